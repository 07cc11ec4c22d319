//! The whole frame, for every signal: which passes run, in which order, on which planes.
//!
//! A renderer (the `vrrt-scene` crate, or an engine) supplies what only it has — the G-buffer, the
//! scene on the executor ([`FrameScene`]) — and calls [`Frame::render`]; everything else is
//! decided here, so an engine gets the same frame that `vrrt run` measures:
//!
//! ```text
//! absent? ─► temporal ─► G-buffer ─► gradients ─► reflections.prepare ─► rates ─► raygen ─► reuse ─► detect ─► raygen ─► resolve
//! (no pass)  reset/moved  (renderer)  (A-SVGF)     tiles, parallax        reproject,        (reflections) + refill  (refill   accumulate,
//!                                                                         balance, apply                  lists     lists)    variance, filter
//! ```
//!
//! Rules that live here and nowhere else:
//! - **Absent signal**: shadows in a frame without a light run no pass at all; the next frame with
//!   a light starts with fresh history.
//! - **Reset**: the first frame, a camera cut, and the frame after an absent one discard history.
//! - **Still frame**: nothing moved (same camera, every instance map the identity, same lights):
//!   the temporal-gradient prepass is skipped (every re-trace would repeat last frame's ray) and
//!   the adaptive plan may drop converged pixels to the floor rate (`Denoiser::plan_rays`).
//! - **Plane layout** ([`Signal::layout`]) and which raygen traces which plane
//!   ([`trace_planes`]).

mod planes;
mod signal;
pub mod target;

pub use planes::trace_planes;
pub use signal::{PlaneLayout, Signal, SignalName};
pub use target::{GBuffer, RaygenTarget};

use crate::budget::{self, MsBudget, TraceCost};
use crate::camera::{Camera, View};
use crate::denoiser::{
    Denoiser, DenoiserError, EngineTextures, FrameInfo, GradientRays, GradientScene,
};
use crate::executor::{BufferId, Executor};
use crate::kernels::balance::{Balance, MAX_GROUPS};
use crate::kernels::gbuffer::InstanceData;
use crate::kernels::gradient::GradientSample;
use crate::kernels::group_planes;
use crate::kernels::raygen::AreaLight;
use crate::layout::Layout;
use crate::reflections::{ReflectionScene, Reflections};
use crate::settings::{Settings, SettingsError};

/// What a renderer supplies each frame besides the G-buffer: its scene on the executor, the
/// cameras, and the host copies of what can move (for the still-frame rule).
#[derive(Copy, Clone, Debug)]
pub struct FrameScene<'a> {
    /// BVH nodes of this frame's geometry.
    pub nodes: BufferId,
    /// Triangles of this frame's geometry.
    pub tris: BufferId,
    /// This frame's lights (`AreaLight`s).
    pub lights: BufferId,
    /// Per-instance previous→current maps (`InstanceData`, the inverse of the G-buffer's).
    pub next: BufferId,
    /// This frame's lights, on the host.
    pub light_list: &'a [AreaLight],
    /// This frame's instance maps (`InstanceData`), on the host.
    pub instances: &'a [InstanceData],
    /// This frame's camera.
    pub camera: Camera,
    /// Last frame's camera.
    pub prev_camera: Camera,
    /// The camera jumped: history is worthless.
    pub camera_cut: bool,
    /// Where the host knows the signal changed since last frame, as a temporal gradient
    /// (`GradientSample` per gradient cell and plane, plane-stacked; see
    /// [`Denoiser::supply_gradient`]): an engine's moved instances and lights, or the bench's
    /// oracle. When given it replaces the re-tracing prepass, on every signal.
    pub changes: Option<&'a [GradientSample]>,
}

impl FrameScene<'_> {
    /// What the reflection passes trace against.
    pub fn reflection_scene(&self) -> ReflectionScene {
        ReflectionScene {
            nodes: self.nodes,
            tris: self.tris,
            lights: self.lights,
            light_count: self.light_list.len() as u32,
            camera: self.camera,
            prev_camera: self.prev_camera,
        }
    }

    /// What the temporal-gradient prepass re-traces against for `signal`; `None` for signals it
    /// cannot re-trace (reflections, and so the multi-signal frame).
    /// `geometry` is the renderer's geometry buffer of this frame and last frame.
    pub fn gradient_scene(&self, signal: Signal, geometry: [BufferId; 2]) -> Option<GradientScene> {
        let rays = match signal {
            Signal::Ao { max_distance } => GradientRays::Ao { max_distance },
            Signal::Shadows => GradientRays::Shadows {
                lights: self.lights,
            },
            Signal::Reflections | Signal::All { .. } => return None,
        };
        Some(GradientScene {
            nodes: self.nodes,
            tris: self.tris,
            next: self.next,
            geometry,
            rays,
        })
    }

    /// Whether anything that changes a ray moved since a frame whose lights hashed to
    /// `prev_lights`.
    fn moved(&self, prev_lights: u64) -> bool {
        let identity = InstanceData::default();
        let still = |i: &InstanceData| {
            *i == InstanceData {
                roughness: i.roughness,
                ..identity
            }
        };
        self.camera != self.prev_camera
            || !self.instances.iter().all(still)
            || lights_hash(self.light_list) != prev_lights
    }
}

/// FNV-1a over the lights' bytes: the still-frame rule compares lights without keeping a copy.
fn lights_hash(lights: &[AreaLight]) -> u64 {
    bytemuck::cast_slice::<AreaLight, u8>(lights)
        .iter()
        .fold(0xcbf2_9ce4_8422_2325, |h, &b| {
            (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
        })
}

/// What [`Frame::render`] decided, and once [`Frame::finish`] has read them, what the frame
/// traced and how long its ray tracing took.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct FrameReport {
    /// The signal had no source (shadows without a light): no pass ran.
    pub absent: bool,
    /// History was discarded (first frame, camera cut, or after an absent frame).
    pub reset: bool,
    /// Something moved since the last frame.
    pub moved: bool,
    /// The temporal-gradient prepass ran.
    pub gradient_ran: bool,
    /// Rays the frame traced, main pass and refill lists, per plane: each plane group's rays
    /// weighted by its share of the planes, as the ray budget counts them ([`per_plane`],
    /// [`Frame::finish`]; 0 before it).
    pub rays_traced: u64,
    /// Milliseconds the frame's ray-tracing passes took ([`budget::trace_ms`] of the
    /// executor's timings since [`Frame::render`] began; [`Frame::finish`]).
    pub trace_ms: f64,
}

/// One signal's denoiser and effects, and the frame sequence over them.
pub struct Frame {
    signal: Signal,
    layout: PlaneLayout,
    denoiser: Denoiser,
    reflections: Option<Reflections>,
    /// The built-in renderer's own per-pixel data beside the engine inputs (geometric normal,
    /// instance: [`crate::packing::pack_hit`]), this frame's and last frame's.
    geometry: [BufferId; 2],
    frames: u32,
    prev_lights: u64,
    /// The last frame ran no passes (its signal was absent): history is stale.
    resume: bool,
    /// The budget in milliseconds (`rates.budget_ms`), fed by [`Frame::finish`].
    budget: Option<MsBudget>,
    /// The executor's timings before this frame's passes: the frame's are those after.
    first_timing: usize,
    /// The engine's own G-buffer textures, when the inputs come from them.
    engine: Option<EngineTextures>,
    /// The engine's texture the denoised signal goes into, when it has one.
    output: Option<BufferId>,
}

impl Frame {
    /// A frame sequence of `width × height` for `signal` in a scene with `lights` lights. The
    /// denoiser's [`Layout`] follows from the signal's planes
    /// ([`PlaneLayout::denoiser`]); `settings` are the denoiser's as given. Reflections
    /// cannot be re-traced by the temporal-gradient prepass, so with them `prepass.stratum`
    /// must be 0, or 1 for changes the host supplies ([`FrameScene::changes`]).
    pub fn new<E: Executor>(
        exec: &mut E,
        width: u32,
        height: u32,
        signal: Signal,
        lights: usize,
        settings: Settings,
    ) -> Result<Self, DenoiserError<E::Error>> {
        let layout = signal.layout(lights);
        let planes = layout.denoiser(&settings);
        if layout.reflections.is_some() && settings.prepass.stratum > 1 {
            return Err(DenoiserError::Settings(SettingsError::OutOfRange {
                field: "prepass.stratum",
                value: settings.prepass.stratum.into(),
                range: "0, or 1 for host-supplied changes, with reflections (the prepass has no \
                        reflection re-trace)",
            }));
        }
        let mut denoiser = Denoiser::with_layout(exec, width, height, planes, settings)?;
        denoiser
            .set_ao_radius(signal.ao_distance().unwrap_or(0.0))
            .map_err(DenoiserError::Settings)?;
        let reflections = match layout.reflections {
            Some(plane) => Some(Reflections::new(
                exec,
                width,
                height,
                plane,
                settings.reflections,
            )?),
            None => None,
        };
        let geometry_bytes = width as u64 * height as u64 * 8;
        let geometry = [
            exec.create_buffer(geometry_bytes)?,
            exec.create_buffer(geometry_bytes)?,
        ];
        Ok(Frame {
            signal,
            layout,
            denoiser,
            reflections,
            geometry,
            frames: 0,
            prev_lights: lights_hash(&[]),
            resume: false,
            budget: MsBudget::from_settings(&settings.rates),
            first_timing: 0,
            engine: None,
            output: None,
        })
    }

    /// The signal.
    pub fn signal(&self) -> Signal {
        self.signal
    }

    /// Keeps the change detector's `λ` for the host ([`Denoiser::keep_changes`]).
    pub fn keep_changes<E: Executor>(&mut self, exec: &mut E) -> Result<BufferId, E::Error> {
        self.denoiser.keep_changes(exec)
    }

    /// Where each signal lives among the planes.
    pub fn layout(&self) -> PlaneLayout {
        self.layout
    }

    /// The denoiser (buffers, settings).
    pub fn denoiser(&self) -> &Denoiser {
        &self.denoiser
    }

    /// The reflection effect, when the signal has reflections.
    pub fn reflections(&self) -> Option<&Reflections> {
        self.reflections.as_ref()
    }

    /// Sets the ray budget of the next frames ([`Denoiser::set_rays_per_pixel`]). With a budget
    /// in milliseconds, [`Self::finish`] sets it after every frame: this one holds for the next
    /// frame only.
    pub fn set_rays_per_pixel(&mut self, rays_per_pixel: f32) -> Result<(), SettingsError> {
        self.denoiser.set_rays_per_pixel(rays_per_pixel)
    }

    /// This frame's G-buffer: the denoiser's inputs and the renderer's geometry.
    pub fn gbuffer(&self) -> GBuffer {
        GBuffer::of(&self.denoiser, self.geometry[(self.frames % 2) as usize])
    }

    /// Takes the inputs of the frames rendered from now on from the engine's own G-buffer
    /// textures ([`Denoiser::ingest`]: reprojection decodes them on its way), or, with `None`,
    /// from the denoiser's input buffers again. The G-buffer closure of [`Self::render`] then
    /// only renders into those textures and the renderer's geometry.
    pub fn set_engine_textures(&mut self, textures: Option<EngineTextures>) {
        self.engine = textures;
    }

    /// Writes the denoised signal of the frames rendered from now on into the engine's own
    /// texture ([`Denoiser::resolve_into`]: an R32F storage texture the last à-trous iteration
    /// writes), or, with `None`, into [`Denoiser::output`] again.
    pub fn set_output_texture(&mut self, target: Option<BufferId>) {
        self.output = target;
    }

    /// Records one frame. `gbuffer(exec, target)` records the renderer's G-buffer into the
    /// denoiser's input buffers (or the engine's textures, [`Self::set_engine_textures`]) and
    /// the renderer's geometry; it is not called when the signal is absent.
    pub fn render<E: Executor>(
        &mut self,
        exec: &mut E,
        scene: &FrameScene<'_>,
        gbuffer: impl FnOnce(&mut E, GBuffer) -> Result<(), E::Error>,
    ) -> Result<FrameReport, E::Error> {
        self.first_timing = exec.timings().len();
        if self.signal.needs_lights() && scene.light_list.is_empty() {
            self.resume = true;
            self.prev_lights = lights_hash(&[]);
            return Ok(FrameReport {
                absent: true,
                ..FrameReport::default()
            });
        }
        let info = self.temporal(exec, scene)?;
        let target = self.gbuffer();
        gbuffer(exec, target)?;
        if let Some(textures) = &self.engine {
            self.denoiser.ingest(exec, textures)?;
        }
        let gradient_ran = self.gradients(exec, scene)?;
        let reflection_scene = scene.reflection_scene();
        if let Some(r) = &self.reflections {
            r.prepare(exec, &self.denoiser, &target, &reflection_scene)?;
        }
        self.denoiser.plan_rays(exec)?;
        let gb = target;
        let target = RaygenTarget::of(&self.denoiser, gb.geometry);
        let reflections = self.reflections.as_ref();
        trace_planes(exec, self.signal, &self.layout, scene, reflections, &target)?;
        if let Some(r) = reflections {
            r.reuse(exec, &self.denoiser, &gb, &reflection_scene)?;
        }
        if self.denoiser.detect_changes(exec)? {
            let refill = RaygenTarget::refill(&self.denoiser, gb.geometry);
            trace_planes(exec, self.signal, &self.layout, scene, reflections, &refill)?;
        }
        if let Some(r) = reflections {
            r.guide(exec, &self.denoiser)?;
        }
        match self.output {
            Some(texture) => self.denoiser.resolve_into(exec, texture)?,
            None => self.denoiser.resolve(exec)?,
        }
        Ok(FrameReport {
            absent: false,
            reset: info.reset,
            moved: info.moved,
            gradient_ran,
            ..FrameReport::default()
        })
    }

    /// Completes `report` once the frame's passes have run: reads the rays each plane group
    /// traced (its decision: [`Balance::traced`] and [`Balance::refill_traced`], counted on the
    /// device, a few words) and the tracing time from the executor's timings, and with a budget
    /// in milliseconds sets the next frame's rays per pixel from them. An engine calls it after
    /// each [`Self::render`], once it may read back; a frame without a signal traced nothing and
    /// leaves the budget as it was.
    ///
    /// Why a call of its own, not the start of the next `render`: `render` only records, so the
    /// engine chooses where to wait for the frame (where it waits anyway: its own readback, its
    /// present fence), and the report describes the frame just rendered. Why no
    /// [`Executor::finish`] first: the decisions' readback waits for every recorded pass, and
    /// the backends collect their pass timings at that wait, so the frame's are in when the time
    /// is read. The count is the work lists' (what apply granted after the trim, and what the
    /// refill lists fitted), so it equals the sum of `Denoiser::read_rays` per plane plus the
    /// refill lists' rays, without reading a word per pixel.
    pub fn finish<E: Executor>(
        &mut self,
        exec: &mut E,
        report: FrameReport,
    ) -> Result<FrameReport, DenoiserError<E::Error>> {
        if report.absent {
            return Ok(report);
        }
        let layout = *self.denoiser.layout();
        let groups = layout.groups() as usize;
        let mut decisions = [Balance::default(); MAX_GROUPS as usize];
        exec.read_buffer(
            self.denoiser.decision(),
            bytemuck::cast_slice_mut(&mut decisions[..groups]),
        )?;
        let traced = |d: &Balance| d.traced + d.refill_traced;
        let report = FrameReport {
            rays_traced: per_plane(&layout, &decisions[..groups], traced),
            trace_ms: budget::trace_ms(exec.timings().get(self.first_timing..).unwrap_or(&[])),
            ..report
        };
        if let Some(b) = &mut self.budget {
            let next = b.update(TraceCost {
                rays_per_pixel: self.denoiser.rays_per_pixel(),
                rays: report.rays_traced,
                ms: report.trace_ms,
            });
            self.denoiser
                .set_rays_per_pixel(next)
                .map_err(DenoiserError::Settings)?;
        }
        Ok(report)
    }

    /// The controller of the budget in milliseconds, when `rates.budget_ms` is set.
    pub fn budget(&self) -> Option<&MsBudget> {
        self.budget.as_ref()
    }

    /// The temporal stage: the reset and still-frame rules, then the denoiser's frame begins.
    fn temporal<E: Executor>(
        &mut self,
        exec: &mut E,
        scene: &FrameScene<'_>,
    ) -> Result<FrameInfo, E::Error> {
        let moved = scene.moved(self.prev_lights);
        self.prev_lights = lights_hash(scene.light_list);
        let (_, height) = self.denoiser.size();
        let info = FrameInfo {
            index: self.frames,
            reset: self.frames == 0 || scene.camera_cut || self.resume,
            pixel_angle: 2.0 * scene.camera.tan_half_fov_y / height as f32,
            moved,
            importance_plane: self.reflections.as_ref().map(|r| r.plane()),
            view: View {
                camera: scene.camera,
                prev_camera: scene.prev_camera,
            },
        };
        // `gbuffer()` indexes the geometry pair by the frame count: this frame's is written next.
        self.frames += 1;
        self.denoiser.begin_frame(exec, info)?;
        self.resume = false;
        Ok(info)
    }

    /// The gradient stage: the host's changes where it gave them, else the A-SVGF prepass where
    /// the signal can be re-traced.
    fn gradients<E: Executor>(
        &mut self,
        exec: &mut E,
        scene: &FrameScene<'_>,
    ) -> Result<bool, E::Error> {
        if let Some(changes) = scene.changes {
            return self.denoiser.supply_gradient(exec, changes);
        }
        let cur = (self.frames % 2) as usize;
        let geometry = [self.geometry[cur], self.geometry[1 - cur]];
        match scene.gradient_scene(self.signal, geometry) {
            Some(g) => self.denoiser.temporal_gradients(exec, &g),
            None => Ok(false),
        }
    }
}

/// A count of rays per plane of the frame, as the ray budget counts them: `count` of each plane
/// group's decision (group `g` at `decisions[g]`), a group's ray costing one ray of each of its
/// planes, summed in whole plane-rays and rounded once (half up). Why whole plane-rays: the
/// frame's rays ([`FrameReport::rays_traced`]) and its budget ([`Balance::allowed`]) counted
/// alike cannot round apart, so a frame whose every group keeps to its own budget never shows
/// over the whole of it (a shadow ray of one of three lights is a third of an AO ray).
pub fn per_plane(layout: &Layout, decisions: &[Balance], count: impl Fn(&Balance) -> u32) -> u64 {
    let planes = layout.planes.max(1) as u64;
    let weighted: u64 = decisions
        .iter()
        .zip(0..)
        .map(|(d, g)| count(d) as u64 * group_planes(layout.plane_groups, layout.planes, g) as u64)
        .sum();
    (weighted + planes / 2) / planes
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use glam::Vec3;

    fn scene<'a>(lights: &'a [AreaLight], instances: &'a [InstanceData]) -> FrameScene<'a> {
        let camera = Camera::look_at(Vec3::new(0.0, 1.0, 4.0), Vec3::ZERO, Vec3::Y, 0.8);
        FrameScene {
            nodes: BufferId(0),
            tris: BufferId(1),
            lights: BufferId(2),
            next: BufferId(3),
            light_list: lights,
            instances,
            camera,
            prev_camera: camera,
            camera_cut: false,
            changes: None,
        }
    }

    /// The rays of a shared frame (AO, three lights' shadows, reflections: groups of 1, 3 and
    /// 1 planes) counted per plane never exceed its budget counted alike, whenever each group
    /// keeps to its own; a lone group's count is its own.
    #[test]
    fn rays_per_plane_keep_to_the_budget_per_plane() {
        let layout = Signal::All { max_distance: 1.0 }
            .layout(3)
            .denoiser(&Settings::default());
        assert_eq!((layout.planes, layout.groups()), (5, 3));
        let mut state = 0x2545_f491_u32;
        let mut next = |n: u32| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) % n
        };
        for _ in 0..10_000 {
            let mut decisions = [Balance::default(); 3];
            for d in &mut decisions {
                d.allowed = next(100_000);
                d.traced = d.allowed - next(d.allowed + 1).min(next(4));
            }
            let traced = per_plane(&layout, &decisions, |d| d.traced);
            let allowed = per_plane(&layout, &decisions, |d| d.allowed);
            assert!(traced <= allowed, "{decisions:?}: {traced} > {allowed}");
        }
        // 2 AO rays and 1 shadow ray of each light: (2 + 3) / 5 planes, one ray.
        let d = |n| Balance {
            traced: n,
            ..Balance::default()
        };
        assert_eq!(per_plane(&layout, &[d(2), d(1), d(0)], |d| d.traced), 1);
        let alone = Layout::with_planes(1);
        assert_eq!(per_plane(&alone, &[d(12_345)], |d| d.traced), 12_345);
    }

    #[test]
    fn still_frame_rule_sees_every_kind_of_motion() {
        let light = AreaLight {
            corner_y: 3.0,
            ..AreaLight::default()
        };
        let lights = [light];
        let still = [InstanceData {
            roughness: 0.3,
            ..InstanceData::default()
        }];
        let prev = lights_hash(&lights);
        assert!(!scene(&lights, &still).moved(prev), "nothing moved");

        let moved_light = [AreaLight {
            corner_y: 3.5,
            ..light
        }];
        assert!(scene(&moved_light, &still).moved(prev), "a light moved");
        assert!(scene(&[], &still).moved(prev), "the light went out");

        let moved = [InstanceData {
            m03: 0.1,
            ..still[0]
        }];
        assert!(scene(&lights, &moved).moved(prev), "an instance moved");

        let mut panned = scene(&lights, &still);
        panned.prev_camera = Camera::look_at(Vec3::new(0.1, 1.0, 4.0), Vec3::ZERO, Vec3::Y, 0.8);
        assert!(panned.moved(prev), "the camera moved");
    }
}
