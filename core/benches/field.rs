//! Point-evaluation throughput of the field engine (issue: "the scene model and the field
//! engine"). Queries sit near the surface (a skeleton vertex or blob centre plus about one radius
//! in a random direction) so that every evaluation touches primitives. Scenes grow at fixed
//! support overlap, so the time per evaluation should stay flat as the primitive count grows.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use skeletrace_core::model::generate::{GenerateOptions, GeneratorKind, generate};
use skeletrace_core::model::kernel::Kernel;
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::{Blob, Camera, Group, Material, Scene};
use skeletrace_core::{FieldProgram, Interval, Ray};

const QUERIES: usize = 4096;

/// `n` compact blobs of radius 0.1 uniform in a cube whose volume grows with `n` (about 8 blobs
/// per unit volume, so each point sees the same number of supports at every size).
fn blob_scene(n: usize) -> Scene {
    let mut rng = SplitMix64::new(11);
    let side = (n as f64 / 8.0).cbrt();
    let blobs = (0..n)
        .map(|_| Blob {
            center: [
                rng.range(0.0, side),
                rng.range(0.0, side),
                rng.range(0.0, side),
            ],
            radius: rng.range(0.15, 0.3),
        })
        .collect();
    Scene {
        version: 1,
        isovalue: 1.0,
        groups: vec![Group {
            name: "blobs".into(),
            kernel: Kernel::default(),
            material: Material::default(),
            skeletons: Vec::new(),
            blobs,
            shapes: Vec::new(),
            hrbfs: Vec::new(),
            transform: skeletrace_core::model::scene::Transform::IDENTITY,
            repeat: None,
        }],
        blend: None,
        camera: Camera::default(),
        lights: Vec::new(),
    }
}

fn skeleton_scene(segments: usize) -> Scene {
    generate(
        GeneratorKind::RandomSkeleton,
        &GenerateOptions {
            seed: 3,
            size: Some(segments),
            ..GenerateOptions::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Points about one radius from random skeleton vertices or blob centres.
fn queries(scene: &Scene) -> Vec<DVec3> {
    let mut anchors: Vec<(DVec3, f64)> = Vec::new();
    for g in &scene.groups {
        for s in &g.skeletons {
            anchors.extend(
                s.vertices
                    .iter()
                    .map(|v| (DVec3::from_array(v.position), v.radius)),
            );
        }
        anchors.extend(
            g.blobs
                .iter()
                .map(|b| (DVec3::from_array(b.center), b.radius)),
        );
    }
    let mut rng = SplitMix64::new(5);
    (0..QUERIES)
        .map(|_| {
            let (c, r) = anchors[rng.below(anchors.len())];
            c + DVec3::from_array(rng.direction()) * r * rng.range(0.5, 1.5)
        })
        .collect()
}

fn bench_points(c: &mut Criterion) {
    let mut group = c.benchmark_group("point evaluation");
    group.throughput(Throughput::Elements(QUERIES as u64));
    let scenes = [
        ("scalis segments", 100, skeleton_scene(100)),
        ("scalis segments", 1_000, skeleton_scene(1_000)),
        ("scalis segments", 10_000, skeleton_scene(10_000)),
        ("blobs", 1_000, blob_scene(1_000)),
        ("blobs", 10_000, blob_scene(10_000)),
        ("blobs", 100_000, blob_scene(100_000)),
    ];
    for (name, n, scene) in &scenes {
        let program = FieldProgram::new(scene);
        let points = queries(scene);
        group.bench_with_input(
            BenchmarkId::new(format!("{name} value"), n),
            &points,
            |b, pts| {
                b.iter(|| {
                    pts.iter()
                        .map(|&p| program.value(black_box(p)))
                        .sum::<f64>()
                });
            },
        );
        group.bench_with_input(
            BenchmarkId::new(format!("{name} value+gradient"), n),
            &points,
            |b, pts| {
                b.iter(|| {
                    pts.iter()
                        .map(|&p| program.value_gradient(black_box(p)).0)
                        .sum::<f64>()
                });
            },
        );
    }
    group.finish();
}

fn bench_ray_bounds(c: &mut Criterion) {
    let mut group = c.benchmark_group("ray interval bounds");
    group.throughput(Throughput::Elements(QUERIES as u64));
    for (name, scene) in [
        ("scalis segments 1000", skeleton_scene(1_000)),
        ("blobs 10000", blob_scene(10_000)),
    ] {
        let program = FieldProgram::new(&scene);
        let mut rng = SplitMix64::new(9);
        let rays: Vec<(Ray, Interval)> = queries(&scene)
            .into_iter()
            .map(|p| {
                let d = DVec3::from_array(rng.direction());
                (Ray::new(p - d, d), Interval::new(0.9, 1.1))
            })
            .collect();
        group.bench_function(name, |b| {
            b.iter(|| {
                rays.iter()
                    .map(|(r, s)| program.ray_jet(black_box(r), *s).d1.hi)
                    .sum::<f64>()
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench_points, bench_ray_bounds);
criterion_main!(benches);
