//! Helpers shared by the integration tests: running the real Gmsh and
//! VTK, and an independent quadrature.
//!
//! The Python interpreter is `$DEFORMESH_PYTHON`, else `.venv/bin/python` in
//! the crate; `scripts/test.sh` sets the latter up.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// The geometry file binding `wall` to the circle r = 0.5.
pub const WALL_CIRCLE: &str = include_str!("../data/circle_wall.geometry.toml");

/// The geometry file of the ball octant (`tests/data/ball_octant_hex.msh`).
pub const BALL_OCTANT: &str = include_str!("../data/ball_octant.geometry.toml");

/// The geometry file of Gmsh's three-block quarter disk
/// (tests/python/quarter_disk.py).
pub const QUARTER_DISK: &str = include_str!("../data/quarter_disk.geometry.toml");

/// The file `tests/data/<file>`.
pub fn data(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(file)
}

/// The Python with `gmsh` and `vtk`, or a panic saying how to get one.
pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("DEFORMESH_PYTHON") {
        let p = PathBuf::from(p);
        assert!(p.exists(), "DEFORMESH_PYTHON={} does not exist", p.display());
        return p;
    }
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python");
    assert!(
        venv.exists(),
        "no Python with gmsh and vtk: set DEFORMESH_PYTHON or run scripts/test.sh \
         (it creates {} and runs the tests)",
        venv.display()
    );
    venv
}

/// Runs `tests/python/<script> ARGS...`, asserts it succeeded, and
/// returns what it printed.
pub fn run_script<S: AsRef<std::ffi::OsStr>>(script: &str, args: &[S]) -> Vec<u8> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python").join(script);
    let out = Command::new(python()).arg(&script).args(args).output().expect("cannot start Python");
    assert!(out.status.success(), "{} failed: {}", script.display(), String::from_utf8_lossy(&out.stderr));
    out.stdout
}

/// Runs `tests/python/<script> <file>` and parses the JSON it prints.
pub fn run_checker(script: &str, file: &Path) -> Value {
    let out = run_script(script, &[file]);
    serde_json::from_slice(&out).unwrap_or_else(|e| panic!("bad JSON from {script}: {e}"))
}

/// The JSON array `v` as `f64`s.
pub fn floats(v: &Value) -> Vec<f64> {
    v.as_array().expect("array").iter().map(|x| x.as_f64().expect("number")).collect()
}

/// Our certificates per element, from the written file.
pub fn our_certificates<const D: usize>(file: &Path) -> Vec<deformesh::quality::certify::Certificate> {
    use deformesh::quality::certify::{Certifiers, CertifyOptions};
    let mesh = deformesh::mesh::CurvedMesh::<D>::read_msh(file).unwrap();
    // each element to the certifier's own 1e-7 (a whole mesh's run
    // brackets its elements to 1e-3, its extremes to 1e-7)
    let certifiers = Certifiers::new(&mesh.shapes(), mesh.p, mesh.spacing).unwrap();
    (0..mesh.cells.len()).map(|c| certifiers.of(mesh.cell_shape(c)).certify(&mesh.cell_coords(c), &CertifyOptions::default())).collect()
}

/// How Gmsh's figures compare with ours.
#[derive(Debug, Default)]
pub struct Agreement {
    /// Largest relative difference of minDetJac on elements whose det J
    /// varies less than 20× (min/max ≥ 0.05).
    pub shaped: f64,
    /// Largest difference relative to the element's max det J, on the
    /// nearly degenerate rest.
    pub degenerate: f64,
    /// Nearly degenerate elements (min/max < 0.05).
    pub degenerate_count: usize,
    /// Elements whose Gmsh minSJ is not positive (Gmsh bounds the scaled
    /// Jacobian from below; near a straight angle its bound goes under 0).
    pub sj_not_positive: usize,
}

/// The real Gmsh opens `file`, finds `count` elements of type `ty`, finds
/// every one valid by minDetJac, and its minDetJac agrees with ours.
pub fn gmsh_agrees<const D: usize>(file: &Path, ty: i64, count: usize) -> Agreement {
    gmsh_agrees_within::<D>(file, ty, count, 1.5e-3)
}

/// [`gmsh_agrees`], with Gmsh's minDetJac within `shaped` (relative) of
/// ours on elements that are not nearly degenerate. Gmsh's is a looser
/// lower bound than ours (never above a value det J takes, checked), the
/// more so on thin curved elements.
pub fn gmsh_agrees_within<const D: usize>(file: &Path, ty: i64, count: usize, shaped: f64) -> Agreement {
    let g = run_checker("check_msh.py", file);
    assert_eq!(g["element_types"][ty.to_string()]["count"].as_u64(), Some(count as u64), "{}", g["element_types"]);
    let block = if D == 2 { &g["elements_2d"] } else { &g["elements_3d"] };
    let gmin = floats(&block["minDetJac"]);
    let gsj = floats(&block["minSJ"]);
    let sampled = floats(&block["sampledSJ"]);
    let ours = our_certificates::<D>(file);
    assert_eq!(gmin.len(), ours.len());
    // Gmsh's reference cell is [−1,1]^d: its det J is ours / 2^d
    let scale = if D == 2 { 0.25 } else { 0.125 };
    let mut a = Agreement::default();
    for (k, (g, o)) in gmin.iter().zip(&ours).enumerate() {
        assert!(*g > 0.0, "Gmsh finds element {k} invalid: minDetJac {g}");
        let (lo, hi) = (scale * o.min_det_lower, scale * o.max_det);
        // both are lower bounds from Bézier coefficients; ours is refined
        // until it is within 1e-7 of a value det J takes. Round-off: at a
        // straight-angle corner det J is a difference of products the
        // size of max det J (measured: Gmsh's 2.5e-16 above an attained
        // 3.9e-10, the quarter disk's corner cell at p = 3)
        assert!(*g <= scale * o.min_det_upper * (1.0 + 1e-9) + 1e-12 * hi, "element {k}: Gmsh's bound {g} above an attained value {}", scale * o.min_det_upper);
        if lo / hi >= 0.05 {
            a.shaped = a.shaped.max((g - lo).abs() / lo);
            assert!(o.min_scaled_jacobian > 0.0);
        } else {
            a.degenerate_count += 1;
            a.degenerate = a.degenerate.max((g - lo).abs() / hi);
        }
        // Gmsh's own Jacobians of our element, on our sampling grid
        assert!((sampled[k] - o.min_scaled_jacobian).abs() < 1e-9, "element {k}: Gmsh's Jacobians give a scaled Jacobian of {} on the (3p + 1)^d points, ours {}", sampled[k], o.min_scaled_jacobian);
        if gsj[k] <= 0.0 {
            a.sj_not_positive += 1;
        }
    }
    assert!(a.shaped < shaped, "Gmsh's minDetJac and ours differ by {:e} relative", a.shaped);
    assert!(a.degenerate < 1e-3, "on nearly degenerate elements Gmsh's minDetJac and ours differ by {:e} of max det J", a.degenerate);
    a
}


/// The 5-point Gauss–Legendre rule on [0, 1]: (point, weight), exact to
/// degree 9 — not the 2-point rule `normalise` uses, so an integral with it
/// checks that sum rather than repeating it.
pub const GAUSS5: [(f64, f64); 5] = [
    (0.04691007703066802, 0.11846344252809464),
    (0.23076534494715845, 0.23931433524968315),
    (0.5, 0.28444444444444444),
    (0.7692346550528415, 0.23931433524968315),
    (0.9530899229693319, 0.11846344252809464),
];

/// Gmsh's library of the test Python's `gmsh` package (what `--cad`
/// loads), by `gmsh.libpath`.
pub fn gmsh_lib() -> PathBuf {
    let out = Command::new(python()).args(["-c", "import gmsh; print(gmsh.libpath)"]).output().expect("cannot start Python");
    assert!(out.status.success(), "the test Python has no gmsh: {}", String::from_utf8_lossy(&out.stderr));
    PathBuf::from(String::from_utf8(out.stdout).unwrap().trim())
}
