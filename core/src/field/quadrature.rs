//! Gauss–Legendre quadrature on `[a, b]`, the rule MATH.md §3 recommends for the SCALIS
//! integral. Nodes are computed once per order by Newton iteration on the Legendre polynomial.

use std::sync::OnceLock;

/// Number of nodes of the rule used for SCALIS segments (MATH.md §3: ≤ 6e-11 relative error
/// up to a radius ratio of 21 when integrating in `ln τ`).
pub const SCALIS_ORDER: usize = 12;

/// Nodes and weights of the Gauss–Legendre rule on `[-1, 1]`.
#[derive(Debug)]
pub struct GaussLegendre {
    /// Abscissae in `[-1, 1]`, increasing.
    pub nodes: Vec<f64>,
    /// Weights, summing to 2.
    pub weights: Vec<f64>,
}

impl GaussLegendre {
    /// Builds the `n`-point rule.
    #[must_use]
    pub fn new(n: usize) -> Self {
        let mut nodes = vec![0.0; n];
        let mut weights = vec![0.0; n];
        let nf = n as f64;
        for i in 0..n.div_ceil(2) {
            // Tricomi's initial guess, then Newton on P_n.
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..100 {
                let (p, dp) = legendre(n, x);
                derivative = dp;
                let dx = p / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let (_, dp) = legendre(n, x);
            derivative = if dp == 0.0 { derivative } else { dp };
            let w = 2.0 / ((1.0 - x * x) * derivative * derivative);
            nodes[i] = -x;
            nodes[n - 1 - i] = x;
            weights[i] = w;
            weights[n - 1 - i] = w;
        }
        Self { nodes, weights }
    }

    /// The shared 12-point rule.
    #[must_use]
    pub fn scalis() -> &'static Self {
        Self::with_nodes(SCALIS_ORDER)
    }

    /// The rule with the fewest nodes that integrates polynomials of `degree` exactly
    /// (`⌈(degree + 1)/2⌉` nodes; up to degree 23, the 12-point rule past it).
    #[must_use]
    pub fn exact_for_degree(degree: usize) -> &'static Self {
        Self::with_nodes((degree + 1).div_ceil(2))
    }

    /// The shared `n`-point rule, for `n` from 1 to [`SCALIS_ORDER`] (clamped to that range).
    #[must_use]
    pub fn with_nodes(n: usize) -> &'static Self {
        const MOST: usize = SCALIS_ORDER;
        static RULES: [OnceLock<GaussLegendre>; MOST] = [const { OnceLock::new() }; MOST];
        let n = n.clamp(1, MOST);
        RULES[n - 1].get_or_init(|| Self::new(n))
    }

    /// `∫_a^b g` by this rule, split into `panels` equal panels.
    pub fn integrate(&self, a: f64, b: f64, panels: usize, mut g: impl FnMut(f64) -> f64) -> f64 {
        let panels = panels.max(1);
        let h = (b - a) / panels as f64;
        let mut sum = 0.0;
        for p in 0..panels {
            let mid = a + (p as f64 + 0.5) * h;
            for (x, w) in self.nodes.iter().zip(&self.weights) {
                sum += w * g(mid + 0.5 * h * x);
            }
        }
        0.5 * h * sum
    }
}

/// Legendre polynomial `P_n(x)` and its derivative.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    let nf = n as f64;
    (p1, nf * (x * p1 - p0) / (x * x - 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_smallest_exact_rule_integrates_its_degree_exactly() {
        for degree in 0..=23 {
            let rule = GaussLegendre::exact_for_degree(degree);
            assert_eq!(
                rule.nodes.len(),
                (degree + 1).div_ceil(2).max(1),
                "{degree}"
            );
            // ∫_{-1}^{3} (t + 0.5)^degree
            let exact = (3.5_f64.powi(degree as i32 + 1) - (-0.5_f64).powi(degree as i32 + 1))
                / (degree as f64 + 1.0);
            let got = rule.integrate(-1.0, 3.0, 1, |t| (t + 0.5).powi(degree as i32));
            assert!(
                (got - exact).abs() < 1e-12 * exact.abs().max(1.0),
                "{degree}: {got} vs {exact}"
            );
        }
    }

    #[test]
    fn integrates_polynomials_of_degree_2n_minus_1_exactly() {
        let rule = GaussLegendre::new(6);
        let exact = 2.0_f64.powi(12) / 12.0; // ∫_0^2 t^11
        let got = rule.integrate(0.0, 2.0, 1, |t| t.powi(11));
        assert!((got - exact).abs() < 1e-12 * exact, "{got} vs {exact}");
        assert!((rule.weights.iter().sum::<f64>() - 2.0).abs() < 1e-14);
    }
}
