//! Surfaces of revolution `r = R(z)` about a vertical axis, `R` an
//! expression in z.

use super::solvers::{brent_min, brent_root, first_crossing, unit_ball_roots};
use super::{ray_s_min, GeometryError, Validator};
use crate::expr::Expr;
use crate::numeric::{add, dot, norm, scale, unit, EPS};

/// Intervals of the z sampling of a surface of revolution: the radius
/// expression is checked for positivity at these samples, and they bracket
/// the numeric closest-point and ray searches.
const REVOLUTION_SAMPLES: usize = 4096;

/// Lateral surface `r = R(z)`, `z0 ≤ z ≤ z1`, about the vertical line through
/// `axis`. Points are `(axis + R(z)(cos θ, sin θ), z)`; every query reduces
/// to the meridian half-plane `(r, z)` of the query point.
#[derive(Debug, Clone)]
pub(super) struct Revolution {
    pub(super) radius: Expr,
    pub(super) axis: [f64; 2],
    pub(super) z0: f64,
    pub(super) z1: f64,
    /// `z` at the sample points, `z0` to `z1` inclusive.
    pub(super) zs: Vec<f64>,
    /// `R` at the sample points.
    pub(super) rs: Vec<f64>,
    /// Largest sampled radius.
    pub(super) r_max: f64,
}

/// A point of a surface of revolution: height and the direction of its
/// meridian half-plane.
#[derive(Debug, Clone, Copy)]
pub(super) struct Meridian {
    pub(super) z: f64,
    pub(super) cos: f64,
    pub(super) sin: f64,
}

impl Revolution {
    pub(super) fn new(
        v: &Validator,
        text: &str,
        z_range: [f64; 2],
        axis: [f64; 2],
    ) -> Result<Revolution, GeometryError> {
        v.finite_point("axis_point", axis)?;
        v.finite_point("z_range", z_range)?;
        let [z0, z1] = z_range;
        if z0 >= z1 {
            return Err(v.error(
                "z_range",
                format!("must be increasing, [z0, z1] with z0 < z1 (got {z_range:?})"),
            ));
        }
        let radius = Expr::parse(text, &["z"])
            .map_err(|e| v.error("radius", format!("is not a valid expression in z: {e}")))?;
        let n = REVOLUTION_SAMPLES;
        let zs: Vec<f64> = (0..=n)
            .map(|k| {
                if k == n {
                    z1
                } else {
                    z0 + (z1 - z0) * k as f64 / n as f64
                }
            })
            .collect();
        let mut rs = Vec::with_capacity(zs.len());
        for &z in &zs {
            let r = radius.eval(&[z]);
            if !(r > 0.0 && r.is_finite()) {
                let reason = format!("must be finite and > 0 on z_range (got R = {r} at z = {z})");
                return Err(v.error("radius", reason));
            }
            rs.push(r);
        }
        let r_max = rs.iter().copied().fold(0.0, f64::max);
        Ok(Revolution {
            radius,
            axis,
            z0,
            z1,
            zs,
            rs,
            r_max,
        })
    }

    pub(super) fn r(&self, z: f64) -> f64 {
        self.radius.eval(&[z])
    }

    /// `R'(z)` by differentiating the quartic through five samples `h`
    /// apart, shifted to stay inside `[z0, z1]` (the expression need not be
    /// valid outside). Accurate to ~1e-12 relative for smooth `R`.
    pub(super) fn dr(&self, z: f64) -> f64 {
        let h = 1e-3 * (self.z1 - self.z0);
        let zc = z.clamp(self.z0 + 2.0 * h, self.z1 - 2.0 * h);
        let t = (z - zc) / h;
        let nodes = [-2.0, -1.0, 0.0, 1.0, 2.0];
        let mut sum = 0.0;
        for (k, &xk) in nodes.iter().enumerate() {
            // Derivative at t of the Lagrange basis polynomial of node k.
            let mut lk = 0.0;
            for (m, &xm) in nodes.iter().enumerate() {
                if m == k {
                    continue;
                }
                let mut prod = 1.0 / (xk - xm);
                for (l, &xl) in nodes.iter().enumerate() {
                    if l != k && l != m {
                        prod *= (t - xl) / (xk - xl);
                    }
                }
                lk += prod;
            }
            sum += self.r(zc + xk * h) * lk;
        }
        sum / h
    }

    pub(super) fn size(&self) -> f64 {
        (self.z1 - self.z0).max(self.r_max)
    }

    /// Distance from the axis and meridian direction of `p` (the +x
    /// direction when `p` is on the axis).
    pub(super) fn polar(&self, p: [f64; 3]) -> (f64, f64, f64) {
        let (x, y) = (p[0] - self.axis[0], p[1] - self.axis[1]);
        let rho = x.hypot(y);
        if rho == 0.0 {
            (0.0, 1.0, 0.0)
        } else {
            (rho, x / rho, y / rho)
        }
    }

    pub(super) fn point(&self, m: Meridian) -> [f64; 3] {
        let r = self.r(m.z);
        [self.axis[0] + r * m.cos, self.axis[1] + r * m.sin, m.z]
    }

    pub(super) fn normal_at(&self, m: Meridian) -> [f64; 3] {
        // The meridian (R(z), z) has tangent (R', 1); rotated away from the
        // axis, (1, −R').
        unit([m.cos, m.sin, -self.dr(m.z)])
    }

    /// Closest point in the meridian half-plane of `p`: minimise
    /// `h(z) = (ρ − R(z))² + (z_p − z)²` over `[z0, z1]`. The samples give
    /// the best few local minima (and the range ends as candidates); each
    /// is refined as the sign change of `h'/2 = (R − ρ)R' + (z − z_p)`,
    /// which pins `z` down far better than minimising `h` itself, falling
    /// back to Brent's minimiser where the bracket shows no such change.
    pub(super) fn closest_param(&self, p: [f64; 3]) -> Meridian {
        let (rho, cos, sin) = self.polar(p);
        let zp = p[2];
        let h = |z: f64| (rho - self.r(z)).powi(2) + (zp - z).powi(2);
        let hs: Vec<f64> = self
            .zs
            .iter()
            .zip(&self.rs)
            .map(|(&z, &r)| (rho - r).powi(2) + (zp - z).powi(2))
            .collect();
        let mut best = if hs[0] <= hs[hs.len() - 1] {
            (self.z0, hs[0])
        } else {
            (self.z1, hs[hs.len() - 1])
        };
        for i in best_local_minima(&hs) {
            let (lo, hi) = (
                self.zs[i.saturating_sub(1)],
                self.zs[(i + 1).min(hs.len() - 1)],
            );
            let z = self.refine_meridian(rho, zp, lo, hi);
            let hz = h(z);
            if hz < best.1 {
                best = (z, hz);
            }
        }
        // A minimum at an end is approached but never evaluated by the
        // refinement, which may then beat the exact end by round-off only:
        // snap to the end, so end-circle points are exactly on it.
        let snap = 8.0 * EPS * (self.z0.abs().max(self.z1.abs()) + self.size());
        let z = if best.0 - self.z0 <= snap {
            self.z0
        } else if self.z1 - best.0 <= snap {
            self.z1
        } else {
            best.0
        };
        Meridian { z, cos, sin }
    }

    pub(super) fn refine_meridian(&self, rho: f64, zp: f64, lo: f64, hi: f64) -> f64 {
        let g = |z: f64| (self.r(z) - rho) * self.dr(z) + (z - zp);
        let (glo, ghi) = (g(lo), g(hi));
        if glo < 0.0 && ghi > 0.0 {
            return brent_root(&g, lo, hi, glo, ghi);
        }
        // h' = 2g keeps one sign on the bracket: the minimum is at an end
        // (typically the surface's end circle), which a minimiser would
        // only approach to about √ε
        if glo <= 0.0 && ghi <= 0.0 {
            return hi;
        }
        if glo >= 0.0 && ghi >= 0.0 {
            return lo;
        }
        let h = |z: f64| (rho - self.r(z)).powi(2) + (zp - z).powi(2);
        brent_min(&h, lo, hi, EPS * self.size()).0
    }

    pub(super) fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        let (lo, hi) = self.ray_window(origin, dir)?;
        let o = [origin[0] - self.axis[0], origin[1] - self.axis[1]];
        let at = |s: f64| {
            let z = (origin[2] + s * dir[2]).clamp(self.z0, self.z1);
            ((o[0] + s * dir[0]).hypot(o[1] + s * dir[1]), z)
        };
        let f = |s: f64| {
            let (rho, z) = at(s);
            rho - self.r(z)
        };
        // Sample finely enough to follow R's z samples and to resolve the
        // cross-section's scale across the axis.
        let span_z = (hi - lo) * dir[2].abs() / (self.z1 - self.z0);
        let span_r = (hi - lo) * dir[0].hypot(dir[1]) / self.r_max;
        let count = (64.0 + REVOLUTION_SAMPLES as f64 * span_z + 256.0 * span_r).min(16384.0);
        let s = first_crossing(&f, lo, hi, count as usize)?;
        let hit = add(origin, scale(s, dir));
        let (_, cos, sin) = self.polar(hit);
        Some(self.point(Meridian {
            z: at(s).1,
            cos,
            sin,
        }))
    }

    /// The range of ray parameters `s > s_min` where the ray is inside the
    /// slab `z0 ≤ z ≤ z1` and close enough to the axis to meet the surface
    /// (within a margin over the largest sampled radius).
    pub(super) fn ray_window(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<(f64, f64)> {
        let reference = [self.axis[0], self.axis[1], 0.5 * (self.z0 + self.z1)];
        let mut lo = ray_s_min(origin, dir, reference, self.size());
        let mut hi = f64::INFINITY;
        if dir[2] == 0.0 {
            if origin[2] < self.z0 || origin[2] > self.z1 {
                return None;
            }
        } else {
            let (s1, s2) = (
                (self.z0 - origin[2]) / dir[2],
                (self.z1 - origin[2]) / dir[2],
            );
            lo = lo.max(s1.min(s2));
            hi = hi.min(s1.max(s2));
        }
        let bound = 1.05 * self.r_max;
        let o = [origin[0] - self.axis[0], origin[1] - self.axis[1], 0.0];
        let d = [dir[0], dir[1], 0.0];
        if dot(d, d) == 0.0 {
            if norm(o) > bound {
                return None;
            }
        } else {
            let (s1, s2) = unit_ball_roots(scale(1.0 / bound, o), scale(1.0 / bound, d))?;
            lo = lo.max(s1);
            hi = hi.min(s2);
        }
        (lo < hi && hi.is_finite()).then_some((lo, hi))
    }
}

/// Indices of up to three smallest local minima of `values` (ties with a
/// neighbour count), smallest first.
fn best_local_minima(values: &[f64]) -> Vec<usize> {
    let n = values.len();
    let mut top: Vec<usize> = Vec::with_capacity(4);
    for i in 0..n {
        let left = i == 0 || values[i] <= values[i - 1];
        let right = i + 1 == n || values[i] <= values[i + 1];
        if left && right {
            top.push(i);
            top.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
            top.truncate(3);
        }
    }
    top
}
