//! Building the canonical scene of a Matterport3D scan from its parsed `.house` records and
//! its geometry (the house mesh split per region into room surfaces, or proxy geometry): the
//! rooms, the objects and their categories, the levels, and the faces sorted into floor,
//! ceiling and wall surfaces (see the module overview in `mod.rs`).

use super::*;

/// A whole-house mesh in y-up coordinates with per-triangle labels (`-1`: none).
#[derive(Debug, Default)]
pub(super) struct RawMesh {
    pub(super) positions: Vec<Vec3>,
    pub(super) triangles: Vec<[u32; 3]>,
    pub(super) segment: Vec<i32>,
    pub(super) category: Vec<i32>,
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
pub(super) struct Build<'a> {
    loader: &'a Mp3dLoader,
    entry: &'a SceneEntry,
    house: &'a HouseFile,
    scene: Scene,
    pub(super) sources: Vec<PathBuf>,
    warnings: Vec<String>,
    /// Per region: (level, index of the room in that level).
    room_of: Vec<(usize, usize)>,
    /// Floor outlines (one per `F` surface).
    outlines: Vec<Outline>,
    /// Per `O` record, in file order.
    boxes: Vec<ObjectInfo>,
}

impl<'a> Build<'a> {
    pub(super) fn new(loader: &'a Mp3dLoader, entry: &'a SceneEntry, house: &'a HouseFile) -> Self {
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

    pub(super) fn warn(&mut self, w: String) {
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
    pub(super) fn rooms(&mut self) -> Result<(), LoadError> {
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
    pub(super) fn objects(&mut self) -> Result<(), LoadError> {
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
    pub(super) fn proxy_geometry(&mut self) {
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
    pub(super) fn mesh_geometry(&mut self, mesh: RawMesh) {
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
    pub(super) fn finish(mut self) -> Result<LoadedScene, LoadError> {
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
