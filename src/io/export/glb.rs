//! Binary glTF (GLB) writer, built on `gltf::json` and written with `gltf::binary::Glb`.
//!
//! One buffer (the GLB's BIN chunk); per part one mesh node whose positions (with the
//! `min`/`max` glTF requires), normals and UVs are shared by one primitive per material slot
//! used, each with its own `u32` index accessor. Mesh nodes are the children of one root node
//! per level (`level <index>`); nodes carry no transform, the geometry is already in world space.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::io;
use std::path::Path;

use glam::Vec3;
use gltf::json::{self, validation::Checked::Valid, validation::USize64, Index};

use super::{Counter, ExportError, ExportSummary, Plan};
use crate::atomic::write_atomic;
use crate::scene::Scene;

/// Size of the GLB header plus the two chunk headers.
const GLB_OVERHEAD: usize = 12 + 8 + 8;

/// Writes `plan` to `out` as one GLB file.
pub(super) fn write(scene: &Scene, plan: &Plan, out: &Path) -> Result<ExportSummary, ExportError> {
    let (root, bin, mut summary) = build(scene, plan);
    let json = root
        .to_vec()
        .map_err(|e| ExportError::invalid(out, format!("cannot encode glTF JSON: {e}")))?;
    let length = GLB_OVERHEAD + json.len().next_multiple_of(4) + bin.len().next_multiple_of(4);
    let length = u32::try_from(length).map_err(|_| {
        ExportError::invalid(
            out,
            format!("{length} bytes exceeds the 4 GiB limit of a GLB file; export as OBJ"),
        )
    })?;
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            length,
        },
        json: Cow::Owned(json),
        bin: (!bin.is_empty()).then_some(Cow::Borrowed(bin.as_slice())),
    };
    summary.bytes = write_atomic(out, |w| {
        let mut w = Counter::new(w);
        glb.to_writer(&mut w).map_err(|e| match e {
            gltf::Error::Io(e) => e,
            other => io::Error::other(other.to_string()),
        })?;
        Ok::<_, io::Error>(w.bytes)
    })
    .map_err(ExportError::io(out))?;
    summary.files = vec![out.to_path_buf()];
    Ok(summary)
}

/// The glTF document, its binary buffer, and the node / triangle counts.
fn build(scene: &Scene, plan: &Plan) -> (json::Root, Vec<u8>, ExportSummary) {
    let mut root = json::Root {
        asset: json::Asset {
            generator: Some("minos".to_string()),
            ..Default::default()
        },
        ..Default::default()
    };
    let buffer = root.push(json::Buffer {
        byte_length: USize64(0),
        name: None,
        uri: None,
        extensions: None,
        extras: Default::default(),
    });
    for m in &plan.materials {
        let translucent = m.diffuse[3] < 1.0;
        root.push(json::Material {
            name: Some(m.name.clone()),
            alpha_mode: Valid(if translucent {
                json::material::AlphaMode::Blend
            } else {
                json::material::AlphaMode::Opaque
            }),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor(m.diffuse),
                metallic_factor: json::material::StrengthFactor(0.0),
                roughness_factor: json::material::StrengthFactor(1.0),
                ..Default::default()
            },
            ..Default::default()
        });
    }

    let mut bin = Vec::new();
    let mut summary = ExportSummary::default();
    let mut children: Vec<Vec<Index<json::Node>>> = vec![Vec::new(); scene.levels.len()];
    for part in &plan.parts {
        let Some(world) = part.world(scene) else {
            summary.skipped.push(part.warn_skipped());
            continue;
        };
        let mut data = Data {
            root: &mut root,
            bin: &mut bin,
            buffer,
        };
        let (min, max) = bounds(&world.positions);
        let positions = data.vec3(&world.positions, Some((min, max)));
        let mut attributes = BTreeMap::new();
        attributes.insert(Valid(json::mesh::Semantic::Positions), positions);
        if world.normals.len() == world.positions.len() {
            let normals = data.vec3(&world.normals, None);
            attributes.insert(Valid(json::mesh::Semantic::Normals), normals);
        }
        if let Some(uvs) = part.uvs() {
            // `Mesh::uvs` has v = 0 at the bottom of the image, glTF at the top.
            let flipped: Vec<[f32; 2]> = uvs.iter().map(|&[u, v]| [u, 1.0 - v]).collect();
            let uvs = data.vec2(&flipped);
            attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), uvs);
        }
        let mut primitives = Vec::new();
        for (&(_, mat), tris) in part.slots.iter().zip(part.triangles_by_slot(&world)) {
            if tris.is_empty() {
                continue;
            }
            summary.triangles += (tris.len() / 3) as u64;
            let indices = data.indices(&tris);
            primitives.push(json::mesh::Primitive {
                attributes: attributes.clone(),
                indices: Some(indices),
                material: Some(Index::new(mat as u32)),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
                extensions: None,
                extras: Default::default(),
            });
        }
        if primitives.is_empty() {
            continue;
        }
        let mesh = root.push(json::Mesh {
            name: Some(part.name.clone()),
            primitives,
            weights: None,
            extensions: None,
            extras: Default::default(),
        });
        let node = root.push(json::Node {
            name: Some(part.name.clone()),
            mesh: Some(mesh),
            ..Default::default()
        });
        if let Some(c) = children.get_mut(part.level) {
            c.push(node);
        }
        summary.nodes += 1;
    }

    let levels: Vec<Index<json::Node>> = scene
        .levels
        .iter()
        .zip(children)
        .map(|(level, children)| {
            root.push(json::Node {
                name: Some(format!("level {}", level.index)),
                children: (!children.is_empty()).then_some(children),
                ..Default::default()
            })
        })
        .collect();
    let scene_index = root.push(json::Scene {
        name: Some(scene.id.clone()),
        nodes: levels,
        extensions: None,
        extras: Default::default(),
    });
    root.scene = Some(scene_index);

    if bin.is_empty() {
        // glTF forbids empty buffers; nothing refers to it.
        root.buffers.clear();
    } else {
        root.buffers[0].byte_length = USize64::from(bin.len());
    }
    (root, bin, summary)
}

/// Component-wise min and max of `points` (zeros when empty).
fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    let mut it = points.iter().copied();
    let first = it.next().unwrap_or(Vec3::ZERO);
    it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p)))
}

/// Appends buffer views and accessors to the document and their bytes to the buffer.
struct Data<'a> {
    root: &'a mut json::Root,
    bin: &'a mut Vec<u8>,
    buffer: Index<json::Buffer>,
}

impl Data<'_> {
    /// Appends `bytes` (already a multiple of 4 long) as one buffer view.
    fn view(&mut self, bytes: Vec<u8>, target: json::buffer::Target) -> Index<json::buffer::View> {
        let offset = self.bin.len();
        self.bin.extend_from_slice(&bytes);
        self.root.push(json::buffer::View {
            buffer: self.buffer,
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            name: None,
            target: Some(Valid(target)),
            extensions: None,
            extras: Default::default(),
        })
    }

    fn accessor(
        &mut self,
        view: Index<json::buffer::View>,
        count: usize,
        component: json::accessor::ComponentType,
        type_: json::accessor::Type,
        bounds: Option<(Vec<f32>, Vec<f32>)>,
    ) -> Index<json::Accessor> {
        let (min, max) = match bounds {
            Some((lo, hi)) => (Some(json::Value::from(lo)), Some(json::Value::from(hi))),
            None => (None, None),
        };
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            type_: Valid(type_),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
            extensions: None,
            extras: Default::default(),
        })
    }

    /// A `VEC3` float accessor, with `min`/`max` when given.
    fn vec3(&mut self, values: &[Vec3], bounds: Option<(Vec3, Vec3)>) -> Index<json::Accessor> {
        let bytes = values
            .iter()
            .flat_map(|v| v.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let view = self.view(bytes, json::buffer::Target::ArrayBuffer);
        self.accessor(
            view,
            values.len(),
            json::accessor::ComponentType::F32,
            json::accessor::Type::Vec3,
            bounds.map(|(lo, hi)| (lo.to_array().to_vec(), hi.to_array().to_vec())),
        )
    }

    /// A `VEC2` float accessor.
    fn vec2(&mut self, values: &[[f32; 2]]) -> Index<json::Accessor> {
        let bytes = values
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        let view = self.view(bytes, json::buffer::Target::ArrayBuffer);
        self.accessor(
            view,
            values.len(),
            json::accessor::ComponentType::F32,
            json::accessor::Type::Vec2,
            None,
        )
    }

    /// A `SCALAR` `u32` index accessor.
    fn indices(&mut self, indices: &[u32]) -> Index<json::Accessor> {
        let bytes = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(bytes, json::buffer::Target::ElementArrayBuffer);
        self.accessor(
            view,
            indices.len(),
            json::accessor::ComponentType::U32,
            json::accessor::Type::Scalar,
            None,
        )
    }
}
