//! The validity certificate of a curved pyramid of order `p = 1..=4` in
//! Gmsh's rational space ([`crate::mesh::element::pyramid`]): the pyramid
//! counterpart of [`super::certify`], with the same [`Certificate`],
//! [`CertifyOptions`], branch and bound and rounding argument.
//!
//! **det J is a polynomial in the collapsed cube.** With `x = a (1 − c) +
//! c/2`, `y = b (1 − c) + c/2`, `z = c`, every function of the space is
//! `Σ C_f α^i β^j (1 − c)^{max(i,j)} γ^k` (`α = 2a − 1`, `β = 2b − 1`, `γ =
//! 2c − 1`), so `∂X/∂x = (∂X/∂a)/(1 − c)` and `∂X/∂y = (∂X/∂b)/(1 − c)` are
//! polynomials (each term with `i ≥ 1` carries `(1 − c)^{m−1}`, `m =
//! max(i, j) ≥ 1`), of degrees `(p−1, p, p−1)` and `(p, p−1, p−1)` in `(a,
//! b, c)`; and `∂X/∂z = ∂X/∂c + (a − ½) ∂X/∂x + (b − ½) ∂X/∂y`. The
//! determinant is multilinear, so **det J = det[∂X/∂x, ∂X/∂y, ∂X/∂c]**,
//! `∂X/∂c` of degree `(p, p, p−1)`: det J lies in `Q_{3p−1, 3p−1, 3p−3}`
//! of the cube, and its Bernstein coefficients there bound it over the
//! pyramid (the cube's top face is the apex, where the limit values of
//! det J along the rays into it are the face's values). The test
//! `det_j_is_a_polynomial_of_those_degrees` checks the degrees.
//!
//! **Coefficients.** The node coordinates go to the spanning coefficients
//! `C = inv · x` ([`PyramidSpace::inv`]), and from `C` to each column's
//! tensor Bernstein coefficients by matrices computed once in exact
//! rational arithmetic and rounded once (the Bernstein coefficients of
//! `α^i`, `(1 − c)^μ γ^κ`, …); the products of [`super::certify`] make
//! det J. The rounding bound follows [`super::certify`]'s `error_bound`:
//! the computed `inv` is `(I + R) V⁻¹` with `‖R‖∞ ≤ ρ` bounded once
//! (`V`'s entries recomputed, their own rounding counted), so `C` errs by
//! `γ_{N+1} ‖inv‖ max|x| + ρ/(1 − ρ) (max|C| + …)`; the column
//! coefficients by `‖E‖∞` times that plus `γ_{N+2} ‖E‖∞ max|C|`; and the
//! products as for hexes.
//!
//! **Units.** det J is with respect to our reference pyramid (base
//! `[0,1]²`, apex `(½, ½, 1)`); Gmsh's has the base `[−1,1]²`, so its
//! det J (`minDetJac`) is a quarter of ours.
//!
//! **Scaled Jacobian.** Sampled, `det J / (|x_x| |x_y| |x_z|)` (the
//! hex's measure): 1 for a right pyramid on a square at every point, at
//! any height. Samples run over the cube with `c < 1`.

use super::certify::{bound_min, brackets, det3, gamma, normalise, Certificate, CertifyOptions, Goal, U};
use crate::mesh::element::basis::{det, scaled_det};
use crate::mesh::element::pyramid::{self, PyramidSpace};
use crate::mesh::element::{HighOrderError, Spacing};
use crate::numeric::bezier::Bezier;

/// An exact rational `n / d`, `d > 0`, in lowest terms.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Q(i128, i128);

fn gcd(a: i128, b: i128) -> i128 {
    if b == 0 { a.abs().max(1) } else { gcd(b, a % b) }
}

impl Q {
    fn new(n: i128, d: i128) -> Q {
        let g = gcd(n, d) * d.signum();
        Q(n / g, d / g)
    }
    fn add(self, o: Q) -> Q {
        Q::new(self.0 * o.1 + o.0 * self.1, self.1 * o.1)
    }
    fn mul(self, o: Q) -> Q {
        Q::new(self.0 * o.0, self.1 * o.1)
    }
    /// The nearest `f64` (numerator and denominator are small: exact, and
    /// one rounding in the quotient).
    fn to_f64(self) -> f64 {
        self.0 as f64 / self.1 as f64
    }
}

/// The product of two polynomials given by their monomial coefficients.
fn poly_mul(a: &[i128], b: &[i128]) -> Vec<i128> {
    let mut out = vec![0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

/// `(c0 + c1 t)^r`.
fn pow_lin(c0: i128, c1: i128, r: usize) -> Vec<i128> {
    (0..r).fold(vec![1], |acc, _| poly_mul(&acc, &[c0, c1]))
}

/// `C(n, k)`, 0 for `k > n`.
fn binom(n: usize, k: usize) -> i128 {
    if k > n {
        return 0;
    }
    (0..k).fold(1i128, |acc, i| acc * (n - i) as i128 / (i + 1) as i128)
}

/// The degree-`n` Bernstein coefficients of `Σ_q d_q t^q`: `Σ_q d_q
/// C(l, q) / C(n, q)` at `l` (the monomial `t^q` has these).
fn to_bernstein(d: &[i128], n: usize) -> Vec<Q> {
    assert!(d.len() <= n + 1 || d[n + 1..].iter().all(|&x| x == 0), "degree above {n}");
    (0..=n).map(|l| d.iter().enumerate().take(n + 1).fold(Q(0, 1), |s, (q, &dq)| s.add(Q::new(dq * binom(l, q), binom(n, q))))).collect()
}

/// One column of J as a linear map of the spanning coefficients: its
/// degrees and `e[row][f]`, row a tensor Bernstein index (first variable
/// fastest).
struct Column {
    deg: [usize; 3],
    e: Vec<Vec<f64>>,
}

impl Column {
    /// The column whose spanning function `f` has, per variable, the
    /// monomial coefficients `factors(f)` (each of degree ≤ `deg`), all
    /// scaled by the integer `factors(f).3`.
    fn new(span: &[[usize; 3]], deg: [usize; 3], factors: impl Fn([usize; 3]) -> Option<[Vec<i128>; 3]>) -> Column {
        let rows = deg.iter().map(|n| n + 1).product();
        let mut e = vec![vec![0.0; span.len()]; rows];
        for (f, &exps) in span.iter().enumerate() {
            let Some(fs) = factors(exps) else { continue };
            let b: [Vec<Q>; 3] = std::array::from_fn(|v| to_bernstein(&fs[v], deg[v]));
            for l2 in 0..=deg[2] {
                for l1 in 0..=deg[1] {
                    for l0 in 0..=deg[0] {
                        let row = l0 + (deg[0] + 1) * (l1 + (deg[1] + 1) * l2);
                        e[row][f] = b[0][l0].mul(b[1][l1]).mul(b[2][l2]).to_f64();
                    }
                }
            }
        }
        Column { deg, e }
    }

    /// The column's coefficients for spanning coefficients `c`.
    fn apply(&self, c: &[f64]) -> Bezier {
        Bezier { deg: self.deg, coef: self.e.iter().map(|row| row.iter().zip(c).map(|(e, x)| e * x).sum()).collect() }
    }

    /// `‖e‖∞`.
    fn norm(&self) -> f64 {
        self.e.iter().map(|r| r.iter().map(|x| x.abs()).sum::<f64>()).fold(0.0, f64::max)
    }
}

/// `2t − 1` and `1 − t` as monomial coefficients, to powers.
fn centred(r: usize) -> Vec<i128> {
    pow_lin(-1, 2, r)
}
fn falling(r: usize) -> Vec<i128> {
    pow_lin(1, -1, r)
}

/// `s · v`.
fn scaled(s: i128, v: Vec<i128>) -> Vec<i128> {
    v.into_iter().map(|x| s * x).collect()
}

/// The certificate's set-up for one order and node set, made once per
/// mesh: the three columns' matrices and the bound on the basis' inverse.
pub struct PyramidCertifier {
    p: usize,
    space: &'static PyramidSpace,
    /// `∂X/∂x`, `∂X/∂y`, `∂X/∂c` from the spanning coefficients.
    cols: [Column; 3],
    /// `‖inv‖∞`.
    inv_norm: f64,
    /// `‖inv V − I‖∞` for the exact `V`, bounded.
    rho: f64,
    /// The largest `‖e‖∞` of the columns.
    e_norm: f64,
}

impl PyramidCertifier {
    /// For order-`p` pyramids with nodes at `spacing`.
    pub fn new(p: usize, spacing: Spacing) -> Result<Self, HighOrderError> {
        let space = pyramid::space(p, spacing)?;
        let span = &space.span;
        let a = Column::new(span, [p - 1, p, p - 1], |[i, j, k]| {
            let m = i.max(j);
            (i > 0).then(|| [scaled(2 * i as i128, centred(i - 1)), centred(j), poly_mul(&falling(m - 1), &centred(k))])
        });
        let b = Column::new(span, [p, p - 1, p - 1], |[i, j, k]| {
            let m = i.max(j);
            (j > 0).then(|| [centred(i), scaled(2 * j as i128, centred(j - 1)), poly_mul(&falling(m - 1), &centred(k))])
        });
        let c = Column::new(span, [p, p, p - 1], |[i, j, k]| {
            let m = i.max(j);
            // 2k γ^{k−1} (1 − c)^m − m (1 − c)^{m−1} γ^k
            let up = if k > 0 { scaled(2 * k as i128, poly_mul(&centred(k - 1), &falling(m))) } else { vec![0] };
            let down = if m > 0 { scaled(-(m as i128), poly_mul(&falling(m - 1), &centred(k))) } else { vec![0] };
            let len = up.len().max(down.len());
            let sum: Vec<i128> = (0..len).map(|q| up.get(q).copied().unwrap_or(0) + down.get(q).copied().unwrap_or(0)).collect();
            Some([centred(i), centred(j), sum])
        });
        let (inv_norm, rho) = residual(space);
        let e_norm = [&a, &b, &c].iter().map(|c| c.norm()).fold(0.0, f64::max);
        Ok(PyramidCertifier { p, space, cols: [a, b, c], inv_norm, rho, e_norm })
    }

    /// `det J` of the normalised element (Bernstein form), its rounding
    /// bound, the columns, and the scale `s` of [`normalise`].
    fn det_j<const D: usize>(&self, ctrl: &[[f64; D]]) -> (Bezier, f64, [[Bezier; 3]; 3], f64) {
        assert!(D == 3 && ctrl.len() == self.space.num_nodes(), "an order-{} pyramid has {} nodes", self.p, self.space.num_nodes());
        let (centre, s) = normalise(ctrl);
        let n = ctrl.len();
        let xs: [Vec<f64>; 3] = std::array::from_fn(|r| ctrl.iter().map(|x| (x[r] - centre[r]) / s).collect());
        let input_max = xs.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let coef: [Vec<f64>; 3] = std::array::from_fn(|r| self.space.inv.iter().map(|row| row.iter().zip(&xs[r]).map(|(w, x)| w * x).sum()).collect());
        let c_max = coef.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        // col[c][r] = ∂x_r/∂(x, y, c)_c
        let col: [[Bezier; 3]; 3] = std::array::from_fn(|c| std::array::from_fn(|r| self.cols[c].apply(&coef[r])));
        let abs = col.each_ref().map(|c| c.each_ref().map(Bezier::abs));
        let (det, det_abs, k) = det3(&col, &abs);
        // the spanning coefficients: the centring (U), the n-term products
        // with the computed inverse, and that inverse's distance from V⁻¹
        let round_c = gamma(n + 1) * self.inv_norm * input_max;
        let err_c = round_c + self.rho / (1.0 - self.rho) * (c_max + round_c);
        // the columns: the error of C through E, the rounding of E (one U
        // per entry) and of its n-term products
        let delta = self.e_norm * (err_c + gamma(n + 2) * c_max);
        let m = col.iter().flatten().map(Bezier::max_abs).fold(0.0, f64::max);
        let g = gamma(k);
        let err = (g / (1.0 - g) * det_abs.max_abs() + 6.0 * ((m + delta).powi(3) - m.powi(3))) * (1.0 + 16.0 * U);
        (det, err, col, s)
    }

    /// Whether `det J > 0` on the whole element (control points in the
    /// pyramid's lattice order), decided conservatively as
    /// [`super::certify::Certifier::is_valid`].
    ///
    /// # Panics
    /// If `D` is not 3 or `ctrl` has the wrong length.
    pub fn is_valid<const D: usize>(&self, ctrl: &[[f64; D]]) -> bool {
        if !ctrl.iter().flatten().all(|x| x.is_finite()) {
            return false;
        }
        let (det, err, _, _) = self.det_j(ctrl);
        bound_min(&det, 3, err, Goal::Sign).0 > 0.0
    }

    /// The certificate: the bracket of `min det J` and a bound of `max det
    /// J` (units of our reference pyramid), the sampled minima of det J
    /// and of the scaled Jacobian on `opts.samples` points per direction of
    /// the collapsed cube, `c < 1` (`0`: `3p + 1`).
    ///
    /// # Panics
    /// If `D` is not 3 or `ctrl` has the wrong length.
    pub fn certify<const D: usize>(&self, ctrl: &[[f64; D]], opts: &CertifyOptions) -> Certificate {
        let (det_j, err, col, s) = self.det_j(ctrl);
        let (min, neg, splits) = brackets(&det_j, &det_j.neg(), err, opts, |c, e, g| bound_min(c, 3, e, g));
        let (mut min_det, mut min_sj) = (f64::INFINITY, f64::INFINITY);
        for [a, b, c] in sample_points(opts.sample_count(self.p)) {
            let at = |k: usize, r: usize| col[k][r].eval([a, b, c]);
            // columns ∂x/∂x, ∂x/∂y and ∂x/∂z = ∂x/∂c + (a − ½) ∂x/∂x + (b − ½) ∂x/∂y
            let j: [[f64; 3]; 3] = std::array::from_fn(|r| {
                let (xx, xy) = (at(0, r), at(1, r));
                [xx, xy, at(2, r) + (a - 0.5) * xx + (b - 0.5) * xy]
            });
            min_det = min_det.min(det(&j));
            min_sj = min_sj.min(scaled_det(&j));
        }
        Certificate::of_normalised(3, s, min, neg, (min_det, min_sj), splits)
    }
}

/// The sample points `(a, b, c)` of the collapsed cube: `m` per direction,
/// `a` and `b` from 0 to 1, `c` from 0 up to `(m − 1)/m` (the apex, where
/// J has no single value, left out).
fn sample_points(m: usize) -> impl Iterator<Item = [f64; 3]> {
    let t = move |i: usize| i as f64 / (m - 1) as f64;
    (0..m).flat_map(move |k| (0..m).flat_map(move |j| (0..m).map(move |i| [t(i), t(j), k as f64 / m as f64])))
}

/// `(‖inv‖∞, ρ)`: `ρ` bounds `‖inv V − I‖∞` for the exact `V[n][f] =
/// φ_f(x_n)` at the stored nodes: the computed residual, plus the rounding
/// of its sums and of `V`'s entries (the collapse, the centring, four
/// powers of at most `p` factors and their product: fewer than `4p + 12`
/// roundings), both within `γ_{4p+12+N} |inv||V|`, as in
/// [`super::certify`]'s `Conversion`.
fn residual(space: &PyramidSpace) -> (f64, f64) {
    let n = space.num_nodes();
    let v: Vec<Vec<f64>> = space.nodes.iter().map(|&x| space.span.iter().map(|&f| pyramid::spanning_eval(f, pyramid::collapse(x)).0).collect()).collect();
    let g = gamma(4 * space.p + 12 + n);
    let mut rho = 0.0f64;
    for (f, row) in space.inv.iter().enumerate() {
        let mut sum = 0.0;
        for h in 0..n {
            let r: f64 = (0..n).map(|k| row[k] * v[k][h]).sum::<f64>() - f64::from(u8::from(f == h));
            let a: f64 = (0..n).map(|k| (row[k] * v[k][h]).abs()).sum();
            sum += r.abs() + g * a;
        }
        rho = rho.max(sum);
    }
    let inv_norm = space.inv.iter().map(|r| r.iter().map(|x| x.abs()).sum::<f64>()).fold(0.0, f64::max);
    (inv_norm, rho * (1.0 + 4.0 * U))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quality::tests::lcg;


    /// The reference nodes through an affine map `M x + t` and a bend,
    /// plus noise of amplitude `amp`.
    fn curved(p: usize, spacing: Spacing, amp: f64, bend: f64, seed: u64) -> Vec<[f64; 3]> {
        let mut s = seed;
        pyramid::space(p, spacing)
            .unwrap()
            .nodes
            .iter()
            .map(|&[x, y, z]| {
                [1.2 * x + 0.2 * y + bend * z * z + amp * lcg(&mut s), 0.1 * x + 0.9 * y + bend * x * z + amp * lcg(&mut s), 0.8 * z + bend * (x * y) + amp * lcg(&mut s)]
            })
            .collect()
    }

    /// det J of the map through `ctrl` at reference point `ξ`, from the
    /// basis (independent of the certificate's columns).
    fn det_at(space: &PyramidSpace, ctrl: &[[f64; 3]], xi: [f64; 3]) -> f64 {
        let n = space.num_nodes();
        let (mut v, mut g) = (vec![0.0; n], vec![[0.0; 3]; n]);
        space.eval(xi, &mut v, &mut g);
        let j: [[f64; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| ctrl.iter().zip(&g).map(|(x, d)| x[r] * d[c]).sum()));
        det(&j)
    }

    /// Dense samples of det J over the pyramid (collapsed cube, c < 1).
    fn sampled_min(space: &PyramidSpace, ctrl: &[[f64; 3]], m: usize) -> f64 {
        let mut min = f64::INFINITY;
        for k in 0..m {
            let c = k as f64 / m as f64;
            for j in 0..=m {
                for i in 0..=m {
                    let (a, b) = (i as f64 / m as f64, j as f64 / m as f64);
                    min = min.min(det_at(space, ctrl, [a * (1.0 - c) + 0.5 * c, b * (1.0 - c) + 0.5 * c, c]));
                }
            }
        }
        min
    }

    /// det J of random curved pyramids, from the basis, is a polynomial
    /// of degree (3p−2, 3p−2, 3p−3) in the collapsed cube: its Bernstein
    /// form (degree (3p−1, 3p−1, 3p−3)) from the certificate's columns
    /// takes the basis' values at random points, and differences of the
    /// next degree along each variable vanish while those of the degree
    /// itself do not.
    #[test]
    fn det_j_is_a_polynomial_of_those_degrees() {
        for p in 1..=4 {
            let cert = PyramidCertifier::new(p, Spacing::Equispaced).unwrap();
            let ctrl = curved(p, Spacing::Equispaced, 0.02, 0.15, p as u64);
            let space = cert.space;
            let (det_b, _, _, s) = cert.det_j(&ctrl);
            assert_eq!(det_b.deg, [3 * p - 1, 3 * p - 1, 3 * p - 3]);
            let mut seed = 7;
            for _ in 0..20 {
                let [a, b, c] = [0.5 + 0.5 * lcg(&mut seed), 0.5 + 0.5 * lcg(&mut seed), 0.45 + 0.45 * lcg(&mut seed)];
                let want = det_at(space, &ctrl, [a * (1.0 - c) + 0.5 * c, b * (1.0 - c) + 0.5 * c, c]);
                let got = det_b.eval([a, b, c]) * s * s * s;
                assert!((got - want).abs() < 1e-11 * want.abs().max(1.0), "p = {p}: {got} vs {want}");
            }
            // finite differences along each collapsed variable
            let f = |x: [f64; 3]| det_at(space, &ctrl, [x[0] * (1.0 - x[2]) + 0.5 * x[2], x[1] * (1.0 - x[2]) + 0.5 * x[2], x[2]]);
            // the degrees attained: 3p − 2 in a and b (the top terms of
            // ∂X/∂x and ∂X/∂c in a are parallel), 3p − 3 in c
            let attained = [3 * p - 2, 3 * p - 2, 3 * p - 3];
            for (v, &n) in attained.iter().enumerate() {
                let diff = |order: usize| {
                    let h = 0.8 / order as f64;
                    (0..=order)
                        .map(|q| {
                            let mut x = [0.1, 0.15, 0.05];
                            x[v] += q as f64 * h;
                            let sign = if (order - q).is_multiple_of(2) { 1.0 } else { -1.0 };
                            sign * binom(order, q) as f64 * f(x)
                        })
                        .sum::<f64>()
                };
                assert!(diff(n + 1).abs() < 1e-10, "p = {p}: variable {v} has degree above {n}: {:e}", diff(n + 1));
                if n > 0 {
                    assert!(diff(n).abs() > 1e-6, "p = {p}: variable {v} of degree below {n}: {:e}", diff(n));
                }
            }
        }
    }

    /// On random curved pyramids, valid and invalid, p = 1..4, both
    /// spacings: the bracket holds the dense sampled minimum, a valid
    /// verdict has no sample ≤ 0 and a sample < 0 no valid verdict; the
    /// same verdicts translated by 1e6 and scaled by 1e-6.
    #[test]
    fn the_certificate_agrees_with_dense_sampling() {
        let opts = CertifyOptions::default();
        let (mut valid, mut invalid) = (0, 0);
        for p in 1..=4 {
            for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
                let cert = PyramidCertifier::new(p, spacing).unwrap();
                for trial in 0..12 {
                    let amp = [0.0, 0.03, 0.08, 0.15][trial % 4];
                    let ctrl = curved(p, spacing, amp, 0.1 * (trial % 3) as f64, (100 * p + trial) as u64);
                    let c = cert.certify(&ctrl, &opts);
                    let sampled = sampled_min(cert.space, &ctrl, 12);
                    assert!(c.min_det_lower <= sampled * (1.0 + 1e-12) + 1e-14, "p = {p} trial {trial}: lower {} above sampled {sampled}", c.min_det_lower);
                    assert!(c.min_det_upper >= c.min_det_lower);
                    if c.valid {
                        assert!(sampled > 0.0, "p = {p} trial {trial}: valid, sampled {sampled}");
                        valid += 1;
                    }
                    if sampled < 0.0 {
                        assert!(!c.valid && !cert.is_valid(&ctrl));
                        invalid += 1;
                    }
                    assert_eq!(cert.is_valid(&ctrl), c.valid, "p = {p} trial {trial}");
                    let moved: Vec<[f64; 3]> = ctrl.iter().map(|x| x.map(|v| v + 1e6)).collect();
                    let small: Vec<[f64; 3]> = ctrl.iter().map(|x| x.map(|v| v * 1e-6)).collect();
                    assert_eq!(cert.is_valid(&small), c.valid, "p = {p} trial {trial}: scaled");
                    if c.valid && c.min_det_lower > 1e-6 * c.max_det {
                        assert!(cert.is_valid(&moved), "p = {p} trial {trial}: translated");
                    }
                }
            }
        }
        assert!(valid > 40 && invalid > 10, "{valid} valid, {invalid} invalid");
    }

    /// An affine pyramid has det J = det M everywhere: the bracket is
    /// tight; the reference one has scaled Jacobian 1.
    #[test]
    fn affine_pyramids_have_their_exact_det() {
        let opts = CertifyOptions::default();
        for p in 1..=4 {
            let cert = PyramidCertifier::new(p, Spacing::GaussLobatto).unwrap();
            let m = [[1.3, 0.2, -0.1], [0.1, 0.7, 0.3], [0.0, 0.2, 2.0]];
            let ctrl: Vec<[f64; 3]> = cert.space.nodes.iter().map(|x| std::array::from_fn(|r| (0..3).map(|c| m[r][c] * x[c]).sum::<f64>() + 5.0)).collect();
            let c = cert.certify(&ctrl, &opts);
            let want = det(&m);
            // the rounding bound: ρ of the spanning basis' inverse (1e-13 at
            // p = 2, 2e-11 at p = 4) through the columns and their products:
            // 3e-12, 2e-10, 7e-9, 2e-7 of det J at p = 1..4
            let slack = [1e-11, 1e-9, 1e-8, 1e-6][p - 1];
            assert!((c.min_det_lower - want).abs() < slack * want && (c.max_det - want).abs() < slack * want, "p = {p}: {c:?} vs {want}");
            eprintln!("affine pyramid p = {p}: bracket [{:.3e}, {:.3e}] relative to det M", c.min_det_lower / want - 1.0, c.max_det / want - 1.0);
            let c = cert.certify(&cert.space.nodes, &opts);
            assert!((c.min_scaled_jacobian - 1.0).abs() < 1e-12 && c.valid, "p = {p}: {c:?}");
        }
    }

    /// A linear pyramid over the unit square with base corner 2 lifted by
    /// `h` (a twisted base), apex (½, ½, 1): by hand, `A = (1, 0, b h)`, `B
    /// = (0, 1, a h)`, `X_c = (½ − a, ½ − b, 1 − a b h)`, so det J = 1 − (h/2)
    /// (a + b − 2ab), at every height: least, `1 − h/2`, at the base corners
    /// 1 and 3, largest, 1, at 0 and 2. Bracketed tightly; folded past h =
    /// 2, and said so.
    #[test]
    fn a_twisted_linear_pyramid_is_bracketed() {
        let opts = CertifyOptions::default();
        let cert = PyramidCertifier::new(1, Spacing::Equispaced).unwrap();
        for h in [0.5, 1.5, 1.99, 2.5] {
            // lattice order of p = 1: corners 0, 1, 3, 2, then the apex
            let ctrl = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, h], [0.5, 0.5, 1.0]];
            let c = cert.certify(&ctrl, &opts);
            let least = 1.0 - 0.5 * h;
            assert!(c.min_det_lower <= least && least <= c.min_det_upper, "h = {h}: {c:?}");
            assert!(c.min_det_upper - c.min_det_lower < 1e-3 * least.abs() + 1e-12, "h = {h}: {c:?}");
            assert!(c.max_det >= 1.0 && c.max_det < 1.0 + 1e-10, "h = {h}: {c:?}");
            assert_eq!((c.valid, cert.is_valid(&ctrl)), (least > 0.0, least > 0.0), "h = {h}");
        }
    }
}
