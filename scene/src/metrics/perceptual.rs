//! NVIDIA's LDR-FLIP through the `nv-flip` crate (feature `flip`): the perceptual metric, in its
//! own module because it is optional and needs sRGB8 input rather than linear `f32`.

use super::{all_finite, check_same_shape, MetricsError};
use crate::image::{srgb8, Image, ImageRef};

/// Converts an image to tightly packed sRGB8 RGB for FLIP (grey replicated for one channel).
/// `worst_against`: replace non-finite pixels by the byte farthest from that image's byte.
fn flip_rgb8(image: ImageRef<'_>, worst_against: Option<&[u8]>) -> Result<Vec<u8>, MetricsError> {
    let c = image.channels();
    if c == 2 {
        return Err(MetricsError::UnsupportedChannels(c));
    }
    let mut out = Vec::with_capacity(image.pixel_count() * 3);
    for i in 0..image.pixel_count() {
        let p = image.pixel_at(i);
        let rgb = if c == 1 {
            [p[0]; 3]
        } else {
            [p[0], p[1], p[2]]
        };
        match worst_against {
            Some(reference) if !all_finite(p) => {
                out.extend((0..3).map(|k| if reference[i * 3 + k] >= 128 { 0 } else { 255 }));
            }
            _ => out.extend(rgb.map(srgb8)),
        }
    }
    Ok(out)
}

/// Per-pixel LDR-FLIP error map (one channel, `[0,1]`) of `test` against `reference`, both
/// clamped and sRGB-encoded to 8 bits first. `pixels_per_degree`: viewing condition, 67 for the
/// FLIP paper's default (`nv_flip::DEFAULT_PIXELS_PER_DEGREE`). Useful as a heatmap overlay.
pub fn flip_map(
    test: ImageRef<'_>,
    reference: ImageRef<'_>,
    pixels_per_degree: f32,
) -> Result<Image, MetricsError> {
    check_same_shape(test, reference)?;
    let too_big = || MetricsError::UnsupportedChannels(test.channels());
    let w = u32::try_from(test.width()).map_err(|_| too_big())?;
    let h = u32::try_from(test.height()).map_err(|_| too_big())?;
    let reference_bytes = flip_rgb8(reference, None)?;
    let test_bytes = flip_rgb8(test, Some(&reference_bytes))?;
    let reference_image = nv_flip::FlipImageRgb8::with_data(w, h, &reference_bytes);
    let test_image = nv_flip::FlipImageRgb8::with_data(w, h, &test_bytes);
    let map = nv_flip::flip(reference_image, test_image, pixels_per_degree);
    Ok(Image::new(test.width(), test.height(), 1, map.to_vec())
        .expect("FLIP map has the image's shape"))
}

/// Mean LDR-FLIP error (in `[0,1]`, 0 = identical) at the default 67 pixels per degree; the
/// single FLIP number the FLIP authors recommend reporting. See [`flip_map`].
pub fn flip(test: ImageRef<'_>, reference: ImageRef<'_>) -> Result<f64, MetricsError> {
    let map = flip_map(test, reference, nv_flip::DEFAULT_PIXELS_PER_DEGREE)?;
    Ok(map.data().iter().map(|&v| f64::from(v)).sum::<f64>() / map.data().len() as f64)
}
