//! Wavefront OBJ: `v`, `vn` and `f` (with `v`, `v/vt`, `v/vt/vn`, `v//vn` corners, negative
//! relative indices, polygons fan-triangulated). Everything else (`vt`, groups, materials, lines,
//! points) is ignored. A vertex is a distinct `(position, normal)` pair.
//!
//! Written by hand rather than with `tobj`: tobj 4.0.5 panics (integer overflow, debug builds)
//! on an out-of-range relative normal or texture index such as `f 1//-5` and returns wrong
//! normals for huge ones in release builds, makes triangles of `l` polylines, and peaks at more
//! heap before any conversion than this parser does in all, at about the same speed (see
//! `docs/reliability.md`). It also keeps no line numbers for errors.

use super::{Limit, LoadLimits};
use crate::error::SceneError;
use crate::mesh::{smooth_normals, Mesh};
use std::collections::HashMap;
use std::path::Path;
use vrrt_core::glam::Vec3;

/// No normal given for a corner.
const NONE: u32 = u32::MAX;

/// Parses OBJ text; the vertex and triangle limits are checked as the lists grow.
pub fn parse(path: &Path, bytes: &[u8], limits: &LoadLimits) -> Result<Mesh, SceneError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        SceneError::parse(path, format!("not UTF-8 text (byte {})", e.valid_up_to()))
    })?;
    // A byte-order mark would otherwise glue itself to the first keyword (`\u{feff}v`), which
    // is then skipped as unknown and every later index shifts.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut positions: Vec<Vec3> = Vec::new();
    let mut file_normals: Vec<Vec3> = Vec::new();
    // Corners as (position index, normal index or NONE).
    let mut corners: Vec<[(u32, u32); 3]> = Vec::new();
    let mut polygon: Vec<(u32, u32)> = Vec::new();
    for (line_no, raw) in text.lines().enumerate() {
        let line_no = line_no + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            "v" => {
                limits.check(path, Limit::Vertices, positions.len() as u64 + 1)?;
                positions.push(parse_vec3(path, line_no, &mut words)?);
            }
            "vn" => file_normals.push(parse_vec3(path, line_no, &mut words)?),
            "f" => {
                polygon.clear();
                for word in words {
                    polygon.push(parse_corner(
                        path,
                        line_no,
                        word,
                        positions.len(),
                        file_normals.len(),
                    )?);
                }
                if polygon.len() < 3 {
                    return Err(SceneError::parse_at(
                        path,
                        line_no,
                        format!("face with {} corners (at least 3 needed)", polygon.len()),
                    ));
                }
                let triangles = corners.len() + polygon.len() - 2;
                limits.check(path, Limit::Triangles, triangles as u64)?;
                for i in 1..polygon.len() - 1 {
                    corners.push([polygon[0], polygon[i], polygon[i + 1]]);
                }
            }
            _ => {}
        }
    }
    if corners.is_empty() {
        return Err(SceneError::NoTriangles {
            path: path.to_path_buf(),
        });
    }
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(SceneError::geometry(
            path,
            format!("vertex {} is not finite", i + 1),
        ));
    }
    // Normals for corners without one: smooth normals over the position indices.
    let position_tris: Vec<[u32; 3]> = corners.iter().map(|c| c.map(|(p, _)| p)).collect();
    let smooth = smooth_normals(&positions, &position_tris);
    let mut map: HashMap<(u32, u32), u32> = HashMap::new();
    let mut out_pos = Vec::new();
    let mut out_nrm = Vec::new();
    let mut indices = Vec::with_capacity(corners.len());
    for tri in &corners {
        let mut t = [0u32; 3];
        for (k, &(p, n)) in tri.iter().enumerate() {
            t[k] = *map.entry((p, n)).or_insert_with(|| {
                out_pos.push(positions[p as usize]);
                out_nrm.push(if n == NONE {
                    smooth[p as usize]
                } else {
                    file_normals[n as usize]
                });
                (out_pos.len() - 1) as u32
            });
        }
        indices.push(t);
    }
    Mesh::new(path, out_pos, out_nrm, indices)
}

fn parse_vec3<'a>(
    path: &Path,
    line: usize,
    words: &mut impl Iterator<Item = &'a str>,
) -> Result<Vec3, SceneError> {
    let mut v = [0.0f32; 3];
    for c in &mut v {
        let w = words
            .next()
            .ok_or_else(|| SceneError::parse_at(path, line, "expected three coordinates"))?;
        *c = w
            .parse()
            .map_err(|_| SceneError::parse_at(path, line, format!("`{w}` is not a number")))?;
    }
    Ok(Vec3::from(v))
}

/// Resolves a 1-based (or negative, relative) OBJ index against `count` elements so far.
fn resolve(
    path: &Path,
    line: usize,
    word: &str,
    count: usize,
    what: &str,
) -> Result<u32, SceneError> {
    let i: i64 = word
        .parse()
        .map_err(|_| SceneError::parse_at(path, line, format!("`{word}` is not a {what} index")))?;
    let resolved = if i > 0 { i - 1 } else { count as i64 + i };
    if i == 0 || resolved < 0 || resolved >= count as i64 {
        return Err(SceneError::parse_at(
            path,
            line,
            format!("{what} index {i} out of range ({count} defined so far)"),
        ));
    }
    Ok(resolved as u32)
}

fn parse_corner(
    path: &Path,
    line: usize,
    word: &str,
    positions: usize,
    normals: usize,
) -> Result<(u32, u32), SceneError> {
    let mut parts = word.split('/');
    let p = resolve(path, line, parts.next().unwrap_or(""), positions, "vertex")?;
    let _texcoord = parts.next();
    let n = match parts.next() {
        Some(w) if !w.is_empty() => resolve(path, line, w, normals, "normal")?,
        _ => NONE,
    };
    if parts.next().is_some() {
        return Err(SceneError::parse_at(
            path,
            line,
            format!("malformed face corner `{word}`"),
        ));
    }
    Ok((p, n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quad_with_normals_and_negative_indices() {
        let src = b"# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -4 -2 -1\n";
        let m = parse(Path::new("q.obj"), src, &LoadLimits::default()).unwrap();
        assert_eq!(m.triangle_count(), 3);
        // 4 corners with the file normal plus 3 with computed ones.
        assert_eq!(m.positions.len(), 7);
        assert!(m.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
    }

    #[test]
    fn errors_name_file_and_line() {
        let e = parse(
            Path::new("x.obj"),
            b"v 0 0 0\nv 1 0\n",
            &LoadLimits::default(),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(e, "x.obj:2: expected three coordinates");
        let e = parse(
            Path::new("x.obj"),
            b"v 0 0 0\nf 1 2 3\n",
            &LoadLimits::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("x.obj:2: vertex index 2 out of range"), "{e}");
        let e = parse(
            Path::new("x.obj"),
            b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            &LoadLimits::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
        let e = parse(Path::new("x.obj"), b"v 0 0 0\n", &LoadLimits::default()).unwrap_err();
        assert!(matches!(e, SceneError::NoTriangles { .. }));
        // A relative index before the first normal (tobj 4.0.5 overflows on it).
        let e = parse(
            Path::new("x.obj"),
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//-5 2 3\n",
            &LoadLimits::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("x.obj:5: normal index -5 out of range"),
            "{e}"
        );
    }

    #[test]
    fn counts_are_limited_while_parsing() {
        let limits = LoadLimits {
            max_vertices: 3,
            max_triangles: 1,
            ..LoadLimits::default()
        };
        let quad = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nf 1 2 3 1\n";
        let e = parse(Path::new("x.obj"), quad, &limits).unwrap_err();
        assert!(
            matches!(
                e,
                SceneError::LimitExceeded {
                    limit: Limit::Triangles,
                    value: Some(3),
                    ..
                }
            ),
            "{e}"
        );
        let e = parse(
            Path::new("x.obj"),
            b"v 0 0 0\nv 0 0 0\nv 0 0 0\nv 0 0 0\n",
            &limits,
        )
        .unwrap_err();
        assert!(e.to_string().contains("--max-vertices"), "{e}");
    }
}
