//! The order-`p` Lagrange prism (wedge): the triangle's space `P_p` times
//! the line's, on the reference prism `{(x, y) in the unit triangle} ×
//! [0, 1]` of [`Shape::Prism`].
//!
//! **The lattice order** (fixed: the crate keeps prism nodes in it). A node
//! is `(i, j, k)`: `(i, j)` a node of the order-`p` triangle lattice of
//! [`super::simplex`] (`j` outer, `i` inner), `k = 0..=p` its layer along
//! z. Layers are outermost: position `k · T + t` with `t` the triangle
//! position and `T = (p+1)(p+2)/2`. So the bottom triangle (vertices 0, 1,
//! 2) is layer 0 and the top one (vertices 3, 4, 5) layer `p`.
//!
//! **Nodes.** The triangle's node set (equispaced or warp-blend) times the
//! 1-D set of [`super::nodes_1d`] on the same spacing: a quad face carries
//! the tensor nodes of a quad, a triangle face a triangle's, so a prism
//! shares its faces with hexes and tetrahedra node for node.
//!
//! **Basis.** `ℓ_{(t, k)}(x, y, z) = ℓ_t^{tri}(x, y) · l_k(z)`.
//!
//! **File orders.** [`gmsh_prism_order`] (MSH types 6, 13, 90, 91) and
//! [`vtk_wedge_order`] (`VTK_WEDGE` = 13, `VTK_LAGRANGE_WEDGE` = 73) are
//! built from each format's rules, not copied from tables, and checked
//! against the real programs in `tests/it/simplex_orders.rs`. Both
//! formats orient the prism as we do: the bottom triangle 0, 1, 2 runs
//! counter-clockwise seen from the top 3, 4, 5 (positive det J of the
//! reference map), so neither order mirrors the cell. For VTK this holds
//! for its linear and its Lagrange wedge alike, by each of VTK 9.7's own
//! measures (`tests/it/real_programs_highorder.rs`): its det J is positive,
//! `vtkCellSizeFilter` finds a positive volume, `vtkCellValidator` no
//! wrongly oriented faces, and the faces `GetFace` lists turn their normals
//! outward — and a mirrored cell fails each of these. Mind the sources
//! that say otherwise: `vtkWedge`'s documentation still says the base's
//! normal points away from the top, and older VTK listed the linear
//! wedge's faces the other way round (`{0,1,2}, {3,5,4}, …`), where a
//! Gmsh-ordered linear prism showed a negative volume in ParaView's cell
//! size filter (meshio PR #863, 2020).

use std::sync::OnceLock;

use super::simplex::{self, SimplexSpace};
use super::{check_order, gmsh_line_order, gmsh_quad_order, nodes_1d, to_format, HighOrderError, Shape, Spacing, MAX_ORDER};

/// The number of nodes of the order-`p` triangle.
fn triangle_count(p: usize) -> usize {
    (p + 1) * (p + 2) / 2
}

/// The multi-indices `(i, j, k)` of the order-`p` prism in lattice order.
pub fn lattice(p: usize) -> Vec<[usize; 3]> {
    let tri = simplex::lattice(Shape::Triangle, p);
    (0..=p).flat_map(|k| tri.iter().map(move |&[i, j, _]| [i, j, k])).collect()
}

/// The position of `(i, j, k)` in [`lattice`]`(p)`.
///
/// # Panics
/// If it is not in the lattice.
pub fn lattice_index(p: usize, [i, j, k]: [usize; 3]) -> usize {
    assert!(k <= p, "layer {k} of an order-{p} prism");
    k * triangle_count(p) + simplex::lattice_index(Shape::Triangle, p, [i, j, 0])
}

/// The positions of the six vertices in [`lattice`] order, in
/// [`Shape::Prism`]'s vertex order.
pub fn vertex_nodes(p: usize) -> [usize; 6] {
    let tri = [[0, 0], [p, 0], [0, p]];
    std::array::from_fn(|v| lattice_index(p, [tri[v % 3][0], tri[v % 3][1], if v < 3 { 0 } else { p }]))
}

/// The `p³` sub-prisms of the order-`p` lattice (layer by layer, the
/// triangle's `p²` sub-triangles of [`simplex::sub_simplices`]), corners in
/// [`Shape::Prism`]'s vertex order, each oriented like the reference
/// prism.
pub fn sub_prisms(p: usize) -> Vec<[usize; 6]> {
    let tri = simplex::sub_simplices(Shape::Triangle, p);
    let lat = simplex::lattice(Shape::Triangle, p);
    let mut out = Vec::with_capacity(p * tri.len());
    for k in 0..p {
        for s in &tri {
            out.push(std::array::from_fn(|a| {
                let [i, j, _] = lat[s[a % 3]];
                lattice_index(p, [i, j, k + a / 3])
            }));
        }
    }
    out
}

/// The reference coordinates of the order-`p` nodes in lattice order.
pub fn prism_nodes(p: usize, spacing: Spacing) -> Result<Vec<[f64; 3]>, HighOrderError> {
    let tri = simplex::simplex_nodes(Shape::Triangle, p, spacing)?;
    let t = nodes_1d(p, spacing)?;
    Ok(t.iter().flat_map(|&z| tri.iter().map(move |x| [x[0], x[1], z])).collect())
}

/// The lattice point of vertex `v` of [`Shape::Prism`]: `p` times its
/// coordinates.
fn vertex_point(p: usize, v: usize) -> [usize; 3] {
    Shape::Prism.vertices()[v].map(|x| x as usize * p)
}

/// The lattice point of vertex `v` of `shape` (a prism or a pyramid),
/// whose lattice points are affine in their positions, so a node on an
/// edge or face is an exact combination of vertex points ([`combine`]).
pub(super) fn lattice_vertex(shape: Shape, p: usize, v: usize) -> [usize; 3] {
    match shape {
        Shape::Pyramid => super::pyramid::vertex_point(p, v),
        _ => vertex_point(p, v),
    }
}

/// `a + (s (b − a) + t (c − a)) / p` for lattice points of the order-`p`
/// prism; exact, as the differences of vertex points are multiples of `p`.
pub(super) fn combine(p: usize, [a, b, c]: [[usize; 3]; 3], s: usize, t: usize) -> [usize; 3] {
    std::array::from_fn(|x| {
        let (a, b, c) = (a[x] as isize, b[x] as isize, c[x] as isize);
        (a + (s as isize * (b - a) + t as isize * (c - a)) / p as isize) as usize
    })
}

/// The lattice positions on edge `edge` of [`Shape::edges`] of the prism,
/// from its first vertex to its second (`p + 1` of them).
pub fn edge_nodes(p: usize, edge: usize) -> Vec<usize> {
    cell_edge_nodes(Shape::Prism, p, edge, lattice_index)
}

/// [`edge_nodes`] of a prism or a pyramid, whose lattice positions are
/// `index`.
pub(super) fn cell_edge_nodes(cell: Shape, p: usize, edge: usize, index: fn(usize, [usize; 3]) -> usize) -> Vec<usize> {
    let [a, b] = cell.edges()[edge].map(|v| lattice_vertex(cell, p, v));
    (0..=p).map(|s| index(p, combine(p, [a, b, a], s, 0))).collect()
}

/// The lattice positions on face `face` of [`Shape::faces`] of the prism,
/// in the face's own frame, oriented outward: on the loop `a, b, c(, d)`
/// (counter-clockwise seen from outside) the first axis runs from `a` to
/// `b`, the second from `a` to `c` (triangle) or `d` (quadrilateral); a
/// triangle face lists its nodes in the triangle lattice order of
/// [`simplex`], a quadrilateral face in tensor order (`s + (p+1) t`), like
/// [`simplex::face_nodes`] and a hex's faces.
pub fn face_nodes(p: usize, face: usize) -> Vec<usize> {
    cell_face_nodes(Shape::Prism, p, face, lattice_index)
}

/// [`face_nodes`] of a prism or a pyramid, whose lattice positions are
/// `index`.
pub(super) fn cell_face_nodes(cell: Shape, p: usize, face: usize, index: fn(usize, [usize; 3]) -> usize) -> Vec<usize> {
    let (shape, loop_) = cell.faces()[face];
    let v = |k: usize| lattice_vertex(cell, p, loop_[k]);
    let frame = [v(0), v(1), v(loop_.len() - 1)];
    face_points(shape, p).into_iter().map(|[s, t]| index(p, combine(p, frame, s, t))).collect()
}

/// The points `(s, t)` of an order-`q` face of `shape` in its own order:
/// the triangle lattice, or tensor order (`s` fastest).
pub(super) fn face_points(shape: Shape, q: usize) -> Vec<[usize; 2]> {
    match shape {
        Shape::Triangle => simplex::lattice(shape, q).into_iter().map(|[s, t, _]| [s, t]).collect(),
        _ => (0..=q).flat_map(|t| (0..=q).map(move |s| [s, t])).collect(),
    }
}

/// `perm[lattice position] = place in points`.
fn permutation(p: usize, points: &[[usize; 3]]) -> Vec<usize> {
    let mut perm = vec![usize::MAX; points.len()];
    for (local, &m) in points.iter().enumerate() {
        let at = lattice_index(p, m);
        debug_assert_eq!(perm[at], usize::MAX, "node {m:?} listed twice");
        perm[at] = local;
    }
    debug_assert_eq!(points.len(), Shape::Prism.num_nodes(p));
    perm
}

/// The points `(s, t)` of an order-`q` face in Gmsh's order (`q = 0`: the
/// single node of a recursion): its triangle (`gmshGenerateMonomialsTriangle`)
/// or quadrilateral order, each vertices, edges, then the interior
/// recursively.
pub(super) fn gmsh_face_points(shape: Shape, q: usize) -> Vec<[usize; 2]> {
    if q == 0 {
        return vec![[0, 0]];
    }
    let ok = "an order of 1..=MAX_ORDER";
    let perm = match shape {
        Shape::Triangle => simplex::gmsh_triangle_order(q).expect(ok),
        _ => gmsh_quad_order(q).expect(ok),
    };
    to_format(&perm, &face_points(shape, q))
}

/// The inner nodes of the faces of `faces` (loops of prism vertices), each
/// laid out by `inner(shape)` (points of an order `p − 3` triangle or
/// `p − 2` quadrilateral), one node in from the face's sides, on the
/// face's frame ([`face_nodes`]).
pub(super) fn face_interiors(cell: Shape, p: usize, faces: &[(Shape, &[usize])], inner: impl Fn(Shape) -> Vec<[usize; 2]>) -> Vec<[usize; 3]> {
    let mut out = Vec::new();
    for &(shape, loop_) in faces {
        let interior = if shape == Shape::Triangle { p >= 3 } else { p >= 2 };
        if interior {
            let v = |k: usize| lattice_vertex(cell, p, loop_[k]);
            let frame = [v(0), v(1), v(loop_.len() - 1)];
            out.extend(inner(shape).into_iter().map(|[s, t]| combine(p, frame, s + 1, t + 1)));
        }
    }
    out
}

/// The vertices, then the inner nodes of each edge of `edges` from its
/// first vertex to its second: how both formats begin.
pub(super) fn vertices_and_edges(cell: Shape, p: usize, edges: &[[usize; 2]]) -> Vec<[usize; 3]> {
    let v: Vec<[usize; 3]> = (0..cell.vertices().len()).map(|a| lattice_vertex(cell, p, a)).collect();
    let mut out = v.clone();
    for &[a, b] in edges {
        out.extend((1..p).map(|s| combine(p, [v[a], v[b], v[a]], s, 0)));
    }
    out
}

/// Gmsh's order of an order-`p` prism (MSH types 6, 13, 90, 91), the rules
/// of `gmshGenerateMonomialsPrism`: vertices; the inner nodes of each edge
/// of Gmsh's table ([`Shape::edges`]: (0,1) (0,2) (0,3) (1,2) (1,4) (2,5)
/// (3,4) (3,5) (4,5)) from first to second vertex; the inner nodes of each
/// face of its table ([`Shape::faces`]: triangles (0,2,1) (3,4,5), quads
/// (0,1,4,3) (0,3,5,2) (1,2,5,4)), laid out as Gmsh's triangle of order
/// `p − 3` or quad of order `p − 2` on the face's frame ([`face_nodes`]);
/// then the interior, the inner triangle (Gmsh's order `p − 3`) outer and
/// the inner line (Gmsh's order `p − 2`: its two ends first) inner.
/// `perm[lattice position] = Gmsh's local number`.
pub fn gmsh_prism_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    let mut points = vertices_and_edges(Shape::Prism, p, Shape::Prism.edges());
    points.extend(face_interiors(Shape::Prism, p, Shape::Prism.faces(), |shape| {
        gmsh_face_points(shape, if shape == Shape::Triangle { p - 3 } else { p - 2 })
    }));
    if p >= 3 {
        let line = to_format(&gmsh_line_order(p - 2)?, &(0..=p - 2).collect::<Vec<_>>());
        for [s, t] in gmsh_face_points(Shape::Triangle, p - 3) {
            points.extend(line.iter().map(|&z| [s + 1, t + 1, z + 1]));
        }
    }
    Ok(permutation(p, &points))
}

/// VTK's wedge edges (`vtkWedge`'s, and the edge numbers of
/// `vtkHigherOrderWedge::PointIndexFromIJK`): the bottom loop, the top
/// loop, then the vertical edges; nodes run from first to second vertex.
const VTK_WEDGE_EDGES: [[usize; 2]; 9] = [[0, 1], [1, 2], [2, 0], [3, 4], [4, 5], [5, 3], [0, 3], [1, 4], [2, 5]];

/// The faces of VTK's Lagrange wedge as its face nodes are laid out
/// (`PointIndexFromIJK`), first axis from the first vertex to the second,
/// the other to the last: the triangles z = 0 and z = 1 both in the
/// bottom's (x, y) lattice order — so these two are *not* outward loops,
/// unlike `GetFace`'s (0,2,1) — then the quads y = 0, x + y = 1, x = 0
/// along the bottom edges (0,1), (1,2), (2,0) and up.
const VTK_WEDGE_FACES: [(Shape, &[usize]); 5] = [
    (Shape::Triangle, &[0, 1, 2]),
    (Shape::Triangle, &[3, 4, 5]),
    (Shape::Quadrilateral, &[0, 1, 4, 3]),
    (Shape::Quadrilateral, &[1, 2, 5, 4]),
    (Shape::Quadrilateral, &[2, 0, 3, 5]),
];

/// VTK's order of an order-`p` wedge (`VTK_WEDGE` = 13 for p = 1,
/// `VTK_LAGRANGE_WEDGE` = 73 above), the rules of
/// `vtkHigherOrderWedge::PointIndexFromIJK`: vertices; edges
/// (`VTK_WEDGE_EDGES`) from first to second vertex; the inner nodes of the
/// faces (`VTK_WEDGE_FACES`), each in plain lattice or tensor order (first
/// axis fastest, no recursion); then the interior, layer by layer, each
/// layer's inner triangle in lattice order. `perm[lattice position] =
/// VTK's local number`.
pub fn vtk_wedge_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    let mut points = vertices_and_edges(Shape::Prism, p, &VTK_WEDGE_EDGES);
    points.extend(face_interiors(Shape::Prism, p, &VTK_WEDGE_FACES, |shape| {
        face_points(shape, if shape == Shape::Triangle { p - 3 } else { p - 2 })
    }));
    if p >= 3 {
        let inner = face_points(Shape::Triangle, p - 3);
        points.extend((1..p).flat_map(|k| inner.iter().map(move |&[s, t]| [s + 1, t + 1, k])));
    }
    Ok(permutation(p, &points))
}

/// The Lagrange space on the prism, on one node set. Get the shared
/// instances from [`space`].
#[derive(Clone, Debug)]
pub struct PrismSpace {
    /// Element order.
    pub p: usize,
    /// The node set.
    pub spacing: Spacing,
    /// Reference coordinates of the nodes, lattice order.
    pub nodes: Vec<[f64; 3]>,
    /// The triangle's space.
    tri: &'static SimplexSpace,
    /// The 1-D nodes.
    t: Vec<f64>,
    /// `1 / Π_{m≠k} (t_k − t_m)`.
    scale: Vec<f64>,
}

impl PrismSpace {
    /// The order-`p` space on `spacing`'s nodes.
    pub fn new(p: usize, spacing: Spacing) -> Result<Self, HighOrderError> {
        let t = nodes_1d(p, spacing)?;
        let scale = (0..=p).map(|k| 1.0 / (0..=p).filter(|&m| m != k).map(|m| t[k] - t[m]).product::<f64>()).collect();
        Ok(PrismSpace { p, spacing, nodes: prism_nodes(p, spacing)?, tri: simplex::space(Shape::Triangle, p, spacing)?, t, scale })
    }

    /// The number of nodes (basis functions).
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// The basis values and reference gradients at `ξ` into the caller's
    /// slices (each of [`PrismSpace::num_nodes`]); allocates nothing.
    ///
    /// # Panics
    /// If a slice has another length.
    pub fn eval(&self, xi: [f64; 3], values: &mut [f64], grads: &mut [[f64; 3]]) {
        let nt = triangle_count(self.p);
        assert!(values.len() == nt * (self.p + 1) && grads.len() == values.len(), "{} basis functions", nt * (self.p + 1));
        let (mut tv, mut tg) = ([0.0; 15], [[0.0; 3]; 15]);
        self.tri.eval([xi[0], xi[1], 0.0], &mut tv[..nt], &mut tg[..nt]);
        let (mut lv, mut ld) = ([0.0; MAX_ORDER + 1], [0.0; MAX_ORDER + 1]);
        for k in 0..=self.p {
            let (mut v, mut dv) = (1.0, 0.0);
            for m in (0..=self.p).filter(|&m| m != k) {
                let d = xi[2] - self.t[m];
                dv = dv * d + v;
                v *= d;
            }
            lv[k] = v * self.scale[k];
            ld[k] = dv * self.scale[k];
        }
        for k in 0..=self.p {
            for t in 0..nt {
                let n = k * nt + t;
                values[n] = tv[t] * lv[k];
                grads[n] = [tg[t][0] * lv[k], tg[t][1] * lv[k], tv[t] * ld[k]];
            }
        }
    }
}

/// The shared space of order `p` and `spacing`, built on first use
/// (Gmsh's `BasisFactory`).
pub fn space(p: usize, spacing: Spacing) -> Result<&'static PrismSpace, HighOrderError> {
    static SPACES: [OnceLock<PrismSpace>; MAX_ORDER * 2] = [const { OnceLock::new() }; MAX_ORDER * 2];
    check_order(p)?;
    let slot = (p - 1) * 2 + usize::from(spacing == Spacing::GaussLobatto);
    Ok(SPACES[slot].get_or_init(|| PrismSpace::new(p, spacing).expect("the order was checked")))
}

#[cfg(test)]
/// Tests, and the box of prisms other modules' tests draw and write
/// (`pub`: a test module as `scripts/deps.py` recognises one).
pub mod tests {
    use super::*;
    use crate::mesh::CurvedMesh;
    use std::collections::HashMap;

    /// The box `[0, n0] × [0, n1] × [0, n2]` of unit cubes, each split into
    /// two order-`p` prisms along the diagonal x + y = 1 of its square (the
    /// first with its right angle at the cube's lowest corner, the second
    /// turned half a turn about z), nodes at `spacing`'s reference nodes
    /// mapped affinely into each prism and then through `map`. Nodes of
    /// shared edges and faces are shared (found by their lattice point in
    /// the box); every prism is positively oriented before `map`. Cube `c`
    /// (x fastest) holds cells `2c` and `2c + 1`; no boundary elements.
    pub fn prism_box(p: usize, spacing: Spacing, n: [usize; 3], map: impl Fn([f64; 3]) -> [f64; 3]) -> CurvedMesh<3> {
        let reference = &space(p, spacing).unwrap().nodes;
        let mut ids: HashMap<[usize; 3], usize> = HashMap::new();
        let (mut nodes, mut cells) = (Vec::new(), Vec::new());
        for cube in 0..n.iter().product() {
            let base = [cube % n[0], cube / n[0] % n[1], cube / (n[0] * n[1])];
            for turned in [false, true] {
                let cell: Vec<usize> = lattice(p)
                    .into_iter()
                    .zip(reference)
                    .map(|([i, j, k], x)| {
                        let (i, j, u, v) = if turned { (p - i, p - j, 1.0 - x[0], 1.0 - x[1]) } else { (i, j, x[0], x[1]) };
                        let at = [p * base[0] + i, p * base[1] + j, p * base[2] + k];
                        *ids.entry(at).or_insert_with(|| {
                            nodes.push(map([base[0] as f64 + u, base[1] as f64 + v, base[2] as f64 + x[2]]));
                            nodes.len() - 1
                        })
                    })
                    .collect();
                cells.push(cell);
            }
        }
        let cells = crate::mesh::Cells::from_cells(3, p, Shape::Prism, cells);
        CurvedMesh { shape: Shape::Prism, p, spacing, nodes, cells, boundary: crate::mesh::Facets::new(), part_names: vec![] }
    }

    /// The box is a valid mesh of shared nodes, its prisms affine with
    /// det J = 1 (the map's at a point: constant on an affine cell), their
    /// volumes summing to the box's.
    #[test]
    fn the_prism_box_is_a_valid_mesh() {
        for p in 1..=MAX_ORDER {
            for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
                let m = prism_box(p, spacing, [2, 1, 2], |x| x);
                m.validate().unwrap();
                assert_eq!(m.cells.len(), 8);
                // the two prisms of a square use all of its (p+1)² grid points
                let lines = |k: usize| k * p + 1;
                assert_eq!(m.nodes.len(), lines(2) * lines(1) * lines(2), "p = {p}");
                let s = space(p, spacing).unwrap();
                let (mut v, mut g) = (vec![0.0; s.num_nodes()], vec![[0.0; 3]; s.num_nodes()]);
                let mut volume = 0.0;
                for cell in &m.cells {
                    s.eval([0.2, 0.3, 0.4], &mut v, &mut g);
                    let j: [[f64; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| cell.iter().zip(&g).map(|(&n, d)| m.nodes[n][r] * d[c]).sum()));
                    let det = j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1]) - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0])
                        + j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
                    assert!((det - 1.0).abs() < 1e-12, "p = {p} {spacing:?}: det J {det}");
                    volume += 0.5 * det;
                }
                assert!((volume - 4.0).abs() < 1e-12);
            }
        }
    }

    /// The basis interpolates: `ℓ_n(x_m) = δ_nm`, the values sum to 1 and
    /// the gradients to 0 anywhere, and it reproduces `x y² z^p`-type
    /// members of `P_p ⊗ P_p` through its nodes (here the map ξ itself
    /// and a product of the two factors' top degrees).
    #[test]
    fn the_basis_interpolates_and_reproduces_its_space() {
        for p in 1..=MAX_ORDER {
            for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
                let s = space(p, spacing).unwrap();
                let n = s.num_nodes();
                assert_eq!(n, Shape::Prism.num_nodes(p));
                let (mut v, mut g) = (vec![0.0; n], vec![[0.0; 3]; n]);
                for (m, &x) in s.nodes.iter().enumerate() {
                    s.eval(x, &mut v, &mut g);
                    for (k, &val) in v.iter().enumerate() {
                        assert!((val - f64::from(u8::from(k == m))).abs() < 1e-12, "p = {p}, ℓ_{k}(x_{m}) = {val}");
                    }
                }
                let f = |x: [f64; 3]| x[0].powi(p as i32 - 1) * x[1] * x[2].powi(p as i32) + 0.3 * x[2];
                let df = |x: [f64; 3]| {
                    let a = p as i32 - 1;
                    [
                        if a > 0 { f64::from(a) * x[0].powi(a - 1) * x[1] * x[2].powi(p as i32) } else { 0.0 },
                        x[0].powi(a) * x[2].powi(p as i32),
                        x[0].powi(a) * x[1] * p as f64 * x[2].powi(p as i32 - 1) + 0.3,
                    ]
                };
                let at = [0.21, 0.33, 0.71];
                s.eval(at, &mut v, &mut g);
                let value: f64 = v.iter().zip(&s.nodes).map(|(l, &x)| l * f(x)).sum();
                assert!((value - f(at)).abs() < 1e-12, "p = {p}: {value} vs {}", f(at));
                for d in 0..3 {
                    let grad: f64 = g.iter().zip(&s.nodes).map(|(l, &x)| l[d] * f(x)).sum();
                    assert!((grad - df(at)[d]).abs() < 1e-11, "p = {p}, ∂{d}: {grad} vs {}", df(at)[d]);
                }
            }
        }
    }

    fn is_permutation(perm: &[usize]) -> bool {
        let mut seen = vec![false; perm.len()];
        perm.iter().all(|&l| l < seen.len() && !std::mem::replace(&mut seen[l], true))
    }

    /// Both file orders list every node once, the vertices first in
    /// [`Shape::Prism`]'s order; their places against the real Gmsh and
    /// VTK are checked in `tests/it/simplex_orders.rs`.
    #[test]
    fn format_orders_are_permutations_with_vertices_first() {
        for p in 1..=MAX_ORDER {
            for perm in [gmsh_prism_order(p).unwrap(), vtk_wedge_order(p).unwrap()] {
                assert_eq!(perm.len(), Shape::Prism.num_nodes(p));
                assert!(is_permutation(&perm), "p = {p}");
                assert_eq!(vertex_nodes(p).map(|n| perm[n]), [0, 1, 2, 3, 4, 5]);
            }
        }
        assert!(gmsh_prism_order(0).is_err() && vtk_wedge_order(MAX_ORDER + 1).is_err());
    }

    fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| a[i] - b[i])
    }

    fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    }

    /// Edge nodes run from the edge's first vertex to its second at the
    /// 1-D nodes; face nodes lie on their face at the face element's own
    /// nodes (a triangle's or a quadrilateral's of the same spacing),
    /// start at the loop's vertices, and their frame points out of the
    /// prism.
    #[test]
    fn edge_and_face_nodes_follow_the_shape_tables() {
        let centre = [1.0 / 3.0, 1.0 / 3.0, 0.5];
        for p in 1..=MAX_ORDER {
            for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
                let x = prism_nodes(p, spacing).unwrap();
                let t = nodes_1d(p, spacing).unwrap();
                let v = Shape::Prism.vertices();
                for (e, &[a, b]) in Shape::Prism.edges().iter().enumerate() {
                    for (s, &n) in edge_nodes(p, e).iter().enumerate() {
                        let want: [f64; 3] = std::array::from_fn(|c| v[a][c] + t[s] * (v[b][c] - v[a][c]));
                        assert!((0..3).all(|c| (x[n][c] - want[c]).abs() < 1e-15), "p = {p} edge {e} node {s}");
                    }
                }
                let tri = simplex::simplex_nodes(Shape::Triangle, p, spacing).unwrap();
                for (f, &(shape, loop_)) in Shape::Prism.faces().iter().enumerate() {
                    let on = face_nodes(p, f);
                    assert_eq!(on.len(), shape.num_nodes(p));
                    let (a, b, c) = (v[loop_[0]], v[loop_[1]], v[loop_[loop_.len() - 1]]);
                    let (du, dv) = (sub(b, a), sub(c, a));
                    let local: Vec<[f64; 2]> = match shape {
                        Shape::Triangle => tri.iter().map(|y| [y[0], y[1]]).collect(),
                        _ => (0..=p).flat_map(|j| (0..=p).map(move |i| [i, j])).map(|[i, j]| [t[i], t[j]]).collect(),
                    };
                    for (&n, [s, r]) in on.iter().zip(local) {
                        let want: [f64; 3] = std::array::from_fn(|k| a[k] + s * du[k] + r * dv[k]);
                        assert!((0..3).all(|k| (x[n][k] - want[k]).abs() < 1e-15), "p = {p} {spacing:?} face {f}");
                    }
                    for (k, &corner) in loop_.iter().enumerate() {
                        let at = match shape {
                            Shape::Triangle => [0, p, on.len() - 1][k],
                            _ => [0, p, (p + 1) * (p + 1) - 1, p * (p + 1)][k],
                        };
                        assert_eq!(x[on[at]], v[corner], "face {f} corner {k}");
                    }
                    let normal = cross(du, dv);
                    let out: f64 = (0..3).map(|k| normal[k] * (a[k] - centre[k])).sum();
                    assert!(out > 0.0, "face {f} points inward");
                }
            }
        }
    }

    /// The sub-prisms tile the reference prism: p³ of them, each of
    /// volume 1/(2p³) and positive orientation, and every lattice node is
    /// a corner of one.
    #[test]
    fn the_sub_prisms_tile_the_lattice() {
        for p in 1..=MAX_ORDER {
            let x = prism_nodes(p, Spacing::Equispaced).unwrap();
            let subs = sub_prisms(p);
            assert_eq!(subs.len(), p * p * p);
            let mut seen = vec![false; x.len()];
            for s in &subs {
                let c = s.map(|n| x[n]);
                // base triangle area (signed) times height
                let area = 0.5 * ((c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[1][1] - c[0][1]) * (c[2][0] - c[0][0]));
                let h = c[3][2] - c[0][2];
                assert!((area * h - 0.5 / (p * p * p) as f64).abs() < 1e-14, "p = {p}: {s:?}");
                assert!((0..3).all(|a| c[a + 3][0] == c[a][0] && c[a + 3][1] == c[a][1]), "upright");
                s.iter().for_each(|&n| seen[n] = true);
            }
            assert!(seen.iter().all(|&b| b));
            let v = vertex_nodes(p);
            for (a, &n) in v.iter().enumerate() {
                assert_eq!(x[n], Shape::Prism.vertices()[a]);
            }
            assert_eq!(lattice(p).len(), x.len());
            assert!(lattice(p).iter().enumerate().all(|(n, &m)| lattice_index(p, m) == n));
        }
    }
}
