//! File > New: the scenes a new document starts from — an empty scene (one group to sketch
//! in, a ground plane that the "without ground" entry leaves out, a camera and a light), a blob,
//! a skeleton to extend, and the creature. Each is a scene file embedded from `app/templates/`
//! (the creature is the default asset), so that what a template holds reads as any scene.

use skeletrace_core::Scene;

/// A scene File > New starts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Template {
    /// One empty group over a ground plane.
    Empty,
    /// One empty group, nothing else.
    EmptyWithoutGround,
    /// One point blob over a ground plane.
    Blob,
    /// A small SCALIS skeleton (a spine and two limbs) over a ground plane.
    Skeleton,
    /// The default creature.
    Creature,
}

impl Template {
    /// Every template, in the menu's order.
    pub const ALL: [Self; 5] = [
        Self::Empty,
        Self::EmptyWithoutGround,
        Self::Blob,
        Self::Skeleton,
        Self::Creature,
    ];

    /// Its entry in File > New.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Self::Empty => "Empty scene",
            Self::EmptyWithoutGround => "Empty scene without ground",
            Self::Blob => "Blob",
            Self::Skeleton => "Skeleton to start from",
            Self::Creature => "Creature",
        }
    }

    /// The scene it starts.
    #[must_use]
    pub fn scene(self) -> Scene {
        let (text, name) = match self {
            Self::Empty | Self::EmptyWithoutGround => (
                include_str!("../../templates/empty.ron"),
                "<template empty.ron>",
            ),
            Self::Blob => (
                include_str!("../../templates/blob.ron"),
                "<template blob.ron>",
            ),
            Self::Skeleton => (
                include_str!("../../templates/skeleton.ron"),
                "<template skeleton.ron>",
            ),
            Self::Creature => (crate::DEFAULT_SCENE, crate::DEFAULT_SCENE_NAME),
        };
        // The embedded files are checked by this module's test; a failure is a build defect.
        let mut scene =
            Scene::from_ron(text, name).unwrap_or_else(|e| unreachable!("template {name}: {e}"));
        if self == Self::EmptyWithoutGround {
            scene.groups.truncate(1);
            scene.blend = None;
        }
        scene
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use skeletrace_core::backend::{Cancel, FrameBackend, FrameRequest};
    use skeletrace_core::cpu::cpu_backend::CpuBackend;
    use skeletrace_core::frame::{FieldShading, View};
    use skeletrace_core::methods::{MethodId, TraceSettings};

    /// Every template validates, compiles and traces through its camera: the empty scenes show
    /// the ground or nothing, the others their shape in the middle of the view.
    #[test]
    fn every_template_is_a_valid_scene_showing_what_it_says() {
        for template in Template::ALL {
            let scene = template.scene();
            scene
                .validate()
                .unwrap_or_else(|e| panic!("{}: {e}", template.label()));
            let compiled = skeletrace_core::compile(&scene);
            let request = FrameRequest {
                camera: scene.camera,
                width: 32,
                height: 24,
                methods: vec![MethodId::QuadraticTaylor],
                view: View::Shaded(FieldShading::default()),
                shadows: false,
                settings: TraceSettings::for_program(&compiled.program),
                cancel: Cancel::new(),
            };
            let frame = CpuBackend::new()
                .render(&compiled, &request)
                .unwrap_or_else(|e| panic!("{}: {e}", template.label()))
                .remove(0);
            let centre = 12 * 32 + 16;
            let hits = (0..frame.depth.len()).filter(|&i| frame.is_hit(i)).count();
            match template {
                Template::EmptyWithoutGround => {
                    assert_eq!(scene.groups.len(), 1);
                    assert_eq!(hits, 0, "nothing to see");
                }
                Template::Empty => {
                    assert_eq!(scene.counts().vertices + scene.counts().blobs, 0);
                    assert!(hits > 0, "the ground is seen");
                }
                _ => assert!(
                    frame.is_hit(centre),
                    "{}: its shape in the middle",
                    template.label()
                ),
            }
        }
    }
}
