//! Islands: connected components of walkable spans, with their area and radius so that
//! samplers can reject small ones (Habitat rejects islands of radius < 1.5 m).

use glam::Vec3;

use super::grid::{Island, NavGrid, NONE};

/// Labels every walkable span with its island (numbered in order of their first span) and
/// fills `grid.islands`.
pub fn label_islands(grid: &mut NavGrid) {
    grid.islands.clear();
    for s in &mut grid.spans {
        s.island = NONE;
    }
    let cell_area = grid.cell() * grid.cell();
    let mut stack = Vec::new();
    let mut members = Vec::new();
    for start in 0..grid.spans.len() {
        if !grid.spans[start].walkable || grid.spans[start].island != NONE {
            continue;
        }
        let id = grid.islands.len() as u32;
        members.clear();
        grid.spans[start].island = id;
        stack.push(start as u32);
        while let Some(s) = stack.pop() {
            members.push(s);
            for n in grid.spans[s as usize].links {
                if n != NONE
                    && grid.spans[n as usize].island == NONE
                    && grid.spans[n as usize].walkable
                {
                    grid.spans[n as usize].island = id;
                    stack.push(n);
                }
            }
        }
        let sum = members
            .iter()
            .fold(Vec3::ZERO, |acc, &s| acc + grid.span_position(s as usize));
        let centroid = sum / members.len() as f32;
        let radius = members
            .iter()
            .map(|&s| {
                let p = grid.span_position(s as usize);
                ((p.x - centroid.x).powi(2) + (p.z - centroid.z).powi(2)).sqrt()
            })
            .fold(0.0f32, f32::max);
        grid.islands.push(Island {
            area: members.len() as f32 * cell_area,
            radius,
            spans: members.len() as u32,
            centroid: centroid.to_array(),
        });
    }
}
