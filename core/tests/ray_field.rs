//! A ray's gathered candidates answer every query bit for bit as the program's BVH does
//! (`core/src/field/ray_field.rs`): values and derivatives at points, jets, group jets and
//! values, Lipschitz bounds, supports and their unions, on every asset and on random scenes of
//! every primitive type and blend, for rays aimed at primitives and the `stats` protocol's
//! axis-aligned rays (whose zero direction components exercise the slab test's edge cases).
//! So the marches, their step counts and their depths are those of the BVH queries.

mod common;

use common::{
    KERNELS, KINDS, Kind, add_primitive, assert_no_failures, assets, every_operator, group,
    random_groups, scene,
};
use glam::DVec3;
use rayon::prelude::*;
use skeletrace_core::compile;
use skeletrace_core::cpu::renderer::{RenderOptions, Renderer};
use skeletrace_core::field::primitives::Primitive;
use skeletrace_core::field::program::PrimitiveSlope;
use skeletrace_core::field::ray_field::{RayField, TileCandidates};
use skeletrace_core::frame::{FieldShading, PinholeCamera, far_distance};
use skeletrace_core::methods::{MethodId, TraceMode};
use skeletrace_core::model::generate::{GenerateOptions, GeneratorKind, generate};
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::{Blend, Camera, Group, Scene};
use skeletrace_core::stats::protocol_rays;
use skeletrace_core::{FieldProgram, Interval, Jet, Ray};

fn same_bits(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits()
}

/// Compares every query of `field` with the program's own; returns the first difference.
fn compare(program: &FieldProgram, field: &RayField, rng: &mut SplitMix64) -> Option<String> {
    let (ray, span) = (&field.ray().clone(), field.span());
    // Enough point questions that the ray's candidates get binned (`CELLS_AFTER`), so that both
    // the scan of every candidate and the bins are compared.
    for k in 0..48 {
        let t = rng.range(span.lo, span.hi);
        let (a, b) = (field.along(t), program.along_ray(ray, t));
        if !same_bits(a.0, b.0) || !same_bits(a.1, b.1) {
            return Some(format!("along({t}) after {k} questions: {a:?} vs {b:?}"));
        }
        if !same_bits(field.value(t), b.0) {
            return Some(format!("value({t}): {} vs {}", field.value(t), b.0));
        }
        let (gradient, expected) = (
            field.value_gradient(t).1,
            program.value_gradient(ray.at(t)).1,
        );
        if gradient.to_array().map(f64::to_bits) != expected.to_array().map(f64::to_bits) {
            return Some(format!("gradient at {t}: {gradient} vs {expected}"));
        }
        if k % 4 != 0 {
            continue;
        }
        if field.group_values(t) != program.group_values_along_ray(ray, t) {
            return Some(format!("group values at {t}"));
        }
        let width = span.width() * 10f64.powf(rng.range(-4.0, 0.0));
        let sub = Interval::new(t, t + width);
        if field.jet(sub) != program.ray_jet(ray, sub) {
            return Some(format!(
                "jet on {sub:?}: {:?} vs {:?}",
                field.jet(sub),
                program.ray_jet(ray, sub)
            ));
        }
        if field.group_jets(sub) != program.ray_group_jets(ray, sub) {
            return Some(format!("group jets on {sub:?}"));
        }
        for slope in [PrimitiveSlope::Exact, PrimitiveSlope::Published] {
            if !same_bits(
                field.summed_lipschitz(sub, slope),
                program.summed_lipschitz(ray, sub, slope),
            ) {
                return Some(format!("summed Lipschitz ({slope:?}) on {sub:?}"));
            }
        }
    }
    if field.supports(span) != program.ray_supports(ray, span) {
        return Some("supports".to_owned());
    }
    // Into an array holding an earlier ray's parts, as the tracer's reused arrays do.
    let mut parts = vec![Interval::new(-1.0, 1.0); 3];
    field.support_unions_into(span, &mut parts);
    if parts != program.ray_support_unions(ray, span) {
        return Some("support unions".to_owned());
    }
    None
}

/// Rays aimed at random primitives, then the protocol's rays.
fn check_program(program: &FieldProgram, label: &str, seed: u64) -> Vec<String> {
    let mut rng = SplitMix64::new(seed);
    let mut rays: Vec<(Ray, Interval)> = (0..60)
        .map(|_| common::aimed_ray(program, &mut rng))
        .collect();
    rays.extend(protocol_rays(program, 60, seed));
    rays.iter()
        .filter_map(|(ray, span)| {
            compare(program, &RayField::new(program, ray, *span), &mut rng)
                .map(|e| format!("{label}: ray {ray:?}: {e}"))
        })
        .collect()
}

/// Two random groups, each but an HRBF set given `extra` more primitives of random kinds, so
/// that the BVH has depth.
fn crowded_groups(rng: &mut SplitMix64, extra: usize) -> Vec<Group> {
    let mut groups = random_groups(rng, 2);
    for g in &mut groups {
        if g.hrbfs.is_empty() {
            for _ in 0..extra {
                let kind = KINDS[rng.below(KINDS.len() - 1)];
                common::add_primitive(g, kind, rng);
            }
        }
    }
    groups
}

/// Camera rays of random 8×8 tiles of a 64×48 image from random cameras around the scene (and
/// the scene's own): the fields gathered from the tile's list answer as the program does.
fn check_tiles(
    program: &FieldProgram,
    scene_camera: &Camera,
    label: &str,
    seed: u64,
) -> Vec<String> {
    let bounds = program.support_bounds();
    let mut rng = SplitMix64::new(seed);
    let mut failures = Vec::new();
    for k in 0..6 {
        let camera = if k == 0 {
            *scene_camera
        } else {
            let dir = DVec3::from_array(rng.direction());
            let distance = bounds.diagonal() * rng.range(0.3, 2.0);
            Camera {
                position: (bounds.center() + distance * dir).to_array(),
                target: (bounds.center()
                    + 0.2 * bounds.diagonal() * DVec3::from_array(rng.direction()))
                .to_array(),
                fov_degrees: rng.range(20.0, 90.0),
                ..Camera::default()
            }
        };
        let pinhole = PinholeCamera::new(&camera);
        let (w, h) = (64, 48);
        let span = Interval::new(0.0, far_distance(program, &camera));
        let (x0, y0) = (8 * rng.below(w / 8), 8 * rng.below(h / 8));
        let corners = pinhole.tile_corners((x0, x0 + 8), (y0, y0 + 8), w, h);
        let tile = TileCandidates::gather(program, pinhole.origin(), corners, span);
        for y in y0..y0 + 8 {
            for x in x0..x0 + 8 {
                let ray = pinhole.ray(x, y, w, h);
                let field = RayField::from_tile(program, &ray, span, &tile);
                if let Some(e) = compare(program, &field, &mut rng) {
                    failures.push(format!("{label}: camera {k}, pixel ({x}, {y}): {e}"));
                }
            }
        }
    }
    failures
}

/// A tile's list is a small part of the scene: on the molecule asset and on 1000 generated
/// blobs, through their cameras at 256×256, tiles list on average under a tenth of the
/// primitives (a beam that kept every box would pass the tests above, tracing as slowly as
/// without tiles).
#[test]
fn tile_candidates_are_a_small_part_of_the_scene() {
    let molecule = Scene::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/molecule.ron"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let options = GenerateOptions {
        seed: 21,
        size: Some(1000),
        groups: Some(1),
        ..GenerateOptions::default()
    };
    let blobs = generate(GeneratorKind::Blobs, &options).unwrap_or_else(|e| panic!("{e}"));
    for (name, scene) in [("molecule", molecule), ("1000 blobs", blobs)] {
        let program = FieldProgram::new(&scene);
        let pinhole = PinholeCamera::new(&scene.camera);
        let span = Interval::new(0.0, far_distance(&program, &scene.camera));
        let (size, tile) = (256, 8);
        let tiles = size / tile;
        let listed: usize = (0..tiles * tiles)
            .map(|k| {
                let (x0, y0) = ((k % tiles) * tile, (k / tiles) * tile);
                let corners = pinhole.tile_corners((x0, x0 + tile), (y0, y0 + tile), size, size);
                TileCandidates::gather(&program, pinhole.origin(), corners, span).len()
            })
            .sum();
        let share = listed as f64 / (tiles * tiles * program.primitives().len()) as f64;
        eprintln!(
            "{name}: tiles list {:.2} % of the primitives on average",
            100.0 * share
        );
        assert!(
            share < 0.1,
            "{name}: tiles list {share} of the primitives on average"
        );
    }
}

#[test]
fn tile_candidates_answer_as_the_bvh_on_every_asset() {
    let failures: Vec<String> = assets()
        .par_iter()
        .flat_map_iter(|path| {
            let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
            let program = FieldProgram::new(&scene);
            check_tiles(&program, &scene.camera, &path.display().to_string(), 11)
        })
        .collect();
    assert_no_failures(&failures, "differences");
}

#[test]
fn tile_candidates_answer_as_the_bvh_on_random_scenes() {
    let failures: Vec<String> = (0..60)
        .into_par_iter()
        .flat_map_iter(|job| {
            let mut rng = SplitMix64::new(job as u64 * 104_729 + 5);
            let groups = crowded_groups(&mut rng, 30);
            let program = FieldProgram::new(&scene(groups, None));
            check_tiles(
                &program,
                &Camera::default(),
                &format!("scene {job}"),
                job as u64,
            )
        })
        .collect();
    assert_no_failures(&failures, "differences");
}

/// The renderer traces camera rays from tile lists: its frames' step counts and depths are
/// those of the same rays traced one by one (`RayTracer::trace`, a BVH walk per ray), for every
/// method on every asset.
#[test]
fn frames_traced_by_tiles_are_those_traced_ray_by_ray() {
    let jobs: Vec<(std::path::PathBuf, MethodId)> = assets()
        .into_iter()
        .flat_map(|path| MethodId::ALL.map(|m| (path.clone(), m)))
        .filter(|(_, m)| *m != MethodId::Reference)
        .collect();
    let failures: Vec<String> = jobs
        .par_iter()
        .filter_map(|(path, id)| {
            let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
            let compiled = compile(&scene);
            let method = id.method();
            method.supports(&compiled.program).ok()?;
            let tracer = method.prepare(&compiled.program, compiled.settings);
            let renderer = Renderer::new(&compiled, tracer.as_ref(), compiled.settings);
            let (w, h) = (21, 13);
            let options = RenderOptions {
                width: w,
                height: h,
                shadows: false,
                shading: FieldShading::default(),
            };
            let frame = renderer.render(&scene.camera, options);
            let pinhole = PinholeCamera::new(&scene.camera);
            let span = Interval::new(0.0, far_distance(&compiled.program, &scene.camera));
            let opaque = compiled.materials.iter().all(|m| m.opacity >= 1.0);
            let differing = (0..w * h)
                .filter(|&i| {
                    let trace =
                        tracer.trace(&pinhole.ray(i % w, i / w, w, h), span, TraceMode::Opaque);
                    let depth = trace.first().map_or(f64::INFINITY, |c| c.t);
                    depth.to_bits() != frame.depth[i].to_bits()
                        || (opaque && trace.steps != frame.steps[i])
                })
                .count();
            (differing > 0).then(|| {
                format!(
                    "{}: {}: {differing} pixels differ",
                    path.display(),
                    id.name()
                )
            })
        })
        .collect();
    assert_no_failures(&failures, "frames");
}

#[test]
fn candidates_answer_as_the_bvh_on_every_asset() {
    let failures: Vec<String> = assets()
        .par_iter()
        .flat_map_iter(|path| {
            let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
            check_program(&FieldProgram::new(&scene), &path.display().to_string(), 5)
        })
        .collect();
    assert_no_failures(&failures, "differences");
}

#[test]
fn candidates_answer_as_the_bvh_on_random_scenes() {
    let operators = every_operator(Blend::Group(0), Blend::Group(1));
    let failures: Vec<String> = (0..200)
        .into_par_iter()
        .flat_map_iter(|job| {
            let mut rng = SplitMix64::new(job as u64 * 7_919 + 3);
            let groups = crowded_groups(&mut rng, 20);
            let blend = operators[job % operators.len()].clone();
            let program = FieldProgram::new(&scene(groups, Some(blend)));
            check_program(&program, &format!("scene {job}"), job as u64)
        })
        .collect();
    assert_no_failures(&failures, "differences");
}

/// A ray's field leaves out a primitive whose support its line misses by more than rounding
/// (`Primitive::zero_on_line`), which is sound only if the primitive is exactly 0, with a zero
/// gradient, at every point of the ray. Checked on lines tangent to point blobs' and SCALIS
/// segments' supports (both convex), offset outward by 10⁻⁹ to 10⁻² of the local radius, for
/// every kernel: sampled uniformly and ever closer around the point of tangency. The line is
/// left out at 10⁻³ and beyond, and kept at 10⁻⁹ (within the margin) and where it is offset
/// inward (through the support).
#[test]
fn primitives_left_out_of_a_ray_are_zero_on_it() {
    let mut rng = SplitMix64::new(11);
    let mut failures = Vec::new();
    let mut left_out = 0;
    for kernel in KERNELS {
        for kind in [Kind::Point, Kind::ScalisSegment] {
            for _ in 0..12 {
                let mut g = group(kernel);
                add_primitive(&mut g, kind, &mut rng);
                let compiled = compile(&scene(vec![g], None));
                let program = &compiled.program;
                for (i, primitive) in program.primitives().iter().enumerate() {
                    let k = program.kernel_of(i as u32);
                    // A boundary point with its outward normal, and the local radius there.
                    let (touch, normal, radius) = match primitive {
                        Primitive::Point(blob) => {
                            let n = DVec3::from(rng.direction());
                            let r = blob.radius * k.support_radius();
                            (blob.center + r * n, n, r)
                        }
                        Primitive::Scalis(segment) => {
                            // On the larger end's cap, where the normal is radial.
                            let cone = segment.support(k);
                            let n = loop {
                                let n = DVec3::from(rng.direction());
                                if n.dot(cone.axis) > cone.slope {
                                    break n;
                                }
                            };
                            let r = cone.end_radius();
                            (cone.end() + r * n, n, r)
                        }
                        _ => continue,
                    };
                    // A random direction in the tangent plane.
                    let (u, v) = normal.any_orthonormal_pair();
                    let angle = rng.range(0.0, std::f64::consts::TAU);
                    let direction = u * angle.cos() + v * angle.sin();
                    for relative in [-1e-2, -1e-6, 1e-9, 1e-7, 1e-5, 1e-3, 1e-2] {
                        let offset = relative * radius;
                        let reach = 4.0 * radius;
                        let ray = Ray::new(touch + offset * normal - reach * direction, direction);
                        let t_max = 2.0 * reach;
                        let zero = primitive.zero_on_line(&ray, k, t_max);
                        // Inside the support, or within the margin: kept.
                        if relative <= 1e-9 && zero {
                            failures.push(format!("{kernel:?} {i}: left out at {relative:e}"));
                        }
                        if relative >= 1e-3 && !zero {
                            failures.push(format!("{kernel:?} {i}: kept at {relative:e}"));
                        }
                        if !zero {
                            continue;
                        }
                        left_out += 1;
                        for sample in 0..400 {
                            let t = if sample < 100 {
                                rng.range(0.0, t_max)
                            } else {
                                let closeness = 10f64.powi(-(sample % 12));
                                reach + radius * closeness * rng.range(-1.0, 1.0)
                            };
                            let p = ray.at(t);
                            let (v, gradient) = primitive.value_gradient(p, k);
                            if v != 0.0 || gradient != DVec3::ZERO || primitive.value(p, k) != 0.0 {
                                failures.push(format!(
                                    "{kernel:?} {i} at {relative:e}: f({t}) = {v}, ∇f = {gradient}"
                                ));
                                break;
                            }
                        }
                    }
                }
            }
        }
    }
    assert!(left_out > 100, "only {left_out} lines left out");
    assert_no_failures(&failures, "left-out primitives not zero on their ray");
}

/// A camera ray's field takes a tile's blobs with the tile's own zero test (`TileBall`, its
/// margin computed once for the tile's farthest reach): on rays tangent to blobs' supports
/// ([`check_rays_tangent_at`]), the field answers point questions and jets as the program
/// does, bit for bit, for every kernel.
#[test]
fn tile_rays_tangent_to_blobs_are_answered_as_by_the_program() {
    let mut rng = SplitMix64::new(12);
    let mut failures = Vec::new();
    let mut nonzero_near_tangency = 0;
    for kernel in KERNELS {
        for _ in 0..12 {
            let mut g = group(kernel);
            add_primitive(&mut g, Kind::Point, &mut rng);
            let compiled = compile(&scene(vec![g], None));
            let program = &compiled.program;
            let Primitive::Point(blob) = program.primitives()[0] else {
                panic!("a point blob was added");
            };
            let radius = blob.support_radius(program.kernel_of(0));
            let normal = DVec3::from(rng.direction());
            let (found, nonzero) = check_rays_tangent_at(
                program,
                (blob.center + radius * normal, normal, radius),
                &mut rng,
            );
            failures.extend(found.into_iter().map(|f| format!("{kernel:?} {f}")));
            nonzero_near_tangency += nonzero;
        }
    }
    eprintln!("{nonzero_near_tangency} non-zero values just outside the supports");
    assert_no_failures(&failures, "tile rays tangent to blobs");
}

/// A camera ray's field takes a tile's SCALIS segments with the tile's own tests (the support
/// sphere-cone seen from the tile's origin, `ConeFromOrigin`, and the cone grown by the zero
/// test's margin for the tile's farthest reach): on rays tangent to segments' supports at the
/// lateral surface and at the poles of the end balls ([`check_rays_tangent_at`]), the field
/// answers point questions and jets as the program does, bit for bit, for every kernel.
#[test]
fn tile_rays_tangent_to_scalis_supports_are_answered_as_by_the_program() {
    let mut rng = SplitMix64::new(13);
    let mut failures = Vec::new();
    let mut nonzero_near_tangency = 0;
    for kernel in KERNELS {
        for _ in 0..12 {
            let mut g = group(kernel);
            add_primitive(&mut g, Kind::ScalisSegment, &mut rng);
            let compiled = compile(&scene(vec![g], None));
            let program = &compiled.program;
            let Primitive::Scalis(segment) = program.primitives()[0] else {
                panic!("a SCALIS segment was added");
            };
            let cone = segment.support(program.kernel_of(0));
            // Where the surface touches the ball at `s`: the outward normal leans back along
            // the axis by the cone's slope; the poles' normals are the axis itself.
            let (u, v) = cone.axis.any_orthonormal_pair();
            let angle = rng.range(0.0, std::f64::consts::TAU);
            let radial = u * angle.cos() + v * angle.sin();
            let s = rng.range(0.1, 0.9) * cone.length;
            let lean = cone.slope;
            let lateral = (1.0 - lean * lean).sqrt() * radial - lean * cone.axis;
            let contacts = [
                (
                    cone.start + s * cone.axis,
                    cone.radius + cone.slope * s,
                    lateral,
                ),
                (cone.start, cone.radius, -cone.axis),
                (cone.end(), cone.end_radius(), cone.axis),
            ];
            for (centre, radius, normal) in contacts {
                let (found, nonzero) = check_rays_tangent_at(
                    program,
                    (centre + radius * normal, normal, radius),
                    &mut rng,
                );
                failures.extend(found.into_iter().map(|f| format!("{kernel:?} {f}")));
                nonzero_near_tangency += nonzero;
            }
        }
    }
    eprintln!("{nonzero_near_tangency} non-zero values just outside the supports");
    assert_no_failures(&failures, "tile rays tangent to SCALIS supports");
}

/// Rays tangent to a support at `touch` (outward `normal`, local support radius `radius`),
/// offset outward and inward by 10⁻¹⁵ to 10⁻² of it, each the only ray of a tile about it (a
/// few 10⁻⁷ radians wide): the tile field's point values and gradients, sampled uniformly and
/// ever closer around the point of tangency, and its jets there, must be the program's bit for
/// bit. Returns the differences and how many values just outside the support were not zero.
fn check_rays_tangent_at(
    program: &FieldProgram,
    (touch, normal, radius): (DVec3, DVec3, f64),
    rng: &mut SplitMix64,
) -> (Vec<String>, usize) {
    let (mut failures, mut nonzero) = (Vec::new(), 0);
    let (u, v) = normal.any_orthonormal_pair();
    let angle = rng.range(0.0, std::f64::consts::TAU);
    let direction = u * angle.cos() + v * angle.sin();
    let jet_bits = |j: Jet| [j.value, j.d1, j.d2].map(|i| (i.lo.to_bits(), i.hi.to_bits()));
    let bits = |(v, g): (f64, DVec3)| (v.to_bits(), g.to_array().map(f64::to_bits));
    for relative in [
        -1e-2, -1e-9, -1e-15, 1e-15, 1e-13, 1e-11, 1e-9, 1e-7, 1e-5, 1e-2,
    ] {
        let reach = 4.0 * radius * rng.range(1.0, 20.0);
        let origin = touch + relative * radius * normal - reach * direction;
        let ray = Ray::new(origin, direction);
        let span = Interval::new(0.0, 2.0 * reach);
        let (a, b) = ray.direction.any_orthonormal_pair();
        let corners = [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]
            .map(|(x, y)| ray.direction + 3e-7 * (x * a + y * b));
        let tile = TileCandidates::gather(program, origin, corners, span);
        let field = RayField::from_tile(program, &ray, span, &tile);
        for sample in 0..300 {
            let closeness = 10f64.powi(-(sample % 15));
            let t = if sample < 60 {
                rng.range(span.lo, span.hi)
            } else {
                reach + radius * closeness * rng.range(-1.0, 1.0)
            };
            let (got, want) = (field.value_gradient(t), program.value_gradient(ray.at(t)));
            if bits(got) != bits(want) {
                failures.push(format!("at {relative:e}, t = {t}: {got:?} vs {want:?}"));
                break;
            }
            nonzero += usize::from(relative > 0.0 && want.0 != 0.0);
            let around = Interval::new(t, t + radius * closeness);
            let (got, want) = (field.jet(around), program.ray_jet(&ray, around));
            if jet_bits(got) != jet_bits(want) {
                failures.push(format!(
                    "at {relative:e}, jet on {around:?}: {got:?} vs {want:?}"
                ));
                break;
            }
        }
    }
    (failures, nonzero)
}
