//! skeletrace: the editor and the command line (DESIGN.md, "Command line").
//!
//! Every command reports bad input as one line on standard error naming the file, the position
//! and the item, and exits with a non-zero status; nothing here panics on user input.

mod bench_cmd;
mod bench_sweep;
mod cli;
mod render_cmd;
mod stdout;
mod trace_ray_cmd;

use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;

use clap::Parser;
use skeletrace_core::backend::{
    BackendChoice, BackendError, Cancel, Capabilities, FrameRequest, Side, decide,
};
use skeletrace_core::frame::View;
use skeletrace_core::methods::{Method, MethodId, Protocol, TraceMode, TraceSettings};
use skeletrace_core::model::generate::{GenerateOptions, GeneratorKind, generate};
use skeletrace_core::stats;
use skeletrace_core::{FieldProgram, Scene};
use skeletrace_render::{GpuMethod, GpuRenderer};

use cli::{Cli, Command};
use stdout::Skipped;

use skeletrace::{DEFAULT_SCENE, DEFAULT_SCENE_NAME};

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Generate(args)) => run_generate(&args),
        Some(Command::Stats(args)) => run_stats(&args),
        Some(Command::Bench(args)) => load(Some(&args.scene)).and_then(|s| match args.sweep {
            Some(param) => bench_sweep::run(&args, &s, param),
            None => bench_cmd::run(&args, &s),
        }),
        Some(Command::Render(args)) => {
            load(Some(&args.scene)).and_then(|s| render_cmd::run(&args, &s))
        }
        Some(Command::TraceRay(args)) => {
            load(Some(&args.scene)).and_then(|s| trace_ray_cmd::run(&args, &s))
        }
        Some(Command::Export(args)) => load(Some(&args.scene)).and_then(|s| run_export(&args, &s)),
        Some(Command::Info(args)) => load(Some(&args.scene)).and_then(|s| print_info(&args, &s)),
        Some(Command::Import(args)) => run_import(&args),
        None => open_editor(cli.scene.as_deref()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("skeletrace: {message}");
            ExitCode::FAILURE
        }
    }
}

fn load(path: Option<&Path>) -> Result<Scene, String> {
    match path {
        Some(p) => Scene::load(p).map_err(|e| e.to_string()),
        None => Scene::from_ron(DEFAULT_SCENE, DEFAULT_SCENE_NAME).map_err(|e| e.to_string()),
    }
}

/// The headless commands, as typed.
const COMMANDS: [&str; 8] = [
    "generate",
    "info",
    "import",
    "stats",
    "render",
    "bench",
    "trace-ray",
    "export",
];

/// Opens the editor window (DESIGN.md, "Editor") on `path` or the embedded scene. A word that
/// is no file and looks like a command (no extension, no folder) is answered as a mistyped
/// command rather than a missing scene.
fn open_editor(path: Option<&Path>) -> Result<(), String> {
    if let Some(word) = path
        .filter(|p| !p.exists() && p.extension().is_none() && p.components().count() == 1)
        .and_then(|p| p.to_str())
    {
        let hint = skeletrace_core::model::names::nearest(word, &COMMANDS)
            .map_or_else(String::new, |c| format!("; did you mean `{c}`?"));
        return Err(format!(
            "'{word}' is neither a command nor a scene file{hint} (commands: {}; \
             `skeletrace --help` says more)",
            COMMANDS.join(", ")
        ));
    }
    skeletrace::editor::run(path)
}

/// The estimated memory past which `export` refuses without `--allow-large`.
const EXPORT_MEMORY_LIMIT: u64 = 4_000_000_000;

/// `export`: states the estimate (refusing past [`EXPORT_MEMORY_LIMIT`]), then extracts,
/// reports and writes; a progress bar on standard error when it is a terminal.
fn run_export(args: &cli::ExportArgs, scene: &Scene) -> Result<(), String> {
    let started = std::time::Instant::now();
    let terminal = std::io::stderr().is_terminal();
    let estimate = skeletrace::export::estimate(scene, args.resolution)
        .map_err(|e| format!("{}: {e}", args.scene.display()))?;
    let stated = format!(
        "{} grid points, about {} triangles and {:.0} MB",
        estimate.grid_points,
        estimate.triangles,
        estimate.bytes as f64 / 1e6
    );
    if estimate.bytes > EXPORT_MEMORY_LIMIT && !args.allow_large {
        return Err(format!(
            "{} at --resolution {}: {stated}, past the limit of {:.0} MB; choose a smaller \
             --resolution or pass --allow-large",
            args.scene.display(),
            args.resolution,
            EXPORT_MEMORY_LIMIT as f64 / 1e6
        ));
    }
    // On a terminal, beside the progress bar; otherwise the summary says it (a failure stays
    // one line on standard error).
    if terminal && !args.json {
        eprintln!("skeletrace: exporting {}: {stated}", args.scene.display());
    }
    let progress = |fraction: f64| {
        if terminal {
            let filled = (fraction * 30.0).round() as usize;
            eprint!(
                "\rsampling the field [{}{}] {:3.0} %",
                "#".repeat(filled),
                " ".repeat(30 - filled.min(30)),
                100.0 * fraction
            );
        }
    };
    let mesh = skeletrace::export::extract(scene, args.resolution, &progress)
        .map_err(|e| format!("{}: {e}", args.scene.display()))?;
    if terminal {
        eprintln!();
    }
    skeletrace::export::write_mesh(scene, &mesh, &args.output, &[&args.scene])?;
    if mesh.cut_at_box {
        eprintln!(
            "skeletrace: {}: a plane was cut at the box of the other primitives' supports and closed there by a cap",
            args.scene.display()
        );
    }
    let r = &mesh.report;
    if r.lost_features > 0 {
        eprintln!(
            "skeletrace: {}: {} points of the skeleton lie in parts thinner than a cell ({:.4}), missing from the mesh; a larger --resolution keeps them",
            args.scene.display(),
            r.lost_features,
            mesh.cell
        );
    }
    if args.json {
        #[derive(serde::Serialize)]
        struct ExportJson<'a> {
            output: String,
            cell: f64,
            groups: usize,
            seconds: f64,
            #[serde(flatten)]
            report: &'a skeletrace_core::isosurface::MeshReport,
        }
        let json = ExportJson {
            output: args.output.display().to_string(),
            cell: mesh.cell,
            groups: mesh.triangles.iter().filter(|t| !t.is_empty()).count(),
            seconds: started.elapsed().as_secs_f64(),
            report: r,
        };
        return stdout::print(
            &(serde_json::to_string_pretty(&json).map_err(|e| e.to_string())? + "\n"),
        );
    }
    stdout::print(&format!(
        "{}: {} vertices, {} triangles in {} group meshes (estimated {stated}), cell {:.4}; {}: {} boundary edges, {} non-manifold edges, {} non-manifold vertices, {} degenerate triangles, {} misoriented edges, volume {:.4e}; vertices within {:.1e} cells of the surface; {:.1} s\n",
        args.output.display(),
        r.vertices,
        r.triangles,
        mesh.triangles.iter().filter(|t| !t.is_empty()).count(),
        mesh.cell,
        if r.watertight {
            "watertight"
        } else {
            "NOT watertight"
        },
        r.boundary_edges,
        r.non_manifold_edges,
        r.non_manifold_vertices,
        r.degenerate_triangles,
        r.misoriented_edges,
        r.volume,
        r.max_distance_cells,
        started.elapsed().as_secs_f64()
    ))
}

fn run_generate(args: &cli::GenerateArgs) -> Result<(), String> {
    let options = GenerateOptions {
        seed: args.seed,
        size: args.size,
        groups: args.groups,
        varying_radii: matches!(args.radii, cli::Radii::Varying),
        field: Some(args.field.into()),
        allow_large: args.allow_large,
    };
    let kind: GeneratorKind = args.kind.into();
    let mut scene = generate(kind, &options)?;
    // A three-quarter view of the whole scene, from its compiled supports.
    scene.camera = skeletrace_core::compile::framing_camera(&skeletrace_core::compile(&scene));
    let comment = format!(
        "{}\nGenerated by `skeletrace generate {} --seed {}{}{}`.",
        kind.description(),
        kind.name(),
        args.seed,
        args.size
            .map_or_else(String::new, |n| format!(" --size {n}")),
        args.groups
            .map_or_else(String::new, |n| format!(" --groups {n}"))
    );
    scene
        .save_with_comment(&args.output, &comment)
        .map_err(|e| e.to_string())?;
    let c = scene.counts();
    stdout::print(&format!(
        "wrote {}: {} segments, {} blobs (seed {})\n",
        args.output.display(),
        c.segments,
        c.blobs,
        args.seed
    ))
}

fn run_import(args: &cli::ImportArgs) -> Result<(), String> {
    let (scene, moved) = skeletrace::import::swc_scene(&args.input)?;
    let comment = format!(
        "Imported by `skeletrace import` from {}: one group per SWC structure type, one \
         skeleton per tree; {moved} radii brought within the kernel's slope limit.",
        args.input.display()
    );
    scene
        .save_with_comment(&args.output, &comment)
        .map_err(|e| e.to_string())?;
    let c = scene.counts();
    stdout::print(&format!(
        "wrote {}: {} groups, {} skeletons, {} vertices, {} segments ({moved} radii brought within the kernel's slope limit)\n",
        args.output.display(),
        c.groups,
        c.skeletons,
        c.vertices,
        c.segments
    ))
}

/// The methods named by `list`, and those `all` left out with the reason (also reported on
/// standard error).
fn chosen_methods(
    list: &str,
    program: &FieldProgram,
    mode: TraceMode,
) -> Result<(Vec<MethodId>, Vec<Skipped>), String> {
    // What keeps a method out, and why.
    let applies = |id: MethodId| {
        let method = id.method();
        method
            .supports(program)
            .map_err(|why| ("does not apply to this scene", why))?;
        method
            .traces(mode)
            .map_err(|why| ("cannot trace transparent rays", why))
    };
    if list == "all" {
        let (mut out, mut skipped) = (Vec::new(), Vec::new());
        for id in MethodId::ALL {
            match applies(id) {
                Ok(()) => out.push(id),
                Err((_, reason)) => {
                    eprintln!("skeletrace: skipping {id}: {reason}");
                    skipped.push(Skipped {
                        name: id.name(),
                        reason,
                    });
                }
            }
        }
        return Ok((out, skipped));
    }
    let ids = MethodId::parse_list(list)?;
    for &id in &ids {
        applies(id).map_err(|(what, why)| format!("method '{id}' {what}: {why}"))?;
    }
    Ok((ids, Vec::new()))
}

/// The methods of `chosen` `stats` traces on the CPU and on the GPU, as
/// `skeletrace_core::backend::decide` decides for `--backend` (the GPU opened unless the choice
/// is the CPU; `all` leaves out, with the reason, a method the GPU lacks under `--backend gpu`),
/// and the GPU.
///
/// # Errors
/// `--backend gpu` without a GPU, or a named method the GPU lacks there.
fn stats_sides(
    args: &cli::StatsArgs,
    compiled: &skeletrace_core::Compiled,
    chosen: &[MethodId],
    protocol: Protocol,
    skipped: &mut Vec<Skipped>,
) -> Result<StatsSides, String> {
    let gpu = match args.backend {
        BackendChoice::Cpu => Err("the CPU backend was chosen".to_owned()),
        _ => GpuRenderer::new().map_err(|e| e.to_string()),
    };
    if let (BackendChoice::Gpu, Err(why)) = (args.backend, &gpu) {
        return Err(format!("--backend gpu: {why}"));
    }
    // What the statistics ask of a backend: rays under the profile's settings, no shading.
    let request = FrameRequest {
        camera: skeletrace_core::model::scene::Camera::default(),
        width: 1,
        height: 1,
        methods: Vec::new(),
        view: View::Steps { steps_max: 0 },
        shadows: false,
        settings: TraceSettings::for_protocol(&compiled.program, protocol),
        cancel: Cancel::new(),
    };
    let (mut on_cpu, mut on_gpu) = (Vec::new(), Vec::new());
    for &id in chosen {
        let capabilities = gpu
            .as_ref()
            .map(|g| g as &dyn Capabilities)
            .map_err(String::as_str);
        match decide(args.backend, capabilities, compiled, id, &request) {
            Ok(Side::Cpu) => on_cpu.push(id.method()),
            // The decision asked the GPU's support already: `id` has a GPU method.
            Ok(Side::Gpu) => on_gpu.extend(GpuMethod::from_id(id)),
            Err(BackendError::Unsupported(reason)) if args.methods == "all" => {
                eprintln!("skeletrace: skipping {id}: {reason}");
                skipped.push(Skipped {
                    name: id.name(),
                    reason,
                });
            }
            Err(e) => return Err(format!("method '{id}': {e}")),
        }
    }
    Ok(StatsSides {
        on_cpu,
        on_gpu,
        gpu,
    })
}

/// The methods `stats` traces on each side, and the GPU.
struct StatsSides {
    on_cpu: Vec<Box<dyn Method>>,
    on_gpu: Vec<GpuMethod>,
    /// The GPU opened for `--backend gpu` or `auto`, or why there is none.
    gpu: Result<GpuRenderer, String>,
}

/// Most rays `stats` traces per method on the CPU, which keeps every ray's outcome until the
/// method's tally (about 200 bytes a ray: 2 GB here), and on the GPU, which keeps every ray's
/// step count (4 bytes). The papers trace 10⁷.
const MAX_STATS_RAYS: (usize, usize) = (10_000_000, 100_000_000);

/// `Err` when `stats --rays` is below one ray per axis direction or past [`MAX_STATS_RAYS`].
fn check_stats_rays(rays: usize, on_gpu: bool) -> Result<(), String> {
    let (most, backend) = if on_gpu {
        (MAX_STATS_RAYS.1, "GPU")
    } else {
        (MAX_STATS_RAYS.0, "CPU")
    };
    if (6..=most).contains(&rays) {
        Ok(())
    } else {
        Err(format!(
            "--rays {rays}: expected from 6 (one per axis direction) to {most} on the {backend}"
        ))
    }
}

/// `stats --json`: DESIGN.md's schema, and the methods left out with their reasons.
#[derive(serde::Serialize)]
struct StatsReport<'a> {
    scene: &'a str,
    rays: usize,
    protocol: &'static str,
    transparent: bool,
    methods: &'a [stats::MethodStats],
    skipped: Vec<Skipped>,
}

fn run_stats(args: &cli::StatsArgs) -> Result<(), String> {
    let scene = load(Some(&args.scene))?;
    let compiled = std::sync::Arc::new(skeletrace_core::compile(&scene));
    let program = &compiled.program;
    let mode = if args.transparent {
        TraceMode::Transparent
    } else {
        TraceMode::Opaque
    };
    let (chosen, mut skipped) = chosen_methods(&args.methods, program, mode)?;
    let terminal = std::io::stderr().is_terminal();
    let progress = |name: &str, fraction: f64| {
        if terminal {
            eprint!("\r{name:<28} {:>3.0} %", 100.0 * fraction);
        }
    };
    let name = args.scene.display().to_string();
    let setup = stats::StatsSetup {
        rays: args.rays,
        seed: args.seed,
        protocol: args.protocol,
        mode,
    };
    let StatsSides {
        on_cpu,
        on_gpu,
        gpu,
    } = stats_sides(args, &compiled, &chosen, setup.protocol, &mut skipped)?;
    check_stats_rays(args.rays, on_cpu.is_empty() && !on_gpu.is_empty())?;
    let mut methods = Vec::new();
    let (mut rays, mut protocol) = (args.rays, args.protocol);
    if !on_cpu.is_empty() {
        let cpu = stats::run(program, &name, &on_cpu, setup, &progress)?;
        (rays, protocol) = (cpu.rays, cpu.protocol);
        methods.extend(cpu.methods);
    }
    if let (false, Ok(mut gpu)) = (on_gpu.is_empty(), gpu) {
        eprintln!(
            "skeletrace: {} rays per method on {}; the first {} compared with the reference on the CPU",
            setup.rays,
            gpu.adapter_name(),
            args.compared.min(setup.rays)
        );
        let traced = skeletrace_render::gpu_stats::run(
            &mut gpu,
            &compiled,
            &name,
            &on_gpu,
            (setup, args.compared),
            &progress,
        )
        .map_err(|e| e.to_string())?;
        (rays, protocol) = (traced.rays, traced.protocol);
        methods.extend(traced.methods);
    }
    // In the order asked, whichever side traced them.
    methods.sort_by_key(|m| chosen.iter().position(|id| id.name() == m.name));
    let stats = stats::SceneStats {
        scene: name.clone(),
        rays,
        protocol,
        mode,
        methods,
    };
    if terminal {
        eprint!("\r{:40}\r", "");
    }
    if args.json {
        stdout::print_json(&StatsReport {
            scene: &stats.scene,
            rays: stats.rays,
            protocol: stats.protocol.name(),
            transparent: stats.mode == TraceMode::Transparent,
            methods: &stats.methods,
            skipped,
        })
    } else {
        stdout::print(&format!(
            "{name}: {} {} rays per method, protocol {}\n{}",
            stats.rays,
            if args.transparent {
                "transparent"
            } else {
                "opaque"
            },
            stats.protocol,
            stats.to_table()
        ))
    }
}

/// `info --json`: what `info` prints, as a record.
#[derive(serde::Serialize)]
struct InfoReport {
    scene: String,
    version: u32,
    isovalue: f64,
    counts: InfoCounts,
    primitives: usize,
    groups: Vec<InfoGroup>,
    /// The support box; `None` (`null`) when no primitive is bounded.
    bounds: Option<InfoBox>,
    unbounded_planes: bool,
    /// The support box snapped to its grid, which trace tolerances follow.
    scale_box: Option<InfoBox>,
}

#[derive(serde::Serialize)]
struct InfoCounts {
    groups: usize,
    skeletons: usize,
    vertices: usize,
    segments: usize,
    blobs: usize,
    shapes: usize,
    hrbf_points: usize,
}

#[derive(serde::Serialize)]
struct InfoGroup {
    name: String,
    kernel: String,
    colour: [f64; 3],
    opacity: f64,
}

#[derive(serde::Serialize)]
struct InfoBox {
    min: [f64; 3],
    max: [f64; 3],
    diagonal: f64,
}

impl InfoBox {
    fn of(aabb: skeletrace_core::Aabb) -> Self {
        Self {
            min: aabb.min.to_array(),
            max: aabb.max.to_array(),
            diagonal: aabb.diagonal(),
        }
    }
}

fn print_info(args: &cli::InfoArgs, scene: &Scene) -> Result<(), String> {
    let name = args.scene.display().to_string();
    let c = scene.counts();
    let program = FieldProgram::new(scene);
    let bounds = program.support_bounds();
    let report = InfoReport {
        scene: name,
        version: scene.version,
        isovalue: scene.isovalue,
        counts: InfoCounts {
            groups: c.groups,
            skeletons: c.skeletons,
            vertices: c.vertices,
            segments: c.segments,
            blobs: c.blobs,
            shapes: c.shapes,
            hrbf_points: c.hrbf_points,
        },
        primitives: program.primitives().len(),
        groups: scene
            .groups
            .iter()
            .map(|g| InfoGroup {
                name: g.name.clone(),
                kernel: format!("{:?}", g.kernel),
                colour: g.material.color,
                opacity: g.material.opacity,
            })
            .collect(),
        bounds: (!bounds.is_empty()).then(|| InfoBox::of(bounds)),
        unbounded_planes: program.has_unbounded_support(),
        scale_box: (!bounds.is_empty()).then(|| InfoBox::of(program.scale_bounds())),
    };
    if args.json {
        return stdout::print_json(&report);
    }
    stdout::print(&info_text(&report))
}

/// `info`'s lines.
fn info_text(r: &InfoReport) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let c = &r.counts;
    let _ = writeln!(out, "scene      {}", r.scene);
    let _ = writeln!(out, "validation ok (version {})", r.version);
    let _ = writeln!(out, "isovalue   {}", r.isovalue);
    let _ = writeln!(
        out,
        "counts     {} groups, {} skeletons, {} vertices, {} segments, {} blobs, {} shapes, \
         {} HRBF points",
        c.groups, c.skeletons, c.vertices, c.segments, c.blobs, c.shapes, c.hrbf_points
    );
    let _ = writeln!(
        out,
        "primitives {} (segments, end-point correctors, blobs, shapes, copies, HRBF terms)",
        r.primitives
    );
    for (i, g) in r.groups.iter().enumerate() {
        let _ = writeln!(
            out,
            "group {i}    '{}': {}, colour {:?}, opacity {}",
            g.name, g.kernel, g.colour, g.opacity
        );
    }
    let f = |v: [f64; 3]| format!("({:.3}, {:.3}, {:.3})", v[0], v[1], v[2]);
    match (&r.bounds, &r.scale_box) {
        (Some(b), Some(scale)) => {
            let _ = writeln!(
                out,
                "bounds     {} .. {} (diagonal {:.3}){}",
                f(b.min),
                f(b.max),
                b.diagonal,
                if r.unbounded_planes {
                    ", plus unbounded planes"
                } else {
                    ""
                }
            );
            let _ = writeln!(
                out,
                "scale box  {} .. {} (diagonal {:.3}): the bounds snapped to their grid, which \
                 the trace tolerances and the rays' reach follow",
                f(scale.min),
                f(scale.max),
                scale.diagonal,
            );
        }
        _ => out.push_str("bounds     none (no bounded primitive)\n"),
    }
    out
}
