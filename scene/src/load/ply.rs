//! Stanford PLY: ascii, binary little endian and binary big endian. Reads `vertex` (`x y z`, optional
//! `nx ny nz`) and `face` (`vertex_indices` or `vertex_index` list, polygons fan-triangulated); every
//! other element and property is parsed for its size and skipped.

use super::{Limit, LoadLimits};
use crate::error::SceneError;
use crate::mesh::Mesh;
use std::path::Path;
use vrrt_core::glam::Vec3;

#[derive(Copy, Clone, Debug, PartialEq)]
enum Encoding {
    Ascii,
    LittleEndian,
    BigEndian,
}

#[derive(Copy, Clone, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Clone, Debug)]
enum Property {
    Scalar(Scalar, String),
    List {
        count: Scalar,
        item: Scalar,
        name: String,
    },
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

/// Reads values in file order, whatever the encoding.
struct Reader<'a> {
    path: &'a Path,
    encoding: Encoding,
    data: &'a [u8],
    pos: usize,
    /// Ascii: tokens of the body.
    tokens: std::str::SplitAsciiWhitespace<'a>,
}

impl<'a> Reader<'a> {
    fn truncated(&self) -> SceneError {
        SceneError::parse(
            self.path,
            "file is truncated (fewer values than the header declares)",
        )
    }

    fn read(&mut self, s: Scalar) -> Result<f64, SceneError> {
        if self.encoding == Encoding::Ascii {
            let tok = self.tokens.next().ok_or_else(|| self.truncated())?;
            return tok
                .parse::<f64>()
                .map_err(|_| SceneError::parse(self.path, format!("`{tok}` is not a number")));
        }
        let n = s.size();
        let bytes = self
            .data
            .get(self.pos..self.pos + n)
            .ok_or_else(|| self.truncated())?;
        self.pos += n;
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(bytes);
        if self.encoding == Encoding::BigEndian {
            b[..n].reverse();
        }
        Ok(match s {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(b),
        })
    }

    /// Bytes left (binary) or a generous bound (ascii), to cap allocations by declared counts.
    fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }
}

/// Parses a PLY file. The declared vertex and face counts are held to the limits before the
/// body is read (a face makes at least one triangle), the triangles again as polygons split.
pub fn parse(path: &Path, bytes: &[u8], limits: &LoadLimits) -> Result<Mesh, SceneError> {
    let (encoding, elements, body) = parse_header(path, bytes)?;
    for el in &elements {
        match el.name.as_str() {
            "vertex" => limits.check(path, Limit::Vertices, el.count as u64)?,
            "face" => limits.check(path, Limit::Triangles, el.count as u64)?,
            _ => {}
        }
    }
    let body_text = if encoding == Encoding::Ascii {
        std::str::from_utf8(&bytes[body..])
            .map_err(|_| SceneError::parse(path, "ascii body is not text"))?
    } else {
        ""
    };
    let mut r = Reader {
        path,
        encoding,
        data: bytes,
        pos: body,
        tokens: body_text.split_ascii_whitespace(),
    };
    let mut positions: Vec<Vec3> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut indices: Vec<[u32; 3]> = Vec::new();
    let mut saw_vertex = false;
    for el in &elements {
        // Every element takes at least one byte per item (binary) or two (ascii): cap capacity.
        let cap = el.count.min(r.remaining());
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        let prop_index = |name: &str| {
            el.properties
                .iter()
                .position(|p| matches!(p, Property::Scalar(_, n) if n == name))
        };
        let xyz = [prop_index("x"), prop_index("y"), prop_index("z")];
        let nxyz = [prop_index("nx"), prop_index("ny"), prop_index("nz")];
        let has_normals = nxyz.iter().all(Option::is_some);
        if is_vertex {
            if xyz.iter().any(Option::is_none) {
                return Err(SceneError::parse(path, "vertex element lacks x, y or z"));
            }
            saw_vertex = true;
            positions.reserve(cap);
            if has_normals {
                normals.reserve(cap);
            }
        }
        let face_list = el.properties.iter().position(
            |p| matches!(p, Property::List { name, .. } if name == "vertex_indices" || name == "vertex_index"),
        );
        if is_face && face_list.is_none() {
            return Err(SceneError::parse(
                path,
                "face element lacks a vertex_indices list",
            ));
        }
        if el.properties.is_empty() {
            // Items of no bytes: nothing to read, however many are declared.
            continue;
        }
        let mut values = vec![0.0f64; el.properties.len()];
        let mut polygon: Vec<u32> = Vec::new();
        for item in 0..el.count {
            for (k, prop) in el.properties.iter().enumerate() {
                match prop {
                    Property::Scalar(s, _) => values[k] = r.read(*s)?,
                    Property::List {
                        count,
                        item: item_ty,
                        ..
                    } => {
                        let n = r.read(*count)?;
                        if !(0.0..=1e6).contains(&n) || n.fract() != 0.0 {
                            return Err(SceneError::parse(
                                path,
                                format!("{} {item}: invalid list length {n}", el.name),
                            ));
                        }
                        let keep = is_face && Some(k) == face_list;
                        if keep {
                            polygon.clear();
                        }
                        for _ in 0..n as usize {
                            let v = r.read(*item_ty)?;
                            if keep {
                                if !(0.0..u32::MAX as f64).contains(&v) || v.fract() != 0.0 {
                                    return Err(SceneError::parse(
                                        path,
                                        format!("face {item}: invalid vertex index {v}"),
                                    ));
                                }
                                polygon.push(v as u32);
                            }
                        }
                    }
                }
            }
            if is_vertex {
                let at = |i: Option<usize>| values[i.unwrap_or(0)] as f32;
                positions.push(Vec3::new(at(xyz[0]), at(xyz[1]), at(xyz[2])));
                if has_normals {
                    normals.push(Vec3::new(at(nxyz[0]), at(nxyz[1]), at(nxyz[2])));
                }
            }
            if is_face {
                if polygon.len() < 3 {
                    return Err(SceneError::parse(
                        path,
                        format!(
                            "face {item} has {} vertices (at least 3 needed)",
                            polygon.len()
                        ),
                    ));
                }
                let triangles = indices.len() + polygon.len() - 2;
                limits.check(path, Limit::Triangles, triangles as u64)?;
                for i in 1..polygon.len() - 1 {
                    indices.push([polygon[0], polygon[i], polygon[i + 1]]);
                }
            }
        }
    }
    if !saw_vertex {
        return Err(SceneError::parse(path, "no vertex element"));
    }
    Mesh::new(path, positions, normals, indices)
}

/// Returns the encoding, the elements and the byte offset of the body.
fn parse_header(path: &Path, bytes: &[u8]) -> Result<(Encoding, Vec<Element>, usize), SceneError> {
    if !bytes.starts_with(b"ply") {
        return Err(SceneError::parse(
            path,
            "not a PLY file (missing `ply` magic)",
        ));
    }
    let mut pos = 0usize;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut line_no = 0usize;
    loop {
        let rest = &bytes[pos..];
        let Some(len) = rest.iter().position(|&b| b == b'\n') else {
            return Err(SceneError::parse(path, "header has no `end_header`"));
        };
        line_no += 1;
        let line = std::str::from_utf8(&rest[..len])
            .map_err(|_| SceneError::parse_at(path, line_no, "header line is not text"))?
            .trim();
        pos += len + 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["ply"] | [] => {}
            ["comment", ..] | ["obj_info", ..] => {}
            ["format", fmt, _version] => {
                encoding = Some(match *fmt {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::LittleEndian,
                    "binary_big_endian" => Encoding::BigEndian,
                    other => {
                        return Err(SceneError::parse_at(
                            path,
                            line_no,
                            format!("unknown format `{other}`"),
                        ))
                    }
                })
            }
            ["element", name, count] => {
                let count = count.parse().map_err(|_| {
                    SceneError::parse_at(path, line_no, format!("bad element count `{count}`"))
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            ["property", "list", count, item, name] => {
                let (Some(count), Some(item)) = (Scalar::parse(count), Scalar::parse(item)) else {
                    return Err(SceneError::parse_at(
                        path,
                        line_no,
                        "unknown list property type",
                    ));
                };
                if matches!(count, Scalar::F32 | Scalar::F64) {
                    return Err(SceneError::parse_at(
                        path,
                        line_no,
                        "list count must be an integer type",
                    ));
                }
                let el = elements.last_mut().ok_or_else(|| {
                    SceneError::parse_at(path, line_no, "property before any element")
                })?;
                el.properties.push(Property::List {
                    count,
                    item,
                    name: name.to_string(),
                });
            }
            ["property", ty, name] => {
                let ty = Scalar::parse(ty).ok_or_else(|| {
                    SceneError::parse_at(path, line_no, format!("unknown property type `{ty}`"))
                })?;
                let el = elements.last_mut().ok_or_else(|| {
                    SceneError::parse_at(path, line_no, "property before any element")
                })?;
                el.properties.push(Property::Scalar(ty, name.to_string()));
            }
            ["end_header"] => break,
            ["element" | "property" | "format", ..] => {
                return Err(SceneError::parse_at(
                    path,
                    line_no,
                    format!("malformed header line `{line}`"),
                ))
            }
            // Some exporters write free text without `comment` (Blender 2.4x): skip it.
            _ => {}
        }
    }
    let encoding =
        encoding.ok_or_else(|| SceneError::parse(path, "header has no `format` line"))?;
    Ok((encoding, elements, pos))
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

    #[test]
    fn ascii_quad() {
        let m = parse(Path::new("q.ply"), ASCII.as_bytes(), &LoadLimits::default()).unwrap();
        assert_eq!(m.triangle_count(), 2);
        assert_eq!(m.positions.len(), 4);
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
    fn truncated_and_bad_index() {
        let b = binary(false);
        let e = parse(
            Path::new("t.ply"),
            &b[..b.len() - 2],
            &LoadLimits::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("t.ply") && e.contains("truncated"), "{e}");
        let bad = ASCII.replace("4 0 1 2 3", "3 0 1 9");
        let e = parse(Path::new("q.ply"), bad.as_bytes(), &LoadLimits::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("only 4 vertices"), "{e}");
        let e = parse(
            Path::new("q.ply"),
            b"ply\nformat ascii 1.0\n",
            &LoadLimits::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("end_header"), "{e}");
    }

    #[test]
    fn declared_counts_are_limited_before_the_body() {
        // A header declaring a billion vertices and no body: refused by the limit, not by
        // truncation after reading.
        let huge = "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\n\
            property float x\nproperty float y\nproperty float z\nend_header\n";
        let e = parse(Path::new("h.ply"), huge.as_bytes(), &LoadLimits::default()).unwrap_err();
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
        assert!(e.to_string().contains("--max-triangles"), "{e}");
        // Elements without properties take no bytes; a huge count must not loop.
        let empty = ASCII.replace(
            "end_header",
            "element dummy 18446744073709551615\nend_header",
        );
        let m = parse(Path::new("q.ply"), empty.as_bytes(), &LoadLimits::default()).unwrap();
        assert_eq!(m.triangle_count(), 2);
    }
}
