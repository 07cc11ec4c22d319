//! What the fuzz targets share: the tight [`LoadLimits`] and the checks of a load's result (a
//! valid mesh and scene, or a typed error naming the file), and the `vrrt` command line for
//! clap. A broken property panics, which libFuzzer reports as a crash with the input saved under
//! `fuzz/artifacts/<target>/`. The same checks run in the default test loop on seeded mutations
//! (`scene/tests/fuzz.rs`, `cli/tests/fuzz.rs`).

use clap::Parser;
use std::ffi::OsString;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, Once};
/// The `vrrt` command line itself, parsed by the `config_names` and `size_rate` targets.
pub use vrrt_cli::{Cli, Command};
use vrrt_scene::load::{load_mesh_from_reader, LoadLimits};
use vrrt_scene::{builtin, bvh, Mesh, SceneError};

/// Tight limits, as in the test loop: mutated counts, repeats and gzip bombs hit them, and no
/// input can make a load hold more than a few MiB.
pub fn limits() -> LoadLimits {
    LoadLimits {
        max_file_size: 64 << 10,
        max_decompressed_size: 256 << 10,
        max_vertices: 4096,
        max_triangles: 4096,
        max_bvh_bytes: bvh::memory_bound(4096),
    }
}

/// The file an input is loaded as: in a directory that does not exist, so relative glTF buffer
/// URIs find nothing.
pub fn path(name: &str) -> PathBuf {
    Path::new("/nonexistent-vrrt-fuzz").join(name)
}

/// The last panic's location and message, noted by the hook of [`allow_caught_panics`].
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);

/// libfuzzer-sys aborts on every panic, even one the code under test catches (the glTF loader
/// turns panics inside the `gltf` crate into parse errors). Unless `VRRT_FUZZ_STRICT` is set,
/// this replaces that hook (once) with one that only notes the panic, so that a caught panic is
/// no crash; [`load`] aborts on an uncaught one after printing where it happened.
fn allow_caught_panics() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        if std::env::var_os("VRRT_FUZZ_STRICT").is_some() {
            return;
        }
        std::panic::set_hook(Box::new(|info| {
            let at = info
                .location()
                .map_or("unknown location".into(), |l| l.to_string());
            let payload = info.payload();
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            *LAST_PANIC.lock().unwrap_or_else(|e| e.into_inner()) = Some(format!("{at}: {msg}"));
        }));
    });
}

/// Loads `bytes` as the file `name` (its extension picks the format) and checks the result. A
/// panic the loader does not catch, or a broken property, aborts (a crash for libFuzzer).
pub fn load(name: &str, bytes: &[u8]) {
    allow_caught_panics();
    let path = path(name);
    let limits = limits();
    let checked = catch_unwind(AssertUnwindSafe(|| {
        match load_mesh_from_reader(&path, bytes, &limits) {
            Ok(m) => {
                check_mesh(&path, &m, &limits);
                check_bom(&path, bytes, &m, &limits);
            }
            Err(e) => check_error(&path, &e),
        }
    }));
    if checked.is_err() {
        let last = LAST_PANIC.lock().unwrap_or_else(|e| e.into_inner()).take();
        eprintln!(
            "uncaught panic or broken property at {}",
            last.unwrap_or_else(|| "an unknown location".into())
        );
        std::process::abort();
    }
}

/// For OBJ and plain PLY: the same bytes after a UTF-8 byte-order mark give the same mesh (a
/// mark once glued itself to the first keyword and shifted every index).
pub fn check_bom(path: &Path, bytes: &[u8], m: &Mesh, limits: &LoadLimits) {
    let name = path.to_string_lossy().to_ascii_lowercase();
    if !(name.ends_with(".obj") || name.ends_with(".ply")) || bytes.starts_with(b"\xEF\xBB\xBF") {
        return;
    }
    let marked = [&b"\xEF\xBB\xBF"[..], bytes].concat();
    match load_mesh_from_reader(path, &marked[..], limits) {
        Ok(with_mark) => assert!(&with_mark == m, "a byte-order mark changed the mesh"),
        // The mark adds 3 bytes: a file at the size limit may now pass it.
        Err(SceneError::LimitExceeded { .. }) => {}
        Err(e) => panic!("a byte-order mark made a valid file fail: {e}"),
    }
}

/// A typed error naming the file (or, for a glTF buffer file, its directory); never one no mesh
/// file can give.
pub fn check_error(path: &Path, e: &SceneError) {
    let msg = e.to_string();
    let name = path.file_name().unwrap().to_string_lossy();
    let dir = path.parent().unwrap().display().to_string();
    assert!(
        msg.contains(&*name) || msg.contains(&dir),
        "the error does not name the file: {msg}"
    );
    assert!(
        !matches!(
            e,
            SceneError::UnsupportedFormat { .. }
                | SceneError::UnknownScene { .. }
                | SceneError::MeshNotFetched { .. }
                | SceneError::InvalidScene { .. }
        ),
        "an error no mesh file can give: {msg}"
    );
}

/// A loaded mesh is valid (what `Mesh::new` promises, within the limits, visible), and the scene
/// `vrrt` would build around it is refused by `Scene::validate` or has a finite frame with a BVH
/// of bounded depth.
pub fn check_mesh(path: &Path, m: &Mesh, limits: &LoadLimits) {
    let n = m.positions.len();
    assert!(m.triangle_count() > 0, "Ok with no triangles");
    assert!(
        n as u64 <= limits.max_vertices && m.triangle_count() as u64 <= limits.max_triangles,
        "Ok past the limits: {n} vertices, {} triangles",
        m.triangle_count()
    );
    assert!(
        m.positions.iter().all(|p| p.is_finite()),
        "non-finite vertex"
    );
    assert!(
        m.indices.iter().flatten().all(|&i| (i as usize) < n),
        "index out of range"
    );
    assert_eq!(m.normals.len(), n, "one normal per vertex");
    assert!(
        m.normals
            .iter()
            .all(|v| v.is_finite() && (v.length() - 1.0).abs() <= 1e-3),
        "a normal is not a unit vector"
    );
    if let Err(e) = m.check_visible(path) {
        panic!("Ok but not visible: {e}");
    }
    let scene = builtin::showcase("fuzz", m);
    if scene.validate().is_err() {
        return;
    }
    let frame = scene.frame(0);
    let g = &frame.geometry;
    assert!(
        g.triangles
            .iter()
            .all(|t| t.v0().is_finite() && t.v1().is_finite() && t.v2().is_finite()),
        "the showcase scene has a non-finite triangle"
    );
    assert!(
        g.normals.iter().all(
            |n| [n.n0x, n.n0y, n.n0z, n.n1x, n.n1y, n.n1z, n.n2x, n.n2y, n.n2z]
                .iter()
                .all(|x| x.is_finite())
        ),
        "the showcase scene has a non-finite normal"
    );
    let (depth, _) = bvh::depth_and_leaves(&g.nodes);
    assert!(depth < vrrt_core::trace::MAX_DEPTH, "BVH depth {depth}");
}

/// A value parser's error: non-empty, and one line unless it quotes an input holding line breaks.
pub fn check_one_line(e: &str, input: &str) {
    let breaks = |t: &str| t.contains(['\n', '\r']);
    assert!(
        !e.trim().is_empty() && !(breaks(e) && !breaks(input)),
        "error is not one line: {e:?}"
    );
}

/// Parses `vrrt <args…> <value>`, the value as raw bytes (not necessarily UTF-8). A failure must
/// render.
pub fn clap_parse(args: &[&str], value: &[u8]) -> Option<Cli> {
    use std::os::unix::ffi::OsStringExt;
    let argv = std::iter::once(OsString::from("vrrt"))
        .chain(args.iter().map(OsString::from))
        .chain([OsString::from_vec(value.to_vec())]);
    match Cli::try_parse_from(argv) {
        Ok(cli) => Some(cli),
        Err(e) => {
            assert!(
                !e.render().to_string().trim().is_empty(),
                "empty clap error"
            );
            None
        }
    }
}
