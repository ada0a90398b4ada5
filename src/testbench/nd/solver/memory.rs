//! What a [`SolverNd`] holds: [`SolverNd::memory_bytes`].

use super::{CarriedNd, SolverNd, StateNd};

/// Bytes of a vector's allocation (its capacity).
fn heap<T>(v: &Vec<T>) -> usize {
    v.capacity() * std::mem::size_of::<T>()
}

impl<const D: usize> StateNd<D> {
    /// Bytes of the arrays this state owns (the carried fields are counted once, apart).
    fn heap_bytes(&self) -> usize {
        heap(&self.x)
            + heap(&self.v)
            + heap(&self.sigma)
            + heap(&self.f)
            + heap(&self.density)
            + heap(&self.node_mass)
            + heap(&self.node_v)
            + heap(&self.node_a)
            + heap(&self.active)
    }
}

impl<const D: usize> CarriedNd<D> {
    fn heap_bytes(&self) -> usize {
        heap(&self.mass)
            + heap(&self.volume0)
            + heap(&self.domain)
            + heap(&self.material)
            + heap(&self.id)
    }
}

impl<const D: usize> SolverNd<D> {
    /// Bytes of heap memory the solver holds (its arrays' capacities): the committed state
    /// and the trial, the carried fields and the moduli (once where the two states share
    /// them),
    /// the grid's nodal flags and the nodal velocities of the step, and on threads the
    /// particles' order by slab (8 bytes each). Module docs of
    /// [`SolverNd`] for what is O(particles) and what O(nodes); a grid-decomposed run's
    /// slab tables are not counted.
    pub fn memory_bytes(&self) -> usize {
        let (c, t) = (&self.committed, &self.trial);
        let carried = c.carried.heap_bytes()
            + if std::rc::Rc::ptr_eq(&c.carried, &t.carried) {
                0
            } else {
                t.carried.heap_bytes()
            };
        // The moduli: once where the two states share them.
        let moduli = |s: &StateNd<D>| heap(&s.moduli.lambda) + heap(&s.moduli.mu);
        let moduli = moduli(c)
            + if std::rc::Rc::ptr_eq(&c.moduli, &t.moduli) {
                0
            } else {
                moduli(t)
            };
        c.heap_bytes()
            + t.heap_bytes()
            + carried
            + moduli
            + heap(&self.constrained)
            + heap(&self.node_v1)
            + self.scratch.memory_bytes()
    }
}
