//! `vrrt info --memory`: what a frame's buffers hold and move, from the plan itself. The sizes
//! are core's (`vrrt_core::buffers`, what `Denoiser::new` allocates), and the bytes moved come
//! from one frame recorded through an executor that computes nothing: the figures are exact for
//! any size and any device, with no pixel rendered.

use crate::passes::is_denoiser;
use crate::passes::recorder::Recorder;
use anyhow::Result;
use std::convert::Infallible;
use vrrt_core::buffers::denoiser_buffers;
use vrrt_core::camera::Camera;
use vrrt_core::executor::{BufferId, Executor, Pass, PassTiming};
use vrrt_core::frame::{Frame, FrameScene, Signal};
use vrrt_core::glam::Vec3;
use vrrt_core::kernels::names::format_of;
use vrrt_core::kernels::raygen::AreaLight;
use vrrt_core::payload::PackedSample;
use vrrt_core::reflections::Reflections;
use vrrt_core::settings::Settings;

/// An executor that runs nothing: buffers are only ids, and the [`Recorder`] around it counts
/// each pass's bytes.
#[derive(Default)]
struct PlanOnly {
    buffers: u32,
}

impl Executor for PlanOnly {
    type Error = Infallible;
    fn name(&self) -> &'static str {
        "plan only"
    }
    fn create_buffer(&mut self, _size_bytes: u64) -> Result<BufferId, Infallible> {
        self.buffers += 1;
        Ok(BufferId(self.buffers - 1))
    }
    fn write_buffer(&mut self, _: BufferId, _: &[u8]) -> Result<(), Infallible> {
        Ok(())
    }
    fn dispatch(&mut self, _: &Pass<'_>) -> Result<(), Infallible> {
        Ok(())
    }
    fn read_buffer(&mut self, _: BufferId, out: &mut [u8]) -> Result<(), Infallible> {
        out.fill(0);
        Ok(())
    }
    fn finish(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
    fn timings(&self) -> &[PassTiming] {
        &[]
    }
    fn clear_timings(&mut self) {}
}

/// The buffers whose current copy the engine writes (the VRS mask only when it keeps one).
const ENGINE_INPUTS: [&str; 4] = ["depth", "normal_roughness", "motion", "mask"];

/// The memory report of a `size` frame of `signal` (called `label`) with `lights` lights, default
/// settings at 1 ray per pixel.
pub fn report(size: (u32, u32), label: &str, signal: Signal, lights: usize) -> Result<String> {
    let (w, h) = size;
    let pixels = w as f64 * h as f64;
    let settings = Settings::default();
    let mut exec = Recorder::new(PlanOnly::default());
    let mut frame = Frame::new(&mut exec, w, h, signal, lights, settings)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut out = format!(
        "{w}x{h}, signal {label}, {} planes, 1 rpp\n\n",
        frame.layout().planes
    );
    out += "| buffer | format | copies | bytes each | bytes/pixel |\n|---|---|---:|---:|---:|\n";
    let mut sizes: Vec<(&str, &str, u32, u64)> =
        denoiser_buffers(w, h, frame.denoiser().layout(), frame.denoiser().settings())
            .iter()
            .map(|b| (b.name, b.ty, b.count, b.bytes))
            .collect();
    if frame.reflections().is_some() {
        sizes.push((
            "reflection hits",
            "RayHit",
            1,
            Reflections::hits_bytes(w, h),
        ));
    }
    let mut total = 0u64;
    for (name, ty, count, bytes) in &sizes {
        total += *count as u64 * bytes;
        let format = format_of(ty).unwrap_or(ty);
        out += &format!(
            "| {name} | {format} | {count} | {bytes} | {:.2} |\n",
            (*count as u64 * bytes) as f64 / pixels
        );
    }

    // Two frames through the plan (the first resets history); the second is measured, with the
    // camera moving so nothing is skipped as a still frame.
    let ids: Vec<BufferId> = (0..4)
        .map(|_| exec.create_buffer(4))
        .collect::<Result<_, _>>()?;
    let light_list = vec![AreaLight::default(); lights];
    let camera = Camera::look_at(Vec3::new(0.0, 1.0, 4.0), Vec3::ZERO, Vec3::Y, 0.8);
    let prev_camera = Camera::look_at(Vec3::new(0.1, 1.0, 4.0), Vec3::ZERO, Vec3::Y, 0.8);
    let scene = FrameScene {
        nodes: ids[0],
        tris: ids[1],
        lights: ids[2],
        next: ids[3],
        light_list: &light_list,
        instances: &[],
        camera,
        prev_camera,
        camera_cut: false,
        changes: None,
    };
    frame.render(&mut exec, &scene, |_, _| Ok(()))?;
    exec.clear_timings();
    frame.render(&mut exec, &scene, |_, _| Ok(()))?;
    let (mut denoiser, mut tracing) = (0u64, 0u64);
    for d in exec.dispatched() {
        if is_denoiser(d.kernel) {
            denoiser += d.bytes.total();
        } else {
            tracing += d.bytes.total();
        }
    }
    let per_px = |b: u64| b as f64 / pixels;
    // This frame's copy of each input is the engine's; last frame's depth and normal, the
    // second copies, are the denoiser's.
    let inputs: u64 = sizes
        .iter()
        .filter(|(name, ..)| ENGINE_INPUTS.contains(name))
        .map(|(.., bytes)| bytes)
        .sum();
    out += &format!(
        "\ndenoiser memory: {:.1} bytes/pixel\n",
        per_px(total - inputs)
    );
    out += &format!("engine inputs: {:.1} bytes/pixel\n", per_px(inputs));
    out += &format!(
        "bytes moved per frame: {:.1} bytes/pixel\n",
        per_px(denoiser)
    );
    out += &format!(
        "\nengine inputs are this frame's view depth, normal + roughness and motion (the README's \
         input contract); the noisy signal adds {} bytes/pixel per plane (`PackedSample`, counted in \
         the denoiser's `samples`). The built-in renderer keeps 16 bytes/pixel of its own beside \
         them (geometric normal and instance of two frames).\nbytes moved count the denoiser's passes \
         (`Pass::bytes_moved`: each bound buffer once); the ray-tracing passes, which also read \
         the BVH, move {:.1} bytes/pixel more.\n",
        size_of::<PackedSample>(),
        per_px(tracing)
    );
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The number on the line that starts with `key`.
    fn figure(report: &str, key: &str) -> f64 {
        let line = report.lines().find(|l| l.starts_with(key)).expect(key);
        line[key.len()..]
            .trim()
            .trim_end_matches(" bytes/pixel")
            .parse()
            .unwrap()
    }

    #[test]
    fn report_has_the_three_figures_and_more_signals_cost_more() {
        let ao = report((320, 180), "ao", Signal::Ao { max_distance: 1.0 }, 1).unwrap();
        let all = Signal::All { max_distance: 1.0 };
        let all = report((320, 180), "all", all, 1).unwrap();
        for key in [
            "denoiser memory:",
            "engine inputs:",
            "bytes moved per frame:",
        ] {
            assert!(figure(&ao, key) > 0.0, "{key}\n{ao}");
        }
        assert!(figure(&all, "denoiser memory:") > figure(&ao, "denoiser memory:"));
        assert!(figure(&all, "bytes moved per frame:") > figure(&ao, "bytes moved per frame:"));
        assert!(ao.contains("| depth | R32F view depth | 2 |"), "{ao}");
        assert_eq!(figure(&ao, "engine inputs:"), 16.0, "{ao}");
        assert!(all.contains("| reflection hits | struct | 1 |"), "{all}");
    }
}
