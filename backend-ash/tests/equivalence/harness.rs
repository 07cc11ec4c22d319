//! The comparison harness of the ash-vs-CPU equivalence tests (inputs, launches, tolerance checks).

use bytemuck::Pod;
use vrrt_ash::AshExecutor;
use vrrt_core::executor::{BufferId, Executor, KernelDesc, Pass};
use vrrt_cpu::CpuExecutor;
use vrrt_tests::{compare_words, Tolerance, Word};

/// xorshift32: deterministic "random" inputs.
pub struct Rng(pub u32);
impl Rng {
    pub fn next(&mut self) -> u32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        self.0
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f32 {
        (self.next() >> 8) as f32 / (1u32 << 24) as f32
    }
}

/// Creates and fills the same buffers on both executors.
pub fn upload<E: Executor>(ex: &mut E, data: &[&[u8]]) -> Vec<BufferId> {
    data.iter()
        .map(|d| {
            let b = ex.create_buffer(d.len() as u64).unwrap();
            ex.write_buffer(b, d).unwrap();
            b
        })
        .collect()
}

pub fn read<E: Executor, T: Pod>(ex: &mut E, b: BufferId, len: usize) -> Vec<T> {
    let mut out = vec![T::zeroed(); len];
    ex.read_buffer(b, bytemuck::cast_slice_mut(&mut out))
        .unwrap();
    out
}

/// Asserts that `gpu` matches `cpu` within `tol`, word by word in `layout`
/// (`vrrt_tests::compare_words`): integers exactly, f32 by relative error or ULP, binary16 halves
/// as halves. The GPU's native transcendentals and fused multiply-adds leave the last bits free.
pub fn assert_within<T: Pod>(
    what: &str,
    gpu: &[T],
    cpu: &[T],
    layout: &'static [Word],
    tol: &Tolerance,
) {
    let (g, c): (&[u32], &[u32]) = (bytemuck::cast_slice(gpu), bytemuck::cast_slice(cpu));
    assert_eq!(g.len(), c.len());
    let r = compare_words(layout, tol, c, g);
    println!(
        "{what}: {} int and {} float words of {} differ (max {} ULP, {:.2e} relative, {} half-ULPs)",
        r.int_mismatches, r.float_mismatches, r.words, r.max_ulp, r.max_rel, r.max_half_ulp
    );
    assert!(r.within(tol), "{what}: outside {tol:?}: {r:?}");
}

pub fn check_validation(ex: &AshExecutor) {
    assert_eq!(
        ex.validation_errors(),
        0,
        "validation reported errors (see stderr)"
    );
}

/// One kernel launch of [`run_both`].
pub struct Launch<'a> {
    pub kernel: &'static KernelDesc,
    /// Contents of the buffers created for the pass, in binding order.
    pub inputs: &'a [&'a [u8]],
    pub params: &'a [u8],
    /// `[width, height, planes]`: one invocation per element.
    pub grid: [u32; 3],
    /// Index of the buffer read back, and its length in elements.
    pub out: usize,
    pub out_len: usize,
}

/// Runs `launch` on both executors; returns (gpu, cpu) contents of its `out` buffer.
pub fn run_both<T: Pod>(ex: &mut AshExecutor, launch: &Launch<'_>) -> (Vec<T>, Vec<T>) {
    let Launch {
        kernel,
        inputs,
        params,
        grid: [w, h, planes],
        out,
        out_len,
    } = *launch;
    let mut cpu = CpuExecutor::new();
    let gb = upload(ex, inputs);
    let cb = upload(&mut cpu, inputs);
    ex.dispatch(&Pass::over_grid(kernel, &gb, params, w, h, planes))
        .unwrap();
    cpu.dispatch(&Pass::over_grid(kernel, &cb, params, w, h, planes))
        .unwrap();
    (read(ex, gb[out], out_len), read(&mut cpu, cb[out], out_len))
}
