//! Capability: the view checked at the door, in 1D. The same misuses as in 2D
//! (`tests/view_check.rs`) made by a 1D solver's `View` end the run at once with a typed
//! `ControllerError::InvalidView` naming the array, the particle and the value; the
//! shipped 1D scenarios (periodic and clamped, GIMP and linear hat) pass.

use mpm_dt::controller::{Controller, ControllerConfig, ControllerError};
use mpm_dt::mpm::ReferenceStepper;
use mpm_dt::scenario::Scenario;
use mpm_dt::weights::Weights;
use mpm_dt::{Grid, StepError, Stepper, View, ViewError};

#[derive(Clone, Copy, Debug)]
enum Misuse {
    TangentModulusOneShort,
    GridOneCellBigger,
    HalfWeights,
    GradientsWithoutInverseH,
    NanVelocity(usize),
}

/// A 1D reference solver whose committed view carries one misuse.
struct Tampered {
    inner: ReferenceStepper,
    misuse: Misuse,
    grid: Grid,
    weights: Weights,
    v: Vec<f64>,
}

impl Tampered {
    fn new(inner: ReferenceStepper, misuse: Misuse) -> Self {
        let view = inner.view();
        let mut grid = view.grid.clone();
        grid.cells += 1;
        let w = view.weights.get();
        let h = view.grid.h;
        let (ks, kd) = match misuse {
            Misuse::HalfWeights => (0.5, 1.0),
            Misuse::GradientsWithoutInverseH => (1.0, h),
            _ => (1.0, 1.0),
        };
        let mut weights = Weights::new(w.n_nodes(), w.width());
        for p in 0..w.n_particles() {
            let row: Vec<_> = w.row(p).map(|(i, s, d)| (i, ks * s, kd * d)).collect();
            weights.push_row(&row).expect("row");
        }
        let mut v = view.v.to_vec();
        if let Misuse::NanVelocity(p) = misuse {
            v[p] = f64::NAN;
        }
        Self {
            inner,
            misuse,
            grid,
            weights,
            v,
        }
    }
}

impl Stepper for Tampered {
    fn time(&self) -> f64 {
        self.inner.time()
    }
    fn step_count(&self) -> u64 {
        self.inner.step_count()
    }
    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        self.inner.try_step(dt)
    }
    fn accept(&mut self) -> Result<(), StepError> {
        self.inner.accept()
    }
    fn reject(&mut self) {
        self.inner.reject()
    }
    fn view(&self) -> View<'_> {
        let view = View {
            summary: None,
            nodal_stiffness: None,
            ..self.inner.view()
        };
        match self.misuse {
            Misuse::TangentModulusOneShort => View {
                tangent_modulus: &view.tangent_modulus[1..],
                ..view
            },
            Misuse::GridOneCellBigger => View {
                grid: &self.grid,
                ..view
            },
            Misuse::HalfWeights | Misuse::GradientsWithoutInverseH => View {
                weights: (&self.weights).into(),
                ..view
            },
            Misuse::NanVelocity(_) => View { v: &self.v, ..view },
        }
    }
    fn trial_view(&self) -> Option<View<'_>> {
        self.inner.trial_view()
    }
}

fn build(json: &str) -> ReferenceStepper {
    Scenario::from_json(json)
        .expect("scenario")
        .build()
        .expect("solver")
}

/// The error the standard 1D controller ends with on `misuse`, before any attempt.
fn door_error(misuse: Misuse) -> ViewError {
    let mut s = Tampered::new(build(r#"{"cells": 16, "t_end": 0.25}"#), misuse);
    let mut c = Controller::standard(ControllerConfig::default()).expect("controller");
    let mut attempts = 0;
    let err = c
        .run_until(&mut s, 0.25, &mut |_| attempts += 1)
        .expect_err("a misused view must end the run");
    assert_eq!(attempts, 0, "{err}");
    match err {
        ControllerError::InvalidView {
            step: 0,
            trial: false,
            source,
            ..
        } => source,
        e => panic!("expected InvalidView, got {e}"),
    }
}

#[test]
fn each_misuse_is_named_in_1d() {
    let e = door_error(Misuse::TangentModulusOneShort);
    assert!(
        matches!(
            e,
            ViewError::Length {
                array: "tangent_modulus",
                len: 31,
                expected: 32,
                ..
            }
        ),
        "{e}"
    );
    let e = door_error(Misuse::GridOneCellBigger);
    assert!(
        matches!(
            e,
            ViewError::Grid {
                grid_nodes: 17,
                array_nodes: 16,
                ..
            }
        ),
        "{e}"
    );
    let e = door_error(Misuse::HalfWeights);
    assert!(
        matches!(e, ViewError::PartitionOfUnity { particle: 0, sum } if (sum - 0.5).abs() < 1e-12),
        "{e}"
    );
    let e = door_error(Misuse::GradientsWithoutInverseH);
    let h = 1.0 / 16.0;
    assert!(
        matches!(e, ViewError::GradientMoment { particle: 0, value, .. } if (value - h).abs() < 1e-12),
        "{e}"
    );
    let e = door_error(Misuse::NanVelocity(5));
    assert!(
        matches!(e, ViewError::NonFinite { array: "v", index: 5, value } if value.is_nan()),
        "{e}"
    );
}

#[test]
fn shipped_1d_views_pass() {
    for name in [
        "vibrating_bar.json",
        "clamped_bar.json",
        "jittered_gimp_bar.json",
        "linear_hat_bar.json",
        "neo_hookean_bar.json",
    ] {
        let path = format!("{}/scenarios/{name}", env!("CARGO_MANIFEST_DIR"));
        let scenario = Scenario::from_file(path).expect("scenario");
        let mut s = scenario.build().expect("solver");
        s.view().check().unwrap_or_else(|e| panic!("{name}: {e}"));
        let mut c = Controller::standard(ControllerConfig::default()).expect("controller");
        for _ in 0..5 {
            c.step(&mut s, scenario.t_end)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            s.view().check().unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
}
