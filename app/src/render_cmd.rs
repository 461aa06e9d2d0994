//! `skeletrace render`: one method's shaded view or heat map, or `--compare` panels with one
//! shared step-count scale, each labelled with its method and average/median/max steps.

use std::time::Instant;

use skeletrace_core::methods::TraceSettings;
use skeletrace_core::render::{Frame, RenderOptions, Renderer};
use skeletrace_core::shading::FieldShading;
use skeletrace_core::{FieldProgram, Scene};
use skeletrace_render::{GpuMethod, GpuRenderer, View as GpuView};

use crate::cli::{Backend, RenderArgs, View};
use skeletrace::picture::{Panels, compose, shared_scale};

/// Method of a render when none is named: guaranteed, and the fastest on most scenes.
const DEFAULT_METHOD: &str = "quadratic-taylor";

/// Parses `WxH`.
///
/// # Errors
/// A message naming the value.
pub fn parse_size(text: &str) -> Result<(usize, usize), String> {
    let bad =
        || format!("--size '{text}': expected WxH with both between 1 and 8192, e.g. 512x512");
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: usize = w.trim().parse().map_err(|_| bad())?;
    let h: usize = h.trim().parse().map_err(|_| bad())?;
    if (1..=8192).contains(&w) && (1..=8192).contains(&h) {
        Ok((w, h))
    } else {
        Err(bad())
    }
}

/// Runs `render`.
///
/// # Errors
/// Bad arguments, a scene error, a method that does not apply, an unwritable output.
pub fn run(args: &RenderArgs, scene: &Scene) -> Result<(), String> {
    let (width, height) = parse_size(&args.size)?;
    let program = FieldProgram::new(scene);
    let list = args
        .compare
        .as_deref()
        .or(args.method.as_deref())
        .unwrap_or(DEFAULT_METHOD);
    let methods = crate::chosen_methods(list, &program)?;
    if methods.is_empty() {
        return Err(format!("no method of '{list}' applies to this scene"));
    }
    let view = args.view.unwrap_or(if args.compare.is_some() {
        View::Steps
    } else {
        View::Shaded
    });
    let options = RenderOptions {
        width,
        height,
        shadows: args.shadows,
        shading: FieldShading {
            soft_shadows: args.soft_shadows,
            ambient_occlusion: args.ao,
        },
    };
    let gpu = match args.backend {
        Backend::Cpu => None,
        Backend::Gpu => match GpuRenderer::new() {
            Ok(g) => Some(g),
            Err(why) => {
                eprintln!("skeletrace: {why}; falling back to the CPU backend");
                None
            }
        },
    };
    let frames = match gpu {
        Some(mut gpu) => {
            let names: Vec<&'static str> = methods.iter().map(|m| m.name()).collect();
            render_gpu(&mut gpu, scene, &program, &names, options, list == "all")?
        }
        None => render_cpu(scene, &program, &methods, options),
    };
    let steps_max = args
        .steps_max
        .unwrap_or_else(|| shared_scale(&frames))
        .max(1);
    let clipped = frames.iter().any(|(_, f)| f.step_summary().max > steps_max);
    let panels = match view {
        View::Shaded => Panels::Shaded {
            labelled: args.compare.is_some(),
        },
        View::Steps => Panels::Steps { steps_max, clipped },
    };
    let picture = compose(&frames, panels);
    picture.save_png(&args.output)?;
    println!(
        "wrote {} ({}x{})",
        args.output.display(),
        picture.width,
        picture.height
    );
    Ok(())
}

fn print_timing(name: &str, ms: f64, frame: &Frame) {
    let s = frame.step_summary();
    println!(
        "{name:<28} {ms:>8.1} ms   steps avg {:.2}, median {}, max {}",
        s.average, s.median, s.max
    );
}

/// One frame per method on the CPU tracer.
fn render_cpu(
    scene: &Scene,
    program: &FieldProgram,
    methods: &[Box<dyn skeletrace_core::methods::Method>],
    options: RenderOptions,
) -> Vec<(&'static str, Frame)> {
    let settings = TraceSettings::for_program(program);
    methods
        .iter()
        .map(|method| {
            let tracer = method.prepare(program, settings);
            let renderer = Renderer::new(scene, program, tracer.as_ref(), settings);
            let start = Instant::now();
            let frame = renderer.render(&scene.camera, options);
            print_timing(method.name(), start.elapsed().as_secs_f64() * 1e3, &frame);
            (method.name(), frame)
        })
        .collect()
}

/// One frame per method on the GPU. A method without a GPU implementation for this scene is
/// an error when named, and skipped with a message under `--compare all`; never silently
/// traced on the CPU instead.
fn render_gpu(
    gpu: &mut GpuRenderer,
    scene: &Scene,
    program: &FieldProgram,
    names: &[&'static str],
    options: RenderOptions,
    skip_cpu_only: bool,
) -> Result<Vec<(&'static str, Frame)>, String> {
    eprintln!("skeletrace: GPU adapter {}", gpu.adapter_name());
    let mut chosen = Vec::new();
    for &name in names {
        let gpu_method = GpuMethod::by_name(name)
            .ok_or_else(|| format!("method '{name}' runs only on the CPU backend"))
            .and_then(|m| {
                m.supports(program).map(|()| m).map_err(|why| {
                    format!("method '{name}' runs only on the CPU for this scene: {why}")
                })
            });
        match gpu_method {
            Ok(m) => chosen.push(m),
            Err(why) if skip_cpu_only => eprintln!("skeletrace: skipping {name}: {why}"),
            Err(why) => return Err(why),
        }
    }
    if chosen.is_empty() {
        return Err("no chosen method runs on the GPU for this scene".to_owned());
    }
    if options.shadows {
        eprintln!(
            "skeletrace: the GPU shaded view has no exact shadow rays or refraction yet \
             (--soft-shadows and --ao run on the GPU)"
        );
    }
    gpu.set_scene(scene, program)?;
    let settings = TraceSettings::for_program(program);
    let size = (options.width as u32, options.height as u32);
    let start = Instant::now();
    let frames = gpu.render(
        program,
        &chosen,
        &scene.camera,
        &settings,
        size,
        GpuView::Shaded(options.shading),
    )?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let out: Vec<(&'static str, Frame)> = chosen.iter().map(|m| m.name()).zip(frames).collect();
    for (name, frame) in &out {
        print_timing(name, ms / out.len().max(1) as f64, frame);
    }
    Ok(out)
}
