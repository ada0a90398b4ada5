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
    /// attempt `attempt`.
    pub(super) fn arrays_to_propose(&self, view: &ViewOf<'_, D>, attempt: u32) -> bool {
        !view.holds_arrays()
            && (self.contents_due(view.step_index(), attempt)
                || self.limits_read(LimitCall::Propose, view))
    }

    /// Whether both states' arrays must be loaded before `call` on the trial `after`.
    pub(super) fn arrays_for_trial(
        &self,
        call: LimitCall,
        before: &ViewOf<'_, D>,
        after: &ViewOf<'_, D>,
    ) -> bool {
        (!before.holds_arrays() || !after.holds_arrays())
            && ((matches!(call, LimitCall::Judge { .. }) && after.first_nonfinite().is_some())
                || self.limits_read(call, after))
    }
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
        let need = match stepper.trial_view() {
            Some(after) => {
                self.arrays_for_trial(LimitCall::Accepted { dt }, &stepper.view(), &after)
            }
            None => false,
        };
        if need {
            load_committed(stepper, t)?;
            load(stepper, true).map_err(|source| ControllerError::Stepper { t, source })?;
        }
        Ok(())
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
        let need = match stepper.trial_view() {
            Some(after) => self.arrays_for_trial(LimitCall::Judge { dt }, &stepper.view(), &after),
            None => false,
        };
        if need {
            load(stepper, false).map_err(|e| (false, e))?;
            load(stepper, true).map_err(|e| (true, e))?;
        }
        Ok(())
    }
}

/// Loads the committed state's arrays (`trial == false`) or the trial's, and checks that
/// the next view holds them: a stepper that leaves it summary-only ends the run.
pub(super) fn load<const D: usize>(
    stepper: &mut dyn Stepper<D>,
    trial: bool,
) -> Result<(), StepError>
where
    Dim<D>: Dimension,
{
    stepper.load_arrays(trial)?;
    let holds = match trial {
        false => stepper.view().holds_arrays(),
        true => stepper.trial_view().is_some_and(|v| v.holds_arrays()),
    };
    match holds {
        true => Ok(()),
        false => Err(StepError::Other(format!(
            "load_arrays({trial}) left the {} view without its arrays",
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
    load(stepper, false).map_err(|source| ControllerError::Stepper { t, source })
}
