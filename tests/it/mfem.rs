//! Checks the MFEM mesh writer (`io::mfem`) and the VTU attribute array
//! with the real MFEM 4.10 (PyMFEM, `tests/python/check_mfem.py`): MFEM
//! loads our files, and for every element its own transformation gives
//! the map x(ξ) and det J ours gives at fixed reference points, so every
//! vertex, edge, face and interior DOF must be where MFEM looks for it.
//! The meshes are renumbered at random (nodes, cell order, and each cell
//! turned by a random rotation of its reference cell) so that edges and
//! faces meet in every orientation. Attributes differ per cell and per
//! boundary part so that a reordering shows. Areas and volumes are
//! compared with ours (an independent Gauss rule on our own map) and with
//! the exact ones.
//!
//! The Python interpreter is `$DEFORMESH_PYTHON`, else `.venv/bin/python` in
//! the crate; `scripts/test.sh` sets the latter up.

use std::f64::consts::PI;
use std::path::Path;

use deformesh::highorder::{hex_map, quad_map, Spacing};
use deformesh::io::mfem::write_mfem;
use deformesh::mesh::CurvedMesh;
use serde_json::Value;

use crate::common::{floats, run_checker, GAUSS5};

/// A deterministic pseudo-random number in [0, 1).
fn rand01(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

/// A random index in `0..n`.
fn rand_below(seed: &mut u64, n: usize) -> usize {
    ((rand01(seed) * n as f64) as usize).min(n - 1)
}

/// Fisher–Yates.
fn shuffle<T>(items: &mut [T], seed: &mut u64) {
    for i in (1..items.len()).rev() {
        items.swap(i, rand_below(seed, i + 1));
    }
}

/// The quarter annulus 1 ≤ r ≤ 2, 0 ≤ θ ≤ π/2 (x → r, y → θ: det J > 0).
fn annulus([x, y]: [f64; 2]) -> [f64; 2] {
    let (r, t) = (1.0 + x, 0.5 * PI * y);
    [r * t.cos(), r * t.sin()]
}

/// Its area, (2² − 1²) π / 4.
const ANNULUS_AREA: f64 = 0.75 * PI;

/// A sector of the spherical shell 1 ≤ r ≤ 2, π/6 ≤ θ ≤ π/2 (polar),
/// 0 ≤ φ ≤ π/2 (x → r, y → θ, z → φ: right-handed, det J > 0).
fn shell([x, y, z]: [f64; 3]) -> [f64; 3] {
    let (r, t, f) = (1.0 + x, PI / 6.0 + PI / 3.0 * y, 0.5 * PI * z);
    [r * t.sin() * f.cos(), r * t.sin() * f.sin(), r * t.cos()]
}

/// Its volume, (2³ − 1³)/3 · π/2 · (cos π/6 − cos π/2) = 7√3 π / 12.
fn shell_volume() -> f64 {
    7.0 * 3f64.sqrt() * PI / 12.0
}

/// The proper rotations of the reference cell `[0,p]^D` as (axis
/// permutation, flips): `q'_d = flip_d ? p − q_{perm_d} : q_{perm_d}`,
/// those of determinant +1 (4 in 2D, 24 in 3D).
fn rotations<const D: usize>() -> Vec<([usize; D], [bool; D])> {
    let perms: Vec<Vec<usize>> = if D == 2 {
        vec![vec![0, 1], vec![1, 0]]
    } else {
        vec![vec![0, 1, 2], vec![1, 2, 0], vec![2, 0, 1], vec![1, 0, 2], vec![0, 2, 1], vec![2, 1, 0]]
    };
    let mut out = Vec::new();
    for (k, perm) in perms.iter().enumerate() {
        let odd = if D == 2 { k == 1 } else { k >= 3 };
        for bits in 0..1usize << D {
            let flips = (0..D).filter(|d| bits >> d & 1 == 1).count();
            if odd == (flips % 2 == 1) {
                out.push((std::array::from_fn(|d| perm[d]), std::array::from_fn(|d| bits >> d & 1 == 1)));
            }
        }
    }
    assert_eq!(out.len(), if D == 2 { 4 } else { 24 });
    out
}

/// A cell's nodes after a rotation of its reference cell: the same
/// geometry, another local numbering.
fn rotate<const D: usize>(cell: &[usize], (perm, flip): &([usize; D], [bool; D]), p: usize) -> Vec<usize> {
    let n = p + 1;
    let tensor = |q: [usize; D]| q.iter().rev().fold(0, |acc, &x| acc * n + x);
    (0..cell.len())
        .map(|t| {
            let q: [usize; D] = std::array::from_fn(|d| t / n.pow(d as u32) % n);
            let r = std::array::from_fn(|d| if flip[d] { p - q[perm[d]] } else { q[perm[d]] });
            cell[tensor(r)]
        })
        .collect()
}

/// The mesh with nodes renumbered at random, cells in random order and
/// each cell rotated at random; boundary elements keep their order.
fn scramble<const D: usize>(m: &CurvedMesh<D>, seed: u64) -> CurvedMesh<D> {
    let mut s = seed;
    let mut old: Vec<usize> = (0..m.nodes.len()).collect();
    shuffle(&mut old, &mut s);
    let mut new = vec![0; old.len()];
    old.iter().enumerate().for_each(|(i, &o)| new[o] = i);
    let mut order: Vec<usize> = (0..m.cells.len()).collect();
    shuffle(&mut order, &mut s);
    let rots = rotations::<D>();
    let mut out = m.clone();
    out.nodes = old.iter().map(|&o| m.nodes[o]).collect();
    let cells = order
        .iter()
        .map(|&c| rotate(&m.cells[c], &rots[rand_below(&mut s, rots.len())], m.p).iter().map(|&v| new[v]).collect::<Vec<usize>>());
    out.cells = deformesh::mesh::Cells::from_cells(D, m.p, m.shape, cells);
    for b in 0..out.boundary.len() {
        out.boundary.nodes_mut(b).iter_mut().for_each(|v| *v = new[*v]);
    }
    out
}

/// Our map of cell `c` at `xi`: (x, det J).
fn our_map<const D: usize>(m: &CurvedMesh<D>, c: usize, xi: &[f64]) -> (Vec<f64>, f64) {
    let ctrl = m.cell_coords(c);
    if D == 2 {
        let ctrl: Vec<[f64; 2]> = ctrl.iter().map(|x| [x[0], x[1]]).collect();
        let (x, j) = quad_map(m.p, m.spacing, &ctrl, [xi[0], xi[1]]).unwrap();
        (x.to_vec(), j[0][0] * j[1][1] - j[0][1] * j[1][0])
    } else {
        let ctrl: Vec<[f64; 3]> = ctrl.iter().map(|x| [x[0], x[1], x[2]]).collect();
        let (x, j) = hex_map(m.p, m.spacing, &ctrl, [xi[0], xi[1], xi[2]]).unwrap();
        let det = j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1]) - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0])
            + j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
        (x.to_vec(), det)
    }
}

/// Our area/volume of cell `c`: the tensor 5-point Gauss rule of det J,
/// exact for the degree ≤ 3p − 1 ≤ 9 per variable of p ≤ 3 hexes and
/// p ≤ 4 quads (2p − 1); for p = 4 hexes (degree 11) it agrees with
/// MFEM's exact rule to 1e-15 on these smooth maps.
fn our_volume<const D: usize>(m: &CurvedMesh<D>, c: usize) -> f64 {
    let mut total = 0.0;
    for a in 0..GAUSS5.len().pow(D as u32) {
        let idx: Vec<usize> = (0..D).map(|d| a / 5usize.pow(d as u32) % 5).collect();
        let xi: Vec<f64> = idx.iter().map(|&i| GAUSS5[i].0).collect();
        let w: f64 = idx.iter().map(|&i| GAUSS5[i].1).product();
        total += w * our_map(m, c, &xi).1;
    }
    total
}

/// The JSON array as integers.
fn ints(v: &Value) -> Vec<i64> {
    v.as_array().expect("array").iter().map(|x| x.as_i64().expect("integer")).collect()
}

/// The sorted distinct values.
fn set(v: &[i64]) -> Vec<i64> {
    let mut s = v.to_vec();
    s.sort_unstable();
    s.dedup();
    s
}

/// Asserts MFEM's reading of a file of `m` agrees with ours: counts,
/// dimension, order, cell attributes, and per cell x(ξ), det J and the
/// area/volume. Returns our total area/volume and MFEM's JSON.
fn agrees<const D: usize>(m: &CurvedMesh<D>, file: &Path, attributes: &[i64]) -> (f64, Value) {
    let g = run_checker("check_mfem.py", file);
    let what = format!("{} (p = {}, {:?})", file.display(), m.p, m.spacing);
    assert_eq!(g["elements"].as_u64(), Some(m.cells.len() as u64), "{what}");
    assert_eq!(g["dimension"].as_u64(), Some(D as u64), "{what}");
    assert_eq!(g["space_dimension"].as_u64(), Some(D as u64), "{what}");
    assert_eq!(g["order"].as_u64(), Some(m.p as u64), "{what}: {}", g["fec"]);
    assert_eq!(ints(&g["attributes"]), attributes, "{what}");
    assert_eq!(ints(&g["attribute_set"]), set(attributes), "{what}");
    assert_eq!(ints(&g["mesh_attributes"]), set(attributes), "{what}");
    let points: Vec<Vec<f64>> = g["points"].as_array().unwrap().iter().map(floats).collect();
    let (mut worst_x, mut worst_det) = (0.0f64, 0.0f64);
    for c in 0..m.cells.len() {
        let xs = g["x"][c].as_array().unwrap();
        let dets = floats(&g["det"][c]);
        for (k, xi) in points.iter().enumerate() {
            let (x, det) = our_map(m, c, xi);
            let theirs = floats(&xs[k]);
            worst_x = worst_x.max(x.iter().zip(&theirs).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max));
            worst_det = worst_det.max((det - dets[k]).abs() / det.abs());
        }
    }
    assert!(worst_x < 1e-12, "{what}: MFEM's x(ξ) differs from ours by {worst_x:e}");
    assert!(worst_det < 1e-10, "{what}: MFEM's det J differs from ours by {worst_det:e} relative");
    let theirs = floats(&g["element_volumes"]);
    let ours: Vec<f64> = (0..m.cells.len()).map(|c| our_volume(m, c)).collect();
    for (c, (a, b)) in ours.iter().zip(&theirs).enumerate() {
        assert!((a - b).abs() <= 1e-12 * a.abs(), "{what}: cell {c}: our volume {a}, MFEM's {b}");
    }
    let total: f64 = ours.iter().sum();
    let v = g["volume"].as_f64().unwrap();
    assert!((v - total).abs() <= 1e-10 * total, "{what}: MFEM's volume {v}, ours {total}");
    // GetElementVolume's rule (of MFEM's `OrderJ`) is not exact for curved
    // elements: measured up to 4.0e-3 (trilinear hexes), 2.1e-4 (p = 3)
    let v = g["volume_mfem"].as_f64().unwrap();
    assert!((v - total).abs() <= 5e-3 * total, "{what}: MFEM's GetElementVolume sum {v}, ours {total}");
    (total, g)
}

/// Asserts MFEM read the boundary elements in order, each with our
/// attribute and on our corners (as a set: MFEM may turn them around;
/// sorted, since the coordinates agree to rounding and differ in the
/// first component).
fn boundary_agrees<const D: usize>(m: &CurvedMesh<D>, g: &Value, attributes: &[i64]) {
    assert_eq!(g["boundary_elements"].as_u64(), Some(attributes.len() as u64));
    let n = m.p + 1;
    let corners: Vec<usize> = if D == 2 { vec![0, m.p] } else { vec![0, m.p, n * n - 1, n * m.p] };
    for (b, e) in m.boundary.iter().enumerate() {
        let mut ours: Vec<Vec<f64>> = corners.iter().map(|&k| m.nodes[e.nodes[k]].to_vec()).collect();
        let mut theirs: Vec<Vec<f64>> = g["bdr_vertices"][b].as_array().unwrap().iter().map(floats).collect();
        ours.sort_by(|a, b| a.partial_cmp(b).unwrap());
        theirs.sort_by(|a, b| a.partial_cmp(b).unwrap());
        // MFEM evaluates its nodal map at the vertices: last-bit rounding
        let off = ours.iter().flatten().zip(theirs.iter().flatten()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(ours.len() == theirs.len() && off < 1e-14, "boundary element {b}: ours {ours:?}, MFEM's {theirs:?}");
    }
    assert_eq!(ints(&g["bdr_attributes"]), attributes);
    assert_eq!(ints(&g["bdr_attribute_set"]), set(attributes));
    assert_eq!(ints(&g["mesh_bdr_attributes"]), set(attributes));
}

/// Attributes per cell (6, 7, 8 in turn: a reordering would show) and per
/// boundary part (part k → 2 + k).
fn attributes<const D: usize>(m: &CurvedMesh<D>) -> (Vec<i64>, Vec<i64>) {
    let cells = (0..m.cells.len()).map(|c| 6 + (c % 3) as i64).collect();
    let bdr = m.boundary.iter().map(|b| 2 + b.part as i64).collect();
    (cells, bdr)
}

/// The FE collection name we promise for the nodes.
fn fec_name(d: usize, p: usize, spacing: Spacing) -> String {
    match spacing {
        Spacing::GaussLobatto => format!("H1_{d}D_P{p}"),
        Spacing::Equispaced => format!("H1@U_{d}D_P{p}"),
    }
}

/// Writes `m` as an MFEM mesh, has MFEM read it, checks everything; returns
/// the relative error of the area/volume against `exact`.
fn mesh_file_agrees<const D: usize>(m: &CurvedMesh<D>, exact: f64) -> f64 {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("m.mesh");
    let (cells, bdr) = attributes(m);
    write_mfem(&file, m, &cells, &bdr).unwrap();
    let (total, g) = agrees(m, &file, &cells);
    boundary_agrees(m, &g, &bdr);
    let fec = if m.p == 1 { Value::Null } else { Value::from(fec_name(D, m.p, m.spacing)) };
    assert_eq!(g["fec"], fec);
    let corners: std::collections::HashSet<usize> = m.cells.iter().flat_map(|c| {
        let n = m.p + 1;
        (0..1usize << D).map(move |v| c[(0..D).map(|d| (v >> d & 1) * m.p * n.pow(d as u32)).sum::<usize>()])
    }).collect();
    assert_eq!(g["vertices"].as_u64(), Some(corners.len() as u64));
    (total - exact).abs() / exact
}

/// Relative area errors measured (MFEM's = ours) on the 4 × 4 quarter
/// annulus, equispaced / Gauss–Lobatto nodes: p = 1: 2.55e-2, 2: 4.93e-5
/// (the same nodes), 3: 7.26e-6 / 4.83e-8, 4: 1.89e-8 / 2.77e-11. The
/// bounds are 1.2–1.5 times these.
#[test]
fn mfem_reads_curved_quads_of_every_order() {
    let bound = |p: usize, s: Spacing| match (p, s) {
        (1, _) => 3e-2,
        (2, _) => 6e-5,
        (3, Spacing::Equispaced) => 9e-6,
        (3, _) => 6e-8,
        (_, Spacing::Equispaced) => 2.5e-8,
        _ => 4e-11,
    };
    for p in 1..=4 {
        for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
            let m = CurvedMesh::<2>::structured(p, spacing, [4, 4], annulus).unwrap();
            let m = scramble(&m, 17 + p as u64);
            let err = mesh_file_agrees(&m, ANNULUS_AREA);
            eprintln!("quarter annulus p = {p} {spacing:?}: area error {err:.2e}");
            assert!(err < bound(p, spacing), "p = {p} {spacing:?}: area off by {err:e} relative");
        }
    }
}

/// Relative volume errors measured on the 3 × 2 × 2 shell sector,
/// equispaced / Gauss–Lobatto nodes: p = 1: 1.60e-1, 2: 1.01e-3, 3:
/// 1.46e-4 / 4.08e-6, 4: 1.35e-6 / 9.12e-9. The bounds are 1.2–1.3 times
/// these.
#[test]
fn mfem_reads_curved_hexes() {
    let bound = |p: usize, s: Spacing| match (p, s) {
        (1, _) => 0.2,
        (2, _) => 1.2e-3,
        (3, Spacing::Equispaced) => 1.8e-4,
        (3, _) => 5e-6,
        (_, Spacing::Equispaced) => 1.8e-6,
        _ => 1.2e-8,
    };
    for p in 1..=4 {
        for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
            let m = CurvedMesh::<3>::structured(p, spacing, [3, 2, 2], shell).unwrap();
            let m = scramble(&m, 40 + p as u64);
            let err = mesh_file_agrees(&m, shell_volume());
            eprintln!("shell sector p = {p} {spacing:?}: volume error {err:.2e}");
            assert!(err < bound(p, spacing), "p = {p} {spacing:?}: volume off by {err:e} relative");
        }
    }
}

/// MFEM takes its element attributes from our VTU's `attribute` array and
/// its Lagrange cells give our maps (a VTU has no boundary elements: MFEM makes its own).
#[test]
fn mfem_reads_vtu_attributes() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("m.vtu");
    let q = CurvedMesh::<2>::structured(3, Spacing::GaussLobatto, [4, 4], annulus).unwrap();
    let (cells, _) = attributes(&q);
    q.write_vtu_with_attributes(&file, &[("quality", &vec![0.5; cells.len()])], &cells).unwrap();
    let (_, g) = agrees(&q, &file, &cells);
    // MFEM makes the boundary elements itself, attribute 1
    assert_eq!(g["boundary_elements"].as_u64(), Some(q.boundary.len() as u64));
    assert_eq!(ints(&g["bdr_attribute_set"]), [1]);
    let h = CurvedMesh::<3>::structured(2, Spacing::Equispaced, [3, 2, 2], shell).unwrap();
    let (cells, _) = attributes(&h);
    h.write_vtu_with_attributes(&file, &[], &cells).unwrap();
    agrees(&h, &file, &cells);
}

/// `deformesh curve` to `.mesh` on the quarter disk (Gmsh's three blocks,
/// tests/python/quarter_disk.py) and the ball octant: MFEM's area and
/// volume equal ours (the Gauss rule on the same curve run's `.msh`) and
/// the exact ones to within the sampled boundary error times the curved
/// wall's length (π/2) or area (π/2); at p = 2 and 3 on the disk, p = 2
/// on the ball.
#[test]
fn mfem_integrates_curved_quarter_disks_and_ball_octants() {
    use deformesh::app::driver::{curve_file, CurveJob, OutputFormat};
    let dir = tempfile::tempdir().unwrap();
    let disk = dir.path().join("quarter_disk.msh");
    crate::common::run_script("quarter_disk.py", &["6", disk.to_str().unwrap()]);
    let ball = crate::common::data("ball_octant_hex.msh");
    let arc = crate::common::QUARTER_DISK;
    let sphere = crate::common::BALL_OCTANT;
    // the ball at p = 2 only: at p = 3 its two runs take 15 s of the suite
    for (input, geometry, exact, dim, orders) in [(&disk, arc, PI / 4.0, 2, &[2, 3][..]), (&ball, sphere, PI / 6.0, 3, &[2][..])] {
        let g = dir.path().join("geometry.toml");
        std::fs::write(&g, geometry).unwrap();
        for &p in orders {
            let run = |name: &str, format| {
                let options = deformesh::highorder::curve::CurveOptions { order: p, ..Default::default() };
                let job = CurveJob { input: input.clone(), geometry: Some(g.clone()), cad: None, output: dir.path().join(name), format, options, width: 200, force: false };
                curve_file(&job, |_| {}).unwrap()
            };
            let report = run(&format!("d{dim}p{p}.mesh"), OutputFormat::Mfem);
            run(&format!("t{dim}p{p}.msh"), OutputFormat::Msh41);
            let m = run_checker("check_mfem.py", &dir.path().join(format!("d{dim}p{p}.mesh")));
            assert_eq!((m["order"].as_u64(), m["elements"].as_u64()), (Some(p as u64), Some(report.cells as u64)));
            let theirs = m["volume"].as_f64().unwrap();
            let file = dir.path().join(format!("t{dim}p{p}.msh"));
            let ours: f64 = if dim == 2 {
                let mesh = CurvedMesh::<2>::read_msh(&file).unwrap();
                (0..mesh.cells.len()).map(|c| our_volume(&mesh, c)).sum()
            } else {
                let mesh = CurvedMesh::<3>::read_msh(&file).unwrap();
                (0..mesh.cells.len()).map(|c| our_volume(&mesh, c)).sum()
            };
            assert!((theirs - ours).abs() <= 1e-12 * exact, "{dim}D p = {p}: MFEM {theirs} vs ours {ours}");
            let bound = PI / 2.0 * report.quality.boundary_sample_distance;
            assert!((theirs - exact).abs() <= bound, "{dim}D p = {p}: {theirs} vs exact {exact}, off by more than {bound:e}");
        }
    }
}
