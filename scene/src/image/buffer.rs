//! The in-memory image types: an owned [`Image`] and a borrowed [`ImageRef`] with their shape
//! check, and the interleaved ↔ planar conversions the EXR files and the renderers' planes need.
//! The shape is validated here once so that metrics and writers can index freely.

use std::fmt;

/// Why a buffer cannot be viewed as an image of the requested shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShapeError {
    /// Requested width in pixels.
    pub width: usize,
    /// Requested height in pixels.
    pub height: usize,
    /// Requested channels per pixel.
    pub channels: usize,
    /// Length of the buffer that was offered.
    pub len: usize,
}

impl fmt::Display for ShapeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "buffer of {} floats does not hold a {}x{} image with {} channel(s) \
             (dimensions must be non-zero and the length width*height*channels)",
            self.len, self.width, self.height, self.channels
        )
    }
}

impl std::error::Error for ShapeError {}

fn check_shape(len: usize, width: usize, height: usize, channels: usize) -> Result<(), ShapeError> {
    let expected = width
        .checked_mul(height)
        .and_then(|p| p.checked_mul(channels));
    if width == 0 || height == 0 || channels == 0 || expected != Some(len) {
        return Err(ShapeError {
            width,
            height,
            channels,
            len,
        });
    }
    Ok(())
}

/// An owned linear `f32` image: interleaved channels, row-major, top-left origin.
///
/// The shape is validated once at construction so that metrics and writers can index freely.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    width: usize,
    height: usize,
    channels: usize,
    data: Vec<f32>,
}

impl Image {
    /// Wraps `data` (length `width * height * channels`, all non-zero).
    pub fn new(
        width: usize,
        height: usize,
        channels: usize,
        data: Vec<f32>,
    ) -> Result<Self, ShapeError> {
        check_shape(data.len(), width, height, channels)?;
        Ok(Self {
            width,
            height,
            channels,
            data,
        })
    }

    /// An all-zero image, for accumulating into.
    ///
    /// # Panics
    /// If a dimension is zero or the size overflows `usize` (a programming error, not data).
    pub fn zeros(width: usize, height: usize, channels: usize) -> Self {
        let len = width
            .checked_mul(height)
            .and_then(|p| p.checked_mul(channels))
            .expect("image size overflows usize");
        Self::new(width, height, channels, vec![0.0; len])
            .expect("image dimensions must be non-zero")
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Channels per pixel.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// The interleaved samples.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// The interleaved samples, mutably (the shape cannot change through this).
    pub fn data_mut(&mut self) -> &mut [f32] {
        &mut self.data
    }

    /// Gives the sample buffer back.
    pub fn into_data(self) -> Vec<f32> {
        self.data
    }

    /// The channels of pixel `(x, y)`.
    ///
    /// # Panics
    /// If `(x, y)` is outside the image.
    pub fn pixel(&self, x: usize, y: usize) -> &[f32] {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside {}x{}",
            self.width,
            self.height
        );
        let i = (y * self.width + x) * self.channels;
        &self.data[i..i + self.channels]
    }

    /// A borrowed view, which is what the metrics and writers take.
    pub fn view(&self) -> ImageRef<'_> {
        ImageRef {
            width: self.width,
            height: self.height,
            channels: self.channels,
            data: &self.data,
        }
    }
}

/// A borrowed image: lets metrics and writers run on a renderer's buffer without copying it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageRef<'a> {
    width: usize,
    height: usize,
    channels: usize,
    data: &'a [f32],
}

impl<'a> ImageRef<'a> {
    /// Views `data` (length `width * height * channels`, all non-zero) as an image.
    pub fn new(
        data: &'a [f32],
        width: usize,
        height: usize,
        channels: usize,
    ) -> Result<Self, ShapeError> {
        check_shape(data.len(), width, height, channels)?;
        Ok(Self {
            width,
            height,
            channels,
            data,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Channels per pixel.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Number of pixels (`width * height`).
    pub fn pixel_count(&self) -> usize {
        self.width * self.height
    }

    /// The interleaved samples.
    pub fn data(&self) -> &'a [f32] {
        self.data
    }

    /// The channels of pixel index `i` (`y * width + x`).
    ///
    /// # Panics
    /// If `i >= width * height`.
    pub fn pixel_at(&self, i: usize) -> &'a [f32] {
        &self.data[i * self.channels..(i + 1) * self.channels]
    }

    /// Copies the view into an owned [`Image`].
    pub fn to_image(&self) -> Image {
        Image {
            width: self.width,
            height: self.height,
            channels: self.channels,
            data: self.data.to_vec(),
        }
    }
}

impl<'a> From<&'a Image> for ImageRef<'a> {
    fn from(image: &'a Image) -> Self {
        image.view()
    }
}

/// Deinterleaves channel `c` of `image`.
pub(crate) fn plane(image: ImageRef<'_>, c: usize) -> Vec<f32> {
    image
        .data()
        .iter()
        .skip(c)
        .step_by(image.channels())
        .copied()
        .collect()
}

/// Interleaves equally long planes into an [`Image`].
pub(crate) fn interleave(width: usize, height: usize, planes: &[&[f32]]) -> Image {
    let pixels = width * height;
    let mut data = Vec::with_capacity(pixels * planes.len());
    for i in 0..pixels {
        data.extend(planes.iter().map(|p| p[i]));
    }
    Image {
        width,
        height,
        channels: planes.len(),
        data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shape_is_validated() {
        assert!(Image::new(2, 2, 3, vec![0.0; 12]).is_ok());
        assert!(Image::new(2, 2, 3, vec![0.0; 11]).is_err());
        assert!(Image::new(0, 2, 1, vec![]).is_err());
        assert!(ImageRef::new(&[0.0; 4], 2, 2, 0).is_err());
        let e = ImageRef::new(&[0.0; 5], 2, 2, 1).unwrap_err();
        assert!(e.to_string().contains("5 floats"));
    }

    #[test]
    fn pixel_indexing_is_row_major_top_left() {
        let img = Image::new(3, 2, 2, (0..12).map(|v| v as f32).collect()).unwrap();
        assert_eq!(img.pixel(0, 0), &[0.0, 1.0]);
        assert_eq!(img.pixel(2, 0), &[4.0, 5.0]);
        assert_eq!(img.pixel(0, 1), &[6.0, 7.0]);
        assert_eq!(img.view().pixel_at(5), &[10.0, 11.0]);
    }
}
