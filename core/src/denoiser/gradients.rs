//! The gradient stage: the A-SVGF temporal-gradient prepass (forward projection, re-trace,
//! reconstruction), before the rates see last frame's buffers overwritten.

use super::*;

impl Denoiser {
    /// The temporal-gradient prepass (A-SVGF), between the G-buffer and [`Self::plan_rays`]:
    /// forward projection of one previous-frame sample per stratum, re-trace of its 0th ray
    /// against `scene`, and the à-trous reconstruction. It reads last frame's samples and
    /// history, which [`Self::plan_rays`] overwrites, so it must run first. Returns
    /// whether it ran: it is skipped when off, on reset frames, and when [`FrameInfo::moved`] is
    /// false (nothing can have changed, so every `λ` would be 0).
    pub fn temporal_gradients<E: Executor>(
        &mut self,
        exec: &mut E,
        scene: &GradientScene,
    ) -> Result<bool, E::Error> {
        let s = self.settings;
        self.gradient_ran = false;
        if s.prepass.stratum == 0 || self.frame.reset || !self.frame.moved {
            return Ok(false);
        }
        self.gradient_project(exec, scene)?;
        self.gradient_retrace(exec, scene)?;
        self.gradient_reconstruct(exec)?;
        self.gradient_ran = true;
        Ok(true)
    }

    /// The prepass's forward projection: one previous-frame sample per stratum claims its cell
    /// (keys cleared first), where it lands on the same surface this frame.
    fn gradient_project<E: Executor>(
        &self,
        exec: &mut E,
        scene: &GradientScene,
    ) -> Result<(), E::Error> {
        let s = self.settings;
        let (w, h) = (self.width, self.height);
        let (gw, gh) = self.gradient_size();
        let index_mask = gradient::index_mask(w * h);
        let clear = fill::FillParams {
            len: gw * gh,
            value: gradient::EMPTY_KEY,
        };
        let keys = kernels::FillBindings {
            buf: self.gradient_keys,
        };
        exec.dispatch(&keys.over_grid(&clear, clear.len, 1, 1))?;
        let proj = gradient::ProjectParams {
            width: w,
            height: h,
            stratum: s.prepass.stratum,
            grid_width: gw,
            grid_height: gh,
            frame_index: self.frame.index,
            index_mask,
            normal_threshold: s.temporal.normal_threshold,
            plane_threshold: s.temporal.plane_threshold,
            camera: self.frame.view.camera,
        };
        let (inputs, prev) = (self.inputs(), self.prev_inputs());
        let project = kernels::GradientProjectBindings {
            prev_depth: prev.depth,
            prev_normal_roughness: prev.normal_roughness,
            prev_geometry: scene.geometry[1],
            depth: inputs.depth,
            normal_roughness: inputs.normal_roughness,
            geometry: scene.geometry[0],
            view: self.view,
            prev_samples: self.samples,
            next: scene.next,
            keys: self.gradient_keys,
        };
        exec.dispatch(&project.over_grid(&proj, gw, gh, 1))?;
        Ok(())
    }

    /// The prepass's re-trace: each projected sample's 0th ray again, against this frame's
    /// scene, with last frame's rng (AO or shadow rays, as `scene` says).
    fn gradient_retrace<E: Executor>(
        &self,
        exec: &mut E,
        scene: &GradientScene,
    ) -> Result<(), E::Error> {
        let (s, l) = (self.settings, self.layout);
        let (w, h) = (self.width, self.height);
        let (gw, gh) = self.gradient_size();
        let index_mask = gradient::index_mask(w * h);
        let prev = self.prev_inputs();
        let mut retrace = gradient::RetraceParams {
            width: w,
            height: h,
            planes: l.planes,
            grid_width: gw,
            grid_height: gh,
            index_mask,
            max_distance: 0.0,
            rng_wrap: self.rng_wrap(),
            frame: self.prev_frame,
            sampling: s.temporal.sampling.code(),
            _pad: [0; 2],
        };
        // Last frame's accumulated history holds the rng index each pixel's raygen started from
        // plus the rays it traced (`samples`, which also keeps last frame's 0th ray values).
        let ao = kernels::GradientAoBindings {
            keys: self.gradient_keys,
            prev_depth: prev.depth,
            prev_normal_roughness: prev.normal_roughness,
            prev_geometry: scene.geometry[1],
            view: self.view,
            next: scene.next,
            prev_payload: self.history[1 - self.cur],
            prev_samples: self.samples,
            nodes: scene.nodes,
            tris: scene.tris,
            out: self.gradient_raw,
        };
        match scene.rays {
            GradientRays::Ao { max_distance } => {
                retrace.max_distance = max_distance;
                exec.dispatch(&ao.over_grid(&retrace, gw, gh, 1))?;
            }
            GradientRays::Shadows { lights } => {
                let shadow = kernels::GradientShadowBindings {
                    keys: ao.keys,
                    prev_depth: ao.prev_depth,
                    prev_normal_roughness: ao.prev_normal_roughness,
                    prev_geometry: ao.prev_geometry,
                    view: ao.view,
                    next: ao.next,
                    prev_payload: ao.prev_payload,
                    prev_samples: ao.prev_samples,
                    nodes: ao.nodes,
                    tris: ao.tris,
                    lights,
                    out: ao.out,
                };
                exec.dispatch(&shadow.over_grid(&retrace, gw, gh, 1))?;
            }
        }
        Ok(())
    }

    /// The prepass's reconstruction: à-trous iterations over the cells, ping-ponging between
    /// the two gradient buffers (`gradient_out` says which holds the result).
    fn gradient_reconstruct<E: Executor>(&mut self, exec: &mut E) -> Result<(), E::Error> {
        let (s, l) = (self.settings, self.layout);
        let (gw, gh) = self.gradient_size();
        let mut input = self.gradient_raw;
        for i in 0..s.prepass.iterations {
            let p = gradient::GradientAtrousParams {
                grid_width: gw,
                grid_height: gh,
                step: 1 << i,
                _pad: 0,
            };
            let out = self.gradient[(i % 2) as usize];
            let pass = kernels::GradientAtrousBindings { input, out };
            exec.dispatch(&pass.over_grid(&p, gw, gh, l.planes))?;
            input = out;
            self.gradient_out = (i % 2) as usize;
        }
        Ok(())
    }

    /// Uses `changes` (`GradientSample` per cell of [`Self::gradient_size`] and plane,
    /// plane-stacked) as this frame's temporal gradient instead of the prepass: reprojection
    /// shortens or drops history by its `λ` exactly as if the prepass had measured it. Skipped,
    /// like the prepass, when gradients are off (`stratum` 0) and on reset frames. Returns whether
    /// it was used.
    ///
    /// # Panics
    /// If `changes` does not hold one sample per cell and plane (hosts check first; a short
    /// buffer would leave last frame's `λ` in the rest).
    pub fn supply_gradient<E: Executor>(
        &mut self,
        exec: &mut E,
        changes: &[gradient::GradientSample],
    ) -> Result<bool, E::Error> {
        self.gradient_ran = false;
        if self.settings.prepass.stratum == 0 || self.frame.reset {
            return Ok(false);
        }
        let (gw, gh) = self.gradient_size();
        let expected = (gw * gh * self.layout.planes) as usize;
        assert_eq!(
            changes.len(),
            expected,
            "supplied gradient: one sample per cell and plane"
        );
        exec.write_buffer(self.gradient(), bytemuck::cast_slice(changes))?;
        self.gradient_ran = true;
        Ok(true)
    }
}
