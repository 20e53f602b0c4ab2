//! Textures with answers known in advance: a quad with a 2×2 checker seen head-on shows each
//! texel (times the flat shading of the same material) on the CPU and wgpu renderers; on an
//! oblique floor the texel boundary lies where the world midpoint projects (perspective-
//! correct, not the screen midpoint); a missing texture file falls back to the flat colour.

use crate::common;

use std::path::Path;

use glam::{Mat4, Vec3};
use minos::render::gpu::GpuRenderer;
use minos::render::{cpu, Camera, RenderScene};
use minos::scene::{Aabb, Categories, Dataset, Level, Material, Mesh, Object, ObjectFlags, Scene};

/// Top row red, green; bottom row blue, white (v = 0 is the bottom row).
const CHECKER: [[u8; 3]; 4] = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]];
/// The material colour the texture is multiplied with.
const TINT: [f32; 3] = [1.0, 0.5, 0.8];

fn write_checker(dir: &Path) {
    let img = image::RgbImage::from_fn(2, 2, |x, y| image::Rgb(CHECKER[(y * 2 + x) as usize]));
    img.save(dir.join("checker.png")).unwrap();
}

/// One object: a quad with corners `p` (CCW seen from the camera), UVs (0,0), (1,0), (1,1),
/// (0,1), textured with `texture` (resolved beside `dir/quad.obj`).
fn quad_scene(dir: &Path, p: [[f32; 3]; 4], texture: &str) -> Scene {
    let mut mesh = Mesh {
        name: dir.join("quad.obj").display().to_string(),
        positions: p.to_vec(),
        uvs: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
        indices: vec![0, 1, 2, 0, 2, 3],
        face_materials: vec![0, 0],
        materials: vec![Material {
            name: "board".into(),
            diffuse: [TINT[0], TINT[1], TINT[2], 1.0],
            texture: Some(texture.into()),
        }],
        ..Default::default()
    };
    mesh.compute_normals();
    let bbox = mesh.bounds();
    Scene {
        id: "quad".into(),
        dataset: Dataset::Suncg,
        levels: vec![Level {
            index: 0,
            bbox,
            floor_heights: vec![0.0],
            rooms: vec![],
            objects: vec![Object {
                id: "0_0".into(),
                model_id: "board".into(),
                categories: Categories::default(),
                transform: Mat4::IDENTITY,
                bbox: Aabb::from_corners(bbox.min, bbox.max),
                mesh: Some(0),
                materials: vec![],
                flags: ObjectFlags::default(),
                rooms: vec![],
            }],
            ground: vec![],
        }],
        meshes: vec![mesh],
    }
}

fn camera(size: u32) -> Camera {
    Camera {
        position: Vec3::new(0.0, 1.0, 0.0),
        yaw: 0.0,
        tilt: 0.0,
        vfov_deg: 90.0,
        width: size,
        height: size,
        near: 0.01,
        far: 20.0,
    }
}

/// A 2 m square at z = −1 filling a 90° view from (0, 1, 0).
const HEAD_ON: [[f32; 3]; 4] = [
    [-1.0, 0.0, -1.0],
    [1.0, 0.0, -1.0],
    [1.0, 2.0, -1.0],
    [-1.0, 2.0, -1.0],
];

/// The renderers to check: CPU always, wgpu when an adapter exists.
fn render_all(rs: &RenderScene, cam: &Camera) -> Vec<(&'static str, Vec<[u8; 3]>)> {
    let mut out = vec![("cpu", cpu::render(rs, cam).color(rs, cam))];
    match GpuRenderer::new() {
        Ok(mut g) => {
            g.upload(rs).unwrap();
            let frame = g.render_batch(&[*cam]).unwrap().remove(0);
            out.push(("wgpu", frame.color(rs, cam)));
        }
        Err(e) => common::skip(format!("the wgpu part: {e}")),
    }
    out
}

fn close(a: [u8; 3], b: [f32; 3], tol: f32) -> bool {
    (0..3).all(|k| (f32::from(a[k]) - b[k]).abs() <= tol)
}

#[test]
fn a_checker_quad_seen_head_on_shows_each_texel_times_the_flat_colour() {
    let dir = tempfile::tempdir().unwrap();
    write_checker(dir.path());
    let size = 64;
    let cam = camera(size);
    // The same quad with a texture that does not exist: the flat material colour.
    let flat_rs = RenderScene::new(&quad_scene(dir.path(), HEAD_ON, "no_such_texture.png"));
    assert!(flat_rs.textures.is_empty());
    let flat = cpu::render(&flat_rs, &cam).color(&flat_rs, &cam);
    let f = flat[(size * size / 2 + size / 2) as usize];
    assert!(f[0] > 100, "the quad fills the view: {f:?}");
    assert!(
        flat.iter().all(|&c| c == f),
        "missing texture: one flat colour"
    );
    // Independent of the texture code: flat = tint × shade.
    let shade = f32::from(f[0]) / 255.0 / TINT[0];
    assert!(close(f, TINT.map(|t| t * shade * 255.0), 1.0), "{f:?}");

    let rs = RenderScene::new(&quad_scene(dir.path(), HEAD_ON, "checker.png"));
    assert_eq!(rs.textures.len(), 1);
    for (name, img) in render_all(&rs, &cam) {
        // Quadrant centres: top-left shows the image's top-left texel, and so on.
        for (k, (x, y)) in [(16u32, 16u32), (48, 16), (16, 48), (48, 48)]
            .into_iter()
            .enumerate()
        {
            let got = img[(y * size + x) as usize];
            let want: [f32; 3] =
                std::array::from_fn(|c| f32::from(CHECKER[k][c]) / 255.0 * f32::from(f[c]));
            // Pixel centres sit 1/128 of the quad off the texel centres along each axis: at
            // most 1.6 % + 1.6 % of the neighbouring texels mix in (≤ 8/255).
            assert!(
                close(got, want, 8.0),
                "{name}: pixel ({x}, {y}) is {got:?}, want {want:?}"
            );
        }
    }
}

#[test]
fn texture_coordinates_are_perspective_correct_on_an_oblique_floor() {
    let dir = tempfile::tempdir().unwrap();
    write_checker(dir.path());
    let size = 64;
    let cam = camera(size);
    // A floor from z = −1 (v = 0) to z = −5 (v = 1), 2 m wide: its v = 0.5 boundary is at
    // z = −3, which projects 1/3 below the centre, on row 42.7; the screen midpoint of the
    // floor's rows (64 and 38.4) would be row 51.2.
    let floor = [
        [-1.0, 0.0, -1.0],
        [1.0, 0.0, -1.0],
        [1.0, 0.0, -5.0],
        [-1.0, 0.0, -5.0],
    ];
    let rs = RenderScene::new(&quad_scene(dir.path(), floor, "checker.png"));
    for (name, img) in render_all(&rs, &cam) {
        // Column 26 lies on the left half (u in 0.18–0.40 over these rows): near rows show
        // the bottom-left texel (blue), far rows the top-left one (red).
        let px = |y: u32| img[(y * size + 26) as usize];
        let blueish = |c: [u8; 3]| c[2] > 3 * c[0].max(c[1]).max(1) / 2;
        let reddish = |c: [u8; 3]| c[0] > 3 * c[1].max(c[2]).max(1) / 2;
        for y in [40, 41] {
            assert!(reddish(px(y)), "{name}: row {y} {:?} (far texel)", px(y));
        }
        for y in [46, 50, 60] {
            assert!(blueish(px(y)), "{name}: row {y} {:?} (near texel)", px(y));
        }
    }
}
