//! The comparison harness of the ash-vs-CPU equivalence tests (inputs, launches, bit checks).

use bytemuck::Pod;
use vrrt_ash::AshExecutor;
use vrrt_core::payload::{Filtered, PackedFiltered};
use vrrt_core::plan::{BufferId, Executor, KernelDesc, Pass};
use vrrt_cpu::CpuExecutor;

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

/// Distance in units in the last place between two f32 bit patterns (0 for +0/-0).
fn ulp(a: u32, b: u32) -> u32 {
    let key = |x: u32| {
        if x & 0x8000_0000 != 0 {
            0x8000_0000 - (x & 0x7fff_ffff)
        } else {
            0x8000_0000 + x
        }
    };
    key(a).abs_diff(key(b))
}

/// Whether the embedded module decorates float arithmetic `NoContraction`. Without it, drivers
/// may fuse `a * b + c` into an FMA (lavapipe does), so float results can differ from the CPU by a
/// few ULP; with it, lavapipe is bit-exact.
fn module_forbids_contraction() -> bool {
    let bytes = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders/vrrt.spv"));
    let words: Vec<u32> = bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let mut i = 5;
    while i < words.len() {
        let (op, n) = (words[i] & 0xffff, (words[i] >> 16) as usize);
        // OpDecorate %id NoContraction
        if op == 71 && n >= 3 && words[i + 2] == 42 {
            return true;
        }
        i += n.max(1);
    }
    false
}

/// Integer words must match exactly; float words bit-exactly when `exact_floats`, else within
/// `max_ulp` (reported).
pub fn assert_bits<T: Pod + std::fmt::Debug>(
    what: &str,
    gpu: &[T],
    cpu: &[T],
    floats: bool,
    max_ulp: u32,
) {
    let (g, c): (&[u32], &[u32]) = (bytemuck::cast_slice(gpu), bytemuck::cast_slice(cpu));
    assert_eq!(g.len(), c.len());
    let exact = !floats || module_forbids_contraction();
    let diff = g.iter().zip(c).filter(|(a, b)| a != b).count();
    let worst = g.iter().zip(c).map(|(&a, &b)| ulp(a, b)).max().unwrap_or(0);
    println!(
        "{what}: {diff} of {} words differ, max {worst} ULP",
        g.len()
    );
    let limit = if exact { 0 } else { max_ulp };
    if (exact && diff > 0) || worst > limit {
        let i = g.iter().zip(c).position(|(a, b)| a != b).unwrap() * 4 / std::mem::size_of::<T>();
        panic!(
            "{what}: {diff} words differ (max {worst} ULP, allowed {limit}); first element {i}: gpu {:?} cpu {:?}",
            gpu[i], cpu[i]
        );
    }
    if !exact && diff > 0 {
        println!("  (module lacks NoContraction: FMA contraction allowed, not bit-exact)");
    }
}

/// The filter's packed words as values (compared as floats).
pub fn unpacked(f: &[PackedFiltered]) -> Vec<Filtered> {
    f.iter().map(|p| p.unpack()).collect()
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
