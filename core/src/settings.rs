//! The denoiser's tunables, one struct per stage (like NRD's settings): [`TemporalSettings`]
//! (reprojection and accumulation of history), [`RateSettings`] (how many rays each pixel gets),
//! [`PrepassSettings`] (the A-SVGF temporal-gradient prepass), [`DetectorSettings`] (the change
//! detector and its refill lists), [`FilterSettings`] (variance estimation and the à-trous filter)
//! and [`ReflectionSettings`] (the reflection passes), gathered in [`Settings`]. Where the planes
//! are and this frame's ray budget are not tunables: they are the frame's
//! ([`Layout`](crate::denoiser::Layout),
//! [`Denoiser::rays_per_pixel`](crate::denoiser::Denoiser::rays_per_pixel)).
//!
//! Every struct's `Default` is full VRRT, every field documents its unit, range and default, and
//! every `validate` names a bad field by its path (`filter.sigma_luminance`). With the `serde`
//! feature they (de)serialize with missing fields taken from the defaults and unknown fields
//! refused, so a partial settings file (`vrrt run --settings FILE`) tunes only what it names.

pub use crate::quantize::StoragePrecision;
pub use crate::sampling::SamplePattern;

mod defaults;
mod error;
mod validate;

pub use error::SettingsError;
pub(crate) use validate::check;

/// Largest [`RateSettings::reset_payback`].
pub const MAX_RESET_PAYBACK: u32 = 64;

/// Every tunable of the denoiser, by stage. `Settings::default()` is full VRRT; [`Settings::svgf`]
/// the fixed-rate baseline.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct Settings {
    /// Reprojection and accumulation of history.
    pub temporal: TemporalSettings,
    /// Ray rates: the budget, VRRT's supersampling, undersampling and load balancing.
    pub rates: RateSettings,
    /// The temporal-gradient prepass (A-SVGF), off by default.
    pub prepass: PrepassSettings,
    /// The change detector (no extra rays) and its refill lists, on by default.
    pub detector: DetectorSettings,
    /// Variance estimation and the à-trous spatial filter.
    pub filter: FilterSettings,
    /// The reflection passes, where the signal has reflections.
    pub reflections: ReflectionSettings,
}

/// Reprojection and accumulation of history (`kernels::reproject`, `kernels::accumulate`).
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct TemporalSettings {
    /// History length clamp in rays (1..=2048; default 64).
    pub max_history: f32,
    /// Reprojection: minimum cosine between this frame's and last frame's normals (-1..=1;
    /// default 0.9).
    pub normal_threshold: f32,
    /// Reprojection: maximum plane distance as a fraction of view depth (> 0; default 0.02).
    pub plane_threshold: f32,
    /// Variance clamp of history against this frame's samples: window radius in pixels, 0 = off
    /// (0..=5; default 0, off; the SVGF baseline turns it on, VRRT does not need it).
    pub clamp_radius: u32,
    /// Variance clamp width in standard deviations (> 0; default 1).
    pub clamp_gamma: f32,
    /// Variance clamp of the reflections' history (`Layout::parallax_plane`) over the pixels
    /// of the window that lie on the pixel's own surface (normals within `normal_threshold`, view
    /// depths within `clamp_depth_tolerance`): window radius in pixels, 0 = off (0..=5; default
    /// 2; it replaces `clamp_radius` on that plane). The detector keeps a moving highlight's
    /// history short, and the à-trous filter turns short histories' noise into blotches; clamped,
    /// history stays long without lagging. A window across edges (the textbook clamp) pulled the
    /// room's and the dragon's reflections towards other surfaces.
    pub reflection_clamp_radius: u32,
    /// View-depth tolerance of that window, as a fraction of the pixel's depth (> 0; default
    /// 0.05).
    pub clamp_depth_tolerance: f32,
    /// Firefly clamp of this frame's per-pixel mean, in signal units; 0 = off (>= 0; default 0,
    /// off).
    pub firefly_max: f32,
    /// Precision of the stored history moments (`f16` or `unorm8`; default `f16`, what the seed
    /// ships). The history is stored packed (8 bytes per pixel and plane: binary16 moments and
    /// length, 16-bit rng index); every stored moment is rounded to the precision with the
    /// seed's stuck correction. Unorm8 is for signals in `[0, 1]` (shadows, AO) only.
    pub storage: StoragePrecision,
    /// Width of the stored rng index: it wraps at this value (0 = the width that goes with
    /// `storage`: 2^16 for f16, 2^8 for unorm8; 0..=65536; default 0).
    pub rng_wrap: u32,
    /// The seed's stuck correction when storing low-precision history (default on). Off only to
    /// demonstrate the pixel that never converges without it.
    pub stuck_correction: bool,
    /// Where the rays' first two random numbers come from (`per-pixel` or `screen-blue`; default
    /// `screen-blue`): each pixel's own sequence at the rng index its history carries, or
    /// screen-space blue noise of the pixel and frame that motion does not scramble.
    pub sampling: SamplePattern,
}

/// How many rays each pixel traces: the budget, VRRT's requests and the load balancer
/// (`kernels::reproject`, `kernels::balance`, `kernels::apply`).
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct RateSettings {
    /// Ray budget: average rays per pixel per frame (0 < r <= 16; default 1). With `budget_ms`
    /// it is the first frame's budget only.
    pub rays_per_pixel: f32,
    /// Ray budget in milliseconds of tracing per frame (the `raygen_*` passes): each frame's rays
    /// per pixel follow from the cost of recent frames ([`MsBudget`](crate::budget::MsBudget)); 0 =
    /// off, the fixed `rays_per_pixel` (0 or 0 < t <= 1000; default 0).
    pub budget_ms: f32,
    /// Lowest budget `budget_ms` may set, rays per pixel: however slow the rays, the image keeps
    /// this many (0 < r <= 16; default 0.25).
    pub budget_floor: f32,
    /// Highest budget `budget_ms` may set, rays per pixel (`budget_floor..=16`; default 4: past
    /// 2 rays VRRT's error barely falls, and it caps what the first frames after a stretch of
    /// cheap ones may cost).
    pub budget_ceiling: f32,
    /// VRRT supersampling: pixels with less history than this many rays ask for the difference
    /// (up to 16 a frame); 0 turns VRRT off: every pixel traces `rays_per_pixel`, fractions by a
    /// blue-noise test, and `load_balance` is moot (rays; 0 or 1..=`temporal.max_history`;
    /// default 16).
    pub supersample_target: f32,
    /// Fit requests to the budget with the load balancer (default on). Off: requests are traced
    /// as asked, whatever they cost.
    pub load_balance: bool,
    /// Spend budget left over by raising low requests, inner rings first (default on); off is the
    /// "save" mode.
    pub spend_saved_rays: bool,
    /// Move every request by the same step to fit the budget, down over it and up under it, so
    /// rays go where history is shortest (`kernels::balance::MODE_SHIFT`, `MODE_LIFT`: water
    /// filling on history plus rays), instead of capping the largest requests or raising the
    /// smallest, the seed's: capped, a pixel disoccluded after a camera cut gets the same one ray
    /// as its neighbours with ten (default on). The reflections' requests, which their tiles'
    /// importance scales, keep the seed's rule, and so do the shadows' in a shared frame, where
    /// their refills and verification rays would take the other signals' rays.
    pub shift_requests: bool,
    /// After a reset (first frame, camera cut) the balancer spends this many frames' budget
    /// ahead, and the next `reset_payback` frames spend it less (0..=1; default 1; balanced rates
    /// only, and none under `budget_ms`, whose frames must keep to their time). Every pixel is
    /// fresh then and holds only this frame's rays, which stay in the history the next frames
    /// add to: spent early they count in every frame, the cut's included (see
    /// `docs/algorithms/fresh-pixels.md`). The cost is a frame of twice the rays at the cut.
    /// Reflections alone pay it back over `reflections.reset_payback` frames; a frame of AO
    /// alone takes `ao_reset_boost` instead, and one of shadows alone `shadow_reset_boost`.
    pub reset_boost: f32,
    /// What a frame of AO alone (`Layout::ao_alone`) spends ahead at a reset in place of
    /// `reset_boost` (0..=4, at most half of `reset_payback`; default 3: at one ray per pixel a
    /// cut's frame traces four frames' budget, the next `reset_payback` frames 5/8 of theirs).
    /// Below that budget it is lowered so that the payback frames keep 5/8 of a ray per pixel,
    /// but not below `reset_boost` (a value under `reset_boost` is kept as set:
    /// `denoiser::rates::alone_boost`). AO's fresh pixels gain from each ray the cut's frame gets,
    /// and its history holds them for every later frame; the reflections lost with a larger
    /// boost (`docs/algorithms/fresh-pixels.md`).
    pub ao_reset_boost: f32,
    /// What a frame of shadows alone (`Layout::shadows_alone`) spends ahead at a reset in place
    /// of `reset_boost`, lowered the same way as `ao_reset_boost` (0..=4, at most half of
    /// `reset_payback`; default 2: at one ray per pixel a cut's frame traces three frames'
    /// budget, `reset_refill` of the boost on the penumbrae, and the next `reset_payback` frames
    /// 3/4 of theirs). At 3 the payback frames starved the pixels a moving object uncovers
    /// (`docs/algorithms/fresh-pixels.md`).
    pub shadow_reset_boost: f32,
    /// Frames over which a reset's `reset_boost` is paid back (0 = no boost; 0..=64; default 8:
    /// a frame without rays after the cut starves what it disoccludes and lets moving shadows
    /// lag; see `docs/algorithms/fresh-pixels.md`).
    pub reset_payback: u32,
    /// Share of `reset_boost` a reset frame spends on the shadows' penumbrae instead of on every
    /// pixel (0..=1; default 0.95; only a denoiser of the shadows alone, `Layout::shadows_alone`:
    /// in a shared frame the other signals would pay for the penumbrae): the pixels whose 3×3
    /// window of rays is mixed are re-traced with it, up to 16 rays (`kernels::refill`; see
    /// `docs/algorithms/penumbra-guide.md`). The rest is a second ray for a tenth of the pixels
    /// at one ray per pixel: where the penumbrae are wide and the lists hit their 16 rays, it
    /// keeps the boost from going unspent (`docs/algorithms/fresh-pixels.md`). AO alone takes
    /// `ao_reset_refill` instead, reflections alone `reflections.reset_refill`.
    pub reset_refill: f32,
    /// Share of `ao_reset_boost` a reset frame of AO alone spends on the pixels whose 3×3
    /// window of rays is contrasted (`ao_reset_contrast`) instead of on every pixel (0..=1,
    /// 0 = off; default 0.35; on images at least `filter.wide_rows` tall, and at most what
    /// leaves the main pass a ray per pixel). Past four rays the filter, not the rays, sets a
    /// cut's error on open surfaces; in the crevices and at the silhouettes the filter brightens
    /// the darkest pixels from their neighbours, and there up to 16 rays of their own hold them
    /// (see `docs/algorithms/fresh-pixels.md`).
    pub ao_reset_refill: f32,
    /// Factor by which the brightest ray mean of a reset pixel's 3×3 window must exceed its
    /// darkest for the pixel to take `ao_reset_refill`'s rays (>= 1; default 2: a window that
    /// holds a pixel with most of its rays occluded; at a few rays a pixel 3 lists the same).
    pub ao_reset_contrast: f32,
    /// VRRT undersampling of converged pixels by variance (default on).
    pub undersample: bool,
    /// History length (rays) from which a pixel counts as converged and may undersample
    /// (1..=`temporal.max_history`; default 16, the supersampling target: a pixel that has
    /// refilled its history stops asking and may give rays away). The seed waits for full history
    /// (`max_history`); the shorter wait frees rays sooner for disocclusions, at some risk on
    /// slowly changing signals, which the change detector covers (see
    /// `docs/algorithms/undersampling.md`).
    pub undersample_after: f32,
    /// Undersampling thresholds on the variance of the estimate (signal units squared), increasing;
    /// a 0 ends the list (each >= 0; default `[1e-4, 1e-3, 1e-2, 0]`).
    pub variance_threshold: [f32; 4],
    /// Undersampling rates of those thresholds, relative to the base rate
    /// `min(rays_per_pixel, 1)` (each in 1/64..=16; default `[1/8, 1/4, 1/2, 1]`).
    pub variance_rate: [f32; 4],
    /// Still frames (nothing moved, `FrameInfo::moved` false): history stays valid, so it may grow
    /// to twice `temporal.max_history` (at most 2048; the length whose plain mean is worth what a
    /// pixel clamped at `max_history` reaches by tracing on, see `Denoiser::history_clamp`);
    /// pixels complete it first, as fast as the budget allows, and then those whose estimate's
    /// standard deviation (signal units) is below this ask only for the floor,
    /// `variance_rate[0]`; the first frame that moves cuts history back. 0 = off. With
    /// `spend_saved_rays` off the rays stay unspent ("save" mode). Needs `undersample` (>= 0;
    /// default 0.045).
    pub still_sigma: f32,
    /// The engine writes a VRS-style mask every frame
    /// ([`Denoiser::mask`](crate::denoiser::Denoiser::mask), `u32` per pixel, 0 = needs no ray) and
    /// pixels it rules out ask for none (default off: no mask is kept, 4 bytes per pixel saved).
    pub vrs_mask: bool,
    /// A frame with several signals (`Signal::All`) gives each its own ray requests and work list
    /// (`Layout::plane_groups`) instead of one request per pixel that traces every signal
    /// (default on).
    pub per_signal: bool,
    /// Least share of the budget a signal keeps when the balancer shares it by the rays each
    /// signal requests (`kernels::balance::group_rates`), as a fraction of its equal share; 1
    /// gives every signal `rays_per_pixel` (0..=1; default 0.25).
    pub signal_floor: f32,
}

/// The temporal-gradient prepass (A-SVGF, `kernels::gradient`): one re-traced sample per stratum
/// tells where the signal changed, so history is dropped there instead of clamped and VRRT can
/// supersample. It re-traces last frame's rays, so it costs rays; the [`DetectorSettings`] find
/// changes in this frame's own rays.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct PrepassSettings {
    /// Stratum size in pixels, one re-traced sample per stratum and frame (0 = off, default;
    /// 1..=8: 3 and more re-trace a fraction of the rays; 1 also takes per-pixel changes the
    /// host supplies, `FrameScene::changes`).
    pub stratum: u32,
    /// À-trous iterations of the gradient reconstruction at stratum resolution (0..=5; default 3).
    pub iterations: u32,
    /// Gradient `λ` above which history is dropped like a disocclusion (0..=1; default 0.5);
    /// below it history is shortened to `count · (1 − λ)`.
    pub threshold: f32,
    /// Gain on the reconstructed `λ` (`min(1, scale · λ)`, >= 0; default 1, A-SVGF as published).
    /// A single binary ray per stratum sees slow changes (a light creeping, a penumbra sliding)
    /// as a small `λ`; a gain shortens history there sooner, like Q2RTX's anti-lag scale.
    pub scale: f32,
}

/// The change detector (`kernels::detect`, no extra rays): this frame's rays are tested against
/// the history over a window, and where they disagree the `λ` it finds shortens or drops history;
/// the pixels it drops that traced nothing are re-traced in the same frame (the refill lists,
/// `kernels::refill`).
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct DetectorSettings {
    /// Radius in pixels of the window over which this frame's rays are tested against the
    /// history; 0 = off (0..=4; default 2, 5×5).
    pub radius: u32,
    /// The detector's `λ` above which history is dropped like a disocclusion (0..=1; default
    /// 0.5, the prepass's `threshold`); below it history is shortened to `count · (1 − λ)`. The
    /// shadow planes take `shadow_threshold`.
    pub threshold: f32,
    /// Significance, in standard deviations, from which a detected change counts fully (>= 1;
    /// default 1: at 1.5σ and above moving shadows lag more; with the refill lists, 1 is
    /// better than 1.5 on every signal of room, bunny and dragon, see
    /// `docs/algorithms/change-detector.md`). The AO planes take `ao_sigma`.
    pub sigma: f32,
    /// Per-ray variance the detector assumes at least (signal units squared, >= 0; default
    /// 1e-4): a converged pixel's history may read 0.
    pub min_variance: f32,
    /// Trace `refill_rays`, in the same frame, for each pixel whose history the detector drops
    /// and that traced none (`kernels::refill`; default on); the rays come out of the frame's own
    /// budget, set aside from last frame's lists (`kernels::refill::fit`, `docs/ray-budget.md`).
    pub refill: bool,
    /// Rays of each refilled pixel when the lists fit what the frame set aside (1..=16;
    /// default 4: with fewer, moving shadows lag; more gain nothing, see
    /// `docs/algorithms/change-detector.md`); the lists share what is left over or missing. A
    /// dropped pixel is a fresh one, and a fresh one asks for up to 16.
    pub refill_rays: u32,
    /// The reflections' fresh pixels (disoccluded this frame) that traced fewer than
    /// `refill_rays` join the refill lists too (default on): a glossy reflection at one ray is
    /// the noisiest the filter sees where it has no history to lean on.
    pub refill_fresh: bool,
    /// Most of a signal's budget the refill lists may set aside from the main pass (0 < share
    /// <= 1; default 0.1); the lists share what that and the main pass leave
    /// (`kernels::refill::fit`). Sized to a large disocclusion (a crossing sphere's reflection),
    /// a larger reserve starved the main pass whose rays the listed pixels reuse (see
    /// `docs/algorithms/reflections.md`).
    pub refill_share: f32,
    /// `radius` of the shadow planes (`Layout::shadow_planes`)
    /// (0..=4; default 1): a sliding penumbra changes a band about a pixel wide, a share of the
    /// window that falls as `1 / (2r + 1)`, so a 5×5 window sees it as a small `λ` and history
    /// lags. AO's soft, faint changes need the larger window to be significant (see
    /// `docs/algorithms/change-detector.md`).
    pub shadow_radius: u32,
    /// `threshold` of the shadow planes (0..=1; default 0.3).
    pub shadow_threshold: f32,
    /// `sigma` of the AO planes (`Layout::ao_planes`; >= 1; default 1.5) at one ray per pixel
    /// and more; below, it rises as `1/√rays_per_pixel` (`kernels::detect::ao_significance`):
    /// AO changes only where geometry moves, and where a frame holds few rays a low
    /// significance shortens converged history by chance (see
    /// `docs/algorithms/change-detector.md`).
    pub ao_sigma: f32,
    /// Gain of `λ` on the AO planes (>= 1, 1 = none; default 3), up to the drop `threshold`
    /// (`kernels::detect::plane_lambda`): AO's slow changes read as a small `λ`, which left
    /// history as long as a converged pixel's, and the contact shadows of moving objects lagged
    /// (see `docs/algorithms/change-detector.md`).
    pub ao_gain: f32,
    /// Verification of the shadow planes (>= 0, 0 = off; default 0.75): a pixel that traced fewer
    /// than `refill_rays` and whose own rays lie this many standard deviations from its history
    /// (`kernels::detect::pixel_z`) joins the refill lists, and accumulation drops its history
    /// where the `refill_rays` then lie `shadow_drop_sigma` from it. A thin umbra that the camera
    /// slides under a pixel of lit history is one disagreeing ray, which the detector's window
    /// dilutes; four rays decide it. Against less noisy references the dragon's slow penumbra
    /// changes showed that 0.75 here and in `shadow_drop_sigma` lag less than 1.5 (see
    /// `docs/algorithms/change-detector.md`).
    pub shadow_verify_sigma: f32,
    /// History length (rays) from which that test trusts a pixel's history variance (>= 1;
    /// default 1: a younger history already asks for rays).
    pub shadow_verify_history: f32,
    /// Significance of two or more rays against their history from which accumulation drops
    /// it on the shadow planes (> 0; default 0.75).
    pub shadow_drop_sigma: f32,
    /// Confirmation of the reflections' drops (on the
    /// `Layout::parallax_plane`; >= 0, 0 = off; default
    /// 1.25): where `λ` drops history, the pixel's own rays (the refill lists give it some) must
    /// lie this many standard deviations from it (`kernels::detect::pixel_z`), or the history is
    /// kept whole. The 1σ window reads noise as a
    /// change now and then, and a converged reflection dropped by chance comes back as blotches
    /// (see `docs/algorithms/change-detector.md`).
    pub reflection_confirm_sigma: f32,
    /// The detector reads each texel's terms from a workgroup tile, computed once per workgroup
    /// (`kernels::refill::tile`), instead of once per window it falls in (default off). The
    /// results are the same; a choice for GPUs, not yet measured on one: on lavapipe it halved
    /// the detector's time, on the CPU backend it is 5x slower (see `docs/results/per-pass.md`).
    pub workgroup_tiles: bool,
}

/// The reflection passes (`crate::reflections`, `kernels::reflect`): the rays' roughness cut-off
/// and the shading of what they hit, the tile classification, ray reuse, the parallax and the
/// hit-distance guide. Used wherever the signal has reflections.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct ReflectionSettings {
    /// Surfaces with a larger GGX alpha reflect nothing and trace no reflection ray (0..=1;
    /// default 0.5; the seed traces "HQ rays for roughness < 20%" and filters the rest).
    pub max_roughness: f32,
    /// Request scale of a tile whose reflection is flat or empty (0 < min <= max; default 0.5).
    pub min_rate: f32,
    /// Request scale of the noisiest tiles (min..=4; default 2).
    pub max_rate: f32,
    /// Standard deviation of the tone-mapped tracer values that earns `max_rate` (> 0; default
    /// 0.15).
    pub tile_sigma: f32,
    /// Ray reuse radius in pixels (0..=3; 0 = no reuse; default 1, a 3×3 neighbourhood: on the
    /// room, 5×5 reuses rays across lobes too different and the error rises again), on images
    /// less than `filter.wide_rows` tall.
    pub reuse_radius: u32,
    /// `reuse_radius` on images at least `filter.wide_rows` tall, but for reset frames (0..=3;
    /// default 2, a 5×5 neighbourhood). Why larger there: a glossy lobe and the surface under
    /// it span more pixels, so a wider window still gathers rays of nearly the same lobe, and
    /// each pixel reuses more of them; on a reset frame, where no pixel has history, it made
    /// the first frame worse (measured in `docs/algorithms/reflections.md`).
    pub tall_reuse_radius: u32,
    /// Reproject reflections along the parallax of their hit distance (default on); off, they
    /// follow the surface (the G-buffer motion), which smears them when the camera moves.
    pub parallax: bool,
    /// Radius over which last frame's hit distances are averaged for the parallax (0..=3;
    /// default 2).
    pub motion_radius: u32,
    /// Reuse only neighbours within this fraction of view depth of the pixel's tangent plane
    /// (> 0; default 0.02, the reprojection's plane test).
    pub plane_threshold: f32,
    /// Radiance of the lights seen in a reflection (>= 0; default 5).
    pub light_radiance: f32,
    /// Albedo of the surfaces seen in a reflection (0..=1; default 0.7).
    pub albedo: f32,
    /// Radiance of the sky (>= 0; default 0.3).
    pub sky: f32,
    /// Ambient irradiance at reflected hits (>= 0; default 0.1).
    pub ambient: f32,
    /// Extra lobe directions per ray that only test for the lights (0..=15; default 7; 0 = the
    /// lights' part from the ray's own direction alone): unbiased, and they beat more rays at
    /// about equal time ([`crate::kernels::reflect`], "Light probes";
    /// `docs/algorithms/reflections.md`).
    pub light_probes: u32,
    /// Window radius of the hit-distance guide (`kernels::reflect::reflect_guide`; 0..=3;
    /// default 2, a 5×5 mean: on the bunny's first frame a 3×3 one guides worse).
    pub guide_radius: u32,
    /// Frames over which a frame of reflections alone pays back a reset's `rates.reset_boost`,
    /// in place of `rates.reset_payback` (0..=64; default 64, the longest: over 8 frames their
    /// moving highlights starve after a cut, while their fresh pixels gain from the boost either
    /// way; `docs/algorithms/fresh-pixels.md`).
    pub reset_payback: u32,
    /// Share of `rates.reset_boost` a reset frame of reflections alone spends on the pixels whose
    /// 3×3 window of rays is contrasted (`reset_contrast`) instead of on every pixel, in place of
    /// `rates.reset_refill` (0..=1, 0 = off; default 0.75; at most what leaves the main pass a
    /// ray per pixel). At a cut the filter has no history to lean on, and its error lies at the
    /// highlights' and the reflected silhouettes' edges, where one ray in a neighbour leaks in:
    /// there the listed pixels add up to 16 rays to their sequences (`kernels::refill`;
    /// `docs/algorithms/reflections.md`).
    pub reset_refill: f32,
    /// Factor by which the brightest ray of a reset pixel's 3×3 window must exceed its darkest
    /// for the pixel to take `reset_refill`'s rays (>= 1; default 4: at 2 the dragon's fresh
    /// pixels kept less of the gain, at 6 every scene's did; `docs/algorithms/reflections.md`).
    pub reset_contrast: f32,
}

/// Variance estimation and the edge-stopping à-trous filter (`kernels::variance`,
/// `kernels::classify`, `kernels::atrous`).
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct FilterSettings {
    /// À-trous iterations, strides 1, 2, 4, … pixels (0..=5; default 4, as the seed's engine
    /// runs: SVGF's fifth, 16-pixel stride made only one quality-bench sequence better, and by
    /// little, for a pass over the image; `docs/results/per-pass.md`).
    pub atrous_iterations: u32,
    /// Luminance edge-stopping σ_l, in standard deviations of the estimate (> 0; default 1: with
    /// the variance of the estimate, not of a single ray, SVGF's 4 over-blurs contact shadows and
    /// disocclusions).
    pub sigma_luminance: f32,
    /// Normal edge-stopping exponent (>= 0; default 128).
    pub normal_power: f32,
    /// Normal edge-stopping exponent of the AO planes (`Layout::ao_planes`; >= 0; default 8;
    /// SVGF as published: `normal_power`). AO is a cosine-weighted integral over the hemisphere,
    /// so it turns slowly with the normal; at 128 a curved mesh at 128x72 rejects neighbours a
    /// few degrees apart and a 1-ray pixel keeps its own ray (see
    /// `docs/algorithms/fresh-pixels.md`).
    pub ao_normal_power: f32,
    /// Plane-distance tolerance in pixel footprints (> 0; default 2).
    pub plane_tolerance: f32,
    /// Window radius of the spatial variance estimate in pixels (0..=5; default 1, i.e. 3×3:
    /// SVGF's 7×7 mixes an umbra or a thin shadow with the lit surface around it into one large
    /// variance, and the filter then blurs the edge away; see `docs/algorithms/fresh-pixels.md`).
    pub spatial_radius: u32,
    /// History shorter than this (rays) blends in the spatial variance estimate (>= 0; default 4).
    pub spatial_until: f32,
    /// `spatial_until` of the AO planes (>= 0; default 8; SVGF as published: `spatial_until`).
    /// From `spatial_until` rays on a pixel's σ is its own rays' alone, and a few binary rays
    /// that agree give σ = 0 and no filtering: AO's first frame at 4 rays was worse than at 2.
    /// Shadows keep 4: at 8 their whole sequences got worse (see
    /// `docs/algorithms/fresh-pixels.md`).
    pub ao_spatial_until: f32,
    /// Image height (rows) at which `ao_spatial_until` applies as written; a taller image
    /// scales it by `height / ao_spatial_rows`, at most 3x (`kernels::variance::spatial_until_at`;
    /// default 120; 0 = never scaled, as SVGF). The 3×3 window covers less of the scene as
    /// the resolution grows, so its mean costs less detail and is worth more rays: the best
    /// whole-sequence AO was at 8 rays at 160x90, 16 at 320x180 and 24–32 at 640x360 (see
    /// `docs/algorithms/fresh-pixels.md`).
    pub ao_spatial_rows: u32,
    /// How far the AO planes' à-trous taps may reach, as a fraction of the image height (0..=1,
    /// 0 = as far as `atrous_iterations` go, as SVGF; default 0.1). The AO planes run the
    /// iterations whose footprint, `2·(2ⁿ − 1)` pixels from the centre, stays within
    /// `ao_reach × rows`, at least one and at most `atrous_iterations`
    /// (`kernels::atrous::ao_iterations`): 2 at 90 rows, 3 at 144–180, 4 from 360 on. A wide
    /// stride at a small size blurs across what the scene holds of AO's detail (a contact, a
    /// crease, a thin pole); from 360 rows on, fewer were no better (see
    /// `docs/results/benchmarks.md`, "AO's filter reach on small images").
    pub ao_reach: f32,
    /// Pixels holding fewer rays than this take a spatial variance window one pixel wider
    /// (`spatial_radius + 1`, 5×5 by default) on the AO and reflections planes of an image at
    /// least `wide_rows` tall (>= 0; default 3: a cut's pixels, which hold the reset boost's two
    /// rays; 0 = off, as SVGF). Two rays leave a pixel's own estimate, and a 3×3 window's,
    /// noisiest. Pixels with more rays, the shadows' penumbrae (whose edges are in the signal)
    /// and smaller images, where 5×5 covers more of the scene, were worse with it (see
    /// `docs/algorithms/fresh-pixels.md`).
    pub wide_until: f32,
    /// Image height (rows) from which `wide_until`, `tall_guided_sigma_luminance` and
    /// `reflections.tall_reuse_radius` apply (default 360; 0 = every size).
    pub wide_rows: u32,
    /// Adaptive filtering: an 8×8 tile runs only the à-trous iterations needed to bring its
    /// largest standard deviation of the estimate (signal units) below this (each iteration
    /// counted as halving it, `kernels::classify`); 0 = every tile runs every iteration (>= 0;
    /// default 0.004, below what a [0, 1] signal shows on an 8-bit display).
    pub skip_sigma: f32,
    /// Cap the luminance test's blurred variance at the pixel's own (default on; SVGF as
    /// published: off). Next to a noisier surface the 3×3 blur raises a pixel's σ to its
    /// neighbours' and the filter pulls a highlight into the dark line beside it.
    pub cap_variance: bool,
    /// À-trous on the AO planes takes its taps in point-symmetric pairs, each pair at the
    /// geometric mean of its two weights (default on; SVGF as published: off). Next to a crease
    /// or a contact the edge-stopping weights keep only the brighter side of the window, and its
    /// mean is biased toward it; a symmetric window cancels a linear gradient. Shadows and
    /// reflections keep one-sided windows: their edges are in the signal, not the geometry, and
    /// pairs made the room's fresh reflections worse (see `docs/algorithms/fresh-pixels.md`).
    pub ao_symmetric_taps: bool,
    /// Directions of the AO guide the AO planes' spatial filter divides by and multiplies back
    /// (`kernels::ao_guide`: screen-space AO from the G-buffer alone; 0..=64, 0 = off; default
    /// off, 16 and 24 measured). A pixel without history leans on its neighbours, and where AO changes
    /// within the filter's footprint (a crevice, a silhouette) their mean is not the pixel's;
    /// the ratio to the guide is flat there. Every AO figure of the production bench but the
    /// flicker gained with 16 and more with 24, but the march's depth reads (directions × steps a pixel) cost the CPU backend
    /// several times its frame, so it is a choice, not yet measured on a GPU (see
    /// `docs/algorithms/fresh-pixels.md`). Needs the AO rays' length
    /// (`Denoiser::set_ao_radius`; `Frame` sets it from the signal).
    pub ao_guide_directions: u32,
    /// Steps per direction of the AO guide's march (1..=32; default 6).
    pub ao_guide_steps: u32,
    /// Directions a pixel marches once its AO guide holds `ao_guide_directions` of them
    /// (0..=64, at most `ao_guide_directions` taken; default 2): the guide is kept across frames, reprojected
    /// like history, and each frame blends these few new ones in. 0 marches every direction
    /// every frame, from a dither fixed to the screen, which flickers where the camera moves.
    pub ao_guide_refresh: u32,
    /// σ of the hit-distance guide of the reflections, in stops of hit distance (`log2`; >= 0,
    /// 0 = off; default 1.6). The G-buffer does not show the edges inside a reflected image and
    /// at 1 rpp the luminance test cannot find them either (`kernels::reflect::reflect_guide`).
    pub guide_sigma: f32,
    /// `sigma_luminance` of the plane the guide steers (> 0; default 3). Where the guide stops
    /// the filter at the reflected image's edges, the luminance test need not, and at 1 rpp its
    /// σ from a few rays cuts the blur the flat parts need (see
    /// `docs/algorithms/reflections.md`).
    pub guided_sigma_luminance: f32,
    /// `guided_sigma_luminance` on images at least `wide_rows` tall (> 0; default 6): on
    /// smaller images the filter's footprint covers more of the reflected image, and the wider
    /// test blurred it (measured in `docs/algorithms/reflections.md`).
    pub tall_guided_sigma_luminance: f32,
    /// Reach of à-trous on the penumbra plane in penumbra widths (`k`: a tap `r` pixels from a
    /// pixel whose penumbra is `W` pixels wide weighs `exp(−(r / (k·W))²)`; >= 0, 0 = off;
    /// default 0.5): at 1 rpp the luminance test tells neither a wide penumbra nor a contact
    /// shadow's edge from noise, the blockers can (`kernels::penumbra`; the sweep is in
    /// `docs/algorithms/penumbra-guide.md`).
    pub penumbra_reach: f32,
    /// `sigma_luminance` of the penumbra plane (> 0; default 2): within the reach the luminance
    /// test need not stop the taps (see `docs/algorithms/penumbra-guide.md`).
    pub penumbra_sigma_luminance: f32,
    /// Window radius of the penumbra guide's mean (0..=3; default 2).
    pub penumbra_radius: u32,
    /// À-trous reads its taps from workgroup tiles, each texel loaded and decoded once per
    /// workgroup (`kernels::atrous::tile`), instead of once per tap (default off). The results
    /// are the same; only the speed differs, and it is a choice for GPUs, not yet measured on
    /// one: on lavapipe the tiles saved 1–5%, and the CPU backend runs a workgroup's invocations
    /// one after another (see `docs/results/per-pass.md`).
    pub workgroup_tiles: bool,
    /// The first two à-trous iterations run as one dispatch (`kernels::atrous::pair`), the
    /// first's results kept in workgroup memory, its halo filtered again by each workgroup
    /// (default off). The results are the same and 16 bytes per pixel of AO are not moved; a
    /// choice for GPUs, not yet measured on one, and a slow one on the CPU backend, which runs
    /// a workgroup's invocations one after another (see `docs/results/per-pass.md`).
    pub fused_pair: bool,
}

impl FilterSettings {
    /// Whether an image `rows` tall takes the tall-image values (`wide_until`,
    /// `tall_guided_sigma_luminance`, `reflections.tall_reuse_radius`): at least `wide_rows`.
    pub fn tall(&self, rows: u32) -> bool {
        rows >= self.wide_rows
    }
}

impl Settings {
    /// The SVGF baseline VRRT is measured against (every tile filtered fully, as published): every
    /// pixel traces `rays_per_pixel`, no requests, no balancing.
    pub fn svgf(rays_per_pixel: f32) -> Self {
        Settings::default().to_svgf(rays_per_pixel)
    }

    /// These settings with VRRT's rates and the adaptive filter turned off, as in [`Self::svgf`]:
    /// every pixel traces `rays_per_pixel`, no supersampling, undersampling or balancing, no
    /// change detector, the textbook variance clamp only (no reflections' own-surface clamp),
    /// and every tile runs every filter iteration. The other fields are kept.
    pub fn to_svgf(self, rays_per_pixel: f32) -> Self {
        Settings {
            rates: RateSettings {
                rays_per_pixel,
                supersample_target: 0.0,
                load_balance: false,
                undersample: false,
                ..self.rates
            },
            filter: FilterSettings {
                skip_sigma: 0.0,
                cap_variance: false,
                ao_normal_power: self.filter.normal_power,
                ao_spatial_until: self.filter.spatial_until,
                ao_spatial_rows: 0,
                ao_reach: 0.0,
                wide_until: 0.0,
                ao_symmetric_taps: false,
                ao_guide_directions: 0,
                guide_sigma: 0.0,
                penumbra_reach: 0.0,
                ..self.filter
            },
            detector: DetectorSettings {
                radius: 0,
                ..self.detector
            },
            temporal: TemporalSettings {
                reflection_clamp_radius: 0,
                ..self.temporal
            },
            ..self
        }
    }

    /// Checks every field against its documented range: the frame-level fields, each stage's
    /// [`validate`](TemporalSettings::validate), and the limits one stage puts on another
    /// (`rates.supersample_target` and `rates.undersample_after` up to `temporal.max_history`).
    pub fn validate(&self) -> Result<(), SettingsError> {
        self.temporal.validate()?;
        self.rates.validate()?;
        self.prepass.validate()?;
        self.detector.validate()?;
        self.filter.validate()?;
        self.reflections.validate()?;
        let (r, max) = (&self.rates, self.temporal.max_history);
        check(
            r.supersample_target <= max,
            "rates.supersample_target",
            r.supersample_target,
            "0 or 1..=temporal.max_history",
        )?;
        check(
            r.undersample_after <= max,
            "rates.undersample_after",
            r.undersample_after,
            "1..=temporal.max_history",
        )
    }
}

#[cfg(all(test, feature = "std"))]
mod tests;
