//! The eq 56 operator `D*F`, applied matrix-free in `O(nnz)` and assembled densely.
//!
//! ```text
//! A = I − dt² 𝐄 K 𝐕,   K = Dᵀ M D,   M = diag(1/m_i) over active nodes      (eq 56)
//! B = diag(s) K diag(s),   s_p = √(E_p V_p),   V_p = F_p V_p⁰                (symmetric, PSD)
//! ```
//!
//! `A` is similar to `I − dt² B` (see the [module guide](super)), so everything about its
//! spectrum is read from `B`, which is symmetric and is applied without forming it:
//! `y = s ∘ Dᵀ (M (D (s ∘ x)))` — one scatter and one gather over the stored weights, i.e.
//! `O(nnz)` with `nnz ≤ 3 n_p` in 1D. The paper's `D*F = h² K 𝐕` is `h²/E` times `B`'s
//! similarity class for a uniform `E`.

use super::error::{check_view, StabilityError};
use crate::stepper::View;
use crate::weights::Weights;
use faer::Mat;

/// The symmetric form `B` of the eq 56 operator on one state, ready to apply.
///
/// Built from any [`View`]; keeps `s_p = √(E_p V_p)` and `1/m_i` (0 at inactive and
/// constrained nodes) and borrows the view's weights.
#[derive(Clone, Debug)]
pub struct Eq56Operator<'a> {
    weights: &'a Weights,
    h: f64,
    scale: Vec<f64>,
    inv_mass: Vec<f64>,
    c2_ref: f64,
    modulus: &'a [f64],
    f: &'a [f64],
    volume0: &'a [f64],
}

impl<'a> Eq56Operator<'a> {
    /// The operator of the state `view`. Fails with a typed error on NaN or non-positive
    /// moduli, volumes, densities, on an active node with non-positive mass, and when no
    /// node is active.
    pub fn new(view: &View<'a>) -> Result<Self, StabilityError> {
        check_view(view)?;
        let scale = view
            .tangent_modulus
            .iter()
            .zip(view.f.iter().zip(view.volume0))
            .map(|(e, (f, v0))| (e * f * v0).sqrt())
            .collect();
        let inv_mass = view
            .node_mass
            .iter()
            .zip(view.node_active)
            .map(|(&m, &a)| if a { 1.0 / m } else { 0.0 })
            .collect();
        let c2_ref = view
            .tangent_modulus
            .iter()
            .zip(view.density)
            .map(|(e, r)| e / r)
            .fold(0.0, f64::max);
        Ok(Self {
            weights: view.weights.get(),
            h: view.grid.h,
            scale,
            inv_mass,
            c2_ref,
            modulus: view.tangent_modulus,
            f: view.f,
            volume0: view.volume0,
        })
    }

    /// Dimension (number of particles).
    pub fn dim(&self) -> usize {
        self.scale.len()
    }

    /// Grid spacing `h`.
    pub fn h(&self) -> f64 {
        self.h
    }

    /// `c²_ref = max_p E_p/ρ_p`, the squared wave speed used to report λmax in the paper's
    /// normalisation.
    pub fn c2_ref(&self) -> f64 {
        self.c2_ref
    }

    /// Per-particle moduli `E_p`.
    pub fn modulus(&self) -> &[f64] {
        self.modulus
    }

    /// Current volume `V_p = F_p V_p⁰` of particle `p`.
    pub fn volume(&self, p: usize) -> f64 {
        self.f[p] * self.volume0[p]
    }

    /// `1/m_i` at active nodes, 0 elsewhere (the diagonal `M` of eq 56).
    pub fn inv_mass(&self) -> &[f64] {
        &self.inv_mass
    }

    /// The weights the operator reads.
    pub fn weights(&self) -> &Weights {
        self.weights
    }

    /// `y = B x` in `O(nnz)`; `work` must have one slot per node.
    pub fn apply(&self, x: &[f64], y: &mut [f64], work: &mut [f64]) {
        let w = self.weights;
        work.iter_mut().for_each(|v| *v = 0.0);
        for (p, (&xp, &sp)) in x.iter().zip(&self.scale).enumerate() {
            let u = xp * sp;
            for (&i, &d) in w.nodes_of(p).iter().zip(w.d_of(p)) {
                work[i as usize] += d * u;
            }
        }
        for (v, &im) in work.iter_mut().zip(&self.inv_mass) {
            *v *= im;
        }
        for (p, (yp, &sp)) in y.iter_mut().zip(&self.scale).enumerate() {
            let g: f64 = w
                .nodes_of(p)
                .iter()
                .zip(w.d_of(p))
                .map(|(&i, &d)| d * work[i as usize])
                .sum();
            *yp = sp * g;
        }
    }

    /// An upper bound on `λmax(B)` by Gershgorin's theorem, in `O(nnz)`:
    /// `λmax(B) ≤ max_p s_p Σ_i |D_ip| (1/m_i) Σ_q |D_iq| s_q`. A guard against an
    /// iterative estimate missing the top of the spectrum; not tight.
    pub fn gershgorin_bound(&self) -> f64 {
        let w = self.weights;
        let mut node = vec![0.0; self.inv_mass.len()];
        for (p, &sp) in self.scale.iter().enumerate() {
            for (&i, &d) in w.nodes_of(p).iter().zip(w.d_of(p)) {
                node[i as usize] += d.abs() * sp;
            }
        }
        for (v, &im) in node.iter_mut().zip(&self.inv_mass) {
            *v *= im;
        }
        (0..self.dim())
            .map(|p| {
                self.scale[p]
                    * w.nodes_of(p)
                        .iter()
                        .zip(w.d_of(p))
                        .map(|(&i, &d)| d.abs() * node[i as usize])
                        .sum::<f64>()
            })
            .fold(0.0, f64::max)
    }

    /// The dense `n_p × n_p` matrix `K = Dᵀ M D` (faer).
    pub fn dense_k(&self) -> Mat<f64> {
        let n = self.dim();
        let w = self.weights;
        let mut k = Mat::<f64>::zeros(n, n);
        // Group particles by node: K_pq = Σ_i D_ip D_iq / m_i.
        let mut by_node: Vec<Vec<(usize, f64)>> = vec![Vec::new(); self.inv_mass.len()];
        for p in 0..n {
            for (&i, &d) in w.nodes_of(p).iter().zip(w.d_of(p)) {
                if d != 0.0 && self.inv_mass[i as usize] != 0.0 {
                    by_node[i as usize].push((p, d));
                }
            }
        }
        for (i, list) in by_node.iter().enumerate() {
            let im = self.inv_mass[i];
            for &(p, dp) in list {
                for &(q, dq) in list {
                    k[(p, q)] += dp * im * dq;
                }
            }
        }
        k
    }

    /// The dense symmetric `B = diag(s) K diag(s)`.
    pub fn dense_b(&self) -> Mat<f64> {
        let k = self.dense_k();
        Mat::from_fn(self.dim(), self.dim(), |p, q| {
            self.scale[p] * k[(p, q)] * self.scale[q]
        })
    }

    /// The dense amplification matrix `A = I − dt² 𝐄 K 𝐕` of eq 56 (not symmetric unless
    /// `E_p V_p` is uniform).
    pub fn dense_amplification(&self, dt: f64) -> Mat<f64> {
        let k = self.dense_k();
        let n = self.dim();
        Mat::from_fn(n, n, |p, q| {
            let delta = if p == q { 1.0 } else { 0.0 };
            delta - dt * dt * self.modulus[p] * k[(p, q)] * self.volume(q)
        })
    }

    /// `λmax(B)` from a dense self-adjoint eigen-decomposition (small problems, tests).
    pub fn dense_lambda_max(&self) -> Result<f64, StabilityError> {
        let ev = self
            .dense_b()
            .self_adjoint_eigenvalues(faer::Side::Lower)
            .map_err(|_| StabilityError::NoConvergence {
                what: "self-adjoint eigenvalues",
            })?;
        Ok(ev.last().copied().unwrap_or(0.0).max(0.0))
    }

    /// λmax in the paper's normalisation, `λ̂ = h² λmax(B)/c²_ref` (4 on uniform GIMP
    /// layouts; the paper's `λmax(D*F)` with `ρ = 1`).
    pub fn normalised(&self, lambda_b: f64) -> f64 {
        self.h * self.h * lambda_b / self.c2_ref
    }

    /// The eq 56 critical step `√(2/λmax(B)) = h √(2/(c²_ref λ̂))` (infinite if `λ = 0`).
    pub fn critical_dt(lambda_b: f64) -> f64 {
        if lambda_b > 0.0 {
            (2.0 / lambda_b).sqrt()
        } else {
            f64::INFINITY
        }
    }
}

/// `‖A‖₂`, the spectral norm (largest singular value) of a dense matrix.
pub fn spectral_norm(a: &Mat<f64>) -> Result<f64, StabilityError> {
    let sv = a
        .singular_values()
        .map_err(|_| StabilityError::NoConvergence {
            what: "singular values",
        })?;
    Ok(sv.first().copied().unwrap_or(0.0))
}
