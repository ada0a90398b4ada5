//! The moduli of a state dict: `"lame"` rows or the scalars `"youngs_modulus"`,
//! `"poisson_ratio"`, and with `"material"` each particle's tangent pair at its `F`
//! (`mpm_dt::tangent`).

use crate::arrays::{item, scalar, with_values};
use crate::errors::state_error;
use crate::state::{lame, StateNd};
use mpm_dt::nd::Tensor;
use pyo3::prelude::*;
use pyo3::types::PyDict;

impl<const D: usize> StateNd<D> {
    /// `"lame"` `(n, 2)` per particle, or the scalars `"youngs_modulus"`, `"poisson_ratio"`.
    pub(crate) fn read_moduli(&mut self, dict: &Bound<'_, PyDict>, n: usize) -> PyResult<()> {
        let py = dict.py();
        self.lame_lambda.clear();
        self.lame_mu.clear();
        if dict.contains("lame")? {
            let obj = item(dict, "lame")?;
            with_values(&obj, "lame", &[n, 2], |s| {
                for c in s.chunks_exact(2) {
                    self.lame_lambda.push(c[0]);
                    self.lame_mu.push(c[1]);
                }
            })?;
        } else {
            let e = scalar(dict, "youngs_modulus")?;
            let nu = scalar(dict, "poisson_ratio")?;
            if !(e.is_finite() && e >= 0.0 && nu > -1.0 && nu < 0.5) {
                return Err(state_error(
                    py,
                    format!(
                        "youngs_modulus = {e}, poisson_ratio = {nu}: need E >= 0 and -1 < nu < 0.5"
                    ),
                ));
            }
            let (l, m) = lame(e, nu);
            self.lame_lambda.resize(n, l);
            self.lame_mu.resize(n, m);
        }
        let bad = (0..n).find(|&p| {
            let (l, m) = (self.lame_lambda[p], self.lame_mu[p]);
            !(l.is_finite() && m.is_finite() && m >= 0.0 && l + 2.0 * m >= 0.0)
        });
        match bad {
            Some(p) => Err(state_error(py, format!("state[\"lame\"][{p}] = ({}, {}): need finite moduli with mu >= 0 and lambda + 2 mu >= 0", self.lame_lambda[p], self.lame_mu[p]))),
            None => Ok(()),
        }
    }

    /// `"material"` (optional): the moduli read so far are the material's small-strain
    /// pair, and each particle reports its tangent pair at its `F` instead
    /// (`mpm_dt::tangent`): `"neo_hookean"` the exact `(λ/J, (μ − λ ln J)/J)`,
    /// `"fixed_corotated"` (Stomakhin et al. 2012; mpm99, taichi_elements) an isotropic
    /// pair bounding its acoustic tensor and its tangent on symmetric tensors;
    /// `"linear_elastic"` (the default) keeps the pair as given. Called after the
    /// density, which refuses `det F ≤ 0` first.
    pub(crate) fn apply_material(&mut self, dict: &Bound<'_, PyDict>) -> PyResult<()> {
        let py = dict.py();
        if !dict.contains("material")? {
            return Ok(());
        }
        let name: String = item(dict, "material")?
            .extract()
            .map_err(|_| state_error(py, "state[\"material\"] must be a string".to_string()))?;
        let tangent: fn(f64, f64, &Tensor<D>) -> (f64, f64) = match name.as_str() {
            "linear_elastic" => return Ok(()),
            "neo_hookean" => mpm_dt::tangent::neo_hookean::<D>,
            "fixed_corotated" => mpm_dt::tangent::fixed_corotated::<D>,
            other => {
                return Err(state_error(
                    py,
                    format!("state[\"material\"] = {other:?}: expected \"linear_elastic\", \"neo_hookean\" or \"fixed_corotated\""),
                ))
            }
        };
        for ((l, m), f) in self
            .lame_lambda
            .iter_mut()
            .zip(&mut self.lame_mu)
            .zip(&self.f)
        {
            (*l, *m) = tangent(*l, *m, f);
        }
        match (0..self.f.len())
            .find(|&p| !(self.lame_lambda[p].is_finite() && self.lame_mu[p].is_finite()))
        {
            Some(p) => Err(state_error(
                py,
                format!(
                    "state[\"material\"] = {name:?}: no tangent moduli at particle {p} (F = {:?})",
                    self.f[p].as_slice()
                ),
            )),
            None => Ok(()),
        }
    }
}
