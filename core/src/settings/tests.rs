//! Unit tests of the settings' defaults and range checks, kept apart so settings.rs stays short.

use super::*;

use std::string::ToString;

fn field_of(s: &Settings) -> &'static str {
    match s.validate() {
        Err(SettingsError::OutOfRange { field, .. }) => field,
        other => panic!("expected an out-of-range error, got {other:?}"),
    }
}

#[test]
fn defaults_validate() {
    assert_eq!(Settings::default().validate(), Ok(()));
    assert_eq!(Settings::svgf(0.25).validate(), Ok(()));
}

#[test]
fn svgf_is_the_default_with_rates_off() {
    let s = Settings::svgf(2.0);
    let d = Settings::default();
    assert_eq!(s.rates.rays_per_pixel, 2.0);
    assert_eq!(s.rates.supersample_target, 0.0);
    assert!(!s.rates.load_balance && !s.rates.undersample);
    assert!(s.rates.spend_saved_rays);
    assert_eq!(s.filter.skip_sigma, 0.0);
    assert!(
        !s.filter.cap_variance,
        "SVGF's variance is the textbook blur"
    );
    assert_eq!(
        s.filter.ao_normal_power, d.filter.normal_power,
        "SVGF's AO takes the published normal weight"
    );
    assert_eq!(s.filter.ao_spatial_until, d.filter.spatial_until);
    assert_eq!(
        s.filter.ao_spatial_rows, 0,
        "SVGF's window does not grow with the image"
    );
    assert_eq!(s.filter.ao_reach, 0.0, "SVGF's AO runs every iteration");
    assert!(
        !s.filter.ao_symmetric_taps,
        "SVGF's taps are the published ones"
    );
    assert_eq!(s.filter.wide_until, 0.0, "SVGF's window has one size");
    assert_eq!(s.filter.guide_sigma, 0.0, "SVGF has no hit-distance guide");
    assert_eq!(s.filter.penumbra_reach, 0.0, "SVGF has no penumbra guide");
    assert_eq!(s.detector.radius, 0, "SVGF has no change detector");
    assert_eq!(
        s.temporal.reflection_clamp_radius, 0,
        "SVGF's clamp is the textbook one"
    );
    let detector = DetectorSettings {
        radius: d.detector.radius,
        ..s.detector
    };
    let temporal = TemporalSettings {
        reflection_clamp_radius: d.temporal.reflection_clamp_radius,
        ..s.temporal
    };
    assert_eq!(
        (temporal, s.prepass, detector),
        (d.temporal, d.prepass, d.detector)
    );
    assert_eq!(
        FilterSettings {
            skip_sigma: d.filter.skip_sigma,
            cap_variance: d.filter.cap_variance,
            ao_normal_power: d.filter.ao_normal_power,
            ao_spatial_until: d.filter.ao_spatial_until,
            ao_spatial_rows: d.filter.ao_spatial_rows,
            ao_reach: d.filter.ao_reach,
            ao_symmetric_taps: d.filter.ao_symmetric_taps,
            ao_guide_directions: d.filter.ao_guide_directions,
            wide_until: d.filter.wide_until,
            guide_sigma: d.filter.guide_sigma,
            penumbra_reach: d.filter.penumbra_reach,
            ..s.filter
        },
        d.filter
    );
}

/// Each of `cases` (settings, the field out of range) is refused naming its stage and field.
fn assert_named(cases: &[(Settings, &str)]) {
    for (s, field) in cases {
        assert_eq!(field_of(s), *field);
    }
}

#[test]
fn out_of_range_filter_and_temporal_name_their_field() {
    let d = Settings::default();
    assert_named(&[
        (
            Settings {
                filter: FilterSettings {
                    sigma_luminance: 0.0,
                    ..d.filter
                },
                ..d
            },
            "filter.sigma_luminance",
        ),
        (
            Settings {
                filter: FilterSettings {
                    atrous_iterations: 6,
                    ..d.filter
                },
                ..d
            },
            "filter.atrous_iterations",
        ),
        (
            Settings {
                filter: FilterSettings {
                    wide_until: f32::NAN,
                    ..d.filter
                },
                ..d
            },
            "filter.wide_until",
        ),
        (
            Settings {
                temporal: TemporalSettings {
                    max_history: f32::NAN,
                    ..d.temporal
                },
                ..d
            },
            "temporal.max_history",
        ),
        (
            Settings {
                temporal: TemporalSettings {
                    clamp_radius: 9,
                    ..d.temporal
                },
                ..d
            },
            "temporal.clamp_radius",
        ),
    ]);
}

#[test]
fn out_of_range_rates_prepass_and_detector_name_their_field() {
    let d = Settings::default();
    assert_named(&[
        (
            Settings {
                rates: RateSettings {
                    rays_per_pixel: 17.0,
                    ..d.rates
                },
                ..d
            },
            "rates.rays_per_pixel",
        ),
        (
            Settings {
                rates: RateSettings {
                    budget_ms: f32::NAN,
                    ..d.rates
                },
                ..d
            },
            "rates.budget_ms",
        ),
        (
            Settings {
                rates: RateSettings {
                    budget_floor: 0.0,
                    ..d.rates
                },
                ..d
            },
            "rates.budget_floor",
        ),
        (
            Settings {
                rates: RateSettings {
                    budget_ceiling: 0.2,
                    ..d.rates
                },
                ..d
            },
            "rates.budget_ceiling",
        ),
        (
            Settings {
                rates: RateSettings {
                    variance_threshold: [1e-2, 1e-3, 0.0, 0.0],
                    ..d.rates
                },
                ..d
            },
            "rates.variance_threshold",
        ),
        (
            Settings {
                prepass: PrepassSettings {
                    stratum: 9,
                    ..d.prepass
                },
                ..d
            },
            "prepass.stratum",
        ),
        (
            Settings {
                prepass: PrepassSettings {
                    threshold: 1.5,
                    ..d.prepass
                },
                ..d
            },
            "prepass.threshold",
        ),
        (
            Settings {
                detector: DetectorSettings {
                    threshold: f32::NAN,
                    ..d.detector
                },
                ..d
            },
            "detector.threshold",
        ),
        (
            Settings {
                detector: DetectorSettings {
                    reflection_confirm_sigma: -1.0,
                    ..d.detector
                },
                ..d
            },
            "detector.reflection_confirm_sigma",
        ),
    ]);
}

#[test]
fn a_boost_beyond_its_payback_names_its_field() {
    let d = Settings::default();
    let with = |ao_reset_boost, shadow_reset_boost, reset_payback| Settings {
        rates: RateSettings {
            ao_reset_boost,
            shadow_reset_boost,
            reset_payback,
            ..d.rates
        },
        ..d
    };
    assert_eq!(with(3.0, 2.0, 8).validate(), Ok(()));
    assert_eq!(with(3.0, 3.0, 0).validate(), Ok(()), "no payback, no boost");
    // Paid back over 4 frames, a boost of 3 would leave them a quarter of their budget.
    assert_named(&[
        (with(4.5, 1.0, 16), "rates.ao_reset_boost"),
        (with(3.0, 1.0, 4), "rates.ao_reset_boost"),
        (with(1.0, 4.5, 16), "rates.shadow_reset_boost"),
        (with(1.0, 3.0, 4), "rates.shadow_reset_boost"),
    ]);
}

#[test]
fn rates_are_limited_by_the_history() {
    let d = Settings::default();
    let s = Settings {
        temporal: TemporalSettings {
            max_history: 8.0,
            ..d.temporal
        },
        ..d
    };
    // The stage alone is fine; with a history of 8 rays a target of 16 is not.
    assert_eq!(s.rates.validate(), Ok(()));
    assert_eq!(field_of(&s), "rates.supersample_target");
    let s = Settings {
        rates: RateSettings {
            supersample_target: 8.0,
            ..s.rates
        },
        ..s
    };
    assert_eq!(field_of(&s), "rates.undersample_after");
}

#[test]
fn error_message_names_the_path() {
    let e = FilterSettings {
        sigma_luminance: -1.0,
        ..Default::default()
    }
    .validate()
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "setting `filter.sigma_luminance` = -1 is out of range (> 0)"
    );
}

#[test]
fn reflection_settings_out_of_range_name_their_field() {
    assert_eq!(ReflectionSettings::default().validate(), Ok(()));
    let bad = [
        ReflectionSettings {
            max_roughness: f32::NAN,
            ..Default::default()
        },
        ReflectionSettings {
            min_rate: 3.0,
            ..Default::default()
        },
        ReflectionSettings {
            reuse_radius: 9,
            ..Default::default()
        },
        ReflectionSettings {
            sky: -1.0,
            ..Default::default()
        },
    ];
    for (s, field) in bad.iter().zip([
        "reflections.max_roughness",
        "reflections.min_rate",
        "reflections.reuse_radius",
        "reflections.sky",
    ]) {
        match s.validate() {
            Err(SettingsError::OutOfRange { field: f, .. }) => assert_eq!(f, field),
            other => panic!("{field}: {other:?}"),
        }
    }
}
