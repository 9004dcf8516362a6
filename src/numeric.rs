//! Small numerics shared by the geometry modules: vector arithmetic on
//! fixed-size arrays and a robust scalar root finder.

/// Machine epsilon, used for root-finding tolerances.
pub const EPS: f64 = f64::EPSILON;

/// A ray hit closer than this fraction of the problem's length scale is
/// taken to be the ray's own origin lying on the shape, not a hit (`s > 0`).
pub const RAY_ORIGIN_TOL: f64 = 1e-12;

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

/// Smallest accepted ray parameter: hits closer than this to the origin
/// are round-off images of an origin lying on the shape. Scaled by the
/// shape size and the origin's distance from it, the two sources of
/// round-off in the intersection arithmetic.
pub fn ray_s_min<const D: usize>(origin: [f64; D], dir: [f64; D], reference: [f64; D], size: f64) -> f64 {
    RAY_ORIGIN_TOL * (size + norm(sub(origin, reference))) / norm(dir)
}

/// Brent's root finder on `[a, b]` with `f(a)`, `f(b)` of opposite signs
/// (or one zero), iterating until the bracket is a few ulps wide.
pub fn brent_root(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64, mut fa: f64, mut fb: f64) -> f64 {
    let xtol = EPS * (a.abs().max(b.abs()) + (b - a).abs());
    let (mut c, mut fc) = (b, fb);
    let (mut d, mut e) = (b - a, b - a);
    for _ in 0..200 {
        if (fb > 0.0) == (fc > 0.0) && fb != 0.0 && fc != 0.0 {
            (c, fc) = (a, fa);
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            (a, fa) = (b, fb);
            (b, fb) = (c, fc);
            (c, fc) = (a, fa);
        }
        let tol = 2.0 * EPS * b.abs() + 0.5 * xtol;
        let m = 0.5 * (c - b);
        if m.abs() <= tol || fb == 0.0 {
            return b;
        }
        if e.abs() >= tol && fa.abs() > fb.abs() {
            // Inverse quadratic interpolation or secant step, accepted only
            // when it stays well inside the bracket and keeps shrinking.
            let s = fb / fa;
            let (mut p, mut q) = if a == c {
                (2.0 * m * s, 1.0 - s)
            } else {
                let (q0, r) = (fa / fc, fb / fc);
                (
                    s * (2.0 * m * q0 * (q0 - r) - (b - a) * (r - 1.0)),
                    (q0 - 1.0) * (r - 1.0) * (s - 1.0),
                )
            };
            if p > 0.0 {
                q = -q;
            }
            p = p.abs();
            if 2.0 * p < (3.0 * m * q - (tol * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = m;
                e = m;
            }
        } else {
            d = m;
            e = m;
        }
        (a, fa) = (b, fb);
        b += if d.abs() > tol { d } else { tol.copysign(m) };
        fb = f(b);
    }
    b
}
