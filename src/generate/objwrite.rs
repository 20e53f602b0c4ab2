//! Minimal, deterministic OBJ/MTL text for box-built geometry.

use std::fmt::Write as _;

use super::plan::Rect;

/// Formats a coordinate with at most 4 decimals, without a negative zero.
pub fn num(out: &mut String, v: f64) {
    let r = (v * 10_000.0).round() / 10_000.0;
    let r = if r == 0.0 { 0.0 } else { r };
    let _ = write!(out, "{r}");
}

/// An OBJ being assembled: vertices, the six axis normals, faces grouped by material;
/// faces of textured materials also get planar texture coordinates.
pub struct ObjText {
    body: String,
    faces: Vec<(usize, String)>,
    vertices: usize,
    texcoords: usize,
    mtllib: String,
    /// (material, metres per texture repeat) of textured materials.
    textured: Vec<(usize, f64)>,
}

/// The six axis normals, written once at the top of every OBJ: -x, +x, -y, +y, -z, +z.
const NORMALS: &str = "vn -1 0 0\nvn 1 0 0\nvn 0 -1 0\nvn 0 1 0\nvn 0 0 -1\nvn 0 0 1\n";

impl ObjText {
    /// An empty OBJ that uses the material library `mtllib`.
    pub fn new(mtllib: &str) -> Self {
        ObjText {
            body: String::with_capacity(4096),
            faces: Vec::new(),
            vertices: 0,
            texcoords: 0,
            mtllib: mtllib.to_string(),
            textured: Vec::new(),
        }
    }

    /// Gives faces of `material` texture coordinates, one repeat per `metres`, projected
    /// along the face's axis (x faces use (z, y), y faces (x, z), z faces (x, y)).
    pub fn texture_scale(mut self, material: usize, metres: f64) -> Self {
        self.textured.push((material, metres));
        self
    }

    fn vertex(&mut self, p: [f64; 3]) {
        self.body.push_str("v ");
        num(&mut self.body, p[0]);
        self.body.push(' ');
        num(&mut self.body, p[1]);
        self.body.push(' ');
        num(&mut self.body, p[2]);
        self.body.push('\n');
        self.vertices += 1;
    }

    /// A quad with corners (1-based vertex numbers) at `points`, normal number `normal`.
    fn face(&mut self, material: usize, corners: [usize; 4], points: [[f64; 3]; 4], normal: usize) {
        let scale = self
            .textured
            .iter()
            .find(|(m, _)| *m == material)
            .map(|(_, s)| *s);
        let mut f = String::with_capacity(48);
        f.push('f');
        match scale {
            Some(s) => {
                let (a, b) = match normal {
                    1 | 2 => (2, 1),
                    3 | 4 => (0, 2),
                    _ => (0, 1),
                };
                for (c, p) in corners.iter().zip(points) {
                    self.body.push_str("vt ");
                    num(&mut self.body, p[a] / s);
                    self.body.push(' ');
                    num(&mut self.body, p[b] / s);
                    self.body.push('\n');
                    self.texcoords += 1;
                    let _ = write!(f, " {c}/{}/{normal}", self.texcoords);
                }
            }
            None => {
                for c in corners {
                    let _ = write!(f, " {c}//{normal}");
                }
            }
        }
        f.push('\n');
        self.faces.push((material, f));
    }

    /// A closed box, faces counter-clockwise seen from outside.
    pub fn add_box(&mut self, min: [f64; 3], max: [f64; 3], material: usize) {
        let o = self.vertices + 1;
        let corner = |i: usize| {
            [
                if i & 1 == 0 { min[0] } else { max[0] },
                if i & 2 == 0 { min[1] } else { max[1] },
                if i & 4 == 0 { min[2] } else { max[2] },
            ]
        };
        for i in 0..8 {
            self.vertex(corner(i));
        }
        // Corner k has bits (x, y, z); faces listed CCW from outside.
        let quads: [([usize; 4], usize); 6] = [
            ([0, 4, 6, 2], 1), // -x
            ([1, 3, 7, 5], 2), // +x
            ([0, 1, 5, 4], 3), // -y
            ([2, 6, 7, 3], 4), // +y
            ([0, 2, 3, 1], 5), // -z
            ([4, 5, 7, 6], 6), // +z
        ];
        for (q, normal) in quads {
            self.face(material, q.map(|k| o + k), q.map(corner), normal);
        }
    }

    /// A horizontal rectangle at height `y`, facing up (`up`) or down.
    pub fn add_flat(&mut self, r: &Rect, y: f64, up: bool, material: usize) {
        let o = self.vertices + 1;
        let p = [
            [r.x0, y, r.z0],
            [r.x0, y, r.z1],
            [r.x1, y, r.z1],
            [r.x1, y, r.z0],
        ];
        for q in p {
            self.vertex(q);
        }
        if up {
            self.face(material, [o, o + 1, o + 2, o + 3], p, 4);
        } else {
            self.face(
                material,
                [o, o + 3, o + 2, o + 1],
                [p[0], p[3], p[2], p[1]],
                3,
            );
        }
    }

    /// The OBJ text, faces grouped by material (names from `materials`).
    pub fn finish(mut self, materials: &[String]) -> String {
        let mut out = String::with_capacity(self.body.len() + self.faces.len() * 40 + 256);
        let _ = writeln!(out, "# generated by minos\nmtllib {}", self.mtllib);
        out.push_str(&self.body);
        out.push_str(NORMALS);
        self.faces.sort_by_key(|(m, _)| *m);
        let mut current = usize::MAX;
        for (m, f) in &self.faces {
            if *m != current {
                current = *m;
                let _ = writeln!(out, "usemtl {}", materials[*m]);
            }
            out.push_str(f);
        }
        out
    }
}

/// One MTL material: name, diffuse colour, opacity and an optional `map_Kd` path.
pub type MtlMaterial = (String, [f64; 3], f64, Option<String>);

/// MTL text for `materials`.
pub fn mtl_text(materials: &[MtlMaterial]) -> String {
    let mut out = String::from("# generated by minos\n");
    for (name, rgb, alpha, texture) in materials {
        let _ = write!(out, "newmtl {name}\nKd ");
        num(&mut out, rgb[0]);
        out.push(' ');
        num(&mut out, rgb[1]);
        out.push(' ');
        num(&mut out, rgb[2]);
        out.push_str("\nKa 0 0 0\nd ");
        num(&mut out, *alpha);
        out.push('\n');
        if let Some(t) = texture {
            let _ = writeln!(out, "map_Kd {t}");
        }
    }
    out
}
