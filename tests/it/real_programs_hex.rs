//! Checks our hex MSH and VTU files with the real programs: the Gmsh Python
//! API and VTK's own XML reader (scripts `check_msh.py`, `check_vtu.py`).
//!
//! The Python interpreter is `$DEFORMESH_PYTHON`, else `.venv/bin/python` in
//! the crate; `scripts/test.sh` sets the latter up.

use std::path::Path;

use deformesh::quality::certify::{det_j_bounds, invalid_cells};
use deformesh::quality::{cell_size as hex_volume, hex_scaled_jacobian as scaled_jacobian};
use deformesh::io::msh::{write_hex_msh, DOMAIN_NAME};
use deformesh::io::vtu::{write_hex_vtu, VTK_HEXAHEDRON};
use deformesh::mesh::HexMesh;

use crate::common;
use common::{floats, run_checker};




/// A 4×3×3 brick bent by a smooth non-affine map: every cell is a genuinely
/// trilinear hex (det J not constant), and all stay valid.
fn distorted_brick() -> HexMesh {
    let mut m = HexMesh::structured_box([0.0; 3], [2.0, 1.5, 1.5], [4, 3, 3]);
    for p in &mut m.nodes {
        let [x, y, z] = *p;
        *p = [
            x + 0.1 * (1.3 * y + 0.4).sin() * (1.0 + 0.2 * z),
            y + 0.12 * (0.9 * x).cos() * y + 0.05 * x * z,
            z + 0.08 * (1.1 * x + 0.7 * y).sin() + 0.04 * x * y,
        ];
    }
    m
}


/// `|a - b| / |b|`.
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn gmsh_reads_our_hex_msh_with_the_expected_jacobians() {
    let mesh = distorted_brick();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("brick.msh");
    write_hex_msh(&path, &mesh).unwrap();
    let report = run_checker("check_msh.py", &path);

    assert_eq!(report["num_nodes"], mesh.num_nodes());
    let types = report["element_types"].as_object().unwrap();
    assert_eq!(types.len(), 2, "only quads and hexes expected: {types:?}");
    assert_eq!(types["3"]["count"], mesh.faces.len());
    assert_eq!(types["5"]["count"], mesh.num_cells());
    assert_eq!(
        report["physical_names"]["2"],
        serde_json::json!(mesh.part_names)
    );
    assert_eq!(
        report["physical_names"]["3"],
        serde_json::json!([DOMAIN_NAME])
    );

    // Hexes carry tags faces+1.., so Gmsh's tag order is our cell order.
    let h = &report["elements_3d"];
    let (min_dj, max_dj, min_sj) = (
        floats(&h["minDetJac"]),
        floats(&h["maxDetJac"]),
        floats(&h["minSJ"]),
    );
    assert_eq!(min_dj.len(), mesh.num_cells());
    let mut worst: f64 = 0.0;
    for c in 0..mesh.num_cells() {
        let p = mesh.cell_coords(c);
        // Gmsh's reference hex is [-1,1]³, ours [0,1]³: each of the three
        // derivatives is half ours, so its det J is ours / 8.
        let (lo, hi) = det_j_bounds(&p);
        assert!(
            lo > 0.0 && min_dj[c] > 0.0 && min_sj[c] > 0.0,
            "cell {c} invalid"
        );
        assert!(
            lo < hi * 0.99,
            "cell {c} is nearly affine: the test would see little"
        );
        let (d_lo, d_hi) = (rel(min_dj[c], lo / 8.0), rel(max_dj[c], hi / 8.0));
        eprintln!(
            "cell {c:2}: gmsh min {:.17e} ours/8 {:.17e} rel {d_lo:.1e}; max rel {d_hi:.1e}; \
             gmsh minSJ {:.6} ours {:.6}; vol {:.6}",
            min_dj[c],
            lo / 8.0,
            min_sj[c],
            scaled_jacobian(&p),
            hex_volume(&p)
        );
        worst = worst.max(d_lo).max(d_hi);
    }
    eprintln!("largest relative difference of Gmsh's min/maxDetJac from ours/8: {worst:.2e}");
    assert!(
        worst < 1e-12,
        "Gmsh's det J bounds differ from ours/8 by {worst:e}"
    );
    assert!(invalid_cells(&mesh.cells, &mesh.nodes).is_empty());
}

#[test]
fn vtk_reads_our_hex_vtu() {
    let original = HexMesh::structured_box([0.0; 3], [2.0, 1.5, 1.5], [4, 3, 3]);
    let mesh = distorted_brick();
    let volumes: Vec<f64> = (0..mesh.num_cells())
        .map(|c| hex_volume(&mesh.cell_coords(c)))
        .collect();
    let min_det: Vec<f64> = (0..mesh.num_cells())
        .map(|c| det_j_bounds(&mesh.cell_coords(c)).0)
        .collect();
    let disp: Vec<[f64; 3]> = mesh
        .nodes
        .iter()
        .zip(&original.nodes)
        .map(|(p, q)| [p[0] - q[0], p[1] - q[1], p[2] - q[2]])
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("brick.vtu");
    write_hex_vtu(
        &path,
        &mesh,
        &[("volume", &volumes), ("min_det_j", &min_det)],
        &[("displacement", &disp)],
    )
    .unwrap();
    let report = run_checker("check_vtu.py", &path);

    assert_eq!(report["num_points"], mesh.num_nodes());
    assert_eq!(report["num_cells"], mesh.num_cells());
    let types = report["cell_types"].as_array().unwrap();
    assert!(
        types.len() == mesh.num_cells() && types.iter().all(|t| *t == VTK_HEXAHEDRON),
        "{types:?}"
    );
    assert_eq!(
        report["cell_arrays"],
        serde_json::json!({"volume": 1, "min_det_j": 1})
    );
    assert_eq!(
        report["point_arrays"],
        serde_json::json!({"displacement": 3})
    );
    let cells = report["cells"].as_array().unwrap();
    for (c, cell) in cells.iter().enumerate() {
        let seen: Vec<Vec<f64>> = cell.as_array().unwrap().iter().map(floats).collect();
        let ours = mesh.cell_coords(c);
        assert_eq!(seen.len(), 8);
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

/// A one-cell mesh whose hex has the corners `p` (in node order).
fn one_cell(p: [[f64; 3]; 8]) -> HexMesh {
    let mut mesh = HexMesh::structured_box([0.0; 3], [1.0; 3], [1, 1, 1]);
    let cell = mesh.cells[0];
    for (n, x) in cell.iter().zip(p) {
        mesh.nodes[*n] = x;
    }
    mesh
}

/// Gmsh's minDetJac of the single hex of `mesh`.
fn gmsh_min_det_j(mesh: &HexMesh) -> (f64, f64) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("one.msh");
    write_hex_msh(&path, mesh).unwrap();
    let h = &run_checker("check_msh.py", &path)["elements_3d"];
    (floats(&h["minDetJac"])[0], floats(&h["maxDetJac"])[0])
}

/// Where one set of Bézier coefficients is a loose bound, Gmsh subdivides
/// (as our `linear_is_valid` does), so its minDetJac is tighter than our
/// `det_j_bounds`: for a valid hex with a negative coefficient, Gmsh
/// reports a positive value; for a hex that is invalid inside although
/// all corners are positive, a negative one, as `invalid_cells` says.
#[test]
fn gmsh_refines_loose_bezier_bounds_like_hex_is_valid() {
    let valid = one_cell([
        [0.8, -0.8, -0.5],
        [1.2, 0.5, -0.2],
        [0.2, 1.6, -0.8],
        [-0.7, 1.3, -0.5],
        [-0.8, -0.5, 1.6],
        [0.5, -0.4, 1.1],
        [1.2, 0.2, 1.4],
        [0.0, 1.2, 0.6],
    ]);
    let (lo, hi) = det_j_bounds(&valid.cell_coords(0));
    let (g_lo, g_hi) = gmsh_min_det_j(&valid);
    eprintln!(
        "valid: ours/8 ({}, {}) gmsh ({g_lo}, {g_hi})",
        lo / 8.0,
        hi / 8.0
    );
    assert!(lo < 0.0 && g_lo > 0.0);
    assert!(invalid_cells(&valid.cells, &valid.nodes).is_empty());

    let invalid = one_cell([
        [-0.3, 0.6, 0.8],
        [0.8, -0.6, -0.2],
        [1.8, 1.5, 0.3],
        [0.9, 0.1, 0.3],
        [0.5, 0.2, 1.2],
        [1.7, -0.3, 0.3],
        [1.2, 0.3, 0.9],
        [0.9, 1.1, 0.2],
    ]);
    let (lo, hi) = det_j_bounds(&invalid.cell_coords(0));
    let (g_lo, g_hi) = gmsh_min_det_j(&invalid);
    eprintln!(
        "invalid: ours/8 ({}, {}) gmsh ({g_lo}, {g_hi})",
        lo / 8.0,
        hi / 8.0
    );
    assert!(
        g_lo < 0.0 && g_lo > lo / 8.0,
        "Gmsh's bound is the tighter one"
    );
    assert_eq!(invalid_cells(&invalid.cells, &invalid.nodes), vec![0]);
}

/// A whole 3D `run` (the quarter ball at 6³): Gmsh opens mesh.msh, finds
/// every hex and the sphere and plane groups, judges every hex valid, and
/// its extreme Jacobian determinants agree with report.json's (÷ 8).
#[test]
fn gmsh_agrees_with_the_report_of_a_3d_run() {
    use deformesh::app::case::{AnySetup, Case};
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/quarter_ball.toml");
    let mut case = Case::read(&path).unwrap();
    case.mesh.cells = vec![6, 6, 6];
    case.output.animation = false;
    case.output.frames.clear();
    let AnySetup::Hex(setup) = case.setup_any("quarter_ball", Path::new(".")).unwrap() else { panic!("3D case") };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let report = deformesh::app::driver::run_setup::<_, 3, 8>(setup, &out, |_| {}).unwrap();
    assert_eq!(report.invalid_cells, 0);
    let gmsh = run_checker("check_msh.py", &out.join("mesh.msh"));
    let types = gmsh["element_types"].as_object().unwrap();
    assert_eq!(types["5"]["count"], 216);
    assert_eq!(types["3"]["count"], 6 * 36);
    assert_eq!(gmsh["physical_names"]["2"], serde_json::json!(["planes", "sphere"]));
    let h = &gmsh["elements_3d"];
    let (min_dj, max_dj, min_sj) = (floats(&h["minDetJac"]), floats(&h["maxDetJac"]), floats(&h["minSJ"]));
    assert!(min_dj.iter().chain(&min_sj).all(|&v| v > 0.0), "Gmsh finds an invalid hex");
    let gmsh_min = min_dj.iter().copied().fold(f64::INFINITY, f64::min);
    let gmsh_max = max_dj.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (ours_min, ours_max) = (report.quality.det_j.min / 8.0, report.quality.det_j.max / 8.0);
    eprintln!("minDetJac: Gmsh {gmsh_min:e}, ours/8 {ours_min:e}; maxDetJac: Gmsh {gmsh_max:e}, ours/8 {ours_max:e}");
    assert!(rel(gmsh_min, ours_min) < 1e-3 && rel(gmsh_max, ours_max) < 1e-3, "Gmsh [{gmsh_min}, {gmsh_max}] vs ours/8 [{ours_min}, {ours_max}]");
    let vtk = run_checker("check_vtu.py", &out.join("mesh.vtu"));
    assert_eq!(vtk["num_cells"], 216);
    assert_eq!(vtk["cell_arrays"]["J/f"], 1);
}
