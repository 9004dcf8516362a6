//! Algorithm 1 (`run`) on every element kind: the cases' boxes made of
//! triangles, tetrahedra, prisms or pyramids, or of kinds side by side
//! (`mesh.elements`), moved
//! through the P1 system of their triangles or tetrahedra, and on through
//! Algorithms 2 and 3. The real Gmsh reads every written mesh.

use crate::prisms::{gmsh_agrees, group_off};
use crate::simplices::{gmsh_agrees_kinds, gmsh_agrees_simplex};
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

/// The quarter ball's `sphere` nodes in `file` within 1e-12 of the
/// sphere r = 1.25, its `planes` nodes exactly on the coordinate planes.
fn quarter_ball_nodes_on_their_surfaces(file: &Path, kind: &str) {
    let (off, n) = group_off::<3>(file, "sphere", |x| (x[0].hypot(x[1]).hypot(x[2]) - 1.25).abs());
    assert!(off < 1e-12 && n > 0, "{kind}: sphere nodes {off:e} off");
    let (off, n) = group_off::<3>(file, "planes", |x| x.iter().fold(f64::INFINITY, |a, &v| a.min(v.abs())));
    assert!(off == 0.0 && n > 0, "{kind}: plane nodes {off:e} off");
}

/// The quarter ball of tetrahedra and of prisms: every cell certified
/// valid (and by the real Gmsh, also at order 2 after Algorithms 2 and
/// 3), the sphere and plane nodes on their surfaces, and the nodes where
/// the hex run of the same box puts them, to the discretisation's error,
/// which falls as the box is refined.
#[test]
fn the_quarter_ball_runs_on_tetrahedra_and_prisms_as_on_hexes() {
    for (kind, per_hex, ty) in [("tetrahedron", 6, 4), ("prism", 2, 6)] {
        let (report, out, _dir) = run_case("quarter_ball.toml", |t| with_cells(t, "[6, 6, 6]", Some(kind)));
        assert_eq!((report.cells, report.invalid_cells), (216 * per_hex, 0), "{kind}");
        assert!(report.boundary_distance_max < 1e-12, "{kind}: {}", report.boundary_distance_max);
        let file = out.join("mesh.msh");
        assert_eq!(gmsh_agrees(&file, &[(ty, 216 * per_hex)]), 216 * per_hex);
        quarter_ball_nodes_on_their_surfaces(&file, kind);
        // measured: J/f in [0.870, 1.180] on both (the prisms' three
        // tetrahedra are Kuhn's six per box cell, the tetrahedra's)
        assert!(report.jf.min > 0.86 && report.jf.max < 1.19, "{kind}: J/f in [{}, {}]", report.jf.min, report.jf.max);
    }
    // both kinds keep the box's nodes first: the same nodes as the hexes'
    let (coarse, fine) = (gap::<3>("quarter_ball.toml", "[4, 4, 4]", "prism"), gap::<3>("quarter_ball.toml", "[8, 8, 8]", "prism"));
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

/// The largest distance between the nodes of two runs of `file` at
/// `cells`, of `kind` and of the case's quads or hexes (the boxes number
/// their nodes alike).
fn gap<const D: usize>(file: &str, cells: &str, kind: &str) -> f64 {
    let plain = final_nodes::<D>(file, cells, None);
    let other = final_nodes::<D>(file, cells, Some(kind));
    plain.iter().zip(&other).map(|(a, b)| (0..D).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()).fold(0.0, f64::max)
}

/// The quarter disk of quads and triangles side by side (a checkerboard):
/// valid at order 3 with both kinds, Gmsh agrees on both, the arc nodes
/// on the arc; and its nodes where the all-quad run puts them, the gap
/// falling as the box is refined.
#[test]
fn the_quarter_disk_runs_on_quads_and_triangles_together() {
    let edit = |t: String| with_cells(t, "[8, 8]", Some("mixed")) + "\n[highorder]\norder = 3\n";
    let (report, out, _dir) = run_case("quarter_disk.toml", edit);
    assert_eq!((report.cells, report.invalid_cells), (32 + 64, 0));
    assert!(report.boundary_distance_max < 1e-12, "{}", report.boundary_distance_max);
    let curved = report.highorder.as_ref().expect("order 3");
    assert!(curved.quality.invalid_elements.is_empty() && curved.quality.min_det_j > 0.0);
    let file = out.join("mesh.msh");
    // Gmsh's reference square is [-1, 1]²: its det J is a quarter of ours
    let (det, _) = gmsh_agrees_kinds::<2>(&file, &[(36, 32, 0.25), (21, 64, 1.0)], 1e-7, None);
    let (off, n) = group_off::<2>(&file, "arc", |x| (x[0].hypot(x[1]) - 1.25).abs());
    assert!(off < 1e-12 && n > 0, "arc nodes {off:e} off");
    let linear = out.join("linear.msh");
    gmsh_agrees_kinds::<2>(&linear, &[(3, 32, 0.25), (2, 64, 1.0)], 1e-9, None);
    let (coarse, fine) = (gap::<2>("quarter_disk.toml", "[8, 8]", "mixed"), gap::<2>("quarter_disk.toml", "[16, 16]", "mixed"));
    eprintln!("Gmsh's minDetJac within {det:.1e} of ours; largest distance from the quad run's nodes: {coarse:.3e} at 8², {fine:.3e} at 16²");
    // measured: 1.81e-3 at 8², 1.08e-3 at 16²
    assert!(fine < 0.65 * coarse && fine < 1.2e-3, "{coarse:e} at 8², {fine:e} at 16²");
}

/// The quarter ball of hexes and prisms in columns side by side: valid,
/// Gmsh agrees on both kinds (linear and at order 2), sphere and plane
/// nodes on their surfaces, and the nodes where the all-hex run puts
/// them, closer as the box is refined.
#[test]
fn the_quarter_ball_runs_on_hexes_and_prisms_together() {
    let edit = |t: String| with_cells(t, "[6, 6, 6]", Some("mixed")) + "\n[highorder]\norder = 2\n";
    let (report, out, _dir) = run_case("quarter_ball.toml", edit);
    // 18 columns of 6 hexes, 18 of 12 prisms
    assert_eq!((report.cells, report.invalid_cells), (108 + 216, 0));
    assert!(report.boundary_distance_max < 1e-12, "{}", report.boundary_distance_max);
    let file = out.join("mesh.msh");
    assert_eq!(gmsh_agrees(&file, &[(12, 108), (13, 216)]), 324);
    assert_eq!(gmsh_agrees(&out.join("linear.msh"), &[(5, 108), (6, 216)]), 324);
    quarter_ball_nodes_on_their_surfaces(&file, "mixed");
    let (coarse, fine) = (gap::<3>("quarter_ball.toml", "[4, 4, 4]", "mixed"), gap::<3>("quarter_ball.toml", "[8, 8, 8]", "mixed"));
    eprintln!("largest distance from the hex run's nodes: {coarse:.3e} at 4³, {fine:.3e} at 8³");
    // measured: 1.31e-2 at 4³, 4.69e-3 at 8³
    assert!(fine < 0.45 * coarse && fine < 5.2e-3, "{coarse:e} at 4³, {fine:e} at 8³");
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
