//! The real Matterport3D `.house` files in the shared datasets folder load as the issue
//! describes, and their proxy geometry is navigable between the panoramas R2R links. Gated on
//! `MINOS_REAL_DATA` (the folder holding `matterport3d/`).

use crate::common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;
use minos::navmesh::build::build;
use minos::navmesh::NavParams;
use minos::pipeline::ingest::{ingest, DatasetFormat, IngestConfig, Outcome};
use minos::progress::NoProgress;
use minos::scene::formats::mp3d::{house_file, zup_to_yup, Mp3dLoader};
use minos::scene::formats::DatasetLoader;
use minos::scene::formats::SceneEntry;
use minos::scene::{RoomClass, SurfaceKind};

const HOUSE: &str = "GdvgFV5R1Z5";
const TRUNCATED: &str = "gZ6f7yhEvPG";
/// A panorama counts as standing on walkable floor when a walkable span lies this close (m,
/// horizontally) to the point under its camera: the tripod itself is not in the annotations,
/// but the boxes of objects it stood next to are, and the agent keeps its radius from them.
const STAND_RADIUS: f32 = 0.5;

fn real_data() -> Option<PathBuf> {
    match std::env::var_os("MINOS_REAL_DATA") {
        Some(p) => Some(PathBuf::from(p).join("matterport3d")),
        None => {
            common::skip("MINOS_REAL_DATA is not set");
            None
        }
    }
}

fn loader(mp3d: &std::path::Path) -> Mp3dLoader {
    Mp3dLoader::open(
        &mp3d.join("house"),
        Some(&mp3d.join("category_mapping.tsv")),
    )
    .expect("category tables")
}

fn entry(mp3d: &std::path::Path, id: &str) -> SceneEntry {
    SceneEntry {
        id: id.into(),
        path: mp3d.join("house").join(format!("{id}.house")),
    }
}

#[test]
fn real_house_loads_with_the_header_counts_classes_and_categories() {
    let Some(mp3d) = real_data() else { return };
    let loader = loader(&mp3d);
    let found: Vec<String> = loader
        .discover()
        .unwrap()
        .into_iter()
        .map(|e| e.id)
        .collect();
    assert_eq!(found, vec![HOUSE.to_string(), TRUNCATED.to_string()]);
    let bytes = std::fs::read(mp3d.join("house").join(format!("{HOUSE}.house"))).unwrap();
    let house = house_file::parse(&bytes).expect("complete file parses");
    assert_eq!(house.regions.len(), 6);
    assert_eq!(house.objects.len(), 99);
    assert_eq!(house.categories.len(), 1659);
    assert_eq!(house.levels.len(), 1);
    assert_eq!(house.panoramas.len(), 12);
    assert_eq!(house.images.len(), 216);
    assert_eq!(house.segments.len(), 14402);
    assert_eq!(house.vertices.len(), 48);
    assert_eq!(house.header.counts.categories, 1659);

    let start = Instant::now();
    let loaded = loader.load(&entry(&mp3d, HOUSE)).expect("real house loads");
    eprintln!(
        "{HOUSE}: loaded (parse + proxy geometry) in {:.1} ms",
        start.elapsed().as_secs_f64() * 1e3
    );
    let scene = &loaded.scene;
    assert_eq!(scene.levels.len(), 1);
    let level = &scene.levels[0];
    assert_eq!(level.rooms.len(), 6);
    assert_eq!(level.objects.len(), 99);
    let classes: Vec<RoomClass> = level.rooms.iter().map(|r| r.class).collect();
    use RoomClass::*;
    assert_eq!(
        classes,
        vec![Kitchen, Hallway, Bedroom, DiningRoom, LivingRoom, Bathroom]
    );
    assert_eq!(level.rooms[5].raw_types, vec!["a".to_string()]);
    // Every region has an outline, a floor and (proxy) walls; areas are the polygons'.
    for r in &level.rooms {
        assert!(
            r.floor_polygon.as_ref().is_some_and(|p| p.len() >= 4),
            "{}",
            r.id
        );
        assert!(r.surfaces.iter().any(|s| s.kind == SurfaceKind::Floor));
        assert!(r.area > 2.0 && r.area < 15.0, "{}: {}", r.id, r.area);
    }
    // The kitchen's floor is at z = -0.0076 (z-up), so y = -0.0076; its outline spans
    // x -6.56..-2.73 and y_zup -1.158..0.480, i.e. z = -0.480..1.158.
    let kitchen = &level.rooms[0];
    assert!((kitchen.floor_height + 0.00762).abs() < 1e-4);
    let poly = kitchen.floor_polygon.as_ref().unwrap();
    let zs: Vec<f32> = poly.iter().map(|p| p[1]).collect();
    let (zmin, zmax) = zs
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &z| (a.min(z), b.max(z)));
    assert!(
        (zmin + 0.4795).abs() < 1e-3 && (zmax - 1.1581).abs() < 1e-3,
        "{zmin} {zmax}"
    );
    // Categories from category_mapping.tsv: raw, cleaned, NYU-40 and mpcat40 names.
    let toilet = level.objects.iter().find(|o| o.id == "86").unwrap();
    assert_eq!(toilet.categories.mpcat40.as_deref(), Some("toilet"));
    assert_eq!(toilet.categories.nyu40.as_deref(), Some("toilet"));
    assert_eq!(toilet.rooms, vec![5]);
    let doors = level.objects.iter().filter(|o| o.flags.door).count();
    assert_eq!(doors, 5);
    // Object 86's box: centre (-4.84064, -2.66495, 0.40977) z-up → y-up.
    let c = toilet.bbox.center();
    assert!(
        (c - Vec3::new(-4.84064, 0.40977, 2.66495)).length() < 1e-3,
        "{c}"
    );
    // Obstacles are unit boxes; structure (walls, floors, doors, …) is not.
    let boxes = level.objects.iter().filter(|o| o.mesh.is_some()).count();
    assert!(boxes > 40 && boxes < 99, "{boxes}");
    assert!(level
        .objects
        .iter()
        .filter(|o| o.categories.mpcat40.as_deref() == Some("wall"))
        .all(|o| o.mesh.is_none()));
}

#[test]
fn truncated_house_fails_with_a_line_numbered_error_and_the_batch_goes_on() {
    let Some(mp3d) = real_data() else { return };
    let failure = loader(&mp3d)
        .load(&entry(&mp3d, TRUNCATED))
        .expect_err("truncated file must fail");
    // The parser's error is kept as the cause, with its line.
    assert!(
        matches!(&failure, minos::scene::formats::LoadError::House { source, .. } if source.line == 171),
        "{failure:?}"
    );
    let err = minos::escape::error_line(&failure);
    eprintln!("{err}");
    assert!(!err.contains('\n'));
    assert!(
        err.contains(&format!("{TRUNCATED}.house: line 171:")),
        "{err}"
    );
    assert!(
        err.contains("0 of the 5864 segments") && err.contains("truncated"),
        "{err}"
    );

    let dir = tempfile::tempdir().unwrap();
    let cfg = IngestConfig {
        format: DatasetFormat::Mp3d,
        root: mp3d.join("house"),
        data: minos::store::DataDir::new(dir.path().join("DATA")),
        ids: None,
        force: false,
        categories: Some(mp3d.join("category_mapping.tsv")),
        models: None,
    };
    let start = Instant::now();
    let report = ingest(&cfg, &NoProgress).expect("ingest runs");
    eprintln!(
        "ingest of 2 scans (1 ok, 1 failing): {:.1} ms",
        start.elapsed().as_secs_f64() * 1e3
    );
    assert_eq!(report.count(Outcome::Compiled), 1);
    assert_eq!(report.count(Outcome::Failed), 1);
    let rows: BTreeMap<&str, _> = report
        .scenes
        .iter()
        .map(|(r, _)| (r.id.as_str(), r))
        .collect();
    let ok = rows[HOUSE];
    assert_eq!((ok.nlevels, ok.nrooms, ok.nobjects), (1, 6, 99));
    assert_eq!(ok.dataset, "mp3d");
    assert!(ok.categories.iter().any(|c| c == "toilet"));
    let failed = rows[TRUNCATED];
    assert!(failed
        .error
        .as_deref()
        .is_some_and(|e| e.contains("line 171")));
}

#[test]
fn linked_panoramas_stand_on_mutually_reachable_floor() {
    let Some(mp3d) = real_data() else { return };
    let loader = loader(&mp3d);
    let loaded = loader.load(&entry(&mp3d, HOUSE)).unwrap();
    let scene = &loaded.scene;
    let bytes = std::fs::read(mp3d.join("house").join(format!("{HOUSE}.house"))).unwrap();
    let house = house_file::parse(&bytes).unwrap();
    let start = Instant::now();
    let grid = build(scene, &NavParams::default()).expect("bake");
    eprintln!(
        "bake: {:.1} ms, {} walkable spans, {} islands",
        start.elapsed().as_secs_f64() * 1e3,
        grid.walkable_count(),
        grid.islands.len()
    );
    // Panorama positions are cameras ~1.5 m up: drop them onto their region's floor.
    let mut feet: BTreeMap<String, Vec3> = BTreeMap::new();
    for p in &house.panoramas {
        let cam = zup_to_yup(p.position);
        let region = p.region.expect("every panorama of this house has a region");
        let room = scene
            .rooms()
            .find(|r| r.id == format!("region{region}"))
            .unwrap();
        feet.insert(p.name.clone(), Vec3::new(cam.x, room.floor_height, cam.z));
    }
    let json: serde_json::Value = serde_json::from_slice(
        &std::fs::read(
            mp3d.join("house")
                .join(format!("{HOUSE}_connectivity.json")),
        )
        .unwrap(),
    )
    .unwrap();
    let nodes = json.as_array().unwrap();
    let ids: Vec<&str> = nodes
        .iter()
        .map(|n| n["image_id"].as_str().unwrap())
        .collect();
    let stand = |id: &str| -> Option<u32> {
        let p = feet[id];
        let s = grid.snap(p)?;
        let q = grid.span_position(s as usize);
        (Vec3::new(q.x - p.x, 0.0, q.z - p.z).length() <= STAND_RADIUS).then_some(s)
    };
    let mut pairs = BTreeSet::new();
    for (i, n) in nodes.iter().enumerate() {
        if !n["included"].as_bool().unwrap_or(false) {
            continue;
        }
        for (j, u) in n["unobstructed"].as_array().unwrap().iter().enumerate() {
            if u.as_bool() == Some(true) && nodes[j]["included"].as_bool() == Some(true) {
                pairs.insert((ids[i].min(ids[j]), ids[i].max(ids[j])));
            }
        }
    }
    assert!(pairs.len() >= 10, "{} linked pairs", pairs.len());
    let mut good = 0;
    for &(a, b) in &pairs {
        let ok = match (stand(a), stand(b)) {
            (Some(sa), Some(sb)) => {
                grid.spans[sa as usize].island == grid.spans[sb as usize].island
            }
            _ => false,
        };
        if ok {
            good += 1;
        } else {
            eprintln!("not reachable: {a} ({:?}) - {b} ({:?})", feet[a], feet[b]);
        }
    }
    let direct = feet.values().filter(|p| grid.is_walkable(**p)).count();
    println!(
        "{HOUSE}: {direct} of {} panoramas stand on a walkable span directly (the others count when one lies within {STAND_RADIUS} m)",
        feet.len()
    );
    let fraction = good as f64 / pairs.len() as f64;
    println!(
        "{HOUSE}: {good} of {} unobstructed panorama pairs on walkable, mutually reachable spans ({:.1}%)",
        pairs.len(),
        100.0 * fraction
    );
    assert!(fraction >= 0.95, "{fraction}");
    // Every panorama is used by some link, and a good part of the floor stays walkable once
    // furniture boxes and the agent's radius are taken out (18.6 of 38.7 m² when written).
    let used: BTreeSet<&str> = pairs.iter().flat_map(|&(a, b)| [a, b]).collect();
    assert_eq!(used.len(), 12);
    let area = f64::from(grid.walkable_count() as f32 * grid.cell() * grid.cell());
    let floor = scene.floor_area();
    eprintln!("walkable {area:.1} m² of {floor:.1} m² of region floor");
    assert!(area > 0.35 * floor && area < floor, "{area} of {floor}");
}

/// MINOS's own Matterport3D episode states for the house, read by `minos episodes import`:
/// in minos's frame they start on the baked floor with their goal in reach, at about MINOS's
/// path length, and read as RoomGoal their goal room is the region holding the goal point.
/// Read in MINOS's frame as written (no quarter turn), most would not be.
#[test]
fn minos_episode_states_land_on_the_floor_in_minos_frame() {
    use minos::episode::goal::shortest_path;
    use minos::episode::minos_csv::import_minos_csv;
    use minos::episode::{Goal, Task};
    let Some(mp3d) = real_data() else { return };
    let states = mp3d.join("../minos/episode_states.mp3d.csv.bz2");
    if !states.exists() {
        common::skip("MINOS_REAL_DATA has no minos/episode_states.mp3d.csv.bz2");
        return;
    }
    let loader = loader(&mp3d);
    let scene = loader.load(&entry(&mp3d, HOUSE)).unwrap().scene;
    let grid = build(&scene, &NavParams::default()).expect("bake");
    let of_house = |task| {
        import_minos_csv(&states, task)
            .unwrap()
            .into_iter()
            .filter(|e| e.scene_id == HOUSE)
            .collect::<Vec<_>>()
    };
    let length = |p: &[Vec3]| p.windows(2).map(|w| w[0].distance(w[1])).sum::<f32>();

    let points = of_house(None);
    assert_eq!(points.len(), 100);
    let mut ratios = Vec::new();
    for e in points.iter().filter(|e| e.geodesic_distance.is_finite()) {
        if let Some(path) = shortest_path(&grid, e) {
            ratios.push(length(&path) / e.geodesic_distance);
        }
    }
    ratios.sort_by(f32::total_cmp);
    let median = ratios[ratios.len() / 2];
    println!(
        "{HOUSE}: {} of 100 MINOS states reachable, geodesic / MINOS pathDist median {median:.3}",
        ratios.len()
    );
    assert!(ratios.len() >= 90, "{} reachable", ratios.len());
    assert!((0.85..=1.15).contains(&median), "{median}");

    // The same rows without the quarter turn (MINOS's frame as written): (x, z) = (−z', x').
    let unturned = points
        .iter()
        .filter(|e| {
            let mut e = (*e).clone();
            let back = |[x, y, z]: [f32; 3]| [-z, y, x];
            e.start_position = back(e.start_position);
            if let Goal::Point { position } = &mut e.goal {
                *position = back(*position);
            }
            shortest_path(&grid, &e).is_some()
        })
        .count();
    println!("{HOUSE}: {unturned} of 100 reachable in MINOS's frame as written");
    assert!(unturned < 50, "{unturned} reachable unturned");

    let rooms = of_house(Some(Task::RoomGoal));
    let mut inside = 0;
    for e in &rooms {
        let Goal::Room { targets, .. } = &e.goal else {
            panic!("{}: not a room goal", e.episode_id)
        };
        let id = &targets[0].id;
        let index = grid.rooms.iter().position(|r| &r.id == id);
        assert!(index.is_some(), "{}: no room {id}", e.episode_id);
        let on = grid
            .snap(Vec3::from_array(targets[0].position))
            .map(|s| grid.spans[s as usize].room as usize);
        inside += usize::from(on == index);
    }
    println!("{HOUSE}: {inside} of 100 room goals hold their goal point");
    assert!(inside >= 85, "{inside}");
}
