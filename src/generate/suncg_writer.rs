//! Writes plans in SUNCG's on-disk layout:
//! `house/<id>/house.json`, `room/<id>/<modelId>{f,c,w}.obj/.mtl`,
//! `object/<modelId>/<modelId>.obj/.mtl`, `metadata/ModelCategoryMapping.csv` and the
//! procedural textures in `texture/` (wood on floors of most rooms and on every model
//! material named `wood`, tiles in kitchens and bathrooms, a checker in hallways).
//!
//! Every file is written atomically, and `house.json` last, so a house whose `house.json`
//! exists is complete; a house's room meshes are flushed to stable storage together (one
//! `syncfs`) before its `house.json` is written durably.

use std::fmt::Write as _;
use std::io;
use std::path::Path;

use serde_json::{json, Value};

use crate::atomic::{sync_filesystem, write_bytes_atomic, write_bytes_staged};

use super::catalog::catalog;
use super::objwrite::{mtl_text, MtlMaterial, ObjText};
use super::plan::{HousePlan, LevelPlan, Rect, RoomPlan, Side};
use super::textures::{self, ProceduralTexture};

/// Metres per texture repeat on generated surfaces.
const TEXTURE_METRES: f64 = 1.0;

/// The texture a model material gets, by its name.
fn model_texture(material: &str) -> Option<ProceduralTexture> {
    (material == "wood").then_some(textures::WOOD)
}

/// Writes the model library (`object/`), its category table (`metadata/`) and the
/// procedural textures (`texture/`).
pub fn write_library(root: &Path) -> io::Result<()> {
    textures::write_textures(root)?;
    let mut csv = String::from(
        "index,model_id,fine_grained_class,coarse_grained_class,empty_struct_obj,nyuv2_40class,wnsynsetid,wnsynsetkey\n",
    );
    for (i, m) in catalog().models.iter().enumerate() {
        let dir = root.join("object").join(&m.id);
        let names: Vec<String> = m.materials.iter().map(|x| x.name.clone()).collect();
        let mut obj = ObjText::new(&format!("{}.mtl", m.id));
        for (i, x) in m.materials.iter().enumerate() {
            if model_texture(&x.name).is_some() {
                obj = obj.texture_scale(i, TEXTURE_METRES);
            }
        }
        for p in &m.parts {
            obj.add_box(p.min, p.max, p.material);
        }
        write_bytes_atomic(
            &dir.join(format!("{}.obj", m.id)),
            obj.finish(&names).as_bytes(),
        )?;
        let mtl: Vec<MtlMaterial> = m
            .materials
            .iter()
            .map(|x| {
                let texture = model_texture(&x.name).map(|t| t.mtl_path());
                (x.name.clone(), x.rgb, x.alpha, texture)
            })
            .collect();
        write_bytes_atomic(
            &dir.join(format!("{}.mtl", m.id)),
            mtl_text(&mtl).as_bytes(),
        )?;
        let structure = if m.fine == "stairs" { 1 } else { 2 };
        let _ = writeln!(
            csv,
            "{i},{},{},{},{structure},{},-,-",
            m.id, m.fine, m.coarse, m.nyu40
        );
    }
    write_bytes_atomic(
        &root.join("metadata").join("ModelCategoryMapping.csv"),
        csv.as_bytes(),
    )
}

fn room_model_id(level: usize, k: usize) -> String {
    format!("fr_{level}rm_{k}")
}

fn ground_model_id(level: usize) -> String {
    format!("fr_{level}gd_0")
}

fn hex(rgb: [f64; 3]) -> String {
    let c = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    format!("#{:02x}{:02x}{:02x}", c(rgb[0]), c(rgb[1]), c(rgb[2]))
}

fn r4(v: f64) -> f64 {
    let r = (v * 10_000.0).round() / 10_000.0;
    if r == 0.0 {
        0.0
    } else {
        r
    }
}

fn bbox_json(lo: [f64; 3], hi: [f64; 3]) -> Value {
    json!({"min": [r4(lo[0]), r4(lo[1]), r4(lo[2])], "max": [r4(hi[0]), r4(hi[1]), r4(hi[2])]})
}

/// A room surface material: name, colour and texture.
#[derive(Clone, Copy)]
struct SurfaceMaterial {
    name: &'static str,
    rgb: [f64; 3],
    texture: Option<ProceduralTexture>,
}

const WOOD_FLOOR: SurfaceMaterial = SurfaceMaterial {
    name: "floor",
    rgb: [0.72, 0.57, 0.42],
    texture: Some(textures::WOOD),
};
const TILE_FLOOR: SurfaceMaterial = SurfaceMaterial {
    name: "floor_tiles",
    rgb: [0.9, 0.88, 0.84],
    texture: Some(textures::TILES),
};
const CHECKER_FLOOR: SurfaceMaterial = SurfaceMaterial {
    name: "floor_checker",
    rgb: [0.86, 0.8, 0.72],
    texture: Some(textures::CHECKER),
};
const GROUND: SurfaceMaterial = SurfaceMaterial {
    name: "floor",
    rgb: [0.62, 0.5, 0.38],
    texture: None,
};
const CEILING: SurfaceMaterial = SurfaceMaterial {
    name: "ceiling",
    rgb: [0.95, 0.95, 0.95],
    texture: None,
};
const WALL: SurfaceMaterial = SurfaceMaterial {
    name: "wall",
    rgb: [0.85, 0.83, 0.78],
    texture: None,
};

/// The floor material of a room of SUNCG type `raw_type`.
fn floor_material(raw_type: &str) -> SurfaceMaterial {
    match raw_type {
        "Kitchen" | "Bathroom" => TILE_FLOOR,
        "Hallway" => CHECKER_FLOOR,
        _ => WOOD_FLOOR,
    }
}

/// Writes `stem.obj` (every face in material 0, `material`) and its `stem.mtl`.
fn write_obj_mtl(
    dir: &Path,
    stem: &str,
    obj: ObjText,
    material: SurfaceMaterial,
) -> io::Result<()> {
    write_bytes_staged(
        &dir.join(format!("{stem}.obj")),
        obj.finish(&[material.name.to_string()]).as_bytes(),
    )?;
    let mtl: MtlMaterial = (
        material.name.to_string(),
        material.rgb,
        1.0,
        material.texture.map(|t| t.mtl_path()),
    );
    write_bytes_staged(
        &dir.join(format!("{stem}.mtl")),
        mtl_text(&[mtl]).as_bytes(),
    )
}

/// An OBJ for one surface material (texture coordinates when it has a texture).
fn surface_obj(mtllib: &str, material: SurfaceMaterial) -> ObjText {
    let obj = ObjText::new(mtllib);
    match material.texture {
        Some(_) => obj.texture_scale(0, TEXTURE_METRES),
        None => obj,
    }
}

fn minus_all(r: Rect, holes: &[Rect]) -> Vec<Rect> {
    let mut parts = vec![r];
    for h in holes {
        parts = parts.iter().flat_map(|p| p.minus(h)).collect();
    }
    parts
}

fn write_room(dir: &Path, model: &str, room: &RoomPlan, base: f64) -> io::Result<()> {
    let floor_mat = floor_material(room.raw_type);
    let mut floor = surface_obj(&format!("{model}f.mtl"), floor_mat);
    for part in minus_all(room.rect, &room.floor_holes) {
        floor.add_flat(&part, base, true, 0);
    }
    write_obj_mtl(dir, &format!("{model}f"), floor, floor_mat)?;
    let mut ceiling = surface_obj(&format!("{model}c.mtl"), CEILING);
    for part in minus_all(room.rect, &room.ceiling_holes) {
        ceiling.add_flat(&part, base + room.wall_height, false, 0);
    }
    write_obj_mtl(dir, &format!("{model}c"), ceiling, CEILING)?;
    let mut walls = surface_obj(&format!("{model}w.mtl"), WALL);
    for side in Side::ALL {
        for (min, max) in room.wall_boxes(side, base) {
            walls.add_box(min, max, 0);
        }
    }
    write_obj_mtl(dir, &format!("{model}w"), walls, WALL)
}

fn level_nodes(li: usize, level: &LevelPlan, lo: &mut [f64; 3], hi: &mut [f64; 3]) -> Vec<Value> {
    let mut grow = |a: [f64; 3], b: [f64; 3]| {
        for k in 0..3 {
            lo[k] = lo[k].min(a[k]);
            hi[k] = hi[k].max(b[k]);
        }
    };
    let nrooms = level.rooms.len();
    let mut nodes = Vec::with_capacity(nrooms + level.objects.len() + 1);
    for (k, room) in level.rooms.iter().enumerate() {
        let members: Vec<usize> = level
            .objects
            .iter()
            .enumerate()
            .filter(|(_, o)| o.rooms.contains(&k))
            .map(|(i, _)| nrooms + i)
            .collect();
        let a = [room.rect.x0, level.base_y, room.rect.z0];
        let b = [room.rect.x1, level.base_y + room.wall_height, room.rect.z1];
        grow(a, b);
        nodes.push(json!({
            "id": format!("{li}_{k}"),
            "type": "Room",
            "valid": 1,
            "modelId": room_model_id(li, k),
            "nodeIndices": members,
            "roomTypes": [room.raw_type],
            "bbox": bbox_json(a, b),
            "hideCeiling": i32::from(room.hide_ceiling),
            "hideFloor": 0,
            "hideWalls": 0,
        }));
    }
    for (i, o) in level.objects.iter().enumerate() {
        let (a, b) = o.world_box();
        grow(a, b);
        let mut node = json!({
            "id": format!("{li}_{}", nrooms + i),
            "type": "Object",
            "valid": 1,
            "modelId": o.spec().id,
            "transform": o.transform().iter().map(|v| r4(*v)).collect::<Vec<_>>(),
            "bbox": bbox_json(a, b),
        });
        if o.colors.iter().any(Option::is_some) {
            let mats: Vec<Value> = o
                .spec()
                .materials
                .iter()
                .zip(&o.colors)
                .map(|(m, c)| json!({"name": m.name, "diffuse": hex(c.unwrap_or(m.rgb))}))
                .collect();
            node["materials"] = Value::Array(mats);
        }
        if o.mirrored {
            node["isMirrored"] = json!(1);
        }
        nodes.push(node);
    }
    if let Some(g) = level.ground {
        let a = [g.x0, level.base_y, g.z0];
        let b = [g.x1, level.base_y, g.z1];
        grow(a, b);
        nodes.push(json!({
            "id": format!("{li}_{}", nrooms + level.objects.len()),
            "type": "Ground",
            "valid": 1,
            "modelId": ground_model_id(li),
            "bbox": bbox_json(a, b),
        }));
    }
    nodes
}

/// Writes one house (room meshes first, `house.json` last).
pub fn write_house(root: &Path, plan: &HousePlan) -> io::Result<()> {
    let room_dir = root.join("room").join(&plan.id);
    let mut levels = Vec::new();
    let mut house_lo = [f64::INFINITY; 3];
    let mut house_hi = [f64::NEG_INFINITY; 3];
    for (li, level) in plan.levels.iter().enumerate() {
        for (k, room) in level.rooms.iter().enumerate() {
            write_room(&room_dir, &room_model_id(li, k), room, level.base_y)?;
        }
        if let Some(g) = level.ground {
            let footprint = level.rooms.iter().fold(
                Rect::new(
                    f64::INFINITY,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::NEG_INFINITY,
                ),
                |acc, r| {
                    Rect::new(
                        acc.x0.min(r.rect.x0),
                        acc.z0.min(r.rect.z0),
                        acc.x1.max(r.rect.x1),
                        acc.z1.max(r.rect.z1),
                    )
                },
            );
            let mut ground = surface_obj(&format!("{}f.mtl", ground_model_id(li)), GROUND);
            for part in g.minus(&footprint) {
                ground.add_flat(&part, level.base_y, true, 0);
            }
            write_obj_mtl(
                &room_dir,
                &format!("{}f", ground_model_id(li)),
                ground,
                GROUND,
            )?;
        }
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        let nodes = level_nodes(li, level, &mut lo, &mut hi);
        for k in 0..3 {
            house_lo[k] = house_lo[k].min(lo[k]);
            house_hi[k] = house_hi[k].max(hi[k]);
        }
        levels.push(json!({"id": li.to_string(), "bbox": bbox_json(lo, hi), "nodes": nodes}));
    }
    let house = json!({
        "version": "suncg@1.0.0",
        "id": plan.id,
        "up": [0, 1, 0],
        "front": [0, 0, 1],
        "scaleToMeters": 1,
        "bbox": bbox_json(house_lo, house_hi),
        "levels": levels,
    });
    let bytes = serde_json::to_vec(&house).map_err(io::Error::other)?;
    // The house's room meshes were written without a flush each: one flush of the file
    // system makes them durable before `house.json` marks the house complete.
    sync_filesystem(root)?;
    write_bytes_atomic(
        &root.join("house").join(&plan.id).join("house.json"),
        &bytes,
    )
}
