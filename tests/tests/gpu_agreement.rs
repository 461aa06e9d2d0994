//! CPU/GPU agreement (issue: "the wgpu ray-tracing backend"): for every asset, two cameras each
//! (one on the large and slow scenes) and every GPU method
//! that applies, the GPU frame is compared pixel by pixel with the
//! CPU tracer's, and the agreement printed: hit masks, worst depth difference, equal step
//! counts and the distribution of the differences. Runs on whatever adapter wgpu finds —
//! Mesa's lavapipe in CI — and fails, never skips, when there is none.
//!
//! The thresholds (hit masks equal on ≥ 99.9 % of pixels, depth within 10⁻³ of the
//! support diagonal, steps equal on ≥ 99 %) are asserted for every method, with four measured
//! allowances, below. Some step counts are sensitive to perturbations at f32 precision:
//! - bottom-up-quadratic even in f64: on the CPU alone, moving the camera by 2.4·10⁻⁷ of its
//!   distance (two f32 ulps) changes the step count of 1–2 % of the pixels (a validity
//!   interval ending at the support's exit computed another way rounds a few ulps short of the
//!   part's end or not, and the march takes one more step over that sliver or not);
//! - sphere tracing and its over-relaxed variant in f32: hundreds of steps, each rounding the
//!   ray parameter to an f32 ulp, decide whether the last step falls below ε; the GPU's own
//!   step counts change under the same camera move on 1–4 % of the pixels.
//!
//! No march can agree with another better than the two agree with themselves at f32
//! precision, so where the GPU misses 99 %, the test measures the CPU's self-agreement under
//! that camera move ([`self_agreement`]) and asks for the GPU to be within
//! [`PERTURBATION_MARGIN`] of it. Where the GPU misses that too, it measures the GPU's own:
//! each march changes its step count on its own sensitive pixels, and CPU and GPU, which differ
//! by far more than two ulps, may each land on the other side on theirs, so the two fractions
//! of changed pixels add: the GPU is held to `CPU's + GPU's self-agreement − 1 −` the margin.
//! (Random scenes with tori need it: on seed 43 of `shapes_match_the_cpu_tracer`, quadratic
//! Taylor changes 1.6 % of its step counts on the CPU and 1.4 % on the GPU under the camera
//! move, and the two backends differ on 2.9 %.)
//!
//! Long marches drift: over hundreds of f32 steps the ray parameter's rounding adds up. On the
//! creature (40×40), sphere tracing takes 128–2 048 steps on most hit pixels; every pixel
//! where the GPU's sphere-tracing count differs from the CPU's has a march of at least 246
//! steps, differing by at most 1.09 % of its length, and for sphere-enhanced of at least 113
//! steps, differing by one step below 200. Step counts of two marches of at least
//! [`LONG_MARCH`] steps that differ by at most [`DRIFT`] of the CPU's count therefore agree;
//! the test prints the strictly equal fraction too.
//!
//! A march that runs out of its step budget has no verdict on its pixel, and whether a long
//! march ends just before or just after the budget depends on its last bits (on the creature,
//! sphere-enhanced on the CPU runs out on 29 pixels where the GPU's march ends at 1 948–2 015
//! steps): such pixels are left out of the hit mask and the agreeing steps (and counted, and a
//! GPU that runs out of steps on 1 % more of the pixels than the CPU fails). Hit masks are
//! otherwise held as they are.
//!
//! Depths are held to 10⁻³ of the diagonal, or where a frame misses that, to that plus the
//! largest change of the CPU's own depths under the camera move above (which by itself shifts
//! depths by about 10⁻⁶). Only sherstyuk has needed it: its crossing is a root of a cubic
//! interpolant, not of the field, and where the cubic barely reaches the isovalue the root moves
//! with the square root of a perturbation (random scene 42: the CPU's own depth moves by 1.4e-2
//! under the move, as much as the GPU's differs from it).

use std::path::Path;

use glam::DVec3;
use skeletrace_core::cpu::renderer::{RenderOptions, Renderer};
use skeletrace_core::frame::{Frame, View};
use skeletrace_core::methods::MethodId;
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::{Blend, Camera};
use skeletrace_core::{Scene, compile};
use skeletrace_render::{GpuMethod, GpuRenderer};
use skeletrace_tests::gpu_or_skip;

#[path = "../../core/tests/common/mod.rs"]
mod common;

const SIZE: usize = 40;

/// Marches of at least this many steps may drift (module docs).
const LONG_MARCH: u32 = 100;

/// How far, as a fraction of its length, a long march's step count may drift (module docs).
const DRIFT: f64 = 0.015;

/// How far below the self-agreement under an f32-sized camera perturbation the GPU's step
/// agreement may fall, where it is below 99 % (module docs).
const PERTURBATION_MARGIN: f64 = 0.01;

/// The relative camera perturbation of [`self_agreement`]: two f32 ulps.
const PERTURBATION: f64 = 2.0 / 8_388_608.0;

/// The GPU implementation of `id`.
fn shader_of(id: MethodId) -> GpuMethod {
    GpuMethod::from_id(id).unwrap_or_else(|| panic!("{} has no shader", id.name()))
}

fn load(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../assets/scenes/{name}.ron"));
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The scene camera turned by `degrees` about the vertical axis through its target.
fn orbit(camera: &Camera, degrees: f64) -> Camera {
    let target = DVec3::from_array(camera.target);
    let offset = DVec3::from_array(camera.position) - target;
    let (s, c) = degrees.to_radians().sin_cos();
    let turned = DVec3::new(
        c * offset.x + s * offset.z,
        offset.y,
        -s * offset.x + c * offset.z,
    );
    Camera {
        position: (target + turned).to_array(),
        ..*camera
    }
}

struct Agreement {
    /// Pixels whose march ran out of its step budget on the CPU, on the GPU.
    exhausted: (usize, usize),
    /// Pixels hit only on the CPU, only on the GPU (where neither ran out of steps).
    one_sided: (usize, usize),
    /// Equal hit masks, over the pixels where neither march ran out of steps.
    hit_mask: f64,
    worst_depth: f64,
    /// Pixels with equal step counts.
    equal_steps: f64,
    /// Pixels with equal step counts, or with long marches that differ by at most their
    /// drift ([`LONG_MARCH`], [`DRIFT`]), over the pixels where neither ran out of steps.
    agreeing_steps: f64,
    histogram: Vec<(i64, usize)>,
}

/// The GPU's shaded frames (default field shading, no shadows) of `methods` at `SIZE`², side by
/// side; a failure panics naming `label`.
fn shaded_frames(
    gpu: &mut GpuRenderer,
    methods: &[GpuMethod],
    camera: &Camera,
    settings: &skeletrace_core::methods::TraceSettings,
    label: &str,
) -> Vec<Frame> {
    try_shaded_frames(gpu, methods, camera, settings).unwrap_or_else(|e| panic!("{label}: {e}"))
}

/// The request of `methods` side by side at [`SIZE`]² through `camera`.
fn request(
    methods: &[GpuMethod],
    camera: &Camera,
    settings: &skeletrace_core::methods::TraceSettings,
    view: View,
    shadows: bool,
) -> skeletrace_core::backend::FrameRequest {
    skeletrace_core::backend::FrameRequest {
        camera: *camera,
        width: SIZE,
        height: SIZE,
        methods: methods.iter().map(|m| m.id()).collect(),
        view,
        shadows,
        settings: *settings,
        cancel: skeletrace_core::backend::Cancel::new(),
    }
}

/// [`shaded_frames`], with the renderer's error.
fn try_shaded_frames(
    gpu: &mut GpuRenderer,
    methods: &[GpuMethod],
    camera: &Camera,
    settings: &skeletrace_core::methods::TraceSettings,
) -> Result<Vec<Frame>, String> {
    gpu.render(&request(
        methods,
        camera,
        settings,
        View::Shaded(skeletrace_core::frame::FieldShading::default()),
        false,
    ))
    .map_err(|e| e.to_string())
}

/// Compares two frames of a method whose step budget is `budget`. A march that runs out of
/// steps has no verdict on its pixel: whether a long march ends just before or just after the
/// budget depends on the last bits of its steps, so such pixels count in the strictly equal
/// steps but not in the hit mask or the agreeing steps.
fn compare(cpu: &Frame, gpu: &Frame, budget: u32) -> Agreement {
    let n = cpu.steps.len();
    let mut same_hit = 0;
    let mut worst_depth: f64 = 0.0;
    let mut equal = 0;
    let mut agreeing = 0;
    let mut histogram = std::collections::BTreeMap::new();
    let mut one_sided = (0, 0);
    let mut exhausted = (0, 0);
    let mut with_verdict = 0;
    for i in 0..n {
        let (cpu_out, gpu_out) = (cpu.steps[i] >= budget, gpu.steps[i] >= budget);
        exhausted.0 += usize::from(cpu_out);
        exhausted.1 += usize::from(gpu_out);
        let d = i64::from(gpu.steps[i]) - i64::from(cpu.steps[i]);
        if d == 0 {
            equal += 1;
        } else {
            *histogram.entry(d.clamp(-5, 5)).or_insert(0) += 1;
        }
        if cpu_out || gpu_out {
            continue;
        }
        with_verdict += 1;
        let long = cpu.steps[i].min(gpu.steps[i]) >= LONG_MARCH;
        if d == 0 || (long && d.unsigned_abs() as f64 <= DRIFT * f64::from(cpu.steps[i])) {
            agreeing += 1;
        }
        match (cpu.is_hit(i), gpu.is_hit(i)) {
            (true, false) => one_sided.0 += 1,
            (false, true) => one_sided.1 += 1,
            _ => {}
        }
        if cpu.is_hit(i) == gpu.is_hit(i) {
            same_hit += 1;
            if cpu.is_hit(i) {
                worst_depth = worst_depth.max((cpu.depth[i] - gpu.depth[i]).abs());
            }
        }
    }
    // Where no pixel has a verdict (both marches ran out of steps everywhere), the hit masks
    // agree on every pixel there is to compare.
    let all_if_none = |n: u32| {
        if with_verdict == 0 {
            1.0
        } else {
            f64::from(n) / with_verdict as f64
        }
    };
    Agreement {
        exhausted,
        one_sided,
        hit_mask: all_if_none(same_hit),
        worst_depth,
        equal_steps: f64::from(equal) / n as f64,
        agreeing_steps: all_if_none(agreeing),
        histogram: histogram.into_iter().collect(),
    }
}

/// The last frame's GPU pass times, which `bench` reports: one trace time per method, all
/// finite; lavapipe has timestamp queries, so there they must be reported.
fn check_pass_times(gpu: &GpuRenderer, label: &str, methods: usize) {
    let Some(times) = gpu.last_pass_times() else {
        assert!(
            !gpu.adapter_name().contains("llvmpipe"),
            "{label}: lavapipe has timestamp queries, but no pass times were reported"
        );
        return;
    };
    assert_eq!(times.trace_ms.len(), methods, "{label}: {times:?}");
    assert!(
        times
            .trace_ms
            .iter()
            .chain([&times.binning_ms])
            .all(|ms| ms.is_finite() && *ms >= 0.0),
        "{label}: {times:?}"
    );
    assert!(
        times.trace_ms.iter().all(|&ms| ms > 0.0),
        "{label}: a trace pass took no time: {times:?}"
    );
}

/// Renders `scene` with those of `methods` that apply on each camera and compares each frame
/// with the CPU tracer's; the pairs that miss the thresholds (with the allowances of
/// the module docs) go to `failures`. Returns the most pixels the CPU tracer hit in one frame.
fn check_methods_agreement(
    gpu: &mut GpuRenderer,
    label: &str,
    scene: &Scene,
    cameras: &[Camera],
    methods: &[GpuMethod],
    failures: &mut Vec<String>,
) -> usize {
    let mut most_hits = 0;
    let compiled = compile(scene);
    let program = &compiled.program;
    let settings = compiled.settings;
    let diagonal = program.support_bounds().diagonal();
    gpu.set_scene(&compiled)
        .unwrap_or_else(|e| panic!("{label}: {e}"));
    // SKELETRACE_GPU_METHODS=a,b narrows the run while investigating some methods.
    let only = std::env::var("SKELETRACE_GPU_METHODS").ok();
    let gpu_methods: Vec<GpuMethod> = methods
        .iter()
        .copied()
        .filter(|m| {
            only.as_ref()
                .is_none_or(|o| o.split(',').any(|n| n == m.name()))
        })
        .filter(|m| m.supports(program).is_ok())
        .filter(|m| m.id().method().supports(program).is_ok())
        .collect();
    if gpu_methods.is_empty() {
        assert!(only.is_some(), "{label}: no GPU method applies");
        return 0;
    }
    for camera in cameras {
        let frames = shaded_frames(gpu, &gpu_methods, camera, &settings, label);
        check_pass_times(gpu, label, gpu_methods.len());
        for (method, gpu_frame) in gpu_methods.iter().zip(&frames) {
            let cpu_method = method.id().method();
            let tracer = cpu_method.prepare(program, settings);
            let cpu_render = |camera: &Camera| {
                Renderer::new(&compiled, tracer.as_ref(), settings).render(
                    camera,
                    RenderOptions {
                        width: SIZE,
                        height: SIZE,
                        shadows: false,
                        shading: skeletrace_core::frame::FieldShading::default(),
                    },
                )
            };
            let cpu_frame = cpu_render(camera);
            most_hits = most_hits.max((0..SIZE * SIZE).filter(|&i| cpu_frame.is_hit(i)).count());
            let a = compare(&cpu_frame, gpu_frame, settings.max_steps);
            // Below 99 %, or depths beyond 10⁻³ of the diagonal: the allowance the marches' own
            // sensitivity earns (module docs).
            let mut steps_needed = 0.99;
            let mut depth_allowed = 1e-3 * diagonal;
            let mut cpu_own = 1.0;
            if a.agreeing_steps < steps_needed || a.worst_depth > depth_allowed {
                let (own_steps, own_depth) = self_agreement("CPU", &cpu_frame, &cpu_render, camera);
                cpu_own = own_steps;
                steps_needed = (cpu_own - PERTURBATION_MARGIN).min(steps_needed);
                depth_allowed += own_depth;
            }
            if a.agreeing_steps < steps_needed {
                let gpu_render = |camera: &Camera| {
                    shaded_frames(gpu, &[*method], camera, &settings, label).remove(0)
                };
                let (own, _) = self_agreement("GPU", gpu_frame, gpu_render, camera);
                // Each march changes on its own sensitive pixels; the two sets add.
                steps_needed = (cpu_own + own - 1.0 - PERTURBATION_MARGIN).min(steps_needed);
            }
            eprintln!(
                "{label:<18} {:<20} hit mask {:.4} (CPU only {}, GPU only {}; out of steps: CPU {}, GPU {})  depth {:.1e} (held to {:.1e})  equal steps {:.4}, agreeing {:.4} (held to {steps_needed:.4})  differences {:?}",
                method.name(),
                a.hit_mask,
                a.one_sided.0,
                a.one_sided.1,
                a.exhausted.0,
                a.exhausted.1,
                a.worst_depth / diagonal,
                depth_allowed / diagonal,
                a.equal_steps,
                a.agreeing_steps,
                a.histogram
            );
            // A shader whose rays stall must not hide them from the hit mask.
            let meets = a.hit_mask >= 0.999
                && a.exhausted.1 <= a.exhausted.0 + SIZE * SIZE / 100
                && a.worst_depth <= depth_allowed
                && a.agreeing_steps >= steps_needed;
            if !meets {
                failures.push(format!("{label} {}", method.name()));
            }
        }
    }
    most_hits
}

/// How `frame` (rendered by `backend` through `camera`) agrees with the frame of the camera
/// moved by [`PERTURBATION`] of its position: the fraction of pixels whose step count is
/// unchanged, and the largest change of a depth (the move itself shifts depths by about
/// 10⁻⁶): how well a march agrees with itself at f32 precision.
fn self_agreement(
    backend: &str,
    frame: &Frame,
    mut render: impl FnMut(&Camera) -> Frame,
    camera: &Camera,
) -> (f64, f64) {
    let moved = Camera {
        position: camera.position.map(|p| p * (1.0 + PERTURBATION)),
        ..*camera
    };
    let own = compare(frame, &render(&moved), u32::MAX);
    eprintln!(
        "{:<39} {backend} against itself, camera moved by {PERTURBATION:.1e}: equal steps {:.4}, agreeing {:.4}, largest depth change {:.1e} (scene units)  differences {:?}",
        "", own.equal_steps, own.agreeing_steps, own.worst_depth, own.histogram
    );
    (own.agreeing_steps, own.worst_depth)
}

/// Every asset, in three lists by the kinds their pipelines are compiled for (shared.rs
/// `KindSet::TIERS`), one test of the suite each, which the binary's renderers run at once.
const POINT_BLOB_ASSETS: [&str; 3] = ["blobs", "molecule", "summed-blobs"];
/// See [`POINT_BLOB_ASSETS`].
const SKELETON_ASSETS: [&str; 6] = [
    "tree",
    "creature",
    "hand",
    "truss",
    "foam",
    "random-skeleton",
];
/// See [`POINT_BLOB_ASSETS`].
const SHAPE_AND_HRBF_ASSETS: [&str; 2] = ["operators", "hrbf"];

/// The three lists above hold every scene of `assets/scenes`, each once, so that a new asset
/// cannot miss the agreement test.
#[test]
fn every_asset_is_in_one_agreement_test() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes");
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|entry| {
            let name = entry.ok()?.file_name().into_string().ok()?;
            name.strip_suffix(".ron").map(str::to_owned)
        })
        .collect();
    on_disk.sort();
    let mut listed: Vec<String> = [
        &POINT_BLOB_ASSETS[..],
        &SKELETON_ASSETS[..],
        &SHAPE_AND_HRBF_ASSETS[..],
    ]
    .concat()
    .into_iter()
    .map(str::to_owned)
    .collect();
    listed.sort();
    assert_eq!(listed, on_disk);
}

/// The scenes of `assets`: two cameras on the small ones; the scene camera only on the large
/// ones and on those whose CPU sphere tracing runs hundreds of marches to the step budget.
/// `SKELETRACE_GPU_ASSETS=a,b` narrows the run while investigating one scene.
fn assets(assets: &[&str]) -> Vec<Case> {
    let only = std::env::var("SKELETRACE_GPU_ASSETS").ok();
    assets
        .iter()
        .filter(|asset| {
            only.as_ref()
                .is_none_or(|o| o.split(',').any(|a| a == **asset))
        })
        .map(|&asset| {
            let scene = load(asset);
            let counts = scene.counts();
            let large = counts.segments + counts.blobs + counts.shapes > 1000
                || ["creature", "truss", "foam"].contains(&asset);
            let cameras = if large {
                vec![scene.camera]
            } else {
                vec![scene.camera, orbit(&scene.camera, 40.0)]
            };
            Case {
                label: asset.to_owned(),
                scene,
                cameras,
                min_hits: 0,
            }
        })
        .collect()
}

/// One scene of the agreement suite: its label, the cameras it is traced through and the
/// fewest pixels the CPU tracer must hit in one of its frames (a scene that misses the view
/// would agree trivially).
struct Case {
    label: String,
    scene: Scene,
    cameras: Vec<Camera>,
    min_hits: usize,
}

impl Case {
    /// `scene` through its own camera, hitting at least `min_hits` pixels.
    fn of(label: impl Into<String>, scene: Scene, min_hits: usize) -> Self {
        Self {
            label: label.into(),
            cameras: vec![scene.camera],
            scene,
            min_hits,
        }
    }
}

/// Traces every case with those of `methods` that apply on `gpu` and on the CPU tracer, and
/// fails naming every case and method that disagree (module docs), or a case that hits too
/// few pixels.
fn run_cases(gpu: &mut GpuRenderer, test: &str, cases: Vec<Case>, methods: &[GpuMethod]) {
    eprintln!("{test}: adapter {}", gpu.adapter_name());
    let mut failures = Vec::new();
    for case in cases {
        let hits = check_methods_agreement(
            gpu,
            &case.label,
            &case.scene,
            &case.cameras,
            methods,
            &mut failures,
        );
        eprintln!("{}: {hits} pixels hit", case.label);
        if hits < case.min_hits {
            failures.push(format!(
                "{}: only {hits} pixels hit (at least {})",
                case.label, case.min_hits
            ));
        }
    }
    assert!(failures.is_empty(), "{test}: disagreements: {failures:?}");
}

/// The agreement suite: one test per line, each tracing a family of scenes ([`Case`]) with the
/// GPU methods named and holding every frame to the CPU tracer's. Instantiated once per GPU
/// backend wgpu opens here (Vulkan and OpenGL, below), as fidget instantiates its `*_tests!`
/// per evaluator. A new primitive, operator or scene family is covered by one line; a new
/// method by its shader, since the lines that say `GpuMethod::ALL` take every one.
macro_rules! agreement_suite {
    ($open:path; $($test:ident: $cases:expr, $methods:expr;)+) => {
        $(
            #[test]
            fn $test() {
                let name = concat!(module_path!(), "::", stringify!($test));
                let Some(mut gpu) = $open(name) else {
                    return;
                };
                run_cases(&mut gpu, name, $cases, $methods);
            }
        )+
    };
}

/// Every GPU method on Vulkan (lavapipe here and in CI): every asset, in three tests by the
/// kinds their pipelines are compiled for (shared.rs `KindSet::TIERS`), which the binary's
/// renderers run at once; then the operators, primitives and blend trees.
mod vulkan {
    use super::*;

    agreement_suite! { skeletrace_tests::gpu_or_skip;
        point_blob_assets_match: assets(&POINT_BLOB_ASSETS), &GpuMethod::ALL;
        skeleton_assets_match: assets(&SKELETON_ASSETS), &GpuMethod::ALL;
        shape_and_hrbf_assets_match: assets(&SHAPE_AND_HRBF_ASSETS), &GpuMethod::ALL;
        smooth_blends_match: smooth_blends(), &GpuMethod::ALL;
        distance_segments_match: distance_segments(), &GpuMethod::ALL;
        every_primitive_matches: every_primitive(), &GpuMethod::ALL;
        blend_trees_match: blend_trees(), &[
            shader_of(MethodId::Sphere),
            shader_of(MethodId::Segment),
            shader_of(MethodId::QuadraticTaylor),
            shader_of(MethodId::BottomUpLinear),
            shader_of(MethodId::QuadraticMixed),
        ];
        ricci_blends_past_f32_powers_match: ricci_past_f32_powers(), &[
            shader_of(MethodId::Sphere),
            shader_of(MethodId::Segment),
            shader_of(MethodId::QuadraticTaylor),
        ];
        scenes_of_many_groups_match: many_groups(), &[
            shader_of(MethodId::Segment),
            shader_of(MethodId::QuadraticTaylor),
            shader_of(MethodId::BottomUpQuadratic),
            shader_of(MethodId::QuadraticMixed),
        ];
    }
}

/// wgpu's OpenGL backend (llvmpipe through EGL), on the tree at its scene camera with
/// scalis-quadratic and quadratic Taylor (the window's refills and the inclusion march): only
/// these, since llvmpipe compiles a GL pipeline in about 50 s with a fresh shader cache, as in
/// CI (every GPU method on the tree and `blobs`, 31 pipelines, agreed in a run with a warm
/// cache). Its statistics rays: [`the_opengl_backend_traces_the_statistics_rays_as_the_cpu`].
mod opengl {
    use super::*;

    agreement_suite! { skeletrace_tests::opengl_or_skip;
        the_tree_matches: vec![Case::of("tree (OpenGL)", load("tree"), SIZE * SIZE / 20)], &[
            shader_of(MethodId::ScalisQuadratic),
            shader_of(MethodId::QuadraticTaylor),
        ];
    }
}

/// The smooth union and intersection (2014 notes §11.6) over the blobs' groups: values and
/// gradients (every method), ray jets (the Taylor methods, and bottom-up-quadratic, which falls
/// back to quadratic Taylor for them on both backends). Two groups that overlap: every blob of
/// the asset, and one large blob at its centre.
fn smooth_blends() -> Vec<Case> {
    let mut scene = load("blobs");
    let all: Vec<_> = scene.groups.iter().flat_map(|g| g.blobs.clone()).collect();
    scene.groups.truncate(2);
    scene.groups[0].blobs = all;
    scene.groups[1].blobs = vec![skeletrace_core::model::scene::Blob {
        center: [0.0; 3],
        radius: 0.9,
    }];
    let leaves = vec![Blend::Group(0), Blend::Group(1)];
    let union = Blend::SmoothUnion {
        width: 0.3,
        of: leaves.clone(),
    };
    let intersection = Blend::SmoothIntersection {
        width: 0.3,
        of: leaves,
    };
    [
        ("blobs-smooth-union", union),
        ("blobs-smooth-inter", intersection),
    ]
    .into_iter()
    .map(|(label, blend)| {
        let scene = Scene {
            blend: Some(blend),
            ..scene.clone()
        };
        Case::of(label, scene, SIZE * SIZE / 50)
    })
    .collect()
}

/// Distance segments (scalis eq. 7): the hand with every skeleton switched from SCALIS to the
/// kernel of the homothetic distance, whose ray jets (segment.rs) hull the end caps and the
/// cone side.
fn distance_segments() -> Vec<Case> {
    let mut scene = load("hand");
    for group in &mut scene.groups {
        for skeleton in &mut group.skeletons {
            skeleton.field = skeletrace_core::model::scene::SkeletonField::Distance;
        }
    }
    vec![Case::of("hand-distance", scene, SIZE * SIZE / 10)]
}

/// Boxes, rounded boxes, tori and cylinders (2014 notes §7; shapes.rs): values, gradients,
/// support intervals and ray jets, on the operators asset with its groups summed and on random
/// scenes of 2–4 groups of 1–3 primitives of every kind, summed (seeds 42–45, none of which
/// draws an HRBF set; those are checked on the hrbf asset and in the random blend trees). Before
/// infinite f″ bounds stayed infinite when scaled (interval.wgsl mul_ends), tori stalled
/// quadratic Taylor on seed 43 and others.
fn every_primitive() -> Vec<Case> {
    let mut operators = load("operators");
    operators.blend = None;
    let mut cases = vec![Case::of("operators-summed", operators, SIZE * SIZE / 10)];
    let mut shapes = 0;
    for seed in 42..46 {
        let mut rng = SplitMix64::new(seed);
        // Four summed groups in every scene: one blend tree, so the scenes share their
        // pipelines (with the secondary-ray test's random scenes too).
        let groups = common::random_groups(&mut rng, 4);
        shapes += groups.iter().map(|g| g.shapes.len()).sum::<usize>();
        cases.push(Case::of(
            format!("random-{seed}"),
            common::scene(groups, None),
            0,
        ));
    }
    assert!(shapes >= 6, "only {shapes} shapes in the random scenes");
    cases
}

/// Blend trees (blend.rs; compiled to WGSL per scene, blend_wgsl.rs): random trees of depth up to
/// 4 over 2–5 random groups of every primitive kind, every operator — difference, Ricci, smooth
/// union and intersection, nested — with 1–3 operands each: the first four scenes drawn from
/// seed 61 whose tree has at least two operators. One method per blend function, since each
/// tree builds its own pipelines: sphere tracing (values and gradients), segment tracing
/// (Lipschitz bounds), quadratic Taylor (jets), bottom-up-linear and quadratic-mixed (the
/// forward-inclusion composition, and the whole-field fallback where it has no rule).
fn blend_trees() -> Vec<Case> {
    let mut operators = std::collections::BTreeSet::new();
    let mut rng = SplitMix64::new(61);
    let mut cases = Vec::new();
    while cases.len() < 4 {
        let scene = common::random_nested_scene(&mut rng);
        let blend = scene.blend.clone().unwrap_or(Blend::Group(0));
        if count_operators(&blend) < 2 {
            continue;
        }
        collect_operators(&blend, &mut operators);
        let label = format!("nested-{}", cases.len() + 1);
        eprintln!("{label}: {blend:?}");
        cases.push(Case::of(label, scene, 0));
    }
    eprintln!("operators: {operators:?}");
    assert!(
        operators.len() >= 5,
        "only {operators:?} in the random trees"
    );
    cases
}

/// The operators asset's Ricci blend at exponents whose p-th powers leave f32's range: p = 32 at
/// isovalue 0.05 (the fields scale with the isovalue, so the operands near the surface are about
/// 0.05 and 0.05³² underflows: the blend was 0 there and the surface gone) and p = 200 (the
/// Lipschitz bounds' 200th powers overflow: segment tracing stepped by 0). The shaders take the
/// p-norms relative to their largest term as the CPU does (`blend.rs` `p_norm`), in the values,
/// the jets and the Lipschitz bound: sphere, segment and quadratic Taylor tracing.
fn ricci_past_f32_powers() -> Vec<Case> {
    [(32.0, 0.05), (200.0, 1.0)]
        .into_iter()
        .map(|(p, isovalue)| {
            let mut scene = load("operators");
            let Some(Blend::Ricci { of, .. }) = scene.blend.take() else {
                panic!("the operators asset is a Ricci blend");
            };
            scene.blend = Some(Blend::Ricci { p, of });
            scene.isovalue = isovalue;
            Case::of(
                format!("operators, Ricci p = {p}, isovalue {isovalue}"),
                scene,
                100,
            )
        })
        .collect()
}

/// Scenes of more groups than the eight slots the shaders held before: each scene's shaders
/// hold one per group (`GROUPS`, emitted with the blend tree), so the max of twelve and of
/// forty sums of blobs agrees with the CPU, in the methods that blend values, jets and the
/// groups' inclusions.
fn many_groups() -> Vec<Case> {
    [(12, 71), (40, 72)]
        .into_iter()
        .map(|(groups, seed)| {
            let options = skeletrace_core::model::generate::GenerateOptions {
                seed,
                size: Some(10 * groups),
                groups: Some(groups),
                ..Default::default()
            };
            let scene = skeletrace_core::model::generate::generate(
                skeletrace_core::model::generate::GeneratorKind::Blobs,
                &options,
            )
            .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(scene.groups.len(), groups);
            Case::of(format!("blobs in {groups} groups"), scene, SIZE * SIZE / 10)
        })
        .collect()
}

/// The editor's GPU viewport compiles a new scene's pipelines on threads of their own
/// (`GpuRenderer::pipelines_compiling`) so that its window does not wait for the driver: the
/// frame traced with them is the frame traced with pipelines compiled in place, and a new blend
/// tree starts new ones instead of using the old tree's — also when it replaces a tree whose
/// pipelines are still compiling (they finish first, then the new tree's start).
#[test]
fn pipelines_compiled_in_the_background_trace_the_same_frames() {
    let Some(mut gpu) = gpu_or_skip("pipelines_compiled_in_the_background_trace_the_same_frames")
    else {
        return;
    };
    let methods = [
        shader_of(MethodId::Segment),
        shader_of(MethodId::QuadraticTaylor),
    ];
    let ricci = load("operators");
    let summed = Scene {
        blend: Some(Blend::Sum((0..3).map(Blend::Group).collect())),
        ..ricci.clone()
    };
    let frames_of = |gpu: &mut GpuRenderer, scene: &Scene, background: bool| {
        let compiled = compile(scene);
        gpu.set_scene(&compiled).unwrap_or_else(|e| panic!("{e}"));
        if background {
            assert!(
                gpu.pipelines_compiling(&methods),
                "a new tree's pipelines are compiled in the background"
            );
            let deadline = std::time::Instant::now() + std::time::Duration::from_secs(600);
            while gpu.pipelines_compiling(&methods) {
                assert!(std::time::Instant::now() < deadline, "still compiling");
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
        }
        shaded_frames(
            gpu,
            &methods,
            &scene.camera,
            &compiled.settings,
            "background",
        )
    };
    // The Ricci tree's pipelines start, and the sum replaces it before they are done.
    gpu.set_scene(&compile(&ricci))
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(gpu.pipelines_compiling(&methods));
    for scene in [&summed, &ricci] {
        let background = frames_of(&mut gpu, scene, true);
        let mut fresh = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
        let in_place = frames_of(&mut fresh, scene, false);
        for (b, p) in background.iter().zip(&in_place) {
            assert_eq!(b.steps, p.steps, "{:?}", scene.blend);
            assert_eq!(b.colour, p.colour, "{:?}", scene.blend);
        }
    }
}

/// A parameter is data on the GPU (blend_wgsl.rs): a smooth blend's width, a Ricci exponent, a
/// kernel's scale, radii, the isovalue and materials change uploaded buffers, never the shader
/// code, so editing them compiles no pipeline, and the frames that follow still agree with the
/// CPU tracer's. The first frame compiles one pipeline per method (the counter counts), a
/// scene of another blend structure needs new ones.
#[test]
fn parameter_edits_compile_no_pipelines_and_match_the_cpu() {
    let Some(mut gpu) = gpu_or_skip("parameter_edits_compile_no_pipelines_and_match_the_cpu")
    else {
        return;
    };
    let methods = [
        shader_of(MethodId::Segment),
        shader_of(MethodId::QuadraticTaylor),
    ];
    fn tree(outer: f64, p: f64, inner: f64) -> Blend {
        let g = Blend::Group;
        Blend::SmoothUnion {
            width: outer,
            of: vec![
                Blend::Ricci {
                    p,
                    of: vec![Blend::Difference(Box::new(g(0)), Box::new(g(1))), g(2)],
                },
                Blend::SmoothIntersection {
                    width: inner,
                    of: vec![g(0), g(2)],
                },
            ],
        }
    }
    let base = Scene {
        blend: Some(tree(0.2, 4.0, 0.1)),
        ..load("operators")
    };
    let mut failures = Vec::new();
    let before = gpu.pipelines_compiled();
    let camera = [base.camera];
    check_methods_agreement(&mut gpu, "base", &base, &camera, &methods, &mut failures);
    assert_eq!(
        gpu.pipelines_compiled(),
        before + methods.len() as u64,
        "the first frame compiles one pipeline per method"
    );
    let first = gpu.pipelines_compiled();
    type Edit = fn(&mut Scene);
    let edits: [(&str, Edit); 8] = [
        ("smooth union width", |s| {
            s.blend = Some(tree(0.45, 4.0, 0.1))
        }),
        ("ricci exponent", |s| s.blend = Some(tree(0.2, 7.0, 0.1))),
        ("smooth intersection width", |s| {
            s.blend = Some(tree(0.2, 4.0, 0.3));
        }),
        ("kernel scale", |s| {
            for group in &mut s.groups {
                group.kernel = group.kernel.scaled(1.1);
            }
        }),
        ("radius", |s| {
            for blob in s.groups.iter_mut().flat_map(|g| &mut g.blobs) {
                blob.radius *= 1.15;
            }
            for v in s
                .groups
                .iter_mut()
                .flat_map(|g| &mut g.skeletons)
                .flat_map(|k| &mut k.vertices)
            {
                v.radius *= 1.15;
            }
        }),
        ("isovalue", |s| s.isovalue *= 0.85),
        ("colour and opacity", |s| {
            s.groups[1].material.color = [0.9, 0.2, 0.1];
        }),
        ("every parameter at once", |s| {
            s.blend = Some(tree(0.3, 2.5, 0.2));
            s.isovalue *= 1.1;
            s.groups[0].kernel = s.groups[0].kernel.scaled(1.1);
        }),
    ];
    for (name, edit) in edits {
        let mut scene = base.clone();
        edit(&mut scene);
        assert_ne!(scene, base, "{name} changes the scene");
        check_methods_agreement(&mut gpu, name, &scene, &camera, &methods, &mut failures);
        assert_eq!(
            gpu.pipelines_compiled(),
            first,
            "editing the {name} compiled pipelines"
        );
    }
    assert!(failures.is_empty(), "{failures:?}");
}

/// Compiled pipelines are kept across runs in a pipeline cache file per adapter and driver
/// (`render/src/pipeline_cache.rs`): a renderer on a fresh directory starts cold and writes the
/// file once its pipelines compile, the next starts from it (warm) and traces the same frames,
/// and a corrupt file is ignored with a warning (the frames are the same again) and written
/// anew. On Vulkan, lavapipe included, the device has a cache; what its data holds is the
/// driver's (lavapipe keeps only Vulkan's header, a hardware driver its compiled code).
#[test]
fn pipelines_are_kept_across_runs_and_a_corrupt_cache_is_ignored() {
    if skeletrace_tests::skip_without_gpu("pipelines_are_kept_across_runs") {
        return;
    }
    let dir =
        std::env::temp_dir().join(format!("skeletrace-pipeline-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let scene = load("blobs");
    let compiled = compile(&scene);
    let run = |label: &str| {
        let mut gpu = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
        gpu.set_pipeline_cache_dir(Some(&dir));
        gpu.set_scene(&compiled).unwrap_or_else(|e| panic!("{e}"));
        let frames = shaded_frames(
            &mut gpu,
            &[shader_of(MethodId::Segment)],
            &scene.camera,
            &compiled.settings,
            label,
        );
        (
            gpu,
            frames
                .into_iter()
                .next()
                .unwrap_or_else(|| panic!("a frame")),
        )
    };
    let (cold, first) = run("cold");
    if cold.graphics_api() != eframe::wgpu::Backend::Vulkan {
        eprintln!("no pipeline cache on {:?}", cold.graphics_api());
        return;
    }
    let cache = cold
        .pipeline_cache()
        .unwrap_or_else(|| panic!("a Vulkan device has a pipeline cache"));
    assert_eq!(cache.loaded_bytes(), 0, "a fresh directory starts cold");
    let file = cache.path().to_path_buf();
    let written = std::fs::read(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    let data = skeletrace_render::pipeline_cache::unwrap(&written)
        .unwrap_or_else(|e| panic!("{e}"))
        .len();
    assert!(data > 0, "the driver's data is kept");

    let (warm, second) = run("warm");
    let cache = warm.pipeline_cache().unwrap_or_else(|| panic!("a cache"));
    assert_eq!(
        cache.loaded_bytes(),
        data as u64,
        "the next run starts warm"
    );
    assert!(cache.warning().is_none());
    assert_eq!(second.steps, first.steps);
    assert_eq!(second.colour, first.colour);

    let mut corrupt = written;
    let last = corrupt.len() - 1;
    corrupt[last] ^= 0xff;
    std::fs::write(&file, &corrupt).unwrap_or_else(|e| panic!("{e}"));
    let (ignored, third) = run("corrupt");
    let cache = ignored
        .pipeline_cache()
        .unwrap_or_else(|| panic!("a cache"));
    assert_eq!(cache.loaded_bytes(), 0, "a corrupt file is not used");
    assert!(
        cache.warning().is_some_and(|w| w.contains("ignored")),
        "{:?}",
        cache.warning()
    );
    assert_eq!(third.steps, first.steps);
    assert_eq!(third.colour, first.colour);
    let rewritten = std::fs::read(&file).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        skeletrace_render::pipeline_cache::unwrap(&rewritten).is_ok(),
        "written anew"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The operator nodes in `blend`.
fn count_operators(blend: &Blend) -> usize {
    match blend {
        Blend::Group(_) => 0,
        Blend::Difference(a, b) => 1 + count_operators(a) + count_operators(b),
        Blend::Sum(v) | Blend::Max(v) | Blend::Min(v) => {
            1 + v.iter().map(count_operators).sum::<usize>()
        }
        Blend::Ricci { of, .. }
        | Blend::SmoothUnion { of, .. }
        | Blend::SmoothIntersection { of, .. } => 1 + of.iter().map(count_operators).sum::<usize>(),
    }
}

/// The names of the operators in `blend`.
fn collect_operators(blend: &Blend, out: &mut std::collections::BTreeSet<&'static str>) {
    let children: Vec<&Blend> = match blend {
        Blend::Group(_) => return,
        Blend::Sum(v) => {
            out.insert("sum");
            v.iter().collect()
        }
        Blend::Max(v) => {
            out.insert("max");
            v.iter().collect()
        }
        Blend::Min(v) => {
            out.insert("min");
            v.iter().collect()
        }
        Blend::Difference(a, b) => {
            out.insert("difference");
            vec![a.as_ref(), b.as_ref()]
        }
        Blend::Ricci { of, .. } => {
            out.insert("ricci");
            of.iter().collect()
        }
        Blend::SmoothUnion { of, .. } => {
            out.insert("smooth union");
            of.iter().collect()
        }
        Blend::SmoothIntersection { of, .. } => {
            out.insert("smooth intersection");
            of.iter().collect()
        }
    };
    for c in children {
        collect_operators(c, out);
    }
}

#[test]
fn editing_one_primitive_re_uploads_only_that_primitive() {
    let Some(mut gpu) = gpu_or_skip("editing_one_primitive_re_uploads_only_that_primitive") else {
        return;
    };
    let mut scene = load("blobs");
    gpu.set_scene(&compile(&scene))
        .unwrap_or_else(|e| panic!("{e}"));
    let full = gpu.uploaded_primitive_bytes();
    scene.groups[0].blobs[3].radius *= 1.1;
    gpu.set_scene(&compile(&scene))
        .unwrap_or_else(|e| panic!("{e}"));
    let edit = gpu.uploaded_primitive_bytes() - full;
    let one = std::mem::size_of::<skeletrace_render::buffers::GpuPrimitive>() as u64;
    assert_eq!(
        edit, one,
        "one primitive ({one} bytes), got {edit} bytes (full upload {full})"
    );
}

/// The largest difference of two linear colours' channels. The GPU stores 8-bit sRGB, so both
/// are compared clamped to [0, 1].
fn colour_difference(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3)
        .map(|c| (a[c].min(1.0) - b[c].min(1.0)).abs())
        .fold(0.0, f32::max)
}

/// Soft shadows and ambient occlusion from the field (2014 notes §12.4) shade the same on both
/// backends: on a scene whose groups are moved by a transform and repeated (the operators are
/// baked into the primitives, so the GPU sees them too), and ambient occlusion on the 3 000-atom
/// `molecule`, whose samples the GPU finds in the scene's hierarchy (main.wgsl
/// `field_anywhere`). Its soft shadows stay over lavapipe's loop limit by the walk's bound
/// (`RayBvh::point_walk_bound`), and the renderer refuses them on a software adapter.
#[test]
fn field_shading_and_group_operators_agree_with_the_cpu() {
    let Some(mut gpu) = gpu_or_skip("field_shading_and_group_operators_agree_with_the_cpu") else {
        return;
    };
    let mut moved = load("blobs");
    moved.groups[0].transform = skeletrace_core::model::scene::Transform {
        translate: [0.3, -0.2, 0.1],
        rotate: [10.0, 35.0, -20.0],
        scale: 0.9,
    };
    moved.groups[3].repeat = Some(skeletrace_core::model::scene::Repeat {
        count: [2, 1, 1],
        spacing: [0.6, 0.0, 0.0],
    });
    let every_term = skeletrace_core::frame::FieldShading {
        soft_shadows: true,
        ambient_occlusion: true,
    };
    let occlusion = skeletrace_core::frame::FieldShading {
        soft_shadows: false,
        ambient_occlusion: true,
    };
    for (name, scene, shading) in [
        ("moved blobs", moved, every_term),
        ("molecule", load("molecule"), occlusion),
    ] {
        let compiled = compile(&scene);
        let program = &compiled.program;
        let settings = compiled.settings;
        gpu.set_scene(&compiled).unwrap_or_else(|e| panic!("{e}"));
        let method = shader_of(MethodId::QuadraticTaylor);
        let tracer = method.id().method().prepare(program, settings);
        let cpu = |shading| {
            Renderer::new(&compiled, tracer.as_ref(), settings).render(
                &scene.camera,
                RenderOptions {
                    width: SIZE,
                    height: SIZE,
                    shadows: false,
                    shading,
                },
            )
        };
        let (shaded, plain) = (cpu(shading), cpu(Default::default()));
        let gpu_frame = gpu
            .render(&request(
                &[method],
                &scene.camera,
                &settings,
                View::Shaded(shading),
                false,
            ))
            .unwrap_or_else(|e| panic!("{name}: {e}"))
            .remove(0);
        let both: Vec<usize> = (0..SIZE * SIZE)
            .filter(|&i| shaded.is_hit(i) && gpu_frame.is_hit(i))
            .collect();
        assert!(
            both.len() > SIZE * SIZE / 10,
            "{name}: too few hit pixels: {}",
            both.len()
        );
        let close = both
            .iter()
            .filter(|&&i| colour_difference(shaded.colour[i], gpu_frame.colour[i]) <= 0.02)
            .count();
        let darkened = both
            .iter()
            .filter(|&&i| (0..3).any(|c| plain.colour[i][c] - shaded.colour[i][c] > 0.02))
            .count();
        eprintln!(
            "field shading, {name}: {close}/{} hit pixels within 0.02 of the CPU colour; \
             {darkened} darkened by soft shadows or occlusion",
            both.len()
        );
        assert!(
            close * 100 >= both.len() * 99,
            "{name}: GPU and CPU shading differ"
        );
        assert!(
            darkened * 20 >= both.len(),
            "{name}: the shading terms hardly change the image"
        );
    }
    if gpu.device_kind() == skeletrace_core::backend::DeviceKind::SoftwareGpu {
        let molecule = compile(&load("molecule"));
        let refused = gpu.check_shading_budget(&molecule, every_term);
        assert!(
            refused.is_err(),
            "the molecule's soft shadows pass lavapipe's loop budget: {refused:?}"
        );
    }
}

/// A marching method's rays are suspended when a dispatch's allowance of steps runs out and
/// resumed by the next dispatch (parts.wgsl). Resuming must be exact: frames traced three steps
/// per dispatch equal, bit for bit, those traced with the adapter's default allowance, on
/// scenes whose sphere-traced rays run up to the step budget, far past the allowance, and on
/// summed-blobs, the asset sherstyuk applies to.
#[test]
fn resumed_marches_give_the_same_frames() {
    let Some(mut gpu) = gpu_or_skip("resumed_marches_give_the_same_frames") else {
        return;
    };
    let default_allowance = gpu.steps_per_dispatch();
    for asset in ["blobs", "tree", "summed-blobs"] {
        let scene = load(asset);
        let compiled = compile(&scene);
        let program = &compiled.program;
        let settings = compiled.settings;
        gpu.set_scene(&compiled)
            .unwrap_or_else(|e| panic!("{asset}: {e}"));
        let marching: Vec<GpuMethod> = GpuMethod::ALL
            .into_iter()
            .filter(|m| m.resumable() && m.supports(program).is_ok())
            .collect();
        let mut frames = |steps_per_dispatch| {
            gpu.set_steps_per_dispatch(steps_per_dispatch);
            shaded_frames(&mut gpu, &marching, &scene.camera, &settings, asset)
        };
        let default = frames(default_allowance);
        let sliced = frames(3);
        gpu.set_steps_per_dispatch(default_allowance);
        for ((method, a), b) in marching.iter().zip(&default).zip(&sliced) {
            let longest = a.steps.iter().max().copied().unwrap_or(0);
            eprintln!(
                "{asset} {}: longest march {longest} steps, default allowance {default_allowance}",
                method.name()
            );
            assert_eq!(a.steps, b.steps, "{asset} {}: steps", method.name());
            assert!(
                a.depth
                    .iter()
                    .zip(&b.depth)
                    .all(|(x, y)| x.to_bits() == y.to_bits()),
                "{asset} {}: depth",
                method.name()
            );
            assert_eq!(a.colour, b.colour, "{asset} {}: colour", method.name());
        }
        let longest_sphere = default[0].steps.iter().max().copied().unwrap_or(0);
        assert!(
            longest_sphere > 2 * default_allowance,
            "{asset}: sphere tracing should outrun two dispatches ({longest_sphere} steps)"
        );
    }
}

/// Occluders (scalis 2021 §7; binning.wgsl): primitives wholly behind a ball inside the
/// surface are left out of a tile's list. On the 3 000-atom molecule, many layers deep, seen
/// through a narrow field of view so that atoms cover whole 4-pixel tiles, the tile lists get
/// shorter, and the frames keep their hits and depths.
#[test]
fn occluders_shorten_the_tile_lists_and_keep_the_surface() {
    let Some(mut gpu) = gpu_or_skip("occluders_shorten_the_tile_lists_and_keep_the_surface") else {
        return;
    };
    let scene = load("molecule");
    let compiled = compile(&scene);
    let program = &compiled.program;
    let settings = compiled.settings;
    let diagonal = program.support_bounds().diagonal();
    gpu.set_scene(&compiled).unwrap_or_else(|e| panic!("{e}"));
    let camera = Camera {
        fov_degrees: scene.camera.fov_degrees / 5.0,
        ..scene.camera
    };
    let methods = [
        shader_of(MethodId::Segment),
        shader_of(MethodId::QuadraticTaylor),
    ];
    let mut frames = |occluders| {
        gpu.set_occluders(occluders);
        (
            shaded_frames(&mut gpu, &methods, &camera, &settings, "molecule"),
            gpu.last_tile_items(),
            gpu.last_pass_times().cloned(),
        )
    };
    let (open, open_items, open_times) = frames(false);
    let (occluded, occluded_items, occluded_times) = frames(true);
    eprintln!(
        "molecule: {open_items} (primitive, tile) pairs without occluders, {occluded_items} with; \
         pass times without {open_times:?}, with {occluded_times:?}"
    );
    assert!(
        occluded_items * 2 < open_items,
        "occluders should leave out at least half of the molecule's pairs: {occluded_items} of {open_items}"
    );
    for ((method, a), b) in methods.iter().zip(&open).zip(&occluded) {
        assert_same_surface(method.name(), a, b, settings.max_steps, diagonal);
    }
}

/// Beam culling (binning.wgsl `beam_misses_hull`, the twin of the CPU tile lists' `Beam`): a
/// tile's lists leave out the point blobs and SCALIS segments whose support lies beyond a side
/// of its pixel rays' beam, not only those whose bounding sphere's rectangle misses the tile.
/// A long, thin strut's rectangle holds many tiles its support never reaches, and a ball's
/// rectangle is the square around the bounding sphere of its box, so the lists get much
/// shorter. Every support left out is one the tile's rays miss, so each ray's window holds
/// the same supports: the same step counts and hits, and depths within the rounding of
/// supports entering at the same depth (a vertex ball two struts share), whose order in the
/// window is the tile list's, set by the fill's atomics.
#[test]
fn beam_culling_shortens_the_tile_lists_and_keeps_the_frames() {
    use skeletrace_core::model::generate::GeneratorKind;
    let Some(mut gpu) = gpu_or_skip("beam_culling_shortens_the_tile_lists_and_keeps_the_frames")
    else {
        return;
    };
    let foam = generated(GeneratorKind::Foam, 3, 1000);
    let blobs = generated(GeneratorKind::Blobs, 5, 400);
    for (label, scene, methods) in [
        (
            "foam-1000",
            &foam,
            &[
                shader_of(MethodId::QuadraticTaylor),
                shader_of(MethodId::ScalisQuadratic),
            ][..],
        ),
        (
            "tree",
            &load("tree"),
            &[shader_of(MethodId::ScalisQuadratic)][..],
        ),
        (
            "blobs-400",
            &blobs,
            &[
                shader_of(MethodId::Segment),
                shader_of(MethodId::QuadraticTaylor),
            ][..],
        ),
    ] {
        let compiled = compile(scene);
        gpu.set_scene(&compiled)
            .unwrap_or_else(|e| panic!("{label}: {e}"));
        let cameras = [
            skeletrace_core::compile::framing_camera(&compiled),
            orbit(&scene.camera, 35.0),
        ];
        for camera in &cameras {
            let mut frames = |on| {
                gpu.set_hull_culling(on);
                let frames = shaded_frames(&mut gpu, methods, camera, &compiled.settings, label);
                (frames, gpu.last_tile_items())
            };
            let (culled, culled_items) = frames(true);
            let (open, open_items) = frames(false);
            gpu.set_hull_culling(true);
            eprintln!(
                "{label}: {open_items} (primitive, tile) pairs by bounding spheres, \
                 {culled_items} with beam culling"
            );
            // Measured: about a quarter kept on each scene.
            assert!(
                culled_items * 2 < open_items,
                "{label}: beam culling kept {culled_items} of {open_items} pairs"
            );
            for ((method, a), b) in methods.iter().zip(&culled).zip(&open) {
                let name = method.name();
                assert_eq!(a.steps, b.steps, "{label} {name}: step counts differ");
                // The same supports in each window; where two enter at the same depth (a
                // vertex ball two struts share), their order is the tile list's, which the fill's
                // atomics set, and the field adds them in that order: a few f32 roundings.
                let (mut moved, mut worst) = (0, 0.0_f64);
                for (x, y) in a.depth.iter().zip(&b.depth) {
                    assert_eq!(
                        x.is_finite(),
                        y.is_finite(),
                        "{label} {name}: hit masks differ"
                    );
                    if x != y {
                        moved += 1;
                        worst = worst.max((x - y).abs() / x.abs());
                    }
                }
                let colour = a.colour.iter().zip(&b.colour).fold(0.0_f32, |m, (x, y)| {
                    (0..3).fold(m, |m, c| m.max((x[c] - y[c]).abs()))
                });
                eprintln!(
                    "{label} {name}: {moved} depths moved, by at most {worst:.1e} relative; \
                     colours by at most {colour:.1e}"
                );
                assert!(
                    worst <= 1e-6,
                    "{label} {name}: a depth moved by {worst:.1e}"
                );
                assert!(
                    colour <= 1e-4,
                    "{label} {name}: a colour moved by {colour:.1e}"
                );
            }
        }
    }
}

/// Asserts that two GPU frames of one scene have the same hit mask and depths within 10⁻⁵ of
/// the `diagonal`, where only the binning differed (their step counts may differ where an
/// interval reaches past a tile's occluding depth).
fn assert_same_surface(label: &str, a: &Frame, b: &Frame, budget: u32, diagonal: f64) {
    let same = compare(a, b, budget);
    eprintln!(
        "{label}: hit mask {:.4}, depth {:.1e}, equal steps {:.4} {:?}",
        same.hit_mask,
        same.worst_depth / diagonal,
        same.equal_steps,
        same.histogram
    );
    assert_eq!(same.hit_mask, 1.0, "{label}: hit masks differ");
    assert!(
        same.worst_depth <= 1e-5 * diagonal,
        "{label}: depths differ by {:.1e} of the diagonal",
        same.worst_depth / diagonal
    );
}

/// A frame whose tile lists do not fit in one storage binding (the 500 000-segment
/// foam at 2048² on a hardware GPU: 2.4 GB against wgpu's 2 GB) is binned again with wider
/// tiles instead of failing. Here the lists of the molecule are held to two fifths of what its
/// 4-pixel tiles need; the frame is binned with wider tiles and keeps its hits and depths.
#[test]
fn lists_too_large_for_one_binding_widen_the_tiles() {
    let Some(mut gpu) = gpu_or_skip("lists_too_large_for_one_binding_widen_the_tiles") else {
        return;
    };
    let scene = load("molecule");
    let compiled = compile(&scene);
    let settings = compiled.settings;
    let diagonal = compiled.program.support_bounds().diagonal();
    gpu.set_scene(&compiled).unwrap_or_else(|e| panic!("{e}"));
    let methods = [shader_of(MethodId::Segment)];
    let frame = |gpu: &mut GpuRenderer| {
        let frames = shaded_frames(gpu, &methods, &scene.camera, &settings, "molecule");
        (frames, gpu.last_tile_items(), gpu.tile_edge())
    };
    let (fine, fine_items, fine_tile) = frame(&mut gpu);
    gpu.limit_tile_lists(fine_items * 4 * 2 / 5);
    let (wide, wide_items, wide_tile) = frame(&mut gpu);
    gpu.limit_tile_lists(u64::MAX);
    eprintln!(
        "molecule: {fine_items} (primitive, tile) pairs with {fine_tile}-pixel tiles, \
         {wide_items} with {wide_tile}-pixel tiles"
    );
    assert_eq!(fine_tile, 4);
    assert!(wide_tile > 4, "the tiles should have widened");
    assert!(
        wide_items * 4 <= fine_items * 4 * 2 / 5,
        "the lists exceed the limit"
    );
    assert_same_surface("segment", &fine[0], &wide[0], settings.max_steps, diagonal);
}

/// `stats --backend gpu` against the CPU's statistics on the same rays: the tree and
/// a generated blob scene, the six-axis protocol and the random rays around the box of
/// `paper-2023`; and transparent statistics (every crossing, forward-inclusion 2023 Table 4's
/// protocol) on its summed blobs and on the generated blobs, with the table's methods (and
/// sherstyuk on the summed blobs), and those of the two methods traced in one dispatch:
/// scalis-quadratic on the tree, field inversion on a generated molecule of Gaussian atoms.
/// Every ray is compared with the CPU reference, every crossing in transparent mode; hits agree
/// to 0.5 % of the rays, average steps (to the last crossing, in transparent mode) to 1 %, and
/// no conservative method misses a reference crossing or finds a spurious one (sherstyuk,
/// scalis-quadratic and field inversion miss some on the CPU too: the GPU may not miss or add
/// more than 0.5 % of the rays beyond the CPU's).
#[test]
fn gpu_statistics_agree_with_the_cpus() {
    use skeletrace_core::methods::{MethodId, Protocol, TraceMode};
    use skeletrace_core::model::generate::GeneratorKind;
    let Some(mut gpu) = gpu_or_skip("gpu_statistics_agree_with_the_cpus") else {
        return;
    };
    let blobs = generated(GeneratorKind::Blobs, 23, 60);
    // Gaussian atoms, as field inversion needs.
    let molecule = generated(GeneratorKind::Molecule, 29, 150);
    let opaque = [MethodId::Segment, MethodId::QuadraticTaylor];
    // Table 4's baseline and the two bottom-up and Taylor rows.
    let transparent = [
        MethodId::SegmentOriginal,
        MethodId::BottomUpQuadratic,
        MethodId::QuadraticTaylor,
    ];
    let mut failures = Vec::new();
    for (name, scene, protocol, mode, methods) in [
        (
            "tree",
            load("tree"),
            Protocol::Default,
            TraceMode::Opaque,
            &opaque[..],
        ),
        (
            "generated blobs",
            blobs.clone(),
            Protocol::Default,
            TraceMode::Opaque,
            &opaque,
        ),
        (
            "generated blobs",
            blobs.clone(),
            Protocol::Paper2023,
            TraceMode::Opaque,
            &opaque,
        ),
        (
            "summed-blobs",
            load("summed-blobs"),
            Protocol::Paper2023,
            TraceMode::Transparent,
            &transparent,
        ),
        (
            "generated blobs",
            blobs,
            Protocol::Paper2023,
            TraceMode::Transparent,
            &transparent,
        ),
        // Every root of an interval's cubic (summed blobs: its polynomials add).
        (
            "summed-blobs",
            load("summed-blobs"),
            Protocol::Paper2023,
            TraceMode::Transparent,
            &[MethodId::Sherstyuk],
        ),
        // The two methods that trace one dispatch per ray, past every crossing too.
        (
            "tree",
            load("tree"),
            Protocol::Default,
            TraceMode::Transparent,
            &[MethodId::ScalisQuadratic],
        ),
        (
            "generated molecule",
            molecule,
            Protocol::Default,
            TraceMode::Transparent,
            &[MethodId::FieldInversion],
        ),
    ] {
        failures.extend(statistics_disagreements(
            &mut gpu,
            name,
            &scene,
            (protocol, mode),
            (methods, STEPS_TOLERANCE),
        ));
    }
    assert!(failures.is_empty(), "disagreements: {failures:?}");
}

/// One f32 ulp of the field must not change the transparent marches' steps (docs/gpu.md,
/// "Transparent marches past a crossing"): a step that lands on the surface is on either side
/// of it by rounding, and an H200 rounding differently from lavapipe took 2 % more quadratic
/// Taylor steps until both sides resumed the march the same way. Moving the isovalue a few
/// f32 ulps up and down moves which side such steps fall on, as that GPU's arithmetic did;
/// the summed blobs of the 2023 paper's Table 4 are then traced on the GPU and on the CPU (at
/// the same isovalue). Quadratic Taylor's steps must stay within 0.2 % of the CPU's, and the
/// rest within the thresholds of [`gpu_statistics_agree_with_the_cpus`]. On lavapipe they are
/// equal at every nudge; with the old resumption (before e3cf9b5) one ulp down took 0.7 %
/// fewer steps and four ulps up 0.3 % more, and this test failed.
#[test]
fn a_few_ulps_of_the_isovalue_keep_the_transparent_steps() {
    use skeletrace_core::methods::{MethodId, Protocol, TraceMode};
    let Some(mut gpu) = gpu_or_skip("a_few_ulps_of_the_isovalue_keep_the_transparent_steps") else {
        return;
    };
    let scene = load("summed-blobs");
    let c = scene.isovalue as f32;
    let mut failures = Vec::new();
    for ulps in [-4_i32, -1, 1, 4] {
        let isovalue =
            (0..ulps.abs()).fold(c, |v, _| if ulps > 0 { v.next_up() } else { v.next_down() });
        let mut nudged = scene.clone();
        nudged.isovalue = f64::from(isovalue);
        failures.extend(statistics_disagreements(
            &mut gpu,
            &format!("summed-blobs, isovalue {ulps:+} ulp"),
            &nudged,
            (Protocol::Paper2023, TraceMode::Transparent),
            (&[MethodId::QuadraticTaylor], 0.002),
        ));
    }
    assert!(failures.is_empty(), "disagreements: {failures:?}");
}

/// A dense foam, whose rays cross far more supports than a window holds (64), seen framed as
/// `skeletrace generate` frames it and face-on from the generator's camera (deeper rays).
/// Lavapipe cuts an invocation's loops once they reach 65 535 iterations in all: before the
/// tile lists were cut into depth bands, every refill walked a tile list thousands long and
/// the framed quadratic Taylor frame differed from the CPU's on about a third of the pixels;
/// until each dispatch filled a suspended march's window once instead of twice, the face-on
/// one missed 61 of 479 hits (docs/gpu.md). The frames are held to the CPU's as in
/// [`check_methods_agreement`].
#[test]
fn a_dense_foam_matches_the_cpu() {
    use skeletrace_core::model::generate::GeneratorKind;
    let Some(mut gpu) = gpu_or_skip("a_dense_foam_matches_the_cpu") else {
        return;
    };
    // 8 200 Voronoi cells: 99 647 SCALIS segments, seen as `skeletrace generate` frames them.
    // The generator thins the struts of foams past 1 000 cells; they keep the radius of 1 000
    // cells here, so that the supports crowd the cells and the rays cross many.
    let mut foam = generated(GeneratorKind::Foam, 1, 8200);
    for vertex in &mut foam.groups[0].skeletons[0].vertices {
        vertex.radius = skeletrace_core::model::generate::FOAM_STRUT_RADIUS;
    }
    let framed = skeletrace_core::compile::framing_camera(&compile(&foam));
    let mut failures = Vec::new();
    let hits = check_methods_agreement(
        &mut gpu,
        "foam-8200",
        &foam,
        &[framed, foam.camera],
        &[
            shader_of(MethodId::QuadraticTaylor),
            shader_of(MethodId::ScalisQuadratic),
        ],
        &mut failures,
    );
    assert!(hits > SIZE * SIZE / 2, "foam-8200: {hits} pixels hit");
    assert!(failures.is_empty(), "disagreements: {failures:?}");
}

/// Lavapipe stops an invocation's loops once they have run 65 535 iterations in all, which cuts
/// rays short and loses hits without a word; the renderer finds out (main.wgsl
/// `note_loop_limit`) and fails the frame, naming the cause. Sphere tracing the tree takes up
/// to 2 048 steps per ray, each looping over the ray's supports: with the whole budget in one
/// dispatch it passes the limit on lavapipe (552 of the 1 600 invocations), with the software
/// adapter's allowance of 8 steps it stays below it. A hardware GPU has no such limit and
/// traces both frames.
#[test]
fn a_frame_past_lavapipes_loop_limit_fails_naming_it() {
    let Some(mut gpu) = gpu_or_skip("a_frame_past_lavapipes_loop_limit_fails_naming_it") else {
        return;
    };
    let tree = load("tree");
    let compiled = compile(&tree);
    gpu.set_scene(&compiled)
        .unwrap_or_else(|e| panic!("tree: {e}"));
    let frame = |gpu: &mut GpuRenderer| {
        try_shaded_frames(
            gpu,
            &[shader_of(MethodId::Sphere)],
            &tree.camera,
            &compiled.settings,
        )
    };
    if let Err(e) = frame(&mut gpu) {
        panic!("tree, the default allowance: {e}");
    }
    let default_allowance = gpu.steps_per_dispatch();
    gpu.set_steps_per_dispatch(compiled.settings.max_steps);
    let whole_budget = frame(&mut gpu);
    // The renderer goes back to the other tests as it came.
    gpu.set_steps_per_dispatch(default_allowance);
    if gpu.device_kind() == skeletrace_core::backend::DeviceKind::SoftwareGpu {
        let Err(e) = whole_budget else {
            panic!("tree, the whole budget in one dispatch: no error on a software adapter")
        };
        assert!(e.contains("loop limit"), "{e}");
    } else if let Err(e) = whole_budget {
        panic!("tree, the whole budget in one dispatch: {e}");
    }
}

/// wgpu's OpenGL backend (Mesa's llvmpipe through EGL here and in CI), which wgpu falls back to
/// on a machine without a Vulkan loader: its shaders go through naga's GLSL and the driver's
/// GLSL compiler, which once dropped a store in the SCALIS tracer's breakpoint sort that
/// Vulkan kept (48 of the tree's 3 000 statistics rays; docs/gpu.md). Held to the CPU as on
/// Vulkan: that statistics case (scalis-quadratic through the tree, every crossing); its frames
/// are the `opengl` instance of the agreement suite.
#[test]
fn the_opengl_backend_traces_the_statistics_rays_as_the_cpu() {
    use skeletrace_core::methods::{Protocol, TraceMode};
    let Some(mut gpu) = skeletrace_tests::opengl_or_skip(
        "the_opengl_backend_traces_the_statistics_rays_as_the_cpu",
    ) else {
        return;
    };
    eprintln!("adapter: {}", gpu.adapter_name());
    let failures = statistics_disagreements(
        &mut gpu,
        "tree (OpenGL)",
        &load("tree"),
        (Protocol::Default, TraceMode::Transparent),
        (&[MethodId::ScalisQuadratic], STEPS_TOLERANCE),
    );
    assert!(failures.is_empty(), "disagreements: {failures:?}");
}

/// The scene the generator makes of `kind` from `seed` with `size` items.
fn generated(
    kind: skeletrace_core::model::generate::GeneratorKind,
    seed: u64,
    size: usize,
) -> Scene {
    let options = skeletrace_core::model::generate::GenerateOptions {
        seed,
        size: Some(size),
        ..Default::default()
    };
    skeletrace_core::model::generate::generate(kind, &options).unwrap_or_else(|e| panic!("{e}"))
}

/// The relative gap in average steps [`gpu_statistics_agree_with_the_cpus`] allows.
const STEPS_TOLERANCE: f64 = 0.01;

/// Traces the statistics protocol's first 3 000 rays (seed 5) on `scene` with `methods` on the
/// CPU and on `gpu`, prints both, and names the methods that miss the thresholds of
/// [`gpu_statistics_agree_with_the_cpus`], with average steps held to `steps_tolerance`
/// (relative).
fn statistics_disagreements(
    gpu: &mut GpuRenderer,
    name: &str,
    scene: &Scene,
    (protocol, mode): (
        skeletrace_core::methods::Protocol,
        skeletrace_core::methods::TraceMode,
    ),
    (methods, steps_tolerance): (&[skeletrace_core::methods::MethodId], f64),
) -> Vec<String> {
    use skeletrace_core::stats::{self, StatsSetup};
    let mut failures = Vec::new();
    let compiled = std::sync::Arc::new(compile(scene));
    let setup = StatsSetup {
        protocol,
        mode,
        ..StatsSetup::opaque(3000, 5)
    };
    let chosen: Vec<_> = methods.iter().map(|m| m.method()).collect();
    let cpu = stats::run(&compiled.program, name, &chosen, setup, &|_, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    let gpu_methods: Vec<GpuMethod> = methods
        .iter()
        .map(|&m| GpuMethod::from_id(m).unwrap_or_else(|| panic!("{m}")))
        .collect();
    let on_gpu = skeletrace_render::gpu_stats::run(
        gpu,
        &compiled,
        name,
        &gpu_methods,
        (setup, setup.rays),
        &|_, _| {},
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"));
    for (c, g) in cpu.methods.iter().zip(&on_gpu.methods) {
        eprintln!(
            "{name} ({protocol}, {mode:?}) {}: hits {} / {}, avg steps {:.3} / {:.3}, \
             missed {} / {}, spurious {} / {} of {} compared (CPU / GPU), GPU depth error \
             {:.1e}",
            c.name,
            c.hits,
            g.hits,
            c.avg_steps,
            g.avg_steps,
            c.missed,
            g.missed,
            c.spurious,
            g.spurious,
            g.compared,
            g.max_depth_error
        );
        let hits = c.hits.abs_diff(g.hits) as f64 / c.rays as f64;
        let steps = (g.avg_steps / c.avg_steps - 1.0).abs();
        // Field inversion is not conservative: it misses every exit and crossings past
        // its distance threshold on the CPU too. The GPU may not miss more.
        let errors = |m: &stats::MethodStats| m.missed + m.spurious;
        let more_errors = errors(g) as f64 - errors(c) as f64 > 0.005 * c.rays as f64
            || (errors(c) == 0 && errors(g) > 0);
        if g.compared != c.rays || hits > 0.005 || steps > steps_tolerance || more_errors {
            failures.push(format!("{name} ({protocol}, {mode:?}) {}", c.name));
        }
    }
    failures
}

/// Secondary rays (main.wgsl `trace_path`; cpu/renderer.rs): exact shadow rays towards every
/// light, and reflection and refraction through transparent groups (forward-inclusion 2023
/// §7.2), as the CPU renderer traces them. On `blobs` with shadow rays (two lights), on `blobs`
/// with two of its groups made transparent, and on random scenes of every primitive kind with
/// transparent groups under the maximum of `blobs` (one blend code for every case, so one set
/// of pipelines), a point and a directional light: the hit masks and the camera rays'
/// depths as in the other agreement tests, the step counts (summed over the reflected and
/// refracted rays, as on the CPU) and the colours of the hit pixels. Each case must show the
/// secondary rays: shadowed or see-through pixels that a plain render colours otherwise.
#[test]
fn secondary_rays_match_the_cpu_renderer() {
    let Some(mut gpu) = gpu_or_skip("secondary_rays_match_the_cpu_renderer") else {
        return;
    };
    let glass = |g: &mut skeletrace_core::model::scene::Group, opacity: f64, ior: f64| {
        g.material.opacity = opacity;
        g.material.ior = ior;
    };
    let mut cases = Vec::new();
    cases.push(("blobs-shadows", load("blobs"), true));
    let mut glassy = load("blobs");
    glass(&mut glassy.groups[0], 0.35, 1.5);
    glass(&mut glassy.groups[2], 0.6, 1.33);
    // Reflection and refraction alone.
    cases.push(("blobs-transparent", glassy, false));
    for seed in [71, 72] {
        let mut rng = SplitMix64::new(seed);
        let mut groups = common::random_groups(&mut rng, 4);
        for (i, g) in groups.iter_mut().enumerate() {
            g.material.color = [
                rng.range(0.2, 0.9),
                rng.range(0.2, 0.9),
                rng.range(0.2, 0.9),
            ];
            if i != 1 {
                glass(g, rng.range(0.2, 0.8), rng.range(1.1, 1.8));
            }
        }
        // The maximum of four groups, as `blobs`: the same blend code, the same pipelines.
        let mut scene = common::scene(groups, Some(Blend::Max((0..4).map(Blend::Group).collect())));
        scene.lights = vec![
            skeletrace_core::model::scene::Light::Point {
                position: [2.0, 3.0, 4.0],
                color: [1.0, 0.9, 0.8],
                intensity: 1.0,
            },
            skeletrace_core::model::scene::Light::Directional {
                direction: [-0.5, 0.7, 0.3],
                color: [0.6, 0.7, 1.0],
                intensity: 0.5,
            },
        ];
        cases.push((
            if seed == 71 { "random-71" } else { "random-72" },
            scene,
            true,
        ));
    }
    let mut failures = Vec::new();
    for (label, scene, shadows) in &cases {
        let compiled = compile(scene);
        let settings = compiled.settings;
        gpu.set_scene(&compiled).unwrap_or_else(|e| panic!("{e}"));
        // The same view with opaque groups and no shadow rays: no secondary ray at all.
        let mut opaque = scene.clone();
        for g in &mut opaque.groups {
            g.material.opacity = 1.0;
        }
        let opaque = compile(&opaque);
        for method in [
            shader_of(MethodId::QuadraticTaylor),
            shader_of(MethodId::Sphere),
        ] {
            let cpu_render = |compiled: &skeletrace_core::Compiled, shadows: bool| {
                let tracer = method.id().method().prepare(&compiled.program, settings);
                Renderer::new(compiled, tracer.as_ref(), settings).render(
                    &scene.camera,
                    RenderOptions {
                        width: SIZE,
                        height: SIZE,
                        shadows,
                        shading: Default::default(),
                    },
                )
            };
            let cpu_frame = cpu_render(&compiled, *shadows);
            let plain = cpu_render(&opaque, false);
            let gpu_frame = gpu
                .render(&request(
                    &[method],
                    &scene.camera,
                    &settings,
                    View::Shaded(Default::default()),
                    *shadows,
                ))
                .unwrap_or_else(|e| panic!("{label}: {e}"))
                .remove(0);
            let agreement = compare(&cpu_frame, &gpu_frame, settings.max_steps);
            let both: Vec<usize> = (0..SIZE * SIZE)
                .filter(|&i| cpu_frame.is_hit(i) && gpu_frame.is_hit(i))
                .collect();
            let close = both
                .iter()
                .filter(|&&i| colour_difference(cpu_frame.colour[i], gpu_frame.colour[i]) <= 0.02)
                .count();
            let changed = both
                .iter()
                .filter(|&&i| colour_difference(cpu_frame.colour[i], plain.colour[i]) > 0.02)
                .count();
            eprintln!(
                "{label} {}: hit mask {:.4}, steps equal {:.4} agreeing {:.4}, depth {:.2e}, \
                 colours {close}/{} within 0.02, {changed} changed by the secondary rays",
                method.name(),
                agreement.hit_mask,
                agreement.equal_steps,
                agreement.agreeing_steps,
                agreement.worst_depth,
                both.len()
            );
            // Sphere tracing's global Lipschitz bound may be too weak for a random scene to
            // hit anything; the guaranteed method must show the secondary rays.
            let shows_little = both.len() < SIZE * SIZE / 20 || changed * 20 < both.len();
            if method == shader_of(MethodId::QuadraticTaylor) && shows_little {
                failures.push(format!(
                    "{label}: {} hit pixels, {changed} changed: the case shows too little",
                    both.len()
                ));
            }
            let diagonal = compiled.program.support_bounds().diagonal();
            if agreement.hit_mask < 1.0
                || agreement.worst_depth > 1e-3 * diagonal
                || agreement.agreeing_steps < 0.99
                || close * 100 < both.len() * 99
            {
                failures.push(format!("{label} {}: GPU and CPU differ", method.name()));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}
