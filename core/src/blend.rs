//! Blend operators over group fields (scalis 2021 eq. 1 and the blob-tree composition; numerical
//! ray tracing notes 2014 §7): sum, max (sharp union), min (intersection), difference
//! `min(f₁, 2c − f₂)` (the complement of a density field about the isovalue), and the Ricci
//! p-blend `(Σ max(fᵢ, 0)^p)^(1/p)`. Each operator evaluates values with gradients and composes
//! ray-interval jets.

use glam::DVec3;

use crate::interval::{Interval, Jet};
use crate::scene::Blend;

/// Value and gradient of `b` from the groups' values and gradients.
#[must_use]
pub fn value_gradient(b: &Blend, groups: &[(f64, DVec3)], isovalue: f64) -> (f64, DVec3) {
    match b {
        Blend::Group(i) => groups[*i as usize],
        Blend::Sum(v) => v.iter().fold((0.0, DVec3::ZERO), |acc, c| {
            let (f, g) = value_gradient(c, groups, isovalue);
            (acc.0 + f, acc.1 + g)
        }),
        Blend::Max(v) => select(v, groups, isovalue, |a, b| a > b),
        Blend::Min(v) => select(v, groups, isovalue, |a, b| a < b),
        Blend::Difference(a, b) => {
            let (fa, ga) = value_gradient(a, groups, isovalue);
            let (fb, gb) = value_gradient(b, groups, isovalue);
            let complement = 2.0 * isovalue - fb;
            if fa <= complement {
                (fa, ga)
            } else {
                (complement, -gb)
            }
        }
        Blend::Ricci { p, of } => {
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
    }
}

fn select(
    v: &[Blend],
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
pub fn jet(b: &Blend, groups: &[Jet], isovalue: f64) -> Jet {
    match b {
        Blend::Group(i) => groups[*i as usize],
        Blend::Sum(v) => v
            .iter()
            .map(|c| jet(c, groups, isovalue))
            .fold(Jet::ZERO, |a, c| a + c),
        Blend::Max(v) => fold(v, groups, isovalue, Jet::max),
        Blend::Min(v) => fold(v, groups, isovalue, Jet::min),
        Blend::Difference(a, b) => {
            let complement = Jet::constant(2.0 * isovalue) - jet(b, groups, isovalue);
            jet(a, groups, isovalue).min(complement)
        }
        Blend::Ricci { p, of } => {
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
    }
}

fn fold(v: &[Blend], groups: &[Jet], isovalue: f64, op: impl Fn(Jet, Jet) -> Jet) -> Jet {
    let mut it = v.iter().map(|c| jet(c, groups, isovalue));
    let first = it.next().unwrap_or(Jet::ZERO);
    it.fold(first, op)
}

/// Lipschitz bound of `b` from the groups' bounds: sums add, the other operators are bounded by
/// their largest operand (Ricci by the sum, its weights being at most 1).
#[must_use]
pub fn lipschitz(b: &Blend, groups: &[f64]) -> f64 {
    match b {
        Blend::Group(i) => groups[*i as usize],
        Blend::Sum(v) | Blend::Ricci { of: v, .. } => v.iter().map(|c| lipschitz(c, groups)).sum(),
        Blend::Max(v) | Blend::Min(v) => v.iter().map(|c| lipschitz(c, groups)).fold(0.0, f64::max),
        Blend::Difference(a, c) => lipschitz(a, groups).max(lipschitz(c, groups)),
    }
}
