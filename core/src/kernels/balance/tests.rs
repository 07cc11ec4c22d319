//! Unit tests of the balancer: water filling and the budget's split between signals.

use super::*;
use crate::kernels::buckets::{COUNTS_LEN, MAX_RINGS};

fn params(rays_per_pixel: f32, ring_count: u32, raise: u32) -> BalanceParams {
    BalanceParams {
        rays_per_pixel,
        ring_count,
        raise,
        policy: POLICY_BALANCE,
        groups: 1,
        plane_groups: 0,
        planes: 1,
        signal_floor: 1.0,
        refill_rays: 1,
        refill_share: 1.0,
        after_reset: 0,
        shift: 0,
    }
}

/// The decision of a one-group histogram.
fn solve_one(c: &[u32], p: &BalanceParams) -> Balance {
    solve(c, 0, p.rays_per_pixel, 0.0, p)
}

/// A histogram with `n` pixels per (bucket, ring) entry given.
fn histogram(entries: &[(u32, u32, u32)]) -> [u32; COUNTS_LEN as usize] {
    let mut c = [0u32; COUNTS_LEN as usize];
    for &(b, ring, n) in entries {
        c[b as usize] += n;
        c[((1 + ring) * BUCKET_COUNT + b) as usize] += n;
    }
    c
}

/// Expected rays granted, recomputed pixel group by pixel group from `granted_rate`.
fn granted(c: &[u32], rings: u32, d: &Balance) -> f64 {
    let mut sum = 0.0;
    for r in 0..rings {
        for b in 0..BUCKET_COUNT {
            let n = c[((1 + r) * BUCKET_COUNT + b) as usize] as f64;
            sum += n * granted_rate(b, r, d) as f64;
        }
    }
    sum
}

#[test]
fn converged_image_at_one_and_a_half_rays_gives_the_centre_two() {
    // 4 rings of 100 pixels, all asking for 1 ray; budget 1.5 rays per pixel.
    let c = histogram(&[(64, 0, 100), (64, 1, 100), (64, 2, 100), (64, 3, 100)]);
    let d = solve_one(&c, &params(1.5, 4, 1));
    assert_eq!(d.mode, MODE_UNDER);
    assert_eq!(d.bucket_threshold, 64);
    assert_eq!(d.ring_threshold, 2, "inner half of the rings get 2 rays");
    assert_eq!(granted(&c, 4, &d), 600.0);
    // Save mode leaves the budget unspent.
    let d = solve_one(&c, &params(1.5, 4, 0));
    assert_eq!(d.mode, MODE_KEEP);
}

#[test]
fn over_budget_drops_the_highest_requests_first() {
    // 10 disoccluded pixels want 16 rays, 90 converged want 1; budget 1 ray per pixel.
    let c = histogram(&[(79, 0, 10), (64, 0, 90)]);
    let d = solve_one(&c, &params(1.0, 1, 1));
    assert_eq!(d.mode, MODE_OVER);
    assert!(granted(&c, 1, &d) <= 100.0);
    assert_eq!(
        granted_bucket(64, 0, &d),
        64,
        "converged pixels keep their ray"
    );
    assert!(bucket_to_rate(granted_bucket(79, 0, &d)) >= 1.0);
}

#[test]
fn shifted_requests_give_the_rays_to_the_shortest_history() {
    // After a camera cut: 90 pixels hold 10 rays and ask for 6, 10 were disoccluded this frame
    // and ask for 16; budget 1 ray per pixel, in two rings.
    let c = histogram(&[(69, 0, 45), (69, 1, 45), (79, 0, 5), (79, 1, 5)]);
    // Capped (the seed's), every pixel gets the same.
    let capped = solve_one(&c, &params(1.0, 2, 1));
    assert_eq!(capped.mode, MODE_OVER);
    assert_eq!(granted_rate(79, 0, &capped), granted_rate(69, 0, &capped));
    // Shifted, the disoccluded pixels get most of the budget: history plus rays would be level
    // at 0 new rays for the others and 10 for them, but no request falls below the floor, so
    // the others keep half a ray and the rest goes to the disoccluded.
    let shifted = solve_one(
        &c,
        &BalanceParams {
            shift: 1,
            ..params(1.0, 2, 1)
        },
    );
    assert_eq!(shifted.mode, MODE_SHIFT);
    for ring in 0..2 {
        let fresh = bucket_to_rate(granted_bucket(79, ring, &shifted));
        let young = bucket_to_rate(granted_bucket(69, ring, &shifted));
        assert!(fresh >= 5.0 && young == 0.5, "{fresh} {young}");
    }
    let total = granted(&c, 2, &shifted);
    assert!((99.0..=100.001).contains(&total), "{total}");
}

#[test]
fn below_the_shifts_floor_the_seeds_cap_decides() {
    // Every pixel asks for 16 rays (a camera cut); a quarter of a ray each is all there is.
    let c = histogram(&[(79, 0, 100)]);
    let p = BalanceParams {
        shift: 1,
        ..params(0.25, 1, 1)
    };
    let d = solve_one(&c, &p);
    assert_eq!(d.mode, MODE_OVER);
    assert!(granted(&c, 1, &d) <= 25.001, "{d:?}");
}

#[test]
fn lifted_requests_spend_the_rest_on_young_history() {
    // 90 converged pixels ask for 1/8 ray, 10 young ones for 2; budget 1 ray per pixel.
    let c = histogram(&[(56, 0, 90), (65, 0, 10)]);
    let p = |shift| BalanceParams {
        shift,
        ..params(1.0, 1, 1)
    };
    // Raised to the threshold (the seed's), the converged pixels get the rays left over.
    let raised = solve_one(&c, &p(0));
    assert_eq!(raised.mode, MODE_UNDER);
    assert_eq!(granted_rate(65, 0, &raised), 2.0);
    // Lifted, the young pixels gain as many buckets as the converged ones: whole rays.
    let lifted = solve_one(&c, &p(1));
    assert_eq!(lifted.mode, MODE_LIFT);
    assert!(granted_rate(65, 0, &lifted) >= 4.0, "{lifted:?}");
    assert!(granted_rate(56, 0, &lifted) < granted_rate(56, 0, &raised));
    let total = granted(&c, 1, &lifted);
    assert!((99.0..=100.001).contains(&total), "{total}");
}

#[test]
fn shift_and_lift_are_monotone_and_end_at_the_requests() {
    for b in 0..BUCKET_COUNT {
        assert_eq!(mapped_bucket(b, BUCKET_COUNT - 1, MODE_SHIFT), b);
        assert_eq!(mapped_bucket(b, 0, MODE_SHIFT), b.min(SHIFT_FLOOR));
        assert_eq!(mapped_bucket(b, 0, MODE_LIFT), b);
        for t in 1..BUCKET_COUNT {
            for mode in [MODE_SHIFT, MODE_LIFT] {
                let (lower, upper) = (mapped_bucket(b, t - 1, mode), mapped_bucket(b, t, mode));
                assert!(upper == lower || upper == lower + 1, "b {b} t {t}");
            }
        }
    }
}

#[test]
fn last_frames_refill_rays_come_off_the_budget() {
    // 100 pixels asking for 1 ray, 10 rays already spent by last frame's refill list.
    let c = histogram(&[(64, 0, 100)]);
    let d = solve(&c, 0, 1.0, 10.0, &params(1.0, 1, 1));
    assert_eq!(d.budget, 90.0);
    assert_eq!(d.mode, MODE_OVER);
    assert!(granted(&c, 1, &d) <= 90.0, "{}", granted(&c, 1, &d));
    // More spent than the whole budget: nothing is left, not a negative budget.
    assert_eq!(solve(&c, 0, 1.0, 500.0, &params(1.0, 1, 1)).budget, 0.0);
}

#[test]
fn half_a_ray_is_spent_although_no_bucket_lies_between_a_half_and_one() {
    // 50 converged pixels at 1/4 ray, 50 asking for 1; budget 1/2 ray per pixel (50 rays).
    // Clamping to 1/2 spends 37.5; the partial step gives the 50 others 3/4 each.
    let c = histogram(&[(60, 0, 50), (64, 0, 50)]);
    let d = solve_one(&c, &params(0.5, 1, 1));
    assert_eq!(
        (d.mode, d.bucket_threshold, d.ring_threshold),
        (MODE_OVER, 62, 1)
    );
    assert_eq!(d.partial, 0.5);
    assert_eq!(granted_rate(64, 0, &d), 0.75);
    assert_eq!(
        granted_rate(60, 0, &d),
        0.25,
        "converged pixels keep their rate"
    );
    assert_eq!(granted(&c, 1, &d), 50.0);
}

#[test]
fn fixed_policy_grants_the_budget_rate_to_every_request() {
    let c = histogram(&[(60, 0, 50), (79, 0, 50)]);
    let p = BalanceParams {
        policy: POLICY_FIXED,
        ..params(1.5, 1, 1)
    };
    let d = solve_one(&c, &p);
    assert_eq!(d.mode, MODE_FIXED);
    assert_eq!(granted_rate(79, 0, &d), 1.5);
    assert_eq!(granted(&c, 1, &d), 150.0);
}

#[test]
fn infeasible_budget_clamps_to_the_lowest_rate() {
    let c = histogram(&[(64, 0, 1000)]);
    let d = solve_one(&c, &params(0.001, 1, 1));
    assert_eq!(d.bucket_threshold, 0);
    assert!(d.granted > d.budget);
}

/// Budget invariant over random histograms: whenever the budget can be met, expected rays
/// granted never exceed it; and the balancer spends it to within one bucket step of one ring.
#[test]
fn budget_invariant_over_random_histograms() {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for case in 0..3000 {
        let rings = 1 + (next() % MAX_RINGS as u64) as u32;
        let mut entries = [(0u32, 0u32, 0u32); 40];
        for e in entries.iter_mut() {
            *e = (
                (next() % BUCKET_COUNT as u64) as u32,
                (next() % rings as u64) as u32,
                (next() % 2000) as u32,
            );
        }
        let c = histogram(&entries);
        let pixels: u32 = c[..BUCKET_COUNT as usize].iter().sum();
        let rpp = [0.25f32, 0.5, 1.0, 1.5, 2.0, 4.0][case % 6];
        let p = params(rpp, rings, 1);
        let d = solve_one(&c, &p);
        let got = granted(&c, rings, &d);
        let budget = rpp as f64 * pixels as f64;
        let feasible = (pixels as f64 / 64.0) <= budget;
        if feasible {
            // f32 accumulation in the solver vs f64 here: allow relative rounding only.
            assert!(
                got <= budget * (1.0 + 1e-5),
                "case {case}: {got} > {}",
                budget
            );
            approx::assert_relative_eq!(got as f32, d.granted, max_relative = 1e-4);
        }
        if feasible && d.mode != MODE_KEEP && d.bucket_threshold + 1 < BUCKET_COUNT {
            // With the partial step the budget is spent, up to f32 rounding.
            assert!(
                budget - got <= 1e-4 * budget,
                "case {case}: left {} of {budget} unspent",
                budget - got
            );
        }
    }
}

/// Counts of plane groups whose 100 pixels each ask for `rates` rays (a bucket's rate).
fn group_counts(buckets: &[u32]) -> std::vec::Vec<u32> {
    let mut c = std::vec![0u32; buckets.len() * COUNTS_LEN as usize];
    for (g, &b) in buckets.iter().enumerate() {
        let base = g * COUNTS_LEN as usize;
        c[base + b as usize] = 100;
        c[base + (BUCKET_COUNT + b) as usize] = 100;
    }
    c
}

fn grouped(plane_groups: u32, planes: u32, signal_floor: f32) -> BalanceParams {
    let groups = crate::kernels::plane_group(plane_groups, planes - 1) + 1;
    BalanceParams {
        groups,
        plane_groups,
        planes,
        signal_floor,
        ..params(1.0, 1, 1)
    }
}

/// Rays of every group weighted by its planes, per plane: the shared budget.
fn rays_per_plane(rates: &[f32], costs: &[f32]) -> f32 {
    let planes: f32 = costs.iter().sum();
    rates.iter().zip(costs).map(|(r, c)| r * c).sum::<f32>() / planes
}

#[test]
fn a_quiet_signal_gives_rays_to_one_that_asks_at_equal_total() {
    // AO (plane 0) converged at 1/8 ray, reflections (plane 1) refilling at 4 rays: shares
    // 1/33 and 32/33 of the two planes' rays.
    let c = group_counts(&[56, 67]);
    assert_eq!((bucket_to_rate(56), bucket_to_rate(67)), (0.125, 4.0));
    let rates = group_rates(&c, &grouped(0x10, 2, 0.0));
    approx::assert_relative_eq!(rates[0], 2.0 / 33.0, max_relative = 1e-5);
    approx::assert_relative_eq!(rates[1], 64.0 / 33.0, max_relative = 1e-5);
    approx::assert_relative_eq!(rays_per_plane(&rates[..2], &[1.0, 1.0]), 1.0);
    // The floor keeps the quiet one at a quarter of its equal share.
    let p = grouped(0x10, 2, 0.25);
    let rates = group_rates(&c, &p);
    approx::assert_relative_eq!(rates[0], 0.25, max_relative = 1e-5);
    approx::assert_relative_eq!(rates[1], 1.75, max_relative = 1e-5);
    // Each group's decision spends its own rate.
    let d = solve(&c, 1, rates[1], 0.0, &p);
    approx::assert_relative_eq!(d.budget, 175.0, max_relative = 1e-5);
}

#[test]
fn a_group_of_several_planes_pays_for_each() {
    // AO, two shadow planes, reflections, all asking for one ray: equal rates, as each
    // shadow ray costs two.
    let c = group_counts(&[64, 64, 64]);
    let rates = group_rates(&c, &grouped(0x2110, 4, 0.0));
    for r in &rates[..3] {
        approx::assert_relative_eq!(*r, 1.0, max_relative = 1e-5);
    }
    approx::assert_relative_eq!(rays_per_plane(&rates[..3], &[1.0, 2.0, 1.0]), 1.0);
}

#[test]
fn equal_rates_without_requests_or_a_split() {
    let nothing = std::vec![0u32; 2 * COUNTS_LEN as usize];
    assert_eq!(group_rates(&nothing, &grouped(0x10, 2, 0.0))[..2], [1.0; 2]);
    let c = group_counts(&[56, 67]);
    assert_eq!(group_rates(&c, &grouped(0x10, 2, 1.0))[..2], [1.0; 2]);
    let fixed = BalanceParams {
        policy: POLICY_FIXED,
        ..grouped(0x10, 2, 0.0)
    };
    assert_eq!(group_rates(&c, &fixed)[..2], [1.0; 2]);
    // A group without requesting pixels gets no floor: the other spends the whole budget.
    let mut one = group_counts(&[64, 64]);
    one[COUNTS_LEN as usize + 64] = 0;
    one[COUNTS_LEN as usize + BUCKET_COUNT as usize + 64] = 0;
    let rates = group_rates(&one, &grouped(0x10, 2, 0.5));
    assert_eq!((rates[0], rates[1]), (2.0, 0.0));
}

#[test]
fn the_workgroup_phases_give_the_serial_decisions_bit_for_bit() {
    use std::{vec, vec::Vec};
    assert_eq!(crate::kernels::BALANCE.workgroup_size, [THREADS, 1, 1]);
    let mut state = 0x9e37_79b9u32;
    let mut next = move |n: u32| {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state % n
    };
    for case in 0..200 {
        let groups = 1 + case % MAX_GROUPS;
        let rings = 1 + next(MAX_RINGS);
        let mut c = vec![0u32; (groups * COUNTS_LEN) as usize];
        for g in 0..groups {
            for _ in 0..next(400) {
                let (b, ring) = (next(BUCKET_COUNT), next(rings));
                let n = 1 + next(50);
                c[(g * COUNTS_LEN + b) as usize] += n;
                c[(g * COUNTS_LEN + (1 + ring) * BUCKET_COUNT + b) as usize] += n;
            }
        }
        let p = BalanceParams {
            rays_per_pixel: [0.1f32, 0.5, 1.0, 1.7, 4.0][next(5) as usize],
            ring_count: rings,
            raise: next(2),
            policy: [POLICY_KEEP, POLICY_BALANCE, POLICY_BALANCE, POLICY_FIXED][next(4) as usize],
            groups,
            plane_groups: [0x0, 0x10, 0x210, 0x3210][groups as usize - 1],
            planes: groups,
            signal_floor: [0.0f32, 0.25, 1.0][next(3) as usize],
            refill_rays: 1 + next(8),
            refill_share: [0.1f32, 0.5, 1.0][next(3) as usize],
            after_reset: (next(3) == 0) as u32,
            shift: next(16),
        };
        let rates = group_rates(&c, &p);
        // Last frame's refill lists: their counts times their rays come off each group's budget.
        let mut refill = vec![7u32; (groups * crate::kernels::work_list::ARGS_LEN) as usize];
        for g in 0..groups as usize {
            refill[4 * g] = next(3) * next(200);
        }
        // Last frame's decisions, left in the output: the balancer overwrites them unread.
        let last: Vec<Balance> = (0..groups)
            .map(|_| Balance {
                budget: (next(1000) * 7) as f32,
                ..Balance::default()
            })
            .collect();
        let serial: Vec<Balance> = (0..groups)
            .map(|g| {
                let spent = refill_reserve(refill[4 * g as usize], &p);
                solve(&c, g, rates[g as usize], spent, &p)
            })
            .collect();
        let mut out = last.clone();
        let mut args = vec![7u32; (groups * crate::kernels::work_list::ARGS_LEN) as usize];
        let mut local: Shared = bytemuck::Zeroable::zeroed();
        let phases: [fn(WorkgroupIds, &BalanceParams, BalanceIo<'_>, &mut Shared); 5] =
            [setup, sums, pick, super::rings, write];
        for phase in phases {
            for i in 0..THREADS {
                let ids = WorkgroupIds {
                    global: glam::UVec3::new(i, 0, 0),
                    group: glam::UVec3::ZERO,
                    local_index: i,
                };
                let io = BalanceIo {
                    counts: &c,
                    out: &mut out,
                    args: &mut args,
                    refill: &mut refill,
                };
                phase(ids, &p, io, &mut local);
            }
        }
        for (g, (a, b)) in out.iter().zip(&serial).enumerate() {
            assert_eq!(
                bytemuck::bytes_of(a),
                bytemuck::bytes_of(b),
                "case {case} group {g}"
            );
        }
        assert!(args.chunks(4).all(|a| a == [0, 0, 1, 1]));
        assert!(refill.chunks(4).all(|a| a == [0, 0, 1, 1]));
    }
}

#[test]
fn last_frames_lists_set_rays_aside() {
    let detector = BalanceParams {
        refill_rays: 4,
        ..params(1.0, 1, 1)
    };
    // The detector's lists: their rays and a quarter more.
    assert_eq!(refill_reserve(30, &detector), 150.0);
    // A reset frame's: one ray per entry.
    let reset = BalanceParams {
        after_reset: 1,
        ..detector
    };
    assert_eq!(refill_reserve(100, &reset), 100.0);
}

#[test]
fn the_lists_set_aside_at_most_their_share_of_the_budget() {
    // 100 pixels asking for one ray each (bucket 64), one ray per pixel: 100 rays.
    let c = histogram(&[(64, 0, 100)]);
    let p = BalanceParams {
        refill_share: 0.1,
        ..params(1.0, 1, 1)
    };
    // Lists worth 80 rays keep 10 aside; lists worth 6 keep their 6.
    assert_eq!(solve(&c, 0, 1.0, 80.0, &p).budget, 90.0);
    assert_eq!(solve(&c, 0, 1.0, 6.0, &p).budget, 94.0);
    let whole = BalanceParams {
        refill_share: 1.0,
        ..p
    };
    assert_eq!(solve(&c, 0, 1.0, 80.0, &whole).budget, 20.0);
}
