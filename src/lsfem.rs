//! Least-squares finite elements for the div-curl system
//! `div u = g`, `curl u = 0` with bilinear (Q1) quadrilaterals.
//!
//! The discrete functional is `w‖div u − g‖² + ‖curl u‖²`. Boundary
//! conditions are imposed exactly, without penalties: a node's two
//! unknowns are rotated into its frame (normal, tangent) and constrained
//! components are eliminated, so the reduced system stays symmetric
//! positive definite. The sparsity pattern depends only on which
//! components are constrained, which never changes during a run: it is
//! built once ([`DivCurlSystem::new`]) and refilled each step
//! ([`DivCurlSystem::assemble`]).

use crate::mesh::{colour_cells, Point2, QuadMesh};
use crate::solve::SparsePattern;
use rayon::prelude::*;

/// The boundary condition of one node, in the form the assembly needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NodeConstraint {
    /// Interior node: both components free.
    Free,
    /// `u·n = value` with unit normal `n`; the tangential part is free.
    Normal {
        /// Unit normal.
        n: Point2,
        /// Prescribed normal component.
        value: f64,
    },
    /// Both components prescribed (Dirichlet).
    Fixed {
        /// Prescribed vector.
        value: Point2,
    },
}

impl NodeConstraint {
    /// The node's frame: columns are the directions of its two unknowns.
    fn frame(&self) -> [[f64; 2]; 2] {
        match *self {
            NodeConstraint::Normal { n, .. } => [n, [-n[1], n[0]]],
            _ => [[1.0, 0.0], [0.0, 1.0]],
        }
    }

    /// Prescribed values of the two rotated components (None = free).
    fn fixed_values(&self) -> [Option<f64>; 2] {
        match *self {
            NodeConstraint::Free => [None, None],
            NodeConstraint::Normal { value, .. } => [Some(value), None],
            NodeConstraint::Fixed { value } => [Some(value[0]), Some(value[1])],
        }
    }

    fn kind(&self) -> u8 {
        match self {
            NodeConstraint::Free => 0,
            NodeConstraint::Normal { .. } => 1,
            NodeConstraint::Fixed { .. } => 2,
        }
    }
}

/// Errors of the assembly.
#[derive(Debug, thiserror::Error)]
pub enum LsfemError {
    /// The constraints changed kind since the pattern was built.
    #[error("node {node}: constraint kind changed after the pattern was built")]
    KindChanged {
        /// The node.
        node: usize,
    },
    /// A cell has a non-positive Jacobian at a quadrature point.
    #[error("cell {cell} is inverted (det J = {det:e} at a quadrature point)")]
    Inverted {
        /// The cell.
        cell: usize,
        /// The determinant found.
        det: f64,
    },
}

const NONE: u32 = u32::MAX;
/// Gauss points on [0,1]: 1/2 ∓ 1/(2√3), weight 1/2 each.
const GAUSS: [f64; 2] = [0.211_324_865_405_187_1, 0.788_675_134_594_812_9];

/// Shape-function gradients of the reference square [0,1]² at (ξ, η).
pub fn q1_gradients(xi: f64, eta: f64) -> [[f64; 4]; 2] {
    [
        [-(1.0 - eta), 1.0 - eta, eta, -eta],
        [-(1.0 - xi), -xi, xi, 1.0 - xi],
    ]
}

/// Shape functions of the reference square at (ξ, η).
pub fn q1_values(xi: f64, eta: f64) -> [f64; 4] {
    [(1.0 - xi) * (1.0 - eta), xi * (1.0 - eta), xi * eta, (1.0 - xi) * eta]
}

/// Physical point, det J and physical gradients of a bilinear cell at (ξ, η).
/// `J[i][j] = ∂x_i/∂ξ_j`; gradients are `J⁻ᵀ ∇_ξ N` — the transpose matters
/// as soon as the cell is not a rectangle.
pub fn q1_map(p: &[Point2; 4], xi: f64, eta: f64) -> (Point2, f64, [[f64; 4]; 2]) {
    let n = q1_values(xi, eta);
    let d = q1_gradients(xi, eta);
    let mut x = [0.0; 2];
    let mut j = [[0.0; 2]; 2];
    for a in 0..4 {
        for i in 0..2 {
            x[i] += n[a] * p[a][i];
            j[i][0] += d[0][a] * p[a][i];
            j[i][1] += d[1][a] * p[a][i];
        }
    }
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    let mut g = [[0.0; 4]; 2];
    for a in 0..4 {
        g[0][a] = (j[1][1] * d[0][a] - j[1][0] * d[1][a]) / det;
        g[1][a] = (-j[0][1] * d[0][a] + j[0][0] * d[1][a]) / det;
    }
    (x, det, g)
}

/// The assembled reduced system: matrix values on a fixed pattern and the
/// right-hand side, over the free (rotated) unknowns.
pub struct DivCurlSystem {
    cells: Vec<[usize; 4]>,
    colours: Vec<Vec<usize>>,
    kinds: Vec<u8>,
    /// Free-unknown index of each node's two rotated components.
    dof: Vec<[u32; 2]>,
    pattern: SparsePattern,
    /// Per cell, the value position of each local pair (i ≥ j in global
    /// order), 8×8 row-major; NONE where a component is constrained.
    scatter: Vec<[u32; 64]>,
    /// Matrix values on `pattern`.
    pub values: Vec<f64>,
    /// Right-hand side over the free unknowns.
    pub rhs: Vec<f64>,
    /// Weight of the divergence term.
    pub div_weight: f64,
}

impl DivCurlSystem {
    /// Numbers the free unknowns and builds the pattern for `constraints`
    /// (only their kinds matter here).
    pub fn new(mesh: &QuadMesh, constraints: &[NodeConstraint]) -> DivCurlSystem {
        let mut next = 0u32;
        let dof: Vec<[u32; 2]> = constraints
            .iter()
            .map(|c| {
                c.fixed_values().map(|v| {
                    if v.is_some() {
                        NONE
                    } else {
                        next += 1;
                        next - 1
                    }
                })
            })
            .collect();
        let n = next as usize;
        let local = |cell: &[usize; 4]| -> [u32; 8] {
            let mut l = [NONE; 8];
            for a in 0..4 {
                l[2 * a] = dof[cell[a]][0];
                l[2 * a + 1] = dof[cell[a]][1];
            }
            l
        };
        let pairs = mesh.cells.iter().flat_map(|cell| {
            let l = local(cell);
            (0..64).filter_map(move |k| {
                let (i, j) = (l[k / 8], l[k % 8]);
                (i != NONE && j != NONE).then_some((i as usize, j as usize))
            })
        });
        let pattern = SparsePattern::from_pairs(n, pairs);
        let scatter = mesh
            .cells
            .par_iter()
            .map(|cell| {
                let l = local(cell);
                let mut s = [NONE; 64];
                for k in 0..64 {
                    let (i, j) = (l[k / 8], l[k % 8]);
                    if i != NONE && j != NONE && i >= j {
                        s[k] = pattern.position(i as usize, j as usize).expect("pattern entry") as u32;
                    }
                }
                s
            })
            .collect();
        DivCurlSystem {
            cells: mesh.cells.clone(),
            colours: colour_cells(&mesh.cells, mesh.num_nodes()),
            kinds: constraints.iter().map(NodeConstraint::kind).collect(),
            dof,
            values: vec![0.0; pattern.nnz()],
            rhs: vec![0.0; n],
            pattern,
            scatter,
            div_weight: 1.0,
        }
    }

    /// The sparsity pattern (lower triangle) of the reduced matrix.
    pub fn pattern(&self) -> &SparsePattern {
        &self.pattern
    }

    /// Number of free unknowns.
    pub fn num_unknowns(&self) -> usize {
        self.pattern.n
    }

    /// Fills matrix and right-hand side for nodes at `nodes`, constraints
    /// `constraints` (same kinds as at construction) and the divergence
    /// data `g(x)` at physical points. Parallel over cells of one colour.
    pub fn assemble<G>(&mut self, nodes: &[Point2], constraints: &[NodeConstraint], g: G) -> Result<(), LsfemError>
    where
        G: Fn(Point2) -> f64 + Sync,
    {
        if let Some(node) = (0..constraints.len()).find(|&i| constraints[i].kind() != self.kinds[i]) {
            return Err(LsfemError::KindChanged { node });
        }
        self.values.iter_mut().for_each(|v| *v = 0.0);
        self.rhs.iter_mut().for_each(|v| *v = 0.0);
        let values = SyncPtr(self.values.as_mut_ptr());
        let rhs = SyncPtr(self.rhs.as_mut_ptr());
        let (cells, scatter, dof, w) = (&self.cells, &self.scatter, &self.dof, self.div_weight);
        for group in &self.colours {
            group.par_iter().try_for_each(|&c| {
                let cell = &cells[c];
                let p = cell.map(|n| nodes[n]);
                let cons = cell.map(|n| constraints[n]);
                let (k, f) = element(c, &p, &cons, w, &g)?;
                // Cells of one colour share no node, hence no matrix entry
                // and no rhs entry: these writes never race.
                let (values, rhs) = (&values, &rhs);
                scatter_element(&k, &f, &scatter[c], cell, &cons, dof, values, rhs);
                Ok::<(), LsfemError>(())
            })?;
        }
        Ok(())
    }

    /// Nodal velocities from the solution `x` of the reduced system:
    /// free components from `x`, constrained ones from `constraints`,
    /// rotated back to (x, y).
    pub fn expand(&self, x: &[f64], constraints: &[NodeConstraint], out: &mut [Point2]) {
        for (node, c) in constraints.iter().enumerate() {
            let fixed = c.fixed_values();
            let w: [f64; 2] = std::array::from_fn(|k| match fixed[k] {
                Some(v) => v,
                None => x[self.dof[node][k] as usize],
            });
            let r = c.frame();
            out[node] = [r[0][0] * w[0] + r[1][0] * w[1], r[0][1] * w[0] + r[1][1] * w[1]];
        }
    }
}

#[derive(Clone, Copy)]
struct SyncPtr(*mut f64);
// SAFETY: used only for colour-disjoint writes, see `assemble`.
unsafe impl Sync for SyncPtr {}
unsafe impl Send for SyncPtr {}

/// Element matrix (8×8, row-major) and vector in the nodes' rotated frames.
fn element<G: Fn(Point2) -> f64>(
    c: usize,
    p: &[Point2; 4],
    cons: &[NodeConstraint; 4],
    w: f64,
    g: &G,
) -> Result<([f64; 64], [f64; 8]), LsfemError> {
    let frames = cons.map(|c| c.frame());
    let mut k = [0.0; 64];
    let mut f = [0.0; 8];
    for &xi in &GAUSS {
        for &eta in &GAUSS {
            let (x, det, grad) = q1_map(p, xi, eta);
            if !(det > 0.0) {
                return Err(LsfemError::Inverted { cell: c, det });
            }
            let weight = 0.25 * det;
            // div and curl rows in the rotated unknowns: b·R per node
            let mut bd = [0.0; 8];
            let mut bc = [0.0; 8];
            for a in 0..4 {
                let (dx, dy) = (grad[0][a], grad[1][a]);
                for (k_, col) in frames[a].iter().enumerate() {
                    bd[2 * a + k_] = dx * col[0] + dy * col[1];
                    bc[2 * a + k_] = -dy * col[0] + dx * col[1];
                }
            }
            let gq = g(x);
            for i in 0..8 {
                f[i] += weight * w * gq * bd[i];
                for j in 0..8 {
                    k[8 * i + j] += weight * (w * bd[i] * bd[j] + bc[i] * bc[j]);
                }
            }
        }
    }
    Ok((k, f))
}

#[allow(clippy::too_many_arguments)]
fn scatter_element(
    k: &[f64; 64],
    f: &[f64; 8],
    scatter: &[u32; 64],
    cell: &[usize; 4],
    cons: &[NodeConstraint; 4],
    dof: &[[u32; 2]],
    values: &SyncPtr,
    rhs: &SyncPtr,
) {
    let fixed: [Option<f64>; 8] = std::array::from_fn(|l| cons[l / 2].fixed_values()[l % 2]);
    for i in 0..8 {
        let gi = dof[cell[i / 2]][i % 2];
        if gi == NONE {
            continue;
        }
        // move the constrained columns to the right-hand side
        let mut fi = f[i];
        for j in 0..8 {
            if let Some(v) = fixed[j] {
                fi -= k[8 * i + j] * v;
            }
        }
        // SAFETY: colour-disjoint cells, see `assemble`.
        unsafe {
            *rhs.0.add(gi as usize) += fi;
            for j in 0..8 {
                let pos = scatter[8 * i + j];
                if pos != NONE {
                    *values.0.add(pos as usize) += k[8 * i + j];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::{CholeskySolver, SpdSolver};

    /// Solves the div-curl system for u = ∇ψ, ψ = sin(2x)eʸ: curl u = 0,
    /// div u = −3 sin(2x)eʸ. With the exact normal component on every side,
    /// Q1 LSFEM must converge to u; returns the max nodal error.
    fn solve_on(n: usize, distort: bool) -> f64 {
        let mut mesh = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], n, n);
        if distort {
            for p in &mut mesh.nodes {
                let s = 0.08 * (std::f64::consts::PI * p[0]).sin() * (std::f64::consts::PI * p[1]).sin();
                *p = [p[0] + s, p[1] + 0.5 * s];
            }
        }
        let exact = |p: Point2| [2.0 * (2.0 * p[0]).cos() * p[1].exp(), (2.0 * p[0]).sin() * p[1].exp()];
        let parts = mesh.node_parts();
        let normals = [[-1.0, 0.0], [1.0, 0.0], [0.0, -1.0], [0.0, 1.0]];
        let cons: Vec<NodeConstraint> = (0..mesh.num_nodes())
            .map(|i| match parts[i].as_slice() {
                [] => NodeConstraint::Free,
                [s] => {
                    let nrm = normals[*s];
                    let u = exact(mesh.nodes[i]);
                    NodeConstraint::Normal { n: nrm, value: u[0] * nrm[0] + u[1] * nrm[1] }
                }
                _ => NodeConstraint::Fixed { value: exact(mesh.nodes[i]) },
            })
            .collect();
        let mut sys = DivCurlSystem::new(&mesh, &cons);
        sys.assemble(&mesh.nodes, &cons, |x| -3.0 * (2.0 * x[0]).sin() * x[1].exp()).unwrap();
        let mut solver = CholeskySolver::new();
        solver.analyze(sys.pattern()).unwrap();
        solver.factor(&sys.values).unwrap();
        let mut x = sys.rhs.clone();
        solver.solve_in_place(&mut x).unwrap();
        let mut u = vec![[0.0; 2]; mesh.num_nodes()];
        sys.expand(&x, &cons, &mut u);
        u.iter()
            .zip(&mesh.nodes)
            .map(|(u, p)| {
                let e = exact(*p);
                (u[0] - e[0]).abs().max((u[1] - e[1]).abs())
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn recovers_linear_field_exactly() {
        // u = (x + 2y, 2x − y)... has curl 2 − 2 = 0 and div 0: use
        // u = (x, y) + (y, x): div 2, curl 0 — in the Q1 space, so exact.
        let mesh = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 5, 4);
        let exact = |p: Point2| [p[0] + p[1], p[1] + p[0]];
        let parts = mesh.node_parts();
        let normals = [[-1.0, 0.0], [1.0, 0.0], [0.0, -1.0], [0.0, 1.0]];
        let cons: Vec<NodeConstraint> = (0..mesh.num_nodes())
            .map(|i| match parts[i].as_slice() {
                [] => NodeConstraint::Free,
                [s] => {
                    let u = exact(mesh.nodes[i]);
                    NodeConstraint::Normal { n: normals[*s], value: u[0] * normals[*s][0] + u[1] * normals[*s][1] }
                }
                _ => NodeConstraint::Fixed { value: exact(mesh.nodes[i]) },
            })
            .collect();
        let mut sys = DivCurlSystem::new(&mesh, &cons);
        sys.assemble(&mesh.nodes, &cons, |_| 2.0).unwrap();
        let mut solver = CholeskySolver::new();
        solver.analyze(sys.pattern()).unwrap();
        solver.factor(&sys.values).unwrap();
        let mut x = sys.rhs.clone();
        solver.solve_in_place(&mut x).unwrap();
        let mut u = vec![[0.0; 2]; mesh.num_nodes()];
        sys.expand(&x, &cons, &mut u);
        for (u, p) in u.iter().zip(&mesh.nodes) {
            let e = exact(*p);
            assert!((u[0] - e[0]).abs() < 1e-12 && (u[1] - e[1]).abs() < 1e-12);
        }
    }

    #[test]
    fn converges_at_second_order_in_nodes() {
        for distort in [false, true] {
            let e1 = solve_on(8, distort);
            let e2 = solve_on(16, distort);
            let e3 = solve_on(32, distort);
            let r1 = (e1 / e2).log2();
            let r2 = (e2 / e3).log2();
            assert!(r1 > 1.7 && r2 > 1.7, "distort={distort}: errors {e1:e} {e2:e} {e3:e}, rates {r1} {r2}");
        }
    }

    #[test]
    fn changed_kind_is_an_error() {
        let mesh = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 2, 2);
        let mut cons = vec![NodeConstraint::Fixed { value: [0.0; 2] }; 9];
        cons[4] = NodeConstraint::Free;
        let mut sys = DivCurlSystem::new(&mesh, &cons);
        cons[4] = NodeConstraint::Normal { n: [1.0, 0.0], value: 0.0 };
        assert!(matches!(sys.assemble(&mesh.nodes, &cons, |_| 0.0), Err(LsfemError::KindChanged { node: 4 })));
    }
}
