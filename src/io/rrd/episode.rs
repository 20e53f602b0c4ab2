//! One episode's recording, logged step by step while it rolls out: the scene and the
//! episode's plan once, then per step the agent's pose and trajectory, each camera's pose and
//! image, the goal distances, the reward and the action. Nothing is kept but the trajectory's
//! points, so memory does not grow with images.

use glam::Quat;
use rerun::{
    Capsules3D, Color, DepthImage, Image, LineStrips3D, Pinhole, Quaternion, Scalars,
    SegmentationImage, TextLog, Transform3D,
};

use super::scene::{annotation, log_coordinates, log_episode_plan, log_nav, log_scene_mesh};
use super::{RecordingError, RrdFile};
use crate::episode::Episode;
use crate::render::Camera;
use crate::render::{Image as SensorImage, Modality};
use crate::sim::{CameraSensor, DepthEncoding};
use crate::sim::{AgentConfig, AgentState, Observation, SceneAssets};

/// The agent's base (pose per step).
pub const AGENT: &str = "world/agent";
/// The agent's body, a capsule in the agent's frame.
pub const AGENT_BODY: &str = "world/agent/body";
/// The path walked so far (a line strip per step).
pub const TRAJECTORY: &str = "world/trajectory";
/// Prefix of the camera entities: `world/cameras/<sensor>` (pose per step) and
/// `world/cameras/<sensor>/image` (intrinsics and the image per step).
pub const CAMERAS: &str = "world/cameras";
/// The episode's start, goal and shortest path.
pub const PLAN: &str = "world/episode";
/// Prefix of the scalar time series (`metrics/geodesic`, `metrics/euclidean`,
/// `metrics/reward`, `metrics/collision`).
pub const METRICS: &str = "metrics";
/// The action taken at each step.
pub const ACTION: &str = "agent/action";

/// Colour of the agent and its trajectory.
fn trajectory_color() -> Color {
    Color::from_rgb(40, 120, 250)
}

/// Streams one episode into a recording.
pub struct EpisodeRecorder {
    file: RrdFile,
    cameras: Vec<CameraSensor>,
    dt: f32,
    trail: Vec<[f32; 3]>,
}

/// Rotation of a yaw (CCW about +Y, 0 faces −Z) followed by a tilt (about +X, up).
fn rotation(yaw: f32, tilt: f32) -> Quaternion {
    Quaternion::from_xyzw((Quat::from_rotation_y(yaw) * Quat::from_rotation_x(tilt)).to_array())
}

/// Camera intrinsics: square pixels, vertical field of view, +X right, +Y up, looking −Z.
fn pinhole(c: &CameraSensor) -> Pinhole {
    let [w, h] = c.resolution.map(|v| v as f32);
    let f = 0.5 * h / (0.5 * c.vfov.to_radians()).tan();
    Pinhole::from_focal_length_and_resolution([f, f], [w, h])
        .with_camera_xyz(rerun::components::ViewCoordinates::RUB)
        .with_image_plane_distance(0.25)
}

/// Bytes of a slice of plain numbers, little-endian.
fn le_bytes<T: bytemuck::Pod>(v: &[T]) -> Vec<u8> {
    bytemuck::cast_slice(v).to_vec()
}

impl EpisodeRecorder {
    /// Starts the recording of `episode` at `path` (recording id = episode id) and logs what
    /// does not change: the scene, the navigation grid, the episode's plan, the agent's body
    /// and the cameras' intrinsics.
    pub fn create(
        path: &std::path::Path,
        episode: &Episode,
        assets: &SceneAssets,
        cameras: &[CameraSensor],
        agent: &AgentConfig,
    ) -> Result<Self, RecordingError> {
        let file = RrdFile::create(path, &episode.episode_id, &episode.episode_id)?;
        log_coordinates(&file)?;
        log_scene_mesh(&file, &assets.render)?;
        log_nav(&file, &assets.grid)?;
        log_episode_plan(&file, &assets.grid, episode, &PLAN.into())?;
        let length = (agent.body.height - 2.0 * agent.body.radius).max(0.0);
        file.log_static(
            AGENT_BODY,
            &Capsules3D::from_lengths_and_radii([length], [agent.body.radius])
                .with_translations([[0.0, agent.body.radius, 0.0]])
                .with_quaternions([Quaternion::from_xyzw(
                    Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2).to_array(),
                )])
                .with_colors([trajectory_color()]),
        )?;
        for c in cameras {
            let image = format!("{CAMERAS}/{}/image", c.name);
            file.log_static(image.as_str(), &pinhole(c))?;
            if c.modality == Modality::Semantic {
                file.log_static(image.as_str(), &annotation(c.taxonomy))?;
            }
        }
        Ok(EpisodeRecorder {
            file,
            cameras: cameras.to_vec(),
            dt: agent.dt,
            trail: Vec::new(),
        })
    }

    /// Logs the state observed at `step`: the agent's pose and trajectory, each camera's pose
    /// (`cameras`, in sensor order, as the simulator placed them) and image, and the goal
    /// distances.
    pub fn observe(
        &mut self,
        step: u32,
        state: &AgentState,
        cameras: &[Camera],
        obs: &Observation,
    ) -> Result<(), RecordingError> {
        let f = &self.file;
        f.set_step(step, self.dt)?;
        f.log(
            AGENT,
            &Transform3D::from_translation_rotation(state.position, rotation(state.yaw, 0.0)),
        )?;
        self.trail.push(state.position);
        f.log(
            TRAJECTORY,
            &LineStrips3D::new([self
                .trail
                .iter()
                .map(|p| [p[0], p[1] + 0.05, p[2]])
                .collect::<Vec<_>>()])
            .with_colors([trajectory_color()])
            .with_radii([0.025]),
        )?;
        for (sensor, cam) in self.cameras.iter().zip(cameras) {
            let entity = format!("{CAMERAS}/{}", sensor.name);
            f.log(
                entity.as_str(),
                &Transform3D::from_translation_rotation(
                    cam.position.to_array(),
                    rotation(cam.yaw, cam.tilt),
                ),
            )?;
            if let Some((_, img)) = obs.images.iter().find(|(n, _)| *n == sensor.name) {
                log_image(f, &format!("{entity}/image"), sensor, img)?;
            }
        }
        let m = &obs.measurements;
        if let Some(g) = m.goal_geodesic {
            f.log(
                format!("{METRICS}/geodesic"),
                &Scalars::single(f64::from(g)),
            )?;
        }
        if let Some(e) = m.goal_euclidean {
            f.log(
                format!("{METRICS}/euclidean"),
                &Scalars::single(f64::from(e)),
            )?;
        }
        Ok(())
    }

    /// Logs what the agent did at `step`: the action, the reward it earned and whether it
    /// collided.
    pub fn act(
        &mut self,
        step: u32,
        action: &str,
        reward: f32,
        collision: bool,
    ) -> Result<(), RecordingError> {
        let f = &self.file;
        f.set_step(step, self.dt)?;
        f.log(ACTION, &TextLog::new(action.to_string()))?;
        f.log(
            format!("{METRICS}/reward"),
            &Scalars::single(f64::from(reward)),
        )?;
        f.log(
            format!("{METRICS}/collision"),
            &Scalars::single(if collision { 1.0 } else { 0.0 }),
        )?;
        Ok(())
    }

    /// Completes the file (see [`RrdFile::finish`]).
    pub fn finish(self) -> Result<std::path::PathBuf, RecordingError> {
        self.file.finish()
    }
}

/// Logs one sensor image as the archetype the viewer shows best: colour and grey as images,
/// depth as a depth image in metres, labels as segmentation images, normals mapped to RGB.
fn log_image(
    f: &RrdFile,
    entity: &str,
    sensor: &CameraSensor,
    img: &SensorImage,
) -> Result<(), RecordingError> {
    use rerun::datatypes::ChannelDatatype as D;
    let wh = sensor.resolution;
    match (sensor.modality, img) {
        (Modality::Color, SensorImage::U8 { data, .. }) => {
            f.log(entity, &Image::from_rgb24(data.clone(), wh))
        }
        (Modality::Gray, SensorImage::U8 { data, .. }) => {
            f.log(entity, &Image::from_l8(data.clone(), wh))
        }
        (Modality::Depth, img) => {
            let [lo, hi] = sensor.depth_range;
            let (bytes, datatype, meter) = match (sensor.depth_encoding, img) {
                (DepthEncoding::Float, SensorImage::F32 { data, .. }) => {
                    (le_bytes(data), D::F32, 1.0)
                }
                (DepthEncoding::U8, SensorImage::U8 { data, .. }) => {
                    (data.clone(), D::U8, 255.0 / (hi - lo))
                }
                (DepthEncoding::U16, SensorImage::U16(data)) => {
                    (le_bytes(data), D::U16, 65535.0 / (hi - lo))
                }
                _ => return Err(f.error(format!("{entity}: unexpected depth image type"))),
            };
            f.log(
                entity,
                &DepthImage::from_data_type_and_bytes(bytes, wh, datatype).with_meter(meter),
            )
        }
        (Modality::Normal, SensorImage::F32 { data, .. }) => {
            let rgb: Vec<u8> = data
                .iter()
                .map(|&v| ((v.clamp(-1.0, 1.0) + 1.0) * 127.5).round() as u8)
                .collect();
            f.log(entity, &Image::from_rgb24(rgb, wh))
        }
        (Modality::Semantic, SensorImage::U16(data)) => f.log(
            entity,
            &SegmentationImage::new(
                le_bytes(data),
                rerun::components::ImageFormat::segmentation(wh, D::U16),
            ),
        ),
        (Modality::Instance | Modality::Room, SensorImage::U32(data)) => f.log(
            entity,
            &SegmentationImage::new(
                le_bytes(data),
                rerun::components::ImageFormat::segmentation(wh, D::U32),
            ),
        ),
        (Modality::RoomClass, SensorImage::U8 { data, .. }) => f.log(
            entity,
            &SegmentationImage::new(
                data.clone(),
                rerun::components::ImageFormat::segmentation(wh, D::U8),
            ),
        ),
        (m, _) => Err(f.error(format!("{entity}: unexpected image type for {m:?}"))),
    }
}
