//! The range checks: each stage's `validate` and the `check` they share, apart from the structs.

use super::{
    DetectorSettings, FilterSettings, PrepassSettings, RateSettings, ReflectionSettings,
    SettingsError, TemporalSettings,
};
use crate::kernels::reflect;

/// `Ok` when `ok`, else the out-of-range error for `field` (the settings validators' one check).
pub(crate) fn check(
    ok: bool,
    field: &'static str,
    value: impl Into<f64>,
    range: &'static str,
) -> Result<(), SettingsError> {
    if ok {
        Ok(())
    } else {
        Err(SettingsError::OutOfRange {
            field,
            value: value.into(),
            range,
        })
    }
}

/// Largest history length in rays: the packed history holds it as binary16, whose whole numbers
/// are consecutive up to 2048.
const MAX_HISTORY: f32 = 2048.0;

impl TemporalSettings {
    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let finite = |v: f32| v.is_finite();
        check(
            finite(self.max_history) && self.max_history >= 1.0 && self.max_history <= MAX_HISTORY,
            "temporal.max_history",
            self.max_history,
            "1..=2048",
        )?;
        check(
            self.rng_wrap <= 1 << 16,
            "temporal.rng_wrap",
            self.rng_wrap,
            "0..=65536 (the packed history holds 16 bits)",
        )?;
        check(
            finite(self.normal_threshold) && (-1.0..=1.0).contains(&self.normal_threshold),
            "temporal.normal_threshold",
            self.normal_threshold,
            "-1..=1",
        )?;
        check(
            finite(self.plane_threshold) && self.plane_threshold > 0.0,
            "temporal.plane_threshold",
            self.plane_threshold,
            "> 0",
        )?;
        check(
            self.clamp_radius <= 5,
            "temporal.clamp_radius",
            self.clamp_radius,
            "0..=5",
        )?;
        check(
            finite(self.clamp_gamma) && self.clamp_gamma > 0.0,
            "temporal.clamp_gamma",
            self.clamp_gamma,
            "> 0",
        )?;
        check(
            self.reflection_clamp_radius <= 5,
            "temporal.reflection_clamp_radius",
            self.reflection_clamp_radius,
            "0..=5",
        )?;
        check(
            finite(self.clamp_depth_tolerance) && self.clamp_depth_tolerance > 0.0,
            "temporal.clamp_depth_tolerance",
            self.clamp_depth_tolerance,
            "> 0",
        )?;
        check(
            finite(self.firefly_max) && self.firefly_max >= 0.0,
            "temporal.firefly_max",
            self.firefly_max,
            ">= 0",
        )
    }
}

impl RateSettings {
    /// Checks every field against its documented range. The limit `temporal.max_history` puts on
    /// `supersample_target` and `undersample_after` is checked by [`Settings::validate`]; here
    /// they may go up to the largest history, 65504.
    ///
    /// [`Settings::validate`]: super::Settings::validate
    pub fn validate(&self) -> Result<(), SettingsError> {
        let finite = |v: f32| v.is_finite();
        check(
            finite(self.rays_per_pixel) && self.rays_per_pixel > 0.0 && self.rays_per_pixel <= 16.0,
            "rates.rays_per_pixel",
            self.rays_per_pixel,
            "0 < r <= 16",
        )?;
        check(
            finite(self.budget_ms) && self.budget_ms >= 0.0 && self.budget_ms <= 1000.0,
            "rates.budget_ms",
            self.budget_ms,
            "0 (off) or 0 < t <= 1000",
        )?;
        check(
            finite(self.budget_floor) && self.budget_floor > 0.0 && self.budget_floor <= 16.0,
            "rates.budget_floor",
            self.budget_floor,
            "0 < r <= 16",
        )?;
        check(
            finite(self.budget_ceiling)
                && self.budget_ceiling >= self.budget_floor
                && self.budget_ceiling <= 16.0,
            "rates.budget_ceiling",
            self.budget_ceiling,
            "rates.budget_floor..=16",
        )?;
        check(
            finite(self.supersample_target)
                && (self.supersample_target == 0.0
                    || (self.supersample_target >= 1.0 && self.supersample_target <= MAX_HISTORY)),
            "rates.supersample_target",
            self.supersample_target,
            "0 or 1..=temporal.max_history",
        )?;
        check(
            finite(self.undersample_after)
                && self.undersample_after >= 1.0
                && self.undersample_after <= MAX_HISTORY,
            "rates.undersample_after",
            self.undersample_after,
            "1..=temporal.max_history",
        )?;
        for i in 0..4 {
            let t = self.variance_threshold[i];
            check(
                finite(t) && t >= 0.0,
                "rates.variance_threshold",
                t,
                ">= 0, finite",
            )?;
            if i > 0 && t != 0.0 {
                let prev = self.variance_threshold[i - 1];
                check(
                    t >= prev,
                    "rates.variance_threshold",
                    t,
                    "increasing (0 ends the list)",
                )?;
            }
            let r = self.variance_rate[i];
            check(
                finite(r) && (1.0 / 64.0..=16.0).contains(&r),
                "rates.variance_rate",
                r,
                "1/64..=16",
            )?;
        }
        check(
            finite(self.still_sigma) && self.still_sigma >= 0.0,
            "rates.still_sigma",
            self.still_sigma,
            ">= 0",
        )?;
        check(
            (0.0..=1.0).contains(&self.signal_floor),
            "rates.signal_floor",
            self.signal_floor,
            "0..=1",
        )?;
        self.validate_reset()
    }

    /// The fields of a reset's boost, its payback and the shadows' refill.
    fn validate_reset(&self) -> Result<(), SettingsError> {
        check(
            (0.0..=1.0).contains(&self.reset_boost),
            "rates.reset_boost",
            self.reset_boost,
            "0..=1",
        )?;
        for (boost, name) in [
            (self.ao_reset_boost, "rates.ao_reset_boost"),
            (self.shadow_reset_boost, "rates.shadow_reset_boost"),
        ] {
            check(
                (0.0..=4.0).contains(&boost)
                    && (self.reset_payback == 0 || boost * 2.0 <= self.reset_payback as f32),
                name,
                boost,
                "0..=4 and at most half of rates.reset_payback",
            )?;
        }
        check(
            self.reset_payback <= super::MAX_RESET_PAYBACK,
            "rates.reset_payback",
            self.reset_payback,
            "0..=64",
        )?;
        check(
            (0.0..=1.0).contains(&self.ao_reset_refill),
            "rates.ao_reset_refill",
            self.ao_reset_refill,
            "0..=1",
        )?;
        check(
            self.ao_reset_contrast.is_finite() && self.ao_reset_contrast >= 1.0,
            "rates.ao_reset_contrast",
            self.ao_reset_contrast,
            ">= 1",
        )?;
        check(
            (0.0..=1.0).contains(&self.reset_refill),
            "rates.reset_refill",
            self.reset_refill,
            "0..=1",
        )
    }
}

impl PrepassSettings {
    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let finite = |v: f32| v.is_finite();
        check(self.stratum <= 8, "prepass.stratum", self.stratum, "0..=8")?;
        check(
            self.iterations <= 5,
            "prepass.iterations",
            self.iterations,
            "0..=5",
        )?;
        check(
            finite(self.threshold) && (0.0..=1.0).contains(&self.threshold),
            "prepass.threshold",
            self.threshold,
            "0..=1",
        )?;
        check(
            finite(self.scale) && self.scale >= 0.0,
            "prepass.scale",
            self.scale,
            ">= 0",
        )
    }
}

impl DetectorSettings {
    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let finite = |v: f32| v.is_finite();
        check(self.radius <= 4, "detector.radius", self.radius, "0..=4")?;
        check(
            finite(self.threshold) && (0.0..=1.0).contains(&self.threshold),
            "detector.threshold",
            self.threshold,
            "0..=1",
        )?;
        for (v, name) in [
            (self.sigma, "detector.sigma"),
            (self.ao_sigma, "detector.ao_sigma"),
            (self.ao_gain, "detector.ao_gain"),
            (self.shadow_verify_history, "detector.shadow_verify_history"),
        ] {
            check(finite(v) && v >= 1.0, name, v, ">= 1")?;
        }
        for (v, name) in [
            (self.min_variance, "detector.min_variance"),
            (self.shadow_verify_sigma, "detector.shadow_verify_sigma"),
            (
                self.reflection_confirm_sigma,
                "detector.reflection_confirm_sigma",
            ),
        ] {
            check(finite(v) && v >= 0.0, name, v, ">= 0")?;
        }
        check(
            finite(self.refill_share) && self.refill_share > 0.0 && self.refill_share <= 1.0,
            "detector.refill_share",
            self.refill_share,
            "0 < share <= 1",
        )?;
        check(
            (1..=16).contains(&self.refill_rays),
            "detector.refill_rays",
            self.refill_rays,
            "1..=16",
        )?;
        check(
            self.shadow_radius <= 4,
            "detector.shadow_radius",
            self.shadow_radius,
            "0..=4",
        )?;
        check(
            (0.0..=1.0).contains(&self.shadow_threshold),
            "detector.shadow_threshold",
            self.shadow_threshold,
            "0..=1",
        )?;
        check(
            finite(self.shadow_drop_sigma) && self.shadow_drop_sigma > 0.0,
            "detector.shadow_drop_sigma",
            self.shadow_drop_sigma,
            "> 0",
        )
    }
}

impl FilterSettings {
    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let finite = |v: f32| v.is_finite();
        check(
            self.atrous_iterations <= 5,
            "filter.atrous_iterations",
            self.atrous_iterations,
            "0..=5",
        )?;
        for (v, name) in [
            (self.sigma_luminance, "filter.sigma_luminance"),
            (self.plane_tolerance, "filter.plane_tolerance"),
            (self.guided_sigma_luminance, "filter.guided_sigma_luminance"),
            (
                self.tall_guided_sigma_luminance,
                "filter.tall_guided_sigma_luminance",
            ),
            (
                self.penumbra_sigma_luminance,
                "filter.penumbra_sigma_luminance",
            ),
        ] {
            check(finite(v) && v > 0.0, name, v, "> 0")?;
        }
        for (v, name) in [
            (self.normal_power, "filter.normal_power"),
            (self.ao_normal_power, "filter.ao_normal_power"),
            (self.spatial_until, "filter.spatial_until"),
            (self.ao_spatial_until, "filter.ao_spatial_until"),
            (self.wide_until, "filter.wide_until"),
            (self.skip_sigma, "filter.skip_sigma"),
            (self.guide_sigma, "filter.guide_sigma"),
            (self.penumbra_reach, "filter.penumbra_reach"),
        ] {
            check(finite(v) && v >= 0.0, name, v, ">= 0")?;
        }
        check(
            finite(self.ao_reach) && (0.0..=1.0).contains(&self.ao_reach),
            "filter.ao_reach",
            self.ao_reach,
            "0..=1",
        )?;
        check(
            self.spatial_radius <= 5,
            "filter.spatial_radius",
            self.spatial_radius,
            "0..=5",
        )?;
        check(
            self.penumbra_radius <= 3,
            "filter.penumbra_radius",
            self.penumbra_radius,
            "0..=3",
        )?;
        check(
            self.ao_guide_directions <= 64,
            "filter.ao_guide_directions",
            self.ao_guide_directions,
            "0..=64",
        )?;
        check(
            (1..=32).contains(&self.ao_guide_steps),
            "filter.ao_guide_steps",
            self.ao_guide_steps,
            "1..=32",
        )?;
        check(
            self.ao_guide_refresh <= 64,
            "filter.ao_guide_refresh",
            self.ao_guide_refresh,
            "0..=64",
        )
    }
}

impl ReflectionSettings {
    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let f = |v: f32| v.is_finite();
        check(
            f(self.max_roughness) && (0.0..=1.0).contains(&self.max_roughness),
            "reflections.max_roughness",
            self.max_roughness,
            "0..=1",
        )?;
        check(
            f(self.min_rate) && self.min_rate > 0.0 && self.min_rate <= self.max_rate,
            "reflections.min_rate",
            self.min_rate,
            "0 < min_rate <= max_rate",
        )?;
        check(
            f(self.max_rate) && self.max_rate <= 4.0,
            "reflections.max_rate",
            self.max_rate,
            "min_rate..=4",
        )?;
        check(
            f(self.tile_sigma) && self.tile_sigma > 0.0,
            "reflections.tile_sigma",
            self.tile_sigma,
            "> 0",
        )?;
        for (radius, name) in [
            (self.reuse_radius, "reflections.reuse_radius"),
            (self.tall_reuse_radius, "reflections.tall_reuse_radius"),
        ] {
            check(radius <= 3, name, radius, "0..=3")?;
        }
        check(
            self.guide_radius <= 3,
            "reflections.guide_radius",
            self.guide_radius,
            "0..=3",
        )?;
        check(
            self.reset_payback <= super::MAX_RESET_PAYBACK,
            "reflections.reset_payback",
            self.reset_payback,
            "0..=64",
        )?;
        check(
            (0.0..=1.0).contains(&self.reset_refill),
            "reflections.reset_refill",
            self.reset_refill,
            "0..=1",
        )?;
        check(
            f(self.reset_contrast) && self.reset_contrast >= 1.0,
            "reflections.reset_contrast",
            self.reset_contrast,
            ">= 1",
        )?;
        check(
            self.light_probes <= reflect::MAX_LIGHT_PROBES,
            "reflections.light_probes",
            self.light_probes,
            "0..=15",
        )?;
        check(
            self.motion_radius <= 3,
            "reflections.motion_radius",
            self.motion_radius,
            "0..=3",
        )?;
        check(
            f(self.plane_threshold) && self.plane_threshold > 0.0,
            "reflections.plane_threshold",
            self.plane_threshold,
            "> 0",
        )?;
        for (field, v) in [
            ("reflections.light_radiance", self.light_radiance),
            ("reflections.sky", self.sky),
            ("reflections.ambient", self.ambient),
        ] {
            check(f(v) && v >= 0.0, field, v, ">= 0")?;
        }
        check(
            f(self.albedo) && (0.0..=1.0).contains(&self.albedo),
            "reflections.albedo",
            self.albedo,
            "0..=1",
        )
    }
}
