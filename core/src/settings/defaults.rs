//! The defaults: full VRRT, each value's reason at its field.

use super::*;
use crate::kernels::reflect::Shading;

impl Default for TemporalSettings {
    fn default() -> Self {
        TemporalSettings {
            max_history: 64.0,
            normal_threshold: 0.9,
            plane_threshold: 0.02,
            clamp_radius: 0,
            clamp_gamma: 1.0,
            reflection_clamp_radius: 2,
            clamp_depth_tolerance: 0.05,
            firefly_max: 0.0,
            storage: StoragePrecision::F16,
            rng_wrap: 0,
            stuck_correction: true,
            sampling: SamplePattern::ScreenBlue,
        }
    }
}

impl Default for RateSettings {
    fn default() -> Self {
        RateSettings {
            rays_per_pixel: 1.0,
            budget_ms: 0.0,
            budget_floor: 0.25,
            budget_ceiling: 4.0,
            supersample_target: 16.0,
            load_balance: true,
            spend_saved_rays: true,
            reset_boost: 1.0,
            ao_reset_boost: 3.0,
            shadow_reset_boost: 2.0,
            reset_payback: 8,
            reset_refill: 0.95,
            ao_reset_refill: 0.35,
            ao_reset_contrast: 2.0,
            undersample: true,
            undersample_after: 16.0,
            variance_threshold: [1e-4, 1e-3, 1e-2, 0.0],
            variance_rate: [0.125, 0.25, 0.5, 1.0],
            still_sigma: 0.045,
            vrs_mask: false,
            per_signal: true,
            signal_floor: 0.25,
            shift_requests: true,
        }
    }
}

impl Default for PrepassSettings {
    fn default() -> Self {
        PrepassSettings {
            stratum: 0,
            iterations: 3,
            threshold: 0.5,
            scale: 1.0,
        }
    }
}

impl Default for DetectorSettings {
    fn default() -> Self {
        DetectorSettings {
            radius: 2,
            threshold: 0.5,
            sigma: 1.0,
            ao_sigma: 1.5,
            ao_gain: 3.0,
            min_variance: 1e-4,
            refill: true,
            refill_rays: 4,
            refill_fresh: true,
            refill_share: 0.1,
            shadow_radius: 1,
            shadow_threshold: 0.3,
            shadow_verify_sigma: 0.75,
            shadow_verify_history: 1.0,
            shadow_drop_sigma: 0.75,
            reflection_confirm_sigma: 1.25,
            workgroup_tiles: false,
        }
    }
}

impl Default for FilterSettings {
    fn default() -> Self {
        FilterSettings {
            atrous_iterations: 4,
            sigma_luminance: 1.0,
            normal_power: 128.0,
            ao_normal_power: 8.0,
            plane_tolerance: 2.0,
            spatial_radius: 1,
            spatial_until: 4.0,
            ao_spatial_until: 8.0,
            ao_spatial_rows: 120,
            ao_reach: 0.1,
            wide_until: 3.0,
            wide_rows: 360,
            skip_sigma: 0.004,
            cap_variance: true,
            ao_symmetric_taps: true,
            ao_guide_directions: 0,
            ao_guide_steps: 6,
            ao_guide_refresh: 2,
            guide_sigma: 1.6,
            guided_sigma_luminance: 3.0,
            tall_guided_sigma_luminance: 6.0,
            penumbra_reach: 0.5,
            penumbra_sigma_luminance: 2.0,
            penumbra_radius: 2,
            workgroup_tiles: false,
            fused_pair: false,
        }
    }
}

impl Default for ReflectionSettings {
    fn default() -> Self {
        let sh = Shading::default();
        ReflectionSettings {
            max_roughness: sh.max_roughness,
            min_rate: 0.5,
            max_rate: 2.0,
            tile_sigma: 0.15,
            reuse_radius: 1,
            tall_reuse_radius: 2,
            parallax: true,
            motion_radius: 2,
            plane_threshold: 0.02,
            light_radiance: sh.light_radiance,
            albedo: sh.albedo,
            sky: sh.sky,
            ambient: sh.ambient,
            light_probes: sh.light_probes,
            guide_radius: 2,
            reset_payback: super::MAX_RESET_PAYBACK,
            reset_refill: 0.75,
            reset_contrast: 4.0,
        }
    }
}
