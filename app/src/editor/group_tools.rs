//! Inspector helpers for a group's operators (transform and repetition, 2014 notes §11.4–11.5)
//! and its HRBF sets (forward inclusion 2023 eq. 9): a new set to start from, and normals
//! edited as two angles so that dragging rotates them instead of resizing them.

use eframe::egui;
use skeletrace_core::model::scene::{Hrbf, HrbfPoint, Repeat, Transform, Vec3};

use super::shape_tools::{scalar, vector};

/// Eight points on the corners of a cube of half side `half` around `centre`, normals along
/// the diagonals: a rounded box to start editing from.
#[must_use]
pub fn new_hrbf_set(centre: Vec3, half: f64) -> Hrbf {
    let mut points = Vec::with_capacity(8);
    for i in 0..8 {
        let s = [
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { -1.0 } else { 1.0 },
        ];
        points.push(HrbfPoint {
            position: [
                centre[0] + half * s[0],
                centre[1] + half * s[1],
                centre[2] + half * s[2],
            ],
            normal: s,
        });
    }
    Hrbf { points }
}

/// Azimuth (about `y`, from `+z`) and elevation (from the `xz` plane) of a direction, degrees.
#[must_use]
pub fn normal_angles(n: Vec3) -> (f64, f64) {
    let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-300);
    let elevation = (n[1] / length).clamp(-1.0, 1.0).asin().to_degrees();
    let azimuth = n[0].atan2(n[2]).to_degrees();
    (azimuth, elevation)
}

/// The unit direction with the given azimuth and elevation (degrees).
#[must_use]
pub fn normal_from_angles(azimuth: f64, elevation: f64) -> Vec3 {
    let (a, e) = (azimuth.to_radians(), elevation.to_radians());
    [e.cos() * a.sin(), e.sin(), e.cos() * a.cos()]
}

/// Edits one HRBF point: its position, and its normal's azimuth and elevation.
pub fn edit_point(ui: &mut egui::Ui, point: &mut HrbfPoint) {
    vector(ui, "position", &mut point.position, 0.01);
    let (mut azimuth, mut elevation) = normal_angles(point.normal);
    let before = (azimuth, elevation);
    ui.horizontal(|ui| {
        ui.label("normal azimuth / elevation °");
        ui.add(egui::DragValue::new(&mut azimuth).speed(1.0));
        ui.add(
            egui::DragValue::new(&mut elevation)
                .speed(1.0)
                .range(-90.0..=90.0),
        );
    });
    if (azimuth, elevation) != before {
        point.normal = normal_from_angles(azimuth, elevation);
    }
}

/// Edits a group's transform and repetition.
pub fn edit_operators(ui: &mut egui::Ui, transform: &mut Transform, repeat: &mut Option<Repeat>) {
    vector(ui, "translate", &mut transform.translate, 0.01);
    vector(ui, "rotate °", &mut transform.rotate, 1.0);
    scalar(ui, "scale", &mut transform.scale, 0.01);
    transform.scale = transform.scale.max(1e-3);
    let mut repeated = repeat.is_some();
    ui.checkbox(&mut repeated, "repeat on a grid");
    match (repeated, repeat.as_mut()) {
        (true, Some(r)) => {
            ui.horizontal(|ui| {
                ui.label("copies");
                for n in &mut r.count {
                    ui.add(egui::DragValue::new(n).range(1..=64));
                }
            });
            vector(ui, "spacing", &mut r.spacing, 0.01);
        }
        (true, None) => {
            *repeat = Some(Repeat {
                count: [2, 1, 1],
                spacing: [1.0, 0.0, 0.0],
            });
        }
        (false, _) => *repeat = None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use skeletrace_core::Scene;

    #[test]
    fn a_new_set_is_valid_in_a_group_of_its_own_and_normals_survive_their_angles() {
        let mut scene = crate::editor::default_scene();
        let mut group = scene.groups[0].clone();
        group.skeletons.clear();
        group.blobs.clear();
        group.shapes.clear();
        group.hrbfs.push(new_hrbf_set([0.1, 0.2, 0.3], 0.4));
        scene.groups.push(group);
        let back = Scene::from_ron(&scene.to_ron(), "hrbf");
        assert!(back.is_ok(), "{back:?}");
        for n in [[1.0, 1.0, 1.0], [0.0, -1.0, 0.2], [-0.3, 0.1, -2.0]] {
            let (a, e) = normal_angles(n);
            let m = normal_from_angles(a, e);
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            for k in 0..3 {
                assert!((m[k] - n[k] / len).abs() < 1e-12, "{n:?} → {m:?}");
            }
        }
    }
}
