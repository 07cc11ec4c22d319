//! Mesh files: OBJ, PLY (ascii and binary), glTF 2.0 (`.gltf`, `.glb`), each optionally gzipped
//! (`.ply.gz`, …). The format is chosen by extension. Every failure is a [`SceneError`] naming the
//! file; no input makes a loader panic (a fuzz test holds them to it), and memory stays bounded
//! by [`LoadLimits`]: the format is checked on the first bytes before the body is read, and
//! every read and count is capped.

pub mod gltf;
pub mod limits;
pub mod obj;
pub mod ply;

pub use limits::{Limit, LoadLimits};

use crate::bvh;
use crate::error::SceneError;
use crate::mesh::Mesh;
use std::io::{self, Read};
use std::path::Path;

/// Bytes of a file (after inflation, for gzip) read to check its format before the rest.
const HEAD_LEN: u64 = 4096;

/// The UTF-8 byte-order mark some editors put at the start of text files.
pub(crate) const BOM: &[u8] = b"\xEF\xBB\xBF";

/// Mesh file formats.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Format {
    /// Wavefront OBJ.
    Obj,
    /// Stanford PLY.
    Ply,
    /// glTF 2.0, JSON or binary (told apart by content).
    Gltf,
}

impl Format {
    /// The format of a file name, and whether it is gzipped; `None` if unsupported.
    pub fn from_path(path: &Path) -> Option<(Format, bool)> {
        let name = path.file_name()?.to_str()?.to_ascii_lowercase();
        let (stem, gz) = match name.strip_suffix(".gz") {
            Some(stem) => (stem.to_string(), true),
            None => (name, false),
        };
        let ext = stem.rsplit_once('.')?.1;
        let format = match ext {
            "obj" => Format::Obj,
            "ply" => Format::Ply,
            "gltf" | "glb" => Format::Gltf,
            _ => return None,
        };
        Some((format, gz))
    }

    /// `Ok` if `head` (the first bytes) can start a file of this format. OBJ has no magic bytes;
    /// it must at least be text (UTF-8, no NUL).
    fn check_head(self, path: &Path, head: &[u8]) -> Result<(), SceneError> {
        let ok = match self {
            Format::Ply => {
                let head = head.strip_prefix(BOM).unwrap_or(head);
                head.starts_with(b"ply\n") || head.starts_with(b"ply\r")
            }
            Format::Gltf => {
                let json = head.strip_prefix(BOM).unwrap_or(head);
                head.starts_with(b"glTF")
                    || json.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{')
            }
            Format::Obj => {
                // A multi-byte character may be cut at the end of the head.
                !head.contains(&0)
                    && std::str::from_utf8(head).map_or_else(|e| e.error_len().is_none(), |_| true)
            }
        };
        if ok {
            return Ok(());
        }
        let expected = match self {
            Format::Obj => "OBJ (text)",
            Format::Ply => "PLY",
            Format::Gltf => "glTF",
        };
        Err(wrong_format(path, expected, head))
    }
}

fn wrong_format(path: &Path, expected: &'static str, head: &[u8]) -> SceneError {
    SceneError::WrongFormat {
        path: path.to_path_buf(),
        expected,
        found: head[..head.len().min(16)].escape_ascii().to_string(),
    }
}

/// Loads a mesh file (format from the extension) under the default [`LoadLimits`].
pub fn load_mesh(path: &Path) -> Result<Mesh, SceneError> {
    load_mesh_with(path, &LoadLimits::default())
}

/// Loads a mesh file (format from the extension) under `limits`.
pub fn load_mesh_with(path: &Path, limits: &LoadLimits) -> Result<Mesh, SceneError> {
    if Format::from_path(path).is_none() {
        return Err(SceneError::UnsupportedFormat {
            path: path.to_path_buf(),
        });
    }
    let io_error = |source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    };
    // Only a regular file: a FIFO would block the open or the read forever, a device never end.
    let file = crate::safe_fs::open_regular(path).map_err(|e| io_error(e.into()))?;
    // Refuse a file known to be too large before reading any of it (the read is capped too:
    // special files report no size, and files grow).
    let len = file.metadata().map_err(io_error)?.len();
    limits.check(path, Limit::FileSize, len)?;
    load_mesh_from_reader(path, file, limits)
}

/// Parses mesh bytes under the default [`LoadLimits`]; `path` picks the format by extension,
/// names the file in errors and anchors relative glTF buffer URIs.
pub fn load_mesh_from_bytes(path: &Path, bytes: &[u8]) -> Result<Mesh, SceneError> {
    load_mesh_from_reader(path, bytes, &LoadLimits::default())
}

/// Reads and parses a mesh from `reader` under `limits`; `path` as in [`load_mesh_from_bytes`].
///
/// The first bytes are checked against the format (the gzip magic, then the inflated format's)
/// before the body is read; the body is read through a cap of [`LoadLimits::max_file_size`]
/// (and [`LoadLimits::max_decompressed_size`] after inflation), so a stream larger than the
/// limit costs at most the limit in memory. The mesh is then held to the count and BVH limits
/// and must be visible ([`Mesh::check_visible`]).
pub fn load_mesh_from_reader(
    path: &Path,
    reader: impl Read,
    limits: &LoadLimits,
) -> Result<Mesh, SceneError> {
    let Some((format, gz)) = Format::from_path(path) else {
        return Err(SceneError::UnsupportedFormat {
            path: path.to_path_buf(),
        });
    };
    let io_error = |e: io::Error| read_error(path, gz, limits, e);
    let mut raw = Capped::new(reader, Limit::FileSize, limits);
    let mesh = if gz {
        let mut magic = Vec::new();
        (&mut raw)
            .take(2)
            .read_to_end(&mut magic)
            .map_err(io_error)?;
        if magic != [0x1f, 0x8b] {
            return Err(wrong_format(path, "gzip", &magic));
        }
        let inflated = flate2::read::GzDecoder::new(io::Cursor::new(magic).chain(raw));
        parse_from(
            path,
            format,
            Capped::new(inflated, Limit::DecompressedSize, limits),
            limits,
        )
    } else {
        parse_from(path, format, raw, limits)
    }
    .map_err(|e| e.into_scene_error(io_error))?;
    limits.check(path, Limit::Vertices, mesh.positions.len() as u64)?;
    limits.check(path, Limit::Triangles, mesh.triangle_count() as u64)?;
    limits.check(
        path,
        Limit::BvhMemory,
        bvh::memory_bound(mesh.triangle_count()),
    )?;
    mesh.check_visible(path)?;
    Ok(mesh)
}

/// Parses the mesh `reader` yields after checking its first bytes against `format`. PLY is
/// streamed into the mesh's arrays, and the rest of the stream is then read through its cap
/// without being kept, so a gzip bomb behind a small mesh is refused at the cost of the mesh;
/// OBJ and glTF are read whole first.
fn parse_from<R: Read>(
    path: &Path,
    format: Format,
    mut reader: Capped<R>,
    limits: &LoadLimits,
) -> Result<Mesh, ReadError> {
    if format != Format::Ply {
        let bytes = read_checked(path, format, reader)?;
        return match format {
            Format::Obj => obj::parse(path, &bytes, limits),
            _ => gltf::parse(path, &bytes, limits),
        }
        .map_err(ReadError::Format);
    }
    let mut head = Vec::new();
    (&mut reader)
        .take(HEAD_LEN)
        .read_to_end(&mut head)
        .map_err(ReadError::Io)?;
    format.check_head(path, &head).map_err(ReadError::Format)?;
    let bound = reader.max;
    let input = io::Cursor::new(head).chain(&mut reader);
    let parsed = ply::parse_stream(path, input, limits, bound);
    // A stream past its cap is refused for the cap, whatever its rows held.
    match (parsed, io::copy(&mut reader, &mut io::sink())) {
        (_, Err(e)) if limit_hit(&e).is_some() => Err(ReadError::Io(e)),
        (Err(e), _) => Err(ReadError::Format(e)),
        (Ok(_), Err(e)) => Err(ReadError::Io(e)),
        (Ok(mesh), Ok(_)) => Ok(mesh),
    }
}

/// A failure of [`read_checked`]: the head is not the format's, or reading failed.
enum ReadError {
    Format(SceneError),
    Io(io::Error),
}

impl ReadError {
    fn into_scene_error(self, io: impl FnOnce(io::Error) -> SceneError) -> SceneError {
        match self {
            ReadError::Format(e) => e,
            ReadError::Io(e) => io(e),
        }
    }
}

/// Reads [`HEAD_LEN`] bytes, checks them against `format`, then reads the rest.
fn read_checked<R: Read>(
    path: &Path,
    format: Format,
    mut reader: Capped<R>,
) -> Result<Vec<u8>, ReadError> {
    let mut out = Vec::new();
    (&mut reader)
        .take(HEAD_LEN)
        .read_to_end(&mut out)
        .map_err(ReadError::Io)?;
    format.check_head(path, &out).map_err(ReadError::Format)?;
    read_capped(reader, &mut out).map_err(ReadError::Io)?;
    Ok(out)
}

/// Appends everything `reader` yields to `out`, growing it by at most doubling and never past
/// the reader's cap, so the buffer never holds (or reserves) more than the limit.
fn read_capped<R: Read>(mut reader: Capped<R>, out: &mut Vec<u8>) -> io::Result<()> {
    let cap = usize::try_from(reader.max).unwrap_or(usize::MAX);
    let mut chunk = vec![0u8; 64 << 10];
    loop {
        let n = match reader.read(&mut chunk) {
            Ok(0) => return Ok(()),
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        // `Capped` has already refused anything past the limit: `len + n <= cap`.
        let need = out.len() + n;
        if need > out.capacity() {
            let target = (out.capacity() * 2).clamp(need, cap.max(need));
            out.reserve_exact(target - out.len());
        }
        out.extend_from_slice(&chunk[..n]);
    }
}

/// The limit a [`Capped`] reader failed with, if `e` is that failure.
pub(crate) fn limit_hit(e: &io::Error) -> Option<Limit> {
    e.get_ref()
        .and_then(|i| i.downcast_ref::<Exceeded>())
        .map(|Exceeded(limit)| *limit)
}

/// The [`SceneError`] of a failed read: a hit limit, a corrupt gzip stream or an I/O error.
pub(crate) fn read_error(path: &Path, gz: bool, limits: &LoadLimits, e: io::Error) -> SceneError {
    if let Some(limit) = limit_hit(&e) {
        return limits.exceeded(path, limit, None);
    }
    let bad_data = matches!(
        e.kind(),
        io::ErrorKind::InvalidData | io::ErrorKind::InvalidInput | io::ErrorKind::UnexpectedEof
    );
    if gz && bad_data {
        SceneError::parse(path, format!("corrupt gzip stream: {e}"))
    } else {
        SceneError::Io {
            path: path.to_path_buf(),
            source: e,
        }
    }
}

/// The error a [`Capped`] reader fails with once its limit is passed.
#[derive(Debug)]
struct Exceeded(Limit);

impl std::fmt::Display for Exceeded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} limit exceeded", self.0.what())
    }
}

impl std::error::Error for Exceeded {}

/// A reader that yields at most `max` bytes and fails with [`Exceeded`] on the first byte past
/// them (it asks its source for at most one byte more than it may return, never a full buffer).
/// Errors pass through decoders unchanged, so a cap under an inflater still names its limit.
struct Capped<R> {
    inner: R,
    limit: Limit,
    max: u64,
    read: u64,
}

impl<R: Read> Capped<R> {
    fn new(inner: R, limit: Limit, limits: &LoadLimits) -> Self {
        Capped {
            inner,
            limit,
            max: limits.get(limit),
            read: 0,
        }
    }
}

impl<R: Read> Read for Capped<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let allowed = self.max.saturating_sub(self.read).saturating_add(1);
        let len = buf
            .len()
            .min(usize::try_from(allowed).unwrap_or(usize::MAX));
        let n = self.inner.read(&mut buf[..len])?;
        self.read += n as u64;
        if self.read > self.max {
            return Err(io::Error::other(Exceeded(self.limit)));
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_by_extension() {
        assert_eq!(
            Format::from_path(Path::new("a/b.PLY.gz")),
            Some((Format::Ply, true))
        );
        assert_eq!(
            Format::from_path(Path::new("x.glb")),
            Some((Format::Gltf, false))
        );
        assert_eq!(Format::from_path(Path::new("x.stl")), None);
        assert_eq!(Format::from_path(Path::new("gz")), None);
    }

    #[test]
    fn missing_and_unsupported_files() {
        let e = load_mesh(Path::new("/nonexistent/bunny.obj"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("/nonexistent/bunny.obj: cannot read"), "{e}");
        let e = load_mesh(Path::new("model.stl")).unwrap_err().to_string();
        assert!(e.contains("model.stl: unsupported mesh format"), "{e}");
    }

    #[test]
    fn gzip_ply() {
        use std::io::Write;
        let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
            property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
            0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        enc.write_all(ply).unwrap();
        let gz = enc.finish().unwrap();
        let m = load_mesh_from_bytes(Path::new("t.ply.gz"), &gz).unwrap();
        assert_eq!(m.triangle_count(), 1);
        let e = load_mesh_from_bytes(Path::new("t.ply.gz"), &gz[..gz.len() / 2]).unwrap_err();
        assert!(e.to_string().contains("t.ply.gz"), "{e}");

        // Each limit is named, whether hit on the compressed or on the inflated side.
        let limit_hit = |limits: LoadLimits| match load_mesh_from_reader(
            Path::new("t.ply.gz"),
            &gz[..],
            &limits,
        ) {
            Err(SceneError::LimitExceeded { limit, .. }) => Some(limit),
            _ => None,
        };
        let defaults = LoadLimits::default();
        for (lowered, limit) in [
            (
                LoadLimits {
                    max_file_size: 40,
                    ..defaults
                },
                Limit::FileSize,
            ),
            (
                LoadLimits {
                    max_decompressed_size: 100,
                    ..defaults
                },
                Limit::DecompressedSize,
            ),
            (
                LoadLimits {
                    max_bvh_bytes: 100,
                    ..defaults
                },
                Limit::BvhMemory,
            ),
        ] {
            assert_eq!(limit_hit(lowered), Some(limit));
        }
        assert_eq!(limit_hit(LoadLimits::default()), None);
        let exact = LoadLimits {
            max_file_size: gz.len() as u64,
            max_decompressed_size: ply.len() as u64,
            ..LoadLimits::default()
        };
        assert!(load_mesh_from_reader(Path::new("t.ply.gz"), &gz[..], &exact).is_ok());
    }
}
