//! Door operations: opening closed doors (MINOS swapped closed-door models for open ones) and
//! per-door states.
//!
//! A door's state comes from its model id: a model whose id contains `closed` is a closed door
//! and its open counterpart has the same id with `open` in its place (the convention of the
//! generated houses, `g_door_closed_90` ↔ `g_door_open_90`; other datasets' door models can
//! follow it through ingest). A door is swapped to its counterpart's mesh when some instance
//! of the scene uses that model. When none does, an opened door keeps its record (id,
//! category, box, so it still counts as a door for ObjectGoal and path door counts) but loses
//! its geometry: the doorway becomes passable and renders as an opening.

use std::collections::BTreeMap;

use crate::scene::{MeshId, Scene};

use super::spec::{DoorState, VariantSpec};

/// What the door operations did to one scene.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct DoorReport {
    /// Doors swapped to their counterpart model.
    pub swapped: usize,
    /// Doors opened by removing their geometry (no open model in the scene).
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
                    let object = &mut scene.levels[li].objects[oi];
                    object.mesh = None;
                    object.model_id = target;
                    object.materials.clear();
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
