//! Per-category material statistics and the texture-set partition retexturing draws from.
//!
//! A *material* is a diffuse colour (quantised to 8 bits per channel) with an optional texture
//! name; its key is `#rrggbb` or `#rrggbb|texture`. Every used material slot of every object
//! instance (after the instance's overrides) counts once for the object's category (its most
//! specific label, lower-cased); room surfaces count for `room:floor`, `room:wall`,
//! `room:ceiling` and outdoor ground for `room:ground`. The set of all materials is partitioned
//! into train/val/test by a hash of `(partition seed, key)`, so no material is in two sets and
//! adding scenes never moves a material to another set.

use std::collections::{BTreeMap, BTreeSet};

use serde::{Deserialize, Serialize};

use crate::invalid::Invalid;
use crate::scene::{Mesh, Object, Scene, SurfaceKind};
use crate::seed::{derive_seed, splitmix64};

use super::spec::TextureSet;

/// Version of the statistics file layout.
pub const STATS_VERSION: u32 = 1;

/// Default share of materials in the train and val sets (the rest is test).
pub const DEFAULT_FRACTIONS: [f64; 2] = [0.6, 0.2];

/// One distinct material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialEntry {
    /// `#rrggbb` or `#rrggbb|texture`.
    pub key: String,
    /// A name the datasets give it (the smallest seen, so the choice is order-free).
    pub name: String,
    /// Linear RGB diffuse colour.
    pub rgb: [f32; 3],
    /// Texture name, if any.
    pub texture: Option<String>,
    /// The texture set it belongs to.
    pub set: TextureSet,
}

/// Material statistics over a set of scenes (`DATA/stats/materials.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialStats {
    /// [`STATS_VERSION`].
    pub version: u32,
    /// Seed of the train/val/test partition.
    pub partition_seed: u64,
    /// Shares of the train and val sets.
    pub fractions: [f64; 2],
    /// Scenes counted, sorted.
    pub scenes: Vec<String>,
    /// Every material, sorted by key.
    pub materials: Vec<MaterialEntry>,
    /// Per category: `(material index, count)`, by material index.
    pub categories: BTreeMap<String, Vec<(u32, u64)>>,
}

/// The category a room surface's materials are counted under.
pub fn surface_category(kind: SurfaceKind) -> &'static str {
    match kind {
        SurfaceKind::Floor => "room:floor",
        SurfaceKind::Wall => "room:wall",
        SurfaceKind::Ceiling => "room:ceiling",
    }
}

/// Category of outdoor ground meshes.
pub const GROUND_CATEGORY: &str = "room:ground";

/// The category an object's materials are counted under.
pub fn object_category(object: &Object) -> String {
    object.categories.best().to_ascii_lowercase()
}

/// The key of a colour and texture.
pub fn material_key(rgb: [f32; 3], texture: Option<&str>) -> String {
    let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    let hex = format!("#{:02x}{:02x}{:02x}", q(rgb[0]), q(rgb[1]), q(rgb[2]));
    match texture {
        Some(t) => format!("{hex}|{t}"),
        None => hex,
    }
}

/// Slots of `mesh` used by at least one triangle, ascending.
pub fn used_slots(mesh: &Mesh) -> Vec<u32> {
    let used: BTreeSet<u32> = mesh.face_materials.iter().map(|&m| u32::from(m)).collect();
    used.into_iter()
        .filter(|&s| (s as usize) < mesh.materials.len())
        .collect()
}

/// The material an instance shows on `slot`: `(name, rgba, texture)` after its overrides.
pub fn effective_material(
    mesh: &Mesh,
    object: Option<&Object>,
    slot: u32,
) -> Option<(String, [f32; 4], Option<String>)> {
    let base = mesh.materials.get(slot as usize)?;
    let mut out = (base.name.clone(), base.diffuse, base.texture.clone());
    if let Some(o) = object.and_then(|o| o.materials.iter().find(|m| m.slot == slot)) {
        out.0 = o.name.clone();
        if let Some(d) = o.diffuse {
            out.1 = d;
        }
        match o.texture.as_deref() {
            Some("") => out.2 = None,
            Some(t) => out.2 = Some(t.to_string()),
            None => {}
        }
    }
    Some(out)
}

/// Counts materials scene by scene; [`MaterialStatsBuilder::finish`] gives the statistics.
/// The result does not depend on the order scenes are added in.
#[derive(Debug, Default)]
pub struct MaterialStatsBuilder {
    scenes: BTreeSet<String>,
    /// key → (smallest name, rgb, texture).
    materials: BTreeMap<String, (String, [f32; 3], Option<String>)>,
    /// category → key → count.
    counts: BTreeMap<String, BTreeMap<String, u64>>,
}

impl MaterialStatsBuilder {
    fn count(&mut self, category: &str, name: &str, rgba: [f32; 4], texture: Option<String>) {
        let rgb = [rgba[0], rgba[1], rgba[2]];
        let key = material_key(rgb, texture.as_deref());
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() / 255.0;
        let entry = self
            .materials
            .entry(key.clone())
            .or_insert_with(|| (name.to_string(), [q(rgb[0]), q(rgb[1]), q(rgb[2])], texture));
        if name < entry.0.as_str() {
            entry.0 = name.to_string();
        }
        *self
            .counts
            .entry(category.to_string())
            .or_default()
            .entry(key)
            .or_insert(0) += 1;
    }

    /// Counts every used material slot of `scene`.
    pub fn add(&mut self, scene: &Scene) {
        if !self.scenes.insert(scene.id.clone()) {
            return;
        }
        for level in &scene.levels {
            let surfaces = level.rooms.iter().flat_map(|r| {
                r.surfaces
                    .iter()
                    .map(|s| (surface_category(s.kind), s.mesh))
            });
            let ground = level.ground.iter().map(|&g| (GROUND_CATEGORY, g));
            let placed: Vec<(&str, u32)> = surfaces.chain(ground).collect();
            for (category, mesh) in placed {
                let Some(mesh) = scene.meshes.get(mesh as usize) else {
                    continue;
                };
                for slot in used_slots(mesh) {
                    if let Some((name, rgba, tex)) = effective_material(mesh, None, slot) {
                        self.count(category, &name, rgba, tex);
                    }
                }
            }
            for object in &level.objects {
                let Some(mesh) = object.mesh.and_then(|m| scene.meshes.get(m as usize)) else {
                    continue;
                };
                let category = object_category(object);
                for slot in used_slots(mesh) {
                    if let Some((name, rgba, tex)) = effective_material(mesh, Some(object), slot) {
                        self.count(&category, &name, rgba, tex);
                    }
                }
            }
        }
    }

    /// The statistics, with materials partitioned by `partition_seed` and `fractions`
    /// (train and val shares; the rest is test).
    pub fn finish(self, partition_seed: u64, fractions: [f64; 2]) -> MaterialStats {
        let index: BTreeMap<&str, u32> = self
            .materials
            .keys()
            .enumerate()
            .map(|(i, k)| (k.as_str(), i as u32))
            .collect();
        let categories = self
            .counts
            .iter()
            .map(|(c, keys)| {
                let list = keys.iter().map(|(k, &n)| (index[k.as_str()], n)).collect();
                (c.clone(), list)
            })
            .collect();
        let materials = self
            .materials
            .iter()
            .map(|(key, (name, rgb, texture))| MaterialEntry {
                key: key.clone(),
                name: name.clone(),
                rgb: *rgb,
                texture: texture.clone(),
                set: texture_set_of(partition_seed, fractions, key),
            })
            .collect();
        MaterialStats {
            version: STATS_VERSION,
            partition_seed,
            fractions,
            scenes: self.scenes.into_iter().collect(),
            materials,
            categories,
        }
    }
}

/// The texture set of a material key: a hash of `(seed, key)` mapped to `[0, 1)` and cut at
/// the train and train + val shares.
pub fn texture_set_of(seed: u64, fractions: [f64; 2], key: &str) -> TextureSet {
    let h = splitmix64(derive_seed(seed, &["texture-set", key]));
    let u = (h >> 11) as f64 / (1u64 << 53) as f64;
    if u < fractions[0] {
        TextureSet::Train
    } else if u < fractions[0] + fractions[1] {
        TextureSet::Val
    } else {
        TextureSet::Test
    }
}

impl MaterialStats {
    /// Statistics over `scenes` with the default shares.
    pub fn collect<'a>(scenes: impl IntoIterator<Item = &'a Scene>, partition_seed: u64) -> Self {
        let mut b = MaterialStatsBuilder::default();
        for s in scenes {
            b.add(s);
        }
        b.finish(partition_seed, DEFAULT_FRACTIONS)
    }

    /// The materials seen on `category` that belong to `set`, with their counts.
    pub fn candidates(&self, category: &str, set: TextureSet) -> Vec<(&MaterialEntry, u64)> {
        self.categories
            .get(category)
            .into_iter()
            .flatten()
            .filter_map(|&(i, n)| self.materials.get(i as usize).map(|m| (m, n)))
            .filter(|(m, _)| m.set == set)
            .collect()
    }

    /// Checks internal consistency (after reading a file).
    pub fn validate(&self) -> Result<(), Invalid> {
        if self.version != STATS_VERSION {
            return Err(format!(
                "version {} (this minos reads {STATS_VERSION})",
                self.version
            )
            .into());
        }
        let n = self.materials.len() as u32;
        for (c, list) in &self.categories {
            if let Some((i, _)) = list.iter().find(|(i, _)| *i >= n) {
                return Err(
                    format!("categories.{c}: material {i} out of range ({n} materials)").into(),
                );
            }
        }
        Ok(())
    }
}
