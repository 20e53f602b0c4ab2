//! `minos serve`: a web page to explore scenes and record human demonstrations. An HTTP +
//! WebSocket server (axum on tokio) serves one self-contained page (HTML, CSS and script
//! compiled into the binary; nothing is fetched from elsewhere) and runs sessions: each
//! session is a thread with its own simulator that plays episodes into its own output folder
//! exactly as `minos run` would write them (see [`run_live`](crate::pipeline::rollout::run_live)),
//! the person at the page being the agent.
//!
//! Requests: `GET /` (the page), `GET /api/info` (preset, actions, sensors, scenes,
//! episodes), `POST /api/sessions` (`{"episode": ID}` or `{"scene": ID}` → a session token),
//! `GET /api/sessions/<token>/ws` (the session's WebSocket: JSON commands in; JSON state,
//! camera images and the map out, see [`frames`]). Nothing in a request names a file: scenes
//! and episodes are looked up among those the server loaded, session folders are named by
//! the server. Security: session tokens are 256 random bits from the OS; with an access
//! token every request must carry it (`?access=` or the `x-minos-access` header), compared
//! in constant time; a request whose `Host` is not this server's (DNS rebinding) or that
//! comes from a page of another origin is refused; every response carries a
//! content-security policy and the headers that go with it (`security.rs`); new sessions per
//! access token and messages per session are rate-limited ([`RateLimits`]); a socket that
//! does not connect in time, a page idle too long or one that stops reading ends its session;
//! settings that make no sense and grids baked for another body than the agent's are refused
//! at start-up (`checks.rs`). A server starting on an output folder first finishes the
//! sessions a killed server left there (`recover.rs`).

pub mod campaign;
mod checks;
pub mod frames;
mod http;
pub mod rate;
mod recover;
internal! {
    pub mod replay;
}
mod security;
pub mod session;
internal! {
    pub mod token;
}
mod ws;

use crate::file_error::FileError;
use std::collections::HashMap;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use crate::episode::Episode;
use crate::scene::SceneRef;
use frames::FrameFormat;
use rate::RateLimits;
use session::{Shared, Start};

/// How a server runs, beyond what its sessions share.
#[derive(Debug)]
pub struct ServeConfig {
    /// What sessions share (DATA, episodes, output folder, agent, sensors, …).
    pub shared: Shared,
    /// A token every request must carry (for a server reachable from other machines).
    pub access_token: Option<String>,
    /// Sessions at once, at most (each holds a simulator).
    pub max_sessions: usize,
    /// A created session whose WebSocket does not connect within this is dropped.
    pub connect_timeout: Duration,
    /// A page that does not take a message within this is disconnected.
    pub send_timeout: Duration,
    /// Host names the server answers for besides `localhost` and addresses (lowercase; the
    /// names people reach it by, behind a proxy or on a network).
    pub allowed_hosts: Vec<String>,
    /// Rate limits of new sessions and of messages.
    pub rate: RateLimits,
}

/// Why a server could not start.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The address could not be bound.
    #[error("cannot listen on {addr}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// The cause.
        source: std::io::Error,
    },
    /// A folder could not be created or read.
    #[error(transparent)]
    Io(#[from] FileError),
    /// The tokio runtime could not start.
    #[error("the async runtime")]
    Runtime(#[source] std::io::Error),
    /// A campaign's episode cannot be served (its scene is not in the DATA folder).
    #[error(transparent)]
    Campaign(#[from] UnservableScene),
    /// A setting makes no sense (the message names it and why).
    #[error("{0}")]
    Setting(String),
    /// Scenes to be played cannot be (not baked, or baked for another body than the
    /// agent's); the message lists them.
    #[error("{0}")]
    NotReady(String),
}

/// A session: created by `POST /api/sessions`, started when its WebSocket connects.
#[derive(Debug)]
struct Slot {
    /// The session's name (its output folder).
    name: String,
    /// What it plays; taken when the socket connects (a second socket is refused).
    start: Option<Start>,
    /// When it was created.
    created: Instant,
    /// Seed of its free-exploration episodes.
    seed: u64,
}

/// The server's state.
#[derive(Debug)]
struct App {
    shared: Arc<Shared>,
    access_token: Option<String>,
    max_sessions: usize,
    connect_timeout: Duration,
    send_timeout: Duration,
    /// The address the server listens on.
    addr: SocketAddr,
    /// Host names it answers for besides localhost and addresses.
    allowed_hosts: Vec<String>,
    /// Rate limits.
    rate: RateLimits,
    /// New sessions per access token.
    new_sessions: rate::Keyed,
    /// The page, with its style and script inlined.
    page: String,
    /// The page's content-security policy.
    page_policy: String,
    /// Sessions by token.
    slots: Mutex<HashMap<String, Slot>>,
    /// `shared.data`'s root and `shared.out`, canonical.
    data_root: PathBuf,
    /// The campaign this server runs (`minos serve --campaign`).
    campaign: Option<Arc<campaign::Campaign>>,
    /// Session threads still running (a stopped server waits for them to write their
    /// tables).
    session_threads: std::sync::atomic::AtomicUsize,
    /// Operator replays running.
    replays: std::sync::atomic::AtomicUsize,
}

impl App {
    fn slots(&self) -> std::sync::MutexGuard<'_, HashMap<String, Slot>> {
        self.slots.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Forgets a session (its thread ended).
    fn remove(&self, token: &str) {
        self.slots().remove(token);
    }

    /// Drops the sessions whose socket did not connect in time.
    fn reap(&self) {
        let timeout = self.connect_timeout;
        let mut dropped = Vec::new();
        self.slots().retain(|_, s| {
            let keep = s.start.is_none() || s.created.elapsed() < timeout;
            if !keep {
                dropped.push((s.name.clone(), s.start.take()));
            }
            keep
        });
        // A campaign session that never connected frees its participant's seat.
        for (name, start) in dropped {
            if let Some(Start::Campaign(seat)) = start {
                seat.campaign.close_session(&seat.participant, &name);
            }
        }
    }

    /// Whether the files scene `id` is loaded from lie inside the DATA folder (a symbolic
    /// link out of it is refused).
    fn contained(&self, id: &str) -> Result<(), UnservableScene> {
        let scene = SceneRef::parse(id);
        let data = &self.shared.data;
        for path in [data.scene_path(&scene.scene), data.grid_path(&scene)] {
            let real = match path.canonicalize() {
                Ok(real) => real,
                Err(e) => {
                    return Err(UnservableScene::Missing {
                        scene: id.to_string(),
                        file: FileError::new(path, e),
                    })
                }
            };
            if !real.starts_with(&self.data_root) {
                return Err(UnservableScene::Outside {
                    scene: id.to_string(),
                    path,
                });
            }
        }
        Ok(())
    }
}

/// A scene whose files are missing or lie outside the DATA folder (a symbolic link out of
/// it), so the server refuses to load it.
#[derive(Debug, thiserror::Error)]
pub enum UnservableScene {
    /// A file the scene is loaded from cannot be resolved (it does not exist, or cannot be
    /// read).
    #[error("scene {scene}")]
    Missing {
        /// The scene id.
        scene: String,
        /// The file and what the file system said.
        #[source]
        file: FileError,
    },
    /// A file the scene is loaded from resolves to a place outside the DATA folder.
    #[error("scene {scene}: {} leads outside the DATA folder", path.display())]
    Outside {
        /// The scene id.
        scene: String,
        /// The file, as the DATA folder names it.
        path: PathBuf,
    },
}

/// A running server.
pub struct Running {
    /// The address it listens on.
    pub addr: SocketAddr,
    app: Arc<App>,
    shutdown: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Running {
    /// Sessions created and not ended (connected or waiting for their socket).
    pub fn sessions(&self) -> usize {
        self.app.slots().len()
    }

    /// The episodes and the scenes (for exploration) it offers, after the start-up checks.
    pub fn offered(&self) -> (usize, usize) {
        (self.app.shared.episodes.len(), self.app.shared.scenes.len())
    }

    /// Blocks until the server stops (it runs until the process ends).
    pub fn wait(mut self) {
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }

    /// Stops listening and closes every socket (sessions then end as if their page left),
    /// and returns once every session has written its tables (at most a minute).
    pub fn stop(mut self) {
        self.halt();
    }

    fn halt(&mut self) {
        if let Some(tx) = self.shutdown.take() {
            let _ = tx.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let deadline = std::time::Instant::now() + Duration::from_secs(60);
        while self
            .app
            .session_threads
            .load(std::sync::atomic::Ordering::Acquire)
            > 0
            && std::time::Instant::now() < deadline
        {
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.halt();
    }
}

/// Episodes whose scene is not an ingested scene are dropped (with a warning): a session
/// loads only scenes of the DATA folder's manifest.
fn playable_episodes(episodes: Vec<Episode>, scenes: &[String]) -> Vec<Episode> {
    let (keep, drop): (Vec<Episode>, Vec<Episode>) = episodes
        .into_iter()
        .partition(|e| scenes.contains(&SceneRef::parse(&e.scene_id).scene));
    if let Some(first) = drop.first() {
        tracing::warn!(
            "{} episodes name scenes that are not ingested and cannot be played (first: {} on {})",
            drop.len(),
            first.episode_id,
            first.scene_id
        );
    }
    keep
}

fn canonical(path: &Path) -> Result<PathBuf, ServeError> {
    path.canonicalize()
        .map_err(|source| ServeError::Io(FileError::new(path, source)))
}

/// Binds `bind` and serves `cfg` on a thread of its own until stopped. Refuses settings
/// that make no sense and scenes whose grids do not serve the agent ([`ServeError`]), then
/// finishes the sessions a killed server left in the output folder, before it listens.
pub fn start(cfg: ServeConfig, bind: SocketAddr) -> Result<Running, ServeError> {
    launch(cfg, None, bind)
}

/// Opens the campaign `spec` for a server whose sessions share `shared` (its `out` the
/// campaign's sessions folder): first finishes the sessions a killed server left there (their
/// finished episodes hold only parts), then rebuilds the ledger from the session folders
/// ([`campaign::Campaign::open`]) — in that order, so no finished episode is missed.
pub fn open_campaign(
    spec: campaign::CampaignSpec,
    shared: &Shared,
) -> Result<campaign::Campaign, campaign::CampaignError> {
    recover::finish_sessions(shared);
    campaign::Campaign::open(spec, &shared.episodes)
}

/// Serves `campaign` (opened over `cfg.shared.episodes`, its sessions recorded in
/// `cfg.shared.out`, which must be the campaign's `demos_dir`) as [`start`] serves `cfg`;
/// sessions are created only from participants' links.
pub fn start_campaign(
    cfg: ServeConfig,
    campaign: campaign::Campaign,
    bind: SocketAddr,
) -> Result<Running, ServeError> {
    launch(cfg, Some(Arc::new(campaign)), bind)
}

fn launch(
    cfg: ServeConfig,
    campaign: Option<Arc<campaign::Campaign>>,
    bind: SocketAddr,
) -> Result<Running, ServeError> {
    checks::settings(&cfg)?;
    let ServeConfig {
        mut shared,
        access_token,
        max_sessions,
        connect_timeout,
        send_timeout,
        allowed_hosts,
        rate,
    } = cfg;
    std::fs::create_dir_all(&shared.out)
        .map_err(|source| ServeError::Io(FileError::new(shared.out.clone(), source)))?;
    shared.out = canonical(&shared.out)?;
    let data_root = canonical(shared.data.root())?;
    if campaign.is_none() {
        shared.episodes = playable_episodes(std::mem::take(&mut shared.episodes), &shared.scenes);
    }
    shared.scenes = checks::grids(&shared)?;
    recover::finish_sessions(&shared);
    let listener = std::net::TcpListener::bind(bind)
        .map_err(|source| ServeError::Bind { addr: bind, source })?;
    let addr = listener
        .local_addr()
        .map_err(|source| ServeError::Bind { addr: bind, source })?;
    listener
        .set_nonblocking(true)
        .map_err(|source| ServeError::Bind { addr: bind, source })?;
    let app = Arc::new(App {
        shared: Arc::new(shared),
        access_token,
        max_sessions,
        connect_timeout,
        send_timeout,
        addr,
        allowed_hosts: allowed_hosts
            .iter()
            .map(|h| h.to_ascii_lowercase())
            .collect(),
        rate,
        new_sessions: rate::Keyed::new(
            f64::from(rate.sessions_per_minute) / 60.0,
            f64::from(rate.sessions_per_minute),
        ),
        page: http::page(),
        page_policy: http::page_policy(),
        slots: Mutex::new(HashMap::new()),
        data_root,
        campaign,
        session_threads: std::sync::atomic::AtomicUsize::new(0),
        replays: std::sync::atomic::AtomicUsize::new(0),
    });
    if let Some(c) = &app.campaign {
        // Every scene a participant may be handed lies inside DATA.
        let mut scenes: Vec<&str> = c
            .selection
            .pool
            .iter()
            .chain(&c.selection.tutorial)
            .filter_map(|&i| app.shared.episodes.get(i))
            .map(|e| e.scene_id.as_str())
            .collect();
        scenes.sort();
        scenes.dedup();
        for scene in scenes {
            app.contained(scene)?;
        }
    }
    // The sockets of every session (each step's frames and JSON, every key press) go through
    // these workers while the sessions' own threads render and write: two were enough on two
    // cores, but 100 sessions on 16 cores send ≈ 4,000 messages a second.
    let workers = std::thread::available_parallelism().map_or(2, |n| n.get().clamp(2, 8));
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(workers)
        .thread_name("minos-serve")
        .enable_all()
        .build()
        .map_err(ServeError::Runtime)?;
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let router = http::router(app.clone());
    let reaper = app.clone();
    let thread = std::thread::Builder::new()
        .name("minos-serve".into())
        .spawn(move || {
            runtime.block_on(async move {
                let listener = match tokio::net::TcpListener::from_std(listener) {
                    Ok(l) => l,
                    Err(e) => {
                        tracing::error!("listener: {e}");
                        return;
                    }
                };
                tokio::spawn(async move {
                    let mut tick = tokio::time::interval(Duration::from_millis(250));
                    loop {
                        tick.tick().await;
                        reaper.reap();
                    }
                });
                // Frames are small messages sent back to back: without TCP_NODELAY, Nagle's
                // algorithm holds each one until the last is acknowledged (40 ms delayed ACKs).
                use axum::serve::ListenerExt as _;
                let listener = listener.tap_io(|tcp| {
                    if let Err(e) = tcp.set_nodelay(true) {
                        tracing::debug!("TCP_NODELAY: {e}");
                    }
                });
                let serve = axum::serve(listener, router).with_graceful_shutdown(async {
                    let _ = rx.await;
                });
                if let Err(e) = serve.await {
                    tracing::error!("server: {e}");
                }
            });
            // Dropping the runtime here cancels the open sockets: their sessions end.
        })
        .map_err(ServeError::Runtime)?;
    Ok(Running {
        addr,
        app,
        shutdown: Some(tx),
        thread: Some(thread),
    })
}
