use mpm_dt::{Boundary, Grid, Shape, Weights};
#[test]
fn partition_and_linear() {
    for shape in [Shape::Gimp, Shape::Linear] {
        for b in [Boundary::Periodic, Boundary::Fixed] {
            let g = Grid::new(b, 10, 1.0);
            let xs: Vec<f64> = (0..97).map(|k| 0.003 + k as f64 * 0.0102).collect();
            let w = Weights::compute(&g, shape, &xs, &vec![0.05; xs.len()]);
            for p in 0..xs.len() {
                let s: f64 = w.s_of(p).iter().sum();
                let d: f64 = w.d_of(p).iter().sum();
                let sx: f64 = w.row(p).map(|(i, s, _)| s * g.offset(i, xs[p])).sum();
                let dx: f64 = w.row(p).map(|(i, _, d)| d * g.offset(i, xs[p])).sum();
                assert!(
                    (s - 1.0).abs() < 1e-12
                        && d.abs() < 1e-9
                        && sx.abs() < 1e-12
                        && (dx - 1.0).abs() < 1e-12,
                    "{shape:?} {b:?} p={p} {s} {d} {sx} {dx}"
                );
            }
        }
    }
}
