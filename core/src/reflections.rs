//! Glossy reflections as one effect beside the denoiser (like kajiya's per-effect structs): it
//! owns the ray records and records the passes of `kernels::reflect` around the denoiser's plan.
//!
//! Per frame, with the reflections in plane `plane` of a [`Denoiser`]:
//!
//! ```text
//! begin_frame(use_importance) ─► Reflections::prepare ─► Denoiser::plan_rays ─► Reflections::raygen ─► Reflections::reuse ─► Reflections::guide ─► Denoiser::resolve
//!                                 tiles → importance                            → samples, hits         → samples             hits → guide
//!                                 motion → parallax
//! ```
//!
//! (`guide` after the refill lists' rays too, when the detector runs: `Denoiser::detect_changes`.)
//! `crate::frame` runs this order; the other planes (AO, shadows) are traced by their own raygen
//! between `plan_rays` and `resolve`: all planes share the reprojection, the one ray request per pixel and the one load
//! balancer, so the ray budget is spent across signals.

use crate::camera::Camera;
use crate::denoiser::Denoiser;
use crate::executor::{BufferId, Executor};
use crate::frame::target::{GBuffer, RaygenTarget};
use crate::kernels;
use crate::kernels::reflect::{self, RayHit, Shading};
use crate::settings::ReflectionSettings;

/// What the reflection passes trace against in this frame.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ReflectionScene {
    /// BVH nodes of this frame's geometry.
    pub nodes: BufferId,
    /// Triangles of this frame's geometry.
    pub tris: BufferId,
    /// This frame's lights (`AreaLight`).
    pub lights: BufferId,
    /// How many of them to use.
    pub light_count: u32,
    /// This frame's camera.
    pub camera: Camera,
    /// Last frame's camera (parallax).
    pub prev_camera: Camera,
}

/// The reflection effect: its settings, plane and ray records.
#[derive(Clone, Debug)]
pub struct Reflections {
    settings: ReflectionSettings,
    plane: u32,
    hits: BufferId,
}

impl Reflections {
    /// Bytes of the ray records of a `width × height` image (one `RayHit` per pixel).
    pub fn hits_bytes(width: u32, height: u32) -> u64 {
        width as u64 * height as u64 * core::mem::size_of::<RayHit>() as u64
    }

    /// Reflections written to plane `plane` of a `width × height` denoiser (which should
    /// reproject that plane along the parallax: `Layout::parallax_plane`).
    pub fn new<E: Executor>(
        exec: &mut E,
        width: u32,
        height: u32,
        plane: u32,
        settings: ReflectionSettings,
    ) -> Result<Self, crate::denoiser::DenoiserError<E::Error>> {
        settings
            .validate()
            .map_err(crate::denoiser::DenoiserError::Settings)?;
        let bytes = Self::hits_bytes(width, height);
        // Zero-filled: pdf 0 marks every record unused until the first trace.
        let hits = exec.create_buffer(bytes.max(4))?;
        Ok(Reflections {
            settings,
            plane,
            hits,
        })
    }

    /// The settings in use.
    pub fn settings(&self) -> &ReflectionSettings {
        &self.settings
    }

    /// The plane the reflections are written to.
    pub fn plane(&self) -> u32 {
        self.plane
    }

    /// Ray records (`RayHit` per pixel) of the last [`Self::raygen`].
    pub fn hits(&self) -> BufferId {
        self.hits
    }

    /// The shading constants for `scene`.
    pub fn shading(&self, scene: &ReflectionScene) -> Shading {
        let s = &self.settings;
        let eye = scene.camera.origin();
        Shading {
            eye_x: eye.x,
            eye_y: eye.y,
            eye_z: eye.z,
            max_roughness: s.max_roughness,
            light_radiance: s.light_radiance,
            albedo: s.albedo,
            sky: s.sky,
            ambient: s.ambient,
            light_probes: s.light_probes,
            _pad: [0; 3],
        }
    }

    /// Before [`Denoiser::plan_rays`] (after the G-buffer): tile classification into
    /// [`Denoiser::importance`] (begin the frame with `use_importance` to use it) and, with
    /// `parallax` on, the reflection parallax into [`Denoiser::parallax`].
    pub fn prepare<E: Executor>(
        &self,
        exec: &mut E,
        denoiser: &Denoiser,
        gbuffer: &GBuffer,
        scene: &ReflectionScene,
    ) -> Result<(), E::Error> {
        let s = &self.settings;
        let (w, h) = denoiser.size();
        let frame = denoiser.frame().index;
        let tiles = reflect::TileParams {
            width: w,
            height: h,
            lights: scene.light_count,
            frame,
            min_rate: s.min_rate,
            max_rate: s.max_rate,
            sigma: s.tile_sigma,
            _pad: 0,
            shading: self.shading(scene),
        };
        let (tw, th) = reflect::tile_grid(w, h);
        let pass = kernels::ReflectTilesBindings {
            depth: gbuffer.inputs.depth,
            normal_roughness: gbuffer.inputs.normal_roughness,
            geometry: gbuffer.geometry,
            view: gbuffer.view,
            nodes: scene.nodes,
            tris: scene.tris,
            lights: scene.lights,
            importance: denoiser.importance(),
        };
        exec.dispatch(&pass.over_grid(&tiles, tw, th, 1))?;
        if !s.parallax {
            return Ok(());
        }
        let eye = scene.camera.origin();
        let motion = reflect::MotionParams {
            width: w,
            height: h,
            frame: frame.wrapping_sub(1),
            radius: s.motion_radius,
            eye_x: eye.x,
            eye_y: eye.y,
            eye_z: eye.z,
            max_roughness: s.max_roughness,
            prev_camera: scene.prev_camera,
        };
        let pass = kernels::ReflectMotionBindings {
            depth: gbuffer.inputs.depth,
            normal_roughness: gbuffer.inputs.normal_roughness,
            motion: gbuffer.inputs.motion,
            view: gbuffer.view,
            hits: self.hits,
            parallax: denoiser.parallax(),
        };
        exec.dispatch(&pass.over_grid(&motion, w, h, 1))
    }

    /// The reflection rays of `target`'s work list into plane [`Self::plane`] of its samples and
    /// the ray records.
    pub fn raygen<E: Executor>(
        &self,
        exec: &mut E,
        scene: &ReflectionScene,
        target: &RaygenTarget,
    ) -> Result<(), E::Error> {
        let p = reflect::RaygenParams {
            width: target.size.0,
            height: target.size.1,
            plane: self.plane,
            lights: scene.light_count,
            frame: target.frame,
            list: target.list(self.plane),
            sampling: target.sampling,
            merge: target.merge as u32,
            shading: self.shading(scene),
        };
        let pass = kernels::RaygenReflectBindings {
            work: target.work,
            args: target.args,
            depth: target.gbuffer.inputs.depth,
            normal_roughness: target.gbuffer.inputs.normal_roughness,
            geometry: target.gbuffer.geometry,
            view: target.gbuffer.view,
            history: target.history,
            nodes: scene.nodes,
            tris: scene.tris,
            lights: scene.lights,
            out: target.out,
            hits: self.hits,
        };
        exec.dispatch(&pass.pass(&p, target.groups(p.list)))
    }

    /// After the reflection rays of [`Self::raygen`] over the denoiser's work list: ray reuse
    /// between neighbours, in place in the denoiser's samples.
    pub fn reuse<E: Executor>(
        &self,
        exec: &mut E,
        denoiser: &Denoiser,
        gbuffer: &GBuffer,
        scene: &ReflectionScene,
    ) -> Result<(), E::Error> {
        let (w, h) = denoiser.size();
        // A reset frame keeps the narrow window: no pixel has history there, and the wider
        // reuse made the first frames worse (`docs/algorithms/reflections.md`).
        let tall = denoiser.settings().filter.tall(h) && !denoiser.frame().reset;
        let radius = if tall {
            self.settings.tall_reuse_radius
        } else {
            self.settings.reuse_radius
        };
        if radius == 0 {
            return Ok(());
        }
        let frame = denoiser.frame().index;
        let reuse = reflect::ReuseParams {
            width: w,
            height: h,
            plane: self.plane,
            frame,
            radius,
            plane_threshold: self.settings.plane_threshold,
            _pad: [0; 2],
            shading: self.shading(scene),
        };
        let pass = kernels::ReflectReuseBindings {
            depth: gbuffer.inputs.depth,
            normal_roughness: gbuffer.inputs.normal_roughness,
            geometry: gbuffer.geometry,
            view: gbuffer.view,
            hits: self.hits,
            samples: denoiser.samples(),
        };
        exec.dispatch(&pass.over_grid(&reuse, w, h, 1))
    }

    /// After the last reflection rays of the frame (refills included), before
    /// [`Denoiser::resolve`]: the hit-distance guide into [`Denoiser::guide`], when the
    /// denoiser has a guide plane.
    pub fn guide<E: Executor>(&self, exec: &mut E, denoiser: &Denoiser) -> Result<(), E::Error> {
        if denoiser.layout().guide_plane.is_none() {
            return Ok(());
        }
        let (w, h) = denoiser.size();
        let p = reflect::GuideParams {
            width: w,
            height: h,
            frame: denoiser.frame().index,
            radius: self.settings.guide_radius,
        };
        let pass = kernels::ReflectGuideBindings {
            hits: self.hits,
            guide: denoiser.guide(),
        };
        exec.dispatch(&pass.over_grid(&p, w, h, 1))
    }
}
