//! Random scenes of one primitive type and kernel for the accuracy and bound tests.
#![expect(dead_code, reason = "each test binary uses a part of these helpers")]

use skeletrace_core::field::kernel::KernelProfile;
use skeletrace_core::model::kernel::Kernel;
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::{
    Blend, Blob, Camera, Group, Hrbf, HrbfPoint, Material, Scene, Shape, Skeleton, SkeletonField,
    Vertex,
};

/// Primitive types exercised by the tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Point,
    DistanceSegment,
    ScalisSegment,
    Plane,
    Box,
    RoundedBox,
    Torus,
    Cylinder,
    Hrbf,
}

pub const KINDS: [Kind; 9] = [
    Kind::Point,
    Kind::DistanceSegment,
    Kind::ScalisSegment,
    Kind::Plane,
    Kind::Box,
    Kind::RoundedBox,
    Kind::Torus,
    Kind::Cylinder,
    Kind::Hrbf,
];

pub const KERNELS: [Kernel; 5] = [
    Kernel::CompactPolynomial {
        degree: 6,
        scale: 2.0,
    },
    Kernel::CompactPolynomial {
        degree: 4,
        scale: 3.0,
    },
    Kernel::CompactPolynomial {
        degree: 2,
        scale: 1.5,
    },
    Kernel::Cauchy {
        degree: 3,
        scale: 1.0,
    },
    Kernel::Gaussian { scale: 1.0 },
];

pub fn point(rng: &mut SplitMix64, scale: f64) -> [f64; 3] {
    [
        rng.range(-scale, scale),
        rng.range(-scale, scale),
        rng.range(-scale, scale),
    ]
}

/// A segment whose radius ratio goes up to 10 within the kernel's slope limit.
pub fn segment(rng: &mut SplitMix64, kernel: Kernel) -> [Vertex; 2] {
    let support = KernelProfile::new(kernel).support_radius();
    let r0 = rng.range(0.05, 0.5);
    let ratio = (10.0_f64).powf(rng.unit());
    let r1 = r0 * ratio;
    let min_length = (r1 - r0) * support * 1.05;
    let length = min_length.max(0.2) * rng.range(1.0, 3.0);
    let a = point(rng, 0.5);
    let d = rng.direction();
    let b = [
        a[0] + length * d[0],
        a[1] + length * d[1],
        a[2] + length * d[2],
    ];
    let (ra, rb) = if rng.unit() < 0.5 { (r0, r1) } else { (r1, r0) };
    [
        Vertex {
            position: a,
            radius: ra,
        },
        Vertex {
            position: b,
            radius: rb,
        },
    ]
}

pub fn group(kernel: Kernel) -> Group {
    Group {
        name: String::new(),
        kernel,
        material: Material::default(),
        skeletons: Vec::new(),
        blobs: Vec::new(),
        shapes: Vec::new(),
        hrbfs: Vec::new(),
        transform: skeletrace_core::model::scene::Transform::IDENTITY,
        repeat: None,
    }
}

/// Adds one random primitive of `kind` to `g`.
pub fn add_primitive(g: &mut Group, kind: Kind, rng: &mut SplitMix64) {
    let kernel = g.kernel;
    let radius = rng.range(0.1, 0.6);
    let center = point(rng, 0.5);
    let rotation = [
        rng.range(-180.0, 180.0),
        rng.range(-180.0, 180.0),
        rng.range(-180.0, 180.0),
    ];
    let half = [
        rng.range(0.1, 1.0),
        rng.range(0.1, 1.0),
        rng.range(0.1, 1.0),
    ];
    match kind {
        Kind::Point => g.blobs.push(Blob { center, radius }),
        Kind::DistanceSegment | Kind::ScalisSegment => g.skeletons.push(Skeleton {
            name: String::new(),
            field: if kind == Kind::ScalisSegment {
                SkeletonField::Scalis
            } else {
                SkeletonField::Distance
            },
            end_correctors: false,
            vertices: segment(rng, kernel).to_vec(),
            edges: vec![[0, 1]],
        }),
        Kind::Plane => g.shapes.push(Shape::Plane {
            normal: rng.direction(),
            offset: rng.range(-0.5, 0.5),
            radius,
        }),
        Kind::Box => g.shapes.push(Shape::Box {
            center,
            half_extents: half,
            rotation,
            radius,
        }),
        Kind::RoundedBox => g.shapes.push(Shape::RoundedBox {
            center,
            half_extents: half,
            rounding: rng.range(0.0, 1.0) * half.iter().copied().fold(f64::INFINITY, f64::min),
            rotation,
            radius,
        }),
        Kind::Torus => g.shapes.push(Shape::Torus {
            center,
            axis: rng.direction(),
            major: rng.range(0.4, 1.2),
            minor: rng.range(0.05, 0.4),
            radius,
        }),
        Kind::Hrbf => g.hrbfs.push(random_hrbf(rng)),
        Kind::Cylinder => g.shapes.push(Shape::Cylinder {
            center,
            axis: rng.direction(),
            cylinder_radius: rng.range(0.1, 0.6),
            half_height: rng.range(0.1, 1.0),
            radius,
        }),
    }
}

/// 4–12 points on a random ellipsoid around a random centre, with the ellipsoid's normals
/// perturbed.
pub fn random_hrbf(rng: &mut SplitMix64) -> Hrbf {
    let center = point(rng, 0.4);
    let axes = [
        rng.range(0.2, 0.8),
        rng.range(0.2, 0.8),
        rng.range(0.2, 0.8),
    ];
    let n = 6 + rng.below(10);
    let points = (0..n)
        .map(|_| {
            let d = rng.direction();
            let position = [
                center[0] + axes[0] * d[0],
                center[1] + axes[1] * d[1],
                center[2] + axes[2] * d[2],
            ];
            let jitter = rng.direction();
            let normal = [
                d[0] / axes[0] + 0.1 * jitter[0],
                d[1] / axes[1] + 0.1 * jitter[1],
                d[2] / axes[2] + 0.1 * jitter[2],
            ];
            HrbfPoint { position, normal }
        })
        .collect();
    Hrbf { points }
}

pub fn scene(groups: Vec<Group>, blend: Option<Blend>) -> Scene {
    Scene {
        version: 1,
        isovalue: 1.0,
        groups,
        blend,
        camera: Camera::default(),
        lights: Vec::new(),
    }
}

/// The asset `assets/scenes/{name}.ron`, loaded.
pub fn asset(name: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../assets/scenes")
        .join(format!("{name}.ron"));
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The `.ron` files of `assets/scenes/`, sorted.
pub fn assets() -> Vec<std::path::PathBuf> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    files.retain(|p| p.extension().is_some_and(|e| e == "ron"));
    files.sort();
    files
}

/// Central-difference gradient of `program`'s field at `p` with step `h`.
pub fn numeric_gradient(
    program: &skeletrace_core::FieldProgram,
    p: glam::DVec3,
    h: f64,
) -> glam::DVec3 {
    use glam::DVec3;
    DVec3::new(
        program.value(p + DVec3::X * h) - program.value(p - DVec3::X * h),
        program.value(p + DVec3::Y * h) - program.value(p - DVec3::Y * h),
        program.value(p + DVec3::Z * h) - program.value(p - DVec3::Z * h),
    ) / (2.0 * h)
}

/// One instance of every blend operator over two operands `a` and `b` (Ricci at several
/// exponents, below and above 2 where its curvature bound changes form).
pub fn every_operator(a: Blend, b: Blend) -> Vec<Blend> {
    let two = vec![a.clone(), b.clone()];
    let mut ops = vec![
        Blend::Sum(two.clone()),
        Blend::Max(two.clone()),
        Blend::Min(two.clone()),
        Blend::Difference(Box::new(a), Box::new(b)),
    ];
    for p in [1.0, 1.5, 2.0, 4.0] {
        ops.push(Blend::Ricci { p, of: two.clone() });
    }
    ops.push(Blend::SmoothUnion {
        width: 0.3,
        of: two.clone(),
    });
    ops.push(Blend::SmoothUnion {
        width: 2.0,
        of: two.clone(),
    });
    ops.push(Blend::SmoothIntersection {
        width: 0.5,
        of: two,
    });
    ops
}

/// A random blend tree of depth at most `depth` over groups `0..groups`: every operator, 1–3
/// operands each, leaves drawn with repetition. The last `groups / 2` groups appear only as the
/// subtracted side of a difference: a group on both sides, as in `Min([X, Difference(Y, X)])`,
/// makes `min(f, 2c − f)`, which touches `c` on the whole surface of `X` without crossing it, a
/// degenerate zero-thickness shell on which "first crossing" has no answer.
pub fn random_blend(rng: &mut SplitMix64, depth: usize, groups: u32) -> Blend {
    let all: Vec<u32> = (0..groups).collect();
    let (positive, subtracted) = all.split_at((groups - groups / 2) as usize);
    random_subtree(rng, depth, positive, subtracted)
}

fn random_subtree(rng: &mut SplitMix64, depth: usize, groups: &[u32], subtracted: &[u32]) -> Blend {
    if depth == 0 || rng.below(4) == 0 {
        return Blend::Group(groups[rng.below(groups.len())]);
    }
    let operator = rng.below(7);
    if operator == 3 && !subtracted.is_empty() {
        return Blend::Difference(
            Box::new(random_subtree(rng, depth - 1, groups, subtracted)),
            Box::new(random_subtree(rng, depth - 1, subtracted, &[])),
        );
    }
    let (p, width) = (
        [1.0, 1.5, 2.0, 3.0, 4.0, 8.0][rng.below(6)],
        rng.range(0.1, 1.5),
    );
    let n = 1 + rng.below(3);
    let of: Vec<Blend> = (0..n)
        .map(|_| random_subtree(rng, depth - 1, groups, subtracted))
        .collect();
    match operator {
        0 | 3 => Blend::Sum(of),
        1 => Blend::Max(of),
        2 => Blend::Min(of),
        4 => Blend::Ricci { p, of },
        5 => Blend::SmoothUnion { width, of },
        _ => Blend::SmoothIntersection { width, of },
    }
}

/// `n` groups of 1–3 random primitives each, every primitive type possible (HRBF sets alone in
/// their group, as the scene format requires), kernels drawn from [`KERNELS`].
pub fn random_groups(rng: &mut SplitMix64, n: usize) -> Vec<Group> {
    (0..n)
        .map(|_| {
            let mut g = group(KERNELS[rng.below(KERNELS.len())]);
            let kind = KINDS[rng.below(KINDS.len())];
            if kind == Kind::Hrbf {
                add_primitive(&mut g, kind, rng);
            } else {
                for _ in 0..1 + rng.below(3) {
                    let other = KINDS[rng.below(KINDS.len() - 1)];
                    add_primitive(&mut g, other, rng);
                }
            }
            g
        })
        .collect()
}

/// A scene of 2–5 random groups ([`random_groups`]) under a random blend tree of depth at most 4
/// ([`random_blend`]).
pub fn random_nested_scene(rng: &mut SplitMix64) -> Scene {
    let n = 2 + rng.below(4);
    let groups = random_groups(rng, n);
    let blend = random_blend(rng, 4, n as u32);
    scene(groups, Some(blend))
}

/// Panics with the count and the first of `failures` (`what` names them) unless there are none.
pub fn assert_no_failures(failures: &[String], what: &str) {
    assert!(
        failures.is_empty(),
        "{} {what}, first: {}",
        failures.len(),
        failures[0]
    );
}

/// A ray through the centre of a random primitive's support box from a random direction,
/// starting one support-box diagonal before it, and its span (two diagonals).
pub fn aimed_ray(
    program: &skeletrace_core::FieldProgram,
    rng: &mut SplitMix64,
) -> (skeletrace_core::Ray, skeletrace_core::Interval) {
    let bounds = program.support_bounds();
    let diagonal = bounds.diagonal();
    let i = rng.below(program.primitives().len());
    let target = program.primitives()[i]
        .support_aabb(program.kernel_of(i as u32))
        .map_or(bounds.center(), |b| b.center());
    let dir = glam::DVec3::from_array(rng.direction());
    (
        skeletrace_core::Ray::new(target - diagonal * dir, dir),
        skeletrace_core::Interval::new(0.0, 2.0 * diagonal),
    )
}
