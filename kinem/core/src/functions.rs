//! Driving functions d(t) (Sec. 4.2.8) and their exact first and second
//! derivatives: polynomials sum c_k t^k, harmonics offset + a sin(w t + p),
//! and tables as piecewise cubics (the not-a-knot spline's pieces, made by
//! scipy in kinem.functions when the model is compiled; extended beyond the
//! table by its end cubics, as scipy's PPoly).
use crate::table::Table;

pub const POLY: i64 = 0;
pub const HARMONIC: i64 = 1;
pub const PIECES: i64 = 2;

/// Function f's parameters are data[start[f]..start[f + 1]]:
/// POLY: c_0 .. c_d; HARMONIC: amplitude, omega, phase, offset;
/// PIECES: k, then k + 1 breakpoints, then 4 k coefficients (piece-major,
/// highest power first: s = c0 h^3 + c1 h^2 + c2 h + c3, h = t - x_i).
#[derive(Default, Clone, Debug)]
pub struct Functions {
    kind: Vec<i64>,
    start: Vec<usize>,
    data: Vec<f64>,
    /// per function: its value when it is a constant (a ground's, an
    /// absolute constraint's), evaluated without the general path
    value: Vec<Option<f64>>,
}

impl Functions {
    pub fn from_table(t: &Table) -> Result<Self, String> {
        let kind = t.int("kind")?;
        let data = t.real("data")?;
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
                    let k = if b > a { data[a] } else { -1.0 };
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
        Ok(Functions { kind, start, data, value })
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

    /// d(t) (order 0), d'(t) (1) or d''(t) (2) of function f.
    #[inline]
    pub fn eval(&self, f: usize, t: f64, order: u8) -> f64 {
        if let Some(v) = self.value[f] {
            return if order == 0 { v } else { 0.0 };
        }
        let p = &self.data[self.start[f]..self.start[f + 1]];
        match self.kind[f] {
            POLY => {
                // Horner on the order-th derivative's coefficients
                let d = p.len();
                let mut v = 0.0;
                for j in (order as usize..d).rev() {
                    let mut c = p[j];
                    for r in 0..order as usize {
                        c *= (j - r) as f64;
                    }
                    v = v * t + c;
                }
                v
            }
            HARMONIC => {
                let (a, w, ph, c) = (p[0], p[1], p[2], p[3]);
                match order {
                    0 => c + a * (w * t + ph).sin(),
                    1 => a * w * (w * t + ph).cos(),
                    _ => -a * w * w * (w * t + ph).sin(),
                }
            }
            _ => {
                let k = p[0] as usize;
                let x = &p[1..k + 2];
                let c = &p[k + 2..];
                // the piece: the last breakpoint at or before t, clamped to the table's pieces
                let i = match x[..k].partition_point(|&b| b <= t) {
                    0 => 0,
                    j => j - 1,
                };
                let h = t - x[i];
                let (c0, c1, c2, c3) = (c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]);
                match order {
                    0 => ((c0 * h + c1) * h + c2) * h + c3,
                    1 => (3.0 * c0 * h + 2.0 * c1) * h + c2,
                    _ => 6.0 * c0 * h + 2.0 * c1,
                }
            }
        }
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
        let f =
            Functions::from_table(&table(vec![POLY, HARMONIC], vec![0, 3, 7], vec![1.0, 2.0, 3.0, 2.0, 3.0, 0.5, 1.0]))
                .unwrap();
        let t = 0.7;
        assert!((f.eval(0, t, 0) - (1.0 + 2.0 * t + 3.0 * t * t)).abs() < 1e-15);
        assert!((f.eval(0, t, 1) - (2.0 + 6.0 * t)).abs() < 1e-15);
        assert!((f.eval(0, t, 2) - 6.0).abs() < 1e-15);
        assert!((f.eval(1, t, 2) + 2.0 * 9.0 * (3.0 * t + 0.5).sin()).abs() < 1e-14);
    }

    #[test]
    fn malformed_tables_are_refused() {
        assert!(Functions::from_table(&table(vec![HARMONIC], vec![0, 3], vec![1.0, 2.0, 3.0])).is_err());
        assert!(Functions::from_table(&table(vec![POLY], vec![0, 9], vec![1.0])).is_err());
    }
}
