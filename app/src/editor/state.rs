//! The editor's UI state types: what is persisted between runs ([`UiState`], [`ViewMode`]),
//! the methods panel's tags and what they depend on, and the status bar's message. A leaf: it
//! imports nothing from the editor's other modules.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};
use skeletrace_core::backend::{BackendChoice, DeviceKind, Side};
use skeletrace_core::frame::{FieldShading, StepScale};
use skeletrace_core::methods::MethodId;

/// What the centre of the window shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ViewMode {
    /// The shaded surface of one method with the skeleton overlay.
    Shaded,
    /// The step-count heat maps of the chosen methods, one shared scale.
    Compare,
}

impl ViewMode {
    /// The suffix of this view's screenshot file names.
    #[must_use]
    pub fn file_suffix(self) -> &'static str {
        match self {
            Self::Shaded => "shaded",
            Self::Compare => "compare",
        }
    }
}

/// The mirror plane: the one through the origin across this world axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Mirror {
    /// `x = 0` (left and right).
    X,
    /// `y = 0`.
    Y,
    /// `z = 0`.
    Z,
}

impl Mirror {
    /// Every plane, in the order the editor offers them.
    pub const ALL: [Self; 3] = [Self::X, Self::Y, Self::Z];

    pub(super) fn axis(self) -> usize {
        match self {
            Self::X => 0,
            Self::Y => 1,
            Self::Z => 2,
        }
    }

    /// Its name in the editor.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Self::X => "x = 0",
            Self::Y => "y = 0",
            Self::Z => "z = 0",
        }
    }

    /// `p` mirrored across the plane.
    #[must_use]
    pub fn point(self, mut p: [f64; 3]) -> [f64; 3] {
        p[self.axis()] = -p[self.axis()];
        p
    }

    /// Whether `p` lies on the plane, within `tolerance`.
    pub(super) fn on_plane(self, p: [f64; 3], tolerance: f64) -> bool {
        p[self.axis()].abs() <= tolerance
    }
}

/// UI state kept between runs (eframe persistence), apart from anything on the GPU.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UiState {
    /// Method of the shaded view.
    pub shaded_method: MethodId,
    /// Methods of the comparison grid.
    pub compare_methods: Vec<MethodId>,
    /// Shaded view or comparison grid.
    pub view: ViewMode,
    /// Where frames are traced.
    pub backend: BackendChoice,
    /// Exact shadow rays in the shaded view (CPU and GPU).
    pub shadows: bool,
    /// Field soft shadows and ambient occlusion in the shaded view.
    #[serde(default)]
    pub shading: FieldShading,
    /// Colour scale of the comparison grid's heat maps (logarithmic by default).
    #[serde(default)]
    pub step_scale: StepScale,
    /// Recently opened or saved files, newest first.
    pub recent: Vec<PathBuf>,
    /// Screenshot size in pixels.
    pub screenshot_size: (usize, usize),
    /// Mirror symmetry of sketching and edits (`symmetry.rs`), if on.
    #[serde(default)]
    pub mirror: Option<Mirror>,
    /// Grid cells of a mesh export along the longest side of the support box.
    #[serde(default = "default_export_resolution")]
    pub export_resolution: usize,
}

fn default_export_resolution() -> usize {
    128
}

impl Default for UiState {
    fn default() -> Self {
        Self {
            shaded_method: MethodId::QuadraticTaylor,
            compare_methods: vec![
                MethodId::Sphere,
                MethodId::Segment,
                MethodId::QuadraticTaylor,
                MethodId::BottomUpQuadratic,
            ],
            view: ViewMode::Shaded,
            backend: BackendChoice::Auto,
            shadows: false,
            shading: FieldShading::default(),
            step_scale: StepScale::Log,
            recent: Vec::new(),
            screenshot_size: (1280, 960),
            mirror: None,
            export_resolution: default_export_resolution(),
        }
    }
}

/// Key of the persisted [`UiState`].
pub const UI_STATE_KEY: &str = "skeletrace-ui";
/// A method, whether it applies to the scene, and whether it runs on the GPU there.
#[derive(Clone, Debug)]
pub struct MethodTag {
    pub id: MethodId,
    /// The method applies to the scene (on the CPU).
    pub applies: bool,
    /// Where the render thread traces it for the backend choice
    /// (`skeletrace_core::backend::decide`), or why it cannot.
    pub side: Result<Side, String>,
}

/// What the methods' tags depend on.
#[derive(Clone, Copy, PartialEq)]
pub struct TagsKey {
    pub revision: u64,
    pub backend: BackendChoice,
    pub shadows: bool,
    pub shading: FieldShading,
    pub gpu: Option<DeviceKind>,
}

/// A message in the status bar.
pub struct Notice {
    pub text: String,
    pub error: bool,
}
