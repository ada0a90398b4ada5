//! [`NodalStiffness`]: the nodal stiffness `K_N = Σ_p E_p V_p d_p d_pᵀ` a stepper may provide.
//!
//! The eq 56 critical step is `√(2/λmax(M^{1/2} K_N M^{1/2}))` (see
//! [`crate::stability::nodal`]): `K_N` is all the stability limit needs besides the nodal
//! masses. A solver's particle→grid pass already holds every particle's `D_ip` weights
//! (`d_p`, the column of `D` of particle `p`), so it can accumulate `K_N` there at the cost of
//! six products per particle, instead of the library rebuilding the weights of every state to
//! assemble it (about one solver step of work). A stepper that does so exposes it through
//! [`crate::View::nodal_stiffness`]; one that does not leaves it `None` and the library
//! assembles `K_N` from [`crate::View::weights`].
//!
//! **Storage (1D).** A particle touches at most [`crate::shape::MAX_NODES`] = 3 consecutive
//! nodes, so `K_N` is pentadiagonal on the node lattice: `diag[i] = K_N(i, i)` and
//! `off[i] = [K_N(i, i+1), K_N(i, i+2)]`, node indices wrapped on periodic grids and entries
//! past the last node of a fixed grid zero. `E_p` is the particle's tangent modulus and
//! `V_p = F_p V_p⁰` its current volume, as in eq 56; constrained and inactive nodes are
//! included here (the operator drops them through `M`).

/// The nodal stiffness of one state in band storage (module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodalStiffness {
    /// `K_N(i, i)`.
    pub diag: Vec<f64>,
    /// `[K_N(i, i+1), K_N(i, i+2)]` (wrapped on periodic grids).
    pub off: Vec<[f64; 2]>,
    /// `max_p E_p/ρ_p`, the squared reference wave speed of the paper's normalisation of λmax.
    pub c2_ref: f64,
}

impl NodalStiffness {
    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.diag.len()
    }
}
