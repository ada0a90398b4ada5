//! The eq 56 operator reduced to the nodes: `λmax` from an `n_nodes × n_nodes` banded matrix.
//!
//! ```text
//! B = Gᵀ G,   G = M^{1/2} D diag(s),   s_p = √(E_p V_p)         (n_nodes × n_particles)
//! C = G Gᵀ = M^{1/2} K_N M^{1/2},      K_N = Σ_p E_p V_p d_p d_pᵀ   (nodal stiffness)
//! ```
//!
//! `B` is the symmetric form of the eq 56 operator ([`super::operator`]): `A = I − dt² 𝐄 K 𝐕`
//! with `K = Dᵀ M D` is similar to `I − dt² B`. For any matrix `G` the products `GᵀG` and
//! `GGᵀ` have the same non-zero eigenvalues (with multiplicity), so
//!
//! ```text
//! λmax(B) = λmax(C),   and   C u = λ u  ⇒  B (Gᵀu) = λ (Gᵀu).
//! ```
//!
//! `C` lives on the nodes, and in 1D it is banded: a particle touches at most
//! [`MAX_NODES`](crate::shape::MAX_NODES) = 3 consecutive nodes, so `K_N` couples a node with
//! its neighbours at lattice distance 1 and 2 only (pentadiagonal, wrapped on periodic
//! grids). Applying `C` costs `O(5 n_nodes)` with no indirection, against a scatter and a
//! gather over `3 n_particles` weights for `B`; building `K_N` is one pass over the particles'
//! `D` weights (6 products each). `M = diag(1/m_i)` over the *active* nodes only (inactive and
//! constrained nodes get `M_ii = 0`, exactly as in `B`), so their rows and columns of `C` are
//! zero and add only zero eigenvalues.
//!
//! `K_N` is the 1D linear-elastic *nodal stiffness matrix* of the current configuration
//! (`∫ E N_i′ N_j′ dV` by particle quadrature), and `C` its mass-scaled form: the eq 56 bound
//! is the classical `dt ≤ 2/ω_max` of the lumped-mass nodal system — which is why the critical
//! step collapses with a small nodal mass `m_i` (linear hats) wherever `K_N,ii` does not shrink
//! with it.
//!
//! In 2D/3D the same reduction holds with `K_N` a sparse nodal matrix of the stencil's
//! bandwidth; only the storage here is 1D.

use super::error::{all_finite, check_nodes, check_view, StabilityError};
use super::lambda_max::SymmetricOperator;
use crate::grid::Boundary;
use crate::nodal_stiffness::NodalStiffness;
use crate::stepper::View;

/// The nodal form `C = M^{1/2} K_N M^{1/2}` of the eq 56 operator on one state (module docs).
///
/// `C` is stored as three bands on the nodes: the diagonal and the couplings to the next node
/// and the one after (as pairs per node), wrapped on periodic grids. `K_N` itself
/// is read from the view when the stepper provides it and assembled here only otherwise.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodalOperator {
    /// `K_N` assembled from the view's weights, when the view does not carry the stepper's.
    assembled: NodalStiffness,
    /// `1/√m_i` at active nodes, 0 elsewhere.
    scale: Vec<f64>,
    /// The bands of `C` itself: `C_ii = K_N(i, i)/m_i` …
    c_diag: Vec<f64>,
    /// … and `[C(i, i+1), C(i, i+2)] = K_N(i, i+o)/√(m_i m_{i+o})`, so that an application
    /// is one pass with five products per node.
    c_off: Vec<[f64; 2]>,
    /// `(i, C_ii)` of the largest diagonal entry (see `diagonal_max`).
    diag_max: Option<(usize, f64)>,
    periodic: bool,
    h: f64,
    c2_ref: f64,
}

/// The bands of `C = M^{1/2} K_N M^{1/2}` from `K_N` and `scale = 1/√m` (0 at inactive nodes),
/// and the largest diagonal entry.
fn scale_bands(
    k: &NodalStiffness,
    scale: &[f64],
    periodic: bool,
    c_diag: &mut Vec<f64>,
    c_off: &mut Vec<[f64; 2]>,
) -> Option<(usize, f64)> {
    let n = k.diag.len();
    c_diag.clear();
    c_diag.extend(k.diag.iter().zip(scale).map(|(k, s)| k * s * s));
    c_off.clear();
    c_off.resize(n, [0.0; 2]);
    // Rows with both neighbours in range need no wrap test (every row but the last two).
    let inner = n.saturating_sub(2);
    let uppers = k.upper1[..inner].iter().zip(&k.upper2[..inner]);
    for (i, (c, (&u1, &u2))) in c_off[..inner].iter_mut().zip(uppers).enumerate() {
        let (s0, s1, s2) = (scale[i], scale[i + 1], scale[i + 2]);
        *c = [u1 * s0 * s1, u2 * s0 * s2];
    }
    for i in inner..n {
        for (o, (c, kk)) in c_off[i].iter_mut().zip(k.upper(i)).enumerate() {
            if let Some(j) = neighbour(n, periodic, i, o + 1) {
                *c = kk * scale[i] * scale[j];
            }
        }
    }
    c_diag
        .iter()
        .copied()
        .enumerate()
        .fold(None, |best: Option<(usize, f64)>, (i, c)| match best {
            Some((_, b)) if b >= c => best,
            _ => Some((i, c)),
        })
}

/// Node `i + o` of `n` (wrapped on periodic grids, `None` past a fixed grid's last node).
#[inline]
fn neighbour(n: usize, periodic: bool, i: usize, o: usize) -> Option<usize> {
    let j = i + o;
    if j < n {
        Some(j)
    } else if periodic {
        Some(j - n)
    } else {
        None
    }
}

impl NodalOperator {
    /// The nodal operator of the state `view`: from the stepper's [`crate::NodalStiffness`]
    /// when the view carries one (`O(n_nodes)`), else assembled from its `D` weights in
    /// `O(nnz)`.
    /// Fails with a typed error on NaN or non-positive moduli, volumes, densities, on an
    /// active node with non-positive mass, when no node is active, and when a particle's
    /// stencil couples nodes more than two lattice cells apart (not a 1D MPM stencil).
    pub fn new(view: &View<'_>) -> Result<Self, StabilityError> {
        let mut op = Self::default();
        op.rebuild(view)?;
        Ok(op)
    }

    /// Rebuilds `self` for the state `view`, reusing its allocations.
    ///
    /// Validation follows what is read: with the stepper's `K_N` only the nodal fields and
    /// `K_N` itself (finite) are checked — the particle fields are neither read here nor
    /// worth a second full scan per step — otherwise the whole view, as [`Self::new`] describes.
    pub fn rebuild(&mut self, view: &View<'_>) -> Result<(), StabilityError> {
        match view.nodal_stiffness {
            Some(k) => {
                check_nodes(view)?;
                if !(all_finite(&k.diag) && all_finite(&k.upper1) && all_finite(&k.upper2)) {
                    // `index` counts through the diagonal, then `upper1`, then `upper2`.
                    if let Some((index, &value)) =
                        k.values().enumerate().find(|(_, v)| !v.is_finite())
                    {
                        return Err(StabilityError::InvalidField {
                            field: "nodal_stiffness",
                            index,
                            value,
                        });
                    }
                }
            }
            None => check_view(view)?,
        }
        let n = view.n_nodes();
        let periodic = view.grid.boundary == Boundary::Periodic;
        self.periodic = periodic;
        self.h = view.grid.h;
        self.scale.clear();
        // Branch-free (so that it vectorises): the root is taken everywhere and masked.
        self.scale
            .extend(view.node_mass.iter().zip(view.node_active).map(|(&m, &a)| {
                let s = 1.0 / m.sqrt();
                f64::from_bits(s.to_bits() & (a as u64).wrapping_neg())
            }));
        let k = match view.nodal_stiffness {
            Some(k) if k.has_len(n) => k,
            Some(k) => {
                return Err(StabilityError::LengthMismatch {
                    field: "nodal_stiffness",
                    len: k.diag.len().min(k.upper1.len()).min(k.upper2.len()),
                    expected: n,
                })
            }
            None => {
                self.assemble(view, n, periodic)?;
                &self.assembled
            }
        };
        self.c2_ref = k.c2_ref;
        self.diag_max = scale_bands(k, &self.scale, periodic, &mut self.c_diag, &mut self.c_off);
        Ok(())
    }

    /// `K_N` from the view's `D` weights (one pass over the particles) into `self.assembled`.
    fn assemble(
        &mut self,
        view: &View<'_>,
        n: usize,
        periodic: bool,
    ) -> Result<(), StabilityError> {
        let NodalStiffness {
            diag,
            upper1,
            upper2,
            c2_ref: c2_out,
        } = &mut self.assembled;
        for band in [&mut *diag, &mut *upper1, &mut *upper2] {
            band.clear();
            band.resize(n, 0.0);
        }
        // `upper[o][i] = K_N(i, i+o+1)`.
        let upper = [upper1, upper2];
        let w = view.weights;
        let mut c2_ref = 0.0_f64;
        let (modulus, density) = (view.tangent_modulus, view.density);
        let (f, volume0) = (view.f, view.volume0);
        for p in 0..view.n_particles() {
            let e = modulus[p];
            c2_ref = c2_ref.max(e / density[p]);
            let k = e * f[p] * volume0[p];
            let (nodes, d) = (w.nodes_of(p), w.d_of(p));
            // Fast path: three consecutive nodes (every stencil of a periodic grid, and every
            // stencil away from a fixed grid's ends).
            if let ([i0, i1, i2], [d0, d1, d2]) = (nodes, d) {
                let (i0, i1, i2) = (*i0 as usize, *i1 as usize, *i2 as usize);
                let next = |i: usize| if i + 1 == n && periodic { 0 } else { i + 1 };
                if i1 == next(i0) && i2 == next(i1) {
                    let (k0, k1) = (k * d0, k * d1);
                    diag[i0] += k0 * d0;
                    diag[i1] += k1 * d1;
                    diag[i2] += k * d2 * d2;
                    upper[0][i0] += k0 * d1;
                    upper[1][i0] += k0 * d2;
                    upper[0][i1] += k1 * d2;
                    continue;
                }
            }
            for a in 0..nodes.len() {
                let da = d[a];
                if da == 0.0 {
                    continue;
                }
                let ia = nodes[a] as usize;
                let kda = k * da;
                diag[ia] += kda * da;
                for b in a + 1..nodes.len() {
                    let db = d[b];
                    if db == 0.0 {
                        continue;
                    }
                    let (i, o) = band_slot(ia, nodes[b] as usize, n, periodic).ok_or(
                        StabilityError::InvalidField {
                            field: "weights (stencil wider than 3 nodes)",
                            index: p,
                            value: nodes[b] as f64,
                        },
                    )?;
                    upper[o][i] += kda * db;
                }
            }
        }
        *c2_out = c2_ref;
        Ok(())
    }

    /// The bands of `C`: `(diag, off)` with `diag[i] = C(i, i)` and
    /// `off[i] = [C(i, i+1), C(i, i+2)]` (indices wrapped on periodic grids, zero past a fixed
    /// grid's last node).
    pub fn bands(&self) -> (&[f64], &[[f64; 2]]) {
        (&self.c_diag, &self.c_off)
    }

    /// `1/√m_i` at active nodes, 0 elsewhere (`C = S K_N S` with `S = diag(scale)`).
    pub fn scale(&self) -> &[f64] {
        &self.scale
    }

    /// `K_N` as assembled from the view's weights by the last build (empty when the view
    /// carried the stepper's `K_N`, which is not copied).
    pub fn stiffness(&self) -> &NodalStiffness {
        &self.assembled
    }

    /// Whether the grid is periodic (the bands wrap).
    pub fn is_periodic(&self) -> bool {
        self.periodic
    }

    /// Whether every eigenvalue of `C` is below `mu` (one `LDLᵀ` of `μI − C`, Sylvester's law
    /// of inertia: see [`super::certificate`]).
    pub fn eigenvalues_below(&self, mu: f64) -> bool {
        super::certificate::below_shift(&self.c_diag, &self.c_off, self.periodic, mu)
    }

    /// Grid spacing `h`.
    pub fn h(&self) -> f64 {
        self.h
    }

    /// `c²_ref = max_p E_p/ρ_p` (the normalisation of [`super::Eq56Operator::normalised`]).
    pub fn c2_ref(&self) -> f64 {
        self.c2_ref
    }

    /// A rigorous upper bound on `λmax(C) = λmax(B)` by Gershgorin's theorem on `C`:
    /// `max_i s_i Σ_j |K_N(i, j)| s_j` with `s_i = 1/√m_i` (0 at inactive nodes). `O(n_nodes)`.
    pub fn gershgorin_bound(&self) -> f64 {
        let n = self.c_diag.len();
        let mut row: Vec<f64> = self.c_diag.iter().map(|c| c.abs()).collect();
        for i in 0..n {
            for o in 0..2 {
                if let Some(j) = self.neighbour(i, o + 1) {
                    let c = self.c_off[i][o].abs();
                    row[i] += c;
                    row[j] += c;
                }
            }
        }
        row.into_iter().fold(0.0, f64::max)
    }

    /// Node `i + o` (wrapped on periodic grids, `None` past a fixed grid's last node).
    #[inline]
    fn neighbour(&self, i: usize, o: usize) -> Option<usize> {
        neighbour(self.c_diag.len(), self.periodic, i, o)
    }
}

/// The band slot `(i, o)` (`o = 0` for distance 1, `1` for distance 2) holding the coupling
/// of nodes `a ≠ b`, or `None` if they are more than two lattice cells apart.
fn band_slot(a: usize, b: usize, n: usize, periodic: bool) -> Option<(usize, usize)> {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    let d = hi - lo;
    if (1..=2).contains(&d) {
        return Some((lo, d - 1));
    }
    if periodic && (1..=2).contains(&(n - d)) {
        // `hi + (n − d)` wraps onto `lo`.
        return Some((hi, n - d - 1));
    }
    None
}

impl SymmetricOperator for NodalOperator {
    fn dim(&self) -> usize {
        self.c_diag.len()
    }

    /// `y = C x = M^{1/2} K_N M^{1/2} x` in one pass of five products per node (`work` is
    /// not needed).
    fn apply(&self, x: &[f64], y: &mut [f64], _work: &mut Vec<f64>) {
        let n = self.c_diag.len();
        let (cd, co) = (&self.c_diag[..n], &self.c_off[..n]);
        let (x, y) = (&x[..n], &mut y[..n]);
        // Row i: C_ii x_i + C(i,i+1) x_{i+1} + C(i,i+2) x_{i+2} + C(i−1,i) x_{i−1} + C(i−2,i) x_{i−2}.
        let row = |i: usize| -> f64 {
            let mut acc = cd[i] * x[i];
            for o in 1..=2 {
                if let Some(j) = self.neighbour(i, o) {
                    acc += co[i][o - 1] * x[j];
                }
                let back = if i >= o {
                    Some(i - o)
                } else if self.periodic {
                    Some(i + n - o)
                } else {
                    None
                };
                if let Some(j) = back {
                    acc += co[j][o - 1] * x[j];
                }
            }
            acc
        };
        if n >= 5 {
            for i in 2..n - 2 {
                let xx = &x[i - 2..i + 3];
                let [a1, a2] = co[i];
                y[i] = cd[i] * xx[2]
                    + a1 * xx[3]
                    + a2 * xx[4]
                    + co[i - 1][0] * xx[1]
                    + co[i - 2][1] * xx[0];
            }
            for i in [0, 1, n - 2, n - 1] {
                y[i] = row(i);
            }
        } else {
            for (i, yi) in y.iter_mut().enumerate() {
                *yi = row(i);
            }
        }
    }

    /// The nodal checkerboard `(−1)^i` (the top mode of uniform layouts: nodal forces that
    /// flip sign from node to node) plus a deterministic 10 % pseudo-random part.
    fn checkerboard_start(&self) -> Vec<f64> {
        super::lambda_max::checkerboard_with_noise(self.dim(), |i| i as u64)
    }

    fn normalised(&self, lambda: f64) -> f64 {
        self.h * self.h * lambda / self.c2_ref
    }

    /// `max_i K_N(i, i)/m_i` over active nodes: the lower bound on `λmax` that catches a mode
    /// localised at a light node (linear hats) which a warm start may not see.
    fn diagonal_max(&self) -> Option<(usize, f64)> {
        self.diag_max
    }
}
