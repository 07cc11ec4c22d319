//! Unit tests of the plan types (traffic accounting of a pass), kept apart so plan.rs stays short.

use super::*;

/// A kernel that is never run: only its bindings matter to the accounting.
unsafe fn no_op(_: UVec3, _: &CpuBindings<'_>) {}

static KERNEL: KernelDesc = KernelDesc {
    entry: "hand_built",
    workgroup_size: [8, 8, 1],
    bindings: &[
        Binding {
            name: "input",
            ty: "f32",
            elem_size: 4,
            access: Access::Read,
        },
        Binding {
            name: "out",
            ty: "[f32; 4]",
            elem_size: 16,
            access: Access::Write,
        },
        Binding {
            name: "counters",
            ty: "u32",
            elem_size: 4,
            access: Access::Atomic,
        },
    ],
    params_size: 0,
    cpu: no_op,
};

#[test]
fn bytes_moved_reads_and_writes_each_bound_buffer_once() {
    let buffers = [BufferId(3), BufferId(7), BufferId(9)];
    let pass = Pass::over_grid(&KERNEL, &buffers, &[], 64, 32, 1);
    let size = |id: BufferId| match id.0 {
        3 => 64 * 32 * 4,
        7 => 64 * 32 * 16,
        9 => 8,
        _ => unreachable!("not bound"),
    };
    let bytes = pass.bytes_moved(size);
    // Read: the input and the atomic counters; written: the output and the counters.
    assert_eq!(
        bytes,
        PassBytes {
            read: 64 * 32 * 4 + 8,
            written: 64 * 32 * 16 + 8,
        }
    );
    assert_eq!(bytes.total(), 64 * 32 * 20 + 16);
    let mut twice = bytes;
    twice += bytes;
    assert_eq!(twice.total(), 2 * bytes.total());
}
