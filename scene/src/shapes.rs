//! Procedural meshes for the built-in scenes and benchmarks: quads, boxes, cylinders, spheres.
//! All are closed or single-sided surfaces with outward (or `u × v`) normals.

use crate::mesh::Mesh;
use vrrt_core::glam::Vec3;
use vrrt_core::math;

fn mesh(positions: Vec<Vec3>, normals: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Mesh {
    Mesh::new(
        std::path::Path::new("<procedural>"),
        positions,
        normals,
        indices,
    )
    .expect("procedural meshes are valid by construction")
}

/// The parallelogram `corner + a·u + b·v`, `a, b ∈ [0, 1]`, facing `u × v`.
pub fn quad(corner: Vec3, u: Vec3, v: Vec3) -> Mesh {
    let n = u.cross(v).normalize_or(Vec3::Y);
    mesh(
        vec![corner, corner + u, corner + u + v, corner + v],
        vec![n; 4],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

/// An axis-aligned box with flat outward normals (24 vertices, 12 triangles).
pub fn cuboid(min: Vec3, max: Vec3) -> Mesh {
    let d = max - min;
    let mut out = Mesh::default();
    // Each face as (corner, u, v) with u × v pointing outward.
    let faces = [
        (min, Vec3::new(0.0, 0.0, d.z), Vec3::new(0.0, d.y, 0.0)), // -X
        (
            Vec3::new(max.x, min.y, min.z),
            Vec3::new(0.0, d.y, 0.0),
            Vec3::new(0.0, 0.0, d.z),
        ), // +X
        (min, Vec3::new(d.x, 0.0, 0.0), Vec3::new(0.0, 0.0, d.z)), // -Y
        (
            Vec3::new(min.x, max.y, min.z),
            Vec3::new(0.0, 0.0, d.z),
            Vec3::new(d.x, 0.0, 0.0),
        ), // +Y
        (min, Vec3::new(0.0, d.y, 0.0), Vec3::new(d.x, 0.0, 0.0)), // -Z
        (
            Vec3::new(min.x, min.y, max.z),
            Vec3::new(d.x, 0.0, 0.0),
            Vec3::new(0.0, d.y, 0.0),
        ), // +Z
    ];
    for (c, u, v) in faces {
        out.append(&quad(c, u, v));
    }
    out
}

/// A capped cylinder from `a` to `b` with smooth side normals (`segments` around).
pub fn cylinder(a: Vec3, b: Vec3, radius: f32, segments: u32) -> Mesh {
    let segments = segments.max(3);
    let axis = (b - a).normalize_or(Vec3::Y);
    let (t, s) = vrrt_core::sampling::orthonormal_basis(axis);
    let mut pos = Vec::new();
    let mut nrm = Vec::new();
    let mut idx = Vec::new();
    for i in 0..segments {
        let (sn, cs) = math::sin_cos_turns(i as f32 / segments as f32);
        let r = t * cs + s * sn;
        pos.push(a + r * radius);
        pos.push(b + r * radius);
        nrm.push(r);
        nrm.push(r);
    }
    for i in 0..segments {
        let j = (i + 1) % segments;
        let (a0, b0, a1, b1) = (2 * i, 2 * i + 1, 2 * j, 2 * j + 1);
        idx.push([a0, a1, b1]);
        idx.push([a0, b1, b0]);
    }
    let mut out = mesh(pos, nrm, idx);
    // Caps as fans with flat normals.
    for (centre, n, flip) in [(a, -axis, true), (b, axis, false)] {
        let base = out.positions.len() as u32;
        out.positions.push(centre);
        out.normals.push(n);
        for i in 0..segments {
            let (sn, cs) = math::sin_cos_turns(i as f32 / segments as f32);
            out.positions.push(centre + (t * cs + s * sn) * radius);
            out.normals.push(n);
        }
        for i in 0..segments {
            let (p, q) = (base + 1 + i, base + 1 + (i + 1) % segments);
            out.indices
                .push(if flip { [base, q, p] } else { [base, p, q] });
        }
    }
    out
}

/// A UV sphere with smooth normals: `rings` latitude bands, `segments` longitude slices.
pub fn uv_sphere(centre: Vec3, radius: f32, rings: u32, segments: u32) -> Mesh {
    let (rings, segments) = (rings.max(2), segments.max(3));
    let mut pos = Vec::new();
    let mut nrm = Vec::new();
    for r in 0..=rings {
        let (st, ct) = math::sin_cos_turns(0.5 * r as f32 / rings as f32);
        for s in 0..=segments {
            let (sp, cp) = math::sin_cos_turns(s as f32 / segments as f32);
            let n = Vec3::new(st * cp, ct, st * sp);
            pos.push(centre + n * radius);
            nrm.push(n);
        }
    }
    let row = segments + 1;
    let mut idx = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (
                r * row + s,
                r * row + s + 1,
                (r + 1) * row + s,
                (r + 1) * row + s + 1,
            );
            if r != 0 {
                idx.push([a, b, c]);
            }
            if r != rings - 1 {
                idx.push([b, d, c]);
            }
        }
    }
    mesh(pos, nrm, idx)
}

/// A mesh of about `target` triangles for benchmarks: a field of spheres scattered
/// deterministically over a 40 × 40 area, on a ground grid.
pub fn sphere_field(target: usize) -> Mesh {
    let per_sphere = 2 * 24 * 47; // rings 24, segments 48 → 2·24·48 − 2·48 = 2208; close enough
    let count = (target / per_sphere).max(1);
    let mut out = Mesh::default();
    let mut state = 0x2545_f491u32;
    let mut next = || {
        state = vrrt_core::sequence::pcg_hash(state);
        (state >> 8) as f32 / 16_777_216.0
    };
    for _ in 0..count {
        let c = Vec3::new(next() * 40.0 - 20.0, next() * 4.0, next() * 40.0 - 20.0);
        out.append(&uv_sphere(c, 0.3 + next() * 1.2, 24, 48));
    }
    let have = out.triangle_count();
    if have < target {
        // Fill the remainder with a ground grid of small quads.
        let cells = (((target - have) / 2) as f32).sqrt().ceil() as u32;
        let size = 44.0 / cells as f32;
        for i in 0..cells {
            for j in 0..cells {
                let corner = Vec3::new(-22.0 + i as f32 * size, -0.5, -22.0 + j as f32 * size);
                out.append(&quad(corner, Vec3::Z * size, Vec3::X * size));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_are_valid_and_outward() {
        let c = cuboid(Vec3::ZERO, Vec3::ONE);
        assert_eq!(c.triangle_count(), 12);
        for t in &c.indices {
            let [a, b, d] = t.map(|i| c.positions[i as usize]);
            let face = (b - a).cross(d - a);
            let centre = (a + b + d) / 3.0 - Vec3::splat(0.5);
            assert!(face.dot(centre) > 0.0, "inward face");
            assert!((face.normalize() - c.normals[t[0] as usize]).length() < 1e-6);
        }
        let s = uv_sphere(Vec3::ZERO, 2.0, 8, 12);
        assert_eq!(s.triangle_count(), 2 * 8 * 12 - 2 * 12);
        assert!(s.positions.iter().all(|p| (p.length() - 2.0).abs() < 1e-5));
        let cyl = cylinder(Vec3::ZERO, Vec3::Y, 0.1, 8);
        assert_eq!(cyl.triangle_count(), 16 + 16);
        let field = sphere_field(20_000);
        assert!(field.triangle_count() >= 20_000 && field.triangle_count() < 24_000);
    }
}
