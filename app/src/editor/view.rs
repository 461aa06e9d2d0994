//! The viewport's camera (orbit, pan, zoom, framing) and the mapping between the scene and the
//! viewport's pixels that the skeleton overlay, picking and the gizmo share with the tracer's
//! pinhole camera (core `render::PinholeCamera`).

use eframe::egui;
use glam::DVec3;
use serde::{Deserialize, Serialize};
use skeletrace_core::Scene;
use skeletrace_core::model::scene::Camera;

/// An orbit camera around a target point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OrbitCamera {
    /// The point orbited.
    pub target: [f64; 3],
    /// Turn about the vertical axis, radians.
    pub yaw: f64,
    /// Elevation, radians, within ±89°.
    pub pitch: f64,
    /// Distance from the target.
    pub distance: f64,
    /// Vertical field of view, degrees.
    pub fov_degrees: f64,
}

const MAX_PITCH: f64 = 89.0_f64.to_radians();

/// The views along the axes, with the keys of common modelling tools (Blender's numeric keys:
/// 1 front, 3 right, 7 top; with Ctrl the opposite side).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StandardView {
    /// From +z, looking along −z.
    Front,
    /// From −z.
    Back,
    /// From +x.
    Right,
    /// From −x.
    Left,
    /// From above (+y), as far as the orbit's pitch goes.
    Top,
    /// From below.
    Bottom,
}

impl StandardView {
    /// Every view, in the View menu's order.
    pub const ALL: [Self; 6] = [
        Self::Front,
        Self::Back,
        Self::Right,
        Self::Left,
        Self::Top,
        Self::Bottom,
    ];

    /// The menu's label.
    #[must_use]
    pub const fn label(self) -> &'static str {
        match self {
            Self::Front => "Front view",
            Self::Back => "Back view",
            Self::Right => "Right view",
            Self::Left => "Left view",
            Self::Top => "Top view",
            Self::Bottom => "Bottom view",
        }
    }

    /// The key (with Ctrl for the opposite views) and its text in the shortcut list.
    #[must_use]
    pub const fn key(self) -> (egui::Key, bool, &'static str) {
        match self {
            Self::Front => (egui::Key::Num1, false, "1"),
            Self::Back => (egui::Key::Num1, true, "Ctrl+1"),
            Self::Right => (egui::Key::Num3, false, "3"),
            Self::Left => (egui::Key::Num3, true, "Ctrl+3"),
            Self::Top => (egui::Key::Num7, false, "7"),
            Self::Bottom => (egui::Key::Num7, true, "Ctrl+7"),
        }
    }

    /// The orbit's yaw and pitch that look along this view's axis.
    #[must_use]
    pub const fn yaw_pitch(self) -> (f64, f64) {
        use std::f64::consts::{FRAC_PI_2, PI};
        match self {
            Self::Front => (0.0, 0.0),
            Self::Back => (PI, 0.0),
            Self::Right => (FRAC_PI_2, 0.0),
            Self::Left => (-FRAC_PI_2, 0.0),
            Self::Top => (0.0, MAX_PITCH),
            Self::Bottom => (0.0, -MAX_PITCH),
        }
    }
}

impl OrbitCamera {
    /// The orbit that sees what the scene camera sees.
    #[must_use]
    pub fn from_camera(camera: &Camera) -> Self {
        let target = DVec3::from_array(camera.target);
        let offset = DVec3::from_array(camera.position) - target;
        let distance = offset.length().max(1e-6);
        Self {
            target: camera.target,
            yaw: offset.x.atan2(offset.z),
            pitch: (offset.y / distance).clamp(-1.0, 1.0).asin(),
            distance,
            fov_degrees: camera.fov_degrees,
        }
    }

    /// The pinhole camera of the scene format.
    #[must_use]
    pub fn camera(&self) -> Camera {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        let offset = DVec3::new(sy * cp, sp, cy * cp) * self.distance;
        Camera {
            position: (DVec3::from_array(self.target) + offset).to_array(),
            target: self.target,
            up: [0.0, 1.0, 0.0],
            fov_degrees: self.fov_degrees,
        }
    }

    /// Looks at the target along `view`'s axis, keeping the distance.
    pub fn look_from(&mut self, view: StandardView) {
        let (yaw, pitch) = view.yaw_pitch();
        self.yaw = yaw;
        self.pitch = pitch;
    }

    /// Turns by a mouse drag of `(dx, dy)` points.
    pub fn orbit(&mut self, dx: f64, dy: f64) {
        self.yaw -= dx * 0.01;
        self.pitch = (self.pitch + dy * 0.01).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Moves the target with the view plane by a drag of `(dx, dy)` points in a viewport
    /// `height` points high.
    pub fn pan(&mut self, dx: f64, dy: f64, height: f64) {
        let projection = Projection::new(&self.camera(), 1.0, height);
        let scale = self.distance / projection.focal;
        let target = DVec3::from_array(self.target) - projection.right * dx * scale
            + projection.up * dy * scale;
        self.target = target.to_array();
    }

    /// Zooms by `factor` (< 1 moves closer).
    pub fn zoom(&mut self, factor: f64) {
        self.distance = (self.distance * factor).clamp(1e-3, 1e6);
    }

    /// Frames the points `(centre, radius)`: target at their bounding box centre, distance
    /// so that the box's bounding sphere fits the view.
    pub fn frame(&mut self, balls: impl IntoIterator<Item = ([f64; 3], f64)>) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for (c, r) in balls {
            let c = DVec3::from_array(c);
            lo = lo.min(c - DVec3::splat(r));
            hi = hi.max(c + DVec3::splat(r));
        }
        if !lo.is_finite() || !hi.is_finite() {
            return;
        }
        let radius = (0.5 * (hi - lo).length()).max(1e-3);
        self.target = (0.5 * (lo + hi)).to_array();
        let half = (0.5 * self.fov_degrees.to_radians()).tan().max(1e-3);
        self.distance = 1.15 * radius / half.atan().sin();
    }
}

/// Every item as `(centre, radius)` where the viewport shows it: what frame-all frames.
pub fn scene_balls(scene: &Scene) -> Vec<([f64; 3], f64)> {
    super::selection::all_items(scene)
        .into_iter()
        .filter_map(|i| i.world_ball(scene))
        .collect()
}

/// World ↔ viewport pixels for one camera and viewport size (pixels from the top-left).
#[derive(Clone, Copy, Debug)]
pub struct Projection {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    /// Pixels per unit of the image plane at distance 1.
    focal: f64,
    centre: (f64, f64),
}

impl Projection {
    /// The projection of `camera` onto a `width × height` viewport.
    #[must_use]
    pub fn new(camera: &Camera, width: f64, height: f64) -> Self {
        let pinhole = skeletrace_core::frame::PinholeCamera::new(camera);
        let (forward, right, up) = pinhole.axes();
        let tan_half = (0.5 * camera.fov_degrees.to_radians()).tan();
        Self {
            eye: DVec3::from_array(camera.position),
            forward,
            right,
            up,
            focal: 0.5 * height / tan_half,
            centre: (0.5 * width, 0.5 * height),
        }
    }

    /// Pixel position and depth of a world point; `None` behind the eye.
    #[must_use]
    pub fn project(&self, p: [f64; 3]) -> Option<(f64, f64, f64)> {
        let d = DVec3::from_array(p) - self.eye;
        let z = d.dot(self.forward);
        if z <= 1e-6 {
            return None;
        }
        Some((
            self.centre.0 + self.focal * d.dot(self.right) / z,
            self.centre.1 - self.focal * d.dot(self.up) / z,
            z,
        ))
    }

    /// Pixels covered by a length `r` at depth `z`.
    #[must_use]
    pub fn pixels(&self, r: f64, z: f64) -> f64 {
        self.focal * r / z.max(1e-9)
    }

    /// `direction` (world) turned about the viewing axis by the screen angle from `from` to
    /// `to` (pixel offsets, y down): what dragging its drawn tip around its base does. Its
    /// component along the viewing axis is kept.
    #[must_use]
    pub fn turn_in_view(&self, direction: DVec3, from: (f64, f64), to: (f64, f64)) -> DVec3 {
        let cross = from.0 * to.1 - from.1 * to.0;
        let dot = from.0 * to.0 + from.1 * to.1;
        glam::DQuat::from_axis_angle(self.forward, cross.atan2(dot)) * direction
    }

    /// The world point at pixel `(x, y)` on the plane through `anchor` facing the camera.
    #[must_use]
    pub fn unproject_on_plane(&self, x: f64, y: f64, anchor: [f64; 3]) -> [f64; 3] {
        let z = (DVec3::from_array(anchor) - self.eye)
            .dot(self.forward)
            .max(1e-6);
        let u = (x - self.centre.0) / self.focal;
        let v = (self.centre.1 - y) / self.focal;
        (self.eye + z * (self.forward + u * self.right + v * self.up)).to_array()
    }

    /// The world displacement of a screen drag `(dx, dy)` pixels at depth `z`, in the plane
    /// facing the camera.
    #[must_use]
    pub fn drag_in_view_plane(&self, dx: f64, dy: f64, z: f64) -> [f64; 3] {
        let s = z / self.focal;
        (self.right * dx * s - self.up * dy * s).to_array()
    }

    /// Where the eye ray through pixel `(x, y)` meets the plane through `point` with normal
    /// `normal`; `None` when the ray runs parallel to it or meets it behind the eye.
    #[must_use]
    pub fn unproject_on_world_plane(
        &self,
        (x, y): (f64, f64),
        point: [f64; 3],
        normal: [f64; 3],
    ) -> Option<DVec3> {
        let u = (x - self.centre.0) / self.focal;
        let v = (self.centre.1 - y) / self.focal;
        let dir = self.forward + u * self.right + v * self.up;
        let n = DVec3::from_array(normal);
        let along = dir.dot(n);
        if along.abs() < 1e-9 {
            return None;
        }
        let t = (DVec3::from_array(point) - self.eye).dot(n) / along;
        (t > 0.0).then(|| self.eye + t * dir)
    }

    /// The world displacement, within the plane through `anchor` with normal `normal`, of a
    /// pointer moving from pixel `from` to pixel `to`: the handle stays under the pointer.
    #[must_use]
    pub fn drag_in_plane(
        &self,
        from: (f64, f64),
        to: (f64, f64),
        anchor: [f64; 3],
        normal: [f64; 3],
    ) -> [f64; 3] {
        match (
            self.unproject_on_world_plane(from, anchor, normal),
            self.unproject_on_world_plane(to, anchor, normal),
        ) {
            (Some(a), Some(b)) => (b - a).to_array(),
            _ => [0.0; 3],
        }
    }

    /// The world displacement along `axis` (unit) of a screen drag `(dx, dy)` pixels applied
    /// to a handle at `anchor`: the drag projected on the axis' screen direction.
    #[must_use]
    pub fn drag_along_axis(&self, dx: f64, dy: f64, anchor: [f64; 3], axis: [f64; 3]) -> [f64; 3] {
        let a = DVec3::from_array(anchor);
        let dir = DVec3::from_array(axis);
        let (Some(p0), Some(p1)) = (self.project(anchor), self.project((a + dir).to_array()))
        else {
            return [0.0; 3];
        };
        let (sx, sy) = (p1.0 - p0.0, p1.1 - p0.1);
        let len2 = sx * sx + sy * sy;
        if len2 < 1e-9 {
            return [0.0; 3];
        }
        (dir * ((dx * sx + dy * sy) / len2)).to_array()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_orbit_camera_reproduces_the_scene_camera_and_projects_its_target_to_the_centre() {
        let camera = Camera {
            position: [3.0, 2.0, 5.0],
            target: [0.5, 0.25, -1.0],
            up: [0.0, 1.0, 0.0],
            fov_degrees: 40.0,
        };
        let orbit = OrbitCamera::from_camera(&camera);
        let back = orbit.camera();
        for i in 0..3 {
            assert!(
                (back.position[i] - camera.position[i]).abs() < 1e-9,
                "{back:?}"
            );
        }
        let p = Projection::new(&back, 800.0, 600.0);
        let (x, y, _) = p.project(camera.target).unwrap_or_default();
        assert!((x - 400.0).abs() < 1e-6 && (y - 300.0).abs() < 1e-6);
        // A drag in the ground plane keeps y and lands under the pointer.
        let anchor = [0.5, 0.25, -1.0];
        let moved = p.drag_in_plane((400.0, 300.0), (480.0, 340.0), anchor, [0.0, 1.0, 0.0]);
        assert!(moved[1].abs() < 1e-9, "{moved:?}");
        let landed = [anchor[0] + moved[0], anchor[1], anchor[2] + moved[2]];
        let (lx, ly, _) = p.project(landed).unwrap_or_default();
        assert!((lx - 480.0).abs() < 1e-6 && (ly - 340.0).abs() < 1e-6);
        let q = p.unproject_on_plane(123.0, 45.0, [0.0, 0.0, 0.0]);
        let (qx, qy, _) = p.project(q).unwrap_or_default();
        assert!((qx - 123.0).abs() < 1e-6 && (qy - 45.0).abs() < 1e-6);
    }

    #[test]
    fn standard_views_look_along_their_axes() {
        let mut orbit = OrbitCamera::from_camera(&Camera::default());
        for (view, from) in [
            (StandardView::Front, DVec3::Z),
            (StandardView::Back, -DVec3::Z),
            (StandardView::Right, DVec3::X),
            (StandardView::Left, -DVec3::X),
            (StandardView::Top, DVec3::Y),
            (StandardView::Bottom, -DVec3::Y),
        ] {
            orbit.look_from(view);
            let c = orbit.camera();
            let offset = (DVec3::from_array(c.position) - DVec3::from_array(c.target)).normalize();
            assert!(offset.dot(from) > 0.999, "{view:?}: from {offset}");
        }
    }

    #[test]
    fn a_direction_turned_in_view_follows_the_pointer() {
        let camera = Camera {
            position: [2.0, 1.5, 4.0],
            target: [0.0, 0.2, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_degrees: 40.0,
        };
        let p = Projection::new(&camera, 800.0, 600.0);
        let base = [0.1, 0.3, -0.2];
        let screen = |q: [f64; 3]| p.project(q).map(|(x, y, _)| (x, y)).unwrap_or_default();
        let (bx, by) = screen(base);
        // A direction in the view plane, pointing right on screen.
        let start = p.unproject_on_plane(bx + 50.0, by, base);
        let d = DVec3::from_array(start) - DVec3::from_array(base);
        let turned = p.turn_in_view(d, (50.0, 0.0), (30.0, 40.0));
        let (tx, ty) = screen((DVec3::from_array(base) + turned).to_array());
        let (ux, uy) = (tx - bx, ty - by);
        let along = (ux * 30.0 + uy * 40.0) / (ux.hypot(uy) * 50.0);
        assert!(
            along > 1.0 - 1e-9,
            "turned tip at ({ux}, {uy}), pointer at (30, 40)"
        );
        assert!((turned.length() - d.length()).abs() < 1e-12);
    }
}
