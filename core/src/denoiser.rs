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
//! Temporal gradients (A-SVGF, optional: [`Settings::gradient_stratum`]) run as a prepass between
//! the G-buffer and reprojection ([`Denoiser::temporal_gradients`]): project last frame's samples
//! forward, re-trace them against this frame's scene, blur the change at stratum resolution;
//! reprojection then shortens or drops history where the signal changed, and VRRT supersamples
//! there. It is skipped when nothing moved (the host says so in [`FrameInfo::moved`]).
//!
//! History is ping-ponged explicitly: `history[prev]` is read by reprojection and
//! `history[cur]` written by accumulation; the spatial filter's output never feeds back into
//! history (seed: "spatial output is NOT being fed to temporal").

use crate::blue_noise;
use crate::camera::Camera;
use crate::kernels::gradient::{self, GradientSample};
use crate::kernels::{
    self, accumulate, apply, atrous, balance, buckets, classify, fill, reflect, reproject, variance,
};
use crate::payload::COUNTERS_LEN;
use crate::plan::{BufferId, Executor, Groups};
pub use crate::quantize::StoragePrecision;
use core::fmt;

/// Every tunable of the denoiser, with documented defaults and ranges (like NRD's settings).
/// `Settings::default()` is full VRRT; [`Settings::svgf`] the fixed-rate baseline.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Settings {
    /// Ray budget: average rays per pixel per frame (0 < r <= 16; default 1).
    pub rays_per_pixel: f32,
    /// VRRT supersampling: pixels with less history than this many rays ask for the difference
    /// (up to 16 a frame); 0 turns VRRT off: every pixel traces `rays_per_pixel`, fractions by a
    /// blue-noise test, and `load_balance` is moot (0 or 1..=max_history; default 16).
    pub supersample_target: f32,
    /// Fit requests to the budget with the load balancer (default on). Off: requests are traced
    /// as asked, whatever they cost.
    pub load_balance: bool,
    /// Spend budget left over by raising low requests, inner rings first (default on); off is the
    /// "save" mode.
    pub spend_saved_rays: bool,
    /// VRRT undersampling of converged pixels by variance (default on).
    pub undersample: bool,
    /// History length (rays) from which a pixel counts as converged and may undersample
    /// (1..=max_history; default 16, the supersampling target: a pixel that has refilled its
    /// history stops asking and may give rays away). The seed waits for full history
    /// (`max_history`); the shorter wait frees rays sooner for disocclusions (room scene, 96
    /// frames: relMSE 0.00515 → 0.00455 at 1 ray), at some risk on slowly changing signals, which
    /// temporal gradients cover.
    pub undersample_after: f32,
    /// Undersampling variance thresholds, increasing (default `[1e-4, 1e-3, 1e-2, 0]`).
    pub variance_threshold: [f32; 4],
    /// Undersampling rates of those thresholds, in `[1/64, 16]` (default `[1/8, 1/4, 1/2, 1]`),
    /// relative to the base rate `min(rays_per_pixel, 1)`.
    pub variance_rate: [f32; 4],
    /// Scalar signal planes denoised together (1..=4: AO, shadows of up to 4 lights).
    pub planes: u32,
    /// History length clamp in rays (1..=65504; default 64).
    pub max_history: f32,
    /// Still frames (nothing moved, [`FrameInfo::moved`] false): a pixel with full history
    /// (`max_history`) whose estimate's standard deviation is below this asks only for the floor,
    /// `variance_rate[0]`, and other pixels complete their history before any variance-based
    /// undersampling. With `spend_saved_rays` off the rays stay unspent ("save" mode). Needs
    /// `undersample` (>= 0; default 0.045: on the static room the error rises 1.8% for 77% of
    /// the rays saved).
    pub still_sigma: f32,
    /// À-trous iterations, strides 1, 2, 4, … (0..=5; default 5).
    pub atrous_iterations: u32,
    /// Adaptive filtering: an 8×8 tile runs only the à-trous iterations needed to bring its largest
    /// standard deviation of the estimate below this (each iteration counted as halving it,
    /// `kernels::classify`); 0 = every tile runs every iteration (>= 0; default 0.004, below what
    /// a [0, 1] signal shows on an 8-bit display).
    pub skip_sigma: f32,
    /// Luminance edge-stopping σ_l (> 0; default 1: with the variance of the estimate, not of a
    /// single ray, SVGF's 4 over-blurs contact shadows and disocclusions).
    pub sigma_luminance: f32,
    /// Normal edge-stopping exponent (>= 0; default 128).
    pub normal_power: f32,
    /// Plane-distance tolerance in pixel footprints (> 0; default 2).
    pub plane_tolerance: f32,
    /// History shorter than this (rays) blends in the spatial variance estimate (>= 0; default 4).
    pub spatial_until: f32,
    /// Window radius of the spatial variance estimate (0..=5; default 3, i.e. 7×7).
    pub spatial_radius: u32,
    /// Variance clamp of history against this frame's samples: window radius, 0 = off (default
    /// off; the SVGF baseline turns it on, VRRT does not need it).
    pub clamp_radius: u32,
    /// Variance clamp width in standard deviations (> 0; default 1).
    pub clamp_gamma: f32,
    /// Firefly clamp of this frame's per-pixel mean; 0 = off (default off).
    pub firefly_max: f32,
    /// Reprojection: minimum cosine between normals (default 0.9).
    pub normal_threshold: f32,
    /// Reprojection: maximum plane distance as a fraction of view depth (default 0.02).
    pub plane_threshold: f32,
    /// Width of the stored rng index (wraps there; 0 = the width that goes with `storage`: 32
    /// bits for f32, 16 for f16, 8 for unorm8; default 0).
    pub rng_wrap: u32,
    /// Storage precision of the history moments (default f32, the reference). f16 and unorm8
    /// round every stored moment to that format's precision, with the seed's stuck correction, to
    /// measure what a low-precision history does; buffers keep their f32 layout (packed formats
    /// are not implemented). Unorm8 is for signals in `[0, 1]` (shadows, AO) only.
    pub storage: StoragePrecision,
    /// The seed's stuck correction when storing low-precision history (default on). Off only to
    /// demonstrate the pixel that never converges without it; no effect with f32 storage.
    pub stuck_correction: bool,
    /// Temporal gradients (A-SVGF): stratum size in pixels, one re-traced sample per stratum and
    /// frame (0 = off, default; 3..=8). Lets history be dropped where the signal changed instead of
    /// clamped, so VRRT can supersample there.
    pub gradient_stratum: u32,
    /// À-trous iterations of the gradient reconstruction at stratum resolution (0..=5; default 3).
    pub gradient_iterations: u32,
    /// Gradient `λ` above which history is dropped like a disocclusion (0..=1; default 0.5);
    /// below it history is shortened to `count · (1 − λ)`.
    pub gradient_threshold: f32,
    /// Gain on the reconstructed `λ` (`min(1, scale · λ)`, >= 0; default 1, A-SVGF as published).
    /// A single binary ray per stratum sees slow changes (a light creeping, a penumbra sliding)
    /// as a small `λ`; a gain shortens history there sooner, like Q2RTX's anti-lag scale.
    pub gradient_scale: f32,
    /// Plane reprojected along the reflection parallax (`kernels::reflect::reflect_motion`, which
    /// the caller runs into [`Denoiser::parallax`] before [`Denoiser::plan_rays`]) instead of the
    /// surface motion; `None` (default) for none.
    pub parallax_plane: Option<u32>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            rays_per_pixel: 1.0,
            supersample_target: 16.0,
            load_balance: true,
            spend_saved_rays: true,
            undersample: true,
            undersample_after: 16.0,
            variance_threshold: [1e-4, 1e-3, 1e-2, 0.0],
            variance_rate: [0.125, 0.25, 0.5, 1.0],
            planes: 1,
            max_history: 64.0,
            still_sigma: 0.045,
            atrous_iterations: 5,
            skip_sigma: 0.004,
            sigma_luminance: 1.0,
            normal_power: 128.0,
            plane_tolerance: 2.0,
            spatial_until: 4.0,
            spatial_radius: 3,
            clamp_radius: 0,
            clamp_gamma: 1.0,
            firefly_max: 0.0,
            normal_threshold: 0.9,
            plane_threshold: 0.02,
            rng_wrap: 0,
            storage: StoragePrecision::F32,
            stuck_correction: true,
            gradient_stratum: 0,
            gradient_iterations: 3,
            gradient_threshold: 0.5,
            gradient_scale: 1.0,
            parallax_plane: None,
        }
    }
}

/// A setting out of its range.
#[derive(Clone, Debug, PartialEq)]
pub enum SettingsError {
    /// Width or height is zero.
    Resolution {
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
    },
    /// A field outside its documented range.
    OutOfRange {
        /// Field name.
        field: &'static str,
        /// Value given.
        value: f32,
        /// The range, in words.
        range: &'static str,
    },
}

impl fmt::Display for SettingsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SettingsError::Resolution { width, height } => {
                write!(
                    f,
                    "resolution {width}x{height}: width and height must be at least 1"
                )
            }
            SettingsError::OutOfRange {
                field,
                value,
                range,
            } => {
                write!(f, "setting `{field}` = {value} is out of range ({range})")
            }
        }
    }
}

impl Settings {
    /// The SVGF baseline VRRT is measured against (every tile filtered fully, as published): every pixel traces `rays_per_pixel`, no
    /// requests, no balancing.
    pub fn svgf(rays_per_pixel: f32) -> Self {
        Settings {
            rays_per_pixel,
            supersample_target: 0.0,
            load_balance: false,
            undersample: false,
            skip_sigma: 0.0,
            ..Settings::default()
        }
    }

    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let finite = |v: f32| v.is_finite();
        check(
            finite(self.rays_per_pixel) && self.rays_per_pixel > 0.0 && self.rays_per_pixel <= 16.0,
            "rays_per_pixel",
            self.rays_per_pixel,
            "0 < r <= 16",
        )?;
        check(
            finite(self.supersample_target)
                && (self.supersample_target == 0.0
                    || (self.supersample_target >= 1.0
                        && self.supersample_target <= self.max_history)),
            "supersample_target",
            self.supersample_target,
            "0 or 1..=max_history",
        )?;
        check(
            finite(self.undersample_after)
                && self.undersample_after >= 1.0
                && self.undersample_after <= self.max_history,
            "undersample_after",
            self.undersample_after,
            "1..=max_history",
        )?;
        for i in 0..4 {
            let t = self.variance_threshold[i];
            check(
                finite(t) && t >= 0.0,
                "variance_threshold",
                t,
                ">= 0, finite",
            )?;
            if i > 0 && t != 0.0 {
                let prev = self.variance_threshold[i - 1];
                check(
                    t >= prev,
                    "variance_threshold",
                    t,
                    "increasing (0 ends the list)",
                )?;
            }
            let r = self.variance_rate[i];
            check(
                finite(r) && (1.0 / 64.0..=16.0).contains(&r),
                "variance_rate",
                r,
                "1/64..=16",
            )?;
        }
        check(
            (1..=4).contains(&self.planes),
            "planes",
            self.planes as f32,
            "1..=4",
        )?;
        check(
            finite(self.max_history) && self.max_history >= 1.0 && self.max_history <= 65504.0,
            "max_history",
            self.max_history,
            "1..=65504",
        )?;
        check(
            self.atrous_iterations <= 5,
            "atrous_iterations",
            self.atrous_iterations as f32,
            "0..=5",
        )?;
        check(
            finite(self.sigma_luminance) && self.sigma_luminance > 0.0,
            "sigma_luminance",
            self.sigma_luminance,
            "> 0",
        )?;
        check(
            finite(self.normal_power) && self.normal_power >= 0.0,
            "normal_power",
            self.normal_power,
            ">= 0",
        )?;
        check(
            finite(self.plane_tolerance) && self.plane_tolerance > 0.0,
            "plane_tolerance",
            self.plane_tolerance,
            "> 0",
        )?;
        check(
            finite(self.still_sigma) && self.still_sigma >= 0.0,
            "still_sigma",
            self.still_sigma,
            ">= 0",
        )?;
        check(
            finite(self.skip_sigma) && self.skip_sigma >= 0.0,
            "skip_sigma",
            self.skip_sigma,
            ">= 0",
        )?;
        check(
            finite(self.spatial_until) && self.spatial_until >= 0.0,
            "spatial_until",
            self.spatial_until,
            ">= 0",
        )?;
        check(
            self.spatial_radius <= 5,
            "spatial_radius",
            self.spatial_radius as f32,
            "0..=5",
        )?;
        check(
            self.clamp_radius <= 5,
            "clamp_radius",
            self.clamp_radius as f32,
            "0..=5",
        )?;
        check(
            finite(self.clamp_gamma) && self.clamp_gamma > 0.0,
            "clamp_gamma",
            self.clamp_gamma,
            "> 0",
        )?;
        check(
            finite(self.firefly_max) && self.firefly_max >= 0.0,
            "firefly_max",
            self.firefly_max,
            ">= 0",
        )?;
        check(
            finite(self.normal_threshold) && (-1.0..=1.0).contains(&self.normal_threshold),
            "normal_threshold",
            self.normal_threshold,
            "-1..=1",
        )?;
        check(
            finite(self.plane_threshold) && self.plane_threshold > 0.0,
            "plane_threshold",
            self.plane_threshold,
            "> 0",
        )?;
        check(
            self.gradient_stratum == 0 || (3..=8).contains(&self.gradient_stratum),
            "gradient_stratum",
            self.gradient_stratum as f32,
            "0 or 3..=8",
        )?;
        check(
            finite(self.gradient_scale) && self.gradient_scale >= 0.0,
            "gradient_scale",
            self.gradient_scale,
            ">= 0",
        )?;
        check(
            self.gradient_iterations <= 5,
            "gradient_iterations",
            self.gradient_iterations as f32,
            "0..=5",
        )?;
        check(
            finite(self.gradient_threshold) && (0.0..=1.0).contains(&self.gradient_threshold),
            "gradient_threshold",
            self.gradient_threshold,
            "0..=1",
        )?;
        if let Some(z) = self.parallax_plane {
            check(
                z < self.planes,
                "parallax_plane",
                z as f32,
                "a plane (< planes)",
            )?;
        }
        Ok(())
    }
}

/// `Ok` when `ok`, else the out-of-range error for `field` (the settings validators' one check).
pub(crate) fn check(
    ok: bool,
    field: &'static str,
    value: f32,
    range: &'static str,
) -> Result<(), SettingsError> {
    if ok {
        Ok(())
    } else {
        Err(SettingsError::OutOfRange {
            field,
            value,
            range,
        })
    }
}

/// A denoiser failure: bad settings or a backend error.
#[derive(Debug)]
pub enum DenoiserError<E> {
    /// Settings or resolution out of range.
    Settings(SettingsError),
    /// The backend failed.
    Backend(E),
}

impl<E: fmt::Display> fmt::Display for DenoiserError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DenoiserError::Settings(e) => write!(f, "{e}"),
            DenoiserError::Backend(e) => write!(f, "backend: {e}"),
        }
    }
}

impl core::error::Error for SettingsError {}

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

/// Bytes of one element of each buffer kind.
const SURFACE_BYTES: u64 = core::mem::size_of::<crate::gbuffer::Surface>() as u64;
const PAYLOAD_BYTES: u64 = core::mem::size_of::<crate::payload::Payload>() as u64;
const SAMPLE_BYTES: u64 = core::mem::size_of::<crate::payload::Sample>() as u64;
const FILTERED_BYTES: u64 = core::mem::size_of::<atrous::Filtered>() as u64;
const GRADIENT_BYTES: u64 = core::mem::size_of::<GradientSample>() as u64;

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
        let pixels = width as u64 * height as u64;
        let planes = pixels * settings.planes as u64;
        let noise = exec.create_buffer(blue_noise::LEN as u64 * 4)?;
        let (gw, gh) = grid_size(width, height, settings.gradient_stratum);
        let cells = gw as u64 * gh as u64;
        let gradient_bytes = cells * settings.planes as u64 * GRADIENT_BYTES;
        exec.write_buffer(noise, bytemuck::cast_slice(&blue_noise::generate_mask()))?;
        let counters = exec.create_buffer(COUNTERS_LEN as u64 * 4)?;
        exec.write_buffer(counters, &[0; COUNTERS_LEN as usize * 4])?;
        Ok(Denoiser {
            settings,
            width,
            height,
            surfaces: [
                exec.create_buffer(pixels * SURFACE_BYTES)?,
                exec.create_buffer(pixels * SURFACE_BYTES)?,
            ],
            history: [
                exec.create_buffer(planes * PAYLOAD_BYTES)?,
                exec.create_buffer(planes * PAYLOAD_BYTES)?,
            ],
            reprojected: exec.create_buffer(planes * PAYLOAD_BYTES)?,
            flags: exec.create_buffer(pixels * 4)?,
            samples: exec.create_buffer(planes * SAMPLE_BYTES)?,
            filtered: [
                exec.create_buffer(planes * FILTERED_BYTES)?,
                exec.create_buffer(planes * FILTERED_BYTES)?,
            ],
            mask: exec.create_buffer(pixels * 4)?,
            requests: exec.create_buffer(pixels * 4)?,
            counts: exec.create_buffer(buckets::COUNTS_LEN as u64 * 4)?,
            decision: exec.create_buffer(core::mem::size_of::<balance::Balance>() as u64)?,
            noise,
            rays: exec.create_buffer(pixels * 4)?,
            work: exec.create_buffer(pixels * 4)?,
            args: exec.create_buffer(apply::ARGS_LEN as u64 * 4)?,
            counters,
            gradient_keys: exec.create_buffer(cells * 4)?,
            gradient_raw: exec.create_buffer(gradient_bytes)?,
            gradient: [
                exec.create_buffer(gradient_bytes)?,
                exec.create_buffer(gradient_bytes)?,
            ],
            gradient_out: 0,
            gradient_ran: false,
            tiles: {
                let (tw, th) = classify::tile_grid(width, height);
                exec.create_buffer(tw as u64 * th as u64 * 4)?
            },
            tile_histogram: exec.create_buffer(classify::HISTOGRAM_LEN as u64 * 4)?,
            importance: {
                let (tw, th) = reflect::tile_grid(width, height);
                exec.create_buffer(tw as u64 * th as u64 * 4)?
            },
            parallax: exec.create_buffer(pixels * 8)?,
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

    /// The rng wrap accumulation uses: [`Settings::rng_wrap`], or the storage format's width.
    pub fn rng_wrap(&self) -> u32 {
        if self.settings.rng_wrap != 0 {
            self.settings.rng_wrap
        } else {
            self.settings.storage.rng_wrap()
        }
    }

    /// Gradient cells across and down ([`grid_size`] of the settings).
    pub fn gradient_size(&self) -> (u32, u32) {
        grid_size(self.width, self.height, self.settings.gradient_stratum)
    }

    /// Raw temporal gradient of this frame (`GradientSample` per cell and plane, plane-stacked;
    /// `λ` = [`GradientSample::lambda`]): the overlay of what the re-traced samples saw. Valid when
    /// [`Self::gradient_ran`].
    pub fn gradient_raw(&self) -> BufferId {
        self.gradient_raw
    }

    /// Reconstructed (blurred) temporal gradient, the one reprojection reads; same layout as
    /// [`Self::gradient_raw`].
    pub fn gradient(&self) -> BufferId {
        if self.settings.gradient_iterations == 0 {
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
        if s.gradient_stratum == 0 || self.frame.reset || !self.frame.moved {
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
            stratum: s.gradient_stratum,
            grid_width: gw,
            grid_height: gh,
            frame_index: self.frame.index,
            index_mask,
            normal_threshold: s.normal_threshold,
            plane_threshold: s.plane_threshold,
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
        for i in 0..s.gradient_iterations {
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
        let vrrt = s.supersample_target > 0.0;
        let (gw, gh) = self.gradient_size();
        // Below one ray per pixel the budget's rate is the base request (seed: "can use global
        // ray rate < 1") and undersampling rates scale with it: with a base of 1 every request
        // would exceed a 1/2-ray budget and water filling would level refills down to the base.
        let still = s.undersample && !self.frame.moved && !self.frame.reset;
        let base_rate = if vrrt {
            s.rays_per_pixel.min(1.0)
        } else {
            s.rays_per_pixel
        };
        let params = reproject::ReprojectParams {
            width: w,
            height: h,
            planes: s.planes,
            reset: self.frame.reset as u32,
            normal_threshold: s.normal_threshold,
            plane_threshold: s.plane_threshold,
            frame_index: self.frame.index,
            supersample_target: s.supersample_target,
            // On a still frame history stays valid, so it is completed before any undersampling.
            full_history: if still {
                s.max_history
            } else {
                s.undersample_after
            },
            base_rate,
            use_mask: self.frame.use_mask as u32,
            variance_threshold: if s.undersample {
                s.variance_threshold
            } else {
                [0.0; 4]
            },
            variance_rate: s.variance_rate.map(|r| r * base_rate),
            gradient_stratum: if self.gradient_ran {
                s.gradient_stratum
            } else {
                0
            },
            gradient_width: gw,
            gradient_height: gh,
            gradient_threshold: s.gradient_threshold,
            gradient_scale: s.gradient_scale,
            still_history: if still { s.max_history } else { 0.0 },
            still_variance: s.still_sigma * s.still_sigma,
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
            rays_per_pixel: s.rays_per_pixel,
            ring_count: buckets::ring_count(w, h),
            raise: s.spend_saved_rays as u32,
            policy: if s.supersample_target <= 0.0 {
                balance::POLICY_FIXED
            } else if s.load_balance {
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
            max_history: s.max_history,
            rng_wrap: self.rng_wrap(),
            clamp_radius: s.clamp_radius,
            clamp_gamma: s.clamp_gamma,
            firefly_max: s.firefly_max,
            storage: s.storage.code()
                | if s.stuck_correction {
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

        let plane_scale = s.plane_tolerance * self.frame.pixel_angle;
        let var = variance::VarianceParams {
            width: w,
            height: h,
            radius: s.spatial_radius,
            spatial_until: s.spatial_until,
            plane_scale,
            normal_power: s.normal_power,
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
            iterations: s.atrous_iterations,
            skip_sigma: s.skip_sigma,
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
        for i in 0..s.atrous_iterations {
            let params = atrous::AtrousParams {
                width: w,
                height: h,
                step: 1 << i,
                iteration: i,
                sigma_luminance: s.sigma_luminance,
                plane_scale,
                normal_power: s.normal_power,
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
