//! The scalar the families' kernels are written over: f64 for the analysis,
//! and `Dual` (forward-mode dual numbers v + d eps, eps^2 = 0) for design
//! sensitivities (crate::sensitivity). One kernel evaluates values and, with
//! Dual, their exact directional derivatives: the tangents of the tables (a
//! design parameter's seed) and of q, qd (dq/dp, dqd/dp) carry through
//! every operation by the chain rule. `Lanes<N>` carries N tangents at
//! once (N parameters' directions, the value computed once). A planar
//! vector is num_complex's Complex<S>, as C64 = Complex<f64> is.
use num_complex::Complex;
use num_traits::{Num, One, Zero};
use std::ops::{Add, Div, Mul, Neg, Rem, Sub};

pub trait Real:
    Copy
    + Default
    + Num
    + Neg<Output = Self>
    + Mul<f64, Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Send
    + Sync
{
    /// v + d eps (f64: v, the tangent dropped).
    fn lift(v: f64, d: f64) -> Self;
    /// The value part.
    fn re(self) -> f64;
    /// The tangent part (f64: 0).
    fn tangent(self) -> f64;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn sqrt(self) -> Self;
    #[inline(always)]
    fn c(v: f64) -> Self {
        Self::lift(v, 0.0)
    }
    /// How many tangents it carries (Lanes<N>: N; f64 drops its one).
    const WIDTH: usize = 1;
    /// v with the tangents d (WIDTH of them).
    #[inline(always)]
    fn of_lanes(v: f64, d: &[f64]) -> Self {
        Self::lift(v, d.first().copied().unwrap_or(0.0))
    }
    /// The value v, every tangent kept (a constant shift).
    #[inline(always)]
    fn with_value(self, v: f64) -> Self {
        Self::lift(v, self.tangent())
    }
}

impl Real for f64 {
    #[inline(always)]
    fn lift(v: f64, _: f64) -> f64 {
        v
    }
    #[inline(always)]
    fn re(self) -> f64 {
        self
    }
    #[inline(always)]
    fn tangent(self) -> f64 {
        0.0
    }
    #[inline(always)]
    fn sin(self) -> f64 {
        f64::sin(self)
    }
    #[inline(always)]
    fn cos(self) -> f64 {
        f64::cos(self)
    }
    #[inline(always)]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
}

/// i = sqrt(-1) as a planar vector of S.
#[inline(always)]
pub fn i<S: Real>() -> Complex<S> {
    Complex::new(S::zero(), S::one())
}

/// e^{i x}.
#[inline(always)]
pub fn cis<S: Real>(x: S) -> Complex<S> {
    Complex::new(x.cos(), x.sin())
}

/// A complex of S from a C64 value and a C64 tangent.
#[inline(always)]
pub fn lift_c<S: Real>(v: Complex<f64>, d: Complex<f64>) -> Complex<S> {
    Complex::new(S::lift(v.re, d.re), S::lift(v.im, d.im))
}

/// v + d eps: a value and its derivative along one direction.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Dual {
    pub v: f64,
    pub d: f64,
}

impl Real for Dual {
    #[inline(always)]
    fn lift(v: f64, d: f64) -> Dual {
        Dual { v, d }
    }
    #[inline(always)]
    fn re(self) -> f64 {
        self.v
    }
    #[inline(always)]
    fn tangent(self) -> f64 {
        self.d
    }
    #[inline(always)]
    fn sin(self) -> Dual {
        Dual { v: self.v.sin(), d: self.d * self.v.cos() }
    }
    #[inline(always)]
    fn cos(self) -> Dual {
        Dual { v: self.v.cos(), d: -self.d * self.v.sin() }
    }
    #[inline(always)]
    fn sqrt(self) -> Dual {
        let r = self.v.sqrt();
        Dual { v: r, d: self.d / (2.0 * r) }
    }
}

impl Add for Dual {
    type Output = Dual;
    #[inline(always)]
    fn add(self, o: Dual) -> Dual {
        Dual { v: self.v + o.v, d: self.d + o.d }
    }
}
impl Sub for Dual {
    type Output = Dual;
    #[inline(always)]
    fn sub(self, o: Dual) -> Dual {
        Dual { v: self.v - o.v, d: self.d - o.d }
    }
}
impl Mul for Dual {
    type Output = Dual;
    #[inline(always)]
    fn mul(self, o: Dual) -> Dual {
        Dual { v: self.v * o.v, d: self.d * o.v + self.v * o.d }
    }
}
impl Div for Dual {
    type Output = Dual;
    #[inline(always)]
    fn div(self, o: Dual) -> Dual {
        Dual { v: self.v / o.v, d: (self.d * o.v - self.v * o.d) / (o.v * o.v) }
    }
}
impl Rem for Dual {
    type Output = Dual;
    /// x mod y = x - y trunc(x / y): the truncation is locally constant.
    #[inline(always)]
    fn rem(self, o: Dual) -> Dual {
        let k = (self.v / o.v).trunc();
        Dual { v: self.v % o.v, d: self.d - k * o.d }
    }
}
impl Neg for Dual {
    type Output = Dual;
    #[inline(always)]
    fn neg(self) -> Dual {
        Dual { v: -self.v, d: -self.d }
    }
}
impl Mul<f64> for Dual {
    type Output = Dual;
    #[inline(always)]
    fn mul(self, o: f64) -> Dual {
        Dual { v: self.v * o, d: self.d * o }
    }
}
impl Add<f64> for Dual {
    type Output = Dual;
    #[inline(always)]
    fn add(self, o: f64) -> Dual {
        Dual { v: self.v + o, d: self.d }
    }
}
impl Sub<f64> for Dual {
    type Output = Dual;
    #[inline(always)]
    fn sub(self, o: f64) -> Dual {
        Dual { v: self.v - o, d: self.d }
    }
}
impl Zero for Dual {
    fn zero() -> Dual {
        Dual { v: 0.0, d: 0.0 }
    }
    fn is_zero(&self) -> bool {
        self.v == 0.0 && self.d == 0.0
    }
}
impl One for Dual {
    fn one() -> Dual {
        Dual { v: 1.0, d: 0.0 }
    }
}
impl Num for Dual {
    type FromStrRadixErr = <f64 as Num>::FromStrRadixErr;
    fn from_str_radix(s: &str, radix: u32) -> Result<Dual, Self::FromStrRadixErr> {
        Ok(Dual::c(f64::from_str_radix(s, radix)?))
    }
}

/// v + sum_k d[k] eps_k (eps_j eps_k = 0): a value and its derivatives
/// along N directions at once (N design parameters: crate::sensitivity),
/// the value's own work (a sine, a square root) done once for all N.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lanes<const N: usize> {
    pub v: f64,
    pub d: [f64; N],
}

impl<const N: usize> Lanes<N> {
    /// v with the tangents d.
    #[inline(always)]
    pub fn of(v: f64, d: [f64; N]) -> Self {
        Lanes { v, d }
    }
    #[inline(always)]
    fn map(self, f: f64) -> Self {
        Lanes { v: 0.0, d: self.d.map(|x| x * f) }
    }
    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(f64, f64) -> f64) -> [f64; N] {
        let mut d = self.d;
        for (x, y) in d.iter_mut().zip(o.d) {
            *x = f(*x, y);
        }
        d
    }
}

impl<const N: usize> Default for Lanes<N> {
    fn default() -> Self {
        Lanes { v: 0.0, d: [0.0; N] }
    }
}

impl<const N: usize> Real for Lanes<N> {
    const WIDTH: usize = N;
    #[inline(always)]
    fn of_lanes(v: f64, d: &[f64]) -> Self {
        let mut x = [0.0; N];
        x.copy_from_slice(&d[..N]);
        Lanes { v, d: x }
    }
    /// v with every tangent d.
    #[inline(always)]
    fn lift(v: f64, d: f64) -> Self {
        Lanes { v, d: [d; N] }
    }
    #[inline(always)]
    fn re(self) -> f64 {
        self.v
    }
    /// The first tangent.
    #[inline(always)]
    fn tangent(self) -> f64 {
        self.d.first().copied().unwrap_or(0.0)
    }
    #[inline(always)]
    fn with_value(self, v: f64) -> Self {
        Lanes { v, d: self.d }
    }
    #[inline(always)]
    fn sin(self) -> Self {
        let (s, c) = self.v.sin_cos();
        Lanes { v: s, d: self.map(c).d }
    }
    #[inline(always)]
    fn cos(self) -> Self {
        let (s, c) = self.v.sin_cos();
        Lanes { v: c, d: self.map(-s).d }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        Lanes { v: r, d: self.map(0.5 / r).d }
    }
}

impl<const N: usize> Add for Lanes<N> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Lanes { v: self.v + o.v, d: self.zip(o, |a, b| a + b) }
    }
}
impl<const N: usize> Sub for Lanes<N> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Lanes { v: self.v - o.v, d: self.zip(o, |a, b| a - b) }
    }
}
#[allow(clippy::suspicious_arithmetic_impl)]
impl<const N: usize> Mul for Lanes<N> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        let (a, b) = (self.v, o.v);
        Lanes { v: a * b, d: self.zip(o, |x, y| x * b + a * y) }
    }
}
#[allow(clippy::suspicious_arithmetic_impl)]
impl<const N: usize> Div for Lanes<N> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        let (a, b) = (self.v, o.v);
        Lanes { v: a / b, d: self.zip(o, |x, y| (x * b - a * y) / (b * b)) }
    }
}
#[allow(clippy::suspicious_arithmetic_impl)]
impl<const N: usize> Rem for Lanes<N> {
    type Output = Self;
    /// x mod y = x - y trunc(x / y): the truncation is locally constant.
    #[inline(always)]
    fn rem(self, o: Self) -> Self {
        let k = (self.v / o.v).trunc();
        Lanes { v: self.v % o.v, d: self.zip(o, |x, y| x - k * y) }
    }
}
impl<const N: usize> Neg for Lanes<N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Lanes { v: -self.v, d: self.d.map(|x| -x) }
    }
}
impl<const N: usize> Mul<f64> for Lanes<N> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: f64) -> Self {
        Lanes { v: self.v * o, d: self.map(o).d }
    }
}
impl<const N: usize> Add<f64> for Lanes<N> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: f64) -> Self {
        Lanes { v: self.v + o, d: self.d }
    }
}
impl<const N: usize> Sub<f64> for Lanes<N> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: f64) -> Self {
        Lanes { v: self.v - o, d: self.d }
    }
}
impl<const N: usize> Zero for Lanes<N> {
    fn zero() -> Self {
        Self::default()
    }
    fn is_zero(&self) -> bool {
        self.v == 0.0 && self.d.iter().all(|&x| x == 0.0)
    }
}
impl<const N: usize> One for Lanes<N> {
    fn one() -> Self {
        Lanes { v: 1.0, d: [0.0; N] }
    }
}
impl<const N: usize> Num for Lanes<N> {
    type FromStrRadixErr = <f64 as Num>::FromStrRadixErr;
    fn from_str_radix(s: &str, radix: u32) -> Result<Self, Self::FromStrRadixErr> {
        Ok(Self::c(f64::from_str_radix(s, radix)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every operation over S, of x and y.
    fn ops<S: Real>(x: S, y: S) -> [S; 8] {
        [
            x + y,
            x - y * 2.0,
            x * y + 1.0,
            x / y - 0.5,
            x % y,
            -x.sin() * x.cos(),
            (x * x + y * y).sqrt(),
            x.with_value(2.0) * y,
        ]
    }

    /// Every operation of Lanes<3> gives, lane by lane, Dual's tangent.
    #[test]
    fn lanes_are_duals_side_by_side() {
        let (a, b) = (Lanes::of(0.7, [1.0, -2.0, 0.5]), Lanes::of(-1.3, [0.25, 3.0, -1.0]));
        let dual = |x: Lanes<3>, k: usize| Dual { v: x.v, d: x.d[k] };
        let lanes = ops(a, b);
        for k in 0..3 {
            for (r, d) in lanes.iter().zip(ops(dual(a, k), dual(b, k))) {
                assert!(
                    (r.v - d.v).abs() <= 1e-15 * d.v.abs().max(1.0)
                        && (r.d[k] - d.d).abs() <= 1e-15 * d.d.abs().max(1.0)
                );
            }
        }
    }
}
