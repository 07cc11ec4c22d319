//! Tests of the à-trous iteration.

use super::*;
use crate::camera::{Camera, View};
use crate::payload::Filtered;
use glam::Vec3;

/// One iteration of `p` at pixel `(x, y)` of a `w`×`h` wall facing the camera, 5 units away
/// where `depth` says so (0: no surface), holding `input` and `guide`: the hit-distance guide
/// when `p.guide_plane` is 0, the penumbra guide when `p.penumbra_plane` is; every tile
/// filters.
fn filter_wall(
    input: &[PackedFiltered],
    depth: &[f32],
    guide: &[f32],
    w: u32,
    p: AtrousParams,
    x: u32,
    y: u32,
) -> f32 {
    let h = input.len() as u32 / w;
    let camera = Camera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 0.9);
    let view = [View {
        camera,
        prev_camera: camera,
    }];
    let (tw, th) = crate::kernels::classify::tile_grid(w, h);
    let tiles = std::vec![5; (tw * th) as usize];
    let normals = std::vec![packing::pack_normal_roughness(Vec3::Z, 0.0); input.len()];
    let mut out = input.to_vec();
    let io = AtrousIo {
        input,
        depth,
        normal_roughness: &normals,
        view: &view,
        tiles: &tiles,
        guide,
        penumbra: guide,
        out: &mut out,
    };
    let p = AtrousParams {
        width: w,
        height: h,
        ..p
    };
    atrous::<1>(UVec3::new(x, y, 0), &p, io);
    out[(y * w + x) as usize].unpack().value
}

/// A 5×3 patch of one wall: a highlight along the top row (4.0, variance of the estimate 4.0),
/// a dark, settled surface below it (0.1, variance 1e-4).
fn highlight_patch() -> std::vec::Vec<PackedFiltered> {
    (0..15)
        .map(|i| {
            let (value, variance) = if i < 5 { (4.0, 4.0) } else { (0.1, 1e-4) };
            Filtered { value, variance }.pack()
        })
        .collect()
}

/// The first iteration at the middle of [`highlight_patch`].
fn below_a_highlight(cap_variance: u32) -> f32 {
    let input = highlight_patch();
    let p = AtrousParams {
        cap_variance,
        ..Default::default()
    };
    filter_wall(&input, &[5.0; 15], &[NO_GUIDE], 5, p, 2, 1)
}

#[test]
fn a_capped_variance_keeps_the_highlight_out() {
    // Blurred, the dark pixel's σ is the highlight's (about 1): the bright taps get in.
    assert!(below_a_highlight(0) > 0.15, "{}", below_a_highlight(0));
    // Capped at its own (0.01), they do not.
    assert!(
        (below_a_highlight(1) - 0.1).abs() < 1e-3,
        "{}",
        below_a_highlight(1)
    );
}

/// The middle of [`highlight_patch`] (variance uncapped, so the highlight gets in)
/// at the second iteration, stride 1, its plane an AO plane or not, the AO planes running
/// `ao_iterations`.
fn second_iteration_below_a_highlight(ao_planes: u32, ao_iterations: u32) -> f32 {
    let input = highlight_patch();
    let p = AtrousParams {
        iteration: 1,
        ao_planes,
        ao_iterations,
        ..Default::default()
    };
    filter_wall(&input, &[5.0; 15], &[NO_GUIDE], 5, p, 2, 1)
}

#[test]
fn ao_planes_pass_through_once_they_have_run_their_iterations() {
    let unfiltered = Filtered {
        value: 0.1,
        variance: 1e-4,
    }
    .pack()
    .unpack()
    .value;
    // An AO plane that has run its one iteration keeps its value, though its tile needs more.
    assert_eq!(second_iteration_below_a_highlight(1, 1), unfiltered);
    // With two, or on a plane that is not AO, the second iteration filters.
    assert!(second_iteration_below_a_highlight(1, 2) > 0.15);
    assert!(second_iteration_below_a_highlight(0, 1) > 0.15);
}

#[test]
fn ao_iterations_keep_the_footprint_within_the_reach() {
    // Footprints 2, 6, 14, 30 pixels: a tenth of 72–90 rows holds 6, of 144–180 holds 14.
    let at = |rows| ao_iterations(0.1, rows, 4);
    assert_eq!(
        [at(72), at(90), at(144), at(180), at(360), at(1080)],
        [2, 2, 3, 3, 4, 4]
    );
    // At least one iteration, at most the configured count; reach 0 runs them all.
    assert_eq!(ao_iterations(0.1, 8, 4), 1);
    assert_eq!(ao_iterations(1.0, 1080, 5), 5);
    assert_eq!(ao_iterations(0.1, 90, 0), 0);
    assert_eq!(ao_iterations(0.0, 90, 4), 4);
}

/// Pixel `x` of a row on one wall whose value rises linearly (0.1 a pixel) and whose
/// surface ends after pixel 5 (a crease seen edge-on), filtered with taps in pairs on plane 0
/// (`symmetric_planes` 1) or one at a time (0).
fn at_an_edge(x: u32, symmetric_planes: u32) -> f32 {
    let input: std::vec::Vec<PackedFiltered> = (0..9)
        .map(|i| {
            Filtered {
                value: 0.1 * i as f32,
                variance: 1.0,
            }
            .pack()
        })
        .collect();
    let depth: std::vec::Vec<f32> = (0..9).map(|i| if i <= 5 { 5.0 } else { 0.0 }).collect();
    let p = AtrousParams {
        symmetric_planes,
        ..Default::default()
    };
    filter_wall(&input, &depth, &[NO_GUIDE], 9, p, x, 0)
}

#[test]
fn symmetric_pairs_do_not_lean_away_from_an_edge() {
    for x in [4, 5] {
        let centre = Filtered {
            value: 0.1 * x as f32,
            variance: 1.0,
        }
        .pack()
        .unpack()
        .value;
        // One tap at a time the window holds only the darker side: the mean leans to it.
        assert!(
            at_an_edge(x, 0) < centre - 0.01,
            "{x}: {}",
            at_an_edge(x, 0)
        );
        // In pairs a linear ramp cancels.
        approx::assert_abs_diff_eq!(at_an_edge(x, 1), centre, epsilon = 2e-3);
    }
}

/// Pixel 3 of a 9-pixel row of one flat wall at 1 rpp (variance 1): a dark reflection
/// (0.1) in pixels 0..=3 whose rays hit at 4 units, a bright one (1.0) from pixel 4 on
/// whose rays hit at 1000, filtered with or without the guide.
fn beside_a_reflected_edge(guided: bool) -> f32 {
    let input: std::vec::Vec<PackedFiltered> = (0..9)
        .map(|i| {
            let value = if i <= 3 { 0.1 } else { 1.0 };
            Filtered {
                value,
                variance: 1.0,
            }
            .pack()
        })
        .collect();
    let guide: std::vec::Vec<f32> = (0..9).map(|i| if i <= 3 { 2.0 } else { 10.0 }).collect();
    let p = AtrousParams {
        guide_plane: if guided { 0 } else { NO_PLANE },
        guide_scale: core::f32::consts::FRAC_1_SQRT_2 / 1.6,
        ..Default::default()
    };
    filter_wall(&input, &[5.0; 9], &guide, 9, p, 3, 0)
}

#[test]
fn the_guide_keeps_a_reflected_edge_the_g_buffer_does_not_see() {
    // One flat wall: the normal and plane weights see nothing, and σ = 1 lets the bright
    // taps in.
    assert!(
        beside_a_reflected_edge(false) > 0.3,
        "{}",
        beside_a_reflected_edge(false)
    );
    let guided = beside_a_reflected_edge(true);
    assert!((guided - 0.1).abs() < 1e-3, "{guided}");
}

/// Pixel 3 of a 9-pixel row of one flat wall at 1 rpp (variance 1): an umbra (0) in pixels
/// 0..=3 beside a lit floor (1), whose penumbra is `width` pixels wide (`None`: no blocker
/// nearby), at the default reach (0.5) and the penumbra plane's σ_l.
fn beside_a_shadow_edge(width: Option<f32>) -> f32 {
    let input: std::vec::Vec<PackedFiltered> = (0..9)
        .map(|i| {
            let value = if i <= 3 { 0.0 } else { 1.0 };
            Filtered {
                value,
                variance: 1.0,
            }
            .pack()
        })
        .collect();
    let p = AtrousParams {
        penumbra_plane: 0,
        penumbra_scale: 2.0,
        penumbra_sigma_luminance: 2.0,
        ..Default::default()
    };
    filter_wall(
        &input,
        &[5.0; 9],
        &[width.unwrap_or(NO_GUIDE); 9],
        9,
        p,
        3,
        0,
    )
}

#[test]
fn the_penumbra_keeps_a_contact_shadows_edge_and_lets_a_wide_one_blur() {
    // A contact shadow (1 pixel): the lit taps are out of reach.
    let sharp = beside_a_shadow_edge(Some(1.0));
    assert!(sharp < 0.01, "{sharp}");
    // A wide penumbra (20 pixels): the first iteration's taps are all within it, and the
    // luminance test at σ_l 2 lets them in, as it does with no blocker nearby.
    let wide = beside_a_shadow_edge(Some(20.0));
    assert!(wide > 0.15, "{wide}");
    let unlimited = beside_a_shadow_edge(None);
    assert!((wide - unlimited).abs() < 0.005, "{wide} {unlimited}");
}

#[test]
fn tap_tables_match_the_per_tap_formulas() {
    for j in 0..3 {
        for i in 0..3 {
            let w = B3[i] * B3[j] * (1.0 / (B3[0] * B3[0]));
            assert_eq!(TAP_WEIGHT[j][i].to_bits(), w.to_bits());
            let d = math::sqrt((i * i + j * j) as f32);
            assert_eq!(TAP_DISTANCE[j][i].to_bits(), d.to_bits());
        }
    }
}
