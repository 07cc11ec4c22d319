//! `vrrt info`: the backends, the Vulkan adapters each sees, and what `auto` would pick; with
//! `--settings`, the default denoiser settings as TOML; with `--memory`, the memory report.

use crate::session::{parse_size, SignalArg};
use anyhow::Result;
use vrrt_ash::{AshExecutor, AshOptions};
use vrrt_backend::{Backend, BackendKind};
use vrrt_core::executor::Executor;
use vrrt_wgpu::{WgpuExecutor, WgpuOptions};

/// Options of `vrrt info`.
#[derive(Clone, Debug, clap::Args)]
pub struct InfoArgs {
    /// Print the default denoiser settings as a TOML settings file (a template for `vrrt run
    /// --settings FILE`) instead of the backends.
    #[arg(long)]
    pub settings: bool,
    /// Print what the denoiser's buffers hold and what one frame moves, per buffer and per pixel
    /// (at `--size`, for `--signal`, default settings at 1 rpp), instead of the backends.
    #[arg(long)]
    pub memory: bool,
    /// Image size of `--memory`, WxH.
    #[arg(long, default_value = "1920x1080", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Signal of `--memory`.
    #[arg(long, value_enum, default_value = "ao")]
    pub signal: SignalArg,
    /// Lights in the scene of `--memory` (one shadow plane each): 1 to 4, and with `--signal
    /// all` 1 or 2 (AO, the shadows and the reflections share the 4 planes).
    #[arg(long, default_value = "1", value_parser = parse_lights)]
    pub lights: usize,
}

/// Most shadow planes, one per light (the denoiser's four planes).
const MAX_LIGHTS: usize = 4;

/// Parses `--lights`: 1 to [`MAX_LIGHTS`]; anything else is an error, not clamped.
fn parse_lights(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n) if (1..=MAX_LIGHTS).contains(&n) => Ok(n),
        _ => Err(format!(
            "`{s}` is not a number of lights from 1 to {MAX_LIGHTS} (one shadow plane each)"
        )),
    }
}

/// Refuses more lights than `signal` leaves planes for (with `all`, AO and reflections take
/// two of the four), with the reason, before the layout's own check fails on a plane count.
fn check_lights(signal: SignalArg, lights: usize) -> Result<()> {
    if signal == SignalArg::All && lights > MAX_LIGHTS - 2 {
        anyhow::bail!(
            "--signal all has planes for at most {} lights (AO and reflections take 2 of the {MAX_LIGHTS} \
             planes, each light a shadow plane), got --lights {lights}",
            MAX_LIGHTS - 2
        );
    }
    Ok(())
}

/// Runs `vrrt info`.
pub fn run(args: &InfoArgs) -> Result<()> {
    if args.settings {
        print!(
            "{}",
            crate::settings::to_toml(&vrrt_core::settings::Settings::default())
        );
        return Ok(());
    }
    if args.memory {
        check_lights(args.signal, args.lights)?;
        let signal = args.signal.signal(1.0);
        let report = crate::memory::report(args.size, args.signal.name(), signal, args.lights)?;
        print!("{report}");
        return Ok(());
    }
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!("cpu:  available — native CPU kernels, {threads} threads (wall-clock pass timings)");

    println!("wgpu (Vulkan):");
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
    if adapters.is_empty() {
        println!("  no Vulkan adapter found");
    }
    for a in &adapters {
        let i = a.get_info();
        let ts = a.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        println!(
            "  adapter: {} ({:?}), driver {} {}, timestamps {}",
            i.name,
            i.device_type,
            i.driver,
            i.driver_info,
            if ts { "supported" } else { "not supported" }
        );
    }
    match WgpuExecutor::new_headless(WgpuOptions::default()) {
        Ok(e) => println!(
            "  opens: {} ({:?}), pass timings from {}",
            e.adapter_info().name,
            e.adapter_info().device_type,
            if e.timestamps_enabled() {
                "GPU timestamps"
            } else {
                "nothing (no timestamp queries)"
            }
        ),
        Err(e) => println!("  unavailable: {e}"),
    }

    println!("ash (raw Vulkan):");
    match AshExecutor::new_headless(AshOptions::default()) {
        Ok(e) => {
            let i = e.adapter_info();
            println!(
                "  opens: {} ({:?}), Vulkan {}.{}.{}, timestamps {}",
                i.name,
                i.adapter_type,
                i.api_version >> 22,
                (i.api_version >> 12) & 0x3ff,
                i.api_version & 0xfff,
                if i.timestamps {
                    format!("supported (period {} ns)", i.timestamp_period_ns)
                } else {
                    "not supported".into()
                }
            );
        }
        Err(e) => println!("  unavailable: {e}"),
    }

    match Backend::open(BackendKind::Auto, false) {
        Ok((b, why)) => println!("auto: {} — {} — because {why}", b.name(), b.device()),
        Err(e) => println!("auto: cannot open any backend: {e}"),
    }
    Ok(())
}
