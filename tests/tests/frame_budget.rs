//! The frame owns its budget in milliseconds: an engine that drives
//! [`vrrt_core::frame::Frame`] itself (its scene on the executor, its G-buffer, `render` then
//! `finish` each frame) gets the frames `vrrt run --budget-ms` renders through
//! [`vrrt_scene::render::Renderer`], budget by budget and pixel by pixel.
//!
//! Real timings differ from run to run, so the executor here reports a fixed cost per ray
//! (`FixedCost`): both runs see the same milliseconds for the same rays, and the budget they
//! follow must be the same.

use vrrt_core::budget::TRACE_ENTRIES;
use vrrt_core::frame::Frame;
use vrrt_core::payload::PackedFiltered;
use vrrt_core::plan::{BufferId, Executor, Groups, Pass, PassTiming};
use vrrt_core::settings::Settings;
use vrrt_cpu::{CpuError, CpuExecutor};
use vrrt_scene::builtin::builtin;
use vrrt_scene::render::{GpuScene, Readback, Renderer, Signal};
use vrrt_scene::Scene;

const SIZE: (u32, u32) = (96, 54);
const FRAMES: u32 = 16;
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

/// Each frame's budget (rays per pixel it ran with) and denoised image.
type Frames = Vec<(f32, Vec<f32>)>;

fn settings() -> Settings {
    let mut s = Settings::default();
    s.rates.budget_ms = 1.5;
    s
}

/// `vrrt run --budget-ms`'s path: the renderer.
fn through_renderer(scene: &Scene, signal: Signal) -> Frames {
    let mut exec = FixedCost::default();
    let (w, h) = SIZE;
    let mut r = Renderer::new(&mut exec, w, h, signal, scene.lights.len(), settings()).unwrap();
    (0..FRAMES)
        .map(|i| {
            let out = r
                .render(&mut exec, &scene.frame(i), Readback::default())
                .unwrap();
            (out.rays_per_pixel, out.denoised)
        })
        .collect()
}

/// An engine's path: the frame itself, with the scene's geometry as its own.
fn through_frame(scene: &Scene, signal: Signal) -> Frames {
    let mut exec = FixedCost::default();
    let (w, h) = SIZE;
    let mut frame = Frame::new(&mut exec, w, h, signal, scene.lights.len(), settings()).unwrap();
    let mut gpu = GpuScene::default();
    (0..FRAMES)
        .map(|i| {
            let f = scene.frame(i);
            let rays_per_pixel = frame.denoiser().settings().rates.rays_per_pixel;
            gpu.upload(&mut exec, &f).unwrap();
            let report = frame
                .render(&mut exec, &gpu.frame_scene(&f), |exec, target| {
                    gpu.gbuffer(exec, &f, w, h, target)
                })
                .unwrap();
            frame.finish(&mut exec, report).unwrap();
            let n = (w * h * frame.layout().planes) as usize;
            let mut out = vec![PackedFiltered::default(); n];
            exec.read_buffer(
                frame.denoiser().output(),
                bytemuck::cast_slice_mut(&mut out),
            )
            .unwrap();
            (
                rays_per_pixel,
                out.iter().map(|p| p.unpack().value).collect(),
            )
        })
        .collect()
}

#[test]
fn an_engine_calling_frame_gets_what_vrrt_run_budget_ms_renders() {
    let scene = builtin("room").unwrap();
    for signal in [Signal::Ao { max_distance: 1.0 }, Signal::Shadows] {
        let (renderer, engine) = (
            through_renderer(&scene, signal),
            through_frame(&scene, signal),
        );
        let budgets: Vec<f32> = renderer.iter().map(|(b, _)| *b).collect();
        // The budget moved: the frame followed its time, not a fixed count.
        assert!(
            budgets.windows(2).any(|b| b[0] != b[1]),
            "{signal:?}: the budget never moved: {budgets:?}"
        );
        for (i, (r, e)) in renderer.iter().zip(&engine).enumerate() {
            assert_eq!(r.0, e.0, "{signal:?}, frame {i}: budgets {budgets:?}");
            assert!(r.1 == e.1, "{signal:?}, frame {i}: the images differ");
        }
    }
}
