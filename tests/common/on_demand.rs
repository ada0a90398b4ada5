//! [`OnDemand`]: a 2D reference solver handing over its arrays on demand, as a solver on a
//! GPU or in Python would: its views hold only the pass summary (with the element bound,
//! computed by the library's function from the full view) until the controller loads
//! them. Counts the loads; can mark trials' summaries non-finite (as a blown-up pass
//! would), can refuse to load, and can load a state's particle arrays alone
//! (`Stepper::load_particles`, its view then `ViewNd::without_nodal`).

use mpm_dt::limits_nd::element_bound::element_bound;
use mpm_dt::nd::{SolverNd, SummaryNd};
use mpm_dt::reduce::SingleProcess;
use mpm_dt::{StepError, Stepper, ViewNd};

/// The solver, handing over its arrays when the controller asks for them.
pub struct OnDemand {
    solver: SolverNd<2>,
    /// Whether the summaries carry the element bound.
    bound: bool,
    /// Whether the stepper offers to hand over on demand at all.
    pub offer: bool,
    committed_loaded: bool,
    trial_loaded: bool,
    /// Whether `load_particles` loads the particle arrays alone (else everything).
    pub particles_alone: bool,
    committed_particles: bool,
    trial_particles: bool,
    /// `load_arrays` calls that loaded a state.
    pub loads: usize,
    /// `load_particles` calls that loaded a state's particles alone.
    pub particle_loads: usize,
    /// Trials still to be marked non-finite (the next ones `try_step` computes).
    pub poison_trials: u32,
    trial_poisoned: bool,
    /// Whether `load_arrays` does nothing (a broken stepper).
    pub refuse_to_load: bool,
    /// Whether every view leaves out its nodal arrays (a broken stepper).
    pub hide_nodal: bool,
}

impl OnDemand {
    /// `solver` handing over its summaries with the element bound (`bound`) or without.
    pub fn new(solver: SolverNd<2>, bound: bool) -> Self {
        Self {
            solver,
            bound,
            offer: true,
            committed_loaded: false,
            trial_loaded: false,
            particles_alone: false,
            committed_particles: false,
            trial_particles: false,
            loads: 0,
            particle_loads: 0,
            poison_trials: 0,
            trial_poisoned: false,
            refuse_to_load: false,
            hide_nodal: false,
        }
    }

    /// The view as the controller sees it: full when loaded, its particles when they are,
    /// else its summary only.
    fn shown<'a>(
        &self,
        full: ViewNd<'a, 2>,
        (loaded, particles): (bool, bool),
        poisoned: bool,
    ) -> ViewNd<'a, 2> {
        let element_bound = self
            .bound
            .then(|| element_bound(&full, &SingleProcess).lambda);
        let summary = full.summary.map(|s| SummaryNd {
            finite: s.finite && !poisoned,
            element_bound,
            ..s
        });
        match (loaded || !self.offer, particles) {
            _ if self.hide_nodal => ViewNd { summary, ..full }.without_nodal(),
            (true, _) => ViewNd { summary, ..full },
            (false, true) => ViewNd { summary, ..full }.without_nodal(),
            (false, false) => ViewNd::summary_only(full.t, full.step, full.grid, summary.unwrap()),
        }
    }
}

impl Stepper<2> for OnDemand {
    fn time(&self) -> f64 {
        self.solver.time()
    }
    fn step_count(&self) -> u64 {
        self.solver.step_count()
    }
    fn try_step(&mut self, dt: f64) -> Result<(), StepError> {
        self.trial_loaded = false;
        self.trial_particles = false;
        self.trial_poisoned = false;
        self.solver.try_step(dt)?;
        if self.poison_trials > 0 {
            self.poison_trials -= 1;
            self.trial_poisoned = true;
        }
        Ok(())
    }
    fn accept(&mut self) -> Result<(), StepError> {
        self.solver.accept()?;
        self.committed_loaded = self.trial_loaded;
        self.committed_particles = self.trial_particles;
        self.trial_loaded = false;
        self.trial_particles = false;
        Ok(())
    }
    fn reject(&mut self) {
        self.trial_loaded = false;
        self.trial_particles = false;
        self.solver.reject()
    }
    fn view(&self) -> ViewNd<'_, 2> {
        let loaded = (self.committed_loaded, self.committed_particles);
        self.shown(self.solver.view(), loaded, false)
    }
    fn trial_view(&self) -> Option<ViewNd<'_, 2>> {
        let full = self.solver.trial_view()?;
        let loaded = (self.trial_loaded, self.trial_particles);
        Some(self.shown(full, loaded, self.trial_poisoned))
    }
    fn provide_summary(&mut self, on: bool) -> bool {
        self.solver.provide_summary(on)
    }
    fn provide_arrays_on_demand(&mut self, on: bool) -> bool {
        on && self.offer
    }
    fn load_arrays(&mut self, trial: bool) -> Result<(), StepError> {
        if self.refuse_to_load {
            return Ok(());
        }
        let loaded = match trial {
            true => &mut self.trial_loaded,
            false => &mut self.committed_loaded,
        };
        if !*loaded {
            *loaded = true;
            self.loads += 1;
        }
        match trial {
            true => self.trial_particles = true,
            false => self.committed_particles = true,
        }
        if trial && self.trial_poisoned {
            // What a read of a blown-up trial finds.
            return Err(StepError::NonFinite {
                field: "v",
                index: 3,
                t: self.solver.time(),
                step: self.solver.step_count(),
                dt: f64::NAN,
            });
        }
        Ok(())
    }

    fn load_particles(&mut self, trial: bool) -> Result<(), StepError> {
        if !self.particles_alone {
            return self.load_arrays(trial);
        }
        let (loaded, particles) = match trial {
            true => (self.trial_loaded, &mut self.trial_particles),
            false => (self.committed_loaded, &mut self.committed_particles),
        };
        if !loaded && !*particles {
            *particles = true;
            self.particle_loads += 1;
        }
        Ok(())
    }
}
