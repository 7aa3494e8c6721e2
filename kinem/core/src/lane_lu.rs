//! J_s's LU over lanes (crate::lanes): the block-triangular layout
//! (crate::triangular) factorised and solved for WIDTH variants per
//! instruction, each diagonal block in its fixed pivot order
//! (crate::order's program, the same operations in the same order as
//! Order::numeric and Order::eliminate, so each lane's factors, pivots and
//! solutions are the scalar's to the bit). The order is checked per lane
//! (shared/reference/performance.md, "What a static pivot order must
//! respect"): a lane with a zero or non-finite pivot, a multiplier above
//! crate::order::MULTIPLIER, or pivots spanning more than
//! crate::lu::FALLBACK is not `fixed`: the caller factorises that lane
//! alone (Layout::factor: partial pivoting, as the scalar march does).
use crate::lanes::{W, WIDTH};
use crate::lu::{Layout, Shape, FALLBACK};
use crate::order::{Order, MULTIPLIER};
use crate::real::Real;
use crate::triangular::{Triangular, BLOCK};
use crate::wide::Wide;

pub struct LaneLu<'a> {
    t: &'a Triangular,
    /// the diagonal blocks' factors (at their Factors::j places) and the off-diagonal values
    j: Vec<W>,
    off: Vec<W>,
    w: Vec<W>,
    /// per lane: factorised in the fixed order, and then its (pivot ratio, det sign)
    pub fixed: [bool; WIDTH],
    pub stats: [(f64, i32); WIDTH],
}

/// a where the lane's flag is set, else b.
#[inline(always)]
fn pick(flag: [bool; WIDTH], a: W, b: W) -> W {
    let mut x = b.0;
    for l in 0..WIDTH {
        if flag[l] {
            x[l] = a.0[l];
        }
    }
    Wide(x)
}

impl<'a> LaneLu<'a> {
    /// For a block-triangular layout (None otherwise: each lane's own LU).
    pub fn new(layout: &'a Layout) -> Option<Self> {
        let Shape::Triangular(t) = &layout.shape else { return None };
        let n = t.gather.len();
        Some(LaneLu {
            t,
            j: vec![W::default(); t.stored()],
            off: vec![W::default(); t.off_entries.len()],
            w: vec![W::default(); n],
            fixed: [false; WIDTH],
            stats: [(0.0, 0); WIDTH],
        })
    }

    /// J_s from the Jacobian's values over lanes, as Triangular::factor's blocks.
    pub fn factor(&mut self, values: &[W]) {
        let t = self.t;
        for (x, &(e, scale)) in self.off.iter_mut().zip(&t.off_entries) {
            *x = values[e as usize] * scale;
        }
        let mut ok = [true; WIDTH];
        let (mut small, mut big, mut det) = ([f64::INFINITY; WIDTH], [0.0f64; WIDTH], [t.sign; WIDTH]);
        let mut pivot = |d: W, ok: &mut [bool; WIDTH]| {
            for l in 0..WIDTH {
                let x = d.0[l];
                if x == 0.0 || !x.is_finite() {
                    ok[l] = false;
                    continue;
                }
                if x < 0.0 {
                    det[l] = -det[l];
                }
                small[l] = small[l].min(x.abs());
                big[l] = big[l].max(x.abs());
            }
        };
        for d in &t.blocks {
            let a = &mut self.j[d.store..d.store + d.s * d.s];
            match &d.order {
                None => {
                    for &(e, scale) in &d.entries {
                        a[0] = values[e as usize] * scale;
                    }
                    pivot(a[0], &mut ok);
                }
                Some(o) => {
                    for &at in &o.fill_at {
                        a[at] = W::default();
                    }
                    for &(e, at, scale) in &o.place {
                        a[at as usize] = values[e as usize] * scale;
                    }
                    numeric(o, a, &mut ok);
                    for k in 0..d.s {
                        pivot(a[k * d.s + k], &mut ok);
                    }
                }
            }
        }
        for l in 0..WIDTH {
            let ratio = if big[l] > 0.0 { small[l] / big[l] } else { 0.0 };
            self.fixed[l] = ok[l] && ratio >= FALLBACK;
            self.stats[l] = (ratio, det[l]);
        }
    }

    /// x = Phi_q^-1 b over lanes (model rows in, coordinates out), as
    /// Triangular::solve's blocks; the lanes not `fixed` hold nothing of use.
    pub fn solve(&mut self, b: &[W], x: &mut [W]) {
        let t = self.t;
        let w = &mut self.w;
        for ((v, &i), &scale) in w.iter_mut().zip(&t.gather).zip(&t.gscale) {
            *v = b[i] * scale;
        }
        let (j, off) = (&self.j, &self.off);
        for &(r, c, v) in &t.program {
            let (r, c, v) = (r as usize, c as usize, v as usize);
            if r == c {
                w[r] = w[r] / j[v];
            } else if r == BLOCK as usize {
                let d = &t.blocks[c];
                if let Some(o) = &d.order {
                    eliminate(o, &j[d.store..d.store + d.s * d.s], &mut w[d.at..d.at + d.s]);
                }
            } else {
                let y = w[c];
                w[r] = w[r] - off[v] * y;
            }
        }
        for ((&v, &j), &scale) in w.iter().zip(&t.scatter).zip(&t.sscale) {
            x[j] = v * scale;
        }
    }
}

/// Order::numeric over lanes (its checks per lane into ok; a lane's
/// updates skipped where its multiplier is zero, as the scalar's).
fn numeric(o: &Order, a: &mut [W], ok: &mut [bool; WIDTH]) {
    let s = o.s;
    let (steps, mult, right, right_start, _) = o.program();
    for &(k, lo, hi) in steps {
        let k = k as usize;
        let r = W::c(1.0) / a[k * s + k];
        let right = &right[right_start[k] as usize..right_start[k + 1] as usize];
        for &(i, at) in &mult[lo as usize..hi as usize] {
            let l = a[at as usize] * r;
            let mut nonzero = [false; WIDTH];
            for q in 0..WIDTH {
                ok[q] &= l.0[q].abs() <= MULTIPLIER;
                nonzero[q] = l.0[q] != 0.0;
            }
            a[at as usize] = l;
            if nonzero.iter().any(|&x| x) {
                let (i, k) = (i as usize * s, k * s);
                for &j in right {
                    let (to, from) = (i + j as usize, k + j as usize);
                    a[to] = pick(nonzero, a[to] - l * a[from], a[to]);
                }
            }
        }
    }
}

/// Order::eliminate over lanes: y <- U^-1 L^-1 y.
fn eliminate(o: &Order, a: &[W], y: &mut [W]) {
    let (steps, mult, _, _, back) = o.program();
    for &(k, lo, hi) in steps {
        let yk = y[k as usize];
        let nonzero = yk.0.map(|x| x != 0.0);
        if nonzero.iter().any(|&x| x) {
            for &(i, at) in &mult[lo as usize..hi as usize] {
                let i = i as usize;
                y[i] = pick(nonzero, y[i] - a[at as usize] * yk, y[i]);
            }
        }
    }
    for &(i, at, k) in back {
        let (i, at, k) = (i as usize, at as usize, k as usize);
        if i == k {
            y[k] = y[k] / a[at];
        } else {
            y[i] = y[i] - a[at] * y[k];
        }
    }
}
