//! TODO(issue 23): port from kinem/constraints (stub).
use super::{At, Shared};
use crate::table::Table;

pub struct Simple { rows: usize, entries: usize }

impl Simple {
    pub fn new(t: &Table, n: usize, functions: usize) -> Result<Self, String> {
        let _ = (t, n, functions);
        Err("Simple: not ported yet".into())
    }
    pub fn rows(&self) -> usize { self.rows }
    pub fn entries(&self) -> usize { self.entries }
    pub fn phi(&self, _: &At, _: &Shared, _: &mut [f64]) {}
    pub fn jac(&self, _: &At, _: &Shared, _: &mut [f64]) {}
    pub fn gamma(&self, _: &At, _: &[f64], _: &Shared, _: &mut [f64]) {}
    pub fn time_dependent(&self, _: &Shared) -> bool { false }
    pub fn nu(&self, _: f64, _: &Shared, out: &mut [f64]) { out.fill(0.0) }
}
