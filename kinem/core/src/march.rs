//! The step and the march over output instants (docs/solver.md, "The
//! march"). `step` takes one instant from the accepted `MarchState`: the
//! predictor (Taylor, or Lagrange without rates), the chord from the Hermite
//! start with the last instant's LU to rounding and the LU there
//! (newton::chord), or, at a march's first instant and where the chord
//! contracts too slowly, Newton-Raphson with the final correction and the LU
//! at the corrected q (newton::settle); the acceptance test
//! (accept::rejected) and the velocity and acceleration solves from that one
//! LU; it updates the state when it accepts. It runs on any `Step`
//! operations: the core's own (`Native`: kinem's LU) and, through the
//! bindings, Python's (another linear solver: LAPACK, SuperLU, least
//! squares; a trace; modified Newton). `run` steps over output instants
//! until one is not accepted and hands it to the tracker
//! (kinem/tracking.py), whose policy (halving, stepping over a limit
//! position, landing on an output instant) calls `step` again.
use crate::accept::{codes, hermite, jump_sizes, lagrange, rejected, taylor, Why};
use crate::families::At;
use crate::lu::{Factors, Layout};
use crate::model::Kin;
use crate::newton::{chord, settle, Ops, Settled, RECENT};
use crate::watch::Watch;
use num_complex::Complex64 as C64;
use std::convert::Infallible;
use std::time::Instant;

/// The march looks at its watch (a deadline, a signal) every this many instants.
const WATCH_EVERY: u32 = 4;

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
    /// the accepted state before this one (q, qd, qdd: 3 n) and its time
    /// (NaN: none), when the steps solve rates (the chord's Hermite start)
    pub prev: Vec<f64>,
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
            prev: vec![0.0; 3 * n],
            before: f64::NAN,
        }
    }

    /// Back to the estimates in q: nothing accepted.
    pub fn restart(&mut self) {
        *self = MarchState::new(&self.q);
    }

    /// Takes the state q (into which `Step::q` has settled) at t, det sign
    /// `det`, as the last accepted one; `rates`: the steps solve rates (the
    /// caller then puts them in qd, qdd), else the Lagrange history moves on.
    #[inline(always)]
    pub fn take(&mut self, q: &[f64], t: f64, det: i32, rates: bool) {
        let n = q.len();
        if rates {
            // the last state becomes the earlier one of the Hermite start
            self.prev[..n].copy_from_slice(&self.q);
            self.prev[n..2 * n].copy_from_slice(&self.qd);
            self.prev[2 * n..].copy_from_slice(&self.qdd);
            self.before = self.t;
        }
        self.q.copy_from_slice(q);
        if !rates {
            self.tt.copy_within(1..3, 0);
            self.h.copy_within(n..3 * n, 0);
            self.tt[2] = t;
            self.h[2 * n..3 * n].copy_from_slice(q);
        }
        self.rates = false;
        self.t = t;
        self.det = det;
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
}

/// A step's working room across the instants of a march: the operations
/// hold the factorisation at the last accepted q (`held`), the chord's last
/// measured contraction and the instants since (newton::chord's `known`),
/// and room for the predictor and the Hermite start (n each).
pub struct Work {
    pub held: bool,
    theta: f64,
    age: u32,
    qp: Vec<f64>,
    start: Vec<f64>,
}

impl Work {
    /// No factorisation held: the first step starts with Newton.
    pub fn new(n: usize) -> Self {
        Work { held: false, theta: f64::INFINITY, age: RECENT + 1, qp: vec![0.0; n], start: vec![0.0; n] }
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
    let n = st.q.len();
    let Work { qp, start, .. } = c;
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
    let h = t - st.t;
    let mut judge = !first;
    if first {
        qp.copy_from_slice(&st.q);
    } else if taylor_from {
        taylor(&st.q, &st.qd, &st.qdd, h, qp);
    } else {
        judge = lagrange(t, &st.tt, &st.h, qp) >= 1;
    }
    // the chord with the last instant's factorisation, from the Hermite start when the last two
    // instants are at hand, else (or when it contracts too slowly) Newton from the predictor
    if c.held && st.before.is_finite() && h <= 2.0 * (st.t - st.before) {
        let p = [&st.prev[..n], &st.prev[n..2 * n], &st.prev[2 * n..]];
        hermite(p, [&st.q[..], &st.qd[..], &st.qdd[..]], st.t - st.before, h, start);
        ops.start(start, t)?;
    } else {
        ops.start(qp, t)?;
    }
    let known = if c.age <= RECENT { c.theta } else { f64::INFINITY };
    let chorded = if c.held { chord(ops, s.tolerance, s.max_step, known)? } else { None };
    c.held = false;
    let settled = match chorded {
        Some((settled, measured)) => {
            if measured.is_nan() {
                c.age += 1;
            } else {
                (c.theta, c.age) = (measured, 0);
            }
            settled
        }
        None => {
            (c.theta, c.age) = (f64::INFINITY, RECENT + 1);
            ops.start(qp, t)?;
            settle(ops, s.tolerance, s.max_iterations, s.max_step, true)?
        }
    };
    if !settled.converged {
        return Ok(Outcome::of(Why::NotConverged, &settled));
    }
    let mut out = Outcome::of(Why::Accepted, &settled);
    let (ratio, det) = ops.stats()?;
    (out.pivot, out.det) = if ratio >= SINGULAR { (ratio, det) } else { (0.0, 0) };
    let previous = if first { out.det } else { st.det };
    ops.fetch()?;
    (out.corr, out.motion) = jump_sizes(ops.q(), qp, &st.q, ops.col_scale());
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
    st.take(ops.q(), t, out.det, s.rates);
    if s.rates && out.pivot > 0.0 {
        ops.rates(&mut st.qd, &mut st.qdd)?;
        st.rates = true;
    }
    Ok(out)
}

/// Per instant: Q, QD, QDD (K n), Newton iterations, residual, pivot ratio,
/// det sign (K); counts: Jacobian evaluations and factorisations, added to.
pub struct Out<'a> {
    pub q: &'a mut [f64],
    pub qd: &'a mut [f64],
    pub qdd: &'a mut [f64],
    pub iterations: &'a mut [i64],
    pub residual: &'a mut [f64],
    pub pivot: &'a mut [f64],
    /// the det sign of each instant's factorisation
    pub det: &'a mut [i8],
    pub counts: &'a mut [i64],
    /// the instant of the outputs' first row (0: they hold every instant)
    pub first: usize,
}

/// A step's operations on the core's own model and LU: q lives in `q`.
pub struct Native<'a> {
    pub kin: &'a Kin,
    pub layout: &'a Layout,
    pub f: Factors,
    pub q: Vec<f64>,
    pub e: Vec<C64>,
    /// the angles e holds (NaN: none yet)
    seen: Vec<f64>,
    pub phi: Vec<f64>,
    values: Vec<f64>,
    dq: Vec<f64>,
    b: Vec<f64>,
    pub t: f64,
    pub counts: [i64; 2],
    /// e holds e^{i q} of the current q (q has not moved since)
    rotated: bool,
}

impl<'a> Native<'a> {
    pub fn new(kin: &'a Kin, layout: &'a Layout) -> Self {
        Native {
            kin,
            layout,
            f: layout.factors(),
            q: vec![0.0; kin.n],
            e: vec![C64::new(1.0, 0.0); kin.n],
            seen: vec![f64::NAN; kin.n],
            phi: vec![0.0; kin.m],
            values: vec![0.0; kin.nnz],
            dq: vec![0.0; kin.n],
            b: vec![0.0; kin.m],
            t: 0.0,
            counts: [0, 0],
            rotated: false,
        }
    }
}

/// max |phi_i| / scale_i; a NaN gives NaN.
pub fn residual(phi: &[f64], scale: &[f64]) -> f64 {
    let mut r = 0.0f64;
    for i in 0..phi.len() {
        let v = phi[i].abs() / scale[i];
        if v > r || v.is_nan() {
            r = v;
        }
    }
    r
}

/// The largest |dq_j| / col_scale_j.
fn size(dq: &[f64], col_scale: &[f64]) -> f64 {
    dq.iter().zip(col_scale).fold(0.0f64, |a, (d, c)| a.max(d.abs() / c))
}

/// qd, qdd at (q, t) (e: e^{i q}) with `solve` (x with Phi_q x = b, the
/// factorisation at q): Phi_q qd = nu, Phi_q qdd = gamma (Eqs. 3.13, 3.15).
/// nu and gamma: room for m values each. Every step's rates, whatever its solver.
#[allow(clippy::too_many_arguments)]
pub fn rates_with<E>(
    kin: &Kin,
    at: &At,
    nu: &mut [f64],
    gamma: &mut [f64],
    qd: &mut [f64],
    qdd: &mut [f64],
    mut solve: impl FnMut(&[f64], &mut [f64]) -> Result<(), E>,
) -> Result<(), E> {
    kin.nu(at.t, nu);
    solve(nu, qd)?;
    kin.gamma(at, qd, gamma);
    solve(gamma, qdd)
}

impl Native<'_> {
    /// e = e^{i q} at the angle columns, once per configuration.
    #[inline]
    fn rotate(&mut self) {
        if !self.rotated {
            self.kin.rotate_changed(&self.q, &mut self.e, &mut self.seen);
            self.rotated = true;
        }
    }
}

impl Ops for Native<'_> {
    type Error = Infallible;

    fn evaluate(&mut self, _: i64) -> Result<f64, Infallible> {
        self.rotate();
        self.kin.phi(&At { q: &self.q, e: &self.e, t: self.t }, &mut self.phi);
        Ok(residual(&self.phi, &self.layout.scale))
    }

    /// Always at q; it leaves `e` at q too (the rates read it).
    #[inline(always)]
    fn factor(&mut self, _: bool) -> Result<(), Infallible> {
        self.rotate();
        self.kin.jac(&At { q: &self.q, e: &self.e, t: self.t }, &mut self.values);
        self.layout.factor(&self.values, &mut self.f);
        self.counts[0] += 1;
        self.counts[1] += 1;
        Ok(())
    }

    fn correct(&mut self, limit: f64) -> Result<f64, Infallible> {
        for i in 0..self.b.len() {
            self.b[i] = -self.phi[i];
        }
        self.layout.solve(&mut self.f, &self.b, &mut self.dq);
        let big = size(&self.dq, &self.layout.col_scale);
        let f = if big > 0.0 { (limit / big).min(1.0) } else { 1.0 };
        for j in 0..self.q.len() {
            self.q[j] += f * self.dq[j];
        }
        self.rotated = false;
        Ok(big)
    }
}

impl Step for Native<'_> {
    fn start(&mut self, q: &[f64], t: f64) -> Result<(), Infallible> {
        self.q.copy_from_slice(q);
        self.t = t;
        self.rotated = false;
        Ok(())
    }

    fn q(&self) -> &[f64] {
        &self.q
    }

    fn stats(&mut self) -> Result<(f64, i32), Infallible> {
        Ok(self.layout.stats(&self.f))
    }

    /// The factorisation and e^{i q} are at q: settle's and the chord's last operation.
    #[inline(always)]
    fn rates(&mut self, qd: &mut [f64], qdd: &mut [f64]) -> Result<(), Infallible> {
        self.rotate();
        let Native { kin, layout, f, q, e, t, phi, b, .. } = self;
        let at = At { q: &q[..], e: &e[..], t: *t };
        rates_with(kin, &at, phi, b, qd, qdd, |rhs, x| {
            layout.solve(f, rhs, x);
            Ok(())
        })
    }

    fn probe(&mut self) -> Result<f64, Infallible> {
        self.evaluate(-1)?;
        for i in 0..self.b.len() {
            self.b[i] = -self.phi[i];
        }
        self.layout.solve(&mut self.f, &self.b, &mut self.dq);
        Ok(size(&self.dq, &self.layout.col_scale))
    }

    fn col_scale(&self) -> &[f64] {
        &self.layout.col_scale
    }
}

/// March from the accepted `st` over times[k..] until an instant is not
/// accepted or `watch` stops it (a deadline, a signal: polled here when
/// `caller`, the thread that owns the watch): `step` at each instant, its
/// figures into `out`; returns (the first instant not taken, or
/// times.len(), and why: Accepted when all were taken). From k = 0 it
/// first assembles from the estimates in st.q (accepted when its pivot
/// ratio is above the floor; not tested for a jump or a det flip: no state
/// before it).
#[allow(clippy::too_many_arguments)]
pub fn run(
    kin: &Kin,
    layout: &Layout,
    times: &[f64],
    mut k: usize,
    st: &mut MarchState,
    s: &Settings,
    out: Out,
    watch: &Watch,
    caller: bool,
) -> (usize, Why) {
    let n = kin.n;
    let mut ops = Native::new(kin, layout);
    let mut result = (times.len(), Why::Accepted);
    let (mut next, mut tick) = (Instant::now(), 0u32);
    // ops.f holds the factorisation at the last accepted q (none before the first)
    let mut c = Work::new(n);
    if k == 0 {
        st.restart();
    }
    while k < times.len() {
        // the clock every WATCH_EVERY instants: a few ns per instant, a stop within a few
        if tick % WATCH_EVERY == 0 {
            if let Some(why) = watch.check(caller, &mut next) {
                result = (k, why);
                break;
            }
        }
        tick = tick.wrapping_add(1);
        let Ok(o) = step(&mut ops, st, times[k], s, Mode::Track, &mut c);
        if o.why != Why::Accepted {
            result = (k, o.why);
            break;
        }
        let r = k - out.first;
        out.q[r * n..(r + 1) * n].copy_from_slice(&st.q);
        if s.rates {
            out.qd[r * n..(r + 1) * n].copy_from_slice(&st.qd);
            out.qdd[r * n..(r + 1) * n].copy_from_slice(&st.qdd);
        }
        out.iterations[r] = o.iterations as i64;
        out.residual[r] = o.residual;
        out.pivot[r] = o.pivot;
        out.det[r] = o.det as i8;
        k += 1;
    }
    out.counts[0] += ops.counts[0];
    out.counts[1] += ops.counts[1];
    result
}
