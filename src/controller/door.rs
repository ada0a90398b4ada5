//! The door check of the views the controller reads ([`crate::view_check`]): the committed
//! view before any limit proposes from it, the trial view before any limit judges it.

use super::{Controller, ControllerError};
use crate::dimension::{Dim, Dimension, StateView, ViewOf};
use crate::view_check::VIEW_CHECK_CADENCE;

impl<const D: usize> Controller<D>
where
    Dim<D>: Dimension,
{
    /// Whether the committed view's contents are checked at this step and attempt: the
    /// first view, then the first attempt of every `VIEW_CHECK_CADENCE`th step.
    pub(super) fn contents_due(&self, step: u64, attempt: u32) -> bool {
        !self.first_view_checked || (attempt == 1 && step.is_multiple_of(VIEW_CHECK_CADENCE))
    }

    /// Checks the committed view of attempt `attempt`: its shape always, its contents on
    /// the first view this controller reads and on the first attempt of every step whose
    /// index is a multiple of [`VIEW_CHECK_CADENCE`]. The processes of a distributed run
    /// agree on the outcome before any limit reads the view (one `any_flags`).
    pub(super) fn check_committed(
        &mut self,
        view: &ViewOf<'_, D>,
        attempt: u32,
    ) -> Result<(), ControllerError> {
        let step = view.step_index();
        let contents = self.contents_due(step, attempt);
        // A summary-only view of a stepper handing over on demand holds nothing to check;
        // it is loaded whenever the contents are due (`super::on_demand`). Any other
        // stepper's view is checked whole: one without its arrays is refused.
        let checked = view.holds_arrays() || !self.arrays_on_demand;
        let result = match checked {
            false => Ok(()),
            true => view.check_shape().and_then(|_| {
                if contents {
                    view.check_contents()
                } else {
                    Ok(())
                }
            }),
        };
        if contents && checked && result.is_ok() {
            self.first_view_checked = true;
        }
        let mut failed = [result.is_err()];
        if self.reduce.size() > 1 {
            self.reduce.any_flags(&mut failed);
        }
        let t = view.time();
        match result {
            Err(source) => Err(ControllerError::InvalidView {
                t,
                step,
                trial: false,
                source,
            }),
            Ok(()) if failed[0] => Err(ControllerError::OtherRank {
                t,
                phase: "at the door check of its view",
            }),
            Ok(()) => Ok(()),
        }
    }
}

/// The shape check of a trial view (its finite values are the trial check's business: a
/// non-finite trial is rejected and retried); a view without its arrays is checked only
/// where the stepper does not hand them over on demand (`on_demand`). `Some` ends the run.
pub(super) fn check_trial<V: StateView>(after: &V, on_demand: bool) -> Option<ControllerError> {
    if on_demand && !after.holds_arrays() {
        return None;
    }
    let source = after.check_shape().err()?;
    Some(ControllerError::InvalidView {
        t: after.time(),
        step: after.step_index(),
        trial: true,
        source,
    })
}
