//! Writes plans in Matterport3D's layout: `<id>/house_segmentations/<id>.house` and the house
//! mesh `<id>/house_segmentations/<id>.ply`, so the whole Matterport3D path is exercised
//! without licensed data.
//!
//! A plan's rooms become regions (letter labels from their types, rectangle floor outlines,
//! heights), its doors and arches between two rooms also portals, its placed objects `O`
//! records (oriented boxes from the models' boxes and orientations) with mpcat40-like
//! categories (`C` records; no `category_mapping.tsv` is written, so loaders fall back to the
//! `C` records). One panorama stands at the free spot nearest to each room's centre, 1.5 m up.
//! The PLY holds floors, ceilings, walls with their openings, and every model part, each face
//! labelled with a `category_id` (the `C` record's mapping index) and a `segment_id` (`E`
//! records: one segment per object, and per room one each for floor, ceiling and walls with
//! no object). Everything is written z-up (`(x, y, z)_y-up → (x, −z, y)`), the `.house` file
//! last so that a house whose `.house` exists is complete. Random choices are the plan's: the
//! writer adds none.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};

use crate::atomic::write_bytes_atomic;
use crate::scene::formats::mp3d::ply::write_ply;
use crate::scene::RoomClass;

use super::catalog::catalog;
use super::mp3d_mesh::*;
use crate::seed::{derive_seed, Rng};

use super::plan::{HousePlan, PlacedObject, Rect, RoomPlan, Side, WALL_T};

/// Camera height of written panoramas above their room's floor (m).
pub const PANORAMA_HEIGHT: f64 = 1.5;
/// Clearance (m) kept between a panorama and furniture footprints or walls.
const PANORAMA_CLEARANCE: f64 = 0.35;

/// The `.house` file of house `id` under `root`.
pub fn house_path(root: &Path, id: &str) -> PathBuf {
    root.join(id)
        .join("house_segmentations")
        .join(format!("{id}.house"))
}

/// The Matterport3D region letter of a generated room: by its SUNCG type where Matterport3D
/// has the same room, else by its MINOS class.
pub fn region_letter(raw_type: &str, class: RoomClass) -> &'static str {
    match raw_type {
        "Toilet" => "t",
        "Storage" => "c",
        "Balcony" => "y",
        _ => match class {
            RoomClass::Other => "z",
            RoomClass::Bedroom => "b",
            RoomClass::LivingRoom => "l",
            RoomClass::Bathroom => "a",
            RoomClass::Kitchen => "k",
            RoomClass::DiningRoom => "d",
            RoomClass::Office => "o",
            RoomClass::Hallway => "h",
            RoomClass::Outdoor => "p",
        },
    }
}

/// The mpcat40 class `(index, name)` of a generated model's fine category.
pub fn mpcat40_of(fine: &str) -> (usize, &'static str) {
    match fine {
        "double_bed" | "single_bed" => (11, "bed"),
        "stand" | "dresser" => (13, "chest_of_drawers"),
        "wardrobe_cabinet" | "tv_stand" | "shoes_cabinet" => (7, "cabinet"),
        "desk" | "coffee_table" | "dining_table" => (5, "table"),
        "office_chair" | "chair" | "armchair" => (3, "chair"),
        "sofa" => (10, "sofa"),
        "television" => (22, "tv_monitor"),
        "bookshelf" => (31, "shelving"),
        "kitchen_cabinet" => (26, "counter"),
        "refrigerator" | "range_oven" => (37, "appliances"),
        "sink" => (15, "sink"),
        "toilet" => (18, "toilet"),
        "bathtub" => (25, "bathtub"),
        "shower" => (23, "shower"),
        "plant" => (14, "plant"),
        "floor_lamp" | "table_lamp" => (28, "lighting"),
        "outdoor_seating" => (34, "seating"),
        "door" | "arch" => (4, "door"),
        "window" => (9, "window"),
        "stairs" => (16, "stairs"),
        "wall" => (1, "wall"),
        "floor" => (2, "floor"),
        "ceiling" => (17, "ceiling"),
        _ => (39, "objects"),
    }
}

/// The raw category name written for a fine category (`double_bed` → `double bed`).
pub fn raw_name(fine: &str) -> String {
    fine.replace('_', " ")
}

/// The categories every generated house lists: wall, floor, ceiling, then each fine category
/// of the model library in library order. Position `k` is `C` record `k`, mapping index `k+1`.
fn category_names() -> Vec<&'static str> {
    let mut out = vec!["wall", "floor", "ceiling"];
    for m in &catalog().models {
        if !out.contains(&m.fine) {
            out.push(m.fine);
        }
    }
    out
}

/// Formats a number with at most 6 decimals and no negative zero.
fn num(v: f64) -> String {
    let r = (v * 1e6).round() / 1e6;
    let r = if r == 0.0 { 0.0 } else { r };
    format!("{r}")
}

fn nums(vals: &[f64]) -> String {
    vals.iter().map(|v| num(*v)).collect::<Vec<_>>().join(" ")
}

fn minus_all(r: Rect, holes: &[Rect]) -> Vec<Rect> {
    let mut parts = vec![r];
    for h in holes {
        parts = parts.iter().flat_map(|p| p.minus(h)).collect();
    }
    parts
}

/// The model-space box `(min, max)` of an object's model.
fn model_box(o: &PlacedObject) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &o.spec().parts {
        for k in 0..3 {
            lo[k] = lo[k].min(p.min[k]);
            hi[k] = hi[k].max(p.max[k]);
        }
    }
    (lo, hi)
}

/// The free spot nearest to a room's centre (outside furniture footprints and floor holes,
/// away from walls), if any.
fn panorama_spot(room: &RoomPlan, objects: &[&PlacedObject]) -> Option<(f64, f64)> {
    let inner = room.rect.inflate(-(WALL_T + PANORAMA_CLEARANCE));
    if inner.w() <= 0.0 || inner.d() <= 0.0 {
        return None;
    }
    let blocked: Vec<Rect> = objects
        .iter()
        .map(|o| o.footprint().inflate(PANORAMA_CLEARANCE))
        .chain(
            room.floor_holes
                .iter()
                .map(|h| h.inflate(PANORAMA_CLEARANCE)),
        )
        .collect();
    let (cx, cz) = ((inner.x0 + inner.x1) / 2.0, (inner.z0 + inner.z1) / 2.0);
    let step = 0.1;
    let (nx, nz) = ((inner.w() / step) as i64, (inner.d() / step) as i64);
    let mut best: Option<(f64, (f64, f64))> = None;
    for i in 0..=nx {
        for j in 0..=nz {
            let (x, z) = (inner.x0 + i as f64 * step, inner.z0 + j as f64 * step);
            if blocked.iter().any(|b| b.contains_point(x, z)) {
                continue;
            }
            let d = (x - cx).powi(2) + (z - cz).powi(2);
            if best.is_none_or(|(bd, _)| d < bd - 1e-12) {
                best = Some((d, (x, z)));
            }
        }
    }
    best.map(|(_, p)| p)
}

/// Writes one house (mesh first, `.house` last).
pub fn write_house(root: &Path, plan: &HousePlan) -> io::Result<()> {
    write_house_with(root, plan, None)
}

/// An object record to write: level, region of its room (global index), fine category, and
/// its oriented box (y-up centre, first axis, radii along the model's x, y, z).
struct ObjectRec {
    region: i64,
    fine: &'static str,
    centre: [f64; 3],
    axis0: [f64; 3],
    radii: [f64; 3],
}

/// Writes one house, as a scan when `scan` says so (see [`super::scan`]).
pub(super) fn write_house_with(
    root: &Path,
    plan: &HousePlan,
    scan: Option<&super::scan::ScanParams>,
) -> io::Result<()> {
    let mut cats = category_names();
    if scan.is_some() {
        cats.extend(super::scan::CLUTTER_CATEGORIES);
    }
    let cat_index: HashMap<&str, usize> = cats.iter().enumerate().map(|(i, c)| (*c, i)).collect();
    // category_id in the mesh: the C record's mapping index (index + 1).
    let cat_id = |fine: &str| cat_index.get(fine).map_or(-1, |&i| i as i32 + 1);
    let mut mesh = MeshOut::default();
    let mut regions = Vec::new(); // (level, room, global index)
    let mut region_base = Vec::new();
    for (li, level) in plan.levels.iter().enumerate() {
        region_base.push(regions.len());
        for (k, _) in level.rooms.iter().enumerate() {
            regions.push((li, k));
        }
    }
    // Segments: per region floor/ceiling/walls (ids 3r+1..3r+3, no object), then one per
    // object (ids 100000 + object index).
    let mut objects: Vec<(usize, &PlacedObject)> = Vec::new();
    for (li, level) in plan.levels.iter().enumerate() {
        for o in &level.objects {
            objects.push((li, o));
        }
    }
    for (g, &(li, k)) in regions.iter().enumerate() {
        let level = &plan.levels[li];
        let room = &level.rooms[k];
        let base = level.base_y;
        let seg = 3 * g as i32;
        for part in minus_all(room.rect, &room.floor_holes) {
            mesh.flat(&part, base, true, cat_id("floor"), seg + 1, QuadKind::Floor);
        }
        if !room.hide_ceiling {
            for part in minus_all(room.rect, &room.ceiling_holes) {
                mesh.flat(
                    &part,
                    base + room.wall_height,
                    false,
                    cat_id("ceiling"),
                    seg + 2,
                    QuadKind::Ceiling,
                );
            }
        }
        for side in Side::ALL {
            for (min, max) in room.wall_boxes(side, base) {
                mesh.aabox(min, max, cat_id("wall"), seg + 3, QuadKind::Wall);
            }
        }
    }
    for (oi, (_, o)) in objects.iter().enumerate() {
        let seg = 100_000 + oi as i32;
        for p in &o.spec().parts {
            let a = o.apply(p.min);
            let b = o.apply(p.max);
            let min = [a[0].min(b[0]), a[1].min(b[1]), a[2].min(b[2])];
            let max = [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])];
            let fine = o.spec().fine;
            let kind = if fine == "stairs" {
                QuadKind::Floor
            } else {
                QuadKind::Object
            };
            mesh.aabox(min, max, cat_id(fine), seg, kind);
        }
    }
    let mut records: Vec<ObjectRec> = objects
        .iter()
        .map(|(li, o)| {
            let (lo, hi) = model_box(o);
            let c = o.apply([
                (lo[0] + hi[0]) / 2.0,
                (lo[1] + hi[1]) / 2.0,
                (lo[2] + hi[2]) / 2.0,
            ]);
            let origin = o.apply([0.0; 3]);
            let xdir = o.apply([1.0, 0.0, 0.0]);
            ObjectRec {
                region: o
                    .rooms
                    .first()
                    .map_or(-1, |&k| (region_base[*li] + k) as i64),
                fine: o.spec().fine,
                centre: c,
                axis0: sub3(xdir, origin),
                radii: [
                    (hi[0] - lo[0]) / 2.0,
                    (hi[1] - lo[1]) / 2.0,
                    (hi[2] - lo[2]) / 2.0,
                ],
            }
        })
        .collect();
    let data = match scan {
        None => mesh.plain(),
        Some(params) => {
            let mut rng = Rng::new(derive_seed(params.seed, &[&plan.id, "scan"]));
            for c in super::scan::clutter(plan, &mut rng) {
                let seg = 100_000 + records.len() as i32;
                mesh.aabox(c.min, c.max, cat_id(c.fine), seg, QuadKind::Object);
                records.push(ObjectRec {
                    region: (region_base[c.level] + c.room) as i64,
                    fine: c.fine,
                    centre: [
                        (c.min[0] + c.max[0]) / 2.0,
                        (c.min[1] + c.max[1]) / 2.0,
                        (c.min[2] + c.max[2]) / 2.0,
                    ],
                    axis0: [1.0, 0.0, 0.0],
                    radii: [
                        (c.max[0] - c.min[0]) / 2.0,
                        (c.max[1] - c.min[1]) / 2.0,
                        (c.max[2] - c.min[2]) / 2.0,
                    ],
                });
            }
            super::scan::tessellate(&mesh.quads, params, &mut rng)
        }
    };
    drop(mesh);
    let dir = root.join(&plan.id).join("house_segmentations");
    write_bytes_atomic(
        &dir.join(format!("{}.ply", plan.id)),
        &write_ply(&data.positions, &data.triangles, &data.labels),
    )?;

    let mut body = String::new();
    // Levels.
    let mut house_lo = [f64::INFINITY; 3];
    let mut house_hi = [f64::NEG_INFINITY; 3];
    let mut level_lines = Vec::new();
    for (li, level) in plan.levels.iter().enumerate() {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for r in &level.rooms {
            let b = zbox(
                [r.rect.x0, level.base_y, r.rect.z0],
                [r.rect.x1, level.base_y + r.wall_height, r.rect.z1],
            );
            for k in 0..3 {
                lo[k] = lo[k].min(b[k]);
                hi[k] = hi[k].max(b[k + 3]);
            }
        }
        for k in 0..3 {
            house_lo[k] = house_lo[k].min(lo[k]);
            house_hi[k] = house_hi[k].max(hi[k]);
        }
        let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, lo[2]];
        level_lines.push(format!(
            "L  {li}  {}  -  {}  {}  0 0 0 0 0",
            level.rooms.len(),
            nums(&centre),
            nums(&[lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]])
        ));
    }
    // Regions.
    let mut region_lines = Vec::new();
    let mut surface_lines = Vec::new();
    let mut vertex_lines = Vec::new();
    let mut panorama_lines = Vec::new();
    for (g, &(li, k)) in regions.iter().enumerate() {
        let level = &plan.levels[li];
        let room = &level.rooms[k];
        let r = room.rect;
        let base = level.base_y;
        let b = zbox([r.x0, base, r.z0], [r.x1, base + room.wall_height, r.z1]);
        let centre = zup([(r.x0 + r.x1) / 2.0, base, (r.z0 + r.z1) / 2.0]);
        region_lines.push(format!(
            "R  {g} {li}  0 0  {}  {}  {}  {}  0 0 0 0",
            region_letter(room.raw_type, room.class),
            nums(&centre),
            nums(&b),
            num(room.wall_height)
        ));
        let floor_box = [b[0], b[1], b[2], b[3], b[4], b[2]];
        surface_lines.push(format!(
            "S  {g} {g}  0  F  {}  0 0 1  {}  0 0 0 0 0",
            nums(&centre),
            nums(&floor_box)
        ));
        // Counter-clockwise seen from +Z (z-up).
        for (x, y) in [(b[0], b[1]), (b[3], b[1]), (b[3], b[4]), (b[0], b[4])] {
            vertex_lines.push((g, nums(&[x, y, b[2]])));
        }
        let in_room: Vec<&PlacedObject> = level
            .objects
            .iter()
            .filter(|o| o.rooms.contains(&k))
            .collect();
        if let Some((x, z)) = panorama_spot(room, &in_room) {
            panorama_lines.push((
                format!("pano_{}_{g}", &plan.id[..8.min(plan.id.len())]),
                g,
                zup([x, base + PANORAMA_HEIGHT, z]),
            ));
        }
    }
    // Portals: doors and arches between two rooms.
    let mut portal_lines = Vec::new();
    for (li, o) in &objects {
        let fine = o.spec().fine;
        if (fine == "door" || fine == "arch") && o.rooms.len() == 2 {
            let base = region_base[*li];
            let (a, b) = o.world_box();
            portal_lines.push(format!(
                "P  {}  {} {}  {}  {}  0 0 0 0",
                portal_lines.len(),
                base + o.rooms[0],
                base + o.rooms[1],
                fine,
                nums(&zbox(a, b))
            ));
        }
    }
    // Objects.
    let object_lines: Vec<String> = records
        .iter()
        .enumerate()
        .map(|(oi, r)| {
            format!(
                "O  {oi} {} {}  {}  {}  0 0 1  {}  0 0 0 0 0 0 0 0",
                r.region,
                cat_index.get(r.fine).map_or(-1, |&i| i as i64),
                nums(&zup(r.centre)),
                nums(&zup(r.axis0)),
                nums(&r.radii)
            )
        })
        .collect();
    // Segments, sorted by id.
    let segment_lines: Vec<String> = data
        .segments
        .iter()
        .enumerate()
        .map(|(si, e)| {
            let b = e.bbox;
            format!(
                "E  {si} {} {}  {}  {}  {}  0 0 0 0 0",
                e.object,
                e.id,
                num(e.area),
                nums(&[
                    (b[0] + b[3]) / 2.0,
                    (b[1] + b[4]) / 2.0,
                    (b[2] + b[5]) / 2.0
                ]),
                nums(&b)
            )
        })
        .collect();
    let _ = writeln!(body, "ASCII 1.1");
    let _ = writeln!(
        body,
        "H  -  -  0 {} {} {} {} {} {} {} {}  {}  0 0 0 0 0  {}  0 0 0 0 0",
        panorama_lines.len(),
        vertex_lines.len(),
        surface_lines.len(),
        segment_lines.len(),
        object_lines.len(),
        cats.len(),
        region_lines.len(),
        portal_lines.len(),
        level_lines.len(),
        nums(&[
            house_lo[0],
            house_lo[1],
            house_lo[2],
            house_hi[0],
            house_hi[1],
            house_hi[2]
        ])
    );
    for l in level_lines
        .iter()
        .chain(&region_lines)
        .chain(&portal_lines)
        .chain(&surface_lines)
    {
        let _ = writeln!(body, "{l}");
    }
    for (vi, (s, p)) in vertex_lines.iter().enumerate() {
        let _ = writeln!(body, "V  {vi} {s}  F  {p}  0 0 1  0 0 0");
    }
    for (pi, (name, region, p)) in panorama_lines.iter().enumerate() {
        let _ = writeln!(body, "P  {name}  {pi} {region}  0  {}  0 0 0 0 0", nums(p));
    }
    for (ci, fine) in cats.iter().enumerate() {
        let (mi, mname) = mpcat40_of(fine);
        let _ = writeln!(
            body,
            "C  {ci}  {} {}  {mi} {mname}  0 0 0 0 0",
            ci + 1,
            raw_name(fine).replace(' ', "#")
        );
    }
    for l in object_lines.iter().chain(&segment_lines) {
        let _ = writeln!(body, "{l}");
    }
    write_bytes_atomic(&house_path(root, &plan.id), body.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::formats::mp3d::house_file;
    use crate::scene::formats::mp3d::ply::read_ply;

    #[test]
    fn every_library_category_gets_a_distinct_record_and_an_mpcat40_class() {
        let cats = category_names();
        assert_eq!(&cats[..3], &["wall", "floor", "ceiling"]);
        let distinct: std::collections::BTreeSet<_> = cats.iter().collect();
        assert_eq!(distinct.len(), cats.len());
        assert_eq!(mpcat40_of("double_bed"), (11, "bed"));
        assert_eq!(mpcat40_of("stairs"), (16, "stairs"));
        assert_eq!(mpcat40_of("candle"), (39, "objects"));
        assert_eq!(raw_name("dining_table"), "dining table");
    }

    #[test]
    fn written_house_parses_with_consistent_counts_and_mesh_labels() {
        let cfg = crate::generate::GenerateConfig {
            houses: 1,
            seed: 5,
            rooms: (4, 6),
            levels: (2, 2),
            closed_door_prob: 0.5,
            ..Default::default()
        };
        let plan = crate::generate::plan_house(&cfg, 0);
        let dir = tempfile::tempdir().unwrap();
        write_house(dir.path(), &plan).unwrap();
        let bytes = std::fs::read(house_path(dir.path(), &plan.id)).unwrap();
        let house = house_file::parse(&bytes).expect("writer output parses");
        assert_eq!(house.regions.len(), plan.room_count());
        assert_eq!(house.objects.len(), plan.object_count());
        assert_eq!(house.levels.len(), plan.levels.len());
        assert!(!house.panoramas.is_empty());
        assert!(!house.portals.is_empty());
        let ply = std::fs::read(
            dir.path()
                .join(&plan.id)
                .join("house_segmentations")
                .join(format!("{}.ply", plan.id)),
        )
        .unwrap();
        let mesh = read_ply(&ply).unwrap();
        // Every face's segment is an E record and its category a C mapping index.
        let ids: std::collections::HashSet<i64> = house.segments.iter().map(|e| e.id).collect();
        assert!(mesh.segment.iter().all(|s| ids.contains(&i64::from(*s))));
        let n = house.categories.len() as i32;
        assert!(mesh.category.iter().all(|&c| c >= 1 && c <= n));
        // Region 0's outline: 4 vertices, counter-clockwise seen from +Z.
        let outline = &house.surface_outlines()[0];
        let p: Vec<[f64; 3]> = outline.iter().map(|v| v.position).collect();
        let area2: f64 = (0..4)
            .map(|i| p[i][0] * p[(i + 1) % 4][1] - p[(i + 1) % 4][0] * p[i][1])
            .sum();
        assert!(area2 > 0.0);
    }
}
