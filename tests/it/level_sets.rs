//! `deformesh curve` with walls bound as level sets: the same curved mesh
//! as with the built-in shape of the same surface, since the level set's
//! Newton projection (exact gradient of the compiled expression) gives the
//! exact closest point on circles and spheres.

use deformesh::app::driver::{curve_file, CurveJob, OutputFormat};
use deformesh::highorder::curve::CurveOptions;
use deformesh::mesh::CurvedMesh;
use std::path::{Path, PathBuf};

fn data(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(file)
}

/// Curves `mesh` with `geometry` at order `p`; the output file.
fn curve(dir: &Path, name: &str, mesh: &str, geometry: &str, p: usize) -> PathBuf {
    let g = dir.join(format!("{name}.toml"));
    std::fs::write(&g, geometry).unwrap();
    let job = CurveJob {
        input: data(mesh),
        geometry: Some(g), cad: None,
        output: dir.join(format!("{name}.msh")),
        format: OutputFormat::Msh41,
        options: CurveOptions { order: p, ..Default::default() },
        width: 200,
        force: false,
    };
    curve_file(&job, |_| {}).unwrap_or_else(|e| panic!("{name}: {e}"));
    job.output
}

/// The largest coordinate difference of two curved meshes of the same
/// nodes and cells: over the nodes of the boundary elements of group
/// `wall`, and over all nodes.
fn largest_differences<const D: usize>(a: &CurvedMesh<D>, b: &CurvedMesh<D>, wall: &str) -> (f64, f64) {
    assert_eq!((a.nodes.len(), &a.cells), (b.nodes.len(), &b.cells));
    let diff = |n: usize| (0..D).map(|k| (a.nodes[n][k] - b.nodes[n][k]).abs()).fold(0.0, f64::max);
    let part = a.part_names.iter().position(|p| p == wall).expect("the wall group");
    let on_wall: Vec<usize> = a.boundary.iter().filter(|e| e.part == part).flat_map(|e| e.nodes.iter().copied()).collect();
    assert!(!on_wall.is_empty());
    (on_wall.iter().map(|&n| diff(n)).fold(0.0, f64::max), (0..a.nodes.len()).map(diff).fold(0.0, f64::max))
}

/// The wall's nodes are projections at their fitted places
/// (`geometry::fit`): they agree to the fit's precision along the wall,
/// whose least-squares objective is flat at its minimum (round-off in the
/// two projections moves them by up to 3.0e-10, measured at p = 3; the
/// error they leave is the same). The other
/// nodes come from the deformation's
/// iterative solve (CG to a relative residual of 1e-7), which turns
/// round-off differences on the wall into up to 1e-10 (measured, test
/// profile): they are held to the solver's level only.
fn assert_agree(what: &str, (wall, all): (f64, f64)) {
    assert!(wall < 1e-9, "{what}: wall nodes {wall:e}");
    assert!(all < 1e-8, "{what}: all nodes {all:e}");
}

#[test]
fn a_circle_as_a_level_set_curves_like_the_circle() {
    let dir = tempfile::tempdir().unwrap();
    let shape = "[[group]]\nname = \"wall\"\nkind = \"curve\"\nshape = { type = \"circle\", centre = [0.0, 0.0], radius = 0.5 }\n";
    let level = "[[group]]\nname = \"wall\"\nkind = \"curve\"\nlevel_set = \"x^2 + y^2 - 0.25\"\n";
    for p in [2, 3] {
        let a = CurvedMesh::<2>::read_msh(&curve(dir.path(), &format!("shape{p}"), "cylinder_bl_coarse.msh", shape, p)).unwrap();
        let b = CurvedMesh::<2>::read_msh(&curve(dir.path(), &format!("level{p}"), "cylinder_bl_coarse.msh", level, p)).unwrap();
        // with ∇φ by central differences the wall nodes differed by
        // 3.2e-10 at p = 2, 2.3e-10 at p = 3 (their error, through the
        // arc-length placement of the new nodes); 1.2e-14 with the exact
        // gradient
        assert_agree(&format!("p = {p}"), largest_differences(&a, &b, "wall"));
    }
}

#[test]
fn a_sphere_as_a_level_set_curves_like_the_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let planes = "[[group]]\nname = \"plane_x0\"\nkind = \"slip\"\n[[group]]\nname = \"plane_y0\"\nkind = \"slip\"\n[[group]]\nname = \"plane_z0\"\nkind = \"slip\"\n";
    let shape = format!("[[group]]\nname = \"sphere\"\nkind = \"curve\"\nshape = {{ type = \"sphere\", centre = [0.0, 0.0, 0.0], radius = 1.0 }}\n{planes}");
    let level = format!("[[group]]\nname = \"sphere\"\nkind = \"curve\"\nlevel_set = \"x^2 + y^2 + z^2 - 1\"\n{planes}");
    let a = CurvedMesh::<3>::read_msh(&curve(dir.path(), "shape", "ball_octant_hex.msh", &shape, 2)).unwrap();
    let b = CurvedMesh::<3>::read_msh(&curve(dir.path(), "level", "ball_octant_hex.msh", &level, 2)).unwrap();
    assert_agree("ball octant", largest_differences(&a, &b, "sphere"));
}
