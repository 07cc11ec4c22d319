//! Mesh loaders on the kept corpus (tests/corpus), fuzzed by truncation and byte mutation (no
//! input may panic), and on real meshes when their Debian packages are installed.

use proptest::prelude::*;
use std::path::{Path, PathBuf};
use vrrt_scene::load::{load_mesh, load_mesh_from_bytes};
use vrrt_scene::{bvh, SceneError};

fn corpus() -> Vec<(PathBuf, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect();
    files.sort();
    files
}

#[test]
fn corpus_loads() {
    let expect = [
        ("cube_ascii.ply", 12),
        ("quad.obj", 3),
        ("tri.glb", 1),
        ("tri.gltf", 1),
        ("tri_le.ply", 1),
    ];
    let files = corpus();
    assert_eq!(files.len(), expect.len());
    for ((path, _), (name, tris)) in files.iter().zip(expect) {
        assert!(path.ends_with(name));
        let m = load_mesh(path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.triangle_count(), tris, "{name}");
    }
    // glTF node translation applied.
    let m = load_mesh(&files[2].0).unwrap();
    assert!(m.positions.iter().all(|p| p.z == -1.0));
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 400,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// Truncated, bit-flipped or spliced inputs give `Ok` or a `SceneError`, never a panic, and
    /// every `Ok` mesh is valid.
    #[test]
    fn mutated_corpus_never_panics(
        file in 0usize..5,
        cut in any::<prop::sample::Index>(),
        flips in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..6),
        truncate in any::<bool>(),
    ) {
        let files = corpus();
        let (path, bytes) = &files[file % files.len()];
        let mut b = bytes.clone();
        for (at, v) in flips {
            let i = at.index(b.len());
            b[i] = v;
        }
        if truncate {
            b.truncate(cut.index(b.len() + 1));
        }
        match load_mesh_from_bytes(path, &b) {
            Ok(m) => {
                prop_assert!(m.triangle_count() > 0);
                prop_assert!(m.positions.iter().all(|p| p.is_finite()));
                prop_assert!(m.indices.iter().flatten().all(|&i| (i as usize) < m.positions.len()));
                prop_assert_eq!(m.normals.len(), m.positions.len());
            }
            Err(e) => {
                let msg = e.to_string();
                let name = path.file_name().unwrap().to_str().unwrap();
                prop_assert!(msg.contains(name), "error must name the file: {}", msg);
            }
        }
    }

    /// Arbitrary bytes under every extension.
    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..512), ext in 0usize..6) {
        let name = ["x.obj", "x.ply", "x.glb", "x.gltf", "x.ply.gz", "x.obj.gz"][ext];
        let _ = load_mesh_from_bytes(Path::new(name), &bytes);
        let mut ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
            property float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\n\
            end_header\n".to_vec();
        ply.extend_from_slice(&bytes);
        let _ = load_mesh_from_bytes(Path::new("y.ply"), &ply);
    }

    /// PLY bodies under a header that takes every path of the PLY reader (elements skipped
    /// before and after the mesh, lists of several types, normals, big endian), as arbitrary
    /// bytes and as number-like ascii tokens.
    #[test]
    fn ply_bodies_never_panic(
        bytes in prop::collection::vec(any::<u8>(), 0..512),
        text in prop::collection::vec(prop::sample::select(b"0123 \n-.e+nai".to_vec()), 0..512),
    ) {
        for (format, body) in [("binary_big_endian", &bytes), ("ascii", &bytes), ("ascii", &text)] {
            let mut ply = format!(
                "ply\nformat {format} 1.0\nelement extra 2\nproperty list uchar float v\n\
                 property short s\nelement vertex 3\nproperty double x\nproperty double y\n\
                 property double z\nproperty float nx\nproperty float ny\nproperty float nz\n\
                 element face 2\nproperty list ushort uint vertex_index\nelement tail 1\n\
                 property uchar t\nend_header\n"
            )
            .into_bytes();
            ply.extend_from_slice(body);
            if let Ok(m) = load_mesh_from_bytes(Path::new("z.ply"), &ply) {
                prop_assert!(m.positions.iter().all(|p| p.is_finite()));
                prop_assert!(m.indices.iter().flatten().all(|&i| (i as usize) < m.positions.len()));
            }
        }
    }
}

fn installed(path: &str) -> Option<&Path> {
    let p = Path::new(path);
    if p.exists() {
        Some(p)
    } else {
        println!("skipped: {path} not installed (apt-get install assimp-testmodels glmark2-data)");
        None
    }
}

#[test]
fn real_meshes_when_installed() {
    for (path, min_tris) in [
        ("/usr/share/glmark2/models/bunny.obj", 60_000),
        (
            "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb",
            100_000,
        ),
        ("/usr/share/assimp/models/PLY/cube_binary.ply", 12),
        ("/usr/share/assimp/models/PLY/Wuson.ply", 1000),
    ] {
        let Some(p) = installed(path) else { continue };
        let t = std::time::Instant::now();
        let m = load_mesh(p).unwrap_or_else(|e| panic!("{e}"));
        let loaded = t.elapsed();
        assert!(
            m.triangle_count() >= min_tris,
            "{path}: {} triangles",
            m.triangle_count()
        );
        let scene = vrrt_scene::builtin::showcase("mesh", &m);
        let t = std::time::Instant::now();
        let f = scene.frame(0);
        println!(
            "{path}: {} triangles, loaded in {loaded:?}, frame (BVH) in {:?}, {} nodes",
            m.triangle_count(),
            t.elapsed(),
            f.geometry.nodes.len()
        );
        let (depth, _) = bvh::depth_and_leaves(&f.geometry.nodes);
        assert!(depth < vrrt_core::trace::MAX_DEPTH);
    }
}

#[test]
fn broken_real_files_give_errors() {
    for path in [
        "/usr/share/assimp/models/glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb",
        "/usr/share/assimp/models/glTF2/IndexOutOfRange/IndexOutOfRange.gltf",
        "/usr/share/assimp/models/glTF2/IndexOutOfRange/AllIndicesOutOfRange.gltf",
        "/usr/share/assimp/models/glTF2/MissingBin/BoxTextured.gltf",
        "/usr/share/assimp/models/glTF2/RecursiveNodes/RecursiveNodes.gltf",
        "/usr/share/assimp/models/glTF2/IncorrectVertexArrays/Cube.gltf",
        "/usr/share/assimp/models/glTF2/TestNoRootNode/NoScene.gltf",
        "/usr/share/assimp/models/glTF2/TestNoRootNode/SceneWithoutNodes.gltf",
        "/usr/share/assimp/models/OBJ/box_UTF16BE.obj",
        "/usr/share/assimp/models/OBJ/point_cloud.obj",
        "/usr/share/assimp/models/PLY/points.ply",
    ] {
        let Some(p) = installed(path) else { continue };
        match load_mesh(p) {
            Ok(m) => println!("{path}: loaded {} triangles", m.triangle_count()),
            Err(e) => {
                println!("{e}");
                assert!(e
                    .to_string()
                    .contains(p.file_name().unwrap().to_str().unwrap()));
                assert!(!matches!(e, SceneError::UnsupportedFormat { .. }));
            }
        }
    }
}
