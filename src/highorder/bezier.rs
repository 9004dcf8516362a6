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
        let t = nodes_1d(p, spacing)?;
        // V[i][j] = B_j(t_i): Bernstein coefficients c satisfy V c = values
        let v: Vec<Vec<f64>> = t.iter().map(|&x| bernstein(p, x)).collect();
        let inv = invert(&v);
        let mut b = Bezier {
            deg: [0; 3],
            coef: values.to_vec(),
        };
        for d in 0..dim {
            b.deg[d] = p;
        }
        for d in 0..dim {
            b = b.apply(d, &inv);
        }
        Ok(b)
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

/// The Bernstein coefficients of one coordinate of all control points.
fn component<const D: usize>(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; D]],
    r: usize,
) -> Result<Bezier, HighOrderError> {
    let v: Vec<f64> = ctrl.iter().map(|c| c[r]).collect();
    Bezier::from_lagrange(p, spacing, D, &v)
}

/// `det J` of the order-`p` quad map (control points in tensor order) on
/// `[0,1]²`, exactly, in degree `(2p−1, 2p−1)`.
pub fn det_j_bezier_quad(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; 2]],
) -> Result<Bezier, HighOrderError> {
    check_nodes(p, 2, ctrl.len())?;
    let x = component(p, spacing, ctrl, 0)?;
    let y = component(p, spacing, ctrl, 1)?;
    let (xu, xv, yu, yv) = (
        x.derivative(0),
        x.derivative(1),
        y.derivative(0),
        y.derivative(1),
    );
    Ok(xu.mul(&yv).add_scaled(-1.0, &xv.mul(&yu)))
}

/// `det J` of the order-`p` hex map (control points in tensor order) on
/// `[0,1]³`, exactly, in degree `(3p−1, 3p−1, 3p−1)`.
pub fn det_j_bezier_hex(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; 3]],
) -> Result<Bezier, HighOrderError> {
    check_nodes(p, 3, ctrl.len())?;
    let comps: Vec<Bezier> = (0..3)
        .map(|r| component(p, spacing, ctrl, r))
        .collect::<Result<_, _>>()?;
    // col[c][r] = ∂x_r/∂ξ_c
    let col: Vec<Vec<Bezier>> = (0..3)
        .map(|c| comps.iter().map(|x| x.derivative(c)).collect())
        .collect();
    let (a, b, c) = (&col[0], &col[1], &col[2]);
    // b × c, each component of degree (2p, 2p−1, 2p−1)
    let cross = |i: usize, j: usize| b[i].mul(&c[j]).add_scaled(-1.0, &b[j].mul(&c[i]));
    let bc = [cross(1, 2), cross(2, 0), cross(0, 1)];
    Ok(a[0]
        .mul(&bc[0])
        .add_scaled(1.0, &a[1].mul(&bc[1]))
        .add_scaled(1.0, &a[2].mul(&bc[2])))
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
    /// 64 ulps of the largest coefficient to cover rounding).
    pub min_det_lower: f64,
    /// A value `det J` takes on the element, so an upper bound of the true
    /// minimum: the true minimum lies in `[min_det_lower, min_det_upper]`.
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
/// `poly` over its box, a value it attains (upper bound of the minimum)
/// and the number of splits used. Best first: always split the box with
/// the smallest lower bound, in all `dim` variables at once; drop boxes
/// that cannot hold a value below `upper − tol`.
fn bound_min(poly: &Bezier, dim: usize, opts: &CertifyOptions) -> (f64, f64, usize) {
    let scale = poly.coef.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    // The floor keeps a minimum of exactly 0 from asking for infinite
    // relative precision.
    let tol = |upper: f64| opts.rel_tol * upper.abs().max(1e-9 * scale);
    // Coefficients carry rounding errors of a few ulps of the largest one;
    // the certified lower bound steps back by a safe multiple of that.
    let margin = 64.0 * f64::EPSILON * scale;
    let mut upper = poly.min_corner();
    let mut pruned = f64::INFINITY;
    let mut heap = BinaryHeap::new();
    heap.push(BoxItem {
        lower: poly.coef_bounds().0,
        poly: poly.clone(),
    });
    let mut splits = 0;
    while let Some(top) = heap.pop() {
        if top.lower >= upper - tol(upper) || splits >= opts.max_splits {
            return (top.lower.min(pruned) - margin, upper, splits);
        }
        splits += 1;
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
                heap.push(BoxItem { lower, poly: b });
            }
        }
    }
    // every box was pruned: the minimum is within tol of upper
    (pruned.min(upper) - margin, upper, splits)
}

/// Certificate of a polynomial det J plus sampled figures of the map.
fn certify<const D: usize>(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; D]],
    det: &Bezier,
    opts: &CertifyOptions,
) -> Result<Certificate, HighOrderError> {
    let (lo, up, s1) = bound_min(det, D, opts);
    let (neg_lo, _, s2) = bound_min(&det.neg(), D, opts);
    let basis = Basis1d::new(p, spacing)?;
    let m = if opts.samples >= 2 {
        opts.samples
    } else {
        3 * p + 1
    };
    let mut min_det = f64::INFINITY;
    let mut min_sj = f64::INFINITY;
    for j in jacobians_on_grid(&basis, ctrl, m) {
        min_det = min_det.min(super::basis::det(&j));
        min_sj = min_sj.min(scaled_det(&j));
    }
    Ok(Certificate {
        valid: lo > 0.0,
        min_det_lower: lo,
        min_det_upper: up.min(min_det),
        max_det: -neg_lo,
        min_det_sampled: min_det,
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
    let det = det_j_bezier_quad(p, spacing, ctrl)?;
    certify(p, spacing, ctrl, &det, opts)
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
    let det = det_j_bezier_hex(p, spacing, ctrl)?;
    certify(p, spacing, ctrl, &det, opts)
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
            assert!(
                c.min_det_upper - c.min_det_lower <= 1e-6 * c.min_det_upper,
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
        assert!(coarse.min_det_lower <= raw && coarse.min_det_lower > raw - 1e-12);
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

    #[test]
    fn wrong_node_count_is_an_error() {
        assert!(certify_hex(2, Spacing::Equispaced, &[[0.0; 3]; 26]).is_err());
        assert!(certify_quad(0, Spacing::Equispaced, &[[0.0; 2]; 1]).is_err());
    }
}
