//! Simplified constraints (Eqs. 4.31-4.34) and driving constraints
//! (Eqs. 4.36-4.40); gamma Eq. 4.38 and the point forms.
//!
//! Every row has the form Phi = q_a [+ (A_i s'_i^P)_c] [- phi_k] - f(t):
//! q_a is x_i, y_i or phi_i, the point term mx Re(s) + my Im(s) with
//! s = A_i s'_i^P is present for the point forms (Eqs. 4.34, 4.39, 4.40),
//! the relative term for a motor between two moving bodies. ground,
//! absolute and driver rows all come here, one row each (ground: three).
use super::{At, Shared};
use crate::real::Real;
use crate::table::Table;
use num_complex::Complex;

/// Columns, one entry per row: a (the coordinate q_a), angle (phi_i's
/// column), k (phi_k's column when relative, else any valid column),
/// local (s'_i^P; 0 without a point), mx, my (1.0 for a point row's x or y
/// component, else 0.0), point and relative (flags: which Jacobian entries
/// the row has besides its 1 in column a), f (the driving function, an
/// index into the model's functions; a constant for ground and absolute).
pub struct Simple<S = f64> {
    a: Vec<usize>,
    angle: Vec<usize>,
    k: Vec<usize>,
    w: Vec<f64>, // 1.0 for a relative row, 0.0 otherwise
    local: Vec<Complex<S>>,
    mx: Vec<f64>,
    my: Vec<f64>,
    point: Vec<bool>,
    relative: Vec<bool>,
    f: Vec<usize>,
    entries: usize,
    /// per row: its function is not a constant (`bind`; all until bound),
    /// else its constant value
    driven: Vec<bool>,
    value: Vec<S>,
}

impl<S: Real> Simple<S> {
    pub fn new(t: &Table, n: usize, functions: usize) -> Result<Self, String> {
        let a = t.index("a", n)?;
        t.same_length(a.len(), &["angle", "k", "local", "mx", "my", "point", "relative", "f"])?;
        let point = t.flags("point")?;
        let relative = t.flags("relative")?;
        let entries = a.len() + point.iter().filter(|&&p| p).count() + relative.iter().filter(|&&r| r).count();
        Ok(Simple {
            angle: t.index("angle", n)?,
            k: t.index("k", n)?,
            w: relative.iter().map(|&r| if r { 1.0 } else { 0.0 }).collect(),
            local: t.cplx_s("local")?,
            mx: t.real("mx")?,
            my: t.real("my")?,
            f: t.index("f", functions)?,
            driven: vec![true; a.len()],
            value: vec![S::zero(); a.len()],
            a,
            point,
            relative,
            entries,
        })
    }

    /// Takes each constant function's value (a ground's, an absolute
    /// constraint's) once, so that the kernels evaluate only the drivers.
    pub fn bind(&mut self, s: &Shared<S>) {
        for r in 0..self.a.len() {
            self.driven[r] = !s.functions.constant(self.f[r]);
            self.value[r] = if self.driven[r] { S::zero() } else { s.functions.eval(self.f[r], 0.0, 0) };
        }
    }

    /// f(t) (order 0), f'(t), f''(t) of row r's function.
    #[inline(always)]
    fn drive(&self, r: usize, t: f64, order: u8, s: &Shared<S>) -> S {
        if self.driven[r] {
            s.functions.eval(self.f[r], t, order)
        } else if order == 0 {
            self.value[r]
        } else {
            S::zero()
        }
    }

    pub fn rows(&self) -> usize {
        self.a.len()
    }

    pub fn entries(&self) -> usize {
        self.entries
    }

    /// Whether any row's function is not a constant (a driver: nu, gamma terms).
    pub fn time_dependent(&self, s: &Shared<S>) -> bool {
        self.f.iter().any(|&f| !s.functions.constant(f))
    }

    /// The point term of row r: mx Re(A_i s') + my Im(A_i s'), if the row has one.
    #[inline(always)]
    fn point_term(&self, r: usize, at: &At<S>) -> Option<S> {
        if self.mx[r] != 0.0 || self.my[r] != 0.0 {
            let s = self.local[r] * at.e[self.angle[r]];
            Some(s.re * self.mx[r] + s.im * self.my[r])
        } else {
            None
        }
    }

    /// Eqs. 4.31-4.40: q_a - w q_k + point term - f(t).
    pub fn phi(&self, at: &At<S>, s: &Shared<S>, out: &mut [S]) {
        for (r, o) in out.iter_mut().enumerate() {
            let mut v = at.q[self.a[r]] - at.q[self.k[r]] * self.w[r] - self.drive(r, at.t, 0, s);
            if let Some(p) = self.point_term(r, at) {
                v = v + p;
            }
            *o = v;
        }
    }

    /// 1 in column a; d(point term)/dphi_i = (B_i s')_c if a point; -1 in
    /// phi_k if relative (the pattern's order: a, angle, k, kept entries only).
    pub fn jac(&self, at: &At<S>, _: &Shared<S>, out: &mut [S]) {
        let mut e = 0;
        for r in 0..self.a.len() {
            out[e] = S::one();
            e += 1;
            if self.point[r] {
                let s = self.local[r] * at.e[self.angle[r]];
                out[e] = s.re * self.my[r] - s.im * self.mx[r];
                e += 1;
            }
            if self.relative[r] {
                out[e] = S::c(-self.w[r]);
                e += 1;
            }
        }
    }

    /// nu = -Phi_t = f'(t) per row (Eq. 4.37).
    pub fn nu(&self, t: f64, s: &Shared<S>, out: &mut [S]) {
        for (r, o) in out.iter_mut().enumerate() {
            *o = self.drive(r, t, 1, s);
        }
    }

    /// Eq. 4.38 and the point forms: f''(t) + (A_i s')_c w_i^2.
    pub fn gamma(&self, at: &At<S>, qd: &[S], s: &Shared<S>, out: &mut [S]) {
        for (r, o) in out.iter_mut().enumerate() {
            let mut v = self.drive(r, at.t, 2, s);
            if let Some(p) = self.point_term(r, at) {
                let w = qd[self.angle[r]];
                v = v + p * (w * w);
            }
            *o = v;
        }
    }
}
