//! A batch's own worker threads: a crew that runs one job at a time on the calling thread and
//! whichever members join it in time.
//!
//! Why not rayon's pool for the batch's steps: a step of 64 worlds on two threads lasts about a
//! tenth of a millisecond, and handing it to rayon cost a clear share of that on a 2-core VM
//! (the batch on rayon against two separate 32-world batches stepped in lockstep by two
//! spinning threads: BENCHMARKS.md, "Optimisations"). Rayon hands a scope's jobs over its
//! global queue and its sleep module (a worker between jobs yields to the kernel and sleeps;
//! waking it is a futex call and a vCPU to schedule), and the batch had to spawn a job per
//! step just to keep its workers awake between steps. A crew member waits for its next job on
//! an epoch counter — awake for [`LINGER`], then parked on a condition variable, or parked at
//! once when it sees another crew of the process start a job (`JOBS_STARTED`) — and the caller
//! starts each job itself at once, without waiting for anyone to wake.
//!
//! **A member that comes late is not waited for.** A job is work that any participant can take
//! a share of (the batch's [`par_for`](crate::batch) hands out chunks of worlds, and a
//! participant that runs out takes another's), so the caller needs no member to finish it. A
//! member joins the job when it wakes, before it takes any work; once the caller has run out of
//! work it closes the job to joiners and waits only for those that joined. A member that is not
//! running when the job starts — descheduled because another process wants the core, as a
//! learner beside the batch always does — would otherwise cost the caller a scheduler slice
//! (milliseconds) per step (waiting for every member, two threads beside one busy process ran
//! several times slower than one: BENCHMARKS.md, "Optimisations"); instead the caller steps
//! that member's share itself, and the member that wakes after the job closed goes back to
//! waiting.
//!
//! Rayon stays what runs the scripted episodes (`episode::run_episodes`), whose tasks are
//! whole episodes (milliseconds each), where none of this shows.
//!
//! Panics: a member's panic is caught, and the caller re-raises it once every member that
//! joined the job has finished it (the job borrows the caller's stack, so the caller never
//! returns before then). A crew made in one process and used in a child forked from it (whose members did
//! not survive the fork) starts new members first instead of waiting forever.

use std::any::Any;
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long a member keeps waiting, awake, for the next job after finishing one: none. A
/// member that waits awake (spinning) joins the next step tens of µs sooner than a parked one
/// is woken, but beside another busy process it is a third thread on two cores, taking time
/// from the caller and from that process. On the 2-core VM (`benchmarks/under_load.py`, two
/// threads against one) waiting awake was faster quiet, by much only at small batches, but left
/// two threads no faster than one beside a busy process, where members that park at once keep
/// two about as fast as one or faster (BENCHMARKS.md, "Threads beside a busy process"). Tests
/// give members a long wait to reach the awake paths.
pub const LINGER: Duration = Duration::ZERO;

/// Jobs started by any crew of this process. A member waiting awake for its own crew's next
/// job stops waiting (parks) as soon as another crew starts one: two batches stepped in turn
/// (a training and an evaluation batch, two sides of a league) would otherwise each leave a
/// member spinning through the other's whole step, on the core that batch's own member needs
/// (on 2 cores, two E = 64 batches stepped in turn ran at a third of one batch's rate:
/// BENCHMARKS.md, "Optimisations").
static JOBS_STARTED: AtomicUsize = AtomicUsize::new(0);

/// The job of the moment: member `w` calls it with `w + 1` (the caller takes 0). Its lifetime
/// is erased: [`Crew::run`] keeps the borrowed closure alive until every member that joined
/// the job is done with it.
type Job = *const (dyn Fn(usize) + Sync + 'static);

struct Shared {
    /// Bumped for each job (and once at shutdown); a member looks at the gate when it sees a
    /// new value.
    epoch: AtomicUsize,
    /// Who may still join the current job: [`gate`] of the job's epoch, whether it is closed,
    /// and how many members joined it. Set (open) before the epoch moves; closed by the
    /// caller when it has run out of work.
    gate: AtomicU64,
    /// Written by the caller before the epoch moves, read by the members that joined.
    job: Mutex<Option<SendJob>>,
    /// Members done with the current job (of those that joined).
    done: AtomicUsize,
    /// The first panic of a member during the current job.
    panic: Mutex<Option<Box<dyn Any + Send>>>,
    /// Members parked, and where they park.
    parked: AtomicUsize,
    bell: Condvar,
    bell_lock: Mutex<()>,
    shutdown: AtomicBool,
    /// How long a member waits awake ([`LINGER`]; longer in tests).
    linger: Duration,
    /// Held by a test to keep the members from joining (as a descheduled member would not).
    #[cfg(test)]
    hold: Mutex<()>,
}

impl Shared {
    fn new(linger: Duration) -> Arc<Self> {
        Arc::new(Shared {
            epoch: AtomicUsize::new(0),
            gate: AtomicU64::new(gate(0) | CLOSED),
            job: Mutex::new(None),
            done: AtomicUsize::new(0),
            panic: Mutex::new(None),
            parked: AtomicUsize::new(0),
            bell: Condvar::new(),
            bell_lock: Mutex::new(()),
            shutdown: AtomicBool::new(false),
            linger,
            #[cfg(test)]
            hold: Mutex::new(()),
        })
    }

    /// Joins the job of `epoch` if it is still the current one and still open.
    fn join(&self, epoch: usize) -> bool {
        let mut g = self.gate.load(Ordering::Acquire);
        loop {
            if g & EPOCH != gate(epoch) || g & CLOSED != 0 {
                return false;
            }
            match self.gate.compare_exchange_weak(g, g + 1, Ordering::AcqRel, Ordering::Acquire) {
                Ok(_) => return true,
                Err(now) => g = now,
            }
        }
    }

    /// Closes the current job to joiners; how many joined it.
    fn close(&self) -> usize {
        (self.gate.fetch_or(CLOSED, Ordering::AcqRel) & (CLOSED - 1)) as usize
    }
}

/// The gate's closed bit; below it the count of members that joined, above it the epoch.
const CLOSED: u64 = 1 << 31;
const EPOCH: u64 = 0xffff_ffff << 32;

/// An open gate of the job of `epoch`, no member in yet (the epoch's low 32 bits on top: a
/// member that saw an older epoch never joins a newer job by mistake).
fn gate(epoch: usize) -> u64 {
    (epoch as u64 & 0xffff_ffff) << 32
}

#[derive(Clone, Copy)]
struct SendJob(Job);
// SAFETY: the pointee is `Sync` and outlives every use (see `Crew::run`).
unsafe impl Send for SendJob {}

/// `members` threads of their own besides the caller's (see the module's doc).
pub struct Crew {
    shared: Arc<Shared>,
    members: Vec<JoinHandle<()>>,
    /// The process the members were started in (a forked child has none of them).
    pid: u32,
}

impl Crew {
    /// A crew of `members` threads (0 is allowed: the caller alone).
    pub fn new(members: usize) -> std::io::Result<Self> {
        Self::with_linger(members, LINGER)
    }

    /// [`Crew::new`] whose members wait awake for `linger` after each job.
    fn with_linger(members: usize, linger: Duration) -> std::io::Result<Self> {
        let shared = Shared::new(linger);
        let mut crew = Self { shared, members: Vec::new(), pid: std::process::id() };
        crew.start(members)?;
        Ok(crew)
    }

    fn start(&mut self, members: usize) -> std::io::Result<()> {
        for w in 0..members {
            let shared = self.shared.clone();
            let seen = shared.epoch.load(Ordering::Acquire);
            let h = std::thread::Builder::new().name(format!("wolfpack-crew-{}", w + 1)).spawn(move || member(&shared, w + 1, seen))?;
            self.members.push(h);
        }
        Ok(())
    }

    /// Threads besides the caller.
    pub fn members(&self) -> usize {
        self.members.len()
    }

    /// Runs `job(0)` on the calling thread, and `job(w)` on each member w (1..=members) that
    /// joins in time — while `job(0)` runs — and returns when all these have returned. So
    /// `job(0)` alone must see the work done (a member's share is taken over when it does not
    /// come). A panic in any of them is re-raised here, after all have returned.
    pub fn run(&mut self, job: &(dyn Fn(usize) + Sync)) {
        self.run_with(job, true);
    }

    /// [`Crew::run`], waking parked members only when `wake` (or every [`PROBE_EVERY`]-th
    /// job): a job shorter than a member's wake-up is over before a woken member could join
    /// it, so waking one for it only costs the caller a system call and, beside a busy
    /// process, the core for a moment. Members waiting awake join either way.
    pub fn run_with(&mut self, job: &(dyn Fn(usize) + Sync), wake: bool) {
        if std::process::id() != self.pid {
            // A forked child: the members stayed with the parent (their handles name threads
            // this process never had: nothing to join or detach).
            let n = self.members.len();
            std::mem::forget(std::mem::take(&mut self.members));
            self.shared = Shared::new(self.shared.linger);
            self.pid = std::process::id();
            // Members that cannot be started only mean fewer threads: the others (the caller
            // at least) take the work their homes would have had.
            let _ = self.start(n);
        }
        let s = &*self.shared;
        // SAFETY (the lifetime's erasure): a member reads the pointer only after it joined the
        // job and before its `done` count, and this function does not return (nor unwind)
        // before every member that joined has counted.
        let erased: Job = unsafe { std::mem::transmute::<*const (dyn Fn(usize) + Sync + '_), Job>(job as *const _) };
        *s.job.lock().unwrap_or_else(PoisonError::into_inner) = Some(SendJob(erased));
        s.done.store(0, Ordering::Relaxed);
        // The gate before the epoch (a member that sees the new epoch finds its job open), the
        // epoch before the process-wide count (a member of this crew that sees the count move
        // then sees its own epoch moved too).
        let epoch = s.epoch.load(Ordering::SeqCst).wrapping_add(1);
        s.gate.store(gate(epoch), Ordering::SeqCst);
        s.epoch.store(epoch, Ordering::SeqCst);
        JOBS_STARTED.fetch_add(1, Ordering::SeqCst);
        if (wake || epoch % PROBE_EVERY == 0) && s.parked.load(Ordering::SeqCst) > 0 {
            let _g = s.bell_lock.lock().unwrap_or_else(PoisonError::into_inner);
            s.bell.notify_all();
        }
        let mine = catch_unwind(AssertUnwindSafe(|| job(0)));
        let joined = s.close();
        // A member still at work is usually a world's step (µs) from done: wait awake. One
        // that takes longer was most likely taken off its core mid-world by another process;
        // then this thread sleeps in short naps, which leaves its own core idle for the kernel
        // to run that member on, instead of spinning until the member's core is free again
        // (a scheduler slice, milliseconds).
        let mut spins = 0u32;
        while s.done.load(Ordering::Acquire) < joined {
            spins += 1;
            if spins < 1 << 10 {
                std::hint::spin_loop();
            } else {
                std::thread::sleep(NAP);
            }
        }
        *s.job.lock().unwrap_or_else(PoisonError::into_inner) = None;
        if let Err(p) = mine {
            resume_unwind(p);
        }
        if let Some(p) = s.panic.lock().unwrap_or_else(PoisonError::into_inner).take() {
            resume_unwind(p);
        }
    }
}

impl Drop for Crew {
    fn drop(&mut self) {
        let s = &*self.shared;
        s.shutdown.store(true, Ordering::SeqCst);
        s.epoch.fetch_add(1, Ordering::SeqCst);
        {
            let _g = s.bell_lock.lock().unwrap_or_else(PoisonError::into_inner);
            s.bell.notify_all();
        }
        if std::process::id() == self.pid {
            for h in self.members.drain(..) {
                let _ = h.join();
            }
        } else {
            // A forked child never had these threads: nothing to join or detach.
            std::mem::forget(std::mem::take(&mut self.members));
        }
    }
}

/// How long the caller sleeps at a time while it waits for a member that is taking long (see
/// [`Crew::run_with`]).
const NAP: Duration = Duration::from_micros(20);

/// Parked members are woken for one job in this many even when the caller does not ask (see
/// [`Crew::run_with`]), so that a member parked beside a busy process that has since ended
/// goes back to waiting awake for the small jobs too.
pub const PROBE_EVERY: usize = 64;

/// A member's life: wait for the epoch to move (spinning for [`LINGER`], then parked), join
/// the job if it is still open, run it and count itself done; until shutdown.
fn member(s: &Shared, me: usize, mut seen: usize) {
    loop {
        let start = Instant::now();
        let others = JOBS_STARTED.load(Ordering::SeqCst);
        let mut now = s.epoch.load(Ordering::SeqCst);
        'wait: while start.elapsed() < s.linger {
            for _ in 0..64 {
                now = s.epoch.load(Ordering::SeqCst);
                if now != seen {
                    break 'wait;
                }
                if JOBS_STARTED.load(Ordering::SeqCst) != others {
                    // Another crew's job (ours would have moved our epoch first): park.
                    now = s.epoch.load(Ordering::SeqCst);
                    break 'wait;
                }
                std::hint::spin_loop();
            }
        }
        if now == seen {
            let mut g = s.bell_lock.lock().unwrap_or_else(PoisonError::into_inner);
            s.parked.fetch_add(1, Ordering::SeqCst);
            loop {
                now = s.epoch.load(Ordering::SeqCst);
                if now != seen {
                    break;
                }
                g = s.bell.wait(g).unwrap_or_else(PoisonError::into_inner);
            }
            s.parked.fetch_sub(1, Ordering::SeqCst);
        }
        seen = now;
        if s.shutdown.load(Ordering::SeqCst) {
            return;
        }
        #[cfg(test)]
        drop(s.hold.lock().unwrap_or_else(PoisonError::into_inner));
        if !s.join(now) {
            // Too late: the caller took this member's share and may have returned already.
            continue;
        }
        let job = *s.job.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(SendJob(job)) = job {
            // SAFETY: see `Crew::run`: the job outlives this call.
            let r = catch_unwind(AssertUnwindSafe(|| unsafe { (*job)(me) }));
            if let Err(p) = r {
                s.panic.lock().unwrap_or_else(PoisonError::into_inner).get_or_insert(p);
            }
        }
        s.done.fetch_add(1, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs one job on `crew` and returns the participant numbers that ran it, sorted.
    fn who_runs_a_job(crew: &mut Crew) -> Vec<usize> {
        let ran = Mutex::new(Vec::new());
        crew.run(&|w| ran.lock().unwrap().push(w));
        let mut ran = ran.into_inner().unwrap();
        ran.sort_unstable();
        ran
    }

    /// Runs a job whose caller's part waits (up to 20 s) until `expected` members have joined
    /// it; the participants that ran it, sorted.
    fn who_joins_a_waiting_job(crew: &mut Crew, expected: usize) -> Vec<usize> {
        let ran = Mutex::new(Vec::new());
        let members = AtomicUsize::new(0);
        crew.run(&|w| {
            ran.lock().unwrap().push(w);
            if w == 0 {
                let t = Instant::now();
                while members.load(Ordering::SeqCst) < expected && t.elapsed() < Duration::from_secs(20) {
                    std::thread::yield_now();
                }
            } else {
                members.fetch_add(1, Ordering::SeqCst);
            }
        });
        let mut ran = ran.into_inner().unwrap();
        ran.sort_unstable();
        ran
    }

    #[test]
    fn the_caller_runs_every_job_and_each_member_at_most_once() {
        let mut crew = Crew::new(3).unwrap();
        for round in 0..200 {
            let hits: Vec<AtomicUsize> = (0..4).map(|_| AtomicUsize::new(0)).collect();
            crew.run(&|w| {
                hits[w].fetch_add(1, Ordering::Relaxed);
            });
            assert_eq!(hits[0].load(Ordering::Relaxed), 1, "round {round}: the caller");
            assert!(hits.iter().all(|h| h.load(Ordering::Relaxed) <= 1), "round {round}");
            if round % 50 == 0 {
                // Long enough for the members to park: a job that waits for them must wake them.
                std::thread::sleep(LINGER * 4);
                assert_eq!(who_joins_a_waiting_job(&mut crew, 3), [0, 1, 2, 3], "round {round}");
            }
        }
        assert_eq!(who_runs_a_job(&mut Crew::new(0).unwrap()), [0], "a crew of none: the caller alone");
    }

    /// A member that does not come while the caller works (held here, as the kernel holds a
    /// descheduled thread) is not waited for; it does not run the closed job when it comes,
    /// and joins the next one.
    #[test]
    fn a_member_that_comes_late_is_not_waited_for() {
        let mut crew = Crew::with_linger(1, Duration::from_secs(60)).unwrap();
        let shared = crew.shared.clone();
        let held = shared.hold.lock().unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        let caller = std::thread::spawn(move || {
            let ran = who_runs_a_job(&mut crew);
            tx.send(ran).unwrap();
            crew
        });
        let ran = rx.recv_timeout(Duration::from_secs(20));
        drop(held);
        assert_eq!(ran.expect("the caller waited for a member that never came"), [0]);
        let mut crew = caller.join().unwrap();
        assert_eq!(who_joins_a_waiting_job(&mut crew, 1), [0, 1]);
    }

    #[test]
    fn a_members_panic_reaches_the_caller_after_every_member_is_done() {
        let mut crew = Crew::new(2).unwrap();
        let (started, finished) = (AtomicUsize::new(0), AtomicUsize::new(0));
        let r = catch_unwind(AssertUnwindSafe(|| {
            crew.run(&|w| {
                started.fetch_add(1, Ordering::SeqCst);
                if w == 1 {
                    panic!("member {w}");
                }
                // The caller keeps the job open until both members joined.
                let t = Instant::now();
                while w == 0 && started.load(Ordering::SeqCst) < 3 && t.elapsed() < Duration::from_secs(20) {
                    std::thread::yield_now();
                }
                std::thread::sleep(Duration::from_millis(20));
                finished.fetch_add(1, Ordering::SeqCst);
            })
        }));
        assert!(r.is_err());
        assert_eq!(finished.load(Ordering::SeqCst), 2, "the caller returned before the others finished");
        // The crew still works after a panic.
        assert_eq!(who_joins_a_waiting_job(&mut crew, 2), [0, 1, 2]);
    }

    /// A member waiting awake for its own crew's next job parks as soon as another crew starts
    /// one (here the wait would otherwise last a minute), and wakes for its own next job.
    #[test]
    fn a_waiting_member_parks_when_another_crew_starts_a_job() {
        let mut a = Crew::with_linger(1, Duration::from_secs(60)).unwrap();
        let mut b = Crew::new(1).unwrap();
        a.run(&|_| {});
        let parked = |c: &Crew| c.shared.parked.load(Ordering::SeqCst);
        let shared_a = a.shared.clone();
        b.run(&|w| {
            if w == 0 {
                let t = Instant::now();
                while shared_a.parked.load(Ordering::SeqCst) == 0 && t.elapsed() < Duration::from_secs(20) {
                    std::thread::yield_now();
                }
            }
        });
        assert_eq!(parked(&a), 1, "crew a's member still spinning through crew b's job");
        assert_eq!(who_joins_a_waiting_job(&mut a, 1), [0, 1]);
    }

    /// A job that does not ask to wake parked members leaves them parked, but for one job in
    /// [`PROBE_EVERY`].
    #[test]
    fn small_jobs_leave_parked_members_parked_but_for_a_probe() {
        let mut crew = Crew::with_linger(1, Duration::ZERO).unwrap();
        let t = Instant::now();
        while crew.shared.parked.load(Ordering::SeqCst) == 0 && t.elapsed() < Duration::from_secs(20) {
            std::thread::yield_now();
        }
        let mut joined = Vec::new();
        for k in 1..=PROBE_EVERY {
            let member_ran = AtomicBool::new(false);
            crew.run_with(
                &|w| {
                    if w == 0 {
                        // Time enough for a woken member to come (a parked one never does).
                        let t = Instant::now();
                        while !member_ran.load(Ordering::SeqCst) && t.elapsed() < Duration::from_millis(20) {
                            std::thread::yield_now();
                        }
                    } else {
                        member_ran.store(true, Ordering::SeqCst);
                    }
                },
                false,
            );
            if member_ran.load(Ordering::SeqCst) {
                joined.push(k);
            }
        }
        assert_eq!(joined, [PROBE_EVERY], "jobs a parked member ran");
    }

    #[test]
    fn dropping_a_crew_stops_its_members() {
        let crew = Crew::new(2).unwrap();
        let t = Instant::now();
        drop(crew);
        assert!(t.elapsed() < Duration::from_secs(10));
    }
}
