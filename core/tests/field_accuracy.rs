//! Accuracy of the field engine: SCALIS values against an independent adaptive quadrature,
//! gradients against central differences, and the BVH-accelerated queries against brute force.

mod common;

use common::{KERNELS, KINDS, add_primitive, group, scene};
use glam::DVec3;
use skeletrace_core::field::geometry::Ray;
use skeletrace_core::model::kernel::{CLIP_EPSILON, Kernel};
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::{Blend, Skeleton, SkeletonField, Vertex};
use skeletrace_core::{FieldProgram, Interval};

/// The kernel written from its definition (scalis eq. 2–3, MATH.md §1), independent of
/// `KernelProfile`: clipped at `CLIP_EPSILON` for the infinite-support kernels.
fn reference_kernel(kernel: Kernel, r: f64) -> f64 {
    let clip = |k: f64| ((k - CLIP_EPSILON) / (1.0 - CLIP_EPSILON)).max(0.0);
    match kernel {
        Kernel::CompactPolynomial { degree, scale } => {
            if r >= scale {
                0.0
            } else {
                (1.0 - (r / scale).powi(2)).powi(degree as i32 / 2)
            }
        }
        Kernel::Cauchy { degree, scale } => {
            clip((1.0 + (r / scale).powi(2)).powf(-f64::from(degree) / 2.0))
        }
        Kernel::Gaussian { scale } => clip((-(r / scale).powi(2)).exp()),
    }
}

/// Adaptive Gauss–Kronrod (7, 15) quadrature: panels are split until Gauss and Kronrod agree to
/// `tol` (absolute, per panel).
fn adaptive(f: &dyn Fn(f64) -> f64, a: f64, b: f64, tol: f64, depth: u32) -> f64 {
    const XK: [f64; 8] = [
        0.991_455_371_120_812_6,
        0.949_107_912_342_758_5,
        0.864_864_423_359_769_1,
        0.741_531_185_599_394_4,
        0.586_087_235_467_691_1,
        0.405_845_151_377_397_2,
        0.207_784_955_007_898_5,
        0.0,
    ];
    const WK: [f64; 8] = [
        0.022_935_322_010_529_22,
        0.063_092_092_629_978_55,
        0.104_790_010_322_250_2,
        0.140_653_259_715_525_9,
        0.169_004_726_639_267_9,
        0.190_350_578_064_785_4,
        0.204_432_940_075_298_9,
        0.209_482_141_084_727_8,
    ];
    const WG: [f64; 4] = [
        0.129_484_966_168_869_7,
        0.279_705_391_489_276_7,
        0.381_830_050_505_118_9,
        0.417_959_183_673_469_4,
    ];
    let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
    let mut kronrod = WK[7] * f(c);
    let mut gauss = WG[3] * f(c);
    for i in 0..7 {
        let (l, r) = (f(c - h * XK[i]), f(c + h * XK[i]));
        kronrod += WK[i] * (l + r);
        if i % 2 == 1 {
            gauss += WG[i / 2] * (l + r);
        }
    }
    let (kronrod, gauss) = (kronrod * h, gauss * h);
    if (kronrod - gauss).abs() <= tol || depth > 30 {
        kronrod
    } else {
        adaptive(f, a, c, tol, depth + 1) + adaptive(f, c, b, tol, depth + 1)
    }
}

/// SCALIS field of one segment by adaptive quadrature, normalised independently.
fn reference_scalis(kernel: Kernel, v: &[Vertex; 2], p: DVec3) -> f64 {
    let (a, b) = (
        DVec3::from_array(v[0].position),
        DVec3::from_array(v[1].position),
    );
    let length = (b - a).length();
    let integrand = |s: f64| {
        let q = a + (b - a) * (s / length);
        let tau = v[0].radius + (v[1].radius - v[0].radius) * s / length;
        reference_kernel(kernel, (p - q).length() / tau) / tau
    };
    // Normalisation: the field of an infinite unit line at unit distance equals 1.
    let line = |u: f64| reference_kernel(kernel, (1.0 + u * u).sqrt());
    // A compact kernel's line integral ends where the kernel does, at a kink for degree 2.
    let reach = match kernel {
        Kernel::CompactPolynomial { scale, .. } => (scale * scale - 1.0).sqrt(),
        _ => 60.0,
    };
    let norm = 1.0 / adaptive(&line, -reach, reach, 1e-15, 0);
    // Where a compact kernel's support ends along the segment, the integrand has a kink (of
    // its first derivative for degree 2): integrate between those points, the roots of
    // `|p − q(s)|² = σ²τ(s)²` (a quadratic in `s`, solved naively).
    let (mut from, mut to) = (0.0_f64, length);
    if let Kernel::CompactPolynomial { scale, .. } = kernel {
        let (axis, w) = ((b - a) / length, p - a);
        let slope = (v[1].radius - v[0].radius) / length;
        let s2 = scale * scale;
        let qa = 1.0 - s2 * slope * slope;
        let qb = -2.0 * (axis.dot(w) + s2 * v[0].radius * slope);
        let qc = w.length_squared() - s2 * v[0].radius * v[0].radius;
        let disc = qb * qb - 4.0 * qa * qc;
        if disc <= 0.0 {
            return 0.0;
        }
        from = from.max((-qb - disc.sqrt()) / (2.0 * qa));
        to = to.min((-qb + disc.sqrt()) / (2.0 * qa));
        if from >= to {
            return 0.0;
        }
    }
    // Start from many panels so that narrow support crossings are not missed.
    let panels = 256;
    norm * (0..panels)
        .map(|i| {
            let (s0, s1) = (
                from + (to - from) * f64::from(i) / f64::from(panels),
                from + (to - from) * f64::from(i + 1) / f64::from(panels),
            );
            adaptive(&integrand, s0, s1, 1e-15, 0)
        })
        .sum::<f64>()
}

/// The program of one SCALIS segment without end correctors.
fn one_segment(kernel: Kernel, seg: &[Vertex; 2]) -> FieldProgram {
    let mut g = group(kernel);
    g.skeletons.push(Skeleton {
        name: String::new(),
        field: SkeletonField::Scalis,
        end_correctors: false,
        vertices: seg.to_vec(),
        edges: vec![[0, 1]],
    });
    FieldProgram::new(&scene(vec![g], None))
}

#[test]
fn scalis_values_match_adaptive_quadrature_to_one_part_per_million() {
    let mut rng = SplitMix64::new(2024);
    let mut worst = 0.0_f64;
    let mut checked = 0;
    for kernel in KERNELS {
        for _ in 0..150 {
            let seg = common::segment(&mut rng, kernel);
            let program = one_segment(kernel, &seg);
            for _ in 0..10 {
                let (a, b) = (
                    DVec3::from_array(seg[0].position),
                    DVec3::from_array(seg[1].position),
                );
                let along = a.lerp(b, rng.range(-0.3, 1.3));
                let offset = DVec3::from_array(rng.direction())
                    * rng.range(0.0, 2.0)
                    * seg[0].radius.max(seg[1].radius);
                let p = along + offset;
                let reference = reference_scalis(kernel, &seg, p);
                let got = program.value(p);
                if reference < 1e-4 {
                    assert!(
                        (got - reference).abs() < 1e-10,
                        "{kernel:?} at {p}: {got} vs {reference}"
                    );
                    continue;
                }
                let rel = (got - reference).abs() / reference;
                worst = worst.max(rel);
                checked += 1;
                assert!(
                    rel < 1e-6,
                    "{kernel:?} segment {seg:?} at {p}: {got} vs {reference} (relative {rel:e})"
                );
            }
        }
    }
    eprintln!("SCALIS: {checked} values, worst relative error {worst:e}");
    assert!(checked > 3000);
}

/// The compact kernels' node counts (`scalis.rs` `COMPACT_NODES`) keep every value converged:
/// within 10⁻¹² of the adaptive reference (in units of the isovalue, which the normalisation
/// sets to 1), for every power the table covers, scales from 1.3 to 3.5, radius ratios from
/// barely varying to tenfold.
#[test]
fn compact_scalis_values_are_converged_to_one_part_in_a_trillion() {
    let mut rng = SplitMix64::new(4711);
    for degree in [2, 4, 6, 8] {
        for scale in [1.3, 2.0, 3.5] {
            let kernel = Kernel::CompactPolynomial { degree, scale };
            let mut worst = 0.0_f64;
            for _ in 0..40 {
                let mut seg = common::segment(&mut rng, kernel);
                if rng.unit() < 0.5 {
                    // Nearly constant radii: the arc-length rules.
                    seg[1].radius = seg[0].radius * (1.0 + 10.0_f64.powf(rng.range(-5.0, -0.7)));
                }
                let program = one_segment(kernel, &seg);
                let (a, b) = (
                    DVec3::from_array(seg[0].position),
                    DVec3::from_array(seg[1].position),
                );
                for _ in 0..8 {
                    let p = a.lerp(b, rng.range(-0.3, 1.3))
                        + DVec3::from_array(rng.direction())
                            * rng.range(0.0, scale)
                            * seg[0].radius.max(seg[1].radius);
                    let (got, reference) = (program.value(p), reference_scalis(kernel, &seg, p));
                    let error = (got - reference).abs();
                    worst = worst.max(error);
                    assert!(
                        error < 1e-12,
                        "{kernel:?} segment {seg:?} at {p}: {got:e} against {reference:e}"
                    );
                }
            }
            eprintln!("{kernel:?}: worst error {worst:e}");
        }
    }
}

#[test]
fn gradients_match_central_differences() {
    let mut rng = SplitMix64::new(77);
    for kind in KINDS {
        for kernel in KERNELS {
            let mut g = group(kernel);
            for _ in 0..3 {
                add_primitive(&mut g, kind, &mut rng);
            }
            let program = FieldProgram::new(&scene(vec![g], None));
            let mut compared = 0;
            while compared < 200 {
                let p = DVec3::from_array(common::point(&mut rng, 1.5));
                let (f, grad) = program.value_gradient(p);
                if f == 0.0 {
                    continue;
                }
                compared += 1;
                let numeric = common::numeric_gradient(&program, p, 1e-6);
                let error = (numeric - grad).length();
                // Kinks (box edges, clipped supports) make differences one-sided within h.
                let tol = 1e-5 * (1.0 + grad.length());
                if error > tol {
                    let near_kink = (0..3).any(|axis| {
                        let e = DVec3::AXES[axis] * 1e-4;
                        let g1 = program.value_gradient(p + e).1;
                        let g0 = program.value_gradient(p - e).1;
                        (g1 - g0).length() > 1e-2 * (1.0 + grad.length())
                    });
                    assert!(
                        near_kink,
                        "{kind:?} {kernel:?} at {p}: analytic {grad}, numeric {numeric}"
                    );
                }
            }
        }
    }
}

#[test]
fn bvh_queries_agree_with_brute_force() {
    let mut rng = SplitMix64::new(5);
    let mut groups = vec![group(KERNELS[0]), group(KERNELS[4])];
    for g in &mut groups {
        for _ in 0..60 {
            let kind = KINDS[rng.below(KINDS.len())];
            add_primitive(g, kind, &mut rng);
        }
    }
    let program = FieldProgram::new(&scene(
        groups,
        Some(Blend::Max(vec![Blend::Group(0), Blend::Group(1)])),
    ));
    for _ in 0..2000 {
        let p = DVec3::from_array(common::point(&mut rng, 2.0));
        // Group membership: the first group's primitives come first.
        let split = (0..program.primitives().len())
            .position(|i| program.kernel_of(i as u32) != program.kernel_of(0))
            .unwrap_or(program.primitives().len());
        let (mut a, mut b, mut magnitude) = (0.0, 0.0, 0.0);
        for (i, prim) in program.primitives().iter().enumerate() {
            let v = prim.value(p, program.kernel_of(i as u32));
            magnitude += v.abs();
            if i < split { a += v } else { b += v }
        }
        let expected = f64::max(a, b);
        // HRBF terms are large and cancel: rounding depends on the order of the sum.
        assert!((program.value(p) - expected).abs() < 1e-12 * (1.0 + magnitude));
    }
    for _ in 0..500 {
        let origin = DVec3::from_array(common::point(&mut rng, 4.0));
        let ray = Ray::new(origin, DVec3::from_array(rng.direction()));
        let span = Interval::new(0.0, 8.0);
        let listed: Vec<u32> = program
            .ray_supports(&ray, span)
            .iter()
            .map(|s| s.primitive)
            .collect();
        let mut brute: Vec<u32> = (0..program.primitives().len() as u32)
            .filter(|&i| {
                program.primitives()[i as usize]
                    .support_interval(&ray, program.kernel_of(i))
                    .and_then(|s| s.intersect(span))
                    .is_some()
            })
            .collect();
        let mut sorted = listed.clone();
        sorted.sort_unstable();
        brute.sort_unstable();
        assert_eq!(sorted, brute);
        let spans = program.ray_supports(&ray, span);
        assert!(
            spans.windows(2).all(|w| w[0].span.lo <= w[1].span.lo),
            "sorted by entry"
        );
    }
}

#[test]
fn isolated_primitives_put_the_surface_at_the_prescribed_radius() {
    for kernel in KERNELS {
        let mut g = group(kernel);
        g.blobs.push(skeletrace_core::model::scene::Blob {
            center: [0.0; 3],
            radius: 0.7,
        });
        let program = FieldProgram::new(&scene(vec![g], None));
        assert!((program.value(DVec3::new(0.7, 0.0, 0.0)) - 1.0).abs() < 1e-12);
        // A long SCALIS segment: the surface sits at the radius around its middle.
        let mut g = group(kernel);
        g.skeletons.push(Skeleton {
            name: String::new(),
            field: SkeletonField::Scalis,
            end_correctors: true,
            vertices: vec![
                Vertex {
                    position: [-40.0, 0.0, 0.0],
                    radius: 0.5,
                },
                Vertex {
                    position: [40.0, 0.0, 0.0],
                    radius: 0.5,
                },
            ],
            edges: vec![[0, 1]],
        });
        let program = FieldProgram::new(&scene(vec![g], None));
        let mid = program.value(DVec3::new(0.0, 0.5, 0.0));
        assert!((mid - 1.0).abs() < 1e-6, "{kernel:?}: {mid}");
        // End-point corrector: the surface passes at one radius past the free end.
        let tip = program.value(DVec3::new(40.5, 0.0, 0.0));
        assert!(
            (tip - 1.0).abs() < 1e-6,
            "{kernel:?}: field {tip} one radius past the end"
        );
    }
}
