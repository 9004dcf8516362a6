//! Nothing of the user's mesh lost: `curve` keeps every physical group
//! (name, dimension, tag), every entity with its groups and boundary, the
//! element tags on each entity, the input's node tags, and `$Periodic`
//! with the new nodes paired, as the real Gmsh reads them back
//! (tests/python/check_kept.py); what it cannot keep it refuses.

use crate::common;

use deformesh::app::driver::{curve_file, CurveJob, CurveReport, OutputFormat, RunError};
use deformesh::highorder::curve::CurveOptions;
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use crate::common::WALL_CIRCLE as CHANNEL;

const BOX: &str = r#"
[[group]]
name = "wall"
kind = "curve"
shape = { type = "cylinder", point = [0.0, 0.0, 0.0], axis = [0.0, 0.0, 1.0], radius = 0.5 }
[[group]]
name = "top"
kind = "slip"
[[group]]
name = "bottom"
kind = "slip"
"#;

/// Makes `kind` (channel or box) with tests/python/kept_meshes.py.
fn make(dir: &Path, kind: &str) -> PathBuf {
    let path = dir.join(format!("{kind}.msh"));
    common::run_script("kept_meshes.py", &[kind, path.to_str().unwrap()]);
    path
}

/// [`make`] of triangles or tetrahedra.
fn make_simplices(dir: &Path, kind: &str) -> PathBuf {
    let path = dir.join(format!("{kind}_simplices.msh"));
    common::run_script("kept_meshes.py", &[kind, path.to_str().unwrap(), "--simplices"]);
    path
}

fn curve(dir: &Path, input: &Path, geometry: &str, order: usize) -> Result<(CurveReport, PathBuf), RunError> {
    curve_to(dir, input, geometry, order, &format!("curved{order}.msh"), OutputFormat::Msh41)
}

fn curve_to(dir: &Path, input: &Path, geometry: &str, order: usize, out: &str, format: OutputFormat) -> Result<(CurveReport, PathBuf), RunError> {
    let g = dir.join("geometry.toml");
    std::fs::write(&g, geometry).unwrap();
    let output = dir.join(out);
    let job = CurveJob {
        input: input.to_path_buf(),
        geometry: Some(g), cad: None,
        output: output.clone(),
        format,
        options: CurveOptions { order, ..Default::default() },
        width: 300,
        force: false,
    };
    curve_file(&job, |_| {}).map(|r| (r, output))
}

/// `(dim, tag)` → (physicals, boundary, element tags) of every entity.
fn entities(v: &Value) -> Vec<(i64, i64, Value, Value, Value)> {
    v["entities"].as_array().unwrap().iter().map(|e| (e["dim"].as_i64().unwrap(), e["tag"].as_i64().unwrap(), e["physicals"].clone(), e["boundary"].clone(), e["elements"].clone())).collect()
}

fn node_set(e: &Value) -> BTreeSet<u64> {
    e["nodes"].as_array().unwrap().iter().map(|n| n.as_u64().unwrap()).collect()
}

/// Gmsh's view of the curved file against its view of the input.
fn assert_kept(input: &Value, output: &Value, order: usize, top_dim: i64) {
    assert_eq!(output["groups"], input["groups"], "physical groups: names, dimensions and tags");
    assert_eq!(entities(output), entities(input), "entities: tags, groups, boundaries and the element tags on each");
    for (a, b) in input["entities"].as_array().unwrap().iter().zip(output["entities"].as_array().unwrap()) {
        assert!(node_set(a).is_subset(&node_set(b)), "entity ({}, {}): the input's node tags stay on it", a["dim"], a["tag"]);
        // each linear MSH type raised to the order
        let raised = |t: i64| match t {
            15 => 15,
            1 => [1, 8, 26, 27][order - 1],
            2 => [2, 9, 21, 23][order - 1],
            3 => [3, 10, 36, 37][order - 1],
            4 => [4, 11, 29, 30][order - 1],
            5 => [5, 12, 92, 93][order - 1],
            _ => panic!("type {t} in the input"),
        };
        let want: Vec<i64> = a["types"].as_array().unwrap().iter().map(|t| raised(t.as_i64().unwrap())).collect();
        assert_eq!(b["types"], serde_json::json!(want), "entity ({}, {}): elements of order {order}", a["dim"], a["tag"]);
    }
    let links = |v: &Value| -> Vec<(i64, i64, i64)> {
        v["periodic"].as_array().unwrap().iter().map(|l| (l["dim"].as_i64().unwrap(), l["slave"].as_i64().unwrap(), l["master"].as_i64().unwrap())).collect()
    };
    assert_eq!(links(output), links(input), "periodic links");
    assert!(!links(output).is_empty());
    for l in output["periodic"].as_array().unwrap() {
        assert_eq!(l["unpaired_count"], 0, "every node of the slave's elements is paired: {l}");
        assert!(l["worst"].as_f64().unwrap() <= 1e-12, "pairs map by the affine transform: {l}");
    }
    let top = |v: &Value| v["entities"].as_array().unwrap().iter().filter(|e| e["dim"] == top_dim).map(|e| e["elements"].as_array().unwrap().len()).sum::<usize>();
    assert_eq!(output["elements"].as_u64().unwrap() as usize, top(input));
    assert_eq!(output["invalid"], 0, "Gmsh finds every element valid");
}

#[test]
fn a_periodic_channel_keeps_its_groups_entities_tags_and_pairs() {
    let dir = tempfile::tempdir().unwrap();
    let input = make(dir.path(), "channel");
    let before = common::run_checker("check_kept.py", &input);
    // the input as made: tags 2..7, a group of two curves, a point group
    let names: Vec<String> = before["groups"].as_array().unwrap().iter().map(|g| format!("{}:{}:{}", g[0], g[1], g[2].as_str().unwrap())).collect();
    assert_eq!(names, ["0:7:corner", "1:2:wall", "1:3:inlet", "1:4:outlet", "1:5:sides", "2:6:fluid"]);
    for p in [2, 3] {
        let (report, out) = curve(dir.path(), &input, CHANNEL, p).unwrap_or_else(|e| panic!("p = {p}: {e}"));
        assert!(report.quality.invalid_elements.is_empty());
        // inlet and outlet are not bound: their new nodes stay where they
        // were made, images of each other
        assert_eq!(report.periodic_snap, 0.0, "p = {p}");
        let after = common::run_checker("check_kept.py", &out);
        assert_kept(&before, &after, p, 2);
        let link = after["periodic"].as_array().unwrap().iter().find(|l| l["dim"] == 1).unwrap().clone();
        let old = before["periodic"].as_array().unwrap().iter().find(|l| l["dim"] == 1).unwrap()["pairs"].as_u64().unwrap();
        // the 8 inlet edges gain p − 1 pairs each
        assert_eq!(link["pairs"].as_u64().unwrap(), old + (old - 1) * (p as u64 - 1), "p = {p}: {link}");
    }
}

#[test]
fn a_periodic_hex_box_keeps_point_and_curve_groups_and_its_pairs() {
    let dir = tempfile::tempdir().unwrap();
    let input = make(dir.path(), "box");
    let before = common::run_checker("check_kept.py", &input);
    let groups = before["groups"].to_string();
    assert!(groups.contains(r#"[0,7,"corner"]"#) && groups.contains(r#"[1,10,"rim"]"#) && groups.contains(r#"[3,6,"fluid"]"#), "{groups}");
    for p in [2, 3] {
        let (report, out) = curve(dir.path(), &input, BOX, p).unwrap_or_else(|e| panic!("p = {p}: {e}"));
        // top and bottom slide: their new nodes agree with their images to
        // the solver's residual, and are then put exactly there
        assert!(report.periodic_snap < 1e-8, "p = {p}: moved {:e}", report.periodic_snap);
        let after = common::run_checker("check_kept.py", &out);
        assert_kept(&before, &after, p, 3);
        // the rim (the circle at z = 0, a curve group) is raised to order p
        // and lies on the cylinder
        let rim = after["entities"].as_array().unwrap().iter().find(|e| e["physicals"] == serde_json::json!([10])).unwrap().clone();
        let line_type = [1, 8, 26, 27][p - 1];
        assert_eq!(rim["types"], serde_json::json!([line_type]), "{rim}");
        assert!(report.quality.boundary_node_distance < 1e-12, "p = {p}: {}", report.quality.boundary_node_distance);
    }
}

/// The periodic channel and box of triangles and tetrahedra. The box's
/// top and bottom slide, and its tetrahedra are not symmetric across the
/// period, so the two sides' new nodes move differently: they are paired
/// by their places on the straight faces, each slave put at its master's
/// image, and the mesh certified again; Gmsh finds every pair an exact
/// image and every element valid.
#[test]
fn periodic_triangles_and_tetrahedra_keep_their_pairs() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, geometry, dim) in [("channel", CHANNEL, 2), ("box", BOX, 3)] {
        let input = make_simplices(dir.path(), kind);
        let before = common::run_checker("check_kept.py", &input);
        for p in [2, 3] {
            let (report, out) = curve(dir.path(), &input, geometry, p).unwrap_or_else(|e| panic!("{kind}, p = {p}: {e}"));
            assert!(report.quality.invalid_elements.is_empty());
            assert!(report.quality.boundary_node_distance < 1e-12, "{kind}, p = {p}: {}", report.quality.boundary_node_distance);
            // measured: the box's slaves moved up to 5.6e-3 (p = 2) and
            // 6.2e-3 (p = 3) onto their images; the channel's inlet and
            // outlet are not bound and stay as made, to rounding
            eprintln!("{kind}, p = {p}: slaves moved up to {:e}", report.periodic_snap);
            if dim == 3 {
                assert!(report.periodic_snap > 4e-3 && report.periodic_snap < 8e-3, "p = {p}: moved {:e}", report.periodic_snap);
            } else {
                assert!(report.periodic_snap < 1e-15, "p = {p}: moved {:e}", report.periodic_snap);
            }
            let after = common::run_checker("check_kept.py", &out);
            assert_kept(&before, &after, p, dim);
        }
        // Gauss–Lobatto nodes are written resampled to equispaced ones,
        // which lie off the wall by the interpolation error: the move of
        // the slaves is judged against that, not against the GLL nodes
        let output = dir.path().join("gll.msh");
        let g = dir.path().join("geometry.toml");
        let options = CurveOptions { order: 3, spacing: deformesh::highorder::Spacing::GaussLobatto, ..Default::default() };
        let job = CurveJob { input: input.clone(), geometry: Some(g), cad: None, output, format: OutputFormat::Msh41, options, width: 300, force: false };
        let report = curve_file(&job, |_| {}).unwrap_or_else(|e| panic!("{kind}, Gauss-Lobatto: {e}"));
        assert!(report.quality.invalid_elements.is_empty());
    }
}

/// A slave bound to a shape that is not its master's image: its new
/// nodes, put at the images, would leave the shape; refused, nothing
/// written.
#[test]
fn a_periodic_slave_bound_to_another_shape_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let input = make_simplices(dir.path(), "channel");
    // the outlet (x = 2, the slave) on a circle of radius 1e4 through its
    // ends, 5e-5 from the line at y = 0; the inlet not bound
    let geometry = format!(
        "{CHANNEL}\n[[group]]\nname = \"outlet\"\nkind = \"curve\"\nshape = {{ type = \"circle\", centre = [-9998.0, 0.0], radius = {} }}\n",
        (1e8f64 + 1.0).sqrt()
    );
    let Err(e) = curve(dir.path(), &input, &geometry, 3) else { panic!("curved, not refused") };
    let text = e.to_string();
    assert!(matches!(e, RunError::PeriodicOffShape { ref group, distance, .. } if group == "outlet" && distance > 1e-5 && distance < 6e-5), "{text}");
    assert!(text.contains("not images of each other") && text.contains("nothing was written") && text.contains("more is allowed"), "{text}");
    assert_eq!(e.exit_code(), 1);
    assert!(!dir.path().join("curved3.msh").exists());
}

#[test]
fn partitioned_and_high_order_inputs_are_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let input = make(dir.path(), "channel");
    let variants = dir.path().join("variants");
    std::fs::create_dir(&variants).unwrap();
    let script = r#"
import sys, gmsh
src, out = sys.argv[1], sys.argv[2]
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.open(src)
gmsh.model.mesh.partition(2)
gmsh.write(out + "/partitioned.msh")
gmsh.open(src)
gmsh.model.mesh.setOrder(2)
gmsh.write(out + "/order2.msh")
gmsh.finalize()
"#;
    let py = dir.path().join("variants.py");
    std::fs::write(&py, script).unwrap();
    let ran = std::process::Command::new(common::python()).arg(&py).arg(&input).arg(&variants).output().unwrap();
    assert!(ran.status.success(), "{}", String::from_utf8_lossy(&ran.stderr));
    for (file, needles) in [
        ("partitioned.msh", &["partitioned mesh: the file has $PartitionedEntities", "unpartition()"][..]),
        ("order2.msh", &["unsupported element type 8", "is a line of order 2", "setOrder(1)"][..]),
    ] {
        let e = curve(dir.path(), &variants.join(file), CHANNEL, 3).err().unwrap_or_else(|| panic!("{file} was curved"));
        assert_eq!(e.exit_code(), 1, "{file}: bad input");
        let text = e.to_string();
        for n in needles {
            assert!(text.contains(n), "{file}: `{n}` not in: {text}");
        }
        assert!(!dir.path().join("curved3.msh").exists(), "{file}: nothing written");
    }
}

#[test]
fn every_format_keeps_the_numbers_solvers_key_on() {
    let dir = tempfile::tempdir().unwrap();
    let channel = make(dir.path(), "channel");
    let groups = common::run_checker("check_kept.py", &channel)["groups"].clone();
    // MFEM: attributes are the physical tags (wall 2, inlet 3, outlet 4,
    // sides 5, fluid 6), not 1..5, in the .mesh file and in the VTU; the
    // area it integrates is the exact one to within the boundary error
    // times the wall's length
    let exact = 8.0 - std::f64::consts::PI * 0.25;
    let (report, mesh) = curve_to(dir.path(), &channel, CHANNEL, 3, "channel.mesh", OutputFormat::Mfem).unwrap();
    let m = common::run_checker("check_mfem.py", &mesh);
    assert_eq!((m["elements"].as_u64(), m["order"].as_u64()), (Some(report.cells as u64), Some(3)));
    assert_eq!(m["attribute_set"], serde_json::json!([6]));
    assert_eq!(m["bdr_attribute_set"], serde_json::json!([2, 3, 4, 5]));
    let area = m["volume"].as_f64().unwrap();
    let bound = std::f64::consts::PI * report.quality.boundary_sample_distance;
    assert!((area - exact).abs() <= bound, "area {area} vs {exact}: off by more than {bound:e}");
    let v = common::run_checker("check_mfem.py", &dir.path().join("channel.vtu"));
    assert_eq!(v["attribute_set"], serde_json::json!([6]), "the VTU's attribute array");
    assert!((v["volume"].as_f64().unwrap() - area).abs() < 1e-12);
    // MSH 2.2: Gmsh reads the same groups, every element valid
    let (_, msh22) = curve_to(dir.path(), &channel, CHANNEL, 3, "channel22.msh", OutputFormat::Msh22).unwrap();
    assert!(std::fs::read_to_string(&msh22).unwrap().starts_with("$MeshFormat\n2.2 0 8\n"));
    let g = common::run_checker("check_kept.py", &msh22);
    assert_eq!(g["groups"], groups);
    assert_eq!((g["elements"].as_u64(), g["invalid"].as_u64()), (Some(report.cells as u64), Some(0)));
    // ABAQUS for Trixi.jl: meshio reads the linear part; every group's name
    // is on some element side of the high-order block
    let (_, inp) = curve_to(dir.path(), &channel, CHANNEL, 3, "channel.inp", OutputFormat::Abaqus).unwrap();
    let a = common::run_checker("check_abaqus.py", &inp);
    assert_eq!(a["cells"]["quad"].as_u64(), Some(report.cells as u64));
    let text = std::fs::read_to_string(&inp).unwrap();
    let names: BTreeSet<&str> = text.lines().filter_map(|l| l.strip_prefix("** ")).flat_map(str::split_whitespace).collect();
    for n in ["wall", "inlet", "outlet", "sides"] {
        assert!(names.contains(n), "`{n}` names no side");
    }
    // 3D: the periodic box, for MFEM
    let boxed = make(dir.path(), "box");
    let (report, mesh) = curve_to(dir.path(), &boxed, BOX, 2, "box.mesh", OutputFormat::Mfem).unwrap();
    let m = common::run_checker("check_mfem.py", &mesh);
    assert_eq!(m["bdr_attribute_set"], serde_json::json!([2, 3, 4, 5, 8, 9]));
    assert_eq!(m["attribute_set"], serde_json::json!([6]));
    let volume = m["volume"].as_f64().unwrap();
    let bound = std::f64::consts::PI * report.quality.boundary_sample_distance;
    assert!((volume - exact).abs() <= bound, "volume {volume} vs {exact}: off by more than {bound:e}");
}
