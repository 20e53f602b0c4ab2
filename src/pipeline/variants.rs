//! Variants over many scenes: the material statistics retexturing draws from, and a dry run
//! that applies a variant to every scene without writing anything.

use rayon::prelude::*;

use crate::progress::Progress;
use crate::scene::variants::{
    apply_variant, MaterialStats, MaterialStatsBuilder, VariantError, VariantReport, VariantSpec,
};
use crate::scene::Scene;
use crate::store::{DataDir, SceneFileError};

/// Computes material statistics over the compiled scenes `ids` (in parallel; the result does
/// not depend on the order or thread count). Scenes that cannot be read are returned with
/// their error and left out.
pub fn collect_stats(
    data: &DataDir,
    ids: &[String],
    partition_seed: u64,
    fractions: [f64; 2],
    progress: &dyn Progress,
) -> (MaterialStats, Vec<(String, String)>) {
    progress.set_total(ids.len() as u64);
    let mut builder = MaterialStatsBuilder::default();
    let mut failures = Vec::new();
    // Chunks bound how many scenes are held at once.
    for chunk in ids.chunks(64) {
        let loaded: Vec<(String, Result<Scene, SceneFileError>)> = chunk
            .par_iter()
            .map(|id| {
                let r = data.read_scene(id).map(|(_, s)| s);
                progress.advance(1);
                (id.clone(), r)
            })
            .collect();
        for (id, r) in loaded {
            match r {
                Ok(scene) => builder.add(&scene),
                Err(e) => failures.push((id, e.to_string())),
            }
        }
    }
    (builder.finish(partition_seed, fractions), failures)
}

/// Why a variant's dry run failed on a scene.
#[derive(Debug, thiserror::Error)]
pub enum DryRunError {
    /// The scene could not be read.
    #[error("{0}")]
    Read(SceneFileError),
    /// The variant could not be applied to it.
    #[error("{0}")]
    Apply(VariantError),
}

/// Applies variant `name` to every scene of `ids` without writing anything, to report what it
/// does (and to find scenes it cannot be applied to).
pub fn dry_run(
    data: &DataDir,
    ids: &[String],
    name: &str,
    spec: &VariantSpec,
    stats: Option<&MaterialStats>,
    progress: &dyn Progress,
) -> Vec<(String, Result<VariantReport, DryRunError>)> {
    progress.set_total(ids.len() as u64);
    ids.par_iter()
        .map(|id| {
            let r = data
                .read_scene(id)
                .map_err(DryRunError::Read)
                .and_then(|(_, mut scene)| {
                    apply_variant(&mut scene, name, spec, stats).map_err(DryRunError::Apply)
                });
            progress.advance(1);
            (id.clone(), r)
        })
        .collect()
}
