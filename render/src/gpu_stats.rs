//! `stats --backend gpu`: the statistics protocol's rays (core `stats.rs`: the
//! six axis directions, or random rays around the box under `paper-2023`) traced on the GPU in
//! batches of a million, so that the papers' ten million rays per method take seconds. The
//! screen tiles of a frame do not apply to these rays; [`RayLists`] gives each ray its
//! candidate primitives instead (`ray_lists.rs`). The reference tracer runs on the CPU, on
//! the first rays of the same sequence, and every method is compared with it there; steps are
//! counted over every ray. Transparent statistics (forward-inclusion 2023, Tables 3–4: every
//! crossing of each ray, steps counted to the last one) run on the GPU for every method, each
//! march going on past a crossing as its core method does (main.wgsl `crossing_ends_march`),
//! each ray keeping up to [`CROSSING_SLOTS`] crossings. The GPU counts no evaluations.

use std::sync::Arc;
use std::time::Instant;

use skeletrace_core::backend::BackendError;
use skeletrace_core::bounds::interval::Interval;
use skeletrace_core::compile::Compiled;
use skeletrace_core::field::geometry::Ray;
use skeletrace_core::methods::{Crossing, TraceMode, TraceSettings};
use skeletrace_core::stats::{
    MethodStats, MethodTally, Reference, SceneStats, StatsSetup, ran_out_of_steps, rays_of_iter,
    reference_crossings,
};

use crate::gpu_renderer::GpuRenderer;
use crate::ray_lists::{CROSSING_SLOTS, GpuStatsRay, RayCrossings, RayLists};
use crate::shaders::GpuMethod;

/// Rays per GPU batch.
const BATCH: usize = 1 << 20;
/// Rays per GPU batch in transparent statistics, whose rays carry [`CROSSING_SLOTS`] depths.
const TRANSPARENT_BATCH: usize = 1 << 17;

/// Traces `setup.rays` protocol rays with each of `methods` on `renderer`'s GPU and compares
/// the first `compared` of them with the reference tracer on the CPU; `progress` is called
/// with the method's name and the fraction done.
///
/// # Errors
/// [`BackendError::Unsupported`] for a method the GPU does not run on the scene, or in
/// transparent mode a ray with more
/// than [`CROSSING_SLOTS`] crossings; a device failure.
pub fn run(
    renderer: &mut GpuRenderer,
    compiled: &Arc<Compiled>,
    scene_name: &str,
    methods: &[GpuMethod],
    (setup, compared): (StatsSetup, usize),
    progress: &dyn Fn(&str, f64),
) -> Result<SceneStats, BackendError> {
    let transparent = setup.mode == TraceMode::Transparent;
    renderer.set_scene(compiled)?;
    let program = &compiled.program;
    let settings = TraceSettings::for_protocol(program, setup.protocol);
    let bounds = program.support_bounds();
    let lists = RayLists::new(renderer.packed_primitives(), bounds.min, bounds.max);
    let uploaded = renderer.upload_ray_lists(&lists);
    let sample: Vec<(Ray, Interval)> = rays_of_iter(program, setup.protocol, setup.seed)
        .take(compared.min(setup.rays))
        .collect();
    progress("reference", 0.0);
    // Every crossing, whatever the mode (core stats.rs `Reference`).
    let reference = reference_crossings(program, settings, &sample, TraceMode::Transparent)
        .map_err(BackendError::Unsupported)?;
    // An opaque ray's first crossing enters the volume unless the ray starts inside it
    // (transparent rays bring each crossing's direction from the GPU).
    let entering: Vec<bool> = if transparent {
        Vec::new()
    } else {
        sample
            .iter()
            .map(|(ray, span)| program.value(ray.at(span.lo)) < program.isovalue())
            .collect()
    };
    let mut out = Vec::with_capacity(methods.len());
    for &method in methods {
        let mut tally = MethodTally {
            steps: Vec::with_capacity(setup.rays),
            evaluations: None,
            hits: 0,
            out_of_steps: 0,
            nanoseconds: 0.0,
        };
        let mut found: Vec<Vec<Crossing>> = Vec::with_capacity(sample.len());
        let mut source = rays_of_iter(program, setup.protocol, setup.seed);
        // Untimed: the first batch would otherwise time the pipeline's build.
        if let Some((ray, span)) = sample.first() {
            renderer.trace_rays(method, &[lists.ray(ray, *span)], &uploaded, &settings)?;
        }
        let batch_size = if transparent {
            TRANSPARENT_BATCH
        } else {
            BATCH
        };
        while tally.steps.len() < setup.rays {
            progress(method.name(), tally.steps.len() as f64 / setup.rays as f64);
            let batch: Vec<(Ray, Interval)> = source
                .by_ref()
                .take(batch_size.min(setup.rays - tally.steps.len()))
                .collect();
            let gpu_rays: Vec<GpuStatsRay> = batch.iter().map(|(r, s)| lists.ray(r, *s)).collect();
            if transparent {
                let start = Instant::now();
                let traced = renderer.trace_rays_through(
                    method,
                    &gpu_rays,
                    &uploaded,
                    (&settings, CROSSING_SLOTS),
                )?;
                tally.nanoseconds += start.elapsed().as_nanos() as f64;
                for (ray, (_, span)) in traced.into_iter().zip(&batch) {
                    let i = tally.steps.len();
                    tally_crossings(&mut tally, &ray, settings.max_steps, i)?;
                    if i < sample.len() {
                        found.push(
                            ray.kept
                                .iter()
                                .map(|&(t, entering)| Crossing {
                                    t: span.lo + t,
                                    entering,
                                })
                                .collect(),
                        );
                    }
                }
                continue;
            }
            let start = Instant::now();
            let traced = renderer.trace_rays(method, &gpu_rays, &uploaded, &settings)?;
            tally.nanoseconds += start.elapsed().as_nanos() as f64;
            for ((steps, t), (_, span)) in traced.into_iter().zip(&batch) {
                let i = tally.steps.len();
                tally.steps.push(steps);
                tally.hits += usize::from(t.is_finite());
                tally.out_of_steps += usize::from(ran_out_of_steps(
                    TraceMode::Opaque,
                    steps,
                    settings.max_steps,
                    usize::from(t.is_finite()),
                ));
                if i < sample.len() {
                    found.push(if t.is_finite() {
                        vec![Crossing {
                            t: span.lo + t,
                            entering: entering[i],
                        }]
                    } else {
                        Vec::new()
                    });
                }
            }
        }
        let pairs = reference
            .iter()
            .zip(&found)
            .map(|(all, got)| (Reference::of(all, setup.mode), got.as_slice()));
        out.push(MethodStats::of(
            method.name(),
            tally,
            pairs,
            program.scale_bounds().diagonal(),
        ));
        progress(method.name(), 1.0);
    }
    Ok(SceneStats {
        scene: scene_name.to_owned(),
        rays: setup.rays,
        protocol: setup.protocol,
        mode: setup.mode,
        methods: out,
    })
}

/// Counts transparent ray `index` into `tally` as core's `stats::run` does: steps to its last
/// crossing when it has one, a hit when it has any, out of steps when it spent the budget.
///
/// # Errors
/// [`BackendError::Unsupported`] when the ray crossed the surface more often than its slots
/// hold.
fn tally_crossings(
    tally: &mut MethodTally,
    ray: &RayCrossings,
    max_steps: u32,
    index: usize,
) -> Result<(), BackendError> {
    if ray.found > CROSSING_SLOTS {
        return Err(BackendError::Unsupported(format!(
            "ray {index} crosses the surface {} times, more than the GPU keeps per ray \
             ({CROSSING_SLOTS}); trace these statistics on the CPU",
            ray.found
        )));
    }
    tally.steps.push(if ray.found > 0 {
        ray.steps_to_last
    } else {
        ray.steps
    });
    tally.hits += usize::from(ray.found > 0);
    tally.out_of_steps += usize::from(ran_out_of_steps(
        TraceMode::Transparent,
        ray.steps,
        max_steps,
        ray.found as usize,
    ));
    Ok(())
}
