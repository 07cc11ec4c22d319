//! A frame's stacked planes as images, and the moving-region mask derived from the references:
//! the per-frame inputs of the metrics.

use vrrt_core::kernels::reproject::FLAG_DISOCCLUDED;
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
