//! `skeletrace bench`: milliseconds per full frame per method (median of several frames after
//! a warm-up that also compiles the GPU pipelines and lasts at least [`WARM_UP`], so that a GPU
//! has left its idle clock), on the CPU tracer or the GPU backend, with the adapter name. On the
//! GPU, where the adapter has timestamp queries, also the GPU's own time for the trace pass and
//! the tile binning: the wall-clock frame holds the readback and the conversion to frames as
//! well.

use std::time::Instant;

use skeletrace_core::backend::{BackendChoice, BackendError, Cancel, FrameRequest};
use skeletrace_core::frame::{FieldShading, View};
use skeletrace_core::methods::TraceSettings;
use skeletrace_core::{Scene, compile};

use crate::cli::BenchArgs;
use crate::render_cmd::parse_size;
use skeletrace::backends::Backends;

/// Shortest warm-up per method. An idle H100 runs at 345 MHz and reaches its 1 980 MHz within
/// a few dozen frames: after one warm-up frame, the median of 7 frames of the tree read 3.9 ms
/// where 40 frames read 2.0 ms.
const WARM_UP: std::time::Duration = std::time::Duration::from_millis(500);

/// Renders untimed frames until [`WARM_UP`] has passed (at least one).
fn warm_up<E>(mut frame: impl FnMut() -> Result<(), E>) -> Result<(), E> {
    let start = Instant::now();
    frame()?;
    while start.elapsed() < WARM_UP {
        frame()?;
    }
    Ok(())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// One method's timings.
struct Row {
    name: &'static str,
    /// Median wall-clock milliseconds per frame.
    frame_ms: f64,
    /// Median GPU milliseconds of the trace pass and of the binning passes.
    passes: Option<(f64, f64)>,
}

/// Runs `bench`.
///
/// # Errors
/// Bad arguments, a method that does not run on the chosen backend, a failed device.
pub fn run(args: &BenchArgs, scene: &Scene) -> Result<(), String> {
    let (width, height) = parse_size(&args.size)?;
    let compiled = compile(scene);
    let frames = args.frames.max(1);
    let chosen = crate::chosen_methods(&args.methods, &compiled.program)?;
    let mut backends = Backends::open(args.backend);
    if args.backend == BackendChoice::Gpu
        && let Err(why) = &backends.gpu
    {
        return Err(format!("--backend gpu: {why}"));
    }
    let mut rows: Vec<Row> = Vec::new();
    let mut devices: Vec<String> = Vec::new();
    for method in chosen {
        let request = FrameRequest {
            camera: scene.camera,
            width,
            height,
            methods: vec![method],
            view: View::Shaded(FieldShading::default()),
            shadows: false,
            settings: TraceSettings::for_protocol(&compiled.program, args.protocol),
            cancel: Cancel::new(),
        };
        let backend = match backends.choose(args.backend, &compiled, method, &request) {
            Ok(backend) => backend,
            Err(BackendError::Unsupported(why)) if args.methods == "all" => {
                eprintln!("skeletrace: skipping {method}: {why}");
                continue;
            }
            Err(e) => return Err(e.to_string()),
        };
        let device = backend.describe();
        let fail = |e: BackendError| format!("{method} on {device}: {e}");
        warm_up(|| backend.render(&compiled, &request).map(drop)).map_err(fail)?;
        let mut times = Vec::with_capacity(frames);
        let (mut trace, mut binning) = (Vec::new(), Vec::new());
        for _ in 0..frames {
            let start = Instant::now();
            backend.render(&compiled, &request).map_err(fail)?;
            times.push(start.elapsed().as_secs_f64() * 1e3);
            if let Some(passes) = backend.last_pass_times() {
                trace.extend(passes.trace_ms.first().copied());
                binning.push(passes.binning_ms);
            }
        }
        if !devices.contains(&device) {
            devices.push(device);
        }
        rows.push(Row {
            name: method.name(),
            frame_ms: median(times),
            passes: (!trace.is_empty()).then(|| (median(trace), median(binning))),
        });
    }
    let device = devices.join(" and ");
    if args.json {
        let methods: Vec<String> = rows
            .iter()
            .map(|row| {
                let passes = row.passes.map_or(String::new(), |(trace, binning)| {
                    format!(", \"gpu_trace_ms\": {trace:.3}, \"gpu_binning_ms\": {binning:.3}")
                });
                format!(
                    "{{\"name\": \"{}\", \"ms_per_frame\": {:.3}{passes}}}",
                    row.name, row.frame_ms
                )
            })
            .collect();
        println!(
            "{{\"scene\": \"{}\", \"device\": \"{}\", \"width\": {width}, \"height\": {height}, \"frames\": {frames}, \"methods\": [{}]}}",
            args.scene.display().to_string().replace('"', "'"),
            device.replace('"', "'"),
            methods.join(", ")
        );
    } else {
        println!(
            "{}: {width}x{height} on {device}, median of {frames} frames",
            args.scene.display()
        );
        for row in rows {
            let passes = row.passes.map_or(String::new(), |(trace, binning)| {
                format!("   (GPU: trace {trace:.3} ms, binning {binning:.3} ms)")
            });
            println!("{:<28} {:>10.2} ms/frame{passes}", row.name, row.frame_ms);
        }
    }
    Ok(())
}
