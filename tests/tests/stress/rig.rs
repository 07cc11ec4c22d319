//! The stress suite's synthetic frame loop ([`Rig`]) and the helpers its cases share, kept apart.

use std::time::Instant;
use vrrt_backend::{Backend, BackendKind};
use vrrt_core::camera::{Camera, View};
use vrrt_core::denoiser::{Denoiser, FrameInfo};
use vrrt_core::executor::{BufferId, Executor};
use vrrt_core::glam::Vec3;
use vrrt_core::payload::PackedFiltered;
use vrrt_core::payload::{self, PackedPayload, PackedSample, Payload, Sample};
use vrrt_core::settings::Settings;
use vrrt_core::surface::{Surface, NO_INSTANCE};
use vrrt_tests::inputs::Images;

pub fn long() -> bool {
    std::env::var("VRRT_STRESS_LONG").is_ok_and(|v| v == "1")
}

/// The CPU backend, then wgpu and ash where a Vulkan adapter exists.
fn backends() -> Vec<Backend> {
    // The cases run on parallel test threads; Vulkan instances and devices (with the validation
    // layer) are created one at a time: a CI run once died of SIGSEGV before any case had
    // finished, while they were being created concurrently.
    static OPENING: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = OPENING.lock().unwrap_or_else(|e| e.into_inner());
    let require = std::env::var("VRRT_REQUIRE_VULKAN").is_ok_and(|v| v == "1");
    let mut out = vec![Backend::open(BackendKind::Cpu, false).unwrap().0];
    for kind in [BackendKind::Wgpu, BackendKind::Ash] {
        match Backend::open(kind, true) {
            Ok((b, _)) => out.push(b),
            Err(e) if require => panic!("{kind:?}: {e} (VRRT_REQUIRE_VULKAN=1)"),
            Err(e) => println!("{kind:?}: skipped: no Vulkan adapter ({e})"),
        }
    }
    out
}

/// Runs `case` on every backend, printing its figure and wall time, and fails on validation
/// errors.
pub fn on_every_backend(name: &str, mut case: impl FnMut(&mut Backend) -> String) {
    for mut b in backends() {
        let t = Instant::now();
        let figure = case(&mut b);
        println!(
            "{name:<28} {:<5} {figure} ({:.2} s)",
            b.name(),
            t.elapsed().as_secs_f64()
        );
        assert_eq!(b.validation_errors(), 0, "{name} on {}", b.name());
    }
}

/// Integer hash of a pixel, plane and frame: deterministic noise shared by every backend and run.
pub fn hash(x: u32, y: u32, z: u32, f: u32) -> u32 {
    let mut h =
        x.wrapping_mul(0x8da6_b343) ^ y.wrapping_mul(0xd816_3841) ^ z.wrapping_mul(0xcb1a_b31f);
    h ^= f.wrapping_mul(0x9e37_79b9);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^ (h >> 16)
}

/// Uniform in `[-1, 1)`.
pub fn noise(x: u32, y: u32, z: u32, f: u32) -> f32 {
    (hash(x, y, z, f) >> 8) as f32 / (1u32 << 23) as f32 - 1.0
}

/// The camera of every case: at the origin looking down +z, so the plane at depth 1 faces it.
fn view() -> View {
    let camera = Camera::from_basis(Vec3::ZERO, Vec3::X, -Vec3::Y, Vec3::Z, 0.5);
    View {
        camera,
        prev_camera: camera,
    }
}

/// A flat plane facing the camera at depth 1: every pixel valid, static (reprojects onto itself).
pub fn plane(w: u32, h: u32) -> Vec<Surface> {
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let (px, py) = (x as f32 * 1e-3, y as f32 * 1e-3);
            out.push(Surface {
                px,
                py,
                pz: 1.0,
                depth: 1.0,
                nz: -1.0,
                instance: 0,
                gz: -1.0,
                roughness: 1.0,
                prev_x: x as f32,
                prev_y: y as f32,
                prev_px: px,
                prev_py: py,
                prev_pz: 1.0,
                ..Surface::default()
            });
        }
    }
    out
}

/// A frame with no geometry: every pixel is sky.
pub fn sky(w: u32, h: u32) -> Vec<Surface> {
    vec![
        Surface {
            instance: NO_INSTANCE,
            ..Surface::default()
        };
        (w * h) as usize
    ]
}

fn read<T: bytemuck::Pod + Default>(exec: &mut Backend, id: BufferId, len: usize) -> Vec<T> {
    let mut out = vec![T::default(); len];
    exec.read_buffer(id, bytemuck::cast_slice_mut(&mut out))
        .unwrap();
    out
}

/// A denoiser with its synthetic frame loop.
pub struct Rig {
    d: Denoiser,
    w: u32,
    h: u32,
    planes: u32,
    frame: u32,
    gbuffer: Images,
}

impl Rig {
    pub fn new(
        exec: &mut Backend,
        w: u32,
        h: u32,
        settings: Settings,
        surfaces: Vec<Surface>,
    ) -> Self {
        let d = Denoiser::new(exec, w, h, settings).unwrap();
        Rig {
            w,
            h,
            planes: d.layout().planes,
            d,
            frame: 0,
            gbuffer: Images::pack(&surfaces, w, &view()),
        }
    }

    /// One frame. `sample(x, y, plane, frame)` gives the `(m1, m2)` of the rays granted to that
    /// pixel; returns the rays traced in total.
    // `..Default::default()` on `FrameInfo` keeps this valid as the struct gains fields.
    #[allow(clippy::needless_update)]
    pub fn frame(
        &mut self,
        exec: &mut Backend,
        reset: bool,
        sample: impl Fn(u32, u32, u32, u32) -> (f32, f32),
    ) -> u64 {
        let (w, h) = (self.w, self.h);
        let info = FrameInfo {
            index: self.frame,
            reset: reset || self.frame == 0,
            pixel_angle: 1.0 / h as f32,
            view: view(),
            ..Default::default()
        };
        self.d.begin_frame(exec, info).unwrap();
        let inputs = self.d.inputs();
        let g = &self.gbuffer;
        exec.write_buffer(inputs.depth, bytemuck::cast_slice(&g.depth))
            .unwrap();
        exec.write_buffer(
            inputs.normal_roughness,
            bytemuck::cast_slice(&g.normal_roughness),
        )
        .unwrap();
        exec.write_buffer(inputs.motion, bytemuck::cast_slice(&g.motion))
            .unwrap();
        self.d.plan_rays(exec).unwrap();
        let rays = self.d.read_rays(exec).unwrap();
        let mut samples = vec![Sample::default(); (w * h * self.planes) as usize];
        for z in 0..self.planes {
            for y in 0..h {
                for x in 0..w {
                    let r = rays[(y * w + x) as usize];
                    if r > 0 {
                        let (m1, m2) = sample(x, y, z, self.frame);
                        samples[((z * h + y) * w + x) as usize] = Sample {
                            m1,
                            m2,
                            rays: r,
                            ..Sample::default()
                        };
                    }
                }
            }
        }
        let packed: Vec<PackedSample> = samples.iter().map(|s| s.pack()).collect();
        exec.write_buffer(self.d.samples(), bytemuck::cast_slice(&packed))
            .unwrap();
        self.d.resolve(exec).unwrap();
        self.frame += 1;
        rays.iter().map(|&r| r as u64).sum()
    }

    pub fn output(&self, exec: &mut Backend) -> Vec<f32> {
        let n = (self.w * self.h * self.planes) as usize;
        read::<PackedFiltered>(exec, self.d.output(), n)
            .iter()
            .map(|f| f.unpack().value)
            .collect()
    }

    pub fn history(&self, exec: &mut Backend) -> Vec<Payload> {
        let packed: Vec<PackedPayload> = read(
            exec,
            self.d.history(),
            (self.w * self.h * self.planes) as usize,
        );
        packed.iter().map(|p| p.unpack()).collect()
    }

    pub fn counters(&self, exec: &mut Backend) -> [u32; 2] {
        let c: Vec<u32> = read(exec, self.d.counters(), payload::COUNTERS_LEN as usize);
        [c[payload::COUNTER_NON_FINITE], c[payload::COUNTER_CLAMPED]]
    }
}

pub fn non_finite(v: &[f32]) -> usize {
    v.iter().filter(|x| !x.is_finite()).count()
}

pub fn mean(v: &[f32]) -> f64 {
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
}

/// A noisy single-ray signal in `[0.2, 0.8]`: a per-pixel pattern plus ±0.1 of noise.
pub fn pattern(x: u32, y: u32, z: u32, f: u32) -> (f32, f32) {
    let v = 0.3 + 0.4 * ((x * 7 + y * 13) % 10) as f32 / 10.0 + 0.1 * noise(x, y, z, f);
    (v, v * v)
}
