//! One bare step (`try_step` + `accept`) of the d-dimensional reference solver: periodic
//! box, 2 particles per cell per axis, GIMP and quadratic B-splines, 10⁴ … 10⁶ particles in
//! 2D and 3D, on the calling thread (`Gimp/…`) and on 1 and 2 threads of the solver's
//! pool (`Gimp-1t/…`, `Gimp-2t/…`, `SolverNd::set_threads`). Throughput is in particles:
//! criterion reports particle-steps per second.

use common::{solver, MATERIAL};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mpm_dt::nd::ShapeNd;
use mpm_dt::{Dim, Dimension, Stepper, ViewNd};
use std::hint::black_box;

mod common;

fn bench<const D: usize>(c: &mut Criterion, cells: &[usize])
where
    Dim<D>: for<'a> Dimension<View<'a> = ViewNd<'a, D>>,
{
    let mut group = c.benchmark_group(format!("step_{D}d"));
    group.sample_size(10);
    let modes: [(Option<usize>, &str); 3] = [(None, ""), (Some(1), "-1t"), (Some(2), "-2t")];
    for shape in [ShapeNd::Gimp, ShapeNd::BSpline2] {
        for &n in cells {
            for (threads, suffix) in modes {
                let mut s = solver::<D>(n, shape);
                if let Err(e) = s.set_threads(threads) {
                    panic!("{e}");
                }
                let particles = s.n_particles();
                // Half the sound-speed step h/c_p: stable for both shapes.
                let dt = 0.5 * s.grid().h_min() / MATERIAL.p_modulus().sqrt();
                group.throughput(Throughput::Elements(particles as u64));
                group.bench_with_input(
                    BenchmarkId::new(format!("{shape:?}{suffix}"), particles),
                    &dt,
                    |b, &dt| {
                        b.iter(|| {
                            if let Err(e) = s.try_step(black_box(dt)) {
                                panic!("step failed: {e}");
                            }
                            let _ = s.accept();
                        })
                    },
                );
            }
        }
    }
    group.finish();
}

fn bench_steps(c: &mut Criterion) {
    // 2D: 50², 158², 500² cells × 4 ≈ 10⁴, 10⁵, 10⁶ particles.
    bench::<2>(c, &[50, 158, 500]);
    // 3D: 11³, 23³, 50³ cells × 8 ≈ 10⁴, 10⁵, 10⁶ particles.
    bench::<3>(c, &[11, 23, 50]);
}

criterion_group!(benches, bench_steps);
criterion_main!(benches);
