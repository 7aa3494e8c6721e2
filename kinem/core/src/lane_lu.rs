//! J_s's LU over lanes (crate::lanes): the block-triangular layout
//! (crate::triangular) factorised and solved for WIDTH variants per
//! instruction, each diagonal block in its fixed pivot order
//! (the scalar's own flat lists, triangular::Factoring and Program, run
//! over lanes: the same operations in the same order, so each lane's
//! factors, pivots and solutions are the scalar's to the bit). The order is checked per lane
//! (shared/reference/performance.md, "What a static pivot order must
//! respect"): a lane with a zero or non-finite pivot, a multiplier above
//! crate::order::MULTIPLIER, or pivots spanning more than
//! crate::lu::FALLBACK, a folded pivot (Factoring::one_entries) not exactly 1,
//! a negated one (Factoring::minus_entries: its reciprocal is the -1 set
//! once, as the scalar's) not exactly -1
//! or an entry taken for zero (Factoring::zero_entries) not exactly 0
//! is not `fixed`: the caller factorises that lane
//! alone (Layout::factor: partial pivoting, as the scalar march does).
use crate::lanes::{W, WIDTH};
use crate::lu::{Layout, Shape, FALLBACK};
use crate::order::MULTIPLIER;
use crate::triangular::Triangular;

pub struct LaneLu<'a> {
    t: &'a Triangular,
    /// the blocks' factors and the off-diagonal values (Factors::j's places)
    j: Vec<W>,
    /// per lane: factorised in the fixed order, and then its (pivot ratio, det sign)
    pub fixed: [bool; WIDTH],
    pub stats: [(f64, i32); WIDTH],
}

impl<'a> LaneLu<'a> {
    /// For a block-triangular layout (None otherwise: each lane's own LU).
    pub fn new(layout: &'a Layout) -> Option<Self> {
        let Shape::Triangular(t) = &layout.shape else { return None };
        let mut j = vec![W::default(); t.factoring.values];
        t.factoring.init(&mut j);
        Some(LaneLu { t, j, fixed: [false; WIDTH], stats: [(0.0, 0); WIDTH] })
    }

    /// J_s from the Jacobian's values over lanes: Factoring's elimination
    /// over lanes, its checks lane by lane.
    pub fn factor(&mut self, values: &[W]) {
        let (f, a) = (&self.t.factoring, &mut self.j);
        let mut ok = [true; WIDTH];
        f.eliminate(values, a, |l: W, scale| {
            for q in 0..WIDTH {
                ok[q] &= (l.0[q] * scale).abs() <= MULTIPLIER; // false for a zero or non-finite pivot too
            }
        });
        for &e in &f.one_entries {
            let v = values[e as usize];
            for q in 0..WIDTH {
                ok[q] &= v.0[q] == 1.0;
            }
        }
        for &e in &f.minus_entries {
            let v = values[e as usize];
            for q in 0..WIDTH {
                ok[q] &= v.0[q] == -1.0; // as the scalar's Factoring::run: that lane's own LU
            }
        }
        for &e in &f.zero_entries {
            let v = values[e as usize];
            for q in 0..WIDTH {
                ok[q] &= v.0[q] == 0.0; // a lane that moved a zero local point: its own LU
            }
        }
        let (mut small, mut big, mut det) = ([f64::INFINITY; WIDTH], [0.0f64; WIDTH], [self.t.sign; WIDTH]);
        for (&at, &scale) in f.diag.iter().zip(&f.pivot_scale) {
            for q in 0..WIDTH {
                let d = a[at as usize].0[q] * scale; // J_s's pivot (Factoring)
                if d == 0.0 || !d.is_finite() {
                    ok[q] = false;
                    continue;
                }
                if d < 0.0 {
                    det[q] = -det[q];
                }
                small[q] = small[q].min(d.abs());
                big[q] = big[q].max(d.abs());
            }
        }
        for l in 0..WIDTH {
            let ratio = if big[l] > 0.0 { small[l] / big[l] } else { 0.0 };
            self.fixed[l] = ok[l] && ratio >= FALLBACK;
            self.stats[l] = (ratio, det[l]);
        }
    }

    /// x = Phi_q^-1 b over lanes (model rows in, coordinates out):
    /// Triangular::solve's gather, Program::run and scatter over lanes;
    /// the lanes not `fixed` hold nothing of use.
    pub fn solve(&mut self, b: &[W], x: &mut [W]) {
        self.t.run(&self.j, b, x);
    }
}
