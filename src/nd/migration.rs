//! Particles moving between the slabs of a grid-decomposed run ([`super::SolverNd::new_slab`]):
//! after the grid → particle pass of a trial, the particles that left this process's slab
//! are sent to the neighbour that owns them with every field that describes them, and the
//! ones that arrive are appended — first those from below, then those from above, each in
//! the order their sender held them. The committed state is untouched (a rejected trial
//! leaves every process with its own particles, bit for bit).

use super::slab::{record_len, ParticleRecord, SlabNd};
use super::solver::{CarriedNd, StateNd};
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
    let n = s.x.len();
    let mut up = Vec::new();
    let mut down = Vec::new();
    let mut keep = vec![true; n];
    let mut stray = None;
    if !failed {
        for (p, kept) in keep.iter_mut().enumerate() {
            let y = s.x[p][D - 1];
            if slab.owns(y) {
                continue;
            }
            *kept = false;
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
    if failed || (up.is_empty() && down.is_empty() && arrived.is_empty()) {
        return Ok(());
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
    s.lame_lambda = retain(&s.lame_lambda, &keep);
    s.lame_mu = retain(&s.lame_mu, &keep);
    for r in arrived.chunks_exact(record_len(D)) {
        let r = ParticleRecord::<D>::read(r);
        s.x.push(r.x);
        s.v.push(r.v);
        s.sigma.push(r.sigma);
        s.f.push(r.f);
        s.density.push(r.density);
        s.lame_lambda.push(r.lame.0);
        s.lame_mu.push(r.lame.1);
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
        lame: (s.lame_lambda[p], s.lame_mu[p]),
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
