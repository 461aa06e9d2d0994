//! Geometric helpers shared by primitives and the acceleration structure: rays, boxes,
//! sphere-cone supports (scalis 2021 §3, fig. 3) and the closest points of two segments.

use glam::{DMat3, DVec3};

use crate::bounds::interval::Interval;

/// A ray `r(t) = origin + t·direction` with a unit direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin `o`.
    pub origin: DVec3,
    /// Unit direction `u`.
    pub direction: DVec3,
}

impl Ray {
    /// A ray through `origin` along `direction` (normalised here).
    #[must_use]
    pub fn new(origin: DVec3, direction: DVec3) -> Self {
        Self {
            origin,
            direction: direction.normalize(),
        }
    }

    /// The point at parameter `t`.
    #[must_use]
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + t * self.direction
    }
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: DVec3,
    /// Maximum corner.
    pub max: DVec3,
}

impl Aabb {
    /// The empty box (union identity).
    pub const EMPTY: Self = Self {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };

    /// Box of a ball.
    #[must_use]
    pub fn ball(center: DVec3, radius: f64) -> Self {
        Self {
            min: center - DVec3::splat(radius),
            max: center + DVec3::splat(radius),
        }
    }

    /// Smallest box containing both.
    #[must_use]
    pub fn union(self, o: Self) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// `true` when the box contains nothing.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// Centre of the box.
    #[must_use]
    pub fn center(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }

    /// `true` when `p` lies in the closed box.
    #[must_use]
    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Length of the diagonal.
    #[must_use]
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).length()
    }

    /// The box widened to the lines of a grid of cubic cells whose side is the power of two
    /// between 1/32 and 1/16 of its diagonal: the same box for every box that lies within the
    /// same grid cells at the same power, so that what is scaled by it
    /// ([`crate::field::program::FieldProgram::scale_bounds`]) does not move when the box
    /// grows or shrinks by less than a cell. Exact: the cell is a power of two, and the
    /// corners are whole multiples of it. An empty or degenerate box is returned as it is.
    #[must_use]
    pub fn snapped_to_grid(&self) -> Self {
        let diagonal = self.diagonal();
        if self.is_empty() || !(diagonal > 0.0 && diagonal.is_finite()) {
            return *self;
        }
        let cell = (diagonal / 16.0).log2().floor().exp2();
        Self {
            min: (self.min / cell).floor() * cell,
            max: (self.max / cell).ceil() * cell,
        }
    }

    /// Parameter interval where the ray is inside the box (slab test), clipped to `span`.
    #[must_use]
    pub fn ray_interval(&self, ray: &Ray, span: Interval) -> Option<Interval> {
        self.ray_interval_with(ray, ray.direction.recip(), span)
    }

    /// [`Aabb::ray_interval`] with the ray direction's reciprocal `inv` computed by the caller
    /// (once per ray in a traversal).
    #[must_use]
    pub fn ray_interval_with(&self, ray: &Ray, inv: DVec3, span: Interval) -> Option<Interval> {
        slab_interval(
            (self.min - ray.origin) * inv,
            (self.max - ray.origin) * inv,
            span,
        )
    }
}

/// The slab test from its planes' parameters on the ray, `t_a = (min − o)·inv` and
/// `t_b = (max − o)·inv` ([`Aabb::ray_interval_with`]; a camera tile's rays share `min − o`
/// and `max − o`), clipped to `span`.
#[inline]
#[must_use]
pub fn slab_interval(t_a: DVec3, t_b: DVec3, span: Interval) -> Option<Interval> {
    let mut lo = span.lo;
    let mut hi = span.hi;
    for axis in 0..3 {
        let (a, b) = (t_a[axis], t_b[axis]);
        if a.is_nan() || b.is_nan() {
            // Direction component is 0 and the origin lies on a slab plane: inside.
            continue;
        }
        lo = lo.max(a.min(b));
        hi = hi.min(a.max(b));
    }
    (lo <= hi).then_some(Interval { lo, hi })
}

/// Real roots of `a t² + b t + c`, in increasing order, computed without cancellation.
#[must_use]
pub fn quadratic_roots(a: f64, b: f64, c: f64) -> Option<(f64, f64)> {
    let scale = a.abs().max(b.abs()).max(c.abs());
    if scale == 0.0 {
        return None;
    }
    if a.abs() <= 1e-14 * scale {
        if b == 0.0 {
            return None;
        }
        let t = -c / b;
        return Some((t, t));
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let (r1, r2) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
    Some((r1.min(r2), r1.max(r2)))
}

/// The relative part of the margin by which a ray's line must miss a support for the field to
/// be exactly 0 along it: a fraction of the support's (local) radius, far above the rounding of
/// a squared distance over a squared radius, so that every kernel argument lands beyond its
/// support. Added to [`rounding_margin`].
pub const RELATIVE_SUPPORT_MARGIN: f64 = 1e-6;

/// The absolute part of the margin by which a ray's line must miss a support for the field to
/// be exactly 0 at every point `origin + t·direction`, `|t·direction| ≤ reach`, near `center`
/// (`RayField`): 10⁴ times the rounding of such a point minus `center` and of a
/// distance to the line.
#[must_use]
pub fn rounding_margin(origin: DVec3, center: DVec3, reach: f64) -> f64 {
    // The 1-norm bounds the length from above without a square root.
    let scale = origin.abs().max_element()
        + center.abs().max_element()
        + (center - origin).abs().element_sum()
        + reach.abs();
    1e-12 * scale
}

/// Interval where a ray is inside a ball.
#[must_use]
pub fn ball_interval(ray: &Ray, center: DVec3, radius: f64) -> Option<Interval> {
    let oc = ray.origin - center;
    ball_interval_from(oc, oc.length_squared() - radius * radius, ray.direction)
}

/// [`ball_interval`] from `oc = origin − centre` and `c = |oc|² − radius²`, which the rays from
/// one origin share, and the ray's `direction`.
#[inline]
#[must_use]
pub fn ball_interval_from(oc: DVec3, c: f64, direction: DVec3) -> Option<Interval> {
    let b = oc.dot(direction);
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let root = disc.sqrt();
    let (t0, t1) = (-b - root, -b + root);
    Some(Interval::new(t0, t1))
}

/// The union of balls centred on a segment with linearly varying radius (a *sphere-cone*),
/// oriented so that the radius grows from `start` (scalis fig. 2–3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereCone {
    /// End with the smaller radius.
    pub start: DVec3,
    /// Unit axis from `start` to the other end.
    pub axis: DVec3,
    /// Segment length `L > 0`.
    pub length: f64,
    /// Radius at `start`.
    pub radius: f64,
    /// Radius growth per unit length, `0 ≤ slope < 1`.
    pub slope: f64,
}

impl SphereCone {
    /// Radius at the far end.
    #[must_use]
    pub fn end_radius(&self) -> f64 {
        self.radius + self.slope * self.length
    }

    /// The far end.
    #[must_use]
    pub fn end(&self) -> DVec3 {
        self.start + self.length * self.axis
    }

    /// Bounding box.
    #[must_use]
    pub fn aabb(&self) -> Aabb {
        Aabb::ball(self.start, self.radius).union(Aabb::ball(self.end(), self.end_radius()))
    }

    /// The sphere-cone scaled by `k` about its axis (radii times `k`): the support of a
    /// primitive whose kernel vanishes beyond `k` prescribed radii.
    #[must_use]
    pub fn scaled(&self, k: f64) -> Self {
        Self {
            radius: self.radius * k,
            slope: self.slope * k,
            ..*self
        }
    }

    /// The sphere-cone with its radii grown by `margin` relative to the local radius plus
    /// `absolute`, if it is still one (slope below 1): a line that misses it passes outside
    /// this cone by more than that.
    #[must_use]
    pub fn grown_by(&self, margin: f64, absolute: f64) -> Option<Self> {
        let grown = Self {
            radius: self.radius * (1.0 + margin) + absolute,
            slope: self.slope * (1.0 + margin),
            ..*self
        };
        (grown.slope < 1.0).then_some(grown)
    }

    /// Exact parameter interval where the ray is inside the sphere-cone: the hull of the two
    /// end balls and the points of the lateral cone tangent to both.
    #[must_use]
    pub fn ray_interval(&self, ray: &Ray) -> Option<Interval> {
        self.seen_from(ray.origin).ray_interval(ray.direction)
    }

    /// What [`SphereCone::ray_interval`] computes alike for every ray from `origin`
    /// (the rays of a tile share their origin).
    #[must_use]
    pub fn seen_from(&self, origin: DVec3) -> ConeFromOrigin {
        let d = self.slope;
        let w0 = origin - self.start;
        let a0 = w0.dot(self.axis);
        let b0 = w0.length_squared() - a0 * a0;
        let e = 1.0 - d * d;
        let y0 = self.radius + d * a0;
        let end = origin - self.end();
        let end_radius = self.end_radius();
        ConeFromOrigin {
            axis: self.axis,
            length: self.length,
            radius: self.radius,
            slope: d,
            w0,
            start_c: w0.length_squared() - self.radius * self.radius,
            end,
            end_c: end.length_squared() - end_radius * end_radius,
            a0,
            e,
            y0,
            qc: e * b0 - y0 * y0,
        }
    }
}

/// A [`SphereCone`] seen from a ray origin `o`: the terms of [`ConeFromOrigin::ray_interval`]
/// that do not depend on the ray's direction.
#[derive(Clone, Copy, Debug)]
pub struct ConeFromOrigin {
    axis: DVec3,
    length: f64,
    radius: f64,
    slope: f64,
    /// `o − start`, and `|o − start|² − r₀²`: the start ball's [`ball_interval_from`] terms.
    w0: DVec3,
    start_c: f64,
    /// `o − end`, and `|o − end|² − r₁²`: the end ball's.
    end: DVec3,
    end_c: f64,
    /// The lateral surface's: the origin's axial coordinate `a₀`, `e = 1 − δ²`,
    /// `y₀ = r₀ + δ·a₀`, and the quadratic's constant term.
    a0: f64,
    e: f64,
    y0: f64,
    qc: f64,
}

impl ConeFromOrigin {
    /// [`SphereCone::ray_interval`] of the ray from the origin along `direction`.
    #[must_use]
    pub fn ray_interval(&self, direction: DVec3) -> Option<Interval> {
        let mut hull: Option<Interval> = None;
        let mut add = |i: Interval| hull = Some(hull.map_or(i, |h| h.hull(i)));
        if let Some(i) = ball_interval_from(self.w0, self.start_c, direction) {
            add(i);
        }
        if let Some(i) = ball_interval_from(self.end, self.end_c, direction) {
            add(i);
        }
        // Lateral surface: (1 − δ²)·b²(t) = (r₀ + δ·a(t))², a = axial coordinate,
        // b = distance to the axis; valid where the tangent skeleton point
        // s* = (a + δ r₀)/(1 − δ²) lies on the segment.
        let (d, a0, e, y0) = (self.slope, self.a0, self.e, self.y0);
        let a1 = direction.dot(self.axis);
        let b1 = 2.0 * (self.w0.dot(direction) - a0 * a1);
        let b2 = 1.0 - a1 * a1;
        let qa = e * b2 - d * d * a1 * a1;
        let qb = e * b1 - 2.0 * d * a1 * y0;
        if let Some((r1, r2)) = quadratic_roots(qa, qb, self.qc) {
            for t in [r1, r2] {
                let a = a0 + a1 * t;
                let s = (a + d * self.radius) / e;
                if self.radius + d * a > 0.0 && (0.0..=self.length).contains(&s) {
                    add(Interval::point(t));
                }
            }
        }
        hull
    }
}

/// Distances from a chord `[a, b]` to pieces `[s₀, s₁]` of a line `start + s·axis` (`|axis| = 1`),
/// for the per-piece bounds of a SCALIS segment along a ray: the products that do not depend on
/// the piece are formed once, and each piece costs two clamps and one distance.
///
/// `g(s) = dist(start + s·axis, [a, b])²` is convex (a jointly convex function minimised over the
/// chord's parameter), so its minimum over `[s₀, s₁]` is at the clamp of its minimiser over the
/// whole line, `s*`, the projection onto the line of the chord point closest to it.
#[derive(Clone, Copy, Debug)]
pub struct ChordToAxis {
    chord_start: DVec3,
    chord: DVec3,
    /// `1/|b − a|²`, 0 for a point chord.
    inv_chord_sq: f64,
    /// `(start − a)·(b − a)` and `axis·(b − a)`: the projection of `start + s·axis` onto the chord
    /// is at `(start_along + s·axis_along)·inv_chord_sq`.
    start_along: f64,
    axis_along: f64,
    line_start: DVec3,
    axis: DVec3,
    /// The line's parameter closest to the chord.
    closest: f64,
}

impl ChordToAxis {
    /// The chord `[a, b]` and the line `start + s·axis`.
    #[must_use]
    pub fn new(a: DVec3, b: DVec3, start: DVec3, axis: DVec3) -> Self {
        let chord = b - a;
        let chord_sq = chord.length_squared();
        let from_start = a - start;
        let axis_along = axis.dot(chord);
        // Chord point a + t·chord; its projection on the line is at from_start·axis + t·axis_along,
        // and its squared distance to the line is a quadratic in t with leading coefficient
        // chord_sq − axis_along² ≥ 0 (Cauchy–Schwarz). Parallel or point chords: any t.
        let across = chord_sq - axis_along * axis_along;
        let t = if across > 0.0 {
            ((axis_along * from_start.dot(axis) - from_start.dot(chord)) / across).clamp(0.0, 1.0)
        } else {
            0.0
        };
        Self {
            chord_start: a,
            chord,
            inv_chord_sq: if chord_sq > 0.0 { 1.0 / chord_sq } else { 0.0 },
            start_along: -from_start.dot(chord),
            axis_along,
            line_start: start,
            axis,
            closest: from_start.dot(axis) + t * axis_along,
        }
    }

    /// Smallest squared distance between the chord and the line's piece `[s0, s1]` (`s0 ≤ s1`).
    #[must_use]
    #[inline]
    pub fn distance_sq_to_piece(&self, s0: f64, s1: f64) -> f64 {
        let s = self.closest.clamp(s0, s1);
        let t = ((self.start_along + s * self.axis_along) * self.inv_chord_sq).clamp(0.0, 1.0);
        ((self.line_start + s * self.axis) - (self.chord_start + t * self.chord)).length_squared()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The oracle: closest distance squared between segments (Ericson, Real-Time Collision
    /// Detection §5.1.9).
    fn segment_segment_distance_sq(p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3) -> f64 {
        let d1 = p1 - p0;
        let d2 = q1 - q0;
        let r = p0 - q0;
        let a = d1.length_squared();
        let e = d2.length_squared();
        let f = d2.dot(r);
        let (s, t);
        if a <= f64::EPSILON && e <= f64::EPSILON {
            return r.length_squared();
        }
        if a <= f64::EPSILON {
            s = 0.0;
            t = (f / e).clamp(0.0, 1.0);
        } else {
            let c = d1.dot(r);
            if e <= f64::EPSILON {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else {
                let b = d1.dot(d2);
                let denom = a * e - b * b;
                let s0 = if denom > 0.0 {
                    ((b * f - c * e) / denom).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let t0 = (b * s0 + f) / e;
                if t0 < 0.0 {
                    t = 0.0;
                    s = (-c / a).clamp(0.0, 1.0);
                } else if t0 > 1.0 {
                    t = 1.0;
                    s = ((b - c) / a).clamp(0.0, 1.0);
                } else {
                    t = t0;
                    s = s0;
                }
            }
        }
        ((p0 + s * d1) - (q0 + t * d2)).length_squared()
    }

    #[test]
    fn chord_to_axis_distances_match_the_segment_segment_distance() {
        let mut rng = crate::model::rng::SplitMix64::new(0x5eed);
        let mut next = || rng.range(-1.0, 1.0);
        for case in 0..20_000 {
            let mut point = || DVec3::new(next(), next(), next()) * 3.0;
            let (a, start) = (point(), point());
            // Every tenth chord is a point, every tenth else parallel to the axis.
            let axis = point().normalize();
            let b = match case % 10 {
                0 => a,
                1 => a + axis * 1.7,
                _ => point(),
            };
            let chord = ChordToAxis::new(a, b, start, axis);
            let (s0, s1) = (next() * 2.0, next() * 2.0);
            let (s0, s1) = (s0.min(s1), s0.max(s1));
            let expected = segment_segment_distance_sq(a, b, start + s0 * axis, start + s1 * axis);
            let got = chord.distance_sq_to_piece(s0, s1);
            assert!(
                (got - expected).abs() <= 1e-12 * (1.0 + expected),
                "case {case}: {got} vs {expected}"
            );
        }
    }

    /// On random boxes of every scale and place: the snapped box contains the box, its
    /// corners are whole multiples of one power of two between 1/32 and 1/16 of the box's
    /// diagonal, its diagonal is at most `1 + 2√3/16` times the box's, and a box grown or
    /// moved within the snapped box's cells (the same power) snaps to the same box.
    #[test]
    fn snapped_boxes_contain_the_box_and_stay_put_within_their_cells() {
        let mut rng = crate::model::rng::SplitMix64::new(0x9a1d);
        let mut unchanged_after_a_nudge = 0;
        for case in 0..20_000 {
            let scale = 10f64.powf(rng.range(-4.0, 4.0));
            let corner = DVec3::new(
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
            );
            let size = DVec3::new(
                rng.range(0.0, 1.0),
                rng.range(0.0, 1.0),
                rng.range(0.05, 1.0),
            );
            let b = Aabb {
                min: corner * scale,
                max: (corner + size) * scale,
            };
            let s = b.snapped_to_grid();
            let d = b.diagonal();
            assert!(
                s.min.cmple(b.min).all() && s.max.cmpge(b.max).all(),
                "case {case}"
            );
            assert!(s.diagonal() <= d * (1.0 + 2.0 * 3f64.sqrt() / 16.0) * (1.0 + 1e-12));
            let cell = (s.max - b.max).max(b.min - s.min).max_element();
            let power = (d / 16.0).log2().floor().exp2();
            assert!(
                power > d / 32.0 && power <= d / 16.0 && cell < power,
                "case {case}"
            );
            for corner in [s.min, s.max] {
                for c in corner.to_array() {
                    assert_eq!((c / power).fract(), 0.0, "case {case}: {c} by {power}");
                }
            }
            // The top face raised by a thousandth of the diagonal.
            let nudged = Aabb {
                max: b.max + DVec3::Y * 1e-3 * d,
                ..b
            };
            let same_power = (nudged.diagonal() / 16.0).log2().floor().exp2() == power;
            if same_power && nudged.max.y <= s.max.y {
                assert_eq!(nudged.snapped_to_grid(), s, "case {case}");
                unchanged_after_a_nudge += 1;
            }
        }
        assert!(
            unchanged_after_a_nudge > 15_000,
            "{unchanged_after_a_nudge}"
        );
        assert_eq!(Aabb::EMPTY.snapped_to_grid(), Aabb::EMPTY);
    }

    #[test]
    fn sphere_cone_interval_matches_sampled_membership() {
        let cone = SphereCone {
            start: DVec3::new(0.1, -0.2, 0.0),
            axis: DVec3::new(1.0, 0.3, -0.2).normalize(),
            length: 2.0,
            radius: 0.3,
            slope: 0.4,
        };
        let inside = |p: DVec3| {
            (0..=4000).any(|i| {
                let s = cone.length * f64::from(i) / 4000.0;
                (p - (cone.start + s * cone.axis)).length() <= cone.radius + cone.slope * s
            })
        };
        let mut state = 12345_u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..200 {
            let o = DVec3::new(next(), next(), next()) * 3.0;
            let ray = Ray::new(o, DVec3::new(next(), next(), next()));
            let interval = cone.ray_interval(&ray);
            for k in 0..200 {
                let t = -6.0 + 12.0 * f64::from(k) / 200.0;
                let p = ray.at(t);
                let claimed = interval.is_some_and(|i| i.contains(t));
                if claimed != inside(p) {
                    // Allow disagreement only within sampling resolution of the boundary.
                    let near = interval
                        .is_some_and(|i| (t - i.lo).abs() < 2e-3 || (t - i.hi).abs() < 2e-3);
                    assert!(near, "t = {t}, claimed {claimed}, interval {interval:?}");
                }
            }
        }
    }
}

/// A similarity `p ↦ s·R·p + t` (uniform scale, rotation, translation): the group transforms of
/// the 2014 notes (§11.5), applied to primitives when a scene is compiled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    /// Uniform scale `s > 0`.
    pub scale: f64,
    /// Rotation `R` (orthonormal, determinant 1).
    pub rotation: DMat3,
    /// Translation `t`.
    pub translation: DVec3,
}

impl Similarity {
    /// The identity.
    pub const IDENTITY: Self = Self {
        scale: 1.0,
        rotation: DMat3::IDENTITY,
        translation: DVec3::ZERO,
    };

    /// Image of a point.
    #[must_use]
    pub fn point(&self, p: DVec3) -> DVec3 {
        self.scale * (self.rotation * p) + self.translation
    }

    /// Image of a direction (unit vectors stay unit).
    #[must_use]
    pub fn direction(&self, v: DVec3) -> DVec3 {
        self.rotation * v
    }

    /// The point that maps to `p`.
    #[must_use]
    pub fn inverse_point(&self, p: DVec3) -> DVec3 {
        self.rotation.transpose() * (p - self.translation) / self.scale
    }

    /// The direction that maps to `v` (unit vectors stay unit).
    #[must_use]
    pub fn inverse_direction(&self, v: DVec3) -> DVec3 {
        self.rotation.transpose() * v
    }

    /// `self` after `first`: `p ↦ self(first(p))`.
    #[must_use]
    pub fn after(&self, first: &Self) -> Self {
        Self {
            scale: self.scale * first.scale,
            rotation: self.rotation * first.rotation,
            translation: self.point(first.translation),
        }
    }
}
