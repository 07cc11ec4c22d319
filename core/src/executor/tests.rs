//! Unit tests of the executor types (traffic accounting of a pass, runs of workgroups).

use super::*;

/// A kernel that is never run: only its bindings matter to the accounting.
unsafe fn no_op(_: GroupSpan, _: &CpuBindings<'_>) {}

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

/// Every workgroup of a dispatch in exactly one run, runs aligned so a lanes call never
/// straddles two, and enough runs to share among the threads.
#[test]
fn group_spans_cover_each_workgroup_once_aligned() {
    for groups in [
        [160, 90, 1],
        [240, 135, 2],
        [1, 1, 1],
        [3000, 1, 1],
        [37, 2, 3],
        [0, 5, 1],
    ] {
        for threads in [1, 2, 16] {
            let spans: std::vec::Vec<GroupSpan> = GroupSpan::split(groups, threads).collect();
            let mut seen = std::vec![0u32; (groups[0] * groups[1] * groups[2]) as usize];
            for s in &spans {
                assert_eq!(s.x_start % GroupSpan::ALIGN, 0, "{s:?}");
                assert!(
                    s.x_end % GroupSpan::ALIGN == 0 || s.x_end == groups[0],
                    "{s:?}"
                );
                for g in s.groups() {
                    seen[((g.z * groups[1] + g.y) * groups[0] + g.x) as usize] += 1;
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "{groups:?} {threads}");
            // Aligning a piece at most doubles it: at least half the runs asked for, where the
            // dispatch has that many aligned pieces.
            let pieces = groups[1] * groups[2] * groups[0].div_ceil(GroupSpan::ALIGN);
            let wanted = (8 * threads as u32).min(pieces);
            assert!(
                spans.len() as u32 * 2 >= wanted,
                "{groups:?} {threads}: {}",
                spans.len()
            );
        }
    }
}
