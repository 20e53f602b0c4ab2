//! Scene variants end to end on generated houses: clutter removal in the model, the grid and
//! the semantic image; empty houses; opened doors merging islands; retexturing that changes
//! colours only, follows the category statistics and keeps texture sets disjoint; and the
//! paper's empty-vs-furnished geodesic/Euclidean comparison.

use crate::common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use common::{generate_into, ingest_into, minos, RunOk};
use glam::Vec3;
use minos::body::{AgentBody, BodyRule};
use minos::episode::sample::SampleConfig;
use minos::episode::Task;
use minos::generate::GenerateConfig;
use minos::navmesh::build::build;
use minos::navmesh::{NavGrid, NavParams};
use minos::pipeline::bake::{bake_scenes, BakeConfig};
use minos::pipeline::episodes::sample_scenes;
use minos::pipeline::variants::collect_stats;
use minos::progress::NoProgress;
use minos::render::Renderer;
use minos::render::RendererChoice;
use minos::render::{Image, Modality};
use minos::scene::variants::{
    effective_material, material_key, object_category, surface_category, used_slots,
    DEFAULT_FRACTIONS,
};
use minos::scene::variants::{MaterialStats, Retexture, TextureSet, VariantSpec};
use minos::scene::Scene;
use minos::scene::Taxonomy;
use minos::seed::Rng;
use minos::shard::Shard;
use minos::sim::{AgentConfig, SceneAssets, SensorSuite, Simulator};
use minos::store::DataDir;

/// Generated (`cfg`), ingested houses in `dir/data`; returns that DATA folder and the ids.
fn houses_with(dir: &Path, cfg: &GenerateConfig) -> (PathBuf, Vec<String>) {
    let root = dir.join("raw");
    let data = dir.join("data");
    generate_into(cfg, &root);
    let report = ingest_into(&root, &data);
    let mut ids: Vec<String> = report.scenes.iter().map(|(r, _)| r.id.clone()).collect();
    ids.sort();
    (data, ids)
}

/// `count` default generated houses from `seed`, see [`houses_with`].
fn houses(dir: &Path, count: usize, seed: u64) -> (PathBuf, Vec<String>) {
    let cfg = GenerateConfig {
        houses: count,
        seed,
        ..Default::default()
    };
    houses_with(dir, &cfg)
}

fn define(data: &Path, name: &str, spec: VariantSpec) {
    DataDir::new(data).write_variant(name, &spec).unwrap();
}

fn load(data: &Path, scene_ref: &str) -> Scene {
    DataDir::new(data)
        .load_scene(&scene_ref.parse().unwrap())
        .unwrap()
        .0
}

fn object_ids(scene: &Scene) -> BTreeSet<String> {
    scene.objects().map(|o| o.id.clone()).collect()
}

/// Semantic and depth images from `poses` (x, y, z, yaw) with a 48² camera.
fn views(scene: &Scene, poses: &[(Vec3, f32)]) -> Vec<(Vec<u16>, Vec<f32>, Vec<u8>)> {
    let agent = AgentConfig::minos_continuous();
    let grid = build(scene, &NavParams::for_body(agent.body)).unwrap();
    let assets = Arc::new(SceneAssets::new(scene, grid, &agent).unwrap());
    let renderer = Arc::new(Renderer::new(RendererChoice::Cpu, &assets.render).unwrap());
    let mut suite = SensorSuite::minos(48);
    let template = suite.cameras[0].clone();
    suite.cameras = [
        ("s", Modality::Semantic),
        ("d", Modality::Depth),
        ("c", Modality::Color),
    ]
    .iter()
    .map(|(n, m)| {
        let mut c = template.clone();
        c.name = n.to_string();
        c.modality = *m;
        c.taxonomy = Taxonomy::Nyu40;
        c
    })
    .collect();
    suite.contact = None;
    let mut sim = Simulator::new(assets, renderer, agent, suite, 10, 0);
    poses
        .iter()
        .map(|&(p, yaw)| {
            sim.reset(p, yaw, None, "v");
            let obs = sim.observe().unwrap();
            let Image::U16(sem) = &obs.images[0].1 else {
                panic!("semantic is u16")
            };
            let Image::F32 { data: depth, .. } = &obs.images[1].1 else {
                panic!("depth is f32")
            };
            let Image::U8 { data: color, .. } = &obs.images[2].1 else {
                panic!("color is u8")
            };
            (sem.clone(), depth.clone(), color.clone())
        })
        .collect()
}

/// Walkable poses of `grid` (seeded), four headings each.
fn poses(grid: &NavGrid, n: usize) -> Vec<(Vec3, f32)> {
    let mut rng = Rng::new(11);
    (0..n)
        .filter_map(|_| grid.random_point(&mut rng, None))
        .flat_map(|(_, p)| (0..4).map(move |k| (p, k as f32 * std::f32::consts::FRAC_PI_2)))
        .collect()
}

#[test]
fn removing_a_category_removes_exactly_its_instances_from_model_grid_and_image() {
    let dir = tempfile::tempdir().unwrap();
    let (data, ids) = houses(dir.path(), 3, 5);
    define(
        &data,
        "nochairs",
        VariantSpec {
            remove: vec!["chair".into()],
            ..Default::default()
        },
    );
    let mut chairs_seen = 0;
    let mut chair_pixels = 0;
    for id in &ids {
        let base = load(&data, id);
        let variant = load(&data, &format!("{id}@nochairs"));
        assert_eq!(variant.id, format!("{id}@nochairs"));
        // The model: exactly the chair instances are gone, the others are untouched.
        let chairs: BTreeSet<String> = base
            .objects()
            .filter(|o| o.categories.matches("chair"))
            .map(|o| o.id.clone())
            .collect();
        chairs_seen += chairs.len();
        let expected: BTreeSet<String> = object_ids(&base).difference(&chairs).cloned().collect();
        assert_eq!(object_ids(&variant), expected, "{id}");
        for o in variant.objects() {
            let b = base.objects().find(|b| b.id == o.id).unwrap();
            assert_eq!(o, b, "{id}: object {} changed", o.id);
        }
        assert_eq!(base.rooms().count(), variant.rooms().count());

        // The grid: no chair is recorded; every span that changed lies where a chair stood.
        let params = NavParams::default();
        let (gb, gv) = (
            build(&base, &params).unwrap(),
            build(&variant, &params).unwrap(),
        );
        assert!(gv.objects.iter().all(|o| !chairs.contains(&o.id)), "{id}");
        assert_eq!((gb.x0, gb.z0, gb.nx, gb.nz), (gv.x0, gv.z0, gv.nx, gv.nz));
        let near_chair = |p: Vec3| {
            let m = params.body.radius + 2.0 * params.cell_size;
            base.objects().filter(|o| chairs.contains(&o.id)).any(|o| {
                p.x >= o.bbox.min.x - m
                    && p.x <= o.bbox.max.x + m
                    && p.z >= o.bbox.min.z - m
                    && p.z <= o.bbox.max.z + m
            })
        };
        for c in 0..(gb.nx * gb.nz) as usize {
            let walk = |g: &NavGrid| -> Vec<i32> {
                g.column_spans(c)
                    .filter(|&s| g.spans[s].walkable)
                    .map(|s| (g.spans[s].y * 100.0).round() as i32)
                    .collect()
            };
            if walk(&gb) != walk(&gv) {
                let s = gb
                    .column_spans(c)
                    .start
                    .min(gb.spans.len().saturating_sub(1));
                let p = if gb.column_spans(c).is_empty() {
                    gv.span_position(gv.column_spans(c).start)
                } else {
                    gb.span_position(s)
                };
                assert!(
                    near_chair(p),
                    "{id}: column {c} at {p} changed away from chairs"
                );
            }
        }

        // The semantic image: chair pixels vanish; every other pixel keeps its label.
        let chair_class = base
            .objects()
            .find(|o| chairs.contains(&o.id))
            .map(|o| Taxonomy::Nyu40.object_class(&o.categories));
        let Some(chair_class) = chair_class else {
            continue;
        };
        let others: BTreeSet<u16> = base
            .objects()
            .filter(|o| !chairs.contains(&o.id))
            .map(|o| Taxonomy::Nyu40.object_class(&o.categories))
            .collect();
        assert!(!others.contains(&chair_class), "chair label shared");
        let ps = poses(&gb, 25);
        for ((sb, _, _), (sv, _, _)) in views(&base, &ps).iter().zip(views(&variant, &ps).iter()) {
            for (b, v) in sb.iter().zip(sv) {
                assert_ne!(*v, chair_class, "{id}: a chair pixel after removal");
                if *b == chair_class {
                    chair_pixels += 1;
                } else {
                    assert_eq!(b, v, "{id}: a non-chair pixel changed label");
                }
            }
        }
    }
    assert!(chairs_seen > 0, "the test houses have chairs");
    assert!(chair_pixels > 0, "the test views see chairs");
}

#[test]
fn empty_keeps_doors_arches_windows_and_the_rooms() {
    let dir = tempfile::tempdir().unwrap();
    let (data, ids) = houses(dir.path(), 2, 8);
    define(
        &data,
        "empty",
        VariantSpec {
            empty: true,
            ..Default::default()
        },
    );
    define(
        &data,
        "arch",
        VariantSpec {
            keep_only: Some(minos::scene::variants::KeepOnly::One("arch".into())),
            ..Default::default()
        },
    );
    for id in &ids {
        let base = load(&data, id);
        let empty = load(&data, &format!("{id}@empty"));
        let kept: BTreeSet<String> = base
            .objects()
            .filter(|o| o.flags.door || o.flags.arch || o.flags.window)
            .map(|o| o.id.clone())
            .collect();
        assert!(!kept.is_empty() && kept.len() < base.objects().count());
        assert_eq!(object_ids(&empty), kept, "{id}");
        assert_eq!(
            base.levels.iter().map(|l| &l.rooms).collect::<Vec<_>>(),
            empty.levels.iter().map(|l| &l.rooms).collect::<Vec<_>>(),
            "{id}: rooms (walls, floors, ceilings) untouched"
        );
        // keep_only = "arch" also keeps stairs.
        let arch = load(&data, &format!("{id}@arch"));
        let with_stairs: BTreeSet<String> = base
            .objects()
            .filter(|o| o.flags.door || o.flags.arch || o.flags.window || o.flags.stairs)
            .map(|o| o.id.clone())
            .collect();
        assert_eq!(object_ids(&arch), with_stairs, "{id}");
    }
}

#[test]
fn opening_doors_merges_the_islands_they_separated() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = GenerateConfig {
        houses: 3,
        seed: 21,
        closed_door_prob: 1.0,
        ..Default::default()
    };
    let (data, ids) = houses_with(dir.path(), &cfg);
    define(
        &data,
        "open",
        VariantSpec {
            open_doors: true,
            ..Default::default()
        },
    );
    let params = NavParams::default();
    let mut checked = 0;
    for id in &ids {
        let base = load(&data, id);
        let open = load(&data, &format!("{id}@open"));
        let (gb, go) = (
            build(&base, &params).unwrap(),
            build(&open, &params).unwrap(),
        );
        for door in base
            .objects()
            .filter(|o| o.flags.door && o.model_id.contains("closed"))
        {
            let opened = open.objects().find(|o| o.id == door.id).unwrap();
            assert!(
                !opened.model_id.contains("closed"),
                "{id}: {} still closed",
                door.id
            );
            let c = door.bbox.center();
            let size = door.bbox.size();
            let across = if size.x < size.z { Vec3::X } else { Vec3::Z };
            let y = door.bbox.min.y;
            let (a, b) = (c - across * 0.45, c + across * 0.45);
            let (a, b) = (Vec3::new(a.x, y, a.z), Vec3::new(b.x, y, b.z));
            let island = |g: &NavGrid, p: Vec3| g.snap(p).map(|s| g.spans[s as usize].island);
            let (Some(ia), Some(ib)) = (island(&gb, a), island(&gb, b)) else {
                continue;
            };
            assert_ne!(ia, ib, "{id}: closed door {} does not separate", door.id);
            assert_eq!(
                island(&go, a),
                island(&go, b),
                "{id}: opened door {} does not join its sides",
                door.id
            );
            checked += 1;
        }
        assert!(go.islands.len() <= gb.islands.len());
    }
    assert!(checked > 0, "the test houses have closed doors");
}

fn stats_for(data: &Path, ids: &[String]) -> MaterialStats {
    let data = DataDir::new(data);
    let (stats, failures) = collect_stats(&data, ids, 0, DEFAULT_FRACTIONS, &NoProgress);
    assert!(failures.is_empty());
    data.write_material_stats(&stats).unwrap();
    stats
}

/// `(category, key)` of every used slot of every object and surface of `scene`.
fn slot_materials(scene: &Scene) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for l in &scene.levels {
        for r in &l.rooms {
            for s in &r.surfaces {
                let m = &scene.meshes[s.mesh as usize];
                for slot in used_slots(m) {
                    let (_, d, t) = effective_material(m, None, slot).unwrap();
                    out.push((
                        surface_category(s.kind).to_string(),
                        material_key([d[0], d[1], d[2]], t.as_deref()),
                    ));
                }
            }
        }
        for o in &l.objects {
            let Some(m) = o.mesh.map(|m| &scene.meshes[m as usize]) else {
                continue;
            };
            for slot in used_slots(m) {
                let (_, d, t) = effective_material(m, Some(o), slot).unwrap();
                out.push((
                    object_category(o),
                    material_key([d[0], d[1], d[2]], t.as_deref()),
                ));
            }
        }
    }
    out
}

#[test]
fn retexturing_is_seeded_changes_colours_only_and_follows_the_statistics() {
    let dir = tempfile::tempdir().unwrap();
    let (data, ids) = houses(dir.path(), 4, 2);
    let stats = stats_for(&data, &ids);
    // The partition: every material in exactly one set, all three sets used.
    let keys: BTreeSet<&str> = stats.materials.iter().map(|m| m.key.as_str()).collect();
    assert_eq!(keys.len(), stats.materials.len());
    for set in TextureSet::ALL {
        assert!(
            stats.materials.iter().any(|m| m.set == set),
            "{set} is empty"
        );
    }
    for (name, seed, set) in [
        ("t7", 7, TextureSet::Train),
        ("t7b", 7, TextureSet::Train),
        ("t8", 8, TextureSet::Train),
        ("v7", 7, TextureSet::Val),
        ("s7", 7, TextureSet::Test),
    ] {
        define(
            &data,
            name,
            VariantSpec {
                retexture: Some(Retexture {
                    seed,
                    texture_set: set,
                }),
                ..Default::default()
            },
        );
    }
    let set_of = |key: &str| stats.materials.iter().find(|m| m.key == key).map(|m| m.set);
    let mut drawn: [BTreeSet<String>; 3] = Default::default();
    let mut differs_by_seed = false;
    for id in &ids {
        let base = load(&data, id);
        let t7 = load(&data, &format!("{id}@t7"));
        // Deterministic: the same seed gives the same scene (another name, same draws).
        let mut t7b = load(&data, &format!("{id}@t7b"));
        t7b.id = t7.id.clone();
        assert_eq!(t7, t7b, "{id}");
        differs_by_seed |= slot_materials(&t7) != slot_materials(&load(&data, &format!("{id}@t8")));
        // Geometry, ids and categories identical.
        assert_eq!(object_ids(&t7), object_ids(&base));
        for (a, b) in t7.objects().zip(base.objects()) {
            assert_eq!(
                (&a.id, &a.categories, a.transform, a.mesh),
                (&b.id, &b.categories, b.transform, b.mesh)
            );
        }
        for (a, b) in t7.meshes.iter().zip(&base.meshes) {
            assert_eq!(
                (&a.positions, &a.indices, &a.face_materials),
                (&b.positions, &b.indices, &b.face_materials)
            );
        }
        // Every redrawn slot holds a material its category shows, from the asked set; a kept
        // slot's category has no material in that set.
        for (variant, set) in [
            ("t7", TextureSet::Train),
            ("v7", TextureSet::Val),
            ("s7", TextureSet::Test),
        ] {
            let scene = load(&data, &format!("{id}@{variant}"));
            let before = slot_materials(&base);
            for ((cat, key), (_, old)) in slot_materials(&scene).into_iter().zip(before) {
                let candidates = stats.candidates(&cat, set);
                if candidates.is_empty() {
                    assert_eq!(key, old, "{id}: {cat} slot changed without candidates");
                    continue;
                }
                assert!(
                    candidates.iter().any(|(m, _)| m.key == key),
                    "{id}: {cat} got {key}, never seen on {cat} in {set}"
                );
                assert_eq!(set_of(&key), Some(set));
                drawn[set as usize].insert(key);
            }
        }
        // Rendered: labels and depth identical, colours differ somewhere.
        let grid = build(&base, &NavParams::default()).unwrap();
        let ps = poses(&grid, 6);
        let (vb, vt) = (views(&base, &ps), views(&t7, &ps));
        let mut colour_changed = false;
        for ((sb, db, cb), (st, dt, ct)) in vb.iter().zip(&vt) {
            assert_eq!(sb, st, "{id}: labels changed");
            assert_eq!(db, dt, "{id}: depth changed");
            colour_changed |= cb != ct;
        }
        assert!(colour_changed, "{id}: retexturing changed no pixel");
    }
    assert!(differs_by_seed, "another seed draws other materials");
    // Texture sets never share a material.
    assert!(drawn.iter().all(|d| !d.is_empty()));
    assert!(
        drawn[0].is_disjoint(&drawn[1])
            && drawn[0].is_disjoint(&drawn[2])
            && drawn[1].is_disjoint(&drawn[2])
    );
}

#[test]
fn furnished_houses_make_longer_detours_than_empty_ones() {
    let dir = tempfile::tempdir().unwrap();
    let (data, ids) = houses(dir.path(), 6, 1);
    define(
        &data,
        "empty",
        VariantSpec {
            empty: true,
            ..Default::default()
        },
    );
    let refs: Vec<String> = ids
        .iter()
        .cloned()
        .chain(ids.iter().map(|id| format!("{id}@empty")))
        .collect();
    let report = bake_scenes(
        &BakeConfig {
            data: DataDir::new(&data),
            scenes: refs.iter().map(|r| r.parse().unwrap()).collect(),
            params: NavParams::default(),
            force: false,
            previews: false,
        },
        &NoProgress,
    );
    assert_eq!(report.failures().count(), 0);
    let cfg = SampleConfig {
        task: Task::PointGoal,
        per_scene: 60,
        seed: 4,
        ratio_rule: false,
        ..Default::default()
    };
    let sample = |variant: &str| {
        let scenes: Vec<(String, String)> = ids
            .iter()
            .map(|id| (format!("{id}{variant}"), "train".to_string()))
            .collect();
        sample_scenes(
            &DataDir::new(&data),
            &scenes,
            &cfg,
            BodyRule::strict(AgentBody::HABITAT),
            Shard::ALL,
            &NoProgress,
        )
    };
    let (furnished, empty) = (sample(""), sample("@empty"));
    assert_eq!(furnished.total, 6 * 60);
    assert_eq!(empty.total, 6 * 60);
    assert!(empty
        .episodes
        .iter()
        .all(|e| e.scene_id.ends_with("@empty")));
    assert!(
        furnished.mean_ratio > empty.mean_ratio + 0.05,
        "furnished {:.3} vs empty {:.3}",
        furnished.mean_ratio,
        empty.mean_ratio
    );
}

#[test]
fn the_cli_defines_bakes_and_reports_variants() {
    let dir = tempfile::tempdir().unwrap();
    let (data, ids) = houses(dir.path(), 2, 3);
    let spec = dir.path().join("variants.toml");
    std::fs::write(
        &spec,
        "[empty]\nempty = true\n[tex]\nretexture = { seed = 1, texture_set = \"val\" }\n",
    )
    .unwrap();
    minos()
        .args(["-q", "variants", "--data"])
        .arg(&data)
        .arg("--spec")
        .arg(&spec)
        .ok_output();
    assert!(data.join("variants/empty.toml").is_file());
    assert!(data.join("stats/materials.json").is_file());
    minos()
        .args(["-q", "bake", "--no-preview", "--variant", "empty", "--data"])
        .arg(&data)
        .ok_output();
    for id in &ids {
        assert!(data.join(format!("nav/{id}@empty.nav")).is_file());
    }
    // Unknown variants and bad spec files give one-line errors naming what is wrong.
    let err = minos()
        .args(["bake", "--variant", "nope", "--data"])
        .arg(&data)
        .failed_stderr();
    assert!(
        err.contains("--variant nope") && err.contains("nope.toml"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    // `minos variants --spec` over a spec file holding `text`, which must fail: its stderr.
    let refused_spec = |text: &str| {
        std::fs::write(&spec, text).unwrap();
        minos()
            .args(["variants", "--data"])
            .arg(&data)
            .arg("--spec")
            .arg(&spec)
            .failed_stderr()
    };
    let err = refused_spec("[bad]\nempty = \"yes\"\n");
    assert!(
        err.contains("variants.toml") && err.contains("line 2") && err.contains("empty = \"yes\""),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    // A variant that changes nothing is refused before anything is written, from a spec
    // file (the library's line) and from flags (with the flags that would change something).
    let err = refused_spec("[open]\nopen_doors = true\n[same]\n");
    assert_eq!(err.trim(), "error: variant same: no change given", "{err}");
    assert!(!data.join("variants/open.toml").exists());
    let err = minos()
        .args(["variants", "--name", "same", "--data"])
        .arg(&data)
        .failed_stderr();
    assert!(
        err.starts_with("error: variant same: no change given (use --remove, ")
            && err.trim().lines().count() == 1,
        "{err}"
    );
    assert!(!data.join("variants/same.toml").exists());
}
