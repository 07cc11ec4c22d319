//! The resolve stage, after raygen: accumulation, variance, tile classification and the à-trous
//! iterations.

use super::*;

impl Denoiser {
    /// The change detector and its refill lists, after raygen (and before [`Self::resolve`],
    /// which runs it itself if the host did not). Returns whether refill lists were made: the
    /// host then traces them like the frame's work lists ([`Self::refill_work`],
    /// [`Self::refill_args`]) into [`Self::samples`] before [`Self::resolve`].
    pub fn detect_changes<E: Executor>(&mut self, exec: &mut E) -> Result<bool, E::Error> {
        self.detect(exec, self.settings.detector.refill)
    }

    /// The detector, and the refill lists when `refill` (a host that does not trace them must
    /// not make them: the next frame's balancer would take their rays off its budget).
    fn detect<E: Executor>(&mut self, exec: &mut E, refill: bool) -> Result<bool, E::Error> {
        if refill && !self.detected && self.refills_reset() {
            self.detected = true;
            self.dispatch_reset_refill(exec)?;
            return Ok(true);
        }
        if self.detected || !self.detects() {
            return Ok(false);
        }
        self.detected = true;
        let (s, l) = (self.settings, self.layout);
        let (w, h, planes) = (self.width, self.height, l.planes);
        let p = detect::DetectParams {
            width: w,
            height: h,
            radius: s.detector.radius,
            shadow_radius: s.detector.shadow_radius,
            shadow_planes: l.shadow_planes,
            z_full: s.detector.sigma,
            ao_planes: l.ao_planes,
            ao_z_full: detect::ao_significance(s.detector.ao_sigma, self.rays_per_pixel),
            ao_gain: s.detector.ao_gain,
            ao_cap: s.detector.threshold,
            min_variance: s.detector.min_variance,
        };
        if !refill {
            let pass = kernels::DetectBindings {
                history: self.history[self.cur],
                samples: self.samples,
                changes: self.changes_buffer(),
            };
            exec.dispatch(&pass.over_grid(&p, w, h, planes))?;
            return Ok(false);
        }
        // The lists are all the detector feeds: one pass, `λ` tested where it is computed.
        self.clear_refill_hist(exec)?;
        let fused = refill::DetectRefillParams {
            detect: p,
            refill: self.refill_params(false),
        };
        let pass = kernels::DetectRefillBindings {
            requests: self.requests,
            samples: self.samples,
            history: self.history[self.cur],
            changes: self.changes_buffer(),
            work: self.refill_work(),
            args: self.refill_args,
            hist: self.refill_hist,
        };
        let mut pass = pass.over_grid(&fused, w, h, l.groups());
        if s.detector.workgroup_tiles {
            pass = pass.variant_over_grid(&kernels::DETECT_REFILL_TILED, w, h, l.groups());
        }
        exec.dispatch(&pass)?;
        self.fit_refill_lists(exec, false)?;
        Ok(true)
    }

    /// Zeroes the refill lists' histograms before the lists are made.
    fn clear_refill_hist<E: Executor>(&mut self, exec: &mut E) -> Result<(), E::Error> {
        let clear = fill::FillParams {
            len: self.layout.groups() * refill::FIT_BINS,
            value: 0,
        };
        let fill = kernels::FillBindings {
            buf: self.refill_hist,
        };
        exec.dispatch(&fill.over_grid(&clear, clear.len, 1, 1))
    }

    /// Fits this frame's refill lists (`reset`: a reset frame's) into what the frame may still
    /// trace ([`refill::fit`]) and writes each entry's rays ([`refill::cap`]).
    fn fit_refill_lists<E: Executor>(&mut self, exec: &mut E, reset: bool) -> Result<(), E::Error> {
        let l = self.layout;
        let p = refill::FitParams {
            groups: l.groups(),
            rays: self.refill_params(reset).rays,
            least: if reset { self.reset_least() } else { 1 },
            unbounded: (self.policy() == balance::POLICY_KEEP) as u32,
        };
        let fit = kernels::RefillFitBindings {
            args: self.refill_args,
            hist: self.refill_hist,
            decision: self.decision,
        };
        exec.dispatch(&fit.over_grid(&p, l.groups(), 1, 1))?;
        for list in 0..l.groups() {
            let p = refill::CapParams {
                pixels: self.width * self.height,
                list,
                frame_index: self.frame.index,
            };
            let pass = kernels::RefillCapBindings {
                decision: self.decision,
                args: self.refill_args,
                work: self.refill_work(),
            };
            let groups = Groups::Indirect {
                buffer: self.refill_args,
                offset: 4 * (work_list::ARGS_LEN * list + 1) as u64,
            };
            exec.dispatch(&pass.pass(&p, groups))?;
        }
        Ok(())
    }

    /// The refill lists' parameters (`reset`: a reset frame's, whose listed pixels take up to
    /// `MAX_RATE` rays, set by [`refill::cap`]).
    fn refill_params(&self, reset: bool) -> refill::RefillParams {
        let (s, l) = (self.settings, self.layout);
        refill::RefillParams {
            width: self.width,
            height: self.height,
            planes: l.planes,
            plane_groups: l.plane_groups,
            threshold: s.detector.threshold,
            shadow_threshold: s.detector.shadow_threshold,
            shadow_planes: l.shadow_planes,
            rays: if reset {
                buckets::MAX_RATE
            } else {
                s.detector.refill_rays
            },
            verify_sigma: s.detector.shadow_verify_sigma,
            verify_history: s.detector.shadow_verify_history,
            min_variance: s.detector.min_variance,
            frame_index: self.frame.index,
            fresh_planes: match l.parallax_plane {
                Some(z) if s.detector.refill_fresh => 1 << z,
                _ => 0,
            },
            reset_planes: l.shadow_planes | l.ao_planes | l.parallax_plane.map_or(0, |z| 1 << z),
            // Reset lists are a signal's alone (`Denoiser::reset_refill_share`): one contrast.
            reset_contrast: if l.ao_alone() {
                s.rates.ao_reset_contrast
            } else {
                s.reflections.reset_contrast
            },
        }
    }

    /// A reset frame's refill lists (no detector): the pixels of the shadows' mixed windows,
    /// their rays set by [`refill::fit`] from the reserve the frame set aside.
    fn dispatch_reset_refill<E: Executor>(&mut self, exec: &mut E) -> Result<(), E::Error> {
        let l = self.layout;
        let (w, h) = (self.width, self.height);
        self.clear_refill_hist(exec)?;
        let p = self.refill_params(true);
        let pass = kernels::RefillBindings {
            requests: self.requests,
            samples: self.samples,
            work: self.refill_work(),
            args: self.refill_args,
            hist: self.refill_hist,
        };
        exec.dispatch(&pass.over_grid(&p, w, h, l.groups()))?;
        self.fit_refill_lists(exec, true)
    }

    /// Where the detector's `λ` goes: the kept buffer, or a filter buffer the filter writes only
    /// after accumulation (the work list aliased there is spent by raygen; the refill lists live
    /// in the other one).
    fn changes_buffer(&self) -> BufferId {
        self.kept_changes.unwrap_or(self.filtered[0])
    }

    /// Passes 2.. (after raygen): the change detector (without refill lists) unless
    /// [`Self::detect_changes`] ran, accumulation, variance estimation and the à-trous
    /// iterations.
    pub fn resolve<E: Executor>(&mut self, exec: &mut E) -> Result<(), E::Error> {
        self.resolve_passes(exec, None)
    }

    /// [`Self::resolve`] with the last à-trous iteration writing into the engine's own texture
    /// `target` (no copy pass; [`Self::output`] is then not written this frame): an R32F
    /// storage texture `width × height · planes` texels, plane `z`'s pixel `(x, y)` at
    /// `(x, y + z · height)` (the denoised value; `WgpuExecutor::import_texture`, `AshExecutor::import_image`, or on the CPU
    /// `CpuExecutor::create_texture`).
    pub fn resolve_into<E: Executor>(
        &mut self,
        exec: &mut E,
        target: BufferId,
    ) -> Result<(), E::Error> {
        self.resolve_passes(exec, Some(target))
    }

    fn resolve_passes<E: Executor>(
        &mut self,
        exec: &mut E,
        target: Option<BufferId>,
    ) -> Result<(), E::Error> {
        self.detect(exec, false)?;
        self.accumulate(exec)?;
        let guided = self.ao_guide(exec)?;
        self.estimate_variance(exec, guided)?;
        self.penumbra_guide(exec)?;
        self.filter(exec, target, guided)
    }

    /// The AO guide (`kernels::ao_guide`) and the history divided by it, where the AO planes
    /// take it; whether they do. The divided history goes to `history[1 - cur]`, last frame's,
    /// which reprojection has spent; the history itself stays undivided for the next frame,
    /// whose guide differs.
    fn ao_guide<E: Executor>(&self, exec: &mut E) -> Result<bool, E::Error> {
        let (s, l) = (self.settings, self.layout);
        if l.ao_planes == 0 || s.filter.ao_guide_directions == 0 || !(self.ao_radius > 0.0) {
            return Ok(false);
        }
        let (w, h, cur) = (self.width, self.height, self.cur);
        let (depth, normal_roughness) = (self.depth[cur], self.normal_roughness[cur]);
        let directions = s.filter.ao_guide_directions;
        let refresh = s.filter.ao_guide_refresh.min(directions);
        let index = self.frame.index as u64;
        let march = ao_guide::MarchParams {
            width: w,
            height: h,
            directions,
            steps: s.filter.ao_guide_steps,
            radius: self.ao_radius,
            refresh,
            reset: self.frame.reset as u32,
            first: (index * refresh as u64 % directions as u64) as u32,
            // The golden ratio's multiples' fractions, in 64-bit fixed point (2^64 / φ) so that
            // large indices keep theirs; 24 bits of it.
            turn: if refresh > 0 {
                (index.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40) as f32 / (1u32 << 24) as f32
            } else {
                0.0
            },
            normal_threshold: s.temporal.normal_threshold,
            plane_threshold: s.temporal.plane_threshold,
        };
        // Kept across frames, or else in the filter buffer the first iteration writes: free
        // from accumulation on (its work and refill lists are spent). Without history the
        // march reads nothing of last frame's.
        let (raw, prev_raw) = if refresh > 0 {
            (self.ao_guide_raw[cur], self.ao_guide_raw[1 - cur])
        } else {
            (self.filtered[1], self.unread[0])
        };
        let pass = kernels::AoGuideMarchBindings {
            depth,
            normal_roughness,
            motion: self.motion,
            prev_depth: self.depth[1 - cur],
            prev_normal_roughness: self.normal_roughness[1 - cur],
            view: self.view,
            prev_raw,
            raw,
        };
        exec.dispatch(&pass.over_grid(&march, w, h, 1))?;
        let p = ao_guide::GuideParams {
            width: w,
            height: h,
            ao_planes: l.ao_planes,
        };
        let blur = kernels::AoGuideBlurBindings {
            raw,
            depth,
            normal_roughness,
            guide: self.ao_guide,
        };
        let words = ao_guide::guide_row_words(w);
        exec.dispatch(&blur.over_grid(&p, words, h, 1))?;
        let divide = kernels::AoDemodulateBindings {
            history: self.history[self.cur],
            guide: self.ao_guide,
            out: self.history[1 - self.cur],
        };
        exec.dispatch(&divide.over_grid(&p, w, h, l.planes))?;
        Ok(true)
    }

    /// Accumulation of this frame's samples into the reprojected history.
    fn accumulate<E: Executor>(&self, exec: &mut E) -> Result<(), E::Error> {
        let (s, l) = (self.settings, self.layout);
        let (w, h, planes) = (self.width, self.height, l.planes);
        let changes = self.changes_buffer();
        let detect = self.detects();
        // The reflections' plane: its own-surface clamp and its confirmed drops.
        let reflections = l.parallax_plane.map_or(0, |z| 1 << z);
        let acc = accumulate::AccumulateParams {
            width: w,
            height: h,
            max_history: self.history_clamp(),
            rng_wrap: self.rng_wrap(),
            clamp_radius: s.temporal.clamp_radius,
            clamp_gamma: s.temporal.clamp_gamma,
            firefly_max: s.temporal.firefly_max,
            storage: s.temporal.storage.code()
                | if s.temporal.stuck_correction {
                    0
                } else {
                    crate::quantize::STORAGE_NO_CORRECTION
                },
            use_changes: detect as u32,
            change_threshold: s.detector.threshold,
            shadow_threshold: s.detector.shadow_threshold,
            shadow_planes: l.shadow_planes,
            drop_sigma: s.detector.shadow_drop_sigma,
            min_variance: s.detector.min_variance,
            surface_clamp_planes: reflections,
            surface_clamp_radius: s.temporal.reflection_clamp_radius,
            normal_threshold: s.temporal.normal_threshold,
            depth_tolerance: s.temporal.clamp_depth_tolerance,
            confirm_planes: reflections,
            confirm_sigma: s.detector.reflection_confirm_sigma,
        };
        // Only the reflections' own-surface clamp reads the surfaces.
        let surfaces = reflections != 0 && s.temporal.reflection_clamp_radius > 0;
        let accumulate = kernels::AccumulateBindings {
            history: self.history[self.cur],
            samples: self.samples,
            changes,
            counters: self.counters,
            depth: if surfaces {
                self.depth[self.cur]
            } else {
                self.unread[0]
            },
            normal_roughness: if surfaces {
                self.normal_roughness[self.cur]
            } else {
                self.unread[1]
            },
        };
        exec.dispatch(&accumulate.over_grid(&acc, w, h, planes))
    }

    /// Variance estimation into the filter's input, then the tiles' classification.
    fn estimate_variance<E: Executor>(&self, exec: &mut E, guided: bool) -> Result<(), E::Error> {
        let (s, l) = (self.settings, self.layout);
        let (w, h, planes) = (self.width, self.height, l.planes);
        // The variance pass gathers each tile's worst variance, the classification turns it into
        // iterations and counts them: both start from zero.
        let (tw, th) = classify::tile_grid(w, h);
        for (buf, len) in [
            (self.tiles, tw * th),
            (self.tile_histogram, classify::HISTOGRAM_LEN),
        ] {
            let clear = fill::FillParams { len, value: 0 };
            let fill = kernels::FillBindings { buf };
            exec.dispatch(&fill.over_grid(&clear, len, 1, 1))?;
        }

        let plane_scale = s.filter.plane_tolerance * self.frame.pixel_angle;
        let var = variance::VarianceParams {
            width: w,
            height: h,
            radius: s.filter.spatial_radius,
            spatial_until: s.filter.spatial_until,
            plane_scale,
            normal_power: s.filter.normal_power,
            ao_planes: l.ao_planes,
            ao_normal_power: s.filter.ao_normal_power,
            ao_spatial_until: variance::spatial_until_at(
                s.filter.ao_spatial_until,
                s.filter.ao_spatial_rows,
                h,
            ),
            guide_plane: l.guide_plane.unwrap_or(reproject::NO_PLANE),
            guide_scale: guide_scale(s.filter.guide_sigma),
            wide_until: if s.filter.tall(h) {
                s.filter.wide_until
            } else {
                0.0
            },
            wide_planes: !l.shadow_planes,
        };
        let variance = kernels::VarianceBindings {
            // Divided by the AO guide where it ran (`Self::ao_guide`).
            payload: self.history[if guided { 1 - self.cur } else { self.cur }],
            depth: self.depth[self.cur],
            normal_roughness: self.normal_roughness[self.cur],
            view: self.view,
            guide: self.guide,
            out: self.filtered[0],
            tiles: self.tiles,
        };
        exec.dispatch(&variance.over_grid(&var, w, h, planes))?;

        let cls = classify::ClassifyParams {
            width: w,
            height: h,
            iterations: self.filter_iterations(),
            skip_sigma: s.filter.skip_sigma,
        };
        let classify = kernels::ClassifyBindings {
            tiles: self.tiles,
            histogram: self.tile_histogram,
        };
        exec.dispatch(&classify.over_grid(&cls, tw, th, 1))
    }

    /// The shadows' penumbra guide, where a plane takes it.
    fn penumbra_guide<E: Executor>(&self, exec: &mut E) -> Result<(), E::Error> {
        let (s, l) = (self.settings, self.layout);
        let (w, h) = (self.width, self.height);
        if let Some(plane) = l.penumbra_plane {
            let p = penumbra::PenumbraParams {
                width: w,
                height: h,
                plane,
                radius: s.filter.penumbra_radius,
                pixel_angle: self.frame.pixel_angle,
            };
            let guide = kernels::PenumbraGuideBindings {
                samples: self.samples,
                blockers: self.blockers,
                depth: self.depth[self.cur],
                guide: self.penumbra,
            };
            exec.dispatch(&guide.over_grid(&p, w, h, 1))?;
        }
        Ok(())
    }

    /// The à-trous iterations, ping-ponging between the two filter buffers (`out` says which
    /// holds the result), the last into `target` when the engine gave one (at least one
    /// iteration then, which passes every tile through when the filter has none). `guided`:
    /// the input is divided by the AO guide, and a last pass multiplies it back, into `target`
    /// when given.
    fn filter<E: Executor>(
        &mut self,
        exec: &mut E,
        target: Option<BufferId>,
        guided: bool,
    ) -> Result<(), E::Error> {
        let (w, h, planes) = (self.width, self.height, self.layout.planes);
        let iterations = self.filter_iterations();
        let tiled = self.settings.filter.workgroup_tiles;
        self.out = 0;
        // The iterations write the target themselves only without the guide.
        let target_written = if guided { None } else { target };
        let passes = if target_written.is_some() {
            iterations.max(1)
        } else {
            iterations
        };
        // The fused pair writes the second iteration to the filter buffers, not to a target.
        let fused = self.settings.filter.fused_pair
            && passes >= 2
            && !(target_written.is_some() && passes == 2);
        let mut i = 0;
        while i < passes {
            let params = self.atrous_params(i);
            let (input, depth, normal_roughness) = (
                self.filtered[self.out],
                self.depth[self.cur],
                self.normal_roughness[self.cur],
            );
            if let (Some(out), true) = (target_written, i + 1 == passes) {
                let atrous = kernels::AtrousEngineBindings {
                    input,
                    depth,
                    normal_roughness,
                    view: self.view,
                    tiles: self.tiles,
                    guide: self.guide,
                    penumbra: self.penumbra,
                    out,
                };
                return exec.dispatch(&atrous.over_grid(&params, w, h, planes));
            }
            let bindings = kernels::AtrousBindings {
                input,
                depth,
                normal_roughness,
                view: self.view,
                tiles: self.tiles,
                guide: self.guide,
                penumbra: self.penumbra,
                out: self.filtered[1 - self.out],
            };
            let mut pass = bindings.over_grid(&params, w, h, planes);
            if fused && i == 0 {
                pass = pass.variant_over_grid(&kernels::ATROUS_PAIR, w, h, planes);
                i += 1;
            } else if tiled {
                let (gw, gh) = atrous::tile::grid(w, h, params.step);
                pass = pass.variant_over_grid(&kernels::ATROUS_TILED, gw, gh, planes);
            }
            exec.dispatch(&pass)?;
            self.out = 1 - self.out;
            i += 1;
        }
        if guided {
            self.remodulate(exec, target)?;
        }
        Ok(())
    }

    /// The filter's output multiplied back by the AO guide (`kernels::ao_guide`): in place, or
    /// into the engine's `target`.
    fn remodulate<E: Executor>(
        &self,
        exec: &mut E,
        target: Option<BufferId>,
    ) -> Result<(), E::Error> {
        let (w, h, planes) = (self.width, self.height, self.layout.planes);
        let p = ao_guide::GuideParams {
            width: w,
            height: h,
            ao_planes: self.layout.ao_planes,
        };
        match target {
            Some(out) => {
                let pass = kernels::AoRemodulateIntoBindings {
                    input: self.filtered[self.out],
                    guide: self.ao_guide,
                    out,
                };
                exec.dispatch(&pass.over_grid(&p, w, h, planes))
            }
            None => {
                let pass = kernels::AoRemodulateBindings {
                    guide: self.ao_guide,
                    out: self.filtered[self.out],
                };
                exec.dispatch(&pass.over_grid(&p, w, h, planes))
            }
        }
    }

    /// The parameters of à-trous iteration `i`.
    fn atrous_params(&self, i: u32) -> atrous::AtrousParams {
        let (s, l) = (self.settings, self.layout);
        atrous::AtrousParams {
            width: self.width,
            height: self.height,
            step: 1 << i,
            iteration: i,
            sigma_luminance: s.filter.sigma_luminance,
            plane_scale: s.filter.plane_tolerance * self.frame.pixel_angle,
            normal_power: s.filter.normal_power,
            cap_variance: s.filter.cap_variance as u32,
            ao_planes: l.ao_planes,
            ao_normal_power: s.filter.ao_normal_power,
            symmetric_planes: if s.filter.ao_symmetric_taps {
                l.ao_planes
            } else {
                0
            },
            guide_plane: l.guide_plane.unwrap_or(reproject::NO_PLANE),
            guide_scale: guide_scale(s.filter.guide_sigma),
            guided_sigma_luminance: if s.filter.tall(self.height) {
                s.filter.tall_guided_sigma_luminance
            } else {
                s.filter.guided_sigma_luminance
            },
            penumbra_plane: l.penumbra_plane.unwrap_or(reproject::NO_PLANE),
            penumbra_scale: if s.filter.penumbra_reach > 0.0 {
                1.0 / s.filter.penumbra_reach
            } else {
                0.0
            },
            penumbra_sigma_luminance: s.filter.penumbra_sigma_luminance,
            ao_iterations: self.ao_iterations(),
        }
    }

    /// Iterations the AO planes run on this image (`FilterSettings::ao_reach`).
    fn ao_iterations(&self) -> u32 {
        let f = &self.settings.filter;
        atrous::ao_iterations(f.ao_reach, self.height, f.atrous_iterations)
    }

    /// À-trous iterations a frame dispatches: the AO planes' own count on a frame of AO planes
    /// alone (the later passes would only copy), else `filter.atrous_iterations`.
    pub fn filter_iterations(&self) -> u32 {
        if self.layout.ao_alone() {
            self.ao_iterations()
        } else {
            self.settings.filter.atrous_iterations
        }
    }
}

/// `AtrousParams::guide_scale` of σ: `1 / (σ √2)`, and 0 (the guide never stops a tap) for σ = 0.
fn guide_scale(sigma: f32) -> f32 {
    if sigma > 0.0 {
        core::f32::consts::FRAC_1_SQRT_2 / sigma
    } else {
        0.0
    }
}
