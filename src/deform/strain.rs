//! How far a velocity field may carry the cells in one step: the step
//! control of `curve` (docs/METHOD.md §4).
//!
//! An Euler step of size h maps the frame E of edges at a corner of a Q1
//! cell to E + h U, with U the velocity differences along the same edges,
//! so the corner's Jacobian changes by the factor
//! det(I + h M) = 1 + a₁h + a₂h² + a₃h³, M = U E⁻¹ = ∇u
//! (a₁ = tr M, a₂ the sum of its principal 2×2 minors, a₃ = det M).
//! The step is the largest h for which every corner's factor stays within
//! 1 ± c on the whole of [0, h]. It bounds what the step does to the cells
//! (a corner that would invert needs a factor of 0), while a shear or a
//! rotation, which the flow of a sliding wall makes across thin boundary
//! layers and which keeps det J, does not cut the step.

use crate::lsfem::{linear_corner, q1_eval};
use rayon::prelude::*;

/// The largest step h ≤ `h_max` for which det(I + s ∇u) stays within
/// 1 ± `c` for all s in [0, h] at every corner of every cell. Corners with
/// a non-positive Jacobian are skipped: the validity check rejects the
/// step that made them.
pub fn max_step<const D: usize, const N: usize>(cells: &[[usize; N]], nodes: &[[f64; D]], u: &[[f64; D]], c: f64, h_max: f64) -> f64 {
    cells
        .par_iter()
        .with_min_len(256)
        .map(|cell| {
            let p: [[f64; D]; N] = std::array::from_fn(|a| nodes[cell[a]]);
            let v: [[f64; D]; N] = std::array::from_fn(|a| u[cell[a]]);
            (0..N).map(|a| corner_step(&p, &v, a, c, h_max)).fold(h_max, f64::min)
        })
        .reduce(|| h_max, f64::min)
}

/// The smallest and largest ratio det J(after) / det J(before) over the
/// corners of all cells: what a step did to the cells, its put-back onto
/// the walls included. Corners not valid before are skipped.
pub fn corner_ratio_range<const D: usize, const N: usize>(cells: &[[usize; N]], before: &[[f64; D]], after: &[[f64; D]]) -> (f64, f64) {
    cells
        .par_iter()
        .with_min_len(256)
        .map(|cell| {
            let p: [[f64; D]; N] = std::array::from_fn(|a| before[cell[a]]);
            let q: [[f64; D]; N] = std::array::from_fn(|a| after[cell[a]]);
            (0..N).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), a| {
                let xi = linear_corner::<D, N>(a);
                let d0 = q1_eval::<D, N>(&p, xi).1;
                if d0 <= 0.0 {
                    return (lo, hi);
                }
                let r = q1_eval::<D, N>(&q, xi).1 / d0;
                (lo.min(r), hi.max(r))
            })
        })
        .reduce(|| (f64::INFINITY, f64::NEG_INFINITY), |a, b| (a.0.min(b.0), a.1.max(b.1)))
}

/// [`max_step`] at corner `a` of one cell.
fn corner_step<const D: usize, const N: usize>(p: &[[f64; D]; N], v: &[[f64; D]; N], a: usize, c: f64, h_max: f64) -> f64 {
    let xi = linear_corner::<D, N>(a);
    let (_, det, g) = q1_eval::<D, N>(p, xi);
    if det <= 0.0 {
        return h_max;
    }
    // M_ji = ∂u_j/∂x_i = Σ_b u_b,j ∂N_b/∂x_i
    let m: [[f64; D]; D] = std::array::from_fn(|j| std::array::from_fn(|i| (0..N).map(|b| v[b][j] * g[i][b]).sum()));
    let q = det_factor_coefficients(&m);
    first_exit(q, c, h_max)
}

/// The coefficients [a₁, a₂, a₃] of det(I + h M) − 1 (D = 2 or 3).
fn det_factor_coefficients<const D: usize>(m: &[[f64; D]; D]) -> [f64; 3] {
    let trace = (0..D).map(|i| m[i][i]).sum();
    let mut minors = 0.0;
    for i in 0..D {
        for j in i + 1..D {
            minors += m[i][i] * m[j][j] - m[i][j] * m[j][i];
        }
    }
    let det = if D == 3 {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    } else {
        0.0
    };
    [trace, minors, det]
}

/// The first h in (0, h_max] where |a₁h + a₂h² + a₃h³| reaches c, or
/// h_max if it stays below. The cubic is monotone between its critical
/// points, so each such piece is searched by bisection for a crossing.
fn first_exit([a1, a2, a3]: [f64; 3], c: f64, h_max: f64) -> f64 {
    let q = |h: f64| ((a3 * h + a2) * h + a1) * h;
    // critical points: 3a₃h² + 2a₂h + a₁ = 0 (on the stack: this runs at
    // every corner of every moving cell at every step)
    let mut cuts: smallvec::SmallVec<[f64; 4]> = smallvec::smallvec![0.0];
    let (qa, qb, qc) = (3.0 * a3, 2.0 * a2, a1);
    if qa != 0.0 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            let s = disc.sqrt();
            cuts.extend([(-qb - s) / (2.0 * qa), (-qb + s) / (2.0 * qa)]);
        }
    } else if qb != 0.0 {
        cuts.push(-qc / qb);
    }
    cuts.retain(|h| *h >= 0.0 && *h < h_max);
    cuts.sort_by(f64::total_cmp);
    cuts.push(h_max);
    for w in cuts.windows(2) {
        let (mut lo, mut hi) = (w[0], w[1]);
        if q(hi).abs() < c {
            continue;
        }
        // |q(lo)| < c ≤ |q(hi)| with q monotone on [lo, hi]
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if q(mid).abs() < c {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        return lo;
    }
    h_max
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lsfem::q1_corner;

    fn det2(m: [[f64; 2]; 2]) -> f64 {
        m[0][0] * m[1][1] - m[0][1] * m[1][0]
    }

    /// u = A x on a distorted quad: ∇u = A at every corner, so the step
    /// is where det(I + hA) first leaves 1 ± c, computed here directly.
    #[test]
    fn linear_field_step_is_where_the_factor_reaches_the_limit() {
        let a = [[-0.9, 0.4], [0.3, -0.5]];
        let quad = [[0.0, 0.0], [1.3, 0.1], [1.1, 0.9], [-0.2, 1.4]];
        let u: Vec<[f64; 2]> = quad.iter().map(|x| std::array::from_fn(|j| a[j][0] * x[0] + a[j][1] * x[1])).collect();
        let c = 0.3;
        let h = max_step(&[[0, 1, 2, 3]], &quad, &u, c, 10.0);
        let factor = |h: f64| det2([[1.0 + h * a[0][0], h * a[0][1]], [h * a[1][0], 1.0 + h * a[1][1]]]);
        assert!((factor(h) - (1.0 - c)).abs() < 1e-12, "factor {} at h = {h}", factor(h));
        // and not earlier: the factor decreases monotonically from 1 here
        assert!(factor(0.99 * h) > 1.0 - c);
    }

    /// A pure shear keeps det J however far it goes; a compression of a
    /// thin layer is cut where it has shrunk the layer by c.
    #[test]
    fn shear_does_not_cut_the_step_compression_does() {
        let quad = [[0.0, 0.0], [1.0, 0.0], [1.0, 1e-4], [0.0, 1e-4]];
        let shear = vec![[0.0, 0.0], [0.0, 0.0], [1e-3, 0.0], [1e-3, 0.0]];
        assert_eq!(max_step(&[[0, 1, 2, 3]], &quad, &shear, 0.25, 1.0), 1.0);
        let squeeze = vec![[0.0, 0.0], [0.0, 0.0], [0.0, -1e-4], [0.0, -1e-4]];
        let h = max_step(&[[0, 1, 2, 3]], &quad, &squeeze, 0.25, 1.0);
        assert!((h - 0.25).abs() < 1e-12, "{h}");
    }

    /// In 3D the cubic term counts: u = A x with A = diag(−1, −1, −1)
    /// gives (1 − h)³, which reaches 1 − c at h = 1 − (1 − c)^⅓.
    #[test]
    fn hex_uses_the_whole_determinant() {
        let hex: Vec<[f64; 3]> = (0..8).map(|k| [q1_corner(k, 0) * 1.2 + 0.1 * q1_corner(k, 2), q1_corner(k, 1) * 0.8, q1_corner(k, 2) * 1.1 + 0.1 * q1_corner(k, 1) * q1_corner(k, 0)]).collect();
        let u: Vec<[f64; 3]> = hex.iter().map(|x| x.map(|v| -v)).collect();
        let h = max_step(&[[0, 1, 2, 3, 4, 5, 6, 7]], &hex, &u, 0.5, 1.0);
        let want = 1.0 - 0.5f64.cbrt();
        assert!((h - want).abs() < 1e-12, "{h} vs {want}");
    }

    /// Stretching a quad by 3 along x and a hex by 0.5 along z scales
    /// every corner Jacobian by that factor; a rigid motion by none.
    #[test]
    fn corner_ratios_are_the_jacobian_change() {
        let quad = [[0.0, 0.0], [1.3, 0.1], [1.1, 0.9], [-0.2, 1.4]];
        let stretched: Vec<[f64; 2]> = quad.iter().map(|x| [3.0 * x[0], x[1]]).collect();
        let (lo, hi) = corner_ratio_range(&[[0, 1, 2, 3]], &quad, &stretched);
        assert!((lo - 3.0).abs() < 1e-14 && (hi - 3.0).abs() < 1e-14, "{lo} {hi}");
        let (c, s) = (0.6f64, 0.8f64);
        let turned: Vec<[f64; 2]> = quad.iter().map(|x| [c * x[0] - s * x[1] + 5.0, s * x[0] + c * x[1]]).collect();
        let (lo, hi) = corner_ratio_range(&[[0, 1, 2, 3]], &quad, &turned);
        assert!((lo - 1.0).abs() < 1e-14 && (hi - 1.0).abs() < 1e-14, "{lo} {hi}");
        let hex: Vec<[f64; 3]> = (0..8).map(|k| [q1_corner(k, 0) + 0.1 * q1_corner(k, 2), q1_corner(k, 1), q1_corner(k, 2) * (1.0 + 0.2 * q1_corner(k, 0))]).collect();
        let flat: Vec<[f64; 3]> = hex.iter().map(|x| [x[0], x[1], 0.5 * x[2]]).collect();
        let (lo, hi) = corner_ratio_range(&[[0, 1, 2, 3, 4, 5, 6, 7]], &hex, &flat);
        assert!((lo - 0.5).abs() < 1e-14 && (hi - 0.5).abs() < 1e-14, "{lo} {hi}");
    }
}
