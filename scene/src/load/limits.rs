//! Resource limits for untrusted mesh files.
//!
//! A mesh file is user input: a small `.ply.gz` can inflate without bound, a PLY header can
//! declare billions of vertices, a glTF file can place one large mesh thousands of times. Every
//! loader checks the limits below as early as it can (the file size before reading, the
//! decompressed size while inflating, declared counts before the body, running counts while
//! parsing), so memory stays bounded by them whatever the input. Each breach is a
//! [`SceneError::LimitExceeded`] naming the limit and the command-line flag that raises it.

use crate::error::SceneError;
use std::path::Path;

const MIB: u64 = 1 << 20;
const GIB: u64 = 1 << 30;

/// One of the limits of [`LoadLimits`].
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Limit {
    /// Bytes read from disk: the mesh file, and each external glTF buffer file.
    FileSize,
    /// Bytes of a gzipped file after inflation.
    DecompressedSize,
    /// Vertices of the mesh (and of the file's vertex list while parsing).
    Vertices,
    /// Triangles of the mesh, after polygons are split into triangles.
    Triangles,
    /// Bytes of the BVH built over the mesh ([`crate::bvh::memory_bound`]).
    BvhMemory,
}

impl Limit {
    /// The `vrrt` flag that sets this limit.
    pub fn flag(self) -> &'static str {
        match self {
            Limit::FileSize => "--max-file-size",
            Limit::DecompressedSize => "--max-decompressed",
            Limit::Vertices => "--max-vertices",
            Limit::Triangles => "--max-triangles",
            Limit::BvhMemory => "--max-bvh-memory",
        }
    }

    /// What is limited, in words.
    pub fn what(self) -> &'static str {
        match self {
            Limit::FileSize => "file size",
            Limit::DecompressedSize => "decompressed size",
            Limit::Vertices => "vertex count",
            Limit::Triangles => "triangle count",
            Limit::BvhMemory => "BVH memory",
        }
    }

    /// A value of this limit as text: bytes in the largest whole binary unit, counts as numbers.
    pub fn format(self, value: u64) -> String {
        match self {
            Limit::Vertices | Limit::Triangles => value.to_string(),
            _ if value >= GIB && value.is_multiple_of(GIB) => format!("{} GiB", value / GIB),
            _ if value >= MIB && value.is_multiple_of(MIB) => format!("{} MiB", value / MIB),
            _ if value >= 1024 && value.is_multiple_of(1024) => format!("{} KiB", value / 1024),
            _ => format!("{value} bytes"),
        }
    }
}

/// The limits a mesh load runs under. The defaults keep one scene under 4 GB of peak memory
/// (what a mesh scene takes per triangle with its references is measured in
/// `docs/reliability.md`) while taking any scanned model of a few million triangles; raise them
/// for larger scenes (Stanford's 28-million-triangle Lucy needs `--max-vertices 33554432
/// --max-triangles 33554432 --max-bvh-memory 8G` and more memory).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct LoadLimits {
    /// Largest file read, in bytes (default 1 GiB; `--max-file-size`).
    pub max_file_size: u64,
    /// Largest inflated size of a gzipped file, in bytes (default 1 GiB; `--max-decompressed`).
    pub max_decompressed_size: u64,
    /// Most vertices (default 2²³ = 8,388,608; `--max-vertices`).
    pub max_vertices: u64,
    /// Most triangles (default 2²³ = 8,388,608; `--max-triangles`).
    pub max_triangles: u64,
    /// Largest BVH over the mesh, in bytes (default 2 GiB, about 14 million triangles;
    /// `--max-bvh-memory`).
    pub max_bvh_bytes: u64,
}

impl Default for LoadLimits {
    fn default() -> Self {
        LoadLimits {
            max_file_size: GIB,
            max_decompressed_size: GIB,
            max_vertices: 1 << 23,
            max_triangles: 1 << 23,
            max_bvh_bytes: 2 * GIB,
        }
    }
}

impl LoadLimits {
    /// The value of one limit.
    pub fn get(&self, limit: Limit) -> u64 {
        match limit {
            Limit::FileSize => self.max_file_size,
            Limit::DecompressedSize => self.max_decompressed_size,
            Limit::Vertices => self.max_vertices,
            Limit::Triangles => self.max_triangles,
            Limit::BvhMemory => self.max_bvh_bytes,
        }
    }

    /// `Ok` if `value` is within `limit`, else the error naming it (with the value).
    pub fn check(&self, path: &Path, limit: Limit, value: u64) -> Result<(), SceneError> {
        if value <= self.get(limit) {
            Ok(())
        } else {
            Err(self.exceeded(path, limit, Some(value)))
        }
    }

    /// The error for `limit` exceeded by `value` (`None` when reading stopped at the limit, so
    /// the full value is unknown).
    pub fn exceeded(&self, path: &Path, limit: Limit, value: Option<u64>) -> SceneError {
        SceneError::LimitExceeded {
            path: path.to_path_buf(),
            limit,
            max: self.get(limit),
            value,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_limit_and_its_flag() {
        let limits = LoadLimits::default();
        let e = limits
            .check(Path::new("big.ply.gz"), Limit::DecompressedSize, GIB + 1)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "big.ply.gz: decompressed size (1073741825 bytes) exceeds the 1 GiB limit \
             (--max-decompressed)"
        );
        let e = limits
            .exceeded(Path::new("a.obj"), Limit::Triangles, None)
            .to_string();
        assert_eq!(
            e,
            "a.obj: triangle count exceeds the 8388608 limit (--max-triangles)"
        );
        assert!(limits
            .check(Path::new("a.obj"), Limit::Vertices, 1 << 23)
            .is_ok());
        assert_eq!(Limit::FileSize.format(3 * MIB), "3 MiB");
        assert_eq!(Limit::BvhMemory.format(1000), "1000 bytes");
    }
}
