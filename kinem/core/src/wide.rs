//! N independent numbers side by side (crate::lanes: N variants of one
//! mechanism, issue 31 item 5): `Wide<N>` is an f64 per lane, every
//! operation lane by lane (fixed-width arrays the compiler vectorises;
//! sin, cos and sqrt are f64's own, per lane), so that each lane's result
//! is the bit pattern the scalar computation gives. As a `Real` (crate::real)
//! it runs the families' kernels over N variants' tables at once.
//!
//! What `Real` asks that lanes cannot give sensibly: a single value (`re`,
//! lane 0: the kernels read it only for a piecewise function's breakpoints,
//! the same in every lane, and an outline's segment, which differs per lane:
//! models with outlines are not marched as lanes) and a tangent (none: 0).
//! `of_lanes(v, d)` takes the lanes' own values d (crate::model::Kin::new
//! through Table::real_s, a column's d_reals holding N values per entry).
use crate::real::Real;
use num_traits::{Num, One, Zero};
use std::ops::{Add, Div, Mul, Neg, Rem, Sub};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wide<const N: usize>(pub [f64; N]);

impl<const N: usize> Wide<N> {
    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        Wide(self.0.map(f))
    }
    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        let mut x = self.0;
        for (a, b) in x.iter_mut().zip(o.0) {
            *a = f(*a, b);
        }
        Wide(x)
    }
}

impl<const N: usize> Default for Wide<N> {
    fn default() -> Self {
        Wide([0.0; N])
    }
}

impl<const N: usize> Real for Wide<N> {
    const WIDTH: usize = N;
    /// v in every lane.
    #[inline(always)]
    fn lift(v: f64, _: f64) -> Self {
        Wide([v; N])
    }
    /// Lane 0 (see the module's note).
    #[inline(always)]
    fn re(self) -> f64 {
        self.0[0]
    }
    #[inline(always)]
    fn tangent(self) -> f64 {
        0.0
    }
    /// The lanes' values d (N of them).
    #[inline(always)]
    fn of_lanes(_: f64, d: &[f64]) -> Self {
        let mut x = [0.0; N];
        x.copy_from_slice(&d[..N]);
        Wide(x)
    }
    #[inline(always)]
    fn sin(self) -> Self {
        self.map(f64::sin)
    }
    #[inline(always)]
    fn cos(self) -> Self {
        self.map(f64::cos)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }
}

macro_rules! lanewise {
    ($($tr:ident $f:ident $op:tt),*) => {$(
        impl<const N: usize> $tr for Wide<N> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                self.zip(o, |a, b| a $op b)
            }
        }
        impl<const N: usize> $tr<f64> for Wide<N> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: f64) -> Self {
                self.map(|a| a $op o)
            }
        }
    )*};
}
lanewise!(Add add +, Sub sub -, Mul mul *, Div div /, Rem rem %);

impl<const N: usize> Neg for Wide<N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|a| -a)
    }
}
impl<const N: usize> Zero for Wide<N> {
    fn zero() -> Self {
        Wide([0.0; N])
    }
    fn is_zero(&self) -> bool {
        self.0.iter().all(|&x| x == 0.0)
    }
}
impl<const N: usize> One for Wide<N> {
    fn one() -> Self {
        Wide([1.0; N])
    }
}
impl<const N: usize> Num for Wide<N> {
    type FromStrRadixErr = <f64 as Num>::FromStrRadixErr;
    fn from_str_radix(s: &str, radix: u32) -> Result<Self, Self::FromStrRadixErr> {
        Ok(Self::c(f64::from_str_radix(s, radix)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::real::cis;
    use num_complex::Complex;

    /// Every operation over S, of x and y (complex ones too).
    fn ops<S: Real>(x: S, y: S) -> [S; 12] {
        let z = Complex::new(x, y) * cis(y) / Complex::new(y, S::one());
        [
            x + y,
            x - y * 2.0,
            x * y + 1.0,
            x / y - 0.5,
            x % y,
            -x.sin() * x.cos(),
            (x * x + y * y).sqrt(),
            S::c(3.0) * x - S::one() + S::zero(),
            z.re,
            z.im,
            z.norm_sqr(),
            (z * z.conj()).re,
        ]
    }

    /// Each lane is, to the bit, the scalar computation on that lane's numbers.
    #[test]
    fn each_lane_is_the_scalar() {
        let xs = [0.7, -1.3, 12.5, 1e-9, -3.0, 2.0, 0.0, 5.5];
        let ys = [-1.3, 0.25, 3.0, -1.0, 7.0, 1e3, 0.4, -0.01];
        let wide = ops(Wide(xs), Wide(ys));
        for k in 0..8 {
            for (w, s) in wide.iter().zip(ops(xs[k], ys[k])) {
                assert_eq!(w.0[k].to_bits(), s.to_bits(), "lane {k}: {} {s}", w.0[k]);
            }
        }
        assert_eq!(Wide::<4>::of_lanes(9.0, &[1.0, 2.0, 3.0, 4.0]).0, [1.0, 2.0, 3.0, 4.0]);
        assert_eq!(Wide::<4>::c(2.5).0, [2.5; 4]);
    }
}
