//! Detects whether `shaders/vrrt.spv` exists, so the crate still builds (and reports a clear
//! runtime error) before the shader module has been generated.

use std::path::Path;

fn main() {
    let spv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders/vrrt.spv");
    println!("cargo::rerun-if-changed={}", spv.display());
    println!("cargo::rustc-check-cfg=cfg(vrrt_spv_missing)");
    if !spv.is_file() {
        println!("cargo::rustc-cfg=vrrt_spv_missing");
        println!(
            "cargo::warning=shaders/vrrt.spv not found: WgpuExecutor will report ShaderMissing"
        );
    }
}
