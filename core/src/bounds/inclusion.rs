//! Forward inclusion functions (forward-inclusion 2023 §4–6): on `[t₀, t₀ + h]`, a lower and an
//! upper quadratic `f(t₀) + s·(a + b·s)`, `s = t − t₀`, both exact at `t₀`. Linear inclusions are
//! the case `b = 0`. Sums add coefficients; the maximum of several inclusions takes, for the upper
//! bound, the quadratic Bézier whose control points are the maxima of the operands' control
//! points (appendix C; for lines, the chord from the largest start value to the largest end
//! value, §5.2) and, for the lower bound, the lower bound of the operand with the largest start
//! value. The minimum is the mirror image.

use std::cell::Cell;

use crate::bounds::interval::Jet;
use crate::field::blend::{BlendTree, gathered};

/// A quadratic `s ↦ a·s + b·s²` (the offset from the exact start value).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Offset {
    /// Linear coefficient.
    pub a: f64,
    /// Quadratic coefficient.
    pub b: f64,
}

impl Offset {
    fn at(self, s: f64) -> f64 {
        s * (self.a + self.b * s)
    }
}

/// Bounds of `f(t₀ + s)` for `s ∈ [0, h]`: `start + lower(s) ≤ f ≤ start + upper(s)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForwardInclusion {
    /// `f(t₀)`, exact.
    pub start: f64,
    /// Lower offset.
    pub lower: Offset,
    /// Upper offset.
    pub upper: Offset,
    /// Length `h` of the interval the bounds hold on.
    pub length: f64,
}

impl ForwardInclusion {
    /// Linear Taylor inclusion: slopes from an enclosure of `f′` (§5.1).
    #[must_use]
    pub fn linear(start: f64, jet: &Jet, length: f64) -> Self {
        Self {
            start,
            lower: Offset {
                a: jet.d1.lo,
                b: 0.0,
            },
            upper: Offset {
                a: jet.d1.hi,
                b: 0.0,
            },
            length,
        }
    }

    /// Quadratic Taylor inclusion `f(t₀) + f′(t₀)s + ½f″(ξ)s²` (§6.1); a side whose `f″` bound is
    /// infinite (a kink inside the interval) falls back to the linear Taylor bound.
    #[must_use]
    pub fn quadratic(start: f64, slope: f64, jet: &Jet, length: f64) -> Self {
        let side = |d2: f64, d1: f64| {
            if d2.is_finite() {
                Offset {
                    a: slope,
                    b: 0.5 * d2,
                }
            } else {
                Offset { a: d1, b: 0.0 }
            }
        };
        Self {
            start,
            lower: side(jet.d2.lo, jet.d1.lo),
            upper: side(jet.d2.hi, jet.d1.hi),
            length,
        }
    }

    /// The zero function on `[0, length]`.
    #[must_use]
    pub fn zero(length: f64) -> Self {
        let flat = Offset { a: 0.0, b: 0.0 };
        Self {
            start: 0.0,
            lower: flat,
            upper: flat,
            length,
        }
    }

    /// The tightest linear inclusion containing this one (§5.2): a convex side is bounded by its
    /// tangent at the start (lower) or its chord (upper), a concave side the other way round.
    #[must_use]
    pub fn linearized(self) -> Self {
        let h = self.length;
        let chord = |o: Offset| o.a + o.b * h;
        Self {
            lower: Offset {
                a: if self.lower.b >= 0.0 {
                    self.lower.a
                } else {
                    chord(self.lower)
                },
                b: 0.0,
            },
            upper: Offset {
                a: if self.upper.b <= 0.0 {
                    self.upper.a
                } else {
                    chord(self.upper)
                },
                b: 0.0,
            },
            ..self
        }
    }

    /// Value of the lower bound at `s`.
    #[must_use]
    pub fn lower_at(&self, s: f64) -> f64 {
        self.start + self.lower.at(s)
    }

    /// Value of the upper bound at `s`.
    #[must_use]
    pub fn upper_at(&self, s: f64) -> f64 {
        self.start + self.upper.at(s)
    }

    /// The largest value of the upper bound on `[0, length]`.
    #[must_use]
    pub fn upper_max(&self) -> f64 {
        let h = self.length;
        let mut top = self.start.max(self.upper_at(h));
        if self.upper.b < 0.0 {
            let apex = -self.upper.a / (2.0 * self.upper.b);
            if apex > 0.0 && apex < h {
                top = top.max(self.upper_at(apex));
            }
        }
        top
    }

    fn negate(self) -> Self {
        Self {
            start: -self.start,
            lower: Offset {
                a: -self.upper.a,
                b: -self.upper.b,
            },
            upper: Offset {
                a: -self.lower.a,
                b: -self.lower.b,
            },
            length: self.length,
        }
    }

    /// Inclusion of `max(f, 0)` (the clamped density of an HRBF group).
    #[must_use]
    pub fn positive_part(self) -> Self {
        Self::max(&[self, Self::zero(self.length)]).unwrap_or(self)
    }

    /// Maximum of inclusions (appendix C).
    fn max(items: &[Self]) -> Option<Self> {
        let h = items.iter().map(|i| i.length).fold(f64::INFINITY, f64::min);
        let best = items.iter().max_by(|a, b| a.start.total_cmp(&b.start))?;
        // Control points of each upper quadratic on [0, h]: start, start + a·h/2, value at h.
        let (mut c0, mut c1, mut c2) = (f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for i in items {
            c0 = c0.max(i.start);
            c1 = c1.max(i.start + 0.5 * h * i.upper.a);
            c2 = c2.max(i.upper_at(h));
        }
        let upper = if h > 0.0 {
            // Bézier (c0, c1, c2) in u = s/h, written as c0 + s·(a + b·s).
            Offset {
                a: 2.0 * (c1 - c0) / h,
                b: (c0 - 2.0 * c1 + c2) / (h * h),
            }
        } else {
            best.upper
        };
        Some(Self {
            start: c0,
            lower: best.lower,
            upper,
            length: h,
        })
    }
}

impl std::ops::Add for ForwardInclusion {
    type Output = Self;

    /// Sum of two inclusions (forward-inclusion eq. 16), on the shorter of their intervals.
    fn add(self, o: Self) -> Self {
        Self {
            start: self.start + o.start,
            lower: Offset {
                a: self.lower.a + o.lower.a,
                b: self.lower.b + o.lower.b,
            },
            upper: Offset {
                a: self.upper.a + o.upper.a,
                b: self.upper.b + o.upper.b,
            },
            length: self.length.min(o.length),
        }
    }
}

/// Composes group inclusions through the blend tree; `None` for operators without a forward
/// inclusion rule here (the smooth blends, and Ricci where two operands may be positive), where
/// callers fall back to whole-field bounds.
#[must_use]
pub fn blend(
    b: &BlendTree,
    groups: &[ForwardInclusion],
    isovalue: f64,
) -> Option<ForwardInclusion> {
    match b {
        BlendTree::Group(i) => groups.get(*i as usize).copied(),
        BlendTree::Sum(v) => {
            let mut it = v.iter().map(|c| blend(c, groups, isovalue));
            let first = it.next()??;
            it.try_fold(first, |acc, c| Some(acc + c?))
        }
        BlendTree::Max(v) => with_operands(v.iter().map(|c| blend(c, groups, isovalue)), |items| {
            ForwardInclusion::max(items)
        }),
        BlendTree::Min(v) => with_operands(
            v.iter()
                .map(|c| blend(c, groups, isovalue).map(ForwardInclusion::negate)),
            |items| ForwardInclusion::max(items).map(ForwardInclusion::negate),
        ),
        BlendTree::Difference(a, c) => {
            let a = blend(a, groups, isovalue)?.negate();
            let mut complement = blend(c, groups, isovalue)?;
            complement.start -= 2.0 * isovalue;
            // −min(a, 2c − b) = max(−a, b − 2c)
            ForwardInclusion::max(&[a, complement]).map(ForwardInclusion::negate)
        }
        BlendTree::Ricci { of, .. } => {
            // Where at most one operand can be positive on the interval the blend is that
            // operand's positive part (see `blend::ricci_jet`); elsewhere there is no rule.
            with_operands(of.iter().map(|c| blend(c, groups, isovalue)), |items| {
                let h = items.iter().map(|i| i.length).fold(f64::INFINITY, f64::min);
                let mut positive = items.iter().filter(|i| i.upper_max() > 0.0);
                match (positive.next(), positive.next()) {
                    (None, _) => Some(ForwardInclusion::zero(h)),
                    (Some(only), None) => Some(only.positive_part()),
                    (Some(_), Some(_)) => None,
                }
            })
        }
        BlendTree::SmoothUnion { .. } | BlendTree::SmoothIntersection { .. } => None,
    }
}

/// `combine(operands)` where every operand has an inclusion; `None` as soon as one has none
/// (the operands after it are not asked). Gathered on the stack as the blend's operands are.
fn with_operands(
    operands: impl ExactSizeIterator<Item = Option<ForwardInclusion>>,
    combine: impl FnOnce(&[ForwardInclusion]) -> Option<ForwardInclusion>,
) -> Option<ForwardInclusion> {
    let complete = Cell::new(true);
    let count = operands.len();
    let present = operands.map_while(|operand| {
        complete.set(operand.is_some());
        operand
    });
    gathered(present, count, ForwardInclusion::zero(0.0), |items| {
        if complete.get() { combine(items) } else { None }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn max_of_quadratics_bounds_both_operands() {
        let a = ForwardInclusion {
            start: 1.0,
            lower: Offset { a: -1.0, b: 0.0 },
            upper: Offset { a: 0.5, b: 2.0 },
            length: 1.0,
        };
        let b = ForwardInclusion {
            start: 0.5,
            lower: Offset { a: 0.0, b: -1.0 },
            upper: Offset { a: 3.0, b: -0.5 },
            length: 1.0,
        };
        let m = ForwardInclusion::max(&[a, b]).unwrap_or(a);
        assert_eq!(m.start, 1.0);
        for k in 0..=100 {
            let s = f64::from(k) / 100.0;
            let top = a.upper_at(s).max(b.upper_at(s));
            assert!(m.upper_at(s) >= top - 1e-12, "s = {s}");
            assert!(m.lower_at(s) <= a.lower_at(s).max(b.lower_at(s)) + 1e-12);
        }
    }
}
