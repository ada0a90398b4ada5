//! The 1D verification tools: the empirical critical step that runs the reference solver
//! ([`empirical`]; public path `mpm_dt::stability::empirical`) and the dense frozen-particle
//! full map of the whole USL step ([`full_map`]; public path `mpm_dt::stability::full_map`).

pub mod empirical;
pub mod full_map;
