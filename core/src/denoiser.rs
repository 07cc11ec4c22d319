//! The denoiser as a frame plan: which passes run, in which order, on which buffers, with which
//! parameters. Backends only execute the passes it hands them.
//!
//! Per frame (seed vrrt-call-of-duty-2026, "Full pipeline"; SVGF from q2vkpt-2019):
//!
//! ```text
//! G-buffer ─► reproject ─► fill ─► count_buckets ─► balance ─► apply ─► raygen ─► accumulate ─► variance ─► atrous × N
//! (caller)    + requests   counts=0   histogram      thresholds  rays,      (caller,   history[cur]   filtered ping-pong
//!             history[prev] → reprojected                        work list  indirect)
//! ```
//!
//! The ray budget is decided before raygen: reprojection asks for a rate per pixel (refill lost
//! history, undersample converged pixels), the balancer fits the requests to
//! `rays_per_pixel × pixels`, apply grants each pixel its rays and compacts a work list. The
//! fixed-rate SVGF baseline is the same plan with requests off (every pixel asks for
//! `rays_per_pixel`) and no balancing.
//!
//! Temporal gradients (A-SVGF, optional: [`GradientSettings`](crate::settings::GradientSettings))
//! run as a prepass between the G-buffer and reprojection ([`Denoiser::temporal_gradients`]):
//! project last frame's samples forward, re-trace them against this frame's scene, blur the
//! change at stratum resolution; reprojection then shortens or drops history where the signal
//! changed, and VRRT supersamples there. It is skipped when nothing moved (the host says so in
//! [`FrameInfo::moved`]).
//!
//! History is ping-ponged explicitly: `history[prev]` is read by reprojection and
//! `history[cur]` written by accumulation; the spatial filter's output never feeds back into
//! history (seed: "spatial output is NOT being fed to temporal").

use crate::blue_noise;
use crate::buffers::{self, TooLarge};
use crate::camera::Camera;
use crate::kernels::gradient;
use crate::kernels::{
    self, accumulate, apply, atrous, balance, buckets, classify, fill, reproject, variance,
};
use crate::payload::COUNTERS_LEN;
use crate::plan::{BufferId, Executor, Groups};
use crate::settings::{Settings, SettingsError};
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
    /// Read [`Denoiser::mask`] this frame.
    pub use_mask: bool,
    /// Something moved since last frame (camera, objects or lights). When false the
    /// temporal-gradient prepass is skipped: every re-trace would return last frame's value.
    pub moved: bool,
    /// Scale each pixel's ray request by its tile's [`Denoiser::importance`], which the caller
    /// wrote this frame (the reflection tile classification).
    pub use_importance: bool,
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
    /// This frame's camera.
    pub camera: Camera,
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
#[derive(Clone, Debug)]
pub struct Denoiser {
    settings: Settings,
    width: u32,
    height: u32,
    surfaces: [BufferId; 2],
    history: [BufferId; 2],
    reprojected: BufferId,
    flags: BufferId,
    samples: BufferId,
    filtered: [BufferId; 2],
    mask: BufferId,
    requests: BufferId,
    counts: BufferId,
    decision: BufferId,
    noise: BufferId,
    rays: BufferId,
    work: BufferId,
    args: BufferId,
    counters: BufferId,
    gradient_keys: BufferId,
    gradient_raw: BufferId,
    gradient: [BufferId; 2],
    gradient_out: usize,
    gradient_ran: bool,
    tiles: BufferId,
    tile_histogram: BufferId,
    importance: BufferId,
    parallax: BufferId,
    cur: usize,
    out: usize,
    frame: FrameInfo,
}

/// Gradient cells across and down for stratum size `stratum` (one dummy cell when off).
pub fn grid_size(width: u32, height: u32, stratum: u32) -> (u32, u32) {
    if stratum == 0 {
        (1, 1)
    } else {
        (width.div_ceil(stratum), height.div_ceil(stratum))
    }
}

impl Denoiser {
    /// Validates `settings` and allocates every buffer for a `width × height` image.
    pub fn new<E: Executor>(
        exec: &mut E,
        width: u32,
        height: u32,
        settings: Settings,
    ) -> Result<Self, DenoiserError<E::Error>> {
        if width == 0 || height == 0 {
            return Err(DenoiserError::Settings(SettingsError::Resolution {
                width,
                height,
            }));
        }
        settings.validate().map_err(DenoiserError::Settings)?;
        let sizes = buffers::denoiser_buffers(width, height, &settings);
        buffers::check_fit(width, height, &settings, exec.binding_limit())
            .map_err(DenoiserError::TooLarge)?;
        let mut ids = [[BufferId(0); 2]; 22];
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
        Ok(Denoiser {
            settings,
            width,
            height,
            surfaces: id("surfaces"),
            history: id("history"),
            reprojected: id("reprojected")[0],
            flags: id("flags")[0],
            samples: id("samples")[0],
            filtered: id("filtered"),
            mask: id("mask")[0],
            requests: id("requests")[0],
            counts: id("counts")[0],
            decision: id("decision")[0],
            noise,
            rays: id("rays")[0],
            work: id("work")[0],
            args: id("args")[0],
            counters,
            gradient_keys: id("gradient_keys")[0],
            gradient_raw: id("gradient_raw")[0],
            gradient: id("gradient"),
            gradient_out: 0,
            gradient_ran: false,
            tiles: id("tiles")[0],
            tile_histogram: id("tile_histogram")[0],
            importance: id("importance")[0],
            parallax: id("parallax")[0],
            cur: 0,
            out: 0,
            frame: FrameInfo {
                index: 0,
                reset: true,
                pixel_angle: 1.0 / height as f32,
                use_mask: false,
                moved: true,
                use_importance: false,
            },
        })
    }

    /// This frame's [`FrameInfo`] (from [`Self::begin_frame`]).
    pub fn frame(&self) -> FrameInfo {
        self.frame
    }

    /// The settings in use.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Image size.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// This frame's G-buffer (`Surface` per pixel): the caller fills it before [`Self::plan_rays`].
    pub fn surfaces(&self) -> BufferId {
        self.surfaces[self.cur]
    }

    /// Last frame's G-buffer.
    pub fn prev_surfaces(&self) -> BufferId {
        self.surfaces[1 - self.cur]
    }

    /// Reprojected history (`Payload` per pixel and plane): raygen reads each pixel's rng index
    /// from it.
    pub fn reprojected(&self) -> BufferId {
        self.reprojected
    }

    /// Optional VRS-style mask (`u32` per pixel, 0 = needs no ray), used when
    /// [`FrameInfo::use_mask`] is set; the caller writes it.
    pub fn mask(&self) -> BufferId {
        self.mask
    }

    /// Request scale per tile (`f32` per `reflect::TILE`² tile, row-major over
    /// `reflect::tile_grid`), read when [`FrameInfo::use_importance`] is set; the caller writes
    /// it (`reflect::reflect_tiles`).
    pub fn importance(&self) -> BufferId {
        self.importance
    }

    /// Where each pixel's [`Settings::parallax_plane`] was last frame (`[f32; 2]` per pixel, in
    /// pixels); the caller writes it (`reflect::reflect_motion`) before [`Self::plan_rays`].
    pub fn parallax(&self) -> BufferId {
        self.parallax
    }

    /// Requested bucket per pixel (after [`Self::plan_rays`]).
    pub fn requests(&self) -> BufferId {
        self.requests
    }

    /// The balancer's decision (`balance::Balance`, after [`Self::plan_rays`]).
    pub fn decision(&self) -> BufferId {
        self.decision
    }

    /// Rays granted per pixel (`u32`, after [`Self::plan_rays`]): raygen traces exactly these.
    pub fn rays(&self) -> BufferId {
        self.rays
    }

    /// Compacted list of tracing pixels (`u32` pixel indices, after [`Self::plan_rays`]).
    pub fn work(&self) -> BufferId {
        self.work
    }

    /// `[count, groups_x, 1, 1]` of the work list: indirect dispatch arguments at byte offset 4.
    pub fn args(&self) -> BufferId {
        self.args
    }

    /// Per-pixel reprojection flags (`reproject::FLAG_*`).
    pub fn flags(&self) -> BufferId {
        self.flags
    }

    /// This frame's raygen output (`Sample` per pixel and plane): the caller fills it between
    /// [`Self::plan_rays`] and [`Self::resolve`].
    pub fn samples(&self) -> BufferId {
        self.samples
    }

    /// Accumulated history after [`Self::resolve`] (`Payload` per pixel and plane).
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

    /// Gradient cells across and down ([`grid_size`] of the settings).
    pub fn gradient_size(&self) -> (u32, u32) {
        grid_size(self.width, self.height, self.settings.gradient.stratum)
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
        if self.settings.gradient.iterations == 0 {
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

    /// Whether this frame's temporal-gradient prepass ran (false: off, first frame or camera
    /// cut, or nothing moved).
    pub fn gradient_ran(&self) -> bool {
        self.gradient_ran
    }

    /// Starts a frame: swaps the ping-pong G-buffer and history so last frame's become `prev`.
    pub fn begin_frame(&mut self, frame: FrameInfo) {
        self.cur = 1 - self.cur;
        self.frame = frame;
        self.gradient_ran = false;
    }

    /// The temporal-gradient prepass (A-SVGF), between the G-buffer and [`Self::plan_rays`]:
    /// forward projection of one previous-frame sample per stratum, re-trace of its 0th ray
    /// against `scene`, and the à-trous reconstruction. It reads last frame's rays, samples and
    /// reprojected history, which [`Self::plan_rays`] overwrites, so it must run first. Returns
    /// whether it ran: it is skipped when off, on reset frames, and when [`FrameInfo::moved`] is
    /// false (nothing can have changed, so every `λ` would be 0).
    pub fn temporal_gradients<E: Executor>(
        &mut self,
        exec: &mut E,
        scene: &GradientScene,
    ) -> Result<bool, E::Error> {
        let s = self.settings;
        self.gradient_ran = false;
        if s.gradient.stratum == 0 || self.frame.reset || !self.frame.moved {
            return Ok(false);
        }
        let (w, h) = (self.width, self.height);
        let (gw, gh) = self.gradient_size();
        let index_mask = gradient::index_mask(w * h);
        let clear = fill::FillParams {
            len: gw * gh,
            value: gradient::EMPTY_KEY,
        };
        let keys = kernels::FillBindings {
            buf: self.gradient_keys,
        };
        exec.dispatch(&keys.over_grid(&clear, clear.len, 1, 1))?;
        let proj = gradient::ProjectParams {
            width: w,
            height: h,
            stratum: s.gradient.stratum,
            grid_width: gw,
            grid_height: gh,
            frame_index: self.frame.index,
            index_mask,
            normal_threshold: s.temporal.normal_threshold,
            plane_threshold: s.temporal.plane_threshold,
            camera: scene.camera,
        };
        let project = kernels::GradientProjectBindings {
            prev_surfaces: self.surfaces[1 - self.cur],
            surfaces: self.surfaces[self.cur],
            rays: self.rays,
            next: scene.next,
            keys: self.gradient_keys,
        };
        exec.dispatch(&project.over_grid(&proj, gw, gh, 1))?;
        let mut retrace = gradient::RetraceParams {
            width: w,
            height: h,
            planes: s.planes,
            grid_width: gw,
            grid_height: gh,
            index_mask,
            max_distance: 0.0,
            _pad: 0,
        };
        // Last frame's reprojected history still holds the rng index each pixel's raygen started
        // from, and `samples` last frame's 0th ray values.
        let ao = kernels::GradientAoBindings {
            keys: self.gradient_keys,
            prev_surfaces: self.surfaces[1 - self.cur],
            next: scene.next,
            prev_payload: self.reprojected,
            prev_samples: self.samples,
            nodes: scene.nodes,
            tris: scene.tris,
            out: self.gradient_raw,
        };
        match scene.rays {
            GradientRays::Ao { max_distance } => {
                retrace.max_distance = max_distance;
                exec.dispatch(&ao.over_grid(&retrace, gw, gh, 1))?;
            }
            GradientRays::Shadows { lights } => {
                let shadow = kernels::GradientShadowBindings {
                    keys: ao.keys,
                    prev_surfaces: ao.prev_surfaces,
                    next: ao.next,
                    prev_payload: ao.prev_payload,
                    prev_samples: ao.prev_samples,
                    nodes: ao.nodes,
                    tris: ao.tris,
                    lights,
                    out: ao.out,
                };
                exec.dispatch(&shadow.over_grid(&retrace, gw, gh, 1))?;
            }
        }
        let mut input = self.gradient_raw;
        for i in 0..s.gradient.iterations {
            let p = gradient::GradientAtrousParams {
                grid_width: gw,
                grid_height: gh,
                step: 1 << i,
                _pad: 0,
            };
            let out = self.gradient[(i % 2) as usize];
            let pass = kernels::GradientAtrousBindings { input, out };
            exec.dispatch(&pass.over_grid(&p, gw, gh, s.planes))?;
            input = out;
            self.gradient_out = (i % 2) as usize;
        }
        self.gradient_ran = true;
        Ok(true)
    }

    /// Passes before raygen: reprojection (with ray requests), bucket counting, load balancing
    /// and apply. Afterwards [`Self::rays`], [`Self::work`] and [`Self::args`] say what to trace.
    pub fn plan_rays<E: Executor>(&mut self, exec: &mut E) -> Result<(), E::Error> {
        let s = self.settings;
        let (w, h) = (self.width, self.height);
        let vrrt = s.rates.supersample_target > 0.0;
        let (gw, gh) = self.gradient_size();
        // Below one ray per pixel the budget's rate is the base request (seed: "can use global
        // ray rate < 1") and undersampling rates scale with it: with a base of 1 every request
        // would exceed a 1/2-ray budget and water filling would level refills down to the base.
        let still = s.rates.undersample && !self.frame.moved && !self.frame.reset;
        let base_rate = if vrrt {
            s.rates.rays_per_pixel.min(1.0)
        } else {
            s.rates.rays_per_pixel
        };
        let params = reproject::ReprojectParams {
            width: w,
            height: h,
            planes: s.planes,
            reset: self.frame.reset as u32,
            normal_threshold: s.temporal.normal_threshold,
            plane_threshold: s.temporal.plane_threshold,
            frame_index: self.frame.index,
            supersample_target: s.rates.supersample_target,
            // On a still frame history stays valid, so it is completed before any undersampling.
            full_history: if still {
                s.temporal.max_history
            } else {
                s.rates.undersample_after
            },
            base_rate,
            use_mask: self.frame.use_mask as u32,
            variance_threshold: if s.rates.undersample {
                s.rates.variance_threshold
            } else {
                [0.0; 4]
            },
            variance_rate: s.rates.variance_rate.map(|r| r * base_rate),
            gradient_stratum: if self.gradient_ran {
                s.gradient.stratum
            } else {
                0
            },
            gradient_width: gw,
            gradient_height: gh,
            gradient_threshold: s.gradient.threshold,
            gradient_scale: s.gradient.scale,
            still_history: if still { s.temporal.max_history } else { 0.0 },
            still_variance: s.rates.still_sigma * s.rates.still_sigma,
            use_importance: self.frame.use_importance as u32,
            parallax_plane: s.parallax_plane.unwrap_or(reproject::NO_PLANE),
            ..Default::default()
        };
        let reproject = kernels::ReprojectBindings {
            surfaces: self.surfaces[self.cur],
            prev_surfaces: self.surfaces[1 - self.cur],
            history: self.history[1 - self.cur],
            mask: self.mask,
            gradient: self.gradient(),
            importance: self.importance,
            parallax: self.parallax,
            out: self.reprojected,
            flags: self.flags,
            requests: self.requests,
        };
        exec.dispatch(&reproject.over_grid(&params, w, h, 1))?;

        let clear = fill::FillParams {
            len: buckets::COUNTS_LEN,
            value: 0,
        };
        let counts = kernels::FillBindings { buf: self.counts };
        exec.dispatch(&counts.over_grid(&clear, clear.len, 1, 1))?;
        let count = buckets::BucketParams {
            width: w,
            height: h,
        };
        let buckets = kernels::CountBucketsBindings {
            requests: self.requests,
            counts: self.counts,
        };
        exec.dispatch(&buckets.over_grid(&count, w, h, 1))?;

        let bal = balance::BalanceParams {
            rays_per_pixel: s.rates.rays_per_pixel,
            ring_count: buckets::ring_count(w, h),
            raise: s.rates.spend_saved_rays as u32,
            policy: if s.rates.supersample_target <= 0.0 {
                balance::POLICY_FIXED
            } else if s.rates.load_balance {
                balance::POLICY_BALANCE
            } else {
                balance::POLICY_KEEP
            },
        };
        let balance = kernels::BalanceBindings {
            counts: self.counts,
            out: self.decision,
            args: self.args,
        };
        exec.dispatch(&balance.pass(&bal, Groups::Direct([1, 1, 1])))?;

        let app = apply::ApplyParams {
            width: w,
            height: h,
            planes: s.planes,
            frame_index: self.frame.index,
        };
        let apply = kernels::ApplyBindings {
            requests: self.requests,
            decision: self.decision,
            noise: self.noise,
            rays: self.rays,
            work: self.work,
            args: self.args,
            samples: self.samples,
        };
        exec.dispatch(&apply.over_grid(&app, w, h, 1))
    }

    /// Passes 2.. (after raygen): accumulation, variance estimation and the à-trous iterations.
    pub fn resolve<E: Executor>(&mut self, exec: &mut E) -> Result<(), E::Error> {
        let s = self.settings;
        let (w, h, planes) = (self.width, self.height, s.planes);
        let acc = accumulate::AccumulateParams {
            width: w,
            height: h,
            max_history: s.temporal.max_history,
            rng_wrap: self.rng_wrap(),
            clamp_radius: s.temporal.clamp_radius,
            clamp_gamma: s.temporal.clamp_gamma,
            firefly_max: s.temporal.firefly_max,
            storage: s.temporal.storage.code()
                | if s.temporal.stuck_correction {
                    0
                } else {
                    crate::quantize::STORAGE_NO_CORRECTION
                },
        };
        let accumulate = kernels::AccumulateBindings {
            history: self.reprojected,
            samples: self.samples,
            out: self.history[self.cur],
            counters: self.counters,
        };
        exec.dispatch(&accumulate.over_grid(&acc, w, h, planes))?;

        let plane_scale = s.filter.plane_tolerance * self.frame.pixel_angle;
        let var = variance::VarianceParams {
            width: w,
            height: h,
            radius: s.filter.spatial_radius,
            spatial_until: s.filter.spatial_until,
            plane_scale,
            normal_power: s.filter.normal_power,
            ..Default::default()
        };
        let variance = kernels::VarianceBindings {
            payload: self.history[self.cur],
            surfaces: self.surfaces[self.cur],
            out: self.filtered[0],
        };
        exec.dispatch(&variance.over_grid(&var, w, h, planes))?;

        let clear = fill::FillParams {
            len: classify::HISTOGRAM_LEN,
            value: 0,
        };
        let histogram = kernels::FillBindings {
            buf: self.tile_histogram,
        };
        exec.dispatch(&histogram.over_grid(&clear, clear.len, 1, 1))?;
        let cls = classify::ClassifyParams {
            width: w,
            height: h,
            planes,
            iterations: s.filter.atrous_iterations,
            skip_sigma: s.filter.skip_sigma,
            ..Default::default()
        };
        let (tw, th) = classify::tile_grid(w, h);
        let classify = kernels::ClassifyBindings {
            surfaces: self.surfaces[self.cur],
            filtered: self.filtered[0],
            tiles: self.tiles,
            histogram: self.tile_histogram,
        };
        exec.dispatch(&classify.over_grid(&cls, tw, th, 1))?;

        self.out = 0;
        for i in 0..s.filter.atrous_iterations {
            let params = atrous::AtrousParams {
                width: w,
                height: h,
                step: 1 << i,
                iteration: i,
                sigma_luminance: s.filter.sigma_luminance,
                plane_scale,
                normal_power: s.filter.normal_power,
                ..Default::default()
            };
            let atrous = kernels::AtrousBindings {
                input: self.filtered[self.out],
                surfaces: self.surfaces[self.cur],
                tiles: self.tiles,
                out: self.filtered[1 - self.out],
            };
            exec.dispatch(&atrous.over_grid(&params, w, h, planes))?;
            self.out = 1 - self.out;
        }
        Ok(())
    }
}
