//! A small deterministic fuzzer for stable Rust, shared by the parser fuzz tests of
//! monohand-io, monohand-eval and monohand-vision (included with `#[path]`).
//!
//! Each case takes a seed (a real file or a writer's output), applies one to four mutations
//! and calls the parser under `catch_unwind`. A case fails when the parser panics, takes
//! longer than [`SLOW_CASE`], or asks the allocator for more than [`ALLOC_LIMIT`] bytes in
//! one request (a forged size). Failing inputs are written to
//! `$TMPDIR/monohand-fuzz-failures/` so they can be turned into regression tests.
//!
//! Environment:
//! - `MONOHAND_FUZZ_CASES`: cases per parser (default: each test's small CI number);
//! - `MONOHAND_FUZZ_SEED`: the RNG seed (default 1), to explore other inputs in a long run.
//!
//! Mutations: for text, bit flips, insertion of syntax tokens and extreme numbers (0, -1,
//! 1e308, NaN, 2^64, ...), deletion and duplication of ranges (repeated up to 64 times),
//! truncation, splicing two seeds, deep nesting of brackets/indentation, and for JSON a
//! tree-level mutation (replace a value by an extreme number or another type, remove or
//! duplicate keys and array elements). For binary formats, aligned u32/u16/u8 fields
//! (lengths, offsets, dimensions, indices) are overwritten with boundary values, bytes are
//! inserted/deleted in 4- and 8-byte steps, and files are truncated or spliced; the caller
//! can restrict positions to the structural regions of a file (not its weights).
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Largest single allocation a parser may request for one fuzz case.
pub const ALLOC_LIMIT: usize = 256 << 20;
/// Requests above this are refused outright (the process would abort): found as a bug too.
const ALLOC_REFUSE: usize = 4 << 30;
/// A case slower than this is reported (a hang or a quadratic blow-up).
pub const SLOW_CASE: Duration = Duration::from_secs(5);

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
    static IN_CASE: Cell<bool> = const { Cell::new(false) };
}

/// Global allocator that remembers, per thread, the largest request of the current case.
pub struct TrackingAlloc;

// SAFETY: every allocation and deallocation is `System`'s, called with the caller's own
// arguments (which meet `GlobalAlloc`'s requirements), so `System`'s guarantees hold; a
// refused request returns null, which `GlobalAlloc` allows for a failed allocation. `note`
// neither allocates nor panics (a `const`-initialised thread-local `Cell`, reached with
// `try_with`), so the allocator never unwinds nor calls itself.
unsafe impl GlobalAlloc for TrackingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        if layout.size() > ALLOC_REFUSE {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's `layout` (non-zero size, as `GlobalAlloc::alloc` requires).
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        if layout.size() > ALLOC_REFUSE {
            return std::ptr::null_mut();
        }
        // SAFETY: as in `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was allocated by this allocator, that is by `System`, with `layout`
        // (the caller's guarantee).
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        if new_size > ALLOC_REFUSE {
            return std::ptr::null_mut();
        }
        // SAFETY: `ptr` was allocated by `System` with `layout`, and `new_size` is non-zero
        // and valid for `layout`'s alignment (the caller's guarantees).
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

fn note(size: usize) {
    let _ = LARGEST.try_with(|l| {
        if size > l.get() {
            l.set(size);
        }
    });
}

/// SplitMix64: small, fast, deterministic.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed ^ 0x9e37_79b9_7f4a_7c15)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }
    pub fn chance(&mut self, percent: u64) -> bool {
        self.next_u64() % 100 < percent
    }
    pub fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len())]
    }
}

/// Cases per parser: `MONOHAND_FUZZ_CASES` or the test's default.
pub fn cases(default: usize) -> usize {
    match std::env::var("MONOHAND_FUZZ_CASES") {
        Ok(s) => s
            .trim()
            .parse()
            .unwrap_or_else(|_| panic!("MONOHAND_FUZZ_CASES={s:?} is not a number")),
        Err(_) => default,
    }
}

fn base_seed() -> u64 {
    match std::env::var("MONOHAND_FUZZ_SEED") {
        Ok(s) => s
            .trim()
            .parse()
            .unwrap_or_else(|_| panic!("MONOHAND_FUZZ_SEED={s:?} is not a number")),
        Err(_) => 1,
    }
}

fn name_hash(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    })
}

/// Reads a seed file; a missing one fails the test (the seeds are part of the harness).
pub fn seed_file(path: impl Into<PathBuf>) -> Vec<u8> {
    let path = path.into();
    std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "fuzz seed {} is missing ({e}); the fuzz tests need ../shared beside the repository \
             and the MediaPipe models",
            path.display()
        )
    })
}

/// `../shared/data/<rel>` seen from a crate directory.
pub fn shared(manifest_dir: &str, rel: &str) -> Vec<u8> {
    seed_file(
        PathBuf::from(manifest_dir)
            .join("../../../shared/data")
            .join(rel),
    )
}

/// What one fuzz run did.
#[derive(Debug)]
pub struct Summary {
    pub name: String,
    pub cases: usize,
    pub rejected: usize,
    pub accepted: usize,
    pub slowest: Duration,
    pub largest_alloc: usize,
}

/// Outcome of one parser call: its error, if it refused the input.
pub trait Outcome {
    fn error(&self) -> Option<String>;
}
impl<T, E: std::fmt::Debug> Outcome for Result<T, E> {
    fn error(&self) -> Option<String> {
        self.as_ref().err().map(|e| format!("{e:?}"))
    }
}

fn install_quiet_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            // Panics inside a fuzz case are collected and reported at the end.
            if !IN_CASE.with(|c| c.get()) {
                default(info);
            }
        }));
    });
}

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "(non-string panic payload)".to_string()
    }
}

fn save_failure(name: &str, case: usize, input: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join("monohand-fuzz-failures");
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join(format!("{name}-{case}.bin"));
    let _ = std::fs::write(&path, input);
    path
}

/// Runs `target` on one input: what went wrong with the run (a panic, a too large
/// allocation, too slow), the error it returned, its time and its largest allocation.
fn one_case<R: Outcome>(
    target: &mut impl FnMut(&[u8]) -> R,
    input: &[u8],
) -> (Option<String>, Option<String>, Duration, usize) {
    LARGEST.with(|l| l.set(0));
    IN_CASE.with(|c| c.set(true));
    let t0 = Instant::now();
    let result = catch_unwind(AssertUnwindSafe(|| target(input)));
    let dt = t0.elapsed();
    IN_CASE.with(|c| c.set(false));
    let largest = LARGEST.with(|l| l.get());
    let problem = match &result {
        Err(p) => Some(format!("panicked: {}", panic_message(p.as_ref()))),
        Ok(_) if largest > ALLOC_LIMIT => Some(format!(
            "allocated {largest} bytes in one request (limit {ALLOC_LIMIT})"
        )),
        Ok(_) if dt > SLOW_CASE => Some(format!("took {dt:?}")),
        Ok(_) => None,
    };
    let error = match &result {
        Ok(r) => r.error(),
        Err(_) => Some("panic".to_string()),
    };
    (problem, error, dt, largest)
}

/// Runs every seed unmutated (at least one must be accepted), then `cases` mutated inputs through `target`; panics with the
/// list of failing cases (and where their inputs were saved) if any failed.
pub fn run<R: Outcome>(
    name: &str,
    seeds: &[Vec<u8>],
    cases: usize,
    mut mutate: impl FnMut(&mut Rng, &[Vec<u8>]) -> Vec<u8>,
    mut target: impl FnMut(&[u8]) -> R,
) -> Summary {
    assert!(!seeds.is_empty(), "{name}: no seeds");
    install_quiet_hook();
    let mut rng = Rng::new(base_seed() ^ name_hash(name));
    let mut failures: Vec<String> = Vec::new();
    let mut summary = Summary {
        name: name.to_string(),
        cases: 0,
        rejected: 0,
        accepted: 0,
        slowest: Duration::ZERO,
        largest_alloc: 0,
    };
    let start = Instant::now();
    let mut slowest = (0, 0);
    let mut refused_seeds = 0;
    for case in 0..seeds.len() + cases {
        let input = if case < seeds.len() {
            seeds[case].clone()
        } else {
            mutate(&mut rng, seeds)
        };
        let (problem, error, dt, largest) = one_case(&mut target, &input);
        if dt > summary.slowest {
            summary.slowest = dt;
            slowest = (case, input.len());
        }
        summary.largest_alloc = summary.largest_alloc.max(largest);
        if case < seeds.len() {
            if let Some(e) = &error {
                // Some seeds are refused on purpose (valid syntax, not a calibration...).
                println!("fuzz {name}: seed {case} is refused: {e}");
                refused_seeds += 1;
            }
            // A harness whose seeds are all refused explores error paths only.
            assert!(
                case + 1 < seeds.len() || refused_seeds < seeds.len(),
                "fuzz {name}: every seed is refused"
            );
        }
        match error {
            None => summary.accepted += 1,
            Some(_) => summary.rejected += 1,
        }
        summary.cases += 1;
        if let Some(problem) = problem {
            let path = save_failure(name, case, &input);
            failures.push(format!("case {case} {problem} (input: {})", path.display()));
        }
    }
    println!(
        "fuzz {name}: {} inputs ({} seeds + {} mutated), {} accepted, {} rejected with an error, \
         slowest {:?} (case {}, {} bytes), largest allocation {} bytes, {:.1} s",
        summary.cases,
        seeds.len(),
        cases,
        summary.accepted,
        summary.rejected,
        summary.slowest,
        slowest.0,
        slowest.1,
        summary.largest_alloc,
        start.elapsed().as_secs_f64()
    );
    assert!(
        failures.is_empty(),
        "fuzz {name}: {} failing inputs:\n{}",
        failures.len(),
        failures
            .iter()
            .take(20)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
    summary
}

// ------------------------------------------------------------------ text mutations

const TOKENS: &[&str] = &[
    "{",
    "}",
    "[",
    "]",
    "\"",
    ":",
    ",",
    "\n",
    " ",
    "-",
    ".",
    "e",
    "0",
    "null",
    "true",
    "false",
    "\"\":",
    "\t",
    "<",
    ">",
    "</",
    "/>",
    "<_>",
    "</_>",
    "!!opencv-matrix",
    "&amp;",
    "&#",
    "&",
    "%YAML:1.0\n",
    "<?xml version=\"1.0\"?>",
    "- ",
    "\r",
    "\u{feff}",
    "é",
    "\u{10ffff}",
    "#",
    "'",
    "\\",
    "\\u0000",
    "\\ud800",
    "---\n",
    "<!--",
    "-->",
    "rows",
    "cols",
    "data",
    "dt",
    "type_id=\"opencv-matrix\"",
    "   ",
    "\0",
];

/// Extreme and boundary numbers, as text.
pub const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "3",
    "20",
    "21",
    "22",
    "0.5",
    "1e308",
    "-1e308",
    "1e400",
    "5e-324",
    "NaN",
    ".Nan",
    "Infinity",
    "-Infinity",
    ".Inf",
    "-.Inf",
    "nan",
    "inf",
    "18446744073709551615",
    "18446744073709551616",
    "-9223372036854775808",
    "4294967295",
    "4294967296",
    "2147483647",
    "2147483648",
    "-2147483648",
    "999999999999999999999999",
    "1e15",
    "65536",
    "1/0",
    "0/0",
    "30000/1001",
    "-30/1",
];

fn is_num_byte(b: u8) -> bool {
    b.is_ascii_digit() || b == b'.' || b == b'-' || b == b'+' || b == b'e' || b == b'E'
}

/// Byte ranges of number-like tokens (digit runs with their sign, dot and exponent).
fn number_spans(t: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < t.len() {
        if t[i].is_ascii_digit() {
            let mut s = i;
            while s > 0 && is_num_byte(t[s - 1]) {
                s -= 1;
            }
            let mut e = i;
            while e < t.len() && is_num_byte(t[e]) {
                e += 1;
            }
            spans.push((s, e));
            i = e;
        } else {
            i += 1;
        }
    }
    spans
}

fn nesting(rng: &mut Rng) -> Vec<u8> {
    let n = 50 + rng.below(20_000);
    // Indented YAML grows as the square of its depth: usually a few hundred levels, now and
    // then thousands (enough to overflow a stack without a depth limit).
    let levels = if rng.chance(10) {
        n.min(2500)
    } else {
        n.min(300)
    };
    match rng.below(5) {
        0 => "[".repeat(n).into_bytes(),
        1 => "{\"a\":".repeat(n).into_bytes(),
        2 => "<a>".repeat(n).into_bytes(),
        3 => {
            // YAML maps nested by indentation.
            let mut s = String::from("\n");
            for k in 0..levels {
                s.push_str(&" ".repeat(k));
                s.push_str("k:\n");
            }
            s.into_bytes()
        }
        _ => {
            let mut s = String::from("\n");
            for k in 0..levels {
                s.push_str(&" ".repeat(2 * k));
                s.push_str("- a:\n");
            }
            s.into_bytes()
        }
    }
}

/// One byte-level mutation of text.
pub fn mutate_text_once(rng: &mut Rng, t: &mut Vec<u8>, seeds: &[Vec<u8>]) {
    let len = t.len();
    let pos = rng.below(len + 1);
    match rng.below(13) {
        0 if len > 0 => {
            let i = rng.below(len);
            t[i] ^= 1 << rng.below(8);
        }
        1 | 2 => {
            let tok = rng.pick(TOKENS).as_bytes().to_vec();
            t.splice(pos..pos, tok);
        }
        3 if len > 0 => {
            let n = 1 + rng.below(16.min(len - pos.min(len - 1)));
            let p = pos.min(len - 1);
            t.drain(p..(p + n).min(len));
        }
        4 => t.truncate(pos),
        5 if len > 0 => {
            // Duplicate a range, possibly many times.
            let s = rng.below(len);
            let e = (s + 1 + rng.below(64)).min(len);
            let chunk = t[s..e].to_vec();
            let times = if rng.chance(20) { 1 + rng.below(64) } else { 1 };
            for _ in 0..times {
                t.splice(e..e, chunk.iter().copied());
            }
        }
        6 => {
            // Splice: this input's prefix with another seed's suffix.
            let other = rng.pick(seeds);
            let from = rng.below(other.len() + 1);
            t.truncate(pos);
            t.extend_from_slice(&other[from..]);
        }
        7 | 8 => {
            let spans = number_spans(t);
            if spans.is_empty() {
                t.splice(pos..pos, rng.pick(NUMBERS).bytes());
            } else {
                let (s, e) = *rng.pick(&spans);
                t.splice(s..e, rng.pick(NUMBERS).bytes());
            }
        }
        9 if rng.chance(30) => {
            let nest = nesting(rng);
            t.splice(pos..pos, nest);
        }
        10 if len > 0 => {
            // Remove one structural character.
            let structural: Vec<usize> = (0..len)
                .filter(|&i| b"{}[]\":,<>/\n".contains(&t[i]))
                .collect();
            if !structural.is_empty() {
                t.remove(*rng.pick(&structural));
            }
        }
        11 if len > 0 => {
            // Duplicate a whole line elsewhere (a repeated key or record).
            let lines: Vec<(usize, usize)> = line_spans(t);
            let (s, e) = *rng.pick(&lines);
            let line = t[s..e].to_vec();
            let at = rng.pick(&lines).0;
            t.splice(at..at, line);
        }
        _ if len > 1 => {
            let (a, b) = (rng.below(len), rng.below(len));
            t.swap(a, b);
        }
        _ => t.push(rng.below(256) as u8),
    }
}

fn line_spans(t: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut s = 0;
    for (i, &b) in t.iter().enumerate() {
        if b == b'\n' {
            out.push((s, i + 1));
            s = i + 1;
        }
    }
    if s < t.len() || out.is_empty() {
        out.push((s, t.len()));
    }
    out
}

fn extreme_json(rng: &mut Rng) -> serde_json::Value {
    use serde_json::{json, Value};
    match rng.below(16) {
        0 => json!(0),
        1 => json!(-1),
        2 => json!(1e308),
        3 => json!(-1e308),
        4 => json!(5e-324),
        5 => json!(u64::MAX),
        6 => json!(i64::MIN),
        7 => json!(4294967296u64),
        8 => json!(0.5),
        9 => json!(21),
        10 => Value::Null,
        11 => json!("x"),
        12 => json!([]),
        13 => json!({}),
        14 => json!(true),
        _ => json!(1e15),
    }
}

/// Mutates one node of a JSON tree: a value replaced by an extreme number or another type,
/// a key removed or duplicated under another name, an array element removed or repeated.
fn mutate_json_tree(rng: &mut Rng, v: &mut serde_json::Value) {
    use serde_json::Value;
    // Walk down to a random node (depth is bounded by serde_json's recursion limit).
    let descend = rng.chance(70);
    match v {
        Value::Array(a) if !a.is_empty() && descend => {
            let i = rng.below(a.len());
            return mutate_json_tree(rng, &mut a[i]);
        }
        Value::Object(o) if !o.is_empty() && descend => {
            let keys: Vec<String> = o.keys().cloned().collect();
            let k = rng.pick(&keys).clone();
            return mutate_json_tree(rng, o.get_mut(&k).expect("key present"));
        }
        _ => {}
    }
    match v {
        Value::Array(a) if !a.is_empty() && rng.chance(50) => {
            let i = rng.below(a.len());
            if rng.chance(50) {
                a.remove(i);
            } else {
                let x = a[i].clone();
                for _ in 0..1 + rng.below(3) {
                    a.push(x.clone());
                }
            }
        }
        Value::Object(o) if !o.is_empty() && rng.chance(50) => {
            let keys: Vec<String> = o.keys().cloned().collect();
            let k = rng.pick(&keys).clone();
            if rng.chance(60) {
                o.remove(&k);
            } else {
                let x = o[&k].clone();
                o.insert(format!("{k}_"), x);
            }
        }
        other => *other = extreme_json(rng),
    }
}

/// A mutated copy of a random text seed: one to four byte-level mutations, or (for JSON
/// seeds, one line at a time for JSON Lines) a tree-level mutation.
pub fn mutate_text(rng: &mut Rng, seeds: &[Vec<u8>]) -> Vec<u8> {
    let mut t = rng.pick(seeds).clone();
    if rng.chance(50) {
        // Structure-aware: the whole text, or one of its lines, as a JSON tree.
        let lines = line_spans(&t);
        let (s, e) = if rng.chance(50) {
            (0, t.len())
        } else {
            *rng.pick(&lines)
        };
        if let Ok(mut v) = serde_json::from_slice::<serde_json::Value>(&t[s..e]) {
            for _ in 0..1 + rng.below(3) {
                mutate_json_tree(rng, &mut v);
            }
            let mut out = serde_json::to_vec(&v).expect("serialise");
            if t[s..e].ends_with(b"\n") {
                out.push(b'\n');
            }
            t.splice(s..e, out);
            if rng.chance(60) {
                return t;
            }
        }
    }
    let n = 1 + rng.below(4);
    for _ in 0..n {
        mutate_text_once(rng, &mut t, seeds);
    }
    t
}

// ---------------------------------------------------------------- binary mutations

const U32S: &[u32] = &[
    0,
    1,
    2,
    3,
    4,
    7,
    8,
    16,
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
    0xffff_fffe,
    0xffff_fff8,
    0x4000_0000,
    0x1000_0000,
];

/// Positions a binary mutation may touch: everything, or the given byte ranges.
pub struct Regions(pub Vec<(usize, usize)>);

impl Regions {
    fn pick(&self, rng: &mut Rng, len: usize) -> usize {
        if self.0.is_empty() || rng.chance(5) {
            return rng.below(len.max(1));
        }
        let (s, e) = *rng.pick(&self.0);
        let e = e.min(len);
        if s >= e {
            rng.below(len.max(1))
        } else {
            s + rng.below(e - s)
        }
    }
}

/// One structure-aware mutation of a binary file (little- or big-endian fields).
pub fn mutate_binary_once(rng: &mut Rng, b: &mut Vec<u8>, regions: &Regions, seeds: &[Vec<u8>]) {
    let len = b.len();
    if len < 8 {
        b.push(rng.below(256) as u8);
        return;
    }
    let pos = regions.pick(rng, len);
    match rng.below(10) {
        0..=3 => {
            // An aligned 32-bit field: a length, offset, dimension or index.
            let p = (pos & !3).min(len - 4);
            let old = u32::from_le_bytes(b[p..p + 4].try_into().unwrap());
            let v = match rng.below(4) {
                0 | 1 => *rng.pick(U32S),
                2 => old.wrapping_add((rng.below(17) as u32).wrapping_sub(8)),
                _ => len as u32 - p as u32 + rng.below(16) as u32,
            };
            let bytes = if rng.chance(50) {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            };
            b[p..p + 4].copy_from_slice(&bytes);
        }
        4 => {
            let p = (pos & !1).min(len - 2);
            let v = *rng.pick(&[0u16, 1, 2, 0x7fff, 0x8000, 0xffff, 4, 8]);
            b[p..p + 2].copy_from_slice(&v.to_le_bytes());
        }
        5 => {
            b[pos.min(len - 1)] = *rng.pick(&[0u8, 1, 0x7f, 0x80, 0xff, 14, 15, 6, 9]);
        }
        6 => {
            b[pos.min(len - 1)] ^= 1 << rng.below(8);
        }
        7 => {
            // Insert or delete 4 or 8 bytes (fields shift, offsets go stale).
            let n = if rng.chance(50) { 4 } else { 8 };
            let p = pos & !3;
            if rng.chance(50) && p + n <= len {
                b.drain(p..p + n);
            } else {
                let fill = rng.below(256) as u8;
                b.splice(p.min(len)..p.min(len), std::iter::repeat_n(fill, n));
            }
        }
        8 => b.truncate(rng.below(len)),
        _ => {
            let other = rng.pick(seeds);
            let from = rng.below(other.len() + 1);
            let to = (from + 8 + rng.below(256)).min(other.len());
            let p = pos.min(len);
            b.splice(
                p..(p + (to - from)).min(len),
                other[from..to].iter().copied(),
            );
        }
    }
}

/// A mutated copy of a random binary seed: one to four mutations.
pub fn mutate_binary(rng: &mut Rng, seeds: &[Vec<u8>], regions: &[Regions]) -> Vec<u8> {
    let i = rng.below(seeds.len());
    let mut b = seeds[i].clone();
    let none = Regions(Vec::new());
    let r = regions.get(i).unwrap_or(&none);
    for _ in 0..1 + rng.below(4) {
        mutate_binary_once(rng, &mut b, r, seeds);
    }
    b
}

/// Text of an input (parsers of text get lossy UTF-8, as `read_to_string` would refuse
/// invalid UTF-8 before them anyway).
pub fn text(input: &[u8]) -> String {
    String::from_utf8_lossy(input).into_owned()
}
