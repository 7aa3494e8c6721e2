//! What a model's plan computes once: the fixed pivot order of each small
//! block of J_s (crate::order), from the Jacobian's pattern and the entries
//! that are constant whatever the configuration.
use crate::families::At;
use crate::lu::{Layout, Shape, MASK};
use crate::model::Kin;
use crate::order::Order;
use num_complex::Complex64 as C64;

/// The Jacobian's values at a few arbitrary configurations and times:
/// (constant, unit) per entry: the same value at every one of them (a
/// constant of the formulation: +-1 of a joint, a gear's radii) and, for
/// those, whether the scaled value is +-1.
pub fn constant_entries(kin: &Kin, entry_scale: &[f64]) -> (Vec<bool>, Vec<bool>) {
    let n = kin.n;
    let mut first: Option<Vec<f64>> = None;
    let mut constant = vec![true; kin.nnz];
    let mut values = vec![0.0; kin.nnz];
    let mut e = vec![C64::new(1.0, 0.0); n];
    for trial in 0..3 {
        let q: Vec<f64> = (0..n).map(|j| (1.7 * j as f64 + 0.9 * trial as f64 + 0.3).sin() * 2.0).collect();
        kin.rotate(&q, &mut e);
        kin.jac(&At { q: &q, e: &e, t: 0.31 + 0.77 * trial as f64 }, &mut values);
        match &first {
            None => first = Some(values.clone()),
            Some(v) => {
                for k in 0..kin.nnz {
                    constant[k] &= v[k] == values[k];
                }
            }
        }
    }
    let v = first.unwrap_or_default();
    let unit = (0..kin.nnz).map(|k| constant[k] && (v[k] * entry_scale[k]).abs() == 1.0).collect();
    (constant, unit)
}

/// Gives every block of up to MASK coordinates its fixed order (none where
/// the pattern is structurally singular: that block keeps partial pivoting).
pub fn order_blocks(kin: &Kin, layout: &mut Layout) {
    let (constant, unit) = constant_entries(kin, &layout.entry_scale);
    let Shape::Blocks { count, size, pad, patterns, .. } = &layout.shape else { return };
    let (count, s) = (*count, *size);
    if s > MASK || patterns.len() != count * s {
        return;
    }
    let (mut row_at, mut col_at) = (vec![crate::order::NONE; count * s], vec![crate::order::NONE; count * s]);
    for (i, &p) in layout.row_pos.iter().enumerate() {
        row_at[p] = i;
    }
    for (j, &p) in layout.col_pos.iter().enumerate() {
        col_at[p] = j;
    }
    let mut orders = Vec::with_capacity(count);
    for c in 0..count {
        let rows: Vec<u64> = (0..s).map(|i| patterns[c * s + i].0).collect();
        let (mut u, mut k) = (vec![0u64; s], vec![0u64; s]);
        for &e in &layout.by_block[layout.block_start[c]..layout.block_start[c + 1]] {
            let (_, r, col) = layout.at[e];
            if constant[e] {
                k[r] |= 1 << col;
                if unit[e] {
                    u[r] |= 1 << col;
                }
            }
        }
        for &p in pad.iter().filter(|&&p| p / s == c) {
            let i = p % s;
            u[i] |= 1 << i;
            k[i] |= 1 << i;
        }
        let mut order = Order::new(s, &rows, &u, &k);
        if let Some(o) = &mut order {
            let entries: Vec<(usize, usize)> = layout.by_block[layout.block_start[c]..layout.block_start[c + 1]]
                .iter()
                .map(|&e| (layout.at[e].1, layout.at[e].2))
                .collect();
            let pads: Vec<usize> = pad.iter().filter(|&&p| p / s == c).map(|&p| p % s).collect();
            o.fuse(
                &row_at[c * s..(c + 1) * s],
                &col_at[c * s..(c + 1) * s],
                &layout.scale,
                &layout.col_scale,
                &entries,
                &pads,
                &layout.real[c * s..(c + 1) * s],
            );
            let ids = &layout.by_block[layout.block_start[c]..layout.block_start[c + 1]];
            o.place =
                ids.iter().zip(&o.entry_at).map(|(&e, &at)| (e as u32, at as u32, layout.entry_scale[e])).collect();
        }
        orders.push(order);
    }
    if let Shape::Blocks { orders: o, .. } = &mut layout.shape {
        *o = orders;
    }
}
