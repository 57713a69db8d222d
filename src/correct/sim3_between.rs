//! The Sim(3) between factor of the pose graph: apex-solver's
//! `BetweenFactor<Sim3>` with the logarithm's Jacobian by eight-node
//! Gauss-Legendre quadrature.
//!
//! The residual of an edge `i -> j` measuring `i_T_j` is
//! `r = log((world_T_j⁻¹ world_T_i) · i_T_j)`, and its Jacobian the chain
//! of the between's and the composition's adjoints with the logarithm's,
//! the inverse of the right Jacobian
//!
//! ```text
//! J_r(ξ) = ∫₀¹ Ad(exp(-t ξ)) dt.
//! ```
//!
//! apex-manifolds integrates it by Simpson's rule on 256 intervals (257
//! exponentials and adjoints per edge and iteration: 80 % of a Sim(3)
//! solve). Its integrand is built from `sin`, `cos` and `exp` of `t θ` and
//! `t σ` times polynomials of degree two in `t`, and eight Gauss-Legendre
//! nodes (exact to degree 15) integrate it to 1e-9 of apex's own for
//! rotations up to 3.1 rad and scales from e⁻¹ to e
//! (`matches_apex_right_jacobian`). The residual is apex's, so the optimum
//! is the same; only the steps towards it use the quadrature.

use apex_solver::manifold::sim3::{Sim3, Sim3Tangent};
use apex_solver::manifold::{LieGroup, Tangent};
use faer::prelude::ReborrowMut;
use nalgebra_apex::SMatrix;

type Matrix7 = SMatrix<f64, 7, 7>;

/// Gauss-Legendre nodes on [0, 1] and their weights, eight of them: exact
/// for polynomials up to degree 15, and within 1e-9 of apex's 257-point
/// integral for rotations up to 3.1 rad (`matches_apex_right_jacobian`),
/// so the steps are apex's own at a thirtieth of the exponentials.
const NODES: [(f64, f64); 8] = [
    (0.019_855_071_751_231_856, 0.050_614_268_145_188_13),
    (0.101_666_761_293_186_6, 0.111_190_517_226_687_24),
    (0.237_233_795_041_835_5, 0.156_853_322_938_943_65),
    (0.408_282_678_752_175_1, 0.181_341_891_689_180_98),
    (0.591_717_321_247_825, 0.181_341_891_689_180_98),
    (0.762_766_204_958_164_5, 0.156_853_322_938_943_65),
    (0.898_333_238_706_813_4, 0.111_190_517_226_687_24),
    (0.980_144_928_248_768_1, 0.050_614_268_145_188_13),
];

/// `J_r(ξ)` of Sim(3) by [`NODES`].
pub(super) fn right_jacobian(xi: &Sim3Tangent) -> Matrix7 {
    let (rho, theta, sigma) = (xi.rho(), xi.theta(), xi.sigma());
    NODES.iter().fold(Matrix7::zeros(), |sum, &(t, w)| {
        let at = Sim3Tangent::new(rho * -t, theta * -t, sigma * -t);
        sum + at.exp(None).adjoint() * w
    })
}

/// The between factor of one edge, `i_T_j` measured.
pub(super) struct Sim3Between {
    measured: Sim3,
}

impl Sim3Between {
    pub(super) fn new(measured: Sim3) -> Self {
        Self { measured }
    }
}

impl apex_solver::Factor for Sim3Between {
    fn linearize(
        &self,
        params: &[&[f64]],
        residual: &mut [f64],
        jacobian: Option<faer::mat::MatMut<'_, f64>>,
    ) {
        let world_T_i = Sim3::from_param_slice(params[0]);
        let world_T_j = Sim3::from_param_slice(params[1]);
        let (mut d_j, mut d_i, mut d_between) =
            (Matrix7::zeros(), Matrix7::zeros(), Matrix7::zeros());
        let j_T_i = world_T_j.between(&world_T_i, Some(&mut d_j), Some(&mut d_i));
        let miss = j_T_i.compose(&self.measured, Some(&mut d_between), None);
        let r = miss.log(None);
        residual[..7].copy_from_slice(r.as_slice());
        let Some(mut jac) = jacobian else {
            return;
        };
        let jr = right_jacobian(&r);
        // apex's own fallback where J_r is singular (θ at 2π): the identity.
        let d_log = jr.try_inverse().unwrap_or_else(Matrix7::identity);
        let (wrt_i, wrt_j) = (d_log * d_between * d_i, d_log * d_between * d_j);
        for row in 0..7 {
            for col in 0..7 {
                *jac.rb_mut().get_mut(row, col) = wrt_i[(row, col)];
                *jac.rb_mut().get_mut(row, col + 7) = wrt_j[(row, col)];
            }
        }
    }

    fn residual_dim(&self) -> usize {
        7
    }

    fn jacobian_shape(&self) -> (usize, usize) {
        (7, 14)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra_apex::Vector3;

    /// Tangents over the range a pose graph's residuals reach: rotations
    /// up to just below π, scales e^±1, translations of a hundred units.
    fn tangents() -> Vec<Sim3Tangent> {
        let mut out = Vec::new();
        for (k, &angle) in [0.0, 1e-6, 0.3, 1.5, 2.5, 3.1].iter().enumerate() {
            for &sigma in &[0.0, -1.0, 0.4, 1.0] {
                let axis = Vector3::new(1.0, -2.0 + k as f64, 0.5).normalize();
                let rho = Vector3::new(100.0, -3.0, 0.2 * k as f64);
                out.push(Sim3Tangent::new(rho, axis * angle, sigma));
            }
        }
        out
    }

    #[test]
    fn matches_apex_right_jacobian() {
        for xi in tangents() {
            let ours = right_jacobian(&xi);
            let apex = xi.right_jacobian();
            let scale = apex.abs().max().max(1.0);
            let off = (ours - apex).abs().max() / scale;
            assert!(off < 1e-9, "{xi}: off by {off:e} of {scale}");
        }
    }

    #[test]
    fn linearizes_as_apex_between_factor() {
        use apex_solver::factors::pose::BetweenFactor;
        use apex_solver::Factor;
        let measured = Sim3Tangent::new(
            Vector3::new(2.0, 0.5, -1.0),
            Vector3::new(0.1, 0.4, -0.2),
            0.1,
        )
        .exp(None);
        let ours = Sim3Between::new(measured.clone());
        let apex = BetweenFactor::new(measured);
        for (a, b) in tangents().iter().zip(tangents().iter().rev()) {
            let (i, j) = (a.exp(None), b.exp(None));
            let params = [i.as_param_slice(), j.as_param_slice()];
            let mut results = Vec::new();
            for factor in [&ours as &dyn Factor, &apex as &dyn Factor] {
                let mut r = vec![0.0; 7];
                let mut jac = faer::Mat::<f64>::zeros(7, 14);
                factor.linearize(&params, &mut r, Some(jac.as_mut()));
                results.push((r, jac));
            }
            let (r0, j0) = &results[0];
            let (r1, j1) = &results[1];
            assert_eq!(r0, r1);
            for row in 0..7 {
                for col in 0..14 {
                    let (x, y) = (j0[(row, col)], j1[(row, col)]);
                    assert!(
                        (x - y).abs() <= 1e-7 * y.abs().max(1.0),
                        "{row},{col}: {x} vs {y}"
                    );
                }
            }
        }
    }
}
