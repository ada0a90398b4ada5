//! The 2D/3D verification tools that run the reference solver: the critical steps of a
//! layout ([`critical`]; public path `mpm_dt::limits_nd::critical`).

pub mod critical;
