//! The denoiser as a frame plan: which passes run, in which order, on which buffers, with which
//! parameters. Backends only execute the passes it hands them.
//!
//! Per frame (seed vrrt-call-of-duty-2026, "Full pipeline"; SVGF from q2vkpt-2019):
//!
//! ```text
//! G-buffer ─► reproject ─► fill ─► count_buckets ─► balance ─► apply ─► raygen ─► accumulate ─► variance ─► atrous × N
//! (caller)    + requests   counts=0   histogram      thresholds  work list  (caller,   history[cur]   filtered ping-pong
//!             history[prev] → history[cur]                       + rays     indirect)  in place
//! ```
//!
//! The ray budget is decided before raygen: reprojection asks for a rate per pixel (refill lost
//! history, undersample converged pixels), the balancer fits the requests to
//! `rays_per_pixel × pixels`, apply grants each pixel its rays and compacts a work list. The
//! fixed-rate SVGF baseline is the same plan with requests off (every pixel asks for
//! `rays_per_pixel`) and no balancing.
//!
//! Temporal gradients (A-SVGF, optional: [`PrepassSettings`](crate::settings::PrepassSettings))
//! run as a prepass between the G-buffer and reprojection ([`Denoiser::temporal_gradients`]):
//! project last frame's samples forward, re-trace them against this frame's scene, blur the
//! change at stratum resolution; reprojection then shortens or drops history where the signal
//! changed, and VRRT supersamples there. It is skipped when nothing moved (the host says so in
//! [`FrameInfo::moved`]).
//!
//! History is ping-ponged explicitly: reprojection reads `history[prev]` (its 2×2 footprints
//! need last frame's intact) and writes `history[cur]`, which raygen reads for its rng indices
//! and accumulation then updates in place; the spatial filter's output never feeds back into
//! history (seed: "spatial output is NOT being fed to temporal"). On the AO planes the spatial
//! filter runs on the history divided by the AO guide (`kernels::ao_guide`), written to
//! `history[prev]`, which reprojection has spent, and multiplies its output back.

mod gradients;
mod rates;
mod resolve;

pub use crate::layout::Layout;

use crate::blue_noise;
use crate::buffers::{self, TooLarge};
use crate::camera::View;
use crate::executor::{BufferId, Executor, Groups};
use crate::inputs::{ConventionError, InputConventions};
use crate::kernels::gradient;
use crate::kernels::{
    self, accumulate, ao_guide, apply, atrous, balance, buckets, classify, detect, fill, penumbra,
    refill, reproject, trim, variance, work_list,
};
use crate::payload::COUNTERS_LEN;
use crate::settings::{RateSettings, Settings, SettingsError};
use core::fmt;

/// A denoiser failure: bad settings or a backend error.
#[derive(Debug)]
pub enum DenoiserError<E> {
    /// Settings or resolution out of range.
    Settings(SettingsError),
    /// The buffers of this size do not fit the device.
    TooLarge(TooLarge),
    /// The backend failed.
    Backend(E),
}

impl<E: fmt::Display> fmt::Display for DenoiserError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DenoiserError::Settings(e) => write!(f, "{e}"),
            DenoiserError::TooLarge(e) => write!(f, "{e}"),
            DenoiserError::Backend(e) => write!(f, "backend: {e}"),
        }
    }
}

impl<E: fmt::Debug + fmt::Display> core::error::Error for DenoiserError<E> {}

impl<E> From<E> for DenoiserError<E> {
    fn from(e: E) -> Self {
        DenoiserError::Backend(e)
    }
}

/// Per-frame inputs that are not images. `Default` is frame 0 with every flag off and a zero
/// `pixel_angle`, so callers name the fields they set and stay valid when fields are added.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct FrameInfo {
    /// Frame number; seeds the rng index of pixels whose history was lost.
    pub index: u32,
    /// First frame or camera cut: discard all history.
    pub reset: bool,
    /// Angle one pixel subtends, radians (`2·tan(fov_y/2) / height`): scales plane tolerances.
    pub pixel_angle: f32,
    /// Something moved since last frame (camera, objects or lights). When false the
    /// temporal-gradient prepass is skipped: every re-trace would return last frame's value.
    pub moved: bool,
    /// Scale the ray requests of this plane's group by the pixel's tile's
    /// [`Denoiser::importance`], which the caller wrote this frame (the reflection tile
    /// classification, for the reflection plane).
    pub importance_plane: Option<u32>,
    /// This frame's and last frame's camera: positions are reconstructed from view depth through
    /// them, and last frame's from the motion's depth change.
    pub view: View,
}

/// The engine's per-pixel inputs, one buffer each (formats in [`crate::packing`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Inputs {
    /// Linear view depth, `f32` per pixel; 0 or +∞ where there is no surface.
    pub depth: BufferId,
    /// Shading normal (octahedral 11+11 bits) and linear roughness (10 bits), `u32` per pixel.
    pub normal_roughness: BufferId,
    /// 2.5D motion to last frame as RGBA16F (`dx, dy` in pixels, view-depth change, 0), two
    /// `u32` per pixel.
    pub motion: BufferId,
}

/// The engine's own G-buffer textures, which [`Denoiser::ingest`] reads in the engine's
/// conventions (`Access::Sampled` bindings: textures the backend imported, e.g.
/// `WgpuExecutor::import_texture`, or `CpuExecutor::create_texture`). Built by
/// [`EngineTextures::new`], which refuses conventions that cannot be decoded.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct EngineTextures {
    depth: BufferId,
    normal_roughness: BufferId,
    motion: BufferId,
    conventions: InputConventions,
}

impl EngineTextures {
    /// Depth (red channel), normal + roughness and motion textures in `conventions`.
    pub fn new(
        depth: BufferId,
        normal_roughness: BufferId,
        motion: BufferId,
        conventions: InputConventions,
    ) -> Result<Self, ConventionError> {
        conventions.validate()?;
        Ok(EngineTextures {
            depth,
            normal_roughness,
            motion,
            conventions,
        })
    }

    /// The conventions the textures are read in.
    pub fn conventions(&self) -> &InputConventions {
        &self.conventions
    }

    /// Records the `ingest` pass that decodes these textures into `inputs` of a `width × height`
    /// image, with the cameras of `view`: what [`Denoiser::ingest`] records into its own where
    /// the inputs are read before reprojection. For a renderer inside
    /// [`crate::frame::Frame::render`], whose G-buffer closure is handed this frame's inputs and
    /// view (`frame::GBuffer`) while the frame holds the denoiser.
    pub fn ingest<E: Executor>(
        &self,
        exec: &mut E,
        inputs: Inputs,
        view: BufferId,
        (width, height): (u32, u32),
    ) -> Result<(), E::Error> {
        let params = self.conventions.params(width, height);
        let ingest = kernels::IngestBindings {
            engine_depth: self.depth,
            engine_normal: self.normal_roughness,
            engine_motion: self.motion,
            view,
            depth: inputs.depth,
            normal_roughness: inputs.normal_roughness,
            motion: inputs.motion,
        };
        exec.dispatch(&ingest.over_grid(&params, width, height, 1))
    }
}

/// What the temporal-gradient prepass re-traces against: this frame's scene on the executor.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct GradientScene {
    /// BVH nodes of this frame's geometry.
    pub nodes: BufferId,
    /// Triangles of this frame's geometry.
    pub tris: BufferId,
    /// Per-instance previous→current maps (`InstanceData`, the inverse of the G-buffer's).
    pub next: BufferId,
    /// The renderer's `geometry` (geometric normal, instance) of this frame and last frame.
    pub geometry: [BufferId; 2],
    /// The signal's rays.
    pub rays: GradientRays,
}

/// Which raygen the gradient pass re-creates.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum GradientRays {
    /// Ambient occlusion with this radius.
    Ao {
        /// AO radius.
        max_distance: f32,
    },
    /// Area-light shadows, one light (`AreaLight`) per plane.
    Shadows {
        /// This frame's lights.
        lights: BufferId,
    },
}

/// The buffers of one denoiser instance and the passes that run on them.
///
/// A frame is four calls, the same on every backend (`vrrt-cpu`'s `CpuExecutor`, `vrrt-wgpu`'s
/// `WgpuExecutor`, `vrrt-ash`'s `AshExecutor`); this one traces on the host (the CPU backend's
/// docs run it):
///
/// ```
/// use vrrt_core::denoiser::{Denoiser, FrameInfo};
/// use vrrt_core::payload::{PackedFiltered, PackedSample};
/// use vrrt_core::executor::Executor;
///
/// /// One frame of the application's G-buffer, in the formats of `vrrt_core::packing`.
/// struct GBuffer {
///     depth: Vec<f32>,
///     normal_roughness: Vec<u32>,
///     motion: Vec<[u32; 2]>,
/// }
///
/// /// Denoises one frame; `trace` is the application's ray tracer: `rays[i]` rays at pixel `i`
/// /// (per plane), their moments back as one sample each.
/// fn denoise<E: Executor>(
///     exec: &mut E,
///     denoiser: &mut Denoiser,
///     frame: FrameInfo,
///     g: &GBuffer,
///     trace: impl FnOnce(&[u32]) -> Vec<PackedSample>,
/// ) -> Result<Vec<f32>, E::Error> {
///     // 1. The cameras, then the G-buffer into the denoiser's input buffers.
///     denoiser.begin_frame(exec, frame)?;
///     let inputs = denoiser.inputs();
///     exec.write_buffer(inputs.depth, bytemuck::cast_slice(&g.depth))?;
///     exec.write_buffer(inputs.normal_roughness, bytemuck::cast_slice(&g.normal_roughness))?;
///     exec.write_buffer(inputs.motion, bytemuck::cast_slice(&g.motion))?;
///     // 2. How many rays each pixel traces this frame, within the budget.
///     denoiser.plan_rays(exec)?;
///     let rays = denoiser.read_rays(exec)?;
///     // 3. The noisy samples.
///     exec.write_buffer(denoiser.samples(), bytemuck::cast_slice(&trace(&rays)))?;
///     // 4. Accumulate and filter; read the denoised planes back.
///     denoiser.resolve(exec)?;
///     let (w, h) = denoiser.size();
///     let len = (w * h * denoiser.layout().planes) as usize;
///     let mut out = vec![PackedFiltered::default(); len];
///     exec.read_buffer(denoiser.output(), bytemuck::cast_slice_mut(&mut out))?;
///     Ok(out.iter().map(|f| f.unpack().value).collect())
/// }
/// ```
///
/// A GPU ray pass reads the work list ([`Denoiser::work`], [`Denoiser::args`]) on the device
/// instead of `read_rays`, and engines that record their own command buffers capture the passes
/// (see the `examples/` crate of the repository).
#[derive(Clone, Debug)]
pub struct Denoiser {
    settings: Settings,
    layout: Layout,
    /// This frame's ray budget in rays per pixel: `rates.rays_per_pixel` until
    /// [`Self::set_rays_per_pixel`] changes it (a budget in milliseconds does, every frame).
    rays_per_pixel: f32,
    width: u32,
    height: u32,
    depth: [BufferId; 2],
    normal_roughness: [BufferId; 2],
    motion: BufferId,
    view: BufferId,
    /// The engine textures' conventions (`IngestParams`), for `reproject_engine`.
    conventions: BufferId,
    /// What `conventions` holds, so that an engine's unchanged conventions are not uploaded
    /// again every frame.
    conventions_written: Option<crate::inputs::IngestParams>,
    /// The engine's textures this frame, read by reprojection ([`Self::ingest`]).
    engine: Option<EngineTextures>,
    history: [BufferId; 2],
    samples: BufferId,
    filtered: [BufferId; 2],
    mask: BufferId,
    requests: BufferId,
    counts: BufferId,
    decision: BufferId,
    /// The trim's histograms ([`trim`]).
    trim: BufferId,
    /// The refill lists' histograms ([`refill::fit`]).
    refill_hist: BufferId,
    noise: BufferId,
    args: BufferId,
    refill_args: BufferId,
    counters: BufferId,
    gradient_keys: BufferId,
    gradient_raw: BufferId,
    gradient: [BufferId; 2],
    gradient_out: usize,
    gradient_ran: bool,
    /// This frame's change detector ran ([`Self::detect_changes`]).
    detected: bool,
    kept_changes: Option<BufferId>,
    tiles: BufferId,
    tile_histogram: BufferId,
    importance: BufferId,
    parallax: BufferId,
    guide: BufferId,
    blockers: BufferId,
    penumbra: BufferId,
    /// The AO guide (`kernels::ao_guide`), binary16 per pixel with AO planes and the guide on.
    ao_guide: BufferId,
    /// The AO guide's raw fractions, this frame's (`cur`) and last frame's, when it is kept
    /// across frames (`filter.ao_guide_refresh`).
    ao_guide_raw: [BufferId; 2],
    /// The AO rays' length, which the AO guide marches to (0 until [`Self::set_ao_radius`]: no
    /// guide).
    ao_radius: f32,
    /// Bound where a pass does not read a binding in this configuration (`buffers`' `unread`).
    unread: [BufferId; 2],
    cur: usize,
    out: usize,
    frame: FrameInfo,
    /// Last frame's index: the gradient pass re-creates that frame's rays.
    prev_frame: u32,
    /// Frames since the last reset (`rates.reset_boost` is paid back over the next ones).
    since_reset: u32,
}

impl Denoiser {
    /// Validates `settings` and allocates every buffer for a `width × height` image of one plane
    /// ([`Layout::default`]).
    pub fn new<E: Executor>(
        exec: &mut E,
        width: u32,
        height: u32,
        settings: Settings,
    ) -> Result<Self, DenoiserError<E::Error>> {
        Self::with_layout(exec, width, height, Layout::default(), settings)
    }

    /// Validates `layout` and `settings` and allocates every buffer for a `width × height` image
    /// of `layout.planes` planes.
    pub fn with_layout<E: Executor>(
        exec: &mut E,
        width: u32,
        height: u32,
        layout: Layout,
        settings: Settings,
    ) -> Result<Self, DenoiserError<E::Error>> {
        if width == 0 || height == 0 || width as u64 * height as u64 > work_list::MAX_PIXELS {
            return Err(DenoiserError::Settings(SettingsError::Resolution {
                width,
                height,
            }));
        }
        layout.validate().map_err(DenoiserError::Settings)?;
        settings.validate().map_err(DenoiserError::Settings)?;
        let sizes = buffers::denoiser_buffers(width, height, &layout, &settings);
        buffers::check_fit(width, height, &layout, &settings, exec.binding_limit())
            .map_err(DenoiserError::TooLarge)?;
        let mut ids = [[BufferId(0); 2]; buffers::DENOISER_BUFFERS];
        for (slot, b) in ids.iter_mut().zip(&sizes) {
            for id in &mut slot[..b.count as usize] {
                *id = exec.create_buffer(b.bytes)?;
            }
        }
        let id = |name: &str| ids[sizes.iter().position(|b| b.name == name).expect(name)];
        let noise = id("noise")[0];
        exec.write_buffer(noise, bytemuck::cast_slice(&blue_noise::generate_mask()))?;
        let counters = id("counters")[0];
        exec.write_buffer(counters, &[0; COUNTERS_LEN as usize * 4])?;
        // The first balancer reads it as last frame's refill counts.
        let refill_args = id("refill_args")[0];
        let zeros = [0u8; (balance::MAX_GROUPS * work_list::ARGS_LEN * 4) as usize];
        let args_bytes = (layout.groups() * work_list::ARGS_LEN * 4) as usize;
        exec.write_buffer(refill_args, &zeros[..args_bytes])?;
        Ok(Denoiser {
            settings,
            layout,
            rays_per_pixel: settings.rates.rays_per_pixel,
            width,
            height,
            depth: id("depth"),
            normal_roughness: id("normal_roughness"),
            motion: id("motion")[0],
            view: id("view")[0],
            conventions: id("conventions")[0],
            conventions_written: None,
            engine: None,
            history: id("history"),
            samples: id("samples")[0],
            filtered: id("filtered"),
            mask: id("mask")[0],
            requests: id("requests")[0],
            counts: id("counts")[0],
            decision: id("decision")[0],
            trim: id("trim")[0],
            refill_hist: id("refill_hist")[0],
            noise,
            args: id("args")[0],
            refill_args,
            counters,
            gradient_keys: id("gradient_keys")[0],
            gradient_raw: id("gradient_raw")[0],
            gradient: id("gradient"),
            gradient_out: 0,
            gradient_ran: false,
            detected: false,
            kept_changes: None,
            tiles: id("tiles")[0],
            tile_histogram: id("tile_histogram")[0],
            importance: id("importance")[0],
            parallax: id("parallax")[0],
            guide: id("guide")[0],
            blockers: id("blockers")[0],
            penumbra: id("penumbra")[0],
            ao_guide: id("ao_guide")[0],
            ao_guide_raw: [id("ao_guide_raw")[0], id("ao_guide_raw")[1]],
            ao_radius: 0.0,
            unread: [id("unread")[0], id("unread")[1]],
            cur: 0,
            out: 0,
            frame: FrameInfo {
                index: 0,
                reset: true,
                pixel_angle: 1.0 / height as f32,
                moved: true,
                importance_plane: None,
                view: View::default(),
            },
            prev_frame: 0,
            since_reset: u32::MAX,
        })
    }

    /// This frame's [`FrameInfo`] (from [`Self::begin_frame`]).
    pub fn frame(&self) -> FrameInfo {
        self.frame
    }

    /// Tells the denoiser the AO rays' length (world units), which its AO guide marches to
    /// (`filter.ao_guide_directions`); until then, or at 0, the AO planes are filtered without
    /// the guide. [`crate::frame::Frame`] sets it from its signal.
    pub fn set_ao_radius(&mut self, radius: f32) -> Result<(), SettingsError> {
        if !(radius.is_finite() && radius >= 0.0) {
            return Err(SettingsError::OutOfRange {
                field: "ao radius",
                value: radius.into(),
                range: ">= 0",
            });
        }
        self.ao_radius = radius;
        Ok(())
    }

    /// The settings in use: the tunables it was created with, which never change.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The planes and their rules.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// This frame's ray budget in rays per pixel (`rates.rays_per_pixel` at creation, then what
    /// [`Self::set_rays_per_pixel`] set).
    pub fn rays_per_pixel(&self) -> f32 {
        self.rays_per_pixel
    }

    /// Sets the ray budget from the next [`Self::plan_rays`] on (what a
    /// [`MsBudget`](crate::budget::MsBudget) decides each frame), in the range of
    /// `rates.rays_per_pixel`. The settings are fixed at creation; the budget may change any
    /// frame, as it only sets the balancer's target and the base rate.
    pub fn set_rays_per_pixel(&mut self, rays_per_pixel: f32) -> Result<(), SettingsError> {
        RateSettings {
            rays_per_pixel,
            ..self.settings.rates
        }
        .validate()?;
        self.rays_per_pixel = rays_per_pixel;
        Ok(())
    }

    /// The rates stage as this frame runs it: the settings' with this frame's budget, and the
    /// boost, payback and reset refill of the signal alone.
    pub(super) fn rates(&self) -> RateSettings {
        let r = self.settings.rates;
        let reset_boost = if self.layout.ao_alone() {
            rates::alone_boost(&r, r.ao_reset_boost, self.rays_per_pixel)
        } else if self.layout.shadows_alone() {
            rates::alone_boost(&r, r.shadow_reset_boost, self.rays_per_pixel)
        } else {
            r.reset_boost
        };
        RateSettings {
            rays_per_pixel: self.rays_per_pixel,
            reset_boost,
            reset_payback: if self.layout.reflections_alone {
                self.settings.reflections.reset_payback
            } else {
                r.reset_payback
            },
            reset_refill: self.reset_refill_share(reset_boost),
            ..r
        }
    }

    /// The share of a reset's boost its refill lists take, for a denoiser of one signal alone:
    /// the shadows' `rates.reset_refill`, or, for the contrasted windows of AO and of the
    /// reflections, `rates.ao_reset_refill` and `reflections.reset_refill`, at most what leaves
    /// the main pass one ray per pixel (`rates::contrast_share`); AO's only on images at least
    /// `filter.wide_rows` tall, like its other rules for a cut's few-ray pixels. None in a shared
    /// frame, where the other signals would pay for one signal's lists.
    fn reset_refill_share(&self, boost: f32) -> f32 {
        let (s, l, rpp) = (&self.settings, &self.layout, self.rays_per_pixel);
        if l.shadows_alone() {
            s.rates.reset_refill
        } else if l.ao_alone() && s.filter.tall(self.height) {
            rates::contrast_share(s.rates.ao_reset_refill, boost, rpp)
        } else if l.reflections_alone {
            rates::contrast_share(s.reflections.reset_refill, boost, rpp)
        } else {
            0.0
        }
    }

    /// Image size.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// This frame's input buffers (the engine's G-buffer, see the README's input contract): the
    /// caller fills them after [`Self::begin_frame`] and before [`Self::plan_rays`].
    pub fn inputs(&self) -> Inputs {
        Inputs {
            depth: self.depth[self.cur],
            normal_roughness: self.normal_roughness[self.cur],
            motion: self.motion,
        }
    }

    /// Last frame's depth and normal + roughness, which the denoiser keeps (its motion is not).
    pub fn prev_inputs(&self) -> Inputs {
        Inputs {
            depth: self.depth[1 - self.cur],
            normal_roughness: self.normal_roughness[1 - self.cur],
            motion: self.motion,
        }
    }

    /// The one-element [`View`] buffer (this and last frame's camera), written by
    /// [`Self::begin_frame`].
    pub fn view(&self) -> BufferId {
        self.view
    }

    /// Optional VRS-style mask (`u32` per pixel, 0 = needs no ray): with
    /// [`RateSettings::vrs_mask`](crate::settings::RateSettings::vrs_mask) the engine writes it
    /// every frame; otherwise it is one unused word.
    pub fn mask(&self) -> BufferId {
        self.mask
    }

    /// Request scale per tile (`f32` per `reflect::TILE`² tile, row-major over
    /// `reflect::tile_grid`), read when [`FrameInfo::importance_plane`] is set; the caller writes
    /// it (`reflect::reflect_tiles`).
    pub fn importance(&self) -> BufferId {
        self.importance
    }

    /// Where each pixel's [`Layout::parallax_plane`] was last frame (`[f32; 2]` per pixel, in
    /// pixels); the caller writes it (`reflect::reflect_motion`) before [`Self::plan_rays`].
    pub fn parallax(&self) -> BufferId {
        self.parallax
    }

    /// The hit-distance guide of [`Layout::guide_plane`] (`f32` per pixel, or
    /// `kernels::reflect::NO_GUIDE`); the caller writes it (`reflect::reflect_guide`) before
    /// [`Self::resolve`].
    pub fn guide(&self) -> BufferId {
        self.guide
    }

    /// The shadow raygen's blocker records of [`Layout::penumbra_plane`] (`f32` per pixel:
    /// the mean penumbra width of a traced pixel's blocked rays, `raygen::NO_BLOCKER` when
    /// none was); raygen writes it between [`Self::plan_rays`] and [`Self::resolve`], which
    /// builds the penumbra guide from it.
    pub fn blockers(&self) -> BufferId {
        self.blockers
    }

    /// Per pixel and plane group (after [`Self::plan_rays`]; group-stacked like planes): the
    /// requested bucket and the reprojection flags (`requests::FLAG_*`) in one word;
    /// `requests::bucket_of` and `requests::flags_of` read them.
    pub fn requests(&self) -> BufferId {
        self.requests
    }

    /// The balancer's decision per plane group (`balance::Balance`, after [`Self::plan_rays`]).
    pub fn decision(&self) -> BufferId {
        self.decision
    }

    /// Compacted lists of tracing pixels and their granted rays, one per plane group at
    /// `group × pixels` (one `u32` each, `work_list::work_entry`, decoded by `work_list::work_item`):
    /// raygen traces exactly these, `args[4 · group]` of them. Valid from [`Self::plan_rays`] to
    /// [`Self::resolve`]: it lives in the filter's scratch copy, which is free until the variance
    /// pass (the copy that does not hold the output; it has a word per pixel and plane, and there
    /// are no more groups than planes).
    pub fn work(&self) -> BufferId {
        self.filtered[1 - self.settings.filter.atrous_iterations as usize % 2]
    }

    /// Rays granted per pixel and plane group this frame (after [`Self::plan_rays`], until the
    /// next frame's; group-stacked): apply's own rule ([`apply::resolve_rays`]) on the host, from
    /// the requests, the decisions and the blue noise, which outlive the work lists. For hosts
    /// that trace on the CPU or inspect the plan; a GPU ray pass reads the work lists itself.
    #[cfg(feature = "std")]
    pub fn read_rays<E: Executor>(&self, exec: &mut E) -> Result<std::vec::Vec<u32>, E::Error> {
        let (w, h) = (self.width, self.height);
        let groups = self.layout.groups();
        let pixels = w * h;
        let mut requests = std::vec![0u32; (pixels * groups) as usize];
        exec.read_buffer(self.requests, bytemuck::cast_slice_mut(&mut requests))?;
        let mut decision = std::vec![balance::Balance::default(); groups as usize];
        exec.read_buffer(self.decision, bytemuck::cast_slice_mut(&mut decision))?;
        let mut noise = std::vec![0.0f32; blue_noise::LEN];
        exec.read_buffer(self.noise, bytemuck::cast_slice_mut(&mut noise))?;
        let p = self.apply_params();
        Ok((0..pixels * groups)
            .map(|i| {
                let (g, pix) = (i / pixels, i % pixels);
                let bucket = kernels::requests::bucket_of(requests[i as usize]);
                let d = &decision[g as usize];
                apply::resolve_rays(pix % w, pix / w, g, bucket, &p, d, &noise)
            })
            .collect())
    }

    /// `[count, groups_x, 1, 1]` of each plane group's work list: the indirect dispatch arguments
    /// of group `g` at byte offset `16·g + 4`.
    pub fn args(&self) -> BufferId {
        self.args
    }

    /// The refill lists ([`Self::detect_changes`]): the detector's dropped pixels that traced
    /// nothing, with the rays [`refill::fit`] gave them, one list per plane group at
    /// `group × pixels` (as [`Self::work`]); an entry that did not fit is
    /// [`work_list::SKIPPED`] and traces nothing. Valid from [`Self::detect_changes`] to
    /// [`Self::resolve`], in the filter buffer that holds neither the detector's `λ` nor, by
    /// then, a live work list.
    pub fn refill_work(&self) -> BufferId {
        self.filtered[1]
    }

    /// Indirect dispatch arguments of the refill lists (as [`Self::args`]); the counts
    /// (`[4 · group]`) stay readable until the next frame's [`Self::plan_rays`], which sets rays
    /// aside for its own lists from them.
    pub fn refill_args(&self) -> BufferId {
        self.refill_args
    }

    /// This frame's raygen output (`Sample` per pixel and plane): the caller fills it between
    /// [`Self::plan_rays`] and [`Self::resolve`].
    pub fn samples(&self) -> BufferId {
        self.samples
    }

    /// This frame's history (`PackedPayload` per pixel and plane): reprojected after
    /// [`Self::plan_rays`] (raygen reads each pixel's rng index from it), accumulated after
    /// [`Self::resolve`].
    pub fn history(&self) -> BufferId {
        self.history[self.cur]
    }

    /// The denoised signal after [`Self::resolve`] (`Filtered` per pixel and plane). The buffer
    /// depends on the iteration count, so ask for it after `resolve`, not before.
    pub fn output(&self) -> BufferId {
        self.filtered[self.out]
    }

    /// À-trous iterations each 8×8 tile of this frame needed (`u32` per tile, row-major over
    /// `classify::tile_grid`; 0 also for tiles without geometry), after [`Self::resolve`].
    pub fn tiles(&self) -> BufferId {
        self.tiles
    }

    /// This frame's tile counts (`u32`, `classify::HISTOGRAM_LEN` words): tiles without geometry,
    /// then tiles needing 0, 1, … 5 iterations. What the adaptive filter skipped.
    pub fn tile_histogram(&self) -> BufferId {
        self.tile_histogram
    }

    /// Input clean-up counters (`u32`, [`COUNTERS_LEN`] words, indexed by
    /// `payload::COUNTER_*`): samples dropped as non-finite and samples clamped into range, totals
    /// since this denoiser was created (wrapping at 2^32). A healthy raygen leaves them at 0; read
    /// them to find out that it is not.
    pub fn counters(&self) -> BufferId {
        self.counters
    }

    /// The rng wrap accumulation uses: `temporal.rng_wrap`
    /// ([`TemporalSettings`](crate::settings::TemporalSettings)), or the storage format's width.
    pub fn rng_wrap(&self) -> u32 {
        if self.settings.temporal.rng_wrap != 0 {
            self.settings.temporal.rng_wrap
        } else {
            self.settings.temporal.storage.rng_wrap()
        }
    }

    /// Gradient cells across and down ([`buffers::grid_size`] of the settings).
    pub fn gradient_size(&self) -> (u32, u32) {
        buffers::grid_size(self.width, self.height, self.settings.prepass.stratum)
    }

    /// Raw temporal gradient of this frame (`GradientSample` per cell and plane, plane-stacked;
    /// `λ` = [`GradientSample::lambda`](gradient::GradientSample::lambda)): the overlay of what
    /// the re-traced samples saw. Valid when [`Self::gradient_ran`].
    pub fn gradient_raw(&self) -> BufferId {
        self.gradient_raw
    }

    /// Reconstructed (blurred) temporal gradient, the one reprojection reads; same layout as
    /// [`Self::gradient_raw`].
    pub fn gradient(&self) -> BufferId {
        if self.settings.prepass.iterations == 0 {
            self.gradient_raw
        } else {
            self.gradient[self.gradient_out]
        }
    }

    /// Winning packed key per gradient cell (`u32`, [`gradient::EMPTY_KEY`] where no sample
    /// landed): one re-traced ray per plane for every other cell.
    pub fn gradient_keys(&self) -> BufferId {
        self.gradient_keys
    }

    /// Keeps the change detector's `λ` (`f32` per pixel and plane, plane-stacked) in a buffer of
    /// its own from now on, for the host to read after a frame ([`Self::changes`]): 4 bytes per
    /// pixel and plane more. Without it `λ` lives in a filter buffer the filter overwrites.
    pub fn keep_changes<E: Executor>(&mut self, exec: &mut E) -> Result<BufferId, E::Error> {
        if let Some(b) = self.kept_changes {
            return Ok(b);
        }
        let bytes = self.width as u64 * self.height as u64 * self.layout.planes as u64 * 4;
        let b = exec.create_buffer(bytes)?;
        self.kept_changes = Some(b);
        Ok(b)
    }

    /// The buffer of [`Self::keep_changes`], when kept and the detector ran this frame.
    pub fn changes(&self) -> Option<BufferId> {
        self.kept_changes.filter(|_| self.detects())
    }

    /// Whether this frame runs the change detector: on, and the frame neither resets history nor
    /// stands still.
    pub(super) fn detects(&self) -> bool {
        self.settings.detector.radius > 0 && !self.frame.reset && self.frame.moved
    }

    /// Whether this frame's refill lists are a reset frame's (the shadows' mixed windows, traced
    /// with the rays it set aside: `rates.reset_refill`) rather than the detector's.
    pub fn refills_reset(&self) -> bool {
        self.frame.reset && self.reset_share() > 0.0
    }

    /// Whether reset frames make refill lists: a share of the boost for them
    /// ([`Self::reset_refill_share`]) and a host that traces refill lists (`detector.refill`).
    pub(super) fn reset_refill_on(&self) -> bool {
        self.rates().reset_refill > 0.0 && self.settings.detector.refill
    }

    /// A reset frame's refill reserve as a share of its main pass's budget
    /// ([`refill::reserve`]); 0 without.
    pub(super) fn reset_share(&self) -> f32 {
        rates::reset_share(&self.rates(), self.reset_refill_on())
    }

    /// The fewest rays of a reset frame's refill entry ([`refill::CapParams::least`]).
    pub(super) fn reset_least(&self) -> u32 {
        rates::reset_least(&self.rates(), self.reset_refill_on())
    }

    /// Whether this frame's temporal-gradient prepass ran (false: off, first frame or camera
    /// cut, or nothing moved).
    pub fn gradient_ran(&self) -> bool {
        self.gradient_ran
    }

    /// Starts a frame: swaps the ping-pong inputs and history so last frame's become `prev`, and
    /// uploads the frame's cameras ([`FrameInfo::view`]).
    pub fn begin_frame<E: Executor>(
        &mut self,
        exec: &mut E,
        frame: FrameInfo,
    ) -> Result<(), E::Error> {
        self.cur = 1 - self.cur;
        self.prev_frame = self.frame.index;
        self.since_reset = if frame.reset {
            0
        } else {
            self.since_reset.saturating_add(1)
        };
        self.frame = frame;
        self.gradient_ran = false;
        self.detected = false;
        self.engine = None;
        exec.write_buffer(self.view, bytemuck::bytes_of(&frame.view))
    }

    /// Takes this frame's inputs from the engine's own G-buffer textures, in its conventions,
    /// instead of the caller writing [`Self::inputs`]: call it after [`Self::begin_frame`] (the
    /// decode reads the cameras) and before anything that reads the inputs. Reprojection, their
    /// first reader, decodes them and writes the denoiser's own inputs on the way (no pass of its
    /// own); where the reflections' passes or the gradient prepass read the inputs before it,
    /// the `ingest` pass decodes them now.
    pub fn ingest<E: Executor>(
        &mut self,
        exec: &mut E,
        textures: &EngineTextures,
    ) -> Result<(), E::Error> {
        let read_before_reprojection =
            self.layout.parallax_plane.is_some() || self.settings.prepass.stratum > 0;
        if read_before_reprojection {
            return textures.ingest(exec, self.inputs(), self.view, (self.width, self.height));
        }
        let params = textures.conventions.params(self.width, self.height);
        if self.conventions_written != Some(params) {
            exec.write_buffer(self.conventions, bytemuck::bytes_of(&params))?;
            self.conventions_written = Some(params);
        }
        self.engine = Some(*textures);
        Ok(())
    }
}
