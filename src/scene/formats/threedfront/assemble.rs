//! Builds one canonical [`Scene`] from a parsed 3D-FRONT file: rooms with their surfaces,
//! architecture objects (doors, windows, openings, fixed furniture) and furniture objects,
//! all on one level.
//!
//! It decides what each child of a room becomes and names the record when a value is wrong;
//! reading the file is `json`'s job, number checks and mesh building are `geometry`'s, and
//! finding files on disk is the loader's (`mod.rs`).

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};

use crate::scene::formats::suncg::floor_area_and_height;
use crate::scene::formats::{load_mesh_file, LoadError, LoadedScene};
use crate::scene::Aabb;
use crate::scene::{Material, Mesh};
use crate::scene::{
    Categories, Dataset, Level, MeshId, Object, Room, Scene, Surface, SurfaceKind,
};
use crate::scene::{FlagTable, RoomClass};

use super::geometry::{append_placed, child_transform, furniture_extent, inline_mesh, unit_box};
use super::json::{ChildJson, FrontJson, FurnitureJson, MaterialJson};
use super::tables::{arch_role, ArchRole, FrontRoomTypes, FutureCategories};

/// What assembling a scene needs besides the file.
pub(super) struct Inputs<'a> {
    /// The scene file (named in every message).
    pub path: &'a Path,
    /// The scene id (file stem).
    pub id: &'a str,
    /// 3D-FUTURE model folder (`<jid>/raw_model.obj`), if any.
    pub models: Option<&'a Path>,
    /// 3D-FUTURE categories by jid.
    pub categories: &'a FutureCategories,
    /// Room types to classes.
    pub room_types: &'a FrontRoomTypes,
    /// Category names that set door/window flags.
    pub flags: &'a FlagTable,
}

/// Remarks of one kind, counted, with the first occurrence spelled out.
#[derive(Default)]
struct Tally {
    count: usize,
    first: String,
}

struct Build<'a> {
    input: &'a Inputs<'a>,
    json: &'a FrontJson,
    scene: Scene,
    sources: Vec<PathBuf>,
    warnings: Vec<String>,
    tallies: BTreeMap<&'static str, Tally>,
    /// Architecture mesh index → its model-space mesh in the scene (architecture objects).
    arch_meshes: HashMap<usize, MeshId>,
    /// 3D-FUTURE jid → its mesh, `None` when the model file is absent.
    model_meshes: HashMap<String, Option<MeshId>>,
    unit_box: Option<MeshId>,
    object_ids: HashSet<String>,
    materials: HashMap<&'a str, &'a MaterialJson>,
    door_refs: HashSet<String>,
}

/// Record name of a room child, e.g. `scene.room[2].children[5] (furniture/102)`.
fn child_record(ri: usize, ci: usize, child: &ChildJson) -> String {
    match child.instanceid.as_deref() {
        Some(id) => format!("scene.room[{ri}].children[{ci}] ({})", show(id)),
        None => format!("scene.room[{ri}].children[{ci}]"),
    }
}

/// A string from the file as shown in a message: control characters escaped (so a message
/// stays on one line) and at most 80 characters.
fn show(s: &str) -> String {
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i == 80 {
            out.push('…');
            break;
        }
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

fn non_empty(s: Option<&str>) -> Option<&str> {
    s.map(str::trim).filter(|s| !s.is_empty())
}

/// Assembles the scene of a parsed file.
pub(super) fn assemble(json: &FrontJson, input: &Inputs<'_>) -> Result<LoadedScene, LoadError> {
    let mut b = Build {
        input,
        json,
        scene: Scene {
            id: input.id.to_string(),
            dataset: Dataset::ThreeDFront,
            levels: Vec::new(),
            meshes: Vec::new(),
        },
        sources: vec![input.path.to_path_buf()],
        warnings: Vec::new(),
        tallies: BTreeMap::new(),
        arch_meshes: HashMap::new(),
        model_meshes: HashMap::new(),
        unit_box: None,
        object_ids: HashSet::new(),
        materials: json
            .material
            .iter()
            .filter_map(|m| Some((non_empty(m.uid.as_deref())?, m)))
            .collect(),
        door_refs: json.door_refs().into_iter().collect(),
    };
    if let Some(uid) = non_empty(json.uid.as_deref()).filter(|u| *u != input.id) {
        b.warnings.push(format!(
            "{}: uid `{}` differs from the file name",
            input.path.display(),
            show(uid)
        ));
    }
    let level = b.level()?;
    b.scene.levels.push(level);
    b.scene
        .validate()
        .map_err(|m| LoadError::parse(input.path, m))?;
    let mut warnings = b.warnings;
    for (what, t) in b.tallies {
        let more = if t.count > 1 {
            format!(" (and {} more)", t.count - 1)
        } else {
            String::new()
        };
        warnings.push(format!(
            "{}: {}: {what}{more}",
            input.path.display(),
            t.first
        ));
    }
    Ok(LoadedScene {
        scene: b.scene,
        sources: b.sources,
        warnings,
    })
}

impl<'a> Build<'a> {
    fn note(&mut self, what: &'static str, first: impl FnOnce() -> String) {
        let t = self.tallies.entry(what).or_default();
        if t.count == 0 {
            t.first = first();
        }
        t.count += 1;
    }

    fn node_err(&self, record: &str, message: impl Into<String>) -> LoadError {
        LoadError::node(self.input.path, record, message)
    }

    fn add_mesh(&mut self, mesh: Mesh) -> MeshId {
        self.scene.meshes.push(mesh);
        (self.scene.meshes.len() - 1) as MeshId
    }

    fn level(&mut self) -> Result<Level, LoadError> {
        let json = self.json;
        // uid → index; the first of duplicates wins (files repeat identical furniture).
        let mut meshes: HashMap<&str, usize> = HashMap::new();
        for (i, m) in json.mesh.iter().enumerate() {
            if let Some(uid) = non_empty(m.uid.as_deref()) {
                meshes.entry(uid).or_insert(i);
            }
        }
        let mut furniture: HashMap<&str, usize> = HashMap::new();
        for (i, f) in json.furniture.iter().enumerate() {
            if let Some(uid) = non_empty(f.uid.as_deref()) {
                furniture.entry(uid).or_insert(i);
            }
        }
        let mut rooms = Vec::with_capacity(json.scene.room.len());
        let mut objects = Vec::new();
        let mut room_ids: HashSet<String> = HashSet::new();
        let mut used_meshes: HashSet<usize> = HashSet::new();
        for (ri, room) in json.scene.room.iter().enumerate() {
            let mut room_id = match non_empty(room.instanceid.as_deref()) {
                Some(id) => id.to_string(),
                None => {
                    self.note("room without `instanceid`, named room-<index>", || {
                        format!("scene.room[{ri}]")
                    });
                    format!("room-{ri}")
                }
            };
            if !room_ids.insert(room_id.clone()) {
                let unique = (2..)
                    .map(|k| format!("{room_id}~{k}"))
                    .find(|c| !room_ids.contains(c))
                    .unwrap_or_default();
                self.note("duplicate room `instanceid`, renamed with ~N", || {
                    format!("scene.room[{ri}] ({})", show(&room_id))
                });
                room_ids.insert(unique.clone());
                room_id = unique;
            }
            let raw_type = non_empty(room.kind.as_deref()).unwrap_or("");
            let class = match self.input.room_types.class_of(raw_type) {
                Some(c) => c,
                None => {
                    self.note(
                        "room type not in data/taxonomy/3dfront_room_types.csv, class other",
                        || {
                            format!(
                                "scene.room[{ri}] ({}) type `{}`",
                                show(&room_id),
                                show(raw_type)
                            )
                        },
                    );
                    RoomClass::Other
                }
            };
            let mut parts: [Mesh; 3] = Default::default();
            let room_index = ri as u32;
            for (ci, child) in room.children.iter().enumerate() {
                let record = child_record(ri, ci, child);
                let transform = child_transform(child).map_err(|m| self.node_err(&record, m))?;
                let Some(reference) = non_empty(child.reference.as_deref()) else {
                    self.note("child without `ref`, skipped", || record.clone());
                    continue;
                };
                if let Some(&mi) = meshes.get(reference) {
                    used_meshes.insert(mi);
                    let kind = non_empty(json.mesh[mi].kind.as_deref()).unwrap_or("");
                    let (role, known) = arch_role(kind);
                    if !known {
                        self.note(
                            "unknown architecture mesh type, placed by name rules",
                            || format!("mesh[{mi}] ({}) type `{}`", show(reference), show(kind)),
                        );
                    }
                    match role {
                        ArchRole::Surface(surface) => {
                            let mesh = self.inline(mi)?;
                            let slot = match surface {
                                SurfaceKind::Floor => 0,
                                SurfaceKind::Ceiling => 1,
                                SurfaceKind::Wall => 2,
                            };
                            append_placed(&mut parts[slot], &mesh, &transform);
                        }
                        ArchRole::Object { category, flags } => {
                            let object = self.arch_object(
                                mi,
                                reference,
                                category,
                                &transform,
                                (ri, ci, child, &room_id),
                            )?;
                            objects.push(Object {
                                flags,
                                rooms: vec![room_index],
                                ..object
                            });
                        }
                    }
                } else if let Some(&fi) = furniture.get(reference) {
                    let f = &json.furniture[fi];
                    if !f.is_valid() {
                        self.note("child of furniture marked `valid: false`, skipped", || {
                            format!("{record} ref `{}`", show(reference))
                        });
                        continue;
                    }
                    let object =
                        self.furniture(fi, f, reference, &transform, (ri, ci, child, &room_id))?;
                    objects.push(Object {
                        rooms: vec![room_index],
                        ..object
                    });
                } else {
                    self.note(
                        "`ref` matches no mesh[] or furniture[] uid, child skipped",
                        || format!("{record} ref `{}`", show(reference)),
                    );
                }
            }
            rooms.push(self.room(room_id, raw_type, class, parts));
        }
        let unused = json
            .mesh
            .iter()
            .enumerate()
            .filter(|(i, _)| !used_meshes.contains(i))
            .map(|(i, m)| format!("mesh[{i}] ({})", show(m.uid.as_deref().unwrap_or("no uid"))))
            .collect::<Vec<_>>();
        for record in unused {
            self.note("architecture mesh no room refers to, not used", || record);
        }
        let mut bbox = Aabb::EMPTY;
        for r in &rooms {
            bbox = bbox.union(&r.bbox);
        }
        for o in &objects {
            bbox = bbox.union(&o.bbox);
        }
        let mut floor_heights: Vec<f32> = rooms
            .iter()
            .filter(|r| r.surfaces.iter().any(|s| s.kind == SurfaceKind::Floor))
            .map(|r| r.floor_height)
            .collect();
        floor_heights.sort_by(f32::total_cmp);
        floor_heights.dedup_by(|a, b| (*a - *b).abs() < 0.01);
        Ok(Level {
            index: 0,
            bbox,
            floor_heights,
            rooms,
            objects,
            ground: Vec::new(),
        })
    }

    /// The object made of architecture mesh `mi` (a door, window, opening, fixed furniture),
    /// its mesh stored once however many children place it. Flags and rooms are the caller's.
    fn arch_object(
        &mut self,
        mi: usize,
        reference: &str,
        category: &str,
        transform: &Mat4,
        (ri, ci, child, room_id): (usize, usize, &ChildJson, &str),
    ) -> Result<Object, LoadError> {
        let mesh = match self.arch_meshes.get(&mi) {
            Some(&m) => m,
            None => {
                let m = self.inline(mi)?;
                let id = self.add_mesh(m);
                self.arch_meshes.insert(mi, id);
                id
            }
        };
        let nyu40 = match category {
            "door" | "arch" => Some("door".to_string()),
            "window" => Some("window".to_string()),
            "stairs" => Some("stairs".to_string()),
            _ => None,
        };
        Ok(Object {
            id: self.object_id(ri, ci, child, room_id),
            model_id: reference.to_string(),
            categories: Categories {
                fine: Some(category.to_string()),
                coarse: Some(category.to_string()),
                nyu40,
                mpcat40: None,
            },
            bbox: self.scene.meshes[mesh as usize].world_bounds(transform),
            transform: *transform,
            mesh: Some(mesh),
            materials: Vec::new(),
            flags: Default::default(),
            rooms: Vec::new(),
        })
    }

    /// The model-space mesh of architecture mesh `mi`.
    fn inline(&self, mi: usize) -> Result<Mesh, LoadError> {
        let m = &self.json.mesh[mi];
        let uid = m.uid.as_deref().unwrap_or("");
        let record = format!("mesh[{mi}] ({})", show(uid));
        let material = self.material(m.material.as_deref());
        inline_mesh(m, uid, material).map_err(|e| self.node_err(&record, e))
    }

    /// The material a mesh names, grey when the file has no such material.
    fn material(&self, uid: Option<&str>) -> Material {
        let Some(uid) = non_empty(uid) else {
            return Material::solid("architecture", [0.8, 0.8, 0.8]);
        };
        let Some(m) = self.materials.get(uid) else {
            return Material::solid(uid, [0.8, 0.8, 0.8]);
        };
        let mut diffuse = [0.8, 0.8, 0.8, 1.0];
        if let Some(c) = m.color.as_ref().and_then(|c| c.as_array()) {
            let v: Vec<f32> = c
                .iter()
                .filter_map(|v| v.as_f64())
                .filter(|v| v.is_finite())
                .map(|v| (v / 255.0).clamp(0.0, 1.0) as f32)
                .collect();
            if v.len() >= 3 {
                diffuse = [v[0], v[1], v[2], v.get(3).copied().unwrap_or(1.0)];
            }
        }
        Material {
            name: uid.to_string(),
            diffuse,
            texture: non_empty(m.texture.as_deref()).map(str::to_string),
        }
    }

    /// A unique object id: the child's `instanceid`, else `<room>/child<index>`.
    fn object_id(&mut self, ri: usize, ci: usize, child: &ChildJson, room_id: &str) -> String {
        let base = match non_empty(child.instanceid.as_deref()) {
            Some(id) => id.to_string(),
            None => {
                self.note(
                    "child without `instanceid`, named <room>/child<index>",
                    || child_record(ri, ci, child),
                );
                format!("{room_id}/child{ci}")
            }
        };
        if self.object_ids.insert(base.clone()) {
            return base;
        }
        let unique = (2..)
            .map(|k| format!("{base}~{k}"))
            .find(|c| !self.object_ids.contains(c))
            .unwrap_or_default();
        self.note("duplicate child `instanceid`, renamed with ~N", || {
            child_record(ri, ci, child)
        });
        self.object_ids.insert(unique.clone());
        unique
    }

    /// The 3D-FUTURE mesh of `jid` under `--models`, loaded once; `None` when absent.
    fn model_mesh(&mut self, jid: &str) -> Result<Option<MeshId>, LoadError> {
        if let Some(&m) = self.model_meshes.get(jid) {
            return Ok(m);
        }
        let Some(models) = self.input.models else {
            return Ok(None);
        };
        // A jid is a plain name; anything that could leave the folder is not looked up.
        if jid.contains(['/', '\\']) || jid == "." || jid == ".." {
            self.model_meshes.insert(jid.to_string(), None);
            return Ok(None);
        }
        let file = models.join(jid).join("raw_model.obj");
        let id = if file.is_file() {
            let mesh = load_mesh_file(&file)?;
            self.sources.push(file);
            Some(self.add_mesh(mesh))
        } else {
            None
        };
        self.model_meshes.insert(jid.to_string(), id);
        Ok(id)
    }

    fn furniture(
        &mut self,
        fi: usize,
        f: &FurnitureJson,
        uid: &str,
        transform: &Mat4,
        (ri, ci, child, room_id): (usize, usize, &ChildJson, &str),
    ) -> Result<Object, LoadError> {
        let record = format!("furniture[{fi}] ({})", show(uid));
        let jid = non_empty(f.jid.as_deref());
        let future = jid.and_then(|j| self.input.categories.get(j));
        let mut categories = Categories {
            fine: non_empty(f.category.as_deref())
                .or(non_empty(f.title.as_deref()))
                .map(str::to_string)
                .or_else(|| future.and_then(|c| c.category.clone())),
            coarse: future.and_then(|c| c.super_category.clone()),
            nyu40: None,
            mpcat40: None,
        };
        let mut flags = self.input.flags.flags_of(&categories);
        if self.door_refs.contains(uid) {
            flags.door = true;
            categories.fine.get_or_insert_with(|| "door".to_string());
        }
        let model = match jid {
            Some(j) => self.model_mesh(j)?,
            None => None,
        };
        let (mesh, transform) = match model {
            Some(m) => (Some(m), *transform),
            None => {
                if self.input.models.is_some() {
                    self.note(
                        "model not in the 3D-FUTURE model folder (<jid>/raw_model.obj), box used",
                        || format!("{record} jid `{}`", show(jid.unwrap_or(""))),
                    );
                }
                match furniture_extent(f).map_err(|m| self.node_err(&record, m))? {
                    Some(extent) => {
                        let unit = match self.unit_box {
                            Some(u) => u,
                            None => {
                                let u = self.add_mesh(unit_box());
                                self.unit_box = Some(u);
                                u
                            }
                        };
                        (Some(unit), *transform * Mat4::from_scale(extent))
                    }
                    None => {
                        self.note(
                            "furniture without model, `size` or `bbox`: object without geometry",
                            || format!("{record} jid `{}`", show(jid.unwrap_or(""))),
                        );
                        (None, *transform)
                    }
                }
            }
        };
        let bbox = match mesh {
            Some(m) => self.scene.meshes[m as usize].world_bounds(&transform),
            None => Aabb::from_points([transform.transform_point3(Vec3::ZERO)]),
        };
        Ok(Object {
            id: self.object_id(ri, ci, child, room_id),
            model_id: jid.unwrap_or(uid).to_string(),
            categories,
            transform,
            bbox,
            mesh,
            materials: Vec::new(),
            flags,
            rooms: Vec::new(),
        })
    }

    fn room(&mut self, id: String, raw_type: &str, class: RoomClass, parts: [Mesh; 3]) -> Room {
        let mut surfaces = Vec::new();
        let mut bbox = Aabb::EMPTY;
        let mut area = 0.0f64;
        let mut floor_height = None;
        let kinds = [SurfaceKind::Floor, SurfaceKind::Ceiling, SurfaceKind::Wall];
        for (mut mesh, kind) in parts.into_iter().zip(kinds) {
            if mesh.positions.is_empty() {
                continue;
            }
            mesh.name = format!("{}/{id}/{}", self.scene.id, kind_name(kind));
            bbox = bbox.union(&mesh.bounds());
            if kind == SurfaceKind::Floor {
                let (a, h) = floor_area_and_height(&mesh);
                area += a;
                floor_height = h;
            }
            let mesh = self.add_mesh(mesh);
            surfaces.push(Surface { kind, mesh });
        }
        let floor_height = floor_height.unwrap_or(if bbox.is_empty() { 0.0 } else { bbox.min.y });
        Room {
            id,
            raw_types: if raw_type.is_empty() {
                Vec::new()
            } else {
                vec![raw_type.to_string()]
            },
            class,
            floor_polygon: None,
            surfaces,
            area: area as f32,
            floor_height,
            bbox,
        }
    }
}

fn kind_name(kind: SurfaceKind) -> &'static str {
    match kind {
        SurfaceKind::Floor => "floor",
        SurfaceKind::Ceiling => "ceiling",
        SurfaceKind::Wall => "wall",
    }
}
