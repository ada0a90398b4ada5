//! [`Timed`]: a [`Reduce`] with a stopwatch, to measure what agreeing costs.

use super::Reduce;
use std::cell::Cell;
use std::time::{Duration, Instant};

/// Wraps a [`Reduce`] and adds up the time spent in its calls (waiting for slower
/// processes included) and their number.
#[derive(Debug)]
pub struct Timed<R: Reduce> {
    inner: R,
    spent: Cell<Duration>,
    calls: Cell<u64>,
}

impl<R: Reduce> Timed<R> {
    /// `inner`, timed from now on.
    pub fn new(inner: R) -> Self {
        Self {
            inner,
            spent: Cell::new(Duration::ZERO),
            calls: Cell::new(0),
        }
    }

    /// Time spent in reductions so far.
    pub fn spent(&self) -> Duration {
        self.spent.get()
    }

    /// Reductions so far.
    pub fn calls(&self) -> u64 {
        self.calls.get()
    }

    fn time<T>(&self, f: impl FnOnce() -> T) -> T {
        let start = Instant::now();
        let out = f();
        self.spent.set(self.spent.get() + start.elapsed());
        self.calls.set(self.calls.get() + 1);
        out
    }
}

impl<R: Reduce> Reduce for Timed<R> {
    fn rank(&self) -> usize {
        self.inner.rank()
    }
    fn size(&self) -> usize {
        self.inner.size()
    }
    fn min_and_any(&self, value: f64, flag: bool) -> (f64, bool) {
        self.time(|| self.inner.min_and_any(value, flag))
    }
    fn any_flags(&self, flags: &mut [bool]) {
        self.time(|| self.inner.any_flags(flags))
    }
    fn sum(&self, values: &mut [f64]) {
        self.time(|| self.inner.sum(values))
    }
    fn exchange(
        &self,
        to: Option<usize>,
        from: Option<usize>,
        tag: u16,
        send: &[f64],
    ) -> Option<Vec<f64>> {
        self.time(|| self.inner.exchange(to, from, tag, send))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reduce::SingleProcess;

    #[test]
    fn counts_every_call_and_passes_values_through() {
        let t = Timed::new(SingleProcess);
        let (v, any) = t.min_and_any(3.0, false);
        assert!(!any && v.to_bits() == 3.0f64.to_bits());
        let mut f = [true];
        t.any_flags(&mut f);
        let mut v = [1.5f64];
        t.sum(&mut v);
        assert_eq!(t.calls(), 3);
        assert_eq!(v[0].to_bits(), 1.5f64.to_bits());
        assert!(f[0]);
    }
}
