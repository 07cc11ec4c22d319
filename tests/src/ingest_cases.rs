//! The `ingest` pass's case: the engine's textures in formats and conventions engines use, each
//! size in a different set, with the sky, the far plane and the near plane among the depths.

use crate::layouts::{FLOATS, INTS};
use crate::{cases, inputs, BufferSpec, Case, Word};
use rand::Rng;
use rand_pcg::Pcg32;
use vrrt_backend::TextureFormat;
use vrrt_core::camera::Camera;
use vrrt_core::glam::{Vec2, Vec3};
use vrrt_core::inputs::{
    DepthEncoding, InputConventions, MotionDepth, MotionSign, MotionUnits, NormalEncoding,
    NormalSpace,
};
use vrrt_core::packing;
use vrrt_core::textures::Texel;

/// A reversed-Z engine with view-space RGBA16F normals and UV velocities; a standard-Z engine
/// with NRD's RGB10A2 normals and RG motion in NDC (no depth change); our own conventions.
fn conventions(k: u32) -> (InputConventions, TextureFormat, TextureFormat) {
    let ours = InputConventions::default();
    match k {
        0 => (
            InputConventions {
                depth: DepthEncoding::ReversedZ,
                near: 0.05,
                far: f32::INFINITY,
                normal_space: NormalSpace::View,
                motion_units: MotionUnits::Uv,
                motion_sign: MotionSign::ToCurrent,
                ..ours
            },
            TextureFormat::Rgba16Float,
            TextureFormat::Rgba16Float,
        ),
        1 => (
            InputConventions {
                depth: DepthEncoding::StandardZ,
                near: 0.5,
                far: 500.0,
                normal_encoding: NormalEncoding::Octahedral,
                motion_units: MotionUnits::Ndc,
                motion_depth: MotionDepth::Static,
                ..ours
            },
            TextureFormat::Rgb10a2Unorm,
            TextureFormat::Rg16Float,
        ),
        _ => (ours, TextureFormat::Rgba32Float, TextureFormat::Rgba16Float),
    }
}

/// A random unit vector.
fn direction(rng: &mut Pcg32) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
            return v.normalize();
        }
    }
}

/// A normal texel of `encoding`.
fn normal_texel(rng: &mut Pcg32, encoding: NormalEncoding) -> Texel {
    let (n, r) = (direction(rng), rng.random_range(0.0..1.0f32));
    match encoding {
        NormalEncoding::Octahedral => {
            let e = packing::oct_encode(n) * 0.5 + Vec2::splat(0.5);
            [e.x, e.y, r, 1.0]
        }
        NormalEncoding::Unsigned => [n.x * 0.5 + 0.5, n.y * 0.5 + 0.5, n.z * 0.5 + 0.5, r],
        NormalEncoding::Signed => [n.x, n.y, n.z, r],
    }
}

/// A device or linear depth texel: mostly surfaces, with the sky and the planes' ends.
fn depth_texel(rng: &mut Pcg32, c: &InputConventions) -> Texel {
    let z = match (c.depth, rng.random_range(0..10)) {
        (DepthEncoding::Linear, 0) => 0.0,
        (DepthEncoding::Linear, _) => rng.random_range(0.1..80.0f32),
        (DepthEncoding::ReversedZ, 0) => 0.0,
        (DepthEncoding::StandardZ, 0) => 1.0,
        (_, 1) => 1.0 - rng.random_range(0.0..1.0f32),
        _ => rng.random_range(0.0..1.0f32),
    };
    [z, 0.0, 0.0, 1.0]
}

/// The `ingest` case at `w × h`; the conventions follow the size ([`crate::cases::SIZES`]: one
/// pixel in our own, the odd size reversed-Z, the large one standard-Z).
pub fn ingest_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let (c, normal_format, motion_format) = conventions(match w * h {
        1 => 2,
        n if n < 1000 => 0,
        _ => 1,
    });
    let mut view = inputs::test_view();
    view.prev_camera = Camera::look_at(Vec3::new(0.5, 0.2, 6.5), Vec3::ZERO, Vec3::Y, 0.9);
    let n = (w * h) as usize;
    let depth: Vec<Texel> = (0..n).map(|_| depth_texel(rng, &c)).collect();
    let normals: Vec<Texel> = (0..n)
        .map(|_| normal_texel(rng, c.normal_encoding))
        .collect();
    let motion: Vec<Texel> = (0..n)
        .map(|_| [0.0; 4].map(|_: f32| rng.random_range(-0.05..0.05)))
        .collect();
    let params = c.params(w, h);
    Case {
        name: format!("ingest {w}x{h} ({:?} depth)", c.depth),
        kernel: &vrrt_core::kernels::INGEST,
        buffers: vec![
            BufferSpec::texture(w, h, TextureFormat::R32Float, &depth),
            BufferSpec::texture(w, h, normal_format, &normals),
            BufferSpec::texture(w, h, motion_format, &motion),
            inputs::view(&view),
            BufferSpec::from_pod(&vec![0.0f32; n], FLOATS),
            // A packed normal's codes round floats: one code apart is a decided difference.
            BufferSpec::from_pod(&vec![0u32; n], INTS).decided(),
            BufferSpec::from_pod(&vec![[0u32; 2]; n], &[Word::Half2, Word::HalfU16]),
        ],
        params: bytemuck::bytes_of(&params).to_vec(),
        groups: cases::groups(&vrrt_core::kernels::INGEST, w, h, 1),
    }
}

/// `reproject`'s case with this frame's inputs as the engine's textures in our own conventions
/// (f32 texels, so they decode to the same words), plus the decoded inputs it writes.
pub fn reproject_engine_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let base = cases::reproject_case(rng, w, h);
    let depth: &[f32] = bytemuck::cast_slice(&base.buffers[0].data);
    let normals: &[u32] = &base.buffers[1].data;
    let motion: &[[u32; 2]] = bytemuck::cast_slice(&base.buffers[2].data);
    let depth: Vec<Texel> = depth.iter().map(|&d| [d, 0.0, 0.0, 1.0]).collect();
    let normals: Vec<Texel> = normals
        .iter()
        .map(|&w| {
            let (n, alpha) = packing::unpack_normal_roughness(w);
            [n.x, n.y, n.z, alpha.sqrt()]
        })
        .collect();
    let motion: Vec<Texel> = motion
        .iter()
        .map(|&m| packing::unpack_motion(m).extend(0.0).to_array())
        .collect();
    let n = (w * h) as usize;
    let conventions = InputConventions::default().params(w, h);
    let mut buffers = vec![
        BufferSpec::texture(w, h, TextureFormat::R32Float, &depth),
        BufferSpec::texture(w, h, TextureFormat::Rgba32Float, &normals),
        BufferSpec::texture(w, h, TextureFormat::Rgba32Float, &motion),
        BufferSpec::from_pod(std::slice::from_ref(&conventions), INTS),
        BufferSpec::from_pod(&vec![0.0f32; n], FLOATS),
        BufferSpec::from_pod(&vec![0u32; n], INTS).decided(),
        BufferSpec::from_pod(&vec![[0u32; 2]; n], &[Word::Half2, Word::HalfU16]),
    ];
    buffers.extend(base.buffers[3..].iter().cloned());
    Case {
        name: base.name.replace("reproject", "reproject_engine"),
        kernel: &vrrt_core::kernels::REPROJECT_ENGINE,
        buffers,
        ..base
    }
}

/// `atrous`'s case writing into an engine texture instead of `out`: plane `z` at rows
/// `z · height ..`, the value in red.
pub fn atrous_engine_case(rng: &mut Pcg32, w: u32, h: u32) -> Case {
    let mut base = crate::filter_cases::atrous_case(rng, w, h);
    base.buffers.pop();
    base.buffers
        .push(BufferSpec::output_texture(w, h * cases::PLANES));
    Case {
        name: base.name.replace("atrous", "atrous_engine"),
        kernel: &vrrt_core::kernels::ATROUS_ENGINE,
        ..base
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cases::rng;

    /// Reading the inputs from textures in our own conventions changes nothing: the reprojected
    /// history and the requests are those of `reproject` over the same inputs, word for word,
    /// and the decoded inputs are the words `reproject` read (normals as directions: the two
    /// octahedral corners of −z are one normal).
    #[test]
    fn reprojection_from_textures_is_reprojection() {
        for (i, &(w, h)) in cases::SIZES.iter().enumerate() {
            let plain = cases::reproject_case(&mut rng(50 + i as u64), w, h);
            let engine = reproject_engine_case(&mut rng(50 + i as u64), w, h);
            let mut cpu = vrrt_cpu::CpuExecutor::new();
            let a = crate::run_case(&mut cpu, &plain).unwrap();
            let b = crate::run_case(&mut cpu, &engine).unwrap();
            let (out, requests) = (a.len() - 2, a.len() - 1);
            assert_eq!(a[out], b[b.len() - 2], "{w}x{h}: history");
            assert_eq!(a[requests], b[b.len() - 1], "{w}x{h}: requests");
            assert_eq!(plain.buffers[0].data, b[4], "{w}x{h}: depth");
            assert_eq!(plain.buffers[2].data, b[6], "{w}x{h}: motion");
            for (&p, &e) in plain.buffers[1].data.iter().zip(&b[5]) {
                let (p, e) = (packing::unpack_normal(p), packing::unpack_normal(e));
                assert!(p.dot(e) > 0.99999, "{w}x{h}: normal {p} vs {e}");
            }
        }
    }

    /// The texture the last iteration writes holds what `atrous` writes to its buffer: each
    /// plane's value, at rows `z · height ..`.
    #[test]
    fn the_engine_texture_holds_the_filtered_planes() {
        for (i, &(w, h)) in cases::SIZES.iter().enumerate() {
            let plain = crate::filter_cases::atrous_case(&mut rng(70 + i as u64), w, h);
            let engine = atrous_engine_case(&mut rng(70 + i as u64), w, h);
            let mut cpu = vrrt_cpu::CpuExecutor::new();
            let a = crate::run_case(&mut cpu, &plain).unwrap();
            let b = crate::run_case(&mut cpu, &engine).unwrap();
            let filtered: &[vrrt_core::payload::PackedFiltered] =
                bytemuck::cast_slice(&a[a.len() - 1]);
            let texels: &[Texel] = bytemuck::cast_slice(&b[b.len() - 1]);
            assert_eq!(filtered.len(), texels.len());
            for (f, t) in filtered.iter().zip(texels) {
                let f = f.unpack();
                assert_eq!([f.value, 0.0, 0.0, 1.0], *t, "{w}x{h}");
            }
        }
    }
}
