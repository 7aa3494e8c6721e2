//! WIDTH (8) variants of one mechanism marched together (issue 31 item 5;
//! docs/solver.md, "Variants of one mechanism"): the same program over the
//! WIDTH variants per instruction where it costs most, the families' Phi,
//! Jacobian, nu and gamma (one `Kin<Wide<WIDTH>>` whose tables hold the
//! lanes' numbers, crate::wide), and the step around it lane by lane with
//! each lane's own decisions, as crate::step takes them in Mode::Track:
//! Taylor's (or Lagrange's) prediction, the chord from the Hermite start
//! with the lane's last factorisation, corrections in lockstep (a lane whose
//! chord is done waits, masked, while the others correct), Newton
//! (newton::Settling, settle a step at a time, in lockstep too: one Phi or Jacobian
//! over the lanes for every lane that asks one, each lane's own LU and
//! solves) where a lane has no factorisation yet (the first instant) or its
//! chord contracts too slowly, the acceptance test and the rates: no lane
//! builds a scalar model. Each lane's LU, solves, pivot ratio and
//! det sign are the scalar march's own (Layout::factor, solve, stats on the
//! lane's Factors: the fixed pivot order, or partial pivoting where that
//! order does not suit the lane's values), so each lane's figures are the
//! scalar march's to the bit. A lane stops on its own at its first instant
//! not accepted, with its reason (the caller solves it again alone, as it
//! does a scalar march's); the others go on.
use crate::accept::{gap, rejected, Why};
use crate::families::At;
use crate::lane_lu::LaneLu;
use crate::lu::{Factors, Layout};
use crate::march::{limited, residual, size, MarchState, Settings};
use crate::model::{follow, Anchor, Kin, Rotation};
use crate::newton::{self, Ask, Settled, Settling, Verdict, CHORD_STEPS};
use crate::real::Real;
use crate::step::{biased_start, hermite_near, predict, signs, Bias, Contraction};
use crate::table::Table;
use crate::watch::Watch;
use crate::wide::Wide;
use num_complex::{Complex, Complex64 as C64};
use num_traits::{One, Zero};
#[cfg(test)]
use std::collections::HashMap;
use std::time::Instant;

/// Variants per group: 8 measured about 5 % faster than 4 (docs/solver.md,
/// "Variants of one mechanism").
pub const WIDTH: usize = 8;
pub type W = Wide<WIDTH>;
/// The group looks at its watch every this many instants (as the march).
const WATCH_EVERY: usize = 4;

/// Whether a model's variants can march as lanes: not with outlines (a
/// cam's segment is chosen by each lane's own angle).
pub fn suits(outlines: &Table) -> bool {
    outlines.ints.values().all(|v| v.is_empty()) && outlines.reals.values().all(|v| v.is_empty())
}

/// One table whose real and complex columns hold the lanes' values (as
/// tangents: WIDTH per entry, read by Wide::of_lanes).
#[cfg(test)]
fn stack(lanes: &[&Table]) -> Result<Table, String> {
    let mut t = lanes[0].clone();
    t.d_reals = interleave(lanes, |t| &t.reals)?;
    t.d_complex = interleave(lanes, |t| &t.complex)?;
    Ok(t)
}

/// Per column of the first lane's: every lane's entry i, for i in order.
#[cfg(test)]
fn interleave<T: Copy>(
    lanes: &[&Table],
    columns: impl Fn(&Table) -> &HashMap<String, Vec<T>>,
) -> Result<HashMap<String, Vec<T>>, String> {
    let mut out = HashMap::new();
    for (key, v) in columns(lanes[0]) {
        // each lane's column, looked up once
        let each = lanes.iter().map(|l| columns(l).get(key).filter(|x| x.len() == v.len())).collect::<Option<Vec<_>>>();
        let each = each.ok_or_else(|| format!("lanes: column '{key}' differs in length between variants"))?;
        let mut d = Vec::with_capacity(v.len() * WIDTH);
        for i in 0..v.len() {
            d.extend(each.iter().map(|x| x[i]));
        }
        out.insert(key.clone(), d);
    }
    Ok(out)
}

/// A variant's tables: its families', functions' and outlines'.
pub type Tables = (Vec<(String, Table)>, Table, Table);

/// The model over lanes from WIDTH variants' own tables (tests: the reference
/// for crate::variants, which forms the tables over lanes at once).
#[cfg(test)]
pub fn wide_kin(n: usize, angles: &[i64], lanes: &[Tables]) -> Result<Kin<W>, String> {
    if lanes.len() != WIDTH {
        return Err(format!("lanes: {WIDTH} variants expected, got {}", lanes.len()));
    }
    let families = (0..lanes[0].0.len())
        .map(|k| {
            let kind = &lanes[0].0[k].0;
            let tables: Vec<&Table> = lanes.iter().map(|l| &l.0[k].1).collect();
            Ok((kind.clone(), stack(&tables)?))
        })
        .collect::<Result<Vec<_>, String>>()?;
    let functions = stack(&lanes.iter().map(|l| &l.1).collect::<Vec<_>>())?;
    let outlines = stack(&lanes.iter().map(|l| &l.2).collect::<Vec<_>>())?;
    Kin::new(n, families, &functions, &outlines, angles.to_vec())
}

/// How a lane's chord stands within an instant.
#[derive(Clone, Copy)]
enum Chord {
    /// no chord at this instant (no factorisation held): Newton
    Off,
    On(newton::Chord),
    Done(Settled, f64),
    /// it gave up: Newton from the predictor
    Failed,
}

/// One lane: its LU (its own factors: the fixed order or partial pivoting,
/// as the scalar march's), its state, the chord's memory
/// (crate::step::Work's), the predictor, its Newton, its rows.
struct Lane {
    f: Factors,
    /// Phi at its q, Newton's last evaluation (Newton corrects with it)
    phi: Vec<f64>,
    newton: Option<Settling>,
    st: MarchState,
    held: bool,
    memory: Contraction,
    qp: Vec<f64>,
    /// the predicted motion at this instant (dimensionless)
    motion: f64,
    /// Hermite's start (its chord starts from it, biased, at this instant: `hermite`)
    start: Vec<f64>,
    hermite: bool,
    /// whether its next start adds the last one's error, room for the biased start (crate::step::Work's)
    bias: Bias,
    biased: Vec<f64>,
    judge: bool,
    chord: Chord,
    settled: Option<Settled>,
    det0: i8,
    /// its rates are solved at this instant
    rate: bool,
    /// (first instant not taken, why) once it stopped
    end: Option<(usize, Why)>,
    /// it needs the scalar march alone (a state without rates to predict from)
    again: bool,
}

/// The group's numbers over lanes and one lane's scalar room.
struct Room {
    q: Vec<W>,
    e: Vec<Complex<W>>,
    /// the angles e holds (NaN: none yet)
    seen: Vec<W>,
    /// each angle's last e^{i a} from sin_cos, per lane (model::follow)
    anchor: Vec<[Anchor; WIDTH]>,
    /// per lane: q was set (a start), not corrected, since e was rotated
    fresh: [bool; WIDTH],
    phi: Vec<W>,
    values: Vec<W>,
    qd: Vec<W>,
    rhs: Vec<W>,
    one: Vec<f64>,
    b: Vec<f64>,
    dq: Vec<f64>,
}

impl Room {
    /// Lane l of v into out.
    fn lane(v: &[W], l: usize, out: &mut [f64]) {
        for (o, x) in out.iter_mut().zip(v) {
            *o = x.0[l];
        }
    }

    /// e = e^{i q} at the angle columns, lane by lane as march::Native's
    /// (Kin::rotate_changed: kept where q has not moved, from the anchor
    /// after a start, turned after a correction: model::follow).
    fn rotate(&mut self, kin: &Kin<W>) {
        for &j in &kin.angles {
            let (e, seen, anchor, q) = (&mut self.e[j], &mut self.seen[j].0, &mut self.anchor[j], &self.q[j].0);
            for l in 0..WIDTH {
                let mut z = C64::new(e.re.0[l], e.im.0[l]);
                let how = if self.fresh[l] { Rotation::Fresh } else { Rotation::Turn };
                follow(q[l], &mut seen[l], &mut z, &mut anchor[l], how);
                (e.re.0[l], e.im.0[l]) = (z.re, z.im);
            }
        }
        self.fresh = [false; WIDTH];
    }
}

/// Per lane: (first instant not taken, why, det sign at its first
/// instant), or None for a lane to march alone; `row(l, k, state)` at
/// every instant k lane l takes (crate::variants writes its columns there).
#[allow(clippy::too_many_arguments)]
pub fn march(
    wide: &Kin<W>,
    layout: &Layout,
    times: &[f64],
    q0: &[f64],
    s: &Settings,
    watch: &Watch,
    mut row: impl FnMut(usize, usize, &MarchState),
) -> Vec<Option<(usize, Why, i8)>> {
    let (n, m, kk) = (wide.n, wide.m, times.len());
    let mut lanes: Vec<Lane> = (0..WIDTH)
        .map(|_| Lane {
            f: layout.factors(),
            phi: vec![0.0; m],
            newton: None,
            st: MarchState::new(q0),
            held: false,
            memory: Contraction::none(),
            motion: 0.0,
            qp: vec![0.0; n],
            start: vec![0.0; n],
            hermite: false,
            bias: Bias::new(wide.smooth),
            biased: vec![0.0; n],
            judge: false,
            chord: Chord::Off,
            settled: None,
            det0: 0,
            rate: false,
            end: None,
            again: false,
        })
        .collect();
    let mut r = Room {
        q: vec![W::zero(); n],
        e: vec![Complex::new(W::one(), W::zero()); n],
        seen: vec![W::c(f64::NAN); n],
        anchor: vec![[Anchor::NONE; WIDTH]; n],
        fresh: [true; WIDTH],
        phi: vec![W::zero(); m],
        values: vec![W::zero(); wide.nnz],
        qd: vec![W::zero(); n],
        rhs: vec![W::zero(); m],
        one: vec![0.0; m.max(wide.nnz)],
        b: vec![0.0; m],
        dq: vec![0.0; n],
    };
    let (scale, col_scale) = (&layout.scale, &layout.col_scale);
    // the LU over lanes where the layout is block-triangular, else each lane's own
    let mut lu = LaneLu::new(layout);
    let fixed = |lu: &Option<LaneLu>, l: usize| lu.as_ref().is_some_and(|u| u.fixed[l]);
    let mut dq = vec![W::zero(); n];
    let mut next = Instant::now();
    for k in 0..kk {
        let t = times[k];
        let live = |x: &Lane| x.end.is_none() && !x.again;
        if !lanes.iter().any(live) {
            break;
        }
        if k % WATCH_EVERY == 0 {
            if let Some(why) = watch.check(false, &mut next) {
                lanes.iter_mut().filter(|x| live(x)).for_each(|x| x.end = Some((k, why)));
                break;
            }
        }
        // the predictor and the chord's start, per lane (crate::step::step)
        for x in lanes.iter_mut() {
            (x.chord, x.rate) = (Chord::Off, false);
        }
        for (l, x) in lanes.iter_mut().enumerate().filter(|(_, x)| live(x)) {
            let st = &x.st;
            let taylor_from = s.rates && !st.t.is_nan();
            if taylor_from && !st.rates {
                x.again = true;
                continue;
            }
            x.judge = predict(st, t, taylor_from, &mut x.qp);
            x.motion = gap(&x.qp, &st.q, col_scale);
            x.hermite = x.held && hermite_near(st, t);
            if x.held {
                let taylor = if taylor_from { Some(&x.qp[..]) } else { None };
                let from = if x.hermite {
                    biased_start(st, t, taylor, &mut x.start, &x.bias, &mut x.biased);
                    &x.biased
                } else {
                    &x.qp
                };
                for j in 0..n {
                    r.q[j].0[l] = from[j];
                }
                r.fresh[l] = true;
                x.chord = Chord::On(newton::Chord::new(x.memory.known(x.motion)));
            }
            x.held = false;
        }
        // the chord (newton::chord) in lockstep: one Phi over the lanes a correction
        for step in 0..CHORD_STEPS {
            if !lanes.iter().any(|x| matches!(x.chord, Chord::On { .. })) {
                break;
            }
            r.rotate(wide);
            wide.phi(&At { q: &r.q, e: &r.e, t }, &mut r.phi);
            if let Some(u) = lu.as_mut().filter(|u| u.fixed.iter().any(|&f| f)) {
                u.solve(&r.phi, &mut dq);
            }
            for (l, x) in lanes.iter_mut().enumerate() {
                let Chord::On(c) = &mut x.chord else { continue };
                Room::lane(&r.phi, l, &mut r.one[..m]);
                if !c.residual(step, residual(&r.one[..m], scale), s.tolerance) {
                    x.chord = Chord::Failed;
                    continue;
                }
                // correct(max_step) as march::Native's (q - f Phi_q^-1 Phi)
                if fixed(&lu, l) {
                    Room::lane(&dq, l, &mut r.dq);
                } else {
                    layout.solve(&mut x.f, &r.one[..m], &mut r.dq);
                }
                let big = size(&r.dq, col_scale);
                let f = limited(big, s.max_step);
                for j in 0..n {
                    r.q[j].0[l] -= f * r.dq[j];
                }
                match c.corrected(step, big, s.tolerance) {
                    Verdict::Go => {}
                    Verdict::Done(settled, measured) => x.chord = Chord::Done(settled, measured),
                    Verdict::Stop => x.chord = Chord::Failed,
                }
            }
        }
        // Newton from the predictor where there was no chord or it gave up; the chord's memory
        // (crate::step::step)
        for (l, x) in lanes.iter_mut().enumerate().filter(|(_, x)| live(x)) {
            (x.settled, x.newton) = match x.chord {
                Chord::Done(settled, measured) => {
                    x.memory.chorded(measured, x.motion);
                    (Some(settled), None)
                }
                _ => {
                    x.memory.forget();
                    for j in 0..n {
                        r.q[j].0[l] = x.qp[j];
                    }
                    r.fresh[l] = true;
                    (None, Some(Settling::new(s.tolerance, s.max_iterations, s.max_step, true)))
                }
            };
        }
        settle(wide, layout, t, &mut lanes, &mut r);
        // the factorisation at each lane's final q (the chord's last step; Newton's, again), from
        // one Jacobian over the lanes: over lanes where the fixed order suits, else the lane's own
        r.rotate(wide);
        wide.jac(&At { q: &r.q, e: &r.e, t }, &mut r.values);
        if let Some(u) = lu.as_mut() {
            u.factor(&r.values);
        }
        for (l, x) in lanes.iter_mut().enumerate().filter(|(_, x)| live(x)) {
            let newton = !matches!(x.chord, Chord::Done(..));
            if !fixed(&lu, l) && !newton {
                Room::lane(&r.values, l, &mut r.one[..wide.nnz]);
                layout.factor(&r.one[..wide.nnz], &mut x.f);
            }
        }
        // the acceptance test (crate::step::step, Mode::Track)
        let mut rates = false;
        for (l, x) in lanes.iter_mut().enumerate().filter(|(_, x)| live(x)) {
            let settled =
                x.settled.take().unwrap_or(Settled { iterations: 0, residual: 0.0, converged: false, last_step: 0.0 });
            if !settled.converged {
                x.end = Some((k, Why::NotConverged));
                continue;
            }
            let stats = match &lu {
                Some(u) if u.fixed[l] => u.stats[l],
                _ => layout.stats(&x.f),
            };
            let (pivot, det, previous) = signs(stats, &x.st);
            Room::lane(&r.q, l, &mut r.dq);
            let (corr, motion) = (gap(&r.dq, &x.qp, col_scale), x.motion);
            let why =
                rejected(pivot, settled.last_step, det, previous, corr, motion, x.judge, s.floor, s.tolerance, false);
            if why != Why::Accepted {
                x.end = Some((k, why));
                continue;
            }
            x.held = true;
            x.memory.hold(pivot);
            let chorded = matches!(x.chord, Chord::Done(..));
            x.bias.measure(x.hermite && chorded, t - x.st.t);
            x.st.take(&r.dq, t, det, s.rates);
            if k == 0 {
                x.det0 = det as i8;
            }
            x.rate = s.rates && pivot > 0.0;
            if s.rates && !x.rate {
                x.st.no_rates();
            }
            rates |= x.rate;
        }
        // the rates (crate::step::rates_with): nu and gamma over the lanes, each lane's solves
        if rates {
            let taking = |x: &Lane| live(x) && x.rate;
            wide.nu(t, &mut r.rhs);
            solve(&mut lu, &mut lanes, layout, &taking, &r.rhs, &mut r.qd, &mut r.b, false);
            wide.gamma(&At { q: &r.q, e: &r.e, t }, &r.qd, &mut r.rhs);
            solve(&mut lu, &mut lanes, layout, &taking, &r.rhs, &mut dq, &mut r.b, true);
            lanes.iter_mut().filter(|x| taking(x)).for_each(|x| x.st.rates = true);
        }
        for (l, x) in lanes.iter().enumerate().filter(|(_, x)| live(x)) {
            row(l, k, &x.st);
        }
    }
    lanes
        .iter()
        .map(|x| {
            if x.again {
                None
            } else {
                Some((x.end.map_or(kk, |e| e.0), x.end.map_or(Why::Accepted, |e| e.1), x.det0))
            }
        })
        .collect()
}

/// Newton (`Settling`: newton::settle's steps) for the lanes that have one,
/// in lockstep: per round each lane's corrections with its own factors
/// (march::Native::correct's), then one Phi and one Jacobian over the lanes
/// for the lanes that ask them, each lane's residual and its own LU
/// (Native::evaluate's, factor's). A lane's operations read only its own
/// lane, so each equals the scalar march's to the bit.
fn settle(wide: &Kin<W>, layout: &Layout, t: f64, lanes: &mut [Lane], r: &mut Room) {
    let mut ask: [Option<Ask>; WIDTH] = std::array::from_fn(|l| lanes[l].newton.as_mut().map(|w| w.next(0.0)));
    let (n, nnz) = (wide.n, wide.nnz);
    loop {
        for (x, a) in lanes.iter_mut().zip(ask.iter_mut()) {
            if let Some(Ask::Done(settled)) = *a {
                (x.settled, x.newton, *a) = (Some(settled), None, None);
            }
        }
        if ask.iter().all(Option::is_none) {
            return;
        }
        let mut result = [0.0; WIDTH];
        for (l, x) in lanes.iter_mut().enumerate() {
            let Some(Ask::Correct(limit)) = ask[l] else { continue };
            // as march::Native::correct: q - f Phi_q^-1 Phi
            layout.solve(&mut x.f, &x.phi, &mut r.dq);
            let big = size(&r.dq, &layout.col_scale);
            let f = limited(big, limit);
            for j in 0..n {
                r.q[j].0[l] -= f * r.dq[j];
            }
            result[l] = big;
        }
        let evaluate = ask.iter().any(|a| matches!(a, Some(Ask::Evaluate(_))));
        let factor = ask.iter().any(|a| matches!(a, Some(Ask::Factor(_))));
        if evaluate || factor {
            r.rotate(wide);
        }
        if evaluate {
            wide.phi(&At { q: &r.q, e: &r.e, t }, &mut r.phi);
        }
        if factor {
            wide.jac(&At { q: &r.q, e: &r.e, t }, &mut r.values);
        }
        for (l, x) in lanes.iter_mut().enumerate() {
            match ask[l] {
                Some(Ask::Evaluate(_)) => {
                    Room::lane(&r.phi, l, &mut x.phi);
                    result[l] = residual(&x.phi, &layout.scale);
                }
                Some(Ask::Factor(_)) => {
                    Room::lane(&r.values, l, &mut r.one[..nnz]);
                    layout.factor(&r.one[..nnz], &mut x.f);
                }
                _ => {}
            }
            if let (Some(_), Some(w)) = (ask[l], x.newton.as_mut()) {
                ask[l] = Some(w.next(result[l]));
            }
        }
    }
}

/// x = Phi_q^-1 b for the lanes `taking`: over lanes where their
/// factorisation is, else each alone; into each lane's qd (`second`: qdd) and xw's lane.
#[allow(clippy::too_many_arguments)]
fn solve(
    lu: &mut Option<LaneLu>,
    lanes: &mut [Lane],
    layout: &Layout,
    taking: &dyn Fn(&Lane) -> bool,
    b: &[W],
    xw: &mut [W],
    room: &mut [f64],
    second: bool,
) {
    fn into(x: &mut Lane, second: bool) -> &mut Vec<f64> {
        if second {
            &mut x.st.qdd
        } else {
            &mut x.st.qd
        }
    }
    let fixed: [bool; WIDTH] = std::array::from_fn(|l| lu.as_ref().is_some_and(|u| u.fixed[l]) && taking(&lanes[l]));
    if let Some(u) = lu.as_mut().filter(|_| fixed.iter().any(|&f| f)) {
        u.solve(b, xw);
    }
    for (l, x) in lanes.iter_mut().enumerate().filter(|(_, x)| taking(x)) {
        if fixed[l] {
            let out = into(x, second);
            Room::lane(xw, l, out);
        } else {
            Room::lane(b, l, room);
            let mut out = std::mem::take(into(x, second));
            layout.solve(&mut x.f, room, &mut out);
            for (w, &v) in xw.iter_mut().zip(&out) {
                w.0[l] = v;
            }
            *into(x, second) = out;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::functions::POLY;
    use num_complex::Complex64 as C64;

    /// Variant l: a revolute and a distance driver (a cubic) over three
    /// bodies, its numbers moved by l.
    fn variant(l: usize) -> Tables {
        let d = 0.01 * l as f64;
        let mut rev = Table::default();
        rev.ints.insert("ci".into(), vec![0]);
        rev.ints.insert("cj".into(), vec![3]);
        rev.complex.insert("si".into(), vec![C64::new(0.4 + d, 0.1)]);
        rev.complex.insert("sj".into(), vec![C64::new(0.0, -0.5 - d)]);
        let mut dist = Table::default();
        dist.ints.insert("ci".into(), vec![3]);
        dist.ints.insert("cj".into(), vec![6]);
        dist.ints.insert("f".into(), vec![0]);
        dist.complex.insert("si".into(), vec![C64::new(-0.3, 0.2 * (1.0 + d))]);
        dist.complex.insert("sj".into(), vec![C64::new(0.6, 0.6)]);
        let mut f = Table::default();
        f.ints.insert("kind".into(), vec![POLY]);
        f.ints.insert("start".into(), vec![0, 4]);
        f.reals.insert("data".into(), vec![0.9 + d, 0.5, -0.2 * d, 0.1]);
        (vec![("revolute".into(), rev), ("distance".into(), dist)], f, Table::default())
    }

    /// The model over lanes gives, lane by lane and to the bit, each
    /// variant's own Phi, Jacobian, nu and gamma.
    #[test]
    fn the_model_over_lanes_is_each_variants_model() {
        let (n, angles) = (9, vec![2, 5, 8]);
        let lanes: Vec<Tables> = (0..WIDTH).map(variant).collect();
        let wide = wide_kin(n, &angles, &lanes).unwrap();
        let kins: Vec<Kin> =
            lanes.iter().map(|(f, fu, o)| Kin::new(n, f.clone(), fu, o, angles.clone()).unwrap()).collect();
        let q: Vec<W> =
            (0..n).map(|j| Wide(std::array::from_fn(|l| (0.3 * j as f64 + 0.1 * l as f64).sin()))).collect();
        let qd: Vec<W> = (0..n).map(|j| Wide(std::array::from_fn(|l| 0.2 * j as f64 - 0.05 * l as f64))).collect();
        let mut e = vec![Complex::new(W::one(), W::zero()); n];
        wide.rotate(&q, &mut e);
        let (t, m, nnz) = (0.7, wide.m, wide.nnz);
        let (mut phi, mut jac, mut nu, mut gamma) =
            (vec![W::zero(); m], vec![W::zero(); nnz], vec![W::zero(); m], vec![W::zero(); m]);
        let at = At { q: &q, e: &e, t };
        wide.phi(&at, &mut phi);
        wide.jac(&at, &mut jac);
        wide.nu(t, &mut nu);
        wide.gamma(&at, &qd, &mut gamma);
        for (l, kin) in kins.iter().enumerate() {
            let (ql, qdl): (Vec<f64>, Vec<f64>) =
                (q.iter().map(|x| x.0[l]).collect(), qd.iter().map(|x| x.0[l]).collect());
            let mut el = vec![C64::new(1.0, 0.0); n];
            kin.rotate(&ql, &mut el);
            let (mut p, mut j, mut v, mut g) = (vec![0.0; m], vec![0.0; nnz], vec![0.0; m], vec![0.0; m]);
            let at = At { q: &ql, e: &el, t };
            kin.phi(&at, &mut p);
            kin.jac(&at, &mut j);
            kin.nu(t, &mut v);
            kin.gamma(&at, &qdl, &mut g);
            for (wide, one) in [(&phi, &p), (&jac, &j), (&nu, &v), (&gamma, &g)] {
                assert!(wide.iter().zip(one.iter()).all(|(w, s)| w.0[l].to_bits() == s.to_bits()), "lane {l}");
            }
        }
        // the lanes differ: the variants' numbers reached them
        assert!(phi.iter().any(|x| x.0[0] != x.0[WIDTH - 1]) && nu.iter().any(|x| x.0[0] != x.0[1]));
        assert!(suits(&Table::default()) && !suits(&lanes[0].1));
    }
}
