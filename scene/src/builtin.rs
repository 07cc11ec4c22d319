//! Built-in scenes, designed to break denoisers, and a registry to list and pick them by name:
//! the procedural `room` and `thicket` ([`crate::thicket`]; embedded, no files) and the scenes on
//! meshes `vrrt fetch` downloads (`bunny`, `dragon`: [`crate::mesh_scenes`]).
//!
//! Y is up, units are metres, 30 fps.

use crate::animation::{CameraKey, CameraPath, Light, RigidKey, Trajectory};
use crate::error::SceneError;
use crate::mesh::Mesh;
use crate::mesh_cache::{self, CachedMesh};
use crate::mesh_scenes::{self, on_floor};
use crate::scene::Scene;
use crate::shapes::{cuboid, cylinder, quad, uv_sphere};
use vrrt_core::glam::{Affine3A, Quat, Vec3};
use vrrt_core::kernels::raygen::AreaLight;

/// A built-in scene's registry entry.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct BuiltinInfo {
    /// Name to pass to [`builtin`].
    pub name: &'static str,
    /// One-line description (for `--list`).
    pub description: &'static str,
    /// The downloaded mesh it is built on (`vrrt fetch`), if any.
    pub mesh: Option<CachedMesh>,
}

/// Every built-in scene.
pub const BUILTINS: &[BuiltinInfo] = &[
    BuiltinInfo {
        name: "room",
        description: "open-top room, 120 frames: box sliding along a wall (contact-shadow ghosting), \
                      sphere crossing in front of the camera (disocclusion), thin railing and poles, \
                      moving area light, camera cut at frame 60",
        mesh: None,
    },
    BuiltinInfo {
        name: "room_static",
        description: "the room at frame 0 with nothing moving (camera, objects, light): convergence \
                      tests; still, so it runs any number of frames",
        mesh: None,
    },
    BuiltinInfo {
        name: "thicket",
        description: crate::thicket::THICKET_DESCRIPTION,
        mesh: None,
    },
    BuiltinInfo {
        name: "bunny",
        description: mesh_scenes::BUNNY_DESCRIPTION,
        mesh: Some(CachedMesh::Bunny),
    },
    BuiltinInfo {
        name: "dragon",
        description: mesh_scenes::DRAGON_DESCRIPTION,
        mesh: Some(CachedMesh::Dragon),
    },
];

/// The built-in scene called `name`. A scene on a downloaded mesh loads it from the mesh cache
/// ([`mesh_cache::load_default`]); [`SceneError::MeshNotFetched`] says to run `vrrt fetch`.
pub fn builtin(name: &str) -> Result<Scene, SceneError> {
    if let Some(which) = CachedMesh::for_scene(name) {
        let mesh = mesh_cache::load_default(which)?;
        return Ok(mesh_scenes::build(which, &mesh));
    }
    match name {
        "room" => Ok(room(true)),
        "room_static" => Ok(room(false)),
        "thicket" => Ok(crate::thicket::thicket()),
        _ => Err(SceneError::UnknownScene {
            name: name.to_string(),
            known: BUILTINS
                .iter()
                .map(|b| b.name)
                .collect::<Vec<_>>()
                .join(", "),
        }),
    }
}

/// Frame of the camera cut in `room`.
pub const ROOM_CUT_FRAME: u32 = 60;

/// Instance ids of the room's moving objects (stable, for tests and overlays).
pub mod room_ids {
    /// The box sliding along the back wall.
    pub const SLIDING_BOX: u32 = 0;
    /// The sphere crossing in front of the camera.
    pub const CROSSING_SPHERE: u32 = 1;
}

fn room(animated: bool) -> Scene {
    let (name, info) = if animated {
        ("room", &BUILTINS[0])
    } else {
        ("room_static", &BUILTINS[1])
    };
    let mut s = Scene::new(name, info.description);
    s.fps = 30.0;
    s.frame_count = if animated { 120 } else { 64 };
    add_room_movers(&mut s, animated);
    add_room_fixtures(&mut s);
    // A 1.2 m square light near the top, facing down, sweeping over the room.
    let light = AreaLight::new(Vec3::new(-0.6, 3.8, -1.8), Vec3::Z * 1.2, Vec3::X * 1.2);
    let sweep = Trajectory::Oscillate {
        base: Affine3A::IDENTITY,
        amplitude: Vec3::new(2.5, 0.0, 0.0),
        period: 6.0,
        phase: 0.0,
    };
    s.add_light(Light {
        base: light,
        motion: freeze(animated, sweep),
    });

    s.camera = room_camera(animated, s.fps);
    s
}

/// `m`, or its pose at time 0 for the static room.
fn freeze(animated: bool, m: Trajectory) -> Trajectory {
    if animated {
        m
    } else {
        Trajectory::Static(m.at(0.0))
    }
}

/// The room's moving objects, added first so their ids are fixed (see `room_ids`).
fn add_room_movers(s: &mut Scene, animated: bool) {
    // Moving objects first, so their ids are fixed (see `room_ids`).
    let box_size = 0.8;
    let sliding = Trajectory::Oscillate {
        base: Affine3A::from_translation(Vec3::new(0.0, 0.0, -5.0 + 0.12 + box_size * 0.5)),
        amplitude: Vec3::new(2.2, 0.0, 0.0),
        period: 4.0,
        phase: 0.0,
    };
    let half = Vec3::new(box_size * 0.5, 0.0, box_size * 0.5);
    s.add_object(
        "sliding box",
        cuboid(-half, half + Vec3::Y * box_size),
        freeze(animated, sliding),
        0.4,
    );
    let crossing = Trajectory::Keyframes(vec![
        RigidKey {
            time: 0.3,
            translation: Vec3::new(-6.5, 1.3, 2.6),
            rotation: Quat::IDENTITY,
        },
        RigidKey {
            time: 1.9,
            translation: Vec3::new(6.5, 1.3, 2.6),
            rotation: Quat::IDENTITY,
        },
        RigidKey {
            time: 2.4,
            translation: Vec3::new(4.0, 1.0, 1.0),
            rotation: Quat::IDENTITY,
        },
        RigidKey {
            time: 3.8,
            translation: Vec3::new(-5.0, 1.0, 1.0),
            rotation: Quat::IDENTITY,
        },
    ]);
    s.add_object(
        "crossing sphere",
        uv_sphere(Vec3::ZERO, 0.6, 24, 48),
        freeze(animated, crossing),
        0.2,
    );
}

/// The room's static geometry: floor, three walls (open front and top: sky shows above the
/// walls), pillars, a railing of thin poles and a resting sphere.
fn add_room_fixtures(s: &mut Scene) {
    let fixed = Trajectory::Static(Affine3A::IDENTITY);
    add_floor_and_walls(s);
    s.add_object(
        "right wall",
        quad(Vec3::new(6.0, 0.0, -5.0), Vec3::Z * 11.0, Vec3::Y * 3.5),
        fixed.clone(),
        1.0,
    );
    let mut pillars = Mesh::default();
    for (x, z) in [(-3.5, -3.0), (3.5, -3.0), (-3.5, 1.0), (3.5, 1.0)] {
        pillars.append(&cuboid(
            Vec3::new(x - 0.25, 0.0, z - 0.25),
            Vec3::new(x + 0.25, 3.2, z + 0.25),
        ));
    }
    s.add_object("pillars", pillars, fixed.clone(), 1.0);
    // Thin geometry: a railing (bar + poles a few pixels wide or less).
    let mut railing = cylinder(
        Vec3::new(-4.5, 1.0, -0.5),
        Vec3::new(4.5, 1.0, -0.5),
        0.025,
        10,
    );
    for i in 0..=18 {
        let x = -4.5 + i as f32 * 0.5;
        railing.append(&cylinder(
            Vec3::new(x, 0.0, -0.5),
            Vec3::new(x, 1.0, -0.5),
            0.015,
            8,
        ));
    }
    s.add_object("railing", railing, fixed.clone(), 1.0);
    s.add_object(
        "resting sphere",
        uv_sphere(Vec3::new(-1.8, 0.5, -2.5), 0.5, 24, 48),
        fixed,
        1.0,
    );
}

/// The room's camera: a slow push, a cut at `ROOM_CUT_FRAME`, then a pan; fixed for the static
/// room.
fn room_camera(animated: bool, fps: f32) -> CameraPath {
    let key = room_camera_key;
    let cut_time = ROOM_CUT_FRAME as f32 / fps;
    if animated {
        CameraPath {
            keys: vec![
                key(
                    0.0,
                    Vec3::new(0.0, 2.2, 7.5),
                    Vec3::new(0.0, 1.0, -3.0),
                    false,
                ),
                key(
                    cut_time - 1e-3,
                    Vec3::new(0.8, 2.0, 6.0),
                    Vec3::new(0.2, 1.0, -3.0),
                    false,
                ),
                key(
                    cut_time,
                    Vec3::new(5.0, 1.6, 3.5),
                    Vec3::new(-2.0, 0.6, -4.0),
                    true,
                ),
                key(
                    4.0,
                    Vec3::new(4.2, 1.9, 4.2),
                    Vec3::new(-2.5, 0.6, -3.5),
                    false,
                ),
            ],
        }
    } else {
        CameraPath::fixed(Vec3::new(0.0, 2.2, 7.5), Vec3::new(0.0, 1.0, -3.0), 1.0)
    }
}

/// A camera key of the room's lens (1 radian vertical field of view).
pub(crate) fn room_camera_key(time: f32, position: Vec3, target: Vec3, cut: bool) -> CameraKey {
    CameraKey {
        time,
        position,
        target,
        fov_y: 1.0,
        cut,
    }
}

/// The room's floor (12 × 11 m), back wall and left wall (3.5 m high), static.
pub(crate) fn add_floor_and_walls(s: &mut Scene) {
    let fixed = Trajectory::Static(Affine3A::IDENTITY);
    s.add_object(
        "floor",
        quad(Vec3::new(-6.0, 0.0, 6.0), Vec3::X * 12.0, Vec3::Z * -11.0),
        fixed.clone(),
        0.3,
    );
    s.add_object(
        "back wall",
        quad(Vec3::new(-6.0, 0.0, -5.0), Vec3::X * 12.0, Vec3::Y * 3.5),
        fixed.clone(),
        1.0,
    );
    s.add_object(
        "left wall",
        quad(Vec3::new(-6.0, 0.0, 6.0), Vec3::Z * -11.0, Vec3::Y * 3.5),
        fixed,
        1.0,
    );
}

/// A static scene showing `mesh` (scaled to about 2 m, resting on a floor, in front of a wall)
/// under one area light, with a camera framing it: for loaded meshes.
pub fn showcase(name: &str, mesh: &Mesh) -> Scene {
    let mut s = Scene::new(name, "a loaded mesh on a floor in front of a wall");
    s.frame_count = 64;
    s.add_object(
        name,
        mesh.clone(),
        Trajectory::Static(on_floor(mesh, 2.0)),
        1.0,
    );
    let fixed = Trajectory::Static(Affine3A::IDENTITY);
    s.add_object(
        "floor",
        quad(Vec3::new(-5.0, 0.0, 5.0), Vec3::X * 10.0, Vec3::Z * -7.0),
        fixed.clone(),
        0.3,
    );
    s.add_object(
        "wall",
        quad(Vec3::new(-5.0, 0.0, -2.0), Vec3::X * 10.0, Vec3::Y * 4.0),
        fixed,
        1.0,
    );
    s.add_light(Light {
        base: AreaLight::new(Vec3::new(0.5, 3.5, -0.5), Vec3::Z * 1.0, Vec3::X * 1.0),
        motion: Trajectory::Static(Affine3A::IDENTITY),
    });
    s.camera = CameraPath::fixed(Vec3::new(0.8, 1.6, 4.0), Vec3::new(0.0, 0.9, 0.0), 0.9);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registry_builds_every_scene() {
        // Scenes on downloaded meshes are built on a stand-in (no network in tests).
        let stand_in = uv_sphere(Vec3::ZERO, 1.0, 24, 48);
        for b in BUILTINS {
            let s = match b.mesh {
                Some(which) => mesh_scenes::build(which, &stand_in),
                None => builtin(b.name).unwrap(),
            };
            assert_eq!(s.name, b.name);
            assert_eq!(s.description, b.description);
            let f = s.frame(0);
            assert!(f.geometry.triangles.len() > 1000);
            assert_eq!(f.lights.len(), 1);
        }
        let e = builtin("nope").unwrap_err().to_string();
        assert!(e.contains("room, room_static"), "{e}");
    }

    #[test]
    fn room_has_a_cut_and_moving_parts() {
        let s = builtin("room").unwrap();
        assert!(!s.geometry_is_static());
        assert!(s.frame(ROOM_CUT_FRAME).camera_cut);
        assert!(!s.frame(ROOM_CUT_FRAME - 1).camera_cut && !s.frame(ROOM_CUT_FRAME + 1).camera_cut);
        assert_ne!(s.frame(10).lights[0], s.frame(11).lights[0]);
        let st = builtin("room_static").unwrap();
        assert!(st.geometry_is_static() && st.camera.is_static());
        assert_eq!(st.frame(3).lights[0], st.frame(40).lights[0]);
        // Still: any number of frames, all the same; the animated room stops at its length.
        assert!(st.is_still() && !s.is_still());
        assert_eq!(st.frames_available(), u32::MAX);
        assert_eq!(s.frames_available(), s.frame_count);
        assert_eq!(st.frame(500).camera, st.frame(0).camera);
    }
}
