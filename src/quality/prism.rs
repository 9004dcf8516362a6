//! The validity certificate of a curved prism (wedge) of order `p = 1..=4`:
//! the prism counterpart of [`super::certify`] and [`super::simplex`],
//! with the same [`Certificate`], [`CertifyOptions`] and branch-and-bound
//! goals.
//!
//! **Degrees.** The map of an order-`p` prism lies in `P_p(ξ, η) ⊗
//! P_p(ζ)` (total degree `p` on the triangle, degree `p` along z). Its
//! columns `x_ξ`, `x_η` lie in `P_{p−1} ⊗ P_p` and `x_ζ` in `P_p ⊗
//! P_{p−1}`; every term of `det J = x_ζ · (x_ξ × x_η)` takes one factor of
//! each, so det J lies in `P_{3p−2} ⊗ P_{3p−1}`: for `p = 1` degree 1 on
//! the triangle and 2 along z, as the twisted linear prism's `det J = h
//! det(M) ((1 − ζ(1 − cos θ))² + ζ² sin² θ)` of the tests shows; the test
//! `bernstein_det_is_the_map_det` finds both degrees attained. (Gmsh's
//! `JacobianBasis::jacobianOrder` gives prisms order `3p − 1`, its prism
//! space of that order: degree `3p − 1` on the triangle too, one more than
//! needed there.) We represent it in the product of the triangle's and the
//! line's Bernstein bases ([`crate::numeric::prism_bezier`]), compute its
//! coefficients up to rounding (Lagrange to Bernstein per factor,
//! derivatives and products in Bernstein form), bound the rounding and
//! subtract the bound: the smallest coefficient bounds det J below, the
//! six corner coefficients are values, and a best-first search tightens
//! the bracket, cutting the piece with the lowest bound either across the
//! triangle (its longest edge, as [`super::simplex`]) or along z (de
//! Casteljau at ½), in the factor where its coefficients may lie further
//! from det J.
//!
//! **Units.** det J is with respect to our reference prism, the unit
//! triangle × `[0,1]`. Gmsh's reference prism is the unit triangle ×
//! `[−1,1]`, so its `ζ` runs twice as fast and Gmsh's det J (its
//! `minDetJac`, `maxDetJac`) is half ours. Measured with Gmsh 4.15.2 on
//! seven p = 2 prisms (`gmsh_figures_of_p2_prisms` below): its `minDetJac`
//! is half our certified minimum to 1e-11, its `maxDetJac` half our max or
//! above it.
//!
//! **Scaled Jacobian.** [`Certificate::min_scaled_jacobian`] is sampled,
//! as for the other kinds, and is Gmsh's IGE measure of a prism
//! (`_computeIGE`, `TYPE_PRI`, of Gmsh's qualityMeasuresJacobian.cpp,
//! which `getElementQualities` samples at the element's order-`p` nodes
//! and calls `minSIGE`): with `v0 = |x_ξ|`, `v1 = |x_η|`, `v2 = |x_ζ|`,
//! `v3 = |x_η − x_ξ|`, `(2/√3) det J · mean(1/(v0 v1 v2), 1/(v0 v3 v2),
//! 1/(v1 v3 v2))`: the triangle's measure of the base times the sine of
//! the angle of `x_ζ` to it, 1 for a right prism on an equilateral
//! triangle (of any height) and for no other affine prism. It does not
//! depend on Gmsh's z scale (det J and `v2` both halve); sampled on
//! Gmsh's points (`samples: p + 1`) it is Gmsh's `minSIGE` to 1e-13, and
//! our default lattice contains those points. Gmsh's `minSJ` quality is
//! another figure (`distoShapeMeasure`: the smallest raw Bernstein
//! coefficient of det J over det J of the straight prism through the six
//! vertices at the centre `(⅓, ⅓, ½)`: 1 for every affine prism; measured,
//! see the test).

use std::cmp::Ordering;

use smallvec::{smallvec, SmallVec};

use super::certify::{brackets, gamma, normalise, Certificate, CertifyOptions, Conversion as LineConversion, Goal, U};
use super::simplex::{constant_jacobian, Conversion as TriConversion};
use crate::mesh::element::basis::det;
use crate::mesh::element::{check_order, HighOrderError};
use crate::numeric::bezier::bernstein;
use crate::numeric::prism_bezier::{PrismDerivative, PrismLattice, PrismProduct, PrismSplit};
use crate::numeric::simplex_bezier::{edges, max_abs, multi_indices, Coef, Lattice};
use crate::numeric::{dist2, dot, sub};

/// The number of nodes of the order-`p` triangle.
fn triangle_count(p: usize) -> usize {
    (p + 1) * (p + 2) / 2
}

/// `det J` in Bernstein form with what is needed to bound its rounding
/// (as [`super::simplex`]'s `DetParts`).
struct DetParts {
    /// The computed coefficients, degree `(3p − 2, 3p − 1)`.
    det: Coef,
    /// The Bernstein coefficients of `∂x_r/∂ξ_c` as `col[c][r]`.
    col: [[Coef; 3]; 3],
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

impl DetParts {
    /// A bound on `|computed − exact|` for every coefficient of `det`, the
    /// exact one being that of the Lagrange map through the control points
    /// at the reference nodes (before the centring subtraction). The
    /// argument of [`super::simplex`]'s, with the conversion a product:
    /// 1. coordinates: the centring rounds each input by ≤ U relative; the
    ///    triangle's conversion is an `n_T`-term dot product per layer,
    ///    the line's a `(p+1)`-term one across layers, so every term of an
    ///    output carries at most `n_T + p + 2` rounding factors and, with
    ///    the computed inverses taken as exact, a coefficient errs by ≤
    ///    `γ_{n_T+p+2} ‖inv_L‖ ‖inv_T‖ max|x|`. The computed inverses are
    ///    `inv = (I + R) V⁻¹` per factor, so exact arithmetic with them
    ///    gives `((I + R_L) ⊗ (I + R_T)) c` for the exact coefficients
    ///    `c` (the nodes are the product of the factors' nodes, so the
    ///    values are `(V_L ⊗ V_T) c`), off by ≤ `r max|c|`, `r = (1 +
    ///    ρ_L)(1 + ρ_T) − 1` (the ∞-norm of a Kronecker product is the
    ///    product of the norms), and `max|c|` ≤ `(computed max + that) /
    ///    (1 − r)`. Together: `ε`.
    /// 2. derivatives `n (c_{β+e} − c_β)`, `n = p` in either factor: `2p ε`
    ///    plus the two roundings `γ_2 · 2p max|c|`. Together: `δ`.
    /// 3. products: `γ_k` times the companion (itself computed with `k`
    ///    roundings, hence `/(1 − γ_k)`), plus `6 ((M + δ)³ − M³)` for the
    ///    errors of the factors (the weights into one coefficient sum to
    ///    one in each factor; `det` has 6 signed products of 3 factors),
    ///    written `6 δ (3M² + 3Mδ + δ²)`: no cancellation when `δ ≪ M`.
    fn error_bound(&self, p: usize, tri: &TriConversion, line: &LineConversion) -> f64 {
        let pf = p as f64;
        let round_c = gamma(tri.n + p + 2) * line.norm * tri.norm * self.input_max;
        let r = (tri.rho + line.rho + tri.rho * line.rho) * (1.0 + 4.0 * U);
        let eps = round_c + r / (1.0 - r) * (self.coord_max + round_c);
        let delta = 2.0 * pf * eps + gamma(2) * 2.0 * pf * (self.coord_max + eps);
        let g = gamma(self.k);
        let round = g / (1.0 - g) * self.abs_max;
        let m = self.deriv_max;
        let inputs = 6.0 * delta * (3.0 * m * m + 3.0 * m * delta + delta * delta);
        // a few ulps more cover the rounding of this formula itself
        (round + inputs) * (1.0 + 16.0 * U)
    }
}

/// A piece of the branch and bound: the polynomial on a sub-prism (its
/// triangle's reference vertices by barycentric slot, its z interval).
#[derive(Clone)]
struct Piece {
    coef: Coef,
    tri: [[f64; 2]; 3],
    z: [f64; 2],
}

impl super::branch::Piece for Piece {
    type Context = PrismCertifier;
    fn coefficients(&self) -> &[f64] {
        &self.coef
    }
    fn least_vertex(&self, cx: &PrismCertifier) -> f64 {
        super::branch::least_at(&self.coef, &cx.det_vertices)
    }
    fn cut(self, cx: &PrismCertifier, _: Goal) -> (SmallVec<[Piece; 8]>, usize) {
        (cx.bisect(&self).into_iter().collect(), 1)
    }
}

/// The bases of the Jacobian's columns on a sampling lattice of `m` points
/// per edge of the triangle times `m` along z: on the triangle points,
/// degree `p − 1` (columns ξ, η) and `p` (column ζ), row after row; on
/// the z points the line's degree `p` and `p − 1`.
struct Samples {
    m: usize,
    points: usize,
    tri_xy: Vec<f64>,
    tri_z: Vec<f64>,
    line_xy: Vec<f64>,
    line_z: Vec<f64>,
}

impl Samples {
    fn new(p: usize, m: usize) -> Self {
        let (lxy, lz) = (Lattice::new(2, p - 1), Lattice::new(2, p));
        let points: Vec<[f64; 3]> = multi_indices(2, m - 1).map(|a| a.map(|i| i as f64 / (m - 1) as f64)).collect();
        let table = |lat: &Lattice| {
            let mut t = vec![0.0; points.len() * lat.len()];
            for (x, row) in points.iter().zip(t.chunks_exact_mut(lat.len())) {
                lat.basis(*x, row);
            }
            t
        };
        let line = |n: usize| (0..m).flat_map(|j| bernstein(n, j as f64 / (m - 1) as f64)).collect();
        Samples { m, points: points.len(), tri_xy: table(&lxy), tri_z: table(&lz), line_xy: line(p), line_z: line(p - 1) }
    }
}

/// The certificate's set-up for one order and node set, made once per
/// mesh: the Lagrange-to-Bernstein conversion of each factor and the
/// tables of the Bernstein algebra.
pub struct PrismCertifier {
    p: usize,
    /// The triangle factor's conversion (`n_T × n_T`) and the line's.
    tri_conv: TriConversion,
    line_conv: LineConversion,
    /// Derivatives from degree `(p, p)`.
    deriv: PrismDerivative,
    /// `(p−1, p) × (p−1, p)`: the cross product `x_ξ × x_η`.
    mul_gg: PrismProduct,
    /// `(p, p−1) × (2p−2, 2p)`: the dot product with `x_ζ`.
    mul_gc: PrismProduct,
    /// Cuts and corner positions of det J, degree `(3p−2, 3p−1)`.
    split: PrismSplit,
    det_vertices: [usize; 6],
    /// The default sampling lattice (`3p + 1` points per edge).
    samples: Samples,
}

impl PrismCertifier {
    /// For order-`p` prisms whose nodes sit at `nodes` (reference positions
    /// in the lattice order of [`crate::mesh::element::prism`]: a
    /// triangle's node set, layer after layer, at the heights of a 1-D
    /// node set), e.g. [`crate::mesh::element::prism::space`]`(p,
    /// spacing)?.nodes`.
    ///
    /// Errors: an order outside `1..=4` or a node count other than
    /// `(p+1)²(p+2)/2`.
    ///
    /// # Panics
    /// If the nodes are not such a product, or a factor is not unisolvent
    /// for degree `p` (two coinciding nodes, say): a node table is a
    /// constant of the code.
    pub fn new(p: usize, nodes: &[[f64; 3]]) -> Result<Self, HighOrderError> {
        check_order(p)?;
        let t = triangle_count(p);
        if nodes.len() != t * (p + 1) {
            return Err(HighOrderError::NodeCount { order: p, dim: 3, expected: t * (p + 1), found: nodes.len() });
        }
        let tri: Vec<[f64; 3]> = nodes[..t].iter().map(|x| [x[0], x[1], 0.0]).collect();
        let z: Vec<f64> = (0..=p).map(|k| nodes[k * t][2]).collect();
        let product = nodes.iter().enumerate().all(|(n, x)| *x == [tri[n % t][0], tri[n % t][1], z[n / t]]);
        assert!(product, "the order-{p} prism nodes are not a triangle's times a line's");
        let tri_conv = TriConversion::new(&Lattice::new(2, p), &tri).unwrap_or_else(|| panic!("the order-{p} prism's triangle nodes are not unisolvent"));
        let line_conv = LineConversion::from_nodes(&z);
        let r = tri_conv.rho + line_conv.rho + tri_conv.rho * line_conv.rho;
        assert!(r.is_finite() && r < 0.5, "the order-{p} prism's z nodes are not unisolvent");
        let coord = PrismLattice::new(p, p);
        let (gxy, gz) = (PrismLattice::new(p - 1, p), PrismLattice::new(p, p - 1));
        let det_lat = PrismLattice::new(3 * p - 2, 3 * p - 1);
        Ok(PrismCertifier {
            p,
            deriv: PrismDerivative::new(&coord),
            mul_gg: PrismProduct::new(&gxy, &gxy),
            mul_gc: PrismProduct::new(&gz, &PrismLattice::new(2 * p - 2, 2 * p)),
            split: PrismSplit::new(&det_lat),
            det_vertices: std::array::from_fn(|v| det_lat.vertex(v)),
            samples: Samples::new(p, 3 * p + 1),
            tri_conv,
            line_conv,
        })
    }

    /// The Bernstein coefficients of the interpolant of `values` (lattice
    /// order): the triangle's conversion on every layer, then the line's
    /// across layers.
    fn convert(&self, values: &[f64]) -> Coef {
        let (t, n) = (self.tri_conv.n, self.p + 1);
        let mut y = Coef::with_capacity(values.len());
        for layer in values.chunks_exact(t) {
            y.extend(self.tri_conv.apply(layer));
        }
        let inv = &self.line_conv.inv;
        let mut out: Coef = smallvec![0.0; values.len()];
        for k in 0..n {
            for a in 0..t {
                out[k * t + a] = (0..n).map(|l| inv[k][l] * y[l * t + a]).sum();
            }
        }
        out
    }

    /// `det J` of the normalised element with its rounding bound, and the
    /// scale `s` of [`normalise`] (`det J` of `ctrl` is `s³` times it).
    fn det_j<const D: usize>(&self, ctrl: &[[f64; D]]) -> (DetParts, f64, f64) {
        let n = triangle_count(self.p) * (self.p + 1);
        assert!(D == 3 && ctrl.len() == n, "an order-{} prism has {n} nodes in 3D, given {} in {D}D", self.p, ctrl.len());
        let (centre, s) = normalise(ctrl);
        let mut input_max = 0.0f64;
        let x: [Coef; 3] = std::array::from_fn(|r| {
            let moved: Coef = ctrl.iter().map(|c| (c[r] - centre[r]) / s).collect();
            input_max = input_max.max(max_abs(&moved));
            self.convert(&moved)
        });
        let coord_max = x.iter().map(|c| max_abs(c)).fold(0.0, f64::max);
        let col: [[Coef; 3]; 3] = std::array::from_fn(|c| std::array::from_fn(|r| self.deriv.apply(c, &x[r])));
        let deriv_max = col.iter().flatten().map(|c| max_abs(c)).fold(0.0, f64::max);
        let abs = col.each_ref().map(|c| c.each_ref().map(|b| b.iter().map(|v| v.abs()).collect::<Coef>()));
        let (gg, gc) = (&self.mul_gg, &self.mul_gc);
        // det [a b c] = c · (a × b), a = x_ξ and b = x_η of one degree
        let triple = |cols: &[[Coef; 3]; 3], sign: f64| -> Coef {
            let (a, b, c) = (&cols[0], &cols[1], &cols[2]);
            let cross = |i: usize, j: usize| -> Coef {
                let (u, v) = (gg.apply(&a[i], &b[j]), gg.apply(&a[j], &b[i]));
                u.iter().zip(&v).map(|(x, y)| x + sign * y).collect()
            };
            let ab = [cross(1, 2), cross(2, 0), cross(0, 1)];
            let t: [Coef; 3] = std::array::from_fn(|r| gc.apply(&c[r], &ab[r]));
            (0..t[0].len()).map(|i| t[0][i] + t[1][i] + t[2][i]).collect()
        };
        let (det, det_abs) = (triple(&col, -1.0), triple(&abs, 1.0));
        let k = gg.roundings() + 1 + gc.roundings() + 2;
        let parts = DetParts { det, col, abs_max: max_abs(&det_abs), coord_max, input_max, deriv_max, k };
        // a coordinate that is not finite leaves NaN coefficients, which
        // min and max would skip: no bound at all then
        let err = if parts.det.iter().all(|c| c.is_finite()) { parts.error_bound(self.p, &self.tri_conv, &self.line_conv) } else { f64::INFINITY };
        (parts, err, s)
    }

    /// The two halves of a piece: cut across the triangle (its longest
    /// reference edge bisected, the first of [`edges`] on ties) or along z
    /// (halved), in the factor whose coefficients may lie further from the
    /// polynomial ([`PrismSplit::gaps`]; on a tie, the longer of the longest
    /// edge and the z interval). So a det J that varies in one factor only
    /// (the twisted prism's, in z alone; any p = 1 prism's along the
    /// triangle, where it is linear) is cut in that factor only, and an
    /// anisotropic one more often across its curved direction. (Cutting
    /// where the halves' bound rises most, tried too, cut the same factor
    /// over and over into slabs: five times the splits on random curved
    /// prisms; the gap rule takes 5 % fewer than alternating by size.)
    fn bisect(&self, piece: &Piece) -> [Piece; 2] {
        let len2 = |&(a, b): &(usize, usize)| dist2(piece.tri[a], piece.tri[b]);
        let all = edges(2);
        let e = (0..all.len()).fold(0, |best, e| if len2(&all[e]) > len2(&all[best]) { e } else { best });
        let (gt, gz) = self.split.gaps(&piece.coef);
        let across = match gt.partial_cmp(&gz) {
            Some(Ordering::Greater) => true,
            Some(Ordering::Less) => false,
            _ => len2(&all[e]) >= (piece.z[1] - piece.z[0]).powi(2),
        };
        let half = |coef: Coef, tri, z| Piece { coef, tri, z };
        if across {
            let (a, b) = all[e];
            let (ta, tb) = self.split.tri(e, &piece.coef);
            let mid: [f64; 2] = std::array::from_fn(|r| 0.5 * (piece.tri[a][r] + piece.tri[b][r]));
            let (mut va, mut vb) = (piece.tri, piece.tri);
            va[b] = mid;
            vb[a] = mid;
            [half(ta, va, piece.z), half(tb, vb, piece.z)]
        } else {
            let (za, zb) = self.split.z(&piece.coef);
            let mid = 0.5 * (piece.z[0] + piece.z[1]);
            [half(za, piece.tri, [piece.z[0], mid]), half(zb, piece.tri, [mid, piece.z[1]])]
        }
    }

    /// `(lower, upper, splits)` of the minimum of the exact det J over the
    /// element, given `poly` whose coefficients are within `err` of the
    /// exact ones: the branch and bound of [`super::branch`] with the
    /// prism's cut. One split is one cut (two pieces); three cuts (two
    /// across the triangle, one along z) halve a piece about as one box
    /// split does.
    fn bound_min(&self, poly: Coef, err: f64, goal: Goal) -> (f64, f64, usize) {
        // A cut applies to each line of coefficients rows of non-negative
        // weights summing to one (at most 3p − 1 averaging steps, one
        // rounding each).
        let root = Piece { coef: poly, tri: [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], z: [0.0, 1.0] };
        super::branch::bound_min(&root, self, 3, 3 * self.p + 1, err, goal)
    }

    /// Whether `det J > 0` on the whole element (control points in lattice
    /// order), decided conservatively: `true` is a proof; `false` means
    /// invalid or so nearly invalid that det J comes within the Bernstein
    /// bound's slack of 0 on a piece `3 ·` [`MAX_SUBDIVISION_DEPTH`](super::certify::MAX_SUBDIVISION_DEPTH) cuts
    /// deep. Cheaper than [`PrismCertifier::certify`].
    ///
    /// # Panics
    /// If `D` is not 3 or `ctrl` has the wrong length.
    pub fn is_valid<const D: usize>(&self, ctrl: &[[f64; D]]) -> bool {
        let (parts, err, _) = self.det_j(ctrl);
        self.bound_min(parts.det, err, Goal::Sign).0 > 0.0
    }

    /// The certificate of the element with control points `ctrl` (lattice
    /// order): the bracket of `min det J`, a bound of `max det J` (both in
    /// the units of the reference prism unit triangle × `[0,1]`), and the
    /// sampled minima of det J and of the scaled Jacobian on the lattice of
    /// `opts.samples` points per edge of the triangle times as many along
    /// z (`0`: `3p + 1`).
    ///
    /// # Panics
    /// If `D` is not 3 or `ctrl` has the wrong length.
    pub fn certify<const D: usize>(&self, ctrl: &[[f64; D]], opts: &CertifyOptions) -> Certificate {
        let (parts, err, s) = self.det_j(ctrl);
        let m = opts.sample_count(self.p);
        let (min_det, min_sj) = match constant_jacobian(&parts.col, parts.deriv_max) {
            // a straight-sided prism: its J, hence both figures, is the
            // same at every sample
            Some(j) => (det(&j), scaled_jacobian(&j)),
            None if m == self.samples.m => self.sample(&parts.col, &self.samples),
            None => self.sample(&parts.col, &Samples::new(self.p, m)),
        };
        let neg: Coef = parts.det.iter().map(|c| -c).collect();
        let (min, neg, splits) = brackets(parts.det, neg, err, opts, |c, e, g| self.bound_min(c, e, g));
        Certificate::of_normalised(3, s, min, neg, (min_det, min_sj), splits)
    }

    /// `(min det J, min scaled Jacobian)` of the normalised element over
    /// the sampling lattice, J from the Bernstein derivatives: per z level
    /// the line's factor is summed out first, then the triangle's.
    fn sample(&self, col: &[[Coef; 3]; 3], tables: &Samples) -> (f64, f64) {
        let p = self.p;
        let (txy, tz) = (triangle_count(p - 1), triangle_count(p));
        let (mut min_det, mut min_sj) = (f64::INFINITY, f64::INFINITY);
        // on one z level: the triangle coefficients of every entry
        let mut at = [[[0.0f64; 15]; 3]; 3];
        for j in 0..tables.m {
            for (c, entries) in at.iter_mut().enumerate() {
                let (t, line) = if c < 2 { (txy, &tables.line_xy[j * (p + 1)..(j + 1) * (p + 1)]) } else { (tz, &tables.line_z[j * p..(j + 1) * p]) };
                for (r, out) in entries.iter_mut().enumerate() {
                    for (a, o) in out[..t].iter_mut().enumerate() {
                        *o = line.iter().enumerate().map(|(k, b)| b * col[c][r][k * t + a]).sum();
                    }
                }
            }
            for i in 0..tables.points {
                let (bxy, bz) = (&tables.tri_xy[i * txy..(i + 1) * txy], &tables.tri_z[i * tz..(i + 1) * tz]);
                let j: [[f64; 3]; 3] = std::array::from_fn(|r| {
                    std::array::from_fn(|c| {
                        let b = if c < 2 { bxy } else { bz };
                        at[c][r].iter().zip(b).map(|(x, y)| x * y).sum()
                    })
                });
                min_det = min_det.min(det(&j));
                min_sj = min_sj.min(scaled_jacobian(&j));
            }
        }
        (min_det, min_sj)
    }
}

/// Gmsh's scaled Jacobian (IGE measure) of a prism at a point, from the
/// Jacobian `j` (rows: coordinates; columns: `∂x/∂ξ`, `∂x/∂η`, `∂x/∂ζ`):
/// `(2/√3) det J (1/(v0 v1 v2) + 1/(v0 v3 v2) + 1/(v1 v3 v2)) / 3` with
/// `v0 = |x_ξ|`, `v1 = |x_η|`, `v2 = |x_ζ|`, `v3 = |x_η − x_ξ|` (see the
/// module's documentation): 1 for a right prism on an equilateral
/// triangle, negative where J is.
pub(crate) fn scaled_jacobian(j: &[[f64; 3]; 3]) -> f64 {
    let col = |c: usize| -> [f64; 3] { std::array::from_fn(|r| j[r][c]) };
    let norm = |v: [f64; 3]| dot(v, v).sqrt();
    let (a, b, c) = (col(0), col(1), col(2));
    let v = [norm(a), norm(b), norm(c), norm(sub(b, a))];
    2.0 / 3f64.sqrt() * det(j) * (1.0 / (v[0] * v[1] * v[2]) + 1.0 / (v[0] * v[3] * v[2]) + 1.0 / (v[1] * v[3] * v[2])) / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quality::tests::{lcg, threshold};
    use crate::numeric::simplex_bezier::coef_bounds;
    use crate::mesh::element::prism::{space, PrismSpace};
    use crate::mesh::element::Spacing;


    const SPACINGS: [Spacing; 2] = [Spacing::Equispaced, Spacing::GaussLobatto];

    fn setup(p: usize, spacing: Spacing) -> (PrismCertifier, &'static PrismSpace) {
        let sp = space(p, spacing).unwrap();
        (PrismCertifier::new(p, &sp.nodes).unwrap(), sp)
    }

    /// A curved prism on `nodes`: a random affine image (linear part of
    /// determinant > ½) of the reference prism bent by `ξ_r += bend
    /// sin(2 ξ_{r+1} + 1.5 ξ_r + φ_r)`, every node then moved by up to
    /// `noise`.
    fn curved(nodes: &[[f64; 3]], bend: f64, noise: f64, seed: &mut u64) -> Vec<[f64; 3]> {
        let a: [[f64; 3]; 3] = loop {
            let a = std::array::from_fn(|r| std::array::from_fn(|c| f64::from(u8::from(r == c)) + 0.35 * lcg(seed)));
            if det(&a) > 0.5 {
                break a;
            }
        };
        let t: [f64; 3] = std::array::from_fn(|_| lcg(seed));
        let phase: [f64; 3] = std::array::from_fn(|_| 3.0 * lcg(seed));
        nodes
            .iter()
            .map(|x| {
                let y: [f64; 3] = std::array::from_fn(|r| x[r] + bend * (2.0 * x[(r + 1) % 3] + 1.5 * x[r] + phase[r]).sin());
                std::array::from_fn(|r| (0..3).map(|c| a[r][c] * y[c]).sum::<f64>() + t[r] + noise * lcg(seed))
            })
            .collect()
    }

    /// J of the map through `q` at `xi` by the Lagrange basis of
    /// `mesh::element::prism`: no Bernstein polynomial involved.
    fn jacobian(sp: &PrismSpace, q: &[[f64; 3]], xi: [f64; 3]) -> [[f64; 3]; 3] {
        let n = sp.num_nodes();
        let (mut v, mut g) = (vec![0.0; n], vec![[0.0; 3]; n]);
        sp.eval(xi, &mut v, &mut g);
        std::array::from_fn(|r| std::array::from_fn(|c| (0..n).map(|i| q[i][r] * g[i][c]).sum()))
    }

    /// `(min, max)` of det J by that evaluator over the lattice of `m`
    /// points per triangle edge times `m` along z, each refined by a
    /// compass search inside the prism from the 8 best lattice points;
    /// and whether a lattice point had det J ≤ 0.
    fn dense(sp: &PrismSpace, q: &[[f64; 3]], m: usize) -> (f64, f64, bool) {
        let f = |x: [f64; 3]| det(&jacobian(sp, q, x));
        let inside = |x: &[f64; 3]| x.iter().all(|&c| c >= 0.0) && x[0] + x[1] <= 1.0 && x[2] <= 1.0;
        let mut pts: Vec<(f64, [f64; 3])> = Vec::new();
        for k in 0..m {
            for a in multi_indices(2, m - 1) {
                let x = [a[0] as f64, a[1] as f64, k as f64].map(|c| c / (m - 1) as f64);
                pts.push((f(x), x));
            }
        }
        let nonpositive = pts.iter().any(|p| p.0 <= 0.0);
        let mut dirs: Vec<[f64; 3]> = Vec::new();
        for d in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [1.0, 0.0, -1.0], [0.0, 1.0, -1.0]] {
            dirs.extend([d, d.map(|v: f64| -v)]);
        }
        let search = |sign: f64, pts: &mut Vec<(f64, [f64; 3])>| -> f64 {
            pts.sort_by(|a, b| (sign * a.0).total_cmp(&(sign * b.0)));
            let mut best = f64::INFINITY;
            for &(v, x) in pts.iter().take(8) {
                let (mut v, mut x, mut h) = (sign * v, x, 1.0 / (m - 1) as f64);
                while h > 1e-9 {
                    let step = dirs
                        .iter()
                        .map(|d| std::array::from_fn(|k| x[k] + h * d[k]))
                        .filter(inside)
                        .map(|y| (sign * f(y), y))
                        .min_by(|a, b| a.0.total_cmp(&b.0));
                    match step {
                        Some(s) if s.0 < v => (v, x) = s,
                        _ => h *= 0.5,
                    }
                }
                best = best.min(v);
            }
            sign * best
        };
        let min = search(1.0, &mut pts);
        let max = search(-1.0, &mut pts);
        (min, max, nonpositive)
    }

    /// Certifies one element and checks the certificate against the
    /// independent dense extremes; returns whether it was certified valid
    /// and whether the bracket settled within the options' tolerance.
    fn check_against_sampling(cert: &PrismCertifier, sp: &PrismSpace, q: &[[f64; 3]], label: &str) -> (bool, bool) {
        let opts = CertifyOptions::default();
        let c = cert.certify(q, &opts);
        let (min, max, nonpositive) = dense(sp, q, 25);
        let scale = c.max_det.abs().max(c.min_det_lower.abs());
        // the evaluator's own rounding
        let tol = 1e-10 * scale;
        assert!(c.min_det_lower <= min + tol, "{label}: lower above the minimum {min}: {c:?}");
        assert!(c.min_det_lower <= c.min_det_upper && c.min_det_upper <= c.min_det_sampled, "{label}: {c:?}");
        assert!(c.max_det >= max - tol && c.max_det >= c.min_det_upper, "{label}: max {max}: {c:?}");
        let (_, err, s) = cert.det_j(q);
        let err = err * s * s * s;
        let settled = c.min_det_upper - c.min_det_lower <= opts.rel_tol * c.min_det_upper.abs().max(1e-9 * scale) + 2.0 * err + 1e-12 * scale;
        if settled {
            // the bracket holds the minimum the search found, closely
            assert!(c.min_det_upper >= min - opts.rel_tol * min.abs() - tol, "{label}: upper below the minimum {min}: {c:?}");
            assert!(c.min_det_upper - min <= 2.0 * opts.rel_tol * min.abs() + 2.0 * err + tol, "{label}: upper above the minimum {min}: {c:?}");
            // and the max is as tight
            assert!(c.max_det - max <= 2.0 * opts.rel_tol * max.abs() + 2.0 * err + tol, "{label}: max {max}: {c:?}");
        }
        if c.valid {
            assert!(!nonpositive && min > 0.0, "{label}: certified valid with minimum {min}");
        }
        if min < -1e-6 * scale {
            assert!(!c.valid && c.min_det_upper < 0.0, "{label}: minimum {min} not shown invalid: {c:?}");
        }
        if min > 1e-6 * scale && settled {
            assert!(c.valid, "{label}: minimum {min} not certified: {c:?}");
        }
        let ok = cert.is_valid(q);
        assert!(!ok || (min > 0.0 && !nonpositive), "{label}: is_valid with minimum {min}");
        assert!(ok || min < 0.05 * scale, "{label}: is_valid refused minimum {min} of {scale}");
        (c.valid, settled)
    }

    /// On random curved prisms of orders 1 to 4, on both node sets, valid
    /// and inverted, the certificate brackets the minimum of det J found
    /// by dense sampling (and a local search) of an independent evaluator
    /// to the options' tolerance, bounds its maximum as tightly, is never
    /// `valid` where a sample is ≤ 0, and decides validity as it does.
    #[test]
    fn certificate_brackets_the_dense_minimum() {
        let mut seed = 0x9215;
        let (mut valid, mut invalid, mut unsettled) = (0, 0, 0);
        for p in 1..=4 {
            for spacing in SPACINGS {
                let (cert, sp) = setup(p, spacing);
                for n in 0..16 {
                    let (bend, noise) = ([0.05, 0.25, 0.4, 0.55][n % 4], [0.0, 0.05, 0.1, 0.2][n / 4] / p as f64);
                    let q = curved(&sp.nodes, bend, noise, &mut seed);
                    let (ok, settled) = check_against_sampling(&cert, sp, &q, &format!("p={p} {spacing:?} #{n}"));
                    if ok {
                        valid += 1
                    } else {
                        invalid += 1
                    }
                    unsettled += usize::from(!settled);
                }
            }
        }
        // measured: 74 valid, 54 invalid
        assert!(valid > 50 && invalid > 30 && unsettled == 0, "{valid} valid, {invalid} invalid, {unsettled} unsettled");
    }

    /// det J lies in `P_{3p−2} ⊗ P_{3p−1}` and no smaller product space:
    /// on random curved prisms, det J by the independent evaluator along a
    /// line across the triangle has a vanishing `(3p−1)`-th difference and
    /// a `(3p−2)`-th that does not vanish, along z a vanishing `3p`-th and
    /// a `(3p−1)`-th that does not; the Bernstein det J has `C(3p, 2) · 3p`
    /// coefficients and agrees with the evaluator at random points to
    /// 1e-12 of its size, and its coefficients bound it.
    #[test]
    fn bernstein_det_is_the_map_det() {
        let mut seed = 7;
        for p in 1..=4 {
            for spacing in SPACINGS {
                let (cert, sp) = setup(p, spacing);
                let q = curved(&sp.nodes, 0.2, 0.05, &mut seed);
                let (parts, _, s) = cert.det_j(&q);
                let unit = s * s * s;
                let lat = PrismLattice::new(3 * p - 2, 3 * p - 1);
                assert_eq!((parts.det.len(), lat.len()), (triangle_count(3 * p - 2) * 3 * p, triangle_count(3 * p - 2) * 3 * p));
                let size = max_abs(&parts.det) * unit;
                let (lo, hi) = coef_bounds(&parts.det);
                let f = |x: [f64; 3]| det(&jacobian(sp, &q, x));
                // the n-th forward difference of f on n + 1 equispaced points
                let diff = |n: usize, at: &dyn Fn(f64) -> [f64; 3]| -> f64 {
                    (0..=n).map(|i| if (n - i) % 2 == 0 { 1.0 } else { -1.0 } * crate::numeric::bezier::binom(n, i) * f(at(i as f64 / n as f64))).sum()
                };
                let across = |t: f64| [0.05 + 0.8 * t, 0.1, 0.37];
                let along = |t: f64| [0.21, 0.33, t];
                let (n, m) = (3 * p - 2, 3 * p - 1);
                assert!(
                    diff(n + 1, &across).abs() < 1e-11 * size && diff(n, &across).abs() > 1e-5 * size,
                    "p={p}: across {} {}",
                    diff(n + 1, &across),
                    diff(n, &across)
                );
                assert!(
                    diff(m + 1, &along).abs() < 1e-11 * size && diff(m, &along).abs() > 1e-5 * size,
                    "p={p}: along {} {}",
                    diff(m + 1, &along),
                    diff(m, &along)
                );
                for _ in 0..30 {
                    let x = loop {
                        let x: [f64; 3] = std::array::from_fn(|_| 0.5 + 0.5 * lcg(&mut seed));
                        if x[0] + x[1] <= 1.0 {
                            break x;
                        }
                    };
                    let (b, e) = (lat.eval(&parts.det, x) * unit, f(x));
                    assert!((b - e).abs() <= 1e-12 * size, "p={p} {spacing:?}: {b} vs {e} at {x:?}");
                    assert!(lo * unit <= e + 1e-12 * size && e <= hi * unit + 1e-12 * size);
                }
            }
        }
    }

    /// An affine prism's det J is the determinant of its linear part (for
    /// the one below, 2.3125 exactly; then random ones of either sign):
    /// every coefficient, the upper end of the bracket, the max and the
    /// sampled value reproduce it to 1e-12 relative, with no split; the
    /// bracket is twice the rounding bound wide (measured 2e-13 of det J at
    /// p = 1, 2.5e-12, 2.5e-11, 2.3e-10 at p = 4), and its sign is the
    /// verdict.
    #[test]
    fn affine_prisms_have_their_constant_det() {
        let mut seed = 11;
        for p in 1..=4 {
            for spacing in SPACINGS {
                let (cert, sp) = setup(p, spacing);
                for n in 0..5 {
                    let a: [[f64; 3]; 3] = if n == 0 {
                        [[2.0, 0.5, 0.0], [0.0, 1.5, 0.25], [0.5, 0.0, 0.75]]
                    } else {
                        let mut a: [[f64; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| 2.0 * f64::from(u8::from(r == c)) + 0.5 * lcg(&mut seed)));
                        if n % 2 == 0 {
                            a[0] = a[0].map(|v| -v);
                        }
                        a
                    };
                    let exact = if n == 0 { 2.3125 } else { det(&a) };
                    let t: [f64; 3] = std::array::from_fn(|_| 3.0 * lcg(&mut seed));
                    let q: Vec<[f64; 3]> = sp.nodes.iter().map(|x| std::array::from_fn(|r| dot(a[r], *x) + t[r])).collect();
                    let (parts, _, s) = cert.det_j(&q);
                    for &b in &parts.det {
                        assert!((b * s * s * s - exact).abs() <= 1e-12 * exact.abs(), "p={p} {spacing:?}: {} vs {exact}", b * s * s * s);
                    }
                    let c = cert.certify(&q, &CertifyOptions::default());
                    let tol = 1e-12 * exact.abs();
                    assert!(c.min_det_lower <= exact && exact - tol <= c.min_det_upper && c.min_det_upper <= exact + tol, "p={p}: {exact} {c:?}");
                    assert!((c.max_det - exact).abs() <= 5e-10 * exact.abs() && (c.min_det_sampled - exact).abs() <= tol, "p={p}: {exact} {c:?}");
                    assert!(c.min_det_upper - c.min_det_lower <= 5e-10 * exact.abs() && c.splits == 0, "p={p}: {c:?}");
                    assert_eq!((c.valid, cert.is_valid(&q)), (exact > 0.0, exact > 0.0));
                }
            }
        }
    }

    /// The linear prism over the triangle `M` (corners `M e_v`) whose top,
    /// at height `h`, is the bottom turned by `θ` about the z axis and
    /// shifted by `t`: `x = ((1 − ζ) M + ζ R_θ M) (ξ, η) + ζ t`, `z = h ζ`,
    /// at the nodes of `nodes` (the map is in `P_1 ⊗ P_1`, so every order
    /// reproduces it).
    fn twisted(nodes: &[[f64; 3]], m: [[f64; 2]; 2], h: f64, theta: f64, t: [f64; 2]) -> Vec<[f64; 3]> {
        let (c, s) = (theta.cos(), theta.sin());
        nodes
            .iter()
            .map(|x| {
                let b = [m[0][0] * x[0] + m[0][1] * x[1], m[1][0] * x[0] + m[1][1] * x[1]];
                let top = [c * b[0] - s * b[1] + t[0], s * b[0] + c * b[1] + t[1]];
                let z = x[2];
                [(1.0 - z) * b[0] + z * top[0], (1.0 - z) * b[1] + z * top[1], h * z]
            })
            .collect()
    }

    /// The twisted prism's det J is not constant. Its columns `x_ξ`, `x_η`
    /// are horizontal (`((1 − ζ) I + ζ R) M e_c`) and `x_ζ` has z component
    /// `h`, so `det J = h det((1 − ζ) I + ζ R) det M = h det M ((1 − ζ(1 −
    /// cos θ))² + ζ² sin² θ)`, a function of ζ alone, whose derivative
    /// vanishes at ζ = ½: `min det J = h det M (1 + cos θ)/2 = h det M
    /// cos²(θ/2)`, `max = h det M` at both ends. Its Bernstein
    /// coefficients along z are `h det M (1, cos θ, 1)`: at θ = 100° the
    /// middle one is negative, the element valid. The certificate cuts
    /// along z once (the gap rule sees no curvature across the triangle),
    /// which puts the minimum at a corner, and brackets both exact
    /// extremes to rounding, at every order.
    #[test]
    fn twisted_linear_prism_is_bracketed() {
        let (m, h, theta, t) = ([[1.3, 0.4], [-0.2, 0.9]], 0.7, 100f64.to_radians(), [0.3, -0.2]);
        let det_m = 1.3 * 0.9 + 0.4 * 0.2;
        let (min, max) = (h * det_m * (0.5 * theta).cos().powi(2), h * det_m);
        for p in 1..=4 {
            for spacing in SPACINGS {
                let (cert, sp) = setup(p, spacing);
                let q = twisted(&sp.nodes, m, h, theta, t);
                let (parts, err, s) = cert.det_j(&q);
                let unit = s * s * s;
                let raw = coef_bounds(&parts.det).0 * unit;
                // at p ≥ 2 the coefficients are those raised to degree
                // 3p − 1, `Σ_j C(2, j) C(m − 2, k − j) / C(m, k) b_j`, the
                // smallest the middle one's, still below the minimum
                let b = [1.0, theta.cos(), 1.0].map(|x| h * det_m * x);
                let mz = 3 * p - 1;
                let binom = crate::numeric::bezier::binom;
                let raised = (0..=mz)
                    .map(|k| (0..=2).filter(|&j| j <= k && k - j <= mz - 2).map(|j| binom(2, j) * binom(mz - 2, k - j) / binom(mz, k) * b[j]).sum::<f64>());
                let expected = raised.fold(f64::INFINITY, f64::min);
                assert!((raw - expected).abs() < 1e-12 && raw < min - 0.04, "p={p}: raw {raw} vs {expected}");
                let c = cert.certify(&q, &CertifyOptions::default());
                let tol = 2.0 * err * unit + 1e-14;
                // (the upper end is a value computed in floating point:
                // within rounding of the minimum, either side)
                assert!(
                    c.valid && c.min_det_lower <= min && min <= c.min_det_upper + 1e-15 && c.min_det_upper - c.min_det_lower <= tol,
                    "p={p} {spacing:?}: {min} {c:?}"
                );
                assert!(c.max_det >= max && c.max_det - max <= tol && c.splits == 1, "p={p} {spacing:?}: {max} {c:?}");
                assert!(cert.is_valid(&q));
            }
        }
    }

    /// A p = 2 prism on the reference one whose bottom hypotenuse node (½,
    /// ½, 0) is pulled towards the axis by `lam` times a dyadic vector:
    /// every coordinate a multiple of 2^-33, so adding 1e6 is exact.
    fn pulled(lam: f64) -> Vec<[f64; 3]> {
        let mut q = space(2, Spacing::Equispaced).unwrap().nodes.clone();
        // (odd numerators: det J does not vanish exactly at a dyadic lam)
        q[4][0] -= lam * 0.46875;
        q[4][1] -= lam * 0.4375;
        q
    }

    /// [`crate::quality::tests::check_moves`] with `cert`.
    fn check_moves(cert: &PrismCertifier, q: &[[f64; 3]], dyadic: bool) -> Certificate {
        crate::quality::tests::check_moves(|q| cert.certify(q, &CertifyOptions::default()), |q| cert.is_valid(q), q, dyadic)
    }

    /// Random curved prisms (on a dyadic grid) and a barely valid and a
    /// barely invalid one (min det J about ±4e-9 of its size) keep their
    /// verdicts and (scaled) figures when moved by 1e6 or scaled by 2^-20
    /// or 1e-6.
    #[test]
    fn verdicts_do_not_depend_on_position_or_size() {
        let mut seed = 0xD1AD;
        for p in 1..=4 {
            for spacing in SPACINGS {
                let (cert, sp) = setup(p, spacing);
                for n in 0..3 {
                    let grid = 2f64.powi(30);
                    let q: Vec<[f64; 3]> =
                        curved(&sp.nodes, [0.1, 0.45, 0.3][n], 0.05 / p as f64, &mut seed).iter().map(|c| c.map(|x| (x * grid).round() / grid)).collect();
                    check_moves(&cert, &q, true);
                }
            }
        }
        let (cert, _) = setup(2, Spacing::Equispaced);
        let opts = CertifyOptions::default();
        let (valid, invalid) = threshold(pulled, |q| {
            let c = cert.certify(q, &opts);
            assert!(c.valid || c.min_det_upper <= 0.0, "undecided: {c:?}");
            c.valid
        });
        let (cv, ci) = (check_moves(&cert, &valid, true), check_moves(&cert, &invalid, true));
        let size = cv.max_det;
        assert!(cv.valid && cv.min_det_lower < 1e-7 * size, "{cv:?}");
        assert!(!ci.valid && ci.min_det_upper < 0.0 && ci.min_det_upper > -1e-7 * size, "{ci:?}");
    }

    /// The rounding bound is small next to det J and scales with it.
    #[test]
    fn rounding_bound_is_small_and_scale_free() {
        let mut seed = 5;
        for p in 1..=4 {
            for spacing in SPACINGS {
                let (cert, sp) = setup(p, spacing);
                let q = curved(&sp.nodes, 0.2, 0.05, &mut seed);
                let (parts, err, _) = cert.det_j(&q);
                // measured 1.1e-13 (p = 1), 2.4e-12, 1.2e-10 and 2.3e-9 (p =
                // 4, whose noisy element has derivative coefficients up to
                // 29 and products cancelling from 4837 to 34)
                assert!(err > 0.0 && err < 1e-8 * max_abs(&parts.det), "p={p} {spacing:?}: {err} vs {}", max_abs(&parts.det));
                let (scaled, err2, _) = cert.det_j(&q.iter().map(|c| c.map(|x| x * 2f64.powi(-30))).collect::<Vec<_>>());
                assert_eq!((err2, scaled.det), (err, parts.det));
            }
        }
    }

    /// Subdivision tightens the bound: the raw coefficient minimum of a
    /// curved prism is well below the certified one; with no split the
    /// bound is the raw minimum less the rounding bound.
    #[test]
    fn subdivision_tightens_the_bound() {
        let mut seed = 99;
        let (cert, sp) = setup(3, Spacing::Equispaced);
        let q = curved(&sp.nodes, 0.2, 0.01, &mut seed);
        let (parts, err, s) = cert.det_j(&q);
        let unit = s * s * s;
        let raw = coef_bounds(&parts.det).0 * unit;
        let c = cert.certify(&q, &CertifyOptions::default());
        assert!(c.valid && c.splits > 0, "{c:?}");
        assert!(c.min_det_upper - raw > 100.0 * (c.min_det_upper - c.min_det_lower), "{raw} {c:?}");
        let coarse = cert.certify(&q, &CertifyOptions { max_splits: 0, ..Default::default() });
        assert_eq!(coarse.min_det_lower, raw - err * unit, "{raw} {coarse:?}");
    }

    /// Gmsh's normalisation of the scaled Jacobian: a right prism on an
    /// equilateral triangle (any height, position and rotation, any order)
    /// has 1; the reference prism `(2/√3)(1 + √2)/3`, its base's; leaning
    /// the z edges by `s` multiplies it by `1/√(1 + s²)`; bending an edge
    /// lowers it.
    #[test]
    fn scaled_jacobian_is_gmsh_s() {
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let rot = |v: [f64; 3]| [c * v[0] - s * v[2], v[1], s * v[0] + c * v[2]];
        let opts = CertifyOptions::default();
        let right = 2.0 / 3f64.sqrt() * (1.0 + 2f64.sqrt()) / 3.0;
        for p in 1..=4 {
            for spacing in SPACINGS {
                let (cert, sp) = setup(p, spacing);
                let map = |f: &dyn Fn([f64; 3]) -> [f64; 3]| sp.nodes.iter().map(|&x| f(x)).collect::<Vec<[f64; 3]>>();
                let equilateral = map(&|x| rot([2.5 * (x[0] + 0.5 * x[1]) + 7.0, 2.5 * 0.75f64.sqrt() * x[1] - 1.0, 0.3 * x[2] + 2.0]));
                let sj = cert.certify(&equilateral, &opts).min_scaled_jacobian;
                assert!((sj - 1.0).abs() < 1e-14, "p={p}: {sj}");
                let sj = cert.certify(&sp.nodes, &opts).min_scaled_jacobian;
                assert!((sj - right).abs() < 1e-14, "p={p}: {sj}");
                let lean = 0.75;
                let leaning = map(&|x| [x[0] + lean * x[2], x[1], x[2]]);
                let sj = cert.certify(&leaning, &opts).min_scaled_jacobian;
                assert!((sj - right / (1.0 + lean * lean).sqrt()).abs() < 1e-14, "p={p}: {sj}");
                if p >= 2 {
                    // the bottom edge's first inner node pushed out: no longer straight
                    let mut bent = equilateral.clone();
                    bent[1][1] -= 0.5;
                    let sj = cert.certify(&bent, &opts).min_scaled_jacobian;
                    assert!(sj < 0.99, "p={p}: {sj}");
                }
            }
        }
    }

    /// A NaN or infinite coordinate gives no bound: never valid.
    #[test]
    fn non_finite_coordinates_are_not_valid() {
        let (cert, sp) = setup(3, Spacing::GaussLobatto);
        for bad in [f64::NAN, f64::INFINITY] {
            let mut q = sp.nodes.clone();
            q[7][1] = bad;
            let c = cert.certify(&q, &CertifyOptions::default());
            assert!(!c.valid && c.min_det_lower == f64::NEG_INFINITY && !cert.is_valid(&q), "{c:?}");
        }
    }

    #[test]
    fn wrong_order_or_node_count_is_an_error() {
        let nodes = &space(2, Spacing::Equispaced).unwrap().nodes;
        assert!(matches!(PrismCertifier::new(2, &nodes[..17]), Err(HighOrderError::NodeCount { expected: 18, found: 17, .. })));
        assert!(matches!(PrismCertifier::new(5, nodes), Err(HighOrderError::UnsupportedOrder(5))));
        assert!(matches!(PrismCertifier::new(3, nodes), Err(HighOrderError::NodeCount { expected: 40, .. })));
    }

    #[test]
    #[should_panic(expected = "not a triangle's times a line's")]
    fn nodes_that_are_not_a_product_are_refused() {
        let mut nodes = space(2, Spacing::Equispaced).unwrap().nodes.clone();
        nodes[10][0] += 0.01;
        let _ = PrismCertifier::new(2, &nodes);
    }

    /// The crate's certifier of prisms is this one (not the hex's, which
    /// would read 18 nodes as a wrong count or the lattice as a box): the
    /// same certificate through [`super::super::certify::ElementCertifier`].
    #[test]
    fn element_certifier_takes_prisms() {
        use crate::mesh::element::Shape;
        let mut seed = 3;
        for p in 1..=4 {
            for spacing in SPACINGS {
                let (cert, sp) = setup(p, spacing);
                let q = curved(&sp.nodes, 0.3, 0.05, &mut seed);
                let any = super::super::certify::ElementCertifier::new(Shape::Prism, p, spacing).unwrap();
                let opts = CertifyOptions::default();
                assert!(matches!(any, super::super::certify::ElementCertifier::Prism(_)));
                assert_eq!(any.certify(&q, &opts), cert.certify(&q, &opts));
                assert_eq!(any.is_valid(&q), cert.is_valid(&q));
            }
        }
    }

    /// A release micro-measurement, printed (`cargo test --release --lib
    /// certify_timing -- --nocapture`), not asserted: µs per element of
    /// `certify` and `is_valid` on straight (affine) and on curved prisms
    /// at p = 2 and 3, next to the hex certifier on hexes made the same
    /// way.
    #[test]
    fn certify_timing() {
        use crate::mesh::element::basis::reference_nodes;
        use crate::quality::certify::Certifier;
        use std::time::Instant;
        fn time(elements: &[Vec<[f64; 3]>], f: &dyn Fn(&[[f64; 3]]) -> bool) -> f64 {
            let (start, mut runs) = (Instant::now(), 0);
            while runs == 0 || start.elapsed().as_secs_f64() < 0.05 {
                for q in elements {
                    std::hint::black_box(f(q));
                }
                runs += elements.len();
            }
            start.elapsed().as_secs_f64() / runs as f64 * 1e6
        }
        let opts = CertifyOptions::default();
        let mut seed = 0x7133;
        for p in 2..=3 {
            let (cert, sp) = setup(p, Spacing::Equispaced);
            let hex_nodes: Vec<[f64; 3]> = reference_nodes::<3>(p, Spacing::Equispaced).unwrap();
            let hex = Certifier::new(p, Spacing::Equispaced).unwrap();
            let make = |nodes: &[[f64; 3]], bend: f64, seed: &mut u64| -> Vec<Vec<[f64; 3]>> { (0..32).map(|_| curved(nodes, bend, 0.0, seed)).collect() };
            for (kind, bend) in [("straight", 0.0), ("curved", 0.15)] {
                let (prisms, hexes) = (make(&sp.nodes, bend, &mut seed), make(&hex_nodes, bend, &mut seed));
                let splits =
                    |c: &dyn Fn(&[[f64; 3]]) -> Certificate, qs: &[Vec<[f64; 3]>]| qs.iter().map(|q| c(q).splits).sum::<usize>() as f64 / qs.len() as f64;
                println!(
                    "p = {p}, {kind:8}: prism certify {:7.1} µs ({:5.1} splits), is_valid {:6.1} µs | hex certify {:7.1} µs ({:5.1} splits), is_valid {:6.1} µs",
                    time(&prisms, &|q| cert.certify(q, &opts).valid),
                    splits(&|q| cert.certify(q, &opts), &prisms),
                    time(&prisms, &|q| cert.is_valid(q)),
                    time(&hexes, &|q| hex.certify(q, &opts).valid),
                    splits(&|q| hex.certify(q, &opts), &hexes),
                    time(&hexes, &|q| hex.is_valid(q)),
                );
            }
        }
    }

    /// The p = 2 prisms of the Gmsh comparison, by name, at `nodes`.
    fn gmsh_prisms(nodes: &[[f64; 3]]) -> Vec<(&'static str, Vec<[f64; 3]>)> {
        let map = |f: &dyn Fn([f64; 3]) -> [f64; 3]| nodes.iter().map(|&x| f(x)).collect::<Vec<_>>();
        let a = [[2.0, 0.5, 0.0], [0.0, 1.5, 0.25], [0.5, 0.0, 0.75]];
        vec![
            ("affine", map(&|x| std::array::from_fn(|r| dot(a[r], x) + [1.0, 2.0, 3.0][r]))),
            ("equilateral", map(&|x| [x[0] + 0.5 * x[1], 0.75f64.sqrt() * x[1], 0.4 * x[2]])),
            ("curved", map(&|[u, v, w]| [u + 0.15 * v * v - 0.1 * w * w, v + 0.2 * u * w, w + 0.1 * u * v + 0.05 * (u + v) * (u + v)])),
            ("bent", map(&|[u, v, w]| [u + 0.3 * u * v * (1.0 - w), v + 0.25 * u * u - 0.2 * v * w, 0.8 * w + 0.3 * u * v])),
            ("twisted", twisted(nodes, [[1.3, 0.4], [-0.2, 0.9]], 0.7, 100f64.to_radians(), [0.3, -0.2])),
            ("pulled", pulled(0.75)),
            ("wavy", map(&|[u, v, w]| [u + 0.12 * (3.0 * v + 2.0 * w).sin(), v + 0.1 * (2.5 * u - w).sin(), 0.6 * w + 0.08 * (2.0 * u + 3.0 * v).cos()])),
        ]
    }

    /// Gmsh 4.15.2's figures of the prisms of [`gmsh_prisms`] (type 13,
    /// built at its own reference nodes from the same formulas, written to
    /// an .msh and read back: `tests/python/prism_qualities.py`):
    /// `minDetJac`, `maxDetJac`, `minSJ`, `minSIGE`.
    const GMSH: [(&str, [f64; 4]); 7] = [
        ("affine", [1.15624999999886, 1.15625000000127, 0.999999999998981, 0.922701655104165]),
        ("equilateral", [0.173205080756864, 0.173205080756911, 0.999999999999849, 1.0]),
        ("curved", [0.480000000000002, 0.500525, 0.970186963112683, 0.858431808196881]),
        ("bent", [0.319999999999999, 0.52, 0.888888888888885, 0.859095982921671]),
        ("twisted", [0.180764461135357, 0.437500000000004, 0.715944674907502, 0.376017438922926]),
        ("pulled", [-0.203125, 0.587890625000014, -0.40625, -0.288335424472517]),
        ("wavy", [0.247573794022075, 0.371737915044372, 0.82054390096579, 0.706400521813584]),
    ];

    /// What Gmsh's figures of a p = 2 prism are in ours (measured):
    /// - `minDetJac` is half our minimum (its reference prism is twice as
    ///   tall), to 1e-11 relative: our bracket halved holds it; its
    ///   `maxDetJac` is an upper bound of half our max, looser where the
    ///   max is inside (0.500525 against 0.500450 on "curved");
    /// - `minSIGE` is its IGE measure *sampled* at the order-p nodes (its
    ///   `sampleIGEMeasure(el, p)`), not a bound: our scaled Jacobian
    ///   sampled on those points (`samples: p + 1`) to 1e-13, and our
    ///   default lattice, which contains them, finds as low or lower
    ///   (0.69797 against 0.70640 on "wavy");
    /// - `minSJ` (`distoShapeMeasure`) is not a scaled Jacobian: the
    ///   smallest raw Bernstein coefficient of det J (no subdivision) over
    ///   det J of the straight prism through the six vertices at the
    ///   centre `(⅓, ⅓, ½)` — 1 on every affine prism, where our scaled
    ///   Jacobian is the shape's (0.92270 on "affine"). That ratio with our
    ///   coefficients is Gmsh's to 1e-11 on five prisms; on "curved" and
    ///   "wavy" Gmsh's is lower by 0.3 % and 0.08 % (its Jacobian basis for
    ///   prisms has degree 3p − 1 on the triangle too, one more than det J
    ///   needs, but raising the degree only raises the smallest
    ///   coefficient; not investigated further).
    #[test]
    fn gmsh_figures_of_p2_prisms() {
        let (cert, sp) = setup(2, Spacing::Equispaced);
        let linear = space(1, Spacing::Equispaced).unwrap();
        for ((name, q), (gname, [min_det, max_det, min_sj, min_sige])) in gmsh_prisms(&sp.nodes).into_iter().zip(GMSH) {
            assert_eq!(name, gname);
            let c = cert.certify(&q, &CertifyOptions::default());
            let tol = 1e-11 * max_det.abs();
            assert!(c.min_det_lower / 2.0 <= min_det + tol && min_det <= c.min_det_upper / 2.0 + tol, "{name}: {min_det} {c:?}");
            assert!(max_det >= c.max_det / 2.0 - tol && max_det - c.max_det / 2.0 <= 2e-4 * max_det, "{name}: {max_det} {c:?}");
            let at_nodes = cert.certify(&q, &CertifyOptions { samples: 3, ..Default::default() });
            assert!(
                (at_nodes.min_scaled_jacobian - min_sige).abs() <= 1e-13 && c.min_scaled_jacobian <= at_nodes.min_scaled_jacobian,
                "{name}: {min_sige} {c:?}"
            );
            let (parts, _, s) = cert.det_j(&q);
            let raw = coef_bounds(&parts.det).0 * s * s * s;
            let corners = crate::mesh::element::prism::vertex_nodes(2).map(|n| q[n]);
            let ratio = raw / det(&jacobian(linear, &corners, [1.0 / 3.0, 1.0 / 3.0, 0.5]));
            let curved_inside = matches!(name, "curved" | "wavy");
            assert!(if curved_inside { min_sj < ratio && ratio - min_sj < 3e-3 } else { (ratio - min_sj).abs() < 1e-11 }, "{name}: {min_sj} vs {ratio}");
        }
        assert_eq!(GMSH.iter().filter(|g| g.1[0] < 0.0).count(), 1);
    }
}
