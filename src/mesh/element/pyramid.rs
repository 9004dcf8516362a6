//! The order-`p` Lagrange pyramid on the reference pyramid of
//! [`Shape::Pyramid`] (base `[0,1]²` at z = 0, apex `(½, ½, 1)`), in the
//! space Gmsh uses for its pyramids (`BergotBasis`: Bergot, Cohen &
//! Duruflé, "Higher-order finite elements for hybrid meshes using new
//! nodal pyramidal elements", J. Sci. Comput. 2010).
//!
//! **The space is rational.** No polynomial space of the right dimension
//! is continuous with `P_p` on the four triangles and `Q_p` on the square.
//! In the *collapsed* coordinates `(a, b, c)` of the unit cube, `x = a (1 −
//! c) + c/2`, `y = b (1 − c) + c/2`, `z = c` (the square of height `c`
//! shrunk towards the apex), it is spanned by
//! `a^i b^j (1 − c)^{max(i,j)} c^k`, `i, j ≤ p`, `k ≤ p − max(i, j)`:
//! Gmsh's `L_i(â) L_j(b̂) (1 − w)^{max(i,j)} P_k(w)` in another basis of
//! the same span (an affine change of `â` keeps `max(i, j)` from growing).
//! So every function is a polynomial of degree `p` per collapsed variable,
//! `(p+1)(p+2)(2p+3)/6` of them, and on each face it is the face's own
//! `P_p` or `Q_p`: a pyramid shares its faces node for node with
//! tetrahedra, prisms and hexes.
//!
//! **The lattice order** (fixed: the crate keeps pyramid nodes in it). A
//! node is `(i, j, k)`: `k = 0..=p` its layer along z, outermost, and
//! `0 ≤ i, j ≤ p − k` its place in the layer's square (`i` fastest), at
//! `((i + k/2)/p, (j + k/2)/p, k/p)` for equispaced nodes. Gmsh's own
//! "monomials" of a pyramid (`gmshGenerateMonomialsPyramid`) are these
//! `(i, j, k)`.
//!
//! **Nodes.** Equispaced, or for [`Spacing::GaussLobatto`] the face
//! elements' own nodes on the faces (warp-blend triangles, the
//! Gauss–Lobatto square) with the few interior nodes (one at p = 3, five
//! at p = 4) left equispaced: what a pyramid must have to meet tetrahedra
//! and hexes of that spacing.
//!
//! **File orders.** [`gmsh_pyramid_order`] (MSH types 7, 14, 118, 119) is
//! built from Gmsh's rules and checked against the real Gmsh in
//! `tests/it/simplex_orders.rs`. VTK has its linear pyramid (type 14,
//! Gmsh's vertex order) but no Lagrange pyramid: VTK 9.7 names the type
//! `VTK_LAGRANGE_PYRAMID` = 74 without a cell behind it, and its 13- and
//! 19-node quadratic pyramids are other spaces.

use std::sync::OnceLock;

use super::prism::{cell_edge_nodes, cell_face_nodes, face_interiors, face_points, gmsh_face_points, vertices_and_edges};
use super::simplex;
use super::{check_order, nodes_1d, HighOrderError, Shape, Spacing, MAX_ORDER};
use crate::numeric::bezier::invert;

/// The number of nodes of the order-`p` square layer `k`.
fn layer_count(p: usize, k: usize) -> usize {
    (p - k + 1) * (p - k + 1)
}

/// The multi-indices `(i, j, k)` of the order-`p` pyramid in lattice order.
pub fn lattice(p: usize) -> Vec<[usize; 3]> {
    (0..=p).flat_map(|k| (0..=p - k).flat_map(move |j| (0..=p - k).map(move |i| [i, j, k]))).collect()
}

/// The position of `(i, j, k)` in [`lattice`]`(p)`.
///
/// # Panics
/// If it is not in the lattice.
pub fn lattice_index(p: usize, [i, j, k]: [usize; 3]) -> usize {
    assert!(k <= p && i <= p - k && j <= p - k, "({i}, {j}, {k}) is not a node of the order-{p} pyramid");
    (0..k).map(|l| layer_count(p, l)).sum::<usize>() + j * (p - k + 1) + i
}

/// The lattice point of vertex `v` of [`Shape::Pyramid`].
pub(super) fn vertex_point(p: usize, v: usize) -> [usize; 3] {
    [[0, 0, 0], [p, 0, 0], [p, p, 0], [0, p, 0], [0, 0, p]][v]
}

/// The positions of the five vertices in [`lattice`] order, in
/// [`Shape::Pyramid`]'s vertex order.
pub fn vertex_nodes(p: usize) -> [usize; 5] {
    std::array::from_fn(|v| lattice_index(p, vertex_point(p, v)))
}

/// The equispaced reference point of lattice point `(i, j, k)`.
fn lattice_point(p: usize, [i, j, k]: [usize; 3]) -> [f64; 3] {
    let (pf, half) = (p as f64, k as f64 / 2.0);
    [(i as f64 + half) / pf, (j as f64 + half) / pf, k as f64 / pf]
}

/// The lattice positions on edge `edge` of [`Shape::edges`] of the pyramid,
/// from its first vertex to its second (`p + 1` of them).
pub fn edge_nodes(p: usize, edge: usize) -> Vec<usize> {
    cell_edge_nodes(Shape::Pyramid, p, edge, lattice_index)
}

/// The lattice positions on face `face` of [`Shape::faces`] of the
/// pyramid, in the face's own frame (as [`super::prism::face_nodes`]): a
/// triangle's lattice order or a quadrilateral's tensor order, the first
/// axis from the loop's first vertex to its second, the other to its last.
pub fn face_nodes(p: usize, face: usize) -> Vec<usize> {
    cell_face_nodes(Shape::Pyramid, p, face, lattice_index)
}

/// The reference coordinates of the order-`p` nodes in lattice order: the
/// lattice points, the face nodes moved to their face element's nodes of
/// `spacing` (see the module notes).
pub fn pyramid_nodes(p: usize, spacing: Spacing) -> Result<Vec<[f64; 3]>, HighOrderError> {
    check_order(p)?;
    let mut x: Vec<[f64; 3]> = lattice(p).into_iter().map(|m| lattice_point(p, m)).collect();
    if spacing == Spacing::Equispaced {
        return Ok(x);
    }
    let t = nodes_1d(p, spacing)?;
    let tri = simplex::simplex_nodes(Shape::Triangle, p, spacing)?;
    let v = Shape::Pyramid.vertices();
    for (f, &(shape, loop_)) in Shape::Pyramid.faces().iter().enumerate() {
        let (a, b, c) = (v[loop_[0]], v[loop_[1]], v[loop_[loop_.len() - 1]]);
        let local: Vec<[f64; 2]> = match shape {
            Shape::Triangle => tri.iter().map(|y| [y[0], y[1]]).collect(),
            _ => face_points(shape, p).into_iter().map(|[s, r]| [t[s], t[r]]).collect(),
        };
        for (n, [s, r]) in face_nodes(p, f).into_iter().zip(local) {
            x[n] = std::array::from_fn(|d| a[d] + s * (b[d] - a[d]) + r * (c[d] - a[d]));
        }
    }
    Ok(x)
}

/// The sub-cells of the order-`p` lattice, each positively oriented: the
/// pyramids (per layer, `(p−k)²` upright over the layer's squares and
/// `(p−k−1)²` upside down under the next layer's, corners in
/// [`Shape::Pyramid`]'s order) and the `2 (p−k)(p−k−1)` tetrahedra
/// between them (a lower edge inside the layer's square and the upper
/// edge across it). Volumes: `p³/3` in unit pyramids.
pub fn sub_cells(p: usize) -> (Vec<[usize; 5]>, Vec<[usize; 4]>) {
    let at = |i: usize, j: usize, k: usize| lattice_index(p, [i, j, k]);
    let (mut pyramids, mut tets) = (Vec::new(), Vec::new());
    for k in 0..p {
        let n = p - k;
        for j in 0..n {
            for i in 0..n {
                pyramids.push([at(i, j, k), at(i + 1, j, k), at(i + 1, j + 1, k), at(i, j + 1, k), at(i, j, k + 1)]);
            }
        }
        // upside down: the base clockwise seen from above, so that it
        // turns counter-clockwise seen from the apex below
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                pyramids.push([at(i, j, k + 1), at(i, j + 1, k + 1), at(i + 1, j + 1, k + 1), at(i + 1, j, k + 1), at(i + 1, j + 1, k)]);
            }
        }
        for a in 1..n {
            for b in 0..n {
                // the lower edge along x at j = a, and along y at i = a
                tets.push(orient([at(b, a, k), at(b + 1, a, k), at(b, a - 1, k + 1), at(b, a, k + 1)], p));
                tets.push(orient([at(a, b, k), at(a, b + 1, k), at(a - 1, b, k + 1), at(a, b, k + 1)], p));
            }
        }
    }
    (pyramids, tets)
}

/// The tetrahedron `t` of lattice positions with two corners swapped if
/// it is negatively oriented.
fn orient(mut t: [usize; 4], p: usize) -> [usize; 4] {
    let lat = lattice(p);
    let x = t.map(|n| lattice_point(p, lat[n]));
    let e = |a: usize| std::array::from_fn::<f64, 3, _>(|d| x[a][d] - x[0][d]);
    if crate::mesh::element::basis::det(&[e(1), e(2), e(3)]) < 0.0 {
        t.swap(2, 3);
    }
    t
}

/// `perm[lattice position] = place in points`.
fn permutation(p: usize, points: &[[usize; 3]]) -> Vec<usize> {
    let mut perm = vec![usize::MAX; points.len()];
    for (local, &m) in points.iter().enumerate() {
        let at = lattice_index(p, m);
        debug_assert_eq!(perm[at], usize::MAX, "node {m:?} listed twice");
        perm[at] = local;
    }
    debug_assert_eq!(points.len(), Shape::Pyramid.num_nodes(p));
    perm
}

/// Gmsh's points of an order-`p` pyramid, `p = 0` the single node of its
/// recursion (`gmshGenerateMonomialsPyramid`): vertices; the inner nodes
/// of each edge of its table ((0,1) (0,3) (0,4) (1,2) (1,4) (2,3) (2,4)
/// (3,4)) from first to second vertex; the inner nodes of each face of its
/// table (triangles (0,1,4) (3,0,4) (1,2,4) (2,3,4), the square
/// (0,3,2,1)) as Gmsh's triangle of order `p − 3` or quadrilateral of
/// order `p − 2` on the face's frame; then the inner pyramid of order
/// `p − 3` the same way, one node in.
fn gmsh_points(p: usize) -> Vec<[usize; 3]> {
    if p == 0 {
        return vec![[0, 0, 0]];
    }
    let mut points = vertices_and_edges(Shape::Pyramid, p, Shape::Pyramid.edges());
    points.extend(face_interiors(Shape::Pyramid, p, Shape::Pyramid.faces(), |shape| {
        gmsh_face_points(shape, if shape == Shape::Triangle { p - 3 } else { p - 2 })
    }));
    if p >= 3 {
        points.extend(gmsh_points(p - 3).into_iter().map(|m| m.map(|x| x + 1)));
    }
    points
}

/// Gmsh's order of an order-`p` pyramid (MSH types 7, 14, 118, 119;
/// [`gmsh_points`]). `perm[lattice position] = Gmsh's local number`.
pub fn gmsh_pyramid_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    Ok(permutation(p, &gmsh_points(p)))
}

/// The collapsed coordinates `(a, b, c)` of reference point `ξ` (module
/// notes); at the apex, where `a` and `b` are undefined, the centre.
pub fn collapse(xi: [f64; 3]) -> [f64; 3] {
    let c = xi[2];
    let w = 1.0 - c;
    if w <= 0.0 {
        return [0.5, 0.5, c];
    }
    [(xi[0] - 0.5 * c) / w, (xi[1] - 0.5 * c) / w, c]
}

/// The exponents `(i, j, k)` of the spanning functions `α^i β^j (1 −
/// c)^{max(i,j)} γ^k` of the order-`p` space, `α = 2a − 1`, `β = 2b − 1`,
/// `γ = 2c − 1` (centred: an affine change of each variable keeps the
/// span, and the Vandermonde matrix is better conditioned than on `a^i`).
pub fn spanning(p: usize) -> Vec<[usize; 3]> {
    let mut out = Vec::new();
    for i in 0..=p {
        for j in 0..=p {
            out.extend((0..=p - i.max(j)).map(|k| [i, j, k]));
        }
    }
    out
}

/// `x^n` with `x^0 = 1` (also for `x = 0`).
fn pow(x: f64, n: usize) -> f64 {
    x.powi(n as i32)
}

/// The spanning function `[i, j, k]` at collapsed point `(a, b, c)`: its
/// value and its gradient in the reference coordinates `(x, y, z)`. With
/// `m = max(i, j)`: `∂x = 2i α^{i−1} β^j (1−c)^{m−1} γ^k` (as `∂a/∂x = 1/(1
/// − c)`, and `i ≥ 1` makes `m ≥ 1`), `∂y` alike, and `∂z = ∂c + (a − ½)
/// ∂x + (b − ½) ∂y`.
pub fn spanning_eval([i, j, k]: [usize; 3], [a, b, c]: [f64; 3]) -> (f64, [f64; 3]) {
    let m = i.max(j);
    let (al, be, ga, w) = (2.0 * a - 1.0, 2.0 * b - 1.0, 2.0 * c - 1.0, 1.0 - c);
    let (ai, bj, wm, ck) = (pow(al, i), pow(be, j), pow(w, m), pow(ga, k));
    let value = ai * bj * wm * ck;
    let dx = if i > 0 { 2.0 * i as f64 * pow(al, i - 1) * bj * pow(w, m - 1) * ck } else { 0.0 };
    let dy = if j > 0 { 2.0 * j as f64 * ai * pow(be, j - 1) * pow(w, m - 1) * ck } else { 0.0 };
    let dk = if k > 0 { 2.0 * k as f64 * pow(ga, k - 1) * wm } else { 0.0 };
    let dm = if m > 0 { m as f64 * pow(w, m - 1) * ck } else { 0.0 };
    let dc = ai * bj * (dk - dm);
    (value, [dx, dy, dc + (a - 0.5) * dx + (b - 0.5) * dy])
}

/// The Lagrange space on the pyramid, on one node set. Get the shared
/// instances from [`space`].
#[derive(Clone, Debug)]
pub struct PyramidSpace {
    /// Element order.
    pub p: usize,
    /// The node set.
    pub spacing: Spacing,
    /// Reference coordinates of the nodes, lattice order.
    pub nodes: Vec<[f64; 3]>,
    /// The spanning functions' exponents ([`spanning`]).
    pub span: Vec<[usize; 3]>,
    /// The computed inverse of the matrix `V[n][f] = φ_f(x_n)`: basis
    /// function `n` is `Σ_f φ_f inv[f][n]`.
    pub inv: Vec<Vec<f64>>,
}

impl PyramidSpace {
    /// The order-`p` space on `spacing`'s nodes.
    pub fn new(p: usize, spacing: Spacing) -> Result<Self, HighOrderError> {
        let nodes = pyramid_nodes(p, spacing)?;
        let span = spanning(p);
        let v: Vec<Vec<f64>> = nodes.iter().map(|&x| span.iter().map(|&f| spanning_eval(f, collapse(x)).0).collect()).collect();
        Ok(PyramidSpace { p, spacing, nodes, span, inv: invert(&v) })
    }

    /// The number of nodes (basis functions).
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// The basis values and reference gradients at `ξ` into the caller's
    /// slices (each of [`PyramidSpace::num_nodes`]); allocates nothing. At
    /// the apex the gradient is the limit along the axis (it has no single
    /// value there).
    ///
    /// # Panics
    /// If a slice has another length.
    pub fn eval(&self, xi: [f64; 3], values: &mut [f64], grads: &mut [[f64; 3]]) {
        let n = self.num_nodes();
        assert!(values.len() == n && grads.len() == n, "{n} basis functions");
        values.fill(0.0);
        grads.fill([0.0; 3]);
        let abc = collapse(xi);
        for (f, &e) in self.span.iter().enumerate() {
            let (v, g) = spanning_eval(e, abc);
            for (m, &w) in self.inv[f].iter().enumerate() {
                values[m] += v * w;
                for d in 0..3 {
                    grads[m][d] += g[d] * w;
                }
            }
        }
    }
}

/// The shared space of order `p` and `spacing`, built on first use
/// (Gmsh's `BasisFactory`).
pub fn space(p: usize, spacing: Spacing) -> Result<&'static PyramidSpace, HighOrderError> {
    static SPACES: [OnceLock<PyramidSpace>; MAX_ORDER * 2] = [const { OnceLock::new() }; MAX_ORDER * 2];
    check_order(p)?;
    let slot = (p - 1) * 2 + usize::from(spacing == Spacing::GaussLobatto);
    Ok(SPACES[slot].get_or_init(|| PyramidSpace::new(p, spacing).expect("the order was checked")))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPACINGS: [Spacing; 2] = [Spacing::Equispaced, Spacing::GaussLobatto];

    fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| a[i] - b[i])
    }

    fn triple(u: [f64; 3], v: [f64; 3], w: [f64; 3]) -> f64 {
        crate::mesh::element::basis::det(&[u, v, w])
    }

    /// The lattice has the shape table's count, its vertices sit at the
    /// reference vertices, and the index inverts the list.
    #[test]
    fn the_lattice_is_the_shape_tables() {
        for p in 1..=MAX_ORDER {
            let lat = lattice(p);
            assert_eq!(lat.len(), Shape::Pyramid.num_nodes(p));
            assert!(lat.iter().enumerate().all(|(n, &m)| lattice_index(p, m) == n));
            let x = pyramid_nodes(p, Spacing::Equispaced).unwrap();
            for (v, &n) in vertex_nodes(p).iter().enumerate() {
                assert_eq!(x[n], Shape::Pyramid.vertices()[v], "p = {p} vertex {v}");
            }
        }
    }

    /// The basis interpolates, sums to one with gradients summing to zero,
    /// and reproduces the space: the affine functions (so the identity
    /// map, with gradient I) and a rational member `x y / (1 − z)`-type
    /// function `a b (1 − c)` with its exact gradient.
    #[test]
    fn the_basis_interpolates_and_reproduces_its_space() {
        for p in 1..=MAX_ORDER {
            for spacing in SPACINGS {
                let s = space(p, spacing).unwrap();
                let n = s.num_nodes();
                let (mut v, mut g) = (vec![0.0; n], vec![[0.0; 3]; n]);
                for (m, &x) in s.nodes.iter().enumerate() {
                    s.eval(x, &mut v, &mut g);
                    for (k, &val) in v.iter().enumerate() {
                        assert!((val - f64::from(u8::from(k == m))).abs() < 1e-11, "p = {p} {spacing:?}: ℓ_{k}(x_{m}) = {val}");
                    }
                }
                for at in [[0.3, 0.4, 0.2], [0.55, 0.45, 0.7], [0.1, 0.8, 0.05]] {
                    s.eval(at, &mut v, &mut g);
                    assert!((v.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                    for d in 0..3 {
                        let id: f64 = s.nodes.iter().zip(&v).map(|(x, l)| x[d] * l).sum();
                        assert!((id - at[d]).abs() < 1e-12, "p = {p} {spacing:?}");
                        for e in 0..3 {
                            let grad: f64 = s.nodes.iter().zip(&g).map(|(x, l)| x[d] * l[e]).sum();
                            assert!((grad - f64::from(u8::from(d == e))).abs() < 1e-11, "p = {p} {spacing:?}: ∂{e} x_{d} = {grad}");
                        }
                    }
                    if p >= 1 {
                        let f = |x: [f64; 3]| {
                            let [a, b, c] = collapse(x);
                            a * b * (1.0 - c)
                        };
                        let value: f64 = s.nodes.iter().zip(&v).map(|(&x, l)| f(x) * l).sum();
                        assert!((value - f(at)).abs() < 1e-12, "p = {p} {spacing:?}");
                        let h = 1e-6;
                        for d in 0..3 {
                            let (mut up, mut down) = (at, at);
                            up[d] += h;
                            down[d] -= h;
                            let want = (f(up) - f(down)) / (2.0 * h);
                            let grad: f64 = s.nodes.iter().zip(&g).map(|(&x, l)| f(x) * l[d]).sum();
                            assert!((grad - want).abs() < 1e-8, "p = {p} ∂{d}: {grad} vs {want}");
                        }
                    }
                }
            }
        }
    }

    /// Edge nodes run from the first vertex to the second at the 1-D
    /// nodes; face nodes lie on their face at the face element's nodes of
    /// the same spacing, their frame turned outward.
    #[test]
    fn edge_and_face_nodes_follow_the_shape_tables() {
        let centre = [0.5, 0.5, 0.25];
        let v = Shape::Pyramid.vertices();
        for p in 1..=MAX_ORDER {
            for spacing in SPACINGS {
                let x = pyramid_nodes(p, spacing).unwrap();
                let t = nodes_1d(p, spacing).unwrap();
                for (e, &[a, b]) in Shape::Pyramid.edges().iter().enumerate() {
                    for (s, &n) in edge_nodes(p, e).iter().enumerate() {
                        let want: [f64; 3] = std::array::from_fn(|c| v[a][c] + t[s] * (v[b][c] - v[a][c]));
                        assert!((0..3).all(|c| (x[n][c] - want[c]).abs() < 1e-15), "p = {p} {spacing:?} edge {e} node {s}");
                    }
                }
                let tri = simplex::simplex_nodes(Shape::Triangle, p, spacing).unwrap();
                for (f, &(shape, loop_)) in Shape::Pyramid.faces().iter().enumerate() {
                    let on = face_nodes(p, f);
                    assert_eq!(on.len(), shape.num_nodes(p));
                    let (a, b, c) = (v[loop_[0]], v[loop_[1]], v[loop_[loop_.len() - 1]]);
                    let local: Vec<[f64; 2]> = match shape {
                        Shape::Triangle => tri.iter().map(|y| [y[0], y[1]]).collect(),
                        _ => (0..=p).flat_map(|j| (0..=p).map(move |i| [i, j])).map(|[i, j]| [t[i], t[j]]).collect(),
                    };
                    for (&n, [s, r]) in on.iter().zip(local) {
                        let want: [f64; 3] = std::array::from_fn(|k| a[k] + s * (b[k] - a[k]) + r * (c[k] - a[k]));
                        assert!((0..3).all(|k| (x[n][k] - want[k]).abs() < 1e-15), "p = {p} {spacing:?} face {f}");
                    }
                    let normal = {
                        let (u, w) = (sub(b, a), sub(c, a));
                        [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
                    };
                    assert!((0..3).map(|k| normal[k] * (a[k] - centre[k])).sum::<f64>() > 0.0, "face {f} points inward");
                }
            }
        }
    }

    /// The sub-cells tile the reference pyramid (volume ⅓): each positive,
    /// the pyramids unit ones scaled by 1/p, every node a corner.
    #[test]
    fn the_sub_cells_tile_the_lattice() {
        for p in 1..=MAX_ORDER {
            let x = pyramid_nodes(p, Spacing::Equispaced).unwrap();
            let (pyramids, tets) = sub_cells(p);
            let (n, m) = (pyramids.len(), tets.len());
            let sum = |f: &dyn Fn(usize) -> usize| (1..=p).map(f).sum::<usize>();
            assert_eq!((n, m), (sum(&|q| q * q + (q - 1) * (q - 1)), sum(&|q| 2 * q * (q - 1))));
            let mut volume = 0.0;
            let mut seen = vec![false; x.len()];
            for s in &pyramids {
                let c = s.map(|k| x[k]);
                // the two tetrahedra of its base's diagonal 0–2
                let v = (triple(sub(c[1], c[0]), sub(c[2], c[0]), sub(c[4], c[0])) + triple(sub(c[2], c[0]), sub(c[3], c[0]), sub(c[4], c[0]))) / 6.0;
                assert!((v - 1.0 / (3 * p * p * p) as f64).abs() < 1e-14, "p = {p}: {s:?} volume {v}");
                volume += v;
                s.iter().for_each(|&k| seen[k] = true);
            }
            for t in &tets {
                let c = t.map(|k| x[k]);
                let v = triple(sub(c[1], c[0]), sub(c[2], c[0]), sub(c[3], c[0])) / 6.0;
                assert!((v - 1.0 / (6 * p * p * p) as f64).abs() < 1e-14, "p = {p}: tet {t:?} volume {v}");
                volume += v;
            }
            assert!((volume - 1.0 / 3.0).abs() < 1e-13, "p = {p}: {volume}");
            assert!(seen.iter().all(|&b| b));
        }
    }

    /// Gmsh's order lists every node once, the vertices first in the
    /// shape table's order, and it begins as Gmsh's 14-node pyramid does
    /// (`MPyramid14`: edges (0,1) (0,3) (0,4) (1,2) (1,4) (2,3) (2,4)
    /// (3,4), then the square's centre); the places of every node against
    /// the real Gmsh are in `tests/it/simplex_orders.rs`.
    #[test]
    fn the_gmsh_order_is_a_permutation_with_vertices_first() {
        for p in 1..=MAX_ORDER {
            let perm = gmsh_pyramid_order(p).unwrap();
            let mut seen = vec![false; perm.len()];
            assert!(perm.iter().all(|&l| l < seen.len() && !std::mem::replace(&mut seen[l], true)), "p = {p}");
            assert_eq!(vertex_nodes(p).map(|n| perm[n]), [0, 1, 2, 3, 4]);
        }
        let perm = gmsh_pyramid_order(2).unwrap();
        let x = pyramid_nodes(2, Spacing::Equispaced).unwrap();
        let mut by_gmsh = vec![[0.0; 3]; 14];
        for (n, &l) in perm.iter().enumerate() {
            by_gmsh[l] = x[n];
        }
        assert_eq!(by_gmsh[5], [0.5, 0.0, 0.0]);
        assert_eq!(by_gmsh[7], [0.25, 0.25, 0.5]);
        assert_eq!(by_gmsh[13], [0.5, 0.5, 0.0]);
    }
}
