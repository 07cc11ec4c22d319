//! Ground-truth references of a sequence's frames: loaded from the on-disk cache, else traced on
//! the backend and stored, so that runs and benches trace each reference once.

use super::recycle::BufferPool;
use super::{mean, planes_to_image};
use crate::progress::Progress;
use anyhow::{anyhow, Result};
use std::cell::RefCell;
use std::path::Path;
use vrrt_backend::Backend;
use vrrt_core::settings::ReflectionSettings;
use vrrt_scene::image::Image;
use vrrt_scene::reference_cache::{ReferenceCache, ReferenceKey, StdErr};
use vrrt_scene::render::{self, Signal};
use vrrt_scene::FrameGeometry;

/// Version of the reference cache entries this command writes and reads; bump it when the
/// renderer's estimator changes so that stale references are not reused.
pub const REFERENCE_VERSION: u32 = 1;

/// A reference image and its standard error.
#[derive(Clone)]
pub struct FrameReference {
    /// The converged image, interleaved planes.
    pub image: Image,
    /// Mean over pixels and planes of the per-pixel standard error.
    pub mean_stderr: f64,
    /// Per-pixel standard error (one channel, or as many as `image`), where known.
    pub stderr: Option<Image>,
    /// True when it came from the cache.
    pub cached: bool,
}

/// Which reference [`References::get`] returns: one frame of one scene at one size, signal and
/// sample count (the fields of its cache key).
pub struct ReferenceRequest<'a> {
    /// Name the scene's references are cached under
    /// ([`LoadedScene::key`](super::LoadedScene::key)).
    pub scene_key: &'a str,
    /// The frame.
    pub frame: &'a FrameGeometry,
    /// Width and height.
    pub size: (u32, u32),
    /// The signal (one part's, see [`parts`](super::parts)).
    pub signal: Signal,
    /// The reflection passes' settings, for a signal with reflections.
    pub reflections: &'a ReflectionSettings,
    /// Reference samples per pixel.
    pub spp: u32,
}

/// Where references come from: the on-disk cache, else traced (and then stored).
///
/// The executor buffers of the references it traces are kept and reused (executors cannot
/// free a buffer, and each reference made its own would keep a copy of the geometry), so one
/// `References` serves one executor: open another for another backend.
pub struct References {
    cache: Option<ReferenceCache>,
    /// Show the progress of each reference traced.
    pub progress: bool,
    buffers: RefCell<render::ReferenceBuffers>,
    /// The renderers' buffers of the sequences run on the same executor ([`super::run_sequence`]).
    pub(super) pool: RefCell<BufferPool>,
}

impl References {
    /// The cache at [`ReferenceCache::from_env`] (none if no cache directory can be found).
    pub fn from_env(progress: bool) -> Self {
        let cache = ReferenceCache::from_env();
        if cache.is_none() {
            eprintln!("note: no reference cache directory (set $VRRT_REFERENCE_CACHE or $HOME); references are traced every time");
        }
        References {
            cache,
            progress,
            buffers: RefCell::default(),
            pool: RefCell::default(),
        }
    }

    /// The cache directory, if any.
    pub fn cache_dir(&self) -> Option<&Path> {
        self.cache.as_ref().map(|c| c.root())
    }

    /// The reference `request` names: from the cache, or traced on `exec` with `request.spp`
    /// samples per pixel and stored.
    pub fn get(&self, exec: &mut Backend, request: ReferenceRequest<'_>) -> Result<FrameReference> {
        let ReferenceRequest {
            scene_key,
            frame: f,
            size: (width, height),
            signal,
            reflections,
            spp,
        } = request;
        let key = ReferenceKey::for_frame(
            scene_key,
            f,
            (width, height),
            signal.name(reflections),
            spp as u64,
            REFERENCE_VERSION,
        );
        let planes = signal.planes(f.lights.len());
        if let Some(hit) = self.cache.as_ref().and_then(|c| c.load(&key)) {
            let (mean_stderr, stderr) = match hit.stderr {
                StdErr::Scalar(v) => (v, None),
                StdErr::Image(img) => (mean(img.data()), Some(img)),
            };
            return Ok(FrameReference {
                image: hit.image,
                mean_stderr,
                stderr,
                cached: true,
            });
        }
        let frame = f.index;
        let mut bar = None;
        let mut buffers = self.buffers.borrow_mut();
        let r = render::reference_with(
            exec,
            &mut buffers,
            f,
            (width, height),
            render::ReferenceSpec {
                signal,
                reflections,
                spp,
            },
            |done, total| {
                if self.progress {
                    bar.get_or_insert_with(|| {
                        let what = match signal {
                            Signal::Ao { .. } => "ao",
                            Signal::Shadows => "shadows",
                            Signal::Reflections => "reflections",
                            Signal::All { .. } => "all",
                        };
                        Progress::new(
                            format!("reference of frame {frame} ({what}), spp"),
                            total.into(),
                            1,
                        )
                    })
                    .set(done.into(), String::new);
                }
            },
        )
        .map_err(|e| anyhow!("tracing the reference of frame {frame}: {e}"))?;
        drop(bar);
        let image = planes_to_image(&r.mean, width, height, planes);
        let stderr = planes_to_image(&r.stderr, width, height, planes);
        let mean_stderr = mean(&r.stderr);
        if let Some(cache) = &self.cache {
            if let Err(e) = cache.store(&key, image.view(), &StdErr::Image(stderr.clone())) {
                eprintln!("warning: reference not cached: {e}");
            }
        }
        Ok(FrameReference {
            image,
            mean_stderr,
            stderr: Some(stderr),
            cached: false,
        })
    }
}
