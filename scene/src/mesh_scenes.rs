//! The built-in scenes on real meshes (`bunny`, `dragon`), animated like `room` (120 frames at
//! 30 fps) with the events a denoiser must react to: moving lights sweeping shadows, an orbiting
//! camera, a moving object casting contact shadows on a large scanned mesh, and camera cuts.
//!
//! They take the mesh as an argument: [`crate::builtin::builtin`] passes the one `vrrt fetch`
//! cached, tests pass a small procedural stand-in (everything is placed from the mesh's bounds
//! and vertices, so any mesh gives a valid scene).

use crate::animation::{CameraKey, CameraPath, Light, RigidKey, Trajectory};
use crate::mesh::Mesh;
use crate::mesh_cache::CachedMesh;
use crate::scene::Scene;
use crate::shapes::{quad, uv_sphere};
use vrrt_core::glam::{Affine3A, Quat, Vec3};
use vrrt_core::kernels::raygen::AreaLight;
use vrrt_core::math;

/// `bunny`'s registry description.
pub const BUNNY_DESCRIPTION: &str =
    "Stanford bunny on a glossy floor in a wall corner, 120 frames: area light circling overhead \
     (shadows sweep round), camera orbiting, camera cut at frame 72 to a low close-up (needs \
     `vrrt fetch`)";

/// `dragon`'s registry description.
pub const DRAGON_DESCRIPTION: &str =
    "Stanford dragon (48k triangles) on a floor, 120 frames: a sphere rests still, then from \
     frame 30 skims over the dragon's back and round its head (contact shadows on the scan), the \
     light slides across in frames 54-78, camera cut at frame 84 to the head (needs `vrrt fetch`)";

/// Frame of the camera cut in `bunny`.
pub const BUNNY_CUT_FRAME: u32 = 72;
/// Frame of the camera cut in `dragon`.
pub const DRAGON_CUT_FRAME: u32 = 84;
/// Frame at which `dragon`'s sphere starts moving (it is still before).
pub const DRAGON_SPHERE_START_FRAME: u32 = 30;
/// Radius of `dragon`'s moving sphere, metres.
pub const DRAGON_SPHERE_RADIUS: f32 = 0.28;
/// Gap between `dragon`'s sphere and the highest point of the dragon under it, metres: close
/// enough for a contact shadow, never touching.
pub const DRAGON_SPHERE_GAP: f32 = 0.06;

/// Instance ids of the scenes' named objects (stable, for tests and overlays).
pub mod ids {
    /// The bunny in `bunny`.
    pub const BUNNY: u32 = 0;
    /// The sphere moving over the dragon in `dragon`.
    pub const DRAGON_SPHERE: u32 = 0;
    /// The dragon in `dragon`.
    pub const DRAGON: u32 = 1;
}

/// The scene built on `mesh` for the cached mesh `which`.
pub fn build(which: CachedMesh, mesh: &Mesh) -> Scene {
    match which {
        CachedMesh::Bunny => bunny(mesh),
        CachedMesh::Dragon => dragon(mesh),
    }
}

/// The transform that scales `mesh` so its largest extent is `size`, centres it over the origin
/// in x and z and rests it on the floor (y = 0).
pub fn on_floor(mesh: &Mesh, size: f32) -> Affine3A {
    let (lo, hi) = mesh.bounds();
    let scale = size / (hi - lo).max_element().max(1e-12);
    let centre = (lo + hi) * 0.5;
    Affine3A::from_translation(Vec3::new(0.0, (hi.y - lo.y) * 0.5 * scale, 0.0))
        * Affine3A::from_scale(Vec3::splat(scale))
        * Affine3A::from_translation(-centre)
}

/// `bunny`: the mesh (1.4 m) on a glossy floor in the corner of two walls, under a 1 m light
/// circling overhead; the camera orbits a quarter turn, then cuts to a low close-up orbiting back.
pub fn bunny(mesh: &Mesh) -> Scene {
    let mut s = Scene::new("bunny", BUNNY_DESCRIPTION);
    s.fps = 30.0;
    s.frame_count = 120;
    s.add_object(
        "bunny",
        mesh.clone(),
        Trajectory::Static(on_floor(mesh, 1.4)),
        1.0,
    );
    add_floor_and_walls(&mut s, 6.0, 3.5, -3.0, Some(-3.5));
    // Spin turns the light about the world's vertical axis: its shadows sweep round the bunny.
    s.add_light(Light {
        base: AreaLight::new(Vec3::new(1.2, 3.0, -0.5), Vec3::Z, Vec3::X),
        motion: Trajectory::Spin {
            base: Affine3A::IDENTITY,
            turns_per_second: 0.2,
        },
    });
    let cut = BUNNY_CUT_FRAME as f32 / s.fps;
    let target = Vec3::new(0.0, 0.55, 0.0);
    let mut keys = orbit(
        (0.0, -0.06),
        (cut - 1e-3, 0.17),
        (2.8, 1.4, 0.9),
        target,
        false,
    );
    keys.extend(orbit(
        (cut, 0.30),
        (4.0, 0.22),
        (2.0, 0.45, 0.8),
        Vec3::new(0.0, 0.45, 0.0),
        true,
    ));
    s.camera = CameraPath { keys };
    s
}

/// `dragon`: the mesh (3.2 m long) on a floor before a wall. A sphere rests on the floor by its
/// +x end, then skims [`DRAGON_SPHERE_GAP`] above the highest point under it from the +x end to
/// the −x end and comes down round it; the light overhead slides across; the camera dollies,
/// then cuts to a close view of the −x end.
pub fn dragon(mesh: &Mesh) -> Scene {
    let mut s = Scene::new("dragon", DRAGON_DESCRIPTION);
    s.fps = 30.0;
    s.frame_count = 120;
    let place = on_floor(mesh, 3.2);
    let placed = mesh.transformed(&place);
    let (lo, hi) = placed.bounds();
    let r = DRAGON_SPHERE_RADIUS;
    s.add_object(
        "sphere",
        uv_sphere(Vec3::ZERO, r, 24, 48),
        Trajectory::Keyframes(sphere_path(&placed.positions, lo, hi, s.fps)),
        0.2,
    );
    s.add_object("dragon", mesh.clone(), Trajectory::Static(place), 1.0);
    add_floor_and_walls(&mut s, 9.0, 5.0, lo.z - 1.5, None);

    // The light holds, slides 2 m across (the dragon's shadow swings), then holds again.
    let slide = |time: f32, x: f32| RigidKey {
        time,
        translation: Vec3::new(x, 0.0, 0.0),
        rotation: Quat::IDENTITY,
    };
    let top = hi.y + 2.6;
    s.add_light(Light {
        base: AreaLight::new(Vec3::new(-0.6, top, -0.6), Vec3::Z * 1.2, Vec3::X * 1.2),
        motion: Trajectory::Keyframes(vec![slide(54.0 / s.fps, 0.8), slide(78.0 / s.fps, -1.2)]),
    });

    let cut = DRAGON_CUT_FRAME as f32 / s.fps;
    let h = hi.y - lo.y;
    let key = |time, position, target, cut| CameraKey {
        time,
        position,
        target,
        fov_y: 0.9,
        cut,
    };
    s.camera = CameraPath {
        keys: vec![
            key(
                0.0,
                Vec3::new(-0.8, h + 0.8, hi.z + 3.6),
                Vec3::new(0.0, 0.45 * h, 0.0),
                false,
            ),
            key(
                cut - 1e-3,
                Vec3::new(0.7, h + 0.5, hi.z + 3.2),
                Vec3::new(0.2, 0.45 * h, 0.0),
                false,
            ),
            key(
                cut,
                Vec3::new(lo.x - 1.6, h + 0.6, hi.z + 1.9),
                Vec3::new(lo.x + 0.6, 0.7 * h, 0.0),
                true,
            ),
            key(
                4.0,
                Vec3::new(lo.x - 1.2, h + 0.3, hi.z + 2.3),
                Vec3::new(lo.x + 0.5, 0.6 * h, 0.0),
                false,
            ),
        ],
    };
    s
}

/// The dragon's sphere: still on the floor by the +x end until [`DRAGON_SPHERE_START_FRAME`],
/// then up, across nine stations along x from the +x end to the −x end, each over the highest
/// vertex within reach, out past the −x end and down to the floor in front of it.
///
/// A station's height clears every vertex within one station spacing plus the radius of it in
/// x, so the moves between stations (linear in x and y) pass above every vertex in reach; the
/// rise and the descent are vertical, beyond the mesh's x range, and the moves to and from
/// them level.
fn sphere_path(placed: &[Vec3], lo: Vec3, hi: Vec3, fps: f32) -> Vec<RigidKey> {
    const STATIONS: usize = 9;
    let r = DRAGON_SPHERE_RADIUS;
    let at = |time: f32, translation: Vec3| RigidKey {
        time,
        translation,
        rotation: Quat::IDENTITY,
    };
    let (x0, x1) = (hi.x - 0.15, lo.x + 0.15);
    let spacing = (x0 - x1).abs() / (STATIONS - 1) as f32;
    let stations: Vec<Vec3> = (0..STATIONS)
        .map(|i| {
            let x = x0 + (x1 - x0) * i as f32 / (STATIONS - 1) as f32;
            // The highest vertex in reach, or the floor (a stand-in may leave gaps).
            let top = placed
                .iter()
                .filter(|p| (p.x - x).abs() <= spacing + r)
                .max_by(|a, b| a.y.total_cmp(&b.y))
                .map_or(Vec3::new(x, 0.0, 0.0), |p| Vec3::new(x, p.y, p.z));
            top + Vec3::Y * (r + DRAGON_SPHERE_GAP)
        })
        .collect();
    let start = DRAGON_SPHERE_START_FRAME as f32 / fps;
    let rest = Vec3::new(hi.x + r + 0.3, r, hi.z + 0.4);
    let (first, last) = (stations[0], stations[STATIONS - 1]);
    let out = lo.x - r - 0.3;
    // Keyframes hold the first key before its time: exactly still until `start`.
    let mut keys = vec![
        at(start, rest),
        at(start + 0.3, Vec3::new(rest.x, first.y, rest.z)),
    ];
    for (i, &p) in stations.iter().enumerate() {
        keys.push(at(start + 0.6 + 1.8 * i as f32 / (STATIONS - 1) as f32, p));
    }
    keys.push(at(start + 2.7, Vec3::new(out, last.y, hi.z + 0.4)));
    keys.push(at(start + 3.0, Vec3::new(out, r, hi.z + 0.4)));
    keys
}

/// A floor `2·half` metres square centred on the origin (glossy), a back wall at `z = back` and,
/// if given, a left wall at `x = left` (both `height` metres high, diffuse).
fn add_floor_and_walls(s: &mut Scene, half: f32, height: f32, back: f32, left: Option<f32>) {
    let fixed = Trajectory::Static(Affine3A::IDENTITY);
    s.add_object(
        "floor",
        quad(
            Vec3::new(-half, 0.0, half),
            Vec3::X * 2.0 * half,
            Vec3::Z * -2.0 * half,
        ),
        fixed.clone(),
        0.3,
    );
    s.add_object(
        "back wall",
        quad(
            Vec3::new(-half, 0.0, back),
            Vec3::X * 2.0 * half,
            Vec3::Y * height,
        ),
        fixed.clone(),
        1.0,
    );
    if let Some(x) = left {
        s.add_object(
            "left wall",
            quad(
                Vec3::new(x, 0.0, half),
                Vec3::Z * -2.0 * half,
                Vec3::Y * height,
            ),
            fixed,
            1.0,
        );
    }
}

/// Camera keys on a circle about `target` (linear between keys 0.2 s apart, close enough to
/// the arc): from `(time, angle)` to `(time, angle)`, angles in turns from +z towards +x, at
/// `(radius, height above y = 0, fov_y)`; the first key is a cut if `cut`.
fn orbit(
    from: (f32, f32),
    to: (f32, f32),
    (radius, height, fov_y): (f32, f32, f32),
    target: Vec3,
    cut: bool,
) -> Vec<CameraKey> {
    let steps = (((to.0 - from.0) / 0.2).ceil() as u32).max(1);
    (0..=steps)
        .map(|i| {
            let s = i as f32 / steps as f32;
            let (sin, cos) = math::sin_cos_turns(from.1 + (to.1 - from.1) * s);
            CameraKey {
                time: from.0 + (to.0 - from.0) * s,
                position: Vec3::new(target.x + radius * sin, height, target.z + radius * cos),
                target,
                fov_y,
                cut: cut && i == 0,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dragon-like stand-in: an ellipsoid 2 : 1.4 : 0.9 (2,208 triangles).
    fn stand_in() -> Mesh {
        uv_sphere(Vec3::ZERO, 1.0, 24, 48)
            .transformed(&Affine3A::from_scale(Vec3::new(2.0, 1.4, 0.9)))
    }

    #[test]
    fn bunny_orbits_cuts_and_sweeps_its_light() {
        let s = bunny(&stand_in());
        s.validate().unwrap();
        assert!(s.geometry_is_static() && !s.is_still());
        let cuts: Vec<u32> = (0..s.frame_count)
            .filter(|&i| s.frame(i).camera_cut)
            .collect();
        assert_eq!(cuts, [BUNNY_CUT_FRAME]);
        // The camera moves every frame and keeps its distance to the target (an orbit).
        for i in 1..s.frame_count {
            let (a, b) = (s.camera.key_at(s.time(i - 1)), s.camera.key_at(s.time(i)));
            assert_ne!(a.position, b.position, "frame {i}");
            if i != BUNNY_CUT_FRAME {
                let d = |k: CameraKey| (k.position - k.target).length();
                assert!((d(a) - d(b)).abs() < 0.05, "frame {i}");
            }
        }
        assert_ne!(s.frame(10).lights[0], s.frame(11).lights[0]);
        // The bunny rests on the floor, 1.4 m across.
        let bunny = &s.instances[ids::BUNNY as usize];
        let (lo, hi) = s.meshes[bunny.mesh]
            .transformed(&bunny.motion.at(0.0))
            .bounds();
        assert!(lo.y.abs() < 1e-5 && ((hi - lo).max_element() - 1.4).abs() < 1e-4);
    }

    #[test]
    fn dragon_sphere_waits_then_skims_without_touching() {
        let s = dragon(&stand_in());
        s.validate().unwrap();
        let cuts: Vec<u32> = (0..s.frame_count)
            .filter(|&i| s.frame(i).camera_cut)
            .collect();
        assert_eq!(cuts, [DRAGON_CUT_FRAME]);
        let sphere = &s.instances[ids::DRAGON_SPHERE as usize].motion;
        let centre = |i: u32| Vec3::from(sphere.at(s.time(i)).translation);
        for i in 1..=DRAGON_SPHERE_START_FRAME {
            assert_eq!(centre(i), centre(0), "still until frame {i}");
        }
        assert_ne!(centre(DRAGON_SPHERE_START_FRAME + 1), centre(0));
        // The light holds, then moves.
        let light = |i: u32| s.frame(i).lights[0];
        assert_eq!(light(0), light(50));
        assert_ne!(light(60), light(61));

        // Over the dragon, the sphere clears every vertex under it and comes close.
        let dragon = &s.instances[ids::DRAGON as usize];
        let placed = s.meshes[dragon.mesh].transformed(&dragon.motion.at(0.0));
        let r = DRAGON_SPHERE_RADIUS;
        let mut closest = f32::MAX;
        for i in 0..s.frame_count {
            let c = centre(i);
            let under = placed
                .positions
                .iter()
                .filter(|p| (p.x - c.x).powi(2) + (p.z - c.z).powi(2) < r * r)
                .map(|p| p.y)
                .fold(f32::MIN, f32::max);
            if under > f32::MIN {
                let gap = c.y - r - under;
                assert!(
                    gap > 0.0,
                    "frame {i}: the sphere dips {gap} m into the mesh"
                );
                closest = closest.min(gap);
            }
        }
        assert!(closest < 0.2, "the sphere never comes close: {closest} m");
    }
}
