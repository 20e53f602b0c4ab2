//! Geometry of the 3D-FRONT loader: child transforms (`pos`, `rot` quaternion, `scale`),
//! inline architecture meshes (`xyz`/`normal`/`uv`/`faces`) as model-space [`Mesh`]es, the
//! unit box that stands for furniture without a model file, furniture extents, and merging
//! placed meshes into one world-space surface.
//!
//! Functions here check values (finite, in range, a usable rotation) and say what is wrong in a
//! message that names the field; the caller adds the file and the record. Nothing here knows
//! rooms or objects.

use glam::{Mat4, Quat, Vec3};

use crate::invalid::Invalid;
use crate::scene::{Material, Mesh, WorldMesh};

use super::json::{ChildJson, FurnitureJson, MeshJson};

/// Largest coordinate magnitude accepted (metres); beyond it a value is garbage.
const MAX_COORD: f64 = 1e7;

/// Reads `values` as exactly `n` finite numbers; the error names `field`.
fn fixed(field: &str, values: &[Option<f64>], n: usize) -> Result<Vec<f32>, Invalid> {
    if values.len() != n {
        return Err(format!("`{field}` has {} values, expected {n}", values.len()).into());
    }
    values
        .iter()
        .enumerate()
        .map(|(i, v)| finite(field, i, *v))
        .collect()
}

fn finite(field: &str, i: usize, v: Option<f64>) -> Result<f32, Invalid> {
    match v {
        Some(v) if v.is_finite() && v.abs() < MAX_COORD => Ok(v as f32),
        Some(v) => Err(format!("`{field}[{i}]` is {v}, not a finite coordinate").into()),
        None => Err(format!("`{field}[{i}]` is NaN, infinite or null").into()),
    }
}

/// The model-to-world transform of a child: translate(`pos`) · rotate(`rot`) · scale(`scale`),
/// as the 3D-FRONT ToolBox applies it. `rot` is a quaternion `[x, y, z, w]`, normalised here;
/// missing fields mean identity. Negative scales (mirrors) are kept.
pub(super) fn child_transform(child: &ChildJson) -> Result<Mat4, Invalid> {
    let pos = match &child.pos {
        Some(p) => Vec3::from_slice(&fixed("pos", p, 3)?),
        None => Vec3::ZERO,
    };
    let rot = match &child.rot {
        Some(r) => {
            let q = fixed("rot", r, 4)?;
            let q = Quat::from_xyzw(q[0], q[1], q[2], q[3]);
            let len = q.length();
            if !len.is_finite() || len <= 1e-6 {
                return Err(format!(
                    "`rot` {:?} is not a rotation (quaternion of length {len})",
                    q.to_array()
                )
                .into());
            }
            q / len
        }
        None => Quat::IDENTITY,
    };
    let scale = match &child.scale {
        Some(s) => {
            let s = Vec3::from_slice(&fixed("scale", s, 3)?);
            if let Some(i) = (0..3).find(|&i| s[i].abs() < 1e-9) {
                return Err(format!("`scale[{i}]` is 0: the transform is singular").into());
            }
            s
        }
        None => Vec3::ONE,
    };
    Ok(Mat4::from_scale_rotation_translation(scale, rot, pos))
}

/// An inline architecture mesh in its own space (for architecture, that is world space before
/// the child's transform). Normals are used when the file's are unit vectors, recomputed from
/// the faces otherwise; `uv` is kept when it has one pair per vertex.
pub(super) fn inline_mesh(m: &MeshJson, name: &str, material: Material) -> Result<Mesh, Invalid> {
    let xyz = m.xyz.as_deref().ok_or("missing field `xyz`")?;
    if !xyz.len().is_multiple_of(3) {
        return Err(format!("`xyz` has {} values, not a multiple of 3", xyz.len()).into());
    }
    let positions: Vec<[f32; 3]> = xyz
        .chunks_exact(3)
        .enumerate()
        .map(|(k, c)| {
            Ok([
                finite("xyz", 3 * k, c[0])?,
                finite("xyz", 3 * k + 1, c[1])?,
                finite("xyz", 3 * k + 2, c[2])?,
            ])
        })
        .collect::<Result<_, Invalid>>()?;
    let n = positions.len();
    let faces = m.faces.as_deref().ok_or("missing field `faces`")?;
    if !faces.len().is_multiple_of(3) {
        return Err(format!("`faces` has {} indices, not a multiple of 3", faces.len()).into());
    }
    let indices: Vec<u32> = faces
        .iter()
        .enumerate()
        .map(|(k, &i)| {
            if i >= 0 && (i as u64) < n as u64 {
                Ok(i as u32)
            } else {
                Err(format!("`faces[{k}]` is {i}, out of range for {n} vertices").into())
            }
        })
        .collect::<Result<_, Invalid>>()?;
    let mut mesh = Mesh {
        name: name.to_string(),
        positions,
        face_materials: vec![0; indices.len() / 3],
        indices,
        materials: vec![material],
        ..Default::default()
    };
    match m.normal.as_deref().and_then(|v| unit_normals(v, n)) {
        Some(normals) => mesh.normals = normals,
        None => mesh.compute_normals(),
    }
    if let Some(uv) = m.uv.as_deref().filter(|uv| uv.len() == 2 * n) {
        let uvs: Option<Vec<[f32; 2]>> = uv
            .chunks_exact(2)
            .map(|c| match (c[0], c[1]) {
                (Some(u), Some(v)) if u.is_finite() && v.is_finite() => Some([u as f32, v as f32]),
                _ => None,
            })
            .collect();
        mesh.uvs = uvs.unwrap_or_default();
    }
    Ok(mesh)
}

/// The file's normals when there is one finite unit vector per vertex.
fn unit_normals(v: &[Option<f64>], n: usize) -> Option<Vec<[f32; 3]>> {
    if v.len() != 3 * n {
        return None;
    }
    v.chunks_exact(3)
        .map(|c| {
            let n = Vec3::new(c[0]? as f32, c[1]? as f32, c[2]? as f32);
            (n.is_finite() && (n.length() - 1.0).abs() < 0.05).then(|| n.normalize().to_array())
        })
        .collect()
}

/// A box one metre on each side standing on the origin: x and z in [−½, ½], y in [0, 1]
/// (the placement convention of 3D-FUTURE models: origin at the bottom centre), with flat
/// faces wound counter-clockwise outside ([`Mesh::push_box`]).
pub fn unit_box() -> Mesh {
    let mut mesh = Mesh {
        name: "3dfront/unit_box".into(),
        materials: vec![Material::solid("furniture_box", [0.6, 0.55, 0.5])],
        ..Default::default()
    };
    let bottom = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]];
    let [b0, b1, b2, b3] = bottom.map(|[x, z]| Vec3::new(x, 0.0, z));
    mesh.push_box([b0, b1, b2, b3, b0 + Vec3::Y, b1 + Vec3::Y, b2 + Vec3::Y, b3 + Vec3::Y], 0);
    mesh
}

/// The extents (x, y, z) of a furniture model in metres, or `None` when the file gives none.
///
/// `size` is read as (length x, depth z, height y) — the order of the design tool; `bbox`, used
/// when `size` is absent, as (x, y, z), either flat or as a list holding one triple. Errors
/// name the field holding a non-finite or negative value.
pub(super) fn furniture_extent(f: &FurnitureJson) -> Result<Option<Vec3>, Invalid> {
    if let Some(size) = f.size.as_deref().filter(|s| !s.is_empty()) {
        let s = fixed("size", size, 3)?;
        return positive("size", Vec3::new(s[0], s[2], s[1])).map(Some);
    }
    let Some(bbox) = &f.bbox else {
        return Ok(None);
    };
    let triple = match bbox.as_array() {
        Some(a) if a.len() == 1 && a[0].is_array() => a[0].as_array(),
        Some(a) => Some(a),
        None => None,
    };
    let Some(triple) = triple.filter(|t| !t.is_empty()) else {
        return Ok(None);
    };
    let values: Vec<Option<f64>> = triple.iter().map(|v| v.as_f64()).collect();
    let b = fixed("bbox", &values, 3)?;
    positive("bbox", Vec3::from_slice(&b)).map(Some)
}

fn positive(field: &str, v: Vec3) -> Result<Vec3, Invalid> {
    if v.min_element() < 0.0 {
        return Err(format!("`{field}` {v} has a negative extent").into());
    }
    // A flat model (a rug) keeps a sliver of thickness so its transform stays invertible.
    Ok(v.max(Vec3::splat(1e-3)))
}

/// Appends `src` placed by `transform` (winding fixed for mirrors) to the world-space mesh
/// `dst`, sharing material slots by name.
pub(super) fn append_placed(dst: &mut Mesh, src: &Mesh, transform: &Mat4) {
    let placed = WorldMesh::place(src, transform);
    let base = dst.positions.len();
    if !src.uvs.is_empty() && dst.uvs.len() < base {
        dst.uvs.resize(base, [0.0, 0.0]);
    }
    dst.positions
        .extend(placed.positions.iter().map(|p| p.to_array()));
    dst.normals
        .extend(placed.normals.iter().map(|n| n.to_array()));
    if !src.uvs.is_empty() {
        dst.uvs.extend_from_slice(&src.uvs);
    } else if !dst.uvs.is_empty() {
        dst.uvs.resize(dst.positions.len(), [0.0, 0.0]);
    }
    dst.indices
        .extend(placed.indices.iter().map(|i| i + base as u32));
    let slots: Vec<u16> = src
        .materials
        .iter()
        .map(
            |m| match dst.materials.iter().position(|d| d.name == m.name) {
                Some(i) => i as u16,
                None => {
                    dst.materials.push(m.clone());
                    (dst.materials.len() - 1) as u16
                }
            },
        )
        .collect();
    dst.face_materials.extend(
        placed
            .face_materials
            .iter()
            .map(|&s| slots.get(s as usize).copied().unwrap_or(0)),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn child(pos: &str, rot: &str, scale: &str) -> ChildJson {
        serde_json::from_str(&format!(
            r#"{{"ref": "r", "pos": {pos}, "rot": {rot}, "scale": {scale}}}"#
        ))
        .unwrap()
    }

    #[test]
    fn transforms_scale_then_rotate_then_translate() {
        // A quarter turn about +Y (x → −z), scale x by 2, then move up by 1.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let c = child("[0, 1, 0]", &format!("[0, {h}, 0, {h}]"), "[2, 1, 1]");
        let m = child_transform(&c).unwrap();
        let p = m.transform_point3(Vec3::new(1.0, 0.0, 0.0));
        assert!((p - Vec3::new(0.0, 1.0, -2.0)).length() < 1e-5, "{p}");
    }

    #[test]
    fn unnormalised_quaternions_are_normalised_and_zero_ones_rejected() {
        let c = child("[0, 0, 0]", "[0, 0, 0, 2]", "[1, 1, 1]");
        assert!((child_transform(&c).unwrap().determinant() - 1.0).abs() < 1e-6);
        let err = child_transform(&child("[0, 0, 0]", "[0, 0, 0, 0]", "[1, 1, 1]")).unwrap_err();
        assert!(
            err.to_string().contains("`rot`") && err.to_string().contains("not a rotation"),
            "{err}"
        );
    }

    #[test]
    fn bad_fields_are_named() {
        let err = child_transform(&child("[0, null, 0]", "[0, 0, 0, 1]", "[1, 1, 1]")).unwrap_err();
        assert!(err.to_string().contains("`pos[1]`"), "{err}");
        let err = child_transform(&child("[0, 0]", "[0, 0, 0, 1]", "[1, 1, 1]")).unwrap_err();
        assert!(err.to_string().contains("`pos` has 2 values"), "{err}");
        let err = child_transform(&child("[0, 0, 0]", "[0, 0, 0, 1]", "[1, 0, 1]")).unwrap_err();
        assert!(err.to_string().contains("`scale[1]` is 0"), "{err}");
        let err =
            child_transform(&child("[0, 1e300, 0]", "[0, 0, 0, 1]", "[1, 1, 1]")).unwrap_err();
        assert!(err.to_string().contains("`pos[1]`"), "{err}");
    }

    #[test]
    fn negative_scale_mirrors() {
        let c = child("[0, 0, 0]", "[0, 0, 0, 1]", "[-1, 1, 1]");
        assert!(child_transform(&c).unwrap().determinant() < 0.0);
    }

    #[test]
    fn unit_box_is_closed_outward_and_valid() {
        let b = unit_box();
        assert!(b.validate().is_ok());
        assert_eq!(b.triangle_count(), 12);
        let bounds = b.bounds();
        assert_eq!(bounds.min, Vec3::new(-0.5, 0.0, -0.5));
        assert_eq!(bounds.max, Vec3::new(0.5, 1.0, 0.5));
        let w = WorldMesh::place(&b, &Mat4::IDENTITY);
        for t in 0..12 {
            let n = w.face_normal(t).normalize();
            assert!(
                n.dot(w.normals[w.indices[3 * t] as usize]) > 0.99,
                "face {t}"
            );
            // Outward: the normal points away from the box centre.
            let c = w.positions[w.indices[3 * t] as usize] - Vec3::new(0.0, 0.5, 0.0);
            assert!(n.dot(c) > 0.0, "face {t}");
        }
    }

    fn mesh_json(text: &str) -> MeshJson {
        serde_json::from_str(text).unwrap()
    }

    #[test]
    fn inline_meshes_recompute_non_unit_normals_and_check_faces() {
        let m = mesh_json(
            r#"{"uid": "m", "type": "Floor", "xyz": [0,0,0, 1,0,0, 0,0,-1],
                "normal": [5,1,5, 5,1,5, 5,1,5], "uv": [0,0, 1,0, 0,1], "faces": [0,1,2]}"#,
        );
        let mesh = inline_mesh(&m, "m", Material::solid("x", [1.0; 3])).unwrap();
        assert!(mesh.validate().is_ok());
        assert_eq!(mesh.normals[0], [0.0, 1.0, 0.0]);
        assert_eq!(mesh.uvs.len(), 3);
        let bad = mesh_json(r#"{"xyz": [0,0,0, 1,0,0, 0,0,-1], "faces": [0,1,3]}"#);
        let err = inline_mesh(&bad, "m", Material::solid("x", [1.0; 3])).unwrap_err();
        assert!(err.to_string().contains("`faces[2]` is 3"), "{err}");
        let bad = mesh_json(r#"{"xyz": [0,0,0, 1,null,0, 0,0,-1], "faces": [0,1,2]}"#);
        let err = inline_mesh(&bad, "m", Material::solid("x", [1.0; 3])).unwrap_err();
        assert!(err.to_string().contains("`xyz[4]`"), "{err}");
        let bad = mesh_json(r#"{"xyz": [0,0,0, 1,0], "faces": []}"#);
        assert!(inline_mesh(&bad, "m", Material::solid("x", [1.0; 3]))
            .unwrap_err()
            .to_string()
            .contains("multiple of 3"));
    }

    fn furniture(text: &str) -> FurnitureJson {
        serde_json::from_str(text).unwrap()
    }

    #[test]
    fn furniture_extents_read_size_as_xzy_and_bbox_as_xyz() {
        let f = furniture(r#"{"size": [2, 0.5, 1], "bbox": [9, 9, 9]}"#);
        assert_eq!(
            furniture_extent(&f).unwrap(),
            Some(Vec3::new(2.0, 1.0, 0.5))
        );
        let f = furniture(r#"{"bbox": [[2, 1, 0.5]]}"#);
        assert_eq!(
            furniture_extent(&f).unwrap(),
            Some(Vec3::new(2.0, 1.0, 0.5))
        );
        assert_eq!(furniture_extent(&furniture("{}")).unwrap(), None);
        let err = furniture_extent(&furniture(r#"{"size": [1, -2, 1]}"#)).unwrap_err();
        assert!(err.to_string().contains("negative"), "{err}");
        let err = furniture_extent(&furniture(r#"{"bbox": [1, "x", 1]}"#)).unwrap_err();
        assert!(err.to_string().contains("`bbox[1]`"), "{err}");
    }

    #[test]
    fn appending_a_mirrored_mesh_keeps_faces_up_and_shares_materials() {
        let m = mesh_json(r#"{"xyz": [0,0,0, 1,0,0, 0,0,-1], "faces": [0,1,2]}"#);
        let tri = inline_mesh(&m, "t", Material::solid("floor", [1.0; 3])).unwrap();
        let mut dst = Mesh::default();
        append_placed(&mut dst, &tri, &Mat4::IDENTITY);
        append_placed(&mut dst, &tri, &Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
        assert!(dst.validate().is_ok());
        assert_eq!(dst.materials.len(), 1);
        let w = WorldMesh::place(&dst, &Mat4::IDENTITY);
        assert!(w.face_normal(0).y > 0.0 && w.face_normal(1).y > 0.0);
    }
}
