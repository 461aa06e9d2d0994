//! Reference scenes: on every asset, the composed field (BVH, blend tree, every primitive type
//! present) is finite, and its ray bounds hold on random rays through the scene.

use std::path::Path;

use glam::DVec3;
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::{FieldProgram, Interval, Ray, Scene};

#[test]
fn ray_bounds_hold_on_every_asset() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{e}"))
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    files.sort();
    assert!(files.len() >= 8);
    for path in files {
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let program = FieldProgram::new(&scene);
        let bounds = program.support_bounds();
        let mut rng = SplitMix64::new(3);
        let (mut touched, mut checked) = (0, 0);
        for _ in 0..400 {
            // Aim at a random primitive so that thin skeletons are reached too.
            let i = rng.below(program.primitives().len());
            let target = program.primitives()[i]
                .support_aabb(program.kernel_of(i as u32))
                .map_or(bounds.center(), |b| b.center());
            let dir = DVec3::from_array(rng.direction());
            let reach = bounds.diagonal();
            let ray = Ray::new(target - dir * reach, dir);
            let width = reach * 10f64.powf(rng.range(-3.0, -0.5));
            let t0 = reach + rng.range(-0.05, 0.05) * reach;
            let span = Interval::new(t0, t0 + width);
            let jet = program.ray_jet(&ray, span);
            touched += usize::from(jet.value.hi > 0.0);
            for k in 0..=8 {
                let t = span.lo + span.width() * f64::from(k) / 8.0;
                let (f, d) = program.along_ray(&ray, t);
                assert!(
                    f.is_finite() && d.is_finite(),
                    "{}: non-finite field at {}",
                    path.display(),
                    ray.at(t)
                );
                let tol = 1e-8 * (1.0 + f.abs() + d.abs());
                assert!(
                    jet.value.lo - tol <= f && f <= jet.value.hi + tol,
                    "{}: value {f} outside {:?}",
                    path.display(),
                    jet.value
                );
                assert!(
                    jet.d1.lo - tol <= d && d <= jet.d1.hi + tol,
                    "{}: f′ {d} outside {:?}",
                    path.display(),
                    jet.d1
                );
                checked += 1;
            }
        }
        assert!(
            touched > 100,
            "{}: rays rarely reach the surface ({touched})",
            path.display()
        );
        assert!(checked > 0);
    }
}
