//! Indexed triangle meshes, materials, and placing a mesh in the world.

use glam::{Mat3, Mat4, Vec3};
use serde::{Deserialize, Serialize};

use crate::invalid::Invalid;

use super::geometry::Aabb;

/// A surface appearance: a diffuse colour and, where the dataset has one, a texture name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// The name the source file gives the material.
    pub name: String,
    /// Linear RGBA diffuse colour in `[0, 1]`; alpha below 1 means translucent.
    pub diffuse: [f32; 4],
    /// Texture name or path as the dataset gives it (not loaded by ingest; the renderers
    /// resolve it next to the mesh file or in SUNCG's `texture/` folder, see
    /// [`crate::render::texture_library`]).
    pub texture: Option<String>,
}

impl Material {
    /// An opaque material of one colour.
    pub fn solid(name: impl Into<String>, rgb: [f32; 3]) -> Self {
        Material {
            name: name.into(),
            diffuse: [rgb[0], rgb[1], rgb[2], 1.0],
            texture: None,
        }
    }
}

/// An indexed triangle mesh in its own (model) space, shared by every instance that uses it.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    /// Where the mesh came from (a file path, or a name for generated meshes).
    pub name: String,
    /// Vertex positions in metres.
    pub positions: Vec<[f32; 3]>,
    /// Unit vertex normals, one per position.
    pub normals: Vec<[f32; 3]>,
    /// Texture coordinates, one per position, or empty when the mesh has none. OBJ/OpenGL
    /// convention: v = 0 is the bottom row of the image (glTF's v is flipped on load and
    /// on export).
    pub uvs: Vec<[f32; 2]>,
    /// Three vertex indices per triangle, counter-clockwise seen from the front.
    pub indices: Vec<u32>,
    /// Material slot of each triangle (index into `materials`).
    pub face_materials: Vec<u16>,
    /// The material slots.
    pub materials: Vec<Material>,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Box of all vertices in model space.
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(self.positions.iter().map(|p| Vec3::from_array(*p)))
    }

    /// Box of all vertices after `transform`, computed from every vertex (exact).
    pub fn world_bounds(&self, transform: &Mat4) -> Aabb {
        Aabb::from_points(
            self.positions
                .iter()
                .map(|p| transform.transform_point3(Vec3::from_array(*p))),
        )
    }

    /// Recomputes vertex normals as the area-weighted average of adjacent face normals.
    pub fn compute_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for t in self.indices.chunks_exact(3) {
            let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
            let (pa, pb, pc) = (
                Vec3::from_array(self.positions[a]),
                Vec3::from_array(self.positions[b]),
                Vec3::from_array(self.positions[c]),
            );
            let n = (pb - pa).cross(pc - pa);
            acc[a] += n;
            acc[b] += n;
            acc[c] += n;
        }
        self.normals = acc
            .into_iter()
            .map(|n| n.try_normalize().unwrap_or(Vec3::Y).to_array())
            .collect();
    }

    /// Appends a closed box with flat faces in material `slot`: bottom corners `c[0..4]` in
    /// order around the box, top corner `c[4 + k]` above `c[k]` (any box, not only an
    /// axis-aligned one). Each face has its own four vertices with the face's unit normal and
    /// two triangles wound counter-clockwise seen from outside, whichever way the corners go
    /// round. Faces come bottom, top, then the four sides from `c[0]–c[1]` on.
    ///
    /// The one box builder: 3D-FRONT's furniture stand-in, the Matterport3D proxies' unit
    /// box and their wall slabs all come from here.
    pub fn push_box(&mut self, c: [Vec3; 8], slot: u16) {
        let centre = c.iter().copied().sum::<Vec3>() / 8.0;
        let sides = [0, 1, 2, 3].map(|k| [k, (k + 1) % 4, 4 + (k + 1) % 4, 4 + k]);
        for f in [[0, 1, 2, 3], [4, 5, 6, 7]].into_iter().chain(sides) {
            let q = f.map(|k| c[k]);
            let mid = (q[0] + q[1] + q[2] + q[3]) / 4.0;
            let n = (q[1] - q[0]).cross(q[2] - q[0]) + (q[2] - q[0]).cross(q[3] - q[0]);
            let (q, n) = if n.dot(mid - centre) >= 0.0 {
                (q, n)
            } else {
                ([q[0], q[3], q[2], q[1]], -n)
            };
            let base = self.positions.len() as u32;
            self.positions.extend(q.map(|v| v.to_array()));
            self.normals
                .extend([n.try_normalize().unwrap_or(Vec3::Y).to_array(); 4]);
            if !self.uvs.is_empty() {
                self.uvs.extend([[0.0; 2]; 4]);
            }
            self.indices
                .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
            self.face_materials.extend([slot; 2]);
        }
    }

    /// Checks the invariants every stage relies on; returns what is wrong.
    pub fn validate(&self) -> Result<(), Invalid> {
        let n = self.positions.len();
        if !self.indices.len().is_multiple_of(3) {
            return Err(format!("{} indices is not a multiple of 3", self.indices.len()).into());
        }
        if let Some(bad) = self.indices.iter().find(|&&i| i as usize >= n) {
            return Err(format!("index {bad} out of range for {n} vertices").into());
        }
        if self.normals.len() != n {
            return Err(format!("{} normals for {n} vertices", self.normals.len()).into());
        }
        if !self.uvs.is_empty() && self.uvs.len() != n {
            return Err(format!("{} uvs for {n} vertices", self.uvs.len()).into());
        }
        if self.face_materials.len() != self.triangle_count() {
            return Err(format!(
                "{} face materials for {} triangles",
                self.face_materials.len(),
                self.triangle_count()
            )
            .into());
        }
        if let Some(bad) = self
            .face_materials
            .iter()
            .find(|&&m| m as usize >= self.materials.len())
        {
            return Err(format!(
                "material slot {bad} out of range for {} materials",
                self.materials.len()
            )
            .into());
        }
        if let Some(p) = self
            .positions
            .iter()
            .find(|p| !p.iter().all(|v| v.is_finite()))
        {
            return Err(format!("non-finite vertex position {p:?}").into());
        }
        Ok(())
    }
}

/// A mesh placed in the world: world-space positions and normals, with the triangle winding
/// flipped when the transform mirrors (negative determinant), so front faces stay front faces.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WorldMesh {
    /// World positions.
    pub positions: Vec<Vec3>,
    /// World unit normals.
    pub normals: Vec<Vec3>,
    /// Triangle indices (winding corrected).
    pub indices: Vec<u32>,
    /// Material slot of each triangle.
    pub face_materials: Vec<u16>,
}

impl WorldMesh {
    /// Places `mesh` with `transform`: the one place where mirrored instances get their
    /// winding flipped and normals get the inverse-transpose.
    pub fn place(mesh: &Mesh, transform: &Mat4) -> Self {
        // A singular transform (a zero scale) has no inverse (glam asserts in debug builds):
        // its normals are kept as they are, then normalised with the usual fallback.
        let linear = Mat3::from_mat4(*transform);
        let det = linear.determinant();
        let normal_matrix = if det != 0.0 && det.is_finite() {
            linear.inverse().transpose()
        } else {
            Mat3::IDENTITY
        };
        let mirrored = transform.determinant() < 0.0;
        let positions = mesh
            .positions
            .iter()
            .map(|p| transform.transform_point3(Vec3::from_array(*p)))
            .collect();
        let normals = mesh
            .normals
            .iter()
            .map(|n| {
                (normal_matrix * Vec3::from_array(*n))
                    .try_normalize()
                    .unwrap_or(Vec3::Y)
            })
            .collect();
        let mut indices = mesh.indices.clone();
        if mirrored {
            for t in indices.chunks_exact_mut(3) {
                t.swap(1, 2);
            }
        }
        WorldMesh {
            positions,
            normals,
            indices,
            face_materials: mesh.face_materials.clone(),
        }
    }

    /// Geometric (right-hand rule) normal of triangle `t`, not normalised.
    pub fn face_normal(&self, t: usize) -> Vec3 {
        let [a, b, c] = [
            self.positions[self.indices[3 * t] as usize],
            self.positions[self.indices[3 * t + 1] as usize],
            self.positions[self.indices[3 * t + 2] as usize],
        ];
        (b - a).cross(c - a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_triangle() -> Mesh {
        let mut m = Mesh {
            name: "tri".into(),
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
            indices: vec![0, 1, 2],
            face_materials: vec![0],
            materials: vec![Material::solid("m", [1.0, 1.0, 1.0])],
            ..Default::default()
        };
        m.compute_normals();
        m
    }

    #[test]
    fn push_box_faces_outwards_with_flat_normals_whatever_the_corner_order() {
        // A rotated, stretched box whose bottom corners go clockwise seen from above, so
        // push_box must flip the sides and the top to face out.
        let r = Mat3::from_rotation_y(0.6);
        let bottom = [[0.0, 0.0], [0.0, 2.0], [3.0, 2.0], [3.0, 0.0]]
            .map(|[x, z]| r * Vec3::new(x, 0.5, z) + Vec3::new(10.0, 0.0, -4.0));
        let up = r * Vec3::new(0.0, 1.5, 0.0);
        let mut m = Mesh::default();
        m.materials.push(Material::solid("m", [0.5; 3]));
        let c = [0, 1, 2, 3, 0, 1, 2, 3].map(|k| bottom[k]);
        let c = [
            c[0],
            c[1],
            c[2],
            c[3],
            c[4] + up,
            c[5] + up,
            c[6] + up,
            c[7] + up,
        ];
        m.push_box(c, 0);
        assert!(m.validate().is_ok());
        assert_eq!((m.positions.len(), m.triangle_count()), (24, 12));
        let centre = c.iter().copied().sum::<Vec3>() / 8.0;
        let mut area = 0.0f32;
        for (t, tri) in m.indices.chunks_exact(3).enumerate() {
            let p = [0, 1, 2].map(|k| Vec3::from_array(m.positions[tri[k] as usize]));
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            area += n.length() / 2.0;
            assert!(
                n.dot((p[0] + p[1] + p[2]) / 3.0 - centre) > 0.0,
                "triangle {t} faces in"
            );
            for i in tri {
                let vn = Vec3::from_array(m.normals[*i as usize]);
                assert!(vn.dot(n.normalize()) > 0.9999, "triangle {t}: normal {vn}");
            }
        }
        // Independent: the surface of a 3 × 2 × 1.5 box.
        assert!(
            (area - 2.0 * (3.0 * 2.0 + 3.0 * 1.5 + 2.0 * 1.5)).abs() < 1e-4,
            "{area}"
        );
    }

    #[test]
    fn computed_normals_follow_ccw_winding() {
        let m = one_triangle();
        assert_eq!(m.normals[0], [0.0, 1.0, 0.0]);
        assert!(m.validate().is_ok());
    }

    #[test]
    fn mirrored_placement_keeps_faces_facing_their_normals() {
        let m = one_triangle();
        let mirror = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        let w = WorldMesh::place(&m, &mirror);
        assert_eq!(w.indices, vec![0, 2, 1]);
        let geometric = w.face_normal(0).normalize();
        assert!(
            geometric.dot(w.normals[0]) > 0.99,
            "{geometric} vs {}",
            w.normals[0]
        );
        let plain = WorldMesh::place(&m, &Mat4::IDENTITY);
        assert_eq!(plain.indices, vec![0, 1, 2]);
    }

    #[test]
    fn a_singular_transform_places_without_a_panic() {
        use glam::Vec4;
        // Fuzzing regression (target `mscene`): an object scaled to zero in a compiled scene
        // panicked in glam's `Mat3::inverse` (`det != 0.0`) in debug builds.
        let m = one_triangle();
        let zero = Mat4::from_cols(Vec4::ZERO, Vec4::ZERO, Vec4::ZERO, Vec4::W);
        let flat = Mat4::from_cols(Vec4::X, Vec4::ZERO, Vec4::Z, Vec4::W);
        for t in [zero, flat] {
            let w = WorldMesh::place(&m, &t);
            assert_eq!(w.positions.len(), 3);
            assert!(w
                .normals
                .iter()
                .all(|n| n.is_finite() && (n.length() - 1.0).abs() < 1e-5));
        }
    }

    #[test]
    fn validate_reports_bad_indices() {
        let mut m = one_triangle();
        m.indices[2] = 9;
        assert!(m.validate().unwrap_err().to_string().contains("index 9"));
    }
}
