//! The rates stage: reprojection with ray requests, bucket counting, load balancing and apply
//! (the work list raygen traces).

use super::*;

impl Denoiser {
    /// The plane groups whose requests the balancer shifts (`balance::BalanceParams::shift`): with
    /// `rates.shift_requests`, every group but the reflections' importance-scaled one, and in a
    /// shared frame not those holding a shadow plane. Shifted, the shadows gain alone (pixels
    /// whose history a moving light or object drops every frame get the rays) but lose in the
    /// shared frame, where their refills and verification rays compete with the other signals'
    /// (measured in `docs/algorithms/balancer.md`).
    fn shifting_groups(&self, importance_group: u32) -> u32 {
        let (s, l) = (&self.settings, &self.layout);
        if !s.rates.shift_requests {
            return 0;
        }
        let mut mask = !(1u32.checked_shl(importance_group).unwrap_or(0));
        if l.shadows_alone() {
            return mask;
        }
        for z in 0..l.planes {
            if kernels::plane_in(l.shadow_planes, z) {
                mask &= !(1 << kernels::plane_group(l.plane_groups, z));
            }
        }
        mask
    }

    /// Passes before raygen: reprojection (with ray requests), bucket counting, load balancing
    /// and apply. Afterwards [`Self::work`] and [`Self::args`] say what to trace.
    pub fn plan_rays<E: Executor>(&mut self, exec: &mut E) -> Result<(), E::Error> {
        let importance_group = self.importance_group();
        self.reproject(exec, importance_group)?;
        self.count_buckets(exec)?;
        self.balance(exec, importance_group)?;
        self.trim(exec)?;
        let (w, h, groups) = (self.width, self.height, self.layout.groups());
        let app = self.apply_params();
        let apply = kernels::ApplyBindings {
            requests: self.requests,
            decision: self.decision,
            noise: self.noise,
            work: self.work(),
            args: self.args,
            samples: self.samples,
        };
        exec.dispatch(&apply.over_grid(&app, w, h, groups))
    }

    /// The group whose requests the reflections' tile importance scales: they are no longer a
    /// history's deficit, which the balancer's shift assumes (`balance::MODE_SHIFT`).
    fn importance_group(&self) -> u32 {
        let l = &self.layout;
        self.frame
            .importance_plane
            .map_or(reproject::NO_GROUP, |z| {
                kernels::plane_group(l.plane_groups, z)
            })
    }

    /// Reprojection, with each pixel's ray request.
    fn reproject<E: Executor>(&self, exec: &mut E, importance_group: u32) -> Result<(), E::Error> {
        let (s, l) = (self.settings, self.layout);
        let (w, h) = (self.width, self.height);
        let vrrt = s.rates.supersample_target > 0.0;
        let (gw, gh) = self.gradient_size();
        // Below one ray per pixel the budget's rate is the base request (seed: "can use global
        // ray rate < 1") and undersampling rates scale with it: with a base of 1 every request
        // would exceed a 1/2-ray budget and water filling would level refills down to the base.
        let still = s.rates.undersample && !self.frame.moved && !self.frame.reset;
        let still_rule = self.still_rule();
        let history = self.history_clamp();
        let base_rate = if vrrt {
            self.rays_per_pixel.min(1.0)
        } else {
            self.rays_per_pixel
        };
        let params = reproject::ReprojectParams {
            width: w,
            height: h,
            planes: l.planes,
            reset: self.frame.reset as u32,
            normal_threshold: s.temporal.normal_threshold,
            plane_threshold: s.temporal.plane_threshold,
            // Within the stored index's range, so the gradient re-trace can step back to it.
            frame_index: self.frame.index % self.rng_wrap(),
            supersample_target: s.rates.supersample_target,
            // On a still frame history stays valid, so it is completed before any undersampling.
            full_history: if still {
                history
            } else {
                s.rates.undersample_after
            },
            base_rate,
            use_mask: s.rates.vrs_mask as u32,
            variance_threshold: if s.rates.undersample {
                s.rates.variance_threshold
            } else {
                [0.0; 4]
            },
            variance_rate: s.rates.variance_rate.map(|r| r * base_rate),
            gradient_stratum: if self.gradient_ran {
                s.prepass.stratum
            } else {
                0
            },
            gradient_width: gw,
            gradient_height: gh,
            gradient_threshold: s.prepass.threshold,
            gradient_scale: s.prepass.scale,
            still_history: if still_rule { history } else { 0.0 },
            still_variance: s.rates.still_sigma * s.rates.still_sigma,
            max_history: history,
            importance_group,
            parallax_plane: l.parallax_plane.unwrap_or(reproject::NO_PLANE),
            plane_groups: l.plane_groups,
            ..Default::default()
        };
        let (cur, prev) = (self.cur, 1 - self.cur);
        if let Some(t) = self.engine {
            let reproject = kernels::ReprojectEngineBindings {
                engine_depth: t.depth,
                engine_normal: t.normal_roughness,
                engine_motion: t.motion,
                conventions: self.conventions,
                depth: self.depth[cur],
                normal_roughness: self.normal_roughness[cur],
                motion: self.motion,
                prev_depth: self.depth[prev],
                prev_normal_roughness: self.normal_roughness[prev],
                view: self.view,
                history: self.history[prev],
                mask: self.mask,
                gradient: self.gradient(),
                importance: self.importance,
                parallax: self.parallax,
                out: self.history[cur],
                requests: self.requests,
            };
            return exec.dispatch(&reproject.over_grid(&params, w, h, 1));
        }
        let reproject = kernels::ReprojectBindings {
            depth: self.depth[cur],
            normal_roughness: self.normal_roughness[cur],
            motion: self.motion,
            prev_depth: self.depth[prev],
            prev_normal_roughness: self.normal_roughness[prev],
            view: self.view,
            history: self.history[prev],
            mask: self.mask,
            gradient: self.gradient(),
            importance: self.importance,
            parallax: self.parallax,
            out: self.history[cur],
            requests: self.requests,
        };
        exec.dispatch(&reproject.over_grid(&params, w, h, 1))
    }

    /// The bucket histogram of each plane group's requests.
    fn count_buckets<E: Executor>(&self, exec: &mut E) -> Result<(), E::Error> {
        let (w, h) = (self.width, self.height);
        let groups = self.layout.groups();
        let clear = fill::FillParams {
            len: groups * buckets::COUNTS_LEN,
            value: 0,
        };
        let counts = kernels::FillBindings { buf: self.counts };
        exec.dispatch(&counts.over_grid(&clear, clear.len, 1, 1))?;
        let count = buckets::BucketParams {
            width: w,
            height: h,
        };
        let buckets = kernels::CountBucketsBindings {
            requests: self.requests,
            counts: self.counts,
        };
        exec.dispatch(&buckets.over_grid(&count, w, h, groups))?;
        Ok(())
    }

    /// The load balancer: each plane group's rates for this frame's budget.
    fn balance<E: Executor>(&self, exec: &mut E, importance_group: u32) -> Result<(), E::Error> {
        let (s, l) = (self.settings, self.layout);
        let (w, h, groups) = (self.width, self.height, l.groups());
        let bal = balance::BalanceParams {
            rays_per_pixel: frame_budget(&self.rates(), self.since_reset, self.reset_refill_on()),
            ring_count: buckets::ring_count(w, h),
            raise: s.rates.spend_saved_rays as u32,
            policy: self.policy(),
            groups,
            plane_groups: l.plane_groups,
            planes: l.planes,
            signal_floor: s.rates.signal_floor,
            refill_rays: s.detector.refill_rays,
            refill_share: s.detector.refill_share,
            after_reset: (self.since_reset == 1 && self.reset_share() > 0.0) as u32,
            shift: self.shifting_groups(importance_group),
        };
        let balance = kernels::BalanceBindings {
            counts: self.counts,
            out: self.decision,
            args: self.args,
            refill: self.refill_args,
        };
        exec.dispatch(&balance.pass(&bal, Groups::Direct([1, 1, 1])))?;
        Ok(())
    }

    /// The balancer's policy: the SVGF baseline's fixed rate without VRRT requests, balanced
    /// rates, or every request granted.
    pub(super) fn policy(&self) -> u32 {
        let r = &self.settings.rates;
        if r.supersample_target <= 0.0 {
            balance::POLICY_FIXED
        } else if r.load_balance {
            balance::POLICY_BALANCE
        } else {
            balance::POLICY_KEEP
        }
    }

    /// Trims the rays apply will realise to each group's budget ([`trim`]): the histogram of
    /// the last rays' priorities, then each group's cut, into its decision.
    fn trim<E: Executor>(&mut self, exec: &mut E) -> Result<(), E::Error> {
        let groups = self.layout.groups();
        let clear = fill::FillParams {
            len: groups * trim::HIST_LEN,
            value: 0,
        };
        let hist = kernels::FillBindings { buf: self.trim };
        exec.dispatch(&hist.over_grid(&clear, clear.len, 1, 1))?;
        let trim_count = kernels::TrimCountBindings {
            requests: self.requests,
            decision: self.decision,
            noise: self.noise,
            hist: self.trim,
        };
        let p = self.apply_params().trim();
        exec.dispatch(&trim_count.over_grid(&p, self.width, self.height, groups))?;
        let cut = trim::CutParams {
            groups,
            policy: self.policy(),
            reset_share: if self.refills_reset() {
                self.reset_share()
            } else {
                0.0
            },
        };
        let trim_cut = kernels::TrimCutBindings {
            hist: self.trim,
            decision: self.decision,
        };
        exec.dispatch(&trim_cut.over_grid(&cut, groups, 1, 1))
    }

    /// Whether this frame applies the still rule (`rates.still_sigma`): nothing moved, the rule
    /// is on and so is undersampling.
    pub(super) fn still_rule(&self) -> bool {
        let s = &self.settings.rates;
        s.undersample && s.still_sigma > 0.0 && !self.frame.moved && !self.frame.reset
    }

    /// This frame's history length clamp (rays): `temporal.max_history`, or twice that (at most
    /// 2048, what the stored binary16 length holds exactly) on a frame under the still rule.
    ///
    /// Why twice: history clamped at `N` rays and merged as a running mean is an exponential
    /// moving average, which keeps improving after the clamp; `n` rays a frame settle at the
    /// variance of a `2N + n`-ray mean (`σ² · α / (2 − α) / n` with `α = n / (N + n)`). A still
    /// pixel that drops to the floor holds a plain mean instead, and at `N` rays it is worth half
    /// of what the same pixel would reach by tracing on, which cost save mode on the static room
    /// (`docs/algorithms/adaptive-plan.md`). Still history stays valid, so it may grow to `2N` before the pixel stops tracing; the
    /// first frame that moves cuts it back to `N` (`reproject`).
    pub(super) fn history_clamp(&self) -> f32 {
        let n = self.settings.temporal.max_history;
        if self.still_rule() {
            (2.0 * n).min(crate::payload::MAX_EXACT_COUNT)
        } else {
            n
        }
    }

    /// The parameters of this frame's apply pass (also how [`Self::read_rays`] repeats it).
    pub(super) fn apply_params(&self) -> apply::ApplyParams {
        apply::ApplyParams {
            width: self.width,
            height: self.height,
            planes: self.layout.planes,
            frame_index: self.frame.index,
            plane_groups: self.layout.plane_groups,
        }
    }
}

/// A frame's budget in rays per pixel, `since_reset` frames after the last reset: a reset frame
/// spends `rates.reset_boost` frames' budget ahead, and the next `rates.reset_payback` frames
/// take it off theirs in equal parts (balanced rates only, and not under a budget in
/// milliseconds: a frame over its time is what that budget exists to avoid). A reset during a
/// payback starts a new one: what the last had left to pay is forgiven, at most one frame's
/// budget per reset. With `refill` (the shadows' reset refill lists), the reset frame's own
/// pass leaves out the `rates.reset_refill` share of the boost, which the lists spend
/// ([`reset_reserve`]).
pub(crate) fn frame_budget(
    r: &crate::settings::RateSettings,
    since_reset: u32,
    refill: bool,
) -> f32 {
    let ahead = if !boosts(r) {
        0.0
    } else if since_reset == 0 {
        r.reset_boost - reset_reserve(r, refill) / r.rays_per_pixel
    } else if since_reset <= r.reset_payback {
        -r.reset_boost / r.reset_payback as f32
    } else {
        0.0
    };
    r.rays_per_pixel * (1.0 + ahead)
}

/// How far above the balancer's shift floor the payback frames of a signal alone keep their
/// budget per pixel ([`alone_boost`]): the shift lowers no request below
/// [`balance::SHIFT_FLOOR`]'s half ray, and where every pixel asks, as after a cut, a budget
/// below that falls back to the seed's cap, which gives a disoccluded pixel the same half ray as
/// its neighbours. A quarter more than the floor: at exactly the floor the room's disoccluded
/// pixels starved (`docs/algorithms/fresh-pixels.md`).
const PAYBACK_MARGIN: f32 = 1.25;

/// The boost of a frame of one shifted signal alone (AO: `rates.ao_reset_boost`, shadows:
/// `rates.shadow_reset_boost`, passed as `boost`) at a budget of `rays_per_pixel`: `boost`, or
/// less where its payback frames would keep under [`PAYBACK_MARGIN`] times the shift's floor per
/// pixel, but never less than `rates.reset_boost` (unless `boost` itself is less: an engine that
/// turns the boost down gets what it set). Host-side, once a frame.
pub(crate) fn alone_boost(
    r: &crate::settings::RateSettings,
    boost: f32,
    rays_per_pixel: f32,
) -> f32 {
    let least = PAYBACK_MARGIN * buckets::bucket_to_rate(balance::SHIFT_FLOOR);
    let room = r.reset_payback as f32 * (1.0 - least / rays_per_pixel.max(1e-6));
    let lowest = r.reset_boost.min(boost);
    boost.min(room).max(lowest)
}

/// Whether a reset frame spends ahead: balanced rates, a payback, and no budget in milliseconds.
fn boosts(r: &crate::settings::RateSettings) -> bool {
    r.load_balance && r.supersample_target > 0.0 && r.reset_payback != 0 && r.budget_ms <= 0.0
}

/// The share of a reset's `boost` that lists of contrasted windows take (`kernels::refill`):
/// `share`, but at most what leaves the frame's main pass one ray per pixel at
/// `rays_per_pixel`. A window's contrast compares its pixels' own means, and a pixel the main
/// pass skips has none; at half a ray per pixel, where the boost leaves no more than that, the
/// lists cost the meshes' fresh reflection pixels 29–33% and AO's whole sequences 1–2%
/// (`docs/algorithms/fresh-pixels.md`).
pub(crate) fn contrast_share(share: f32, boost: f32, rays_per_pixel: f32) -> f32 {
    let reset = rays_per_pixel * (1.0 + boost);
    let room = (reset - 1.0) / (rays_per_pixel * boost).max(1e-6);
    share.min(room.max(0.0))
}

/// Rays per pixel a reset frame sets aside for its refill lists (with `refill`): the
/// `reset_refill` share of its boost.
pub(crate) fn reset_reserve(r: &crate::settings::RateSettings, refill: bool) -> f32 {
    if refill && boosts(r) {
        r.rays_per_pixel * r.reset_boost * r.reset_refill
    } else {
        0.0
    }
}

/// The reserve as a share of what the reset frame's own pass gets ([`frame_budget`]): the
/// lists' rays are `share` times the main pass's granted budget ([`refill::reserve`]).
pub(crate) fn reset_share(r: &crate::settings::RateSettings, refill: bool) -> f32 {
    reset_reserve(r, refill) / frame_budget(r, 0, refill)
}

/// The most rays a pixel traces in a reset frame's own pass (all pixels ask alike then), the
/// fewest its refill entry gets.
pub(crate) fn reset_least(r: &crate::settings::RateSettings, refill: bool) -> u32 {
    let b = frame_budget(r, 0, refill);
    let t = b as u32;
    if (t as f32) < b {
        t + 1
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::RateSettings;

    #[test]
    fn contrast_lists_leave_the_main_pass_a_ray_per_pixel() {
        // One ray per pixel: AO's boost of 3 and the reflections' of 1 keep their shares.
        assert_eq!(contrast_share(0.35, 3.0, 1.0), 0.35);
        assert_eq!(contrast_share(0.75, 1.0, 1.0), 0.75);
        // Half a ray with a boost of 1: one ray per pixel in all, none for the lists.
        assert_eq!(contrast_share(0.75, 1.0, 0.5), 0.0);
        // In between, the share is cut to what leaves one ray: 0.8 · 2 − 1 of 0.8.
        let share = contrast_share(1.0, 1.0, 0.8);
        approx::assert_relative_eq!(share, 0.75, epsilon = 1e-6);
        approx::assert_relative_eq!(0.8 * 2.0 - 0.8 * share, 1.0, epsilon = 1e-6);
    }

    #[test]
    fn a_reset_spends_ahead_what_the_next_frames_pay_back() {
        let r = RateSettings {
            rays_per_pixel: 1.5,
            reset_boost: 1.0,
            reset_payback: 8,
            ..RateSettings::default()
        };
        assert_eq!(frame_budget(&r, 0, false), 3.0);
        let budgets: std::vec::Vec<f32> = (0..=9).map(|f| frame_budget(&r, f, false)).collect();
        approx::assert_relative_eq!(budgets.iter().sum::<f32>(), 1.5 * 10.0, epsilon = 1e-5);
        approx::assert_relative_eq!(budgets[1], 1.5 * 7.0 / 8.0);
        assert_eq!(budgets[9], 1.5, "paid back");
        assert_eq!(frame_budget(&r, u32::MAX, false), 1.5, "no reset yet");
    }

    #[test]
    fn a_boost_goes_no_further_than_its_payback_frames_afford() {
        let r = RateSettings {
            reset_boost: 1.0,
            reset_payback: 8,
            ..RateSettings::default()
        };
        assert_eq!(
            alone_boost(&r, 3.0, 1.0),
            3.0,
            "payback frames keep 5/8 of a ray"
        );
        assert_eq!(alone_boost(&r, 2.0, 1.0), 2.0, "and 3/4 at a boost of 2");
        assert_eq!(alone_boost(&r, 3.0, 4.0), 3.0);
        approx::assert_relative_eq!(alone_boost(&r, 3.0, 0.8), 1.75);
        approx::assert_relative_eq!(alone_boost(&r, 2.0, 0.8), 1.75);
        assert_eq!(alone_boost(&r, 3.0, 0.5), 1.0, "never below reset_boost");
        assert_eq!(alone_boost(&r, 3.0, 0.0), 1.0);
        let none = RateSettings {
            reset_payback: 0,
            ..r
        };
        assert_eq!(alone_boost(&none, 3.0, 1.0), 1.0);
        for (boost, rpp) in [(0.0, 1.0), (0.0, 0.25), (0.5, 0.25)] {
            assert_eq!(
                alone_boost(&r, boost, rpp),
                boost,
                "turned down, it stays down"
            );
        }
    }

    #[test]
    fn an_ao_boost_of_three_frames_is_paid_back_over_eight() {
        let r = RateSettings {
            rays_per_pixel: 1.0,
            reset_boost: 3.0,
            reset_payback: 8,
            ..RateSettings::default()
        };
        assert_eq!(frame_budget(&r, 0, false), 4.0);
        assert_eq!(frame_budget(&r, 1, false), 0.625);
        let budgets: f32 = (0..=8).map(|f| frame_budget(&r, f, false)).sum();
        approx::assert_relative_eq!(budgets, 9.0, epsilon = 1e-5);
    }

    #[test]
    fn a_reset_refill_spends_its_share_of_the_boost_on_the_lists() {
        let r = RateSettings {
            rays_per_pixel: 1.5,
            reset_boost: 1.0,
            reset_refill: 0.5,
            ..RateSettings::default()
        };
        // The main pass gets 1.5 · (1 + 0.5), the lists 0.75: the boosted 3 rays in all.
        assert_eq!(frame_budget(&r, 0, true), 2.25);
        assert_eq!(reset_reserve(&r, true), 0.75);
        approx::assert_relative_eq!(reset_share(&r, true), 1.0 / 3.0);
        assert_eq!(reset_least(&r, true), 3);
        // The payback is the boost's, lists or not.
        assert_eq!(frame_budget(&r, 1, true), frame_budget(&r, 1, false));
        assert_eq!(frame_budget(&r, 0, false), 3.0);
        assert_eq!(reset_reserve(&r, false), 0.0);
    }

    #[test]
    fn no_boost_without_balancing_or_under_a_time_budget() {
        let base = RateSettings::default();
        for r in [
            RateSettings {
                load_balance: false,
                ..base
            },
            RateSettings {
                supersample_target: 0.0,
                ..base
            },
            RateSettings {
                budget_ms: 2.0,
                ..base
            },
            RateSettings {
                reset_payback: 0,
                ..base
            },
        ] {
            assert_eq!(frame_budget(&r, 0, false), r.rays_per_pixel);
            assert_eq!(frame_budget(&r, 1, false), r.rays_per_pixel);
        }
    }
}
