//! CAD geometry through Gmsh's library (`--cad`): the shapes of a STEP
//! file answer as the exact shapes do, meshes made from a STEP are
//! curved onto it, and wrong pairings are refused.

use crate::common;

use deformesh::geometry::cad::{CadModel, CadShape};
use deformesh::geometry::ClosestPoint;

/// The cylinder r = 0.5 (0 ≤ z ≤ 1) and the sphere r = 0.3 at (2, 0, 0.5)
/// of tests/python/cad_primitives.py, read back from their STEP file.
fn primitives(dir: &std::path::Path) -> std::sync::Arc<CadModel> {
    let step = dir.join("primitives.step");
    common::run_script(
        "cad_primitives.py",
        &[std::ffi::OsStr::new("shapes"), step.as_os_str()],
    );
    CadModel::open(&step, Some(&common::gmsh_lib())).unwrap()
}

/// The square [-2, 2]² minus the disk r = 0.5 of tests/python/cad_primitives.py
/// in `dir`: its STEP file and its mesh.
fn disk(dir: &std::path::Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let (step, mesh) = (dir.join("disk.step"), dir.join("disk.msh"));
    common::run_script("cad_primitives.py", &[std::ffi::OsStr::new("disk"), step.as_os_str(), mesh.as_os_str()]);
    (step, mesh)
}

fn surface_of_type(model: &std::sync::Arc<CadModel>, ty: &str) -> CadShape {
    let tag = model
        .entities(2)
        .unwrap()
        .into_iter()
        .find(|&t| model.entity_type(2, t).unwrap() == ty)
        .unwrap_or_else(|| panic!("no {ty}"));
    model.shape(2, tag)
}

#[test]
fn step_surfaces_answer_as_the_exact_shapes() {
    let dir = tempfile::tempdir().unwrap();
    let model = primitives(dir.path());
    let cylinder = surface_of_type(&model, "Cylinder");
    let sphere = surface_of_type(&model, "Sphere");
    let mut worst = [0.0f64; 3];
    for k in 0..40 {
        let a = 0.37 * k as f64;
        let (r, z) = (0.3 + 0.02 * k as f64, 0.1 + 0.02 * k as f64);
        let p = [r * a.cos(), r * a.sin(), z];
        let q = ClosestPoint::<3>::closest_point(&cylinder, p);
        let exact = [0.5 * a.cos(), 0.5 * a.sin(), z];
        worst[0] = worst[0].max(deformesh::numeric::dist2(q, exact).sqrt());
        let n = ClosestPoint::<3>::normal(&cylinder, p);
        worst[1] = worst[1].max(1.0 - (n[0] * a.cos() + n[1] * a.sin()).abs());
        let s = [
            2.0 + r * a.cos(),
            0.0 + r * a.sin() * (0.5 * a).cos(),
            0.5 + r * a.sin() * (0.5 * a).sin(),
        ];
        let d = ClosestPoint::<3>::distance(&sphere, s);
        worst[2] = worst[2].max((d - (r - 0.3).abs()).abs());
    }
    assert!(model.failure().is_none(), "{:?}", model.failure());
    assert!(
        worst[0] < 1e-12 && worst[1] < 1e-12 && worst[2] < 1e-12,
        "closest point, normal, sphere distance: {worst:?}"
    );
}

use deformesh::app::driver::{
    curve_file, CadSource, CurveJob, CurveReport, OutputFormat, RunError,
};
use deformesh::highorder::curve::CurveOptions;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// tests/python/cad_models.py `kind` into `dir` (`args` more options):
/// the mesh, the model it is bound to (the STEP; for the wing the BREP
/// its meshing session wrote, see the script), and what the script
/// printed (Gmsh's own curving with `--peers`).
fn model(dir: &Path, kind: &str, args: &[&str]) -> (PathBuf, PathBuf, Option<Value>) {
    let mut all = vec![kind.to_string(), dir.display().to_string()];
    all.extend(args.iter().map(|s| s.to_string()));
    let out = common::run_script("cad_models.py", &all);
    let peers = (!out.is_empty()).then(|| {
        serde_json::from_slice(&out)
            .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out)))
    });
    let ext = if kind == "wing" && !args.contains(&"--renumber") {
        "brep"
    } else {
        "step"
    };
    (
        dir.join(format!("{kind}.msh")),
        dir.join(format!("{kind}.{ext}")),
        peers,
    )
}

/// `curve MESH --cad MODEL` at order p (a geometry file too if given).
fn curve_cad(
    dir: &Path,
    mesh: &Path,
    cad: Option<&Path>,
    geometry: Option<&str>,
    p: usize,
) -> Result<(CurveReport, PathBuf), RunError> {
    let geometry = geometry.map(|text| {
        let g = dir.join("geometry.toml");
        std::fs::write(&g, text).unwrap();
        g
    });
    let tag = if cad.is_some() { "cad" } else { "geometry" };
    let output = dir.join(format!(
        "{}_{tag}_p{p}.msh",
        mesh.file_stem().unwrap().to_string_lossy()
    ));
    let cad = cad.map(|m| CadSource {
        model: m.to_path_buf(),
        library: Some(common::gmsh_lib()),
        scale: 1.0,
    });
    let job = CurveJob {
        input: mesh.to_path_buf(),
        geometry,
        cad,
        output: output.clone(),
        format: OutputFormat::Msh41,
        options: CurveOptions {
            order: p,
            ..Default::default()
        },
        width: 300,
        force: false,
    };
    curve_file(&job, |_| {}).map(|r| (r, output))
}

/// tests/python/check_cad.py --by-geometry: the real Gmsh reads `step`
/// and `mesh` into two models and measures each boundary node against
/// the model's entity nearest to it (not by tag).
fn judged(step: &Path, mesh: &Path) -> Value {
    let out = common::run_script("check_cad.py", &[Path::new("--by-geometry"), step, mesh]);
    serde_json::from_slice(&out).unwrap()
}

/// The checks every curved CAD mesh must pass: the real Gmsh finds every
/// element valid, every node on the CAD entity it is classified on (the
/// curves where faces meet included) to 1e-10, our sampled boundary
/// error is Gmsh's measure of it, and within 2× of Gmsh's `setOrder` on
/// the same mesh (`peer`, its sampled distance). Returns Gmsh's figures.
fn on_its_cad(step: &Path, out: &Path, r: &CurveReport, peer: f64) -> Value {
    assert!(r.quality.invalid_elements.is_empty());
    let g = judged(step, out);
    assert_eq!(
        g["invalid"].as_u64(),
        Some(0),
        "Gmsh finds invalid elements: {g}"
    );
    assert!(g["min_det_jac"].as_f64().unwrap() > 0.0, "{g}");
    for dim in ["0", "1", "2"] {
        let d = g["node_distance"][dim].as_f64().unwrap_or(0.0);
        assert!(
            d <= 1e-10,
            "nodes of dimension {dim} are {d:e} off their CAD entity: {}",
            g["worst"][dim]
        );
    }
    let ours = r.quality.boundary_sample_distance;
    let boundary = (r.dimension - 1).to_string();
    let theirs = g["sample_distance"][&boundary].as_f64().unwrap();
    assert!(
        (ours - theirs).abs() <= 0.05 * theirs + 1e-14,
        "our sampled boundary error {ours:e}, Gmsh's measure of it {theirs:e}"
    );
    assert!(
        ours <= 2.0 * peer,
        "boundary error {ours:e} against Gmsh setOrder's {peer:e}"
    );
    g
}

/// Gmsh's `setOrder` figures from `--peers`.
fn setorder(peers: &Option<Value>) -> (u64, f64) {
    let s = &peers.as_ref().expect("--peers printed")["setorder"];
    (
        s["invalid"].as_u64().unwrap(),
        s["boundary_sample_distance"].as_f64().unwrap(),
    )
}

#[test]
fn a_naca_section_with_a_boundary_layer_is_curved_onto_its_step() {
    curved_at_p2_p3("naca2d", |_, _| {});
}

/// `kind` of cad_models.py curved with `--cad` at p = 2 and 3, each
/// judged by [`on_its_cad`] and then by `more` (Gmsh's figures, p).
fn curved_at_p2_p3(kind: &str, more: impl Fn(&Value, usize)) {
    let dir = tempfile::tempdir().unwrap();
    for p in [2, 3] {
        // meshed in the session that built the model, as the Gmsh
        // tutorials do: bound to the STEP by geometry, not by tag
        let (mesh, model_file, peers) =
            model(dir.path(), kind, &["--renumber", "--peers", &p.to_string()]);
        let (invalid, peer) = setorder(&peers);
        let (r, out) = curve_cad(dir.path(), &mesh, Some(&model_file), None, p)
            .unwrap_or_else(|e| panic!("p = {p}: {e}"));
        more(&on_its_cad(&model_file, &out, &r, peer), p);
        let cad = r.cad.as_ref().expect("the report names the model");
        // every entity of the mesh bound, its nodes on the model
        assert!(
            !cad.bound.is_empty()
                && cad
                    .bound
                    .iter()
                    .all(|b| !b.model.is_empty() && b.max_distance <= 1e-9),
            "{:?}",
            cad.bound
        );
        groups_kept(&mesh, &out);
        assert!(
            cad.model
                .ends_with(model_file.file_name().unwrap().to_str().unwrap())
                && cad.gmsh_version.starts_with("4."),
            "{cad:?}"
        );
        eprintln!("{kind} p = {p}: {} elements, min SJ {:.3}, boundary {:.3e} (Gmsh setOrder: {invalid} invalid, {peer:.3e}), {:.2} s", r.cells, r.quality.scaled_jacobian.min, r.quality.boundary_sample_distance, r.total_s);
    }
}

/// How many nodes Gmsh finds on the model's curves (entities of dimension 1).
fn nodes_on_curves(g: &Value) -> u64 {
    g["entities"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["dim"] == 1)
        .map(|e| e["nodes"].as_u64().unwrap())
        .sum()
}

#[test]
fn a_filleted_box_of_tetrahedra_is_curved_onto_its_faces_and_their_edges() {
    // nodes on the curves where the faces meet were judged
    curved_at_p2_p3("fillet_box", |g, _| {
        assert!(nodes_on_curves(g) > 0, "{}", g["entities"])
    });
}

#[test]
#[ignore = "heavy (80 s on 2 cores): benches/heavy_tests.sh runs it"]
fn an_extruded_naca_wing_of_hexahedra_is_curved_onto_its_step() {
    // the file saves no line elements (groups on surfaces only): the new
    // nodes along the wing's edges are put on their curves all the same
    curved_at_p2_p3("wing", |g, p| {
        assert!(
            nodes_on_curves(g) >= 40 * (p as u64 - 1),
            "{}",
            g["entities"]
        )
    });
}

/// The wing at the size (2,024 hexes) at p = 3: the nose element
/// spans the leading edge's changing curvature, where equal arc length
/// left 1.95e-4 against setOrder's 8.5e-5; the fitted places leave 1.4e-6
/// (measured, and Gmsh's measure of it agrees).
#[test]
#[ignore = "heavy (50 s on 2 cores): benches/heavy_tests.sh runs it"]
fn the_full_wing_at_p3_fits_its_nose_closer_than_gmsh() {
    let dir = tempfile::tempdir().unwrap();
    let (mesh, model_file, peers) = model(dir.path(), "wing", &["--size", "0.05", "--peers", "3"]);
    let (_, peer) = setorder(&peers);
    let (r, out) = curve_cad(dir.path(), &mesh, Some(&model_file), None, 3).unwrap();
    assert_eq!(r.cells, 2024);
    assert!(r.quality.settling.fitted, "{:?}", r.quality.settling);
    on_its_cad(&model_file, &out, &r, peer);
    let ours = r.quality.boundary_sample_distance;
    assert!(
        ours < 2e-6 && ours < peer / 40.0,
        "boundary error {ours:e}, Gmsh setOrder's {peer:e}"
    );
    eprintln!("wing 2,024 hexes p = 3: min SJ {:.3}, boundary {ours:.3e} (Gmsh setOrder {peer:.3e}), {:.2} s", r.quality.scaled_jacobian.min, r.total_s);
}

#[test]
fn a_step_circle_and_the_exact_circle_curve_a_mesh_alike() {
    let dir = tempfile::tempdir().unwrap();
    let (step, mesh) = disk(dir.path());
    // without physical groups the circle is entity 5: `curve5`
    let circle = "[[group]]\nname = \"curve5\"\nkind = \"curve\"\nshape = { type = \"circle\", centre = [0.0, 0.0], radius = 0.5 }\n";
    for p in [2, 3] {
        let (a, _) = curve_cad(dir.path(), &mesh, Some(&step), None, p).unwrap();
        let (b, _) = curve_cad(dir.path(), &mesh, None, Some(circle), p).unwrap();
        assert!(a.quality.invalid_elements.is_empty() && b.quality.invalid_elements.is_empty());
        let rel = |x: f64, y: f64| (x - y).abs() / y.abs();
        // the square's sides slip with CAD, stay without: the wall is the same
        assert!(
            rel(a.quality.min_det_j, b.quality.min_det_j) < 1e-9,
            "p = {p}: min det J {} against {}",
            a.quality.min_det_j,
            b.quality.min_det_j
        );
        assert!(
            rel(
                a.quality.boundary_sample_distance,
                b.quality.boundary_sample_distance
            ) < 1e-6,
            "p = {p}: {} against {}",
            a.quality.boundary_sample_distance,
            b.quality.boundary_sample_distance
        );
    }
    // a geometry file given with --cad overrides the groups it names: the
    // circle held fixed is no curved part, and a side of the square slips
    let held = "[[group]]\nname = \"curve5\"\nkind = \"fixed\"\n[[group]]\nname = \"curve1\"\nkind = \"slip\"\n";
    let (c, _) = curve_cad(dir.path(), &mesh, Some(&step), Some(held), 2).unwrap();
    assert!(
        c.quality.boundary_error.is_empty(),
        "{:?}",
        c.quality.boundary_error
    );
    let (a, _) = curve_cad(dir.path(), &mesh, Some(&step), None, 2).unwrap();
    assert_eq!(
        a.quality.boundary_error.keys().collect::<Vec<_>>(),
        ["curve 5"]
    );
}

/// The physical groups of the linear mesh `before` (dimension, tag, name,
/// element count) are those of the curved mesh `after`, read by Gmsh.
fn groups_kept(before: &Path, after: &Path) {
    let groups = |m: &Path| common::run_checker("check_msh22.py", m)["physical_groups"].clone();
    assert_eq!(
        groups(before),
        groups(after),
        "physical groups of {} and {}",
        before.display(),
        after.display()
    );
}

/// How much `a` and `b` (curved meshes of the same linear mesh) differ:
/// the largest difference of a node of elements matched by their corners.
fn twins_differ(a: &Path, b: &Path) -> f64 {
    let c: Value = serde_json::from_slice(&common::run_script(
        "mesh_twins.py",
        &[Path::new("compare"), a, b],
    ))
    .unwrap();
    assert_eq!(c["elements"], c["matched"], "{c}");
    c["max_difference"].as_f64().unwrap()
}

#[test]
fn a_mesh_from_meshio_as_msh22_curves_as_the_gmsh_file_does() {
    let dir = tempfile::tempdir().unwrap();
    let (mesh, step, _) = model(dir.path(), "fillet_box", &["--renumber"]);
    // meshio's ASCII MSH 2.2 of the mesh (mesh_twins.py msh22, with
    // `how`), and its curving
    let twin = |name: &str, how: Option<&str>| {
        let file = dir.path().join(name);
        let mut args = vec![Path::new("msh22"), &mesh, &file];
        args.extend(how.map(Path::new));
        common::run_script("mesh_twins.py", &args);
        let (r, out) = curve_cad(dir.path(), &file, Some(&step), None, 2).unwrap();
        (file, r, out)
    };
    let (a, out_a) = curve_cad(dir.path(), &mesh, Some(&step), None, 2).unwrap();
    let (m22, b, out_b) = twin("fillet_box_meshio22.msh", None);
    assert!(
        std::fs::read_to_string(&m22)
            .unwrap()
            .contains("$MeshFormat\n2.2 0 8")
            && !std::fs::read_to_string(&m22).unwrap().contains("$Entities")
    );
    assert!(a.quality.invalid_elements.is_empty() && b.quality.invalid_elements.is_empty());
    // measured 0: a foot is a function of its point alone, whatever
    // query came first (3.8e-11 before feet were settled on a grid)
    let d = twins_differ(&out_a, &out_b);
    assert!(d <= 1e-12, "the MSH 2.2 twin's nodes differ by {d:e}");
    // a mesher that merged the faces: one entity over all eight, bound
    // element by element
    let (_, c, out_c) = twin("fillet_box_one_entity.msh", Some("--one-entity"));
    let bound = &c.cad.as_ref().unwrap().bound;
    assert!(bound.len() == 1 && bound[0].model.len() == 8 && bound[0].model.values().sum::<usize>() == a.cad.as_ref().unwrap().bound.iter().map(|b| b.model.values().sum::<usize>()).sum::<usize>(), "{bound:?}");
    let d = twins_differ(&out_a, &out_c);
    assert!(d <= 1e-12, "the merged twin's nodes differ by {d:e}");
    // a tool that writes no tags at all: every element on entity 0, in no
    // group (attribute 1 in the VTU, as MFEM gives such an element)
    let (_, e, out_e) = twin("fillet_box_no_tags.msh", Some("--no-tags"));
    let bound = &e.cad.as_ref().unwrap().bound;
    assert!(bound.len() == 1 && bound[0].model.len() == 8, "{bound:?}");
    let d = twins_differ(&out_a, &out_e);
    assert!(d <= 1e-12, "the tagless twin's nodes differ by {d:e}");
    assert!(out_e.with_extension("vtu").exists(), "the tagless twin's VTU (attribute 0 was refused there)");
    let g = judged(&step, &out_b);
    assert_eq!(g["invalid"].as_u64(), Some(0), "{g}");
    assert!(
        g["node_distance"]["2"].as_f64().unwrap() <= 1e-10
            && g["node_distance"]["1"].as_f64().unwrap() <= 1e-10,
        "{g}"
    );
}

#[test]
fn a_mesh_in_millimetres_of_a_model_in_metres_is_refused_with_the_factor() {
    let dir = tempfile::tempdir().unwrap();
    let (mesh, step, _) = model(dir.path(), "naca2d", &["--renumber"]);
    let mm = dir.path().join("naca2d_mm.msh");
    common::run_script(
        "mesh_twins.py",
        &[Path::new("scaled"), &mesh, &mm, Path::new("1000")],
    );
    let e = curve_cad(dir.path(), &mm, Some(&step), None, 2)
        .err()
        .expect("refused")
        .to_string();
    assert!(
        e.contains("scaled by 1000") && e.contains("millimetres") && e.contains("--cad-scale 1000"),
        "{e}"
    );
    // the command line: exit 1 (bad input), the factor on stderr
    let cli = std::process::Command::new(env!("CARGO_BIN_EXE_deformesh"))
        .arg("curve")
        .arg(&mm)
        .arg("--cad")
        .arg(&step)
        .args(["--order", "2", "-o"])
        .arg(dir.path().join("naca2d_mm_cli.msh"))
        .env("DEFORMESH_GMSH_LIB", common::gmsh_lib())
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&cli.stderr);
    assert!(cli.status.code() == Some(1) && said.contains("--cad-scale 1000"), "{:?}: {said}", cli.status);
    assert!(
        std::fs::read_dir(dir.path()).unwrap().all(|f| !f.unwrap().file_name().to_string_lossy().contains("_cli")),
        "nothing written by the command line"
    );
    assert!(
        std::fs::read_dir(dir.path()).unwrap().all(|f| !f
            .unwrap()
            .file_name()
            .to_string_lossy()
            .contains("_cad_")),
        "nothing written"
    );
    // the advice works: the model read in millimetres curves the mesh as
    // the mesh in metres, a thousand times larger
    let (m, _) = curve_cad(dir.path(), &mesh, Some(&step), None, 2).unwrap();
    let output = dir.path().join("naca2d_mm_scaled.msh");
    let cad = Some(CadSource {
        model: step.clone(),
        library: Some(common::gmsh_lib()),
        scale: 1000.0,
    });
    let job = CurveJob {
        input: mm.clone(),
        geometry: None,
        cad,
        output,
        format: OutputFormat::Msh41,
        options: CurveOptions {
            order: 2,
            ..Default::default()
        },
        width: 300,
        force: false,
    };
    let r = curve_file(&job, |_| {}).unwrap();
    assert!(r.quality.invalid_elements.is_empty());
    assert_eq!(r.cad.as_ref().unwrap().scale, 1000.0);
    let rel = |x: f64, y: f64| (x - y).abs() / y.abs();
    assert!(
        rel(
            r.quality.boundary_sample_distance,
            1000.0 * m.quality.boundary_sample_distance
        ) < 1e-3,
        "{} against 1000 x {}",
        r.quality.boundary_sample_distance,
        m.quality.boundary_sample_distance
    );
    assert!(rel(r.quality.scaled_jacobian.min, m.quality.scaled_jacobian.min) < 1e-6);
}

#[test]
fn a_mesh_of_another_model_is_refused_naming_the_entity_and_the_distance() {
    let dir = tempfile::tempdir().unwrap();
    let (_, disk_mesh) = disk(dir.path());
    let (_, step, _) = model(dir.path(), "naca2d", &["--renumber"]);
    // the disk's mesh against the airfoil's model
    let e = curve_cad(dir.path(), &disk_mesh, Some(&step), None, 2)
        .err()
        .expect("refused")
        .to_string();
    assert!(
        e.contains("the mesh's curve ")
            && e.contains("is on no entity of the model")
            && e.contains("from the nearest of the model's curves (curve "),
        "{e}"
    );
    let d: f64 = e
        .split(" lies ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .expect("a distance");
    assert!(d > 1e-3, "{e}");
    assert!(
        std::fs::read_dir(dir.path()).unwrap().all(|f| !f
            .unwrap()
            .file_name()
            .to_string_lossy()
            .contains("_cad_")),
        "nothing written"
    );
}
