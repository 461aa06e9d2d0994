//! A ray's gathered candidates answer every query bit for bit as the program's BVH does
//! (`core/src/field/ray_field.rs`): values and derivatives at points, jets, group jets and
//! values, Lipschitz bounds, supports and their unions, on every asset and on random scenes of
//! every primitive type and blend, for rays aimed at primitives and the `stats` protocol's
//! axis-aligned rays (whose zero direction components exercise the slab test's edge cases).
//! So the marches, their step counts and their depths are those of the BVH queries.

mod common;

use common::{KINDS, assert_no_failures, assets, every_operator, random_groups, scene};
use glam::DVec3;
use rayon::prelude::*;
use skeletrace_core::cpu::stats::protocol_rays;
use skeletrace_core::field::program::PrimitiveSlope;
use skeletrace_core::field::ray_field::RayField;
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::{Blend, Scene};
use skeletrace_core::{FieldProgram, Interval, Ray};

fn same_bits(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits()
}

/// Compares every query on `ray` over `span`; returns the first difference.
fn compare(
    program: &FieldProgram,
    ray: &Ray,
    span: Interval,
    rng: &mut SplitMix64,
) -> Option<String> {
    let field = RayField::new(program, ray, span);
    // Enough point questions that the ray's candidates get binned (`CELLS_AFTER`), so that both
    // the scan of every candidate and the bins are compared.
    for k in 0..48 {
        let t = rng.range(span.lo, span.hi);
        let (a, b) = (field.along(t), program.along_ray(ray, t));
        if !same_bits(a.0, b.0) || !same_bits(a.1, b.1) {
            return Some(format!("along({t}) after {k} questions: {a:?} vs {b:?}"));
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
    if field.support_unions(span) != program.ray_support_unions(ray, span) {
        return Some("support unions".to_owned());
    }
    None
}

/// Rays aimed at random primitives, then the protocol's rays.
fn check_program(program: &FieldProgram, label: &str, seed: u64) -> Vec<String> {
    let bounds = program.support_bounds();
    let diagonal = bounds.diagonal();
    let mut rng = SplitMix64::new(seed);
    let mut rays: Vec<(Ray, Interval)> = (0..60)
        .map(|_| {
            let i = rng.below(program.primitives().len());
            let target = program.primitives()[i]
                .support_aabb(program.kernel_of(i as u32))
                .map_or(bounds.center(), |b| b.center());
            let dir = DVec3::from_array(rng.direction());
            (
                Ray::new(target - diagonal * dir, dir),
                Interval::new(0.0, 2.0 * diagonal),
            )
        })
        .collect();
    rays.extend(protocol_rays(program, 60, seed));
    rays.iter()
        .filter_map(|(ray, span)| {
            compare(program, ray, *span, &mut rng).map(|e| format!("{label}: ray {ray:?}: {e}"))
        })
        .collect()
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
            let mut groups = random_groups(&mut rng, 2);
            // Many primitives of every kind, so that the BVH has depth.
            for g in &mut groups {
                if g.hrbfs.is_empty() {
                    for _ in 0..20 {
                        let kind = KINDS[rng.below(KINDS.len() - 1)];
                        common::add_primitive(g, kind, &mut rng);
                    }
                }
            }
            let blend = operators[job % operators.len()].clone();
            let program = FieldProgram::new(&scene(groups, Some(blend)));
            check_program(&program, &format!("scene {job}"), job as u64)
        })
        .collect();
    assert_no_failures(&failures, "differences");
}
