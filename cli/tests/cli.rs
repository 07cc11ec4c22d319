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
        "frame,rays_traced,budget,requested,granted,overshoot,rays_saved,prepass_ran,filter_skipped,empty_tiles,signal_absent,relmse,rmse,psnr,ssim,flip,temporal,moving_relmse,ms_frame,ms_"
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
fn bench_writes_csv() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let o = vrrt(
        &[
            "bench",
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
