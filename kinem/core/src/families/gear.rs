//! TODO(issue 23): port from kinem/constraints (stub).
use super::{At, Shared};
use crate::table::Table;

pub struct Gear { rows: usize, entries: usize }

impl Gear {
    pub fn new(t: &Table, n: usize) -> Result<Self, String> {
        let _ = (t, n);
        Err("Gear: not ported yet".into())
    }
    pub fn rows(&self) -> usize { self.rows }
    pub fn entries(&self) -> usize { self.entries }
    pub fn phi(&self, _: &At, _: &Shared, _: &mut [f64]) {}
    pub fn jac(&self, _: &At, _: &Shared, _: &mut [f64]) {}
    pub fn gamma(&self, _: &At, _: &[f64], _: &Shared, _: &mut [f64]) {}
}
