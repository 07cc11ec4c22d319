//! Renders a scene's frames through any executor: the G-buffer pass, the denoiser's plan, and
//! raygen of the chosen signal; and converged references traced with the very same estimator.

use crate::scene::FrameGeometry;
use std::sync::Arc;
use vrrt_core::denoiser::{
    Denoiser, DenoiserError, FrameInfo, GradientRays, GradientScene, Settings, SettingsError,
};
use vrrt_core::gbuffer::Surface;
use vrrt_core::kernels::apply::LIST_GROUP;
use vrrt_core::kernels::atrous::Filtered;
use vrrt_core::kernels::balance::Balance;
use vrrt_core::kernels::gradient::{GradientSample, EMPTY_KEY};
use vrrt_core::kernels::{self, classify, gbuffer, raygen};
use vrrt_core::payload::{Payload, Sample};
use vrrt_core::plan::{BufferId, Executor};
use vrrt_core::reflections::{RaygenTarget, ReflectionScene, ReflectionSettings, Reflections};

/// The ray-traced signal being denoised.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Signal {
    /// Ambient occlusion with a maximum distance (one plane).
    Ao {
        /// Occluders beyond this distance do not count.
        max_distance: f32,
    },
    /// Area-light shadows: one plane per light of the scene (up to 4).
    Shadows,
    /// Glossy reflections (`vrrt_core::reflections`, one plane).
    Reflections(ReflectionSettings),
    /// AO, the shadows of every light and reflections in one frame: planes AO, shadows…,
    /// reflections, sharing reprojection and one ray budget.
    All {
        /// AO radius.
        max_distance: f32,
        /// The reflections' settings.
        reflections: ReflectionSettings,
    },
}

/// Where each signal of a [`Signal`] lives among the denoiser's planes.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct PlaneLayout {
    /// The AO plane.
    pub ao: Option<u32>,
    /// First shadow plane and how many (one per light).
    pub shadows: Option<(u32, u32)>,
    /// The reflection plane.
    pub reflections: Option<u32>,
    /// Planes in all.
    pub planes: u32,
}

impl Signal {
    /// The planes of each signal for a frame with `lights` lights.
    pub fn layout(&self, lights: usize) -> PlaneLayout {
        let shadows = lights.clamp(1, 4) as u32;
        match self {
            Signal::Ao { .. } => PlaneLayout {
                ao: Some(0),
                planes: 1,
                ..PlaneLayout::default()
            },
            Signal::Shadows => PlaneLayout {
                shadows: Some((0, shadows)),
                planes: shadows,
                ..PlaneLayout::default()
            },
            Signal::Reflections(_) => PlaneLayout {
                reflections: Some(0),
                planes: 1,
                ..PlaneLayout::default()
            },
            Signal::All { .. } => PlaneLayout {
                ao: Some(0),
                shadows: Some((1, shadows)),
                reflections: Some(1 + shadows),
                planes: 2 + shadows,
            },
        }
    }

    /// Signal planes for a frame with `lights` lights.
    pub fn planes(&self, lights: usize) -> u32 {
        self.layout(lights).planes
    }

    /// The AO radius, when the signal has AO.
    fn ao_distance(&self) -> Option<f32> {
        match *self {
            Signal::Ao { max_distance } | Signal::All { max_distance, .. } => Some(max_distance),
            _ => None,
        }
    }

    /// The reflections' settings, when the signal has reflections.
    pub fn reflections(&self) -> Option<ReflectionSettings> {
        match *self {
            Signal::Reflections(r) | Signal::All { reflections: r, .. } => Some(r),
            _ => None,
        }
    }

    /// Short name, used in file names and cache keys: it names everything the estimator
    /// depends on (reflections: roughness cut-off and hit lighting, not reuse or tiles).
    pub fn name(&self) -> String {
        let reflect = |r: &ReflectionSettings| {
            format!(
                "reflect{}-{}-{}-{}-{}",
                r.max_roughness, r.light_radiance, r.albedo, r.sky, r.ambient
            )
        };
        match self {
            Signal::Ao { max_distance } => format!("ao{max_distance}"),
            Signal::Shadows => "shadows".into(),
            Signal::Reflections(r) => reflect(r),
            Signal::All {
                max_distance,
                reflections,
            } => format!("all-ao{max_distance}-{}", reflect(reflections)),
        }
    }
}

fn bytes<T: bytemuck::Pod>(v: &[T]) -> &[u8] {
    bytemuck::cast_slice(v)
}

/// Reads `len` elements of `T` from a buffer.
pub fn read<T: bytemuck::Pod + Default, E: Executor>(
    exec: &mut E,
    id: BufferId,
    len: usize,
) -> Result<Vec<T>, E::Error> {
    let mut out = vec![T::default(); len];
    exec.read_buffer(id, bytemuck::cast_slice_mut(&mut out))?;
    Ok(out)
}

/// A growable buffer: recreated only when a larger size is needed.
#[derive(Copy, Clone, Debug)]
struct Slot {
    id: BufferId,
    bytes: u64,
}

fn ensure<E: Executor>(
    exec: &mut E,
    slot: &mut Option<Slot>,
    data: &[u8],
) -> Result<BufferId, E::Error> {
    let need = (data.len() as u64).max(4).next_multiple_of(4);
    let s = match *slot {
        Some(s) if s.bytes >= need => s,
        _ => {
            let s = Slot {
                id: exec.create_buffer(need)?,
                bytes: need,
            };
            *slot = Some(s);
            s
        }
    };
    if !data.is_empty() {
        exec.write_buffer(s.id, data)?;
    }
    Ok(s.id)
}

/// A frame's geometry on the executor; static geometry is uploaded once.
#[derive(Default)]
pub struct GpuScene {
    nodes: Option<Slot>,
    tris: Option<Slot>,
    normals: Option<Slot>,
    instances: Option<Slot>,
    lights: Option<Slot>,
    next: Option<Slot>,
    uploaded: Option<Arc<crate::scene::Geometry>>,
}

impl GpuScene {
    /// Uploads what changed since the last frame.
    pub fn upload<E: Executor>(&mut self, exec: &mut E, f: &FrameGeometry) -> Result<(), E::Error> {
        if !self
            .uploaded
            .as_ref()
            .is_some_and(|g| Arc::ptr_eq(g, &f.geometry))
        {
            ensure(exec, &mut self.nodes, bytes(&f.geometry.nodes))?;
            ensure(exec, &mut self.tris, bytes(&f.geometry.triangles))?;
            ensure(exec, &mut self.normals, bytes(&f.geometry.normals))?;
            self.uploaded = Some(f.geometry.clone());
        }
        ensure(exec, &mut self.instances, bytes(&f.instances))?;
        ensure(exec, &mut self.lights, bytes(&f.lights))?;
        // Previous→current maps for the temporal-gradient prepass (forward projection).
        let next: Vec<_> = f.instances.iter().map(|i| i.inverse()).collect();
        ensure(exec, &mut self.next, bytes(&next))?;
        Ok(())
    }

    fn ids(&self) -> [BufferId; 5] {
        let id = |s: &Option<Slot>| s.expect("GpuScene::upload first").id;
        [
            id(&self.nodes),
            id(&self.tris),
            id(&self.normals),
            id(&self.instances),
            id(&self.lights),
        ]
    }

    /// What the denoiser's temporal-gradient prepass re-traces against for `signal` in frame `f`;
    /// `None` for signals it cannot re-trace (reflections).
    pub fn gradient_scene(&self, f: &FrameGeometry, signal: Signal) -> Option<GradientScene> {
        let [nodes, tris, _, _, lights] = self.ids();
        let rays = match signal {
            Signal::Ao { max_distance } => GradientRays::Ao { max_distance },
            Signal::Shadows => GradientRays::Shadows { lights },
            Signal::Reflections(_) | Signal::All { .. } => return None,
        };
        Some(GradientScene {
            nodes,
            tris,
            next: self.next.expect("GpuScene::upload first").id,
            camera: f.camera,
            rays,
        })
    }

    /// What the reflection passes trace against in frame `f`.
    pub fn reflection_scene(&self, f: &FrameGeometry) -> ReflectionScene {
        let [nodes, tris, _, _, lights] = self.ids();
        ReflectionScene {
            nodes,
            tris,
            lights,
            light_count: f.lights.len() as u32,
            camera: f.camera,
            prev_camera: f.prev_camera,
        }
    }

    /// Records the G-buffer pass into `surfaces`.
    pub fn gbuffer<E: Executor>(
        &self,
        exec: &mut E,
        f: &FrameGeometry,
        width: u32,
        height: u32,
        surfaces: BufferId,
    ) -> Result<(), E::Error> {
        let [nodes, tris, normals, instances, _] = self.ids();
        let p = f.gbuffer_params(width, height);
        let pass = kernels::GbufferBindings {
            nodes,
            tris,
            normals,
            instances,
            out: surfaces,
        };
        exec.dispatch(&pass.over_grid(&p, width, height, 1))
    }

    /// Records raygen of the AO and shadow planes of `signal` over `target`'s work list;
    /// reflections are traced by [`Reflections`].
    pub fn raygen<E: Executor>(
        &self,
        exec: &mut E,
        signal: Signal,
        lights: usize,
        target: &RaygenTarget,
    ) -> Result<(), E::Error> {
        let [nodes, tris, _, _, light_buffer] = self.ids();
        let (width, height) = target.size;
        let layout = signal.layout(lights);
        let ao = kernels::RaygenAoBindings {
            work: target.work,
            args: target.args,
            rays: target.rays,
            surfaces: target.surfaces,
            history: target.history,
            nodes,
            tris,
            out: target.out,
        };
        if let Some(max_distance) = signal.ao_distance() {
            let p = raygen::AoParams {
                width,
                height,
                planes: 1,
                max_distance,
            };
            exec.dispatch(&ao.pass(&p, target.groups()))?;
        }
        if let Some((first_plane, planes)) = layout.shadows {
            let p = raygen::ShadowParams {
                width,
                height,
                planes,
                first_plane,
            };
            let shadow = kernels::RaygenShadowBindings {
                work: ao.work,
                args: ao.args,
                rays: ao.rays,
                surfaces: ao.surfaces,
                history: ao.history,
                nodes,
                tris,
                lights: light_buffer,
                out: ao.out,
            };
            exec.dispatch(&shadow.pass(&p, target.groups()))?;
        }
        Ok(())
    }
}

/// What to read back after a frame (each costs a copy from the device).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Readback {
    /// Requests, granted rays and history lengths (the debug overlays).
    pub overlays: bool,
}

/// One rendered frame, all planes stacked (`plane * width * height + pixel`).
#[derive(Clone, Debug, Default)]
pub struct FrameOutput {
    /// Denoised signal.
    pub denoised: Vec<f32>,
    /// This frame's raw samples (mean of the rays traced; 0 where none).
    pub raw: Vec<f32>,
    /// Rays traced per pixel (all planes trace the same count).
    pub rays: Vec<u32>,
    /// Rays traced in the frame, per plane.
    pub rays_traced: u64,
    /// The load balancer's decision.
    pub decision: Balance,
    /// Per-pixel flags of reprojection (`reproject::FLAG_*`).
    pub flags: Vec<u32>,
    /// Overlays, when asked for: requested bucket per pixel.
    pub requests: Vec<u32>,
    /// Overlays: history length (plane 0) after reprojection.
    pub history_reprojected: Vec<f32>,
    /// Overlays: history length (plane 0) after accumulation.
    pub history_accumulated: Vec<f32>,
    /// Whether the temporal-gradient prepass ran this frame (false: off, reset, or skipped
    /// because nothing moved).
    pub gradient_ran: bool,
    /// Rays the gradient prepass re-traced (over all planes; 0 when it did not run).
    pub gradient_rays: u64,
    /// Gradient cells across and down (stratum resolution).
    pub gradient_size: (u32, u32),
    /// Overlays, when the prepass ran: raw `λ` per cell and plane (plane-stacked).
    pub gradient_raw: Vec<f32>,
    /// Overlays, when the prepass ran: reconstructed `λ` per cell and plane.
    pub gradient: Vec<f32>,
    /// The frame's signal has no source (shadows without a light): nothing was traced or
    /// denoised, `denoised` is all 1 (unshadowed), and the next frame with a source starts fresh.
    pub signal_absent: bool,
    /// 8×8 tiles of the spatial filter (`Denoiser::tile_histogram`): without geometry, then
    /// needing 0, 1, … 5 à-trous iterations.
    pub tiles: [u32; classify::HISTOGRAM_LEN as usize],
}

impl FrameOutput {
    /// À-trous tile-iterations over the tiles with geometry: `(run, configured)`, where every such
    /// tile would run `iterations` with nothing skipped (`classify` never asks for more).
    pub fn filter_work(&self, iterations: u32) -> (u64, u64) {
        let mut work = (0, 0);
        for n in 0..=5 {
            let tiles = self.tiles[1 + n] as u64;
            work.0 += tiles * n as u64;
            work.1 += tiles * iterations as u64;
        }
        work
    }
}

/// Runs a scene frame by frame through the denoiser.
pub struct Renderer {
    width: u32,
    height: u32,
    signal: Signal,
    planes: u32,
    lights: usize,
    denoiser: Denoiser,
    reflections: Option<Reflections>,
    gpu: GpuScene,
    frames: u32,
    prev_lights: Vec<raygen::AreaLight>,
    /// The last frame ran no passes (its signal was absent): history is stale.
    resume: bool,
}

impl Renderer {
    /// A renderer for `width × height` with denoiser `settings` (its `planes` and
    /// `parallax_plane` are set from the signal and the number of lights). Reflections cannot be
    /// re-traced by the temporal-gradient prepass, so with them `gradient_stratum` must be 0.
    pub fn new<E: Executor>(
        exec: &mut E,
        width: u32,
        height: u32,
        signal: Signal,
        lights: usize,
        mut settings: Settings,
    ) -> Result<Self, DenoiserError<E::Error>> {
        let layout = signal.layout(lights);
        settings.planes = layout.planes;
        settings.parallax_plane = layout
            .reflections
            .filter(|_| signal.reflections().is_some_and(|r| r.parallax));
        if layout.reflections.is_some() && settings.gradient_stratum != 0 {
            return Err(DenoiserError::Settings(SettingsError::OutOfRange {
                field: "gradient_stratum",
                value: settings.gradient_stratum as f32,
                range: "0 with reflections (the prepass has no reflection re-trace)",
            }));
        }
        let denoiser = Denoiser::new(exec, width, height, settings)?;
        let reflections = match (layout.reflections, signal.reflections()) {
            (Some(plane), Some(r)) => Some(Reflections::new(exec, width, height, plane, r)?),
            _ => None,
        };
        Ok(Renderer {
            width,
            height,
            signal,
            planes: settings.planes,
            lights,
            denoiser,
            reflections,
            gpu: GpuScene::default(),
            frames: 0,
            prev_lights: Vec::new(),
            resume: false,
        })
    }

    /// The reflection effect, when the signal has reflections.
    pub fn reflections(&self) -> Option<&Reflections> {
        self.reflections.as_ref()
    }

    /// The denoiser (buffers, settings).
    pub fn denoiser(&self) -> &Denoiser {
        &self.denoiser
    }

    /// Renders one frame and reads back its outputs.
    pub fn render<E: Executor>(
        &mut self,
        exec: &mut E,
        f: &FrameGeometry,
        readback: Readback,
    ) -> Result<FrameOutput, E::Error> {
        let (w, h, planes) = (self.width, self.height, self.planes);
        if self.signal == Signal::Shadows && f.lights.is_empty() {
            // A signal the scene lacks costs zero passes.
            self.resume = true;
            self.prev_lights.clear();
            return Ok(FrameOutput {
                denoised: vec![1.0; (w * h * planes) as usize],
                raw: vec![1.0; (w * h * planes) as usize],
                rays: vec![0; (w * h) as usize],
                signal_absent: true,
                ..FrameOutput::default()
            });
        }
        let d = &mut self.denoiser;
        // Nothing moved: same camera, every instance map the identity, same lights. Then the
        // gradient prepass is skipped (every re-trace would repeat last frame's ray exactly).
        let identity = gbuffer::InstanceData::default();
        let still = |i: &gbuffer::InstanceData| {
            *i == gbuffer::InstanceData {
                roughness: i.roughness,
                ..identity
            }
        };
        let moved = f.camera != f.prev_camera
            || !f.instances.iter().all(still)
            || f.lights != self.prev_lights;
        self.prev_lights = f.lights.clone();
        d.begin_frame(FrameInfo {
            index: self.frames,
            reset: self.frames == 0 || f.camera_cut || self.resume,
            pixel_angle: 2.0 * f.camera.tan_half_fov_y / h as f32,
            use_mask: false,
            moved,
            use_importance: self.reflections.is_some(),
        });
        self.frames += 1;
        self.resume = false;
        self.gpu.upload(exec, f)?;
        self.gpu.gbuffer(exec, f, w, h, d.surfaces())?;
        let gradient_ran = match self.gpu.gradient_scene(f, self.signal) {
            Some(scene) => d.temporal_gradients(exec, &scene)?,
            None => false,
        };
        let reflection_scene = self.gpu.reflection_scene(f);
        if let Some(r) = &self.reflections {
            r.prepare(exec, d, &reflection_scene)?;
        }
        let mut gradient_rays = 0;
        let gradient_size = d.gradient_size();
        let mut gradient_overlays = (Vec::new(), Vec::new());
        if gradient_ran {
            let cells = (gradient_size.0 * gradient_size.1) as usize;
            let keys: Vec<u32> = read(exec, d.gradient_keys(), cells)?;
            gradient_rays = keys.iter().filter(|&&k| k != EMPTY_KEY).count() as u64 * planes as u64;
            if readback.overlays {
                let lambda = |g: Vec<GradientSample>| g.iter().map(|g| g.lambda()).collect();
                let n = cells * planes as usize;
                gradient_overlays = (
                    lambda(read(exec, d.gradient_raw(), n)?),
                    lambda(read(exec, d.gradient(), n)?),
                );
            }
        }
        d.plan_rays(exec)?;
        self.gpu
            .raygen(exec, self.signal, self.lights, &RaygenTarget::of(d))?;
        if let Some(r) = &self.reflections {
            r.trace(exec, d, &reflection_scene)?;
        }
        let overlays_before = if readback.overlays {
            Some((
                read::<u32, E>(exec, d.requests(), (w * h) as usize)?,
                read::<Payload, E>(exec, d.reprojected(), (w * h) as usize)?,
            ))
        } else {
            None
        };
        d.resolve(exec)?;
        let n = (w * h * planes) as usize;
        let denoised: Vec<Filtered> = read(exec, d.output(), n)?;
        let samples: Vec<Sample> = read(exec, d.samples(), n)?;
        let rays: Vec<u32> = read(exec, d.rays(), (w * h) as usize)?;
        let decision: Vec<Balance> = read(exec, d.decision(), 1)?;
        let flags: Vec<u32> = read(exec, d.flags(), (w * h) as usize)?;
        let tiles: Vec<u32> = read(exec, d.tile_histogram(), classify::HISTOGRAM_LEN as usize)?;
        let mut out = FrameOutput {
            denoised: denoised.iter().map(|f| f.value).collect(),
            raw: samples
                .iter()
                .map(|s| if s.rays > 0 { s.m1 } else { 0.0 })
                .collect(),
            rays_traced: rays.iter().map(|&r| r as u64).sum(),
            rays,
            decision: decision[0],
            flags,
            gradient_ran,
            gradient_rays,
            gradient_size,
            gradient_raw: gradient_overlays.0,
            gradient: gradient_overlays.1,
            tiles: tiles.try_into().expect("histogram length"),
            ..FrameOutput::default()
        };
        if let Some((requests, reprojected)) = overlays_before {
            let history: Vec<Payload> = read(exec, d.history(), (w * h) as usize)?;
            out.requests = requests;
            out.history_reprojected = reprojected.iter().map(|p| p.count).collect();
            out.history_accumulated = history.iter().map(|p| p.count).collect();
        }
        Ok(out)
    }
}

/// A converged reference and its own Monte Carlo error.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Mean per pixel and plane.
    pub mean: Vec<f32>,
    /// Standard error of the mean per pixel and plane.
    pub stderr: Vec<f32>,
    /// Samples per pixel.
    pub spp: u32,
}

/// rng indices of reference rays start here, far from any index a denoised frame uses, so the
/// reference is independent of the frames it judges.
pub const REFERENCE_RNG_BASE: u32 = 1 << 30;

/// Traces `spp` rays per pixel of frame `f` with the raygen kernels (the same estimator the
/// denoiser sees) in passes of up to 64 rays, calling `progress(done, spp)` after each.
pub fn reference<E: Executor>(
    exec: &mut E,
    f: &FrameGeometry,
    width: u32,
    height: u32,
    signal: Signal,
    spp: u32,
    mut progress: impl FnMut(u32, u32),
) -> Result<Reference, DenoiserError<E::Error>> {
    let pixels = (width * height) as usize;
    let planes = signal.planes(f.lights.len());
    let n = pixels * planes as usize;
    let mut gpu = GpuScene::default();
    gpu.upload(exec, f)?;
    let surfaces = exec.create_buffer((pixels * std::mem::size_of::<Surface>()) as u64)?;
    gpu.gbuffer(exec, f, width, height, surfaces)?;
    let work_ids: Vec<u32> = (0..pixels as u32).collect();
    let work = exec.create_buffer(pixels as u64 * 4)?;
    exec.write_buffer(work, bytes(&work_ids))?;
    let args = exec.create_buffer(16)?;
    exec.write_buffer(
        args,
        bytes(&[pixels as u32, (pixels as u32).div_ceil(LIST_GROUP), 1, 1]),
    )?;
    let rays = exec.create_buffer(pixels as u64 * 4)?;
    let history = exec.create_buffer((n * std::mem::size_of::<Payload>()) as u64)?;
    let out = exec.create_buffer((n * std::mem::size_of::<Sample>()) as u64)?;
    let layout = signal.layout(f.lights.len());
    let reflections = match (layout.reflections, signal.reflections()) {
        (Some(plane), Some(r)) => Some(Reflections::new(exec, width, height, plane, r)?),
        _ => None,
    };
    let (mut sum, mut sum_sq) = (vec![0.0f64; n], vec![0.0f64; n]);
    let mut done = 0u32;
    while done < spp {
        let batch = (spp - done).min(64);
        exec.write_buffer(rays, bytes(&vec![batch; pixels]))?;
        let start = REFERENCE_RNG_BASE + done;
        let hist: Vec<Payload> = vec![
            Payload {
                rng_index: start,
                ..Payload::default()
            };
            n
        ];
        exec.write_buffer(history, bytes(&hist))?;
        let target = RaygenTarget {
            size: (width, height),
            work,
            args,
            rays,
            surfaces,
            history,
            out,
            frame: 0,
        };
        gpu.raygen(exec, signal, f.lights.len(), &target)?;
        if let Some(r) = &reflections {
            r.raygen(exec, &gpu.reflection_scene(f), &target)?;
        }
        let samples: Vec<Sample> = read(exec, out, n)?;
        for (i, s) in samples.iter().enumerate() {
            sum[i] += s.m1 as f64 * s.rays as f64;
            sum_sq[i] += s.m2 as f64 * s.rays as f64;
        }
        done += batch;
        progress(done, spp);
    }
    let k = spp.max(1) as f64;
    let mean: Vec<f32> = sum.iter().map(|s| (s / k) as f32).collect();
    let stderr = sum
        .iter()
        .zip(&sum_sq)
        .map(|(s, q)| {
            let m = s / k;
            let var = (q / k - m * m).max(0.0);
            (var / (k - 1.0).max(1.0)).sqrt() as f32
        })
        .collect();
    Ok(Reference { mean, stderr, spp })
}
