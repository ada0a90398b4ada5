//! The standard controller in every dimension: [`Controller::standard`] and
//! [`Controller::with_default_limits`] for `D = 1, 2, 3`.
//!
//! One config builds the same four limits in every dimension, in this order: the sound-speed
//! cap (eq 49 with the particle speed), the stability limit (eqs 56–58), the temporal error
//! (eqs 20–30) and the growth monitor, each as the config enables and sets it. The
//! sound-speed cap is one limit for every dimension; the stability limit, the temporal error
//! and the growth monitor are one limit each whose rule differs by dimension, chosen by
//! [`StandardLimits`]:
//!
//! | limit | 1D | 2D and 3D |
//! |---|---|---|
//! | sound speed | [`crate::sound_speed::SoundSpeed`] | the same |
//! | stability | [`crate::stability::limit::Stability<1>`](crate::stability::limit::Stability) | [`crate::stability::limit::Stability<D>`](crate::stability::limit::Stability) |
//! | temporal error | [`crate::temporal::TemporalError<1>`] | [`crate::temporal::TemporalError<D>`] |
//! | growth | [`crate::growth::Growth<1>`] | [`crate::growth::Growth<D>`] (with `config.gravity`) |
//!
//! The dimension is the controller's type parameter: `Controller::<2>::standard(config)`.
//! Where the stepper fixes it, it is inferred (`Controller::standard(config)` followed by a
//! run of a 1D stepper is the 1D controller).

use super::TemporalError;
use super::{ConfigError, Controller, ControllerConfig, ControllerError};
use crate::dimension::{Dim, Dimension};
use crate::growth::Growth;
use crate::limit::StepLimit;
use crate::limits_nd::{StabilityNd, StabilityNdConfig, TemporalErrorNd};
use crate::nd::{Vector, ViewNd};
use crate::sound_speed::SoundSpeed;

/// The library's limits of one dimension, built from a [`ControllerConfig`] (module docs).
/// Implemented for `Dim<1>`, `Dim<2>` and `Dim<3>`.
pub trait StandardLimits<const D: usize> {
    /// The paper's two step limits as `config` enables them: the sound-speed cap
    /// (`config.sound_speed`) and the stability limit (`config.stability`, and in 2D/3D
    /// `config.stability_nd`). `config` must be valid for `D` ([`ControllerConfig::validate_for`]).
    fn paper_limits(config: &ControllerConfig) -> Result<Vec<Box<dyn StepLimit<D>>>, ConfigError>;

    /// The limits every run gets after the user's: the temporal error
    /// (`config.temporal.enabled`) and the growth monitor (`config.growth.enabled`).
    /// `config` must be valid for `D`.
    fn default_limits(config: &ControllerConfig)
        -> Result<Vec<Box<dyn StepLimit<D>>>, ConfigError>;
}

/// Maps a 1D limit's construction error (the config was validated, so this does not
/// happen) to the config error it stands for.
fn invalid(e: impl std::fmt::Display) -> ConfigError {
    ConfigError::Parse {
        message: e.to_string(),
        source: None,
    }
}

impl StandardLimits<1> for Dim<1> {
    fn paper_limits(config: &ControllerConfig) -> Result<Vec<Box<dyn StepLimit>>, ConfigError> {
        let mut limits: Vec<Box<dyn StepLimit>> = Vec::new();
        if let Some(c) = config.sound_speed {
            limits.push(Box::new(SoundSpeed::new(c)?));
        }
        if let Some(c) = config.stability {
            limits.push(Box::new(
                crate::stability::Stability::new(c).map_err(invalid)?,
            ));
        }
        Ok(limits)
    }

    fn default_limits(config: &ControllerConfig) -> Result<Vec<Box<dyn StepLimit>>, ConfigError> {
        let mut limits: Vec<Box<dyn StepLimit>> = Vec::new();
        if config.temporal.enabled {
            limits.push(Box::new(
                TemporalError::new(config.temporal.clone()).map_err(invalid)?,
            ));
        }
        if config.growth.enabled {
            limits.push(Box::new(
                Growth::<1>::new(config.growth.clone()).map_err(invalid)?,
            ));
        }
        Ok(limits)
    }
}

/// The 2D/3D limits of `config` ([`standard_limits`]' two halves); the
/// same for `Dim<2>` and `Dim<3>`.
macro_rules! standard_limits_nd {
    ($d:literal) => {
        impl StandardLimits<$d> for Dim<$d> {
            fn paper_limits(
                config: &ControllerConfig,
            ) -> Result<Vec<Box<dyn StepLimit<$d>>>, ConfigError> {
                Ok(paper_limits::<$d>(config))
            }

            fn default_limits(
                config: &ControllerConfig,
            ) -> Result<Vec<Box<dyn StepLimit<$d>>>, ConfigError> {
                Ok(default_limits::<$d>(config, gravity::<$d>(config)?))
            }
        }
    };
}

standard_limits_nd!(2);
standard_limits_nd!(3);

/// `config.gravity` as a vector (zero when unset), or the error naming its length.
fn gravity<const D: usize>(config: &ControllerConfig) -> Result<Vector<D>, ConfigError> {
    match &config.gravity {
        None => Ok(Vector::<D>::zeros()),
        Some(g) if g.len() == D => Ok(Vector::<D>::from_column_slice(g)),
        Some(g) => Err(ConfigError::WrongLength {
            field: "gravity",
            len: g.len(),
            dim: D,
        }),
    }
}

/// The standard constructors, in every dimension.
impl<const D: usize> Controller<D>
where
    Dim<D>: Dimension + StandardLimits<D>,
{
    /// A controller with `limits` (e.g. the sound-speed and stability limits, users' own)
    /// followed by the temporal-error limit and the growth monitor of dimension `D`
    /// ([`StandardLimits::default_limits`]) when the config enables them.
    pub fn with_default_limits(
        config: ControllerConfig,
        mut limits: Vec<Box<dyn StepLimit<D>>>,
    ) -> Result<Self, ControllerError> {
        config.validate_for(D)?;
        limits.extend(<Dim<D> as StandardLimits<D>>::default_limits(&config)?);
        Self::new(config, limits)
    }

    /// The standard mpm-dt controller in `D` dimensions: the three limits of the paper —
    /// the sound-speed cap (eq 49 with `|v|`), the stability limit (eqs 56–58, tracked
    /// λmax), the temporal error (eqs 20–30) — and the growth monitor, each as `config`
    /// enables and sets it (module docs: which implementation in which dimension). In
    /// 2D/3D the growth monitor counts the potential energy of `config.gravity`. Users add
    /// their own limits with [`Controller::with_default_limits`].
    pub fn standard(config: ControllerConfig) -> Result<Self, ControllerError> {
        config.validate_for(D)?;
        let limits = <Dim<D> as StandardLimits<D>>::paper_limits(&config)?;
        Self::with_default_limits(config, limits)
    }
}

/// The standard limits of a d-dimensional run, as `config` enables and sets them
/// (module docs): sound speed, stability, temporal error, growth. `gravity` is the run's
/// body force (the growth monitor counts its potential energy); `config.gravity` is not
/// read here. [`Controller::standard`] builds the same list with
/// `config.gravity`.
pub fn standard_limits<const D: usize>(
    config: &ControllerConfig,
    gravity: Vector<D>,
) -> Vec<Box<dyn StepLimit<D>>>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let mut limits = paper_limits(config);
    limits.extend(default_limits(config, gravity));
    limits
}

/// The first half of [`standard_limits`]: the sound-speed cap and the stability limit, as
/// `config.sound_speed` and `config.stability` enable them.
fn paper_limits<const D: usize>(config: &ControllerConfig) -> Vec<Box<dyn StepLimit<D>>>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let mut limits: Vec<Box<dyn StepLimit<D>>> = Vec::new();
    if let Some(s) = &config.sound_speed {
        // Unchecked here (this function returns no error): `Controller::new` validates the
        // config, `alpha` included, before any limit runs.
        limits.push(Box::new(SoundSpeed::unchecked(*s)));
    }
    if let Some(s) = &config.stability {
        limits.push(Box::new(StabilityNd::<D>::unchecked(StabilityNdConfig {
            safety: s.safety,
            ..config.stability_nd.clone()
        })));
    }
    limits
}

/// The second half of [`standard_limits`]: the temporal error and the growth monitor (with
/// body force `gravity`), as `config.temporal.enabled` and `config.growth.enabled` say.
fn default_limits<const D: usize>(
    config: &ControllerConfig,
    gravity: Vector<D>,
) -> Vec<Box<dyn StepLimit<D>>>
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let mut limits: Vec<Box<dyn StepLimit<D>>> = Vec::new();
    if config.temporal.enabled {
        limits.push(Box::new(TemporalErrorNd::<D>::new(config.temporal.clone())));
    }
    if config.growth.enabled {
        let growth = &config.growth;
        limits.push(Box::new(Growth::<D>::new(
            gravity,
            growth.windows as usize * growth.window as usize,
            growth.energy_tol,
        )));
    }
    limits
}
