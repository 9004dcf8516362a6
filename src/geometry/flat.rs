//! Flat shapes: the infinite line (2D) and plane (3D).

use super::ray_s_min;
use crate::numeric::{add, cross2, dot, norm, rot_cw, scale, sub, unit};

/// Infinite line through `from` with unit direction `dir`.
#[derive(Debug, Clone)]
pub(super) struct Line {
    pub(super) from: [f64; 2],
    pub(super) dir: [f64; 2],
    pub(super) normal: [f64; 2],
    length: f64,
}

impl Line {
    pub(super) fn new(from: [f64; 2], to: [f64; 2]) -> Line {
        let dir = unit(sub(to, from));
        Line {
            from,
            dir,
            normal: rot_cw(dir),
            length: norm(sub(to, from)),
        }
    }

    pub(super) fn closest(&self, p: [f64; 2]) -> [f64; 2] {
        add(self.from, scale(dot(sub(p, self.from), self.dir), self.dir))
    }

    pub(super) fn ray_hit(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<[f64; 2]> {
        let denom = cross2(dir, self.dir);
        if denom == 0.0 {
            return None; // parallel (or along the line): no single crossing
        }
        let s = cross2(sub(self.from, origin), self.dir) / denom;
        let s_min = ray_s_min(origin, dir, self.from, self.length);
        // Project the hit so it lies on the line to machine precision.
        (s > s_min).then(|| self.closest(add(origin, scale(s, dir))))
    }
}
/// Infinite plane through `point` with unit `normal`.
#[derive(Debug, Clone)]
pub(super) struct Plane {
    pub(super) point: [f64; 3],
    pub(super) normal: [f64; 3],
}

impl Plane {
    pub(super) fn closest(&self, p: [f64; 3]) -> [f64; 3] {
        sub(p, scale(dot(sub(p, self.point), self.normal), self.normal))
    }

    pub(super) fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        let denom = dot(dir, self.normal);
        if denom == 0.0 {
            return None; // parallel (or within the plane): no single crossing
        }
        let s = dot(sub(self.point, origin), self.normal) / denom;
        let s_min = ray_s_min(origin, dir, self.point, 0.0);
        // Project the hit so it lies on the plane to machine precision.
        (s > s_min).then(|| self.closest(add(origin, scale(s, dir))))
    }
}
