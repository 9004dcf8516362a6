//! The numeric solvers the shapes share: Brent's root finder and
//! minimiser, bisection, the first sign change along a sampled interval,
//! the line–unit-ball intersection, Eberly's closest point on an ellipse or
//! ellipsoid, and Newton's projection onto a level set.

use crate::numeric::{dot, EPS};

/// Brent's root finder on `[a, b]` with `f(a)`, `f(b)` of opposite signs
/// (or one zero), iterating until the bracket is a few ulps wide.
pub(super) fn brent_root(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64, mut fa: f64, mut fb: f64) -> f64 {
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


/// Brent's derivative-free minimiser on `[a, b]` (as in Numerical Recipes'
/// `brent`), returning `(x, f(x))`. The tolerance is a few ulps of `x`
/// plus `abs_tol` rather than the textbook √ε: our squared distances vanish
/// at on-surface points, so their minimisers are resolved much better.
pub(super) fn brent_min(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64, abs_tol: f64) -> (f64, f64) {
    const CGOLD: f64 = 0.381_966_011_250_105_1;
    let mut x = a + CGOLD * (b - a);
    let (mut w, mut v) = (x, x);
    let mut fx = f(x);
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..300 {
        let xm = 0.5 * (a + b);
        let tol1 = 2.0 * EPS * x.abs() + abs_tol;
        let tol2 = 2.0 * tol1;
        if (x - xm).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            // Try a parabola through x, w, v.
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            e = d;
            if p.abs() < (0.5 * q * etemp).abs() && p > q * (a - x) && p < q * (b - x) {
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = tol1.copysign(xm - x);
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= xm { a - x } else { b - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let fu = f(u);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, fv) = (w, fw);
            (w, fw) = (x, fx);
            (x, fx) = (u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv) = (w, fw);
                (w, fw) = (u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (x, fx)
}

/// The first sign change of `f` on `[lo, hi]` sampled at `count` equal
/// steps, refined with Brent's method. A zero sample counts as a crossing
/// unless it is the very first one (the ray's start touching the surface).
/// Where the samples dip towards zero without changing sign, the dip is
/// minimised too: a ray clipping a thin edge or spike of the surface
/// between two samples crosses it twice there.
pub(super) fn first_crossing(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64, count: usize) -> Option<f64> {
    let at = |k: usize| {
        if k == count {
            hi
        } else {
            lo + (hi - lo) * k as f64 / count as f64
        }
    };
    let mut prev: Option<(f64, f64)> = None;
    let mut a = (lo, f(lo));
    for k in 1..=count {
        let b = (at(k), f(at(k)));
        if b.1 == 0.0 {
            return Some(b.0);
        }
        if !(a.1.is_finite() && b.1.is_finite()) {
            (prev, a) = (None, b);
            continue;
        }
        if let Some(p) = prev {
            if let Some(s) = dip_crossing(f, p, a, b) {
                return Some(s);
            }
        }
        if a.1 != 0.0 && (a.1 > 0.0) != (b.1 > 0.0) {
            return Some(brent_root(f, a.0, b.0, a.1, b.1));
        }
        (prev, a) = (Some(a), b);
    }
    None
}

/// If `a` is a local minimum of `|f|` among three samples `p`, `a`, `b` of
/// one sign, minimises `σf` (σ that sign) on `[p, b]`; when the minimum
/// has the other sign, returns the first root, between `p` and it.
fn dip_crossing(
    f: &dyn Fn(f64) -> f64,
    p: (f64, f64),
    a: (f64, f64),
    b: (f64, f64),
) -> Option<f64> {
    let sigma = a.1.signum();
    let same_sign = a.1 != 0.0 && p.1.signum() == sigma && b.1.signum() == sigma;
    if !same_sign || sigma * p.1 < sigma * a.1 || sigma * b.1 < sigma * a.1 {
        return None;
    }
    let g = |s: f64| sigma * f(s);
    let (sm, gm) = brent_min(&g, p.0, b.0, EPS * (p.0.abs() + b.0.abs()));
    (gm < 0.0).then(|| brent_root(f, p.0, sm, p.1, f(sm)))
}

/// Bisection for the root of a decreasing function on `[lo, hi]`, until the
/// midpoint is no longer representable between the ends.
pub(super) fn bisect_decreasing(f: &dyn Fn(f64) -> f64, lo: &mut f64, hi: &mut f64) -> f64 {
    let mut s = *lo;
    for _ in 0..2000 {
        s = 0.5 * (*lo + *hi);
        if s == *lo || s == *hi {
            break;
        }
        let g = f(s);
        if g > 0.0 {
            *lo = s;
        } else if g < 0.0 {
            *hi = s;
        } else {
            break;
        }
    }
    s
}

/// Roots `s1 <= s2` of `|o + s·d| = 1` (the unit circle or sphere),
/// computed without cancellation, or `None` if the line misses it (or `d`
/// is zero).
pub(super) fn unit_ball_roots<const D: usize>(o: [f64; D], d: [f64; D]) -> Option<(f64, f64)> {
    let a = dot(d, d);
    let b = dot(o, d);
    let c = dot(o, o) - 1.0;
    let disc = b * b - a * c;
    if disc < 0.0 || a == 0.0 {
        return None;
    }
    // q has the sign of -b, so q/a and c/q avoid subtracting close numbers.
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return Some((0.0, 0.0)); // o on the ball's surface and d tangent
    }
    let (r1, r2) = (q / a, c / q);
    Some((r1.min(r2), r1.max(r2)))
}

/// Closest point on the axis-aligned ellipse (`D` = 2) or ellipsoid
/// (`D` = 3) `Σ (x_k/e_k)² = 1` to local `q`, by Eberly's robust bisection
/// ("Distance from a point to an ellipse, an ellipsoid, or a
/// hyperellipsoid"). Other dimensions give NaN.
pub(super) fn closest_on_axis_ellipsoid<const D: usize>(e: [f64; D], q: [f64; D]) -> [f64; D] {
    // Eberly's method wants the semi-axes in decreasing order and the point
    // in the first orthant; undo both at the end.
    let mut order: [usize; D] = std::array::from_fn(|k| k);
    order.sort_by(|&i, &j| e[j].total_cmp(&e[i]));
    let es = order.map(|k| e[k]);
    let ys = order.map(|k| q[k].abs());
    let xs = match (&es[..], &ys[..]) {
        (&[e0, e1], &[y0, y1]) => {
            let [x0, x1] = eberly_first_quadrant(e0, e1, y0, y1);
            [x0, x1, 0.0]
        }
        (&[e0, e1, e2], &[y0, y1, y2]) => eberly_octant([e0, e1, e2], [y0, y1, y2]),
        _ => [f64::NAN; 3],
    };
    let mut x = [0.0; D];
    for (slot, &k) in order.iter().enumerate() {
        x[k] = xs[slot].copysign(q[k]);
    }
    x
}

/// Eberly's case analysis for `e0 ≥ e1 ≥ e2 > 0` and `y ≥ 0`: the general
/// case is a 1-D root, points on a coordinate plane reduce to an ellipse.
fn eberly_octant(e: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    let [e0, e1, e2] = e;
    let [y0, y1, y2] = y;
    if y2 > 0.0 {
        if y1 > 0.0 {
            if y0 > 0.0 {
                let z = [y0 / e0, y1 / e1, y2 / e2];
                let g = z[0] * z[0] + z[1] * z[1] + z[2] * z[2] - 1.0;
                if g == 0.0 {
                    return y;
                }
                let r = [(e0 / e2).powi(2), (e1 / e2).powi(2)];
                let s = eberly_root3(r, z, g);
                return [
                    r[0] * y0 / (s + r[0]),
                    r[1] * y1 / (s + r[1]),
                    y2 / (s + 1.0),
                ];
            }
            let [x1, x2] = eberly_first_quadrant(e1, e2, y1, y2);
            return [0.0, x1, x2];
        }
        if y0 > 0.0 {
            let [x0, x2] = eberly_first_quadrant(e0, e2, y0, y2);
            return [x0, 0.0, x2];
        }
        return [0.0, 0.0, e2];
    }
    // On the plane of the smallest axis: the closest point is either in
    // that plane or, for points inside near the centre, off it.
    let (d0, d1) = (e0 * e0 - e2 * e2, e1 * e1 - e2 * e2);
    let (n0, n1) = (e0 * y0, e1 * y1);
    if n0 < d0 && n1 < d1 {
        let (xd0, xd1) = (n0 / d0, n1 / d1);
        let disc = 1.0 - xd0 * xd0 - xd1 * xd1;
        if disc > 0.0 {
            return [e0 * xd0, e1 * xd1, e2 * disc.sqrt()];
        }
    }
    let [x0, x1] = eberly_first_quadrant(e0, e1, y0, y1);
    [x0, x1, 0.0]
}

/// Bisection for the root of Eberly's monotone function in 3D; converges to
/// the last representable bit.
fn eberly_root3(r: [f64; 2], z: [f64; 3], g: f64) -> f64 {
    let (n0, n1) = (r[0] * z[0], r[1] * z[1]);
    let mut lo = z[2] - 1.0;
    let mut hi = if g < 0.0 {
        0.0
    } else {
        n0.hypot(n1).hypot(z[2]) - 1.0
    };
    let f = |s: f64| {
        let (a, b, c) = (n0 / (s + r[0]), n1 / (s + r[1]), z[2] / (s + 1.0));
        a * a + b * b + c * c - 1.0
    };
    bisect_decreasing(&f, &mut lo, &mut hi)
}

/// The 2D ellipse case `(x/e0)² + (y/e1)² = 1`, `e0 ≥ e1`, for `y ≥ 0`.
fn eberly_first_quadrant(e0: f64, e1: f64, y0: f64, y1: f64) -> [f64; 2] {
    if y1 > 0.0 {
        if y0 > 0.0 {
            let (z0, z1) = (y0 / e0, y1 / e1);
            let g = z0 * z0 + z1 * z1 - 1.0;
            if g == 0.0 {
                return [y0, y1];
            }
            let r0 = (e0 / e1) * (e0 / e1);
            let n0 = r0 * z0;
            let mut lo = z1 - 1.0;
            let mut hi = if g < 0.0 { 0.0 } else { n0.hypot(z1) - 1.0 };
            let f = |s: f64| {
                let (a, b) = (n0 / (s + r0), z1 / (s + 1.0));
                a * a + b * b - 1.0
            };
            let s = bisect_decreasing(&f, &mut lo, &mut hi);
            return [r0 * y0 / (s + r0), y1 / (s + 1.0)];
        }
        return [0.0, e1];
    }
    // On the major axis: the vertex or, for points near the centre, off
    // the axis.
    let (numer, denom) = (e0 * y0, e0 * e0 - e1 * e1);
    if numer < denom {
        let xde = numer / denom;
        return [e0 * xde, e1 * (1.0 - xde * xde).max(0.0).sqrt()];
    }
    [e0, 0.0]
}


/// How Newton's projection onto a level set ([`project_level_set`]) is run.
pub(super) struct Newton {
    /// Most iterations.
    pub(super) iterations: usize,
    /// Converged once a step is at most this relative to `1 + |x|`.
    pub(super) tol: f64,
}

/// Newton's projection onto {φ = 0}, `x ← x − φ ∇φ / |∇φ|²`, from `x`: a
/// foot point on the zero set near `x` (for points close to it, as mesh
/// nodes are, the closest one to first order). `phi_grad` gives φ and its
/// exact gradient in one call (a level set's compiled expression in
/// forward mode), so an iteration costs one evaluation and allocates
/// nothing. Returns the last iterate and whether the steps converged; they
/// do not where ∇φ vanishes or is not finite, φ is not finite, or the
/// iterations run out.
pub(super) fn project_level_set<const D: usize>(phi_grad: impl Fn([f64; D]) -> (f64, [f64; D]), x: [f64; D], newton: &Newton) -> ([f64; D], bool) {
    let mut p = x;
    for _ in 0..newton.iterations {
        let (v, g) = phi_grad(p);
        let n2 = dot(g, g);
        if !(n2 > 0.0 && n2.is_finite() && v.is_finite()) {
            return (p, false);
        }
        let step: [f64; D] = std::array::from_fn(|k| v * g[k] / n2);
        p = std::array::from_fn(|k| p[k] - step[k]);
        if dot(step, step).sqrt() <= newton.tol * (1.0 + dot(p, p).sqrt()) {
            return (p, true);
        }
    }
    (p, false)
}
