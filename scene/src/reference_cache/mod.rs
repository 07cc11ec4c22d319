//! On-disk cache of ground-truth reference images.
//!
//! References take minutes to converge, so they are rendered once and kept as EXR files. An
//! entry must never be used for an image it does not show, so:
//! - it is keyed by content (`key.rs`): a hash of the frame the renderer reads, the size, the
//!   signal and its parameters, the sample count and the estimator's version. A stale or
//!   foreign entry has another path, and the full key stored in each entry is checked on load;
//! - each entry carries a checksum (`entry.rs`): a damaged entry reads as [`Lookup::Corrupt`]
//!   (a warning and a miss from [`ReferenceCache::load`]), never as a hit or a panic, and the
//!   next [`ReferenceCache::store`] replaces it;
//! - writes are atomic and safe between concurrent writers, and temporary files of dead writers
//!   are cleaned (`store.rs`, which says why no lock is needed).

mod entry;
mod key;
mod store;
#[cfg(test)]
mod tests;

use std::fmt;
use std::path::{Path, PathBuf};

use crate::image::{Image, ImageRef};
use entry::{decode_entry, encode_entry, EncodeError};
pub use key::{ReferenceKey, SceneHash, ESTIMATOR_VERSION, REFLECTIONS_ESTIMATOR_VERSION};
pub(crate) use store::write_atomically;
pub use store::ORPHAN_AGE;

/// Monte Carlo standard error of a cached reference: its own noise level.
#[derive(Debug, Clone, PartialEq)]
pub enum StdErr {
    /// One number for the whole image (e.g. [`crate::metrics::StandardError::rms`]).
    Scalar(f64),
    /// Per pixel, same size as the image, one channel or as many as the image.
    Image(Image),
}

/// A reference loaded from the cache.
#[derive(Debug, Clone, PartialEq)]
pub struct CachedReference {
    /// The reference image (linear `f32`).
    pub image: Image,
    /// Its standard error.
    pub stderr: StdErr,
}

/// Result of [`ReferenceCache::lookup`], distinguishing a corrupt entry from an absent one.
#[derive(Debug, Clone, PartialEq)]
pub enum Lookup {
    /// The entry exists and is valid.
    Hit(CachedReference),
    /// No entry for this key.
    Miss,
    /// An entry exists but cannot be used; the message says why.
    Corrupt(String),
}

/// Why a reference could not be stored. Names the file where there is one.
#[derive(Debug)]
pub enum CacheError {
    /// The image or standard error does not fit the key (size) or each other (channels).
    Mismatch(String),
    /// Creating directories, writing or renaming failed.
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// EXR encoding failed.
    Encode {
        /// The entry's path.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
}

impl fmt::Display for CacheError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Mismatch(m) => write!(f, "reference does not match its cache key: {m}"),
            Self::Io { path, source } => write!(f, "reference cache {}: {source}", path.display()),
            Self::Encode { path, message } => write!(
                f,
                "reference cache {}: EXR encoding: {message}",
                path.display()
            ),
        }
    }
}

impl std::error::Error for CacheError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// `$<env_var>` if set, else `$XDG_CACHE_HOME/vrrt/<leaf>`, else `$HOME/.cache/vrrt/<leaf>`;
/// `None` if none of these variables is set (non-empty). Shared with the mesh cache, so every
/// cache of ours lives in one place outside the clone.
pub(crate) fn user_cache_dir(env_var: &str, leaf: &str) -> Option<PathBuf> {
    let var = |name: &str| {
        std::env::var_os(name)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    var(env_var)
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("vrrt").join(leaf)))
        .or_else(|| var("HOME").map(|d| d.join(".cache").join("vrrt").join(leaf)))
}

/// A directory of cached references.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReferenceCache {
    root: PathBuf,
}

impl ReferenceCache {
    /// Environment variable that overrides the default cache directory.
    pub const ENV_VAR: &'static str = "VRRT_REFERENCE_CACHE";

    /// A cache rooted at `root` (created on the first store).
    pub fn new(root: impl Into<PathBuf>) -> Self {
        Self { root: root.into() }
    }

    /// The default directory: `$VRRT_REFERENCE_CACHE` if set, else
    /// `$XDG_CACHE_HOME/vrrt/references`, else `$HOME/.cache/vrrt/references`; `None` if none of
    /// these variables is set (non-empty).
    pub fn default_dir() -> Option<PathBuf> {
        user_cache_dir(Self::ENV_VAR, "references")
    }

    /// A cache at [`default_dir`](Self::default_dir).
    pub fn from_env() -> Option<Self> {
        Self::default_dir().map(Self::new)
    }

    /// The cache directory.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Where `key`'s entry lives.
    pub fn path(&self, key: &ReferenceKey) -> PathBuf {
        self.root.join(key.relative_path())
    }

    /// Looks `key` up, telling a missing entry from an unusable one.
    pub fn lookup(&self, key: &ReferenceKey) -> Lookup {
        let path = self.path(key);
        // A regular file no larger than the key's image can make: a FIFO, a device or a link
        // to `/dev/zero` placed in the cache is unusable, not waited on or read without end.
        let bytes = match crate::safe_fs::read_capped(&path, entry_cap(key)) {
            Ok(bytes) => bytes,
            Err(crate::safe_fs::ReadError::Io(e)) if e.kind() == std::io::ErrorKind::NotFound => {
                return Lookup::Miss
            }
            Err(e) => return Lookup::Corrupt(format!("{} {e}", path.display())),
        };
        match decode_entry(key, &bytes) {
            Ok(reference) => Lookup::Hit(reference),
            Err(reason) => Lookup::Corrupt(format!("{}: {reason}", path.display())),
        }
    }

    /// The cached reference for `key`, or `None` on a miss. A corrupt entry is a miss too, with
    /// a warning on stderr (it is overwritten by the next [`store`](Self::store)).
    pub fn load(&self, key: &ReferenceKey) -> Option<CachedReference> {
        match self.lookup(key) {
            Lookup::Hit(reference) => Some(reference),
            Lookup::Miss => None,
            Lookup::Corrupt(reason) => {
                eprintln!(
                    "warning: ignoring unusable reference cache entry {reason}; \
                     it is rendered again"
                );
                None
            }
        }
    }

    /// Stores `image` with its standard error under `key`, atomically (temporary file + rename),
    /// and returns the entry's path. The image must be `key.width × key.height` with 1, 3 or 4
    /// channels; a per-pixel `stderr` must have the same size and 1 or the image's channel count.
    pub fn store(
        &self,
        key: &ReferenceKey,
        image: ImageRef<'_>,
        stderr: &StdErr,
    ) -> Result<PathBuf, CacheError> {
        let path = self.path(key);
        let bytes = encode_entry(key, image, stderr).map_err(|e| match e {
            EncodeError::Mismatch(m) => CacheError::Mismatch(m),
            EncodeError::Exr(message) => CacheError::Encode {
                path: path.clone(),
                message,
            },
        })?;
        write_atomically(&path, &bytes)?;
        Ok(path)
    }
}

/// The largest entry `key` can have: four image and four standard-error channels of `f32` per
/// pixel (uncompressed), plus the EXR header and line offsets.
fn entry_cap(key: &ReferenceKey) -> u64 {
    let (w, h) = (u64::from(key.width), u64::from(key.height));
    w * h * 8 * 4 + h * 16 + (1 << 20)
}
