//! Clutter operations: removing categories, keeping only some, emptying rooms.
//!
//! The rooms' walls, floors and ceilings are never touched (they are surfaces, not objects).
//! Removing an object deletes it from its level; the remaining objects keep their instance ids.

use crate::scene::{Object, Scene};

use super::spec::{VariantSpec, ARCH_ONLY};

/// Categories that count as architecture for `keep_only = "arch"` besides the door, window,
/// arch and stairs flags.
pub const ARCH_CATEGORIES: [&str; 4] = ["column", "pillar", "beam", "railing"];

/// True when `object` is architecture in MINOS's `archOnly` sense: doors, windows, arches,
/// stairs and structural categories.
pub fn is_architecture(object: &Object) -> bool {
    let f = object.flags;
    f.door
        || f.window
        || f.arch
        || f.stairs
        || ARCH_CATEGORIES.iter().any(|c| object.categories.matches(c))
}

/// True when `object` survives `empty = true`: doors, arches and windows only.
pub fn survives_empty(object: &Object) -> bool {
    let f = object.flags;
    f.door || f.window || f.arch
}

/// Whether the clutter rules of `spec` keep `object`.
pub fn keeps(spec: &VariantSpec, object: &Object) -> bool {
    let named = |list: &[String]| list.iter().any(|c| object.categories.matches(c));
    if named(&spec.remove) || named(&spec.hide) {
        return false;
    }
    if spec.empty && !survives_empty(object) {
        return false;
    }
    if let Some(keep) = &spec.keep_only {
        // Architecture always stays, so `keep_only = "arch"` keeps exactly architecture.
        let listed = keep
            .names()
            .iter()
            .any(|n| n != ARCH_ONLY && object.categories.matches(n));
        if !(is_architecture(object) || listed) {
            return false;
        }
    }
    true
}

/// Removes the objects `spec` does not keep; returns how many were removed.
pub fn apply_clutter(scene: &mut Scene, spec: &VariantSpec) -> usize {
    let mut removed = 0;
    for level in &mut scene.levels {
        let before = level.objects.len();
        level.objects.retain(|o| keeps(spec, o));
        removed += before - level.objects.len();
    }
    removed
}
