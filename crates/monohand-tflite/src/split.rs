//! One operator's output rows shared between the cores.
//!
//! When one network runs alone (one tracked hand, no detector) the other cores would idle.
//! [`NhwcDepthwise`](crate::NhwcDepthwise), [`PointwiseConv`](crate::PointwiseConv) and
//! [`NhwcConv`](crate::NhwcConv) then cut a large output into pieces (rows, or blocks of
//! channels) that the calling thread and the helper threads of a small process-wide team
//! claim one at a time and compute side by side. Each output value is computed by the same
//! instructions as in one piece, so the results are the same bits.
//!
//! The helpers wait for work by spinning for a short while (as XNNPACK's pthreadpool does:
//! an operator follows the last within microseconds, far less than a sleeping thread takes
//! to wake) and then sleep. A network evaluation that holds a [`Running`] counts as in
//! flight; while more than one is, each runs on its own thread and nothing is split (the
//! cores are already shared between them).
//!
//! The team has `MONOHAND_OP_THREADS` threads, else `OMP_NUM_THREADS` (which Ray, for one,
//! sets to a worker's share of the cores), else `min(cores, 4)` (the cores this process may
//! use). The variables are read once; `1` turns the splitting off for the whole process.
//! Where threads are not std's (WebAssembly, whose threads are Web Workers), the embedder
//! starts the team itself with [`start_team`], its helpers on threads of its own.

use std::cell::UnsafeCell;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex, OnceLock, PoisonError};
#[cfg(not(target_arch = "wasm32"))]
use std::time::{Duration, Instant};

use tract_core::internal::*;

/// Multiply-adds below which an operator runs in one piece: handing out the pieces and
/// waiting for them costs a few microseconds, the time of about 10^5 multiply-adds.
pub(crate) const MIN_WORK: usize = 1 << 20;

/// How long an idle helper spins before it sleeps.
#[cfg(not(target_arch = "wasm32"))]
const SPIN: Duration = Duration::from_micros(100);

/// Rounds an idle helper spins before it sleeps where std has no clock (WebAssembly): one
/// round is an atomic load, about a nanosecond, so about `SPIN`'s 100 µs.
#[cfg(target_arch = "wasm32")]
const SPIN_ROUNDS: u32 = 1 << 17;

/// Pieces per thread of the team: claimed one at a time, so a thread held up elsewhere
/// delays the operator by one piece at most.
const PIECES_PER_THREAD: usize = 4;

/// Most threads in the team (caller included) unless `MONOHAND_OP_THREADS` says otherwise.
const MAX_TEAM: usize = 4;

/// Marks one network evaluation in flight while it lives. Operators split their rows only
/// while at most one evaluation is in flight, so that two networks run side by side on two
/// cores (for example two tracked hands) do not also compete for the team's threads.
/// Evaluations without one are not counted.
pub struct Running(&'static Team);

impl Running {
    /// Counts one more evaluation in flight until the value is dropped.
    pub fn start() -> Running {
        Running::on(team())
    }

    fn on(team: &'static Team) -> Running {
        team.in_flight.fetch_add(1, Ordering::Relaxed);
        Running(team)
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.0.in_flight.fetch_sub(1, Ordering::Relaxed);
    }
}

impl std::fmt::Debug for Running {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Running")
    }
}

thread_local! {
    /// Whether evaluations on this thread may split (see [`allow_split_here`]).
    static ALLOWED: std::cell::Cell<bool> = const { std::cell::Cell::new(true) };
}

/// Whether the operators of networks evaluated on this thread may share their rows with the
/// team (default: true). A caller whose other threads are busy turns it off for a while:
/// `monohand run` does while its network thread waits for the video decoder, whose core the
/// team would otherwise take.
pub fn allow_split_here(allowed: bool) {
    ALLOWED.set(allowed);
}

/// The threads (caller included) operators share their rows between in this process.
pub fn team_size() -> usize {
    team().size()
}

/// One piece of work, called with the piece's index.
type Piece<'a> = dyn Fn(usize) + Sync + 'a;

/// The caller and `size - 1` helper threads.
///
/// A job is a number of pieces that the caller and the helpers claim one at a time from a
/// shared counter, so that a helper that is late (asleep, or its core taken by another
/// process) leaves its pieces to the others instead of holding the caller up.
pub(crate) struct Team {
    /// Threads, the caller included (set once the helpers have started).
    size: AtomicUsize,
    /// Network evaluations in flight (see [`Running`]).
    in_flight: AtomicUsize,
    /// Taken by the one caller whose job the team runs.
    busy: AtomicBool,
    /// The current job and its number of pieces; written only by the caller that holds
    /// `busy` while `open` is false, and read by helpers only after they have registered
    /// in `workers` and seen `open` true.
    job: UnsafeCell<Option<(&'static Piece<'static>, usize)>>,
    /// Whether the job may be joined.
    open: AtomicBool,
    /// The next piece to claim.
    next: AtomicUsize,
    /// Helpers registered with the current job (the caller waits for none to be left).
    workers: AtomicUsize,
    /// Incremented (under `sleep`) for each job, to wake the helpers.
    epoch: AtomicUsize,
    /// A helper's piece panicked.
    panicked: AtomicBool,
    /// Helpers asleep, guarded by the mutex with `epoch`'s increments.
    sleep: Mutex<usize>,
    wake: Condvar,
    /// Jobs this team has run (see [`shared_operators`] for the process's total).
    jobs: AtomicUsize,
}

// SAFETY: `job` is written only by the thread that holds `busy`, while `open` is false;
// a helper reads it only after registering in `workers` and then seeing `open` true
// (sequentially consistent), and the caller closes the job and waits until no helper is
// registered before it writes `job` again or returns.
unsafe impl Sync for Team {}

/// The process's team, once started.
static TEAM: OnceLock<&'static Team> = OnceLock::new();

/// Starts the process's team with `size` threads, the caller included, unless it has
/// started already, and returns its size. Each of the `size - 1` helpers is a function that
/// runs for the life of the process; `spawn(index, helper)` starts one on a thread of its
/// own and returns whether it could (the team is then smaller). For embedders whose threads
/// are not std's: in WebAssembly, where `std::thread::spawn` fails, the browser module
/// starts its helpers on threads of its Web Worker pool. Elsewhere the team starts by
/// itself on std threads when an operator first needs it.
pub fn start_team(size: usize, spawn: &dyn Fn(usize, Box<dyn FnOnce() + Send>) -> bool) -> usize {
    TEAM.get_or_init(|| Team::start_with(size.max(1), spawn))
        .size()
}

/// Starts a helper on a std thread named `monohand-op-INDEX`.
fn std_thread(index: usize, helper: Box<dyn FnOnce() + Send>) -> bool {
    std::thread::Builder::new()
        .name(format!("monohand-op-{index}"))
        .spawn(helper)
        .is_ok()
}

/// The process's team. (In this crate's unit tests: the team the test thread gave itself
/// with [`testing::with_own_team`], else one of three threads, so that the operators'
/// tests split whatever the machine.)
pub(crate) fn team() -> &'static Team {
    #[cfg(test)]
    if let Some(own) = testing::OWN_TEAM.get() {
        return own;
    }
    TEAM.get_or_init(|| {
        if cfg!(test) {
            return Team::start(3);
        }
        let size = ["MONOHAND_OP_THREADS", "OMP_NUM_THREADS"]
            .iter()
            .find_map(|name| std::env::var(name).ok()?.trim().parse::<usize>().ok())
            .unwrap_or_else(|| {
                std::thread::available_parallelism()
                    .map_or(1, |n| n.get())
                    .min(MAX_TEAM)
            })
            .max(1);
        Team::start(size)
    })
}

impl Team {
    /// A team of up to `size` threads (fewer if a helper cannot be started), its helpers on
    /// std threads, for the life of the process.
    fn start(size: usize) -> &'static Team {
        Team::start_with(size, &std_thread)
    }

    /// [`Team::start`] with the helpers started by `spawn` (see [`start_team`]).
    fn start_with(
        size: usize,
        spawn: &dyn Fn(usize, Box<dyn FnOnce() + Send>) -> bool,
    ) -> &'static Team {
        let team: &'static Team = Box::leak(Box::new(Team {
            size: AtomicUsize::new(1),
            in_flight: AtomicUsize::new(0),
            busy: AtomicBool::new(false),
            job: UnsafeCell::new(None),
            open: AtomicBool::new(false),
            next: AtomicUsize::new(0),
            workers: AtomicUsize::new(0),
            epoch: AtomicUsize::new(0),
            panicked: AtomicBool::new(false),
            sleep: Mutex::new(0),
            wake: Condvar::new(),
            jobs: AtomicUsize::new(0),
        }));
        let mut started = 1;
        for index in 1..size {
            if !spawn(index, Box::new(move || team.help())) {
                break;
            }
            started += 1;
        }
        team.size.store(started, Ordering::Relaxed);
        team
    }

    fn size(&self) -> usize {
        self.size.load(Ordering::Relaxed)
    }

    /// A helper's life: wait for a job, claim its pieces while any are left, repeat.
    fn help(&self) {
        let mut seen = 0;
        loop {
            seen = self.next_epoch(seen);
            self.workers.fetch_add(1, Ordering::SeqCst);
            if self.open.load(Ordering::SeqCst) {
                // SAFETY: registered and the job open (see `Team`'s `Sync`).
                if let Some((job, count)) = unsafe { *self.job.get() } {
                    if catch_unwind(AssertUnwindSafe(|| self.claim(job, count))).is_err() {
                        self.panicked.store(true, Ordering::Relaxed);
                    }
                }
            }
            self.workers.fetch_sub(1, Ordering::SeqCst);
        }
    }

    /// Runs pieces of `job` while any are unclaimed.
    fn claim(&self, job: &Piece<'_>, count: usize) {
        loop {
            let i = self.next.fetch_add(1, Ordering::Relaxed);
            if i >= count {
                return;
            }
            job(i);
        }
    }

    /// Waits until `epoch` differs from `seen` and returns it: spinning for `SPIN`, then
    /// asleep. (In WebAssembly, which has no clock for std, for `SPIN_ROUNDS` rounds.)
    fn next_epoch(&self, seen: usize) -> usize {
        #[cfg(not(target_arch = "wasm32"))]
        let start = Instant::now();
        let mut spins = 0u32;
        loop {
            let e = self.epoch.load(Ordering::Acquire);
            if e != seen {
                return e;
            }
            std::hint::spin_loop();
            spins = spins.wrapping_add(1);
            if spins.is_multiple_of(128) {
                #[cfg(not(target_arch = "wasm32"))]
                if start.elapsed() > SPIN {
                    break;
                }
                #[cfg(target_arch = "wasm32")]
                if spins >= SPIN_ROUNDS {
                    break;
                }
                // Another thread that wants this core (the video decoder) gets it.
                std::thread::yield_now();
            }
        }
        let mut asleep = self.sleep.lock().unwrap_or_else(PoisonError::into_inner);
        loop {
            let e = self.epoch.load(Ordering::Acquire);
            if e != seen {
                return e;
            }
            *asleep += 1;
            asleep = self
                .wake
                .wait(asleep)
                .unwrap_or_else(PoisonError::into_inner);
            *asleep -= 1;
        }
    }

    /// Runs `piece(0..count)`, the pieces claimed by this thread and the helpers, and
    /// returns when all are done; `false` (nothing run) if the team is taken.
    fn run(&self, piece: &Piece<'_>, count: usize) -> bool {
        if self.size() < 2
            || self
                .busy
                .compare_exchange(false, true, Ordering::Acquire, Ordering::Relaxed)
                .is_err()
        {
            return false;
        }
        // SAFETY: the lifetime is extended only while helpers may call it: the job is
        // closed and no helper is registered before this function returns.
        let job: &'static Piece<'static> = unsafe { std::mem::transmute(piece) };
        // SAFETY: `busy` is held and the job closed (see `Team`'s `Sync`).
        unsafe { *self.job.get() = Some((job, count)) };
        self.next.store(0, Ordering::Relaxed);
        self.open.store(true, Ordering::SeqCst);
        {
            let asleep = self.sleep.lock().unwrap_or_else(PoisonError::into_inner);
            self.epoch.fetch_add(1, Ordering::Release);
            if *asleep > 0 {
                self.wake.notify_all();
            }
        }
        SPLITS.fetch_add(1, Ordering::Relaxed);
        self.jobs.fetch_add(1, Ordering::Relaxed);
        let mine = catch_unwind(AssertUnwindSafe(|| self.claim(piece, count)));
        self.open.store(false, Ordering::SeqCst);
        let mut spins = 0u32;
        while self.workers.load(Ordering::SeqCst) != 0 {
            // A registered helper is finishing its last piece (or was stopped between
            // registering and claiming).
            std::hint::spin_loop();
            spins = spins.wrapping_add(1);
            if spins.is_multiple_of(1024) {
                std::thread::yield_now();
            }
        }
        // SAFETY: closed, and no helper registered.
        unsafe { *self.job.get() = None };
        let helper_panicked = self.panicked.swap(false, Ordering::Relaxed);
        self.busy.store(false, Ordering::Release);
        if let Err(p) = mine {
            std::panic::resume_unwind(p);
        }
        if helper_panicked {
            panic!("an operator's piece panicked on a helper thread");
        }
        true
    }
}

/// Operators the teams have shared between threads (see [`shared_operators`]).
static SPLITS: AtomicUsize = AtomicUsize::new(0);

/// How many operator evaluations this process has shared between threads so far (to check
/// that it happens, or how often).
pub fn shared_operators() -> usize {
    SPLITS.load(Ordering::Relaxed)
}

/// The first row of piece `i` of `n` over `rows` rows, at a multiple of `unit`.
fn cut(rows: usize, unit: usize, i: usize, n: usize) -> usize {
    ((rows * i / n).div_ceil(unit) * unit).min(rows)
}

/// A pointer to an output that may cross to the helpers, which write disjoint parts.
pub(crate) struct Out<T = f32>(pub(crate) *mut T);
// SAFETY: each piece writes its own part only (see `rows` and the operators' pieces); the
// values are plain numbers (f32 or u8 codes), sent between threads by value.
unsafe impl<T: Send> Sync for Out<T> {}

impl<T> Out<T> {
    /// The output's first value.
    pub(crate) fn ptr(&self) -> *mut T {
        self.0
    }

    /// `len` values from `offset` on.
    ///
    /// # Safety
    /// `offset + len` values from the output's first are within the output, which is still
    /// alive and valid for writes; and nothing else reads or writes those values while the
    /// returned slice is in use (no other live reference overlaps them), which must end
    /// before the output's own borrow does (the slice's lifetime is not tied to it).
    #[allow(clippy::mut_from_ref)]
    unsafe fn slice(&self, offset: usize, len: usize) -> &mut [T] {
        // SAFETY: the caller's contract.
        unsafe { std::slice::from_raw_parts_mut(self.0.add(offset), len) }
    }
}

impl Team {
    /// Calls `f` on pieces `[a, b)` of `0..total` that together cover it, cut at multiples
    /// of `unit`. With `enabled`, `work` (the operator's multiply-adds) at least
    /// [`MIN_WORK`], at most one [`Running`] evaluation in flight, splitting allowed on this
    /// thread ([`allow_split_here`]) and the team free, the team's threads claim the pieces;
    /// otherwise `f(0..total)` runs on this thread. The first error is returned.
    pub(crate) fn pieces<F>(
        &self,
        total: usize,
        unit: usize,
        work: usize,
        enabled: bool,
        f: &F,
    ) -> TractResult<()>
    where
        F: Fn(std::ops::Range<usize>) -> TractResult<()> + Sync,
    {
        let n = self.size() * PIECES_PER_THREAD;
        if !enabled
            || !ALLOWED.get()
            || work < MIN_WORK
            || self.size() < 2
            || total <= unit
            || self.in_flight.load(Ordering::Relaxed) > 1
        {
            return f(0..total);
        }
        let error: Mutex<Option<TractError>> = Mutex::new(None);
        let piece = |i: usize| {
            let (a, b) = (cut(total, unit, i, n), cut(total, unit, i + 1, n));
            if a >= b {
                return;
            }
            if let Err(e) = f(a..b) {
                let mut first = error.lock().unwrap_or_else(PoisonError::into_inner);
                first.get_or_insert(e);
            }
        };
        if !self.run(&piece, n) {
            return f(0..total);
        }
        match error.into_inner().unwrap_or_else(PoisonError::into_inner) {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// [`Team::pieces`] over the rows of `out` (rows of `row_len` values):
    /// `f(first_row, out_rows)` on disjoint parts of `out` that together cover it.
    pub(crate) fn rows<T: Send, F>(
        &self,
        out: &mut [T],
        row_len: usize,
        unit: usize,
        work: usize,
        enabled: bool,
        f: &F,
    ) -> TractResult<()>
    where
        F: Fn(usize, &mut [T]) -> TractResult<()> + Sync,
    {
        ensure!(
            row_len > 0 && unit > 0 && out.len().is_multiple_of(row_len),
            "split: {} values in rows of {row_len}",
            out.len()
        );
        let total = out.len() / row_len;
        let base = Out(out.as_mut_ptr());
        self.pieces(total, unit, work, enabled, &|r: std::ops::Range<usize>| {
            // SAFETY: rows [r.start, r.end) of `out`, disjoint from every other piece's (the
            // pieces do not overlap), while `out` is borrowed by this function.
            let o = unsafe { base.slice(r.start * row_len, r.len() * row_len) };
            f(r.start, o)
        })
    }
}

/// For the operators' tests.
#[cfg(test)]
pub(crate) mod testing {
    use super::*;

    thread_local! {
        /// The team [`team`] gives on this thread (see [`with_own_team`]).
        pub(crate) static OWN_TEAM: std::cell::Cell<Option<&'static Team>> =
            const { std::cell::Cell::new(None) };
    }

    /// Runs `f` with a new team of three threads as this thread's [`team`], and returns
    /// what `f` returned with the jobs that team ran. No other test can hold that team or
    /// count evaluations in flight on it, so whether it splits does not depend on what the
    /// other tests run meanwhile.
    pub(crate) fn with_own_team<R>(f: impl FnOnce() -> R) -> (R, usize) {
        let own = Team::start(3);
        assert_eq!(own.size(), 3, "could not start the test's helper threads");
        let before = OWN_TEAM.replace(Some(own));
        let r = f();
        OWN_TEAM.set(before);
        (r, own.jobs.load(Ordering::Relaxed))
    }

    /// A small deterministic generator of values in [-1, 1) (the 1x1 convolutions' tests,
    /// f32 and int8).
    pub(crate) struct Lcg(pub(crate) u64);

    impl Lcg {
        /// The next value.
        pub(crate) fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        }

        /// `n` values times `scale`.
        pub(crate) fn vec(&mut self, n: usize, scale: f32) -> Vec<f32> {
            (0..n).map(|_| self.next() * scale).collect()
        }
    }

    /// How many values of `a` and `b` differ in their bits (the kernels' tests: a SIMD
    /// kernel against the portable loop it must equal).
    pub(crate) fn differing_bits(a: &[f32], b: &[f32]) -> usize {
        assert_eq!(a.len(), b.len(), "outputs of different lengths");
        a.iter()
            .zip(b)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count()
    }

    /// The bits of the first output of `op` on `inputs`, evaluated as a tract operator (an
    /// f32 output's bits, or a u8 output's codes).
    pub(crate) fn bits(op: &dyn EvalOp, inputs: &[Tensor]) -> Vec<u32> {
        let out = op
            .eval_out_of_plan(inputs.iter().map(|t| t.clone().into_tvalue()).collect())
            .expect("eval")
            .expect("evaluates out of plan");
        tensor_bits(&out[0])
    }

    /// The bits of a tensor's values (an f32 tensor's bits, or a u8 tensor's codes).
    pub(crate) fn tensor_bits(t: &Tensor) -> Vec<u32> {
        let t = t.try_as_plain_ram().expect("ram");
        if let Ok(codes) = t.as_slice::<u8>() {
            return codes.iter().map(|&q| q as u32).collect();
        }
        t.as_slice::<f32>()
            .expect("f32")
            .iter()
            .map(|v| v.to_bits())
            .collect()
    }

    /// Checks that `split` (an operator that shares its rows between the threads) gives the
    /// bits of `whole` (the same operator in one piece) on `inputs`, and that it did share:
    /// on a team of the test's own ([`with_own_team`]), which no other test can hold.
    pub(crate) fn same_bits_split(split: &dyn EvalOp, whole: &dyn EvalOp, inputs: &[Tensor]) {
        let (want, whole_jobs) = with_own_team(|| bits(whole, inputs));
        assert_eq!(whole_jobs, 0, "the operator in one piece shared its rows");
        let (got, jobs) = with_own_team(|| bits(split, inputs));
        assert!(jobs > 0, "no split");
        assert_eq!(got.len(), want.len());
        let differ = got.iter().zip(&want).filter(|(g, w)| g != w).count();
        assert_eq!(differ, 0, "{differ} of {} values differ", want.len());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, Instant};

    /// The pieces (first row, row count) `team` makes, checked to cover every row once at
    /// multiples of `unit`, with the threads that ran them. With `meet`, each piece waits
    /// until pieces have started on two threads: the caller cannot finish the job alone, so
    /// a helper must take a piece, however late it is scheduled (no timing involved; a
    /// helper that never comes fails after a minute instead of hanging).
    fn pieces_and_threads(
        team: &Team,
        rows: usize,
        unit: usize,
        work: usize,
        meet: bool,
    ) -> (Vec<(usize, usize)>, usize) {
        let seen = Mutex::new(Vec::new());
        let met = Condvar::new();
        let mut out = vec![-1.0f32; rows * 3];
        team.rows(&mut out, 3, unit, work, true, &|first, o: &mut [f32]| {
            for (i, row) in o.chunks_exact_mut(3).enumerate() {
                row.fill((first + i) as f32);
            }
            let me = std::thread::current().id();
            let mut s = seen.lock().expect("lock");
            s.push((first, o.len() / 3, me));
            met.notify_all();
            let deadline = Instant::now() + Duration::from_secs(60);
            while meet && s.iter().all(|p| p.2 == me) {
                let left = deadline.saturating_duration_since(Instant::now());
                assert!(!left.is_zero(), "no other thread took a piece in a minute");
                s = met.wait_timeout(s, left).expect("lock").0;
            }
            Ok(())
        })
        .expect("rows");
        for (i, row) in out.chunks_exact(3).enumerate() {
            assert!(row.iter().all(|&v| v == i as f32), "row {i}: {row:?}");
        }
        let mut seen = seen.into_inner().expect("lock");
        seen.sort_unstable_by_key(|p| p.0);
        let mut threads: Vec<_> = seen.iter().map(|p| p.2).collect();
        threads.dedup();
        threads.sort_unstable_by_key(|t| format!("{t:?}"));
        threads.dedup();
        let pieces: Vec<_> = seen.iter().map(|p| (p.0, p.1)).collect();
        for (k, &(first, n)) in pieces.iter().enumerate() {
            assert!(first.is_multiple_of(unit) && n > 0, "{pieces:?}");
            let end = pieces.get(k + 1).map_or(rows, |p| p.0);
            assert_eq!(first + n, end, "{pieces:?}");
        }
        (pieces, threads.len())
    }

    fn pieces(team: &Team, rows: usize, unit: usize, work: usize) -> Vec<(usize, usize)> {
        pieces_and_threads(team, rows, unit, work, false).0
    }

    #[test]
    fn cuts_at_whole_units_and_the_helpers_take_pieces() {
        let two = Team::start(2);
        let three = Team::start(3);
        assert_eq!(two.size(), 2);
        assert_eq!(three.size(), 3);
        assert_eq!(pieces(two, 100, 8, MIN_WORK).len(), 2 * PIECES_PER_THREAD);
        assert_eq!(
            pieces(three, 1000, 8, MIN_WORK).len(),
            3 * PIECES_PER_THREAD
        );
        // Fewer units than pieces: some pieces are empty and skipped.
        assert_eq!(
            pieces(three, 17, 8, MIN_WORK),
            vec![(0, 8), (8, 8), (16, 1)]
        );
        // A helper takes pieces (here the caller waits for it, so it must).
        let (p, threads) = pieces_and_threads(two, 64, 1, MIN_WORK, true);
        assert_eq!(p.len(), 8);
        assert_eq!(threads, 2, "the helper took no piece");
        // Many jobs in a row (the helpers spin between them, then sleep, then wake).
        for k in 0..200 {
            assert_eq!(pieces(two, 64, 1, MIN_WORK).len(), 8);
            if k % 50 == 0 {
                // Past the helpers' spin (`SPIN`, 100 µs): they fall asleep.
                std::thread::sleep(Duration::from_micros(300));
            }
        }
    }

    #[test]
    fn small_work_one_thread_disabled_or_busy_run_in_one_piece() {
        let two = Team::start(2);
        assert_eq!(pieces(two, 100, 8, MIN_WORK - 1), vec![(0, 100)]);
        assert_eq!(pieces(Team::start(1), 100, 8, MIN_WORK), vec![(0, 100)]);
        assert_eq!(pieces(two, 8, 8, MIN_WORK), vec![(0, 8)]);
        let mut out = vec![0.0f32; 30];
        two.rows(
            &mut out,
            3,
            1,
            usize::MAX,
            false,
            &|first, o: &mut [f32]| {
                assert_eq!((first, o.len()), (0, 30));
                Ok(())
            },
        )
        .expect("rows");
        // A split inside a piece finds the team taken and runs in one piece.
        let inner = Mutex::new(Vec::new());
        let mut out = vec![0.0f32; 64];
        two.rows(&mut out, 1, 1, MIN_WORK, true, &|_, o: &mut [f32]| {
            let mut o2 = vec![0.0f32; 64];
            two.rows(&mut o2, 1, 1, MIN_WORK, true, &|first, p: &mut [f32]| {
                inner.lock().expect("lock").push((first, p.len()));
                Ok(())
            })?;
            o.fill(1.0);
            Ok(())
        })
        .expect("rows");
        assert_eq!(*inner.lock().expect("lock"), vec![(0, 64); 8]);
        assert!(out.iter().all(|&v| v == 1.0));
        // Two evaluations in flight: no split.
        let a = Running::on(two);
        assert_eq!(pieces(two, 100, 8, MIN_WORK).len(), 8);
        let _b = Running::on(two);
        assert_eq!(pieces(two, 100, 8, MIN_WORK), vec![(0, 100)]);
        drop(a);
        assert_eq!(pieces(two, 100, 8, MIN_WORK).len(), 8);
    }

    #[test]
    fn an_error_in_a_piece_is_returned_and_bad_sizes_refused() {
        let two = Team::start(2);
        let mut out = vec![0.0f32; 64];
        let r = two.rows(&mut out, 1, 1, MIN_WORK, true, &|first, _: &mut [f32]| {
            ensure!(first == 0, "piece at {first}");
            Ok(())
        });
        let e = format!("{:?}", r.expect_err("error"));
        assert!(e.contains("piece at") && !e.contains("piece at 0"), "{e}");
        assert!(two
            .rows(&mut out, 5, 1, 0, true, &|_, _: &mut [f32]| Ok(()))
            .is_err());
        // The team still works after the error.
        assert_eq!(pieces(two, 64, 1, MIN_WORK).len(), 8);
    }
}
