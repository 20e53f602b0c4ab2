//! minos: indoor 3D scene datasets in, embodied-AI navigation data out.
//!
//! Data flows one way: [`scene`] (canonical model and dataset loaders) → navigation → episodes
//! → simulation and rendering → [`io`]. [`generate`] writes procedural houses in real dataset
//! formats; [`ingest`], [`split`] and [`stats`] build and describe a DATA folder. The command
//! line (`src/cmd/`, in the binary) only turns flags into the configuration structs of these
//! modules. See `docs/ARCHITECTURE.md`.

pub mod episode;
pub mod generate;
pub mod ingest;
pub mod io;
pub mod navmesh;
pub mod progress;
pub mod render;
pub mod run;
pub mod scene;
pub mod seed;
pub mod sim;
pub mod split;
pub mod stats;
