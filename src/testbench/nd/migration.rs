//! Particles moving between the slabs of a grid-decomposed run ([`super::SolverNd::new_slab`]):
//! after the grid → particle pass of a trial, the particles that left this process's slab
//! are sent to the neighbour that owns them with every field that describes them, and the
//! ones that arrive are appended — first those from below, then those from above, each in
//! the order their sender held them. The committed state is untouched (a rejected trial
//! leaves every process with its own particles, bit for bit).

use super::slab::SlabNd;
use super::solver::{CarriedNd, StateNd};
use super::MaterialNd;
use crate::nd::{Tensor, Vector};
use std::rc::Rc;

/// Hands the particles of the trial `s` that left `slab` to the neighbours and takes in
/// theirs. Collective between neighbours: a process whose trial `failed` sends nothing
/// but takes part. Returns the first particle that jumped past the neighbouring slab, if
/// any (the trial then fails; the exchange has been made).
pub(super) fn migrate<const D: usize>(
    slab: &SlabNd<D>,
    s: &mut StateNd<D>,
    failed: bool,
) -> Result<(), usize> {
    let mut up = Vec::new();
    let mut down = Vec::new();
    // Usually empty: no per-step allocation when no particle leaves.
    let mut leaving = Vec::new();
    let mut stray = None;
    if !failed {
        for p in 0..s.x.len() {
            let y = s.x[p][D - 1];
            if slab.owns(y) {
                continue;
            }
            leaving.push(p);
            let out = match slab.direction(y) {
                Some(true) => &mut up,
                Some(false) => &mut down,
                None => {
                    stray = stray.or(Some(p));
                    continue;
                }
            };
            record_of(s, p).write(out);
        }
    }
    let arrived = slab.migrate(&up, &down);
    if let Some(p) = stray {
        return Err(p);
    }
    if failed || (leaving.is_empty() && arrived.is_empty()) {
        return Ok(());
    }
    let mut keep = vec![true; s.x.len()];
    for &p in &leaving {
        keep[p] = false;
    }
    let c = &*s.carried;
    let mut carried = CarriedNd::<D> {
        mass: retain(&c.mass, &keep),
        volume0: retain(&c.volume0, &keep),
        domain: retain(&c.domain, &keep),
        material: retain(&c.material, &keep),
        id: retain(&c.id, &keep),
    };
    s.x = retain(&s.x, &keep);
    s.v = retain(&s.v, &keep);
    s.sigma = retain(&s.sigma, &keep);
    s.f = retain(&s.f, &keep);
    s.density = retain(&s.density, &keep);
    // The moduli of this trial alone (a copy where they were shared with the committed
    // state, which keeps its particles).
    let moduli = Rc::make_mut(&mut s.moduli);
    moduli.lambda = retain(&moduli.lambda, &keep);
    moduli.mu = retain(&moduli.mu, &keep);
    for r in arrived.chunks_exact(record_len(D)) {
        let r = ParticleRecord::<D>::read(r);
        s.x.push(r.x);
        s.v.push(r.v);
        s.sigma.push(r.sigma);
        s.f.push(r.f);
        s.density.push(r.density);
        moduli.lambda.push(r.lame.0);
        moduli.mu.push(r.lame.1);
        carried.mass.push(r.mass);
        carried.volume0.push(r.volume0);
        carried.domain.push(r.domain);
        carried.material.push(r.material);
        carried.id.push(r.id);
    }
    s.carried = Rc::new(carried);
    Ok(())
}

fn record_of<const D: usize>(s: &StateNd<D>, p: usize) -> ParticleRecord<D> {
    let c = &s.carried;
    ParticleRecord {
        x: s.x[p],
        v: s.v[p],
        sigma: s.sigma[p],
        f: s.f[p],
        density: s.density[p],
        lame: (s.moduli.lambda[p], s.moduli.mu[p]),
        mass: c.mass[p],
        volume0: c.volume0[p],
        domain: c.domain[p],
        material: c.material[p],
        id: c.id[p],
    }
}

fn retain<T: Copy>(v: &[T], keep: &[bool]) -> Vec<T> {
    v.iter()
        .zip(keep)
        .filter(|(_, &k)| k)
        .map(|(x, _)| *x)
        .collect()
}

/// Numbers in one migrating particle's record.
pub const fn record_len(d: usize) -> usize {
    3 * d + 2 * d * d + 9
}

/// One particle's fields as they travel between processes.
#[derive(Clone, Copy, Debug)]
pub struct ParticleRecord<const D: usize> {
    pub x: Vector<D>,
    pub v: Vector<D>,
    pub sigma: Tensor<D>,
    pub f: Tensor<D>,
    pub density: f64,
    pub lame: (f64, f64),
    pub mass: f64,
    pub volume0: f64,
    pub domain: Vector<D>,
    pub material: MaterialNd,
    pub id: u64,
}

impl<const D: usize> ParticleRecord<D> {
    /// Appends the record to `out` ([`record_len`] numbers).
    pub fn write(&self, out: &mut Vec<f64>) {
        out.extend(self.x.iter());
        out.extend(self.v.iter());
        out.extend(self.sigma.iter());
        out.extend(self.f.iter());
        out.extend([
            self.density,
            self.lame.0,
            self.lame.1,
            self.mass,
            self.volume0,
        ]);
        out.extend(self.domain.iter());
        let (kind, e, nu) = match self.material {
            MaterialNd::LinearElastic {
                youngs_modulus,
                poisson_ratio,
            } => (0.0, youngs_modulus, poisson_ratio),
            MaterialNd::NeoHookean {
                youngs_modulus,
                poisson_ratio,
            } => (1.0, youngs_modulus, poisson_ratio),
        };
        out.extend([kind, e, nu, self.id as f64]);
    }

    /// Reads a record written by [`Self::write`].
    pub fn read(r: &[f64]) -> Self {
        let mut k = 0;
        let mut take = |n: usize| {
            let s = &r[k..k + n];
            k += n;
            s
        };
        let x = Vector::<D>::from_column_slice(take(D));
        let v = Vector::<D>::from_column_slice(take(D));
        let sigma = Tensor::<D>::from_column_slice(take(D * D));
        let f = Tensor::<D>::from_column_slice(take(D * D));
        let s = take(5);
        let (density, lame, mass, volume0) = (s[0], (s[1], s[2]), s[3], s[4]);
        let domain = Vector::<D>::from_column_slice(take(D));
        let m = take(4);
        let (youngs_modulus, poisson_ratio) = (m[1], m[2]);
        let material = if m[0] == 0.0 {
            MaterialNd::LinearElastic {
                youngs_modulus,
                poisson_ratio,
            }
        } else {
            MaterialNd::NeoHookean {
                youngs_modulus,
                poisson_ratio,
            }
        };
        Self {
            x,
            v,
            sigma,
            f,
            density,
            lame,
            mass,
            volume0,
            domain,
            material,
            id: m[3] as u64,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_travels_unchanged() {
        let r = ParticleRecord::<3> {
            x: Vector::<3>::new(0.1, 0.2, 0.3),
            v: Vector::<3>::new(-1.0, 2.0, 1e-300),
            sigma: Tensor::<3>::from_fn(|i, j| (i * 3 + j) as f64 + 0.5),
            f: Tensor::<3>::from_fn(|i, j| (i + 2 * j) as f64 - 0.25),
            density: 1000.0,
            lame: (1.5, 2.5),
            mass: 3.0e-4,
            volume0: 2.0e-7,
            domain: Vector::<3>::new(0.01, 0.02, 0.03),
            material: MaterialNd::NeoHookean {
                youngs_modulus: 1e6,
                poisson_ratio: 0.3,
            },
            id: (1 << 40) + 7,
        };
        let mut buf = Vec::new();
        r.write(&mut buf);
        assert_eq!(buf.len(), record_len(3));
        let back = ParticleRecord::<3>::read(&buf);
        let mut again = Vec::new();
        back.write(&mut again);
        assert_eq!(
            buf.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            again.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(back.id, r.id);
        assert_eq!(back.material, r.material);
    }
}
