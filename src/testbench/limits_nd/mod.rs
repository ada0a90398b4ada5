//! The 2D/3D verification tools: the critical steps of a layout that run the reference
//! solver ([`critical`]; public path `mpm_dt::limits_nd::critical`) and the dense
//! frozen-particle full map ([`full_map`]; public path `mpm_dt::limits_nd::full_map`).

pub mod critical;
pub mod full_map;
