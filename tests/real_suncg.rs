//! The real public SUNCG sample loads as the issue describes. Gated on `MINOS_REAL_DATA`
//! (set by `.ci/run` to `../shared/datasets` when that folder exists).

use crate::common;

use std::collections::BTreeSet;
use std::path::PathBuf;

use minos::scene::formats::suncg::SuncgLoader;
use minos::scene::formats::{DatasetLoader, SceneEntry};
use minos::scene::{RoomClass, SurfaceKind};

const HOUSE: &str = "00e2eed27fb6b5c911624902888039ee";

fn real_data() -> Option<PathBuf> {
    match std::env::var_os("MINOS_REAL_DATA") {
        Some(p) => Some(PathBuf::from(p)),
        None => {
            common::skip("MINOS_REAL_DATA is not set");
            None
        }
    }
}

#[test]
fn real_suncg_house_loads_with_all_objects_categories_and_bbox() {
    let Some(data) = real_data() else { return };
    let root = data.join("suncg");
    let loader = SuncgLoader::open(&root, None).expect("category table");
    assert!(loader
        .mapping_path()
        .is_some_and(|p| p.ends_with("house3d_ModelCategoryMapping.csv")));
    let entry = SceneEntry {
        id: HOUSE.into(),
        path: root.join(HOUSE).join("house.json"),
    };
    let loaded = loader.load(&entry).expect("real house loads");
    let scene = &loaded.scene;
    assert_eq!(scene.levels.len(), 1);
    let level = &scene.levels[0];
    assert_eq!(level.rooms.len(), 1);
    assert_eq!(level.rooms[0].class, RoomClass::Bedroom);
    assert_eq!(level.rooms[0].surfaces.len(), 3);
    assert_eq!(level.objects.len(), 56);
    let models: BTreeSet<&str> = level.objects.iter().map(|o| o.model_id.as_str()).collect();
    assert_eq!(models.len(), 40);
    // Each distinct model is stored once: 40 object meshes + 3 room meshes.
    assert_eq!(scene.meshes.len(), 43);
    assert!(
        level.objects.iter().all(|o| o.categories.fine.is_some()),
        "{:?}",
        loaded.warnings
    );
    assert!(level.objects.iter().all(|o| o.rooms == vec![0]));
    assert!(level.objects.iter().any(|o| o.flags.door));
    assert!(level.objects.iter().any(|o| o.flags.window));
    // The file's level bbox.
    let (min, max) = ([37.315_26, 0.0, 37.292_77], [45.074_735, 2.74, 42.15]);
    for a in 0..3 {
        assert!(
            (level.bbox.min[a] - min[a]).abs() < 1e-3,
            "min {a}: {}",
            level.bbox.min
        );
        assert!(
            (level.bbox.max[a] - max[a]).abs() < 1e-3,
            "max {a}: {}",
            level.bbox.max
        );
    }
    let floor = level.rooms[0]
        .surfaces
        .iter()
        .find(|s| s.kind == SurfaceKind::Floor)
        .unwrap();
    assert!(scene.meshes[floor.mesh as usize].triangle_count() > 0);
    assert!(
        level.rooms[0].area > 20.0 && level.rooms[0].area < 40.0,
        "{}",
        level.rooms[0].area
    );
    // Mirrored instances keep their faces pointing along their normals.
    let mirrored: Vec<_> = level
        .objects
        .iter()
        .filter(|o| o.transform.determinant() < 0.0)
        .collect();
    assert_eq!(mirrored.len(), 4);
    for o in mirrored {
        let w = scene.object_world_mesh(o).unwrap();
        let agree = (0..w.indices.len() / 3)
            .filter(|&t| {
                let n = w.face_normal(t);
                let vn = w.normals[w.indices[3 * t] as usize];
                n.length() > 1e-9 && n.normalize().dot(vn) > 0.0
            })
            .count();
        assert!(
            agree * 10 >= (w.indices.len() / 3) * 8,
            "object {}: {agree} of {}",
            o.id,
            w.indices.len() / 3
        );
    }
}
