//! The simulator: a scene, its navigation grid, an agent with a body and sensors, and a
//! renderer. `reset` places the agent (and its goal), `step` applies actions with collisions
//! and returns an [`Observation`]: the sensors' images and the measurements.

use std::sync::Arc;

use glam::Vec3;

use crate::body::BodyMismatch;
use crate::navmesh::geodesic::{DistanceField, Geodesic};
use crate::navmesh::path::{path_from_field, PathResult};
use crate::navmesh::NavGrid;
use crate::render::cpu::Method;
use crate::render::gpu::GpuError;
use crate::render::Renderer;
use crate::render::{Camera, Channels, Frame, RenderScene};
use crate::scene::Scene;
use crate::seed::{derive_seed, Rng};

use super::agent::{intended_motion, Actions, AgentConfig, AgentState};
use super::collision::CollisionWorld;
use super::sensors::SensorSuite;
use crate::render::Image;

/// Errors building a simulator.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The scene has nothing to collide with, or parry3d refused its mesh.
    #[error(transparent)]
    Collision(#[from] crate::sim::collision::CollisionError),
    /// The renderer could not be created.
    #[error(transparent)]
    Render(#[from] GpuError),
    /// The navigation grid was baked for another body than the agent's.
    #[error(transparent)]
    Body(#[from] BodyMismatch),
}

/// Everything that does not change between simulators of one scene (share it with `Arc`).
pub struct SceneAssets {
    /// Scene id.
    pub id: String,
    /// Renderable triangles.
    pub render: RenderScene,
    /// Collision mesh.
    pub collision: CollisionWorld,
    /// Navigation grid.
    pub grid: NavGrid,
}

impl SceneAssets {
    /// Prepares a scene for agents of `agent`'s body, on `grid`, which must have been baked
    /// for that body ([`SimError::Body`] otherwise).
    pub fn new(scene: &Scene, grid: NavGrid, agent: &AgentConfig) -> Result<Self, SimError> {
        agent.body.check_grid(&grid.params.body)?;
        Self::new_allowing_body_mismatch(scene, grid, agent)
    }

    /// [`SceneAssets::new`] without the body check, for a grid knowingly baked for another
    /// body (`--allow-body-mismatch`): geodesics and goal measurements then describe the
    /// grid's body, collisions the agent's.
    pub fn new_allowing_body_mismatch(
        scene: &Scene,
        grid: NavGrid,
        agent: &AgentConfig,
    ) -> Result<Self, SimError> {
        // Independent structures of the same scene: built side by side.
        let (render, collision) = rayon::join(
            || RenderScene::new(scene),
            || {
                CollisionWorld::new(
                    scene,
                    agent.body.radius,
                    agent.body.height,
                    agent.body.max_climb,
                )
            },
        );
        Ok(SceneAssets {
            id: scene.id.clone(),
            render,
            collision: collision?,
            grid,
        })
    }
}

/// What the agent is asked to reach, for goal measurements.
#[derive(Debug, Clone, PartialEq)]
pub enum GoalSpec {
    /// A point.
    Point(Vec3),
    /// Any of these walkable spans (an object's view points, a room's floor).
    Spans(Vec<u32>),
}

/// Measurements of one step.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Measurements {
    /// Step index (0 after reset).
    pub step: u32,
    /// Base position.
    pub position: [f32; 3],
    /// Yaw (rad).
    pub yaw: f32,
    /// Tilt (rad).
    pub tilt: f32,
    /// Horizontal velocity (x, z) in m/s.
    pub velocity: [f32; 2],
    /// `step / max_steps`.
    pub time_fraction: f32,
    /// The body hit something during the step.
    pub collision: bool,
    /// Contact per contact sensor.
    pub contacts: Vec<bool>,
    /// Impulse per contact sensor (N·s).
    pub contact_impulses: Vec<f32>,
    /// Straight-line distance to the goal (m): to a point goal's point; for object and room
    /// goals to the goal span the shortest path ends at (the one `goal_geodesic` measures
    /// to), or the first goal span when none is reachable.
    pub goal_euclidean: Option<f32>,
    /// Unit direction to that goal target in the agent frame `[right, forward]`.
    pub goal_direction: Option<[f32; 2]>,
    /// Shortest-path distance to the goal (m), from the agent's position to the same target
    /// as `goal_euclidean` (so never below it); `None` when unreachable or no goal.
    pub goal_geodesic: Option<f32>,
    /// Unit direction to the next waypoint of the shortest path, agent frame `[right, forward]`.
    pub waypoint_direction: Option<[f32; 2]>,
}

/// The outcome of one step's motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transition {
    /// The state after the step.
    pub state: AgentState,
    /// The body hit something.
    pub collided: bool,
    /// Velocity the actions asked for (x, z), before collisions.
    pub intended_velocity: [f32; 2],
}

/// Sensor images and measurements.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// `(sensor name, image)` in the suite's order.
    pub images: Vec<(String, Image)>,
    /// Measurements.
    pub measurements: Measurements,
}

impl Observation {
    /// An observation with no images and default measurements: what agents that ignore what
    /// they see (the oracle) are given, and a stepper's observation before its first episode.
    pub fn blind() -> Observation {
        Observation {
            images: Vec::new(),
            measurements: Measurements::default(),
        }
    }
}

struct GoalState {
    /// A point goal's point; for span goals the first span's position.
    point: Vec3,
    /// The goal is a point (not walkable spans).
    is_point: bool,
    field: DistanceField,
    /// The last measured span and its path's points (turning in place measures the same
    /// span again).
    last: Option<(u32, Option<Vec<Vec3>>)>,
}

/// Builds what `renderer` needs to render `sensors` in `assets`' scene ahead of the first
/// observation: a scene the CPU renderer will ray cast gets its BVH now (seconds for
/// millions of triangles), so set-up pays for it and the first observation does not.
/// [`Simulator::new`] calls it.
///
/// The BVH is built once, on first use, with rayon work inside; a thread that needs it
/// while another builds it waits. Call this once per scene *before* making simulators of
/// the scene on several threads of one rayon pool: otherwise every other pool thread can end
/// up waiting on the build while the builder, waiting on its own stolen work, runs one of
/// their pending tasks that needs the same BVH — a deadlock (`VectorNavEnv(num_envs=N,
/// threads=N)` for N ≥ 8 hung so).
pub fn prepare_render(assets: &SceneAssets, renderer: &Renderer, sensors: &SensorSuite) {
    let ray_cast = |c: &crate::sim::CameraSensor| {
        let [w, h] = c.resolution;
        Method::for_size(assets.render.triangle_count(), w, h) == Method::RayCast
    };
    if matches!(renderer, Renderer::Cpu) && sensors.cameras.iter().any(ray_cast) {
        let _ = assets.render.bvh();
    }
}

/// One agent in one scene.
pub struct Simulator {
    assets: Arc<SceneAssets>,
    renderer: Arc<Renderer>,
    agent: AgentConfig,
    sensors: SensorSuite,
    max_steps: u32,
    seed: u64,
    rng: Rng,
    state: AgentState,
    step: u32,
    goal: Option<GoalState>,
    last_collision: bool,
    last_velocity: [f32; 2],
}

/// Length (m) of sub-steps, as a fraction of the body radius: small enough never to tunnel.
const SUBSTEP: f32 = 0.5;

impl Simulator {
    /// A simulator on shared scene assets and renderer.
    pub fn new(
        assets: Arc<SceneAssets>,
        renderer: Arc<Renderer>,
        agent: AgentConfig,
        sensors: SensorSuite,
        max_steps: u32,
        seed: u64,
    ) -> Self {
        prepare_render(&assets, &renderer, &sensors);
        Simulator {
            assets,
            renderer,
            agent,
            sensors,
            max_steps: max_steps.max(1),
            seed,
            rng: Rng::new(seed),
            state: AgentState::default(),
            step: 0,
            goal: None,
            last_collision: false,
            last_velocity: [0.0; 2],
        }
    }

    /// A fresh simulator on the same shared assets, renderer, body, sensors, step limit and
    /// seed (e.g. one per thread running a scene's episodes): episodes it runs give what
    /// they give on this one, since every episode is seeded from its own id.
    pub fn sibling(&self) -> Simulator {
        Simulator::new(
            self.assets.clone(),
            self.renderer.clone(),
            self.agent,
            self.sensors.clone(),
            self.max_steps,
            self.seed,
        )
    }

    /// The renderer the simulator observes with (shared with its siblings).
    pub fn renderer(&self) -> &Arc<Renderer> {
        &self.renderer
    }

    /// The agent's state.
    pub fn state(&self) -> AgentState {
        self.state
    }

    /// Sets the tilt (clamped to ±90°), e.g. to render a pose.
    pub fn set_tilt(&mut self, tilt: f32) {
        self.state.tilt = tilt.clamp(-std::f32::consts::FRAC_PI_2, std::f32::consts::FRAC_PI_2);
    }

    /// The scene assets.
    pub fn assets(&self) -> &SceneAssets {
        &self.assets
    }

    /// Places the agent at `start` (y = floor height) facing `yaw`, with an optional goal;
    /// the noise generator restarts from `(seed, episode)`.
    pub fn reset(&mut self, start: Vec3, yaw: f32, goal: Option<GoalSpec>, episode: &str) {
        self.reset_in(start, yaw, goal, episode, None);
    }

    /// [`Simulator::reset`] computing the goal's distance field with `geo`, precomputed
    /// geodesic data of this simulator's grid (ignored when it belongs to another grid):
    /// callers running many episodes in one scene save rebuilding it per episode.
    pub fn reset_in(
        &mut self,
        start: Vec3,
        yaw: f32,
        goal: Option<GoalSpec>,
        episode: &str,
        geo: Option<&Geodesic<'_>>,
    ) {
        self.state = AgentState {
            position: start.to_array(),
            yaw,
            ..Default::default()
        };
        self.step = 0;
        self.last_collision = false;
        self.last_velocity = [0.0; 2];
        self.rng = Rng::new(derive_seed(
            self.seed,
            &[&self.assets.id, episode, "sensors"],
        ));
        let grid = &self.assets.grid;
        self.goal = goal.map(|g| {
            let is_point = matches!(g, GoalSpec::Point(_));
            let (point, spans) = match g {
                GoalSpec::Point(p) => (p, grid.snap(p).into_iter().collect::<Vec<_>>()),
                GoalSpec::Spans(s) => {
                    let p = s.first().map_or(start, |&s| grid.span_position(s as usize));
                    (p, s)
                }
            };
            let field = match geo.filter(|g| std::ptr::eq(g.grid(), grid)) {
                Some(g) => g.field(&spans),
                None => Geodesic::new(grid).field(&spans),
            };
            GoalState {
                point,
                is_point,
                field,
                last: None,
            }
        });
    }

    /// Resets to an episode's start, with its goal for the measurements (object goals: the
    /// walkable spans within the success radius of each target; room goals: the rooms' floor).
    pub fn reset_episode(&mut self, episode: &crate::episode::Episode) {
        self.reset_episode_in(episode, None);
    }

    /// [`Simulator::reset_episode`] with precomputed geodesic data of this simulator's grid
    /// (see [`Simulator::reset_in`]).
    pub fn reset_episode_in(
        &mut self,
        episode: &crate::episode::Episode,
        geo: Option<&Geodesic<'_>>,
    ) {
        use crate::episode::Goal;
        let goal = match &episode.goal {
            Goal::Point { position } => GoalSpec::Point(Vec3::from_array(*position)),
            Goal::Object { .. } | Goal::Room { .. } => {
                GoalSpec::Spans(crate::episode::goal::goal_spans(&self.assets.grid, episode))
            }
        };
        let start = Vec3::from_array(episode.start_position);
        let id = episode.episode_id.clone();
        self.reset_in(start, episode.start_yaw, Some(goal), &id, geo);
    }

    /// Floor height at `p` reachable from height `y` (within the climb), from the grid.
    fn floor_at(&self, x: f32, z: f32, y: f32) -> Option<f32> {
        let grid = &self.assets.grid;
        let (ix, iz) = grid.cell_of(x, z);
        let c = grid.column(ix, iz)?;
        grid.column_spans(c)
            .map(|s| grid.spans[s].y)
            .filter(|h| (h - y).abs() <= self.agent.body.max_climb + 1e-4)
            .min_by(|a, b| (a - y).abs().total_cmp(&(b - y).abs()))
    }

    /// Tries to move the base by `d` (x, z); returns the new base or `None` when blocked.
    fn try_move(&self, base: Vec3, d: Vec3) -> Option<Vec3> {
        let target = base + d;
        let y = self.floor_at(target.x, target.z, base.y)?;
        let target = Vec3::new(target.x, y, target.z);
        (!self.assets.collision.blocked(target)).then_some(target)
    }

    /// Applies `actions` for one time step and observes.
    pub fn step(&mut self, actions: Actions) -> Result<Observation, GpuError> {
        self.advance(actions);
        self.observe()
    }

    /// Applies `actions` for one time step without observing ([`Simulator::step`] is this,
    /// then [`Simulator::observe`]; [`super::batch::step_many`] observes many at once).
    pub fn advance(&mut self, actions: Actions) {
        let t = self.transition(&self.state, actions);
        self.state = t.state;
        self.last_velocity = t.intended_velocity;
        self.last_collision = t.collided;
        self.step += 1;
    }

    /// What `actions` would do from `state`, without changing the simulator (planners use it).
    pub fn transition(&self, state: &AgentState, actions: Actions) -> Transition {
        let mut state = *state;
        let (disp, rot) = intended_motion(&self.agent, &mut state, actions);
        state.yaw = (state.yaw + rot).rem_euclid(std::f32::consts::TAU);
        let mut base = Vec3::from_array(state.position);
        let total = Vec3::new(disp[0], 0.0, disp[1]);
        let n = (total.length() / (SUBSTEP * self.agent.body.radius))
            .ceil()
            .max(1.0) as usize;
        let mut step = total / n as f32;
        let mut collided = false;
        let start = base;
        for _ in 0..n {
            if step.length_squared() == 0.0 {
                break;
            }
            if let Some(next) = self.try_move(base, step) {
                base = next;
                continue;
            }
            collided = true;
            // Slide: drop the part of the motion going into what was hit, first as it is met
            // on the way (around a corner's edge), else as it overlaps at the end of the move.
            // (The overlap's normal is asked for only when the first slide is blocked.)
            let collision = &self.assets.collision;
            let slide_along = |n: Option<Vec3>| {
                let s = n.map(|n| step - n * step.dot(n).min(0.0))?;
                (s.length_squared() > 1e-12).then_some(())?;
                self.try_move(base, s).map(|b| (b, s))
            };
            let slid = slide_along(collision.impact_normal(base, step))
                .or_else(|| slide_along(collision.push_out(base + step)));
            match slid {
                Some((b, s)) => {
                    base = b;
                    step = s;
                }
                None => break,
            }
        }
        let moved = base - start;
        let dt = self.agent.dt;
        if collided {
            state.velocity = [moved.x / dt, moved.z / dt];
        }
        state.position = base.to_array();
        Transition {
            state,
            collided,
            intended_velocity: [total.x / dt, total.z / dt],
        }
    }

    /// The sensor suite.
    pub fn sensor_suite(&self) -> &SensorSuite {
        &self.sensors
    }

    /// The agent's body and motion model.
    pub fn agent(&self) -> &AgentConfig {
        &self.agent
    }

    /// Steps taken since the last reset.
    pub fn steps(&self) -> u32 {
        self.step
    }

    /// The goal field's anchor of a span (the next corner of its shortest path), if any.
    pub fn goal_anchor(&self, span: u32) -> Option<u32> {
        self.goal.as_ref()?.field.anchor(span)
    }

    /// Geodesic distance (m) from a base position to the goal, from the goal's distance field
    /// (the field's value at the nearest span plus the way to it); `None` without a goal or
    /// when unreachable.
    pub fn goal_field_distance(&self, p: Vec3) -> Option<f32> {
        let goal = self.goal.as_ref()?;
        let grid = &self.assets.grid;
        let s = grid.snap(p)?;
        let d = goal.field.distance(s)?;
        Some(d + grid.span_position(s as usize).distance(p))
    }

    /// The cameras of the sensor suite at the current pose.
    pub fn cameras(&self) -> Vec<Camera> {
        let base = Vec3::from_array(self.state.position);
        let (sin, cos) = self.state.yaw.sin_cos();
        self.sensors
            .cameras
            .iter()
            .map(|c| {
                let off = c.position.unwrap_or([0.0, self.agent.eye_height, 0.0]);
                // Agent frame (x right, y up, z back) to world.
                let world = Vec3::new(
                    cos * off[0] + sin * off[2],
                    off[1],
                    -sin * off[0] + cos * off[2],
                );
                Camera {
                    position: base + world,
                    yaw: self.state.yaw + c.orientation[0].to_radians(),
                    tilt: (self.state.tilt + c.orientation[1].to_radians())
                        .clamp(-std::f32::consts::FRAC_PI_2, std::f32::consts::FRAC_PI_2),
                    vfov_deg: c.vfov,
                    width: c.resolution[0],
                    height: c.resolution[1],
                    near: c.near,
                    far: c.far,
                }
            })
            .collect()
    }

    /// Agent-frame `[right, forward]` of a world direction (x, z), normalised.
    fn agent_frame(&self, d: Vec3) -> Option<[f32; 2]> {
        let (sin, cos) = self.state.yaw.sin_cos();
        let v = glam::Vec2::new(d.x * cos - d.z * sin, -d.x * sin - d.z * cos);
        v.try_normalize().map(|v| v.to_array())
    }

    /// Observes the current state (sensors and measurements) without stepping.
    pub fn observe(&mut self) -> Result<Observation, GpuError> {
        let views = self.views();
        let frames =
            self.renderer
                .render_with(&self.assets.render, &views.unique, self.image_channels())?;
        Ok(self.observation_from(&views, &frames))
    }

    /// The images the simulator's camera sensors read from their frames (what a GPU
    /// renderer is asked to derive).
    pub(crate) fn image_channels(&self) -> Channels {
        self.sensors.cameras.iter().fold(Channels::NONE, |c, s| {
            c.union(Channels::for_modality(s.modality, s.taxonomy))
        })
    }

    /// The cameras to render for an observation. Sensors that share a camera (colour,
    /// depth and labels of one eye) share one frame: every modality comes from one pass.
    pub(crate) fn views(&self) -> Views {
        let cams = self.cameras();
        let mut unique: Vec<Camera> = Vec::new();
        let which: Vec<usize> = cams
            .iter()
            .map(|c| match unique.iter().position(|u| u == c) {
                Some(i) => i,
                None => {
                    unique.push(*c);
                    unique.len() - 1
                }
            })
            .collect();
        Views {
            cams,
            unique,
            which,
        }
    }

    /// The observation of the current state from the frames of `views.unique`.
    pub(super) fn observation_from(&mut self, views: &Views, frames: &[Frame]) -> Observation {
        let Views { cams, which, .. } = views;
        let mut images = Vec::with_capacity(cams.len());
        for ((sensor, &k), cam) in self.sensors.cameras.iter().zip(which).zip(cams) {
            images.push((
                sensor.name.clone(),
                sensor.image(&frames[k], &self.assets.render, cam, &mut self.rng),
            ));
        }
        let base = Vec3::from_array(self.state.position);
        let mut m = Measurements {
            step: self.step,
            position: self.state.position,
            yaw: self.state.yaw,
            tilt: self.state.tilt,
            velocity: self.state.velocity,
            time_fraction: self.step as f32 / self.max_steps as f32,
            collision: self.last_collision,
            ..Default::default()
        };
        if let Some(contact) = self.sensors.contact {
            for k in 0..contact.count {
                let a = self.state.yaw + k as f32 * std::f32::consts::TAU / contact.count as f32;
                let dir = Vec3::new(-a.sin(), 0.0, -a.cos());
                let probe = 0.03;
                let center =
                    base + Vec3::Y * contact.height + dir * (self.agent.body.radius + probe);
                let hit = self.assets.collision.probe(center, probe);
                let v = Vec3::new(self.last_velocity[0], 0.0, self.last_velocity[1]);
                m.contacts.push(hit);
                m.contact_impulses.push(if hit {
                    self.agent.mass * v.dot(dir).max(0.0)
                } else {
                    0.0
                });
            }
        }
        let snapped = self.assets.grid.snap(base);
        if let (Some(goal), Some(span)) = (self.goal.as_mut(), snapped) {
            if goal.last.as_ref().is_none_or(|(s, _)| *s != span) {
                let points = match path_from_field(&self.assets.grid, &goal.field, span) {
                    PathResult::Found(p) => Some(p.points),
                    PathResult::Unreachable => None,
                };
                goal.last = Some((span, points));
            }
        }
        if let Some(goal) = &self.goal {
            // Both distances measure to one target: a point goal's point, or the goal span
            // the shortest path ends at (the nearest by path; the first span when none is
            // reachable). The path runs from the agent's own position to that target, so the
            // geodesic is never below the straight line.
            let mut target = goal.point;
            if let Some((_, Some(points))) = goal.last.as_ref().filter(|(s, _)| Some(*s) == snapped)
            {
                let mut pts = points.clone();
                if let Some(first) = pts.first_mut() {
                    *first = base;
                }
                if goal.is_point {
                    // The path ends at the goal's cell: finish it at the goal itself.
                    if pts.len() > 1 {
                        pts.pop();
                    }
                    pts.push(goal.point);
                } else if let Some(&end) = pts.last() {
                    target = end;
                }
                m.goal_geodesic = Some(pts.windows(2).map(|w| w[0].distance(w[1])).sum());
                m.waypoint_direction = pts.get(1).and_then(|&w| self.agent_frame(w - base));
            }
            m.goal_euclidean = Some(base.distance(target));
            m.goal_direction = self.agent_frame(target - base);
        }
        Observation {
            images,
            measurements: m,
        }
    }
}

/// The cameras of one observation: every sensor's camera, the distinct ones to render, and
/// which distinct camera each sensor uses.
pub(crate) struct Views {
    cams: Vec<Camera>,
    /// The distinct cameras, rendered once each.
    pub(crate) unique: Vec<Camera>,
    which: Vec<usize>,
}
