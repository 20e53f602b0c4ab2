//! Habitat metadata around glTF assets, parsed into typed values: `*.stage_config.json` and
//! `*.object_config.json` ([`Attributes`]), `*.scene_instance.json` ([`SceneInstance`]),
//! `*.scene_dataset_config.json` ([`DatasetConfig`]) and `*.semantic_config.json` region
//! annotations ([`Region`]), plus the frame and placement arithmetic Habitat applies to them
//! ([`frame_to_world`], [`Placement`]).
//!
//! Conventions, as in habitat-sim:
//! - quaternions are written `[w, x, y, z]` (scalar first);
//! - a frame is given by `up` and `front` in the asset's own axes; Habitat's frame is up = +Y,
//!   front = −Z, and the asset is rotated so that its `up`/`front` land there;
//! - `scale` (attributes) times `uniform_scale` times `non_uniform_scale` (instance) scales the
//!   re-oriented asset;
//! - `translation_origin: asset_local` puts the asset's own origin at `translation`; `com` (and
//!   an unset origin) puts its centre of mass there, which is the attributes' `COM` (scaled)
//!   or else the centre of the re-oriented, scaled asset's bounding box.
//!
//! Where this module's job ends: it reads JSON it is handed and resolves paths relative to the
//! file that holds them; finding files and loading geometry belong to the loader.

use crate::file_error::FileError;
use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3};
use serde::Deserialize;

use crate::invalid::Invalid;

use super::super::LoadError;

/// The placeholder Habitat replaces with the configuration's short name.
pub const CONFIG_NAME_TAG: &str = "%%CONFIG_NAME_AS_ASSET_FILENAME%%";

/// A file name as a configuration writes it, with the folder it is relative to.
#[derive(Debug, Clone, PartialEq)]
pub struct AssetRef {
    /// The text (may hold [`CONFIG_NAME_TAG`]).
    pub text: String,
    /// The folder of the file that wrote it.
    pub base: PathBuf,
}

impl AssetRef {
    /// The path, with [`CONFIG_NAME_TAG`] replaced by `config_name` and resolved against
    /// `tag_base` when the tag is present (Habitat names such files beside the asset), against
    /// [`base`](Self::base) otherwise.
    pub fn resolve(&self, config_name: &str, tag_base: &Path) -> PathBuf {
        if self.text.contains(CONFIG_NAME_TAG) {
            normalize(&tag_base.join(self.text.replace(CONFIG_NAME_TAG, config_name)))
        } else {
            normalize(&self.base.join(&self.text))
        }
    }
}

/// Stage or object attributes (the fields minos uses). Every field is optional so that
/// layers merge: dataset defaults, then the config file, then a dataset override.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Attributes {
    /// `render_asset`: the mesh that is drawn (and that minos loads).
    pub render_asset: Option<AssetRef>,
    /// `collision_asset`.
    pub collision_asset: Option<AssetRef>,
    /// `semantic_asset`: the semantic mesh (HM3D `.semantic.glb`).
    pub semantic_asset: Option<AssetRef>,
    /// `semantic_descriptor_filename`: the semantic table (HM3D `.semantic.txt`).
    pub semantic_descriptor: Option<AssetRef>,
    /// `up` in the asset's axes.
    pub up: Option<Vec3>,
    /// `front` in the asset's axes.
    pub front: Option<Vec3>,
    /// `origin` (read, not applied: habitat-sim does not apply it either).
    pub origin: Option<Vec3>,
    /// `scale`.
    pub scale: Option<Vec3>,
    /// `units_to_meters` (read; only 1 is supported).
    pub units_to_meters: Option<f32>,
    /// `COM`: centre of mass in the re-oriented, unscaled asset.
    pub com: Option<Vec3>,
}

impl Attributes {
    /// These attributes with every field `top` sets replaced by `top`'s.
    pub fn under(mut self, top: &Attributes) -> Attributes {
        macro_rules! take {
            ($($f:ident),*) => {$(
                if top.$f.is_some() {
                    self.$f = top.$f.clone();
                }
            )*};
        }
        take!(
            render_asset,
            collision_asset,
            semantic_asset,
            semantic_descriptor,
            up,
            front,
            origin,
            scale,
            units_to_meters,
            com
        );
        self
    }
}

#[derive(Debug, Default, Deserialize)]
struct AttributesJson {
    render_asset: Option<String>,
    collision_asset: Option<String>,
    semantic_asset: Option<String>,
    semantic_descriptor_filename: Option<String>,
    up: Option<[f64; 3]>,
    front: Option<[f64; 3]>,
    origin: Option<[f64; 3]>,
    scale: Option<[f64; 3]>,
    units_to_meters: Option<f64>,
    #[serde(rename = "COM")]
    com: Option<[f64; 3]>,
}

impl AttributesJson {
    fn typed(self, base: &Path, path: &Path, record: &str) -> Result<Attributes, LoadError> {
        let asset = |s: Option<String>| {
            s.filter(|s| !s.trim().is_empty()).map(|text| AssetRef {
                text,
                base: base.to_path_buf(),
            })
        };
        let vec = |v: Option<[f64; 3]>, field: &str| -> Result<Option<Vec3>, LoadError> {
            v.map(|v| finite_vec(v, path, record, field)).transpose()
        };
        let units = match self.units_to_meters {
            Some(u) if !(u.is_finite() && u > 0.0) => {
                return Err(field_error(
                    path,
                    record,
                    format!("units_to_meters is {u}, expected a positive number"),
                ))
            }
            u => u.map(|u| u as f32),
        };
        let scale = vec(self.scale, "scale")?;
        if let Some(s) = scale.filter(|s| s.x * s.y * s.z == 0.0) {
            return Err(field_error(
                path,
                record,
                format!("scale {s} has a zero component"),
            ));
        }
        Ok(Attributes {
            render_asset: asset(self.render_asset),
            collision_asset: asset(self.collision_asset),
            semantic_asset: asset(self.semantic_asset),
            semantic_descriptor: asset(self.semantic_descriptor_filename),
            up: vec(self.up, "up")?,
            front: vec(self.front, "front")?,
            origin: vec(self.origin, "origin")?,
            scale,
            units_to_meters: units,
            com: vec(self.com, "COM")?,
        })
    }
}

/// An error about one record of a file (`record` empty: the file as a whole).
fn field_error(path: &Path, record: &str, message: impl Into<String>) -> LoadError {
    if record.is_empty() {
        LoadError::parse(path, message)
    } else {
        LoadError::node(path, record, message)
    }
}

fn finite_vec(v: [f64; 3], path: &Path, record: &str, field: &str) -> Result<Vec3, LoadError> {
    if v.iter().all(|x| x.is_finite() && x.abs() < 1e12) {
        Ok(Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32))
    } else {
        Err(field_error(
            path,
            record,
            format!("{field} {v:?} is not a finite vector"),
        ))
    }
}

/// serde_json's message as `line L column C: what`, without its trailing position.
pub fn json_error(path: &Path, e: &serde_json::Error) -> LoadError {
    LoadError::parse(path, crate::scene::formats::json_error_text(e))
}

/// Reads a JSON file.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io(FileError::new(path, source)))?;
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(&bytes);
    serde_json::from_slice(bytes).map_err(|e| json_error(path, &e))
}

/// Parses a `*.stage_config.json` or `*.object_config.json`; relative paths are relative to
/// its folder.
pub fn read_attributes(path: &Path) -> Result<Attributes, LoadError> {
    let json: AttributesJson = read_json(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    json.typed(base, path, "")
}

/// A template a scene dataset config defines (`configs` of `stages` or `objects`).
#[derive(Debug, Clone, PartialEq)]
pub struct Template {
    /// `template_handle`, the name scene instances use.
    pub handle: String,
    /// `original_file`: the config file the template starts from, if any.
    pub original_file: Option<PathBuf>,
    /// `attributes` overriding the original file's.
    pub attributes: Attributes,
}

/// A `*.scene_dataset_config.json`: defaults and templates for stages and objects, and the
/// default semantic scene of scene instances. Its `paths` lists are not read: the loader
/// searches the whole root.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetConfig {
    /// The file.
    pub path: PathBuf,
    /// `stages.default_attributes`.
    pub stage_defaults: Attributes,
    /// `objects.default_attributes`.
    pub object_defaults: Attributes,
    /// `stages.configs`.
    pub stage_templates: Vec<Template>,
    /// `objects.configs`.
    pub object_templates: Vec<Template>,
    /// `scene_instances.default_attributes.semantic_scene_instance`.
    pub semantic_scene_default: Option<String>,
}

#[derive(Debug, Default, Deserialize)]
struct DatasetJson {
    #[serde(default)]
    stages: Option<SectionJson>,
    #[serde(default)]
    objects: Option<SectionJson>,
    #[serde(default)]
    scene_instances: Option<SceneSectionJson>,
}

#[derive(Debug, Default, Deserialize)]
struct SectionJson {
    #[serde(default)]
    default_attributes: Option<AttributesJson>,
    #[serde(default)]
    configs: Vec<TemplateJson>,
}

#[derive(Debug, Deserialize)]
struct TemplateJson {
    #[serde(default)]
    original_file: Option<String>,
    #[serde(default)]
    template_handle: Option<String>,
    #[serde(default)]
    attributes: Option<AttributesJson>,
}

#[derive(Debug, Default, Deserialize)]
struct SceneSectionJson {
    #[serde(default)]
    default_attributes: Option<SceneDefaultsJson>,
}

#[derive(Debug, Default, Deserialize)]
struct SceneDefaultsJson {
    #[serde(default)]
    semantic_scene_instance: Option<String>,
}

/// Parses a `*.scene_dataset_config.json`.
pub fn read_dataset_config(path: &Path) -> Result<DatasetConfig, LoadError> {
    let json: DatasetJson = read_json(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    let section =
        |s: Option<SectionJson>, name: &str| -> Result<(Attributes, Vec<Template>), LoadError> {
            let s = s.unwrap_or_default();
            let defaults = match s.default_attributes {
                Some(d) => d.typed(base, path, &format!("{name}.default_attributes"))?,
                None => Attributes::default(),
            };
            let mut templates = Vec::new();
            for (i, t) in s.configs.into_iter().enumerate() {
                let record = format!("{name}.configs[{i}]");
                let handle = t
                    .template_handle
                    .filter(|h| !h.trim().is_empty())
                    .ok_or_else(|| LoadError::node(path, &record, "missing `template_handle`"))?;
                templates.push(Template {
                    handle,
                    original_file: t
                        .original_file
                        .filter(|f| !f.trim().is_empty())
                        .map(|f| normalize(&base.join(f))),
                    attributes: match t.attributes {
                        Some(a) => a.typed(base, path, &record)?,
                        None => Attributes::default(),
                    },
                });
            }
            Ok((defaults, templates))
        };
    let (stage_defaults, stage_templates) = section(json.stages, "stages")?;
    let (object_defaults, object_templates) = section(json.objects, "objects")?;
    Ok(DatasetConfig {
        path: path.to_path_buf(),
        stage_defaults,
        object_defaults,
        stage_templates,
        object_templates,
        semantic_scene_default: json
            .scene_instances
            .and_then(|s| s.default_attributes)
            .and_then(|d| d.semantic_scene_instance)
            .filter(|s| !s.trim().is_empty()),
    })
}

/// Where an instance's `translation` puts the asset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TranslationOrigin {
    /// Not given: the centre of mass (habitat-sim's behaviour without a scene default).
    #[default]
    Unknown,
    /// The asset's own origin.
    AssetLocal,
    /// The centre of mass.
    Com,
}

/// How an object instance moves in simulation. minos places every instance as a static
/// obstacle whatever its motion type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MotionType {
    /// Not given.
    #[default]
    Undefined,
    /// `STATIC`.
    Static,
    /// `KINEMATIC`.
    Kinematic,
    /// `DYNAMIC`.
    Dynamic,
}

/// A stage or object instance of a scene instance.
#[derive(Debug, Clone, PartialEq)]
pub struct Instance {
    /// Where it is in the file (`stage_instance`, `object_instances[3]`).
    pub record: String,
    /// `template_name`.
    pub template: String,
    /// `translation`.
    pub translation: Vec3,
    /// `rotation` (written `[w, x, y, z]`), normalised.
    pub rotation: Quat,
    /// `uniform_scale` × `non_uniform_scale`.
    pub scale: Vec3,
    /// `motion_type`.
    pub motion: MotionType,
    /// `translation_origin` of this instance.
    pub origin: TranslationOrigin,
}

/// A `*.scene_instance.json`.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneInstance {
    /// The scene-wide `translation_origin`.
    pub translation_origin: TranslationOrigin,
    /// `stage_instance`.
    pub stage: Option<Instance>,
    /// `object_instances`.
    pub objects: Vec<Instance>,
    /// Number of `articulated_object_instances` (not loaded).
    pub articulated: usize,
    /// `semantic_scene_instance`.
    pub semantic_scene: Option<String>,
}

#[derive(Debug, Deserialize)]
struct SceneInstanceJson {
    #[serde(default)]
    translation_origin: Option<String>,
    #[serde(default)]
    stage_instance: Option<serde_json::Value>,
    #[serde(default)]
    object_instances: Vec<serde_json::Value>,
    #[serde(default)]
    articulated_object_instances: Vec<serde_json::Value>,
    #[serde(default)]
    semantic_scene_instance: Option<String>,
}

#[derive(Debug, Deserialize)]
struct InstanceJson {
    #[serde(default)]
    template_name: Option<String>,
    #[serde(default)]
    translation: Option<[f64; 3]>,
    #[serde(default)]
    rotation: Option<[f64; 4]>,
    #[serde(default)]
    uniform_scale: Option<f64>,
    #[serde(default)]
    non_uniform_scale: Option<[f64; 3]>,
    #[serde(default)]
    motion_type: Option<String>,
    #[serde(default)]
    translation_origin: Option<String>,
}

fn parse_origin(
    s: Option<&str>,
    path: &Path,
    record: &str,
    warnings: &mut Vec<String>,
) -> TranslationOrigin {
    match s.map(|s| s.trim().to_ascii_lowercase()).as_deref() {
        None | Some("") | Some("unknown") => TranslationOrigin::Unknown,
        Some("asset_local") => TranslationOrigin::AssetLocal,
        Some("com") => TranslationOrigin::Com,
        Some(other) => {
            warnings.push(format!(
                "{}: {record}: translation_origin `{other}` is not asset_local or com; treated as unset",
                path.display()
            ));
            TranslationOrigin::Unknown
        }
    }
}

/// Parses a `*.scene_instance.json`; non-fatal remarks go to `warnings`.
pub fn read_scene_instance(
    path: &Path,
    warnings: &mut Vec<String>,
) -> Result<SceneInstance, LoadError> {
    let json: SceneInstanceJson = read_json(path)?;
    let translation_origin = parse_origin(
        json.translation_origin.as_deref(),
        path,
        "translation_origin",
        warnings,
    );
    let stage = json
        .stage_instance
        .map(|v| instance(v, "stage_instance".into(), path, warnings))
        .transpose()?;
    let objects = json
        .object_instances
        .into_iter()
        .enumerate()
        .map(|(i, v)| instance(v, format!("object_instances[{i}]"), path, warnings))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(SceneInstance {
        translation_origin,
        stage,
        objects,
        articulated: json.articulated_object_instances.len(),
        semantic_scene: json
            .semantic_scene_instance
            .filter(|s| !s.trim().is_empty()),
    })
}

fn instance(
    value: serde_json::Value,
    record: String,
    path: &Path,
    warnings: &mut Vec<String>,
) -> Result<Instance, LoadError> {
    let json: InstanceJson = serde_json::from_value(value)
        .map_err(|e| LoadError::node(path, &record, crate::scene::formats::json_message(&e)))?;
    let template = json
        .template_name
        .map(|t| t.trim().to_string())
        .filter(|t| !t.is_empty())
        .ok_or_else(|| LoadError::node(path, &record, "missing `template_name`"))?;
    let translation = match json.translation {
        Some(t) => finite_vec(t, path, &record, "translation")?,
        None => Vec3::ZERO,
    };
    let rotation = match json.rotation {
        Some(q) => {
            if !q.iter().all(|v| v.is_finite()) {
                return Err(LoadError::node(
                    path,
                    &record,
                    format!("rotation {q:?} is not finite"),
                ));
            }
            // Habitat writes quaternions scalar first: [w, x, y, z].
            let quat = Quat::from_xyzw(q[1] as f32, q[2] as f32, q[3] as f32, q[0] as f32);
            if quat.length() < 1e-6 {
                return Err(LoadError::node(
                    path,
                    &record,
                    format!("rotation {q:?} is a zero quaternion (expected [w, x, y, z])"),
                ));
            }
            quat.normalize()
        }
        None => Quat::IDENTITY,
    };
    let uniform = json.uniform_scale.unwrap_or(1.0);
    let non_uniform = match json.non_uniform_scale {
        Some(s) => finite_vec(s, path, &record, "non_uniform_scale")?,
        None => Vec3::ONE,
    };
    if !uniform.is_finite() {
        return Err(LoadError::node(
            path,
            &record,
            format!("uniform_scale {uniform} is not finite"),
        ));
    }
    let scale = non_uniform * uniform as f32;
    if scale.x * scale.y * scale.z == 0.0 {
        return Err(LoadError::node(
            path,
            &record,
            format!("scale {scale} (uniform_scale × non_uniform_scale) has a zero component"),
        ));
    }
    let motion = match json
        .motion_type
        .as_deref()
        .map(|m| m.trim().to_ascii_lowercase())
        .as_deref()
    {
        None | Some("") | Some("undefined") => MotionType::Undefined,
        Some("static") => MotionType::Static,
        Some("kinematic") => MotionType::Kinematic,
        Some("dynamic") => MotionType::Dynamic,
        Some(other) => {
            warnings.push(format!(
                "{}: {record}: motion_type `{other}` is not STATIC, KINEMATIC or DYNAMIC; ignored",
                path.display()
            ));
            MotionType::Undefined
        }
    };
    let origin = parse_origin(json.translation_origin.as_deref(), path, &record, warnings);
    Ok(Instance {
        record,
        template,
        translation,
        rotation,
        scale,
        motion,
        origin,
    })
}

/// A region annotation of a `*.semantic_config.json`: a labelled floor polygon.
#[derive(Debug, Clone, PartialEq)]
pub struct Region {
    /// `name`.
    pub name: String,
    /// `label` (a room type such as `bedroom`).
    pub label: String,
    /// `poly_loop` projected on XZ.
    pub polygon: Vec<[f32; 2]>,
    /// `floor_height`.
    pub floor_height: f32,
    /// `min_bounds`..`max_bounds` (or the polygon extruded by `extrusion_height`).
    pub min: Vec3,
    /// See [`min`](Self::min).
    pub max: Vec3,
}

#[derive(Debug, Deserialize)]
struct SemanticConfigJson {
    #[serde(default)]
    region_annotations: Vec<RegionJson>,
}

#[derive(Debug, Deserialize)]
struct RegionJson {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    label: Option<String>,
    poly_loop: Vec<[f64; 3]>,
    #[serde(default)]
    floor_height: Option<f64>,
    #[serde(default)]
    extrusion_height: Option<f64>,
    #[serde(default)]
    min_bounds: Option<[f64; 3]>,
    #[serde(default)]
    max_bounds: Option<[f64; 3]>,
}

/// Parses the region annotations of a `*.semantic_config.json`.
pub fn read_semantic_config(path: &Path) -> Result<Vec<Region>, LoadError> {
    let json: SemanticConfigJson = read_json(path)?;
    let mut regions = Vec::new();
    for (i, r) in json.region_annotations.into_iter().enumerate() {
        let record = format!("region_annotations[{i}]");
        if r.poly_loop.len() < 3 {
            return Err(LoadError::node(
                path,
                &record,
                format!(
                    "poly_loop has {} points, expected at least 3",
                    r.poly_loop.len()
                ),
            ));
        }
        let points = r
            .poly_loop
            .iter()
            .map(|p| finite_vec(*p, path, &record, "poly_loop"))
            .collect::<Result<Vec<_>, _>>()?;
        let low = points.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
        let floor_height = match r.floor_height {
            Some(h) if h.is_finite() => h as f32,
            Some(h) => {
                return Err(LoadError::node(
                    path,
                    &record,
                    format!("floor_height {h} is not finite"),
                ))
            }
            None => low,
        };
        let extrusion = r.extrusion_height.filter(|h| h.is_finite()).unwrap_or(0.0) as f32;
        let mut min = points.iter().fold(Vec3::INFINITY, |a, p| a.min(*p));
        let mut max = points.iter().fold(Vec3::NEG_INFINITY, |a, p| a.max(*p));
        min.y = floor_height;
        max.y = max.y.max(floor_height + extrusion);
        if let Some(b) = r.min_bounds {
            min = finite_vec(b, path, &record, "min_bounds")?;
        }
        if let Some(b) = r.max_bounds {
            max = finite_vec(b, path, &record, "max_bounds")?;
        }
        regions.push(Region {
            name: r
                .name
                .filter(|n| !n.trim().is_empty())
                .unwrap_or_else(|| format!("region_{i}")),
            label: r.label.unwrap_or_default(),
            polygon: points.iter().map(|p| [p.x, p.z]).collect(),
            floor_height,
            min,
            max,
        });
    }
    Ok(regions)
}

/// The rotation that takes an asset whose axes say `up` and `front` into Habitat's frame
/// (up = +Y, front = −Z). Missing `front` is −Z when that is orthogonal to `up`, else +Y;
/// missing `up` is +Y when orthogonal to `front`, else +Z.
pub fn frame_to_world(up: Option<Vec3>, front: Option<Vec3>) -> Result<Quat, Invalid> {
    let unit = |v: Vec3, name: &str| {
        v.try_normalize()
            .ok_or_else(|| format!("`{name}` {v} is not a direction"))
    };
    let orthogonal = |a: Vec3, b: Vec3| a.dot(b).abs() < 1e-3;
    let (up, front) = match (up, front) {
        (None, None) => (Vec3::Y, Vec3::NEG_Z),
        (Some(u), None) => {
            let u = unit(u, "up")?;
            let f = if orthogonal(u, Vec3::NEG_Z) {
                Vec3::NEG_Z
            } else {
                Vec3::Y
            };
            (u, f)
        }
        (None, Some(f)) => {
            let f = unit(f, "front")?;
            let u = if orthogonal(f, Vec3::Y) {
                Vec3::Y
            } else {
                Vec3::Z
            };
            (u, f)
        }
        (Some(u), Some(f)) => (unit(u, "up")?, unit(f, "front")?),
    };
    if !orthogonal(up, front) {
        return Err(format!("`up` {up} and `front` {front} are not orthogonal").into());
    }
    // habitat-sim's CoordinateFrame: world-to-frame turns +Y onto `up`, then the turned −Z
    // onto `front`; the asset goes the other way.
    let r1 = Quat::from_rotation_arc(Vec3::Y, up);
    let r2 = Quat::from_rotation_arc(r1 * Vec3::NEG_Z, front);
    Ok((r2 * r1).normalize().inverse())
}

/// Everything that places an object asset in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Asset frame to Habitat frame ([`frame_to_world`]).
    pub frame: Quat,
    /// Attributes `scale` × instance scale.
    pub scale: Vec3,
    /// Attributes `COM` (re-oriented, unscaled), if given.
    pub com: Option<Vec3>,
    /// Instance `translation`.
    pub translation: Vec3,
    /// Instance `rotation`.
    pub rotation: Quat,
    /// True when `translation` is where the asset's origin goes (`asset_local`), false when it
    /// is where its centre of mass goes.
    pub asset_local: bool,
}

impl Placement {
    /// The placement of `instance` in a scene whose default origin is `scene_origin`, as
    /// habitat-sim decides it: the asset origin is used when the instance says `asset_local`,
    /// or when the scene does and the instance does not say `com`.
    pub fn new(
        instance: &Instance,
        scene_origin: TranslationOrigin,
        frame: Quat,
        attributes_scale: Vec3,
        com: Option<Vec3>,
    ) -> Self {
        let asset_local = instance.origin == TranslationOrigin::AssetLocal
            || (scene_origin == TranslationOrigin::AssetLocal
                && instance.origin != TranslationOrigin::Com);
        Placement {
            frame,
            scale: attributes_scale * instance.scale,
            com,
            translation: instance.translation,
            rotation: instance.rotation,
            asset_local,
        }
    }

    /// Asset (file) space to the re-oriented, scaled object space.
    pub fn local(&self) -> Mat4 {
        Mat4::from_scale(self.scale) * Mat4::from_quat(self.frame)
    }

    /// The model-to-world transform; `bbox_center` is the centre of the asset's box in object
    /// space (used when no `COM` is given).
    pub fn transform(&self, bbox_center: Vec3) -> Mat4 {
        let mut m = Mat4::from_translation(self.translation) * Mat4::from_quat(self.rotation);
        if !self.asset_local {
            let com = self.com.map_or(bbox_center, |c| c * self.scale);
            m *= Mat4::from_translation(-com);
        }
        m * self.local()
    }
}

/// `path` with `.` removed and `..` applied lexically (no file system access), so paths built
/// from different folders compare equal.
pub fn normalize(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                if !out.pop() {
                    out.push("..");
                }
            }
            other => out.push(other.as_os_str()),
        }
    }
    if out.as_os_str().is_empty() {
        out.push(".");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-5
    }

    #[test]
    fn z_up_front_y_maps_as_habitat_does() {
        let q = frame_to_world(Some(Vec3::Z), Some(Vec3::Y)).unwrap();
        // (x, y, z) z-up -> (x, z, -y) y-up.
        assert!(close(
            q * Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(1.0, 3.0, -2.0)
        ));
        let id = frame_to_world(None, None).unwrap();
        assert!(close(
            id * Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(1.0, 2.0, 3.0)
        ));
        // `up` alone: front defaults to +Y for a z-up asset.
        let q2 = frame_to_world(Some(Vec3::Z), None).unwrap();
        assert!(close(q2 * Vec3::X, Vec3::X) && close(q2 * Vec3::Z, Vec3::Y));
        assert!(frame_to_world(Some(Vec3::Z), Some(Vec3::Z)).is_err());
        assert!(frame_to_world(Some(Vec3::ZERO), None).is_err());
    }

    #[test]
    fn com_placement_moves_the_box_centre_to_the_translation() {
        let inst = Instance {
            record: "object_instances[0]".into(),
            template: "t".into(),
            translation: Vec3::new(1.0, 0.0, 0.0),
            rotation: Quat::IDENTITY,
            scale: Vec3::splat(2.0),
            motion: MotionType::Static,
            origin: TranslationOrigin::Unknown,
        };
        let com = Placement::new(
            &inst,
            TranslationOrigin::Unknown,
            Quat::IDENTITY,
            Vec3::ONE,
            None,
        );
        assert!(!com.asset_local);
        // A box centred at (0.5, 0.5, 0.5) in object space lands centred on the translation.
        let m = com.transform(Vec3::splat(0.5));
        assert!(close(
            m.transform_point3(Vec3::splat(0.25)),
            Vec3::new(1.0, 0.0, 0.0)
        ));
        let local = Placement::new(
            &inst,
            TranslationOrigin::AssetLocal,
            Quat::IDENTITY,
            Vec3::ONE,
            None,
        );
        assert!(local.asset_local);
        let m = local.transform(Vec3::splat(0.5));
        assert!(close(
            m.transform_point3(Vec3::ZERO),
            Vec3::new(1.0, 0.0, 0.0)
        ));
        assert!(close(m.transform_point3(Vec3::X), Vec3::new(3.0, 0.0, 0.0)));
    }

    #[test]
    fn normalize_is_lexical() {
        assert_eq!(
            normalize(Path::new("/a/b/./c/../d.glb")),
            PathBuf::from("/a/b/d.glb")
        );
    }
}
