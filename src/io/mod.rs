//! Files minos reads and writes: atomic output, the compiled scene format, the Parquet
//! manifest, scene export to OBJ/GLB, and rerun recordings (`.rrd`).

pub mod atomic;
pub mod export;
pub mod manifest;
pub mod rrd;
pub mod scene_file;
pub mod variant_store;
