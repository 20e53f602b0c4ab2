//! Wavefront OBJ (+ MTL) meshes through `tobj`, merged into one indexed [`Mesh`] with a
//! material slot per triangle.

use crate::file_error::FileError;
use std::cell::RefCell;
use std::path::{Path, PathBuf};

use crate::scene::{Material, Mesh};

use super::{guarded, LoadError};

/// Loads an OBJ file and its MTL library. A missing MTL is not fatal: the mesh gets one grey
/// material per name used (real datasets often lack MTL files). A malformed MTL line is an
/// error naming the MTL file and the line.
pub fn load_obj(path: &Path) -> Result<Mesh, LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io(FileError::new(path, source)))?;
    load_obj_bytes(path, &bytes, &|mtl| std::fs::read(mtl))
}

/// Loads an OBJ mesh from `bytes` (`path` names it in errors and locates its MTL libraries,
/// which `read_mtl` reads). The text is checked before `tobj` sees it (an MTL colour line
/// with fewer than three numbers panics inside tobj 4.0.5), and `tobj` runs under
/// [`std::panic::catch_unwind`], so no input can panic: a panic becomes an error naming the
/// file.
pub fn load_obj_bytes(
    path: &Path,
    bytes: &[u8],
    read_mtl: &dyn Fn(&Path) -> std::io::Result<Vec<u8>>,
) -> Result<Mesh, LoadError> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let mtl_error: RefCell<Option<LoadError>> = RefCell::new(None);
    let load_mtl = |name: &Path| -> tobj::MTLLoadResult {
        let mtl_path: PathBuf = path.parent().map_or(name.to_path_buf(), |d| d.join(name));
        let text = match read_mtl(&mtl_path) {
            Ok(t) => t,
            Err(e) => {
                tracing::debug!(
                    "{}: MTL {} not read ({e}); using default materials",
                    path.display(),
                    mtl_path.display()
                );
                return Err(tobj::LoadError::OpenFileFailed);
            }
        };
        if let Err(e) = check_mtl(&mtl_path, &text) {
            mtl_error.borrow_mut().get_or_insert(e);
            return Err(tobj::LoadError::MaterialParseError);
        }
        guarded(&mtl_path, || tobj::load_mtl_buf(&mut &text[..])).unwrap_or_else(|e| {
            mtl_error.borrow_mut().get_or_insert(e);
            Err(tobj::LoadError::MaterialParseError)
        })
    };
    let loaded = guarded(path, || {
        tobj::load_obj_buf(&mut &bytes[..], &opts, load_mtl)
    })?;
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    let (models, materials) =
        loaded.map_err(|e| LoadError::parse(path, format!("invalid OBJ: {e}")))?;
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

/// Keywords of MTL lines that `tobj` reads as three numbers.
const MTL_COLOURS: [&str; 4] = ["Ka", "Kd", "Ks", "Ke"];

/// Checks the MTL lines `tobj` would panic on: a colour (`Ka`, `Kd`, `Ks`, `Ke`) needs three
/// values (a non-number among them is tobj's own parse error, which drops the library). The error names the file, the line and the keyword.
pub fn check_mtl(path: &Path, text: &[u8]) -> Result<(), LoadError> {
    for (n, line) in text.split(|&b| b == b'\n').enumerate() {
        let line = String::from_utf8_lossy(line);
        let mut words = line.split_whitespace();
        let Some(key) = words.next().filter(|k| MTL_COLOURS.contains(k)) else {
            continue;
        };
        let numbers = words.take(3).count();
        if numbers < 3 {
            return Err(LoadError::parse(
                path,
                format!("line {}: `{key}` needs 3 numbers, found {numbers}", n + 1),
            ));
        }
    }
    Ok(())
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
    fn a_colour_with_two_numbers_is_an_error_naming_the_mtl_and_line_not_a_panic() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl red\nKd 1 0 0\nnewmtl bad\nKd 0.55 0.56\n",
        )
        .unwrap();
        let obj = dir.path().join("m.obj");
        std::fs::write(
            &obj,
            "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 -1\nusemtl red\nf 1 2 3\n",
        )
        .unwrap();
        let err = load_obj(&obj).unwrap_err().to_string();
        assert!(
            err.contains("m.mtl: line 4: `Kd` needs 3 numbers, found 2"),
            "{err}"
        );
        assert!(!err.contains('\n'));
    }

    #[test]
    fn a_panic_inside_the_reader_becomes_an_error_naming_the_file() {
        let err = guarded(Path::new("x.obj"), || -> u32 { panic!("boom") }).unwrap_err();
        assert_eq!(err.to_string(), "x.obj: the reader failed: boom");
    }

    #[test]
    fn missing_file_is_an_io_error_naming_it() {
        let err = load_obj(Path::new("/nonexistent/x.obj")).unwrap_err();
        assert!(matches!(err, LoadError::Io(FileError { .. })));
        assert!(err.to_string().contains("/nonexistent/x.obj"));
    }
}
