//! Closed intervals and interval jets: the arithmetic behind every bound of the field engine.
//!
//! Theory: an [`Interval`] encloses a set of reals; every operation returns an interval that
//! contains every result of the operation on members of its inputs (an *inclusion function*,
//! forward-inclusion paper §4.1). Endpoints may be infinite: an unbounded interval is a valid,
//! if useless, enclosure, and is what an operation returns where its formula breaks down
//! (division by an interval containing 0, the square root's derivative at 0) — the validity
//! intervals of §4.2 are the methods' business, not the arithmetic's.
//!
//! Practice: a [`Jet`] carries enclosures of a function of the ray parameter `t` and of its
//! first and second derivatives over one ray interval `[t0, t1]`. Primitives build jets from
//! exact pieces ([`Jet::affine`], [`Jet::quadratic`]) and combine them with the rules of
//! forward differentiation; the blend tree composes them. Rounding is not directed: bounds
//! are exact up to a few ulps, which the tests absorb in a relative tolerance.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A closed interval `[lo, hi]` of reals, possibly unbounded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// Lower end point (may be `-inf`).
    pub lo: f64,
    /// Upper end point (may be `+inf`).
    pub hi: f64,
}

impl Interval {
    /// `[0, 0]`.
    pub const ZERO: Self = Self { lo: 0.0, hi: 0.0 };
    /// `[-inf, +inf]`: the enclosure that says nothing.
    pub const ENTIRE: Self = Self {
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };

    /// The interval between two values, in either order.
    #[must_use]
    pub fn new(a: f64, b: f64) -> Self {
        if a <= b {
            Self { lo: a, hi: b }
        } else {
            Self { lo: b, hi: a }
        }
    }

    /// The degenerate interval `[v, v]`.
    #[must_use]
    pub const fn point(v: f64) -> Self {
        Self { lo: v, hi: v }
    }

    /// Smallest interval containing both.
    #[must_use]
    pub fn hull(self, other: Self) -> Self {
        Self {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
        }
    }

    /// Smallest interval containing `self` and the value `v`.
    #[must_use]
    pub fn include(self, v: f64) -> Self {
        Self {
            lo: self.lo.min(v),
            hi: self.hi.max(v),
        }
    }

    /// Intersection; `None` when the intervals are disjoint.
    #[must_use]
    pub fn intersect(self, other: Self) -> Option<Self> {
        let lo = self.lo.max(other.lo);
        let hi = self.hi.min(other.hi);
        (lo <= hi).then_some(Self { lo, hi })
    }

    /// `true` when `v` lies in the interval.
    #[must_use]
    pub fn contains(self, v: f64) -> bool {
        self.lo <= v && v <= self.hi
    }

    /// `hi - lo`.
    #[must_use]
    pub fn width(self) -> f64 {
        self.hi - self.lo
    }

    /// Largest absolute value of a member: the local Lipschitz constant when the interval
    /// encloses a derivative.
    #[must_use]
    pub fn magnitude(self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }

    /// Exact enclosure of `x²` for `x` in the interval (no dependency loss).
    #[must_use]
    pub fn square(self) -> Self {
        if self.lo >= 0.0 {
            Self::new(self.lo * self.lo, self.hi * self.hi)
        } else if self.hi <= 0.0 {
            Self::new(self.hi * self.hi, self.lo * self.lo)
        } else {
            Self {
                lo: 0.0,
                hi: (self.lo * self.lo).max(self.hi * self.hi),
            }
        }
    }

    /// Enclosure of `1 / x`; unbounded when the interval contains 0.
    #[must_use]
    pub fn recip(self) -> Self {
        if self.lo > 0.0 || self.hi < 0.0 {
            Self::new(1.0 / self.lo, 1.0 / self.hi)
        } else {
            Self::ENTIRE
        }
    }

    /// Enclosure of `√x` over the non-negative part of the interval.
    #[must_use]
    pub fn sqrt(self) -> Self {
        Self {
            lo: self.lo.max(0.0).sqrt(),
            hi: self.hi.max(0.0).sqrt(),
        }
    }

    /// Enclosure of `x^q` over the non-negative part of the interval (`0^q = ∞` for `q < 0`).
    #[must_use]
    pub fn powf(self, q: f64) -> Self {
        let (lo, hi) = (self.lo.max(0.0), self.hi.max(0.0));
        if q >= 0.0 {
            Self::new(lo.powf(q), hi.powf(q))
        } else {
            Self::new(hi.powf(q), lo.powf(q))
        }
    }

    /// Scales by a real number.
    #[must_use]
    #[inline]
    pub fn scale(self, k: f64) -> Self {
        let (lo, hi) = (mul_ends(self.lo, k), mul_ends(self.hi, k));
        // A positive factor keeps the order (rounding is monotone); the SCALIS bounds scale by
        // positive constants in their innermost loop.
        if k > 0.0 {
            Self { lo, hi }
        } else {
            Self::new(lo, hi)
        }
    }

    /// `self · o` for `o` of positive members only (`o.lo > 0`): the end points of `*` (equal
    /// numbers; where both are zeros their signs may differ), since the order of the products
    /// is known (the larger factor of `self` gives the larger products), with two products and
    /// comparisons fewer. For the hot loops of the SCALIS bounds, where `o` is a power of `1/τ`.
    #[must_use]
    #[inline]
    pub fn times_positive(self, o: Self) -> Self {
        debug_assert!(o.lo > 0.0, "{o:?}");
        // Rounding is monotone: `a·o.lo ≤ a·o.hi` for `a ≥ 0`, the reverse for `a < 0`.
        Self {
            lo: mul_ends(self.lo, if self.lo >= 0.0 { o.lo } else { o.hi }),
            hi: mul_ends(self.hi, if self.hi >= 0.0 { o.hi } else { o.lo }),
        }
    }
}

/// Product of two end points with the interval convention `0 · ∞ = 0`.
#[inline]
fn mul_ends(a: f64, b: f64) -> f64 {
    // Both tests and the product evaluated, then one selected: no branch in the interval
    // products' inner loops (the SCALIS bounds take millions per frame).
    let product = a * b;
    let zero = (a == 0.0) | (b == 0.0);
    if zero { 0.0 } else { product }
}

impl Add for Interval {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            lo: self.lo + o.lo,
            hi: self.hi + o.hi,
        }
    }
}

impl Sub for Interval {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self {
            lo: self.lo - o.hi,
            hi: self.hi - o.lo,
        }
    }
}

impl Neg for Interval {
    type Output = Self;
    fn neg(self) -> Self {
        Self {
            lo: -self.hi,
            hi: -self.lo,
        }
    }
}

impl Mul for Interval {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        // Both non-negative (the kernel's `K″` times a square in the SCALIS bounds): the
        // products are ordered, rounding being monotone, and the ends are two of them.
        if self.lo >= 0.0 && o.lo >= 0.0 {
            return Self {
                lo: mul_ends(self.lo, o.lo),
                hi: mul_ends(self.hi, o.hi),
            };
        }
        let p = [
            mul_ends(self.lo, o.lo),
            mul_ends(self.lo, o.hi),
            mul_ends(self.hi, o.lo),
            mul_ends(self.hi, o.hi),
        ];
        Self {
            lo: p.iter().copied().fold(f64::INFINITY, f64::min),
            hi: p.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

/// Enclosures of a function of the ray parameter and of its first two derivatives over one
/// ray interval: `value ∋ f(t)`, `d1 ∋ f′(t)`, `d2 ∋ f″(t)` for every `t` in the interval.
///
/// `d2` is meant in the sense the marching methods use it: for every `a, b` in the interval,
/// `f(b) − f(a) − f′(a)(b − a)` lies in `½·d2·(b − a)²`. Where `f′` jumps (a kink of a clipped
/// kernel, a max blend) the side of `d2` that the jump would violate is infinite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jet {
    /// Enclosure of the value.
    pub value: Interval,
    /// Enclosure of the first derivative.
    pub d1: Interval,
    /// Enclosure of the second derivative.
    pub d2: Interval,
}

impl Jet {
    /// The identically zero function.
    pub const ZERO: Self = Self {
        value: Interval::ZERO,
        d1: Interval::ZERO,
        d2: Interval::ZERO,
    };

    /// A constant function.
    #[must_use]
    pub fn constant(c: f64) -> Self {
        Self {
            value: Interval::point(c),
            ..Self::ZERO
        }
    }

    /// Exact jet of `a + b·t` over `t ∈ span`.
    #[must_use]
    pub fn affine(a: f64, b: f64, span: Interval) -> Self {
        Self {
            value: Interval::new(a + b * span.lo, a + b * span.hi),
            d1: Interval::point(b),
            d2: Interval::ZERO,
        }
    }

    /// Exact jet of `a·t² + b·t + c` over `t ∈ span`.
    #[must_use]
    pub fn quadratic(a: f64, b: f64, c: f64, span: Interval) -> Self {
        let eval = |t: f64| (a * t + b) * t + c;
        let mut value = Interval::new(eval(span.lo), eval(span.hi));
        if a != 0.0 {
            let apex = -b / (2.0 * a);
            if span.contains(apex) {
                value = value.include(eval(apex));
            }
        }
        Self {
            value,
            d1: Interval::new(2.0 * a * span.lo + b, 2.0 * a * span.hi + b),
            d2: Interval::point(2.0 * a),
        }
    }

    /// Smallest jet containing both (used where a function is one of several formulas on
    /// parts of the interval).
    #[must_use]
    pub fn hull(self, o: Self) -> Self {
        Self {
            value: self.value.hull(o.value),
            d1: self.d1.hull(o.d1),
            d2: self.d2.hull(o.d2),
        }
    }

    /// Multiplies by a real constant.
    #[must_use]
    pub fn scale(self, k: f64) -> Self {
        Self {
            value: self.value.scale(k),
            d1: self.d1.scale(k),
            d2: self.d2.scale(k),
        }
    }

    /// Jet of `f²`, exact in the value.
    #[must_use]
    pub fn square(self) -> Self {
        Self {
            value: self.value.square(),
            d1: (self.value * self.d1).scale(2.0),
            d2: (self.d1.square() + self.value * self.d2).scale(2.0),
        }
    }

    /// Jet of `1/f`.
    #[must_use]
    pub fn recip(self) -> Self {
        let r = self.value.recip();
        let r2 = r.square();
        // (1/f)' = −f′/f², (1/f)″ = (2f′² − f f″)/f³ = 2f′²·r³ − f″·r².
        Self {
            value: r,
            d1: -(self.d1 * r2),
            d2: (self.d1.square().scale(2.0) * r2 * r) - self.d2 * r2,
        }
    }

    /// Jet of `√f` (on the non-negative part of `f`).
    #[must_use]
    pub fn sqrt(self) -> Self {
        let r = self.value.sqrt();
        let half_inv = Interval::new(0.5, 0.5) * r.recip();
        let d1 = self.d1 * half_inv;
        // r″ = (f″ − 2r′²)/(2r).
        let d2 = (self.d2 - d1.square().scale(2.0)) * half_inv;
        Self { value: r, d1, d2 }
    }

    /// Jet of `√f` valid where `√f ≥ floor > 0`: `f` is clamped below at `floor²`. Use it only
    /// where the result feeds `max(√f − floor′, 0)` with `floor′ ≥ floor`, which is 0 wherever the
    /// clamp changed anything, so the enclosure stays valid and the derivative stays finite.
    #[must_use]
    pub fn sqrt_above(self, floor: f64) -> Self {
        let f2 = floor * floor;
        Self {
            value: Interval {
                lo: self.value.lo.max(f2),
                hi: self.value.hi.max(f2),
            },
            ..self
        }
        .sqrt()
    }

    /// Jet of `f^q` for `f ≥ 0`.
    #[must_use]
    pub fn powf(self, q: f64) -> Self {
        let v1 = self.value.powf(q - 1.0).scale(q);
        let v2 = self.value.powf(q - 2.0).scale(q * (q - 1.0));
        Self {
            value: self.value.powf(q),
            d1: v1 * self.d1,
            d2: v2 * self.d1.square() + v1 * self.d2,
        }
    }

    /// Jet of `max(f, g)`: where neither dominates on the whole interval, `f″` may jump
    /// upwards at the switch, so the upper second-derivative bound is infinite.
    #[must_use]
    pub fn max(self, g: Self) -> Self {
        if self.value.lo >= g.value.hi {
            self
        } else if g.value.lo >= self.value.hi {
            g
        } else {
            Self {
                value: Interval {
                    lo: self.value.lo.max(g.value.lo),
                    hi: self.value.hi.max(g.value.hi),
                },
                d1: self.d1.hull(g.d1),
                d2: Interval {
                    lo: self.d2.lo.min(g.d2.lo),
                    hi: f64::INFINITY,
                },
            }
        }
    }

    /// Jet of `min(f, g)` (the lower second-derivative bound is infinite at a switch).
    #[must_use]
    pub fn min(self, g: Self) -> Self {
        -((-self).max(-g))
    }

    /// Jet of `max(f, 0)²`, a C¹ function of `f` (distance to a solid, squared).
    #[must_use]
    pub fn positive_part_squared(self) -> Self {
        // `lo == 0` may come from a clamp (see `sqrt_above`): treat it as straddling 0.
        if self.value.lo > 0.0 {
            self.square()
        } else if self.value.hi <= 0.0 {
            Self::ZERO
        } else {
            let pos = Interval {
                lo: 0.0,
                hi: self.value.hi,
            };
            Self {
                value: pos.square(),
                d1: (pos * self.d1).scale(2.0).include(0.0),
                d2: (self.d1.square() + pos * self.d2).scale(2.0).include(0.0),
            }
        }
    }
}

impl Add for Jet {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            value: self.value + o.value,
            d1: self.d1 + o.d1,
            d2: self.d2 + o.d2,
        }
    }
}

impl Sub for Jet {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self {
            value: self.value - o.value,
            d1: self.d1 - o.d1,
            d2: self.d2 - o.d2,
        }
    }
}

/// Jet of `f/g`, as `f · (1/g)`.
impl Div for Jet {
    type Output = Self;
    #[expect(
        clippy::suspicious_arithmetic_impl,
        reason = "a quotient of jets is the product with the reciprocal jet"
    )]
    fn div(self, g: Self) -> Self {
        self * g.recip()
    }
}

impl Neg for Jet {
    type Output = Self;
    fn neg(self) -> Self {
        Self {
            value: -self.value,
            d1: -self.d1,
            d2: -self.d2,
        }
    }
}

impl Mul for Jet {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        Self {
            value: self.value * o.value,
            d1: self.d1 * o.value + self.value * o.d1,
            d2: self.d2 * o.value + (self.d1 * o.d1).scale(2.0) + self.value * o.d2,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn multiplication_treats_zero_times_infinity_as_zero() {
        let z = Interval::ZERO * Interval::ENTIRE;
        assert_eq!(z, Interval::ZERO);
    }

    /// The product of two non-negative intervals, which takes two end products, is the hull of
    /// all four, bit for bit, zero and infinite end points included.
    #[test]
    fn product_of_non_negative_intervals_is_the_four_products_hull() {
        let mut rng = crate::model::rng::SplitMix64::new(29);
        let end = |rng: &mut crate::model::rng::SplitMix64| match rng.below(8) {
            0 => 0.0,
            1 => f64::INFINITY,
            _ => rng.range(0.0, 1.0) * 10f64.powf(rng.range(-300.0, 300.0)),
        };
        for _ in 0..100_000 {
            let a = Interval::new(end(&mut rng), end(&mut rng));
            let b = Interval::new(end(&mut rng), end(&mut rng));
            let p = [
                mul_ends(a.lo, b.lo),
                mul_ends(a.lo, b.hi),
                mul_ends(a.hi, b.lo),
                mul_ends(a.hi, b.hi),
            ];
            let hull = Interval {
                lo: p.iter().copied().fold(f64::INFINITY, f64::min),
                hi: p.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            };
            let fast = a * b;
            assert!(
                fast.lo.to_bits() == hull.lo.to_bits() && fast.hi.to_bits() == hull.hi.to_bits(),
                "{a:?} · {b:?}: {fast:?} vs {hull:?}"
            );
        }
    }

    /// `times_positive` gives the end points of `*`, on intervals of every sign (zero and
    /// infinite end points included) times positive ones: bit for bit, except the sign of a
    /// zero where the products underflow (`==` holds; the march fingerprints are unchanged).
    #[test]
    fn product_with_a_positive_interval_is_the_general_product() {
        let mut rng = crate::model::rng::SplitMix64::new(17);
        let end = |rng: &mut crate::model::rng::SplitMix64| match rng.below(8) {
            0 => 0.0,
            1 => f64::INFINITY,
            2 => f64::NEG_INFINITY,
            _ => rng.range(-1.0, 1.0) * 10f64.powf(rng.range(-300.0, 300.0)),
        };
        for _ in 0..100_000 {
            let a = Interval::new(end(&mut rng), end(&mut rng));
            let lo = rng.range(0.0, 1.0) * 10f64.powf(rng.range(-300.0, 300.0));
            let hi = if rng.below(8) == 0 {
                f64::INFINITY
            } else {
                lo * rng.range(1.0, 10.0)
            };
            if lo <= 0.0 {
                continue;
            }
            let b = Interval::new(lo, hi);
            let (fast, general) = (a.times_positive(b), a * b);
            assert!(
                fast == general
                    && [(fast.lo, general.lo), (fast.hi, general.hi)]
                        .iter()
                        .all(|(f, g)| *f == 0.0 || f.to_bits() == g.to_bits()),
                "{a:?} · {b:?}: {fast:?} vs {general:?}"
            );
        }
    }

    #[test]
    fn quadratic_jet_encloses_its_apex() {
        let j = Jet::quadratic(1.0, -2.0, 3.0, Interval::new(0.0, 3.0));
        assert_eq!(j.value, Interval::new(2.0, 6.0));
        assert_eq!(j.d1, Interval::new(-2.0, 4.0));
    }

    #[test]
    fn jet_rules_enclose_sampled_derivatives() {
        // f(t) = sqrt(1 + t²) / (2 + t) on [0.5, 1.5], compared with sampled values.
        let span = Interval::new(0.5, 1.5);
        let f = Jet::quadratic(1.0, 0.0, 1.0, span).sqrt() / Jet::affine(2.0, 1.0, span);
        for i in 0..=100 {
            let t = 0.5 + f64::from(i) / 100.0;
            let g = |t: f64| (1.0 + t * t).sqrt() / (2.0 + t);
            let h = 1e-4;
            let d1 = (g(t + h) - g(t - h)) / (2.0 * h);
            let d2 = (g(t + h) - 2.0 * g(t) + g(t - h)) / (h * h);
            assert!(f.value.contains(g(t)));
            assert!(f.d1.contains(d1));
            assert!(f.d2.lo - 1e-6 <= d2 && d2 <= f.d2.hi + 1e-6);
        }
    }
}
