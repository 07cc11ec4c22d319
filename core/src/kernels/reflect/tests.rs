//! Tests of the reflection rays: light geometry, the lobe sampler, the hit radiance, the
//! light probes and the hit-distance guide.

use super::*;

fn empty_scene(lights: &[AreaLight], light_count: u32) -> HitScene<'_> {
    HitScene {
        nodes: &[],
        tris: &[],
        lights,
        light_count,
    }
}

fn floor_surface(roughness: f32) -> Surface {
    Surface {
        py: 0.0,
        depth: 3.0,
        ny: 1.0,
        gy: 1.0,
        roughness,
        instance: 0,
        ..Surface::default()
    }
}

#[test]
fn light_distance_hits_inside_and_misses_outside() {
    let l = AreaLight::new(Vec3::new(-1.0, 2.0, -1.0), Vec3::X * 2.0, Vec3::Z * 2.0);
    let up = Ray {
        origin: Vec3::ZERO,
        dir: Vec3::Y,
    };
    assert!((light_distance(&l, &up, 100.0) - 2.0).abs() < 1e-6);
    let aside = Ray {
        origin: Vec3::new(1.5, 0.0, 0.0),
        dir: Vec3::Y,
    };
    assert_eq!(light_distance(&l, &aside, 100.0), 100.0);
    let down = Ray {
        origin: Vec3::ZERO,
        dir: -Vec3::Y,
    };
    assert_eq!(light_distance(&l, &down, 100.0), 100.0);
}

#[test]
fn rays_stay_above_the_surface_and_rough_surfaces_reflect_nothing() {
    let sh = Shading {
        eye_x: 0.0,
        eye_y: 0.3,
        eye_z: 3.0,
        ..Shading::default()
    };
    let s = floor_surface(0.3);
    let (n, wo, alpha) = lobe(&s, &sh).expect("glossy floor reflects");
    let seed = pixel_seed(1, 2, 0);
    let mut found = 0;
    for i in 0..2000 {
        if let Some((d, pdf)) = sample_direction(n, n, wo, alpha, Stream::per_pixel(seed), i) {
            assert!(d.y > 0.0 && pdf > 0.0);
            found += 1;
        }
    }
    // Grazing view, alpha 0.3: retries find a direction above the floor almost always.
    assert!(found > 1990, "{found}");
    assert!(lobe(&floor_surface(0.9), &sh).is_none());
    let lone = reflection_ray(
        &floor_surface(0.9),
        &sh,
        Stream::per_pixel(seed),
        0,
        empty_scene(&[], 0),
    );
    assert_eq!(lone.pdf, 0.0);
}

#[test]
fn empty_scene_reflects_the_sky_and_the_light() {
    let sh = Shading {
        eye_x: 0.0,
        eye_y: 2.0,
        eye_z: 2.0,
        ..Shading::default()
    };
    let s = floor_surface(0.05);
    let light = AreaLight::new(
        Vec3::new(-50.0, 10.0, -60.0),
        Vec3::X * 100.0,
        Vec3::Z * 55.0,
    );
    let seed = pixel_seed(0, 0, 0);
    let sky = reflection_ray(
        &s,
        &sh,
        Stream::per_pixel(seed),
        3,
        empty_scene(&[light], 0),
    );
    assert_eq!((sky.radiance, sky.distance), (sh.sky, MISS_DISTANCE));
    // The mirror direction from (0,2,2) off the origin points up and away (−z): the light.
    let lit = reflection_ray(
        &s,
        &sh,
        Stream::per_pixel(seed),
        3,
        empty_scene(&[light], 1),
    );
    assert_eq!(lit.radiance, sh.light_radiance);
    assert!((lit.point().y - 10.0).abs() < 1e-3);
}

/// Mean and variance of `n` rays of one glossy floor pixel under a light the lobe half
/// covers, with `probes` light probes.
fn floor_under_light(probes: u32, n: u32) -> (f64, f64) {
    let sh = Shading {
        eye_x: 0.0,
        eye_y: 1.0,
        eye_z: 1.0,
        light_probes: probes,
        ..Shading::default()
    };
    // The mirror direction from (0,1,1) off the origin is (0,1,−1)/√2: the light's near
    // edge at z = −2 on y = 2 cuts the lobe (alpha 0.3) near its middle.
    let light = AreaLight::new(Vec3::new(-2.0, 2.0, -4.0), Vec3::X * 4.0, Vec3::Z * 2.0);
    let lights = [light];
    let s = floor_surface(0.3);
    let stream = Stream::per_pixel(pixel_seed(3, 5, 0));
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for i in 0..n {
        let r = reflection_ray(&s, &sh, stream, i, empty_scene(&lights, 1));
        let v = r.radiance as f64;
        s1 += v;
        s2 += v * v;
    }
    let mean = s1 / n as f64;
    (mean, s2 / n as f64 - mean * mean)
}

#[test]
fn light_probes_keep_the_mean_and_cut_the_variance() {
    let n = 20_000;
    let (mean0, var0) = floor_under_light(0, n);
    let (mean, var) = floor_under_light(Shading::default().light_probes, n);
    // Part of the lobe on the light, the rest on the sky: a mean well inside (sky, light).
    let sh = Shading::default();
    assert!(mean0 > sh.sky as f64 + 0.5 && mean0 < sh.light_radiance as f64 - 0.5);
    // Same expectation: within four standard errors of the difference.
    let se = ((var0 + var) / n as f64).sqrt();
    assert!(
        (mean - mean0).abs() < 4.0 * se,
        "{mean} vs {mean0} (se {se})"
    );
    // Eight draws of the light term per ray: most of its variance goes.
    assert!(var < 0.3 * var0, "variance {var} vs {var0} without probes");
}

#[test]
fn the_guide_averages_this_frames_records_only() {
    // A 3×1 row: this frame's records at log2 distances 1 and 3, and a stale one (frame 6).
    let record = |frame, log_distance| RayHit {
        pdf: 1.0,
        frame,
        log_distance,
        ..RayHit::default()
    };
    let hits = [record(7, 1.0), record(6, 100.0), record(7, 3.0)];
    let guide_of = |radius, frame| {
        let mut guide = [0.0f32; 3];
        let p = GuideParams {
            width: 3,
            height: 1,
            frame,
            radius,
        };
        for x in 0..3 {
            let io = ReflectGuideIo {
                hits: &hits,
                guide: &mut guide,
            };
            reflect_guide(UVec3::new(x, 0, 0), &p, io);
        }
        guide
    };
    assert_eq!(guide_of(1, 7), [1.0, 2.0, 3.0]);
    assert_eq!(guide_of(0, 7), [1.0, NO_GUIDE, 3.0]);
    assert_eq!(guide_of(1, 8), [NO_GUIDE; 3]);
}
