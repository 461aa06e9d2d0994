//! Blend operators over group fields (scalis 2021 eq. 1 and the blob-tree composition; numerical
//! ray tracing notes 2014 §7): sum, max (sharp union), min (intersection), difference
//! `min(f₁, 2c − f₂)` (the complement of a density field about the isovalue), and the Ricci
//! p-blend `(Σ max(fᵢ, 0)^p)^(1/p)`, and the smooth union / intersection built from the 2014
//! notes' polynomial smooth minimum (§11.6). Each operator evaluates values with gradients and
//! composes ray-interval jets.
//!
//! [`BlendTree`] is the compiled tree the field and the bounds read: the scene's `Blend` (model
//! data) is turned into it once, when the scene is compiled, so that nothing below the model
//! depends on the file format.

use glam::DVec3;

use crate::bounds::interval::{Interval, Jet};
use crate::model::scene::Blend;

/// The blend tree of a compiled scene: operators over group indices.
#[derive(Clone, Debug, PartialEq)]
pub enum BlendTree {
    /// The field of one group.
    Group(u32),
    /// Sum.
    Sum(Vec<BlendTree>),
    /// Maximum (sharp union).
    Max(Vec<BlendTree>),
    /// Minimum (intersection).
    Min(Vec<BlendTree>),
    /// `min(f₁, 2c − f₂)`.
    Difference(Box<BlendTree>, Box<BlendTree>),
    /// Ricci p-blend.
    Ricci {
        /// Exponent `p ≥ 1`.
        p: f64,
        /// Operands.
        of: Vec<BlendTree>,
    },
    /// Smooth union of width `width`.
    SmoothUnion {
        /// Blend width in field units.
        width: f64,
        /// Operands.
        of: Vec<BlendTree>,
    },
    /// Smooth intersection of width `width`.
    SmoothIntersection {
        /// Blend width in field units.
        width: f64,
        /// Operands.
        of: Vec<BlendTree>,
    },
}

impl BlendTree {
    /// The compiled form of a scene's blend; `None` (no blend given) is the sum of all
    /// `groups`.
    #[must_use]
    pub fn compile(blend: Option<&Blend>, groups: usize) -> Self {
        let all = |v: &[Blend]| v.iter().map(|b| Self::compile(Some(b), groups)).collect();
        match blend {
            None => Self::Sum((0..groups as u32).map(Self::Group).collect()),
            Some(Blend::Group(i)) => Self::Group(*i),
            Some(Blend::Sum(v)) => Self::Sum(all(v)),
            Some(Blend::Max(v)) => Self::Max(all(v)),
            Some(Blend::Min(v)) => Self::Min(all(v)),
            Some(Blend::Difference(a, b)) => Self::Difference(
                Box::new(Self::compile(Some(a), groups)),
                Box::new(Self::compile(Some(b), groups)),
            ),
            Some(Blend::Ricci { p, of }) => Self::Ricci { p: *p, of: all(of) },
            Some(Blend::SmoothUnion { width, of }) => Self::SmoothUnion {
                width: *width,
                of: all(of),
            },
            Some(Blend::SmoothIntersection { width, of }) => Self::SmoothIntersection {
                width: *width,
                of: all(of),
            },
        }
    }
}

/// What the blend operators combine at a point: a group's value alone (`f64`, for the
/// questions that need no gradient) or its value with its gradient (`(f64, DVec3)`). No
/// operator's value reads a gradient, so both give the same values bit for bit.
pub trait BlendOperand: Copy {
    /// The empty sum.
    const ZERO: Self;
    /// The value.
    fn value(self) -> f64;
    /// `self + o`.
    #[must_use]
    fn plus(self, o: Self) -> Self;
    /// `−self`.
    #[must_use]
    fn negated(self) -> Self;
    /// `2c − self`, the complement about the isovalue `c`.
    #[must_use]
    fn complement(self, isovalue: f64) -> Self;
    /// `max(self, 0)`, with a zero gradient where the value is not positive.
    #[must_use]
    fn positive_part(self) -> Self;
    /// `(Σ partsᵢ^p)^(1/p)` of non-negative parts; 0 where the sum is not positive.
    fn ricci(parts: &[Self], p: f64) -> Self;
    /// The polynomial smooth maximum of width `width` ([`smooth_max`]).
    #[must_use]
    fn smooth_max(self, o: Self, width: f64) -> Self;
}

/// The weight `h = clamp(½ + (a − b)/2w, 0, 1)` of the smooth maximum of `a` and `b`, and its
/// value `b + h(a − b) + w·h(1 − h)`.
fn smooth_max_value(a: f64, b: f64, width: f64) -> (f64, f64) {
    let h = (0.5 + (a - b) / (2.0 * width)).clamp(0.0, 1.0);
    (h, b + h * (a - b) + width * h * (1.0 - h))
}

impl BlendOperand for f64 {
    const ZERO: Self = 0.0;
    fn value(self) -> f64 {
        self
    }
    fn plus(self, o: Self) -> Self {
        self + o
    }
    fn negated(self) -> Self {
        -self
    }
    fn complement(self, isovalue: f64) -> Self {
        2.0 * isovalue - self
    }
    fn positive_part(self) -> Self {
        self.max(0.0)
    }
    fn ricci(parts: &[Self], p: f64) -> Self {
        p_norm(parts.iter().copied(), p)
    }
    fn smooth_max(self, o: Self, width: f64) -> Self {
        smooth_max_value(self, o, width).1
    }
}

impl BlendOperand for (f64, DVec3) {
    const ZERO: Self = (0.0, DVec3::ZERO);
    fn value(self) -> f64 {
        self.0
    }
    fn plus(self, o: Self) -> Self {
        (self.0 + o.0, self.1 + o.1)
    }
    fn negated(self) -> Self {
        (-self.0, -self.1)
    }
    fn complement(self, isovalue: f64) -> Self {
        (2.0 * isovalue - self.0, -self.1)
    }
    fn positive_part(self) -> Self {
        (
            self.0.max(0.0),
            if self.0 > 0.0 { self.1 } else { DVec3::ZERO },
        )
    }
    fn ricci(parts: &[Self], p: f64) -> Self {
        let value = p_norm(parts.iter().map(|&(f, _)| f), p);
        if value <= 0.0 {
            return Self::ZERO;
        }
        let grad = parts.iter().fold(DVec3::ZERO, |acc, (f, g)| {
            acc + (f / value).powf(p - 1.0) * *g
        });
        (value, grad)
    }
    fn smooth_max(self, o: Self, width: f64) -> Self {
        smooth_max(self, o, width)
    }
}

/// `(Σ xᵢ^p)^(1/p)` of non-negative terms (0 when every term is 0), the Ricci blend's p-norm.
/// Where the plain sum of powers is a finite normal number, its root (moderate `p`, terms not far
/// from 1: every scene the fingerprints hold). Where it overflows, or underflows to a subnormal
/// or to 0 with a term positive (a large `p`, or terms far from 1 such as those near a small
/// isovalue), the terms are scaled by the largest first, `m·(Σ (xᵢ/m)^p)^(1/p)`, whose sum lies
/// in `[1, n]`: with `p = 1000` the plain sum made the field 0 or infinite wherever an operand
/// was below or above 1, and the reference tracer took millions of steps.
pub(crate) fn p_norm(terms: impl Iterator<Item = f64> + Clone, p: f64) -> f64 {
    let plain: f64 = terms.clone().map(|x| x.powf(p)).sum();
    if plain.is_finite() && plain >= f64::MIN_POSITIVE {
        return plain.powf(1.0 / p);
    }
    let largest = terms.clone().fold(0.0, f64::max);
    if largest <= 0.0 || largest.is_infinite() {
        return largest.max(0.0);
    }
    largest
        * terms
            .map(|x| (x / largest).powf(p))
            .sum::<f64>()
            .powf(1.0 / p)
}

/// Value and gradient of `b` from the groups' values and gradients.
#[must_use]
pub fn value_gradient(b: &BlendTree, groups: &[(f64, DVec3)], isovalue: f64) -> (f64, DVec3) {
    evaluate(b, groups, isovalue)
}

/// `b` at a point from the groups' operands there: values, or values with gradients.
#[must_use]
pub fn evaluate<T: BlendOperand>(b: &BlendTree, groups: &[T], isovalue: f64) -> T {
    match b {
        BlendTree::Group(i) => groups[*i as usize],
        BlendTree::Sum(v) => v
            .iter()
            .fold(T::ZERO, |acc, c| acc.plus(operand(c, groups, isovalue))),
        BlendTree::Max(v) => select(v, groups, isovalue, |a, b| a > b),
        BlendTree::Min(v) => select(v, groups, isovalue, |a, b| a < b),
        BlendTree::Difference(a, b) => {
            let a = operand(a, groups, isovalue);
            let complement = operand(b, groups, isovalue).complement(isovalue);
            if a.value() <= complement.value() {
                a
            } else {
                complement
            }
        }
        BlendTree::Ricci { p, of } => gathered(
            of.iter()
                .map(|c| operand(c, groups, isovalue).positive_part()),
            of.len(),
            T::ZERO,
            |parts| T::ricci(parts, *p),
        ),
        BlendTree::SmoothUnion { width, of } => of
            .iter()
            .map(|c| operand(c, groups, isovalue))
            .reduce(|a, b| a.smooth_max(b, *width))
            .unwrap_or(T::ZERO),
        BlendTree::SmoothIntersection { width, of } => of
            .iter()
            .map(|c| operand(c, groups, isovalue).negated())
            .reduce(|a, b| a.smooth_max(b, *width))
            .map_or(T::ZERO, T::negated),
    }
}

/// Operands an operator gathers before combining them: on the stack for up to this many (a
/// point question or a march step allocates nothing), in a vector beyond.
const INLINE_OPERANDS: usize = 8;

/// `combine` of the items, at most `count` of them, gathered on the stack where they are few
/// (the blend's operators here, the forward inclusions' in `bounds/inclusion.rs`).
pub(crate) fn gathered<T: Copy, R>(
    items: impl Iterator<Item = T>,
    count: usize,
    zero: T,
    combine: impl FnOnce(&[T]) -> R,
) -> R {
    if count > INLINE_OPERANDS {
        let all: Vec<T> = items.collect();
        return combine(&all);
    }
    let mut inline = [zero; INLINE_OPERANDS];
    let mut n = 0;
    for item in items {
        inline[n] = item;
        n += 1;
    }
    combine(&inline[..n])
}

/// An operand of an operator: a group's entry read directly (most trees are one operator over
/// groups), any other subtree evaluated.
#[inline]
fn operand<T: BlendOperand>(b: &BlendTree, groups: &[T], isovalue: f64) -> T {
    match b {
        BlendTree::Group(i) => groups[*i as usize],
        _ => evaluate(b, groups, isovalue),
    }
}

/// Polynomial smooth maximum of two values with gradients, `−smin(−a, −b)` of the 2014 notes
/// (§11.6): with `h = clamp(½ + (a − b)/2w, 0, 1)`, `b + h(a − b) + w·h(1 − h)`, whose gradient
/// is the convex combination `h∇a + (1 − h)∇b`.
#[must_use]
pub fn smooth_max(a: (f64, DVec3), b: (f64, DVec3), width: f64) -> (f64, DVec3) {
    let (h, value) = smooth_max_value(a.0, b.0, width);
    (value, h * a.1 + (1.0 - h) * b.1)
}

/// Jet of [`smooth_max`] over an interval. Where the operands' ranges stay `width` apart it is
/// the larger one. Otherwise: value in `[max, max + w/4]`; `f′ = h a′ + (1 − h) b′` lies in the
/// hull of the operands' `f′`; `f″ = h a″ + (1 − h) b″ + (a′ − b′)²/2w` inside the band (and
/// `a″` or `b″` outside it), so `f″` lies in the hull of theirs widened up by `max (a′ − b′)²/2w`.
#[must_use]
pub fn smooth_max_jet(a: Jet, b: Jet, width: f64) -> Jet {
    if a.value.lo - b.value.hi >= width {
        return a;
    }
    if b.value.lo - a.value.hi >= width {
        return b;
    }
    let spread = (a.d1 - b.d1).magnitude();
    let d2 = a.d2.hull(b.d2);
    Jet {
        value: Interval {
            lo: a.value.lo.max(b.value.lo),
            hi: a.value.hi.max(b.value.hi) + 0.25 * width,
        },
        d1: a.d1.hull(b.d1),
        d2: Interval {
            lo: d2.lo,
            hi: d2.hi + spread * spread / (2.0 * width),
        },
    }
}

fn select<T: BlendOperand>(
    v: &[BlendTree],
    groups: &[T],
    isovalue: f64,
    better: impl Fn(f64, f64) -> bool,
) -> T {
    let mut best: Option<T> = None;
    for c in v {
        let r = operand(c, groups, isovalue);
        if best.is_none_or(|b| better(r.value(), b.value())) {
            best = Some(r);
        }
    }
    best.unwrap_or(T::ZERO)
}

/// Jet of `b` over a ray interval from the groups' jets.
#[must_use]
pub fn jet(b: &BlendTree, groups: &[Jet], isovalue: f64) -> Jet {
    match b {
        BlendTree::Group(i) => groups[*i as usize],
        BlendTree::Sum(v) => v
            .iter()
            .map(|c| jet(c, groups, isovalue))
            .fold(Jet::ZERO, |a, c| a + c),
        BlendTree::Max(v) => fold(v, groups, isovalue, Jet::max),
        BlendTree::Min(v) => fold(v, groups, isovalue, Jet::min),
        BlendTree::Difference(a, b) => {
            let complement = Jet::constant(2.0 * isovalue) - jet(b, groups, isovalue);
            jet(a, groups, isovalue).min(complement)
        }
        BlendTree::Ricci { p, of } => gathered(
            of.iter().map(|c| jet(c, groups, isovalue)),
            of.len(),
            Jet::ZERO,
            |operands| ricci_jet(*p, operands),
        ),
        BlendTree::SmoothUnion { width, of } => of
            .iter()
            .map(|c| jet(c, groups, isovalue))
            .reduce(|a, b| smooth_max_jet(a, b, *width))
            .unwrap_or(Jet::ZERO),
        BlendTree::SmoothIntersection { width, of } => -of
            .iter()
            .map(|c| -jet(c, groups, isovalue))
            .reduce(|a, b| smooth_max_jet(a, b, *width))
            .unwrap_or(Jet::ZERO),
    }
}

fn fold(v: &[BlendTree], groups: &[Jet], isovalue: f64, op: impl Fn(Jet, Jet) -> Jet) -> Jet {
    let mut it = v.iter().map(|c| jet(c, groups, isovalue));
    let first = it.next().unwrap_or(Jet::ZERO);
    it.fold(first, op)
}

/// Lipschitz bound of `b` from the groups' bounds: sums add, Ricci takes the p-norm of its
/// operands' bounds (Hölder, see [`ricci_jet`]), the other operators are bounded by their largest
/// operand (the smooth operators' gradients are convex combinations of their operands').
#[must_use]
pub fn lipschitz(b: &BlendTree, groups: &[f64]) -> f64 {
    match b {
        BlendTree::Group(i) => groups[*i as usize],
        BlendTree::Sum(v) => v.iter().map(|c| lipschitz(c, groups)).sum(),
        BlendTree::Ricci { p, of } => {
            // |R′| = |Σ uᵢ^(p−1) gᵢ′| ≤ ‖(Lᵢ)‖_p by Hölder, since Σ (uᵢ^(p−1))^(p/(p−1)) = 1.
            p_norm(of.iter().map(|c| lipschitz(c, groups)), *p)
        }
        BlendTree::Max(v)
        | BlendTree::Min(v)
        | BlendTree::SmoothUnion { of: v, .. }
        | BlendTree::SmoothIntersection { of: v, .. } => {
            v.iter().map(|c| lipschitz(c, groups)).fold(0.0, f64::max)
        }
        BlendTree::Difference(a, c) => lipschitz(a, groups).max(lipschitz(c, groups)),
    }
}

/// Jet of the Ricci blend `R = (Σ gᵢ^p)^(1/p)`, `gᵢ = max(fᵢ, 0)`, from its operands' jets,
/// derived from the structure of a p-norm rather than by jet arithmetic through `x^(1/p)` (whose
/// derivatives are unbounded where the sum approaches 0, which is most of space). With
/// `uᵢ = gᵢ/R ∈ [0, 1]`, `Σ uᵢ^p = 1`:
///
/// - **No operand positive** on the interval: `R = 0`.
/// - **One operand `k` that may be positive**, the others `≤ 0`: `R = max(f_k, 0)` exactly, so
///   the interval costs what that operand costs (`f_k` itself where `f_k ≥ 0`).
/// - `p = 1`: `R = Σ gᵢ`.
/// - **Several**, `p > 1`:
///   - value: `R` is increasing in every `gᵢ`, so `[‖g.lo‖_p, ‖g.hi‖_p]` is exact.
///   - `R′ = Σ wᵢ gᵢ′` with weights `wᵢ = uᵢ^(p−1) ∈ [(gᵢ.lo/R.hi)^(p−1), min(1, gᵢ.hi/R.lo)^(p−1)]`.
///   - `R″ = Σ wᵢ gᵢ″ + T`, `T = (p−1)/R · (Σ uᵢ^(p−2) gᵢ′² − R′²)`. By Cauchy–Schwarz
///     (`R′² = (Σ uᵢ^(p/2) · uᵢ^(p/2−1) gᵢ′)² ≤ Σ uᵢ^p · Σ uᵢ^(p−2) gᵢ′²`) `T ≥ 0`: the p-norm is
///     convex. Above, `T ≤ (p−1)/R.lo · (Σ sup uᵢ^(p−2) · sup gᵢ′² − inf R′²)`, with
///     `sup uᵢ^(p−2)` at the largest `uᵢ` for `p ≥ 2` and at the smallest for `p < 2` (infinite
///     where `gᵢ` may vanish: the blend's curvature really is unbounded there when `p < 2`).
///     `T` grows like `1/R` only where every operand is small at once, far below the isovalue.
///   - Each `gᵢ` enters with `gᵢ′` and `gᵢ″` hulled with 0 where `fᵢ` crosses 0: the jump of
///     `gᵢ′` at the crossing is multiplied by `wᵢ = 0` there, so `R` stays C¹ (for `p > 1`).
///
/// Where `R` itself reaches 0 inside the interval it may have a kink (`R = |t|` for operands `t`
/// and `−t`); that point is a minimum of `R ≥ 0`, a convex kink, which the infinite `T` bound
/// (`R.lo = 0`) covers.
#[must_use]
pub fn ricci_jet(p: f64, operands: &[Jet]) -> Jet {
    let positive = operands.iter().copied().filter(|f| f.value.hi > 0.0);
    gathered(
        positive,
        operands.len(),
        Jet::ZERO,
        |positive| match positive {
            [] => Jet::ZERO,
            [only] => only.max(Jet::ZERO),
            _ if p == 1.0 => positive
                .iter()
                .fold(Jet::ZERO, |acc, f| acc + f.max(Jet::ZERO)),
            // gᵢ with the C¹ clamp (see above).
            _ => gathered(
                positive.iter().map(|f| {
                    if f.value.lo >= 0.0 {
                        *f
                    } else {
                        Jet {
                            value: Interval {
                                lo: 0.0,
                                hi: f.value.hi,
                            },
                            d1: f.d1.include(0.0),
                            d2: f.d2.include(0.0),
                        }
                    }
                }),
                positive.len(),
                Jet::ZERO,
                |parts| ricci_of_parts(p, parts),
            ),
        },
    )
}

/// [`ricci_jet`] of several clamped parts `gᵢ`, `p > 1`.
fn ricci_of_parts(p: f64, parts: &[Jet]) -> Jet {
    let norm = |end: fn(&Interval) -> f64| p_norm(parts.iter().map(|g| end(&g.value)), p);
    let value = Interval {
        lo: norm(|v| v.lo),
        hi: norm(|v| v.hi),
    };
    let ratio = |g: &Jet| Interval {
        lo: g.value.lo / value.hi,
        hi: if value.lo > 0.0 {
            (g.value.hi / value.lo).min(1.0)
        } else {
            1.0
        },
    };
    let (mut d1, mut weighted_d2, mut curvature) = (Interval::ZERO, Interval::ZERO, 0.0);
    for g in parts {
        let u = ratio(g);
        let weight = Interval {
            lo: u.lo.powf(p - 1.0),
            hi: u.hi.powf(p - 1.0),
        };
        d1 = d1 + weight * g.d1;
        weighted_d2 = weighted_d2 + weight * g.d2;
        let slope_squared = g.d1.square().hi;
        if slope_squared > 0.0 {
            let sup_u = if p >= 2.0 { u.hi } else { u.lo };
            curvature += sup_u.powf(p - 2.0) * slope_squared;
        }
    }
    let curvature = (curvature - d1.square().lo).max(0.0);
    let t_hi = if curvature == 0.0 {
        0.0
    } else {
        (p - 1.0) * curvature / value.lo
    };
    Jet {
        value,
        d1,
        d2: Interval {
            lo: weighted_d2.lo,
            hi: weighted_d2.hi + t_hi,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn jet(value: (f64, f64), d1: (f64, f64), d2: (f64, f64)) -> Jet {
        Jet {
            value: Interval::new(value.0, value.1),
            d1: Interval::new(d1.0, d1.1),
            d2: Interval::new(d2.0, d2.1),
        }
    }

    /// The p-norm keeps the plain sum's bits where it is a normal number and, scaled, stays
    /// between the largest term and `n^(1/p)` times it for any exponent and scale.
    #[test]
    fn p_norms_neither_overflow_nor_underflow() {
        let terms = [0.3, 1.7, 0.9];
        for p in [1.0, 1.5, 4.0, 32.0] {
            let plain: f64 = terms
                .iter()
                .map(|x: &f64| x.powf(p))
                .sum::<f64>()
                .powf(1.0 / p);
            assert_eq!(p_norm(terms.iter().copied(), p).to_bits(), plain.to_bits());
        }
        for p in [4.0, 300.0, 1e4, 1e12] {
            for scale in [1e-300, 1e-3, 1.0, 1e3, 1e300] {
                let scaled = terms.map(|x| x * scale);
                let norm = p_norm(scaled.iter().copied(), p);
                let largest = 1.7 * scale;
                assert!(
                    norm >= largest * (1.0 - 1e-15)
                        && norm <= largest * 3f64.powf(1.0 / p) * (1.0 + 1e-15),
                    "p = {p}, scale {scale}: {norm} for the largest term {largest}"
                );
            }
        }
        assert_eq!(p_norm([0.0, 0.0].into_iter(), 1e4), 0.0);
        assert_eq!(p_norm([2.0, f64::INFINITY].into_iter(), 8.0), f64::INFINITY);
    }

    #[test]
    fn ricci_of_one_positive_operand_is_that_operand() {
        let f = jet((0.2, 1.4), (-3.0, 2.0), (-5.0, 7.0));
        let off = jet((-2.0, 0.0), (-1.0, 1.0), (-9.0, 9.0));
        for p in [1.0, 1.5, 4.0] {
            assert_eq!(ricci_jet(p, &[off, f, off]), f);
            assert_eq!(ricci_jet(p, &[off, off]), Jet::ZERO);
        }
    }

    #[test]
    fn ricci_bounds_are_finite_where_the_blend_is_smooth() {
        let a = jet((0.5, 1.5), (-2.0, 2.0), (-4.0, 4.0));
        let b = jet((0.1, 0.8), (-1.0, 3.0), (-2.0, 6.0));
        for p in [2.0, 4.0, 8.0] {
            let r = ricci_jet(p, &[a, b]);
            assert!(r.d2.lo.is_finite() && r.d2.hi.is_finite(), "p = {p}: {r:?}");
            // max ≤ R ≤ Σ on the values.
            assert!(r.value.lo >= 0.5 && r.value.hi <= 1.5 + 0.8);
            // |R′| ≤ Σ |gᵢ′| and, the weights being at most 1, within the operands' hull sum.
            assert!(r.d1.lo >= -3.0 && r.d1.hi <= 5.0);
        }
        // p < 2 with an operand that may vanish: the curvature is genuinely unbounded above.
        let c = jet((-0.5, 0.8), (-1.0, 3.0), (-2.0, 6.0));
        let r = ricci_jet(1.5, &[a, c]);
        assert!(r.d2.hi.is_infinite() && r.d2.lo.is_finite());
    }
}
