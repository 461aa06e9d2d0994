//! Ray statistics with the scalis 2021 protocol (§8, "Statistics"): rays along the six axis
//! directions, origins uniform on the faces of the scene's support bounding box, equally many per
//! direction; under `--protocol paper-2023` random rays around the box instead
//! ([`rays_around_box`]), as the forward-inclusion paper's tables use. Every method traces the same rays in opaque mode and is compared with the reference
//! tracer: every reference crossing is *found* (within the tolerance), *late* (found beyond it,
//! but before the reference's next crossing: a depth error, reported) or *skipped* (never
//! reported: the missed isosurface crossing the papers speak of); a ray is *skipped* when one of
//! its crossings is, *late* when one is late and none skipped, and *missed* when either. A
//! *spurious* ray has a method crossing the reference does not have (or one found too early); all use
//! a tolerance of 10⁻⁴ of the diagonal of the scale box ([`TOLERANCE`]; the support box snapped
//! to its grid, `FieldProgram::scale_bounds`, which the trace settings' `min_step` follows too),
//! and the depth error of the remaining hits is reported separately, relative to that diagonal.
//!
//! Transparent statistics (forward-inclusion 2023, Tables 3–4) trace every crossing, match them
//! in order with the reference's, and count a ray's steps (and evaluations) up to the one that
//! found its last crossing (all of them when it has none), as the paper counts them.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::bounds::interval::Interval;
use crate::field::geometry::Ray;
use crate::field::program::FieldProgram;
use crate::methods::{self, Crossing, Method, Protocol, TraceMode, TraceSettings};
use crate::model::rng::SplitMix64;

/// Statistics of one method; serialised with DESIGN.md's field names (NaN and infinities as
/// `null`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MethodStats {
    /// Method name.
    pub name: String,
    /// Rays traced.
    pub rays: usize,
    /// Rays with a crossing.
    pub hits: usize,
    /// Rays compared with the reference tracer: every ray on the CPU, the first ones on the
    /// GPU (the reference runs on the CPU); `missed` and `spurious` count among them.
    pub compared: usize,
    /// Rays with a reference crossing the method found late or never: `skipped + late`.
    pub missed: usize,
    /// Rays with a reference crossing the method never reported (the papers' missed crossing).
    pub skipped: usize,
    /// Rays whose crossings were all found, one or more beyond the tolerance but before the
    /// reference's next crossing.
    pub late: usize,
    /// Largest depth error of a late crossing, relative to the box diagonal (0 without one).
    pub max_late_error: f64,
    /// Rays with a crossing the reference does not have.
    pub spurious: usize,
    /// Mean steps per ray.
    pub avg_steps: f64,
    /// Mean point evaluations of the field per ray (value and gradient count as one): the
    /// measure that compares methods whose steps differ in cost (a SCALIS iteration, a bisection
    /// leaf, a confirmation past a root). Not counted on the GPU (NaN, `null` in JSON).
    pub avg_evaluations: f64,
    /// Median steps per ray.
    pub median_steps: u32,
    /// 95th percentile of steps per ray.
    pub p95_steps: u32,
    /// Largest steps per ray.
    pub max_steps: u32,
    /// Rays that spent the whole step budget ([`TraceSettings::max_steps`]) without finishing:
    /// opaque, without a crossing; transparent, before the end of their span (or exactly at
    /// it). The method gave up on them, whatever the step columns say (in transparent mode
    /// they count steps to the last crossing found, not the steps spent after it).
    pub out_of_steps: usize,
    /// Mean time per ray, in nanoseconds: one CPU thread's, or on the GPU the batches' wall
    /// time over their rays.
    pub ns_per_ray: f64,
    /// Largest depth error of the matched hits, relative to the scale box's diagonal.
    pub max_depth_error: f64,
}

/// Statistics of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneStats {
    /// Scene name.
    pub scene: String,
    /// Rays per method.
    pub rays: usize,
    /// Settings profile.
    pub protocol: Protocol,
    /// Opaque or transparent rays.
    pub mode: TraceMode,
    /// One entry per method.
    pub methods: Vec<MethodStats>,
}

/// The protocol's rays: `count` rays, a sixth per axis direction, with their intervals across
/// the support box.
#[must_use]
pub fn protocol_rays(program: &FieldProgram, count: usize, seed: u64) -> Vec<(Ray, Interval)> {
    rays_of_iter(program, Protocol::Default, seed)
        .take(count)
        .collect()
}

/// Random rays around the support box (forward-inclusion 2023, Tables 1, 3 and 4: "random
/// rays around the bounding box"): origins uniform on the sphere around the box, each aimed at
/// a uniform point inside it; the interval is the part of the ray inside the box.
#[must_use]
pub fn rays_around_box(program: &FieldProgram, count: usize, seed: u64) -> Vec<(Ray, Interval)> {
    rays_of_iter(program, Protocol::Paper2023, seed)
        .take(count)
        .collect()
}

/// The rays of a profile's statistics: around the box for the forward-inclusion paper, along
/// the six axis directions ([`protocol_rays`]) otherwise.
#[must_use]
pub fn rays_of(
    program: &FieldProgram,
    protocol: Protocol,
    count: usize,
    seed: u64,
) -> Vec<(Ray, Interval)> {
    rays_of_iter(program, protocol, seed).take(count).collect()
}

/// The rays of [`rays_of`], one at a time (the GPU's statistics take millions, in batches).
pub fn rays_of_iter(
    program: &FieldProgram,
    protocol: Protocol,
    seed: u64,
) -> impl Iterator<Item = (Ray, Interval)> + use<> {
    let b = program.support_bounds();
    let extent = b.max - b.min;
    let mut rng = SplitMix64::new(seed);
    let around = protocol == Protocol::Paper2023;
    let (center, radius) = (b.center(), 0.5 * b.diagonal());
    (0_usize..).filter_map(move |i| {
        if around {
            let origin = center + DVec3::from_array(rng.direction()) * radius;
            let target = b.min + extent * DVec3::new(rng.unit(), rng.unit(), rng.unit());
            let direction = (target - origin).try_normalize()?;
            let ray = Ray { origin, direction };
            let span = b.ray_interval(&ray, Interval::new(0.0, f64::INFINITY))?;
            return Some((ray, span));
        }
        let axis = (i % 6) / 2;
        let positive = i % 2 == 0;
        let mut origin = b.min + extent * DVec3::new(rng.unit(), rng.unit(), rng.unit());
        let mut direction = DVec3::ZERO;
        origin[axis] = if positive { b.min[axis] } else { b.max[axis] };
        direction[axis] = if positive { 1.0 } else { -1.0 };
        Some((Ray { origin, direction }, Interval::new(0.0, extent[axis])))
    })
}

/// What `stats` traces: how many rays from which seed, under which settings profile, opaque or
/// transparent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StatsSetup {
    /// Rays per method.
    pub rays: usize,
    /// Seed of the ray origins.
    pub seed: u64,
    /// Settings profile ([`Protocol`]).
    pub protocol: Protocol,
    /// Opaque (first crossing) or transparent (every crossing).
    pub mode: TraceMode,
}

impl StatsSetup {
    /// `rays` opaque rays from `seed` under the default profile.
    #[must_use]
    pub fn opaque(rays: usize, seed: u64) -> Self {
        Self {
            rays,
            seed,
            protocol: Protocol::Default,
            mode: TraceMode::Opaque,
        }
    }
}

/// Tolerance of the comparison with the reference, relative to the scale box's diagonal: the
/// same fraction as `TraceSettings::min_step`, which bounds how early a confirmed crossing may
/// be reported.
pub const TOLERANCE: f64 = 1e-4;

/// What one method did on every ray, before it is summarised ([`MethodStats::of`]).
#[derive(Clone, Debug, Default)]
pub struct MethodTally {
    /// Steps per ray (counted to the last crossing in transparent mode).
    pub steps: Vec<u32>,
    /// Point evaluations over all rays, where they are counted.
    pub evaluations: Option<u64>,
    /// Rays with a crossing.
    pub hits: usize,
    /// Rays that spent the step budget without finishing ([`MethodStats::out_of_steps`]).
    pub out_of_steps: usize,
    /// Nanoseconds over all rays.
    pub nanoseconds: f64,
}

impl MethodStats {
    /// The statistics of `name` from its tally and the comparison of its crossings with the
    /// reference's, `(reference, method)` per compared ray; depth errors relative to the box
    /// `diagonal`.
    pub fn of<'a>(
        name: &str,
        mut tally: MethodTally,
        compared: impl Iterator<Item = (Reference<'a>, &'a [Crossing])>,
        diagonal: f64,
    ) -> Self {
        tally.steps.sort_unstable();
        let steps = &tally.steps;
        let count = steps.len().max(1) as f64;
        let mut stats = MethodStats {
            name: name.to_owned(),
            rays: steps.len(),
            hits: tally.hits,
            compared: 0,
            missed: 0,
            skipped: 0,
            late: 0,
            max_late_error: 0.0,
            spurious: 0,
            avg_steps: steps.iter().map(|&s| f64::from(s)).sum::<f64>() / count,
            avg_evaluations: tally.evaluations.map_or(f64::NAN, |e| e as f64 / count),
            median_steps: percentile(steps, 0.5),
            p95_steps: percentile(steps, 0.95),
            max_steps: steps.last().copied().unwrap_or(0),
            out_of_steps: tally.out_of_steps,
            ns_per_ray: tally.nanoseconds / count,
            max_depth_error: 0.0,
        };
        let tolerance = TOLERANCE * diagonal;
        for (reference, got) in compared {
            let verdict = compare(reference, got, tolerance);
            stats.compared += 1;
            stats.skipped += usize::from(verdict.skipped);
            stats.late += usize::from(verdict.late && !verdict.skipped);
            stats.missed += usize::from(verdict.skipped || verdict.late);
            stats.max_late_error = stats.max_late_error.max(verdict.late_error / diagonal);
            stats.spurious += usize::from(verdict.spurious);
            stats.max_depth_error = stats.max_depth_error.max(verdict.depth_error / diagonal);
        }
        stats
    }
}

/// The reference tracer's crossings along `rays` (in parallel).
///
/// # Errors
/// A ray on which the reference spent its whole step budget
/// ([`methods::REFERENCE_STEP_BUDGET`]): its crossings would not be the truth the statistics
/// compare with.
pub fn reference_crossings(
    program: &FieldProgram,
    settings: TraceSettings,
    rays: &[(Ray, Interval)],
    mode: TraceMode,
) -> Result<Vec<Vec<Crossing>>, String> {
    let tracer = methods::Reference.prepare(program, settings);
    rays.par_iter()
        .enumerate()
        .map(|(k, (ray, span))| {
            let trace = tracer.trace(ray, *span, mode);
            if trace.steps >= methods::REFERENCE_STEP_BUDGET {
                return Err(format!(
                    "the reference tracer spent its budget of {} steps on ray {k} (from {:?} \
                     along {:?}) without finishing; the field is degenerate along it",
                    methods::REFERENCE_STEP_BUDGET,
                    ray.origin.to_array(),
                    ray.direction.to_array()
                ));
            }
            Ok(trace.crossings.into_vec())
        })
        .collect()
}

/// One traced ray, as the statistics need it.
struct Outcome {
    crossings: Vec<Crossing>,
    steps: u32,
    evaluations: u32,
    out_of_steps: bool,
    nanoseconds: u128,
}

/// Whether a ray traced in `mode` that took `steps` of a budget of `max_steps` and found
/// `crossings` stopped because the budget was spent ([`MethodStats::out_of_steps`]).
#[must_use]
pub fn ran_out_of_steps(mode: TraceMode, steps: u32, max_steps: u32, crossings: usize) -> bool {
    steps >= max_steps && (mode == TraceMode::Transparent || crossings == 0)
}

/// Traces the protocol's rays with each method; `progress` is called with the method name and
/// the fraction done.
///
/// # Errors
/// As [`reference_crossings`].
pub fn run(
    program: &FieldProgram,
    scene_name: &str,
    chosen: &[Box<dyn Method>],
    setup: StatsSetup,
    progress: &(dyn Fn(&str, f64) + Sync),
) -> Result<SceneStats, String> {
    let settings = TraceSettings::for_protocol(program, setup.protocol);
    let diagonal = program.scale_bounds().diagonal();
    let rays = rays_of(program, setup.protocol, setup.rays, setup.seed);
    progress("reference", 0.0);
    // Every crossing, whatever the mode: an opaque method's late hit is told from a skipped
    // crossing by the reference's next one.
    let reference = reference_crossings(program, settings, &rays, TraceMode::Transparent)?;
    let mut out = Vec::new();
    for method in chosen {
        let tracer = method.prepare(program, settings);
        let done = std::sync::atomic::AtomicUsize::new(0);
        let results: Vec<Outcome> = rays
            .par_iter()
            .map(|(ray, span)| {
                let start = Instant::now();
                let trace = tracer.trace(ray, *span, setup.mode);
                let nanoseconds = start.elapsed().as_nanos();
                let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                if n.is_multiple_of(4096) {
                    progress(method.name(), n as f64 / rays.len() as f64);
                }
                let (steps, evaluations) = match setup.mode {
                    TraceMode::Transparent if !trace.crossings.is_empty() => (
                        trace.steps_to_last_crossing,
                        trace.evaluations_to_last_crossing,
                    ),
                    _ => (trace.steps, trace.evaluations),
                };
                Outcome {
                    steps,
                    evaluations,
                    out_of_steps: ran_out_of_steps(
                        setup.mode,
                        trace.steps,
                        settings.max_steps,
                        trace.crossings.len(),
                    ),
                    nanoseconds,
                    crossings: trace.crossings.into_vec(),
                }
            })
            .collect();
        let tally = MethodTally {
            steps: results.iter().map(|r| r.steps).collect(),
            evaluations: Some(results.iter().map(|r| u64::from(r.evaluations)).sum()),
            hits: results.iter().filter(|r| !r.crossings.is_empty()).count(),
            out_of_steps: results.iter().filter(|r| r.out_of_steps).count(),
            nanoseconds: results.iter().map(|r| r.nanoseconds as f64).sum(),
        };
        let compared = reference
            .iter()
            .zip(&results)
            .map(|(all, got)| (Reference::of(all, setup.mode), got.crossings.as_slice()));
        progress(method.name(), 1.0);
        out.push(MethodStats::of(method.name(), tally, compared, diagonal));
    }
    Ok(SceneStats {
        scene: scene_name.to_owned(),
        rays: rays.len(),
        protocol: setup.protocol,
        mode: setup.mode,
        methods: out,
    })
}

/// A ray's reference crossings as a method in `mode` is compared with them: every crossing
/// (transparent), or the first (opaque), with the reference's next crossing after those, which
/// bounds how late a crossing may be found before it is skipped.
#[derive(Clone, Copy, Debug)]
pub struct Reference<'a> {
    /// The crossings the method must find.
    pub want: &'a [Crossing],
    /// The reference's next crossing after the last of `want`, if any.
    pub next: Option<f64>,
    /// Every crossing of the reference: a method crossing at one of them is not spurious, even
    /// where it is not one the method had to find (an opaque hit on the far side of a part
    /// whose entry it skipped).
    pub all: &'a [Crossing],
}

impl<'a> Reference<'a> {
    /// The crossings of `all` (the reference traced in transparent mode) a method in `mode`
    /// must find.
    #[must_use]
    pub fn of(all: &'a [Crossing], mode: TraceMode) -> Self {
        match mode {
            TraceMode::Transparent => Self {
                want: all,
                next: None,
                all,
            },
            TraceMode::Opaque => Self {
                want: &all[..all.len().min(1)],
                next: all.get(1).map(|c| c.t),
                all,
            },
        }
    }
}

/// One ray's method crossings against the reference's.
struct Verdict {
    /// A reference crossing the method never reported.
    skipped: bool,
    /// A reference crossing the method found beyond the tolerance, before the next one.
    late: bool,
    /// Largest depth error of the late crossings.
    late_error: f64,
    /// A method crossing the reference does not have, or one found early.
    spurious: bool,
    /// Largest depth error of the matched crossings.
    depth_error: f64,
}

/// Matches crossings in order: each reference crossing with the first unmatched method crossing
/// of the same direction within `tolerance`. A pair of crossings closer than `tolerance` (a
/// graze through a sliver of the volume, or of the outside, thinner than the tolerance) may be
/// missing from either list without counting. A reference crossing left unmatched is late when
/// an unmatched method crossing of its direction lies after it and before the reference's next
/// crossing, skipped otherwise. In opaque mode both lists hold one crossing at most, and a
/// method crossing early is spurious.
fn compare(reference: Reference<'_>, got: &[Crossing], tolerance: f64) -> Verdict {
    let want = reference.want;
    let mut verdict = Verdict {
        skipped: false,
        late: false,
        late_error: 0.0,
        spurious: false,
        depth_error: 0.0,
    };
    let mut used = vec![false; got.len()];
    let mut matched = vec![false; want.len()];
    for (j, w) in want.iter().enumerate() {
        let found = got.iter().enumerate().position(|(i, g)| {
            !used[i] && g.entering == w.entering && (g.t - w.t).abs() <= tolerance
        });
        if let Some(i) = found {
            used[i] = true;
            matched[j] = true;
            verdict.depth_error = verdict.depth_error.max((got[i].t - w.t).abs());
        }
    }
    if want.len() == 1 && got.len() == 1 && !matched[0] && got[0].t < want[0].t {
        // Opaque: one crossing each, found early: spurious.
        verdict.spurious = true;
        return verdict;
    }
    for j in unmatched_outside_slivers(want, &matched, tolerance) {
        let w = want[j];
        let next = want.get(j + 1).map_or(reference.next, |n| Some(n.t));
        let late = got.iter().enumerate().position(|(i, g)| {
            !used[i] && g.entering == w.entering && g.t > w.t && next.is_none_or(|n| g.t < n)
        });
        match late {
            Some(i) => {
                used[i] = true;
                verdict.late = true;
                verdict.late_error = verdict.late_error.max(got[i].t - w.t);
            }
            None => verdict.skipped = true,
        }
    }
    let at_a_reference_crossing = |g: &Crossing| {
        reference
            .all
            .iter()
            .any(|r| r.entering == g.entering && (r.t - g.t).abs() <= tolerance)
    };
    verdict.spurious = unmatched_outside_slivers(got, &used, tolerance)
        .into_iter()
        .any(|i| reference.want.len() == reference.all.len() || !at_a_reference_crossing(&got[i]));
    verdict
}

/// The unmatched crossings of `crossings` that are not one of an unmatched pair closer than
/// `tolerance`.
fn unmatched_outside_slivers(
    crossings: &[Crossing],
    matched: &[bool],
    tolerance: f64,
) -> Vec<usize> {
    (0..crossings.len())
        .filter(|&i| {
            let sliver_with = |j: usize| {
                !matched[j]
                    && crossings[j].entering != crossings[i].entering
                    && (crossings[j].t - crossings[i].t).abs() <= tolerance
            };
            let in_sliver =
                (i > 0 && sliver_with(i - 1)) || (i + 1 < crossings.len() && sliver_with(i + 1));
            !matched[i] && !in_sliver
        })
        .collect()
}

fn percentile(sorted: &[u32], q: f64) -> u32 {
    if sorted.is_empty() {
        return 0;
    }
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}

impl SceneStats {
    /// A fixed-width table for the terminal (and the results page).
    #[must_use]
    pub fn to_table(&self) -> String {
        let mut out = String::from(
            "| method | hits | skipped | late | spurious | avg steps | avg evaluations | median | p95 | max | out of steps | ns/ray | max depth error |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        for m in &self.methods {
            out.push_str(&format!(
                "| {} | {} | {} | {} | {} | {:.2} | {} | {} | {} | {} | {} | {:.0} | {:.1e} |\n",
                m.name,
                m.hits,
                m.skipped,
                m.late,
                m.spurious,
                m.avg_steps,
                if m.avg_evaluations.is_finite() {
                    format!("{:.2}", m.avg_evaluations)
                } else {
                    "–".to_owned()
                },
                m.median_steps,
                m.p95_steps,
                m.max_steps,
                m.out_of_steps,
                m.ns_per_ray,
                m.max_depth_error
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::{
        Crossing, MethodStats, MethodTally, Reference, TraceMode, compare, ran_out_of_steps,
    };

    /// A ray is out of steps when it spent the budget: opaque, only without a crossing (one
    /// found on the last step finished the ray); transparent, with or without crossings.
    #[test]
    fn rays_out_of_steps_spent_the_budget_unfinished() {
        let (opaque, transparent) = (TraceMode::Opaque, TraceMode::Transparent);
        assert!(ran_out_of_steps(opaque, 2048, 2048, 0));
        assert!(!ran_out_of_steps(opaque, 2048, 2048, 1));
        assert!(!ran_out_of_steps(opaque, 2047, 2048, 0));
        assert!(ran_out_of_steps(transparent, 2048, 2048, 3));
        assert!(ran_out_of_steps(transparent, 2048, 2048, 0));
        assert!(!ran_out_of_steps(transparent, 12, 2048, 2));
    }

    fn crossings(list: &[(f64, bool)]) -> Vec<Crossing> {
        list.iter()
            .map(|&(t, entering)| Crossing { t, entering })
            .collect()
    }

    fn all(want: &[Crossing]) -> Reference<'_> {
        Reference::of(want, TraceMode::Transparent)
    }

    fn first(want: &[Crossing]) -> Reference<'_> {
        Reference::of(want, TraceMode::Opaque)
    }

    #[test]
    fn crossings_match_in_order_and_slivers_thinner_than_the_tolerance_may_merge() {
        let want = crossings(&[(1.0, true), (2.0, false), (2.00005, true), (3.0, false)]);
        // The sliver pair at 2 is merged: neither missed nor spurious.
        let merged = crossings(&[(1.00002, true), (3.0, false)]);
        let v = compare(all(&want), &merged, 1e-4);
        assert!(!v.skipped && !v.late && !v.spurious);
        assert!((v.depth_error - 2e-5).abs() < 1e-12);
        // A real pair left out is skipped; an extra one is spurious.
        let short = crossings(&[(1.0, true), (2.0, false)]);
        let v = compare(all(&want), &short, 1e-4);
        assert!(v.skipped && !v.late);
        let extra = crossings(&[(0.5, true), (0.6, false), (1.0, true), (3.0, false)]);
        let v = compare(all(&want), &extra, 1e-4);
        assert!(v.spurious && !v.skipped && !v.late);
        // A direction mismatch never matches.
        let v = compare(first(&want), &crossings(&[(1.0, false)]), 1e-4);
        assert!(v.skipped);
    }

    /// The papers' missed crossing is one never reported; one found past the tolerance but
    /// before the reference's next crossing is late, with its error, and not spurious.
    #[test]
    fn a_late_crossing_is_told_from_a_skipped_one() {
        let want = crossings(&[(1.0, true), (2.0, false), (3.0, true), (4.0, false)]);
        // Opaque: a hit at 1.1 is late (before the exit at 2); at 3.0 it is the next part's
        // entry: the first part was skipped, and the hit, a real crossing, is not spurious;
        // at 2.5 there is no crossing: skipped and spurious.
        let v = compare(first(&want), &crossings(&[(1.1, true)]), 1e-4);
        assert!(v.late && !v.skipped && !v.spurious);
        assert!((v.late_error - 0.1).abs() < 1e-12);
        let v = compare(first(&want), &crossings(&[(3.0, true)]), 1e-4);
        assert!(v.skipped && !v.late && !v.spurious);
        let v = compare(first(&want), &crossings(&[(2.5, true)]), 1e-4);
        assert!(v.skipped && v.spurious);
        // Early is spurious, never late or skipped.
        let v = compare(first(&want), &crossings(&[(0.9, true)]), 1e-4);
        assert!(v.spurious && !v.late && !v.skipped);
        // Transparent: the exit found late, before the next entry; the second part skipped.
        let got = crossings(&[(1.0, true), (2.5, false)]);
        let v = compare(all(&want), &got, 1e-4);
        assert!(v.late && v.skipped && !v.spurious);
        assert!((v.late_error - 0.5).abs() < 1e-12);
        // The statistics count such a ray as skipped (and missed), not late.
        let stats = MethodStats::of(
            "m",
            MethodTally {
                steps: vec![1, 1],
                evaluations: None,
                hits: 2,
                out_of_steps: 0,
                nanoseconds: 0.0,
            },
            [(all(&want), got.as_slice()), (all(&want[..2]), &got[..0])].into_iter(),
            1.0,
        );
        assert_eq!((stats.skipped, stats.late, stats.missed), (2, 0, 2));
    }
}
