//! The command's manners (issue 20, points 2 and 6): mesh limits set by flags, progress fit for
//! a pipe, output directories holding only the latest run's files, labels that match outputs.

use std::path::Path;
use std::process::{Command, Output};

fn vrrt(args: &[&str], cache: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vrrt"))
        .args(args)
        .env("VRRT_REFERENCE_CACHE", cache)
        .output()
        .expect("run vrrt")
}

/// A tiny `vrrt run` on the CPU into `out`.
fn run(frames: &str, out: &Path, cache: &Path) -> Output {
    let o = vrrt(
        &[
            "run", "--size", "24x16", "--frames", frames, "--spp", "4", "--every", "1", "--out",
        ]
        .into_iter()
        .chain([out.to_str().unwrap()])
        .collect::<Vec<_>>(),
        cache,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

#[test]
fn limit_flags_cap_a_mesh_file_with_exit_2_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("quad.obj");
    std::fs::write(
        &mesh,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let mesh = mesh.to_str().unwrap();
    let cache = dir.path().join("cache");
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let scene = ["--scene", mesh, "--frames", "1", "--spp", "2"];
    let cases: [(&[&str], &str); 5] = [
        (
            &["run", "--out", out, "--max-triangles", "1"],
            "--max-triangles",
        ),
        (&["reference", "--max-vertices", "3"], "--max-vertices"),
        (
            &["run", "--out", out, "--max-file-size", "16"],
            "--max-file-size",
        ),
        (
            &["run", "--out", out, "--max-file-size", "5X"],
            "unknown size suffix `X`",
        ),
        (
            &["run", "--out", out, "--max-bvh-memory", "0"],
            "at least 1 byte",
        ),
    ];
    for (args, needle) in cases {
        let args: Vec<&str> = args.iter().chain(&scene).copied().collect();
        let o = vrrt(&args, &cache);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {needle:?} missing: {err}");
    }
    let o = vrrt(
        &[
            "bench",
            "--scenes",
            mesh,
            "--max-triangles",
            "1",
            "--out",
            out,
        ],
        &cache,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--max-triangles"), "{err}");
    // Within the limits the same file renders.
    let o = vrrt(
        &[
            "run",
            "--scene",
            mesh,
            "--size",
            "16x16",
            "--frames",
            "1",
            "--spp",
            "2",
            "--out",
            out,
            "--max-triangles",
            "2",
            "--max-file-size",
            "1K",
        ],
        &cache,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn progress_to_a_pipe_is_plain_lines_and_the_summary_names_planes() {
    let dir = tempfile::tempdir().unwrap();
    let o = run("3", &dir.path().join("out"), &dir.path().join("cache"));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!stderr.contains('\r'), "{stderr:?}");
    assert!(!stderr.contains('\x1b'), "{stderr:?}");
    assert!(stderr.contains("frame 3/3: relMSE"), "{stderr}");
    assert!(
        stderr.contains("reference of frame 2 (ao), spp 4/4"),
        "{stderr}"
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(!stdout.contains("ao1"), "{stdout}");
    assert!(stdout.contains("ao, AO radius 1; planes ao"), "{stdout}");
}

#[test]
fn a_shorter_run_leaves_no_stale_files_of_a_longer_one() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let cache = dir.path().join("cache");
    run("3", &out, &cache);
    assert!(out.join("frame0002_denoised.png").is_file());
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let o = run("2", &out, &cache);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("removed 11 files an earlier `vrrt run` wrote"),
        "{stderr}"
    );
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    let mut expected: Vec<String> = [
        ".vrrt-run-manifest",
        "denoised_last.exr",
        "frames.csv",
        "notes.txt",
    ]
    .map(String::from)
    .into();
    for i in 0..2 {
        for what in ["denoised", "raw", "reference"] {
            expected.push(format!("frame{i:04}_{what}.png"));
        }
    }
    expected.sort();
    assert_eq!(names, expected);
    let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
}
