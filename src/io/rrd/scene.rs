//! What a recording shows at all times: the scene mesh (material colours, and a copy coloured
//! by semantic class), the navigation grid (walkable spans as points, and the per-level
//! preview images of `minos bake`), and an episode's start, goal and shortest path.

use glam::Vec3;
use rerun::{
    AnnotationContext, Color, EntityPath, EntityPathPart, Image, LineStrips3D, Mesh3D, Points3D,
    ViewCoordinates,
};

use super::{RecordingError, RrdFile};
use crate::episode::goal::{goal_positions, shortest_path};
use crate::episode::Episode;
use crate::navmesh::NONE;
use crate::navmesh::preview::{levels_present, render_level};
use crate::navmesh::NavGrid;
use crate::render::RenderScene;
use crate::scene::Taxonomy;
use crate::scene::room_colors::room_class_color;
use crate::scene::SurfaceKind;

/// Root of the 3D world (right-handed, metres, +Y up).
pub const WORLD: &str = "world";
/// The scene mesh in material colours.
pub const SCENE_MESH: &str = "world/scene/mesh";
/// Root of the semantic copy of the scene (a 3D view of its own, so the two meshes do not
/// overlap).
pub const SEMANTIC: &str = "semantic";
/// The scene mesh coloured by NYU-40 class.
pub const SEMANTIC_MESH: &str = "semantic/mesh";
/// Walkable spans of the navigation grid as points coloured by room class.
pub const NAV_POINTS: &str = "world/nav/walkable";
/// Prefix of the per-level preview images (`nav/L0`, `nav/L1`, …).
pub const NAV_IMAGES: &str = "nav";

/// Height (m) above the floor at which points and paths are drawn, so floors do not hide
/// them.
const LIFT: f32 = 0.03;
const START_COLOR: [u8; 3] = [40, 200, 60];
const GOAL_COLOR: [u8; 3] = [230, 40, 40];
const PATH_COLOR: [u8; 3] = [250, 200, 30];

fn color([r, g, b]: [u8; 3]) -> Color {
    Color::from_rgb(r, g, b)
}

/// A fixed, well-spread colour per class index (0, void, is black): hues step by the golden
/// angle, so neighbouring classes differ.
pub fn class_color(class: u16) -> [u8; 3] {
    if class == 0 {
        return [0, 0, 0];
    }
    let h = (f32::from(class) * 0.618_034).fract() * 6.0;
    let (s, v) = (0.65, if class.is_multiple_of(2) { 0.95 } else { 0.78 });
    let c = v * s;
    let x = c * (1.0 - ((h % 2.0) - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [r, g, b].map(|u| ((u + m) * 255.0).round() as u8)
}

/// The class names and colours of `taxonomy`, for segmentation images and the semantic mesh.
pub fn annotation(taxonomy: Taxonomy) -> AnnotationContext {
    AnnotationContext::new(taxonomy.class_names().iter().enumerate().map(|(i, name)| {
        let [r, g, b] = class_color(i as u16);
        let label = if name.is_empty() {
            "void"
        } else {
            name.as_str()
        };
        (i as u16, label, rerun::Rgba32::from_rgb(r, g, b))
    }))
}

/// The coordinate system of both 3D roots (+Y up).
pub fn log_coordinates(file: &RrdFile) -> Result<(), RecordingError> {
    file.log_static(WORLD, &ViewCoordinates::RIGHT_HAND_Y_UP())?;
    file.log_static(SEMANTIC, &ViewCoordinates::RIGHT_HAND_Y_UP())
}

/// Logs the scene's triangles twice: in material colours at [`SCENE_MESH`] and by NYU-40
/// class at [`SEMANTIC_MESH`]. Ceilings are left out so the rooms can be seen from above.
/// Returns the number of triangles logged.
pub fn log_scene_mesh(file: &RrdFile, scene: &RenderScene) -> Result<usize, RecordingError> {
    let ceiling = Taxonomy::Nyu40.surface_class(SurfaceKind::Ceiling);
    let kept: Vec<usize> = (0..scene.tris.len())
        .filter(|&t| scene.tris[t].nyu40 != ceiling || scene.tris[t].object != 0)
        .collect();
    let positions: Vec<[f32; 3]> = kept
        .iter()
        .flat_map(|&t| scene.triangle(t).map(|v| v.to_array()))
        .collect();
    let per_vertex = |f: &dyn Fn(usize) -> Color| -> Vec<Color> {
        kept.iter().flat_map(|&t| [f(t); 3]).collect()
    };
    let normals: Vec<[f32; 3]> = kept
        .iter()
        .flat_map(|&t| [scene.tris[t].normal; 3])
        .collect();
    let material = per_vertex(&|t| {
        color(
            scene.tris[t]
                .color
                .map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8),
        )
    });
    file.log_static(
        SCENE_MESH,
        &Mesh3D::new(positions.iter().copied())
            .with_vertex_normals(normals.iter().copied())
            .with_vertex_colors(material),
    )?;
    let semantic = per_vertex(&|t| color(class_color(scene.tris[t].nyu40)));
    file.log_static(
        SEMANTIC_MESH,
        &Mesh3D::new(positions)
            .with_vertex_normals(normals)
            .with_vertex_colors(semantic),
    )?;
    Ok(kept.len())
}

/// Logs the grid's walkable spans as points at [`NAV_POINTS`] (coloured by MINOS room class,
/// grey outside rooms) and each level's preview image at `nav/L<level>`. Returns the number
/// of points.
pub fn log_nav(file: &RrdFile, grid: &NavGrid) -> Result<usize, RecordingError> {
    let walkable: Vec<usize> = (0..grid.spans.len())
        .filter(|&s| grid.spans[s].walkable)
        .collect();
    let positions: Vec<[f32; 3]> = walkable
        .iter()
        .map(|&s| (grid.span_position(s) + Vec3::Y * LIFT).to_array())
        .collect();
    let colors: Vec<Color> = walkable
        .iter()
        .map(|&s| match grid.spans[s].room {
            NONE => color([200, 200, 200]),
            r => color(room_class_color(grid.rooms[r as usize].class)),
        })
        .collect();
    file.log_static(
        NAV_POINTS,
        &Points3D::new(positions)
            .with_colors(colors)
            .with_radii([grid.cell() * 0.5]),
    )?;
    for level in levels_present(grid) {
        let img = render_level(grid, level, 1);
        let (w, h) = img.dimensions();
        file.log_static(
            format!("{NAV_IMAGES}/L{level}"),
            &Image::from_rgb24(img.into_raw(), [w, h]),
        )?;
    }
    Ok(walkable.len())
}

/// Logs an episode's start (green), goal positions (red) and shortest path (yellow) under
/// `base` (`base/start`, `base/goal`, `base/shortest_path`). Returns the path's points (none
/// when the goal is unreachable on this grid).
pub fn log_episode_plan(
    file: &RrdFile,
    grid: &NavGrid,
    episode: &Episode,
    base: &EntityPath,
) -> Result<Vec<Vec3>, RecordingError> {
    let child = |name: &str| base.join(&EntityPath::new(vec![EntityPathPart::new(name)]));
    let lift = |p: [f32; 3]| [p[0], p[1] + LIFT, p[2]];
    file.log_static(
        child("start"),
        &Points3D::new([lift(episode.start_position)])
            .with_colors([color(START_COLOR)])
            .with_radii([0.12])
            .with_labels([format!("start {}", episode.episode_id)]),
    )?;
    let goals = goal_positions(episode);
    file.log_static(
        child("goal"),
        &Points3D::new(goals.iter().map(|&p| lift(p)))
            .with_colors([color(GOAL_COLOR)])
            .with_radii([0.12]),
    )?;
    let path = shortest_path(grid, episode).unwrap_or_default();
    if !path.is_empty() {
        let strip: Vec<[f32; 3]> = path.iter().map(|p| lift(p.to_array())).collect();
        file.log_static(
            child("shortest_path"),
            &LineStrips3D::new([strip])
                .with_colors([color(PATH_COLOR)])
                .with_radii([0.03])
                .with_labels([format!("{:.2} m", episode.geodesic_distance)]),
        )?;
    }
    Ok(path)
}

/// The entity path `world/episodes/<episode id>` (the id as one path part, whatever its
/// characters).
pub fn episode_entity(episode_id: &str) -> EntityPath {
    EntityPath::new(vec![
        EntityPathPart::new(WORLD),
        EntityPathPart::new("episodes"),
        EntityPathPart::new(episode_id),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn class_colours_are_distinct_for_the_first_classes_and_void_is_black() {
        assert_eq!(class_color(0), [0, 0, 0]);
        let colors: Vec<[u8; 3]> = (1..=40).map(class_color).collect();
        for (i, a) in colors.iter().enumerate() {
            for b in &colors[i + 1..] {
                assert_ne!(a, b);
            }
        }
    }

    #[test]
    fn formats_md_shows_how_an_episode_id_is_escaped_in_its_entity_path() {
        let doc = include_str!("../../../docs/FORMATS.md");
        let shown = episode_entity("h1@empty:pointgoal:00003").to_string();
        assert_eq!(shown, r"/world/episodes/h1\@empty\:pointgoal\:00003");
        let mentioned = shown.trim_start_matches('/');
        assert!(
            doc.contains(&format!("`{mentioned}`")),
            "docs/FORMATS.md should show {mentioned}"
        );
        // The id stays one path part whatever it holds.
        assert_eq!(episode_entity("a/b c").len(), 3);
    }
}
