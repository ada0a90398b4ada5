//! The spatial dimension as a type parameter: one [`crate::Stepper`], one
//! [`crate::StepLimit`] and one controller for d = 1, 2, 3.
//!
//! The traits take the dimension as a const generic, `Stepper<const D: usize = 1>`, and the
//! view they hand around is the dimension's own type, [`ViewOf<'a, D>`]:
//!
//! | `D` | view | particle fields |
//! |---|---|---|
//! | 1 | [`crate::View`] | `&[f64]` (the 1D solver's layout, unchanged) |
//! | 2, 3 | [`crate::nd::ViewNd`] | `&[SVector<f64, D>]`, `&[SMatrix<f64, D, D>]` |
//!
//! `D = 1` is the default, so `dyn Stepper`, `Box<dyn StepLimit>` and `Controller` keep
//! meaning the 1D ones; a 2D solver is a `&mut dyn Stepper<2>`. The 1D view keeps its scalar
//! slices because the 1D kernels (and every result they pin) are written against them.

use crate::nd::ViewNd;
use crate::view::View;
use crate::view_check::ViewError;

/// The dimension `D` as a type (`Dim<2>`), so that it can carry the view type.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Dim<const D: usize>;

/// What a dimension fixes: the type of a read-only state view.
pub trait Dimension {
    /// The number of spatial dimensions.
    const D: usize;
    /// A read-only view of one state of a solver in this dimension.
    type View<'a>: StateView;
}

impl Dimension for Dim<1> {
    const D: usize = 1;
    type View<'a> = View<'a>;
}

impl Dimension for Dim<2> {
    const D: usize = 2;
    type View<'a> = ViewNd<'a, 2>;
}

impl Dimension for Dim<3> {
    const D: usize = 3;
    type View<'a> = ViewNd<'a, 3>;
}

/// The view type of dimension `D`: [`View`] for `D = 1`, [`ViewNd`] for `D = 2, 3`.
pub type ViewOf<'a, const D: usize> = <Dim<D> as Dimension>::View<'a>;

/// What the controller reads from a view of any dimension.
pub trait StateView {
    /// Time `t` of this state.
    fn time(&self) -> f64;
    /// Number of accepted steps that led to this state.
    fn step_index(&self) -> u64;
    /// Number of particles.
    fn particle_count(&self) -> usize;
    /// The first non-finite value among the particle positions, velocities, stresses and
    /// deformation gradients (in that order), as (field name, particle index, value).
    fn first_nonfinite(&self) -> Option<(&'static str, usize, f64)>;
    /// The O(1) part of the door check ([`crate::view_check`]): the arrays' lengths agree
    /// with the particle count and with the grid. Returns the particle count.
    fn check_shape(&self) -> Result<usize, ViewError>;
    /// The O(n) part of the door check ([`crate::view_check`]): a finite state, weights that
    /// form a partition of unity with complete gradients.
    fn check_contents(&self) -> Result<(), ViewError>;

    /// Whether the view holds its particle and nodal arrays; `false` for a 2D/3D
    /// summary-only view ([`ViewNd::summary_only`]) of a stepper handing over its arrays
    /// on demand ([`crate::Stepper::provide_arrays_on_demand`]).
    fn holds_arrays(&self) -> bool {
        true
    }

    /// Whether the view holds at least its particle arrays (a 2D/3D view
    /// [`ViewNd::without_nodal`], or any view that [`Self::holds_arrays`]).
    fn holds_particles(&self) -> bool {
        self.holds_arrays()
    }
}

impl StateView for View<'_> {
    fn time(&self) -> f64 {
        self.t
    }

    fn step_index(&self) -> u64 {
        self.step
    }

    fn particle_count(&self) -> usize {
        self.x.len()
    }

    fn first_nonfinite(&self) -> Option<(&'static str, usize, f64)> {
        crate::view_check::first_nonfinite(self)
    }

    fn check_shape(&self) -> Result<usize, ViewError> {
        View::check_shape(self)
    }

    fn check_contents(&self) -> Result<(), ViewError> {
        View::check_contents(self)
    }
}

impl<const D: usize> StateView for ViewNd<'_, D> {
    fn time(&self) -> f64 {
        self.t
    }

    fn step_index(&self) -> u64 {
        self.step
    }

    fn particle_count(&self) -> usize {
        self.x.len()
    }

    fn check_shape(&self) -> Result<usize, ViewError> {
        ViewNd::check_shape(self)
    }

    fn check_contents(&self) -> Result<(), ViewError> {
        ViewNd::check_contents(self)
    }

    fn holds_arrays(&self) -> bool {
        ViewNd::holds_arrays(self)
    }

    fn holds_particles(&self) -> bool {
        ViewNd::holds_particles(self)
    }

    fn first_nonfinite(&self) -> Option<(&'static str, usize, f64)> {
        // The stepper's own check, when it made one.
        if self.summary.is_some_and(|s| s.finite) {
            return None;
        }
        if !self.holds_arrays() {
            // A summary-only view whose summary is not finite: no particle to name until
            // its arrays are loaded.
            return Some(("summary", 0, f64::NAN));
        }
        fn scan<'b, I: Iterator<Item = &'b f64>>(p: usize, it: I) -> Option<(usize, f64)> {
            it.copied().find(|v| !v.is_finite()).map(|v| (p, v))
        }
        for (p, x) in self.x.iter().enumerate() {
            if let Some((p, v)) = scan(p, x.iter()) {
                return Some(("x", p, v));
            }
        }
        for (p, x) in self.v.iter().enumerate() {
            if let Some((p, v)) = scan(p, x.iter()) {
                return Some(("v", p, v));
            }
        }
        for (p, x) in self.sigma.iter().enumerate() {
            if let Some((p, v)) = scan(p, x.iter()) {
                return Some(("sigma", p, v));
            }
        }
        for (p, x) in self.f.iter().enumerate() {
            if let Some((p, v)) = scan(p, x.iter()) {
                return Some(("F", p, v));
            }
        }
        None
    }
}
