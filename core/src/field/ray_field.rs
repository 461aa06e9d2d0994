//! The field restricted to one ray, with the ray's candidate primitives gathered once.
//!
//! A tracer asks the field many questions along one ray: the value and derivative at each step,
//! a bound over the next interval, the supports it crosses. Asked of the [`FieldProgram`], each
//! walks the BVH again, though the primitives a ray can meet do not change along it. A
//! [`RayField`] walks the BVH once per ray, keeping every primitive whose (slightly widened)
//! box meets the ray on the traced span (widened by a margin for the steps that look just past
//! it), with that box's interval on the ray's line and the primitive's exact support interval;
//! each question then scans that short list with interval tests. Once a ray has asked many
//! point questions (sphere tracing), its candidates are binned along the ray so that each
//! question scans only its bin. A question outside the gathered reach goes to the program.
//! The candidates are kept one array per field (structure of arrays), and a point question
//! tests a box only where the ray's parameter lies in that box's (widened) interval on the ray;
//! the arrays are recycled from ray to ray on each thread, so that a ray allocates nothing.
//! Camera rays take their candidates from their screen tile's list ([`TileCandidates`]), which
//! holds what the tile's rays share: the differences between their origin and each box's
//! corners, each point blob's centre and each segment's sphere-cone (its end balls' and lateral
//! surface's terms), so that a ray's tests are a few products each.
//!
//! The answers are bit for bit those of the program's own queries: the list keeps the BVH's
//! depth-first order (which every program query follows), a point query keeps exactly the items
//! whose box contains the point, and an interval query exactly those whose box and support meet
//! the interval (the slab test clipped to a span equals the line's slab interval intersected with
//! it, `max`/`min` being exact). Left out are only the primitives whose support the ray's line
//! misses by more than rounding (`Primitive::zero_on_line`; for a tile, by one side of its beam,
//! `Beam::misses_hull`): at every point of the ray they are exactly 0 with a zero gradient, terms
//! that leave any sum unchanged, and they meet no interval query. So the marches, their step
//! counts and depths are unchanged; `tests/ray_field.rs` compares the two on every asset and
//! checks the left-out primitives' zeros on lines tangent to their supports.

use std::cell::{Cell, OnceCell};

use glam::DVec3;

use crate::bounds::interval::{Interval, Jet};
use crate::field::bvh::{Beam, NearRay, near_slab_interval};
use crate::field::geometry::{
    Aabb, ConeFromOrigin, RELATIVE_SUPPORT_MARGIN, Ray, ball_interval_from, rounding_margin,
    slab_interval,
};
use crate::field::kernel::KernelProfile;
use crate::field::primitives::{PointBlob, Primitive};
use crate::field::program::{FieldProgram, PointLookup, PrimitiveSlope, RayLookup, SupportSpan};
use crate::scratch::{Scratch, ScratchPool};

/// The primitives the ray may meet, one array per field (structure of arrays: a question's
/// scan reads only what its test needs), in the BVH's depth-first order, the unbounded
/// primitives (planes) last.
#[derive(Debug, Default)]
struct Candidates {
    primitive: Vec<u32>,
    /// Where the ray's line is inside the candidate's widened box, within the reach (the whole
    /// line for an unbounded primitive): a point `ray.at(t)` inside the box has `t` here, so a
    /// point question tests the box only where this holds `t`.
    near: Vec<Interval>,
    /// The support boxes of the first `bounded` candidates, for point questions.
    boxes: Vec<Aabb>,
    bounded: usize,
    /// The box's interval on the ray's line (the whole line for an unbounded primitive).
    line: Vec<Interval>,
    /// The exact support's interval on the line ([`NO_SUPPORT`] where the line misses it).
    support: Vec<Interval>,
}

/// An empty interval: its intersection with any interval is empty.
const NO_SUPPORT: Interval = Interval {
    lo: f64::INFINITY,
    hi: f64::NEG_INFINITY,
};

thread_local! {
    /// Candidate arrays of rays whose fields were dropped, reused by the next rays of the thread:
    /// no allocation per ray once they have grown.
    static SPARE: ScratchPool<Candidates> = const { ScratchPool::new() };
}

impl Scratch for Candidates {
    fn clear(&mut self) {
        self.primitive.clear();
        self.near.clear();
        self.boxes.clear();
        self.line.clear();
        self.support.clear();
        self.bounded = 0;
    }
}

impl Candidates {
    /// Empty arrays, recycled from a dropped field of this thread where there is one.
    fn recycled() -> Self {
        ScratchPool::take(&SPARE)
    }

    fn len(&self) -> usize {
        self.primitive.len()
    }

    #[inline]
    fn push(&mut self, primitive: u32, near: Interval, line: Interval, support: Option<Interval>) {
        self.primitive.push(primitive);
        self.near.push(near);
        self.line.push(line);
        self.support.push(support.unwrap_or(NO_SUPPORT));
    }

    /// Whether candidate `i`'s box contains `p = ray.at(t)`.
    #[inline]
    fn contains(&self, i: usize, t: f64, p: DVec3) -> bool {
        self.near[i].contains(t) && (i >= self.bounded || self.boxes[i].contains(p))
    }

    /// Candidate `i`'s support on `span`, if its box and its support meet the ray there.
    #[inline]
    fn on(&self, i: usize, span: Interval) -> Option<Interval> {
        let line = self.line[i];
        if line.lo.max(span.lo) <= line.hi.min(span.hi) {
            self.support[i].intersect(span)
        } else {
            None
        }
    }
}

/// The field along one ray; see the module documentation.
pub struct RayField<'a> {
    program: &'a FieldProgram,
    ray: Ray,
    /// The interval it was built for.
    span: Interval,
    /// The part of the ray the candidates cover.
    reach: Interval,
    candidates: Candidates,
    /// Built once the ray has asked [`CELLS_AFTER`] point questions.
    cells: OnceCell<Cells>,
    point_questions: Cell<u32>,
}

/// Widening of every box in the candidate tests: it absorbs the rounding of `ray.at(t)`
/// against the slab test, so that a point question's box containing the point is in the list;
/// measured on `FieldProgram::scale_bounds`, so that it is the same after an edit within them.
fn pad_of(program: &FieldProgram) -> f64 {
    let b = program.scale_bounds();
    if b.is_empty() {
        0.0
    } else {
        1e-9 * (b.diagonal() + b.min.abs().max(b.max.abs()).max_element())
    }
}

/// The part of the ray a field gathered for `span` covers: a margin either side for the steps
/// that look just past it.
fn reach_of(span: Interval) -> Interval {
    let margin = 1e-3 * (1.0 + span.width());
    Interval {
        lo: span.lo - margin,
        hi: span.hi + margin,
    }
}

/// The candidates of a bundle of rays from one origin — a screen tile's camera rays — on one
/// span: every primitive whose box may meet one of them, in the BVH's depth-first order, with
/// its box (the CPU twin of the GPU's tile binning, `render/shaders/binning.wgsl`).
/// One BVH walk per tile instead of one per ray; [`RayField::from_tile`] filters it per ray.
#[derive(Debug)]
pub struct TileCandidates {
    span: Interval,
    origin: DVec3,
    items: Vec<TileItem>,
    /// The segments' sphere-cones ([`TileSupport::Cone`]).
    cones: Vec<TileCone>,
}

/// One primitive of a tile's list, with what every ray from the tile's origin computes alike
/// from it: the differences of the slab tests and, for a ball-shaped support, of
/// the ball's. The per-ray tests take them as the program's queries compute them, bit for bit.
#[derive(Debug)]
struct TileItem {
    primitive: u32,
    bounds: Aabb,
    /// [`NearRay::offsets`] of the box.
    near: (DVec3, DVec3),
    /// `bounds.min − o`, `bounds.max − o`: the unwidened slab test's differences.
    line: (DVec3, DVec3),
    /// The support, seen from the origin, where it is a ball or a sphere-cone.
    support: TileSupport,
}

/// A tile item's support seen from the tile's origin, for the per-ray tests of
/// [`RayField::from_tile`].
#[derive(Debug)]
enum TileSupport {
    /// A point blob's support ball.
    Ball(TileBall),
    /// A segment's: the index of its [`TileCone`] in the tile's `cones` (kept apart, so that
    /// the items stay small).
    Cone(u32),
    /// Another primitive's: the per-ray tests of [`Sieve::kept`].
    Other,
}

/// A segment's support sphere-cone seen from a tile's origin, and for a SCALIS segment the cone
/// grown by the margin of [`crate::field::primitives::ScalisSegment::line_misses_support`] for
/// the tile's farthest reach (as [`TileBall::miss_sq`]); `grown` is `None` where the primitive
/// is never left out (a distance segment, or a grown cone past the sphere-cone limit).
#[derive(Debug)]
struct TileCone {
    support: ConeFromOrigin,
    grown: Option<ConeFromOrigin>,
}

impl TileCone {
    fn new(origin: DVec3, primitive: &Primitive, k: &KernelProfile, t_max: f64) -> Option<Self> {
        match primitive {
            Primitive::Distance(segment) => Some(Self {
                support: segment.support(k).seen_from(origin),
                grown: None,
            }),
            Primitive::Scalis(segment) => Some(Self {
                support: segment.support(k).seen_from(origin),
                grown: segment
                    .support_grown_for_reach(origin, k, 2.0 * t_max)
                    .map(|cone| cone.seen_from(origin)),
            }),
            _ => None,
        }
    }

    /// The support's interval on the line along `direction`, and whether the primitive is
    /// kept: `None` where the line misses the grown cone (as [`Sieve::kept`]).
    #[inline]
    fn kept(&self, direction: DVec3) -> Option<Option<Interval>> {
        let on_line = self.support.ray_interval(direction);
        let misses = || {
            self.grown
                .as_ref()
                .is_some_and(|g| g.ray_interval(direction).is_none())
        };
        (on_line.is_some() || !misses()).then_some(on_line)
    }
}

/// A point blob's support ball (centre `c`, radius `r`) seen from a tile's origin `o`.
#[derive(Debug)]
struct TileBall {
    /// `o − c`.
    oc: DVec3,
    /// `|o − c|² − r²`: with `oc`, [`ball_interval`]'s terms.
    c: f64,
    /// `(r + m)²`, `m` the margin of [`PointBlob::line_misses_support`] for the tile's
    /// farthest reach along any unit direction (`|u|₁ ≤ √3 < 2`): no smaller than the margin
    /// of any of the tile's rays.
    miss_sq: f64,
}

impl TileBall {
    fn new(origin: DVec3, blob: &PointBlob, k: &KernelProfile, t_max: f64) -> Self {
        let oc = origin - blob.center;
        let radius = blob.support_radius(k);
        let margin =
            RELATIVE_SUPPORT_MARGIN * radius + rounding_margin(origin, blob.center, 2.0 * t_max);
        Self {
            oc,
            c: oc.length_squared() - radius * radius,
            miss_sq: (radius + margin) * (radius + margin),
        }
    }

    /// The ball's interval on the line along `direction`, as [`ball_interval`] gives it.
    #[inline]
    fn interval(&self, direction: DVec3) -> Option<Interval> {
        ball_interval_from(self.oc, self.c, direction)
    }

    /// Whether the line along `direction` misses the ball by the margin, so that the blob is
    /// zero on it (as [`PointBlob::line_misses_support`] decides with its own margin).
    #[inline]
    fn line_misses(&self, direction: DVec3) -> bool {
        let across = (-self.oc).cross(direction).length_squared() / direction.length_squared();
        across > self.miss_sq
    }
}

impl TileCandidates {
    /// The primitives of the list, in its order.
    pub fn primitives(&self) -> impl Iterator<Item = u32> + '_ {
        self.items.iter().map(|item| item.primitive)
    }

    /// The candidates of the rays from `origin` whose directions lie in the cone over the
    /// quadrilateral `corners` (in order around it; for a tile, the directions through its
    /// outer pixel corners, half a pixel outside the pixel centres), on `span`.
    #[must_use]
    pub fn gather(
        program: &FieldProgram,
        origin: DVec3,
        corners: [DVec3; 4],
        span: Interval,
    ) -> Self {
        let reach = reach_of(span);
        let behind = (-reach.lo).max(0.0);
        let beam = Beam::new(origin, corners, pad_of(program), behind);
        // A primitive whose support every ray of the tile misses by more than rounding is zero
        // on them all (see `Sieve::zero_on_ray`): left out here once for the tile's rays.
        let reach_length = reach.lo.abs().max(reach.hi.abs());
        let zero_on_tile = |i: u32| {
            let Some(balls) = program.primitives()[i as usize].support_hull(program.kernel_of(i))
            else {
                return false;
            };
            let margin = RELATIVE_SUPPORT_MARGIN * balls[0].1.max(balls[1].1)
                + rounding_margin(origin, balls[0].0, reach_length).max(rounding_margin(
                    origin,
                    balls[1].0,
                    reach_length,
                ));
            beam.misses_hull(balls, margin)
        };
        let pad = pad_of(program);
        let mut items = Vec::new();
        let mut cones = Vec::new();
        program
            .lookup_parts()
            .0
            .for_each_in_beam(&beam, |i, bounds| {
                if zero_on_tile(i) {
                    return;
                }
                let (primitive, k) = (&program.primitives()[i as usize], program.kernel_of(i));
                let support = if let Primitive::Point(blob) = primitive {
                    TileSupport::Ball(TileBall::new(origin, blob, k, reach_length))
                } else if let Some(cone) = TileCone::new(origin, primitive, k, reach_length) {
                    cones.push(cone);
                    TileSupport::Cone(cones.len() as u32 - 1)
                } else {
                    TileSupport::Other
                };
                items.push(TileItem {
                    primitive: i,
                    bounds: *bounds,
                    near: NearRay::offsets(origin, pad, bounds),
                    line: (bounds.min - origin, bounds.max - origin),
                    support,
                });
            });
        Self {
            span,
            origin,
            items,
            cones,
        }
    }

    /// Primitives in the list.
    #[must_use]
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether no primitive's box may meet the bundle.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }
}

/// Point questions on one ray after which its candidates are binned: the marches that take a
/// handful of steps never pay for the bins, sphere tracing's hundreds of steps do once.
const CELLS_AFTER: u32 = 32;

/// The candidates binned along the ray, so that a question about a point or a short interval
/// scans only the candidates near it (sphere tracing asks hundreds of point questions per ray):
/// cell `k` covers `[start + k·width, start + (k + 1)·width)` and lists, in the candidates'
/// order, those whose box interval on the line, widened by `slack`, overlaps it. A question
/// that straddles cells scans every candidate.
#[derive(Debug, Default)]
struct Cells {
    start: f64,
    width: f64,
    /// `items[offsets[k]..offsets[k + 1]]` are cell `k`'s candidates.
    offsets: Vec<u32>,
    items: Vec<u32>,
}

/// Most cells per ray; about one per two candidates below that.
const MAX_CELLS: usize = 32;

impl Cells {
    fn new(candidates: &Candidates, reach: Interval) -> Self {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for near in &candidates.near[..candidates.bounded] {
            lo = lo.min(near.lo);
            hi = hi.max(near.hi);
        }
        let (lo, hi) = (lo.max(reach.lo), hi.min(reach.hi));
        let count = (candidates.len() / 2).min(MAX_CELLS);
        let spread = lo < hi;
        if !spread || count < 2 {
            return Self::default();
        }
        let width = (hi - lo) / count as f64;
        // Clamped to be non-negative first, the cast truncates as `floor` does (a library call
        // on the baseline x86-64 target). A candidate's `near` holds every point question's
        // `t` that may find it and, within the reach, its box's interval on the line; the cell
        // of a parameter grows with it, so the cells a question looks at list the candidate.
        let last = (count - 1) as f64;
        let range = |near: &Interval| {
            let cell = |t: f64| ((t - lo) / width).clamp(0.0, last) as usize;
            cell(near.lo)..=cell(near.hi)
        };
        let mut offsets = vec![0_u32; count + 1];
        for near in &candidates.near {
            for k in range(near) {
                offsets[k + 1] += 1;
            }
        }
        for k in 0..count {
            offsets[k + 1] += offsets[k];
        }
        let mut fill = offsets.clone();
        let mut items = vec![0_u32; offsets[count] as usize];
        for (i, near) in candidates.near.iter().enumerate() {
            for k in range(near) {
                items[fill[k] as usize] = i as u32;
                fill[k] += 1;
            }
        }
        Self {
            start: lo,
            width,
            offsets,
            items,
        }
    }

    /// The cell holding every candidate that may matter on `[a, b]`, if one does.
    fn cell(&self, a: f64, b: f64) -> Option<&[u32]> {
        let count = self.offsets.len().checked_sub(1)?;
        let end = self.start + self.width * count as f64;
        let inside = a >= self.start && b < end;
        if !inside {
            return None;
        }
        // Both non-negative: the casts truncate as `floor` does.
        let k = ((a - self.start) / self.width) as usize;
        if k != ((b - self.start) / self.width) as usize || k >= count {
            return None;
        }
        Some(&self.items[self.offsets[k] as usize..self.offsets[k + 1] as usize])
    }
}

/// The per-primitive tests of a ray's gathering.
struct Sieve<'p> {
    program: &'p FieldProgram,
    ray: &'p Ray,
    /// The farthest the reach goes from the origin, in ray parameter.
    t_max: f64,
}

impl<'p> Sieve<'p> {
    fn new(program: &'p FieldProgram, ray: &'p Ray, reach: Interval) -> Self {
        Self {
            program,
            ray,
            t_max: reach.lo.abs().max(reach.hi.abs()),
        }
    }

    /// Primitive `i`'s support on the ray's line, where the ray's fields keep the primitive;
    /// `None` where they leave it out: the line misses the support, by more than rounding
    /// ([`Sieve::zero_on_ray`]).
    fn kept(&self, i: u32) -> Option<Option<Interval>> {
        let on_line = self.support(i);
        (on_line.is_some() || !self.zero_on_ray(i)).then_some(on_line)
    }

    /// Primitive `i`'s support on the ray's line.
    fn support(&self, i: u32) -> Option<Interval> {
        self.program.primitives()[i as usize].support_interval(self.ray, self.program.kernel_of(i))
    }

    /// Whether the ray's line misses primitive `i`'s support by more than rounding: it is then
    /// zero at every point question and meets no interval question, so it is left out and no
    /// answer changes (its terms would be `±0`).
    fn zero_on_ray(&self, i: u32) -> bool {
        self.program.primitives()[i as usize].zero_on_line(
            self.ray,
            self.program.kernel_of(i),
            self.t_max,
        )
    }
}

impl<'a> RayField<'a> {
    /// Gathers the candidates of `ray` on `span` from `program` (one BVH traversal).
    #[must_use]
    pub fn new(program: &'a FieldProgram, ray: &Ray, span: Interval) -> Self {
        let reach = reach_of(span);
        let sieve = Sieve::new(program, ray, reach);
        let inv = ray.direction.recip();
        let mut candidates = Candidates::recycled();
        let (bvh, _) = program.lookup_parts();
        bvh.for_each_near(
            &NearRay::new(ray, reach, pad_of(program)),
            |i, bounds, near| {
                let Some(on_line) = sieve.kept(i) else {
                    return;
                };
                let line = bounds
                    .ray_interval_with(ray, inv, Interval::ENTIRE)
                    .unwrap_or(NO_SUPPORT);
                candidates.push(i, near, line, on_line);
                candidates.boxes.push(*bounds);
            },
        );
        Self::with_candidates(program, &sieve, (span, reach), candidates)
    }

    /// Whether every field of `ray` on `span` over `program` answers as if primitive `i` were
    /// not there: the ray's line misses its support by more than rounding (the test that
    /// leaves a primitive out of [`RayField::new`]; [`RayField::from_tile`] leaves out fewer
    /// point blobs, whose terms are then `±0` and change no answer).
    #[must_use]
    pub fn leaves_out(program: &FieldProgram, ray: &Ray, span: Interval, i: u32) -> bool {
        Sieve::new(program, ray, reach_of(span)).kept(i).is_none()
    }

    /// As [`RayField::new`] for a ray of the bundle `tile` was gathered for: the tile's list
    /// filtered by the BVH walk's own test on each box, which gives the walk's candidates in
    /// its order (a box the ray meets has every enclosing node's box met too), so every
    /// question is answered bit for bit as by [`RayField::new`]. The tests take the
    /// differences the tile computed once for its rays, with the arithmetic of the walk's.
    #[must_use]
    pub fn from_tile(
        program: &'a FieldProgram,
        ray: &Ray,
        span: Interval,
        tile: &TileCandidates,
    ) -> Self {
        debug_assert!(
            tile.span == span,
            "a tile list serves the span it was gathered for"
        );
        debug_assert!(
            ray.origin == tile.origin,
            "a tile list serves the rays from its origin"
        );
        let reach = reach_of(span);
        let sieve = Sieve::new(program, ray, reach);
        let inv = ray.direction.recip();
        let mut candidates = Candidates::recycled();
        for item in &tile.items {
            let (low, high) = item.near;
            let Some(near) = near_slab_interval(low * inv, high * inv, reach) else {
                continue;
            };
            let kept = match &item.support {
                TileSupport::Ball(ball) => {
                    let on_line = ball.interval(ray.direction);
                    (on_line.is_some() || !ball.line_misses(ray.direction)).then_some(on_line)
                }
                TileSupport::Cone(cone) => tile.cones[*cone as usize].kept(ray.direction),
                TileSupport::Other => sieve.kept(item.primitive),
            };
            let Some(on_line) = kept else {
                continue;
            };
            let (low, high) = item.line;
            let line = slab_interval(low * inv, high * inv, Interval::ENTIRE).unwrap_or(NO_SUPPORT);
            candidates.push(item.primitive, near, line, on_line);
            candidates.boxes.push(item.bounds);
        }
        Self::with_candidates(program, &sieve, (span, reach), candidates)
    }

    /// The field with `candidates` holding the bounded candidates, in the BVH's order; the
    /// unbounded ones are added after them.
    /// `sieve` and `reach` are those the candidates were gathered with, for `span`.
    fn with_candidates(
        program: &'a FieldProgram,
        sieve: &Sieve,
        (span, reach): (Interval, Interval),
        mut candidates: Candidates,
    ) -> Self {
        let (_, unbounded) = program.lookup_parts();
        candidates.bounded = candidates.len();
        for &i in unbounded {
            candidates.push(i, Interval::ENTIRE, Interval::ENTIRE, sieve.support(i));
        }
        Self {
            program,
            ray: *sieve.ray,
            span,
            reach,
            candidates,
            cells: OnceCell::new(),
            point_questions: Cell::new(0),
        }
    }

    fn covers(&self, span: Interval) -> bool {
        self.reach.lo <= span.lo && span.hi <= self.reach.hi
    }

    /// The interval of the ray it was built for.
    #[must_use]
    pub fn span(&self) -> Interval {
        self.span
    }

    /// The program.
    #[must_use]
    pub fn program(&self) -> &'a FieldProgram {
        self.program
    }

    /// The ray.
    #[must_use]
    pub fn ray(&self) -> &Ray {
        &self.ray
    }

    /// `(f(t), f′(t))`, as [`FieldProgram::along_ray`].
    #[must_use]
    pub fn along(&self, t: f64) -> (f64, f64) {
        if !self.reach.contains(t) {
            return self.program.along_ray(&self.ray, t);
        }
        let (v, g) = self.value_gradient(t);
        (v, g.dot(self.ray.direction))
    }

    /// Value and gradient at `ray.at(t)`, as [`FieldProgram::value_gradient`] there (the
    /// shading normal at a crossing, without a BVH walk).
    #[must_use]
    pub fn value_gradient(&self, t: f64) -> (f64, DVec3) {
        let p = self.ray.at(t);
        if !self.reach.contains(t) {
            return self.program.value_gradient(p);
        }
        self.program.value_gradient_in(&AtParameter(self, t), p)
    }

    /// `f(t)`: bit for bit the value of [`RayField::along`], without the derivative.
    #[must_use]
    pub fn value(&self, t: f64) -> f64 {
        if !self.reach.contains(t) {
            return self.program.along_ray(&self.ray, t).0;
        }
        self.program.value_in(&AtParameter(self, t), self.ray.at(t))
    }

    /// As [`FieldProgram::ray_jet`].
    #[must_use]
    pub fn jet(&self, span: Interval) -> Jet {
        if !self.covers(span) {
            return self.program.ray_jet(&self.ray, span);
        }
        self.program.ray_jet_in(self, &self.ray, span)
    }

    /// As [`FieldProgram::ray_group_jets`].
    #[must_use]
    pub fn group_jets(&self, span: Interval) -> Vec<Jet> {
        let mut slots = vec![Jet::ZERO; self.program.group_count()];
        self.add_group_jets(span, &mut slots);
        slots
    }

    /// [`RayField::group_jets`] added into `slots` (one per group, zero): no allocation.
    pub(crate) fn add_group_jets(&self, span: Interval, slots: &mut [Jet]) {
        if self.covers(span) {
            self.program
                .accumulate_group_jets(self, &self.ray, span, slots);
        } else {
            self.program
                .accumulate_ray_group_jets(&self.ray, span, slots);
        }
    }

    /// As [`FieldProgram::group_values_along_ray`].
    #[must_use]
    pub fn group_values(&self, t: f64) -> Vec<(f64, f64)> {
        let mut slots = vec![(0.0, 0.0); self.program.group_count()];
        self.add_group_values(t, &mut slots);
        slots
    }

    /// [`RayField::group_values`] added into `slots` (one per group, zero): no allocation.
    pub(crate) fn add_group_values(&self, t: f64, slots: &mut [(f64, f64)]) {
        if self.reach.contains(t) {
            self.program
                .group_values_in(&AtParameter(self, t), &self.ray, t, slots);
        } else {
            self.program
                .group_values_in(self.program, &self.ray, t, slots);
        }
    }

    /// As [`FieldProgram::summed_lipschitz`].
    #[must_use]
    pub fn summed_lipschitz(&self, span: Interval, slope: PrimitiveSlope) -> f64 {
        if !self.covers(span) {
            return self.program.summed_lipschitz(&self.ray, span, slope);
        }
        self.program
            .summed_lipschitz_in(self, &self.ray, span, slope)
    }

    /// As [`FieldProgram::for_each_primitive_on_ray`].
    pub fn for_each_primitive(
        &self,
        span: Interval,
        visit: impl FnMut(usize, &Primitive, &KernelProfile, Interval),
    ) {
        if !self.covers(span) {
            return self
                .program
                .for_each_primitive_on_ray(&self.ray, span, visit);
        }
        self.program.for_each_primitive_in(self, span, visit);
    }

    /// As [`FieldProgram::ray_supports`].
    #[must_use]
    pub fn supports(&self, span: Interval) -> Vec<SupportSpan> {
        if !self.covers(span) {
            return self.program.ray_supports(&self.ray, span);
        }
        self.program.ray_supports_in(self, span)
    }

    /// As [`FieldProgram::ray_support_unions`], into `parts` (cleared first).
    pub fn support_unions_into(&self, span: Interval, parts: &mut Vec<Interval>) {
        if self.covers(span) {
            self.program
                .ray_support_unions_in(self, &self.ray, span, parts);
        } else {
            *parts = self.program.ray_support_unions(&self.ray, span);
        }
    }
}

impl Drop for RayField<'_> {
    fn drop(&mut self) {
        ScratchPool::give_back(&SPARE, std::mem::take(&mut self.candidates));
    }
}

impl RayField<'_> {
    /// The candidates' indices in one cell covering `[a, b]`, once the cells are built.
    fn cell(&self, a: f64, b: f64) -> Option<&[u32]> {
        self.cells.get().and_then(|cells| cells.cell(a, b))
    }
}

/// Point queries at `ray.at(t)`.
struct AtParameter<'b, 'a>(&'b RayField<'a>, f64);

impl PointLookup for AtParameter<'_, '_> {
    fn near(&self, p: DVec3, mut visit: impl FnMut(u32)) {
        let field = self.0;
        let asked = field.point_questions.get() + 1;
        field.point_questions.set(asked);
        if asked == CELLS_AFTER {
            field
                .cells
                .get_or_init(|| Cells::new(&field.candidates, field.reach));
        }
        let (t, candidates) = (self.1, &field.candidates);
        if let Some(cell) = field.cell(t, t) {
            for &i in cell {
                if candidates.contains(i as usize, t, p) {
                    visit(candidates.primitive[i as usize]);
                }
            }
        } else {
            for i in 0..candidates.len() {
                if candidates.contains(i, t, p) {
                    visit(candidates.primitive[i]);
                }
            }
        }
    }
}

impl RayLookup for RayField<'_> {
    fn on_ray(&self, span: Interval, mut visit: impl FnMut(u32, Interval)) {
        let candidates = &self.candidates;
        if let Some(cell) = self.cell(span.lo, span.hi) {
            for &i in cell {
                if let Some(s) = candidates.on(i as usize, span) {
                    visit(candidates.primitive[i as usize], s);
                }
            }
        } else {
            for i in 0..candidates.len() {
                if let Some(s) = candidates.on(i, span) {
                    visit(candidates.primitive[i], s);
                }
            }
        }
    }
}
