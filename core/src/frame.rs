//! What both frame backends share: the [`Frame`] they return (colour, depth, steps per pixel),
//! the [`PinholeCamera`] that makes primary rays, the far distance of those rays, what the colour
//! output shows ([`View`], [`FieldShading`]) and the step-count colour map. The CPU tracer
//! (`crate::cpu`) and the GPU backend (`skeletrace-render`) both build on these, so that their
//! frames can be compared pixel by pixel.

use glam::DVec3;

use crate::field::geometry::Ray;
use crate::field::program::FieldProgram;
use crate::model::scene::Camera;

/// What the colour output of a frame shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum View {
    /// Blinn–Phong shading, with the field's soft shadows and ambient occlusion if asked.
    Shaded(FieldShading),
    /// Step-count heat map ([`heat_colour`]) on `[0, steps_max]`.
    Steps {
        /// Top of the colour scale.
        steps_max: u32,
    },
}

// ---- Field shading (2014 notes §12.4): the constants both backends use (cpu/shading.rs,
// render/shaders/main.wgsl). ----

/// Reflection and refraction depth of a pixel's path through transparent groups, on both
/// backends.
pub const MAX_BOUNCES: u32 = 4;

/// Largest number of samples along a soft-shadow ray.
pub const SOFT_SHADOW_STEPS: u32 = 32;
/// Penumbra sharpness `k` of `min(k·e/t)`.
pub const SOFTNESS: f64 = 8.0;
/// First sample and smallest step of a soft-shadow ray, × scale.
pub const MIN_STEP: f64 = 0.002;
/// Largest step (and largest distance estimate), × scale.
pub const MAX_STEP: f64 = 0.08;
/// Length of a soft-shadow ray, × scale (shorter for a closer point light).
pub const SHADOW_REACH: f64 = 1.5;
/// Ambient-occlusion samples along the normal.
pub const AO_SAMPLES: u32 = 5;
/// Height between ambient-occlusion samples, × scale.
pub const AO_STEP: f64 = 0.012;
/// Weight ratio between consecutive ambient-occlusion samples.
pub const AO_DECAY: f64 = 0.6;

/// The scale the shading distances are relative to: the diagonal of the bounded supports' box
/// snapped to its grid (`FieldProgram::scale_bounds`).
#[must_use]
pub fn shading_scale(program: &FieldProgram) -> f64 {
    let bounds = program.scale_bounds();
    if bounds.is_empty() {
        1.0
    } else {
        bounds.diagonal()
    }
}

/// Which field-based shading terms to add.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct FieldShading {
    /// Soft shadows towards every light.
    pub soft_shadows: bool,
    /// Ambient occlusion.
    pub ambient_occlusion: bool,
}

impl FieldShading {
    /// Whether any term is on.
    #[must_use]
    pub fn any(self) -> bool {
        self.soft_shadows || self.ambient_occlusion
    }
}

/// Per-pixel output of a render.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Linear RGB, row-major from the top-left pixel.
    pub colour: Vec<[f32; 3]>,
    /// Ray parameter of the first crossing (distance from the eye); infinite where none.
    pub depth: Vec<f64>,
    /// Steps per pixel.
    pub steps: Vec<u32>,
}

/// Summary of a frame's step counts, over every pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepSummary {
    /// Mean.
    pub average: f64,
    /// Median.
    pub median: u32,
    /// 95th percentile.
    pub p95: u32,
    /// Maximum.
    pub max: u32,
}

/// How many pixels of a frame took each step count: `counts[s]` pixels took `s` steps. The
/// statistics of the comparison grid come from it, whether the frame is on the CPU
/// ([`StepHistogram::of`]) or stays on the GPU and only its histogram is read back.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StepHistogram {
    counts: Vec<u64>,
}

impl StepHistogram {
    /// The histogram of `steps`.
    #[must_use]
    pub fn of(steps: &[u32]) -> Self {
        let top = steps.iter().copied().max().unwrap_or(0) as usize;
        let mut counts = vec![0; top + 1];
        for &s in steps {
            counts[s as usize] += 1;
        }
        Self { counts }
    }

    /// The histogram with `counts[s]` pixels of `s` steps (trailing empty counts dropped).
    #[must_use]
    pub fn from_counts(mut counts: Vec<u64>) -> Self {
        while counts.last() == Some(&0) {
            counts.pop();
        }
        Self { counts }
    }

    /// Pixels of each step count, from 0 steps up to the largest count taken.
    #[must_use]
    pub fn counts(&self) -> &[u64] {
        &self.counts
    }

    /// Pixels counted.
    #[must_use]
    pub fn pixels(&self) -> u64 {
        self.counts.iter().sum()
    }

    /// The step count of the `rank`-th pixel (from 0) in increasing order of steps.
    fn ranked(&self, rank: u64, from: usize) -> u32 {
        let mut seen = 0;
        for (s, &c) in self.counts.iter().enumerate().skip(from) {
            seen += c;
            if seen > rank {
                return s as u32;
            }
        }
        self.counts.len().saturating_sub(1) as u32
    }

    /// Average, median, 95th percentile and maximum, over every pixel.
    #[must_use]
    pub fn summary(&self) -> StepSummary {
        let n = self.pixels();
        if n == 0 {
            return StepSummary {
                average: 0.0,
                median: 0,
                p95: 0,
                max: 0,
            };
        }
        let total: f64 = self
            .counts
            .iter()
            .enumerate()
            .map(|(s, &c)| s as f64 * c as f64)
            .sum();
        StepSummary {
            average: total / n as f64,
            median: self.ranked(n / 2, 0),
            p95: self.ranked(n * 95 / 100, 0),
            max: self.counts.len().saturating_sub(1) as u32,
        }
    }

    /// The 99th percentile of the pixels that took at least one step (1 when none did): a
    /// panel's share of the grid's colour scale, which no single outlier pixel sets.
    #[must_use]
    pub fn worked_p99(&self) -> u32 {
        let worked: u64 = self.counts.iter().skip(1).sum();
        if worked == 0 {
            return 1;
        }
        self.ranked(worked * 99 / 100, 1)
    }
}

/// The top of a comparison's shared colour scale: the largest of the panels'
/// [`StepHistogram::worked_p99`] (1 without panels). Counts above it take the top colour.
#[must_use]
pub fn shared_step_top<'a>(panels: impl IntoIterator<Item = &'a StepHistogram>) -> u32 {
    panels
        .into_iter()
        .map(StepHistogram::worked_p99)
        .max()
        .unwrap_or(1)
        .max(1)
}

impl Frame {
    /// Average, median, 95th percentile and maximum steps.
    #[must_use]
    pub fn step_summary(&self) -> StepSummary {
        self.step_histogram().summary()
    }

    /// How many pixels took each step count.
    #[must_use]
    pub fn step_histogram(&self) -> StepHistogram {
        StepHistogram::of(&self.steps)
    }

    /// Whether pixel `i` hit the surface.
    #[must_use]
    pub fn is_hit(&self, i: usize) -> bool {
        self.depth[i].is_finite()
    }
}

/// Primary rays of a pinhole camera.
#[derive(Clone, Copy, Debug)]
pub struct PinholeCamera {
    origin: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_half: f64,
}

impl PinholeCamera {
    /// The scene camera. A target on the eye looks along −z; an up along the view direction
    /// gives way to any direction across it, so that the axes stay orthonormal.
    #[must_use]
    pub fn new(camera: &Camera) -> Self {
        let origin = DVec3::from_array(camera.position);
        let forward = (DVec3::from_array(camera.target) - origin).normalize_or(DVec3::NEG_Z);
        let right = forward
            .cross(DVec3::from_array(camera.up))
            .normalize_or(forward.any_orthonormal_vector());
        Self {
            origin,
            forward,
            right,
            up: right.cross(forward),
            tan_half: (0.5 * camera.fov_degrees.to_radians()).tan(),
        }
    }

    /// Unit forward, right and up axes.
    #[must_use]
    pub fn axes(&self) -> (DVec3, DVec3, DVec3) {
        (self.forward, self.right, self.up)
    }

    /// Ray through the centre of pixel `(x, y)` of a `width × height` image.
    #[must_use]
    pub fn ray(&self, x: usize, y: usize, width: usize, height: usize) -> Ray {
        Ray::new(
            self.origin,
            self.direction_at(x as f64 + 0.5, y as f64 + 0.5, width, height),
        )
    }

    /// The eye.
    #[must_use]
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// Direction (not normalised) through the point `(px, py)` of the image, in pixels from
    /// its top left corner.
    #[must_use]
    pub fn direction_at(&self, px: f64, py: f64, width: usize, height: usize) -> DVec3 {
        let aspect = width as f64 / height.max(1) as f64;
        let u = (2.0 * px / width as f64 - 1.0) * self.tan_half * aspect;
        let v = (1.0 - 2.0 * py / height as f64) * self.tan_half;
        self.forward + u * self.right + v * self.up
    }

    /// Directions through the outer corners of the pixels `x0..x1 × y0..y1`, in order around
    /// them: the cone of a screen tile's camera rays ([`crate::field::ray_field::TileCandidates`]).
    #[must_use]
    pub fn tile_corners(
        &self,
        (x0, x1): (usize, usize),
        (y0, y1): (usize, usize),
        width: usize,
        height: usize,
    ) -> [DVec3; 4] {
        let (x0, x1, y0, y1) = (x0 as f64, x1 as f64, y0 as f64, y1 as f64);
        [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
            .map(|(x, y)| self.direction_at(x, y, width, height))
    }
}

/// Length of the primary rays: past the farthest support seen from the camera, measured on the
/// supports' box snapped to its grid (`FieldProgram::scale_bounds`; four times as far when a
/// plane reaches to infinity). The GPU backend uses the same value.
#[must_use]
pub fn far_distance(program: &FieldProgram, camera: &Camera) -> f64 {
    let bounds = program.scale_bounds();
    if bounds.is_empty() {
        return 100.0;
    }
    let eye = DVec3::from_array(camera.position);
    let reach = (bounds.center() - eye).length() + bounds.diagonal();
    if program.has_unbounded_support() {
        4.0 * reach
    } else {
        reach
    }
}

/// Linear to sRGB-encoded 8-bit.
#[must_use]
pub fn srgb8(linear: f32) -> u8 {
    let c = linear.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// Coefficients of the Turbo polynomial fit (Mikhailov 2019), one row per channel (red, green,
/// blue), lowest degree first. The GPU backend emits the same numbers into its shaders.
pub const TURBO: [[f64; 6]; 3] = [
    [
        0.135_721_38,
        4.615_392_6,
        -42.660_322_6,
        132.131_082_9,
        -152.942_393_9,
        59.286_379_0,
    ],
    [
        0.091_402_61,
        2.194_188_39,
        4.842_966_58,
        -14.185_033_3,
        4.277_298_55,
        2.829_566_04,
    ],
    [
        0.106_673_30,
        12.641_946_08,
        -60.582_048_8,
        110.362_767_7,
        -89.903_109_8,
        27.348_249_3,
    ],
];

/// How step counts map onto the colour scale `[0, top]`: logarithmically by default, so that
/// 5 and 2048 steps are both readable on one scale, or linearly.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum StepScale {
    /// `ln(1 + steps) / ln(1 + top)`.
    #[default]
    Log,
    /// `steps / top`.
    Linear,
}

impl StepScale {
    /// Position in `[0, 1]` of `steps` on a scale whose top is `top` (counts above take 1).
    #[must_use]
    pub fn position(self, steps: f64, top: u32) -> f64 {
        let top = f64::from(top.max(1));
        let x = match self {
            Self::Log => steps.max(0.0).ln_1p() / top.ln_1p(),
            Self::Linear => steps / top,
        };
        x.clamp(0.0, 1.0)
    }
}

/// The step-count colour map (Turbo, Mikhailov 2019, polynomial fit [`TURBO`]) at
/// `x ∈ [0, 1]`, sRGB in `[0, 1]`.
#[must_use]
pub fn heat_colour(x: f64) -> [f32; 3] {
    let x = x.clamp(0.0, 1.0);
    TURBO.map(|c| {
        let v = c[0] + x * (c[1] + x * (c[2] + x * (c[3] + x * (c[4] + x * c[5]))));
        v.clamp(0.0, 1.0) as f32
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cameras whose up lies along the view (here along x, where the old fallback right axis
    /// was the view itself and every pixel's ray the same) or whose target is the eye.
    #[test]
    fn degenerate_cameras_keep_orthonormal_axes() {
        let looking = |position: [f64; 3], target: [f64; 3], up: [f64; 3]| Camera {
            position,
            target,
            up,
            ..Camera::default()
        };
        for camera in [
            looking([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
            looking([0.0, 0.0, 0.0], [0.0, -3.0, 0.0], [0.0, 1.0, 0.0]),
            looking([1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [0.0, 1.0, 0.0]),
            looking([1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [0.0, 0.0, 1.0]),
        ] {
            let (forward, right, up) = PinholeCamera::new(&camera).axes();
            for (a, b) in [(forward, right), (right, up), (up, forward)] {
                assert!(a.dot(b).abs() < 1e-12, "{camera:?}");
            }
            for axis in [forward, right, up] {
                assert!((axis.length() - 1.0).abs() < 1e-12, "{camera:?}");
            }
        }
    }

    /// On a 2048-step scale, 5 and 8 steps land in clearly different colours on the log scale
    /// (a tenth of the bar apart) where the linear one squeezes them into its first 0.4 %.
    #[test]
    fn the_log_scale_separates_small_counts_that_the_linear_one_merges() {
        for scale in [StepScale::Log, StepScale::Linear] {
            assert_eq!(scale.position(0.0, 2048), 0.0);
            assert_eq!(scale.position(2048.0, 2048), 1.0);
            assert_eq!(
                scale.position(5000.0, 2048),
                1.0,
                "counts above the top clip"
            );
            let mut last = -1.0;
            for s in 0..=2048 {
                let x = scale.position(f64::from(s), 2048);
                assert!(x > last, "{scale:?} is not increasing at {s}");
                last = x;
            }
        }
        let gap = |scale: StepScale| scale.position(8.0, 2048) - scale.position(5.0, 2048);
        assert!(gap(StepScale::Log) > 0.05, "{}", gap(StepScale::Log));
        assert!(gap(StepScale::Linear) < 0.004);
        assert_eq!(StepScale::default(), StepScale::Log);
    }

    /// The histogram's statistics are those of the sorted list of step counts, on random
    /// lists of every size from empty up.
    #[test]
    fn histogram_statistics_equal_those_of_the_sorted_counts() {
        let mut state = 0x9e37_79b9_u64;
        for n in 0..300 {
            let steps: Vec<u32> = (0..n)
                .map(|_| {
                    state = state
                        .wrapping_mul(6_364_136_223_846_793_005)
                        .wrapping_add(1);
                    let r = (state >> 33) as u32;
                    if r.is_multiple_of(7) {
                        0
                    } else {
                        r % (1 + n as u32 % 50)
                    }
                })
                .collect();
            let mut sorted = steps.clone();
            sorted.sort_unstable();
            let h = StepHistogram::of(&steps);
            let s = h.summary();
            assert_eq!(h.pixels(), n as u64);
            if n == 0 {
                assert_eq!(s.max, 0);
                assert_eq!(h.worked_p99(), 1);
                continue;
            }
            let mean = sorted.iter().map(|&v| f64::from(v)).sum::<f64>() / n as f64;
            assert!((s.average - mean).abs() < 1e-9);
            assert_eq!(s.median, sorted[n / 2]);
            assert_eq!(s.p95, sorted[n * 95 / 100]);
            assert_eq!(s.max, sorted[n - 1]);
            let worked: Vec<u32> = sorted.iter().copied().filter(|&v| v > 0).collect();
            let p99 = worked.get(worked.len() * 99 / 100).copied().unwrap_or(1);
            assert_eq!(h.worked_p99(), p99, "{steps:?}");
            let counts = h.counts().to_vec();
            assert_eq!(StepHistogram::from_counts([counts, vec![0; 3]].concat()), h);
        }
    }
}
