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

mod buffer;
mod exr_io;
mod png_io;

pub(crate) use buffer::{interleave, plane};
pub use buffer::{Image, ImageRef, ShapeError};
pub(crate) use exr_io::{decode_exr, encode_exr, exr_channel_names, image_from_decoded};
pub use exr_io::{read_exr, write_exr};
pub use png_io::{
    heatmap_rgb8, srgb8, srgb_oetf, write_heatmap_png, write_png, HEATMAP_NAN, HEATMAP_OVER,
};

use std::fmt;
use std::path::{Path, PathBuf};

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

/// Writes through a temporary file renamed over `path`: a symbolic link there is replaced, not
/// followed ([`crate::safe_fs::write_atomic`]).
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), ImageError> {
    crate::safe_fs::write_atomic(path, bytes).map_err(|e| io_error(path, "writing", e))
}
