//! The predictor and the one acceptance test of a tracked state (the
//! tracker's, kinem/tracking.py, and the march's): docs/solver.md,
//! "Branches and singular configurations".

/// A correction above half the predicted motion is a jump, not a refinement.
pub const KAPPA: f64 = 0.5;
/// A state whose last Newton correction is above REGULAR sqrt(tolerance)
/// (dimensionless) converged linearly, to a singular root.
pub const REGULAR: f64 = 1e-2;

/// An enum of codes that cross to Python (a kinem.native IntEnum mirrors
/// them; tests/test_bounds.py checks they agree): its members, `ALL` in
/// order and each one's `name` as the mirror spells it.
macro_rules! codes {
    ($(#[$m:meta])* pub enum $name:ident { $($(#[$vm:meta])* $v:ident = $code:literal => $text:literal,)* }) => {
        $(#[$m])*
        #[repr(u8)]
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
        pub enum $name {
            $($(#[$vm])* $v = $code,)*
        }

        impl $name {
            /// Every code, in order.
            pub const ALL: &'static [$name] = &[$($name::$v,)*];

            /// The code's name as the Python mirror spells it.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$v => $text,)*
                }
            }
        }
    };
}
pub(crate) use codes;

codes! {
    /// Why a state is not taken: the acceptance test's verdicts and the
    /// march's own stops (kinem.native.Why, each with its message).
    pub enum Why {
        Accepted = 0 => "ACCEPTED",
        /// the pivot ratio below the floor, or Newton converged linearly
        NearSingular = 1 => "NEAR_SINGULAR",
        /// det(J_s) changed sign
        DetFlip = 2 => "DET_FLIP",
        /// the correction from the predictor is a jump
        Jump = 3 => "JUMP",
        /// the march's position solve did not converge
        NotConverged = 4 => "NOT_CONVERGED",
        /// the march stopped for a signal (Ctrl-C): Python raises it
        Interrupted = 5 => "INTERRUPTED",
        /// the march reached its time limit (Options.max_seconds)
        OutOfTime = 6 => "OUT_OF_TIME",
        /// a variant refused before the march (kinem.variants: a length not
        /// positive, a number beyond the magnitude limit); never the march's own
        BadInput = 7 => "BAD_INPUT",
    }
}

/// The acceptance test: NEAR_SINGULAR when the pivot ratio is below the
/// floor (or not a number) or the last Newton correction is above REGULAR
/// sqrt(tolerance); DET_FLIP when det(J_s) changed sign (unless
/// `allow_flip`: a step over a bifurcation); JUMP when the correction from
/// the predictor is above KAPPA times the predicted motion plus ten times
/// the tolerance for round-off (judged when `judge_jump`: the predictor had
/// a slope); else Accepted.
#[allow(clippy::too_many_arguments)]
pub fn rejected(
    pivot: f64,
    correction: f64,
    det: i32,
    previous_det: i32,
    corr: f64,
    motion: f64,
    judge_jump: bool,
    floor: f64,
    tolerance: f64,
    allow_flip: bool,
) -> Why {
    if !(pivot >= floor) || !(correction <= REGULAR * tolerance.sqrt()) {
        return Why::NearSingular;
    }
    if det != previous_det && !allow_flip {
        return Why::DetFlip;
    }
    if judge_jump && corr > KAPPA * motion + 10.0 * tolerance {
        return Why::Jump;
    }
    Why::Accepted
}

/// The largest dimensionless |a - b| (lengths over their column scales):
/// the correction from the predictor (q, q_pred) and the predicted motion
/// (q_pred, q_last) that the acceptance test compares.
#[inline]
pub fn gap(a: &[f64], b: &[f64], col_scale: &[f64]) -> f64 {
    gap_as::<false>(a, b, col_scale, &mut [])
}

/// `gap`, copying a into `keep` (a's length) in the same pass.
#[inline]
pub fn gap_keep(a: &[f64], b: &[f64], col_scale: &[f64], keep: &mut [f64]) -> f64 {
    gap_as::<true>(a, b, col_scale, keep)
}

/// `gap`, with a copied into `keep` when K.
#[inline(always)]
fn gap_as<const K: bool>(a: &[f64], b: &[f64], col_scale: &[f64], keep: &mut [f64]) -> f64 {
    let n = a.len();
    let (b, col_scale) = (&b[..n], &col_scale[..n]);
    // two running maxima, so that the loop vectorises (a maximum does not
    // depend on the order it is taken in: the same figure)
    let (a2, b2, c2) = (a.as_chunks::<2>().0, b.as_chunks::<2>().0, col_scale.as_chunks::<2>().0);
    let mut g = [0.0f64; 2];
    if K {
        let keep = &mut keep[..n];
        for ((x, a), (b, c)) in keep.as_chunks_mut::<2>().0.iter_mut().zip(a2).zip(b2.iter().zip(c2)) {
            for l in 0..2 {
                g[l] = most(g[l], (a[l] - b[l]).abs() / c[l]);
            }
            *x = *a;
        }
        if n % 2 == 1 {
            keep[n - 1] = a[n - 1];
        }
    } else {
        for (a, (b, c)) in a2.iter().zip(b2.iter().zip(c2)) {
            for l in 0..2 {
                g[l] = most(g[l], (a[l] - b[l]).abs() / c[l]);
            }
        }
    }
    if n % 2 == 1 {
        g[0] = most(g[0], (a[n - 1] - b[n - 1]).abs() / col_scale[n - 1]);
    }
    most(g[0], g[1])
}

/// g.max(v) where g is not NaN (a running maximum from 0): v when above g,
/// else g, so a NaN v is passed over as f64::max passes it; the same figure
/// as f64::max, in one comparison (maxsd) instead of its NaN handling.
#[inline(always)]
pub fn most(g: f64, v: f64) -> f64 {
    if v > g {
        v
    } else {
        g
    }
}

/// The least spacing of two states that `lagrange` extrapolates through, as
/// a fraction of its step: sub-steps (halvings of an output interval) stay far
/// above it, so only states nearly at one instant are left out.
pub const STATES_APART: f64 = 1e-8;

/// q at t extrapolated through the states h (3 rows of n) at times tt (3),
/// oldest first (NaN: none): Lagrange through those within four steps of t
/// and, newest first, more than STATES_APART of the step from every newer
/// one taken: states closer together than that carry Newton's error (up to
/// its tolerance) into the slope multiplied by the step over their spacing (a
/// state 1e-40 s after the one before, then a step of 0.5 s: 5e39). Returns
/// the order: the points used - 1 (0: no slope to judge a jump by; -1: none).
pub fn lagrange(t: f64, tt: &[f64; 3], h: &[f64], q: &mut [f64]) -> i32 {
    let n = q.len();
    let step = t - tt[2];
    q.fill(0.0);
    let mut near = [false; 3];
    for i in (0..3).rev() {
        near[i] = t - tt[i] <= 4.0 * step && (i + 1..3).all(|j| !near[j] || tt[j] - tt[i] > STATES_APART * step);
    }
    let mut used = 0;
    for i in 0..3 {
        if !near[i] {
            continue;
        }
        used += 1;
        let mut w = 1.0;
        for j in 0..3 {
            if j != i && near[j] {
                w *= (t - tt[j]) / (tt[i] - tt[j]);
            }
        }
        for c in 0..n {
            q[c] += w * h[i * n + c];
        }
    }
    used - 1
}

/// The Taylor predictor q + h qd + h^2/2 qdd.
pub fn taylor(q: &[f64], qd: &[f64], qdd: &[f64], h: f64, out: &mut [f64]) {
    let n = out.len();
    let (q, qd, qdd) = (&q[..n], &qd[..n], &qdd[..n]);
    for j in 0..n {
        out[j] = q[j] + h * qd[j] + 0.5 * h * h * qdd[j];
    }
}

/// The quintic Hermite extrapolation through (q, qd, qdd) at the last two
/// accepted instants: `p` (the earlier one, a before) and `c`, to h after
/// `c`: Taylor's q + h qd + h^2/2 qdd (`base`, as `taylor` computes it from
/// `c`; None: computed here) plus u^3 times the Hermite terms (u = h / a).
/// Its error is of order h^6 (1.3e-13 of the size on the slider-crank's 501
/// instants, Taylor's 1.4e-7): a start for the chord (crate::newton::chord),
/// not the acceptance test's predictor.
#[inline(always)]
pub fn hermite(p: [&[f64]; 3], c: [&[f64]; 3], a: f64, h: f64, base: Option<&[f64]>, out: &mut [f64]) {
    let (w, u3) = weights(a, h);
    let n = out.len();
    let (p, c) = ([&p[0][..n], &p[1][..n], &p[2][..n]], [&c[0][..n], &c[1][..n], &c[2][..n]]);
    let (p0, p1, p2, c0, c1, c2) = (p[0], p[1], p[2], c[0], c[1], c[2]);
    match base {
        Some(b) => {
            let b = &b[..n];
            for j in 0..n {
                let d = w[0] * (c0[j] - p0[j]) + w[1] * p1[j] + w[2] * c1[j] + w[3] * p2[j] + w[4] * c2[j];
                out[j] = b[j] + u3 * d;
            }
        }
        None => {
            for j in 0..n {
                let d = w[0] * (c0[j] - p0[j]) + w[1] * p1[j] + w[2] * c1[j] + w[3] * p2[j] + w[4] * c2[j];
                out[j] = c0[j] + h * c1[j] + 0.5 * h * h * c2[j] + u3 * d;
            }
        }
    }
}

/// Hermite's weights (`hermite`'s d = w0 (q - p0) + w1 p1 + w2 qd + w3 p2
/// + w4 qdd) and u^3, u = h / a.
#[inline(always)]
fn weights(a: f64, h: f64) -> ([f64; 5], f64) {
    let u = h / a;
    let (u3, aa) = (u * u * u, a * a);
    let w = [
        10.0 + 15.0 * u + 6.0 * u * u,
        -a * (4.0 + 7.0 * u + 3.0 * u * u),
        -a * (6.0 + 8.0 * u + 3.0 * u * u),
        -0.5 * aa * (1.0 + u) * (1.0 + u),
        0.5 * aa * (3.0 + 3.0 * u + u * u),
    ];
    (w, u3)
}

/// The march's predictors in one pass over the coordinates (step::step
/// where the chord starts from Hermite's extrapolation with Taylor's base):
/// Taylor's predictor into `qp` (`taylor`), the predicted motion (returned:
/// `gap(qp, q)`), Hermite's start into `start` (`hermite` with base `qp`),
/// and the chord's start into `room`: that start, plus the last start's
/// error (q - the last start, which `start` holds on entry) where `biased`
/// (step::biased_start). Each figure is those functions' to the bit (the
/// same operations per coordinate; the motion a maximum, whatever its
/// order). `c`: the last accepted state (q, qd, qdd), `p`: the one before,
/// `a` before it; `h`: the step from `c`. Every slice holds n = qp.len()
/// (sliced once here: the loop reads them without bounds checks).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn predicted(
    c: [&[f64]; 3],
    p: [&[f64]; 3],
    a: f64,
    h: f64,
    col_scale: &[f64],
    biased: bool,
    qp: &mut [f64],
    start: &mut [f64],
    room: &mut [f64],
) -> f64 {
    if biased {
        predicted_as::<true>(c, p, a, h, col_scale, qp, start, room)
    } else {
        predicted_as::<false>(c, p, a, h, col_scale, qp, start, room)
    }
}

/// `predicted`, biased or not (B), each its own loop.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn predicted_as<const B: bool>(
    c: [&[f64]; 3],
    p: [&[f64]; 3],
    a: f64,
    h: f64,
    col_scale: &[f64],
    qp: &mut [f64],
    start: &mut [f64],
    room: &mut [f64],
) -> f64 {
    let ([w0, w1, w2, w3, w4], u3) = weights(a, h);
    let n = qp.len();
    let ([q, qd, qdd], [p0, p1, p2]) = ([&c[0][..n], &c[1][..n], &c[2][..n]], [&p[0][..n], &p[1][..n], &p[2][..n]]);
    let (start, room) = (&mut start[..n], &mut room[..n]);
    for j in 0..n {
        // Taylor's b (as `taylor`), Hermite's s (as `hermite` from b), the chord's start
        let b = q[j] + h * qd[j] + 0.5 * h * h * qdd[j];
        qp[j] = b;
        let d = w0 * (q[j] - p0[j]) + w1 * p1[j] + w2 * qd[j] + w3 * p2[j] + w4 * qdd[j];
        let s = b + u3 * d;
        room[j] = if B { (q[j] - start[j]) + s } else { s };
        start[j] = s;
    }
    // the maximum in its own loop (`gap`'s pairs: a running maximum does not vectorise with the rest)
    gap(qp, q, col_scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lagrange_is_exact_on_a_parabola() {
        let f = |t: f64| 1.0 + 2.0 * t - 3.0 * t * t;
        let tt = [0.0, 0.1, 0.2];
        let h: Vec<f64> = tt.iter().map(|&t| f(t)).collect();
        let mut q = [0.0];
        assert_eq!(lagrange(0.3, &tt, &h, &mut q), 2);
        assert!((q[0] - f(0.3)).abs() < 1e-14);
        let none = [f64::NAN, f64::NAN, 0.2];
        assert_eq!(lagrange(0.3, &none, &h, &mut q), 0);
    }

    #[test]
    fn lagrange_skips_states_too_close_for_the_step() {
        // a state 1e-40 s after the one before, then a step of 0.5 s: the last state alone
        let h = [f64::NAN, 1.0, 1.0 + 1e-16];
        let mut q = [0.0];
        assert_eq!(lagrange(0.5, &[f64::NAN, 0.0, 1e-40], &h, &mut q), 0);
        assert_eq!(q[0], h[2]);
        // the middle state too close to the newest: the line through the oldest and the newest
        let f = |t: f64| 2.0 - 3.0 * t;
        let tt = [0.0, 0.1, 0.1 + 1e-10];
        let h: Vec<f64> = tt.iter().map(|&t| f(t)).collect();
        assert_eq!(lagrange(0.6, &tt, &h, &mut q), 1);
        assert!((q[0] - f(0.6)).abs() < 1e-13, "{}", q[0]);
        // evenly spaced states are all taken, as are a sub-step's 2^-20 of the step
        assert_eq!(lagrange(0.3, &[0.0, 0.1, 0.2], &[1.0, 1.0, 1.0], &mut q), 2);
        assert_eq!(lagrange(1.0, &[f64::NAN, 0.0, 2f64.powi(-20)], &[0.0, 1.0, 1.0], &mut q), 1);
    }

    #[test]
    fn hermite_is_exact_on_a_quintic() {
        let f = |t: f64| [1.0 - t + 2.0 * t.powi(3) - 0.5 * t.powi(5)];
        let d = |t: f64| [-1.0 + 6.0 * t * t - 2.5 * t.powi(4)];
        let dd = |t: f64| [12.0 * t - 10.0 * t.powi(3)];
        let (t0, t1, t) = (0.2, 0.5, 1.1);
        let mut q = [0.0];
        hermite([&f(t0), &d(t0), &dd(t0)], [&f(t1), &d(t1), &dd(t1)], t1 - t0, t - t1, None, &mut q);
        assert!((q[0] - f(t)[0]).abs() < 1e-12);
        // with Taylor's predictor given as the base: the same figure to the bit (tolerance 0)
        let mut base = [0.0];
        taylor(&f(t1), &d(t1), &dd(t1), t - t1, &mut base);
        let mut r = [0.0];
        hermite([&f(t0), &d(t0), &dd(t0)], [&f(t1), &d(t1), &dd(t1)], t1 - t0, t - t1, Some(&base), &mut r);
        assert_eq!(r[0].to_bits(), q[0].to_bits());
    }

    /// `predicted` gives `taylor`'s predictor, `gap`'s motion, `hermite`'s
    /// start (from Taylor's base) and the chord's start, biased (q minus the
    /// last start, plus the new one) or not, to the bit (tolerance 0), for
    /// odd and even n.
    #[test]
    fn one_pass_predictors_equal_the_separate_ones_to_the_bit() {
        for n in [1usize, 5, 12] {
            let v = |k: usize| -> Vec<f64> {
                (0..n).map(|j| ((k * 31 + j * 7) as f64 * 0.37).sin() * (1.0 + j as f64)).collect()
            };
            let (c, p, last, col) =
                ([v(1), v(2), v(3)], [v(4), v(5), v(6)], v(7), v(8).iter().map(|x| 0.5 + x.abs()).collect::<Vec<_>>());
            let (c, p) = ([&c[0][..], &c[1][..], &c[2][..]], [&p[0][..], &p[1][..], &p[2][..]]);
            let (a, h) = (0.013, 0.0127);
            for biased in [false, true] {
                let (mut qp, mut start, mut room) = (vec![0.0; n], last.clone(), vec![0.0; n]);
                let motion = predicted(c, p, a, h, &col, biased, &mut qp, &mut start, &mut room);
                let mut base = vec![0.0; n];
                taylor(c[0], c[1], c[2], h, &mut base);
                let mut s = vec![0.0; n];
                hermite(p, c, a, h, Some(&base), &mut s);
                let chord: Vec<f64> = (0..n).map(|j| if biased { (c[0][j] - last[j]) + s[j] } else { s[j] }).collect();
                let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&qp), bits(&base));
                assert_eq!(bits(&start), bits(&s));
                assert_eq!(bits(&room), bits(&chord));
                assert_eq!(motion.to_bits(), gap(&base, c[0], &col).to_bits());
                // the gap that keeps its first vector: the same figure, and the copy
                let mut kept = vec![f64::NAN; n];
                assert_eq!(gap_keep(&s, &base, &col, &mut kept).to_bits(), gap(&s, &base, &col).to_bits());
                assert_eq!(bits(&kept), bits(&s));
            }
        }
    }

    /// Coordinates at rest (q finite and not -0, qd and qdd +0 or -0, the
    /// state before the same there): `predicted` over a range that holds
    /// every other coordinate, with its buffers holding q at the rest ones,
    /// gives the whole run's figures to the bit (tolerance 0), biased or
    /// not; so does `gap_keep` (crate::march's `rest`).
    #[test]
    fn rest_coordinates_leave_the_predictors_as_they_were() {
        let n = 12;
        let rest = [0usize, 1, 2, 3, 4, 11];
        let v = |k: usize| -> Vec<f64> {
            (0..n).map(|j| ((k * 29 + j * 11) as f64 * 0.53).sin() * (1.0 + j as f64)).collect()
        };
        let (mut c, mut p) = ([v(1), v(2), v(3)], [v(4), v(5), v(6)]);
        let col: Vec<f64> = v(8).iter().map(|x| 0.5 + x.abs()).collect();
        for (i, &j) in rest.iter().enumerate() {
            let q = [0.0, 0.3, -1.7, 1e-300, 2.5e3, -0.0 + 0.0][i];
            (c[0][j], p[0][j]) = (q, q);
            let z = |k: usize| if (i + k).is_multiple_of(2) { 0.0 } else { -0.0 };
            (c[1][j], c[2][j], p[1][j], p[2][j]) = (z(0), z(1), z(2), z(3));
        }
        let (cs, ps) = ([&c[0][..], &c[1][..], &c[2][..]], [&p[0][..], &p[1][..], &p[2][..]]);
        let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for (a, h) in [(0.013, 0.0127), (1e-6, 2e-6), (3.0, 0.5)] {
            for biased in [false, true] {
                // the last start: the state's q at the rest coordinates (as any start from it left)
                let mut last = v(7);
                rest.iter().for_each(|&j| last[j] = c[0][j]);
                let (mut qp, mut start, mut room) = (vec![0.0; n], last.clone(), vec![0.0; n]);
                let motion = predicted(cs, ps, a, h, &col, biased, &mut qp, &mut start, &mut room);
                let (lo, hi) = (5, 11);
                let (mut qr, mut sr, mut rr) = (vec![f64::NAN; n], last.clone(), vec![f64::NAN; n]);
                rest.iter().for_each(|&j| (qr[j], rr[j]) = (c[0][j], c[0][j]));
                let (cr, pr) =
                    ([&c[0][lo..hi], &c[1][lo..hi], &c[2][lo..hi]], [&p[0][lo..hi], &p[1][lo..hi], &p[2][lo..hi]]);
                let m =
                    predicted(cr, pr, a, h, &col[lo..hi], biased, &mut qr[lo..hi], &mut sr[lo..hi], &mut rr[lo..hi]);
                assert_eq!(
                    (bits(&qr), bits(&sr), bits(&rr)),
                    (bits(&qp), bits(&start), bits(&room)),
                    "{a} {h} {biased}"
                );
                assert_eq!(m.to_bits(), motion.to_bits());
                // the settled q against the predictor, kept: over the range, the same figure and copy
                let mut settled = room.clone();
                (lo..hi).for_each(|j| settled[j] += 1e-9 * (j as f64));
                let (mut kept, mut kr) = (vec![0.0; n], vec![f64::NAN; n]);
                rest.iter().for_each(|&j| kr[j] = c[0][j]);
                let g = gap_keep(&settled, &qp, &col, &mut kept);
                let gr = gap_keep(&settled[lo..hi], &qp[lo..hi], &col[lo..hi], &mut kr[lo..hi]);
                assert_eq!((g.to_bits(), bits(&kept)), (gr.to_bits(), bits(&kr)));
            }
        }
    }

    #[test]
    fn the_test_rejects_each_way() {
        assert_eq!(rejected(1e-3, 0.0, 1, 1, 0.0, 0.0, true, 1e-5, 1e-12, false), Why::Accepted);
        assert_eq!(rejected(1e-7, 0.0, 1, 1, 0.0, 0.0, true, 1e-5, 1e-12, false), Why::NearSingular);
        assert_eq!(rejected(f64::NAN, 0.0, 1, 1, 0.0, 0.0, true, 1e-5, 1e-12, false), Why::NearSingular);
        assert_eq!(rejected(1e-3, 1e-7, 1, 1, 0.0, 0.0, true, 1e-5, 1e-12, false), Why::NearSingular);
        assert_eq!(rejected(1e-3, 0.0, -1, 1, 0.0, 0.0, true, 1e-5, 1e-12, false), Why::DetFlip);
        assert_eq!(rejected(1e-3, 0.0, -1, 1, 0.0, 0.0, true, 1e-5, 1e-12, true), Why::Accepted);
        assert_eq!(rejected(1e-3, 0.0, 1, 1, 1.0, 1.0, true, 1e-5, 1e-12, false), Why::Jump);
        assert_eq!(rejected(1e-3, 0.0, 1, 1, 1.0, 1.0, false, 1e-5, 1e-12, false), Why::Accepted);
    }
}
