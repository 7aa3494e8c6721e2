//! Named arrays handed over from Python once, when a model is compiled
//! (kinem.model.compile): every family's struct-of-arrays table, the driving
//! functions and the outlines. Every index is validated here, once, so that
//! the kernels may index without further checks.
use crate::real::{lift_c, Real};
use num_complex::{Complex, Complex64 as C64};
use std::collections::HashMap;

/// A table's columns by name; each column one value per constraint (or per row).
#[derive(Default, Clone, Debug)]
pub struct Table {
    pub ints: HashMap<String, Vec<i64>>,
    pub reals: HashMap<String, Vec<f64>>,
    pub complex: HashMap<String, Vec<C64>>,
    /// Tangents of real and complex columns along one design parameter
    /// (crate::sensitivity), or along S::WIDTH of them (Lanes: entry-major,
    /// WIDTH per entry); a column without one has tangent zero.
    pub d_reals: HashMap<String, Vec<f64>>,
    pub d_complex: HashMap<String, Vec<C64>>,
}

impl Table {
    fn missing(key: &str) -> String {
        format!("table has no column '{key}'")
    }

    /// Integers that must index a vector of `bound` entries (coordinate columns:
    /// bound = n): an index out of range is an error here, never in a kernel.
    pub fn index(&self, key: &str, bound: usize) -> Result<Vec<usize>, String> {
        let v = self.ints.get(key).ok_or_else(|| Self::missing(key))?;
        v.iter()
            .map(|&x| {
                if x >= 0 && (x as usize) < bound {
                    Ok(x as usize)
                } else {
                    Err(format!("column '{key}': index {x} outside 0..{bound}"))
                }
            })
            .collect()
    }

    pub fn flags(&self, key: &str) -> Result<Vec<bool>, String> {
        Ok(self.ints.get(key).ok_or_else(|| Self::missing(key))?.iter().map(|&x| x != 0).collect())
    }

    pub fn int(&self, key: &str) -> Result<Vec<i64>, String> {
        self.ints.get(key).cloned().ok_or_else(|| Self::missing(key))
    }

    pub fn real(&self, key: &str) -> Result<Vec<f64>, String> {
        self.reals.get(key).cloned().ok_or_else(|| Self::missing(key))
    }

    pub fn cplx(&self, key: &str) -> Result<Vec<C64>, String> {
        self.complex.get(key).cloned().ok_or_else(|| Self::missing(key))
    }

    /// A real column as S: with Dual, its values carry their tangents.
    pub fn real_s<S: Real>(&self, key: &str) -> Result<Vec<S>, String> {
        let v = self.reals.get(key).ok_or_else(|| Self::missing(key))?;
        Ok(match self.d_reals.get(key).filter(|d| d.len() == v.len() * S::WIDTH) {
            Some(d) => v.iter().zip(d.chunks(S::WIDTH)).map(|(&x, dx)| S::of_lanes(x, dx)).collect(),
            None => v.iter().map(|&x| S::c(x)).collect(),
        })
    }

    /// A complex column as Complex<S>: with Dual, its values carry their tangents.
    pub fn cplx_s<S: Real>(&self, key: &str) -> Result<Vec<Complex<S>>, String> {
        let v = self.complex.get(key).ok_or_else(|| Self::missing(key))?;
        Ok(match self.d_complex.get(key).filter(|d| d.len() == v.len() * S::WIDTH) {
            Some(d) => v
                .iter()
                .zip(d.chunks(S::WIDTH))
                .map(|(&x, dx)| {
                    let (re, im): (Vec<f64>, Vec<f64>) = dx.iter().map(|z| (z.re, z.im)).unzip();
                    Complex::new(S::of_lanes(x.re, &re), S::of_lanes(x.im, &im))
                })
                .collect(),
            None => v.iter().map(|&x| lift_c(x, C64::new(0.0, 0.0))).collect(),
        })
    }

    /// Checks that every listed column has `len` entries.
    pub fn same_length(&self, len: usize, keys: &[&str]) -> Result<(), String> {
        for k in keys {
            let l = if let Some(v) = self.ints.get(*k) {
                v.len()
            } else if let Some(v) = self.reals.get(*k) {
                v.len()
            } else if let Some(v) = self.complex.get(*k) {
                v.len()
            } else {
                return Err(Self::missing(k));
            };
            if l != len {
                return Err(format!("column '{k}' has {l} entries, expected {len}"));
            }
        }
        Ok(())
    }
}
