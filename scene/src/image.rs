//! Linear `f32` image buffers and their file IO.
//!
//! Everything the renderers and denoisers produce is linear radiance or a `[0,1]` signal (AO,
//! shadow visibility), stored interleaved, row-major, top-left origin. Two formats cover the
//! project's needs:
//!
//! - **EXR** (linear `f32`, lossless ZIP) for anything that is compared numerically later,
//!   above all the ground-truth references ([`crate::reference_cache`]). A write→read round trip
//!   is bit-exact.
//! - **PNG** (8-bit sRGB) for looking at results: values are clamped to `[0,1]` and sRGB-encoded,
//!   with no exposure or tone curve, so what you see is what [`crate::metrics`]' LDR metrics see.
//!   [`write_heatmap_png`] turns a scalar (ray counts, error) into a false-colour overlay.
//!
//! IO never panics: every failure is an [`ImageError`] that names the file.

use std::collections::HashMap;
use std::fmt;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Layer, LayerAttributes,
    ReadChannels, ReadLayers, SmallVec, Text, WritableImage,
};

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

/// An image file could not be written or read. Every variant names the file.
#[derive(Debug)]
pub enum ImageError {
    /// The operating system refused (missing directory, permissions, disk full, ...).
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done: "reading" or "writing".
        action: &'static str,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The PNG encoder or decoder failed.
    Png {
        /// The file.
        path: PathBuf,
        /// The codec's message.
        message: String,
    },
    /// The EXR encoder or decoder failed (corrupt, truncated or unsupported file).
    Exr {
        /// The file.
        path: PathBuf,
        /// The codec's message.
        message: String,
    },
    /// The image has a channel count the format (or this writer) cannot express.
    UnsupportedChannels {
        /// The file.
        path: PathBuf,
        /// "PNG", "EXR" or "heatmap".
        format: &'static str,
        /// The offending channel count.
        channels: usize,
    },
    /// An EXR file's channels are not Y, R/G/B(/A) or a single channel of any name.
    UnrecognisedChannels {
        /// The file.
        path: PathBuf,
        /// The channel names found.
        names: Vec<String>,
    },
}

impl fmt::Display for ImageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io { path, action, source } => write!(f, "{action} {}: {source}", path.display()),
            Self::Png { path, message } => write!(f, "PNG {}: {message}", path.display()),
            Self::Exr { path, message } => write!(f, "EXR {}: {message}", path.display()),
            Self::UnsupportedChannels { path, format, channels } => write!(
                f,
                "{}: {format} output does not support {channels} channel(s)",
                path.display()
            ),
            Self::UnrecognisedChannels { path, names } => write!(
                f,
                "EXR {}: unrecognised channel set {names:?} (expected Y, R/G/B, R/G/B/A or one channel)",
                path.display()
            ),
        }
    }
}

impl std::error::Error for ImageError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

fn io_error(path: &Path, action: &'static str, source: std::io::Error) -> ImageError {
    ImageError::Io {
        path: path.to_path_buf(),
        action,
        source,
    }
}

// ---------------------------------------------------------------------------------------------
// PNG
// ---------------------------------------------------------------------------------------------

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

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), ImageError> {
    std::fs::write(path, bytes).map_err(|e| io_error(path, "writing", e))
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

// ---------------------------------------------------------------------------------------------
// EXR
// ---------------------------------------------------------------------------------------------

/// EXR channel names for an interleaved image: Y for one channel, R,G,B(,A) for three (four).
pub(crate) fn exr_channel_names(channels: usize) -> Option<&'static [&'static str]> {
    match channels {
        1 => Some(&["Y"]),
        3 => Some(&["R", "G", "B"]),
        4 => Some(&["R", "G", "B", "A"]),
        _ => None,
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

/// Encodes named planar `f32` channels (each `width * height` long, row-major) plus custom
/// header attributes as a lossless (ZIP) single-part EXR in memory.
pub(crate) fn encode_exr(
    width: usize,
    height: usize,
    channels: Vec<(&str, Vec<f32>)>,
    attributes: Vec<(&str, AttributeValue)>,
) -> Result<Vec<u8>, String> {
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (name, samples) in channels {
        if samples.len() != width * height {
            return Err(format!(
                "channel {name} has {} samples, expected {}",
                samples.len(),
                width * height
            ));
        }
        let name = Text::new_or_none(name)
            .ok_or_else(|| format!("channel name {name:?} is not Latin-1"))?;
        list.push(AnyChannel::new(name, FlatSamples::F32(samples)));
    }
    let mut layer_attributes = LayerAttributes::default();
    for (name, value) in attributes {
        let name = Text::new_or_none(name)
            .ok_or_else(|| format!("attribute name {name:?} is not Latin-1"))?;
        layer_attributes.other.insert(name, value);
    }
    let layer = Layer::new(
        (width, height),
        layer_attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let image = exr::image::Image::from_layer(layer);
    let mut out = Cursor::new(Vec::new());
    image
        .write()
        .non_parallel()
        .to_buffered(&mut out)
        .map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

/// A decoded single-part EXR: planar `f32` channels by name and the custom header attributes.
pub(crate) struct DecodedExr {
    pub width: usize,
    pub height: usize,
    /// Channel name → row-major samples (converted to `f32` from whatever the file held).
    pub channels: Vec<(String, Vec<f32>)>,
    pub attributes: HashMap<String, AttributeValue>,
}

impl DecodedExr {
    /// The channel called `name`, if present.
    pub fn channel(&self, name: &str) -> Option<&[f32]> {
        self.channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, s)| s.as_slice())
    }
}

/// Decodes the first layer of an in-memory EXR, strictly: a truncated or inconsistent file is an
/// error, never a partially zero image.
pub(crate) fn decode_exr(bytes: &[u8]) -> Result<DecodedExr, String> {
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .pedantic()
        .non_parallel()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| e.to_string())?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let mut channels = Vec::with_capacity(layer.channel_data.list.len());
    for channel in layer.channel_data.list {
        let samples: Vec<f32> = match channel.sample_data {
            FlatSamples::F32(v) => v,
            FlatSamples::F16(v) => v.into_iter().map(|h| h.to_f32()).collect(),
            FlatSamples::U32(v) => v.into_iter().map(|u| u as f32).collect(),
        };
        if samples.len() != width * height {
            return Err(format!(
                "channel {} has {} samples for {width}x{height}",
                channel.name,
                samples.len()
            ));
        }
        channels.push((channel.name.to_string(), samples));
    }
    let attributes = layer
        .attributes
        .other
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
    Ok(DecodedExr {
        width,
        height,
        channels,
        attributes,
    })
}

/// Picks the image channels of a decoded EXR: R,G,B(,A), else Y, else a lone channel.
/// Channels with a `.` (another layer's, e.g. `stderr.Y`) are ignored.
pub(crate) fn image_from_decoded(decoded: &DecodedExr) -> Result<Image, Vec<String>> {
    let names: Vec<&str> = decoded
        .channels
        .iter()
        .map(|(n, _)| n.as_str())
        .filter(|n| !n.contains('.'))
        .collect();
    let has = |n: &str| names.contains(&n);
    let chosen: Vec<&str> = if has("R") && has("G") && has("B") {
        if has("A") {
            vec!["R", "G", "B", "A"]
        } else {
            vec!["R", "G", "B"]
        }
    } else if has("Y") {
        vec!["Y"]
    } else if names.len() == 1 {
        vec![names[0]]
    } else {
        return Err(decoded.channels.iter().map(|(n, _)| n.clone()).collect());
    };
    let planes: Vec<&[f32]> = chosen.iter().filter_map(|n| decoded.channel(n)).collect();
    Ok(interleave(decoded.width, decoded.height, &planes))
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

/// Writes `image` as a linear `f32` EXR (lossless ZIP): one channel as `Y`, three as `R,G,B`,
/// four as `R,G,B,A`. Reading it back with [`read_exr`] gives the identical bits.
pub fn write_exr(path: impl AsRef<Path>, image: ImageRef<'_>) -> Result<(), ImageError> {
    let path = path.as_ref();
    let names = exr_channel_names(image.channels()).ok_or(ImageError::UnsupportedChannels {
        path: path.to_path_buf(),
        format: "EXR",
        channels: image.channels(),
    })?;
    let channels = names
        .iter()
        .enumerate()
        .map(|(c, &n)| (n, plane(image, c)))
        .collect();
    let bytes =
        encode_exr(image.width(), image.height(), channels, Vec::new()).map_err(|message| {
            ImageError::Exr {
                path: path.to_path_buf(),
                message,
            }
        })?;
    write_file(path, &bytes)
}

/// Reads the first layer of an EXR as linear `f32`: `R,G,B(,A)` → 3 (4) channels, `Y` → 1, or a
/// lone channel of any name → 1. Half and uint samples are converted to `f32`.
pub fn read_exr(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| io_error(path, "reading", e))?;
    let decoded = decode_exr(&bytes).map_err(|message| ImageError::Exr {
        path: path.to_path_buf(),
        message,
    })?;
    image_from_decoded(&decoded).map_err(|names| ImageError::UnrecognisedChannels {
        path: path.to_path_buf(),
        names,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode_png(path: &Path) -> (png::OutputInfo, Vec<u8>) {
        let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        buf.truncate(info.buffer_size());
        (info, buf)
    }

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

    #[test]
    fn exr_round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let specials = [
            0.0,
            -0.0,
            1.0,
            f32::MIN_POSITIVE,
            1e-42,
            f32::MAX,
            -7.25,
            f32::INFINITY,
            f32::NAN,
        ];
        for channels in [1usize, 3, 4] {
            let (w, h) = (7, 5);
            let data: Vec<f32> = (0..w * h * channels)
                .map(|i| {
                    if i < specials.len() {
                        specials[i]
                    } else {
                        // Arbitrary bit patterns of finite floats.
                        f32::from_bits((i as u32).wrapping_mul(2_654_435_761) & 0x7f7f_ffff)
                    }
                })
                .collect();
            let img = Image::new(w, h, channels, data).unwrap();
            let p = dir.path().join(format!("img{channels}.exr"));
            write_exr(&p, img.view()).unwrap();
            let back = read_exr(&p).unwrap();
            assert_eq!(
                (back.width(), back.height(), back.channels()),
                (w, h, channels)
            );
            let a: Vec<u32> = img.data().iter().map(|v| v.to_bits()).collect();
            let b: Vec<u32> = back.data().iter().map(|v| v.to_bits()).collect();
            assert_eq!(a, b, "{channels} channel(s)");
        }
    }

    #[test]
    fn exr_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.exr");
        let e = read_exr(&missing).unwrap_err();
        assert!(matches!(e, ImageError::Io { .. }));
        assert!(e.to_string().contains("missing.exr"), "{e}");

        let garbage = dir.path().join("garbage.exr");
        std::fs::write(&garbage, b"definitely not an exr file").unwrap();
        let e = read_exr(&garbage).unwrap_err();
        assert!(matches!(e, ImageError::Exr { .. }));
        assert!(e.to_string().contains("garbage.exr"), "{e}");

        let good = dir.path().join("good.exr");
        write_exr(
            &good,
            Image::new(16, 16, 3, vec![0.25; 768]).unwrap().view(),
        )
        .unwrap();
        let bytes = std::fs::read(&good).unwrap();
        let truncated = dir.path().join("truncated.exr");
        std::fs::write(&truncated, &bytes[..bytes.len() - 8]).unwrap();
        assert!(matches!(
            read_exr(&truncated).unwrap_err(),
            ImageError::Exr { .. }
        ));

        let e = write_exr(
            dir.path().join("no/such/dir/x.exr"),
            Image::zeros(1, 1, 1).view(),
        )
        .unwrap_err();
        assert!(matches!(
            e,
            ImageError::Io {
                action: "writing",
                ..
            }
        ));
    }

    #[test]
    fn exr_reader_ignores_other_layers_and_reads_single_named_channel() {
        let bytes = encode_exr(
            2,
            1,
            vec![("Y", vec![1.0, 2.0]), ("stderr.Y", vec![0.1, 0.2])],
            vec![("note", AttributeValue::F64(0.5))],
        )
        .unwrap();
        let decoded = decode_exr(&bytes).unwrap();
        assert!(
            matches!(decoded.attributes.get("note"), Some(AttributeValue::F64(v)) if *v == 0.5)
        );
        let img = image_from_decoded(&decoded).unwrap();
        assert_eq!((img.channels(), img.data()), (1, &[1.0, 2.0][..]));

        let bytes = encode_exr(2, 1, vec![("depth", vec![3.0, 4.0])], vec![]).unwrap();
        let img = image_from_decoded(&decode_exr(&bytes).unwrap()).unwrap();
        assert_eq!(img.data(), &[3.0, 4.0]);

        let bytes = encode_exr(1, 1, vec![("U", vec![0.0]), ("V", vec![0.0])], vec![]).unwrap();
        assert_eq!(
            image_from_decoded(&decode_exr(&bytes).unwrap()).unwrap_err(),
            vec!["U", "V"]
        );
    }
}
