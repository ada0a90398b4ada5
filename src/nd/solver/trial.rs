//! One trial step of a [`SolverNd`].

use super::SolverNd;
use crate::nd::kernels::{self, Committed, ParticleFault, Written};
use crate::nd::{SummaryNd, Tensor, Vector, ViewWeightsNd};
use crate::stepper::StepError;
use std::rc::Rc;

impl<const D: usize> SolverNd<D> {
    /// Computes the trial state of step `dt` into the trial buffer. In a split run every
    /// process makes the same exchanges in the same order, also when its own part fails:
    /// migration (grid-decomposed), the nodal sums, the whole run's totals.
    pub(super) fn trial_step(&mut self, dt: f64) -> Result<(), StepError> {
        self.has_trial = false;
        let c = &self.committed;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::InvalidDt { dt, t: c.t });
        }
        let n = c.x.len();
        self.node_v1.clear();
        self.node_v1
            .extend(c.node_v.iter().zip(&c.node_a).map(|(v, a)| v + a * dt));
        let mut trial = std::mem::take(&mut self.trial);
        trial.x.resize(n, Vector::<D>::zeros());
        trial.v.resize(n, Vector::<D>::zeros());
        trial.sigma.resize(n, Tensor::<D>::zeros());
        trial.f.resize(n, Tensor::<D>::zeros());
        trial.density.resize(n, 0.0);
        trial.carried = Rc::clone(&c.carried);
        // Constant moduli: the committed state's, shared; else the trial's own buffers.
        let moduli = if self.constant_moduli {
            trial.moduli = Rc::clone(&c.moduli);
            None
        } else {
            let m = Rc::make_mut(&mut trial.moduli);
            m.lambda.resize(n, 0.0);
            m.mu.resize(n, 0.0);
            Some((&mut m.lambda[..], &mut m.mu[..]))
        };
        let fault = kernels::grid_to_particle(
            self.whole(),
            &c.carried.material,
            &c.carried.mass,
            &c.carried.volume0,
            &self.node_v1,
            dt,
            Committed {
                x: &c.x,
                v: &c.v,
                sigma: &c.sigma,
                f: &c.f,
                weights: ViewWeightsNd::formed(&self.grid, self.shape, &c.x, &c.carried.domain),
                node_a: &c.node_a,
            },
            Written {
                x: &mut trial.x,
                v: &mut trial.v,
                sigma: &mut trial.sigma,
                f: &mut trial.f,
                density: &mut trial.density,
                moduli,
            },
            self.summarize,
        );
        let (t, step) = (c.t, c.step);
        let mut result = fault.map_err(|f| step_error(f, t, step, dt));
        if let Some(slab) = self.split.slab() {
            let moved = crate::nd::migration::migrate(slab, &mut trial, result.is_err());
            if let (Ok(_), Err(index)) = (&result, moved) {
                // It jumped past the neighbouring slab: a blow-up, as leaving the box is.
                result = Err(StepError::OutOfDomain {
                    index,
                    axis: D - 1,
                    x: trial.x[index][D - 1],
                    t,
                    step,
                    dt,
                });
            }
        }
        let derived = self.derive_state(&mut trial, result.is_err());
        let local = match (&result, &derived) {
            (Ok(_), Ok(local)) => *local,
            _ => None,
        };
        trial.summary = self.trial_summary(result.as_ref().ok().copied(), local);
        let result = result.and_then(|_| {
            derived.map(|_| ()).map_err(|index| {
                let axis = self.whole().axis_outside(&trial.x[index]).unwrap_or(0);
                StepError::OutOfDomain {
                    index,
                    axis,
                    x: trial.x[index][axis],
                    t,
                    step,
                    dt,
                }
            })
        });
        trial.t = t + dt;
        trial.step = step + 1;
        self.trial = trial;
        self.has_trial = result.is_ok();
        result
    }

    /// The trial's [`SummaryNd`] while summaries are on: the pass's totals `mine` (`None`:
    /// this process's part failed) completed over the processes of a split run, with the
    /// element bound and speed-of-sound step `local` accumulated in the particle → grid
    /// pass. Every process takes part in the reductions, failed or not, in the order
    /// [`SolverNd::summary_of`] makes them (bounds, then totals).
    pub(super) fn trial_summary(
        &self,
        mine: Option<SummaryNd<D>>,
        local: Option<(f64, f64)>,
    ) -> Option<SummaryNd<D>> {
        if !self.summarize {
            return None;
        }
        let mine = mine.unwrap_or(SummaryNd {
            finite: false,
            kinetic: 0.0,
            strain: 0.0,
            first_moment: Vector::<D>::zeros(),
            element_bound: None,
            sound_unit_step: None,
        });
        let (element_bound, sound_unit_step) = self.whole_run_bounds(local);
        Some(SummaryNd {
            element_bound,
            sound_unit_step,
            ..self.whole_run_summary(mine)
        })
    }
}

/// The trial error of a particle's fault in the step of `dt` from `(t, step)`.
fn step_error(fault: ParticleFault, t: f64, step: u64, dt: f64) -> StepError {
    match fault {
        ParticleFault::NonFinite(field, index) => StepError::NonFinite {
            field,
            index,
            t,
            step,
            dt,
        },
        ParticleFault::OutOfDomain(index, axis, x) => StepError::OutOfDomain {
            index,
            axis,
            x,
            t,
            step,
            dt,
        },
        ParticleFault::Inverted(index, det_f) => StepError::Inverted {
            index,
            det_f,
            t,
            step,
            dt,
        },
    }
}
