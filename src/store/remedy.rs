//! What a user does about an error whose fix is another step of the pipeline — ingest the
//! scenes, ingest one again, bake the grids, bake one again, define a variant, wait for
//! another writer — read from the
//! error's typed chain ([`remedy_of`]). The library's messages name no command or flag; each
//! front door says the remedy in its own words (the command line as a command and its flags,
//! Python as a function call).

use std::error::Error;

use super::{SceneFileError, StoreError};
use crate::navmesh::file::NavFileError;
use crate::scene::variants::VariantError;

/// The step that fixes an error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Remedy {
    /// Ingest the scenes (the DATA folder has no manifest, or not this scene).
    Ingest,
    /// Ingest the scene again, replacing its compiled file (corrupt, or another version).
    Reingest,
    /// Bake the scenes' navigation grids (this one has none).
    Bake,
    /// Bake the grid again, replacing it (corrupt, or another version).
    Rebake,
    /// Define the variant (`[name]` in a variant spec file).
    DefineVariant,
    /// Compute the DATA folder's material statistics (again).
    MaterialStats,
    /// Another process writes the folder: wait for it (or ask to wait for its lock).
    Wait,
}

/// The remedy of the first error in `err`'s chain (`err` itself first) that has one.
pub fn remedy_of(err: &(dyn Error + 'static)) -> Option<Remedy> {
    let mut at = Some(err);
    while let Some(e) = at {
        if let Some(r) = remedy_here(e) {
            return Some(r);
        }
        at = e.source();
    }
    None
}

/// The remedy of `e` itself.
fn remedy_here(e: &(dyn Error + 'static)) -> Option<Remedy> {
    if let Some(e) = e.downcast_ref::<NavFileError>() {
        return Some(match e {
            NavFileError::Io(f) if f.not_found() => Remedy::Bake,
            NavFileError::Io(_) => return None,
            NavFileError::Format { .. } => Remedy::Rebake,
        });
    }
    if let Some(e) = e.downcast_ref::<SceneFileError>() {
        return Some(match e {
            SceneFileError::Io(f) if f.not_found() => Remedy::Ingest,
            SceneFileError::Io(_) => return None,
            SceneFileError::Format { .. } => Remedy::Reingest,
        });
    }
    if let Some(e) = e.downcast_ref::<StoreError>() {
        return match e {
            StoreError::NoManifest { .. } => Some(Remedy::Ingest),
            StoreError::NoVariant { .. } => Some(Remedy::DefineVariant),
            StoreError::StaleStats { .. } => Some(Remedy::MaterialStats),
            _ => None,
        };
    }
    if let Some(crate::lock::LockError::Held { .. }) = e.downcast_ref::<crate::lock::LockError>() {
        return Some(Remedy::Wait);
    }
    if let Some(VariantError::NoStats(_)) = e.downcast_ref::<VariantError>() {
        return Some(Remedy::MaterialStats);
    }
    None
}
