//! A batch's own worker threads: a crew that runs one job at a time on every member and the
//! calling thread together, then waits awake a short while for the next one.
//!
//! Why not rayon's pool for the batch's steps: a step of 64 worlds on two threads is ≈ 110 µs,
//! and handing it to rayon cost ≈ 15 % of that on this 2-core VM (measured with
//! `examples/batch_threads` against two separate 32-world batches stepped in lockstep by two
//! spinning threads: 560 k against 660 k env-steps/s). Rayon hands a scope's jobs over its
//! global queue and its sleep module (a worker between jobs yields to the kernel and sleeps;
//! waking it is a futex call and a vCPU to schedule), and the batch had to spawn a job per
//! step just to keep its workers awake between steps. A crew member instead spins on an
//! epoch counter for [`LINGER`] after each job and takes the next job the moment the counter
//! moves; only a member left idle longer, or one that sees another crew of the process start
//! a job (`JOBS_STARTED`), parks (on a condition variable) and is woken by the next job.
//!
//! Rayon stays what runs the scripted episodes (`episode::run_episodes`), whose tasks are
//! whole episodes (milliseconds each), where none of this shows.
//!
//! Panics: a member's panic is caught, and the caller re-raises it once every member has
//! finished the job (the job borrows the caller's stack, so the caller never returns before
//! then). A crew made in one process and used in a child forked from it (whose members did
//! not survive the fork) starts new members first instead of waiting forever.

use std::any::Any;
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long a member keeps waiting, awake, for the next job after finishing one. A parked
/// member takes tens of µs to wake on a VM (a futex wake and the hypervisor scheduling the
/// vCPU), as much as a quarter of a 64-world step; between two steps of a training loop the
/// caller is away for far less than this.
pub const LINGER: Duration = Duration::from_micros(300);

/// Jobs started by any crew of this process. A member waiting awake for its own crew's next
/// job stops waiting (parks) as soon as another crew starts one: two batches stepped in turn
/// (a training and an evaluation batch, two sides of a league) would otherwise each leave a
/// member spinning through the other's whole step, on the core that batch's own member needs
/// (on 2 cores, two E = 64 batches stepped in turn ran at 0.2 M env-steps/s against 0.6 M for
/// one).
static JOBS_STARTED: AtomicUsize = AtomicUsize::new(0);

/// The job of the moment: member `w` calls it with `w + 1` (the caller takes 0). Its lifetime
/// is erased: [`Crew::run`] keeps the borrowed closure alive until every member is done.
type Job = *const (dyn Fn(usize) + Sync + 'static);

struct Shared {
    /// Bumped for each job (and once at shutdown); a member runs a job when it sees a new value.
    epoch: AtomicUsize,
    /// Written by the caller before the epoch moves, read by the members after they see it.
    job: Mutex<Option<SendJob>>,
    /// Members done with the current job.
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
}

impl Shared {
    fn new(linger: Duration) -> Arc<Self> {
        Arc::new(Shared {
            epoch: AtomicUsize::new(0),
            job: Mutex::new(None),
            done: AtomicUsize::new(0),
            panic: Mutex::new(None),
            parked: AtomicUsize::new(0),
            bell: Condvar::new(),
            bell_lock: Mutex::new(()),
            shutdown: AtomicBool::new(false),
            linger,
        })
    }
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

    /// Runs `job(0)` on the calling thread and `job(w)` on member w (1..=members) at the same
    /// time, and returns when all have returned. A panic in any of them is re-raised here,
    /// after all have returned.
    pub fn run(&mut self, job: &(dyn Fn(usize) + Sync)) {
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
        // SAFETY (the lifetime's erasure): the members read the pointer only between the epoch
        // moving and their `done` count, and this function does not return (nor unwind) before
        // every member has counted.
        let erased: Job = unsafe { std::mem::transmute::<*const (dyn Fn(usize) + Sync + '_), Job>(job as *const _) };
        *s.job.lock().unwrap_or_else(PoisonError::into_inner) = Some(SendJob(erased));
        s.done.store(0, Ordering::Relaxed);
        // The epoch before the process-wide count: a member of this crew that sees the count
        // move then sees its own epoch moved too.
        s.epoch.fetch_add(1, Ordering::SeqCst);
        JOBS_STARTED.fetch_add(1, Ordering::SeqCst);
        if s.parked.load(Ordering::SeqCst) > 0 {
            let _g = s.bell_lock.lock().unwrap_or_else(PoisonError::into_inner);
            s.bell.notify_all();
        }
        let mine = catch_unwind(AssertUnwindSafe(|| job(0)));
        let members = self.members.len();
        let mut spins = 0u32;
        while s.done.load(Ordering::Acquire) < members {
            spins += 1;
            if spins < 1 << 14 {
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
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

/// A member's life: wait for the epoch to move (spinning for [`LINGER`], then parked), run the
/// job, count itself done; until shutdown.
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

    #[test]
    fn every_member_and_the_caller_run_each_job_once() {
        let mut crew = Crew::new(3).unwrap();
        for round in 0..200 {
            let hits: Vec<AtomicUsize> = (0..4).map(|_| AtomicUsize::new(0)).collect();
            crew.run(&|w| {
                hits[w].fetch_add(1, Ordering::Relaxed);
            });
            assert!(hits.iter().all(|h| h.load(Ordering::Relaxed) == 1), "round {round}");
            if round % 50 == 0 {
                // Long enough for the members to park: the next job must wake them.
                std::thread::sleep(LINGER * 4);
            }
        }
        assert_eq!(who_runs_a_job(&mut Crew::new(0).unwrap()), [0], "a crew of none: the caller alone");
    }

    #[test]
    fn a_members_panic_reaches_the_caller_after_every_member_is_done() {
        let mut crew = Crew::new(2).unwrap();
        let finished = AtomicUsize::new(0);
        let r = catch_unwind(AssertUnwindSafe(|| {
            crew.run(&|w| {
                if w == 1 {
                    panic!("member {w}");
                }
                std::thread::sleep(Duration::from_millis(20));
                finished.fetch_add(1, Ordering::SeqCst);
            })
        }));
        assert!(r.is_err());
        assert_eq!(finished.load(Ordering::SeqCst), 2, "the caller returned before the others finished");
        // The crew still works after a panic.
        assert_eq!(who_runs_a_job(&mut crew), [0, 1, 2]);
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
        assert_eq!(who_runs_a_job(&mut a), [0, 1]);
    }

    #[test]
    fn dropping_a_crew_stops_its_members() {
        let crew = Crew::new(2).unwrap();
        let t = Instant::now();
        drop(crew);
        assert!(t.elapsed() < Duration::from_secs(10));
    }
}
