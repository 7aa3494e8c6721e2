//! The march over output instants (docs/solver.md, "The march"): at each
//! instant the predictor, the chord from the Hermite start with the last
//! instant's LU to rounding and the LU there (newton::chord), or, at the
//! march's first instant and where the chord contracts too slowly,
//! Newton-Raphson with the final correction and the LU at the corrected q
//! (newton::settle), both on the core's own operations; the acceptance test
//! and the velocity and acceleration solves from that one LU.
//! It stops at the first instant not accepted and hands it to the tracker
//! (kinem/tracking.py), which sub-steps, diagnoses and steps over.
use crate::accept::{hermite, jump_sizes, lagrange, rejected, taylor, Why};
use crate::families::At;
use crate::lu::{Factors, Layout};
use crate::model::Kin;
use crate::newton::{chord, settle, Ops, RECENT};
use crate::watch::Watch;
use num_complex::Complex64 as C64;
use std::convert::Infallible;
use std::time::Instant;

/// The march looks at its watch (a deadline, a signal) every this many instants.
const WATCH_EVERY: u32 = 4;

pub struct Settings {
    pub tolerance: f64,
    pub max_iterations: usize,
    pub max_step: f64,
    /// the pivot ratio below which a state is near-singular (kinem.tracking.singular_pivot)
    pub floor: f64,
    /// solve velocities and accelerations (and predict by Taylor from them)
    pub rates: bool,
}

/// The accepted state the march starts from and leaves at its last instant.
pub struct State<'a> {
    pub q: &'a mut [f64],
    pub qd: &'a mut [f64],
    pub qdd: &'a mut [f64],
    /// (time, det sign) of the last accepted state
    pub last: &'a mut [f64],
    /// the last three states' q (3 n) and times (3), oldest first, NaN for none
    pub h: &'a mut [f64],
    pub tt: &'a mut [f64],
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

/// settle's operations on the core's own model and LU: q lives in `q`.
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

impl Native<'_> {
    /// e = e^{i q} at the angle columns, once per configuration.
    fn rotate(&mut self) {
        if !self.rotated {
            self.kin.rotate_changed(&self.q, &mut self.e, &mut self.seen);
            self.rotated = true;
        }
    }

    /// Starts a solve at (q, t).
    pub fn start(&mut self, q: &[f64], t: f64) {
        self.q.copy_from_slice(q);
        self.t = t;
        self.rotated = false;
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
        let cs = &self.layout.col_scale;
        let big = self.dq.iter().zip(cs).fold(0.0f64, |a, (d, c)| a.max(d.abs() / c));
        let f = if big > 0.0 { (limit / big).min(1.0) } else { 1.0 };
        for j in 0..self.q.len() {
            self.q[j] += f * self.dq[j];
        }
        self.rotated = false;
        Ok(big)
    }
}

/// March from the accepted `state` over times[k..] until an instant is not
/// accepted or `watch` stops it (a deadline, a signal: polled here when
/// `caller`, the thread that owns the watch); returns (the first instant
/// not taken, or times.len(), and why: Accepted when all were taken). From k = 0 it first
/// assembles from the estimates in state.q (accepted when its pivot ratio is
/// above the floor; not tested for a jump or a det flip: no state before it).
#[allow(clippy::too_many_arguments)]
pub fn run(
    kin: &Kin,
    layout: &Layout,
    times: &[f64],
    mut k: usize,
    st: State,
    s: &Settings,
    out: Out,
    watch: &Watch,
    caller: bool,
) -> (usize, Why) {
    let n = kin.n;
    let mut ops = Native::new(kin, layout);
    let mut qp = vec![0.0; n];
    let mut nu = vec![0.0; kin.m];
    let mut gamma = vec![0.0; kin.m];
    let mut result = (times.len(), Why::Accepted);
    let (mut next, mut tick) = (Instant::now(), 0u32);
    // ops.f holds the factorisation at the last accepted q (none before the first)
    let mut held = false;
    // the chord's last measured contraction and the instants since (newton::chord's `known`)
    let (mut theta, mut age) = (f64::INFINITY, RECENT + 1);
    // the state before the last accepted one (q, qd, qdd) and its time (NaN: none in this march)
    let (mut prev, mut before, mut start) = (vec![0.0; 3 * n], f64::NAN, vec![0.0; n]);
    while k < times.len() {
        // the clock every WATCH_EVERY instants: a few ns per instant, a stop within a few
        if tick % WATCH_EVERY == 0 {
            if let Some(why) = watch.check(caller, &mut next) {
                result = (k, why);
                break;
            }
        }
        tick = tick.wrapping_add(1);
        let t = times[k];
        let h = t - st.last[0];
        let mut judge = k > 0;
        if k == 0 {
            qp.copy_from_slice(st.q);
        } else if s.rates {
            taylor(st.q, st.qd, st.qdd, h, &mut qp);
        } else {
            let tt = [st.tt[0], st.tt[1], st.tt[2]];
            judge = lagrange(t, &tt, st.h, &mut qp) >= 1;
        }
        // the chord with the last instant's factorisation, from the Hermite start when the last two
        // instants are at hand, else (or when it contracts too slowly) Newton from the predictor
        if held && before.is_finite() && h <= 2.0 * (st.last[0] - before) {
            let (p, c) = ([&prev[..n], &prev[n..2 * n], &prev[2 * n..]], [&st.q[..], &st.qd[..], &st.qdd[..]]);
            hermite(p, c, st.last[0] - before, h, &mut start);
            ops.start(&start, t);
        } else {
            ops.start(&qp, t);
        }
        let known = if age <= RECENT { theta } else { f64::INFINITY };
        let Ok(chorded) = if held { chord(&mut ops, s.tolerance, s.max_step, known) } else { Ok(None) };
        let settled = match chorded {
            Some((c, measured)) => {
                if measured.is_nan() {
                    age += 1;
                } else {
                    (theta, age) = (measured, 0);
                }
                c
            }
            None => {
                (theta, age) = (f64::INFINITY, RECENT + 1);
                ops.start(&qp, t);
                let Ok(c) = settle(&mut ops, s.tolerance, s.max_iterations, s.max_step, true);
                c
            }
        };
        if !settled.converged {
            result = (k, Why::NotConverged);
            break;
        }
        let (ratio, det) = layout.stats(&ops.f);
        let (corr, motion) = jump_sizes(&ops.q, &qp, st.q, &layout.col_scale);
        let previous = if k == 0 { det } else { st.last[1] as i32 };
        let why = rejected(ratio, settled.last_step, det, previous, corr, motion, judge, s.floor, s.tolerance, false);
        // the factorisation at the accepted q serves the rates and the next instant's chord
        held = why == Why::Accepted;
        if why != Why::Accepted {
            result = (k, why);
            break;
        }
        if s.rates {
            // the last state becomes the earlier one of the Hermite start
            prev[..n].copy_from_slice(st.q);
            prev[n..2 * n].copy_from_slice(st.qd);
            prev[2 * n..].copy_from_slice(st.qdd);
            before = if k == 0 { f64::NAN } else { st.last[0] };
        }
        st.q.copy_from_slice(&ops.q);
        if s.rates {
            // the factorisation and e^{i q} are at the corrected q: settle's last operation
            kin.nu(t, &mut nu);
            layout.solve(&mut ops.f, &nu, st.qd);
            kin.gamma(&At { q: &ops.q, e: &ops.e, t }, st.qd, &mut gamma);
            layout.solve(&mut ops.f, &gamma, st.qdd);
            let r = k - out.first;
            out.qd[r * n..(r + 1) * n].copy_from_slice(st.qd);
            out.qdd[r * n..(r + 1) * n].copy_from_slice(st.qdd);
        } else {
            st.tt.copy_within(1..3, 0);
            st.h.copy_within(n..3 * n, 0);
            st.tt[2] = t;
            st.h[2 * n..3 * n].copy_from_slice(st.q);
        }
        st.last[0] = t;
        st.last[1] = det as f64;
        let r = k - out.first;
        out.q[r * n..(r + 1) * n].copy_from_slice(st.q);
        out.iterations[r] = settled.iterations as i64;
        out.residual[r] = settled.residual;
        out.pivot[r] = ratio;
        out.det[r] = det as i8;
        k += 1;
    }
    out.counts[0] += ops.counts[0];
    out.counts[1] += ops.counts[1];
    result
}
