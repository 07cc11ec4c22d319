//! # vrrt-tests
//!
//! The cross-backend equivalence harness, public so an engine can check its own port of a kernel,
//! or its own backend, against the CPU backend:
//!
//! 1. a [`Case`] is a kernel plus generated input buffers, parameters and a dispatch size;
//! 2. [`run_case`] runs it on any [`Executor`];
//! 3. [`compare`] compares the results word by word — integers exactly, floats by ULP distance.
//!
//! [`cases::TABLE`] lists one generator per kernel: adding a kernel adds one line there.

mod balance_cases;
pub mod cases;
mod filter_cases;
pub mod gradient_cases;
pub mod inputs;
pub mod reflect_cases;
pub mod spirv;
pub mod trace_cases;

use vrrt_core::plan::{Executor, Groups, KernelDesc, Pass};

/// How to compare one 4-byte word of a buffer.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Word {
    /// IEEE f32: compared by ULP distance.
    F32,
    /// Integer: compared exactly.
    U32,
}

/// One binding of a case: initial contents and how its words compare.
#[derive(Clone, Debug)]
pub struct BufferSpec {
    /// Initial contents.
    pub data: Vec<u32>,
    /// Word kinds of one element, repeated over the buffer (e.g. `[F32, F32, F32, U32]`).
    pub layout: &'static [Word],
    /// Compare as a multiset of `u32` words: for lists filled through an atomic counter, whose
    /// order legitimately differs between backends and runs.
    pub unordered: bool,
}

impl BufferSpec {
    /// A buffer initialised from `Pod` elements.
    pub fn from_pod<T: bytemuck::Pod>(elems: &[T], layout: &'static [Word]) -> Self {
        BufferSpec {
            data: bytemuck::cast_slice(elems).to_vec(),
            layout,
            unordered: false,
        }
    }

    /// The same buffer, compared without regard to order.
    pub fn unordered(mut self) -> Self {
        self.unordered = true;
        self
    }
}

/// A kernel with concrete inputs, ready to run on any backend.
#[derive(Clone, Debug)]
pub struct Case {
    /// Human-readable name, e.g. `accumulate 37x19x2`.
    pub name: String,
    /// The kernel.
    pub kernel: &'static KernelDesc,
    /// One spec per binding.
    pub buffers: Vec<BufferSpec>,
    /// Push-constant bytes.
    pub params: Vec<u8>,
    /// Workgroups to launch.
    pub groups: [u32; 3],
}

/// Runs `case` on `exec` and returns every buffer's final contents.
pub fn run_case<E: Executor>(exec: &mut E, case: &Case) -> Result<Vec<Vec<u32>>, E::Error> {
    let mut ids = Vec::with_capacity(case.buffers.len());
    for spec in &case.buffers {
        let id = exec.create_buffer(spec.data.len().max(1) as u64 * 4)?;
        exec.write_buffer(id, bytemuck::cast_slice(&spec.data))?;
        ids.push(id);
    }
    exec.dispatch(&Pass {
        kernel: case.kernel,
        buffers: &ids,
        params: &case.params,
        groups: Groups::Direct(case.groups),
    })?;
    let mut out = Vec::with_capacity(ids.len());
    for (id, spec) in ids.iter().zip(&case.buffers) {
        let mut words = vec![0u32; spec.data.len()];
        exec.read_buffer(*id, bytemuck::cast_slice_mut(&mut words))?;
        out.push(words);
    }
    Ok(out)
}

/// Distance in units in the last place between two f32 bit patterns (0 for identical bits or
/// two NaNs; `u32::MAX` when only one is NaN).
pub fn ulp_distance(a: u32, b: u32) -> u32 {
    let (fa, fb) = (f32::from_bits(a), f32::from_bits(b));
    match (fa.is_nan(), fb.is_nan()) {
        (true, true) => return 0,
        (true, false) | (false, true) => return u32::MAX,
        _ => {}
    }
    // Map sign-magnitude to a monotonic integer line (+0 and -0 both map to 0).
    let ordered = |x: u32| -> i64 {
        if x & 0x8000_0000 != 0 {
            -((x & 0x7fff_ffff) as i64)
        } else {
            x as i64
        }
    };
    (ordered(a) - ordered(b))
        .unsigned_abs()
        .min(u32::MAX as u64) as u32
}

/// The first differing word of a comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct Difference {
    /// Binding index.
    pub binding: usize,
    /// Word index inside the buffer.
    pub word: usize,
    /// Reference bits.
    pub expected: u32,
    /// Bits of the backend under test.
    pub got: u32,
}

/// Outcome of comparing one backend's results with the reference.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    /// Words compared.
    pub words: usize,
    /// Integer words that differ.
    pub int_mismatches: usize,
    /// Float words that differ in any bit.
    pub float_mismatches: usize,
    /// Largest float ULP distance.
    pub max_ulp: u32,
    /// Largest float relative difference `|a-b| / max(|a|,|b|)` over differing finite words.
    pub max_rel: f64,
    /// First differing word, if any.
    pub first: Option<Difference>,
}

impl Report {
    /// True when every word is identical.
    pub fn is_exact(&self) -> bool {
        self.int_mismatches == 0 && self.float_mismatches == 0
    }
}

/// Compares `got` with `expected` buffer by buffer using each binding's word layout.
pub fn compare(case: &Case, expected: &[Vec<u32>], got: &[Vec<u32>]) -> Report {
    let mut r = Report::default();
    for (binding, ((spec, e), g)) in case.buffers.iter().zip(expected).zip(got).enumerate() {
        let sorted = |v: &[u32]| {
            let mut v = v.to_vec();
            v.sort_unstable();
            v
        };
        let (e, g) = if spec.unordered {
            (sorted(e), sorted(g))
        } else {
            (e.clone(), g.clone())
        };
        for (word, (&a, &b)) in e.iter().zip(&g).enumerate() {
            r.words += 1;
            let both_nan = f32::from_bits(a).is_nan() && f32::from_bits(b).is_nan();
            if a == b || (both_nan && spec.layout[word % spec.layout.len()] == Word::F32) {
                continue;
            }
            match spec.layout[word % spec.layout.len()] {
                Word::U32 => r.int_mismatches += 1,
                Word::F32 => {
                    r.float_mismatches += 1;
                    r.max_ulp = r.max_ulp.max(ulp_distance(a, b));
                    let (fa, fb) = (f32::from_bits(a) as f64, f32::from_bits(b) as f64);
                    if fa.is_finite() && fb.is_finite() {
                        let rel = (fa - fb).abs() / fa.abs().max(fb.abs());
                        r.max_rel = r.max_rel.max(rel);
                    } else {
                        r.max_rel = f64::INFINITY;
                    }
                }
            }
            if r.first.is_none() {
                r.first = Some(Difference {
                    binding,
                    word,
                    expected: a,
                    got: b,
                });
            }
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ulp_distance_is_monotonic_across_zero() {
        assert_eq!(ulp_distance(1.0f32.to_bits(), 1.0f32.to_bits()), 0);
        assert_eq!(
            ulp_distance(
                1.0f32.to_bits(),
                f32::from_bits(1.0f32.to_bits() + 3).to_bits()
            ),
            3
        );
        assert_eq!(ulp_distance(0.0f32.to_bits(), (-0.0f32).to_bits()), 0);
        assert_eq!(
            ulp_distance(
                f32::from_bits(1).to_bits(),
                f32::from_bits(0x8000_0001).to_bits()
            ),
            2
        );
        assert_eq!(ulp_distance(f32::NAN.to_bits(), 1.0f32.to_bits()), u32::MAX);
        assert_eq!(ulp_distance(f32::NAN.to_bits(), f32::NAN.to_bits()), 0);
    }

    #[test]
    fn compare_detects_a_perturbed_word() {
        let case = cases::TABLE[0].1(&mut cases::rng(1), 9, 7);
        let mut exec = vrrt_cpu::CpuExecutor::new();
        let a = run_case(&mut exec, &case).unwrap();
        let mut b = a.clone();
        assert!(compare(&case, &a, &b).is_exact());
        let last = b.len() - 1;
        b[last][0] ^= 1;
        let r = compare(&case, &a, &b);
        assert!(!r.is_exact());
        assert_eq!(r.first.unwrap().binding, last);
    }
}
