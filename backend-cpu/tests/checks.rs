//! The checks every backend shares (`Pass::check`, `ExecError`), through the CPU backend: bad
//! passes and buffer accesses are reported with the shared error, never run.

use vrrt_core::executor::{BufferId, ExecError, Executor, Groups, Pass, PlanError};
use vrrt_core::kernels::copy::CopyParams;
use vrrt_core::kernels::fill::FillParams;
use vrrt_core::kernels::{COPY, FILL};
use vrrt_cpu::{CpuError, CpuExecutor};

const PARAMS: FillParams = FillParams { len: 4, value: 7 };

fn fill(buffers: &[BufferId], groups: Groups) -> Pass<'_> {
    Pass {
        kernel: &FILL,
        buffers,
        params: bytemuck::bytes_of(&PARAMS),
        groups,
    }
}

#[test]
fn buffer_errors() {
    let mut ex = CpuExecutor::new();
    assert_eq!(ex.create_buffer(6), Err(CpuError::UnalignedSize(6)));
    let a = ex.create_buffer(16).unwrap();
    assert_eq!(
        ex.write_buffer(a, &[0; 20]),
        Err(ExecError::OutOfRange {
            buffer: a,
            bytes: 20,
            size: 16
        })
    );
    assert_eq!(
        ex.read_buffer(BufferId(9), &mut [0; 4]),
        Err(ExecError::UnknownBuffer(BufferId(9)))
    );
    let e = ex.read_buffer(a, &mut [0; 17]).unwrap_err();
    assert_eq!(
        e.to_string(),
        "17 bytes do not fit buffer BufferId(0) of 16 bytes"
    );
}

#[test]
fn pass_errors() {
    let mut ex = CpuExecutor::new();
    let a = ex.create_buffer(16).unwrap();
    let args = ex.create_buffer(16).unwrap();
    let direct = Groups::Direct([1, 1, 1]);

    let e = ex.dispatch(&fill(&[a, a], direct)).unwrap_err();
    assert!(
        matches!(e, ExecError::Plan(PlanError::BindingCount { .. })),
        "{e}"
    );
    assert_eq!(
        ex.dispatch(&fill(&[BufferId(5)], direct)),
        Err(ExecError::UnknownBuffer(BufferId(5)))
    );

    let indirect = |buffer, offset| Groups::Indirect { buffer, offset };
    assert_eq!(
        ex.dispatch(&fill(&[a], indirect(BufferId(5), 0))),
        Err(ExecError::UnknownBuffer(BufferId(5)))
    );
    assert_eq!(
        ex.dispatch(&fill(&[a], indirect(args, 8))),
        Err(ExecError::OutOfRange {
            buffer: args,
            bytes: 20,
            size: 16
        })
    );
    let e = ex.dispatch(&fill(&[args], indirect(args, 0))).unwrap_err();
    assert_eq!(e, ExecError::IndirectWritten(args));
    assert!(e.to_string().contains("indirect counts"), "{e}");

    // Nothing ran.
    let mut out = [1u8; 16];
    ex.read_buffer(a, &mut out).unwrap();
    assert_eq!(out, [0; 16]);
    assert!(ex.timings().is_empty());

    // A valid indirect pass runs.
    ex.write_buffer(args, bytemuck::cast_slice(&[0u32, 1, 1, 1]))
        .unwrap();
    ex.dispatch(&fill(&[a], indirect(args, 4))).unwrap();
    let mut words = [0u32; 4];
    ex.read_buffer(a, bytemuck::cast_slice_mut(&mut words))
        .unwrap();
    assert_eq!(words, [7; 4]);
}

/// Two bindings of one kernel bound to the same buffer.
#[test]
fn aliased_binding() {
    let kernel = vrrt_core::kernels::ALL
        .iter()
        .copied()
        .find(|k| k.bindings.len() >= 2)
        .expect("a kernel with two bindings");
    let mut ex = CpuExecutor::new();
    let a = ex.create_buffer(64).unwrap();
    let buffers = vec![a; kernel.bindings.len()];
    let params = vec![0u8; kernel.params_size as usize];
    let pass = Pass {
        kernel,
        buffers: &buffers,
        params: &params,
        groups: Groups::Direct([1, 1, 1]),
    };
    let e = ex.dispatch(&pass).unwrap_err();
    assert_eq!(e, ExecError::AliasedBinding(a));
    assert_eq!(e.to_string(), "buffer BufferId(0) bound twice in one pass");
}

/// A shared buffer is the caller's bytes, not a copy, for as long as it is only read: a pass
/// reads it in place; writing it, or binding it where a pass writes, gives the executor its own
/// copy and leaves the caller's bytes as they were.
#[test]
fn shared_buffers_are_read_in_place_and_copied_on_write() {
    use std::sync::Arc;
    let words: Vec<u32> = (0..256).collect();
    let data = Arc::new(words.clone());
    let mut ex = CpuExecutor::new();
    let src = ex.create_buffer_shared(data.clone()).unwrap();
    let dst = ex.create_buffer(1024).unwrap();
    assert_eq!(ex.owned_bytes(), 1024, "the shared buffer is not a copy");
    assert_eq!(
        ex.contents(src).unwrap().as_ptr(),
        data.as_ptr() as *const u8
    );
    let params = CopyParams { row: 64, len: 256 };
    ex.dispatch(&copy(&[src, dst], &params)).unwrap();
    assert_eq!(ex.contents(dst).unwrap(), bytemuck::cast_slice(&words));
    assert_eq!(ex.owned_bytes(), 1024, "read in place");
    // Written by a pass: the executor's own copy; the caller's bytes are unchanged.
    ex.write_buffer(dst, &[0; 1024]).unwrap();
    ex.dispatch(&copy(&[dst, src], &params)).unwrap();
    assert_eq!(ex.owned_bytes(), 2048);
    assert_eq!(ex.contents(src).unwrap(), &[0; 1024][..]);
    assert_eq!(*data, words);
    // Written from the host, the same.
    let shared = ex.create_buffer_shared(data.clone()).unwrap();
    ex.write_buffer(shared, &[9; 4]).unwrap();
    assert_eq!(
        &ex.contents(shared).unwrap()[..8],
        &[9, 9, 9, 9, 1, 0, 0, 0]
    );
    assert_eq!(*data, words);
    // Bytes that are not whole aligned words are copied, sized as `create_buffer` would.
    let odd = ex.create_buffer_shared(Arc::new(OddBytes)).unwrap();
    assert_eq!(ex.contents(odd).unwrap(), &[1, 2, 3, 0]);
}

/// Three bytes: not a whole word.
struct OddBytes;

impl vrrt_core::executor::SharedBytes for OddBytes {
    fn bytes(&self) -> &[u8] {
        &[1, 2, 3]
    }
}

/// The copy kernel from the first buffer to the second.
fn copy<'a>(buffers: &'a [BufferId], params: &'a CopyParams) -> Pass<'a> {
    Pass {
        kernel: &COPY,
        buffers,
        params: bytemuck::bytes_of(params),
        groups: Groups::Direct([1, 1, 1]),
    }
}
