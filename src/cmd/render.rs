//! `minos render`: flags → [`RenderJob`] ([`config`]) → [`render_views`]; prints what was
//! written.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use minos::body::AgentPreset;
use minos::pipeline::render_views::{render_views, RenderError, RenderJob};
use minos::render::RendererChoice;
use minos::scene::SceneRef;
use minos::sim::{AgentConfig, SensorSuite};
use minos::store::DataDir;

use super::common::{sensor_suite, sensors_help, vocab};
use super::Context;

/// Render what an agent's sensors see at a pose, one PNG per sensor (colour; depth as 16-bit
/// millimetres; normals as (n+1)/2; labels with a fixed colour per id).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  minos render --data DATA --scene ID --out frames/            # the most open view\n  \
    minos render --data DATA --scene ID --pose 3.2,0,4.5,1.57 --out frames/\n  \
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
    scene: SceneRef,
    /// Render this variant of the scene (same as `--scene <scene>@NAME`).
    #[arg(long, value_name = "NAME")]
    variant: Option<String>,
    /// Agent pose x,y,z,yaw: y is the floor height under the agent, yaw in radians. Default:
    /// where the view is most open (among the places farthest from walls, the heading whose
    /// depth image sees farthest).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_pose)]
    pose: Option<[f32; 4]>,
    /// Tilt (radians, positive up).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    tilt: f32,
    /// Renderer.
    #[arg(long, value_parser = vocab::<RendererChoice>(), default_value = "auto")]
    renderer: RendererChoice,
    /// Agent preset (body and eye height; the grid must be baked for its body).
    #[arg(long, value_parser = vocab::<AgentPreset>(), default_value = "habitat")]
    preset: AgentPreset,
    /// Render on a grid baked for another body than --preset's.
    #[arg(long)]
    allow_body_mismatch: bool,
    #[arg(long, help = sensors_help("every modality at --size."))]
    sensors: Option<PathBuf>,
    /// Image size of the default sensors.
    #[arg(long, default_value_t = 256)]
    size: u32,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

fn parse_pose(s: &str) -> Result<[f32; 4], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f32>()
                .map_err(|_| format!("`{t}` is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z, yaw] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z, yaw]),
        _ => Err(format!("`{s}`: expected four finite numbers x,y,z,yaw")),
    }
}

/// Flags → the render job (reads the sensor file, if any).
pub fn config(args: &Args) -> anyhow::Result<RenderJob> {
    let scene = match &args.variant {
        Some(v) => args.scene.with_variant(Some(v)),
        None => args.scene.clone(),
    };
    Ok(RenderJob {
        data: DataDir::new(&args.data),
        scene,
        agent: AgentConfig::preset(args.preset),
        allow_body_mismatch: args.allow_body_mismatch,
        pose: args.pose,
        tilt: args.tilt,
        renderer: args.renderer,
        sensors: {
            let suite = sensor_suite(args.sensors.as_deref(), args.size, || {
                SensorSuite::all(args.size)
            })?;
            if suite.cameras.is_empty() {
                anyhow::bail!(
                    "--sensors {}: no cameras, nothing to render",
                    args.sensors
                        .as_deref()
                        .unwrap_or(std::path::Path::new(""))
                        .display()
                );
            }
            suite
        },
        out: args.out.clone(),
    })
}

/// Runs `minos render`.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let job = config(&args)?;
    if let Some(v) = &job.scene.variant {
        job.data
            .read_variant(v)
            .with_context(|| format!("--variant {v}"))?;
    }
    let report = render_views(&job).map_err(|e| match e {
        RenderError::NowhereToStand(_) => {
            anyhow::anyhow!("{} (--pose)", minos::escape::error_line(&e))
        }
        e => e.into(),
    })?;
    let [x, y, z, yaw] = report.pose;
    // The pose exactly (shortest round-trip digits), so `--pose` renders it again.
    ctx.say(format!(
        "rendered {} images with {} at --pose {x},{y},{z},{yaw}{} -> {}",
        report.images.len(),
        report.renderer,
        if job.pose.is_none() {
            " (the most open view)"
        } else {
            ""
        },
        job.out.display()
    ));
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::common::parse_flags;
    use minos::body::AgentBody;
    use minos::render::RendererChoice;

    fn job(line: &str) -> RenderJob {
        let args = parse_flags::<Args>(line).expect("flags parse");
        config(&args).expect("config")
    }

    #[test]
    fn flags_become_the_job() {
        let j = job("--data D --scene h --variant empty --pose 1,0,-2,1.5 --out o");
        assert_eq!(j.scene.to_string(), "h@empty");
        assert_eq!(j.pose, Some([1.0, 0.0, -2.0, 1.5]));
        assert_eq!(j.agent.body, AgentBody::HABITAT);
        assert_eq!(j.renderer, RendererChoice::Auto);
        assert_eq!(j.sensors.cameras.len(), SensorSuite::all(256).cameras.len());
        let j = job("--data D --scene h --pose 0,0,0,0 --preset minos --renderer cpu --out o");
        assert_eq!(j.agent.body, AgentBody::MINOS);
        assert_eq!(j.renderer, RendererChoice::Cpu);
        for bad in ["1,2,3", "1,2,3,x", "1,2,3,nan"] {
            assert!(parse_pose(bad).is_err(), "{bad}");
        }
    }
}
