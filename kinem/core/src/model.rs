//! A compiled model's evaluation: its families laid end to end (rows and
//! Jacobian entries in the order of kinem.model.Model), the driving
//! functions and outlines they read, and the angle columns whose e^{i q}
//! the families share.
use crate::families::{At, Family, Shared};
use crate::functions::Functions;
use crate::outline::Outlines;
use crate::table::Table;
use num_complex::Complex64 as C64;

pub struct Kin {
    pub n: usize,
    pub m: usize,
    pub nnz: usize,
    pub families: Vec<Family>,
    pub row_off: Vec<usize>,   // first row of each family (and m at the end)
    pub entry_off: Vec<usize>, // first Jacobian entry of each family (and nnz)
    pub angles: Vec<usize>,    // the angle columns (bodies' phi, outlines' theta)
    pub functions: Functions,
    pub outlines: Outlines,
    pub time_dependent: Vec<usize>, // families whose nu may be non-zero
}

impl Kin {
    pub fn new(
        n: usize,
        families: Vec<(String, Table)>,
        functions: &Table,
        outlines: &Table,
        angles: Vec<i64>,
    ) -> Result<Kin, String> {
        let functions = Functions::from_table(functions)?;
        let outlines = if outlines.ints.is_empty() && outlines.reals.is_empty() {
            Outlines::default()
        } else {
            Outlines::from_table(outlines)?
        };
        let mut list = Vec::new();
        for (kind, t) in &families {
            list.push(Family::new(kind, t, n, functions.len(), outlines.len()).map_err(|e| format!("{kind}: {e}"))?);
        }
        let angles = angles
            .into_iter()
            .map(|a| {
                if a >= 0 && (a as usize) < n {
                    Ok(a as usize)
                } else {
                    Err(format!("angle column {a} outside 0..{n}"))
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        let (mut row_off, mut entry_off) = (vec![0], vec![0]);
        for f in &list {
            row_off.push(row_off.last().unwrap() + f.rows());
            entry_off.push(entry_off.last().unwrap() + f.entries());
        }
        let shared = Shared { functions: &functions, outlines: &outlines };
        let time_dependent = (0..list.len()).filter(|&k| list[k].time_dependent(&shared)).collect();
        Ok(Kin {
            n,
            m: *row_off.last().unwrap(),
            nnz: *entry_off.last().unwrap(),
            families: list,
            row_off,
            entry_off,
            angles,
            functions,
            outlines,
            time_dependent,
        })
    }

    fn shared(&self) -> Shared<'_> {
        Shared { functions: &self.functions, outlines: &self.outlines }
    }

    /// e[j] = e^{i q[j]} at the angle columns: once per configuration.
    #[inline]
    pub fn rotate(&self, q: &[f64], e: &mut [C64]) {
        for &j in &self.angles {
            let (s, c) = q[j].sin_cos();
            e[j] = C64::new(c, s);
        }
    }

    pub fn phi(&self, at: &At, out: &mut [f64]) {
        let s = self.shared();
        for (k, f) in self.families.iter().enumerate() {
            f.phi(at, &s, &mut out[self.row_off[k]..self.row_off[k + 1]]);
        }
    }

    pub fn jac(&self, at: &At, out: &mut [f64]) {
        let s = self.shared();
        for (k, f) in self.families.iter().enumerate() {
            f.jac(at, &s, &mut out[self.entry_off[k]..self.entry_off[k + 1]]);
        }
    }

    pub fn nu(&self, t: f64, out: &mut [f64]) {
        out.fill(0.0);
        let s = self.shared();
        for &k in &self.time_dependent {
            self.families[k].nu(t, &s, &mut out[self.row_off[k]..self.row_off[k + 1]]);
        }
    }

    pub fn gamma(&self, at: &At, qd: &[f64], out: &mut [f64]) {
        let s = self.shared();
        for (k, f) in self.families.iter().enumerate() {
            f.gamma(at, qd, &s, &mut out[self.row_off[k]..self.row_off[k + 1]]);
        }
    }
}
