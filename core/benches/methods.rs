//! Time per ray of every method on the `blobs` and `tree` assets and on 1000 summed blobs
//! (`generate blobs --groups 1 --size 1000`), with the statistics protocol's rays (six
//! axis directions from the faces of the support box), single-threaded; and time per pixel of
//! whole 64×64 frames (camera rays from screen-tile candidate lists, normals, shading) for one
//! method of each family, on rayon's pool (`RAYON_NUM_THREADS=1` for one thread). Criterion reports time per ray as the inverse of the
//! element throughput; `skeletrace stats` reports the same quantity with the step counts.

use std::hint::black_box;
use std::path::Path;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use skeletrace_core::compile;
use skeletrace_core::cpu::renderer::{RenderOptions, Renderer};
use skeletrace_core::frame::FieldShading;
use skeletrace_core::methods::{self, MethodId, TraceMode, TraceSettings};
use skeletrace_core::model::generate::{GenerateOptions, GeneratorKind, generate};
use skeletrace_core::stats::protocol_rays;
use skeletrace_core::{FieldProgram, Scene};

const RAYS: usize = 600;

fn asset(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../assets/scenes/{name}.ron"));
    match Scene::load(&path) {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    }
}

fn bench_scene(c: &mut Criterion, name: &str, scene: &Scene) {
    let program = FieldProgram::new(scene);
    let settings = TraceSettings::for_program(&program);
    let rays = protocol_rays(&program, RAYS, 1);
    let mut group = c.benchmark_group(format!("ray/{name}"));
    group.throughput(Throughput::Elements(RAYS as u64));
    group.sample_size(10);
    for method in methods::all() {
        if method.id() == MethodId::Reference || method.supports(&program).is_err() {
            continue;
        }
        let tracer = method.prepare(&program, settings);
        group.bench_function(BenchmarkId::from_parameter(method.name()), |b| {
            b.iter(|| {
                for (ray, span) in &rays {
                    black_box(tracer.trace(ray, *span, TraceMode::Opaque));
                }
            });
        });
    }
    group.finish();
}

/// Side of the benchmarked frames.
const FRAME: usize = 64;

fn bench_frames(c: &mut Criterion, name: &str, scene: &Scene) {
    let compiled = compile(scene);
    let mut group = c.benchmark_group(format!("frame/{name}"));
    group.throughput(Throughput::Elements((FRAME * FRAME) as u64));
    group.sample_size(10);
    let options = RenderOptions {
        width: FRAME,
        height: FRAME,
        shadows: false,
        shading: FieldShading::default(),
    };
    for id in [
        MethodId::Sphere,
        MethodId::Segment,
        MethodId::QuadraticTaylor,
        MethodId::BottomUpQuadratic,
        MethodId::ScalisQuadratic,
    ] {
        let method = id.method();
        if method.supports(&compiled.program).is_err() {
            continue;
        }
        let tracer = method.prepare(&compiled.program, compiled.settings);
        let renderer = Renderer::new(&compiled, tracer.as_ref(), compiled.settings);
        group.bench_function(BenchmarkId::from_parameter(id.name()), |b| {
            b.iter(|| black_box(renderer.render(&scene.camera, options)));
        });
    }
    group.finish();
}

fn thousand_blobs() -> Scene {
    let options = GenerateOptions {
        seed: 1,
        size: Some(1000),
        groups: Some(1),
        ..GenerateOptions::default()
    };
    match generate(GeneratorKind::Blobs, &options) {
        Ok(scene) => scene,
        Err(e) => panic!("{e}"),
    }
}

fn methods_per_ray(c: &mut Criterion) {
    bench_scene(c, "blobs", &asset("blobs"));
    bench_scene(c, "tree", &asset("tree"));
    bench_scene(c, "blobs-1000", &thousand_blobs());
    bench_frames(c, "tree", &asset("tree"));
    bench_frames(c, "blobs-1000", &thousand_blobs());
}

criterion_group!(benches, methods_per_ray);
criterion_main!(benches);
