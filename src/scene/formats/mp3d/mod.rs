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

mod build;
pub mod house_file;
pub mod ply;
pub mod proxy;
pub mod tables;

use crate::file_error::FileError;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::scene::Aabb;
use crate::scene::{Material, Mesh};
use crate::scene::{
    Categories, Dataset, Level, MeshId, Object, ObjectFlags, Room, Scene, Surface, SurfaceKind,
};
use crate::scene::{FlagTable, RoomClass};

use super::suncg::floor_area_and_height;
use super::{obj_mesh, DatasetLoader, LoadError, LoadedScene, SceneEntry};

use build::{Build, RawMesh};
pub use house_file::HouseFile;
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
#[cfg(test)]
pub(crate) fn yup_to_zup(p: Vec3) -> [f64; 3] {
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
    #[cfg(any(test, feature = "internals"))]
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
    #[cfg(feature = "internals")]
    pub fn with_options(mut self, options: Mp3dOptions) -> Self {
        self.options = options;
        self
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

    /// Builds the scene of an already parsed house, reading its geometry files as
    /// [`Mp3dLoader::load`] does.
    pub fn build(&self, entry: &SceneEntry, house: &HouseFile) -> Result<LoadedScene, LoadError> {
        match self.mesh_files(entry) {
            MeshFiles::Ply(p) => {
                let bytes = std::fs::read(&p).map_err(|source| LoadError::Io(FileError::new(p.clone(), source)))?;
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
    /// Every scan under the root, sorted by id: `<root>/<id>/house_segmentations/<id>.house`
    /// (under `<root>/v1/scans/` when that exists) and bare `<root>/<id>.house` files.
    fn discover(&self) -> Result<Vec<SceneEntry>, LoadError> {
        let scans = self.root.join("v1").join("scans");
        let dir = if scans.is_dir() {
            scans
        } else {
            self.root.clone()
        };
        let entries = std::fs::read_dir(&dir).map_err(|source| LoadError::Io(FileError::new(dir.clone(), source)))?;
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
    /// Loads one scan. Every failure names the file and the line or record.
    fn load(&self, entry: &SceneEntry) -> Result<LoadedScene, LoadError> {
        let path = &entry.path;
        let bytes = std::fs::read(path).map_err(|source| LoadError::Io(FileError::new(path.clone(), source)))?;
        let house = house_file::parse(&bytes).map_err(|source| LoadError::House {
            path: path.to_path_buf(),
            source,
        })?;
        self.build(entry, &house)
    }
    fn scene_layout(&self) -> &'static str {
        "<scan>/house_segmentations/<scan>.house or <scan>.house (in v1/scans/ when present)"
    }
    fn root_warning(&self) -> Option<String> {
        self.mapping_path.is_none().then(|| {
            format!(
                "{}: no category_mapping.tsv: object categories come from the .house C records (no coarse or NYU-40 names; give a category mapping file)",
                self.root.display()
            )
        })
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
