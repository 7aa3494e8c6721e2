//! Fixed-size dense kernels for the block-triangular layout's diagonal
//! blocks (crate::triangular, issue 31 round 15): a block of s coordinates,
//! 2 <= s <= LIMIT, is solved over all s x s places of its factors (stored
//! dense, row-major, in its fixed pivot order: crate::order; factorised by
//! the lists, crate::triangular::Factoring, every place outside the
//! pattern zero), by code written for its size (const generics, one match
//! on s per block: the loops unroll, the right side lives in registers).
//!
//! Each entry sees the operations of the block's program (Order::program)
//! in their order, and more: the structural zeros' products. x - 0 y = x
//! for every finite y, so the figures are the program's to the bit but for
//! the sign of an exact zero (-0 - 0 y can be +0). (A dense factorisation
//! of the blocks was measured slower: docs/benchmarks.md, "Round 15".)
use crate::triangular::Cell;

/// The largest block given a dense kernel; larger ones keep the lists.
pub const LIMIT: usize = 8;

/// Whether a block of s coordinates is solved dense.
pub fn fits(s: usize) -> bool {
    (2..=LIMIT).contains(&s)
}

/// w at the places p (the block's coordinates, in its fixed order) <-
/// U^-1 L^-1 w, a: the block's factors (s x s, L unit lower). Forward
/// elimination column by column, then back substitution from the last
/// column (its division, then U's column above it): Order::program's order.
///
/// # Safety
/// a.len() >= s s, p.len() >= s, every place of p below w.len().
#[inline(always)]
unsafe fn solve_s<const S: usize, A: Copy, W: Cell<A>>(a: &[A], p: &[u32], w: &mut [W]) {
    let mut y: [W; S] = std::array::from_fn(|k| *w.get_unchecked(*p.get_unchecked(k) as usize));
    for k in 0..S {
        let x = y[k];
        for i in k + 1..S {
            y[i].sub_mul(*a.get_unchecked(i * S + k), x);
        }
    }
    for k in (0..S).rev() {
        y[k].div(*a.get_unchecked(k * S + k));
        let x = y[k];
        for i in 0..k {
            y[i].sub_mul(*a.get_unchecked(i * S + k), x);
        }
    }
    for k in 0..S {
        *w.get_unchecked_mut(*p.get_unchecked(k) as usize) = y[k];
    }
}

/// `solve_s` for a block of s coordinates (`fits(s)`).
///
/// # Safety
/// as `solve_s`.
#[inline(always)]
pub unsafe fn solve<A: Copy, W: Cell<A>>(s: usize, a: &[A], p: &[u32], w: &mut [W]) {
    debug_assert!(fits(s) && a.len() >= s * s && p.len() >= s && p[..s].iter().all(|&c| (c as usize) < w.len()));
    match s {
        2 => solve_s::<2, A, W>(a, p, w),
        3 => solve_s::<3, A, W>(a, p, w),
        4 => solve_s::<4, A, W>(a, p, w),
        5 => solve_s::<5, A, W>(a, p, w),
        6 => solve_s::<6, A, W>(a, p, w),
        7 => solve_s::<7, A, W>(a, p, w),
        8 => solve_s::<8, A, W>(a, p, w),
        _ => unreachable!("dense block of {s}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::order::Order;
    use crate::triangular::Program;

    fn next(x: &mut u64) -> u64 {
        *x ^= *x << 13;
        *x ^= *x >> 7;
        *x ^= *x << 17;
        *x
    }

    fn unit(x: &mut u64) -> f64 {
        (next(x) >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    /// A random block of s coordinates with a full matching (its fixed order
    /// and its permuted s x s values, pivots kept away from zero), or None.
    fn block(s: usize, x: &mut u64) -> Option<(Order, Vec<f64>)> {
        let mut rows = vec![0u64; s];
        let perm: Vec<usize> = {
            let mut p: Vec<usize> = (0..s).collect();
            for i in (1..s).rev() {
                p.swap(i, next(x) as usize % (i + 1));
            }
            p
        };
        for i in 0..s {
            rows[i] = 1 << perm[i];
            for j in 0..s {
                if next(x).is_multiple_of(3) {
                    rows[i] |= 1 << j;
                }
            }
        }
        let o = Order::new(s, &rows, &vec![0; s], &vec![0; s])?;
        let mut a = vec![0.0; s * s];
        for i in 0..s {
            for j in (0..s).filter(|&j| rows[i] >> j & 1 == 1) {
                a[o.inv_row[i] * s + o.inv_col[j]] = unit(x) + if next(x).is_multiple_of(2) { 0.5 } else { -0.5 };
            }
        }
        for k in 0..s {
            a[k * s + k] += 4.0f64.copysign(a[k * s + k]);
        }
        Some((o, a))
    }

    #[test]
    fn the_dense_solve_is_the_programs_to_the_bit() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut tried = [0; LIMIT + 1];
        for trial in 0..700 {
            let s = 2 + trial % (LIMIT - 1);
            let Some((o, mut a)) = block(s, &mut x) else { continue };
            o.numeric(&mut a).expect("pivots kept away from zero");
            // the block's places scattered over n coordinates (Program::renumber), its factors after others
            let (n, store) = (s + 3, 7);
            let mut to: Vec<usize> = (0..n).collect();
            for i in (1..n).rev() {
                to.swap(i, next(&mut x) as usize % (i + 1));
            }
            let values = store + s * s;
            let (mut lists, mut dense) = (Program::default(), Program::default());
            for p in [&mut lists, &mut dense] {
                (p.positions, p.values) = (n, values);
            }
            o.program(1, store, &mut lists);
            dense.dense_block(1, s, store);
            for p in [&mut lists, &mut dense] {
                p.renumber(&to);
                p.check().unwrap();
            }
            let mut f = vec![f64::NAN; store];
            f.extend(&a);
            let w: Vec<f64> = (0..n).map(|_| unit(&mut x)).collect();
            let (mut u, mut v) = (w.clone(), w.clone());
            lists.run(&f, &mut u);
            dense.run(&f, &mut v);
            assert!(u.iter().zip(&v).all(|(p, q)| p.to_bits() == q.to_bits()), "size {s}: {u:?} {v:?}");
            // three right sides at once (the sensitivities' Cell): each its own solve's
            let mut w3: Vec<[f64; 3]> = w.iter().map(|&y| [y, -2.0 * y, 0.25 + y]).collect();
            dense.run(&f, &mut w3);
            for c in 0..3 {
                let mut one: Vec<f64> = w3.iter().map(|_| 0.0).collect();
                for (p, q) in one.iter_mut().zip(&w) {
                    *p = [*q, -2.0 * q, 0.25 + q][c];
                }
                lists.run(&f, &mut one);
                assert!(one.iter().zip(&w3).all(|(p, q)| p.to_bits() == q[c].to_bits()), "size {s}, side {c}");
            }
            tried[s] += 1;
        }
        assert!(tried[2..].iter().all(|&t| t >= 40), "blocks per size {tried:?}");
    }
}
