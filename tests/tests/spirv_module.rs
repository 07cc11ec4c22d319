//! The shipped SPIR-V matches the kernel descriptions the backends launch it with.

use vrrt_tests::spirv::entry_points;

use vrrt_spirv::SPIRV as MODULE;

#[test]
fn every_kernel_desc_matches_its_entry_point() {
    let entries = entry_points(MODULE).expect("parse shaders/vrrt.spv");
    for kernel in vrrt_core::kernels::ALL {
        let e = entries
            .iter()
            .find(|e| e.name == kernel.entry)
            .unwrap_or_else(|| {
                panic!(
                    "entry point `{}` missing from shaders/vrrt.spv",
                    kernel.entry
                )
            });
        assert_eq!(
            e.local_size, kernel.workgroup_size,
            "workgroup size of `{}`",
            kernel.entry
        );
        let of_kind = |texture: bool| -> Vec<u32> {
            (0..kernel.bindings.len() as u32)
                .filter(|&i| kernel.bindings[i as usize].access.texture() == texture)
                .collect()
        };
        assert_eq!(
            e.bindings.iter().copied().collect::<Vec<_>>(),
            of_kind(false),
            "storage-buffer bindings of `{}`",
            kernel.entry
        );
        assert_eq!(
            e.textures.iter().copied().collect::<Vec<_>>(),
            of_kind(true),
            "texture bindings of `{}`",
            kernel.entry
        );
        assert_eq!(
            e.push_constants,
            kernel.params_size > 0,
            "push constants of `{}`",
            kernel.entry
        );
    }
    for e in &entries {
        assert!(
            vrrt_core::kernels::ALL.iter().any(|k| k.entry == e.name),
            "entry point `{}` has no KernelDesc in vrrt_core::kernels::ALL",
            e.name
        );
    }
}

#[test]
fn rejects_garbage() {
    assert!(entry_points(&[0u8; 3]).is_err());
    assert!(entry_points(&[0u8; 40]).is_err());
}
