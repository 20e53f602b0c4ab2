//! The whole Matterport3D path without licensed data: `generate --format mp3d` writes houses
//! as `.house` + `.ply`, `ingest --dataset mp3d` reads them back, and the manifest, the scenes
//! and their navigation agree with the plans — with the house mesh and with proxy geometry.

use crate::common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use common::{minos, tree_bytes, RunOk};
use glam::Vec3;
use minos::generate::mp3d_writer::{house_path, raw_name, region_letter, PANORAMA_HEIGHT};
use minos::generate::plan::HousePlan;
use minos::generate::{generate, plan_house, GenerateConfig, OutputFormat};
use minos::navmesh::build::build;
use minos::navmesh::{NavGrid, NavParams};
use minos::pipeline::ingest::{ingest, DatasetFormat, IngestConfig, IngestReport, Outcome};
use minos::progress::NoProgress;
use minos::scene::formats::mp3d::{
    house_file, zup_to_yup, GeometrySource, Mp3dLoader, Mp3dOptions,
};
use minos::scene::formats::DatasetLoader;
use minos::scene::formats::SceneEntry;
use minos::scene::{Scene, SurfaceKind};
use minos::store::manifest::read_manifest;

fn config(houses: usize, seed: u64, closed_door_prob: f64) -> GenerateConfig {
    GenerateConfig {
        houses,
        seed,
        rooms: (1, 10),
        levels: (1, 2),
        closed_door_prob,
        ..Default::default()
    }
}

fn generate_mp3d(cfg: &GenerateConfig, root: &Path) -> Vec<HousePlan> {
    generate(cfg, OutputFormat::Mp3d, root, false, &NoProgress).expect("generate");
    (0..cfg.houses).map(|i| plan_house(cfg, i)).collect()
}

fn ingest_mp3d(root: &Path, data: &Path) -> IngestReport {
    let cfg = IngestConfig {
        format: DatasetFormat::Mp3d,
        root: root.to_path_buf(),
        data: minos::store::DataDir::new(data),
        ids: None,
        force: false,
        categories: None,
        models: None,
    };
    ingest(&cfg, &NoProgress).expect("ingest")
}

fn entry(root: &Path, id: &str) -> SceneEntry {
    SceneEntry {
        id: id.to_string(),
        path: house_path(root, id),
    }
}

/// Each panorama of the written house, dropped to its region's floor, with its level.
fn panorama_feet(root: &Path, id: &str, scene: &Scene) -> Vec<(usize, Vec3)> {
    let bytes = std::fs::read(house_path(root, id)).unwrap();
    let house = house_file::parse(&bytes).unwrap();
    house
        .panoramas
        .iter()
        .map(|p| {
            let cam = zup_to_yup(p.position);
            let region = p.region.unwrap();
            let (li, room) = scene
                .levels
                .iter()
                .enumerate()
                .find_map(|(li, l)| {
                    l.rooms
                        .iter()
                        .find(|r| r.id == format!("region{region}"))
                        .map(|r| (li, r))
                })
                .unwrap();
            assert!((cam.y - room.floor_height - PANORAMA_HEIGHT as f32).abs() < 1e-4);
            (li, Vec3::new(cam.x, room.floor_height, cam.z))
        })
        .collect()
}

#[test]
fn manifest_agrees_with_the_plans() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("mp3d"), dir.path().join("DATA"));
    let plans = generate_mp3d(&config(12, 21, 0.3), &root);
    assert!(plans.iter().any(|p| p.levels.len() == 2));
    let report = ingest_mp3d(&root, &data);
    assert_eq!(report.scenes.len(), 12);
    assert_eq!(
        report.count(Outcome::Failed),
        0,
        "{:?}",
        report.scenes.iter().find_map(|(r, _)| r.error.clone())
    );
    // No category table in generated roots: one root warning, nothing per house.
    assert_eq!(report.warnings.len(), 1, "{:?}", report.warnings);
    assert!(report.warnings[0].contains("category_mapping.tsv"));
    let rows = read_manifest(&report.manifest).unwrap();
    for plan in &plans {
        let row = rows.iter().find(|r| r.id == plan.id).expect("row");
        assert_eq!(row.dataset, "mp3d");
        assert_eq!(row.nlevels as usize, plan.levels.len(), "{}", plan.id);
        assert_eq!(row.nrooms as usize, plan.room_count(), "{}", plan.id);
        assert_eq!(row.nobjects as usize, plan.object_count(), "{}", plan.id);
        let rooms = plan.levels.iter().flat_map(|l| &l.rooms);
        let classes: BTreeSet<String> = rooms.clone().map(|r| r.class.name().into()).collect();
        assert_eq!(
            row.room_classes.iter().cloned().collect::<BTreeSet<_>>(),
            classes
        );
        let letters: BTreeSet<String> = rooms
            .clone()
            .map(|r| region_letter(r.raw_type, r.class).into())
            .collect();
        assert_eq!(
            row.room_types.iter().cloned().collect::<BTreeSet<_>>(),
            letters
        );
        let cats: BTreeSet<String> = plan
            .levels
            .iter()
            .flat_map(|l| l.objects.iter().map(|o| raw_name(o.spec().fine)))
            .collect();
        assert_eq!(
            row.categories.iter().cloned().collect::<BTreeSet<_>>(),
            cats
        );
        // Floor area is the outlines' (the rectangles), summed independently.
        let area: f64 = rooms.map(|r| r.rect.area()).sum();
        assert!(
            (row.floor_area - area).abs() < 1e-3 * area,
            "{}: {} vs {area}",
            plan.id,
            row.floor_area
        );
        assert!(row.ntriangles > 100);
    }
}

#[test]
fn house_mesh_scenes_split_by_region_and_keep_categories() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("mp3d");
    let plans = generate_mp3d(&config(4, 3, 0.3), &root);
    let loader = Mp3dLoader::open(&root, None).unwrap();
    for plan in &plans {
        let loaded = loader.load(&entry(&root, &plan.id)).unwrap();
        assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
        assert!(loaded
            .sources
            .iter()
            .any(|p| p.extension().is_some_and(|e| e == "ply")));
        let scene = &loaded.scene;
        for (level, lp) in scene.levels.iter().zip(&plan.levels) {
            for (room, rp) in level.rooms.iter().zip(&lp.rooms) {
                assert_eq!(room.class, rp.class);
                // The floor surface is the room's rectangle at its height.
                let floor = room
                    .surfaces
                    .iter()
                    .find(|s| s.kind == SurfaceKind::Floor)
                    .expect("floor surface");
                let b = scene.meshes[floor.mesh as usize].bounds();
                assert!((b.min.y - lp.base_y as f32).abs() < 1e-3);
                assert!(b.min.x >= rp.rect.x0 as f32 - 1e-3 && b.max.x <= rp.rect.x1 as f32 + 1e-3);
                assert!((room.floor_height - lp.base_y as f32).abs() < 1e-4);
                assert!(room.surfaces.iter().any(|s| s.kind == SurfaceKind::Wall));
            }
            // Objects keep their box, category and room; the mesh holds their geometry.
            for (o, po) in level.objects.iter().zip(&lp.objects) {
                assert!(o.mesh.is_none());
                let (lo, hi) = po.world_box();
                assert!(
                    (o.bbox.min - Vec3::new(lo[0] as f32, lo[1] as f32, lo[2] as f32)).length()
                        < 1e-3
                );
                assert!(
                    (o.bbox.max - Vec3::new(hi[0] as f32, hi[1] as f32, hi[2] as f32)).length()
                        < 1e-3
                );
                assert_eq!(o.categories.fine, Some(raw_name(po.spec().fine)));
                assert_eq!(o.rooms, vec![po.rooms[0] as u32]);
                assert_eq!(
                    o.flags.door,
                    po.spec().fine == "door" || po.spec().fine == "arch"
                );
                assert_eq!(o.flags.stairs, po.spec().fine == "stairs");
            }
        }
        // Faces keep their mpcat40 class as material: floors are "floor" (or "stairs").
        let floor_materials: BTreeSet<&str> = scene
            .rooms()
            .flat_map(|r| &r.surfaces)
            .filter(|s| s.kind == SurfaceKind::Floor)
            .flat_map(|s| {
                scene.meshes[s.mesh as usize]
                    .materials
                    .iter()
                    .map(|m| m.name.as_str())
            })
            .collect();
        assert!(
            floor_materials
                .iter()
                .all(|m| *m == "floor" || *m == "stairs"),
            "{floor_materials:?}"
        );
    }
}

fn stand(grid: &NavGrid, p: Vec3, radius: f32) -> Option<u32> {
    let s = grid.snap(p)?;
    let q = grid.span_position(s as usize);
    (Vec3::new(q.x - p.x, 0.0, q.z - p.z).length() <= radius).then_some(s)
}

#[test]
fn with_every_door_open_all_panoramas_share_one_island_across_levels() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("mp3d");
    let plans = generate_mp3d(&config(6, 8, 0.0), &root);
    assert!(plans.iter().any(|p| p.levels.len() == 2));
    let loader = Mp3dLoader::open(&root, None).unwrap();
    for plan in &plans {
        let scene = loader.load(&entry(&root, &plan.id)).unwrap().scene;
        let grid = build(&scene, &NavParams::default()).unwrap();
        let feet = panorama_feet(&root, &plan.id, &scene);
        assert!(feet.len() * 2 >= plan.room_count(), "{}", plan.id);
        let islands: BTreeSet<u32> = feet
            .iter()
            .map(|(_, p)| {
                assert!(
                    grid.is_walkable(*p),
                    "{}: panorama at {p} not walkable",
                    plan.id
                );
                grid.spans[grid.span_at(*p).unwrap() as usize].island
            })
            .collect();
        // Open doors, arches and stairs join everything: one island holds every panorama.
        assert_eq!(islands.len(), 1, "{}: {islands:?}", plan.id);
    }
}

#[test]
fn proxy_geometry_of_generated_houses_is_navigable_per_level() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("mp3d");
    let plans = generate_mp3d(&config(6, 8, 0.0), &root);
    let loader = Mp3dLoader::open(&root, None)
        .unwrap()
        .with_options(Mp3dOptions {
            geometry: GeometrySource::Proxy,
            proxy_walls: true,
        });
    let mut boxes = 0;
    for plan in &plans {
        let loaded = loader.load(&entry(&root, &plan.id)).unwrap();
        assert!(loaded
            .sources
            .iter()
            .all(|p| p.extension().is_some_and(|e| e == "house")));
        let scene = &loaded.scene;
        assert_eq!(scene.rooms().count(), plan.room_count());
        boxes += scene.objects().filter(|o| o.mesh.is_some()).count();
        // Doors, arches and stairs are never obstacles.
        assert!(scene
            .objects()
            .filter(|o| o.flags.door || o.flags.stairs)
            .all(|o| o.mesh.is_none()));
        let grid = build(scene, &NavParams::default()).unwrap();
        let feet = panorama_feet(&root, &plan.id, scene);
        let mut by_level: BTreeMap<usize, BTreeSet<u32>> = BTreeMap::new();
        for (li, p) in &feet {
            let s = stand(&grid, *p, 0.3)
                .unwrap_or_else(|| panic!("{}: panorama at {p} off the floor", plan.id));
            by_level
                .entry(*li)
                .or_default()
                .insert(grid.spans[s as usize].island);
        }
        // Adjacent rooms share their outlines, so each level is one open floor.
        for (li, islands) in by_level {
            assert_eq!(islands.len(), 1, "{} level {li}: {islands:?}", plan.id);
        }
    }
    assert!(boxes > 20, "{boxes} obstacle boxes");
}

#[test]
fn cli_generates_and_ingests_mp3d_and_reports_broken_houses_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let (root, data) = (dir.path().join("mp3d"), dir.path().join("DATA"));
    minos()
        .args([
            "generate", "--format", "mp3d", "--houses", "4", "--seed", "2", "--rooms", "2..5",
            "--out",
        ])
        .arg(&root)
        .ok_output();
    let cfg = GenerateConfig {
        houses: 4,
        seed: 2,
        rooms: (2, 5),
        ..GenerateConfig::default()
    };
    let ids: Vec<String> = (0..4).map(|i| minos::generate::house_id(&cfg, i)).collect();
    // 0: Windows line endings and trailing blanks: still fine.
    let p0 = house_path(&root, &ids[0]);
    let crlf = std::fs::read_to_string(&p0).unwrap().replace('\n', " \r\n");
    std::fs::write(&p0, crlf).unwrap();
    // 1: a broken number in an O record.
    let p1 = house_path(&root, &ids[1]);
    let text = std::fs::read_to_string(&p1).unwrap();
    let line = text.lines().position(|l| l.starts_with("O ")).unwrap() + 1;
    let broken: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i + 1 == line {
                let mut f: Vec<&str> = l.split_whitespace().collect();
                f[2] = "x";
                f.join(" ")
            } else {
                l.to_string()
            }
        })
        .collect();
    std::fs::write(&p1, broken.join("\n")).unwrap();
    // 2: the PLY cut short.
    let ply = house_path(&root, &ids[2]).with_extension("ply");
    let bytes = std::fs::read(&ply).unwrap();
    std::fs::write(&ply, &bytes[..bytes.len() / 2]).unwrap();
    // A bare .house file beside the scans is a scan too (id = file stem).
    let p3 = house_path(&root, &ids[3]);
    std::fs::copy(&p3, root.join("bare.house")).unwrap();

    let out = minos()
        .args(["ingest", "--dataset", "mp3d", "--root"])
        .arg(&root)
        .arg("--out")
        .arg(&data)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 2, "{stderr}");
    let e1 = errors.iter().find(|l| l.contains(&ids[1])).unwrap();
    assert!(
        e1.contains(&format!(
            "{}.house: line {line}: O record: field 2 (region_index) is `x`",
            ids[1]
        )),
        "{e1}"
    );
    let e2 = errors.iter().find(|l| l.contains(&ids[2])).unwrap();
    assert!(e2.contains(".ply:") && e2.contains("invalid PLY"), "{e2}");
    let rows = read_manifest(&data.join("houses.parquet")).unwrap();
    assert_eq!(rows.len(), 5);
    assert_eq!(rows.iter().filter(|r| r.is_ok()).count(), 3);
    let bare = rows.iter().find(|r| r.id == "bare").unwrap();
    let scan3 = rows.iter().find(|r| r.id == ids[3]).unwrap();
    assert!(bare.is_ok());
    // Without its PLY, the bare file gets proxy geometry: same rooms and objects.
    assert_eq!((bare.nrooms, bare.nobjects), (scan3.nrooms, scan3.nobjects));
    assert_ne!(bare.ntriangles, scan3.ntriangles);
    let crlf_row = rows.iter().find(|r| r.id == ids[0]).unwrap();
    assert!(crlf_row.is_ok() && crlf_row.nrooms >= 2);
}

#[test]
fn same_seed_gives_identical_bytes_and_an_interrupted_run_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(5, 13, 0.3);
    let run = |threads: usize, out: &Path| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| generate(&cfg, OutputFormat::Mp3d, out, false, &NoProgress).unwrap())
    };
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    run(1, &a);
    run(2, &b);
    let before = tree_bytes(&a);
    // A .house and a .ply per house, nothing else (no SUNCG model library).
    assert_eq!(before.len(), 10);
    assert!(before == tree_bytes(&b), "outputs differ");
    let victim = minos::generate::house_id(&cfg, 3);
    std::fs::remove_file(house_path(&a, &victim)).unwrap();
    let report = run(2, &a);
    assert_eq!(report.written, vec![victim]);
    assert_eq!(report.skipped.len(), 4);
    assert!(tree_bytes(&a) == before);
}

#[test]
fn textured_obj_without_labels_has_floors_guessed_from_height() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("mp3d");
    let cfg = GenerateConfig {
        levels: (1, 1),
        ..config(3, 17, 0.0)
    };
    let plans = generate_mp3d(&cfg, &root);
    // Replace each house mesh by an unlabelled OBJ in matterport_mesh/<uuid>/, z-up like
    // Matterport's.
    for plan in &plans {
        let ply_path = house_path(&root, &plan.id).with_extension("ply");
        let mesh =
            minos::scene::formats::mp3d::ply::read_ply(&std::fs::read(&ply_path).unwrap()).unwrap();
        std::fs::remove_file(&ply_path).unwrap();
        let mut obj = String::new();
        for p in &mesh.positions {
            obj.push_str(&format!("v {} {} {}\n", p[0], p[1], p[2]));
        }
        for t in &mesh.triangles {
            obj.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
        }
        let uuid = root.join(&plan.id).join("matterport_mesh").join("a1b2c3");
        std::fs::create_dir_all(&uuid).unwrap();
        std::fs::write(uuid.join("a1b2c3.obj"), obj).unwrap();
    }
    let loader = Mp3dLoader::open(&root, None).unwrap();
    for plan in &plans {
        let e = entry(&root, &plan.id);
        assert!(matches!(
            loader.mesh_files(&e),
            minos::scene::formats::mp3d::MeshFiles::Obj(ref f) if f.len() == 1
        ));
        let loaded = loader.load(&e).unwrap();
        assert!(loaded
            .warnings
            .iter()
            .any(|w| w.contains("OBJ without labels")));
        let scene = &loaded.scene;
        // Each room's floor surface covers its rectangle and holds nothing higher than a
        // step (shower trays, thresholds); furniture tops stay in the non-walkable surface.
        for (room, rp) in scene.levels[0].rooms.iter().zip(&plan.levels[0].rooms) {
            let floor = room
                .surfaces
                .iter()
                .find(|s| s.kind == SurfaceKind::Floor)
                .expect("floor");
            let m = &scene.meshes[floor.mesh as usize];
            assert!(
                m.bounds().max.y <= 0.15 + 1e-4,
                "{}: {}",
                room.id,
                m.bounds().max.y
            );
            let area = minos::scene::formats::suncg::floor_area_and_height(m).0;
            assert!(area >= rp.rect.area() * (1.0 - 1e-3), "{area}");
        }
        let high_tops = scene
            .rooms()
            .flat_map(|r| &r.surfaces)
            .filter(|s| s.kind == SurfaceKind::Wall)
            .map(|s| scene.surface_world_mesh(s.mesh))
            .map(|w| {
                (0..w.indices.len() / 3)
                    .filter(|&t| {
                        let n = w.face_normal(t);
                        n.y > 0.9 * n.length() && w.positions[w.indices[3 * t] as usize].y > 0.3
                    })
                    .count()
            })
            .sum::<usize>();
        assert!(high_tops > 10, "{high_tops} furniture tops");
        let grid = build(scene, &NavParams::default()).unwrap();
        let islands: BTreeSet<u32> = panorama_feet(&root, &plan.id, scene)
            .iter()
            .map(|(_, p)| {
                assert!(grid.is_walkable(*p), "{}: {p}", plan.id);
                grid.spans[grid.span_at(*p).unwrap() as usize].island
            })
            .collect();
        assert_eq!(islands.len(), 1, "{}: {islands:?}", plan.id);
    }
}
