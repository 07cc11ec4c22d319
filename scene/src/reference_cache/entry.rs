//! One cache entry as bytes: a single-part EXR holding the image, its standard error, the full
//! key and a checksum.
//!
//! - the image as `Y` or `R,G,B(,A)` linear `f32` channels (readable by any EXR viewer and by
//!   [`crate::image::read_exr`]);
//! - its Monte Carlo standard error ([`StdErr`]) either per pixel as `stderr.Y` / `stderr.R,...`
//!   channels or as one number in the `vrrtStdErr` header attribute;
//! - the full key in the `vrrtKey` attribute, checked on load, so an entry of another key (a
//!   foreign file, or a hash-prefix collision of file names) is never used;
//! - a BLAKE3 checksum of key, channels and scalar standard error in `vrrtChecksum`, since EXR
//!   itself has no content checksum and a flipped bit must not pass as a valid reference.

use exr::prelude::AttributeValue;

use super::{CachedReference, ReferenceKey, StdErr};
use crate::image::{self, ImageRef};

pub(super) const KEY_ATTRIBUTE: &str = "vrrtKey";
const STDERR_ATTRIBUTE: &str = "vrrtStdErr";
const STDERR_PREFIX: &str = "stderr.";
const CHECKSUM_ATTRIBUTE: &str = "vrrtChecksum";

/// BLAKE3 (hex) over the key, every channel (sorted by name: name, then sample bits) and the
/// scalar standard error if any.
fn checksum(key: &ReferenceKey, channels: &[(&str, &[f32])], scalar: Option<f64>) -> String {
    let mut h = blake3::Hasher::new();
    h.update(key.canonical().as_bytes());
    let mut sorted: Vec<&(&str, &[f32])> = channels.iter().collect();
    sorted.sort_by_key(|(name, _)| *name);
    for (name, samples) in sorted {
        h.update(name.as_bytes());
        h.update(&[0]);
        for v in samples.iter() {
            h.update(&v.to_bits().to_le_bytes());
        }
    }
    if let Some(v) = scalar {
        h.update(&v.to_bits().to_le_bytes());
    }
    h.finalize().to_hex().to_string()
}

/// Why an entry could not be encoded.
pub(super) enum EncodeError {
    Mismatch(String),
    Exr(String),
}

/// The entry of `image` with `stderr` under `key`.
pub(super) fn encode_entry(
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
    attributes.push((CHECKSUM_ATTRIBUTE, text_attribute(&sum)));
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

/// The reference in `bytes` if they are a valid entry of `key`, else why not.
pub(super) fn decode_entry(key: &ReferenceKey, bytes: &[u8]) -> Result<CachedReference, String> {
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
    let expected_sum = checksum(key, &views, scalar);
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
