//! HRBF sets (forward inclusion 2023 eq. 9): the solved interpolant passes through every point
//! with its normal, the compiled density puts the surface there, and bad sets are refused with
//! the group and set named.

mod common;

use common::random_hrbf;
use glam::DVec3;
use skeletrace_core::FieldProgram;
use skeletrace_core::field::hrbf_solve::solve;
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::Scene;

#[test]
fn the_interpolant_passes_through_every_point_with_its_normal() {
    let mut rng = SplitMix64::new(17);
    for _ in 0..50 {
        let set = random_hrbf(&mut rng);
        let w = solve(&set.points).unwrap_or_else(|e| panic!("{e}"));
        for p in &set.points {
            let (h, g) = w.value_gradient(DVec3::from(p.position));
            let n = DVec3::from(p.normal).normalize();
            assert!(h.abs() < 1e-8, "h = {h} at a point");
            assert!((g - n).length() < 1e-7, "∇h = {g}, normal {n}");
        }
        // The compiled density: c on the points, gradient −(c/ℓ)·n.
        let mut g = common::group(common::KERNELS[0]);
        g.hrbfs.push(set.clone());
        let program = FieldProgram::new(&common::scene(vec![g], None));
        let c = program.isovalue();
        for p in &set.points {
            let (f, grad) = program.value_gradient(DVec3::from(p.position));
            let n = DVec3::from(p.normal).normalize();
            assert!((f - c).abs() < 1e-7, "f = {f} on a point, c = {c}");
            let expected = -c / w.length_scale() * n;
            assert!((grad - expected).length() < 1e-6 * expected.length());
        }
    }
}

fn load(groups: &str) -> Result<Scene, String> {
    Scene::from_ron(&format!("(version: 1, groups: [{groups}])"), "set.ron")
        .map_err(|e| e.to_string())
}

#[test]
fn bad_sets_are_refused_with_the_group_and_set_named() {
    let point = |x: f64, n: &str| format!("(position: ({x}, 0, 0), normal: {n})");
    let ok = load(&format!(
        "(name: \"shell\", hrbfs: [(points: [{}, {}])])",
        point(-1.0, "(-1, 0, 0)"),
        point(1.0, "(1, 0, 0)")
    ));
    assert!(ok.is_ok(), "{ok:?}");
    let repeated = load(&format!(
        "(name: \"shell\", hrbfs: [(points: [{}, {}])])",
        point(1.0, "(1, 0, 0)"),
        point(1.0, "(0, 1, 0)")
    ))
    .err()
    .unwrap_or_default();
    assert!(
        repeated.contains("set.ron")
            && repeated.contains("'shell', HRBF set 0")
            && repeated.contains("singular"),
        "{repeated}"
    );
    let zero = load(&format!(
        "(name: \"shell\", hrbfs: [(points: [{}])])",
        point(1.0, "(0, 0, 0)")
    ))
    .err()
    .unwrap_or_default();
    assert!(
        zero.contains("set.ron") && zero.contains("(0, 0, 0)"),
        "{zero}"
    );
    let mixed = load(&format!(
        "(name: \"shell\", blobs: [(center: (0, 0, 0), radius: 1)], hrbfs: [(points: [{}])])",
        point(1.0, "(1, 0, 0)")
    ))
    .err()
    .unwrap_or_default();
    assert!(
        mixed.contains("'shell'") && mixed.contains("holds nothing else"),
        "{mixed}"
    );
}
