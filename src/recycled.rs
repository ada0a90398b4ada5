//! [`Recycled`]: a value computed on first use that keeps its allocation when invalidated.
//!
//! The lazily computed parts of a state (the view's weights, the reference solver's
//! per-particle tangent modulus and density, the node flags) are recomputed for every new
//! state. Dropping and reallocating them each step costs page faults on large vectors (a
//! fresh 10⁵-element vector is a fresh mapping: about 3 % of a controlled step, measured by
//! `perf`), so an invalidated value is kept as a spare and handed to the next computation,
//! which overwrites it.

use std::cell::{Cell, OnceCell};

/// A value computed on first use through `&self`, whose storage survives [`Self::invalidate`].
pub(crate) struct Recycled<T> {
    cell: OnceCell<T>,
    spare: Cell<Option<T>>,
}

impl<T> Default for Recycled<T> {
    fn default() -> Self {
        Self {
            cell: OnceCell::new(),
            spare: Cell::new(None),
        }
    }
}

#[cfg_attr(not(feature = "reference"), allow(dead_code))] // used by the reference solvers
impl<T> Recycled<T> {
    /// Forgets the value; its storage is kept for the next computation.
    pub fn invalidate(&mut self) {
        if let Some(v) = self.cell.take() {
            *self.spare.get_mut() = Some(v);
        }
    }

    /// The value, computed on the first call after [`Self::invalidate`] by `compute`, which
    /// receives the previous value's storage (if any) to overwrite.
    pub fn get_or_init_with(&self, compute: impl FnOnce(Option<T>) -> T) -> &T {
        self.cell.get_or_init(|| compute(self.spare.take()))
    }

    /// Installs `value` as the computed value (the cell must be empty: after
    /// [`Self::invalidate`], before any read) and returns the spare storage, for the
    /// producer to fill next time. Returns `value` back, untouched, if the cell already
    /// holds a value.
    pub fn install(&mut self, value: T) -> Result<Option<T>, T> {
        match self.cell.set(value) {
            Ok(()) => Ok(self.spare.get_mut().take()),
            Err(value) => Err(value),
        }
    }

    /// Whether the value is computed.
    pub fn is_computed(&self) -> bool {
        self.cell.get().is_some()
    }
}

impl<T: Clone> Clone for Recycled<T> {
    /// A clone keeps a computed value but not the spare storage.
    fn clone(&self) -> Self {
        Self {
            cell: self.cell.clone(),
            spare: Cell::new(None),
        }
    }
}

/// A vector refilled from `values` in the storage of `spare` (emptied first).
#[cfg(feature = "reference")]
pub(crate) fn refill<T>(spare: Option<Vec<T>>, values: impl Iterator<Item = T>) -> Vec<T> {
    let mut v = spare.unwrap_or_default();
    v.clear();
    v.extend(values);
    v
}

impl<T> std::fmt::Debug for Recycled<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recycled")
            .field("computed", &self.is_computed())
            .finish()
    }
}
