//! Scene variants (MINOS's environment customisation): clutter removal, empty houses, open
//! doors and semantically consistent retexturing, described by a small [`VariantSpec`] and
//! applied to a loaded scene, never stored as copies of meshes.
//!
//! A variant is addressed as `<scene>@<variant>` ([`SceneRef`]). [`apply_variant`] runs the
//! operations in a fixed order — clutter, doors, retexture — on the canonical model, so every
//! later stage (navigation grids, episodes, rendering, rollouts) sees the variant like any other
//! scene. Retexturing draws from [`MaterialStats`] computed over the ingested scenes.

mod clutter;
mod doors;
mod materials;
mod retexture;
mod spec;

pub use clutter::{apply_clutter, is_architecture, keeps, survives_empty, ARCH_CATEGORIES};
pub use doors::{apply_doors, DoorReport, HEADER_BAND};
pub use materials::{
    effective_material, material_key, object_category, surface_category, texture_set_of,
    used_slots, MaterialEntry, MaterialStats, MaterialStatsBuilder, DEFAULT_FRACTIONS,
    GROUND_CATEGORY, STATS_VERSION,
};
pub use retexture::{apply_retexture, RetextureReport};
pub use spec::{
    parse_spec_file, validate_name, DoorState, KeepOnly, Retexture, TextureSet, VariantSpec,
    ARCH_ONLY,
};

use crate::scene::{Scene, SceneRef};

/// What applying a variant did to one scene.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct VariantReport {
    /// Objects removed by the clutter rules.
    pub removed: usize,
    /// Door changes.
    pub doors: DoorReport,
    /// Retexturing, when the variant asks for it.
    pub retexture: Option<RetextureReport>,
}

/// Errors applying a variant.
#[derive(Debug, thiserror::Error)]
pub enum VariantError {
    /// Retexturing needs material statistics.
    #[error("variant {0}: retexture needs material statistics")]
    NoStats(String),
}

/// Applies variant `name` to `scene` (loaded without variant): clutter, then doors, then
/// retexture. The scene's id becomes `<scene>@<name>`. Level boxes are kept (they still bound
/// everything), so a variant's grid covers the same area as its scene's.
pub fn apply_variant(
    scene: &mut Scene,
    name: &str,
    spec: &VariantSpec,
    stats: Option<&MaterialStats>,
) -> Result<VariantReport, VariantError> {
    let base = SceneRef::parse(&scene.id).scene;
    let mut report = VariantReport {
        removed: apply_clutter(scene, spec),
        doors: apply_doors(scene, spec),
        retexture: None,
    };
    if let Some(r) = &spec.retexture {
        let stats = stats.ok_or_else(|| VariantError::NoStats(name.to_string()))?;
        report.retexture = Some(apply_retexture(scene, &base, r, stats));
    }

    scene.id = SceneRef::base(base.as_str())
        .with_variant(Some(name))
        .to_string();
    Ok(report)
}
