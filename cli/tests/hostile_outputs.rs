//! The `vrrt` binary against hostile output directories and inputs (issue 47): only the files
//! the last run wrote are removed, no write follows a link, every argument and the output
//! directory are checked before anything is removed or rendered, FIFOs and devices never hang a
//! run, and duplicate bench budgets are one cell.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs `vrrt args` with its caches in `dir`; fails the test (killing it) if it runs past a
/// minute, as a read of a FIFO would.
fn vrrt(args: &[&str], dir: &Path) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_vrrt"))
        .args(args)
        .env("VRRT_REFERENCE_CACHE", dir.join("cache"))
        .env("VRRT_MESH_CACHE", dir.join("meshes"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run vrrt");
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("vrrt {args:?} hung");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// `vrrt run` at the small size into `out`, with `extra` options (which replace the
/// defaults of the same name).
fn run(dir: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["run", "--out", out.to_str().unwrap()];
    for (flag, value) in [("--size", "32x18"), ("--frames", "2"), ("--spp", "4")] {
        if !extra.contains(&flag) {
            args.extend([flag, value]);
        }
    }
    args.extend_from_slice(extra);
    vrrt(&args, dir)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().unwrap().success();
    assert!(ok, "mkfifo {}", path.display());
}

#[test]
fn a_run_removes_only_what_the_last_run_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("D");
    std::fs::create_dir(&out).unwrap();
    // Names an earlier pattern match took for the run's own.
    let users = [
        "framework_notes_v2.png",
        "frame0001_mine.png",
        "frames.csv.bak",
    ];
    for f in users {
        std::fs::write(out.join(f), b"user").unwrap();
    }
    let o = run(dir.path(), &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("frame0001_denoised.png").is_file());
    // A shorter second run removes the first run's frame 1.
    let o = run(dir.path(), &out, &["--frames", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!out.join("frame0001_denoised.png").exists());
    assert!(out.join("frame0000_denoised.png").is_file());
    for f in users {
        assert_eq!(std::fs::read(out.join(f)).unwrap(), b"user", "{f}");
    }
}

#[test]
fn a_bench_keeps_a_users_report_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("D");
    std::fs::create_dir_all(out.join("report")).unwrap();
    let users = ["report/figure.png", "report.html", "relmse_vs_notes.png"];
    for f in users {
        std::fs::write(out.join(f), b"user").unwrap();
    }
    let o = vrrt(
        &[
            "bench",
            "--quick",
            "--configs",
            "raw",
            "--budgets",
            "1,1,1",
            "--signals",
            "ao",
            "--size",
            "32x18",
            "--frames",
            "2",
            "--spp",
            "4",
            "--no-page",
            "--out",
            out.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for f in users {
        assert_eq!(std::fs::read(out.join(f)).unwrap(), b"user", "{f}");
    }
    // `--budgets 1,1,1` is one cell: a header and one row.
    let csv = std::fs::read_to_string(out.join("bench.csv")).unwrap();
    assert_eq!(csv.lines().count(), 2, "{csv}");
}

#[cfg(unix)]
#[test]
fn writes_replace_links_instead_of_following_them() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("D");
    std::fs::create_dir(&out).unwrap();
    let victims = [
        ("frames.csv", dir.path().join("victim.txt")),
        ("frame0000_raw.png", dir.path().join("victim.png")),
        ("denoised_last.exr", dir.path().join("victim.exr")),
    ];
    for (name, victim) in &victims {
        std::fs::write(victim, b"keep").unwrap();
        std::os::unix::fs::symlink(victim, out.join(name)).unwrap();
    }
    let o = run(dir.path(), &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    for (name, victim) in &victims {
        assert_eq!(std::fs::read(victim).unwrap(), b"keep", "{name}");
        let meta = std::fs::symlink_metadata(out.join(name)).unwrap();
        assert!(meta.is_file(), "{name} is the run's own file now");
    }
}

#[test]
fn bad_arguments_remove_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("D");
    let o = run(dir.path(), &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    for bad in [
        &["--spp", "4294967295"][..],
        &["--frames", "4294967295"],
        &["--settings", "/nonexistent/settings.toml"],
        &["--scene", "/nonexistent/mesh.obj"],
    ] {
        let o = run(dir.path(), &out, bad);
        assert!(!o.status.success(), "{bad:?} was accepted");
        assert!(out.join("frames.csv").is_file(), "{bad:?} removed outputs");
    }
    let o = run(dir.path(), &out, &["--spp", "4294967295"]);
    assert!(
        stderr(&o).contains("--spp must be between 1 and"),
        "{}",
        stderr(&o)
    );
}

/// A directory no file can be created in, even by root: `/proc/self` (Linux).
#[test]
fn an_unwritable_out_is_found_before_rendering() {
    let proc_self = Path::new("/proc/self");
    if !proc_self.is_dir() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let o = run(dir.path(), proc_self, &["--frames", "1"]);
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(e.contains("is not writable"), "{e}");
    // Nothing was rendered: no reference was traced into the cache.
    assert!(
        !dir.path().join("cache").exists(),
        "rendered before failing: {e}"
    );
}

#[test]
fn fifos_and_devices_never_hang_a_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("D");
    let fifo_obj = dir.path().join("f.obj");
    let fifo_toml = dir.path().join("f.toml");
    mkfifo(&fifo_obj);
    mkfifo(&fifo_toml);
    for (args, needle) in [
        (["--scene", fifo_obj.to_str().unwrap()], "FIFO"),
        (["--settings", fifo_toml.to_str().unwrap()], "FIFO"),
        (["--settings", "/dev/zero"], "device"),
    ] {
        let o = run(dir.path(), &out, &args);
        assert!(!o.status.success(), "{args:?}");
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
    // A mesh-cache entry that is a FIFO.
    std::fs::create_dir(dir.path().join("meshes")).unwrap();
    mkfifo(&dir.path().join("meshes/bunny.ply"));
    let o = run(dir.path(), &out, &["--scene", "bunny"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("FIFO"), "{}", stderr(&o));
}

#[cfg(unix)]
#[test]
fn unusable_reference_cache_entries_are_rendered_again() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("D");
    let o = run(dir.path(), &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut entries = Vec::new();
    let mut stack = vec![dir.path().join("cache")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "exr") {
                entries.push(p);
            }
        }
    }
    assert!(entries.len() >= 2, "{entries:?}");
    std::fs::remove_file(&entries[0]).unwrap();
    mkfifo(&entries[0]);
    std::fs::remove_file(&entries[1]).unwrap();
    std::os::unix::fs::symlink("/dev/zero", &entries[1]).unwrap();
    let o = run(dir.path(), &out, &[]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert_eq!(
        e.matches("ignoring unusable reference cache entry").count(),
        2,
        "{e}"
    );
    // Stored again as regular files.
    for p in &entries[..2] {
        assert!(
            std::fs::symlink_metadata(p).unwrap().is_file(),
            "{}",
            p.display()
        );
    }
}

#[test]
fn lights_out_of_range_are_errors_and_all_names_its_limit() {
    let dir = tempfile::tempdir().unwrap();
    for lights in ["0", "5", "99"] {
        let o = vrrt(&["info", "--memory", "--lights", lights], dir.path());
        assert!(!o.status.success(), "--lights {lights} was accepted");
        assert!(stderr(&o).contains("lights from 1 to 4"), "{}", stderr(&o));
    }
    let o = vrrt(
        &["info", "--memory", "--signal", "all", "--lights", "3"],
        dir.path(),
    );
    let e = stderr(&o);
    assert!(!e.contains("planes` = 5"), "{e}");
    assert!(
        e.contains("--signal all has planes for at most 2 lights"),
        "{e}"
    );
    let o = vrrt(
        &["info", "--memory", "--signal", "all", "--lights", "2"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A bench's denoisers reuse the buffers of its earlier cells (memory stays flat across cells):
/// a cell rendered after another gives the same numbers as rendered first.
#[test]
fn a_cell_after_another_gives_the_same_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let row_of_budget_1 = |budgets: &str| {
        let out = dir.path().join(format!("B{budgets}"));
        let o = vrrt(
            &[
                "bench",
                "--quick",
                "--configs",
                "svgf,vrrt",
                "--signals",
                "ao,all",
                "--size",
                "48x27",
                "--frames",
                "4",
                "--spp",
                "4",
                "--no-page",
                "--budgets",
                budgets,
                "--out",
                out.to_str().unwrap(),
            ],
            dir.path(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let csv = std::fs::read_to_string(out.join("bench.csv")).unwrap();
        // Scene to relMSE (the timings differ from run to run).
        csv.lines()
            .filter(|l| l.contains(",1,cpu,"))
            .map(|l| l.split(',').take(9).collect::<Vec<_>>().join(","))
            .collect::<Vec<_>>()
    };
    let first = row_of_budget_1("1");
    assert_eq!(first.len(), 4, "{first:?}");
    assert_eq!(row_of_budget_1("2,1"), first);
}
