//! Ground truth converges: the Monte Carlo standard error of a reference shrinks as 1/sqrt(spp),
//! and the mean stays within a few standard errors of a much longer run.

use vrrt_cpu::CpuExecutor;
use vrrt_scene::render::{reference, ReferenceSpec, Signal};

#[test]
fn reference_standard_error_shrinks_as_one_over_sqrt_spp() {
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    let frame = scene.frame(10);
    let mut exec = CpuExecutor::new();
    let (w, h) = (64, 36);
    let refl = vrrt_core::settings::ReflectionSettings::default();
    for signal in [Signal::Ao { max_distance: 1.0 }, Signal::Shadows] {
        let mut previous: Option<f64> = None;
        let mut trace = |spp| {
            let spec = ReferenceSpec {
                signal,
                reflections: &refl,
                spp,
            };
            reference(&mut exec, &frame, (w, h), spec, |_, _| {}).unwrap()
        };
        let long = trace(4096);
        for spp in [16u32, 64, 256, 1024] {
            let r = trace(spp);
            let mean_se = r.stderr.iter().map(|&s| s as f64).sum::<f64>() / r.stderr.len() as f64;
            // Pixels further from the long run than 5 standard errors of an spp-sample estimate
            // (estimated from the long run, which is well resolved: a 16-spp pixel can show zero
            // variance of its own).
            let scale = (4096.0 / spp as f32).sqrt();
            let outliers = r
                .mean
                .iter()
                .zip(&long.mean)
                .zip(&long.stderr)
                .filter(|((&a, &b), &sb)| (a - b).abs() > 5.0 * sb * (scale + 1.0) + 1e-6)
                .count();
            println!(
                "{} spp {spp}: mean standard error {mean_se:.5}, outliers {outliers}",
                signal.name(&refl)
            );
            if let Some(prev) = previous {
                let ratio = prev / mean_se;
                assert!(
                    (1.7..2.3).contains(&ratio),
                    "{spp} spp: 4x the samples cut the error {ratio:.2}x, not ~2x"
                );
            }
            assert!(
                outliers <= r.mean.len() / 1000 + 1,
                "{outliers} pixels disagree with the 4096-spp run"
            );
            previous = Some(mean_se);
        }
    }
}

/// A reflection reference's standard error is its error: traced in independent replicates of
/// each pixel's low-discrepancy sequence, the replicates' spread measures the mean's error
/// (the samples' own spread would overstate it: a stratified mean beats independent samples).
/// Pooled over the image as relMSE pools (`(a - b)² / (b² + 0.01)`), the squared error against
/// a 32x longer run, less that run's own, is within a quarter of the squared standard error.
/// (The two runs share rng indices, hence some light samples, which makes the error look a few
/// percent smaller than it is; the samples' spread would make the ratio about a half.)
#[test]
fn a_reflection_references_standard_error_is_its_error() {
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    let frame = scene.frame(10);
    let mut exec = CpuExecutor::new();
    let refl = vrrt_core::settings::ReflectionSettings::default();
    let mut trace = |spp| {
        let spec = ReferenceSpec {
            signal: Signal::Reflections,
            reflections: &refl,
            spp,
        };
        reference(&mut exec, &frame, (64, 36), spec, |_, _| {}).unwrap()
    };
    let (short, long) = (trace(64), trace(2048));
    let (mut error, mut estimate) = (0.0f64, 0.0f64);
    for ((a, b), (sa, sb)) in short
        .mean
        .iter()
        .zip(&long.mean)
        .zip(short.stderr.iter().zip(&long.stderr))
    {
        let (sa, sb) = (f64::from(*sa), f64::from(*sb));
        let weight = 1.0 / (f64::from(*b).powi(2) + 1e-2);
        error += (f64::from(a - b).powi(2) - sb * sb) * weight;
        estimate += sa * sa * weight;
    }
    let ratio = error / estimate;
    println!("squared error {error:.5}, squared standard error {estimate:.5}: {ratio:.3}");
    assert!(
        estimate > 0.0 && (0.75..1.25).contains(&ratio),
        "{ratio:.3}"
    );
    // An odd sample count makes one sequence, whose error is unknown (NaN), not the samples'.
    let odd = trace(3);
    assert!(odd.stderr.iter().all(|s| s.is_nan()));
}
