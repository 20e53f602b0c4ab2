//! Hand-made scenes for navigation tests: floors, walls and objects from boxes.

use glam::{Mat4, Vec3};
use minos::scene::{
    Aabb, Categories, Dataset, Level, Material, Mesh, Object, ObjectFlags, Room, RoomClass, Scene,
    Surface, SurfaceKind,
};

/// A closed box mesh (CCW faces seen from outside).
pub fn box_mesh(min: [f32; 3], max: [f32; 3]) -> Mesh {
    let mut m = Mesh {
        name: "box".into(),
        materials: vec![Material::solid("m", [0.5, 0.5, 0.5])],
        ..Default::default()
    };
    add_box(&mut m, min, max);
    m
}

/// Appends a box to a mesh.
pub fn add_box(m: &mut Mesh, min: [f32; 3], max: [f32; 3]) {
    let o = m.positions.len() as u32;
    for i in 0..8 {
        m.positions.push(minos::scene::box_corner(min, max, i));
    }
    for q in minos::scene::BOX_FACES.map(|q| q.map(|i| i as u32)) {
        m.indices
            .extend([o + q[0], o + q[1], o + q[2], o + q[0], o + q[2], o + q[3]]);
        m.face_materials.extend([0, 0]);
    }
    m.compute_normals();
}

/// An upward-facing floor rectangle at height `y`.
pub fn floor_mesh(x0: f32, z0: f32, x1: f32, z1: f32, y: f32) -> Mesh {
    let mut m = Mesh {
        name: "floor".into(),
        positions: vec![[x0, y, z0], [x0, y, z1], [x1, y, z1], [x1, y, z0]],
        indices: vec![0, 1, 2, 0, 2, 3],
        face_materials: vec![0, 0],
        materials: vec![Material::solid("f", [0.6, 0.5, 0.4])],
        ..Default::default()
    };
    m.compute_normals();
    m
}

/// Builds scenes one piece at a time.
pub struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    /// An empty one-level scene.
    pub fn new(id: &str) -> Self {
        SceneBuilder {
            scene: Scene {
                id: id.into(),
                dataset: Dataset::Suncg,
                levels: vec![Level {
                    index: 0,
                    bbox: Aabb::EMPTY,
                    floor_heights: vec![0.0],
                    rooms: vec![],
                    objects: vec![],
                    ground: vec![],
                }],
                meshes: vec![],
            },
        }
    }

    fn mesh(&mut self, m: Mesh) -> u32 {
        self.scene.meshes.push(m);
        (self.scene.meshes.len() - 1) as u32
    }

    /// A room with a floor rectangle at `y` and optional wall boxes (world space).
    pub fn room(
        mut self,
        id: &str,
        class: RoomClass,
        rect: [f32; 4],
        y: f32,
        walls: &[([f32; 3], [f32; 3])],
    ) -> Self {
        let floor = self.mesh(floor_mesh(rect[0], rect[1], rect[2], rect[3], y));
        let mut surfaces = vec![Surface {
            kind: SurfaceKind::Floor,
            mesh: floor,
        }];
        if !walls.is_empty() {
            let mut w = Mesh {
                name: "walls".into(),
                materials: vec![Material::solid("w", [0.8, 0.8, 0.8])],
                ..Default::default()
            };
            for (a, b) in walls {
                add_box(&mut w, *a, *b);
            }
            let wm = self.mesh(w);
            surfaces.push(Surface {
                kind: SurfaceKind::Wall,
                mesh: wm,
            });
        }
        let mut bbox = Aabb::from_corners(
            Vec3::new(rect[0], y, rect[1]),
            Vec3::new(rect[2], y + 2.7, rect[3]),
        );
        for (a, b) in walls {
            bbox = bbox.union(&Aabb::from_corners(
                Vec3::from_array(*a),
                Vec3::from_array(*b),
            ));
        }
        let level = &mut self.scene.levels[0];
        level.rooms.push(Room {
            id: id.into(),
            raw_types: vec![class.name().into()],
            class,
            floor_polygon: None,
            surfaces,
            area: (rect[2] - rect[0]) * (rect[3] - rect[1]),
            floor_height: y,
            bbox,
        });
        level.bbox = level.bbox.union(&bbox);
        self
    }

    /// An object made of boxes (world space), with a category and flags.
    pub fn object(
        mut self,
        id: &str,
        category: &str,
        flags: ObjectFlags,
        boxes: &[([f32; 3], [f32; 3])],
        rooms: Vec<u32>,
    ) -> Self {
        let mut m = Mesh {
            name: id.into(),
            materials: vec![Material::solid("o", [0.3, 0.3, 0.3])],
            ..Default::default()
        };
        for (a, b) in boxes {
            add_box(&mut m, *a, *b);
        }
        let bbox = m.bounds();
        let mesh = self.mesh(m);
        let level = &mut self.scene.levels[0];
        level.objects.push(Object {
            id: id.into(),
            model_id: id.into(),
            categories: Categories {
                fine: Some(category.into()),
                coarse: Some(category.into()),
                nyu40: Some(category.into()),
                mpcat40: None,
            },
            transform: Mat4::IDENTITY,
            bbox,
            mesh: Some(mesh),
            materials: vec![],
            flags,
            rooms,
        });
        level.bbox = level.bbox.union(&bbox);
        self
    }

    /// The scene.
    pub fn build(mut self) -> Scene {
        let mut heights: Vec<f32> = self.scene.levels[0]
            .rooms
            .iter()
            .map(|r| r.floor_height)
            .collect();
        heights.sort_by(f32::total_cmp);
        heights.dedup();
        self.scene.levels[0].floor_heights = heights;
        self.scene.validate().expect("valid test scene");
        self.scene
    }
}
