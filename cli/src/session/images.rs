//! A frame's stacked planes as images, and the moving-region mask derived from the references:
//! the per-frame inputs of the metrics.

use super::FrameReference;
use vrrt_core::kernels::gradient::GradientSample;
use vrrt_core::kernels::requests::FLAG_DISOCCLUDED;
use vrrt_scene::image::Image;

/// Reference change (per frame, any plane; relative above 1, see [`moving_mask`]) above which a
/// pixel counts as "moving".
pub const MOVING_THRESHOLD: f32 = 0.02;

/// Stacked planes (`plane * pixels + pixel`) as an interleaved image; two planes are padded
/// with a zero third channel (images have 1, 3 or 4 channels).
pub fn planes_to_image(stacked: &[f32], width: u32, height: u32, planes: u32) -> Image {
    let pixels = (width * height) as usize;
    let planes = planes as usize;
    let channels = if planes == 2 { 3 } else { planes };
    let mut data = vec![0.0f32; pixels * channels];
    for p in 0..planes {
        for i in 0..pixels {
            data[i * channels + p] = stacked[p * pixels + i];
        }
    }
    Image::new(width as usize, height as usize, channels, data).expect("image of the frame size")
}

/// Pixels flagged disoccluded, or whose reference changed (in any channel) since the previous
/// frame by more than [`MOVING_THRESHOLD`], relative to the previous value where that exceeds 1
/// (HDR radiance, where an absolute threshold would flag every highlight).
pub fn moving_mask(flags: &[u32], reference: &Image, previous: Option<&Image>) -> Vec<bool> {
    let c = reference.channels();
    (0..flags.len())
        .map(|i| {
            let disoccluded = flags[i] & FLAG_DISOCCLUDED != 0;
            let changed = previous.is_some_and(|p| {
                (0..c).any(|k| {
                    let (now, before) = (reference.data()[i * c + k], p.data()[i * c + k]);
                    (now - before).abs() > MOVING_THRESHOLD * before.abs().max(1.0)
                })
            });
            disoccluded || changed
        })
        .collect()
}

/// Standard errors of the difference of two references that a pixel must move by before the
/// oracle calls it a change, so that the references' own noise flags about 1 static pixel in
/// 16,000 (a normal 4σ test). Each standard error is estimated from the reference's eight
/// replicates (`vrrt_scene::render::REPLICATES`, seven degrees of freedom), so the difference
/// over its estimated error follows Student's t with about fourteen: that rate needs 5.6 of
/// them, where 4 would flag 1 pixel in 770.
pub const ORACLE_SIGMAS: f32 = 5.6;

/// The oracle's changes for one part whose planes start at `first_plane`: `λ = 1` (history
/// dropped) for each pixel and plane whose reference moved since the previous frame by more than
/// [`ORACLE_SIGMAS`] standard errors of the difference, or by the [`moving_mask`] rule where the
/// references' errors are unknown. Written into `out`, one `GradientSample` per pixel and plane
/// (plane-stacked over every plane of the frame).
pub fn oracle_changes(
    now: &FrameReference,
    before: &FrameReference,
    first_plane: usize,
    planes: usize,
    out: &mut [GradientSample],
) {
    let (image, prev) = (&now.image, &before.image);
    let pixels = image.width() * image.height();
    let c = image.channels();
    let sigma = |e: &Option<Image>, i: usize, k: usize| {
        e.as_ref().map_or(f32::NAN, |e| {
            let ch = if e.channels() == 1 { 0 } else { k };
            e.data()[i * e.channels() + ch]
        })
    };
    for k in 0..planes {
        for i in 0..pixels {
            let (a, b) = (image.data()[i * c + k], prev.data()[i * c + k]);
            let (sa, sb) = (sigma(&now.stderr, i, k), sigma(&before.stderr, i, k));
            let noise = (sa * sa + sb * sb).sqrt();
            let changed = if noise.is_nan() {
                (a - b).abs() > MOVING_THRESHOLD * b.abs().max(1.0)
            } else {
                (a - b).abs() > ORACLE_SIGMAS * noise
            };
            if changed {
                out[(first_plane + k) * pixels + i] = GradientSample {
                    delta: 1.0,
                    luminance: 1.0,
                };
            }
        }
    }
}

/// Pixels without history: all of a reset frame, else the disoccluded ones.
pub fn fresh_mask(flags: &[u32], reset: bool) -> Vec<bool> {
    flags
        .iter()
        .map(|f| reset || f & FLAG_DISOCCLUDED != 0)
        .collect()
}
