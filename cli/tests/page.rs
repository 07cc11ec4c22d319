//! The bench's page (issue 18, item 7): a tiny bench writes `report.html` beside its crops, the
//! page links only files that exist and fetches nothing, and it has a section per event in the
//! rendered frames with a heatmap per configuration.

use std::path::Path;
use std::process::{Command, Output};

fn vrrt(args: &[&str], cache: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vrrt"))
        .args(args)
        .env("VRRT_REFERENCE_CACHE", cache)
        .output()
        .expect("run vrrt")
}

/// A tiny bench of `room` over its first 12 frames (events: the box and the light start at
/// frame 1, the sphere at frame 10) into `out`.
fn bench(out: &Path, cache: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "bench",
        "--scenes",
        "room",
        "--size",
        "24x16",
        "--frames",
        "12",
        "--spp",
        "4",
        "--budgets",
        "1",
        "--configs",
        "svgf,vrrt",
        "--signals",
        "ao,shadows",
        "--backends",
        "cpu",
        "--repeats",
        "1",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = vrrt(&args, cache);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

/// The values of every `attr="…"` in `html`.
fn attributes<'a>(html: &'a str, attr: &str) -> Vec<&'a str> {
    let key = format!("{attr}=\"");
    html.match_indices(&key)
        .map(|(i, _)| {
            let rest = &html[i + key.len()..];
            &rest[..rest.find('"').unwrap()]
        })
        .collect()
}

#[test]
fn bench_writes_a_page_of_crops_per_event() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let cache = dir.path().join("cache");
    bench(&out, &cache, &[]);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();

    // Self-contained: no script, stylesheet link or remote address.
    for banned in ["<script", "<link", "http://", "https://", "url("] {
        assert!(!html.contains(banned), "{banned} in the page");
    }
    // Every image it shows exists, and every crop it wrote is shown.
    let sources = attributes(&html, "src");
    assert!(sources.len() > 50, "{}", sources.len());
    for src in &sources {
        assert!(src.starts_with("report/"), "{src}");
        assert!(out.join(src).is_file(), "{src} missing");
    }
    let written = std::fs::read_dir(out.join("report")).unwrap().count();
    let mut unique = sources.clone();
    unique.sort();
    unique.dedup();
    assert_eq!(unique.len(), written);

    // A section per event in range: AO does not see the light, shadows do.
    let headings: Vec<&str> = html
        .split("<h3>")
        .skip(1)
        .map(|s| &s[..s.find("</h3>").unwrap()])
        .collect();
    assert_eq!(
        headings,
        [
            "room · ao · 1 rpp · frame 1: sliding box starts moving",
            "room · ao · 1 rpp · frame 10: crossing sphere starts moving",
            "room · shadows · 1 rpp · frame 1: sliding box starts moving",
            "room · shadows · 1 rpp · frame 1: light 0 starts moving",
            "room · shadows · 1 rpp · frame 10: crossing sphere starts moving",
        ]
    );
    assert!(
        html.contains("frame 60 camera cut (not rendered)"),
        "{html}"
    );
    // Rows are the window within the 12 frames, each with every column and a heatmap per
    // configuration.
    let ids = attributes(&html, "id");
    assert_eq!(ids, ["s000", "s001", "s002", "s003", "s004"]);
    for (id, frames) in ids.iter().zip([
        &[1, 2, 3, 5, 9][..],
        &[10, 11],
        &[1, 2, 3, 5, 9],
        &[1, 2, 3, 5, 9],
        &[10, 11],
    ]) {
        for f in frames {
            for what in [
                "reference",
                "moving",
                "samples",
                "samples_error",
                "svgf",
                "svgf_error",
                "vrrt",
                "vrrt_error",
            ] {
                let file = format!("report/{id}_f{f:04}_{what}.png");
                assert!(sources.contains(&file.as_str()), "{file} not shown");
            }
        }
    }
    assert!(html.contains("relMSE 0."), "captions");

    // `--no-page` leaves no page of an earlier bench behind.
    bench(&out, &cache, &["--no-page"]);
    assert!(!out.join("report.html").exists());
    assert_eq!(std::fs::read_dir(out.join("report")).unwrap().count(), 0);
}
