//! Builds `vrrt-shaders` (and through it `vrrt-core`) to one SPIR-V module with every entry point,
//! and writes it to `shaders/vrrt.spv`, the artifact the `vrrt-spirv` crate ships to the GPU
//! backends.
//!
//! `cargo run --release -- --check` rebuilds into the cache and fails if the result differs from the
//! checked-in file (what CI runs). `--crate DIR --out FILE` builds another shader crate instead
//! (e.g. one of another project that depends on `vrrt-core`) with the same toolchain and cache,
//! so it needs no codegen backend of its own. Run through `shaders-builder/build.sh`,
//! which keeps the codegen backend and shader build outside the clone.

use spirv_builder::{ModuleResult, SpirvBuilder, SpirvMetadata};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

const TOOLCHAIN: &str = "nightly-2026-08-15";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let check = args.iter().any(|a| a == "--check");
    let path_arg = |flag: &str| {
        let i = args.iter().position(|a| a == flag)?;
        args.get(i + 1).map(PathBuf::from)
    };
    // The repository root comes from build.sh at run time: the cached builder binary may have
    // been compiled from another checkout.
    let root = std::env::var_os("VRRT_ROOT")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf());
    let shader_crate = path_arg("--crate").unwrap_or_else(|| root.join("shaders-rust"));
    let artifact = path_arg("--out").unwrap_or_else(|| root.join("shaders/vrrt.spv"));
    let cache = std::env::var_os("VRRT_SHADER_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target/shader-cache"));

    let mut builder = SpirvBuilder::new(&shader_crate, "spirv-unknown-vulkan1.2");
    builder.toolchain_overwrite = Some(TOOLCHAIN.into());
    builder.target_dir_path = Some(cache.join("shaders"));
    builder.spirv_metadata = SpirvMetadata::None;
    builder.release = true;
    let built = match builder.build() {
        Ok(result) => result,
        Err(e) => {
            eprintln!("shader build failed: {e}");
            return ExitCode::FAILURE;
        }
    };
    let ModuleResult::SingleModule(path) = built.module else {
        eprintln!("expected a single SPIR-V module");
        return ExitCode::FAILURE;
    };
    // As built: no `NoContraction` decorations, so drivers may fuse multiply-adds (equivalence
    // across backends is held to declared tolerances, not bits).
    let fresh = std::fs::read(&path).expect("read built SPIR-V");
    let entries: Vec<_> = built.entry_points.iter().map(String::as_str).collect();
    println!("built {} bytes, entry points: {}", fresh.len(), entries.join(", "));

    if check {
        let committed = std::fs::read(&artifact).unwrap_or_default();
        if committed != fresh {
            eprintln!(
                "{} is stale: it differs from a fresh build of {} ({} vs {} bytes). \
                 Regenerate with shaders-builder/build.sh and commit it.",
                artifact.display(),
                shader_crate.display(),
                committed.len(),
                fresh.len()
            );
            return ExitCode::FAILURE;
        }
        println!("{} is fresh", artifact.display());
    } else {
        if let Some(dir) = artifact.parent() {
            std::fs::create_dir_all(dir).expect("create the output directory");
        }
        std::fs::write(&artifact, &fresh).expect("write the SPIR-V module");
        println!("wrote {}", artifact.display());
    }
    ExitCode::SUCCESS
}
