//! The one Newton-Raphson of kinem (Eqs. 4.41, 4.42; docs/solver.md,
//! "Residual scaling and convergence"), with the final correction and the
//! factorisation at the corrected configuration that the conditioning
//! monitor and the rate solves use. It runs on three operations (`Ops`):
//! the step's own (kinem's LU, kinem/core/src/step.rs and march.rs) and, for the
//! step-by-step analysis, Python's (any linear solver: LAPACK, SuperLU,
//! least squares, minimum-norm steps; kinem.analysis).

/// Newton steps are limited to this length in dimensionless coordinates
/// (lengths over L, angles in radians): a rough estimate never sends the
/// assembly many turns away, and tracking steps are far shorter anyway.
pub const MAX_STEP: f64 = 0.5;
/// A final correction (dimensionless) above this calls for one more: at the
/// default tolerance it is about 1e-12; at a loose one (1e-6) about the
/// tolerance, and the first correction, made with the last iteration's LU,
/// leaves that times the iteration's step.
pub const POLISH: f64 = 1e-10;

/// What `settle` works on: the configuration q lives in the implementor.
pub trait Ops {
    type Error;
    /// Phi at q and its max scaled residual (it: the Newton iteration, -1
    /// after convergence, where the residual is not read: an implementor may
    /// return 0 there).
    fn evaluate(&mut self, it: i64) -> Result<f64, Self::Error>;
    /// The factorisation at q (final: the one left at the end; a
    /// step-by-step run with Jacobian reuse may keep a nearby one otherwise).
    fn factor(&mut self, last: bool) -> Result<(), Self::Error>;
    /// q -= Phi_q^-1 Phi, the step limited to `limit`; returns its size
    /// (dimensionless) before the limit.
    fn correct(&mut self, limit: f64) -> Result<f64, Self::Error>;
}

/// How a `settle` ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settled {
    pub iterations: usize,
    /// the max scaled residual of the last iteration
    pub residual: f64,
    pub converged: bool,
    /// the last correction's size: the polishing one's when there was one,
    /// else the final correction's (0 without `finish`). At a regular root
    /// the polishing correction is about the square of the first; at a
    /// singular one Newton converges linearly and it is of the first's order
    /// (the acceptance test judges it).
    pub last_step: f64,
}

/// Newton-Raphson from q to Phi(q, t) = 0, every scaled residual at or
/// below the tolerance, steps limited to max_step. With `finish`, then the
/// final correction (the position error falls from about the tolerance to
/// about its square) with the last iteration's factorisation (a fresh one
/// when q already converged), one more when that correction is above
/// POLISH, and the factorisation at the corrected q, left in the operations
/// for the pivot ratio, det sign and rate solves.
pub fn settle<O: Ops>(
    ops: &mut O,
    tolerance: f64,
    max_iterations: usize,
    max_step: f64,
    finish: bool,
) -> Result<Settled, O::Error> {
    let (mut w, mut x) = (Settling::new(tolerance, max_iterations, max_step, finish), 0.0);
    loop {
        x = match w.next(x) {
            Ask::Evaluate(it) => ops.evaluate(it)?,
            Ask::Factor(last) => ops.factor(last).map(|_| 0.0)?,
            Ask::Correct(limit) => ops.correct(limit)?,
            Ask::Done(settled) => return Ok(settled),
        };
    }
}

/// `settle` a step at a time (crate::lanes takes it in lockstep over its
/// lanes): `next` takes the result of the operation asked last (a
/// residual, a correction's size; nothing for a factorisation) and asks the
/// next one. The one place of Newton's decisions.
#[derive(Clone, Copy)]
pub struct Settling {
    tolerance: f64,
    max_iterations: usize,
    max_step: f64,
    finish: bool,
    it: usize,
    r: f64,
    step: f64,
    converged: bool,
    refined: bool,
    polished: bool,
    polish: bool,
    /// where the operation asked last was asked
    at: Site,
}

/// Settling's call sites.
#[derive(Clone, Copy)]
enum Site {
    Start,
    Evaluated,
    Polished,
    Refined,
    Factored,
    Iterated,
    RefinedAfter,
}

/// An operation Newton asks (Ops's, with its argument), or its end.
#[derive(Clone, Copy)]
pub enum Ask {
    Evaluate(i64),
    Factor(bool),
    /// a correction limited to this size
    Correct(f64),
    Done(Settled),
}

impl Settling {
    pub fn new(tolerance: f64, max_iterations: usize, max_step: f64, finish: bool) -> Settling {
        Settling {
            tolerance,
            max_iterations,
            max_step,
            finish,
            it: 0,
            r: f64::INFINITY,
            step: 0.0,
            converged: false,
            refined: false,
            polished: false,
            polish: false,
            at: Site::Start,
        }
    }

    fn done(&self, converged: bool) -> Ask {
        Ask::Done(Settled { iterations: self.it, residual: self.r, converged, last_step: self.step })
    }

    /// The next operation, given the result `x` of the last one.
    pub fn next(&mut self, x: f64) -> Ask {
        match self.at {
            Site::Start => {}
            Site::Evaluated => {
                if !self.converged {
                    self.r = x;
                    if self.r <= self.tolerance {
                        self.converged = true;
                        if !self.finish {
                            return Ask::Done(Settled {
                                iterations: self.it,
                                residual: self.r,
                                converged: true,
                                last_step: 0.0,
                            });
                        }
                    } else if !(self.r < f64::INFINITY) || self.it == self.max_iterations {
                        return self.done(false);
                    }
                }
                return self.corrections();
            }
            Site::Polished => {
                (self.step, self.polish, self.polished) = (x, false, true);
                return self.factor();
            }
            Site::Refined => {
                (self.step, self.refined) = (x, true);
                return self.factor();
            }
            Site::Factored => return self.after_factor(),
            Site::Iterated => self.it += 1,
            Site::RefinedAfter => (self.step, self.refined) = (x, true),
        }
        self.top()
    }

    /// The loop's head: evaluate unless converged and not polishing.
    fn top(&mut self) -> Ask {
        if !self.converged || self.polish {
            self.at = Site::Evaluated;
            return Ask::Evaluate(if self.converged { -1 } else { self.it as i64 });
        }
        self.corrections()
    }

    /// The polishing correction, or the first after convergence, then the factorisation.
    fn corrections(&mut self) -> Ask {
        if self.polish {
            self.at = Site::Polished;
            return Ask::Correct(f64::INFINITY);
        }
        if self.converged && !self.refined && self.it > 0 {
            self.at = Site::Refined;
            return Ask::Correct(f64::INFINITY);
        }
        self.factor()
    }

    fn factor(&mut self) -> Ask {
        self.at = Site::Factored;
        Ask::Factor(self.refined)
    }

    fn after_factor(&mut self) -> Ask {
        if !self.converged {
            self.at = Site::Iterated;
            Ask::Correct(self.max_step)
        } else if !self.refined {
            self.at = Site::RefinedAfter;
            Ask::Correct(f64::INFINITY)
        } else if self.step > POLISH && !self.polished {
            self.polish = true;
            self.top()
        } else {
            self.done(true)
        }
    }
}

/// A chord correction (with a factorisation from another configuration:
/// the previous instant's) that shrinks the last one by less than this
/// factor calls for fresh factorisations: Newton's corrections then cost
/// less than the chord's remaining ones.
pub const CONTRACTION: f64 = 0.03;
/// The chord stops when its last correction is this small (dimensionless;
/// it leaves at most itself), or when its error estimate (the correction
/// times theta / (1 - theta), theta the contraction) is at or below `NOISE`:
/// rounding of the positions, so that the factorisation at the final q, the
/// instant's only one, gives the rates to rounding.
pub const ROUNDING: f64 = 2e-15;
/// A correction this small that no longer contracts is rounding noise
/// (dimensionless): in their fast phases the Jansen leg's and the peers'
/// four-bar's corrections stall at 2e-15 to 4e-15 (round 12, one more
/// correction forced after each chord), and MARGIN asks for more
/// corrections near that floor than the estimate without it did. The
/// error estimate's bound too (round 25): at ROUNDING it asked a second
/// correction in 106 of the Jansen leg's 498 chords, 86 of them where the
/// first had left no more than this; at this bound, one correction forced
/// after every stop measured at most 3.6e-15 there.
pub const NOISE: f64 = 4.0 * ROUNDING;
/// At most this many chord corrections, then Newton: six since a later
/// correction's estimate carries MARGIN (round 12), where a Lagrange start
/// (positions only) may take one more to prove (quick_return_1's
/// positions-only run: 503 factorisations with five, 287 with six).
pub const CHORD_STEPS: usize = 6;
/// A contraction measured this many instants ago or less may stand for the
/// current one (scaled by the instants' motions and pivot ratios,
/// crate::step::Contraction, and times `MARGIN`): the chord then stops after its
/// first correction when that times the contraction is at rounding. The
/// scaling follows the contraction's drift; the age bounds how far the
/// Jacobian's curvature it assumes is carried (any chord whose first
/// correction is not proved measures a new one).
pub const RECENT: u32 = 100;
/// The recent contraction times this stands for a chord's first one, and a
/// measured one times this (not below the first's) for the next. What it
/// covers was measured (docs/benchmarks.md, round 12: every chord that
/// made a second correction, its first contraction over the recent one):
/// at most 1.96 on the Jansen leg, 2.47 on the peers' four-bar, 4.32 at
/// worst over the cases (pin_in_slot, whose chords never stop after one
/// correction); and every chord, made to take one more correction where it
/// stopped, left at most its claim or the rounding noise (about 3e-15 on
/// the Jansen leg's fast phases), but for one phase of the peers' four-bar
/// (1.2e-14: a second contraction 40 times the first); with the last
/// contraction doubled the Jansen leg's left up to 2.9e-14.
pub const MARGIN: f64 = 4.0;

/// The book's modified Newton-Raphson with the factorisation the
/// operations already hold (the previous instant's, at its corrected q):
/// from q, chord corrections until the residual is at or below the
/// tolerance and the error estimate at rounding (`ROUNDING`), then the
/// factorisation at that q, the instant's only one: the pivot ratio, the
/// det sign, the rates and the next instant's chord. Returns None (q has
/// moved: the caller starts `settle` again from its predictor) when a
/// correction contracts by less than `CONTRACTION`, is not finite, or after
/// `CHORD_STEPS`. The iterations counted are the corrections made before
/// the residual met the tolerance (the others are the final correction, as
/// in `settle`); the last step is the last correction. `known`: a recent
/// contraction (the march's, scaled to this instant, crate::step::Contraction; infinite: none),
/// which, times `MARGIN`, stands for this one's at the first correction; returned
/// with the first correction's contraction measured here (NaN: none, one correction).
pub fn chord<O: Ops>(
    ops: &mut O,
    tolerance: f64,
    max_step: f64,
    known: f64,
) -> Result<Option<(Settled, f64)>, O::Error> {
    let mut c = Chord::new(known);
    for step in 0..CHORD_STEPS {
        let r = ops.evaluate(c.iteration(step, tolerance))?;
        if !c.residual(step, r, tolerance) {
            return Ok(None);
        }
        match c.corrected(step, ops.correct(max_step)?, tolerance) {
            Verdict::Go => {}
            Verdict::Stop => return Ok(None),
            Verdict::Done(settled, measured) => {
                ops.factor(true)?;
                return Ok(Some((settled, measured)));
            }
        }
    }
    Ok(None)
}

/// A chord's running figures, correction by correction: `chord`'s, and
/// each lane's in crate::lanes, whose lanes correct in lockstep.
#[derive(Clone, Copy)]
pub struct Chord {
    previous: f64,
    iterations: usize,
    residual: f64,
    assumed: f64,
    /// the first correction's contraction: the second's size over the first's (NaN: not made)
    first: f64,
}

/// What a chord correction leaves: more to do, done (how it settled, the
/// first correction's contraction: NaN after one correction), or give up.
pub enum Verdict {
    Go,
    Done(Settled, f64),
    Stop,
}

impl Chord {
    /// `known`: `chord`'s.
    pub fn new(known: f64) -> Self {
        Chord {
            previous: f64::INFINITY,
            iterations: 0,
            residual: f64::INFINITY,
            assumed: MARGIN * known,
            first: f64::NAN,
        }
    }

    /// The first correction's assumed contraction where one is known (0: none).
    fn floor(&self) -> f64 {
        if self.assumed < f64::INFINITY {
            self.assumed
        } else {
            0.0
        }
    }

    /// Ops::evaluate's iteration at correction `step` (-1 once the residual met the tolerance).
    pub fn iteration(&self, step: usize, tolerance: f64) -> i64 {
        if self.residual <= tolerance {
            -1
        } else {
            step as i64
        }
    }

    /// The scaled residual r before correction `step`; false (give up) when it is not finite.
    pub fn residual(&mut self, step: usize, r: f64, tolerance: f64) -> bool {
        if !(r < f64::INFINITY) {
            return false;
        }
        if self.residual > tolerance {
            (self.residual, self.iterations) = (r, step);
        }
        true
    }

    /// After correction `step`, of dimensionless size `size`.
    pub fn corrected(&mut self, step: usize, size: f64, tolerance: f64) -> Verdict {
        if !(size < f64::INFINITY) {
            return Verdict::Stop;
        }
        let theta = size / self.previous;
        self.previous = size;
        if step == 1 {
            // what the next chord's first correction assumes: the first contraction, not a
            // later one (the error's direction changes: cam_roller_circle's second is often a
            // tenth of its first, so the last one underestimated the next first by 7 at the median)
            self.first = theta;
        }
        // a correction at rounding leaves at most itself; else the estimate from the contraction,
        // at the noise (NOISE: what a fresh factorisation would leave too): at the first
        // correction the recent one times MARGIN, later the measured one times MARGIN
        // and not below the first's assumed (a later contraction exceeds the one measured before
        // it: the Jansen leg's by up to 20 times, where the error turns to a direction that
        // contracts less)
        let estimate = |theta: f64| theta < 0.5 && size * theta / (1.0 - theta) <= NOISE;
        let assumed = if step == 0 { self.assumed } else { (MARGIN * theta).max(self.floor()) };
        // a later correction at NOISE or below that no longer contracts is the arithmetic's noise:
        // the chord is as converged as a fresh factorisation would leave it (Newton from the
        // predictor would only meet the same floor)
        let stalled = step > 0 && size <= NOISE && theta > CONTRACTION;
        let done = size <= ROUNDING || estimate(assumed) || stalled;
        if self.residual <= tolerance && done {
            let settled =
                Settled { iterations: self.iterations, residual: self.residual, converged: true, last_step: size };
            return Verdict::Done(settled, self.first);
        }
        // a slow contraction gives up to Newton, unless the corrections left reach rounding at it
        // (near convergence they cost less than Newton's fresh factorisations)
        let left = (CHORD_STEPS - 1 - step) as i32;
        let reachable = theta < 0.5 && size * theta.powi(left) <= ROUNDING;
        if theta > CONTRACTION && size > ROUNDING && !reachable {
            return Verdict::Stop;
        }
        Verdict::Go
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Newton on x^2 - 2 = 0 (scaled residual |x^2 - 2|).
    struct Sqrt2 {
        x: f64,
        slope: f64,
        evaluations: usize,
        factorizations: usize,
    }

    impl Ops for Sqrt2 {
        type Error = ();
        fn evaluate(&mut self, _: i64) -> Result<f64, ()> {
            self.evaluations += 1;
            Ok((self.x * self.x - 2.0).abs())
        }
        fn factor(&mut self, _: bool) -> Result<(), ()> {
            self.factorizations += 1;
            self.slope = 2.0 * self.x;
            Ok(())
        }
        fn correct(&mut self, limit: f64) -> Result<f64, ()> {
            let dx = -(self.x * self.x - 2.0) / self.slope;
            let f = if dx.abs() > limit { limit / dx.abs() } else { 1.0 };
            self.x += f * dx;
            Ok(dx.abs())
        }
    }

    #[test]
    fn converges_quadratically_with_the_final_correction() {
        let mut s = Sqrt2 { x: 1.0, slope: 0.0, evaluations: 0, factorizations: 0 };
        let r = settle(&mut s, 1e-12, 25, 0.5, true).unwrap();
        assert!(r.converged && r.iterations <= 6);
        assert!((s.x - 2f64.sqrt()).abs() <= 2.0 * f64::EPSILON);
        // the last factorisation is at the corrected x
        assert_eq!(s.slope, 2.0 * s.x);
    }

    #[test]
    fn the_chord_converges_to_rounding_with_an_old_slope_and_gives_up_on_a_poor_one() {
        // the slope at 1.41 (a previous instant's): contraction about 3e-3, one factorisation at the end
        let mut s = Sqrt2 { x: 1.4143, slope: 2.0 * 1.41, evaluations: 0, factorizations: 0 };
        let (r, theta) = chord(&mut s, 1e-12, 0.5, f64::INFINITY).unwrap().unwrap();
        assert!(r.converged && s.factorizations == 1);
        assert!((s.x - 2f64.sqrt()).abs() <= 2.0 * f64::EPSILON);
        assert_eq!(s.slope, 2.0 * s.x);
        assert!(theta > 1e-4 && theta < 1e-2);
        // a recent contraction at hand: one correction when it makes the estimate rounding
        let mut s = Sqrt2 { x: 2f64.sqrt() + 1e-14, slope: 2.0 * 1.41, evaluations: 0, factorizations: 0 };
        let (_, theta) = chord(&mut s, 1e-12, 0.5, 3e-3).unwrap().unwrap();
        assert!(theta.is_nan() && s.evaluations == 1 && (s.x - 2f64.sqrt()).abs() <= 4.0 * f64::EPSILON);
        // the slope at 1.0: contraction about 0.3, no convergence claimed
        let mut s = Sqrt2 { x: 1.4, slope: 2.0, evaluations: 0, factorizations: 0 };
        assert!(chord(&mut s, 1e-12, 0.5, f64::INFINITY).unwrap().is_none() && s.factorizations == 0);
    }

    /// The chord's verdicts on given sizes (tolerance 1e-12, residual met):
    /// a slow contraction gives up far from rounding but goes on where the
    /// corrections left reach it; a later correction's estimate carries
    /// MARGIN and the first's assumed figure; a stall at the noise is done.
    #[test]
    fn the_chord_gives_up_only_where_rounding_is_out_of_reach() {
        let run = |known: f64, sizes: &[f64]| {
            let mut c = Chord::new(known);
            let mut last = Verdict::Go;
            for (step, &size) in sizes.iter().enumerate() {
                assert!(c.residual(step, 1e-13, 1e-12));
                last = c.corrected(step, size, 1e-12);
            }
            last
        };
        // contraction 0.1 at 1e-10: four corrections leave 1e-14, out of reach
        assert!(matches!(run(f64::INFINITY, &[1e-9, 1e-10]), Verdict::Stop));
        // contraction 0.1 at 5e-14, three corrections left: reachable, go on
        assert!(matches!(run(f64::INFINITY, &[5e-12, 5e-13, 5e-14]), Verdict::Go));
        // contraction 1e-3 at 4e-12: 4e-15 by the measured figure, but 1.6e-14 by MARGIN times it
        assert!(matches!(run(f64::INFINITY, &[4e-9, 4e-12]), Verdict::Go));
        assert!(matches!(run(f64::INFINITY, &[1e-9, 1e-12]), Verdict::Done(..)));
        // the first's assumed figure (4 x 1e-2) stands under a smaller measured one
        assert!(matches!(run(1e-2, &[4e-10, 4e-13]), Verdict::Go));
        assert!(matches!(run(1e-2, &[1e-10, 1e-13]), Verdict::Done(..)));
        // a correction at NOISE that no longer contracts: done, with the first contraction measured
        match run(f64::INFINITY, &[1e-14, 5e-15]) {
            Verdict::Done(s, first) => assert!(s.converged && first == 0.5),
            _ => panic!("a stall at the noise is done"),
        }
    }

    #[test]
    fn reports_no_convergence_after_max_iterations() {
        let mut s = Sqrt2 { x: 1.0, slope: 0.0, evaluations: 0, factorizations: 0 };
        let r = settle(&mut s, 1e-12, 2, 0.5, true).unwrap();
        assert!(!r.converged && r.iterations == 2);
    }
}
