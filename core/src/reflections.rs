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
use crate::frame::target::{GBuffer, RaygenTarget};
use crate::kernels;
use crate::kernels::reflect::{self, RayHit, Shading};
use crate::plan::{BufferId, Executor};
use crate::settings::{check, SettingsError};

/// Tunables of the reflection passes, with documented defaults and ranges (with the `serde`
/// feature, a settings file's `[reflections]` table: missing fields keep their defaults).
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct ReflectionSettings {
    /// Surfaces with a larger GGX alpha reflect nothing and trace no reflection ray (0..=1;
    /// default 0.5; the seed traces "HQ rays for roughness < 20%" and filters the rest).
    pub max_roughness: f32,
    /// Request scale of a tile whose reflection is flat or empty (0 < min <= max; default 0.5).
    pub min_rate: f32,
    /// Request scale of the noisiest tiles (min..=4; default 2).
    pub max_rate: f32,
    /// Standard deviation of the tone-mapped tracer values that earns `max_rate` (> 0; default
    /// 0.15).
    pub tile_sigma: f32,
    /// Ray reuse radius in pixels (0..=3; 0 = no reuse; default 1, a 3×3 neighbourhood: on the
    /// room, 5×5 reuses rays across lobes too different and the error rises again).
    pub reuse_radius: u32,
    /// Reproject reflections along the parallax of their hit distance (default on); off, they
    /// follow the surface (the G-buffer motion), which smears them when the camera moves.
    pub parallax: bool,
    /// Radius over which last frame's hit distances are averaged for the parallax (0..=3;
    /// default 2).
    pub motion_radius: u32,
    /// Reuse only neighbours within this fraction of view depth of the pixel's tangent plane
    /// (> 0; default 0.02, the reprojection's plane test).
    pub plane_threshold: f32,
    /// Radiance of the lights seen in a reflection (>= 0; default 5).
    pub light_radiance: f32,
    /// Albedo of the surfaces seen in a reflection (0..=1; default 0.7).
    pub albedo: f32,
    /// Radiance of the sky (>= 0; default 0.3).
    pub sky: f32,
    /// Ambient irradiance at reflected hits (>= 0; default 0.1).
    pub ambient: f32,
    /// Extra lobe directions per ray that only test for the lights (0..=15; default 7; 0 = the
    /// lights' part from the ray's own direction alone): unbiased, and they beat more rays at
    /// about equal time ([`crate::kernels::reflect`], "Light probes";
    /// `docs/algorithms/reflections.md`).
    pub light_probes: u32,
    /// Window radius of the hit-distance guide (`kernels::reflect::reflect_guide`; 0..=3;
    /// default 2, a 5×5 mean: on the bunny's first frame a 3×3 one guides worse).
    pub guide_radius: u32,
}

impl Default for ReflectionSettings {
    fn default() -> Self {
        let sh = Shading::default();
        ReflectionSettings {
            max_roughness: sh.max_roughness,
            min_rate: 0.5,
            max_rate: 2.0,
            tile_sigma: 0.15,
            reuse_radius: 1,
            parallax: true,
            motion_radius: 2,
            plane_threshold: 0.02,
            light_radiance: sh.light_radiance,
            albedo: sh.albedo,
            sky: sh.sky,
            ambient: sh.ambient,
            light_probes: sh.light_probes,
            guide_radius: 2,
        }
    }
}

impl ReflectionSettings {
    /// Checks every field against its documented range; errors name the field by its path in a
    /// settings file (`reflections.reuse_radius`), as [`SettingsError::OutOfRange`] asks.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let f = |v: f32| v.is_finite();
        check(
            f(self.max_roughness) && (0.0..=1.0).contains(&self.max_roughness),
            "reflections.max_roughness",
            self.max_roughness,
            "0..=1",
        )?;
        check(
            f(self.min_rate) && self.min_rate > 0.0 && self.min_rate <= self.max_rate,
            "reflections.min_rate",
            self.min_rate,
            "0 < min_rate <= max_rate",
        )?;
        check(
            f(self.max_rate) && self.max_rate <= 4.0,
            "reflections.max_rate",
            self.max_rate,
            "min_rate..=4",
        )?;
        check(
            f(self.tile_sigma) && self.tile_sigma > 0.0,
            "reflections.tile_sigma",
            self.tile_sigma,
            "> 0",
        )?;
        check(
            self.reuse_radius <= 3,
            "reflections.reuse_radius",
            self.reuse_radius as f32,
            "0..=3",
        )?;
        check(
            self.guide_radius <= 3,
            "reflections.guide_radius",
            self.guide_radius as f32,
            "0..=3",
        )?;
        check(
            self.light_probes <= reflect::MAX_LIGHT_PROBES,
            "reflections.light_probes",
            self.light_probes as f32,
            "0..=15",
        )?;
        check(
            self.motion_radius <= 3,
            "reflections.motion_radius",
            self.motion_radius as f32,
            "0..=3",
        )?;
        check(
            f(self.plane_threshold) && self.plane_threshold > 0.0,
            "reflections.plane_threshold",
            self.plane_threshold,
            "> 0",
        )?;
        for (field, v) in [
            ("reflections.light_radiance", self.light_radiance),
            ("reflections.sky", self.sky),
            ("reflections.ambient", self.ambient),
        ] {
            check(f(v) && v >= 0.0, field, v, ">= 0")?;
        }
        check(
            f(self.albedo) && (0.0..=1.0).contains(&self.albedo),
            "reflections.albedo",
            self.albedo,
            "0..=1",
        )
    }
}

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
    /// reproject that plane along the parallax: `Settings::parallax_plane`).
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
            _pad: 0,
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
        if self.settings.reuse_radius == 0 {
            return Ok(());
        }
        let (w, h) = denoiser.size();
        let frame = denoiser.frame().index;
        let reuse = reflect::ReuseParams {
            width: w,
            height: h,
            plane: self.plane,
            frame,
            radius: self.settings.reuse_radius,
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
        if denoiser.settings().guide_plane.is_none() {
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

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;

    #[test]
    fn settings_out_of_range_name_their_field() {
        assert_eq!(ReflectionSettings::default().validate(), Ok(()));
        let bad = [
            ReflectionSettings {
                max_roughness: f32::NAN,
                ..Default::default()
            },
            ReflectionSettings {
                min_rate: 3.0,
                ..Default::default()
            },
            ReflectionSettings {
                reuse_radius: 9,
                ..Default::default()
            },
            ReflectionSettings {
                sky: -1.0,
                ..Default::default()
            },
        ];
        for (s, field) in bad.iter().zip([
            "reflections.max_roughness",
            "reflections.min_rate",
            "reflections.reuse_radius",
            "reflections.sky",
        ]) {
            match s.validate() {
                Err(SettingsError::OutOfRange { field: f, .. }) => assert_eq!(f, field),
                other => panic!("{field}: {other:?}"),
            }
        }
    }
}
