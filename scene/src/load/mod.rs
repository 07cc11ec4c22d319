//! Mesh files: OBJ, PLY (ascii and binary), glTF 2.0 (`.gltf`, `.glb`), each optionally gzipped
//! (`.ply.gz`, …). The format is chosen by extension. Every failure is a [`SceneError`] naming the
//! file; no input makes a loader panic (a fuzz test holds them to it).

pub mod gltf;
pub mod obj;
pub mod ply;

use crate::error::SceneError;
use crate::mesh::Mesh;
use std::io::Read;
use std::path::Path;

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
}

/// Loads a mesh file (format from the extension).
pub fn load_mesh(path: &Path) -> Result<Mesh, SceneError> {
    if Format::from_path(path).is_none() {
        return Err(SceneError::UnsupportedFormat {
            path: path.to_path_buf(),
        });
    }
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    load_mesh_from_bytes(path, &bytes)
}

/// Parses mesh bytes; `path` picks the format by extension, names the file in errors and anchors
/// relative glTF buffer URIs.
pub fn load_mesh_from_bytes(path: &Path, bytes: &[u8]) -> Result<Mesh, SceneError> {
    let Some((format, gz)) = Format::from_path(path) else {
        return Err(SceneError::UnsupportedFormat {
            path: path.to_path_buf(),
        });
    };
    let inflated;
    let bytes = if gz {
        let mut out = Vec::new();
        flate2::read::GzDecoder::new(bytes)
            .read_to_end(&mut out)
            .map_err(|e| SceneError::parse(path, format!("corrupt gzip stream: {e}")))?;
        inflated = out;
        &inflated[..]
    } else {
        bytes
    };
    match format {
        Format::Obj => obj::parse(path, bytes),
        Format::Ply => ply::parse(path, bytes),
        Format::Gltf => gltf::parse(path, bytes),
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
    }
}
