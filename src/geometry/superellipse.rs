//! Superellipses `|x/a|^n + |y/b|^n = 1` (2D) and superquadrics
//! `|x/a|^n + |y/b|^n + |z/c|^n = 1` (3D): star-shaped about their centre,
//! rounded boxes for large n, with creases and spikes for n < 1.

use super::parametric::{ray_param, Param, Samples};
use super::ray_s_min;
use super::round::orthonormal_basis;
use super::solvers::{brent_min, first_crossing};
use crate::numeric::{add, dist2, dot, norm, rot_ccw, scale, sub, unit, EPS};
use std::f64::consts::TAU;

/// Cells per cube face of the direction grid whose surface points seed the
/// superquadric closest-point search (6·(m+1)² seeds).
const SUPERQUADRIC_SEED_CELLS: usize = 12;

/// Samples along the crease curves of a superquadric with exponent ≤ 1.
const CREASE_SAMPLES: usize = 128;

/// Samples along a ray's chord through the superquadric's bounding box when
/// bracketing its first crossing numerically.
const SUPERQUADRIC_RAY_SAMPLES: usize = 512;

/// The gauge `N(w) = (Σ |w_k/a_k|^n)^(1/n)` in `D` dimensions, whose unit
/// level set is the superellipse (`D` = 2) or the superquadric (`D` = 3).
/// It is positively homogeneous of degree 1, so `w / N(w)` projects any
/// non-zero local vector radially onto the shape: the parametrisation
/// every numeric query evaluates, so results are on the shape to machine
/// precision.
#[derive(Debug, Clone)]
pub(super) struct Gauge<const D: usize> {
    /// The semi-axes.
    pub(super) a: [f64; D],
    /// The exponent.
    pub(super) n: f64,
}

impl<const D: usize> Gauge<D> {
    /// `N(w)`, with the largest term factored out so that large `n`
    /// neither overflows nor underflows.
    fn norm(&self, w: [f64; D]) -> f64 {
        let t: [f64; D] = std::array::from_fn(|k| (w[k] / self.a[k]).abs());
        let big = t.iter().fold(t[0], |m, &x| m.max(x));
        if big == 0.0 {
            return 0.0;
        }
        let sum: f64 = t.iter().map(|x| (x / big).powf(self.n)).sum();
        big * sum.powf(1.0 / self.n)
    }

    /// Radial projection of a non-zero local vector onto the shape.
    fn project(&self, w: [f64; D]) -> [f64; D] {
        scale(1.0 / self.norm(w), w)
    }

    /// Outward normal direction (not unit) at local point `x` on the
    /// shape, from the implicit gradient. For n < 1 the gradient is
    /// multiplied by `Π |x_k/a_k|^(1−n)`, which removes its poles on the
    /// cusps (creases) and leaves one of the one-sided normals there.
    fn normal_dir(&self, x: [f64; D]) -> [f64; D] {
        let t: [f64; D] = std::array::from_fn(|k| (x[k] / self.a[k]).abs());
        let m = 1.0 - self.n;
        std::array::from_fn(|k| {
            let s = x[k].signum() / self.a[k];
            if self.n >= 1.0 {
                s * t[k].powf(self.n - 1.0)
            } else {
                (1..D).fold(s, |acc, j| acc * t[(k + j) % D].powf(m))
            }
        })
    }
}

/// Superellipse `|x/a|^n + |y/b|^n = 1`, parametrised by the polar angle
/// about its centre (a star-shaped curve, so every angle gives one point;
/// unlike the usual `cos^(2/n)` form this does not crowd points together).
#[derive(Debug, Clone)]
pub(super) struct Superellipse {
    pub(super) centre: [f64; 2],
    gauge: Gauge<2>,
    pub(super) samples: Samples,
}

impl Superellipse {
    pub(super) fn new(centre: [f64; 2], a: [f64; 2], n: f64) -> Superellipse {
        let mut s = Superellipse { centre, gauge: Gauge { a, n }, samples: Samples::empty() };
        let params: Vec<f64> = (0..256).map(|k| TAU * k as f64 / 256.0).collect();
        s.samples = Samples::new(&s, &params, Some(TAU));
        s
    }

    pub(super) fn ray_hit(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<[f64; 2]> {
        let size = self.gauge.a[0].max(self.gauge.a[1]);
        if norm(sub(origin, self.centre)) <= 1e-15 * size {
            // From the centre, the ray's angle is the polar parameter.
            return Some(self.point(dir[1].atan2(dir[0])));
        }
        let s_min = ray_s_min(origin, dir, self.centre, size);
        ray_param(self, &self.samples, origin, dir, s_min).map(|t| self.point(t))
    }
}

impl Param for Superellipse {
    fn point(&self, phi: f64) -> [f64; 2] {
        let (s, c) = phi.sin_cos();
        add(self.centre, self.gauge.project([c, s]))
    }

    fn tangent(&self, phi: f64) -> [f64; 2] {
        let q = sub(self.point(phi), self.centre);
        // The polar angle increases counter-clockwise along the curve.
        rot_ccw(unit(self.gauge.normal_dir(q)))
    }
}

/// Superquadric `|x/a|^n + |y/b|^n + |z/c|^n = 1` about `centre` (see
/// [`Gauge`]).
#[derive(Debug, Clone)]
pub(super) struct Superquadric {
    pub(super) centre: [f64; 3],
    pub(super) gauge: Gauge<3>,
    /// Largest semi-axis: the length scale.
    size: f64,
    /// Local surface points on a coarse direction grid, seeding the search.
    seeds: Vec<[f64; 3]>,
}

/// Directions through the grid points of the cube `[-1, 1]³`'s faces,
/// `cells` cells a side (not normalised; edge points repeat).
fn cube_directions(cells: usize) -> Vec<[f64; 3]> {
    let mut dirs = Vec::with_capacity(6 * (cells + 1) * (cells + 1));
    for axis in 0..3 {
        for side in [-1.0, 1.0] {
            for i in 0..=cells {
                for j in 0..=cells {
                    let mut w = [0.0; 3];
                    w[axis] = side;
                    w[(axis + 1) % 3] = -1.0 + 2.0 * i as f64 / cells as f64;
                    w[(axis + 2) % 3] = -1.0 + 2.0 * j as f64 / cells as f64;
                    dirs.push(w);
                }
            }
        }
    }
    dirs
}

/// A step `d` in the local chart of the superquadric's Newton iteration,
/// with the gradient of `½|P − q|²` at the chart's origin.
struct Step {
    d: [f64; 2],
    grad: [f64; 2],
    /// Whether `d` came from the (positive definite) Hessian, not
    /// Gauss-Newton.
    newton: bool,
}

/// One evaluation of the local chart `(α, β) ↦ P(x + α e1 + β e2)` used by
/// the superquadric's Newton iteration.
struct ChartPoint {
    /// Jacobian columns `∂P/∂α`, `∂P/∂β`.
    jac: [[f64; 3]; 2],
    /// Gradient of `½|P − q|²` with respect to `(α, β)`.
    grad: [f64; 2],
}

impl Superquadric {
    pub(super) fn new(centre: [f64; 3], a: [f64; 3], n: f64) -> Superquadric {
        let mut s = Superquadric { centre, gauge: Gauge { a, n }, size: a[0].max(a[1]).max(a[2]), seeds: vec![] };
        s.seeds = cube_directions(SUPERQUADRIC_SEED_CELLS)
            .into_iter()
            .map(|w| s.gauge.project(w))
            .collect();
        s
    }

    /// `∇N(w)`; infinite on a coordinate plane when `n < 1` (the creases).
    fn grad_norm(&self, w: [f64; 3], nw: f64) -> [f64; 3] {
        [0, 1, 2].map(|k| {
            let t = (w[k] / self.gauge.a[k]).abs() / nw;
            w[k].signum() / self.gauge.a[k] * t.powf(self.gauge.n - 1.0)
        })
    }

    /// Unit outward normal at `q` on the surface. At a spike tip (n < 1),
    /// where every one-sided normal is across the spike, the spike's own
    /// direction is returned instead, the limit of the normals of the
    /// surrounding smooth surface seen from outside it.
    pub(super) fn normal_at(&self, q: [f64; 3]) -> [f64; 3] {
        let x = sub(q, self.centre);
        let nd = self.gauge.normal_dir(x);
        if nd != [0.0; 3] {
            return unit(nd);
        }
        let t = [0, 1, 2].map(|k| (x[k] / self.gauge.a[k]).abs());
        let k = (0..3).fold(0, |b, k| if t[k] > t[b] { k } else { b });
        let mut axis = [0.0; 3];
        axis[k] = 1.0f64.copysign(x[k]);
        axis
    }

    pub(super) fn closest(&self, p: [f64; 3]) -> [f64; 3] {
        add(self.centre, self.closest_local(sub(p, self.centre)))
    }

    /// Closest point to local `q`: the best of Newton refinements on the
    /// smooth part of the surface, seeded by the radial projection of `q`
    /// and by the nearest coarse grid points (so a far point or one near
    /// the centre does not settle for a worse local minimum), and, when
    /// n ≤ 1, the best points on the creases, where the surface is not
    /// smooth and a minimum need not be stationary.
    fn closest_local(&self, q: [f64; 3]) -> [f64; 3] {
        let mut best = ([0.0; 3], f64::INFINITY);
        let mut consider = |x: [f64; 3]| {
            let d = dist2(x, q);
            if d < best.1 {
                best = (x, d);
            }
        };
        if q != [0.0; 3] {
            let radial = self.gauge.project(q);
            consider(radial);
            consider(self.refine_patch(q, radial));
        }
        for seed in self.nearest_seeds(q) {
            consider(self.refine_patch(q, seed));
        }
        if self.gauge.n <= 1.0 {
            for k in 0..3 {
                consider(self.crease_closest(q, k));
                let mut tip = [0.0; 3];
                tip[k] = self.gauge.a[k];
                consider(tip);
                tip[k] = -self.gauge.a[k];
                consider(tip);
            }
        }
        best.0
    }

    /// The three seed points nearest to `q`.
    fn nearest_seeds(&self, q: [f64; 3]) -> Vec<[f64; 3]> {
        let mut top = [(f64::INFINITY, [0.0; 3]); 3];
        for s in &self.seeds {
            let d = dist2(*s, q);
            if d < top[2].0 {
                top[2] = (d, *s);
                top.sort_by(|x, y| x.0.total_cmp(&y.0));
            }
        }
        top.iter()
            .filter(|t| t.0.is_finite())
            .map(|t| t.1)
            .collect()
    }

    /// Evaluates the chart about `x` (tangent basis `e`) at `(α, β)`, or
    /// `None` where the parametrisation is not differentiable (a crease).
    fn chart(
        &self,
        q: [f64; 3],
        x: [f64; 3],
        e: [[f64; 3]; 2],
        ab: [f64; 2],
    ) -> Option<ChartPoint> {
        let w = add(x, add(scale(ab[0], e[0]), scale(ab[1], e[1])));
        let nw = self.gauge.norm(w);
        let point = scale(1.0 / nw, w);
        let g = self.grad_norm(w, nw);
        // d(w/N) = (dw − P (∇N·dw)) / N
        let jac = e.map(|ek| scale(1.0 / nw, sub(ek, scale(dot(g, ek), point))));
        let r = sub(point, q);
        let grad = [dot(r, jac[0]), dot(r, jac[1])];
        let finite = grad.iter().chain(&point).all(|v| v.is_finite());
        finite.then_some(ChartPoint { jac, grad })
    }

    /// Damped Newton minimisation of `|P − q|²` over the surface from the
    /// on-surface local point `seed`, in a chart re-centred at every step:
    /// `P(x + α e1 + β e2)` with `e1`, `e2` tangent at `x` (never parallel
    /// to the radial direction, the surface being star-shaped). The Hessian
    /// is a central difference of the analytic gradient, accurate enough for
    /// fast convergence while the gradient fixes the stationary point to
    /// machine precision. Where the Hessian is not positive definite the
    /// Gauss-Newton matrix is used instead; steps are capped and halved
    /// until the distance decreases.
    fn refine_patch(&self, q: [f64; 3], seed: [f64; 3]) -> [f64; 3] {
        let h = 1e-6 * self.size;
        let mut x = seed;
        let mut g = dist2(x, q);
        for _ in 0..100 {
            let nd = self.gauge.normal_dir(x);
            if !nd.iter().all(|v| v.is_finite()) || nd == [0.0; 3] {
                break;
            }
            let (e1, e2) = orthonormal_basis(unit(nd));
            let e = [e1, e2];
            let Some(step) = self.newton_step(q, x, e, h) else {
                break;
            };
            let Some((next, gn)) = self.line_search(q, x, e, step, g) else {
                break; // no decrease: converged to round-off
            };
            let moved = norm(sub(next, x));
            (x, g) = (next, gn);
            if moved <= 4.0 * EPS * (self.size + g.sqrt()) {
                break;
            }
        }
        x
    }

    /// The Newton (or Gauss-Newton) step in the chart about `x`, capped at
    /// half the surface size, and the gradient it was computed from.
    fn newton_step(&self, q: [f64; 3], x: [f64; 3], e: [[f64; 3]; 2], h: f64) -> Option<Step> {
        let c = self.chart(q, x, e, [0.0, 0.0])?;
        let px = self.chart(q, x, e, [h, 0.0])?;
        let mx = self.chart(q, x, e, [-h, 0.0])?;
        let py = self.chart(q, x, e, [0.0, h])?;
        let my = self.chart(q, x, e, [0.0, -h])?;
        let h11 = (px.grad[0] - mx.grad[0]) / (2.0 * h);
        let h22 = (py.grad[1] - my.grad[1]) / (2.0 * h);
        let h12 = 0.25 * (px.grad[1] - mx.grad[1] + py.grad[0] - my.grad[0]) / h;
        let newton = h11 > 0.0 && h11 * h22 - h12 * h12 > 0.0;
        let [m11, m12, m22] = if newton {
            [h11, h12, h22]
        } else {
            let [j1, j2] = c.jac;
            [dot(j1, j1), dot(j1, j2), dot(j2, j2)]
        };
        let det = m11 * m22 - m12 * m12;
        if det.is_nan() || det <= 0.0 {
            return None;
        }
        let mut d = [
            -(m22 * c.grad[0] - m12 * c.grad[1]) / det,
            -(m11 * c.grad[1] - m12 * c.grad[0]) / det,
        ];
        let len = d[0].hypot(d[1]);
        let cap = 0.5 * self.size;
        if len > cap {
            d = [d[0] * cap / len, d[1] * cap / len];
        }
        Some(Step {
            d,
            grad: c.grad,
            newton,
        })
    }

    /// Backtracking along the step: the first fraction giving sufficient
    /// decrease (Armijo) of the squared distance `g`. The Armijo test keeps
    /// Newton from bouncing across a coordinate plane where the surface's
    /// curvature is unbounded (1 < n < 2), where it would otherwise swap
    /// sides forever. Near the minimum the distance can no longer resolve
    /// the last digits that the gradient still can, so there a small full
    /// Newton step is accepted first if it at least halves the gradient.
    fn line_search(
        &self,
        q: [f64; 3],
        x: [f64; 3],
        e: [[f64; 3]; 2],
        step: Step,
        g: f64,
    ) -> Option<([f64; 3], f64)> {
        let d = step.d;
        let at = |t: f64| self.gauge.project(add(x, add(scale(t * d[0], e[0]), scale(t * d[1], e[1]))));
        if step.newton && d[0].hypot(d[1]) <= 1e-4 * self.size {
            let c = self.chart(q, x, e, d)?;
            if c.grad[0].hypot(c.grad[1]) <= 0.5 * step.grad[0].hypot(step.grad[1]) {
                let cand = at(1.0);
                return Some((cand, dist2(cand, q)));
            }
        }
        // Rate of change of g = |P − q|² along d (twice that of ½|P − q|²).
        let slope = 2.0 * (step.grad[0] * d[0] + step.grad[1] * d[1]);
        let mut t = 1.0;
        for _ in 0..50 {
            let cand = at(t);
            let gc = dist2(cand, q);
            if gc <= g + 0.25 * t * slope && gc.is_finite() {
                return Some((cand, gc));
            }
            t *= 0.5;
        }
        None
    }

    /// Closest point to local `q` on the crease curve `x_k = 0` (a
    /// superellipse in the other two coordinates), parametrised by polar
    /// angle: best sample, then Brent's minimiser between its neighbours.
    fn crease_closest(&self, q: [f64; 3], k: usize) -> [f64; 3] {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let point = |phi: f64| {
            let mut w = [0.0; 3];
            (w[j], w[i]) = phi.sin_cos();
            self.gauge.project(w)
        };
        let f = |phi: f64| dist2(point(phi), q);
        let step = TAU / CREASE_SAMPLES as f64;
        let best = (0..CREASE_SAMPLES).map(|m| (m, f(m as f64 * step))).fold(
            (0, f64::INFINITY),
            |acc, x| if x.1 < acc.1 { x } else { acc },
        );
        let centre = best.0 as f64 * step;
        let (phi, d) = brent_min(&f, centre - step, centre + step, EPS);
        if d < best.1 {
            point(phi)
        } else {
            point(centre)
        }
    }

    pub(super) fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        let o = sub(origin, self.centre);
        if norm(o) <= 1e-15 * self.size {
            // From the centre the hit is the radial projection of `dir`.
            return Some(add(self.centre, self.gauge.project(dir)));
        }
        // The surface lies in the box |x_k| ≤ a_k: only the ray's chord
        // through it needs searching.
        let (mut lo, mut hi) = (
            ray_s_min(origin, dir, self.centre, self.size),
            f64::INFINITY,
        );
        for k in 0..3 {
            if dir[k] == 0.0 {
                if o[k].abs() > self.gauge.a[k] {
                    return None;
                }
                continue;
            }
            let (s1, s2) = ((-self.gauge.a[k] - o[k]) / dir[k], (self.gauge.a[k] - o[k]) / dir[k]);
            lo = lo.max(s1.min(s2));
            hi = hi.min(s1.max(s2));
        }
        if lo >= hi || lo.is_nan() || hi.is_nan() {
            return None;
        }
        let f = |s: f64| self.gauge.norm(add(o, scale(s, dir))) - 1.0;
        let s = first_crossing(&f, lo, hi, SUPERQUADRIC_RAY_SAMPLES)?;
        Some(add(self.centre, self.gauge.project(add(o, scale(s, dir)))))
    }
}
