//! How the balancer shares one budget between plane groups (signals): by the rays each asks for.

use super::{rays_at, BalanceParams, MAX_GROUPS, MODE_KEEP, POLICY_BALANCE};
use crate::kernels::buckets::COUNTS_LEN;

/// Rays per pixel of each plane group: one budget of `rays_per_pixel` rays for every plane,
/// shared by what each group asks for.
///
/// A group's share of the frame's rays is its share of the rays requested (each group's ray
/// costs one ray per plane it has), so every signal gets the same fraction of its request: a
/// quiet, converged AO asks for fractions of a ray and gives its rays to a signal refilling
/// history or still noisy. Requests already carry each signal's measured state (history length,
/// temporal variance; `reproject::requested_rate`). Every group keeps at least `signal_floor` of
/// its equal share, so none stops reacting. Equal rates with one group, when nothing is asked
/// for, and outside [`POLICY_BALANCE`].
///
/// Why requests and not a Neyman split by each signal's relative variance: history is clamped
/// in rays, so past the refill a signal's steady-state noise barely depends on its rays a frame;
/// the rays pay off where history is young, which is what the requests count. On the
/// multi-signal room frame (`docs/algorithms/balancer.md`) every split by measured variance
/// tried ended worse than equal shares.
pub fn group_rates(counts: &[u32], p: &BalanceParams) -> [f32; MAX_GROUPS as usize] {
    let equal = [p.rays_per_pixel; MAX_GROUPS as usize];
    if p.groups < 2 || p.groups > MAX_GROUPS || p.policy != POLICY_BALANCE || p.signal_floor >= 1.0
    {
        return equal;
    }
    // Weights: rays requested, times the planes each ray costs. Groups without a requesting
    // pixel get no floor (they would spend nothing of it).
    let mut cost = [0.0f32; MAX_GROUPS as usize];
    let mut weight = [0.0f32; MAX_GROUPS as usize];
    let mut floor = [0.0f32; MAX_GROUPS as usize];
    let (mut planes, mut total) = (0.0f32, 0.0f32);
    let mut g = 0;
    while g < p.groups {
        let i = g as usize;
        cost[i] = crate::kernels::group_planes(p.plane_groups, p.planes, g) as f32;
        weight[i] = rays_at(counts, (g * COUNTS_LEN) as usize, 0, MODE_KEEP) * cost[i];
        planes += cost[i];
        total += weight[i];
        g += 1;
    }
    if !(total > 0.0) {
        return equal;
    }
    g = 0;
    while g < p.groups {
        let i = g as usize;
        if weight[i] > 0.0 {
            floor[i] = p.signal_floor * cost[i] / planes;
        }
        g += 1;
    }
    // Groups whose share falls under their floor get the floor; the others share the rest by
    // weight. Each round fixes at least one more group or ends.
    let mut fixed = [0u32; MAX_GROUPS as usize];
    let mut round = 0;
    while round < MAX_GROUPS {
        let (left, weights) = free_share(&weight, &floor, &fixed, p.groups);
        let mut changed = false;
        g = 0;
        while g < p.groups {
            let i = g as usize;
            if fixed[i] == 0 && !(left * weight[i] >= floor[i] * weights) {
                fixed[i] = 1;
                changed = true;
            }
            g += 1;
        }
        if !changed {
            break;
        }
        round += 1;
    }
    let (left, weights) = free_share(&weight, &floor, &fixed, p.groups);
    let mut rates = equal;
    g = 0;
    while g < p.groups {
        let i = g as usize;
        let share = if fixed[i] != 0 {
            floor[i]
        } else if weights > 0.0 {
            left * weight[i] / weights
        } else {
            0.0
        };
        rates[i] = share * planes * p.rays_per_pixel / cost[i];
        g += 1;
    }
    rates
}

/// What the groups not `fixed` at their floor share: the share left and their summed weight.
fn free_share(
    weight: &[f32; MAX_GROUPS as usize],
    floor: &[f32; MAX_GROUPS as usize],
    fixed: &[u32; MAX_GROUPS as usize],
    groups: u32,
) -> (f32, f32) {
    let (mut left, mut weights) = (1.0f32, 0.0f32);
    let mut g = 0;
    while g < groups {
        let i = g as usize;
        if fixed[i] != 0 {
            left -= floor[i];
        } else {
            weights += weight[i];
        }
        g += 1;
    }
    (left, weights)
}
