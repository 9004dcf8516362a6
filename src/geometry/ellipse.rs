//! Ellipses (2D, any orientation) and axis-aligned ellipsoids (3D), both
//! projected with Eberly's method ([`closest_on_axis_ellipsoid`]).

use super::ray_s_min;
use super::solvers::{closest_on_axis_ellipsoid, unit_ball_roots};
use crate::numeric::{add, rotate, scale, sub, unit};

/// Ellipse with semi-axes `a` (along angle `angle`) and `b`.
#[derive(Debug, Clone)]
pub(super) struct Ellipse {
    pub(super) centre: [f64; 2],
    pub(super) a: f64,
    pub(super) b: f64,
    cos: f64,
    sin: f64,
}

impl Ellipse {
    pub(super) fn new(centre: [f64; 2], semi_axes: [f64; 2], angle_deg: f64) -> Ellipse {
        let (sin, cos) = angle_deg.to_radians().sin_cos();
        Ellipse {
            centre,
            a: semi_axes[0],
            b: semi_axes[1],
            cos,
            sin,
        }
    }

    fn to_local(&self, p: [f64; 2]) -> [f64; 2] {
        rotate(sub(p, self.centre), self.cos, -self.sin)
    }

    pub(super) fn to_world(&self, q: [f64; 2]) -> [f64; 2] {
        add(self.centre, rotate(q, self.cos, self.sin))
    }

    /// The local point at the eccentric angle of local `q`: snaps a nearly
    /// on-curve point exactly onto the curve.
    fn snap_local(&self, q: [f64; 2]) -> [f64; 2] {
        let (s, c) = (q[1] / self.b).atan2(q[0] / self.a).sin_cos();
        [self.a * c, self.b * s]
    }

    /// Closest point and outward unit normal there.
    pub(super) fn closest(&self, p: [f64; 2]) -> ([f64; 2], [f64; 2]) {
        let q = self.to_local(p);
        let x = self.snap_local(closest_on_axis_ellipsoid([self.a, self.b], q));
        let n = unit([x[0] / (self.a * self.a), x[1] / (self.b * self.b)]);
        (self.to_world(x), rotate(n, self.cos, self.sin))
    }

    pub(super) fn ray_hit(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<[f64; 2]> {
        // In coordinates scaled by the semi-axes the ellipse is the unit
        // circle and the ray parameter s is unchanged.
        let (o, d) = (self.to_local(origin), rotate(dir, self.cos, -self.sin));
        let stretch = |v: [f64; 2]| [v[0] / self.a, v[1] / self.b];
        let (s1, s2) = unit_ball_roots(stretch(o), stretch(d))?;
        let s_min = ray_s_min(origin, dir, self.centre, self.a.max(self.b));
        let s = [s1, s2].into_iter().find(|s| *s > s_min)?;
        // Project the world-space hit back onto the curve: projecting along
        // the normal moves it less across the ray than snapping the angle in
        // stretched coordinates, which matters for flat ellipses.
        Some(self.closest(add(origin, scale(s, dir))).0)
    }
}

/// Axis-aligned ellipsoid.
#[derive(Debug, Clone)]
pub(super) struct Ellipsoid {
    pub(super) centre: [f64; 3],
    pub(super) semi_axes: [f64; 3],
}

impl Ellipsoid {
    /// Closest point: Eberly's bisection in local coordinates, then a radial
    /// rescale onto `Σ (x/e)² = 1` so the result is on the surface to the
    /// last bit (the rescale moves it by round-off only).
    pub(super) fn closest(&self, p: [f64; 3]) -> [f64; 3] {
        let e = self.semi_axes;
        let x = closest_on_axis_ellipsoid(e, sub(p, self.centre));
        let level = (0..3).map(|k| (x[k] / e[k]).powi(2)).sum::<f64>().sqrt();
        add(self.centre, scale(1.0 / level, x))
    }

    /// Outward normal at a point on the ellipsoid: the implicit gradient.
    pub(super) fn normal_at(&self, q: [f64; 3]) -> [f64; 3] {
        let x = sub(q, self.centre);
        let e = self.semi_axes;
        unit([
            x[0] / (e[0] * e[0]),
            x[1] / (e[1] * e[1]),
            x[2] / (e[2] * e[2]),
        ])
    }

    pub(super) fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        // In coordinates scaled by the semi-axes the ellipsoid is the unit
        // sphere and the ray parameter s is unchanged.
        let e = self.semi_axes;
        let stretch = |v: [f64; 3]| [v[0] / e[0], v[1] / e[1], v[2] / e[2]];
        let (s1, s2) = unit_ball_roots(stretch(sub(origin, self.centre)), stretch(dir))?;
        let size = e[0].max(e[1]).max(e[2]);
        let s_min = ray_s_min(origin, dir, self.centre, size);
        let s = [s1, s2].into_iter().find(|s| *s > s_min)?;
        // Project the world-space hit back onto the surface along its
        // normal: it moves less across the ray than rescaling in stretched
        // coordinates, which matters for flat ellipsoids.
        Some(self.closest(add(origin, scale(s, dir))))
    }
}

