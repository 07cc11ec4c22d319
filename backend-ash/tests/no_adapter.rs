//! With the loader pointed at a driver manifest that does not exist, construction must fail with
//! an error mentioning "no Vulkan adapter", not panic. The check runs in a child process (this
//! same test binary), because the environment variables affect the whole process.

use std::process::Command;
use vrrt_ash::{AshExecutor, AshOptions};

const CHILD: &str = "VRRT_ASH_NO_ADAPTER_CHILD";

fn child(validation: bool) {
    match AshExecutor::new_headless(AshOptions {
        validation,
        sync_validation: true,
    }) {
        Err(e) => {
            let s = e.to_string();
            assert!(s.contains("no Vulkan adapter"), "unexpected error: {s}");
            println!("CHILD-OK validation={validation}: {s}");
        }
        Ok(ex) => panic!(
            "found an adapter despite the bogus ICD: {:?}",
            ex.adapter_info()
        ),
    }
}

#[test]
fn bogus_driver_manifest_gives_no_adapter_error() {
    if std::env::var_os(CHILD).is_some() {
        child(false);
        // The validation layer may still load without a driver; the answer must not change.
        if AshExecutor::new_headless(AshOptions {
            validation: true,
            sync_validation: true,
        })
        .is_err_and(|e| !matches!(e, vrrt_ash::AshError::ValidationUnavailable(_)))
        {
            child(true);
        }
        return;
    }
    let bogus = "/nonexistent/vrrt-no-such-icd.json";
    let out = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "bogus_driver_manifest_gives_no_adapter_error",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD, "1")
        .env("VK_ICD_FILENAMES", bogus)
        .env("VK_DRIVER_FILES", bogus)
        .env_remove("VK_ADD_DRIVER_FILES")
        .env(
            "XDG_RUNTIME_DIR",
            std::env::var_os("XDG_RUNTIME_DIR").unwrap_or("/tmp".into()),
        )
        .output()
        .expect("cannot run the test binary");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("child stdout:\n{stdout}\nchild stderr:\n{stderr}");
    assert!(out.status.success(), "child failed: {}", out.status);
    assert!(
        stdout.contains("CHILD-OK validation=false"),
        "child did not run the check"
    );
}
