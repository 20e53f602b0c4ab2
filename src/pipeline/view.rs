//! `minos view`: loads one scene and its grid from a DATA folder and writes its recording for
//! the rerun viewer (`crate::io::rrd::view`).

use std::path::PathBuf;

use crate::episode::Episode;
use crate::io::rrd::view::ViewReport;
use crate::io::rrd::RecordingError;
use crate::scene::SceneRef;
use crate::store::DataDir;

/// What `minos view` records.
#[derive(Debug, Clone)]
pub struct ViewConfig {
    /// DATA folder (ingested and baked).
    pub data: DataDir,
    /// The scene, or a variant of it.
    pub scene: SceneRef,
    /// The `.rrd` file to write.
    pub out: PathBuf,
}

/// Why a view could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// The scene or its grid could not be read.
    #[error("{0}")]
    Input(#[from] crate::store::StoreError),
    /// The recording failed.
    #[error(transparent)]
    Recording(#[from] RecordingError),
}

/// Writes the recording of `cfg.scene` with those of `episodes` that belong to it.
pub fn write_view(cfg: &ViewConfig, episodes: &[Episode]) -> Result<ViewReport, ViewError> {
    let (scene, _) = cfg.data.load_scene(&cfg.scene).map_err(ViewError::Input)?;
    let grid = cfg.data.read_grid(&cfg.scene).map_err(ViewError::Input)?;
    let name = cfg.scene.to_string();
    Ok(crate::io::rrd::view::write_view(
        &cfg.out, &name, &scene, &grid, episodes,
    )?)
}
