//! `manifest.json`: what a run was: the command, the minos version, the episodes, the agent,
//! its body and sensors, seed, shard, reward and encodings (keys sorted).

use super::{io_error, RolloutError, RunConfig};
use crate::atomic::write_bytes_atomic;

/// Writes `cfg.out/manifest.json`.
pub fn write(cfg: &RunConfig) -> Result<(), RolloutError> {
    let p = &cfg.provenance;
    let mut manifest = serde_json::json!({
        "command": p.command,
        "minos_version": env!("CARGO_PKG_VERSION"),
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
    let path = cfg.out.join("manifest.json");
    let bytes = serde_json::to_vec_pretty(&manifest)
        .map_err(|e| RolloutError::Table(format!("{}: {e}", path.display())))?;
    write_bytes_atomic(&path, &bytes).map_err(io_error(&path))
}
