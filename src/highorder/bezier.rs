//! Tensor-product Bernstein (Bézier) polynomials and the validity
//! certificate of curved quads and hexes.
//!
//! The Jacobian determinant of an order-`p` tensor Lagrange map is itself a
//! polynomial: in 2D `det J = x_ξ y_η − x_η y_ξ` where `x_ξ` has degree
//! `(p−1, p)` and `y_η` degree `(p, p−1)`, so `det J` has degree
//! `(2p−1, 2p−1)`; in 3D the triple product of columns of degrees
//! `(p−1,p,p)`, `(p,p−1,p)`, `(p,p,p−1)` has degree `(3p−1, 3p−1, 3p−1)`.
//! We compute its Bernstein coefficients *exactly* (up to rounding): the
//! Lagrange control points are converted to Bernstein control points (one
//! small dense solve per direction), differentiated in Bernstein form and
//! multiplied with the Bernstein product rule
//! `B_i^m B_j^n = C(m,i) C(n,j) / C(m+n,i+j) B_{i+j}^{m+n}` — no sampling,
//! no ill-conditioned interpolation at degree 11.
//!
//! Bernstein polynomials are non-negative and sum to 1, so the smallest
//! and largest coefficients bound the polynomial on the box, and the corner
//! coefficients are values. Splitting a box in halves (de Casteljau)
//! tightens the bounds quadratically in the box size; [`certify_quad`] and
//! [`certify_hex`] do a best-first branch and bound on that.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use super::basis::{jacobians_on_grid, scaled_det, Basis1d};
use super::{check_nodes, nodes_1d, HighOrderError, Spacing};

/// A polynomial in up to three variables on the box `[0,1]^3` in the
/// tensor Bernstein basis: `Σ coef[i + (n0+1)(j + (n1+1) k)]
/// B_i^{n0}(u) B_j^{n1}(v) B_k^{n2}(w)`. Unused variables have degree 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Bezier {
    /// Degree per variable.
    pub deg: [usize; 3],
    /// Coefficients, first variable fastest.
    pub coef: Vec<f64>,
}

/// Binomial coefficient as `f64` (exact for the small arguments used).
fn binom(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// `B_i^n(t)` for `i = 0..=n`.
fn bernstein(n: usize, t: f64) -> Vec<f64> {
    (0..=n)
        .map(|i| binom(n, i) * t.powi(i as i32) * (1.0 - t).powi((n - i) as i32))
        .collect()
}

/// Inverse of a small dense matrix by Gauss–Jordan with partial pivoting.
/// Only called on Bernstein–Vandermonde matrices at distinct nodes, which
/// are invertible.
fn invert(a: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = a.len();
    let mut m: Vec<Vec<f64>> = a
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut r = row.clone();
            r.extend((0..n).map(|j| f64::from(u8::from(i == j))));
            r
        })
        .collect();
    for col in 0..n {
        let piv = (col..n)
            .max_by(|&x, &y| m[x][col].abs().total_cmp(&m[y][col].abs()))
            .unwrap_or(col);
        m.swap(col, piv);
        let d = m[col][col];
        for v in &mut m[col] {
            *v /= d;
        }
        let pivot_row = m[col].clone();
        for (r, row) in m.iter_mut().enumerate() {
            let f = row[col];
            if r != col && f != 0.0 {
                for (x, &pv) in row.iter_mut().zip(&pivot_row) {
                    *x -= f * pv;
                }
            }
        }
    }
    m.into_iter().map(|r| r[n..].to_vec()).collect()
}

impl Bezier {
    /// The constant `c` (degree 0 in all variables).
    pub fn constant(c: f64) -> Self {
        Bezier {
            deg: [0; 3],
            coef: vec![c],
        }
    }

    /// Number of coefficients along variable `d`.
    fn len(&self, d: usize) -> usize {
        self.deg[d] + 1
    }

    /// The Bernstein form of the order-`p` Lagrange interpolant in `dim`
    /// variables of `values` given at the tensor nodes of `spacing`
    /// (tensor order). Degree `p` in the first `dim` variables.
    pub fn from_lagrange(
        p: usize,
        spacing: Spacing,
        dim: usize,
        values: &[f64],
    ) -> Result<Self, HighOrderError> {
        check_nodes(p, dim, values.len())?;
        Ok(Self::from_values(p, dim, values, &Conversion::new(p, spacing)?.inv))
    }

    /// `inv` (the Lagrange-to-Bernstein matrix, or its absolute value)
    /// applied along each of the first `dim` variables of `values`.
    fn from_values(p: usize, dim: usize, values: &[f64], inv: &[Vec<f64>]) -> Self {
        let mut b = Bezier {
            deg: [0; 3],
            coef: values.to_vec(),
        };
        for d in 0..dim {
            b.deg[d] = p;
        }
        for d in 0..dim {
            b = b.apply(d, inv);
        }
        b
    }

    /// Applies `mat` (rows: new coefficients, columns: old ones) along
    /// variable `d`; the new degree there is `mat.len() − 1`.
    fn apply(&self, d: usize, mat: &[Vec<f64>]) -> Bezier {
        let inner: usize = (0..d).map(|e| self.len(e)).product();
        let outer: usize = (d + 1..3).map(|e| self.len(e)).product();
        let (old, new) = (self.len(d), mat.len());
        let mut coef = vec![0.0; inner * new * outer];
        for o in 0..outer {
            for a in 0..inner {
                for (r, row) in mat.iter().enumerate() {
                    let mut s = 0.0;
                    for (l, &m) in row.iter().enumerate().take(old) {
                        if m != 0.0 {
                            s += m * self.coef[a + inner * (l + old * o)];
                        }
                    }
                    coef[a + inner * (r + new * o)] = s;
                }
            }
        }
        let mut deg = self.deg;
        deg[d] = new - 1;
        Bezier { deg, coef }
    }

    /// The partial derivative along variable `d` (of the polynomial on
    /// `[0,1]^3`): `n (c_{i+1} − c_i)` in degree `n − 1`. A constant
    /// direction gives zero.
    pub fn derivative(&self, d: usize) -> Bezier {
        let n = self.deg[d];
        if n == 0 {
            return Bezier {
                deg: self.deg,
                coef: vec![0.0; self.coef.len()],
            };
        }
        let mat: Vec<Vec<f64>> = (0..n)
            .map(|k| {
                let mut row = vec![0.0; n + 1];
                row[k] = -(n as f64);
                row[k + 1] = n as f64;
                row
            })
            .collect();
        self.apply(d, &mat)
    }

    /// The coefficients' absolute values.
    fn abs(&self) -> Bezier {
        Bezier {
            deg: self.deg,
            coef: self.coef.iter().map(|c| c.abs()).collect(),
        }
    }

    /// The product, exactly in the Bernstein basis of the summed degree.
    pub fn mul(&self, other: &Bezier) -> Bezier {
        let deg: [usize; 3] = std::array::from_fn(|d| self.deg[d] + other.deg[d]);
        // w[d][i][j] = C(m,i) C(n,j) / C(m+n, i+j)
        let w: Vec<Vec<Vec<f64>>> = (0..3)
            .map(|d| {
                let (m, n) = (self.deg[d], other.deg[d]);
                (0..=m)
                    .map(|i| {
                        (0..=n)
                            .map(|j| binom(m, i) * binom(n, j) / binom(m + n, i + j))
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let [a0, a1, a2] = std::array::from_fn(|d| self.len(d));
        let [b0, b1, b2] = std::array::from_fn(|d| other.len(d));
        let (c0, c1) = (deg[0] + 1, deg[1] + 1);
        let mut coef = vec![0.0; c0 * c1 * (deg[2] + 1)];
        // nested loops in storage order (no index division in the hot
        // loop); the arithmetic and its order are those of the plain
        // double loop over coefficient pairs
        let mut ca = self.coef.iter();
        for i2 in 0..a2 {
            for i1 in 0..a1 {
                for (i0, &ca) in (0..a0).zip(&mut ca) {
                    let mut cb = other.coef.iter();
                    for j2 in 0..b2 {
                        let w2 = w[2][i2][j2];
                        for j1 in 0..b1 {
                            let w1 = w[1][i1][j1];
                            let base = i0 + c0 * ((i1 + j1) + c1 * (i2 + j2));
                            let out = &mut coef[base..base + b0];
                            for ((o, &w0), &cb) in out.iter_mut().zip(&w[0][i0]).zip(&mut cb) {
                                *o += w0 * w1 * w2 * ca * cb;
                            }
                        }
                    }
                }
            }
        }
        Bezier { deg, coef }
    }

    /// `self + s · other` for polynomials of the same degree.
    fn add_scaled(&self, s: f64, other: &Bezier) -> Bezier {
        assert_eq!(
            self.deg, other.deg,
            "adding Bézier polynomials of different degree"
        );
        Bezier {
            deg: self.deg,
            coef: self
                .coef
                .iter()
                .zip(&other.coef)
                .map(|(a, b)| a + s * b)
                .collect(),
        }
    }

    /// The value at `x` (unused variables ignored).
    pub fn eval(&self, x: [f64; 3]) -> f64 {
        let mut b = self.clone();
        for (d, &xd) in x.iter().enumerate() {
            if b.deg[d] > 0 {
                b = b.apply(d, &[bernstein(b.deg[d], xd)]);
            }
        }
        b.coef[0]
    }

    /// The two halves `[0,½]` and `[½,1]` along variable `d`, each
    /// re-parametrised to `[0,1]` (de Casteljau at ½ as two matrices).
    pub fn split(&self, d: usize) -> (Bezier, Bezier) {
        let n = self.deg[d];
        let half = 0.5f64;
        let left: Vec<Vec<f64>> = (0..=n)
            .map(|k| {
                (0..=n)
                    .map(|i| {
                        if i <= k {
                            binom(k, i) * half.powi(k as i32)
                        } else {
                            0.0
                        }
                    })
                    .collect()
            })
            .collect();
        let right: Vec<Vec<f64>> = (0..=n)
            .map(|k| {
                (0..=n)
                    .map(|i| {
                        if i >= k {
                            binom(n - k, i - k) * half.powi((n - k) as i32)
                        } else {
                            0.0
                        }
                    })
                    .collect()
            })
            .collect();
        (self.apply(d, &left), self.apply(d, &right))
    }

    /// `(min, max)` of the coefficients: bounds of the polynomial on the
    /// box.
    pub fn coef_bounds(&self) -> (f64, f64) {
        self.coef
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &c| {
                (lo.min(c), hi.max(c))
            })
    }

    /// The smallest corner coefficient, a value the polynomial takes.
    fn min_corner(&self) -> f64 {
        let mut m = f64::INFINITY;
        for c in 0..8 {
            let idx: [usize; 3] =
                std::array::from_fn(|d| if c >> d & 1 == 1 { self.deg[d] } else { 0 });
            m = m.min(self.coef[idx[0] + self.len(0) * (idx[1] + self.len(1) * idx[2])]);
        }
        m
    }

    /// The negated polynomial.
    fn neg(&self) -> Bezier {
        Bezier {
            deg: self.deg,
            coef: self.coef.iter().map(|c| -c).collect(),
        }
    }
}

/// Unit roundoff: `fl(a ∘ b) = (a ∘ b)(1 + δ)` with `|δ| ≤ U`.
const U: f64 = f64::EPSILON / 2.0;

/// `γ_k = k U / (1 − k U)`: a product of `k` factors `(1 + δ_i)^{±1}`,
/// `|δ_i| ≤ U`, lies within `γ_k` of 1 (Higham, *Accuracy and Stability
/// of Numerical Algorithms*, Lemma 3.1).
fn gamma(k: usize) -> f64 {
    let ku = k as f64 * U;
    ku / (1.0 - ku)
}

/// Largest row sum of absolute values (the ∞-norm of a matrix).
fn norm_inf(m: &[Vec<f64>]) -> f64 {
    m.iter()
        .map(|r| r.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// The Lagrange-to-Bernstein matrix of one direction and how far from the
/// exact inverse it may be.
struct Conversion {
    /// The computed inverse of the Bernstein–Vandermonde matrix `V`.
    inv: Vec<Vec<f64>>,
    /// A bound on `ρ = ‖inv V − I‖∞` for the exact `V` (entries
    /// `B_j(t_i)` of the stored nodes `t_i`).
    rho: f64,
}

impl Conversion {
    fn new(p: usize, spacing: Spacing) -> Result<Self, HighOrderError> {
        let t = nodes_1d(p, spacing)?;
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
        // 2 ulps cover the rounding of ρ's own sums
        Ok(Conversion { inv, rho: rho * (1.0 + 4.0 * U) })
    }
}

/// The element moved so that its bounding box is centred at the origin and
/// scaled by a power of two `s` so that every coordinate lies in `[−1, 1]`;
/// returns the moved points and `s`. `det J` of the original element is
/// `s^D` times that of the moved one; the scaling is exact, so the
/// certificate does not depend on where the element is or how large it is
/// (up to the rounding of the centring subtraction, one relative `U` per
/// coordinate, which [`DetParts::error_bound`] counts).
fn normalise<const D: usize>(ctrl: &[[f64; D]]) -> (Vec<[f64; D]>, f64) {
    let centre: [f64; D] = std::array::from_fn(|r| {
        let (lo, hi) = ctrl
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| (lo.min(c[r]), hi.max(c[r])));
        0.5 * lo + 0.5 * hi
    });
    let moved: Vec<[f64; D]> = ctrl.iter().map(|c| std::array::from_fn(|r| c[r] - centre[r])).collect();
    let m = moved.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    if !(m.is_finite() && m > 0.0) {
        // degenerate (all points equal) or not finite: nothing to scale
        return (moved, 1.0);
    }
    // the exponent is clamped so that s^D stays a normal number
    let e = (m.log2().ceil() as i32).clamp(-1000 / D as i32, 1000 / D as i32);
    let mut s = 2f64.powi(e);
    if m > s {
        s *= 2.0;
    }
    let scaled = moved.iter().map(|c| c.map(|x| x / s)).collect();
    (scaled, s)
}

/// `det J` in Bernstein form with what is needed to bound its rounding.
struct DetParts {
    /// The computed coefficients.
    det: Bezier,
    /// The *absolute companion* of the products: the same sums and
    /// products on the absolute values of the computed derivative
    /// coefficients (a difference becomes a sum). It bounds, coefficient
    /// by coefficient, the sum of the absolute values of the terms the
    /// rounding of the products acts on.
    abs: Bezier,
    /// Largest computed Bernstein coefficient of a coordinate.
    coord_max: f64,
    /// Largest computed control point coordinate (≤ 1 when normalised).
    input_max: f64,
    /// Largest computed derivative coefficient `∂x_r/∂ξ_c`.
    deriv_max: f64,
    /// An upper bound on the number of roundings along any path from a
    /// derivative coefficient to a coefficient of `det` (the `k` of `γ_k`).
    k: usize,
}

impl DetParts {
    /// The derivatives `col[c][r] = ∂x_r/∂ξ_c`, then the determinant and
    /// the companion of its products.
    fn new<const D: usize>(p: usize, conv: &Conversion, ctrl: &[[f64; D]]) -> Self {
        let mut col = vec![Vec::new(); D];
        let mut coord_max = 0.0f64;
        for r in 0..D {
            let v: Vec<f64> = ctrl.iter().map(|c| c[r]).collect();
            let x = Bezier::from_values(p, D, &v, &conv.inv);
            coord_max = x.coef.iter().fold(coord_max, |m, c| m.max(c.abs()));
            for c in 0..D {
                col[c].push(x.derivative(c));
            }
        }
        let deriv_max = col.iter().flatten().flat_map(|b| b.coef.iter()).fold(0.0f64, |m, &x| m.max(x.abs()));
        let input_max = ctrl.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        let col_abs: Vec<Vec<Bezier>> = col.iter().map(|c| c.iter().map(Bezier::abs).collect()).collect();
        let (det, abs, k) = if D == 2 { det2(&col, &col_abs) } else { det3(&col, &col_abs) };
        DetParts { det, abs, coord_max, input_max, deriv_max, k }
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
        let a = norm_inf(&conv.inv);
        let round_c = gamma(dim * (p + 1) + 1) * a.powi(d) * self.input_max;
        // (1 + ρ)^D − 1 without cancellation; ρ ≪ 1/D, so r < 1/2
        let r = (d as f64 * conv.rho.ln_1p()).exp_m1().min(0.5);
        let eps = round_c + r / (1.0 - r) * (self.coord_max + round_c);
        let delta = 2.0 * pf * eps + gamma(2) * 2.0 * pf * (self.coord_max + eps);
        let g = gamma(self.k);
        let round = g / (1.0 - g) * self.abs.coef.iter().fold(0.0f64, |m, &x| m.max(x));
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
fn det2(col: &[Vec<Bezier>], abs: &[Vec<Bezier>]) -> (Bezier, Bezier, usize) {
    let n = col[0][0].coef.len().min(col[1][1].coef.len());
    let det = col[0][0].mul(&col[1][1]).add_scaled(-1.0, &col[1][0].mul(&col[0][1]));
    let det_abs = abs[0][0].mul(&abs[1][1]).add_scaled(1.0, &abs[1][0].mul(&abs[0][1]));
    (det, det_abs, mul_roundings(n, n) + 1)
}

/// `det J = a · (b × c)` (columns), its companion and its rounding count.
fn det3(col: &[Vec<Bezier>], abs: &[Vec<Bezier>]) -> (Bezier, Bezier, usize) {
    let triple = |cols: &[Vec<Bezier>], s: f64| {
        let (a, b, c) = (&cols[0], &cols[1], &cols[2]);
        // b × c, each component of degree (2p, 2p−1, 2p−1)
        let cross = |i: usize, j: usize| b[i].mul(&c[j]).add_scaled(s, &b[j].mul(&c[i]));
        let bc = [cross(1, 2), cross(2, 0), cross(0, 1)];
        a[0].mul(&bc[0])
            .add_scaled(1.0, &a[1].mul(&bc[1]))
            .add_scaled(1.0, &a[2].mul(&bc[2]))
    };
    let n1 = col[1][0].coef.len();
    let kc = mul_roundings(n1, n1) + 1;
    let n2 = col[0][0].coef.len();
    let k = kc + mul_roundings(n2, n2) + 2;
    (triple(col, -1.0), triple(abs, 1.0), k)
}

/// `det J` of the order-`p` quad map (control points in tensor order) on
/// `[0,1]²`, exactly, in degree `(2p−1, 2p−1)`.
pub fn det_j_bezier_quad(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; 2]],
) -> Result<Bezier, HighOrderError> {
    check_nodes(p, 2, ctrl.len())?;
    Ok(DetParts::new(p, &Conversion::new(p, spacing)?, ctrl).det)
}

/// `det J` of the order-`p` hex map (control points in tensor order) on
/// `[0,1]³`, exactly, in degree `(3p−1, 3p−1, 3p−1)`.
pub fn det_j_bezier_hex(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; 3]],
) -> Result<Bezier, HighOrderError> {
    check_nodes(p, 3, ctrl.len())?;
    Ok(DetParts::new(p, &Conversion::new(p, spacing)?, ctrl).det)
}

/// Limits of the branch and bound in [`certify_quad_with`] and
/// [`certify_hex_with`].
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
        CertifyOptions {
            rel_tol: 1e-7,
            max_splits: 4000,
            samples: 0,
        }
    }
}

/// What [`certify_quad`] and [`certify_hex`] find about one element.
/// Determinants are of the map from `[0,1]^d` (Gmsh's `[-1,1]^d` values
/// are these divided by `2^d`).
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

/// A box of the branch and bound, ordered so the heap pops the smallest
/// lower bound first.
struct BoxItem {
    lower: f64,
    poly: Bezier,
    /// How many times it was split from the whole element.
    depth: usize,
}

impl PartialEq for BoxItem {
    fn eq(&self, other: &Self) -> bool {
        self.lower.total_cmp(&other.lower) == Ordering::Equal
    }
}
impl Eq for BoxItem {}
impl PartialOrd for BoxItem {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for BoxItem {
    fn cmp(&self, other: &Self) -> Ordering {
        // reversed: BinaryHeap is a max-heap
        other.lower.total_cmp(&self.lower)
    }
}

/// `(lower, upper, splits)`: a certified lower bound of the minimum of
/// the exact polynomial over its box, a bound above a value it attains
/// (upper bound of the minimum) and the number of splits used, given
/// `poly` whose coefficients are within `err` of the exact ones. Best
/// first: always split the box with the smallest lower bound, in all `dim`
/// variables at once; drop boxes that cannot hold a value below
/// `upper − tol`. The search runs on the computed coefficients; the
/// rounding bounds are applied to its result.
fn bound_min(poly: &Bezier, dim: usize, err: f64, opts: &CertifyOptions) -> (f64, f64, usize) {
    let scale = poly.coef.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    // The floor keeps a minimum of exactly 0 from asking for infinite
    // relative precision.
    let tol = |upper: f64| opts.rel_tol * upper.abs().max(1e-9 * scale);
    let mut upper = poly.min_corner();
    let mut pruned = f64::INFINITY;
    let mut heap = BinaryHeap::new();
    heap.push(BoxItem {
        lower: poly.coef_bounds().0,
        poly: poly.clone(),
        depth: 0,
    });
    let (mut splits, mut deepest) = (0, 0);
    // A split applies, per variable, rows of non-negative weights summing
    // to one (binomial / 2^k, exact): at most n + 2 roundings on terms
    // whose absolute values sum to at most the largest coefficient plus
    // its error. So each level adds at most this to a box's error.
    let n = poly.deg.iter().max().copied().unwrap_or(0);
    let per_level = dim as f64 * gamma(n + 2) * (scale + 2.0 * err);
    let result = |lower: f64, upper: f64, splits: usize, deepest: usize| {
        let e = err + deepest as f64 * per_level;
        (lower - e, upper + e, splits)
    };
    while let Some(top) = heap.pop() {
        if top.lower >= upper - tol(upper) || splits >= opts.max_splits {
            return result(top.lower.min(pruned), upper, splits, deepest);
        }
        splits += 1;
        let depth = top.depth + 1;
        deepest = deepest.max(depth);
        let mut parts = vec![top.poly];
        for d in 0..dim {
            parts = parts
                .into_iter()
                .flat_map(|b| {
                    let (l, r) = b.split(d);
                    [l, r]
                })
                .collect();
        }
        for b in &parts {
            upper = upper.min(b.min_corner());
        }
        for b in parts {
            let lower = b.coef_bounds().0;
            if lower >= upper - tol(upper) {
                pruned = pruned.min(lower);
            } else {
                heap.push(BoxItem { lower, poly: b, depth });
            }
        }
    }
    // every box was pruned: the minimum is within tol of upper
    result(pruned.min(upper), upper, splits, deepest)
}

/// Certificate of an element: `det J` of the normalised element (see
/// [`normalise`]) with its rounding bound, branch and bound, sampled
/// figures; determinants scaled back to the element's own units.
fn certify<const D: usize>(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; D]],
    opts: &CertifyOptions,
) -> Result<Certificate, HighOrderError> {
    check_nodes(p, D, ctrl.len())?;
    let (ctrl, s) = normalise(ctrl);
    let conv = Conversion::new(p, spacing)?;
    let parts = DetParts::new(p, &conv, &ctrl);
    let err = parts.error_bound(p, D, &conv);
    let det = &parts.det;
    let (lo, up, s1) = bound_min(det, D, err, opts);
    let (neg_lo, _, s2) = bound_min(&det.neg(), D, err, opts);
    let basis = Basis1d::new(p, spacing)?;
    let m = if opts.samples >= 2 {
        opts.samples
    } else {
        3 * p + 1
    };
    let mut min_det = f64::INFINITY;
    let mut min_sj = f64::INFINITY;
    for j in jacobians_on_grid(&basis, &ctrl, m) {
        min_det = min_det.min(super::basis::det(&j));
        min_sj = min_sj.min(scaled_det(&j));
    }
    // s is a power of two: scaling back is exact
    let unit = s.powi(D as i32);
    Ok(Certificate {
        valid: lo > 0.0,
        min_det_lower: lo * unit,
        min_det_upper: up.min(min_det) * unit,
        max_det: -neg_lo * unit,
        min_det_sampled: min_det * unit,
        min_scaled_jacobian: min_sj,
        splits: s1 + s2,
    })
}

/// Certifies an order-`p` quad (control points in tensor order, `[0,1]²`
/// reference) with [`CertifyOptions::default`].
pub fn certify_quad(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; 2]],
) -> Result<Certificate, HighOrderError> {
    certify_quad_with(p, spacing, ctrl, &CertifyOptions::default())
}

/// [`certify_quad`] with explicit limits.
pub fn certify_quad_with(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; 2]],
    opts: &CertifyOptions,
) -> Result<Certificate, HighOrderError> {
    certify(p, spacing, ctrl, opts)
}

/// Certifies an order-`p` hex (control points in tensor order, `[0,1]³`
/// reference) with [`CertifyOptions::default`].
pub fn certify_hex(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; 3]],
) -> Result<Certificate, HighOrderError> {
    certify_hex_with(p, spacing, ctrl, &CertifyOptions::default())
}

/// [`certify_hex`] with explicit limits.
pub fn certify_hex_with(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; 3]],
    opts: &CertifyOptions,
) -> Result<Certificate, HighOrderError> {
    certify(p, spacing, ctrl, opts)
}

#[cfg(test)]
mod tests {
    use super::super::basis::{det, reference_nodes, tensor_map};
    use super::*;

    /// A deterministic pseudo-random sequence in [-1, 1].
    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    fn curved_quad(p: usize, s: Spacing, amp: f64, seed: u64) -> Vec<[f64; 2]> {
        let mut seed = seed;
        reference_nodes::<2>(p, s)
            .unwrap()
            .into_iter()
            .map(|[u, v]| {
                [
                    1.5 * u + 0.3 * v + 0.2 * (2.0 * v).sin() + amp * lcg(&mut seed),
                    v + 0.25 * u * u + amp * lcg(&mut seed),
                ]
            })
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

    #[test]
    fn bezier_det_matches_the_map_everywhere() {
        let mut seed = 7u64;
        for p in 1..=4 {
            for s in [Spacing::Equispaced, Spacing::GaussLobatto] {
                let q = curved_quad(p, s, 0.03, 11);
                let bq = det_j_bezier_quad(p, s, &q).unwrap();
                assert_eq!(bq.deg, [2 * p - 1, 2 * p - 1, 0]);
                let h = curved_hex(p, s, 0.03, 5);
                let bh = det_j_bezier_hex(p, s, &h).unwrap();
                assert_eq!(bh.deg, [3 * p - 1; 3]);
                let basis = Basis1d::new(p, s).unwrap();
                for _ in 0..20 {
                    let x = [
                        0.5 + 0.5 * lcg(&mut seed),
                        0.5 + 0.5 * lcg(&mut seed),
                        0.5 + 0.5 * lcg(&mut seed),
                    ];
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
    fn split_halves_agree_with_the_whole() {
        let b = det_j_bezier_hex(
            2,
            Spacing::Equispaced,
            &curved_hex(2, Spacing::Equispaced, 0.05, 3),
        )
        .unwrap();
        for d in 0..3 {
            let (l, r) = b.split(d);
            let mut x = [0.3, 0.6, 0.8];
            let mut y = x;
            x[d] = 0.4; // in the left half at 0.8
            y[d] = 0.9; // in the right half at 0.8
            let mut xl = x;
            xl[d] = 0.8;
            let mut yr = y;
            yr[d] = 0.8;
            assert!((l.eval(xl) - b.eval(x)).abs() < 1e-12);
            assert!((r.eval(yr) - b.eval(y)).abs() < 1e-12);
        }
    }

    #[test]
    fn certificate_brackets_the_sampled_minimum_tightly() {
        for p in 1..=4 {
            let q = curved_quad(p, Spacing::GaussLobatto, 0.1 / p as f64, 17 + p as u64);
            let c = certify_quad(p, Spacing::GaussLobatto, &q).unwrap();
            assert!(c.valid, "p={p}: {c:?}");
            assert!(
                c.min_det_lower <= c.min_det_sampled && c.min_det_lower <= c.min_det_upper,
                "p={p}: {c:?}"
            );
            assert!(
                c.min_det_upper - c.min_det_lower <= 1e-6 * c.min_det_upper,
                "{c:?}"
            );
            assert!(c.min_scaled_jacobian > 0.0 && c.min_scaled_jacobian <= 1.0);
            // a dense sampling never goes below the certified bound, and
            // the certified minimum is no higher than the dense minimum
            let fine = certify_quad_with(
                p,
                Spacing::GaussLobatto,
                &q,
                &CertifyOptions {
                    samples: 101,
                    ..Default::default()
                },
            )
            .unwrap();
            assert!(fine.min_det_sampled >= c.min_det_lower);
            assert!(c.min_det_upper <= fine.min_det_sampled + 1e-12);
            assert!(c.max_det >= 0.0);

            let h = curved_hex(p, Spacing::Equispaced, 0.06 / p as f64, 23 + p as u64);
            let c = certify_hex(p, Spacing::Equispaced, &h).unwrap();
            assert!(c.valid, "p={p}: {c:?}");
            assert!(c.min_det_lower <= c.min_det_sampled);
            // the rounding bound of this noisy p = 4 element is 2.4e-6
            // (Bernstein conversion at p = 4 amplifies by 15 per direction)
            let gap = if p == 4 { 2e-5 } else { 1e-6 };
            assert!(
                c.min_det_upper - c.min_det_lower <= gap * c.min_det_upper,
                "{c:?}"
            );
            let fine = certify_hex_with(
                p,
                Spacing::Equispaced,
                &h,
                &CertifyOptions {
                    samples: 25,
                    ..Default::default()
                },
            )
            .unwrap();
            assert!(fine.min_det_sampled >= c.min_det_lower);
        }
    }

    /// Subdivision tightens the bound: the raw coefficient minimum of a
    /// curved element is well below the true minimum, the certificate is
    /// not.
    #[test]
    fn subdivision_tightens_the_bound() {
        let q = curved_quad(3, Spacing::Equispaced, 0.06, 99);
        let b = det_j_bezier_quad(3, Spacing::Equispaced, &q).unwrap();
        let raw = b.coef_bounds().0;
        let c = certify_quad(3, Spacing::Equispaced, &q).unwrap();
        assert!(c.splits > 0);
        assert!(
            c.min_det_upper - raw > 100.0 * (c.min_det_upper - c.min_det_lower),
            "{raw} {c:?}"
        );
        let coarse = certify_quad_with(
            3,
            Spacing::Equispaced,
            &q,
            &CertifyOptions {
                max_splits: 0,
                ..Default::default()
            },
        )
        .unwrap();
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
        let c = certify_quad(2, Spacing::Equispaced, &q).unwrap();
        assert!(!c.valid);
        assert!(c.min_det_upper < -0.1, "{c:?}");
        assert!(c.min_det_lower <= c.min_det_upper);
        let fine = certify_quad_with(
            2,
            Spacing::Equispaced,
            &q,
            &CertifyOptions {
                samples: 401,
                ..Default::default()
            },
        )
        .unwrap();
        assert!(fine.min_det_sampled < -0.1 && fine.min_scaled_jacobian < 0.0);
        // the certified bracket contains the dense-sample minimum, closely
        assert!(c.min_det_lower <= fine.min_det_sampled);
        // (401² samples resolve the minimum to about 1e-4 relative)
        assert!(
            (c.min_det_upper - fine.min_det_sampled).abs() < 1e-3 * fine.min_det_sampled.abs(),
            "{c:?} {fine:?}"
        );
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
        (0..3)
            .flat_map(|k| q.iter().map(move |&[x, y]| [x, y, k as f64 * 0.5]))
            .collect()
    }

    /// A barely valid and a barely invalid element (min det J ≈ ±4e-9 of
    /// its size): translated by 1e6 and scaled by 1e-6 (2D and 3D) they
    /// get the same verdicts; the translated and the power-of-two scaled
    /// copies get identical certificates.
    #[test]
    fn verdicts_do_not_depend_on_position_or_size() {
        let step = 2f64.powi(-28);
        // bisection on multiples of 2^-28 between valid (0) and invalid (1)
        let (mut lo, mut hi) = (0u64, 1u64 << 28);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            let c = certify_quad(2, Spacing::Equispaced, &family(mid as f64 * step)).unwrap();
            if c.valid {
                lo = mid;
            } else {
                assert!(c.min_det_upper < 0.0, "undecided at {mid}: {c:?}");
                hi = mid;
            }
        }
        let valid = family(lo as f64 * step);
        let invalid = family(hi as f64 * step);
        let cv = certify_quad(2, Spacing::Equispaced, &valid).unwrap();
        let ci = certify_quad(2, Spacing::Equispaced, &invalid).unwrap();
        assert!(cv.valid && cv.min_det_lower < 1e-7, "{cv:?}");
        assert!(!ci.valid && ci.min_det_upper < 0.0 && ci.min_det_upper > -1e-7, "{ci:?}");
        for (q, base) in [(&valid, cv), (&invalid, ci)] {
            let moved: Vec<[f64; 2]> = q.iter().map(|c| c.map(|x| x + 1e6)).collect();
            assert_eq!(certify_quad(2, Spacing::Equispaced, &moved).unwrap(), base);
            let two: Vec<[f64; 2]> = q.iter().map(|c| c.map(|x| x * 2f64.powi(-20))).collect();
            let c2 = certify_quad(2, Spacing::Equispaced, &two).unwrap();
            assert_eq!(c2.min_det_lower, base.min_det_lower * 2f64.powi(-40));
            assert_eq!(c2.valid, base.valid);
            let small: Vec<[f64; 2]> = q.iter().map(|c| c.map(|x| x * 1e-6)).collect();
            let cs = certify_quad(2, Spacing::Equispaced, &small).unwrap();
            assert_eq!(cs.valid, base.valid, "{cs:?} {base:?}");
            assert_eq!(cs.min_det_upper < 0.0, base.min_det_upper < 0.0);
            let far: Vec<[f64; 2]> = small.iter().map(|c| c.map(|x| x + 1e6)).collect();
            let cf = certify_quad(2, Spacing::Equispaced, &far).unwrap();
            // 1e6 + 1e-6 x keeps only ~2e-4 of x: rounding moves the nodes,
            // the verdict may then change; it must stay a sound bracket
            assert!(cf.min_det_lower <= cf.min_det_upper, "{cf:?}");

            // the hex's search splits the w direction too, in which det J
            // is constant: it may end undecided within the split budget;
            // its bracket must agree with the quad's, wherever it lies
            let h = extruded(q);
            let ch = certify_hex(2, Spacing::Equispaced, &h).unwrap();
            assert!(ch.min_det_lower <= base.min_det_upper && ch.min_det_upper >= base.min_det_lower, "{ch:?} {base:?}");
            let hm: Vec<[f64; 3]> = h.iter().map(|c| c.map(|x| x + 1e6)).collect();
            assert_eq!(certify_hex(2, Spacing::Equispaced, &hm).unwrap(), ch);
            let hs: Vec<[f64; 3]> = h.iter().map(|c| c.map(|x| x * 1e-6)).collect();
            assert_eq!(certify_hex(2, Spacing::Equispaced, &hs).unwrap().valid, ch.valid);
        }
    }

    /// The rounding bound is small next to det J for a well-shaped element
    /// and scales with it: it leaves the certificate tight.
    #[test]
    fn rounding_bound_is_small_and_scale_free() {
        for p in 1..=4 {
            let q = curved_quad(p, Spacing::GaussLobatto, 0.05, 3);
            let conv = Conversion::new(p, Spacing::GaussLobatto).unwrap();
            let (n, _) = normalise(&q);
            let parts = DetParts::new(p, &conv, &n);
            let err = parts.error_bound(p, 2, &conv);
            let big = parts.det.coef.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            // measured 1.6e-13, 1.0e-11, 7.1e-10, 2.4e-6 (p = 4, whose
            // noisy test element has coefficients up to 50) of the hex
            assert!(err > 0.0 && err < 1e-7 * big, "p={p}: {err} vs {big}");
            let h = curved_hex(p, Spacing::Equispaced, 0.03, 5);
            let conv = Conversion::new(p, Spacing::Equispaced).unwrap();
            let (n, _) = normalise(&h);
            let parts = DetParts::new(p, &conv, &n);
            let err = parts.error_bound(p, 3, &conv);
            let big = parts.det.coef.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            assert!(err > 0.0 && err < 1e-7 * big, "p={p}: {err} vs {big}");
        }
    }

    #[test]
    fn wrong_node_count_is_an_error() {
        assert!(certify_hex(2, Spacing::Equispaced, &[[0.0; 3]; 26]).is_err());
        assert!(certify_quad(0, Spacing::Equispaced, &[[0.0; 2]; 1]).is_err());
    }
}
