//! One trial step of a [`SolverNd`].

use super::{SolverNd, StateNd};
use crate::nd::factor_metric::ParticleBounds;
use crate::nd::kernels;
use crate::nd::{SummaryNd, Tensor, Vector, ViewWeightsNd};
use crate::stepper::StepError;
use crate::testbench::nd::fused::{fused_step, FusedInputs, NodalSums};
use crate::testbench::nd::threaded::ThreadScratch;
use crate::testbench::nd::update::{self, Committed, ParticleFault, Written};
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
        if self.constant_moduli {
            trial.moduli = Rc::clone(&c.moduli);
        } else {
            let m = Rc::make_mut(&mut trial.moduli);
            m.lambda.resize(n, 0.0);
            m.mu.resize(n, 0.0);
        }
        let (t, step) = (c.t, c.step);
        let (result, derived) = if self.split.slab().is_none() {
            let mut scratch = std::mem::take(&mut self.scratch);
            let parts = self.fused_trial(dt, &mut trial, &mut scratch);
            self.scratch = scratch;
            parts
        } else {
            self.two_pass_trial(dt, &mut trial)
        };
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

    /// Grid → particle into `trial`, then the particle → grid pass at the new positions,
    /// in one pass over the particles ([`crate::testbench::nd::fused`]): the trial's totals (or the
    /// error of its first failed particle) and its derived state's
    /// [`SolverNd::derive_state`] result.
    fn fused_trial(
        &self,
        dt: f64,
        trial: &mut StateNd<D>,
        scratch: &mut ThreadScratch,
    ) -> TrialParts<D> {
        let c = &self.committed;
        let StateNd {
            x,
            v,
            sigma,
            f,
            density,
            moduli,
            node_mass,
            node_v,
            node_a,
            active,
            ..
        } = trial;
        let constant = self
            .constant_moduli
            .then(|| (&c.moduli.lambda[..], &c.moduli.mu[..]));
        let moduli = match constant {
            Some(_) => None,
            None => {
                let m = Rc::make_mut(moduli);
                Some((&mut m.lambda[..], &mut m.mu[..]))
            }
        };
        let inputs = FusedInputs {
            dt,
            grid: &self.grid,
            shape: self.shape,
            material: &c.carried.material,
            mass: &c.carried.mass,
            volume0: &c.carried.volume0,
            domain: &c.carried.domain,
            node_v1: &self.node_v1,
            constant_moduli: constant,
        };
        let from = self.committed_view();
        let mut into = Written {
            x,
            v,
            sigma,
            f,
            density,
            moduli,
        };
        let sums = NodalSums {
            mass: node_mass,
            momentum: node_v,
            force: node_a,
        };
        let h: [f64; D] = std::array::from_fn(|a| self.grid.h[a]);
        let mut bounds = self.summarize.then(|| ParticleBounds::detached(h));
        let threads = self.threads.as_deref().map(|pool| (pool, scratch));
        let outcome = fused_step(threads, &inputs, &from, &mut into, sums, bounds.as_mut());
        let outcome = match outcome {
            Ok(outcome) => outcome,
            Err(fault) => {
                self.take_part_after_failure();
                return (Err(self.step_error(fault, dt)), Ok(None));
            }
        };
        let complete = |m: &mut Vec<f64>, v: &mut Vec<Vector<D>>, a: &mut Vec<Vector<D>>| {
            self.split.complete_nodal(m, v, a)
        };
        kernels::finish_nodal_on(
            self.threads.as_deref(),
            (node_mass, node_v, node_a, active),
            &self.gravity,
            &self.constrained,
            self.threshold,
            &complete,
        );
        let derived = match outcome.unformed {
            Some(p) => Err(p),
            None => Ok(bounds.map(|b| b.result())),
        };
        (Ok(outcome.summary), derived)
    }

    /// Grid → particle into `trial`; on a grid split into slabs the particles that left
    /// this process's slab move to their new one; then the particle → grid pass at the
    /// new positions ([`SolverNd::derive_state`]).
    fn two_pass_trial(&self, dt: f64, trial: &mut StateNd<D>) -> TrialParts<D> {
        let c = &self.committed;
        let moduli = if self.constant_moduli {
            None
        } else {
            let m = Rc::make_mut(&mut trial.moduli);
            Some((&mut m.lambda[..], &mut m.mu[..]))
        };
        let fault = update::grid_to_particle(
            self.whole(),
            &c.carried.material,
            &c.carried.mass,
            &c.carried.volume0,
            &self.node_v1,
            dt,
            self.committed_view(),
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
        let mut result = fault.map_err(|f| self.step_error(f, dt));
        if let Some(slab) = self.split.slab() {
            let moved = crate::testbench::nd::migration::migrate(slab, trial, result.is_err());
            if let (Ok(_), Err(index)) = (&result, moved) {
                // It jumped past the neighbouring slab: a blow-up, as leaving the box is.
                result = Err(StepError::OutOfDomain {
                    index,
                    axis: D - 1,
                    x: trial.x[index][D - 1],
                    t: c.t,
                    step: c.step,
                    dt,
                });
            }
        }
        let derived = self.derive_state(trial, result.is_err());
        (result, derived)
    }

    /// The committed state as a step reads it (its weights formed from its positions).
    fn committed_view(&self) -> Committed<'_, D> {
        let c = &self.committed;
        Committed {
            x: &c.x,
            v: &c.v,
            sigma: &c.sigma,
            f: &c.f,
            weights: ViewWeightsNd::formed(&self.grid, self.shape, &c.x, &c.carried.domain),
            node_a: &c.node_a,
        }
    }

    /// The trial error of a particle's fault in the step of `dt` from the committed state.
    fn step_error(&self, fault: ParticleFault, dt: f64) -> StepError {
        step_error(fault, self.committed.t, self.committed.step, dt)
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
        let mine = mine.unwrap_or(SummaryNd::zero(false));
        let (element_bound, sound_unit_step) = self.whole_run_bounds(local);
        Some(SummaryNd {
            element_bound,
            sound_unit_step,
            ..self.whole_run_summary(mine)
        })
    }
}

/// The trial's totals (or its error) and its derived state's [`SolverNd::derive_state`]
/// result.
type TrialParts<const D: usize> = (
    Result<SummaryNd<D>, StepError>,
    Result<Option<(f64, f64)>, usize>,
);

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nd::{GridNd, MaterialNd, ParticlesNd, ShapeNd};
    use crate::{Boundary, Stepper};

    /// Bit patterns of a state's particle and nodal fields and of its summary.
    fn bits<const D: usize>(s: &StateNd<D>) -> Vec<u64> {
        let mut out: Vec<u64> = Vec::new();
        for p in 0..s.x.len() {
            out.extend(s.x[p].iter().chain(&s.v[p]).map(|c| c.to_bits()));
            out.extend(s.sigma[p].iter().chain(s.f[p].iter()).map(|c| c.to_bits()));
            out.push(s.density[p].to_bits());
            out.extend([s.moduli.lambda[p].to_bits(), s.moduli.mu[p].to_bits()]);
        }
        out.extend(s.node_mass.iter().map(|m| m.to_bits()));
        for i in 0..s.node_v.len() {
            out.extend(s.node_v[i].iter().chain(&s.node_a[i]).map(|c| c.to_bits()));
            out.push(u64::from(s.active[i]));
        }
        if let Some(sum) = &s.summary {
            out.extend([sum.kinetic, sum.strain].map(f64::to_bits));
            out.extend(sum.first_moment.iter().map(|c| c.to_bits()));
            out.extend(
                [sum.element_bound, sum.sound_unit_step].map(|b| b.map(f64::to_bits).unwrap_or(1)),
            );
        }
        out
    }

    /// A moving, sheared block of jittered particles on a 2D grid with the given walls.
    fn solver(shape: ShapeNd, boundary: Boundary, material: MaterialNd) -> SolverNd<2> {
        let grid = GridNd::<2>::new([boundary; 2], [12, 10], [1.2, 1.0]);
        let mut particles = ParticlesNd::uniform(&grid, [2, 2], 1000.0, material);
        let mut seed = 7u64;
        let mut jitter = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.02
        };
        for p in 0..particles.len() {
            let x = particles.x[p];
            particles.x[p][0] += jitter();
            particles.x[p][1] += jitter();
            particles.v[p][0] = 0.3 * (x[1] - 0.5);
            particles.v[p][1] = -0.2 * (x[0] - 0.6) + jitter();
        }
        match SolverNd::new(grid, shape, particles, [0.0, -9.8].into()) {
            Ok(s) => s,
            Err(e) => panic!("set-up: {e}"),
        }
    }

    /// The fused step writes the same trial, bit for bit, as grid → particle followed by
    /// particle → grid, for every shape, both boundaries, constant and evolving moduli,
    /// with summaries off and on. On a CPU with AVX2 the fused step runs in its AVX2 build
    /// and the two passes in the baseline build, so this also checks that the two builds
    /// agree bit for bit ([`crate::cpu`]).
    #[test]
    fn the_fused_step_is_the_two_passes_bit_for_bit() {
        let materials = [
            MaterialNd::LinearElastic {
                youngs_modulus: 1e5,
                poisson_ratio: 0.3,
            },
            MaterialNd::NeoHookean {
                youngs_modulus: 1e5,
                poisson_ratio: 0.3,
            },
        ];
        let mut compared = 0;
        for shape in [ShapeNd::Gimp, ShapeNd::Linear, ShapeNd::BSpline2] {
            for boundary in [Boundary::Periodic, Boundary::Fixed] {
                if shape == ShapeNd::BSpline2 && boundary == Boundary::Fixed {
                    continue; // B-splines are periodic only
                }
                for material in materials {
                    for summarize in [false, true] {
                        let mut s = solver(shape, boundary, material);
                        s.provide_summary(summarize);
                        for _ in 0..5 {
                            let mut fused = StateNd::default();
                            let mut two = StateNd::default();
                            for (state, fuse) in [(&mut fused, true), (&mut two, false)] {
                                s.trial_step(1e-3).expect("a stable step");
                                *state = s.trial.clone();
                                let parts = if fuse {
                                    s.fused_trial(1e-3, state, &mut ThreadScratch::default())
                                } else {
                                    s.two_pass_trial(1e-3, state)
                                };
                                assert!(parts.0.is_ok() && parts.1.is_ok());
                                let local = parts.1.expect("formed");
                                state.summary = s.trial_summary(parts.0.ok(), local);
                            }
                            assert_eq!(bits(&fused), bits(&two), "{shape:?} {boundary:?}");
                            s.try_step(1e-3).expect("a stable step");
                            s.accept().expect("accepted");
                            compared += 1;
                        }
                    }
                }
            }
        }
        assert_eq!(compared, 5 * 5 * 2 * 2);
    }
}
