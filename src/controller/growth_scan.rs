//! The growth monitor's two indicators of one state in a single pass:
//! the checkerboard share `s = |Σ_i (−1)^i m_i a_i| / Σ_i m_i |a_i|` over active nodes and
//! the total energy `E = Σ_p ½ m_p v_p² + Σ_p ½ σ_p² F_p V⁰_p / E_t,p` (see
//! [`super::growth`]), bit for bit equal to [`super::checkerboard_share`] and
//! [`super::total_energy`].
//!
//! The sums are latency bound: `E` adds two terms per particle to one running sum, the
//! share one term per node to each of two, and the results must keep the plain loops'
//! order. So the terms are formed in blocks of [`BLOCK`] (independent products and
//! divisions: vectorised) and the three running sums are then advanced together in one
//! loop, each in its own order: the node sums hide under the energy's chain instead of
//! running after it. Inactive nodes and particles with `E_t,p ≤ 0` (or NaN) contribute an
//! exact `+0.0`, which leaves the sums unchanged: a sum that starts at `+0.0` is never
//! `−0.0` in round-to-nearest, so adding `+0.0` is the identity on it. Compiled for the
//! baseline target and for AVX2 (never FMA), chosen at run time as the reference solver's
//! particle pass ([`crate::mpm`]).

use crate::stepper::View;

/// Particles (and nodes) per block.
const BLOCK: usize = 256;

/// `(checkerboard share, total energy)` of a state, or `None` when its arrays' lengths
/// differ (the callers then use the two plain functions, which handle that).
pub(super) fn share_and_energy(view: &View<'_>) -> Option<(f64, f64)> {
    let n = view.n_particles();
    let nn = view.node_acceleration.len();
    let lengths_ok = [
        view.v.len(),
        view.mass.len(),
        view.sigma.len(),
        view.f.len(),
        view.volume0.len(),
        view.tangent_modulus.len(),
    ]
    .iter()
    .all(|&l| l == n)
        && view.node_mass.len() == nn
        && view.node_active.len() == nn;
    if !lengths_ok {
        return None;
    }
    #[cfg(target_arch = "x86_64")]
    if crate::mpm::has_avx2() {
        // SAFETY: `scan_avx2` only requires AVX2, which `has_avx2` detected on this CPU.
        return Some(unsafe { scan_avx2(view, n, nn) });
    }
    Some(scan(view, n, nn))
}

/// [`scan`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn scan_avx2(view: &View<'_>, n: usize, nn: usize) -> (f64, f64) {
    scan(view, n, nn)
}

/// The fused pass (see the module docs); all particle arrays have length `n`, all nodal
/// ones `nn`.
#[inline(always)]
fn scan(view: &View<'_>, n: usize, nn: usize) -> (f64, f64) {
    let (m, v, s) = (&view.mass[..n], &view.v[..n], &view.sigma[..n]);
    let (f, v0, et) = (&view.f[..n], &view.volume0[..n], &view.tangent_modulus[..n]);
    let (nm, na, act) = (
        &view.node_mass[..nn],
        &view.node_acceleration[..nn],
        &view.node_active[..nn],
    );
    let (mut kinetic, mut strain) = ([0.0_f64; BLOCK], [0.0_f64; BLOCK]);
    let (mut signed, mut magnitude) = ([0.0_f64; BLOCK], [0.0_f64; BLOCK]);
    let (mut e, mut alt, mut total) = (0.0_f64, 0.0_f64, 0.0_f64);
    let mut start = 0;
    while start < n.max(nn) {
        // Particle terms of this block (zero past the end).
        let lp = BLOCK.min(n.saturating_sub(start));
        if lp < BLOCK {
            kinetic[lp..].fill(0.0);
            strain[lp..].fill(0.0);
        }
        if lp > 0 {
            let r = start..start + lp;
            let (m, v, s) = (&m[r.clone()], &v[r.clone()], &s[r.clone()]);
            let (f, v0, et) = (&f[r.clone()], &v0[r.clone()], &et[r]);
            for k in 0..lp {
                kinetic[k] = 0.5 * m[k] * v[k] * v[k];
                let se = 0.5 * s[k] * s[k] * f[k] * v0[k] / et[k];
                strain[k] = if et[k] > 0.0 { se } else { 0.0 };
            }
        }
        // Node terms of this block (zero past the end and at inactive nodes).
        let ln = BLOCK.min(nn.saturating_sub(start));
        if ln < BLOCK {
            signed[ln..].fill(0.0);
            magnitude[ln..].fill(0.0);
        }
        if ln > 0 {
            let r = start..start + ln;
            let (nm, na, act) = (&nm[r.clone()], &na[r.clone()], &act[r]);
            for k in 0..ln {
                let ma = nm[k] * na[k];
                // `start` is a multiple of BLOCK (even), so the parity of `k` is that of
                // the node index.
                let sg = if k % 2 == 0 { ma } else { -ma };
                signed[k] = if act[k] { sg } else { 0.0 };
                magnitude[k] = if act[k] { ma.abs() } else { 0.0 };
            }
        }
        // The three running sums, each in its plain loop's order.
        for k in 0..BLOCK {
            e += kinetic[k];
            e += strain[k];
            alt += signed[k];
            total += magnitude[k];
        }
        start += BLOCK;
    }
    let share = if total > 0.0 { alt.abs() / total } else { 0.0 };
    (share, e)
}
