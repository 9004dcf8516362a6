//! Level sets: the zero set of a function φ(x, y, z) as a curve (2D) or a
//! surface (3D), for walls that no spec describes and for interfaces of a
//! prescribed Jacobian.

use super::solvers::{bisect_decreasing, central_gradient, project_level_set, Newton};
use super::ClosestPoint;
use crate::expr::Expr;
use crate::numeric::{dot, sub, unit};

/// Newton's projection for putting mesh nodes onto the zero set: run to
/// round-off, as a node on a wall should be.
const ONTO: Newton = Newton { h_rel: 1e-7, iterations: 50, tol: 1e-15 };

/// Newton's projection for the distances of an interface band: g₁ needs
/// them to far less than round-off, at every quadrature point of every
/// step, so fewer and cheaper iterations.
const BAND: Newton = Newton { h_rel: 1e-6, iterations: 30, tol: 1e-13 };

/// {φ = 0} for φ an expression in x, y, z (variables
/// [`crate::jacobian::EXPR_VARS`]; t must not occur, a shape does not move).
/// Its closest point is Newton's foot point from the point itself, its
/// normal the direction of ∇φ there.
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

    /// Distance from `x` to the zero set for an interface band: Newton's
    /// projection from `x`, then the length travelled. Where that does not
    /// converge (a critical point of φ, say), the first-order estimate
    /// |φ|/|∇φ| stands in, which is what the band needs far from the
    /// interface anyway. Where that estimate exceeds `far`, it is returned
    /// without projecting: the band has vanished there, and the projection
    /// is the costly part. NaN where φ is not finite at `x`, so that a bad
    /// φ is reported rather than a band silently absent.
    pub fn band_distance(&self, x: [f64; 3], far: f64) -> f64 {
        let phi = |p: [f64; 3]| self.eval(p);
        let v0 = phi(x);
        let g0 = central_gradient(&phi, x, BAND.h_rel);
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
        match project_level_set(&phi, x, &BAND) {
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
        project_level_set(&|x| self.eval(x), p, &ONTO).0
    }

    fn normal(&self, p: [f64; D]) -> [f64; D] {
        unit(central_gradient(&|x| self.eval(x), self.closest_point(p), ONTO.h_rel))
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
            assert!((d - exact).abs() < 1e-9, "{p:?}: {d} vs {exact}");
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
