//! Algorithm 1 on hexahedral meshes: the seed's 3D figures, with the
//! figures the issue asks for.

use crate::common;
use common::GAUSS5;
use deformesh::app::case::{AnySetup, Case, Setup};
use deformesh::deform::Deformation3;
use deformesh::lsfem::{gauss_points, q1_eval};
use deformesh::mesh::HexMesh;
use deformesh::quality::{corner_det_j, hex_mesh_quality};
use std::path::Path;

fn setup(file: &str, edit: impl Fn(&mut Case)) -> Setup<HexMesh, 3> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases").join(file);
    let mut case = Case::read(&path).unwrap();
    edit(&mut case);
    match case.setup_any(file, path.parent().unwrap()).unwrap() {
        AnySetup::Hex(s) => s,
        _ => panic!("{file} is not of hexahedra"),
    }
}

fn run(s: Setup<HexMesh, 3>) -> Deformation3 {
    let mut d = Deformation3::new(s.mesh, s.parts, s.field, s.options).unwrap();
    d.run(&[], |_| {}, |_| {}).unwrap();
    d
}

/// Every cell valid by the Bézier certificate, and det J > 0 at its eight
/// corners and eight Gauss points.
fn assert_valid(d: &Deformation3) {
    let q = hex_mesh_quality(&d.mesh);
    assert!(q.invalid_cells.is_empty(), "invalid cells {:?}", q.invalid_cells);
    for c in 0..d.mesh.num_cells() {
        let p = d.mesh.cell_coords(c);
        assert!(corner_det_j(&p).iter().all(|&v| v > 0.0), "cell {c} corner");
        assert!(gauss_points::<3>().all(|(xi, _)| q1_eval(&p, xi).1 > 0.0), "cell {c} Gauss point");
    }
}

fn assert_on_targets(d: &Deformation3) -> usize {
    let dists = d.boundary_distances();
    for &(i, dist) in &dists {
        assert!(dist < 1e-10, "node {i} at {:?} is {dist:e} off its target", d.mesh.nodes[i]);
    }
    dists.len()
}

#[test]
fn quarter_ball_12_is_valid_on_the_sphere_and_near_f() {
    let d = run(setup("quarter_ball.toml", |c| c.mesh.cells = vec![12, 12, 12]));
    assert_valid(&d);
    // nodes on the three moving faces: 13³ − 12³
    assert_eq!(assert_on_targets(&d), 13 * 13 * 13 - 12 * 12 * 12);
    for (p, s) in d.mesh.nodes.iter().zip(&d.start) {
        let r = p[0].hypot(p[1]).hypot(p[2]);
        if s.iter().any(|&c| c == 1.0) {
            assert!((r - 1.25).abs() < 1e-10, "sphere node {s:?} at radius {r}");
        }
        for k in 0..3 {
            if s[k] == 0.0 {
                assert_eq!(p[k], 0.0, "slip node {s:?} left its plane");
            }
        }
    }
    // J/f outside a band of width 0.25 along the three edges on the sphere
    let jf = d.jf_now().unwrap();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (c, cell) in d.mesh.cells.iter().enumerate() {
        let centre: Vec<f64> = (0..3).map(|k| cell.iter().map(|&v| d.start[v][k]).sum::<f64>() / 8.0).collect();
        if centre.iter().filter(|&&x| x > 0.75).count() <= 1 {
            lo = lo.min(jf[c]);
            hi = hi.max(jf[c]);
        }
    }
    // measured [0.984, 1.067]; everywhere [0.799, 1.070]; margins 0.01
    assert!(lo >= 0.974 && hi <= 1.077, "J/f outside the edge band in [{lo}, {hi}]");
    let all = jf.iter().fold(f64::INFINITY, |a, &b| a.min(b));
    assert!(all > 0.789, "the gliding edges keep even the corner cell near f: min J/f {all}");
}

#[test]
fn horn_and_ellipsoid_are_valid_and_on_their_surfaces() {
    let horn = run(setup("horn.toml", |c| c.mesh.cells = vec![6, 6, 12]));
    assert_valid(&horn);
    assert!(assert_on_targets(&horn) > 0);
    let ellipsoid = run(setup("ellipsoid.toml", |c| c.mesh.cells = vec![8, 6, 4]));
    assert_valid(&ellipsoid);
    assert!(assert_on_targets(&ellipsoid) > 0);
    for p in &ellipsoid.mesh.nodes {
        let f = (p[0] / 1.5).powi(2) + (p[1] / 1.0).powi(2) + (p[2] / 0.75).powi(2);
        assert!(f <= 1.0 + 1e-12, "node {p:?} outside the ellipsoid");
    }
}

#[test]
fn cube_on_ball_takes_the_ball_shape() {
    let d = run(setup("cube_on_ball.toml", |c| c.mesh.cells = vec![6, 6, 6]));
    assert_valid(&d);
    for (p, s) in d.mesh.nodes.iter().zip(&d.start) {
        if s[2] == 0.0 {
            // onto the sphere of radius 1.7 about (0, 0, −1.5)
            let r = p[0].hypot(p[1]).hypot(p[2] + 1.5);
            assert!((r - 1.7).abs() < 1e-10, "bottom node {s:?} at {p:?}");
        }
        for k in 0..2 {
            if s[k].abs() == 0.5 {
                assert_eq!(p[k], s[k], "node {s:?} left its side wall");
            }
        }
        if s[2] == 1.0 {
            assert_eq!(p[2], 1.0, "the top is a slip wall: its nodes stay in the plane z = 1");
        }
    }
}

#[test]
fn an_unreachable_target_names_the_part() {
    // rays from the origin miss a small sphere far away
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/quarter_ball.toml"))
        .unwrap()
        .replace("centre = [0.0, 0.0, 0.0], radius = 1.25", "centre = [10.0, 10.0, 10.0], radius = 1.0");
    let case = Case::parse(&text, "far.toml").unwrap();
    let AnySetup::Hex(s) = case.setup_any("far.toml", Path::new(".")).unwrap() else { panic!() };
    let err = Deformation3::new(s.mesh, s.parts, s.field, s.options).err().expect("an error");
    let msg = err.to_string();
    assert!(msg.contains("`sphere`") && msg.contains("cannot be reached"), "{msg}");
}

fn brick_onto(shape: &str, correspondence: &str, extra: &str) -> Setup<HexMesh, 3> {
    let text = format!(
        "[mesh]\nlower = [-0.5, -0.5, 0.0]\nupper = [0.5, 0.5, 1.0]\ncells = [6, 6, 6]\n\
         [[boundary]]\nname = \"target\"\nsides = [\"xmin\", \"xmax\", \"ymin\", \"ymax\"]\nkind = \"move\"\n\
         shape = {shape}\n{correspondence}\n{extra}\n[time]\nsteps = 12\n"
    );
    match Case::parse(&text, "brick").unwrap().setup_any("brick", Path::new(".")).unwrap() {
        AnySetup::Hex(s) => s,
        _ => unreachable!(),
    }
}

#[test]
fn cylinder_and_superquadric_targets_and_plane_walls() {
    // the four sides onto a cylinder about z (closest points keep z, so the
    // end faces stay in their planes, given here as explicit plane walls)
    let walls = "[[boundary]]\nname = \"ends\"\nsides = [\"zmin\"]\nkind = \"slip\"\n\
                 shape = { type = \"plane\", point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, -1.0] }\n";
    let d = run(brick_onto("{ type = \"cylinder\", point = [0.0, 0.0, 0.0], axis = [0.0, 0.0, 1.0], radius = 0.6 }", "correspondence = \"normal\"", walls));
    assert_valid(&d);
    assert!(assert_on_targets(&d) > 0);
    for (p, s) in d.mesh.nodes.iter().zip(&d.start) {
        if s[2] == 0.0 {
            assert!(p[2].abs() < 1e-15, "node {s:?} left the plane wall: {p:?}");
        }
    }
    // a superquadric seen from its centre (radial), all six faces moving
    let text = "[mesh]\nlower = [-0.5, -0.5, -0.5]\nupper = [0.5, 0.5, 0.5]\ncells = [6, 6, 6]\n\
        [[boundary]]\nname = \"blob\"\nsides = [\"xmin\", \"xmax\", \"ymin\", \"ymax\", \"zmin\", \"zmax\"]\nkind = \"move\"\n\
        shape = { type = \"superquadric\", centre = [0.0, 0.0, 0.0], semi_axes = [0.7, 0.6, 0.5], exponent = 3.0 }\n\
        correspondence = \"radial\"\ncentre = [0.0, 0.0, 0.0]\n[time]\nsteps = 12\n";
    let AnySetup::Hex(s) = Case::parse(text, "blob").unwrap().setup_any("blob", Path::new(".")).unwrap() else { panic!() };
    let d = run(s);
    assert_valid(&d);
    assert_eq!(assert_on_targets(&d), 7 * 7 * 7 - 5 * 5 * 5);
}

#[test]
fn expression_field_in_3d_is_normalised() {
    // cells crowd towards the bottom: f small where z is small
    let s = setup("quarter_ball.toml", |c| {
        c.mesh.cells = vec![6, 6, 6];
        c.jacobian.field = deformesh::app::case::FieldSpec::Expression { f: "0.5 + z".into() };
    });
    let d = run(s);
    assert_valid(&d);
    let norm = d.normalisation_now().unwrap();
    let field = deformesh::jacobian::JacobianField::expression(deformesh::expr::Expr::parse("0.5 + z", &deformesh::jacobian::EXPR_VARS).unwrap());
    // not the 2×2×2 Gauss rule `normalise` uses (that would only repeat its
    // sum): 5×5×5 Gauss–Legendre per cell, exact to degree 9
    let mut integral = 0.0;
    for c in 0..d.mesh.num_cells() {
        let p = d.mesh.cell_coords(c);
        for (a, wa) in GAUSS5 {
            for (b, wb) in GAUSS5 {
                for (e, we) in GAUSS5 {
                    let (x, det, _) = deformesh::lsfem::q1_eval(&p, [a, b, e]);
                    integral += wa * wb * we * det / norm.f(&field, x);
                }
            }
        }
    }
    // measured: |∫ 1/f − 1| = 2.06e-5 on these 6³ cells, the 2×2×2 rule's
    // own error (a wrong c(t) shows at 1e-3 and more); margin 2.4×
    assert!((integral - 1.0).abs() < 5e-5, "∫ 1/f = {integral}, |Ω₀| = 1");
    let jf = d.jf_now().unwrap();
    let (lo, hi) = jf.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &r| (l.min(r), h.max(r)));
    eprintln!("J/f in [{lo}, {hi}], |∫ 1/f − 1| = {:e}", (integral - 1.0).abs());
    // measured: J/f in [0.870, 1.094]; margin 0.01
    assert!(lo > 0.860 && hi < 1.104, "J/f in [{lo}, {hi}]");
}

#[test]
fn iterative_solvers_give_the_cholesky_mesh() {
    use deformesh::deform::SolverChoice;
    // 12³: 6.6k unknowns, so the multigrid has a coarse level below it
    let with = |solver| run(setup("quarter_ball.toml", |c| {
        c.mesh.cells = vec![12, 12, 12];
        c.time.steps = 20;
        c.time.solver = solver;
    }));
    let exact = with(SolverChoice::Cholesky);
    for solver in [SolverChoice::Cg, SolverChoice::Amg] {
        let b = with(solver);
        let diff = exact.mesh.nodes.iter().zip(&b.mesh.nodes).map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).abs()).fold(0.0, f64::max)).fold(0.0, f64::max);
        // measured at the default tolerance 1e-7: 2.1e-8 (Jacobi), 2.4e-9
        // (multigrid); the issue asks 1e-7
        assert!(diff < 1e-7, "{solver:?}: meshes differ by {diff}");
        assert_valid(&b);
    }
}

#[test]
fn multigrid_iterations_stay_low_on_the_quarter_ball() {
    use deformesh::deform::SolverChoice;
    for n in [8, 16, 32] {
        let d = run(setup("quarter_ball.toml", |c| {
            c.mesh.cells = vec![n, n, n];
            c.time.steps = 10;
            c.time.solver = SolverChoice::Amg;
        }));
        let r = d.solver_report();
        assert!(r.solver.contains("AMG"), "{}", r.solver);
        // measured (steps of 0.1): means 10.7, 10.6, 13.9 and at most 16,
        // 14, 20 (a solve after which the hierarchy is rebuilt)
        assert!(r.iterations_max < 25 && r.iterations_mean < 16.0 && r.iterations_mean > 2.0, "{n}³: {r:?}");
        assert!(r.hierarchy_builds >= 1 && r.hierarchy_builds <= 3, "{n}³: {r:?}");
        assert!(hex_mesh_quality(&d.mesh).invalid_cells.is_empty());
    }
}

#[test]
fn a_jumping_correspondence_in_3d_is_reported_as_tangling() {
    // (±1, 0, 0) lie inside the evolute of this ellipsoid: closest points
    // of the end faces jump between its sides. 3D does not detect this up
    // front (2D does); the run stops and names the cells instead.
    let text = "[mesh]\nlower = [-1.0, -0.5, -0.5]\nupper = [1.0, 0.5, 0.5]\ncells = [8, 4, 4]\n\
        [[boundary]]\nname = \"shell\"\nsides = [\"xmin\", \"xmax\", \"ymin\", \"ymax\", \"zmin\", \"zmax\"]\nkind = \"move\"\n\
        shape = { type = \"ellipsoid\", centre = [0.0, 0.0, 0.0], semi_axes = [1.6, 0.9, 0.9] }\ncorrespondence = \"normal\"\n";
    let AnySetup::Hex(s) = Case::parse(text, "fold.toml").unwrap().setup_any("fold.toml", Path::new(".")).unwrap() else { panic!() };
    let mut d = Deformation3::new(s.mesh, s.parts, s.field, s.options).unwrap();
    match d.run(&[], |_| {}, |_| {}) {
        Err(deformesh::deform::DeformError::Tangled { cells, t, .. }) => {
            assert!(!cells.is_empty() && t < 1.0);
            // the state is the last valid one
            assert!(hex_mesh_quality(&d.mesh).invalid_cells.is_empty());
        }
        other => panic!("expected tangling, got {:?}", other.map(|_| ())),
    }
}
