//! Seeded mutation fuzzing of the mesh loaders, in the default test loop: for each format (OBJ,
//! ASCII PLY, binary PLY, PLY.gz, glTF, GLB), [`INPUTS`] deterministic mutations of valid files
//! through the public loading API ([`load_mesh_from_reader`]) under tight [`LoadLimits`]. Every
//! input must give a valid mesh (finite, indices in range, unit normals, visible, within the
//! limits, and a scene with finite geometry around it) or a typed [`SceneError`] naming the
//! file: no panic, no hang, no input slower than [`PER_INPUT`], none holding more than
//! [`PER_INPUT_MEMORY`], and the process's peak RSS under [`PEAK_RSS`].
//!
//! `cargo test -p vrrt-scene --test fuzz -- --nocapture` prints one summary line per format;
//! `VRRT_FUZZ_INPUTS=N` tries N inputs per format instead (more for a longer soak; the
//! cargo-fuzz targets in `fuzz/` are the open-ended version). The mutator, the runner and the
//! counting allocator are in `fuzzkit/`, shared with the CLI's fuzz test.

mod fuzzkit;
#[path = "fuzz/seeds.rs"]
mod seeds;

use fuzzkit::{Bounds, Inputs, Mutator, Report, Verdict, MIB};
use seeds::{
    corpus, glb, gltf_docs, gltf_external, gltf_text, gzip, obj_seeds, ply_ascii_seeds,
    ply_binary_seeds, GLTF_WORDS, OBJ_WORDS, PLY_WORDS,
};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use vrrt_scene::load::{load_mesh_from_reader, LoadLimits};
use vrrt_scene::{builtin, bvh, Mesh, SceneError};

/// Longest mutated input (before gzip).
const MAX_LEN: usize = 12 << 10;

/// Tight limits: small enough that mutated counts, repeats and gzip bombs hit them.
fn limits() -> LoadLimits {
    LoadLimits {
        max_file_size: 16 << 10,
        max_decompressed_size: 64 << 10,
        max_vertices: 512,
        max_triangles: 512,
        max_bvh_bytes: bvh::memory_bound(512),
    }
}

// ---- Checks. ---------------------------------------------------------------------------------

/// A loaded mesh is valid: what [`Mesh::new`] promises, within the limits and visible. Then, as
/// `vrrt` does with a mesh file, it is placed in [`builtin::showcase`]'s scene and that scene is
/// validated: the scene is refused with a typed error (`Ok(Some(kind))`), or its frame has finite
/// triangles and normals and a BVH of bounded depth (`Ok(None)`).
fn check_mesh(path: &Path, m: &Mesh, limits: &LoadLimits) -> Result<Option<&'static str>, String> {
    let n = m.positions.len();
    if m.triangle_count() == 0 {
        return Err("Ok with no triangles".into());
    }
    if n as u64 > limits.max_vertices || m.triangle_count() as u64 > limits.max_triangles {
        return Err(format!(
            "Ok past the limits: {n} vertices, {} triangles",
            m.triangle_count()
        ));
    }
    if let Some(p) = m.positions.iter().find(|p| !p.is_finite()) {
        return Err(format!("non-finite vertex {p}"));
    }
    if let Some(t) = m
        .indices
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= n))
    {
        return Err(format!("triangle {t:?} out of range of {n} vertices"));
    }
    if m.normals.len() != n {
        return Err(format!("{} normals for {n} vertices", m.normals.len()));
    }
    if let Some(v) = m
        .normals
        .iter()
        .find(|v| !v.is_finite() || (v.length() - 1.0).abs() > 1e-3)
    {
        return Err(format!("normal {v} is not a unit vector"));
    }
    m.check_visible(path)
        .map_err(|e| format!("Ok but not visible: {e}"))?;
    let scene = builtin::showcase("fuzz", m);
    if let Err(e) = scene.validate() {
        return Ok(Some(kind(&e)));
    }
    let frame = scene.frame(0);
    let g = &frame.geometry;
    if let Some(t) = g
        .triangles
        .iter()
        .find(|t| !(t.v0().is_finite() && t.v1().is_finite() && t.v2().is_finite()))
    {
        return Err(format!(
            "the showcase scene has a non-finite triangle {t:?}"
        ));
    }
    let normals: &[f32] = bytemuck::cast_slice(&g.normals);
    if normals.iter().any(|x| !x.is_finite()) {
        return Err("the showcase scene has a non-finite normal".into());
    }
    let (depth, _) = bvh::depth_and_leaves(&g.nodes);
    if depth >= vrrt_core::trace::MAX_DEPTH {
        return Err(format!("BVH depth {depth}"));
    }
    Ok(None)
}

fn kind(e: &SceneError) -> &'static str {
    match e {
        SceneError::Io { .. } => "Io",
        SceneError::Parse { .. } => "Parse",
        SceneError::InvalidGeometry { .. } => "InvalidGeometry",
        SceneError::NoTriangles { .. } => "NoTriangles",
        SceneError::WrongFormat { .. } => "WrongFormat",
        SceneError::LimitExceeded { .. } => "LimitExceeded",
        SceneError::ZeroSize { .. } => "ZeroSize",
        SceneError::AllDegenerate { .. } => "AllDegenerate",
        SceneError::UnsupportedFormat { .. } => "UnsupportedFormat",
        SceneError::UnknownScene { .. } => "UnknownScene",
        SceneError::MeshNotFetched { .. } => "MeshNotFetched",
        SceneError::InvalidScene { .. } => "InvalidScene",
    }
}

/// For OBJ and plain PLY: the same bytes after a UTF-8 byte-order mark give the same mesh (a
/// mark once glued itself to the first keyword and shifted every index, issue 47).
fn check_bom(path: &Path, bytes: &[u8], m: &Mesh, limits: &LoadLimits) -> Result<(), String> {
    let name = path.to_string_lossy().to_ascii_lowercase();
    if !(name.ends_with(".obj") || name.ends_with(".ply")) || bytes.starts_with(b"\xEF\xBB\xBF") {
        return Ok(());
    }
    let marked = [&b"\xEF\xBB\xBF"[..], bytes].concat();
    match load_mesh_from_reader(path, &marked[..], limits) {
        Ok(with_mark) if &with_mark == m => Ok(()),
        Ok(_) => Err("a byte-order mark changed the mesh".into()),
        // The mark adds 3 bytes: a file at the size limit may now pass it.
        Err(SceneError::LimitExceeded { .. }) => Ok(()),
        Err(e) => Err(format!("a byte-order mark made a valid file fail: {e}")),
    }
}

/// Loads `bytes` as the file `path` and judges the result.
fn check_load(path: &Path, bytes: &[u8], limits: &LoadLimits) -> Result<Verdict, String> {
    match load_mesh_from_reader(path, bytes, limits) {
        Ok(m) => Ok(match check_mesh(path, &m, limits)? {
            None => {
                check_bom(path, bytes, &m, limits)?;
                Verdict::Valid
            }
            Some(kind) => Verdict::Error(kind),
        }),
        Err(e) => {
            let msg = e.to_string();
            let name = path.file_name().unwrap().to_string_lossy();
            let dir = path.parent().unwrap().display().to_string();
            // A glTF buffer file's errors name that file, in the glTF file's directory.
            if !(msg.contains(&*name) || msg.contains(&dir)) {
                return Err(format!("the error does not name the file: {msg}"));
            }
            match e {
                SceneError::UnsupportedFormat { .. }
                | SceneError::UnknownScene { .. }
                | SceneError::MeshNotFetched { .. }
                | SceneError::InvalidScene { .. } => {
                    Err(format!("an error no mesh file can give: {msg}"))
                }
                e => Ok(Verdict::Error(kind(&e))),
            }
        }
    }
}

/// Fuzzes one format: `inputs` loaded as `name` in a fresh directory (where glTF buffer URIs
/// resolve; `files` are written there first).
fn fuzz(format: &str, name: &str, files: &[(&str, Vec<u8>)], inputs: Inputs) -> Report {
    let dir = tempfile::tempdir().unwrap();
    for (file, bytes) in files {
        std::fs::write(dir.path().join(file), bytes).unwrap();
    }
    let path: PathBuf = dir.path().join(name);
    let limits = limits();
    let bounds = Bounds::standard();
    let report = fuzzkit::run(format, inputs.clone(), bounds, move |_, bytes| {
        check_load(&path, bytes, &limits)
    });
    report.finish(&bounds, &inputs);
    drop(dir);
    report
}

/// Asserts every seed loads (under the tight limits), so the mutations start from valid files.
fn assert_seeds_load(name: &str, seeds: &[Vec<u8>], files: &[(&str, Vec<u8>)]) {
    let dir = tempfile::tempdir().unwrap();
    for (file, bytes) in files {
        std::fs::write(dir.path().join(file), bytes).unwrap();
    }
    let path = dir.path().join(name);
    for (i, s) in seeds.iter().enumerate() {
        match check_load(&path, s, &limits()) {
            Ok(Verdict::Valid) => {}
            Ok(Verdict::Error(k)) => panic!(
                "{name} seed {i} does not load ({k}: {}): b\"{}\"",
                load_mesh_from_reader(&path, &s[..], &limits()).unwrap_err(),
                s.escape_ascii()
            ),
            Err(e) => panic!("{name} seed {i}: {e}"),
        }
    }
}

// ---- One test per format. ----------------------------------------------------------------------

#[test]
fn fuzz_obj() {
    let seeds = obj_seeds();
    assert_seeds_load("fuzz.obj", &seeds, &[]);
    let m = Mutator::new(seeds, OBJ_WORDS, MAX_LEN, 0x0b1);
    fuzz("obj", "fuzz.obj", &[], m.into_inputs());
}

#[test]
fn fuzz_ply_ascii() {
    let seeds = ply_ascii_seeds();
    assert_seeds_load("fuzz.ply", &seeds, &[]);
    let m = Mutator::new(seeds, PLY_WORDS, MAX_LEN, 0xa5c11);
    fuzz("ply-ascii", "fuzz.ply", &[], m.into_inputs());
}

#[test]
fn fuzz_ply_binary() {
    let seeds = ply_binary_seeds();
    assert_seeds_load("fuzz.ply", &seeds, &[]);
    let m = Mutator::new(seeds, PLY_WORDS, MAX_LEN, 0xb1a);
    fuzz("ply-binary", "fuzz.ply", &[], m.into_inputs());
}

/// Half the inputs are mutated PLY files, gzipped (the PLY parser behind the inflater); half are
/// mutated `.ply.gz` bytes (the gzip header, the deflate stream, the CRC), a gzip bomb among the
/// seeds.
#[test]
fn fuzz_ply_gz() {
    let plain: Vec<Vec<u8>> = ply_ascii_seeds()
        .into_iter()
        .chain(ply_binary_seeds())
        .collect();
    let mut gz: Vec<Vec<u8>> = plain.iter().map(|s| gzip(s)).collect();
    assert_seeds_load("fuzz.ply.gz", &gz, &[]);
    // A bomb: a valid header, then 1 MiB of zeros (about 1 KiB gzipped).
    let mut bomb = ply_binary_seeds()[1].clone();
    bomb.resize(bomb.len() + MIB, 0);
    gz.push(gzip(&bomb));
    let inner = Mutator::new(plain, PLY_WORDS, MAX_LEN, 0x9a1);
    let outer = Mutator::new(gz, &[], MAX_LEN, 0x9a2);
    let inputs: Inputs = Arc::new(move |i| {
        if i % 2 == 0 {
            gzip(&inner.input(i))
        } else {
            outer.input(i)
        }
    });
    fuzz("ply.gz", "fuzz.ply.gz", &[], inputs);
}

/// `.gltf` with data URIs and with an external `buffer.bin` (written beside the file).
#[test]
fn fuzz_gltf() {
    let docs = gltf_docs();
    let (ext_json, ext_bin) = &docs[0];
    let files = [("buffer.bin", ext_bin.clone())];
    let mut seeds = vec![corpus("tri.gltf")];
    seeds.extend(docs.iter().map(|(j, b)| gltf_text(j, b)));
    seeds.push(gltf_external(ext_json, ext_bin));
    assert_seeds_load("fuzz.gltf", &seeds, &files);
    let m = Mutator::new(seeds, GLTF_WORDS, MAX_LEN, 0x91f);
    fuzz("gltf", "fuzz.gltf", &files, m.into_inputs());
}

#[test]
fn fuzz_glb() {
    let mut seeds = vec![corpus("tri.glb")];
    seeds.extend(gltf_docs().iter().map(|(j, b)| glb(j, b)));
    assert_seeds_load("fuzz.glb", &seeds, &[]);
    let m = Mutator::new(seeds, GLTF_WORDS, MAX_LEN, 0x91b);
    fuzz("glb", "fuzz.glb", &[], m.into_inputs());
}
