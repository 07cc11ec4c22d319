//! 8-bit sRGB PNG output for looking at results: the sRGB transfer function (shared with FLIP),
//! the PNG writer and the false-colour heatmap for scalar overlays. Nothing here is read back.

use super::{write_file, ImageError, ImageRef};
use std::path::Path;

/// The sRGB opto-electronic transfer function (IEC 61966-2-1) of a value clamped to `[0,1]`.
///
/// NaN maps to 0 and +inf to 1, so a broken pixel shows up as black or white rather than
/// aborting an image dump.
pub fn srgb_oetf(linear: f32) -> f32 {
    let v = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// [`srgb_oetf`] quantised to 8 bits (round to nearest): the PNG and FLIP encoding.
pub fn srgb8(linear: f32) -> u8 {
    (srgb_oetf(linear) * 255.0 + 0.5) as u8
}

/// Clamps a linear value to `[0,1]` and quantises it without a transfer curve (alpha channels).
fn linear8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    (v * 255.0 + 0.5) as u8
}

fn encode_png(
    width: usize,
    height: usize,
    color: png::ColorType,
    bytes: &[u8],
) -> Result<Vec<u8>, String> {
    let (w, h) = match (u32::try_from(width), u32::try_from(height)) {
        (Ok(w), Ok(h)) => (w, h),
        _ => return Err(format!("{width}x{height} is too large for PNG")),
    };
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, w, h);
        encoder.set_color(color);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
        writer.write_image_data(bytes).map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// Writes `image` as an 8-bit sRGB PNG: each channel clamped to `[0,1]` and sRGB-encoded.
///
/// 1 channel → greyscale, 3 → RGB, 4 → RGBA (alpha stays linear). No exposure or tone curve is
/// applied: scale HDR radiance before calling if it exceeds 1.
pub fn write_png(path: impl AsRef<Path>, image: ImageRef<'_>) -> Result<(), ImageError> {
    let path = path.as_ref();
    let color = match image.channels() {
        1 => png::ColorType::Grayscale,
        3 => png::ColorType::Rgb,
        4 => png::ColorType::Rgba,
        channels => {
            return Err(ImageError::UnsupportedChannels {
                path: path.to_path_buf(),
                format: "PNG",
                channels,
            })
        }
    };
    let channels = image.channels();
    let bytes: Vec<u8> = image
        .data()
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            if channels == 4 && i % 4 == 3 {
                linear8(v)
            } else {
                srgb8(v)
            }
        })
        .collect();
    let png = encode_png(image.width(), image.height(), color, &bytes).map_err(|message| {
        ImageError::Png {
            path: path.to_path_buf(),
            message,
        }
    })?;
    write_file(path, &png)
}

/// Colour of a NaN in [`heatmap_rgb8`]: loud magenta, which the ramp never produces.
pub const HEATMAP_NAN: [u8; 3] = [255, 0, 255];

/// Colour of values above the maximum in [`heatmap_rgb8`]: white, so saturation is visible.
pub const HEATMAP_OVER: [u8; 3] = [255, 255, 255];

/// Ramp stops of [`heatmap_rgb8`] at 0, 1/4, 1/2, 3/4 and 1 of the range.
const HEATMAP_STOPS: [[f32; 3]; 5] = [
    [0.0, 0.0, 0.0],   // black: nothing
    [0.0, 0.2, 0.9],   // blue
    [0.0, 0.75, 0.25], // green
    [0.95, 0.85, 0.0], // yellow
    [0.9, 0.05, 0.0],  // red: at the maximum
];

/// False colour for `value / max` on a black→blue→green→yellow→red ramp, for overlays such as
/// rays per pixel or an error map.
///
/// Values above `max` are [`HEATMAP_OVER`] (white) and NaN is [`HEATMAP_NAN`] (magenta), so
/// neither hides inside the ramp; negative values clamp to black. A `max` that is not positive
/// and finite makes every finite value "over".
pub fn heatmap_rgb8(value: f32, max: f32) -> [u8; 3] {
    if value.is_nan() {
        return HEATMAP_NAN;
    }
    if !(max > 0.0 && max.is_finite()) || value > max {
        return if value <= 0.0 {
            [0, 0, 0]
        } else {
            HEATMAP_OVER
        };
    }
    let t = (value / max).clamp(0.0, 1.0) * (HEATMAP_STOPS.len() - 1) as f32;
    let i = (t as usize).min(HEATMAP_STOPS.len() - 2);
    let f = t - i as f32;
    let (a, b) = (HEATMAP_STOPS[i], HEATMAP_STOPS[i + 1]);
    let mut rgb = [0u8; 3];
    for c in 0..3 {
        rgb[c] = ((a[c] + (b[c] - a[c]) * f) * 255.0 + 0.5) as u8;
    }
    rgb
}

/// Writes a single-channel image as a false-colour RGB PNG through [`heatmap_rgb8`] with the
/// given maximum (values are not sRGB-encoded: the ramp is already display colours).
pub fn write_heatmap_png(
    path: impl AsRef<Path>,
    values: ImageRef<'_>,
    max: f32,
) -> Result<(), ImageError> {
    let path = path.as_ref();
    if values.channels() != 1 {
        return Err(ImageError::UnsupportedChannels {
            path: path.to_path_buf(),
            format: "heatmap",
            channels: values.channels(),
        });
    }
    let bytes: Vec<u8> = values
        .data()
        .iter()
        .flat_map(|&v| heatmap_rgb8(v, max))
        .collect();
    let png = encode_png(values.width(), values.height(), png::ColorType::Rgb, &bytes).map_err(
        |message| ImageError::Png {
            path: path.to_path_buf(),
            message,
        },
    )?;
    write_file(path, &png)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;

    fn decode_png(path: &Path) -> (png::OutputInfo, Vec<u8>) {
        let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        buf.truncate(info.buffer_size());
        (info, buf)
    }

    #[test]
    fn srgb_curve_endpoints_and_knee() {
        assert_eq!(srgb_oetf(0.0), 0.0);
        assert!((srgb_oetf(1.0) - 1.0).abs() < 1e-6);
        assert_eq!(srgb_oetf(-3.0), 0.0);
        assert!((srgb_oetf(7.0) - 1.0).abs() < 1e-6);
        assert_eq!(srgb_oetf(f32::NAN), 0.0);
        assert!((srgb_oetf(f32::INFINITY) - 1.0).abs() < 1e-6);
        // Linear segment below the knee, and the well-known mid-grey 0.18 → ~0.4614.
        assert!((srgb_oetf(0.001) - 0.01292).abs() < 1e-7);
        assert!((srgb_oetf(0.18) - 0.4614).abs() < 1e-3);
        assert_eq!(srgb8(0.5), 188);
        assert_eq!(srgb8(1.0), 255);
    }

    #[test]
    fn png_grey_and_rgb_are_decodable() {
        let dir = tempfile::tempdir().unwrap();
        let grey = Image::new(3, 2, 1, vec![0.0, 0.5, 1.0, 2.0, -1.0, f32::NAN]).unwrap();
        let p = dir.path().join("grey.png");
        write_png(&p, grey.view()).unwrap();
        let (info, bytes) = decode_png(&p);
        assert_eq!(
            (info.width, info.height, info.color_type),
            (3, 2, png::ColorType::Grayscale)
        );
        assert_eq!(bytes, vec![0, 188, 255, 255, 0, 0]);

        let rgb = Image::new(2, 1, 3, vec![1.0, 0.0, 0.0, 0.0, 0.5, 1.0]).unwrap();
        let p = dir.path().join("rgb.png");
        write_png(&p, rgb.view()).unwrap();
        let (info, bytes) = decode_png(&p);
        assert_eq!(
            (info.width, info.height, info.color_type),
            (2, 1, png::ColorType::Rgb)
        );
        assert_eq!(bytes, vec![255, 0, 0, 0, 188, 255]);
    }

    #[test]
    fn png_rejects_two_channels_and_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let img = Image::zeros(2, 2, 2);
        let p = dir.path().join("two.png");
        let e = write_png(&p, img.view()).unwrap_err();
        assert!(matches!(
            e,
            ImageError::UnsupportedChannels { channels: 2, .. }
        ));
        assert!(e.to_string().contains("two.png"));
    }

    #[test]
    fn heatmap_ramp_and_flags() {
        assert_eq!(heatmap_rgb8(0.0, 10.0), [0, 0, 0]);
        assert_eq!(heatmap_rgb8(-5.0, 10.0), [0, 0, 0]);
        assert_eq!(heatmap_rgb8(10.0, 10.0), [230, 13, 0]);
        assert_eq!(heatmap_rgb8(10.5, 10.0), HEATMAP_OVER);
        assert_eq!(heatmap_rgb8(f32::NAN, 10.0), HEATMAP_NAN);
        assert_eq!(heatmap_rgb8(5.0, 10.0), [0, 191, 64]);
        // A non-positive maximum flags everything as over, but zero stays black.
        assert_eq!(heatmap_rgb8(1.0, 0.0), HEATMAP_OVER);
        assert_eq!(heatmap_rgb8(0.0, 0.0), [0, 0, 0]);

        let dir = tempfile::tempdir().unwrap();
        let counts = Image::new(2, 2, 1, vec![0.0, 1.0, 2.0, 3.0]).unwrap();
        let p = dir.path().join("heat.png");
        write_heatmap_png(&p, counts.view(), 2.0).unwrap();
        let (info, bytes) = decode_png(&p);
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(&bytes[0..3], &[0, 0, 0]);
        assert_eq!(&bytes[9..12], &HEATMAP_OVER);
        assert!(write_heatmap_png(&p, Image::zeros(1, 1, 3).view(), 1.0).is_err());
    }
}
