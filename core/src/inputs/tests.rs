use super::*;
use glam::{Vec2, Vec4};
use std::string::ToString;

const W: u32 = 200;
const H: u32 = 100;

fn decoded_depth(c: InputConventions, z: f32) -> f32 {
    decode_depth(z, &c.params(W, H))
}

fn projection(depth: DepthEncoding, near: f32, far: f32) -> InputConventions {
    InputConventions {
        depth,
        near,
        far,
        ..InputConventions::default()
    }
}

/// Device depth of view depth `d` under a perspective projection (the engine's side).
fn device_depth(c: InputConventions, d: f32) -> f32 {
    let (n, f) = (c.near, c.far);
    let standard = if f.is_infinite() {
        1.0 - n / d
    } else {
        f / (f - n) - f * n / ((f - n) * d)
    };
    match c.depth {
        DepthEncoding::ReversedZ => 1.0 - standard,
        _ => standard,
    }
}

#[test]
fn perspective_depth_inverts_to_view_depth() {
    for c in [
        projection(DepthEncoding::ReversedZ, 0.1, f32::INFINITY),
        projection(DepthEncoding::ReversedZ, 0.5, 200.0),
        projection(DepthEncoding::StandardZ, 0.1, f32::INFINITY),
        projection(DepthEncoding::StandardZ, 0.5, 200.0),
    ] {
        for d in [0.6f32, 1.0, 7.5, 42.0, 150.0] {
            let got = decoded_depth(c, device_depth(c, d));
            assert!((got - d).abs() <= 2e-3 * d, "{c:?}: {d} decoded as {got}");
        }
    }
}

#[test]
fn the_sky_and_garbage_decode_to_no_surface() {
    let reversed = projection(DepthEncoding::ReversedZ, 0.1, f32::INFINITY);
    let standard = projection(DepthEncoding::StandardZ, 0.1, 100.0);
    assert_eq!(decoded_depth(reversed, 0.0), 0.0);
    assert_eq!(decoded_depth(standard, 1.0), 0.0);
    assert_eq!(decoded_depth(reversed, f32::NAN), 0.0);
    assert_eq!(decoded_depth(reversed, -0.5), 0.0);
    assert_eq!(
        decoded_depth(InputConventions::default(), f32::INFINITY),
        0.0
    );
    assert_eq!(decoded_depth(InputConventions::default(), 3.5), 3.5);
}

#[test]
fn projections_that_cannot_be_inverted_are_refused() {
    assert!(projection(DepthEncoding::ReversedZ, 0.0, 10.0)
        .validate()
        .is_err());
    assert!(projection(DepthEncoding::ReversedZ, f32::NAN, 10.0)
        .validate()
        .is_err());
    let e = projection(DepthEncoding::StandardZ, 1.0, 1.0)
        .validate()
        .unwrap_err();
    assert_eq!(e.field, "far");
    assert!(e.to_string().contains("`far` must be > near"), "{e}");
    // Linear depth has no projection to check.
    assert!(projection(DepthEncoding::Linear, 0.0, 0.0)
        .validate()
        .is_ok());
}

fn camera() -> Camera {
    Camera::look_at(
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(-2.0, 0.5, -1.0),
        Vec3::Y,
        1.0,
    )
}

#[test]
fn view_space_normals_turn_into_world_space() {
    let cam = camera();
    let c = InputConventions {
        normal_space: NormalSpace::View,
        ..InputConventions::default()
    };
    let p = c.params(W, H);
    // Towards the viewer in view space is against the camera's forward axis in the world.
    let (n, r) = decode_normal(Vec4::new(0.0, 0.0, 1.0, 0.25), &p, &cam);
    assert!((n + cam.forward()).length() < 1e-5, "{n}");
    assert_eq!(r, 0.25);
    let (n, _) = decode_normal(Vec4::new(0.0, 1.0, 0.0, 0.0), &p, &cam);
    assert!((n - cam.up()).length() < 1e-5, "{n}");
}

#[test]
fn every_normal_encoding_decodes_the_same_normal() {
    let cam = camera();
    let n = Vec3::new(0.3, -0.8, 0.52).normalize();
    let oct = crate::packing::oct_encode(n) * 0.5 + Vec2::splat(0.5);
    for (encoding, texel) in [
        (NormalEncoding::Signed, n.extend(0.5)),
        (
            NormalEncoding::Unsigned,
            (n * 0.5 + Vec3::splat(0.5)).extend(0.5),
        ),
        (
            NormalEncoding::Octahedral,
            Vec4::new(oct.x, oct.y, 0.5, 1.0),
        ),
    ] {
        let c = InputConventions {
            normal_encoding: encoding,
            ..InputConventions::default()
        };
        let (got, r) = decode_normal(texel, &c.params(W, H), &cam);
        assert!((got - n).length() < 1e-5, "{encoding:?}: {got}");
        assert_eq!(r, 0.5);
    }
}

#[test]
fn motion_units_and_signs_become_pixels_to_last_frame() {
    let cams = [&camera(), &camera()];
    let texel = Vec4::new(0.01, -0.02, 0.5, 0.0);
    let cases = [
        (
            MotionUnits::Pixels,
            MotionSign::ToPrevious,
            Vec3::new(0.01, -0.02, 0.5),
        ),
        (
            MotionUnits::Uv,
            MotionSign::ToPrevious,
            Vec3::new(2.0, -2.0, 0.5),
        ),
        (
            MotionUnits::Uv,
            MotionSign::ToCurrent,
            Vec3::new(-2.0, 2.0, -0.5),
        ),
        (
            MotionUnits::Ndc,
            MotionSign::ToPrevious,
            Vec3::new(1.0, 1.0, 0.5),
        ),
    ];
    for (units, sign, want) in cases {
        let c = InputConventions {
            motion_units: units,
            motion_sign: sign,
            ..InputConventions::default()
        };
        let got = decode_motion(texel, &c.params(W, H), 5, 5, 4.0, cams);
        assert!((got - want).length() < 1e-5, "{units:?} {sign:?}: {got}");
    }
}

#[test]
fn without_a_depth_change_a_static_point_is_assumed() {
    let cam = camera();
    // Last frame the camera stood 1.5 units further back along its forward axis.
    let mut prev = cam;
    let back = cam.origin() - cam.forward() * 1.5;
    prev.origin_x = back.x;
    prev.origin_y = back.y;
    prev.origin_z = back.z;
    let c = InputConventions {
        motion_depth: MotionDepth::Static,
        ..InputConventions::default()
    };
    let got = decode_motion(
        Vec4::new(0.0, 0.0, 9.0, 0.0),
        &c.params(W, H),
        40,
        70,
        6.0,
        [&cam, &prev],
    );
    assert!((got.z - 1.5).abs() < 1e-4, "{got}");
    // The sky has no depth to change.
    let sky = decode_motion(Vec4::ZERO, &c.params(W, H), 40, 70, 0.0, [&cam, &prev]);
    assert_eq!(sky.z, 0.0);
}
