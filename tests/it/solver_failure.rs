//! A linear solve that does not converge is retried by what is likely to
//! work (a rebuilt preconditioner, a Cholesky factor, a smaller step);
//! only when every way fails does `curve` end with the solver's error
//! (exit code 3), writing nothing. The iteration cap
//! (`DeformOptions::max_iterations`) and the factor limit
//! (`DeformOptions::factor_limit`) make the failure happen on a small
//! mesh, deterministically.

use deformesh::app::driver::{curve_file, CurveJob, CurveReport, OutputFormat};
use deformesh::deform::{DeformOptions, SolverChoice};
use deformesh::highorder::curve::CurveOptions;
use std::path::{Path, PathBuf};

use crate::common::WALL_CIRCLE as CYLINDER;

/// The cylinder's boundary layer curved at p = 2 in 4 steps, the geometry
/// in `dir`, the outputs in `dir/out` (created empty).
fn job(dir: &Path, flow: DeformOptions) -> CurveJob {
    let g = dir.join("geometry.toml");
    std::fs::write(&g, CYLINDER).unwrap();
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    CurveJob {
        input: Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cylinder_bl_coarse.msh"),
        geometry: Some(g), cad: None,
        output: out.join("curved.msh"),
        format: OutputFormat::Msh41,
        options: CurveOptions { order: 2, steps: Some(4), flow, ..Default::default() },
        width: 200,
        force: false,
    }
}

fn files(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * a.abs().max(b.abs())
}

#[test]
fn a_solver_that_fails_every_way_ends_the_run_with_exit_code_3_and_no_files() {
    let dir = tempfile::tempdir().unwrap();
    // one CG iteration a solve and no factor: the multigrid (what `auto`
    // takes when no factor is allowed) cannot solve, rebuilt or not, and
    // the first solve at t = 0 has no smaller step
    let flow = DeformOptions { max_iterations: Some(1), factor_limit: 0, ..Default::default() };
    let j = job(dir.path(), flow);
    let e = curve_file(&j, |_| {}).expect_err("one iteration and no factor cannot solve");
    assert_eq!(e.exit_code(), 3, "{e}");
    let text = format!("{:#}", anyhow::Error::from(e));
    for part in [
        "the linear solver failed (the solver, not the input)",
        "conjugate gradients did not converge in 1 iteration (relative residual",
        "smoothed-aggregation AMG",
        "then again on a rebuilt preconditioner",
        "a Cholesky factor: not allowed (factor limit 0 unknowns)",
        "a smaller step: none to take, as the failing solve is the run's first, at t = 0",
    ] {
        assert!(text.contains(part), "`{part}` not in: {text}");
    }
    assert!(files(j.output.parent().unwrap()).is_empty(), "written: {:?}", files(j.output.parent().unwrap()));
}

#[test]
fn a_capped_multigrid_turns_to_the_factor_and_gives_the_uncapped_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let free = curve_file(&job(dir.path(), DeformOptions::default()), |_| {}).unwrap_or_else(|e| panic!("{e}"));
    let dir = tempfile::tempdir().unwrap();
    // the multigrid needs more than 3 iterations on this layer
    let flow = DeformOptions { solver: SolverChoice::Amg, max_iterations: Some(3), ..Default::default() };
    let capped: CurveReport = curve_file(&job(dir.path(), flow), |_| {}).unwrap_or_else(|e| panic!("{e}"));
    let f = &capped.solver.fallbacks;
    assert!(f.factor >= 1, "{f:?}");
    assert!(f.rebuilt >= 1, "the fresh hierarchy is rebuilt with safe bounds first: {f:?}");
    assert!(f.solved_by.is_some(), "{f:?}");
    assert!(capped.solver.solver.contains("multigrid, then the Cholesky factor"), "{}", capped.solver.solver);
    let serialised = serde_json::to_value(&capped.solver).unwrap();
    assert!(serialised["fallbacks"]["factor"].as_u64().unwrap() >= 1, "{serialised}");
    // a default run needs none
    assert_eq!(free.solver.fallbacks, Default::default());
    // the same mesh
    assert!(capped.quality.invalid_elements.is_empty() && free.quality.invalid_elements.is_empty());
    assert!(close(capped.quality.min_det_j, free.quality.min_det_j), "min det J {} against {}", capped.quality.min_det_j, free.quality.min_det_j);
    assert!(close(capped.quality.max_det_j, free.quality.max_det_j), "max det J {} against {}", capped.quality.max_det_j, free.quality.max_det_j);
    assert!(!files(&dir.path().join("out")).is_empty());
}

/// Exact Cholesky, except that the solves numbered in `fail` (from 1)
/// report no convergence: a solver that fails at a chosen state.
struct Flaky {
    exact: deformesh::solve::CholeskySolver,
    solves: usize,
    fail: fn(usize) -> bool,
}

impl deformesh::solve::SpdSolver for Flaky {
    fn analyze(&mut self, a: &deformesh::solve::Csr) -> Result<(), deformesh::solve::SolveError> {
        self.exact.analyze(a)
    }
    fn factor(&mut self, a: &deformesh::solve::Csr, s: deformesh::solve::Structure<'_>) -> Result<(), deformesh::solve::SolveError> {
        self.exact.factor(a, s)
    }
    fn solve_in_place(&mut self, a: &deformesh::solve::Csr, rhs: &mut [f64]) -> Result<(), deformesh::solve::SolveError> {
        self.solves += 1;
        if (self.fail)(self.solves) {
            return Err(deformesh::solve::SolveError::NoConvergence { iterations: 7, residual: 0.5, tolerance: 1e-7 });
        }
        self.exact.solve_in_place(a, rhs)
    }
    fn name(&self) -> &'static str {
        "flaky"
    }
}

fn quarter_disk(fail: fn(usize) -> bool) -> deformesh::deform::Deformation {
    let case = deformesh::app::case::Case::parse(deformesh::app::case::DEMO_CASE, "quarter_disk").unwrap();
    let mut s = case.setup("quarter_disk", Path::new(".")).unwrap();
    s.options.steps = 10;
    let solver = Box::new(Flaky { exact: deformesh::solve::CholeskySolver::new(), solves: 0, fail });
    deformesh::deform::Deformation::with_solver(s.mesh, s.parts, s.field, s.options, solver).unwrap()
}

#[test]
fn a_solve_that_fails_at_a_step_s_start_retakes_the_step_before_smaller() {
    // the third solve (at t = 0.2) fails once: the step from t = 0.1 is
    // retaken with 0.05, and the run goes on
    let mut d = quarter_disk(|k| k == 3);
    d.run(&[], |_| {}, |_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.t, 1.0);
    assert_eq!((d.stats.solver_retakes, d.stats.halved), (1, 1));
    assert!(d.stats.steps > 10, "{} steps", d.stats.steps);
    let r = d.solver_report();
    assert_eq!((r.fallbacks.smaller_steps, r.fallbacks.solved_by.as_deref()), (1, Some("a smaller step")));
    assert!(deformesh::quality::mesh_quality(&d.mesh).invalid_cells.is_empty());
}

#[test]
fn a_solve_that_keeps_failing_ends_the_run_saying_what_was_tried() {
    // every solve from the third on fails: the step before is retaken
    // smaller, max_halvings (12) times, then the run ends
    let mut d = quarter_disk(|k| k >= 3);
    let e = d.run(&[], |_| {}, |_| {}).expect_err("no solve after the second succeeds");
    let text = e.to_string();
    assert!(matches!(e, deformesh::deform::DeformError::Solve(_)), "{e:?}");
    assert!(text.starts_with("the linear solver failed (the solver, not the input): conjugate gradients did not converge in 7 iterations (relative residual 5.00e-1"), "{text}");
    assert!(text.contains("a smaller step: the steps before t = 0.2000 retaken 12 times with half the step"), "{text}");
    assert_eq!(d.stats.solver_retakes, 12);
    assert!(d.t > 0.1 && d.t < 0.2, "the run stopped at t = {}", d.t);
}
