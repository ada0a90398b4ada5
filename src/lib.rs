//! # mpm-dt: time steps for explicit Material Point Method solvers
//!
//! Explicit MPM codes usually pick `dt` from a speed-of-sound (CFL) rule with a hand-tuned
//! factor. This crate chooses the step from the method's own error and stability analysis,
//! following M. Berzins, *Time stepping with space and time errors and stability of the
//! Material Point Method* (equation numbers in these docs refer to that paper).
//!
//! ## The parts
//!
//! * [`stepper`] — the object-safe [`Stepper`] trait a solver implements: trial step,
//!   accept, reject (bit-for-bit rollback), and a read-only [`View`] ([`view`]; in 2D/3D
//!   [`ViewNd`]) of particle fields,
//!   nodal fields, material tangent moduli and the weight matrices `S`, `D`
//!   ([`view_weights`]: ready or computed on first use), and optionally the nodal stiffness
//!   `K_N` of eq 56 ([`nodal_stiffness`]) accumulated by the solver's own pass.
//! * [`limit`] — the object-safe [`StepLimit`] trait: propose a step, judge a trial;
//!   [`config_error`] — the typed error of every setting.
//! * [`dimension`] — the dimension as a type parameter (`Dim<1>`, `Dim<2>`, `Dim<3>`).
//! * [`grid`], [`shape`], [`weights`] — the 1D background grid, GIMP and linear-hat
//!   basis functions, and the `S`/`D` matrices in fixed-width particle-major storage.
//! * [`testbench`] (`src/testbench/`, the `reference` feature) — the test bench, re-exported
//!   at its public paths: [`mpm`], the reference 1D update-stress-last solver (eqs 17–29);
//!   [`scenario`], serde scenario files with validation; [`problems`], problems with exact
//!   solutions (the vibrating bar); [`memory`]; the 2D/3D reference solver
//!   [`nd::SolverNd`] with [`nd::scenario`] and [`nd::problems`]; the verification tools
//!   `stability::empirical` and [`limits_nd::critical`].
//! * [`estimators`] — the spatial error estimators of Section 4 (eqs 31–44).
//! * [`stability`] — the sound-speed limit (eq 49), the eq 56 amplification operator and
//!   its tracked λmax, the eq 58 bound, and exact critical steps for verification.
//! * [`synchronized_velocity`] — the particle velocity at the state's time, second order in
//!   dt: the USL step's velocity lags half a step, a closing half kick
//!   ([`View::synchronized_velocity`]) removes the lag.
//! * [`view_check`] — what the controller checks of every view before a limit reads it
//!   (array lengths, the grid, a finite state, weights forming a partition of unity with
//!   complete gradients) and the typed [`ViewError`] naming what is wrong.
//! * [`limits_nd`] — the 2D/3D limits; [`temporal`] — what the temporal-error limits of
//!   every dimension share (settings, deferral, the weights' field scales);
//!   [`sound_speed`] — the speed-of-sound limit, one for every dimension.
//! * [`tangent`] — the tangent Lamé moduli a 2D/3D view reports, for hyperelastic models
//!   (neo-Hookean exact, fixed corotated a guaranteed bound).
//! * [`controller`] — the adaptive controller combining the limits
//!   ([`controller::Controller::standard`] builds the paper's three plus a growth monitor,
//!   in any dimension).
//!
//! Every Lanczos estimate of a largest eigenvalue (eq 56's `λmax` in 1D and 2D/3D, the
//! full map's critical step) runs one iteration over an operator trait whose inner product
//! sums over the processes of a split run ([`lanczos`]: the maths and the stopping rules);
//! the 1D tracker's served values, the dense verification paths and the element bound
//! are computed otherwise.
//!
//! ## In five lines
//!
//! ```
//! use mpm_dt::controller::{Controller, ControllerConfig};
//! use mpm_dt::scenario::Scenario;
//! use mpm_dt::Stepper;
//!
//! let scenario = Scenario::from_json(r#"{"cells": 16, "t_end": 0.25}"#)?;
//! let mut solver = scenario.build()?; // any `Stepper` works: `&mut dyn Stepper`
//! // Sound-speed cap (eq 49), stability (eqs 56–58), temporal error (eqs 20–30), growth.
//! let mut controller = Controller::standard(ControllerConfig::default())?;
//! controller.run_until(&mut solver, scenario.t_end, &mut |decision| {
//!     assert!(decision.dt > 0.0); // every attempt, accepted or not, with its reasons
//! })?;
//! assert!((solver.time() - 0.25).abs() < 1e-12);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Both dimensions at a glance
//!
//! The controller, the [`Stepper`] and [`StepLimit`] traits and the config are generic over
//! the dimension `D` ([`Dimension`]: `Dim<1>`'s view is [`View`], `Dim<2>`'s and `Dim<3>`'s
//! is [`ViewNd`]); the limits and the reference solvers are written per dimension:
//!
//! | part | 1D | 2D and 3D |
//! |---|---|---|
//! | state a limit reads | [`View`] (`S`, `D` matrices, [`weights`]) | [`ViewNd`] ([`nd::WeightsNd`], optional [`nd::SummaryNd`] from the stepper's pass) |
//! | sound speed (eq 49) | [`sound_speed::SoundSpeed`], one limit: its 1D kernel in [`stability::sound_speed`] | the same limit: its 2D/3D kernel in [`limits_nd::sound_speed`] |
//! | stability (eqs 56–58) | [`stability::limit::Stability<1>`](stability::limit::Stability) (`stability::Stability`; certified tracker on the `K_N` band, eq 58, [`stability::one_d`]) | [`stability::limit::Stability<D>`](stability::limit::Stability) (`limits_nd::StabilityNd`; Lanczos with a motion guard, the element bound, [`limits_nd::stability`]) — one limit, its rule per dimension |
//! | temporal error (eqs 20–30) | [`temporal::TemporalError<1>`] (`controller::TemporalError`; SIMD kernels, [`controller::RateKernels`]) | [`temporal::TemporalError<D>`] (`limits_nd::TemporalErrorNd`; threaded sweep, [`limits_nd::RateSweeps`]) — one limit, its estimator per dimension |
//! | growth monitor | [`growth::Growth<1>`] (`GrowthMonitor`; checkerboard share, [`growth::one_d`]) | [`growth::Growth<D>`] (`GrowthNd`; energy, [`growth::nd`]) — one limit, its rule per dimension |
//! | the standard controller | [`controller::Controller::standard`] (`Controller::<1>`) | [`controller::Controller::standard`] (`Controller::<2>`, `Controller::<3>`; gravity from `config.gravity`), or [`controller::standard_limits`] + [`controller::Controller::new`] |
//! | reference solver | [`mpm::ReferenceStepper`] | [`nd::SolverNd`] |
//! | scenarios, exact problems | [`scenario`], [`problems`] | [`nd::scenario`], [`nd::problems`] |
//! | spatial error estimators (eqs 31–44) | [`estimators`] | — |
//!
//! One [`controller::ControllerConfig`] serves every dimension; a setting that applies in
//! one dimension only is refused in the others ([`controller::config_dims`]).
//!
//! ## Features
//!
//! * `reference` (on by default) — the test bench ([`testbench`], every file of it under
//!   `src/testbench/`): the reference solvers ([`mpm`], [`nd::SolverNd`] and its kernels),
//!   their scenarios and exact problems ([`scenario`], [`problems`], [`nd::scenario`],
//!   [`nd::problems`]), [`memory`], and the verification tools that run them
//!   (`stability::empirical`, [`limits_nd::critical`]). Without it
//!   (`mpm-dt = { version = "…", default-features = false }`) the crate is the controller
//!   library alone — the stepper contract, views, grids and weights (with the kernels that
//!   compute weights and nodal fields for a solver that keeps only particles,
//!   [`nd::fields`]), the limits and the controller — and compiles no reference solver,
//!   scenario or verification tool: `cargo build --lib --no-default-features` checks it.
//! * `mpi` — global reductions over MPI ranks ([`reduce`], rsmpi): a run split over
//!   processes by particle or by grid slab takes the same steps on every rank. Needs an MPI
//!   library (OpenMPI) and libclang.
//!
//! The library logs through `tracing` and never installs a subscriber.

// Links from the library's docs to the test bench resolve with the `reference` feature
// (the default); without it they are left as text.
#![cfg_attr(not(feature = "reference"), allow(rustdoc::broken_intra_doc_links))]

pub mod config_error;
pub mod controller;
mod cpu;
pub mod dimension;
pub mod estimators;
pub mod fmt_num;
pub mod grid;
pub mod growth;
pub mod lanczos;
pub mod limit;
pub mod limits_nd;
pub mod nd;
pub mod nodal_stiffness;
mod recycled;
pub mod reduce;
pub mod shape;
pub mod sound_speed;
pub mod stability;
mod stencil;
pub mod stepper;
pub mod synchronized_velocity;
pub mod tangent;
pub mod temporal;
#[cfg(feature = "reference")]
pub mod testbench;
pub mod view;
pub use view::pass_summary;
pub mod view_check;
pub mod view_weights;
pub mod weights;

// The test bench's top-level modules keep their paths (`mpm_dt::mpm`, `mpm_dt::scenario`, …).
#[cfg(feature = "reference")]
pub use testbench::{memory, mpm, problems, scenario};

pub use dimension::{Dim, Dimension, StateView, ViewOf};
pub use grid::{Boundary, Grid};
pub use limit::{
    Judgement, LimitCall, LimitError, Metrics, Proposal, RejectCause, StepLimit, Verdict,
};
pub use nd::ViewNd;
pub use nodal_stiffness::NodalStiffness;
pub use pass_summary::PassSummary;
pub use shape::Shape;
pub use stepper::{StepError, Stepper, View};
pub use synchronized_velocity::{closing_half_step, SyncVelocityError};
pub use view_check::ViewError;
pub use view_weights::{ViewWeights, WeightsCache};
pub use weights::{WeightKind, Weights};
