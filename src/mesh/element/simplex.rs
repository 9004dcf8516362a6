//! Lagrange spaces `P_p` on the simplices (point, line, triangle,
//! tetrahedron) of order `p = 1..=MAX_ORDER`: the node lattice and its
//! order, the two node sets, the basis, the subdivision of the lattice
//! into sub-simplices, the nodes on edges and faces, and the node orders
//! of Gmsh and VTK.
//!
//! **The lattice order** (fixed: the crate keeps simplex nodes in it). A
//! node is a multi-index `(i, j, k)`, `i + j + k ≤ p`, unused entries 0:
//! a line has `i = 0..=p`; a triangle `(i, j)` with `j` outer and `i`
//! inner (`for j in 0..=p { for i in 0..=p-j }`); a tetrahedron `(i, j, k)`
//! with `k` outermost, then `j`, `i` fastest. The equispaced node is
//! `(i, j, k) / p`. Its barycentric index is `(p − i − j − k, i, j, k)`:
//! one entry per vertex of [`Shape::vertices`] (vertex 0 at the origin,
//! vertex `a ≥ 1` at the unit point of axis `a − 1`); the vertices, edges
//! and faces a node lies on are those of its non-zero entries.
//!
//! **Node sets.** [`Spacing::Equispaced`]: the lattice over `p`.
//! [`Spacing::GaussLobatto`]: Warburton's warp & blend nodes ("An explicit
//! construction of interpolation nodes on the simplex", J. Eng. Math.
//! 2006), built on the 1-D Gauss–Lobatto points of [`nodes_1d`]:
//! - a node on an edge sits at the 1-D node of its index along the edge,
//!   set exactly (not through the warp formula, which gives it only up to
//!   rounding), so a triangle's edge carries the very values of a
//!   neighbouring quad's edge;
//! - a node inside a triangle, or inside a face of a tetrahedron, is
//!   warped and blended in the triangle's barycentric coordinates with his
//!   α-optimised parameter (`α = 1.4152` for p = 3, `0.1001` for p = 4, as
//!   in `Nodes2D` of Hesthaven & Warburton's book; α does not matter for
//!   p ≤ 3, whose only interior triangle node is the centroid);
//! - a tetrahedron takes the triangle's set on each face, so a tet face, a
//!   boundary triangle and the triangles of a neighbouring element carry
//!   the same nodes. Warburton's 3-D construction would warp the faces
//!   with its own α (0.1002 for p = 4, against 0.1001 in 2-D; `Nodes3D`
//!   of the book): nearly the same face nodes, but not a triangle's. For
//!   `p ≤ 4` the one node inside a
//!   tetrahedron (p = 4) is its centroid, by symmetry.
//!
//! Every node set holds the vertices exactly and is symmetric under the
//! permutations of the vertices: each node is computed from its sorted
//! barycentric index and put back, and the warp factor is odd by
//! construction, so mirrored nodes are mirrored to the last bit in the
//! barycentric coordinates they are computed in (the stored `ξ` are
//! `λ_1..λ_d`; `λ_0 = 1 − Σ ξ` comes back to rounding).
//!
//! **Basis.** `ℓ_i = Σ_m C_{m i} φ_m` with the monomials `φ_m(ξ) = (ξ − c)^m`
//! about the centroid `c`, over the lattice's own multi-indices `m` (which
//! are the exponents of `P_p`), and `C = V⁻¹` the inverse of the
//! Vandermonde `V_{r m} = φ_m(x_r)` at the nodes, computed once per space.
//! For `p ≤ 4` (at most 35 monomials) centred monomials are conditioned
//! well enough (the tests reproduce degree-p polynomials to 1e-11); an
//! orthogonal Dubiner basis would only matter at higher orders.

use std::sync::OnceLock;

use super::{check_order, nodes_1d, Basis1d, HighOrderError, Shape, Spacing, MAX_ORDER};

/// The dimension of a simplex shape.
///
/// # Panics
/// For a shape that is not a simplex: the callers dispatch on
/// [`Shape::is_simplex`], so any other shape is a bug of theirs.
fn simplex_dim(shape: Shape) -> usize {
    assert!(shape.is_simplex(), "{shape:?} is not a simplex");
    shape.dim()
}

/// `C(q + d, d)`: the number of nodes of an order-`q` `d`-simplex.
fn count(d: usize, q: usize) -> usize {
    (1..=d).fold(1, |n, k| n * (q + k) / k)
}

/// The multi-indices of the order-`p` lattice of `shape` (a simplex), in
/// the lattice order (module docs). Any `p ≥ 0` (0: the one node).
pub fn lattice(shape: Shape, p: usize) -> Vec<[usize; 3]> {
    let d = simplex_dim(shape);
    let top = |axis: usize, left: usize| if axis < d { left } else { 0 };
    let mut out = Vec::with_capacity(count(d, p));
    for k in 0..=top(2, p) {
        for j in 0..=top(1, p - k) {
            for i in 0..=top(0, p - k - j) {
                out.push([i, j, k]);
            }
        }
    }
    out
}

/// The position of multi-index `m` in [`lattice`]`(shape, p)`: the layers
/// below `k`, the rows below `j` in its layer, then `i`.
///
/// # Panics
/// If `m` is not in the lattice (`i + j + k > p`, or an entry beyond the
/// shape's dimension is not 0).
pub fn lattice_index(shape: Shape, p: usize, m: [usize; 3]) -> usize {
    let d = simplex_dim(shape);
    let [i, j, k] = m;
    assert!(i + j + k <= p && m[d..].iter().all(|&x| x == 0), "{m:?} is not in the order-{p} {shape:?} lattice");
    let q = p - k;
    (count(3, p) - count(3, q)) + (count(2, q) - count(2, q - j)) + i
}

/// The positions in [`lattice`]`(shape, p)` of the vertices of `shape`, in
/// the shape's vertex order.
pub fn vertex_nodes(shape: Shape, p: usize) -> Vec<usize> {
    (0..shape.vertices().len()).map(|v| lattice_index(shape, p, vertex_point(shape, p, v))).collect()
}

/// The barycentric index `(p − i − j − k, i, j, k)` of multi-index `m`.
fn barycentric(m: [usize; 3], p: usize) -> [usize; 4] {
    [p - m[0] - m[1] - m[2], m[0], m[1], m[2]]
}

/// The lattice point of vertex `v` of `shape`: `p` times its coordinates.
fn vertex_point(shape: Shape, p: usize, v: usize) -> [usize; 3] {
    shape.vertices()[v].map(|x| x as usize * p)
}

/// `a + (s (b − a) + t (c − a)) / p` for lattice points; exact, as the
/// differences of vertex points are multiples of `p`.
fn combine(p: usize, [a, b, c]: [[usize; 3]; 3], s: usize, t: usize) -> [usize; 3] {
    std::array::from_fn(|x| {
        let (a, b, c) = (a[x] as isize, b[x] as isize, c[x] as isize);
        (a + (s as isize * (b - a) + t as isize * (c - a)) / p as isize) as usize
    })
}

/// The lattice positions on edge `edge` of [`Shape::edges`], from its
/// first vertex to its second (`p + 1` of them): the edge element of
/// order `p` in its own (line) lattice order.
pub fn edge_nodes(shape: Shape, p: usize, edge: usize) -> Vec<usize> {
    let [a, b] = shape.edges()[edge];
    let v = [vertex_point(shape, p, a), vertex_point(shape, p, b), vertex_point(shape, p, a)];
    (0..=p).map(|s| lattice_index(shape, p, combine(p, v, s, 0))).collect()
}

/// The lattice positions on face `face` of [`Shape::faces`] (a
/// triangle's one face is itself), in the lattice order of a triangle
/// whose vertices (0,0), (1,0), (0,1) are the face's loop: the boundary
/// triangle of order `p` as the cell sees it, oriented outward.
pub fn face_nodes(shape: Shape, p: usize, face: usize) -> Vec<usize> {
    let loop_ = shape.faces()[face].1;
    let v = [0, 1, 2].map(|a| vertex_point(shape, p, loop_[a]));
    lattice(Shape::Triangle, p).into_iter().map(|[s, t, _]| lattice_index(shape, p, combine(p, v, s, t))).collect()
}

/// The reference coordinates of the order-`p` nodes of `shape` (a
/// simplex) in lattice order, for either spacing (module docs).
pub fn simplex_nodes(shape: Shape, p: usize, spacing: Spacing) -> Result<Vec<[f64; 3]>, HighOrderError> {
    check_order(p)?;
    let points = lattice(shape, p);
    Ok(match spacing {
        Spacing::Equispaced => points.into_iter().map(|m| m.map(|i| i as f64 / p as f64)).collect(),
        Spacing::GaussLobatto => {
            let warp = WarpBlend::new(p)?;
            points
                .into_iter()
                .map(|m| {
                    let l = warp.barycentric(barycentric(m, p));
                    [l[1], l[2], l[3]]
                })
                .collect()
        }
    })
}

/// Warburton's warp & blend construction of order `p` (module docs).
struct WarpBlend {
    p: usize,
    /// The 1-D Gauss–Lobatto nodes on `[0,1]`.
    t: Vec<f64>,
    /// The equispaced Lagrange basis on `[0,1]` that interpolates the warp.
    equi: Basis1d,
    /// `r_i^GLL − r_i^eq` on `[-1,1]`: what the warp moves 1-D node `i` by.
    shift: Vec<f64>,
    /// His optimised α for this order (`alpopt` of `Nodes2D`).
    alpha: f64,
}

impl WarpBlend {
    fn new(p: usize) -> Result<Self, HighOrderError> {
        let t = nodes_1d(p, Spacing::GaussLobatto)?;
        let eq = nodes_1d(p, Spacing::Equispaced)?;
        let shift = t.iter().zip(&eq).map(|(g, e)| 2.0 * (g - e)).collect();
        let alpha = [0.0, 0.0, 1.4152, 0.1001][p - 1];
        Ok(WarpBlend { p, t, equi: Basis1d::new(p, Spacing::Equispaced)?, shift, alpha })
    }

    /// The warp factor at `r ∈ (-1,1)`: the interpolated shift over
    /// `1 − r²` (the blend `4 λ_a λ_b` restores it on the edge). Evaluated
    /// at `|r|` and signed, so it is odd to the last bit.
    fn factor(&self, r: f64) -> f64 {
        let x = r.abs();
        let (l, _) = self.equi.eval(0.5 * (1.0 + x));
        let w: f64 = l.iter().zip(&self.shift).map(|(l, s)| l * s).sum();
        (w / (1.0 - x * x)).copysign(r)
    }

    /// The barycentric coordinates of the node of barycentric index `b`:
    /// exact on vertices and edges, warped inside triangles (and tet
    /// faces), the centroid inside a tetrahedron.
    fn barycentric(&self, b: [usize; 4]) -> [f64; 4] {
        let mut on = [0usize; 4];
        let mut n = 0;
        for (a, &x) in b.iter().enumerate() {
            if x > 0 {
                on[n] = a;
                n += 1;
            }
        }
        let mut l = [0.0; 4];
        match n {
            // a vertex, or an edge node at its 1-D node (t[p−i] = 1 − t[i]
            // exactly, so the two coordinates sum to 1)
            1 | 2 => (0..n).for_each(|k| l[on[k]] = self.t[b[on[k]]]),
            3 => {
                let w = self.triangle([b[on[0]], b[on[1]], b[on[2]]]);
                (0..3).for_each(|k| l[on[k]] = w[k]);
            }
            _ => {
                // the only interior lattice point of a tet of order ≤ 4
                assert!(b == [1; 4], "no interior tetrahedron nodes beyond order {MAX_ORDER}: {b:?}");
                l = [0.25; 4];
            }
        }
        l
    }

    /// The warped barycentric coordinates of the triangle node with
    /// barycentric index `m` (all > 0), computed from `m` sorted
    /// (descending) so that permuted indices give permuted results.
    fn triangle(&self, m: [usize; 3]) -> [f64; 3] {
        let mut order = [0, 1, 2];
        order.sort_by_key(|&a| std::cmp::Reverse(m[a]));
        let lam = order.map(|a| m[a] as f64 / self.p as f64);
        let mut out = lam;
        // each edge (a → b, opposite c) moves the node along itself; an
        // edge of length 2 in Warburton's equilateral triangle, so a warp
        // w changes λ_b − λ_a by w
        for (a, b, c) in [(0, 1, 2), (1, 2, 0), (2, 0, 1)] {
            let blend = 4.0 * lam[a] * lam[b] * (1.0 + (self.alpha * lam[c]).powi(2));
            let w = blend * self.factor(lam[b] - lam[a]);
            out[b] += 0.5 * w;
            out[a] -= 0.5 * w;
        }
        let mut res = [0.0; 3];
        (0..3).for_each(|k| res[order[k]] = out[k]);
        res
    }
}

/// The Lagrange space `P_p` on a simplex, on one node set: nodes and basis
/// (module docs). Get the shared instances from [`space`].
#[derive(Clone, Debug, PartialEq)]
pub struct SimplexSpace {
    /// [`Shape::Point`], [`Shape::Line`], [`Shape::Triangle`] or
    /// [`Shape::Tetrahedron`].
    pub shape: Shape,
    /// Element order.
    pub p: usize,
    /// The node set.
    pub spacing: Spacing,
    /// Reference coordinates of the nodes, lattice order (unused
    /// coordinates 0).
    pub nodes: Vec<[f64; 3]>,
    /// The monomial exponents: the lattice's multi-indices.
    exponents: Vec<[usize; 3]>,
    /// The centre of the monomials (the reference centroid).
    center: [f64; 3],
    /// `V⁻¹`, row `m` (monomial) holding `C_{m i}` for every node `i`.
    coef: Vec<f64>,
}

impl SimplexSpace {
    /// The order-`p` space of `shape` on `spacing`'s nodes.
    ///
    /// # Panics
    /// If `shape` is not a simplex.
    pub fn new(shape: Shape, p: usize, spacing: Spacing) -> Result<Self, HighOrderError> {
        let nodes = simplex_nodes(shape, p, spacing)?;
        let exponents = lattice(shape, p);
        let vertices = shape.vertices();
        let center = std::array::from_fn(|x| vertices.iter().map(|v| v[x]).sum::<f64>() / vertices.len() as f64);
        let n = nodes.len();
        let mut vander = vec![0.0; n * n];
        for (r, x) in nodes.iter().enumerate() {
            for (m, e) in exponents.iter().enumerate() {
                vander[r * n + m] = (0..3).map(|d| (x[d] - center[d]).powi(e[d] as i32)).product();
            }
        }
        let coef = invert(vander, n);
        Ok(SimplexSpace { shape, p, spacing, nodes, exponents, center, coef })
    }

    /// The number of nodes (basis functions).
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// The basis values `values[i] = ℓ_i(ξ)` and reference gradients
    /// `grads[i] = ∇_ξ ℓ_i(ξ)` (entries beyond the dimension 0) at any
    /// `ξ`, into the caller's slices; allocates nothing.
    ///
    /// # Panics
    /// If a slice's length is not [`SimplexSpace::num_nodes`].
    pub fn eval(&self, xi: [f64; 3], values: &mut [f64], grads: &mut [[f64; 3]]) {
        let n = self.nodes.len();
        assert!(values.len() == n && grads.len() == n, "{n} basis functions, slices of {} and {}", values.len(), grads.len());
        // powers u^e and e u^(e-1) of each centred coordinate
        let mut pow = [[1.0; MAX_ORDER + 1]; 3];
        let mut dpow = [[0.0; MAX_ORDER + 1]; 3];
        for d in 0..3 {
            let u = xi[d] - self.center[d];
            for e in 1..=self.p {
                dpow[d][e] = e as f64 * pow[d][e - 1];
                pow[d][e] = pow[d][e - 1] * u;
            }
        }
        values.fill(0.0);
        grads.fill([0.0; 3]);
        for (e, row) in self.exponents.iter().zip(self.coef.chunks_exact(n)) {
            let [a, b, c] = *e;
            let phi = pow[0][a] * pow[1][b] * pow[2][c];
            let dphi = [dpow[0][a] * pow[1][b] * pow[2][c], pow[0][a] * dpow[1][b] * pow[2][c], pow[0][a] * pow[1][b] * dpow[2][c]];
            for ((v, g), &w) in values.iter_mut().zip(grads.iter_mut()).zip(row) {
                *v += w * phi;
                (0..3).for_each(|d| g[d] += w * dphi[d]);
            }
        }
    }
}

/// The inverse of the `n × n` row-major matrix `a`, by Gauss–Jordan
/// elimination with partial pivoting.
///
/// # Panics
/// If `a` is singular: a Vandermonde at a unisolvent node set never is.
fn invert(mut a: Vec<f64>, n: usize) -> Vec<f64> {
    let mut inv = vec![0.0; n * n];
    (0..n).for_each(|i| inv[i * n + i] = 1.0);
    for col in 0..n {
        let pivot = (col..n).max_by(|&r, &s| a[r * n + col].abs().total_cmp(&a[s * n + col].abs())).expect("rows left");
        assert!(a[pivot * n + col].abs() > 1e-300, "the nodes are not unisolvent");
        for k in 0..n {
            a.swap(col * n + k, pivot * n + k);
            inv.swap(col * n + k, pivot * n + k);
        }
        let scale = 1.0 / a[col * n + col];
        for k in 0..n {
            a[col * n + k] *= scale;
            inv[col * n + k] *= scale;
        }
        for r in (0..n).filter(|&r| r != col) {
            let f = a[r * n + col];
            if f != 0.0 {
                for k in 0..n {
                    a[r * n + k] -= f * a[col * n + k];
                    inv[r * n + k] -= f * inv[col * n + k];
                }
            }
        }
    }
    inv
}

/// One slot per simplex shape (point, line, triangle, tetrahedron), order
/// and spacing.
const SLOTS: usize = 4 * MAX_ORDER * 2;

/// The shared space of `shape` (a simplex), order `p` and `spacing`,
/// built on first use and kept for the program's life (Gmsh's
/// `BasisFactory`).
///
/// # Panics
/// If `shape` is not a simplex.
pub fn space(shape: Shape, p: usize, spacing: Spacing) -> Result<&'static SimplexSpace, HighOrderError> {
    static SPACES: [OnceLock<SimplexSpace>; SLOTS] = [const { OnceLock::new() }; SLOTS];
    check_order(p)?;
    let s = match spacing {
        Spacing::Equispaced => 0,
        Spacing::GaussLobatto => 1,
    };
    let slot = (simplex_dim(shape) * MAX_ORDER + p - 1) * 2 + s;
    Ok(SPACES[slot].get_or_init(|| SimplexSpace::new(shape, p, spacing).expect("the order was checked")))
}

/// `a + Σ e_x` over the axes `x` listed.
fn plus(a: [usize; 3], axes: &[usize]) -> [usize; 3] {
    let mut out = a;
    axes.iter().for_each(|&x| out[x] += 1);
    out
}

/// The integer determinant of the sub-simplex's edge vectors from its
/// first vertex (dimension `d`).
fn lattice_det(d: usize, v: &[[usize; 3]]) -> i64 {
    let e: Vec<[i64; 3]> = v[1..=d].iter().map(|x| std::array::from_fn(|c| x[c] as i64 - v[0][c] as i64)).collect();
    match d {
        0 => 1,
        1 => e[0][0],
        2 => e[0][0] * e[1][1] - e[0][1] * e[1][0],
        _ => {
            e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
                + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0])
        }
    }
}

/// The subdivision of the order-`p` lattice of `shape` (a simplex) into
/// `p^d` sub-simplices with lattice positions as vertices (a triangle uses
/// the first 3, a line the first 2; the rest are 0), every one oriented
/// like the reference cell (positive determinant).
///
/// Per base point `a` (lattice order, `|a| ≤ p − 1`): the upright copy
/// `a, a+e₁, a+e₂(, a+e₃)`; on a triangle with `|a| ≤ p − 2` the inverted
/// one `a+e₁, a+e₁+e₂, a+e₂`; on a tetrahedron with `|a| ≤ p − 2` the
/// octahedron `a+e₁, a+e₂, a+e₃, a+e₁+e₂, a+e₁+e₃, a+e₂+e₃`, split into 4
/// around its diagonal `a+e₂ — a+e₁+e₃` (VTK's `vtkHigherOrderTetra`
/// "linearization 0"; all three diagonals are equally long in the
/// reference cell), and with `|a| ≤ p − 3` the inverted tetrahedron
/// `a+e₁+e₂, a+e₁+e₃, a+e₂+e₃, a+e₁+e₂+e₃`.
pub fn sub_simplices(shape: Shape, p: usize) -> Vec<[usize; 4]> {
    let d = simplex_dim(shape);
    if d == 0 || p == 0 {
        return vec![[0; 4]];
    }
    let mut cells: Vec<Vec<[usize; 3]>> = Vec::with_capacity(p.pow(d as u32));
    for a in lattice(shape, p - 1) {
        let level = a.iter().sum::<usize>();
        cells.push(std::iter::once(a).chain((0..d).map(|x| plus(a, &[x]))).collect());
        match d {
            2 if level + 2 <= p => cells.push(vec![plus(a, &[0]), plus(a, &[0, 1]), plus(a, &[1])]),
            3 if level + 2 <= p => {
                let (top, bottom) = (plus(a, &[1]), plus(a, &[0, 2]));
                let ring = [plus(a, &[0]), plus(a, &[0, 1]), plus(a, &[1, 2]), plus(a, &[2])];
                cells.extend((0..4).map(|r| vec![top, bottom, ring[r], ring[(r + 1) % 4]]));
                if level + 3 <= p {
                    cells.push(vec![plus(a, &[0, 1]), plus(a, &[0, 2]), plus(a, &[1, 2]), plus(a, &[0, 1, 2])]);
                }
            }
            _ => {}
        }
    }
    cells.into_iter().map(|mut v| orient_and_index(shape, p, d, &mut v)).collect()
}

/// Swaps the last two vertices of a negatively oriented sub-simplex and
/// returns its lattice positions.
fn orient_and_index(shape: Shape, p: usize, d: usize, v: &mut [[usize; 3]]) -> [usize; 4] {
    let det = lattice_det(d, v);
    debug_assert!(det != 0, "degenerate sub-simplex {v:?}");
    if det < 0 {
        v.swap(d - 1, d);
    }
    let mut out = [0; 4];
    for (o, x) in out.iter_mut().zip(v.iter()) {
        *o = lattice_index(shape, p, *x);
    }
    out
}

/// VTK's tetrahedron edges (`EdgeVertices` of `vtkHigherOrderTetra`, also
/// `vtkTetra`'s): its edge nodes run from first to second vertex.
const VTK_TET_EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]];

/// VTK's tetrahedron faces as the vertex loops its face nodes are laid out
/// on, from `FaceBCoords` of `vtkHigherOrderTetra` (face `f`'s triangle
/// barycentric coordinate `c` is the tet's `FaceBCoords[f][c]`; the
/// triangle's vertex 0 is where its coordinate 2 is largest, vertex 1 its
/// coordinate 0, vertex 2 its coordinate 1; the tet's coordinate 3 is
/// vertex 0, coordinates 0, 1, 2 vertices 1, 2, 3): faces y = 0, the
/// slanted one, x = 0, z = 0 — `vtkTetra`'s faces, in its order.
const VTK_TET_FACES: [[usize; 3]; 4] = [[0, 1, 3], [2, 3, 1], [0, 3, 2], [0, 2, 1]];

/// The lattice points `(s, t)` of an order-`q` triangle in the order Gmsh
/// (`gmshGenerateMonomialsTriangle`) and VTK
/// (`vtkHigherOrderTriangle::SetParametricCoords`) both use: vertices,
/// the inner nodes of edges (0,1), (1,2), (2,0) from first to second
/// vertex, then the interior as a triangle of order `q − 3` shifted by
/// (1, 1), recursively. `q = 0`: the single node of a recursion.
fn format_triangle(q: usize) -> Vec<[usize; 3]> {
    if q == 0 {
        return vec![[0; 3]];
    }
    let v: Vec<[usize; 3]> = (0..3).map(|a| vertex_point(Shape::Triangle, q, a)).collect();
    let mut out = v.clone();
    for &[a, b] in Shape::Triangle.edges() {
        out.extend((1..q).map(|s| combine(q, [v[a], v[b], v[a]], s, 0)));
    }
    if q >= 3 {
        out.extend(format_triangle(q - 3).into_iter().map(|x| plus(x, &[0, 1])));
    }
    out
}

/// The lattice points of an order-`q` tetrahedron in a format's order:
/// vertices, the inner nodes of each edge of `edges` (first to second
/// vertex), the inner nodes of each face of `faces` as an order-`q − 3`
/// triangle in [`format_triangle`]'s order on the face's loop (shifted one
/// node in from each side), then the interior as an order-`q − 4`
/// tetrahedron shifted by (1,1,1), recursively — the rules of both Gmsh
/// (`gmshGenerateMonomialsTetrahedron`) and VTK
/// (`vtkHigherOrderTetra::BarycentricIndex`), which differ in the tables.
fn format_tet(q: usize, edges: &[[usize; 2]], faces: &[[usize; 3]]) -> Vec<[usize; 3]> {
    if q == 0 {
        return vec![[0; 3]];
    }
    let v: Vec<[usize; 3]> = (0..4).map(|a| vertex_point(Shape::Tetrahedron, q, a)).collect();
    let mut out = v.clone();
    for &[a, b] in edges {
        out.extend((1..q).map(|s| combine(q, [v[a], v[b], v[a]], s, 0)));
    }
    if q >= 3 {
        let inner = format_triangle(q - 3);
        for &[a, b, c] in faces {
            out.extend(inner.iter().map(|&[s, t, _]| combine(q, [v[a], v[b], v[c]], s + 1, t + 1)));
        }
    }
    if q >= 4 {
        out.extend(format_tet(q - 4, edges, faces).into_iter().map(|x| plus(x, &[0, 1, 2])));
    }
    out
}

/// `perm[lattice position] = place in points`.
fn permutation(shape: Shape, p: usize, points: &[[usize; 3]]) -> Vec<usize> {
    let mut perm = vec![usize::MAX; points.len()];
    for (local, &m) in points.iter().enumerate() {
        let at = lattice_index(shape, p, m);
        debug_assert_eq!(perm[at], usize::MAX, "node {m:?} listed twice");
        perm[at] = local;
    }
    debug_assert_eq!(points.len(), shape.num_nodes(p));
    perm
}

/// The faces of Gmsh's tetrahedron ([`Shape::faces`]) as loops.
fn gmsh_tet_faces() -> Vec<[usize; 3]> {
    Shape::Tetrahedron.faces().iter().map(|f| [f.1[0], f.1[1], f.1[2]]).collect()
}

/// Gmsh's order of an order-`p` triangle (MSH types 2, 9, 21, 23):
/// `perm[lattice position] = Gmsh's local node number`, for
/// [`super::to_format`] / [`super::from_format`]. Vertices, edge nodes
/// along [`Shape::edges`], then the interior recursively.
pub fn gmsh_triangle_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    Ok(permutation(Shape::Triangle, p, &format_triangle(p)))
}

/// Gmsh's order of an order-`p` tetrahedron (MSH types 4, 11, 29, 30):
/// vertices, edge nodes along Gmsh's edges (0,1) (1,2) (2,0) (3,0) (3,2)
/// (3,1), face nodes per face (0,2,1) (0,1,3) (0,3,2) (3,1,2), each laid
/// out like a triangle of order `p − 3` on the face's loop, then the
/// interior. `perm[lattice position] = local number`.
pub fn gmsh_tet_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    Ok(permutation(Shape::Tetrahedron, p, &format_tet(p, Shape::Tetrahedron.edges(), &gmsh_tet_faces())))
}

/// VTK's order of an order-`p` Lagrange triangle (`VTK_LAGRANGE_TRIANGLE`
/// = 69; order 1 is the linear `VTK_TRIANGLE`'s): the same as Gmsh's for
/// every order here (`vtkHigherOrderTriangle` lists vertices, edges
/// (0,1) (1,2) (2,0) along their direction, then the interior triangle,
/// recursively). `perm[lattice position] = local number`.
pub fn vtk_triangle_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    Ok(permutation(Shape::Triangle, p, &format_triangle(p)))
}

/// VTK's order of an order-`p` Lagrange tetrahedron
/// (`VTK_LAGRANGE_TETRAHEDRON` = 71; the 10-node order 2, not VTK's
/// special 15-node cell): vertices, edges (0,1) (1,2) (2,0) (0,3) (1,3)
/// (2,3) from first to second vertex, faces (0,1,3) (2,3,1) (0,3,2) (0,2,1)
/// (see `VTK_TET_FACES`), then the interior. `perm[lattice position] =
/// local number`.
pub fn vtk_tet_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    Ok(permutation(Shape::Tetrahedron, p, &format_tet(p, &VTK_TET_EDGES, &VTK_TET_FACES)))
}


#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::{BTreeSet, HashMap};

    const SIMPLICES: [Shape; 3] = [Shape::Line, Shape::Triangle, Shape::Tetrahedron];
    const SPACINGS: [Spacing; 2] = [Spacing::Equispaced, Spacing::GaussLobatto];

    /// A deterministic pseudo-random number in [0, 1).
    fn rand01(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    /// The barycentric coordinates of a reference point of a `d`-simplex.
    fn bary_of(x: [f64; 3], d: usize) -> [f64; 4] {
        let mut l = [0.0; 4];
        l[0] = 1.0 - x[..d].iter().sum::<f64>();
        l[1..=d].copy_from_slice(&x[..d]);
        l
    }

    /// All permutations of `0..n`.
    fn permutations(n: usize) -> Vec<Vec<usize>> {
        if n == 0 {
            return vec![vec![]];
        }
        permutations(n - 1)
            .into_iter()
            .flat_map(|q| (0..n).map(move |at| {
                let mut r = q.clone();
                r.insert(at, n - 1);
                r
            }))
            .collect()
    }

    #[test]
    fn lattice_is_in_the_documented_order() {
        for p in 0..=5 {
            let tri: Vec<[usize; 3]> = (0..=p).flat_map(|j| (0..=p - j).map(move |i| [i, j, 0])).collect();
            assert_eq!(lattice(Shape::Triangle, p), tri);
            let tet: Vec<[usize; 3]> = (0..=p)
                .flat_map(|k| (0..=p - k).flat_map(move |j| (0..=p - k - j).map(move |i| [i, j, k])))
                .collect();
            assert_eq!(lattice(Shape::Tetrahedron, p), tet);
            assert_eq!(lattice(Shape::Line, p), (0..=p).map(|i| [i, 0, 0]).collect::<Vec<_>>());
            assert_eq!(lattice(Shape::Point, p), vec![[0; 3]]);
            for shape in SIMPLICES {
                let l = lattice(shape, p);
                assert_eq!(l.len(), shape.num_nodes(p));
                for (a, &m) in l.iter().enumerate() {
                    assert_eq!(lattice_index(shape, p, m), a, "{shape:?} p={p} {m:?}");
                }
            }
        }
    }

    #[test]
    #[should_panic(expected = "not in the order-2")]
    fn points_off_the_lattice_have_no_index() {
        lattice_index(Shape::Triangle, 2, [1, 1, 1]);
    }

    #[test]
    fn nodes_hold_the_vertices_exactly_and_are_symmetric() {
        for shape in SIMPLICES {
            let d = shape.dim();
            for p in 1..=MAX_ORDER {
                let lat = lattice(shape, p);
                for spacing in SPACINGS {
                    let nodes = simplex_nodes(shape, p, spacing).unwrap();
                    for v in 0..=d {
                        let at = lattice_index(shape, p, vertex_point(shape, p, v));
                        assert_eq!(nodes[at], shape.vertices()[v], "{shape:?} p={p} {spacing:?}");
                    }
                    // the node of index σ(b) is σ applied to node b
                    let at: HashMap<[usize; 4], usize> = lat.iter().enumerate().map(|(a, &m)| (barycentric(m, p), a)).collect();
                    for sigma in permutations(d + 1) {
                        for (a, &m) in lat.iter().enumerate() {
                            let (b, l) = (barycentric(m, p), bary_of(nodes[a], d));
                            let mut sb = [0; 4];
                            let mut sl = [0.0; 4];
                            (0..=d).for_each(|v| (sb[sigma[v]], sl[sigma[v]]) = (b[v], l[v]));
                            let image = bary_of(nodes[at[&sb]], d);
                            assert!((0..=d).all(|v| (image[v] - sl[v]).abs() < 2e-16), "{shape:?} p={p} {spacing:?} {b:?} σ={sigma:?}");
                        }
                    }
                }
            }
        }
    }

    /// A node on an edge has the 1-D nodes of its barycentric index as
    /// barycentric coordinates: bit for bit in the stored coordinates
    /// (`λ_v = ξ_{v−1}`, v ≥ 1), to rounding in `λ_0 = 1 − Σ ξ`. So the
    /// parameter along the edge, from either end, is a 1-D node.
    #[test]
    fn edge_nodes_are_the_1d_nodes_and_tet_faces_the_triangle_nodes() {
        for p in 1..=MAX_ORDER {
            for spacing in SPACINGS {
                let t = nodes_1d(p, spacing).unwrap();
                for shape in SIMPLICES {
                    let (d, lat) = (shape.dim(), lattice(shape, p));
                    let nodes = simplex_nodes(shape, p, spacing).unwrap();
                    for e in 0..shape.edges().len() {
                        for &at in &edge_nodes(shape, p, e) {
                            let b = barycentric(lat[at], p);
                            let want: [f64; 3] = std::array::from_fn(|c| if c < d { t[b[c + 1]] } else { 0.0 });
                            assert_eq!(nodes[at], want, "{shape:?} p={p} {spacing:?} edge {e} node {b:?}");
                            assert!((bary_of(nodes[at], d)[0] - t[b[0]]).abs() <= f64::EPSILON / 2.0);
                        }
                    }
                }
                let tri = simplex_nodes(Shape::Triangle, p, spacing).unwrap();
                let tet = simplex_nodes(Shape::Tetrahedron, p, spacing).unwrap();
                for (f, face) in Shape::Tetrahedron.faces().iter().enumerate() {
                    let v = face.1.iter().map(|&k| Shape::Tetrahedron.vertices()[k]).collect::<Vec<_>>();
                    for (&at, x) in face_nodes(Shape::Tetrahedron, p, f).iter().zip(&tri) {
                        let want: [f64; 3] = std::array::from_fn(|c| v[0][c] + x[0] * (v[1][c] - v[0][c]) + x[1] * (v[2][c] - v[0][c]));
                        assert!((0..3).all(|c| (tet[at][c] - want[c]).abs() < 3e-16), "p={p} {spacing:?} face {f}: {:?} vs {want:?}", tet[at]);
                    }
                }
            }
        }
    }

    /// The triangle's warped interior nodes of p = 4 move off the
    /// equispaced lattice, and the warp lowers the Lebesgue constant (the
    /// point of the construction; a wrong sign of the warp raises it).
    #[test]
    fn warp_blend_nodes_lower_the_lebesgue_constant() {
        let lebesgue = |shape: Shape, p: usize, spacing: Spacing| {
            let s = space(shape, p, spacing).unwrap();
            let (mut v, mut g) = (vec![0.0; s.num_nodes()], vec![[0.0; 3]; s.num_nodes()]);
            let m = 40;
            let mut worst = 0.0f64;
            for x in lattice(shape, m) {
                s.eval(x.map(|i| i as f64 / m as f64), &mut v, &mut g);
                worst = worst.max(v.iter().map(|l| l.abs()).sum());
            }
            worst
        };
        for shape in [Shape::Triangle, Shape::Tetrahedron] {
            for p in 3..=MAX_ORDER {
                let (eq, gl) = (lebesgue(shape, p, Spacing::Equispaced), lebesgue(shape, p, Spacing::GaussLobatto));
                eprintln!("{shape:?} p={p}: Lebesgue constant equispaced {eq:.4}, warp & blend {gl:.4}");
                assert!(gl < eq - 0.05, "{shape:?} p={p}: {gl} vs {eq}");
            }
        }
        let at = lattice_index(Shape::Triangle, 4, [1, 1, 0]);
        let x = simplex_nodes(Shape::Triangle, 4, Spacing::GaussLobatto).unwrap()[at];
        assert!((x[0] - 0.25).abs() > 1e-3 && x[0] == x[1], "{x:?}");
    }

    /// `Σ_i f(x_i) ℓ_i` is `f` with its gradient for a random polynomial of
    /// degree `p` (every monomial present), at points inside and a little
    /// outside the cell; `f = 1` gives the partition of unity.
    #[test]
    fn basis_reproduces_polynomials_of_degree_p() {
        let mut seed = 7;
        for shape in SIMPLICES {
            let d = shape.dim();
            for p in 1..=MAX_ORDER {
                for spacing in SPACINGS {
                    let s = space(shape, p, spacing).unwrap();
                    let terms: Vec<([usize; 3], f64)> = lattice(shape, p).into_iter().map(|e| (e, 2.0 * rand01(&mut seed) - 1.0)).collect();
                    let f = |x: [f64; 3]| -> (f64, [f64; 3]) {
                        let mono = |e: [usize; 3], skip: usize| (0..3).filter(|&c| c != skip).map(|c| x[c].powi(e[c] as i32)).product::<f64>();
                        let val = terms.iter().map(|&(e, c)| c * mono(e, 3)).sum();
                        let grad = std::array::from_fn(|k| terms.iter().filter(|(e, _)| e[k] > 0).map(|&(e, c)| c * e[k] as f64 * x[k].powi(e[k] as i32 - 1) * mono(e, k)).sum());
                        (val, grad)
                    };
                    let at_nodes: Vec<f64> = s.nodes.iter().map(|&x| f(x).0).collect();
                    let (mut v, mut g) = (vec![0.0; s.num_nodes()], vec![[0.0; 3]; s.num_nodes()]);
                    for _ in 0..25 {
                        let xi: [f64; 3] = std::array::from_fn(|c| if c < d { 1.2 * rand01(&mut seed) / d as f64 - 0.1 } else { 0.0 });
                        s.eval(xi, &mut v, &mut g);
                        assert!((v.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{shape:?} p={p} {spacing:?}");
                        let (want, dwant) = f(xi);
                        let got: f64 = v.iter().zip(&at_nodes).map(|(l, y)| l * y).sum();
                        assert!((got - want).abs() < 1e-11, "{shape:?} p={p} {spacing:?} at {xi:?}: {got} vs {want}");
                        for k in 0..3 {
                            let dgot: f64 = g.iter().zip(&at_nodes).map(|(l, y)| l[k] * y).sum();
                            assert!((dgot - dwant[k]).abs() < 1e-10, "{shape:?} p={p} {spacing:?} ∂{k}: {dgot} vs {}", dwant[k]);
                            assert!(k < d || g.iter().all(|l| l[k] == 0.0));
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn basis_is_kronecker_at_the_nodes() {
        for shape in SIMPLICES {
            for p in 1..=MAX_ORDER {
                for spacing in SPACINGS {
                    let s = space(shape, p, spacing).unwrap();
                    let (mut v, mut g) = (vec![0.0; s.num_nodes()], vec![[0.0; 3]; s.num_nodes()]);
                    for (r, &x) in s.nodes.iter().enumerate() {
                        s.eval(x, &mut v, &mut g);
                        for (i, &l) in v.iter().enumerate() {
                            assert!((l - f64::from(u8::from(i == r))).abs() < 1e-12, "{shape:?} p={p} {spacing:?} ℓ_{i}(x_{r}) = {l}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn spaces_are_built_once_and_orders_checked() {
        let a = space(Shape::Tetrahedron, 3, Spacing::GaussLobatto).unwrap();
        let b = space(Shape::Tetrahedron, 3, Spacing::GaussLobatto).unwrap();
        assert!(std::ptr::eq(a, b));
        assert_eq!((a.shape, a.p, a.spacing, a.num_nodes()), (Shape::Tetrahedron, 3, Spacing::GaussLobatto, 20));
        assert!(!std::ptr::eq(a, space(Shape::Tetrahedron, 3, Spacing::Equispaced).unwrap()));
        assert_eq!(*space(Shape::Triangle, 2, Spacing::Equispaced).unwrap(), SimplexSpace::new(Shape::Triangle, 2, Spacing::Equispaced).unwrap());
        assert_eq!(space(Shape::Triangle, 0, Spacing::Equispaced), Err(HighOrderError::UnsupportedOrder(0)));
        assert_eq!(space(Shape::Tetrahedron, 5, Spacing::GaussLobatto), Err(HighOrderError::UnsupportedOrder(5)));
        let point = space(Shape::Point, 2, Spacing::Equispaced).unwrap();
        let (mut v, mut g) = ([0.0], [[0.0; 3]]);
        point.eval([0.0; 3], &mut v, &mut g);
        assert_eq!((v, g), ([1.0], [[0.0; 3]]));
    }

    #[test]
    #[should_panic(expected = "not a simplex")]
    fn quads_have_no_simplex_space() {
        let _ = space(Shape::Quadrilateral, 2, Spacing::Equispaced);
    }

    /// The facets of a sub-simplex (sorted lattice positions).
    fn facets_of(d: usize, s: &[usize; 4]) -> Vec<Vec<usize>> {
        (0..=d)
            .map(|skip| {
                let mut f: Vec<usize> = (0..=d).filter(|&k| k != skip).map(|k| s[k]).collect();
                f.sort_unstable();
                f
            })
            .collect()
    }

    /// The sub-simplices tile the cell: `p^d` of them, all positive, their
    /// volumes summing to the cell's, every inner facet shared by two, and
    /// the boundary facets on each face of the cell those of the face's own
    /// order-`p` subdivision.
    #[test]
    fn sub_simplices_tile_the_reference_cell() {
        for shape in SIMPLICES {
            let d = shape.dim();
            for p in 1..=MAX_ORDER {
                let lat = lattice(shape, p);
                let subs = sub_simplices(shape, p);
                assert_eq!(subs.len(), p.pow(d as u32), "{shape:?} p={p}");
                let mut volume = 0.0;
                let mut seen: HashMap<Vec<usize>, usize> = HashMap::new();
                for s in &subs {
                    let v: Vec<[usize; 3]> = s[..=d].iter().map(|&k| lat[k]).collect();
                    let det = lattice_det(d, &v);
                    assert!(det > 0, "{shape:?} p={p} {s:?}");
                    volume += det as f64 / (p.pow(d as u32) * (1..=d).product::<usize>()) as f64;
                    assert!(s[d + 1..].iter().all(|&k| k == 0));
                    for f in facets_of(d, s) {
                        *seen.entry(f).or_default() += 1;
                    }
                }
                assert!((volume - shape.volume()).abs() < 1e-14, "{shape:?} p={p}: {volume}");
                assert!(seen.values().all(|&n| n <= 2));
                let boundary: BTreeSet<Vec<usize>> = seen.into_iter().filter(|(_, n)| *n == 1).map(|(f, _)| f).collect();
                let mut expected = BTreeSet::new();
                for f in 0..shape.facets().len() {
                    if d == 3 {
                        let on = face_nodes(shape, p, f);
                        expected.extend(sub_simplices(Shape::Triangle, p).iter().map(|t| {
                            let mut x = vec![on[t[0]], on[t[1]], on[t[2]]];
                            x.sort_unstable();
                            x
                        }));
                    } else if d == 2 {
                        let on = edge_nodes(shape, p, f);
                        expected.extend(on.windows(2).map(|w| vec![w[0].min(w[1]), w[0].max(w[1])]));
                    } else {
                        expected.insert(vec![[0, p][f]]);
                    }
                }
                assert_eq!(boundary, expected, "{shape:?} p={p}");
            }
        }
    }

    #[test]
    fn edge_and_face_nodes_follow_the_shape_tables() {
        for p in 1..=MAX_ORDER {
            for shape in SIMPLICES {
                let lat = lattice(shape, p);
                let d = shape.dim();
                for (e, &[a, b]) in shape.edges().iter().enumerate() {
                    let on = edge_nodes(shape, p, e);
                    assert_eq!(lat[on[0]], vertex_point(shape, p, a));
                    assert_eq!(lat[on[p]], vertex_point(shape, p, b));
                    // on the edge: the other barycentric entries are 0
                    for (s, &k) in on.iter().enumerate() {
                        let bary = barycentric(lat[k], p);
                        assert_eq!((bary[a], bary[b]), (p - s, s));
                        assert!((0..=d).filter(|&v| v != a && v != b).all(|v| bary[v] == 0));
                    }
                }
            }
            for (f, face) in Shape::Tetrahedron.faces().iter().enumerate() {
                let on = face_nodes(Shape::Tetrahedron, p, f);
                let lat = lattice(Shape::Tetrahedron, p);
                let tri = lattice(Shape::Triangle, p);
                for (&k, &[s, t, _]) in on.iter().zip(&tri) {
                    let b = barycentric(lat[k], p);
                    assert_eq!([b[face.1[0]], b[face.1[1]], b[face.1[2]]], [p - s - t, s, t], "face {f}");
                }
            }
            assert_eq!(face_nodes(Shape::Triangle, p, 0), (0..Shape::Triangle.num_nodes(p)).collect::<Vec<_>>());
        }
    }

    fn is_permutation(perm: &[usize]) -> bool {
        let mut seen = vec![false; perm.len()];
        perm.iter().all(|&l| l < seen.len() && !std::mem::replace(&mut seen[l], true))
    }

    #[test]
    fn format_orders_are_permutations_with_vertices_first() {
        for p in 1..=MAX_ORDER {
            let orders = [
                (Shape::Triangle, gmsh_triangle_order(p).unwrap()),
                (Shape::Triangle, vtk_triangle_order(p).unwrap()),
                (Shape::Tetrahedron, gmsh_tet_order(p).unwrap()),
                (Shape::Tetrahedron, vtk_tet_order(p).unwrap()),
            ];
            for (shape, perm) in orders {
                assert_eq!(perm.len(), shape.num_nodes(p));
                assert!(is_permutation(&perm), "{shape:?} p={p}");
                for v in 0..=shape.dim() {
                    assert_eq!(perm[lattice_index(shape, p, vertex_point(shape, p, v))], v);
                }
            }
        }
        assert!(gmsh_tet_order(5).is_err() && vtk_triangle_order(0).is_err());
    }

    /// The local nodes of TRI_10, TET_20 (Gmsh 4.15's
    /// `getElementProperties`) and VTK 9.7's 20-node Lagrange tetrahedron
    /// (`GetParametricCoords`), times 3, as lattice points.
    #[test]
    fn known_gmsh_and_vtk_tables() {
        let listed = |shape: Shape, p: usize, perm: Vec<usize>| -> Vec<[usize; 3]> {
            super::super::to_format(&perm, &lattice(shape, p))
        };
        #[rustfmt::skip]
        let tri10 = [[0,0,0],[3,0,0],[0,3,0],[1,0,0],[2,0,0],[2,1,0],[1,2,0],[0,2,0],[0,1,0],[1,1,0]];
        assert_eq!(listed(Shape::Triangle, 3, gmsh_triangle_order(3).unwrap()), tri10);
        assert_eq!(listed(Shape::Triangle, 3, vtk_triangle_order(3).unwrap()), tri10);
        #[rustfmt::skip]
        let gmsh_tet20 = [
            [0,0,0],[3,0,0],[0,3,0],[0,0,3],[1,0,0],[2,0,0],[2,1,0],[1,2,0],[0,2,0],[0,1,0],
            [0,0,2],[0,0,1],[0,1,2],[0,2,1],[1,0,2],[2,0,1],[1,1,0],[1,0,1],[0,1,1],[1,1,1],
        ];
        assert_eq!(listed(Shape::Tetrahedron, 3, gmsh_tet_order(3).unwrap()), gmsh_tet20);
        #[rustfmt::skip]
        let vtk_tet20 = [
            [0,0,0],[3,0,0],[0,3,0],[0,0,3],[1,0,0],[2,0,0],[2,1,0],[1,2,0],[0,2,0],[0,1,0],
            [0,0,1],[0,0,2],[2,0,1],[1,0,2],[0,2,1],[0,1,2],[1,0,1],[1,1,1],[0,1,1],[1,1,0],
        ];
        assert_eq!(listed(Shape::Tetrahedron, 3, vtk_tet_order(3).unwrap()), vtk_tet20);
    }
}
