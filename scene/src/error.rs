//! The one error type of scene loading: every variant names the file (or scene) and the problem,
//! so a user can fix the input without a debugger.

use crate::load::Limit;
use std::fmt;
use std::path::PathBuf;

/// Why a mesh or scene could not be loaded.
#[derive(Debug)]
pub enum SceneError {
    /// The file could not be read.
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file is not valid in its format (malformed or truncated).
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line for text formats, when known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// The file parsed, but its geometry is unusable (NaN vertex, index out of range, …).
    InvalidGeometry {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The file holds no triangles.
    NoTriangles {
        /// The file.
        path: PathBuf,
    },
    /// The file's first bytes are not those of the format its extension names (checked before
    /// the rest of the file is read).
    WrongFormat {
        /// The file.
        path: PathBuf,
        /// The format the extension names, e.g. `"PLY"` or `"gzip"`.
        expected: &'static str,
        /// The file's first bytes, escaped.
        found: String,
    },
    /// A resource limit of [`crate::load::LoadLimits`] was hit.
    LimitExceeded {
        /// The file.
        path: PathBuf,
        /// Which limit.
        limit: Limit,
        /// Its value.
        max: u64,
        /// The value found, when known (reading stops at the limit, so sizes often are not).
        value: Option<u64>,
    },
    /// Every vertex the triangles use is at one point: the scene has no extent.
    ZeroSize {
        /// The file.
        path: PathBuf,
    },
    /// Every triangle has zero area (at `f32` precision at the mesh's scale): nothing would be
    /// visible.
    AllDegenerate {
        /// The file.
        path: PathBuf,
        /// How many triangles there are.
        triangles: usize,
    },
    /// The file extension is not a supported mesh format.
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
    },
    /// No built-in scene has this name.
    UnknownScene {
        /// The name asked for.
        name: String,
        /// The names that exist, comma-separated.
        known: String,
    },
    /// A built-in scene's mesh is not in the mesh cache ([`crate::mesh_cache`]): `vrrt fetch`
    /// downloads it.
    MeshNotFetched {
        /// The scene's name.
        scene: String,
        /// What the mesh is, e.g. "the Stanford bunny".
        mesh: &'static str,
        /// Where it was looked for; `None` when no cache directory is known.
        path: Option<PathBuf>,
    },
    /// A scene whose camera, animation or lights cannot give a defined image (NaN or infinite
    /// transforms, a camera looking at its own position, a field of view outside (0, π)).
    InvalidScene {
        /// The scene's name.
        scene: String,
        /// What is wrong, naming the camera key, instance or light.
        message: String,
    },
}

impl SceneError {
    /// A parse error without a line number.
    pub fn parse(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        SceneError::Parse {
            path: path.into(),
            line: None,
            message: message.into(),
        }
    }

    /// A parse error at a 1-based line.
    pub fn parse_at(path: impl Into<PathBuf>, line: usize, message: impl Into<String>) -> Self {
        SceneError::Parse {
            path: path.into(),
            line: Some(line),
            message: message.into(),
        }
    }

    /// An invalid-geometry error.
    pub fn geometry(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        SceneError::InvalidGeometry {
            path: path.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneError::Io { path, source } => {
                write!(f, "{}: cannot read: {source}", path.display())
            }
            SceneError::Parse {
                path,
                line: Some(line),
                message,
            } => {
                write!(f, "{}:{line}: {message}", path.display())
            }
            SceneError::Parse {
                path,
                line: None,
                message,
            } => write!(f, "{}: {message}", path.display()),
            SceneError::InvalidGeometry { path, message } => {
                write!(f, "{}: invalid geometry: {message}", path.display())
            }
            SceneError::NoTriangles { path } => {
                write!(f, "{}: the file holds no triangles", path.display())
            }
            SceneError::WrongFormat {
                path,
                expected,
                found,
            } if found.is_empty() => {
                write!(f, "{}: not a {expected} file (it is empty)", path.display())
            }
            SceneError::WrongFormat {
                path,
                expected,
                found,
            } => write!(
                f,
                "{}: not a {expected} file (it starts with `{found}`)",
                path.display()
            ),
            SceneError::LimitExceeded {
                path,
                limit,
                max,
                value,
            } => {
                write!(f, "{}: {}", path.display(), limit.what())?;
                if let Some(v) = value {
                    write!(f, " ({})", limit.format(*v))?;
                }
                write!(
                    f,
                    " exceeds the {} limit ({})",
                    limit.format(*max),
                    limit.flag()
                )
            }
            SceneError::ZeroSize { path } => write!(
                f,
                "{}: the scene has zero size (every vertex is at one point)",
                path.display()
            ),
            SceneError::AllDegenerate { path, triangles } => write!(
                f,
                "{}: all {triangles} triangles are degenerate (zero area): nothing is visible",
                path.display()
            ),
            SceneError::UnsupportedFormat { path } => write!(
                f,
                "{}: unsupported mesh format (expected .obj, .ply, .glb or .gltf, optionally .gz)",
                path.display()
            ),
            SceneError::UnknownScene { name, known } => {
                write!(f, "no built-in scene named `{name}` (known: {known})")
            }
            SceneError::MeshNotFetched {
                scene,
                mesh,
                path: Some(path),
            } => write!(
                f,
                "scene `{scene}` needs {mesh}, which is not in the mesh cache ({}): \
                 run `vrrt fetch` first",
                path.display()
            ),
            SceneError::MeshNotFetched {
                scene,
                mesh,
                path: None,
            } => write!(
                f,
                "scene `{scene}` needs {mesh}, but no mesh cache directory is known (set \
                 {}, XDG_CACHE_HOME or HOME): set one, then run `vrrt fetch` first",
                crate::mesh_cache::MeshCache::ENV_VAR
            ),
            SceneError::InvalidScene { scene, message } => {
                write!(f, "scene `{scene}`: {message}")
            }
        }
    }
}

impl std::error::Error for SceneError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            SceneError::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}
