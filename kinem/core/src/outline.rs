//! Outlines of bodies (Sec. 4.2.4): a curve fixed in a body, in polar
//! coordinates s(theta) about a centre Q of the body (Eq. 4.25),
//! p(theta) = Q + s(theta) e^{i theta}. s is a piecewise cubic (the spline's
//! pieces, made by scipy in kinem.outline when the model is compiled; a
//! circle is one constant piece). A periodic outline wraps theta into its
//! period; an open one is extended beyond its table by its end cubics.
use crate::table::Table;
use num_complex::Complex64 as C64;

#[derive(Default, Clone, Debug)]
pub struct Outlines {
    first: Vec<usize>, // first piece of outline o
    last: Vec<usize>,  // last piece of outline o
    t0: Vec<f64>,      // theta of its table's first entry
    span: Vec<f64>,    // its table's length in theta (the period of a periodic one)
    periodic: Vec<bool>,
    center: Vec<C64>, // Q, local
    starts: Vec<f64>, // each piece's start, from t0
    coef: Vec<f64>,   // 4 per piece, highest power first
}

/// A = A_c p(theta), G = A_c dp/dtheta, H and K = A_c times the second and
/// third derivatives (global components; A_c the outline body's rotation).
#[derive(Clone, Copy, Debug, Default)]
pub struct Curve {
    pub a: C64,
    pub g: C64,
    pub h: C64,
    pub k: C64,
}

impl Outlines {
    pub fn from_table(t: &Table) -> Result<Self, String> {
        let starts = t.real("starts")?;
        let coef = t.real("coef")?;
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
            center: t.cplx("center")?,
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
    pub fn radius(&self, o: usize, theta: f64) -> [f64; 4] {
        let mut x = theta - self.t0[o];
        let span = self.span[o];
        if self.periodic[o] {
            x = x.rem_euclid(span);
        }
        let key = x.clamp(0.0, span);
        let (a, b) = (self.first[o], self.last[o]);
        let i = (a + self.starts[a..=b].partition_point(|&s| s <= key)).saturating_sub(1).clamp(a, b);
        let h = x - self.starts[i];
        let c = &self.coef[4 * i..4 * i + 4];
        [
            ((c[0] * h + c[1]) * h + c[2]) * h + c[3],
            (3.0 * c[0] * h + 2.0 * c[1]) * h + c[2],
            6.0 * c[0] * h + 2.0 * c[1],
            6.0 * c[0],
        ]
    }

    /// The outline o at theta, in a body rotated by `rot` = e^{i phi_c};
    /// `e` = e^{i theta}.
    #[inline]
    pub fn curve(&self, o: usize, theta: f64, e: C64, rot: C64) -> Curve {
        let [s, s1, s2, s3] = self.radius(o, theta);
        let i = C64::new(0.0, 1.0);
        let re = rot * e;
        Curve {
            a: rot * self.center[o] + re * s,
            g: re * (s1 + i * s),
            h: re * (s2 - s + i * (2.0 * s1)),
            k: re * (s3 - 3.0 * s1 + i * (3.0 * s2 - s)),
        }
    }
}
