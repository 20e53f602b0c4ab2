//! Semantically consistent retexturing: every used material slot of every object instance and
//! room surface gets a material drawn from those observed on its category, restricted to one
//! texture set, weighted by how often the category shows it.
//!
//! Each draw is seeded by `(seed, scene id, owner id, slot)`, so a slot's draw does not depend
//! on any other slot, on the order of objects, or on which objects a clutter operation
//! removed. Only colours and textures change: geometry, categories and ids stay. A slot keeps
//! its alpha (a glass pane stays translucent). A slot whose category has no material in the
//! chosen set keeps its own material; the report counts such slots.

use crate::scene::{MaterialOverride, Scene};
use crate::seed::{derive_seed, Rng};

use super::materials::{
    effective_material, object_category, surface_category, used_slots, MaterialEntry,
    MaterialStats, GROUND_CATEGORY,
};
use super::spec::Retexture;

/// What retexturing did to one scene.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RetextureReport {
    /// Slots given a drawn material.
    pub redrawn: usize,
    /// Slots kept because their category has no material in the set.
    pub kept: usize,
}

fn draw<'a>(candidates: &[(&'a MaterialEntry, u64)], seed: u64) -> Option<&'a MaterialEntry> {
    let total: u64 = candidates.iter().map(|(_, n)| n).sum();
    if total == 0 {
        return None;
    }
    let mut pick = Rng::new(seed).next_u64() % total;
    for (m, n) in candidates {
        if pick < *n {
            return Some(m);
        }
        pick -= n;
    }
    None
}

/// Retextures `scene` (whose base id is `scene_id`) from `stats`.
pub fn apply_retexture(
    scene: &mut Scene,
    scene_id: &str,
    r: &Retexture,
    stats: &MaterialStats,
) -> RetextureReport {
    let mut report = RetextureReport::default();
    let seed_of = |owner: &str, slot: u32| {
        derive_seed(r.seed, &[scene_id, "retexture", owner, &slot.to_string()])
    };

    // Room surfaces and ground: their meshes are world-space and normally used once; a mesh
    // placed more than once is copied first so each placement draws on its own.
    let mut uses = vec![0u32; scene.meshes.len()];
    for l in &scene.levels {
        for m in l
            .rooms
            .iter()
            .flat_map(|r| r.surfaces.iter().map(|s| s.mesh))
            .chain(l.ground.iter().copied())
        {
            uses[m as usize] += 1;
        }
        for m in l.objects.iter().filter_map(|o| o.mesh) {
            uses[m as usize] += 1;
        }
    }
    let mut owners = Vec::new();
    for (li, l) in scene.levels.iter().enumerate() {
        for (ri, room) in l.rooms.iter().enumerate() {
            for (si, s) in room.surfaces.iter().enumerate() {
                let owner = format!("room {} {:?} {si}", room.id, s.kind);
                owners.push((li, Some((ri, si)), s.mesh, surface_category(s.kind), owner));
            }
        }
        for (gi, &g) in l.ground.iter().enumerate() {
            owners.push((li, None, g, GROUND_CATEGORY, format!("ground {li} {gi}")));
        }
    }
    for (li, place, mesh, category, owner) in owners {
        let mut mesh_id = mesh;
        if uses[mesh as usize] > 1 {
            let copy = scene.meshes[mesh as usize].clone();
            scene.meshes.push(copy);
            mesh_id = (scene.meshes.len() - 1) as u32;
            uses[mesh as usize] -= 1;
            match place {
                Some((ri, si)) => scene.levels[li].rooms[ri].surfaces[si].mesh = mesh_id,
                None => {
                    if let Some(g) = scene.levels[li].ground.iter_mut().find(|g| **g == mesh) {
                        *g = mesh_id;
                    }
                }
            }
        }
        let m = &mut scene.meshes[mesh_id as usize];
        for slot in used_slots(m) {
            let candidates = stats.candidates(category, r.texture_set);
            match draw(&candidates, seed_of(&owner, slot)) {
                Some(entry) => {
                    let mat = &mut m.materials[slot as usize];
                    mat.name = entry.name.clone();
                    mat.diffuse = [entry.rgb[0], entry.rgb[1], entry.rgb[2], mat.diffuse[3]];
                    mat.texture = entry.texture.clone();
                    report.redrawn += 1;
                }
                None => report.kept += 1,
            }
        }
    }

    // Object instances: overrides per slot; the shared model mesh is never modified.
    for li in 0..scene.levels.len() {
        for oi in 0..scene.levels[li].objects.len() {
            let object = &scene.levels[li].objects[oi];
            let Some(mesh) = object.mesh.and_then(|m| scene.meshes.get(m as usize)) else {
                continue;
            };
            let category = object_category(object);
            let candidates = stats.candidates(&category, r.texture_set);
            let mut overrides = Vec::new();
            for slot in used_slots(mesh) {
                let Some((_, rgba, _)) = effective_material(mesh, Some(object), slot) else {
                    continue;
                };
                match draw(&candidates, seed_of(&object.id, slot)) {
                    Some(entry) => {
                        overrides.push(MaterialOverride {
                            slot,
                            name: entry.name.clone(),
                            diffuse: Some([entry.rgb[0], entry.rgb[1], entry.rgb[2], rgba[3]]),
                            // An untextured draw must also drop the model's texture.
                            texture: Some(entry.texture.clone().unwrap_or_default()),
                        });
                        report.redrawn += 1;
                    }
                    None => report.kept += 1,
                }
            }
            let object = &mut scene.levels[li].objects[oi];
            for o in overrides {
                object.materials.retain(|m| m.slot != o.slot);
                object.materials.push(o);
            }
            object.materials.sort_by_key(|m| m.slot);
        }
    }
    report
}
