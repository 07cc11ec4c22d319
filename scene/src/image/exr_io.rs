//! Lossless linear `f32` EXR IO: the public [`write_exr`] / [`read_exr`] and the crate-internal
//! encoder and strict decoder with named channels and header attributes, which the reference
//! cache builds its files on.

use super::{interleave, io_error, plane, write_file, Image, ImageError, ImageRef};
use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Layer, LayerAttributes,
    ReadChannels, ReadLayers, SmallVec, Text, WritableImage,
};

/// EXR channel names for an interleaved image: Y for one channel, R,G,B(,A) for three (four).
pub(crate) fn exr_channel_names(channels: usize) -> Option<&'static [&'static str]> {
    match channels {
        1 => Some(&["Y"]),
        3 => Some(&["R", "G", "B"]),
        4 => Some(&["R", "G", "B", "A"]),
        _ => None,
    }
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
