//! BVH build time on a procedural 200k-triangle mesh, and single-threaded CPU throughput of
//! `vrrt_core::trace` on it: primary rays (closest hit) and AO rays (any hit).
//!
//! `cargo bench -p vrrt-scene --bench bvh`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use vrrt_core::camera::Camera;
use vrrt_core::glam::Vec3;
use vrrt_core::sampling::{cosine_hemisphere, pixel_seed, rand};
use vrrt_core::trace::{closest_hit, occluded, Ray, Triangle, TriangleNormals};
use vrrt_scene::{bvh, shapes};

const TRIANGLES: usize = 200_000;
const W: u32 = 256;
const H: u32 = 256;

fn mesh_triangles() -> (Vec<Triangle>, Vec<TriangleNormals>) {
    let m = shapes::sphere_field(TRIANGLES);
    let tris = m
        .indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            Triangle::new(a, b, c, 0)
        })
        .collect();
    let normals = m
        .indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.normals[i as usize]);
            TriangleNormals::new(a, b, c)
        })
        .collect();
    (tris, normals)
}

fn benches(c: &mut Criterion) {
    let (tris, normals) = mesh_triangles();
    let mut g = c.benchmark_group("bvh");
    g.sample_size(10);
    g.throughput(Throughput::Elements(tris.len() as u64));
    g.bench_function(format!("build {} triangles", tris.len()), |b| {
        b.iter(|| bvh::build(black_box(&tris), black_box(&normals)))
    });
    g.finish();

    let built = bvh::build(&tris, &normals);
    let camera = Camera::look_at(
        Vec3::new(0.0, 12.0, 30.0),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::Y,
        1.0,
    );
    let primary: Vec<Ray> = (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| camera.primary_ray(x, y, W, H))
        .collect();
    // AO rays from the primary hit points.
    let mut ao = Vec::new();
    for (i, r) in primary.iter().enumerate() {
        let h = closest_hit(&built.nodes, &built.triangles, r, 1e30);
        if h.is_hit() {
            let t = built.triangles[h.tri as usize];
            let mut n = t.face_normal().normalize();
            if n.dot(r.dir) > 0.0 {
                n = -n;
            }
            let p = t.point(h.b1, h.b2) + n * 1e-3;
            let seed = pixel_seed(i as u32 % W, i as u32 / W, 0);
            ao.push(Ray {
                origin: p,
                dir: cosine_hemisphere(n, rand(seed, 0, 0), rand(seed, 0, 1)),
            });
        }
    }

    let mut g = c.benchmark_group("trace (1 thread)");
    g.sample_size(10);
    g.throughput(Throughput::Elements(primary.len() as u64));
    g.bench_function("primary closest hit", |b| {
        b.iter(|| {
            primary
                .iter()
                .filter(|r| closest_hit(&built.nodes, &built.triangles, r, 1e30).is_hit())
                .count()
        })
    });
    g.throughput(Throughput::Elements(ao.len() as u64));
    g.bench_function("ao any hit (max 2.0)", |b| {
        b.iter(|| {
            ao.iter()
                .filter(|r| occluded(&built.nodes, &built.triangles, r, 2.0))
                .count()
        })
    });
    g.finish();
}

criterion_group!(bvh_benches, benches);
criterion_main!(bvh_benches);
