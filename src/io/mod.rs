//! Files minos reads and writes: atomic output, the compiled scene format, the Parquet
//! manifest, and scene export to OBJ/GLB.

pub mod atomic;
pub mod export;
pub mod manifest;
pub mod scene_file;
pub mod variant_store;
