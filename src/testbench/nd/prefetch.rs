//! Software prefetch of the trial particle fields a step is about to write.
//!
//! A step writes each particle's new `x`, `v`, `F`, `σ` and density once, in particle
//! order, into arrays far larger than the caches. A store to a line not in the cache
//! waits in the store buffer while the line is read in, and once the buffer is full the
//! pass stalls: `perf` put several per cent of the step's samples on the instructions
//! just after those stores. Asking for the lines of the particle [`AHEAD`] places on
//! (ordinary prefetches, which fetch a line without other sharers in the exclusive state
//! a store needs) has them in the cache by the time they are written: measured 3–6 % on
//! the one-thread step at 10⁶ particles (distances 2 to 8 did alike). Prefetches change
//! no value and never fault, past the arrays' end included.

/// How many particles ahead of the one being written the pass prefetches.
pub(super) const AHEAD: usize = 8;

/// Prefetches the cache line holding `slice[at]` (nothing where `at` is past the end or
/// off x86-64).
#[inline(always)]
pub(super) fn line_of<T>(slice: &[T], at: usize) {
    #[cfg(target_arch = "x86_64")]
    if at < slice.len() {
        let ptr = slice[at..].as_ptr() as *const i8;
        // SAFETY: `prefetcht0` (SSE, in every x86-64 CPU) only hints the cache; `ptr`
        // points into `slice` (and a prefetch would not fault even if it did not).
        unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(ptr) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (slice, at);
}
