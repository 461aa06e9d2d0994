//! The CPU backend's tile reuse (`cpu_backend.rs`, edit loop): after an edit, a
//! frame that copies the earlier frame's unchanged tiles, and in the other tiles the rays no
//! changed primitive reaches, is the frame a full trace gives, bit for bit, for every method,
//! on generated scenes and random edits the code was not written against; and it does copy
//! tiles and rays.

mod common;

use skeletrace_core::backend::{Cancel, FrameBackend, FrameRequest};
use skeletrace_core::compile::{Compiled, compile};
use skeletrace_core::cpu::cpu_backend::CpuBackend;
use skeletrace_core::cpu::renderer::{EarlierFrame, RenderOptions, Renderer, TracedFrame};
use skeletrace_core::frame::{FieldShading, Frame, View};
use skeletrace_core::methods::MethodId;
use skeletrace_core::model::generate::{GenerateOptions, GeneratorKind, generate};
use skeletrace_core::model::kernel::Kernel;
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::Scene;

const SIZE: (usize, usize) = (40, 32);

/// A frame's pixels as bits.
fn bits(frame: &Frame) -> Vec<(u32, u32, u32, u64, u32)> {
    (0..frame.width * frame.height)
        .map(|i| {
            let [r, g, b] = frame.colour[i].map(f32::to_bits);
            (r, g, b, frame.depth[i].to_bits(), frame.steps[i])
        })
        .collect()
}

fn request(scene: &Scene, compiled: &Compiled, methods: &[MethodId], view: View) -> FrameRequest {
    FrameRequest {
        camera: scene.camera,
        width: SIZE.0,
        height: SIZE.1,
        methods: methods.to_vec(),
        view,
        shadows: false,
        settings: compiled.settings,
        cancel: Cancel::new(),
    }
}

/// The methods that trace `compiled`'s scene.
fn methods_tracing(compiled: &Compiled) -> Vec<MethodId> {
    MethodId::ALL
        .into_iter()
        .filter(|id| id.method().supports(&compiled.program).is_ok())
        .collect()
}

/// The scene `generate` makes of `kind` at `size` from `seed`.
fn generated(kind: GeneratorKind, size: usize, seed: u64) -> Scene {
    let options = GenerateOptions {
        seed,
        size: Some(size),
        ..GenerateOptions::default()
    };
    generate(kind, &options).unwrap_or_else(|e| panic!("{e}"))
}

/// A random edit of `scene`: a vertex or a blob moved a little, a radius changed, or (one
/// time in five) a kernel scale, which every ray sees.
fn edit(scene: &mut Scene, rng: &mut SplitMix64) -> &'static str {
    let nudge = |rng: &mut SplitMix64, p: &mut [f64; 3], by: f64| {
        for c in p.iter_mut() {
            *c += rng.range(-by, by);
        }
    };
    let g = rng.below(scene.groups.len());
    let group = &mut scene.groups[g];
    if rng.below(5) == 0
        && let Kernel::CompactPolynomial { scale, .. } | Kernel::Cauchy { scale, .. } =
            &mut group.kernel
    {
        *scale *= 1.05;
        return "kernel scale";
    }
    if let Some(skeleton) = group.skeletons.first_mut() {
        let v = rng.below(skeleton.vertices.len());
        let vertex = &mut skeleton.vertices[v];
        if rng.below(2) == 0 {
            vertex.radius *= 1.1;
            return "vertex radius";
        }
        let by = 0.2 * vertex.radius;
        nudge(rng, &mut vertex.position, by);
        return "vertex moved";
    }
    if !group.blobs.is_empty() {
        let b = rng.below(group.blobs.len());
        let blob = &mut group.blobs[b];
        let by = 0.2 * blob.radius;
        nudge(rng, &mut blob.center, by);
        return "blob moved";
    }
    "nothing"
}

#[test]
fn frames_reusing_tiles_are_the_frames_traced_in_full() {
    let kinds = [
        (GeneratorKind::Tree, 3),
        (GeneratorKind::RandomSkeleton, 24),
        (GeneratorKind::Blobs, 60),
        (GeneratorKind::Truss, 2),
        (GeneratorKind::Molecule, 40),
    ];
    let generated = kinds.into_iter().enumerate().map(|(case, (kind, size))| {
        (
            format!("{kind:?}"),
            generated(kind, size, 4401 + case as u64),
        )
    });
    // And hand-made scenes: a plane and groups under a max (creature), shapes and every
    // operator (operators), an HRBF set (hrbf).
    let assets =
        ["creature", "operators", "hrbf"].map(|name| (name.to_owned(), common::asset(name)));
    let mut rng = SplitMix64::new(4401);
    let (mut compared, mut edits_reusing, mut edits_copying_rays) = (0, 0, 0);
    for (kind, mut scene) in generated.chain(assets) {
        let mut compiled = compile(&scene);
        let methods = methods_tracing(&compiled);
        assert!(
            methods.contains(&MethodId::QuadraticTaylor),
            "{kind}: {methods:?}"
        );
        for view in [
            View::Shaded(FieldShading::default()),
            View::Steps { steps_max: 64 },
        ] {
            let mut backend = CpuBackend::reusing_tiles();
            let _ = backend
                .render(&compiled, &request(&scene, &compiled, &methods, view))
                .unwrap_or_else(|e| panic!("{e}"));
            for step in 0..4 {
                let what = edit(&mut scene, &mut rng);
                scene.validate().unwrap_or_else(|e| panic!("{e}"));
                compiled = compile(&scene);
                let asked = request(&scene, &compiled, &methods, view);
                let got = backend
                    .render(&compiled, &asked)
                    .unwrap_or_else(|e| panic!("{e}"));
                let want = CpuBackend::new()
                    .render(&compiled, &asked)
                    .unwrap_or_else(|e| panic!("{e}"));
                for ((id, got), want) in methods.iter().zip(&got).zip(&want) {
                    assert!(
                        bits(got) == bits(want),
                        "{kind} step {step} ({what}), {view:?}: {} differs from a full trace",
                        id.name()
                    );
                    compared += 1;
                }
                edits_reusing += usize::from(backend.share_of_tiles_reused() > 0.0);
                // Every tile is whole (`SIZE` is a multiple of 8): more pixels than tiles
                // copied means rays copied in tiles traced again.
                edits_copying_rays +=
                    usize::from(backend.share_of_pixels_reused() > backend.share_of_tiles_reused());
            }
        }
    }
    eprintln!(
        "compared {compared} frames; {edits_reusing} edits reused tiles, \
         {edits_copying_rays} copied rays of tiles traced again"
    );
    assert!(compared > 100, "{compared}");
    assert!(edits_reusing > 0, "no edit reused a tile");
    assert!(
        edits_copying_rays > 0,
        "no edit copied a ray of a tile traced again"
    );
}

/// Side, in pixels, of the frames of [`frames_around`]: 12 × 9 whole tiles of 64 pixels.
const EDIT_FRAME: (usize, usize) = (96, 72);

/// An edit's frames, quadratic Taylor through the scene's camera at [`EDIT_FRAME`].
struct EditFrames {
    /// Before the edit.
    first: TracedFrame,
    /// After it, reusing `first`.
    again: TracedFrame,
    /// After it, traced in full.
    full: TracedFrame,
    /// How many primitives it changed.
    changed: usize,
}

/// The frames around `edit` of `scene`, after checking that the edit shows and that the frame
/// reusing the earlier one is the full trace's, bit for bit.
fn frames_around(mut scene: Scene, edit: impl FnOnce(&mut Scene)) -> EditFrames {
    let before = compile(&scene);
    edit(&mut scene);
    let after = compile(&scene);
    let changed = after
        .program
        .primitives_changed_since(&before.program)
        .unwrap_or_else(|| panic!("the edit changes nothing but some primitives"));
    let render_options = RenderOptions {
        width: EDIT_FRAME.0,
        height: EDIT_FRAME.1,
        shadows: false,
        shading: FieldShading::default(),
    };
    let method = MethodId::QuadraticTaylor.method();
    let trace = |compiled: &Compiled, earlier: Option<&EarlierFrame<'_>>| {
        let tracer = method.prepare(&compiled.program, compiled.settings);
        Renderer::new(compiled, tracer.as_ref(), compiled.settings)
            .render_reusing(&scene.camera, render_options, &Cancel::new(), earlier)
            .unwrap_or_else(|| panic!("not cancelled"))
    };
    let first = trace(&before, None);
    let again = trace(
        &after,
        Some(&EarlierFrame {
            frame: &first.frame,
            tile_primitives: &first.tile_primitives,
            changed: &changed,
            program: &before.program,
        }),
    );
    let full = trace(&after, None);
    assert!(
        bits(&first.frame) != bits(&full.frame),
        "the edit must show, or copying a pixel it reached would go unseen"
    );
    assert!(bits(&again.frame) == bits(&full.frame));
    assert_eq!((full.reused_tiles, full.reused_pixels), (0, 0));
    EditFrames {
        first,
        again,
        full,
        changed: changed.iter().filter(|c| **c).count(),
    }
}

/// An edit far from most of the screen copies most tiles: a blob of a generated scene moved;
/// the frame is the full trace's.
#[test]
fn an_edit_traces_again_only_the_tiles_it_reaches() {
    let scene = generated(GeneratorKind::Blobs, 80, 77);
    let frames = frames_around(scene, |scene| {
        let blob = &mut scene.groups[0].blobs[0];
        blob.center[0] += 0.1 * blob.radius;
    });
    assert_eq!(frames.changed, 1);
    let tiles = frames.full.tile_primitives.len();
    assert_eq!(tiles, frames.first.tile_primitives.len());
    let again = &frames.again;
    assert!(
        again.reused_tiles * 2 > tiles && again.reused_tiles < tiles,
        "{} of {tiles} tiles reused",
        again.reused_tiles
    );
}

/// An edit that moves the support bounds within their grid cells (`FieldProgram::scale_bounds`)
/// copies what it did not reach, as any other: on generated scenes, the skeleton vertex or
/// blob whose support reaches highest moved up a little, the frame the full trace's.
#[test]
fn an_edit_of_an_extremal_primitive_traces_again_only_what_it_reaches() {
    let kinds = [
        (GeneratorKind::Blobs, 40),
        (GeneratorKind::Tree, 3),
        (GeneratorKind::RandomSkeleton, 16),
        (GeneratorKind::Molecule, 30),
    ];
    let mut copied = 0;
    for (case, (kind, size)) in kinds.into_iter().enumerate() {
        let scene = generated(kind, size, 9300 + case as u64);
        let top = |scene: &Scene| compile(scene).program.support_bounds().max.y;
        let before = compile(&scene);
        // A vertex of a group's first skeleton (`true`) or a blob, moved up by `by` radii.
        let raise = |scene: &mut Scene, (g, vertex, i): (usize, bool, usize), by: f64| {
            let group = &mut scene.groups[g];
            let (position, radius) = if vertex {
                let vertex = &mut group.skeletons[0].vertices[i];
                (&mut vertex.position, vertex.radius)
            } else {
                let blob = &mut group.blobs[i];
                (&mut blob.center, blob.radius)
            };
            position[1] += by * radius;
        };
        let targets = scene.groups.iter().enumerate().flat_map(|(g, group)| {
            let vertices = group.skeletons.first().map_or(0, |s| s.vertices.len());
            (0..vertices)
                .map(move |v| (g, true, v))
                .chain((0..group.blobs.len()).map(move |b| (g, false, b)))
        });
        // The vertex or blob whose move up raises the support bounds' top.
        let extremal = targets
            .filter(|&target| {
                let mut moved = scene.clone();
                raise(&mut moved, target, 0.01);
                top(&moved) > top(&scene)
            })
            .collect::<Vec<_>>();
        let Some(&target) = extremal.first() else {
            panic!("{kind:?}: no vertex or blob reaches the top");
        };
        let mut moved = scene.clone();
        raise(&mut moved, target, 0.01);
        let (before, after) = (&before.program, &compile(&moved).program);
        assert!(after.support_bounds() != before.support_bounds());
        assert_eq!(
            after.scale_bounds(),
            before.scale_bounds(),
            "{kind:?}: the move crosses a grid line; choose a smaller one"
        );
        let frames = frames_around(scene, |scene| raise(scene, target, 0.01));
        eprintln!(
            "{kind:?}: {} of {} pixels copied",
            frames.again.reused_pixels,
            EDIT_FRAME.0 * EDIT_FRAME.1
        );
        copied += usize::from(frames.again.reused_pixels > 0);
    }
    assert_eq!(copied, kinds.len(), "every extremal edit copies pixels");
}

/// In the tiles an edit reaches, the rays that no changed primitive reaches are copied: the
/// creature's left hind knee moved; the frame is the full trace's.
#[test]
fn an_edit_traces_again_only_the_rays_it_reaches() {
    let frames = frames_around(common::asset("creature"), |scene| {
        let knee = &mut scene.groups[0].skeletons[0].vertices[9];
        knee.position[1] += 0.05 * knee.radius;
    });
    let again = &frames.again;
    let pixels = EDIT_FRAME.0 * EDIT_FRAME.1;
    let tiles = frames.full.tile_primitives.len();
    eprintln!(
        "{} of {pixels} pixels copied, {} of {tiles} tiles whole",
        again.reused_pixels, again.reused_tiles
    );
    assert!(again.reused_tiles < tiles, "the edit reaches some tiles");
    assert!(
        again.reused_pixels > again.reused_tiles * 64 && again.reused_pixels < pixels,
        "{} of {pixels} pixels reused, {} of {tiles} whole tiles",
        again.reused_pixels,
        again.reused_tiles
    );
}
