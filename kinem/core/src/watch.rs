//! What stops a march before its end (issue 33): a deadline
//! (kinem.Options.max_seconds) and a signal (Ctrl-C). The march looks at
//! both at every instant: the deadline and an atomic stop flag on any
//! thread; the thread that called it also polls for signals every POLL (the
//! Python binding re-acquires the GIL briefly for it). A stop leaves the
//! march's state at its last instant taken.
use crate::accept::Why;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::time::{Duration, Instant};

/// How often the calling thread polls for a signal while marching.
pub const POLL: Duration = Duration::from_millis(2);

/// A signal poll: true when the march must stop (a signal arrived).
pub type Poll<'a> = &'a (dyn Fn() -> bool + Sync);

pub struct Watch<'a> {
    deadline: Option<Instant>,
    stop: AtomicU8,
    poll: Option<Poll<'a>>,
}

impl<'a> Watch<'a> {
    /// A watch with `seconds` left (not finite: no deadline; zero or less: out
    /// of time at once) and a signal poll for the calling thread.
    pub fn new(seconds: f64, poll: Option<Poll<'a>>) -> Self {
        let now = Instant::now();
        let deadline = if seconds.is_nan() || seconds == f64::INFINITY {
            None
        } else if seconds <= 0.0 {
            Some(now)
        } else {
            // beyond a year: no deadline (Duration and Instant would overflow)
            (seconds < 3.2e7).then(|| now + Duration::from_secs_f64(seconds))
        };
        Watch { deadline, stop: AtomicU8::new(0), poll }
    }

    /// No deadline, no signals.
    pub fn none() -> Watch<'static> {
        Watch { deadline: None, stop: AtomicU8::new(0), poll: None }
    }

    fn halt(&self, why: Why) -> Why {
        self.stop.store(why as u8, Ordering::Relaxed);
        why
    }

    /// Why to stop before the next instant, if at all: the stop flag, the
    /// deadline, and on the calling thread (`caller`) a signal poll when
    /// `next` has passed (then POLL later).
    pub fn check(&self, caller: bool, next: &mut Instant) -> Option<Why> {
        self.look(caller, next).0
    }

    /// `check`, with the time it read (None: it read no clock, having no
    /// deadline nor, on this thread, a poll; or the stop flag was set).
    pub fn look(&self, caller: bool, next: &mut Instant) -> (Option<Why>, Option<Instant>) {
        let code = self.stop.load(Ordering::Relaxed);
        if code != 0 {
            return (Why::ALL.get(code as usize).copied(), None);
        }
        if self.deadline.is_none() && !(caller && self.poll.is_some()) {
            return (None, None);
        }
        let now = Instant::now();
        (self.clocked(caller, next, now), Some(now))
    }

    /// `check`'s deadline and signal poll at `now`.
    fn clocked(&self, caller: bool, next: &mut Instant, now: Instant) -> Option<Why> {
        if self.deadline.is_some_and(|d| now >= d) {
            return Some(self.halt(Why::OutOfTime));
        }
        if caller && now >= *next {
            *next = now + POLL;
            if self.poll.is_some_and(|p| p()) {
                return Some(self.halt(Why::Interrupted));
            }
        }
        None
    }

    /// f() run on the thread pool while the calling thread polls for
    /// signals (setting the stop flag that f's marches look at); without
    /// a poll, f() here.
    pub fn around<T: Send>(&self, f: impl FnOnce() -> T + Send) -> T {
        if self.poll.is_none() {
            return f();
        }
        let done = AtomicBool::new(false);
        let caller = std::thread::current();
        let mut result = None;
        rayon::in_place_scope(|s| {
            let (done, result) = (&done, &mut result);
            s.spawn(move |_| {
                // done even when f panics (the scope then raises the panic here)
                let _done = Done(done, caller);
                *result = Some(f());
            });
            let mut next = Instant::now() + POLL;
            while !done.load(Ordering::Acquire) {
                std::thread::park_timeout(POLL);
                if !done.load(Ordering::Acquire) {
                    self.check(true, &mut next);
                }
            }
        });
        match result {
            Some(v) => v,
            None => unreachable!("the scope ends after its task"),
        }
    }
}

/// Sets its flag and wakes the calling thread when dropped.
struct Done<'a>(&'a AtomicBool, std::thread::Thread);

impl Drop for Done<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Release);
        self.1.unpark();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_deadline_stops_and_none_never() {
        let mut next = Instant::now();
        assert_eq!(Watch::new(0.0, None).check(false, &mut next), Some(Why::OutOfTime));
        assert_eq!(Watch::new(f64::INFINITY, None).check(true, &mut next), None);
        assert_eq!(Watch::new(1e300, None).check(true, &mut next), None);
        assert_eq!(Watch::none().check(true, &mut next), None);
        let yes = || true;
        let w = Watch::new(f64::INFINITY, Some(&yes));
        assert_eq!(w.check(false, &mut next), None);
        assert_eq!(w.check(true, &mut next), Some(Why::Interrupted));
        // the flag stops every thread
        assert_eq!(w.check(false, &mut next), Some(Why::Interrupted));
        assert_eq!(w.around(|| 7), 7);
    }

    #[test]
    fn a_panic_around_comes_back_not_a_hang() {
        let no = || false;
        let w = Watch::new(f64::INFINITY, Some(&no));
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| w.around(|| -> i32 { panic!("inside") })));
        assert!(r.is_err());
    }
}
