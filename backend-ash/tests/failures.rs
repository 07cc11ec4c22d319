//! Device limits are typed errors naming the limit, raised before any Vulkan call, and the
//! executor stays usable after one. (Allocation failures within the limits come back as
//! `AshError::Vulkan { call: "vkAllocateMemory", .. }`; a device the application destroys under
//! an embedded executor is outside the `unsafe` contract of `AshExecutor::from_raw`.)

mod common;

use vrrt_ash::AshError;
use vrrt_core::executor::Executor;

#[test]
fn a_buffer_beyond_max_memory_allocation_size_is_refused_by_name() {
    let Some(mut ex) = common::executor() else {
        return;
    };
    match ex.create_buffer(1 << 50) {
        Err(e @ AshError::BufferTooLarge { limit, max, .. }) => {
            assert_eq!(limit, "maxMemoryAllocationSize");
            assert!(max < 1 << 50);
            println!("refused: {e}");
        }
        other => panic!("2^50 bytes: {other:?}"),
    }
    let b = ex.create_buffer(64).unwrap();
    ex.write_buffer(b, &[7u8; 64]).unwrap();
    let mut out = [0u8; 64];
    ex.read_buffer(b, &mut out).unwrap();
    assert_eq!(out, [7u8; 64]);
    assert_eq!(ex.validation_errors(), 0);
}
