//! The kernel as a scene stores it: the file's spec (compact polynomial, Cauchy, Gaussian with
//! their degree and scale), its validation, and the support its clipped form reaches. The field
//! (`field/kernel.rs`) builds its evaluation profiles from it (scalis 2021 eq. 2–3,
//! forward-inclusion 2023 eq. 6–7, MATH.md §1–4).

use serde::{Deserialize, Serialize};

/// Clipping threshold of the infinite-support kernels (scalis §7 uses 0.005). The clipped
/// kernel is within this absolute error of the exact kernel.
pub const CLIP_EPSILON: f64 = 0.005;

/// A kernel as stored in a scene, validated on load.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "KernelSpec")]
pub enum Kernel {
    /// `(1 − r²/σ²)^(i/2)` on `r < σ` (C² for degree 6).
    CompactPolynomial {
        /// Even degree `i ≥ 2`.
        degree: u32,
        /// Support scale `σ > 1`.
        scale: f64,
    },
    /// `(1 + r²/σ²)^(−i/2)`, clipped at [`CLIP_EPSILON`].
    Cauchy {
        /// Degree `i ≥ 1`.
        degree: u32,
        /// Scale `σ > 0`.
        scale: f64,
    },
    /// `exp(−r²/σ²)`, clipped at [`CLIP_EPSILON`].
    Gaussian {
        /// Scale `σ > 0`.
        scale: f64,
    },
}

impl Default for Kernel {
    fn default() -> Self {
        Self::CompactPolynomial {
            degree: 6,
            scale: 2.0,
        }
    }
}

/// The unvalidated shape of [`Kernel`] as read from a file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Kernel")]
enum KernelSpec {
    CompactPolynomial { degree: u32, scale: f64 },
    Cauchy { degree: u32, scale: f64 },
    Gaussian { scale: f64 },
}

impl TryFrom<KernelSpec> for Kernel {
    type Error = String;

    fn try_from(spec: KernelSpec) -> Result<Self, String> {
        let kernel = match spec {
            KernelSpec::CompactPolynomial { degree, scale } => {
                Self::CompactPolynomial { degree, scale }
            }
            KernelSpec::Cauchy { degree, scale } => Self::Cauchy { degree, scale },
            KernelSpec::Gaussian { scale } => Self::Gaussian { scale },
        };
        kernel.validate()?;
        Ok(kernel)
    }
}

impl Kernel {
    /// The same family and degree with the scale σ multiplied by `factor`.
    #[must_use]
    pub fn scaled(self, factor: f64) -> Self {
        match self {
            Self::CompactPolynomial { degree, scale } => Self::CompactPolynomial {
                degree,
                scale: scale * factor,
            },
            Self::Cauchy { degree, scale } => Self::Cauchy {
                degree,
                scale: scale * factor,
            },
            Self::Gaussian { scale } => Self::Gaussian {
                scale: scale * factor,
            },
        }
    }

    /// Checks degree and scale, and that the clipped support reaches past the prescribed
    /// radius. The file loader and `Scene::validate` both call it.
    ///
    /// # Errors
    /// The kernel, the value and the rule it breaks.
    pub fn validate(self) -> Result<(), String> {
        match self {
            Self::CompactPolynomial { degree, scale } => {
                if degree < 2 || degree % 2 == 1 || degree > 20 {
                    return Err(format!(
                        "compact polynomial kernel: degree {degree} must be even, between 2 and 20"
                    ));
                }
                if !(scale.is_finite() && scale > 1.0) {
                    return Err(format!(
                        "compact polynomial kernel: scale σ = {scale} must be finite and > 1"
                    ));
                }
            }
            Self::Cauchy { degree, scale } => {
                if !(1..=20).contains(&degree) {
                    return Err(format!(
                        "Cauchy kernel: degree {degree} must be between 1 and 20"
                    ));
                }
                if !(scale.is_finite() && scale > 0.0) {
                    return Err(format!(
                        "Cauchy kernel: scale σ = {scale} must be finite and > 0"
                    ));
                }
            }
            Self::Gaussian { scale } => {
                if !(scale.is_finite() && scale > 0.0) {
                    return Err(format!(
                        "Gaussian kernel: scale σ = {scale} must be finite and > 0"
                    ));
                }
            }
        }
        let support = self.support_sq().sqrt();
        if support <= 1.0 {
            return Err(format!(
                "{self:?}: the clipped support radius {support:.4} does not reach the prescribed \
                 radius (must be > 1); increase the scale"
            ));
        }
        // A support of more than a thousand radii makes every primitive cover the scene (and
        // at σ = 10³⁰⁸ it is infinite).
        if support.is_nan() || support > 1e3 {
            return Err(format!(
                "{self:?}: the clipped support radius {support:.4e} is more than 1000 times the \
                 prescribed radius; decrease the scale"
            ));
        }
        Ok(())
    }

    /// Squared normalised distance beyond which the kernel (clipped at [`CLIP_EPSILON`] where its
    /// support is infinite) vanishes: `σ²` for compact kernels, `σ²(ε^(−2/i) − 1)` for Cauchy,
    /// `σ² ln(1/ε)` for Gaussian. The field's profiles take it from here.
    #[must_use]
    pub fn support_sq(self) -> f64 {
        match self {
            Self::CompactPolynomial { scale, .. } => scale * scale,
            Self::Cauchy { degree, scale } => {
                let n = f64::from(degree) / 2.0;
                scale * scale * (CLIP_EPSILON.powf(-1.0 / n) - 1.0)
            }
            Self::Gaussian { scale } => scale * scale * (1.0 / CLIP_EPSILON).ln(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_kernels_are_rejected_with_their_values() {
        let odd = Kernel::try_from(KernelSpec::CompactPolynomial {
            degree: 5,
            scale: 2.0,
        });
        assert!(odd.is_err_and(|e| e.contains("degree 5")));
        let narrow = Kernel::try_from(KernelSpec::CompactPolynomial {
            degree: 6,
            scale: 1.0,
        });
        assert!(narrow.is_err_and(|e| e.contains("σ = 1")));
    }

    #[test]
    fn supports_reach_where_the_clipped_kernels_fall_to_epsilon() {
        for kernel in [
            Kernel::Cauchy {
                degree: 3,
                scale: 0.7,
            },
            Kernel::Gaussian { scale: 1.3 },
        ] {
            let r2 = kernel.support_sq();
            let k = match kernel {
                Kernel::Cauchy { degree, scale } => {
                    (1.0 + r2 / (scale * scale)).powf(-f64::from(degree) / 2.0)
                }
                Kernel::Gaussian { scale } => (-r2 / (scale * scale)).exp(),
                Kernel::CompactPolynomial { .. } => 0.0,
            };
            assert!((k - CLIP_EPSILON).abs() < 1e-12, "{kernel:?}: {k}");
        }
    }
}
