//! Independent parts marched on their own (issue 23, "batch across
//! cores"): a model whose Jacobian has several diagonal blocks (merged
//! variants, kinem.batch) is split once into one model per block, and each
//! part marches with its own predictor, Newton, acceptance test and rate
//! solves, in parallel (rayon). A part that converges in one iteration does
//! not iterate again because another needs three; the march of the whole
//! ends where the first part stops, and the tracker (kinem/tracking.py)
//! takes that instant for the whole model as before.
use crate::accept::Why;
use crate::families::At;
use crate::lu::Layout;
use crate::march::{run, MarchState, Native, Out, Room, Settings, Step};
use crate::model::Kin;
use crate::newton::Ops;
use crate::watch::Watch;
use rayon::prelude::*;

/// One diagonal block as a model of its own: its evaluation and layout over
/// its coordinates `cols` (global, ascending).
pub struct Part {
    pub kin: Kin,
    pub layout: Layout,
    pub cols: Vec<usize>,
}

/// The parts of a model of `layout.count` >= 2 blocks, each checked once:
/// its residual and Jacobian values at an arbitrary configuration equal the
/// whole model's at the block's rows and entries, to the bit (they are the
/// same arithmetic on the same numbers).
pub fn split(kin: &Kin, layout: &Layout) -> Result<Vec<Part>, String> {
    let (count, s) = (layout.count, layout.height);
    let (mut rows, mut cols, mut entries) = (vec![Vec::new(); count], vec![Vec::new(); count], vec![Vec::new(); count]);
    for (i, &p) in layout.row_pos.iter().enumerate() {
        rows[p / s].push(i);
    }
    for (j, &p) in layout.col_pos.iter().enumerate() {
        cols[p / s].push(j);
    }
    for (e, &(b, _, _)) in layout.at.iter().enumerate() {
        entries[b].push(e);
    }
    let kins = kin.split(&cols)?;
    // the check's configuration
    let q: Vec<f64> = (0..kin.n).map(|j| (0.37 * j as f64 + 0.2).sin()).collect();
    let t = 0.43;
    let (phi, jac) = evaluate(kin, &q, t);
    let mut parts = Vec::with_capacity(count);
    for (c, k) in kins.into_iter().enumerate() {
        let l = layout.part(c, &rows[c], &cols[c], &entries[c]).ok_or("not a blocks layout")?;
        if k.m != rows[c].len() || k.nnz != entries[c].len() {
            return Err(format!(
                "part {c}: {} rows and {} entries for the block's {} and {}",
                k.m,
                k.nnz,
                rows[c].len(),
                entries[c].len()
            ));
        }
        let local: Vec<f64> = cols[c].iter().map(|&j| q[j]).collect();
        let (p, v) = evaluate(&k, &local, t);
        let same = rows[c].iter().zip(&p).all(|(&i, &x)| x.to_bits() == phi[i].to_bits())
            && entries[c].iter().zip(&v).all(|(&e, &x)| x.to_bits() == jac[e].to_bits());
        if !same {
            return Err(format!("part {c}: its residual or Jacobian differs from the whole model's"));
        }
        let mut l = l;
        crate::plan::order_blocks(&k, &mut l);
        parts.push(Part { kin: k, layout: l, cols: cols[c].clone() });
    }
    Ok(parts)
}

fn evaluate(kin: &Kin, q: &[f64], t: f64) -> (Vec<f64>, Vec<f64>) {
    let mut e = vec![num_complex::Complex64::new(1.0, 0.0); kin.n];
    kin.rotate(q, &mut e);
    let at = At { q, e: &e, t };
    let (mut phi, mut jac) = (vec![0.0; kin.m], vec![0.0; kin.nnz]);
    kin.phi(&at, &mut phi);
    kin.jac(&at, &mut jac);
    (phi, jac)
}

/// One stage's outputs of a part's march (q, qd or qdd).
type Stage = fn(&Marched) -> &[f64];

/// What one part's march over a window left: its outputs from the window's
/// first instant k (row i - k for instant i), where it stopped and why.
struct Marched {
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    iterations: Vec<i64>,
    residual: Vec<f64>,
    pivot: Vec<f64>,
    det: Vec<i8>,
    counts: [i64; 2],
    end: usize,
    why: Why,
}

/// The first window's instants; each window without a stop doubles it. A
/// part that stops makes every other part stop at that instant too (the
/// tracker takes it for the whole model), so the others have marched at
/// most WINDOW instants or twice as far as the whole did past it: resuming
/// after every instant of a long run costs about WINDOW instants each time,
/// not a march to the end.
const WINDOW: usize = 4;

/// crate::march::run for a model split into parts, with the whole model's
/// state and outputs: the parts march from the state at their coordinates,
/// in parallel, over windows of instants; the whole takes the instants
/// every part took, each instant's iterations and residual the largest of
/// the parts', its pivot ratio the smallest, its det sign `sign` times the
/// parts' product; the counts are the busiest part's. The state is left at
/// the last instant taken.
#[allow(clippy::too_many_arguments)]
pub fn run_parts(
    parts: &[Part],
    sign: i32,
    times: &[f64],
    k: usize,
    st: &mut MarchState,
    s: &Settings,
    mut out: Out,
    watch: &Watch,
) -> (usize, Why) {
    let kk = times.len();
    let n = st.q.len();
    let whole: &MarchState = st;
    let mut states: Vec<MarchState> = parts
        .par_iter()
        .map(|p| {
            let gather = |v: &[f64]| p.cols.iter().map(|&j| v[j]).collect::<Vec<f64>>();
            let rows = |v: &[f64], r: usize| p.cols.iter().map(move |&j| v[r * n + j]).collect::<Vec<f64>>();
            let mut ps = MarchState::new(&gather(&whole.q));
            if k == 0 || whole.t.is_nan() {
                return ps;
            }
            // the part's own det sign at the state it starts from (the assembly sets it at k = 0)
            let mut ops = Native::new(&p.kin, &p.layout);
            let Ok(()) = ops.start(&ps.q, whole.t);
            let Ok(()) = ops.factor(true);
            ps.det = p.layout.stats(&ops.f).1;
            (ps.qd, ps.qdd, ps.rates, ps.t) = (gather(&whole.qd), gather(&whole.qdd), whole.rates, whole.t);
            (ps.h, ps.tt, ps.before) = ((0..3).flat_map(|r| rows(&whole.h, r)).collect(), whole.tt, whole.before);
            ps.prev = [gather(&whole.prev[0]), gather(&whole.prev[1]), gather(&whole.prev[2])];
            ps
        })
        .collect();
    let (mut from, mut window, mut end, mut why) = (k, WINDOW, k, Why::Accepted);
    while from < kk {
        let stop = (from + window).min(kk);
        // the parts march on the pool while this thread polls for signals
        let marched: Vec<Marched> = watch.around(|| {
            parts
                .par_iter()
                .zip(states.par_iter_mut())
                .map(|(p, ps)| window_of(p, ps, &times[..stop], from, s, watch))
                .collect()
        });
        // the first part to stop, with why (a part that reached the window's end has why 0)
        (end, why) = marched
            .iter()
            .map(|m| (m.end, m.why))
            .min_by_key(|&(e, w)| (e, w == Why::Accepted))
            .unwrap_or((stop, Why::Accepted));
        gather(parts, &marched, n, from, end, s.rates, sign, &mut out);
        if end < stop {
            break;
        }
        (from, window) = (stop, 2 * window);
    }
    if k == 0 && end > k {
        st.restart();
    }
    // the whole state at the last instant taken, through the instants that make its history
    for j in end.saturating_sub(3).max(k)..end {
        st.take(&out.q[j * n..(j + 1) * n], times[j], out.det[j] as i32, s.rates);
        if s.rates {
            st.qd.copy_from_slice(&out.qd[j * n..(j + 1) * n]);
            st.qdd.copy_from_slice(&out.qdd[j * n..(j + 1) * n]);
            st.rates = true;
        }
    }
    (end, why)
}

/// Part p's march over times[from..] (a window: `times` ends where it
/// does), from and into its state ps.
fn window_of(p: &Part, ps: &mut MarchState, times: &[f64], from: usize, s: &Settings, watch: &Watch) -> Marched {
    let (nb, rows) = (p.cols.len(), times.len() - from);
    let mut m = Marched {
        q: vec![0.0; rows * nb],
        qd: vec![0.0; if s.rates { rows * nb } else { 0 }],
        qdd: vec![0.0; if s.rates { rows * nb } else { 0 }],
        iterations: vec![0; rows],
        residual: vec![0.0; rows],
        pivot: vec![0.0; rows],
        det: vec![0; rows],
        counts: [0, 0],
        end: from,
        why: Why::Accepted,
    };
    let o = Out {
        q: &mut m.q,
        qd: &mut m.qd,
        qdd: &mut m.qdd,
        iterations: &mut m.iterations,
        residual: &mut m.residual,
        pivot: &mut m.pivot,
        det: &mut m.det,
        counts: &mut m.counts,
        first: from,
    };
    (m.end, m.why) = run(&p.kin, &p.layout, times, from, ps, s, o, watch, false, &mut Room::new(&p.kin, &p.layout));
    m
}

/// The instants from..end that every part took, from the parts' window
/// outputs into the whole model's rows (in parallel over instants), with
/// each instant's figures; adds the busiest part's counts.
#[allow(clippy::too_many_arguments)]
fn gather(
    parts: &[Part],
    marched: &[Marched],
    n: usize,
    from: usize,
    end: usize,
    rates: bool,
    sign: i32,
    out: &mut Out,
) {
    let stages: [(&mut [f64], Stage); 3] =
        [(&mut *out.q, |m| &m.q), (&mut *out.qd, |m| &m.qd), (&mut *out.qdd, |m| &m.qdd)];
    for (x, of) in stages.into_iter().take(if rates { 3 } else { 1 }) {
        x.par_chunks_mut(n).enumerate().skip(from).take(end.saturating_sub(from)).for_each(|(i, row)| {
            let r = i - from;
            for (p, m) in parts.iter().zip(marched) {
                let nb = p.cols.len();
                for (&j, &v) in p.cols.iter().zip(&of(m)[r * nb..(r + 1) * nb]) {
                    row[j] = v;
                }
            }
        });
    }
    for i in from..end {
        let (r, mut it, mut res, mut piv, mut det) = (i - from, 0i64, 0.0f64, f64::INFINITY, sign);
        for m in marched {
            it = it.max(m.iterations[r]);
            if m.residual[r] > res || m.residual[r].is_nan() {
                res = m.residual[r];
            }
            piv = piv.min(m.pivot[r]);
            det *= m.det[r] as i32;
        }
        out.iterations[i] = it;
        out.residual[i] = res;
        out.pivot[i] = piv;
        out.det[i] = det as i8;
    }
    for c in 0..2 {
        out.counts[c] += marched.iter().map(|m| m.counts[c]).max().unwrap_or(0);
    }
}
