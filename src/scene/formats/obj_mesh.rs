//! Wavefront OBJ (+ MTL) meshes through `tobj`, merged into one indexed [`Mesh`] with a
//! material slot per triangle.

use std::path::Path;

use crate::scene::mesh::{Material, Mesh};

use super::LoadError;

/// Loads an OBJ file and its MTL library. A missing or broken MTL is not fatal: the mesh
/// gets one grey material per name used (real datasets often lack MTL files).
pub fn load_obj(path: &Path) -> Result<Mesh, LoadError> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, materials) = tobj::load_obj(path, &opts).map_err(|e| match e {
        tobj::LoadError::OpenFileFailed => LoadError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "cannot open file"),
        },
        other => LoadError::parse(path, format!("invalid OBJ: {other}")),
    })?;
    let materials = match materials {
        Ok(m) => m,
        Err(e) => {
            tracing::debug!(
                "{}: MTL not loaded ({e}); using default materials",
                path.display()
            );
            Vec::new()
        }
    };
    let mut mesh = Mesh {
        name: path.display().to_string(),
        materials: materials.iter().map(to_material).collect(),
        ..Default::default()
    };
    let mut default_slot: Option<u16> = None;
    let mut needs_normals = false;
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32;
        let nverts = m.positions.len() / 3;
        mesh.positions
            .extend(m.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]));
        if m.normals.len() == m.positions.len() {
            mesh.normals
                .extend(m.normals.chunks_exact(3).map(|n| [n[0], n[1], n[2]]));
        } else {
            needs_normals = true;
            mesh.normals
                .extend(std::iter::repeat_n([0.0, 1.0, 0.0], nverts));
        }
        if m.texcoords.len() / 2 == nverts {
            mesh.uvs
                .extend(m.texcoords.chunks_exact(2).map(|t| [t[0], t[1]]));
        } else {
            mesh.uvs.extend(std::iter::repeat_n([0.0, 0.0], nverts));
        }
        let slot = match m.material_id {
            Some(id) if id < mesh.materials.len() => id as u16,
            _ => *default_slot.get_or_insert_with(|| {
                mesh.materials
                    .push(Material::solid("default", [0.7, 0.7, 0.7]));
                (mesh.materials.len() - 1) as u16
            }),
        };
        mesh.indices.extend(m.indices.iter().map(|i| base + i));
        mesh.face_materials
            .extend(std::iter::repeat_n(slot, m.indices.len() / 3));
    }
    if needs_normals {
        mesh.compute_normals();
    }
    if mesh.uvs.iter().all(|t| *t == [0.0, 0.0]) {
        mesh.uvs.clear();
    }
    Ok(mesh)
}

fn to_material(m: &tobj::Material) -> Material {
    let kd = m.diffuse.unwrap_or([0.7, 0.7, 0.7]);
    Material {
        name: m.name.clone(),
        diffuse: [kd[0], kd[1], kd[2], m.dissolve.unwrap_or(1.0)],
        texture: m.diffuse_texture.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quads_are_triangulated_with_materials_and_normals() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl red\nKd 1 0 0\nnewmtl glass\nKd 0 0 1\nd 0.25\n",
        )
        .unwrap();
        let obj = dir.path().join("m.obj");
        std::fs::write(
            &obj,
            "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 -1\nv 0 0 -1\nv 0 1 0\n\
             usemtl red\nf 1 2 3 4\nusemtl glass\nf 1 2 5\n",
        )
        .unwrap();
        let m = load_obj(&obj).unwrap();
        assert_eq!(m.triangle_count(), 3);
        assert_eq!(m.face_materials, vec![0, 0, 1]);
        assert_eq!(m.materials[1].diffuse, [0.0, 0.0, 1.0, 0.25]);
        // No normals in the file: computed from the counter-clockwise quad, facing +Y.
        assert!((m.normals[2][1] - 1.0).abs() < 1e-6);
        assert!(m.validate().is_ok());
    }

    #[test]
    fn missing_file_is_an_io_error_naming_it() {
        let err = load_obj(Path::new("/nonexistent/x.obj")).unwrap_err();
        assert!(matches!(err, LoadError::Io { .. }));
        assert!(err.to_string().contains("/nonexistent/x.obj"));
    }
}
