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

/// Value and gradient of `b` from the groups' values and gradients.
#[must_use]
pub fn value_gradient(b: &BlendTree, groups: &[(f64, DVec3)], isovalue: f64) -> (f64, DVec3) {
    match b {
        BlendTree::Group(i) => groups[*i as usize],
        BlendTree::Sum(v) => v.iter().fold((0.0, DVec3::ZERO), |acc, c| {
            let (f, g) = value_gradient(c, groups, isovalue);
            (acc.0 + f, acc.1 + g)
        }),
        BlendTree::Max(v) => select(v, groups, isovalue, |a, b| a > b),
        BlendTree::Min(v) => select(v, groups, isovalue, |a, b| a < b),
        BlendTree::Difference(a, b) => {
            let (fa, ga) = value_gradient(a, groups, isovalue);
            let (fb, gb) = value_gradient(b, groups, isovalue);
            let complement = 2.0 * isovalue - fb;
            if fa <= complement {
                (fa, ga)
            } else {
                (complement, -gb)
            }
        }
        BlendTree::Ricci { p, of } => {
            let parts: Vec<(f64, DVec3)> = of
                .iter()
                .map(|c| {
                    let (f, g) = value_gradient(c, groups, isovalue);
                    (f.max(0.0), if f > 0.0 { g } else { DVec3::ZERO })
                })
                .collect();
            let s: f64 = parts.iter().map(|(f, _)| f.powf(*p)).sum();
            if s <= 0.0 {
                return (0.0, DVec3::ZERO);
            }
            let value = s.powf(1.0 / p);
            let grad = parts.iter().fold(DVec3::ZERO, |acc, (f, g)| {
                acc + (f / value).powf(p - 1.0) * *g
            });
            (value, grad)
        }
        BlendTree::SmoothUnion { width, of } => of
            .iter()
            .map(|c| value_gradient(c, groups, isovalue))
            .reduce(|a, b| smooth_max(a, b, *width))
            .unwrap_or((0.0, DVec3::ZERO)),
        BlendTree::SmoothIntersection { width, of } => of
            .iter()
            .map(|c| {
                let (f, g) = value_gradient(c, groups, isovalue);
                (-f, -g)
            })
            .reduce(|a, b| smooth_max(a, b, *width))
            .map_or((0.0, DVec3::ZERO), |(f, g)| (-f, -g)),
    }
}

/// Polynomial smooth maximum of two values with gradients, `−smin(−a, −b)` of the 2014 notes
/// (§11.6): with `h = clamp(½ + (a − b)/2w, 0, 1)`, `b + h(a − b) + w·h(1 − h)`, whose gradient
/// is the convex combination `h∇a + (1 − h)∇b`.
#[must_use]
pub fn smooth_max(a: (f64, DVec3), b: (f64, DVec3), width: f64) -> (f64, DVec3) {
    let h = (0.5 + (a.0 - b.0) / (2.0 * width)).clamp(0.0, 1.0);
    (
        b.0 + h * (a.0 - b.0) + width * h * (1.0 - h),
        h * a.1 + (1.0 - h) * b.1,
    )
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

fn select(
    v: &[BlendTree],
    groups: &[(f64, DVec3)],
    isovalue: f64,
    better: impl Fn(f64, f64) -> bool,
) -> (f64, DVec3) {
    let mut best: Option<(f64, DVec3)> = None;
    for c in v {
        let r = value_gradient(c, groups, isovalue);
        if best.is_none_or(|b| better(r.0, b.0)) {
            best = Some(r);
        }
    }
    best.unwrap_or((0.0, DVec3::ZERO))
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
        BlendTree::Ricci { p, of } => {
            let parts: Vec<Jet> = of
                .iter()
                .map(|c| jet(c, groups, isovalue).max(Jet::ZERO))
                .collect();
            if parts.iter().all(|j| *j == Jet::ZERO) {
                return Jet::ZERO;
            }
            let sum = parts
                .iter()
                .map(|j| j.powf(*p))
                .fold(Jet::ZERO, |a, c| a + c);
            let mut result = sum.powf(1.0 / p);
            // F′ = Σ wᵢ fᵢ′ with weights wᵢ = (fᵢ/F)^(p−1) in [0, 1].
            let weighted = parts.iter().fold(Interval::ZERO, |acc, j| {
                acc + Interval {
                    lo: j.d1.lo.min(0.0),
                    hi: j.d1.hi.max(0.0),
                }
            });
            result.d1 = result.d1.intersect(weighted).unwrap_or(weighted);
            result
        }
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

/// Lipschitz bound of `b` from the groups' bounds: sums add, the other operators are bounded by
/// their largest operand (Ricci by the sum, its weights being at most 1; the smooth operators'
/// gradients are convex combinations of their operands').
#[must_use]
pub fn lipschitz(b: &BlendTree, groups: &[f64]) -> f64 {
    match b {
        BlendTree::Group(i) => groups[*i as usize],
        BlendTree::Sum(v) | BlendTree::Ricci { of: v, .. } => {
            v.iter().map(|c| lipschitz(c, groups)).sum()
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
