//! One session: a thread of its own that plays episodes with [`run_live`] (its own
//! simulator, its own output folder `OUT/<name>/`), driven by a person through the session's
//! WebSocket. The person is the run's agent (`HumanAgent`): before each step it sends the
//! page the step's state and images and waits for an action; the episode source waits for
//! "next episode". A closed socket or no message for the idle timeout ends the session: the
//! agent gives up, the unfinished episode is left out, and the thread ends, freeing the
//! simulator.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use serde_json::json;

use super::frames::{self, display_rgb, FrameFormat, KIND_MAP};
use crate::body::{AgentPreset, BodyRule};
use crate::episode::goal::{goal_positions, shortest_path};
use crate::episode::instruction::instruction;
use crate::episode::sample::SampleConfig;
use crate::episode::{Episode, Task};
use crate::invalid::Invalid;
use crate::io::image_codec::ImageEncoding;
use crate::io::run_dir::RunDir;
use crate::lock::LockMode;
use crate::pipeline::episodes::sample_scenes;
use crate::pipeline::rollout::{
    run_live, AgentKind, EpisodeFailure, EpisodeSource, Provenance, RunConfig,
};
use crate::progress::NoProgress;
use crate::render::RendererChoice;
use crate::run::agents::{Agent, AgentError, Decision, STOP};
use crate::run::metrics::{reached, EpisodeMetrics, Reward};
use crate::shard::Shard;
use crate::sim::{AgentConfig, Observation, SensorSuite, Simulator};
use crate::store::DataDir;

/// Step limit of a free-exploration episode.
pub const EXPLORE_STEPS: u32 = 2000;

/// What every session of a server shares (read-only).
#[derive(Debug)]
pub struct Shared {
    /// The DATA folder.
    pub data: DataDir,
    /// The episodes sessions play, in file order.
    pub episodes: Vec<Episode>,
    /// The episode file they came from.
    pub episodes_file: Option<PathBuf>,
    /// Ingested scenes (the only scenes a session may load).
    pub scenes: Vec<String>,
    /// The output folder (one folder per session inside).
    pub out: PathBuf,
    /// The agent preset.
    pub preset: AgentPreset,
    /// Body and motion.
    pub agent_config: AgentConfig,
    /// Sensors recorded (and shown).
    pub sensors: SensorSuite,
    /// Renderer.
    pub renderer: RendererChoice,
    /// Reward.
    pub reward: Reward,
    /// Image storage of the observations.
    pub encoding: ImageEncoding,
    /// Seed of sensor noise and of the sessions' free-exploration episodes.
    pub seed: u64,
    /// A session ends after this long without a message from its page.
    pub idle: Duration,
    /// The server's command line (for each session's manifest).
    pub command: Vec<String>,
    /// The variant every episode is played on (its ids already read `<scene>@NAME`, as
    /// `minos run --variant` moves them); explored scenes are loaded on it too.
    pub variant: Option<String>,
    /// How camera images travel to the page.
    pub frames: FrameFormat,
}

impl Shared {
    /// The actions people are offered: exactly the agent's action set (what a policy
    /// trained on the recordings can do, e.g. Habitat's forward and turns), `stop` last.
    pub fn actions(&self) -> Vec<&'static str> {
        let mut names: Vec<&str> = self.agent_config.action_names().to_vec();
        names.push(STOP);
        names
    }

    /// The decision named `name` when it is one of [`Shared::actions`]; otherwise why not.
    pub fn decision(&self, name: &str) -> Result<Decision, Invalid> {
        let offered = self.actions();
        match Decision::from_name(name) {
            Some(d) if offered.contains(&name) => Ok(d),
            known => Err(format!(
                "{} action `{name}`: the {} agent's actions are {}",
                if known.is_some() { "no" } else { "unknown" },
                self.preset.name(),
                offered.join(", ")
            )
            .into()),
        }
    }

    /// Bit mask of the cameras sent with every step: the first colour camera (or the first).
    pub fn default_views(&self) -> u32 {
        let i = self
            .sensors
            .cameras
            .iter()
            .position(|c| c.modality == crate::render::Modality::Color)
            .unwrap_or(0);
        1 << i.min(31)
    }

    /// The bit mask of the cameras named `names` plus the default ones.
    pub fn views_of(&self, names: &[String]) -> u32 {
        self.sensors
            .cameras
            .iter()
            .enumerate()
            .filter(|(i, c)| *i < 32 && names.contains(&c.name))
            .fold(self.default_views(), |m, (i, _)| m | 1 << i)
    }
}

/// What a session starts with.
#[derive(Debug, Clone, PartialEq)]
pub enum Start {
    /// The episode at this index of [`Shared::episodes`].
    Episode(usize),
    /// Free exploration of this scene (a random start and a point goal one may ignore).
    Explore(String),
    /// A campaign participant's session: the campaign hands out the episodes.
    Campaign(super::campaign::Seat),
}

/// A message from the page.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Take this decision (an action or stop).
    Act(Decision),
    /// Play the next episode: this one (by id), or the next in the file (or a new
    /// exploration episode).
    Next(Option<String>),
    /// End the session.
    End,
}

/// A message to the page.
#[derive(Debug, Clone, PartialEq)]
pub enum Update {
    /// JSON.
    Text(String),
    /// A camera image or the map (see [`frames`]).
    Binary(Vec<u8>),
}

/// The session thread's end of its WebSocket.
pub struct Link {
    /// Messages from the page.
    pub commands: Mutex<Receiver<Command>>,
    /// Messages to the page.
    pub updates: tokio::sync::mpsc::Sender<Update>,
    /// Cameras to send with each step (bit i: camera i).
    pub views: Arc<AtomicU32>,
    /// How long to wait for the page.
    pub idle: Duration,
    /// The page said `end`, closed or went idle: every later wait answers at once.
    pub ended: std::sync::atomic::AtomicBool,
}

impl Link {
    /// Sends `update`; false when the page is gone.
    fn send(&self, update: Update) -> bool {
        self.updates.blocking_send(update).is_ok()
    }

    /// Sends a JSON message; false when the page is gone.
    fn text(&self, value: serde_json::Value) -> bool {
        self.send(Update::Text(value.to_string()))
    }

    /// The next message, or `None` when the page closed or said nothing for the idle time;
    /// after `end` (or once the page is gone) `None` at once, so a session whose
    /// page said `end` but keeps its socket open ends now, not after the idle time.
    fn wait(&self) -> Option<Command> {
        if self.ended.load(Ordering::Acquire) {
            return None;
        }
        let rx = self.commands.lock().unwrap_or_else(PoisonError::into_inner);
        // Timeout or disconnected: the page is gone either way.
        let got = rx.recv_timeout(self.idle).ok();
        if matches!(got, None | Some(Command::End)) {
            self.ended.store(true, Ordering::Release);
        }
        got
    }
}

/// The run configuration of session `name` (its folder `shared.out/<name>/`).
pub fn run_config(shared: &Shared, name: &str) -> RunConfig {
    RunConfig {
        batch: Some(1),
        data: shared.data.clone(),
        out: shared.out.join(name),
        // Not used by a live run: the agent is the person.
        agent: AgentKind::Replay(Default::default()),
        agent_config: shared.agent_config,
        sensors: shared.sensors.clone(),
        renderer: shared.renderer,
        max_steps: None,
        seed: shared.seed,
        shard: Shard::ALL,
        resume: false,
        reward: shared.reward,
        encoding: shared.encoding,
        lerobot: false,
        lerobot_video: None,
        rerun: None,
        allow_body_mismatch: false,
        provenance: Provenance {
            command: shared.command.clone(),
            episodes_file: Some(cfg_episodes_file(shared, name)),
            variant: shared.variant.clone(),
            agent: format!("human:{name}"),
            preset: Some(shared.preset),
        },
    }
}

/// Runs session `name` until its page leaves; writes into `shared.out/<name>/`. Tells the
/// page how it ended.
pub fn run_session(
    shared: Arc<Shared>,
    name: &str,
    start: Start,
    link: Arc<Link>,
    session_seed: u64,
) {
    let cfg = run_config(&shared, name);
    let clock = Arc::new(Mutex::new(Clock::default()));
    let seat = match &start {
        Start::Campaign(seat) => Some(seat.clone()),
        _ => None,
    };
    let mut source = Source {
        shared: shared.clone(),
        link: link.clone(),
        seat,
        name: name.to_string(),
        clock: clock.clone(),
        start: Some(start),
        cursor: 0,
        scene: None,
        explored: 0,
        session_seed,
        played: 0,
    };
    let agent = Box::new(HumanAgent {
        link: link.clone(),
        episode: None,
        map: None,
        clock,
        frames: shared.frames,
    });
    let end = match run_live(&cfg, &mut source, agent, LockMode::Fail) {
        Ok(report) => json!({"type": "end", "episodes": report.episodes.len(), "session": name}),
        Err(e) => {
            tracing::error!("session {name}: {}", crate::escape::error_line(&e));
            json!({"type": "error", "message": crate::escape::error_line(&e), "fatal": true})
        }
    };
    link.text(end);
}

/// The episode file a session's replay reads: its own `played.parquet`.
fn cfg_episodes_file(shared: &Shared, name: &str) -> PathBuf {
    RunDir::new(shared.out.join(name)).played()
}

/// The wall-clock times of an episode's actions (for its quality record; never in the
/// tables, which a replay must reproduce).
#[derive(Debug, Default)]
struct Clock {
    /// When the episode was shown.
    shown: Option<std::time::Instant>,
    /// Seconds since then of each action taken.
    actions: Vec<f32>,
}

/// What the page is told of `episode` as it starts on `sim` (the `episode` message: task,
/// instruction, start, goals, shortest path, the map's placement) and the map of the start's
/// level.
pub fn episode_intro(
    episode: &Episode,
    sim: &Simulator,
) -> Result<(serde_json::Value, frames::Map), image::ImageError> {
    let grid = &sim.assets().grid;
    let start = glam::Vec3::from_array(episode.start_position);
    let level = grid
        .snap(start)
        .map(|s| grid.spans[s as usize].level)
        .unwrap_or(0);
    let map = frames::map(grid, level)?;
    let path: Vec<[f32; 3]> = shortest_path(grid, episode)
        .unwrap_or_default()
        .iter()
        .map(|p| p.to_array())
        .collect();
    let agent = sim.agent();
    let intro = json!({
        "type": "episode",
        "episode_id": episode.episode_id,
        "scene_id": episode.scene_id,
        "task": episode.task.name(),
        "instruction": instruction(episode),
        "max_steps": episode.max_steps,
        "success_radius": episode.success_radius,
        "geodesic_distance": episode.geodesic_distance,
        "start": episode.start_position,
        "start_yaw": episode.start_yaw,
        "goals": goal_positions(episode),
        "path": path,
        "dt": agent.dt,
        "radius": agent.body.radius,
        "map": {"size": map.size, "origin": map.origin, "pixels_per_metre": map.pixels_per_metre, "level": map.level},
    });
    Ok((intro, map))
}

/// A camera's image could not be encoded for the page.
#[derive(Debug, thiserror::Error)]
#[error("camera {camera}")]
pub struct CameraMessageError {
    /// The camera.
    pub camera: String,
    /// Why.
    #[source]
    pub source: image::ImageError,
}

/// The camera messages of `obs` (taken on `sim`) for the cameras in the bit mask `views`,
/// compressed as `format` says for each camera's modality.
pub fn camera_messages(
    obs: &Observation,
    sim: &Simulator,
    views: u32,
    format: FrameFormat,
) -> Result<Vec<Vec<u8>>, CameraMessageError> {
    let cameras = &sim.sensor_suite().cameras;
    let mut out = Vec::new();
    for (i, ((_, image), cam)) in obs.images.iter().zip(cameras).enumerate() {
        if i >= 32 || views & (1 << i) == 0 {
            continue;
        }
        let Some(rgb) = display_rgb(cam.modality, image, cam.depth_range) else {
            continue;
        };
        let [w, h] = cam.resolution;
        let msg = frames::camera_message(format.for_modality(cam.modality), i as u8, w, h, &rgb)
            .map_err(|source| CameraMessageError {
                camera: cam.name.clone(),
                source,
            })?;
        out.push(msg);
    }
    Ok(out)
}

/// The person at the page, as the run's agent.
struct HumanAgent {
    link: Arc<Link>,
    episode: Option<Episode>,
    /// The map last sent: scene, level.
    map: Option<(String, u16)>,
    /// Action times of the current episode.
    clock: Arc<Mutex<Clock>>,
    /// How camera images are sent.
    frames: FrameFormat,
}

fn gone() -> AgentError {
    AgentError::Human {
        what: "the page left or was idle too long".into(),
        source: None,
    }
}

impl Agent for HumanAgent {
    fn reset(&mut self, episode: &Episode, sim: &Simulator) -> Result<(), AgentError> {
        let (intro, map) = episode_intro(episode, sim).map_err(|e| AgentError::Human {
            what: format!("map of {}", episode.scene_id),
            source: Some(Box::new(e)),
        })?;
        let level = map.level;
        let ok = self.link.text(intro);
        let key = (episode.scene_id.clone(), level);
        let sent = if self.map.as_ref() == Some(&key) {
            true
        } else {
            self.link.send(Update::Binary(frames::message(
                KIND_MAP,
                0,
                map.size[0],
                map.size[1],
                &map.png,
            )))
        };
        if !(ok && sent) {
            return Err(gone());
        }
        self.map = Some(key);
        self.episode = Some(episode.clone());
        *self.clock.lock().unwrap_or_else(PoisonError::into_inner) = Clock {
            shown: Some(std::time::Instant::now()),
            actions: Vec::new(),
        };
        Ok(())
    }

    /// The step's state and images go to the page (the run then writes the observation
    /// while the person decides).
    fn present(&mut self, obs: &Observation, sim: &Simulator) -> Result<(), AgentError> {
        let episode = self.episode.as_ref().ok_or(AgentError::NotReset("human"))?;
        let state = sim.state();
        let m = &obs.measurements;
        let step = json!({
            "type": "step",
            "step": m.step,
            "time": m.step as f32 * sim.agent().dt,
            "position": state.position,
            "yaw": state.yaw,
            "tilt": state.tilt,
            "euclidean": m.goal_euclidean,
            "geodesic": m.goal_geodesic,
            "collision": m.collision,
            "at_goal": reached(sim, episode, &state),
        });
        if !self.link.text(step) {
            return Err(gone());
        }
        let views = self.link.views.load(Ordering::Relaxed);
        let messages =
            camera_messages(obs, sim, views, self.frames).map_err(|e| AgentError::Human {
                what: "camera images".into(),
                source: Some(Box::new(e)),
            })?;
        for msg in messages {
            if !self.link.send(Update::Binary(msg)) {
                return Err(gone());
            }
        }
        Ok(())
    }

    /// Waits for the person's action.
    fn decide(&mut self, _obs: &Observation, _sim: &Simulator) -> Result<Decision, AgentError> {
        loop {
            match self.link.wait() {
                Some(Command::Act(d)) => {
                    let mut clock = self.clock.lock().unwrap_or_else(PoisonError::into_inner);
                    let t = clock.shown.map_or(0.0, |s| s.elapsed().as_secs_f32());
                    clock.actions.push(t);
                    return Ok(d);
                }
                // "Next" only means something between episodes.
                Some(Command::Next(_)) => continue,
                Some(Command::End) | None => return Err(gone()),
            }
        }
    }

    fn stops(&self) -> bool {
        // As for the oracle and replays: success needs an explicit stop at the goal.
        true
    }
    fn waits_elsewhere(&self) -> bool {
        // On the person: a row group's compression must not delay their next frame.
        true
    }
}

/// The episodes of a session: the one it started with, then what the page asks for.
struct Source {
    shared: Arc<Shared>,
    link: Arc<Link>,
    /// The campaign seat of a participant's session.
    seat: Option<super::campaign::Seat>,
    /// The session's name (its folder).
    name: String,
    /// Action times of the current episode.
    clock: Arc<Mutex<Clock>>,
    start: Option<Start>,
    /// Index in the episode file after the last episode handed out.
    cursor: usize,
    /// Scene of free exploration.
    scene: Option<String>,
    /// Exploration episodes drawn.
    explored: u32,
    session_seed: u64,
    /// Episodes finished.
    played: usize,
}

impl Source {
    fn episode_at(&mut self, i: usize) -> Episode {
        self.cursor = i + 1;
        self.shared.episodes[i].clone()
    }

    /// A new free-exploration episode of `scene`: a PointGoal episode drawn with the
    /// session's seed, its id `<scene>:explore:<n>`.
    fn explore(&mut self, scene: &str) -> Result<Episode, Invalid> {
        let n = self.explored;
        self.explored += 1;
        let seed = crate::seed::derive_seed(self.session_seed, &[scene, &n.to_string(), "explore"]);
        let scene = &match &self.shared.variant {
            Some(v) => crate::scene::SceneRef::base(scene)
                .with_variant(Some(v))
                .to_string(),
            None => scene.to_string(),
        };
        let batch = sample_scenes(
            &self.shared.data,
            &[(scene.to_string(), String::new())],
            &SampleConfig {
                task: Task::PointGoal,
                per_scene: 1,
                seed,
                max_steps: EXPLORE_STEPS,
                ..Default::default()
            },
            BodyRule::strict(self.shared.agent_config.body),
            Shard::ALL,
            &NoProgress,
        );
        let mut ep = batch
            .episodes
            .into_iter()
            .next()
            .ok_or_else(|| format!("scene {scene}: no start could be drawn (is it baked?)"))?;
        ep.episode_id = format!("{scene}:explore:{n:05}");
        Ok(ep)
    }

    /// The campaign's next episode for this participant, or `None` (after telling the page)
    /// when nothing is left.
    fn campaign_next(&mut self) -> Option<Episode> {
        let seat = self.seat.as_ref()?;
        match seat.campaign.assign(&seat.participant) {
            Some(i) => Some(self.episode_at(i)),
            None => {
                self.link
                    .text(json!({"type": "campaign_done", "played": self.played}));
                None
            }
        }
    }

    fn error(&self, message: &str) {
        self.link
            .text(json!({"type": "error", "message": message, "fatal": false}));
    }
}

impl EpisodeSource for Source {
    fn next(&mut self) -> Option<Episode> {
        if let Some(start) = self.start.take() {
            match start {
                Start::Episode(i) => return Some(self.episode_at(i)),
                Start::Explore(scene) => {
                    self.scene = Some(scene.clone());
                    match self.explore(&scene) {
                        Ok(e) => return Some(e),
                        Err(m) => self.error(&m.to_string()),
                    }
                }
                Start::Campaign(_) => return self.campaign_next(),
            }
        }
        loop {
            match self.link.wait()? {
                Command::Act(_) => continue,
                Command::End => return None,
                Command::Next(_) if self.seat.is_some() => return self.campaign_next(),
                Command::Next(Some(id)) => {
                    match self.shared.episodes.iter().position(|e| e.episode_id == id) {
                        Some(i) => return Some(self.episode_at(i)),
                        None => self.error(&format!("no episode `{id}` in the episode file")),
                    }
                }
                Command::Next(None) => {
                    if let Some(scene) = self.scene.clone() {
                        match self.explore(&scene) {
                            Ok(e) => return Some(e),
                            Err(m) => self.error(&m.to_string()),
                        }
                    } else if self.cursor < self.shared.episodes.len() {
                        return Some(self.episode_at(self.cursor));
                    } else {
                        self.error("that was the last episode of the file");
                    }
                }
            }
        }
    }

    fn finished(&mut self, episode: &Episode, outcome: Result<&EpisodeMetrics, &EpisodeFailure>) {
        let msg = match outcome {
            Ok(m) => {
                self.played += 1;
                let mut more = self.scene.is_some() || self.cursor < self.shared.episodes.len();
                let mut qc = serde_json::Value::Null;
                if let Some(seat) = &self.seat {
                    let times = std::mem::take(
                        &mut self
                            .clock
                            .lock()
                            .unwrap_or_else(PoisonError::into_inner)
                            .actions,
                    );
                    match seat
                        .campaign
                        .finished(&seat.participant, &self.name, episode, m, &times)
                    {
                        Ok(entry) => qc = json!(entry.verdict),
                        Err(e) => tracing::error!(
                            "session {}: {}",
                            self.name,
                            crate::escape::error_line(&e)
                        ),
                    }
                    more = seat.campaign.more_for(&seat.participant);
                }
                json!({"type": "done", "episode_id": episode.episode_id, "metrics": m,
                       "played": self.played, "more": more, "qc": qc})
            }
            Err(problem) => {
                if let Some(seat) = &self.seat {
                    seat.campaign.release(&seat.participant);
                }
                json!({"type": "error", "episode_id": episode.episode_id, "message": crate::escape::error_line(problem), "fatal": false})
            }
        };
        self.link.text(msg);
    }
}

impl Drop for Source {
    /// A campaign session's unfinished episode goes back to the campaign's pool.
    fn drop(&mut self) {
        if let Some(seat) = &self.seat {
            seat.campaign.close_session(&seat.participant, &self.name);
        }
    }
}
