//! `skeletrace render`: one method's shaded view or heat map, or `--compare` panels with one
//! shared step-count scale, each labelled with its method and average/median/max steps.

use std::time::Instant;

use skeletrace_core::backend::{BackendChoice, BackendError, Cancel, FrameRequest};
use skeletrace_core::frame::{FieldShading, Frame, StepScale, View as FrameView};
use skeletrace_core::methods::{MethodId, TraceMode, TraceSettings};
use skeletrace_core::{Scene, compile};

use crate::cli::{RenderArgs, Scale, View};
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
    run_on(args, scene, &mut Backends::open(args.backend))
}

/// Runs `render` on the given backends.
fn run_on(args: &RenderArgs, scene: &Scene, backends: &mut Backends) -> Result<(), String> {
    let (width, height) = parse_size(&args.size)?;
    let compiled = compile(scene);
    let list = args
        .compare
        .as_deref()
        .or(args.method.as_deref())
        .unwrap_or(DEFAULT_METHOD.name());
    let (methods, _) = crate::chosen_methods(list, &compiled.program, TraceMode::Opaque)?;
    if methods.is_empty() {
        return Err(format!("no method of '{list}' applies to this scene"));
    }
    let view = args.view.unwrap_or(if args.compare.is_some() {
        View::Steps
    } else {
        View::Shaded
    });
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
            settings: TraceSettings::for_protocol(&compiled.program, args.protocol),
            cancel: Cancel::new(),
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
        print_timing(method.name(), start.elapsed().as_secs_f64() * 1e3, &frame)?;
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
        View::Steps => Panels::Steps {
            steps_max,
            scale: match args.scale {
                Scale::Log => StepScale::Log,
                Scale::Linear => StepScale::Linear,
            },
            clipped,
        },
    };
    let picture = compose(&frames, panels);
    picture.save_png(&args.output, &[&args.scene])?;
    crate::stdout::print(&format!(
        "wrote {} ({}x{})\n",
        args.output.display(),
        picture.width,
        picture.height
    ))
}

fn print_timing(name: &str, ms: f64, frame: &Frame) -> Result<(), String> {
    let s = frame.step_summary();
    crate::stdout::print(&format!(
        "{name:<28} {ms:>8.1} ms   steps avg {:.2}, median {}, p95 {}, max {}\n",
        s.average, s.median, s.p95, s.max
    ))
}

#[cfg(test)]
mod tests {
    use clap::Parser;
    use skeletrace::backends::FailingGpu;

    use super::*;
    use crate::cli::{Cli, Command};

    /// A device that fails while `render` traces ends the command with the message, naming the
    /// method and the device; nothing is written.
    #[test]
    fn a_failing_device_ends_render_with_a_clear_message() {
        let out = std::env::temp_dir().join(format!("skeletrace-fail-{}.png", std::process::id()));
        let out_arg = out.display().to_string();
        let cli = Cli::parse_from([
            "skeletrace",
            "render",
            "scene.ron",
            "-o",
            &out_arg,
            "--backend",
            "gpu",
            "--size",
            "16x12",
            "--method",
            "segment",
        ]);
        let Some(Command::Render(args)) = cli.command else {
            panic!("render arguments");
        };
        let scene = skeletrace::editor::default_scene();
        let mut backends = Backends::open(BackendChoice::Cpu);
        backends.gpu = Ok(Box::new(FailingGpu));
        let err = run_on(&args, &scene, &mut backends)
            .err()
            .unwrap_or_default();
        assert!(
            err.contains("segment")
                && err.contains("failing GPU (injected)")
                && err.contains("device failed: device lost (injected)"),
            "{err}"
        );
        assert!(!out.exists(), "nothing is written after a device failure");
    }
}
