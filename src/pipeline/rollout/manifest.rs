//! `manifest.json`: what a run was — the run's provenance record: the command, the minos
//! version and source commit, the episodes, the agent, its body and sensors, seed, shard,
//! reward and encodings, the scenes (with the sha256 of each compiled scene and of its
//! sources) and the sha256 of every other file of the run folder (keys sorted).

use super::{io_error, RolloutError, RunConfig};
use crate::atomic::write_bytes_atomic;
use crate::episode::Episode;
use crate::io::run_dir::{RunManifest, MANIFEST};

/// The manifest of the run `cfg` but its `files` (`scenes`: the scene ids of its episodes).
pub fn value<'a>(cfg: &RunConfig, scenes: impl IntoIterator<Item = &'a str>) -> serde_json::Value {
    let mut manifest = configuration(cfg);
    manifest["command"] = serde_json::json!(cfg.provenance.command);
    manifest["minos_commit"] = serde_json::json!(crate::provenance::SOURCE_COMMIT);
    manifest["scenes"] =
        serde_json::json!(crate::store::provenance::scene_records(&cfg.data, scenes));
    manifest
}

/// What decides the bytes of a run's episodes: the manifest's configuration, without the
/// command line (the same run can be asked for in other words) or the scenes' checksums.
fn configuration(cfg: &RunConfig) -> serde_json::Value {
    let p = &cfg.provenance;
    let mut manifest = serde_json::json!({
        "minos_version": env!("CARGO_PKG_VERSION"),
        "episodes_file": p.episodes_file,
        "variant": p.variant,
        "agent": p.agent,
        "preset": p.preset.map(|p| p.name()),
        "body": cfg.agent_config,
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

/// The record an unfinished run keeps beside its parts (`.parts/run.json`), so that running
/// it again continues it only when nothing that decides its bytes changed: the manifest's
/// configuration without the command line, the step limit, and the sha256 of its episodes.
pub fn unfinished_record(cfg: &RunConfig, mine: &[(usize, Episode)]) -> serde_json::Value {
    use sha2::{Digest, Sha256};
    let mut hash = Sha256::new();
    for (i, e) in mine {
        hash.update((*i as u64).to_le_bytes());
        hash.update(serde_json::to_vec(e).unwrap_or_default());
    }
    let mut record = configuration(cfg);
    record["max_steps"] = serde_json::json!(cfg.max_steps);
    record["episodes"] = serde_json::json!({
        "count": mine.len(),
        "sha256": format!("{:x}", hash.finalize()),
    });
    record
}

/// The first key (in key order) whose value differs between two [`unfinished_record`]s.
pub fn first_difference(a: &serde_json::Value, b: &serde_json::Value) -> Option<String> {
    let (Some(a), Some(b)) = (a.as_object(), b.as_object()) else {
        return (a != b).then(|| "the record".to_string());
    };
    let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
    keys.into_iter()
        .find(|k| a.get(*k) != b.get(*k))
        .map(|k| k.to_string())
}

/// Writes `manifest` (from [`value`]) as `cfg.out/manifest.json`, last: it adds the checksums
/// of the folder's other files.
pub fn write(cfg: &RunConfig, manifest: RunManifest) -> Result<(), RolloutError> {
    let path = manifest.path().to_path_buf();
    let mut manifest = manifest.into_value();
    manifest["files"] = files_of(&cfg.out)?;
    // A JSON value always serialises.
    let bytes = serde_json::to_vec_pretty(&manifest).unwrap_or_default();
    write_bytes_atomic(&path, &bytes).map_err(io_error(&path))
}

/// The checksums of the files of the run folder `out` but `manifest.json` itself (and hidden
/// ones: `.parts/`, the lock, temporary files), as `manifest.json`'s `files`.
pub fn files_of(out: &std::path::Path) -> Result<serde_json::Value, RolloutError> {
    let files = crate::provenance::checksums(out, &[MANIFEST]).map_err(RolloutError::Checksums)?;
    Ok(serde_json::json!(files))
}
