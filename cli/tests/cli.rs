//! Runs the `vrrt` binary on tiny inputs.

use std::process::Command;

fn vrrt(args: &[&str], cache: &std::path::Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_vrrt"))
        .args(args)
        .env("VRRT_REFERENCE_CACHE", cache)
        .output()
        .expect("run vrrt")
}

#[test]
fn run_writes_frames_csv() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = vrrt(
        &[
            "run",
            "--size",
            "32x18",
            "--frames",
            "3",
            "--spp",
            "16",
            "--overlays",
            "--out",
            out.to_str().unwrap(),
        ],
        &dir.path().join("cache"),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap();
    assert!(header.starts_with(
        "frame,rays_traced,budget,requested,granted,overshoot,rays_saved,prepass_ran,filter_skipped,empty_tiles,signal_absent,relmse,rmse,psnr,ssim,flip,temporal,moving_relmse,fresh_relmse,fresh_pixels,detector_rays,reference_noise,fresh_reference_noise,ms_frame,budget_rpp,trace_ms,ms_"
    ));
    assert_eq!(lines.count(), 3);
    for f in [
        "frame0000_denoised.png",
        "frame0002_reference.png",
        "frame0001_budget.png",
        "denoised_last.exr",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("relMSE, 2nd half"), "{stdout}");
}

#[test]
fn run_with_a_budget_in_ms_writes_the_budget_columns() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = vrrt(
        &[
            "run",
            "--size",
            "32x18",
            "--frames",
            "4",
            "--spp",
            "8",
            "--budget-ms",
            "0.5",
            "--out",
            out.to_str().unwrap(),
        ],
        &dir.path().join("cache"),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (rpp, ms) = (col("budget_rpp"), col("trace_ms"));
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .map(|v| v.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 4);
    // The first frame runs at `--rpp` (1); every budget stays within the floor and ceiling.
    assert_eq!(rows[0][rpp], 1.0);
    for r in &rows {
        assert!((0.25..=4.0).contains(&r[rpp]), "{csv}");
        assert!(r[ms] > 0.0, "{csv}");
    }
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("target 0.5 ms"), "{stdout}");
    assert_usage_error(&["run", "--budget-ms", "2000"], "out of range");
}

#[test]
fn bench_writes_csv() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let o = vrrt(
        &[
            "bench",
            "--scenes",
            "room",
            "--size",
            "24x16",
            "--frames",
            "2",
            "--spp",
            "8",
            "--budgets",
            "1",
            "--configs",
            "svgf,vrrt",
            "--signals",
            "ao,reflections",
            "--backends",
            "cpu",
            "--repeats",
            "2",
            "--out",
            out.to_str().unwrap(),
        ],
        &dir.path().join("cache"),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("bench.csv")).unwrap();
    assert!(csv.starts_with("scene,signal,config,budget_rpp,backend,width,height,frames,relmse,psnr,ssim,flip,temporal_error,moving_relmse,rays_per_frame,ms_per_frame,ms_spread"));
    assert_eq!(csv.lines().count(), 5);
    assert!(csv.contains("\nroom,reflections,vrrt,"), "{csv}");
    assert!(out.join("bench.md").is_file());
}

#[test]
fn run_all_signals_writes_each_part() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = vrrt(
        &[
            "run",
            "--signal",
            "all",
            "--size",
            "32x18",
            "--frames",
            "3",
            "--spp",
            "16",
            "--out",
            out.to_str().unwrap(),
        ],
        &dir.path().join("cache"),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let parts = ["relmse_ao", "relmse_shadows", "relmse_reflections"];
    let columns: Vec<usize> = parts
        .iter()
        .map(|p| header.iter().position(|h| h == p).expect(p))
        .collect();
    for line in lines {
        let row: Vec<&str> = line.split(',').collect();
        for &c in &columns {
            let v: f64 = row[c].parse().unwrap();
            assert!(v.is_finite() && v >= 0.0, "{line}");
        }
    }
    for part in ["ao", "shadows", "reflections"] {
        for f in [
            format!("frame0000_{part}_denoised.png"),
            format!("frame0002_{part}_reference.png"),
            format!("denoised_last_{part}.exr"),
        ] {
            assert!(out.join(&f).is_file(), "{f} missing");
        }
    }
}

fn assert_usage_error(args: &[&str], needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    let o = vrrt(args, dir.path());
    assert_eq!(o.status.code(), Some(2), "{args:?}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains(needle), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bad_input_exits_2_with_a_message() {
    assert_usage_error(
        &["run", "--size", "0x5"],
        "width and height must be at least 1",
    );
    assert_usage_error(&["run", "--size", "12"], "expected WxH");
    assert_usage_error(&["run", "--scene", "nosuch"], "nosuch");
    assert_usage_error(&["run", "--rpp", "0"], "out of range");
    assert_usage_error(&["run", "--scene", "/nonexistent/x.obj"], "x.obj");
    assert_usage_error(&["run", "--frames", "0"], "--frames");
}

#[test]
fn mesh_scenes_without_their_meshes_name_vrrt_fetch() {
    // The default bench (room, bunny, dragon) stops before rendering anything.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    for args in [
        &["bench", "--out", out.to_str().unwrap()][..],
        &["run", "--scene", "dragon"][..],
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_vrrt"))
            .args(args)
            .env("VRRT_REFERENCE_CACHE", dir.path().join("cache"))
            .env("VRRT_MESH_CACHE", dir.path().join("meshes"))
            .output()
            .expect("run vrrt");
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("needs the Stanford"), "{err}");
        assert!(err.contains("run `vrrt fetch` first"), "{err}");
    }
    assert!(!out.exists(), "nothing rendered or written");
}

/// The columns of `frames.csv` that do not depend on timing (frame … moving_relmse).
fn deterministic_columns(csv: &str) -> Vec<String> {
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let end = header.iter().position(|h| *h == "moving_relmse").unwrap() + 1;
    csv.lines()
        .map(|l| l.split(',').take(end).collect::<Vec<_>>().join(","))
        .collect()
}

#[test]
fn info_prints_default_settings_that_run_accepts() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let o = vrrt(&["info", "--settings"], &cache);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let toml = String::from_utf8(o.stdout).unwrap();
    assert!(toml.contains("[filter]\n") && toml.contains("sigma_luminance = 1.0\n"));
    let file = dir.path().join("defaults.toml");
    std::fs::write(&file, &toml).unwrap();
    // The defaults from a file give the same frames as no file at all.
    let mut csv = Vec::new();
    for with_file in [false, true] {
        let out = dir.path().join(format!("out{with_file}"));
        let mut args = vec![
            "run",
            "--size",
            "32x18",
            "--frames",
            "3",
            "--spp",
            "8",
            "--out",
            out.to_str().unwrap(),
        ];
        if with_file {
            args.extend(["--settings", file.to_str().unwrap()]);
        }
        let o = vrrt(&args, &cache);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        csv.push(deterministic_columns(
            &std::fs::read_to_string(out.join("frames.csv")).unwrap(),
        ));
    }
    assert_eq!(csv[0], csv[1]);
}

#[test]
fn run_and_bench_take_a_partial_settings_file() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let file = dir.path().join("s.toml");
    std::fs::write(
        &file,
        "[rates]\nrays_per_pixel = 0.5\n[filter]\natrous_iterations = 2\n",
    )
    .unwrap();
    let out = dir.path().join("run");
    let o = vrrt(
        &[
            "run",
            "--size",
            "24x16",
            "--frames",
            "2",
            "--spp",
            "8",
            "--settings",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &cache,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Without --rpp the file's budget is used.
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("vrrt at 0.5 rpp"), "{stdout}");
    let out = dir.path().join("bench");
    let o = vrrt(
        &[
            "bench",
            "--scenes",
            "room",
            "--size",
            "24x16",
            "--frames",
            "2",
            "--spp",
            "8",
            "--budgets",
            "1",
            "--configs",
            "vrrt",
            "--signals",
            "ao",
            "--backends",
            "cpu",
            "--repeats",
            "1",
            "--settings",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &cache,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("bench.csv")).unwrap();
    assert!(csv.contains("\nroom,ao,vrrt,1,"), "{csv}");
}

#[test]
fn bad_settings_files_exit_2_naming_file_and_problem() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "typo.toml",
            "[filter]\nsigma_luminace = 2.0\n",
            "unknown field `sigma_luminace`",
        ),
        (
            "range.toml",
            "[filter]\nsigma_luminance = 0.0\n",
            "`filter.sigma_luminance` = 0 is out of range",
        ),
        ("syntax.toml", "[rates\n", "line 1"),
    ];
    for (name, text, problem) in cases {
        let file = dir.path().join(name);
        std::fs::write(&file, text).unwrap();
        for cmd in ["run", "bench"] {
            let args = [cmd, "--settings", file.to_str().unwrap()];
            assert_usage_error(&args, name);
            assert_usage_error(&args, problem);
        }
    }
    assert_usage_error(
        &["run", "--settings", "/nonexistent/s.toml"],
        "cannot read settings file /nonexistent/s.toml",
    );
}

#[test]
fn bench_passes_reports_every_denoiser_pass_against_the_floor() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("passes");
    let o = vrrt(
        &[
            "bench",
            "--passes",
            "--size",
            "64x36",
            "--frames",
            "4",
            "--backends",
            "cpu",
            "--out",
            out.to_str().unwrap(),
        ],
        &dir.path().join("cache"),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("passes.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let num = |r: &[&str], name: &str| r[col(name)].parse::<f64>().unwrap();
    let row = |pass: &str| {
        rows.iter()
            .find(|r| r[col("pass")] == pass)
            .unwrap_or_else(|| panic!("no row {pass} in\n{csv}"))
    };
    // The passes of vrrt, AO, 1 rpp that run every frame; the gradient prepass runs only when
    // something moved.
    for pass in [
        "reproject",
        "fill",
        "count_buckets",
        "balance",
        "apply",
        "accumulate",
        "variance",
        "classify",
        "atrous",
        "denoiser",
    ] {
        assert_eq!(row(pass)[col("denoiser")], "1", "{pass}");
    }
    for pass in ["gbuffer", "raygen_ao"] {
        assert_eq!(row(pass)[col("denoiser")], "0", "{pass}");
    }
    assert_eq!(row("denoiser")[col("frames")], "2");
    assert_eq!(row("warmup")[col("frames")], "2");
    // One dispatch per iteration: AO runs as many as reach a tenth of 36 rows.
    let f = vrrt_core::settings::Settings::default().filter;
    let iterations = vrrt_core::kernels::atrous::ao_iterations(f.ao_reach, 36, f.atrous_iterations);
    assert_eq!(
        num(row("atrous"), "dispatches_per_frame"),
        f64::from(iterations)
    );
    let denoiser_ms: f64 = rows
        .iter()
        .filter(|r| r[col("denoiser")] == "1" && !["denoiser", "warmup"].contains(&r[col("pass")]))
        .map(|r| num(r, "ms"))
        .sum();
    assert!((denoiser_ms - num(row("denoiser"), "ms")).abs() < 1e-4);
    for r in &rows {
        let pass = r[col("pass")];
        assert!(num(r, "bytes_per_px") > 0.0, "{pass}");
        assert!(num(r, "bandwidth_gb_s") > 0.0, "{pass}");
        let (ms, floor, ratio) = (num(r, "ms"), num(r, "floor_ms"), num(r, "floor_ratio"));
        assert!(floor > 0.0, "{pass}");
        // The CSV prints 6 decimals of ms: a tiny floor carries few digits.
        let rounding = 0.5e-6 * (ratio + 1.0);
        assert!(
            (ratio * floor - ms).abs() <= 1e-3 * ms + rounding,
            "{pass}: {ratio} != {ms} / {floor}"
        );
    }
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("| **whole denoiser** |"), "{stdout}");
    assert!(stdout.contains("warm-up"), "{stdout}");
}

/// On a device whose storage-buffer binding limit is below what 1080p needs (lavapipe: 128 MiB),
/// `vrrt run` stops before any work with the buffer, the limit and the largest size that fits.
/// Skipped without a Vulkan adapter, unless `VRRT_REQUIRE_VULKAN` is set.
#[test]
fn oversized_request_fails_early_naming_buffer_limit_and_fit() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = vrrt(
        &[
            "run",
            "--size",
            "1920x1080",
            "--frames",
            "1",
            "--spp",
            "2",
            "--backend",
            "ash",
            "--out",
            out.to_str().unwrap(),
        ],
        &dir.path().join("cache"),
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    if stderr.contains("no Vulkan") && std::env::var_os("VRRT_REQUIRE_VULKAN").is_none() {
        println!("skipped: no Vulkan adapter");
        return;
    }
    if o.status.success() {
        // A device with a larger limit (a hardware GPU) runs 1080p: nothing to refuse.
        return;
    }
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    for needle in [
        "`surfaces`",
        "maxStorageBufferRange",
        "largest size",
        "fits is ",
    ] {
        assert!(stderr.contains(needle), "{needle:?} missing: {stderr}");
    }
    // Refused before any frame was rendered.
    assert!(!out.join("frames.csv").exists());
    assert!(!out.join("frame0000_denoised.png").exists());
}
