//! What a reference is cached under: everything that changes its pixels.
//!
//! A reference is a function of the frame the renderer reads (triangles, BVH, instances,
//! cameras, lights), the size, the signal with its parameters, the sample count and the
//! estimator's code. The frame enters as a hash of its contents ([`SceneHash`]), not as a name:
//! a user's `room.obj` and the built-in `room` share a name but not a hash, and an edited file
//! or a changed built-in or loader gets a new hash by itself. The name only labels the directory.

use std::fmt;
use std::path::PathBuf;

use crate::render::SignalName;
use crate::FrameGeometry;

/// Version of the reference estimator ([`crate::render::reference`]: its rng stream, batching
/// and standard-error formula) and of this key's layout. Bump it when either changes: older
/// entries are then never looked up again. Since 6 every plane is traced in replicates
/// ([`crate::render::REPLICATES`]); before, only the reflection plane was (5).
pub const ESTIMATOR_VERSION: u32 = 6;

/// The version a signal of reflections alone is keyed with: its one plane has been traced the
/// same way since version 5, so its entries stay valid.
pub const REFLECTIONS_ESTIMATOR_VERSION: u32 = 5;

/// BLAKE3 hash of everything of a frame that the reference renderer reads.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct SceneHash(pub [u8; 32]);

impl SceneHash {
    /// The hash of `frame`: BVH nodes, triangles, normals, instances, both cameras and the
    /// lights, each with its length so that no two different frames hash the same bytes.
    /// Floats are hashed by their bits (the scene is built deterministically, so a rebuild of
    /// the same scene gives the same bits; a different build at worst misses the cache).
    pub fn of_frame(frame: &FrameGeometry) -> SceneHash {
        let mut h = blake3::Hasher::new();
        h.update(b"vrrt-scene frame\0");
        let g = &frame.geometry;
        let mut section = |bytes: &[u8]| {
            h.update(&(bytes.len() as u64).to_le_bytes());
            h.update(bytes);
        };
        section(bytemuck::cast_slice(&g.nodes));
        section(bytemuck::cast_slice(&g.triangles));
        section(bytemuck::cast_slice(&g.normals));
        section(bytemuck::cast_slice(&frame.instances));
        section(bytemuck::bytes_of(&frame.camera));
        section(bytemuck::bytes_of(&frame.prev_camera));
        section(bytemuck::cast_slice(&frame.lights));
        SceneHash(*h.finalize().as_bytes())
    }
}

impl fmt::Display for SceneHash {
    /// Lower-case hex, 64 digits.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.iter().try_for_each(|b| write!(f, "{b:02x}"))
    }
}

/// Everything that determines a reference image's content.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct ReferenceKey {
    /// Scene name (built-in scene id or mesh file stem): labels the directory only, the
    /// content is told by `content`.
    pub scene: String,
    /// Hash of the frame's contents ([`SceneHash::of_frame`]).
    pub content: SceneHash,
    /// Frame index within the scene's animation.
    pub frame: u32,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel the reference was accumulated with.
    pub spp: u64,
    /// What was rendered with which parameters: [`SignalName`]'s `Display`, e.g. `"ao0.5"`.
    pub signal: String,
    /// The caller's own version (e.g. the `vrrt` command's).
    pub version: u32,
    /// The estimator's version: [`ESTIMATOR_VERSION`], or [`REFLECTIONS_ESTIMATOR_VERSION`]
    /// for a signal of reflections alone.
    pub estimator: u32,
}

impl ReferenceKey {
    /// The key of `frame` of scene `scene` rendered at `size` with `signal` (its name with the
    /// reflection settings, [`Signal::name`](crate::render::Signal::name)) and `spp` samples per
    /// pixel, under the caller's `version`.
    pub fn for_frame(
        scene: &str,
        frame: &FrameGeometry,
        (width, height): (u32, u32),
        signal: SignalName<'_>,
        spp: u64,
        version: u32,
    ) -> Self {
        ReferenceKey {
            scene: scene.to_string(),
            content: SceneHash::of_frame(frame),
            frame: frame.index,
            width,
            height,
            spp,
            signal: signal.to_string(),
            version,
            estimator: if signal.is_reflections() {
                REFLECTIONS_ESTIMATOR_VERSION
            } else {
                ESTIMATOR_VERSION
            },
        }
    }

    /// The entry's path relative to the cache root:
    /// `<scene>/<signal>/f<frame>_<w>x<h>_<spp>spp_<hash>_v<version>e<estimator>.exr`, with
    /// the first 16 hex digits of the content hash, and the names sanitised to
    /// `[A-Za-z0-9._-]` (anything else becomes `_`). The whole key is checked on load.
    pub fn relative_path(&self) -> PathBuf {
        let mut p = PathBuf::from(sanitise(&self.scene));
        p.push(sanitise(&self.signal));
        let hash = self.content.to_string();
        p.push(format!(
            "f{:06}_{}x{}_{}spp_{}_v{}e{}.exr",
            self.frame,
            self.width,
            self.height,
            self.spp,
            &hash[..16],
            self.version,
            self.estimator
        ));
        p
    }

    /// Unambiguous ASCII description stored in, and checked against, the entry.
    pub(super) fn canonical(&self) -> String {
        format!(
            "scene=\"{}\";content={};signal=\"{}\";frame={};size={}x{};spp={};version={};\
             estimator={}",
            self.scene.escape_default(),
            self.content,
            self.signal.escape_default(),
            self.frame,
            self.width,
            self.height,
            self.spp,
            self.version,
            self.estimator
        )
    }
}

impl fmt::Display for ReferenceKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.canonical())
    }
}

/// A file-name component from arbitrary text: keeps `[A-Za-z0-9._-]`, maps the rest to `_`, and
/// never yields an empty, `.` or `..` component.
fn sanitise(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.chars().all(|c| c == '.') {
        format!("_{s}")
    } else {
        s
    }
}
