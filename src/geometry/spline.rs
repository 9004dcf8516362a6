//! Cubic splines through points of the plane, open (natural ends) or
//! closed (periodic), parametrised by chord length.

use super::parametric::{Param, Samples};
use super::{GeometryError, Validator};
use crate::numeric::{cross2, norm, sub};

/// Cubic spline through points, parametrised by cumulative chord length.
#[derive(Debug, Clone)]
pub(super) struct Spline {
    /// Knots; `knots[k]` is the parameter of `points[k]`.
    pub(super) knots: Vec<f64>,
    /// Interpolated points; for a closed spline the first is repeated last.
    pub(super) points: Vec<[f64; 2]>,
    /// Second derivatives at the knots (repeated last too when closed).
    pub(super) second: Vec<[f64; 2]>,
    pub(super) closed: bool,
    pub(super) samples: Samples,
}

impl Spline {
    /// Checks the points of a spline spec: enough of them, finite, no two
    /// consecutive ones equal, and a closed spline not repeating its first.
    pub(super) fn check(v: &Validator, points: &[[f64; 2]], closed: bool) -> Result<(), GeometryError> {
        let needed = if closed { 3 } else { 2 };
        if points.len() < needed {
            let kind = if closed { "a closed" } else { "an open" };
            let reason = format!("needs at least {needed} points for {kind} spline (got {})", points.len());
            return Err(v.error("points", reason));
        }
        for (i, p) in points.iter().enumerate() {
            v.finite_point(&format!("points[{i}]"), *p)?;
            if i > 0 && *p == points[i - 1] {
                return Err(v.error(&format!("points[{i}]"), format!("repeats points[{}]", i - 1)));
            }
        }
        let last = points.len() - 1;
        if closed && points[last] == points[0] {
            let reason = "repeats points[0]; a closed spline closes by itself, do not repeat the first point";
            return Err(v.error(&format!("points[{last}]"), reason));
        }
        Ok(())
    }

    pub(super) fn new(points: &[[f64; 2]], closed: bool) -> Spline {
        let mut pts = points.to_vec();
        // Closed curves run counter-clockwise so their normal is outward.
        if closed && signed_area(&pts) < 0.0 {
            pts.reverse();
        }
        if closed {
            pts.push(pts[0]);
        }
        let mut knots = vec![0.0];
        for w in pts.windows(2) {
            knots.push(knots.last().unwrap() + norm(sub(w[1], w[0])));
        }
        let second = spline_second_derivatives(&knots, &pts, closed);
        let mut s = Spline {
            knots,
            points: pts,
            second,
            closed,
            samples: Samples::empty(),
        };
        s.samples = s.build_samples();
        s
    }

    /// At least 4 samples per span, refined by chord length.
    pub(super) fn build_samples(&self) -> Samples {
        let spans = self.knots.len() - 1;
        let mut params = Vec::with_capacity(4 * spans + 1);
        for k in 0..spans {
            let (t0, t1) = (self.knots[k], self.knots[k + 1]);
            params.extend((0..4).map(|j| t0 + (t1 - t0) * j as f64 / 4.0));
        }
        let period = self.closed.then(|| self.period());
        if !self.closed {
            params.push(self.knots[spans]);
        }
        Samples::new(self, &params, period)
    }

    pub(super) fn period(&self) -> f64 {
        *self.knots.last().unwrap()
    }

    /// Maps `t` into the domain: wraps a closed spline, clamps an open one.
    pub(super) fn wrap(&self, t: f64) -> f64 {
        let end = self.period();
        if self.closed {
            let w = t.rem_euclid(end);
            if w >= end {
                0.0
            } else {
                w
            }
        } else {
            t.clamp(0.0, end)
        }
    }

    /// Index of the span containing parameter `t` (already in the domain).
    pub(super) fn span(&self, t: f64) -> usize {
        let k = self.knots.partition_point(|&x| x <= t);
        k.saturating_sub(1).min(self.knots.len() - 2)
    }

    /// Value, first and second derivative of span `k` at `t`.
    pub(super) fn eval_span(&self, k: usize, t: f64) -> [[f64; 2]; 3] {
        let h = self.knots[k + 1] - self.knots[k];
        let (a, b) = ((self.knots[k + 1] - t) / h, (t - self.knots[k]) / h);
        let (p0, p1, m0, m1) = (
            self.points[k],
            self.points[k + 1],
            self.second[k],
            self.second[k + 1],
        );
        let mut out = [[0.0; 2]; 3];
        for d in 0..2 {
            out[0][d] = a * p0[d]
                + b * p1[d]
                + ((a * a * a - a) * m0[d] + (b * b * b - b) * m1[d]) * h * h / 6.0;
            out[1][d] = (p1[d] - p0[d]) / h - (3.0 * a * a - 1.0) / 6.0 * h * m0[d]
                + (3.0 * b * b - 1.0) / 6.0 * h * m1[d];
            out[2][d] = a * m0[d] + b * m1[d];
        }
        out
    }

    pub(super) fn eval(&self, t: f64) -> [[f64; 2]; 3] {
        let t = self.wrap(t);
        self.eval_span(self.span(t), t)
    }
}

impl Param for Spline {
    fn point(&self, t: f64) -> [f64; 2] {
        self.eval(t)[0]
    }

    fn tangent(&self, t: f64) -> [f64; 2] {
        let [_, d1, d2] = self.eval(t);
        // A chord-length spline can stop momentarily at a cusp; the second
        // derivative then gives the direction of motion.
        if d1 == [0.0, 0.0] {
            d2
        } else {
            d1
        }
    }
}

/// Shoelace signed area of a closed polygon (positive if counter-clockwise).
fn signed_area(pts: &[[f64; 2]]) -> f64 {
    let n = pts.len();
    0.5 * (0..n).map(|i| cross2(pts[i], pts[(i + 1) % n])).sum::<f64>()
}

/// Second derivatives of the interpolating cubic spline at the knots, per
/// coordinate: natural end conditions when open, periodic when closed (the
/// last point then repeats the first, and so does the result).
fn spline_second_derivatives(knots: &[f64], pts: &[[f64; 2]], closed: bool) -> Vec<[f64; 2]> {
    let m = knots.len() - 1; // number of spans
    let h: Vec<f64> = knots.windows(2).map(|w| w[1] - w[0]).collect();
    let mut result = vec![[0.0; 2]; m + 1];
    for d in 0..2 {
        let slope = |k: usize| (pts[k + 1][d] - pts[k][d]) / h[k];
        if closed {
            // Row i ties spans i-1 and i around knot i, indices mod m.
            let prev = |i: usize| (i + m - 1) % m;
            let lower: Vec<f64> = (0..m).map(|i| h[prev(i)]).collect();
            let diag: Vec<f64> = (0..m).map(|i| 2.0 * (h[prev(i)] + h[i])).collect();
            let upper: Vec<f64> = h.clone();
            let rhs: Vec<f64> = (0..m).map(|i| 6.0 * (slope(i) - slope(prev(i)))).collect();
            let x = solve_cyclic(&lower, &diag, &upper, &rhs);
            for i in 0..m {
                result[i][d] = x[i];
            }
            result[m][d] = x[0];
        } else if m >= 2 {
            let inner = 1..m;
            let lower: Vec<f64> = inner.clone().map(|i| h[i - 1]).collect();
            let diag: Vec<f64> = inner.clone().map(|i| 2.0 * (h[i - 1] + h[i])).collect();
            let upper: Vec<f64> = inner.clone().map(|i| h[i]).collect();
            let rhs: Vec<f64> = inner.map(|i| 6.0 * (slope(i) - slope(i - 1))).collect();
            for (k, x) in solve_tridiagonal(&lower, &diag, &upper, &rhs)
                .into_iter()
                .enumerate()
            {
                result[k + 1][d] = x;
            }
        }
    }
    result
}

/// Thomas algorithm for `lower[i]·x[i-1] + diag[i]·x[i] + upper[i]·x[i+1] =
/// rhs[i]` (`lower[0]` and `upper[n-1]` unused). Stable here because the
/// spline systems are strictly diagonally dominant.
fn solve_tridiagonal(lower: &[f64], diag: &[f64], upper: &[f64], rhs: &[f64]) -> Vec<f64> {
    let n = diag.len();
    let mut c = vec![0.0; n];
    let mut x = vec![0.0; n];
    for i in 0..n {
        let (l, cp, xp) = if i == 0 {
            (0.0, 0.0, 0.0)
        } else {
            (lower[i], c[i - 1], x[i - 1])
        };
        let denom = diag[i] - l * cp;
        c[i] = upper[i] / denom;
        x[i] = (rhs[i] - l * xp) / denom;
    }
    for i in (0..n.saturating_sub(1)).rev() {
        x[i] -= c[i] * x[i + 1];
    }
    x
}

/// Cyclic tridiagonal solve (`lower[0]` couples row 0 to `x[n-1]`,
/// `upper[n-1]` couples row n-1 to `x[0]`) by the Sherman–Morrison formula
/// on top of two ordinary tridiagonal solves. Needs n ≥ 3.
fn solve_cyclic(lower: &[f64], diag: &[f64], upper: &[f64], rhs: &[f64]) -> Vec<f64> {
    let n = diag.len();
    let (alpha, beta) = (upper[n - 1], lower[0]);
    let gamma = -diag[0];
    let mut bb = diag.to_vec();
    bb[0] -= gamma;
    bb[n - 1] -= alpha * beta / gamma;
    let mut x = solve_tridiagonal(lower, &bb, upper, rhs);
    let mut u = vec![0.0; n];
    u[0] = gamma;
    u[n - 1] = alpha;
    let z = solve_tridiagonal(lower, &bb, upper, &u);
    let fact = (x[0] + beta * x[n - 1] / gamma) / (1.0 + z[0] + beta * z[n - 1] / gamma);
    for i in 0..n {
        x[i] -= fact * z[i];
    }
    x
}
