//! Group transforms and repetition (2014 notes §11.4–11.5): a transformed group's field is the
//! original composed with the inverse similarity, copies of a repeated group carry the field
//! of the original at their offsets, and the scene file reads and rejects them with clear
//! messages. The smooth blends' bounds are sampled in `field_bounds.rs`.

mod common;

use common::{KINDS, Kind, add_primitive, group, scene};
use glam::{DMat3, DVec3, EulerRot};
use skeletrace_core::FieldProgram;
use skeletrace_core::model::kernel::Kernel;
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::{Blend, Repeat, Scene, Transform};

const KERNEL: Kernel = Kernel::CompactPolynomial {
    degree: 6,
    scale: 2.0,
};

fn random_group(rng: &mut SplitMix64) -> skeletrace_core::model::scene::Group {
    let mut g = group(KERNEL);
    for kind in KINDS {
        if kind != Kind::Plane {
            add_primitive(&mut g, kind, rng);
        }
    }
    g
}

#[test]
fn a_transformed_group_is_the_original_seen_through_the_inverse_map() {
    let mut rng = SplitMix64::new(11);
    for _ in 0..20 {
        let original = random_group(&mut rng);
        let transform = Transform {
            translate: common::point(&mut rng, 3.0),
            rotate: [
                rng.range(-180.0, 180.0),
                rng.range(-180.0, 180.0),
                rng.range(-180.0, 180.0),
            ],
            scale: rng.range(0.3, 3.0),
        };
        let mut moved = original.clone();
        moved.transform = transform;
        let a = FieldProgram::new(&scene(vec![original], None));
        let b = FieldProgram::new(&scene(vec![moved], None));
        let rotation = DMat3::from_euler(
            EulerRot::XYZ,
            transform.rotate[0].to_radians(),
            transform.rotate[1].to_radians(),
            transform.rotate[2].to_radians(),
        );
        let map = |p: DVec3| transform.scale * (rotation * p) + DVec3::from(transform.translate);
        let mut inside = 0;
        for _ in 0..2_000 {
            let p = DVec3::from(common::point(&mut rng, 1.5));
            let (f, g) = a.value_gradient(p);
            let (f2, g2) = b.value_gradient(map(p));
            assert!(
                (f - f2).abs() <= 1e-9 * (1.0 + f.abs()),
                "{f} vs {f2} at {p}"
            );
            // ∇(f∘M⁻¹) = R∇f / s
            let expected = rotation * g / transform.scale;
            assert!(
                (expected - g2).length() <= 1e-8 * (1.0 + expected.length()),
                "gradient {expected} vs {g2} at {p}"
            );
            inside += usize::from(f > 1.0);
        }
        assert!(
            inside > 0,
            "no sample inside the surface: the test proves little"
        );
    }
}

#[test]
fn every_copy_of_a_repeated_group_carries_the_original_field() {
    let mut rng = SplitMix64::new(5);
    let original = random_group(&mut rng);
    let single = FieldProgram::new(&scene(vec![original.clone()], None));
    let mut repeated = original;
    let spacing = [9.0, -8.0, 10.0];
    repeated.repeat = Some(Repeat {
        count: [3, 2, 2],
        spacing,
    });
    repeated.transform.translate = [1.0, 2.0, 3.0];
    let program = FieldProgram::new(&scene(vec![repeated.clone()], None));
    assert_eq!(program.primitives().len(), 12 * single.primitives().len());
    let offsets = repeated.repeat.map_or_else(Vec::new, |r| r.offsets());
    assert_eq!(offsets.len(), 12);
    for offset in offsets {
        let shift = DVec3::from(offset) + DVec3::new(1.0, 2.0, 3.0);
        for _ in 0..300 {
            // Copies are farther apart than the supports: each point sees one copy.
            let p = DVec3::from(common::point(&mut rng, 1.5));
            let (f, g) = single.value_gradient(p);
            let (f2, g2) = program.value_gradient(p + shift);
            assert!((f - f2).abs() < 1e-9 && (g - g2).length() < 1e-8);
        }
    }
}

#[test]
fn smooth_union_lies_between_the_max_and_a_quarter_width_above() {
    let mut rng = SplitMix64::new(3);
    let groups = vec![random_group(&mut rng), random_group(&mut rng)];
    let leaves = vec![Blend::Group(0), Blend::Group(1)];
    let width = 0.4;
    let max = FieldProgram::new(&scene(groups.clone(), Some(Blend::Max(leaves.clone()))));
    let min = FieldProgram::new(&scene(groups.clone(), Some(Blend::Min(leaves.clone()))));
    let union = FieldProgram::new(&scene(
        groups.clone(),
        Some(Blend::SmoothUnion {
            width,
            of: leaves.clone(),
        }),
    ));
    let intersection = FieldProgram::new(&scene(
        groups,
        Some(Blend::SmoothIntersection { width, of: leaves }),
    ));
    let (mut blended, mut total) = (0, 0);
    for _ in 0..5_000 {
        let p = DVec3::from(common::point(&mut rng, 1.5));
        let (hi, lo) = (max.value(p), min.value(p));
        let (u, i) = (union.value(p), intersection.value(p));
        assert!(
            u >= hi - 1e-12 && u <= hi + 0.25 * width + 1e-12,
            "{u} vs max {hi}"
        );
        assert!(
            i <= lo + 1e-12 && i >= lo - 0.25 * width - 1e-12,
            "{i} vs min {lo}"
        );
        if hi > 0.0 {
            total += 1;
            blended += usize::from(u > hi + 1e-6);
        }
        // The gradient is continuous: compare with central differences.
        let (_, g) = union.value_gradient(p);
        let numeric = common::numeric_gradient(&union, p, 1e-6);
        assert!(
            (numeric - g).length() < 1e-4 * (1.0 + g.length()),
            "{numeric} vs {g}"
        );
    }
    assert!(
        blended * 20 > total,
        "the blend band is almost never active ({blended}/{total})"
    );
}

#[test]
fn scene_files_read_transforms_and_repetition_and_name_bad_values() {
    let text = |group_extra: &str| {
        format!(
            "(version: 1, groups: [(name: \"arm\", blobs: [(center: (0, 0, 0), radius: 1)], \
             {group_extra})])"
        )
    };
    let scene = Scene::from_ron(
        &text(
            "transform: (translate: (1, 2, 3), rotate: (0, 90, 0), scale: 2), \
             repeat: Some((count: (4, 1, 1), spacing: (3, 0, 0)))",
        ),
        "ok.ron",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.groups[0].transform.scale, 2.0);
    assert_eq!(FieldProgram::new(&scene).primitives().len(), 4);
    let round_trip =
        Scene::from_ron(&scene.to_ron(), "again.ron").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(round_trip, scene);
    let plain = Scene::from_ron(&text(""), "plain.ron").unwrap_or_else(|e| panic!("{e}"));
    assert!(!plain.to_ron().contains("transform"));

    let bad_scale = Scene::from_ron(&text("transform: (scale: -1)"), "bad.ron")
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        bad_scale.contains("bad.ron") && bad_scale.contains("-1"),
        "{bad_scale}"
    );
    let bad_count = Scene::from_ron(
        &text("repeat: Some((count: (2, 0, 1), spacing: (1, 1, 1)))"),
        "count.ron",
    )
    .err()
    .map(|e| e.to_string())
    .unwrap_or_default();
    assert!(
        bad_count.contains("count.ron")
            && bad_count.contains("'arm'")
            && bad_count.contains("(2, 0, 1)"),
        "{bad_count}"
    );
}
