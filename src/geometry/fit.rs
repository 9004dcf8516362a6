//! Where the new nodes of a curved edge go so that the edge's polynomial
//! lies closest to its shape ("geometric interpolation").
//!
//! The nodes of an order-p edge must lie on the shape, but where along it
//! is free: the polynomial through them may take any parametrisation of
//! the curve. Equal arc length is a fine start, yet where the curvature
//! changes along the edge (an airfoil's nose) the places that minimise
//! the polynomial's distance to the shape are measurably elsewhere, and
//! the gain is large: on the 2,024-hex wing's nose element at p = 3,
//! 1.9e-4 at equal arc length, 8.6e-5 at Gmsh's places (projections of
//! the chord's equispaced points), 1.4e-6 at the places found here. Why
//! so large: a planar cubic through 4 points whose parameters are free
//! approximates to a higher order than one whose parameters are fixed
//! (de Boor, Höllig and Sabin, "High accuracy geometric Hermite
//! interpolation", CAGD 1987); Toulorge, Lambrechts and Remacle
//! ("Optimizing the geometrical accuracy of curvilinear meshes", JCP 2016)
//! use the same freedom in Gmsh's optimiser.

use crate::numeric::{dist2, sub};

/// Gauss–Legendre points on [0, 1] at which each interval between two
/// nodes is sampled (three: the least that sees a cubic's bulge).
const SAMPLES: [f64; 3] = [0.112_701_665_379_258_3, 0.5, 0.887_298_334_620_741_7];

/// A step of the places (parameters in [0, 1] along the line) shorter
/// than this ends the fit ([`fitted_places`]).
const FIT_STEP: f64 = 1e-9;

/// Gauss–Newton iterations at most (from equal arc length the places
/// converge in three or four).
const ITERATIONS: usize = 12;

/// The places, along a curve, of the nodes of one line of an order-p edge
/// that bring its interpolant closest to the shape (least squares of the
/// offsets at [`SAMPLES`] in each interval).
///
/// * `curve(xs)`: the shape's points at the curve's parameters `xs` in
///   [0, 1] (x = 0 and 1 are the line's fixed end nodes);
/// * `feet(qs)`: the shape's points closest to `qs` (asked together: on
///   CAD one batch of Gmsh's calls);
/// * `reference`: the nodes' reference places, increasing from 0 to 1
///   (equispaced or Gauss–Lobatto), ends included;
/// * `start`: the inner nodes' parameters to start from (equal arc
///   length), one per inner node of `reference`.
///
/// Returns the inner nodes' parameters, or None where the fit does not
/// improve on `start` (a straight line, a flat curve, a step that would
/// let the nodes cross): then `start` stands.
pub fn fitted_places<const D: usize>(curve: impl Fn(&[f64]) -> Vec<[f64; D]>, feet: impl Fn(&[[f64; D]]) -> Vec<[f64; D]>, reference: &[f64], start: &[f64]) -> Option<Vec<f64>> {
    let m = start.len();
    debug_assert_eq!(reference.len(), m + 2);
    let basis = Interpolant::new(reference);
    let ends: [[f64; D]; 2] = curve(&[0.0, 1.0]).try_into().ok()?;
    let scale = dist2(ends[0], ends[1]).sqrt();
    let residual = |x: &[f64]| -> Option<Vec<f64>> {
        let mut nodes = Vec::with_capacity(m + 2);
        nodes.push(ends[0]);
        nodes.extend(curve(x));
        nodes.push(ends[1]);
        let qs: Vec<[f64; D]> = basis.samples.iter().map(|w| std::array::from_fn(|i| w.iter().zip(&nodes).map(|(w, n)| w * n[i]).sum())).collect();
        let r: Vec<f64> = qs.iter().zip(feet(&qs)).flat_map(|(&q, f)| sub(q, f)).collect();
        r.iter().all(|v| v.is_finite()).then_some(r)
    };
    let norm2 = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
    let mut x = start.to_vec();
    let mut r = residual(&x)?;
    let first = norm2(&r);
    // a straight or already fitting line: nothing to gain
    if first <= (1e-13 * scale).powi(2) {
        return None;
    }
    // the nodes stay in order, each gap at least a fifth of where it began
    let gaps: Vec<f64> = (0..=m).map(|j| 0.2 * (at(&x, j + 1) - at(&x, j))).collect();
    let ordered = |x: &[f64]| (0..=m).all(|j| at(x, j + 1) - at(x, j) >= gaps[j]);
    let mut damping = 1e-6;
    for _ in 0..ITERATIONS {
        let jac = jacobian(&residual, &x, &r)?;
        // the normal equations (JᵀJ + λ diag JᵀJ) δ = −Jᵀr, m ≤ a few
        let mut a = vec![vec![0.0; m]; m];
        let mut g = vec![0.0; m];
        for j in 0..m {
            g[j] = -jac[j].iter().zip(&r).map(|(a, b)| a * b).sum::<f64>();
            for k in 0..m {
                a[j][k] = jac[j].iter().zip(&jac[k]).map(|(a, b)| a * b).sum();
            }
        }
        let mut improved = false;
        while damping < 1e6 {
            let mut damped = a.clone();
            for j in 0..m {
                damped[j][j] *= 1.0 + damping;
            }
            let Some(step) = solve(damped, g.clone()) else { break };
            // a step this short that does not lower the offsets is at
            // their round-off: converged (damping it further only costs
            // evaluations, a dozen per line measured)
            if step.iter().all(|s| s.abs() < 1e-12) {
                return (norm2(&r) < first).then_some(x);
            }
            let next: Vec<f64> = x.iter().zip(&step).map(|(x, s)| x + s).collect();
            if let Some(rn) = ordered(&next).then(|| residual(&next)).flatten() {
                if norm2(&rn) < norm2(&r) {
                    // a step under 1e-9 of the line moves a node by less
                    // than the shapes' own tolerance: converged (to 1e-13
                    // it took twice the projections, on CAD the most of a
                    // snap's time: 0.63 s of 3.2 s on a 5,062-tet ball in a
                    // box at p = 3)
                    let small = step.iter().all(|s| s.abs() < FIT_STEP);
                    (x, r, improved) = (next, rn, true);
                    damping = (damping * 0.1).max(1e-9);
                    if small {
                        return Some(x);
                    }
                    break;
                }
            }
            damping *= 10.0;
        }
        if !improved {
            break;
        }
    }
    (norm2(&r) < first).then_some(x)
}

/// The parameter of node `j` of the line (0 and 1 at its ends).
fn at(x: &[f64], j: usize) -> f64 {
    if j == 0 {
        0.0
    } else if j > x.len() {
        1.0
    } else {
        x[j - 1]
    }
}

/// ∂r/∂x_j by forward differences, one column per inner node.
fn jacobian(residual: &impl Fn(&[f64]) -> Option<Vec<f64>>, x: &[f64], r: &[f64]) -> Option<Vec<Vec<f64>>> {
    const H: f64 = 1e-7;
    (0..x.len())
        .map(|j| {
            let mut y = x.to_vec();
            y[j] += H;
            let ry = residual(&y)?;
            Some(ry.iter().zip(r).map(|(a, b)| (a - b) / H).collect())
        })
        .collect()
}

/// Gaussian elimination with partial pivoting; None if singular.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if !(a[p][c].abs() > 0.0) {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for i in c + 1..n {
            let f = a[i][c] / a[c][c];
            for k in c..n {
                a[i][k] -= f * a[c][k];
            }
            b[i] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        x[i] = (b[i] - (i + 1..n).map(|k| a[i][k] * x[k]).sum::<f64>()) / a[i][i];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The Lagrange weights of a line's nodes at its sample points.
struct Interpolant {
    samples: Vec<Vec<f64>>,
}

impl Interpolant {
    fn new(reference: &[f64]) -> Self {
        let samples = reference.windows(2).flat_map(|w| SAMPLES.iter().map(move |&s| w[0] + s * (w[1] - w[0]))).map(|t| weights(reference, t)).collect();
        Interpolant { samples }
    }
}

/// The Lagrange weights at `t` of nodes at `reference`.
fn weights(reference: &[f64], t: f64) -> Vec<f64> {
    (0..reference.len())
        .map(|j| (0..reference.len()).filter(|&k| k != j).map(|k| (t - reference[k]) / (reference[j] - reference[k])).product())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest distance of the cubic through the curve's points at
    /// `x` (reference places 0, 1/3, 2/3, 1) to the curve, sampled finely.
    fn error(curve: &impl Fn(f64) -> [f64; 2], foot: &impl Fn([f64; 2]) -> [f64; 2], x: &[f64]) -> f64 {
        let reference = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0];
        let nodes: Vec<[f64; 2]> = [0.0, x[0], x[1], 1.0].iter().map(|&t| curve(t)).collect();
        (0..=400)
            .map(|i| {
                let t = i as f64 / 400.0;
                let w = weights(&reference, t);
                let q: [f64; 2] = std::array::from_fn(|c| (0..4).map(|j| w[j] * nodes[j][c]).sum());
                dist2(q, foot(q)).sqrt()
            })
            .fold(0.0, f64::max)
    }

    /// An ellipse's quarter, from the end of its major axis (curvature
    /// changing 8-fold along it): the fitted places beat equal arc length
    /// more than a hundredfold (measured: 2.85e-2 against 1.26e-4),
    /// measured on 400 points with the exact foot
    /// (a fine polyline of the ellipse, 20,000 pieces, whose own error is
    /// below 1e-9).
    #[test]
    fn fitted_places_beat_equal_arc_length_on_an_ellipse_quarter() {
        let (a, b) = (2.0, 1.0);
        let curve = |x: f64| {
            let t = x * std::f64::consts::FRAC_PI_2;
            [a * t.cos(), b * t.sin()]
        };
        let poly: Vec<[f64; 2]> = (0..=20_000).map(|i| curve(i as f64 / 20_000.0)).collect();
        let foot = |q: [f64; 2]| {
            poly.windows(2)
                .map(|w| {
                    let d = sub(w[1], w[0]);
                    let s = (((q[0] - w[0][0]) * d[0] + (q[1] - w[0][1]) * d[1]) / (d[0] * d[0] + d[1] * d[1])).clamp(0.0, 1.0);
                    [w[0][0] + s * d[0], w[0][1] + s * d[1]]
                })
                .min_by(|p, r| dist2(*p, q).total_cmp(&dist2(*r, q)))
                .unwrap()
        };
        // equal arc length, from the polyline's lengths
        let lengths: Vec<f64> = std::iter::once(0.0).chain(poly.windows(2).scan(0.0, |s, w| Some(*s + dist2(w[0], w[1]).sqrt()).inspect(|v| *s = *v))).collect();
        let total = *lengths.last().unwrap();
        let arc = |f: f64| lengths.iter().position(|&l| l >= f * total).unwrap() as f64 / 20_000.0;
        let start = [arc(1.0 / 3.0), arc(2.0 / 3.0)];
        let fitted = fitted_places(|xs: &[f64]| xs.iter().map(|&x| curve(x)).collect(), |qs: &[[f64; 2]]| qs.iter().map(|&q| foot(q)).collect(), &[0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0], &start).expect("a curved line is fitted");
        let (before, after) = (error(&curve, &foot, &start), error(&curve, &foot, &fitted));
        assert!(before > 2.5e-2 && after < 2e-4, "equal arc length {before:.3e}, fitted {after:.3e}");
    }

    /// A straight line has nothing to fit: its places stand.
    #[test]
    fn a_straight_line_keeps_its_places() {
        let curve = |x: f64| [x, 2.0 * x];
        let foot = |q: [f64; 2]| {
            let s = (q[0] + 2.0 * q[1]) / 5.0;
            [s, 2.0 * s]
        };
        assert!(fitted_places(|xs: &[f64]| xs.iter().map(|&x| curve(x)).collect(), |qs: &[[f64; 2]]| qs.iter().map(|&q| foot(q)).collect(), &[0.0, 0.5, 1.0], &[0.5]).is_none());
    }
}
