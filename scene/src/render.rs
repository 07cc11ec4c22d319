//! Renders a scene's frames through any executor: what a renderer supplies to
//! `vrrt_core::frame::Frame` (the scene on the executor and its G-buffer pass), the readback of
//! each frame's outputs, and converged references traced with the very same estimator.

use crate::scene::FrameGeometry;
use rayon::prelude::*;
use std::sync::Arc;
use vrrt_core::budget::MsBudget;
use vrrt_core::camera::View;
use vrrt_core::denoiser::{Denoiser, DenoiserError};
use vrrt_core::executor::{BufferId, Executor, SharedBytes};
use vrrt_core::frame::{trace_planes, Frame, FrameReport, FrameScene, GBuffer, RaygenTarget};
pub use vrrt_core::frame::{PlaneLayout, Signal, SignalName};
use vrrt_core::kernels::balance::Balance;
use vrrt_core::kernels::buckets::MAX_RATE;
use vrrt_core::kernels::gradient::{GradientSample, EMPTY_KEY};
use vrrt_core::kernels::work_list::{work_entry, LIST_GROUP};
use vrrt_core::kernels::{self, classify, group_planes, reproject};
use vrrt_core::layout::Layout;
use vrrt_core::payload::PackedFiltered;
use vrrt_core::payload::{PackedPayload, PackedSample, Payload, Sample};
use vrrt_core::reflections::Reflections;
use vrrt_core::sampling::REPLICATE_PATTERN;
use vrrt_core::settings::{ReflectionSettings, Settings};

fn bytes<T: bytemuck::Pod>(v: &[T]) -> &[u8] {
    bytemuck::cast_slice(v)
}

/// Reads `len` elements of `T` from a buffer.
pub fn read<T: bytemuck::Pod + Default, E: Executor>(
    exec: &mut E,
    id: BufferId,
    len: usize,
) -> Result<Vec<T>, E::Error> {
    let mut out = vec![T::default(); len];
    exec.read_buffer(id, bytemuck::cast_slice_mut(&mut out))?;
    Ok(out)
}

/// A growable buffer: recreated only when a larger size is needed.
#[derive(Copy, Clone, Debug)]
struct Slot {
    id: BufferId,
    bytes: u64,
}

fn ensure<E: Executor>(
    exec: &mut E,
    slot: &mut Option<Slot>,
    data: &[u8],
) -> Result<BufferId, E::Error> {
    let need = (data.len() as u64).max(4).next_multiple_of(4);
    let s = match *slot {
        Some(s) if s.bytes >= need => s,
        _ => {
            let s = Slot {
                id: exec.create_buffer(need)?,
                bytes: need,
            };
            *slot = Some(s);
            s
        }
    };
    if !data.is_empty() {
        exec.write_buffer(s.id, data)?;
    }
    Ok(s.id)
}

/// One array of a scene's geometry, shared with an executor: it holds the geometry, not a copy.
struct GeometryPart(Arc<crate::bvh::Bvh>, fn(&crate::bvh::Bvh) -> &[u8]);

impl SharedBytes for GeometryPart {
    fn bytes(&self) -> &[u8] {
        (self.1)(&self.0)
    }
}

/// Puts one array of `g` (`part`) on the executor: written into the slot's buffer when that is
/// large enough (a moving scene's next frame), else shared with a new buffer
/// ([`Executor::create_buffer_shared`]), so that the CPU backend binds the scene's own array
/// instead of a copy.
fn share<E: Executor>(
    exec: &mut E,
    slot: &mut Option<Slot>,
    g: &Arc<crate::bvh::Bvh>,
    part: fn(&crate::bvh::Bvh) -> &[u8],
) -> Result<(), E::Error> {
    let data = part(g);
    let need = (data.len() as u64).max(4).next_multiple_of(4);
    if let Some(s) = *slot {
        if s.bytes >= need {
            return match data.is_empty() {
                true => Ok(()),
                false => exec.write_buffer(s.id, data),
            };
        }
        // Executors cannot free a buffer. Writing the one left behind makes it the executor's
        // own (the size of this one array), so it no longer holds an earlier frame's geometry.
        exec.write_buffer(s.id, &[0; 4])?;
    }
    let id = exec.create_buffer_shared(Arc::new(GeometryPart(g.clone(), part)))?;
    *slot = Some(Slot { id, bytes: need });
    Ok(())
}

/// A frame's geometry on the executor; static geometry is uploaded once, and shared with the
/// executor rather than copied where it can be (the CPU backend).
#[derive(Default)]
pub struct GpuScene {
    nodes: Option<Slot>,
    tris: Option<Slot>,
    normals: Option<Slot>,
    instances: Option<Slot>,
    lights: Option<Slot>,
    next: Option<Slot>,
    uploaded: Option<Arc<crate::bvh::Bvh>>,
}

impl GpuScene {
    /// Uploads what changed since the last frame.
    pub fn upload<E: Executor>(&mut self, exec: &mut E, f: &FrameGeometry) -> Result<(), E::Error> {
        if !self
            .uploaded
            .as_ref()
            .is_some_and(|g| Arc::ptr_eq(g, &f.geometry))
        {
            share(exec, &mut self.nodes, &f.geometry, |g| bytes(&g.nodes))?;
            share(exec, &mut self.tris, &f.geometry, |g| bytes(&g.triangles))?;
            share(exec, &mut self.normals, &f.geometry, |g| bytes(&g.normals))?;
            self.uploaded = Some(f.geometry.clone());
        }
        ensure(exec, &mut self.instances, bytes(&f.instances))?;
        ensure(exec, &mut self.lights, bytes(&f.lights))?;
        // Previous→current maps for the temporal-gradient prepass (forward projection).
        let next: Vec<_> = f.instances.iter().map(|i| i.inverse()).collect();
        ensure(exec, &mut self.next, bytes(&next))?;
        Ok(())
    }

    fn ids(&self) -> [BufferId; 5] {
        let id = |s: &Option<Slot>| s.expect("GpuScene::upload first").id;
        [
            id(&self.nodes),
            id(&self.tris),
            id(&self.normals),
            id(&self.instances),
            id(&self.lights),
        ]
    }

    /// The scene of frame `f` as the frame pipeline reads it.
    pub fn frame_scene<'a>(&self, f: &'a FrameGeometry) -> FrameScene<'a> {
        let [nodes, tris, _, _, lights] = self.ids();
        FrameScene {
            nodes,
            tris,
            lights,
            next: self.next.expect("GpuScene::upload first").id,
            light_list: &f.lights,
            instances: &f.instances,
            camera: f.camera,
            prev_camera: f.prev_camera,
            camera_cut: f.camera_cut,
            changes: None,
        }
    }

    /// Records the G-buffer pass into `target` (its view is the denoiser's, or written by the
    /// caller).
    pub fn gbuffer<E: Executor>(
        &self,
        exec: &mut E,
        f: &FrameGeometry,
        width: u32,
        height: u32,
        target: GBuffer,
    ) -> Result<(), E::Error> {
        let [nodes, tris, normals, instances, _] = self.ids();
        let p = f.gbuffer_params(width, height);
        let pass = kernels::GbufferBindings {
            nodes,
            tris,
            normals,
            instances,
            depth: target.inputs.depth,
            normal_roughness: target.inputs.normal_roughness,
            motion: target.inputs.motion,
            geometry: target.geometry,
        };
        exec.dispatch(&pass.over_grid(&p, width, height, 1))
    }
}

/// What to read back after a frame (each costs a copy from the device).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Readback {
    /// Requests, granted rays and history lengths (the debug overlays).
    pub overlays: bool,
}

/// One rendered frame, all planes stacked (`plane * width * height + pixel`).
#[derive(Clone, Debug, Default)]
pub struct FrameOutput {
    /// Denoised signal.
    pub denoised: Vec<f32>,
    /// This frame's raw samples (mean of the rays traced; 0 where none).
    pub raw: Vec<f32>,
    /// Rays traced per pixel and plane, averaged over the planes (with per-signal rates each
    /// signal traces its own count).
    pub rays: Vec<f32>,
    /// Rays traced in the frame, per plane (the sum of `rays`, rounded): one ray of every plane
    /// counts once, so coupled and per-signal rates compare at equal total rays.
    pub rays_traced: u64,
    /// The ray budget the frame ran with, rays per pixel (`rates.rays_per_pixel`, or what the
    /// budget in milliseconds decided).
    pub rays_per_pixel: f32,
    /// Milliseconds the ray-tracing passes took (`budget::trace_ms` of the executor's timings
    /// for this frame; 0 when the executor reports none).
    pub trace_ms: f64,
    /// The load balancer's decision of each signal (plane group).
    pub decisions: Vec<Balance>,
    /// The frame's budget, in rays per plane like `rays_traced` (the groups' budgets weighted by
    /// their planes, summed and rounded alike: `vrrt_core::frame::per_plane`).
    pub budget: f64,
    /// Expected rays requested, per plane.
    pub requested: f64,
    /// Expected rays granted, per plane.
    pub granted: f64,
    /// Per-pixel flags of reprojection (`requests::FLAG_*`).
    pub flags: Vec<u32>,
    /// Overlays, when asked for: requested bucket per pixel (`0xffff`: none), of the first
    /// signal (plane group 0).
    pub requests: Vec<u32>,
    /// Overlays: history length (plane 0) after accumulation.
    pub history_accumulated: Vec<f32>,
    /// Whether a temporal gradient (the prepass's, or the host's changes) was used this frame
    /// (false: off, reset, or skipped because nothing moved).
    pub gradient_ran: bool,
    /// History was reset this frame (the first frame, a camera cut): every pixel starts fresh.
    pub reset: bool,
    /// Rays the change detection traced (over all planes): the gradient prepass's re-traces and
    /// the detector's refill lists.
    pub gradient_rays: u64,
    /// Gradient cells across and down (stratum resolution).
    pub gradient_size: (u32, u32),
    /// Overlays, when the prepass ran: raw `λ` per cell and plane (plane-stacked).
    pub gradient_raw: Vec<f32>,
    /// Overlays, when the prepass ran: reconstructed `λ` per cell and plane.
    pub gradient: Vec<f32>,
    /// The change detector's `λ` per pixel and plane (plane-stacked), when kept
    /// ([`Renderer::keep_changes`]) and the detector ran this frame; empty otherwise.
    pub changes: Vec<f32>,
    /// The frame's signal has no source (shadows without a light): nothing was traced or
    /// denoised, `denoised` is all 1 (unshadowed), and the next frame with a source starts fresh.
    pub signal_absent: bool,
    /// 8×8 tiles of the spatial filter (`Denoiser::tile_histogram`): without geometry, then
    /// needing 0, 1, … 5 à-trous iterations.
    pub tiles: [u32; classify::HISTOGRAM_LEN as usize],
    /// À-trous iterations the frame dispatched (`Denoiser::filter_iterations`).
    pub filter_iterations: u32,
}

impl FrameOutput {
    /// À-trous tile-iterations over the tiles with geometry: `(run, configured)`, where every such
    /// tile would run the frame's `filter_iterations` with nothing skipped (`classify` never
    /// asks for more).
    pub fn filter_work(&self) -> (u64, u64) {
        let mut work = (0, 0);
        for n in 0..=5 {
            let tiles = self.tiles[1 + n] as u64;
            work.0 += tiles * n as u64;
            work.1 += tiles * self.filter_iterations as u64;
        }
        work
    }
}

/// Runs a scene frame by frame through core's frame pipeline and reads the outputs back.
///
/// A built-in scene's ambient occlusion, denoised on the CPU backend (any `Executor` works):
///
/// ```
/// use vrrt_core::settings::Settings;
/// use vrrt_cpu::CpuExecutor;
/// use vrrt_scene::builtin::builtin;
/// use vrrt_scene::render::{Readback, Renderer, Signal};
///
/// let scene = builtin("room")?;
/// let (width, height) = (48, 27);
/// let mut cpu = CpuExecutor::new();
/// let signal = Signal::Ao { max_distance: 1.0 };
/// let mut renderer = Renderer::new(&mut cpu, width, height, signal, 0, Settings::default())?;
/// for i in 0..3 {
///     let out = renderer.render(&mut cpu, &scene.frame(i), Readback::default())?;
///     assert_eq!(out.denoised.len(), (width * height) as usize);
///     assert!(out.denoised.iter().all(|ao| (0.0..=1.0).contains(ao)));
///     println!("frame {i}: {} rays", out.rays_traced);
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Renderer {
    frame: Frame,
    gpu: GpuScene,
}

impl Renderer {
    /// A renderer for `width × height` with denoiser `settings` (see `Frame::new`: the plane
    /// count and parallax plane come from the signal and the number of lights).
    pub fn new<E: Executor>(
        exec: &mut E,
        width: u32,
        height: u32,
        signal: Signal,
        lights: usize,
        settings: Settings,
    ) -> Result<Self, DenoiserError<E::Error>> {
        let frame = Frame::new(exec, width, height, signal, lights, settings)?;
        Ok(Renderer {
            frame,
            gpu: GpuScene::default(),
        })
    }

    /// The controller of the budget in milliseconds, when `rates.budget_ms` is set.
    pub fn budget(&self) -> Option<&MsBudget> {
        self.frame.budget()
    }

    /// The reflection effect, when the signal has reflections.
    pub fn reflections(&self) -> Option<&Reflections> {
        self.frame.reflections()
    }

    /// The denoiser (buffers, settings).
    pub fn denoiser(&self) -> &Denoiser {
        self.frame.denoiser()
    }

    /// Reads back the change detector's `λ` with every frame from now on
    /// ([`FrameOutput::changes`]; 4 bytes per pixel and plane more on the device).
    pub fn keep_changes<E: Executor>(&mut self, exec: &mut E) -> Result<(), E::Error> {
        self.frame.keep_changes(exec).map(|_| ())
    }

    /// Records and submits one frame's passes and reads nothing back: for timing runs
    /// (`vrrt bench --passes`), where a readback after every frame leaves a GPU idle between
    /// frames long enough for its clocks to fall (see `docs/results/per-pass.md`). The budget in
    /// milliseconds is not updated.
    pub fn render_unread<E: Executor>(
        &mut self,
        exec: &mut E,
        f: &FrameGeometry,
    ) -> Result<(), E::Error> {
        self.dispatch(exec, f, None).map(|_| ())
    }

    /// Uploads the scene of frame `f` and records the frame's passes.
    fn dispatch<E: Executor>(
        &mut self,
        exec: &mut E,
        f: &FrameGeometry,
        changes: Option<&[GradientSample]>,
    ) -> Result<FrameReport, E::Error> {
        let (w, h) = self.frame.denoiser().size();
        self.gpu.upload(exec, f)?;
        let gpu = &self.gpu;
        let scene = FrameScene {
            changes,
            ..gpu.frame_scene(f)
        };
        self.frame.render(exec, &scene, |exec, target| {
            gpu.gbuffer(exec, f, w, h, target)
        })
    }

    /// Renders one frame and reads back its outputs. [`Frame::finish`] completes the frame: the
    /// rays it traced and its tracing time (from the executor's timings, which this does not
    /// clear), and with a budget in milliseconds the next frame's budget.
    pub fn render<E: Executor>(
        &mut self,
        exec: &mut E,
        f: &FrameGeometry,
        readback: Readback,
    ) -> Result<FrameOutput, DenoiserError<E::Error>> {
        self.render_with_changes(exec, f, readback, None)
    }

    /// [`Self::render`] with the host's knowledge of where the signal changed
    /// ([`FrameScene::changes`]: one `GradientSample` per cell of the denoiser's
    /// `gradient_size()` and plane), which replaces the temporal-gradient prepass.
    pub fn render_with_changes<E: Executor>(
        &mut self,
        exec: &mut E,
        f: &FrameGeometry,
        readback: Readback,
        changes: Option<&[GradientSample]>,
    ) -> Result<FrameOutput, DenoiserError<E::Error>> {
        let (w, h) = self.frame.denoiser().size();
        let planes = self.frame.layout().planes;
        let rays_per_pixel = self.frame.denoiser().rays_per_pixel();
        let report = self.dispatch(exec, f, changes)?;
        if report.absent {
            return Ok(FrameOutput {
                denoised: vec![1.0; (w * h * planes) as usize],
                raw: vec![1.0; (w * h * planes) as usize],
                rays: vec![0.0; (w * h) as usize],
                rays_per_pixel,
                signal_absent: true,
                ..FrameOutput::default()
            });
        }
        let mut out = self.read_outputs(exec, report, readback, changes, rays_per_pixel)?;
        // After every readback: a budget in milliseconds sets the next frame's ray budget.
        let report = self.frame.finish(exec, report)?;
        out.rays_traced = report.rays_traced;
        out.trace_ms = report.trace_ms;
        Ok(out)
    }

    /// The outputs of a frame that ran ([`FrameOutput`], but for what [`Frame::finish`] adds).
    fn read_outputs<E: Executor>(
        &self,
        exec: &mut E,
        report: FrameReport,
        readback: Readback,
        changes: Option<&[GradientSample]>,
        rays_per_pixel: f32,
    ) -> Result<FrameOutput, E::Error> {
        let (w, h) = self.frame.denoiser().size();
        let planes = self.frame.layout().planes;
        let d = self.frame.denoiser();
        let GradientReadback {
            rays: mut gradient_rays,
            size: gradient_size,
            overlays: gradient_overlays,
        } = self.read_gradient(exec, report, readback, changes)?;
        let n = (w * h * planes) as usize;
        let detected = match d.changes() {
            Some(b) => read(exec, b, n)?,
            None => Vec::new(),
        };
        let denoised: Vec<PackedFiltered> = read(exec, d.output(), n)?;
        let samples: Vec<Sample> = unpack_samples(&read(exec, d.samples(), n)?);
        let layout = d.layout();
        let groups = layout.groups();
        let group_rays = d.read_rays(exec)?;
        let decisions: Vec<Balance> = read(exec, d.decision(), groups as usize)?;
        let per_plane = PlaneRays::new(layout, &group_rays, &decisions, (w * h) as usize);
        // Resolve does not write the requests (with the flags).
        let requests: Vec<u32> = read(exec, d.requests(), (w * h) as usize)?;
        let flags = requests
            .iter()
            .map(|&r| kernels::requests::flags_of(r))
            .collect();
        let tiles: Vec<u32> = read(exec, d.tile_histogram(), classify::HISTOGRAM_LEN as usize)?;
        // The refill lists' rays (`Denoiser::detect_changes`), as `refill::fit` gave them, per
        // plane of their group: in the total, and with the prepass's when they are the
        // detector's (not a reset frame's penumbrae).
        let refill_rays: u64 = (0..groups)
            .map(|g| {
                decisions[g as usize].refill_traced as u64
                    * group_planes(layout.plane_groups, planes, g) as u64
            })
            .sum();
        if !d.refills_reset() {
            gradient_rays += refill_rays;
        }
        let mut out = FrameOutput {
            denoised: denoised.iter().map(|f| f.unpack().value).collect(),
            raw: samples
                .iter()
                .map(|s| if s.rays > 0 { s.m1 } else { 0.0 })
                .collect(),
            rays_per_pixel,
            rays: per_plane.rays,
            decisions,
            budget: per_plane.budget,
            requested: per_plane.requested,
            granted: per_plane.granted,
            flags,
            gradient_ran: report.gradient_ran,
            reset: report.reset,
            gradient_rays,
            gradient_size,
            gradient_raw: gradient_overlays.0,
            gradient: gradient_overlays.1,
            changes: detected,
            tiles: tiles.try_into().expect("histogram length"),
            filter_iterations: d.filter_iterations(),
            ..FrameOutput::default()
        };
        if readback.overlays {
            let pixels = (w * h) as usize;
            let history: Vec<PackedPayload> = read(exec, d.history(), pixels)?;
            out.requests = requests
                .iter()
                .map(|&r| kernels::requests::bucket_of(r))
                .collect();
            out.history_accumulated = history.iter().map(|p| p.unpack().count).collect();
        }
        Ok(out)
    }

    /// The temporal-gradient prepass's rays (cells re-traced, per plane) this frame, the
    /// gradient grid's size and, with overlays, its raw and reconstructed `λ`.
    fn read_gradient<E: Executor>(
        &self,
        exec: &mut E,
        report: FrameReport,
        readback: Readback,
        changes: Option<&[GradientSample]>,
    ) -> Result<GradientReadback, E::Error> {
        let d = self.frame.denoiser();
        let planes = self.frame.layout().planes;
        let mut gradient_rays = 0;
        let gradient_size = d.gradient_size();
        let mut gradient_overlays = (Vec::new(), Vec::new());
        // Supplied changes trace no rays (and leave the prepass's keys unwritten).
        if report.gradient_ran && changes.is_none() {
            let cells = (gradient_size.0 * gradient_size.1) as usize;
            let keys: Vec<u32> = read(exec, d.gradient_keys(), cells)?;
            gradient_rays = keys.iter().filter(|&&k| k != EMPTY_KEY).count() as u64 * planes as u64;
            if readback.overlays {
                let lambda = |g: Vec<GradientSample>| g.iter().map(|g| g.lambda()).collect();
                let n = cells * planes as usize;
                gradient_overlays = (
                    lambda(read(exec, d.gradient_raw(), n)?),
                    lambda(read(exec, d.gradient(), n)?),
                );
            }
        }
        Ok(GradientReadback {
            rays: gradient_rays,
            size: gradient_size,
            overlays: gradient_overlays,
        })
    }
}

/// What [`Renderer::read_outputs`] reads of the temporal-gradient prepass.
struct GradientReadback {
    /// Cells re-traced, times the planes.
    rays: u64,
    /// The gradient grid, cells.
    size: (u32, u32),
    /// Raw and reconstructed `λ` per cell and plane, with overlays (else empty).
    overlays: (Vec<f32>, Vec<f32>),
}

/// The samples of a packed samples buffer's contents.
fn unpack_samples(packed: &[PackedSample]) -> Vec<Sample> {
    packed.iter().map(|s| s.unpack()).collect()
}

/// Adds a batch's samples, weighted by their rays, to the per-cell sums of the ray results. On a
/// GPU backend this host-side loop over every pixel of every batch is most of a reference's
/// time, so it runs on all cores.
fn accumulate(samples: &[PackedSample], sum: &mut [f64]) {
    const CHUNK: usize = 1 << 14;
    samples
        .par_chunks(CHUNK)
        .zip(sum.par_chunks_mut(CHUNK))
        .for_each(|(samples, sum)| {
            for (packed, s) in samples.iter().zip(sum) {
                let sample = packed.unpack();
                *s += f64::from(sample.m1) * f64::from(sample.rays);
            }
        });
}

/// A converged reference and its own Monte Carlo error.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Mean per pixel and plane.
    pub mean: Vec<f32>,
    /// Standard error of the mean per pixel and plane (NaN from a single sample: unknown).
    pub stderr: Vec<f32>,
    /// Samples per pixel.
    pub spp: u32,
}

/// rng indices of reference rays start here, far from any index a denoised frame uses, so the
/// reference is independent of the frames it judges. The packed history holds 16 bits of rng
/// index: denoised frames start from the frame number and advance by the rays traced (a few
/// thousand over a bench sequence), references use the upper half (up to 32768 spp without
/// wrapping).
pub const REFERENCE_RNG_BASE: u32 = 1 << 15;

/// Independent replicates a reference traces its planes in, when its samples divide into them
/// (else as many as a power of two does). A ray's first two random numbers follow each pixel's
/// low-discrepancy sequence ([`REPLICATE_PATTERN`]: AO's hemisphere, a shadow's light point, a
/// reflection's lobe), whose mean is more accurate than as many independent samples, and more
/// so than the samples' own spread says (it overstated the reflections' 256-spp error about
/// twofold). Replicate `j` rotates the sequence anew (`frame` = `j`) and takes the next
/// `spp / REPLICATES` rng indices, so the replicates' means are independent and their spread is
/// the mean's error (randomised quasi-Monte Carlo).
pub const REPLICATES: u32 = 8;

/// The replicates a reference of `spp` samples traces its planes in: the largest power of two
/// up to [`REPLICATES`] that divides `spp` (1, an odd `spp`: the per-pixel pattern in one run,
/// whose error is not estimated).
fn replicates(spp: u32) -> u32 {
    1 << spp.max(1).trailing_zeros().min(REPLICATES.trailing_zeros())
}

/// A reference's replicates ([`replicates`] of them, `rays` samples each): the sums at the
/// current replicate's start and the sum of the replicates' squared means, per pixel and plane.
struct ReplicateSums {
    count: u32,
    rays: f64,
    start: Vec<f64>,
    squares: Vec<f64>,
}

impl ReplicateSums {
    fn new(n: usize, spp: u32) -> Self {
        let count = replicates(spp);
        ReplicateSums {
            count,
            rays: f64::from(spp / count),
            start: vec![0.0; n],
            squares: vec![0.0; n],
        }
    }

    /// Ends a replicate whose samples the sums `sum` now include.
    fn close(&mut self, sum: &[f64]) {
        let rays = self.rays;
        for ((s, start), sq) in sum.iter().zip(&mut self.start).zip(&mut self.squares) {
            let mean = (s - *start) / rays;
            *sq += mean * mean;
            *start = *s;
        }
    }

    /// The standard error of cell `k`'s mean `mean` over the replicates (NaN below two:
    /// one sequence has no spread to measure).
    fn stderr(&self, k: usize, mean: f64) -> f32 {
        if self.count < 2 {
            return f32::NAN;
        }
        let r = f64::from(self.count);
        ((self.squares[k] / r - mean * mean).max(0.0) / (r - 1.0)).sqrt() as f32
    }
}

/// The executor buffers of reference renders, kept from one call of [`reference_with`] to the
/// next on the same executor. Executors have no call that frees a buffer, so a reference that
/// made its own each time would keep every frame's copy of the geometry (about 90 bytes a
/// triangle on the CPU backend) and its per-pixel buffers until the executor is dropped.
#[derive(Default)]
pub struct ReferenceBuffers {
    gpu: GpuScene,
    sized: Option<SizedBuffers>,
}

/// The buffers of one image size and signal.
struct SizedBuffers {
    key: (u32, u32, Signal, usize, ReflectionSettings),
    gbuffer: GBuffer,
    work: BufferId,
    args: BufferId,
    history: BufferId,
    out: BufferId,
    blockers: BufferId,
    reflections: Option<Reflections>,
}

impl SizedBuffers {
    fn create<E: Executor>(
        exec: &mut E,
        key: (u32, u32, Signal, usize, ReflectionSettings),
    ) -> Result<SizedBuffers, DenoiserError<E::Error>> {
        let (width, height, signal, lights, reflections) = key;
        let pixels = (width * height) as usize;
        let n = pixels * signal.planes(lights) as usize;
        let layout = signal.layout(lights);
        let args = exec.create_buffer(16)?;
        exec.write_buffer(
            args,
            bytes(&[pixels as u32, (pixels as u32).div_ceil(LIST_GROUP), 1, 1]),
        )?;
        Ok(SizedBuffers {
            key,
            gbuffer: GBuffer::create(exec, width, height)?,
            work: exec.create_buffer(pixels as u64 * 4)?,
            args,
            history: exec.create_buffer((n * std::mem::size_of::<PackedPayload>()) as u64)?,
            out: exec.create_buffer((n * std::mem::size_of::<PackedSample>()) as u64)?,
            // References record no blockers: one element, never written.
            blockers: exec.create_buffer(4)?,
            reflections: match layout.reflections {
                Some(plane) => Some(Reflections::new(exec, width, height, plane, reflections)?),
                None => None,
            },
        })
    }
}

/// What a reference traces: the signal, the reflections' settings (read only when the signal
/// has reflections) and the rays per pixel.
#[derive(Copy, Clone, Debug)]
pub struct ReferenceSpec<'a> {
    /// The signal traced.
    pub signal: Signal,
    /// How reflections are traced and shaded.
    pub reflections: &'a ReflectionSettings,
    /// Rays per pixel.
    pub spp: u32,
}

/// Traces `spec.spp` rays per pixel of frame `f` at `(width, height)` with the raygen kernels
/// (the same estimator the denoiser sees) in passes of up to `MAX_RATE` (16) rays, calling
/// `progress(done, spp)` after each, in [`REPLICATES`] replicates.
/// Its buffers are new and stay on `exec`: for more than one reference on an executor use
/// [`reference_with`].
pub fn reference<E: Executor>(
    exec: &mut E,
    f: &FrameGeometry,
    size: (u32, u32),
    spec: ReferenceSpec<'_>,
    progress: impl FnMut(u32, u32),
) -> Result<Reference, DenoiserError<E::Error>> {
    let mut buffers = ReferenceBuffers::default();
    reference_with(exec, &mut buffers, f, size, spec, progress)
}

/// [`reference()`] with the buffers of `buffers`, which must have been used on `exec` only: the
/// geometry is uploaded again only when the frame's differs, the per-pixel buffers made again
/// only for another size or signal.
pub fn reference_with<E: Executor>(
    exec: &mut E,
    buffers: &mut ReferenceBuffers,
    f: &FrameGeometry,
    (width, height): (u32, u32),
    spec: ReferenceSpec<'_>,
    mut progress: impl FnMut(u32, u32),
) -> Result<Reference, DenoiserError<E::Error>> {
    let ReferenceSpec {
        signal,
        reflections,
        spp,
    } = spec;
    let pixels = (width * height) as usize;
    let planes = signal.planes(f.lights.len());
    let n = pixels * planes as usize;
    let gpu = &mut buffers.gpu;
    gpu.upload(exec, f)?;
    let key = (width, height, signal, f.lights.len(), *reflections);
    if buffers.sized.as_ref().is_none_or(|b| b.key != key) {
        buffers.sized = Some(SizedBuffers::create(exec, key)?);
    }
    let b = buffers.sized.as_ref().expect("just made");
    let (gbuffer, work, args, history, out, blockers) =
        (b.gbuffer, b.work, b.args, b.history, b.out, b.blockers);
    let reflections = b.reflections.as_ref();
    let view = View {
        camera: f.camera,
        prev_camera: f.prev_camera,
    };
    exec.write_buffer(gbuffer.view, bytemuck::bytes_of(&view))?;
    gpu.gbuffer(exec, f, width, height, gbuffer)?;
    let layout = signal.layout(f.lights.len());
    let mut sum = vec![0.0f64; n];
    let mut replicates = ReplicateSums::new(n, spp);
    let count = replicates.count;
    let mut done = 0u32;
    // The work list changes only with the batch's size (the last batch may be smaller).
    let mut listed = 0;
    for replicate in 0..count {
        let end = done + spp / count;
        while done < end {
            // A work-list entry carries at most `MAX_RATE` rays.
            let batch = (end - done).min(MAX_RATE);
            if batch != listed {
                let entries: Vec<u32> = (0..pixels as u32).map(|i| work_entry(i, batch)).collect();
                exec.write_buffer(work, bytes(&entries))?;
                listed = batch;
            }
            let start = REFERENCE_RNG_BASE + done;
            let hist: Vec<PackedPayload> = vec![
                Payload {
                    rng_index: start,
                    ..Payload::default()
                }
                .pack();
                n
            ];
            exec.write_buffer(history, bytes(&hist))?;
            let target = RaygenTarget {
                size: (width, height),
                work,
                args,
                gbuffer,
                history,
                out,
                blockers,
                blocker_plane: reproject::NO_PLANE,
                frame: replicate,
                plane_groups: 0,
                // References keep the per-pixel sequences (rotated per replicate): the pattern under
                // test never judges itself.
                sampling: if count > 1 { REPLICATE_PATTERN } else { 0 },
                merge: false,
            };
            let scene = gpu.frame_scene(f);
            trace_planes(exec, signal, &layout, &scene, reflections, &target)?;
            accumulate(&read(exec, out, n)?, &mut sum);
            done += batch;
            progress(done, spp);
        }
        replicates.close(&sum);
    }
    Ok(Reference::from_sums(spp, &sum, &replicates))
}

impl Reference {
    /// The mean of `spp` samples per cell from the sums of the samples, and its standard error
    /// from the replicates'.
    fn from_sums(spp: u32, sum: &[f64], replicates: &ReplicateSums) -> Reference {
        let k = spp.max(1) as f64;
        let mean = sum.iter().map(|s| (s / k) as f32).collect();
        let stderr = sum
            .iter()
            .enumerate()
            .map(|(i, s)| replicates.stderr(i, s / k))
            .collect();
        Reference { mean, stderr, spp }
    }
}

/// A frame's rays and budget counted per plane of the frame: a group's ray costs one ray of
/// each of its planes, so a shadow ray of one of three lights is a third of an AO ray.
struct PlaneRays {
    /// Each pixel's rays (`Denoiser::read_rays`, group-major, summed over the groups).
    rays: Vec<f32>,
    /// What the frame may trace, its refill lists included (`Balance::allowed`), counted as
    /// the frame's rays are (`vrrt_core::frame::per_plane`).
    budget: f64,
    requested: f64,
    granted: f64,
}

impl PlaneRays {
    fn new(layout: &Layout, group_rays: &[u32], decisions: &[Balance], pixels: usize) -> Self {
        let (groups, planes) = (layout.groups(), layout.planes);
        let weight: Vec<f64> = (0..groups)
            .map(|g| group_planes(layout.plane_groups, planes, g) as f64 / planes as f64)
            .collect();
        let rays = (0..pixels)
            .map(|i| {
                let per_group = group_rays.iter().skip(i).step_by(pixels);
                per_group
                    .zip(&weight)
                    .map(|(&r, &c)| r as f64 * c)
                    .sum::<f64>() as f32
            })
            .collect();
        let weighted = |f: fn(&Balance) -> f32| -> f64 {
            decisions
                .iter()
                .zip(&weight)
                .map(|(d, &c)| f(d) as f64 * c)
                .sum()
        };
        PlaneRays {
            rays,
            budget: vrrt_core::frame::per_plane(layout, decisions, |d| d.allowed) as f64,
            requested: weighted(|d| d.requested),
            granted: weighted(|d| d.granted),
        }
    }
}
