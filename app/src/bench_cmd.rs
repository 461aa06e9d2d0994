//! `skeletrace bench`: milliseconds per full frame per method (median of several frames after
//! a warm-up that also compiles the GPU pipelines and lasts at least [`WARM_UP`], so that a GPU
//! has left its idle clock), on the CPU tracer or the GPU backend, with the adapter name. On the
//! GPU, where the adapter has timestamp queries, also the GPU's own time for the trace pass and
//! the tile binning: the wall-clock frame holds the readback and the conversion to frames as
//! well.

use std::time::Instant;

use skeletrace_core::methods::TraceSettings;
use skeletrace_core::render::{RenderOptions, Renderer};
use skeletrace_core::{FieldProgram, Scene};
use skeletrace_render::{GpuMethod, GpuRenderer, View};

use crate::cli::{Backend, BenchArgs};
use crate::render_cmd::parse_size;

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
/// Bad arguments or a method that does not run on the chosen backend.
pub fn run(args: &BenchArgs, scene: &Scene) -> Result<(), String> {
    let (width, height) = parse_size(&args.size)?;
    let program = FieldProgram::new(scene);
    let settings = TraceSettings::for_program(&program);
    let frames = args.frames.max(1);
    let chosen = crate::chosen_methods(&args.methods, &program)?;
    let mut rows: Vec<Row> = Vec::new();
    let device = match args.backend {
        Backend::Cpu => {
            let device = format!("CPU, {} threads", rayon::current_num_threads());
            let options = RenderOptions {
                width,
                height,
                shadows: false,
                shading: skeletrace_core::shading::FieldShading::default(),
            };
            for method in &chosen {
                let tracer = method.prepare(&program, settings);
                let renderer = Renderer::new(scene, &program, tracer.as_ref(), settings);
                warm_up(|| {
                    let _ = renderer.render(&scene.camera, options);
                    Ok::<(), String>(())
                })?;
                let times = (0..frames)
                    .map(|_| {
                        let start = Instant::now();
                        let _ = renderer.render(&scene.camera, options);
                        start.elapsed().as_secs_f64() * 1e3
                    })
                    .collect();
                rows.push(Row {
                    name: method.name(),
                    frame_ms: median(times),
                    passes: None,
                });
            }
            device
        }
        Backend::Gpu => {
            let mut gpu = GpuRenderer::new()?;
            gpu.set_scene(scene, &program)?;
            for method in &chosen {
                let Some(m) =
                    GpuMethod::by_name(method.name()).filter(|m| m.supports(&program).is_ok())
                else {
                    if args.methods == "all" {
                        eprintln!(
                            "skeletrace: {} runs only on the CPU for this scene",
                            method.name()
                        );
                        continue;
                    }
                    return Err(format!(
                        "method '{}' runs only on the CPU for this scene",
                        method.name()
                    ));
                };
                let size = (width as u32, height as u32);
                let frame = |gpu: &mut GpuRenderer| {
                    gpu.render(
                        &program,
                        &[m],
                        &scene.camera,
                        &settings,
                        size,
                        View::Shaded(skeletrace_core::shading::FieldShading::default()),
                    )
                };
                warm_up(|| frame(&mut gpu).map(drop))?;
                let mut times = Vec::with_capacity(frames);
                let (mut trace, mut binning) = (Vec::new(), Vec::new());
                for _ in 0..frames {
                    let start = Instant::now();
                    frame(&mut gpu)?;
                    times.push(start.elapsed().as_secs_f64() * 1e3);
                    if let Some(passes) = gpu.last_pass_times() {
                        trace.extend(passes.trace_ms.first().copied());
                        binning.push(passes.binning_ms);
                    }
                }
                rows.push(Row {
                    name: m.name(),
                    frame_ms: median(times),
                    passes: (!trace.is_empty()).then(|| (median(trace), median(binning))),
                });
            }
            gpu.adapter_name().to_owned()
        }
    };
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
