//! cargo-fuzz target: the small configuration files, chosen by the first byte: 0 a sensor
//! file (`SensorSuite::parse`, TOML or JSON), 1 the grid and agent body TOML of `bake
//! --config` (`params_from_toml`), 2 a variant spec file (`parse_spec_file`, each variant
//! round-tripping through its TOML). Errors are one line; what parses validates.

#![no_main]

#[path = "common.rs"]
mod common;

use libfuzzer_sys::fuzz_target;
use minos::escape::error_line;
use minos::navmesh::{params_from_toml, NavParams};
use minos::scene::variants::{parse_spec_file, VariantSpec};
use minos::sim::SensorSuite;

fuzz_target!(|data: &[u8]| {
    let Some((&kind, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(rest) else {
        return;
    };
    match kind % 3 {
        0 => match SensorSuite::parse(text, "fuzz.toml") {
            Ok(s) => assert!(s.validate().is_ok()),
            Err(e) => common::one_line_naming(&error_line(&e), "fuzz.toml"),
        },
        1 => match params_from_toml(text, NavParams::default()) {
            Ok(p) => assert!(p.validate().is_ok(), "accepted parameters do not validate"),
            Err(e) => common::one_line_naming(&error_line(&e), ""),
        },
        _ => match parse_spec_file(text) {
            Ok(specs) => {
                for (_, spec) in specs {
                    assert!(spec.validate().is_ok());
                    let again = VariantSpec::from_toml(&spec.to_toml()).expect("round trip");
                    assert_eq!(again, spec);
                }
            }
            Err(e) => common::one_line_naming(&error_line(&e), ""),
        },
    }
});
