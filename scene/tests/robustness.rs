//! Robustness against wrong answers and unbounded resources (issue 20, points 1, 2 and 4):
//! references are keyed by content, damaged or foreign cache entries are never used, cache
//! writes survive interruption and races, untrusted mesh files are format-checked before their
//! body is read and held to limits with bounded memory, and meshes that would render as nothing
//! are refused. Every test works in its own temporary directory, never the user's cache.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Barrier};
use std::time::{Duration, SystemTime};

use vrrt_cpu::CpuExecutor;
use vrrt_scene::image::Image;
use vrrt_scene::load::{self, Limit, LoadLimits};
use vrrt_scene::reference_cache::{Lookup, ReferenceCache, ReferenceKey, StdErr, ORPHAN_AGE};
use vrrt_scene::render::{self, Signal};
use vrrt_scene::{builtin, FrameGeometry, SceneError};

// ---- Measuring memory: the largest single allocation made by the current thread. -------------

/// The system allocator, noting per thread the largest block asked for. A buffer that grows
/// with its input shows up as one large (re)allocation, so this bounds what a load held at once
/// without being disturbed by tests running on other threads.
struct NoteLargest;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
}

unsafe impl GlobalAlloc for NoteLargest {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: NoteLargest = NoteLargest;

/// `f`'s result and the largest allocation it made on this thread.
fn largest_allocation<T>(f: impl FnOnce() -> T) -> (T, usize) {
    LARGEST.with(|l| l.set(0));
    let out = f();
    (out, LARGEST.with(Cell::get))
}

const MIB: usize = 1 << 20;

// ---- Point 1: references keyed by content. ---------------------------------------------------

const SIZE: (u32, u32) = (16, 12);
const AO: Signal = Signal::Ao { max_distance: 0.5 };

/// The cache key of `signal` with the default reflection settings.
fn key_of(
    name: &str,
    frame: &FrameGeometry,
    size: (u32, u32),
    signal: Signal,
    spp: u64,
    version: u32,
) -> ReferenceKey {
    let reflections = vrrt_core::settings::ReflectionSettings::default();
    ReferenceKey::for_frame(name, frame, size, signal.name(&reflections), spp, version)
}

fn key(name: &str, frame: &FrameGeometry) -> ReferenceKey {
    key_of(name, frame, SIZE, AO, 8, 1)
}

fn image(value: f32) -> Image {
    let (w, h) = (SIZE.0 as usize, SIZE.1 as usize);
    Image::new(w, h, 1, vec![value; w * h]).unwrap()
}

/// A user's mesh that happens to be called `room.obj`.
fn user_room_obj(dir: &Path) -> PathBuf {
    let path = dir.join("room.obj");
    std::fs::write(
        &path,
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf 1 2 5\n",
    )
    .unwrap();
    path
}

#[test]
fn user_room_obj_does_not_reuse_the_builtin_room_references() {
    let dir = tempfile::tempdir().unwrap();
    let cache = ReferenceCache::new(dir.path().join("refs"));
    let builtin_room = builtin::builtin("room").unwrap().frame(0);
    let mesh = load::load_mesh(&user_room_obj(dir.path())).unwrap();
    let user_room = builtin::showcase("room", &mesh).frame(0);

    // Same name, same frame, size, signal and spp: different keys and different files.
    let (a, b) = (key("room", &builtin_room), key("room", &user_room));
    assert_eq!((a.scene.as_str(), a.frame), (b.scene.as_str(), b.frame));
    assert_ne!(a.content, b.content);
    assert_ne!(a, b);
    assert_ne!(cache.path(&a), cache.path(&b));

    // The built-in room's reference is cached; the user's room misses it.
    cache
        .store(&a, image(0.25).view(), &StdErr::Scalar(0.0))
        .unwrap();
    assert!(matches!(cache.lookup(&a), Lookup::Hit(_)));
    assert_eq!(cache.lookup(&b), Lookup::Miss);
    // Even a foreign entry placed under the user's room's file name is never used.
    std::fs::create_dir_all(cache.path(&b).parent().unwrap()).unwrap();
    std::fs::copy(cache.path(&a), cache.path(&b)).unwrap();
    assert!(matches!(cache.lookup(&b), Lookup::Corrupt(m) if m.contains("another key")));
    assert!(cache.load(&b).is_none());

    // The key is stable for the same content (so the cache hits): a rebuilt `room`, and even
    // `room_static`, whose frame 0 is the same frame, share the entry.
    assert_eq!(key("room", &builtin::builtin("room").unwrap().frame(0)), a);
    let room_static = builtin::builtin("room_static").unwrap().frame(0);
    assert_eq!(key("room_static", &room_static).content, a.content);
    // It covers everything else that changes the image.
    let differs = [
        key("room", &builtin::builtin("room").unwrap().frame(1)),
        key("room", &builtin::builtin("room").unwrap().frame(20)),
        key_of("room", &builtin_room, (16, 13), AO, 8, 1),
        key_of(
            "room",
            &builtin_room,
            SIZE,
            Signal::Ao { max_distance: 1.0 },
            8,
            1,
        ),
        key_of("room", &builtin_room, SIZE, Signal::Shadows, 8, 1),
        key_of("room", &builtin_room, SIZE, AO, 16, 1),
        key_of("room", &builtin_room, SIZE, AO, 8, 2),
    ];
    for k in &differs {
        assert_ne!(cache.path(k), cache.path(&a), "{k}");
    }
}

/// Traces `frame`'s AO reference on the CPU backend.
fn trace(frame: &FrameGeometry, spp: u32) -> Image {
    let mut exec = CpuExecutor::new();
    let spec = render::ReferenceSpec {
        signal: AO,
        reflections: &Default::default(),
        spp,
    };
    let r = render::reference(&mut exec, frame, SIZE, spec, |_, _| {}).unwrap();
    Image::new(SIZE.0 as usize, SIZE.1 as usize, 1, r.mean).unwrap()
}

/// What a caller does: use the entry if valid, else trace and store (as `vrrt` does).
fn get(cache: &ReferenceCache, key: &ReferenceKey, frame: &FrameGeometry) -> (Image, bool) {
    if let Some(hit) = cache.load(key) {
        return (hit.image, true);
    }
    let img = trace(frame, key.spp as u32);
    cache.store(key, img.view(), &StdErr::Scalar(0.0)).unwrap();
    (img, false)
}

#[test]
fn corrupt_entry_is_detected_and_rendered_again() {
    let dir = tempfile::tempdir().unwrap();
    let cache = ReferenceCache::new(dir.path());
    let frame = builtin::builtin("room_static").unwrap().frame(0);
    let k = key("room_static", &frame);
    let (first, cached) = get(&cache, &k, &frame);
    assert!(!cached);
    assert!(first.data().iter().any(|&v| v > 0.0));
    assert_eq!(get(&cache, &k, &frame), (first.clone(), true));

    // Damage the stored pixels: detected by the checksum, not served.
    let path = cache.path(&k);
    let mut bytes = std::fs::read(&path).unwrap();
    let n = bytes.len();
    bytes[n - 30] ^= 0x40;
    std::fs::write(&path, &bytes).unwrap();
    assert!(matches!(cache.lookup(&k), Lookup::Corrupt(_)));
    // `load` warns on stderr and misses; the caller renders again and the entry is repaired.
    let (again, cached) = get(&cache, &k, &frame);
    assert!(!cached);
    let bits = |i: &Image| i.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(
        bits(&again),
        bits(&first),
        "the reference estimator is deterministic"
    );
    assert!(matches!(cache.lookup(&k), Lookup::Hit(_)));
}

/// A temporary file name as an interrupted writer with `pid` leaves it (see `store.rs`).
fn temp_name(entry: &Path, pid: u32) -> PathBuf {
    let name = entry.file_name().unwrap().to_str().unwrap();
    entry.with_file_name(format!(".{name}.tmp.{pid}.0.123"))
}

#[test]
fn orphan_temp_files_are_cleaned() {
    let dir = tempfile::tempdir().unwrap();
    let cache = ReferenceCache::new(dir.path());
    let frame = builtin::builtin("room_static").unwrap().frame(0);
    let k = key("room_static", &frame);
    let entry = cache
        .store(&k, image(0.5).view(), &StdErr::Scalar(0.0))
        .unwrap();

    // A writer that has exited (a child process, waited for), one of ours that is fresh, one of
    // ours that is far too old to be a live write, and an unrelated file.
    let dead = {
        let mut child = std::process::Command::new(std::env::current_exe().unwrap())
            .arg("--list")
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap();
        child.wait().unwrap();
        child.id()
    };
    let me = std::process::id();
    let dead_tmp = temp_name(&entry, dead);
    let fresh_tmp = temp_name(&entry, me);
    let old_tmp = entry.with_file_name(format!(".other.exr.tmp.{me}.9.9"));
    let unrelated = entry.with_file_name("notes.txt");
    for p in [&dead_tmp, &fresh_tmp, &old_tmp, &unrelated] {
        std::fs::write(p, b"half an entry").unwrap();
    }
    let long_ago = SystemTime::now() - ORPHAN_AGE - Duration::from_secs(60);
    std::fs::File::options()
        .write(true)
        .open(&old_tmp)
        .unwrap()
        .set_modified(long_ago)
        .unwrap();

    // The next store into the directory cleans up.
    cache
        .store(&k, image(0.75).view(), &StdErr::Scalar(0.0))
        .unwrap();
    let has_proc = Path::new("/proc/self").exists();
    assert_eq!(dead_tmp.exists(), !has_proc, "dead writer's file");
    assert!(!old_tmp.exists(), "stale file");
    assert!(fresh_tmp.exists(), "a live writer's file is left alone");
    assert!(unrelated.exists());
    assert!(matches!(cache.lookup(&k), Lookup::Hit(r) if r.image == image(0.75)));
}

#[test]
fn racing_writers_leave_one_valid_entry() {
    let dir = tempfile::tempdir().unwrap();
    let cache = ReferenceCache::new(dir.path());
    let frame = builtin::builtin("room_static").unwrap().frame(0);
    let k = key("room_static", &frame);
    let (a, b) = (image(0.125), image(0.875));
    const ROUNDS: usize = 25;
    // Two writers store different (both valid) images under one key at the same moments, while
    // a reader looks the entry up throughout: it must only ever see one of them, or nothing yet.
    let start = Arc::new(Barrier::new(3));
    let (cache, k, a, b) = (&cache, &k, &a, &b);
    std::thread::scope(|s| {
        for img in [a, b] {
            let start = start.clone();
            s.spawn(move || {
                start.wait();
                for _ in 0..ROUNDS {
                    cache.store(k, img.view(), &StdErr::Scalar(0.0)).unwrap();
                }
            });
        }
        let start = start.clone();
        s.spawn(move || {
            start.wait();
            for _ in 0..4 * ROUNDS {
                match cache.lookup(k) {
                    Lookup::Hit(r) => assert!(&r.image == a || &r.image == b),
                    Lookup::Miss => {}
                    Lookup::Corrupt(m) => panic!("a reader saw a torn entry: {m}"),
                }
            }
        });
    });
    match cache.lookup(k) {
        Lookup::Hit(r) => assert!(&r.image == a || &r.image == b),
        other => panic!("{other:?}"),
    }
    let dir = cache.path(k).parent().unwrap().to_path_buf();
    let names: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "one entry, no temporary files: {names:?}");
}

// ---- Point 2: bounded resources on untrusted files. ------------------------------------------

fn gzip(parts: &[&[u8]], repeat_zeros: usize) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    for p in parts {
        enc.write_all(p).unwrap();
    }
    let zeros = vec![0u8; MIB];
    for _ in 0..repeat_zeros {
        enc.write_all(&zeros).unwrap();
    }
    enc.finish().unwrap()
}

const PLY_HEADER: &[u8] = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n\
    property float x\nproperty float y\nproperty float z\nelement face 1\n\
    property list uchar int vertex_indices\nend_header\n";

#[test]
fn inflating_ply_gz_is_capped_with_bounded_memory() {
    // 64 MiB of zeros after a valid header, in a file of well under 1 MiB.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bomb.ply.gz");
    let gz = gzip(&[PLY_HEADER], 64);
    assert!(gz.len() < MIB, "{} bytes", gz.len());
    std::fs::write(&path, &gz).unwrap();

    let limits = LoadLimits {
        max_decompressed_size: MIB as u64,
        ..LoadLimits::default()
    };
    let (result, largest) = largest_allocation(|| load::load_mesh_with(&path, &limits));
    let e = result.unwrap_err();
    assert!(
        matches!(
            e,
            SceneError::LimitExceeded {
                limit: Limit::DecompressedSize,
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(
        e.to_string(),
        format!(
            "{}: decompressed size exceeds the 1 MiB limit (--max-decompressed)",
            path.display()
        )
    );
    // Read through the cap: never more than the limit (plus read buffers) held at once.
    assert!(largest < 2 * MIB, "largest allocation {largest} bytes");
}

#[test]
fn endless_stream_is_capped_by_the_file_size_limit() {
    let limits = LoadLimits {
        max_file_size: MIB as u64,
        ..LoadLimits::default()
    };
    let endless = io::repeat(b' ');
    let (result, largest) = largest_allocation(|| {
        load::load_mesh_from_reader(Path::new("endless.obj"), endless, &limits)
    });
    let e = result.unwrap_err();
    assert!(
        e.to_string()
            .contains("file size exceeds the 1 MiB limit (--max-file-size)"),
        "{e}"
    );
    assert!(largest < 2 * MIB, "largest allocation {largest} bytes");

    // A file known to be too large is refused before it is read.
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.obj");
    std::fs::File::create(&big)
        .unwrap()
        .set_len(2 * MIB as u64)
        .unwrap();
    let e = load::load_mesh_with(&big, &limits).unwrap_err();
    let refused = matches!(e, SceneError::LimitExceeded { limit: Limit::FileSize, value, .. }
        if value == Some(2 * MIB as u64));
    assert!(refused, "{e}");
}

/// A reader that counts the bytes taken from it.
struct Counting<'a, R> {
    inner: R,
    taken: &'a Cell<u64>,
}

impl<R: Read> Read for Counting<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.taken.set(self.taken.get() + n as u64);
        Ok(n)
    }
}

#[test]
fn wrong_magic_is_rejected_before_the_body_is_read() {
    // Each "file" is a wrong head followed by an endless body: reading the body would hit the
    // file-size limit instead, after a gigabyte.
    let cases: [(&str, &[u8], &str); 5] = [
        ("model.ply", b"solid ascii\nfacet normal 0 0 1\n", "PLY"),
        ("model.glb", b"\x89PNG\r\n\x1a\n", "glTF"),
        ("model.gltf", b"<html><body>", "glTF"),
        ("model.obj", b"\x7fELF\x02\x01\x01\x00", "OBJ (text)"),
        ("model.ply.gz", b"PK\x03\x04", "gzip"),
    ];
    for (name, head, expected) in cases {
        let taken = Cell::new(0);
        let reader = Counting {
            inner: head.chain(io::repeat(0)),
            taken: &taken,
        };
        let e = load::load_mesh_from_reader(Path::new(name), reader, &LoadLimits::default())
            .unwrap_err();
        assert!(
            matches!(&e, SceneError::WrongFormat { expected: x, .. } if *x == expected),
            "{name}: {e}"
        );
        assert!(
            e.to_string()
                .starts_with(&format!("{name}: not a {expected} file")),
            "{e}"
        );
        assert!(taken.get() <= 4096, "{name}: {} bytes read", taken.get());
    }

    // A gzip file whose inflated head is not PLY: refused after inflating only its head.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("stl.ply.gz");
    std::fs::write(&path, gzip(&[b"solid ascii\n"], 64)).unwrap();
    let (e, largest) = largest_allocation(|| load::load_mesh(&path).unwrap_err());
    assert!(
        matches!(
            e,
            SceneError::WrongFormat {
                expected: "PLY",
                ..
            }
        ),
        "{e}"
    );
    assert!(largest < MIB, "largest allocation {largest} bytes");

    // A large (sparse) file with a wrong head, within the size limit: not read whole.
    let sparse = dir.path().join("sparse.ply");
    let mut f = std::fs::File::create(&sparse).unwrap();
    f.write_all(b"NOT A PLY").unwrap();
    f.set_len(512 * MIB as u64).unwrap();
    let (e, largest) = largest_allocation(|| load::load_mesh(&sparse).unwrap_err());
    assert!(matches!(e, SceneError::WrongFormat { .. }), "{e}");
    assert!(largest < MIB, "largest allocation {largest} bytes");
}

// ---- Point 4: degenerate and hostile scenes. -------------------------------------------------

fn load_text(dir: &Path, name: &str, text: &str) -> Result<usize, SceneError> {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    load::load_mesh(&path).map(|m| m.triangle_count())
}

#[test]
fn degenerate_zero_size_and_non_finite_meshes_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Every triangle collinear: nothing would be visible.
    let e = load_text(
        d,
        "line.obj",
        "v 0 0 0\nv 1 1 1\nv 2 2 2\nv 3 3 3\nf 1 2 3\nf 2 3 4\n",
    )
    .unwrap_err();
    assert!(
        matches!(e, SceneError::AllDegenerate { triangles: 2, .. }),
        "{e}"
    );
    assert!(
        e.to_string()
            .contains("line.obj: all 2 triangles are degenerate"),
        "{e}"
    );
    // Every vertex at one point: a zero-size scene.
    let e = load_text(d, "point.obj", "v 1 2 3\nv 1 2 3\nv 1 2 3\nf 1 2 3\n").unwrap_err();
    assert!(matches!(e, SceneError::ZeroSize { .. }), "{e}");
    assert!(e.to_string().contains("zero size"), "{e}");
    // Some degenerate triangles among visible ones are harmless and kept.
    let ok = load_text(
        d,
        "mixed.obj",
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n",
    );
    assert_eq!(ok.unwrap(), 2);

    // A non-finite vertex is an error even when other triangles are fine: the file is damaged,
    // and dropping triangles would render (and score) a different scene than the user's.
    let e = load_text(
        d,
        "inf.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv inf 0 0\nf 1 2 3\nf 1 2 4\n",
    )
    .unwrap_err();
    assert!(
        e.to_string()
            .contains("inf.obj: invalid geometry: vertex 4 is not finite"),
        "{e}"
    );
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
        property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n";
    let e = load_text(d, "nan.ply", ply).unwrap_err();
    assert!(matches!(e, SceneError::InvalidGeometry { .. }), "{e}");
    assert!(e.to_string().contains("not finite"), "{e}");
}
