//! Scenes that cannot give a defined image are refused by name (`Scene::validate`, which the
//! `vrrt` command runs on every scene it loads); a camera inside geometry is valid and renders a
//! defined, finite image — never a silent blank.

use vrrt_core::glam::{Affine3A, Vec3};
use vrrt_core::settings::Settings;
use vrrt_cpu::CpuExecutor;
use vrrt_scene::animation::{CameraPath, Trajectory};
use vrrt_scene::builtin::{builtin, BUILTINS};
use vrrt_scene::render::{Readback, Renderer, Signal};
use vrrt_scene::shapes::cuboid;
use vrrt_scene::{Scene, SceneError};

fn boxed(camera: CameraPath) -> Scene {
    let mut s = Scene::new("boxed", "a closed box");
    s.add_object(
        "box",
        cuboid(Vec3::splat(-2.0), Vec3::splat(2.0)),
        Trajectory::fixed(Vec3::ZERO),
        1.0,
    );
    s.camera = camera;
    s
}

fn refused(s: &Scene, needle: &str) {
    match s.validate() {
        Err(e @ SceneError::InvalidScene { .. }) => {
            let m = e.to_string();
            assert!(m.contains(needle), "{m}");
            println!("refused: {m}");
        }
        other => panic!("expected an invalid scene ({needle}), got {other:?}"),
    }
}

#[test]
fn every_builtin_scene_is_valid() {
    // Scenes on downloaded meshes are checked on a stand-in (and on the real mesh when
    // `vrrt fetch` has cached it).
    let stand_in = vrrt_scene::shapes::uv_sphere(Vec3::ZERO, 1.0, 12, 24);
    for b in BUILTINS {
        match (builtin(b.name), b.mesh) {
            (Ok(s), _) => s.validate().unwrap(),
            (Err(e @ SceneError::MeshNotFetched { .. }), Some(_)) => println!("skipped: {e}"),
            (Err(e), _) => panic!("{}: {e}", b.name),
        }
        if let Some(which) = b.mesh {
            vrrt_scene::mesh_scenes::build(which, &stand_in)
                .validate()
                .unwrap();
        }
    }
}

#[test]
fn nan_cameras_transforms_and_lights_are_refused_by_name() {
    let ok = CameraPath::fixed(Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO, 1.0);
    boxed(ok.clone()).validate().unwrap();

    refused(
        &boxed(CameraPath::fixed(Vec3::NAN, Vec3::ZERO, 1.0)),
        "camera key 0 is not finite",
    );
    refused(
        &boxed(CameraPath::fixed(
            Vec3::ONE,
            Vec3::new(f32::INFINITY, 0.0, 0.0),
            1.0,
        )),
        "camera key 0 is not finite",
    );
    refused(
        &boxed(CameraPath::fixed(Vec3::ONE, Vec3::ZERO, 0.0)),
        "fov_y",
    );
    refused(
        &boxed(CameraPath::fixed(Vec3::ONE, Vec3::ZERO, 3.2)),
        "fov_y",
    );
    refused(
        &boxed(CameraPath::fixed(Vec3::ONE, Vec3::ONE, 1.0)),
        "own position",
    );

    let mut s = boxed(ok.clone());
    s.instances[0].motion = Trajectory::Static(Affine3A::from_translation(Vec3::NAN));
    refused(&s, "instance `box`");
    let mut s = boxed(ok.clone());
    s.instances[0].motion = Trajectory::Linear {
        base: Affine3A::IDENTITY,
        velocity: Vec3::new(0.0, f32::NAN, 0.0),
    };
    refused(&s, "instance `box`");

    let mut s = builtin("room").unwrap();
    s.lights[0].motion = Trajectory::Spin {
        base: Affine3A::IDENTITY,
        turns_per_second: f32::INFINITY,
    };
    refused(&s, "light 0");

    let mut s = boxed(ok);
    s.fps = 0.0;
    refused(&s, "frame rate");
}

#[test]
fn a_camera_inside_a_closed_box_renders_a_defined_dark_image() {
    // Inside the 4-unit box, every AO ray within radius 3 hits a wall near the corners and few
    // elsewhere: the image is finite, has no sky, and is not one flat value.
    let scene = boxed(CameraPath::fixed(
        Vec3::ZERO,
        Vec3::new(0.0, 0.0, -1.0),
        1.2,
    ));
    scene.validate().unwrap();
    let (w, h) = (48, 32);
    let signal = Signal::Ao { max_distance: 3.0 };
    let mut exec = CpuExecutor::new();
    let mut r = Renderer::new(&mut exec, w, h, signal, 0, Settings::default()).unwrap();
    let mut last = None;
    for i in 0..4 {
        last = Some(
            r.render(&mut exec, &scene.frame(i), Readback::default())
                .unwrap(),
        );
    }
    let out = last.unwrap();
    assert!(out.denoised.iter().all(|v| v.is_finite()));
    assert!(
        out.rays_traced > 0,
        "every pixel sees a wall: rays are traced"
    );
    let (lo, hi) = out
        .denoised
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let mean = out.denoised.iter().sum::<f32>() / out.denoised.len() as f32;
    println!("inside the box: AO mean {mean:.3}, range {lo:.3}..{hi:.3}");
    assert!(hi - lo > 0.05, "not a flat image: {lo}..{hi}");
    assert!(
        mean < 0.9,
        "walls within the AO radius occlude: mean {mean}"
    );
}
