//! Outputs: rerun recordings (`rrd`), scene exports to OBJ/GLB (`export`), the tables of batch
//! navigation queries (`pairs`: the pairs read, the answers written), and the Parquet tables
//! of a run (`tables`, with how an image is stored in a cell in `image_codec`), the run
//! folder's layout and manifest (`run_dir`) and the LeRobot v3.0 copy (`lerobot`). Nothing
//! here reads or
//! writes the DATA folder (that is `crate::store`).

pub mod export;
pub mod image_codec;
pub mod lerobot;
pub mod pairs;
pub mod run_dir;
internal! {
    pub mod rrd;
}
pub mod tables;

pub use rrd::view::ViewReport;
pub use rrd::RecordingError;
