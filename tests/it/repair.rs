//! The repair in patches (issue 42): where the snap leaves a few elements
//! invalid or sheared, Algorithm 2 runs on a patch around them only, and
//! the result written is the best certified candidate. Meshes made as a
//! user makes them (tests/python/repair_models.py: OpenCASCADE, STEP
//! written and opened again, meshed there), judged by the real Gmsh.

use crate::common;
use deformesh::app::driver::{curve_file, CadSource, CurveJob, CurveReport, OutputFormat};
use deformesh::highorder::curve::CurveOptions;
use serde_json::Value;
use std::path::Path;

/// repair_models.py `kind` at `size` into `dir`, with Gmsh's setOrder and
/// FastCurving at order p judged; then `curve --cad` at p. Returns our
/// report, Gmsh's judgement of our file, and Gmsh's of its own.
fn curved(dir: &Path, kind: &str, size: &str, p: usize) -> (CurveReport, Value, Value) {
    curved_against(dir, kind, size, p, "setorder,fastcurving")
}

/// [`curved`] with Gmsh's `methods` (setorder, fastcurving, elastic),
/// and as `curve` runs by default: the snap first, then the optimiser.
fn curved_against(dir: &Path, kind: &str, size: &str, p: usize, methods: &str) -> (CurveReport, Value, Value) {
    curved_with(dir, (kind, size, p), methods, |_| {})
}

/// [`curved_against`] with the options changed by `edit`.
fn curved_with(dir: &Path, (kind, size, p): (&str, &str, usize), methods: &str, edit: impl Fn(&mut CurveOptions)) -> (CurveReport, Value, Value) {
    let out = common::run_script("repair_models.py", &[kind, &dir.display().to_string(), size, "--peers", &p.to_string(), "--methods", methods]);
    let peers: Value = serde_json::from_slice(&out).unwrap();
    let (mesh, step) = (dir.join(format!("{kind}.msh")), dir.join(format!("{kind}.step")));
    let output = dir.join(format!("{kind}_p{p}.msh"));
    let cad = Some(CadSource { model: step.clone(), library: Some(common::gmsh_lib()), scale: 1.0 });
    let mut options = CurveOptions { order: p, snap_first: true, optimise: true, ..Default::default() };
    edit(&mut options);
    let job = CurveJob { input: mesh, geometry: None, cad, output: output.clone(), format: OutputFormat::Msh41, options, width: 300, force: false };
    let r = curve_file(&job, |_| {}).unwrap_or_else(|e| panic!("{kind} p = {p}: {e}"));
    let judged: Value = serde_json::from_slice(&common::run_script("check_cad.py", &[&step, &output])).unwrap();
    (r, judged, peers)
}

/// The candidates of a report: (name, elements, invalid, least SJ).
fn candidates(r: &CurveReport) -> Vec<(String, usize, usize, Option<f64>)> {
    r.quality.repair.candidates.iter().map(|c| (c.name.clone(), c.elements, c.invalid, c.min_scaled_jacobian)).collect()
}

/// The OCC torus (R = 1, r = 0.3) at size 0.2, 2,271 tetrahedra, at
/// p = 3: the snap (as Gmsh's setOrder, and FastCurving, which keeps it)
/// leaves one tetrahedron inverted. A patch of two rings (141 elements,
/// 6 % of the mesh) repairs it: its boundary nodes on the snap's places
/// leave it inverted, sliding along the torus as Algorithm 2 does mends it.
#[test]
fn a_torus_whose_snap_inverts_one_tetrahedron_is_repaired_in_a_patch() {
    let dir = tempfile::tempdir().unwrap();
    let (r, judged, peers) = curved(dir.path(), "torus", "0.2", 3);
    assert_eq!(r.cells, 2271);
    let c = candidates(&r);
    // measured: snap 1 invalid; patch 1 invalid; patch (sliding) valid
    assert_eq!((c[0].0.as_str(), c[0].2), ("snap", 1), "{c:?}");
    assert_eq!(r.quality.repair.won, "patch", "{:?}", r.quality.repair);
    let won = c.iter().find(|c| c.3.is_some()).expect("a valid patch");
    assert!(won.0.starts_with("patch") && won.1 == 141 && (won.1 as f64) < 0.1 * r.cells as f64, "{c:?}");
    assert!(r.quality.invalid_elements.is_empty());
    // the real Gmsh agrees: every element valid, where its own curving of
    // the same mesh leaves one inverted
    assert_eq!(judged["invalid"].as_u64(), Some(0), "{judged}");
    assert!(judged["min_det_jac"].as_f64().unwrap() > 0.0, "{judged}");
    for m in ["setorder", "fastcurving"] {
        assert_eq!(peers[m]["invalid"].as_u64(), Some(1), "{m}: {peers}");
    }
    // every node on its entity, and the sampled boundary as Gmsh's
    let d = judged["node_distance"]["2"].as_f64().unwrap();
    assert!(d <= 1e-10, "nodes {d:e} off the torus");
    eprintln!("torus p = 3: {c:?}, {:.2} s; Gmsh min SJ {}", r.total_s, judged["min_sj"]);
}

/// The same torus with the steps given (`--steps 24`): a patch's runs
/// take them all, as the whole mesh's do (their budget is twice the
/// steps given, not a patch's 20, whose pace rule would end a run of 24
/// even steps at step 10, t = 0.42). Measured: the held patch ends its 24
/// steps with one element invalid, the sliding one valid.
#[test]
fn a_patch_takes_the_steps_the_user_gave() {
    let dir = tempfile::tempdir().unwrap();
    let (r, judged, _) = curved_with(dir.path(), ("torus", "0.2", 3), "setorder", |o| o.steps = Some(24));
    let ended: Vec<_> = r.quality.repair.candidates.iter().filter_map(|c| c.ended.clone()).collect();
    assert!(ended.is_empty(), "{ended:?}");
    let c = candidates(&r);
    assert_eq!(r.quality.repair.won, "patch", "{c:?}");
    assert!(c.iter().any(|c| c.0 == "patch (sliding)" && c.1 == 141 && c.3.is_some()), "{c:?}");
    assert_eq!(judged["invalid"].as_u64(), Some(0), "{judged}");
}

/// The box minus a ball (an OCC boolean) at size 0.3, 5,062 tetrahedra,
/// at p = 3: the snap is valid but shears one tetrahedron under 0.9 of
/// its straight scaled Jacobian. A patch of two rings (297 elements)
/// raises the mesh's least scaled Jacobian above the snap's; Gmsh's own
/// measure (minSJ) of our file is above its measure of its setOrder and
/// FastCurving files, which keep the snap (measured 0.39 against 0.25).
#[test]
fn a_ball_in_a_box_whose_snap_shears_a_tetrahedron_keeps_the_better_repair() {
    let dir = tempfile::tempdir().unwrap();
    let (r, judged, peers) = curved(dir.path(), "ballbox", "0.3", 3);
    assert_eq!(r.cells, 5062);
    let c = candidates(&r);
    let snap = c[0].3.expect("the snap is valid");
    assert_eq!(r.quality.repair.won, "patch", "{:?}", r.quality.repair);
    let patch = c.iter().find(|c| c.0 == "patch").expect("a patch");
    assert!(patch.1 < r.cells / 10, "{c:?}");
    // measured: the snap's least 0.2363, the written mesh's 0.2738
    let least = r.quality.scaled_jacobian.min;
    assert!(least > 1.1 * snap, "least scaled Jacobian {least} against the snap's {snap}");
    assert_eq!(judged["invalid"].as_u64(), Some(0), "{judged}");
    let ours = judged["min_sj"].as_f64().unwrap();
    for m in ["setorder", "fastcurving"] {
        let theirs = peers[m]["min_sj"].as_f64().unwrap();
        assert!(ours > 1.3 * theirs, "Gmsh's minSJ of ours {ours}, of its {m} {theirs}");
    }
    eprintln!("ball in a box p = 3: {c:?}, {:.2} s; Gmsh min SJ ours {ours}, setOrder {}", r.total_s, peers["setorder"]["min_sj"]);
}

/// The issue's tet ball (the box [-1.5, 1.5]³ minus the ball r = 0.5,
/// 6,433 tetrahedra, `tests/data/tet_ball_stall.msh`) at p = 2: the snap
/// leaves one sliver with all four vertices and two faces on the sphere
/// inverted (as every Gmsh mode does). Algorithm 2 on the whole mesh used
/// to run without end; now the patches' runs stall at the same pseudo-time
/// for two sizes and the run ends: exit 3, the element by its tag in the
/// file, every run's reason, nothing written.
#[test]
fn the_issue_tet_ball_at_p2_ends_with_its_reason_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_deformesh"))
        .args(["curve", common::data("tet_ball_stall.msh").to_str().unwrap(), "--geometry", common::data("tet_ball_stall.geometry.toml").to_str().unwrap(), "--order", "2", "-o"])
        .arg(dir.path().join("out/ball.msh"))
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    // the sliver is the file's element 7701 (0-based cell 6106)
    assert!(stderr.contains("no result certified valid for 1 element(s), by their tags in the file [7701]"), "{stderr}");
    // (the pace of the first 10 steps, t = 0.1796 for the sliding runs of
    // both patches, would not reach t = 1 in the 20 steps of a patch's
    // budget: before the pace rule they went on to stall at t = 0.2099)
    assert!(stderr.contains("a patch (sliding) of 4 rings (1512 elements): ended: the run stalled at t = 0.1796 after 10 steps") && stderr.contains("the larger patch stalled as the smaller did"), "{stderr}");
    let written: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(written.is_empty() || std::fs::read_dir(dir.path().join("out")).unwrap().next().is_none(), "files were written");
}

/// The ball in a box at p = 2, as `curve` runs by default: the snap, a
/// patch, then the optimiser of the inner nodes. Its least distortion is
/// Gmsh's own `minSJ` of our file (the same Bernstein coefficients,
/// computed by Gmsh), and it is above what Gmsh's HighOrderElastic leaves
/// on the same mesh and CAD (measured: ours 0.8017, Elastic 0.6486,
/// setOrder and FastCurving 0.4774, the snap's figure before the search).
#[test]
fn a_ball_in_a_box_at_p2_is_less_distorted_than_gmsh_elastic_leaves_it() {
    let dir = tempfile::tempdir().unwrap();
    let (r, judged, peers) = curved_against(dir.path(), "ballbox", "0.3", 2, "setorder,fastcurving,elastic");
    let o = r.quality.repair.optimised.as_ref().expect("the optimiser moved nodes");
    assert_eq!(judged["invalid"].as_u64(), Some(0), "{judged}");
    let ours = judged["min_sj"].as_f64().unwrap();
    assert!((ours - o.least_distortion).abs() <= 1e-9, "Gmsh's minSJ {ours}, ours {o:?}");
    let setorder = peers["setorder"]["min_sj"].as_f64().unwrap();
    // before the search, ours is setOrder's (the snap's nodes are Gmsh's
    // projections to 1e-8 of the element: measured 2.3e-9 apart)
    assert!((setorder - o.least_distortion_before).abs() <= 1e-6, "setOrder {setorder}, {o:?}");
    let elastic = peers["elastic"]["min_sj"].as_f64().unwrap();
    assert_eq!(peers["elastic"]["invalid"].as_u64(), Some(0), "{peers}");
    assert!(ours > 1.2 * elastic && ours > 0.78, "ours {ours}, Elastic {elastic}");
    // a few inner nodes (that no vertex and no node of a boundary element
    // moves is the unit test's: highorder::optimise)
    assert!(o.nodes_moved > 0 && o.elements_changed < r.cells / 10, "{o:?}");
    eprintln!("ball in a box p = 2: Gmsh's minSJ ours {ours}, Elastic {elastic}, setOrder {setorder}; {o:?}");
}

/// The OCC torus at size 0.2 (2,271 tetrahedra) at p = 2: its fitted
/// places shear one sliver from 0.170 to 0.001 (scaled Jacobian), where
/// Gmsh's places leave Gmsh's minSJ at 0.0098. Only that sliver's nodes
/// then go to equal arc length, the rest keep the fit: Gmsh's minSJ of
/// our file is at least 0.95 of the best of Gmsh's three modes (measured
/// 0.00982 against 0.0098; 0.0068 when the fitted places stood).
#[test]
fn a_coarse_torus_at_p2_is_at_least_as_well_shaped_as_gmsh_leaves_it() {
    let dir = tempfile::tempdir().unwrap();
    let (r, judged, peers) = curved_against(dir.path(), "torus", "0.2", 2, "setorder,fastcurving,elastic");
    assert_eq!(r.cells, 2271);
    assert_eq!(judged["invalid"].as_u64(), Some(0), "{judged}");
    let ours = judged["min_sj"].as_f64().unwrap();
    let best = ["setorder", "fastcurving", "elastic"].iter().filter(|m| peers[**m]["invalid"].as_u64() == Some(0)).map(|m| peers[*m]["min_sj"].as_f64().unwrap()).fold(f64::NEG_INFINITY, f64::max);
    assert!(best > 0.0, "{peers}");
    assert!(ours >= 0.95 * best, "Gmsh's minSJ: ours {ours}, Gmsh's best {best}; {peers}");
    // the snap's second try kept the fit but at the sheared element
    assert!(r.quality.snap_first.refused.as_deref().is_some_and(|w| w.contains("equal arc length at the sheared")), "{:?}", r.quality.snap_first);
    eprintln!("coarse torus p = 2: Gmsh's minSJ ours {ours}, Gmsh's best {best}");
}
