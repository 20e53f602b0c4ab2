//! The integration tests, one test binary (`cargo test --test suite`): every file beside this
//! one is a module of it, so the crate is linked once and the fixtures of `common` (houses
//! generated, ingested and baked by minos itself) are built once per run and shared.
//!
//! Run one file's tests with its module name as the filter: `cargo test --release --test
//! suite run::` (or a test's name).

mod common;

#[path = "bench.rs"]
mod bench;
#[path = "body.rs"]
mod body;
#[path = "cli.rs"]
mod cli;
#[path = "corrupt_inputs.rs"]
mod corrupt_inputs;
#[path = "durability.rs"]
mod durability;
#[path = "episodes.rs"]
mod episodes;
#[path = "fuzz_regressions.rs"]
mod fuzz_regressions;
#[path = "generate_ingest.rs"]
mod generate_ingest;
#[path = "gltf_scene.rs"]
mod gltf_scene;
#[path = "habitat.rs"]
mod habitat;
#[path = "layering.rs"]
mod layering;
#[path = "lerobot.rs"]
mod lerobot;
#[path = "lerobot_video.rs"]
mod lerobot_video;
#[path = "mp3d.rs"]
mod mp3d;
#[path = "nav_pairs.rs"]
mod nav_pairs;
#[path = "navmesh.rs"]
mod navmesh;
#[path = "navmesh_houses.rs"]
mod navmesh_houses;
#[path = "oracle.rs"]
mod oracle;
#[path = "python_api.rs"]
mod python_api;
#[path = "ray_recipe.rs"]
mod ray_recipe;
#[path = "raycast.rs"]
mod raycast;
#[path = "real_3dfront.rs"]
mod real_3dfront;
#[path = "real_gltf.rs"]
mod real_gltf;
#[path = "real_mp3d.rs"]
mod real_mp3d;
#[path = "real_suncg.rs"]
mod real_suncg;
#[path = "remedy.rs"]
mod remedy;
#[path = "run.rs"]
mod run;
#[path = "scan.rs"]
mod scan;
#[path = "serve.rs"]
mod serve;
#[path = "serve_browser.rs"]
mod serve_browser;
#[path = "serve_campaign.rs"]
mod serve_campaign;
#[path = "serve_campaign_browser.rs"]
mod serve_campaign_browser;
#[path = "shards.rs"]
mod shards;
#[path = "sim.rs"]
mod sim;
#[path = "textures.rs"]
mod textures;
#[path = "threedfront.rs"]
mod threedfront;
#[path = "variants.rs"]
mod variants;
#[path = "verify.rs"]
mod verify;
#[path = "vln.rs"]
mod vln;
mod vocab;
#[path = "workdir.rs"]
mod workdir;
