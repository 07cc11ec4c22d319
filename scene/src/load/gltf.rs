//! glTF 2.0 (`.gltf` with external or data-URI buffers, and binary `.glb`): every triangle
//! primitive of the default scene (or of every scene when none is marked default, or of every
//! root node when there are no scenes), with node transforms applied, merged into one mesh.
//!
//! The `gltf` crate parses and validates the JSON; buffers are resolved here (no image decoding),
//! and every accessor is bounds-checked against its buffer before it is read, so a malformed file
//! gives an error instead of a panic. Sparse accessors are rejected.

use super::{Limit, LoadLimits};
use crate::error::SceneError;
use crate::mesh::Mesh;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::{Mode, Semantic};
use std::path::Path;
use vrrt_core::glam::{Affine3A, Mat4, Vec3};

/// Deepest node hierarchy accepted.
const MAX_NODE_DEPTH: usize = 256;

/// Parses a `.gltf` or `.glb` file; external buffers are read relative to `path`, each under
/// the file-size limit. The vertex and triangle limits are checked before each primitive is
/// added, since nodes may place one mesh many times.
///
/// The `gltf` crate panics on some malformed files (arithmetic overflow in its GLB header and
/// accessor readers, found by `scene/tests/fuzz.rs`): a panic anywhere in parsing is caught and
/// reported as a parse error, never an abort.
pub fn parse(path: &Path, bytes: &[u8], limits: &LoadLimits) -> Result<Mesh, SceneError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        parse_guarded(path, bytes, limits)
    }))
    .unwrap_or_else(|_| {
        Err(SceneError::parse(
            path,
            "glTF: malformed file (the glTF parser panicked)",
        ))
    })
}

fn parse_guarded(path: &Path, bytes: &[u8], limits: &LoadLimits) -> Result<Mesh, SceneError> {
    let gltf = open(path, bytes)?;
    let buffers = resolve_buffers(path, &gltf, limits)?;
    let doc = &gltf.document;

    let roots: Vec<gltf::Node> = if let Some(scene) = doc.default_scene() {
        scene.nodes().collect()
    } else if doc.scenes().len() > 0 {
        doc.scenes()
            .flat_map(|s| s.nodes().collect::<Vec<_>>())
            .collect()
    } else {
        // No scene: every node that is nobody's child.
        let mut is_child = vec![false; doc.nodes().len()];
        for n in doc.nodes() {
            for c in n.children() {
                is_child[c.index()] = true;
            }
        }
        doc.nodes().filter(|n| !is_child[n.index()]).collect()
    };

    let mut mesh = Mesh::default();
    let mut stack: Vec<(gltf::Node, Affine3A, usize)> = roots
        .into_iter()
        .map(|n| (n, Affine3A::IDENTITY, 0))
        .collect();
    // glTF node hierarchies are trees: a node reached twice means a cycle or a shared child,
    // which would otherwise make the walk endless (or exponential).
    let mut visits = vec![0u32; doc.nodes().len()];
    while let Some((node, parent, depth)) = stack.pop() {
        visits[node.index()] += 1;
        if depth > MAX_NODE_DEPTH {
            return Err(SceneError::parse(
                path,
                format!(
                    "node {} is more than {MAX_NODE_DEPTH} levels deep: the node hierarchy is \
                     too deep",
                    node.index()
                ),
            ));
        }
        if visits[node.index()] > 1 {
            return Err(SceneError::parse(
                path,
                format!(
                    "node {} is reached twice: the node hierarchy is not a tree",
                    node.index()
                ),
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        if !local.is_finite() {
            return Err(SceneError::geometry(
                path,
                format!("node {} has a non-finite transform", node.index()),
            ));
        }
        let world = parent * Affine3A::from_mat4(local);
        if let Some(m) = node.mesh() {
            for prim in m.primitives() {
                append_primitive(path, &buffers, &prim, &world, limits, &mut mesh)?;
            }
        }
        for child in node.children() {
            stack.push((child, world, depth + 1));
        }
    }
    Mesh::new(path, mesh.positions, mesh.normals, mesh.indices)
}

/// Parses and validates the document. gltf-json 1.4's validation indexes the accessor list with
/// a primitive's POSITION index before that index is checked (a dangling index panics), so
/// primitive accessor indices are checked first (other panics are caught by [`parse`]).
/// and reported as a parse error.
fn open(path: &Path, bytes: &[u8]) -> Result<gltf::Gltf, SceneError> {
    // gltf 1.4 subtracts the 12-byte GLB header from the declared length unchecked.
    if let Some(len) = bytes.strip_prefix(b"glTF").and_then(|b| b.get(4..8)) {
        let len = u32::from_le_bytes([len[0], len[1], len[2], len[3]]);
        if len < 12 {
            return Err(SceneError::parse(
                path,
                format!("GLB: declared length {len} is shorter than its 12-byte header"),
            ));
        }
    }
    let raw = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| SceneError::parse(path, format!("glTF: {e}")))?;
    let root = raw.document.as_json();
    let count = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for prim in &mesh.primitives {
            let mut ids: Vec<usize> = prim.attributes.values().map(|i| i.value()).collect();
            ids.extend(prim.indices.map(|i| i.value()));
            for t in prim.targets.iter().flatten() {
                ids.extend(
                    [t.positions, t.normals, t.tangents]
                        .into_iter()
                        .flatten()
                        .map(|i| i.value()),
                );
            }
            if let Some(bad) = ids.into_iter().find(|&i| i >= count) {
                return Err(SceneError::parse(
                    path,
                    format!("glTF: mesh {m} uses accessor {bad}, but there are {count}"),
                ));
            }
        }
    }
    let gltf::Gltf { document, blob } = raw;
    let json = document.into_json();
    let document = gltf::Document::from_json(json)
        .map_err(|e| SceneError::parse(path, format!("glTF: {e}")))?;
    Ok(gltf::Gltf { document, blob })
}

fn append_primitive(
    path: &Path,
    buffers: &[Vec<u8>],
    prim: &gltf::Primitive,
    world: &Affine3A,
    limits: &LoadLimits,
    out: &mut Mesh,
) -> Result<(), SceneError> {
    let mode = prim.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        return Ok(());
    }
    let Some(pos_acc) = prim.get(&Semantic::Positions) else {
        return Err(SceneError::parse(path, "primitive without POSITION"));
    };
    check_accessor(path, buffers, &pos_acc, Dimensions::Vec3, &[DataType::F32])?;
    let vertices = out.positions.len() + pos_acc.count();
    limits.check(path, Limit::Vertices, vertices as u64)?;
    let normal_acc = prim.get(&Semantic::Normals);
    if let Some(n) = &normal_acc {
        check_accessor(path, buffers, n, Dimensions::Vec3, &[DataType::F32])?;
    }
    if let Some(i) = prim.indices() {
        check_accessor(
            path,
            buffers,
            &i,
            Dimensions::Scalar,
            &[DataType::U8, DataType::U16, DataType::U32],
        )?;
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
    let positions: Vec<Vec3> = reader
        .read_positions()
        .ok_or_else(|| SceneError::parse(path, "unreadable POSITION"))?
        .map(Vec3::from)
        .collect();
    let normals: Vec<Vec3> = match reader.read_normals() {
        Some(it) => it.map(Vec3::from).collect(),
        None => Vec::new(),
    };
    if !normals.is_empty() && normals.len() != positions.len() {
        return Err(SceneError::geometry(
            path,
            "NORMAL and POSITION counts differ",
        ));
    }
    let order: Vec<u32> = match reader.read_indices() {
        Some(ix) => ix.into_u32().collect(),
        None => (0..positions.len() as u32).collect(),
    };
    let mut tris: Vec<[u32; 3]> = Vec::new();
    match mode {
        Mode::Triangles => tris.extend(order.chunks_exact(3).map(|c| [c[0], c[1], c[2]])),
        Mode::TriangleStrip => {
            for i in 2..order.len() {
                let t = if i % 2 == 0 {
                    [order[i - 2], order[i - 1], order[i]]
                } else {
                    [order[i - 1], order[i - 2], order[i]]
                };
                tris.push(t);
            }
        }
        _ => {
            for i in 2..order.len() {
                tris.push([order[0], order[i - 1], order[i]]);
            }
        }
    }
    let n = positions.len();
    if let Some(bad) = tris.iter().flatten().find(|&&i| i as usize >= n) {
        return Err(SceneError::geometry(
            path,
            format!("index {bad} out of range ({n} vertices)"),
        ));
    }
    // Validate (finite positions, normals) in object space, then move to world space.
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(SceneError::geometry(
            path,
            format!("vertex {i} is not finite ({})", positions[i]),
        ));
    }
    if tris.is_empty() {
        return Ok(());
    }
    limits.check(
        path,
        Limit::Triangles,
        (out.indices.len() + tris.len()) as u64,
    )?;
    let local = Mesh::new(path, positions, normals, tris)?;
    out.append(&local.transformed(world));
    Ok(())
}

/// Bounds and type checks of one accessor against the resolved buffers.
fn check_accessor(
    path: &Path,
    buffers: &[Vec<u8>],
    acc: &gltf::Accessor,
    dims: Dimensions,
    types: &[DataType],
) -> Result<(), SceneError> {
    let name = format!("accessor {}", acc.index());
    if acc.sparse().is_some() {
        return Err(SceneError::parse(
            path,
            format!("{name}: sparse accessors are not supported"),
        ));
    }
    if acc.dimensions() != dims || !types.contains(&acc.data_type()) || acc.normalized() {
        return Err(SceneError::parse(
            path,
            format!(
                "{name}: unexpected type {:?} {:?}",
                acc.dimensions(),
                acc.data_type()
            ),
        ));
    }
    let Some(view) = acc.view() else {
        return Err(SceneError::parse(path, format!("{name}: no buffer view")));
    };
    let data_len = buffers.get(view.buffer().index()).map_or(0, Vec::len);
    let view_end = view.offset().checked_add(view.length());
    if view_end.is_none_or(|e| e > data_len) {
        return Err(SceneError::parse(
            path,
            format!(
                "buffer view {} exceeds its buffer ({data_len} bytes)",
                view.index()
            ),
        ));
    }
    let elem = acc.size();
    let stride = view.stride().unwrap_or(elem);
    if acc.count() == 0 {
        // gltf 1.4's readers compute `count - 1` unchecked.
        return Err(SceneError::parse(path, format!("{name}: no elements")));
    }
    let need = (acc.count() - 1)
        .checked_mul(stride)
        .and_then(|x| x.checked_add(acc.offset()))
        .and_then(|x| x.checked_add(elem));
    if need.is_none_or(|n| n > view.length()) || stride < elem {
        return Err(SceneError::parse(
            path,
            format!("{name} reads past its buffer view"),
        ));
    }
    Ok(())
}

/// The bytes of every buffer. External files and data URIs count against one total of
/// [`LoadLimits::max_file_size`], so naming one large file many times costs at most the limit.
fn resolve_buffers(
    path: &Path,
    gltf: &gltf::Gltf,
    limits: &LoadLimits,
) -> Result<Vec<Vec<u8>>, SceneError> {
    let mut out = Vec::new();
    let mut total = 0u64;
    for buffer in gltf.document.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf
                .blob
                .clone()
                .ok_or_else(|| SceneError::parse(path, "GLB buffer without a BIN chunk"))?,
            gltf::buffer::Source::Uri(uri) => {
                let left = limits.max_file_size.saturating_sub(total);
                load_uri(path, uri, limits, left)?
            }
        };
        if data.len() < buffer.length() {
            return Err(SceneError::parse(
                path,
                format!(
                    "buffer {} has {} bytes, {} declared",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        total += data.len() as u64;
        if !matches!(buffer.source(), gltf::buffer::Source::Bin) {
            buffers_total(path, limits, total)?;
        }
        out.push(data);
    }
    Ok(out)
}

/// `Ok` while the external buffers' `total` is within the file-size limit.
fn buffers_total(path: &Path, limits: &LoadLimits, total: u64) -> Result<(), SceneError> {
    let mut named = path.as_os_str().to_owned();
    named.push(" (its buffers together)");
    limits.check(Path::new(&named), Limit::FileSize, total)
}

/// A buffer's bytes: a base64 data URI, or a file inside the glTF file's own directory (no
/// absolute path, no `..`, no link leading out), at most `left` bytes.
fn load_uri(path: &Path, uri: &str, limits: &LoadLimits, left: u64) -> Result<Vec<u8>, SceneError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest
            .split_once(";base64,")
            .ok_or_else(|| SceneError::parse(path, "data URI is not base64"))?;
        return base64_decode(payload)
            .ok_or_else(|| SceneError::parse(path, "invalid base64 in data URI"));
    }
    if uri.contains("://") {
        return Err(SceneError::parse(
            path,
            format!("buffer URI `{uri}` is not a local file"),
        ));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let file = confined(path, dir, &percent_decode(uri))?;
    let bytes = crate::safe_fs::read_capped(&file, left).map_err(|e| match e {
        crate::safe_fs::ReadError::TooLarge { len, .. } => {
            let mut named = path.as_os_str().to_owned();
            named.push(" (its buffers together)");
            let total = len.map(|l| l + limits.max_file_size - left);
            limits.exceeded(Path::new(&named), Limit::FileSize, total)
        }
        other => SceneError::parse(path, format!("buffer file {}: {other}", file.display())),
    })?;
    Ok(bytes)
}

/// `dir/relative` if `relative` is a plain relative path that stays inside `dir`, also after
/// following links; a parse error of `path` otherwise.
fn confined(path: &Path, dir: &Path, relative: &str) -> Result<std::path::PathBuf, SceneError> {
    use std::path::Component;
    let outside = || {
        SceneError::parse(
            path,
            format!("buffer URI `{relative}` leads outside the glTF file's directory"),
        )
    };
    let rel = Path::new(relative);
    if relative.is_empty()
        || !rel
            .components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(outside());
    }
    let file = dir.join(rel);
    // A link inside the directory may still lead out of it.
    if let (Ok(real_dir), Ok(real_file)) = (dir.canonicalize(), file.canonicalize()) {
        if !real_file.starts_with(&real_dir) {
            return Err(outside());
        }
    }
    Ok(file)
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = |c: u8| (c as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Standard base64 (padding optional, whitespace ignored); `None` on any other character.
fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(s.len() / 4 * 3);
    let mut acc = 0u32;
    let mut bits = 0u32;
    for c in s.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => break,
            b' ' | b'\n' | b'\r' | b'\t' => continue,
            _ => return None,
        };
        acc = (acc << 6) | v as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trip() {
        assert_eq!(base64_decode("TWFu").unwrap(), b"Man");
        assert_eq!(base64_decode("TWE=").unwrap(), b"Ma");
        assert_eq!(base64_decode("TQ==").unwrap(), b"M");
        assert!(base64_decode("T*").is_none());
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
        assert_eq!(percent_decode("50%"), "50%");
    }
}
