//! cargo-fuzz target: arbitrary bytes decoded as a navigation grid (`.nav`).
//!
//! Built with `--cfg fuzzing`, the reader skips the grid's checksum so that inputs reach the
//! array decoding and `NavGrid::validate`. A grid it accepts must build its query structures
//! (`Geodesic::new`: the sight index, the search records) and give every span's position
//! without a panic. Errors are one line naming the file.

#![no_main]

#[path = "common.rs"]
mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use minos::navmesh::file::decode_nav;
use minos::navmesh::geodesic::Geodesic;

fuzz_target!(|data: &[u8]| {
    match decode_nav(Path::new("fuzz.nav"), data) {
        Ok(grid) => {
            // Keep each run small: the decoder's own limits are what is under test.
            if grid.spans.len() > 1 << 16 || u64::from(grid.nx) * u64::from(grid.nz) > 1 << 20 {
                return;
            }
            let geo = Geodesic::new(&grid);
            for s in 0..grid.spans.len() as u32 {
                let _ = geo.position(s);
            }
        }
        Err(e) => common::one_line_naming(&e.to_string(), "fuzz.nav: "),
    }
});
