//! The shared test suite every root-finding method runs (`method_suite!`): analytic cases
//! (one blob, two blended blobs, grazing rays, rays starting inside, rays that miss), agreement
//! with the reference tracer on every asset (no missed crossing for the conservative methods),
//! no NaN, and step counts within the budget.

mod common;

use common::assets;
use glam::DVec3;
use rayon::prelude::*;
use skeletrace_core::field::kernel::Kernel;
use skeletrace_core::methods::{self, Method, MethodId, TraceMode, TraceSettings};
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::{
    Blob, Camera, Group, Material, Scene, Skeleton, SkeletonField, Vertex,
};
use skeletrace_core::{FieldProgram, Interval, Ray};

fn blobs(kernel: Kernel, centers: &[[f64; 3]], radius: f64) -> FieldProgram {
    FieldProgram::new(&blobs_scene(kernel, centers, radius))
}

fn blobs_scene(kernel: Kernel, centers: &[[f64; 3]], radius: f64) -> Scene {
    Scene {
        version: 1,
        isovalue: 1.0,
        groups: vec![Group {
            name: String::new(),
            kernel,
            material: Material::default(),
            skeletons: Vec::new(),
            blobs: centers
                .iter()
                .map(|&center| Blob { center, radius })
                .collect(),
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

/// SCALIS segments of radius `radius` through each centre, along y, long enough that the
/// rays of the analytic cases (all within |y| < 0.6) see an infinite cylinder: a cross-section
/// is the same circle as a blob's.
fn scalis_rods(centers: &[[f64; 3]], radius: f64) -> FieldProgram {
    let rods = centers
        .iter()
        .map(|&[x, y, z]| Skeleton {
            name: String::new(),
            field: SkeletonField::Scalis,
            end_correctors: true,
            vertices: [-5.0, 5.0]
                .map(|dy| Vertex {
                    position: [x, y + dy, z],
                    radius,
                })
                .to_vec(),
            edges: vec![[0, 1]],
        })
        .collect();
    let mut scene = blobs_scene(Kernel::default(), &[], radius);
    scene.groups[0].skeletons = rods;
    FieldProgram::new(&scene)
}

/// A program the method supports whose surface, seen by the test rays, is that of blobs of
/// `radius` at `centers`: compact blobs, Gaussian blobs (field inversion) or SCALIS rods
/// (the SCALIS-only methods).
fn fixture(method: &dyn Method, centers: &[[f64; 3]], radius: f64) -> FieldProgram {
    let compact = blobs(Kernel::default(), centers, radius);
    if method.supports(&compact).is_ok() {
        return compact;
    }
    let gaussian = blobs(Kernel::Gaussian { scale: 1.0 }, centers, radius);
    if method.supports(&gaussian).is_ok() {
        return gaussian;
    }
    scalis_rods(centers, radius)
}

fn check_analytic_cases(method: &dyn Method) {
    let program = fixture(method, &[[0.0; 3]], 1.0);
    assert!(method.supports(&program).is_ok());
    let settings = TraceSettings::for_program(&program);
    let tracer = method.prepare(&program, settings);
    // Field inversion oversteps by design (steps of 1.2·D, hit once inside).
    let tol = if method.is_conservative() { 1e-3 } else { 0.3 };
    let span = Interval::new(0.0, 20.0);
    // Straight at the blob: entry at 5 − 1 = 4.
    let hit = tracer.trace(
        &Ray::new(DVec3::new(0.0, 0.0, -5.0), DVec3::Z),
        span,
        TraceMode::Opaque,
    );
    let first = hit
        .first()
        .unwrap_or_else(|| panic!("{}: missed a head-on blob", method.name()));
    assert!(
        (first.t - 4.0).abs() < tol && first.entering,
        "{}: {first:?}",
        method.name()
    );
    assert!(hit.steps <= settings.max_steps);
    // A miss: passes at 1.5 radii.
    let miss = tracer.trace(
        &Ray::new(DVec3::new(1.5, 0.0, -5.0), DVec3::Z),
        span,
        TraceMode::Opaque,
    );
    assert!(
        miss.crossings.is_empty(),
        "{}: spurious hit {:?}",
        method.name(),
        miss.crossings
    );
    // Grazing: passes at 0.98 radii, crossing at 5 − √(1 − 0.98²).
    let graze = tracer.trace(
        &Ray::new(DVec3::new(0.98, 0.0, -5.0), DVec3::Z),
        span,
        TraceMode::Opaque,
    );
    let expected = 5.0 - (1.0_f64 - 0.98 * 0.98).sqrt();
    if method.is_conservative() {
        let g = graze
            .first()
            .unwrap_or_else(|| panic!("{}: missed a grazing ray", method.name()));
        assert!(
            (g.t - expected).abs() < tol,
            "{}: {g:?} vs {expected}",
            method.name()
        );
    }
    // Starting inside: the first crossing is the exit at 1.
    if method.name() != "field-inversion" {
        let inside = tracer.trace(&Ray::new(DVec3::ZERO, DVec3::X), span, TraceMode::Opaque);
        let exit = inside
            .first()
            .unwrap_or_else(|| panic!("{}: no exit from inside", method.name()));
        assert!(
            (exit.t - 1.0).abs() < tol && !exit.entering,
            "{}: {exit:?}",
            method.name()
        );
    }
}

fn check_two_blobs_and_transparency(method: &dyn Method) {
    let program = fixture(method, &[[-0.6, 0.0, 0.0], [0.6, 0.0, 0.0]], 0.5);
    let settings = TraceSettings::for_program(&program);
    let tracer = method.prepare(&program, settings);
    let reference = MethodId::Reference.method().prepare(&program, settings);
    let mut rng = SplitMix64::new(17);
    for _ in 0..300 {
        let dir = DVec3::from_array(rng.direction());
        let target = DVec3::new(
            rng.range(-1.2, 1.2),
            rng.range(-0.6, 0.6),
            rng.range(-0.6, 0.6),
        );
        let ray = Ray::new(target - 4.0 * dir, dir);
        let span = Interval::new(0.0, 8.0);
        let want = reference.trace(&ray, span, TraceMode::Transparent);
        let got = tracer.trace(&ray, span, TraceMode::Transparent);
        assert!(
            got.crossings.iter().all(|c| c.t.is_finite()),
            "{}: NaN",
            method.name()
        );
        assert!(got.steps <= settings.max_steps);
        if !method.is_conservative() {
            continue;
        }
        // Every reference crossing is matched, in order (grazing pairs closer than the
        // tolerance may merge).
        for w in &want.crossings {
            assert!(
                got.crossings
                    .iter()
                    .any(|g| (g.t - w.t).abs() < 1e-3 && g.entering == w.entering),
                "{}: reference crossing {w:?} not found in {:?} (ray {ray:?})",
                method.name(),
                got.crossings
            );
        }
        assert!(got.crossings.windows(2).all(|p| p[0].t < p[1].t));
    }
}

/// Rays aimed at random primitives of every asset; the reference is traced once per ray and
/// compared with every method. A conservative method that ends a ray within its step budget
/// must not have skipped the reference's first crossing.
#[test]
fn conservative_methods_never_skip_a_crossing_on_the_assets() {
    let all = methods::all();
    let failures: Vec<String> = assets()
        .par_iter()
        .flat_map_iter(|path| {
            let scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
            let program = FieldProgram::new(&scene);
            let settings = TraceSettings::for_program(&program);
            let tracers: Vec<_> = all
                .iter()
                .filter(|m| m.supports(&program).is_ok())
                .map(|m| (m.name(), m.is_conservative(), m.prepare(&program, settings)))
                .collect();
            let reference = MethodId::Reference.method().prepare(&program, settings);
            let bounds = program.support_bounds();
            let diagonal = bounds.diagonal();
            let mut rng = SplitMix64::new(23);
            let mut failures = Vec::new();
            for _ in 0..40 {
                let i = rng.below(program.primitives().len());
                let target = program.primitives()[i]
                    .support_aabb(program.kernel_of(i as u32))
                    .map_or(bounds.center(), |b| b.center());
                let dir = DVec3::from_array(rng.direction());
                let ray = Ray::new(target - diagonal * dir, dir);
                let span = Interval::new(0.0, 2.0 * diagonal);
                let want = reference.trace(&ray, span, TraceMode::Opaque).first();
                for (name, conservative, tracer) in &tracers {
                    let got = tracer.trace(&ray, span, TraceMode::Opaque);
                    if *name != "reference" && got.steps > settings.max_steps {
                        failures.push(format!("{name}: {} steps", got.steps));
                    }
                    if got.first().is_some_and(|g| !g.t.is_finite()) {
                        failures.push(format!("{name}: NaN on {}", path.display()));
                    }
                    let exhausted = got.steps >= settings.max_steps;
                    let skipped = match (want, got.first()) {
                        (Some(w), Some(g)) => g.t > w.t + 1e-4 * diagonal,
                        (Some(_), None) => !exhausted,
                        _ => false,
                    };
                    if *conservative && skipped {
                        failures.push(format!(
                            "{name} skipped the crossing at {:?} on {} (ray {ray:?}, got {:?})",
                            want,
                            path.display(),
                            got.first()
                        ));
                    }
                }
            }
            failures
        })
        .collect();
    assert!(
        failures.is_empty(),
        "{} failures, first: {}",
        failures.len(),
        failures[0]
    );
}

macro_rules! method_suite {
    ($($module:ident => $name:expr;)*) => {$(
        mod $module {
            use super::*;
            fn method() -> Box<dyn Method> {
                let id: MethodId = $name.parse().unwrap_or_else(|e| panic!("{e}"));
                assert_eq!(id.name(), $name);
                id.method()
            }
            #[test]
            fn analytic_cases() {
                check_analytic_cases(method().as_ref());
            }
            #[test]
            fn two_blobs_and_transparency() {
                check_two_blobs_and_transparency(method().as_ref());
            }
        }
    )*};
}

method_suite! {
    sphere => "sphere";
    sphere_enhanced => "sphere-enhanced";
    sphere_accelerated => "sphere-accelerated";
    segment => "segment";
    linear_taylor => "linear-taylor";
    quadratic_taylor => "quadratic-taylor";
    linear_mixed => "linear-mixed";
    quadratic_mixed => "quadratic-mixed";
    field_inversion => "field-inversion";
    reference => "reference";
    sphere_normalized => "sphere-normalized";
    bottom_up_linear => "bottom-up-linear";
    bottom_up_linear_bisection => "bottom-up-linear-bisection";
    bottom_up_quadratic => "bottom-up-quadratic";
    affine => "affine";
    scalis_quadratic => "scalis-quadratic";
    sherstyuk => "sherstyuk";
}

#[test]
fn global_lipschitz_bounds_sampled_gradients_on_every_asset() {
    for path in assets() {
        let program = FieldProgram::new(&Scene::load(&path).unwrap_or_else(|e| panic!("{e}")));
        let lipschitz = program.global_lipschitz();
        let b = program.support_bounds();
        let mut rng = SplitMix64::new(1);
        for _ in 0..5000 {
            let p = b.min + (b.max - b.min) * DVec3::new(rng.unit(), rng.unit(), rng.unit());
            let g = program.value_gradient(p).1.length();
            assert!(
                g <= lipschitz * (1.0 + 1e-9),
                "{}: |∇f| = {g} > L = {lipschitz}",
                path.display()
            );
        }
    }
}

#[test]
fn every_design_method_is_implemented_and_unknown_names_are_refused() {
    let design = [
        "sphere",
        "sphere-enhanced",
        "sphere-accelerated",
        "sphere-normalized",
        "segment",
        "linear-taylor",
        "quadratic-taylor",
        "bottom-up-linear",
        "bottom-up-linear-bisection",
        "bottom-up-quadratic",
        "linear-mixed",
        "quadratic-mixed",
        "affine",
        "field-inversion",
        "scalis-quadratic",
        "sherstyuk",
        "reference",
    ];
    let names: Vec<&str> = methods::all().iter().map(|m| m.name()).collect();
    assert_eq!(names.len(), design.len());
    assert_eq!(names, design, "MethodId::ALL follows DESIGN.md's table");
    for (id, name) in MethodId::ALL.into_iter().zip(design) {
        assert_eq!(name.parse::<MethodId>(), Ok(id));
        assert_eq!(
            id.method().id(),
            id,
            "{name}: the implementation reports its own id"
        );
        assert_eq!(id.is_conservative(), id.method().is_conservative());
    }
    assert!(
        "nonsense"
            .parse::<MethodId>()
            .err()
            .unwrap_or_default()
            .contains("unknown method")
    );
    assert_eq!(
        MethodId::parse_list("sphere, segment"),
        Ok(vec![MethodId::Sphere, MethodId::Segment])
    );
}
