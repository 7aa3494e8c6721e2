//! Driving functions d(t) (Sec. 4.2.8) and their exact first and second
//! derivatives: polynomials sum c_k t^k, harmonics offset + a sin(w t + p),
//! and tables as piecewise cubics (the not-a-knot spline's pieces, made by
//! scipy in kinem.functions when the model is compiled; extended beyond the
//! table by its end cubics, as scipy's PPoly).
use crate::real::{Lanes, Real};
use crate::table::Table;

pub const POLY: i64 = 0;
pub const HARMONIC: i64 = 1;
pub const PIECES: i64 = 2;

/// Function f's parameters are data[start[f]..start[f + 1]]:
/// POLY: c_0 .. c_d; HARMONIC: amplitude, omega, phase, offset;
/// PIECES: k, then k + 1 breakpoints, then 4 k coefficients (piece-major,
/// highest power first: s = c0 h^3 + c1 h^2 + c2 h + c3, h = t - x_i).
/// Over S = Dual (crate::real), the parameters carry their tangents along
/// a design parameter (breakpoints never do: they are abscissae).
#[derive(Default, Clone, Debug)]
pub struct Functions<S = f64> {
    kind: Vec<i64>,
    start: Vec<usize>,
    data: Vec<S>,
    /// per function: its value when it is a constant (a ground's, an
    /// absolute constraint's), evaluated without the general path
    value: Vec<Option<S>>,
    /// per polynomial: the coefficients of d, d' and d'' (c_j j (j - 1) ...,
    /// multiplied in the order the general path would: the same figures to
    /// the bit), made once (empty for the other kinds)
    poly: Vec<[Vec<S>; 3]>,
}

impl<S: Real> Functions<S> {
    pub fn from_table(t: &Table) -> Result<Self, String> {
        let kind = t.int("kind")?;
        let data: Vec<S> = t.real_s("data")?;
        let start = t.index("start", data.len() + 1)?;
        if start.len() != kind.len() + 1 {
            return Err("functions: start needs one entry more than kind".into());
        }
        for f in 0..kind.len() {
            let (a, b) = (start[f], start[f + 1]);
            if b < a {
                return Err(format!("functions: function {f} has a negative length"));
            }
            let ok = match kind[f] {
                POLY => b > a,
                HARMONIC => b - a == 4,
                PIECES => {
                    let k = if b > a { data[a].re() } else { -1.0 };
                    k >= 1.0 && k.fract() == 0.0 && b - a == 1 + (k as usize + 1) + 4 * k as usize
                }
                _ => false,
            };
            if !ok {
                return Err(format!("functions: function {f} (kind {}) is malformed", kind[f]));
            }
        }
        let value = (0..kind.len())
            .map(|f| (kind[f] == POLY && start[f + 1] - start[f] == 1).then(|| data[start[f]]))
            .collect();
        let poly = (0..kind.len())
            .map(|f| {
                let p = &data[start[f]..start[f + 1]];
                let derivative = |order: usize| -> Vec<S> {
                    if kind[f] != POLY {
                        return Vec::new();
                    }
                    (order..p.len()).map(|j| (0..order).fold(p[j], |c, r| c * (j - r) as f64)).collect()
                };
                [derivative(0), derivative(1), derivative(2)]
            })
            .collect();
        Ok(Functions { kind, start, data, value, poly })
    }

    pub fn len(&self) -> usize {
        self.kind.len()
    }

    pub fn is_empty(&self) -> bool {
        self.kind.is_empty()
    }

    /// Whether function f is a constant (its derivatives vanish).
    pub fn constant(&self, f: usize) -> bool {
        self.value[f].is_some()
    }

    /// Whether `eval(f, t, 1)` is the same figure at every finite t: a
    /// constant's (0), a polynomial's of degree one at most whose d' = c is
    /// not -0 (0 t + c is c but for c = -0, which 0 t of a negative t
    /// leaves -0 and of another t +0).
    pub fn rate_fixed(&self, f: usize) -> bool {
        self.value[f].is_some()
            || (self.kind[f] == POLY
                && match self.poly[f][1].as_slice() {
                    [] => true,
                    [c] => !(c.re() == 0.0 && c.re().is_sign_negative()),
                    _ => false,
                })
    }

    /// The two coefficients (c0, c1) of a function that is a polynomial of
    /// degree one with both coefficients (a crank at a constant speed), not
    /// a constant: `eval(f, t, 0)` is then (0 t + c1) t + c0, which a
    /// caller may evaluate without the lookups (`line_at`, the same
    /// operations: the same figures to the bit).
    pub fn line(&self, f: usize) -> Option<[S; 2]> {
        match (self.value[f], self.kind[f], self.poly[f][0].as_slice()) {
            (None, POLY, &[c0, c1]) => Some([c0, c1]),
            _ => None,
        }
    }

    /// Whether `eval(f, t, 2)` is +0 at every t: a constant's (its d''
    /// `S::zero()`), a polynomial's of degree one at most (no coefficient
    /// of d'': Horner's zero, +0).
    pub fn accel_zero(&self, f: usize) -> bool {
        self.value[f].is_some() || (self.kind[f] == POLY && self.poly[f][2].is_empty())
    }

    /// d(t) (order 0), d'(t) (1) or d''(t) (2) of function f: a constant's
    /// and a polynomial's inline, the others out of line.
    #[inline(always)]
    pub fn eval(&self, f: usize, t: f64, order: u8) -> S {
        if let Some(v) = self.value[f] {
            return if order == 0 { v } else { S::zero() };
        }
        if self.kind[f] == POLY && order <= 2 {
            // Horner on the order-th derivative's coefficients, as `general`;
            // up to three written out (the same operations: no loop set-up)
            let c = &self.poly[f][order as usize];
            let z = S::zero();
            return match *c.as_slice() {
                [] => z,
                [c0] => z * t + c0,
                [c0, c1] => (z * t + c1) * t + c0,
                [c0, c1, c2] => ((z * t + c2) * t + c1) * t + c0,
                _ => c.iter().rev().fold(z, |v, &c| v * t + c),
            };
        }
        self.general(f, t, order)
    }

    /// Any function at any order (the polynomials' derivatives beyond the second).
    #[inline(never)]
    fn general(&self, f: usize, t: f64, order: u8) -> S {
        let p = &self.data[self.start[f]..self.start[f + 1]];
        match self.kind[f] {
            POLY => {
                // Horner on the order-th derivative's coefficients
                let d = p.len();
                let mut v = S::zero();
                for j in (order as usize..d).rev() {
                    let mut c = p[j];
                    for r in 0..order as usize {
                        c = c * (j - r) as f64;
                    }
                    v = v * t + c;
                }
                v
            }
            HARMONIC => {
                let (a, w, ph, c) = (p[0], p[1], p[2], p[3]);
                let x = w * t + ph;
                match order {
                    0 => c + a * x.sin(),
                    1 => a * w * x.cos(),
                    _ => -a * w * w * x.sin(),
                }
            }
            _ => {
                let k = p[0].re() as usize;
                let x = &p[1..k + 2];
                let c = &p[k + 2..];
                // the piece: the last breakpoint at or before t, clamped to the table's pieces
                let i = match x[..k].partition_point(|&b| b.re() <= t) {
                    0 => 0,
                    j => j - 1,
                };
                let h = t - x[i].re();
                let (c0, c1, c2, c3) = (c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]);
                match order {
                    0 => ((c0 * h + c1) * h + c2) * h + c3,
                    1 => (c0 * 3.0 * h + c1 * 2.0) * h + c2,
                    _ => c0 * 6.0 * h + c1 * 2.0,
                }
            }
        }
    }
}

impl<const N: usize> Functions<Lanes<N>> {
    /// Whether function f's parameters carry a tangent in any lane (a
    /// design parameter moves it: crate::sensitivity).
    pub fn moves(&self, f: usize) -> bool {
        self.data[self.start[f]..self.start[f + 1]].iter().any(|x| x.d.iter().any(|&v| v != 0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(kind: Vec<i64>, start: Vec<i64>, data: Vec<f64>) -> Table {
        let mut t = Table::default();
        t.ints.insert("kind".into(), kind);
        t.ints.insert("start".into(), start);
        t.reals.insert("data".into(), data);
        t
    }

    #[test]
    fn poly_and_harmonic_derivatives() {
        let f: Functions =
            Functions::from_table(&table(vec![POLY, HARMONIC], vec![0, 3, 7], vec![1.0, 2.0, 3.0, 2.0, 3.0, 0.5, 1.0]))
                .unwrap();
        let t = 0.7;
        assert!((f.eval(0, t, 0) - (1.0 + 2.0 * t + 3.0 * t * t)).abs() < 1e-15);
        assert!((f.eval(0, t, 1) - (2.0 + 6.0 * t)).abs() < 1e-15);
        assert!((f.eval(0, t, 2) - 6.0).abs() < 1e-15);
        assert!((f.eval(1, t, 2) + 2.0 * 9.0 * (3.0 * t + 0.5).sin()).abs() < 1e-14);
    }

    /// The polynomials' kept coefficients give the general path's figures to
    /// the bit (tolerance 0), at each order up to the second.
    #[test]
    fn polynomials_inline_equal_the_general_path_to_the_bit() {
        let c = vec![0.3, -1.7, 2.9, 0.123456789, -4.1, 0.7, 1.9];
        let f: Functions = Functions::from_table(&table(vec![POLY, POLY], vec![0, 5, 7], c)).unwrap();
        for t in [0.0, 0.1, -0.77, 1.3e3, 3.0f64.sqrt()] {
            for fun in 0..2 {
                for order in 0..=2u8 {
                    assert_eq!(f.eval(fun, t, order).to_bits(), f.general(fun, t, order).to_bits());
                }
            }
        }
    }

    /// A function whose d' is the same figure at every t is told so
    /// (constants, polynomials of degree one but for d' = -0), and d' is
    /// then the same to the bit (tolerance 0) at t of either sign.
    #[test]
    fn a_fixed_rate_is_the_same_at_every_instant() {
        let c = vec![7.0, 0.5, 2.0, 0.0, 2.0, 1.0, -0.0, 1.0, 2.0, 3.0, 2.0, 3.0, 0.5, 1.0];
        let f: Functions =
            Functions::from_table(&table(vec![POLY, POLY, POLY, POLY, POLY, HARMONIC], vec![0, 1, 3, 5, 7, 10, 14], c))
                .unwrap();
        let fixed: Vec<bool> = (0..6).map(|k| f.rate_fixed(k)).collect();
        assert_eq!(fixed, [true, true, true, false, false, false]);
        for k in (0..6).filter(|&k| fixed[k]) {
            for t in [0.0, -0.0, 0.1, -0.77, 1.3e3, -2e9] {
                assert_eq!(f.eval(k, t, 1).to_bits(), f.eval(k, 0.0, 1).to_bits());
            }
        }
        // d' = -0: +0 at t >= 0, -0 at t < 0
        assert_ne!(f.eval(3, 1.0, 1).to_bits(), f.eval(3, -1.0, 1).to_bits());
    }

    #[test]
    fn malformed_tables_are_refused() {
        assert!(Functions::<f64>::from_table(&table(vec![HARMONIC], vec![0, 3], vec![1.0, 2.0, 3.0])).is_err());
        assert!(Functions::<f64>::from_table(&table(vec![POLY], vec![0, 9], vec![1.0])).is_err());
    }
}
