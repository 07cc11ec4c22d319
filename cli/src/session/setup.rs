//! Opening what a command works on: the backend and the scene (built-in or a mesh file), with
//! failures turned into one-line errors.

use anyhow::{anyhow, bail, Result};
use std::path::Path;
use vrrt_backend::{Backend, BackendKind};
use vrrt_scene::load::LoadLimits;
use vrrt_scene::Scene;

/// Opens a backend, turning failure into a one-line error.
pub fn open_backend(kind: BackendKind, validation: bool) -> Result<(Backend, String)> {
    Backend::open(kind, validation).map_err(|e| anyhow!("cannot open the {kind:?} backend: {e}"))
}

/// A scene and the name its references are cached under.
pub struct LoadedScene {
    /// The scene.
    pub scene: Scene,
    /// Built-in name, or the mesh file's stem.
    pub key: String,
}

/// Loads a built-in scene by name, or a mesh file (`.obj`, `.ply`, `.ply.gz`, `.glb`, `.gltf`)
/// shown by [`vrrt_scene::builtin::showcase`], loaded under `limits` (the `--max-*` flags).
pub fn load_scene(spec: &str, limits: &LoadLimits) -> Result<LoadedScene> {
    use vrrt_scene::builtin;
    if builtin::BUILTINS.iter().any(|b| b.name == spec) {
        let scene = builtin::builtin(spec).map_err(|e| anyhow!("{e}"))?;
        scene.validate().map_err(|e| anyhow!("{e}"))?;
        return Ok(LoadedScene {
            scene,
            key: spec.to_string(),
        });
    }
    let path = Path::new(spec);
    let is_mesh = vrrt_scene::load::Format::from_path(path).is_some();
    if !is_mesh && !path.exists() {
        // Not a mesh path: report it as an unknown scene name, listing the built-ins.
        let e = builtin::builtin(spec).err().map(|e| e.to_string());
        bail!("{}", e.unwrap_or_else(|| format!("unknown scene `{spec}`")));
    }
    let mesh = vrrt_scene::load::load_mesh_with(path, limits).map_err(|e| anyhow!("{e}"))?;
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .map(|n| n.split('.').next().unwrap_or(n).to_string())
        .filter(|n| !n.is_empty())
        .unwrap_or_else(|| "mesh".into());
    let scene = builtin::showcase(&name, &mesh);
    scene.validate().map_err(|e| anyhow!("{e}"))?;
    Ok(LoadedScene { scene, key: name })
}
