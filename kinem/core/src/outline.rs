//! Outlines of bodies (Sec. 4.2.4): a curve fixed in a body, in polar
//! coordinates s(theta) about a centre Q of the body (Eq. 4.25),
//! p(theta) = Q + s(theta) e^{i theta}. s is a piecewise cubic (the spline's
//! pieces, made by scipy in kinem.outline when the model is compiled; a
//! circle is one constant piece). A periodic outline wraps theta into its
//! period; an open one is extended beyond its table by its end cubics.
use crate::real::{i, Lanes, Real};
use crate::table::Table;
use num_complex::{Complex, Complex64 as C64};

/// Over S = Dual (crate::real), the coefficients and centres carry their
/// tangents along a design parameter, and theta its tangent along q.
#[derive(Default, Clone, Debug)]
pub struct Outlines<S = f64> {
    first: Vec<usize>, // first piece of outline o
    last: Vec<usize>,  // last piece of outline o
    t0: Vec<f64>,      // theta of its table's first entry
    span: Vec<f64>,    // its table's length in theta (the period of a periodic one)
    periodic: Vec<bool>,
    center: Vec<Complex<S>>, // Q, local
    starts: Vec<f64>,        // each piece's start, from t0
    coef: Vec<S>,            // 4 per piece, highest power first
}

/// A = A_c p(theta), G = A_c dp/dtheta, H and K = A_c times the second and
/// third derivatives (global components; A_c the outline body's rotation).
#[derive(Clone, Copy, Debug, Default)]
pub struct Curve<S = f64> {
    pub a: Complex<S>,
    pub g: Complex<S>,
    pub h: Complex<S>,
    pub k: Complex<S>,
}

impl<S: Real> Outlines<S> {
    pub fn from_table(t: &Table) -> Result<Self, String> {
        let starts = t.real("starts")?;
        let coef: Vec<S> = t.real_s("coef")?;
        let pieces = starts.len();
        if coef.len() != 4 * pieces {
            return Err(format!("outlines: {} coefficients for {pieces} pieces", coef.len()));
        }
        let first = t.index("first", pieces.max(1))?;
        let last = t.index("last", pieces.max(1))?;
        let o = first.len();
        t.same_length(o, &["last", "t0", "span", "periodic", "center"])?;
        for k in 0..o {
            if last[k] < first[k] {
                return Err(format!("outlines: outline {k} has no piece"));
            }
        }
        let span = t.real("span")?;
        if span.iter().any(|s| !(*s > 0.0 && s.is_finite())) {
            return Err("outlines: a span is not a positive number".into());
        }
        Ok(Outlines {
            first,
            last,
            t0: t.real("t0")?,
            span,
            periodic: t.flags("periodic")?,
            center: t.cplx_s("center")?,
            starts,
            coef,
        })
    }

    pub fn len(&self) -> usize {
        self.first.len()
    }

    pub fn is_empty(&self) -> bool {
        self.first.is_empty()
    }

    /// s and its first three derivatives of outline o at theta.
    #[inline]
    pub fn radius(&self, o: usize, theta: S) -> [S; 4] {
        self.radius_in(o, theta).0
    }

    /// `radius`, with the piece it was taken on and theta's offset from
    /// that piece's start (the value of h: `Piece`).
    #[inline]
    fn radius_in(&self, o: usize, theta: S) -> ([S; 4], Piece) {
        let mut x = theta - self.t0[o];
        let span = self.span[o];
        if self.periodic[o] {
            x = x.with_value(x.re().rem_euclid(span)); // the wrap is a constant shift
        }
        let key = x.re().clamp(0.0, span);
        let (a, b) = (self.first[o], self.last[o]);
        let i = (a + self.starts[a..=b].partition_point(|&s| s <= key)).saturating_sub(1).clamp(a, b);
        let h = x - self.starts[i];
        (cubic(&self.coef[4 * i..4 * i + 4], h), Piece { i, h: h.re() })
    }

    /// The outline o at theta, in a body rotated by `rot` = e^{i phi_c};
    /// `e` = e^{i theta}.
    #[inline]
    pub fn curve(&self, o: usize, theta: S, e: Complex<S>, rot: Complex<S>) -> Curve<S> {
        self.curve_in(o, theta, e, rot).0
    }

    /// `curve`, with the piece it was taken on (crate::march keeps it for
    /// the design sensitivities at the same q: `Outlines::handed`).
    #[inline]
    pub fn curve_in(&self, o: usize, theta: S, e: Complex<S>, rot: Complex<S>) -> (Curve<S>, Piece) {
        let (r, piece) = self.radius_in(o, theta);
        (place(self.center[o], rot, e, r), piece)
    }
}

/// Where an outline's radius was taken: its piece i and theta's offset h
/// from the piece's start (the analysis' value).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Piece {
    pub i: usize,
    pub h: f64,
}

/// s and its first three derivatives on a piece (coefficients c, highest
/// power first) at offset h.
#[inline(always)]
fn cubic<S: Real>(c: &[S], h: S) -> [S; 4] {
    [
        ((c[0] * h + c[1]) * h + c[2]) * h + c[3],
        (c[0] * 3.0 * h + c[1] * 2.0) * h + c[2],
        c[0] * 6.0 * h + c[1] * 2.0,
        c[0] * 6.0,
    ]
}

/// The outline's place (Curve) from its centre, the body's rotation, e^{i
/// theta} and the radius' [s, s', s'', s'''].
#[inline(always)]
fn place<S: Real>(center: Complex<S>, rot: Complex<S>, e: Complex<S>, [s, s1, s2, s3]: [S; 4]) -> Curve<S> {
    let i = i::<S>();
    let re = rot * e;
    Curve {
        a: rot * center + re * s,
        g: re * (i * s + s1),
        h: re * (i * (s1 * 2.0) + (s2 - s)),
        k: re * (i * (s2 * 3.0 - s) + (s3 - s1 * 3.0)),
    }
}

impl<const N: usize> Outlines<Lanes<N>> {
    /// The piece `curve` takes outline o on at theta (a value: no
    /// tangent), and theta's offset from its start: `radius_in`'s search,
    /// on the values its Lanes carry.
    #[inline(always)]
    pub fn piece(&self, o: usize, theta: f64) -> Piece {
        let mut x = theta - self.t0[o];
        let span = self.span[o];
        if self.periodic[o] {
            x = x.rem_euclid(span);
        }
        let key = x.clamp(0.0, span);
        let (a, b) = (self.first[o], self.last[o]);
        let i = (a + self.starts[a..=b].partition_point(|&s| s <= key)).saturating_sub(1).clamp(a, b);
        Piece { i, h: x - self.starts[i] }
    }

    /// `curve` at the piece the analysis took at the same theta (its value
    /// pass's, handed over: crate::march), at q' = 0 (theta, e and rot
    /// without tangent): the values as `curve`'s (the same operations in
    /// f64), and in each lane the tangent along the tables alone, which is
    /// linear in the coefficients' and the centre's tangents: with ds the
    /// cubic of the coefficients' tangents at h (`cubic`'s operations),
    ///     d(a) = rot d(Q) + re ds,  d(g) = re (ds' + i ds),
    ///     d(h) = re ((ds'' - ds) + i 2 ds'),   re = rot e,
    /// the operations Lanes takes for them less its products by a lifted
    /// value's zero tangent (the same figures but for the sign of an exact
    /// zero). k's tangent is not taken (+0): no kernel reads it
    /// (crate::families::curve keeps a, g, h's tangents and k's value).
    #[inline(always)]
    pub fn handed(&self, o: usize, p: Piece, e: C64, rot: C64) -> Curve<Lanes<N>> {
        let c = &self.coef[4 * p.i..4 * p.i + 4];
        let center = self.center[o];
        let v = place(C64::new(center.re.v, center.im.v), rot, e, cubic(&[c[0].v, c[1].v, c[2].v, c[3].v], p.h));
        let re = rot * e;
        let h = p.h;
        let mut d = [[[0.0; N]; 2]; 3];
        for l in 0..N {
            let (d0, d1, d2, d3) = (c[0].d[l], c[1].d[l], c[2].d[l], c[3].d[l]);
            let s0 = ((d0 * h + d1) * h + d2) * h + d3;
            let s1 = (d0 * 3.0 * h + d1 * 2.0) * h + d2;
            let s2 = d0 * 6.0 * h + d1 * 2.0;
            let rq = rot * C64::new(center.re.d[l], center.im.d[l]);
            let a = C64::new(rq.re + re.re * s0, rq.im + re.im * s0);
            let g = re * C64::new(s1, s0);
            let hh = re * C64::new(s2 - s0, s1 * 2.0);
            for (k, z) in [a, g, hh].into_iter().enumerate() {
                (d[k][0][l], d[k][1][l]) = (z.re, z.im);
            }
        }
        let z = |x: C64, [re, im]: [[f64; N]; 2]| Complex::new(Lanes::of(x.re, re), Lanes::of(x.im, im));
        Curve { a: z(v.a, d[0]), g: z(v.g, d[1]), h: z(v.h, d[2]), k: z(v.k, [[0.0; N]; 2]) }
    }
}
