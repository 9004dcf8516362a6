//! Algorithm 1 (`run`) on every element kind: the cases' boxes made of
//! triangles, tetrahedra, prisms or pyramids (`mesh.elements`), moved
//! through the P1 system of their triangles or tetrahedra, and on through
//! Algorithms 2 and 3. The real Gmsh reads every written mesh.

use crate::prisms::{gmsh_agrees, group_off};
use crate::simplices::gmsh_agrees_simplex;
use deformesh::app::case::{AnySetup, Case};
use deformesh::app::driver::{run_any, Report};
use std::path::{Path, PathBuf};

/// Case `file` with `edit` applied to its text, without pictures but the
/// last one; run into a fresh folder.
fn run_case(file: &str, edit: impl Fn(String) -> String) -> (Report, PathBuf, tempfile::TempDir) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases").join(file);
    let text = edit(std::fs::read_to_string(&path).unwrap());
    let mut case = Case::parse(&text, file).unwrap();
    case.output.animation = false;
    case.output.frames.clear();
    let setup = case.setup_any(file, path.parent().unwrap()).unwrap_or_else(|e| panic!("{e}"));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let report = run_any(setup, &out, |_| {}).unwrap_or_else(|e| panic!("{file}: {e}"));
    (report, out, dir)
}

/// The node positions of a run of `case` with `cells` of `elements`
/// (none: the case's quads or hexes), read back from its mesh file.
fn final_nodes<const D: usize>(file: &str, cells: &str, elements: Option<&str>) -> Vec<[f64; D]> {
    let (_, out, _dir) = run_case(file, |t| with_cells(t, cells, elements));
    deformesh::mesh::CurvedMesh::<D>::read_msh(&out.join("mesh.msh")).unwrap().nodes
}

/// The case text with its `cells` line replaced, and an `elements` line.
fn with_cells(text: String, cells: &str, elements: Option<&str>) -> String {
    let line = text.lines().find(|l| l.starts_with("cells = ")).unwrap().to_string();
    let new = match elements {
        Some(e) => format!("cells = {cells}\nelements = \"{e}\""),
        None => format!("cells = {cells}"),
    };
    text.replacen(&line, &new, 1)
}

/// The quarter ball of tetrahedra and of prisms: every cell certified
/// valid (and by the real Gmsh, also at order 2 after Algorithms 2 and
/// 3), the sphere and plane nodes on their surfaces, and the nodes where
/// the hex run of the same box puts them, to the discretisation's error,
/// which falls as the box is refined.
#[test]
fn the_quarter_ball_runs_on_tetrahedra_and_prisms_as_on_hexes() {
    let sphere = |x: [f64; 3]| (x[0].hypot(x[1]).hypot(x[2]) - 1.25).abs();
    let planes = |x: [f64; 3]| x.iter().fold(f64::INFINITY, |a, &v| a.min(v.abs()));
    for (kind, per_hex, ty) in [("tetrahedron", 6, 4), ("prism", 2, 6)] {
        let (report, out, _dir) = run_case("quarter_ball.toml", |t| with_cells(t, "[6, 6, 6]", Some(kind)));
        assert_eq!((report.cells, report.invalid_cells), (216 * per_hex, 0), "{kind}");
        assert!(report.boundary_distance_max < 1e-12, "{kind}: {}", report.boundary_distance_max);
        let file = out.join("mesh.msh");
        assert_eq!(gmsh_agrees(&file, &[(ty, 216 * per_hex)]), 216 * per_hex);
        let (off, n) = group_off::<3>(&file, "sphere", sphere);
        assert!(off < 1e-12 && n > 0, "{kind}: sphere nodes {off:e} off");
        let (off, n) = group_off::<3>(&file, "planes", planes);
        assert!(off == 0.0 && n > 0, "{kind}: plane nodes {off:e} off");
        // measured: J/f in [0.870, 1.180] on both (the prisms' three
        // tetrahedra are Kuhn's six per box cell, the tetrahedra's)
        assert!(report.jf.min > 0.86 && report.jf.max < 1.19, "{kind}: J/f in [{}, {}]", report.jf.min, report.jf.max);
    }
    // both kinds keep the box's nodes first: the same nodes as the hexes'
    let gap = |cells: &str, kind: &str| {
        let hex = final_nodes::<3>("quarter_ball.toml", cells, None);
        let other = final_nodes::<3>("quarter_ball.toml", cells, Some(kind));
        hex.iter().zip(&other).map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()).fold(0.0, f64::max)
    };
    let (coarse, fine) = (gap("[4, 4, 4]", "prism"), gap("[8, 8, 8]", "prism"));
    eprintln!("largest distance from the hex run's nodes: {coarse:.3e} at 4³, {fine:.3e} at 8³");
    assert!(fine < 0.5 * coarse && fine < 6e-3, "{coarse:e} at 4³, {fine:e} at 8³");
}

/// The ball-topped cube of pyramids (six per box cell about its centre):
/// valid, its bottom on the sphere, and at order 2 Gmsh agrees.
#[test]
fn the_cube_on_a_ball_runs_on_pyramids() {
    let edit = |t: String| with_cells(t, "[4, 4, 4]", Some("pyramid")) + "\n[highorder]\norder = 2\n";
    let (report, out, _dir) = run_case("cube_on_ball.toml", edit);
    assert_eq!((report.cells, report.invalid_cells), (384, 0));
    let curved = report.highorder.as_ref().expect("order 2");
    assert!(curved.quality.invalid_elements.is_empty() && curved.quality.min_det_j > 0.0);
    // VTK has no curved pyramid: no mesh.vtu, and the report says so
    assert!(!out.join("mesh.vtu").exists() && out.join("linear.vtu").exists());
    assert!(!report.outputs.contains(&"mesh.vtu".to_string()));
    let file = out.join("mesh.msh");
    assert_eq!(gmsh_agrees(&file, &[(14, 384)]), 384);
    let ball = |x: [f64; 3]| (x[0].hypot(x[1]).hypot(x[2] + 1.5) - 1.7).abs();
    let (off, n) = group_off::<3>(&file, "ball", ball);
    assert!(off < 1e-12 && n > 0, "ball nodes {off:e} off");
    let linear = out.join("linear.msh");
    assert_eq!(gmsh_agrees(&linear, &[(7, 384)]), 384);
}

/// The quarter disk of triangles at order 3: valid, on the arc, Gmsh
/// agrees.
#[test]
fn the_quarter_disk_runs_on_triangles() {
    let edit = |t: String| with_cells(t, "[8, 8]", Some("triangle")) + "\n[highorder]\norder = 3\n";
    let (report, out, _dir) = run_case("quarter_disk.toml", edit);
    assert_eq!((report.cells, report.invalid_cells), (128, 0));
    let file = out.join("mesh.msh");
    let (det, sj) = gmsh_agrees_simplex::<2>(&file, 21, 128, 1e-6, 2e-4);
    eprintln!("Gmsh's minDetJac within {det:.1e} of ours, its minSIGE within {sj:.1e}");
    let (off, n) = group_off::<2>(&file, "arc", |x| (x[0].hypot(x[1]) - 1.25).abs());
    assert!(off < 1e-12 && n > 0, "arc nodes {off:e} off");
}

/// A kind of the other dimension, or none the table has, is refused
/// naming the field.
#[test]
fn elements_of_the_wrong_dimension_are_refused() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/quarter_disk.toml");
    let text = with_cells(std::fs::read_to_string(&path).unwrap(), "[4, 4]", Some("prism"));
    let err = Case::parse(&text, "qd.toml").unwrap().setup_any("qd.toml", Path::new(".")).err().unwrap().to_string();
    assert!(err.contains("qd.toml") && err.contains("`mesh.elements`") && err.contains("`prism` elements make a 3D mesh"), "{err}");
    let text = with_cells(std::fs::read_to_string(&path).unwrap(), "[4, 4]", Some("hexagon"));
    let err = Case::parse(&text, "qd.toml").err().unwrap().to_string();
    assert!(err.contains("hexagon") && err.contains("triangle"), "{err}");
    let text = with_cells(std::fs::read_to_string(&path).unwrap(), "[4, 4]", Some("triangle"));
    assert!(matches!(Case::parse(&text, "qd.toml").unwrap().setup_any("qd.toml", Path::new(".")).unwrap(), AnySetup::Tri(_)));
}
