//! `minos export`: writes a compiled scene's world-space geometry as OBJ or GLB.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context as _};
use minos::io::export::{export_scene, ExportFormat};
use minos::scene::SceneRef;
use minos::store::DataDir;

use super::common::vocab;
use super::Context;

const AFTER_HELP: &str = "\
The output is in world space: y up, metres. Every object instance becomes one group (OBJ) or
node (GLB) named `<instance id> <category>`, every room surface one named
`<room id> <room class> floor|ceiling|wall`, every outdoor ground mesh one named
`ground <level>`. GLB nests them under one root node per level. Materials carry diffuse colours
(with per-instance overrides applied) and translucency; textures are not exported. OBJ also
writes a .mtl material library with the same stem next to the .obj.

Examples:
  # Wavefront OBJ (+ house.mtl) for Blender: File > Import > Wavefront (.obj)
  minos export --data minos-demo/data --scene gen_000 --out house.obj

  # Binary glTF, format given explicitly
  minos export --data DATA --scene 0004d52d1aeeb8ae6de39d6bd993e992 --format glb --out scene.glb";

/// Flags of `minos export`.
#[derive(Debug, clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    /// DATA folder made by `minos ingest`; the scene is read from DATA/scenes/<ID>.mscene.
    #[arg(long, value_name = "DATA")]
    data: PathBuf,
    /// Id of the scene to export (its compiled file's stem, e.g. a SUNCG house id), or
    /// `<scene>@<variant>` for a variant.
    #[arg(long, value_name = "ID")]
    scene: SceneRef,
    /// Output format. When omitted it is taken from the --out extension (.obj or .glb).
    #[arg(long, value_parser = vocab::<ExportFormat>(), value_name = "FORMAT")]
    format: Option<ExportFormat>,
    /// File to write (replaced atomically; parent folders are created). OBJ also writes the
    /// .mtl with the same stem beside it.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
}

/// The format to write: `--format`, else the extension of `--out`.
pub fn config(args: &Args) -> anyhow::Result<ExportFormat> {
    let format = match args.format {
        Some(f) => f,
        None => match ExportFormat::from_path(&args.out) {
            Some(f) => f,
            None => bail!(
                "cannot tell the format from the name {}; pass --format obj or --format glb",
                args.out.display()
            ),
        },
    };
    if let Some(ext) = ExportFormat::from_path(&args.out).filter(|&e| e != format) {
        tracing::warn!(
            "writing {format} to {} although its extension says {ext}",
            args.out.display()
        );
    }
    Ok(format)
}

/// Runs the subcommand.
pub fn run(args: Args, ctx: &Context) -> anyhow::Result<ExitCode> {
    let format = config(&args)?;
    let data = DataDir::new(&args.data);
    let path = data.scene_path(&args.scene.scene);
    if !path.is_file() {
        bail!(
            "scene {} not found: {} does not exist (run `minos ingest` on {} first, or check --scene)",
            args.scene,
            path.display(),
            args.data.display()
        );
    }
    let (scene, _) = data.load_scene(&args.scene)?;
    let summary = export_scene(&scene, format, &args.out)
        .with_context(|| format!("exporting scene {}", args.scene))?;
    for name in &summary.skipped {
        eprintln!("warning: left out `{name}`: its placed geometry is not finite");
    }
    let files: Vec<String> = summary
        .files
        .iter()
        .map(|f| f.display().to_string())
        .collect();
    ctx.say(format!(
        "exported scene {}: {} nodes, {} triangles -> {} ({})",
        args.scene,
        summary.nodes,
        summary.triangles,
        files.join(" + "),
        human_bytes(summary.bytes)
    ));
    ctx.say(match format {
        ExportFormat::Obj => "open in Blender: File > Import > Wavefront (.obj)",
        ExportFormat::Glb => "open in Blender: File > Import > glTF 2.0 (.glb/.gltf)",
    });
    Ok(ExitCode::SUCCESS)
}

/// `1234567` → `1.2 MB`.
fn human_bytes(n: u64) -> String {
    const UNITS: [&str; 4] = ["bytes", "kB", "MB", "GB"];
    let mut v = n as f64;
    let mut unit = 0;
    while v >= 1000.0 && unit + 1 < UNITS.len() {
        v /= 1000.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{n} bytes")
    } else {
        format!("{v:.1} {}", UNITS[unit])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::common::parse_flags;

    fn format(line: &str) -> anyhow::Result<ExportFormat> {
        let args = parse_flags::<Args>(line).expect("flags parse");
        config(&args)
    }

    #[test]
    fn the_format_comes_from_the_flag_or_the_extension() {
        assert_eq!(
            format("--data D --scene s --out a.glb").unwrap(),
            ExportFormat::Glb
        );
        assert_eq!(
            format("--data D --scene s --out a.OBJ").ok(),
            ExportFormat::from_path(std::path::Path::new("a.OBJ"))
        );
        assert_eq!(
            format("--data D --scene s --out a.glb --format obj").unwrap(),
            ExportFormat::Obj
        );
        assert!(format("--data D --scene s --out a.ply").is_err());
    }
}
