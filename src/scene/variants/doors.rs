//! Door operations: opening closed doors (MINOS swapped closed-door models for open ones) and
//! per-door states.
//!
//! A door's state comes from its model id: a model whose id contains `closed` is a closed door
//! and its open counterpart has the same id with `open` in its place (the convention of the
//! generated houses, `g_door_closed_90` ↔ `g_door_open_90`; other datasets' door models can
//! follow it through ingest). A door is swapped to its counterpart's mesh when some instance
//! of the scene uses that model. When none does, an opened door keeps its record (id,
//! category, box) and only the top band of its geometry (the header, [`HEADER_BAND`] of its
//! height): the doorway becomes passable, and the header still marks the doorway's spans, so
//! the door still counts for ObjectGoal and for doors passed on a path.

use std::collections::BTreeMap;

use glam::Vec3;

use crate::scene::{Mesh, MeshId, Object, Scene};

/// Share of a door's height (from the top) kept when it is opened without an open model.
pub const HEADER_BAND: f32 = 0.12;

/// The triangles of `object`'s mesh that lie entirely in the top [`HEADER_BAND`] of its
/// world box, as a new model-space mesh (unused vertices dropped), or `None` if there are none.
fn header_of(mesh: &Mesh, object: &Object) -> Option<Mesh> {
    let top = object.bbox.max.y;
    let cut = top - HEADER_BAND * (top - object.bbox.min.y);
    let high: Vec<bool> = mesh
        .positions
        .iter()
        .map(|p| object.transform.transform_point3(Vec3::from_array(*p)).y >= cut)
        .collect();
    let mut out = Mesh {
        name: format!("{} (header)", mesh.name),
        materials: mesh.materials.clone(),
        ..Mesh::default()
    };
    let mut remap = vec![u32::MAX; mesh.positions.len()];
    for (t, tri) in mesh.indices.chunks_exact(3).enumerate() {
        if !tri
            .iter()
            .all(|&i| high.get(i as usize).copied().unwrap_or(false))
        {
            continue;
        }
        for &i in tri {
            let i = i as usize;
            if remap[i] == u32::MAX {
                remap[i] = out.positions.len() as u32;
                out.positions.push(mesh.positions[i]);
                out.normals
                    .push(mesh.normals.get(i).copied().unwrap_or([0.0, 1.0, 0.0]));
                if !mesh.uvs.is_empty() {
                    out.uvs.push(mesh.uvs.get(i).copied().unwrap_or([0.0, 0.0]));
                }
            }
            out.indices.push(remap[i]);
        }
        out.face_materials
            .push(mesh.face_materials.get(t).copied().unwrap_or(0));
    }
    (!out.indices.is_empty()).then_some(out)
}

use super::spec::{DoorState, VariantSpec};

/// What the door operations did to one scene.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DoorReport {
    /// Doors swapped to their counterpart model.
    pub swapped: usize,
    /// Doors opened by keeping only their header (no open model in the scene).
    pub cleared: usize,
    /// Per-door entries that name no door of the scene, or a door that cannot be put in the
    /// asked state.
    pub unmatched: Vec<String>,
}

fn state_of(model_id: &str) -> Option<DoorState> {
    let m = model_id.to_ascii_lowercase();
    if m.contains("closed") {
        Some(DoorState::Closed)
    } else if m.contains("open") {
        Some(DoorState::Open)
    } else {
        None
    }
}

fn counterpart(model_id: &str, to: DoorState) -> Option<String> {
    let lower = model_id.to_ascii_lowercase();
    let (from, into) = match to {
        DoorState::Open => ("closed", "open"),
        DoorState::Closed => ("open", "closed"),
    };
    let at = lower.find(from)?;
    Some(format!(
        "{}{}{}",
        &model_id[..at],
        into,
        &model_id[at + from.len()..]
    ))
}

/// Applies `open_doors` and the per-door states of `spec`.
pub fn apply_doors(scene: &mut Scene, spec: &VariantSpec) -> DoorReport {
    let mut report = DoorReport::default();
    if !spec.open_doors && spec.doors.is_empty() {
        return report;
    }
    // Meshes of every model the scene places, by model id.
    let models: BTreeMap<String, MeshId> = scene
        .objects()
        .filter_map(|o| o.mesh.map(|m| (o.model_id.clone(), m)))
        .collect();
    let mut seen = Vec::new();
    for li in 0..scene.levels.len() {
        for oi in 0..scene.levels[li].objects.len() {
            let object = &scene.levels[li].objects[oi];
            if !object.flags.door {
                continue;
            }
            let wanted = match spec.doors.get(&object.id) {
                Some(&s) => {
                    seen.push(object.id.clone());
                    Some(s)
                }
                None => spec.open_doors.then_some(DoorState::Open),
            };
            let Some(wanted) = wanted else { continue };
            if state_of(&object.model_id) == Some(wanted) || state_of(&object.model_id).is_none() {
                if state_of(&object.model_id).is_none() && spec.doors.contains_key(&object.id) {
                    report.unmatched.push(format!(
                        "door {}: model {} has no known state",
                        object.id, object.model_id
                    ));
                }
                continue;
            }
            let Some(target) = counterpart(&object.model_id, wanted) else {
                continue;
            };
            match models.get(&target) {
                Some(&mesh) => {
                    let bbox = scene.meshes[mesh as usize].world_bounds(&object.transform);
                    let object = &mut scene.levels[li].objects[oi];
                    object.mesh = Some(mesh);
                    object.model_id = target;
                    object.bbox = bbox;
                    // Slot overrides belonged to the other model's slots.
                    object.materials.clear();
                    report.swapped += 1;
                }
                None if wanted == DoorState::Open => {
                    let header = object
                        .mesh
                        .and_then(|m| scene.meshes.get(m as usize))
                        .and_then(|m| header_of(m, object));
                    let mesh = header.map(|h| {
                        scene.meshes.push(h);
                        (scene.meshes.len() - 1) as MeshId
                    });
                    let object = &mut scene.levels[li].objects[oi];
                    object.mesh = mesh;
                    object.model_id = target;
                    report.cleared += 1;
                }
                None => report.unmatched.push(format!(
                    "door {}: no instance of {target} in the scene to close it with",
                    scene.levels[li].objects[oi].id
                )),
            }
        }
    }
    for id in spec.doors.keys() {
        if !seen.contains(id) {
            report.unmatched.push(format!("door {id}: no such door"));
        }
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counterparts_follow_the_naming_rule() {
        assert_eq!(
            counterpart("g_door_closed_90", DoorState::Open).as_deref(),
            Some("g_door_open_90")
        );
        assert_eq!(
            counterpart("Door_Open_1", DoorState::Closed).as_deref(),
            Some("Door_closed_1")
        );
        assert_eq!(counterpart("214", DoorState::Open), None);
        assert_eq!(state_of("g_door_closed_90"), Some(DoorState::Closed));
        assert_eq!(state_of("g_door_open_90"), Some(DoorState::Open));
        assert_eq!(state_of("214"), None);
    }
}
