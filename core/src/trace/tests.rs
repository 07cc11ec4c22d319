//! Unit tests of the ray/triangle and ray/box tests and traversal (host-only, apart from kernels).

use super::*;

fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Triangle {
    Triangle::new(Vec3::from(a), Vec3::from(b), Vec3::from(c), 0)
}

#[test]
fn layout_sizes() {
    assert_eq!(core::mem::size_of::<BvhNode>(), 32);
    assert_eq!(core::mem::size_of::<Triangle>(), 40);
    assert_eq!(core::mem::size_of::<TriangleNormals>(), 36);
}

#[test]
fn triangle_hit_and_barycentrics() {
    let t = tri([0.0, 0.0, 5.0], [1.0, 0.0, 5.0], [0.0, 1.0, 5.0]);
    let target = Vec3::new(0.25, 0.5, 5.0);
    for dir in [
        Vec3::Z,
        Vec3::new(0.1, 0.2, 1.0),
        Vec3::new(-0.3, 0.1, -1.0),
    ] {
        let ray = Ray {
            origin: target - dir * 5.0,
            dir,
        };
        let h = closest_hit_brute_force(&[t], &ray, 1e30);
        assert!(h.is_hit());
        assert!((h.t - 5.0).abs() < 1e-5);
        assert!((h.b1 - 0.25).abs() < 1e-6 && (h.b2 - 0.5).abs() < 1e-6);
        assert!((t.point(h.b1, h.b2) - target).length() < 1e-5);
    }
    // Behind the origin, and beyond t_max: no hit.
    let back = Ray {
        origin: Vec3::new(0.2, 0.2, 6.0),
        dir: Vec3::Z,
    };
    assert!(!closest_hit_brute_force(&[t], &back, 1e30).is_hit());
    let short = Ray {
        origin: Vec3::new(0.2, 0.2, 0.0),
        dir: Vec3::Z,
    };
    assert!(!closest_hit_brute_force(&[t], &short, 4.999).is_hit());
    assert!(closest_hit_brute_force(&[t], &short, 5.001).is_hit());
    // Backfaces are hit too (two-sided).
    let rev = Ray {
        origin: Vec3::new(0.2, 0.2, 10.0),
        dir: -Vec3::Z,
    };
    assert!(closest_hit_brute_force(&[t], &rev, 1e30).is_hit());
}

#[test]
fn watertight_on_shared_edge() {
    // Two triangles sharing the diagonal of a unit square; rays exactly through the diagonal.
    let a = tri([0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0]);
    let b = tri([0.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0]);
    // Interior points of the diagonal (its end points are the mesh's outer corners).
    for i in 1..64 {
        let s = i as f32 / 64.0;
        for dir in [
            Vec3::Z,
            Vec3::new(0.3, -0.2, 1.0),
            Vec3::new(-1e-3, 1e-3, 1.0),
        ] {
            let origin = Vec3::new(s, s, 1.0) - dir;
            let h = closest_hit_brute_force(&[a, b], &Ray { origin, dir }, 1e30);
            assert!(h.is_hit(), "leak at s = {s}, dir {dir}");
        }
    }
}

#[test]
fn single_leaf_bvh_and_axis_parallel_rays() {
    let tris = [tri([-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0])];
    let nodes = [BvhNode {
        min_x: -1.0,
        min_y: -1.0,
        min_z: 0.0,
        first: 0,
        max_x: 1.0,
        max_y: 1.0,
        max_z: 0.0,
        count: 1,
    }];
    let ray = Ray {
        origin: Vec3::new(0.0, 0.0, -3.0),
        dir: Vec3::Z,
    };
    let h = closest_hit(&nodes, &tris, &ray, 1e30);
    assert_eq!(h.tri, 0);
    assert_eq!(h.t, 3.0);
    assert!(occluded(&nodes, &tris, &ray, 3.5));
    assert!(!occluded(&nodes, &tris, &ray, 3.0));
    let away = Ray {
        origin: Vec3::new(0.0, 0.0, -3.0),
        dir: -Vec3::Z,
    };
    assert!(!closest_hit(&nodes, &tris, &away, 1e30).is_hit());
    assert!(!closest_hit(&[], &[], &ray, 1e30).is_hit());
}

#[test]
fn empty_tree_misses() {
    let empty = BvhNode {
        min_x: 1e30,
        min_y: 1e30,
        min_z: 1e30,
        first: 0,
        max_x: -1e30,
        max_y: -1e30,
        max_z: -1e30,
        count: 0,
    };
    let ray = Ray {
        origin: Vec3::ZERO,
        dir: Vec3::X,
    };
    assert!(!closest_hit(&[empty], &[], &ray, 1e30).is_hit());
}
