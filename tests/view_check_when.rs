//! Capability: when the door check runs. The shape of every view (committed and trial) is
//! checked on every attempt; the contents on the first view a controller reads and then on
//! every `VIEW_CHECK_CADENCE`-th step; in a distributed run the processes agree on the
//! outcome before any limit reads the view.

use mpm_dt::controller::standard_limits;
use mpm_dt::controller::{Controller, ControllerConfig, ControllerError};
use mpm_dt::nd::scenario::ScenarioNd;
use mpm_dt::nd::{SolverNd, Vector, WeightsNd};
use mpm_dt::view_check::VIEW_CHECK_CADENCE;
use mpm_dt::{StepError, Stepper, ViewError, ViewNd};

/// A 2D solver that goes wrong from step `from` on: its committed weights are halved, or
/// its trial's `lame_mu` is one element short.
struct GoesWrong {
    inner: SolverNd<2>,
    from: u64,
    trial_short: bool,
    halved: WeightsNd<2>,
}

impl GoesWrong {
    fn new(from: u64, trial_short: bool) -> Self {
        let path = format!(
            "{}/scenarios/nd/plane_p_2d.json",
            env!("CARGO_MANIFEST_DIR")
        );
        let (inner, _) = ScenarioNd::from_file(path)
            .expect("scenario")
            .build::<2>()
            .expect("solver");
        let mut s = Self {
            inner,
            from,
            trial_short,
            halved: WeightsNd::default(),
        };
        s.halve();
        s
    }

    /// The committed weights, halved.
    fn halve(&mut self) {
        let w = self.inner.view().weights.to_stored();
        let n = w.n_particles();
        let nodes = (0..n).flat_map(|p| w.nodes_of(p).to_vec()).collect();
        let s = (0..n)
            .flat_map(|p| w.s_of(p).iter().map(|s| 0.5 * s))
            .collect();
        let g = (0..n).flat_map(|p| w.grad_of(p).to_vec()).collect();
        self.halved = WeightsNd::from_rows(w.n_nodes(), w.width(), nodes, s, g).expect("rows");
    }

    fn wrong(&self) -> bool {
        self.inner.step_count() >= self.from
    }
}

impl Stepper<2> for GoesWrong {
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
        self.inner.accept()?;
        self.halve();
        Ok(())
    }
    fn reject(&mut self) {
        self.inner.reject()
    }
    fn view(&self) -> ViewNd<'_, 2> {
        let view = self.inner.view();
        if self.wrong() && !self.trial_short {
            ViewNd {
                weights: (&self.halved).into(),
                ..view
            }
        } else {
            view
        }
    }
    fn trial_view(&self) -> Option<ViewNd<'_, 2>> {
        let view = self.inner.trial_view()?;
        Some(if self.wrong() && self.trial_short {
            ViewNd {
                lame_mu: &view.lame_mu[1..],
                ..view
            }
        } else {
            view
        })
    }
}

fn controller() -> Controller<2> {
    let config = ControllerConfig::default();
    let limits = standard_limits(&config, Vector::<2>::zeros());
    Controller::<2>::new(config, limits).expect("controller")
}

/// Steps until the controller fails; the error and the step count reached.
fn run_to_failure(s: &mut GoesWrong, c: &mut Controller<2>) -> (ControllerError, u64) {
    loop {
        if let Err(e) = c.step(s, 100.0) {
            return (e, s.step_count());
        }
        assert!(s.step_count() <= 2 * VIEW_CHECK_CADENCE, "never caught");
    }
}

#[test]
fn contents_are_checked_on_the_cadence_and_by_a_new_controller() {
    // Weights go wrong from step 5: the next contents check is at the cadence.
    let mut s = GoesWrong::new(5, false);
    let mut c = controller();
    let (e, step) = run_to_failure(&mut s, &mut c);
    assert_eq!(step, VIEW_CHECK_CADENCE);
    assert!(
        matches!(
            e,
            ControllerError::InvalidView {
                step,
                trial: false,
                source: ViewError::PartitionOfUnity { .. },
                ..
            } if step == VIEW_CHECK_CADENCE
        ),
        "{e}"
    );
    // A controller starting on a state off the cadence checks its first view.
    let mut s = GoesWrong::new(0, false);
    for _ in 0..3 {
        s.inner.try_step(1e-3).expect("trial");
        s.inner.accept().expect("accept");
        s.halve();
    }
    let err = controller().step(&mut s, 100.0).unwrap_err();
    assert!(
        matches!(err, ControllerError::InvalidView { step: 3, .. }),
        "{err}"
    );
}

#[test]
fn a_trial_view_one_short_ends_the_run_on_the_trial() {
    let mut s = GoesWrong::new(2, true);
    let mut c = controller();
    let (e, step) = run_to_failure(&mut s, &mut c);
    assert_eq!(step, 2);
    let ControllerError::InvalidView {
        trial: true,
        source,
        ..
    } = &e
    else {
        panic!("{e}");
    };
    assert_eq!(source.array(), "lame_mu", "{e}");
    assert!(e.to_string().starts_with("invalid trial view"), "{e}");
}

/// Two processes, seen from the one whose view is fine: the other's view failed the door.
#[derive(Debug)]
struct OtherProcessFailsTheDoor;

impl mpm_dt::reduce::Reduce for OtherProcessFailsTheDoor {
    fn rank(&self) -> usize {
        0
    }
    fn size(&self) -> usize {
        2
    }
    fn min_and_any(&self, value: f64, flag: bool) -> (f64, bool) {
        (value, flag)
    }
    fn any_flags(&self, flags: &mut [bool]) {
        // The door's agreement is the one reduction of a single flag.
        if let [failed] = flags {
            *failed = true;
        }
    }
    fn sum(&self, _values: &mut [f64]) {}
    fn exchange(
        &self,
        _to: Option<usize>,
        from: Option<usize>,
        _tag: u16,
        send: &[f64],
    ) -> Option<Vec<f64>> {
        from.map(|_| send.to_vec())
    }
}

#[test]
fn every_process_stops_when_one_view_fails_the_door() {
    let mut s = GoesWrong::new(u64::MAX, false);
    let mut c = controller().with_reduce(std::rc::Rc::new(OtherProcessFailsTheDoor));
    let mut attempts = 0;
    let err = c
        .run_until(&mut s, 1.0, &mut |_| attempts += 1)
        .unwrap_err();
    assert!(
        matches!(err, ControllerError::OtherRank { phase, .. } if phase.contains("door")),
        "{err}"
    );
    assert_eq!((attempts, s.step_count()), (0, 0));
}
