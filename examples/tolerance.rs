//! How far the CG tolerance moves the final mesh: runs a case with the
//! multigrid-preconditioned CG at several relative tolerances and prints,
//! for each, the largest node distance to a reference run at 1e-12, with
//! the mean iterations per solve. The measurement behind
//! `solve::DEFAULT_TOLERANCE`.
//!
//!     cargo run --release --example tolerance -- [2|3] [cells per side]

use deformesh::app::case::{AnySetup, Case, DEMO_CASE};
use deformesh::app::bench::QUARTER_BALL;
use deformesh::deform::{Deformation, Deformation3, SolverChoice};
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let dim: usize = args.get(1).map_or(Ok(3), |s| s.parse())?;
    let n: usize = args.get(2).map_or(Ok(24), |s| s.parse())?;
    let run = |tol: f64| -> Result<(Vec<f64>, f64, f64), Box<dyn std::error::Error>> {
        let mut case = Case::parse(if dim == 2 { DEMO_CASE } else { QUARTER_BALL }, "case")?;
        case.mesh.cells = vec![n; dim];
        case.time.solver = SolverChoice::Amg;
        case.time.tolerance = tol;
        let clock = std::time::Instant::now();
        let (nodes, r) = match case.setup_any("case", Path::new("."))? {
            AnySetup::Quad(s) => {
                let mut d = Deformation::new(s.mesh, s.parts, s.field, s.options)?;
                d.run(&[], |_| {}, |_| {})?;
                (d.mesh.nodes.iter().flatten().copied().collect(), d.solver_report())
            }
            AnySetup::Hex(s) => {
                let mut d = Deformation3::new(s.mesh, s.parts, s.field, s.options)?;
                d.run(&[], |_| {}, |_| {})?;
                (d.mesh.nodes.iter().flatten().copied().collect(), d.solver_report())
            }
        };
        Ok((nodes, r.iterations_mean, clock.elapsed().as_secs_f64()))
    };
    let (reference, _, _) = run(1e-12)?;
    println!("{:>9} {:>12} {:>10} {:>8}", "tolerance", "max |Δx|", "iters", "run_s");
    for tol in [1e-10, 1e-8, 1e-6, 1e-5, 1e-4] {
        let (nodes, iters, secs) = run(tol)?;
        let diff = nodes.iter().zip(&reference).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        println!("{tol:>9.0e} {diff:>12.2e} {iters:>10.1} {secs:>8.2}");
    }
    Ok(())
}
