//! Settings files: the denoiser's [`Settings`] as TOML, one table per stage (`[temporal]`,
//! `[rates]`, `[prepass]`, `[detector]`, `[filter]`, `[reflections]`). Fields left out keep their
//! defaults, unknown fields are errors, and the result is validated by
//! [`Settings::validate`], so a bad file fails before anything runs with the file, the line and
//! the problem in one line.

use anyhow::{anyhow, Result};
use std::path::Path;
use vrrt_core::settings::Settings;

/// First lines of [`to_toml`]'s output.
const HEADER: &str = "\
# VRRT-rs settings (`vrrt run --settings FILE`, `vrrt bench --settings FILE`).
# Every field is optional: one left out keeps the default shown here; unknown fields are errors.
# Units and ranges: vrrt_core::settings (one struct per table). The planes and their roles are
# not settings: they follow from the signal (vrrt_core::denoiser::Layout).
";

/// Parses the text of a settings file and validates it. The error is one line: where (line and
/// column, for a TOML or type error) and what.
pub fn parse(text: &str) -> Result<Settings, String> {
    let settings: Settings = toml::from_str(text).map_err(|e| describe(text, &e))?;
    settings.validate().map_err(|e| e.to_string())?;
    Ok(settings)
}

/// Largest settings file read: the defaults take about 2 KiB.
pub const MAX_SETTINGS_BYTES: u64 = 1 << 20;

/// Reads and parses the settings file at `path` (a regular file of at most
/// [`MAX_SETTINGS_BYTES`]: a FIFO or `/dev/zero` is refused, not waited on or read without end);
/// errors name the file.
pub fn load(path: &Path) -> Result<Settings> {
    use vrrt_scene::safe_fs::{read_capped_string, ReadError};
    let text = read_capped_string(path, MAX_SETTINGS_BYTES).map_err(|e| match e {
        ReadError::Io(e) => anyhow!("cannot read settings file {}: {e}", path.display()),
        other => anyhow!("settings file {} {other}", path.display()),
    })?;
    parse(&text).map_err(|e| anyhow!("settings file {}: {e}", path.display()))
}

/// `settings` as the text of a settings file (with a comment header). Every float is written as
/// the shortest decimal that reads back to the same `f32` (`0.9`, not `0.8999999761581421`), so
/// [`parse`] gives `settings` back exactly.
pub fn to_toml(settings: &Settings) -> String {
    let mut value = toml::Value::try_from(settings).expect("settings serialize to TOML");
    shorten_floats(&mut value);
    let body = toml::to_string(&value).expect("a TOML table serializes");
    format!("{HEADER}\n{body}")
}

/// Rewrites every float of `v` (all of them `f32` values widened to `f64`) as the `f64` nearest
/// to the `f32`'s shortest decimal.
fn shorten_floats(v: &mut toml::Value) {
    match v {
        toml::Value::Float(f) if f.is_finite() => {
            let short = (*f as f32).to_string();
            *f = short.parse().expect("a float's decimal parses");
        }
        toml::Value::Array(a) => a.iter_mut().for_each(shorten_floats),
        toml::Value::Table(t) => t.iter_mut().for_each(|(_, v)| shorten_floats(v)),
        _ => {}
    }
}

/// A TOML or deserialization error as `line L, column C: message`, on one line: the message's
/// line breaks become spaces and other control characters escapes (a value quoted from the file,
/// such as `storage = "\r"`, may hold them).
fn describe(text: &str, e: &toml::de::Error) -> String {
    let message: String = e
        .message()
        .trim()
        .replace('\n', " ")
        .chars()
        .map(|c| match c {
            c if c.is_control() => c.escape_debug().to_string(),
            c => c.to_string(),
        })
        .collect();
    match e.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            // The parser's message does not say which key is duplicated; the span holds it.
            let key = text
                .get(span.clone())
                .map(|k| k.trim().trim_matches(['[', ']']).trim())
                .filter(|k| message.contains("duplicate") && !k.is_empty() && !k.contains('\n'));
            match key {
                Some(key) => format!("line {line}, column {column}: {message} `{key}`"),
                None => format!("line {line}, column {column}: {message}"),
            }
        }
        None => message,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vrrt_core::settings::{
        DetectorSettings, FilterSettings, PrepassSettings, RateSettings, ReflectionSettings,
        SamplePattern, StoragePrecision, TemporalSettings,
    };

    #[test]
    fn defaults_round_trip() {
        let d = Settings::default();
        let text = to_toml(&d);
        assert_eq!(parse(&text), Ok(d), "{text}");
        // Readable floats, the stages as tables.
        for needle in [
            "[temporal]",
            "[rates]",
            "[prepass]",
            "[detector]",
            "[filter]",
            "[reflections]",
            "light_probes = 7\n",
            "normal_threshold = 0.9\n",
            "variance_threshold = [0.0001, 0.001, 0.01, 0.0]\n",
            "storage = \"f16\"\n",
        ] {
            assert!(text.contains(needle), "{needle} missing from\n{text}");
        }
    }

    /// [`unusual_settings`]' rates: every field off its default.
    fn unusual_rates() -> RateSettings {
        RateSettings {
            rays_per_pixel: 0.3,
            budget_ms: 2.5,
            budget_floor: 0.125,
            budget_ceiling: 3.0,
            supersample_target: 7.0,
            load_balance: false,
            spend_saved_rays: false,
            reset_boost: 0.375,
            ao_reset_boost: 1.25,
            shadow_reset_boost: 0.75,
            reset_payback: 3,
            reset_refill: 0.1 + 0.2,
            ao_reset_refill: 0.875,
            ao_reset_contrast: 1.5,
            undersample: false,
            undersample_after: 9.5,
            variance_threshold: [1.1e-5, 2.2e-4, 0.0, 0.0],
            variance_rate: [1.0 / 64.0, 0.7, 16.0, 1.0 / 3.0],
            still_sigma: 0.0,
            vrs_mask: true,
            per_signal: false,
            signal_floor: 0.6,
            shift_requests: false,
        }
    }

    /// Non-default settings everywhere, awkward floats included.
    fn unusual_settings() -> Settings {
        Settings {
            temporal: TemporalSettings {
                max_history: 1000.5,
                normal_threshold: -0.3,
                plane_threshold: 1.0e-7,
                clamp_radius: 2,
                clamp_gamma: 0.1 + 0.2,
                reflection_clamp_radius: 4,
                clamp_depth_tolerance: 0.125,
                firefly_max: 3.3333333,
                storage: StoragePrecision::Unorm8,
                rng_wrap: 12345,
                stuck_correction: false,
                sampling: SamplePattern::PerPixel,
            },
            rates: unusual_rates(),
            prepass: PrepassSettings {
                stratum: 5,
                iterations: 0,
                threshold: 0.123,
                scale: 32.0,
            },
            detector: DetectorSettings {
                radius: 3,
                threshold: 0.875,
                sigma: 2.5,
                min_variance: 3.0e-5,
                refill: false,
                refill_rays: 7,
                refill_fresh: false,
                refill_share: 0.5,
                shadow_radius: 3,
                shadow_threshold: 0.25,
                ao_sigma: 2.5,
                ao_gain: 4.5,
                shadow_verify_sigma: 0.75,
                shadow_verify_history: 9.5,
                shadow_drop_sigma: 2.25,
                reflection_confirm_sigma: 0.5,
                workgroup_tiles: true,
            },
            filter: FilterSettings {
                atrous_iterations: 2,
                sigma_luminance: 4.0,
                normal_power: 0.0,
                ao_normal_power: 3.5,
                plane_tolerance: 1.0 / 7.0,
                spatial_radius: 0,
                spatial_until: 0.0,
                ao_spatial_until: 2.5,
                ao_spatial_rows: 45,
                ao_reach: 0.25,
                wide_until: 1.5,
                wide_rows: 77,
                skip_sigma: 1.0e-3,
                cap_variance: false,
                ao_symmetric_taps: false,
                ao_guide_directions: 7,
                ao_guide_steps: 5,
                ao_guide_refresh: 3,
                guide_sigma: 0.1 + 0.7,
                guided_sigma_luminance: 2.75,
                tall_guided_sigma_luminance: 5.5,
                penumbra_reach: 0.1 + 0.2,
                penumbra_sigma_luminance: 1.25,
                penumbra_radius: 1,
                workgroup_tiles: true,
                fused_pair: true,
            },
            reflections: ReflectionSettings {
                max_roughness: 0.25,
                min_rate: 0.3,
                max_rate: 3.5,
                tile_sigma: 0.1 + 0.2,
                reuse_radius: 2,
                tall_reuse_radius: 3,
                parallax: false,
                motion_radius: 0,
                plane_threshold: 1.0e-7,
                light_radiance: 12.5,
                albedo: 0.33333334,
                sky: 0.0,
                ambient: 0.7,
                light_probes: 15,
                guide_radius: 3,
                reset_payback: 17,
                reset_refill: 0.625,
                reset_contrast: 2.5,
            },
        }
    }

    #[test]
    fn every_field_round_trips() {
        let s = unusual_settings();
        assert_eq!(parse(&to_toml(&s)), Ok(s));
    }

    #[test]
    fn shortest_decimals_read_back_exactly() {
        // What `to_toml` relies on: an f32's shortest decimal, read as f64 (as TOML does) and
        // narrowed to f32 (as serde does), is the same f32.
        let mut x = 0x9e37_79b9u32;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let v = f32::from_bits(x);
            if v.is_finite() {
                let back = v.to_string().parse::<f64>().unwrap() as f32;
                assert_eq!(back.to_bits(), v.to_bits(), "{v}");
            }
        }
    }

    #[test]
    fn partial_file_keeps_the_other_defaults() {
        let text = "\
[filter]
sigma_luminance = 2.5
atrous_iterations = 3

[temporal]
max_history = 32 # an integer is a fine float
storage = \"f16\"
";
        let s = parse(text).unwrap();
        let d = Settings::default();
        let denoiser = Settings {
            filter: FilterSettings {
                sigma_luminance: 2.5,
                atrous_iterations: 3,
                ..d.filter
            },
            temporal: TemporalSettings {
                max_history: 32.0,
                storage: StoragePrecision::F16,
                ..d.temporal
            },
            ..d
        };
        assert_eq!(s, denoiser);
        assert_eq!(parse(""), Ok(Settings::default()));
        let r = parse("[reflections]\nlight_probes = 0\n").unwrap();
        let expected = ReflectionSettings {
            light_probes: 0,
            ..ReflectionSettings::default()
        };
        assert_eq!(
            r,
            Settings {
                reflections: expected,
                ..d
            }
        );
    }

    #[test]
    fn sample_patterns_by_name() {
        for (name, pattern) in [
            ("per-pixel", SamplePattern::PerPixel),
            ("screen-blue", SamplePattern::ScreenBlue),
        ] {
            let s = parse(&format!("[temporal]\nsampling = \"{name}\"\n")).unwrap();
            assert_eq!(s.temporal.sampling, pattern);
        }
        assert!(parse("[temporal]\nsampling = \"blue\"\n").is_err());
    }

    #[test]
    fn duplicate_keys_and_large_integers_are_named_exactly() {
        let e = parse("[temporal]\nmax_history = 3\nmax_history = 4\n").unwrap_err();
        assert!(e.contains("duplicate key `max_history`"), "{e}");
        let e = parse("[temporal]\nrng_wrap = 4294967295\n").unwrap_err();
        assert!(e.contains("`temporal.rng_wrap` = 4294967295 is out"), "{e}");
        let e = parse("planes = 2\n").unwrap_err();
        assert!(e.contains("unknown field `planes`"), "{e}");
    }

    #[test]
    fn unknown_fields_are_errors() {
        let e = parse("[filter]\nsigma_luminace = 2.0\n").unwrap_err();
        assert!(e.starts_with("line 2, column 1: "), "{e}");
        assert!(e.contains("unknown field `sigma_luminace`"), "{e}");
        let e = parse("[filters]\nsigma_luminance = 2.0\n").unwrap_err();
        assert!(e.contains("unknown field `filters`"), "{e}");
        let e = parse("rays_per_pixel = 2.0\n").unwrap_err();
        assert!(e.contains("unknown field `rays_per_pixel`"), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }

    #[test]
    fn bad_values_are_errors() {
        let e = parse("[filter]\nsigma_luminance = -1.0\n").unwrap_err();
        assert_eq!(
            e,
            "setting `filter.sigma_luminance` = -1 is out of range (> 0)"
        );
        let e = parse("[rates]\nrays_per_pixel = 32\n").unwrap_err();
        assert!(e.contains("`rates.rays_per_pixel`"), "{e}");
        let e = parse("[temporal]\nmax_history = 8.0\n").unwrap_err();
        assert!(e.contains("`rates.supersample_target`"), "{e}");
        let e = parse("[prepass]\nstratum = -1\n").unwrap_err();
        assert!(e.starts_with("line 2, column 11: "), "{e}");
        let e = parse("[reflections]\nlight_probes = 16\n").unwrap_err();
        assert_eq!(
            e,
            "setting `reflections.light_probes` = 16 is out of range (0..=15)"
        );
        let e = parse("[reflections]\nreuse = 1\n").unwrap_err();
        assert!(e.contains("unknown field `reuse`"), "{e}");
        let e = parse("[temporal]\nstorage = \"f64\"\n").unwrap_err();
        assert!(e.contains("unknown variant `f64`"), "{e}");
        let e = parse("[rates]\nrays_per_pixel = ").unwrap_err();
        assert!(e.starts_with("line 2, column "), "{e}");
        // A quoted value's control characters stay escaped: the error is one line.
        let e = parse("[temporal]\nstorage = \"\\r\\n\\t\"\n").unwrap_err();
        assert!(e.contains("unknown variant `\\r \\t`"), "{e}");
        assert!(!e.contains(['\n', '\r']), "{e}");
    }
}
