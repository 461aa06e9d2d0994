//! Hermite radial basis function surfaces (forward inclusion 2023 eq. 9, Macêdo et al. 2011):
//! `h(p) = Σᵢ αᵢ φ(‖p − pᵢ‖) + βᵢ·∇φ(p − pᵢ) + a·p + b` with `φ(r) = r³`, interpolating
//! `h(pᵢ) = 0` and `∇h(pᵢ) = nᵢ` at points with outward normals. The `4N + 4` weights come from
//! one dense LU solve (nalgebra): `N` value and `3N` gradient conditions, and the four side
//! conditions `Σαᵢ = 0`, `Σ αᵢpᵢ + βᵢ = 0` that make the system square and the polynomial
//! part unique.
//!
//! In a scene, a set becomes the density `f = max(c − (c/ℓ)·h, 0)` (inside where `f ≥ c`, like
//! every other primitive), with `ℓ` a tenth of the points' bounding-box diagonal, so `|∇f| = c/ℓ`
//! on the points, and `f` vanishes where `h ≥ ℓ`: a non-negative density that blends with the
//! other groups like a kernel primitive. Since `h` grows like `r³` away from the points, the set
//! is evaluated only inside the points' box widened by [`HRBF_MARGIN`] of its diagonal on every
//! side (0 outside). A group holding a set holds nothing else, and is clamped as a whole.
//! The clamp is continuous; the box is where `f` has long reached 0 for a surface that closes
//! around its points (if a surface reaches the box, it is cut there).

use std::sync::{Arc, Mutex};

use glam::{DMat3, DVec3};
use nalgebra::{DMatrix, DVector};

use crate::field::geometry::Aabb;
use crate::model::scene::HrbfPoint;

/// Widening of the points' box, × its diagonal, on each side.
pub const HRBF_MARGIN: f64 = 0.3;
/// `ℓ` as a fraction of the points' box diagonal.
pub const HRBF_LENGTH: f64 = 0.1;

/// Solved weights of one HRBF set.
#[derive(Clone, Debug, PartialEq)]
pub struct HrbfWeights {
    /// The points `pᵢ`.
    pub centers: Vec<DVec3>,
    /// `αᵢ`.
    pub alpha: Vec<f64>,
    /// `βᵢ`.
    pub beta: Vec<DVec3>,
    /// `a`.
    pub linear: DVec3,
    /// `b`.
    pub constant: f64,
}

/// `∇φ(v) = 3‖v‖v` for `φ(r) = r³`.
fn grad_phi(v: DVec3) -> DVec3 {
    3.0 * v.length() * v
}

/// Hessian of `φ(‖v‖)`: `3(‖v‖I + vvᵀ/‖v‖)`, 0 at the origin.
fn hessian_phi(v: DVec3) -> DMat3 {
    let r = v.length();
    if r == 0.0 {
        return DMat3::ZERO;
    }
    3.0 * (DMat3::from_diagonal(DVec3::splat(r)) + DMat3::from_cols(v * v.x, v * v.y, v * v.z) / r)
}

/// Sets solved most recently, newest last, keyed by their points' exact bits (see
/// [`solve_shared`]).
static SOLVED: Mutex<Vec<(Vec<u64>, Arc<HrbfWeights>)>> = Mutex::new(Vec::new());

/// How many solved sets [`SOLVED`] keeps.
const SOLVED_KEPT: usize = 32;

/// [`solve`], shared: a set whose points are bit-for-bit those of a recently solved one gets
/// the same weights without a new solve. A 400-point set takes most of a second to solve, and
/// a scene is compiled on every edit of any group, so this keeps editing a scene with large
/// sets live.
///
/// # Errors
/// As [`solve`].
pub fn solve_shared(points: &[HrbfPoint]) -> Result<Arc<HrbfWeights>, String> {
    let key: Vec<u64> = points
        .iter()
        .flat_map(|p| p.position.into_iter().chain(p.normal))
        .map(f64::to_bits)
        .collect();
    // A poisoned lock only means another thread panicked mid-update; entries are whole.
    let lock = || {
        SOLVED
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    };
    {
        let mut solved = lock();
        if let Some(i) = solved.iter().position(|(k, _)| *k == key) {
            let entry = solved.remove(i);
            let weights = entry.1.clone();
            solved.push(entry);
            return Ok(weights);
        }
    }
    let weights = Arc::new(solve(points)?);
    let mut solved = lock();
    if solved.len() >= SOLVED_KEPT {
        solved.remove(0);
    }
    solved.push((key, weights.clone()));
    Ok(weights)
}

/// Solves the interpolation system.
///
/// # Errors
/// Fewer than one point, a zero normal, or a singular system (repeated points).
pub fn solve(points: &[HrbfPoint]) -> Result<HrbfWeights, String> {
    let n = points.len();
    if n == 0 {
        return Err("an HRBF set needs at least one point".to_owned());
    }
    let centers: Vec<DVec3> = points.iter().map(|p| DVec3::from(p.position)).collect();
    let mut normals = Vec::with_capacity(n);
    for (i, p) in points.iter().enumerate() {
        let v = DVec3::from(p.normal);
        if v.length() == 0.0 || !v.is_finite() {
            return Err(format!("HRBF point {i}: the normal must not be (0, 0, 0)"));
        }
        normals.push(v.normalize());
    }
    // Unknowns: α (n), β (3n), a (3), b (1).
    let size = 4 * n + 4;
    let (beta0, a0, b0) = (n, 4 * n, 4 * n + 3);
    let mut m = DMatrix::<f64>::zeros(size, size);
    let mut rhs = DVector::<f64>::zeros(size);
    for (j, &pj) in centers.iter().enumerate() {
        // h(pⱼ) = 0
        let row = j;
        for (i, &pi) in centers.iter().enumerate() {
            let v = pj - pi;
            m[(row, i)] = v.length().powi(3);
            let g = grad_phi(v);
            for k in 0..3 {
                m[(row, beta0 + 3 * i + k)] = g[k];
            }
        }
        for k in 0..3 {
            m[(row, a0 + k)] = pj[k];
        }
        m[(row, b0)] = 1.0;
        // ∇h(pⱼ) = nⱼ
        for k in 0..3 {
            let row = n + 3 * j + k;
            for (i, &pi) in centers.iter().enumerate() {
                let v = pj - pi;
                m[(row, i)] = grad_phi(v)[k];
                let h = hessian_phi(v);
                for l in 0..3 {
                    m[(row, beta0 + 3 * i + l)] = h.col(l)[k];
                }
            }
            m[(row, a0 + k)] = 1.0;
            rhs[row] = normals[j][k];
        }
    }
    // Side conditions: Σαᵢ = 0 and Σ αᵢpᵢ + βᵢ = 0.
    for (i, &pi) in centers.iter().enumerate() {
        m[(a0, i)] = 1.0;
        for k in 0..3 {
            m[(a0 + 1 + k, i)] = pi[k];
            m[(a0 + 1 + k, beta0 + 3 * i + k)] = 1.0;
        }
    }
    let x = m
        .lu()
        .solve(&rhs)
        .filter(|x| x.iter().all(|v| v.is_finite()))
        .ok_or_else(|| {
            "the HRBF system is singular (two points at the same position?)".to_owned()
        })?;
    Ok(HrbfWeights {
        alpha: x.rows(0, n).iter().copied().collect(),
        beta: (0..n)
            .map(|i| DVec3::new(x[beta0 + 3 * i], x[beta0 + 3 * i + 1], x[beta0 + 3 * i + 2]))
            .collect(),
        linear: DVec3::new(x[a0], x[a0 + 1], x[a0 + 2]),
        constant: x[b0],
        centers,
    })
}

impl HrbfWeights {
    /// `h(p)` and `∇h(p)`.
    #[must_use]
    pub fn value_gradient(&self, p: DVec3) -> (f64, DVec3) {
        let mut value = self.linear.dot(p) + self.constant;
        let mut gradient = self.linear;
        for ((&c, &alpha), &beta) in self.centers.iter().zip(&self.alpha).zip(&self.beta) {
            let v = p - c;
            let g = grad_phi(v);
            value += alpha * v.length().powi(3) + beta.dot(g);
            gradient += alpha * g + hessian_phi(v) * beta;
        }
        (value, gradient)
    }

    /// Diagonal of the points' box (at least 10⁻³, for a single point).
    fn extent(&self) -> f64 {
        self.centers
            .iter()
            .fold(Aabb::EMPTY, |acc, &c| acc.union(Aabb::ball(c, 0.0)))
            .diagonal()
            .max(1e-3)
    }

    /// The box the set is evaluated in: the points' box widened by [`HRBF_MARGIN`].
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        let b = self
            .centers
            .iter()
            .fold(Aabb::EMPTY, |acc, &c| acc.union(Aabb::ball(c, 0.0)));
        let pad = DVec3::splat(HRBF_MARGIN * self.extent());
        Aabb {
            min: b.min - pad,
            max: b.max + pad,
        }
    }

    /// `ℓ`: the length over which `f` drops by `c` along a normal.
    #[must_use]
    pub fn length_scale(&self) -> f64 {
        HRBF_LENGTH * self.extent()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere_points(n: usize, radius: f64) -> Vec<HrbfPoint> {
        (0..n)
            .map(|i| {
                let t = i as f64 * 2.399_963;
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let p = [r * t.cos(), r * t.sin(), z];
                HrbfPoint {
                    position: p.map(|x| radius * x),
                    normal: p,
                }
            })
            .collect()
    }

    #[test]
    fn equal_sets_share_one_solve_and_a_moved_point_solves_again() {
        let points = sphere_points(12, 1.3);
        let first = solve_shared(&points).unwrap_or_else(|e| panic!("{e}"));
        let again = solve_shared(&points.clone()).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            Arc::ptr_eq(&first, &again),
            "the same points are solved once"
        );
        assert_eq!(*first, solve(&points).unwrap_or_else(|e| panic!("{e}")));
        let mut moved = points;
        moved[3].position[0] += 1e-9;
        let other = solve_shared(&moved).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            !Arc::ptr_eq(&first, &other),
            "a moved point needs a new solve"
        );
        assert_eq!(*other, solve(&moved).unwrap_or_else(|e| panic!("{e}")));
    }
}
