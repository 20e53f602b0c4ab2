//! glTF 2.0 (`.gltf` with embedded or external buffers, `.glb`) meshes through the `gltf`
//! crate, flattened into one indexed [`Mesh`] in the file's scene space.
//!
//! [`load_gltf`] is the whole-file entry point. [`GltfFile`] (a parsed file with its buffers)
//! and [`MeshBuilder`] (primitives appended into one mesh) are the pieces it is made of, for
//! loaders that need to walk the node tree themselves (the glTF scene loader splits a file
//! into a stage and objects by node).
//!
//! Images are not decoded: a material keeps its texture's name, nothing more. Textures that
//! name their image only through `KHR_texture_basisu`, `EXT_texture_webp` or
//! `MSFT_texture_dds` (Habitat's `.basis.glb`) are accepted for that reason; extensions that
//! change geometry (mesh compression, quantization) are rejected by the `gltf` crate's
//! validation.

use crate::file_error::FileError;
use std::borrow::Cow;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Vec3};

use crate::scene::{Material, Mesh};

use super::LoadError;

/// Texture extensions whose only effect is where a texture's image comes from. Images are
/// never decoded here, so a file that requires one of them loads like any other.
const IMAGE_ONLY_EXTENSIONS: [&str; 3] =
    ["KHR_texture_basisu", "EXT_texture_webp", "MSFT_texture_dds"];

/// Loads every triangle primitive of the default scene (or, in a file without scenes, of
/// every node that is no other node's child: [`GltfFile::root_nodes`]), applying node
/// transforms.
pub fn load_gltf(path: &Path) -> Result<Mesh, LoadError> {
    let file = GltfFile::open(path)?;
    let roots = file.root_nodes();
    let mut builder = MeshBuilder::new(path.display().to_string());
    let mut stack: Vec<(gltf::Node, Mat4)> =
        roots.into_iter().map(|n| (n, Mat4::IDENTITY)).collect();
    let mut visited = 0usize;
    while let Some((node, parent)) = stack.pop() {
        visited += 1;
        if visited > MAX_NODE_VISITS {
            return Err(LoadError::parse(path, "node hierarchy too deep or cyclic"));
        }
        let world = parent * node_matrix(&node);
        builder.add_node_mesh(&file, &node, &world)?;
        for child in node.children() {
            stack.push((child, world));
        }
    }
    Ok(builder.finish())
}

/// Most node visits a traversal makes before calling the hierarchy cyclic.
pub const MAX_NODE_VISITS: usize = 1_000_000;

/// A node's local transform as a matrix.
pub fn node_matrix(node: &gltf::Node) -> Mat4 {
    Mat4::from_cols_array_2d(&node.transform().matrix())
}

/// A parsed glTF file with its buffers loaded (images are not decoded).
pub struct GltfFile {
    /// The file.
    pub path: PathBuf,
    /// The parsed, validated document.
    pub document: gltf::Document,
    /// Buffer contents by buffer index.
    pub buffers: Vec<gltf::buffer::Data>,
}

impl GltfFile {
    /// Reads and validates `path` (`.glb` or `.gltf`) and loads its buffers (embedded,
    /// `data:` URIs, or files beside it). Every failure names the file.
    pub fn open(path: &Path) -> Result<Self, LoadError> {
        let bytes = std::fs::read(path).map_err(|source| LoadError::Io(FileError::new(path, source)))?;
        let (json, blob) = split_glb(path, &bytes)?;
        let mut value: serde_json::Value = serde_json::from_slice(&json).map_err(|e| {
            LoadError::parse(
                path,
                format!("invalid glTF JSON: {}", super::json_error_text(&e)),
            )
        })?;
        accept_image_only_extensions(&mut value);
        let root: gltf::json::Root = serde_json::from_value(value)
            .map_err(|e| LoadError::parse(path, format!("invalid glTF: {e}")))?;
        let document = gltf::Document::from_json(root)
            .map_err(|e| LoadError::parse(path, format!("invalid glTF: {e}")))?;
        let base = path.parent().unwrap_or(Path::new("."));
        let buffers = gltf::import_buffers(&document, Some(base), blob).map_err(|e| {
            let missing = document.buffers().find_map(|b| match b.source() {
                gltf::buffer::Source::Uri(uri)
                    if !uri.starts_with("data:") && !base.join(uri).is_file() =>
                {
                    Some(format!("buffers[{}]: `{uri}`", b.index()))
                }
                _ => None,
            });
            match missing {
                Some(which) => LoadError::parse(path, format!("glTF buffers: {which}: {e}")),
                None => LoadError::parse(path, format!("glTF buffers: {e}")),
            }
        })?;
        check_views(path, &document, &buffers)?;
        super::gltf_hierarchy::check_hierarchy(path, &document)?;
        Ok(GltfFile {
            path: path.to_path_buf(),
            document,
            buffers,
        })
    }

    /// The root nodes of the default scene (or of the first scene); without any scene, every
    /// node that is no other node's child.
    pub fn root_nodes(&self) -> Vec<gltf::Node<'_>> {
        match self
            .document
            .default_scene()
            .or_else(|| self.document.scenes().next())
        {
            Some(scene) => scene.nodes().collect(),
            None => {
                let has_parent = super::gltf_hierarchy::has_parent(&self.document);
                self.document
                    .nodes()
                    .filter(|n| !has_parent[n.index()])
                    .collect()
            }
        }
    }

    /// Files other than the glTF itself that its buffers are read from (`.bin` files).
    pub fn external_buffers(&self) -> Vec<PathBuf> {
        let base = self.path.parent().unwrap_or(Path::new("."));
        self.document
            .buffers()
            .filter_map(|b| match b.source() {
                gltf::buffer::Source::Uri(uri) if !uri.starts_with("data:") => Some(base.join(uri)),
                _ => None,
            })
            .collect()
    }
}

/// A glTF's JSON text and, for a GLB, its binary chunk.
type GlbParts<'a> = (Cow<'a, [u8]>, Option<Vec<u8>>);

/// The JSON and the binary chunk of a GLB, or the whole file as JSON for `.gltf`.
///
/// The GLB header is checked here, before the `gltf` crate sees it, so that a truncated or
/// corrupt file is an error and never an arithmetic overflow.
fn split_glb<'a>(path: &Path, bytes: &'a [u8]) -> Result<GlbParts<'a>, LoadError> {
    if !bytes.starts_with(b"glTF") {
        return Ok((Cow::Borrowed(bytes), None));
    }
    let word = |at: usize| -> Option<u32> {
        let b = bytes.get(at..at + 4)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(LoadError::parse(
            path,
            format!(
                "GLB header: file is {} bytes, shorter than the 12-byte header",
                bytes.len()
            ),
        ));
    };
    if version != 2 {
        return Err(LoadError::parse(
            path,
            format!("GLB header: version {version}, expected 2"),
        ));
    }
    if (length as usize) < 20 || length as usize > bytes.len() {
        return Err(LoadError::parse(
            path,
            format!(
                "GLB header: declared length {length} bytes but the file has {} (truncated or corrupt)",
                bytes.len()
            ),
        ));
    }
    let glb = gltf::binary::Glb::from_slice(&bytes[..length as usize])
        .map_err(|e| LoadError::parse(path, format!("GLB chunks: {e}")))?;
    Ok((glb.json, glb.bin.map(Cow::into_owned)))
}

/// Lets files that need an image-only texture extension load: the texture's `source` comes
/// from the extension when the core field is missing, and the extension is no longer
/// required (images are not decoded anyway).
fn accept_image_only_extensions(value: &mut serde_json::Value) {
    if let Some(required) = value
        .get_mut("extensionsRequired")
        .and_then(|r| r.as_array_mut())
    {
        required.retain(|e| {
            !e.as_str()
                .is_some_and(|e| IMAGE_ONLY_EXTENSIONS.contains(&e))
        });
    }
    let Some(textures) = value.get_mut("textures").and_then(|t| t.as_array_mut()) else {
        return;
    };
    for texture in textures {
        let Some(obj) = texture.as_object_mut() else {
            continue;
        };
        if obj.contains_key("source") {
            continue;
        }
        let source = obj.get("extensions").and_then(|ext| {
            IMAGE_ONLY_EXTENSIONS
                .iter()
                .find_map(|name| ext.get(*name)?.get("source").cloned())
        });
        if let Some(source) = source {
            obj.insert("source".into(), source);
        }
    }
}

/// Buffer views must lie inside their buffers (the reader would otherwise silently skip
/// them).
fn check_views(
    path: &Path,
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
) -> Result<(), LoadError> {
    for view in document.views() {
        let len = buffers.get(view.buffer().index()).map_or(0, |b| b.len());
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|end| end > len) {
            return Err(LoadError::parse(
                path,
                format!(
                    "bufferViews[{}]: bytes {}..{} outside buffer {} ({len} bytes)",
                    view.index(),
                    view.offset(),
                    view.offset().saturating_add(view.length()),
                    view.buffer().index()
                ),
            ));
        }
    }
    for accessor in document.accessors() {
        if accessor.count() == 0 {
            return Err(LoadError::parse(
                path,
                format!("accessors[{}]: count is 0", accessor.index()),
            ));
        }
    }
    Ok(())
}

/// Appends glTF primitives into one indexed [`Mesh`], sharing material slots by glTF
/// material, optionally recording each triangle's vertex colour.
pub struct MeshBuilder {
    mesh: Mesh,
    slots: HashMap<Option<usize>, u16>,
    colors: Option<Vec<Option<[u8; 3]>>>,
}

impl MeshBuilder {
    /// An empty mesh called `name`.
    pub fn new(name: impl Into<String>) -> Self {
        MeshBuilder {
            mesh: Mesh {
                name: name.into(),
                ..Default::default()
            },
            slots: HashMap::new(),
            colors: None,
        }
    }

    /// Also records each triangle's `COLOR_0` (8-bit RGB; the colour two of its three
    /// vertices share, else its first vertex's), `None` for primitives without colours.
    pub fn with_triangle_colors(mut self) -> Self {
        self.colors = Some(Vec::new());
        self
    }

    /// Appends the triangle primitives of `node`'s own mesh (not its children) placed by
    /// `world`.
    pub fn add_node_mesh(
        &mut self,
        file: &GltfFile,
        node: &gltf::Node,
        world: &Mat4,
    ) -> Result<(), LoadError> {
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    continue;
                }
                self.add_primitive(file, &prim, world)?;
            }
        }
        Ok(())
    }

    /// Appends one triangle primitive placed by `world` (winding flipped when `world`
    /// mirrors).
    pub fn add_primitive(
        &mut self,
        file: &GltfFile,
        prim: &gltf::Primitive,
        world: &Mat4,
    ) -> Result<(), LoadError> {
        let path = file.path.as_path();
        let out = &mut self.mesh;
        let reader = prim.reader(|b| file.buffers.get(b.index()).map(|d| &d.0[..]));
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
        if let Some(colors) = self.colors.as_mut() {
            let vertex: Option<Vec<[u8; 3]>> = reader
                .read_colors(0)
                .map(|c| c.into_rgb_u8().collect())
                .filter(|c: &Vec<[u8; 3]>| c.len() == n);
            for t in indices.chunks_exact(3) {
                colors.push(vertex.as_ref().map(|v| {
                    let [a, b, c] = [v[t[0] as usize], v[t[1] as usize], v[t[2] as usize]];
                    if b == c && a != b {
                        b
                    } else {
                        a
                    }
                }));
            }
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
        let slot = match self.slots.get(&key) {
            Some(s) => *s,
            None => {
                let s = out.materials.len() as u16;
                out.materials.push(to_material(&material));
                self.slots.insert(key, s);
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

    /// The mesh: texture coordinates dropped when all are zero (else turned from glTF's
    /// v-down to [`Mesh::uvs`]' v-up convention), a default material when there is none.
    pub fn finish(self) -> Mesh {
        self.finish_with_colors().0
    }

    /// The mesh and, when recorded, each triangle's colour (see
    /// [`with_triangle_colors`](Self::with_triangle_colors)).
    pub fn finish_with_colors(self) -> (Mesh, Vec<Option<[u8; 3]>>) {
        let mut out = self.mesh;
        if out.uvs.iter().all(|t| *t == [0.0, 0.0]) {
            out.uvs.clear();
        } else {
            for uv in &mut out.uvs {
                uv[1] = 1.0 - uv[1];
            }
        }
        if out.materials.is_empty() {
            out.materials
                .push(Material::solid("default", [0.7, 0.7, 0.7]));
        }
        (out, self.colors.unwrap_or_default())
    }
}

fn to_material(m: &gltf::Material) -> Material {
    let pbr = m.pbr_metallic_roughness();
    // An image file's URI (relative to the glTF file) where there is one, so the renderers
    // can find it; otherwise a name (embedded images are not decoded).
    let texture = pbr.base_color_texture().map(|t| {
        let tex = t.texture();
        let img = tex.source();
        match img.source() {
            gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => uri.to_string(),
            _ => tex
                .name()
                .or(img.name())
                .map(str::to_string)
                .unwrap_or_else(|| format!("image_{}", img.index())),
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_without_scenes_loads_each_parentless_hierarchy_once() {
        // Node 0 (moved 10 m along x) holds node 1, which holds the one triangle. Without
        // scenes the roots are the parentless nodes: node 1 is reached only through node 0.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sceneless.gltf");
        let gltf = r#"{"asset": {"version": "2.0"},
            "nodes": [{"translation": [10, 0, 0], "children": [1]}, {"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                           "min": [0, 0, 0], "max": [1, 0, 1]}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "buffers": [{"byteLength": 36, "uri":
                "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAAAAAAIA/"}]}"#;
        std::fs::write(&path, gltf).unwrap();
        let mesh = load_gltf(&path).unwrap();
        assert_eq!(
            mesh.triangle_count(),
            1,
            "the child's mesh once, not again as a root"
        );
        let xs: Vec<f32> = mesh.positions.iter().map(|p| p[0]).collect();
        assert!(xs.iter().all(|&x| (10.0..=11.0).contains(&x)), "{xs:?}");
    }
}
