//! Motion vectors and ray generation on the built-in scenes, through the same kernel functions the
//! GPU runs.

use vrrt_core::glam::Vec3;
use vrrt_core::kernels::gbuffer::surface_at;
use vrrt_core::kernels::raygen::{ao_pixel, shadow_pixel, AreaLight, NO_BLOCKER};
use vrrt_core::sampling::{pixel_seed, Stream};
use vrrt_core::surface::{Surface, NO_INSTANCE};
use vrrt_scene::builtin::{builtin, room_ids};
use vrrt_scene::{FrameGeometry, Scene};

const W: u32 = 192;
const H: u32 = 128;

fn gbuffer(f: &FrameGeometry) -> Vec<Surface> {
    let p = f.gbuffer_params(W, H);
    let g = &f.geometry;
    (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| surface_at(x, y, &p, &g.nodes, &g.triangles, &g.normals, &f.instances))
        .collect()
}

#[test]
fn static_scene_has_identity_motion() {
    let scene = builtin("room_static").unwrap();
    let f = scene.frame(7);
    let surfaces = gbuffer(&f);
    let mut hits = 0;
    for (i, s) in surfaces.iter().enumerate() {
        let (x, y) = ((i as u32 % W) as f32, (i as u32 / W) as f32);
        assert!(
            (s.prev_x - x).abs() < 2e-3 && (s.prev_y - y).abs() < 2e-3,
            "pixel {x},{y}: {s:?}"
        );
        if s.instance != NO_INSTANCE {
            hits += 1;
            assert_eq!(s.prev_position(), s.position());
            assert!(s.depth > 0.0);
            let g = s.geometric_normal();
            assert!((g.length() - 1.0).abs() < 1e-5 && (s.normal().length() - 1.0).abs() < 1e-4);
            // Geometric normal faces the camera.
            assert!(g.dot(f.camera.origin() - s.position()) > 0.0);
        }
    }
    assert!(
        hits > surfaces.len() / 2,
        "most pixels see geometry ({hits})"
    );
    assert!(hits < surfaces.len(), "some sky is visible");
}

/// The pixel a moving point reprojects to last frame shows the same object at the predicted spot.
#[test]
fn moving_instances_reproject_onto_themselves() {
    let scene: Scene = builtin("room").unwrap();
    for (frame, instance) in [
        (20, room_ids::CROSSING_SPHERE),
        (40, room_ids::SLIDING_BOX),
        (70, room_ids::SLIDING_BOX),
    ] {
        let cur = scene.frame(frame);
        let prev = scene.frame(frame - 1);
        let (sc, sp) = (gbuffer(&cur), gbuffer(&prev));
        let mut checked = 0;
        let mut moved = 0.0f32;
        for (i, s) in sc.iter().enumerate() {
            if s.instance != instance {
                continue;
            }
            let (x, y) = ((i as u32 % W) as f32, (i as u32 / W) as f32);
            // Expected previous position: the instance's transform at t-1 applied to its
            // object-space point.
            let inst = &scene.instances[instance as usize];
            let object = inst
                .motion
                .at(cur.time)
                .inverse()
                .transform_point3(s.position());
            let want = inst.motion.at(prev.time).transform_point3(object);
            assert!(
                (s.prev_position() - want).length() < 1e-4,
                "frame {frame} pixel {x},{y}"
            );
            let (px, py) = prev.camera.project_point(want, W, H);
            assert!((px - s.prev_x).abs() < 1e-3 && (py - s.prev_y).abs() < 1e-3);
            moved = moved.max(((s.prev_x - x).powi(2) + (s.prev_y - y).powi(2)).sqrt());
            // Interior pixels: last frame's G-buffer at the reprojected pixel is the same object,
            // close to where we predicted.
            let (rx, ry) = (s.prev_x.round(), s.prev_y.round());
            if rx < 1.0 || ry < 1.0 || rx >= (W - 1) as f32 || ry >= (H - 1) as f32 {
                continue;
            }
            let q = sp[(ry as u32 * W + rx as u32) as usize];
            let interior = [(-1i32, 0i32), (1, 0), (0, -1), (0, 1)]
                .iter()
                .all(|(dx, dy)| {
                    let j = ((y as i32 + dy) as u32 * W + (x as i32 + dx) as u32) as usize;
                    (x as i32 + dx) >= 0
                        && (x as i32 + dx) < W as i32
                        && (y as i32 + dy) >= 0
                        && (y as i32 + dy) < H as i32
                        && sc[j].instance == instance
                });
            if interior && q.instance == instance {
                let footprint = 0.2 * q.depth.max(1.0);
                assert!(
                    (q.position() - want).length() < footprint,
                    "frame {frame}: {:?} vs {want}",
                    q.position()
                );
                checked += 1;
            }
        }
        assert!(
            checked > 5,
            "frame {frame}: too few pixels of instance {instance} checked ({checked})"
        );
        assert!(
            moved > 0.5,
            "frame {frame}: the instance should move on screen ({moved} px)"
        );
    }
}

#[test]
fn camera_motion_of_static_geometry() {
    // During the first shot the camera dollies: static points reproject to where the previous
    // camera saw them.
    let scene = builtin("room").unwrap();
    let (cur, prev) = (scene.frame(30), scene.frame(29));
    let sc = gbuffer(&cur);
    for s in sc
        .iter()
        .filter(|s| s.instance != NO_INSTANCE && s.instance > room_ids::CROSSING_SPHERE)
    {
        assert_eq!(s.prev_position(), s.position());
        let (px, py) = prev.camera.project_point(s.position(), W, H);
        assert!((px - s.prev_x).abs() < 1e-3 && (py - s.prev_y).abs() < 1e-3);
    }
}

#[test]
fn ao_and_shadow_conventions() {
    let scene = builtin("room_static").unwrap();
    let f = scene.frame(0);
    let g = &f.geometry;
    let surfaces = gbuffer(&f);
    let light = f.lights[0];
    let mut ao_sum = 0.0;
    let mut n = 0;
    for (i, s) in surfaces.iter().enumerate() {
        let (x, y) = (i as u32 % W, i as u32 / W);
        let seed = pixel_seed(x, y, 0);
        let a = ao_pixel(
            s,
            Stream::per_pixel(seed),
            5,
            8,
            1.0,
            &g.nodes,
            &g.triangles,
        );
        let b = ao_pixel(
            s,
            Stream::per_pixel(seed),
            5,
            8,
            1.0,
            &g.nodes,
            &g.triangles,
        );
        assert_eq!(a, b, "rays are pure functions of (seed, index, surface)");
        if s.instance == NO_INSTANCE {
            assert_eq!(a.rays, 0);
            continue;
        }
        assert_eq!(a.rays, 8);
        assert!(
            (0.0..=1.0).contains(&a.m1) && a.m1 == a.m2,
            "binary values: m2 = m1"
        );
        ao_sum += a.m1;
        n += 1;
        let sh = shadow_pixel(
            s,
            &light,
            Stream::per_pixel(seed),
            0,
            4,
            &g.nodes,
            &g.triangles,
        );
        assert!((0.0..=1.0).contains(&sh.0.m1));
    }
    let mean = ao_sum / n as f32;
    assert!(mean > 0.5 && mean < 0.999, "mean AO {mean}");
}

/// A bare floor: AO is exactly 1 and the light fully visible, whatever the seed.
#[test]
fn a_bare_floor_is_unoccluded_and_lit_from_above() {
    let mut floor = Scene::new("floor", "");
    floor.add_object(
        "floor",
        vrrt_scene::shapes::quad(Vec3::new(-5.0, 0.0, 5.0), Vec3::X * 10.0, Vec3::Z * -10.0),
        vrrt_scene::animation::Trajectory::fixed(Vec3::ZERO),
        1.0,
    );
    floor.camera =
        vrrt_scene::animation::CameraPath::fixed(Vec3::new(0.0, 2.0, 3.0), Vec3::ZERO, 1.0);
    let ff = floor.frame(0);
    let s = gbuffer(&ff)[(H / 2 * W + W / 2) as usize];
    assert!(s.instance == 0);
    let fg = &ff.geometry;
    let up = AreaLight::new(Vec3::new(-0.5, 3.0, -0.5), Vec3::X, Vec3::Z);
    let down = AreaLight::new(Vec3::new(-0.5, -3.0, -0.5), Vec3::X, Vec3::Z);
    for seed in 0..20 {
        assert_eq!(
            ao_pixel(
                &s,
                Stream::per_pixel(seed),
                0,
                16,
                10.0,
                &fg.nodes,
                &fg.triangles
            )
            .m1,
            1.0
        );
        assert_eq!(
            shadow_pixel(
                &s,
                &up,
                Stream::per_pixel(seed),
                0,
                16,
                &fg.nodes,
                &fg.triangles
            )
            .0
            .m1,
            1.0
        );
        // A light below the surface is never visible (ω·g ≤ 0), and its horizon is no
        // blocker: it records no penumbra, which would keep the filter from blurring the noise
        // where a curved surface turns from the light.
        let (below, record) = shadow_pixel(
            &s,
            &down,
            Stream::per_pixel(seed),
            0,
            16,
            &fg.nodes,
            &fg.triangles,
        );
        assert_eq!(below.m1, 0.0);
        assert_eq!(record, NO_BLOCKER);
    }
}
