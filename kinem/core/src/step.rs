//! The step (docs/solver.md, "The march"): one instant from the accepted
//! `MarchState`: the predictor (Taylor, or Lagrange without rates), the
//! chord from the Hermite start with the last instant's LU to rounding and
//! the LU there (newton::chord), or, at a march's first instant and where
//! the chord contracts too slowly, Newton-Raphson with the final correction
//! and the LU at the corrected q (newton::settle); the acceptance test
//! (accept::rejected) and the velocity and acceleration solves from that one
//! LU (Eqs. 3.13, 3.15); the state moves to the instant when it is accepted.
//! It runs on any `Step` operations: the core's own (crate::march::Native:
//! kinem's LU, for the march and Plan.step) and, through the bindings,
//! Python's (another linear solver: LAPACK, SuperLU, least squares; a
//! trace; modified Newton). The tracker (kinem/tracking.py) keeps the
//! policy around it: halving, stepping over a limit position, landing on an
//! output instant.
use crate::accept::{codes, gap, gap_keep, hermite, lagrange, predicted, rejected, taylor, Why};
use crate::families::At;
use crate::model::Kin;
use crate::newton::{chord, settle, Ops, Settled, RECENT};

/// A pivot ratio below this is a singular factorisation: pivot ratio 0 and
/// det sign 0 (kinem.linalg.PIVOT_RATIO, the other solvers' bound: about 1e3
/// machine epsilon; a Jacobian that has really lost rank gives pivots of
/// order epsilon).
pub const SINGULAR: f64 = 1e-13;

codes! {
    /// What a step does (kinem.native.Mode).
    pub enum Mode {
        /// the next instant from the last accepted one (from the estimates in
        /// q when none is: the march's assembly, judged by the pivot floor)
        Track = 0 => "TRACK",
        /// a step over a bifurcation: a det flip is accepted
        Over = 1 => "OVER",
        /// an output instant near a singular configuration solved directly:
        /// Taylor's predictor (the state's rates solved first when it has
        /// none), the same det sign, and the acceptance test on one more
        /// correction at the final q (`Step::probe`), not the last one
        Direct = 2 => "DIRECT",
        /// the tracker's assembly from the estimates in q: any converged state
        /// whose factorisation is regular (NearSingular otherwise: Python
        /// diagnoses it)
        Assemble = 3 => "ASSEMBLE",
        /// the state's own rates at its q and t, nothing else (NearSingular
        /// where its factorisation is singular)
        Rates = 4 => "RATES",
    }
}

pub struct Settings {
    pub tolerance: f64,
    pub max_iterations: usize,
    pub max_step: f64,
    /// the pivot ratio below which a state is near-singular (kinem.tracking.singular_pivot)
    pub floor: f64,
    /// solve velocities and accelerations (and predict by Taylor from them)
    pub rates: bool,
}

/// The accepted state a step or a march starts from and leaves at its
/// last accepted instant (kinem.native.MarchState).
#[derive(Clone, Debug)]
pub struct MarchState {
    pub q: Vec<f64>,
    pub qd: Vec<f64>,
    pub qdd: Vec<f64>,
    /// qd and qdd hold the rates at q
    pub rates: bool,
    /// the time of the accepted state (NaN: none yet, q holds estimates)
    pub t: f64,
    /// the det sign of its factorisation
    pub det: i32,
    /// the last three accepted q (3 n) and their times, oldest first (NaN:
    /// none), when the steps solve no rates (Lagrange's predictor)
    pub h: Vec<f64>,
    pub tt: [f64; 3],
    /// the accepted state before this one (q, qd, qdd: n each) and its time
    /// (NaN: none), when the steps solve rates (the chord's Hermite start)
    pub prev: [Vec<f64>; 3],
    pub before: f64,
}

impl MarchState {
    /// The estimates q, no accepted state yet.
    pub fn new(q: &[f64]) -> Self {
        let n = q.len();
        MarchState {
            q: q.to_vec(),
            qd: vec![0.0; n],
            qdd: vec![0.0; n],
            rates: false,
            t: f64::NAN,
            det: 0,
            h: vec![0.0; 3 * n],
            tt: [f64::NAN; 3],
            prev: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            before: f64::NAN,
        }
    }

    /// Back to the estimates in q: nothing accepted (`new`'s state, in the
    /// buffers it has: no allocation at every march's start).
    pub fn restart(&mut self) {
        let MarchState { q: _, qd, qdd, rates, t, det, h, tt, prev, before } = self;
        for v in [qd, qdd, h] {
            v.fill(0.0);
        }
        for p in prev.iter_mut() {
            p.fill(0.0);
        }
        (*rates, *t, *det, *tt, *before) = (false, f64::NAN, 0, [f64::NAN; 3], f64::NAN);
    }

    /// Takes the state q (into which `Step::q` has settled) at t, det sign
    /// `det`, as the last accepted one; `rates`: the steps solve rates (the
    /// caller then puts them in qd, qdd, or calls `no_rates`), else the
    /// Lagrange history moves on.
    #[inline(always)]
    pub fn take(&mut self, q: &[f64], t: f64, det: i32, rates: bool) {
        self.retire(rates);
        self.q.copy_from_slice(q);
        self.taken(t, det, rates);
    }

    /// `take` from q in `kept` (n), which is swapped in where the steps
    /// solve rates (`kept` then holds what was the state before the last:
    /// room for the next), not copied.
    #[inline(always)]
    pub fn take_kept(&mut self, kept: &mut Vec<f64>, t: f64, det: i32, rates: bool) {
        self.retire(rates);
        if rates {
            std::mem::swap(&mut self.q, kept);
        } else {
            self.q.copy_from_slice(kept);
        }
        self.taken(t, det, rates);
    }

    /// With rates, the last state becomes the earlier one of the Hermite
    /// start: buffers swapped, not copied (q, qd, qdd are then the caller's to fill).
    #[inline(always)]
    fn retire(&mut self, rates: bool) {
        if rates {
            let [pq, pqd, pqdd] = &mut self.prev;
            std::mem::swap(pq, &mut self.q);
            std::mem::swap(pqd, &mut self.qd);
            std::mem::swap(pqdd, &mut self.qdd);
            self.before = self.t;
        }
    }

    /// After q was taken at t: the Lagrange history (without rates), the flags.
    #[inline(always)]
    fn taken(&mut self, t: f64, det: i32, rates: bool) {
        let n = self.q.len();
        if !rates {
            self.tt.copy_within(1..3, 0);
            self.h.copy_within(n..3 * n, 0);
            self.tt[2] = t;
            self.h[2 * n..3 * n].copy_from_slice(&self.q);
        }
        self.rates = false;
        self.t = t;
        self.det = det;
    }

    /// After `take` with rates, where none are solved (a singular
    /// factorisation): qd and qdd keep the last state's, as before it.
    #[cold]
    pub fn no_rates(&mut self) {
        self.qd.copy_from_slice(&self.prev[1]);
        self.qdd.copy_from_slice(&self.prev[2]);
    }
}

/// How a step ended: why (Accepted: the state moved to it), the Newton
/// iterations and residual, the pivot ratio and det sign of the final
/// factorisation (0 and 0 where it is singular), the last Newton correction
/// (Direct: one more), and the correction from the predictor and the
/// predicted motion (dimensionless).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    pub why: Why,
    pub iterations: usize,
    pub residual: f64,
    pub pivot: f64,
    pub det: i32,
    pub correction: f64,
    pub corr: f64,
    pub motion: f64,
}

impl Outcome {
    fn of(why: Why, s: &Settled) -> Self {
        Outcome {
            why,
            iterations: s.iterations,
            residual: s.residual,
            pivot: 0.0,
            det: 0,
            correction: s.last_step,
            corr: 0.0,
            motion: 0.0,
        }
    }
}

/// The operations of a step beyond Newton's (`Ops`), on the configuration
/// the implementor holds.
pub trait Step: Ops {
    /// Starts a solve at (q, t).
    fn start(&mut self, q: &[f64], t: f64) -> Result<(), Self::Error>;
    /// Starts a solve at t from the q its caller writes into the room
    /// returned (the operations' own q: no copy), with the columns' scales
    /// (`col_scale`); None: the caller uses `start`.
    fn place(&mut self, _t: f64) -> Option<(&mut [f64], &[f64])> {
        None
    }
    /// Brings q from where the operations keep it (after a solve), for `q`.
    fn fetch(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
    /// The configuration q (as of the last `fetch`).
    fn q(&self) -> &[f64];
    /// The pivot ratio and det sign of the factorisation at q.
    fn stats(&mut self) -> Result<(f64, i32), Self::Error>;
    /// qd and qdd at q, t from the factorisation at q (Phi_q qd = nu,
    /// Phi_q qdd = gamma: Eqs. 3.13, 3.15).
    fn rates(&mut self, qd: &mut [f64], qdd: &mut [f64]) -> Result<(), Self::Error>;
    /// The size of one more Newton correction at q with the factorisation
    /// there (dimensionless), q unchanged.
    fn probe(&mut self) -> Result<f64, Self::Error>;
    /// The columns' scales (the dimensionless sizes' units).
    fn col_scale(&self) -> &[f64];
    /// The range of coordinates the step's loops run over where the others
    /// are proved at rest (crate::march's `rest`); None: all n.
    fn moving(&self) -> Option<(usize, usize)> {
        None
    }
}

/// A step's working room across the instants of a march: the operations
/// hold the factorisation at the last accepted q (`held`), the chord's last
/// measured contraction and the instants since (newton::chord's `known`),
/// and room for the predictor and the Hermite start (n each).
pub struct Work {
    pub held: bool,
    memory: Contraction,
    qp: Vec<f64>,
    start: Vec<f64>,
    /// whether the next start adds the last one's error
    bias: Bias,
    /// room for the biased start where the operations give none (`Step::place`)
    biased: Vec<f64>,
    /// the settled q, kept by the correction's gap for the state (MarchState::take_kept)
    kept: Vec<f64>,
}

impl Clone for Work {
    fn clone(&self) -> Self {
        let mut w = Work::new(0, false);
        w.clone_from(self);
        w
    }

    /// Field by field, in the buffers self has (crate::march::Room::set: no allocation).
    fn clone_from(&mut self, s: &Self) {
        let Work { held, memory, qp, start, bias, biased, kept } = self;
        qp.clone_from(&s.qp);
        start.clone_from(&s.start);
        biased.clone_from(&s.biased);
        kept.clone_from(&s.kept);
        (*held, *memory, *bias) = (s.held, s.memory, s.bias);
    }
}

/// Whether the chord's start at the next instant adds the Hermite start's
/// error at the last accepted one (its q minus that start, which `Work`'s
/// `start` keeps): where the last instant was settled by the chord from
/// Hermite's start and the next step is as long (within 1e-6). The
/// quintic's error is of order h^6 and smooth: the biased start's is its
/// change over a step (Jansen leg: median 2.3e-13 -> 4.7e-14 of the sizes).
#[derive(Clone, Copy)]
pub struct Bias {
    /// the step the last start was made over (NaN: its error is not at hand)
    h: f64,
    /// the model is smooth (Kin::smooth): a tabulated outline's or
    /// function's pieces break the error's smoothness (cam_table41: Newton
    /// iterations 15 -> 30 with the bias), so a start there never adds it
    on: bool,
}

impl Bias {
    pub fn new(smooth: bool) -> Self {
        Bias { h: f64::NAN, on: smooth }
    }

    /// Whether a start at a step of length h adds the last start's error.
    #[inline]
    pub fn at(&self, h: f64) -> bool {
        (h - self.h).abs() <= 1e-6 * h
    }

    /// After an instant accepted at a step h: `measured`, settled by the
    /// chord from Hermite's start (kept in `start`), or not.
    #[inline]
    pub fn measure(&mut self, measured: bool, h: f64) {
        self.h = if measured && self.on { h } else { f64::NAN };
    }
}

/// The chord's last measured contraction, what it was measured with and the
/// instants since: what newton::chord takes as `known`. A chord with the
/// factorisation at the last accepted q contracts by about
/// |Phi_q^-1 (Phi_q' - Phi_q)| <= |Phi_q^-1| L |dq| (L: the Jacobian's change per unit
/// motion), so the measured contraction stands for an instant's scaled by
/// the ratio of the instants' motions (the predicted motion from the last
/// accepted q) and of the held factorisations' pivot ratios (|Phi_q^-1|'s
/// proxy), where they grew; for at most `RECENT` instants. The figure kept
/// is the first correction's contraction measured last, or half the one kept
/// before where that is larger: from instant to instant the contraction
/// varies with the start error's direction (cam_roller_circle: 2e-4 and
/// 2.5e-3 at consecutive instants), and a measurement whose second
/// correction is at rounding understates it.
#[derive(Clone, Copy)]
pub struct Contraction {
    theta: f64,
    /// the predicted motion of the instant it was measured at, and the pivot
    /// ratio of the factorisation it was measured with
    motion: f64,
    pivot: f64,
    age: u32,
    /// the pivot ratio of the factorisation held now
    held: f64,
}

impl Contraction {
    pub fn none() -> Self {
        Contraction { theta: f64::INFINITY, motion: 0.0, pivot: 0.0, age: RECENT + 1, held: 0.0 }
    }

    /// The contraction the next chord may assume at an instant of predicted
    /// motion `motion` (infinite: none recent enough, or a singular held factorisation).
    #[inline]
    pub fn known(&self, motion: f64) -> f64 {
        if self.age <= RECENT && self.held > 0.0 {
            // NaN ratios (no motion at either instant) leave the factor 1
            self.theta * 1f64.max(motion / self.motion) * 1f64.max(self.pivot / self.held)
        } else {
            f64::INFINITY
        }
    }

    /// After a chord that settled at an instant of predicted motion
    /// `motion`, with the first correction's contraction it measured (NaN: none).
    #[inline]
    pub fn chorded(&mut self, measured: f64, motion: f64) {
        if measured.is_nan() {
            self.age += 1;
        } else {
            let kept = if self.age <= RECENT && self.theta < f64::INFINITY { 0.5 * self.theta } else { 0.0 };
            (self.theta, self.motion, self.pivot, self.age) = (measured.max(kept), motion, self.held, 0);
        }
    }

    /// A chord gave up: no contraction at hand (the held factorisation's figure kept).
    pub fn forget(&mut self) {
        *self = Contraction { held: self.held, ..Contraction::none() };
    }

    /// The factorisation at an accepted q, of pivot ratio `pivot`, is held for the next chord.
    #[inline]
    pub fn hold(&mut self, pivot: f64) {
        self.held = pivot;
    }
}

/// The predictor at t into qp: at the first instant the state's q, else
/// Taylor's from its rates (`taylor_from`) or Lagrange's from its last
/// instants. Whether the acceptance test judges the jump from it (not at the
/// first instant, nor from a Lagrange predictor of fewer than two instants).
#[inline(always)]
pub fn predict(st: &MarchState, t: f64, taylor_from: bool, qp: &mut [f64]) -> bool {
    if st.t.is_nan() {
        qp.copy_from_slice(&st.q);
        false
    } else if taylor_from {
        taylor(&st.q, &st.qd, &st.qdd, t - st.t, qp);
        true
    } else {
        lagrange(t, &st.tt, &st.h, qp) >= 1
    }
}

/// Whether the chord starts at t from Hermite's extrapolation: the last two
/// accepted instants at hand and t near.
#[inline]
pub fn hermite_near(st: &MarchState, t: f64) -> bool {
    st.before.is_finite() && t - st.t <= 2.0 * (st.t - st.before)
}

/// Hermite's start at t into `start` (which holds the last one) and, with
/// the last one's error (st's q minus it) added where `bias` says so, into
/// `room`: the chord's start (where `hermite_near`). Three short loops,
/// each vectorised (one loop of the three was not).
#[inline(always)]
pub fn biased_start(st: &MarchState, t: f64, taylor: Option<&[f64]>, start: &mut [f64], bias: &Bias, room: &mut [f64]) {
    let n = start.len();
    let (room, q) = (&mut room[..n], &st.q[..n]);
    let biased = bias.at(t - st.t);
    if biased {
        for j in 0..n {
            room[j] = q[j] - start[j];
        }
    }
    hermite_start(st, t, taylor, start);
    if biased {
        for j in 0..n {
            room[j] += start[j];
        }
    } else {
        room.copy_from_slice(start);
    }
}

/// Hermite's start at t into `start` (where `hermite_near`).
#[inline(always)]
fn hermite_start(st: &MarchState, t: f64, taylor: Option<&[f64]>, start: &mut [f64]) {
    let n = st.q.len();
    let p = [&st.prev[0][..n], &st.prev[1][..n], &st.prev[2][..n]];
    hermite(p, [&st.q[..], &st.qd[..], &st.qdd[..]], st.t - st.before, t - st.t, taylor, start);
}

/// The pivot ratio (0 where below SINGULAR) and det sign (0 there) of the
/// factorisation at a settled q from `stats`, and the det sign the
/// acceptance test compares it with: the state's, or its own at the first instant.
pub fn signs((ratio, det): (f64, i32), st: &MarchState) -> (f64, i32, i32) {
    let (pivot, det) = if ratio >= SINGULAR { (ratio, det) } else { (0.0, 0) };
    (pivot, det, if st.t.is_nan() { det } else { st.det })
}

impl Work {
    /// Each of its buffers of positions holds q at the coordinates `at`
    /// (crate::march's `rest`: those the step's loops leave out from here).
    pub fn rest(&mut self, at: &[u32], q: &[f64]) {
        for &j in at {
            let j = j as usize;
            (self.qp[j], self.start[j], self.biased[j], self.kept[j]) = (q[j], q[j], q[j], q[j]);
        }
    }

    /// No factorisation held: the first step starts with Newton; `smooth`:
    /// the model's (Kin::smooth: Hermite's start carries its last error).
    pub fn new(n: usize, smooth: bool) -> Self {
        Work {
            held: false,
            memory: Contraction::none(),
            qp: vec![0.0; n],
            start: vec![0.0; n],
            bias: Bias::new(smooth),
            biased: vec![0.0; n],
            kept: vec![0.0; n],
        }
    }
}

/// One instant t from the accepted state `st` (or, with none, the assembly
/// from its estimates) by `mode`; the state moves to it when accepted.
pub fn step<O: Step>(
    ops: &mut O,
    st: &mut MarchState,
    t: f64,
    s: &Settings,
    mode: Mode,
    c: &mut Work,
) -> Result<Outcome, O::Error> {
    let Work { qp, start, bias, biased, kept, .. } = c;
    let (qp, start) = (&mut qp[..], &mut start[..]);
    let first = st.t.is_nan();
    let taylor_from = (s.rates || mode == Mode::Direct) && !first;
    if (taylor_from && !st.rates) || mode == Mode::Rates {
        // the state's own rates, from the factorisation at its q (none where it is singular)
        ops.start(&st.q, st.t)?;
        ops.factor(true)?;
        c.held = false;
        let mut out =
            Outcome::of(Why::NearSingular, &Settled { iterations: 0, residual: 0.0, converged: true, last_step: 0.0 });
        let (ratio, det) = ops.stats()?;
        if !(ratio >= SINGULAR) {
            return Ok(out);
        }
        ops.rates(&mut st.qd, &mut st.qdd)?;
        st.rates = true;
        if mode == Mode::Rates {
            (out.why, out.pivot, out.det) = (Why::Accepted, ratio, det);
            return Ok(out);
        }
    }
    // the chord with the last instant's factorisation, from the Hermite start when the last two
    // instants are at hand, else (or when it contracts too slowly) Newton from the predictor
    let hermite = c.held && hermite_near(st, t);
    let (judge, motion);
    if hermite && taylor_from {
        // Taylor's predictor, the motion and the chord's start in one pass (accept::predicted)
        let (a, h, on) = (st.t - st.before, t - st.t, bias.at(t - st.t));
        // the moving range alone where the others are at rest (Step::moving), and the weights and
        // h^2 finite (h <= 2 a here): there Taylor's, Hermite's and the biased start are q again
        let (lo, hi) = match ops.moving() {
            Some(r) if a < 1e150 => r,
            _ => (0, st.q.len()),
        };
        let (cs, ps) = (
            [&st.q[lo..hi], &st.qd[lo..hi], &st.qdd[lo..hi]],
            [&st.prev[0][lo..hi], &st.prev[1][lo..hi], &st.prev[2][lo..hi]],
        );
        judge = true;
        motion = match ops.place(t) {
            Some((q, col_scale)) => {
                let (col_scale, q) = (&col_scale[lo..hi], &mut q[lo..hi]);
                predicted(cs, ps, a, h, col_scale, on, &mut qp[lo..hi], &mut start[lo..hi], q)
            }
            None => {
                let (cs, ps) =
                    ([&st.q[..], &st.qd[..], &st.qdd[..]], [&st.prev[0][..], &st.prev[1][..], &st.prev[2][..]]);
                let motion = predicted(cs, ps, a, h, ops.col_scale(), on, qp, start, biased);
                ops.start(biased, t)?;
                motion
            }
        };
    } else if hermite {
        judge = predict(st, t, taylor_from, qp);
        motion = gap(qp, &st.q, ops.col_scale());
        // Hermite's start into `start`, and with the last instant's error (Bias) into the operations' q
        let taylor = if taylor_from { Some(&qp[..]) } else { None };
        match ops.place(t) {
            Some((q, _)) => biased_start(st, t, taylor, start, bias, q),
            None => {
                biased_start(st, t, taylor, start, bias, biased);
                ops.start(biased, t)?;
            }
        }
    } else {
        judge = predict(st, t, taylor_from, qp);
        motion = gap(qp, &st.q, ops.col_scale());
        ops.start(qp, t)?;
    }
    let chorded = if c.held { chord(ops, s.tolerance, s.max_step, c.memory.known(motion))? } else { None };
    c.held = false;
    let settled = match chorded {
        Some((settled, measured)) => {
            c.memory.chorded(measured, motion);
            settled
        }
        None => {
            c.memory.forget();
            ops.start(qp, t)?;
            settle(ops, s.tolerance, s.max_iterations, s.max_step, true)?
        }
    };
    if !settled.converged {
        return Ok(Outcome::of(Why::NotConverged, &settled));
    }
    let mut out = Outcome::of(Why::Accepted, &settled);
    let previous;
    (out.pivot, out.det, previous) = signs(ops.stats()?, st);
    ops.fetch()?;
    // the correction from the predictor, keeping the settled q for the state (take_kept); over the
    // moving range where the others are at rest (their q the predictor's and the kept one's)
    let (lo, hi) = ops.moving().unwrap_or((0, qp.len()));
    let corr = gap_keep(&ops.q()[lo..hi], &qp[lo..hi], &ops.col_scale()[lo..hi], &mut kept[lo..hi]);
    (out.corr, out.motion) = (corr, motion);
    out.why = match mode {
        Mode::Assemble if out.pivot > 0.0 && ops.q().iter().all(|v| v.is_finite()) => Why::Accepted,
        Mode::Assemble => Why::NearSingular,
        Mode::Direct if out.det != previous => Why::DetFlip,
        Mode::Direct => {
            out.correction = ops.probe()?;
            let (a, b) = (out.corr, out.motion);
            rejected(out.pivot, out.correction, out.det, previous, a, b, true, s.floor, s.tolerance, false)
        }
        _ => {
            let flip = mode == Mode::Over;
            let (a, b) = (out.corr, out.motion);
            rejected(out.pivot, out.correction, out.det, previous, a, b, judge, s.floor, s.tolerance, flip)
        }
    };
    if out.why != Why::Accepted {
        return Ok(out);
    }
    // the factorisation at the accepted q serves the rates and the next instant's chord
    c.held = true;
    c.memory.hold(out.pivot);
    bias.measure(hermite && chorded.is_some(), t - st.t);
    st.take_kept(kept, t, out.det, s.rates);
    if s.rates && out.pivot > 0.0 {
        ops.rates(&mut st.qd, &mut st.qdd)?;
        st.rates = true;
    } else if s.rates {
        st.no_rates();
    }
    Ok(out)
}

/// qd, qdd at (q, t) (e: e^{i q}) with `solve` (x with Phi_q x = b, the
/// factorisation at q): Phi_q qd = nu, Phi_q qdd = gamma (Eqs. 3.13, 3.15).
/// nu and gamma: room for m values each; `jac`: the Jacobian values at q,
/// if at hand (Kin::gamma_with reads the revolutes' A s' there). Every
/// step's rates, whatever its solver.
#[allow(clippy::too_many_arguments)]
pub fn rates_with<E>(
    kin: &Kin,
    at: &At,
    jac: Option<&[f64]>,
    nu: &mut [f64],
    gamma: &mut [f64],
    qd: &mut [f64],
    qdd: &mut [f64],
    solve: impl FnMut(&[f64], &mut [f64]) -> Result<(), E>,
) -> Result<(), E> {
    kin.nu(at.t, nu);
    rates_from::<false, E>(kin, at, jac, nu, gamma, qd, qdd, solve)
}

/// `rates_with` where nu already holds nu at t (crate::march::Native:
/// Kin::nu_over); OVER: gamma's room holds the last gamma of this model
/// (or zeros), whose constant rows are not written again (Kin::gamma_over).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn rates_from<const OVER: bool, E>(
    kin: &Kin,
    at: &At,
    jac: Option<&[f64]>,
    nu: &[f64],
    gamma: &mut [f64],
    qd: &mut [f64],
    qdd: &mut [f64],
    mut solve: impl FnMut(&[f64], &mut [f64]) -> Result<(), E>,
) -> Result<(), E> {
    solve(nu, qd)?;
    if OVER {
        kin.gamma_over(at, qd, jac, gamma);
    } else {
        kin.gamma_with(at, qd, jac, gamma);
    }
    solve(gamma, qdd)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hermite's start carrying the last start's error (q = sin 3t, steps
    /// of 0.02): the biased start's error below a tenth of the unbiased
    /// one's (the error is smooth: its change over a step is of order h^7);
    /// unbiased where the step changed, or the model is not smooth.
    /// A restarted state is a new one from its q, whatever it held (the
    /// march restarts its caller's state at every start from k = 0).
    #[test]
    fn a_restarted_state_is_a_new_one() {
        let q = [0.5, -1.0, 2.0];
        let mut st = MarchState::new(&q);
        (st.qd[1], st.qdd[2], st.h[4], st.prev[2][0]) = (3.0, -0.0, 7.0, 1.5);
        (st.rates, st.t, st.det, st.tt, st.before) = (true, 0.25, -1, [0.0, 0.1, 0.2], 0.1);
        st.restart();
        assert_eq!(format!("{st:?}"), format!("{:?}", MarchState::new(&q)));
    }

    #[test]
    fn a_start_carrying_the_last_error_lands_closer() {
        let f = |t: f64| [(3.0 * t).sin()];
        let d = |t: f64| [3.0 * (3.0 * t).cos()];
        let dd = |t: f64| [-9.0 * (3.0 * t).sin()];
        let state = |t0: f64, t1: f64| {
            let mut st = MarchState::new(&f(t1));
            (st.qd, st.qdd, st.t, st.rates) = (d(t1).to_vec(), dd(t1).to_vec(), t1, true);
            st.prev = [f(t0).to_vec(), d(t0).to_vec(), dd(t0).to_vec()];
            st.before = t0;
            st
        };
        let h = 0.02;
        for smooth in [true, false] {
            let (mut start, mut room, mut bias) = ([0.0], [0.0], Bias::new(smooth));
            let mut errors = Vec::new();
            for k in 0..3 {
                let t1 = 0.3 + k as f64 * h;
                biased_start(&state(t1 - h, t1), t1 + h, None, &mut start, &bias, &mut room);
                errors.push(((room[0] - f(t1 + h)[0]).abs(), (start[0] - f(t1 + h)[0]).abs()));
                bias.measure(true, h);
            }
            let (biased, unbiased) = errors[2];
            assert!(unbiased > 1e-12 && errors[0].0 == errors[0].1, "{errors:?}");
            if smooth {
                assert!(biased < 0.1 * unbiased, "{errors:?}");
            } else {
                assert_eq!(biased, unbiased);
            }
            // a step of another length: unbiased
            let t1 = 0.5;
            biased_start(&state(t1 - h, t1), t1 + 1.5 * h, None, &mut start, &bias, &mut room);
            assert_eq!(room, start);
        }
    }

    /// The contraction a chord may assume: none before a measurement, with a
    /// singular held factorisation or after RECENT instants; the measured
    /// one where motion and pivot ratio have not grown, scaled up (exactly,
    /// tolerance 0) where the motion grew or the pivot ratio fell; a smaller
    /// measurement keeps half the last figure.
    #[test]
    fn a_measured_contraction_stands_scaled_by_motion_and_pivot() {
        let mut c = Contraction::none();
        c.hold(0.1);
        assert_eq!(c.known(1e-3), f64::INFINITY);
        c.chorded(4e-3, 1e-3);
        c.hold(0.1);
        assert_eq!(c.known(1e-3), 4e-3);
        assert_eq!(c.known(0.5e-3), 4e-3);
        assert_eq!(c.known(3e-3), 4e-3 * 3.0);
        c.hold(0.05);
        assert_eq!(c.known(3e-3), 4e-3 * 3.0 * 2.0);
        c.hold(0.0);
        assert_eq!(c.known(1e-3), f64::INFINITY);
        c.hold(0.1);
        for _ in 0..RECENT {
            c.chorded(f64::NAN, 1e-3);
        }
        assert_eq!(c.known(1e-3), 4e-3);
        c.chorded(f64::NAN, 1e-3);
        assert_eq!(c.known(1e-3), f64::INFINITY);
        c.chorded(2e-3, 0.0);
        assert_eq!(c.known(0.0), 2e-3);
        // a smaller measurement keeps half the last figure (exactly), a larger one is taken
        c.chorded(1e-4, 0.0);
        assert_eq!(c.known(0.0), 1e-3);
        c.chorded(3e-3, 0.0);
        assert_eq!(c.known(0.0), 3e-3);
        c.forget();
        assert_eq!(c.known(0.0), f64::INFINITY);
    }
}
