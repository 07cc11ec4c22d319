//! Binned SAH BVH builder into `vrrt_core::trace`'s flat layout.
//!
//! Top-down: at each node the triangle centroids are binned along each axis (16 bins), the split
//! plane with the smallest surface-area-heuristic cost is taken if it beats making a leaf, and the
//! triangle index range is partitioned in place. Children are allocated as adjacent pairs (the
//! layout's `first`/`first + 1`). Iterative (explicit work stack), single-threaded, deterministic.
//! Depth is capped below [`MAX_DEPTH`] so the GPU traversal stack cannot overflow.

use vrrt_core::glam::Vec3;
use vrrt_core::trace::{BvhNode, Triangle, TriangleNormals, MAX_DEPTH};

/// Builder settings.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BuildOptions {
    /// Centroid bins per axis (≥ 2).
    pub bins: usize,
    /// Cost of one node traversal step relative to one triangle test.
    pub traversal_cost: f32,
    /// Leaves never hold more triangles than this unless the triangles cannot be separated
    /// (identical centroids) or the depth cap is reached.
    pub max_leaf: usize,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            bins: 16,
            traversal_cost: 1.0,
            max_leaf: 8,
        }
    }
}

/// A built BVH: nodes plus the triangles (and their normals) reordered so leaves reference
/// contiguous ranges.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    /// Nodes, root at 0.
    pub nodes: Vec<BvhNode>,
    /// Triangles in leaf order.
    pub triangles: Vec<Triangle>,
    /// Shading normals, parallel to `triangles`.
    pub normals: Vec<TriangleNormals>,
    /// `order[i]` = index in the input of `triangles[i]`.
    pub order: Vec<u32>,
}

#[derive(Copy, Clone)]
struct Aabb {
    min: Vec3,
    max: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::MAX),
        max: Vec3::splat(f32::MIN),
    };
    fn grow(&mut self, b: &Aabb) {
        self.min = self.min.min(b.min);
        self.max = self.max.max(b.max);
    }
    fn grow_point(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    fn area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }
}

fn node(b: &Aabb, first: u32, count: u32) -> BvhNode {
    BvhNode {
        min_x: b.min.x,
        min_y: b.min.y,
        min_z: b.min.z,
        first,
        max_x: b.max.x,
        max_y: b.max.y,
        max_z: b.max.z,
        count,
    }
}

/// Most bytes a [`Bvh`] over `triangles` triangles holds: at most `2n − 1` nodes (every leaf
/// holds a triangle), plus the reordered triangles, their normals and the order. The builder's
/// transient buffers come on top while it runs.
pub fn memory_bound(triangles: usize) -> u64 {
    use std::mem::size_of;
    let n = triangles as u64;
    let per_triangle = size_of::<Triangle>() + size_of::<TriangleNormals>() + size_of::<u32>();
    (2 * n).saturating_sub(1).max(1) * size_of::<BvhNode>() as u64 + n * per_triangle as u64
}

/// Builds with default options. `normals` may be empty (then the result's normals are empty).
pub fn build(triangles: &[Triangle], normals: &[TriangleNormals]) -> Bvh {
    build_with(triangles, normals, &BuildOptions::default())
}

/// Builds with explicit options.
pub fn build_with(triangles: &[Triangle], normals: &[TriangleNormals], opt: &BuildOptions) -> Bvh {
    check_lengths(triangles, normals);
    let (nodes, idx) = tree(triangles, opt);
    Bvh {
        nodes,
        triangles: idx.iter().map(|&i| triangles[i as usize]).collect(),
        normals: if normals.is_empty() {
            Vec::new()
        } else {
            idx.iter().map(|&i| normals[i as usize]).collect()
        },
        order: idx,
    }
}

/// Builds with default options from owned triangles and normals, reordering them in place: the
/// same BVH as [`build`] without a second copy of the triangles, which on a large mesh is most
/// of the peak memory of loading it.
pub fn build_owned(mut triangles: Vec<Triangle>, mut normals: Vec<TriangleNormals>) -> Bvh {
    check_lengths(&triangles, &normals);
    let (nodes, idx) = tree(&triangles, &BuildOptions::default());
    let mut done = vec![false; idx.len()];
    gather_in_place(&mut triangles, &idx, &mut done);
    if !normals.is_empty() {
        done.fill(false);
        gather_in_place(&mut normals, &idx, &mut done);
    }
    Bvh {
        nodes,
        triangles,
        normals,
        order: idx,
    }
}

/// Builds with default options from owned triangles, reordered in place, and only then makes
/// their normals, in leaf order (`normal(i)`: those of input triangle `i`). The same BVH as
/// [`build_owned`] given those normals, but the normals are never held in input order: the
/// build's own arrays (boxes, centroids, order, nodes) are freed before the normals exist, so
/// a large mesh's peak memory is the built BVH's and not more.
pub fn build_owned_then_normals(
    mut triangles: Vec<Triangle>,
    normal: impl FnMut(usize) -> TriangleNormals,
) -> Bvh {
    check_lengths(&triangles, &[]);
    let (nodes, idx) = tree(&triangles, &BuildOptions::default());
    let mut done = vec![false; idx.len()];
    gather_in_place(&mut triangles, &idx, &mut done);
    drop(done);
    let normals = idx.iter().map(|&i| i as usize).map(normal).collect();
    Bvh {
        nodes,
        triangles,
        normals,
        order: idx,
    }
}

/// Reorders `v` so that `v[k]` becomes the old `v[order[k]]` (`order` a permutation), one cycle
/// at a time; `done` (all false, `v`'s length) marks the positions filled.
fn gather_in_place<T: Copy>(v: &mut [T], order: &[u32], done: &mut [bool]) {
    for start in 0..v.len() {
        if done[start] {
            continue;
        }
        let first = v[start];
        let mut k = start;
        loop {
            done[k] = true;
            let j = order[k] as usize;
            if j == start {
                v[k] = first;
                break;
            }
            v[k] = v[j];
            k = j;
        }
    }
}

fn check_lengths(triangles: &[Triangle], normals: &[TriangleNormals]) {
    assert!(
        triangles.len() < u32::MAX as usize,
        "too many triangles for 32-bit indices"
    );
    assert!(
        normals.is_empty() || normals.len() == triangles.len(),
        "normals must parallel triangles"
    );
}

/// The nodes over `triangles` and the order of the triangles in their leaves.
fn tree(triangles: &[Triangle], opt: &BuildOptions) -> (Vec<BvhNode>, Vec<u32>) {
    let n = triangles.len();
    let bins = opt.bins.max(2);
    if n == 0 {
        let empty = node(
            &Aabb {
                min: Vec3::splat(1e30),
                max: Vec3::splat(-1e30),
            },
            0,
            0,
        );
        return (vec![empty], Vec::new());
    }
    let boxes: Vec<Aabb> = triangles
        .iter()
        .map(|t| {
            let mut b = Aabb {
                min: t.v0(),
                max: t.v0(),
            };
            b.grow_point(t.v1());
            b.grow_point(t.v2());
            b
        })
        .collect();
    let centroids: Vec<Vec3> = boxes.iter().map(|b| (b.min + b.max) * 0.5).collect();
    let mut idx: Vec<u32> = (0..n as u32).collect();
    let mut nodes: Vec<BvhNode> = Vec::with_capacity(2 * n / opt.max_leaf.max(1) + 1);
    nodes.push(BvhNode::default());
    // (node index, start, end, depth)
    let mut work: Vec<(usize, usize, usize, usize)> = vec![(0, 0, n, 0)];
    let mut sweep = Sweep::new(bins);
    while let Some((ni, start, end, depth)) = work.pop() {
        let range = &mut idx[start..end];
        let count = range.len();
        let mut bounds = Aabb::EMPTY;
        let mut cbounds = Aabb::EMPTY;
        for &i in range.iter() {
            bounds.grow(&boxes[i as usize]);
            cbounds.grow_point(centroids[i as usize]);
        }
        let leaf = |nodes: &mut Vec<BvhNode>| nodes[ni] = node(&bounds, start as u32, count as u32);
        if count <= 1 || depth + 1 >= MAX_DEPTH {
            leaf(&mut nodes);
            continue;
        }
        let extent = cbounds.max - cbounds.min;
        let best = sweep.best_split(range, &boxes, &centroids, &cbounds);
        let parent_area = bounds.area().max(f32::MIN_POSITIVE);
        let split = match best {
            Some((cost, axis, b)) => {
                let split_cost = opt.traversal_cost + cost / parent_area;
                if split_cost < count as f32 || count > opt.max_leaf {
                    let (min, scale) = (cbounds.min[axis], bins as f32 / extent[axis]);
                    let mid = partition(range, |i| {
                        bin_of(centroids[i as usize][axis], min, scale, bins) < b
                    });
                    Some(mid)
                } else {
                    None
                }
            }
            // All centroids coincide: only an arbitrary halving can shrink a too-large leaf.
            None if count > opt.max_leaf => Some(count / 2),
            None => None,
        };
        let Some(mid) = split.filter(|&m| m > 0 && m < count) else {
            leaf(&mut nodes);
            continue;
        };
        let left = nodes.len();
        nodes.push(BvhNode::default());
        nodes.push(BvhNode::default());
        nodes[ni] = node(&bounds, left as u32, 0);
        work.push((left + 1, start + mid, end, depth + 1));
        work.push((left, start, start + mid, depth + 1));
    }
    (nodes, idx)
}

/// The binned surface-area heuristic's scratch space, kept across the nodes of one build.
struct Sweep {
    bins: usize,
    boxes: Vec<Aabb>,
    counts: Vec<usize>,
    /// Area and count of bins `b..bins`, from the sweep from the right.
    right_area: Vec<f32>,
    right_count: Vec<usize>,
}

impl Sweep {
    fn new(bins: usize) -> Self {
        Sweep {
            bins,
            boxes: vec![Aabb::EMPTY; bins],
            counts: vec![0; bins],
            right_area: vec![0.0; bins],
            right_count: vec![0; bins],
        }
    }

    /// The cheapest split of the triangles `range` over all axes, as (cost, axis, bin
    /// boundary), binning their centroids within `cbounds`; `None` when every centroid
    /// coincides.
    fn best_split(
        &mut self,
        range: &[u32],
        boxes: &[Aabb],
        centroids: &[Vec3],
        cbounds: &Aabb,
    ) -> Option<(f32, usize, usize)> {
        let bins = self.bins;
        let mut best: Option<(f32, usize, usize)> = None;
        let extent = cbounds.max - cbounds.min;
        for axis in 0..3 {
            if !extent[axis].is_finite() || extent[axis] <= 0.0 {
                continue;
            }
            let scale = bins as f32 / extent[axis];
            self.boxes.fill(Aabb::EMPTY);
            self.counts.fill(0);
            for &i in range.iter() {
                let b = bin_of(centroids[i as usize][axis], cbounds.min[axis], scale, bins);
                self.boxes[b].grow(&boxes[i as usize]);
                self.counts[b] += 1;
            }
            let mut acc = Aabb::EMPTY;
            let mut c = 0;
            for b in (1..bins).rev() {
                acc.grow(&self.boxes[b]);
                c += self.counts[b];
                self.right_area[b] = acc.area();
                self.right_count[b] = c;
            }
            let mut acc = Aabb::EMPTY;
            let mut c = 0;
            for b in 1..bins {
                acc.grow(&self.boxes[b - 1]);
                c += self.counts[b - 1];
                if c == 0 || self.right_count[b] == 0 {
                    continue;
                }
                let cost = acc.area() * c as f32 + self.right_area[b] * self.right_count[b] as f32;
                if best.is_none_or(|(bc, _, _)| cost < bc) {
                    best = Some((cost, axis, b));
                }
            }
        }
        best
    }
}

#[inline]
fn bin_of(c: f32, min: f32, scale: f32, bins: usize) -> usize {
    (((c - min) * scale) as usize).min(bins - 1)
}

/// In-place partition: elements satisfying `pred` first; returns their count.
fn partition(v: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut i = 0;
    let mut j = v.len();
    while i < j {
        if pred(v[i]) {
            i += 1;
        } else {
            j -= 1;
            v.swap(i, j);
        }
    }
    i
}

/// Depth of the tree (root = 0) and number of leaves: for tests and statistics.
pub fn depth_and_leaves(nodes: &[BvhNode]) -> (usize, usize) {
    let mut stack = vec![(0usize, 0usize)];
    let (mut depth, mut leaves) = (0, 0);
    while let Some((i, d)) = stack.pop() {
        depth = depth.max(d);
        let n = &nodes[i];
        if n.count > 0 {
            leaves += 1;
        } else if n.min_x <= n.max_x {
            stack.push((n.first as usize, d + 1));
            stack.push((n.first as usize + 1, d + 1));
        }
    }
    (depth, leaves)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vrrt_core::trace::{closest_hit, closest_hit_brute_force, occluded, Ray};

    /// Deterministic xorshift for test geometry.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn vec(&mut self, s: f32) -> Vec3 {
            Vec3::new(self.next() - 0.5, self.next() - 0.5, self.next() - 0.5) * s
        }
    }

    fn random_triangles(n: usize, seed: u64) -> Vec<Triangle> {
        let mut r = Rng(seed);
        (0..n)
            .map(|i| {
                let c = r.vec(20.0);
                let size = if i % 7 == 0 { 4.0 } else { 0.7 };
                Triangle::new(
                    c + r.vec(size),
                    c + r.vec(size),
                    c + r.vec(size),
                    i as u32 % 5,
                )
            })
            .collect()
    }

    fn check_invariants(bvh: &Bvh, n: usize) {
        let mut seen = vec![0u32; n];
        let mut stack = vec![0usize];
        let mut visited_nodes = 0;
        while let Some(i) = stack.pop() {
            visited_nodes += 1;
            let nd = bvh.nodes[i];
            if nd.count > 0 {
                for t in nd.first..nd.first + nd.count {
                    seen[bvh.order[t as usize] as usize] += 1;
                    let tri = bvh.triangles[t as usize];
                    for v in [tri.v0(), tri.v1(), tri.v2()] {
                        assert!(
                            v.cmpge(nd.min()).all() && v.cmple(nd.max()).all(),
                            "triangle outside leaf"
                        );
                    }
                }
            } else {
                for c in [nd.first as usize, nd.first as usize + 1] {
                    let ch = bvh.nodes[c];
                    assert!(
                        ch.min().cmpge(nd.min()).all() && ch.max().cmple(nd.max()).all(),
                        "child outside parent"
                    );
                    stack.push(c);
                }
            }
        }
        assert!(
            seen.iter().all(|&s| s == 1),
            "every triangle reachable exactly once"
        );
        assert_eq!(visited_nodes, bvh.nodes.len(), "no orphan nodes");
        assert!(depth_and_leaves(&bvh.nodes).0 < MAX_DEPTH);
    }

    #[test]
    fn building_in_place_gives_the_same_bvh() {
        let tris = random_triangles(3000, 7);
        let normals: Vec<TriangleNormals> = (0..tris.len())
            .map(|i| {
                let v = Vec3::new(i as f32, 1.0, 0.0).normalize();
                TriangleNormals::new(v, v, v)
            })
            .collect();
        let copied = build(&tris, &normals);
        assert_eq!(build_owned(tris.clone(), normals), copied);
        assert_eq!(build_owned(tris.clone(), Vec::new()), build(&tris, &[]));
        assert_eq!(build_owned(Vec::new(), Vec::new()), build(&[], &[]));
    }

    #[test]
    fn invariants_hold() {
        for &n in &[1usize, 2, 3, 17, 1000, 5000] {
            let tris = random_triangles(n, 42 + n as u64);
            let bvh = build(&tris, &[]);
            check_invariants(&bvh, n);
            for (i, t) in bvh.triangles.iter().enumerate() {
                assert_eq!(*t, tris[bvh.order[i] as usize]);
            }
        }
    }

    #[test]
    fn identical_centroids_and_depth_cap() {
        // 100 copies of one triangle: no split separates them; leaves get halved anyway.
        let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y, 0);
        let bvh = build(&vec![t; 100], &[]);
        check_invariants(&bvh, 100);
        // A geometric sequence of sizes would make a deep tree without the cap.
        let tris: Vec<Triangle> = (0..200)
            .map(|i| {
                let s = 0.8f32.powi(i);
                Triangle::new(
                    Vec3::splat(s),
                    Vec3::splat(s) + Vec3::X * s * 0.01,
                    Vec3::splat(s) + Vec3::Y * s * 0.01,
                    0,
                )
            })
            .collect();
        let bvh = build(&tris, &[]);
        check_invariants(&bvh, 200);
    }

    #[test]
    fn empty_input_misses() {
        let bvh = build(&[], &[]);
        let ray = Ray {
            origin: Vec3::ZERO,
            dir: Vec3::X,
        };
        assert!(!closest_hit(&bvh.nodes, &bvh.triangles, &ray, 1e30).is_hit());
    }

    #[test]
    fn traversal_equals_brute_force() {
        let tris = random_triangles(3000, 7);
        let bvh = build(&tris, &[]);
        let mut r = Rng(99);
        let mut hits = 0;
        for i in 0..3000 {
            let origin = r.vec(30.0);
            // Some axis-parallel rays too.
            let dir = match i % 10 {
                0 => Vec3::X,
                1 => -Vec3::Z,
                _ => r.vec(2.0),
            };
            if dir.length() < 1e-3 {
                continue;
            }
            let ray = Ray { origin, dir };
            let t_max = if i % 3 == 0 { 5.0 } else { 1e30 };
            let a = closest_hit(&bvh.nodes, &bvh.triangles, &ray, t_max);
            let b = closest_hit_brute_force(&bvh.triangles, &ray, t_max);
            assert_eq!(a, b, "ray {i}");
            assert_eq!(
                occluded(&bvh.nodes, &bvh.triangles, &ray, t_max),
                b.is_hit()
            );
            hits += a.is_hit() as usize;
        }
        assert!(hits > 500, "test rays should hit often ({hits})");
    }
}
