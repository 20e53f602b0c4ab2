//! cargo-fuzz target: arbitrary bytes as a Habitat-Lab episode file (plain JSON; the `.json.gz`
//! path only adds gzip), through `import_habitat`. Errors are one line.

#![no_main]

#[path = "common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;
use minos::episode::habitat::import_habitat;

fuzz_target!(|data: &[u8]| {
    let path = common::temp_file("fuzz.json", data);
    if let Err(e) = import_habitat(&path) {
        common::one_line_naming(&e.to_string(), "");
    }
});
