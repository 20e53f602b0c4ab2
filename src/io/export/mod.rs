//! Scene export: a scene's world-space geometry (y-up, metres) as Wavefront OBJ (with an MTL
//! beside it) or as binary glTF (GLB), so scenes can be opened in Blender or converted for
//! Habitat-style tools.
//!
//! Every object instance with geometry becomes one OBJ group / glTF node named
//! `<instance id> <category>`, every room surface one named
//! `<room id> <room class> floor|ceiling|wall`, and every ground mesh one named
//! `ground <level>`. In GLB these nodes are the children of one root node per level
//! (`level <index>`). Geometry is always placed through [`Scene::object_world_mesh`] and
//! [`Scene::surface_world_mesh`], so mirrored instances keep their front faces.
//!
//! Materials carry the diffuse colour (with the instance's [`MaterialOverride`] applied to its
//! slot) and translucency; textures are not exported. Both writers go through
//! [`write_atomic`](crate::atomic::write_atomic), so an interrupted export never leaves a
//! complete-looking file behind.

mod glb;
mod obj;

use crate::file_error::FileError;
use std::collections::{HashMap, HashSet};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use crate::scene::{
    Material, MaterialOverride, Mesh, MeshId, Object, Scene, SurfaceKind, WorldMesh,
};

/// The file formats [`export_scene`] writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExportFormat {
    /// Wavefront OBJ with an MTL material library of the same stem next to it.
    Obj,
    /// Binary glTF 2.0 (one self-contained `.glb` file).
    Glb,
}

impl crate::vocab::Vocabulary for ExportFormat {
    const WHAT: &'static str = "export format";
    const TERMS: &'static [crate::vocab::Term<Self>] = &[
        crate::vocab::Term {
            value: ExportFormat::Obj,
            name: "obj",
            aliases: &[],
            help: "Wavefront OBJ with an MTL material library",
        },
        crate::vocab::Term {
            value: ExportFormat::Glb,
            name: "glb",
            aliases: &[],
            help: "binary glTF 2.0, one self-contained file",
        },
    ];
}

crate::vocab::name_traits!(ExportFormat);

impl ExportFormat {
    /// Every format, in the order the command line lists them.
    pub const ALL: [ExportFormat; 2] = [ExportFormat::Obj, ExportFormat::Glb];

    /// The name used on the command line (`obj`, `glb`).
    pub fn name(self) -> &'static str {
        crate::vocab::Vocabulary::term_name(self)
    }

    /// The usual file extension, without the dot (same as [`ExportFormat::name`]).
    pub fn extension(self) -> &'static str {
        self.name()
    }

    /// The format a file name's extension asks for (`.obj`, `.glb`, any case), if any.
    pub fn from_path(path: &Path) -> Option<ExportFormat> {
        let ext = path.extension()?.to_str()?;
        ExportFormat::ALL
            .into_iter()
            .find(|f| f.extension().eq_ignore_ascii_case(ext))
    }
}

/// What [`export_scene`] wrote.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ExportSummary {
    /// Geometry groups (OBJ) / mesh nodes (GLB) written; GLB's per-level root nodes are not
    /// counted.
    pub nodes: usize,
    /// Triangles written.
    pub triangles: u64,
    /// Bytes written, over all files.
    pub bytes: u64,
    /// The files written, main file first (OBJ: the `.obj`, then its `.mtl`).
    pub files: Vec<PathBuf>,
    /// Names of parts left out because their placed geometry is not finite (a broken
    /// transform); each is also logged as a warning.
    pub skipped: Vec<String>,
}

/// Errors of [`export_scene`]; every one names the file concerned.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// Writing the file failed.
    #[error(transparent)]
    Io(#[from] FileError),
    /// The scene or the output path cannot be exported as asked.
    #[error("{path}: {message}")]
    Invalid {
        /// The file that was to be written.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

impl ExportError {
    fn io(path: &Path) -> impl FnOnce(io::Error) -> ExportError + '_ {
        move |source| ExportError::Io(FileError::new(path, source))
    }

    fn invalid(path: &Path, message: impl Into<String>) -> ExportError {
        ExportError::Invalid {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
}

/// Writes `scene`'s world-space geometry to `out` in `format` (OBJ also writes
/// `out` with the extension `.mtl`). Files are replaced atomically; parent folders are created.
pub fn export_scene(
    scene: &Scene,
    format: ExportFormat,
    out: &Path,
) -> Result<ExportSummary, ExportError> {
    scene.validate().map_err(|e| {
        ExportError::invalid(
            out,
            format!(
                "scene {} is invalid: {}",
                scene.id,
                crate::escape::error_line(&e)
            ),
        )
    })?;
    let plan = Plan::new(scene);
    match format {
        ExportFormat::Obj => obj::write(scene, &plan, out),
        ExportFormat::Glb => glb::write(scene, &plan, out),
    }
}

/// A material as exported: a unique, sanitized name and the effective diffuse colour.
#[derive(Debug, Clone, PartialEq)]
struct ExportMaterial {
    /// Unique within the export; no whitespace or control characters.
    name: String,
    /// Linear RGBA.
    diffuse: [f32; 4],
    /// The texture name the source gives (only mentioned, never exported).
    texture: Option<String>,
}

/// Where a part's geometry comes from.
#[derive(Debug, Clone, Copy)]
enum Source<'a> {
    /// An object instance (model mesh + transform).
    Object(&'a Object),
    /// A room surface or ground mesh (already in world space).
    World(MeshId),
}

/// One exported group / node.
#[derive(Debug)]
struct Part<'a> {
    /// Group / node name.
    name: String,
    /// Position of its level in [`Scene::levels`].
    level: usize,
    /// Its geometry.
    source: Source<'a>,
    /// The source mesh (for UVs and triangle counts).
    mesh: &'a Mesh,
    /// Each material slot its triangles use (ascending) with the export material it maps to.
    slots: Vec<(u16, usize)>,
}

impl Part<'_> {
    /// The placed geometry, or `None` when a position is not finite.
    fn world(&self, scene: &Scene) -> Option<WorldMesh> {
        let world = match self.source {
            Source::Object(o) => scene.object_world_mesh(o)?,
            Source::World(m) => scene.surface_world_mesh(m),
        };
        world
            .positions
            .iter()
            .chain(&world.normals)
            .all(|p| p.is_finite())
            .then_some(world)
    }

    /// UVs of the source mesh when it has one per vertex.
    fn uvs(&self) -> Option<&[[f32; 2]]> {
        (!self.mesh.uvs.is_empty() && self.mesh.uvs.len() == self.mesh.positions.len())
            .then_some(self.mesh.uvs.as_slice())
    }

    /// The triangle indices of each of [`Part::slots`], in the same order.
    fn triangles_by_slot(&self, world: &WorldMesh) -> Vec<Vec<u32>> {
        let mut groups = vec![Vec::new(); self.slots.len()];
        for (t, tri) in world.indices.chunks_exact(3).enumerate() {
            let slot = world.face_materials.get(t).copied().unwrap_or(0);
            if let Ok(g) = self.slots.binary_search_by_key(&slot, |&(s, _)| s) {
                groups[g].extend_from_slice(tri);
            }
        }
        groups
    }

    fn warn_skipped(&self) -> String {
        tracing::warn!(
            "export: skipping `{}`: its placed geometry is not finite",
            self.name
        );
        self.name.clone()
    }
}

/// Everything to write, decided before any geometry is placed.
#[derive(Debug)]
struct Plan<'a> {
    /// Parts in scene order (per level: room surfaces, ground, objects).
    parts: Vec<Part<'a>>,
    /// The export materials the parts refer to.
    materials: Vec<ExportMaterial>,
}

impl<'a> Plan<'a> {
    fn new(scene: &'a Scene) -> Self {
        let mut table = MaterialTable::default();
        let mut parts = Vec::new();
        for (level_pos, level) in scene.levels.iter().enumerate() {
            let mut add = |name: String, source: Source<'a>, mesh_id: MeshId| {
                let Some(mesh) = scene.meshes.get(mesh_id as usize) else {
                    return;
                };
                if mesh.triangle_count() == 0 {
                    return;
                }
                let overrides = match source {
                    Source::Object(o) => o.materials.as_slice(),
                    Source::World(_) => &[],
                };
                let slots = used_slots(mesh)
                    .into_iter()
                    .map(|slot| {
                        let ov = overrides.iter().rev().find(|o| o.slot == u32::from(slot));
                        (slot, table.add(mesh.materials.get(slot as usize), ov))
                    })
                    .collect();
                parts.push(Part {
                    name: clean_name(&name),
                    level: level_pos,
                    source,
                    mesh,
                    slots,
                });
            };
            for room in &level.rooms {
                for s in &room.surfaces {
                    let kind = match s.kind {
                        SurfaceKind::Floor => "floor",
                        SurfaceKind::Ceiling => "ceiling",
                        SurfaceKind::Wall => "wall",
                    };
                    let name = format!("{} {} {kind}", room.id, room.class.name());
                    add(name, Source::World(s.mesh), s.mesh);
                }
            }
            for &g in &level.ground {
                add(format!("ground {}", level.index), Source::World(g), g);
            }
            for o in &level.objects {
                if let Some(m) = o.mesh {
                    let name = format!("{} {}", o.id, o.categories.best());
                    add(name, Source::Object(o), m);
                }
            }
        }
        Plan {
            parts,
            materials: table.materials,
        }
    }
}

/// The material slots a mesh's triangles use, ascending.
fn used_slots(mesh: &Mesh) -> Vec<u16> {
    let mut used: Vec<u16> = mesh.face_materials.clone();
    if used.len() < mesh.triangle_count() {
        // Triangles without a slot use slot 0.
        used.push(0);
    }
    used.sort_unstable();
    used.dedup();
    used
}

/// Collects the distinct effective materials and gives each a unique name.
#[derive(Debug, Default)]
struct MaterialTable {
    materials: Vec<ExportMaterial>,
    by_key: HashMap<(String, [u32; 4], Option<String>), usize>,
    names: HashSet<String>,
}

impl MaterialTable {
    /// The index of the material `base` becomes with override `ov`, adding it when new.
    fn add(&mut self, base: Option<&Material>, ov: Option<&MaterialOverride>) -> usize {
        let (mut name, mut diffuse, mut texture) = match base {
            Some(m) => (m.name.clone(), m.diffuse, m.texture.clone()),
            None => ("default".to_string(), [0.8, 0.8, 0.8, 1.0], None),
        };
        if let Some(ov) = ov {
            if !ov.name.trim().is_empty() {
                name.clone_from(&ov.name);
            }
            if let Some(d) = ov.diffuse {
                diffuse = d;
            }
            match ov.texture.as_deref() {
                Some("") => texture = None,
                Some(_) => texture.clone_from(&ov.texture),
                None => {}
            }
        }
        let diffuse = diffuse.map(|c| {
            if c.is_finite() {
                c.clamp(0.0, 1.0)
            } else {
                1.0
            }
        });
        let base_name = material_name(&name);
        let key = (
            base_name.clone(),
            diffuse.map(f32::to_bits),
            texture.clone(),
        );
        if let Some(&i) = self.by_key.get(&key) {
            return i;
        }
        let mut unique = base_name.clone();
        let mut n = 2;
        while self.names.contains(&unique) {
            unique = format!("{base_name}_{n}");
            n += 1;
        }
        self.names.insert(unique.clone());
        let i = self.materials.len();
        self.materials.push(ExportMaterial {
            name: unique,
            diffuse,
            texture,
        });
        self.by_key.insert(key, i);
        i
    }
}

/// A material name safe for MTL files: no whitespace, control characters or `#`.
fn material_name(name: &str) -> String {
    let cleaned: String = name
        .trim()
        .chars()
        .map(|c| {
            if c.is_whitespace() || c.is_control() || c == '#' {
                '_'
            } else {
                c
            }
        })
        .collect();
    if cleaned.is_empty() {
        "material".to_string()
    } else {
        cleaned
    }
}

/// A node / group name that fits on one line.
fn clean_name(name: &str) -> String {
    let cleaned: String = name
        .chars()
        .map(|c| if c.is_control() { '_' } else { c })
        .collect();
    let cleaned = cleaned.trim();
    if cleaned.is_empty() {
        "unnamed".to_string()
    } else {
        cleaned.to_string()
    }
}

/// A writer that counts the bytes passing through it.
struct Counter<W> {
    inner: W,
    bytes: u64,
}

impl<W: Write> Counter<W> {
    fn new(inner: W) -> Self {
        Counter { inner, bytes: 0 }
    }
}

impl<W: Write> Write for Counter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.bytes += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests;
