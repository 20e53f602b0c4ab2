//! Builds the canonical [`Scene`] from resolved glTF assets: the stage becomes
//! [`Level::ground`] plus rooms, nodes that name an object category and Habitat object
//! instances become [`Object`]s, and semantic ids tied to geometry through vertex colours
//! become objects and region rooms.
//!
//! Where its job ends: every path it is handed has already been resolved by the loader; it
//! opens mesh and table files, never looks for them.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3};

use crate::scene::formats::gltf_mesh::{node_matrix, GltfFile, MeshBuilder, MAX_NODE_VISITS};
use crate::scene::formats::suncg::floor_area_and_height;
use crate::scene::formats::{load_mesh_file, LoadError, LoadedScene};
use crate::scene::Aabb;
use crate::scene::{Mesh, WorldMesh};
use crate::scene::{
    Categories, Dataset, Level, MeshId, Object, Room, Scene, Surface, SurfaceKind,
};
use crate::scene::{FlagTable, RoomClass, RoomTypeTable};

use super::habitat::{Placement, Region};
use super::semantic::{category_from_name, structural_kind, CategoryMap, SemanticTable};

/// The id of the room made when a scene has no room information.
pub const STAGE_ROOM_ID: &str = "stage";

/// A stage asset with everything needed to place it.
#[derive(Debug, Clone)]
pub(super) struct StageSpec {
    /// The render asset.
    pub asset: PathBuf,
    /// Asset frame to world.
    pub rotation: Quat,
    /// Scale applied after the rotation.
    pub scale: Vec3,
    /// The `.semantic.txt`, if one was found.
    pub semantic_txt: Option<PathBuf>,
    /// The semantic mesh, if one was found.
    pub semantic_glb: Option<PathBuf>,
}

/// Scene under construction.
pub(super) struct Assembler<'a> {
    id: String,
    main: PathBuf,
    categories: &'a CategoryMap,
    flags: FlagTable,
    meshes: Vec<Mesh>,
    /// Every file read.
    pub sources: Vec<PathBuf>,
    /// Non-fatal remarks.
    pub warnings: Vec<String>,
    object_meshes: HashMap<PathBuf, MeshId>,
    ground: Vec<MeshId>,
    objects: Vec<Object>,
    rooms: Vec<Room>,
    stage_bbox: Aabb,
}

impl<'a> Assembler<'a> {
    /// A scene `id` whose main file is `main`.
    pub fn new(id: &str, main: &Path, categories: &'a CategoryMap) -> Self {
        Assembler {
            id: id.to_string(),
            main: main.to_path_buf(),
            categories,
            flags: FlagTable::builtin(),
            meshes: Vec::new(),
            sources: Vec::new(),
            warnings: Vec::new(),
            object_meshes: HashMap::new(),
            ground: Vec::new(),
            objects: Vec::new(),
            rooms: Vec::new(),
            stage_bbox: Aabb::EMPTY,
        }
    }

    fn source(&mut self, path: &Path) {
        if !self.sources.iter().any(|p| p == path) {
            self.sources.push(path.to_path_buf());
        }
    }

    fn add_mesh(&mut self, mesh: Mesh) -> MeshId {
        self.meshes.push(mesh);
        (self.meshes.len() - 1) as MeshId
    }

    /// Bakes `place` into `mesh` (a world-space surface) and stores it.
    fn add_world_mesh(&mut self, mut mesh: Mesh, place: &Mat4) -> MeshId {
        if *place != Mat4::IDENTITY {
            let placed = WorldMesh::place(&mesh, place);
            mesh.positions = placed.positions.iter().map(|p| p.to_array()).collect();
            mesh.normals = placed.normals.iter().map(|n| n.to_array()).collect();
            mesh.indices = placed.indices;
        }
        self.add_mesh(mesh)
    }

    /// The categories a node declares: `extras.category` (or `extras.class`) on the node or
    /// its mesh, else its name read by [`category_from_name`]. Structural categories (floor,
    /// wall, ceiling) give none, so that geometry stays part of the stage surface.
    fn node_categories(&self, node: &gltf::Node) -> Option<Categories> {
        let declared = extras_category(node.extras())
            .or_else(|| node.mesh().and_then(|m| extras_category(m.extras())));
        let cats = match declared {
            Some(raw) => self.categories.categories(&raw),
            None => {
                let name = node.name()?;
                let category = category_from_name(name, self.categories)?;
                self.categories.categories(&category)
            }
        };
        structural_kind(&cats).is_none().then_some(cats)
    }

    /// Loads the stage: object nodes become objects, every other triangle goes (placed) into
    /// one ground mesh; then the semantic table, if any.
    pub fn add_stage(&mut self, spec: &StageSpec) -> Result<(), LoadError> {
        let file = GltfFile::open(&spec.asset)?;
        self.source(&spec.asset);
        for b in file.external_buffers() {
            self.source(&b);
        }
        let place = Mat4::from_scale(spec.scale) * Mat4::from_quat(spec.rotation);
        let mut name_count: HashMap<&str, usize> = HashMap::new();
        for n in file.document.nodes() {
            if let Some(name) = n.name() {
                *name_count.entry(name).or_default() += 1;
            }
        }
        let mut stage = MeshBuilder::new(spec.asset.display().to_string());
        let mut found: Vec<(gltf::Node, Mat4, Categories)> = Vec::new();
        let mut stack: Vec<(gltf::Node, Mat4)> = file
            .root_nodes()
            .into_iter()
            .map(|n| (n, Mat4::IDENTITY))
            .collect();
        let mut visited = 0usize;
        while let Some((node, parent)) = stack.pop() {
            visited += 1;
            if visited > MAX_NODE_VISITS {
                return Err(LoadError::parse(
                    &spec.asset,
                    "node hierarchy too deep or cyclic",
                ));
            }
            let world = parent * node_matrix(&node);
            if let Some(cats) = self.node_categories(&node) {
                if subtree_has_mesh(&node) {
                    found.push((node, world, cats));
                    continue;
                }
            }
            stage.add_node_mesh(&file, &node, &world)?;
            for child in node.children() {
                stack.push((child, world));
            }
        }
        let stage = stage.finish();
        if stage.triangle_count() > 0 {
            let id = self.add_world_mesh(stage, &place);
            self.stage_bbox = self.stage_bbox.union(&self.meshes[id as usize].bounds());
            self.ground.push(id);
        }
        let stem = file_stem(&spec.asset);
        found.sort_by_key(|(n, _, _)| n.index());
        for (node, world, categories) in found {
            let label = match node.name() {
                Some(name) if name_count.get(name) == Some(&1) => name.to_string(),
                _ => format!("node_{}", node.index()),
            };
            let mut builder = MeshBuilder::new(format!("{}#{label}", spec.asset.display()));
            let mut stack = vec![(node.clone(), Mat4::IDENTITY)];
            while let Some((n, m)) = stack.pop() {
                visited += 1;
                if visited > MAX_NODE_VISITS {
                    return Err(LoadError::parse(
                        &spec.asset,
                        "node hierarchy too deep or cyclic",
                    ));
                }
                builder.add_node_mesh(&file, &n, &m)?;
                for child in n.children() {
                    let cm = m * node_matrix(&child);
                    stack.push((child, cm));
                }
            }
            let mesh = builder.finish();
            let transform = place * world;
            let bbox = mesh.world_bounds(&transform);
            let mesh = self.add_mesh(mesh);
            self.stage_bbox = self.stage_bbox.union(&bbox);
            self.objects.push(Object {
                id: label.clone(),
                model_id: format!("{stem}#{label}"),
                flags: self.flags.flags_of(&categories),
                categories,
                transform,
                bbox,
                mesh: Some(mesh),
                materials: Vec::new(),
                rooms: Vec::new(),
            });
        }
        if let Some(txt) = &spec.semantic_txt {
            self.semantics(txt, spec.semantic_glb.as_deref(), &place)?;
        }
        Ok(())
    }

    /// Reads the semantic table and ties it to the semantic mesh when that has vertex
    /// colours; otherwise says why it could not.
    fn semantics(&mut self, txt: &Path, glb: Option<&Path>, place: &Mat4) -> Result<(), LoadError> {
        let table = SemanticTable::read(txt)?;
        self.source(txt);
        let why_not = match glb {
            Some(glb) => self.tie(&table, glb, place)?,
            None => {
                Some("no semantic mesh (`<name>.semantic.glb` or `semantic_asset`) found".into())
            }
        };
        if let Some(why) = why_not {
            self.warnings.push(format!(
                "{}: {} semantic ids in {} regions not tied to geometry: {why}; one room covers the stage",
                txt.display(),
                table.entries.len(),
                table.regions().len()
            ));
        }
        Ok(())
    }

    /// Splits the semantic mesh by vertex colour: ids with structural categories become the
    /// floor / wall / ceiling surfaces of their region's room, other ids become objects.
    /// Returns why nothing could be tied, if so.
    fn tie(
        &mut self,
        table: &SemanticTable,
        glb: &Path,
        place: &Mat4,
    ) -> Result<Option<String>, LoadError> {
        let file = GltfFile::open(glb)?;
        self.source(glb);
        let mut builder = MeshBuilder::new(glb.display().to_string()).with_triangle_colors();
        let mut stack: Vec<(gltf::Node, Mat4)> = file
            .root_nodes()
            .into_iter()
            .map(|n| (n, Mat4::IDENTITY))
            .collect();
        let mut visited = 0usize;
        while let Some((node, parent)) = stack.pop() {
            visited += 1;
            if visited > MAX_NODE_VISITS {
                return Err(LoadError::parse(glb, "node hierarchy too deep or cyclic"));
            }
            let world = parent * node_matrix(&node);
            builder.add_node_mesh(&file, &node, &world)?;
            for child in node.children() {
                stack.push((child, world));
            }
        }
        let (mesh, colors) = builder.finish_with_colors();
        if colors.iter().all(Option::is_none) {
            return Ok(Some(format!(
                "{} has no vertex colours (semantic textures are not decoded)",
                glb.display()
            )));
        }
        let placed = WorldMesh::place(&mesh, place);
        let by_color = table.by_color();
        let mut tris: Vec<Vec<usize>> = vec![Vec::new(); table.entries.len()];
        for (t, c) in colors.iter().enumerate() {
            if let Some(&e) = c.as_ref().and_then(|c| by_color.get(c)) {
                tris[e].push(t);
            }
        }
        let tied = tris.iter().filter(|t| !t.is_empty()).count();
        if tied == 0 {
            return Ok(Some(format!(
                "no vertex colour of {} matches a colour of the table",
                glb.display()
            )));
        }
        #[derive(Default)]
        struct RegionAcc {
            floor: Vec<usize>,
            wall: Vec<usize>,
            ceiling: Vec<usize>,
            bbox: Aabb,
        }
        let mut regions: BTreeMap<i64, RegionAcc> = BTreeMap::new();
        let mut pending: Vec<(usize, i64)> = Vec::new();
        let glb_name = glb
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        for (e, list) in tris.iter().enumerate().filter(|(_, t)| !t.is_empty()) {
            let entry = &table.entries[e];
            let bbox = triangles_bbox(&placed, list);
            let categories = self.categories.categories(&entry.category);
            let kind = structural_kind(&categories);
            if entry.region >= 0 {
                let acc = regions.entry(entry.region).or_default();
                acc.bbox = acc.bbox.union(&bbox);
                match kind {
                    Some(SurfaceKind::Floor) => acc.floor.extend(list),
                    Some(SurfaceKind::Wall) => acc.wall.extend(list),
                    Some(SurfaceKind::Ceiling) => acc.ceiling.extend(list),
                    None => {}
                }
            }
            if kind.is_none() {
                let sub = submesh(&mesh, &placed, list, format!("{glb_name}#{}", entry.id));
                let mesh_id = self.add_mesh(sub);
                pending.push((self.objects.len(), entry.region));
                self.objects.push(Object {
                    id: format!("sem_{}", entry.id),
                    model_id: format!("{glb_name}#{}", entry.id),
                    flags: self.flags.flags_of(&categories),
                    categories,
                    transform: Mat4::IDENTITY,
                    bbox,
                    mesh: Some(mesh_id),
                    materials: Vec::new(),
                    rooms: Vec::new(),
                });
            }
        }
        let mut room_of: HashMap<i64, u32> = HashMap::new();
        for (r, acc) in regions {
            let mut surfaces = Vec::new();
            let mut area = 0.0f64;
            let mut floor_height = None;
            for (kind, list) in [
                (SurfaceKind::Floor, &acc.floor),
                (SurfaceKind::Wall, &acc.wall),
                (SurfaceKind::Ceiling, &acc.ceiling),
            ] {
                if list.is_empty() {
                    continue;
                }
                let sub = submesh(&mesh, &placed, list, format!("{glb_name}#region_{r}"));
                if kind == SurfaceKind::Floor {
                    let (a, h) = floor_area_and_height(&sub);
                    area = a;
                    floor_height = h;
                }
                let mesh = self.add_mesh(sub);
                surfaces.push(Surface { kind, mesh });
            }
            room_of.insert(r, self.rooms.len() as u32);
            self.rooms.push(Room {
                id: format!("region_{r}"),
                raw_types: Vec::new(),
                class: RoomClass::Other,
                floor_polygon: None,
                surfaces,
                area: area as f32,
                floor_height: floor_height.unwrap_or(acc.bbox.min.y),
                bbox: acc.bbox,
            });
        }
        for (o, r) in pending {
            if let Some(&room) = room_of.get(&r) {
                self.objects[o].rooms = vec![room];
            }
        }
        self.warnings.push(format!(
            "{}: {tied} of {} semantic ids tied to geometry through the vertex colours of {}; {} regions became rooms",
            self.main.display(),
            table.entries.len(),
            glb.display(),
            room_of.len()
        ));
        Ok(None)
    }

    /// Places one object instance (the mesh is loaded once per asset).
    pub fn add_instance(
        &mut self,
        id: String,
        model_id: String,
        asset: &Path,
        categories: Categories,
        placement: &Placement,
    ) -> Result<(), LoadError> {
        let mesh_id = match self.object_meshes.get(asset) {
            Some(&m) => m,
            None => {
                let mesh = load_mesh_file(asset)?;
                self.source(asset);
                let m = self.add_mesh(mesh);
                self.object_meshes.insert(asset.to_path_buf(), m);
                m
            }
        };
        let mesh = &self.meshes[mesh_id as usize];
        let center = if mesh.positions.is_empty() {
            Vec3::ZERO
        } else {
            mesh.world_bounds(&placement.local()).center()
        };
        let transform = placement.transform(center);
        let bbox = mesh.world_bounds(&transform);
        self.objects.push(Object {
            id,
            model_id,
            flags: self.flags.flags_of(&categories),
            categories,
            transform,
            bbox,
            mesh: Some(mesh_id),
            materials: Vec::new(),
            rooms: Vec::new(),
        });
        Ok(())
    }

    /// Region annotations become rooms (floor polygon, box, class from the label; no
    /// surfaces, so the bake keeps using the stage geometry for floors).
    pub fn add_regions(&mut self, regions: &[Region]) {
        let types = RoomTypeTable::suncg();
        for r in regions {
            let class = RoomClass::from_label(&r.label).unwrap_or_else(|| types.class_of(&r.label));
            self.rooms.push(Room {
                id: r.name.clone(),
                raw_types: if r.label.is_empty() {
                    Vec::new()
                } else {
                    vec![r.label.clone()]
                },
                class,
                floor_polygon: Some(r.polygon.clone()),
                surfaces: Vec::new(),
                area: polygon_area(&r.polygon),
                floor_height: r.floor_height,
                bbox: Aabb::from_corners(r.min, r.max),
            });
        }
    }

    /// Finishes the scene: one room covering everything when there is no room information,
    /// object-to-room membership, the level box and floor heights.
    pub fn finish(mut self) -> Result<LoadedScene, LoadError> {
        let has_geometry = !self.ground.is_empty()
            || self.objects.iter().any(|o| {
                o.mesh
                    .is_some_and(|m| self.meshes[m as usize].triangle_count() > 0)
            });
        if !has_geometry {
            return Err(LoadError::parse(
                &self.main,
                "no triangles in the stage or its objects",
            ));
        }
        if self.rooms.is_empty() {
            let room = self.stage_room();
            self.rooms.push(room);
        }
        for o in &mut self.objects {
            if o.rooms.is_empty() {
                o.rooms = room_containing(&self.rooms, &o.bbox).into_iter().collect();
            }
        }
        let mut bbox = Aabb::EMPTY;
        for r in &self.rooms {
            bbox = bbox.union(&r.bbox);
        }
        for o in &self.objects {
            bbox = bbox.union(&o.bbox);
        }
        for &g in &self.ground {
            bbox = bbox.union(&self.meshes[g as usize].bounds());
        }
        let mut floor_heights: Vec<f32> = self.rooms.iter().map(|r| r.floor_height).collect();
        floor_heights.sort_by(f32::total_cmp);
        floor_heights.dedup_by(|a, b| (*a - *b).abs() < 0.01);
        let scene = Scene {
            id: self.id,
            dataset: Dataset::Gltf,
            levels: vec![Level {
                index: 0,
                bbox,
                floor_heights,
                rooms: self.rooms,
                objects: self.objects,
                ground: self.ground,
            }],
            meshes: self.meshes,
        };
        scene
            .validate()
            .map_err(|m| LoadError::parse(&self.main, m))?;
        Ok(LoadedScene {
            scene,
            sources: self.sources,
            warnings: self.warnings,
        })
    }

    /// The room of a scene without room information: class other, the stage's box as its
    /// floor polygon, no surfaces (the stage is ground), the upward-facing stage area as its
    /// area and the lowest upward-facing stage triangle as its floor height.
    fn stage_room(&self) -> Room {
        let mut bbox = self.stage_bbox;
        for o in &self.objects {
            bbox = bbox.union(&o.bbox);
        }
        let mut area = 0.0f64;
        let mut low: Option<f32> = None;
        for &g in &self.ground {
            let (a, h) = floor_area_and_height(&self.meshes[g as usize]);
            area += a;
            if let Some(h) = h {
                low = Some(low.map_or(h, |l| l.min(h)));
            }
        }
        let (min, max) = (bbox.min, bbox.max);
        Room {
            id: STAGE_ROOM_ID.into(),
            raw_types: Vec::new(),
            class: RoomClass::Other,
            floor_polygon: Some(vec![
                [min.x, min.z],
                [max.x, min.z],
                [max.x, max.z],
                [min.x, max.z],
            ]),
            surfaces: Vec::new(),
            area: area as f32,
            floor_height: low.unwrap_or(min.y),
            bbox,
        }
    }
}

/// The `category` (or `class`) string of a glTF `extras` object.
fn extras_category(extras: &gltf::json::Extras) -> Option<String> {
    let raw = extras.as_ref()?;
    let value: serde_json::Value = serde_json::from_str(raw.get()).ok()?;
    ["category", "class"]
        .iter()
        .find_map(|k| value.get(*k)?.as_str())
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(str::to_string)
}

fn subtree_has_mesh(node: &gltf::Node) -> bool {
    let mut stack = vec![node.clone()];
    let mut visited = 0usize;
    while let Some(n) = stack.pop() {
        visited += 1;
        if n.mesh().is_some() {
            return true;
        }
        if visited > MAX_NODE_VISITS {
            return false;
        }
        stack.extend(n.children());
    }
    false
}

fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn triangles_bbox(mesh: &WorldMesh, tris: &[usize]) -> Aabb {
    Aabb::from_points(
        tris.iter()
            .flat_map(|&t| mesh.indices[3 * t..3 * t + 3].iter())
            .map(|&i| mesh.positions[i as usize]),
    )
}

/// The triangles `tris` of `mesh`, with world positions and normals from `placed`.
fn submesh(mesh: &Mesh, placed: &WorldMesh, tris: &[usize], name: String) -> Mesh {
    let mut remap: HashMap<u32, u32> = HashMap::new();
    let mut out = Mesh {
        name,
        materials: mesh.materials.clone(),
        ..Default::default()
    };
    let with_uvs = !mesh.uvs.is_empty();
    for &t in tris {
        for &i in &placed.indices[3 * t..3 * t + 3] {
            let next = out.positions.len() as u32;
            let v = *remap.entry(i).or_insert_with(|| {
                out.positions.push(placed.positions[i as usize].to_array());
                out.normals.push(placed.normals[i as usize].to_array());
                if with_uvs {
                    out.uvs.push(mesh.uvs[i as usize]);
                }
                next
            });
            out.indices.push(v);
        }
        out.face_materials
            .push(mesh.face_materials.get(t).copied().unwrap_or(0));
    }
    out
}

/// Area of a polygon in the XZ plane.
fn polygon_area(poly: &[[f32; 2]]) -> f32 {
    let n = poly.len();
    let twice: f32 = (0..n)
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum();
    (twice * 0.5).abs()
}

fn point_in_polygon(poly: &[[f32; 2]], x: f32, z: f32) -> bool {
    let mut inside = false;
    let n = poly.len();
    let mut j = n.wrapping_sub(1);
    for i in 0..n {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > z) != (b[1] > z) && x < (b[0] - a[0]) * (z - a[1]) / (b[1] - a[1]) + a[0] {
            inside = !inside;
        }
        j = i;
    }
    inside
}

/// The room an object stands in: among rooms whose floor region holds the centre of the
/// object's box (polygon when known, else box) at or below it, the highest floor, then the
/// smallest area.
fn room_containing(rooms: &[Room], bbox: &Aabb) -> Option<u32> {
    if bbox.is_empty() {
        return None;
    }
    let c = bbox.center();
    rooms
        .iter()
        .enumerate()
        .filter(|(_, r)| {
            let inside = match &r.floor_polygon {
                Some(p) if p.len() >= 3 => point_in_polygon(p, c.x, c.z),
                _ => {
                    c.x >= r.bbox.min.x
                        && c.x <= r.bbox.max.x
                        && c.z >= r.bbox.min.z
                        && c.z <= r.bbox.max.z
                }
            };
            inside && r.floor_height <= c.y
        })
        .max_by(|(_, a), (_, b)| {
            a.floor_height
                .total_cmp(&b.floor_height)
                .then(b.area.total_cmp(&a.area))
        })
        .map(|(i, _)| i as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygons_measure_and_contain() {
        let square = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        assert_eq!(polygon_area(&square), 4.0);
        assert!(point_in_polygon(&square, 1.0, 1.0));
        assert!(!point_in_polygon(&square, 3.0, 1.0));
    }
}
