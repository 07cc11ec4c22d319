//! The images of the page cut from a frame: crops upscaled by whole factors with nearest
//! neighbour (the noise and a one-pixel ghost stay visible as pixels, not blurred away), the
//! per-pixel error against the reference and the moving mask, and the crop's relMSE.

use super::region::Rect;
use anyhow::{anyhow, Result};
use vrrt_scene::image::Image;
use vrrt_scene::metrics;

/// An image of `r`'s size times `scale` whose pixel `(x, y)` of the crop has channel `c` equal
/// to `value(x, y, c)` (crop coordinates).
fn upscaled(
    r: Rect,
    scale: u32,
    channels: usize,
    value: impl Fn(usize, usize, usize) -> f32,
) -> Image {
    let s = scale as usize;
    let (w, h) = (r.width() as usize, r.height() as usize);
    let mut data = Vec::with_capacity(w * s * h * s * channels);
    for y in 0..h * s {
        for x in 0..w * s {
            for c in 0..channels {
                data.push(value(x / s, y / s, c));
            }
        }
    }
    Image::new(w * s, h * s, channels, data).expect("a non-empty crop inside the image")
}

/// The channels of pixel `(x, y)` of the crop `r` of `image`.
fn at(image: &Image, r: Rect, x: usize, y: usize) -> &[f32] {
    image.pixel(r.x0 as usize + x, r.y0 as usize + y)
}

/// `image` inside `r`, upscaled by `scale`.
pub fn cut(image: &Image, r: Rect, scale: u32) -> Image {
    upscaled(r, scale, image.channels(), |x, y, c| at(image, r, x, y)[c])
}

/// `|test − reference|` per pixel inside `r` (the mean over channels), upscaled by `scale`; NaN
/// where either is not finite (the heatmap shows it in magenta).
pub fn error(test: &Image, reference: &Image, r: Rect, scale: u32) -> Image {
    upscaled(r, scale, 1, |x, y, _| {
        let (t, e) = (at(test, r, x, y), at(reference, r, x, y));
        let sum: f32 = t.iter().zip(e).map(|(a, b)| (a - b).abs()).sum();
        sum / t.len() as f32
    })
}

/// The moving mask (row-major over an image `width` wide) inside `r` as white on black.
pub fn mask(moving: &[bool], width: u32, r: Rect, scale: u32) -> Image {
    upscaled(r, scale, 1, |x, y, _| {
        let i = (r.y0 as usize + y) * width as usize + r.x0 as usize + x;
        if moving.get(i).copied().unwrap_or(false) {
            1.0
        } else {
            0.0
        }
    })
}

/// relMSE of `test` against `reference` inside `r`, as the bench defines it (NaN when no pixel
/// of the crop is finite in both).
pub fn rel_mse(test: &Image, reference: &Image, r: Rect) -> Result<f64> {
    let (t, e) = (cut(test, r, 1), cut(reference, r, 1));
    let all = vec![true; r.width() as usize * r.height() as usize];
    let m = metrics::masked_error(t.view(), e.view(), &all).map_err(|e| anyhow!("{e}"))?;
    Ok(m.map_or(f64::NAN, |m| m.rel_mse))
}

/// Mean of the finite values of an error image (its caption).
pub fn mean_finite(error: &Image) -> f64 {
    crate::session::mean_finite(error.data().iter().map(|&v| f64::from(v)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize, channels: usize) -> Image {
        let data = (0..w * h * channels).map(|i| i as f32).collect();
        Image::new(w, h, channels, data).unwrap()
    }

    #[test]
    fn crops_repeat_pixels_and_errors_average_channels() {
        let img = ramp(4, 3, 1);
        let r = Rect {
            x0: 1,
            y0: 1,
            x1: 3,
            y1: 2,
        };
        let c = cut(&img, r, 2);
        assert_eq!((c.width(), c.height()), (4, 2));
        assert_eq!(c.data(), &[5.0, 5.0, 6.0, 6.0, 5.0, 5.0, 6.0, 6.0]);

        let a = Image::new(2, 1, 3, vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]).unwrap();
        let b = Image::new(2, 1, 3, vec![0.3, 0.0, 0.0, 1.0, f32::NAN, 1.0]).unwrap();
        let full = Rect::full((2, 1));
        let e = error(&a, &b, full, 1);
        assert!((e.data()[0] - 0.1).abs() < 1e-6);
        assert!(e.data()[1].is_nan());
        assert!((mean_finite(&e) - 0.1).abs() < 1e-6);

        let m = mask(&[false, true, true, false], 2, Rect::full((2, 2)), 1);
        assert_eq!(m.data(), &[0.0, 1.0, 1.0, 0.0]);
    }

    #[test]
    fn crop_rel_mse_is_the_metric_on_the_crop() {
        let reference = Image::new(2, 1, 1, vec![1.0, 0.0]).unwrap();
        let test = Image::new(2, 1, 1, vec![1.5, 0.0]).unwrap();
        let left = Rect {
            x0: 0,
            y0: 0,
            x1: 1,
            y1: 1,
        };
        let v = rel_mse(&test, &reference, left).unwrap();
        assert!((v - 0.25 / 1.01).abs() < 1e-9, "{v}");
        let right = Rect {
            x0: 1,
            x1: 2,
            ..left
        };
        assert_eq!(rel_mse(&test, &reference, right).unwrap(), 0.0);
    }
}
