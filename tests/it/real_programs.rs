//! Checks our MSH and VTU files with the real programs: the Gmsh Python API
//! and VTK's own XML reader (scripts in `tests/python/`).
//!
//! The Python interpreter is `$DEFORMESH_PYTHON`, else `.venv/bin/python` in
//! the crate; `scripts/test.sh` sets the latter up.

use std::path::Path;

use deformesh::io::msh::{write_msh, DOMAIN_NAME};
use deformesh::io::vtu::{write_vtu, VTK_QUAD};
use deformesh::mesh::{Point2, QuadMesh};

use crate::common;
use common::{floats, run_checker};



/// A 6×5 box bent by a smooth non-affine map: every cell is a genuinely
/// bilinear (non-parallelogram) quad, and all stay valid.
fn distorted_box() -> QuadMesh {
    let mut m = QuadMesh::structured_box([0.0, 0.0], [3.0, 2.0], 6, 5);
    for p in &mut m.nodes {
        let [x, y] = *p;
        *p = [
            x + 0.1 * (1.3 * y + 0.4).sin() * (1.0 + 0.2 * x),
            y + 0.12 * (0.9 * x).cos() * y + 0.05 * x * y,
        ];
    }
    m
}

/// 2D cross product of `a - o` and `b - o`.
fn cross(o: Point2, a: Point2, b: Point2) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Min and max of det J of the bilinear map from [0,1]² over the cell. det J
/// is bilinear in (u, v), so both extremes sit at corners, where det J is
/// the cross product of the two edges leaving the corner.
fn det_j_range(p: [Point2; 4]) -> (f64, f64) {
    let corner = |k: usize| cross(p[k], p[(k + 1) % 4], p[(k + 3) % 4]);
    (0..4)
        .map(corner)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
            (lo.min(d), hi.max(d))
        })
}

/// `|a - b| <= 1e-6 |b|`.
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * b.abs()
}


#[test]
fn gmsh_reads_our_msh_with_the_expected_jacobians() {
    let mesh = distorted_box();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("box.msh");
    write_msh(&path, &mesh).unwrap();
    let report = run_checker("check_msh.py", &path);

    assert_eq!(report["num_nodes"], mesh.num_nodes());
    let types = report["element_types"].as_object().unwrap();
    assert_eq!(types.len(), 2, "only lines and quads expected: {types:?}");
    assert_eq!(types["1"]["count"], mesh.edges.len());
    assert_eq!(types["3"]["count"], mesh.num_cells());
    assert_eq!(
        report["physical_names"]["1"],
        serde_json::json!(mesh.part_names)
    );
    assert_eq!(
        report["physical_names"]["2"],
        serde_json::json!([DOMAIN_NAME])
    );

    // Quads carry tags edges+1.., so Gmsh's tag order is our cell order.
    let q = &report["elements_2d"];
    let (min_dj, max_dj, min_sj) = (
        floats(&q["minDetJac"]),
        floats(&q["maxDetJac"]),
        floats(&q["minSJ"]),
    );
    assert_eq!(min_dj.len(), mesh.num_cells());
    for c in 0..mesh.num_cells() {
        // Gmsh's reference quad is [-1,1]², ours [0,1]²: each derivative is
        // half ours, so its det J is ours / 4. Gmsh evaluates det J against
        // the element's own normal, not +z (see the clockwise test below),
        // so for our counter-clockwise cells no sign flip is involved. For
        // a bilinear quad det J has degree 1 in u and in v, so Gmsh's
        // Bézier bounds are the corner values: exact, not just bounds.
        let (lo, hi) = det_j_range(mesh.cell_coords(c));
        assert!(
            lo > 0.0 && min_dj[c] > 0.0 && min_sj[c] > 0.0,
            "cell {c} invalid"
        );
        assert!(
            close(min_dj[c], lo / 4.0),
            "cell {c}: gmsh minDetJac {} vs ours/4 {}",
            min_dj[c],
            lo / 4.0
        );
        assert!(
            close(max_dj[c], hi / 4.0),
            "cell {c}: gmsh maxDetJac {} vs ours/4 {}",
            max_dj[c],
            hi / 4.0
        );
        assert!(
            lo < hi * 0.999,
            "cell {c} is a parallelogram: the test would not see a bilinear map"
        );
    }
}

/// Gmsh's det J is signed relative to the element's own orientation: a
/// clockwise quad, which has det J < 0 in our convention, is reported
/// positive, so Gmsh's minDetJac cannot detect a globally flipped cell,
/// only a tangled (partly folded) one.
#[test]
fn gmsh_det_j_ignores_global_orientation_but_sees_folds() {
    let mut mesh = QuadMesh::structured_box([0.0, 0.0], [2.0, 1.0], 2, 1);
    mesh.nodes[4] = [1.2, 0.9]; // moves the shared top node: both cells non-affine
    mesh.cells[0].reverse(); // clockwise
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("flip.msh");
    write_msh(&path, &mesh).unwrap();
    let q = &run_checker("check_msh.py", &path)["elements_2d"];
    let (min_dj, max_dj) = (floats(&q["minDetJac"]), floats(&q["maxDetJac"]));
    let (lo, hi) = det_j_range(mesh.cell_coords(0));
    assert!(hi < 0.0);
    assert!(
        close(min_dj[0], -hi / 4.0) && close(max_dj[0], -lo / 4.0),
        "{min_dj:?} {max_dj:?}"
    );

    // fold cell 1 by pulling node 2 (bottom right) inside past node 4
    mesh.nodes[2] = [0.9, 0.6];
    write_msh(&path, &mesh).unwrap();
    let q = &run_checker("check_msh.py", &path)["elements_2d"];
    let (lo, hi) = det_j_range(mesh.cell_coords(1));
    assert!(lo < 0.0 && hi > 0.0, "cell 1 should be folded: {lo} {hi}");
    let min_dj = floats(&q["minDetJac"]);
    assert!(
        min_dj[1] < 0.0,
        "a fold must show as a negative minDetJac: {min_dj:?}"
    );
}

#[test]
fn vtk_reads_our_vtu() {
    let original = QuadMesh::structured_box([0.0, 0.0], [3.0, 2.0], 6, 5);
    let mesh = distorted_box();
    let areas: Vec<f64> = (0..mesh.num_cells()).map(|c| mesh.cell_area(c)).collect();
    let min_det: Vec<f64> = (0..mesh.num_cells())
        .map(|c| det_j_range(mesh.cell_coords(c)).0)
        .collect();
    let disp: Vec<[f64; 2]> = mesh
        .nodes
        .iter()
        .zip(&original.nodes)
        .map(|(p, q)| [p[0] - q[0], p[1] - q[1]])
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("box.vtu");
    write_vtu(
        &path,
        &mesh,
        &[("area", &areas), ("min_det_j", &min_det)],
        &[("displacement", &disp)],
    )
    .unwrap();
    let report = run_checker("check_vtu.py", &path);

    assert_eq!(report["num_points"], mesh.num_nodes());
    assert_eq!(report["num_cells"], mesh.num_cells());
    let types = report["cell_types"].as_array().unwrap();
    assert!(
        types.len() == mesh.num_cells() && types.iter().all(|t| *t == VTK_QUAD),
        "{types:?}"
    );
    assert_eq!(
        report["cell_arrays"],
        serde_json::json!({"area": 1, "min_det_j": 1})
    );
    assert_eq!(
        report["point_arrays"],
        serde_json::json!({"displacement": 3})
    );
    let cells = report["cells"].as_array().unwrap();
    for (c, cell) in cells.iter().enumerate() {
        let seen: Vec<Vec<f64>> = cell.as_array().unwrap().iter().map(floats).collect();
        let ours: Vec<Vec<f64>> = mesh
            .cell_coords(c)
            .iter()
            .map(|p| vec![p[0], p[1], 0.0])
            .collect();
        assert_eq!(seen.len(), 4);
        for (s, o) in seen.iter().flatten().zip(ours.iter().flatten()) {
            // VTK and Python keep every bit; serde_json's default float
            // parser may round the last bit, so allow one unit in the last place.
            assert!(
                s == o || (s.to_bits() as i64 - o.to_bits() as i64).abs() <= 1,
                "cell {c}: {seen:?} vs {ours:?}"
            );
        }
    }
}

/// The whole `run` of the quarter disk (sliding, 20×20): Gmsh opens the
/// written mesh.msh, finds every element, judges every one valid, and its
/// extreme Jacobian determinants agree with report.json's.
#[test]
fn gmsh_agrees_with_the_report_of_a_run() {
    use deformesh::app::case::{Case, DEMO_CASE};
    let dir = tempfile::tempdir().unwrap();
    let setup = Case::parse(DEMO_CASE, "demo")
        .unwrap()
        .setup("demo", Path::new("."))
        .unwrap();
    let out = dir.path().join("out");
    let report = deformesh::app::driver::run_setup::<_, 2, 4>(setup, &out, |_| {}).unwrap();
    let gmsh = run_checker("check_msh.py", &out.join("mesh.msh"));
    let types = gmsh["element_types"].as_object().unwrap();
    assert_eq!(types["3"]["count"], 400);
    assert_eq!(types["1"]["count"], 80);
    assert_eq!(gmsh["num_nodes"], 441);
    assert_eq!(gmsh["physical_names"]["1"], serde_json::json!(["axes", "arc"]));
    let q = &gmsh["elements_2d"];
    let (min_dj, max_dj, min_sj) = (floats(&q["minDetJac"]), floats(&q["maxDetJac"]), floats(&q["minSJ"]));
    assert!(min_dj.iter().chain(&min_sj).all(|&v| v > 0.0), "Gmsh finds an invalid element");
    let gmsh_min = min_dj.iter().copied().fold(f64::INFINITY, f64::min);
    let gmsh_max = max_dj.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    assert_eq!(report.invalid_cells, 0);
    assert!(close(gmsh_min, report.quality.det_j.min / 4.0), "minDetJac {gmsh_min} vs ours/4 {}", report.quality.det_j.min / 4.0);
    assert!(close(gmsh_max, report.quality.det_j.max / 4.0), "maxDetJac {gmsh_max} vs ours/4 {}", report.quality.det_j.max / 4.0);
    // and the VTU of the same run opens in VTK with the J/f array
    let vtk = run_checker("check_vtu.py", &out.join("mesh.vtu"));
    assert_eq!(vtk["num_cells"], 400);
    assert_eq!(vtk["cell_arrays"]["J/f"], 1);
}
