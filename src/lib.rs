//! minos: indoor 3D scene datasets in, embodied-AI navigation data out.
//!
//! The modules stand on floors; each imports only from floors below it (enforced by
//! `tests/layering.rs`, described in `docs/ARCHITECTURE.md`):
//!
//! 1. ground: [`atomic`] (files written under a temporary name), [`lock`] (one writer per
//!    folder), [`body`] (the agent's body and presets), [`parquet_io`] (Parquet plumbing),
//!    [`seed`], [`shard`], [`progress`];
//! 2. the canonical model: [`scene`] (dataset loaders, variants as model operations);
//! 3. algorithms, in the direction data flows: [`navmesh`] → [`episode`] → [`render`] →
//!    [`sim`] → [`run`] (agents and metrics), plus [`generate`] (procedural houses);
//! 4. storage and outputs: [`store`] (the DATA folder) and [`io`] (recordings, exports,
//!    run tables), which never import each other;
//! 5. what works on a DATA folder as a whole: [`split`], [`stats`] and the batch drivers of
//!    [`pipeline`] (ingest, bake, episode batches, rollouts).
//!
//! The command line (`src/cmd/`, in the binary) only turns flags into the configuration
//! structs of these modules.

/// Declares an item of the library's internals (a module, a method): `pub` with the
/// `internals` feature, which the library's own tests, benchmarks and fuzz targets turn on,
/// and `pub(crate)` without it, so the binary, the Python bindings and every other user see
/// only the API (`docs/ARCHITECTURE.md`, "API boundaries"). One declaration, its doc comment
/// kept: `internal! { /// Docs. pub mod name; }`.
macro_rules! internal {
    ($(#[$meta:meta])* pub $($item:tt)*) => {
        #[cfg(feature = "internals")]
        $(#[$meta])*
        pub $($item)*
        #[cfg(not(feature = "internals"))]
        $(#[$meta])*
        pub(crate) $($item)*
    };
}

pub mod atomic;
pub mod body;
pub mod diff;
pub mod episode;
pub mod escape;
pub mod file_error;
pub mod generate;
pub mod invalid;
pub mod io;
pub mod lock;
pub mod navmesh;
pub mod parquet_io;
pub mod pipeline;
mod prefetch;
pub mod progress;
pub mod provenance;
pub mod render;
pub mod run;
pub mod scene;
pub mod seed;
pub mod serve;
pub mod shard;
pub mod sim;
pub mod split;
pub mod stats;
pub mod store;
pub mod verify;
pub mod vocab;
