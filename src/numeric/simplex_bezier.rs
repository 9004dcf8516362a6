//! Bernstein (Bézier) polynomials on the unit triangle and tetrahedron:
//! the simplex counterpart of [`super::bezier`], of which the simplex
//! validity certificate ([`crate::quality::simplex`]) is made.
//!
//! On the simplex with barycentric coordinates `λ_0 = 1 − Σ ξ_c`,
//! `λ_c = ξ_c`, the degree-`n` Bernstein polynomials are
//! `B_α = n!/(α_0! … α_d!) Π λ_s^{α_s}` over the multi-indices `|α| = n`.
//! They are non-negative and sum to one, so the smallest and largest
//! coefficients bound the polynomial, the coefficient at a vertex (`α =
//! n e_v`) is its value there, and de Casteljau bisection of an edge
//! tightens the bounds quadratically in the size of the pieces.
//!
//! A multi-index is stored by its exponents `(α_1, …, α_d)` of `ξ_1, …, ξ_d`
//! (`α_0` is implied), in *lattice order*: the last exponent outermost, the
//! first fastest (triangle: `for j { for i }`, tetrahedron: `for k { for j
//! { for i } }`), the order of an element's equispaced nodes `α / n`.

use smallvec::{smallvec, SmallVec};

/// Coefficients: inline up to 36, the coordinates of any element of order
/// ≤ 4 and det J of every triangle; a tetrahedron's det J of order ≥ 3 (84
/// or 220 coefficients) goes to the heap.
pub type Coef = SmallVec<[f64; 36]>;

/// The largest degree supported: multinomials up to `20!` are exact
/// integers in `u64` and the weights of a product exact quotients; det J of
/// a p = 4 tetrahedron has degree 9.
pub const MAX_DEGREE: usize = 20;

/// The edges of the triangle (`dim` 2) or tetrahedron (`dim` 3) as pairs
/// of barycentric slots (slot 0 is the vertex at the origin, slot `c` the
/// one at `e_c`).
pub fn edges(dim: usize) -> &'static [(usize, usize)] {
    match dim {
        2 => &[(0, 1), (0, 2), (1, 2)],
        3 => &[(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)],
        _ => unreachable!("simplices here are triangles and tetrahedra"),
    }
}

/// The exponents `(α_1, α_2, α_3)` (unused ones 0) of the multi-indices of
/// degree ≤ `deg` in `dim` variables, in lattice order. Allocation-free:
/// the sampling loops use it per element.
pub fn multi_indices(dim: usize, deg: usize) -> impl Iterator<Item = [usize; 3]> {
    let ext = |d: usize| if d < dim { deg + 1 } else { 1 };
    let (e0, e1, e2) = (ext(0), ext(1), ext(2));
    (0..e0 * e1 * e2).map(move |t| [t % e0, t / e0 % e1, t / (e0 * e1)]).filter(move |a| a.iter().sum::<usize>() <= deg)
}

/// `n! / Π k_s!`, exact.
fn multinomial(n: usize, k: &[usize]) -> u64 {
    let fact = |m: usize| (1..=m as u64).product::<u64>();
    k.iter().fold(fact(n), |acc, &ks| acc / fact(ks))
}

/// The Bernstein basis of one degree on the `dim`-simplex: its
/// multi-indices, their multinomial coefficients, and the position of a
/// multi-index in lattice order.
#[derive(Clone, Debug)]
pub struct Lattice {
    dim: usize,
    deg: usize,
    alpha: Vec<[usize; 3]>,
    multinomial: Vec<f64>,
    /// `position` by `α_1 + (deg+1) (α_2 + (deg+1) α_3)`.
    lookup: Vec<usize>,
}

impl Lattice {
    /// The `C(deg + dim, dim)` multi-indices of degree `deg` (`dim` 2 or 3).
    pub fn new(dim: usize, deg: usize) -> Self {
        assert!((2..=3).contains(&dim) && deg <= MAX_DEGREE, "simplex Bernstein basis of dimension {dim}, degree {deg}");
        let alpha: Vec<[usize; 3]> = multi_indices(dim, deg).collect();
        let mut lattice = Lattice { dim, deg, alpha: Vec::new(), multinomial: Vec::new(), lookup: vec![usize::MAX; (deg + 1).pow(3)] };
        for (i, a) in alpha.iter().enumerate() {
            let key = lattice.key(*a);
            lattice.lookup[key] = i;
        }
        lattice.multinomial = (0..alpha.len()).map(|i| multinomial(deg, &full(deg, alpha[i])) as f64).collect();
        lattice.alpha = alpha;
        lattice
    }

    fn key(&self, a: [usize; 3]) -> usize {
        let n = self.deg + 1;
        a[0] + n * (a[1] + n * a[2])
    }

    /// Dimension of the simplex.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Degree of the basis.
    pub fn deg(&self) -> usize {
        self.deg
    }

    /// Number of basis functions, `C(deg + dim, dim)`.
    pub fn len(&self) -> usize {
        self.alpha.len()
    }

    /// Never: degree 0 has one basis function.
    pub fn is_empty(&self) -> bool {
        self.alpha.is_empty()
    }

    /// The exponents `(α_1, α_2, α_3)` of basis function `i`.
    pub fn alpha(&self, i: usize) -> [usize; 3] {
        self.alpha[i]
    }

    /// The multinomial `n! / Π α_s!` of basis function `i` (exact).
    pub fn multinomial(&self, i: usize) -> f64 {
        self.multinomial[i]
    }

    /// The position of exponents `a` in lattice order.
    ///
    /// # Panics
    /// If `a` is not a multi-index of this degree and dimension.
    pub fn position(&self, a: [usize; 3]) -> usize {
        let i = if a.iter().sum::<usize>() <= self.deg && a[self.dim..].iter().all(|&x| x == 0) { self.lookup[self.key(a)] } else { usize::MAX };
        assert!(i != usize::MAX, "{a:?} is not a multi-index of degree {} in {}D", self.deg, self.dim);
        i
    }

    /// The position of the coefficient at vertex `v` (slot 0: the origin;
    /// slot `c`: `e_c`), the polynomial's value there.
    pub fn vertex(&self, v: usize) -> usize {
        let mut a = [0; 3];
        if v > 0 {
            a[v - 1] = self.deg;
        }
        self.position(a)
    }

    /// The basis functions at `x` (unused coordinates ignored) into `out`.
    /// `λ_0 = ((1 − x_1) − x_2) − x_3` and each basis function is its
    /// multinomial times `deg` factors λ, multiplied in turn: the rounding
    /// the conversion of [`crate::quality::simplex`] bounds.
    pub fn basis(&self, x: [f64; 3], out: &mut [f64]) {
        let lambda = barycentric(self.dim, x);
        for (i, (a, o)) in self.alpha.iter().zip(out.iter_mut()).enumerate() {
            let mut v = self.multinomial[i];
            for (s, &e) in full(self.deg, *a).iter().enumerate() {
                for _ in 0..e {
                    v *= lambda[s];
                }
            }
            *o = v;
        }
    }

    /// The value at `x` of the polynomial with coefficients `coef`.
    pub fn eval(&self, coef: &[f64], x: [f64; 3]) -> f64 {
        let mut b: Coef = smallvec![0.0; self.len()];
        self.basis(x, &mut b);
        b.iter().zip(coef).map(|(b, c)| b * c).sum()
    }
}

/// `(λ_0, λ_1, λ_2, λ_3)` of `x` in `dim` dimensions (unused ones 0).
pub fn barycentric(dim: usize, x: [f64; 3]) -> [f64; 4] {
    let mut lambda = [0.0; 4];
    lambda[0] = x[..dim].iter().fold(1.0, |l, &xc| l - xc);
    lambda[1..=dim].copy_from_slice(&x[..dim]);
    lambda
}

/// The full barycentric exponents `(α_0, α_1, α_2, α_3)` of exponents `a`
/// of degree `deg`.
fn full(deg: usize, a: [usize; 3]) -> [usize; 4] {
    [deg - a.iter().sum::<usize>(), a[0], a[1], a[2]]
}

/// `(min, max)` of the coefficients: bounds of the polynomial on its
/// simplex.
pub fn coef_bounds(coef: &[f64]) -> (f64, f64) {
    coef.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &c| (lo.min(c), hi.max(c)))
}

/// The largest absolute coefficient.
pub fn max_abs(coef: &[f64]) -> f64 {
    coef.iter().fold(0.0f64, |m, c| m.max(c.abs()))
}

/// The partial derivatives of degree-`n` polynomials:
/// `∂/∂ξ_c Σ b_α B_α^n = n Σ_β (b_{β + e_c} − b_β) B_β^{n−1}` (the
/// derivative along `ξ_c` is `∂/∂λ_c − ∂/∂λ_0`, and raising `α_0` keeps the
/// exponents of `ξ`).
#[derive(Clone, Debug)]
pub struct Derivative {
    n: f64,
    /// Per direction, per coefficient of degree `n − 1`: the positions of
    /// `b_{β + e_c}` and `b_β` of degree `n`.
    pairs: [Vec<(usize, usize)>; 3],
}

impl Derivative {
    /// From degree `from.deg()` (≥ 1) to `to.deg() = from.deg() − 1`.
    pub fn new(from: &Lattice, to: &Lattice) -> Self {
        assert!(from.deg >= 1 && to.deg + 1 == from.deg && to.dim == from.dim);
        let pairs = std::array::from_fn(|c| {
            if c >= from.dim {
                return Vec::new();
            }
            (0..to.len())
                .map(|i| {
                    let b = to.alpha(i);
                    let mut up = b;
                    up[c] += 1;
                    (from.position(up), from.position(b))
                })
                .collect()
        });
        Derivative { n: from.deg as f64, pairs }
    }

    /// `∂/∂ξ_c` of the polynomial with coefficients `coef`: two roundings
    /// per coefficient (the difference, the product by `n`).
    pub fn apply(&self, c: usize, coef: &[f64]) -> Coef {
        self.pairs[c].iter().map(|&(hi, lo)| self.n * (coef[hi] - coef[lo])).collect()
    }
}

/// One term of a [`Product`]: `out[o] += w a[i] b[j]`.
#[derive(Clone, Copy, Debug)]
struct Term {
    a: u16,
    b: u16,
    out: u16,
    w: f64,
}

/// The product of two polynomials of fixed degrees, exactly in the
/// Bernstein basis of the summed degree:
/// `B_α^m B_β^n = C(m; α) C(n; β) / C(m+n; α+β) B_{α+β}^{m+n}` (multinomials
/// of the full barycentric indices). The weights into one output
/// coefficient are non-negative and sum to one (Vandermonde's identity).
#[derive(Clone, Debug)]
pub struct Product {
    terms: Vec<Term>,
    len: usize,
    /// The most terms summed into one output coefficient.
    max_terms: usize,
}

impl Product {
    /// The product of degree `a.deg()` by degree `b.deg()` polynomials.
    pub fn new(a: &Lattice, b: &Lattice) -> Self {
        assert_eq!(a.dim, b.dim);
        let c = Lattice::new(a.dim, a.deg + b.deg);
        let mut count = vec![0usize; c.len()];
        let mut terms = Vec::with_capacity(a.len() * b.len());
        for i in 0..a.len() {
            for j in 0..b.len() {
                let (x, y) = (a.alpha(i), b.alpha(j));
                let o = c.position(std::array::from_fn(|d| x[d] + y[d]));
                // the numerator is an exact integer product below 2^53, so
                // the weight is one rounded quotient
                let num = a.multinomial(i) * b.multinomial(j);
                assert!(num < 2f64.powi(53), "product weight not exact");
                terms.push(Term { a: i as u16, b: j as u16, out: o as u16, w: num / c.multinomial(o) });
                count[o] += 1;
            }
        }
        Product { terms, len: c.len(), max_terms: count.into_iter().max().unwrap_or(0) }
    }

    /// The coefficients of the product.
    pub fn apply(&self, a: &[f64], b: &[f64]) -> Coef {
        let mut out: Coef = smallvec![0.0; self.len];
        for t in &self.terms {
            out[t.out as usize] += t.w * a[t.a as usize] * b[t.b as usize];
        }
        out
    }

    /// An upper bound on the roundings along any path from an operand
    /// coefficient to an output coefficient: the weight's quotient, the two
    /// products, and one per term of the sum into the output.
    pub fn roundings(&self) -> usize {
        3 + self.max_terms
    }

    /// The terms `(i, j, o, w)`: `out[o] += w a[i] b[j]`, each weight one
    /// rounded quotient of exact integers (the prism's product,
    /// [`super::prism_bezier`], is this one times the line's).
    pub fn terms(&self) -> impl Iterator<Item = (usize, usize, usize, f64)> + '_ {
        self.terms.iter().map(|t| (t.a as usize, t.b as usize, t.out as usize, t.w))
    }

    /// The number of output coefficients.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Never: a product has at least one coefficient.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The most terms summed into one output coefficient.
    pub fn max_terms(&self) -> usize {
        self.max_terms
    }
}

/// De Casteljau bisection of the simplex at the midpoint of an edge
/// `(a, b)`: for each line of coefficients along the edge (the other
/// exponents fixed, `α_a + α_b = m`), the 1-D de Casteljau algorithm at ½.
/// The piece near vertex `a` (vertex `b` moved to the midpoint) and the
/// piece near `b` keep the slots of the parent's vertices, so their
/// coefficients are indexed as the parent's.
#[derive(Clone, Debug)]
pub struct Split {
    /// Per edge, the positions of the coefficients line after line, each
    /// line ordered by `α_b = 0..=m`.
    order: Vec<Vec<u16>>,
    /// Per edge, the lengths `m + 1` of its lines in turn.
    lens: Vec<Vec<u8>>,
    len: usize,
}

impl Split {
    /// The bisections of degree-`lat.deg()` polynomials, one per edge of
    /// [`edges`]`(lat.dim())`.
    pub fn new(lat: &Lattice) -> Self {
        let (mut order, mut lens) = (Vec::new(), Vec::new());
        for &(a, b) in edges(lat.dim) {
            let (mut o, mut l) = (Vec::new(), Vec::new());
            // each line starts at its multi-index with α_b = 0
            for start in (0..lat.len()).filter(|&i| full(lat.deg, lat.alpha(i))[b] == 0) {
                let f = full(lat.deg, lat.alpha(start));
                let m = f[a];
                for k in 0..=m {
                    let mut g = f;
                    g[a] = m - k;
                    g[b] = k;
                    o.push(lat.position([g[1], g[2], g[3]]) as u16);
                }
                l.push((m + 1) as u8);
            }
            order.push(o);
            lens.push(l);
        }
        Split { order, lens, len: lat.len() }
    }

    /// The pieces near vertex `a` and near vertex `b` of edge `e` of
    /// [`edges`]. Each averaging step `½ (x + y)` rounds once (the halving
    /// is exact), at most `m ≤ deg` steps per coefficient, with weights
    /// `C(k, i) / 2^k` summing to one.
    pub fn apply(&self, e: usize, coef: &[f64]) -> (Coef, Coef) {
        let mut near_a: Coef = smallvec![0.0; self.len];
        let mut near_b: Coef = smallvec![0.0; self.len];
        self.apply_into(e, coef, &mut near_a, &mut near_b);
        (near_a, near_b)
    }

    /// [`Split::apply`] into the caller's slices (each of the lattice's
    /// length): the prism's split runs it on every layer of one buffer.
    pub fn apply_into(&self, e: usize, coef: &[f64], near_a: &mut [f64], near_b: &mut [f64]) {
        let mut line = [0.0f64; MAX_DEGREE + 1];
        let mut rest = &self.order[e][..];
        for &len in &self.lens[e] {
            let (at, tail) = rest.split_at(len as usize);
            rest = tail;
            let n = len as usize - 1;
            for (x, &i) in line.iter_mut().zip(at) {
                *x = coef[i as usize];
            }
            near_a[at[0] as usize] = line[0];
            near_b[at[n] as usize] = line[n];
            for k in 1..=n {
                for i in 0..=n - k {
                    line[i] = 0.5 * (line[i] + line[i + 1]);
                }
                near_a[at[k] as usize] = line[0];
                near_b[at[n - k] as usize] = line[n - k];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A point of the simplex, uniformly enough.
    fn point(dim: usize, seed: &mut u64) -> [f64; 3] {
        loop {
            let x = [lcg(seed), lcg(seed), if dim == 3 { lcg(seed) } else { 0.0 }];
            if x.iter().sum::<f64>() <= 1.0 {
                return x;
            }
        }
    }

    fn random(lat: &Lattice, seed: &mut u64) -> Coef {
        (0..lat.len()).map(|_| 2.0 * lcg(seed) - 1.0).collect()
    }

    #[test]
    fn lattice_order_and_sizes() {
        let t = Lattice::new(2, 3);
        assert_eq!(t.len(), 10);
        assert_eq!((t.alpha(0), t.alpha(3), t.alpha(4), t.alpha(9)), ([0, 0, 0], [3, 0, 0], [0, 1, 0], [0, 3, 0]));
        let k = Lattice::new(3, 9);
        assert_eq!(k.len(), 220);
        assert_eq!(k.alpha(k.vertex(3)), [0, 0, 9]);
        for i in 0..k.len() {
            assert_eq!(k.position(k.alpha(i)), i);
        }
        // the basis is a partition of unity
        let mut seed = 1;
        let mut b = vec![0.0; k.len()];
        k.basis(point(3, &mut seed), &mut b);
        assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-14 && b.iter().all(|&x| x >= 0.0));
    }

    #[test]
    fn product_derivative_and_split_are_exact() {
        let mut seed = 3;
        for dim in [2, 3] {
            let (la, lb) = (Lattice::new(dim, 3), Lattice::new(dim, 2));
            let (a, b) = (random(&la, &mut seed), random(&lb, &mut seed));
            let prod = Product::new(&la, &lb);
            let ab = prod.apply(&a, &b);
            let lab = Lattice::new(dim, 5);
            let lg = Lattice::new(dim, 2);
            let d = Derivative::new(&la, &lg);
            let split = Split::new(&la);
            for _ in 0..10 {
                let x = point(dim, &mut seed);
                assert!((lab.eval(&ab, x) - la.eval(&a, x) * lb.eval(&b, x)).abs() < 1e-13);
                for c in 0..dim {
                    let h = 1e-5;
                    let (mut xp, mut xm) = (x, x);
                    xp[c] += h;
                    xm[c] -= h;
                    let fd = (la.eval(&a, xp) - la.eval(&a, xm)) / (2.0 * h);
                    assert!((lg.eval(&d.apply(c, &a), x) - fd).abs() < 1e-7);
                }
                for (e, &(va, vb)) in edges(dim).iter().enumerate() {
                    // x in the piece near va, whose vertex vb is the midpoint:
                    // its barycentrics there are μ_va = λ_va − λ_vb, μ_vb = 2 λ_vb
                    let lam = barycentric(dim, x);
                    let (near_a, near_b) = split.apply(e, &a);
                    let (piece, mu) = if lam[va] >= lam[vb] {
                        let mut mu = lam;
                        mu[va] = lam[va] - lam[vb];
                        mu[vb] = 2.0 * lam[vb];
                        (near_a, mu)
                    } else {
                        let mut mu = lam;
                        mu[vb] = lam[vb] - lam[va];
                        mu[va] = 2.0 * lam[va];
                        (near_b, mu)
                    };
                    assert!((la.eval(&piece, [mu[1], mu[2], mu[3]]) - la.eval(&a, x)).abs() < 1e-13);
                }
            }
        }
    }
}
