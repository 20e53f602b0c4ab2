//! `minos render`: one PNG per sensor of an agent standing at a pose.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context as _;
use glam::Vec3;
use minos::io::variant_store::{grid_ref, load_scene};
use minos::navmesh::file::{nav_path, read_nav};
use minos::render::visualize::write_png;
use minos::sim::simulator::Renderer;
use minos::sim::{AgentConfig, RendererChoice, SceneAssets, SensorSuite, Simulator};

use super::common::with_variant;
use super::Context;

/// Renderers of `--renderer`.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum RendererArg {
    /// wgpu when an adapter exists, else CPU.
    Auto,
    /// The built-in CPU rasteriser.
    Cpu,
    /// wgpu (fails without an adapter).
    Wgpu,
}

/// Render what an agent's sensors see at a pose, one PNG per sensor (colour; depth as 16-bit
/// millimetres; normals as (n+1)/2; labels with a fixed colour per id).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos render --data DATA --scene ID --pose 3.2,0,4.5,1.57 --out frames/\n  \
    minos render --data DATA --scene ID --pose 3.2,0,4.5,0 --renderer cpu --sensors sensors.toml --out frames/\n  \
    minos render --data DATA --scene ID --variant empty --pose 3.2,0,4.5,0 --out frames/\n\n\
    Sensor files are TOML (or JSON): [[camera]] tables with name, modality (color, gray, depth,\n\
    normal, semantic, instance, room, room_class), resolution = [W, H], vfov, near, far,\n\
    position = [x, y, z] relative to the agent, orientation = [yaw, tilt] in degrees, taxonomy\n\
    (nyu40, mpcat40), depth_encoding (float, u8, u16), depth_range, noise = { kind = \"gaussian\",\n\
    sigma = 0.01 } or { kind = \"kinect\", min = 0.4, max = 4.0 }; and [contact] count, height."
)]
pub struct Args {
    /// DATA folder (ingested and baked).
    #[arg(long)]
    data: PathBuf,
    /// Scene id (or `<scene>@<variant>`).
    #[arg(long)]
    scene: String,
    /// Render this variant of the scene (same as `--scene <scene>@NAME`).
    #[arg(long, value_name = "NAME")]
    variant: Option<String>,
    /// Agent pose x,y,z,yaw: y is the floor height under the agent, yaw in radians.
    #[arg(long, allow_hyphen_values = true)]
    pose: String,
    /// Tilt (radians, positive up).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    tilt: f32,
    /// Renderer.
    #[arg(long, value_enum, default_value = "auto")]
    renderer: RendererArg,
    /// Sensor file (TOML or JSON); default: every modality at --size.
    #[arg(long)]
    sensors: Option<PathBuf>,
    /// Image size of the default sensors.
    #[arg(long, default_value_t = 256)]
    size: u32,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

/// Runs `minos render`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let v: Vec<f32> = args
        .pose
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f32>()
                .with_context(|| format!("--pose: `{t}` is not a number"))
        })
        .collect::<anyhow::Result<_>>()?;
    let [x, y, z, yaw] = v[..] else {
        anyhow::bail!("--pose: expected x,y,z,yaw")
    };
    let sensors = match &args.sensors {
        Some(p) => {
            let text = std::fs::read_to_string(p).with_context(|| p.display().to_string())?;
            SensorSuite::parse(&text, &p.display().to_string()).map_err(anyhow::Error::msg)?
        }
        None => SensorSuite::all(args.size),
    };
    let scene_ref = with_variant(
        &args.data,
        vec![args.scene.clone()],
        args.variant.as_deref(),
    )?
    .remove(0);
    let (scene, _) = load_scene(&args.data, &scene_ref).context("run `minos ingest` first")?;
    let grid = read_nav(&nav_path(&args.data, &grid_ref(&args.data, &scene_ref)))
        .context("run `minos bake` first")?;
    let agent = AgentConfig::minos_continuous();
    let assets = Arc::new(SceneAssets::new(&scene, grid, &agent)?);
    let choice = match args.renderer {
        RendererArg::Auto => RendererChoice::Auto,
        RendererArg::Cpu => RendererChoice::Cpu,
        RendererArg::Wgpu => RendererChoice::Wgpu,
    };
    let renderer = Arc::new(Renderer::new(choice, &assets.render)?);
    let mut sim = Simulator::new(assets, renderer.clone(), agent, sensors.clone(), 1, 0);
    sim.reset(Vec3::new(x, y, z), yaw, None, "render");
    sim.set_tilt(args.tilt);
    let obs = sim.observe()?;
    for ((name, image), sensor) in obs.images.iter().zip(&sensors.cameras) {
        let path = args.out.join(format!("{name}.png"));
        write_png(
            &path,
            sensor.modality,
            image,
            sensor.resolution[0],
            sensor.resolution[1],
        )
        .with_context(|| path.display().to_string())?;
    }
    ctx.say(format!(
        "rendered {} images with {} -> {}",
        obs.images.len(),
        renderer.name(),
        args.out.display()
    ));
    Ok(ExitCode::SUCCESS)
}
