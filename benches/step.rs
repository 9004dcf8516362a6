//! One pseudo-time step of Algorithm 1 (assembly + preconditioner or
//! numeric factorisation + solve) on the quarter disk (2D) and the quarter
//! ball (3D) at growing sizes, for each solver. The symbolic analysis is
//! done once per mesh and the multigrid hierarchy is built by a first
//! step, outside the timed loop, as in a real run. `deformesh bench`
//! prints the same measurement as a table with iterations and memory.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use deformesh::app::bench::{ball_deformation, demo_deformation};
use deformesh::deform::{Deformation, Q1Mesh, SolverChoice};

fn time<M: Q1Mesh<D, N>, const D: usize, const N: usize>(c: &mut Criterion, group: &str, name: String, mut d: Deformation<M, D, N>) {
    let mut group = c.benchmark_group(group);
    group.sample_size(10);
    group.throughput(criterion::Throughput::Elements(d.num_unknowns() as u64));
    d.step(0.01).expect("first step");
    group.bench_function(BenchmarkId::from_parameter(name), |b| {
        // each iteration starts again from t = 0, warm-started CG
        b.iter(|| {
            d.reset();
            d.step(0.01).expect("step");
        });
    });
    group.finish();
}

fn one_step(c: &mut Criterion) {
    for solver in [SolverChoice::Cholesky, SolverChoice::Cg, SolverChoice::Amg] {
        for n in [100, 200, 400] {
            time(c, "step2d", format!("{solver:?}/{n}x{n}"), demo_deformation(n, solver).expect("demo case"));
        }
        for n in [16, 32] {
            time(c, "step3d", format!("{solver:?}/{n}^3"), ball_deformation(n, solver).expect("quarter ball"));
        }
    }
}

criterion_group!(benches, one_step);
criterion_main!(benches);
