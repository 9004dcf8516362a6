//! Bernstein (Bézier) polynomials on the prism (the unit triangle × `[0,1]`)
//! in the product basis `B_α^n(ξ, η) B_k^m(ζ)`: the triangle's basis of
//! [`super::simplex_bezier`] times the line's of [`super::bezier`]. The
//! validity certificate of curved prisms ([`crate::quality::prism`]) is
//! made of it.
//!
//! The map of an order-`p` prism lies in `P_p(triangle) ⊗ P_p(z)` and its
//! Jacobian determinant in `P_{3p−2} ⊗ P_{3p−1}`, neither a total-degree
//! space of the prism nor a tensor one of a box: hence a basis of its
//! own, of two degrees `(n, m)`. Its functions are non-negative and sum
//! to one, so the smallest and largest coefficients bound the polynomial,
//! the coefficient at a corner (`α = n e_v`, `k ∈ {0, m}`) is its value
//! there, and bisecting an edge of the triangle or halving `[0,1]` (de
//! Casteljau, per factor) tightens the bounds.
//!
//! Coefficients are stored as the prism's nodes are
//! ([`crate::mesh::element::prism`]): position `k T + t`, `t` the
//! triangle multi-index in lattice order, `T` their number, `k = 0..=m`
//! outermost.

use smallvec::smallvec;

use super::bezier::{bernstein, binom};
use super::simplex_bezier::{edges, Coef, Derivative, Lattice, Product, Split};

/// The product basis of degree `n` on the triangle and `m` along z.
#[derive(Clone, Debug)]
pub struct PrismLattice {
    tri: Lattice,
    m: usize,
}

impl PrismLattice {
    /// Degrees `n` (triangle, ≤ [`super::simplex_bezier::MAX_DEGREE`]) and
    /// `m` (z, below 24: the binomial table of [`binom`]).
    pub fn new(n: usize, m: usize) -> Self {
        assert!(m < 24, "prism Bernstein basis of degree {m} in z");
        PrismLattice { tri: Lattice::new(2, n), m }
    }

    /// The triangle factor.
    pub fn tri(&self) -> &Lattice {
        &self.tri
    }

    /// `(n, m)`: the degrees on the triangle and along z.
    pub fn deg(&self) -> (usize, usize) {
        (self.tri.deg(), self.m)
    }

    /// Number of basis functions, `(n+1)(n+2)/2 · (m+1)`.
    pub fn len(&self) -> usize {
        self.tri.len() * (self.m + 1)
    }

    /// Never: degree (0, 0) has one basis function.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The position of the coefficient at vertex `v` of the prism in
    /// [`crate::mesh::element::Shape::Prism`]'s order (`v % 3` the
    /// triangle's slot, bottom `v < 3`, top `v ≥ 3`): the value there.
    pub fn vertex(&self, v: usize) -> usize {
        let k = if v < 3 { 0 } else { self.m };
        k * self.tri.len() + self.tri.vertex(v % 3)
    }

    /// The basis functions at `x` into `out` (allocates: tests and set-up).
    pub fn basis(&self, x: [f64; 3], out: &mut [f64]) {
        let t = self.tri.len();
        let mut tri = vec![0.0; t];
        self.tri.basis([x[0], x[1], 0.0], &mut tri);
        for (k, bz) in bernstein(self.m, x[2]).into_iter().enumerate() {
            for (o, bt) in out[k * t..(k + 1) * t].iter_mut().zip(&tri) {
                *o = bt * bz;
            }
        }
    }

    /// The value at `x` of the polynomial with coefficients `coef`.
    pub fn eval(&self, coef: &[f64], x: [f64; 3]) -> f64 {
        let mut b = vec![0.0; self.len()];
        self.basis(x, &mut b);
        b.iter().zip(coef).map(|(b, c)| b * c).sum()
    }
}

/// The partial derivatives of polynomials of degree `(n, m)`, `n, m ≥ 1`:
/// along ξ and η the triangle's ([`Derivative`]) on every layer, to degree
/// `(n − 1, m)`; along ζ the line's `m (c_{k+1} − c_k)` for every triangle
/// index, to degree `(n, m − 1)`. Two roundings per coefficient either way
/// (the difference, the product by the degree).
#[derive(Clone, Debug)]
pub struct PrismDerivative {
    tri: Derivative,
    /// Triangle coefficients of degree `n` and `n − 1`.
    t: usize,
    t_low: usize,
    m: usize,
}

impl PrismDerivative {
    /// From degree `from.deg()`.
    pub fn new(from: &PrismLattice) -> Self {
        let (n, m) = from.deg();
        assert!(n >= 1 && m >= 1, "derivatives of degree ({n}, {m})");
        let low = Lattice::new(2, n - 1);
        PrismDerivative { tri: Derivative::new(&from.tri, &low), t: from.tri.len(), t_low: low.len(), m }
    }

    /// `∂/∂ξ_c` (`c` = 0, 1, 2 for ξ, η, ζ) of the polynomial with
    /// coefficients `coef`.
    pub fn apply(&self, c: usize, coef: &[f64]) -> Coef {
        if c < 2 {
            let mut out = Coef::with_capacity(self.t_low * (self.m + 1));
            for layer in coef.chunks_exact(self.t) {
                out.extend(self.tri.apply(c, layer));
            }
            out
        } else {
            let m = self.m as f64;
            (0..self.m * self.t).map(|i| m * (coef[i + self.t] - coef[i])).collect()
        }
    }
}

/// The product of two polynomials of fixed degrees, exactly in the basis
/// of the summed degrees: the triangle's weights ([`Product`]) times the
/// line's `C(m_a, i) C(m_b, j) / C(m_a + m_b, i + j)`. The weights into one
/// output coefficient are non-negative and sum to one (in each factor).
#[derive(Clone, Debug)]
pub struct PrismProduct {
    /// The triangle's terms `(i, j, o, w)`.
    tri: Vec<(u16, u16, u16, f64)>,
    /// Triangle coefficients of the operands and of the product.
    ta: usize,
    tb: usize,
    tc: usize,
    /// The line's weights by `(i, j)`, row-major `(m_a + 1) × (m_b + 1)`.
    line: Vec<f64>,
    mb: usize,
    len: usize,
    max_terms: usize,
}

impl PrismProduct {
    /// The product of degree `a.deg()` by degree `b.deg()` polynomials.
    pub fn new(a: &PrismLattice, b: &PrismLattice) -> Self {
        let c = PrismLattice::new(a.tri.deg() + b.tri.deg(), a.m + b.m);
        let tri = Product::new(&a.tri, &b.tri);
        // a binomial product below 2^53 is exact: one rounded quotient
        let line = (0..=a.m).flat_map(|i| (0..=b.m).map(move |j| binom(a.m, i) * binom(b.m, j) / binom(a.m + b.m, i + j))).collect();
        // the most pairs (i, j) with i + j = k is min(m_a, m_b) + 1
        let max_terms = tri.max_terms() * (a.m.min(b.m) + 1);
        PrismProduct {
            tri: tri.terms().map(|(i, j, o, w)| (i as u16, j as u16, o as u16, w)).collect(),
            ta: a.tri.len(),
            tb: b.tri.len(),
            tc: c.tri.len(),
            line,
            mb: b.m,
            len: c.len(),
            max_terms,
        }
    }

    /// The coefficients of the product.
    pub fn apply(&self, a: &[f64], b: &[f64]) -> Coef {
        let mut out: Coef = smallvec![0.0; self.len];
        for (ka, ra) in a.chunks_exact(self.ta).enumerate() {
            for (kb, rb) in b.chunks_exact(self.tb).enumerate() {
                let wz = self.line[ka * (self.mb + 1) + kb];
                let ro = &mut out[(ka + kb) * self.tc..(ka + kb + 1) * self.tc];
                for &(i, j, o, w) in &self.tri {
                    ro[o as usize] += w * wz * ra[i as usize] * rb[j as usize];
                }
            }
        }
        out
    }

    /// An upper bound on the roundings along any path from an operand
    /// coefficient to an output coefficient: the two weights' quotients
    /// and their product, the two products by the operands, and one per
    /// term of the sum into the output.
    pub fn roundings(&self) -> usize {
        5 + self.max_terms
    }
}

/// The two ways of cutting a piece of the prism in two: bisecting an edge
/// of the triangle on every layer ([`Split`]), or halving `[0,1]` along z
/// for every triangle index (de Casteljau at ½). Each averaging step
/// `½ (x + y)` rounds once, at most `n` (triangle) or `m` (z) per
/// coefficient, with weights summing to one; each piece keeps the
/// parent's indexing.
#[derive(Clone, Debug)]
pub struct PrismSplit {
    tri: Split,
    t: usize,
    m: usize,
    /// The triangle's second differences: positions of `β + 2e_s`, `β +
    /// e_s + e_u`, `β + 2e_u` for every `|β| = n − 2` and slots `s < u`.
    second: Vec<[u16; 3]>,
    /// The weights of [`PrismSplit::gaps`] for degree `n` and `m`.
    weight: (f64, f64),
}

/// The weight of [`PrismSplit::gaps`] for degree `n`.
fn polygon_gap(n: usize) -> f64 {
    if n < 2 {
        0.0
    } else {
        ((n / 2) * n.div_ceil(2)) as f64 / (2 * n) as f64
    }
}

impl PrismSplit {
    /// The splits of degree-`lat.deg()` polynomials.
    pub fn new(lat: &PrismLattice) -> Self {
        let n = lat.tri.deg();
        let mut second = Vec::new();
        if n >= 2 {
            let low = Lattice::new(2, n - 2);
            for i in 0..low.len() {
                let b = low.alpha(i);
                // e_0 raises the implied exponent: the stored ones stay
                let up = |s: usize, a: [usize; 3]| if s == 0 { a } else { std::array::from_fn(|d| a[d] + usize::from(d + 1 == s)) };
                for (s, u) in [(0, 1), (0, 2), (1, 2)] {
                    let at = |x: [usize; 3]| lat.tri.position(x) as u16;
                    second.push([at(up(s, up(s, b))), at(up(s, up(u, b))), at(up(u, up(u, b)))]);
                }
            }
        }
        PrismSplit { tri: Split::new(&lat.tri), t: lat.tri.len(), m: lat.m, second, weight: (polygon_gap(n), polygon_gap(lat.m)) }
    }

    /// `(triangle, z)`: the largest second difference of the coefficients
    /// across the triangle (along its three edge directions, on every
    /// layer) and along z (for every triangle index), each times
    /// `⌊n/2⌋ ⌈n/2⌉ / (2n)` for that factor's degree `n` (0 for `n ≤ 1`):
    /// a degree-`n` polynomial of one variable is within that times its
    /// largest second difference of its control polygon (Nairn, Peters &
    /// Lutterkort, CAGD 1999), taken as the estimate on the triangle's
    /// edge directions too. How far the coefficients
    /// may lie from the polynomial in each factor, so which cut tightens
    /// the bound more: halving a factor divides its second differences by
    /// about 4 and leaves the other's.
    pub fn gaps(&self, coef: &[f64]) -> (f64, f64) {
        let (t, m) = (self.t, self.m);
        let mut tri = 0.0f64;
        for layer in coef.chunks_exact(t) {
            for &[a, b, c] in &self.second {
                tri = tri.max((layer[a as usize] - 2.0 * layer[b as usize] + layer[c as usize]).abs());
            }
        }
        let mut z = 0.0f64;
        for k in 1..m {
            for s in 0..t {
                z = z.max((coef[(k - 1) * t + s] - 2.0 * coef[k * t + s] + coef[(k + 1) * t + s]).abs());
            }
        }
        (self.weight.0 * tri, self.weight.1 * z)
    }

    /// The pieces near vertex `a` and near vertex `b` of edge `e` of
    /// [`edges`]`(2)` of the triangle factor.
    pub fn tri(&self, e: usize, coef: &[f64]) -> (Coef, Coef) {
        debug_assert!(e < edges(2).len());
        let mut near_a: Coef = smallvec![0.0; coef.len()];
        let mut near_b: Coef = smallvec![0.0; coef.len()];
        for ((c, a), b) in coef.chunks_exact(self.t).zip(near_a.chunks_exact_mut(self.t)).zip(near_b.chunks_exact_mut(self.t)) {
            self.tri.apply_into(e, c, a, b);
        }
        (near_a, near_b)
    }

    /// The lower (`z ≤ ½`) and upper halves along z.
    pub fn z(&self, coef: &[f64]) -> (Coef, Coef) {
        let (t, n) = (self.t, self.m);
        let mut lower: Coef = smallvec![0.0; coef.len()];
        let mut upper: Coef = smallvec![0.0; coef.len()];
        let mut line = [0.0f64; 24];
        for s in 0..t {
            for (k, x) in line[..=n].iter_mut().enumerate() {
                *x = coef[k * t + s];
            }
            lower[s] = line[0];
            upper[n * t + s] = line[n];
            for k in 1..=n {
                for i in 0..=n - k {
                    line[i] = 0.5 * (line[i] + line[i + 1]);
                }
                lower[k * t + s] = line[0];
                upper[(n - k) * t + s] = line[n - k];
            }
        }
        (lower, upper)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A point of the prism.
    fn point(seed: &mut u64) -> [f64; 3] {
        loop {
            let x = [lcg(seed), lcg(seed), lcg(seed)];
            if x[0] + x[1] <= 1.0 {
                return x;
            }
        }
    }

    fn random(lat: &PrismLattice, seed: &mut u64) -> Coef {
        (0..lat.len()).map(|_| 2.0 * lcg(seed) - 1.0).collect()
    }

    /// The basis is a partition of unity, its corner coefficients are
    /// values, and product, derivatives and both splits are exact (against
    /// evaluation, central differences and the re-parametrised pieces).
    #[test]
    fn prism_product_derivative_and_splits_are_exact() {
        let mut seed = 17;
        let (la, lb) = (PrismLattice::new(3, 2), PrismLattice::new(2, 4));
        assert_eq!((la.len(), lb.len(), PrismLattice::new(10, 11).len()), (30, 30, 792));
        let (a, b) = (random(&la, &mut seed), random(&lb, &mut seed));
        let lab = PrismLattice::new(5, 6);
        let ab = PrismProduct::new(&la, &lb).apply(&a, &b);
        assert_eq!(ab.len(), lab.len());
        let d = PrismDerivative::new(&la);
        let (dxy, dz) = (PrismLattice::new(2, 2), PrismLattice::new(3, 1));
        let split = PrismSplit::new(&la);
        let mut basis = vec![0.0; la.len()];
        for v in 0..6 {
            let x = crate::mesh::element::Shape::Prism.vertices()[v];
            assert!((la.eval(&a, x) - a[la.vertex(v)]).abs() < 1e-15);
        }
        for _ in 0..10 {
            let x = point(&mut seed);
            la.basis(x, &mut basis);
            assert!((basis.iter().sum::<f64>() - 1.0).abs() < 1e-14 && basis.iter().all(|&v| v >= 0.0));
            assert!((lab.eval(&ab, x) - la.eval(&a, x) * lb.eval(&b, x)).abs() < 1e-13);
            for c in 0..3 {
                let h = 1e-5;
                let (mut xp, mut xm) = (x, x);
                xp[c] += h;
                xm[c] -= h;
                let fd = (la.eval(&a, xp) - la.eval(&a, xm)) / (2.0 * h);
                let lat = if c < 2 { &dxy } else { &dz };
                assert!((lat.eval(&d.apply(c, &a), x) - fd).abs() < 1e-7, "∂{c}");
            }
            // z: the lower half maps ζ ∈ [0, ½] to 2ζ, the upper one to 2ζ − 1
            let (lo, hi) = split.z(&a);
            let (piece, z) = if x[2] <= 0.5 { (lo, 2.0 * x[2]) } else { (hi, 2.0 * x[2] - 1.0) };
            assert!((la.eval(&piece, [x[0], x[1], z]) - la.eval(&a, x)).abs() < 1e-13);
            // the triangle: as simplex_bezier's own test, on every layer
            for (e, &(va, vb)) in edges(2).iter().enumerate() {
                let lam = crate::numeric::simplex_bezier::barycentric(2, x);
                let (near_a, near_b) = split.tri(e, &a);
                let mut mu = lam;
                let piece = if lam[va] >= lam[vb] {
                    mu[va] = lam[va] - lam[vb];
                    mu[vb] = 2.0 * lam[vb];
                    near_a
                } else {
                    mu[vb] = lam[vb] - lam[va];
                    mu[va] = 2.0 * lam[va];
                    near_b
                };
                assert!((la.eval(&piece, [mu[1], mu[2], x[2]]) - la.eval(&a, x)).abs() < 1e-13);
            }
        }
    }

    /// The gaps see curvature only where it is: a polynomial of z alone
    /// has no gap across the triangle and the 1-D one along z (degree 2:
    /// `¼ |Δ²|`), one of (ξ, η) alone none along z, and a factor of degree
    /// ≤ 1 none at all.
    #[test]
    fn gaps_see_each_factors_curvature() {
        let mut seed = 5;
        let lat = PrismLattice::new(3, 2);
        let split = PrismSplit::new(&lat);
        let t = lat.tri().len();
        let z_only: Coef = (0..lat.len()).map(|i| [1.0, -0.5, 2.0][i / t]).collect();
        assert_eq!(split.gaps(&z_only), (0.0, 0.25 * 4.0));
        let layer: Vec<f64> = (0..t).map(|_| lcg(&mut seed)).collect();
        let tri_only: Coef = (0..lat.len()).map(|i| layer[i % t]).collect();
        let (gt, gz) = split.gaps(&tri_only);
        assert!(gt > 0.0 && gz == 0.0, "{gt} {gz}");
        let linear = PrismLattice::new(1, 1);
        assert_eq!(PrismSplit::new(&linear).gaps(&random(&linear, &mut seed)), (0.0, 0.0));
    }
}
