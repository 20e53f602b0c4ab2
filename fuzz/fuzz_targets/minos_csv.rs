//! cargo-fuzz target: arbitrary bytes as a MINOS episode table (CSV), through
//! `import_minos_csv`. Errors are one line.

#![no_main]

#[path = "common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;
use minos::episode::minos_csv::import_minos_csv;

fuzz_target!(|data: &[u8]| {
    let path = common::temp_file("fuzz.csv", data);
    if let Err(e) = import_minos_csv(&path, None) {
        common::one_line_naming(&e.to_string(), "");
    }
});
