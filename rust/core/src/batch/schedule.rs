//! Spreading one step's worlds over the calling thread and the batch's crew: [`par_for`] hands
//! out indices in chunks from each participant's home run, stealing from the fullest when its
//! own runs out; [`Disjoint`] gives the tasks their own elements of a shared slice.

use std::sync::atomic::Ordering;
use std::sync::Mutex;

use crate::crew::Crew;
use crate::error::{Error, Result};

/// Below this many items a job does not wake the crew's parked members ([`Crew::run_with`]):
/// stepping 32 worlds takes one thread several times as long as a member takes to wake on a VM
/// (tens of µs), so a member woken for them still finds worlds to step; fewer are done, or
/// nearly, by the time it comes (BENCHMARKS.md, "Optimisations").
pub(super) const WAKE_FROM: usize = 32;

/// Maps `f` over `items` on `participants` threads (see [`par_for`]); the results come back
/// in item order, so nothing depends on which thread ran what.
pub(super) fn share<T: Send, R: Send>(crew: Option<&mut Crew>, participants: usize, items: Vec<T>, chunk: usize, f: impl Fn(T) -> R + Sync) -> Vec<R> {
    let n = items.len();
    let mut items: Vec<Option<T>> = items.into_iter().map(Some).collect();
    let mut results: Vec<Option<R>> = std::iter::repeat_with(|| None).take(n).collect();
    let (cells, out) = (Disjoint::new(&mut items), Disjoint::new(&mut results));
    par_for(
        crew,
        participants,
        n,
        chunk,
        |_| {},
        |i| {
            // SAFETY: par_for hands out each index once.
            let (item, result) = unsafe { (cells.item(i), out.item(i)) };
            *result = item.take().map(&f);
        },
    );
    results.into_iter().map(|r| r.expect("par_for calls f once for every index")).collect()
}

/// Calls `f(i)` once for every `i` in `0..n`, on `participants` threads: the calling thread
/// and the members of `crew` ([`Crew::run`]; the caller alone without one, or with one
/// participant). Indices are claimed in chunks of `chunk`. Before `f` takes an index, the
/// index the same thread will take next is hinted to `ahead` (the step uses it to start
/// loading the next world's memory, [`Slot::prefetch`]); a thread claims its next chunk before
/// the last index of the current one, so what it hints is always its own.
///
/// Each participant has a home share of the chunks — a contiguous run, the same run every
/// call — and takes its own chunks first, front to back; one that runs out takes the last
/// chunk of the participant with the most left ([`HomeRuns`], lock-free). So a world is stepped
/// by the same thread step after step and its memory stays in that core's cache, while a slow
/// world (one that spawns its next episode) is still balanced out. (With one shared queue the
/// worlds moved between the cores every step, and two threads stepped 64 worlds well short of
/// twice as fast as one, where two separate batches of 32 reached twice: BENCHMARKS.md,
/// "Optimisations".)
///
/// Only indices are handed out: each task finds its world and its pieces of the outputs from
/// the index ([`Disjoint`], [`OutPieces`]). Building a list of per-world items and output
/// slices first was serial work on the caller, a visible share of a two-thread step at large E.
///
/// Why not `pool.install(par_iter)`: the caller (Python's thread) then only waits, and every
/// step pays for waking all workers and for waking the caller again (tens of µs on a VM, as
/// much as stepping a full chunk of worlds: BENCHMARKS.md, "Optimisations"); here the caller
/// starts at once and the crew's members join as they wake, or not at all for fewer than
/// [`WAKE_FROM`] items (see [`crate::crew`] for why not a rayon scope).
pub(super) fn par_for(crew: Option<&mut Crew>, participants: usize, n: usize, chunk: usize, ahead: impl Fn(usize) + Sync, f: impl Fn(usize) + Sync) {
    let crew = match crew {
        Some(c) if participants > 1 && n > 0 => c,
        // One thread: the caller's, with no crew to hand anything to.
        _ => {
            for i in 0..n {
                if i + 1 < n {
                    ahead(i + 1);
                }
                f(i);
            }
            return;
        }
    };
    let runs = HomeRuns::new(n, chunk, participants);
    // Participant `home` (the caller 0, crew member w its w) drains its home run, then helps.
    // It claims its next chunk before it runs the last index of the current one, so that the
    // index it hints is always one it holds (a world another thread steps is never touched).
    crew.run_with(
        &|home: usize| {
            let mut current = runs.take(home);
            while let Some(range) = current {
                let next = runs.take(home);
                for i in range.clone() {
                    let hint = if i + 1 < range.end { Some(i + 1) } else { next.as_ref().map(|r| r.start) };
                    if let Some(h) = hint {
                        ahead(h);
                    }
                    f(i);
                }
                current = next;
            }
        },
        n >= WAKE_FROM,
    );
}

/// Shared access, from many threads, to distinct elements of a slice borrowed for `'a`: the
/// callers promise (unsafely) that no element is taken twice at once — [`par_for`] hands out
/// each index once.
pub(super) struct Disjoint<'a, T> {
    ptr: *mut T,
    len: usize,
    _borrow: std::marker::PhantomData<&'a mut [T]>,
}

// SAFETY: a Disjoint is a `&mut [T]` whose elements go to different threads.
unsafe impl<T: Send> Send for Disjoint<'_, T> {}
unsafe impl<T: Send> Sync for Disjoint<'_, T> {}

impl<'a, T> Disjoint<'a, T> {
    pub(super) fn new(s: &'a mut [T]) -> Self {
        Self { ptr: s.as_mut_ptr(), len: s.len(), _borrow: std::marker::PhantomData }
    }

    /// Element `i`.
    ///
    /// # Safety
    /// No other reference to element `i` may be alive while this one is.
    #[inline]
    pub(super) unsafe fn item(&self, i: usize) -> &'a mut T {
        assert!(i < self.len, "index {i} of {}", self.len);
        // SAFETY: in bounds; exclusive by the caller's promise.
        unsafe { &mut *self.ptr.add(i) }
    }

    /// Elements `i·per .. (i+1)·per` (empty when `per` is 0).
    ///
    /// # Safety
    /// No other reference to any of these elements may be alive while this one is.
    #[inline]
    pub(super) unsafe fn piece(&self, i: usize, per: usize) -> &'a mut [T] {
        if per == 0 {
            return &mut [];
        }
        assert!((i + 1) * per <= self.len, "piece {i} of {per} in {}", self.len);
        // SAFETY: in bounds; exclusive by the caller's promise.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(i * per), per) }
    }
}

/// The chunks of [`par_for`]: chunk k is indices `k·chunk .. min((k+1)·chunk, n)`, and
/// participant p's home is the run `front..back` of the chunks it has not taken (one atomic
/// word per home, on a cache line of its own: taking one's own next chunk touches no line
/// another thread writes, unless that thread is stealing from it).
struct HomeRuns {
    n: usize,
    chunk: usize,
    homes: Vec<HomeRun>,
}

/// `front << 32 | back`, in chunks.
#[repr(align(64))]
struct HomeRun(std::sync::atomic::AtomicU64);

fn pack(front: usize, back: usize) -> u64 {
    ((front as u64) << 32) | back as u64
}

fn unpack(v: u64) -> (usize, usize) {
    ((v >> 32) as usize, (v & 0xffff_ffff) as usize)
}

impl HomeRuns {
    /// `0..n` in chunks of `chunk` (at least 1), dealt in order to `participants` homes of as
    /// equal a count of chunks as can be.
    fn new(n: usize, chunk: usize, participants: usize) -> Self {
        let chunk = chunk.max(1);
        let c = n.div_ceil(chunk);
        assert!(c < 1 << 32, "{c} chunks");
        let homes = (0..participants).map(|p| HomeRun(std::sync::atomic::AtomicU64::new(pack(p * c / participants, (p + 1) * c / participants)))).collect();
        Self { n, chunk, homes }
    }

    /// The next chunk for participant `home` (taken modulo the participants): the front of its
    /// own run, else the back of the longest run left; `None` when every chunk is taken.
    fn take(&self, home: usize) -> Option<std::ops::Range<usize>> {
        let own = &self.homes[home % self.homes.len()].0;
        let mut v = own.load(Ordering::Acquire);
        let k = loop {
            let (front, back) = unpack(v);
            if front < back {
                match own.compare_exchange_weak(v, pack(front + 1, back), Ordering::AcqRel, Ordering::Acquire) {
                    Ok(_) => break front,
                    Err(now) => v = now,
                }
                continue;
            }
            // Own run done: the back of the longest run left (the lowest-numbered of equals).
            let (victim, (f, b)) = self.homes.iter().map(|h| unpack(h.0.load(Ordering::Acquire))).enumerate().max_by_key(|&(p, (f, b))| (b.saturating_sub(f), std::cmp::Reverse(p)))?;
            if f >= b {
                return None;
            }
            if self.homes[victim].0.compare_exchange(pack(f, b), pack(f, b - 1), Ordering::AcqRel, Ordering::Acquire).is_ok() {
                break b - 1;
            }
            v = own.load(Ordering::Acquire);
        };
        Some(k * self.chunk..((k + 1) * self.chunk).min(self.n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;
    use std::time::Duration;

    #[test]
    fn share_maps_in_item_order_whatever_the_threads_and_chunks() {
        let mut crew = Crew::new(2).unwrap();
        let want: Vec<usize> = (0..1000).map(|k| 3 * k).collect();
        for (participants, chunk) in [(1, 1), (2, 7), (3, 16), (3, 1000)] {
            assert_eq!(share(Some(&mut crew), participants, (0..1000).collect(), chunk, |k: usize| 3 * k), want, "{participants} threads, chunk {chunk}");
        }
        assert_eq!(share(None, 2, (0..10).collect(), 3, |k: usize| k), (0..10).collect::<Vec<_>>());
    }

    #[test]
    fn each_participant_takes_its_home_chunks_first_then_the_back_of_the_longest_run() {
        // 10 indices in chunks of 2: chunks 0..5 start at 0, 2, 4, 6, 8; homes of 2
        // participants are chunks 0..2 and 2..5.
        let q = HomeRuns::new(10, 2, 2);
        assert_eq!(q.take(1), Some(4..6));
        assert_eq!(q.take(0), Some(0..2));
        assert_eq!(q.take(0), Some(2..4));
        // Participant 0's run is done: it takes the last chunk of participant 1's.
        assert_eq!(q.take(0), Some(8..10));
        assert_eq!(q.take(1), Some(6..8));
        assert_eq!(q.take(1), None);
        assert_eq!(q.take(0), None);
        // Homes beyond the participants wrap; a last short chunk; more participants than
        // chunks: every index is still handed out exactly once.
        for (participants, chunk, n) in [(3, 1, 2), (4, 3, 10), (2, 1, 0), (5, 7, 100)] {
            let q = HomeRuns::new(n, chunk, participants);
            let mut seen = Vec::new();
            for round in 0.. {
                match q.take(round * 7) {
                    Some(range) => {
                        assert!(!range.is_empty() && range.len() <= chunk && range.start % chunk == 0);
                        seen.extend(range);
                    }
                    None => break,
                }
            }
            seen.sort_unstable();
            assert_eq!(seen, (0..n).collect::<Vec<_>>(), "{participants} participants, chunk {chunk}, {n} indices");
        }
    }

    #[test]
    fn par_for_hints_each_index_once_just_before_the_one_it_runs_before_it() {
        let log = Mutex::new(Vec::new());
        let push = |s: String| log.lock().unwrap().push(s);
        par_for(None, 1, 5, 5, |next| push(format!("ahead {next}")), |i| push(format!("run {i}")));
        let want = ["ahead 1", "run 0", "ahead 2", "run 1", "ahead 3", "run 2", "ahead 4", "run 3", "run 4"];
        assert_eq!(*log.lock().unwrap(), want);
        // Threads: every index runs once, and the index a thread hints is the next one that
        // same thread runs (a world that another thread may be stepping is never touched).
        let mut crew = Crew::new(2).unwrap();
        for (n, chunk) in [(100, 7), (64, 1), (5, 16), (1000, 3)] {
            let events = Mutex::new(Vec::new());
            let me = || format!("{:?}", std::thread::current().id());
            par_for(
                Some(&mut crew),
                3,
                n,
                chunk,
                |next| events.lock().unwrap().push((me(), true, next)),
                |i| {
                    // Long enough for the threads to interleave and to steal from each other.
                    std::thread::sleep(Duration::from_micros(if i % 5 == 0 { 200 } else { 20 }));
                    events.lock().unwrap().push((me(), false, i));
                },
            );
            let events = events.into_inner().unwrap();
            let mut ran: Vec<usize> = events.iter().filter(|e| !e.1).map(|e| e.2).collect();
            ran.sort_unstable();
            assert_eq!(ran, (0..n).collect::<Vec<_>>(), "n {n}, chunk {chunk}: each index once");
            let mut threads: Vec<String> = events.iter().map(|e| e.0.clone()).collect();
            threads.sort();
            threads.dedup();
            for t in threads {
                let mine: Vec<(bool, usize)> = events.iter().filter(|e| e.0 == t).map(|e| (e.1, e.2)).collect();
                for (k, &(hint, h)) in mine.iter().enumerate() {
                    if hint {
                        // ahead h, run i, then the thread's next run is h.
                        let next_run = mine[k + 1..].iter().filter(|e| !e.0).nth(1).map(|e| e.1);
                        assert_eq!(next_run, Some(h), "n {n}, chunk {chunk}: thread {t} hinted {h}: {mine:?}");
                    }
                }
            }
        }
        par_for(Some(&mut crew), 3, 0, 4, |_| panic!("nothing to hint"), |_| panic!("nothing to run"));
    }

    /// A task that panics on a worker reaches the caller as a panic (the binding turns it
    /// into an exception) instead of leaving the caller waiting for that worker forever.
    #[test]
    fn a_panic_on_a_worker_is_handed_on_not_waited_for() {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut crew = Crew::new(1).unwrap();
            let work = |k: usize| {
                std::thread::sleep(Duration::from_millis(1)); // long enough for the worker to take tasks
                if std::thread::current().name().is_some_and(|n| n.starts_with("wolfpack-crew")) {
                    panic!("task {k} on the worker");
                }
                k
            };
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| share(Some(&mut crew), 2, (0..64).collect(), 1, work)));
            tx.send(r.is_err()).unwrap();
        });
        let panicked = rx.recv_timeout(Duration::from_secs(60)).expect("share still waiting 60 s after a worker's task panicked");
        assert!(panicked, "the worker's panic was not handed on");
    }
}

/// The error of the lowest-numbered world that failed in a batch's tasks, whichever thread saw
/// it first: the error a serial loop over the worlds would have stopped at.
#[derive(Default)]
pub(super) struct FirstFailure(Mutex<Option<(usize, Error)>>);

impl FirstFailure {
    pub(super) fn record(&self, world: usize, err: Error) {
        let mut first = self.0.lock().unwrap_or_else(|p| p.into_inner());
        if first.as_ref().is_none_or(|(k, _)| world < *k) {
            *first = Some((world, err));
        }
    }

    pub(super) fn into_result(self) -> Result<()> {
        match self.0.into_inner().unwrap_or_else(|p| p.into_inner()) {
            Some((_, err)) => Err(err),
            None => Ok(()),
        }
    }
}
