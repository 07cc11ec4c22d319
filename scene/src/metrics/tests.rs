//! Unit tests of the metrics against hand-computed values and scikit-image, kept together
//! because they share the test images.

use super::*;
use crate::image::Image;

fn img(w: usize, h: usize, c: usize, data: Vec<f32>) -> Image {
    Image::new(w, h, c, data).unwrap()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

/// Deterministic test pattern, exactly reproducible in other tools (small rationals).
fn pattern(w: usize, h: usize) -> (Image, Image) {
    let mut x = Vec::new();
    let mut y = Vec::new();
    for i in 0..h {
        for j in 0..w {
            let r = ((i * 73 + j * 151) % 97) as f32 / 96.0;
            let n = (((i * 31 + j * 17) % 13) as f32 - 6.0) / 60.0;
            y.push(r);
            x.push((r + n).clamp(0.0, 1.0));
        }
    }
    (img(w, h, 1, x), img(w, h, 1, y))
}

#[test]
fn identical_images() {
    let (_, y) = pattern(16, 12);
    let m = compare(y.view(), y.view()).unwrap();
    assert_eq!(m.mse, 0.0);
    assert_eq!(m.rmse, 0.0);
    assert_eq!(m.rel_mse, 0.0);
    assert_eq!(m.psnr, f64::INFINITY);
    assert!(close(m.ssim, 1.0, 1e-12), "{}", m.ssim);
    assert_eq!(
        (m.pixels, m.non_finite, m.reference_non_finite),
        (192, 0, 0)
    );
}

#[test]
fn hand_computed_small_case() {
    // Errors 0.1, -0.2, 0.0, 0.3 on references 0.5, 0, 1, 0.1.
    let y = img(2, 2, 1, vec![0.5, 0.0, 1.0, 0.1]);
    let x = img(2, 2, 1, vec![0.6, -0.2, 1.0, 0.4]);
    let m = compare(x.view(), y.view()).unwrap();
    let mse = (0.01 + 0.04 + 0.0 + 0.09) / 4.0;
    assert!(close(m.mse, mse, 1e-7));
    assert!(close(m.rmse, mse.sqrt(), 1e-7));
    let rel = (0.01 / (0.25 + 0.01) + 0.04 / 0.01 + 0.0 + 0.09 / (0.01 + 0.01)) / 4.0;
    assert!(close(m.rel_mse, rel, 1e-6), "{} vs {rel}", m.rel_mse);
    assert_eq!(rel_mse(x.view(), y.view()).unwrap(), m.rel_mse);
    assert!(close(m.psnr, 10.0 * (1.0 / mse).log10(), 1e-5));
    assert!(close(psnr_from_mse(0.01), 20.0, 1e-12));
}

#[test]
fn rgb_metrics_average_over_channels() {
    let y = img(1, 1, 3, vec![0.0, 0.0, 0.0]);
    let x = img(1, 1, 3, vec![0.3, 0.0, 0.0]);
    let m = compare(x.view(), y.view()).unwrap();
    assert!(close(m.mse, 0.09 / 3.0, 1e-8));
    assert!(close(m.rel_mse, 0.09 / 0.01 / 3.0, 1e-5));
}

#[test]
fn ssim_of_constant_images_matches_closed_form() {
    // Constant images: means a, b and zero variance, so
    // SSIM = (2ab + C1) / (a² + b² + C1) exactly, for any window or border rule.
    for (a, b) in [(0.5f32, 0.6f32), (0.2, 0.2), (0.0, 1.0), (0.9, 0.3)] {
        for (w, h) in [(32, 24), (5, 3)] {
            let x = img(w, h, 1, vec![a; w * h]);
            let y = img(w, h, 1, vec![b; w * h]);
            let (a, b) = (f64::from(a), f64::from(b));
            let expect = (2.0 * a * b + SSIM_C1) / (a * a + b * b + SSIM_C1);
            let got = ssim(x.view(), y.view()).unwrap();
            assert!(
                close(got, expect, 1e-9),
                "{a} {b} {w}x{h}: {got} vs {expect}"
            );
        }
    }
    // Clamping: values above 1 behave as 1.
    let x = img(12, 12, 1, vec![3.0; 144]);
    let y = img(12, 12, 1, vec![1.0; 144]);
    assert!(close(ssim(x.view(), y.view()).unwrap(), 1.0, 1e-12));
}

#[test]
fn ssim_constant_offset_on_structured_image() {
    // y + offset keeps the structure term at 1; only the luminance term drops, so SSIM
    // stays high but below 1 and decreases with the offset.
    let (_, y) = pattern(24, 20);
    let shifted = |d: f32| img(24, 20, 1, y.data().iter().map(|v| v * 0.5 + d).collect());
    let half = img(24, 20, 1, y.data().iter().map(|v| v * 0.5).collect());
    let s1 = ssim(shifted(0.05).view(), half.view()).unwrap();
    let s2 = ssim(shifted(0.2).view(), half.view()).unwrap();
    assert!(s1 < 1.0 && s2 < s1 && s2 > 0.5, "{s1} {s2}");
}

#[test]
fn ssim_matches_scikit_image() {
    // Reference: skimage.metrics.structural_similarity(x, y, data_range=1.0,
    // gaussian_weights=True, sigma=1.5, use_sample_covariance=False) on `pattern(24, 20)`
    // (float32 values promoted to float64), scikit-image 0.26.0.
    let (x, y) = pattern(24, 20);
    let got = ssim(x.view(), y.view()).unwrap();
    assert!(close(got, 0.979_105_695_588_829_4, 1e-9), "{got}");
    // An unrelated image: x2[i][j] = ((29 i + 41 j) mod 89) / 88.
    let x2: Vec<f32> = (0..20)
        .flat_map(|i| (0..24).map(move |j| ((i * 29 + j * 41) % 89) as f32 / 88.0))
        .collect();
    let got = ssim(img(24, 20, 1, x2).view(), y.view()).unwrap();
    assert!(close(got, -0.097_782_301_650_601_53, 1e-9), "{got}");
}

#[test]
fn rgb_ssim_uses_luminance() {
    let (x, y) = pattern(16, 16);
    let grey = |i: &Image| {
        img(
            16,
            16,
            3,
            i.data().iter().flat_map(|&v| [v, v, v]).collect(),
        )
    };
    let s1 = ssim(x.view(), y.view()).unwrap();
    let s3 = ssim(grey(&x).view(), grey(&y).view()).unwrap();
    assert!(close(s1, s3, 1e-6), "{s1} vs {s3}");
    assert!(close(f64::from(luminance(&[1.0, 1.0, 1.0])), 1.0, 1e-6));
}

#[test]
fn shape_mismatch_is_an_error() {
    let a = Image::zeros(2, 2, 1);
    let b = Image::zeros(2, 2, 3);
    assert!(matches!(
        compare(a.view(), b.view()),
        Err(MetricsError::ShapeMismatch { .. })
    ));
    assert!(matches!(
        masked_error(a.view(), a.view(), &[true]),
        Err(MetricsError::LengthMismatch { .. })
    ));
}

#[test]
fn non_finite_pixels_are_counted_and_excluded() {
    let y = img(4, 1, 1, vec![0.5, 0.5, 0.5, 0.5]);
    let x = img(4, 1, 1, vec![0.6, f32::NAN, f32::INFINITY, 0.4]);
    let m = compare(x.view(), y.view()).unwrap();
    assert_eq!((m.pixels, m.non_finite, m.reference_non_finite), (2, 2, 0));
    assert!(close(m.mse, 0.01, 1e-7), "{}", m.mse);
    assert!(m.ssim.is_finite() && m.ssim < 1.0);

    // RGB: one bad channel excludes the whole pixel.
    let y = img(2, 1, 3, vec![0.0; 6]);
    let x = img(2, 1, 3, vec![0.0, f32::NEG_INFINITY, 0.0, 0.1, 0.1, 0.1]);
    let m = compare(x.view(), y.view()).unwrap();
    assert_eq!((m.pixels, m.non_finite), (1, 1));
    assert!(close(m.mse, 0.01, 1e-7));

    // Everything broken: NaN metrics, but counted, never silently "perfect".
    let x = img(2, 1, 1, vec![f32::NAN; 2]);
    let y = img(2, 1, 1, vec![0.0, f32::NAN]);
    let m = compare(x.view(), y.view()).unwrap();
    assert_eq!((m.pixels, m.non_finite, m.reference_non_finite), (0, 2, 1));
    assert!(m.rmse.is_nan() && m.rel_mse.is_nan() && m.psnr.is_nan());
}

#[test]
fn non_finite_is_worst_case_in_ssim() {
    let y = img(12, 12, 1, vec![0.8; 144]);
    let mut bad = vec![0.8; 144];
    bad[60] = f32::NAN;
    let dark = {
        let mut v = vec![0.8; 144];
        v[60] = 0.0;
        v
    };
    let s_nan = ssim(img(12, 12, 1, bad).view(), y.view()).unwrap();
    let s_dark = ssim(img(12, 12, 1, dark).view(), y.view()).unwrap();
    assert_eq!(s_nan, s_dark);
    assert!(s_nan < 1.0);
}

#[test]
fn masked_error_selects_pixels() {
    let y = img(3, 1, 1, vec![0.0, 0.0, 0.0]);
    let x = img(3, 1, 1, vec![0.1, 0.5, f32::NAN]);
    assert_eq!(masked_error(x.view(), y.view(), &[false; 3]).unwrap(), None);
    let m = masked_error(x.view(), y.view(), &[false, true, false])
        .unwrap()
        .unwrap();
    assert_eq!((m.pixels, m.non_finite), (1, 0));
    assert!(close(m.rmse, 0.5, 1e-7));
    assert!(close(m.rel_mse, 0.25 / 0.01, 1e-4));
    let m = masked_error(x.view(), y.view(), &[true, false, true])
        .unwrap()
        .unwrap();
    assert_eq!((m.pixels, m.non_finite), (1, 1));
    assert!(close(m.rmse, 0.1, 1e-7));
    let m = masked_error(x.view(), y.view(), &[false, false, true])
        .unwrap()
        .unwrap();
    assert_eq!((m.pixels, m.non_finite), (0, 1));
    assert!(m.rmse.is_nan());
}

#[test]
fn temporal_error_of_constant_offset_is_zero() {
    let mut seq = SequenceMetrics::new();
    for t in 0..5 {
        let y = img(
            4,
            3,
            3,
            (0..36)
                .map(|i| ((i * 7 + t * 5) % 11) as f32 / 10.0)
                .collect(),
        );
        let x = img(4, 3, 3, y.data().iter().map(|v| v + 0.25).collect());
        let f = *seq.push(x.view(), y.view(), None).unwrap();
        assert_eq!(f.frame, t);
        assert!(close(f.metrics.rmse, 0.25, 1e-6));
        match f.temporal {
            None => assert_eq!(t, 0),
            Some(e) => assert!(e.abs() < 1e-6, "frame {t}: {e}"),
        }
    }
    let s = seq.summary();
    assert_eq!(s.frames, 5);
    assert!(s.temporal.unwrap().abs() < 1e-6);
    assert!(close(s.mean_rmse, 0.25, 1e-6));
    assert_eq!((s.masked_frames, s.mean_masked_rel_mse), (0, None));
}

#[test]
fn temporal_error_of_flicker() {
    // Error alternates +0.1 / -0.1 on a static reference: per-frame RMSE 0.1, temporal 0.2.
    let y = img(2, 2, 1, vec![0.5; 4]);
    let mut seq = SequenceMetrics::new();
    assert_eq!(seq.summary().temporal, None);
    for t in 0..4 {
        let d = if t % 2 == 0 { 0.1 } else { -0.1 };
        let x = img(2, 2, 1, vec![0.5 + d; 4]);
        let mask = [t == 2, false, false, false];
        seq.push(x.view(), y.view(), Some(&mask)).unwrap();
    }
    let s = seq.summary();
    assert!(close(s.temporal.unwrap(), 0.2, 1e-6));
    assert!(close(s.mean_rmse, 0.1, 1e-6));
    assert!(close(s.psnr_of_mean_mse, 20.0, 1e-4));
    assert_eq!(s.masked_frames, 1);
    assert!(close(s.mean_masked_rmse.unwrap(), 0.1, 1e-6));
    assert_eq!(seq.frames().len(), 4);

    // A frame of another size is rejected and leaves the sequence unchanged.
    let big = Image::zeros(3, 3, 1);
    assert!(seq.push(big.view(), big.view(), None).is_err());
    assert_eq!(seq.frames().len(), 4);
}

#[test]
fn temporal_error_skips_non_finite_samples() {
    let y = img(2, 1, 1, vec![0.0, 0.0]);
    let mut seq = SequenceMetrics::new();
    seq.push(img(2, 1, 1, vec![0.1, f32::NAN]).view(), y.view(), None)
        .unwrap();
    let f = *seq
        .push(img(2, 1, 1, vec![0.3, 0.0]).view(), y.view(), None)
        .unwrap();
    assert!(close(f.temporal.unwrap(), 0.2, 1e-6));
    assert_eq!(seq.summary().non_finite, 1);
}

#[test]
fn standard_error_by_hand() {
    // Samples {0, 2}: mean 1, mean of squares 2, unbiased variance 2, SE = sqrt(2/2) = 1.
    // Samples {1, 1}: SE 0.
    let se = standard_error(&[1.0f32, 1.0], &[2.0f32, 1.0], 2).unwrap();
    assert_eq!(se.per_sample, vec![1.0, 0.0]);
    assert!(close(se.mean, 0.5, 1e-12));
    assert!(close(se.rms, (0.5f64).sqrt(), 1e-12));
    assert_eq!(se.non_finite, 0);

    // Four samples {0, 0, 1, 1}: mean 0.5, E[x²] 0.5, s² = 0.25·4/3, SE = sqrt(1/12).
    let se = standard_error(&[0.5f64], &[0.5f64], 4).unwrap();
    assert!(close(
        f64::from(se.per_sample[0]),
        (1.0f64 / 12.0).sqrt(),
        1e-7
    ));

    // Rounding that makes mean_sq < mean² clamps to zero variance instead of NaN.
    let se = standard_error(&[0.1f32], &[0.0099999f32], 100).unwrap();
    assert_eq!(se.per_sample[0], 0.0);

    let se = standard_error(&[f32::NAN, 0.0], &[0.0, 0.0], 10).unwrap();
    assert_eq!(se.non_finite, 1);
    assert!(se.per_sample[0].is_nan() && se.mean == 0.0);

    assert_eq!(
        standard_error(&[0.0f32], &[0.0], 1),
        Err(MetricsError::TooFewSamples(1))
    );
    assert!(matches!(
        standard_error(&[0.0f32], &[], 5),
        Err(MetricsError::LengthMismatch { .. })
    ));
}

#[cfg(feature = "flip")]
#[test]
fn flip_identity_and_ordering() {
    let (x, y) = pattern(32, 32);
    assert_eq!(flip(y.view(), y.view()).unwrap(), 0.0);
    let e = flip(x.view(), y.view()).unwrap();
    assert!(e > 0.0 && e < 1.0, "{e}");
    let worse = img(32, 32, 1, y.data().iter().map(|v| 1.0 - v).collect());
    assert!(flip(worse.view(), y.view()).unwrap() > e);
    // RGB grey equals single-channel grey.
    let grey = |i: &Image| {
        img(
            32,
            32,
            3,
            i.data().iter().flat_map(|&v| [v, v, v]).collect(),
        )
    };
    assert!(close(
        flip(grey(&x).view(), grey(&y).view()).unwrap(),
        e,
        1e-9
    ));
    let map = flip_map(x.view(), y.view(), 67.0).unwrap();
    assert_eq!((map.width(), map.height(), map.channels()), (32, 32, 1));
    // Non-finite test pixels count as the worst case, not as a match.
    let mut bad = y.data().to_vec();
    bad[100] = f32::NAN;
    assert!(flip(img(32, 32, 1, bad).view(), y.view()).unwrap() > 0.0);
    assert!(matches!(
        flip(Image::zeros(2, 2, 2).view(), Image::zeros(2, 2, 2).view()),
        Err(MetricsError::UnsupportedChannels(2))
    ));
}

/// A 1-channel image of `f(x, y)`.
fn field(w: usize, h: usize, mut f: impl FnMut(usize, usize) -> f32) -> Image {
    img(w, h, 1, (0..w * h).map(|i| f(i % w, i / w)).collect())
}

#[test]
fn spectrum_bands_sum_to_the_mse() {
    let mut rng = 0x1234_5678u32;
    let mut noise = || {
        rng ^= rng << 13;
        rng ^= rng >> 17;
        rng ^= rng << 5;
        rng as f32 / u32::MAX as f32
    };
    let (w, h) = (96, 54);
    let test = field(w, h, |_, _| noise());
    let reference = field(w, h, |x, _| 0.3 + 0.001 * x as f32);
    let s = error_spectrum(test.view(), reference.view()).unwrap();
    let mse = compare(test.view(), reference.view()).unwrap().mse;
    assert!(
        close(s.dc + s.low + s.high, mse, 1e-6 * mse),
        "{s:?} vs {mse}"
    );
    // White noise: the low band holds its share of the frequency plane, π·LOW_BAND².
    let white = std::f64::consts::PI * LOW_BAND * LOW_BAND;
    assert!(close(s.low_fraction(), white, 0.02), "{}", s.low_fraction());
    assert_eq!(s.radial.len(), RADIAL_BINS);
}

#[test]
fn spectrum_places_smooth_and_checkerboard_errors() {
    let (w, h) = (64, 40);
    let zero = Image::zeros(w, h, 1);
    // One slow cosine: all low band; the checkerboard: all at Nyquist; a constant: all DC.
    let smooth = field(w, h, |x, _| (x as f32 * std::f32::consts::TAU / 64.0).cos());
    let s = error_spectrum(smooth.view(), zero.view()).unwrap();
    assert!(s.low_fraction() > 0.999 && s.dc < 1e-12, "{s:?}");
    let checker = field(w, h, |x, y| if (x + y) % 2 == 0 { 0.5 } else { -0.5 });
    let s = error_spectrum(checker.view(), zero.view()).unwrap();
    assert!(
        s.low_fraction() < 1e-12 && close(s.high, 0.25, 1e-9),
        "{s:?}"
    );
    let (last, rest) = s.radial.split_last().unwrap();
    assert!(
        *last > 0.0 && rest.iter().all(|&p| p < 1e-12),
        "{:?}",
        s.radial
    );
    let flat = field(w, h, |_, _| 0.25);
    let s = error_spectrum(flat.view(), zero.view()).unwrap();
    assert!(close(s.dc, 0.0625, 1e-9) && s.low + s.high < 1e-12, "{s:?}");
    assert!(ErrorSpectrum::default().low_fraction().is_nan());
    let m = ErrorSpectrum::mean([&s, &ErrorSpectrum::default()]);
    assert!(close(m.dc, 0.03125, 1e-9) && m.radial.len() == RADIAL_BINS);
    assert!(error_spectrum(flat.view(), Image::zeros(w, h + 1, 1).view()).is_err());
}

/// A noisy reference's relMSE floor, taken out of a test image's relMSE against it, leaves the
/// test image's relMSE against the truth: images of 512x512 texels with independent noise of
/// known σ (a hash's uniform noise, σ² = a²/3).
#[test]
fn reference_noise_leaves_the_error_against_the_truth() {
    let (w, h) = (512usize, 512usize);
    let noise = |i: usize, seed: u64| {
        let mut z = (i as u64) ^ seed.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    let truth: Vec<f32> = (0..w * h)
        .map(|i| 0.2 + 0.6 * (i % 97) as f32 / 96.0)
        .collect();
    let (a_ref, a_test) = (0.05f32, 0.08f32);
    let reference: Vec<f32> = (0..w * h).map(|i| truth[i] + a_ref * noise(i, 1)).collect();
    let test: Vec<f32> = (0..w * h)
        .map(|i| truth[i] + a_test * noise(i, 2))
        .collect();
    let stderr = vec![a_ref / 3f32.sqrt(); w * h];
    let (truth, reference) = (img(w, h, 1, truth), img(w, h, 1, reference));
    let (test, stderr) = (img(w, h, 1, test), img(w, h, 1, stderr));
    let against_truth = compare(test.view(), truth.view()).unwrap().rel_mse;
    let measured = compare(test.view(), reference.view()).unwrap().rel_mse;
    let floor = reference_rel_noise(reference.view(), stderr.view(), None).unwrap();
    // The floor is a real part of the measured error here (0.05² of 0.05² + 0.08²: 28%)...
    assert!(floor > 0.2 * measured, "floor {floor}, measured {measured}");
    // ...and taking it out leaves the error against the truth, to within 3%.
    let debiased = measured - floor;
    assert!(
        (debiased / against_truth - 1.0).abs() < 0.03,
        "debiased {debiased}, against the truth {against_truth}"
    );
    // Over a mask (the left half of every row), the same against the masked error.
    let mask: Vec<bool> = (0..w * h).map(|i| i % w < w / 2).collect();
    let masked = |r: &Image| {
        masked_error(test.view(), r.view(), &mask)
            .unwrap()
            .unwrap()
            .rel_mse
    };
    let floor = reference_rel_noise(reference.view(), stderr.view(), Some(&mask)).unwrap();
    let debiased = masked(&reference) - floor;
    assert!(
        (debiased / masked(&truth) - 1.0).abs() < 0.03,
        "masked: debiased {debiased}, against the truth {}",
        masked(&truth)
    );
    // A standard error or a mask of another shape is an error, not a number.
    let wrong = img(w, h / 2, 1, vec![0.0; w * h / 2]);
    assert!(reference_rel_noise(reference.view(), wrong.view(), None).is_err());
    let short = vec![true; w];
    assert!(reference_rel_noise(reference.view(), stderr.view(), Some(&short)).is_err());
}
