//! PNG previews of a baked grid, one per level: walkable spans coloured by room class,
//! eroded (too close to obstacles) floor light grey, obstacles dark, doors marked, islands
//! outlined.

use crate::file_error::FileError;
use std::path::Path;

use image::{Rgb, RgbImage};

use super::grid::{NavGrid, NONE};
use crate::atomic::write_atomic;
use crate::scene::room_colors::room_class_color;

const OUTSIDE: [u8; 3] = [200, 200, 200];
const ERODED: [u8; 3] = [235, 235, 235];
const OBSTACLE: [u8; 3] = [45, 45, 50];
const DOOR: [u8; 3] = [230, 80, 40];
const ARCH: [u8; 3] = [240, 140, 40];

/// Renders level `level` (rows are +Z, columns +X, north at the top), `scale` pixels per cell.
pub fn render_level(grid: &NavGrid, level: u16, scale: u32) -> RgbImage {
    let (nx, nz) = (grid.nx, grid.nz);
    let mut img = RgbImage::from_pixel(nx * scale, nz * scale, Rgb(OBSTACLE));
    // The level's walkable span of the column if any (the lowest), else its lowest span.
    let span_of = |c: usize| {
        let mut on_level = grid
            .column_spans(c)
            .filter(|&s| grid.spans[s].level == level);
        let first = on_level.clone().next();
        on_level.find(|&s| grid.spans[s].walkable).or(first)
    };
    for iz in 0..nz {
        for ix in 0..nx {
            let c = (iz * nx + ix) as usize;
            let Some(s) = span_of(c) else { continue };
            let span = &grid.spans[s];
            let mut color = if !span.walkable {
                ERODED
            } else if span.room == NONE {
                OUTSIDE
            } else {
                room_class_color(grid.rooms[span.room as usize].class)
            };
            if span.walkable {
                if let Some(o) = grid.objects_above(s as u32).find(|o| o.door || o.arch) {
                    color = if o.door { DOOR } else { ARCH };
                }
                // Island outline: a walkable span at the edge of its island.
                let edge = span.links[..4]
                    .iter()
                    .any(|&n| n == NONE || grid.spans[n as usize].island != span.island);
                if edge {
                    color = color.map(|v| (v as f32 * 0.55) as u8);
                }
            }
            for py in 0..scale {
                for px in 0..scale {
                    img.put_pixel(ix * scale + px, iz * scale + py, Rgb(color));
                }
            }
        }
    }
    img
}

/// Levels that have at least one span.
pub fn levels_present(grid: &NavGrid) -> Vec<u16> {
    let mut levels: Vec<u16> = grid.spans.iter().map(|s| s.level).collect();
    levels.sort_unstable();
    levels.dedup();
    levels
}

/// The preview of level `level` next to `nav_file`: `<stem>.L<level>.png`.
pub fn preview_path(nav_file: &Path, level: u16) -> std::path::PathBuf {
    let stem = nav_file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    nav_file.with_file_name(format!("{stem}.L{level}.png"))
}

/// True when every level of `grid` has its preview next to `nav_file`.
pub fn previews_present(grid: &NavGrid, nav_file: &Path) -> bool {
    levels_present(grid)
        .into_iter()
        .all(|level| preview_path(nav_file, level).is_file())
}

/// Writes one PNG per level next to `nav_file`: `<stem>.L<level>.png`. Returns the paths; an
/// error names the file.
pub fn write_previews(
    grid: &NavGrid,
    nav_file: &Path,
) -> Result<Vec<std::path::PathBuf>, FileError> {
    let scale = if grid.cell() >= 0.1 { 4 } else { 2 };
    let mut out = Vec::new();
    for level in levels_present(grid) {
        let path = preview_path(nav_file, level);
        let img = render_level(grid, level, scale);
        write_atomic(&path, |w| {
            img.write_to(w, image::ImageFormat::Png)
                .map_err(std::io::Error::other)
        })
        .map_err(|source| FileError::new(&path, source))?;
        out.push(path);
    }
    Ok(out)
}
