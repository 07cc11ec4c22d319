//! `vrrt bench`: error against cost over a matrix of denoiser configurations × ray budgets ×
//! signals × scenes × backends at one size. Writes `bench.csv`, `bench.md` and error-vs-cost plots.

use crate::limits::LimitArgs;
use crate::outdir::OutDir;
use crate::page::Page;
use crate::plot::{self, Curve};
use crate::progress;
use crate::run::{check_common, clamp_frames, load_settings};
use crate::session::{
    self, fmt, load_scene, open_backend, parse_backend, parse_rpp, parse_size, Config, LoadedScene,
    References, SequenceOptions, SignalArg,
};
use anyhow::{bail, Result};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;
use vrrt_backend::{Backend, BackendKind};
use vrrt_scene::metrics::ErrorSpectrum;

mod spectrum;

/// Options of `vrrt bench`. Unset options take the quick or full defaults.
#[derive(Clone, Debug, clap::Args)]
pub struct BenchArgs {
    /// Quick matrix: room, 160x90, 48 frames, budgets 0.5 and 1, cpu, 1 repeat; signals other
    /// than AO only through svgf, vrrt and vrrt-noskip.
    #[arg(long, conflicts_with = "production")]
    pub quick: bool,
    /// Production-size matrix: room, bunny and dragon at 640x360, AO, shadows and reflections,
    /// svgf, svgf-clamp and vrrt at 1 rpp, 96 frames (past every scene's camera cut), cpu, 1
    /// repeat. Options given win over it.
    #[arg(long)]
    pub production: bool,
    /// Scenes, comma separated (default room,bunny,dragon; quick: room). The mesh scenes need
    /// `vrrt fetch` first: without their meshes the bench stops before rendering anything.
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Configurations, comma separated (default all; see `--quick`).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub configs: Vec<Config>,
    /// Ray budgets in rays per pixel, comma separated (full default 0.25,0.5,1,2,4). They win over
    /// `rates.rays_per_pixel` of `--settings`.
    #[arg(long, value_delimiter = ',', value_parser = parse_rpp)]
    pub budgets: Vec<f32>,
    /// Backends, comma separated (full default: cpu, wgpu and ash where available).
    #[arg(long, value_delimiter = ',', value_parser = parse_backend)]
    pub backends: Vec<BackendKind>,
    /// Image size, WxH (default 256x144; quick 160x90).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Frames per sequence (default 96: past the camera cuts, at 60 in room, 72 in bunny, 84 in
    /// dragon; quick 48).
    #[arg(long)]
    pub frames: Option<u32>,
    /// Timing repeats per cell (default 3; quick 1); ms is their median.
    #[arg(long)]
    pub repeats: Option<u32>,
    /// Reference samples per pixel.
    #[arg(long, default_value_t = 256)]
    pub spp: u32,
    /// Signals, comma separated (default ao,reflections).
    #[arg(long, alias = "signal", value_enum, value_delimiter = ',')]
    pub signals: Vec<SignalArg>,
    /// Ambient occlusion maximum distance.
    #[arg(long, default_value_t = 1.0)]
    pub ao_radius: f32,
    /// Output directory. It holds only this bench's files: the files an earlier bench wrote there
    /// (listed in its `.vrrt-bench-manifest`; `.vrrt-bench-passes-manifest` with `--passes`)
    /// are removed first, and nothing else in it is touched.
    #[arg(long, default_value = "out/bench")]
    pub out: PathBuf,
    /// Per-pass report against the bandwidth floor instead of the matrix: renders one
    /// configuration (the first of `--scenes`, `--configs`, `--budgets`, `--signals`; default
    /// room, vrrt, 1 rpp, AO) at `--size` (default 1280x720) for `--frames` (default 8, the
    /// first 2 warm-up) on each of `--backends` (default auto), and writes `passes.csv`.
    #[arg(long)]
    pub passes: bool,
    /// Settings file (TOML, as for `vrrt run --settings`; `vrrt info --settings` prints
    /// the defaults). Every cell starts from it instead of the defaults; the cell's
    /// configuration, budget and signal win over it (`rates.rays_per_pixel` of the file is not
    /// used, nor `rates.reset_payback` for reflections alone or `rates.reset_refill` but for
    /// shadows alone).
    #[arg(long, value_name = "FILE")]
    pub settings: Option<PathBuf>,
    /// Do not write the page `report.html` (with its images in `report/`): crops of what moves
    /// in the frames after each event of the scene, every configuration side by side.
    #[arg(long)]
    pub no_page: bool,
    /// The widest instructions the CPU backend's kernels may take: `native` (the widest the CPU
    /// has: AVX-512, then AVX2), `avx2` (AVX2, F16C and FMA at most) or `baseline` (the target's
    /// baseline, SSE2 on x86-64). Lowered, a machine with AVX-512 runs the code a machine without
    /// it would.
    #[arg(long, value_enum, default_value = "native")]
    pub cpu_lanes: CpuLanesArg,
    /// Limits on a mesh file given as the scene.
    #[command(flatten, next_help_heading = "Limits on a mesh file")]
    pub limits: LimitArgs,
}

/// `--cpu-lanes`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum CpuLanesArg {
    /// The widest the CPU has.
    Native,
    /// AVX2, F16C and FMA at most.
    Avx2,
    /// The target's baseline.
    Baseline,
}

impl From<CpuLanesArg> for vrrt_core::executor::CpuLanes {
    fn from(arg: CpuLanesArg) -> Self {
        match arg {
            CpuLanesArg::Native => Self::Avx512,
            CpuLanesArg::Avx2 => Self::Avx2,
            CpuLanesArg::Baseline => Self::Baseline,
        }
    }
}

/// The scenes of the full matrix when `--scenes` is not given.
pub const DEFAULT_SCENES: [&str; 3] = ["room", "bunny", "dragon"];

/// Most timing repeats per cell (`--repeats`).
pub const MAX_REPEATS: u32 = 100;

/// `items` without repeats, first occurrences kept in order: a list such as `--budgets 1,1,1`
/// names one cell, not three.
pub fn distinct<T: PartialEq + Clone>(items: &[T]) -> Vec<T> {
    let mut out: Vec<T> = Vec::with_capacity(items.len());
    for x in items {
        if !out.contains(x) {
            out.push(x.clone());
        }
    }
    out
}

/// One cell of the matrix.
#[derive(Clone, Debug)]
pub struct Cell {
    /// Scene key.
    pub scene: String,
    /// Signal.
    pub signal: SignalArg,
    /// Configuration.
    pub config: Config,
    /// Budget, rays per pixel.
    pub budget: f32,
    /// Backend name.
    pub backend: String,
    /// Size.
    pub size: (u32, u32),
    /// Frames.
    pub frames: u32,
    /// Mean relMSE over the sequence.
    pub relmse: f64,
    /// Mean over the sequence of the relMSE the references' own noise adds to `relmse`
    /// (`vrrt_scene::metrics::reference_rel_noise`): `relmse` less this estimates the error
    /// against the converged image.
    pub reference_noise: f64,
    /// PSNR of the mean MSE.
    pub psnr: f64,
    /// Mean SSIM.
    pub ssim: f64,
    /// Mean FLIP.
    pub flip: f64,
    /// Temporal error.
    pub temporal: f64,
    /// Mean relMSE of the moving region.
    pub moving_relmse: f64,
    /// relMSE over the pixels without history, pooled over the sequence.
    pub fresh_relmse: f64,
    /// The references' noise over the same pixels, pooled the same way: `fresh_relmse` less
    /// this estimates their error against the converged image.
    pub fresh_reference_noise: f64,
    /// Rays the change detector traced per frame (per plane).
    pub detector_rays_per_frame: f64,
    /// Mean relMSE outside the moving region.
    pub static_relmse: f64,
    /// The change detector against the oracle's mask, summed over the sequence.
    pub detection: Option<session::Detection>,
    /// Rays traced per frame.
    pub rays_per_frame: f64,
    /// Most rays any frame traced beyond its budget (negative: every frame stayed under).
    pub max_overshoot: f64,
    /// Median over repeats of the mean ms per frame.
    pub ms_per_frame: f64,
    /// Max − min over repeats of the mean ms per frame.
    pub ms_spread: f64,
    /// Mean ms per frame of each pass (first repeat).
    pub passes: Vec<(&'static str, f64)>,
    /// Mean relMSE of the raw samples.
    pub raw_relmse: f64,
    /// Error power spectrum of the reported image, mean over the measured frames.
    pub error_spectrum: ErrorSpectrum,
    /// Error power spectrum of the raw samples.
    pub raw_spectrum: ErrorSpectrum,
}

impl Cell {
    /// What names the cell, its first columns everywhere: scene, signal, configuration, budget
    /// and backend, joined by `sep`.
    pub fn key(&self, sep: &str) -> String {
        let budget = self.budget.to_string();
        [
            self.scene.as_str(),
            self.signal.name(),
            self.config.name(),
            &budget,
            self.backend.as_str(),
        ]
        .join(sep)
    }
}

/// What a matrix runs where its options are not given: `--quick`'s, `--production`'s or the
/// full one's.
struct Matrix {
    scenes: &'static [&'static str],
    configs: &'static [Config],
    budgets: &'static [f32],
    backends: &'static [BackendKind],
    signals: &'static [SignalArg],
    size: (u32, u32),
    frames: u32,
    repeats: u32,
}

impl Matrix {
    fn of(args: &BenchArgs) -> Matrix {
        let full = Matrix {
            scenes: &DEFAULT_SCENES,
            configs: &Config::ALL,
            budgets: &[0.25, 0.5, 1.0, 2.0, 4.0],
            backends: &[BackendKind::Cpu, BackendKind::Wgpu, BackendKind::Ash],
            signals: &[SignalArg::Ao, SignalArg::Reflections],
            size: (256, 144),
            frames: 96,
            repeats: 3,
        };
        if args.quick {
            Matrix {
                scenes: &["room"],
                budgets: &[0.5, 1.0],
                backends: &[BackendKind::Cpu],
                size: (160, 90),
                frames: 48,
                repeats: 1,
                ..full
            }
        } else if args.production {
            Matrix {
                configs: &[Config::Svgf, Config::SvgfClamp, Config::Vrrt],
                budgets: &[1.0],
                backends: &[BackendKind::Cpu],
                signals: &[SignalArg::Ao, SignalArg::Shadows, SignalArg::Reflections],
                size: (640, 360),
                repeats: 1,
                ..full
            }
        } else {
            full
        }
    }
}

/// `given` without repeats, or `default` when none was given.
fn or_default<T: PartialEq + Clone>(given: &[T], default: &[T]) -> Vec<T> {
    if given.is_empty() {
        default.to_vec()
    } else {
        distinct(given)
    }
}

/// Says whether OIDN is installed (it is not yet part of the matrix).
fn print_oidn() {
    match which("oidnDenoise") {
        Some(p) => println!(
            "OIDN: found at {} (not yet part of the matrix)",
            p.display()
        ),
        None => println!("OIDN: not installed (pip install pyoidn==2.5.1 provides oidnDenoise)"),
    }
}

/// One cell of the matrix to measure: a scene and signal on a backend, `repeats` times.
struct CellRun<'a> {
    scene: &'a LoadedScene,
    backend: &'a str,
    kind: SignalArg,
    repeats: u32,
}

impl CellRun<'_> {
    /// Renders the cell's sequence `repeats` times (the first measured, the others timed only)
    /// and summarises it: errors from the first, the median time over all.
    fn measure(
        &self,
        exec: &mut Backend,
        mut opts: SequenceOptions,
        refs: &References,
        page: &mut Page,
    ) -> Result<Cell> {
        let mut ms = Vec::new();
        let mut first = None;
        let mut shots = page.sequence(exec, self.scene, &opts);
        for _ in 0..self.repeats {
            let r = session::run_sequence(exec, self.scene, &opts, refs, |v| shots.frame(v))?;
            ms.push(r.mean_of(|f| f.ms_frame));
            first.get_or_insert(r);
            opts.measure = false;
        }
        let r = first.expect("at least one repeat");
        ms.sort_by(f64::total_cmp);
        let s = r.summary();
        Ok(Cell {
            scene: self.scene.key.clone(),
            signal: self.kind,
            config: opts.config,
            budget: opts.rpp,
            backend: self.backend.to_string(),
            size: opts.size,
            frames: opts.frames,
            relmse: s.mean_rel_mse,
            reference_noise: r.mean_of(|f| f.reference_noise),
            psnr: s.psnr_of_mean_mse,
            ssim: s.mean_ssim,
            flip: r.mean_of(|f| f.flip),
            temporal: s.temporal.unwrap_or(f64::NAN),
            moving_relmse: s.mean_masked_rel_mse.unwrap_or(f64::NAN),
            fresh_relmse: r.fresh_relmse(),
            fresh_reference_noise: r.fresh_reference_noise(),
            detector_rays_per_frame: r.mean_of(|f| f.detector_rays as f64),
            static_relmse: r.mean_of(|f| f.static_relmse),
            detection: r.detection(),
            rays_per_frame: r.mean_of(|f| f.rays_traced as f64),
            max_overshoot: r
                .records
                .iter()
                .map(|f| f.overshoot())
                .fold(f64::NEG_INFINITY, f64::max),
            ms_per_frame: ms[ms.len() / 2],
            ms_spread: ms[ms.len() - 1] - ms[0],
            passes: r.pass_means(&r.records),
            raw_relmse: r.mean_of(|f| f.raw_relmse),
            error_spectrum: spectrum::mean(&r.records, |f| &f.error_spectrum),
            raw_spectrum: spectrum::mean(&r.records, |f| &f.raw_spectrum),
        })
    }
}

/// One line of progress: the cell just measured.
fn announce(cell: &Cell, started: Instant) {
    progress::println(&format!(
        "{} {} {} {} rpp on {}: relMSE {}, {:.1} ms/frame ({:.0} s elapsed)",
        cell.scene,
        cell.signal.name(),
        cell.config.name(),
        cell.budget,
        cell.backend,
        fmt(cell.relmse, 6),
        cell.ms_per_frame,
        started.elapsed().as_secs_f64()
    ));
}

/// Writes `bench.csv`, `bench.md`, `spectrum.csv`, the plots and the page, and prints the
/// tables.
fn write_results(
    out: &OutDir,
    page: &mut Page,
    cells: &[Cell],
    started: Instant,
    dir: &std::path::Path,
) -> Result<()> {
    let csv = bench_csv(cells);
    let md = bench_md(cells) + &adaptive_md(cells) + &oracle_md(cells);
    out.write("bench.csv", csv.as_bytes())?;
    out.write("bench.md", md.as_bytes())?;
    out.write("spectrum.csv", spectrum::csv(cells).as_bytes())?;
    if let Err(e) = plots(out, cells) {
        eprintln!("warning: plots not written: {e:#}");
    }
    page.write()?;
    println!("{md}");
    println!(
        "{} cells in {:.1} s; results in {}",
        cells.len(),
        started.elapsed().as_secs_f64(),
        dir.display()
    );
    Ok(())
}

/// Configurations of the quick matrix for signals other than AO: the SVGF baseline, VRRT and its
/// nothing-skipped twin (all eight for reflections too would double the quick bench's time).
const QUICK_OTHER_CONFIGS: [Config; 3] = [Config::Svgf, Config::Vrrt, Config::VrrtNoskip];

const HEADER: &str = "scene,signal,config,budget_rpp,backend,width,height,frames,relmse,psnr,ssim,flip,temporal_error,moving_relmse,rays_per_frame,ms_per_frame,ms_spread,detector_rays_per_px,fresh_relmse,moving_vs_oracle,static_relmse,detector_miss_rate,detector_false_positive_rate,raw_relmse,error_lowfreq_fraction,error_low_mse,raw_lowfreq_fraction,raw_low_mse,max_overshoot,reference_noise,relmse_vs_truth,fresh_reference_noise,fresh_vs_truth";

/// Runs `vrrt bench`.
pub fn run(args: &BenchArgs) -> Result<()> {
    vrrt_core::executor::set_cpu_lanes(args.cpu_lanes.into());
    if args.passes {
        return crate::passes::run(args);
    }
    let q = args.quick;
    let m = Matrix::of(args);
    let pick = |given: &[String], default: &[&str]| -> Vec<String> {
        if given.is_empty() {
            default.iter().map(|s| s.to_string()).collect()
        } else {
            distinct(given)
        }
    };
    // Every scene is loaded (a missing mesh is an error naming `vrrt fetch`) before any
    // rendering, below.
    let scenes = pick(&args.scenes, m.scenes);
    let configs = or_default(&args.configs, m.configs);
    let budgets = or_default(&args.budgets, m.budgets);
    let explicit_backends = !args.backends.is_empty();
    let backends = or_default(&args.backends, m.backends);
    let size = args.size.unwrap_or(m.size);
    let frames = args.frames.unwrap_or(m.frames);
    let repeats = args.repeats.unwrap_or(m.repeats);
    check_common(frames, args.spp, args.ao_radius)?;
    if !(1..=MAX_REPEATS).contains(&repeats) {
        bail!("--repeats must be between 1 and {MAX_REPEATS}, got {repeats}");
    }
    let signals = or_default(&args.signals, m.signals);
    let base = load_settings(args.settings.as_deref())?;
    let limits = args.limits.limits();
    let loaded = scenes
        .iter()
        .map(|s| load_scene(s, &limits))
        .collect::<Result<Vec<_>>>()?;
    let out = std::rc::Rc::new(OutDir::prepare(&args.out, "bench")?);
    let mut page = Page::new(out.clone(), !args.no_page);

    print_oidn();

    let started = Instant::now();
    let mut cells = Vec::new();
    for kind in &backends {
        let (mut exec, _) = match open_backend(*kind, false) {
            Ok(b) => b,
            Err(e) if !explicit_backends => {
                println!("skipping backend {kind:?}: {e}");
                continue;
            }
            Err(e) => return Err(e),
        };
        let backend = {
            use vrrt_core::executor::Executor;
            exec.name().to_string()
        };
        println!("backend {backend}: {}", exec.device());
        // One per executor: it keeps the buffers of the references it traces on it.
        let refs = References::from_env(true);
        for scene in &loaded {
            let frames = clamp_frames(frames, scene.scene.frames_available());
            for &kind in &signals {
                let configs = if q && args.configs.is_empty() && kind != SignalArg::Ao {
                    &QUICK_OTHER_CONFIGS[..]
                } else {
                    &configs
                };
                for &config in configs {
                    for &budget in &budgets {
                        let opts = SequenceOptions {
                            size,
                            frames,
                            signal: kind.signal(args.ao_radius),
                            spp: args.spp,
                            base,
                            config,
                            rpp: budget,
                            overlays: false,
                            measure: true,
                        };
                        let run = CellRun {
                            scene,
                            backend: &backend,
                            kind,
                            repeats,
                        };
                        let cell = run.measure(&mut exec, opts, &refs, &mut page)?;
                        announce(&cell, started);
                        cells.push(cell);
                    }
                }
            }
        }
        exec.warn_validation_errors();
    }
    if cells.is_empty() {
        bail!("no backend could be opened");
    }

    write_results(&out, &mut page, &cells, started, &args.out)
}

fn which(program: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join(program))
        .find(|p| p.is_file())
}

fn pass_names(cells: &[Cell]) -> Vec<&'static str> {
    let mut names = Vec::new();
    for c in cells {
        for (p, _) in &c.passes {
            if !names.contains(p) {
                names.push(*p);
            }
        }
    }
    names
}

/// `bench.csv`: the header of the brief, then one `ms_<pass>` column per pass.
pub fn bench_csv(cells: &[Cell]) -> String {
    let names = pass_names(cells);
    let mut s = String::from(HEADER);
    session::pass_header(&mut s, &names);
    s.push('\n');
    for c in cells {
        let _ = write!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{:.1},{:.3},{:.3},{:.4},{},{},{},{},{},{},{:.0},{},{},{},{}",
            c.key(","),
            c.size.0,
            c.size.1,
            c.frames,
            fmt(c.relmse, 7),
            fmt(c.psnr, 3),
            fmt(c.ssim, 5),
            fmt(c.flip, 5),
            fmt(c.temporal, 7),
            fmt(c.moving_relmse, 7),
            c.rays_per_frame,
            c.ms_per_frame,
            c.ms_spread,
            c.detector_rays_per_frame / (c.size.0 * c.size.1) as f64,
            fmt(c.fresh_relmse, 7),
            fmt(moving_vs_oracle(cells, c), 4),
            fmt(c.static_relmse, 7),
            fmt(c.detection.map_or(f64::NAN, |d| d.miss_rate()), 4),
            fmt(c.detection.map_or(f64::NAN, |d| d.false_positive_rate()), 5),
            spectrum::columns(c),
            c.max_overshoot,
            fmt(c.reference_noise, 7),
            fmt(c.relmse - c.reference_noise, 7),
            fmt(c.fresh_reference_noise, 7),
            fmt(c.fresh_relmse - c.fresh_reference_noise, 7)
        );
        session::pass_columns(&mut s, &c.passes, &names);
        s.push('\n');
    }
    s
}

/// `bench.md`: a markdown table of the cells.
pub fn bench_md(cells: &[Cell]) -> String {
    let mut s = String::from(
        "| scene | signal | config | rpp | backend | size | relMSE | PSNR | SSIM | FLIP | temporal | moving relMSE | rays/px | ms/frame (spread) |\n\
         |---|---|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for c in cells {
        let px = (c.size.0 * c.size.1) as f64;
        let _ = writeln!(
            s,
            "| {} | {}x{} | {} | {} | {} | {} | {} | {} | {:.3} | {:.1} (±{:.1}) |",
            c.key(" | "),
            c.size.0,
            c.size.1,
            fmt(c.relmse, 5),
            fmt(c.psnr, 2),
            fmt(c.ssim, 4),
            fmt(c.flip, 4),
            fmt(c.temporal, 5),
            fmt(c.moving_relmse, 5),
            c.rays_per_frame / px,
            c.ms_per_frame,
            c.ms_spread / 2.0
        );
    }
    s
}

/// The adaptive plan against the same frames with nothing skipped: for every cell of `vrrt` or
/// `vrrt-save` with a `vrrt-noskip` twin (same scene, signal, budget, backend), the differences in error,
/// time and rays. Empty when the matrix has no such pair.
pub fn adaptive_md(cells: &[Cell]) -> String {
    let mut s = String::new();
    for c in cells
        .iter()
        .filter(|c| matches!(c.config, Config::Vrrt | Config::VrrtSave))
    {
        let Some(full) = twin(cells, c, Config::VrrtNoskip) else {
            continue;
        };
        if s.is_empty() {
            s.push_str(
                "\nAdaptive plan against nothing skipped (`vrrt-noskip`):\n\n\
                 | scene | signal | config | rpp | backend | relMSE change | moving relMSE change | ms/frame change | rays change |\n\
                 |---|---|---|---:|---|---:|---:|---:|---:|\n",
            );
        }
        let pct = |a: f64, b: f64| 100.0 * (a / b - 1.0);
        let _ = writeln!(
            s,
            "| {} | {:+.2}% | {:+.2}% | {:+.1}% | {:+.1}% |",
            c.key(" | "),
            pct(c.relmse, full.relmse),
            pct(c.moving_relmse, full.moving_relmse),
            pct(c.ms_per_frame, full.ms_per_frame),
            pct(c.rays_per_frame, full.rays_per_frame)
        );
    }
    s
}

/// The cell of `config` rendering the same scene, signal, budget and backend as `c`.
fn twin<'a>(cells: &'a [Cell], c: &Cell, config: Config) -> Option<&'a Cell> {
    cells.iter().find(|f| {
        f.config == config
            && f.scene == c.scene
            && f.signal == c.signal
            && f.budget == c.budget
            && f.backend == c.backend
    })
}

/// `c`'s moving-region relMSE over the oracle's on the same frames (NaN without an oracle cell).
fn moving_vs_oracle(cells: &[Cell], c: &Cell) -> f64 {
    twin(cells, c, Config::VrrtOracle).map_or(f64::NAN, |o| c.moving_relmse / o.moving_relmse)
}

/// Dynamic events against the oracle: for every `vrrt` cell with a `vrrt-oracle` twin, the
/// moving-region relMSE of `vrrt`, the oracle and `svgf-clamp` and their ratios, the whole
/// sequence against `svgf`, the static region against `vrrt-nodetect`, the pixels without
/// history and the detector's rays, misses and false positives. Empty when the matrix has no
/// such pair.
pub fn oracle_md(cells: &[Cell]) -> String {
    let mut s = String::new();
    for c in cells.iter().filter(|c| c.config == Config::Vrrt) {
        let Some(oracle) = twin(cells, c, Config::VrrtOracle) else {
            continue;
        };
        if s.is_empty() {
            s.push_str(
                "\nDynamic events against the oracle (`vrrt-oracle`: history dropped where the \
                 reference changed):\n\n\
                 | scene | signal | rpp | backend | moving: vrrt | oracle | svgf-clamp | vrrt / oracle | vrrt / svgf-clamp | oracle / svgf-clamp | relMSE vrrt / svgf | static vs no detector | fresh: vrrt | oracle | detector rays/px | missed | false positives |\n\
                 |---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
            );
        }
        let moving = |k| twin(cells, c, k).map_or(f64::NAN, |t| t.moving_relmse);
        let clamp = moving(Config::SvgfClamp);
        let svgf = twin(cells, c, Config::Svgf).map_or(f64::NAN, |t| t.relmse);
        let px = (c.size.0 * c.size.1) as f64;
        let still = twin(cells, c, Config::VrrtNodetect).map_or(f64::NAN, |t| {
            100.0 * (c.static_relmse / t.static_relmse - 1.0)
        });
        let rate = |f: fn(&session::Detection) -> f64| {
            c.detection
                .map_or("n/a".to_string(), |d| format!("{:.2}%", 100.0 * f(&d)))
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:+.1}% | {} | {} | {:.4} | {} | {} |",
            c.scene,
            c.signal.name(),
            c.budget,
            c.backend,
            fmt(c.moving_relmse, 5),
            fmt(oracle.moving_relmse, 5),
            fmt(clamp, 5),
            fmt(c.moving_relmse / oracle.moving_relmse, 3),
            fmt(c.moving_relmse / clamp, 3),
            fmt(oracle.moving_relmse / clamp, 3),
            fmt(c.relmse / svgf, 3),
            still,
            fmt(c.fresh_relmse, 5),
            fmt(oracle.fresh_relmse, 5),
            c.detector_rays_per_frame / px,
            rate(session::Detection::miss_rate),
            rate(session::Detection::false_positive_rate)
        );
    }
    s
}

/// Per scene, signal and backend: relMSE against ms per frame and against rays per pixel, one curve per
/// configuration (its points are the budgets).
fn plots(out: &OutDir, cells: &[Cell]) -> Result<()> {
    let mut groups: Vec<(String, SignalArg, String)> = Vec::new();
    for c in cells {
        let g = (c.scene.clone(), c.signal, c.backend.clone());
        if !groups.contains(&g) {
            groups.push(g);
        }
    }
    for (scene, signal, backend) in groups {
        let in_group: Vec<&Cell> = cells
            .iter()
            .filter(|c| c.scene == scene && c.signal == signal && c.backend == backend)
            .collect();
        let signal = signal.name();
        let mut configs: Vec<Config> = Vec::new();
        for c in &in_group {
            if !configs.contains(&c.config) {
                configs.push(c.config);
            }
        }
        let curves = |x: &dyn Fn(&Cell) -> f64| -> Vec<Curve> {
            configs
                .iter()
                .map(|&k| Curve {
                    name: k.name().to_string(),
                    points: in_group
                        .iter()
                        .filter(|c| c.config == k)
                        .map(|c| (x(c), c.relmse))
                        .collect(),
                })
                .collect()
        };
        plot::curves(
            &out.file(&format!("relmse_vs_ms_{scene}_{signal}_{backend}.png"))?,
            &format!("{scene}, {signal} on {backend}: error vs time"),
            "ms per frame",
            "relMSE",
            &curves(&|c| c.ms_per_frame),
        )?;
        plot::curves(
            &out.file(&format!("relmse_vs_rpp_{scene}_{signal}_{backend}.png"))?,
            &format!("{scene}, {signal} on {backend}: error vs rays"),
            "rays per pixel per frame (traced)",
            "relMSE",
            &curves(&|c| c.rays_per_frame / (c.size.0 * c.size.1) as f64),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        bench: BenchArgs,
    }

    fn matrix(args: &[&str]) -> Matrix {
        let cli = Cli::try_parse_from(std::iter::once("vrrt").chain(args.iter().copied()));
        Matrix::of(&cli.unwrap().bench)
    }

    #[test]
    fn the_production_matrix_is_the_three_scenes_at_640x360() {
        let m = matrix(&["--production"]);
        assert_eq!(m.scenes, DEFAULT_SCENES);
        assert_eq!((m.size, m.frames, m.budgets), ((640, 360), 96, &[1.0][..]));
        assert_eq!(m.signals.len(), 3);
        assert_eq!(m.configs, [Config::Svgf, Config::SvgfClamp, Config::Vrrt]);
        assert_eq!(m.backends, [BackendKind::Cpu]);
        // The quick one is unchanged, and the two do not mix.
        let q = matrix(&["--quick"]);
        assert_eq!((q.scenes, q.size, q.frames), (&["room"][..], (160, 90), 48));
        assert!(Cli::try_parse_from(["vrrt", "--quick", "--production"]).is_err());
    }
}
