//! The translate gizmo at the selection's centroid: three axis handles, three plane handles
//! (one per pair of axes) and a view-plane handle at the centre. [`Gizmo`] is placed once per
//! UI frame from the projection, then drawn, hit-tested and turned into world moves while a
//! drag is under way.

use eframe::egui::{Color32, Painter, Pos2, Rect, Stroke, StrokeKind, Vec2};

use super::view::Projection;

/// Length of the axis handles, points.
const AXIS_LENGTH: f32 = 70.0;
/// Where a plane handle sits, as a fraction of the two axis handles it spans.
const PLANE_HANDLE: f32 = 0.35;
/// Half size of a plane handle, points.
const PLANE_HANDLE_SIZE: f32 = 6.0;
/// How near an axis handle a press must be, points.
const AXIS_PICK: f32 = 6.0;
/// Colours of the x, y and z handles.
pub const AXIS_COLOURS: [Color32; 3] = [
    Color32::from_rgb(230, 80, 80),
    Color32::from_rgb(110, 200, 90),
    Color32::from_rgb(90, 140, 240),
];

/// A handle of the gizmo.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Handle {
    /// Move along world axis `k` (0 x, 1 y, 2 z).
    Axis(usize),
    /// Move in the world plane normal to axis `k` (0 yz, 1 zx, 2 xy).
    Plane(usize),
    /// Move in the plane facing the camera.
    ViewPlane,
}

/// The gizmo placed on screen for one UI frame.
#[derive(Clone, Copy, Debug)]
pub struct Gizmo {
    /// World position of the centre (the selection's centroid).
    pub centre: [f64; 3],
    /// Screen position of the centre.
    pub at: Pos2,
    /// Depth of the centre along the viewing axis.
    pub depth: f64,
    axis_tips: [Pos2; 3],
    plane_handles: [Pos2; 3],
}

impl Gizmo {
    /// The gizmo at `centre`, or `None` when the centre is behind the camera.
    #[must_use]
    pub fn place(
        centre: [f64; 3],
        projection: &Projection,
        to_screen: &impl Fn(f64, f64) -> Pos2,
    ) -> Option<Self> {
        let (x, y, depth) = projection.project(centre)?;
        let at = to_screen(x, y);
        let axis_tips = std::array::from_fn(|k| {
            let mut tip = centre;
            tip[k] += 1.0;
            // Screen direction of the axis: project a point one unit along it.
            let dir = projection
                .project(tip)
                .map(|(x, y, _)| to_screen(x, y) - at)
                .unwrap_or(Vec2::ZERO);
            at + dir.normalized() * AXIS_LENGTH
        });
        let plane_handles = std::array::from_fn(|k| {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            at + ((axis_tips[a] - at) + (axis_tips[b] - at)) * PLANE_HANDLE
        });
        Some(Self {
            centre,
            at,
            depth,
            axis_tips,
            plane_handles,
        })
    }

    /// Draws the handles, `active` (the one being dragged) highlighted.
    pub fn draw(&self, painter: &Painter, active: Option<Handle>, centre_colour: Color32) {
        for (k, &tip) in self.axis_tips.iter().enumerate() {
            let width = if active == Some(Handle::Axis(k)) {
                4.0
            } else {
                2.5
            };
            painter.line_segment([self.at, tip], Stroke::new(width, AXIS_COLOURS[k]));
            painter.circle_filled(tip, 6.0, AXIS_COLOURS[k]);
        }
        for (k, &handle) in self.plane_handles.iter().enumerate() {
            let strength = if active == Some(Handle::Plane(k)) {
                1.0
            } else {
                0.6
            };
            painter.rect_filled(
                Rect::from_center_size(handle, Vec2::splat(2.0 * PLANE_HANDLE_SIZE)),
                1.0,
                AXIS_COLOURS[k].gamma_multiply(strength),
            );
        }
        painter.rect_stroke(
            Rect::from_center_size(self.at, Vec2::splat(14.0)),
            2.0,
            Stroke::new(2.0, centre_colour),
            StrokeKind::Middle,
        );
    }

    /// The axis or plane handle under `p`, axes first.
    #[must_use]
    pub fn axis_or_plane_at(&self, p: Pos2) -> Option<Handle> {
        if let Some(k) = (0..3).find(|&k| near_segment(p, self.at, self.axis_tips[k])) {
            return Some(Handle::Axis(k));
        }
        (0..3)
            .find(|&k| {
                let d = p - self.plane_handles[k];
                d.x.abs() <= PLANE_HANDLE_SIZE + 2.0 && d.y.abs() <= PLANE_HANDLE_SIZE + 2.0
            })
            .map(Handle::Plane)
    }

    /// Whether `p` is within `pick` points of the centre (the view-plane handle).
    #[must_use]
    pub fn centre_at(&self, p: Pos2, pick: f32) -> bool {
        (p - self.at).length() < pick
    }

    /// The world move of dragging `handle` from `from` to `to` (points, relative to the
    /// viewport's top-left corner `origin`).
    #[must_use]
    pub fn drag(
        &self,
        handle: Handle,
        projection: &Projection,
        origin: Pos2,
        from: Pos2,
        to: Pos2,
    ) -> [f64; 3] {
        let delta = to - from;
        let (dx, dy) = (f64::from(delta.x), f64::from(delta.y));
        match handle {
            Handle::Axis(k) => {
                let mut axis = [0.0; 3];
                axis[k] = 1.0;
                projection.drag_along_axis(dx, dy, self.centre, axis)
            }
            Handle::Plane(k) => {
                let pixel = |p: Pos2| (f64::from(p.x - origin.x), f64::from(p.y - origin.y));
                let mut normal = [0.0; 3];
                normal[k] = 1.0;
                projection.drag_in_plane(pixel(from), pixel(to), self.centre, normal)
            }
            Handle::ViewPlane => projection.drag_in_view_plane(dx, dy, self.depth),
        }
    }
}

/// `p` lies near the segment `a`–`b` (an axis handle), away from its start.
fn near_segment(p: Pos2, a: Pos2, b: Pos2) -> bool {
    let ab = b - a;
    let len2 = ab.length_sq();
    if len2 < 1.0 {
        return false;
    }
    let t = ((p - a).dot(ab) / len2).clamp(0.0, 1.0);
    t > 0.25 && (a + ab * t - p).length() < AXIS_PICK
}
