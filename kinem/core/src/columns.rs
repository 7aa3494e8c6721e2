//! A trajectory's named columns (kinem.result.trajectory) from the raw
//! coordinates, in one pass: each column is a coordinate of a stage
//! (positions, velocities, accelerations) or a named point's x or y there
//! (r + A s', its first and second derivatives, Eqs. 4.43-4.45).
//! Over S = Dual (crate::real) it gives the columns' tangents along a
//! design parameter (kinem.sensitivity) from the coordinates' tangents.
use crate::families::{iz, lane};
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
    /// march's own); out point by point, each its 2 stages entries in
    /// `points`' order (x, y, vx, vy, ax, ay: point j's entry i at
    /// 2 stages j + i), N tangents an entry. `only`: the points taken (all
    /// of them, or those a design parameter reaches: crate::sensitivity;
    /// the others' entries are not written).
    pub fn point_tangents<const N: usize>(
        &self,
        x: &[&[f64]],
        d: &[&[[f64; N]]],
        local: &[Complex<Lanes<N>>],
        turn: impl Fn(usize) -> C64,
        only: &[usize],
        out: &mut [[f64; N]],
    ) {
        let (stages, p) = (self.stages, self.pc.len());
        let n = x[0].len();
        assert!(x.len() >= stages && d.len() >= stages && local.len() >= p && out.len() >= 2 * stages * p);
        assert!(x[..stages].iter().all(|a| a.len() >= n) && d[..stages].iter().all(|a| a.len() >= n));
        assert!(self.pc.iter().all(|&c| c + 2 < n) && only.iter().all(|&j| j < p));
        // SAFETY: what point_tangents_unchecked reads, asserted above
        unsafe { self.point_tangents_unchecked(x, d, local, turn, only, out) }
    }

    /// `point_tangents` without its checks (crate::sensitivity makes those
    /// on the points, their columns and `only` once per set-up, those on
    /// the stages once an instant).
    ///
    /// # Safety
    /// What `point_tangents` asserts: x and d at least `stages` long, each
    /// of their first `stages` at least n = x[0].len() long, every point's
    /// column c with c + 2 < n, local at least pc.len() long, out at least
    /// 2 stages pc.len(), every point of `only` below pc.len().
    #[inline(always)]
    pub unsafe fn point_tangents_unchecked<const N: usize>(
        &self,
        x: &[&[f64]],
        d: &[&[[f64; N]]],
        local: &[Complex<Lanes<N>>],
        turn: impl Fn(usize) -> C64,
        only: &[usize],
        out: &mut [[f64; N]],
    ) {
        let stages = self.stages;
        for &j in only {
            // SAFETY: j < p = pc.len() <= local.len() (the # Safety contract)
            let (c, s) = unsafe { (*self.pc.get_unchecked(j), *local.get_unchecked(j)) };
            let e = turn(c + 2);
            let big = C64::new(s.re.v, s.im.v) * e;
            // SAFETY: c + 2 < n, every stage and its tangents hold n (the # Safety contract)
            let at = |k: usize, c: usize| unsafe { *d.get_unchecked(k).get_unchecked(c) };
            let value = |k: usize| unsafe { *x.get_unchecked(k).get_unchecked(c + 2) };
            // SAFETY: j < p and out holds 2 stages p (the # Safety contract)
            let mut put = |i: usize, v: [f64; N]| unsafe { *out.get_unchecked_mut(2 * stages * j + i) = v };
            // dE = i E dphi + d(s') e
            let phi = at(0, c + 2);
            let ib = iz(big);
            let de: [C64; N] = std::array::from_fn(|l| ib * phi[l] + lane(s, l).1 * e);
            let (x0, y0) = (at(0, c), at(0, c + 1));
            put(0, std::array::from_fn(|l| x0[l] + de[l].re));
            put(1, std::array::from_fn(|l| y0[l] + de[l].im));
            if stages > 1 {
                // i E om: re -E.im om, im E.re om
                let (om, dom, vx, vy) = (value(1), at(1, c + 2), at(1, c), at(1, c + 1));
                put(2, std::array::from_fn(|l| vx[l] + (-de[l].im * om + -big.im * dom[l])));
                put(3, std::array::from_fn(|l| vy[l] + (de[l].re * om + big.re * dom[l])));
                if stages > 2 {
                    let (al, dal, ax, ay, oo) = (value(2), at(2, c + 2), at(2, c), at(2, c + 1), om * om);
                    let doo: [f64; N] = std::array::from_fn(|l| 2.0 * om * dom[l]);
                    put(
                        4,
                        std::array::from_fn(|l| {
                            ax[l] + (-de[l].im * al + -big.im * dal[l]) - (de[l].re * oo + big.re * doo[l])
                        }),
                    );
                    put(
                        5,
                        std::array::from_fn(|l| {
                            ay[l] + (de[l].re * al + big.re * dal[l]) - (de[l].im * oo + big.im * doo[l])
                        }),
                    );
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
