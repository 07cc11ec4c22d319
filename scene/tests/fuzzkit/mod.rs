//! The seeded mutation fuzzer of the default test loop, shared by `scene/tests/fuzz.rs` (mesh
//! loaders) and `cli/tests/fuzz.rs` (settings, configuration names, size and rate arguments),
//! which includes this file with `#[path]`.
//!
//! Input `i` of a run is a pure function of the run's seed and `i` ([`Mutator::input`]): valid
//! seed files, mutated by bit flips, byte inserts and deletes, chunk duplication, truncation,
//! splicing between seeds, interesting bytes and words, and (for text) numbers replaced by
//! interesting ones (`nan`, `-1`, `4294967296`, …) and lines duplicated, dropped or swapped.
//! [`run`] feeds every input to a check under `catch_unwind` on a worker thread, while the test's
//! thread watches for a hang, and reports panics, broken properties, the slowest input and the
//! most memory one input held (through the counting allocator below, per thread). The mutator is
//! in `mutate.rs`.

#![allow(dead_code)] // Each test binary uses a different part.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

mod mutate;

pub use mutate::{Inputs, Mutator};

pub const MIB: usize = 1 << 20;

// ---- Memory: bytes held by the current thread, and their peak. --------------------------------

/// The system allocator, counting per thread the bytes allocated and not yet freed, and their
/// peak. A check runs on one thread, so the peak over a call, less the count before it, is the
/// most memory that call held at once, whatever other tests do meanwhile.
pub struct Counting;

thread_local! {
    static LIVE: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
}

fn add(delta: isize) {
    let _ = LIVE.try_with(|l| {
        let v = l.get() + delta;
        l.set(v);
        let _ = PEAK.try_with(|p| p.set(p.get().max(v)));
    });
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        add(layout.size() as isize);
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        add(layout.size() as isize);
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        add(new_size as isize - layout.size() as isize);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        add(-(layout.size() as isize));
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// `f`'s result and the most bytes it held at once on this thread (beyond what was held before).
pub fn peak_memory<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let base = LIVE.with(Cell::get);
    PEAK.with(|p| p.set(base));
    let out = f();
    let peak = PEAK.with(Cell::get);
    (out, (peak - base).max(0) as usize)
}

/// The process's peak resident set (`VmHWM`), in bytes; `None` where `/proc` does not tell.
pub fn peak_rss() -> Option<usize> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: usize = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

// ---- Panics: where they happened, without a backtrace per input. -------------------------------

thread_local! {
    /// Set by the panic hook on fuzz worker threads: the last panic's `file:line:col: message`.
    static LAST_PANIC: std::cell::RefCell<Option<String>> = const { std::cell::RefCell::new(None) };
}

/// Installs (once) a panic hook that, on fuzz worker threads, notes where a panic happened and
/// stays silent (thousands of caught panics would each print a backtrace otherwise); elsewhere
/// it defers to the previous hook.
fn install_panic_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let on_worker = std::thread::current()
                .name()
                .is_some_and(|n| n.starts_with("fuzz-"));
            if !on_worker {
                return previous(info);
            }
            let location = info
                .location()
                .map_or("unknown location".to_string(), |l| l.to_string());
            let _ = LAST_PANIC.try_with(|p| {
                *p.borrow_mut() = Some(format!("{location}: {}", payload_text(info.payload())))
            });
        }));
    });
}

fn payload_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(non-string panic payload)".into())
}

/// How `check` fails on `input`, if it does: `panic at file:line:col: message` (the signature
/// two inputs share when they hit the same bug) or `broken property: …`.
fn failure<C>(check: &C, i: usize, input: &[u8]) -> (Option<Verdict>, Option<String>)
where
    C: Fn(usize, &[u8]) -> Result<Verdict, String>,
{
    let _ = LAST_PANIC.try_with(|p| p.borrow_mut().take());
    match catch_unwind(AssertUnwindSafe(|| check(i, input))) {
        Ok(Ok(v)) => (Some(v), None),
        Ok(Err(broken)) => (None, Some(format!("broken property: {broken}"))),
        Err(payload) => {
            let noted = LAST_PANIC
                .try_with(|p| p.borrow_mut().take())
                .ok()
                .flatten();
            let at = noted.unwrap_or_else(|| payload_text(&*payload));
            (None, Some(format!("panic at {at}")))
        }
    }
}

// ---- The run. ----------------------------------------------------------------------------------

/// What a check made of one input.
pub enum Verdict {
    /// The parser accepted it and the result is valid.
    Valid,
    /// The parser refused it with a typed error, of this kind (a variant name).
    Error(&'static str),
}

/// Bounds one run is held to.
#[derive(Copy, Clone)]
pub struct Bounds {
    /// Inputs tried.
    pub inputs: usize,
    /// The longest one input may take.
    pub per_input: Duration,
    /// An input still running after this is a hang: the run fails at once, naming it.
    pub hang: Duration,
    /// The most memory one input may hold.
    pub per_input_memory: usize,
}

/// The test process's peak resident set (every format of a test binary runs in one process).
pub const PEAK_RSS: usize = 512 * MIB;

impl Bounds {
    /// What both fuzz tests hold every format to: at least 25,000 inputs (`VRRT_FUZZ_INPUTS=N`
    /// asks for more, for a soak), 2 s per input (debug build, a loaded 2-core machine), a hang
    /// after 20 s, 8 MiB held by one input.
    pub fn standard() -> Bounds {
        const INPUTS: usize = 25_000;
        let inputs = std::env::var("VRRT_FUZZ_INPUTS")
            .ok()
            .and_then(|v| v.parse().ok())
            .map_or(INPUTS, |n: usize| n.max(INPUTS));
        Bounds {
            inputs,
            per_input: Duration::from_secs(2),
            hang: Duration::from_secs(20),
            per_input_memory: 8 * MIB,
        }
    }
}

/// One bug: the inputs that failed the same way (same panic location, or a broken property).
pub struct Failure {
    /// `panic at file:line:col: message` or `broken property: …`.
    pub signature: String,
    /// Inputs that failed this way.
    pub count: usize,
    /// The first of them: its index and bytes.
    pub first: (usize, Vec<u8>),
    /// That input shrunk by deleting bytes while it still fails the same way.
    pub minimized: Vec<u8>,
}

/// Distinct failures minimized and reported (the rest are counted).
const REPORTED_FAILURES: usize = 4;

/// What a run saw.
pub struct Report {
    pub name: String,
    pub inputs: usize,
    pub panics: usize,
    pub errors: usize,
    pub valid: usize,
    /// Typed errors by kind.
    pub kinds: BTreeMap<&'static str, usize>,
    /// Inputs whose result broke a property (an invalid `Ok`, an unhelpful error).
    pub broken: usize,
    /// Distinct failures, in the order first seen.
    pub failures: Vec<Failure>,
    /// Panics the parser caught itself (giving a typed error), by location and message.
    pub caught: BTreeMap<String, usize>,
    pub slowest: (usize, Duration),
    pub most_memory: (usize, usize),
    pub elapsed: Duration,
}

impl Report {
    /// The summary line: `fuzz <format>: N inputs, P panics, E typed errors, V valid, peak RSS M
    /// MiB, T s`, then the largest memory one input held and the slowest input.
    pub fn summary(&self) -> String {
        let rss = peak_rss().map_or("n/a".to_string(), |b| {
            format!("{:.1}", b as f64 / MIB as f64)
        });
        format!(
            "fuzz {}: {} inputs, {} panics, {} typed errors, {} valid, peak RSS {rss} MiB, {:.2} s \
             (largest per-input memory {:.1} KiB, input {}; slowest input {:.1} ms, input {})",
            self.name,
            self.inputs,
            self.panics,
            self.errors,
            self.valid,
            self.elapsed.as_secs_f64(),
            self.most_memory.1 as f64 / 1024.0,
            self.most_memory.0,
            self.slowest.1.as_secs_f64() * 1e3,
            self.slowest.0,
        )
    }

    /// The typed errors by kind, one line; then, if any, one line per location of a panic the
    /// parser caught itself.
    pub fn kinds_line(&self) -> String {
        let mut s = format!("fuzz {} errors:", self.name);
        for (k, n) in &self.kinds {
            let _ = write!(s, " {k} {n},");
        }
        s.pop();
        for (at, n) in &self.caught {
            let _ = write!(
                s,
                "\nfuzz {} panics caught by the parser: {n} at {at}",
                self.name
            );
        }
        s
    }

    /// Prints the summary and the error kinds, then asserts the run clean
    /// ([`Report::assert_clean`]) and the process's peak RSS under [`PEAK_RSS`].
    pub fn finish(&self, bounds: &Bounds, inputs: &Inputs) {
        println!("{}", self.summary());
        println!("{}", self.kinds_line());
        self.assert_clean(bounds, inputs);
        if let Some(rss) = peak_rss() {
            assert!(rss < PEAK_RSS, "peak RSS {} MiB", rss / MIB);
        }
    }

    /// Panics unless the run held every bound: no panic, no broken property, no slow input, no
    /// input holding too much memory. A failure names each distinct bug with its first input and
    /// that input minimized, escaped and in hex.
    pub fn assert_clean(&self, bounds: &Bounds, inputs: &Inputs) {
        if !self.failures.is_empty() {
            let mut msg = format!(
                "fuzz {}: {} panics and {} broken properties in {} inputs, {} distinct:",
                self.name,
                self.panics,
                self.broken,
                self.inputs,
                self.failures.len()
            );
            for f in &self.failures {
                let _ = write!(
                    msg,
                    "\n\n{} ({} inputs)\nfirst: input {} ({} bytes): b\"{}\"\nminimized ({} \
                     bytes): b\"{}\"\nminimized (hex): {}",
                    f.signature,
                    f.count,
                    f.first.0,
                    f.first.1.len(),
                    f.first.1.escape_ascii(),
                    f.minimized.len(),
                    f.minimized.escape_ascii(),
                    hex(&f.minimized),
                );
            }
            panic!("{msg}");
        }
        let (i, t) = self.slowest;
        assert!(
            t <= bounds.per_input,
            "fuzz {}: input {i} took {t:?} (bound {:?}): b\"{}\"",
            self.name,
            bounds.per_input,
            inputs(i).escape_ascii()
        );
        let (i, m) = self.most_memory;
        assert!(
            m <= bounds.per_input_memory,
            "fuzz {}: input {i} held {m} bytes (bound {}): b\"{}\"",
            self.name,
            bounds.per_input_memory,
            inputs(i).escape_ascii()
        );
        assert!(self.inputs >= bounds.inputs);
        assert_eq!(
            self.panics + self.broken + self.errors + self.valid,
            self.inputs
        );
    }
}

/// Shrinks a failing input by deleting ever smaller chunks while it still fails with the same
/// signature; at most a few thousand tries.
fn minimize<C>(i: usize, input: &[u8], signature: &str, check: &C) -> Vec<u8>
where
    C: Fn(usize, &[u8]) -> Result<Verdict, String>,
{
    // A broken property's message holds details of the input: keep only its kind.
    let key = |s: &str| {
        if s.starts_with("panic") {
            s.to_string()
        } else {
            s.split(':').take(2).collect::<Vec<_>>().join(":")
        }
    };
    let want = key(signature);
    let mut best = input.to_vec();
    let mut tries = 0;
    let mut chunk = (best.len() / 2).max(1);
    loop {
        let mut at = 0;
        while at < best.len() && tries < 4000 {
            let mut candidate = best.clone();
            candidate.drain(at..(at + chunk).min(best.len()));
            tries += 1;
            match failure(check, i, &candidate).1 {
                Some(s) if key(&s) == want => best = candidate,
                _ => at += chunk,
            }
        }
        if chunk == 1 || tries >= 4000 {
            return best;
        }
        chunk /= 2;
    }
}

pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().fold(String::new(), |mut s, b| {
        let _ = write!(s, "{b:02x}");
        s
    })
}

impl Report {
    /// An empty report of the run `name`.
    fn new(name: String) -> Self {
        Report {
            name,
            inputs: 0,
            panics: 0,
            errors: 0,
            valid: 0,
            kinds: BTreeMap::new(),
            broken: 0,
            failures: Vec::new(),
            caught: BTreeMap::new(),
            slowest: (0, Duration::ZERO),
            most_memory: (0, 0),
            elapsed: Duration::ZERO,
        }
    }

    /// Counts input `i`'s outcome: its verdict, or the failure's signature (broken properties
    /// are one bug per kind of message, before the details; panics one per location).
    fn record(&mut self, i: usize, input: &[u8], verdict: Option<Verdict>, fail: Option<String>) {
        match (verdict, fail) {
            (Some(Verdict::Valid), _) => self.valid += 1,
            (Some(Verdict::Error(kind)), _) => {
                self.errors += 1;
                *self.kinds.entry(kind).or_default() += 1;
            }
            (None, Some(signature)) => {
                if signature.starts_with("panic") {
                    self.panics += 1;
                } else {
                    self.broken += 1;
                }
                // Broken properties are one bug per kind of message (before the
                // details); panics one per location.
                let key = |s: &str| s.split(':').take(2).collect::<String>();
                match self.failures.iter_mut().find(|f| {
                    if signature.starts_with("panic") {
                        f.signature == signature
                    } else {
                        key(&f.signature) == key(&signature)
                    }
                }) {
                    Some(f) => f.count += 1,
                    None => self.failures.push(Failure {
                        signature,
                        count: 1,
                        first: (i, input.to_vec()),
                        minimized: Vec::new(),
                    }),
                }
            }
            (None, None) => unreachable!(),
        }
    }
}

/// Runs `check(i, input)` on inputs `0..bounds.inputs` on a worker thread, each under
/// `catch_unwind`, timed and measured (`i` may pick the form the input is tried in; minimizing
/// keeps it). `check` returns the verdict, or `Err` for a broken property. The calling
/// thread watches: an input running past `bounds.hang` fails the run at once with that input
/// (the worker is left behind; the test process ends without it).
pub fn run<C>(name: &str, inputs: Inputs, bounds: Bounds, check: C) -> Report
where
    C: Fn(usize, &[u8]) -> Result<Verdict, String> + Send + 'static,
{
    install_panic_hook();
    let current = Arc::new(AtomicUsize::new(0));
    let started_ns = Arc::new(AtomicU64::new(0));
    let done = Arc::new(AtomicBool::new(false));
    let epoch = Instant::now();
    let worker = {
        let (current, started_ns, done, inputs) = (
            current.clone(),
            started_ns.clone(),
            done.clone(),
            inputs.clone(),
        );
        let name = name.to_string();
        std::thread::Builder::new()
            .name(format!("fuzz-{name}"))
            .spawn(move || {
                let mut r = Report::new(name);
                let start = Instant::now();
                for i in 0..bounds.inputs {
                    let input = inputs(i);
                    current.store(i, Ordering::SeqCst);
                    started_ns.store(epoch.elapsed().as_nanos() as u64, Ordering::SeqCst);
                    let t = Instant::now();
                    let ((verdict, fail), memory) = peak_memory(|| failure(&check, i, &input));
                    let took = t.elapsed();
                    if took > r.slowest.1 {
                        r.slowest = (i, took);
                    }
                    if memory > r.most_memory.1 {
                        r.most_memory = (i, memory);
                    }
                    r.inputs += 1;
                    // A panic the parser caught itself (and turned into an error) is no failure,
                    // but is counted: the hook saw it.
                    if verdict.is_some() {
                        if let Some(at) = LAST_PANIC.with(|p| p.borrow_mut().take()) {
                            *r.caught.entry(at).or_default() += 1;
                        }
                    }
                    r.record(i, &input, verdict, fail);
                }
                r.elapsed = start.elapsed();
                // Minimizing is not a hang.
                started_ns.store(0, Ordering::SeqCst);
                for f in r.failures.iter_mut().take(REPORTED_FAILURES) {
                    f.minimized = minimize(f.first.0, &f.first.1, &f.signature, &check);
                }
                done.store(true, Ordering::SeqCst);
                r
            })
            .expect("spawn the fuzz worker")
    };
    while !done.load(Ordering::SeqCst) && !worker.is_finished() {
        std::thread::sleep(Duration::from_millis(10));
        let i = current.load(Ordering::SeqCst);
        let since =
            (epoch.elapsed().as_nanos() as u64).saturating_sub(started_ns.load(Ordering::SeqCst));
        // Only a stamp that stayed put while the index did is a hang (the worker may have moved
        // on between the loads).
        if started_ns.load(Ordering::SeqCst) != 0
            && Duration::from_nanos(since) > bounds.hang
            && current.load(Ordering::SeqCst) == i
        {
            let input = inputs(i);
            panic!(
                "fuzz {name}: input {i} still runs after {:?} (a hang); input (escaped): \
                 b\"{}\"\ninput (hex): {}",
                bounds.hang,
                input.escape_ascii(),
                hex(&input)
            );
        }
    }
    match worker.join() {
        Ok(r) => r,
        Err(_) => panic!("fuzz {name}: the worker itself panicked"),
    }
}
