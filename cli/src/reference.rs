//! `vrrt reference`: traces and caches the references of a scene's frames.

use crate::limits::LimitArgs;
use crate::run::{check_common, clamp_frames};
use crate::session::{
    load_scene, open_backend, parse_backend, parse_size, parts, ReferenceRequest, References,
    SignalArg,
};
use anyhow::Result;
use vrrt_backend::BackendKind;
use vrrt_core::settings::ReflectionSettings;

/// Options of `vrrt reference`.
#[derive(Clone, Debug, clap::Args)]
pub struct ReferenceArgs {
    /// Built-in scene name, or a mesh file (.obj, .ply, .ply.gz, .glb, .gltf).
    #[arg(long, default_value = "room")]
    pub scene: String,
    /// Frames (from frame 0).
    #[arg(long, default_value_t = 48)]
    pub frames: u32,
    /// Image size, WxH.
    #[arg(long, default_value = "256x144", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Samples per pixel.
    #[arg(long, default_value_t = 256)]
    pub spp: u32,
    /// Signal.
    #[arg(long, value_enum, default_value = "ao")]
    pub signal: SignalArg,
    /// Ambient occlusion maximum distance.
    #[arg(long, default_value_t = 1.0)]
    pub ao_radius: f32,
    /// Backend that traces them: auto, cpu, wgpu or ash.
    #[arg(long, default_value = "cpu", value_parser = parse_backend)]
    pub backend: BackendKind,
    /// Limits on a mesh file given as the scene.
    #[command(flatten, next_help_heading = "Limits on a mesh file")]
    pub limits: LimitArgs,
}

/// Runs `vrrt reference`: the references `run` measures against, one per part of the signal
/// (`all`: AO, shadows and reflections).
pub fn run(args: &ReferenceArgs) -> Result<()> {
    check_common(args.frames, args.spp, args.ao_radius)?;
    let scene = load_scene(&args.scene, &args.limits.limits())?;
    let frames = clamp_frames(args.frames, scene.scene.frames_available());
    let (mut exec, _) = open_backend(args.backend, false)?;
    let refs = References::from_env(true);
    if let Some(dir) = refs.cache_dir() {
        println!("cache: {}", dir.display());
    }
    let signal = args.signal.signal(args.ao_radius);
    let reflections = ReflectionSettings::default();
    let parts = parts(signal, scene.scene.lights.len());
    println!("frame  signal       source  mean_stderr");
    let mut total = 0.0;
    for i in 0..frames {
        let f = scene.scene.frame(i);
        for p in &parts {
            let r = refs.get(
                &mut exec,
                ReferenceRequest {
                    scene_key: &scene.key,
                    frame: &f,
                    size: args.size,
                    signal: p.signal,
                    reflections: &reflections,
                    spp: args.spp,
                },
            )?;
            total += r.mean_stderr;
            println!(
                "{i:>5}  {:<11}  {:<6}  {:.6}",
                p.name,
                if r.cached { "cache" } else { "traced" },
                r.mean_stderr
            );
        }
    }
    println!(
        "{} frames of {} at {}x{}, {} spp, {}: mean standard error {:.6}",
        frames,
        scene.key,
        args.size.0,
        args.size.1,
        args.spp,
        args.signal.name(),
        total / (frames as usize * parts.len()) as f64
    );
    exec.warn_validation_errors();
    Ok(())
}
