//! The validity certificate of a curved triangle or tetrahedron of order
//! `p = 1..=4` (Johnen, Remacle & Geuzaine, "Geometrical validity of
//! curvilinear finite elements", JCP 2013): the simplex counterpart of
//! [`super::certify`], with the same [`Certificate`], [`CertifyOptions`]
//! and branch-and-bound goals.
//!
//! The map of an order-`p` simplex is a polynomial of total degree `p`, so
//! its Jacobian determinant is a polynomial of degree `D(p − 1)` (triangle
//! `2(p−1)`, tetrahedron `3(p−1)`; a constant for `p = 1`). We compute its
//! Bernstein coefficients on the simplex up to rounding: the Lagrange
//! control points become Bernstein control points through the inverse of
//! the Bernstein–Vandermonde matrix at the reference nodes (whatever the
//! node set: equispaced or warp-blend), are differentiated and multiplied
//! in Bernstein form ([`crate::numeric::simplex_bezier`]). The smallest
//! coefficient bounds det J below, the vertex coefficients are values; a
//! best-first search bisecting the longest edge of the piece with the
//! lowest bound tightens the bracket, and a bound on the rounding of every
//! step, subtracted, keeps the verdict sound.
//!
//! Conventions: reference triangle (0,0), (1,0), (0,1); tetrahedron
//! (0,0,0), (1,0,0), (0,1,0), (0,0,1) — Gmsh's own, so the determinants are
//! Gmsh's `minDetJac` units with no `2^d` factor. Nodes in lattice order
//! (triangle `(i, j)`, `j` outer; tetrahedron `(i, j, k)`, `k` outermost,
//! `i` fastest; equispaced node at `(i, j, k) / p`).

use smallvec::{smallvec, SmallVec};

use super::certify::{brackets, gamma, normalise, Certificate, CertifyOptions, Goal, U};
use crate::mesh::element::basis::det;
use crate::mesh::element::{check_order, HighOrderError, Shape};
use crate::numeric::bezier::invert;
use crate::numeric::simplex_bezier::{edges, max_abs, multi_indices, Coef, Derivative, Lattice, Product, Split};
use crate::numeric::{dot, sub};

/// `C(p + d, d)`, the number of nodes of an order-`p` `d`-simplex.
fn node_count(dim: usize, p: usize) -> usize {
    (1..=dim).fold(1, |n, k| n * (p + k) / k)
}

/// The Lagrange-to-Bernstein matrix of one node set and how far from the
/// exact inverse it may be (also the triangle factor of the prism's
/// conversion, [`super::prism`]).
pub(crate) struct Conversion {
    /// The computed inverse of the Bernstein–Vandermonde matrix `V`,
    /// row-major `n × n`.
    inv: Vec<f64>,
    pub(crate) n: usize,
    /// Its largest row sum of absolute values (∞-norm).
    pub(crate) norm: f64,
    /// A bound on `‖inv V − I‖∞` for the exact `V` (entries `B_j(x_i)` of
    /// the stored nodes `x_i`), below ½.
    pub(crate) rho: f64,
}

impl Conversion {
    /// `None` if the nodes are not unisolvent (or so nearly not that the
    /// inverse cannot be trusted to ½).
    pub(crate) fn new(lat: &Lattice, nodes: &[[f64; 3]]) -> Option<Self> {
        let n = lat.len();
        let v: Vec<Vec<f64>> = nodes
            .iter()
            .map(|&x| {
                let mut row = vec![0.0; n];
                lat.basis(x, &mut row);
                row
            })
            .collect();
        let err: Vec<Vec<f64>> = nodes.iter().map(|&x| basis_rounding(lat, x)).collect();
        let inv = invert(&v);
        if !inv.iter().flatten().all(|x| x.is_finite()) {
            return None;
        }
        // The exact residual inv·V − I differs from the computed one by (i)
        // the rounding of its own n-term sums, ≤ γ_{n+1} |inv||V̂|, and (ii)
        // the rounding of V's entries, ≤ |inv| E (E from basis_rounding).
        let g = gamma(n + 1);
        let mut rho = 0.0f64;
        for (i, row) in inv.iter().enumerate() {
            let mut sum = 0.0;
            for j in 0..n {
                let r: f64 = (0..n).map(|k| row[k] * v[k][j]).sum::<f64>() - f64::from(u8::from(i == j));
                let a: f64 = (0..n).map(|k| (row[k] * v[k][j]).abs()).sum();
                let e: f64 = (0..n).map(|k| row[k].abs() * err[k][j]).sum();
                sum += r.abs() + g * a + e;
            }
            rho = rho.max(sum);
        }
        // the sums of non-negative terms above round by at most γ_{2n+4}
        let rho = rho * (1.0 + gamma(2 * n + 4));
        let norm = inv.iter().map(|r| r.iter().map(|x| x.abs()).sum::<f64>()).fold(0.0, f64::max);
        (rho < 0.5).then(|| Conversion { inv: inv.concat(), n, norm, rho })
    }

    /// The Bernstein coefficients of the interpolant of `values` (one
    /// n-term dot product each).
    pub(crate) fn apply(&self, values: &[f64]) -> Coef {
        self.inv.chunks_exact(self.n).map(|row| row.iter().zip(values).map(|(a, b)| a * b).sum()).collect()
    }
}

/// A bound on `|computed − exact|` of every basis function at node `x`
/// ([`Lattice::basis`]). `λ_0 = ((1 − x_1) − x_2) − x_3` rounds `d` times on
/// partial results of size ≤ `S = 1 + Σ|x_c|`: off by `δ ≤ γ_d S`; the
/// other λ are exact. So `Π λ_s^{α_s}` moves by at most `α_0 δ (|λ̂_0| +
/// δ)^{α_0 − 1} Π_{s>0} |λ_s|^{α_s}`, and the `p` roundings of the product
/// add `γ_p Π |λ̂_s|^{α_s}`, both times the exact multinomial. (Per entry:
/// summed over a row the bound is about `(p δ + γ_p) (Σ|λ|)^p`, not the
/// `p δ` times the sum of the multinomials a uniform bound would give.)
fn basis_rounding(lat: &Lattice, x: [f64; 3]) -> Vec<f64> {
    let (d, p) = (lat.dim(), lat.deg());
    let lambda = crate::numeric::simplex_bezier::barycentric(d, x).map(f64::abs);
    let delta = gamma(d) * x[..d].iter().fold(1.0, |s, c| s + c.abs());
    let pow = |v: f64, e: usize| (0..e).fold(1.0, |acc, _| acc * v);
    (0..lat.len())
        .map(|j| {
            let a = lat.alpha(j);
            let a0 = p - a.iter().sum::<usize>();
            let rest: f64 = (0..d).map(|c| pow(lambda[c + 1], a[c])).product();
            let moved = if a0 == 0 { 0.0 } else { a0 as f64 * delta * pow(lambda[0] + delta, a0 - 1) * rest };
            let rounded = gamma(p) * pow(lambda[0], a0) * rest;
            lat.multinomial(j) * (moved + rounded) * (1.0 + 8.0 * U)
        })
        .collect()
}

/// `det J` in Bernstein form with what is needed to bound its rounding
/// (as [`super::certify`]'s `DetParts`).
struct DetParts<const D: usize> {
    /// The computed coefficients, degree `D (p − 1)`.
    det: Coef,
    /// The Bernstein coefficients of `∂x_r/∂ξ_c` as `col[c][r]`.
    col: [[Coef; D]; D],
    /// The largest coefficient of the absolute companion of the products
    /// (the same products on the absolute values of the derivative
    /// coefficients, differences becoming sums): bounds the sum of the
    /// absolute values of the terms of every coefficient of `det`.
    abs_max: f64,
    /// Largest computed Bernstein coefficient of a coordinate.
    coord_max: f64,
    /// Largest moved control point coordinate (≤ 1 when normalised).
    input_max: f64,
    /// Largest computed derivative coefficient.
    deriv_max: f64,
    /// An upper bound on the roundings along any path from a derivative
    /// coefficient to a coefficient of `det`.
    k: usize,
}

impl<const D: usize> DetParts<D> {
    /// A bound on `|computed − exact|` for every coefficient of `det`, the
    /// exact one being that of the Lagrange map through the control points
    /// at the reference nodes (before the centring subtraction). The
    /// argument of [`super::certify`]'s `DetParts::error_bound`, with one
    /// `n × n` conversion (`n` nodes) in place of `D` passes of `p + 1`:
    /// 1. coordinates: the centring rounds each input by ≤ U relative and
    ///    the conversion is an n-term dot product, so with the computed
    ///    `inv` taken as exact a coefficient errs by ≤ `γ_{n+1} ‖inv‖
    ///    max|x|`; `inv = (I + R) V⁻¹`, `‖R‖ ≤ ρ`, adds `ρ max|c|`, and
    ///    `max|c|` ≤ `(computed max + that) / (1 − ρ)`. Together: `ε`.
    /// 2. derivatives `n (c_{β+e} − c_β)`, `n ≤ p`: `2p ε` plus the two
    ///    roundings `γ_2 · 2p max|c|`. Together: `δ`.
    /// 3. products: `γ_k` times the companion (itself computed with `k`
    ///    roundings, hence `/(1 − γ_k)`), plus `D! ((M + δ)^D − M^D)` for the
    ///    errors of the factors (the weights into one coefficient sum to
    ///    one; `det` has `D!` signed products of `D` factors).
    fn error_bound(&self, p: usize, conv: &Conversion) -> f64 {
        let (pf, d) = (p as f64, D as i32);
        let round_c = gamma(conv.n + 1) * conv.norm * self.input_max;
        let r = conv.rho;
        let eps = round_c + r / (1.0 - r) * (self.coord_max + round_c);
        let delta = 2.0 * pf * eps + gamma(2) * 2.0 * pf * (self.coord_max + eps);
        let g = gamma(self.k);
        let round = g / (1.0 - g) * self.abs_max;
        let m = self.deriv_max;
        let fact = if D == 2 { 2.0 } else { 6.0 };
        let inputs = fact * ((m + delta).powi(d) - m.powi(d));
        // a few ulps more cover the rounding of this formula itself
        (round + inputs) * (1.0 + 16.0 * U)
    }
}

/// A piece of the branch and bound: the polynomial on a sub-simplex (its
/// reference vertices by barycentric slot).
#[derive(Clone)]
struct Piece {
    coef: Coef,
    verts: [[f64; 3]; 4],
}

impl super::branch::Piece for Piece {
    type Context = SimplexCertifier;
    fn coefficients(&self) -> &[f64] {
        &self.coef
    }
    fn least_vertex(&self, cx: &SimplexCertifier) -> f64 {
        super::branch::least_at(&self.coef, &cx.det_vertices)
    }
    fn cut(self, cx: &SimplexCertifier, _: Goal) -> (SmallVec<[Piece; 8]>, usize) {
        (cx.bisect(&self).into_iter().collect(), 1)
    }
}

/// The reference simplex's vertices by slot.
const REFERENCE: [[f64; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The certificate's set-up for one shape, order and node set, made once
/// per mesh: the Lagrange-to-Bernstein conversion and the tables of the
/// Bernstein algebra.
pub struct SimplexCertifier {
    dim: usize,
    p: usize,
    conv: Conversion,
    /// Derivatives from degree `p` to `p − 1`.
    deriv: Derivative,
    /// Basis of the derivatives, degree `p − 1` (sampling evaluates it).
    grad: Lattice,
    /// `(p−1) × (p−1)`: the 2×2 determinant, the tetrahedron's cross product.
    mul_gg: Product,
    /// `(p−1) × 2(p−1)`: the tetrahedron's dot with the cross product.
    mul_gc: Option<Product>,
    /// Bisections and vertex positions of det J, degree `D (p − 1)`.
    split: Split,
    det_vertices: SmallVec<[usize; 4]>,
    /// The default sampling lattice (`3p + 1` points per edge): its size
    /// and the derivatives' basis at its points, row by row.
    samples: (usize, Vec<f64>),
}

impl SimplexCertifier {
    /// For order-`p` triangles or tetrahedra whose nodes sit at `nodes`
    /// (reference positions in lattice order, unused coordinates 0).
    ///
    /// Errors: an order outside `1..=4`, a node count other than `C(p+d,
    /// d)`, or a shape that is not a triangle or tetrahedron (reported as a
    /// `NodeCount` expecting 0 nodes: [`HighOrderError`] has no shape
    /// variant).
    ///
    /// # Panics
    /// If the nodes are not unisolvent for degree `p` (two coinciding, or
    /// all on a conic, say): a node table is a constant of the code.
    pub fn new(shape: Shape, p: usize, nodes: &[[f64; 3]]) -> Result<Self, HighOrderError> {
        check_order(p)?;
        let dim = shape.dim();
        let count = |expected| HighOrderError::NodeCount { order: p, dim, expected, found: nodes.len() };
        if !matches!(shape, Shape::Triangle | Shape::Tetrahedron) {
            return Err(count(0));
        }
        if nodes.len() != node_count(dim, p) {
            return Err(count(node_count(dim, p)));
        }
        let coord = Lattice::new(dim, p);
        let conv = Conversion::new(&coord, nodes).unwrap_or_else(|| panic!("the order-{p} {shape:?} nodes are not unisolvent"));
        let grad = Lattice::new(dim, p - 1);
        let det_lat = Lattice::new(dim, dim * (p - 1));
        let mul_gc = (dim == 3).then(|| Product::new(&grad, &Lattice::new(dim, 2 * (p - 1))));
        let m = 3 * p + 1;
        let mut table = vec![0.0; node_count(dim, m - 1) * grad.len()];
        for (x, row) in lattice_points(dim, m).zip(table.chunks_exact_mut(grad.len())) {
            grad.basis(x, row);
        }
        Ok(SimplexCertifier {
            dim,
            p,
            deriv: Derivative::new(&coord, &grad),
            mul_gg: Product::new(&grad, &grad),
            mul_gc,
            split: Split::new(&det_lat),
            det_vertices: (0..=dim).map(|v| det_lat.vertex(v)).collect(),
            samples: (m, table),
            grad,
            conv,
        })
    }

    /// `det J` of the normalised element with its rounding bound, and the
    /// scale `s` of [`normalise`] (`det J` of `ctrl` is `s^D` times it).
    fn det_j<const D: usize>(&self, ctrl: &[[f64; D]]) -> (DetParts<D>, f64, f64) {
        assert!(D == self.dim && ctrl.len() == self.conv.n, "a {}-node {}D simplex given {} points in {D}D", self.conv.n, self.dim, ctrl.len());
        let (centre, s) = normalise(ctrl);
        let mut input_max = 0.0f64;
        let x: [Coef; D] = std::array::from_fn(|r| {
            let moved: Coef = ctrl.iter().map(|c| (c[r] - centre[r]) / s).collect();
            input_max = input_max.max(max_abs(&moved));
            self.conv.apply(&moved)
        });
        let coord_max = x.iter().map(|c| max_abs(c)).fold(0.0, f64::max);
        let col: [[Coef; D]; D] = std::array::from_fn(|c| std::array::from_fn(|r| self.deriv.apply(c, &x[r])));
        let deriv_max = col.iter().flatten().map(|c| max_abs(c)).fold(0.0, f64::max);
        let abs = col.each_ref().map(|c| c.each_ref().map(|b| b.iter().map(|v| v.abs()).collect::<Coef>()));
        let (det, det_abs, k) = if D == 2 { self.det2(&col, &abs) } else { self.det3(&col, &abs) };
        let parts = DetParts { det, col, abs_max: max_abs(&det_abs), coord_max, input_max, deriv_max, k };
        // a coordinate that is not finite leaves NaN coefficients, which
        // min and max would skip: no bound at all then
        let err = if parts.det.iter().all(|c| c.is_finite()) { parts.error_bound(self.p, &self.conv) } else { f64::INFINITY };
        (parts, err, s)
    }

    /// `det J = x_ξ y_η − x_η y_ξ`, its companion and its rounding count.
    fn det2<const D: usize>(&self, col: &[[Coef; D]; D], abs: &[[Coef; D]; D]) -> (Coef, Coef, usize) {
        (self.cross2(col, -1.0), self.cross2(abs, 1.0), self.mul_gg.roundings() + 1)
    }

    /// `x_ξ y_η + s x_η y_ξ` of the columns `col` (`s = −1`: det J).
    fn cross2<const D: usize>(&self, col: &[[Coef; D]; D], s: f64) -> Coef {
        let m = &self.mul_gg;
        let (a, b) = (m.apply(&col[0][0], &col[1][1]), m.apply(&col[1][0], &col[0][1]));
        a.iter().zip(&b).map(|(x, y)| x + s * y).collect()
    }

    /// `det J = a · (b × c)` (columns), its companion and its rounding count.
    fn det3<const D: usize>(&self, col: &[[Coef; D]; D], abs: &[[Coef; D]; D]) -> (Coef, Coef, usize) {
        let (mg, mc) = (&self.mul_gg, self.mul_gc.as_ref().expect("tetrahedra have the second product"));
        let k = mg.roundings() + 1 + mc.roundings() + 2;
        (self.triple(col, -1.0), self.triple(abs, 1.0), k)
    }

    /// `a · (b × c)` of the columns, the cross product's differences taken
    /// with sign `s` (`s = −1`: det J).
    fn triple<const D: usize>(&self, cols: &[[Coef; D]; D], s: f64) -> Coef {
        let (mg, mc) = (&self.mul_gg, self.mul_gc.as_ref().expect("tetrahedra have the second product"));
        let (a, b, c) = (&cols[0], &cols[1], &cols[2]);
        let cross = |i: usize, j: usize| -> Coef {
            let (u, v) = (mg.apply(&b[i], &c[j]), mg.apply(&b[j], &c[i]));
            u.iter().zip(&v).map(|(x, y)| x + s * y).collect()
        };
        let bc = [cross(1, 2), cross(2, 0), cross(0, 1)];
        let t: [Coef; 3] = std::array::from_fn(|r| mc.apply(&a[r], &bc[r]));
        (0..t[0].len()).map(|i| t[0][i] + t[1][i] + t[2][i]).collect()
    }

    /// The two halves of a piece, bisecting its longest reference edge
    /// (the first of [`edges`] on ties): the pieces' diameters go to zero,
    /// and with them the gap of the Bernstein bound, quadratically.
    fn bisect(&self, piece: &Piece) -> [Piece; 2] {
        let verts = &piece.verts;
        let len2 = |&(a, b): &(usize, usize)| crate::numeric::dist2(verts[a], verts[b]);
        let all = edges(self.dim);
        let e = (0..all.len()).fold(0, |best, e| if len2(&all[e]) > len2(&all[best]) { e } else { best });
        let (a, b) = all[e];
        let mid: [f64; 3] = std::array::from_fn(|r| 0.5 * (verts[a][r] + verts[b][r]));
        let (near_a, near_b) = self.split.apply(e, &piece.coef);
        let (mut va, mut vb) = (*verts, *verts);
        va[b] = mid;
        vb[a] = mid;
        [Piece { coef: near_a, verts: va }, Piece { coef: near_b, verts: vb }]
    }

    /// `(lower, upper, splits)` of the minimum of the exact det J over the
    /// element, given `poly` whose coefficients are within `err` of the
    /// exact ones: the branch and bound of [`super::branch`] on
    /// sub-simplices. One split is one bisection (two pieces); `D`
    /// bisections halve a piece about as one box split does.
    fn bound_min(&self, poly: Coef, err: f64, goal: Goal) -> (f64, f64, usize) {
        // A bisection applies to each line of coefficients rows of
        // non-negative weights summing to one (at most deg averaging
        // steps, one rounding each).
        let n = self.dim * (self.p - 1);
        super::branch::bound_min(&Piece { coef: poly, verts: REFERENCE }, self, self.dim, n + 2, err, goal)
    }

    /// Whether `det J > 0` on the whole element (control points in lattice
    /// order), decided conservatively: `true` is a proof; `false` means
    /// invalid or so nearly invalid that det J comes within the Bernstein
    /// bound's slack of 0 on a piece `D ·` [`MAX_SUBDIVISION_DEPTH`](super::certify::MAX_SUBDIVISION_DEPTH)
    /// bisections deep. Cheaper than [`SimplexCertifier::certify`].
    ///
    /// # Panics
    /// If `D` is not the shape's dimension or `ctrl` has the wrong length.
    pub fn is_valid<const D: usize>(&self, ctrl: &[[f64; D]]) -> bool {
        let (parts, err, _) = self.det_j(ctrl);
        self.bound_min(parts.det, err, Goal::Sign).0 > 0.0
    }

    /// The certificate of the element with control points `ctrl` (lattice
    /// order): the bracket of `min det J`, a bound of `max det J`, and the
    /// sampled minima of det J and of the scaled Jacobian on the lattice
    /// of `opts.samples` points per edge (`0`: `3p + 1`).
    ///
    /// # Panics
    /// If `D` is not the shape's dimension or `ctrl` has the wrong length.
    pub fn certify<const D: usize>(&self, ctrl: &[[f64; D]], opts: &CertifyOptions) -> Certificate {
        let (parts, err, s) = self.det_j(ctrl);
        let (min_det, min_sj) = match constant_jacobian(&parts.col, parts.deriv_max) {
            // a straight-sided element (most of a mesh curved at its walls):
            // its J, hence both figures, is the same at every sample
            Some(j) => (det(&j), scaled_jacobian(&j)),
            None => self.sample(&parts.col, opts.sample_count(self.p)),
        };
        let neg: Coef = parts.det.iter().map(|c| -c).collect();
        let (min, neg, splits) = brackets(parts.det, neg, err, opts, |c, e, g| self.bound_min(c, e, g));
        Certificate::of_normalised(D, s, min, neg, (min_det, min_sj), splits)
    }

    /// The two figures the optimiser of [`crate::highorder::optimise`]
    /// weighs, without the bounds' branch and bound: the least Bernstein
    /// coefficient of det J, unsplit, in the units of `ctrl` (over the
    /// straight element's det J it is Gmsh's `minSJ`, its
    /// `distoShapeMeasure`), and the sampled least scaled Jacobian of
    /// [`Self::certify`] (on the default lattice).
    ///
    /// # Panics
    /// If `D` is not the shape's dimension or `ctrl` has the wrong length.
    pub fn shape_figures<const D: usize>(&self, ctrl: &[[f64; D]]) -> (f64, f64) {
        let (col, s) = self.columns(ctrl);
        (self.least_of(&col, s), self.sample(&col, self.samples.0).1)
    }

    /// The first of [`Self::shape_figures`] alone: the least Bernstein
    /// coefficient of det J, in the units of `ctrl`.
    pub fn least_coefficient<const D: usize>(&self, ctrl: &[[f64; D]]) -> f64 {
        let (col, s) = self.columns(ctrl);
        self.least_of(&col, s)
    }

    /// The least coefficient of det J from the columns of the normalised
    /// element of scale `s`, in the units of the element.
    fn least_of<const D: usize>(&self, col: &[[Coef; D]; D], s: f64) -> f64 {
        let det = if D == 2 { self.cross2(col, -1.0) } else { self.triple(col, -1.0) };
        det.iter().copied().fold(f64::INFINITY, f64::min) * s.powi(D as i32)
    }

    /// The Bernstein coefficients of J's columns of the element normalised
    /// as [`Self::det_j`] does, and its scale (no companion, no rounding
    /// bound: for figures, not proofs).
    fn columns<const D: usize>(&self, ctrl: &[[f64; D]]) -> ([[Coef; D]; D], f64) {
        assert!(D == self.dim && ctrl.len() == self.conv.n, "a {}-node {}D simplex given {} points in {D}D", self.conv.n, self.dim, ctrl.len());
        let (centre, s) = normalise(ctrl);
        let x: [Coef; D] = std::array::from_fn(|r| self.conv.apply(&ctrl.iter().map(|c| (c[r] - centre[r]) / s).collect::<Coef>()));
        (std::array::from_fn(|c| std::array::from_fn(|r| self.deriv.apply(c, &x[r]))), s)
    }

    /// `(min det J, min scaled Jacobian)` of the normalised element over
    /// the lattice of `m` points per edge, J from the Bernstein
    /// derivatives.
    fn sample<const D: usize>(&self, col: &[[Coef; D]; D], m: usize) -> (f64, f64) {
        let (mut min_det, mut min_sj) = (f64::INFINITY, f64::INFINITY);
        let mut visit = |basis: &[f64]| {
            let j: [[f64; D]; D] = std::array::from_fn(|r| std::array::from_fn(|c| col[c][r].iter().zip(basis).map(|(x, b)| x * b).sum()));
            min_det = min_det.min(det(&j));
            min_sj = min_sj.min(scaled_jacobian(&j));
        };
        if m == self.samples.0 {
            self.samples.1.chunks_exact(self.grad.len()).for_each(visit);
        } else {
            let mut basis: Coef = smallvec![0.0; self.grad.len()];
            for x in lattice_points(D, m) {
                self.grad.basis(x, &mut basis);
                visit(&basis);
            }
        }
        (min_det, min_sj)
    }
}

/// J of an affine element: when every entry's Bernstein coefficients
/// agree to rounding (relative to the largest, `deriv_max`), J is that
/// constant (a vertex value: the first coefficient).
pub(crate) fn constant_jacobian<const D: usize>(col: &[[Coef; D]; D], deriv_max: f64) -> Option<[[f64; D]; D]> {
    let tol = 64.0 * f64::EPSILON * deriv_max;
    let flat = col.iter().flatten().all(|c| c.iter().all(|&v| (v - c[0]).abs() <= tol));
    flat.then(|| std::array::from_fn(|r| std::array::from_fn(|c| col[c][r][0])))
}

/// The points of the lattice of `m ≥ 2` points per edge of the simplex.
fn lattice_points(dim: usize, m: usize) -> impl Iterator<Item = [f64; 3]> {
    multi_indices(dim, m - 1).map(move |a| a.map(|i| i as f64 / (m - 1) as f64))
}

/// Gmsh's scaled Jacobian of a simplex at a point, from the Jacobian `j`
/// (rows: coordinates; columns: `∂x/∂ξ_c`): its IGE measure ("inverse
/// gradient error", `_computeIGE` of Gmsh's qualityMeasuresJacobian.cpp,
/// whose sampled minimum `getElementQualities` calls `minSIGE` and whose
/// Bézier-bounded minimum is `MElement::minScaledJacobian`). With `v` the
/// lengths of the images of the reference edges (triangle: `|x_ξ|`,
/// `|x_η|`, `|x_η − x_ξ|`; tetrahedron: `|x_ξ|`, `|x_η|`, `|x_ζ|`,
/// `|x_η − x_ξ|`, `|x_ζ − x_ξ|`, `|x_ζ − x_η|`):
/// - triangle: `(2/√3) det J · mean(1/(v0 v1), 1/(v0 v2), 1/(v1 v2))`, the
///   mean of the sines of the three corner angles over sin 60°;
/// - tetrahedron: `√2 det J · mean of 1/(v_a v_b v_c)` over the 12 triples
///   made of a pair of opposite edges and one other edge.
///
/// Both are 1 for the equilateral triangle and the regular tetrahedron
/// (and for no other affine simplex), negative where J is. (Gmsh's
/// `minSJ` quality is another figure: `distoShapeMeasure`, the smallest
/// Bernstein coefficient of `det J / |det J|` of the straight-sided
/// element, 1 for every affine simplex.)
pub(crate) fn scaled_jacobian<const D: usize>(j: &[[f64; D]; D]) -> f64 {
    let col = |c: usize| -> [f64; D] { std::array::from_fn(|r| j[r][c]) };
    // (√ of the sum of squares, as Gmsh: the element is normalised, so
    // nothing overflows, and it is several times faster than hypot)
    let norm = |v: [f64; D]| dot(v, v).sqrt();
    let d = det(j);
    if D == 2 {
        let (a, b) = (col(0), col(1));
        let v = [norm(a), norm(b), norm(sub(b, a))];
        2.0 / 3f64.sqrt() * d * (1.0 / (v[0] * v[1]) + 1.0 / (v[0] * v[2]) + 1.0 / (v[1] * v[2])) / 3.0
    } else {
        let (a, b, c) = (col(0), col(1), col(2));
        let v = [norm(a), norm(b), norm(c), norm(sub(b, a)), norm(sub(c, a)), norm(sub(c, b))];
        let mut sum = 0.0;
        for (e, f) in [(0, 5), (1, 4), (2, 3)] {
            for g in (0..6).filter(|&g| g != e && g != f) {
                sum += 1.0 / (v[e] * v[f] * v[g]);
            }
        }
        std::f64::consts::SQRT_2 * d * sum / 12.0
    }
}

/// `det J` of a straight triangle or tetrahedron (`corners` by vertex:
/// origin, then `e_1, e_2 (, e_3)`) scaled by `1/s^D` for the power of two
/// `s` of [`normalise`], and a bound on its rounding.
///
/// Why it holds: the edges `x_c − x_0` are differences of exact inputs,
/// one rounding each; dividing by `s` is exact. A 2×2 determinant is two
/// products and a difference (each elementary product `(1+θ)^4`), a 3×3
/// cofactor expansion minors, products and two sums (`(1+θ)^8`), so the
/// error is `≤ γ_k` times the sum of the absolute elementary products,
/// `k = 4, 8`, which is computed with `k` roundings itself.
fn linear_det<const D: usize, const N: usize>(corners: &[[f64; D]; N]) -> (f64, f64) {
    // a runtime check: callers generic over the kind branch on it
    assert!(N == D + 1 && (D == 2 || D == 3), "a linear simplex has D + 1 corners in 2D or 3D");
    let s = normalise(corners).1;
    let j: [[f64; D]; D] = std::array::from_fn(|r| std::array::from_fn(|c| (corners[c + 1][r] - corners[0][r]) / s));
    let a = j.map(|row| row.map(f64::abs));
    let (size, k) = if D == 2 {
        (a[0][0] * a[1][1] + a[0][1] * a[1][0], 4)
    } else {
        let m = |r: usize, c: usize| a[r][c];
        let size = m(0, 0) * (m(1, 1) * m(2, 2) + m(1, 2) * m(2, 1)) + m(0, 1) * (m(1, 0) * m(2, 2) + m(1, 2) * m(2, 0)) + m(0, 2) * (m(1, 0) * m(2, 1) + m(1, 1) * m(2, 0));
        (size, 8)
    };
    let g = gamma(k);
    (det(&j), g / (1.0 - g) * size * (1.0 + 4.0 * U))
}

/// Whether `det J > 0` on a straight triangle (`D = N − 1 = 2`) or
/// tetrahedron (`D = N − 1 = 3`), `corners` by vertex (origin, then `e_1,
/// e_2 (, e_3)` of the reference simplex): det J is constant, so this is
/// its sign, `true` only when it exceeds its rounding bound. Independent
/// of position and (power-of-two) size, and free of under- and overflow
/// for any normal coordinates: Algorithm 1's per-step check of a P1 cell.
pub fn linear_simplex_is_valid<const D: usize, const N: usize>(corners: &[[f64; D]; N]) -> bool {
    let (d, err) = linear_det(corners);
    d > err
}

/// The reference nodes of the equispaced order-`p` triangle or
/// tetrahedron in lattice order (tests only: the crate's node sets are
/// those of `mesh::element`).
#[cfg(test)]
pub fn equispaced_nodes(shape: Shape, p: usize) -> Vec<[f64; 3]> {
    lattice_points(shape.dim(), p + 1).collect()
}


#[cfg(test)]
mod tests {
    use super::*;
    use crate::quality::tests::{lcg, threshold};
    use crate::numeric::simplex_bezier::coef_bounds;


    const SHAPES: [Shape; 2] = [Shape::Triangle, Shape::Tetrahedron];

    fn certifier(shape: Shape, p: usize, nodes: &[[f64; 3]]) -> SimplexCertifier {
        SimplexCertifier::new(shape, p, nodes).unwrap()
    }

    /// Equispaced nodes with every node but the vertices moved by up to
    /// `amp` in each coordinate (a stand-in for a warp-blend set).
    fn perturbed_nodes(shape: Shape, p: usize, amp: f64, seed: &mut u64) -> Vec<[f64; 3]> {
        let d = shape.dim();
        let vertex = |q: &[f64; 3]| q[..d].iter().all(|&c| c == 0.0) || q[..d].contains(&1.0);
        equispaced_nodes(shape, p).into_iter().map(|q| if vertex(&q) { q } else { std::array::from_fn(|c| if c < d { q[c] + amp * lcg(seed) } else { 0.0 }) }).collect()
    }

    /// A curved element on `nodes`: a random affine image (linear part of
    /// determinant > ½) of the reference simplex bent by `ξ_r += bend
    /// sin(2 ξ_{r+1} + 1.5 ξ_r + φ_r)`, every node then moved by up to
    /// `noise`.
    fn curved<const D: usize>(nodes: &[[f64; 3]], bend: f64, noise: f64, seed: &mut u64) -> Vec<[f64; D]> {
        let a: [[f64; D]; D] = loop {
            let a = std::array::from_fn(|r| std::array::from_fn(|c| f64::from(u8::from(r == c)) + 0.35 * lcg(seed)));
            if det(&a) > 0.5 {
                break a;
            }
        };
        let t: [f64; D] = std::array::from_fn(|_| lcg(seed));
        let phase: [f64; D] = std::array::from_fn(|_| 3.0 * lcg(seed));
        nodes
            .iter()
            .map(|x| {
                let y: [f64; D] = std::array::from_fn(|r| x[r] + bend * (2.0 * x[(r + 1) % D] + 1.5 * x[r] + phase[r]).sin());
                std::array::from_fn(|r| (0..D).map(|c| a[r][c] * y[c]).sum::<f64>() + t[r] + noise * lcg(seed))
            })
            .collect()
    }

    /// An independent evaluator of the map: the interpolant through the
    /// nodes in the monomial basis `Π (ξ_c − ¼)^{e_c}` of total degree ≤ p,
    /// by Gaussian elimination (no Bernstein polynomial involved).
    struct Monomial<const D: usize> {
        exps: Vec<[i32; 3]>,
        coef: Vec<[f64; D]>,
    }

    impl<const D: usize> Monomial<D> {
        fn new(p: usize, nodes: &[[f64; 3]], ctrl: &[[f64; D]]) -> Self {
            let p = p as i32;
            let mut exps = Vec::new();
            for a in 0..=p {
                for b in 0..=p - a {
                    for c in 0..=if D == 3 { p - a - b } else { 0 } {
                        exps.push([a, b, c]);
                    }
                }
            }
            let n = exps.len();
            let mono = |x: &[f64; 3], e: &[i32; 3]| (0..3).map(|c| (x[c] - 0.25).powi(e[c])).product::<f64>();
            let mut a: Vec<Vec<f64>> = nodes.iter().map(|x| exps.iter().map(|e| mono(x, e)).collect()).collect();
            let mut b: Vec<[f64; D]> = ctrl.to_vec();
            for col in 0..n {
                let piv = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs())).unwrap();
                a.swap(col, piv);
                b.swap(col, piv);
                let (prow, pb) = (a[col].clone(), b[col]);
                for r in col + 1..n {
                    let f = a[r][col] / prow[col];
                    for (x, y) in a[r][col..].iter_mut().zip(&prow[col..]) {
                        *x -= f * y;
                    }
                    for (x, y) in b[r].iter_mut().zip(&pb) {
                        *x -= f * y;
                    }
                }
            }
            for col in (0..n).rev() {
                let s: [f64; D] = std::array::from_fn(|k| (col + 1..n).map(|j| a[col][j] * b[j][k]).sum());
                b[col] = std::array::from_fn(|k| (b[col][k] - s[k]) / a[col][col]);
            }
            Monomial { exps, coef: b }
        }

        /// `J[r][c] = ∂x_r/∂ξ_c` at `x`.
        fn jacobian(&self, x: [f64; 3]) -> [[f64; D]; D] {
            let mut j = [[0.0; D]; D];
            for (e, a) in self.exps.iter().zip(&self.coef) {
                for c in (0..D).filter(|&c| e[c] > 0) {
                    let g: f64 = (0..3).map(|k| if k == c { f64::from(e[k]) * (x[k] - 0.25).powi(e[k] - 1) } else { (x[k] - 0.25).powi(e[k]) }).product();
                    for r in 0..D {
                        j[r][c] += g * a[r];
                    }
                }
            }
            j
        }

        fn det(&self, x: [f64; 3]) -> f64 {
            det(&self.jacobian(x))
        }

        /// The minimum of det J: the best point of a lattice of `m` points
        /// per edge, refined by a compass search inside the simplex along
        /// the axes and the edge directions (so it also slides along the
        /// slanted face).
        fn min_det(&self, m: usize) -> f64 {
            let inside = |x: &[f64; 3]| x[..D].iter().all(|&c| c >= 0.0) && x[..D].iter().sum::<f64>() <= 1.0;
            let mut best = (f64::INFINITY, [0.0; 3]);
            for a in multi_indices(D, m - 1) {
                let x = a.map(|i| i as f64 / (m - 1) as f64);
                let v = self.det(x);
                if v < best.0 {
                    best = (v, x);
                }
            }
            let mut dirs: Vec<[f64; 3]> = Vec::new();
            for c in 0..D {
                let e: [f64; 3] = std::array::from_fn(|k| f64::from(u8::from(k == c)));
                dirs.extend([e, e.map(|v| -v)]);
                for d in c + 1..D {
                    let mut f = e;
                    f[d] = -1.0;
                    dirs.extend([f, f.map(|v| -v)]);
                }
            }
            let mut h = 1.0 / (m - 1) as f64;
            while h > 1e-10 {
                let step = dirs.iter().map(|d| std::array::from_fn(|k| best.1[k] + h * d[k])).filter(inside).map(|x| (self.det(x), x)).min_by(|u, v| u.0.total_cmp(&v.0));
                match step {
                    Some(s) if s.0 < best.0 => best = s,
                    _ => h *= 0.5,
                }
            }
            best.0
        }
    }

    /// Certifies one element and checks the certificate against the
    /// independent dense minimum; returns whether it was certified valid.
    fn check_against_sampling<const D: usize>(cert: &SimplexCertifier, p: usize, nodes: &[[f64; 3]], q: &[[f64; D]], label: &str) -> (bool, bool) {
        let opts = CertifyOptions::default();
        let c = cert.certify(q, &opts);
        let min = Monomial::new(p, nodes, q).min_det(if D == 2 { 41 } else { 17 });
        let scale = c.max_det.abs().max(c.min_det_lower.abs());
        // the monomial evaluator's own rounding
        let tol = 1e-10 * scale;
        assert!(c.min_det_lower <= min + tol, "{label}: lower above the minimum {min}: {c:?}");
        assert!(c.min_det_lower <= c.min_det_upper && c.min_det_upper <= c.min_det_sampled, "{label}: {c:?}");
        assert!(c.max_det >= c.min_det_upper, "{label}: {c:?}");
        // settled: the bracket is rel_tol wide plus twice the rounding
        // bound (and the splits' far smaller rounding)
        let (_, err, s) = cert.det_j(q);
        let err = (0..D).fold(err, |e, _| e * s);
        let settled = c.min_det_upper - c.min_det_lower <= opts.rel_tol * c.min_det_upper.abs().max(1e-9 * scale) + 2.0 * err + 1e-12 * scale;
        if settled {
            assert!(c.min_det_upper >= min - opts.rel_tol * min.abs() - tol, "{label}: upper below the minimum {min}: {c:?}");
        }
        if c.valid {
            assert!(min > 0.0, "{label}: certified valid with minimum {min}");
        }
        if min < -1e-6 * scale {
            assert!(!c.valid && c.min_det_upper < 0.0, "{label}: minimum {min} not shown invalid: {c:?}");
        }
        if min > 1e-6 * scale && settled {
            assert!(c.valid, "{label}: minimum {min} not certified: {c:?}");
        }
        let ok = cert.is_valid(q);
        assert!(!ok || min > 0.0, "{label}: is_valid with minimum {min}");
        assert!(ok || min < 0.05 * scale, "{label}: is_valid refused minimum {min} of {scale}");
        (c.valid, settled)
    }

    /// On random curved triangles and tetrahedra of orders 2 to 4, valid
    /// and inverted, the certificate brackets the minimum of det J found by
    /// dense sampling (and a local search) of an independent evaluator,
    /// and decides validity as it does.
    #[test]
    fn certificate_brackets_the_dense_minimum() {
        let mut seed = 0x5EED;
        let (mut valid, mut invalid, mut unsettled) = (0, 0, 0);
        for shape in SHAPES {
            for p in 2..=4 {
                let nodes = equispaced_nodes(shape, p);
                let cert = certifier(shape, p, &nodes);
                for n in 0..18 {
                    let (bend, noise) = ([0.05, 0.2, 0.4][n % 3], [0.0, 0.04, 0.12][n / 3 % 3]);
                    let label = format!("{shape:?} p={p} #{n}");
                    let (ok, settled) = if shape.dim() == 2 {
                        check_against_sampling::<2>(&cert, p, &nodes, &curved(&nodes, bend, noise, &mut seed), &label)
                    } else {
                        check_against_sampling::<3>(&cert, p, &nodes, &curved(&nodes, bend, noise, &mut seed), &label)
                    };
                    if ok { valid += 1 } else { invalid += 1 }
                    unsettled += usize::from(!settled);
                }
            }
        }
        assert!(valid > 30 && invalid > 20 && unsettled == 0, "{valid} valid, {invalid} invalid, {unsettled} unsettled");
    }

    /// The Bernstein det J is the map's det J: at random points of random
    /// curved elements of every order, on equispaced and on perturbed node
    /// sets, it agrees with the independent evaluator to 1e-12 of its
    /// size, and its coefficients bound it.
    #[test]
    fn bernstein_det_is_the_map_det() {
        fn compare<const D: usize>(shape: Shape, p: usize, nodes: &[[f64; 3]], seed: &mut u64) {
            let q = curved::<D>(nodes, 0.2, 0.05, seed);
            let (parts, _, s) = certifier(shape, p, nodes).det_j(&q);
            let unit = (0..D).fold(1.0, |u, _| u * s);
            let lat = Lattice::new(D, D * (p - 1));
            assert_eq!(parts.det.len(), lat.len());
            let (lo, hi) = coef_bounds(&parts.det);
            let size = max_abs(&parts.det) * unit;
            let mono = Monomial::new(p, nodes, &q);
            for _ in 0..30 {
                let x = loop {
                    let x: [f64; 3] = std::array::from_fn(|c| if c < D { 0.5 + 0.5 * lcg(seed) } else { 0.0 });
                    if x.iter().sum::<f64>() <= 1.0 {
                        break x;
                    }
                };
                let (b, m) = (lat.eval(&parts.det, x) * unit, mono.det(x));
                assert!((b - m).abs() <= 1e-12 * size, "{shape:?} p={p}: {b} vs {m} at {x:?}");
                assert!(lo * unit <= m + 1e-12 * size && m <= hi * unit + 1e-12 * size);
            }
        }
        let mut seed = 7;
        for shape in SHAPES {
            for p in 1..=4 {
                for nodes in [equispaced_nodes(shape, p), perturbed_nodes(shape, p, 0.04, &mut seed)] {
                    if shape.dim() == 2 {
                        compare::<2>(shape, p, &nodes, &mut seed);
                    } else {
                        compare::<3>(shape, p, &nodes, &mut seed);
                    }
                }
            }
        }
    }

    /// An affine element's det J is the constant of its linear part:
    /// every coefficient is that value, the certificate brackets it to
    /// rounding with no split, and its sign is the verdict.
    #[test]
    fn affine_elements_have_their_constant_det() {
        fn check<const D: usize>(shape: Shape, p: usize, seed: &mut u64) {
            let nodes = equispaced_nodes(shape, p);
            let cert = certifier(shape, p, &nodes);
            for sign in [1.0, -1.0] {
                let mut a: [[f64; D]; D] = std::array::from_fn(|r| std::array::from_fn(|c| 2.0 * f64::from(u8::from(r == c)) + 0.5 * lcg(seed)));
                a[0] = a[0].map(|v| v * sign);
                let (exact, t): (f64, [f64; D]) = (det(&a), std::array::from_fn(|_| 3.0 * lcg(seed)));
                let q: Vec<[f64; D]> = nodes.iter().map(|x| std::array::from_fn(|r| (0..D).map(|c| a[r][c] * x[c]).sum::<f64>() + t[r])).collect();
                let (parts, _, s) = cert.det_j(&q);
                let unit = (0..D).fold(1.0, |u, _| u * s);
                for &b in &parts.det {
                    assert!((b * unit - exact).abs() <= 1e-13 * exact.abs(), "{shape:?} p={p}: {} vs {exact}", b * unit);
                }
                let c = cert.certify(&q, &CertifyOptions::default());
                let tol = 1e-13 * exact.abs();
                assert!(c.min_det_lower <= exact + tol && exact - tol <= c.min_det_upper, "{shape:?} p={p}: {exact} {c:?}");
                // the bracket is twice the rounding bound wide: measured
                // 1e-14 (P1 triangle) to 5.4e-11 (p = 4 tetrahedron) of det J
                assert!(c.min_det_upper - c.min_det_lower <= 1e-10 * exact.abs() && c.splits == 0, "{shape:?} p={p}: {c:?}");
                assert!((c.max_det - exact).abs() <= 1e-10 * exact.abs() && (c.min_det_sampled - exact).abs() <= tol);
                assert_eq!((c.valid, cert.is_valid(&q)), (sign > 0.0, sign > 0.0));
            }
        }
        let mut seed = 11;
        for p in 1..=4 {
            check::<2>(Shape::Triangle, p, &mut seed);
            check::<3>(Shape::Tetrahedron, p, &mut seed);
        }
    }

    /// Gmsh's normalisation: the equilateral triangle and the regular
    /// tetrahedron (any position, size and rotation, any order) have
    /// scaled Jacobian 1; the reference right triangle and trirectangular
    /// tetrahedron have `(2/√3)(1 + √2)/3` and `(2 + √2)/4`; bending an
    /// edge lowers it.
    #[test]
    fn scaled_jacobian_is_gmsh_s() {
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let rot = |[x, y]: [f64; 2]| [2.5 * (c * x - s * y) + 7.0, 2.5 * (s * x + c * y) - 1.0];
        let tri = [[0.0, 0.0], [1.0, 0.0], [0.5, 0.75f64.sqrt()]].map(rot);
        let tet = [[1.0, 1.0, 1.0], [-1.0, 1.0, -1.0], [1.0, -1.0, -1.0], [-1.0, -1.0, 1.0]].map(|v| v.map(|x| 0.7 * x + 2.0));
        let opts = CertifyOptions::default();
        for p in 1..=4 {
            let nodes = equispaced_nodes(Shape::Triangle, p);
            let map = |x: &[f64; 3]| -> [f64; 2] { std::array::from_fn(|r| tri[0][r] + x[0] * (tri[1][r] - tri[0][r]) + x[1] * (tri[2][r] - tri[0][r])) };
            let q: Vec<[f64; 2]> = nodes.iter().map(map).collect();
            let sj = certifier(Shape::Triangle, p, &nodes).certify(&q, &opts).min_scaled_jacobian;
            assert!((sj - 1.0).abs() < 1e-14, "p={p}: {sj}");
            let right: Vec<[f64; 2]> = nodes.iter().map(|x| [x[0], x[1]]).collect();
            let sj = certifier(Shape::Triangle, p, &nodes).certify(&right, &opts).min_scaled_jacobian;
            assert!((sj - 2.0 / 3f64.sqrt() * (1.0 + 2f64.sqrt()) / 3.0).abs() < 1e-14, "p={p}: {sj}");
            if p >= 2 {
                // the bottom edge's node (½, 0) pushed out: no longer straight
                let mut bent = q.clone();
                bent[1][1] -= 0.5;
                let sj = certifier(Shape::Triangle, p, &nodes).certify(&bent, &opts).min_scaled_jacobian;
                assert!(sj < 0.99, "p={p}: {sj}");
            }

            let nodes = equispaced_nodes(Shape::Tetrahedron, p);
            let map = |x: &[f64; 3]| -> [f64; 3] { std::array::from_fn(|r| tet[0][r] + (0..3).map(|c| x[c] * (tet[c + 1][r] - tet[0][r])).sum::<f64>()) };
            let q: Vec<[f64; 3]> = nodes.iter().map(map).collect();
            let c = certifier(Shape::Tetrahedron, p, &nodes).certify(&q, &opts);
            assert!(c.valid && (c.min_scaled_jacobian - 1.0).abs() < 1e-14, "p={p}: {c:?}");
            let sj = certifier(Shape::Tetrahedron, p, &nodes).certify(&nodes, &opts).min_scaled_jacobian;
            assert!((sj - (2.0 + 2f64.sqrt()) / 4.0).abs() < 1e-14, "p={p}: {sj}");
        }
    }

    /// An edge node pushed across the element (p = 2 and 3): certified
    /// invalid, with a value of det J below zero.
    #[test]
    fn pushed_edge_node_is_certified_invalid() {
        let opts = CertifyOptions::default();
        for p in 2..=3 {
            let nodes = equispaced_nodes(Shape::Triangle, p);
            let mut q: Vec<[f64; 2]> = nodes.iter().map(|x| [x[0], x[1]]).collect();
            // the first node inside the bottom edge, beyond the hypotenuse
            q[1] = [q[1][0], 1.2];
            let cert = certifier(Shape::Triangle, p, &nodes);
            let c = cert.certify(&q, &opts);
            assert!(!c.valid && c.min_det_upper < 0.0 && c.min_det_lower <= c.min_det_upper && !cert.is_valid(&q), "p={p}: {c:?}");

            let nodes = equispaced_nodes(Shape::Tetrahedron, p);
            let mut q = nodes.clone();
            // the first node inside the edge along ξ, beyond the slanted face
            q[1] = [q[1][0], 0.5, 0.5];
            let cert = certifier(Shape::Tetrahedron, p, &nodes);
            let c = cert.certify(&q, &opts);
            assert!(!c.valid && c.min_det_upper < 0.0 && !cert.is_valid(&q), "p={p}: {c:?}");
        }
    }

    /// A p = 2 triangle whose hypotenuse node (½, ½) is pulled towards the
    /// origin by `lam` times a dyadic vector, or the p = 2 tetrahedron
    /// whose node (½, ½, 0) is: every coordinate a multiple of 2^-32, so
    /// adding 1e6 is exact.
    fn pulled<const D: usize>(lam: f64) -> Vec<[f64; D]> {
        let shape = if D == 2 { Shape::Triangle } else { Shape::Tetrahedron };
        let mut q: Vec<[f64; D]> = equispaced_nodes(shape, 2).iter().map(|x| std::array::from_fn(|r| x[r])).collect();
        // (odd numerators: det J does not vanish exactly at a dyadic lam)
        q[4][0] -= lam * 0.46875;
        q[4][1] -= lam * 0.4375;
        q
    }

    /// [`crate::quality::tests::check_moves`] with `cert`.
    fn check_moves<const D: usize>(cert: &SimplexCertifier, q: &[[f64; D]], dyadic: bool) -> Certificate {
        crate::quality::tests::check_moves(|q| cert.certify(q, &CertifyOptions::default()), |q| cert.is_valid(q), q, dyadic)
    }

    /// Random curved elements (on a dyadic grid) and a barely valid and a
    /// barely invalid one (min det J about ±4e-9 of its size) keep their
    /// verdicts and (scaled) bounds when moved by 1e6 or scaled by 2^-20
    /// or 1e-6.
    #[test]
    fn verdicts_do_not_depend_on_position_or_size() {
        fn random<const D: usize>(shape: Shape, seed: &mut u64) {
            for p in 2..=4 {
                let nodes = equispaced_nodes(shape, p);
                let cert = certifier(shape, p, &nodes);
                for n in 0..4 {
                    let grid = 2f64.powi(30);
                    let q: Vec<[f64; D]> = curved::<D>(&nodes, [0.1, 0.4][n % 2], 0.05, seed).iter().map(|c| c.map(|x| (x * grid).round() / grid)).collect();
                    check_moves(&cert, &q, true);
                }
            }
        }
        fn barely<const D: usize>() {
            let shape = if D == 2 { Shape::Triangle } else { Shape::Tetrahedron };
            let cert = certifier(shape, 2, &equispaced_nodes(shape, 2));
            let opts = CertifyOptions::default();
            let (valid, invalid) = threshold(pulled::<D>, |q| {
                let c = cert.certify(q, &opts);
                assert!(c.valid || c.min_det_upper <= 0.0, "undecided: {c:?}");
                c.valid
            });
            let (cv, ci) = (check_moves(&cert, &valid, true), check_moves(&cert, &invalid, true));
            let size = cv.max_det;
            assert!(cv.valid && cv.min_det_lower < 1e-7 * size, "{cv:?}");
            assert!(!ci.valid && ci.min_det_upper < 0.0 && ci.min_det_upper > -1e-7 * size, "{ci:?}");
        }
        let mut seed = 0xD1AD;
        random::<2>(Shape::Triangle, &mut seed);
        random::<3>(Shape::Tetrahedron, &mut seed);
        barely::<2>();
        barely::<3>();
    }

    /// The rounding bound is small next to det J and scales with it.
    #[test]
    fn rounding_bound_is_small_and_scale_free() {
        fn check<const D: usize>(shape: Shape, seed: &mut u64) {
            for p in 1..=4 {
                let nodes = equispaced_nodes(shape, p);
                let q = curved::<D>(&nodes, 0.2, 0.05, seed);
                let cert = certifier(shape, p, &nodes);
                let (parts, err, _) = cert.det_j(&q);
                // measured 1.6e-14 (P1 triangle) to 1.6e-10 (p = 4 tetrahedron)
                assert!(err > 0.0 && err < 1e-9 * max_abs(&parts.det), "{shape:?} p={p}: {err} vs {}", max_abs(&parts.det));
                let (scaled, err2, _) = cert.det_j(&q.iter().map(|c| c.map(|x| x * 2f64.powi(-30))).collect::<Vec<_>>());
                assert_eq!((err2, scaled.det), (err, parts.det));
            }
        }
        let mut seed = 5;
        check::<2>(Shape::Triangle, &mut seed);
        check::<3>(Shape::Tetrahedron, &mut seed);
    }

    /// Subdivision tightens the bound: the raw coefficient minimum of a
    /// curved element is well below the certified one; with no split the
    /// bound is the raw minimum less the rounding bound.
    #[test]
    fn subdivision_tightens_the_bound() {
        let mut seed = 99;
        let nodes = equispaced_nodes(Shape::Tetrahedron, 3);
        let cert = certifier(Shape::Tetrahedron, 3, &nodes);
        let q = curved::<3>(&nodes, 0.3, 0.02, &mut seed);
        let (parts, err, s) = cert.det_j(&q);
        let unit = s * s * s;
        let raw = coef_bounds(&parts.det).0 * unit;
        let c = cert.certify(&q, &CertifyOptions::default());
        assert!(c.valid && c.splits > 0, "{c:?}");
        assert!(c.min_det_upper - raw > 100.0 * (c.min_det_upper - c.min_det_lower), "{raw} {c:?}");
        let coarse = cert.certify(&q, &CertifyOptions { max_splits: 0, ..Default::default() });
        assert_eq!(coarse.min_det_lower, raw - err * unit, "{raw} {coarse:?}");
    }

    /// A coordinate that is NaN or infinite gives no bound: never valid.
    #[test]
    fn non_finite_coordinates_are_not_valid() {
        let nodes = equispaced_nodes(Shape::Tetrahedron, 3);
        let cert = certifier(Shape::Tetrahedron, 3, &nodes);
        for bad in [f64::NAN, f64::INFINITY] {
            let mut q = nodes.clone();
            q[7][1] = bad;
            let c = cert.certify(&q, &CertifyOptions::default());
            assert!(!c.valid && c.min_det_lower == f64::NEG_INFINITY && !cert.is_valid(&q), "{c:?}");
            assert!(!linear_simplex_is_valid(&[[0.0; 2], [1.0, 0.0], [0.0, bad]]));
        }
    }

    #[test]
    fn wrong_shape_order_or_node_count_is_an_error() {
        let tri = equispaced_nodes(Shape::Triangle, 2);
        assert!(matches!(SimplexCertifier::new(Shape::Quadrilateral, 2, &[[0.0; 3]; 9]), Err(HighOrderError::NodeCount { expected: 0, .. })));
        assert!(matches!(SimplexCertifier::new(Shape::Triangle, 5, &equispaced_nodes(Shape::Triangle, 5)), Err(HighOrderError::UnsupportedOrder(5))));
        assert!(matches!(SimplexCertifier::new(Shape::Tetrahedron, 2, &tri), Err(HighOrderError::NodeCount { expected: 10, found: 6, .. })));
        assert!(SimplexCertifier::new(Shape::Triangle, 2, &tri).is_ok());
    }

    #[test]
    #[should_panic(expected = "not unisolvent")]
    fn coinciding_nodes_are_refused() {
        let mut nodes = equispaced_nodes(Shape::Triangle, 2);
        nodes[4] = nodes[3];
        let _ = SimplexCertifier::new(Shape::Triangle, 2, &nodes);
    }

    // The linear check (P1).

    /// On random straight triangles and tetrahedra, at many positions and
    /// sizes, the P1 check gives the sign of det J whenever it is clear of
    /// rounding, and the certifier's verdict at p = 1.
    #[test]
    fn linear_check_is_the_sign_of_det_j() {
        fn check<const D: usize, const N: usize>(seed: &mut u64) -> (usize, usize) {
            let shape = if D == 2 { Shape::Triangle } else { Shape::Tetrahedron };
            let cert = certifier(shape, 1, &equispaced_nodes(shape, 1));
            let (mut valid, mut invalid) = (0, 0);
            for n in 0..300 {
                let (scale, shift) = [(1.0, 0.0), (1e-5, 1e3), (1e4, -1e6), (1e-150, 1e-149)][n % 4];
                let v: [[f64; D]; N] = std::array::from_fn(|a| std::array::from_fn(|r| (f64::from(u8::from(a == r + 1)) + lcg(seed)) * scale + shift));
                let e: [[f64; D]; D] = std::array::from_fn(|r| std::array::from_fn(|c| (v[c + 1][r] - v[0][r]) / scale));
                let d = det(&e);
                let ok = linear_simplex_is_valid(&v);
                assert_eq!(ok, cert.certify(&v, &CertifyOptions::default()).valid || d.abs() < 1e-10, "cell {n}: det {d}");
                if d.abs() > 1e-10 {
                    assert_eq!(ok, d > 0.0, "cell {n}: det {d}");
                }
                if ok { valid += 1 } else { invalid += 1 }
            }
            (valid, invalid)
        }
        let mut seed = 0x9E37;
        for (valid, invalid) in [check::<2, 3>(&mut seed), check::<3, 4>(&mut seed)] {
            assert!(valid > 100 && invalid > 50, "{valid} {invalid}");
        }
    }

    /// The apex of a triangle or tetrahedron approaching the plane of the
    /// others in dyadic steps: the barely valid and the barely invalid
    /// cell keep their verdicts translated by 1e6, scaled by 1e-6, 2^-40
    /// or 1e-200 (no underflow) and 1e200 (no overflow).
    #[test]
    fn linear_verdicts_do_not_depend_on_position_or_size() {
        fn check<const D: usize, const N: usize>(make: impl Fn(f64) -> [[f64; D]; N]) {
            let (valid, invalid) = threshold(make, linear_simplex_is_valid);
            assert!(linear_det(&valid).0 < 1e-7 && linear_det(&invalid).0 < 1e-7, "{:?} {:?}", linear_det(&valid), linear_det(&invalid));
            for (cell, verdict) in [(valid, true), (invalid, false)] {
                for f in [|c: f64| c + 1e6, |c| c * 1e-6, |c| c * 2f64.powi(-40), |c| c * 1e-200, |c| c * 1e200, |c| c] {
                    assert_eq!(linear_simplex_is_valid(&cell.map(|x| x.map(f))), verdict);
                }
            }
        }
        // the plane through (0,0), (1, ¼): the apex (½, ¼ − lam) crosses
        // it at lam = ⅛
        check(|lam| [[0.0, 0.0], [1.0, 0.25], [0.5, 0.25 - lam]]);
        check(|lam| [[0.0, 0.0, 0.0], [1.0, 0.25, 0.0], [0.0, 1.0, 0.5], [0.25, 0.25, 0.5 - lam]]);
    }

    /// A p = 2 triangle with its bottom mid-edge node and its hypotenuse
    /// node moved (found by a random search): det J ≥ 0.31 at all six
    /// nodes and positive on the whole default sampling lattice, but
    /// negative between its points. The certificate proves it invalid and
    /// brackets the independent evaluator's minimum.
    #[test]
    fn invalid_between_the_samples_is_found() {
        let nodes = equispaced_nodes(Shape::Triangle, 2);
        let mut q: Vec<[f64; 2]> = nodes.iter().map(|x| [x[0], x[1]]).collect();
        q[1] = [0.5 - 0.15625, 0.46875];
        q[4] = [0.5 + 0.34375, 0.5 + 0.125];
        let cert = certifier(Shape::Triangle, 2, &nodes);
        let at_nodes = cert.certify(&q, &CertifyOptions { samples: 3, ..Default::default() });
        assert!(at_nodes.min_det_sampled > 0.31, "{at_nodes:?}");
        let c = cert.certify(&q, &CertifyOptions::default());
        assert!(c.min_det_sampled > 0.01 && !c.valid && c.min_det_upper < -0.018 && !cert.is_valid(&q), "{c:?}");
        let min = Monomial::new(2, &nodes, &q).min_det(101);
        assert!(c.min_det_lower <= min && (min - c.min_det_upper).abs() < 1e-9, "{min} {c:?}");
    }

    /// On the crate's warp & blend node sets (`mesh::element::simplex`),
    /// the certifier's det J is the det J of that module's own Lagrange
    /// basis, and the certificate bounds it.
    #[test]
    fn warp_blend_nodes_give_the_det_of_their_basis() {
        use crate::mesh::element::{simplex::space, Spacing};
        fn compare<const D: usize>(shape: Shape, p: usize, seed: &mut u64) {
            let sp = space(shape, p, Spacing::GaussLobatto).unwrap();
            let cert = certifier(shape, p, &sp.nodes);
            let q = curved::<D>(&sp.nodes, 0.2, 0.05, seed);
            let (parts, _, s) = cert.det_j(&q);
            let unit = (0..D).fold(1.0, |u, _| u * s);
            let lat = Lattice::new(D, D * (p - 1));
            let size = max_abs(&parts.det) * unit;
            let c = cert.certify(&q, &CertifyOptions::default());
            let n = sp.num_nodes();
            let (mut values, mut grads) = (vec![0.0; n], vec![[0.0; 3]; n]);
            for _ in 0..20 {
                let x = loop {
                    let x: [f64; 3] = std::array::from_fn(|c| if c < D { 0.5 + 0.5 * lcg(seed) } else { 0.0 });
                    if x.iter().sum::<f64>() <= 1.0 {
                        break x;
                    }
                };
                sp.eval(x, &mut values, &mut grads);
                let j: [[f64; D]; D] = std::array::from_fn(|r| std::array::from_fn(|k| (0..n).map(|i| q[i][r] * grads[i][k]).sum()));
                let b = lat.eval(&parts.det, x) * unit;
                assert!((b - det(&j)).abs() <= 1e-12 * size, "{shape:?} p={p}: {b} vs {}", det(&j));
                assert!(c.min_det_lower <= det(&j) && det(&j) <= c.max_det, "{c:?}");
            }
        }
        let mut seed = 31;
        for p in 1..=4 {
            compare::<2>(Shape::Triangle, p, &mut seed);
            compare::<3>(Shape::Tetrahedron, p, &mut seed);
        }
    }
}
