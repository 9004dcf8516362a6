//! Round shapes: circles and arcs (2D), spheres and cylinders (3D).

use super::ray_s_min;
use super::solvers::unit_ball_roots;
use crate::numeric::{add, dist2, dot, norm, scale, sub, unit};
use std::f64::consts::TAU;

/// A circle (`D` = 2) or sphere (`D` = 3): the same projections and ray
/// intersections in either dimension.
#[derive(Debug, Clone)]
pub(super) struct Ball<const D: usize> {
    pub(super) centre: [f64; D],
    pub(super) radius: f64,
}

/// A full circle.
pub(super) type Circle = Ball<2>;

/// A sphere.
pub(super) type Sphere = Ball<3>;

impl<const D: usize> Ball<D> {
    /// Radial projection; the centre itself maps to the point along +x.
    pub(super) fn closest(&self, p: [f64; D]) -> [f64; D] {
        let v = sub(p, self.centre);
        let len = norm(v);
        if len == 0.0 {
            let mut x = [0.0; D];
            x[0] = self.radius;
            return add(self.centre, x);
        }
        add(self.centre, scale(self.radius / len, v))
    }

    /// Outward normal at a point on the ball's surface.
    pub(super) fn normal_at(&self, q: [f64; D]) -> [f64; D] {
        unit(sub(q, self.centre))
    }

    /// The ray's crossings in increasing `s` (both `s > 0` beyond
    /// round-off), projected onto the surface.
    pub(super) fn ray_hits(&self, origin: [f64; D], dir: [f64; D]) -> [Option<[f64; D]>; 2] {
        let s_min = ray_s_min(origin, dir, self.centre, self.radius);
        let Some((s1, s2)) = unit_ball_roots(scale(1.0 / self.radius, sub(origin, self.centre)), scale(1.0 / self.radius, dir)) else {
            return [None, None];
        };
        let hit = |s: f64| (s > s_min).then(|| self.closest(add(origin, scale(s, dir))));
        [hit(s1), hit(s2)]
    }

    /// The ray's first crossing.
    pub(super) fn ray_hit(&self, origin: [f64; D], dir: [f64; D]) -> Option<[f64; D]> {
        self.ray_hits(origin, dir).into_iter().flatten().next()
    }
}

/// Circular arc from angle `start` sweeping counter-clockwise by `sweep`.
#[derive(Debug, Clone)]
pub(super) struct Arc {
    pub(super) circle: Circle,
    pub(super) start: f64,
    pub(super) sweep: f64,
    ends: [[f64; 2]; 2],
}

impl Arc {
    /// Angle slack when testing whether a ray's circle hit is on the arc,
    /// so that hits exactly at an end are not lost to round-off.
    const ANGLE_TOL: f64 = 1e-14;

    pub(super) fn new(circle: Circle, start_deg: f64, end_deg: f64) -> Arc {
        let mut sweep = (end_deg - start_deg).rem_euclid(360.0);
        if sweep == 0.0 {
            sweep = 360.0; // the ends differ by whole turns: a full circle
        }
        let start = start_deg.to_radians();
        let sweep = sweep.to_radians();
        let at = |a: f64| {
            add(
                circle.centre,
                [circle.radius * a.cos(), circle.radius * a.sin()],
            )
        };
        let ends = [at(start), at(start + sweep)];
        Arc {
            circle,
            start,
            sweep,
            ends,
        }
    }

    /// Counter-clockwise angle of `v` from the arc's start, in [0, 2π).
    fn relative_angle(&self, v: [f64; 2]) -> f64 {
        (v[1].atan2(v[0]) - self.start).rem_euclid(TAU)
    }

    pub(super) fn closest(&self, p: [f64; 2]) -> [f64; 2] {
        let v = sub(p, self.circle.centre);
        if v == [0.0, 0.0] {
            return self.ends[0]; // every arc point is equally close
        }
        if self.relative_angle(v) <= self.sweep {
            return self.circle.closest(p);
        }
        // Outside the arc's angular range the distance grows monotonically
        // with the angle away from each end, so the nearer end wins.
        let [a, b] = self.ends;
        if dist2(p, a) <= dist2(p, b) {
            a
        } else {
            b
        }
    }

    pub(super) fn ray_hit(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<[f64; 2]> {
        self.circle
            .ray_hits(origin, dir)
            .into_iter()
            .flatten()
            .find(|q| {
                let u = self.relative_angle(sub(*q, self.circle.centre));
                u <= self.sweep + Self::ANGLE_TOL || u >= TAU - Self::ANGLE_TOL
            })
    }
}
/// Infinite circular cylinder about the line through `point` along unit
/// `axis`.
#[derive(Debug, Clone)]
pub(super) struct Cylinder {
    pub(super) point: [f64; 3],
    pub(super) axis: [f64; 3],
    pub(super) radius: f64,
}

impl Cylinder {
    /// Splits `p − point` into its component along the axis and the rest.
    pub(super) fn split(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let v = sub(p, self.point);
        let t = dot(v, self.axis);
        (t, sub(v, scale(t, self.axis)))
    }

    /// Radial projection away from the axis; points on the axis go in an
    /// arbitrary (but fixed) perpendicular direction.
    pub(super) fn closest(&self, p: [f64; 3]) -> [f64; 3] {
        let (t, perp) = self.split(p);
        let len = norm(perp);
        let dir = if len == 0.0 {
            orthonormal_basis(self.axis).0
        } else {
            scale(1.0 / len, perp)
        };
        add(
            self.point,
            add(scale(t, self.axis), scale(self.radius, dir)),
        )
    }

    pub(super) fn normal_at(&self, q: [f64; 3]) -> [f64; 3] {
        unit(self.split(q).1)
    }

    pub(super) fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        // Only the components across the axis matter; scaled by the radius
        // the cross-section is the unit circle and `s` is unchanged.
        let (_, o) = self.split(origin);
        let d = sub(dir, scale(dot(dir, self.axis), self.axis));
        let k = 1.0 / self.radius;
        let (s1, s2) = unit_ball_roots(scale(k, o), scale(k, d))?;
        let s_min = ray_s_min(
            origin,
            dir,
            add(
                self.point,
                scale(dot(sub(origin, self.point), self.axis), self.axis),
            ),
            self.radius,
        );
        let s = [s1, s2].into_iter().find(|s| *s > s_min)?;
        Some(self.closest(add(origin, scale(s, dir))))
    }
}
/// Two unit vectors completing unit `n` to an orthonormal basis, without a
/// branch on the nearest axis (Duff et al., "Building an orthonormal basis,
/// revisited", 2017).
pub(super) fn orthonormal_basis(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let s = 1.0f64.copysign(n[2]);
    let a = -1.0 / (s + n[2]);
    let b = n[0] * n[1] * a;
    (
        [1.0 + s * n[0] * n[0] * a, s * b, -s * n[0]],
        [b, s + n[1] * n[1] * a, -n[1]],
    )
}
