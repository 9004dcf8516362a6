//! 1-D Lagrange bases on [`nodes_1d`] and the tensor-product maps of
//! order-`p` quads and hexes from the reference cell `[0,1]^d`.

use super::{check_nodes, check_order, nodes_1d, HighOrderError, Spacing};

/// The Lagrange basis of order `p` on one node set: `l_i(t_m) = δ_im`.
#[derive(Clone, Debug, PartialEq)]
pub struct Basis1d {
    /// Element order.
    pub p: usize,
    /// The `p + 1` nodes (from [`nodes_1d`]).
    pub nodes: Vec<f64>,
    /// `1 / Π_{m≠i} (t_i − t_m)`, the normalisation of each `l_i`,
    /// computed once because every evaluation needs it.
    scale: Vec<f64>,
}

impl Basis1d {
    /// The basis of order `p` (in `1..=MAX_ORDER`) on `spacing`'s nodes.
    pub fn new(p: usize, spacing: Spacing) -> Result<Self, HighOrderError> {
        let nodes = nodes_1d(p, spacing)?;
        let scale = (0..=p)
            .map(|i| {
                let prod: f64 = (0..=p)
                    .filter(|&m| m != i)
                    .map(|m| nodes[i] - nodes[m])
                    .product();
                1.0 / prod
            })
            .collect();
        Ok(Basis1d { p, nodes, scale })
    }

    /// `(l_i(t), l_i'(t))` for `i = 0..=p`, by the product formula (p ≤ 4
    /// makes the O(p³) derivative loop cheaper than anything clever).
    /// Defined for every real `t`, not only `[0,1]`.
    pub fn eval(&self, t: f64) -> (Vec<f64>, Vec<f64>) {
        let n = self.p + 1;
        let d: Vec<f64> = self.nodes.iter().map(|&x| t - x).collect();
        let mut val = vec![0.0; n];
        let mut der = vec![0.0; n];
        for i in 0..n {
            let mut v = 1.0;
            let mut dv = 0.0;
            for m in (0..n).filter(|&m| m != i) {
                // product rule, one factor at a time
                dv = dv * d[m] + v;
                v *= d[m];
            }
            val[i] = v * self.scale[i];
            der[i] = dv * self.scale[i];
        }
        (val, der)
    }
}

/// `(l_i(t), l_i'(t))`, `i = 0..=p`, of the order-`p` Lagrange basis on
/// `spacing`'s nodes (see [`Basis1d`] to evaluate many points).
pub fn lagrange_1d(
    p: usize,
    spacing: Spacing,
    t: f64,
) -> Result<(Vec<f64>, Vec<f64>), HighOrderError> {
    Ok(Basis1d::new(p, spacing)?.eval(t))
}

/// `x(ξ)` and `J[r][c] = ∂x_r/∂ξ_c` of the order-`p` tensor Lagrange map
/// in `D` dimensions with control points `ctrl` in tensor order.
pub(crate) fn tensor_map<const D: usize>(
    basis: &Basis1d,
    ctrl: &[[f64; D]],
    xi: [f64; D],
) -> ([f64; D], [[f64; D]; D]) {
    let n = basis.p + 1;
    let e: Vec<(Vec<f64>, Vec<f64>)> = xi.iter().map(|&t| basis.eval(t)).collect();
    let mut x = [0.0; D];
    let mut jac = [[0.0; D]; D];
    for (a, c) in ctrl.iter().enumerate() {
        // the tensor index digits of node a
        let mut idx = [0usize; D];
        let mut rest = a;
        for d in idx.iter_mut() {
            *d = rest % n;
            rest /= n;
        }
        let mut w = 1.0;
        let mut dw = [1.0; D];
        for d in 0..D {
            w *= e[d].0[idx[d]];
            for (c2, dwc) in dw.iter_mut().enumerate() {
                *dwc *= if c2 == d {
                    e[d].1[idx[d]]
                } else {
                    e[d].0[idx[d]]
                };
            }
        }
        for r in 0..D {
            x[r] += w * c[r];
            for col in 0..D {
                jac[r][col] += dw[col] * c[r];
            }
        }
    }
    (x, jac)
}

/// `J[r][c] = ∂x_r/∂ξ_c` of the order-`p` tensor map at the `m^D` points
/// of the uniform grid `ξ_d = s_d/(m−1)` (first axis fastest), by sum
/// factorisation: one axis contracted at a time costs O(m·n^D + … + m^D·n)
/// per component instead of O(m^D·n^D) for [`tensor_map`] at each point.
/// Needs `m ≥ 2`.
#[inline]
pub(crate) fn jacobians_on_grid<const D: usize>(basis: &Basis1d, ctrl: &[[f64; D]], m: usize) -> Vec<[[f64; D]; D]> {
    let n = basis.p + 1;
    let (mut val, mut der) = (Vec::with_capacity(m * n), Vec::with_capacity(m * n));
    for s in 0..m {
        let (v, d) = basis.eval(s as f64 / (m - 1) as f64);
        val.extend(v);
        der.extend(d);
    }
    let total = m.pow(D as u32);
    let mut out = vec![[[0.0; D]; D]; total];
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for r in 0..D {
        for c in 0..D {
            a.clear();
            a.extend(ctrl.iter().map(|x| x[r]));
            // after contracting axes < k: shape (m,…,m, n,…,n)
            for k in 0..D {
                let table = if k == c { &der } else { &val };
                let (before, after) = (m.pow(k as u32), n.pow((D - 1 - k) as u32));
                contract_axis(&a, before, n, after, table, m, &mut b);
                std::mem::swap(&mut a, &mut b);
            }
            for (o, v) in out.iter_mut().zip(&a) {
                o[r][c] = *v;
            }
        }
    }
    out
}

/// `out[b + before·(s + m·a)] = Σ_i table[s·n + i] · input[b + before·(i + n·a)]`:
/// the m × n matrix `table` applied along one axis of a tensor.
fn contract_axis(input: &[f64], before: usize, n: usize, after: usize, table: &[f64], m: usize, out: &mut Vec<f64>) {
    out.clear();
    out.resize(before * m * after, 0.0);
    for a in 0..after {
        for s in 0..m {
            let o = &mut out[before * (s + m * a)..before * (s + 1 + m * a)];
            for (i, &w) in table[s * n..(s + 1) * n].iter().enumerate() {
                let x = &input[before * (i + n * a)..before * (i + 1 + n * a)];
                o.iter_mut().zip(x).for_each(|(o, x)| *o += w * x);
            }
        }
    }
}

/// The order-`p` quad map from `[0,1]²`: `(x(ξ), J)` with
/// `J[r][c] = ∂x_r/∂ξ_c`, for control points `ctrl` in tensor order
/// (`(p+1)²` of them, index `i + (p+1) j`).
pub fn quad_map(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; 2]],
    xi: [f64; 2],
) -> Result<([f64; 2], [[f64; 2]; 2]), HighOrderError> {
    check_nodes(p, 2, ctrl.len())?;
    Ok(tensor_map(&Basis1d::new(p, spacing)?, ctrl, xi))
}

/// The order-`p` hex map from `[0,1]³`: `(x(ξ), J)` with
/// `J[r][c] = ∂x_r/∂ξ_c`, for control points `ctrl` in tensor order
/// (`(p+1)³` of them, index `i + (p+1) j + (p+1)² k`).
pub fn hex_map(
    p: usize,
    spacing: Spacing,
    ctrl: &[[f64; 3]],
    xi: [f64; 3],
) -> Result<([f64; 3], [[f64; 3]; 3]), HighOrderError> {
    check_nodes(p, 3, ctrl.len())?;
    Ok(tensor_map(&Basis1d::new(p, spacing)?, ctrl, xi))
}

/// The reference coordinates of the `(p+1)^D` nodes in tensor order.
pub fn reference_nodes<const D: usize>(
    p: usize,
    spacing: Spacing,
) -> Result<Vec<[f64; D]>, HighOrderError> {
    check_order(p)?;
    let t = nodes_1d(p, spacing)?;
    let n = p + 1;
    Ok((0..n.pow(D as u32))
        .map(|a| {
            let mut rest = a;
            std::array::from_fn(|_| {
                let i = rest % n;
                rest /= n;
                t[i]
            })
        })
        .collect())
}

/// Determinant of a 2×2 or 3×3 matrix given as rows.
pub(crate) fn det<const D: usize>(m: &[[f64; D]; D]) -> f64 {
    match D {
        1 => m[0][0],
        2 => m[0][0] * m[1][1] - m[0][1] * m[1][0],
        3 => {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        }
        _ => unreachable!("only 1D to 3D maps exist here"),
    }
}

/// `det J / Π_c |J e_c|`: the determinant scaled by the lengths of the
/// Jacobian's columns (the images of the reference axes), 1 for an affine
/// map onto a square or cube, `≤ 1` always (Hadamard).
pub(crate) fn scaled_det<const D: usize>(m: &[[f64; D]; D]) -> f64 {
    let norms: f64 = (0..D)
        .map(|c| (0..D).map(|r| m[r][c] * m[r][c]).sum::<f64>().sqrt())
        .product();
    det(m) / norms
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_jacobians_are_the_pointwise_ones() {
        // a p = 3 hex with every control point moved: sum factorisation
        // must give tensor_map's J at every grid point
        let basis = Basis1d::new(3, Spacing::Equispaced).unwrap();
        let ctrl: Vec<[f64; 3]> = (0..64)
            .map(|a| {
                let (i, j, k) = (a % 4, (a / 4) % 4, a / 16);
                [i as f64 / 3.0 + 0.03 * (a as f64).sin(), j as f64 / 3.0 + 0.02 * (a as f64 * 0.7).cos(), k as f64 / 3.0 + 0.01 * a as f64 / 64.0]
            })
            .collect();
        let m = 5;
        let grid = jacobians_on_grid(&basis, &ctrl, m);
        assert_eq!(grid.len(), 125);
        for (s, j) in grid.iter().enumerate() {
            let xi = [s % m, (s / m) % m, s / (m * m)].map(|i| i as f64 / (m - 1) as f64);
            let (_, jr) = tensor_map(&basis, &ctrl, xi);
            for r in 0..3 {
                for c in 0..3 {
                    assert!((j[r][c] - jr[r][c]).abs() < 1e-13, "point {s}, J[{r}][{c}]: {} vs {}", j[r][c], jr[r][c]);
                }
            }
        }
    }

    #[test]
    fn partition_of_unity_and_kronecker() {
        for p in 1..=4 {
            for s in [Spacing::Equispaced, Spacing::GaussLobatto] {
                let b = Basis1d::new(p, s).unwrap();
                for k in 0..=20 {
                    let t = -0.1 + 1.2 * k as f64 / 20.0;
                    let (v, d) = b.eval(t);
                    assert!((v.iter().sum::<f64>() - 1.0).abs() < 1e-13);
                    assert!(d.iter().sum::<f64>().abs() < 1e-11);
                    // reproduces t^p exactly (degree p polynomial space)
                    let tp: f64 = v
                        .iter()
                        .zip(&b.nodes)
                        .map(|(l, x)| l * x.powi(p as i32))
                        .sum();
                    assert!((tp - t.powi(p as i32)).abs() < 1e-12);
                }
                for (i, &x) in b.nodes.iter().enumerate() {
                    let (v, _) = b.eval(x);
                    for (m, &vm) in v.iter().enumerate() {
                        assert!((vm - f64::from(u8::from(m == i))).abs() < 1e-14);
                    }
                }
            }
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        for p in 1..=4 {
            let b = Basis1d::new(p, Spacing::GaussLobatto).unwrap();
            for t in [0.0, 0.13, 0.5, 0.77, 1.0] {
                let h = 1e-6;
                let (_, d) = b.eval(t);
                let (vp, _) = b.eval(t + h);
                let (vm, _) = b.eval(t - h);
                for i in 0..=p {
                    let fd = (vp[i] - vm[i]) / (2.0 * h);
                    assert!(
                        (fd - d[i]).abs() < 1e-7,
                        "p={p} t={t} i={i}: {fd} vs {}",
                        d[i]
                    );
                }
            }
        }
    }

    /// A curved hex: the map's Jacobian agrees with central differences of
    /// the map, and an affine element reproduces its affine map exactly.
    #[test]
    fn hex_and_quad_jacobians_match_finite_differences() {
        for p in 1..=4 {
            let refs = reference_nodes::<3>(p, Spacing::Equispaced).unwrap();
            let ctrl: Vec<[f64; 3]> = refs
                .iter()
                .map(|&[u, v, w]| [u + 0.1 * (3.0 * v).sin(), v + 0.2 * u * w, w - 0.1 * u * u])
                .collect();
            let xi = [0.31, 0.72, 0.45];
            let (_, j) = hex_map(p, Spacing::Equispaced, &ctrl, xi).unwrap();
            let h = 1e-6;
            for c in 0..3 {
                let mut a = xi;
                let mut b = xi;
                a[c] += h;
                b[c] -= h;
                let (xa, _) = hex_map(p, Spacing::Equispaced, &ctrl, a).unwrap();
                let (xb, _) = hex_map(p, Spacing::Equispaced, &ctrl, b).unwrap();
                for r in 0..3 {
                    assert!(((xa[r] - xb[r]) / (2.0 * h) - j[r][c]).abs() < 1e-7);
                }
            }
            // affine quad: x = A ξ + b at every point, J = A
            let refs2 = reference_nodes::<2>(p, Spacing::GaussLobatto).unwrap();
            let aff = |[u, v]: [f64; 2]| [2.0 * u + 0.5 * v + 1.0, -0.3 * u + 1.5 * v];
            let ctrl2: Vec<[f64; 2]> = refs2.iter().map(|&q| aff(q)).collect();
            let (x, j) = quad_map(p, Spacing::GaussLobatto, &ctrl2, [0.2, 0.9]).unwrap();
            let e = aff([0.2, 0.9]);
            assert!((x[0] - e[0]).abs() < 1e-14 && (x[1] - e[1]).abs() < 1e-14);
            assert!((j[0][0] - 2.0).abs() < 1e-13 && (j[0][1] - 0.5).abs() < 1e-13);
            assert!((j[1][0] + 0.3).abs() < 1e-13 && (j[1][1] - 1.5).abs() < 1e-13);
        }
        assert!(quad_map(2, Spacing::Equispaced, &[[0.0; 2]; 8], [0.0; 2]).is_err());
    }
}
