//! Set-up shared by the benches: generated houses, ingested and baked into a DATA folder.

use std::path::{Path, PathBuf};

use minos::generate::{generate, GenerateConfig, OutputFormat};
use minos::navmesh::NavParams;
use minos::pipeline::bake::{bake_scenes, BakeConfig};
use minos::pipeline::ingest::{ingest, IngestConfig};
use minos::progress::NoProgress;

/// Generates `houses` furnished SUNCG-format houses from `seed` under `dir`, ingests them and
/// bakes their grids for `body` at the default resolution; returns the DATA folder and the
/// scene ids.
#[allow(dead_code)] // every bench compiles this module; the rollout bench builds its own config
pub fn baked_houses(
    dir: &Path,
    houses: usize,
    seed: u64,
    body: minos::body::AgentBody,
) -> (PathBuf, Vec<String>) {
    let cfg = GenerateConfig {
        houses,
        seed,
        ..GenerateConfig::default()
    };
    baked_houses_from(dir, &cfg, body)
}

/// [`baked_houses`] of any generator configuration.
pub fn baked_houses_from(
    dir: &Path,
    cfg: &GenerateConfig,
    body: minos::body::AgentBody,
) -> (PathBuf, Vec<String>) {
    let (root, data) = (dir.join("suncg"), dir.join("DATA"));
    generate(cfg, OutputFormat::Suncg, &root, false, &NoProgress).expect("generate");
    let report = ingest(&IngestConfig::suncg(&root, &data), &NoProgress).expect("ingest");
    let ids: Vec<String> = report.scenes.iter().map(|(r, _)| r.id.clone()).collect();
    let bake = BakeConfig {
        data: minos::store::DataDir::new(&data),
        scenes: ids
            .iter()
            .map(|id| minos::scene::SceneRef::parse(id))
            .collect(),
        params: NavParams::for_body(body),
        force: false,
        previews: false,
    };
    bake_scenes(&bake, &NoProgress);
    (data, ids)
}
