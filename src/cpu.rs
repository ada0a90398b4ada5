//! Which instruction-set builds of the hot loops this CPU runs.
//!
//! The particle passes (the 1D particle pass and weights, the 2D/3D fused step, the 1D
//! power pass and temporal kernels) are compiled twice: for the baseline `x86_64`
//! (SSE2) and with AVX2 enabled, chosen at run time. The AVX2 builds use VEX-encoded
//! three-operand arithmetic and single-instruction rounding, but no fused multiply–add:
//! Rust never contracts `a * b + c` on its own, so every value is bit for bit the
//! baseline build's and results do not depend on the machine.
//!
//! Setting the environment variable `MPM_DT_BASELINE=1` makes a process run the baseline
//! builds only (to compare the two builds' speed, or to rule them out when chasing a
//! machine-dependent result).

/// Whether the process runs the AVX2 builds: the CPU has AVX2 and `MPM_DT_BASELINE` is not
/// `1`; decided once per process.
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx2() -> bool {
    static AVX2: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *AVX2.get_or_init(|| {
        std::env::var("MPM_DT_BASELINE").as_deref() != Ok("1") && is_x86_feature_detected!("avx2")
    })
}
