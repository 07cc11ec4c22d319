//! # vrrt-tests
//!
//! The cross-backend equivalence harness, public so an engine can check its own port of a kernel,
//! or its own backend, against the CPU backend:
//!
//! 1. a [`Case`] is a kernel plus generated input buffers, parameters and a dispatch size;
//! 2. [`run_case`] runs it on any [`Executor`];
//! 3. [`compare`] compares the results word by word within the case's [`Tolerance`]: integers
//!    exactly, f32 by relative error or ULP, binary16 halves as halves, and the elements a float
//!    comparison decides (ray counts, work lists) up to a named fraction.
//!
//! [`cases::TABLE`] lists one generator per kernel, with its tolerance: adding a kernel adds one
//! line there.

mod balance_cases;
pub mod cases;
mod filter_cases;
pub mod gradient_cases;
pub mod guide_cases;
pub mod ingest_cases;
pub mod inputs;
pub mod reflect_cases;
pub mod spirv;
pub mod trace_cases;

use vrrt_backend::{Backend, TextureFormat};
use vrrt_core::executor::{Access, BufferId, Executor, Groups, KernelDesc, Pass};
use vrrt_core::textures::Texel;

/// How to compare one 4-byte word of a buffer.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Word {
    /// IEEE f32: within the case's [`Tolerance::rel`] or [`Tolerance::ulp`].
    F32,
    /// Integer: compared exactly.
    U32,
    /// Two binary16 halves (`low | high << 16`), each within [`Tolerance::half_ulps`].
    Half2,
    /// A binary16 in the low half, a 16-bit integer (exact) in the high half.
    HalfU16,
    /// A 16-bit integer (exact) in the low half, a binary16 in the high half.
    U16Half,
}

/// The word layouts of the packed types the kernels store, shared by every case.
pub mod layouts {
    use super::Word::{self, *};
    /// `PackedPayload`: the moments (binary16 pair), the history length (binary16) with the rng
    /// index (16 bits).
    pub const PAYLOAD: &[Word] = &[Half2, HalfU16];
    /// `PackedSample`: the moments (binary16 pair), the ray count (16 bits) with the first ray's
    /// value (binary16).
    pub const SAMPLE: &[Word] = &[Half2, U16Half];
    /// `PackedFiltered`: value and variance, binary16.
    pub const FILTERED: &[Word] = &[Half2];
    /// Two binary16 values a word (the AO guide, `kernels::ao_guide::guide_at`).
    pub const HALVES: &[Word] = &[Half2];
    /// f32 words.
    pub const FLOATS: &[Word] = &[F32];
    /// Integer words.
    pub const INTS: &[Word] = &[U32];
}

/// What a case allows between two backends. Hardware GPUs evaluate `exp2`, `log2`, `pow` and
/// `rsqrt` natively and fuse multiply-adds, so floats are held to a tolerance, not to bits.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Tolerance {
    /// f32 words: largest relative difference `|a − b| / max(|a|, |b|)`.
    pub rel: f64,
    /// f32 words: or at most this many ULP apart (what matters near zero, where relative
    /// differences are large and meaningless).
    pub ulp: u32,
    /// Binary16 halves: at most this many half-ULPs apart.
    pub half_ulps: u32,
    /// Buffers marked [`BufferSpec::decided`]: the largest fraction of their elements that may
    /// differ beyond the tolerances above.
    pub decided: f64,
}

impl Tolerance {
    /// The default: 1e-4 relative or 64 ULP for f32 (hardware GPUs' transcendentals and
    /// division), one half-ULP for binary16 (a rounding boundary an f32 ULP away), decided
    /// integers exact.
    pub const DEFAULT: Tolerance = Tolerance {
        rel: 1e-4,
        ulp: 64,
        half_ulps: 1,
        decided: 0.0,
    };

    /// [`Self::DEFAULT`] with `fraction` of the decided words allowed to differ.
    pub const fn deciding(fraction: f64) -> Tolerance {
        Tolerance {
            decided: fraction,
            ..Self::DEFAULT
        }
    }

    /// [`Self::DEFAULT`] with `half_ulps` for the binary16 halves.
    pub const fn halves(self, half_ulps: u32) -> Tolerance {
        Tolerance { half_ulps, ..self }
    }
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
    /// A float comparison inside the kernel decides these elements (ray counts, work lists,
    /// history drops, the GGX acceptance): an input one ULP away may flip one, so up to
    /// [`Tolerance::decided`] of them may differ.
    pub decided: bool,
    /// An engine texture (`width`, `height`, format) of [`Texel`]s instead of a storage buffer:
    /// read by `Access::Sampled` bindings, written (R32F, read back as fetched) by
    /// `Access::Storage` ones.
    pub texture: Option<(u32, u32, TextureFormat)>,
}

impl BufferSpec {
    /// A buffer initialised from `Pod` elements.
    pub fn from_pod<T: bytemuck::Pod>(elems: &[T], layout: &'static [Word]) -> Self {
        BufferSpec {
            data: bytemuck::cast_slice(elems).to_vec(),
            layout,
            unordered: false,
            decided: false,
            texture: None,
        }
    }

    /// An R32F texture the kernel writes, `width × height` texels, initially zero.
    pub fn output_texture(width: u32, height: u32) -> Self {
        let zeros = vec![[0.0f32; 4]; width as usize * height as usize];
        Self::texture(width, height, TextureFormat::R32Float, &zeros)
    }

    /// An engine texture of `format` holding `texels`, row-major.
    pub fn texture(width: u32, height: u32, format: TextureFormat, texels: &[Texel]) -> Self {
        BufferSpec {
            texture: Some((width, height, format)),
            ..Self::from_pod(texels, layouts::FLOATS)
        }
    }

    /// The same buffer, compared without regard to order.
    pub fn unordered(mut self) -> Self {
        self.unordered = true;
        self
    }

    /// The same buffer, its elements decided by float comparisons ([`Self::decided`]).
    pub fn decided(mut self) -> Self {
        self.decided = true;
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

/// An executor that can also hold an engine texture made from host texels.
pub trait Host: Executor {
    /// A `width × height` texture of `format` holding `texels` (see
    /// [`Backend::create_texture`]).
    fn texture(
        &mut self,
        width: u32,
        height: u32,
        format: TextureFormat,
        texels: &[Texel],
    ) -> Result<BufferId, Self::Error>;

    /// A `width × height` R32F texture a kernel writes (see
    /// [`Backend::create_output_texture`]).
    fn output_texture(&mut self, width: u32, height: u32) -> Result<BufferId, Self::Error>;

    /// The texels of an output texture, as a fetch of R32F returns them.
    fn read_texture(
        &mut self,
        id: BufferId,
        width: u32,
        height: u32,
    ) -> Result<Vec<Texel>, Self::Error>;
}

impl Host for vrrt_cpu::CpuExecutor {
    fn texture(
        &mut self,
        width: u32,
        height: u32,
        format: TextureFormat,
        texels: &[Texel],
    ) -> Result<BufferId, Self::Error> {
        let fetched: Vec<Texel> = texels.iter().map(|&t| format.fetched(t)).collect();
        self.create_texture(width, height, &fetched)
    }

    fn output_texture(&mut self, width: u32, height: u32) -> Result<BufferId, Self::Error> {
        self.create_texture(
            width,
            height,
            &vec![[0.0; 4]; width as usize * height as usize],
        )
    }

    fn read_texture(
        &mut self,
        id: BufferId,
        width: u32,
        height: u32,
    ) -> Result<Vec<Texel>, Self::Error> {
        let mut out = vec![[0.0f32; 4]; width as usize * height as usize];
        self.read_buffer(id, bytemuck::cast_slice_mut(&mut out))?;
        Ok(out
            .into_iter()
            .map(|t| TextureFormat::Rgba16Float.fetched(t))
            .collect())
    }
}

impl Host for Backend {
    fn texture(
        &mut self,
        width: u32,
        height: u32,
        format: TextureFormat,
        texels: &[Texel],
    ) -> Result<BufferId, Self::Error> {
        self.create_texture(width, height, format, texels)
    }

    fn output_texture(&mut self, width: u32, height: u32) -> Result<BufferId, Self::Error> {
        self.create_output_texture(width, height)
    }

    fn read_texture(
        &mut self,
        id: BufferId,
        width: u32,
        height: u32,
    ) -> Result<Vec<Texel>, Self::Error> {
        Backend::read_texture(self, id, width, height)
    }
}

/// Runs `case` on `exec` and returns every buffer's final contents (a texture's: its texels).
pub fn run_case<E: Host>(exec: &mut E, case: &Case) -> Result<Vec<Vec<u32>>, E::Error> {
    let mut ids = Vec::with_capacity(case.buffers.len());
    for (spec, binding) in case.buffers.iter().zip(case.kernel.bindings) {
        let id = match spec.texture {
            Some((w, h, _)) if binding.access == Access::Storage => exec.output_texture(w, h)?,
            Some((w, h, format)) => exec.texture(w, h, format, bytemuck::cast_slice(&spec.data))?,
            None => {
                let id = exec.create_buffer(spec.data.len().max(1) as u64 * 4)?;
                exec.write_buffer(id, bytemuck::cast_slice(&spec.data))?;
                id
            }
        };
        ids.push(id);
    }
    exec.dispatch(&Pass {
        kernel: case.kernel,
        buffers: &ids,
        params: &case.params,
        groups: Groups::Direct(case.groups),
    })?;
    let mut out = Vec::with_capacity(ids.len());
    for ((id, spec), binding) in ids.iter().zip(&case.buffers).zip(case.kernel.bindings) {
        match spec.texture {
            Some((w, h, _)) if binding.access == Access::Storage => {
                out.push(bytemuck::cast_slice(&exec.read_texture(*id, w, h)?).to_vec())
            }
            Some(_) => out.push(spec.data.clone()),
            None => {
                let mut words = vec![0u32; spec.data.len()];
                exec.read_buffer(*id, bytemuck::cast_slice_mut(&mut words))?;
                out.push(words);
            }
        }
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

/// Distance in half-ULPs between two binary16 codes (0 for identical codes or two NaNs;
/// `u32::MAX` when only one is NaN).
pub fn half_ulp_distance(a: u16, b: u16) -> u32 {
    let nan = |h: u16| (h & 0x7c00) == 0x7c00 && (h & 0x03ff) != 0;
    match (nan(a), nan(b)) {
        (true, true) => return 0,
        (true, false) | (false, true) => return u32::MAX,
        _ => {}
    }
    let ordered = |h: u16| -> i32 {
        if h & 0x8000 != 0 {
            -((h & 0x7fff) as i32)
        } else {
            h as i32
        }
    };
    (ordered(a) - ordered(b)).unsigned_abs()
}

/// The first word of a comparison outside its tolerance.
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
    /// Words outside the tolerance, outside decided buffers: any fails the case.
    pub failures: usize,
    /// Integer words (or 16-bit integer halves) that differ.
    pub int_mismatches: usize,
    /// Float words (f32 or binary16) that differ in any bit.
    pub float_mismatches: usize,
    /// Elements of decided buffers compared.
    pub decided_elements: usize,
    /// Elements of decided buffers with a word outside the tolerance.
    pub decided_mismatches: usize,
    /// Largest f32 ULP distance.
    pub max_ulp: u32,
    /// Largest f32 relative difference over differing words (∞ where one is not finite).
    pub max_rel: f64,
    /// Largest binary16 distance in half-ULPs.
    pub max_half_ulp: u32,
    /// First word outside the tolerance outside decided buffers, if any.
    pub first: Option<Difference>,
}

impl Report {
    /// True when every word is identical.
    pub fn is_exact(&self) -> bool {
        self.int_mismatches == 0 && self.float_mismatches == 0
    }

    /// Fraction of the decided elements that differ (0 without any).
    pub fn decided_fraction(&self) -> f64 {
        if self.decided_elements == 0 {
            0.0
        } else {
            self.decided_mismatches as f64 / self.decided_elements as f64
        }
    }

    /// True when every word is within `tol`.
    pub fn within(&self, tol: &Tolerance) -> bool {
        self.failures == 0 && self.decided_fraction() <= tol.decided
    }

    fn f32_word(&mut self, a: u32, b: u32, tol: &Tolerance) -> bool {
        self.float_mismatches += 1;
        let ulp = ulp_distance(a, b);
        self.max_ulp = self.max_ulp.max(ulp);
        let (fa, fb) = (f32::from_bits(a) as f64, f32::from_bits(b) as f64);
        let rel = if fa.is_finite() && fb.is_finite() {
            (fa - fb).abs() / fa.abs().max(fb.abs())
        } else {
            f64::INFINITY
        };
        self.max_rel = self.max_rel.max(rel);
        ulp <= tol.ulp || rel <= tol.rel
    }

    fn half(&mut self, a: u32, b: u32, tol: &Tolerance) -> bool {
        let (a, b) = (a as u16, b as u16);
        if a == b {
            return true;
        }
        self.float_mismatches += 1;
        let d = half_ulp_distance(a, b);
        self.max_half_ulp = self.max_half_ulp.max(d);
        d <= tol.half_ulps
    }

    fn int16(&mut self, a: u32, b: u32) -> bool {
        let same = a as u16 == b as u16;
        if !same {
            self.int_mismatches += 1;
        }
        same
    }

    /// Compares one word of kind `kind`: whether it is within `tol`.
    fn word(&mut self, kind: Word, a: u32, b: u32, tol: &Tolerance) -> bool {
        self.words += 1;
        if a == b {
            return true;
        }
        let (hi_a, hi_b) = (a >> 16, b >> 16);
        match kind {
            Word::U32 => {
                self.int_mismatches += 1;
                false
            }
            Word::F32 => {
                let both_nan = f32::from_bits(a).is_nan() && f32::from_bits(b).is_nan();
                both_nan || self.f32_word(a, b, tol)
            }
            Word::Half2 => self.half(a, b, tol) & self.half(hi_a, hi_b, tol),
            Word::HalfU16 => self.half(a, b, tol) & self.int16(hi_a, hi_b),
            Word::U16Half => self.int16(a, b) & self.half(hi_a, hi_b, tol),
        }
    }

    /// Compares one element (one repetition of `spec.layout`) starting at word `at`.
    fn element(
        &mut self,
        spec: &BufferSpec,
        binding: usize,
        at: usize,
        (e, g): (&[u32], &[u32]),
        tol: &Tolerance,
    ) {
        let mut ok = true;
        for (i, (&a, &b)) in e.iter().zip(g).enumerate() {
            let word_ok = self.word(spec.layout[i], a, b, tol);
            ok &= word_ok;
            if !word_ok && !spec.decided {
                self.failures += 1;
                self.first.get_or_insert(Difference {
                    binding,
                    word: at + i,
                    expected: a,
                    got: b,
                });
            }
        }
        if spec.decided {
            self.decided_elements += 1;
            self.decided_mismatches += usize::from(!ok);
        }
    }
}

/// The words of `e` missing from `g`, as multisets (for lists filled through an atomic counter,
/// whose order legitimately differs between backends and runs).
fn unmatched(e: &[u32], g: &[u32]) -> usize {
    let sorted = |v: &[u32]| {
        let mut v = v.to_vec();
        v.sort_unstable();
        v
    };
    let (e, g) = (sorted(e), sorted(g));
    let (mut i, mut j, mut missing) = (0, 0, 0);
    while i < e.len() {
        if j < g.len() && e[i] == g[j] {
            i += 1;
            j += 1;
        } else if j < g.len() && g[j] < e[i] {
            j += 1;
        } else {
            missing += 1;
            i += 1;
        }
    }
    missing
}

/// Compares `got` with `expected` buffer by buffer using each binding's word layout and `tol`.
pub fn compare(case: &Case, tol: &Tolerance, expected: &[Vec<u32>], got: &[Vec<u32>]) -> Report {
    let mut r = Report::default();
    for (binding, ((spec, e), g)) in case.buffers.iter().zip(expected).zip(got).enumerate() {
        if spec.unordered {
            // Lists of integers, compared as multisets of words.
            let missing = unmatched(e, g);
            r.words += e.len();
            r.int_mismatches += missing;
            if spec.decided {
                r.decided_elements += e.len();
                r.decided_mismatches += missing;
            } else if missing > 0 {
                r.failures += missing;
                r.first.get_or_insert(Difference {
                    binding,
                    word: 0,
                    expected: e.len() as u32,
                    got: missing as u32,
                });
            }
            continue;
        }
        let n = spec.layout.len();
        for (k, pair) in e.chunks(n).zip(g.chunks(n)).enumerate() {
            r.element(spec, binding, k * n, pair, tol);
        }
    }
    r
}

/// Compares two word arrays of one `layout` within `tol` (every word must be within it): for
/// tests that read buffers back themselves, outside a [`Case`].
pub fn compare_words(
    layout: &'static [Word],
    tol: &Tolerance,
    expected: &[u32],
    got: &[u32],
) -> Report {
    let spec = BufferSpec {
        data: Vec::new(),
        layout,
        unordered: false,
        decided: false,
        texture: None,
    };
    let mut r = Report::default();
    let n = layout.len();
    for (k, pair) in expected.chunks(n).zip(got.chunks(n)).enumerate() {
        r.element(&spec, 0, k * n, pair, tol);
    }
    if expected.len() != got.len() {
        r.failures += 1;
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
    fn halves_compare_as_halves() {
        let one: u16 = 0x3c00; // 1.0
        assert_eq!(half_ulp_distance(one, one + 1), 1);
        assert_eq!(half_ulp_distance(0x0001, 0x8001), 2);
        assert_eq!(half_ulp_distance(0x7e00, 0x7e01), 0);
        assert_eq!(half_ulp_distance(0x7e00, one), u32::MAX);
        let tol = Tolerance::DEFAULT;
        let mut r = Report::default();
        let word = |lo: u16, hi: u16| lo as u32 | (hi as u32) << 16;
        assert!(r.word(Word::Half2, word(one, one), word(one + 1, one - 1), &tol));
        assert!(!r.word(Word::Half2, word(one, one), word(one + 2, one), &tol));
        // The integer half of a mixed word is exact.
        assert!(!r.word(Word::HalfU16, word(one, 7), word(one, 8), &tol));
        assert!(r.word(Word::U16Half, word(7, one), word(7, one + 1), &tol));
        assert_eq!(r.max_half_ulp, 2);
    }

    #[test]
    fn decided_buffers_allow_their_fraction() {
        let spec = BufferSpec::from_pod(&[0u32; 4], layouts::INTS).decided();
        let case = Case {
            name: "decided".into(),
            kernel: &vrrt_core::kernels::FILL,
            buffers: vec![spec],
            params: vec![],
            groups: [1, 1, 1],
        };
        let e = vec![vec![1, 2, 3, 4]];
        let g = vec![vec![1, 2, 3, 5]];
        let r = compare(&case, &Tolerance::DEFAULT, &e, &g);
        assert_eq!((r.decided_elements, r.decided_mismatches), (4, 1));
        assert!(!r.within(&Tolerance::DEFAULT));
        assert!(r.within(&Tolerance::deciding(0.25)));
        assert!(!r.within(&Tolerance::deciding(0.2)));
    }

    #[test]
    fn compare_detects_a_perturbed_word() {
        let case = cases::TABLE[0].1(&mut cases::rng(1), 9, 7);
        let mut exec = vrrt_cpu::CpuExecutor::new();
        let a = run_case(&mut exec, &case).unwrap();
        let mut b = a.clone();
        let tol = Tolerance::DEFAULT;
        assert!(compare(&case, &tol, &a, &b).is_exact());
        let last = b.len() - 1;
        // Far outside any tolerance: the sign bit of the first word.
        b[last][0] ^= 0x8000_0000;
        let r = compare(&case, &tol, &a, &b);
        assert!(!r.is_exact() && !r.within(&tol), "{r:?}");
        assert_eq!(r.first.unwrap().binding, last);
    }
}
