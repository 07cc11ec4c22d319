//! `thicket`: a scene whose cost per ray jumps, for the ray budget in milliseconds
//! (`rates.budget_ms`) to follow.
//!
//! The camera first frames an empty corner (floor and two walls: a ray meets one or two large
//! triangles), then cuts at [`THICKET_CUT_FRAME`] to a thicket of 9216 thin blades (110 592
//! triangles in a 5 m square), where an AO or shadow ray passes many boxes of the BVH and many
//! blades before it hits or leaves. Nothing moves but the camera, so the step in cost is the
//! scene's only change.

use crate::animation::{CameraPath, Light, Trajectory};
use crate::mesh::Mesh;
use crate::scene::Scene;
use crate::shapes::cuboid;
use vrrt_core::glam::{Affine3A, Vec3};
use vrrt_core::kernels::raygen::AreaLight;
use vrrt_core::sampling::rand;
use vrrt_core::sequence::pcg_hash;

/// Frame of the camera cut from the empty corner to the thicket.
pub const THICKET_CUT_FRAME: u32 = 48;
/// Blades along each side of the thicket.
const BLADES: u32 = 96;

/// The `description` of [`thicket`].
pub const THICKET_DESCRIPTION: &str =
    "a room with a thicket of 9216 thin blades in one half, 96 frames: the camera frames the \
     empty half and cuts to the thicket at frame 48, where a ray costs several times more (the \
     step a ray budget in milliseconds must follow); nothing else moves";

/// The scene.
pub fn thicket() -> Scene {
    let mut s = Scene::new("thicket", THICKET_DESCRIPTION);
    s.fps = 30.0;
    s.frame_count = 96;
    crate::builtin::add_floor_and_walls(&mut s);
    s.add_object(
        "thicket",
        blades(),
        Trajectory::Static(Affine3A::IDENTITY),
        0.6,
    );
    s.add_light(Light {
        base: AreaLight::new(Vec3::new(-0.5, 3.8, -2.5), Vec3::Z * 1.0, Vec3::X * 1.0),
        motion: Trajectory::Static(Affine3A::IDENTITY),
    });
    let key = crate::builtin::room_camera_key;
    let cut = THICKET_CUT_FRAME as f32 / s.fps;
    let (corner, corner_target) = (Vec3::new(-2.5, 1.6, 1.0), Vec3::new(-3.5, 1.4, -5.0));
    let (above, into) = (Vec3::new(3.0, 1.0, 1.2), Vec3::new(3.0, 0.0, -1.5));
    s.camera = CameraPath {
        keys: vec![
            key(0.0, corner, corner_target, false),
            key(cut - 1e-3, corner, corner_target, false),
            key(cut, above, into, true),
            key(s.frame_count as f32 / s.fps, above, into, false),
        ],
    };
    s
}

/// Thin upright boxes, 2–3 cm square and 25–60 cm tall, jittered on a 96 × 96 grid over
/// `x ∈ [0.5, 5.5]`, `z ∈ [−4.5, 0.5]` (deterministic: the pixel-sequence hash).
fn blades() -> Mesh {
    let mut m = Mesh::default();
    let cell = 5.0 / BLADES as f32;
    for j in 0..BLADES {
        for i in 0..BLADES {
            let seed = pcg_hash(j * BLADES + i);
            let x = 0.5 + (i as f32 + rand(seed, 0, 0)) * cell;
            let z = -4.5 + (j as f32 + rand(seed, 0, 1)) * cell;
            let half = 0.01 + 0.005 * rand(seed, 0, 2);
            let height = 0.25 + 0.35 * rand(seed, 0, 3);
            m.append(&cuboid(
                Vec3::new(x - half, 0.0, z - half),
                Vec3::new(x + half, height, z + half),
            ));
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_thicket_is_dense_and_only_the_camera_moves() {
        let s = thicket();
        let f = s.frame(0);
        assert!(f.geometry.triangles.len() > 110_000);
        assert!(s.geometry_is_static());
        assert!(s.frame(THICKET_CUT_FRAME).camera_cut);
        assert!(!s.frame(THICKET_CUT_FRAME - 1).camera_cut);
        let origin = |i: u32| {
            let c = s.frame(i).camera;
            Vec3::new(c.origin_x, c.origin_y, c.origin_z)
        };
        assert!(origin(10).distance(origin(40)) < 1e-5);
        assert!(origin(50).distance(origin(90)) < 1e-5);
    }
}
