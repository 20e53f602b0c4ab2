//! glTF 2.0 (`.gltf` with embedded or external buffers, `.glb`) meshes through the `gltf`
//! crate, flattened into one indexed [`Mesh`] in the file's scene space.
//!
//! Images are not decoded: a material keeps its texture's name, nothing more.

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat3, Mat4, Vec3};

use crate::scene::mesh::{Material, Mesh};

use super::LoadError;

/// Loads every triangle primitive of the default scene (or of all root nodes when there is
/// no scene), applying node transforms.
pub fn load_gltf(path: &Path) -> Result<Mesh, LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let gltf = gltf::Gltf::from_slice(&bytes)
        .map_err(|e| LoadError::parse(path, format!("invalid glTF: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = gltf::import_buffers(&gltf.document, Some(base), gltf.blob.clone())
        .map_err(|e| LoadError::parse(path, format!("glTF buffers: {e}")))?;
    let mut out = Mesh {
        name: path.display().to_string(),
        ..Default::default()
    };
    let mut slots: HashMap<Option<usize>, u16> = HashMap::new();
    let roots: Vec<gltf::Node> = match gltf
        .document
        .default_scene()
        .or_else(|| gltf.document.scenes().next())
    {
        Some(scene) => scene.nodes().collect(),
        None => gltf.document.nodes().collect(),
    };
    let mut stack: Vec<(gltf::Node, Mat4)> =
        roots.into_iter().map(|n| (n, Mat4::IDENTITY)).collect();
    let mut visited = 0usize;
    while let Some((node, parent)) = stack.pop() {
        visited += 1;
        if visited > 1_000_000 {
            return Err(LoadError::parse(path, "node hierarchy too deep or cyclic"));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    continue;
                }
                add_primitive(path, &prim, &world, &buffers, &mut out, &mut slots)?;
            }
        }
        for child in node.children() {
            stack.push((child, world));
        }
    }
    if out.uvs.iter().all(|t| *t == [0.0, 0.0]) {
        out.uvs.clear();
    }
    if out.materials.is_empty() {
        out.materials
            .push(Material::solid("default", [0.7, 0.7, 0.7]));
    }
    Ok(out)
}

fn add_primitive(
    path: &Path,
    prim: &gltf::Primitive,
    world: &Mat4,
    buffers: &[gltf::buffer::Data],
    out: &mut Mesh,
    slots: &mut HashMap<Option<usize>, u16>,
) -> Result<(), LoadError> {
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let Some(positions) = reader.read_positions() else {
        return Err(LoadError::parse(path, "primitive without POSITION"));
    };
    let normal_matrix = Mat3::from_mat4(*world).inverse().transpose();
    let base = out.positions.len() as u32;
    let positions: Vec<[f32; 3]> = positions
        .map(|p| world.transform_point3(Vec3::from_array(p)).to_array())
        .collect();
    let n = positions.len();
    let normals: Option<Vec<[f32; 3]>> = reader.read_normals().map(|it| {
        it.map(|v| {
            (normal_matrix * Vec3::from_array(v))
                .try_normalize()
                .unwrap_or(Vec3::Y)
                .to_array()
        })
        .collect()
    });
    let uvs: Option<Vec<[f32; 2]>> = reader.read_tex_coords(0).map(|t| t.into_f32().collect());
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..n as u32).collect(),
    };
    if !indices.len().is_multiple_of(3) {
        return Err(LoadError::parse(
            path,
            "triangle primitive index count not a multiple of 3",
        ));
    }
    if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
        return Err(LoadError::parse(
            path,
            format!("index {bad} out of range ({n} vertices)"),
        ));
    }
    let mirrored = world.determinant() < 0.0;
    out.positions.extend(positions);
    let had_normals = normals.as_ref().is_some_and(|v| v.len() == n);
    match normals {
        Some(v) if v.len() == n => out.normals.extend(v),
        _ => out.normals.extend(std::iter::repeat_n([0.0, 1.0, 0.0], n)),
    }
    match uvs {
        Some(v) if v.len() == n => out.uvs.extend(v),
        _ => out.uvs.extend(std::iter::repeat_n([0.0, 0.0], n)),
    }
    let first_tri = out.indices.len();
    for t in indices.chunks_exact(3) {
        if mirrored {
            out.indices.extend([base + t[0], base + t[2], base + t[1]]);
        } else {
            out.indices.extend([base + t[0], base + t[1], base + t[2]]);
        }
    }
    let material = prim.material();
    let key = material.index();
    let slot = match slots.get(&key) {
        Some(s) => *s,
        None => {
            let s = out.materials.len() as u16;
            out.materials.push(to_material(&material));
            slots.insert(key, s);
            s
        }
    };
    out.face_materials.extend(std::iter::repeat_n(
        slot,
        (out.indices.len() - first_tri) / 3,
    ));
    if !had_normals {
        // Flat normals for this primitive only.
        for t in out.indices[first_tri..].chunks_exact(3) {
            let p = |i: u32| Vec3::from_array(out.positions[i as usize]);
            let nrm = (p(t[1]) - p(t[0]))
                .cross(p(t[2]) - p(t[0]))
                .try_normalize()
                .unwrap_or(Vec3::Y);
            for &i in t {
                out.normals[i as usize] = nrm.to_array();
            }
        }
    }
    Ok(())
}

fn to_material(m: &gltf::Material) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let texture = pbr.base_color_texture().map(|t| {
        let tex = t.texture();
        let img = tex.source();
        tex.name()
            .or(img.name())
            .map(str::to_string)
            .unwrap_or_else(|| format!("image_{}", img.index()))
    });
    Material {
        name: m
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("material_{}", m.index().unwrap_or(0))),
        diffuse: pbr.base_color_factor(),
        texture,
    }
}
