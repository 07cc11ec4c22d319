//! Every kernel, on every available backend, against the CPU backend, within the tolerance its
//! line of `cases::TABLE` declares.
//!
//! The GPU evaluates `exp2`, `log2`, `pow` and `rsqrt` natively and may fuse multiply-adds, the
//! CPU runs short polynomials without fusing: floats are held to their tolerance (f32 by relative
//! error or ULP, binary16 halves as halves), integers exactly, and the elements a float
//! comparison decides up to the case's named fraction. The same tolerances hold on lavapipe and
//! on hardware GPUs. GPU backends run with validation layers on; any validation error fails the
//! test. Without a Vulkan adapter the GPU rows print "skipped: no Vulkan adapter", unless
//! `VRRT_REQUIRE_VULKAN=1`.

mod gpu;

use vrrt_core::executor::Executor;
use vrrt_tests::{cases, compare, run_case, Tolerance};

#[test]
fn every_kernel_matches_the_cpu_backend() {
    let mut backends = gpu::backends();
    println!(
        "{:<44} {:<6} {:>8} {:>6} {:>6} {:>8} {:>9} {:>6} {:>9}",
        "case", "backend", "words", "int≠", "float≠", "max ulp", "max rel", "half", "decided≠"
    );
    let mut failures = Vec::new();
    for (_, generate, tolerance) in cases::TABLE {
        for (i, &(w, h)) in cases::SIZES.iter().enumerate() {
            let case = generate(&mut cases::rng(1000 + i as u64), w, h);
            let reference = run_case(&mut vrrt_cpu::CpuExecutor::new(), &case).unwrap();
            // The CPU backend itself is deterministic across runs (parallel workgroups, atomics).
            let again = run_case(&mut vrrt_cpu::CpuExecutor::new(), &case).unwrap();
            let r = compare(&case, &Tolerance::DEFAULT, &reference, &again);
            if !r.is_exact() {
                failures.push(format!("{}: cpu not deterministic: {r:?}", case.name));
            }
            for b in backends.iter_mut() {
                let got = run_case(b, &case)
                    .unwrap_or_else(|e| panic!("{} on {}: {e}", case.name, b.name()));
                let r = compare(&case, tolerance, &reference, &got);
                println!(
                    "{:<44} {:<6} {:>8} {:>6} {:>6} {:>8} {:>9.2e} {:>6} {:>9}",
                    case.name,
                    b.name(),
                    r.words,
                    r.int_mismatches,
                    r.float_mismatches,
                    r.max_ulp,
                    r.max_rel,
                    r.max_half_ulp,
                    format!("{}/{}", r.decided_mismatches, r.decided_elements),
                );
                if !r.within(tolerance) {
                    failures.push(format!(
                        "{} on {} ({}, {tolerance:?}): {r:?}",
                        case.name,
                        b.name(),
                        b.device()
                    ));
                }
            }
        }
    }
    failures.extend(gpu::validation_failures(&backends));
    assert!(failures.is_empty(), "mismatches:\n{}", failures.join("\n"));
}
