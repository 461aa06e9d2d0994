//! `skeletrace render`: one method's shaded view or heat map, or `--compare` panels with one
//! shared step-count scale, each labelled with its method and average/median/max steps.

use std::time::Instant;

use skeletrace_core::backend::{BackendChoice, BackendError, FrameRequest};
use skeletrace_core::frame::{FieldShading, Frame, View as FrameView};
use skeletrace_core::methods::MethodId;
use skeletrace_core::{Scene, compile};

use crate::cli::{RenderArgs, View};
use skeletrace::backends::Backends;
use skeletrace::picture::{Panels, compose, shared_scale};

/// Method of a render when none is named: guaranteed, and the fastest on most scenes.
const DEFAULT_METHOD: MethodId = MethodId::QuadraticTaylor;

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
/// Bad arguments, a scene error, a method that does not apply, a backend that does not
/// support it or whose device failed, an unwritable output.
pub fn run(args: &RenderArgs, scene: &Scene) -> Result<(), String> {
    let (width, height) = parse_size(&args.size)?;
    let compiled = compile(scene);
    let list = args
        .compare
        .as_deref()
        .or(args.method.as_deref())
        .unwrap_or(DEFAULT_METHOD.name());
    let methods = crate::chosen_methods(list, &compiled.program)?;
    if methods.is_empty() {
        return Err(format!("no method of '{list}' applies to this scene"));
    }
    let view = args.view.unwrap_or(if args.compare.is_some() {
        View::Steps
    } else {
        View::Shaded
    });
    let mut backends = Backends::open(args.backend);
    if args.backend == BackendChoice::Gpu
        && let Err(why) = &backends.gpu
    {
        return Err(format!("--backend gpu: {why}"));
    }
    if let Ok(gpu) = &backends.gpu {
        eprintln!("skeletrace: GPU adapter {}", gpu.describe());
    }
    let mut frames: Vec<(&'static str, Frame)> = Vec::new();
    for method in methods {
        let request = FrameRequest {
            camera: scene.camera,
            width,
            height,
            methods: vec![method],
            view: FrameView::Shaded(FieldShading {
                soft_shadows: args.soft_shadows,
                ambient_occlusion: args.ao,
            }),
            shadows: args.shadows,
            settings: compiled.settings,
        };
        let backend = match backends.choose(args.backend, &compiled, method, &request) {
            Ok(backend) => backend,
            // Under `--compare all` a method the chosen backend lacks is skipped, never traced
            // elsewhere in silence.
            Err(BackendError::Unsupported(why)) if list == "all" => {
                eprintln!("skeletrace: skipping {method}: {why}");
                continue;
            }
            Err(e) => return Err(e.to_string()),
        };
        let start = Instant::now();
        let frame = backend
            .render(&compiled, &request)
            .map_err(|e| format!("{method} on {}: {e}", backend.describe()))?
            .pop()
            .ok_or_else(|| format!("{method}: the backend returned no frame"))?;
        print_timing(method.name(), start.elapsed().as_secs_f64() * 1e3, &frame);
        frames.push((method.name(), frame));
    }
    if frames.is_empty() {
        return Err("no chosen method runs on this backend for this scene".to_owned());
    }
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
