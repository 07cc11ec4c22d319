//! The CPU backend's runners of one kernel (AVX-512, AVX2 with F16C and FMA, the baseline) are
//! the same code at different widths: every kernel of the equivalence table gives the same words
//! under each limit of `vrrt_core::executor::set_cpu_lanes` as with the widest the CPU has. A
//! test binary of its own, as the limit holds for the whole process.

use vrrt_core::executor::{cpu_lanes, set_cpu_lanes, CpuLanes};
use vrrt_tests::{cases, compare, run_case};

#[test]
fn every_runner_width_gives_the_same_words() {
    assert_eq!(cpu_lanes(), CpuLanes::Avx512, "the default is the widest");
    let mut failures = Vec::new();
    let mut compared = 0;
    for (_, generate, tolerance) in cases::TABLE {
        for (i, &(w, h)) in cases::SIZES.iter().enumerate() {
            let case = generate(&mut cases::rng(2000 + i as u64), w, h);
            set_cpu_lanes(CpuLanes::Avx512);
            let native = run_case(&mut vrrt_cpu::CpuExecutor::new(), &case).unwrap();
            for lanes in [CpuLanes::Avx2, CpuLanes::Baseline] {
                set_cpu_lanes(lanes);
                let got = run_case(&mut vrrt_cpu::CpuExecutor::new(), &case).unwrap();
                let r = compare(&case, tolerance, &native, &got);
                if !r.is_exact() {
                    failures.push(format!("{} with {lanes:?}: {r:?}", case.name));
                }
                compared += 1;
            }
        }
    }
    set_cpu_lanes(CpuLanes::Avx512);
    println!("{compared} cases compared");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
