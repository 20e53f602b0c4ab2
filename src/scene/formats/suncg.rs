//! SUNCG houses: `house/<id>/house.json` with room meshes in `room/<id>/` and object meshes in
//! `object/<modelId>/`, categories from `metadata/ModelCategoryMapping.csv`.
//!
//! Mesh files may be `.obj` or `.gltf/.glb`. They are looked up in the standard SUNCG
//! folders first, then next to `house.json` (the layout of the public glTF sample).
//! `valid: 0` nodes are skipped, transforms are 4×4 column-major, mirrored transforms flip
//! winding (done once, in [`WorldMesh::place`](crate::scene::WorldMesh::place)), and
//! `hideFloor/hideCeiling/hideWalls` drop the corresponding room meshes.

use crate::file_error::FileError;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3};
use serde::Deserialize;

use crate::scene::Aabb;
use crate::scene::Mesh;
use crate::scene::{
    Categories, Dataset, Level, MaterialOverride, MeshId, Object, Room, Scene, Surface, SurfaceKind,
};
use crate::scene::{FlagTable, ModelCategories, RoomTypeTable};

use super::{
    load_mesh_file, nan_tokens_to_null, DatasetLoader, LoadError, LoadedScene, SceneEntry,
};

/// Mesh file extensions tried, in order.
const MESH_EXTENSIONS: [&str; 3] = ["obj", "gltf", "glb"];

#[derive(Debug, Deserialize)]
struct HouseJson {
    #[serde(default)]
    id: Option<String>,
    #[serde(default)]
    up: Option<[f64; 3]>,
    #[serde(default, rename = "scaleToMeters")]
    scale_to_meters: Option<f64>,
    levels: Vec<LevelJson>,
}

#[derive(Debug, Deserialize)]
struct LevelJson {
    #[serde(default)]
    nodes: Vec<NodeJson>,
}

#[derive(Debug, Deserialize)]
struct NodeJson {
    id: String,
    #[serde(rename = "type")]
    kind: String,
    #[serde(default)]
    valid: Option<i64>,
    #[serde(default, rename = "modelId")]
    model_id: Option<String>,
    #[serde(default)]
    transform: Option<Vec<Option<f64>>>,
    #[serde(default, rename = "roomTypes")]
    room_types: Vec<String>,
    #[serde(default, rename = "nodeIndices")]
    node_indices: Vec<usize>,
    #[serde(default)]
    materials: Vec<MaterialJson>,
    #[serde(default, rename = "hideFloor")]
    hide_floor: Option<i64>,
    #[serde(default, rename = "hideCeiling")]
    hide_ceiling: Option<i64>,
    #[serde(default, rename = "hideWalls")]
    hide_walls: Option<i64>,
}

#[derive(Debug, Deserialize)]
struct MaterialJson {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    diffuse: Option<String>,
    #[serde(default)]
    texture: Option<String>,
}

/// Loads SUNCG houses from one dataset root.
pub struct SuncgLoader {
    root: PathBuf,
    categories: ModelCategories,
    mapping_path: Option<PathBuf>,
    room_types: RoomTypeTable,
    flags: FlagTable,
}

impl SuncgLoader {
    /// A loader for `root`, reading categories from `mapping` or, when `None`, from
    /// `root/metadata/ModelCategoryMapping.csv` (or any `*ModelCategoryMapping.csv` there).
    /// Without any table, objects get no categories (a warning per house says so).
    pub fn open(root: &Path, mapping: Option<&Path>) -> Result<Self, LoadError> {
        let mapping_path = match mapping {
            Some(p) => Some(p.to_path_buf()),
            None => find_mapping(root),
        };
        let categories = match &mapping_path {
            Some(p) => {
                let text = std::fs::read_to_string(p).map_err(|source| LoadError::Io(FileError::new(p.clone(), source)))?;
                ModelCategories::parse(&text, &p.display().to_string())
                    .map_err(|m| LoadError::parse(p, m))?
            }
            None => ModelCategories::default(),
        };
        Ok(SuncgLoader {
            root: root.to_path_buf(),
            categories,
            mapping_path,
            room_types: RoomTypeTable::suncg(),
            flags: FlagTable::builtin(),
        })
    }

    /// The category table in use, if one was found.
    #[cfg(feature = "internals")]
    pub fn mapping_path(&self) -> Option<&Path> {
        self.mapping_path.as_deref()
    }

    fn find_mesh(&self, house: &SceneEntry, folder: &str, stem: &str) -> Option<PathBuf> {
        let standard = match folder {
            "room" => self.root.join("room").join(&house.id),
            _ => self.root.join("object").join(stem),
        };
        let beside = house.path.parent().unwrap_or(Path::new("."));
        let candidates: Vec<PathBuf> = [standard.as_path(), beside]
            .into_iter()
            .flat_map(|dir| {
                MESH_EXTENSIONS
                    .iter()
                    .map(move |ext| dir.join(format!("{stem}.{ext}")))
            })
            .collect();
        candidates.into_iter().find(|p| p.is_file())
    }
}

impl DatasetLoader for SuncgLoader {
    fn dataset(&self) -> Dataset {
        Dataset::Suncg
    }
    /// Every house under the root: `root/house/<id>/house.json`, or `root/<id>/house.json`,
    /// sorted by id.
    fn discover(&self) -> Result<Vec<SceneEntry>, LoadError> {
        let standard = self.root.join("house");
        let dir = if standard.is_dir() {
            standard
        } else {
            self.root.clone()
        };
        let entries = std::fs::read_dir(&dir).map_err(|source| LoadError::Io(FileError::new(dir.clone(), source)))?;
        let mut houses = Vec::new();
        for e in entries.flatten() {
            let path = e.path().join("house.json");
            if path.is_file() {
                houses.push(SceneEntry {
                    id: e.file_name().to_string_lossy().into_owned(),
                    path,
                });
            }
        }
        houses.sort();
        Ok(houses)
    }
    /// Loads one house. Every failure names `house.json` (or the mesh file) and the node.
    fn load(&self, house: &SceneEntry) -> Result<LoadedScene, LoadError> {
        let path = &house.path;
        let bytes = std::fs::read(path).map_err(|source| LoadError::Io(FileError::new(path.clone(), source)))?;
        let json: HouseJson = serde_json::from_slice(&nan_tokens_to_null(&bytes))
            .map_err(|e| LoadError::parse(path, crate::scene::formats::json_error_text(&e)))?;
        let mut ctx = HouseBuild {
            loader: self,
            house,
            root_transform: root_transform(&json, path)?,
            scene: Scene {
                id: house.id.clone(),
                dataset: Dataset::Suncg,
                levels: Vec::new(),
                meshes: Vec::new(),
            },
            sources: vec![path.clone()],
            warnings: Vec::new(),
            object_meshes: HashMap::new(),
        };
        if let Some(id) = json.id.as_deref().filter(|id| *id != house.id) {
            ctx.warnings.push(format!(
                "{}: id `{id}` differs from folder name",
                path.display()
            ));
        }
        for (index, level) in json.levels.iter().enumerate() {
            let level = ctx.level(index as u32, level)?;
            ctx.scene.levels.push(level);
        }
        ctx.scene
            .validate()
            .map_err(|m| LoadError::parse(path, m))?;
        Ok(LoadedScene {
            scene: ctx.scene,
            sources: ctx.sources,
            warnings: ctx.warnings,
        })
    }
    fn scene_layout(&self) -> &'static str {
        "house/<id>/house.json or <id>/house.json"
    }
    fn root_warning(&self) -> Option<String> {
        self.mapping_path.is_none().then(|| {
            format!(
                "{}: no metadata/ModelCategoryMapping.csv: objects will have no categories (give a category mapping file)",
                self.root.display()
            )
        })
    }
}

fn find_mapping(root: &Path) -> Option<PathBuf> {
    let meta = root.join("metadata");
    let standard = meta.join("ModelCategoryMapping.csv");
    if standard.is_file() {
        return Some(standard);
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir(&meta)
        .ok()?
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().ends_with("ModelCategoryMapping.csv"))
        })
        .collect();
    found.sort();
    found.into_iter().next()
}

/// State while one house is assembled.
struct HouseBuild<'a> {
    loader: &'a SuncgLoader,
    house: &'a SceneEntry,
    root_transform: Mat4,
    scene: Scene,
    sources: Vec<PathBuf>,
    warnings: Vec<String>,
    object_meshes: HashMap<String, MeshId>,
}

impl HouseBuild<'_> {
    fn node_err(&self, node: &str, message: impl Into<String>) -> LoadError {
        LoadError::node(&self.house.path, node, message)
    }

    fn add_mesh(&mut self, mesh: Mesh) -> MeshId {
        self.scene.meshes.push(mesh);
        (self.scene.meshes.len() - 1) as MeshId
    }

    /// Loads a world-space room/ground mesh `<modelId><suffix>`, applying the root transform.
    fn world_mesh(
        &mut self,
        node: &NodeJson,
        model: &str,
        suffix: &str,
    ) -> Result<MeshId, LoadError> {
        let stem = format!("{model}{suffix}");
        let file = self
            .loader
            .find_mesh(self.house, "room", &stem)
            .ok_or_else(|| {
                self.node_err(
                    &node.id,
                    format!("missing mesh `{stem}` (looked for room/{}/{stem}.obj|gltf|glb and beside house.json)", self.house.id),
                )
            })?;
        let mut mesh = load_mesh_file(&file)?;
        self.sources.push(file);
        if self.root_transform != Mat4::IDENTITY {
            let placed = crate::scene::WorldMesh::place(&mesh, &self.root_transform);
            mesh.positions = placed.positions.iter().map(|p| p.to_array()).collect();
            mesh.normals = placed.normals.iter().map(|n| n.to_array()).collect();
            mesh.indices = placed.indices;
        }
        Ok(self.add_mesh(mesh))
    }

    fn object_mesh(&mut self, node: &NodeJson, model: &str) -> Result<MeshId, LoadError> {
        if let Some(&id) = self.object_meshes.get(model) {
            return Ok(id);
        }
        let file = self
            .loader
            .find_mesh(self.house, "object", model)
            .ok_or_else(|| {
                self.node_err(
                    &node.id,
                    format!("missing mesh for model `{model}` (looked for object/{model}/{model}.obj|gltf|glb and beside house.json)"),
                )
            })?;
        let mesh = load_mesh_file(&file)?;
        self.sources.push(file);
        let id = self.add_mesh(mesh);
        self.object_meshes.insert(model.to_string(), id);
        Ok(id)
    }

    fn level(&mut self, index: u32, level: &LevelJson) -> Result<Level, LoadError> {
        let mut rooms = Vec::new();
        let mut membership: HashMap<usize, Vec<u32>> = HashMap::new();
        let mut objects = Vec::new();
        let mut ground = Vec::new();
        let valid = |n: &NodeJson| n.valid.unwrap_or(1) != 0;
        for node in level.nodes.iter().filter(|n| valid(n) && n.kind == "Room") {
            let room_index = rooms.len() as u32;
            for &i in &node.node_indices {
                membership.entry(i).or_default().push(room_index);
            }
            rooms.push(self.room(node)?);
        }
        for (i, node) in level.nodes.iter().enumerate().filter(|(_, n)| valid(n)) {
            match node.kind.as_str() {
                "Room" => {}
                "Object" => {
                    let rooms_of = membership.remove(&i).unwrap_or_default();
                    objects.push(self.object(node, rooms_of)?);
                }
                "Ground" => {
                    let model = self.model_id(node)?;
                    ground.push(self.world_mesh(node, &model, "f")?);
                }
                other => self.warnings.push(format!(
                    "{}: node {}: type `{other}` ignored",
                    self.house.path.display(),
                    node.id
                )),
            }
        }
        let mut bbox = Aabb::EMPTY;
        for r in &rooms {
            bbox = bbox.union(&r.bbox);
        }
        for o in &objects {
            bbox = bbox.union(&o.bbox);
        }
        for &g in &ground {
            bbox = bbox.union(&self.scene.meshes[g as usize].bounds());
        }
        let mut floor_heights: Vec<f32> = rooms.iter().map(|r| r.floor_height).collect();
        floor_heights.sort_by(f32::total_cmp);
        floor_heights.dedup_by(|a, b| (*a - *b).abs() < 0.01);
        Ok(Level {
            index,
            bbox,
            floor_heights,
            rooms,
            objects,
            ground,
        })
    }

    fn model_id(&self, node: &NodeJson) -> Result<String, LoadError> {
        node.model_id
            .clone()
            .filter(|m| !m.is_empty())
            .ok_or_else(|| self.node_err(&node.id, "missing `modelId`"))
    }

    fn room(&mut self, node: &NodeJson) -> Result<Room, LoadError> {
        let model = self.model_id(node)?;
        let mut surfaces = Vec::new();
        for (suffix, kind, hidden) in [
            ("f", SurfaceKind::Floor, node.hide_floor),
            ("c", SurfaceKind::Ceiling, node.hide_ceiling),
            ("w", SurfaceKind::Wall, node.hide_walls),
        ] {
            if hidden.unwrap_or(0) != 0 {
                continue;
            }
            let mesh = self.world_mesh(node, &model, suffix)?;
            surfaces.push(Surface { kind, mesh });
        }
        let mut bbox = Aabb::EMPTY;
        let mut area = 0.0f64;
        let mut floor_height = f32::INFINITY;
        for s in &surfaces {
            let mesh = &self.scene.meshes[s.mesh as usize];
            bbox = bbox.union(&mesh.bounds());
            if s.kind == SurfaceKind::Floor {
                let (a, h) = floor_area_and_height(mesh);
                area += a;
                if let Some(h) = h {
                    floor_height = floor_height.min(h);
                }
            }
        }
        if !floor_height.is_finite() {
            floor_height = if bbox.is_empty() { 0.0 } else { bbox.min.y };
        }
        Ok(Room {
            id: node.id.clone(),
            raw_types: node.room_types.clone(),
            class: self.loader.room_types.class_of_all(&node.room_types),
            floor_polygon: None,
            surfaces,
            area: area as f32,
            floor_height,
            bbox,
        })
    }

    fn object(&mut self, node: &NodeJson, rooms: Vec<u32>) -> Result<Object, LoadError> {
        let model = self.model_id(node)?;
        let transform = self.root_transform * self.node_transform(node)?;
        let mesh = self.object_mesh(node, &model)?;
        let bbox = self.scene.meshes[mesh as usize].world_bounds(&transform);
        let categories = match self.loader.categories.get(&model) {
            Some(c) => c.clone(),
            None => {
                self.warnings.push(format!(
                    "{}: node {}: model `{model}` has no category in {}",
                    self.house.path.display(),
                    node.id,
                    self.loader
                        .mapping_path
                        .as_ref()
                        .map(|p| p.display().to_string())
                        .unwrap_or_else(|| "any ModelCategoryMapping.csv (none found)".into())
                ));
                Categories::default()
            }
        };
        let materials = node
            .materials
            .iter()
            .enumerate()
            .map(|(slot, m)| {
                let diffuse = match &m.diffuse {
                    Some(hex) => Some(parse_hex_color(hex).ok_or_else(|| {
                        self.node_err(
                            &node.id,
                            format!("materials[{slot}].diffuse `{hex}` is not a #rrggbb colour"),
                        )
                    })?),
                    None => None,
                };
                Ok(MaterialOverride {
                    slot: slot as u32,
                    name: m.name.clone().unwrap_or_default(),
                    diffuse,
                    texture: m.texture.clone(),
                })
            })
            .collect::<Result<Vec<_>, LoadError>>()?;
        Ok(Object {
            id: node.id.clone(),
            model_id: model,
            flags: self.loader.flags.flags_of(&categories),
            categories,
            transform,
            bbox,
            mesh: Some(mesh),
            materials,
            rooms,
        })
    }

    fn node_transform(&self, node: &NodeJson) -> Result<Mat4, LoadError> {
        let t = node
            .transform
            .as_ref()
            .ok_or_else(|| self.node_err(&node.id, "object without `transform`"))?;
        if t.len() != 16 {
            return Err(self.node_err(
                &node.id,
                format!("transform has {} values, expected 16", t.len()),
            ));
        }
        let mut m = [0f32; 16];
        for (i, v) in t.iter().enumerate() {
            match v {
                Some(v) if v.is_finite() && v.abs() < 1e12 => m[i] = *v as f32,
                Some(v) => {
                    return Err(self.node_err(
                        &node.id,
                        format!("transform[{i}] is {v}, not a finite number"),
                    ))
                }
                None => {
                    return Err(
                        self.node_err(&node.id, format!("transform[{i}] is NaN, infinite or null"))
                    )
                }
            }
        }
        let m = Mat4::from_cols_array(&m);
        // Column-major: the last row is elements 3, 7, 11 and 15 (glam's point transforms
        // assert it is (0, 0, 0, 1)).
        if !m.row(3).abs_diff_eq(glam::Vec4::W, 1e-6) {
            return Err(self.node_err(
                &node.id,
                format!(
                    "transform's last row is {:?}, expected [0, 0, 0, 1] (not affine)",
                    m.row(3).to_array()
                ),
            ));
        }
        if m.determinant().abs() < 1e-12 {
            return Err(self.node_err(&node.id, "transform is singular (determinant 0)"));
        }
        Ok(m)
    }
}

/// The transform that turns file coordinates into minos's (metres, +Y up).
fn root_transform(json: &HouseJson, path: &Path) -> Result<Mat4, LoadError> {
    let scale = json.scale_to_meters.unwrap_or(1.0);
    if !(scale.is_finite() && scale > 0.0) {
        return Err(LoadError::parse(
            path,
            format!("scaleToMeters is {scale}, expected a positive number"),
        ));
    }
    let up = json.up.unwrap_or([0.0, 1.0, 0.0]);
    let up = Vec3::new(up[0] as f32, up[1] as f32, up[2] as f32);
    let up = up
        .try_normalize()
        .ok_or_else(|| LoadError::parse(path, "`up` is not a direction"))?;
    let rotation = Quat::from_rotation_arc(up, Vec3::Y);
    Ok(Mat4::from_scale(Vec3::splat(scale as f32)) * Mat4::from_quat(rotation))
}

/// Area (XZ projection) and lowest height of a floor mesh's upward-facing triangles.
///
/// Floors are often slabs (top, bottom and sides): only the walkable top counts.
pub fn floor_area_and_height(mesh: &Mesh) -> (f64, Option<f32>) {
    let mut area = 0.0f64;
    let mut height: Option<f32> = None;
    for t in mesh.indices.chunks_exact(3) {
        let p = |i: u32| mesh.positions[i as usize];
        let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
        let (ux, uy, uz) = (
            f64::from(b[0] - a[0]),
            f64::from(b[1] - a[1]),
            f64::from(b[2] - a[2]),
        );
        let (vx, vy, vz) = (
            f64::from(c[0] - a[0]),
            f64::from(c[1] - a[1]),
            f64::from(c[2] - a[2]),
        );
        // y component of (b - a) x (c - a): positive when the triangle faces up.
        let ny = uz * vx - ux * vz;
        let len = ((uy * vz - uz * vy).powi(2) + ny.powi(2) + (ux * vy - uy * vx).powi(2)).sqrt();
        if ny > 0.0 && ny > 0.7 * len {
            area += ny * 0.5;
            let low = a[1].min(b[1]).min(c[1]);
            height = Some(height.map_or(low, |h| h.min(low)));
        }
    }
    (area, height)
}

/// `#rrggbb` to RGBA in `[0, 1]`.
fn parse_hex_color(s: &str) -> Option<[f32; 4]> {
    let h = s.strip_prefix('#')?;
    if h.len() != 6 {
        return None;
    }
    let v = u32::from_str_radix(h, 16).ok()?;
    let c = |shift: u32| ((v >> shift) & 0xff) as f32 / 255.0;
    Some([c(16), c(8), c(0), 1.0])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_colours_parse() {
        assert_eq!(
            parse_hex_color("#ff0080"),
            Some([1.0, 0.0, 128.0 / 255.0, 1.0])
        );
        assert_eq!(parse_hex_color("ff0080"), None);
        assert_eq!(parse_hex_color("#ff00"), None);
    }

    #[test]
    fn z_up_files_are_rotated_to_y_up() {
        let json = HouseJson {
            id: None,
            up: Some([0.0, 0.0, 1.0]),
            scale_to_meters: Some(0.01),
            levels: vec![],
        };
        let m = root_transform(&json, Path::new("h.json")).unwrap();
        let p = m.transform_point3(Vec3::new(0.0, 0.0, 100.0));
        assert!((p - Vec3::new(0.0, 1.0, 0.0)).length() < 1e-5, "{p}");
    }
}
