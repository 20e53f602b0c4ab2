//! Matterport3D scans: `<root>/<scan>/house_segmentations/<scan>.house` (the official download
//! layout, also under `<root>/v1/scans/`) or bare `<root>/<scan>.house` files; the scene id is
//! the scan id.
//!
//! The `.house` file ([`house_file`]) gives levels, regions (rooms) with a letter label and a
//! floor polygon, objects as oriented boxes with categories, and portals. Coordinates are
//! z-up and become y-up as Habitat converts them: `(x, y, z) → (x, z, −y)`.
//!
//! Geometry, in order of preference:
//! 1. the house mesh `house_segmentations/<scan>.ply` ([`ply`]), faces labelled by
//!    `segment_id` (→ `E` record → object → region and category) and `category_id`
//!    (→ `category_mapping.tsv` row, or the `C` record with that mapping index → mpcat40);
//! 2. the textured `matterport_mesh/*/*.obj` (tobj), without labels;
//! 3. proxy geometry built from the `.house` file alone ([`proxy`]): floor polygons, walls
//!    along outlines no other region shares, and the objects' boxes as obstacles.
//!
//! A whole-house mesh is split per region into room surfaces, not objects: the bake
//! rasterises room surfaces triangle by triangle and only `Floor` surfaces (and level ground)
//! can be walked on, so faces labelled floor or stairs become the region's `Floor` surface,
//! ceiling faces its `Ceiling`, and everything else (walls, furniture, clutter) its `Wall`
//! surface — an obstacle shell that is never floor. Faces without a usable label (void,
//! unlabeled, misc, or no label at all, as in the OBJ) are floor when they face up within
//! 15 cm of their region's floor height (any upward face in a stairs region), else `Wall`.
//! Objects then carry no mesh (their geometry is already in the house mesh). Faces that no
//! segment places in a region go to the region whose outline contains them, else the nearest.
//!
//! Category tables (`category_mapping.tsv`, `mpcat40.tsv`) are read from the root (or its
//! `metadata/`) when present and never shipped with minos; without them categories come from
//! the `C` records: `fine` is the raw category name, `mpcat40` its mpcat40 name, and `coarse`
//! and `nyu40` (table columns) stay empty. Object ids are the `O` record indices.

pub mod house_file;
pub mod ply;
pub mod proxy;
pub mod tables;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::scene::geometry::Aabb;
use crate::scene::mesh::{Material, Mesh};
use crate::scene::model::{
    Categories, Dataset, Level, MeshId, Object, ObjectFlags, Room, Scene, Surface, SurfaceKind,
};
use crate::scene::taxonomy::{FlagTable, RoomClass};

use super::suncg::floor_area_and_height;
use super::{obj_mesh, DatasetLoader, LoadError, LoadedScene, SceneEntry};

pub use house_file::{HouseError, HouseFile};
pub use proxy::Obb;
pub use tables::{CategoryTables, RegionLabels};

/// mpcat40 classes whose boxes are not obstacles in proxy geometry: structure that proxy
/// floors and walls stand for, doors (they must not block their doorways), stairs (a box is no
/// staircase) and unannotated segments.
pub const NOT_OBSTACLES: [&str; 7] = [
    "void",
    "wall",
    "floor",
    "door",
    "ceiling",
    "stairs",
    "unlabeled",
];
/// Objects whose box covers more than this fraction of their region's floor are region-scale
/// annotations (Matterport's `misc` segments often are), not obstacles.
pub const REGION_SCALE_FRACTION: f32 = 0.5;
/// Most vertices a floor outline may have (real outlines have tens).
pub const MAX_OUTLINE_VERTICES: usize = 4096;
/// Height band (m) around a region's floor within which unlabelled upward faces are floor.
const FLOOR_BAND: f32 = 0.15;
/// Faces steeper than this (cosine of the angle to +Y) are not floor.
const FLOOR_COS: f32 = 0.85;

/// Converts a z-up Matterport3D point or direction to minos's y-up frame: `(x, z, −y)`.
pub fn zup_to_yup(p: [f64; 3]) -> Vec3 {
    Vec3::new(p[0] as f32, p[2] as f32, -p[1] as f32)
}

/// Converts a y-up point back to Matterport3D's z-up frame: `(x, −z, y)`.
pub fn yup_to_zup(p: Vec3) -> [f64; 3] {
    [f64::from(p.x), -f64::from(p.z), f64::from(p.y)]
}

/// Where a house's geometry comes from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum GeometrySource {
    /// The house mesh when present, else the textured OBJ, else proxy geometry.
    #[default]
    Auto,
    /// Always proxy geometry from the `.house` file.
    Proxy,
}

/// How the loader builds geometry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mp3dOptions {
    /// Which geometry to use.
    pub geometry: GeometrySource,
    /// Build walls along unshared region outlines in proxy geometry.
    pub proxy_walls: bool,
}

impl Default for Mp3dOptions {
    fn default() -> Self {
        Mp3dOptions {
            geometry: GeometrySource::Auto,
            proxy_walls: true,
        }
    }
}

/// The geometry files found for one house.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MeshFiles {
    /// `house_segmentations/<id>.ply`.
    Ply(PathBuf),
    /// `matterport_mesh/*/*.obj` (sorted).
    Obj(Vec<PathBuf>),
    /// None: proxy geometry.
    Proxy,
}

/// Loads Matterport3D scans from one dataset root.
pub struct Mp3dLoader {
    root: PathBuf,
    tables: CategoryTables,
    mapping_path: Option<PathBuf>,
    labels: RegionLabels,
    flags: FlagTable,
    options: Mp3dOptions,
}

impl Mp3dLoader {
    /// A loader for `root`, reading `category_mapping.tsv` from `mapping` or, when `None`,
    /// from `root/` or `root/metadata/`; `mpcat40.tsv` is looked for beside it and in the
    /// same places. Missing tables are fine (see the module docs).
    pub fn open(root: &Path, mapping: Option<&Path>) -> Result<Self, LoadError> {
        let places = [root.to_path_buf(), root.join("metadata")];
        let find = |name: &str, first: Option<&Path>| {
            first
                .into_iter()
                .map(Path::to_path_buf)
                .chain(places.iter().map(|d| d.join(name)))
                .find(|p| p.is_file())
        };
        let mapping_path = match mapping {
            Some(p) => Some(p.to_path_buf()),
            None => find("category_mapping.tsv", None),
        };
        let beside = mapping_path
            .as_ref()
            .and_then(|p| p.parent())
            .map(|d| d.join("mpcat40.tsv"));
        let mpcat40_path = find("mpcat40.tsv", beside.as_deref());
        let tables = CategoryTables::read(mapping_path.as_deref(), mpcat40_path.as_deref())?;
        Ok(Mp3dLoader {
            root: root.to_path_buf(),
            tables,
            mapping_path,
            labels: RegionLabels::builtin(),
            flags: FlagTable::builtin(),
            options: Mp3dOptions::default(),
        })
    }

    /// A loader for `root` with the given category tables (nothing is searched or read).
    pub fn with_tables(root: &Path, tables: CategoryTables) -> Self {
        Mp3dLoader {
            root: root.to_path_buf(),
            tables,
            mapping_path: None,
            labels: RegionLabels::builtin(),
            flags: FlagTable::builtin(),
            options: Mp3dOptions::default(),
        }
    }

    /// The same loader with other options.
    pub fn with_options(mut self, options: Mp3dOptions) -> Self {
        self.options = options;
        self
    }

    /// The options in use.
    pub fn options(&self) -> Mp3dOptions {
        self.options
    }

    /// The `category_mapping.tsv` in use, if one was found.
    pub fn mapping_path(&self) -> Option<&Path> {
        self.mapping_path.as_deref()
    }

    /// The category tables in use.
    pub fn tables(&self) -> &CategoryTables {
        &self.tables
    }

    /// Every scan under the root, sorted by id: `<root>/<id>/house_segmentations/<id>.house`
    /// (under `<root>/v1/scans/` when that exists) and bare `<root>/<id>.house` files.
    pub fn discover(&self) -> Result<Vec<SceneEntry>, LoadError> {
        let scans = self.root.join("v1").join("scans");
        let dir = if scans.is_dir() {
            scans
        } else {
            self.root.clone()
        };
        let entries = std::fs::read_dir(&dir).map_err(|source| LoadError::Io {
            path: dir.clone(),
            source,
        })?;
        let mut found: HashMap<String, PathBuf> = HashMap::new();
        let mut bare = Vec::new();
        for e in entries.flatten() {
            let path = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            if path.is_dir() {
                let house = path
                    .join("house_segmentations")
                    .join(format!("{name}.house"));
                if house.is_file() {
                    found.insert(name, house);
                }
            } else if let Some(stem) = name.strip_suffix(".house").filter(|s| !s.is_empty()) {
                bare.push((stem.to_string(), path));
            }
        }
        for (id, path) in bare {
            found.entry(id).or_insert(path);
        }
        let mut out: Vec<SceneEntry> = found
            .into_iter()
            .map(|(id, path)| SceneEntry { id, path })
            .collect();
        out.sort();
        Ok(out)
    }

    /// The geometry files of a house, following [`Mp3dOptions::geometry`].
    pub fn mesh_files(&self, entry: &SceneEntry) -> MeshFiles {
        if self.options.geometry == GeometrySource::Proxy {
            return MeshFiles::Proxy;
        }
        let dir = entry.path.parent().unwrap_or(Path::new("."));
        let ply = dir.join(format!("{}.ply", entry.id));
        if ply.is_file() {
            return MeshFiles::Ply(ply);
        }
        if dir.file_name().is_some_and(|n| n == "house_segmentations") {
            let scan = dir.parent().unwrap_or(Path::new("."));
            let mut objs: Vec<PathBuf> = std::fs::read_dir(scan.join("matterport_mesh"))
                .into_iter()
                .flatten()
                .flatten()
                .filter(|e| e.path().is_dir())
                .flat_map(|e| std::fs::read_dir(e.path()).into_iter().flatten().flatten())
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x.eq_ignore_ascii_case("obj")))
                .collect();
            objs.sort();
            if !objs.is_empty() {
                return MeshFiles::Obj(objs);
            }
        }
        MeshFiles::Proxy
    }

    /// Loads one scan. Every failure names the file and the line or record.
    pub fn load(&self, entry: &SceneEntry) -> Result<LoadedScene, LoadError> {
        let path = &entry.path;
        let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
            path: path.clone(),
            source,
        })?;
        let house = house_file::parse(&bytes).map_err(|e| LoadError::parse(path, e.to_string()))?;
        self.build(entry, &house)
    }

    /// Builds the scene of an already parsed house, reading its geometry files as
    /// [`Mp3dLoader::load`] does.
    pub fn build(&self, entry: &SceneEntry, house: &HouseFile) -> Result<LoadedScene, LoadError> {
        match self.mesh_files(entry) {
            MeshFiles::Ply(p) => {
                let bytes = std::fs::read(&p).map_err(|source| LoadError::Io {
                    path: p.clone(),
                    source,
                })?;
                self.build_with_ply(entry, house, &p, &bytes)
            }
            MeshFiles::Obj(files) => {
                let mut b = Build::new(self, entry, house);
                b.rooms()?;
                b.objects()?;
                let mut mesh = RawMesh::default();
                for f in &files {
                    let m = obj_mesh::load_obj(f)?;
                    m.validate().map_err(|e| LoadError::parse(f, e))?;
                    let base = mesh.positions.len() as u32;
                    mesh.positions
                        .extend(m.positions.iter().map(|q| zup_to_yup(q.map(f64::from))));
                    for t in m.indices.chunks_exact(3) {
                        mesh.triangles.push([base + t[0], base + t[1], base + t[2]]);
                    }
                }
                mesh.segment = vec![-1; mesh.triangles.len()];
                mesh.category = vec![-1; mesh.triangles.len()];
                b.warn(format!(
                    "{}: geometry from matterport_mesh OBJ without labels: floors guessed from face height",
                    entry.path.display()
                ));
                b.sources.extend(files);
                b.mesh_geometry(mesh);
                b.finish()
            }
            MeshFiles::Proxy => {
                let mut b = Build::new(self, entry, house);
                b.rooms()?;
                b.objects()?;
                b.proxy_geometry();
                b.finish()
            }
        }
    }

    /// Builds the scene of a parsed house whose house mesh is `ply_bytes` (a PLY file;
    /// `ply_path` names it in errors and in the scene's sources). Reads nothing from disk.
    pub fn build_with_ply(
        &self,
        entry: &SceneEntry,
        house: &HouseFile,
        ply_path: &Path,
        ply_bytes: &[u8],
    ) -> Result<LoadedScene, LoadError> {
        let mut b = Build::new(self, entry, house);
        b.rooms()?;
        b.objects()?;
        let raw = ply::read_ply(ply_bytes).map_err(|e| LoadError::parse(ply_path, e.0))?;
        if raw.degenerate_faces > 0 {
            b.warn(format!(
                "{}: {} faces with fewer than 3 corners skipped",
                ply_path.display(),
                raw.degenerate_faces
            ));
        }
        let mesh = RawMesh {
            positions: raw
                .positions
                .iter()
                .map(|q| zup_to_yup(q.map(f64::from)))
                .collect(),
            triangles: raw.triangles,
            segment: raw.segment,
            category: raw.category,
        };
        b.sources.push(ply_path.to_path_buf());
        b.mesh_geometry(mesh);
        b.finish()
    }
}

impl DatasetLoader for Mp3dLoader {
    fn dataset(&self) -> Dataset {
        Dataset::Mp3d
    }
    fn discover(&self) -> Result<Vec<SceneEntry>, LoadError> {
        Mp3dLoader::discover(self)
    }
    fn load(&self, entry: &SceneEntry) -> Result<LoadedScene, LoadError> {
        Mp3dLoader::load(self, entry)
    }
    fn root_warning(&self) -> Option<String> {
        self.mapping_path.is_none().then(|| {
            format!(
                "{}: no category_mapping.tsv: object categories come from the .house C records (no coarse or NYU-40 names; pass --categories FILE)",
                self.root.display()
            )
        })
    }
}

/// A whole-house mesh in y-up coordinates with per-triangle labels (`-1`: none).
#[derive(Debug, Default)]
struct RawMesh {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    segment: Vec<i32>,
    category: Vec<i32>,
}

/// A region's floor outline in y-up terms.
#[derive(Debug, Clone)]
struct Outline {
    region: usize,
    /// `(x, z)`, counter-clockwise in `(x, z)` (positive [`proxy::signed_area`]).
    polygon: Vec<[f32; 2]>,
    floor_y: f32,
    bbox: Aabb,
}

/// A group of house-mesh faces that becomes one surface: (region, kind).
type GroupKey = (Option<usize>, FaceKind);

/// What a face of the house mesh is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum FaceKind {
    Floor,
    Ceiling,
    Other,
}

/// What proxy geometry needs to know of an object.
#[derive(Debug, Clone)]
struct ObjectInfo {
    obb: Obb,
    /// Level, and position in that level's objects.
    level: usize,
    slot: usize,
    mpcat40: Option<String>,
    /// A door or an arch: walls leave an opening where it stands.
    opening: bool,
}

/// State while one house is assembled.
struct Build<'a> {
    loader: &'a Mp3dLoader,
    entry: &'a SceneEntry,
    house: &'a HouseFile,
    scene: Scene,
    sources: Vec<PathBuf>,
    warnings: Vec<String>,
    /// Per region: (level, index of the room in that level).
    room_of: Vec<(usize, usize)>,
    /// Floor outlines (one per `F` surface).
    outlines: Vec<Outline>,
    /// Per `O` record, in file order.
    boxes: Vec<ObjectInfo>,
}

impl<'a> Build<'a> {
    fn new(loader: &'a Mp3dLoader, entry: &'a SceneEntry, house: &'a HouseFile) -> Self {
        let nlevels = house.levels.len().max(1);
        let levels = (0..nlevels)
            .map(|i| Level {
                index: i as u32,
                bbox: Aabb::EMPTY,
                floor_heights: Vec::new(),
                rooms: Vec::new(),
                objects: Vec::new(),
                ground: Vec::new(),
            })
            .collect();
        let mut sources = vec![entry.path.clone()];
        sources.extend(loader.tables.sources.iter().cloned());
        Build {
            loader,
            entry,
            house,
            scene: Scene {
                id: entry.id.clone(),
                dataset: Dataset::Mp3d,
                levels,
                meshes: Vec::new(),
            },
            sources,
            warnings: Vec::new(),
            room_of: Vec::new(),
            outlines: Vec::new(),
            boxes: Vec::new(),
        }
    }

    fn warn(&mut self, w: String) {
        self.warnings.push(w);
    }

    fn add_mesh(&mut self, mesh: Mesh) -> MeshId {
        self.scene.meshes.push(mesh);
        (self.scene.meshes.len() - 1) as MeshId
    }

    fn room_mut(&mut self, region: usize) -> &mut Room {
        let (l, r) = self.room_of[region];
        &mut self.scene.levels[l].rooms[r]
    }

    /// One room per `R` record, with its floor outline and class.
    fn rooms(&mut self) -> Result<(), LoadError> {
        let house = self.house;
        let outlines = house.surface_outlines();
        for (si, verts) in outlines.iter().enumerate() {
            if verts.len() > MAX_OUTLINE_VERTICES {
                return Err(LoadError::parse(
                    &self.entry.path,
                    format!(
                        "line {}: S record {si} has {} vertices, more than the {MAX_OUTLINE_VERTICES} a floor outline may have",
                        house.surfaces[si].line,
                        verts.len()
                    ),
                ));
            }
        }
        for (ri, region) in house.regions.iter().enumerate() {
            let level = region.level.unwrap_or(0).min(self.scene.levels.len() - 1);
            let mut floors: Vec<Outline> = house
                .surfaces
                .iter()
                .enumerate()
                .filter(|(_, s)| s.region == Some(ri) && s.label.eq_ignore_ascii_case("F"))
                .filter_map(|(si, _)| {
                    let verts = &outlines[si];
                    let mut polygon: Vec<[f32; 2]> = verts
                        .iter()
                        .map(|v| {
                            let p = zup_to_yup(v.position);
                            [p.x, p.z]
                        })
                        .collect();
                    polygon = proxy::clean_polygon(&polygon);
                    if polygon.len() < 3 || proxy::signed_area(&polygon).abs() < 1e-4 {
                        return None;
                    }
                    if proxy::signed_area(&polygon) < 0.0 {
                        polygon.reverse();
                    }
                    let floor_y = verts
                        .iter()
                        .map(|v| v.position[2] as f32)
                        .fold(f32::INFINITY, f32::min);
                    let bbox =
                        Aabb::from_points(polygon.iter().map(|q| Vec3::new(q[0], floor_y, q[1])));
                    Some(Outline {
                        region: ri,
                        polygon,
                        floor_y,
                        bbox,
                    })
                })
                .collect();
            floors.sort_by(|a, b| {
                proxy::signed_area(&b.polygon).total_cmp(&proxy::signed_area(&a.polygon))
            });
            let region_box =
                Aabb::from_corners(zup_to_yup(region.bbox.lo), zup_to_yup(region.bbox.hi));
            let label = self.loader.labels.get(&region.label);
            if label.is_none() {
                self.warn(format!(
                    "{}: line {}: unknown region label `{}` (class other)",
                    self.entry.path.display(),
                    region.line,
                    region.label
                ));
            }
            if floors.is_empty() {
                self.warn(format!(
                    "{}: line {}: region {ri} has no floor outline (no S record labelled F with 3 or more vertices)",
                    self.entry.path.display(),
                    region.line
                ));
            }
            let main = floors.first();
            let room = Room {
                id: format!("region{ri}"),
                raw_types: vec![region.label.clone()],
                class: label.map_or(RoomClass::Other, |l| l.class),
                // Counter-clockwise seen from above (+Y) is clockwise in (x, z).
                floor_polygon: main.map(|o| o.polygon.iter().rev().copied().collect()),
                surfaces: Vec::new(),
                area: floors.iter().map(|o| proxy::signed_area(&o.polygon)).sum(),
                floor_height: main.map_or(region_box.min.y, |o| o.floor_y),
                bbox: Aabb::EMPTY,
            };
            if self.house.regions[ri].level.is_none() {
                self.warn(format!(
                    "{}: line {}: region {ri} has no level (put on level 0)",
                    self.entry.path.display(),
                    region.line
                ));
            }
            let rooms = &mut self.scene.levels[level].rooms;
            self.room_of.push((level, rooms.len()));
            rooms.push(room);
            self.outlines.extend(floors);
        }
        Ok(())
    }

    /// Categories of a category index, from the tables when present, else the `C` record.
    fn categories(&self, category: Option<usize>) -> Categories {
        let Some(c) = category.and_then(|c| self.house.categories.get(c)) else {
            return Categories::default();
        };
        let tables = &self.loader.tables;
        let row = c.mapping_index.and_then(|i| tables.row(i));
        let mpcat40_index = c.mpcat40_index.or(row.and_then(|r| r.mpcat40_index));
        let mpcat40 = row
            .and_then(|r| r.mpcat40.clone())
            .or_else(|| c.mpcat40_name.clone())
            .or_else(|| mpcat40_index.and_then(|i| tables.mpcat40_name(i).map(str::to_string)));
        Categories {
            fine: row
                .map(|r| r.raw.clone())
                .or_else(|| c.mapping_name.clone()),
            coarse: row.and_then(|r| r.category.clone()),
            nyu40: row.and_then(|r| r.nyu40.clone()),
            mpcat40,
        }
    }

    /// One object per `O` record (no mesh yet).
    fn objects(&mut self) -> Result<(), LoadError> {
        let house = self.house;
        for (oi, o) in house.objects.iter().enumerate() {
            let obb = Obb::new(
                zup_to_yup(o.center),
                zup_to_yup(o.axis0),
                zup_to_yup(o.axis1),
                Vec3::new(o.radii[0] as f32, o.radii[1] as f32, o.radii[2] as f32),
            )
            .map_err(|m| {
                LoadError::parse(&self.entry.path, format!("line {}: O record: {m}", o.line))
            })?;
            let categories = self.categories(o.category);
            let mut flags = self.loader.flags.flags_of(&categories);
            let implied = mpcat40_flags(categories.mpcat40.as_deref());
            flags.door |= implied.door;
            flags.window |= implied.window;
            flags.stairs |= implied.stairs;
            let (level, rooms) = match o.region {
                Some(r) => {
                    let (l, k) = self.room_of[r];
                    (l, vec![k as u32])
                }
                None => (self.level_at(obb.center.y), Vec::new()),
            };
            self.boxes.push(ObjectInfo {
                obb,
                level,
                slot: self.scene.levels[level].objects.len(),
                mpcat40: categories.mpcat40.clone(),
                opening: flags.door || flags.arch,
            });
            self.scene.levels[level].objects.push(Object {
                id: oi.to_string(),
                model_id: String::new(),
                categories,
                transform: obb.transform(),
                bbox: obb.aabb(),
                mesh: None,
                materials: Vec::new(),
                flags,
                rooms,
            });
        }
        Ok(())
    }

    /// The level whose `L` box holds height `y` (the lowest such), else level 0.
    fn level_at(&self, y: f32) -> usize {
        self.house
            .levels
            .iter()
            .position(|l| {
                let (lo, hi) = (l.bbox.lo[2] as f32, l.bbox.hi[2] as f32);
                y >= lo - 0.1 && y <= hi + 0.1
            })
            .unwrap_or(0)
    }

    /// Proxy floors, walls and obstacle boxes from the `.house` file alone.
    fn proxy_geometry(&mut self) {
        let house = self.house;
        let regions: Vec<proxy::ProxyRegion> = self
            .outlines
            .iter()
            .map(|o| {
                let h = house.regions[o.region].height as f32;
                proxy::ProxyRegion {
                    polygon: o.polygon.clone(),
                    floor_y: o.floor_y,
                    wall_height: if h.is_finite() && h >= 1.5 {
                        h
                    } else {
                        proxy::DEFAULT_WALL_HEIGHT
                    },
                    level: self.room_of[o.region].0,
                }
            })
            .collect();
        let mut openings: Vec<Obb> = self
            .boxes
            .iter()
            .filter(|b| b.opening)
            .map(|b| b.obb)
            .collect();
        openings.extend(house.portals.iter().map(|p| {
            Obb::from_aabb(&Aabb::from_corners(
                zup_to_yup(p.bbox.lo),
                zup_to_yup(p.bbox.hi),
            ))
        }));
        let surfaces = proxy::build_surfaces(&regions, &openings, self.loader.options.proxy_walls);
        let outlines = self.outlines.clone();
        for (o, s) in outlines.iter().zip(surfaces) {
            for (kind, mesh) in [(SurfaceKind::Floor, s.floor), (SurfaceKind::Wall, s.walls)] {
                if let Some(m) = mesh {
                    let id = self.add_mesh(m);
                    self.room_mut(o.region)
                        .surfaces
                        .push(Surface { kind, mesh: id });
                }
            }
        }
        // Obstacles: one shared unit box.
        let mut unit: Option<MeshId> = None;
        let areas: Vec<f32> = self
            .room_of
            .iter()
            .map(|&(l, r)| self.scene.levels[l].rooms[r].area)
            .collect();
        for (o, info) in house.objects.iter().zip(self.boxes.clone()) {
            let structural = info
                .mpcat40
                .as_deref()
                .is_some_and(|m| NOT_OBSTACLES.contains(&m));
            let footprint = {
                let s = info.obb.aabb().size();
                s.x * s.z
            };
            let region_scale = o
                .region
                .is_some_and(|r| areas[r] > 0.0 && footprint > REGION_SCALE_FRACTION * areas[r]);
            if structural || region_scale {
                continue;
            }
            let id = match unit {
                Some(id) => id,
                None => {
                    let id = self.add_mesh(proxy::unit_box());
                    unit = Some(id);
                    id
                }
            };
            if let Some(object) = self.scene.levels[info.level].objects.get_mut(info.slot) {
                object.mesh = Some(id);
            }
        }
    }

    /// The region a point belongs to: among regions whose outline holds it and whose
    /// floor-to-ceiling span covers its height, the one with the highest floor at or below it
    /// (else the lowest floor above it); without such a region, the nearest outline at a
    /// fitting height, else the nearest outline.
    fn region_at(&self, p: Vec3) -> Option<usize> {
        let house = self.house;
        let fits = |o: &Outline| {
            let h = (house.regions[o.region].height as f32).max(proxy::DEFAULT_WALL_HEIGHT);
            p.y >= o.floor_y - 0.3 && p.y <= o.floor_y + h + 0.3
        };
        let q = [p.x, p.z];
        let holding = self.outlines.iter().filter(|o| {
            fits(o)
                && p.x >= o.bbox.min.x
                && p.x <= o.bbox.max.x
                && p.z >= o.bbox.min.z
                && p.z <= o.bbox.max.z
                && proxy::contains(&o.polygon, q)
        });
        let (below, above): (Vec<&Outline>, Vec<&Outline>) =
            holding.partition(|o| o.floor_y <= p.y + 0.1);
        let best = below
            .into_iter()
            .max_by(|a, b| a.floor_y.total_cmp(&b.floor_y))
            .or_else(|| {
                above
                    .into_iter()
                    .min_by(|a, b| a.floor_y.total_cmp(&b.floor_y))
            });
        if let Some(o) = best {
            return Some(o.region);
        }
        let nearest = |pred: &dyn Fn(&Outline) -> bool| {
            self.outlines
                .iter()
                .filter(|o| pred(o))
                .map(|o| (o.region, proxy::distance_to(&o.polygon, q)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(r, _)| r)
        };
        nearest(&fits).or_else(|| nearest(&|_| true))
    }

    /// Splits a whole-house mesh into per-region floor, ceiling and other surfaces.
    fn mesh_geometry(&mut self, mesh: RawMesh) {
        let house = self.house;
        let tables = &self.loader.tables;
        let segment_object: HashMap<i64, Option<usize>> =
            house.segments.iter().map(|e| (e.id, e.object)).collect();
        let by_mapping: HashMap<usize, usize> = house
            .categories
            .iter()
            .enumerate()
            .filter_map(|(i, c)| c.mapping_index.map(|m| (m, i)))
            .collect();
        let mut names: HashMap<usize, String> = HashMap::new();
        for c in &house.categories {
            if let (Some(i), Some(n)) = (c.mpcat40_index, &c.mpcat40_name) {
                names.entry(i).or_insert_with(|| n.clone());
            }
        }
        let floor_y: HashMap<usize, f32> = self
            .outlines
            .iter()
            .rev()
            .map(|o| (o.region, o.floor_y))
            .collect();
        // mpcat40 class of a face: its segment's object's category, else its category_id
        // through the house's C records, else through category_mapping.tsv.
        let mpcat40_of = |t: usize, object: Option<usize>| -> Option<usize> {
            if let Some(c) = object.and_then(|o| house.objects[o].category) {
                return house.categories[c].mpcat40_index;
            }
            let id = usize::try_from(*mesh.category.get(t)?)
                .ok()
                .filter(|&i| i > 0)?;
            match by_mapping.get(&id) {
                Some(&c) => house.categories[c].mpcat40_index,
                None => tables.row(id)?.mpcat40_index,
            }
        };
        // Per group (region or none, kind): triangles with their mpcat40 class.
        let mut groups: HashMap<GroupKey, Vec<(u32, Option<usize>)>> = HashMap::new();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let corners = tri.map(|i| mesh.positions[i as usize]);
            let object = mesh
                .segment
                .get(t)
                .and_then(|&s| segment_object.get(&i64::from(s)).copied().flatten());
            let mpcat40 = mpcat40_of(t, object);
            let region = object
                .and_then(|o| house.objects[o].region)
                .or_else(|| self.region_at((corners[0] + corners[1] + corners[2]) / 3.0));
            let kind = self.face_kind(mpcat40, region, &floor_y, corners);
            groups
                .entry((region, kind))
                .or_default()
                .push((t as u32, mpcat40));
        }
        let mut keys: Vec<GroupKey> = groups.keys().copied().collect();
        keys.sort_by_key(|(r, k)| (r.map_or(usize::MAX, |r| r), *k as u8));
        let mut remap = vec![u32::MAX; mesh.positions.len()];
        for key in keys {
            let Some(tris) = groups.remove(&key) else {
                continue;
            };
            let (region, kind) = key;
            let mut m = Mesh {
                name: format!(
                    "{} {} {:?}",
                    self.entry.id,
                    region.map_or("unassigned".to_string(), |r| format!("region{r}")),
                    kind
                ),
                ..Default::default()
            };
            let mut slots: HashMap<Option<usize>, u16> = HashMap::new();
            for &(t, cat) in &tris {
                let slot = *slots.entry(cat).or_insert_with(|| {
                    let name = cat
                        .and_then(|i| {
                            names
                                .get(&i)
                                .cloned()
                                .or_else(|| tables.mpcat40_name(i).map(str::to_string))
                        })
                        .unwrap_or_else(|| "unlabeled".to_string());
                    let rgb = cat
                        .and_then(|i| tables.mpcat40_color(i))
                        .unwrap_or([0.7, 0.7, 0.7]);
                    m.materials.push(Material::solid(name, rgb));
                    (m.materials.len() - 1) as u16
                });
                for v in mesh.triangles[t as usize] {
                    if remap[v as usize] == u32::MAX {
                        remap[v as usize] = m.positions.len() as u32;
                        m.positions.push(mesh.positions[v as usize].to_array());
                    }
                    m.indices.push(remap[v as usize]);
                }
                m.face_materials.push(slot);
            }
            // Reset only the entries this group used.
            for &(t, _) in &tris {
                for v in mesh.triangles[t as usize] {
                    remap[v as usize] = u32::MAX;
                }
            }
            m.compute_normals();
            let id = self.add_mesh(m);
            let surface_kind = match kind {
                FaceKind::Floor => SurfaceKind::Floor,
                FaceKind::Ceiling => SurfaceKind::Ceiling,
                FaceKind::Other => SurfaceKind::Wall,
            };
            match region {
                Some(r) => self.room_mut(r).surfaces.push(Surface {
                    kind: surface_kind,
                    mesh: id,
                }),
                // Only when the house has no floor outline at all: the level's ground keeps
                // the faces (up-facing ones count as floor there).
                None => self.scene.levels[0].ground.push(id),
            }
        }
    }

    /// Floor, ceiling or other, from the mpcat40 class when it says, else from geometry.
    fn face_kind(
        &self,
        mpcat40: Option<usize>,
        region: Option<usize>,
        floor_y: &HashMap<usize, f32>,
        tri: [Vec3; 3],
    ) -> FaceKind {
        match mpcat40 {
            Some(2) | Some(16) => return FaceKind::Floor,
            Some(17) => return FaceKind::Ceiling,
            Some(0) | Some(40) | Some(41) | None => {}
            Some(_) => return FaceKind::Other,
        }
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let len = n.length();
        if len <= 0.0 || n.y < FLOOR_COS * len {
            return FaceKind::Other;
        }
        let Some(r) = region else {
            return FaceKind::Other;
        };
        if self.house.regions[r].label == "s" {
            return FaceKind::Floor;
        }
        let y = (tri[0].y + tri[1].y + tri[2].y) / 3.0;
        match floor_y.get(&r) {
            Some(&f) if (y - f).abs() <= FLOOR_BAND => FaceKind::Floor,
            _ => FaceKind::Other,
        }
    }

    /// Boxes, areas and floor heights; then validation.
    fn finish(mut self) -> Result<LoadedScene, LoadError> {
        let meshes = &self.scene.meshes;
        let house = self.house;
        for (ri, &(l, r)) in self.room_of.iter().enumerate() {
            let room = &mut self.scene.levels[l].rooms[r];
            let mut bbox = Aabb::EMPTY;
            let mut mesh_area = 0.0f64;
            for s in &room.surfaces {
                let m = &meshes[s.mesh as usize];
                bbox = bbox.union(&m.bounds());
                if s.kind == SurfaceKind::Floor {
                    mesh_area += floor_area_and_height(m).0;
                }
            }
            if bbox.is_empty() {
                let region = &house.regions[ri];
                bbox = Aabb::from_corners(zup_to_yup(region.bbox.lo), zup_to_yup(region.bbox.hi));
            }
            room.bbox = bbox;
            if room.floor_polygon.is_none() {
                room.area = mesh_area as f32;
            }
        }
        for level in &mut self.scene.levels {
            let mut bbox = Aabb::EMPTY;
            for r in &level.rooms {
                bbox = bbox.union(&r.bbox);
            }
            for o in &level.objects {
                bbox = bbox.union(&o.bbox);
            }
            for &g in &level.ground {
                bbox = bbox.union(&meshes[g as usize].bounds());
            }
            level.bbox = bbox;
            let mut heights: Vec<f32> = level.rooms.iter().map(|r| r.floor_height).collect();
            heights.sort_by(f32::total_cmp);
            heights.dedup_by(|a, b| (*a - *b).abs() < 0.01);
            level.floor_heights = heights;
        }
        self.scene
            .validate()
            .map_err(|m| LoadError::parse(&self.entry.path, m))?;
        Ok(LoadedScene {
            scene: self.scene,
            sources: self.sources,
            warnings: self.warnings,
        })
    }
}

/// Flags an mpcat40 name implies (door, window, stairs).
fn mpcat40_flags(name: Option<&str>) -> ObjectFlags {
    ObjectFlags {
        door: name == Some("door"),
        window: name == Some("window"),
        arch: false,
        stairs: name == Some("stairs"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two levels, one region each (level 1 is 3 m up); the O records alternate levels: a
    /// door on level 1 first, then a table on level 0, then a wall on level 0.
    fn two_level_house() -> String {
        [
            "ASCII 1.1",
            "H  -  -  0 1 8 2 0 3 3 2 0  2  0 0 0 0 0  0 0 0  4 4 6  0 0 0 0 0",
            "L  0  1  -  2 2 0  0 0 0  4 4 3  0 0 0 0 0",
            "L  1  1  -  2 2 3  0 0 3  4 4 6  0 0 0 0 0",
            "R  0 0  0 0  k  2 2 0  0 0 0  4 4 2.5  2.5  0 0 0 0",
            "R  1 1  0 0  S  2 2 3  0 0 3  4 4 5.5  2.5  0 0 0 0",
            "S  0 0  0  F  2 2 0  0 0 1  0 0 0  4 4 0  0 0 0 0 0",
            "S  1 1  0  F  2 2 3  0 0 1  0 0 3  4 4 3  0 0 0 0 0",
            "V  0 0  F  0 0 0  0 0 1  0 0 0",
            "V  1 0  F  4 0 0  0 0 1  0 0 0",
            "V  2 0  F  4 4 0  0 0 1  0 0 0",
            "V  3 0  F  0 4 0  0 0 1  0 0 0",
            "V  4 1  F  0 0 3  0 0 1  0 0 0",
            "V  5 1  F  0 4 3  0 0 1  0 0 0",
            "V  6 1  F  4 4 3  0 0 1  0 0 0",
            "V  7 1  F  4 0 3  0 0 1  0 0 0",
            "P  pano  0 0  0  1 1 1.5  0 0 0 0 0",
            "C  0  2 door  4 door  0 0 0 0 0",
            "C  1  15 dining#table  5 table  0 0 0 0 0",
            "C  2  1 wall  1 wall  0 0 0 0 0",
            "O  0 1 0  0 2 4  0 1 0  0 0 1  0.5 1 0.1  0 0 0 0 0 0 0 0",
            "O  1 0 1  2 3 0.4  1 0 0  0 1 0  0.5 0.3 0.4  0 0 0 0 0 0 0 0",
            "O  2 0 2  2 0 1.2  1 0 0  0 0 1  2 1.2 0.05  0 0 0 0 0 0 0 0",
        ]
        .join("\n")
    }

    fn load(text: &str, options: Mp3dOptions) -> LoadedScene {
        let house = house_file::parse_str(text).unwrap();
        let loader = Mp3dLoader::with_tables(Path::new("root"), CategoryTables::default())
            .with_options(options);
        let entry = SceneEntry {
            id: "two".into(),
            path: PathBuf::from("two.house"),
        };
        loader.build(&entry, &house).unwrap()
    }

    #[test]
    fn z_up_converts_to_y_up() {
        assert_eq!(zup_to_yup([1.0, 2.0, 3.0]), Vec3::new(1.0, 3.0, -2.0));
        assert_eq!(yup_to_zup(Vec3::new(1.0, 3.0, -2.0)), [1.0, 2.0, 3.0]);
    }

    #[test]
    fn proxy_scene_of_a_two_level_house() {
        let loaded = load(
            &two_level_house(),
            Mp3dOptions {
                geometry: GeometrySource::Proxy,
                proxy_walls: true,
            },
        );
        assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
        let scene = &loaded.scene;
        assert_eq!(scene.levels.len(), 2);
        let (l0, l1) = (&scene.levels[0], &scene.levels[1]);
        assert_eq!((l0.rooms.len(), l1.rooms.len()), (1, 1));
        assert_eq!(l0.rooms[0].class, RoomClass::Kitchen);
        assert_eq!(l1.rooms[0].class, RoomClass::Bathroom, "S is spa");
        assert_eq!(l1.rooms[0].id, "region1");
        assert!((l1.rooms[0].floor_height - 3.0).abs() < 1e-6);
        assert!((l0.rooms[0].area - 16.0).abs() < 1e-4);
        // The outline, z-up (0..4, 0..4) → x 0..4, z -4..0, counter-clockwise from above
        // whatever the file's order (region 1's vertices run the other way).
        for room in [&l0.rooms[0], &l1.rooms[0]] {
            let poly = room.floor_polygon.as_ref().unwrap();
            assert_eq!(poly.len(), 4);
            assert!(poly
                .iter()
                .all(|p| (0.0..=4.0).contains(&p[0]) && (-4.0..=0.0).contains(&p[1])));
            assert!(proxy::signed_area(poly) < 0.0);
        }
        // Objects land on their region's level, ids are the O indices.
        let ids = |l: &Level| l.objects.iter().map(|o| o.id.clone()).collect::<Vec<_>>();
        assert_eq!(ids(l0), vec!["1", "2"]);
        assert_eq!(ids(l1), vec!["0"]);
        let door = &l1.objects[0];
        assert!(
            door.flags.door && door.mesh.is_none(),
            "doors are not obstacles"
        );
        assert_eq!(door.categories.fine.as_deref(), Some("door"));
        let table = &l0.objects[0];
        assert!(table.mesh.is_some(), "the table is an obstacle");
        assert_eq!(table.categories.fine.as_deref(), Some("dining table"));
        assert_eq!(table.categories.mpcat40.as_deref(), Some("table"));
        assert_eq!(table.categories.nyu40, None);
        assert_eq!(table.rooms, vec![0]);
        // Its box: centre (2, 3, 0.4) z-up → (2, 0.4, -3); radii 0.5 (x), 0.3 (y_zup → z),
        // 0.4 (up).
        let b = table.bbox;
        assert!((b.center() - Vec3::new(2.0, 0.4, -3.0)).length() < 1e-5);
        assert!(
            (b.size() - Vec3::new(1.0, 0.8, 0.6)).length() < 1e-5,
            "{}",
            b.size()
        );
        assert!(l0.objects[1].mesh.is_none(), "walls are not obstacles");
        // Level 1's walls leave an opening where the door stands (x = 0, z_zup 1..3): four
        // sides, one split in two.
        let walls = l1.rooms[0]
            .surfaces
            .iter()
            .find(|s| s.kind == SurfaceKind::Wall)
            .unwrap();
        assert_eq!(scene.meshes[walls.mesh as usize].triangle_count(), 5 * 12);
        let l0_walls = l0.rooms[0]
            .surfaces
            .iter()
            .find(|s| s.kind == SurfaceKind::Wall)
            .unwrap();
        assert_eq!(
            scene.meshes[l0_walls.mesh as usize].triangle_count(),
            4 * 12
        );
        assert_eq!(l0.floor_heights, vec![0.0]);
        assert!(scene.validate().is_ok());
    }

    #[test]
    fn proxy_without_walls_has_floors_only() {
        let loaded = load(
            &two_level_house(),
            Mp3dOptions {
                geometry: GeometrySource::Proxy,
                proxy_walls: false,
            },
        );
        assert!(loaded
            .scene
            .rooms()
            .all(|r| r.surfaces.len() == 1 && r.surfaces[0].kind == SurfaceKind::Floor));
    }

    #[test]
    fn house_mesh_faces_go_to_regions_and_kinds() {
        let house = house_file::parse_str(&two_level_house()).unwrap();
        let loader = Mp3dLoader::with_tables(Path::new("root"), CategoryTables::default());
        let entry = SceneEntry {
            id: "two".into(),
            path: PathBuf::from("two.house"),
        };
        // z-up triangles: a floor at 0 (labelled floor), a table top at 0.8 without label, a
        // floor-height face without label upstairs, and a ceiling face at 2.5.
        let positions = [
            [0.5, 0.5, 0.0],
            [3.5, 0.5, 0.0],
            [3.5, 3.5, 0.0],
            [1.0, 1.0, 0.8],
            [2.0, 1.0, 0.8],
            [2.0, 2.0, 0.8],
            [1.0, 1.0, 3.05],
            [2.0, 1.0, 3.05],
            [2.0, 2.0, 3.05],
            [1.0, 1.0, 2.5],
            [2.0, 2.0, 2.5],
            [2.0, 1.0, 2.5],
        ];
        let tris = [[0, 1, 2], [3, 4, 5], [6, 7, 8], [9, 10, 11]];
        // category_id is the C record's mapping index: 4 is not one (→ geometry), 2 is door.
        let labels = [[0, -1, 4], [0, -1, -1], [0, -1, 0], [0, 7, -1]];
        let bytes = ply::write_ply(&positions, &tris, &labels);
        let loaded = loader
            .build_with_ply(&entry, &house, Path::new("two.ply"), &bytes)
            .unwrap();
        let scene = &loaded.scene;
        let kinds = |l: usize| {
            let mut k: Vec<(SurfaceKind, usize)> = scene.levels[l].rooms[0]
                .surfaces
                .iter()
                .map(|s| (s.kind, scene.meshes[s.mesh as usize].triangle_count()))
                .collect();
            k.sort_by_key(|(kind, _)| *kind as u8);
            k
        };
        // Level 0: the floor (up-facing at floor height), the table top (too high) as wall,
        // the ceiling face (down-facing, no label) as wall too.
        assert_eq!(
            kinds(0),
            vec![(SurfaceKind::Floor, 1), (SurfaceKind::Wall, 2)]
        );
        // Level 1: the face 5 cm above its floor is floor.
        assert_eq!(kinds(1), vec![(SurfaceKind::Floor, 1)]);
        assert!(scene.objects().all(|o| o.mesh.is_none()));
        assert!(loaded.sources.iter().any(|p| p == Path::new("two.ply")));
    }
}
