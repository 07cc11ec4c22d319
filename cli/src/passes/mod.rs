//! `vrrt bench --passes`: each pass of one configuration against its bandwidth floor. The
//! floor of a pass is the bytes it must move ([`vrrt_core::executor::Pass::bytes_moved`], recorded
//! by [`Recorder`]) over the memory bandwidth measured in the same run on the same backend
//! ([`bandwidth`]); `floor_ratio = ms / floor` says how far from memory-bound it runs.

pub(crate) mod recorder;

pub use recorder::{bandwidth, Bandwidth, Dispatched, Recorder, COPY_REPEATS, SPIN_UP};

use crate::bench::BenchArgs;
use crate::progress::Progress;
use crate::run::{check_common, clamp_frames, load_settings};
use crate::session::{load_scene, open_backend, Config, SignalArg, WARMUP_FRAMES};
use anyhow::{anyhow, bail, Context, Result};
use std::fmt::Write as _;
use vrrt_backend::BackendKind;
use vrrt_core::executor::{Executor, KernelDesc, PassBytes};
use vrrt_scene::render::Renderer;

/// Size when `--size` is not given: the size of the CPU target.
const DEFAULT_SIZE: (u32, u32) = (1280, 720);
/// Frames when `--frames` is not given: the warm-up frames and 6 measured.
const DEFAULT_FRAMES: u32 = WARMUP_FRAMES as u32 + 6;

/// Whether a pass is the denoiser's. Passes that bind the BVH (the G-buffer, `raygen_*`, the
/// gradient re-trace `gradient_ao`/`gradient_shadow`, `reflect_tiles`) are the renderer's and
/// the ray tracer's: their cost is traversal, and their floor would count the whole BVH.
pub fn is_denoiser(kernel: &KernelDesc) -> bool {
    !kernel.bindings.iter().any(|b| b.ty.ends_with("BvhNode"))
}

/// One pass entry in one frame: its dispatches summed (à-trous runs several times).
#[derive(Copy, Clone, Debug)]
struct Share {
    kernel: &'static KernelDesc,
    ms: f64,
    bytes: PassBytes,
    dispatches: u32,
}

/// The passes of the frame just rendered, in order of first dispatch.
fn frame_shares<E: Executor>(exec: &Recorder<E>) -> Vec<Share> {
    let mut shares: Vec<Share> = Vec::new();
    for d in exec.dispatched() {
        match shares.iter_mut().find(|s| s.kernel.entry == d.kernel.entry) {
            Some(s) => {
                s.bytes += d.bytes;
                s.dispatches += 1;
            }
            None => shares.push(Share {
                kernel: d.kernel,
                ms: 0.0,
                bytes: d.bytes,
                dispatches: 1,
            }),
        }
    }
    for t in exec.timings() {
        if let Some(s) = shares.iter_mut().find(|s| s.kernel.entry == t.entry) {
            s.ms += t.ms;
        }
    }
    shares
}

/// A line of the report: means per frame over `frames` frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Kernel entry, `denoiser` (the sum of the denoiser's passes) or `warmup` (the same sum
    /// over the warm-up frames).
    pub name: &'static str,
    /// Counted in the denoiser.
    pub denoiser: bool,
    /// Frames averaged.
    pub frames: usize,
    /// Dispatches per frame.
    pub dispatches: f64,
    /// Milliseconds per frame.
    pub ms: f64,
    /// Bytes read per frame.
    pub read: f64,
    /// Bytes written per frame.
    pub written: f64,
}

impl Row {
    /// Bytes moved per frame.
    pub fn bytes(&self) -> f64 {
        self.read + self.written
    }

    /// The floor in ms at `bandwidth` bytes per second.
    pub fn floor_ms(&self, bandwidth: f64) -> f64 {
        self.bytes() / bandwidth * 1e3
    }

    /// `ms / floor`.
    pub fn floor_ratio(&self, bandwidth: f64) -> f64 {
        self.ms / self.floor_ms(bandwidth)
    }
}

/// Per-pass means over `frames`, in order of first dispatch (a pass missing from a frame counts
/// 0 there).
fn pass_rows(frames: &[Vec<Share>]) -> Vec<Row> {
    let n = frames.len() as f64;
    let mut rows: Vec<Row> = Vec::new();
    for s in frames.iter().flatten() {
        let i = match rows.iter().position(|r| r.name == s.kernel.entry) {
            Some(i) => i,
            None => {
                rows.push(Row {
                    name: s.kernel.entry,
                    denoiser: is_denoiser(s.kernel),
                    frames: frames.len(),
                    dispatches: 0.0,
                    ms: 0.0,
                    read: 0.0,
                    written: 0.0,
                });
                rows.len() - 1
            }
        };
        let r = &mut rows[i];
        r.dispatches += s.dispatches as f64 / n;
        r.ms += s.ms / n;
        r.read += s.bytes.read as f64 / n;
        r.written += s.bytes.written as f64 / n;
    }
    rows
}

/// The sum of the denoiser's rows, named `name`.
fn denoiser_sum(rows: &[Row], name: &'static str) -> Row {
    let mut sum = Row {
        name,
        denoiser: true,
        frames: rows.first().map_or(0, |r| r.frames),
        dispatches: 0.0,
        ms: 0.0,
        read: 0.0,
        written: 0.0,
    };
    for r in rows.iter().filter(|r| r.denoiser) {
        sum.dispatches += r.dispatches;
        sum.ms += r.ms;
        sum.read += r.read;
        sum.written += r.written;
    }
    sum
}

/// What a report measured.
#[derive(Clone, Debug)]
pub struct Subject {
    /// Backend name.
    pub backend: String,
    /// The device, in words.
    pub device: String,
    /// Scene key.
    pub scene: String,
    /// Signal.
    pub signal: SignalArg,
    /// Configuration.
    pub config: Config,
    /// Budget, rays per pixel.
    pub rpp: f32,
    /// Width and height.
    pub size: (u32, u32),
}

/// The report of one backend.
#[derive(Clone, Debug)]
pub struct Report {
    /// What was measured.
    pub subject: Subject,
    /// The bandwidth measured before and after the frames (a GPU whose clocks fell during the
    /// frames shows it as a lower second figure); the floor takes the better ([`Self::bandwidth`]).
    pub measured: [Bandwidth; 2],
    /// Every pass that ran in the measured frames, then `denoiser`, then `warmup`.
    pub rows: Vec<Row>,
    /// Milliseconds of all passes (G-buffer and ray tracing included) of each warm-up frame.
    pub warmup_frame_ms: Vec<f64>,
    /// The same, mean over the measured frames.
    pub frame_ms: f64,
}

impl Report {
    /// The report of `frames` (warm-up frames first).
    fn new(subject: Subject, bandwidths: [Bandwidth; 2], frames: &[Vec<Share>]) -> Report {
        let (warmup, measured) = frames.split_at(WARMUP_FRAMES);
        let all_ms = |f: &Vec<Share>| f.iter().map(|s| s.ms).sum::<f64>();
        let mut rows = pass_rows(measured);
        rows.push(denoiser_sum(&rows, "denoiser"));
        rows.push(denoiser_sum(&pass_rows(warmup), "warmup"));
        Report {
            subject,
            measured: bandwidths,
            rows,
            warmup_frame_ms: warmup.iter().map(all_ms).collect(),
            frame_ms: measured.iter().map(all_ms).sum::<f64>() / measured.len() as f64,
        }
    }

    /// The bandwidth of the floor: the better of the two measurements.
    pub fn bandwidth(&self) -> Bandwidth {
        let [before, after] = self.measured;
        if after.bytes_per_second > before.bytes_per_second {
            after
        } else {
            before
        }
    }

    fn pixels(&self) -> f64 {
        (self.subject.size.0 * self.subject.size.1) as f64
    }

    /// The printed table (markdown).
    pub fn table(&self) -> String {
        let floor = self.bandwidth();
        let bw = floor.bytes_per_second;
        let px = self.pixels();
        let t = &self.subject;
        let measured = self.rows.first().map_or(0, |r| r.frames);
        let mut s = format!(
            "{} — {}: {}, {}, {} at {} rpp, {}x{}; bandwidth {:.2} GB/s (best of {} copies of \
             {} MiB after {:.1} s of spin-up, before the frames {:.2} and after them {:.2}); \
             means over {} frames after {} warm-up frames\n\n\
             | pass | denoiser | dispatches/frame | ms | bytes/px | floor ms | floor_ratio |\n\
             |---|---|---:|---:|---:|---:|---:|\n",
            t.backend,
            t.device,
            t.scene,
            t.signal.name(),
            t.config.name(),
            t.rpp,
            t.size.0,
            t.size.1,
            bw / 1e9,
            COPY_REPEATS,
            floor.copied >> 20,
            SPIN_UP.as_secs_f64(),
            self.measured[0].bytes_per_second / 1e9,
            self.measured[1].bytes_per_second / 1e9,
            measured,
            WARMUP_FRAMES,
        );
        for r in &self.rows {
            let (name, counted) = match r.name {
                "denoiser" => ("**whole denoiser**".to_string(), "sum of yes"),
                "warmup" => (
                    format!("warm-up, frames 0–{} (excluded)", WARMUP_FRAMES - 1),
                    "sum of yes",
                ),
                n => (n.to_string(), if r.denoiser { "yes" } else { "no" }),
            };
            let _ = writeln!(
                s,
                "| {name} | {counted} | {:.1} | {:.3} | {:.1} | {:.3} | {:.1} |",
                r.dispatches,
                r.ms,
                r.bytes() / px,
                r.floor_ms(bw),
                r.floor_ratio(bw)
            );
        }
        let warm: Vec<String> = self
            .warmup_frame_ms
            .iter()
            .map(|ms| format!("{ms:.1}"))
            .collect();
        let _ = writeln!(
            s,
            "\nAll passes (G-buffer and ray tracing included): {:.1} ms per measured frame; \
             warm-up frames {} ms.",
            self.frame_ms,
            warm.join(", ")
        );
        s
    }
}

const HEADER: &str = "backend,scene,signal,config,budget_rpp,width,height,pass,denoiser,frames,dispatches_per_frame,ms,read_bytes_per_px,written_bytes_per_px,bytes_per_px,floor_ms,floor_ratio,bandwidth_gb_s";

/// `passes.csv`: one line per row of every report.
pub fn passes_csv(reports: &[Report]) -> String {
    let mut s = format!("{HEADER}\n");
    for rep in reports {
        let (bw, px, t) = (rep.bandwidth().bytes_per_second, rep.pixels(), &rep.subject);
        for r in &rep.rows {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{:.2},{:.6},{:.3},{:.3},{:.3},{:.6},{:.4},{:.3}",
                t.backend,
                t.scene,
                t.signal.name(),
                t.config.name(),
                t.rpp,
                t.size.0,
                t.size.1,
                r.name,
                r.denoiser as u8,
                r.frames,
                r.dispatches,
                r.ms,
                r.read / px,
                r.written / px,
                r.bytes() / px,
                r.floor_ms(bw),
                r.floor_ratio(bw),
                bw / 1e9
            );
        }
    }
    s
}

/// Runs `vrrt bench --passes`: one configuration (default `vrrt`, AO, 1 rpp, `room`, 1280x720,
/// 8 frames) on each of `--backends` (default `auto`).
pub fn run(args: &BenchArgs) -> Result<()> {
    if args.quick || args.repeats.is_some() {
        bail!("--passes renders one configuration once: --quick and --repeats do not apply");
    }
    if args.scenes.len() > 1
        || args.configs.len() > 1
        || args.budgets.len() > 1
        || args.signals.len() > 1
    {
        bail!(
            "--passes renders one configuration: give at most one scene, config, budget and signal"
        );
    }
    let scene = load_scene(
        args.scenes.first().map_or("room", String::as_str),
        &args.limits.limits(),
    )?;
    let config = args.configs.first().copied().unwrap_or(Config::Vrrt);
    let rpp = args.budgets.first().copied().unwrap_or(1.0);
    let kind = args.signals.first().copied().unwrap_or(SignalArg::Ao);
    let backends = if args.backends.is_empty() {
        vec![BackendKind::Auto]
    } else {
        args.backends.clone()
    };
    let (w, h) = args.size.unwrap_or(DEFAULT_SIZE);
    let frames = clamp_frames(
        args.frames.unwrap_or(DEFAULT_FRAMES),
        scene.scene.frames_available(),
    );
    check_common(frames, args.spp, args.ao_radius)?;
    if frames as usize <= WARMUP_FRAMES {
        bail!("--passes needs more frames than the {WARMUP_FRAMES} warm-up frames, got {frames}");
    }
    let base = load_settings(args.settings.as_deref())?;
    let signal = kind.signal(args.ao_radius);
    let settings = config.settings(base, rpp, signal);
    let out = crate::outdir::OutDir::prepare(&args.out, "bench-passes")?;

    let mut reports = Vec::new();
    for backend in backends {
        let (exec, _) = open_backend(backend, false)?;
        let device = exec.device();
        let mut exec = Recorder::new(exec);
        let before = bandwidth(&mut exec).context("measuring the bandwidth")?;
        let lights = scene.scene.lights.len();
        let mut renderer = Renderer::new(&mut exec, w, h, signal, lights, settings)
            .map_err(|e| anyhow!("cannot create the denoiser: {e}"))?;
        let mut shares = Vec::new();
        let mut progress = Progress::new(format!("{} frame", exec.name()), frames.into(), 4);
        for i in 0..frames {
            exec.clear_timings();
            // Nothing is read back: the frames run back to back, as in an engine.
            renderer
                .render_unread(&mut exec, &scene.scene.frame(i))
                .and_then(|_| exec.finish())
                .map_err(|e| anyhow!("rendering frame {i}: {e}"))?;
            shares.push(frame_shares(&exec));
            progress.set(u64::from(i) + 1, String::new);
        }
        drop(progress);
        let after = bandwidth(&mut exec).context("measuring the bandwidth")?;
        exec.inner().warn_validation_errors();
        let subject = Subject {
            backend: exec.name().to_string(),
            device,
            scene: scene.key.clone(),
            signal: kind,
            config,
            rpp,
            size: (w, h),
        };
        let report = Report::new(subject, [before, after], &shares);
        println!("{}", report.table());
        reports.push(report);
    }
    let path = out.write("passes.csv", passes_csv(&reports).as_bytes())?;
    println!("written {}", path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_denoiser_is_every_pass_but_the_gbuffer_and_ray_tracing() {
        let not: Vec<&str> = vrrt_core::kernels::ALL
            .iter()
            .filter(|k| !is_denoiser(k))
            .map(|k| k.entry)
            .collect();
        let mut expected = [
            "gbuffer",
            "raygen_ao",
            "raygen_shadow",
            "gradient_ao",
            "gradient_shadow",
            "raygen_reflect",
            "reflect_tiles",
        ];
        let mut not_sorted = not.clone();
        not_sorted.sort_unstable();
        expected.sort_unstable();
        assert_eq!(not_sorted, expected);
    }
}
