//! Capability: the memory the controller and the reference solver account for
//! (`Controller::memory_bytes`, `SolverNd::memory_bytes`) is what they allocate. This test
//! binary counts every live heap byte with its own global allocator: on a 3D and a 2D
//! periodic GIMP plane wave, the bytes a controlled run holds on top of the solver's steady
//! state (committed state and trial allocated) are within 10 % of the controller's
//! accounted bytes, and the bytes the solver holds after its set-up are within 10 % of its
//! own. The controller's figure per particle is the documented one: the temporal-error
//! history `(D + D(D+1)/2)·8` (symmetric stresses) and the stability guard's references
//! `4D + 16` bytes (positions in single precision, two moduli), plus O(nodes); the solver's `2·(2D + 2D² + 1)·8` for its two states
//! plus the shared fields.
//!
//! One `#[test]`: the counter is global, so no other test of this binary may allocate
//! while it measures.

use mpm_dt::controller::standard_limits;
use mpm_dt::controller::Controller;
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::Vector;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicIsize, Ordering};

/// The system allocator, counting the bytes live.
struct Counting;

static LIVE: AtomicIsize = AtomicIsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            LIVE.fetch_add(layout.size() as isize, Ordering::SeqCst);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            LIVE.fetch_add(layout.size() as isize, Ordering::SeqCst);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size() as isize, Ordering::SeqCst);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE.fetch_add(new_size as isize - layout.size() as isize, Ordering::SeqCst);
        }
        p
    }
}

#[global_allocator]
static COUNTING: Counting = Counting;

fn live() -> isize {
    LIVE.load(Ordering::SeqCst)
}

/// `|held − accounted| ≤ 10 %` of `accounted`.
fn within_ten_percent(what: &str, held: isize, accounted: usize) {
    let accounted = accounted as isize;
    eprintln!("{what}: holds {held} B, accounts for {accounted} B");
    assert!(
        (held - accounted).abs() * 10 <= accounted,
        "{what}: holds {held} B, accounts for {accounted} B"
    );
}

/// A periodic GIMP plane wave of `cells` cells per axis, 2 particles per cell per axis.
fn scenario(dim: usize, cells: usize) -> ScenarioNd {
    let wave = if dim == 3 { "[1, 0, 0]" } else { "[1, 0]" };
    ScenarioNd::from_json(&format!(
        r#"{{"dim": {dim}, "cells": {cells}, "length": 1.0, "boundary": "periodic",
            "youngs_modulus": 1.0, "poisson_ratio": 0.3, "density": 1.0,
            "shape": "gimp", "material": "linear_elastic", "particles": {{"per_cell": 2}},
            "initial": {{"plane_wave": {{"amplitude": 0.01, "wave_vector": {wave},
            "direction": {wave}}}}}, "t_end": 1.0}}"#
    ))
    .expect("scenario")
}

/// Measures the solver's and the controller's heap against their accounts; returns the
/// controller's accounted bytes per particle.
fn check<const D: usize>(cells: usize) -> f64
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let scenario = scenario(D, cells);
    let config = scenario.controller_config().expect("config");
    let before_solver = live();
    let (mut solver, _) = scenario.build::<D>().expect("solver");
    // The trial buffers, as every step after the first holds them.
    solver.try_step(1e-6).expect("trial");
    solver.reject();
    let solver_held = live() - before_solver;
    within_ten_percent("solver", solver_held, solver.memory_bytes());
    // Two states of x, v, σ, F and density; the shared fields (mass, V⁰, domain,
    // material, id) and moduli; per node two states' mass, velocity, acceleration and
    // activity, the step's velocities and the constraint flags.
    let (n, nodes) = (solver.n_particles(), solver.grid().n_nodes());
    let states = 2 * (2 * D + 2 * D * D + 1) * 8 * n;
    let shared = (8 + 8 + 8 * D + 24 + 8 + 16) * n;
    let nodal = (2 * (8 + 16 * D + 1) + 8 * D + 1) * nodes;
    assert!(
        solver.memory_bytes() <= states + shared + nodal,
        "{}",
        solver.memory_bytes()
    );

    let limits = standard_limits::<D>(&config, Vector::<D>::zeros());
    let mut controller = Controller::<D>::new(config, limits).expect("controller");
    let before = live();
    let h = 1.0 / cells as f64;
    controller
        .run_until(&mut solver, 12.0 * h, &mut |_| {})
        .expect("run");
    assert!(
        controller.stats().accepted >= 10,
        "{:?}",
        controller.stats()
    );
    let held = live() - before;
    let accounted = controller.memory_bytes();
    within_ten_percent("controller", held, accounted);
    accounted as f64 / solver.n_particles() as f64
}

#[test]
fn the_controller_and_the_solver_hold_what_they_account_for() {
    let per_particle_3d = check::<3>(12);
    // 72 B of temporal-error history and 28 B of guard references, plus the Ritz vector
    // (3 numbers a node, 8 particles a cell).
    assert!(
        (100.0..104.0).contains(&per_particle_3d),
        "3D: {per_particle_3d} B a particle"
    );
    let per_particle_2d = check::<2>(48);
    assert!(
        (64.0..70.0).contains(&per_particle_2d),
        "2D: {per_particle_2d} B a particle"
    );
}
