//! Builds `vrrt-shaders` (and through it `vrrt-core`) to one SPIR-V module with every entry point,
//! and writes it to `shaders/vrrt.spv`, the artifact the host crates embed.
//!
//! `cargo run --release -- --check` rebuilds into the cache and fails if the result differs from the
//! checked-in file (what CI runs). Run through `shaders-builder/build.sh`, which keeps the codegen
//! backend and shader build outside the clone.

use spirv_builder::{ModuleResult, SpirvBuilder, SpirvMetadata};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

const TOOLCHAIN: &str = "nightly-2026-08-15";

fn main() -> ExitCode {
    let check = std::env::args().any(|a| a == "--check");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf();
    let artifact = root.join("shaders/vrrt.spv");
    let cache = std::env::var_os("VRRT_SHADER_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target/shader-cache"));

    let mut builder = SpirvBuilder::new(root.join("shaders-rust"), "spirv-unknown-vulkan1.2");
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
    let fresh = std::fs::read(&path).expect("read built SPIR-V");
    let entries: Vec<_> = built.entry_points.iter().map(String::as_str).collect();
    println!("built {} bytes, entry points: {}", fresh.len(), entries.join(", "));

    if check {
        let committed = std::fs::read(&artifact).unwrap_or_default();
        if committed != fresh {
            eprintln!(
                "shaders/vrrt.spv is stale: it differs from a fresh build of vrrt-shaders \
                 ({} vs {} bytes). Regenerate with shaders-builder/build.sh and commit it.",
                committed.len(),
                fresh.len()
            );
            return ExitCode::FAILURE;
        }
        println!("shaders/vrrt.spv is fresh");
    } else {
        std::fs::write(&artifact, &fresh).expect("write shaders/vrrt.spv");
        println!("wrote {}", artifact.display());
    }
    ExitCode::SUCCESS
}
