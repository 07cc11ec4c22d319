//! The engine's own textures through `Denoiser::ingest`, on the CPU and on wgpu: a reversed-Z
//! engine with view-space normals and UV velocities lands on the same inputs as the G-buffer
//! written in our own formats, decoded by reprojection or (before an earlier reader) by the
//! `ingest` pass; the denoised frame written into the engine's texture is the one the denoiser's
//! own output holds; a buffer bound where a texture belongs is refused.

mod gpu;

use vrrt_backend::{Backend, TextureFormat};
use vrrt_core::camera::{Camera, View};
use vrrt_core::denoiser::{Denoiser, EngineTextures, FrameInfo};
use vrrt_core::executor::{ExecError, Executor};
use vrrt_core::glam::Vec3;
use vrrt_core::inputs::{DepthEncoding, InputConventions, MotionSign, MotionUnits, NormalSpace};
use vrrt_core::packing::{pack_normal_roughness, unpack_motion, unpack_normal_roughness};
use vrrt_core::payload::{PackedFiltered, Sample};
use vrrt_core::settings::Settings;
use vrrt_core::textures::Texel;
use vrrt_tests::Host;

const W: u32 = 24;
const H: u32 = 16;
const NEAR: f32 = 0.1;
const R32F: TextureFormat = TextureFormat::R32Float;

fn view() -> View {
    let camera = Camera::look_at(Vec3::new(0.0, 1.0, 5.0), Vec3::ZERO, Vec3::Y, 0.8);
    View {
        camera,
        prev_camera: camera,
    }
}

/// Per pixel: view depth, world normal, linear roughness, motion in pixels to last frame.
fn scene() -> Vec<(f32, Vec3, f32, [f32; 3])> {
    (0..W * H)
        .map(|i| {
            let (x, y) = ((i % W) as f32, (i / W) as f32);
            let n = Vec3::new(x - 12.0, 8.0, y - 8.0).normalize();
            let depth = if i % 7 == 0 {
                0.0
            } else {
                2.0 + 0.25 * x + 0.5 * y
            };
            (depth, n, 0.5, [0.25 * x - 3.0, 1.0 - 0.125 * y, 0.5])
        })
        .collect()
}

/// The same scene as a reversed-Z engine writes it: device depth (R32F), view-space normals, UV
/// velocities (this frame minus last), the depth change with the velocity's sign.
fn engine_textures(exec: &mut impl Host, view: &View) -> [vrrt_core::executor::BufferId; 3] {
    engine_textures_with(exec, view, TextureFormat::R32Float)
}

/// [`engine_textures`] with the depth in `depth_format`.
fn engine_textures_with(
    exec: &mut impl Host,
    view: &View,
    depth_format: TextureFormat,
) -> [vrrt_core::executor::BufferId; 3] {
    let cam = &view.camera;
    let (mut depth, mut normal, mut motion) = (Vec::<Texel>::new(), Vec::new(), Vec::new());
    for (d, n, r, m) in scene() {
        depth.push([if d > 0.0 { NEAR / d } else { 0.0 }, 0.0, 0.0, 1.0]);
        let v = [n.dot(cam.right()), n.dot(cam.up()), -n.dot(cam.forward())];
        normal.push([v[0], v[1], v[2], r]);
        motion.push([-m[0] / W as f32, -m[1] / H as f32, -m[2], 0.0]);
    }
    let mut texture = |format, texels: &[Texel]| exec.texture(W, H, format, texels).unwrap();
    [
        texture(depth_format, &depth),
        texture(TextureFormat::Rgba32Float, &normal),
        texture(TextureFormat::Rgba32Float, &motion),
    ]
}

fn conventions() -> InputConventions {
    InputConventions {
        depth: DepthEncoding::ReversedZ,
        near: NEAR,
        normal_space: NormalSpace::View,
        motion_units: MotionUnits::Uv,
        motion_sign: MotionSign::ToCurrent,
        ..InputConventions::default()
    }
}

/// The inputs decoded from the engine's textures once the rays are planned: depth, normal +
/// roughness and motion words. With the gradient prepass on (`prepass_stratum` > 0) the inputs
/// are read before reprojection, so the `ingest` pass decodes them; otherwise reprojection does.
fn ingested<E: Host>(
    exec: &mut E,
    prepass_stratum: u32,
    depth_format: TextureFormat,
) -> (Vec<f32>, Vec<u32>, Vec<[u32; 2]>)
where
    E::Error: std::fmt::Debug,
{
    let mut settings = Settings::default();
    settings.prepass.stratum = prepass_stratum;
    let mut denoiser = Denoiser::new(exec, W, H, settings).unwrap();
    let frame = FrameInfo {
        reset: true,
        view: view(),
        ..FrameInfo::default()
    };
    denoiser.begin_frame(exec, frame).unwrap();
    let [d, n, m] = engine_textures_with(exec, &frame.view, depth_format);
    let textures = EngineTextures::new(d, n, m, conventions()).unwrap();
    denoiser.ingest(exec, &textures).unwrap();
    denoiser.plan_rays(exec).unwrap();
    let inputs = denoiser.inputs();
    let n = (W * H) as usize;
    let (mut depth, mut normal, mut motion) = (vec![0f32; n], vec![0u32; n], vec![[0u32; 2]; n]);
    exec.read_buffer(inputs.depth, bytemuck::cast_slice_mut(&mut depth))
        .unwrap();
    exec.read_buffer(
        inputs.normal_roughness,
        bytemuck::cast_slice_mut(&mut normal),
    )
    .unwrap();
    exec.read_buffer(inputs.motion, bytemuck::cast_slice_mut(&mut motion))
        .unwrap();
    (depth, normal, motion)
}

/// Within what the formats hold: depth to 1e-5, normals to a tenth of their 11-bit code spacing,
/// motion to binary16's precision.
fn check(name: &str, (depth, normal, motion): (Vec<f32>, Vec<u32>, Vec<[u32; 2]>)) {
    for (i, (d, n, r, m)) in scene().into_iter().enumerate() {
        assert!(
            (depth[i] - d).abs() <= 1e-5 * d,
            "{name}: depth {i}: {} vs {d}",
            depth[i]
        );
        let (got_n, got_alpha) = unpack_normal_roughness(normal[i]);
        let (want_n, want_alpha) = unpack_normal_roughness(pack_normal_roughness(n, r * r));
        assert!(
            got_n.dot(want_n) > 0.99999,
            "{name}: normal {i}: {got_n} vs {want_n}"
        );
        assert!(
            (got_alpha - want_alpha).abs() < 1e-6,
            "{name}: roughness {i}"
        );
        let (got_m, want_m) = (unpack_motion(motion[i]), Vec3::from_array(m));
        let err = (got_m - want_m).abs().max_element();
        assert!(
            err <= 2e-3 * want_m.abs().max_element(),
            "{name}: motion {i}: {got_m} vs {want_m}"
        );
    }
}

#[test]
fn a_reversed_z_engine_lands_on_our_own_inputs() {
    for stratum in [0, 2] {
        check(
            "cpu",
            ingested(&mut vrrt_cpu::CpuExecutor::new(), stratum, R32F),
        );
    }
    let mut backends = gpu::backends();
    for b in backends.iter_mut() {
        let name = b.name();
        for stratum in [0, 2] {
            check(name, ingested(b, stratum, R32F));
        }
    }
    let failures = gpu::validation_failures(&backends);
    assert!(failures.is_empty(), "{failures:?}");
}

/// One frame from the engine's textures, denoised into the engine's R32F texture
/// (`resolve_into`) or into the denoiser's own buffer (`resolve`, read from `output`): the
/// denoised values of the one plane. Every pixel's rays return a noisy 0.25 or 0.75.
fn denoised<E: Host>(exec: &mut E, into_texture: bool) -> Vec<f32>
where
    E::Error: std::fmt::Debug,
{
    let mut denoiser = Denoiser::new(exec, W, H, Settings::default()).unwrap();
    let frame = FrameInfo {
        reset: true,
        pixel_angle: 0.05,
        view: view(),
        ..FrameInfo::default()
    };
    denoiser.begin_frame(exec, frame).unwrap();
    let [d, n, m] = engine_textures(exec, &frame.view);
    let textures = EngineTextures::new(d, n, m, conventions()).unwrap();
    denoiser.ingest(exec, &textures).unwrap();
    denoiser.plan_rays(exec).unwrap();
    let samples: Vec<_> = (0..W * H)
        .map(|i| {
            let v = if i % 3 == 0 { 0.25 } else { 0.75 };
            Sample {
                m1: v,
                m2: v * v,
                rays: 1,
                first: v,
            }
            .pack()
        })
        .collect();
    exec.write_buffer(denoiser.samples(), bytemuck::cast_slice(&samples))
        .unwrap();
    let n = (W * H) as usize;
    if into_texture {
        let target = exec.output_texture(W, H).unwrap();
        denoiser.resolve_into(exec, target).unwrap();
        let texels = exec.read_texture(target, W, H).unwrap();
        return texels.iter().map(|t| t[0]).collect();
    }
    denoiser.resolve(exec).unwrap();
    let mut out = vec![PackedFiltered::default(); n];
    exec.read_buffer(denoiser.output(), bytemuck::cast_slice_mut(&mut out))
        .unwrap();
    out.iter().map(|f| f.unpack().value).collect()
}

#[test]
fn the_engine_texture_gets_the_denoised_frame() {
    let want = denoised(&mut vrrt_cpu::CpuExecutor::new(), false);
    assert!(
        want.iter().any(|&v| v > 0.0),
        "the frame denoised to nothing"
    );
    assert_eq!(
        denoised(&mut vrrt_cpu::CpuExecutor::new(), true),
        want,
        "cpu"
    );
    let mut backends = gpu::backends();
    for b in backends.iter_mut() {
        let name = b.name();
        let (got, own) = (denoised(b, true), denoised(b, false));
        assert_eq!(got, own, "{name}: texture against its own output");
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(
                (g - w).abs() <= 1e-3 * w.abs().max(1e-3),
                "{name}: pixel {i}: {g} vs {w}"
            );
        }
    }
    let failures = gpu::validation_failures(&backends);
    assert!(failures.is_empty(), "{failures:?}");
}

/// A depth buffer (D32F) read as the depth: on the CPU and ash; wgpu takes no uploads into depth
/// textures, and its raster engine example reads its own z-buffer.
#[test]
fn a_depth_buffer_is_read_as_depth() {
    let depth = TextureFormat::Depth32Float;
    check("cpu", ingested(&mut vrrt_cpu::CpuExecutor::new(), 0, depth));
    let mut backends = gpu::backends();
    for b in backends.iter_mut().filter(|b| matches!(b, Backend::Ash(_))) {
        check("ash", ingested(b, 0, depth));
    }
    let failures = gpu::validation_failures(&backends);
    assert!(failures.is_empty(), "{failures:?}");
    if let Some(b) = backends.iter_mut().find(|b| matches!(b, Backend::Wgpu(_))) {
        let e = b.create_texture(W, H, depth, &[[0.0; 4]; (W * H) as usize]);
        assert!(e.unwrap_err().to_string().contains("render into it"));
    }
}

#[test]
fn a_buffer_where_a_texture_belongs_is_refused() {
    let mut cpu = vrrt_cpu::CpuExecutor::new();
    let mut denoiser = Denoiser::new(&mut cpu, W, H, Settings::default()).unwrap();
    let buffer = cpu.create_buffer((W * H * 16) as u64).unwrap();
    let [_, n, m] = engine_textures(&mut cpu, &view());
    let textures = EngineTextures::new(buffer, n, m, conventions()).unwrap();
    denoiser.ingest(&mut cpu, &textures).unwrap();
    let e = denoiser.plan_rays(&mut cpu).unwrap_err();
    assert!(
        matches!(
            e,
            ExecError::WrongKind {
                binding: "engine_depth",
                texture: true,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("reads a texture"), "{e}");
}

#[test]
fn conventions_that_cannot_be_decoded_are_refused_before_any_work() {
    let id = vrrt_core::executor::BufferId(0);
    let bad = InputConventions {
        far: NEAR,
        ..conventions()
    };
    let e = EngineTextures::new(id, id, id, bad).unwrap_err();
    assert!(e.to_string().contains("`far` must be > near"), "{e}");
}
