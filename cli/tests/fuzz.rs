//! Seeded mutation fuzzing of the command's parsers, in the default test loop: settings files
//! (`settings::parse`, and the configurations' settings built on what it accepts), configuration
//! and other names (`--denoiser`, `--configs`, `--signal(s)`, `--backend(s)`, scene names), image
//! sizes (`--size`), limit sizes and counts (`--max-*`) and ray budgets (`--rpp`, `--budgets`):
//! for each, 25,000 deterministic mutations of valid values, through the value parsers and
//! through clap's parsing of whole command lines. Every input must give a valid value or a
//! one-line error: no panic, no hang, bounded time and memory.
//!
//! `cargo test -p vrrt-cli --test fuzz -- --nocapture` prints one summary line per parser;
//! `VRRT_FUZZ_INPUTS=N` tries N per parser instead. The mutator and the runner are the mesh
//! loaders' (`scene/tests/fuzzkit`).

#[path = "../../scene/tests/fuzzkit/mod.rs"]
mod fuzzkit;

use clap::{Parser, ValueEnum};
use fuzzkit::{Bounds, Mutator, Report, Verdict};
use std::ffi::OsString;
use vrrt_cli::limits::{parse_bytes, parse_count};
use vrrt_cli::session::{parse_backend, parse_rpp, parse_size, Config, SignalArg, MAX_DIMENSION};
use vrrt_cli::settings;
use vrrt_cli::{Cli, Command};
use vrrt_core::settings::ReflectionSettings;
use vrrt_core::settings::{FilterSettings, RateSettings, Settings, TemporalSettings};

/// Longest mutated input.
const MAX_LEN: usize = 4 << 10;

/// Parses `vrrt <args…> <value>` with the mutated bytes as the value (not necessarily UTF-8).
fn clap_parse(args: &[&str], value: &[u8]) -> Result<Cli, clap::Error> {
    use std::os::unix::ffi::OsStringExt;
    let argv = std::iter::once(OsString::from("vrrt"))
        .chain(args.iter().map(OsString::from))
        .chain([OsString::from_vec(value.to_vec())]);
    Cli::try_parse_from(argv)
}

/// A clap failure must render; its kind is the verdict.
fn clap_error(e: clap::Error) -> Result<Verdict, String> {
    use clap::error::ErrorKind as K;
    if e.render().to_string().trim().is_empty() {
        return Err(format!("clap error {:?} renders empty", e.kind()));
    }
    Ok(Verdict::Error(match e.kind() {
        K::ValueValidation => "ValueValidation",
        K::InvalidValue => "InvalidValue",
        K::InvalidUtf8 => "InvalidUtf8",
        K::UnknownArgument => "UnknownArgument",
        K::NoEquals => "NoEquals",
        K::TooManyValues => "TooManyValues",
        K::TooFewValues => "TooFewValues",
        K::WrongNumberOfValues => "WrongNumberOfValues",
        K::ArgumentConflict => "ArgumentConflict",
        K::MissingRequiredArgument => "MissingRequiredArgument",
        K::DisplayHelp => "DisplayHelp",
        K::DisplayVersion => "DisplayVersion",
        _ => "other clap error",
    }))
}

/// A value parser's error: non-empty, and one line unless it quotes an input holding line
/// breaks (the parsers, like clap, echo the value as given).
fn one_line(e: &str, input: &str) -> Result<(), String> {
    let breaks = |t: &str| t.contains(['\n', '\r']);
    if e.trim().is_empty() || (breaks(e) && !breaks(input)) {
        return Err(format!("error is not one line: {e:?}"));
    }
    Ok(())
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

type Check = fn(usize, &[u8]) -> Result<Verdict, String>;

/// Fuzzes one parser: mutations of `seeds`, input `i` tried by `check(i, bytes)`.
fn fuzz(name: &str, seeds: &[&str], words: &[&str], seed: u64, check: Check) -> Report {
    let bounds = Bounds::standard();
    let seeds = seeds.iter().map(|s| s.as_bytes().to_vec()).collect();
    let inputs = Mutator::new(seeds, words, MAX_LEN, seed).into_inputs();
    let report = fuzzkit::run(name, inputs.clone(), bounds, check);
    report.finish(&bounds, &inputs);
    report
}

// ---- Settings files. -------------------------------------------------------------------------

/// A settings file: accepted ones read back through `to_toml` unchanged, and every
/// configuration's settings built on them (at their own budget, for every signal) are valid;
/// refused ones give one line.
fn check_settings(_: usize, bytes: &[u8]) -> Result<Verdict, String> {
    match settings::parse(&text(bytes)) {
        Ok(s) => {
            let again = settings::parse(&settings::to_toml(&s));
            if again != Ok(s) {
                return Err(format!("settings do not read back: {s:?} gives {again:?}"));
            }
            for config in Config::ALL {
                for signal in SignalArg::value_variants() {
                    let c = config.settings(s, s.rates.rays_per_pixel, signal.signal(1.0));
                    if let Err(e) = c.validate() {
                        return Err(format!(
                            "--denoiser {} --signal {} on accepted settings gives invalid \
                             settings: {e}",
                            config.name(),
                            signal.name()
                        ));
                    }
                }
            }
            Ok(Verdict::Valid)
        }
        Err(e) => {
            one_line(&e, "")?;
            Ok(Verdict::Error("settings"))
        }
    }
}

#[test]
fn fuzz_settings_files() {
    let defaults = settings::to_toml(&Settings::default());
    let d = Settings::default();
    let custom = Settings {
        temporal: TemporalSettings {
            max_history: 64.0,
            clamp_radius: 2,
            ..d.temporal
        },
        rates: RateSettings {
            rays_per_pixel: 0.5,
            variance_rate: [1.0 / 64.0, 0.7, 16.0, 1.0 / 3.0],
            ..d.rates
        },
        filter: FilterSettings {
            atrous_iterations: 2,
            ..d.filter
        },
        ..d
    };
    let custom = settings::to_toml(&Settings {
        reflections: ReflectionSettings {
            reuse_radius: 0,
            light_probes: 3,
            ..ReflectionSettings::default()
        },
        ..custom
    });
    let seeds = [
        defaults.as_str(),
        custom.as_str(),
        "",
        "[filter]\nsigma_luminance = 2.5\natrous_iterations = 3\n\n[temporal]\n\
         max_history = 32 # an integer is a fine float\nstorage = \"f16\"\n",
        "[rates]\nrays_per_pixel = 2\nvariance_threshold = [0.0001, 0.001, 0.01, 0.0]\n\
         [prepass]\nstratum = 3\n",
        "[temporal]\nstorage = \"unorm8\"\nstuck_correction = false\n",
    ];
    for s in seeds {
        settings::parse(s).unwrap_or_else(|e| panic!("seed {s:?}: {e}"));
    }
    let words = [
        "[temporal]\n",
        "[rates]\n",
        "[prepass]\n",
        "[detector]\n",
        "[filter]\n",
        "[reflections]\n",
        "[[rates]]\n",
        " = ",
        "=",
        "\"",
        "'",
        "\"\"\"",
        "[",
        "]",
        "{",
        "}",
        ",",
        "#",
        "\n",
        "true",
        "false",
        "nan",
        "inf",
        "-inf",
        "+nan",
        "1e999",
        "0x10",
        "0o7",
        "0b1",
        "1979-05-27T07:32:00Z",
        "planes",
        "parallax_plane",
        "storage = \"f16\"",
        "storage = \"f64\"",
        "rays_per_pixel",
        "max_history",
        "a.b.c",
        "\\u0000",
        "\u{feff}",
        "é",
    ];
    fuzz("settings", &seeds, &words, 0x5e7, check_settings);
}

// ---- Configuration and other names. ------------------------------------------------------------

const NAME_FORMS: [&[&str]; 6] = [
    &["run", "--denoiser"],
    &["bench", "--configs"],
    &["run", "--signal"],
    &["bench", "--signals"],
    &["run", "--backend"],
    &["bench", "--backends"],
];

/// A name: the value parsers accept exactly the documented names, and clap agrees with them.
fn check_names(i: usize, bytes: &[u8]) -> Result<Verdict, String> {
    let s = text(bytes);
    let config = Config::from_str(&s, false);
    if let Ok(c) = config {
        if c.name() != s {
            return Err(format!("`{s}` parses as configuration {}", c.name()));
        }
    }
    let signal = SignalArg::from_str(&s, false);
    if let Ok(k) = signal {
        if k.name() != s {
            return Err(format!("`{s}` parses as signal {}", k.name()));
        }
    }
    let backend = parse_backend(&s);
    match &backend {
        Ok(_) if !["auto", "cpu", "wgpu", "ash"].contains(&s.as_str()) => {
            return Err(format!("`{s}` parses as a backend"));
        }
        Err(e) => one_line(e, &s)?,
        Ok(_) => {}
    }
    // Built-in scenes by name (the names are short: longer inputs cannot be one).
    if s.len() <= 16 {
        match vrrt_scene::builtin::builtin(&s) {
            Ok(_) if !["room", "room_static"].contains(&s.as_str()) => {
                return Err(format!("`{s}` is a built-in scene"));
            }
            Ok(_) => {}
            Err(e) => one_line(&e.to_string(), &s)?,
        }
    }
    let form = NAME_FORMS[i % NAME_FORMS.len()];
    let parsed = match clap_parse(form, bytes) {
        Ok(cli) => cli,
        Err(e) => return clap_error(e),
    };
    // What clap accepted, the value parsers accept (item by item for lists).
    let items: Vec<&str> = s.split(',').collect();
    let agrees = match &parsed.command {
        Command::Run(a) if form[1] == "--denoiser" => config == Ok(a.denoiser),
        Command::Run(a) if form[1] == "--signal" => signal == Ok(a.signal),
        Command::Run(a) => backend == Ok(a.backend),
        Command::Bench(a) if form[1] == "--configs" => items
            .iter()
            .map(|s| Config::from_str(s, false))
            .eq(a.configs.iter().map(|c| Ok(*c))),
        Command::Bench(a) if form[1] == "--signals" => items
            .iter()
            .map(|s| SignalArg::from_str(s, false))
            .eq(a.signals.iter().map(|k| Ok(*k))),
        Command::Bench(a) => items
            .iter()
            .map(|s| parse_backend(s))
            .eq(a.backends.iter().map(|b| Ok(*b))),
        _ => false,
    };
    if !agrees {
        return Err(format!("clap reads `{form:?} {s}` differently"));
    }
    Ok(Verdict::Valid)
}

#[test]
fn fuzz_config_names() {
    let seeds = [
        "raw",
        "svgf",
        "svgf-clamp",
        "vrrt-super",
        "vrrt-balance",
        "vrrt",
        "vrrt-save",
        "vrrt-noskip",
        "raw,svgf,vrrt",
        "ao",
        "shadows",
        "reflections",
        "all",
        "ao,reflections",
        "auto",
        "cpu",
        "wgpu",
        "ash",
        "cpu,wgpu,ash",
        "room",
        "room_static",
    ];
    let words = [
        ",", "-", "_", "vrrt", "svgf", "raw", "clamp", "save", "noskip", "ao", "all", "cpu",
        "room", "--", "--help", "-h", "=", " ", "\u{0}", "é", "\u{200b}",
    ];
    fuzz("config-names", &seeds, &words, 0xc0f, check_names);
}

// ---- Sizes: `--size WxH`, and the byte and count limits. ---------------------------------------

const SIZE_FORMS: [&[&str]; 4] = [
    &["run", "--size"],
    &["info", "--size"],
    &["bench", "--size"],
    &["reference", "--size"],
];

/// Whether clap may refuse a value the value parser accepts: one that is not UTF-8, or that
/// looks like a flag.
fn clap_may_refuse(bytes: &[u8]) -> bool {
    std::str::from_utf8(bytes).is_err() || bytes.starts_with(b"-")
}

/// `WxH`: both in `1..=MAX_DIMENSION`, and the value written back parses the same.
fn check_size(i: usize, bytes: &[u8]) -> Result<Verdict, String> {
    let s = text(bytes);
    let direct = parse_size(&s);
    match &direct {
        Ok((w, h)) => {
            if !(1..=MAX_DIMENSION).contains(w) || !(1..=MAX_DIMENSION).contains(h) {
                return Err(format!("`{s}` parses as {w}x{h}"));
            }
            if parse_size(&format!("{w}x{h}")) != Ok((*w, *h)) {
                return Err(format!("{w}x{h} does not read back"));
            }
        }
        Err(e) => one_line(e, &s)?,
    }
    let form = SIZE_FORMS[i % SIZE_FORMS.len()];
    let size = match clap_parse(form, bytes) {
        Err(e) if direct.is_ok() && !clap_may_refuse(bytes) => {
            return Err(format!("clap refuses `{form:?} {s}`: {e}"));
        }
        Err(e) => return clap_error(e),
        Ok(cli) => match cli.command {
            Command::Run(a) => a.size,
            Command::Info(a) => a.size,
            Command::Bench(a) => a.size.unwrap_or_default(),
            Command::Reference(a) => a.size,
            Command::Fetch(_) => return Err(format!("`{form:?} {s}` parsed as `vrrt fetch`")),
        },
    };
    if Ok(size) != direct {
        return Err(format!("clap reads `{form:?} {s}` as {size:?}"));
    }
    Ok(Verdict::Valid)
}

#[test]
fn fuzz_size_arguments() {
    let seeds = [
        "1920x1080",
        "256x144",
        "1x1",
        "8192x8192",
        "160X90",
        " 32 x 18 ",
        "3840x2160",
    ];
    let words = ["x", "X", "*", "×", " ", "0", "8192", "8193", "+", "-", "\t"];
    fuzz("size", &seeds, &words, 0x512e, check_size);
}

const LIMIT_FORMS: [&[&str]; 5] = [
    &["run", "--max-file-size"],
    &["bench", "--max-decompressed"],
    &["reference", "--max-bvh-memory"],
    &["run", "--max-vertices"],
    &["bench", "--max-triangles"],
];

/// Byte sizes (`512M`) and counts: at least 1, and clap agrees with the value parser.
fn check_limit(i: usize, bytes: &[u8]) -> Result<Verdict, String> {
    let s = text(bytes);
    // Both parsers on every input, whatever the form.
    for r in [parse_count(&s), parse_bytes(&s)] {
        match r {
            Ok(0) => return Err(format!("`{s}` parses as 0")),
            Ok(_) => {}
            Err(e) => one_line(&e, &s)?,
        }
    }
    let form = LIMIT_FORMS[i % LIMIT_FORMS.len()];
    let direct = match form[1] {
        "--max-vertices" | "--max-triangles" => parse_count(&s),
        _ => parse_bytes(&s),
    };
    let limits = match clap_parse(form, bytes) {
        Err(e) if direct.is_ok() && !clap_may_refuse(bytes) => {
            return Err(format!("clap refuses `{form:?} {s}`: {e}"));
        }
        Err(e) => return clap_error(e),
        Ok(cli) => match cli.command {
            Command::Run(a) => a.limits.limits(),
            Command::Bench(a) => a.limits.limits(),
            Command::Reference(a) => a.limits.limits(),
            Command::Info(_) => return Err("`info` has no limits".into()),
            Command::Fetch(_) => return Err("`fetch` has no limits".into()),
        },
    };
    let got = match form[1] {
        "--max-file-size" => limits.max_file_size,
        "--max-decompressed" => limits.max_decompressed_size,
        "--max-bvh-memory" => limits.max_bvh_bytes,
        "--max-vertices" => limits.max_vertices,
        _ => limits.max_triangles,
    };
    if Ok(got) != direct {
        return Err(format!("clap reads `{form:?} {s}` as {got}"));
    }
    Ok(Verdict::Valid)
}

#[test]
fn fuzz_limit_arguments() {
    let seeds = [
        "1G", "512M", "4096", "3kib", " 1 T ", "8G", "67108864", "12", "1", "2KB", "100MiB",
    ];
    let words = [
        "K", "M", "G", "T", "B", "iB", "KB", " ", "0", "-", "+", ".5", "_",
    ];
    fuzz("limits", &seeds, &words, 0x1111, check_limit);
}

// ---- Ray budgets: `--rpp`, `--budgets`. ---------------------------------------------------------

/// Rays per pixel: finite, in `(0, 16]`; lists item by item; clap agrees with the value parser.
fn check_rate(i: usize, bytes: &[u8]) -> Result<Verdict, String> {
    let s = text(bytes);
    let items: Vec<&str> = s.split(',').collect();
    let direct: Vec<Result<f32, String>> = items.iter().map(|s| parse_rpp(s)).collect();
    for (item, r) in items.iter().zip(&direct) {
        match r {
            Ok(v) if !(v.is_finite() && *v > 0.0 && *v <= 16.0) => {
                return Err(format!("`{item}` parses as {v}"));
            }
            Ok(_) => {}
            Err(e) => one_line(e, &s)?,
        }
    }
    let whole = parse_rpp(&s);
    if let Err(e) = &whole {
        one_line(e, &s)?;
    }
    let list = i % 2 == 1;
    let form: &[&str] = if list {
        &["bench", "--budgets"]
    } else {
        &["run", "--rpp"]
    };
    let expect: Result<Vec<f32>, String> = if list {
        direct.into_iter().collect()
    } else {
        whole.map(|v| vec![v])
    };
    let got = match clap_parse(form, bytes) {
        Err(e) if expect.is_ok() && !clap_may_refuse(bytes) => {
            return Err(format!("clap refuses `{form:?} {s}`: {e}"));
        }
        Err(e) => return clap_error(e),
        Ok(cli) => match cli.command {
            Command::Run(a) => a.rpp.into_iter().collect(),
            Command::Bench(a) => a.budgets,
            _ => return Err("unexpected subcommand".into()),
        },
    };
    let same = expect.as_ref().is_ok_and(|e| {
        e.iter()
            .map(|v| v.to_bits())
            .eq(got.iter().map(|v| v.to_bits()))
    });
    if !same {
        return Err(format!(
            "clap reads `{form:?} {s}` as {got:?}, the value parser as {expect:?}"
        ));
    }
    Ok(Verdict::Valid)
}

#[test]
fn fuzz_rate_arguments() {
    let seeds = [
        "1",
        "0.25",
        "16",
        "0.5",
        "2",
        "1e-3",
        "4.0",
        "0.25,0.5,1,2,4",
        "1,2",
    ];
    let words = [
        ",",
        ".",
        "e",
        "E",
        "-",
        "+",
        "0",
        "16",
        "16.000001",
        "1e-45",
        " ",
        "inf",
    ];
    fuzz("rate", &seeds, &words, 0x4a7e, check_rate);
}
