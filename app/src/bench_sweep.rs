//! `skeletrace bench --sweep PARAM`: the frames that follow a parameter's changes, as a slider
//! dragged in the editor sends them. The parameter is set to `--steps` values in turn on every
//! group, primitive or operator that has it; each value is compiled and traced by the chosen
//! backend and by the CPU tracer. Reports, per method, the pipelines the backend compiled after
//! the first frame (on the GPU a parameter is data: none), the median and slowest frame, and
//! how far the frames are from the CPU's: the hit masks' agreement and the largest colour
//! difference where both hit.

use std::sync::Arc;
use std::time::Instant;

use skeletrace::backends::Backends;
use skeletrace_core::backend::{BackendChoice, BackendError, FrameBackend, FrameRequest};
use skeletrace_core::compile::Compiled;
use skeletrace_core::cpu::cpu_backend::CpuBackend;
use skeletrace_core::frame::Frame;
use skeletrace_core::methods::{MethodId, TraceMode};
use skeletrace_core::model::scene::Blend;
use skeletrace_core::{Scene, compile};

use crate::bench_cmd::{median, method_request};
use crate::cli::{BenchArgs, SweepParam};
use crate::render_cmd::parse_size;
use crate::stdout::Skipped;

impl SweepParam {
    /// The name `--sweep` takes.
    fn name(self) -> &'static str {
        match self {
            Self::KernelScale => "kernel-scale",
            Self::Radius => "radius",
            Self::Isovalue => "isovalue",
            Self::SmoothWidth => "smooth-width",
            Self::RicciExponent => "ricci-exponent",
        }
    }

    /// The factor of value `step` of `steps` (1-based): up to 1.25 times the scene's value, or
    /// down to 0.8 times for the isovalue (a higher one may leave no surface), so that every
    /// value stays valid (σ > 1 of a compact kernel, p ≥ 1 of a Ricci blend).
    fn factor(self, step: usize, steps: usize) -> f64 {
        let t = step as f64 / steps as f64;
        match self {
            Self::Isovalue => 1.0 - 0.2 * t,
            _ => 1.0 + 0.25 * t,
        }
    }

    /// Multiplies the parameter by `factor` wherever `scene` has it; returns how many places
    /// that was.
    fn apply(self, scene: &mut Scene, factor: f64) -> usize {
        match self {
            Self::Isovalue => {
                scene.isovalue *= factor;
                1
            }
            Self::KernelScale => {
                for group in &mut scene.groups {
                    group.kernel = group.kernel.scaled(factor);
                }
                scene.groups.len()
            }
            Self::Radius => {
                let mut count = 0;
                for group in &mut scene.groups {
                    for vertex in group.skeletons.iter_mut().flat_map(|s| &mut s.vertices) {
                        vertex.radius *= factor;
                        count += 1;
                    }
                    for blob in &mut group.blobs {
                        blob.radius *= factor;
                        count += 1;
                    }
                }
                count
            }
            Self::SmoothWidth | Self::RicciExponent => scene
                .blend
                .as_mut()
                .map_or(0, |b| scale_operators(b, self, factor)),
        }
    }
}

/// Multiplies the smooth widths or the Ricci exponents of `blend` by `factor`; returns how many.
fn scale_operators(blend: &mut Blend, param: SweepParam, factor: f64) -> usize {
    let (own, operands): (usize, Vec<&mut Blend>) = match blend {
        Blend::Group(_) => (0, Vec::new()),
        Blend::Sum(v) | Blend::Max(v) | Blend::Min(v) => (0, v.iter_mut().collect()),
        Blend::Difference(a, b) => (0, vec![a.as_mut(), b.as_mut()]),
        Blend::Ricci { p, of } => {
            let own = usize::from(param == SweepParam::RicciExponent);
            if own == 1 {
                *p *= factor;
            }
            (own, of.iter_mut().collect())
        }
        Blend::SmoothUnion { width, of } | Blend::SmoothIntersection { width, of } => {
            let own = usize::from(param == SweepParam::SmoothWidth);
            if own == 1 {
                *width *= factor;
            }
            (own, of.iter_mut().collect())
        }
    };
    own + operands
        .into_iter()
        .map(|o| scale_operators(o, param, factor))
        .sum::<usize>()
}

/// How a backend's frame agrees with the CPU tracer's.
#[derive(Clone, Copy)]
struct Difference {
    /// Share of the pixels hit on both or on neither.
    hit_mask: f64,
    /// Largest difference of a colour channel (linear, clamped to [0, 1]) where both hit.
    colour: f64,
}

fn difference(cpu: &Frame, other: &Frame) -> Difference {
    let n = cpu.depth.len().max(1);
    let mut same = 0;
    let mut colour: f64 = 0.0;
    for i in 0..cpu.depth.len() {
        match (cpu.is_hit(i), other.is_hit(i)) {
            (true, true) => {
                same += 1;
                for c in 0..3 {
                    let d = (cpu.colour[i][c].clamp(0.0, 1.0) - other.colour[i][c].clamp(0.0, 1.0))
                        .abs();
                    colour = colour.max(f64::from(d));
                }
            }
            (false, false) => same += 1,
            _ => {}
        }
    }
    Difference {
        hit_mask: same as f64 / n as f64,
        colour,
    }
}

/// One method's sweep.
#[derive(serde::Serialize)]
struct SweepMethod {
    name: &'static str,
    frames: usize,
    /// Pipelines compiled after the first frame; absent where the backend compiles none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pipelines_compiled: Option<u64>,
    ms_per_frame_median: f64,
    ms_per_frame_max: f64,
    max_pixel_difference_to_cpu: f64,
    min_hit_mask_agreement: f64,
}

/// `bench --sweep --json`: the totals over the methods, then each method.
#[derive(serde::Serialize)]
struct SweepReport<'a> {
    scene: &'a str,
    device: &'a str,
    width: usize,
    height: usize,
    param: &'static str,
    /// Places in the scene the parameter was changed on.
    targets: usize,
    frames: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pipelines_compiled: Option<u64>,
    ms_per_frame_median: f64,
    ms_per_frame_max: f64,
    max_pixel_difference_to_cpu: f64,
    min_hit_mask_agreement: f64,
    methods: Vec<SweepMethod>,
    skipped: Vec<Skipped>,
}

/// The scene of each sweep value, compiled (validated first: a value the scene refuses is an
/// error naming it).
fn swept_scenes(
    scene: &Scene,
    param: SweepParam,
    steps: usize,
) -> Result<Vec<Arc<Compiled>>, String> {
    (1..=steps)
        .map(|step| {
            let mut swept = scene.clone();
            param.apply(&mut swept, param.factor(step, steps));
            swept
                .validate()
                .map_err(|e| format!("--sweep {} value {step} of {steps}: {e}", param.name()))?;
            Ok(compile(&swept))
        })
        .collect()
}

/// Runs `bench --sweep`.
///
/// # Errors
/// A scene without the parameter, a method the backend does not run, a failed device.
pub fn run(args: &BenchArgs, scene: &Scene, param: SweepParam) -> Result<(), String> {
    let (width, height) = parse_size(&args.size)?;
    let targets = param.apply(&mut scene.clone(), 1.0);
    if targets == 0 {
        return Err(format!(
            "--sweep {}: {} has no {}",
            param.name(),
            args.scene.display(),
            match param {
                SweepParam::SmoothWidth => "smooth union or intersection",
                SweepParam::RicciExponent => "Ricci blend",
                SweepParam::Radius => "skeleton vertex or point blob",
                SweepParam::KernelScale => "group",
                SweepParam::Isovalue => "isovalue",
            }
        ));
    }
    let compiled = compile(scene);
    let swept = swept_scenes(scene, param, args.steps)?;
    let (chosen, mut skipped) =
        crate::chosen_methods(&args.methods, &compiled.program, TraceMode::Opaque)?;
    let mut backends = Backends::open(args.backend);
    if args.backend == BackendChoice::Gpu
        && let Err(why) = &backends.gpu
    {
        return Err(format!("--backend gpu: {why}"));
    }
    let mut cpu = CpuBackend::new();
    let mut methods = Vec::new();
    let mut devices: Vec<String> = Vec::new();
    for method in chosen {
        let request = method_request(scene, &compiled, method, (width, height), args);
        let backend = match backends.choose(args.backend, &compiled, method, &request) {
            Ok(backend) => backend,
            Err(BackendError::Unsupported(reason)) if args.methods == "all" => {
                eprintln!("skeletrace: skipping {method}: {reason}");
                skipped.push(Skipped {
                    name: method.name(),
                    reason,
                });
                continue;
            }
            Err(e) => return Err(e.to_string()),
        };
        let device = backend.describe();
        if !devices.contains(&device) {
            devices.push(device.clone());
        }
        methods.push(
            sweep_method(backend, &mut cpu, method, &request, &compiled, &swept)
                .map_err(|e| format!("{method} on {device}: {e}"))?,
        );
    }
    let report = SweepReport {
        scene: &args.scene.display().to_string(),
        device: &devices.join(" and "),
        width,
        height,
        param: param.name(),
        targets,
        frames: args.steps,
        pipelines_compiled: methods.iter().map(|m| m.pipelines_compiled).sum(),
        ms_per_frame_median: median(methods.iter().map(|m| m.ms_per_frame_median).collect()),
        ms_per_frame_max: methods
            .iter()
            .map(|m| m.ms_per_frame_max)
            .fold(0.0, f64::max),
        max_pixel_difference_to_cpu: methods
            .iter()
            .map(|m| m.max_pixel_difference_to_cpu)
            .fold(0.0, f64::max),
        min_hit_mask_agreement: methods
            .iter()
            .map(|m| m.min_hit_mask_agreement)
            .fold(1.0, f64::min),
        methods,
        skipped,
    };
    if args.json {
        return crate::stdout::print_json(&report);
    }
    let mut text = format!(
        "{}: {width}x{height} on {}, --sweep {} over {} place(s), {} values\n",
        args.scene.display(),
        report.device,
        report.param,
        report.targets,
        report.frames
    );
    for m in &report.methods {
        text += &format!(
            "{:<28} {:>10.2} ms/frame (slowest {:.2}), {} pipelines compiled after the first frame, hit masks {:.2} % as the CPU's, colour within {:.4}\n",
            m.name,
            m.ms_per_frame_median,
            m.ms_per_frame_max,
            m.pipelines_compiled
                .map_or_else(|| "no".to_owned(), |n| n.to_string()),
            100.0 * m.min_hit_mask_agreement,
            m.max_pixel_difference_to_cpu
        );
    }
    crate::stdout::print(&text)
}

/// One method's sweep on `backend`: the first frame (the base scene; compiles its pipelines),
/// then one timed frame per swept scene, each compared with the CPU's.
fn sweep_method(
    backend: &mut dyn FrameBackend,
    cpu: &mut CpuBackend,
    method: MethodId,
    request: &FrameRequest,
    base: &Arc<Compiled>,
    swept: &[Arc<Compiled>],
) -> Result<SweepMethod, BackendError> {
    backend.render(base, request)?;
    let compiled_before = backend.pipelines_compiled();
    let (mut times, mut colour, mut hit_mask) = (Vec::new(), 0.0_f64, 1.0_f64);
    for scene in swept {
        let start = Instant::now();
        let frames = backend.render(scene, request)?;
        times.push(start.elapsed().as_secs_f64() * 1e3);
        let reference = cpu.render(scene, request)?;
        for (a, b) in reference.iter().zip(&frames) {
            let d = difference(a, b);
            colour = colour.max(d.colour);
            hit_mask = hit_mask.min(d.hit_mask);
        }
    }
    Ok(SweepMethod {
        name: method.name(),
        frames: swept.len(),
        pipelines_compiled: backend
            .pipelines_compiled()
            .zip(compiled_before)
            .map(|(after, before)| after - before),
        ms_per_frame_max: times.iter().copied().fold(0.0, f64::max),
        ms_per_frame_median: median(times),
        max_pixel_difference_to_cpu: colour,
        min_hit_mask_agreement: hit_mask,
    })
}
