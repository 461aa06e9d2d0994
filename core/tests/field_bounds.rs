//! Every ray bound of the field engine holds on random samples: value, first derivative and
//! the second-derivative (Taylor remainder) enclosures of `FieldProgram::ray_jet`, for every
//! primitive type and kernel, and composed through every blend operator.

mod common;

use common::{
    KERNELS, KINDS, Kind, add_primitive, assert_no_failures, every_operator, group, random_groups,
    random_nested_scene, scene,
};
use glam::DVec3;
use rayon::prelude::*;
use skeletrace_core::bounds::affine::field_form;
use skeletrace_core::bounds::bottom_up::{Degree, field_inclusion};
use skeletrace_core::field::primitives::Primitive;
use skeletrace_core::field::ray_field::RayField;
use skeletrace_core::model::kernel::Kernel;
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::{Blend, Scene};
use skeletrace_core::{FieldProgram, Interval, Ray};

const SAMPLES_PER_COMBINATION: usize = 100_000;

/// A random ray aimed near the origin and a random interval on it.
fn random_query(rng: &mut SplitMix64) -> (Ray, Interval) {
    let target = DVec3::from_array(common::point(rng, 0.6));
    let dir = DVec3::from_array(rng.direction());
    let distance = 4.0;
    let ray = Ray::new(target - distance * dir, dir);
    let width = 10f64.powf(rng.range(-3.0, 0.6));
    let t0 = distance + rng.range(-1.2, 1.2) - 0.5 * width;
    (ray, Interval::new(t0, t0 + width))
}

/// The query interval as the methods see it: where the field may jump (an HRBF set's box, see
/// `FieldProgram::ray_support_unions`), spans stay inside one marching part, so the span is
/// cut at the first such boundary (and opened by 10⁻⁹ there).
fn continuous_span(program: &FieldProgram, ray: &Ray, span: Interval) -> Interval {
    if !program
        .primitives()
        .iter()
        .any(|p| matches!(p, Primitive::Hrbf(_)))
    {
        return span;
    }
    // Open at a cut: the end point itself may round to either side of the box.
    let part = program
        .ray_support_unions(ray, span)
        .first()
        .copied()
        .unwrap_or(span);
    let inset = 1e-9 * (1.0 + part.hi.abs());
    Interval::new(part.lo + inset, (part.hi - inset).max(part.lo + inset))
}

/// Checks one query; returns a description of the first violation.
fn check(
    program: &FieldProgram,
    ray: &Ray,
    span: Interval,
    rng: &mut SplitMix64,
    tol: f64,
) -> Result<(), String> {
    let span = continuous_span(program, ray, span);
    let jet = program.ray_jet(ray, span);
    let mut ts = vec![span.lo, span.hi];
    ts.extend((0..4).map(|_| rng.range(span.lo, span.hi)));
    let samples: Vec<(f64, f64, f64)> = ts
        .iter()
        .map(|&t| {
            let (f, d) = program.along_ray(ray, t);
            (t, f, d)
        })
        .collect();
    let slack = |x: f64| tol * (1.0 + x.abs());
    for &(t, f, d) in &samples {
        if f < jet.value.lo - slack(f) || f > jet.value.hi + slack(f) {
            return Err(format!("value {f} at t = {t} outside {:?}", jet.value));
        }
        if d < jet.d1.lo - slack(d) || d > jet.d1.hi + slack(d) {
            return Err(format!("f′ = {d} at t = {t} outside {:?}", jet.d1));
        }
    }
    for &(ta, fa, da) in &samples {
        for &(tb, fb, _) in &samples {
            let h = tb - ta;
            if h == 0.0 {
                continue;
            }
            let remainder = fb - fa - da * h;
            let (lo, hi) = (0.5 * jet.d2.lo * h * h, 0.5 * jet.d2.hi * h * h);
            let s = tol * (1.0 + fa.abs() + fb.abs() + (da * h).abs());
            if remainder < lo - s || remainder > hi + s {
                return Err(format!(
                    "Taylor remainder {remainder} from t = {ta} to {tb} outside ½·{:?}·h²",
                    jet.d2
                ));
            }
        }
    }
    Ok(())
}

/// Samples `batches × 100` random queries (`random_query`), 100 on each scene `make(rng)`
/// builds, the batch's generator seeded with `seed(batch)`; panics with the first failure of
/// `check(program, ray, span, rng)`.
fn sample_scenes(
    label: &str,
    batches: usize,
    seed: impl Fn(u64) -> u64 + Sync,
    make: impl Fn(&mut SplitMix64) -> Scene + Sync,
    check: impl Fn(&FieldProgram, &Ray, Interval, &mut SplitMix64) -> Result<(), String> + Sync,
) {
    let failures: Vec<String> = (0..batches)
        .into_par_iter()
        .flat_map_iter(|batch| {
            let mut rng = SplitMix64::new(seed(batch as u64));
            let scene = make(&mut rng);
            let program = FieldProgram::new(&scene);
            let blend = scene.blend;
            let check = &check;
            (0..100).filter_map(move |_| {
                let (ray, span) = random_query(&mut rng);
                check(&program, &ray, span, &mut rng)
                    .err()
                    .map(|e| format!("{blend:?} ray {ray:?} span {span:?}: {e}"))
            })
        })
        .collect();
    assert_no_failures(&failures, &format!("{label}: violations"));
}

/// The ray-jet bounds of one query ([`check`]) at the tests' tolerance.
fn check_jets(
    program: &FieldProgram,
    ray: &Ray,
    span: Interval,
    rng: &mut SplitMix64,
) -> Result<(), String> {
    check(program, ray, span, rng, 1e-8)
}

fn check_combination(kind: Kind, kernel: Kernel) {
    sample_scenes(
        &format!("{kind:?} {kernel:?}"),
        SAMPLES_PER_COMBINATION / 100,
        |batch| batch * 7919 + kind as u64 * 31,
        |rng| {
            let mut g = group(kernel);
            add_primitive(&mut g, kind, rng);
            scene(vec![g], None)
        },
        check_jets,
    );
}

macro_rules! bound_tests {
    ($($name:ident: $kind:expr;)*) => {$(
        #[test]
        fn $name() {
            for kernel in KERNELS {
                check_combination($kind, kernel);
            }
        }
    )*};
}

bound_tests! {
    point_blob_bounds_hold: Kind::Point;
    distance_segment_bounds_hold: Kind::DistanceSegment;
    scalis_segment_bounds_hold: Kind::ScalisSegment;
    plane_bounds_hold: Kind::Plane;
    box_bounds_hold: Kind::Box;
    rounded_box_bounds_hold: Kind::RoundedBox;
    torus_bounds_hold: Kind::Torus;
    cylinder_bounds_hold: Kind::Cylinder;
    hrbf_bounds_hold: Kind::Hrbf;
}

/// 100 000 queries per operator, over two random groups of every primitive type.
#[test]
fn bounds_hold_through_every_blend_operator() {
    for (i, blend) in every_operator(Blend::Group(0), Blend::Group(1))
        .into_iter()
        .enumerate()
    {
        sample_scenes(
            &format!("{blend:?}"),
            1000,
            |batch| i as u64 * 1_000_003 + batch,
            |rng| scene(random_groups(rng, 2), Some(blend.clone())),
            check_jets,
        );
    }
}

/// 100 000 queries on random blend trees of depth up to 4 over 2–5 random groups (a new tree
/// and new groups for every 100 queries).
#[test]
fn bounds_hold_through_random_nested_blend_trees() {
    sample_scenes(
        "nested trees",
        1000,
        |batch| 99 * 1_000_003 + batch,
        random_nested_scene,
        check_jets,
    );
}

#[test]
fn samples_exercise_finite_nontrivial_bounds() {
    for kind in KINDS {
        for kernel in KERNELS {
            let mut rng = SplitMix64::new(99);
            let (mut nonzero, mut finite_d1, mut finite_d2, mut total) = (0, 0, 0, 0);
            for _ in 0..50 {
                let mut g = group(kernel);
                add_primitive(&mut g, kind, &mut rng);
                let program = FieldProgram::new(&scene(vec![g], None));
                for _ in 0..20 {
                    let (ray, span) = random_query(&mut rng);
                    let jet = program.ray_jet(&ray, span);
                    total += 1;
                    if jet.value.hi > 0.0 {
                        nonzero += 1;
                        finite_d1 += usize::from(jet.d1.magnitude().is_finite());
                        finite_d2 += usize::from(jet.d2.lo.is_finite());
                    }
                }
            }
            eprintln!(
                "{kind:?} {kernel:?}: {nonzero}/{total} touch the support, finite f′ {finite_d1}, finite f″ lower {finite_d2}"
            );
            assert!(
                nonzero * 7 > total,
                "{kind:?} {kernel:?}: only {nonzero}/{total} queries touch the support"
            );
            assert!(
                finite_d1 * 10 > nonzero * 9,
                "{kind:?} {kernel:?}: f′ bounds unbounded too often"
            );
        }
    }
}

/// Checks the bottom-up forward inclusions (both degrees) and the affine form on one query.
fn check_bottom_up_and_affine(
    program: &FieldProgram,
    ray: &Ray,
    span: Interval,
    rng: &mut SplitMix64,
) -> Result<(), String> {
    let span = continuous_span(program, ray, span);
    let field = RayField::new(program, ray, span);
    let (f0, d0) = program.along_ray(ray, span.lo);
    for degree in [Degree::Linear, Degree::Quadratic] {
        let inc = field_inclusion(&field, (span.lo, f0, d0, span.width()), degree);
        if (inc.start - f0).abs() > 1e-9 * (1.0 + f0.abs()) {
            return Err(format!("{degree:?}: start {} ≠ f = {f0}", inc.start));
        }
        for _ in 0..6 {
            let s = rng.range(0.0, inc.length);
            let f = program.along_ray(ray, span.lo + s).0;
            let slack = 1e-9 * (1.0 + f.abs());
            if f < inc.lower_at(s) - slack || f > inc.upper_at(s) + slack {
                return Err(format!(
                    "{degree:?}: f = {f} at s = {s} outside [{}, {}] (h = {})",
                    inc.lower_at(s),
                    inc.upper_at(s),
                    inc.length
                ));
            }
        }
    }
    if let Some(form) = field_form(&field, span) {
        let range = form.range();
        for _ in 0..6 {
            let t = rng.range(span.lo, span.hi);
            let f = program.along_ray(ray, t).0;
            if !Interval::new(range.lo - 1e-9, range.hi + 1e-9).contains(f) {
                return Err(format!("affine: f = {f} at t = {t} outside {range:?}"));
            }
        }
    }
    Ok(())
}

/// The affine forms of HRBF sets alone (their own rule: the Chebyshev square root and one
/// product per term), sampled densely on spans inside and across the sets' boxes.
#[test]
fn hrbf_affine_forms_hold() {
    sample_scenes(
        "HRBF affine forms",
        100,
        |batch| batch * 104_729 + 3,
        |rng| {
            let mut g = group(Kernel::CompactPolynomial {
                degree: 6,
                scale: 2.0,
            });
            add_primitive(&mut g, Kind::Hrbf, rng);
            scene(vec![g], None)
        },
        |program, ray, span, _| {
            let span = continuous_span(program, ray, span);
            let Some(form) = field_form(&RayField::new(program, ray, span), span) else {
                return Ok(());
            };
            let range = form.range();
            (0..=16).try_for_each(|k| {
                let t = span.lo + span.width() * f64::from(k) / 16.0;
                let f = program.along_ray(ray, t).0;
                let slack = 1e-9 * (1.0 + f.abs());
                if f < range.lo - slack || f > range.hi + slack {
                    Err(format!("f = {f} at t = {t} outside {range:?}"))
                } else {
                    Ok(())
                }
            })
        },
    );
}

#[test]
fn bottom_up_inclusions_and_affine_forms_hold() {
    let operators: Vec<Option<Blend>> = std::iter::once(None)
        .chain(
            every_operator(Blend::Group(0), Blend::Group(1))
                .into_iter()
                .map(Some),
        )
        .collect();
    for kernel in KERNELS {
        for (i, blend) in operators.iter().enumerate() {
            sample_scenes(
                &format!("{kernel:?} {blend:?}"),
                100,
                |batch| batch + 7 * i as u64,
                |rng| {
                    let mut groups = vec![group(kernel), group(kernel)];
                    for g in &mut groups {
                        for _ in 0..4 {
                            // Mostly blobs (the bottom-up rule), some other primitives.
                            let kind = if rng.below(4) == 0 {
                                KINDS[rng.below(KINDS.len())]
                            } else {
                                Kind::Point
                            };
                            add_primitive(g, kind, rng);
                        }
                    }
                    scene(groups, blend.clone())
                },
                check_bottom_up_and_affine,
            );
        }
    }
}

/// The bottom-up inclusions and affine forms through random nested blend trees (depth ≤ 4).
#[test]
fn bottom_up_inclusions_and_affine_forms_hold_on_random_nested_trees() {
    sample_scenes(
        "nested trees",
        500,
        |batch| batch * 7_919 + 17,
        random_nested_scene,
        check_bottom_up_and_affine,
    );
}
