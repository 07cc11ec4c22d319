//! The application the examples embed VRRT-rs in, and the few helpers an engine writes once.
//!
//! The "application" is synthetic so the examples need no scene files: a G-buffer of a box sliding
//! right over a back wall (every frame uncovers a strip of wall, where VRRT supersamples) and an
//! ambient-occlusion "ray tracer" whose rays return 0 or 1 with a known probability per pixel.
//!
//! A frame with the denoiser is always the same four steps:
//! 1. [`Denoiser::begin_frame`] with the cameras, then write this frame's G-buffer into
//!    [`Denoiser::inputs`] (depth, normal + roughness, motion);
//! 2. [`Denoiser::plan_rays`]: afterwards the work list [`Denoiser::work`] (or, on the host,
//!    [`Denoiser::read_rays`]) says how many rays each pixel traces *this* frame (more where
//!    history was lost, fewer where it converged, within the budget);
//! 3. trace them and write the noisy [`Sample`]s into [`Denoiser::samples`];
//! 4. [`Denoiser::resolve`]: the denoised signal is in [`Denoiser::output`].
//!
//! [`raster`] is the other kind of application: a small wgpu raster engine drawing a real scene
//! into G-buffer textures of its own conventions, which the denoiser decodes itself
//! (`examples/raster_engine.rs`).

use vrrt_core::camera::{Camera, View};
use vrrt_core::denoiser::{Denoiser, FrameInfo, Inputs};
use vrrt_core::executor::{BufferId, Executor, Groups, KernelDesc, Pass, PassTiming};
use vrrt_core::glam::Vec3;
use vrrt_core::inputs::{InputConventions, MotionUnits, NormalSpace};
use vrrt_core::packing;
use vrrt_core::payload::PackedFiltered;
use vrrt_core::payload::{PackedSample, Sample};
use vrrt_core::settings::Settings;
use vrrt_cpu::CpuExecutor;

pub mod raster;

/// Image width of the examples.
pub const WIDTH: u32 = 64;
/// Image height of the examples.
pub const HEIGHT: u32 = 48;
/// Frames each example renders.
pub const FRAMES: u32 = 24;
/// Pixels per image.
pub const PIXELS: usize = (WIDTH * HEIGHT) as usize;

/// The box: left edge at frame 0, width, rows, and how far it moves per frame (pixels).
const BOX_X: u32 = 12;
const BOX_W: u32 = 24;
const BOX_ROWS: std::ops::Range<u32> = 12..36;
const BOX_SPEED: u32 = 2;
/// `tan(30°)`: a 60° vertical field of view.
const TAN_HALF_FOV: f32 = 0.577_350_3;
/// Angle of one pixel.
const PIXEL_ANGLE: f32 = 2.0 * TAN_HALF_FOV / HEIGHT as f32;

/// Denoiser settings of the examples: the defaults (full VRRT, 1 ray per pixel), one AO plane.
pub fn settings() -> Settings {
    Settings::default()
}

/// Per-frame inputs of frame `index` (history is discarded on frame 0).
pub fn frame_info(index: u32) -> FrameInfo {
    FrameInfo {
        index,
        reset: index == 0,
        pixel_angle: PIXEL_ANGLE,
        moved: index > 0,
        view: View {
            camera: camera(),
            prev_camera: camera(),
        },
        ..FrameInfo::default()
    }
}

fn in_box(x: u32, y: u32, frame: u32) -> bool {
    let left = BOX_X + BOX_SPEED * frame;
    (left..left + BOX_W).contains(&x) && BOX_ROWS.contains(&y)
}

/// The application's camera: at the origin looking down +z, 60° vertical field of view.
pub fn camera() -> Camera {
    Camera::from_basis(Vec3::ZERO, Vec3::X, -Vec3::Y, Vec3::Z, TAN_HALF_FOV)
}

/// One frame of the application's G-buffer in the formats an engine writes and the denoiser
/// reads (the README's input contract), one image per input buffer.
#[derive(Clone, Debug, PartialEq)]
pub struct GBufferImages {
    /// Linear view depth.
    pub depth: Vec<f32>,
    /// `packing::pack_normal_roughness` of the shading normal and GGX alpha.
    pub normal_roughness: Vec<u32>,
    /// `packing::pack_motion`: pixels to last frame's position, view-depth change.
    pub motion: Vec<[u32; 2]>,
}

impl GBufferImages {
    /// Each image's bytes with the denoiser buffer it goes to.
    pub fn uploads(&self, inputs: Inputs) -> [(BufferId, &[u8]); 3] {
        [
            (inputs.depth, bytemuck::cast_slice(&self.depth)),
            (
                inputs.normal_roughness,
                bytemuck::cast_slice(&self.normal_roughness),
            ),
            (inputs.motion, bytemuck::cast_slice(&self.motion)),
        ]
    }
}

/// The G-buffer of frame `frame`: a wall at depth 10 and the box at depth 5, both facing the
/// camera; the box moves `BOX_SPEED` pixels right per frame, so its motion points left.
pub fn gbuffer(frame: u32) -> GBufferImages {
    let facing = packing::pack_normal_roughness(-Vec3::Z, 1.0);
    let mut g = GBufferImages {
        depth: Vec::with_capacity(PIXELS),
        normal_roughness: vec![facing; PIXELS],
        motion: Vec::with_capacity(PIXELS),
    };
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let (depth, shift) = if in_box(x, y, frame) {
                (5.0, BOX_SPEED as f32)
            } else {
                (10.0, 0.0)
            };
            g.depth.push(depth);
            g.motion.push(packing::pack_motion(-shift, 0.0, 0.0));
        }
    }
    g
}

/// The same G-buffer as an engine's own textures in its own conventions
/// ([`texture_conventions`]): linear depth (R32F), view-space normals with roughness (RGBA32F)
/// and motion in UV units (RGBA32F), row-major texels.
pub struct GBufferTexels {
    /// Depth, one `f32` per texel.
    pub depth: Vec<f32>,
    /// View-space normal `xyz` and linear roughness.
    pub normal: Vec<[f32; 4]>,
    /// Motion to last frame in UV units, the view-depth change, 0.
    pub motion: Vec<[f32; 4]>,
}

/// The conventions of [`gbuffer_texels`].
pub fn texture_conventions() -> InputConventions {
    InputConventions {
        normal_space: NormalSpace::View,
        motion_units: MotionUnits::Uv,
        ..InputConventions::default()
    }
}

/// [`gbuffer`]'s frame `frame` as the engine's textures: every surface faces the camera, which
/// in view space is `+z`.
pub fn gbuffer_texels(frame: u32) -> GBufferTexels {
    let mut g = GBufferTexels {
        depth: Vec::with_capacity(PIXELS),
        normal: vec![[0.0, 0.0, 1.0, 1.0]; PIXELS],
        motion: Vec::with_capacity(PIXELS),
    };
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let (depth, shift) = if in_box(x, y, frame) {
                (5.0, BOX_SPEED as f32)
            } else {
                (10.0, 0.0)
            };
            g.depth.push(depth);
            g.motion.push([-shift / WIDTH as f32, 0.0, 0.0, 0.0]);
        }
    }
    g
}

/// The converged AO of frame `frame`: a ramp on the wall, a constant on the box.
pub fn truth(frame: u32) -> Vec<f32> {
    (0..PIXELS as u32)
        .map(|i| {
            let (x, y) = (i % WIDTH, i / WIDTH);
            if in_box(x, y, frame) {
                0.85
            } else {
                0.25 + 0.5 * x as f32 / WIDTH as f32
            }
        })
        .collect()
}

fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// The application's ray tracer: `rays[i]` AO rays at pixel `i`, each 1 (unoccluded) with the
/// probability [`truth`] gives, as the moments the denoiser takes (packed: binary16 moments,
/// rays and the 0th ray's value, [`PackedSample`]).
pub fn trace(frame: u32, rays: &[u32]) -> Vec<PackedSample> {
    let ao = truth(frame);
    rays.iter()
        .zip(&ao)
        .enumerate()
        .map(|(i, (&n, &p))| {
            let ray = |r: u32| {
                let u = hash(i as u32 ^ hash(frame.wrapping_mul(977).wrapping_add(r))) >> 8;
                f32::from(u8::from((u as f32) < p * (1 << 24) as f32))
            };
            let hits: f32 = (0..n).map(ray).sum();
            let mean = if n > 0 { hits / n as f32 } else { 0.0 };
            Sample {
                m1: mean,
                // Rays return 0 or 1: the mean of squares is the mean.
                m2: mean,
                rays: n,
                first: if n > 0 { ray(0) } else { 0.0 },
            }
            .pack()
        })
        .collect()
}

/// Reads `len` elements of `T` from buffer `id`.
pub fn read<T: bytemuck::Pod + Default, E: Executor>(
    exec: &mut E,
    id: BufferId,
    len: usize,
) -> Result<Vec<T>, E::Error> {
    let mut out = vec![T::default(); len];
    exec.read_buffer(id, bytemuck::cast_slice_mut(&mut out))?;
    Ok(out)
}

/// What one frame produced.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameResult {
    /// Rays each pixel traced.
    pub rays: Vec<u32>,
    /// The denoised AO.
    pub denoised: Vec<f32>,
}

/// The denoised values of a [`PackedFiltered`] buffer's contents (RG16F: value, variance).
pub fn values(filtered: &[PackedFiltered]) -> Vec<f32> {
    filtered.iter().map(|f| f.unpack().value).collect()
}

/// The reference the GPU examples compare with: every frame on the CPU backend, the same loop
/// as `examples/cpu_slices.rs`.
pub fn cpu_frames() -> Vec<FrameResult> {
    let cpu = &mut CpuExecutor::new();
    let mut d = Denoiser::new(cpu, WIDTH, HEIGHT, settings()).expect("valid settings");
    (0..FRAMES)
        .map(|frame| {
            let run = |cpu: &mut CpuExecutor, d: &mut Denoiser| {
                d.begin_frame(cpu, frame_info(frame))?;
                for (id, bytes) in gbuffer(frame).uploads(d.inputs()) {
                    cpu.write_buffer(id, bytes)?;
                }
                d.plan_rays(cpu)?;
                let rays = d.read_rays(cpu)?;
                cpu.write_buffer(d.samples(), bytemuck::cast_slice(&trace(frame, &rays)))?;
                d.resolve(cpu)?;
                let denoised = values(&read::<PackedFiltered, _>(cpu, d.output(), PIXELS)?);
                Ok::<_, vrrt_cpu::CpuError>(FrameResult { rays, denoised })
            };
            run(cpu, &mut d).expect("CPU backend")
        })
        .collect()
}

/// How many binary16 steps a GPU example's denoised value may lie from the CPU backend's: five
/// à-trous passes each round to binary16 and history carries a frame's steps into the next, so a
/// few steps, not one (the equivalence table holds a single pass to one).
pub const HALF_STEPS: u32 = 8;

/// Largest distance in binary16 steps between the denoised values `got` and the CPU backend's
/// `want` (both binary16 values, widened); panics with `what` past `half_ulps` or if the lengths
/// differ. The GPU's native transcendentals and fused multiply-adds move the filter's f32
/// arithmetic in the last bits, so a stored half may land a rounding step away, and history
/// carries such steps into later frames.
pub fn assert_close(what: &str, got: &[f32], want: &[f32], half_ulps: u32) -> u32 {
    assert_eq!(got.len(), want.len(), "{what}: lengths differ");
    // Sign-magnitude codes on one monotonic line (+0 and −0 meet).
    let line = |x: f32| {
        let h = vrrt_core::binary16::f32_to_f16(x) as i32;
        if h & 0x8000 != 0 {
            -(h & 0x7fff)
        } else {
            h
        }
    };
    let mut worst = 0;
    for (i, (&a, &b)) in got.iter().zip(want).enumerate() {
        let steps = (line(a) - line(b)).unsigned_abs();
        assert!(
            steps <= half_ulps,
            "{what}: pixel {i} is {a}, the CPU gives {b} ({steps} binary16 steps apart)"
        );
        worst = worst.max(steps);
    }
    worst
}

/// Whether a missing Vulkan adapter is a failure (`VRRT_REQUIRE_VULKAN=1`, as in CI).
pub fn require_vulkan() -> bool {
    std::env::var("VRRT_REQUIRE_VULKAN").is_ok_and(|v| v == "1")
}

/// Whether to run under the Khronos validation layer (`VRRT_VALIDATION=1`, as in CI).
pub fn validation() -> bool {
    std::env::var("VRRT_VALIDATION").is_ok_and(|v| v == "1")
}

/// A pass with its buffers and parameters owned.
struct OwnedPass {
    kernel: &'static KernelDesc,
    buffers: Vec<BufferId>,
    params: Vec<u8>,
    groups: Groups,
}

/// Passes captured by [`capture`], to record into the application's own command encoder
/// ([`vrrt_wgpu::WgpuExecutor::encode`]) or command buffer
/// ([`vrrt_ash::AshExecutor::record_into`]).
#[derive(Default)]
pub struct Passes(Vec<OwnedPass>);

impl Passes {
    /// The passes, in dispatch order.
    pub fn get(&self) -> Vec<Pass<'_>> {
        self.0
            .iter()
            .map(|p| Pass {
                kernel: p.kernel,
                buffers: &p.buffers,
                params: &p.params,
                groups: p.groups,
            })
            .collect()
    }
}

/// An executor that keeps the passes dispatched to it instead of running them; everything else
/// goes to the wrapped executor.
pub struct Capture<'a, E> {
    exec: &'a mut E,
    passes: Passes,
}

/// Runs `f` (e.g. `|e| denoiser.plan_rays(e)`) with dispatches captured rather than run.
///
/// The denoiser's per-frame calls only dispatch. Buffer creation and uploads made inside `f` go
/// straight to `exec` (so they run *before* the captured passes); reading a buffer inside `f`
/// panics, since the passes that would write it have not run.
pub fn capture<E: Executor>(
    exec: &mut E,
    f: impl FnOnce(&mut Capture<'_, E>) -> Result<(), E::Error>,
) -> Result<Passes, E::Error> {
    let mut c = Capture {
        exec,
        passes: Passes::default(),
    };
    f(&mut c)?;
    Ok(c.passes)
}

impl<E: Executor> Executor for Capture<'_, E> {
    type Error = E::Error;

    fn name(&self) -> &'static str {
        self.exec.name()
    }

    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, E::Error> {
        self.exec.create_buffer(size_bytes)
    }

    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), E::Error> {
        self.exec.write_buffer(buffer, data)
    }

    fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), E::Error> {
        self.passes.0.push(OwnedPass {
            kernel: pass.kernel,
            buffers: pass.buffers.to_vec(),
            params: pass.params.to_vec(),
            groups: pass.groups,
        });
        Ok(())
    }

    fn read_buffer(&mut self, _: BufferId, _: &mut [u8]) -> Result<(), E::Error> {
        panic!("read_buffer while capturing: the captured passes have not run");
    }

    fn finish(&mut self) -> Result<(), E::Error> {
        panic!("finish while capturing: record the captured passes first");
    }

    fn timings(&self) -> &[PassTiming] {
        self.exec.timings()
    }

    fn clear_timings(&mut self) {
        self.exec.clear_timings()
    }
}
