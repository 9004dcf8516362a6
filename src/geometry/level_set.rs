//! Level sets: the zero set of a function φ(x, y, z) as a curve (2D) or a
//! surface (3D), for walls that no spec describes and for interfaces of a
//! prescribed Jacobian.

use super::solvers::{bisect_decreasing, project_level_set, Newton};
use super::ClosestPoint;
use crate::expr::Expr;
use crate::numeric::{dot, sub, unit};

/// Newton's projection for putting mesh nodes onto the zero set: run to
/// round-off, as a node on a wall should be.
const ONTO: Newton = Newton { iterations: 50, tol: 1e-15 };

/// Newton's projection for the distances of an interface band: g₁ needs
/// them to far less than round-off, at every quadrature point of every
/// step, so fewer iterations.
const BAND: Newton = Newton { iterations: 30, tol: 1e-13 };

/// {φ = 0} for φ an expression in x, y, z (variables
/// [`crate::jacobian::EXPR_VARS`]; t must not occur, a shape does not move).
/// Its closest point is Newton's foot point from the point itself, its
/// normal the direction of ∇φ there; ∇φ is exact, from the compiled
/// expression in forward mode ([`Expr::eval_gradient`]), one evaluation
/// per Newton step.
#[derive(Clone, Debug)]
pub struct LevelSet {
    phi: Expr,
}

impl LevelSet {
    /// φ from an expression in x, y, z; fails if it uses t.
    pub fn new(phi: Expr) -> Result<LevelSet, String> {
        if phi.uses("t") {
            return Err("a level set may not use t".into());
        }
        Ok(LevelSet { phi })
    }

    /// φ at a point of the plane (z = 0) or of space.
    fn eval<const D: usize>(&self, x: [f64; D]) -> f64 {
        let mut v = [0.0; 4];
        v[..D].copy_from_slice(&x);
        self.phi.eval(&v)
    }

    /// φ and ∇φ at a point of the plane (z = 0) or of space.
    fn eval_gradient<const D: usize>(&self, x: [f64; D]) -> (f64, [f64; D]) {
        let mut v = [0.0; 4];
        v[..D].copy_from_slice(&x);
        self.phi.eval_gradient::<D>(&v)
    }

    /// Distance from `x` to the zero set for an interface band: Newton's
    /// projection from `x`, then the length travelled. Where that does not
    /// converge (a critical point of φ, say), the first-order estimate
    /// |φ|/|∇φ| stands in, which is what the band needs far from the
    /// interface anyway. Where that estimate exceeds `far`, it is returned
    /// without projecting: the band has vanished there, and the projection
    /// is the costly part. NaN where φ is not finite at `x`, so that a bad
    /// φ is reported rather than a band silently absent.
    pub fn band_distance(&self, x: [f64; 3], far: f64) -> f64 {
        let (v0, g0) = self.eval_gradient(x);
        if v0 == 0.0 {
            return 0.0;
        }
        if !v0.is_finite() {
            return f64::NAN;
        }
        let first_order = if dot(g0, g0) > 0.0 { v0.abs() / dot(g0, g0).sqrt() } else { f64::INFINITY };
        if first_order > far {
            return first_order;
        }
        match project_level_set(|p| self.eval_gradient(p), x, &BAND) {
            (p, true) => {
                let d = sub(p, x);
                let d = dot(d, d).sqrt();
                // Newton can land on a far branch: never report more than
                // the first-order estimate allows by a wide margin
                if d.is_finite() { d.min(4.0 * first_order) } else { first_order }
            }
            (_, false) => first_order,
        }
    }
}

impl<const D: usize> ClosestPoint<D> for LevelSet {
    fn closest_point(&self, p: [f64; D]) -> [f64; D] {
        project_level_set(|x| self.eval_gradient(x), p, &ONTO).0
    }

    fn normal(&self, p: [f64; D]) -> [f64; D] {
        unit(self.eval_gradient(self.closest_point(p)).1)
    }

    /// Brackets the first sign change of φ along the ray on a doubling grid
    /// (φ's gradient may vanish at the origin, a centre), then bisects.
    fn ray_hit(&self, origin: [f64; D], dir: [f64; D]) -> Option<[f64; D]> {
        let at = |s: f64| -> [f64; D] { std::array::from_fn(|k| origin[k] + s * dir[k]) };
        let sign = self.eval(origin).signum();
        let (mut lo, mut s) = (0.0, 1e-6);
        for _ in 0..70 {
            let v = self.eval(at(s));
            if v == 0.0 {
                return Some(at(s));
            }
            if v.signum() != sign {
                // σφ is positive at lo and negative at s: bisect it.
                let mut hi = s;
                return Some(at(bisect_decreasing(&|s| sign * self.eval(at(s)), &mut lo, &mut hi)));
            }
            lo = s;
            s *= 2.0;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The variables of [`crate::jacobian::EXPR_VARS`], written out: the
    /// geometry does not depend on the prescribed Jacobians.
    const VARS: [&str; 4] = ["x", "y", "z", "t"];

    fn level_set(text: &str) -> LevelSet {
        LevelSet::new(Expr::parse(text, &VARS).unwrap()).unwrap()
    }

    #[test]
    fn level_set_projects_onto_a_circle_and_hits_it() {
        let ls = level_set("x^2 + y^2 - 0.25");
        for p in [[0.6, 0.1], [0.3, -0.2], [-0.51, 0.0]] {
            let q = ClosestPoint::<2>::closest_point(&ls, p);
            assert!((q[0].hypot(q[1]) - 0.5).abs() < 1e-14, "{q:?}");
            // Newton's foot point lies on the ray through the centre here
            assert!((q[1] * p[0] - q[0] * p[1]).abs() < 1e-8);
            let n = ClosestPoint::<2>::normal(&ls, p);
            assert!((n[0] - q[0] / 0.5).abs() < 1e-6 && (n[1] - q[1] / 0.5).abs() < 1e-6, "{n:?}");
        }
        let hit = ClosestPoint::<2>::ray_hit(&ls, [0.0, 0.0], [1.0, 1.0]).unwrap();
        assert!((hit[0] - 0.5 / 2f64.sqrt()).abs() < 1e-12);
        assert!(ClosestPoint::<2>::ray_hit(&ls, [1.0, 0.0], [1.0, 0.0]).is_none());
    }

    /// Points about a surface: `centre + r (cos a cos b, sin a cos b, sin b)`
    /// for radii `r` and a spread of angles (deterministic).
    fn around(radii: &[f64]) -> Vec<[f64; 3]> {
        let mut out = Vec::new();
        for &r in radii {
            for i in 0..7 {
                for j in 0..5 {
                    let (a, b) = (0.3 + 0.9 * i as f64, -1.2 + 0.55 * j as f64);
                    out.push([r * a.cos() * b.cos(), r * a.sin() * b.cos(), r * b.sin()]);
                }
            }
        }
        out
    }

    fn assert_close(what: &str, got: [f64; 3], want: [f64; 3], tol: f64) {
        let d = crate::numeric::norm(sub(got, want));
        assert!(d <= tol, "{what}: {got:?} vs {want:?} ({d:e})");
    }

    #[test]
    fn projections_onto_a_sphere_cylinder_and_torus_are_the_exact_closest_points() {
        // sphere of radius 0.8 about (0.1, -0.2, 0.3)
        let c = [0.1, -0.2, 0.3];
        let sphere = level_set("(x - 0.1)^2 + (y + 0.2)^2 + (z - 0.3)^2 - 0.64");
        for d in around(&[0.55, 0.79, 0.8, 0.83, 1.2]) {
            let p = [c[0] + d[0], c[1] + d[1], c[2] + d[2]];
            let r = crate::numeric::norm(d);
            let exact = std::array::from_fn(|k| c[k] + 0.8 * d[k] / r);
            assert_close("sphere", ClosestPoint::<3>::closest_point(&sphere, p), exact, 1e-12);
            assert_close("sphere normal", ClosestPoint::<3>::normal(&sphere, p), d.map(|v| v / r), 1e-12);
        }
        // the cylinder x² + y² = 1/4 (the hollow cylinder's inner wall)
        let cylinder = level_set("x^2 + y^2 - 0.25");
        for p in around(&[0.3, 0.48, 0.5, 0.52, 0.9]) {
            let r = p[0].hypot(p[1]);
            let exact = [0.5 * p[0] / r, 0.5 * p[1] / r, p[2]];
            assert_close("cylinder", ClosestPoint::<3>::closest_point(&cylinder, p), exact, 1e-12);
            assert_close("cylinder normal", ClosestPoint::<3>::normal(&cylinder, p), [p[0] / r, p[1] / r, 0.0], 1e-12);
        }
        // the torus R = 1, r = 0.5 about the z axis
        let torus = level_set("(sqrt(x^2 + y^2) - 1)^2 + z^2 - 0.25");
        for (i, q) in around(&[1.0]).into_iter().enumerate() {
            // a point at distance rho from the tube's centre circle
            let rho = [0.2, 0.45, 0.5, 0.55, 0.8][i % 5];
            let (a, b) = (q[1].atan2(q[0]), 0.7 * i as f64);
            let centre = [a.cos(), a.sin(), 0.0];
            let dir = [a.cos() * b.cos(), a.sin() * b.cos(), b.sin()];
            let p = std::array::from_fn(|k| centre[k] + rho * dir[k]);
            let exact = std::array::from_fn(|k| centre[k] + 0.5 * dir[k]);
            assert_close("torus", ClosestPoint::<3>::closest_point(&torus, p), exact, 1e-12);
            assert_close("torus normal", ClosestPoint::<3>::normal(&torus, p), dir, 1e-12);
            assert!((ClosestPoint::<3>::distance(&torus, p) - (rho - 0.5).abs()).abs() < 1e-12);
        }
    }

    /// Newton's projection as it was before the exact gradient: ∇φ by
    /// central differences of step 1e-7 (1 + max |x_k|), seven evaluations
    /// per iteration. The reference the new projection must agree with.
    fn central_difference_projection(ls: &LevelSet, x: [f64; 3]) -> [f64; 3] {
        let grad = |p: [f64; 3]| -> [f64; 3] {
            let h = 1e-7 * (1.0 + p.iter().fold(0.0f64, |m, v| m.max(v.abs())));
            std::array::from_fn(|k| {
                let (mut a, mut b) = (p, p);
                a[k] += h;
                b[k] -= h;
                (ls.eval(a) - ls.eval(b)) / (2.0 * h)
            })
        };
        let mut p = x;
        for _ in 0..50 {
            let (v, g) = (ls.eval(p), grad(p));
            let step = g.map(|gk| v * gk / dot(g, g));
            p = std::array::from_fn(|k| p[k] - step[k]);
            if dot(step, step).sqrt() <= 1e-15 * (1.0 + dot(p, p).sqrt()) {
                break;
            }
        }
        p
    }

    #[test]
    fn projections_agree_with_the_central_difference_newton() {
        // they differ by the central differences' error in the direction
        // of ∇φ times the distance travelled (measured: at most 6.2e-10 of
        // it; 2.4e-12 for a point 4e-3 off the wall)
        let ellipsoid = level_set("x^2 + 2*y^2 + 3*z^2 + 0.2*x*y - 1");
        let blob = level_set("x^2 + y^2 + z^2 + 0.1*sin(3*x)*cos(2*y) + 0.05*exp(z) - 1");
        for ls in [&ellipsoid, &blob] {
            for p in around(&[0.97, 1.0, 1.03]) {
                let (new, old) = (ClosestPoint::<3>::closest_point(ls, p), central_difference_projection(ls, p));
                assert!(ls.eval(new).abs() < 1e-15, "{p:?}: φ = {:e}", ls.eval(new));
                let travelled = crate::numeric::norm(sub(new, p));
                assert_close("against central differences", new, old, 1e-12 + 2e-9 * travelled);
            }
        }
    }

    #[test]
    fn a_projection_takes_few_evaluations() {
        use std::cell::Cell;
        let ls = level_set("x^2 + y^2 - 0.25");
        let calls = Cell::new(0);
        let counted = |p: [f64; 3]| {
            calls.set(calls.get() + 1);
            ls.eval_gradient(p)
        };
        // a node 2 % of the radius off the wall: quadratic convergence,
        // 1e-2 → 1e-4 → 1e-8 → 1e-16, and one step to see it has stopped
        let (q, converged) = project_level_set(counted, [0.51, 0.0, 0.2], &ONTO);
        assert!(converged && (q[0] - 0.5).abs() < 1e-15 && q[1] == 0.0 && q[2] == 0.2, "{q:?}");
        assert!(calls.get() <= 6, "{} evaluations", calls.get());
        // on the wall: one evaluation
        calls.set(0);
        let (q, converged) = project_level_set(counted, [0.0, 0.5, 0.0], &ONTO);
        assert!(converged && q == [0.0, 0.5, 0.0] && calls.get() == 1);
        // where ∇φ vanishes: no step, not converged
        let (q, converged) = project_level_set(|p| ls.eval_gradient(p), [0.0, 0.0, 0.3], &ONTO);
        assert!(!converged && q == [0.0, 0.0, 0.3]);
    }

    #[test]
    fn a_level_set_may_not_use_t() {
        let e = LevelSet::new(Expr::parse("x - t", &VARS).unwrap()).unwrap_err();
        assert!(e.contains("may not use t"), "{e}");
    }

    #[test]
    fn band_distance_is_exact_for_a_circle_and_capped_far_away() {
        let phi = level_set("(x - 0.5)^2 + (y - 0.5)^2 - 0.09");
        for p in [[0.5, 0.9, 0.0], [0.1, 0.2, 0.0], [0.55, 0.52, 0.0], [0.8, 0.5, 0.0]] {
            let exact = ((p[0] - 0.5f64).hypot(p[1] - 0.5) - 0.3).abs();
            let d = phi.band_distance(p, f64::INFINITY);
            assert!((d - exact).abs() < 1e-12, "{p:?}: {d} vs {exact}");
        }
        // beyond `far` the first-order estimate |φ|/|∇φ| comes back
        let p = [3.0, 0.5, 0.0];
        let fo = (2.5f64 * 2.5 - 0.09) / 5.0;
        assert!((phi.band_distance(p, 1.0) - fo).abs() < 1e-6);
        // at the centre ∇φ = 0: no projection, no NaN
        assert!(phi.band_distance([0.5, 0.5, 0.0], f64::INFINITY).is_infinite());
        // where φ is undefined: NaN, to be reported
        assert!(level_set("sqrt(x) - 1").band_distance([-1.0, 0.0, 0.0], f64::INFINITY).is_nan());
    }
}
