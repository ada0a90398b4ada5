//! Particle–node basis functions in 1D: GIMP and classic linear hats.
//!
//! With the nodal hat `N_i(x) = max(0, 1 − |x − X_i|/h)`:
//!
//! * **Linear hat** (original MPM): `S_ip = N_i(x_p)`, `D_ip = N_i′(x_p)`. At a particle
//!   exactly on a node the one-sided derivative of the cell to the right is used.
//! * **GIMP** (the paper's choice, Section 3): the particle has a characteristic function
//!   `χ_p` of width `l_p` centred on `x_p`, and
//!   `S_ip = (1/l_p) ∫ N_i χ_p dx`, `D_ip = (1/l_p) ∫ N_i′ χ_p dx`.
//!   Both are evaluated in closed form through the antiderivative
//!   `Φ(r) = ∫_{−∞}^{r} N(s) ds` of the hat: `S_ip = (Φ(b − X_i) − Φ(a − X_i))/l_p` and
//!   `D_ip = (N_i(b) − N_i(a))/l_p` with `[a, b] = [x_p − l_p/2, x_p + l_p/2]`. With the
//!   first node `j = ⌊a/h⌋` and the domain ends in cell units `α = a/h − j ∈ [0, 1)`,
//!   `β = α + l_p/h < 2`, `β_c = min(β, 1)`, `β_e = max(β − 1, 0)`, `λ = l_p/h`, this is,
//!   for nodes `j, j+1, j+2`, without branches:
//!   `S = [(1−α)² − (1−β_c)², β_c² − α² + 2β_e − β_e², β_e²] / (2λ)` and
//!   `D = [α − β_c, β_c − β_e − α, β_e] / l_p`. This is exact for any `l_p ≤ h`.
//!
//! Both families reproduce constants and linears: `Σ_i S_ip = 1`, `Σ_i S_ip X_i = x_p`,
//! `Σ_i D_ip = 0`, `Σ_i D_ip X_i = 1` (the properties eqs 32–34 rely on).
//!
//! A particle touches at most [`MAX_NODES`] consecutive nodes, starting at lattice index
//! `⌊(x_p − l_p/2 − a)/h⌋` (GIMP) or `⌊(x_p − a)/h⌋` (linear); unused slots get weight 0.

use serde::{Deserialize, Serialize};

/// Most nodes one particle touches in 1D (GIMP with `l_p ≤ h`).
pub const MAX_NODES: usize = 3;

/// Which particle–node weights the method uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// Generalised interpolation material point weights with particle width `l_p`.
    Gimp,
    /// Classic linear-hat weights (`S = N_i(x_p)`): what many codes still use; small nodal
    /// masses make their critical step collapse.
    Linear,
}

/// The weights of one particle: first lattice node, and `S`, `D` for the
/// [`MAX_NODES`] consecutive nodes from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleStencil {
    /// Lattice index (unwrapped, may be negative) of the first node.
    pub first: i64,
    /// `S_ip` for nodes `first, first+1, first+2`.
    pub s: [f64; MAX_NODES],
    /// `D_ip` for nodes `first, first+1, first+2` (units 1/length).
    pub d: [f64; MAX_NODES],
}

/// `⌊q⌋` by truncation and correction: one conversion instead of a call to `floor` (the
/// x86-64 baseline has no rounding instruction, and the call was ~10 % of a solver step).
/// Equal to `q.floor()` for `|q| < 2⁶³`; NaN gives 0 (as `q.floor() as i64` does).
#[inline(always)]
fn floor_fast(q: f64) -> f64 {
    let t = q as i64 as f64;
    if t > q {
        t - 1.0
    } else {
        t
    }
}

impl Shape {
    /// Weights of a particle at `x` (relative to the grid origin) of GIMP width `width`
    /// (ignored by linear hats) on a grid of spacing `h`. Requires `0 < width ≤ h`.
    #[inline(always)]
    pub fn stencil(self, x: f64, width: f64, h: f64) -> ParticleStencil {
        let inv_h = 1.0 / h;
        match self {
            Shape::Gimp => {
                // Local coordinates of the domain ends in units of h, measured from the
                // first node j = ⌊(x − l/2)/h⌋: α ∈ [0, 1), β = α + l/h ∈ [α, 2).
                let lam = width * inv_h;
                let q = (x - 0.5 * width) * inv_h;
                let first = floor_fast(q);
                let alpha = q - first;
                let beta = alpha + lam;
                let bc = beta.min(1.0);
                let be = (beta - 1.0).max(0.0);
                let inv_lam = 1.0 / lam;
                let inv_l = inv_lam * inv_h;
                let (ma, mb) = (1.0 - alpha, 1.0 - bc);
                ParticleStencil {
                    first: first as i64,
                    s: [
                        0.5 * (ma * ma - mb * mb) * inv_lam,
                        (0.5 * (bc * bc - alpha * alpha) + be - 0.5 * be * be) * inv_lam,
                        0.5 * be * be * inv_lam,
                    ],
                    d: [(alpha - bc) * inv_l, (bc - be - alpha) * inv_l, be * inv_l],
                }
            }
            Shape::Linear => {
                let q = x * inv_h;
                let first = floor_fast(q);
                let f = q - first;
                ParticleStencil {
                    first: first as i64,
                    s: [1.0 - f, f, 0.0],
                    d: [-inv_h, inv_h, 0.0],
                }
            }
        }
    }
}
