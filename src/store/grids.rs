//! Navigation grids in a DATA folder: which grid serves a scene reference, and reading it.

use std::path::PathBuf;

use super::{DataDir, StoreError};
use crate::navmesh::file::{read_nav, read_nav_params};
use crate::navmesh::{NavGrid, NavParams};
use crate::scene::SceneRef;

impl DataDir {
    /// The scene reference whose navigation grid serves `scene`: itself, except for a variant
    /// that keeps the geometry (retexture only) and has no grid of its own, which shares its
    /// scene's grid. Every grid lookup goes through here, so a retextured variant needs no
    /// bake.
    pub fn grid_ref(&self, scene: &SceneRef) -> SceneRef {
        let Some(name) = scene.variant.as_deref() else {
            return scene.clone();
        };
        let keeps_geometry = self.read_variant(name).is_ok_and(|s| !s.changes_geometry());
        if keeps_geometry && !self.nav_path(scene).is_file() {
            scene.without_variant()
        } else {
            scene.clone()
        }
    }

    /// The `.nav` file of the grid that serves `scene` (see [`DataDir::grid_ref`]).
    pub fn grid_path(&self, scene: &SceneRef) -> PathBuf {
        self.nav_path(&self.grid_ref(scene))
    }

    /// Reads the grid that serves `scene`; a missing or unreadable grid says to run
    /// `minos bake`.
    pub fn read_grid(&self, scene: &SceneRef) -> Result<NavGrid, StoreError> {
        Ok(read_nav(&self.grid_path(scene))?)
    }

    /// Reads only the parameters (the body among them) of the grid that serves `scene`, from
    /// its header: what a batch checks before loading whole grids.
    pub fn read_grid_params(&self, scene: &SceneRef) -> Result<NavParams, StoreError> {
        Ok(read_nav_params(&self.grid_path(scene))?)
    }
}
