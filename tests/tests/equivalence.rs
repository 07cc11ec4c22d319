//! Every kernel, on every available backend, against the CPU backend.
//!
//! Integers must match exactly everywhere. Floats must match bit for bit on software Vulkan
//! through ash (the module marks float arithmetic `NoContraction`); wgpu re-emits the module
//! through naga, which drops that decoration, so lavapipe may fuse multiply-adds there: wgpu, like
//! hardware GPUs (looser division, fused operations), is held to a relative tolerance and its ULP
//! distance is reported. GPU backends run with validation layers on; any
//! validation error fails the test. Without a Vulkan adapter the GPU rows print
//! "skipped: no Vulkan adapter", unless `VRRT_REQUIRE_VULKAN=1`.

use vrrt_cli::backend::{Backend, BackendKind};
use vrrt_core::plan::Executor;
use vrrt_tests::{cases, compare, run_case};

/// Relative tolerance where bit-exactness is not promised (wgpu, hardware GPUs).
const REL_TOLERANCE: f64 = 1e-4;

/// Kernels held to [`REL_TOLERANCE`] on ash/lavapipe too. `raygen_reflect`: the pdf of
/// near-mirror lobes (GGX alpha 0.02) differs by up to 1e-5 relative in about 0.3% of the ray
/// records; wgpu and ash agree with each other bit for bit, so it is not contraction, and the
/// cause (an input differing by one ULP, amplified by the peaked lobe) is not isolated yet.
const NOT_BIT_EXACT: &[&str] = &["raygen_reflect"];

fn gpu_backends() -> Vec<Backend> {
    let require = std::env::var("VRRT_REQUIRE_VULKAN").is_ok_and(|v| v == "1");
    let mut out = Vec::new();
    for kind in [BackendKind::Wgpu, BackendKind::Ash] {
        match Backend::open(kind, true) {
            Ok((b, _)) => out.push(b),
            Err(e) if require => panic!("{kind:?}: {e} (VRRT_REQUIRE_VULKAN=1)"),
            Err(e) => println!("{kind:?}: skipped: no Vulkan adapter ({e})"),
        }
    }
    out
}

#[test]
fn every_kernel_matches_the_cpu_backend() {
    let mut backends = gpu_backends();
    println!(
        "{:<44} {:<6} {:>8} {:>6} {:>6} {:>8} {:>10}",
        "case", "backend", "words", "int≠", "float≠", "max ulp", "max rel"
    );
    let mut failures = Vec::new();
    for (name, generate) in cases::TABLE {
        for (i, &(w, h)) in cases::SIZES.iter().enumerate() {
            let case = generate(&mut cases::rng(1000 + i as u64), w, h);
            let reference = run_case(&mut vrrt_cpu::CpuExecutor::new(), &case).unwrap();
            // The CPU backend itself is deterministic across runs (parallel workgroups, atomics).
            let again = run_case(&mut vrrt_cpu::CpuExecutor::new(), &case).unwrap();
            let r = compare(&case, &reference, &again);
            if !r.is_exact() {
                failures.push(format!("{}: cpu not deterministic: {r:?}", case.name));
            }
            for b in backends.iter_mut() {
                let got = run_case(b, &case)
                    .unwrap_or_else(|e| panic!("{} on {}: {e}", case.name, b.name()));
                let r = compare(&case, &reference, &got);
                println!(
                    "{:<44} {:<6} {:>8} {:>6} {:>6} {:>8} {:>10.2e}",
                    case.name,
                    b.name(),
                    r.words,
                    r.int_mismatches,
                    r.float_mismatches,
                    r.max_ulp,
                    r.max_rel
                );
                let exact = !NOT_BIT_EXACT.contains(name);
                let float_ok = if exact && b.is_software() && b.name() != "wgpu" {
                    r.float_mismatches == 0
                } else {
                    r.max_rel <= REL_TOLERANCE
                };
                if r.int_mismatches > 0 || !float_ok {
                    failures.push(format!(
                        "{} on {} ({}): {r:?}",
                        case.name,
                        b.name(),
                        b.device()
                    ));
                }
            }
        }
    }
    for b in &backends {
        if b.validation_errors() > 0 {
            failures.push(format!(
                "{}: {} validation errors",
                b.name(),
                b.validation_errors()
            ));
        }
    }
    assert!(failures.is_empty(), "mismatches:\n{}", failures.join("\n"));
}
