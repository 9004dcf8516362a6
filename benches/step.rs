//! One pseudo-time step of Algorithm 1 (assembly + numeric factorisation +
//! solve) on the quarter-disk case at growing sizes. The symbolic analysis
//! is done once per mesh, outside the timed loop, as in a real run.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use deformesh::bench::demo_deformation;

fn one_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    group.sample_size(10);
    for n in [100, 200, 400] {
        let mut d = demo_deformation(n, deformesh::deform::SolverChoice::Cholesky).expect("demo case");
        group.throughput(criterion::Throughput::Elements(d.num_unknowns() as u64));
        group.bench_function(BenchmarkId::from_parameter(format!("{n}x{n}")), |b| {
            // each iteration starts again from t = 0
            b.iter(|| {
                d.reset();
                d.step(0.01).expect("step");
            });
        });
    }
    group.finish();
}

criterion_group!(benches, one_step);
criterion_main!(benches);
