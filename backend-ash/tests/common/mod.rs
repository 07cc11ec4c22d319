//! Shared by the integration tests: the executor under test, or `None` (test skipped) without an
//! adapter.

use vrrt_ash::{AshError, AshExecutor, AshOptions};

/// A headless executor with validation (unless `VRRT_VALIDATION=0`; if the layer is missing and
/// `VRRT_VALIDATION=1` is not set, runs without it and says so). Without an adapter prints
/// "skipped: no Vulkan adapter" and returns `None`, or fails if `VRRT_REQUIRE_VULKAN=1`.
pub fn executor() -> Option<AshExecutor> {
    let env = std::env::var("VRRT_VALIDATION").ok();
    let validation = env.as_deref() != Some("0");
    let result = match AshExecutor::new_headless(AshOptions {
        validation,
        ..AshOptions::default()
    }) {
        Err(AshError::ValidationUnavailable(why)) if env.as_deref() != Some("1") => {
            println!("validation unavailable ({why}): running without it");
            AshExecutor::new_headless(AshOptions {
                validation: false,
                ..AshOptions::default()
            })
        }
        r => r,
    };
    match result {
        Ok(ex) => {
            println!("adapter: {:?}", ex.adapter_info());
            Some(ex)
        }
        Err(e @ AshError::NoAdapter(_)) => {
            assert!(
                std::env::var("VRRT_REQUIRE_VULKAN").map_or(true, |v| v != "1"),
                "VRRT_REQUIRE_VULKAN=1 but: {e}"
            );
            println!("skipped: no Vulkan adapter ({e})");
            None
        }
        Err(e) => panic!("{e}"),
    }
}
