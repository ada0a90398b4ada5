//! The two particle passes of [`super::TemporalError`]'s estimate (eqs 20–30), written so
//! that the compiler vectorises them.
//!
//! **Pass 1** ([`rates_and_scales`]) forms the rates of the trial,
//! `r_p = (u_p^{n+1} − u_p^n)/dt` for `u = v` (eq 22) and `u = σ` (eq 27), and the field
//! scales of the weights: `max_p max(|u_p^n|, |u_p^{n+1}|)` and the energy-equivalent
//! `max_p σ̂_p²/z_p²`, `max_p v̂_p² z_p²` (`v̂_p = max(|v_p^n|, |v_p^{n+1}|)`,
//! `σ̂_p` likewise, `z_p² = E_t,p ρ_p` the squared acoustic impedance, over the particles
//! where `0 < z_p² < ∞`). The maxima are kept in [`LANES`] independent lanes and combined
//! at the end: `f64::max` is commutative and associative on these values (all `≥ +0`, NaN
//! ignored in any order), so the result is bit for bit that of one sequential loop.
//!
//! **Pass 2** ([`sums`]) forms, per particle, the weights
//! `w_u,p = atol_u + s_u,p + atol_rel ‖u‖_∞ + rtol · û_p` (`s_u,p` the balancing spatial
//! error, `0` without balancing) and the squared scaled errors `(le_u,p / w_u,p)²` with
//! `le_u,p = dt²/2 · (x_p − y_p)/span`, in blocks of [`BLOCK`] particles into a stack
//! buffer (independent divisions: vectorised), then adds them to the two sums **strictly
//! in particle order**, so the sums — and `dsm` — are those of the plain loop.
//!
//! Both passes are compiled twice, for the baseline target and with AVX2 (4-wide vectors;
//! never FMA, so every operation rounds as the scalar one), the build chosen at run time as
//! for the particle pass of the reference solver ([`crate::mpm`]).

/// Independent accumulator lanes of the maxima of pass 1.
const LANES: usize = 8;

/// Particles per block of pass 2.
const BLOCK: usize = 256;

/// The particle fields pass 1 reads. `v0, v1, s0, s1` have the particle count `n`;
/// `et` and `rho` (tangent modulus and density of the committed state) have the same
/// length `nz ≤ n`, the particles that enter the energy-equivalent scales.
pub(super) struct Fields<'a> {
    /// Committed velocities `v^n`.
    pub v0: &'a [f64],
    /// Trial velocities `v^{n+1}`.
    pub v1: &'a [f64],
    /// Committed stresses `σ^n`.
    pub s0: &'a [f64],
    /// Trial stresses `σ^{n+1}`.
    pub s1: &'a [f64],
    /// Tangent moduli `E_t,p` (first `nz` particles).
    pub et: &'a [f64],
    /// Densities `ρ_p` (first `nz` particles).
    pub rho: &'a [f64],
}

/// The maxima of pass 1.
#[derive(Clone, Copy, Debug)]
pub(super) struct Scales {
    /// `max_p v̂_p`.
    pub v: f64,
    /// `max_p σ̂_p`.
    pub sigma: f64,
    /// `max_p σ̂_p² / z_p²`.
    pub v_from_s2: f64,
    /// `max_p v̂_p² z_p²`.
    pub s_from_v2: f64,
}

/// What pass 2 reads: the rates `x` (trial) and `y` (previous), the fields for the
/// relative part of the weights, the optional balancing errors and the constants.
pub(super) struct Terms<'a> {
    /// Velocity rates whose difference is the second derivative's numerator (`x`).
    pub xv: &'a [f64],
    /// The rates subtracted (`y`).
    pub yv: &'a [f64],
    /// Stress rates `x`.
    pub xs: &'a [f64],
    /// Stress rates `y`.
    pub ys: &'a [f64],
    /// Committed velocities.
    pub v0: &'a [f64],
    /// Trial velocities.
    pub v1: &'a [f64],
    /// Committed stresses.
    pub s0: &'a [f64],
    /// Trial stresses.
    pub s1: &'a [f64],
    /// κ-scaled spatial errors `(s_v,p, s_σ,p)` when balancing.
    pub spatial: Option<(&'a [f64], &'a [f64])>,
    /// `dt²/(2 span)`: the local error is `c_span (x_p − y_p)`.
    pub c_span: f64,
    /// `atol_v`.
    pub atol_v: f64,
    /// `atol_σ`.
    pub atol_sigma: f64,
    /// `atol_rel ‖v‖_∞`.
    pub abs_v: f64,
    /// `atol_rel ‖σ‖_∞`.
    pub abs_s: f64,
    /// `rtol`.
    pub rtol: f64,
}

/// Pass 1 in the best build the CPU supports. `accel` and `stress_rate` (length `n`)
/// receive the rates.
pub(super) fn dispatch_rates(
    f: Fields<'_>,
    inv_dt: f64,
    accel: &mut [f64],
    stress_rate: &mut [f64],
) -> Scales {
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::has_avx2() {
        // SAFETY: `rates_avx2` only requires AVX2, which `has_avx2` detected on this CPU.
        return unsafe { rates_avx2(&f, inv_dt, accel, stress_rate) };
    }
    rates_and_scales(&f, inv_dt, accel, stress_rate)
}

/// Pass 2 in the best build the CPU supports: `(Σ_p (le_v,p/w_v,p)², Σ_p (le_σ,p/w_σ,p)²)`
/// over the first `n` particles.
pub(super) fn dispatch_sums(t: &Terms<'_>, n: usize) -> (f64, f64) {
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::has_avx2() {
        // SAFETY: `sums_avx2` only requires AVX2, which `has_avx2` detected on this CPU.
        return unsafe { sums_avx2(t, n) };
    }
    sums(t, n)
}

/// [`rates_and_scales`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn rates_avx2(f: &Fields<'_>, inv_dt: f64, accel: &mut [f64], stress_rate: &mut [f64]) -> Scales {
    rates_and_scales(f, inv_dt, accel, stress_rate)
}

/// [`sums`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn sums_avx2(t: &Terms<'_>, n: usize) -> (f64, f64) {
    sums(t, n)
}

/// `&s[start..start + L]` as an array (one bounds check per chunk, none per element).
#[inline(always)]
fn chunk<const L: usize>(s: &[f64], start: usize) -> &[f64; L] {
    match s[start..start + L].try_into() {
        Ok(a) => a,
        Err(_) => unreachable!("a slice of length L"),
    }
}

/// The mutable form of [`chunk`].
#[inline(always)]
fn chunk_mut<const L: usize>(s: &mut [f64], start: usize) -> &mut [f64; L] {
    match (&mut s[start..start + L]).try_into() {
        Ok(a) => a,
        Err(_) => unreachable!("a slice of length L"),
    }
}

/// Pass 1 (see the module docs).
#[inline(always)]
fn rates_and_scales(
    f: &Fields<'_>,
    inv_dt: f64,
    accel: &mut [f64],
    stress_rate: &mut [f64],
) -> Scales {
    let n = accel.len();
    let nz = f.et.len().min(f.rho.len()).min(n);
    let (v0, v1, s0, s1) = (&f.v0[..n], &f.v1[..n], &f.s0[..n], &f.s1[..n]);
    let stress_rate = &mut stress_rate[..n];
    let (mut vm, mut sm) = ([0.0_f64; LANES], [0.0_f64; LANES]);
    let (mut vs2, mut sv2) = ([0.0_f64; LANES], [0.0_f64; LANES]);
    // The particles with a modulus and a density, in whole chunks of LANES.
    let full = nz / LANES * LANES;
    let mut start = 0;
    while start < full {
        let (a, r) = (
            chunk_mut::<LANES>(accel, start),
            chunk_mut::<LANES>(stress_rate, start),
        );
        let (v0, v1, s0, s1) = (
            chunk::<LANES>(v0, start),
            chunk::<LANES>(v1, start),
            chunk::<LANES>(s0, start),
            chunk::<LANES>(s1, start),
        );
        let (et, rho) = (chunk::<LANES>(f.et, start), chunk::<LANES>(f.rho, start));
        for k in 0..LANES {
            a[k] = (v1[k] - v0[k]) * inv_dt;
            r[k] = (s1[k] - s0[k]) * inv_dt;
            let v = v0[k].abs().max(v1[k].abs());
            let sg = s0[k].abs().max(s1[k].abs());
            vm[k] = vm[k].max(v);
            sm[k] = sm[k].max(sg);
            let z2 = et[k] * rho[k];
            // `0 < z² < ∞` is `z².is_finite() && z² > 0` (NaN fails both); a particle
            // outside contributes 0, which leaves a maximum of values `≥ +0` unchanged.
            let ok = z2 > 0.0 && z2 < f64::INFINITY;
            let from_s = sg * sg / z2;
            let from_v = v * v * z2;
            vs2[k] = vs2[k].max(if ok { from_s } else { 0.0 });
            sv2[k] = sv2[k].max(if ok { from_v } else { 0.0 });
        }
        start += LANES;
    }
    // The rest, one particle at a time (lane 0).
    for p in full..n {
        accel[p] = (v1[p] - v0[p]) * inv_dt;
        stress_rate[p] = (s1[p] - s0[p]) * inv_dt;
        let v = v0[p].abs().max(v1[p].abs());
        let sg = s0[p].abs().max(s1[p].abs());
        vm[0] = vm[0].max(v);
        sm[0] = sm[0].max(sg);
        if p < nz {
            let z2 = f.et[p] * f.rho[p];
            if z2.is_finite() && z2 > 0.0 {
                vs2[0] = vs2[0].max(sg * sg / z2);
                sv2[0] = sv2[0].max(v * v * z2);
            }
        }
    }
    let fold = |l: [f64; LANES]| l.into_iter().fold(0.0_f64, f64::max);
    Scales {
        v: fold(vm),
        sigma: fold(sm),
        v_from_s2: fold(vs2),
        s_from_v2: fold(sv2),
    }
}

/// One particle's squared scaled error `(le/w)²` (0 when `le = 0`, whatever `w`). The
/// quotient is formed unconditionally and discarded when `le = 0`, so the loops calling
/// this have no branch.
#[inline(always)]
fn term(le: f64, w: f64) -> f64 {
    let r = le / w.max(f64::MIN_POSITIVE);
    let t = r * r;
    if le == 0.0 {
        0.0
    } else {
        t
    }
}

/// Pass 2 (see the module docs).
#[inline(always)]
fn sums(t: &Terms<'_>, n: usize) -> (f64, f64) {
    let (xv, yv, xs, ys) = (&t.xv[..n], &t.yv[..n], &t.xs[..n], &t.ys[..n]);
    let (v0, v1, s0, s1) = (&t.v0[..n], &t.v1[..n], &t.s0[..n], &t.s1[..n]);
    let (mut sum_v, mut sum_s) = (0.0, 0.0);
    let (mut tv, mut ts) = ([0.0_f64; BLOCK], [0.0_f64; BLOCK]);
    let mut start = 0;
    while start < n {
        let len = BLOCK.min(n - start);
        let r = start..start + len;
        let (xv, yv, xs, ys) = (
            &xv[r.clone()],
            &yv[r.clone()],
            &xs[r.clone()],
            &ys[r.clone()],
        );
        let (v0, v1, s0, s1) = (
            &v0[r.clone()],
            &v1[r.clone()],
            &s0[r.clone()],
            &s1[r.clone()],
        );
        let (tv, ts) = (&mut tv[..len], &mut ts[..len]);
        match t.spatial {
            // The explicit `+ 0.0` keeps the weights' arithmetic identical to the balanced
            // form with a zero spatial error.
            None => {
                for k in 0..len {
                    let wv = t.atol_v + 0.0 + t.abs_v + t.rtol * v0[k].abs().max(v1[k].abs());
                    let ws = t.atol_sigma + 0.0 + t.abs_s + t.rtol * s0[k].abs().max(s1[k].abs());
                    tv[k] = term(t.c_span * (xv[k] - yv[k]), wv);
                    ts[k] = term(t.c_span * (xs[k] - ys[k]), ws);
                }
            }
            Some((sv, ss)) => {
                let (sv, ss) = (&sv[r.clone()], &ss[r]);
                for k in 0..len {
                    let wv = t.atol_v + sv[k] + t.abs_v + t.rtol * v0[k].abs().max(v1[k].abs());
                    let ws = t.atol_sigma + ss[k] + t.abs_s + t.rtol * s0[k].abs().max(s1[k].abs());
                    tv[k] = term(t.c_span * (xv[k] - yv[k]), wv);
                    ts[k] = term(t.c_span * (xs[k] - ys[k]), ws);
                }
            }
        }
        // In particle order, as the plain loop adds them.
        for k in 0..len {
            sum_v += tv[k];
            sum_s += ts[k];
        }
        start += len;
    }
    (sum_v, sum_s)
}

/// `Σ_p (c_lag |a_p| / w_v,p)²` over the first `n` particles, in particle order: the
/// velocity lag `κ_lag dt/2 |a_p|` of [`crate::temporal::TemporalErrorConfig::lag`]
/// (`c_lag = κ_lag dt/2`, `a` the trial state's `Σ_i S_ip a_i`), weighed as pass 2 weighs
/// the velocity (the same `w_v,p`, bit for bit). A plain loop: it runs only when the lag is on.
pub(super) fn lag_sum(t: &Terms<'_>, a: &[f64], c_lag: f64, n: usize) -> f64 {
    let (xv, v0, v1) = (&a[..n], &t.v0[..n], &t.v1[..n]);
    let mut sum = 0.0;
    for p in 0..n {
        let sv = t.spatial.map_or(0.0, |(sv, _)| sv[p]);
        let wv = t.atol_v + sv + t.abs_v + t.rtol * v0[p].abs().max(v1[p].abs());
        sum += term(c_lag * xv[p].abs(), wv);
    }
    sum
}
