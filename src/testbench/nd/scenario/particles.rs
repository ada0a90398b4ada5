//! The particles of a scenario: `per_cell`, explicit `positions`, or `bodies` (boxes and
//! balls filled cell-uniformly, later bodies replacing earlier particles).

use super::{invalid, per_axis, vector, Body, PerAxis, ScenarioError, ScenarioNd, MAX_PARTICLES};
use crate::nd::{GridNd, MaterialNd, ParticlesNd, Vector};
use std::collections::HashMap;

/// A body's region: whether a position lies inside it.
type Region<const D: usize> = Box<dyn Fn(&Vector<D>) -> bool>;

impl ScenarioNd {
    pub(super) fn particles<const D: usize>(
        &self,
        grid: &GridNd<D>,
        base: MaterialNd,
    ) -> Result<ParticlesNd<D>, ScenarioError> {
        let spec = &self.particles;
        let forms = [
            spec.per_cell.is_some(),
            spec.positions.is_some(),
            spec.bodies.is_some(),
        ];
        if forms.iter().filter(|&&f| f).count() != 1 {
            return Err(invalid(
                "particles",
                "give exactly one of per_cell, positions, bodies",
            ));
        }
        let n_cells: f64 = grid.cells.iter().map(|&c| c as f64).product();
        if let Some(pc) = &spec.per_cell {
            return self.per_cell_particles(grid, pc, n_cells, base);
        }
        if let Some(pos) = &spec.positions {
            return self.positioned_particles(grid, pos, n_cells, base);
        }
        let bodies = spec.bodies.as_deref().unwrap_or_default();
        self.body_particles(grid, bodies, n_cells)
    }

    /// The `per_cell` form: checks the counts and fills the grid uniformly.
    fn per_cell_particles<const D: usize>(
        &self,
        grid: &GridNd<D>,
        pc: &PerAxis<usize>,
        n_cells: f64,
        base: MaterialNd,
    ) -> Result<ParticlesNd<D>, ScenarioError> {
        let k: [usize; D] = per_axis(pc, "particles.per_cell")?;
        let per: f64 = k.iter().map(|&k| k as f64).product();
        if k.contains(&0) || n_cells * per > MAX_PARTICLES as f64 {
            return Err(invalid(
                "particles.per_cell",
                format!("must be ≥ 1 with at most {MAX_PARTICLES} particles in all"),
            ));
        }
        fits::<D>(n_cells * per, n_cells, "particles.per_cell")?;
        Ok(ParticlesNd::uniform(grid, k, self.density, base))
    }

    /// The explicit `positions` form, with optional volumes, masses, domains and moduli.
    fn positioned_particles<const D: usize>(
        &self,
        grid: &GridNd<D>,
        pos: &[Vec<f64>],
        n_cells: f64,
        base: MaterialNd,
    ) -> Result<ParticlesNd<D>, ScenarioError> {
        let spec = &self.particles;
        let n = pos.len();
        if n == 0 || n > MAX_PARTICLES {
            return Err(invalid(
                "particles.positions",
                format!("need 1 to {MAX_PARTICLES} positions"),
            ));
        }
        fits::<D>(n as f64, n_cells, "particles.positions")?;
        let x = pos
            .iter()
            .map(|p| vector::<D>(p, "particles.positions"))
            .collect::<Result<Vec<_>, _>>()?;
        let box_volume: f64 = (0..D).map(|a| grid.length(a)).product();
        let volume = match &spec.volumes {
            Some(v) => v.clone(),
            None => vec![box_volume / n as f64; n],
        };
        let mass = match &spec.masses {
            Some(m) => m.clone(),
            None => volume.iter().map(|v| self.density * v).collect(),
        };
        let domain = match &spec.domain_lengths {
            Some(d) => d
                .iter()
                .map(|l| vector::<D>(l, "particles.domain_lengths"))
                .collect::<Result<Vec<_>, _>>()?,
            // volume^(1/d) per axis, at most one cell (a GIMP domain longer than a cell
            // is not supported).
            None => volume
                .iter()
                .map(|v| Vector::<D>::from_fn(|a, _| v.powf(1.0 / D as f64).min(grid.h[a])))
                .collect(),
        };
        let material = match &spec.youngs_modulus {
            Some(e) => e
                .iter()
                .map(|&e| self.material(e, self.poisson_ratio))
                .collect(),
            None => vec![base; n],
        };
        Ok(ParticlesNd {
            v: vec![Vector::<D>::zeros(); n],
            x,
            mass,
            volume,
            domain,
            material,
        })
    }

    /// The `bodies` form: each body's uniform layout clipped to its region, merged in order.
    fn body_particles<const D: usize>(
        &self,
        grid: &GridNd<D>,
        bodies: &[Body],
        n_cells: f64,
    ) -> Result<ParticlesNd<D>, ScenarioError> {
        let mut out = ParticlesNd {
            x: vec![],
            v: vec![],
            mass: vec![],
            volume: vec![],
            domain: vec![],
            material: vec![],
        };
        let mut seen: HashMap<Vec<u64>, usize> = Default::default();
        for (b, body) in bodies.iter().enumerate() {
            let field = format!("particles.bodies[{b}]");
            let (k, velocity, density, material) =
                self.body_properties::<D>(body, &field, n_cells)?;
            let inside = body_region::<D>(body, &field)?;
            let layout = ParticlesNd::uniform(grid, k, density, material);
            let added = merge_body(&mut out, &mut seen, &layout, &inside, velocity, material);
            if added == 0 {
                return Err(invalid(&field, "contains no particle"));
            }
        }
        Ok(out)
    }

    /// Checks a body's settings and returns its per-cell counts, velocity, density and material.
    fn body_properties<const D: usize>(
        &self,
        body: &Body,
        field: &str,
        n_cells: f64,
    ) -> Result<([usize; D], Vector<D>, f64, MaterialNd), ScenarioError> {
        let k: [usize; D] = per_axis(body.per_cell.as_ref().unwrap_or(&PerAxis::One(2)), field)?;
        let per: f64 = k.iter().map(|&k| k as f64).product();
        if k.contains(&0) || n_cells * per > MAX_PARTICLES as f64 {
            return Err(invalid(
                field,
                "per_cell must be ≥ 1 and the layout not too large",
            ));
        }
        let velocity = match &body.velocity {
            Some(v) => vector::<D>(v, &format!("{field}.velocity"))?,
            None => Vector::<D>::zeros(),
        };
        let density = body.density.unwrap_or(self.density);
        let e = body.youngs_modulus.unwrap_or(self.youngs_modulus);
        let nu = body.poisson_ratio.unwrap_or(self.poisson_ratio);
        if !(density.is_finite() && density > 0.0) {
            return Err(invalid(&format!("{field}.density"), "must be positive"));
        }
        let material = self.material(e, nu);
        if !material.is_valid() {
            return Err(invalid(
                field,
                "youngs_modulus must be positive, 0 ≤ poisson_ratio < 0.5",
            ));
        }
        Ok((k, velocity, density, material))
    }
}

/// Checks a body's shape (exactly one of box, ball) and returns its region test.
fn body_region<const D: usize>(body: &Body, field: &str) -> Result<Region<D>, ScenarioError> {
    match (&body.box_, &body.ball) {
        (Some(bx), None) => {
            let lo = vector::<D>(&bx.min, &format!("{field}.box.min"))?;
            let hi = vector::<D>(&bx.max, &format!("{field}.box.max"))?;
            Ok(Box::new(move |x| {
                (0..D).all(|a| x[a] >= lo[a] && x[a] <= hi[a])
            }))
        }
        (None, Some(ball)) => {
            let c = vector::<D>(&ball.center, &format!("{field}.ball.center"))?;
            let r = ball.radius;
            if !(r.is_finite() && r > 0.0) {
                return Err(invalid(&format!("{field}.ball.radius"), "must be positive"));
            }
            Ok(Box::new(move |x| (x - c).norm() <= r))
        }
        _ => Err(invalid(field, "give exactly one of box, ball")),
    }
}

/// Adds a body's particles inside its region to `out`, replacing earlier ones at the same
/// lattice point; returns how many of its particles lie inside.
fn merge_body<const D: usize>(
    out: &mut ParticlesNd<D>,
    seen: &mut HashMap<Vec<u64>, usize>,
    layout: &ParticlesNd<D>,
    inside: &Region<D>,
    velocity: Vector<D>,
    material: MaterialNd,
) -> usize {
    let mut added = 0;
    for p in 0..layout.len() {
        if !inside(&layout.x[p]) {
            continue;
        }
        added += 1;
        let key: Vec<u64> = layout.x[p].iter().map(|c| c.to_bits()).collect();
        // A later body replaces an earlier one's particle at the same lattice point.
        let slot = match seen.get(&key) {
            Some(&i) => i,
            None => {
                seen.insert(key, out.x.len());
                out.x.push(layout.x[p]);
                out.v.push(velocity);
                out.mass.push(0.0);
                out.volume.push(0.0);
                out.domain.push(layout.domain[p]);
                out.material.push(material);
                out.x.len() - 1
            }
        };
        out.v[slot] = velocity;
        out.mass[slot] = layout.mass[p];
        out.volume[slot] = layout.volume[p];
        out.domain[slot] = layout.domain[p];
        out.material[slot] = material;
    }
    added
}

/// Peak bytes per particle of a controlled run of the reference solver, rounded up from
/// the measured 389 B (2D) and 615 B (3D) at 10⁶ particles (`docs/performance.md`).
const PEAK_BYTES_PER_PARTICLE: [f64; 4] = [0.0, 400.0, 450.0, 700.0];

/// Refuses up front a run of `n` particles on `n_cells` cells that the available memory
/// cannot hold (the nodal fields and the tracker's vectors about 1 kB a node).
fn fits<const D: usize>(n: f64, n_cells: f64, field: &str) -> Result<(), ScenarioError> {
    let per_particle = PEAK_BYTES_PER_PARTICLE[D.min(3)];
    crate::memory::check(per_particle * n + 1000.0 * n_cells)
        .map_err(|reason| invalid(field, reason))
}
