//! The validity certificate of a quad or hex of any order `p ≥ 1`:
//! Bernstein bounds of `det J` with their rounding errors, refined by
//! subdivision. The linear check of every Algorithm-1 step
//! ([`invalid_cells`]) is its `p = 1` case.
//!
//! The Jacobian determinant of an order-`p` tensor Lagrange map is itself a
//! polynomial: in 2D `det J = x_ξ y_η − x_η y_ξ` where `x_ξ` has degree
//! `(p−1, p)` and `y_η` degree `(p, p−1)`, so `det J` has degree
//! `(2p−1, 2p−1)`; in 3D the triple product of columns of degrees
//! `(p−1,p,p)`, `(p,p−1,p)`, `(p,p,p−1)` has degree `(3p−1, 3p−1, 3p−1)`
//! (so (1,1), the corner values, for a bilinear quad and (2,2,2) for a
//! trilinear hex). We compute its Bernstein coefficients *exactly* (up to
//! rounding): the Lagrange control points are converted to Bernstein
//! control points (one small dense solve per direction), differentiated in
//! Bernstein form and multiplied with the Bernstein product rule
//! ([`Bezier`]) — no sampling, no ill-conditioned interpolation at degree
//! 11. The smallest coefficient bounds `det J` below; splitting the box in
//! halves tightens it, and a bound on the rounding of every step keeps the
//! verdict sound: [`certify`] brackets the minimum by a best-first branch
//! and bound, [`Certifier::is_valid`] only decides its sign.

use smallvec::SmallVec;
use std::sync::OnceLock;

use rayon::prelude::*;

use crate::mesh::element::basis::{jacobians_on_grid, scaled_det};
use crate::mesh::element::{check_nodes, nodes_1d, Basis1d, HighOrderError, Spacing};
use crate::numeric::bezier::{bernstein, binom, invert, Bezier};

/// Unit roundoff: `fl(a ∘ b) = (a ∘ b)(1 + δ)` with `|δ| ≤ U`.
pub(crate) const U: f64 = f64::EPSILON / 2.0;

/// How many times [`Certifier::is_valid`] halves a box in each direction
/// before it gives up and calls the element (nearly) invalid: 4 levels
/// resolve a zero of det J to 1/16 of the element, and the work stays
/// bounded at 8⁴ sub-boxes for the rare elements that need it.
pub const MAX_SUBDIVISION_DEPTH: usize = 4;

/// `γ_k = k U / (1 − k U)`: a product of `k` factors `(1 + δ_i)^{±1}`,
/// `|δ_i| ≤ U`, lies within `γ_k` of 1 (Higham, *Accuracy and Stability
/// of Numerical Algorithms*, Lemma 3.1).
pub(crate) fn gamma(k: usize) -> f64 {
    let ku = k as f64 * U;
    ku / (1.0 - ku)
}

/// The Lagrange-to-Bernstein matrix of one direction and how far from the
/// exact inverse it may be (also the z factor of the prism's conversion,
/// [`super::prism`]).
pub(crate) struct Conversion {
    /// The computed inverse of the Bernstein–Vandermonde matrix `V`.
    pub(crate) inv: Vec<Vec<f64>>,
    /// Its largest row sum of absolute values (∞-norm).
    pub(crate) norm: f64,
    /// A bound on `‖inv V − I‖∞` for the exact `V` (entries `B_j(t_i)` of
    /// the stored nodes `t_i`).
    pub(crate) rho: f64,
    /// `(1 + ρ)^D − 1` for D = 2, 3.
    grow: [f64; 2],
}

impl Conversion {
    fn new(p: usize, spacing: Spacing) -> Result<Self, HighOrderError> {
        Ok(Conversion::from_nodes(&nodes_1d(p, spacing)?))
    }

    /// For the `p + 1` nodes `t` in `[0,1]` (distinct: the 1-D node sets).
    pub(crate) fn from_nodes(t: &[f64]) -> Self {
        let p = t.len() - 1;
        // V[i][j] = B_j(t_i): Bernstein coefficients c satisfy V c = values
        let v: Vec<Vec<f64>> = t.iter().map(|&x| bernstein(p, x)).collect();
        let inv = invert(&v);
        let n = p + 1;
        // The computed residual R = inv·V − I misses (i) the rounding of
        // its own n-term sums, ≤ γ_{n+1} |inv||V|, and (ii) the rounding of
        // V's entries (binomial exact, then at most p factors of t and
        // 1 − t, each with one rounding, and 2 products: ≤ γ_{2p+4} V,
        // V ≥ 0). Both are bounded by γ_{3p+6} |inv||V|.
        let g = gamma(3 * p + 6);
        let mut rho = 0.0f64;
        for (i, row) in inv.iter().enumerate() {
            let mut sum = 0.0;
            for j in 0..n {
                let r: f64 = (0..n).map(|k| row[k] * v[k][j]).sum::<f64>() - f64::from(u8::from(i == j));
                let a: f64 = (0..n).map(|k| (row[k] * v[k][j]).abs()).sum();
                sum += r.abs() + g * a;
            }
            rho = rho.max(sum);
        }
        let norm = inv.iter().map(|r| r.iter().map(|x| x.abs()).sum::<f64>()).fold(0.0, f64::max);
        // 2 ulps cover the rounding of ρ's own sums
        let rho = rho * (1.0 + 4.0 * U);
        // without cancellation; ρ ≪ 1/D, so it is < 1/2
        let grow = [2.0, 3.0].map(|d: f64| (d * rho.ln_1p()).exp_m1().min(0.5));
        Conversion { inv, norm, rho, grow }
    }
}

/// The translation and power-of-two scale `(centre, s)` that move the
/// element's bounding box to the origin with every coordinate in
/// `[−1, 1]`: point `c` becomes `(c − centre) / s`. `det J` of the original
/// element is `s^D` times that of the moved one; the scaling is exact, so
/// the certificate does not depend on where the element is or how large
/// it is (up to the rounding of the centring subtraction, one relative `U`
/// per coordinate, which [`DetParts::error_bound`] counts).
pub(crate) fn normalise<const D: usize>(ctrl: &[[f64; D]]) -> ([f64; D], f64) {
    let centre: [f64; D] = std::array::from_fn(|r| {
        let (lo, hi) = ctrl.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| (lo.min(c[r]), hi.max(c[r])));
        0.5 * lo + 0.5 * hi
    });
    let m = ctrl.iter().flat_map(|c| (0..D).map(move |r| (c[r] - centre[r]).abs())).fold(0.0f64, f64::max);
    if !(m.is_finite() && m > 0.0) {
        // degenerate (all points equal) or not finite: nothing to scale
        return (centre, 1.0);
    }
    // the smallest power of two ≥ m, from m's exponent field (no log2:
    // this runs on every cell at every step), clamped so that s stays a
    // normal number
    let e = ((m.to_bits() >> 52) as i32 - 1023).clamp(-1020, 1020);
    let mut s = f64::from_bits(((e + 1023) as u64) << 52);
    if m > s {
        s *= 2.0;
    }
    (centre, s)
}

/// `det J` in Bernstein form with what is needed to bound its rounding.
struct DetParts {
    /// The computed coefficients.
    det: Bezier,
    /// A bound, over all coefficients, of the sum of the absolute values
    /// of the terms the rounding of the products acts on: the largest
    /// coefficient of the *absolute companion* of the products (the same
    /// sums and products on the absolute values of the derivative
    /// coefficients, a difference becoming a sum), or for `p = 1` the
    /// permanent of the columns' largest entries.
    abs_max: f64,
    /// Largest computed Bernstein coefficient of a coordinate.
    coord_max: f64,
    /// Largest moved control point coordinate (≤ 1 when normalised).
    input_max: f64,
    /// Largest computed derivative coefficient `∂x_r/∂ξ_c`.
    deriv_max: f64,
    /// An upper bound on the number of roundings along any path from a
    /// derivative coefficient to a coefficient of `det` (the `k` of `γ_k`).
    k: usize,
}

impl DetParts {
    /// The derivatives `col[c][r] = ∂x_r/∂ξ_c` of the element moved by
    /// `(centre, s)` (see [`normalise`]), then the determinant and the
    /// companion of its products.
    fn new<const D: usize>(p: usize, conv: &Conversion, ctrl: &[[f64; D]], (centre, s): ([f64; D], f64)) -> Self {
        let x: [Bezier; D] = std::array::from_fn(|r| Bezier::from_values(p, D, ctrl.iter().map(|c| (c[r] - centre[r]) / s), &conv.inv));
        let coord_max = x.iter().map(Bezier::max_abs).fold(0.0, f64::max);
        let col: [[Bezier; D]; D] = std::array::from_fn(|c| std::array::from_fn(|r| x[r].derivative(c)));
        let deriv_max = col.iter().flatten().map(Bezier::max_abs).fold(0.0, f64::max);
        let input_max = ctrl.iter().flat_map(|c| (0..D).map(move |r| ((c[r] - centre[r]) / s).abs())).fold(0.0, f64::max);
        let col_abs = col.each_ref().map(|c| c.each_ref().map(Bezier::abs));
        let (det, abs, k) = if D == 2 { det2(&col, &col_abs) } else { det3(&col, &col_abs) };
        DetParts { det, abs_max: abs.max_abs(), coord_max, input_max, deriv_max, k }
    }

    /// [`DetParts::new`] for `p = 1` (corners in tensor order), the
    /// product rule written out because the linear check runs on every
    /// cell at every step: the Bernstein coefficients of the coordinates
    /// are the corners, column `c` of J is the edge along `ξ_c`, of degree
    /// 1 in the other variables, and the product of `D` such columns has
    /// at multi-index `k` (degree `D − 1` per variable) the average, over
    /// the ways of giving each column its corner so that in each variable
    /// `d` the bits of the `D − 1` columns other than `d` sum to `k_d`, of
    /// the determinant of the edges chosen (weights `1 / C(D−1, k_d)`, as
    /// in [`Bezier::mul`]). For a quad the coefficients are the corner
    /// values. Every coefficient is a sum of `D!`-term determinants with
    /// non-negative weights summing to one, as for any `p`.
    fn linear<const D: usize>(ctrl: &[[f64; D]], (centre, s): ([f64; D], f64)) -> Self {
        let x = |a: usize| -> [f64; D] { std::array::from_fn(|r| (ctrl[a][r] - centre[r]) / s) };
        // edge[c][e]: along ξ_c from corner e (bit c of e is 0)
        let edge: [[[f64; D]; 8]; D] = std::array::from_fn(|c| std::array::from_fn(|e| if e < 1 << D && e >> c & 1 == 0 { crate::numeric::sub(x(e | 1 << c), x(e)) } else { [0.0; D] }));
        let input_max = (0..1 << D).flat_map(|a| x(a)).fold(0.0f64, |m, v| m.max(v.abs()));
        let col_max: [[f64; D]; D] = std::array::from_fn(|c| std::array::from_fn(|r| edge[c].iter().fold(0.0f64, |m, e| m.max(e[r].abs()))));
        let deriv_max = col_max.iter().flatten().fold(0.0f64, |m, &v| m.max(v));
        let n = D.pow(D as u32);
        let mut det = Bezier { deg: std::array::from_fn(|d| if d < D { D - 1 } else { 0 }), coef: smallvec::smallvec![0.0; n] };
        let inv_binom: [f64; D] = std::array::from_fn(|k| 1.0 / binom(D - 1, k));
        // a choice: the corner of each column, D − 1 bits (bit c is 0)
        for choice in 0..1usize << (D * (D - 1)) {
            let corner = |c: usize| {
                let free = (choice >> ((D - 1) * c)) & ((1 << (D - 1)) - 1);
                (free & ((1 << c) - 1)) | (free >> c) << (c + 1)
            };
            let k: [usize; D] = std::array::from_fn(|d| (0..D).map(|c| corner(c) >> d & 1).sum());
            let w: f64 = k.iter().map(|&kd| inv_binom[kd]).product();
            let m: [[f64; D]; D] = std::array::from_fn(|r| std::array::from_fn(|c| edge[c][corner(c)][r]));
            det.coef[(0..D).rev().fold(0, |i, d| i * D + k[d])] += w * crate::mesh::element::basis::det(&m);
        }
        // the permanent of the largest entries bounds every term sum
        let abs_max = if D == 2 {
            col_max[0][0] * col_max[1][1] + col_max[0][1] * col_max[1][0]
        } else {
            let m = |c: usize, r: usize| col_max[c][r];
            m(0, 0) * (m(1, 1) * m(2, 2) + m(1, 2) * m(2, 1)) + m(0, 1) * (m(1, 0) * m(2, 2) + m(1, 2) * m(2, 0)) + m(0, 2) * (m(1, 0) * m(2, 1) + m(1, 1) * m(2, 0))
        };
        // a determinant rounds 2 (D = 2) or 5 times, the weights are powers
        // of two, and at most 2^D terms are summed into a coefficient
        let k = if D == 2 { 2 } else { 5 } + (1 << D) - 1;
        DetParts { det, abs_max, coord_max: input_max, input_max, deriv_max, k }
    }

    /// A bound on `|computed − exact|` for every coefficient of `det`, the
    /// exact one being that of the Lagrange map through the control
    /// points (before the centring subtraction).
    ///
    /// Why it holds, in three stages (`a = ‖inv‖∞`, `U` the unit
    /// roundoff, `γ_k = kU/(1 − kU)`):
    /// 1. Coordinates to Bernstein coefficients: the centring rounds each
    ///    input by ≤ U relative, and each of the D passes is a (p+1)-term
    ///    dot product, so with the computed `inv` taken as exact a
    ///    coefficient errs by ≤ `γ_{D(p+1)+1} a^D max|x|`. The computed
    ///    `inv` is not `V⁻¹`: with `inv V = I + R`, `inv = (I + R) V⁻¹`, so
    ///    exact arithmetic with it gives `(I + R)^{⊗D} c` for the exact
    ///    coefficients `c`, off by ≤ `((1 + ρ)^D − 1) max|c|`, and
    ///    `max|c|` ≤ the computed maximum plus that error. Together: `ε`.
    /// 2. Derivatives `n (c_{i+1} − c_i)`, `n ≤ p`: the input error grows
    ///    to `2p ε`, and the subtraction and the product round by
    ///    ≤ `γ_2 · 2p max|c|`. Together: `δ`.
    /// 3. The products: each coefficient of `det` is a sum of products of
    ///    derivative coefficients and exact-ratio weights; each product
    ///    carries at most `k` rounding factors `(1 + θ)`, so the rounding
    ///    is ≤ `γ_k` times the sum of the absolute values of the terms,
    ///    which the companion bounds (itself computed with `k` roundings,
    ///    hence `/(1 − γ_k)`). The error `δ` of the factors adds at most
    ///    `D! ((M + δ)^D − M^D)` (`M` the largest factor): the weights of
    ///    one output coefficient sum to one, and `det` has `D!` signed
    ///    products of `D` factors.
    fn error_bound(&self, p: usize, dim: usize, conv: &Conversion) -> f64 {
        let (pf, d) = (p as f64, dim as i32);
        let round_c = gamma(dim * (p + 1) + 1) * conv.norm.powi(d) * self.input_max;
        let r = conv.grow[dim - 2];
        let eps = round_c + r / (1.0 - r) * (self.coord_max + round_c);
        let delta = 2.0 * pf * eps + gamma(2) * 2.0 * pf * (self.coord_max + eps);
        let g = gamma(self.k);
        let round = g / (1.0 - g) * self.abs_max;
        let m = self.deriv_max;
        let fact = if dim == 2 { 2.0 } else { 6.0 };
        let inputs = fact * ((m + delta).powi(d) - m.powi(d));
        // a few ulps more cover the rounding of this formula itself
        (round + inputs) * (1.0 + 16.0 * U)
    }
}

/// Roundings added by one product [`Bezier::mul`] of operands with `na`
/// and `nb` coefficients: 8 for the weight (three quotients of exact
/// binomials, two roundings each, and their product), 2 for the product
/// of weight and coefficients, and one per term of the sum into an output
/// coefficient (each coefficient of one operand meets at most one of the
/// other there).
fn mul_roundings(na: usize, nb: usize) -> usize {
    10 + na.min(nb)
}

/// `det J = x_ξ y_η − x_η y_ξ`, its companion and its rounding count.
fn det2<const D: usize>(col: &[[Bezier; D]; D], abs: &[[Bezier; D]; D]) -> (Bezier, Bezier, usize) {
    let n = col[0][0].coef.len().min(col[1][1].coef.len());
    let det = col[0][0].mul(&col[1][1]).add_scaled(-1.0, &col[1][0].mul(&col[0][1]));
    let det_abs = abs[0][0].mul(&abs[1][1]).add_scaled(1.0, &abs[1][0].mul(&abs[0][1]));
    (det, det_abs, mul_roundings(n, n) + 1)
}

/// `det J = a · (b × c)` (columns), its companion and its rounding count.
pub(crate) fn det3<const D: usize>(col: &[[Bezier; D]; D], abs: &[[Bezier; D]; D]) -> (Bezier, Bezier, usize) {
    let triple = |cols: &[[Bezier; D]; D], s: f64| {
        let (a, b, c) = (&cols[0], &cols[1], &cols[2]);
        // b × c, each component of degree (2p, 2p−1, 2p−1)
        let cross = |i: usize, j: usize| b[i].mul(&c[j]).add_scaled(s, &b[j].mul(&c[i]));
        let bc = [cross(1, 2), cross(2, 0), cross(0, 1)];
        a[0].mul(&bc[0]).add_scaled(1.0, &a[1].mul(&bc[1])).add_scaled(1.0, &a[2].mul(&bc[2]))
    };
    let n1 = col[1][0].coef.len();
    let kc = mul_roundings(n1, n1) + 1;
    let n2 = col[0][0].coef.len();
    let k = kc + mul_roundings(n2, n2) + 2;
    (triple(col, -1.0), triple(abs, 1.0), k)
}

/// Limits of the branch and bound in [`certify_with`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CertifyOptions {
    /// Stop refining when the certified bound is within `rel_tol · |min|`
    /// of a value `det J` attains (and likewise for the max).
    pub rel_tol: f64,
    /// At most this many box splits per bound (min and max each), so a
    /// degenerate element (min exactly 0) cannot run forever.
    pub max_splits: usize,
    /// Points per direction of the sampling grid for
    /// [`Certificate::min_det_sampled`] and the scaled Jacobian; `0` means
    /// `3p + 1`.
    pub samples: usize,
}

impl Default for CertifyOptions {
    /// `rel_tol` 1e-7 (the brief's target is 1e-4; the bound converges
    /// quadratically, so the extra digits cost a few dozen splits),
    /// 4000 splits, `3p + 1` samples per direction.
    fn default() -> Self {
        CertifyOptions { rel_tol: 1e-7, max_splits: 4000, samples: 0 }
    }
}

impl CertifyOptions {
    /// Points per direction of the sampling grid at order `p`.
    pub(crate) fn sample_count(&self, p: usize) -> usize {
        if self.samples >= 2 {
            self.samples
        } else {
            3 * p + 1
        }
    }

    /// Each element's bracket when a whole mesh is certified: to 1e-3 of
    /// its minimum, then [`extreme_candidates`] alone to the default 1e-7.
    /// The extra digits on every element cost most of the splits
    /// (measured on the 1e-5 extruded layer at p = 3: 178,173 splits
    /// with every element to 1e-7, 24,308 with 81 candidates bracketed
    /// again; certification 11.4 s against 5.1 s).
    pub fn element() -> Self {
        CertifyOptions { rel_tol: 1e-3, ..Default::default() }
    }
}

/// The elements of a mesh, given their `certs`, that may hold its least
/// or its largest det J: those whose lower bound of the minimum is at
/// most the least value attained on any element, or whose upper bound of
/// the maximum is at least the largest attained. Bracketing these alone
/// to a tolerance brackets the mesh's extremes to it: every other element
/// has its minimum above a value some candidate attains, and the
/// candidate's new bracket is within the tolerance of that value or below.
pub fn extreme_candidates(certs: &[Certificate]) -> Vec<usize> {
    let least = certs.iter().map(|c| c.min_det_upper).fold(f64::INFINITY, f64::min);
    let most = certs.iter().map(|c| c.max_det_attained).fold(f64::NEG_INFINITY, f64::max);
    (0..certs.len()).filter(|&e| certs[e].min_det_lower <= least || certs[e].max_det >= most).collect()
}

/// What [`certify`] finds about one element. Determinants are of the map
/// from `[0,1]^d` (Gmsh's `[-1,1]^d` values are these divided by `2^d`);
/// for simplices from the unit simplex (Gmsh's own), for prisms from the
/// unit triangle × `[0,1]` (Gmsh's are half these).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Certificate {
    /// `det J > 0` on the whole element, certified (`min_det_lower > 0`).
    /// `false` either means certified invalid (`min_det_upper <= 0`) or,
    /// when `min_det_upper > 0`, undecided within the split budget.
    pub valid: bool,
    /// A certified lower bound of `min det J` over the element (lowered by
    /// a bound on the rounding errors, derived in `DetParts::error_bound`).
    pub min_det_lower: f64,
    /// A value `det J` takes on the element (a corner coefficient of a
    /// sub-box plus its rounding bound, or a sampled value), so an upper
    /// bound of the true minimum: the true minimum lies in
    /// `[min_det_lower, min_det_upper]`; a negative value shows the
    /// element invalid.
    pub min_det_upper: f64,
    /// A certified upper bound of `max det J`, tight like the minimum.
    pub max_det: f64,
    /// A value `det J` takes on the element near its maximum, so a lower
    /// bound of the true maximum: it lies in `[max_det_attained, max_det]`.
    pub max_det_attained: f64,
    /// `min det J` over the sampling grid (`samples` equispaced points per
    /// direction, end points included; for equispaced elements with the
    /// default `3p + 1` it contains the nodes).
    pub min_det_sampled: f64,
    /// `min det J / Π_c |∂x/∂ξ_c|` over the same sampling grid: 1 for an
    /// affine square or cube, negative where the element is inverted.
    pub min_scaled_jacobian: f64,
    /// Box splits used for the two bounds together.
    pub splits: usize,
}

impl Certificate {
    /// The certificate of a normalised element in `dim` dimensions scaled
    /// by `s` ([`normalise`]): from the bracket `(lo, up)` of its min det J,
    /// the bracket `(neg_lo, neg_up)` of the min of −det J, the sampled `(min det J, min
    /// scaled Jacobian)` and the splits used. `s` is a power of two:
    /// scaling back is exact (unless the true value under- or overflows).
    pub(crate) fn of_normalised(dim: usize, s: f64, (lo, up): (f64, f64), (neg_lo, neg_up): (f64, f64), (min_det, min_sj): (f64, f64), splits: usize) -> Certificate {
        let unit = |x: f64| (0..dim).fold(x, |v, _| v * s);
        Certificate {
            valid: lo > 0.0,
            min_det_lower: unit(lo),
            min_det_upper: unit(up.min(min_det)),
            max_det: unit(-neg_lo),
            max_det_attained: unit(-neg_up),
            min_det_sampled: unit(min_det),
            min_scaled_jacobian: min_sj,
            splits,
        }
    }
}

/// The bracket of [`bound_min`] settles within this fraction of the
/// largest coefficient of a minimum (at the rounding level of det J's
/// coefficients), so a minimum of exactly 0 is not refined for ever.
pub(crate) const ZERO_FLOOR: f64 = 1e-16;

/// A certificate's two brackets, of min det J and of min −det J (whose
/// negative bounds max det J), by a kind's branch and bound `bound_min`
/// over det J's coefficients `det` and `neg` (within `err`), each to
/// `opts`' tolerance and split budget: `(min, neg_min, splits)`.
pub(crate) fn brackets<C>(det: C, neg: C, err: f64, opts: &CertifyOptions, bound_min: impl Fn(C, f64, Goal) -> (f64, f64, usize)) -> ((f64, f64), (f64, f64), usize) {
    let goal = Goal::Bracket { rel_tol: opts.rel_tol, max_splits: opts.max_splits };
    let (lo, up, s1) = bound_min(det, err, goal);
    let (neg_lo, neg_up, s2) = bound_min(neg, err, goal);
    ((lo, up), (neg_lo, neg_up), s1 + s2)
}

/// What the branch and bound of [`bound_min`] is after.
#[derive(Clone, Copy)]
pub(crate) enum Goal {
    /// The minimum within `rel_tol`, in at most `max_splits` splits.
    Bracket { rel_tol: f64, max_splits: usize },
    /// Only whether it is certainly positive, in at most
    /// [`MAX_SUBDIVISION_DEPTH`] halvings of any box.
    Sign,
}

/// `(lower, upper, splits)`: a certified lower bound of the minimum of
/// the exact polynomial over its box, a bound above a value it attains
/// (upper bound of the minimum) and the number of splits used, given
/// `poly` whose coefficients are within `err` of the exact ones. Best
/// first: always split the box with the smallest lower bound, in the
/// variables [`split_directions`] picks; drop boxes that are settled (within `rel_tol` of the
/// best value found, or certainly positive for [`Goal::Sign`]). The search
/// runs on the computed coefficients; the rounding bounds are applied to
/// its result. For [`Goal::Sign`] the minimum is positive iff `lower > 0`.
pub(crate) fn bound_min(poly: &Bezier, dim: usize, err: f64, goal: Goal) -> (f64, f64, usize) {
    // A halving in one variable applies rows of non-negative weights
    // summing to one (binomial / 2^k, exact): at most n + 2 roundings.
    let n = poly.deg.iter().max().copied().unwrap_or(0);
    super::branch::bound_min(poly, &dim, dim, n + 2, err, goal)
}

/// A box of a tensor element, halved in the variables
/// [`split_directions`] chooses; its context is the dimension.
impl super::branch::Piece for Bezier {
    type Context = usize;
    fn coefficients(&self) -> &[f64] {
        &self.coef
    }
    fn least_vertex(&self, _: &usize) -> f64 {
        self.min_corner()
    }
    fn cut(self, &dim: &usize, goal: Goal) -> (SmallVec<[Bezier; 8]>, usize) {
        let dirs = split_directions(&self, dim, goal);
        let mut parts: SmallVec<[Bezier; 8]> = smallvec::smallvec![self];
        for &d in &dirs {
            parts = parts
                .into_iter()
                .flat_map(|b| {
                    let (l, r) = b.split(d);
                    [l, r]
                })
                .collect();
        }
        (parts, dirs.len())
    }
}

/// The variables [`bound_min`] halves a box in. The sign test halves all
/// (its depth limit is in halvings of the whole box). The bracket halves
/// those whose [`Bezier::net_gaps`] term is within 4× of the largest: one
/// halving quarters a term, so the others would not yet be the largest;
/// all of them if every term is 0 (a multilinear net, settled by its
/// corners unless rounding keeps it open).
fn split_directions(poly: &Bezier, dim: usize, goal: Goal) -> SmallVec<[usize; 3]> {
    let all = || (0..dim).collect();
    if let Goal::Sign = goal {
        return all();
    }
    let gaps = poly.net_gaps();
    let top = gaps[..dim].iter().copied().fold(0.0f64, f64::max);
    if !(top > 0.0) {
        return all();
    }
    (0..dim).filter(|&d| gaps[d] >= 0.25 * top).collect()
}

/// The certificate's set-up for one order and node spacing, made once per
/// mesh: the Lagrange-to-Bernstein conversion and the basis for sampling.
pub struct Certifier {
    p: usize,
    conv: Conversion,
    basis: Basis1d,
}

impl Certifier {
    /// For order-`p` elements with nodes at `spacing`.
    pub fn new(p: usize, spacing: Spacing) -> Result<Self, HighOrderError> {
        Ok(Certifier { p, conv: Conversion::new(p, spacing)?, basis: Basis1d::new(p, spacing)? })
    }

    /// `det J` of the normalised element with its rounding bound, and the
    /// scale `s` of [`normalise`] (`det J` of `ctrl` is `s^D` times it).
    fn det_j<const D: usize>(&self, ctrl: &[[f64; D]]) -> (DetParts, f64, f64) {
        let (centre, s) = normalise(ctrl);
        let parts = if self.p == 1 { DetParts::linear(ctrl, (centre, s)) } else { DetParts::new(self.p, &self.conv, ctrl, (centre, s)) };
        let err = parts.error_bound(self.p, D, &self.conv);
        (parts, err, s)
    }

    /// Whether `det J > 0` on the whole element (control points in tensor
    /// order), decided conservatively: `true` is a proof; `false` means
    /// invalid or so nearly invalid that det J comes within the Bézier
    /// bound's slack of 0 on a box of 1/2^[`MAX_SUBDIVISION_DEPTH`] of the
    /// element. Cheaper than [`certify`]: no bracket of the minimum.
    pub fn is_valid<const D: usize>(&self, ctrl: &[[f64; D]]) -> bool {
        let (parts, err, _) = self.det_j(ctrl);
        bound_min(&parts.det, D, err, Goal::Sign).0 > 0.0
    }

    /// [`certify_with`] with this set-up (the node count is not checked).
    pub fn certify<const D: usize>(&self, ctrl: &[[f64; D]], opts: &CertifyOptions) -> Certificate {
        let (parts, err, s) = self.det_j(ctrl);
        self.bracket(ctrl, (&parts, err, s), opts)
    }

    /// [`Certifier::certify`] if [`Certifier::is_valid`], else `None`: one
    /// det J for both, and no bracket of an invalid element's minimum (the
    /// costliest to bracket).
    pub fn certify_if_valid<const D: usize>(&self, ctrl: &[[f64; D]], opts: &CertifyOptions) -> Option<Certificate> {
        let (parts, err, s) = self.det_j(ctrl);
        (bound_min(&parts.det, D, err, Goal::Sign).0 > 0.0).then(|| self.bracket(ctrl, (&parts, err, s), opts))
    }

    /// The certificate from det J (`parts`, its rounding bound and scale).
    fn bracket<const D: usize>(&self, ctrl: &[[f64; D]], (parts, err, s): (&DetParts, f64, f64), opts: &CertifyOptions) -> Certificate {
        let (min, neg, splits) = brackets(&parts.det, &parts.det.neg(), err, opts, |c, e, g| bound_min(c, D, e, g));
        let (centre, _) = normalise(ctrl);
        let moved: Vec<[f64; D]> = ctrl.iter().map(|c| std::array::from_fn(|r| (c[r] - centre[r]) / s)).collect();
        let (mut min_det, mut min_sj) = (f64::INFINITY, f64::INFINITY);
        for j in jacobians_on_grid(&self.basis, &moved, opts.sample_count(self.p)) {
            min_det = min_det.min(crate::mesh::element::basis::det(&j));
            min_sj = min_sj.min(scaled_det(&j));
        }
        Certificate::of_normalised(D, s, min, neg, (min_det, min_sj), splits)
    }
}

/// Certifies an order-`p` quad (`D = 2`) or hex (`D = 3`), control points
/// in tensor order, reference `[0,1]^D`, with [`CertifyOptions::default`].
pub fn certify<const D: usize>(p: usize, spacing: Spacing, ctrl: &[[f64; D]]) -> Result<Certificate, HighOrderError> {
    certify_with(p, spacing, ctrl, &CertifyOptions::default())
}

/// [`certify`] with explicit limits.
pub fn certify_with<const D: usize>(p: usize, spacing: Spacing, ctrl: &[[f64; D]], opts: &CertifyOptions) -> Result<Certificate, HighOrderError> {
    check_nodes(p, D, ctrl.len())?;
    Ok(Certifier::new(p, spacing)?.certify(ctrl, opts))
}

/// Tensor position → corner of a linear quad or hex in mesh order
/// (counter-clockwise per layer).
const TENSOR_CORNERS: [usize; 8] = [0, 1, 3, 2, 4, 5, 7, 6];

/// The certifier of order 1, made once (its conversion is the identity for
/// either spacing).
fn linear() -> &'static Certifier {
    static LINEAR: OnceLock<Certifier> = OnceLock::new();
    LINEAR.get_or_init(|| Certifier::new(1, Spacing::Equispaced).expect("order 1 is supported"))
}

/// The corners of a linear cell (mesh order) in tensor order.
fn tensor<const D: usize, const N: usize>(corners: &[[f64; D]; N]) -> [[f64; D]; N] {
    std::array::from_fn(|t| corners[TENSOR_CORNERS[t]])
}

/// Whether `det J > 0` on the whole bilinear quad or trilinear hex with
/// `corners` in mesh order: [`Certifier::is_valid`] at `p = 1`.
pub fn linear_is_valid<const D: usize, const N: usize>(corners: &[[f64; D]; N]) -> bool {
    if crate::lsfem::is_simplex(D, N) {
        return super::simplex::linear_simplex_is_valid(corners);
    }
    linear().is_valid(&tensor(corners))
}

/// `(min, max)` of the Bernstein coefficients of `det J` of a linear cell
/// (corners in mesh order; reference `[0,1]^D`): bounds of det J over the
/// cell, each attained when it sits at a corner. A min ≤ 0 does not prove
/// the cell invalid (see [`linear_is_valid`] for the refined test).
pub fn det_j_bounds<const D: usize, const N: usize>(corners: &[[f64; D]; N]) -> (f64, f64) {
    if crate::lsfem::is_simplex(D, N) {
        // constant on the cell: the determinant of its edges from node 0
        let e: [[f64; D]; D] = std::array::from_fn(|r| std::array::from_fn(|c| corners[c + 1][r] - corners[0][r]));
        let det = crate::mesh::element::basis::det(&e);
        return (det, det);
    }
    let (parts, _, s) = linear().det_j(&tensor(corners));
    let (lo, hi) = parts.det.coef_bounds();
    let unit = |x: f64| (0..D).fold(x, |v, _| v * s);
    (unit(lo), unit(hi))
}

/// The cells (corners in mesh order, indices into `nodes`) that are not
/// certified valid by [`linear_is_valid`], e.g. at the deformed positions
/// of a step. A cell left out is valid (det J > 0 everywhere on it); a
/// reported cell is invalid or nearly so.
///
/// # Panics
/// If a cell refers to a node beyond `nodes`.
pub fn invalid_cells<const D: usize, const N: usize>(cells: &[[usize; N]], nodes: &[[f64; D]]) -> Vec<usize> {
    // once per step attempt over every cell: in parallel
    (0..cells.len()).into_par_iter().with_min_len(256).filter(|&c| !linear_is_valid(&cells[c].map(|n| nodes[n]))).collect()
}

/// The cells of a linear plane mesh of quads and triangles not certified
/// valid by [`linear_is_valid`] (a quad with det J not positive at a
/// corner, a triangle of non-positive area), in mesh order.
pub fn invalid_mixed_cells(mesh: &crate::mesh::CurvedMesh<2>) -> Vec<usize> {
    let at = |n: usize| mesh.nodes[n];
    (0..mesh.cells.len())
        .filter(|&c| match *mesh.vertices(c).as_slice() {
            [a, b, d] => !linear_is_valid(&[a, b, d].map(at)),
            [a, b, d, e] => !linear_is_valid(&[a, b, d, e].map(at)),
            ref v => unreachable!("a plane cell of {} vertices", v.len()),
        })
        .collect()
}

/// The certifier of one kind and order of element, whatever the kind:
/// the one API the method and the readers use (tensor Bernstein bounds on
/// quads and hexes, simplex ones on triangles and tetrahedra, the product
/// of the two on prisms, tensor ones in the collapsed cube on pyramids).
pub enum ElementCertifier {
    /// Quads and hexes.
    Tensor(Certifier),
    /// Triangles and tetrahedra.
    Simplex(super::simplex::SimplexCertifier),
    /// Prisms (wedges).
    Prism(super::prism::PrismCertifier),
    /// Pyramids.
    Pyramid(super::pyramid::PyramidCertifier),
}

impl ElementCertifier {
    /// For order-`p` elements of `shape` with nodes at `spacing`.
    pub fn new(shape: crate::mesh::element::Shape, p: usize, spacing: Spacing) -> Result<Self, HighOrderError> {
        if shape == crate::mesh::element::Shape::Pyramid {
            return Ok(ElementCertifier::Pyramid(super::pyramid::PyramidCertifier::new(p, spacing)?));
        }
        if shape == crate::mesh::element::Shape::Prism {
            let space = crate::mesh::element::prism::space(p, spacing)?;
            return Ok(ElementCertifier::Prism(super::prism::PrismCertifier::new(p, &space.nodes)?));
        }
        if shape.is_simplex() {
            let space = crate::mesh::element::simplex::space(shape, p, spacing)?;
            return Ok(ElementCertifier::Simplex(super::simplex::SimplexCertifier::new(shape, p, &space.nodes)?));
        }
        Ok(ElementCertifier::Tensor(Certifier::new(p, spacing)?))
    }

    /// See [`Certifier::is_valid`].
    pub fn is_valid<const D: usize>(&self, ctrl: &[[f64; D]]) -> bool {
        match self {
            ElementCertifier::Tensor(c) => c.is_valid(ctrl),
            ElementCertifier::Simplex(c) => c.is_valid(ctrl),
            ElementCertifier::Prism(c) => c.is_valid(ctrl),
            ElementCertifier::Pyramid(c) => c.is_valid(ctrl),
        }
    }

    /// See [`Certifier::certify_if_valid`] (one det J on quads and hexes;
    /// the other kinds compute theirs twice).
    pub fn certify_if_valid<const D: usize>(&self, ctrl: &[[f64; D]], opts: &CertifyOptions) -> Option<Certificate> {
        match self {
            ElementCertifier::Tensor(c) => c.certify_if_valid(ctrl, opts),
            _ => self.is_valid(ctrl).then(|| self.certify(ctrl, opts)),
        }
    }

    /// See [`Certifier::certify`].
    pub fn certify<const D: usize>(&self, ctrl: &[[f64; D]], opts: &CertifyOptions) -> Certificate {
        match self {
            ElementCertifier::Tensor(c) => c.certify(ctrl, opts),
            ElementCertifier::Simplex(c) => c.certify(ctrl, opts),
            ElementCertifier::Prism(c) => c.certify(ctrl, opts),
            ElementCertifier::Pyramid(c) => c.certify(ctrl, opts),
        }
    }
}

/// One [`ElementCertifier`] per kind of cell of a mesh: a mixed mesh's
/// quads and triangles each by their own bounds.
pub struct Certifiers(Vec<(crate::mesh::element::Shape, ElementCertifier)>);

impl Certifiers {
    /// For order-`p` elements of each of `shapes` with nodes at `spacing`.
    pub fn new(shapes: &[crate::mesh::element::Shape], p: usize, spacing: Spacing) -> Result<Self, HighOrderError> {
        shapes.iter().map(|&s| Ok((s, ElementCertifier::new(s, p, spacing)?))).collect::<Result<_, _>>().map(Certifiers)
    }

    /// The certifier of `shape`.
    ///
    /// # Panics
    /// If `shape` is not one the set was made for.
    pub fn of(&self, shape: crate::mesh::element::Shape) -> &ElementCertifier {
        &self.0.iter().find(|c| c.0 == shape).expect("a certifier for every kind of the mesh").1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quality::tests::{lcg, threshold};
    use crate::lsfem::q1_eval;
    use crate::mesh::element::basis::{det, reference_nodes, tensor_map};
    use crate::mesh::{HexMesh, Point3};
    use crate::quality::tests::{unit_cube, Rng};


    fn curved_quad(p: usize, s: Spacing, amp: f64, seed: u64) -> Vec<[f64; 2]> {
        let mut seed = seed;
        reference_nodes::<2>(p, s)
            .unwrap()
            .into_iter()
            .map(|[u, v]| [1.5 * u + 0.3 * v + 0.2 * (2.0 * v).sin() + amp * lcg(&mut seed), v + 0.25 * u * u + amp * lcg(&mut seed)])
            .collect()
    }

    fn curved_hex(p: usize, s: Spacing, amp: f64, seed: u64) -> Vec<[f64; 3]> {
        let mut seed = seed;
        reference_nodes::<3>(p, s)
            .unwrap()
            .into_iter()
            .map(|[u, v, w]| {
                [
                    u + 0.15 * (2.0 * v).sin() + amp * lcg(&mut seed),
                    v + 0.2 * u * w + amp * lcg(&mut seed),
                    1.2 * w - 0.15 * u * u + 0.1 * v + amp * lcg(&mut seed),
                ]
            })
            .collect()
    }

    /// `det J` in Bernstein form (in the element's own units) with its
    /// rounding bound.
    fn det_j_bezier<const D: usize>(p: usize, s: Spacing, ctrl: &[[f64; D]]) -> (Bezier, f64) {
        let (parts, err, s) = Certifier::new(p, s).unwrap().det_j(ctrl);
        let unit = |x: f64| (0..D).fold(x, |v, _| v * s);
        (Bezier { deg: parts.det.deg, coef: parts.det.coef.iter().map(|&c| unit(c)).collect() }, unit(err))
    }


    /// A NaN or infinite coordinate gives no bound: not valid, linear or
    /// curved (the min and max of the coefficients skipped NaN, and such
    /// an element was certified valid).
    #[test]
    fn non_finite_coordinates_are_not_valid() {
        let mut hex = curved_hex(2, Spacing::Equispaced, 0.0, 1);
        hex[4][1] = f64::NAN;
        let c = certify(2, Spacing::Equispaced, &hex).unwrap();
        assert!(!c.valid && c.min_det_lower == f64::NEG_INFINITY, "{c:?}");
        let mut cube: [[f64; 3]; 8] = std::array::from_fn(|a| std::array::from_fn(|d| crate::lsfem::q1_corner(a, d)));
        assert!(linear_is_valid(&cube));
        cube[3][2] = f64::INFINITY;
        assert!(!linear_is_valid(&cube));
    }
    #[test]
    fn bezier_det_matches_the_map_everywhere() {
        let mut seed = 7u64;
        for p in 1..=4 {
            for s in [Spacing::Equispaced, Spacing::GaussLobatto] {
                let q = curved_quad(p, s, 0.03, 11);
                let (bq, _) = det_j_bezier(p, s, &q);
                assert_eq!(bq.deg, [2 * p - 1, 2 * p - 1, 0]);
                let h = curved_hex(p, s, 0.03, 5);
                let (bh, _) = det_j_bezier(p, s, &h);
                assert_eq!(bh.deg, [3 * p - 1; 3]);
                let basis = Basis1d::new(p, s).unwrap();
                for _ in 0..20 {
                    let x = [0.5 + 0.5 * lcg(&mut seed), 0.5 + 0.5 * lcg(&mut seed), 0.5 + 0.5 * lcg(&mut seed)];
                    let (_, jq) = tensor_map(&basis, &q, [x[0], x[1]]);
                    assert!((bq.eval(x) - det(&jq)).abs() < 1e-12 * det(&jq).abs().max(1.0));
                    let (_, jh) = tensor_map(&basis, &h, x);
                    assert!((bh.eval(x) - det(&jh)).abs() < 1e-12 * det(&jh).abs().max(1.0));
                    // the coefficients bound every value
                    let (lo, hi) = bh.coef_bounds();
                    assert!(lo <= det(&jh) && det(&jh) <= hi);
                }
            }
        }
    }

    #[test]
    fn certificate_brackets_the_sampled_minimum_tightly() {
        for p in 1..=4 {
            let q = curved_quad(p, Spacing::GaussLobatto, 0.1 / p as f64, 17 + p as u64);
            let c = certify(p, Spacing::GaussLobatto, &q).unwrap();
            assert!(c.valid, "p={p}: {c:?}");
            assert!(c.min_det_lower <= c.min_det_sampled && c.min_det_lower <= c.min_det_upper, "p={p}: {c:?}");
            assert!(c.min_det_upper - c.min_det_lower <= 1e-6 * c.min_det_upper, "{c:?}");
            assert!(c.min_scaled_jacobian > 0.0 && c.min_scaled_jacobian <= 1.0);
            // a dense sampling never goes below the certified bound, and
            // the certified minimum is no higher than the dense minimum
            let opts = |samples| CertifyOptions { samples, ..Default::default() };
            let fine = certify_with(p, Spacing::GaussLobatto, &q, &opts(101)).unwrap();
            assert!(fine.min_det_sampled >= c.min_det_lower);
            assert!(c.min_det_upper <= fine.min_det_sampled + 1e-12);
            assert!(c.max_det >= 0.0);

            let h = curved_hex(p, Spacing::Equispaced, 0.06 / p as f64, 23 + p as u64);
            let c = certify(p, Spacing::Equispaced, &h).unwrap();
            assert!(c.valid, "p={p}: {c:?}");
            assert!(c.min_det_lower <= c.min_det_sampled);
            // the rounding bound of this noisy p = 4 element is 2.4e-6
            // (Bernstein conversion at p = 4 amplifies by 15 per direction)
            let gap = if p == 4 { 2e-5 } else { 1e-6 };
            assert!(c.min_det_upper - c.min_det_lower <= gap * c.min_det_upper, "{c:?}");
            let fine = certify_with(p, Spacing::Equispaced, &h, &opts(25)).unwrap();
            assert!(fine.min_det_sampled >= c.min_det_lower);
        }
    }

    /// Subdivision tightens the bound: the raw coefficient minimum of a
    /// curved element is well below the true minimum, the certificate is
    /// not.
    #[test]
    fn subdivision_tightens_the_bound() {
        let q = curved_quad(3, Spacing::Equispaced, 0.06, 99);
        let raw = det_j_bezier(3, Spacing::Equispaced, &q).0.coef_bounds().0;
        let c = certify(3, Spacing::Equispaced, &q).unwrap();
        assert!(c.splits > 0);
        assert!(c.min_det_upper - raw > 100.0 * (c.min_det_upper - c.min_det_lower), "{raw} {c:?}");
        let coarse = certify_with(3, Spacing::Equispaced, &q, &CertifyOptions { max_splits: 0, ..Default::default() }).unwrap();
        // without splits the bound is the raw minimum less the rounding
        // bound (about 1e-9 here)
        assert!(coarse.min_det_lower <= raw && coarse.min_det_lower > raw - 1e-8, "{raw} {coarse:?}");
    }

    /// A p = 2 square with its bottom mid-edge node and its centre node
    /// moved (found by a random search): det J is positive at all nine
    /// nodes (≥ 0.25) but negative between them. Node values would call it
    /// valid; the certificate proves it invalid.
    #[test]
    fn invalid_element_between_nodes_is_found() {
        let mut q = reference_nodes::<2>(2, Spacing::Equispaced).unwrap();
        q[1][0] -= 0.14; // node (½, 0)
        q[1][1] += 0.44;
        q[4][0] += 0.19; // node (½, ½)
        q[4][1] += 0.29;
        let basis = Basis1d::new(2, Spacing::Equispaced).unwrap();
        for x in &reference_nodes::<2>(2, Spacing::Equispaced).unwrap() {
            let (_, j) = tensor_map(&basis, &q, *x);
            assert!(det(&j) > 0.2, "det J at node {x:?} = {}", det(&j));
        }
        let c = certify(2, Spacing::Equispaced, &q).unwrap();
        assert!(!c.valid && !Certifier::new(2, Spacing::Equispaced).unwrap().is_valid(&q));
        assert!(c.min_det_upper < -0.1, "{c:?}");
        assert!(c.min_det_lower <= c.min_det_upper);
        let fine = certify_with(2, Spacing::Equispaced, &q, &CertifyOptions { samples: 401, ..Default::default() }).unwrap();
        assert!(fine.min_det_sampled < -0.1 && fine.min_scaled_jacobian < 0.0);
        // the certified bracket contains the dense-sample minimum, closely
        // (401² samples resolve the minimum to about 1e-4 relative)
        assert!(c.min_det_lower <= fine.min_det_sampled);
        assert!((c.min_det_upper - fine.min_det_sampled).abs() < 1e-3 * fine.min_det_sampled.abs(), "{c:?} {fine:?}");
    }

    /// The p = 2 quad of `invalid_element_between_nodes` with its two moved
    /// nodes displaced by `lam` times dyadic vectors: every coordinate is a
    /// multiple of 2^-32 below 4, so adding 1e6 (ulp 2^-33 there) is exact.
    fn family(lam: f64) -> Vec<[f64; 2]> {
        let mut q = reference_nodes::<2>(2, Spacing::Equispaced).unwrap();
        q[1][0] -= lam * 0.125;
        q[1][1] += lam * 0.4375;
        q[4][0] += lam * 0.1875;
        q[4][1] += lam * 0.3125;
        q
    }

    /// The same quad as a p = 2 hex of unit height (det J is unchanged).
    fn extruded(q: &[[f64; 2]]) -> Vec<[f64; 3]> {
        (0..3).flat_map(|k| q.iter().map(move |&[x, y]| [x, y, k as f64 * 0.5])).collect()
    }

    /// A barely valid and a barely invalid element (min det J ≈ ±4e-9 of
    /// its size): translated by 1e6 and scaled by 1e-6 (2D and 3D) they
    /// get the same verdicts; the translated and the power-of-two scaled
    /// copies get identical certificates.
    #[test]
    fn verdicts_do_not_depend_on_position_or_size() {
        let cert = |q: &Vec<[f64; 2]>| certify(2, Spacing::Equispaced, q).unwrap();
        let (valid, invalid) = threshold(family, |q| {
            let c = cert(q);
            assert!(c.valid || c.min_det_upper < 0.0, "undecided: {c:?}");
            c.valid
        });
        let (cv, ci) = (cert(&valid), cert(&invalid));
        assert!(cv.valid && cv.min_det_lower < 1e-7, "{cv:?}");
        assert!(!ci.valid && ci.min_det_upper < 0.0 && ci.min_det_upper > -1e-7, "{ci:?}");
        for (q, base) in [(&valid, cv), (&invalid, ci)] {
            let map = |f: &dyn Fn(f64) -> f64| q.iter().map(|c| c.map(f)).collect::<Vec<[f64; 2]>>();
            assert_eq!(cert(&map(&|x| x + 1e6)), base);
            let c2 = cert(&map(&|x| x * 2f64.powi(-20)));
            assert_eq!(c2.min_det_lower, base.min_det_lower * 2f64.powi(-40));
            assert_eq!(c2.valid, base.valid);
            let small = map(&|x| x * 1e-6);
            let cs = cert(&small);
            assert_eq!(cs.valid, base.valid, "{cs:?} {base:?}");
            assert_eq!(cs.min_det_upper < 0.0, base.min_det_upper < 0.0);
            // 1e6 + 1e-6 x keeps only ~2e-4 of x: rounding moves the nodes,
            // the verdict may then change; it must stay a sound bracket
            let cf = cert(&small.iter().map(|c| c.map(|x| x + 1e6)).collect());
            assert!(cf.min_det_lower <= cf.min_det_upper, "{cf:?}");

            // det J is constant along w: the search halves only u and v,
            // so the hex gets the quad's verdict in as many splits (halving
            // w too, it ran out of its 4000 undecided)
            let h = extruded(q);
            let ch = certify(2, Spacing::Equispaced, &h).unwrap();
            assert!(ch.min_det_lower <= base.min_det_upper && ch.min_det_upper >= base.min_det_lower, "{ch:?} {base:?}");
            assert_eq!(ch.valid, base.valid, "{ch:?} {base:?}");
            assert!(ch.splits <= 2 * base.splits, "{} vs {}", ch.splits, base.splits);
            let hm: Vec<[f64; 3]> = h.iter().map(|c| c.map(|x| x + 1e6)).collect();
            assert_eq!(certify(2, Spacing::Equispaced, &hm).unwrap(), ch);
            let hs: Vec<[f64; 3]> = h.iter().map(|c| c.map(|x| x * 1e-6)).collect();
            assert_eq!(certify(2, Spacing::Equispaced, &hs).unwrap().valid, ch.valid);
        }
    }

    /// The rounding bound is small next to det J for a well-shaped element
    /// and scales with it: it leaves the certificate tight.
    #[test]
    fn rounding_bound_is_small_and_scale_free() {
        for p in 1..=4 {
            // measured 1.6e-13, 1.0e-11, 7.1e-10, 2.4e-6 (p = 4, whose
            // noisy test element has coefficients up to 50) of the hex
            let (b, err) = det_j_bezier(p, Spacing::GaussLobatto, &curved_quad(p, Spacing::GaussLobatto, 0.05, 3));
            assert!(err > 0.0 && err < 1e-7 * b.max_abs(), "p={p}: {err} vs {}", b.max_abs());
            let (b, err) = det_j_bezier(p, Spacing::Equispaced, &curved_hex(p, Spacing::Equispaced, 0.03, 5));
            assert!(err > 0.0 && err < 1e-7 * b.max_abs(), "p={p}: {err} vs {}", b.max_abs());
        }
    }

    /// The written-out `p = 1` product gives the coefficients of the
    /// general one, with no larger rounding bound.
    #[test]
    fn linear_kernel_is_the_general_product() {
        fn compare<const D: usize>(ctrl: &[[f64; D]]) {
            let conv = Conversion::new(1, Spacing::Equispaced).unwrap();
            let moved = normalise(ctrl);
            let (k, g) = (DetParts::linear(ctrl, moved), DetParts::new(1, &conv, ctrl, moved));
            assert_eq!(k.det.deg, g.det.deg);
            for (a, b) in k.det.coef.iter().zip(&g.det.coef) {
                assert!((a - b).abs() <= 1e-14 * g.det.max_abs(), "{a} vs {b}");
            }
            assert!(k.error_bound(1, D, &conv) <= g.error_bound(1, D, &conv));
        }
        let mut rng = Rng(5);
        for _ in 0..50 {
            compare(&tensor(&unit_cube().map(|q| q.map(|x| 3.0 * x + rng.sym(0.8)))));
            compare(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]].map(|q: [f64; 2]| q.map(|x| x + rng.sym(0.6))));
        }
    }

    #[test]
    fn wrong_node_count_is_an_error() {
        assert!(certify(2, Spacing::Equispaced, &[[0.0; 3]; 26]).is_err());
        assert!(certify(0, Spacing::Equispaced, &[[0.0; 2]; 1]).is_err());
    }

    // The linear check (p = 1).

    /// The 27 Bernstein coefficients of det J of a trilinear hex the way
    /// the former separate hex check computed them, independently of the
    /// products above: det J sampled on {0, ½, 1}³ (degree 2 in each
    /// variable), converted one direction at a time by `f0, 2 f½ − (f0 +
    /// f1)/2, f1`; index `i + 3 j + 9 k`, tensor order.
    fn sampled_coefficients(p: &[Point3; 8]) -> [f64; 27] {
        let mut b: [f64; 27] = std::array::from_fn(|n| q1_eval(p, [n % 3, n / 3 % 3, n / 9].map(|i| i as f64 / 2.0)).1);
        for stride in [1, 3, 9] {
            for start in (0..27).filter(|s| (s / stride) % 3 == 0) {
                let [i0, i1, i2] = [start, start + stride, start + 2 * stride];
                b[i1] = 2.0 * b[i1] - 0.5 * (b[i0] + b[i2]);
            }
        }
        b
    }

    /// The former hex check's rounding bound on those coefficients, with
    /// its 4 halvings, for a cell whose largest edge component in the
    /// directions u, v, w is `l` (its own units, so valid at any scale).
    fn former_rounding_bound(p: &[Point3; 8], b: &[f64; 27]) -> f64 {
        let edges = [[(0, 1), (3, 2), (4, 5), (7, 6)], [(0, 3), (1, 2), (4, 7), (5, 6)], [(0, 4), (1, 5), (3, 7), (2, 6)]];
        let l = edges.map(|e| e.iter().flat_map(|&(a, c)| crate::numeric::sub(p[c], p[a])).fold(0.0f64, |m, x| m.max(x.abs())));
        let g = |k: f64| k * f64::EPSILON / (1.0 - k * f64::EPSILON);
        let values = g(26.0) * 162.0 * l[0] * l[1] * l[2] * 1.01;
        let big = b.iter().fold(0.0f64, |m, x| m.max(x.abs())) + values;
        values + 4.0 * 3.0 * g(2.0) * big
    }

    /// Minimum of det J sampled on a 25³ grid.
    fn sampled_min(p: &[Point3; 8]) -> f64 {
        let t = |i: usize| i as f64 / 24.0;
        (0..25usize.pow(3)).map(|n| q1_eval(p, [t(n % 25), t(n / 25 % 25), t(n / 625)]).1).fold(f64::INFINITY, f64::min)
    }

    /// On random and on nearly degenerate trilinear hexes the p = 1 path
    /// gives the coefficients of the former hex check, a rounding bound no
    /// looser than its bound, and verdicts that agree with dense sampling
    /// (valid ⇒ sampled min > 0; a sampled min ≤ 0 ⇒ invalid).
    #[test]
    fn linear_hex_check_agrees_with_the_former_one_and_with_sampling() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let (mut valid, mut invalid) = (0, 0);
        for n in 0..400 {
            // perturbations from mild to folding, some scaled far away
            let amp = [0.1, 0.3, 0.45, 0.6][n % 4];
            let (scale, shift) = [(1.0, 0.0), (1e-5, 1e3), (1e4, -1e6), (1.0, 0.5)][n / 4 % 4];
            let p = unit_cube().map(|q| q.map(|x| (x + rng.sym(amp)) * scale + shift));
            let (b, err) = det_j_bezier(1, Spacing::Equispaced, &tensor(&p));
            // (the references on the cell moved to node 0, exactly: q1_eval
            // sums coordinates, not edges)
            let (ok, p) = (linear_is_valid(&p), p.map(|q| crate::numeric::sub(q, p[0])));
            let old = sampled_coefficients(&p);
            let big = old.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            for (i, (x, y)) in b.coef.iter().zip(&old).enumerate() {
                assert!((x - y).abs() <= 1e-13 * big, "cell {n} coefficient {i}: {x} vs {y}");
            }
            let former = former_rounding_bound(&p, &old);
            let depth = MAX_SUBDIVISION_DEPTH as f64 * 3.0 * gamma(4) * (b.max_abs() + 2.0 * err);
            assert!(err + depth <= former, "cell {n}: {err} + {depth} vs {former}");
            let min = sampled_min(&p);
            assert_eq!(ok, linear_is_valid(&p), "cell {n}: moved, another verdict");
            assert!(!ok || min > 0.0, "cell {n} certified with sampled min {min}");
            assert!(ok || min < 0.05 * big, "cell {n} with sampled min {min} not certified");
            if ok { valid += 1 } else { invalid += 1 }
        }
        assert!(valid > 100 && invalid > 50, "{valid} {invalid}");
    }

    /// The unit cube with node 6 pulled towards node 0 by `lam` (dyadic
    /// steps: translating by 1e6 is exact).
    fn pulled(lam: f64) -> [Point3; 8] {
        let mut p = unit_cube();
        p[6] = [1.0 - lam, 1.0 - 0.75 * lam, 1.0 - 0.5 * lam];
        p
    }

    /// A barely valid and a barely invalid cell (det J at node 6 about
    /// ±1e-8): the same verdicts translated by 1e6, scaled by 1e-6 or by
    /// 2^-40; and a cell 1e-200 across is neither lost to underflow nor
    /// refused.
    #[test]
    fn linear_verdicts_do_not_depend_on_position_or_size() {
        let (valid, invalid) = threshold(pulled, linear_is_valid);
        let corner = |p: &[Point3; 8]| crate::quality::corner_det_j(p)[6];
        assert!(corner(&valid) > 0.0 && corner(&valid) < 1e-7, "{}", corner(&valid));
        assert!(corner(&invalid) <= 0.0 && corner(&invalid) > -1e-7);
        for (cell, verdict) in [(valid, true), (invalid, false)] {
            for f in [|c: f64| c + 1e6, |c| c * 1e-6, |c| c * 2f64.powi(-40), |c| c] {
                assert_eq!(linear_is_valid(&cell.map(|x| x.map(f))), verdict);
            }
        }
        assert!(linear_is_valid(&unit_cube().map(|x| x.map(|c| c * 1e-200))));
    }

    #[test]
    fn subdivision_clears_valid_cells_with_negative_coefficients() {
        // Found by a random search over strongly perturbed cubes: all corner
        // values are positive in both, but the first has a negative Bézier
        // coefficient while det J ≥ 0.8 everywhere, and the second really
        // has det J < 0 inside.
        let valid: [Point3; 8] = [
            [0.8, -0.8, -0.5],
            [1.2, 0.5, -0.2],
            [0.2, 1.6, -0.8],
            [-0.7, 1.3, -0.5],
            [-0.8, -0.5, 1.6],
            [0.5, -0.4, 1.1],
            [1.2, 0.2, 1.4],
            [0.0, 1.2, 0.6],
        ];
        assert!(crate::quality::corner_det_j(&valid).iter().all(|&d| d > 0.0));
        assert!(det_j_bounds(&valid).0 < -0.3, "{:?}", det_j_bounds(&valid));
        assert!(sampled_min(&valid) > 0.8);
        assert!(linear_is_valid(&valid));

        let invalid: [Point3; 8] = [
            [-0.3, 0.6, 0.8],
            [0.8, -0.6, -0.2],
            [1.8, 1.5, 0.3],
            [0.9, 0.1, 0.3],
            [0.5, 0.2, 1.2],
            [1.7, -0.3, 0.3],
            [1.2, 0.3, 0.9],
            [0.9, 1.1, 0.2],
        ];
        assert!(crate::quality::corner_det_j(&invalid).iter().all(|&d| d > 0.0));
        assert!(sampled_min(&invalid) < -0.2);
        assert!(!linear_is_valid(&invalid));
    }

    #[test]
    fn folded_cells_are_reported() {
        let mut mesh = HexMesh::structured_box([0.0; 3], [2.0, 1.0, 1.0], [2, 1, 1]);
        let mut nodes = mesh.nodes.clone();
        assert!(invalid_cells(&mesh.cells, &nodes).is_empty());
        // move the shared node (1,0,0) far past x = 2: cell 1 folds, and
        // cell 0 becomes very stretched but stays valid
        nodes[mesh.cells[0][1]][0] = 2.6;
        assert_eq!(invalid_cells(&mesh.cells, &nodes), vec![1]);
        mesh.nodes = nodes;
        assert!(linear_is_valid(&mesh.cell_coords(0)));
    }
}
