//! The d-dimensional growth monitor's path in `limits_nd`: [`GrowthNd`] is an alias of
//! [`crate::growth::Growth<D>`], the one growth monitor of every dimension, whose 2D/3D rule
//! (the mechanical energy with gravity and kept moduli) is [`crate::growth::nd`].

pub use crate::growth::{GrowthNd, GROWTH};
