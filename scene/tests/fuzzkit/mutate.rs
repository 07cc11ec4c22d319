//! The mutator: a small PRNG and the mutations that make input `i` of a run from valid seeds.

use std::sync::Arc;

// ---- A small PRNG: PCG-XSH-RR 64/32 (O'Neill), one stream per input. ------------------------

/// PCG32: deterministic, tiny, good enough to pick mutations.
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    /// The generator of `stream` under `seed`.
    pub fn new(seed: u64, stream: u64) -> Rng {
        let mut r = Rng {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed ^ 0x853c_49e6_748f_ea9b);
        r.next_u32();
        r
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in `0..n` (`n > 0`; the tiny modulo bias does not matter here).
    pub fn below(&mut self, n: usize) -> usize {
        debug_assert!(n > 0);
        let x = ((self.next_u32() as u64) << 32) | self.next_u32() as u64;
        (x % n as u64) as usize
    }

    /// True with probability `1 / n`.
    pub fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }

    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

// ---- Mutations. ------------------------------------------------------------------------------

/// Numbers that break parsers: signs, overflow at every integer width, float edges, junk.
pub const INTERESTING_TEXT: &[&str] = &[
    "nan",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "infinity",
    "-1",
    "-0",
    "0",
    "1",
    "2",
    "3",
    "255",
    "256",
    "65535",
    "65536",
    "-2147483648",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "-4294967296",
    "9223372036854775807",
    "18446744073709551615",
    "18446744073709551616",
    "1e38",
    "3.4e38",
    "-3.4e38",
    "3.5e38",
    "1e39",
    "1e308",
    "1e309",
    "1e-45",
    "1e-320",
    "0x1F",
    "1.5",
    "0.1",
    ".",
    "-",
    "+",
    "e",
    "1e",
    "",
    "00000000000000000000001",
    "99999999999999999999999999999999",
    "0.1e-1000000",
    "1_000",
];

/// Bytes that break parsers.
pub const INTERESTING_BYTES: &[u8] = &[
    0x00, 0xff, 0x7f, 0x80, 0x01, b' ', b'\n', b'\r', b'\t', b'-', b'.', b'e', b'9', b'/', b'#',
    b'"', b'{', b'[', b',', b'\\', 0xc3, 0xe2,
];

/// Words for binary fields, written in either byte order: integer edges and float bit patterns
/// (NaN, ±inf, `f32::MAX`, 1.0).
pub const INTERESTING_WORDS: &[u64] = &[
    0,
    1,
    2,
    3,
    0x7f,
    0x80,
    0xff,
    0x100,
    0x7fff,
    0x8000,
    0xffff,
    0x1_0000,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    0x7fc0_0000,
    0x7f80_0000,
    0xff80_0000,
    0x7f7f_ffff,
    0x3f80_0000,
    0xffff_ffff_ffff_ffff,
    0x7ff8_0000_0000_0000,
];

/// Input `i` of a run (a pure function of `i`, so any input can be made again to report it).
pub type Inputs = Arc<dyn Fn(usize) -> Vec<u8> + Send + Sync>;

/// Makes input `i` of a run from valid seeds.
pub struct Mutator {
    /// Valid inputs of the format.
    pub seeds: Vec<Vec<u8>>,
    /// Tokens of the format (keywords, separators), inserted as whole units.
    pub dictionary: Vec<Vec<u8>>,
    /// Inputs are cut to this length.
    pub max_len: usize,
    /// The run's seed.
    pub seed: u64,
    /// At most this many mutations are stacked on one input.
    pub max_stack: usize,
}

impl Mutator {
    pub fn new(seeds: Vec<Vec<u8>>, dictionary: &[&str], max_len: usize, seed: u64) -> Mutator {
        assert!(!seeds.is_empty());
        Mutator {
            seeds,
            dictionary: dictionary.iter().map(|d| d.as_bytes().to_vec()).collect(),
            max_len,
            seed,
            max_stack: 8,
        }
    }

    /// The run's inputs.
    pub fn into_inputs(self) -> Inputs {
        Arc::new(move |i| self.input(i))
    }

    /// Input `i`: a seed with 1 to `max_stack` mutations (one, half of the time).
    pub fn input(&self, i: usize) -> Vec<u8> {
        let mut rng = Rng::new(self.seed, i as u64);
        let mut b = rng.pick(&self.seeds).clone();
        let stack = if rng.one_in(2) {
            1
        } else {
            2 + rng.below(self.max_stack.max(2) - 1)
        };
        for _ in 0..stack {
            self.mutate(&mut rng, &mut b);
            b.truncate(self.max_len);
        }
        b
    }

    fn mutate(&self, rng: &mut Rng, b: &mut Vec<u8>) {
        let len = b.len();
        match rng.below(16) {
            // Bit flip.
            0 | 1 if len > 0 => {
                let i = rng.below(len);
                b[i] ^= 1 << rng.below(8);
            }
            // Random byte.
            2 if len > 0 => {
                let i = rng.below(len);
                b[i] = rng.next_u32() as u8;
            }
            // Interesting byte, over or inserted.
            3 if len > 0 => {
                let i = rng.below(len);
                b[i] = *rng.pick(INTERESTING_BYTES);
            }
            4 => {
                let i = rng.below(len + 1);
                let n = 1 + rng.below(4);
                let bytes: Vec<u8> = (0..n)
                    .map(|_| {
                        if rng.one_in(2) {
                            *rng.pick(INTERESTING_BYTES)
                        } else {
                            rng.next_u32() as u8
                        }
                    })
                    .collect();
                b.splice(i..i, bytes);
            }
            // Delete a range.
            5 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(32));
                b.drain(i..i + n);
            }
            // Duplicate a chunk elsewhere, or repeat it in place many times.
            6 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(64));
                let chunk = b[i..i + n].to_vec();
                let at = rng.below(len + 1);
                b.splice(at..at, chunk);
            }
            7 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(16));
                let chunk = b[i..i + n].to_vec();
                let times = 2 + rng.below(64);
                let repeated: Vec<u8> = chunk.iter().copied().cycle().take(n * times).collect();
                b.splice(i..i, repeated);
            }
            // Truncate.
            8 if len > 0 => b.truncate(rng.below(len)),
            // Splice: this input's head, another seed's tail.
            9 => {
                let other = rng.pick(&self.seeds);
                let i = rng.below(len + 1);
                let j = rng.below(other.len() + 1);
                b.truncate(i);
                b.extend_from_slice(&other[j..]);
            }
            // An interesting word in 1, 2, 4 or 8 bytes, either byte order.
            10 if len > 0 => write_word(rng, b),
            // A number replaced by an interesting one.
            11 | 12 => replace_number(rng, b),
            // A dictionary token inserted or written over.
            13 if !self.dictionary.is_empty() => {
                let token = rng.pick(&self.dictionary).clone();
                let i = rng.below(len + 1);
                if rng.one_in(2) || i + token.len() > len {
                    b.splice(i..i, token);
                } else {
                    b.splice(i..i + token.len(), token);
                }
            }
            // Line operations: duplicate, drop or swap lines.
            14 | 15 => line_operation(rng, b),
            // The chosen mutation needs bytes that are not there: grow instead.
            _ => b.push(*rng.pick(INTERESTING_BYTES)),
        }
    }
}

/// An interesting word in 1, 2, 4 or 8 bytes, either byte order, over the bytes at a random
/// place (`b` not empty).
fn write_word(rng: &mut Rng, b: &mut [u8]) {
    let len = b.len();
    let w = *rng.pick(INTERESTING_WORDS);
    let n = [1, 2, 4, 8][rng.below(4)];
    let bytes = if rng.one_in(2) {
        w.to_le_bytes()
    } else {
        w.to_be_bytes()
    };
    let bytes = if rng.one_in(2) {
        &bytes[..n]
    } else {
        &bytes[8 - n..]
    };
    let i = rng.below(len);
    let end = (i + n).min(len);
    b[i..end].copy_from_slice(&bytes[..end - i]);
}

/// A number of `b` replaced by an interesting one (or one inserted where there is none).
fn replace_number(rng: &mut Rng, b: &mut Vec<u8>) {
    let len = b.len();
    let numbers = number_tokens(b);
    let token = rng.pick(INTERESTING_TEXT).as_bytes().to_vec();
    if numbers.is_empty() {
        let i = rng.below(len + 1);
        b.splice(i..i, token);
    } else {
        let (s, e) = *rng.pick(&numbers);
        b.splice(s..e, token);
    }
}

/// Line operations: duplicate, drop or swap lines.
fn line_operation(rng: &mut Rng, b: &mut Vec<u8>) {
    let mut lines: Vec<Vec<u8>> = b
        .split_inclusive(|&c| c == b'\n')
        .map(<[u8]>::to_vec)
        .collect();
    if lines.is_empty() {
        return;
    }
    let i = rng.below(lines.len());
    match rng.below(3) {
        0 => {
            let l = lines[i].clone();
            let at = rng.below(lines.len() + 1);
            lines.insert(at, l);
        }
        1 => {
            lines.remove(i);
        }
        _ => {
            let j = rng.below(lines.len());
            lines.swap(i, j);
        }
    }
    *b = lines.concat();
}

/// Byte ranges of the numbers in `b` (maximal runs of `0-9 . + - e E` holding a digit).
fn number_tokens(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    let in_number = |c: u8| c.is_ascii_digit() || matches!(c, b'.' | b'+' | b'-' | b'e' | b'E');
    while i < b.len() {
        if in_number(b[i]) {
            let s = i;
            while i < b.len() && in_number(b[i]) {
                i += 1;
            }
            if b[s..i].iter().any(u8::is_ascii_digit) {
                out.push((s, i));
            }
        } else {
            i += 1;
        }
    }
    out
}
