//! The scenes on downloaded meshes (`bunny`, `dragon`) render defined images through their
//! events (a moving light, a moving sphere, a camera cut), built on a small stand-in mesh so no
//! network is needed.

use vrrt_core::glam::{Affine3A, Vec3};
use vrrt_core::settings::Settings;
use vrrt_cpu::CpuExecutor;
use vrrt_scene::mesh_cache::CachedMesh;
use vrrt_scene::mesh_scenes::{self, BUNNY_CUT_FRAME, DRAGON_CUT_FRAME};
use vrrt_scene::render::{Readback, Renderer, Signal};
use vrrt_scene::shapes::uv_sphere;

#[test]
fn mesh_scenes_render_through_their_cuts() {
    let stand_in = uv_sphere(Vec3::ZERO, 1.0, 12, 24)
        .transformed(&Affine3A::from_scale(Vec3::new(2.0, 1.4, 0.9)));
    for (which, cut) in [
        (CachedMesh::Bunny, BUNNY_CUT_FRAME),
        (CachedMesh::Dragon, DRAGON_CUT_FRAME),
    ] {
        let scene = mesh_scenes::build(which, &stand_in);
        scene.validate().unwrap();
        let (w, h) = (32, 18);
        let mut exec = CpuExecutor::new();
        let mut r = Renderer::new(
            &mut exec,
            w,
            h,
            Signal::Shadows,
            scene.lights.len(),
            Settings::default(),
        )
        .unwrap();
        for i in [0, 1, cut - 1, cut, cut + 1] {
            let f = scene.frame(i);
            assert_eq!(f.camera_cut, i == cut, "{} frame {i}", scene.name);
            let out = r.render(&mut exec, &f, Readback::default()).unwrap();
            assert!(out.denoised.iter().all(|v| v.is_finite()), "{}", scene.name);
            assert!(out.rays_traced > 0, "{} frame {i}", scene.name);
            let (lo, hi) = out
                .denoised
                .iter()
                .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
            assert!(
                hi - lo > 0.1,
                "{} frame {i}: flat image {lo}..{hi}",
                scene.name
            );
        }
    }
}
