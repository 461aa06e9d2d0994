//! Ray statistics with the scalis 2021 protocol (§8, "Statistics"): rays along the six axis
//! directions, origins uniform on the faces of the scene's support bounding box, equally many per
//! direction. Every method traces the same rays in opaque mode and is compared with the reference
//! tracer: a *missed* ray has a reference crossing that the method finds too late or not at all, a
//! *spurious* one a method crossing the reference does not have (or one found too early); both use
//! a tolerance of 10⁻³ of the box diagonal, and the depth error of the remaining hits is reported
//! separately, relative to the diagonal.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::bounds::interval::Interval;
use crate::field::geometry::Ray;
use crate::field::program::FieldProgram;
use crate::json;
use crate::methods::{self, Method, TraceMode, TraceSettings};
use crate::model::rng::SplitMix64;

/// Statistics of one method.
#[derive(Clone, Debug, PartialEq)]
pub struct MethodStats {
    /// Method name.
    pub name: String,
    /// Rays traced.
    pub rays: usize,
    /// Rays with a crossing.
    pub hits: usize,
    /// Rays whose reference crossing the method missed.
    pub missed: usize,
    /// Rays with a crossing the reference does not have.
    pub spurious: usize,
    /// Mean steps per ray.
    pub avg_steps: f64,
    /// Mean point evaluations of the field per ray (value and gradient count as one): the
    /// measure that compares methods whose steps differ in cost (a SCALIS iteration, a bisection
    /// leaf, a confirmation past a root).
    pub avg_evaluations: f64,
    /// Median steps per ray.
    pub median_steps: u32,
    /// 95th percentile of steps per ray.
    pub p95_steps: u32,
    /// Largest steps per ray.
    pub max_steps: u32,
    /// Mean time per ray, in nanoseconds (single thread).
    pub ns_per_ray: f64,
    /// Largest depth error of the matched hits, relative to the box diagonal.
    pub max_depth_error: f64,
}

/// Statistics of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneStats {
    /// Scene name.
    pub scene: String,
    /// Rays per method.
    pub rays: usize,
    /// One entry per method.
    pub methods: Vec<MethodStats>,
}

/// The protocol's rays: `count` rays, a sixth per axis direction, with their intervals across
/// the support box.
#[must_use]
pub fn protocol_rays(program: &FieldProgram, count: usize, seed: u64) -> Vec<(Ray, Interval)> {
    let b = program.support_bounds();
    let extent = b.max - b.min;
    let mut rng = SplitMix64::new(seed);
    (0..count)
        .map(|i| {
            let axis = (i % 6) / 2;
            let positive = i % 2 == 0;
            let mut origin = b.min + extent * DVec3::new(rng.unit(), rng.unit(), rng.unit());
            let mut direction = DVec3::ZERO;
            origin[axis] = if positive { b.min[axis] } else { b.max[axis] };
            direction[axis] = if positive { 1.0 } else { -1.0 };
            (Ray { origin, direction }, Interval::new(0.0, extent[axis]))
        })
        .collect()
}

/// Traces the protocol's rays with each method; `progress` is called with the method name and
/// the fraction done.
#[must_use]
pub fn run(
    program: &FieldProgram,
    scene_name: &str,
    chosen: &[Box<dyn Method>],
    rays: usize,
    seed: u64,
    progress: &(dyn Fn(&str, f64) + Sync),
) -> SceneStats {
    let settings = TraceSettings::for_program(program);
    let diagonal = program.support_bounds().diagonal();
    let tolerance = 1e-3 * diagonal;
    let rays = protocol_rays(program, rays, seed);
    let reference_method = methods::Reference;
    let reference_tracer = reference_method.prepare(program, settings);
    progress("reference", 0.0);
    let reference: Vec<Option<f64>> = rays
        .par_iter()
        .map(|(ray, span)| {
            reference_tracer
                .trace(ray, *span, TraceMode::Opaque)
                .first()
                .map(|c| c.t)
        })
        .collect();
    let mut out = Vec::new();
    for method in chosen {
        let tracer = method.prepare(program, settings);
        let done = std::sync::atomic::AtomicUsize::new(0);
        let results: Vec<(Option<f64>, u32, u128, u32)> = rays
            .par_iter()
            .map(|(ray, span)| {
                let start = Instant::now();
                let trace = tracer.trace(ray, *span, TraceMode::Opaque);
                let elapsed = start.elapsed().as_nanos();
                let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                if n.is_multiple_of(4096) {
                    progress(method.name(), n as f64 / rays.len() as f64);
                }
                (
                    trace.first().map(|c| c.t),
                    trace.steps,
                    elapsed,
                    trace.evaluations,
                )
            })
            .collect();
        let mut steps: Vec<u32> = results.iter().map(|r| r.1).collect();
        steps.sort_unstable();
        let mut stats = MethodStats {
            name: method.name().to_owned(),
            rays: rays.len(),
            hits: 0,
            missed: 0,
            spurious: 0,
            avg_steps: steps.iter().map(|&s| f64::from(s)).sum::<f64>() / steps.len().max(1) as f64,
            avg_evaluations: results.iter().map(|r| f64::from(r.3)).sum::<f64>()
                / results.len().max(1) as f64,
            median_steps: percentile(&steps, 0.5),
            p95_steps: percentile(&steps, 0.95),
            max_steps: steps.last().copied().unwrap_or(0),
            ns_per_ray: results.iter().map(|r| r.2 as f64).sum::<f64>() / rays.len().max(1) as f64,
            max_depth_error: 0.0,
        };
        for ((got, _, _, _), want) in results.iter().zip(&reference) {
            stats.hits += usize::from(got.is_some());
            match (want, got) {
                (Some(w), Some(g)) if *g > w + tolerance => stats.missed += 1,
                (Some(w), Some(g)) if *g < w - tolerance => stats.spurious += 1,
                (Some(w), Some(g)) => {
                    stats.max_depth_error = stats.max_depth_error.max((g - w).abs() / diagonal);
                }
                (Some(_), None) => stats.missed += 1,
                (None, Some(_)) => stats.spurious += 1,
                (None, None) => {}
            }
        }
        progress(method.name(), 1.0);
        out.push(stats);
    }
    SceneStats {
        scene: scene_name.to_owned(),
        rays: rays.len(),
        methods: out,
    }
}

fn percentile(sorted: &[u32], q: f64) -> u32 {
    if sorted.is_empty() {
        return 0;
    }
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}

impl SceneStats {
    /// The DESIGN.md JSON schema.
    #[must_use]
    pub fn to_json(&self) -> String {
        let methods: Vec<String> = self
            .methods
            .iter()
            .map(|m| {
                format!(
                    "{{\"name\": {}, \"rays\": {}, \"hits\": {}, \"missed\": {}, \"spurious\": {}, \
                     \"avg_steps\": {}, \"avg_evaluations\": {}, \"median_steps\": {}, \
                     \"p95_steps\": {}, \"max_steps\": {}, \"ns_per_ray\": {}, \
                     \"max_depth_error\": {}}}",
                    json::string(&m.name),
                    m.rays,
                    m.hits,
                    m.missed,
                    m.spurious,
                    json::number(m.avg_steps),
                    json::number(m.avg_evaluations),
                    m.median_steps,
                    m.p95_steps,
                    m.max_steps,
                    json::number(m.ns_per_ray),
                    json::number(m.max_depth_error)
                )
            })
            .collect();
        format!(
            "{{\"scene\": {}, \"rays\": {}, \"methods\": [\n  {}\n]}}\n",
            json::string(&self.scene),
            self.rays,
            methods.join(",\n  ")
        )
    }

    /// A fixed-width table for the terminal (and the results page).
    #[must_use]
    pub fn to_table(&self) -> String {
        let mut out = String::from(
            "| method | hits | missed | spurious | avg steps | avg evaluations | median | p95 | max | ns/ray | max depth error |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        for m in &self.methods {
            out.push_str(&format!(
                "| {} | {} | {} | {} | {:.2} | {:.2} | {} | {} | {} | {:.0} | {:.1e} |\n",
                m.name,
                m.hits,
                m.missed,
                m.spurious,
                m.avg_steps,
                m.avg_evaluations,
                m.median_steps,
                m.p95_steps,
                m.max_steps,
                m.ns_per_ray,
                m.max_depth_error
            ));
        }
        out
    }
}
