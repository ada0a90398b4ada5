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
//! nodes, so `K_N` is pentadiagonal on the node lattice. It is stored as three bands of one
//! value per node: `diag[i] = K_N(i, i)`, `upper1[i] = K_N(i, i+1)` and
//! `upper2[i] = K_N(i, i+2)`, node indices wrapped on periodic grids and entries past the
//! last node of a fixed grid zero. `E_p` is the particle's tangent modulus and
//! `V_p = F_p V_p⁰` its current volume, as in eq 56; constrained and inactive nodes are
//! included here (the operator drops them through `M`).
//!
//! Three separate arrays rather than one array of `[K(i,i+1), K(i,i+2)]` pairs: the
//! tracker's per-step pass ([`crate::stability::certified`]) reads the four off-diagonal
//! entries of a row of four nodes, `K(j, j+1)`, `K(j, j+2)`, `K(j−1, j)` and `K(j−2, j)`,
//! as four unaligned vector loads from the two bands, where the interleaved pairs took five
//! loads and eight shuffles (the pass measured 18 % faster; README "Stability").

/// The nodal stiffness of one state in band storage (module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodalStiffness {
    /// `K_N(i, i)`.
    pub diag: Vec<f64>,
    /// `K_N(i, i+1)` (wrapped on periodic grids; `0` past a fixed grid's last node).
    pub upper1: Vec<f64>,
    /// `K_N(i, i+2)` (wrapped on periodic grids; `0` past a fixed grid's last node).
    pub upper2: Vec<f64>,
    /// `max_p E_p/ρ_p`, the squared reference wave speed of the paper's normalisation of λmax.
    pub c2_ref: f64,
}

impl NodalStiffness {
    /// Number of nodes (the length of [`Self::diag`]).
    pub fn n_nodes(&self) -> usize {
        self.diag.len()
    }

    /// Whether the three bands have `n` entries each.
    pub fn has_len(&self, n: usize) -> bool {
        self.diag.len() == n && self.upper1.len() == n && self.upper2.len() == n
    }

    /// `[K_N(i, i+1), K_N(i, i+2)]`, row `i`'s couplings to the next two nodes.
    pub fn upper(&self, i: usize) -> [f64; 2] {
        [self.upper1[i], self.upper2[i]]
    }

    /// Every stored value, diagonal first, then `upper1`, then `upper2` (for validation).
    pub fn values(&self) -> impl Iterator<Item = &f64> {
        self.diag.iter().chain(&self.upper1).chain(&self.upper2)
    }
}
