//! Reading the Matterport3D house mesh `house_segmentations/<id>.ply` (binary or ASCII PLY,
//! through `ply-rs-bw`) into plain triangles with their per-face labels.
//!
//! Matterport's files have `vertex` elements (`x y z`, normals, texture coordinates, colours)
//! and `face` elements (`vertex_indices`, `material_id`, `segment_id`, `category_id`). Only
//! positions, the index lists and the three face labels are kept; polygons with more than three
//! corners are split into fans. Coordinates stay as in the file (z-up): turning them into
//! scene geometry is [`super`]'s job. Any PLY with `x y z` vertices and index-list faces is
//! accepted; missing face labels read as `-1`.

use std::io::{BufReader, Cursor};

use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{BeginList, DefaultElement, Property, PropertyAccess, PropertyAccessResult};

/// A PLY file that cannot be used, with the reason (one line).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct PlyError(pub String);

/// Triangles and their labels, as read (z-up file coordinates).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlyMesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Triangles (indices into `positions`).
    pub triangles: Vec<[u32; 3]>,
    /// Per-triangle `material_id` (`-1` when absent).
    pub material: Vec<i32>,
    /// Per-triangle `segment_id` (`-1` when absent).
    pub segment: Vec<i32>,
    /// Per-triangle `category_id` (`-1` when absent).
    pub category: Vec<i32>,
    /// Faces skipped because they had fewer than three corners.
    pub degenerate_faces: usize,
}

#[derive(Debug, Default)]
struct Vertex {
    p: [f32; 3],
    /// Bit k set when coordinate k was read.
    seen: u8,
    bad: bool,
}

impl Vertex {
    fn coord(name: &str) -> Option<usize> {
        match name {
            "x" => Some(0),
            "y" => Some(1),
            "z" => Some(2),
            _ => None,
        }
    }
    fn put(&mut self, k: usize, v: f32) {
        if !v.is_finite() {
            self.bad = true;
        }
        self.p[k] = v;
        self.seen |= 1 << k;
    }
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex::default()
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        match Vertex::coord(name) {
            Some(k) => {
                self.put(k, value);
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::Ignored,
        }
    }
    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let Some(k) = Vertex::coord(name) else {
            return PropertyAccessResult::Ignored;
        };
        match property.to_f32_lossy() {
            Some(v) => {
                self.put(k, v);
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
}

#[derive(Debug)]
struct Face {
    ints: Vec<i32>,
    uints: Vec<u32>,
    /// Indices from other list types, `None` when one was negative.
    other: Option<Vec<u32>>,
    labels: [i32; 3],
}

fn label_slot(name: &str) -> Option<usize> {
    match name {
        "material_id" => Some(0),
        "segment_id" => Some(1),
        "category_id" => Some(2),
        _ => None,
    }
}

fn is_index_list(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Face {
            ints: Vec::new(),
            uints: Vec::new(),
            other: Some(Vec::new()),
            labels: [-1; 3],
        }
    }
    fn begin_list_int(&mut self, name: &str, _len: usize) -> BeginList<'_, i32> {
        if is_index_list(name) {
            BeginList::Fill(&mut self.ints)
        } else {
            BeginList::UseSetter
        }
    }
    fn begin_list_uint(&mut self, name: &str, _len: usize) -> BeginList<'_, u32> {
        if is_index_list(name) {
            BeginList::Fill(&mut self.uints)
        } else {
            BeginList::UseSetter
        }
    }
    fn set_int(&mut self, name: &str, value: i32) -> PropertyAccessResult {
        match label_slot(name) {
            Some(k) => {
                self.labels[k] = value;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::Ignored,
        }
    }
    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if is_index_list(name) {
            return match &property {
                Property::ListFloat(_) | Property::ListDouble(_) => {
                    PropertyAccessResult::UnsupportedType
                }
                p => {
                    self.other = p.to_u32_list();
                    PropertyAccessResult::Set
                }
            };
        }
        let Some(k) = label_slot(name) else {
            return PropertyAccessResult::Ignored;
        };
        match property.to_f32_lossy() {
            Some(v) if v.is_finite() => {
                self.labels[k] = v as i32;
                PropertyAccessResult::Set
            }
            Some(_) => PropertyAccessResult::Set,
            None => PropertyAccessResult::UnsupportedType,
        }
    }
}

/// Reads a PLY mesh from its bytes.
pub fn read_ply(bytes: &[u8]) -> Result<PlyMesh, PlyError> {
    // ply-rs-bw's messages span several lines: fold them into one.
    let err = |e: ply_rs_bw::parser::ParseError| {
        let text = e.to_string();
        PlyError(format!(
            "invalid PLY: {}",
            text.split_whitespace().collect::<Vec<_>>().join(" ")
        ))
    };
    let mut reader = Reader::new(BufReader::new(Cursor::new(bytes)));
    let header = Parser::<Vertex>::new()
        .read_header(&mut reader)
        .map_err(err)?;
    let vertex_def = header
        .elements
        .get("vertex")
        .ok_or_else(|| PlyError("no `vertex` element".into()))?;
    for c in ["x", "y", "z"] {
        if !vertex_def.properties.contains_key(c) {
            return Err(PlyError(format!("`vertex` element has no `{c}` property")));
        }
    }
    let face_def = header
        .elements
        .get("face")
        .ok_or_else(|| PlyError("no `face` element".into()))?;
    if !face_def.properties.keys().any(|k| is_index_list(k)) {
        return Err(PlyError(
            "`face` element has no `vertex_indices` list".into(),
        ));
    }
    let mut mesh = PlyMesh::default();
    for (name, def) in &header.elements {
        match name.as_str() {
            "vertex" => {
                let vertices = Parser::<Vertex>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(err)?;
                mesh.positions.reserve(vertices.len());
                for (i, v) in vertices.iter().enumerate() {
                    if v.bad {
                        return Err(PlyError(format!("vertex {i}: non-finite coordinate")));
                    }
                    mesh.positions.push(v.p);
                }
            }
            "face" => {
                let faces = Parser::<Face>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(err)?;
                add_faces(&mut mesh, &faces)?;
            }
            _ => {
                Parser::<DefaultElement>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(err)?;
            }
        }
    }
    let n = mesh.positions.len();
    if let Some((t, i)) = mesh
        .triangles
        .iter()
        .enumerate()
        .find_map(|(t, tri)| tri.iter().find(|&&i| i as usize >= n).map(|&i| (t, i)))
    {
        return Err(PlyError(format!(
            "triangle {t}: vertex index {i} out of range ({n} vertices)"
        )));
    }
    Ok(mesh)
}

fn add_faces(mesh: &mut PlyMesh, faces: &[Face]) -> Result<(), PlyError> {
    mesh.triangles.reserve(faces.len());
    let mut corners: Vec<u32> = Vec::new();
    for (f, face) in faces.iter().enumerate() {
        corners.clear();
        if !face.ints.is_empty() {
            for &i in &face.ints {
                let i = u32::try_from(i)
                    .map_err(|_| PlyError(format!("face {f}: negative vertex index {i}")))?;
                corners.push(i);
            }
        } else if !face.uints.is_empty() {
            corners.extend_from_slice(&face.uints);
        } else {
            match &face.other {
                Some(list) => corners.extend_from_slice(list),
                None => return Err(PlyError(format!("face {f}: negative vertex index"))),
            }
        }
        if corners.len() < 3 {
            mesh.degenerate_faces += 1;
            continue;
        }
        for k in 1..corners.len() - 1 {
            mesh.triangles
                .push([corners[0], corners[k], corners[k + 1]]);
            mesh.material.push(face.labels[0]);
            mesh.segment.push(face.labels[1]);
            mesh.category.push(face.labels[2]);
        }
    }
    Ok(())
}

/// Writes a binary little-endian PLY in Matterport's house-mesh layout: float `x y z`, face
/// `vertex_indices` (uchar count, int indices) and int `material_id segment_id category_id`.
pub fn write_ply(positions: &[[f32; 3]], triangles: &[[u32; 3]], labels: &[[i32; 3]]) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by minos\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nproperty int material_id\n\
         property int segment_id\nproperty int category_id\nend_header\n",
        positions.len(),
        triangles.len()
    )
    .into_bytes();
    out.reserve(positions.len() * 12 + triangles.len() * 25);
    for p in positions {
        for v in p {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    for (t, l) in triangles.iter().zip(labels) {
        out.push(3);
        for i in t {
            out.extend_from_slice(&(*i as i32).to_le_bytes());
        }
        for v in l {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASCII: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
        property float y\nproperty float z\nproperty uchar red\nelement face 2\n\
        property list uchar int vertex_indices\nproperty int material_id\nproperty int segment_id\n\
        property int category_id\nend_header\n\
        0 0 0 255\n1 0 0 255\n1 1 0 255\n0 1 0 255\n4 0 1 2 3 7 12 4\n2 0 1 7 13 5\n";

    #[test]
    fn ascii_quads_become_triangle_fans_with_labels() {
        let m = read_ply(ASCII.as_bytes()).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.segment, vec![12, 12]);
        assert_eq!(m.category, vec![4, 4]);
        assert_eq!(m.material, vec![7, 7]);
        assert_eq!(m.degenerate_faces, 1);
    }

    #[test]
    fn binary_round_trip_of_the_written_layout() {
        let pos = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.5], [0.0, 3.0, 1.0]];
        let bytes = write_ply(&pos, &[[0, 1, 2]], &[[1, 2, 3]]);
        let m = read_ply(&bytes).unwrap();
        assert_eq!(m.positions, pos.to_vec());
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        assert_eq!((m.material[0], m.segment[0], m.category[0]), (1, 2, 3));
    }

    #[test]
    fn double_coordinates_and_missing_labels_are_accepted() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n\
            property double z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n\
            0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        let m = read_ply(text.as_bytes()).unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        assert_eq!(m.category, vec![-1]);
        assert_eq!(m.positions[1], [1.0, 0.0, 0.0]);
    }

    #[test]
    fn broken_files_are_errors_not_panics() {
        let bad_index = ASCII.replace("4 0 1 2 3 7", "4 0 1 2 9 7");
        let e = read_ply(bad_index.as_bytes()).unwrap_err();
        assert!(e.0.contains("vertex index 9 out of range"), "{e}");
        let negative = ASCII.replace("4 0 1 2 3 7", "4 0 -1 2 3 7");
        assert!(read_ply(negative.as_bytes())
            .unwrap_err()
            .0
            .contains("negative"));
        let no_z = ASCII.replace("property float z\n", "");
        assert!(read_ply(no_z.as_bytes()).unwrap_err().0.contains("`z`"));
        let truncated = &ASCII.as_bytes()[..ASCII.len() - 12];
        assert!(read_ply(truncated).is_err());
        assert!(read_ply(b"not a ply")
            .unwrap_err()
            .0
            .contains("invalid PLY"));
        let pos = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.5], [0.0, 3.0, 1.0]];
        let bytes = write_ply(&pos, &[[0, 1, 2]], &[[1, 2, 3]]);
        assert!(read_ply(&bytes[..bytes.len() - 5]).is_err());
        let nan = ASCII.replace("1 1 0 255", "1 nan 0 255");
        assert!(read_ply(nan.as_bytes()).is_err());
    }
}
