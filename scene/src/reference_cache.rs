//! On-disk cache of ground-truth reference images.
//!
//! References take minutes to converge, so they are rendered once and kept as EXR files keyed by
//! everything that changes their content ([`ReferenceKey`]). Bump [`ReferenceKey::version`] when
//! the renderer's conventions change: old entries are then simply never looked up again.
//!
//! Each entry is one single-part EXR (see [`ReferenceCache::path`]):
//! - the image as `Y` or `R,G,B(,A)` linear `f32` channels (readable by any EXR viewer and by
//!   [`crate::image::read_exr`]);
//! - its Monte Carlo standard error ([`StdErr`]) either per pixel as `stderr.Y` / `stderr.R,...`
//!   channels or as one number in the `vrrtStdErr` header attribute;
//! - the full key in the `vrrtKey` attribute, checked on load so that two keys whose sanitised
//!   file names collide can never be confused;
//! - a 64-bit FNV-1a checksum of key, channels and scalar standard error in `vrrtChecksum`, since
//!   EXR itself has no content checksum and a flipped bit must not pass as a valid reference.
//!
//! Entries are written to a temporary file in the same directory and renamed into place, so an
//! interrupted run never leaves a half-written entry under the final name. A corrupt, truncated
//! or mismatching entry reads as a miss (with a warning on stderr from [`ReferenceCache::load`]),
//! never a panic; the next [`ReferenceCache::store`] replaces it.

use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use exr::prelude::AttributeValue;

use crate::image::{self, Image, ImageRef};

/// Everything that determines a reference image's content.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct ReferenceKey {
    /// Scene name (built-in scene id or mesh file stem).
    pub scene: String,
    /// Frame index within the scene's animation.
    pub frame: u32,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel the reference was accumulated with.
    pub spp: u64,
    /// What was rendered and under which convention, e.g. `"ao-r0.5"` or `"shadow-sun"`.
    pub signal: String,
    /// Cache format / renderer convention version; bump to invalidate older entries.
    pub version: u32,
}

impl ReferenceKey {
    /// The entry's path relative to the cache root:
    /// `<scene>/<signal>/f<frame>_<w>x<h>_<spp>spp_v<version>.exr` with the names sanitised to
    /// `[A-Za-z0-9._-]` (anything else becomes `_`).
    pub fn relative_path(&self) -> PathBuf {
        let mut p = PathBuf::from(sanitise(&self.scene));
        p.push(sanitise(&self.signal));
        p.push(format!(
            "f{:06}_{}x{}_{}spp_v{}.exr",
            self.frame, self.width, self.height, self.spp, self.version
        ));
        p
    }

    /// Unambiguous ASCII description stored in, and checked against, the entry.
    fn canonical(&self) -> String {
        format!(
            "scene=\"{}\";signal=\"{}\";frame={};size={}x{};spp={};version={}",
            self.scene.escape_default(),
            self.signal.escape_default(),
            self.frame,
            self.width,
            self.height,
            self.spp,
            self.version
        )
    }
}

impl fmt::Display for ReferenceKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.canonical())
    }
}

/// A file-name component from arbitrary text: keeps `[A-Za-z0-9._-]`, maps the rest to `_`, and
/// never yields an empty, `.` or `..` component.
fn sanitise(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.chars().all(|c| c == '.') {
        format!("_{s}")
    } else {
        s
    }
}

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

const KEY_ATTRIBUTE: &str = "vrrtKey";
const STDERR_ATTRIBUTE: &str = "vrrtStdErr";
const STDERR_PREFIX: &str = "stderr.";
const CHECKSUM_ATTRIBUTE: &str = "vrrtChecksum";

/// FNV-1a (64-bit) over the key, every channel (sorted by name: name, then sample bits) and the
/// scalar standard error if any. Not cryptographic: it only has to catch accidental damage.
fn checksum(key: &ReferenceKey, channels: &[(&str, &[f32])], scalar: Option<f64>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(key.canonical().as_bytes());
    let mut sorted: Vec<&(&str, &[f32])> = channels.iter().collect();
    sorted.sort_by_key(|(name, _)| *name);
    for (name, samples) in sorted {
        eat(name.as_bytes());
        eat(&[0]);
        for v in samples.iter() {
            eat(&v.to_bits().to_le_bytes());
        }
    }
    if let Some(v) = scalar {
        eat(&v.to_bits().to_le_bytes());
    }
    h
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
        let var = |name: &str| {
            std::env::var_os(name)
                .filter(|v| !v.is_empty())
                .map(PathBuf::from)
        };
        var(Self::ENV_VAR)
            .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("vrrt").join("references")))
            .or_else(|| var("HOME").map(|d| d.join(".cache").join("vrrt").join("references")))
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
        let bytes = match std::fs::read(&path) {
            Ok(bytes) => bytes,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Lookup::Miss,
            Err(e) => return Lookup::Corrupt(format!("{}: {e}", path.display())),
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
                eprintln!("warning: ignoring unusable reference cache entry {reason}");
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

enum EncodeError {
    Mismatch(String),
    Exr(String),
}

fn encode_entry(
    key: &ReferenceKey,
    image: ImageRef<'_>,
    stderr: &StdErr,
) -> Result<Vec<u8>, EncodeError> {
    let size = (image.width(), image.height());
    if size != (key.width as usize, key.height as usize) {
        return Err(EncodeError::Mismatch(format!(
            "image is {}x{}, key says {}x{}",
            size.0, size.1, key.width, key.height
        )));
    }
    let names = image::exr_channel_names(image.channels()).ok_or_else(|| {
        EncodeError::Mismatch(format!(
            "{} image channels (need 1, 3 or 4)",
            image.channels()
        ))
    })?;
    let mut channels: Vec<(String, Vec<f32>)> = names
        .iter()
        .enumerate()
        .map(|(c, n)| (n.to_string(), image::plane(image, c)))
        .collect();
    let mut attributes = vec![(KEY_ATTRIBUTE, text_attribute(&key.canonical()))];
    match stderr {
        StdErr::Scalar(v) => attributes.push((STDERR_ATTRIBUTE, AttributeValue::F64(*v))),
        StdErr::Image(se) => {
            if (se.width(), se.height()) != size {
                return Err(EncodeError::Mismatch(format!(
                    "standard error is {}x{}, image is {}x{}",
                    se.width(),
                    se.height(),
                    size.0,
                    size.1
                )));
            }
            let se_names = match se.channels() {
                1 => &["Y"][..],
                c if c == image.channels() => names,
                c => {
                    return Err(EncodeError::Mismatch(format!(
                        "standard error has {c} channels, image has {}",
                        image.channels()
                    )))
                }
            };
            for (c, n) in se_names.iter().enumerate() {
                channels.push((format!("{STDERR_PREFIX}{n}"), image::plane(se.view(), c)));
            }
        }
    }
    let scalar = match stderr {
        StdErr::Scalar(v) => Some(*v),
        StdErr::Image(_) => None,
    };
    let views: Vec<(&str, &[f32])> = channels
        .iter()
        .map(|(n, s)| (n.as_str(), s.as_slice()))
        .collect();
    let sum = checksum(key, &views, scalar);
    attributes.push((CHECKSUM_ATTRIBUTE, text_attribute(&format!("{sum:016x}"))));
    let channels = channels
        .iter()
        .map(|(n, s)| (n.as_str(), s.clone()))
        .collect();
    image::encode_exr(size.0, size.1, channels, attributes).map_err(EncodeError::Exr)
}

fn text_attribute(s: &str) -> AttributeValue {
    // `canonical` is ASCII (escape_default), so this cannot fail.
    AttributeValue::Text(exr::prelude::Text::new_or_none(s).expect("ASCII key"))
}

fn decode_entry(key: &ReferenceKey, bytes: &[u8]) -> Result<CachedReference, String> {
    // Check the header before decoding pixels, so a damaged size field cannot trigger a huge
    // allocation, then decode strictly; a decoder panic on a malformed file is still a miss.
    let meta = exr::meta::MetaData::read_from_buffered(bytes, true)
        .map_err(|e| format!("EXR header: {e}"))?;
    let header = meta.headers.first().ok_or("EXR has no layer")?;
    let expected = (key.width as usize, key.height as usize);
    if (header.layer_size.width(), header.layer_size.height()) != expected {
        return Err(format!(
            "entry is {}x{}, key says {}x{}",
            header.layer_size.width(),
            header.layer_size.height(),
            expected.0,
            expected.1
        ));
    }
    let decoded = std::panic::catch_unwind(|| image::decode_exr(bytes))
        .map_err(|_| "EXR decoder panicked".to_string())?
        .map_err(|e| format!("EXR: {e}"))?;
    match decoded.attributes.get(KEY_ATTRIBUTE) {
        Some(AttributeValue::Text(t)) if t.to_string() == key.canonical() => {}
        Some(AttributeValue::Text(t)) => return Err(format!("entry is for another key ({t})")),
        _ => return Err(format!("entry has no {KEY_ATTRIBUTE} attribute")),
    }
    let scalar = match decoded.attributes.get(STDERR_ATTRIBUTE) {
        Some(AttributeValue::F64(v)) => Some(*v),
        _ => None,
    };
    let views: Vec<(&str, &[f32])> = decoded
        .channels
        .iter()
        .map(|(n, s)| (n.as_str(), s.as_slice()))
        .collect();
    let expected_sum = format!("{:016x}", checksum(key, &views, scalar));
    match decoded.attributes.get(CHECKSUM_ATTRIBUTE) {
        Some(AttributeValue::Text(t)) if t.to_string() == expected_sum => {}
        Some(_) => return Err("checksum mismatch (damaged entry)".into()),
        None => return Err(format!("entry has no {CHECKSUM_ATTRIBUTE} attribute")),
    }
    let image = image::image_from_decoded(&decoded)
        .map_err(|names| format!("unrecognised channels {names:?}"))?;
    let se_planes: Vec<&str> = decoded
        .channels
        .iter()
        .filter_map(|(n, _)| n.strip_prefix(STDERR_PREFIX))
        .collect();
    let stderr = if se_planes.is_empty() {
        match decoded.attributes.get(STDERR_ATTRIBUTE) {
            Some(AttributeValue::F64(v)) => StdErr::Scalar(*v),
            _ => return Err("entry has no standard error".into()),
        }
    } else {
        let names = image::exr_channel_names(image.channels()).unwrap_or(&[]);
        let wanted: &[&str] = if se_planes == ["Y"] { &["Y"] } else { names };
        let planes: Option<Vec<&[f32]>> = wanted
            .iter()
            .map(|n| decoded.channel(&format!("{STDERR_PREFIX}{n}")))
            .collect();
        match planes {
            Some(planes) if planes.len() == se_planes.len() => {
                StdErr::Image(image::interleave(decoded.width, decoded.height, &planes))
            }
            _ => {
                return Err(format!(
                    "standard-error channels {se_planes:?} do not fit the image"
                ))
            }
        }
    };
    Ok(CachedReference { image, stderr })
}

/// Writes `bytes` to `path` via a uniquely named temporary file in the same directory, flushed to
/// disk before it is renamed over `path`, so readers see either the old entry or the new one.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), CacheError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| CacheError::Io { path, source }
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.subsec_nanos())
        .unwrap_or(0);
    let tmp = dir.join(format!(
        ".{name}.tmp.{}.{}.{nanos}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, path)
    })();
    if let Err(source) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(CacheError::Io {
            path: path.to_path_buf(),
            source,
        });
    }
    // Persist the rename itself where the platform allows opening a directory; best effort.
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key() -> ReferenceKey {
        ReferenceKey {
            scene: "cornell box".into(),
            frame: 3,
            width: 5,
            height: 4,
            spp: 65536,
            signal: "ao-r0.5".into(),
            version: 1,
        }
    }

    fn test_image(channels: usize) -> Image {
        let data = (0..5 * 4 * channels)
            .map(|i| (i as f32 * 0.37).sin().abs() + 1e-7 * i as f32)
            .collect();
        Image::new(5, 4, channels, data).unwrap()
    }

    fn bits(data: &[f32]) -> Vec<u32> {
        data.iter().map(|v| v.to_bits()).collect()
    }

    #[test]
    fn paths_are_sanitised_and_distinct() {
        let k = key();
        assert_eq!(
            k.relative_path(),
            PathBuf::from("cornell_box/ao-r0.5/f000003_5x4_65536spp_v1.exr")
        );
        let evil = ReferenceKey {
            scene: "../..".into(),
            signal: "".into(),
            ..key()
        };
        let p = evil.relative_path();
        assert!(
            p.components()
                .all(|c| matches!(c, std::path::Component::Normal(_))),
            "{p:?}"
        );
        let v2 = ReferenceKey {
            version: 2,
            ..key()
        };
        assert_ne!(k.relative_path(), v2.relative_path());
    }

    #[test]
    fn default_dir_honours_override() {
        // Only reads the environment; the override variable is unlikely to be set in tests, and
        // whichever branch applies, the result must end in the documented location.
        if let Some(d) = ReferenceCache::default_dir() {
            if std::env::var_os(ReferenceCache::ENV_VAR).is_none() {
                assert!(d.ends_with("vrrt/references"), "{d:?}");
            }
        }
    }

    #[test]
    fn miss_then_hit_scalar_stderr() {
        let dir = tempfile::tempdir().unwrap();
        let cache = ReferenceCache::new(dir.path().join("refs"));
        let k = key();
        assert_eq!(cache.lookup(&k), Lookup::Miss);
        assert_eq!(cache.load(&k), None);
        let img = test_image(1);
        let path = cache
            .store(&k, img.view(), &StdErr::Scalar(0.0123))
            .unwrap();
        assert_eq!(path, cache.path(&k));
        let hit = cache.load(&k).unwrap();
        assert_eq!(bits(hit.image.data()), bits(img.data()));
        assert_eq!(hit.image.channels(), 1);
        assert_eq!(hit.stderr, StdErr::Scalar(0.0123));
        // The entry is a plain EXR for other tools too.
        assert_eq!(image::read_exr(&path).unwrap().data(), img.data());
        // Other keys still miss.
        assert_eq!(cache.load(&ReferenceKey { frame: 4, ..key() }), None);
        // No temporary files are left behind.
        let leftovers: Vec<_> = std::fs::read_dir(path.parent().unwrap()).unwrap().collect();
        assert_eq!(leftovers.len(), 1);
    }

    #[test]
    fn hit_with_per_pixel_stderr_rgb() {
        let dir = tempfile::tempdir().unwrap();
        let cache = ReferenceCache::new(dir.path());
        let k = ReferenceKey {
            signal: "radiance".into(),
            ..key()
        };
        let img = test_image(3);
        for se in [test_image(3), test_image(1)] {
            cache
                .store(&k, img.view(), &StdErr::Image(se.clone()))
                .unwrap();
            let hit = cache.load(&k).unwrap();
            assert_eq!(bits(hit.image.data()), bits(img.data()));
            match hit.stderr {
                StdErr::Image(got) => {
                    assert_eq!(got.channels(), se.channels());
                    assert_eq!(bits(got.data()), bits(se.data()));
                }
                other => panic!("expected per-pixel stderr, got {other:?}"),
            }
        }
    }

    #[test]
    fn store_rejects_mismatches() {
        let dir = tempfile::tempdir().unwrap();
        let cache = ReferenceCache::new(dir.path());
        let wrong_size = Image::zeros(4, 4, 1);
        let e = cache
            .store(&key(), wrong_size.view(), &StdErr::Scalar(0.0))
            .unwrap_err();
        assert!(matches!(e, CacheError::Mismatch(_)), "{e}");
        let e = cache
            .store(
                &key(),
                test_image(3).view(),
                &StdErr::Image(Image::zeros(5, 4, 2)),
            )
            .unwrap_err();
        assert!(matches!(e, CacheError::Mismatch(_)), "{e}");
        assert!(matches!(
            cache.store(&key(), Image::zeros(5, 4, 2).view(), &StdErr::Scalar(0.0)),
            Err(CacheError::Mismatch(_))
        ));
        assert_eq!(cache.lookup(&key()), Lookup::Miss);
    }

    #[test]
    fn corrupt_entries_are_misses() {
        let dir = tempfile::tempdir().unwrap();
        let cache = ReferenceCache::new(dir.path());
        let k = key();
        let path = cache
            .store(&k, test_image(3).view(), &StdErr::Image(test_image(3)))
            .unwrap();
        let good = std::fs::read(&path).unwrap();

        // Truncated at many points, including inside the header and the pixel data.
        for len in [
            0,
            3,
            20,
            good.len() / 3,
            good.len() / 2,
            good.len() - 10,
            good.len() - 1,
        ] {
            std::fs::write(&path, &good[..len]).unwrap();
            assert!(
                matches!(cache.lookup(&k), Lookup::Corrupt(_)),
                "truncated to {len}"
            );
            assert_eq!(cache.load(&k), None);
        }
        // Garbage.
        std::fs::write(&path, b"not an exr at all, just text").unwrap();
        assert!(matches!(cache.lookup(&k), Lookup::Corrupt(_)));
        // Flipped bytes in the compressed pixel data.
        let mut flipped = good.clone();
        let n = flipped.len();
        for b in &mut flipped[n - 40..n - 20] {
            *b ^= 0x5a;
        }
        std::fs::write(&path, &flipped).unwrap();
        match cache.lookup(&k) {
            Lookup::Corrupt(_) => {}
            Lookup::Hit(r) => panic!("damaged entry read as a hit: {:?}", r.image.data().len()),
            Lookup::Miss => panic!("damaged entry read as absent"),
        }
        // A directory where the file should be.
        std::fs::remove_file(&path).unwrap();
        std::fs::create_dir(&path).unwrap();
        assert!(matches!(cache.lookup(&k), Lookup::Corrupt(_)));
        std::fs::remove_dir(&path).unwrap();

        // Storing again repairs the entry.
        cache
            .store(&k, test_image(3).view(), &StdErr::Scalar(1.0))
            .unwrap();
        assert!(cache.load(&k).is_some());
    }

    #[test]
    fn every_single_byte_flip_is_caught_or_harmless() {
        // Flip each byte of a stored entry in turn: the lookup must never panic and must never
        // return a hit whose contents differ from what was stored.
        let dir = tempfile::tempdir().unwrap();
        let cache = ReferenceCache::new(dir.path());
        let k = key();
        for stderr in [StdErr::Scalar(0.25), StdErr::Image(test_image(1))] {
            let img = test_image(3);
            let path = cache.store(&k, img.view(), &stderr).unwrap();
            let good = std::fs::read(&path).unwrap();
            let mut caught = 0;
            for i in 0..good.len() {
                let mut bad = good.clone();
                bad[i] ^= 0x10;
                std::fs::write(&path, &bad).unwrap();
                match cache.lookup(&k) {
                    Lookup::Hit(r) => {
                        assert_eq!(bits(r.image.data()), bits(img.data()), "byte {i}");
                        assert_eq!(r.stderr, stderr, "byte {i}");
                    }
                    Lookup::Corrupt(_) => caught += 1,
                    Lookup::Miss => panic!("byte {i}: miss"),
                }
            }
            assert!(caught > good.len() / 2, "{caught} of {}", good.len());
        }
    }

    #[test]
    fn entry_of_another_key_is_rejected() {
        // Two keys whose sanitised paths collide ("a b" vs "a_b") must not read each other.
        let dir = tempfile::tempdir().unwrap();
        let cache = ReferenceCache::new(dir.path());
        let a = ReferenceKey {
            scene: "a b".into(),
            ..key()
        };
        let b = ReferenceKey {
            scene: "a_b".into(),
            ..key()
        };
        assert_eq!(cache.path(&a), cache.path(&b));
        cache
            .store(&a, test_image(1).view(), &StdErr::Scalar(0.5))
            .unwrap();
        assert!(cache.load(&a).is_some());
        assert!(matches!(cache.lookup(&b), Lookup::Corrupt(m) if m.contains("another key")));
    }

    #[test]
    fn plain_exr_without_key_is_rejected() {
        let dir = tempfile::tempdir().unwrap();
        let cache = ReferenceCache::new(dir.path());
        let k = key();
        let path = cache.path(&k);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        image::write_exr(&path, test_image(1).view()).unwrap();
        assert!(matches!(cache.lookup(&k), Lookup::Corrupt(m) if m.contains(KEY_ATTRIBUTE)));
    }

    #[test]
    fn store_into_unwritable_location_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let blocker = dir.path().join("file");
        std::fs::write(&blocker, b"x").unwrap();
        let cache = ReferenceCache::new(blocker.join("below"));
        let e = cache
            .store(&key(), test_image(1).view(), &StdErr::Scalar(0.0))
            .unwrap_err();
        assert!(matches!(e, CacheError::Io { .. }), "{e}");
    }
}
