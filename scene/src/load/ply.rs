//! Stanford PLY (ascii, binary little endian and binary big endian), read with the `serde-ply`
//! crate. The header is read and held to the limits first; then the rows of `vertex` (`x y z`,
//! optional `nx ny nz`) and `face` (`vertex_indices` or `vertex_index` list, polygons
//! fan-triangulated) are streamed into the mesh, and every other element is read for its size
//! and skipped.

use super::{Limit, LoadLimits};
use crate::error::SceneError;
use crate::mesh::Mesh;
use serde::de::{DeserializeSeed, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;
use serde_ply::{DeserializeError, ElementDef, PlyFormat, PlyReader, PropertyType};
use std::fmt;
use std::io::{BufRead, BufReader, ErrorKind, Read};
use std::path::Path;
use vrrt_core::glam::Vec3;

/// Most corners of one face; a longer list is taken for a damaged file (and is refused before
/// its corners are read).
const MAX_CORNERS: usize = 1_000_000;

/// What is done with the rows of one element.
#[derive(Copy, Clone)]
enum Rows {
    /// Read for their size and dropped; `empty` when they have no properties (no bytes).
    Skip { empty: bool },
    /// Positions, and normals when the element has all of `nx ny nz`.
    Vertices { normals: bool },
    /// Polygons from the list property at this index.
    Faces { list: usize },
}

/// Parses a PLY file. The declared vertex and face counts are held to the limits before the
/// body is read (a face makes at least one triangle), the triangles again as polygons split.
pub fn parse(path: &Path, bytes: &[u8], limits: &LoadLimits) -> Result<Mesh, SceneError> {
    parse_stream(path, bytes, limits, bytes.len() as u64)
}

/// Longest PLY header read before its `end_header`.
const MAX_HEADER: u64 = 1 << 20;

/// Allocation made ahead of the rows read: a header may declare more rows than the stream
/// holds, so larger lists grow as their rows arrive.
const RESERVE_AHEAD: usize = 1 << 20;

/// [`parse`] from a stream of at most `size_bound` bytes, read once into the mesh's arrays (no
/// copy of the file is held, so a gzipped file costs its mesh, not its inflated size).
pub fn parse_stream(
    path: &Path,
    input: impl Read,
    limits: &LoadLimits,
    size_bound: u64,
) -> Result<Mesh, SceneError> {
    let mut input = BufReader::new(input);
    let head = read_header(path, limits, &mut input)?;
    // serde-ply's ascii reader needs whitespace after the last value, which a file may lack: an
    // ascii body gets a final newline (a binary one must not, or a truncated file could pass).
    let format = PlyReader::from_reader(&head[..])
        .map_err(|e| header_error(path, e))?
        .header()
        .format;
    let tail: &[u8] = if format == PlyFormat::Ascii {
        b"\n"
    } else {
        b""
    };
    let mut reader = PlyReader::from_reader(head.as_slice().chain(input).chain(tail))
        .map_err(|e| header_error(path, e))?;
    let plan = plan(path, &reader.header().elem_defs, limits)?;
    // x, y and z take at least a byte each.
    let vertex_bound = usize::try_from(size_bound / 3).unwrap_or(usize::MAX);
    let mut sink = Sink {
        path,
        limits,
        positions: Vec::new(),
        normals: Vec::new(),
        indices: Vec::new(),
        polygon: Vec::new(),
        error: None,
    };
    for (el, rows) in reader.header().elem_defs.iter().zip(&plan) {
        if let Rows::Vertices { normals } = rows {
            let cap = el.count.min(vertex_bound).min(RESERVE_AHEAD);
            sink.positions.reserve(cap);
            if *normals {
                sink.normals.reserve(cap);
            }
        }
    }
    let read = (&mut reader).deserialize_map(Elements {
        sink: &mut sink,
        plan: &plan,
    });
    if let Some(e) = sink.error.take() {
        return Err(e);
    }
    read.map_err(|e| body_error(path, limits, e))?;
    Mesh::new(path, sink.positions, sink.normals, sink.indices)
}

/// The header's bytes through `end_header` and its line break (a byte-order mark before it
/// dropped), at most [`MAX_HEADER`].
fn read_header(
    path: &Path,
    limits: &LoadLimits,
    input: &mut impl BufRead,
) -> Result<Vec<u8>, SceneError> {
    let mut head = Vec::new();
    loop {
        let start = head.len();
        let n = input
            .take(MAX_HEADER + 1 - start as u64)
            .read_until(b'\n', &mut head)
            .map_err(|e| super::read_error(path, false, limits, e))?;
        if n == 0 || head.len() as u64 > MAX_HEADER {
            return Err(SceneError::parse(path, "header has no `end_header`"));
        }
        if start == 0 && head.starts_with(super::BOM) {
            head.drain(..super::BOM.len());
        }
        if head[start..].trim_ascii() == b"end_header" {
            return Ok(head);
        }
    }
}

/// Checks the header's elements (counts against the limits, the properties a mesh needs) and
/// says what to do with each.
fn plan(
    path: &Path,
    elements: &[ElementDef],
    limits: &LoadLimits,
) -> Result<Vec<Rows>, SceneError> {
    let mut plan = Vec::with_capacity(elements.len());
    for el in elements {
        let scalar = |name: &str| {
            el.properties
                .iter()
                .any(|p| p.name == name && matches!(p.property_type, PropertyType::Scalar(_)))
        };
        plan.push(match el.name.as_str() {
            "vertex" => {
                limits.check(path, Limit::Vertices, el.count as u64)?;
                if !["x", "y", "z"].into_iter().all(scalar) {
                    return Err(SceneError::parse(path, "vertex element lacks x, y or z"));
                }
                Rows::Vertices {
                    normals: ["nx", "ny", "nz"].into_iter().all(scalar),
                }
            }
            "face" => {
                limits.check(path, Limit::Triangles, el.count as u64)?;
                let list = el.properties.iter().position(|p| {
                    matches!(p.property_type, PropertyType::List { .. })
                        && (p.name == "vertex_indices" || p.name == "vertex_index")
                });
                let Some(list) = list else {
                    return Err(SceneError::parse(
                        path,
                        "face element lacks a vertex_indices list",
                    ));
                };
                Rows::Faces { list }
            }
            _ => Rows::Skip {
                empty: el.properties.is_empty(),
            },
        });
    }
    if !plan.iter().any(|r| matches!(r, Rows::Vertices { .. })) {
        return Err(SceneError::parse(path, "no vertex element"));
    }
    Ok(plan)
}

fn header_error(path: &Path, e: DeserializeError) -> SceneError {
    if e.0.kind() == ErrorKind::UnexpectedEof {
        SceneError::parse(path, "header has no `end_header`")
    } else {
        SceneError::parse(path, format!("bad header: {}", e.0))
    }
}

fn body_error(path: &Path, limits: &LoadLimits, e: DeserializeError) -> SceneError {
    // A cap of the stream (file or inflated size) hit while the rows were read.
    if let Some(limit) = super::limit_hit(&e.0) {
        return limits.exceeded(path, limit, None);
    }
    if e.0.kind() == ErrorKind::UnexpectedEof {
        SceneError::parse(
            path,
            "file is truncated (fewer values than the header declares)",
        )
    } else {
        SceneError::parse(path, e.0.to_string())
    }
}

/// The mesh being read. A check of ours that fails inside the deserializer leaves its error
/// here (serde errors carry only text) and stops the read.
struct Sink<'a> {
    path: &'a Path,
    limits: &'a LoadLimits,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
    /// The face being read.
    polygon: Vec<u32>,
    error: Option<SceneError>,
}

impl Sink<'_> {
    /// Keeps `e` and returns the error that stops the deserializer.
    fn fail<E: serde::de::Error>(&mut self, e: SceneError) -> E {
        let text = e.to_string();
        self.error = Some(e);
        E::custom(text)
    }
}

/// One vertex row; properties other than these are skipped, absent normals read as zero.
#[derive(Default, Deserialize)]
#[serde(default)]
struct Vertex {
    x: f32,
    y: f32,
    z: f32,
    nx: f32,
    ny: f32,
    nz: f32,
}

/// A row of an element that is not kept: every value read and dropped.
#[derive(Deserialize)]
struct Skip {}

/// The file as a map of element name to rows, in header order.
struct Elements<'s, 'a> {
    sink: &'s mut Sink<'a>,
    plan: &'s [Rows],
}

impl<'de> Visitor<'de> for Elements<'_, '_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("PLY elements")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        for &rows in self.plan {
            if map.next_key::<IgnoredAny>()?.is_none() {
                break;
            }
            map.next_value_seed(Element {
                sink: &mut *self.sink,
                rows,
            })?;
        }
        Ok(())
    }
}

/// The rows of one element.
struct Element<'s, 'a> {
    sink: &'s mut Sink<'a>,
    rows: Rows,
}

impl<'de> DeserializeSeed<'de> for Element<'_, '_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for Element<'_, '_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("PLY rows")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut rows: A) -> Result<(), A::Error> {
        let sink = self.sink;
        match self.rows {
            // Rows of no bytes: nothing to read, however many are declared.
            Rows::Skip { empty: true } => {}
            Rows::Skip { empty: false } => while rows.next_element::<Skip>()?.is_some() {},
            Rows::Vertices { normals } => {
                while let Some(v) = rows.next_element::<Vertex>()? {
                    sink.positions.push(Vec3::new(v.x, v.y, v.z));
                    if normals {
                        sink.normals.push(Vec3::new(v.nx, v.ny, v.nz));
                    }
                }
            }
            Rows::Faces { list } => {
                let mut item = 0usize;
                while rows
                    .next_element_seed(FaceRow {
                        sink: &mut *sink,
                        list,
                        item,
                    })?
                    .is_some()
                {
                    let polygon = &sink.polygon;
                    if polygon.len() < 3 {
                        let e = SceneError::parse(
                            sink.path,
                            format!(
                                "face {item} has {} vertices (at least 3 needed)",
                                polygon.len()
                            ),
                        );
                        return Err(sink.fail(e));
                    }
                    let triangles = sink.indices.len() + polygon.len() - 2;
                    if let Err(e) = sink
                        .limits
                        .check(sink.path, Limit::Triangles, triangles as u64)
                    {
                        return Err(sink.fail(e));
                    }
                    for i in 1..polygon.len() - 1 {
                        sink.indices.push([polygon[0], polygon[i], polygon[i + 1]]);
                    }
                    item += 1;
                }
            }
        }
        Ok(())
    }
}

/// A face row: its corner list read into [`Sink::polygon`], other properties dropped.
struct FaceRow<'s, 'a> {
    sink: &'s mut Sink<'a>,
    list: usize,
    item: usize,
}

impl<'de> DeserializeSeed<'de> for FaceRow<'_, '_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for FaceRow<'_, '_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a PLY face")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let mut k = 0;
        while map.next_key::<IgnoredAny>()?.is_some() {
            if k == self.list {
                map.next_value_seed(Corners {
                    sink: &mut *self.sink,
                    item: self.item,
                })?;
            } else {
                map.next_value::<IgnoredAny>()?;
            }
            k += 1;
        }
        Ok(())
    }
}

/// The vertex indices of face `item`, checked to be whole numbers in `u32` range.
struct Corners<'s, 'a> {
    sink: &'s mut Sink<'a>,
    item: usize,
}

impl<'de> DeserializeSeed<'de> for Corners<'_, '_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for Corners<'_, '_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a list of vertex indices")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let (sink, item) = (self.sink, self.item);
        // The list's declared length, known before its corners are read.
        let n = seq.size_hint().unwrap_or(0);
        if n > MAX_CORNERS {
            let e = SceneError::parse(sink.path, format!("face {item}: invalid list length {n}"));
            return Err(sink.fail(e));
        }
        sink.polygon.clear();
        // As f64, which every PLY type converts to exactly, so float lists of whole numbers
        // are taken too.
        while let Some(v) = seq.next_element::<f64>()? {
            if !(0.0..u32::MAX as f64).contains(&v) || v.fract() != 0.0 {
                let e =
                    SceneError::parse(sink.path, format!("face {item}: invalid vertex index {v}"));
                return Err(sink.fail(e));
            }
            sink.polygon.push(v as u32);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASCII: &str = "ply\nformat ascii 1.0\ncomment tri\nelement vertex 4\nproperty float x\n\
        property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n\
        end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";

    fn binary(big: bool) -> Vec<u8> {
        let mut v = format!(
            "ply\nformat {} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
             property uchar red\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n",
            if big { "binary_big_endian" } else { "binary_little_endian" }
        )
        .into_bytes();
        let f = |v: &mut Vec<u8>, x: f32| {
            v.extend(if big {
                x.to_be_bytes()
            } else {
                x.to_le_bytes()
            })
        };
        for p in [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            for c in p {
                f(&mut v, c);
            }
            v.push(255);
        }
        v.push(3);
        for i in [0u32, 1, 2] {
            v.extend(if big {
                i.to_be_bytes()
            } else {
                i.to_le_bytes()
            });
        }
        v
    }

    fn parse_str(text: &str) -> Result<Mesh, SceneError> {
        parse(Path::new("q.ply"), text.as_bytes(), &LoadLimits::default())
    }

    #[test]
    fn ascii_quad() {
        let m = parse_str(ASCII).unwrap();
        assert_eq!(m.triangle_count(), 2);
        assert_eq!(m.positions.len(), 4);
        // Values are whitespace-separated tokens: line breaks may fall anywhere, and the last
        // value needs none after it.
        let m = parse_str(&ASCII.replace("0 1 0\n4 0 1 2 3\n", "0\n1 0 4 0 1\n2 3")).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn binary_both_endians() {
        for big in [false, true] {
            let m = parse(Path::new("t.ply"), &binary(big), &LoadLimits::default()).unwrap();
            assert_eq!(m.indices, vec![[0, 1, 2]]);
            assert_eq!(m.positions[1], Vec3::X);
        }
    }

    #[test]
    fn normals_other_elements_and_property_types() {
        // Double coordinates with normals, an element before the vertices with a list of its
        // own, and a face with extra properties around a ushort list.
        let text = "ply\nformat ascii 1.0\nelement material 2\nproperty list uchar float rgb\n\
            property int id\nelement vertex 3\nproperty double x\nproperty double y\n\
            property double z\nproperty float nx\nproperty float ny\nproperty float nz\n\
            element face 1\nproperty int flags\nproperty list uchar ushort vertex_index\n\
            property uchar tag\nend_header\n3 0.5 0.5 0.5 7\n0 9\n0 0 0 0 0 2\n1 0 0 0 0 2\n\
            0 1 0 0 0 2\n-1 3 0 1 2 255\n";
        let m = parse_str(text).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2]]);
        assert_eq!(m.normals, vec![Vec3::Z; 3]);
    }

    #[test]
    fn truncated_and_bad_index() {
        let b = binary(false);
        for cut in [1, 2, 13] {
            let e = parse(
                Path::new("t.ply"),
                &b[..b.len() - cut],
                &LoadLimits::default(),
            )
            .unwrap_err()
            .to_string();
            assert!(e.contains("t.ply") && e.contains("truncated"), "{e}");
        }
        let bad = ASCII.replace("4 0 1 2 3", "3 0 1 9");
        let e = parse_str(&bad).unwrap_err().to_string();
        assert!(e.contains("only 4 vertices"), "{e}");
        for (corners, expected) in [
            ("3 0 1 -1", "face 0: invalid vertex index -1"),
            ("2 0 1", "face 0 has 2 vertices"),
        ] {
            let e = parse_str(&ASCII.replace("4 0 1 2 3", corners)).unwrap_err();
            assert!(e.to_string().contains(expected), "{e}");
        }
        let e = parse_str("ply\nformat ascii 1.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("end_header"), "{e}");
        let e = parse_str(&ASCII.replace("property float z\n", ""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("lacks x, y or z"), "{e}");
    }

    #[test]
    fn declared_counts_are_limited_before_the_body() {
        // A header declaring a billion vertices and no body: refused by the limit, not by
        // truncation after reading.
        let huge = "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\n\
            property float x\nproperty float y\nproperty float z\nend_header\n";
        let e = parse_str(huge).unwrap_err();
        assert!(
            matches!(
                e,
                SceneError::LimitExceeded {
                    limit: Limit::Vertices,
                    value: Some(1_000_000_000),
                    ..
                }
            ),
            "{e}"
        );
        let limits = LoadLimits {
            max_triangles: 1,
            ..LoadLimits::default()
        };
        let e = parse(Path::new("q.ply"), ASCII.as_bytes(), &limits).unwrap_err();
        assert!(
            matches!(
                e,
                SceneError::LimitExceeded {
                    limit: Limit::Triangles,
                    value: Some(2),
                    ..
                }
            ),
            "{e}"
        );
        // Elements without properties take no bytes; a huge count must not loop.
        let empty = ASCII.replace(
            "end_header",
            "element dummy 18446744073709551615\nend_header",
        );
        assert_eq!(parse_str(&empty).unwrap().triangle_count(), 2);
        let first = ASCII.replace(
            "element vertex",
            "element dummy 18446744073709551615\nelement vertex",
        );
        assert_eq!(parse_str(&first).unwrap().triangle_count(), 2);
        // A face list declaring more corners than any face has is refused before it is read.
        let b = binary(false);
        let body = b.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let mut long = String::from_utf8(b[..body].to_vec())
            .unwrap()
            .replace("list uchar uint", "list uint uint")
            .into_bytes();
        long.extend(&b[body..b.len() - 13]);
        long.extend(u32::MAX.to_le_bytes());
        let e = parse(Path::new("t.ply"), &long, &LoadLimits::default()).unwrap_err();
        assert!(e.to_string().contains("invalid list length"), "{e}");
    }
}
