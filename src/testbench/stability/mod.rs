//! The 1D verification tools that run the reference solver: the empirical critical step
//! ([`empirical`]; public path `mpm_dt::stability::empirical`).

pub mod empirical;
