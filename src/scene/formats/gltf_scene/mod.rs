//! glTF / GLB scenes, alone or with Habitat metadata (`minos ingest --dataset gltf`).
//!
//! **What a scene is.** `--root` is searched recursively (hidden folders skipped; a single
//! file as root is that scene alone, with the configs of its own folder). Each
//! `*.scene_instance.json` is one scene, its id the file name before `.scene_instance`. Each
//! `.glb` / `.gltf` is one scene, its id the file stem, unless it is the render, collision or
//! semantic asset of an object config, the collision or semantic asset of a stage config, the
//! stage of a scene instance, or a `*.semantic.glb`. Two scenes with the same id: the scene
//! instance wins over a plain file, then the first path; the others are skipped with a warning.
//!
//! **Metadata.** A stage takes its attributes from, in increasing priority, the
//! `stages.default_attributes` of every `*.scene_dataset_config.json` in a folder above it, the
//! `*.stage_config.json` whose `render_asset` is the file (or that has its name), and the
//! dataset template the scene instance names. Templates named by scene instances resolve to a
//! dataset config template (`template_handle`), else a `<name>.stage_config.json` /
//! `<name>.object_config.json` whose path ends with the name, else an asset file of that name.
//! Used attributes: `render_asset`, `up`/`front` (default: glTF's +Y up, −Z front), `scale`,
//! `COM`, `semantic_asset`, `semantic_descriptor_filename`. Instances: `translation`,
//! `rotation` (`[w, x, y, z]`, as habitat-sim writes quaternions), `uniform_scale`,
//! `non_uniform_scale`, `translation_origin` (see [`habitat`]) and `motion_type` (read; every
//! instance is placed as a static obstacle). The stage instance's own transform and `origin` are
//! not applied — habitat-sim does not apply them either — and a warning says so.
//!
//! **How geometry enters the model.** A stage is a whole-scene mesh, so it must be a surface:
//! its triangles (placed in world space) become one [`Level::ground`](crate::scene::Level)
//! mesh. The bake rasterises ground triangle by triangle and lets its upward-facing triangles
//! be floor, so floors are walkable and walls, furniture baked into the stage, and ceilings
//! stay obstacles — whereas an *object* would be filled as a solid from its lowest to its
//! highest point per column, burying a house. Ground rather than a room `Floor` surface because
//! the stage is not only floor: labelling its walls and ceilings "floor" would mislead every
//! consumer of room surfaces. glTF nodes that name an object category — `extras.category`
//! (or `extras.class`) on the node or its mesh, or a node name such as `chair_1` /
//! `Chair.001` read by [`semantic::category_from_name`] — become objects with their subtree as
//! the model; structural names (floor, wall, ceiling) stay ground. Scene-instance objects are
//! objects.
//!
//! **Rooms.** With no room information the scene gets one room, id `stage`, class other, with
//! the stage's box as floor polygon and no surfaces: the bake then gives every walkable span
//! above its floor height (the lowest upward-facing stage triangle) to that room, so episodes
//! can be sampled. Rooms come instead from Habitat region annotations (`semantic_scene_instance`
//! / `*.semantic_config.json`: polygon, floor height, label → class), or from an HM3D
//! `.semantic.txt` (`id,HEXRGB,"category",regionId`) when it can be tied to geometry: when the
//! semantic mesh (`semantic_asset`, or `<name>.semantic.glb` beside the stage) has vertex
//! colours, its triangles are grouped by colour → semantic id; ids whose category is floor,
//! wall or ceiling become those surfaces of room `region_<id>`, every other id an object
//! `sem_<id>` with its category. HM3D's own semantic meshes carry the ids in textures, which
//! minos does not decode: then the table is still validated, a warning says it was not tied,
//! and the single `stage` room is made. Objects get the room whose floor region holds their
//! box centre.
//!
//! **Categories.** Raw category names become the fine category; a Habitat category-mapping
//! TSV (`--categories FILE`, or a `*category_mappings.tsv` at the top of the root) adds the
//! coarse category, mpcat40 and NYU-40 where it has them.
//!
//! Where this module's job ends: it finds and resolves files and reports one-line errors
//! naming file and record; parsing lives in [`habitat`] and [`semantic`], geometry assembly in
//! `assemble`, glTF reading in [`gltf_mesh`](super::gltf_mesh).

mod assemble;
mod discover;
pub mod habitat;
mod resolve;
pub mod semantic;

use crate::file_error::FileError;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};

use crate::scene::{Categories, Dataset};

use self::assemble::{Assembler, StageSpec};
use self::habitat::{
    frame_to_world, normalize, read_attributes, read_dataset_config, read_scene_instance,
    read_semantic_config, Attributes, DatasetConfig, Placement, CONFIG_NAME_TAG,
};
use self::semantic::{category_from_name, CategoryMap};

use super::{DatasetLoader, LoadError, LoadedScene, SceneEntry};

#[cfg(feature = "internals")]
pub use self::assemble::STAGE_ROOM_ID;
use self::discover::walk;
use self::resolve::{Kind, ResolveError, Resolved};

const SCENE_INSTANCE: &str = ".scene_instance.json";
const STAGE_CONFIG: &str = ".stage_config.json";
const OBJECT_CONFIG: &str = ".object_config.json";
const DATASET_CONFIG: &str = ".scene_dataset_config.json";
const SEMANTIC_CONFIG: &str = ".semantic_config.json";
const CATEGORY_TABLE: &str = "category_mappings.tsv";
/// Deepest folder level searched under the root.
const MAX_DEPTH: usize = 16;

/// `name` without `suffix` (ASCII case-insensitive), if it ends with it.
fn strip_suffix_ci<'s>(name: &'s str, suffix: &str) -> Option<&'s str> {
    let n = name.len().checked_sub(suffix.len())?;
    (name.is_char_boundary(n) && name[n..].eq_ignore_ascii_case(suffix)).then(|| &name[..n])
}

fn file_name(path: &Path) -> &str {
    path.file_name().and_then(|n| n.to_str()).unwrap_or("")
}

fn is_asset(path: &Path) -> bool {
    let n = file_name(path);
    strip_suffix_ci(n, ".glb").is_some() || strip_suffix_ci(n, ".gltf").is_some()
}

/// A file's name without its last extension or a known config suffix.
fn short_name(path: &Path) -> String {
    let n = file_name(path);
    for suffix in [STAGE_CONFIG, OBJECT_CONFIG, SCENE_INSTANCE, SEMANTIC_CONFIG] {
        if let Some(s) = strip_suffix_ci(n, suffix) {
            return s.to_string();
        }
    }
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The name up to its first dot (`TEEsavR23oF.basis` → `TEEsavR23oF`), which is how Habitat
/// fills [`CONFIG_NAME_TAG`].
fn base_name(name: &str) -> &str {
    name.split('.').next().unwrap_or(name)
}

/// Files found under the root.
#[derive(Debug, Default)]
struct RootIndex {
    scene_instances: Vec<PathBuf>,
    stage_configs: Vec<PathBuf>,
    object_configs: Vec<PathBuf>,
    semantic_configs: Vec<PathBuf>,
    assets: Vec<PathBuf>,
    datasets: Vec<DatasetConfig>,
    /// Render asset → the stage config that describes it.
    stage_config_of: HashMap<PathBuf, PathBuf>,
    /// Config files by kind and short name (`chair` for `chair.object_config.json`).
    config_names: HashMap<(Kind, String), Vec<PathBuf>>,
    /// Asset files by file name and by stem.
    asset_names: HashMap<String, Vec<PathBuf>>,
}

/// Loads glTF / GLB scenes (with optional Habitat metadata) from one root.
pub struct GltfLoader {
    root: PathBuf,
    index: RootIndex,
    scenes: Vec<SceneEntry>,
    categories: CategoryMap,
    category_table: Option<PathBuf>,
    root_warnings: Vec<String>,
}

impl GltfLoader {
    /// Indexes `root` — a folder, searched recursively, or a single `.glb` / `.gltf` /
    /// `.scene_instance.json`, which is then the only scene and finds its configs in its own
    /// folder (not below) — and reads the scene dataset configs and the category table (`categories`, else a
    /// `*category_mappings.tsv` at the top of the root). Fails only when the root cannot be
    /// read or one of those files is invalid.
    pub fn open(root: &Path, categories: Option<&Path>) -> Result<Self, LoadError> {
        let root = &normalize(root);
        let meta = std::fs::metadata(root).map_err(|source| LoadError::Io(FileError::new(root.clone(), source)))?;
        // A single file brings the files of its own folder (its stage config, semantic table).
        let (folder, depth) = if meta.is_file() {
            (root.parent().unwrap_or(Path::new(".")).to_path_buf(), 0)
        } else {
            (root.clone(), MAX_DEPTH)
        };
        let files = walk(&folder, depth)?;
        let mut index = RootIndex::default();
        let mut tables = Vec::new();
        for f in files {
            let n = file_name(&f);
            if strip_suffix_ci(n, SCENE_INSTANCE).is_some() {
                index.scene_instances.push(f);
            } else if strip_suffix_ci(n, STAGE_CONFIG).is_some() {
                index.stage_configs.push(f);
            } else if strip_suffix_ci(n, OBJECT_CONFIG).is_some() {
                index.object_configs.push(f);
            } else if strip_suffix_ci(n, DATASET_CONFIG).is_some() {
                index.datasets.push(read_dataset_config(&f)?);
            } else if strip_suffix_ci(n, SEMANTIC_CONFIG).is_some() {
                index.semantic_configs.push(f);
            } else if is_asset(&f) {
                index.assets.push(f);
            } else if strip_suffix_ci(n, CATEGORY_TABLE).is_some()
                && f.parent() == Some(folder.as_path())
            {
                tables.push(f);
            }
        }
        for (kind, list) in [
            (Kind::Stage, &index.stage_configs),
            (Kind::Object, &index.object_configs),
        ] {
            for p in list {
                index
                    .config_names
                    .entry((kind, short_name(p)))
                    .or_default()
                    .push(p.clone());
            }
        }
        for p in &index.assets {
            let stem = short_name(p);
            let name = file_name(p).to_string();
            index.asset_names.entry(name).or_default().push(p.clone());
            index.asset_names.entry(stem).or_default().push(p.clone());
        }
        let category_table = categories
            .map(Path::to_path_buf)
            .or_else(|| tables.first().cloned());
        let categories = match &category_table {
            Some(p) => CategoryMap::read(p)?,
            None => CategoryMap::default(),
        };
        let mut loader = GltfLoader {
            root: root.to_path_buf(),
            index,
            scenes: Vec::new(),
            categories,
            category_table,
            root_warnings: Vec::new(),
        };
        loader.map_stage_configs();
        loader.scenes = loader.find_scenes();
        if meta.is_file() {
            loader.scenes.retain(|s| s.path == *root);
        }
        Ok(loader)
    }

    /// The category table in use, if any.
    #[cfg(feature = "internals")]
    pub fn category_table(&self) -> Option<&Path> {
        self.category_table.as_deref()
    }

    /// Loads one scene (unguarded: [`DatasetLoader::load`] catches the gltf crate's panics).
    /// Every failure names the file and the record.
    fn assemble(&self, entry: &SceneEntry) -> Result<LoadedScene, LoadError> {
        let mut asm = Assembler::new(&entry.id, &entry.path, &self.categories);
        if let Some(t) = &self.category_table {
            asm.sources.push(t.clone());
        }
        if strip_suffix_ci(file_name(&entry.path), SCENE_INSTANCE).is_some() {
            self.load_instance(entry, &mut asm)?;
        } else {
            let r = self.stage_for_asset(&entry.path)?;
            asm.sources.extend(r.sources.iter().cloned());
            let spec = self.stage_spec(&r, &mut asm.warnings)?;
            asm.add_stage(&spec)?;
        }
        asm.finish()
    }

    fn load_instance(&self, entry: &SceneEntry, asm: &mut Assembler) -> Result<(), LoadError> {
        let path = &entry.path;
        let si = read_scene_instance(path, &mut asm.warnings)?;
        asm.sources.push(path.clone());
        let missing = |kind: Kind, record: &str, template: &str| {
            LoadError::node(
                path,
                record,
                format!(
                    "{} template `{template}` not found (no scene dataset config template, no {template}{} and no asset of that name under {})",
                    kind.name(),
                    kind.suffix(),
                    self.root.display()
                ),
            )
        };
        let resolve =
            |kind: Kind, record: &str, template: &str| match self.resolve(kind, template, path) {
                Ok(r) => Ok(r),
                Err(ResolveError::Missing) => Err(missing(kind, record, template)),
                Err(ResolveError::Load(e)) => Err(LoadError::referenced(path, record, e)),
            };
        let stage = si.stage.as_ref().ok_or_else(|| {
            LoadError::node(
                path,
                "stage_instance",
                "missing (use template_name `NONE` for a scene without a stage)",
            )
        })?;
        if !stage.template.eq_ignore_ascii_case("none") {
            let r = resolve(Kind::Stage, &stage.record, &stage.template)?;
            asm.sources.extend(r.sources.iter().cloned());
            if stage.translation != Vec3::ZERO
                || stage.rotation.angle_between(Quat::IDENTITY) > 1e-5
                || stage.scale != Vec3::ONE
            {
                asm.warnings.push(format!(
                    "{}: stage_instance translation/rotation/scale not applied (habitat-sim does not apply them either)",
                    path.display()
                ));
            }
            let spec = self.stage_spec(&r, &mut asm.warnings)?;
            asm.add_stage(&spec)
                .map_err(|e| LoadError::referenced(path, &stage.record, e))?;
        }
        let mut resolved: HashMap<&str, (Resolved, Quat)> = HashMap::new();
        for (i, inst) in si.objects.iter().enumerate() {
            if !resolved.contains_key(inst.template.as_str()) {
                let r = resolve(Kind::Object, &inst.record, &inst.template)?;
                let frame = frame_to_world(r.attributes.up, r.attributes.front).map_err(|m| {
                    LoadError::referenced(path, &inst.record, LoadError::parse(&r.config, m))
                })?;
                asm.sources.extend(r.sources.iter().cloned());
                resolved.insert(inst.template.as_str(), (r, frame));
            }
            let Some((r, frame)) = resolved.get(inst.template.as_str()) else {
                continue;
            };
            let placement = Placement::new(
                inst,
                si.translation_origin,
                *frame,
                r.attributes.scale.unwrap_or(Vec3::ONE),
                r.attributes.com,
            );
            asm.add_instance(
                format!("inst_{i}"),
                inst.template.clone(),
                &r.asset,
                self.template_categories(&inst.template),
                &placement,
            )
            .map_err(|e| LoadError::referenced(path, &inst.record, e))?;
        }
        if si.articulated > 0 {
            asm.warnings.push(format!(
                "{}: {} articulated_object_instances not loaded",
                path.display(),
                si.articulated
            ));
        }
        if let Some(cfg) =
            self.semantic_config(path, si.semantic_scene.as_deref(), &mut asm.warnings)
        {
            let regions = read_semantic_config(&cfg)?;
            asm.sources.push(cfg);
            asm.add_regions(&regions);
        }
        Ok(())
    }
}

impl DatasetLoader for GltfLoader {
    fn dataset(&self) -> Dataset {
        Dataset::Gltf
    }
    /// Every scene under the root, sorted by id.
    fn discover(&self) -> Result<Vec<SceneEntry>, LoadError> {
        Ok(self.scenes.clone())
    }
    /// Loads one scene; a panic inside the gltf crate on a malformed file becomes an error
    /// naming the scene's file (the batch goes on).
    fn load(&self, entry: &SceneEntry) -> Result<LoadedScene, LoadError> {
        crate::scene::formats::guarded(&entry.path, || self.assemble(entry))?
    }
    fn scene_layout(&self) -> &'static str {
        ".glb, .gltf or .scene_instance.json files in any folder"
    }
    fn root_warning(&self) -> Option<String> {
        if self.root_warnings.is_empty() {
            None
        } else {
            Some(self.root_warnings.join("; "))
        }
    }
}
