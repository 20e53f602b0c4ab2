//! cargo-fuzz target: arbitrary bytes as an external agent's JSON reply line
//! (`run::external::parse_reply`). Errors are one line.

#![no_main]

#[path = "common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;
use minos::run::external::parse_reply;

fuzz_target!(|data: &[u8]| {
    let Ok(value) = serde_json::from_slice::<serde_json::Value>(data) else {
        return;
    };
    if let Err(e) = parse_reply(&value) {
        common::one_line_naming(&e.to_string(), "");
    }
});
