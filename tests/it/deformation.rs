//! Integration tests of Algorithm 1 on the seed's 2D cases, with the
//! figures the issue asks for: validity, J/f bounds, boundary accuracy,
//! and convergence of J/f under refinement.

use crate::common;
use common::GAUSS5;
use deformesh::app::case::{Case, DEMO_CASE};
use deformesh::deform::{Deformation, Integrator};
use deformesh::expr::Expr;
use deformesh::jacobian::JacobianField;
use deformesh::quality::{jf_stats, mesh_quality};
use std::path::Path;

fn quarter_disk(mode: &str) -> Deformation {
    let text = DEMO_CASE.replace("mode = \"sliding\"", &format!("mode = \"{mode}\""));
    let case = Case::parse(&text, "quarter_disk").unwrap();
    assert_eq!(case.mesh.cells, [20, 20]);
    assert_eq!(case.time.steps, 40);
    let s = case.setup("quarter_disk", Path::new(".")).unwrap();
    let mut d = Deformation::new(s.mesh, s.parts, s.field, s.options).unwrap();
    d.run(&[], |_| {}, |_| {}).unwrap();
    d
}

#[test]
fn quarter_disk_sliding_is_valid_accurate_and_on_the_circle() {
    let d = quarter_disk("sliding");
    assert_eq!(d.t, 1.0);
    let q = mesh_quality(&d.mesh);
    assert!(q.invalid_cells.is_empty(), "invalid cells {:?}", q.invalid_cells);
    assert!(q.det_j.min > 0.0);
    let jf = d.jf_now().unwrap();
    let r = jf_stats(&jf, &vec![1.0; jf.len()]);
    // measured: [0.896, 1.038]
    assert!(r.min >= 0.85 && r.max <= 1.10, "J/f in [{}, {}]", r.min, r.max);
    // every node of the moving part on the circle of radius 1.25
    let dists = d.boundary_distances();
    assert_eq!(dists.len(), 41, "20 + 20 edges of the arc part have 41 nodes");
    for &(i, dist) in &dists {
        let p = d.mesh.nodes[i];
        assert!(dist < 1e-10 && (p[0].hypot(p[1]) - 1.25).abs() < 1e-10, "node {i} at {p:?}");
    }
    // slip nodes exactly on their axis: bottom row y = 0, left column x = 0
    for i in 0..=20 {
        assert_eq!(d.mesh.nodes[i][1], 0.0, "bottom node {i}");
        assert_eq!(d.mesh.nodes[i * 21][0], 0.0, "left node {}", i * 21);
    }
    // the area is the quarter disk's up to the polygonal arc
    let (area, exact) = (d.mesh.area(), std::f64::consts::PI * 1.25 * 1.25 / 4.0);
    assert!(area < exact && area > 0.998 * exact, "area {area}, disk {exact}");
}

#[test]
fn quarter_disk_dirichlet_is_valid_but_j_drifts() {
    let d = quarter_disk("dirichlet");
    let q = mesh_quality(&d.mesh);
    assert!(q.invalid_cells.is_empty(), "invalid cells {:?}", q.invalid_cells);
    for &(i, dist) in &d.boundary_distances() {
        assert!(dist < 1e-10, "node {i} off the circle by {dist}");
    }
    // docs/METHOD.md §3: the over-determined Dirichlet data lets J/f drift
    // (measured [0.173, 1.558]); sliding must be much closer to f.
    let jf = d.jf_now().unwrap();
    let r = jf_stats(&jf, &vec![1.0; jf.len()]);
    assert!(r.min < 0.5 && r.max > 1.3, "J/f in [{}, {}]", r.min, r.max);
}

/// L2 norm of J/f − 1 at t = 1 on the fixed unit square (all sides slip)
/// with g₁ = 1 + 0.5 sin(πx) sin(πy), n×n cells, `steps` steps.
fn square_error(n: usize, steps: usize, integrator: Integrator) -> f64 {
    let text = format!(
        "[mesh]\nlower = [0.0, 0.0]\nupper = [1.0, 1.0]\ncells = [{n}, {n}]\n\
         [jacobian]\ntype = \"expression\"\nf = \"1 + 0.5*sin(pi*x)*sin(pi*y)\"\n\
         [time]\nsteps = {steps}\nintegrator = \"{}\"\n",
        if integrator == Integrator::Heun { "heun" } else { "euler" }
    );
    let s = Case::parse(&text, "square").unwrap().setup("square", Path::new(".")).unwrap();
    assert_eq!(s.parts.len(), 4, "unnamed sides become slip walls");
    let areas: Vec<f64> = (0..s.mesh.num_cells()).map(|c| s.mesh.cell_area(c)).collect();
    let mut d = Deformation::new(s.mesh, s.parts, s.field, s.options).unwrap();
    d.run(&[], |_| {}, |_| {}).unwrap();
    assert!(mesh_quality(&d.mesh).invalid_cells.is_empty());
    jf_stats(&d.jf_now().unwrap(), &areas).l2_error
}

#[test]
fn jf_error_converges_in_h_and_dt() {
    // refine h and dt together (steps = n); measured rate 1.01 (Euler is
    // first order in dt, and dt dominates)
    let errors: Vec<f64> = [8, 16, 32].iter().map(|&n| square_error(n, n, Integrator::Euler)).collect();
    let rates: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    eprintln!("Euler, h and dt together: errors {errors:?}, rates {rates:?}");
    for r in &rates {
        assert!(*r > 0.9, "rate {r} (errors {errors:?})");
    }
}

#[test]
fn jf_error_converges_in_h_with_heun() {
    // measured rate 1.96: second order in h once dt is not limiting
    let errors: Vec<f64> = [8, 16, 32].iter().map(|&n| square_error(n, 16, Integrator::Heun)).collect();
    let rates: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    eprintln!("Heun, 16 steps, h refined: errors {errors:?}, rates {rates:?}");
    for r in &rates {
        assert!(*r > 1.8, "rate {r} (errors {errors:?})");
    }
}

#[test]
fn jf_error_converges_in_dt() {
    // measured rate 1.02-1.03: Euler's first order
    let errors: Vec<f64> = [4, 8, 16].iter().map(|&s| square_error(64, s, Integrator::Euler)).collect();
    let rates: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    eprintln!("Euler, 64², dt refined: errors {errors:?}, rates {rates:?}");
    for r in &rates {
        assert!(*r > 0.9, "rate {r} (errors {errors:?})");
    }
}

#[test]
fn expression_field_is_normalised_on_the_moving_domain() {
    // ∫_{Ω_t} 1/f = |Ω₀| at t = 1: with f = c g, c = (1/|Ω₀|) ∫ 1/g
    let e = Expr::parse("1 + x*y", &deformesh::jacobian::EXPR_VARS).unwrap();
    let text = DEMO_CASE.replace("type = \"uniform\"", "type = \"expression\"\nf = \"1 + x*y\"");
    let s = Case::parse(&text, "q").unwrap().setup("q", Path::new(".")).unwrap();
    let mut d = Deformation::new(s.mesh, s.parts, s.field, s.options).unwrap();
    d.run(&[], |_| {}, |_| {}).unwrap();
    let norm = d.normalisation_now().unwrap();
    let field = JacobianField::expression(e);
    // not the 2×2 Gauss rule `normalise` uses (that would only repeat its
    // sum): 5×5 Gauss–Legendre per cell, exact to degree 9
    let mut integral = 0.0;
    for c in 0..d.mesh.num_cells() {
        let p = d.mesh.cell_coords(c);
        for (xi, wx) in GAUSS5 {
            for (eta, wy) in GAUSS5 {
                let (x, det, _) = deformesh::lsfem::q1_map(&p, xi, eta);
                integral += wx * wy * det / norm.f(&field, [x[0], x[1], 0.0]);
            }
        }
    }
    eprintln!("|∫ 1/f − 1| = {:e}", (integral - 1.0).abs());
    // measured: |∫ 1/f − 1| = 2.15e-8, the 2×2 rule's own error (a wrong
    // c(t) shows at 1e-3 and more); margin 2.3×
    assert!((integral - 1.0).abs() < 5e-8, "∫ 1/f = {integral}");
    let q = mesh_quality(&d.mesh);
    assert!(q.invalid_cells.is_empty());
}

/// Runs a case text to t = 1 and checks validity and that every node of
/// every moving part lies on its target within 1e-10; returns J/f range.
fn run_on_target(text: &str) -> (f64, f64) {
    let s = Case::parse(text, "shape").unwrap().setup("shape", Path::new(".")).unwrap();
    let mut d = Deformation::new(s.mesh, s.parts, s.field, s.options).unwrap();
    d.run(&[], |_| {}, |_| {}).unwrap();
    let q = mesh_quality(&d.mesh);
    assert!(q.invalid_cells.is_empty(), "invalid cells {:?}", q.invalid_cells);
    let dists = d.boundary_distances();
    assert!(!dists.is_empty());
    for (i, dist) in dists {
        assert!(dist < 1e-10, "node {i} at {:?} is {dist:e} off its target", d.mesh.nodes[i]);
    }
    let jf = d.jf_now().unwrap();
    let r = jf_stats(&jf, &vec![1.0; jf.len()]);
    (r.min, r.max)
}

fn whole_box_onto(shape: &str, correspondence: &str) -> String {
    format!(
        "[mesh]\nlower = [-1.0, -1.0]\nupper = [1.0, 1.0]\ncells = [16, 16]\n\
         [[boundary]]\nname = \"outer\"\nsides = [\"left\", \"right\", \"bottom\", \"top\"]\nkind = \"move\"\n\
         shape = {shape}\n{correspondence}\n[time]\nsteps = 30\n"
    )
}

#[test]
fn every_target_shape_is_reached_exactly() {
    let radial = "correspondence = \"radial\"\ncentre = [0.0, 0.0]";
    // (name, case, measured J/f range); asserted within 0.01 of it
    let cases = [
        ("ellipse", whole_box_onto("{ type = \"ellipse\", centre = [0.0, 0.0], semi_axes = [1.6, 0.9], angle = 20.0 }", radial), [0.733, 1.471]),
        ("ellipse, closest point", whole_box_onto("{ type = \"ellipse\", centre = [0.0, 0.0], semi_axes = [1.5, 1.3] }", "correspondence = \"normal\""), [0.934, 1.139]),
        ("superellipse", whole_box_onto("{ type = \"superellipse\", centre = [0.0, 0.0], semi_axes = [1.3, 1.1], exponent = 3.0 }", radial), [0.907, 1.154]),
        ("circle", whole_box_onto("{ type = \"circle\", centre = [0.1, 0.0], radius = 1.2 }", radial), [0.935, 1.099]),
        (
            "closed spline",
            whole_box_onto(
                "{ type = \"spline\", closed = true, points = [[1.4, 0.0], [0.9, 0.9], [0.0, 1.2], [-1.0, 0.8], [-1.3, 0.0], [-0.8, -0.9], [0.0, -1.1], [1.0, -0.8]] }",
                radial,
            ),
            [0.883, 1.207],
        ),
    ];
    for (name, text, [mlo, mhi]) in cases {
        let (lo, hi) = run_on_target(&text);
        eprintln!("{name}: J/f in [{lo:.3}, {hi:.3}]");
        assert!(lo > mlo - 0.01 && hi < mhi + 0.01, "{name}: J/f in [{lo}, {hi}], measured [{mlo}, {mhi}]");
    }
    // an open curve and a line: the top of the unit square onto a wave
    // through given points, and the right side onto a slanted line; the
    // wave ends where the line takes the corner (1, 1): (1, 1) projected
    // onto the line, (1 + 0.2/1.04, 1/1.04)
    let text = "[mesh]\nlower = [0.0, 0.0]\nupper = [1.0, 1.0]\ncells = [16, 16]\n\
        [[boundary]]\nname = \"wave\"\nsides = [\"top\"]\nkind = \"move\"\n\
        shape = { type = \"spline\", points = [[-0.2, 1.0], [0.25, 1.15], [0.5, 1.0], [0.75, 0.85], [1.1923076923076923, 0.9615384615384616]] }\n\
        correspondence = \"normal\"\n\
        [[boundary]]\nname = \"slant\"\nsides = [\"right\"]\nkind = \"move\"\n\
        shape = { type = \"line\", from = [1.0, 0.0], to = [1.2, 1.0] }\ncorrespondence = \"normal\"\n";
    // (a wave ending at (1.2, 1) would leave the corner 2.9e-2 off it:
    // refused, naming both groups)
    let off = text.replace("[1.1923076923076923, 0.9615384615384616]]", "[1.2, 1.0]]");
    let s = Case::parse(&off, "shape").unwrap().setup("shape", Path::new(".")).unwrap();
    let e = Deformation::new(s.mesh, s.parts, s.field, s.options).err().expect("refused").to_string();
    assert!(e.contains("`wave`") && e.contains("`slant`") && e.contains("not supported"), "{e}");
    let (lo, hi) = run_on_target(text);
    eprintln!("wave: J/f in [{lo:.3}, {hi:.3}]");
    // measured [0.5747, 1.6343] (the same before and after this round's
    // solver and assembly changes, and with Cholesky or the lagged factor);
    // margin 0.01
    assert!(lo > 0.5647 && hi < 1.6443, "wave: J/f in [{lo}, {hi}]");
}

#[test]
fn a_folding_correspondence_is_an_error_naming_the_part() {
    // (±1, 0) lie inside the evolute of this ellipse: their closest points
    // jump between the upper and lower halves
    let text = whole_box_onto("{ type = \"ellipse\", centre = [0.0, 0.0], semi_axes = [1.6, 0.9] }", "correspondence = \"normal\"");
    let s = Case::parse(&text, "fold").unwrap().setup("fold", Path::new(".")).unwrap();
    let err = Deformation::new(s.mesh, s.parts, s.field, s.options).err().expect("an error");
    let msg = err.to_string();
    assert!(msg.contains("`outer`") && (msg.contains("jumps") || msg.contains("folds")), "{msg}");
}

#[test]
fn a_curved_slip_wall_keeps_its_nodes() {
    // deform onto the quarter disk, then adapt the result with the arc as a
    // curved slip wall: cells crowd towards x = 0 and the arc nodes glide
    use deformesh::deform::{BoundaryPart, BoundaryShape, PartKind};
    use deformesh::geometry::ShapeSpec;
    use std::sync::Arc;
    let first = quarter_disk("sliding");
    let circle: Arc<dyn BoundaryShape<2>> = Arc::new(ShapeSpec::Circle { centre: [0.0, 0.0], radius: 1.25 }.build().unwrap());
    let parts = vec![
        BoundaryPart::new("axes", PartKind::Slip { wall: None }),
        BoundaryPart::new("arc", PartKind::Slip { wall: Some(circle) }),
    ];
    let field = JacobianField::expression(Expr::parse("0.2 + x", &deformesh::jacobian::EXPR_VARS).unwrap());
    let options = deformesh::deform::DeformOptions { steps: 20, ..Default::default() };
    let mut d = Deformation::new(first.mesh.clone(), parts, field, options).unwrap();
    d.run(&[], |_| {}, |_| {}).unwrap();
    assert!(mesh_quality(&d.mesh).invalid_cells.is_empty());
    let mut moved = 0.0f64;
    for (p, s) in d.mesh.nodes.iter().zip(&d.start) {
        if (s[0].hypot(s[1]) - 1.25).abs() < 1e-10 {
            assert!((p[0].hypot(p[1]) - 1.25).abs() < 1e-10, "arc node left the wall: {p:?}");
            moved = moved.max((p[0] - s[0]).hypot(p[1] - s[1]));
        }
    }
    assert!(moved > 1e-3, "arc nodes glide along the wall (largest move {moved})");
    let jf = d.jf_now().unwrap();
    let r = jf_stats(&jf, &vec![1.0; jf.len()]);
    assert!(r.min > 0.8 && r.max < 1.25, "J/f in [{}, {}]", r.min, r.max);
}

fn quarter_disk_with(n: usize, solver: deformesh::deform::SolverChoice) -> Deformation {
    let mut case = Case::parse(DEMO_CASE, "quarter_disk").unwrap();
    case.mesh.cells = vec![n, n];
    case.time.solver = solver;
    let s = case.setup("quarter_disk", Path::new(".")).unwrap();
    let mut d = Deformation::new(s.mesh, s.parts, s.field, s.options).unwrap();
    d.run(&[], |_| {}, |_| {}).unwrap();
    d
}

#[test]
fn multigrid_gives_the_cholesky_mesh_with_few_iterations() {
    use deformesh::deform::SolverChoice;
    let exact = quarter_disk_with(50, SolverChoice::Cholesky);
    for n in [50, 100, 200] {
        let d = quarter_disk_with(n, SolverChoice::Amg);
        let r = d.solver_report();
        // measured: means 10.4, 9.8, 11.8 and at most 18, 14, 17 (a solve
        // after which the hierarchy is rebuilt)
        assert!(r.iterations_max < 20 && r.iterations_mean < 13.0 && r.iterations_mean > 2.0, "{n}²: {r:?}");
        assert!(mesh_quality(&d.mesh).invalid_cells.is_empty());
        if n == 50 {
            let diff = exact.mesh.nodes.iter().zip(&d.mesh.nodes).map(|(p, q)| (p[0] - q[0]).abs().max((p[1] - q[1]).abs())).fold(0.0, f64::max);
            // measured: 2.8e-9 at the default tolerance 1e-7
            assert!(diff < 1e-7, "meshes differ by {diff}");
        }
    }
}

#[test]
fn a_field_that_is_not_one_at_the_start_is_refused() {
    let with = |f: &str| {
        let text = DEMO_CASE.replace("type = \"uniform\"", &format!("type = \"expression\"\nf = \"{f}\""));
        let s = Case::parse(&text, "q").unwrap().setup("q", Path::new(".")).unwrap();
        Deformation::new(s.mesh, s.parts, s.field, s.options).map(|_| ())
    };
    // g(x, 0) = 1 + 3x: the run used to go on and end with J/f in [0.56, 1.97]
    let e = with("1 + 3*x*(1-0.5*t)").err().expect("refused").to_string();
    assert!(e.contains("must be 1 everywhere at t = 0") && e.contains("g = 1.") && e.contains("at t = 0"), "{e}");
    // a t-dependent field that starts at 1 runs
    assert!(with("1 + 3*x*t").is_ok());
}

/// The quarter disk (`n`² cells, `steps` Euler steps) with `f`, run to t = 1.
fn quarter_disk_field(n: usize, steps: usize, f: &str) -> Deformation {
    let text = DEMO_CASE.replace("type = \"uniform\"", &format!("type = \"expression\"\nf = \"{f}\""));
    let mut case = Case::parse(&text, "q").unwrap();
    case.mesh.cells = vec![n, n];
    case.time.steps = steps;
    let s = case.setup("q", Path::new(".")).unwrap();
    let mut d = Deformation::new(s.mesh, s.parts, s.field, s.options).unwrap();
    d.run(&[], |_| {}, |_| {}).unwrap();
    d
}

#[test]
fn a_field_in_t_follows_its_own_path() {
    // g = 1 + 3xt is the linear path of g₁ = 1 + 3x: the same flow, once
    // through ∂g/∂t of the text in t, once through the path's formula
    let by_t = quarter_disk_field(12, 20, "1 + 3*x*t");
    let by_path = quarter_disk_field(12, 20, "1 + 3*x");
    let diff = by_t.mesh.nodes.iter().zip(&by_path.mesh.nodes).map(|(p, q)| (p[0] - q[0]).abs().max((p[1] - q[1]).abs())).fold(0.0, f64::max);
    // measured 3.4e-12: the difference quotient of a g linear in t is exact
    // but for rounding, about ε/h = 2e-10 at h = 1e-6
    assert!(diff < 1e-9, "meshes differ by {diff}");
    // a path of its own, g = 1 + 3x t²: the end is f with J/f near 1
    let d = quarter_disk_field(12, 20, "1 + 3*x*t^2");
    assert!(mesh_quality(&d.mesh).invalid_cells.is_empty());
    let jf = d.jf_now().unwrap();
    let r = jf_stats(&jf, &vec![1.0; jf.len()]);
    eprintln!("g = 1 + 3x t²: J/f in [{}, {}], diff {diff:e}", r.min, r.max);
    // measured [0.869, 1.212]; margin 0.01
    assert!(r.min > 0.859 && r.max < 1.222, "J/f in [{}, {}]", r.min, r.max);
}

#[test]
fn a_step_that_would_tangle_is_halved_and_the_run_ends_valid() {
    // one nominal step of f = 1 + 5xy inverts cells: it is retried at half
    // the step (measured: 3 halvings), from the state before it
    let d = quarter_disk_field(10, 1, "1 + 5*x*y");
    assert!(d.stats.halved > 0, "no step was halved");
    assert_eq!(d.t, 1.0);
    let q = mesh_quality(&d.mesh);
    assert!(q.invalid_cells.is_empty(), "invalid cells {:?}", q.invalid_cells);
    for (i, dist) in d.boundary_distances() {
        assert!(dist < 1e-10, "node {i} is {dist:e} off the circle");
    }
    // a failed trial left behind would show against a run that never halves
    let fine = quarter_disk_field(10, 10, "1 + 5*x*y");
    assert_eq!(fine.stats.halved, 0);
    let diff = d.mesh.nodes.iter().zip(&fine.mesh.nodes).map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1])).fold(0.0, f64::max);
    let jf = d.jf_now().unwrap();
    let r = jf_stats(&jf, &vec![1.0; jf.len()]);
    eprintln!("one step: halved {}, steps {}, J/f in [{}, {}], {diff:e} from 10 steps", d.stats.halved, d.stats.steps, r.min, r.max);
    // measured: 5.86e-2 from the 10-step mesh (Euler's error at dt 1/8
    // against 1/10), J/f in [0.524, 1.686]; margins 35% and 0.02
    assert!(diff < 0.08, "{diff} from the 10-step mesh");
    assert!(r.min > 0.50 && r.max < 1.71, "J/f in [{}, {}]", r.min, r.max);
}

/// The demo's quarter disk with `options` changed by `edit`, run to its
/// end: the error it ended with, and the steps it took.
fn quarter_disk_ending(edit: impl Fn(&mut deformesh::deform::DeformOptions)) -> (deformesh::deform::DeformError, usize) {
    let case = Case::parse(DEMO_CASE, "quarter_disk").unwrap();
    let mut s = case.setup("quarter_disk", Path::new(".")).unwrap();
    edit(&mut s.options);
    let mut d = Deformation::new(s.mesh, s.parts, s.field, s.options).unwrap();
    let e = d.run(&[], |_| {}, |_| {}).expect_err("the run must end short of t = 1");
    (e, d.stats.steps)
}

/// A run with a budget of steps whose pace over a window of steps, kept
/// for the rest of the budget, would not reach t = 1 ends at the end of
/// that window (issue 42). The quarter disk's 40 nominal steps advance t
/// by 1/40 each: with a budget of 39, at step 10 (t = 0.25) the 29 steps
/// left would reach 0.975; with 41 they reach 1.025, and the run ends at
/// t = 1 after 40 steps.
#[test]
fn a_run_too_slow_for_its_budget_ends_with_its_pace() {
    use deformesh::deform::{DeformError, PACE_WINDOW};
    assert_eq!(PACE_WINDOW, 10, "the figures below are for a window of 10 steps");
    let (e, steps) = quarter_disk_ending(|o| o.max_steps = Some(39));
    match &e {
        DeformError::Stalled { t, why, .. } => {
            assert!((t - 0.25).abs() < 1e-12, "t = {t}");
            assert!(why.contains("at that pace the 29 steps left of its budget of 39 would end at t = 0.9750"), "{why}");
        }
        other => panic!("not a stall: {other}"),
    }
    assert_eq!(steps, 10);
    let case = Case::parse(DEMO_CASE, "quarter_disk").unwrap();
    let mut s = case.setup("quarter_disk", Path::new(".")).unwrap();
    s.options.max_steps = Some(41);
    let mut d = Deformation::new(s.mesh, s.parts, s.field, s.options).unwrap();
    d.run(&[], |_| {}, |_| {}).expect("a budget the pace meets");
    assert_eq!(d.stats.steps, 40);
}

/// Every run ends (issue 42): a step control that accepts ever smaller
/// steps (here one allowing a change of 1e-9 of a corner's Jacobian per
/// step) ends after one window of steps that no longer advance t, with
/// its reason; a run that spends its budget of steps ends there.
#[test]
fn a_stalled_step_control_and_a_spent_budget_end_the_run_with_their_reason() {
    use deformesh::deform::{DeformError, STALL_WINDOW};
    let (e, steps) = quarter_disk_ending(|o| o.max_strain = Some(1e-9));
    match &e {
        DeformError::Stalled { t, steps: at, why } => {
            assert!(*t < 1e-3, "t = {t}");
            assert_eq!(*at, steps);
            assert!(why.contains(&format!("last {STALL_WINDOW} steps advanced t by")), "{why}");
        }
        other => panic!("not a stall: {other}"),
    }
    // the first window: the rule looks at no more steps than that
    assert_eq!(steps, STALL_WINDOW, "{e}");
    let (e, steps) = quarter_disk_ending(|o| o.max_steps = Some(7));
    assert!(matches!(&e, DeformError::Stalled { t, why, .. } if (*t - 7.0 / 40.0).abs() < 1e-12 && why.contains("budget of 7 steps")), "{e}");
    assert_eq!(steps, 7);
}
