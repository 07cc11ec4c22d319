//! The frame owns its budget in milliseconds: an engine that drives
//! [`vrrt_core::frame::Frame`] itself (its scene on the executor, its G-buffer, `render` then
//! `finish` each frame) gets the frames `vrrt run --budget-ms` renders through
//! [`vrrt_scene::render::Renderer`], budget by budget and pixel by pixel. And the rays
//! [`Frame::finish`] counts from the balancer's decisions (a few words) are the rays the
//! renderer used to count pixel by pixel.
//!
//! Real timings differ from run to run, so the executor here reports a fixed cost per ray
//! (`FixedCost`): both runs see the same milliseconds for the same rays, and the budget they
//! follow must be the same.

use vrrt_core::budget::TRACE_ENTRIES;
use vrrt_core::executor::{BufferId, Executor, Groups, Pass, PassTiming};
use vrrt_core::frame::Frame;
use vrrt_core::kernels::group_planes;
use vrrt_core::payload::PackedFiltered;
use vrrt_core::settings::Settings;
use vrrt_cpu::{CpuError, CpuExecutor};
use vrrt_scene::builtin::builtin;
use vrrt_scene::render::{FrameOutput, GpuScene, Readback, Renderer, Signal};
use vrrt_scene::Scene;

const SIZE: (u32, u32) = (96, 54);
const FRAMES: u32 = 16;
/// Frames whose rays are counted both ways.
const COUNTED_FRAMES: u32 = 8;
/// Milliseconds a ray-tracing workgroup (64 work-list entries) costs.
const MS_PER_GROUP: f64 = 0.05;

/// The CPU backend with made-up, deterministic timings: a ray-tracing pass costs
/// [`MS_PER_GROUP`] per workgroup of its (indirect) dispatch, any other pass nothing.
#[derive(Default)]
struct FixedCost {
    cpu: CpuExecutor,
    timings: Vec<PassTiming>,
}

impl Executor for FixedCost {
    type Error = CpuError;

    fn name(&self) -> &'static str {
        "cpu, fixed cost"
    }

    fn create_buffer(&mut self, size_bytes: u64) -> Result<BufferId, CpuError> {
        self.cpu.create_buffer(size_bytes)
    }

    fn write_buffer(&mut self, buffer: BufferId, data: &[u8]) -> Result<(), CpuError> {
        self.cpu.write_buffer(buffer, data)
    }

    fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), CpuError> {
        let groups = match pass.groups {
            Groups::Direct([x, y, z]) => x * y * z,
            Groups::Indirect { buffer, offset } => {
                let words: &[u32] = bytemuck::cast_slice(self.cpu.contents(buffer)?);
                let i = (offset / 4) as usize;
                words[i] * words[i + 1] * words[i + 2]
            }
        };
        self.cpu.dispatch(pass)?;
        let traces = TRACE_ENTRIES.contains(&pass.kernel.entry);
        self.timings.push(PassTiming {
            entry: pass.kernel.entry,
            ms: if traces {
                groups as f64 * MS_PER_GROUP
            } else {
                0.0
            },
        });
        Ok(())
    }

    fn read_buffer(&mut self, buffer: BufferId, out: &mut [u8]) -> Result<(), CpuError> {
        self.cpu.read_buffer(buffer, out)
    }

    fn finish(&mut self) -> Result<(), CpuError> {
        self.cpu.finish()
    }

    fn timings(&self) -> &[PassTiming] {
        &self.timings
    }

    fn clear_timings(&mut self) {
        self.timings.clear();
    }
}

/// What a frame gave: the budget it ran with (rays per pixel), the rays it traced, its tracing
/// time and its denoised image.
#[derive(Debug, PartialEq)]
struct Rendered {
    rays_per_pixel: f32,
    rays_traced: u64,
    trace_ms: f64,
    denoised: Vec<f32>,
}

fn settings() -> Settings {
    let mut s = Settings::default();
    s.rates.budget_ms = 1.5;
    s
}

/// Every signal: one plane, one per light, reflections, and all of them sharing one budget.
fn signals() -> [Signal; 4] {
    [
        Signal::Ao { max_distance: 1.0 },
        Signal::Shadows,
        Signal::Reflections,
        Signal::All { max_distance: 1.0 },
    ]
}

/// `vrrt run --budget-ms`'s path: the renderer.
fn through_renderer(scene: &Scene, signal: Signal) -> Vec<Rendered> {
    let mut exec = FixedCost::default();
    let (w, h) = SIZE;
    let mut r = Renderer::new(&mut exec, w, h, signal, scene.lights.len(), settings()).unwrap();
    (0..FRAMES)
        .map(|i| {
            let out = r
                .render(&mut exec, &scene.frame(i), Readback::default())
                .unwrap();
            Rendered {
                rays_per_pixel: out.rays_per_pixel,
                rays_traced: out.rays_traced,
                trace_ms: out.trace_ms,
                denoised: out.denoised,
            }
        })
        .collect()
}

/// An engine's path: the frame itself, with the scene's geometry as its own. With `finish`
/// false the engine forgets [`Frame::finish`] (the report keeps no rays and no time, and the
/// budget never moves): the divergence the comparison must catch.
fn through_frame(scene: &Scene, signal: Signal, finish: bool) -> Vec<Rendered> {
    let mut exec = FixedCost::default();
    let (w, h) = SIZE;
    let mut frame = Frame::new(&mut exec, w, h, signal, scene.lights.len(), settings()).unwrap();
    let mut gpu = GpuScene::default();
    (0..FRAMES)
        .map(|i| {
            let f = scene.frame(i);
            let rays_per_pixel = frame.denoiser().rays_per_pixel();
            gpu.upload(&mut exec, &f).unwrap();
            let mut report = frame
                .render(&mut exec, &gpu.frame_scene(&f), |exec, target| {
                    gpu.gbuffer(exec, &f, w, h, target)
                })
                .unwrap();
            if finish {
                report = frame.finish(&mut exec, report).unwrap();
            }
            let n = (w * h * frame.layout().planes) as usize;
            let mut out = vec![PackedFiltered::default(); n];
            exec.read_buffer(
                frame.denoiser().output(),
                bytemuck::cast_slice_mut(&mut out),
            )
            .unwrap();
            Rendered {
                rays_per_pixel,
                rays_traced: report.rays_traced,
                trace_ms: report.trace_ms,
                denoised: out.iter().map(|p| p.unpack().value).collect(),
            }
        })
        .collect()
}

#[test]
fn an_engine_calling_frame_gets_what_vrrt_run_budget_ms_renders() {
    let scene = builtin("room").unwrap();
    for signal in signals() {
        let renderer = through_renderer(&scene, signal);
        let engine = through_frame(&scene, signal, true);
        let budgets: Vec<f32> = renderer.iter().map(|r| r.rays_per_pixel).collect();
        // The budget moved: the frame followed its time, not a fixed count.
        assert!(
            budgets.windows(2).any(|b| b[0] != b[1]),
            "{signal:?}: the budget never moved: {budgets:?}"
        );
        for (i, (r, e)) in renderer.iter().zip(&engine).enumerate() {
            assert_eq!(
                r.rays_per_pixel, e.rays_per_pixel,
                "{signal:?}, frame {i}: budgets {budgets:?}"
            );
            assert_eq!(
                (r.rays_traced, r.trace_ms),
                (e.rays_traced, e.trace_ms),
                "{signal:?}, frame {i}: rays traced and ms"
            );
            assert!(
                r.denoised == e.denoised,
                "{signal:?}, frame {i}: the images differ"
            );
        }
        // The comparison can fail: an engine that skips `finish` keeps its first budget, and
        // its frames part from the renderer's as soon as the renderer's budget moves.
        let forgetful = through_frame(&scene, signal, false);
        let first = renderer.iter().position(|r| r.rays_per_pixel != budgets[0]);
        let first = first.expect("the budget moved");
        assert_ne!(
            forgetful[first].rays_per_pixel,
            renderer[first].rays_per_pixel
        );
        assert!(
            forgetful[first..]
                .iter()
                .zip(&renderer[first..])
                .any(|(f, r)| f.denoised != r.denoised),
            "{signal:?}: skipping finish changed no image"
        );
    }
}

/// The rays a frame traced as [`Renderer`] derived them before [`Frame::finish`] counted them:
/// each pixel's rays per plane (apply's rule replayed on the host from the requests, the
/// decisions and the blue noise: [`FrameOutput::rays`]) plus the refill lists' (each group's
/// `refill_traced` rays cost one ray of each of its planes), per plane, rounded.
fn per_pixel_count(out: &FrameOutput, plane_groups: u32, planes: u32) -> u64 {
    let refill: u64 = (0..out.decisions.len() as u32)
        .map(|g| {
            out.decisions[g as usize].refill_traced as u64
                * group_planes(plane_groups, planes, g) as u64
        })
        .sum();
    let main: f64 = out.rays.iter().map(|&r| r as f64).sum();
    (main + refill as f64 / planes as f64).round() as u64
}

#[test]
fn the_frame_counts_the_rays_the_renderer_counted_pixel_by_pixel() {
    let scene = builtin("room").unwrap();
    let (w, h) = SIZE;
    let mut refilled = false;
    for signal in signals() {
        let mut exec = FixedCost::default();
        let mut r = Renderer::new(&mut exec, w, h, signal, scene.lights.len(), settings()).unwrap();
        for i in 0..COUNTED_FRAMES {
            let plane_groups = r.denoiser().layout().plane_groups;
            let out = r
                .render(&mut exec, &scene.frame(i), Readback::default())
                .unwrap();
            let planes = (out.denoised.len() / (w * h) as usize) as u32;
            assert!(out.rays_traced > 0, "{signal:?}, frame {i}: no ray traced");
            assert_eq!(
                out.rays_traced,
                per_pixel_count(&out, plane_groups, planes),
                "{signal:?}, frame {i}: the decisions' count against the pixels'"
            );
            refilled |= out.decisions.iter().any(|d| d.refill_traced > 0);
        }
    }
    // The refill lists' rays are part of the count: some frame must have traced them.
    assert!(
        refilled,
        "no refill list traced: only the main pass was compared"
    );
}
