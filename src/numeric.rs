//! Small vector arithmetic on fixed-size arrays, in any dimension and the
//! few operations special to the plane and to space. (The one-dimensional
//! solvers the shapes use are in `geometry/solvers.rs`.) Bernstein
//! polynomials, of which the validity certificate is made, are in
//! [`bezier`] (boxes), [`simplex_bezier`] and [`prism_bezier`].

pub mod bezier;
pub mod prism_bezier;
pub mod simplex_bezier;

/// Machine epsilon, used for root-finding and convergence tolerances.
pub const EPS: f64 = f64::EPSILON;

/// a + b.
pub fn add<const D: usize>(a: [f64; D], b: [f64; D]) -> [f64; D] {
    std::array::from_fn(|i| a[i] + b[i])
}

/// a − b.
pub fn sub<const D: usize>(a: [f64; D], b: [f64; D]) -> [f64; D] {
    std::array::from_fn(|i| a[i] - b[i])
}

/// k a.
pub fn scale<const D: usize>(k: f64, a: [f64; D]) -> [f64; D] {
    a.map(|c| k * c)
}

/// `Σ_j w[j] x[j]`: a point mixed from others by weights.
pub fn mix<const D: usize>(w: &[f64], x: &[[f64; D]]) -> [f64; D] {
    let mut out = [0.0; D];
    for (&wj, xj) in w.iter().zip(x) {
        for (o, c) in out.iter_mut().zip(xj) {
            *o += wj * c;
        }
    }
    out
}

/// a · b.
pub fn dot<const D: usize>(a: [f64; D], b: [f64; D]) -> f64 {
    (0..D).map(|i| a[i] * b[i]).sum()
}

/// |a|, by repeated `hypot` (no overflow for large components).
pub fn norm<const D: usize>(a: [f64; D]) -> f64 {
    a.iter().fold(0.0, |acc: f64, &c| acc.hypot(c))
}

/// a / |a|.
pub fn unit<const D: usize>(a: [f64; D]) -> [f64; D] {
    scale(1.0 / norm(a), a)
}

/// a × b in space.
pub fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// |a − b|², the squared distance (no square root where only comparisons
/// are needed).
pub fn dist2<const D: usize>(a: [f64; D], b: [f64; D]) -> f64 {
    let d = sub(a, b);
    dot(d, d)
}

/// a × b in the plane: the z-component of the 3D cross product.
pub fn cross2(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Rotation by 90° clockwise: turns a curve's tangent into its normal.
pub fn rot_cw(a: [f64; 2]) -> [f64; 2] {
    [a[1], -a[0]]
}

/// Rotation by 90° counter-clockwise.
pub fn rot_ccw(a: [f64; 2]) -> [f64; 2] {
    [-a[1], a[0]]
}

/// Rotation by the angle with the given cosine and sine.
pub fn rotate(a: [f64; 2], cos: f64, sin: f64) -> [f64; 2] {
    [cos * a[0] - sin * a[1], sin * a[0] + cos * a[1]]
}

/// a · (b × c), the determinant of the matrix with columns a, b, c.
pub fn triple(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    dot(a, cross3(b, c))
}
