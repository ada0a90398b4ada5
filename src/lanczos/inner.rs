//! The Euclidean inner product of the iteration's vectors, summed over the processes of a
//! split run.

use crate::reduce::Reduce;

/// `aᵀ b` on this process's entries.
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `aᵀ b` for each `a` in `left`, over the entries `k` with `counted(k)` (this process's
/// own), then summed over the processes of `reduce` (one reduction in all).
pub(crate) fn reduced_dots(
    left: &[&[f64]],
    b: &[f64],
    counted: impl Fn(usize) -> bool,
    reduce: &dyn Reduce,
) -> Vec<f64> {
    let mut out: Vec<f64> = left
        .iter()
        .map(|a| {
            let mut sum = 0.0;
            for (k, (x, y)) in a.iter().zip(b).enumerate() {
                if counted(k) {
                    sum += x * y;
                }
            }
            sum
        })
        .collect();
    reduce.sum(&mut out);
    out
}

/// The Euclidean inner product: on one process's whole vectors ([`Inner::local`]: also a
/// run whose processes hold the same whole vectors), or over the entries each process owns,
/// summed over the processes ([`Inner::over`]: vectors split between processes, with ghost
/// copies that must count once).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Inner<'r> {
    split: Option<(&'r dyn Reduce, &'r [bool])>,
}

impl<'r> Inner<'r> {
    /// `aᵀ b` on this process.
    pub(crate) fn local() -> Self {
        Self { split: None }
    }

    /// `Σ_{k owned} a_k b_k` summed over the processes of `reduce`.
    pub(crate) fn over(reduce: &'r dyn Reduce, owned: &'r [bool]) -> Self {
        Self {
            split: Some((reduce, owned)),
        }
    }

    /// Whether the products reduce over processes.
    pub(crate) fn is_reduced(&self) -> bool {
        self.split.is_some()
    }

    /// Which entries this process counts (`None`: all of them, no reduction).
    pub(crate) fn owned(&self) -> Option<&'r [bool]> {
        self.split.map(|(_, owned)| owned)
    }

    /// Completes partial sums over this process's owned entries (nothing on one process).
    pub(crate) fn complete(&self, sums: &mut [f64]) {
        if let Some((reduce, _)) = self.split {
            reduce.sum(sums);
        }
    }

    /// `⟨a, b⟩` for each `a` in `left` (one reduction in all).
    pub(crate) fn dots(&self, left: &[&[f64]], b: &[f64]) -> Vec<f64> {
        match self.split {
            None => left.iter().map(|a| dot(a, b)).collect(),
            Some((reduce, owned)) => reduced_dots(left, b, |k| owned[k], reduce),
        }
    }

    /// `⟨a, b⟩`.
    pub(crate) fn dot(&self, a: &[f64], b: &[f64]) -> f64 {
        match self.split {
            None => dot(a, b),
            Some(_) => self.dots(&[a], b)[0],
        }
    }
}
