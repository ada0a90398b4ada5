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
//!   `D_ip = (N_i(b) − N_i(a))/l_p` with `[a, b] = [x_p − l_p/2, x_p + l_p/2]`. This is exact
//!   for any `l_p ≤ h` and needs no case analysis of where the domain sits.
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

/// Antiderivative of the unit hat of half-width `h`, scaled by `1/h`:
/// `φ(r) = (1/h) ∫_{−∞}^{r} N(s) ds`, so that `φ(−∞) = 0`, `φ(+∞) = 1`.
#[inline(always)]
fn hat_integral(r: f64, inv_h: f64) -> f64 {
    let q = (r * inv_h).clamp(-1.0, 1.0);
    if q <= 0.0 {
        0.5 * (q + 1.0) * (q + 1.0)
    } else {
        1.0 - 0.5 * (1.0 - q) * (1.0 - q)
    }
}

/// `⌊x⌋` without a call into the C library: on the baseline x86-64 target (no SSE4.1)
/// `f64::floor` is a call to libm's `floor`, which the weights' hot loops paid per particle
/// and axis. Equal to `x.floor()` for every finite `|x| < 2⁶³` (the truncation is exact,
/// and one is subtracted where it rounded up); beyond that (a blown-up position) it
/// saturates, which still places the stencil outside any grid.
#[inline(always)]
pub(crate) fn floor(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// [`floor`] with the floor also as an integer, `(⌊x⌋, ⌊x⌋ as i64)`: one truncation for
/// both, where `floor(x) as i64` converts twice (the second time with the checks of a
/// saturating cast). The same pair as `(floor(x), floor(x) as i64)` for every `x`: below
/// `2⁵³` in magnitude the floor is exact either way; from there up every float is an
/// integer (no correction); past `±2⁶³` and for NaN both saturate alike.
#[inline(always)]
pub(crate) fn floor_index(x: f64) -> (f64, i64) {
    let i = x as i64;
    let t = i as f64;
    if t > x {
        (t - 1.0, i.saturating_sub(1))
    } else {
        (t, i)
    }
}

/// The unit hat `N(r) = max(0, 1 − |r|/h)`.
#[inline(always)]
fn hat(r: f64, inv_h: f64) -> f64 {
    (1.0 - (r * inv_h).abs()).max(0.0)
}

impl Shape {
    /// Weights of a particle at `x` (relative to the grid origin) of GIMP width `width`
    /// (ignored by linear hats) on a grid of spacing `h`. Requires `0 < width ≤ h`.
    #[inline(always)]
    pub fn stencil(self, x: f64, width: f64, h: f64) -> ParticleStencil {
        let inv_h = 1.0 / h;
        match self {
            Shape::Gimp => {
                let half = 0.5 * width;
                let a = x - half;
                let first = floor(a * inv_h);
                let inv_l = 1.0 / width;
                let mut s = [0.0; MAX_NODES];
                let mut d = [0.0; MAX_NODES];
                for k in 0..MAX_NODES {
                    let xi = (first + k as f64) * h;
                    let (ra, rb) = (a - xi, x + half - xi);
                    s[k] = (hat_integral(rb, inv_h) - hat_integral(ra, inv_h)) * h * inv_l;
                    d[k] = (hat(rb, inv_h) - hat(ra, inv_h)) * inv_l;
                }
                ParticleStencil {
                    first: first as i64,
                    s,
                    d,
                }
            }
            Shape::Linear => {
                let q = x * inv_h;
                let first = floor(q);
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

#[cfg(test)]
mod tests {
    use super::floor;

    /// [`super::floor_index`] is the pair `(floor(x), floor(x) as i64)`, bit for bit, also
    /// for non-finite and huge values.
    #[test]
    fn floor_index_is_floor_and_its_cast() {
        let mut values = vec![
            0.0,
            -0.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            9.3e18,
            -9.3e18,
            i64::MAX as f64,
            i64::MIN as f64,
            4.5e15,
            -4.5e15,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        for k in -3000..3000 {
            let x = k as f64 * 0.017_3;
            values.extend([x, x.next_up(), x.next_down(), k as f64]);
        }
        for x in values {
            let (t, i) = super::floor_index(x);
            assert_eq!(t.to_bits(), floor(x).to_bits(), "x {x}");
            assert_eq!(i, floor(x) as i64, "x {x}");
        }
    }

    /// The libm-free floor equals `f64::floor` over the positions a grid holds (as numbers:
    /// `⌊−0⌋` is `+0` here, which adds to the node offsets exactly as `−0` does).
    #[test]
    fn floor_matches_the_standard_floor() {
        let mut values = vec![
            0.0, -0.0, 1.0, -1.0, 0.5, -0.5, 1e-300, -1e-300, 4.0e15, -4.0e15,
        ];
        for k in -2000..2000 {
            let x = k as f64 * 0.013_7;
            values.extend([
                x,
                x.next_up(),
                x.next_down(),
                k as f64,
                (k as f64).next_down(),
            ]);
        }
        for x in values {
            // Equal as numbers (`−0` and `+0` compare equal): exactness is the point.
            let (ours, std) = (floor(x), x.floor());
            assert!(
                ours.to_bits() == std.to_bits() || ours + std == 0.0 && ours == 0.0,
                "{x}"
            );
        }
    }
}
