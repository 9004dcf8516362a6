//! Algorithm 2 solved only in a band along the curved walls (issue 22):
//! the same certified figures as the solve on the whole mesh.

use crate::common::{self, data, BALL_OCTANT, WALL_CIRCLE};
use deformesh::app::driver::{curve_file, CurveJob, CurveReport};
use deformesh::highorder::curve::CurveOptions;
use std::path::{Path, PathBuf};

fn curve(dir: &Path, input: PathBuf, geometry: &str, order: usize, steps: Option<usize>, band: Option<f64>) -> CurveReport {
    let g = dir.join("geometry.toml");
    std::fs::write(&g, geometry).unwrap();
    let name = format!("p{order}_{}.msh", band.map_or("all".into(), |w| w.to_string()));
    let job = CurveJob { input, geometry: Some(g), cad: None, output: dir.join(name), format: deformesh::app::driver::OutputFormat::Msh41, options: CurveOptions { order, steps, band, ..Default::default() }, width: 300, force: false };
    curve_file(&job, |_| {}).unwrap_or_else(|e| panic!("p = {order}, band {band:?}: {e}"))
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs())
}

/// A band of `width` bend lengths against the whole mesh: both valid, the
/// band holding some nodes, min det J within `det_tol` and the boundary
/// errors within 1e-9 (relative).
fn agrees(name: &str, dir: &Path, (input, geometry): (PathBuf, &str), order: usize, steps: Option<usize>, width: f64, det_tol: f64) {
    let whole = curve(dir, input.clone(), geometry, order, steps, None);
    let band = curve(dir, input, geometry, order, steps, Some(width));
    let (w, b) = (&whole.quality, &band.quality);
    assert!(w.invalid_elements.is_empty() && b.invalid_elements.is_empty(), "{name}");
    assert_eq!((w.band.width, w.band.nodes), (None, w.band.all_nodes), "{name}");
    assert!(b.band.nodes < b.band.all_nodes && b.band.width.is_some() && b.band.widened == 0, "{name}: {:?}", b.band);
    assert!(band.solver.unknowns < whole.solver.unknowns, "{name}");
    let det = rel(w.min_det_j, b.min_det_j);
    assert!(det < det_tol, "{name}: min det J {:e} against {:e}", b.min_det_j, w.min_det_j);
    let bnd = rel(w.boundary_sample_distance, b.boundary_sample_distance);
    assert!(bnd < 1e-9, "{name}: boundary error {:e} against {:e}", b.boundary_sample_distance, w.boundary_sample_distance);
    eprintln!(
        "{name}: band {} of {} nodes ({} unknowns against {}), min det J {:.6e} / {:.6e} (rel {det:.1e}), scaled Jacobian {:.6} / {:.6}, boundary {:.3e} (rel {bnd:.1e}), algorithm 2 {:.2} / {:.2} s",
        b.band.nodes, b.band.all_nodes, band.solver.unknowns, whole.solver.unknowns, b.min_det_j, w.min_det_j, b.scaled_jacobian.min, w.scaled_jacobian.min, b.boundary_sample_distance, band.algorithm2_s, whole.algorithm2_s
    );
}

#[test]
#[ignore = "heavy (23 s on 2 cores): benches/heavy_tests.sh runs it"]
fn the_band_solve_agrees_with_the_whole_mesh_solve() {
    let dir = tempfile::tempdir().unwrap();
    let default = CurveOptions::default().band.unwrap();
    // measured: rel 3.8e-11 and 1.4e-9 (ball octant, two multigrids: both
    // runs are CG solves to a relative residual of 1e-7, which bounds how
    // far they can agree), 1.2e-9 – 2.1e-8 (cylinder layer)
    // (the default band holds every node of this small octant: 8 bend
    // lengths, the former default, hold part of it)
    agrees("ball octant p = 3", dir.path(), (data("ball_octant_hex.msh"), BALL_OCTANT), 3, Some(1), 8.0, 1e-7);
    agrees("cylinder 1e-3 layer p = 3", dir.path(), (data("cylinder_bl_coarse.msh"), WALL_CIRCLE), 3, None, default, 1e-6);
    // the 1e-4 sphere layer of curve_import.rs in a box of side 6 (in its
    // own box of side 2 the band holds every node), 1,836 hexes; steps
    // fixed: the step control's choice would take the two runs on
    // different paths (measured: 4 steps, one halved, on the whole mesh; 3
    // in the band; min det J 17 % apart). Measured 4.2e-7 (3.7e-5 with the
    // band of 8 bend lengths it had before)
    let sphere = dir.path().join("sphere_bl.msh");
    common::run_script("sphere_bl.py", &["1e-4", "3", sphere.to_str().unwrap(), "--box", "3"]);
    agrees("sphere 1e-4 layer p = 2", dir.path(), (sphere, include_str!("../data/sphere.geometry.toml")), 2, Some(4), default, 1e-6);
}

#[test]
#[ignore = "heavy (33 s on 2 cores): benches/heavy_tests.sh runs it"]
fn the_multigrid_keeps_its_iterations_on_thin_layers() {
    // the extruded cylinder family of the thin-layer issue, first layers
    // 1e-1 … 1e-5, through the multigrid alone: with line relaxation the
    // iterations per solve stay under 30 and within 2× of each other at
    // p = 2 and 3 (before it: 10 → 645 at p = 2, 13 → 863 at p = 3)
    let dir = tempfile::tempdir().unwrap();
    let geometry = include_str!("../data/extruded_cylinder.geometry.toml");
    for p in [2, 3] {
        let mut means = Vec::new();
        for first in [1e-1, 1e-2, 1e-3, 1e-4, 1e-5] {
            let input = dir.path().join(format!("extruded_{first}.msh"));
            common::run_script("cylinder_bl.py", &[first.to_string(), "0.3".into(), input.display().to_string(), "--far".into(), "0.8".into(), "--extrude".into()]);
            let g = dir.path().join("geometry.toml");
            std::fs::write(&g, geometry).unwrap();
            let flow = deformesh::deform::DeformOptions { solver: deformesh::deform::SolverChoice::Amg, ..Default::default() };
            let options = CurveOptions { order: p, flow, ..Default::default() };
            let job = CurveJob { input, geometry: Some(g), cad: None, output: dir.path().join(format!("p{p}_{first}.msh")), format: deformesh::app::driver::OutputFormat::Msh41, options, width: 300, force: false };
            let r = curve_file(&job, |_| {}).unwrap_or_else(|e| panic!("first layer {first} at p = {p}: {e}"));
            let s = &r.solver;
            assert!(r.quality.invalid_elements.is_empty() && s.solver.contains("AMG") && !s.solver.contains("Cholesky"), "first layer {first} at p = {p}: {}", s.solver);
            assert!(s.iterations_max < 30, "first layer {first} at p = {p}: {s:?}");
            eprintln!("first layer {first:e}, p = {p}: {} unknowns, CG iterations mean {:.1}, max {}, set-up {:.2} s, total {:.2} s", s.unknowns, s.iterations_mean, s.iterations_max, s.setup_s, r.total_s);
            means.push(s.iterations_mean);
        }
        let (lo, hi) = means.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &m| (lo.min(m), hi.max(m)));
        assert!(hi <= 2.0 * lo, "p = {p}: iterations per solve {means:?}");
    }
}

#[test]
fn the_report_gives_the_peak_memory_the_kernel_measured() {
    // the binary in a child of Python, whose getrusage(RUSAGE_CHILDREN)
    // is the kernel's peak resident set of that one child (in KiB)
    let dir = tempfile::tempdir().unwrap();
    let g = dir.path().join("geometry.toml");
    std::fs::write(&g, BALL_OCTANT).unwrap();
    let out = dir.path().join("curved.msh");
    let wrapper = "import resource, subprocess, sys\n\
                   subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL)\n\
                   print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024)";
    let ran = std::process::Command::new(common::python())
        .args(["-c", wrapper, env!("CARGO_BIN_EXE_deformesh"), "curve"])
        .arg(data("ball_octant_hex.msh"))
        .arg("--geometry")
        .arg(&g)
        .args(["--order", "2", "--steps", "1", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(ran.status.success(), "{}", String::from_utf8_lossy(&ran.stderr));
    let kernel: f64 = String::from_utf8_lossy(&ran.stdout).trim().parse().unwrap();
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path().join("curved.report.json")).unwrap()).unwrap();
    let ours = report["peak_memory_mib"].as_f64().expect("peak_memory_mib in report.json");
    // the report is written last; what follows it (writing the files
    // already in memory, freeing) adds no resident memory
    eprintln!("peak memory: report {ours:.1} MiB, kernel {kernel:.1} MiB");
    assert!(ours <= kernel + 0.01 && ours >= 0.98 * kernel, "report {ours} MiB, kernel {kernel} MiB");
}

/// `curve` of `input` with the snap tried first (`--snap auto`).
fn curve_snap_first(dir: &Path, input: PathBuf, geometry: &str, order: usize, name: &str) -> CurveReport {
    let g = dir.join(format!("{name}.geometry.toml"));
    std::fs::write(&g, geometry).unwrap();
    let job = CurveJob { input, geometry: Some(g), cad: None, output: dir.join(format!("{name}.msh")), format: deformesh::app::driver::OutputFormat::Msh41, options: CurveOptions { order, snap_first: true, ..Default::default() }, width: 300, force: false };
    curve_file(&job, |_| {}).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
#[ignore = "heavy (74 s on 2 cores): benches/heavy_tests.sh runs it"]
fn the_snap_is_kept_where_every_element_stays_valid_and_shaped() {
    // the ball octant's cells are not thin: putting the new sphere nodes
    // on the sphere, as Gmsh's setOrder does, keeps every element valid
    // and shaped, so Algorithm 2 does not run
    let dir = tempfile::tempdir().unwrap();
    let input = data("ball_octant_hex.msh");
    let r = curve_snap_first(dir.path(), input.clone(), BALL_OCTANT, 3, "snapped");
    let q = &r.quality;
    assert!(q.snap_first.tried && q.snap_first.kept && q.snap_first.refused.is_none(), "{:?}", q.snap_first);
    assert_eq!((r.algorithm2_runs, r.steps, r.solver.unknowns), (0, 0, 0));
    assert!(q.invalid_elements.is_empty());
    let out = dir.path().join("snapped.msh");
    // Gmsh reads it, and its own Jacobians agree with our certificates
    common::gmsh_agrees::<3>(&out, 92, 2680);
    // Gmsh's straight order-3 mesh of the same input: every node of ours
    // is one of its nodes, but for the new nodes of the sphere's facets,
    // which are on the sphere, and the nodes the blend moved inside the
    // elements that touch them (off the sphere)
    let s = common::run_script("straight_nodes.py", &[input.as_os_str(), out.as_os_str(), std::ffi::OsStr::new("3")]);
    let s: serde_json::Value = serde_json::from_slice(&s).unwrap();
    let moved: Vec<[f64; 3]> = s["moved"].as_array().unwrap().iter().map(|p| std::array::from_fn(|k| p[k].as_f64().unwrap())).collect();
    let on = |p: [f64; 3]| (deformesh::numeric::norm(p) - 1.0).abs() < 1e-12;
    let on_sphere = |nodes: &[[f64; 3]]| nodes.iter().filter(|&&p| on(p)).count();
    let ours = deformesh::mesh::CurvedMesh::<3>::read_msh(&out).unwrap();
    let linear = deformesh::io::msh::read_hex_msh(&input).unwrap();
    let new_on_sphere = on_sphere(&ours.nodes) - on_sphere(&linear.nodes);
    assert_eq!(moved.iter().filter(|&&p| on(p)).count(), new_on_sphere, "moved nodes on the sphere other than its new ones");
    let touching: std::collections::HashSet<usize> = ours.cells.iter().filter(|c| c.iter().any(|&n| on(ours.nodes[n]))).flatten().copied().collect();
    // (Gmsh's reading of a node differs from ours by an ulp at times)
    let mut inside: Vec<[f64; 3]> = touching.iter().map(|&n| ours.nodes[n]).collect();
    inside.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let is_inside = |p: [f64; 3]| {
        let from = inside.partition_point(|q| q[0] < p[0] - 1e-12);
        inside[from..].iter().take_while(|q| q[0] <= p[0] + 1e-12).any(|&q| deformesh::numeric::dist2(p, q) < 1e-24)
    };
    let blended = moved.iter().filter(|&&p| !on(p)).count();
    let outside: Vec<&[f64; 3]> = moved.iter().filter(|&&p| !on(p) && !is_inside(p)).collect();
    assert!(blended > 0 && outside.is_empty(), "{} nodes moved off the sphere outside the elements along it: {:?}", outside.len(), &outside[..outside.len().min(3)]);
    assert_eq!(s["nodes"].as_u64(), Some(ours.nodes.len() as u64));
    // against Algorithm 2 on the same mesh (measured: min scaled Jacobian
    // 0.1536 snapped, 0.1535 deformed; min det J 1.10e-5 against 9.93e-6;
    // boundary errors equal, the same fitted places)
    let deformed = curve(dir.path(), input, BALL_OCTANT, 3, None, Some(CurveOptions::default().band.unwrap()));
    let d = &deformed.quality;
    eprintln!(
        "ball octant p = 3: snapped in {:.2} s ({} nodes moved), min SJ {:.4}, min det J {:.3e}, boundary {:.2e}; Algorithm 2 in {:.2} s, min SJ {:.4}, min det J {:.3e}, boundary {:.2e}",
        r.total_s, format!("{new_on_sphere} + {blended} blended"), q.scaled_jacobian.min, q.min_det_j, q.boundary_sample_distance, deformed.total_s, d.scaled_jacobian.min, d.min_det_j, d.boundary_sample_distance
    );
    assert!(q.scaled_jacobian.min >= 0.99 * d.scaled_jacobian.min && q.min_det_j >= 0.9 * d.min_det_j);
    assert!(rel(q.boundary_sample_distance, d.boundary_sample_distance) < 1e-6);
}

#[test]
fn the_snap_blends_the_wall_into_a_layer_where_snapping_the_wall_alone_inverts_it() {
    // the extruded cylinder layer with first cells 1e-2 and wall edges
    // 0.15: the sagitta of a wall face passes the first cells' inner rows
    // of nodes at p = 3 (a third of 1e-2 up), so moving the wall nodes
    // alone inverts them, but it stays under the cell: blended into the
    // elements, as Gmsh's setOrder blends them (valid here too, judged by
    // Gmsh below), the snap is kept and Algorithm 2 does not run
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("layer.msh");
    let gmsh = common::run_script("cylinder_bl.py", &["1e-2".into(), "0.15".into(), input.display().to_string(), "--far".into(), "0.8".into(), "--extrude".into(), "--order".into(), "3".into()]);
    let gmsh: serde_json::Value = serde_json::from_slice(gmsh.split(|&b| b == b'\n').rfind(|l| l.starts_with(b"{")).unwrap()).unwrap();
    assert_eq!(gmsh["invalid"].as_u64(), Some(0), "Gmsh's setOrder on the same mesh: {gmsh}");
    let linear = deformesh::io::msh::read_hex_msh(&input).unwrap();
    let wall_edge = linear
        .cells
        .iter()
        .flat_map(|c| (0..4).map(move |k| (c[k], c[(k + 1) % 4])))
        .filter(|&(a, b)| [a, b].iter().all(|&n| (linear.nodes[n][0].hypot(linear.nodes[n][1]) - 0.5).abs() < 1e-9) && linear.nodes[a][2] == linear.nodes[b][2])
        .map(|(a, b)| deformesh::numeric::dist2(linear.nodes[a], linear.nodes[b]).sqrt())
        .fold(0.0, f64::max);
    let sagitta = 0.5 - (0.25 - wall_edge * wall_edge / 4.0).sqrt();
    assert!(sagitta > 1e-2 / 3.0 && sagitta < 0.75e-2, "wall edges {wall_edge}: sagitta {sagitta:e}");
    let geometry = include_str!("../data/extruded_cylinder.geometry.toml");
    let r = curve_snap_first(dir.path(), input.clone(), geometry, 3, "blend");
    let q = &r.quality;
    assert!(q.snap_first.kept && q.snap_first.refused.is_none(), "{:?}", q.snap_first);
    assert_eq!((r.algorithm2_runs, r.solver.unknowns), (0, 0));
    assert!(q.invalid_elements.is_empty() && q.boundary_node_distance < 1e-12);
    common::gmsh_agrees::<3>(&dir.path().join("blend.msh"), 92, q.elements);
    // against Algorithm 2 on the same mesh (measured: min scaled Jacobian
    // 0.575 blended, 0.575 deformed)
    let deformed = curve(dir.path(), input, geometry, 3, None, Some(CurveOptions::default().band.unwrap()));
    let d = &deformed.quality;
    eprintln!(
        "extruded 1e-2 layer p = 3, sagitta {sagitta:.2e}: snapped and blended in {:.2} s, min SJ {:.4}, boundary {:.2e}; Algorithm 2 in {:.2} s, min SJ {:.4}, boundary {:.2e}; Gmsh setOrder {gmsh}",
        r.total_s, q.scaled_jacobian.min, q.boundary_sample_distance, deformed.total_s, d.scaled_jacobian.min, d.boundary_sample_distance
    );
    assert!(q.scaled_jacobian.min >= 0.95 * d.scaled_jacobian.min);
    assert!(rel(q.boundary_sample_distance, d.boundary_sample_distance) < 1e-6);
}

#[test]
fn the_snap_is_refused_where_it_shears_a_thin_layer() {
    // the 2D cylinder layer (first cells 1e-3 of the wall's 0.26 edges):
    // the sagitta of a wall edge is larger than the first cell, so the
    // snap inverts the first row; Algorithm 2 runs on a patch around it
    // (issue 42), not on the whole mesh, and keeps it valid
    let dir = tempfile::tempdir().unwrap();
    let r = curve_snap_first(dir.path(), data("cylinder_bl_coarse.msh"), WALL_CIRCLE, 3, "thin");
    let q = &r.quality;
    let why = q.snap_first.refused.as_deref().unwrap_or_else(|| panic!("{:?}", q.snap_first));
    assert!(q.snap_first.tried && !q.snap_first.kept && why.contains("not certified valid") && why.contains("of the 12 elements it moves"), "{why}");
    assert_eq!(q.repair.won, "patch", "{:?}", q.repair);
    let patch = q.repair.candidates.iter().find(|c| c.min_scaled_jacobian.is_some()).expect("a valid patch");
    assert!(patch.elements < q.elements, "{:?}", q.repair);
    assert!(r.algorithm2_runs == 0 && r.steps >= 1 && q.invalid_elements.is_empty());
    common::gmsh_agrees::<2>(&dir.path().join("thin.msh"), 36, q.elements);
}
