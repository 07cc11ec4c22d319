//! The GPU backends of the cross-backend tests, opened and checked one way.

use vrrt_backend::{Backend, BackendKind};
use vrrt_core::executor::Executor;

/// The Vulkan backends that open (wgpu, ash), with validation on. One that does not open prints
/// "skipped: no Vulkan adapter", unless `VRRT_REQUIRE_VULKAN=1` makes that a failure.
pub fn backends() -> Vec<Backend> {
    let require = std::env::var("VRRT_REQUIRE_VULKAN").is_ok_and(|v| v == "1");
    let mut out = Vec::new();
    for kind in [BackendKind::Wgpu, BackendKind::Ash] {
        match Backend::open(kind, true) {
            Ok((b, _)) => {
                println!("{kind:?}: {}", b.device());
                out.push(b);
            }
            Err(e) if require => panic!("{kind:?}: {e} (VRRT_REQUIRE_VULKAN=1)"),
            Err(e) => println!("{kind:?}: skipped: no Vulkan adapter ({e})"),
        }
    }
    out
}

/// A line for each backend that reported validation errors.
pub fn validation_failures(backends: &[Backend]) -> Vec<String> {
    backends
        .iter()
        .filter(|b| b.validation_errors() > 0)
        .map(|b| format!("{}: {} validation errors", b.name(), b.validation_errors()))
        .collect()
}
