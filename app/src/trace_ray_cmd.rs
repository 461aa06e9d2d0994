//! `skeletrace trace-ray`: one pixel's camera ray traced by each method, with the step log of the
//! marching methods ([`RayProbe`]): the point, `f` and `f′` there, the lower and upper bounds
//! `f(t) + a·s + b·s²` on `[t, t + length]` and the advance they allow. The step count is the
//! CPU heat map's at that pixel (opaque scenes; `app/tests/cli.rs` checks it).

use skeletrace::ray_probe::RayProbe;
use std::fmt::Write as _;

use skeletrace_core::methods::{MethodId, Trace, TraceMode};
use skeletrace_core::{Scene, compile};

use crate::cli::TraceRayArgs;
use crate::render_cmd::parse_size;
use crate::stdout::Skipped;

/// Runs `trace-ray`.
pub fn run(args: &TraceRayArgs, scene: &Scene) -> Result<(), String> {
    let (width, height) = parse_size(&args.size)?;
    let (x, y) = parse_pixel(&args.pixel, width, height)?;
    let compiled = compile(scene);
    let program = &compiled.program;
    let (methods, skipped) = crate::chosen_methods(&args.methods, program, TraceMode::Opaque)?;
    let probe = RayProbe::new(&compiled, &scene.camera, (x, y), (width, height), &methods);
    let (ray, span, traces) = (probe.ray, probe.span, &probe.traces);
    if args.json {
        return crate::stdout::print_json(&TraceRayReport {
            pixel: [x, y],
            size: [width, height],
            ray: RayRecord {
                origin: ray.origin.to_array(),
                direction: ray.direction.to_array(),
                span: [span.lo, span.hi],
            },
            isovalue: program.isovalue(),
            methods: traces
                .iter()
                .map(|(id, t)| MethodRecord::of(*id, t))
                .collect(),
            skipped,
        });
    }
    let mut out = format!(
        "pixel ({x}, {y}) of {width}x{height}: ray from {:?} along {:?}, t in [0, {:.4}], c = {}\n",
        ray.origin.to_array(),
        ray.direction.to_array(),
        span.hi,
        program.isovalue()
    );
    for (id, trace) in traces {
        let hit = trace
            .first()
            .map_or_else(|| "no hit".to_owned(), |c| format!("hit at t = {:.6}", c.t));
        let _ = writeln!(
            out,
            "\n{id}: {} steps, {} evaluations, {hit}",
            trace.steps, trace.evaluations
        );
        let Some(log) = &trace.log else {
            out.push_str("  (no step log: not a marching method)\n");
            continue;
        };
        let _ = writeln!(
            out,
            "  {:>4} {:>12} {:>12} {:>12} {:>12} {:>26} {:>26}",
            "step", "t", "f", "f'", "advance", "lower a, b", "upper a, b"
        );
        for (k, s) in log.iter().enumerate() {
            let _ = writeln!(
                out,
                "  {:>4} {:>12.6} {:>12.6} {:>12.4} {:>12.6} {:>12.4}, {:>11.4} {:>12.4}, {:>11.4}",
                k + 1,
                s.t,
                s.f,
                s.slope,
                s.step,
                s.bound.lower.a,
                s.bound.lower.b,
                s.bound.upper.a,
                s.bound.upper.b
            );
        }
    }
    crate::stdout::print(&out)
}

/// `X,Y` inside a `width × height` frame.
fn parse_pixel(text: &str, width: usize, height: usize) -> Result<(usize, usize), String> {
    let parsed = text
        .split_once(',')
        .and_then(|(x, y)| Some((x.trim().parse().ok()?, y.trim().parse().ok()?)));
    match parsed {
        Some((x, y)) if x < width && y < height => Ok((x, y)),
        Some((x, y)) => Err(format!(
            "--pixel {x},{y} is outside the {width}x{height} frame"
        )),
        None => Err(format!(
            "--pixel must be X,Y (two whole numbers), got '{text}'"
        )),
    }
}

/// `trace-ray --json`.
#[derive(serde::Serialize)]
struct TraceRayReport {
    pixel: [usize; 2],
    size: [usize; 2],
    ray: RayRecord,
    isovalue: f64,
    methods: Vec<MethodRecord>,
    /// Methods `all` left out, with the reason.
    skipped: Vec<Skipped>,
}

#[derive(serde::Serialize)]
struct RayRecord {
    origin: [f64; 3],
    direction: [f64; 3],
    span: [f64; 2],
}

/// One method's trace of the ray; `log` is `null` for methods that do not march.
#[derive(serde::Serialize)]
struct MethodRecord {
    name: &'static str,
    steps: u32,
    evaluations: u32,
    hit: Option<f64>,
    log: Option<Vec<StepRecord>>,
}

/// One step: where it stood, the field and slope there, the advance it allowed and the bounds
/// `f(t) + a·s + b·s²` on `[t, t + length]`.
#[derive(serde::Serialize)]
struct StepRecord {
    t: f64,
    f: f64,
    slope: f64,
    step: f64,
    length: f64,
    lower: [f64; 2],
    upper: [f64; 2],
}

impl MethodRecord {
    fn of(id: MethodId, trace: &Trace) -> Self {
        Self {
            name: id.name(),
            steps: trace.steps,
            evaluations: trace.evaluations,
            hit: trace.first().map(|c| c.t),
            log: trace.log.as_ref().map(|steps| {
                steps
                    .iter()
                    .map(|s| StepRecord {
                        t: s.t,
                        f: s.f,
                        slope: s.slope,
                        step: s.step,
                        length: s.bound.length,
                        lower: [s.bound.lower.a, s.bound.lower.b],
                        upper: [s.bound.upper.a, s.bound.upper.b],
                    })
                    .collect()
            }),
        }
    }
}
