//! MSH 2.2 ASCII against the real Gmsh: the same mesh saved by Gmsh as
//! MSH 4.1 and as MSH 2.2 reads the same and curves the same; a curved
//! mesh written as MSH 2.2 is read by Gmsh with every element valid.

use crate::common;

use deformesh::io::layout::Layout;
use deformesh::io::msh::{layout_text_22, parse_any, AnyMesh, Tagged};
use deformesh::mesh::element::{Shape, Spacing};
use deformesh::mesh::CurvedMesh;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::data;

use crate::common::WALL_CIRCLE as CYLINDER;

use crate::common::BALL_OCTANT as BALL;

/// `input` opened by Gmsh and saved as MSH 4.1 and as MSH 2.2 in `dir`.
fn twins(input: &Path, dir: &Path, stem: &str) -> (PathBuf, PathBuf) {
    let (v41, v22) = (dir.join(format!("{stem}41.msh")), dir.join(format!("{stem}22.msh")));
    common::run_script("resave_msh.py", &[input, &v41, &v22]);
    let head = std::fs::read_to_string(&v22).unwrap();
    assert!(head.starts_with("$MeshFormat\n2.2 0 8\n"), "Gmsh did not write MSH 2.2: {}", &head[..40]);
    (v41, v22)
}

fn read(file: &Path) -> Tagged {
    parse_any(&std::fs::read(file).unwrap(), true).unwrap_or_else(|e| panic!("{}: {e}", file.display()))
}

/// Cells, boundary elements and parts as node tags, nodes by tag: what
/// must agree whatever order the nodes come in.
fn by_tags(t: &Tagged) -> (Vec<(u64, [u64; 3])>, Vec<Vec<u64>>, Vec<(String, Vec<u64>)>) {
    let tag = |n: &usize| t.node_tags[*n];
    let (coords, cells, boundary): (Vec<[f64; 3]>, Vec<Vec<u64>>, Vec<(String, Vec<u64>)>) = match &t.mesh {
        AnyMesh::Plane(m) => (
            m.nodes.iter().map(|x| [x[0], x[1], 0.0]).collect(),
            m.cells.iter().map(|c| c.iter().map(tag).collect()).collect(),
            m.boundary.iter().map(|b| (m.part_names[b.part].clone(), b.nodes.iter().map(tag).collect())).collect(),
        ),
        AnyMesh::Solid(m) => (
            m.nodes.clone(),
            m.cells.iter().map(|c| c.iter().map(tag).collect()).collect(),
            m.boundary.iter().map(|b| (m.part_names[b.part].clone(), b.nodes.iter().map(tag).collect())).collect(),
        ),
    };
    let mut nodes: Vec<(u64, [u64; 3])> = t.node_tags.iter().zip(&coords).map(|(&n, x)| (n, x.map(f64::to_bits))).collect();
    nodes.sort_unstable();
    (nodes, cells, boundary)
}

/// Our reader gives the same mesh, tags and parts from both twins.
fn same_mesh(v41: &Path, v22: &Path) -> Tagged {
    let (a, b) = (read(v41), read(v22));
    let (na, ca, ba) = by_tags(&a);
    let (nb, cb, bb) = by_tags(&b);
    assert_eq!(na, nb, "nodes (tag, coordinate bits)");
    assert_eq!(ca, cb, "cells as node tags");
    assert_eq!(ba, bb, "boundary elements with their parts");
    assert_eq!(a.cell_tags, b.cell_tags);
    let parts = |t: &Tagged| match &t.mesh {
        AnyMesh::Plane(m) => m.part_names.clone(),
        AnyMesh::Solid(m) => m.part_names.clone(),
    };
    assert_eq!(parts(&a), parts(&b));
    // Gmsh writes the nodes in the same order in both: the meshes are equal
    assert!(a.mesh == b.mesh && a.node_tags == b.node_tags, "the meshes differ in node order");
    b
}

/// `deformesh curve INPUT --geometry geo.toml --order P -o out/STEM.msh`
/// in `dir`; the report.
fn curve(dir: &Path, input: &Path, geometry: &str, order: usize, stem: &str) -> Value {
    std::fs::write(dir.join("geo.toml"), geometry).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_deformesh"))
        .args(["curve"])
        .arg(input)
        .args(["--geometry", "geo.toml", "--order", &order.to_string(), "-o", &format!("out/{stem}.msh")])
        .current_dir(dir)
        .env_remove("RUST_LOG")
        .output()
        .expect("cannot start deformesh");
    assert_eq!(out.status.code(), Some(0), "curve {}: {}", input.display(), String::from_utf8_lossy(&out.stderr));
    let report = std::fs::read_to_string(dir.join(format!("out/{stem}.report.json"))).unwrap();
    serde_json::from_str(&report).expect("valid JSON")
}

/// Both twins curve to the same figures and the same curved mesh.
fn same_curving<const D: usize>(dir: &Path, v41: &Path, v22: &Path, geometry: &str, order: usize, group: &str) -> Value {
    let a = curve(dir, v41, geometry, order, &format!("a{order}"));
    let b = curve(dir, v22, geometry, order, &format!("b{order}"));
    let q = &b["quality"];
    // every figure, to round-off: the twins number their nodes differently
    // and the parallel solves need not sum in one order (measured on a
    // loaded machine: first_layer_change 1.2e-13 relative apart)
    for key in ["min_det_j", "min_det_j_attained", "scaled_jacobian", "invalid_elements", "boundary_node_distance", "boundary_sample_distance", "boundary_error", "first_layer_change"] {
        assert!(alike(&a["quality"][key], &q[key]), "quality.{key}: {} vs {}", a["quality"][key], q[key]);
    }
    assert!(alike(&a["quality"], q), "quality: {} vs {q}", a["quality"]);
    for key in ["cells", "unbound_groups", "reoriented_cells", "steps", "halved_steps", "algorithm2_runs"] {
        assert_eq!(a[key], b[key], "{key}");
    }
    assert_eq!(q["invalid_elements"].as_array().map(Vec::len), Some(0), "{q:#}");
    assert!(q["min_det_j"].as_f64().unwrap() > 0.0);
    assert!(q["boundary_error"][group]["samples"].as_f64().is_some(), "{q:#}");
    // the same curved mesh, its nodes under the same tags (their order in
    // the file follows the nodes' entities, which MSH 2.2 does not give)
    // to round-off: bit-equal in the runs measured alone, but in one run on
    // a loaded machine they were not (their quality figures still agreed
    // to every digit): the parallel solves need not sum in one order
    let ((pa, na, ca, ba), (pb, nb, cb, bb)) = (mesh::<D>(dir, "a", order), mesh::<D>(dir, "b", order));
    assert_eq!((pa, &ca, &ba), (pb, &cb, &bb), "the curved meshes' elements differ");
    assert_eq!(na.iter().map(|n| n.0).collect::<Vec<_>>(), nb.iter().map(|n| n.0).collect::<Vec<_>>(), "node tags");
    let worst = na.iter().zip(&nb).flat_map(|(x, y)| x.1.iter().zip(&y.1).map(|(a, b)| (a - b).abs())).fold(0.0, f64::max);
    eprintln!("twins p = {order}: curved nodes at most {worst:e} apart");
    assert!(worst <= 1e-12, "curved nodes {worst:e} apart");
    b
}

/// A curved mesh file as nodes by tag, cells and boundary elements (with
/// their parts) as node tags.
#[allow(clippy::type_complexity)]
/// Equal JSON, numbers to a relative 1e-9 (plus 1e-15 for round-off-size
/// figures such as boundary distances of 1e-16).
fn alike(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            (x - y).abs() <= 1e-9 * x.abs().max(y.abs()) + 1e-15
        }
        (Value::Array(x), Value::Array(y)) => x.len() == y.len() && x.iter().zip(y).all(|(u, v)| alike(u, v)),
        (Value::Object(x), Value::Object(y)) => x.len() == y.len() && x.iter().all(|(k, u)| y.get(k).is_some_and(|v| alike(u, v))),
        _ => a == b,
    }
}

/// The curved mesh `out/<stem><order>.msh` by tags.
fn mesh<const D: usize>(dir: &Path, stem: &str, order: usize) -> (usize, Vec<(u64, Vec<f64>)>, Vec<Vec<u64>>, Vec<(String, Vec<u64>)>) {
    curved_by_tags::<D>(&dir.join(format!("out/{stem}{order}.msh")))
}

fn curved_by_tags<const D: usize>(file: &Path) -> (usize, Vec<(u64, Vec<f64>)>, Vec<Vec<u64>>, Vec<(String, Vec<u64>)>) {
    let t = parse_any(&std::fs::read(file).unwrap(), false).unwrap();
    let m = CurvedMesh::<D>::read_msh(file).unwrap();
    let tag = |n: &usize| t.node_tags[*n];
    let mut nodes: Vec<(u64, Vec<f64>)> = t.node_tags.iter().zip(&m.nodes).map(|(&n, x)| (n, x.to_vec())).collect();
    nodes.sort_unstable_by_key(|n| n.0);
    let cells = m.cells.iter().map(|c| c.iter().map(tag).collect()).collect();
    let boundary = m.boundary.iter().map(|b| (m.part_names[b.part].clone(), b.nodes.iter().map(tag).collect())).collect();
    (m.p, nodes, cells, boundary)
}

#[test]
fn gmsh_twins_of_a_quad_mesh_read_and_curve_alike() {
    let dir = tempfile::tempdir().unwrap();
    let made = dir.path().join("cylinder.msh");
    common::run_script("cylinder_bl.py", &["0.01", "0.15", made.to_str().unwrap()]);
    let (v41, v22) = twins(&made, dir.path(), "cylinder");
    let t = same_mesh(&v41, &v22);
    let AnyMesh::Plane(m) = &t.mesh else { panic!("a plane mesh expected") };
    assert_eq!((m.p, m.shapes()), (1, vec![Shape::Quadrilateral]));
    assert_eq!(m.part_names, vec!["wall".to_string(), "farfield".to_string()]);
    for p in [2, 3] {
        let r = same_curving::<2>(dir.path(), &v41, &v22, CYLINDER, p, "wall");
        let q = &r["quality"];
        eprintln!(
            "cylinder, {} quads, p = {p}: min det J {:.4e}, scaled Jacobian min {:.4}, wall within {:.2e} (samples {:.2e}), both formats",
            m.cells.len(), q["min_det_j"].as_f64().unwrap(), q["scaled_jacobian"]["min"].as_f64().unwrap(), q["boundary_error"]["wall"]["nodes"].as_f64().unwrap_or(f64::NAN), q["boundary_error"]["wall"]["samples"].as_f64().unwrap()
        );
    }
}

#[test]
fn gmsh_twins_of_a_hex_mesh_read_and_curve_alike() {
    let dir = tempfile::tempdir().unwrap();
    let (v41, v22) = twins(&data("ball_octant_hex.msh"), dir.path(), "ball");
    let t = same_mesh(&v41, &v22);
    let AnyMesh::Solid(m) = &t.mesh else { panic!("a solid mesh expected") };
    assert_eq!((m.p, m.shapes()), (1, vec![Shape::Hexahedron]));
    assert_eq!(m.part_names.len(), 4, "{:?}", m.part_names);
    let r = same_curving::<3>(dir.path(), &v41, &v22, BALL, 2, "sphere");
    let q = &r["quality"];
    eprintln!(
        "ball octant, {} hexes, p = 2: min det J {:.4e}, scaled Jacobian min {:.4}, sphere samples within {:.2e}, both formats",
        m.cells.len(), q["min_det_j"].as_f64().unwrap(), q["scaled_jacobian"]["min"].as_f64().unwrap(), q["boundary_error"]["sphere"]["samples"].as_f64().unwrap()
    );
}

/// Gmsh opens `text` (MSH 2.2 of `layout`): same element counts and
/// groups as the layout, every cell valid by Gmsh's minDetJac; the least.
fn gmsh_reads(dir: &Path, name: &str, layout: &Layout, cell_type: i64, boundary_type: i64) -> f64 {
    let file = dir.join(name);
    std::fs::write(&file, layout_text_22(layout)).unwrap();
    let g = common::run_checker("check_msh22.py", &file);
    let count = |dim: usize| layout.elements.iter().filter(|e| e.shape.dim() == dim).count() as u64;
    let top = layout.elements.iter().map(|e| e.shape.dim()).max().unwrap();
    assert_eq!(g["num_nodes"].as_u64(), Some(layout.coords.len() as u64), "{name}");
    let types = g["element_types"].as_object().unwrap();
    assert_eq!(types.len(), 2, "{name}: {types:?}");
    assert_eq!(types[&cell_type.to_string()].as_u64(), Some(count(top)), "{name}");
    assert_eq!(types[&boundary_type.to_string()].as_u64(), Some(count(top - 1)), "{name}");
    let ours: Vec<Value> = layout
        .physical_names
        .iter()
        .map(|g| {
            let entities: Vec<i64> = layout.entities.iter().filter(|e| e.dim == g.dim && e.physicals.contains(&g.tag)).map(|e| e.tag).collect();
            let n = layout.elements.iter().filter(|e| e.shape.dim() == g.dim && entities.contains(&e.entity)).count();
            serde_json::json!([g.dim, g.tag, g.name, n])
        })
        .collect();
    assert_eq!(g["physical_groups"].as_array().unwrap(), &ours, "{name}");
    let cells = &g["cells"];
    assert_eq!(cells["dim"].as_u64(), Some(top as u64));
    let tags: Vec<u64> = cells["tags"].as_array().unwrap().iter().map(|t| t.as_u64().unwrap()).collect();
    let mut our_tags: Vec<u64> = layout.elements.iter().filter(|e| e.shape.dim() == top).map(|e| e.tag).collect();
    our_tags.sort_unstable();
    assert_eq!(tags, our_tags, "{name}: cell tags");
    let det = common::floats(&cells["minDetJac"]);
    assert_eq!(det.len(), our_tags.len());
    for (t, d) in tags.iter().zip(&det) {
        assert!(*d > 0.0, "{name}: Gmsh finds element {t} invalid (minDetJac {d})");
    }
    det.iter().copied().fold(f64::INFINITY, f64::min)
}

#[test]
fn gmsh_reads_our_msh22_with_every_element_valid() {
    let dir = tempfile::tempdir().unwrap();
    let bend2 = |[x, y]: [f64; 2]| [x + 0.1 * (2.0 * y).sin(), y + 0.15 * x * x];
    let bend3 = |[x, y, z]: [f64; 3]| [x + 0.1 * (2.0 * y).sin(), y + 0.1 * x * z, z - 0.1 * x * x];
    for p in [2, 3] {
        let quads = CurvedMesh::<2>::structured(p, Spacing::Equispaced, [4, 3], bend2).unwrap();
        let layout = Layout::generated(&quads);
        let least = gmsh_reads(dir.path(), &format!("quads{p}.msh"), &layout, [10, 36][p - 2], [8, 26][p - 2]);
        // and our reader reads back the mesh written
        assert_eq!(CurvedMesh::<2>::parse_msh(layout_text_22(&layout)).unwrap(), quads);
        // Gmsh's reference square is [-1, 1]²: its det J is ours / 4
        let ours = common::our_certificates::<2>(&dir.path().join(format!("quads{p}.msh")));
        let our_least = ours.iter().map(|c| c.min_det_lower).fold(f64::INFINITY, f64::min) / 4.0;
        assert!((least - our_least).abs() < 1e-3 * our_least, "p = {p}: Gmsh's least minDetJac {least}, ours {our_least}");
        eprintln!("{} quads, p = {p}: Gmsh reads MSH 2.2, least minDetJac {least:.5e} (ours {our_least:.5e})", quads.cells.len());

        let hexes = CurvedMesh::<3>::structured(p, Spacing::Equispaced, [2, 2, 2], bend3).unwrap();
        let layout = Layout::generated(&hexes);
        let least = gmsh_reads(dir.path(), &format!("hexes{p}.msh"), &layout, [12, 92][p - 2], [10, 36][p - 2]);
        assert_eq!(CurvedMesh::<3>::parse_msh(layout_text_22(&layout)).unwrap(), hexes);
        let ours = common::our_certificates::<3>(&dir.path().join(format!("hexes{p}.msh")));
        let our_least = ours.iter().map(|c| c.min_det_lower).fold(f64::INFINITY, f64::min) / 8.0;
        assert!((least - our_least).abs() < 1e-3 * our_least, "hex p = {p}: Gmsh's least minDetJac {least}, ours {our_least}");
        eprintln!("{} hexes, p = {p}: Gmsh reads MSH 2.2, least minDetJac {least:.5e} (ours {our_least:.5e})", hexes.cells.len());
    }
}

#[test]
fn gmsh_and_we_agree_on_an_entity_in_two_groups() {
    // Gmsh writes such an element once per group, renumbered; we read one
    // element in both groups, and Gmsh reads our copies as its own
    let dir = tempfile::tempdir().unwrap();
    let quads = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [3, 2], |x| x).unwrap();
    let mut layout = Layout::generated(&quads);
    let k = layout.physical_names.len() as i64;
    layout.physical_names.push(deformesh::io::layout::PhysicalName { dim: 1, tag: k + 1, name: "both".into() });
    for e in layout.entities.iter_mut().filter(|e| e.dim == 1 && e.tag <= 2) {
        e.physicals.push(k + 1);
    }
    let file = dir.path().join("two_groups.msh");
    std::fs::write(&file, layout_text_22(&layout)).unwrap();
    let g = common::run_checker("check_msh22.py", &file);
    let in_both = layout.elements.iter().filter(|e| e.shape.dim() == 1 && e.entity <= 2).count() as u64;
    let lines = layout.elements.iter().filter(|e| e.shape.dim() == 1).count() as u64;
    // Gmsh keeps every line it reads: the copies count twice for it
    assert_eq!(g["element_types"]["8"].as_u64(), Some(lines + in_both), "{g}");
    let both = g["physical_groups"].as_array().unwrap().iter().find(|x| x[2] == "both").expect("group `both`").clone();
    assert_eq!(both[3].as_u64(), Some(2 * in_both), "{g}");
    // Gmsh's own file of the same groups: resaved, read by us as one
    // element per line of the mesh, in both groups
    let (_, v22) = twins(&file, dir.path(), "resaved");
    let ours = CurvedMesh::<2>::read_msh(&v22).unwrap();
    assert_eq!(ours.cells.len(), quads.cells.len());
    let both_part = ours.part_names.iter().position(|n| n == "both").unwrap();
    // (Gmsh, reading ours, doubled the lines of the two curves, and writes
    // each of them once per group: four lines of one element, one for us)
    let text = std::fs::read_to_string(&v22).unwrap();
    let elements = &text[text.find("$Elements").unwrap()..text.find("$EndElements").unwrap()];
    let written = elements.lines().filter(|l| l.split(' ').nth(1) == Some("8")).count() as u64;
    assert_eq!(written, lines + 3 * in_both, "Gmsh's 2.2 lines");
    assert_eq!(ours.boundary.iter().filter(|b| b.part == both_part).count() as u64, in_both, "{:?}", ours.part_names);
    assert_eq!(ours.boundary.len() as u64, lines + in_both);
}
