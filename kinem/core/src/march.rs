//! The march over output instants (docs/solver.md, "The march"): the step
//! (crate::step) at every instant on the core's own operations (`Native`:
//! kinem's LU, holding the last instant's factorisation for the chord), its
//! figures into the outputs, until an instant is not accepted; that one is
//! handed to the tracker (kinem/tracking.py), which calls the same step.
use crate::accept::{most, Why};
use crate::families::At;
use crate::lu::{Factors, Layout};
use crate::model::{Kin, Turning};
use crate::newton::Ops;
use crate::outline::Piece;
pub use crate::step::{rates_from, rates_with, step, MarchState, Mode, Outcome, Settings, Step, Work, SINGULAR};
use crate::watch::Watch;
use num_complex::Complex64 as C64;
use std::convert::Infallible;
use std::time::{Duration, Instant};

/// The march looks at a watch that reads no clock (only the stop flag: no
/// deadline, no signal poll on this thread) every this many instants.
const WATCH_EVERY: u32 = 4;
/// A watch that reads the clock (a deadline, the calling thread's signal
/// poll) is looked at about this often: every `Looks::every` instants,
/// doubled (up to WATCH_MOST) while that many took less than half of it,
/// halved where they took more. A clock read costs about 50 ns in a
/// virtual machine (the slider-crank's instant about 300 ns); at a steady
/// pace a deadline is seen within about two spans of passing, and a signal
/// within that of its poll (every `watch::POLL`, as before).
const WATCH_SPAN: Duration = Duration::from_micros(100);
const WATCH_MOST: u32 = 256;

/// When the march looks at its watch next (`WATCH_SPAN`).
struct Looks {
    /// instants between looks, and left before the next
    every: u32,
    left: u32,
    /// when the watch read its clock last (None: not yet)
    last: Option<Instant>,
}

impl Looks {
    fn new() -> Self {
        Looks { every: 1, left: 0, last: None }
    }

    /// Whether to look at the watch before this instant.
    #[inline(always)]
    fn due(&mut self) -> bool {
        if self.left == 0 {
            return true;
        }
        self.left -= 1;
        false
    }

    /// After a look that read the clock at `now` (None: it read none).
    #[inline]
    fn looked(&mut self, now: Option<Instant>) {
        match (now, self.last) {
            (Some(now), Some(last)) => {
                let took = now.saturating_duration_since(last);
                if took < WATCH_SPAN / 2 && self.every < WATCH_MOST {
                    self.every *= 2;
                } else if took > WATCH_SPAN && self.every > 1 {
                    self.every /= 2;
                }
            }
            (None, _) => self.every = WATCH_EVERY,
            _ => {}
        }
        self.last = now;
        self.left = self.every - 1;
    }
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
    /// e^{i q} at the angle columns (`turning.e`)
    pub turning: Turning,
    pub phi: Vec<f64>,
    values: Vec<f64>,
    dq: Vec<f64>,
    /// room for the corrected q (`correct`: swapped with q)
    next: Vec<f64>,
    /// nu's room: zeroed here, written by Kin::nu_over alone (here
    /// once where the model's nu is the same at every instant: Kin::nu_fixed)
    nu: Vec<f64>,
    /// gamma's room: zeros from `new`, written by the rates alone (Kin::gamma_over)
    b: Vec<f64>,
    pub t: f64,
    pub counts: [i64; 2],
    /// e holds e^{i q} of the current q (q has not moved since)
    rotated: bool,
    /// the pieces the factorisation's outlines were taken on (m, or empty:
    /// not kept; Kin::jac_over_keeping), for `run_hooked`'s hook
    pieces: Vec<Piece>,
    /// the rest coordinates out of the step's loops (`Rest`): the range that
    /// holds every other coordinate, while each solve runs quiet (None:
    /// every loop over all n)
    moving: Option<(usize, usize)>,
    /// the last rates' two solves both ran quiet (Layout::solve_quiet)
    rates_quiet: bool,
}

impl<'a> Native<'a> {
    pub fn new(kin: &'a Kin, layout: &'a Layout) -> Self {
        let (q, turning) = (vec![0.0; kin.n], Turning::new(kin.n));
        // the Jacobian's constant entries, which `factor`'s Kin::jac_over keeps (at any q)
        let mut values = vec![0.0; kin.nnz];
        kin.jac(&At { q: &q, e: &turning.e, t: 0.0 }, &mut values);
        let mut f = layout.factors();
        // the model's own exact zeros: its factorisations need not check them (a variant's may)
        f.zeros_hold = layout.zeros_hold(kin);
        // its folded and negated pivots' entries: constants of its values, never written again
        f.signs_hold = layout.signs_hold(&values, kin.over_kept());
        // and its constant entries placed once, where nothing else writes their places
        layout.place_once(&values, kin.over_kept(), &mut f);
        let mut nu = vec![0.0; kin.m];
        if kin.nu_fixed {
            kin.nu_over(0.0, &mut nu);
        }
        Native {
            kin,
            layout,
            f,
            q,
            turning,
            phi: vec![0.0; kin.m],
            values,
            dq: vec![0.0; kin.n],
            next: vec![0.0; kin.n],
            nu,
            b: vec![0.0; kin.m],
            t: 0.0,
            counts: [0, 0],
            rotated: false,
            pieces: Vec::new(),
            moving: None,
            rates_quiet: false,
        }
    }
}

/// All that a march's operations (`Native`) and its step (`Work`) own
/// beside the model they read: their buffers, with the constants
/// `Native::new` puts in them. A Plan keeps one as made fresh and one to
/// march in (py/plan.rs), which each march sets from the first in place
/// (`clone_from`: copies, no allocation, no evaluation): every march starts
/// where a fresh one would, to the bit.
pub struct Room {
    f: Factors,
    q: Vec<f64>,
    turning: Turning,
    phi: Vec<f64>,
    values: Vec<f64>,
    dq: Vec<f64>,
    next: Vec<f64>,
    nu: Vec<f64>,
    b: Vec<f64>,
    pieces: Vec<Piece>,
    work: Work,
}

impl Room {
    /// The room of a fresh march of kin on layout.
    pub fn new(kin: &Kin, layout: &Layout) -> Self {
        let mut room = Room::empty();
        Native::new(kin, layout).leave(Work::new(kin.n, kin.smooth), &mut room);
        room
    }

    /// No buffers (nothing allocated).
    fn empty() -> Self {
        Room {
            f: Factors::empty(),
            q: Vec::new(),
            turning: Turning::new(0),
            phi: Vec::new(),
            values: Vec::new(),
            dq: Vec::new(),
            next: Vec::new(),
            nu: Vec::new(),
            b: Vec::new(),
            pieces: Vec::new(),
            work: Work::new(0, false),
        }
    }
}

impl Clone for Room {
    fn clone(&self) -> Self {
        let mut room = Room::empty();
        room.clone_from(self);
        room
    }

    /// Field by field, in the buffers self has.
    fn clone_from(&mut self, s: &Self) {
        let Room { f, q, turning, phi, values, dq, next, nu, b, pieces, work } = self;
        f.clone_from(&s.f);
        q.clone_from(&s.q);
        turning.clone_from(&s.turning);
        phi.clone_from(&s.phi);
        values.clone_from(&s.values);
        dq.clone_from(&s.dq);
        next.clone_from(&s.next);
        nu.clone_from(&s.nu);
        b.clone_from(&s.b);
        pieces.clone_from(&s.pieces);
        work.clone_from(&s.work);
    }
}

impl<'a> Native<'a> {
    /// The operations of kin on layout in room's buffers, and the step's
    /// work, both as `new` and `Work::new` make them where room is fresh
    /// (room is left empty until `leave`).
    pub fn enter(kin: &'a Kin, layout: &'a Layout, room: &mut Room) -> (Self, Work) {
        let Room { f, q, turning, phi, values, dq, next, nu, b, pieces, work } = std::mem::replace(room, Room::empty());
        let ops = Native {
            kin,
            layout,
            f,
            q,
            turning,
            phi,
            values,
            dq,
            next,
            nu,
            b,
            t: 0.0,
            counts: [0, 0],
            rotated: false,
            pieces,
            moving: None,
            rates_quiet: false,
        };
        (ops, work)
    }

    /// The buffers and the step's work back into room.
    pub fn leave(self, work: Work, room: &mut Room) {
        let Native {
            kin: _,
            layout: _,
            f,
            q,
            turning,
            phi,
            values,
            dq,
            next,
            nu,
            b,
            t: _,
            counts: _,
            rotated: _,
            pieces,
            moving: _,
            rates_quiet: _,
        } = self;
        *room = Room { f, q, turning, phi, values, dq, next, nu, b, pieces, work };
    }
}

/// max |phi_i| / scale_i; a NaN gives NaN.
pub fn residual(phi: &[f64], scale: &[f64]) -> f64 {
    assert!(scale.len() >= phi.len());
    // the terms' sum is NaN exactly where a term is (each is NaN or at least 0: a sum of those
    // overflows to infinity, never to NaN): one addition per row tells what a NaN test did
    // (in pairs of rows, two running maxima and sums, so that they vectorise, as `size`)
    let n = phi.len();
    let (p2, s2) = (phi.as_chunks::<2>().0, scale[..n].as_chunks::<2>().0);
    let (mut r, mut sum) = ([0.0f64; 2], [0.0f64; 2]);
    for (p, s) in p2.iter().zip(s2) {
        for l in 0..2 {
            let v = p[l].abs() / s[l];
            r[l] = most(r[l], v);
            sum[l] += v;
        }
    }
    if n % 2 == 1 {
        let v = phi[n - 1].abs() / scale[n - 1];
        r[0] = most(r[0], v);
        sum[0] += v;
    }
    if (sum[0] + sum[1]).is_nan() {
        f64::NAN
    } else {
        most(r[0], r[1])
    }
}

/// The largest |dq_j| / col_scale_j: a correction's size (NaNs passed over).
pub fn size(dq: &[f64], col_scale: &[f64]) -> f64 {
    // two running maxima, as accept::gap
    let ((d2, d1), (c2, c1)) = (dq.as_chunks::<2>(), col_scale[..dq.len()].as_chunks::<2>());
    let mut g = [0.0f64; 2];
    for (d, c) in d2.iter().zip(c2) {
        for k in 0..2 {
            g[k] = most(g[k], d[k].abs() / c[k]);
        }
    }
    for (d, c) in d1.iter().zip(c1) {
        g[0] = most(g[0], d.abs() / c);
    }
    most(g[0], g[1])
}

/// `size(dq, col_scale)`, writing q - dq into `next` in the same pass
/// (n = q.len(): every slice holds n).
#[inline(always)]
pub fn stepped(q: &[f64], dq: &[f64], col_scale: &[f64], next: &mut [f64]) -> f64 {
    let n = q.len();
    let (dq, col_scale, next) = (&dq[..n], &col_scale[..n], &mut next[..n]);
    // two running maxima in pairs, as `size`
    let (q2, d2, c2, x2) =
        (q.as_chunks::<2>().0, dq.as_chunks::<2>().0, col_scale.as_chunks::<2>().0, next.as_chunks_mut::<2>().0);
    let mut g = [0.0f64; 2];
    for k in 0..n / 2 {
        let (q, d, c) = (q2[k], d2[k], c2[k]);
        for l in 0..2 {
            g[l] = most(g[l], d[l].abs() / c[l]);
            x2[k][l] = q[l] - d[l];
        }
    }
    if n % 2 == 1 {
        let j = n - 1;
        g[0] = most(g[0], dq[j].abs() / col_scale[j]);
        next[j] = q[j] - dq[j];
    }
    most(g[0], g[1])
}

/// The factor that limits a correction of size `big` to `limit`.
#[inline]
pub fn limited(big: f64, limit: f64) -> f64 {
    if big > 0.0 {
        (limit / big).min(1.0)
    } else {
        1.0
    }
}

impl Native<'_> {
    /// e = e^{i q} at the angle columns, once per configuration: from the
    /// angle's anchor after a start, turned after a correction (model::follow).
    #[inline(always)]
    fn rotate(&mut self) {
        if !self.rotated {
            self.turning.to(self.kin, &self.q);
            self.rotated = true;
        }
    }
}

impl Native<'_> {
    /// The values at q as `factor` takes them, keeping the outlines'
    /// pieces (Kin::jac_over_keeping; out of the march's own line of code).
    #[cold]
    #[inline(never)]
    fn jac_keeping(&mut self) {
        let at = At { q: &self.q, e: &self.turning.e, t: self.t };
        self.kin.jac_over_keeping(&at, &mut self.values, &mut self.pieces);
    }
}

impl Ops for Native<'_> {
    type Error = Infallible;

    /// After convergence (it -1) the residual is not read (newton::Ops): 0,
    /// without its loop over the rows (a non-finite Phi still shows in the
    /// correction's size, which gives up as the residual did).
    fn evaluate(&mut self, it: i64) -> Result<f64, Infallible> {
        self.rotate();
        self.kin.phi(&At { q: &self.q, e: &self.turning.e, t: self.t }, &mut self.phi);
        if it < 0 {
            return Ok(0.0);
        }
        Ok(residual(&self.phi, &self.layout.scale))
    }

    /// Always at q; it leaves `e` at q too (the rates read it).
    #[inline(always)]
    fn factor(&mut self, _: bool) -> Result<(), Infallible> {
        self.rotate();
        if self.pieces.is_empty() {
            // the values' constant entries from `new` (Kin::jac_over)
            self.kin.jac_over(&At { q: &self.q, e: &self.turning.e, t: self.t }, &mut self.values);
        } else {
            self.jac_keeping();
        }
        self.layout.factor(&self.values, &mut self.f);
        self.counts[0] += 1;
        self.counts[1] += 1;
        Ok(())
    }

    /// q -= Phi_q^-1 Phi: dq = Phi_q^-1 Phi, then q - f dq (the solve's
    /// operations are odd in b, so these are the figures of q + f Phi_q^-1 (-Phi)
    /// to the bit, without negating Phi).
    fn correct(&mut self, limit: f64) -> Result<f64, Infallible> {
        let quiet = self.layout.solve_quiet(&mut self.f, &self.phi, &mut self.dq);
        // q - dq into `next` with the size in one pass (`stepped`), taken where the limit leaves
        // the correction whole (f = 1: q - 1 dq is q - dq to the bit), else q - f dq; over the
        // moving range alone where the solve ran quiet (`Rest`: dq is +-0 at every rest
        // coordinate, whose q - dq is its q and whose |dq| / scale no maximum takes)
        let big = match self.moving {
            Some((lo, hi)) if quiet => {
                let cs = &self.layout.col_scale;
                stepped(&self.q[lo..hi], &self.dq[lo..hi], &cs[lo..hi], &mut self.next[lo..hi])
            }
            _ => {
                self.moving = None;
                stepped(&self.q, &self.dq, &self.layout.col_scale, &mut self.next)
            }
        };
        let f = limited(big, limit);
        if f == 1.0 {
            std::mem::swap(&mut self.q, &mut self.next);
        } else {
            for (q, d) in self.q.iter_mut().zip(&self.dq) {
                *q -= f * d;
            }
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
        self.turning.restart();
        Ok(())
    }

    #[inline(always)]
    fn place(&mut self, t: f64) -> Option<(&mut [f64], &[f64])> {
        self.t = t;
        self.rotated = false;
        self.turning.restart();
        Some((&mut self.q, &self.layout.col_scale))
    }

    fn q(&self) -> &[f64] {
        &self.q
    }

    fn stats(&mut self) -> Result<(f64, i32), Infallible> {
        Ok(self.layout.stats(&self.f))
    }

    /// The factorisation and e^{i q} are at q: settle's and the chord's last
    /// operation; so are the Jacobian values it was made from (`values`:
    /// only `factor` writes them), from which gamma reads the revolutes'
    /// A s' (Kin::gamma_with).
    #[inline(always)]
    fn rates(&mut self, qd: &mut [f64], qdd: &mut [f64]) -> Result<(), Infallible> {
        self.rotate();
        let Native { kin, layout, f, q, turning, t, nu, b, values, .. } = self;
        let at = At { q: &q[..], e: &turning.e[..], t: *t };
        // nu's own room: its rows without a driver stay 0 from `new` (Kin::nu_over), and all of
        // them where nu is the same at every instant (Kin::nu_fixed: written in `new`)
        if !kin.nu_fixed {
            kin.nu_over(*t, nu);
        }
        // gamma's room `b`: only here, its constant rows 0 from `new` (Kin::gamma_over)
        let mut quiet = true;
        rates_from::<true, _>(kin, &at, Some(values), nu, b, qd, qdd, |rhs, x| {
            quiet &= layout.solve_quiet(f, rhs, x);
            Ok::<(), Infallible>(())
        })?;
        // where a solve did not run quiet qd or qdd may move a rest coordinate: no `Rest` from here
        self.rates_quiet = quiet;
        if !quiet {
            self.moving = None;
        }
        Ok(())
    }

    fn probe(&mut self) -> Result<f64, Infallible> {
        self.evaluate(-1)?;
        // |Phi_q^-1 Phi| = |Phi_q^-1 (-Phi)|, as in `correct`
        self.layout.solve(&mut self.f, &self.phi, &mut self.dq);
        Ok(size(&self.dq, &self.layout.col_scale))
    }

    fn col_scale(&self) -> &[f64] {
        &self.layout.col_scale
    }

    #[inline(always)]
    fn moving(&self) -> Option<(usize, usize)> {
        self.moving
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
    k: usize,
    st: &mut MarchState,
    s: &Settings,
    out: Out,
    watch: &Watch,
    caller: bool,
    room: &mut Room,
) -> (usize, Why) {
    run_hooked(kin, layout, times, k, st, s, out, watch, caller, room, None)
}

/// At each accepted instant k, after its rates: (k, the state there, the
/// factorisation of Phi_q at its q, which the rates used, e^{i q} there
/// at the angle columns, the pieces its outlines were taken on at that q
/// (m: a point-on-curve constraint's at its first row; empty where the
/// model has none: Kin::jac_over_keeping), and that factorisation's pivot
/// ratio, the instant's own: 0 where below SINGULAR, crate::step::signs).
pub type Hook<'h> = &'h mut dyn FnMut(usize, &MarchState, &mut Factors, &[C64], &[Piece], f64);

/// `run`, calling `hook` at every accepted instant (kinem.sensitivity:
/// the design sensitivities from the march's own factorisation).
#[allow(clippy::too_many_arguments)]
pub fn run_hooked(
    kin: &Kin,
    layout: &Layout,
    times: &[f64],
    k: usize,
    st: &mut MarchState,
    s: &Settings,
    out: Out,
    watch: &Watch,
    caller: bool,
    room: &mut Room,
    mut hook: Option<Hook>,
) -> (usize, Why) {
    let n = kin.n;
    let Out { q, qd, qdd, iterations, residual, pivot, det, counts, first } = out;
    let keep = hook.is_some() && kin.keeps_pieces();
    run_rows(kin, layout, times, k, st, s, watch, caller, counts, keep, room, |k, st, o, ops| {
        let r = k - first;
        q[r * n..(r + 1) * n].copy_from_slice(&st.q);
        if s.rates {
            qd[r * n..(r + 1) * n].copy_from_slice(&st.qd);
            qdd[r * n..(r + 1) * n].copy_from_slice(&st.qdd);
        }
        iterations[r] = o.iterations as i64;
        residual[r] = o.residual;
        pivot[r] = o.pivot;
        det[r] = o.det as i8;
        if let Some(h) = hook.as_mut() {
            ops.rotate();
            h(k, st, &mut ops.f, &ops.turning.e, &ops.pieces, o.pivot);
        }
    })
}

/// The march of `run`, handing each accepted instant (k, the state there,
/// its outcome, the march's operations) to `taken` instead of writing an
/// `Out`: crate::variants keeps only the asked columns, not the trajectory.
/// `keep`: its factorisations keep their outlines' pieces (Native's
/// `pieces`, for run_hooked's hook).
#[allow(clippy::too_many_arguments)]
pub fn run_rows(
    kin: &Kin,
    layout: &Layout,
    times: &[f64],
    mut k: usize,
    st: &mut MarchState,
    s: &Settings,
    watch: &Watch,
    caller: bool,
    counts: &mut [i64],
    keep: bool,
    room: &mut Room,
    mut taken: impl FnMut(usize, &MarchState, &Outcome, &mut Native),
) -> (usize, Why) {
    let (mut ops, mut c) = Native::enter(kin, layout, room);
    if keep {
        ops.pieces = vec![Piece::default(); kin.m];
        // Kin::jac_over_keeping writes every entry of its other families (their constants again)
        ops.f.signs_hold = false;
        layout.place_every(&mut ops.f);
    }
    let mut result = (times.len(), Why::Accepted);
    let (mut next, mut looks) = (Instant::now(), Looks::new());
    // ops.f holds the factorisation at the last accepted q (none before the first)
    if k == 0 {
        st.restart();
    }
    let mut tried = false;
    while k < times.len() {
        // the watch about every WATCH_SPAN (or every WATCH_EVERY instants where it reads no clock)
        if looks.due() {
            let (why, now) = watch.look(caller, &mut next);
            if let Some(why) = why {
                result = (k, why);
                break;
            }
            looks.looked(now);
        }
        let Ok(o) = step(&mut ops, st, times[k], s, Mode::Track, &mut c);
        if o.why != Why::Accepted {
            result = (k, o.why);
            break;
        }
        if !tried {
            // after the run's first accepted instant (the assembly at k = 0): the rest coordinates
            // proved still, or every loop over all n for this run
            tried = true;
            ops.moving = rest(&mut ops, st, s, &mut c);
        }
        taken(k, st, &o, &mut ops);
        k += 1;
    }
    counts[0] += ops.counts[0];
    counts[1] += ops.counts[1];
    ops.leave(c, room);
    result
}

/// The rest coordinates out of the step's vector loops (issue 31, round
/// 24): the layout's quiet coordinates (crate::triangular::Program: 1x1
/// blocks whose right side is their row's alone; the ground's, a body
/// pinned at its origin to it, an angle tied to the ground's) once the
/// march's state holds them still. Where a solve runs quiet
/// (Layout::solve_quiet: every quiet right side zero) each quiet
/// coordinate's x is its row's b, +-0: a correction leaves such a q as it
/// is (q - +-0 is q to the bit for a finite q that is not -0) and the
/// rates leave qd and qdd +-0 there, so that Taylor's predictor and
/// Hermite's start (with or without the bias) give q again, to the bit
/// (crate::step::step's `predicted`; times whose steps keep h^2 and the
/// weights finite). So, from a state whose rest coordinates are finite,
/// not -0, with zero rates (and the state before it the same there, if at
/// hand), every buffer of positions the step writes holds those q at the
/// rest coordinates, and the step's loops (the predictors, the gaps,
/// `stepped`, the kept q) run over the range that holds the others: the
/// same figures, to the bit. Each solve that does not run quiet (a
/// variant that moved a pinned point, the fallback to partial pivoting)
/// ends it for the rest of the run (`Native::moving` None: the loops over
/// all n again, every buffer as the full loops left it). Only with rates
/// (Lagrange's predictor moves a constant q by rounding); the scalar
/// march's only (the lanes keep their loops).
fn rest(ops: &mut Native, st: &mut MarchState, s: &Settings, c: &mut Work) -> Option<(usize, usize)> {
    let layout = ops.layout;
    let (quiet, n) = (layout.quiet(), st.q.len());
    if !s.rates || !st.rates || !ops.rates_quiet || quiet.is_empty() || quiet.len() >= n {
        return None;
    }
    let before = st.before.is_finite();
    for &j in quiet {
        let j = j as usize;
        let (q, zero) = (st.q[j], |x: f64| x == 0.0);
        let still = q.is_finite() && q.to_bits() != (-0.0f64).to_bits() && zero(st.qd[j]) && zero(st.qdd[j]);
        let [pq, pqd, pqdd] = &st.prev;
        if !still || (before && (pq[j].to_bits() != q.to_bits() || !zero(pqd[j]) || !zero(pqdd[j]))) {
            return None;
        }
    }
    // the range that holds every other coordinate, made even where it can be (the loops' pairs)
    let moving = |j: &usize| !quiet.contains(&(*j as u32));
    let (mut lo, mut hi) = ((0..n).find(moving)?, (0..n).rfind(moving)? + 1);
    if !(hi - lo).is_multiple_of(2) {
        if hi < n {
            hi += 1;
        } else {
            lo = lo.saturating_sub(1);
        }
    }
    // every buffer of positions holds the rest coordinates' q (the state's; the one before, where
    // not at hand, is not read before it is written)
    c.rest(quiet, &st.q);
    for &j in quiet {
        let j = j as usize;
        (st.prev[0][j], ops.q[j], ops.next[j]) = (st.q[j], st.q[j], st.q[j]);
    }
    Some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The residual: the largest |phi| / scale; NaN where a row is NaN
    /// (0 / 0 too), infinite where a row is and none NaN (exactly, tolerance 0).
    #[test]
    fn a_residual_is_nan_exactly_where_a_row_is() {
        let scale = [1.0, 2.0, 0.5, 4.0];
        assert_eq!(residual(&[0.1, -0.4, 0.05, 0.0], &scale), 0.2);
        assert!(residual(&[0.1, f64::NAN, 0.05, 0.0], &scale).is_nan());
        assert!(residual(&[f64::INFINITY, f64::NAN, 0.0, 0.0], &scale).is_nan());
        assert!(residual(&[0.0, 0.0], &[1.0, 0.0]).is_nan());
        // an odd count: the last row alone
        assert_eq!(residual(&[0.1, -0.4, 0.9], &[1.0, 2.0, 0.5]), 1.8);
        assert!(residual(&[0.1, -0.4, f64::NAN], &[1.0, 2.0, 0.5]).is_nan());
        assert_eq!(residual(&[f64::INFINITY, -f64::INFINITY, 1e308, 1e308], &scale), f64::INFINITY);
        // rows that sum past the largest float: infinite sum, not NaN; the residual is the largest row
        assert_eq!(residual(&[1e308, 1e308, 1e308, 1e308], &scale), f64::INFINITY);
        assert_eq!(residual(&[1e308, 1e308, 1e307, 1e308], &scale), 1e308);
    }

    /// The looks at a watch: at the first instant, then every 1, 2, 4, ...
    /// instants while those took under half of WATCH_SPAN, at most
    /// WATCH_MOST; halved where they took more than it; every WATCH_EVERY
    /// where the watch reads no clock.
    #[test]
    fn the_watch_is_looked_at_about_every_span() {
        let mut l = Looks::new();
        let t0 = Instant::now();
        let (mut at, mut looks) = (Vec::new(), 0u32);
        for k in 0..2000u32 {
            if l.due() {
                at.push(k);
                looks += 1;
                // each instant takes 10 ns
                l.looked(Some(t0 + Duration::from_nanos(10 * k as u64)));
            }
        }
        assert_eq!(&at[..6], &[0, 1, 3, 7, 15, 31]);
        assert_eq!(l.every, WATCH_MOST);
        assert!(at.windows(2).all(|w| w[1] - w[0] <= WATCH_MOST), "{at:?}");
        assert!(looks < 20, "{looks}");
        // slow instants (1 ms each): halved at every look down to 1
        let mut t = t0 + Duration::from_secs(1);
        while !l.due() {}
        l.looked(Some(t));
        for _ in 0..20 {
            let mut instants = 1;
            while !l.due() {
                instants += 1;
            }
            assert_eq!(instants, l.every);
            t += Duration::from_millis(l.every as u64);
            l.looked(Some(t));
        }
        assert_eq!(l.every, 1);
        // no clock read: every WATCH_EVERY instants
        l.looked(None);
        assert_eq!((l.every, l.left), (WATCH_EVERY, WATCH_EVERY - 1));
    }

    /// A correction that leaves +0 or -0 at the rest coordinates (q finite,
    /// not -0): `stepped` over the range of the others, with `next` holding
    /// q at the rest ones, gives the whole run's size and q - dq to the bit
    /// (march::rest).
    #[test]
    fn a_correction_over_the_moving_range_equals_the_whole_one() {
        let n = 12;
        let rest = [0usize, 1, 2, 3, 4, 11];
        let mut q: Vec<f64> = (0..n).map(|j| ((j * 7) as f64 * 0.61).cos()).collect();
        let mut dq: Vec<f64> = (0..n).map(|j| ((j * 5) as f64 * 0.37).sin() * 1e-4).collect();
        let col: Vec<f64> = (0..n).map(|j| 0.3 + j as f64).collect();
        for (i, &j) in rest.iter().enumerate() {
            (q[j], dq[j]) = ([0.0, 0.2, -3.0, 1e-310, 7.0, 0.5][i], if i % 2 == 0 { 0.0 } else { -0.0 });
        }
        let mut next = vec![0.0; n];
        let big = stepped(&q, &dq, &col, &mut next);
        let mut nr = vec![f64::NAN; n];
        rest.iter().for_each(|&j| nr[j] = q[j]);
        let (lo, hi) = (5, 11);
        let br = stepped(&q[lo..hi], &dq[lo..hi], &col[lo..hi], &mut nr[lo..hi]);
        assert_eq!(big.to_bits(), br.to_bits());
        assert!(next.iter().zip(&nr).all(|(a, b)| a.to_bits() == b.to_bits()), "{next:?} {nr:?}");
    }

    /// `stepped` gives `size`'s figure and q - dq to the bit (tolerance 0),
    /// a NaN passed over as `size` passes it, for odd and even n.
    #[test]
    fn a_correction_in_one_pass_equals_size_and_the_update() {
        for n in [1usize, 4, 7, 12] {
            let v = |k: usize| -> Vec<f64> { (0..n).map(|j| ((k * 13 + j * 5) as f64 * 0.71).cos() * 1e-3).collect() };
            let (q, mut dq, col) = (v(1), v(2), v(3).iter().map(|x| 0.2 + x.abs()).collect::<Vec<_>>());
            for nan in [false, true] {
                if nan {
                    dq[n / 2] = f64::NAN;
                }
                let mut next = vec![0.0; n];
                let big = stepped(&q, &dq, &col, &mut next);
                assert_eq!(big.to_bits(), size(&dq, &col).to_bits());
                for j in 0..n {
                    assert_eq!(next[j].to_bits(), (q[j] - 1.0 * dq[j]).to_bits());
                }
            }
        }
    }
}
