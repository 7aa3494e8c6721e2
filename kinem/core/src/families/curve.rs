//! A point that moves on an outline of a body (Secs. 4.2.4-4.2.6): the
//! disk cam with a point follower (Eqs. 4.26, 4.27) and the point-follower,
//! a pin in a slot (Eq. 4.30); with the outline evaluation the cam
//! families (cam.rs) share.
//!
//! The outline body c, its outline (Eq. 4.25) and the artificial
//! coordinate theta (column ct) locate the point. With a = A_c p(theta),
//! g = A_c p'(theta) (the tangent g_c of Eq. 4.24 in global components),
//! h = A_c p'' and k = A_c p''' (crate::outline::Curve):
//!     da/dphi_c = i a,   da/dtheta = g,   dg/dphi_c = i g,   dg/dtheta = h,
//! and along a motion, without the terms in the accelerations,
//!     a'  = i w a + g th',   a''  = -w^2 a + 2 i w th' g + th'^2 h,
//!     g'  = i w g + h th',   g''  = -w^2 g + 2 i w th' h + th'^2 k.
use super::{At, Shared, I};
use crate::outline::Curve;
use crate::table::Table;
use num_complex::Complex64 as C64;

/// The outline o of body cc at theta = q[ct]: e^{i theta} is in `At::e`
/// (the artificial columns are angle columns).
#[inline(always)]
pub fn curve(at: &At, s: &Shared, o: usize, cc: usize, ct: usize) -> Curve {
    s.outlines.curve(o, at.q[ct], at.e[ct], at.rot(cc))
}

/// a', a'', g', g'' along a motion with w = phi_c', th = theta' (the
/// module's formulas).
pub struct Rates {
    pub a1: C64,
    pub a2: C64,
    pub g1: C64,
    pub g2: C64,
}

#[inline(always)]
pub fn rates(p: &Curve, w: f64, th: f64) -> Rates {
    Rates {
        a1: I * w * p.a + p.g * th,
        a2: -w * w * p.a + 2.0 * I * w * th * p.g + th * th * p.h,
        g1: I * w * p.g + p.h * th,
        g2: -w * w * p.g + 2.0 * I * w * th * p.h + th * th * p.k,
    }
}

/// The columns every curve family has: cc (the outline body's x column),
/// ct (theta's column), o (its outline, an index into the model's outlines).
pub struct Outline {
    pub cc: Vec<usize>,
    pub ct: Vec<usize>,
    pub o: Vec<usize>,
}

impl Outline {
    pub fn new(t: &Table, n: usize, outlines: usize) -> Result<Self, String> {
        let cc = t.index("cc", n.saturating_sub(2))?;
        t.same_length(cc.len(), &["ct", "outline"])?;
        Ok(Outline { cc, ct: t.index("ct", n)?, o: t.index("outline", outlines)? })
    }

    pub fn len(&self) -> usize {
        self.cc.len()
    }

    pub fn is_empty(&self) -> bool {
        self.cc.is_empty()
    }

    #[inline(always)]
    pub fn at(&self, at: &At, s: &Shared, c: usize) -> Curve {
        curve(at, s, self.o[c], self.cc[c], self.ct[c])
    }

    /// The curve and its rates at constraint c.
    #[inline(always)]
    pub fn moving(&self, at: &At, qd: &[f64], s: &Shared, c: usize) -> (Curve, Rates) {
        let p = self.at(at, s, c);
        let r = rates(&p, qd[self.cc[c] + 2], qd[self.ct[c]]);
        (p, r)
    }
}

/// Phi = sigma (r_c + A_c p(theta) - r_b - A_b s'_b): two rows, x and y.
/// cam-point: c = cam i, b = follower j, sigma = +1 (Eq. 4.26);
/// point-follower: c = slotted body j, b = pin body i, sigma = -1 (Eq. 4.30).
/// Columns: cc, ct, outline (Outline), cb (b's x column), sb (s'_b), sign.
pub struct PointOnCurve {
    curve: Outline,
    cb: Vec<usize>,
    sb: Vec<C64>,
    sign: Vec<f64>,
}

impl PointOnCurve {
    pub fn new(t: &Table, n: usize, outlines: usize) -> Result<Self, String> {
        let curve = Outline::new(t, n, outlines)?;
        t.same_length(curve.len(), &["cb", "sb", "sign"])?;
        Ok(PointOnCurve { cb: t.index("cb", n.saturating_sub(2))?, sb: t.cplx("sb")?, sign: t.real("sign")?, curve })
    }

    pub fn rows(&self) -> usize {
        2 * self.cb.len()
    }

    pub fn entries(&self) -> usize {
        10 * self.cb.len()
    }

    /// sigma (r_c + a - r_b - A_b s'_b), rows x and y (Eqs. 4.26, 4.30).
    pub fn phi(&self, at: &At, s: &Shared, out: &mut [f64]) {
        for c in 0..self.cb.len() {
            let (x, y) = (self.curve.cc[c], self.cb[c]);
            let a = self.curve.at(at, s, c).a;
            let d = self.sign[c] * (at.r(x) + a - at.r(y) - self.sb[c] * at.rot(y));
            out[2 * c] = d.re;
            out[2 * c + 1] = d.im;
        }
    }

    /// sigma [I, i a, g, -I, -B_b s'_b] in columns [r_c, phi_c, theta, r_b, phi_b]
    /// (Eq. 4.27's Jacobian; pattern per constraint: row x then row y).
    pub fn jac(&self, at: &At, s: &Shared, out: &mut [f64]) {
        for c in 0..self.cb.len() {
            let p = self.curve.at(at, s, c);
            let b = self.sb[c] * at.rot(self.cb[c]);
            let (k, a, g) = (self.sign[c], p.a, p.g);
            out[10 * c..10 * c + 10].copy_from_slice(&[
                k,
                -k * a.im,
                k * g.re,
                -k,
                k * b.im,
                k,
                k * a.re,
                k * g.im,
                -k,
                -k * b.re,
            ]);
        }
    }

    /// -sigma (a'' + A_b s'_b w_b^2).
    pub fn gamma(&self, at: &At, qd: &[f64], s: &Shared, out: &mut [f64]) {
        for c in 0..self.cb.len() {
            let y = self.cb[c];
            let (_, r) = self.curve.moving(at, qd, s, c);
            let w = qd[y + 2];
            let g = -self.sign[c] * (r.a2 + self.sb[c] * at.rot(y) * (w * w));
            out[2 * c] = g.re;
            out[2 * c + 1] = g.im;
        }
    }
}
