//! The tangent pairs of `mpm_dt::tangent` per particle, as a solver forms them in every
//! step: 8 192 deformation gradients near the rest state (mpm88's jelly at impact reaches
//! singular values of about 0.8–1.2). Throughput is in particles.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use mpm_dt::nd::Tensor;
use mpm_dt::tangent;
use std::hint::black_box;

/// `n` deformation gradients with entries `δ_ij + 0.2·u`, `u` from a fixed sequence in
/// `[−0.5, 0.5)` (deterministic, no random-number crate needed).
fn gradients<const D: usize>(n: usize) -> Vec<Tensor<D>> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    (0..n)
        .map(|_| Tensor::<D>::identity() + Tensor::<D>::from_fn(|_, _| 0.2 * next()))
        .collect()
}

fn bench_tangent(c: &mut Criterion) {
    let mut group = c.benchmark_group("tangent");
    let n = 8192;
    group.throughput(Throughput::Elements(n as u64));
    let f2 = gradients::<2>(n);
    let f3 = gradients::<3>(n);
    let (mut l, mut m) = (vec![0.0; n], vec![0.0; n]);
    group.bench_function("fixed_corotated/2d", |b| {
        b.iter(|| {
            for (p, f) in f2.iter().enumerate() {
                (l[p], m[p]) = tangent::fixed_corotated(400.0, 200.0, f);
            }
            black_box((&l, &m));
        })
    });
    group.bench_function("fixed_corotated_many/2d", |b| {
        b.iter(|| {
            tangent::fixed_corotated_many(400.0, 200.0, &f2, &mut l, &mut m);
            black_box((&l, &m));
        })
    });
    group.bench_function("fixed_corotated/3d", |b| {
        b.iter(|| {
            for (p, f) in f3.iter().enumerate() {
                (l[p], m[p]) = tangent::fixed_corotated(400.0, 200.0, f);
            }
            black_box((&l, &m));
        })
    });
    group.bench_function("neo_hookean/2d", |b| {
        b.iter(|| {
            for (p, f) in f2.iter().enumerate() {
                (l[p], m[p]) = tangent::neo_hookean(400.0, 200.0, f);
            }
            black_box((&l, &m));
        })
    });
    group.finish();
}

criterion_group!(benches, bench_tangent);
criterion_main!(benches);
