//! A fuzz test of the tables validated once when a model is built (issue
//! 31 item 4): the hot loops index without bounds checks (the blocks' solve
//! program and factoring, crate::triangular) or trust the families' column
//! indices, checked by their constructors. Random families (random columns,
//! indices partly out of range) must be refused with an Err or evaluate in
//! bounds; random patterns laid out block-triangularly must pass their
//! checks and solve as a dense LU does, and a corrupted program must be
//! refused. Under `cargo test` (debug) the loops' debug assertions run too.
use crate::families::{At, Family, KINDS};
use crate::lu::{Layout, Shape};
use crate::model::Kin;
use crate::table::Table;
use crate::triangular::{Lay, DIV};
use num_complex::Complex64 as C64;

/// xorshift64*: no crate, reproducible.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, k: u64) -> u64 {
        self.next() % k.max(1)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// Functions: a constant, a line in t, a harmonic (kinem.functions' layout).
fn functions() -> Table {
    let mut t = Table::default();
    t.ints.insert("kind".into(), vec![0, 0, 1]);
    t.ints.insert("start".into(), vec![0, 1, 3, 7]);
    t.reals.insert("data".into(), vec![1.3, 0.2, 0.9, 0.5, 2.0, 0.3, 0.1]);
    t
}

/// One outline: a circle of radius 1.2.
fn outlines() -> Table {
    let mut t = Table::default();
    for (k, v) in [("first", vec![0]), ("last", vec![0]), ("periodic", vec![1])] {
        t.ints.insert(k.into(), v);
    }
    for (k, v) in [("t0", vec![0.0]), ("span", vec![std::f64::consts::TAU]), ("starts", vec![0.0])] {
        t.reals.insert(k.into(), v);
    }
    t.reals.insert("coef".into(), vec![0.0, 0.0, 0.0, 1.2]);
    t.complex.insert("center".into(), vec![C64::new(0.1, -0.2)]);
    t
}

/// A random table for `kind` over n coordinates, `rows` constraints: every
/// column its constructor asks for (named in its "no column" error), as
/// integers (indices mostly in 0..n, some out of range when `wild`), reals
/// and complex values alike. None when the constructor refuses it otherwise.
fn random_family(kind: &str, n: usize, rows: usize, wild: bool, rng: &mut Rng) -> (Table, Result<Family, String>) {
    let mut t = Table::default();
    loop {
        let r = Family::<f64>::new(kind, &t, n, 3, 1);
        let key = match &r {
            Err(e) if e.starts_with("table has no column '") => e[21..e.len() - 1].to_string(),
            _ => return (t, r),
        };
        let ints = (0..rows)
            .map(|_| match rng.below(if wild { 12 } else { 1000 }) {
                0 => -1 - rng.below(3) as i64,
                1 => (n + rng.below(4) as usize) as i64,
                _ => rng.below(n as u64 - 2) as i64, // a body's x column or any column below n - 2
            })
            .collect();
        t.ints.insert(key.clone(), ints);
        t.reals.insert(key.clone(), (0..rows).map(|_| rng.unit()).collect());
        t.complex.insert(key, (0..rows).map(|_| C64::new(rng.unit(), rng.unit())).collect());
    }
}

#[test]
fn random_families_are_refused_or_evaluate_in_bounds() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (f, o) = (functions(), outlines());
    let (mut refused, mut evaluated) = (0, 0);
    for trial in 0..2000 {
        let kind = KINDS[trial % KINDS.len()];
        let n = 3 * (1 + rng.below(4) as usize);
        let rows = 1 + rng.below(4) as usize;
        let (t, family) = random_family(kind, n, rows, trial % 2 == 0, &mut rng);
        let angles: Vec<i64> = (2..n as i64).step_by(3).collect();
        let kin = match Kin::<f64>::new(n, vec![(kind.to_string(), t)], &f, &o, angles) {
            Err(_) => {
                assert!(family.is_err(), "trial {trial}: {kind} accepted alone, refused in a model");
                refused += 1;
                continue;
            }
            Ok(k) => k,
        };
        assert!(family.is_ok(), "trial {trial}: {kind} refused alone, accepted in a model");
        // evaluation: every kernel at a random configuration, in bounds (a panic fails the test)
        let q: Vec<f64> = (0..n).map(|_| rng.unit()).collect();
        let qd: Vec<f64> = (0..n).map(|_| rng.unit()).collect();
        let mut e = vec![C64::new(1.0, 0.0); n];
        kin.rotate(&q, &mut e);
        let at = At { q: &q, e: &e, t: rng.unit() };
        let (mut phi, mut jac, mut nu, mut gamma) =
            (vec![0.0; kin.m], vec![0.0; kin.nnz], vec![0.0; kin.m], vec![0.0; kin.m]);
        kin.phi(&at, &mut phi);
        kin.jac(&at, &mut jac);
        kin.nu(at.t, &mut nu);
        kin.gamma(&at, &qd, &mut gamma);
        // the families that read their columns unchecked refuse (panic on) a
        // configuration shorter than n: their one check per call, never a read out of bounds
        if ["simple", "revolute", "line", "distance"].contains(&kind) {
            let short = At { q: &q[..n - 1], e: &e[..n - 1], t: at.t };
            for which in 0..3 {
                let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match which {
                    0 => kin.phi(&short, &mut phi),
                    1 => kin.jac(&short, &mut jac),
                    _ => kin.gamma(&short, &qd, &mut gamma),
                }));
                assert!(r.is_err(), "trial {trial}: {kind} evaluated a configuration of n - 1 coordinates");
            }
        }
        evaluated += 1;
    }
    assert!(refused >= 200 && evaluated >= 200, "both kinds of table: {refused} refused, {evaluated} evaluated");
}

/// One block over a random square pattern with a matching (a random
/// permutation) and entries below a random block structure, as
/// kinem.model.Model.plan lays it out.
fn random_layout(n: usize, rng: &mut Rng) -> (Layout, Vec<usize>, Vec<usize>) {
    let mut perm: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        perm.swap(i, rng.below(i as u64 + 1) as usize);
    }
    // groups of consecutive matched pairs: dense-ish inside, entries only towards earlier groups
    let mut group = vec![0; n];
    let mut g = 0;
    for (i, x) in group.iter_mut().enumerate() {
        if i > 0 && rng.below(3) == 0 {
            g += 1;
        }
        *x = g;
    }
    let mut set = vec![false; n * n];
    for i in 0..n {
        set[i * n + perm[i]] = true;
        for k in 0..n {
            if group[k] <= group[i] && rng.below(4) == 0 {
                set[i * n + perm[k]] = true;
            }
        }
    }
    let (mut rows, mut cols) = (Vec::new(), Vec::new());
    for i in 0..n {
        for j in 0..n {
            if set[i * n + j] {
                rows.push(i);
                cols.push(j);
            }
        }
    }
    let scale = (0..n).map(|_| 1.0 + 0.5 * rng.unit().abs()).collect();
    let col_scale = (0..n).map(|_| 1.0 + 0.5 * rng.unit().abs()).collect();
    let l = super::one_block(n, &rows, &cols, scale, col_scale);
    (l, rows, cols)
}

/// The pivots' figures read from every pivot of J_s (Phi_q's times c_p /
/// r_p) in position order, from the factors j: (smallest, largest, the
/// position of the first smallest, det sign).
fn every_pivot(t: &crate::triangular::Triangular, j: &[f64]) -> (f64, f64, usize, i32) {
    let (mut small, mut big, mut at, mut det) = (f64::INFINITY, 0.0f64, 0, t.sign);
    for (p, &v) in t.factoring.diag.iter().enumerate() {
        let d = j[v as usize] * t.factoring.pivot_scale[p];
        det = if d < 0.0 { -det } else { det };
        if d.abs() < small {
            (small, at) = (d.abs(), p);
        }
        big = big.max(d.abs());
    }
    (small, big, at, det)
}

#[test]
fn random_block_triangular_layouts_check_and_solve_and_refuse_corruption() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let (mut solved, mut corrupted, mut folds, mut quiet, mut deep, mut refused, mut same) = (0, 0, 0, 0, 0, 0, 0);
    let (mut layouts, mut marks) = (0, 0);
    for trial in 0..600 {
        let n = 2 + rng.below(19) as usize;
        let (mut layout, rows, cols) = random_layout(n, &mut rng);
        let constant: Vec<bool> = rows.iter().map(|_| rng.below(3) == 0).collect();
        // entries taken for +1 (a folded 1x1 pivot where one is alone in its block): set so in half the trials
        let one: Vec<bool> = constant.iter().map(|&c| c && rng.below(2) == 0).collect();
        let honest = trial % 2 == 0;
        // rows whose nu looked zero: their folded 1x1 blocks are quiet positions of the program
        // (from a generator of their own: the other draws as before)
        let mut quiet_rng = Rng(0x9e37_79b9_7f4a_7c15 ^ trial as u64);
        let still: Vec<bool> = (0..n).map(|_| quiet_rng.below(3) != 0).collect();
        // entries exactly zero (a revolute's B s' with s' = 0), in a third of the trials: their
        // subtractions are left out, so that more 1x1 blocks may be quiet
        let mut zero_rng = Rng(0x6a09_e667_f3bc_c908 ^ trial as u64);
        let zero: Vec<bool> = rows.iter().map(|_| trial % 3 == 1 && zero_rng.below(4) == 0).collect();
        let zero: Vec<bool> = zero.iter().zip(&one).map(|(&z, &o)| z && !o).collect();
        let original = layout.clone();
        if !super::triangulate_zero(&mut layout, &constant, &constant, &one, &still, &zero) {
            continue;
        }
        // the same layout with every entry taken for nonzero: the figures the zeros must leave
        let mut with_zeros = original.clone();
        let plain =
            zero.iter().any(|&z| z) && super::triangulate_still(&mut with_zeros, &constant, &constant, &one, &still);
        let Shape::Triangular(t) = &layout.shape else { panic!("trial {trial}: not triangular") };
        t.check().unwrap();
        let folded = t.factoring.ones.len();
        assert_eq!(t.program.divs.len() + folded, n, "trial {trial}: one division per position not folded");
        for _ in 0..4 {
            let mut values: Vec<f64> =
                rows.iter().map(|_| rng.unit() + if rng.below(2) == 0 { 2.0 } else { -2.0 }).collect();
            for e in (0..values.len()).filter(|&e| honest && one[e]) {
                values[e] = 1.0; // Phi_q's value 1 (the factors are unscaled)
            }
            for e in (0..values.len()).filter(|&e| honest && zero[e]) {
                values[e] = if rng.below(2) == 0 { 0.0 } else { -0.0 }; // exactly zero, as the model's
            }
            let mut a = vec![0.0; n * n];
            for e in 0..values.len() {
                a[rows[e] * n + cols[e]] = values[e];
            }
            let x0: Vec<f64> = (0..n).map(|_| rng.unit()).collect();
            let b: Vec<f64> = (0..n).map(|i| (0..n).map(|j| a[i * n + j] * x0[j]).sum()).collect();
            let mut f = layout.factors();
            layout.factor(&values, &mut f);
            if !honest && !t.factoring.zero_entries.is_empty() {
                // an entry taken for zero that is not (a variant's moved local point): the fallback's
                assert!(f.fixed[0].is_none(), "trial {trial}: a nonzero entry taken for zero was factorised");
                refused += 1;
            }
            let (ratio, _) = layout.stats(&f);
            if ratio < 1e-8 {
                continue;
            }
            let mut x = vec![0.0; n];
            layout.solve(&mut f, &b, &mut x);
            if honest && plain {
                // exact zeros no part of the structure (other blocks, other pivot orders): the
                // same matrix's det sign and solution to rounding (the bound below, both ways)
                let mut g = with_zeros.factors();
                with_zeros.factor(&values, &mut g);
                let mut y = vec![0.0; n];
                with_zeros.solve(&mut g, &b, &mut y);
                let (a, c) = (layout.stats(&f), with_zeros.stats(&g));
                let apart = x.iter().zip(&y).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max);
                assert!(a.1 == c.1 && apart < 1e-6 / a.0.min(c.0), "trial {trial}: {a:?} {c:?}, apart {apart}");
                same += 1;
            }
            let err = x.iter().zip(&x0).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max);
            assert!(err < 1e-6 / ratio, "trial {trial}: error {err}, pivot ratio {ratio}");
            solved += 1;
            if f.fixed[0].is_some() {
                // the program laid out either way (triangular::Lay), each list alone: the same figures to the bit
                for lays in
                    [[Lay::Runs, Lay::Runs], [Lay::Lone, Lay::Lone], [Lay::Runs, Lay::Lone], [Lay::Lone, Lay::Runs]]
                {
                    let mut other = (**t).clone();
                    other.program.lay_as(lays);
                    other.check().unwrap();
                    let (mut y, mut z) = (vec![f64::NAN; n], vec![f64::NAN; n]);
                    assert_eq!(other.run_negating(&f.j, &b, &mut y), t.run_negating(&f.j, &b, &mut z));
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&y), bits(&z), "trial {trial}: laid out as {lays:?}, other figures");
                    layouts += 1;
                }
            }
            if let Some(got) = &f.fixed[0] {
                // the pivots' figures read from the free pivots and the folded ones' constants
                // are those of every pivot of J_s (Phi_q's times c_p / r_p) in position order (tolerance 0)
                assert_eq!((got.small, got.big, got.at, got.det), every_pivot(t, &f.j), "trial {trial}");
            }
            if !t.program.quiet.is_empty() && f.fixed[0].is_some() {
                // zero right sides at the quiet positions: the short program's figures are the
                // full one's (equal as numbers: tolerance 0; only a zero's sign may differ)
                let mut b = b.clone();
                for &q in &t.program.quiet {
                    // the program's places are coordinates: the row of coordinate q's position
                    let p = t.scatter.iter().position(|&j| j == q as usize).unwrap();
                    b[t.gather[p]] = 0.0;
                }
                let mut full = (**t).clone();
                full.program.quiet.clear();
                let (mut xs, mut xf) = (vec![0.0; n], vec![0.0; n]);
                t.run(&f.j, &b, &mut xs);
                full.run(&f.j, &b, &mut xf);
                assert_eq!(xs, xf, "trial {trial}: the short program differs from the full one");
                // the solve says it ran quiet, and each quiet coordinate's x is its row's b (+0 or
                // -0), to the bit: what the march's rest coordinates rely on (march::rest)
                for &q in &t.program.quiet {
                    let p = t.scatter.iter().position(|&j| j == q as usize).unwrap();
                    b[t.gather[p]] = if rng.below(2) == 0 { 0.0 } else { -0.0 };
                }
                let mut xq = vec![f64::NAN; n];
                assert!(layout.solve_quiet(&mut f, &b, &mut xq), "trial {trial}: zero quiet sides not quiet");
                for &q in &t.program.quiet {
                    let p = t.scatter.iter().position(|&j| j == q as usize).unwrap();
                    assert_eq!(xq[q as usize].to_bits(), b[t.gather[p]].to_bits(), "trial {trial}: quiet x moved");
                }
                // one quiet side not zero: not quiet
                let k = t.program.quiet[rng.below(t.program.quiet.len() as u64) as usize];
                let p = t.scatter.iter().position(|&j| j == k as usize).unwrap();
                for v in [1e-300, -5e-324, f64::NAN, -f64::INFINITY] {
                    b[t.gather[p]] = v;
                    assert!(!layout.solve_quiet(&mut f, &b, &mut xq), "trial {trial}: a quiet side {v} ran quiet");
                }
                quiet += 1;
                // a quiet position that a subtraction writes (from another quiet one)
                deep += t.program.subs.iter().any(|s| t.program.quiet.contains(&s[0])) as usize;
            }
            folds += (folded > 0 && f.fixed[0].is_some()) as usize;
        }
        // any index of the program or the factoring moved out of range is refused
        let mut p = t.program.clone();
        if !p.subs.is_empty() || !p.divs.is_empty() {
            // (a program of folded pivots whose subtractions all read exact zeros has neither)
            let k = rng.below(p.subs.len() as u64 + p.divs.len() as u64) as usize;
            let far = (p.positions.max(p.values) + rng.below(5) as usize) as u32;
            if k < p.subs.len() {
                p.subs[k][rng.below(3) as usize] = far;
            } else {
                p.divs[k - p.subs.len()][1 + rng.below(2) as usize] = far;
            }
            assert!(p.check().is_err(), "trial {trial}: a corrupted program passed its check");
            // and its flat list alone moved out of range (or out of its order) is refused too
            // (its own generator: the trials' stream is the one before the flat list)
            let (mut p, mut flat_rng) = (t.program.clone(), Rng(0x0f1a_7115_7000_0000 ^ trial as u64));
            let k = flat_rng.below(p.ops.len() as u64) as usize;
            let at = if p.ops[k][2] == DIV { 0 } else { flat_rng.below(3) as usize };
            p.ops[k][at] = far;
            assert!(p.check().is_err(), "trial {trial}: a corrupted flat program passed its check");
            // and a list whose mark is not its layout's
            for list in 0..2 {
                let mut p = t.program.clone();
                p.lays[list] = if p.lays[list] == Lay::Runs { Lay::Lone } else { Lay::Runs };
                let mut relaid = p.clone();
                relaid.lay_as(p.lays);
                let (ops, moved) = if list == 0 { (&p.ops, &relaid.ops) } else { (&p.short_ops, &relaid.short_ops) };
                assert!(
                    ops == moved || p.check().is_err(),
                    "trial {trial}: a list with another's mark passed its check"
                );
                marks += (ops != moved) as usize;
            }
        }
        let mut fa = t.factoring.clone();
        let far = (fa.values + rng.below(5) as usize) as u32;
        match rng.below(3) {
            0 if !fa.place.is_empty() => fa.place[0][1] = far,
            1 if !fa.pairs.is_empty() => fa.pairs[0][1] = far,
            _ => fa.diag[0] = far,
        }
        assert!(fa.check().is_err(), "trial {trial}: a corrupted factoring passed its check");
        corrupted += 1;
    }
    assert!(
        solved >= 300
            && corrupted >= 100
            && folds >= 20
            && quiet >= 20
            && deep >= 5
            && refused >= 20
            && same >= 20
            && layouts >= 1000
            && marks >= 100,
        "{solved} solves ({folds} with folded pivots, {quiet} quiet, {deep} through quiet positions, {refused} \
         nonzero entries taken for zero refused, {same} equal to the solves with the zeros to rounding, \
         {layouts} in other layouts to the bit), {corrupted} corruptions checked ({marks} lists with \
         another's mark)"
    );
}

/// Pivots that are a constant -1 (plan::negate): the solve negates there
/// instead of multiplying by the reciprocal, and its figures are the
/// products' to the bit (tolerance 0, Triangular::run multiplies by the
/// stored -1); every position's reciprocal is 1 / its pivot (tolerance 0:
/// Factoring::recips and the steps'); the pivots'
/// figures with theirs folded are those of every pivot; a factorisation
/// where such an entry is not -1 (a variant's) is refused. The lanes
/// (crate::lane_lu) refuse it too, and otherwise solve as the scalar, to
/// the bit, lane by lane.
#[test]
fn negated_pivots_solve_as_the_divisions_and_a_moved_one_is_refused() {
    use crate::lanes::WIDTH;
    use crate::triangular::NEGATE;
    use crate::wide::Wide;
    let mut rng = Rng(0x3c6e_f372_fe94_f82b);
    let (mut negated, mut equal, mut refused, mut steps) = (0, 0, 0, 0);
    for trial in 0..400 {
        let n = 2 + rng.below(15) as usize;
        let (mut layout, rows, _) = random_layout(n, &mut rng);
        let constant: Vec<bool> = rows.iter().map(|_| rng.below(2) == 0).collect();
        let one: Vec<bool> = constant.iter().map(|&c| c && rng.below(4) == 0).collect();
        let minus: Vec<bool> = constant.iter().zip(&one).map(|(&c, &o)| c && !o && rng.below(2) == 0).collect();
        let still = vec![false; n];
        if !super::triangulate_zero(&mut layout, &constant, &constant, &one, &still, &[]) {
            continue;
        }
        let Shape::Triangular(t) = &mut layout.shape else { panic!("trial {trial}: not triangular") };
        super::negate(t, &minus);
        let t = (**t).clone();
        t.check().unwrap();
        let marked = t.program.divs.iter().filter(|d| d[2] & NEGATE != 0).count();
        negated += (marked > 0) as usize;
        let honest = trial % 4 != 3;
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for _ in 0..3 {
            let mut values: Vec<f64> =
                rows.iter().map(|_| rng.unit() + if rng.below(2) == 0 { 2.0 } else { -2.0 }).collect();
            for e in 0..values.len() {
                if one[e] {
                    values[e] = 1.0;
                } else if minus[e] {
                    values[e] = -1.0;
                }
            }
            if !honest {
                if let Some(&e) = t.factoring.minus_entries.first() {
                    values[e as usize] = -1.0 - 2f64.powi(-40);
                }
            }
            let mut f = layout.factors();
            layout.factor(&values, &mut f);
            // the lanes (crate::lane_lu, each lane these values): refused as the scalar, else its figures
            let mut lanes = crate::lane_lu::LaneLu::new(&layout).expect("triangular");
            lanes.factor(&values.iter().map(|&v| Wide([v; WIDTH])).collect::<Vec<_>>());
            if !honest && !t.factoring.minus_entries.is_empty() {
                assert!(f.fixed[0].is_none(), "trial {trial}: a pivot taken for -1 that is not was factorised");
                assert!(!lanes.fixed.iter().any(|&x| x), "trial {trial}: a lane's pivot taken for -1 that is not");
                refused += 1;
                continue;
            }
            let Some(got) = f.fixed[0] else { continue };
            // the factors with 1 / -1 taken for the steps' negated pivots: the divisions' to the bit
            let mut plain = layout.factors();
            t.factoring.eliminate(&values, &mut plain.j, |_, _| {});
            assert_eq!(bits(&plain.j), bits(&f.j), "trial {trial}: the factors differ from the divisions'");
            let fa = &t.factoring;
            for (p, &at) in fa.diag.iter().enumerate().filter(|(_, at)| !fa.ones.contains(at)) {
                let got = f.j[fa.recip_at as usize + p];
                assert_eq!(
                    got.to_bits(),
                    (1.0 / f.j[at as usize]).to_bits(),
                    "trial {trial}: position {p}'s reciprocal"
                );
            }
            steps += t.factoring.steps.iter().any(|s| s[0] & NEGATE != 0) as usize;
            let b: Vec<f64> = (0..n).map(|_| rng.unit()).collect();
            let (mut x, mut y) = (vec![0.0; n], vec![0.0; n]);
            layout.solve(&mut f, &b, &mut x);
            t.run(&f.j, &b, &mut y);
            assert_eq!(bits(&x), bits(&y), "trial {trial}: negations differ from the divisions");
            let mut xl = vec![Wide([0.0; WIDTH]); n];
            lanes.solve(&b.iter().map(|&v| Wide([v; WIDTH])).collect::<Vec<_>>(), &mut xl);
            for q in 0..WIDTH {
                assert!(lanes.fixed[q], "trial {trial}: lane {q} refused where the scalar was not");
                let lane: Vec<f64> = xl.iter().map(|w| w.0[q]).collect();
                assert_eq!(bits(&lane), bits(&x), "trial {trial}: lane {q} differs from the scalar");
            }
            assert_eq!((got.small, got.big, got.at, got.det), every_pivot(&t, &f.j), "trial {trial}");
            equal += (marked > 0) as usize;
        }
    }
    assert!(
        negated >= 50 && equal >= 100 && refused >= 20 && steps >= 20,
        "{negated} layouts negating, {equal} solves ({steps} with negated steps), {refused} refused"
    );
}

/// The constants placed once (Layout::place_once: entries never written
/// again, at places nothing else writes): every factorisation after it
/// gives the factors of one that places every entry, to the bit (the whole
/// storage, tolerance 0), over values that move but for those entries,
/// and after a factorisation that fell back to partial pivoting (a zero
/// pivot: the fallback writes over the places), whose next one places
/// every entry again.
#[test]
fn constants_placed_once_factorise_as_every_placement() {
    let mut rng = Rng(0x510e_527f_ade6_82d1);
    let (mut once, mut compared, mut fell) = (0, 0, 0);
    for trial in 0..300 {
        let n = 2 + rng.below(15) as usize;
        let (mut layout, rows, _) = random_layout(n, &mut rng);
        let constant: Vec<bool> = rows.iter().map(|_| rng.below(2) == 0).collect();
        let (still, none) = (vec![false; n], vec![false; rows.len()]);
        if !super::triangulate_zero(&mut layout, &constant, &constant, &none, &still, &none) {
            continue;
        }
        let Shape::Triangular(t) = &layout.shape else { panic!("trial {trial}: not triangular") };
        let kept: Vec<bool> = rows.iter().map(|_| rng.below(2) == 0).collect();
        let draw = |rng: &mut Rng| rng.unit() + if rng.below(2) == 0 { 2.0 } else { -2.0 };
        let mut values: Vec<f64> = rows.iter().map(|_| draw(&mut rng)).collect();
        let (mut f, mut plain) = (layout.factors(), layout.factors());
        layout.place_once(&values, &kept, &mut f);
        once += f.once as usize;
        assert!(f.once == f.placed && (!f.once || f.again.len() < t.factoring.place.len()), "trial {trial}");
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        // a pivot placed from an entry that is not kept (zero: the fallback's)
        let pivot = (t.factoring.place.iter()).find(|p| t.factoring.diag.contains(&p[1]) && !kept[p[0] as usize]);
        for round in 0..4 {
            for e in (0..values.len()).filter(|&e| !kept[e]) {
                values[e] = draw(&mut rng);
            }
            let fall = round == 1 && pivot.is_some();
            if fall {
                values[pivot.unwrap()[0] as usize] = 0.0;
            }
            layout.factor(&values, &mut f);
            layout.factor(&values, &mut plain);
            assert_eq!(f.fixed[0].is_some(), plain.fixed[0].is_some(), "trial {trial}");
            if f.fixed[0].is_none() {
                assert!(!f.placed, "trial {trial}: the constants taken for placed after a fallback");
                fell += 1;
            }
            assert_eq!(bits(&f.j), bits(&plain.j), "trial {trial} round {round}: the factors differ");
            compared += 1;
        }
    }
    assert!(once >= 100 && compared >= 600 && fell >= 50, "{once} placed once, {compared} compared, {fell} fallbacks");
}
