//! Hostile files given to the loaders and caches (issue 47): FIFOs and devices are refused
//! without blocking, reads are capped, glTF buffers stay inside the glTF's directory under one
//! total cap, a byte-order mark does not shift OBJ or PLY indices, and an edited mesh-cache
//! entry is refused.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::mpsc;
use std::time::Duration;
use vrrt_scene::load::{load_mesh, load_mesh_from_bytes, load_mesh_with, Limit, LoadLimits};
use vrrt_scene::mesh_cache::{CachedMesh, MeshCache};
use vrrt_scene::{Mesh, SceneError};

/// Notes the largest allocation each thread makes, so a test can tell a load that holds its
/// whole (inflated) input from one that streams it.
struct NoteLargest;

thread_local! {
    static LARGEST: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

unsafe impl std::alloc::GlobalAlloc for NoteLargest {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        let _ = LARGEST.try_with(|l| l.set(l.get().max(layout.size())));
        unsafe { std::alloc::System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, size: usize) -> *mut u8 {
        let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
        unsafe { std::alloc::System.realloc(ptr, layout, size) }
    }
}

#[global_allocator]
static ALLOCATOR: NoteLargest = NoteLargest;

/// Runs `f` on a thread and fails the test if it has not returned within a few seconds (a
/// FIFO read blocks forever; the test must not).
fn within_seconds<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(10))
        .expect("the call blocked (a FIFO was opened and waited on)")
}

fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().unwrap().success();
    assert!(ok, "mkfifo {}", path.display());
}

/// A triangle whose 36 bytes of positions live in the buffer file(s) `uris`, each declared
/// `len` bytes long; the first buffer supplies the positions.
fn gltf_with_buffers(uris: &[&str], len: usize) -> String {
    let buffers: Vec<String> = uris
        .iter()
        .map(|u| format!(r#"{{"uri":"{u}","byteLength":{len}}}"#))
        .collect();
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"mesh":0,"translation":[0,0,-1]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "buffers":[{}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
        "min":[0,0,0],"max":[1,1,0]}}]}}"#,
        buffers.join(",")
    )
}

fn triangle_bytes() -> Vec<u8> {
    [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect()
}

#[test]
fn a_fifo_scene_is_refused_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("f.obj");
    mkfifo(&fifo);
    let e = within_seconds(move || load_mesh(&fifo).unwrap_err().to_string());
    assert!(e.contains("FIFO"), "{e}");
    let e = load_mesh(Path::new("/dev/zero.obj"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("cannot read"), "{e}");
}

#[test]
fn a_fifo_gltf_buffer_is_refused_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("b.bin"));
    let gltf = dir.path().join("t.gltf");
    std::fs::write(&gltf, gltf_with_buffers(&["b.bin"], 36)).unwrap();
    let e = within_seconds(move || load_mesh(&gltf).unwrap_err().to_string());
    assert!(e.contains("FIFO"), "{e}");
}

#[test]
fn gltf_buffers_stay_in_the_gltf_directory() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("model");
    std::fs::create_dir(&dir).unwrap();
    std::fs::write(root.path().join("secret.bin"), triangle_bytes()).unwrap();
    std::fs::write(dir.join("ok.bin"), triangle_bytes()).unwrap();
    let load = |uri: &str| {
        let gltf = dir.join("t.gltf");
        std::fs::write(&gltf, gltf_with_buffers(&[uri], 36)).unwrap();
        load_mesh(&gltf)
    };
    assert_eq!(load("ok.bin").unwrap().triangle_count(), 1);
    let secret = root.path().join("secret.bin");
    for uri in [
        "../secret.bin".to_string(),
        "..%2Fsecret.bin".to_string(),
        secret.display().to_string(),
        "../../../../../../etc/passwd".to_string(),
    ] {
        let e = load(&uri).unwrap_err().to_string();
        assert!(
            e.contains("outside the glTF file's directory"),
            "{uri}: {e}"
        );
    }
    // A link inside the directory that leads out of it.
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&secret, dir.join("link.bin")).unwrap();
        let e = load("link.bin").unwrap_err().to_string();
        assert!(e.contains("outside the glTF file's directory"), "{e}");
    }
}

#[test]
fn gltf_buffers_share_one_size_cap() {
    let dir = tempfile::tempdir().unwrap();
    let mut big = triangle_bytes();
    big.resize(1000, 0);
    std::fs::write(dir.path().join("big.bin"), &big).unwrap();
    let gltf = dir.path().join("t.gltf");
    // One 1000-byte file named as 8 buffers: 8000 bytes in all.
    std::fs::write(&gltf, gltf_with_buffers(&["big.bin"; 8], 1000)).unwrap();
    let limits = |max_file_size| LoadLimits {
        max_file_size,
        ..LoadLimits::default()
    };
    assert!(load_mesh_with(&gltf, &limits(8000)).is_ok());
    // Each buffer alone is within 4000 bytes; together they are not.
    match load_mesh_with(&gltf, &limits(4000)) {
        Err(e @ SceneError::LimitExceeded { limit, .. }) => {
            assert_eq!(limit, Limit::FileSize);
            assert!(e.to_string().contains("buffers together"), "{e}");
        }
        other => panic!("expected the file-size limit, got {other:?}"),
    }
}

#[test]
fn a_deep_gltf_node_chain_is_called_deep() {
    let n = 300;
    let nodes: Vec<String> = (0..n)
        .map(|i| {
            if i + 1 < n {
                format!(r#"{{"children":[{}]}}"#, i + 1)
            } else {
                r#"{"mesh":0}"#.to_string()
            }
        })
        .collect();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}]}}"#,
        nodes.join(",")
    );
    let e = load_mesh_from_bytes(Path::new("deep.gltf"), json.as_bytes())
        .unwrap_err()
        .to_string();
    assert!(e.contains("levels deep"), "{e}");
    assert!(!e.contains("reached twice"), "{e}");
}

/// The quad of the issue's reproduction, with and without a byte-order mark.
fn with_and_without_bom(text: &[u8], name: &str) -> (Mesh, Mesh) {
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend_from_slice(text);
    let plain = load_mesh_from_bytes(Path::new(name), text).unwrap();
    let marked = load_mesh_from_bytes(Path::new(name), &bom).unwrap();
    (plain, marked)
}

#[test]
fn a_byte_order_mark_shifts_no_obj_index() {
    let obj = b"v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 1 1\nf 1 2 3\n";
    let (plain, marked) = with_and_without_bom(obj, "b.obj");
    assert_eq!(plain, marked);
}

#[test]
fn a_byte_order_mark_before_ply_is_skipped() {
    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
        property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
        -1 0 -1\n1 0 -1\n1 0 1\n3 0 1 2\n";
    let (plain, marked) = with_and_without_bom(ply, "b.ply");
    assert_eq!(plain, marked);
}

fn cached_triangle(dir: &Path) -> (MeshCache, PathBuf, Mesh) {
    let cache = MeshCache::new(dir);
    let mesh = load_mesh_from_bytes(
        Path::new("t.obj"),
        b"v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 1 1\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let path = cache.store(CachedMesh::Bunny, &mesh, "test").unwrap();
    (cache, path, mesh)
}

#[test]
fn an_edited_mesh_cache_entry_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (cache, path, _) = cached_triangle(dir.path());
    assert!(cache.load(CachedMesh::Bunny).is_ok());
    // Move one vertex: its first coordinate's float, just after the header.
    let mut bytes = std::fs::read(&path).unwrap();
    let body = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    bytes[body..body + 4].copy_from_slice(&0.5f32.to_le_bytes());
    std::fs::write(&path, &bytes).unwrap();
    let e = cache.load(CachedMesh::Bunny).unwrap_err().to_string();
    assert!(
        e.contains("content hash") && e.contains("vrrt fetch"),
        "{e}"
    );
}

#[test]
fn fifo_and_device_mesh_cache_entries_are_refused_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let cache = MeshCache::new(dir.path());
    mkfifo(&cache.path(CachedMesh::Bunny));
    let e = within_seconds(move || cache.load(CachedMesh::Bunny).unwrap_err().to_string());
    assert!(e.contains("FIFO"), "{e}");
    #[cfg(unix)]
    {
        let cache = MeshCache::new(dir.path());
        std::os::unix::fs::symlink("/dev/zero", cache.path(CachedMesh::Dragon)).unwrap();
        let e = cache.load(CachedMesh::Dragon).unwrap_err().to_string();
        assert!(e.contains("device"), "{e}");
    }
}

/// Reference renders on one executor reuse its buffers (executors cannot free one; a copy of
/// the geometry per reference grew memory by the mesh's size every frame) and give the same
/// images as fresh buffers, across frames, signals and sizes.
#[test]
fn references_reusing_their_buffers_give_the_same_images() {
    use vrrt_core::settings::ReflectionSettings;
    use vrrt_cpu::CpuExecutor;
    use vrrt_scene::render::{self, ReferenceBuffers, Signal};
    let scene = vrrt_scene::builtin::builtin("room").unwrap();
    let all = Signal::All { max_distance: 1.0 };
    let r = ReflectionSettings::default();
    let ao = Signal::Ao { max_distance: 1.0 };
    let mut exec = CpuExecutor::new();
    let mut buffers = ReferenceBuffers::default();
    for (frame, signal, (w, h)) in [
        (0, all, (24, 16)),
        (30, all, (24, 16)),
        (30, ao, (24, 16)),
        (31, all, (16, 8)),
    ] {
        let f = scene.frame(frame);
        let spec = render::ReferenceSpec {
            signal,
            reflections: &r,
            spp: 4,
        };
        let reused =
            render::reference_with(&mut exec, &mut buffers, &f, (w, h), spec, |_, _| {}).unwrap();
        let fresh =
            render::reference(&mut CpuExecutor::new(), &f, (w, h), spec, |_, _| {}).unwrap();
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&reused.mean), bits(&fresh.mean), "frame {frame}");
        assert_eq!(bits(&reused.stderr), bits(&fresh.stderr), "frame {frame}");
    }
}

/// A `.ply.gz` whose small mesh is followed by far more inflated bytes than the limit: refused
/// by the limit, with no allocation near the inflated size (the rows stream into the mesh and
/// the rest of the stream is read through its cap without being kept).
#[test]
fn a_ply_gz_bomb_is_refused_without_holding_it() {
    use std::io::Write;
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    enc.write_all(
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
          property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
          0 0 -2\n1 0 -2\n0 1 -2\n3 0 1 2\n",
    )
    .unwrap();
    let spaces = vec![b' '; 1 << 20];
    for _ in 0..64 {
        enc.write_all(&spaces).unwrap();
    }
    drop(spaces);
    let gz = enc.finish().unwrap();
    let limits = LoadLimits {
        max_decompressed_size: 48 << 20,
        ..LoadLimits::default()
    };
    LARGEST.with(|l| l.set(0));
    let r = vrrt_scene::load::load_mesh_from_reader(Path::new("bomb.ply.gz"), &gz[..], &limits);
    let largest = LARGEST.with(|l| l.get());
    match r {
        Err(SceneError::LimitExceeded { limit, .. }) => assert_eq!(limit, Limit::DecompressedSize),
        other => panic!("expected the decompressed-size limit, got {other:?}"),
    }
    assert!(largest < 4 << 20, "largest allocation {largest} bytes");
}

/// The CPU executor binds a scene's geometry where the scene holds it: neither the frame
/// renderer nor the reference renderer keeps a copy of the triangles, normals or BVH (each
/// copy was about 90 bytes a triangle), and the images are those of an executor given copies.
#[test]
fn the_cpu_executor_keeps_no_copy_of_the_geometry() {
    use std::sync::Arc;
    use vrrt_core::executor::{BufferId, Executor, Pass, PassTiming};
    use vrrt_core::settings::{ReflectionSettings, Settings};
    use vrrt_cpu::CpuExecutor;
    use vrrt_scene::render::{self, Readback, ReferenceBuffers, Renderer, Signal};

    /// The CPU executor as an executor that copies what it is given to share (the default).
    struct Copying(CpuExecutor);
    impl Executor for Copying {
        type Error = vrrt_cpu::CpuError;
        fn name(&self) -> &'static str {
            "copying"
        }
        fn create_buffer(&mut self, size: u64) -> Result<BufferId, Self::Error> {
            self.0.create_buffer(size)
        }
        fn write_buffer(&mut self, b: BufferId, data: &[u8]) -> Result<(), Self::Error> {
            self.0.write_buffer(b, data)
        }
        fn dispatch(&mut self, pass: &Pass<'_>) -> Result<(), Self::Error> {
            self.0.dispatch(pass)
        }
        fn read_buffer(&mut self, b: BufferId, out: &mut [u8]) -> Result<(), Self::Error> {
            self.0.read_buffer(b, out)
        }
        fn finish(&mut self) -> Result<(), Self::Error> {
            self.0.finish()
        }
        fn timings(&self) -> &[PassTiming] {
            self.0.timings()
        }
        fn clear_timings(&mut self) {
            self.0.clear_timings()
        }
    }

    let sphere = vrrt_scene::shapes::uv_sphere(vrrt_core::glam::Vec3::ZERO, 1.0, 150, 300);
    let scene = vrrt_scene::builtin::showcase("sphere", &sphere);
    let f = scene.frame(0);
    let g = &f.geometry;
    let geometry_bytes = std::mem::size_of_val(&g.nodes[..])
        + std::mem::size_of_val(&g.triangles[..])
        + std::mem::size_of_val(&g.normals[..]);
    assert!(geometry_bytes > 8 << 20, "{geometry_bytes}");
    let (w, h) = (16, 9);
    let signal = Signal::Ao { max_distance: 1.0 };
    let reflections = ReflectionSettings::default();
    let mut cpu = CpuExecutor::new();
    let mut renderer = Renderer::new(&mut cpu, w, h, signal, 1, Settings::default()).unwrap();
    let shared = renderer.render(&mut cpu, &f, Readback::default()).unwrap();
    let mut buffers = ReferenceBuffers::default();
    let spec = render::ReferenceSpec {
        signal,
        reflections: &reflections,
        spp: 4,
    };
    let reference =
        render::reference_with(&mut cpu, &mut buffers, &f, (w, h), spec, |_, _| {}).unwrap();
    // Only the denoiser's and the references' per-pixel buffers are the executor's own.
    assert!(
        cpu.owned_bytes() < geometry_bytes as u64 / 8,
        "{} bytes owned for {geometry_bytes} bytes of geometry",
        cpu.owned_bytes()
    );
    assert!(
        Arc::strong_count(g) > 2,
        "the executor holds the scene's geometry"
    );

    let mut copying = Copying(CpuExecutor::new());
    let mut renderer = Renderer::new(&mut copying, w, h, signal, 1, Settings::default()).unwrap();
    let copied = renderer
        .render(&mut copying, &f, Readback::default())
        .unwrap();
    let reference_copied = render::reference(&mut copying, &f, (w, h), spec, |_, _| {}).unwrap();
    assert!(copying.0.owned_bytes() > 2 * geometry_bytes as u64);
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&shared.denoised), bits(&copied.denoised));
    assert_eq!(bits(&reference.mean), bits(&reference_copied.mean));
}
