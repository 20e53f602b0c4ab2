//! cargo-fuzz target: arbitrary bytes as an episode Parquet file (`read_episodes`). Errors are
//! one line.

#![no_main]

#[path = "common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;
use minos::episode::format::read_episodes;

fuzz_target!(|data: &[u8]| {
    common::count_only_uncaught_panics();
    let path = common::temp_file("fuzz.parquet", data);
    if let Err(e) = read_episodes(&path) {
        common::one_line_naming(&e.to_string(), "");
    }
});
