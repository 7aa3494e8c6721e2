//! A trajectory's named columns (kinem.result.trajectory) from the raw
//! coordinates, in one pass: each column is a coordinate of a stage
//! (positions, velocities, accelerations) or a named point's x or y there
//! (r + A s', its first and second derivatives, Eqs. 4.43-4.45).
//! Over S = Dual (crate::real) it gives the columns' tangents along a
//! design parameter (kinem.sensitivity) from the coordinates' tangents.
use crate::families::lane;
use crate::real::{cis, i, Lanes, Real};
use num_complex::{Complex, Complex64 as C64};

/// out (K, C): column c of instant k is coordinate src[c] of stage
/// src[c] / n when src[c] < stages n, else entry src[c] - stages n of the
/// points' values [x_0 .., y_0 .., vx_0 .., vy_0 .., ax_0 .., ay_0 ..], point
/// p on the body whose x column is pc[p], at s'_p = local[p]. x[s] holds
/// stage s (K n each).
pub fn columns<S: Real>(x: &[&[S]], n: usize, src: &[usize], pc: &[usize], local: &[Complex<S>], out: &mut [S]) {
    let stages = x.len();
    let w = src.len();
    let k_count = x[0].len().checked_div(n).unwrap_or(0);
    let layout = Columns::new(n, stages, src, pc);
    let mut pts = vec![S::zero(); 2 * stages * pc.len()];
    for k in 0..k_count {
        let rows: Vec<&[S]> = x.iter().map(|a| &a[k * n..(k + 1) * n]).collect();
        layout.row(&rows, local, &mut pts, &mut out[k * w..(k + 1) * w]);
    }
}

/// The columns' sources laid out once for `row` (see `columns`).
pub struct Columns<'a> {
    pc: &'a [usize],
    /// each column's stage and index there (stage `stages`: a point's value in pts)
    from: Vec<(usize, usize)>,
    stages: usize,
}

impl<'a> Columns<'a> {
    pub fn new(n: usize, stages: usize, src: &[usize], pc: &'a [usize]) -> Self {
        let from =
            src.iter().map(|&j| if j < stages * n { (j / n, j % n) } else { (stages, j - stages * n) }).collect();
        Columns { pc, from, stages }
    }

    /// One instant's columns: x[s] its stage s (n each), pts scratch (2
    /// stages points), out its W columns.
    pub fn row<S: Real>(&self, x: &[&[S]], local: &[Complex<S>], pts: &mut [S], out: &mut [S]) {
        self.points(x, local, pts);
        for (o, &(s, j)) in out.iter_mut().zip(&self.from) {
            *o = if s < self.stages { x[s][j] } else { pts[j] };
        }
    }

    /// The named points' values at one instant (`row`'s pts).
    pub fn points<S: Real>(&self, x: &[&[S]], local: &[Complex<S>], pts: &mut [S]) {
        self.points_turned(x, local, |c| cis(x[0][c]), pts)
    }

    /// `points`, e^{i phi} of angle column c from `turn(c)` (the caller's
    /// own, e.g. the sensitivities' lanes: no sine and cosine taken again).
    pub fn points_turned<S: Real>(
        &self,
        x: &[&[S]],
        local: &[Complex<S>],
        turn: impl Fn(usize) -> Complex<S>,
        pts: &mut [S],
    ) {
        let (stages, p) = (self.stages, self.pc.len());
        let i = i::<S>();
        for (j, (&c, &s)) in self.pc.iter().zip(local).enumerate() {
            let q = x[0];
            let e = s * turn(c + 2);
            let v = Complex::new(q[c], q[c + 1]) + e;
            pts[j] = v.re;
            pts[p + j] = v.im;
            if stages > 1 {
                let qd = x[1];
                let om = qd[c + 2];
                let v = Complex::new(qd[c], qd[c + 1]) + i * e * om;
                pts[2 * p + j] = v.re;
                pts[3 * p + j] = v.im;
                if stages > 2 {
                    let qdd = x[2];
                    let v = Complex::new(qdd[c], qdd[c + 1]) + i * e * qdd[c + 2] - e * (om * om);
                    pts[4 * p + j] = v.re;
                    pts[5 * p + j] = v.im;
                }
            }
        }
    }
}

impl Columns<'_> {
    /// The named points' tangents alone (`points` over Lanes<N> without
    /// their values): x the stages' values (n each), d
    /// their N tangents (s, sd, sdd), local the points' local coordinates
    /// with their tangents, e^{i phi} of angle column c from `turn(c)` (the
    /// march's own); out as `points`' pts, N tangents an entry.
    pub fn point_tangents<const N: usize>(
        &self,
        x: &[&[f64]],
        d: &[&[[f64; N]]],
        local: &[Complex<Lanes<N>>],
        turn: impl Fn(usize) -> C64,
        out: &mut [[f64; N]],
    ) {
        let (stages, p) = (self.stages, self.pc.len());
        for (j, (&c, &s)) in self.pc.iter().zip(local).enumerate() {
            let e = turn(c + 2);
            let dq = d[0];
            let big = C64::new(s.re.v, s.im.v) * e;
            for l in 0..N {
                // dE = i E dphi + d(s') e
                let de = C64::new(-big.im, big.re) * dq[c + 2][l] + lane(s, l).1 * e;
                out[j][l] = dq[c][l] + de.re;
                out[p + j][l] = dq[c + 1][l] + de.im;
                if stages > 1 {
                    let (om, dom, dqd) = (x[1][c + 2], d[1][c + 2][l], d[1]);
                    // i E om: re -E.im om, im E.re om
                    out[2 * p + j][l] = dqd[c][l] + (-de.im * om + -big.im * dom);
                    out[3 * p + j][l] = dqd[c + 1][l] + (de.re * om + big.re * dom);
                    if stages > 2 {
                        let (al, dal, dqdd) = (x[2][c + 2], d[2][c + 2][l], d[2]);
                        let (oo, doo) = (om * om, dom * om + om * dom);
                        out[4 * p + j][l] = dqdd[c][l] + (-de.im * al + -big.im * dal) - (de.re * oo + big.re * doo);
                        out[5 * p + j][l] = dqdd[c + 1][l] + (de.re * al + big.re * dal) - (de.im * oo + big.im * doo);
                    }
                }
            }
        }
    }
}

/// Checks the sources of `columns` against n coordinates, `stages` stages
/// and `points` named points: every point column's x, y, phi a coordinate,
/// every source a stage's coordinate or a point's value.
pub fn check(n: usize, stages: usize, src: &[usize], pc: &[usize], points: usize) -> Result<(), String> {
    if stages == 0 || stages > 3 || pc.len() != points || pc.iter().any(|&c| c.saturating_add(2) >= n.max(1)) {
        return Err("columns: one to three stages, and every point on a body, expected".into());
    }
    let limit = stages * (n + 2 * points);
    if src.iter().any(|&j| j >= limit) {
        return Err("columns: a source out of range".into());
    }
    Ok(())
}
