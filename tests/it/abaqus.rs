//! The HOHQMesh-style ABAQUS writer (`deformesh::io::abaqus`), read back
//! by a parser written here from HOHQMesh's writer and Trixi.jl's reader
//! (not from our writer), and by meshio.
//!
//! The meshes are structured meshes of the unit square/cube bent by maps
//! that are polynomials of degree ≤ p in each variable, so the order-p
//! elements reproduce the map exactly, and whose every component is
//! linear in at least one variable, so the transfinite interpolation Trixi
//! builds from the sides reproduces it too. The expected side points are
//! the map at the Chebyshev–Gauss–Lobatto points computed here.

use std::f64::consts::PI;

use deformesh::io::abaqus::{abaqus_string, write_abaqus};
use deformesh::mesh::element::Spacing;
use deformesh::mesh::CurvedMesh;

use crate::common::{floats, run_checker};

/// What the parser finds in a HOHQMesh ABAQUS file.
#[derive(Debug)]
struct Inp {
    /// `*NODE` coordinates, by node number − 1.
    nodes: Vec<[f64; 3]>,
    /// `*ELEMENT` type.
    element_type: String,
    /// `*ELEMENT` corners (node numbers, 1-based), in file order.
    elements: Vec<Vec<usize>>,
    /// `** mesh polynomial degree = N`.
    degree: usize,
    /// Per element, per side (HOHQMesh order): the points, if flagged.
    sides: Vec<Vec<Option<Vec<[f64; 3]>>>>,
    /// Per element, the names in p4est order.
    names: Vec<Vec<String>>,
}

/// Parses the file as Trixi.jl's `p4est_connectivity_from_hohqmesh_abaqus`
/// and `calc_tree_node_coordinates!` do, plus the checks of the linear
/// part p4est makes (contiguous node numbers, `id, x, y, z` lines).
fn parse(text: &str, dim: usize) -> Inp {
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "*Heading");
    assert_eq!(lines[1], " File created by HOHQMesh", "Trixi compares the second line exactly");
    assert_eq!(lines[2], "*NODE");
    let mut i = 3;
    let mut nodes = Vec::new();
    while !lines[i].starts_with('*') {
        let f: Vec<&str> = lines[i].split(',').map(str::trim).collect();
        assert_eq!(f.len(), 4, "node line {:?}", lines[i]);
        assert_eq!(f[0].parse::<usize>().unwrap(), nodes.len() + 1, "node numbers must be contiguous");
        nodes.push([f[1].parse().unwrap(), f[2].parse().unwrap(), f[3].parse().unwrap()]);
        i += 1;
    }
    let header = lines[i];
    let element_type = header
        .strip_prefix("*ELEMENT, type=")
        .and_then(|r| r.split(',').next())
        .unwrap_or_else(|| panic!("element header {header:?}"))
        .to_string();
    i += 1;
    let ncorner = 1 << dim;
    let mut elements = Vec::new();
    while !lines[i].starts_with('*') {
        let f: Vec<usize> = lines[i].split(',').map(|s| s.trim().parse().unwrap()).collect();
        assert_eq!(f[0], elements.len() + 1);
        assert_eq!(f.len(), ncorner + 1);
        assert!(f[1..].iter().all(|&v| (1..=nodes.len()).contains(&v)));
        elements.push(f[1..].to_vec());
        i += 1;
    }
    assert_eq!(lines[i], "** ***** HOHQMesh boundary information ***** **");
    i += 1;
    let words: Vec<&str> = lines[i].split_whitespace().collect();
    assert_eq!(&words[..5], &["**", "mesh", "polynomial", "degree", "="]);
    let degree: usize = words[5].parse().unwrap();
    i += 1;
    let nsides = 2 * dim;
    let per_side = (degree + 1).pow(dim as u32 - 1);
    let mut sides = Vec::new();
    for (e, element) in elements.iter().enumerate() {
        let w: Vec<&str> = lines[i].split_whitespace().collect();
        assert_eq!(w[0], "**");
        let corners: Vec<usize> = w[1..].iter().map(|s| s.parse().unwrap()).collect();
        assert_eq!(&corners, element, "corner line of element {}", e + 1);
        i += 1;
        let w: Vec<&str> = lines[i].split_whitespace().collect();
        assert_eq!(w[0], "**");
        let flags: Vec<u8> = w[1..].iter().map(|s| s.parse().unwrap()).collect();
        assert_eq!(flags.len(), nsides);
        i += 1;
        let mut mine = Vec::new();
        for &flag in &flags {
            assert!(flag <= 1);
            if flag == 1 {
                let pts = (0..per_side)
                    .map(|_| {
                        let w: Vec<&str> = lines[i].split_whitespace().collect();
                        i += 1;
                        assert_eq!((w[0], w.len()), ("**", 4), "point line {:?}", lines[i - 1]);
                        [w[1].parse().unwrap(), w[2].parse().unwrap(), w[3].parse().unwrap()]
                    })
                    .collect();
                mine.push(Some(pts));
            } else {
                mine.push(None);
            }
        }
        sides.push(mine);
    }
    let mut names = Vec::new();
    for _ in 0..elements.len() {
        let w: Vec<&str> = lines[i].split_whitespace().collect();
        assert_eq!(w[0], "**");
        assert_eq!(w.len(), nsides + 1, "name line {:?}", lines[i]);
        names.push(w[1..].iter().map(|s| s.to_string()).collect());
        i += 1;
    }
    assert_eq!(i, lines.len(), "trailing lines");
    Inp { nodes, element_type, elements, degree, sides, names }
}

/// `−cos(π j / N)`, `j = 0..=N`: Trixi's `chebyshev_gauss_lobatto_nodes_weights`.
fn cgl(n: usize) -> Vec<f64> {
    (0..=n).map(|j| -(PI * j as f64 / n as f64).cos()).collect()
}

/// The Lagrange basis on `nodes` at `x`.
fn lagrange(nodes: &[f64], x: f64) -> Vec<f64> {
    (0..nodes.len())
        .map(|i| (0..nodes.len()).filter(|&m| m != i).map(|m| (x - nodes[m]) / (nodes[i] - nodes[m])).product())
        .collect()
}

/// A curve through `pts` at the CGL nodes, at `s ∈ [−1,1]`.
fn curve(nodes: &[f64], pts: &[[f64; 3]], s: f64) -> [f64; 3] {
    let l = lagrange(nodes, s);
    std::array::from_fn(|r| pts.iter().zip(&l).map(|(x, w)| w * x[r]).sum())
}

/// A face through `pts` (first parameter fastest) at `(u, v) ∈ [−1,1]²`.
fn face(nodes: &[f64], pts: &[[f64; 3]], u: f64, v: f64) -> [f64; 3] {
    let (lu, lv) = (lagrange(nodes, u), lagrange(nodes, v));
    let n = nodes.len();
    std::array::from_fn(|r| (0..n * n).map(|a| lu[a % n] * lv[a / n] * pts[a][r]).sum())
}

/// Trixi's reconstruction of element `e` at `ξ ∈ [−1,1]^D`: the straight
/// map of the corners if no side is flagged, else the transfinite map of
/// the sides (Kopriva's Alg. 98 in 2D, `transfinite_hex_map` in 3D), all
/// sides being flagged (checked by the caller).
fn trixi_map(inp: &Inp, e: usize, xi: &[f64]) -> [f64; 3] {
    let corner = |k: usize| inp.nodes[inp.elements[e][k] - 1];
    let dim = xi.len();
    if inp.sides[e].iter().all(Option::is_none) {
        let mut x = [0.0; 3];
        for k in 0..(1 << dim) {
            // corner k's signs: (−,−) (+,−) (+,+) (−,+), then the same at ζ = +1
            let q = k % 4;
            let s = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]][q];
            let mut w = (1.0 + s[0] * xi[0]) * (1.0 + s[1] * xi[1]) / 4.0;
            if dim == 3 {
                w *= (1.0 + if k < 4 { -xi[2] } else { xi[2] }) / 2.0;
            }
            let c = corner(k);
            (0..3).for_each(|r| x[r] += w * c[r]);
        }
        return x;
    }
    let nodes = cgl(inp.degree);
    let g = |k: usize| inp.sides[e][k].as_ref().expect("all sides flagged");
    if dim == 2 {
        let (s, t) = (xi[0], xi[1]);
        let (c1, c2, c3, c4) = (curve(&nodes, g(0), -1.0), curve(&nodes, g(0), 1.0), curve(&nodes, g(2), 1.0), curve(&nodes, g(2), -1.0));
        let (x1, x2, x3, x4) = (curve(&nodes, g(0), s), curve(&nodes, g(1), t), curve(&nodes, g(2), s), curve(&nodes, g(3), t));
        return std::array::from_fn(|r| {
            0.5 * ((1.0 - s) * x4[r] + (1.0 + s) * x2[r] + (1.0 - t) * x1[r] + (1.0 + t) * x3[r])
                - 0.25 * ((1.0 - s) * ((1.0 - t) * c1[r] + (1.0 + t) * c4[r]) + (1.0 + s) * ((1.0 - t) * c2[r] + (1.0 + t) * c3[r]))
        });
    }
    let (a, b, c) = (xi[0], xi[1], xi[2]);
    let f = |k: usize, u: f64, v: f64| face(&nodes, g(k), u, v);
    let edge = [
        f(0, a, -1.0),
        f(0, 1.0, c),
        f(0, a, 1.0),
        f(0, -1.0, c),
        f(1, a, -1.0),
        f(1, 1.0, c),
        f(1, a, 1.0),
        f(1, -1.0, c),
        f(5, b, -1.0),
        f(3, b, -1.0),
        f(3, b, 1.0),
        f(5, b, 1.0),
    ];
    let fv = [f(0, a, c), f(1, a, c), f(2, a, b), f(3, b, c), f(4, a, b), f(5, b, c)];
    let corners = [f(0, -1.0, -1.0), f(0, 1.0, -1.0), f(1, 1.0, -1.0), f(1, -1.0, -1.0), f(0, -1.0, 1.0), f(0, 1.0, 1.0), f(1, 1.0, 1.0), f(1, -1.0, 1.0)];
    let sg = [[-1.0, -1.0, -1.0], [1.0, -1.0, -1.0], [1.0, 1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0], [1.0, -1.0, 1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0]];
    std::array::from_fn(|r| {
        let sigma = 0.5 * ((1.0 - a) * fv[5][r] + (1.0 + a) * fv[3][r] + (1.0 - b) * fv[0][r] + (1.0 + b) * fv[1][r] + (1.0 - c) * fv[2][r] + (1.0 + c) * fv[4][r]);
        let ed = 0.25
            * (edge[0][r] * (1.0 - b) * (1.0 - c)
                + edge[1][r] * (1.0 + a) * (1.0 - b)
                + edge[2][r] * (1.0 - b) * (1.0 + c)
                + edge[3][r] * (1.0 - a) * (1.0 - b)
                + edge[4][r] * (1.0 + b) * (1.0 - c)
                + edge[5][r] * (1.0 + a) * (1.0 + b)
                + edge[6][r] * (1.0 + b) * (1.0 + c)
                + edge[7][r] * (1.0 - a) * (1.0 + b)
                + edge[8][r] * (1.0 - a) * (1.0 - c)
                + edge[9][r] * (1.0 + a) * (1.0 - c)
                + edge[10][r] * (1.0 + a) * (1.0 + c)
                + edge[11][r] * (1.0 - a) * (1.0 + c));
        let lin: f64 = (0..8).map(|k| corners[k][r] * (0..3).map(|d| 1.0 + sg[k][d] * xi[d]).product::<f64>() / 8.0).sum();
        sigma - ed + lin
    })
}

/// What a side of the written element is, in the reference cell
/// `[−1,1]^D` of the file: 2D sides −y, +x, +y, −x; 3D faces −y, +y, −z,
/// +x, +z, −x (HOHQMesh's numbering), as the point at parameters `(u, v)`.
fn side_point(dim: usize, side: usize, u: f64, v: f64) -> Vec<f64> {
    match (dim, side) {
        (2, 0) => vec![u, -1.0],
        (2, 1) => vec![1.0, u],
        (2, 2) => vec![u, 1.0],
        (2, 3) => vec![-1.0, u],
        (3, 0) => vec![u, -1.0, v],
        (3, 1) => vec![u, 1.0, v],
        (3, 2) => vec![u, v, -1.0],
        (3, 3) => vec![1.0, u, v],
        (3, 4) => vec![u, v, 1.0],
        (3, 5) => vec![-1.0, u, v],
        _ => unreachable!(),
    }
}

/// One test case: a structured mesh of `n` cells bent by `map`, and
/// whether the map reverses orientation (the writer then exchanges the
/// first two reference axes of every cell, as its docs say).
struct Case<const D: usize> {
    p: usize,
    spacing: Spacing,
    n: [usize; D],
    map: fn([f64; D]) -> [f64; D],
    reflected: bool,
    /// Whether every cell has a curved side (else none has).
    curved: bool,
}

impl<const D: usize> Case<D> {
    fn mesh(&self) -> CurvedMesh<D> {
        CurvedMesh::<D>::structured(self.p, self.spacing, self.n, self.map).unwrap()
    }

    /// The grid index of cell `c` (first axis fastest, as `structured`).
    fn cell_index(&self, c: usize) -> [usize; D] {
        let mut rest = c;
        std::array::from_fn(|d| {
            let i = rest % self.n[d];
            rest /= self.n[d];
            i
        })
    }

    /// The point of the unit box at file-reference point `xi ∈ [−1,1]^D`
    /// of element `c`.
    fn unit_box_point(&self, c: usize, xi: &[f64]) -> [f64; D] {
        let mut local: [f64; D] = std::array::from_fn(|d| 0.5 * (1.0 + xi[d]));
        if self.reflected {
            local.swap(0, 1);
        }
        let ci = self.cell_index(c);
        std::array::from_fn(|d| (ci[d] as f64 + local[d]) / self.n[d] as f64)
    }

    fn physical(&self, c: usize, xi: &[f64]) -> [f64; 3] {
        let x = (self.map)(self.unit_box_point(c, xi));
        std::array::from_fn(|r| if r < D { x[r] } else { 0.0 })
    }

    /// The box side (part name) on which the file side `(axis, end)` of
    /// element `c` lies, or "---".
    fn expected_name(&self, c: usize, axis: usize, end: usize) -> String {
        let mut xi = vec![0.0; D];
        xi[axis] = if end == 0 { -1.0 } else { 1.0 };
        let y = self.unit_box_point(c, &xi);
        let own = if self.reflected && axis < 2 { 1 - axis } else { axis };
        let names = ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"];
        if y[own] == 0.0 {
            names[2 * own].to_string()
        } else if y[own] == 1.0 {
            names[2 * own + 1].to_string()
        } else {
            "---".to_string()
        }
    }

    /// Writes, parses and checks; returns (elements, corner nodes, curved
    /// side points checked, largest error of a side point, largest error
    /// of Trixi's reconstruction inside).
    fn check(&self) -> (usize, usize, usize, f64, f64) {
        let mesh = self.mesh();
        let text = abaqus_string(&mesh).unwrap();
        let inp = parse(&text, D);
        let ncells: usize = self.n.iter().product();
        assert_eq!(inp.elements.len(), ncells);
        assert_eq!(inp.element_type, if D == 2 { "CPS4" } else { "C3D8" });
        assert_eq!(inp.nodes.len(), self.n.iter().map(|k| k + 1).product::<usize>(), "only corner nodes are written");
        assert_eq!(inp.degree, self.p);
        let t = cgl(self.p);
        let (mut points, mut side_err, mut inner_err) = (0, 0.0f64, 0.0f64);
        let digits2 = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
        for e in 0..ncells {
            // corners, in ABAQUS order, and right-handedness
            for k in 0..(1 << D) {
                let mut xi = digits2[k % 4].to_vec();
                if D == 3 {
                    xi.push(if k < 4 { -1.0 } else { 1.0 });
                }
                let want = self.physical(e, &xi);
                let got = inp.nodes[inp.elements[e][k] - 1];
                assert!((0..3).all(|r| (want[r] - got[r]).abs() < 1e-14), "element {e} corner {k}: {got:?} != {want:?}");
            }
            assert!(corner_orientation(&inp, e, D) > 0.0, "element {e} is not right-handed");
            // sides: all flagged or none
            let flagged = inp.sides[e].iter().filter(|s| s.is_some()).count();
            assert_eq!(flagged, if self.curved { 2 * D } else { 0 }, "element {e} flags");
            for (k, pts) in inp.sides[e].iter().enumerate() {
                let Some(pts) = pts else { continue };
                for (a, got) in pts.iter().enumerate() {
                    let (u, v) = (t[a % t.len()], t[a / t.len()]);
                    let want = self.physical(e, &side_point(D, k, u, v));
                    let err = (0..3).map(|r| (want[r] - got[r]).abs()).fold(0.0, f64::max);
                    assert!(err < 1e-12, "element {e} side {} point {a}: {got:?} != {want:?}", k + 1);
                    side_err = side_err.max(err);
                    points += 1;
                }
            }
            // names, in p4est order −x +x −y +y (−z +z)
            for (slot, name) in inp.names[e].iter().enumerate() {
                assert_eq!(name, &self.expected_name(e, slot / 2, slot % 2), "element {e} name {slot}");
            }
            // what Trixi rebuilds inside is the map
            let s = [-0.83, -0.31, 0.17, 0.71];
            for a in 0..s.len().pow(D as u32) {
                let xi: Vec<f64> = (0..D).map(|d| s[(a / s.len().pow(d as u32)) % s.len()]).collect();
                let want = self.physical(e, &xi);
                let got = trixi_map(&inp, e, &xi);
                let err = (0..3).map(|r| (want[r] - got[r]).abs()).fold(0.0, f64::max);
                assert!(err < 1e-12, "element {e} at {xi:?}: Trixi's map gives {got:?}, the mesh {want:?}");
                inner_err = inner_err.max(err);
            }
        }
        (ncells, inp.nodes.len(), points, side_err, inner_err)
    }
}

/// det J of the straight map of the corners at the centre (2D: the
/// corner polygon's area sign).
fn corner_orientation(inp: &Inp, e: usize, dim: usize) -> f64 {
    let x = |k: usize| inp.nodes[inp.elements[e][k] - 1];
    if dim == 2 {
        (0..4).map(|k| x(k)[0] * x((k + 1) % 4)[1] - x((k + 1) % 4)[0] * x(k)[1]).sum::<f64>()
    } else {
        // columns: ∂/∂ξ, ∂/∂η, ∂/∂ζ at the centre from the corner differences
        let d = |pairs: [(usize, usize); 4]| -> [f64; 3] { std::array::from_fn(|r| pairs.iter().map(|&(p, m)| x(p)[r] - x(m)[r]).sum::<f64>() / 4.0) };
        let a = d([(1, 0), (2, 3), (5, 4), (6, 7)]);
        let b = d([(3, 0), (2, 1), (7, 4), (6, 5)]);
        let c = d([(4, 0), (5, 1), (6, 2), (7, 3)]);
        a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])
    }
}

fn quad2([x, y]: [f64; 2]) -> [f64; 2] {
    [x + 0.1 * y * y + 0.05 * x * y, y + 0.15 * x * x - 0.05 * x * x * y]
}
fn quad3([x, y]: [f64; 2]) -> [f64; 2] {
    [x + 0.08 * y * y * y + 0.05 * x * y * y, y + 0.1 * x * x * x - 0.04 * x * x * y]
}
fn quad3_reflected([x, y]: [f64; 2]) -> [f64; 2] {
    let [a, b] = quad3([x, y]);
    [-a, b]
}
fn affine2([x, y]: [f64; 2]) -> [f64; 2] {
    [2.0 * x + 0.3 * y, y - 0.2 * x]
}
fn hex2([x, y, z]: [f64; 3]) -> [f64; 3] {
    [x + 0.1 * y * y * z + 0.05 * z * z, y + 0.1 * x * z * z + 0.05 * x * x, z - 0.1 * x * x * y + 0.05 * y * y]
}
fn hex3([x, y, z]: [f64; 3]) -> [f64; 3] {
    [x + 0.06 * y * y * y + 0.05 * y * y * z, y + 0.06 * z * z * z + 0.05 * x * z * z, z + 0.06 * x * x * x - 0.05 * x * x * y]
}
fn hex2_reflected([x, y, z]: [f64; 3]) -> [f64; 3] {
    let [a, b, c] = hex2([x, y, z]);
    [a, b, -c]
}

#[test]
fn quads_parse_back_to_the_mesh() {
    let cases = [
        Case::<2> { p: 2, spacing: Spacing::Equispaced, n: [3, 2], map: quad2, reflected: false, curved: true },
        Case::<2> { p: 3, spacing: Spacing::Equispaced, n: [3, 2], map: quad3, reflected: false, curved: true },
        Case::<2> { p: 3, spacing: Spacing::GaussLobatto, n: [3, 2], map: quad3, reflected: false, curved: true },
        Case::<2> { p: 3, spacing: Spacing::Equispaced, n: [3, 2], map: quad3_reflected, reflected: true, curved: true },
        Case::<2> { p: 4, spacing: Spacing::GaussLobatto, n: [3, 2], map: quad3, reflected: false, curved: true },
        Case::<2> { p: 2, spacing: Spacing::Equispaced, n: [3, 2], map: affine2, reflected: false, curved: false },
    ];
    for (i, case) in cases.iter().enumerate() {
        let (elements, nodes, points, side_err, inner_err) = case.check();
        eprintln!("2D case {i} (p = {}): {elements} elements, {nodes} nodes, {points} side points within {side_err:e}, Trixi's map within {inner_err:e}", case.p);
        assert_eq!(points, if case.curved { elements * 4 * (case.p + 1) } else { 0 });
    }
}

#[test]
fn hexes_parse_back_to_the_mesh() {
    let cases = [
        Case::<3> { p: 2, spacing: Spacing::Equispaced, n: [2, 2, 1], map: hex2, reflected: false, curved: true },
        Case::<3> { p: 3, spacing: Spacing::Equispaced, n: [2, 1, 2], map: hex3, reflected: false, curved: true },
        Case::<3> { p: 3, spacing: Spacing::GaussLobatto, n: [1, 2, 2], map: hex3, reflected: false, curved: true },
        Case::<3> { p: 2, spacing: Spacing::Equispaced, n: [2, 2, 1], map: hex2_reflected, reflected: true, curved: true },
        Case::<3> { p: 4, spacing: Spacing::GaussLobatto, n: [1, 1, 2], map: hex3, reflected: false, curved: true },
    ];
    for (i, case) in cases.iter().enumerate() {
        let (elements, nodes, points, side_err, inner_err) = case.check();
        eprintln!("3D case {i} (p = {}): {elements} elements, {nodes} nodes, {points} face points within {side_err:e}, Trixi's map within {inner_err:e}", case.p);
        assert_eq!(points, elements * 6 * (case.p + 1).pow(2));
    }
}

/// meshio reads the linear part: the points are the corner nodes and each
/// cell's points are the mapped corners of its cell, in ABAQUS order.
#[test]
fn meshio_reads_the_linear_part() {
    let dir = tempfile::tempdir().unwrap();
    let q = Case::<2> { p: 3, spacing: Spacing::Equispaced, n: [3, 2], map: quad3, reflected: false, curved: true };
    let h = Case::<3> { p: 2, spacing: Spacing::GaussLobatto, n: [2, 2, 1], map: hex2, reflected: false, curved: true };
    let path = dir.path().join("quads.inp");
    write_abaqus(&path, &q.mesh()).unwrap();
    let got = run_checker("check_abaqus.py", &path);
    check_meshio(&got, "quad", 6, 12, |c, xi| q.physical(c, xi), 2);
    let path = dir.path().join("hexes.inp");
    write_abaqus(&path, &h.mesh()).unwrap();
    let got = run_checker("check_abaqus.py", &path);
    check_meshio(&got, "hexahedron", 4, 18, |c, xi| h.physical(c, xi), 3);
}

fn check_meshio(got: &serde_json::Value, ty: &str, cells: usize, points: usize, physical: impl Fn(usize, &[f64]) -> [f64; 3], dim: usize) {
    assert_eq!(got["num_points"].as_u64(), Some(points as u64), "{}", got["cells"]);
    assert_eq!(got["cells"].as_object().unwrap().len(), 1, "{}", got["cells"]);
    assert_eq!(got["cells"][ty].as_u64(), Some(cells as u64), "{}", got["cells"]);
    let pts: Vec<Vec<f64>> = got["points"].as_array().unwrap().iter().map(floats).collect();
    let conn = got["connectivity"][ty].as_array().unwrap();
    let digits2 = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
    let mut worst = 0.0f64;
    for (c, cell) in conn.iter().enumerate() {
        let ids: Vec<usize> = cell.as_array().unwrap().iter().map(|v| v.as_u64().unwrap() as usize).collect();
        assert_eq!(ids.len(), 1 << dim);
        for (k, &v) in ids.iter().enumerate() {
            let mut xi = digits2[k % 4].to_vec();
            if dim == 3 {
                xi.push(if k < 4 { -1.0 } else { 1.0 });
            }
            let want = physical(c, &xi);
            let err = (0..3).map(|r| (pts[v][r] - want[r]).abs()).fold(0.0, f64::max);
            assert!(err < 1e-14, "{ty} {c} point {k}: {:?} != {want:?}", pts[v]);
            worst = worst.max(err);
        }
    }
    eprintln!("meshio: {cells} {ty} cells, {points} points, corners within {worst:e}");
}
