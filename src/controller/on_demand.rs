//! The controller's side of a stepper that hands over its arrays on demand
//! ([`crate::Stepper::provide_arrays_on_demand`]): which calls need a state's particle and
//! nodal arrays, and their loading.
//!
//! Asked in single-process runs only (the limits' answers are their own process's). Before
//! the proposals, the committed state's arrays are loaded when its door check's contents
//! are due ([`crate::view_check`]) or some limit's proposal reads them; before the
//! judgement and before the acceptance, both states' arrays are loaded when some limit's
//! call reads them ([`crate::StepLimit::reads_arrays`], asked with the trial's view) or the
//! trial's summary is not finite (the scan then names the particle). A loaded state stays
//! loaded: the stepper keeps it until it is replaced.
//!
//! Where every limit that reads arrays for a judgement or an acceptance reads the particle
//! arrays alone ([`crate::StepLimit::reads_nodal`]: the temporal-error check against a
//! history), the committed state's particles are loaded without its weights and nodal
//! fields ([`crate::Stepper::load_particles`]; the rest of a read, at 8 192 particles in 2D
//! about four fifths of it), the trial in full all the same: accepted, it is the committed
//! state of the next proposals, which use its arrays where it holds them (the stability
//! limit's guard and refreshes), so that the run's decisions are those of full loads. The
//! limits are then asked again with the loaded trial, and the rest loaded where one of
//! them turns. A state of particles alone is summary-only to every other call: the door
//! check loads it in full where it reads it, and the proposals always (it is left so only
//! by a rejected trial, and with full loads it would be whole at the retry).

use super::{Controller, ControllerError};
use crate::dimension::{Dim, Dimension, StateView, ViewOf};
use crate::limit::LimitCall;
use crate::stepper::{StepError, Stepper};

impl<const D: usize> Controller<D>
where
    Dim<D>: Dimension,
{
    /// Asks the stepper to hand over on demand where the run allows it (one process).
    pub(super) fn ask_arrays_on_demand(&self, stepper: &mut dyn Stepper<D>) -> bool {
        self.reduce.size() == 1 && stepper.provide_arrays_on_demand(true)
    }

    /// Whether some limit's `call` reads the arrays (`state`: the committed view for a
    /// proposal, the trial's otherwise).
    fn limits_read(&self, call: LimitCall, state: &ViewOf<'_, D>) -> bool {
        self.limits.iter().any(|l| l.reads_arrays(call, state))
    }

    /// Whether the committed view's arrays must be loaded before the proposals of
    /// attempt `attempt`. A committed state holding its particles alone (loaded so for the
    /// check of a trial that was then rejected) is loaded in full: with full loads it
    /// would hold its arrays here, and the proposals of the retry are those of full loads.
    pub(super) fn arrays_to_propose(&self, view: &ViewOf<'_, D>, attempt: u32) -> bool {
        !view.holds_arrays()
            && (view.holds_particles()
                || self.contents_due(view.step_index(), attempt)
                || self.limits_read(LimitCall::Propose, view))
    }

    /// What of both states must be loaded before `call` on the trial `after`.
    pub(super) fn arrays_for_trial(
        &self,
        call: LimitCall,
        before: &ViewOf<'_, D>,
        after: &ViewOf<'_, D>,
    ) -> Need {
        let nonfinite =
            matches!(call, LimitCall::Judge { .. }) && after.first_nonfinite().is_some();
        let reading = self.limits.iter().filter(|l| l.reads_arrays(call, after));
        let (mut particles, mut full) = (false, nonfinite);
        for l in reading {
            particles = true;
            full |= l.reads_nodal(call, after);
        }
        if full && (!before.holds_arrays() || !after.holds_arrays()) {
            Need::Full
        } else if particles && (!before.holds_particles() || !after.holds_particles()) {
            Need::Particles
        } else {
            Need::Nothing
        }
    }

    /// Loads what both states need before `call` on the pending trial
    /// ([`Self::arrays_for_trial`]): the committed state's particles first where they
    /// suffice (the trial in full, module docs), then the rest where a limit asked again
    /// with the loaded trial reads it. The error says whether the trial's loading failed
    /// (`true`) or the committed state's (`false`).
    fn load_for_trial(
        &self,
        stepper: &mut dyn Stepper<D>,
        call: LimitCall,
    ) -> Result<(), (bool, StepError)> {
        for _ in 0..2 {
            let need = match stepper.trial_view() {
                Some(after) => self.arrays_for_trial(call, &stepper.view(), &after),
                None => Need::Nothing,
            };
            if need == Need::Nothing {
                break;
            }
            load(stepper, false, need == Need::Full).map_err(|e| (false, e))?;
            load(stepper, true, true).map_err(|e| (true, e))?;
        }
        Ok(())
    }
}

/// What of a state the next call reads ([`Controller::arrays_for_trial`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Need {
    /// Nothing more than the view holds.
    Nothing,
    /// The particle arrays ([`crate::Stepper::load_particles`]).
    Particles,
    /// Everything ([`crate::Stepper::load_arrays`]).
    Full,
}

impl<const D: usize> Controller<D>
where
    Dim<D>: Dimension,
{
    /// The committed view for the proposals of attempt `attempt`, its arrays loaded where
    /// they are read ([`Self::arrays_to_propose`]).
    pub(super) fn committed_view<'s>(
        &self,
        stepper: &'s mut dyn Stepper<D>,
        attempt: u32,
        t: f64,
    ) -> Result<ViewOf<'s, D>, ControllerError> {
        if self.arrays_on_demand && self.arrays_to_propose(&stepper.view(), attempt) {
            load_committed(stepper, t)?;
        }
        Ok(stepper.view())
    }

    /// Loads both states' arrays before the limits hear of an accepted trial of `dt`, where
    /// one of them reads them; a failure ends the run.
    pub(super) fn load_to_accept(
        &self,
        stepper: &mut dyn Stepper<D>,
        dt: f64,
        t: f64,
    ) -> Result<(), ControllerError> {
        if !self.arrays_on_demand {
            return Ok(());
        }
        self.load_for_trial(stepper, LimitCall::Accepted { dt })
            .map_err(|(_, source)| ControllerError::Stepper { t, source })
    }

    /// Loads both states' arrays before the judgement of the trial of `dt`, where a limit
    /// reads them or the trial's summary is not finite. The error says whether the trial's
    /// loading failed (`true`: the stepper's error on the trial, which a smaller step may
    /// cure) or the committed state's (`false`).
    pub(super) fn load_to_judge(
        &self,
        stepper: &mut dyn Stepper<D>,
        dt: f64,
    ) -> Result<(), (bool, StepError)> {
        if !self.arrays_on_demand {
            return Ok(());
        }
        self.load_for_trial(stepper, LimitCall::Judge { dt })
    }
}

/// Loads the committed state's arrays (`trial == false`) or the trial's — all of them
/// (`full`) or the particle arrays — and checks that the next view holds them: a stepper
/// that leaves it without ends the run.
pub(super) fn load<const D: usize>(
    stepper: &mut dyn Stepper<D>,
    trial: bool,
    full: bool,
) -> Result<(), StepError>
where
    Dim<D>: Dimension,
{
    // Whether the state holds everything (`whole`) or at least its particles.
    let holds = |stepper: &dyn Stepper<D>, whole: bool| {
        let of = |v: &ViewOf<'_, D>| {
            if whole {
                v.holds_arrays()
            } else {
                v.holds_particles()
            }
        };
        match trial {
            false => of(&stepper.view()),
            true => stepper.trial_view().is_some_and(|v| of(&v)),
        }
    };
    if holds(stepper, full) {
        return Ok(());
    }
    match full {
        true => stepper.load_arrays(trial)?,
        false => stepper.load_particles(trial)?,
    }
    let mut loaded = holds(stepper, full);
    if !loaded && !full {
        // A view of no particles cannot show that it holds them alone: load it whole.
        stepper.load_arrays(trial)?;
        loaded = holds(stepper, true);
    }
    match loaded {
        true => Ok(()),
        false => Err(StepError::Other(format!(
            "{}({trial}) left the {} view without its arrays",
            if full {
                "load_arrays"
            } else {
                "load_particles"
            },
            if trial { "trial" } else { "committed" }
        ))),
    }
}

/// Loads the committed state's arrays before the proposals; a failure ends the run.
pub(super) fn load_committed<const D: usize>(
    stepper: &mut dyn Stepper<D>,
    t: f64,
) -> Result<(), ControllerError>
where
    Dim<D>: Dimension,
{
    load(stepper, false, true).map_err(|source| ControllerError::Stepper { t, source })
}
