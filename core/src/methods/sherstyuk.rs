//! Sherstyuk's fast ray tracing of convolution surfaces (Sherstyuk 1999, the comparison of
//! scalis 2021 §2 and §8): each primitive's field along the ray is approximated on its support
//! interval by piecewise cubic Hermite polynomials, from its value and derivative at the ends
//! of 4 equal subintervals (the coarsest subdivision scalis 2021 found visually acceptable).
//! Summation blending adds the polynomials: on each elementary interval between consecutive
//! nodes the sum is again a cubic, whose Hermite data are the sums of the active pieces'; its
//! roots against the isovalue are found on its monotone parts.
//!
//! Steps are elementary intervals searched for a root; evaluations are the primitive samples
//! (value and gradient of one primitive each). Approximate by construction: the statistics
//! count its misses and depth errors. Needs summation blending.

use super::MethodId;
use crate::bounds::interval::Interval;
use crate::field::blend::BlendTree;
use crate::field::geometry::quadratic_roots;
use crate::field::program::FieldProgram;
use crate::field::ray_field::RayField;

use super::{Crossing, Method, RayTracer, Trace, TraceMode, TraceSettings, trace_supports};

/// `sherstyuk`.
pub struct Sherstyuk;

impl Sherstyuk {
    /// Subintervals per primitive support interval (the GPU's shader takes it from here).
    pub const SUBDIVISIONS: usize = 4;
}

struct Prepared<'a> {
    program: &'a FieldProgram,
    settings: TraceSettings,
}

impl Method for Sherstyuk {
    fn id(&self) -> MethodId {
        MethodId::Sherstyuk
    }

    fn is_conservative(&self) -> bool {
        false
    }

    fn supports(&self, program: &FieldProgram) -> Result<(), String> {
        let summed = match program.blend() {
            BlendTree::Group(_) => true,
            BlendTree::Sum(v) => v.iter().all(|b| matches!(b, BlendTree::Group(_))),
            _ => false,
        };
        if !summed {
            Err("sherstyuk needs groups blended by a plain sum (its polynomials add)".to_owned())
        } else if (0..program.group_count()).any(|g| program.group_is_clamped(g)) {
            Err(
                "sherstyuk does not apply to HRBF sets (their terms add only before the \
                 group's clamp at 0)"
                    .to_owned(),
            )
        } else {
            Ok(())
        }
    }

    fn scene_inputs(&self, _: &FieldProgram) -> Vec<f64> {
        // The Hermite pieces are the ray's own primitives'.
        Vec::new()
    }

    fn prepare<'a>(
        &self,
        program: &'a FieldProgram,
        settings: TraceSettings,
    ) -> Box<dyn RayTracer + 'a> {
        Box::new(Prepared { program, settings })
    }
}

/// Cubic Hermite data on `[t0, t1]`.
#[derive(Clone, Copy, Debug)]
struct Piece {
    t0: f64,
    t1: f64,
    v0: f64,
    d0: f64,
    v1: f64,
    d1: f64,
}

impl Piece {
    /// Value and derivative at `t`.
    fn at(&self, t: f64) -> (f64, f64) {
        let l = self.t1 - self.t0;
        let s = (t - self.t0) / l;
        let [a, b, c, d] = self.monomial();
        (
            a + s * (b + s * (c + s * d)),
            (b + s * (2.0 * c + 3.0 * s * d)) / l,
        )
    }

    /// Coefficients in `s = (t − t0)/(t1 − t0)`.
    fn monomial(&self) -> [f64; 4] {
        let l = self.t1 - self.t0;
        let (ld0, ld1) = (l * self.d0, l * self.d1);
        [
            self.v0,
            ld0,
            -3.0 * self.v0 - 2.0 * ld0 + 3.0 * self.v1 - ld1,
            2.0 * self.v0 + ld0 - 2.0 * self.v1 + ld1,
        ]
    }

    /// Crossings of `c` in order, with their direction.
    fn crossings(&self, c: f64) -> Vec<Crossing> {
        let [a, b, cc, d] = self.monomial();
        let p = |s: f64| a - c + s * (b + s * (cc + s * d));
        let mut cuts = vec![0.0];
        if let Some((r1, r2)) = quadratic_roots(3.0 * d, 2.0 * cc, b) {
            cuts.extend([r1, r2].into_iter().filter(|s| *s > 0.0 && *s < 1.0));
        }
        cuts.push(1.0);
        let mut out = Vec::new();
        for w in cuts.windows(2) {
            let (mut lo, mut hi) = (w[0], w[1]);
            let below_lo = p(lo) < 0.0;
            if below_lo == (p(hi) < 0.0) {
                continue;
            }
            for _ in 0..50 {
                let mid = 0.5 * (lo + hi);
                if (p(mid) < 0.0) == below_lo {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            out.push(Crossing {
                t: self.t0 + 0.5 * (lo + hi) * (self.t1 - self.t0),
                entering: below_lo,
            });
        }
        out
    }
}

impl Prepared<'_> {
    fn trace_part(&self, field: &RayField, part: Interval, mode: TraceMode, trace: &mut Trace) {
        // Per-primitive pieces.
        let ray = field.ray();
        let mut pieces = Vec::new();
        field.for_each_primitive(part, |_, primitive, k, span| {
            if span.width() <= 0.0 {
                return;
            }
            let node =
                |i: usize| span.lo + span.width() * i as f64 / Sherstyuk::SUBDIVISIONS as f64;
            let sample = |t: f64| {
                let (v, g) = primitive.value_gradient(ray.at(t), k);
                (v, g.dot(ray.direction))
            };
            trace.evaluations += Sherstyuk::SUBDIVISIONS as u32 + 1;
            let mut previous = (node(0), sample(node(0)));
            for i in 1..=Sherstyuk::SUBDIVISIONS {
                let t = node(i);
                let here = sample(t);
                pieces.push(Piece {
                    t0: previous.0,
                    t1: t,
                    v0: previous.1.0,
                    d0: previous.1.1,
                    v1: here.0,
                    d1: here.1,
                });
                previous = (t, here);
            }
        });
        let mut nodes: Vec<f64> = pieces.iter().flat_map(|p| [p.t0, p.t1]).collect();
        nodes.sort_by(f64::total_cmp);
        nodes.dedup();
        if nodes.len() < 2 {
            return;
        }
        // Summed Hermite data of the elementary intervals [nodes[i], nodes[i + 1]].
        let n = nodes.len() - 1;
        let mut sums = vec![[0.0; 4]; n];
        for p in &pieces {
            let first = nodes.partition_point(|&t| t < p.t0);
            for i in first..n {
                if nodes[i] >= p.t1 {
                    break;
                }
                let (v0, d0) = p.at(nodes[i]);
                let (v1, d1) = p.at(nodes[i + 1]);
                let s = &mut sums[i];
                s[0] += v0;
                s[1] += d0;
                s[2] += v1;
                s[3] += d1;
            }
        }
        let c = self.program.isovalue();
        for (i, s) in sums.iter().enumerate() {
            if trace.steps >= self.settings.max_steps {
                return;
            }
            trace.steps += 1;
            let piece = Piece {
                t0: nodes[i],
                t1: nodes[i + 1],
                v0: s[0],
                d0: s[1],
                v1: s[2],
                d1: s[3],
            };
            for crossing in piece.crossings(c) {
                trace.push_crossing(crossing);
                if mode == TraceMode::Opaque {
                    return;
                }
            }
        }
    }
}

impl RayTracer for Prepared<'_> {
    fn program(&self) -> &FieldProgram {
        self.program
    }

    fn trace_field(&self, field: &RayField, mode: TraceMode) -> Trace {
        let span = field.span();
        let s = &self.settings;
        trace_supports(field, span, mode, s.max_steps, |part, trace| {
            self.trace_part(field, part, mode, trace);
        })
    }
}
