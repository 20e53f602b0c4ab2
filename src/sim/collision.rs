//! Collisions of the agent's cylinder with the scene's triangles (parry3d): the body is tested
//! from a step's height above its floor to its full height, so steps and stairs below the
//! climb limit pass under it while walls, furniture and closed doors stop it. Contact probes
//! are small balls around the body.

use glam::Vec3;
use parry3d::math::{Pose, Vector};
use parry3d::query::{self, ShapeCastOptions};
use parry3d::shape::{Ball, Cylinder, TriMesh};

use crate::scene::Scene;

/// Gap left between the climb height and the bottom of the collision cylinder (m).
const CLEARANCE: f32 = 0.01;

/// A scene that gives no collision mesh.
#[derive(Debug, thiserror::Error)]
pub enum CollisionError {
    /// Every triangle of the scene is degenerate, or it has none.
    #[error("scene {scene}: no triangles to collide with")]
    NoTriangles {
        /// The scene id.
        scene: String,
    },
    /// parry3d refused the mesh.
    #[error("scene {scene}: collision mesh")]
    Mesh {
        /// The scene id.
        scene: String,
        /// parry3d's reason.
        #[source]
        source: parry3d::shape::TriMeshBuilderError,
    },
}

/// The scene's triangles as one collision mesh, and the agent's collision shape.
pub struct CollisionWorld {
    mesh: TriMesh,
    body: Cylinder,
    body_offset: f32,
}

fn v(p: Vec3) -> Vector {
    Vector::new(p.x, p.y, p.z)
}

impl CollisionWorld {
    /// Builds the collision mesh of every triangle of the scene (rooms, ground, objects) and the
    /// body cylinder from `max_climb` to `height` above the floor.
    pub fn new(
        scene: &Scene,
        radius: f32,
        height: f32,
        max_climb: f32,
    ) -> Result<Self, CollisionError> {
        let mut vertices: Vec<Vector> = Vec::new();
        let mut indices: Vec<[u32; 3]> = Vec::new();
        let mut add = |m: &crate::scene::WorldMesh| {
            let base = vertices.len() as u32;
            vertices.extend(m.positions.iter().map(|p| v(*p)));
            indices.extend(
                m.indices
                    .chunks_exact(3)
                    .map(|t| [base + t[0], base + t[1], base + t[2]]),
            );
        };
        for level in &scene.levels {
            for room in &level.rooms {
                for s in &room.surfaces {
                    add(&scene.surface_world_mesh(s.mesh));
                }
            }
            for &g in &level.ground {
                add(&scene.surface_world_mesh(g));
            }
            for o in &level.objects {
                if let Some(m) = scene.object_world_mesh(o) {
                    add(&m);
                }
            }
        }
        // Drop degenerate triangles, which the mesh builder rejects.
        indices.retain(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            (b - a).cross(c - a).length() > 1e-12
        });
        if indices.is_empty() {
            return Err(CollisionError::NoTriangles {
                scene: scene.id.clone(),
            });
        }
        let mesh = TriMesh::new(vertices, indices).map_err(|source| CollisionError::Mesh {
            scene: scene.id.clone(),
            source,
        })?;
        let bottom = max_climb + CLEARANCE;
        let half = ((height - bottom) / 2.0).max(0.01);
        Ok(CollisionWorld {
            mesh,
            body: Cylinder::new(half, radius),
            body_offset: bottom + half,
        })
    }

    /// The body's pose standing on `base` (x, floor height, z).
    fn body_pose(&self, base: Vec3) -> Pose {
        Pose::from_translation(v(base + Vec3::Y * self.body_offset))
    }

    /// True when the body standing on `base` (x, floor height, z) overlaps the scene.
    pub fn blocked(&self, base: Vec3) -> bool {
        let pose = self.body_pose(base);
        query::intersection_test(&pose, &self.body, &Pose::IDENTITY, &self.mesh)
            .is_ok_and(|r| r.intersecting)
    }

    /// True when the body standing on `base` overlaps the scene by more than `skin` (m): as
    /// [`CollisionWorld::blocked`] with a body `skin` slimmer where it touches, for walks
    /// over a lattice that must not miss a gap the sliding body passes with no room to spare.
    pub fn blocked_beyond(&self, base: Vec3, skin: f32) -> bool {
        let pose = self.body_pose(base);
        query::contact(&pose, &self.body, &Pose::IDENTITY, &self.mesh, 0.0)
            .ok()
            .flatten()
            .is_some_and(|c| c.dist < -skin)
    }

    /// The horizontal direction pushing the body at `base` out of what it touches, if any.
    pub fn push_out(&self, base: Vec3) -> Option<Vec3> {
        let pose = self.body_pose(base);
        let c = query::contact(&pose, &self.body, &Pose::IDENTITY, &self.mesh, 0.0).ok()??;
        let n = Vec3::new(-c.normal1.x, 0.0, -c.normal1.z);
        n.try_normalize()
    }

    /// The horizontal normal (pointing back at the body) of the first surface the body
    /// standing on `base` meets when moved by `d`, if it meets one on the way: at a corner,
    /// the normal of the corner's edge where the body touches it, so a slide along it goes
    /// around the corner. ([`CollisionWorld::push_out`] at the end of the move gives the
    /// normal of the deepest overlap there, which, past a jamb's edge, is the face across
    /// the way ahead.)
    pub fn impact_normal(&self, base: Vec3, d: Vec3) -> Option<Vec3> {
        let pose = self.body_pose(base);
        let options = ShapeCastOptions {
            max_time_of_impact: 1.0,
            target_distance: 0.0,
            stop_at_penetration: true,
            compute_impact_geometry_on_penetration: true,
        };
        let hit = query::cast_shapes(
            &pose,
            v(d),
            &self.body,
            &Pose::IDENTITY,
            Vector::ZERO,
            &self.mesh,
            options,
        )
        .ok()??;
        Vec3::new(-hit.normal1.x, 0.0, -hit.normal1.z).try_normalize()
    }

    /// True when a ball of `radius` at `center` touches the scene.
    pub fn probe(&self, center: Vec3, radius: f32) -> bool {
        let pose = Pose::from_translation(v(center));
        query::intersection_test(&pose, &Ball::new(radius), &Pose::IDENTITY, &self.mesh)
            .is_ok_and(|r| r.intersecting)
    }
}
