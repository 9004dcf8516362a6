//! Tensor-product Bernstein (Bézier) polynomials on the box `[0,1]^3`:
//! conversion from values at nodes, derivative, exact product, value,
//! splitting in halves and coefficient bounds. Bernstein polynomials are
//! non-negative and sum to 1, so the smallest and largest coefficients
//! bound the polynomial on the box, the corner coefficients are values,
//! and splitting a box (de Casteljau) tightens the bounds quadratically in
//! its size: what the certificate of [`crate::quality::certify`] is made of.

use smallvec::{smallvec, SmallVec};

/// Coefficients: inline up to 27, the degree-(2,2,2) det J of a trilinear
/// hex, so the linear check, run on every cell at every step, allocates
/// nothing; higher degrees go to the heap.
type Coef = SmallVec<[f64; 27]>;

/// A polynomial in up to three variables on the box `[0,1]^3` in the
/// tensor Bernstein basis: `Σ coef[i + (n0+1)(j + (n1+1) k)]
/// B_i^{n0}(u) B_j^{n1}(v) B_k^{n2}(w)`. Unused variables have degree 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Bezier {
    /// Degree per variable.
    pub deg: [usize; 3],
    /// Coefficients, first variable fastest.
    pub coef: Coef,
}

/// `C(n, k)` for `n < 24`, exact in `f64` (a table: products of det J
/// columns weigh every pair of coefficients by three of them).
const BINOM: [[f64; 24]; 24] = {
    let mut t = [[0.0; 24]; 24];
    let mut n = 0;
    while n < 24 {
        let (mut k, mut c) = (0, 1u64);
        while k <= n {
            t[n][k] = c as f64;
            c = c * (n - k) as u64 / (k + 1) as u64;
            k += 1;
        }
        n += 1;
    }
    t
};

/// Binomial coefficient as `f64` (exact).
pub fn binom(n: usize, k: usize) -> f64 {
    BINOM[n][k]
}

/// `B_i^n(t)` for `i = 0..=n`.
pub fn bernstein(n: usize, t: f64) -> Vec<f64> {
    (0..=n).map(|i| binom(n, i) * t.powi(i as i32) * (1.0 - t).powi((n - i) as i32)).collect()
}

/// Inverse of a small dense matrix by Gauss–Jordan with partial pivoting.
/// Only called on Bernstein–Vandermonde matrices at distinct nodes, which
/// are invertible.
pub fn invert(a: &[Vec<f64>]) -> Vec<Vec<f64>> {
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
        let piv = (col..n).max_by(|&x, &y| m[x][col].abs().total_cmp(&m[y][col].abs())).unwrap_or(col);
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
    /// Number of coefficients along variable `d`.
    fn len(&self, d: usize) -> usize {
        self.deg[d] + 1
    }

    /// The Bernstein form of the degree-`p` tensor interpolant in `dim`
    /// variables of `values` (tensor order), given `inv`, the matrix from
    /// values at the 1-D nodes to Bernstein coefficients (the inverse of
    /// `V[i][j] = B_j(t_i)`), applied along each variable.
    pub fn from_values(p: usize, dim: usize, values: impl IntoIterator<Item = f64>, inv: &[Vec<f64>]) -> Self {
        let mut b = Bezier { deg: std::array::from_fn(|d| if d < dim { p } else { 0 }), coef: values.into_iter().collect() };
        for d in 0..dim {
            b = b.apply(d, p + 1, |r, l| inv[r][l]);
        }
        b
    }

    /// Applies the matrix `m(r, l)` (`rows` new coefficients from the old
    /// ones) along variable `d`; the new degree there is `rows − 1`. Zero
    /// entries are skipped, so a banded matrix costs only its band.
    fn apply(&self, d: usize, rows: usize, m: impl Fn(usize, usize) -> f64) -> Bezier {
        let inner: usize = (0..d).map(|e| self.len(e)).product();
        let outer: usize = (d + 1..3).map(|e| self.len(e)).product();
        let old = self.len(d);
        let mut coef: Coef = smallvec![0.0; inner * rows * outer];
        for o in 0..outer {
            for a in 0..inner {
                for r in 0..rows {
                    let mut s = 0.0;
                    for l in 0..old {
                        let w = m(r, l);
                        if w != 0.0 {
                            s += w * self.coef[a + inner * (l + old * o)];
                        }
                    }
                    coef[a + inner * (r + rows * o)] = s;
                }
            }
        }
        let mut deg = self.deg;
        deg[d] = rows - 1;
        Bezier { deg, coef }
    }

    /// The partial derivative along variable `d` (of the polynomial on
    /// `[0,1]^3`): `n (c_{i+1} − c_i)` in degree `n − 1`. A constant
    /// direction gives zero.
    pub fn derivative(&self, d: usize) -> Bezier {
        let n = self.deg[d];
        if n == 0 {
            return Bezier { deg: self.deg, coef: smallvec![0.0; self.coef.len()] };
        }
        let nf = n as f64;
        self.apply(d, n, |k, l| if l == k { -nf } else if l == k + 1 { nf } else { 0.0 })
    }

    /// The coefficients' absolute values.
    pub fn abs(&self) -> Bezier {
        Bezier { deg: self.deg, coef: self.coef.iter().map(|c| c.abs()).collect() }
    }

    /// The negated polynomial.
    pub fn neg(&self) -> Bezier {
        Bezier { deg: self.deg, coef: self.coef.iter().map(|c| -c).collect() }
    }

    /// The product, exactly in the Bernstein basis of the summed degree:
    /// `B_i^m B_j^n = C(m,i) C(n,j) / C(m+n,i+j) B_{i+j}^{m+n}`.
    pub fn mul(&self, other: &Bezier) -> Bezier {
        let deg: [usize; 3] = std::array::from_fn(|d| self.deg[d] + other.deg[d]);
        // w[d][i (n+1) + j] = C(m,i) C(n,j) / C(m+n, i+j)
        let w: [SmallVec<[f64; 16]>; 3] = std::array::from_fn(|d| {
            let (m, n) = (self.deg[d], other.deg[d]);
            (0..=m).flat_map(|i| (0..=n).map(move |j| binom(m, i) * binom(n, j) / binom(m + n, i + j))).collect()
        });
        let [a0, a1, a2] = std::array::from_fn(|d| self.len(d));
        let [b0, b1, b2] = std::array::from_fn(|d| other.len(d));
        let (c0, c1) = (deg[0] + 1, deg[1] + 1);
        let mut coef: Coef = smallvec![0.0; c0 * c1 * (deg[2] + 1)];
        // nested loops in storage order (no index division in the hot
        // loop); the arithmetic and its order are those of the plain
        // double loop over coefficient pairs
        let mut ca = self.coef.iter();
        for i2 in 0..a2 {
            for i1 in 0..a1 {
                for (i0, &ca) in (0..a0).zip(&mut ca) {
                    let mut cb = other.coef.iter();
                    for j2 in 0..b2 {
                        let w2 = w[2][i2 * b2 + j2];
                        for j1 in 0..b1 {
                            let w1 = w[1][i1 * b1 + j1];
                            let base = i0 + c0 * ((i1 + j1) + c1 * (i2 + j2));
                            let out = &mut coef[base..base + b0];
                            for ((o, &w0), &cb) in out.iter_mut().zip(&w[0][i0 * b0..]).zip(&mut cb) {
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
    pub fn add_scaled(&self, s: f64, other: &Bezier) -> Bezier {
        assert_eq!(self.deg, other.deg, "adding Bézier polynomials of different degree");
        Bezier { deg: self.deg, coef: self.coef.iter().zip(&other.coef).map(|(a, b)| a + s * b).collect() }
    }

    /// The value at `x` (unused variables ignored).
    pub fn eval(&self, x: [f64; 3]) -> f64 {
        let mut b = self.clone();
        for (d, &xd) in x.iter().enumerate() {
            if b.deg[d] > 0 {
                let row = bernstein(b.deg[d], xd);
                b = b.apply(d, 1, |_, l| row[l]);
            }
        }
        b.coef[0]
    }

    /// The two halves `[0,½]` and `[½,1]` along variable `d`, each
    /// re-parametrised to `[0,1]` (de Casteljau at ½, written as its two
    /// matrices of non-negative weights `C(k,i)/2^k` summing to one).
    pub fn split(&self, d: usize) -> (Bezier, Bezier) {
        let n = self.deg[d];
        let inner: usize = (0..d).map(|e| self.len(e)).product();
        let outer: usize = (d + 1..3).map(|e| self.len(e)).product();
        let mut left: Coef = smallvec![0.0; self.coef.len()];
        let mut right: Coef = smallvec![0.0; self.coef.len()];
        // de Casteljau at ½ along each line of coefficients in direction d:
        // the certification's hot loop (80 % of certifying thin p = 3 hexes
        // went to splits when they were two weight matrices built per
        // entry); degree ≤ 12 here (at most 23, as the binomial table), so a line fits a stack array
        let mut line = [0.0f64; 24];
        for o in 0..outer {
            for a in 0..inner {
                let at = |l: usize| a + inner * (l + (n + 1) * o);
                for l in 0..=n {
                    line[l] = self.coef[at(l)];
                }
                left[at(0)] = line[0];
                right[at(n)] = line[n];
                for k in 1..=n {
                    for i in 0..=n - k {
                        line[i] = 0.5 * (line[i] + line[i + 1]);
                    }
                    left[at(k)] = line[0];
                    right[at(n - k)] = line[n - k];
                }
            }
        }
        (Bezier { deg: self.deg, coef: left }, Bezier { deg: self.deg, coef: right })
    }

    /// `(min, max)` of the coefficients: bounds of the polynomial on the
    /// box.
    pub fn coef_bounds(&self) -> (f64, f64) {
        self.coef.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &c| (lo.min(c), hi.max(c)))
    }

    /// The largest absolute coefficient.
    pub fn max_abs(&self) -> f64 {
        self.coef.iter().fold(0.0f64, |m, c| m.max(c.abs()))
    }

    /// Per variable, a bound on how far the polynomial can fall below the
    /// control net along that variable: `⌊n/2⌋⌈n/2⌉/(2n) · max |Δ²c|` over
    /// the lines of coefficients in that direction (0 for degree < 2). The
    /// gap between the smallest coefficient and the minimum is at most
    /// their sum, and halving the box in a variable quarters its term: the
    /// branch and bound splits only where a term is large. An extruded
    /// hex's det J is constant along the extrusion, and halving that
    /// variable only copied boxes.
    pub fn net_gaps(&self) -> [f64; 3] {
        std::array::from_fn(|d| {
            let n = self.deg[d];
            if n < 2 {
                return 0.0;
            }
            let step: usize = (0..d).map(|e| self.len(e)).product();
            let mut worst = 0.0f64;
            for (i, &c) in self.coef.iter().enumerate() {
                // i is the first of three along d when its index in d is ≤ n − 2
                if (i / step) % (n + 1) + 2 <= n {
                    worst = worst.max((c - 2.0 * self.coef[i + step] + self.coef[i + 2 * step]).abs());
                }
            }
            (n / 2 * n.div_ceil(2)) as f64 / (2 * n) as f64 * worst
        })
    }

    /// The smallest corner coefficient, a value the polynomial takes.
    pub fn min_corner(&self) -> f64 {
        let mut m = f64::INFINITY;
        for c in 0..8 {
            let idx: [usize; 3] = std::array::from_fn(|d| if c >> d & 1 == 1 { self.deg[d] } else { 0 });
            m = m.min(self.coef[idx[0] + self.len(0) * (idx[1] + self.len(1) * idx[2])]);
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A polynomial of degree (3, 2, 1) with awkward coefficients.
    fn sample() -> Bezier {
        Bezier { deg: [3, 2, 1], coef: (0..24).map(|i| ((i * 7 % 11) as f64 - 4.5) / 3.0).collect() }
    }

    /// `(u − ½)²` has coefficients ¼, −¼, ¼: its minimum 0 lies exactly
    /// the gap ¼ above the smallest coefficient. On polynomials of mixed
    /// degree the value at the Greville point of the smallest coefficient
    /// is within the gaps' sum of it, and a halving quarters its own gap.
    #[test]
    fn net_gaps_bound_the_fall_below_the_net() {
        let q = Bezier { deg: [0, 2, 0], coef: [0.25, -0.25, 0.25].into_iter().collect() };
        assert_eq!(q.net_gaps(), [0.0, 0.25, 0.0]);
        assert_eq!(q.eval([0.0, 0.5, 0.0]), q.coef_bounds().0 + 0.25);
        let mut seed = 7u64;
        for deg in [[3, 2, 1], [4, 4, 2], [2, 5, 3]] {
            let len = (deg[0] + 1) * (deg[1] + 1) * (deg[2] + 1);
            let b = Bezier {
                deg,
                // a linear function (its own net) plus a small bump of
                // 1e-2: the gaps are near what the polynomial falls below
                // the net, so the bound is tested close to tight
                coef: (0..len)
                    .map(|i| {
                        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                        let at = [i % (deg[0] + 1), i / (deg[0] + 1) % (deg[1] + 1), i / ((deg[0] + 1) * (deg[1] + 1))];
                        let g: [f64; 3] = std::array::from_fn(|d| if deg[d] == 0 { 0.0 } else { at[d] as f64 / deg[d] as f64 });
                        0.3 * g[0] - 0.7 * g[1] + 0.2 * g[2] + 1e-2 * ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
                    })
                    .collect(),
            };
            let gaps = b.net_gaps();
            let (lo, _) = b.coef_bounds();
            let at = b.coef.iter().position(|&c| c == lo).unwrap();
            let idx = [at % (deg[0] + 1), at / (deg[0] + 1) % (deg[1] + 1), at / ((deg[0] + 1) * (deg[1] + 1))];
            let greville: [f64; 3] = std::array::from_fn(|d| if deg[d] == 0 { 0.0 } else { idx[d] as f64 / deg[d] as f64 });
            let sum: f64 = gaps.iter().sum();
            assert!(sum < 0.03 && b.eval(greville) <= lo + sum + 1e-14, "{deg:?}: {} {lo} {gaps:?}", b.eval(greville));
            for d in 0..3 {
                let (l, r) = b.split(d);
                for h in [l, r] {
                    assert!(h.net_gaps()[d] <= gaps[d] / 4.0 + 1e-15, "{deg:?} {d}");
                }
            }
        }
    }

    #[test]
    fn split_halves_agree_with_the_whole() {
        let b = sample();
        for d in 0..3 {
            let (l, r) = b.split(d);
            let (mut x, mut y) = ([0.3, 0.6, 0.8], [0.3, 0.6, 0.8]);
            x[d] = 0.4; // in the left half at 0.8
            y[d] = 0.9; // in the right half at 0.8
            let (mut xl, mut yr) = (x, y);
            xl[d] = 0.8;
            yr[d] = 0.8;
            assert!((l.eval(xl) - b.eval(x)).abs() < 1e-12);
            assert!((r.eval(yr) - b.eval(y)).abs() < 1e-12);
        }
    }

    #[test]
    fn product_derivative_and_conversion_are_exact() {
        let (a, b) = (sample(), sample().derivative(1).add_scaled(0.5, &sample().derivative(1)));
        let ab = a.mul(&b);
        assert_eq!(ab.deg, [6, 3, 2]);
        for x in [[0.1, 0.7, 0.3], [0.9, 0.2, 1.0], [0.0, 0.5, 0.25]] {
            assert!((ab.eval(x) - a.eval(x) * b.eval(x)).abs() < 1e-12);
            // the derivative by a central difference of the cubic in u
            let h = 1e-4;
            let (mut xp, mut xm) = (x, x);
            xp[0] += h;
            xm[0] -= h;
            let fd = (a.eval(xp) - a.eval(xm)) / (2.0 * h);
            assert!((a.derivative(0).eval(x) - fd).abs() < 1e-6);
        }
        // values at the nodes 0, 1/3, 2/3, 1 of u ↦ u³ through invert
        let t = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0];
        let inv = invert(&t.iter().map(|&x| bernstein(3, x)).collect::<Vec<_>>());
        let cube = Bezier::from_values(3, 1, t.iter().map(|x| x * x * x), &inv);
        assert!((cube.eval([0.6, 0.0, 0.0]) - 0.216).abs() < 1e-14);
        assert_eq!(BINOM[11][5], 462.0);
    }
}
