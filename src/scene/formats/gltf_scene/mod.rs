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
pub mod habitat;
pub mod semantic;

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};

use crate::scene::model::{Categories, Dataset};

use self::assemble::{Assembler, StageSpec};
use self::habitat::{
    frame_to_world, normalize, read_attributes, read_dataset_config, read_scene_instance,
    read_semantic_config, Attributes, DatasetConfig, Placement, CONFIG_NAME_TAG,
};
use self::semantic::{category_from_name, CategoryMap};

use super::{DatasetLoader, LoadError, LoadedScene, SceneEntry};

pub use self::assemble::STAGE_ROOM_ID;

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

/// Stage or object configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Kind {
    Stage,
    Object,
}

impl Kind {
    fn suffix(self) -> &'static str {
        match self {
            Kind::Stage => STAGE_CONFIG,
            Kind::Object => OBJECT_CONFIG,
        }
    }
    fn name(self) -> &'static str {
        match self {
            Kind::Stage => "stage",
            Kind::Object => "object",
        }
    }
}

/// A template resolved to its asset and merged attributes.
#[derive(Debug, Clone)]
struct Resolved {
    asset: PathBuf,
    attributes: Attributes,
    /// The most specific configuration file (for errors about its values).
    config: PathBuf,
    sources: Vec<PathBuf>,
}

/// Why a template did not resolve.
enum ResolveError {
    /// Nothing of that name.
    Missing,
    /// A configuration was found but cannot be used.
    Load(LoadError),
}

impl From<LoadError> for ResolveError {
    fn from(e: LoadError) -> Self {
        ResolveError::Load(e)
    }
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
        let meta = std::fs::metadata(root).map_err(|source| LoadError::Io {
            path: root.clone(),
            source,
        })?;
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
    pub fn category_table(&self) -> Option<&Path> {
        self.category_table.as_deref()
    }

    /// Remarks about the root as a whole (skipped duplicate ids, ambiguous stage configs).
    pub fn root_warnings(&self) -> &[String] {
        &self.root_warnings
    }

    /// Every scene under the root, sorted by id.
    pub fn discover(&self) -> Result<Vec<SceneEntry>, LoadError> {
        Ok(self.scenes.clone())
    }

    /// Maps each stage config's render asset to it (by name when the config cannot be read,
    /// so that loading the asset reports the config's error instead of ignoring it).
    fn map_stage_configs(&mut self) {
        let mut map: HashMap<PathBuf, PathBuf> = HashMap::new();
        for cfg in &self.index.stage_configs {
            let dir = cfg.parent().unwrap_or(Path::new("."));
            let name = short_name(cfg);
            let assets: Vec<PathBuf> = match read_attributes(cfg) {
                Ok(a) => a
                    .render_asset
                    .map(|r| r.resolve(base_name(&name), dir))
                    .into_iter()
                    .collect(),
                Err(_) => ["glb", "gltf"]
                    .iter()
                    .map(|e| normalize(&dir.join(format!("{name}.{e}"))))
                    .collect(),
            };
            for a in assets {
                if let Some(first) = map.get(&a) {
                    self.root_warnings.push(format!(
                        "{}: describes {} already described by {}; ignored",
                        cfg.display(),
                        a.display(),
                        first.display()
                    ));
                } else {
                    map.insert(a, cfg.clone());
                }
            }
        }
        self.index.stage_config_of = map;
    }

    /// Scene instances, then assets that are not parts of something else.
    fn find_scenes(&mut self) -> Vec<SceneEntry> {
        let mut parts: HashSet<PathBuf> = HashSet::new();
        for cfg in &self.index.object_configs {
            let dir = cfg.parent().unwrap_or(Path::new("."));
            let name = short_name(cfg);
            match read_attributes(cfg) {
                Ok(a) => {
                    for r in [&a.render_asset, &a.collision_asset, &a.semantic_asset]
                        .into_iter()
                        .flatten()
                    {
                        parts.insert(r.resolve(base_name(&name), dir));
                    }
                }
                Err(_) => {
                    for e in ["glb", "gltf"] {
                        parts.insert(normalize(&dir.join(format!("{name}.{e}"))));
                    }
                }
            }
        }
        for cfg in &self.index.stage_configs {
            if let Ok(a) = read_attributes(cfg) {
                let dir = cfg.parent().unwrap_or(Path::new("."));
                let name = short_name(cfg);
                for r in [&a.collision_asset, &a.semantic_asset]
                    .into_iter()
                    .flatten()
                {
                    parts.insert(r.resolve(base_name(&name), dir));
                }
            }
        }
        for si in &self.index.scene_instances {
            let mut ignored = Vec::new();
            let Ok(instance) = read_scene_instance(si, &mut ignored) else {
                continue;
            };
            if let Some(stage) = instance.stage {
                if let Ok(r) = self.resolve(Kind::Stage, &stage.template, si) {
                    parts.insert(r.asset);
                }
            }
        }
        let mut scenes: Vec<SceneEntry> = Vec::new();
        let mut ids: HashMap<String, PathBuf> = HashMap::new();
        let candidates = self
            .index
            .scene_instances
            .iter()
            .map(|p| (short_name(p), p))
            .chain(
                self.index
                    .assets
                    .iter()
                    .filter(|a| !parts.contains(*a))
                    .filter(|a| {
                        let n = file_name(a);
                        strip_suffix_ci(n, ".semantic.glb").is_none()
                            && strip_suffix_ci(n, ".semantic.gltf").is_none()
                    })
                    .map(|p| (short_name(p), p)),
            );
        for (id, path) in candidates {
            if let Some(first) = ids.get(&id) {
                self.root_warnings.push(format!(
                    "{}: scene id `{id}` already taken by {}; skipped",
                    path.display(),
                    first.display()
                ));
                continue;
            }
            ids.insert(id.clone(), path.clone());
            scenes.push(SceneEntry {
                id,
                path: path.clone(),
            });
        }
        scenes.sort();
        scenes
    }

    /// The scene dataset configs that apply to a file: those in a folder above it.
    fn datasets_for(&self, near: &Path) -> Vec<&DatasetConfig> {
        self.index
            .datasets
            .iter()
            .filter(|d| d.path.parent().is_some_and(|dir| near.starts_with(dir)))
            .collect()
    }

    /// Merged dataset defaults for `kind` near a file (the first dataset config wins).
    fn defaults(&self, kind: Kind, near: &Path) -> (Attributes, Vec<PathBuf>) {
        let datasets = self.datasets_for(near);
        let mut attributes = Attributes::default();
        for d in datasets.iter().rev() {
            let layer = match kind {
                Kind::Stage => &d.stage_defaults,
                Kind::Object => &d.object_defaults,
            };
            attributes = attributes.under(layer);
        }
        (
            attributes,
            datasets.iter().map(|d| d.path.clone()).collect(),
        )
    }

    /// Finds a config file of `kind` named `template`: `<template><suffix>` beside `near`, else
    /// one whose path without the suffix ends with `/<template>` (preferring `near`'s folder).
    fn find_config(&self, kind: Kind, template: &str, near: &Path) -> Option<PathBuf> {
        let t = template.trim().trim_start_matches("./");
        let t = strip_suffix_ci(t, kind.suffix()).unwrap_or(t);
        let leaf = t.rsplit('/').next().unwrap_or(t);
        let list = self.index.config_names.get(&(kind, leaf.to_string()))?;
        let dir = near.parent().unwrap_or(Path::new("."));
        let direct = normalize(&dir.join(format!("{t}{}", kind.suffix())));
        if list.contains(&direct) {
            return Some(direct);
        }
        let tail = format!("/{t}");
        let matches: Vec<&PathBuf> = list
            .iter()
            .filter(|p| {
                let s = p.to_string_lossy();
                strip_suffix_ci(&s, kind.suffix()).is_some_and(|k| k == t || k.ends_with(&tail))
            })
            .collect();
        matches
            .iter()
            .find(|p| p.parent() == Some(dir))
            .or(matches.first())
            .map(|p| (*p).clone())
    }

    /// Finds an asset file named `template` (a path relative to `near`, or a name with or
    /// without its extension, preferring `near`'s folder).
    fn find_asset(&self, template: &str, near: &Path) -> Option<PathBuf> {
        let t = template.trim().trim_start_matches("./");
        let dir = near.parent().unwrap_or(Path::new("."));
        let direct = normalize(&dir.join(t));
        if is_asset(&direct) && direct.is_file() {
            return Some(direct);
        }
        let leaf = t.rsplit('/').next().unwrap_or(t);
        let list = self.index.asset_names.get(leaf)?;
        let tail = format!("/{t}");
        let matches: Vec<&PathBuf> = list
            .iter()
            .filter(|p| {
                let s = p.to_string_lossy();
                let no_ext = p.with_extension("");
                let no_ext = no_ext.to_string_lossy();
                s.ends_with(&tail) || s == t || no_ext.ends_with(&tail) || no_ext == t
            })
            .collect();
        matches
            .iter()
            .find(|p| p.parent() == Some(dir))
            .or(matches.first())
            .map(|p| (*p).clone())
    }

    /// Resolves a template a scene instance (or nothing: `near` is the asset itself) names.
    fn resolve(&self, kind: Kind, template: &str, near: &Path) -> Result<Resolved, ResolveError> {
        let (mut attributes, mut sources) = self.defaults(kind, near);
        let datasets = self.datasets_for(near);
        let dataset_template = datasets.iter().find_map(|d| {
            let list = match kind {
                Kind::Stage => &d.stage_templates,
                Kind::Object => &d.object_templates,
            };
            list.iter().find(|t| t.handle == template).map(|t| (d, t))
        });
        let (config, name) = if let Some((d, t)) = dataset_template {
            let mut config = d.path.clone();
            let mut name = short_name(Path::new(&t.handle));
            if let Some(f) = &t.original_file {
                attributes = attributes.under(&read_attributes(f)?);
                sources.push(f.clone());
                config = f.clone();
                name = short_name(f);
            }
            attributes = attributes.under(&t.attributes);
            (config, name)
        } else if let Some(f) = self.find_config(kind, template, near) {
            attributes = attributes.under(&read_attributes(&f)?);
            sources.push(f.clone());
            let name = short_name(&f);
            (f, name)
        } else if let Some(asset) = self.find_asset(template, near) {
            let mut config = asset.clone();
            if kind == Kind::Stage {
                if let Some(f) = self.index.stage_config_of.get(&asset) {
                    attributes = attributes.under(&read_attributes(f)?);
                    sources.push(f.clone());
                    config = f.clone();
                }
            }
            return Ok(Resolved {
                asset,
                attributes,
                config,
                sources,
            });
        } else {
            return Err(ResolveError::Missing);
        };
        let dir = config.parent().unwrap_or(Path::new("."));
        let Some(render) = &attributes.render_asset else {
            return Err(LoadError::parse(
                &config,
                format!(
                    "{} template `{template}` has no `render_asset`",
                    kind.name()
                ),
            )
            .into());
        };
        let asset = render.resolve(base_name(&name), dir);
        if !asset.is_file() {
            return Err(LoadError::parse(
                &config,
                format!(
                    "render_asset `{}` not found (looked for {})",
                    render.text,
                    asset.display()
                ),
            )
            .into());
        }
        Ok(Resolved {
            asset,
            attributes,
            config,
            sources,
        })
    }

    /// The stage attributes of a plain asset: dataset defaults and its stage config.
    fn stage_for_asset(&self, asset: &Path) -> Result<Resolved, LoadError> {
        let (mut attributes, mut sources) = self.defaults(Kind::Stage, asset);
        let mut config = asset.to_path_buf();
        if let Some(f) = self.index.stage_config_of.get(asset) {
            attributes = attributes.under(&read_attributes(f)?);
            sources.push(f.clone());
            config = f.clone();
        }
        Ok(Resolved {
            asset: asset.to_path_buf(),
            attributes,
            config,
            sources,
        })
    }

    /// A stage ready to assemble: frame, scale and semantic files; remarks on what is ignored.
    fn stage_spec(&self, r: &Resolved, warnings: &mut Vec<String>) -> Result<StageSpec, LoadError> {
        let a = &r.attributes;
        let rotation = frame_to_world(a.up, a.front).map_err(|m| LoadError::parse(&r.config, m))?;
        if let Some(o) = a.origin.filter(|o| *o != Vec3::ZERO) {
            warnings.push(format!(
                "{}: stage origin {o} not applied (habitat-sim does not apply it either)",
                r.config.display()
            ));
        }
        if let Some(u) = a.units_to_meters.filter(|u| (u - 1.0).abs() > 1e-6) {
            warnings.push(format!(
                "{}: units_to_meters {u} not applied (only `scale` is)",
                r.config.display()
            ));
        }
        let dir = r.asset.parent().unwrap_or(Path::new("."));
        let stem = r
            .asset
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let base = base_name(&stem).to_string();
        let beside = |ext: &str| -> Vec<PathBuf> {
            let mut v = vec![dir.join(format!("{stem}.{ext}"))];
            if base != stem {
                v.push(dir.join(format!("{base}.{ext}")));
            }
            v
        };
        let pick = |explicit: &Option<habitat::AssetRef>, ext: &str| -> Option<PathBuf> {
            match explicit {
                Some(x) => Some(x.resolve(&base, dir)).filter(|p| p.is_file()),
                None => beside(ext).into_iter().find(|p| p.is_file()),
            }
        };
        let semantic_glb = pick(&a.semantic_asset, "semantic.glb").filter(|p| *p != r.asset);
        Ok(StageSpec {
            asset: r.asset.clone(),
            rotation,
            scale: a.scale.unwrap_or(Vec3::ONE),
            semantic_txt: pick(&a.semantic_descriptor, "semantic.txt"),
            semantic_glb,
        })
    }

    /// Categories of a scene-instance object named by `template`.
    fn template_categories(&self, template: &str) -> Categories {
        let last = template.rsplit(['/', '\\']).next().unwrap_or(template);
        let last = strip_suffix_ci(last, OBJECT_CONFIG).unwrap_or(last);
        match category_from_name(last, &self.categories) {
            Some(c) => self.categories.categories(&c),
            None => Categories::default(),
        }
    }

    /// The region annotations file of a scene instance, if one is named and found.
    fn semantic_config(
        &self,
        si: &Path,
        explicit: Option<&str>,
        warnings: &mut Vec<String>,
    ) -> Option<PathBuf> {
        let scene_name = short_name(si);
        let named = explicit.map(str::to_string).or_else(|| {
            self.datasets_for(si)
                .iter()
                .find_map(|d| d.semantic_scene_default.clone())
        })?;
        let name = named.replace(CONFIG_NAME_TAG, base_name(&scene_name));
        let file = if strip_suffix_ci(&name, SEMANTIC_CONFIG).is_some() {
            name.clone()
        } else {
            format!("{name}{SEMANTIC_CONFIG}")
        };
        let dir = si.parent().unwrap_or(Path::new("."));
        let direct = normalize(&dir.join(&file));
        let leaf = Path::new(&file)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let found = if self.index.semantic_configs.contains(&direct) {
            Some(direct)
        } else {
            self.index
                .semantic_configs
                .iter()
                .find(|p| file_name(p) == leaf)
                .cloned()
        };
        if found.is_none() && explicit.is_some() {
            warnings.push(format!(
                "{}: semantic_scene_instance `{named}` not found under {}; no regions",
                si.display(),
                self.root.display()
            ));
        }
        found
    }

    /// Loads one scene. Every failure names the file and the record.
    pub fn load(&self, entry: &SceneEntry) -> Result<LoadedScene, LoadError> {
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
                Err(ResolveError::Load(e)) => Err(LoadError::node(path, record, e.to_string())),
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
                .map_err(|e| LoadError::node(path, &stage.record, e.to_string()))?;
        }
        let mut resolved: HashMap<&str, (Resolved, Quat)> = HashMap::new();
        for (i, inst) in si.objects.iter().enumerate() {
            if !resolved.contains_key(inst.template.as_str()) {
                let r = resolve(Kind::Object, &inst.record, &inst.template)?;
                let frame = frame_to_world(r.attributes.up, r.attributes.front).map_err(|m| {
                    LoadError::node(
                        path,
                        &inst.record,
                        LoadError::parse(&r.config, m).to_string(),
                    )
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
            .map_err(|e| LoadError::node(path, &inst.record, e.to_string()))?;
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
    fn discover(&self) -> Result<Vec<SceneEntry>, LoadError> {
        GltfLoader::discover(self)
    }
    fn load(&self, entry: &SceneEntry) -> Result<LoadedScene, LoadError> {
        GltfLoader::load(self, entry)
    }
    fn root_warning(&self) -> Option<String> {
        if self.root_warnings.is_empty() {
            None
        } else {
            Some(self.root_warnings.join("; "))
        }
    }
}

/// Every file under `root` down to `max_depth` folder levels, sorted, paths normalised.
fn walk(root: &Path, max_depth: usize) -> Result<Vec<PathBuf>, LoadError> {
    let mut out = Vec::new();
    let mut stack = vec![(root.to_path_buf(), 0usize)];
    while let Some((dir, depth)) = stack.pop() {
        let entries = match std::fs::read_dir(&dir) {
            Ok(e) => e,
            Err(source) if depth == 0 => return Err(LoadError::Io { path: dir, source }),
            Err(_) => continue,
        };
        for e in entries.flatten() {
            if e.file_name().to_string_lossy().starts_with('.') {
                continue;
            }
            let Ok(kind) = e.file_type() else { continue };
            let path = e.path();
            if kind.is_dir() {
                if depth < max_depth {
                    stack.push((path, depth + 1));
                }
            } else if kind.is_file() || (kind.is_symlink() && path.is_file()) {
                out.push(normalize(&path));
            }
        }
    }
    out.sort();
    Ok(out)
}
