//! `skeletrace trace-ray`: one pixel's camera ray traced by each method, with the step log of the
//! marching methods ([`RayProbe`]): the point, `f` and `f′` there, the lower and upper bounds
//! `f(t) + a·s + b·s²` on `[t, t + length]` and the advance they allow. The step count is the
//! CPU heat map's at that pixel (opaque scenes; `app/tests/cli.rs` checks it).

use skeletrace::ray_probe::RayProbe;
use skeletrace_core::json::{self, number};
use skeletrace_core::methods::{MethodId, Trace, TraceMode};
use skeletrace_core::{Scene, compile};

use crate::cli::TraceRayArgs;
use crate::render_cmd::parse_size;

/// Runs `trace-ray`.
pub fn run(args: &TraceRayArgs, scene: &Scene) -> Result<(), String> {
    let (width, height) = parse_size(&args.size)?;
    let (x, y) = parse_pixel(&args.pixel, width, height)?;
    let compiled = compile(scene);
    let program = &compiled.program;
    let methods = crate::chosen_methods(&args.methods, program, TraceMode::Opaque)?;
    let probe = RayProbe::new(&compiled, &scene.camera, (x, y), (width, height), &methods);
    let (ray, span, traces) = (probe.ray, probe.span, &probe.traces);
    if args.json {
        let methods: Vec<String> = traces.iter().map(|(id, t)| method_json(*id, t)).collect();
        println!(
            "{{\"pixel\": [{x}, {y}], \"size\": [{width}, {height}], \"ray\": {{\"origin\": {}, \
             \"direction\": {}, \"span\": [{}, {}]}}, \"isovalue\": {}, \"methods\": [\n  {}\n]}}",
            vector(ray.origin.to_array()),
            vector(ray.direction.to_array()),
            number(span.lo),
            number(span.hi),
            number(program.isovalue()),
            methods.join(",\n  ")
        );
        return Ok(());
    }
    println!(
        "pixel ({x}, {y}) of {width}x{height}: ray from {:?} along {:?}, t in [0, {:.4}], c = {}",
        ray.origin.to_array(),
        ray.direction.to_array(),
        span.hi,
        program.isovalue()
    );
    for (id, trace) in traces {
        let hit = trace
            .first()
            .map_or_else(|| "no hit".to_owned(), |c| format!("hit at t = {:.6}", c.t));
        println!(
            "\n{id}: {} steps, {} evaluations, {hit}",
            trace.steps, trace.evaluations
        );
        let Some(log) = &trace.log else {
            println!("  (no step log: not a marching method)");
            continue;
        };
        println!(
            "  {:>4} {:>12} {:>12} {:>12} {:>12} {:>26} {:>26}",
            "step", "t", "f", "f'", "advance", "lower a, b", "upper a, b"
        );
        for (k, s) in log.iter().enumerate() {
            println!(
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
    Ok(())
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

fn method_json(id: MethodId, trace: &Trace) -> String {
    let hit = trace
        .first()
        .map_or_else(|| "null".to_owned(), |c| number(c.t));
    let log = trace.log.as_ref().map_or_else(
        || "null".to_owned(),
        |steps| {
            let steps: Vec<String> = steps
                .iter()
                .map(|s| {
                    format!(
                        "{{\"t\": {}, \"f\": {}, \"slope\": {}, \"step\": {}, \"length\": {}, \
                         \"lower\": [{}, {}], \"upper\": [{}, {}]}}",
                        number(s.t),
                        number(s.f),
                        number(s.slope),
                        number(s.step),
                        number(s.bound.length),
                        number(s.bound.lower.a),
                        number(s.bound.lower.b),
                        number(s.bound.upper.a),
                        number(s.bound.upper.b)
                    )
                })
                .collect();
            format!("[{}]", steps.join(", "))
        },
    );
    format!(
        "{{\"name\": {}, \"steps\": {}, \"evaluations\": {}, \"hit\": {hit}, \"log\": {log}}}",
        json::string(id.name()),
        trace.steps,
        trace.evaluations
    )
}

fn vector(v: [f64; 3]) -> String {
    format!("[{}, {}, {}]", number(v[0]), number(v[1]), number(v[2]))
}
