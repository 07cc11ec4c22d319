//! Ground truth converges: a reference's error shrinks at least as 1/sqrt(spp), and the standard
//! error it keeps is its error.

use vrrt_core::settings::ReflectionSettings;
use vrrt_cpu::CpuExecutor;
use vrrt_scene::render::{reference, Reference, ReferenceSpec, Signal};

/// Traces frame 10 of the room at `size`.
fn trace(exec: &mut CpuExecutor, size: (u32, u32), signal: Signal, spp: u32) -> Reference {
    let frame = vrrt_scene::builtin::builtin("room").unwrap().frame(10);
    let reflections = ReflectionSettings::default();
    let spec = ReferenceSpec {
        signal,
        reflections: &reflections,
        spp,
    };
    reference(exec, &frame, size, spec, |_, _| {}).unwrap()
}

/// `short`'s squared error against `long`, less `long`'s own squared standard error, and
/// `short`'s squared standard error, each pooled over the image as relMSE pools
/// (`(a - b)² / (b² + 0.01)`).
fn pooled_error(short: &Reference, long: &Reference) -> (f64, f64) {
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
    (error, estimate)
}

const SIGNALS: [Signal; 3] = [
    Signal::Ao { max_distance: 1.0 },
    Signal::Shadows,
    Signal::Reflections,
];

/// Four times the samples cut the error against a 4096-spp run at least 1.7x (independent
/// samples: 2x; the replicated low-discrepancy sequences converge faster), and the standard
/// error kept follows it.
#[test]
fn a_references_error_shrinks_at_least_as_one_over_sqrt_spp() {
    let mut exec = CpuExecutor::new();
    let refl = ReflectionSettings::default();
    for signal in SIGNALS {
        let long = trace(&mut exec, (64, 36), signal, 4096);
        let mut previous: Option<(f64, f64)> = None;
        for spp in [16u32, 64, 256] {
            let (error, estimate) = pooled_error(&trace(&mut exec, (64, 36), signal, spp), &long);
            let (error, estimate) = (error.max(0.0).sqrt(), estimate.sqrt());
            let name = signal.name(&refl);
            println!("{name} spp {spp}: error {error:.5}, its estimate {estimate:.5}");
            if let Some((e, s)) = previous {
                assert!(
                    e / error >= 1.7,
                    "{name} {spp} spp: error cut {:.2}x",
                    e / error
                );
                assert!(
                    s / estimate >= 1.7,
                    "{name} {spp} spp: estimate cut {:.2}x",
                    s / estimate
                );
            }
            previous = Some((error, estimate));
        }
    }
}

/// A reference's standard error is its error: every plane is traced in independent replicates
/// of each pixel's low-discrepancy sequence, and the replicates' spread measures the mean's
/// error (the samples' own spread would overstate it: a stratified mean beats independent
/// samples). Pooled over the image as relMSE pools, the squared error against a 32x longer run,
/// less that run's own, is within a quarter of the squared standard error. (The two runs share
/// rng indices, hence some of the reflections' light samples, which makes their error look a
/// few percent smaller than it is; the samples' spread would make the ratio about a half.)
#[test]
fn a_references_standard_error_is_its_error() {
    let mut exec = CpuExecutor::new();
    let refl = ReflectionSettings::default();
    for signal in SIGNALS {
        // At 64x36 the shadows' few penumbra pixels leave the pooled error too noisy to compare.
        let size = (128, 72);
        let (short, long) = (
            trace(&mut exec, size, signal, 64),
            trace(&mut exec, size, signal, 2048),
        );
        let (error, estimate) = pooled_error(&short, &long);
        let ratio = error / estimate;
        let name = signal.name(&refl);
        println!(
            "{name}: squared error {error:.5}, squared standard error {estimate:.5}: {ratio:.3}"
        );
        assert!(
            estimate > 0.0 && (0.75..1.25).contains(&ratio),
            "{name}: {ratio:.3}"
        );
        // An odd sample count is not split into replicates: its error is unknown (NaN).
        let odd = trace(&mut exec, size, signal, 3);
        assert!(odd.stderr.iter().all(|s| s.is_nan()));
    }
}
