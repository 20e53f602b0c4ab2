//! Nothing stored depends on the working directory: a dataset ingested with relative paths
//! from one folder renders, textures included, to the same bytes from another folder.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{minos, tree_bytes};
use minos::navmesh::file::read_nav;
use minos::store::manifest::read_manifest;

/// Runs `minos ARGS` in folder `cwd`; fails the test when it fails.
fn minos_in(cwd: &Path, args: &[&str]) -> Output {
    let out = minos().current_dir(cwd).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "minos {args:?} in {}: {}",
        cwd.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// A pose (`x,y,z,yaw`) on the floor of a room of the baked grid `nav`.
fn indoor_pose(nav: &Path) -> String {
    let grid = read_nav(nav).unwrap();
    let spans: Vec<u32> = grid
        .walkable_spans(None)
        .into_iter()
        .filter(|&s| grid.spans[s as usize].room != minos::navmesh::NONE)
        .collect();
    let p = grid.span_position(spans[spans.len() / 2] as usize);
    format!("{},{},{},0.7", p.x, p.y, p.z)
}

/// Files under a folder with their bytes, sorted by path.
type Images = Vec<(PathBuf, Vec<u8>)>;

/// Renders every default sensor of scene `id` at `pose` from folder `cwd`, reading `data` and
/// writing `out` (both relative to `cwd`); returns the images and what the command logged.
fn render_in(cwd: &Path, data: &str, id: &str, pose: &str, out: &str) -> (Images, String) {
    let o = minos_in(
        cwd,
        &[
            "render",
            "--data",
            data,
            "--scene",
            id,
            "--pose",
            pose,
            "--renderer",
            "cpu",
            "--size",
            "48",
            "--out",
            out,
        ],
    );
    (
        tree_bytes(&cwd.join(out)),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

const FLAT: &str = "flat colours drawn";

#[test]
fn a_dataset_ingested_from_one_folder_renders_identically_from_another() {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path().join("work");
    let elsewhere = dir.path().join("elsewhere/deeper");
    std::fs::create_dir_all(&work).unwrap();
    std::fs::create_dir_all(&elsewhere).unwrap();
    // Everything with relative paths, from `work`.
    minos_in(
        &work,
        &["generate", "--houses", "1", "--seed", "3", "--out", "suncg"],
    );
    minos_in(&work, &["ingest", "--root", "suncg", "--out", "DATA"]);
    minos_in(&work, &["bake", "--data", "DATA"]);
    // The manifest stores where the scene came from, absolutely.
    let rows = read_manifest(&work.join("DATA/houses.parquet")).unwrap();
    assert!(
        rows.iter().all(|r| Path::new(&r.source_path).is_absolute()),
        "{:?}",
        rows.iter().map(|r| &r.source_path).collect::<Vec<_>>()
    );
    assert_eq!(rows.len(), 1);
    let id = &rows[0].id;
    let pose = indoor_pose(&work.join("DATA/nav").join(format!("{id}.nav")));
    let (here, log_here) = render_in(&work, "DATA", id, &pose, "frames");
    let (there, log_there) = render_in(&elsewhere, "../../work/DATA", id, &pose, "frames");
    assert!(!log_here.contains(FLAT), "{log_here}");
    assert!(!log_there.contains(FLAT), "{log_there}");
    assert!(here.iter().any(|(p, _)| p == Path::new("color.png")));
    assert!(
        here == there,
        "the images differ between working directories"
    );
    // The textures were used: without them the colour image is flat and the log says so.
    std::fs::rename(work.join("suncg/texture"), work.join("suncg/texture.off")).unwrap();
    let (flat, log_flat) = render_in(&work, "DATA", id, &pose, "flat");
    assert!(log_flat.contains(FLAT), "{log_flat}");
    let color = |images: &Images| {
        images
            .iter()
            .find(|(p, _)| p == Path::new("color.png"))
            .map(|(_, b)| b.clone())
            .unwrap()
    };
    assert_ne!(color(&here), color(&flat), "textures made no difference");
}
