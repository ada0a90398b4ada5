//! [`StressRates`]: the stress rates `σ̇_p` of the temporal-error history, stored as full
//! `D×D` tensors or — while every rate is exactly symmetric, as the rates of symmetric
//! stresses are — as their upper triangles, `D(D+1)/2` numbers a particle (48 bytes
//! instead of 72 in 3D, 24 instead of 32 in 2D). The form is chosen by the values, bit for
//! bit: a symmetric rate is unpacked to the very tensor that was stored, so the estimate
//! is the same in either form. The first rate that is not symmetric turns the history into
//! the full form for the rest of the run.
//!
//! Checkpoints hold the full tensors (the form is not part of the saved state).

use crate::nd::Tensor;
use serde::{Deserialize, Serialize};

/// `σ̇_p` per particle (module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(into = "Vec<Tensor<D>>", from = "Vec<Tensor<D>>")]
pub(super) enum StressRates<const D: usize> {
    /// Upper triangles, row by row (`(0,0), (0,1), …, (1,1), …`).
    Sym(Vec<f64>),
    /// Full tensors.
    Full(Vec<Tensor<D>>),
}

impl<const D: usize> Default for StressRates<D> {
    fn default() -> Self {
        StressRates::Sym(Vec::new())
    }
}

/// Whether `t` equals its transpose bit for bit.
fn symmetric<const D: usize>(t: &Tensor<D>) -> bool {
    (0..D).all(|a| (a + 1..D).all(|b| t[(a, b)].to_bits() == t[(b, a)].to_bits()))
}

impl<const D: usize> StressRates<D> {
    /// Numbers per particle in the symmetric form.
    const SYM: usize = D * (D + 1) / 2;

    /// Number of particles.
    pub fn len(&self) -> usize {
        match self {
            StressRates::Sym(v) => v.len() / Self::SYM,
            StressRates::Full(v) => v.len(),
        }
    }

    /// Particle `p`'s rate.
    #[inline]
    pub fn get(&self, p: usize) -> Tensor<D> {
        match self {
            StressRates::Full(v) => v[p],
            StressRates::Sym(v) => {
                let packed = &v[p * Self::SYM..(p + 1) * Self::SYM];
                let mut t = Tensor::<D>::zeros();
                let mut k = 0;
                for a in 0..D {
                    for b in a..D {
                        t[(a, b)] = packed[k];
                        t[(b, a)] = packed[k];
                        k += 1;
                    }
                }
                t
            }
        }
    }

    /// Sets particle `p`'s rate (turning the history into the full form if `t` is the first
    /// rate that is not symmetric).
    #[inline]
    pub fn set(&mut self, p: usize, t: Tensor<D>) {
        match self {
            StressRates::Full(v) => v[p] = t,
            StressRates::Sym(v) if symmetric(&t) => {
                let packed = &mut v[p * Self::SYM..(p + 1) * Self::SYM];
                let mut k = 0;
                for a in 0..D {
                    for b in a..D {
                        packed[k] = t[(a, b)];
                        k += 1;
                    }
                }
            }
            StressRates::Sym(_) => {
                *self = StressRates::Full(self.to_full());
                self.set(p, t);
            }
        }
    }

    /// `n` zero rates, in the current form (their storage reused).
    pub fn reset(&mut self, n: usize) {
        match self {
            StressRates::Sym(v) => {
                v.clear();
                v.resize(n * Self::SYM, 0.0);
            }
            StressRates::Full(v) => {
                v.clear();
                v.resize(n, Tensor::<D>::zeros());
            }
        }
    }

    /// Bytes of the storage (its capacity).
    pub fn heap_bytes(&self) -> usize {
        match self {
            StressRates::Sym(v) => v.capacity() * std::mem::size_of::<f64>(),
            StressRates::Full(v) => v.capacity() * std::mem::size_of::<Tensor<D>>(),
        }
    }

    fn to_full(&self) -> Vec<Tensor<D>> {
        (0..self.len()).map(|p| self.get(p)).collect()
    }
}

/// Mutable access to a range of the rates, in their current form: what a threaded sweep
/// writes through, one range per chunk.
pub(super) enum StressRatesMut<'a, const D: usize> {
    Sym(&'a mut [f64]),
    Full(&'a mut [Tensor<D>]),
}

impl<const D: usize> StressRatesMut<'_, D> {
    /// Stores `t` at entry `k` of the range; `false` (nothing stored) where the rates are
    /// packed and `t` is not exactly symmetric: the caller unpacks them
    /// ([`StressRates::unpack`]) and writes again.
    #[inline]
    pub fn set(&mut self, k: usize, t: Tensor<D>) -> bool {
        match self {
            StressRatesMut::Full(v) => {
                v[k] = t;
                true
            }
            StressRatesMut::Sym(v) if symmetric(&t) => {
                let sym = StressRates::<D>::SYM;
                let packed = &mut v[k * sym..(k + 1) * sym];
                let mut i = 0;
                for a in 0..D {
                    for b in a..D {
                        packed[i] = t[(a, b)];
                        i += 1;
                    }
                }
                true
            }
            StressRatesMut::Sym(_) => false,
        }
    }
}

impl<const D: usize> StressRates<D> {
    /// Every rate, mutable.
    pub fn as_mut(&mut self) -> StressRatesMut<'_, D> {
        match self {
            StressRates::Sym(v) => StressRatesMut::Sym(v),
            StressRates::Full(v) => StressRatesMut::Full(v),
        }
    }

    /// The rates in ranges of `chunk` particles (the last one shorter).
    pub fn chunks_mut(&mut self, chunk: usize) -> Vec<StressRatesMut<'_, D>> {
        match self {
            StressRates::Sym(v) => v
                .chunks_mut(chunk * Self::SYM)
                .map(StressRatesMut::Sym)
                .collect(),
            StressRates::Full(v) => v.chunks_mut(chunk).map(StressRatesMut::Full).collect(),
        }
    }

    /// Switches to full tensors (a no-op when they are already), keeping every value.
    pub fn unpack(&mut self) {
        if let StressRates::Sym(_) = self {
            *self = StressRates::Full(self.to_full());
        }
    }
}

impl<const D: usize> From<StressRates<D>> for Vec<Tensor<D>> {
    fn from(rates: StressRates<D>) -> Self {
        match rates {
            StressRates::Full(v) => v,
            sym => sym.to_full(),
        }
    }
}

impl<const D: usize> From<Vec<Tensor<D>>> for StressRates<D> {
    /// The symmetric form where every rate is symmetric, else the full one.
    fn from(full: Vec<Tensor<D>>) -> Self {
        if !full.iter().all(symmetric) {
            return StressRates::Full(full);
        }
        let mut sym = StressRates::Sym(vec![0.0; full.len() * Self::SYM]);
        for (p, t) in full.into_iter().enumerate() {
            sym.set(p, t);
        }
        sym
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symmetric_rates_are_packed_and_read_back_bit_for_bit() {
        let s = Tensor::<3>::from_fn(|a, b| 0.1 + (a + b) as f64 / 3.0);
        let mut r = StressRates::<3>::default();
        r.reset(2);
        r.set(1, s);
        assert!(matches!(r, StressRates::Sym(_)));
        assert_eq!(r.get(1), s);
        assert_eq!(r.get(0), Tensor::<3>::zeros());
        assert_eq!(r.heap_bytes(), 2 * 6 * 8);
        // The first rate that is not symmetric: the full form, the earlier rates kept.
        let mut n = s;
        n[(0, 1)] += 1e-3;
        r.set(0, n);
        assert!(matches!(r, StressRates::Full(_)));
        assert_eq!((r.get(0), r.get(1)), (n, s));
        // Saved as full tensors, restored to the symmetric form where it can be.
        let json = serde_json::to_value(StressRates::<3>::from(vec![s, s])).unwrap();
        let back: StressRates<3> = serde_json::from_value(json.clone()).unwrap();
        assert!(matches!(back, StressRates::Sym(_)));
        assert_eq!(json, serde_json::to_value(vec![s, s]).unwrap());
    }

    #[test]
    fn chunks_write_in_place_and_refuse_an_asymmetric_rate_while_packed() {
        let s = Tensor::<2>::from_fn(|a, b| 1.0 + (a + b) as f64);
        let mut asym = s;
        asym[(0, 1)] += 0.5;
        let mut r = StressRates::<2>::default();
        r.reset(5);
        {
            let mut chunks = r.chunks_mut(2);
            assert_eq!(chunks.len(), 3);
            assert!(chunks[1].set(1, s)); // particle 3
            assert!(!chunks[2].set(0, asym)); // particle 4: refused, nothing written
        }
        assert!(matches!(r, StressRates::Sym(_)));
        assert_eq!((r.get(3), r.get(4)), (s, Tensor::<2>::zeros()));
        r.unpack();
        assert!(matches!(r, StressRates::Full(_)));
        assert_eq!(r.get(3), s);
        assert!(r.chunks_mut(2)[2].set(0, asym));
        assert_eq!(r.get(4), asym);
    }
}
