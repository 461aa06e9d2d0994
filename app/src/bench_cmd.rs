//! `skeletrace bench`: milliseconds per full frame per method (median of several frames after
//! a warm-up that also compiles the GPU pipelines and lasts at least [`WARM_UP`], so that a GPU
//! has left its idle clock), on the CPU tracer or the GPU backend, with the adapter name. On the
//! GPU, where the adapter has timestamp queries, also the GPU's own time for the trace pass and
//! the tile binning: the wall-clock frame holds the readback and the conversion to frames as
//! well; the size of the frame's tile lists, which a scene of many primitives fills first; and
//! the method's first frame, which holds its pipelines' compilation (what a new blend tree or
//! primitive kind costs the editor before its first GPU frame).
//! With `--after-edits`, the frames that follow vertex edits on the CPU, which copies the
//! tiles and rays an edit did not reach, as in the editor (`CpuBackend::reusing_tiles`).

use std::fmt::Write as _;
use std::sync::Arc;
use std::time::Instant;

use skeletrace_core::backend::{
    BackendChoice, BackendError, Cancel, DeviceKind, FrameBackend, FrameRequest,
    PipelineCacheState, TileLists,
};
use skeletrace_core::compile::Compiled;
use skeletrace_core::cpu::cpu_backend::CpuBackend;
use skeletrace_core::frame::{FieldShading, View};
use skeletrace_core::methods::{MethodId, TraceMode, TraceSettings};
use skeletrace_core::{Scene, compile};

use crate::cli::BenchArgs;
use crate::render_cmd::parse_size;
use crate::stdout::Skipped;
use skeletrace::backends::Backends;

/// Shortest warm-up per method. An idle H100 runs at 345 MHz and reaches its 1 980 MHz within
/// a few dozen frames: after one warm-up frame, the median of 7 frames of the tree read 3.9 ms
/// where 40 frames read 2.0 ms.
const WARM_UP: std::time::Duration = std::time::Duration::from_millis(500);

/// Renders untimed frames until [`WARM_UP`] has passed (at least one); returns the first
/// frame's milliseconds, which on the GPU hold the method's pipeline compilation (and, for the
/// first method, the scene's upload).
fn warm_up<E>(mut frame: impl FnMut() -> Result<(), E>) -> Result<f64, E> {
    let start = Instant::now();
    frame()?;
    let first_ms = start.elapsed().as_secs_f64() * 1e3;
    while start.elapsed() < WARM_UP {
        frame()?;
    }
    Ok(first_ms)
}

/// The median of `v` (NaN when empty).
pub(crate) fn median(mut v: Vec<f64>) -> f64 {
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
    /// The last timed frame's tile lists (GPU).
    tile_lists: Option<TileLists>,
    /// Milliseconds of the method's first frame, untimed above (not after edits).
    first_frame_ms: Option<f64>,
    /// After edits: what the frames copied, and their spread.
    edits: Option<AfterEdits>,
}

/// The frames of `--after-edits` beyond their median.
struct AfterEdits {
    /// On the CPU, what the frames copied from the frame before.
    copied: Option<Copied>,
    /// Mean and largest milliseconds per frame: the median hides the edits traced in full.
    mean_ms: f64,
    slowest_ms: f64,
    edits: usize,
}

/// What the CPU's frames after edits copied.
struct Copied {
    /// Median shares of screen tiles copied whole and of pixels copied instead of traced.
    tiles: f64,
    pixels: f64,
    /// How many of the frames copied no pixel.
    traced_in_full: usize,
}

/// Most edits `--after-edits` times per method.
const MOST_EDITS: usize = 64;

/// What one edit of `--after-edits` moves, in group `group`.
struct EditTarget {
    group: usize,
    item: EditItem,
}

enum EditItem {
    /// Vertex `.1` of skeleton `.0`.
    Vertex(usize, usize),
    /// Point blob `.0`.
    Blob(usize),
}

/// The scene's skeleton vertices and point blobs, at most [`MOST_EDITS`] of them evenly
/// spread over the scene's order.
fn edit_targets(scene: &Scene) -> Vec<EditTarget> {
    let all: Vec<EditTarget> = scene
        .groups
        .iter()
        .enumerate()
        .flat_map(|(group, g)| {
            let vertices = g
                .skeletons
                .iter()
                .enumerate()
                .flat_map(move |(s, skeleton)| {
                    (0..skeleton.vertices.len()).map(move |v| EditTarget {
                        group,
                        item: EditItem::Vertex(s, v),
                    })
                });
            let blobs = (0..g.blobs.len()).map(move |b| EditTarget {
                group,
                item: EditItem::Blob(b),
            });
            vertices.chain(blobs)
        })
        .collect();
    let stride = all.len().div_ceil(MOST_EDITS).max(1);
    all.into_iter().step_by(stride).collect()
}

/// Traces a compiled scene after an edit; on the CPU, the shares of tiles and pixels it copied.
type TraceEdit<'a> = dyn FnMut(&Arc<Compiled>) -> Result<Option<(f64, f64)>, BackendError> + 'a;

/// The frames after edits of one method (`--after-edits`): the scene's skeleton vertices and
/// point blobs ([`edit_targets`]) moved one after the other, each edit compiled and its frame
/// traced — on the CPU by a backend that keeps its last frames, on a GPU by `gpu` (which
/// uploads the primitives an edit changed, as the editor's viewport does while a vertex is
/// dragged); the first, full frame is not timed.
fn after_edits(
    scene: &Scene,
    method: MethodId,
    request: &FrameRequest,
    gpu: Option<&mut dyn FrameBackend>,
) -> Result<Row, String> {
    let mut scene = scene.clone();
    let fail = |e: BackendError| format!("{method}: {e}");
    let mut cpu = CpuBackend::reusing_tiles();
    let mut trace: Box<TraceEdit<'_>> = match gpu {
        Some(gpu) => Box::new(move |c| gpu.render(c, request).map(|_| None)),
        None => Box::new(move |c| {
            cpu.render(c, request)?;
            Ok(Some((
                cpu.share_of_tiles_reused(),
                cpu.share_of_pixels_reused(),
            )))
        }),
    };
    trace(&compile(&scene)).map_err(fail)?;
    let targets = edit_targets(&scene);
    if targets.is_empty() {
        return Err(
            "--after-edits moves skeleton vertices and point blobs: the scene has none".to_owned(),
        );
    }
    let (mut times, mut tiles, mut pixels) = (Vec::new(), Vec::new(), Vec::new());
    for target in targets {
        let group = &mut scene.groups[target.group];
        let (position, radius) = match target.item {
            EditItem::Vertex(s, v) => {
                let vertex = &mut group.skeletons[s].vertices[v];
                (&mut vertex.position, vertex.radius)
            }
            EditItem::Blob(b) => {
                let blob = &mut group.blobs[b];
                (&mut blob.center, blob.radius)
            }
        };
        position[1] += 0.05 * radius;
        let compiled = compile(&scene);
        let start = Instant::now();
        let shares = trace(&compiled).map_err(fail)?;
        times.push(start.elapsed().as_secs_f64() * 1e3);
        if let Some((t, p)) = shares {
            tiles.push(t);
            pixels.push(p);
        }
    }
    let edits = AfterEdits {
        copied: (!tiles.is_empty()).then(|| Copied {
            tiles: median(tiles),
            traced_in_full: pixels.iter().filter(|share| **share == 0.0).count(),
            pixels: median(pixels),
        }),
        mean_ms: times.iter().sum::<f64>() / times.len() as f64,
        slowest_ms: times.iter().copied().fold(0.0, f64::max),
        edits: times.len(),
    };
    Ok(Row {
        name: method.name(),
        frame_ms: median(times),
        passes: None,
        tile_lists: None,
        first_frame_ms: None,
        edits: Some(edits),
    })
}

/// The shaded frame of `method` alone through the scene camera that `bench` times.
pub(crate) fn method_request(
    scene: &Scene,
    compiled: &Compiled,
    method: MethodId,
    (width, height): (usize, usize),
    args: &BenchArgs,
) -> FrameRequest {
    FrameRequest {
        camera: scene.camera,
        width,
        height,
        methods: vec![method],
        view: View::Shaded(FieldShading::default()),
        shadows: false,
        settings: TraceSettings::for_protocol(&compiled.program, args.protocol),
        cancel: Cancel::new(),
    }
}

/// Runs `bench`.
///
/// # Errors
/// Bad arguments, a method that does not run on the chosen backend, a failed device.
pub fn run(args: &BenchArgs, scene: &Scene) -> Result<(), String> {
    let (width, height) = parse_size(&args.size)?;
    let compiled = compile(scene);
    let frames = args.frames;
    let (chosen, mut skipped) =
        crate::chosen_methods(&args.methods, &compiled.program, TraceMode::Opaque)?;
    let mut backends = Backends::open(args.backend);
    if args.backend == BackendChoice::Gpu
        && let Err(why) = &backends.gpu
    {
        return Err(format!("--backend gpu: {why}"));
    }
    // What the GPU's pipeline cache held when it opened: the first frames' times are those of
    // a cold cache (empty) or a warm one.
    let pipeline_cache = backends.gpu.as_ref().ok().and_then(|g| g.pipeline_cache());
    let mut rows: Vec<Row> = Vec::new();
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
        if args.after_edits {
            let gpu = (backend.device_kind() != DeviceKind::Cpu).then_some(backend);
            rows.push(after_edits(scene, method, &request, gpu)?);
            if !devices.contains(&device) {
                devices.push(device);
            }
            continue;
        }
        let fail = |e: BackendError| format!("{method} on {device}: {e}");
        let first_frame_ms =
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
            tile_lists: backend.last_tile_lists(),
            first_frame_ms: Some(first_frame_ms),
            edits: None,
        });
    }
    let device = devices.join(" and ");
    if args.json {
        let scene = args.scene.display().to_string();
        let methods = rows.iter().map(BenchMethod::of).collect();
        crate::stdout::print_json(&BenchReport {
            scene: &scene,
            device: &device,
            width,
            height,
            frames,
            pipeline_cache: pipeline_cache.map(CacheRecord::of),
            methods,
            skipped,
        })
    } else {
        let timed = if args.after_edits {
            "median of the frames after moving each skeleton vertex and point blob (at most 64)"
                .to_owned()
        } else {
            format!("median of {frames} frames")
        };
        let mut text = format!(
            "{}: {width}x{height} on {device}, {timed}\n",
            args.scene.display()
        );
        if let Some(cache) = &pipeline_cache {
            let _ = writeln!(
                text,
                "pipeline cache {}: {}",
                cache.path,
                if cache.loaded_bytes == 0 {
                    "cold (empty)".to_owned()
                } else {
                    format!("warm ({} bytes)", cache.loaded_bytes)
                }
            );
        }
        for row in rows {
            let passes = row.passes.map_or(String::new(), |(trace, binning)| {
                format!("   (GPU: trace {trace:.3} ms, binning {binning:.3} ms)")
            }) + &row.tile_lists.map_or(String::new(), |lists| {
                format!(
                    "   (tile lists: {:.2} MB, {}-pixel tiles)",
                    lists.bytes() as f64 / 1e6,
                    lists.tile_edge
                )
            }) + &row
                .passes
                .and(row.first_frame_ms)
                .map_or(String::new(), |ms| {
                    format!("   (first frame {ms:.0} ms, pipelines compiled)")
                }) + &row.edits.as_ref().map_or(String::new(), |e| match &e.copied {
                Some(c) => format!(
                    "   ({:.1} % of tiles copied whole, {:.1} % of pixels copied; mean {:.2} ms, slowest {:.2} ms, {} of {} edits traced in full)",
                    100.0 * c.tiles,
                    100.0 * c.pixels,
                    e.mean_ms,
                    e.slowest_ms,
                    c.traced_in_full,
                    e.edits
                ),
                None => format!(
                    "   (mean {:.2} ms, slowest {:.2} ms over {} edits)",
                    e.mean_ms, e.slowest_ms, e.edits
                ),
            });
            let _ = writeln!(
                text,
                "{:<28} {:>10.2} ms/frame{passes}",
                row.name, row.frame_ms
            );
        }
        crate::stdout::print(&text)
    }
}

/// `bench --json`.
#[derive(serde::Serialize)]
struct BenchReport<'a> {
    scene: &'a str,
    device: &'a str,
    width: usize,
    height: usize,
    frames: usize,
    /// The GPU's persistent pipeline cache when it opened, where it keeps one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pipeline_cache: Option<CacheRecord>,
    methods: Vec<BenchMethod>,
    /// Methods `all` left out, with the reason.
    skipped: Vec<Skipped>,
}

/// `pipeline_cache` of `bench --json`.
#[derive(serde::Serialize)]
struct CacheRecord {
    path: String,
    /// `cold` (it started empty) or `warm`.
    state: &'static str,
    loaded_bytes: u64,
}

impl CacheRecord {
    fn of(cache: PipelineCacheState) -> Self {
        Self {
            state: if cache.loaded_bytes == 0 {
                "cold"
            } else {
                "warm"
            },
            path: cache.path,
            loaded_bytes: cache.loaded_bytes,
        }
    }
}

/// One method of `bench --json`; the fields a backend or mode lacks are left out.
#[derive(serde::Serialize)]
struct BenchMethod {
    name: &'static str,
    ms_per_frame: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    gpu_trace_ms: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gpu_binning_ms: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tile_list_items: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tile_edge: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    first_frame_ms: Option<f64>,
    #[serde(flatten)]
    edits: Option<EditsRecord>,
}

/// The `--after-edits` fields of a method.
#[derive(serde::Serialize)]
struct EditsRecord {
    #[serde(skip_serializing_if = "Option::is_none")]
    tiles_reused: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pixels_reused: Option<f64>,
    mean_ms: f64,
    slowest_ms: f64,
    edits: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    traced_in_full: Option<usize>,
}

impl BenchMethod {
    fn of(row: &Row) -> Self {
        Self {
            name: row.name,
            ms_per_frame: row.frame_ms,
            gpu_trace_ms: row.passes.map(|p| p.0),
            gpu_binning_ms: row.passes.map(|p| p.1),
            tile_list_items: row.tile_lists.map(|l| l.items),
            tile_edge: row.tile_lists.map(|l| l.tile_edge),
            first_frame_ms: row.first_frame_ms,
            edits: row.edits.as_ref().map(|e| EditsRecord {
                tiles_reused: e.copied.as_ref().map(|c| c.tiles),
                pixels_reused: e.copied.as_ref().map(|c| c.pixels),
                mean_ms: e.mean_ms,
                slowest_ms: e.slowest_ms,
                edits: e.edits,
                traced_in_full: e.copied.as_ref().map(|c| c.traced_in_full),
            }),
        }
    }
}
