//! The singular values of a 3×3 matrix in closed form ([`singular_values_3x3`]): the square
//! roots of the eigenvalues of `C = FᵀF`, found by the trigonometric solution of its
//! characteristic cubic (Smith 1961; Kopp 2008). About a tenth of an iterative SVD's cost,
//! which counts where a 3D solver forms the tangent pair of every particle in every step.

use nalgebra::Matrix3;

/// The singular values of `f`, unordered.
///
/// With `q = tr C/3`, `p = √(‖C − qI‖²_F/6)` and `r = det((C − qI)/p)/2 ∈ [−1, 1]`, the
/// eigenvalues of the symmetric `C` are `q + 2p cos(φ + 2πk/3)`, `φ = acos(r)/3`, `k = 0,
/// 1, 2` (the middle one as `3q` minus the other two). Each is accurate to a few units of
/// rounding of `‖C‖`, so a singular value `s` to about `ε‖F‖²/s` — far below what the
/// tangent bound's formulas resolve for any `F` a solver keeps (`J > 0`); an eigenvalue
/// that rounds below zero gives `s = 0`. Checked against nalgebra's SVD in the tests.
pub(super) fn singular_values_3x3(f: &Matrix3<f64>) -> [f64; 3] {
    let c = f.transpose() * f;
    let off = c[(0, 1)] * c[(0, 1)] + c[(0, 2)] * c[(0, 2)] + c[(1, 2)] * c[(1, 2)];
    let eig = if off == 0.0 {
        [c[(0, 0)], c[(1, 1)], c[(2, 2)]]
    } else {
        let q = c.trace() / 3.0;
        let (d0, d1, d2) = (c[(0, 0)] - q, c[(1, 1)] - q, c[(2, 2)] - q);
        let p = ((d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * off) / 6.0).sqrt();
        let b = (c - Matrix3::identity() * q) / p;
        let r = (b.determinant() / 2.0).clamp(-1.0, 1.0);
        let phi = r.acos() / 3.0;
        let top = q + 2.0 * p * phi.cos();
        let bottom = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
        [top, 3.0 * q - top - bottom, bottom]
    };
    eig.map(|e| e.max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_svd() {
        let mut uniform = super::super::uniform(0x2545_f491_4f6c_dd1d);
        let mut next = || uniform() - 0.5;
        let mut cases: Vec<Matrix3<f64>> = (0..3000)
            .map(|k| {
                let scale = [0.05, 0.5, 4.0][k % 3];
                Matrix3::identity() + Matrix3::from_fn(|_, _| scale * next())
            })
            .collect();
        // Repeated singular values: a rotation, a dilation, an axisymmetric stretch.
        let rotation = nalgebra::Rotation3::from_euler_angles(0.3, -1.1, 2.0).into_inner();
        cases.extend([
            rotation,
            rotation * 0.7,
            Matrix3::from_diagonal(&nalgebra::Vector3::new(1.2, 1.2, 0.8)) * rotation,
            Matrix3::zeros(),
        ]);
        for f in &cases {
            let mut svd: Vec<f64> = f.singular_values().iter().copied().collect();
            let mut ours = singular_values_3x3(f).to_vec();
            svd.sort_by(f64::total_cmp);
            ours.sort_by(f64::total_cmp);
            let scale = svd[2].max(1e-300);
            for (a, b) in ours.iter().zip(&svd) {
                // `ε‖F‖²/s` (module docs) with room, plus 10⁻¹² of the largest.
                let tol = 1e-12 * scale + 8.0 * f64::EPSILON * scale * scale / b.max(1e-300);
                assert!((a - b).abs() <= tol, "{f}: {ours:?} against {svd:?}");
            }
        }
    }
}
