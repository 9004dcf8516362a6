//! Checks the simplex and prism elements and the reference-shape table with
//! the real programs: Gmsh 4.15 (its Python API: the local node coordinates
//! and the Lagrange basis of the triangle and tetrahedron types of order
//! 1..4 and the prisms of order 1, 2, the nodes of the prism it meshes
//! itself at order 1..4, and the edge and face tables of a model holding
//! one element of each shape) and VTK 9 (the parametric coordinates and
//! interpolation functions of `vtkLagrangeTriangle` / `vtkLagrangeTetra` /
//! `vtkLagrangeWedge`, the linear cells' points, edges and faces). One
//! Python run (`tests/python/simplex_orders.py`)
//! serves all checks; it also builds Warburton's warp & blend nodes its
//! own way (his `Nodes2D`) for the Gauss–Lobatto triangles.
//!
//! The Python interpreter is `$DEFORMESH_PYTHON`, else `.venv/bin/python` in
//! the crate; `scripts/test.sh` sets the latter up.

use std::sync::OnceLock;

use deformesh::mesh::element::prism::{self, gmsh_prism_order, vtk_wedge_order};
use deformesh::mesh::element::simplex::{gmsh_tet_order, gmsh_triangle_order, simplex_nodes, space, vtk_tet_order, vtk_triangle_order};
use deformesh::mesh::element::{HighOrderError, Shape, Spacing, MAX_ORDER};
use serde_json::{json, Value};

use crate::common::{floats, run_script};

/// Random reference points per simplex.
const POINTS: usize = 12;

/// A deterministic pseudo-random number in [0, 1).
fn rand01(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

/// Points of the unit `d`-simplex (rejection from the unit cube), unused
/// coordinates 0.
fn simplex_points(d: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut s = seed;
    let mut out = Vec::new();
    while out.len() < POINTS {
        let x: [f64; 3] = std::array::from_fn(|c| if c < d { rand01(&mut s) } else { 0.0 });
        if x.iter().sum::<f64>() <= 1.0 {
            out.push(x);
        }
    }
    out
}

/// Points of our reference pyramid: the collapsed cube's points (c < 1)
/// mapped into it.
fn pyramid_points(seed: u64) -> Vec<[f64; 3]> {
    let mut s = seed;
    (0..POINTS)
        .map(|_| {
            let [a, b, c]: [f64; 3] = std::array::from_fn(|_| rand01(&mut s));
            let c = 0.95 * c;
            [a * (1.0 - c) + 0.5 * c, b * (1.0 - c) + 0.5 * c, c]
        })
        .collect()
}

/// Points of the unit triangle × [0, 1].
fn prism_points(seed: u64) -> Vec<[f64; 3]> {
    let mut s = seed;
    simplex_points(2, seed).into_iter().map(|[x, y, _]| [x, y, rand01(&mut s)]).collect()
}

struct Fixture {
    /// Per simplex dimension 2, 3: the evaluation points.
    points: [Vec<[f64; 3]>; 2],
    /// The evaluation points of the prism.
    prism_points: Vec<[f64; 3]>,
    /// The evaluation points of the pyramid.
    pyramid_points: Vec<[f64; 3]>,
    report: Value,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let points = [simplex_points(2, 11), simplex_points(3, 12)];
        let prism_points = prism_points(13);
        let pyramid_points = pyramid_points(14);
        let request = json!({
            "points2": points[0].iter().map(|x| [x[0], x[1]]).collect::<Vec<_>>(),
            "points3": points[1],
            "points_prism": prism_points,
            "points_pyramid": pyramid_points,
        });
        let out = run_script("simplex_orders.py", &[request.to_string()]);
        let report = serde_json::from_slice(&out).unwrap_or_else(|e| panic!("bad JSON from simplex_orders.py: {e}"));
        Fixture { points, prism_points, pyramid_points, report }
    })
}

/// The simplices, their MSH types by order, our Gmsh and VTK orders, the
/// key of VTK's Lagrange cell in the report.
type Orders = fn(usize) -> Result<Vec<usize>, HighOrderError>;
const SIMPLICES: [(Shape, [i64; 4], Orders, Orders, &str); 2] = [
    (Shape::Triangle, [2, 9, 21, 23], gmsh_triangle_order, vtk_triangle_order, "triangle"),
    (Shape::Tetrahedron, [4, 11, 29, 30], gmsh_tet_order, vtk_tet_order, "tetra"),
];

/// Asserts `got` (a format's node `l`, `stride` numbers each) is at `want`.
fn assert_at(got: &[f64], l: usize, stride: usize, want: [f64; 3], what: &str) {
    for (c, w) in want.iter().enumerate().take(stride) {
        let g = got[stride * l + c];
        assert!((g - w).abs() < 1e-12, "{what}: local node {l} at {:?}, ours at {want:?}", &got[stride * l..stride * (l + 1)]);
    }
}

#[test]
fn our_gmsh_simplex_orders_put_every_node_where_gmsh_has_it() {
    let r = &fixture().report["gmsh"];
    for (shape, types, gmsh_order, _, _) in SIMPLICES {
        for p in 1..=MAX_ORDER {
            // Gmsh's reference triangle and tetrahedron are ours: no map
            let t = &r[types[p - 1].to_string()];
            assert_eq!((t["dim"].as_u64(), t["order"].as_u64()), (Some(shape.dim() as u64), Some(p as u64)));
            let nodes = floats(&t["nodes"]);
            assert_eq!(nodes.len(), shape.dim() * shape.num_nodes(p));
            let ours = simplex_nodes(shape, p, Spacing::Equispaced).unwrap();
            for (x, &l) in ours.iter().zip(&gmsh_order(p).unwrap()) {
                assert_at(&nodes, l, shape.dim(), *x, &format!("Gmsh type {}", types[p - 1]));
            }
        }
    }
}

#[test]
fn our_vtk_simplex_orders_put_every_node_where_vtk_has_it() {
    let r = &fixture().report["vtk"];
    for (shape, _, _, vtk_order, key) in SIMPLICES {
        for p in 1..=MAX_ORDER {
            let pc = floats(&r[key][p.to_string()]["pcoords"]);
            assert_eq!(pc.len(), 3 * shape.num_nodes(p), "VTK did not infer order {p} for its {key}");
            let ours = simplex_nodes(shape, p, Spacing::Equispaced).unwrap();
            for (x, &l) in ours.iter().zip(&vtk_order(p).unwrap()) {
                assert_at(&pc, l, 3, *x, &format!("VTK Lagrange {key} of order {p}"));
            }
        }
    }
}

/// Gmsh's `getBasisFunctions` and VTK's `InterpolateFunctions` /
/// `InterpolateDerivs` at random points are our equispaced basis, function
/// by function through the permutations: the orders and `eval` together.
#[test]
fn gmsh_and_vtk_lagrange_bases_are_ours() {
    let f = fixture();
    let mut worst = 0.0f64;
    for (d, (shape, types, gmsh_order, vtk_order, key)) in SIMPLICES.into_iter().enumerate() {
        for p in 1..=MAX_ORDER {
            let s = space(shape, p, Spacing::Equispaced).unwrap();
            let n = s.num_nodes();
            let g = &f.report["gmsh"][types[p - 1].to_string()];
            let (gv, gg) = (floats(&g["values"]), floats(&g["grads"]));
            let v = &f.report["vtk"][key][p.to_string()];
            let (gperm, vperm) = (gmsh_order(p).unwrap(), vtk_order(p).unwrap());
            let (mut val, mut grad) = (vec![0.0; n], vec![[0.0; 3]; n]);
            for (k, &xi) in f.points[d].iter().enumerate() {
                s.eval(xi, &mut val, &mut grad);
                let (vv, vd) = (floats(&v["values"][k]), floats(&v["derivs"][k]));
                for t in 0..n {
                    let (gl, vl) = (gperm[t], vperm[t]);
                    let mut diffs = vec![(gv[k * n + gl] - val[t]).abs(), (vv[vl] - val[t]).abs()];
                    for c in 0..shape.dim() {
                        diffs.push((gg[3 * (k * n + gl) + c] - grad[t][c]).abs());
                        diffs.push((vd[c * n + vl] - grad[t][c]).abs());
                    }
                    let err = diffs.into_iter().fold(0.0, f64::max);
                    assert!(err < 1e-11, "{shape:?} p={p} point {k} function {t}: off by {err:e}");
                    worst = worst.max(err);
                }
            }
        }
    }
    eprintln!("Gmsh's and VTK's Lagrange simplex bases and ours: largest difference {worst:.1e}");
}

/// The MSH types of the prism by order.
const PRISM_TYPES: [i64; 4] = [6, 13, 90, 91];

/// Asserts that Gmsh's local node `perm[t]` of a prism, at `gmsh[3 l..]`
/// in Gmsh's reference prism, is at our lattice node `t`, within `tol`.
fn assert_prism_nodes(gmsh: &[f64], perm: &[usize], p: usize, tol: f64, what: &str) {
    let ours = prism::prism_nodes(p, Spacing::Equispaced).unwrap();
    assert_eq!(gmsh.len(), 3 * ours.len(), "{what}");
    for (x, &l) in ours.iter().zip(perm) {
        let got = from_gmsh(Shape::Prism, std::array::from_fn(|c| gmsh[3 * l + c]));
        assert!((0..3).all(|c| (got[c] - x[c]).abs() < tol), "{what}: local node {l} at {got:?}, ours at {x:?}");
    }
}

/// Our Gmsh prism order puts every node where Gmsh does: where
/// `getElementProperties` lists them (types 6, 13; Gmsh 4.15 has no nodal
/// basis for 90, 91) and where Gmsh's own mesher puts them on a prism it
/// raises to order 1..4 (types 6, 13, 90, 91). Our VTK order puts every
/// node at `vtkLagrangeWedge`'s parametric coordinates (VTK's wedge is our
/// reference prism).
#[test]
fn our_prism_orders_put_every_node_where_gmsh_and_vtk_have_it() {
    let r = &fixture().report;
    for p in 1..=MAX_ORDER {
        let (gmsh, vtk) = (gmsh_prism_order(p).unwrap(), vtk_wedge_order(p).unwrap());
        let meshed = &r["gmsh_meshed"][p.to_string()];
        assert_eq!(meshed["type"].as_i64(), Some(PRISM_TYPES[p - 1]), "Gmsh meshed another type at order {p}");
        // the nodes come back through a 3 × 3 solve: exact to rounding
        assert_prism_nodes(&floats(&meshed["nodes"]), &gmsh, p, 1e-10, &format!("Gmsh's own order-{p} prism"));
        if p <= 2 {
            let t = &r["gmsh"][PRISM_TYPES[p - 1].to_string()];
            assert_eq!((t["dim"].as_u64(), t["order"].as_u64()), (Some(3), Some(p as u64)));
            assert_prism_nodes(&floats(&t["nodes"]), &gmsh, p, 1e-12, &format!("Gmsh type {}", PRISM_TYPES[p - 1]));
        }
        let pc = floats(&r["vtk"]["wedge"][p.to_string()]["pcoords"]);
        assert_eq!(pc.len(), 3 * Shape::Prism.num_nodes(p), "VTK did not infer order {p} for its wedge");
        for (x, &l) in prism::prism_nodes(p, Spacing::Equispaced).unwrap().iter().zip(&vtk) {
            assert_at(&pc, l, 3, *x, &format!("VTK Lagrange wedge of order {p}"));
        }
    }
}

/// VTK's `vtkLagrangeWedge` (p = 1..4) and Gmsh's prisms of order 1, 2
/// evaluate our equispaced prism basis at random points, function by
/// function through the permutations (Gmsh's z runs over [−1, 1]: its z
/// derivatives are half ours).
#[test]
fn gmsh_and_vtk_lagrange_prism_bases_are_ours() {
    let f = fixture();
    let mut worst = 0.0f64;
    for p in 1..=MAX_ORDER {
        let s = prism::space(p, Spacing::Equispaced).unwrap();
        let n = s.num_nodes();
        let v = &f.report["vtk"]["wedge"][p.to_string()];
        let g = &f.report["gmsh"][PRISM_TYPES[p - 1].to_string()];
        let (gv, gg) = if p <= 2 { (floats(&g["values"]), floats(&g["grads"])) } else { (vec![], vec![]) };
        let (gperm, vperm) = (gmsh_prism_order(p).unwrap(), vtk_wedge_order(p).unwrap());
        let (mut val, mut grad) = (vec![0.0; n], vec![[0.0; 3]; n]);
        for (k, &xi) in f.prism_points.iter().enumerate() {
            s.eval(xi, &mut val, &mut grad);
            let (vv, vd) = (floats(&v["values"][k]), floats(&v["derivs"][k]));
            for t in 0..n {
                let (gl, vl) = (gperm[t], vperm[t]);
                let mut diffs = vec![(vv[vl] - val[t]).abs()];
                diffs.extend((0..3).map(|c| (vd[c * n + vl] - grad[t][c]).abs()));
                if p <= 2 {
                    diffs.push((gv[k * n + gl] - val[t]).abs());
                    let scale = [1.0, 1.0, 0.5];
                    diffs.extend((0..3).map(|c| (gg[3 * (k * n + gl) + c] - scale[c] * grad[t][c]).abs()));
                }
                let err = diffs.into_iter().fold(0.0, f64::max);
                assert!(err < 1e-11, "prism p={p} point {k} function {t}: off by {err:e}");
                worst = worst.max(err);
            }
        }
    }
    eprintln!("Gmsh's and VTK's Lagrange prism bases and ours: largest difference {worst:.1e}");
}

/// Our Gmsh pyramid order puts every node where Gmsh's
/// `getElementProperties` lists it (types 7, 14, 118, 119), and Gmsh's
/// Lagrange pyramids (its `BergotBasis`) evaluate our equispaced pyramid
/// basis at random points, function by function through the permutation
/// (Gmsh's x and y run over [−1, 1]: its x and y derivatives are half
/// ours).
#[test]
fn gmsh_pyramids_are_ours_node_for_node_and_function_for_function() {
    use deformesh::mesh::element::pyramid;
    let f = fixture();
    let mut worst = 0.0f64;
    for (p, t) in [7, 14, 118, 119].into_iter().enumerate().map(|(i, t)| (i + 1, t)) {
        let g = &f.report["gmsh"][t.to_string()];
        assert_eq!((g["dim"].as_u64(), g["order"].as_u64()), (Some(3), Some(p as u64)));
        let perm = pyramid::gmsh_pyramid_order(p).unwrap();
        let nodes = floats(&g["nodes"]);
        let ours = pyramid::pyramid_nodes(p, Spacing::Equispaced).unwrap();
        assert_eq!(nodes.len(), 3 * ours.len());
        for (x, &l) in ours.iter().zip(&perm) {
            let got = from_gmsh(Shape::Pyramid, std::array::from_fn(|c| nodes[3 * l + c]));
            assert!((0..3).all(|c| (got[c] - x[c]).abs() < 1e-12), "Gmsh type {t}: local node {l} at {got:?}, ours at {x:?}");
        }
        let s = pyramid::space(p, Spacing::Equispaced).unwrap();
        let n = s.num_nodes();
        let (gv, gg) = (floats(&g["values"]), floats(&g["grads"]));
        let (mut val, mut grad) = (vec![0.0; n], vec![[0.0; 3]; n]);
        for (k, &xi) in f.pyramid_points.iter().enumerate() {
            s.eval(xi, &mut val, &mut grad);
            for a in 0..n {
                let l = perm[a];
                let mut diffs = vec![(gv[k * n + l] - val[a]).abs()];
                let scale = [0.5, 0.5, 1.0];
                diffs.extend((0..3).map(|c| (gg[3 * (k * n + l) + c] - scale[c] * grad[a][c]).abs()));
                let err = diffs.into_iter().fold(0.0, f64::max);
                assert!(err < 1e-10, "pyramid p={p} point {k} function {a}: off by {err:e}");
                worst = worst.max(err);
            }
        }
    }
    eprintln!("Gmsh's Lagrange pyramid bases and ours: largest difference {worst:.1e}");
}

/// Gmsh's reference coordinates of `shape` in ours (module docs of
/// `mesh::element::shape`).
fn from_gmsh(shape: Shape, x: [f64; 3]) -> [f64; 3] {
    let half = |v: f64| 0.5 * (v + 1.0);
    match shape {
        Shape::Triangle | Shape::Tetrahedron => x,
        Shape::Prism => [x[0], x[1], half(x[2])],
        Shape::Pyramid => [half(x[0]), half(x[1]), x[2]],
        _ => std::array::from_fn(|c| if c < shape.dim() { half(x[c]) } else { 0.0 }),
    }
}

/// VTK's parametric coordinates of a linear cell in ours: the pyramid's
/// apex is at (0,0,1) in VTK, at (½,½,1) in ours.
fn from_vtk(shape: Shape, x: [f64; 3]) -> [f64; 3] {
    match shape {
        Shape::Pyramid => [x[0] + 0.5 * x[2], x[1] + 0.5 * x[2], x[2]],
        _ => x,
    }
}

/// Every shape but the point, Gmsh's family name, VTK's linear class.
const SHAPES: [(Shape, &str, &str); 7] = [
    (Shape::Line, "Line", "vtkLine"),
    (Shape::Triangle, "Triangle", "vtkTriangle"),
    (Shape::Quadrilateral, "Quadrangle", "vtkQuad"),
    (Shape::Tetrahedron, "Tetrahedron", "vtkTetra"),
    (Shape::Hexahedron, "Hexahedron", "vtkHexahedron"),
    (Shape::Prism, "Prism", "vtkWedge"),
    (Shape::Pyramid, "Pyramid", "vtkPyramid"),
];

fn integers(v: &Value) -> Vec<usize> {
    v.as_array().expect("array").iter().map(|x| x.as_u64().expect("integer") as usize).collect()
}

/// A vertex loop started at its smallest vertex (same cycle, same
/// direction).
fn canonical(loop_: &[usize]) -> Vec<usize> {
    let start = (0..loop_.len()).min_by_key(|&k| loop_[k]).unwrap_or(0);
    (0..loop_.len()).map(|k| loop_[(start + k) % loop_.len()]).collect()
}

fn assert_vertices(shape: Shape, coords: &[f64], map: fn(Shape, [f64; 3]) -> [f64; 3], who: &str) {
    assert_eq!(coords.len(), 3 * shape.vertices().len(), "{who} {shape:?}");
    for (k, want) in shape.vertices().iter().enumerate() {
        let x = map(shape, std::array::from_fn(|c| coords[3 * k + c]));
        assert!((0..3).all(|c| (x[c] - want[c]).abs() < 1e-15), "{who} {shape:?} vertex {k}: {x:?}, ours {want:?}");
    }
}

/// Our vertices, edges (order and direction) and faces (order, loops)
/// are Gmsh's; our vertices are VTK's linear cells' points, its edges ours
/// as a set, its faces ours as oriented loops.
#[test]
fn reference_shapes_are_gmsh_and_vtk_cells() {
    let r = &fixture().report;
    for (shape, family, class) in SHAPES {
        let g = &r["gmsh_shapes"][family];
        assert_vertices(shape, &floats(&g["vertices"]), from_gmsh, "Gmsh");
        let edges: Vec<[usize; 2]> = integers(&g["edges"]).chunks(2).map(|e| [e[0], e[1]]).collect();
        assert_eq!(edges, shape.edges(), "Gmsh's {family} edges");
        let counts = g["num_nodes"].as_object().unwrap();
        assert!(counts.contains_key("1") && counts.contains_key("2"), "{family}: {counts:?}");
        for (p, count) in counts {
            assert_eq!(count.as_u64(), Some(shape.num_nodes(p.parse().unwrap()) as u64), "{family} of order {p}");
        }
        if shape.dim() >= 2 {
            let mut faces: Vec<Vec<usize>> = integers(&g["tri_faces"]).chunks(3).map(<[usize]>::to_vec).collect();
            faces.extend(integers(&g["quad_faces"]).chunks(4).map(<[usize]>::to_vec));
            let ours: Vec<Vec<usize>> = shape.faces().iter().map(|f| f.1.to_vec()).collect();
            assert_eq!(faces, ours, "Gmsh's {family} faces");
        }
        let v = &r["vtk_linear"][class];
        assert_vertices(shape, &floats(&v["pcoords"]), from_vtk, "VTK");
        // VTK gives a line no edges (nor a polygon faces)
        if shape.dim() >= 2 {
            let as_set = |e: &[usize]| [e[0].min(e[1]), e[0].max(e[1])];
            let mut vtk_edges: Vec<[usize; 2]> = v["edges"].as_array().unwrap().iter().map(|e| as_set(&integers(e))).collect();
            let mut our_edges: Vec<[usize; 2]> = shape.edges().iter().map(|e| as_set(e)).collect();
            vtk_edges.sort_unstable();
            our_edges.sort_unstable();
            assert_eq!(vtk_edges, our_edges, "VTK's {class} edges");
        }
        if shape.dim() == 3 {
            let mut vtk_faces: Vec<Vec<usize>> = v["faces"].as_array().unwrap().iter().map(|f| canonical(&integers(f))).collect();
            let mut our_faces: Vec<Vec<usize>> = shape.faces().iter().map(|f| canonical(f.1)).collect();
            vtk_faces.sort();
            our_faces.sort();
            assert_eq!(vtk_faces, our_faces, "VTK's {class} faces (outward loops)");
        }
    }
}

/// Our Gauss–Lobatto triangle nodes are the set of Hesthaven & Warburton's
/// `Nodes2D`, computed by the script in the equilateral triangle with
/// Legendre Vandermondes (our construction works in barycentric
/// coordinates with Lagrange interpolation: same formula, other route).
#[test]
fn gauss_lobatto_triangle_nodes_are_warburtons() {
    let r = &fixture().report["warburton"];
    for p in 1..=MAX_ORDER {
        let theirs: Vec<Vec<f64>> = r[p.to_string()].as_array().unwrap().iter().map(floats).collect();
        let ours = simplex_nodes(Shape::Triangle, p, Spacing::GaussLobatto).unwrap();
        assert_eq!(theirs.len(), ours.len());
        let mut used = vec![false; theirs.len()];
        for x in &ours {
            let k = (0..theirs.len())
                .filter(|&k| !used[k])
                .min_by(|&a, &b| dist(&theirs[a], x).total_cmp(&dist(&theirs[b], x)))
                .unwrap();
            assert!(dist(&theirs[k], x) < 1e-13, "p={p}: our node {x:?}, nearest of Warburton's {:?}", theirs[k]);
            used[k] = true;
        }
    }
}

fn dist(a: &[f64], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}
