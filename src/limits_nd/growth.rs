//! The d-dimensional growth monitor's older home: [`GrowthNd`] is now
//! [`crate::growth::Growth<D>`], the one growth monitor of every dimension, whose 2D/3D rule
//! (the mechanical energy with gravity and kept moduli) is [`crate::growth::nd`].

pub use crate::growth::{GrowthNd, GROWTH};
