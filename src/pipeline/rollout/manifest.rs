//! `manifest.json`: what a run was — the run's provenance record: the command, the minos
//! version and source commit, the episodes, the agent, its body and sensors, seed, shard,
//! reward and encodings, the scenes (with the sha256 of each compiled scene and of its
//! sources) and the sha256 of every other file of the run folder (keys sorted).

use super::{io_error, RolloutError, RunConfig};
use crate::atomic::write_bytes_atomic;

/// The manifest of the run `cfg` but its `files` (`scenes`: the scene ids of its episodes).
pub fn value<'a>(cfg: &RunConfig, scenes: impl IntoIterator<Item = &'a str>) -> serde_json::Value {
    let p = &cfg.provenance;
    let mut manifest = serde_json::json!({
        "command": p.command,
        "minos_version": env!("CARGO_PKG_VERSION"),
        "minos_commit": crate::provenance::SOURCE_COMMIT,
        "scenes": crate::store::provenance::scene_records(&cfg.data, scenes),
        "episodes_file": p.episodes_file,
        "variant": p.variant,
        "agent": p.agent,
        "preset": p.preset.map(|p| p.name()),
        "body": cfg.body,
        "sensors": cfg.sensors,
        "seed": cfg.seed,
        "shard": cfg.shard.to_string(),
        "reward": cfg.reward.name(),
        "image_encoding": cfg.encoding.name(),
        "rerun": cfg.rerun.as_ref().map(|r| &r.path),
        "rerun_episodes": cfg.rerun.as_ref().map(|r| r.episodes),
    });
    if cfg.allow_body_mismatch {
        manifest["allow_body_mismatch"] = serde_json::Value::Bool(true);
    }
    manifest
}

/// Writes `manifest` (from [`value`]) as `cfg.out/manifest.json`, last: it adds the checksums
/// of the folder's other files.
pub fn write(cfg: &RunConfig, mut manifest: serde_json::Value) -> Result<(), RolloutError> {
    manifest["files"] = files_of(&cfg.out)?;
    let path = cfg.out.join("manifest.json");
    let bytes = serde_json::to_vec_pretty(&manifest)
        .map_err(|e| RolloutError::Table(format!("{}: {e}", path.display())))?;
    write_bytes_atomic(&path, &bytes).map_err(io_error(&path))
}

/// The checksums of the files of the run folder `out` but `manifest.json` itself (and hidden
/// ones: `.parts/`, the lock, temporary files), as `manifest.json`'s `files`.
pub fn files_of(out: &std::path::Path) -> Result<serde_json::Value, RolloutError> {
    let files = crate::provenance::checksums(out, &["manifest.json"])
        .map_err(|e| RolloutError::Table(e.to_string()))?;
    Ok(serde_json::json!(files))
}
