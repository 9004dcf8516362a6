//! Least-squares finite elements for the div-curl system
//! `div u = g`, `curl u = 0` with Q1 elements: bilinear quadrilaterals
//! (D = 2, N = 4 nodes) and trilinear hexahedra (D = 3, N = 8).
//!
//! The discrete functional is `w‖div u − g‖² + ‖curl u‖²` (the curl is a
//! scalar in 2D, a vector in 3D). Boundary conditions are imposed
//! exactly, without penalties: a node's unknowns are the components of u
//! in an orthonormal frame of its own, the leading ones of which may be
//! prescribed and are eliminated, so the reduced system stays symmetric
//! positive definite. The sparsity pattern depends only on how many
//! components each node has prescribed, which never changes during a run:
//! it is built once ([`DivCurlSystem::new`]) and refilled each step
//! ([`DivCurlSystem::assemble`]).

use crate::mesh::{colour_blocks, Point2};
use crate::solve::{Csr, Structure};
use rayon::prelude::*;
use std::ops::Range;

/// The boundary condition of one node: u's components along the columns
/// of `frame` (orthonormal) are the node's unknowns, and the first
/// `fixed` of them are prescribed by `values`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Constraint<const D: usize> {
    /// Orthonormal directions of the node's unknowns.
    pub frame: [[f64; D]; D],
    /// How many leading components are prescribed.
    pub fixed: usize,
    /// Prescribed values of the leading components.
    pub values: [f64; D],
}

/// A 2D node constraint.
pub type NodeConstraint = Constraint<2>;

impl<const D: usize> Constraint<D> {
    /// Both (all) components free: an interior node.
    pub fn free() -> Self {
        Constraint { frame: identity(), fixed: 0, values: [0.0; D] }
    }

    /// u prescribed (Dirichlet).
    pub fn fixed(value: [f64; D]) -> Self {
        Constraint { frame: identity(), fixed: D, values: value }
    }
}

fn identity<const D: usize>() -> [[f64; D]; D] {
    std::array::from_fn(|k| std::array::from_fn(|i| if i == k { 1.0 } else { 0.0 }))
}

impl Constraint<2> {
    /// `u·n = value` (n unit); the tangential part is free.
    pub fn normal(n: Point2, value: f64) -> Self {
        Constraint { frame: [n, [-n[1], n[0]]], fixed: 1, values: [value, 0.0] }
    }
}

impl Constraint<3> {
    /// `u·n = value` (n unit); the two tangential components are free.
    pub fn normal(n: [f64; 3], value: f64) -> Self {
        let (t1, t2) = complement(n);
        Constraint { frame: [n, t1, t2], fixed: 1, values: [value, 0.0, 0.0] }
    }

    /// u's components across the unit direction `tau` equal those of `v`;
    /// the component along `tau` is free: the node glides along a curve
    /// with tangent `tau` that itself moves with velocity `v`.
    pub fn along(tau: [f64; 3], v: [f64; 3]) -> Self {
        let (e1, e2) = complement(tau);
        let dot = |a: [f64; 3]| a[0] * v[0] + a[1] * v[1] + a[2] * v[2];
        Constraint { frame: [e1, e2, tau], fixed: 2, values: [dot(e1), dot(e2), 0.0] }
    }
}

/// Two unit vectors completing the unit vector `n` to a right-handed
/// orthonormal frame.
pub fn complement(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    // start from the axis least aligned with n
    let a = if n[0].abs() < 0.6 { [1.0, 0.0, 0.0] } else if n[1].abs() < 0.6 { [0.0, 1.0, 0.0] } else { [0.0, 0.0, 1.0] };
    let d = a[0] * n[0] + a[1] * n[1] + a[2] * n[2];
    let t = [a[0] - d * n[0], a[1] - d * n[1], a[2] - d * n[2]];
    let l = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
    let t1 = [t[0] / l, t[1] / l, t[2] / l];
    let t2 = [n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2], n[0] * t1[1] - n[1] * t1[0]];
    (t1, t2)
}

/// Errors of the assembly.
#[derive(Debug, thiserror::Error)]
pub enum LsfemError {
    /// The constraints changed kind since the pattern was built.
    #[error("node {node}: the number of prescribed components changed after the pattern was built")]
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

/// Most cells per colouring block of the assembly (fewer on small meshes,
/// which still get 64 blocks to share among the cores). On the 48³
/// quarter ball, blocks of 128 or 1024 cells halved the assembly time
/// against single cells (each colour then streamed the whole matrix).
const CELLS_PER_BLOCK: usize = 512;
/// Gauss points on `[0,1]`: 1/2 ∓ 1/(2√3), weight 1/2 each.
pub const GAUSS: [f64; 2] = [0.211_324_865_405_187_1, 0.788_675_134_594_812_9];
/// Largest number of unknowns of one cell (a hexahedron: 8 × 3).
const MAX_LOCAL: usize = 24;

/// Reference coordinates of Q1 node `a` (Gmsh/VTK order: the bottom face
/// counter-clockwise, then the top face).
fn corner(a: usize, d: usize) -> f64 {
    match d {
        0 => [0.0, 1.0, 1.0, 0.0][a % 4],
        1 => [0.0, 0.0, 1.0, 1.0][a % 4],
        _ => (a / 4) as f64,
    }
}

/// Reference coordinate along axis `d` of Q1 node `a` (0 or 1).
pub fn q1_corner(a: usize, d: usize) -> f64 {
    corner(a, d)
}

/// Whether a linear cell of `N` nodes in dimension `D` is a simplex (a
/// triangle or a tetrahedron) rather than a tensor cell (quad, hex): the
/// kind is the node count, fixed at compile time, so each kind's loops
/// are compiled apart and the tensor paths are unchanged.
pub const fn is_simplex(d: usize, n: usize) -> bool {
    n == d + 1
}

/// Reference coordinates of node `a` of a linear cell: a corner of
/// `[0,1]^D` (tensor cells) or of the unit simplex, whose node 0 is the
/// origin and node `k + 1` the unit vector `e_k` (Gmsh's order).
pub fn linear_corner<const D: usize, const N: usize>(a: usize) -> [f64; D] {
    if is_simplex(D, N) {
        std::array::from_fn(|d| if a == d + 1 { 1.0 } else { 0.0 })
    } else {
        std::array::from_fn(|d| corner(a, d))
    }
}

/// Shape functions of the linear reference cell at ξ: the Q1 functions of
/// `[0,1]^D`, or the barycentric coordinates of the simplex.
pub fn q1_shape<const D: usize, const N: usize>(xi: [f64; D]) -> [f64; N] {
    if is_simplex(D, N) {
        return std::array::from_fn(|a| if a == 0 { 1.0 - xi.iter().sum::<f64>() } else { xi[a - 1] });
    }
    std::array::from_fn(|a| (0..D).map(|d| if corner(a, d) == 1.0 { xi[d] } else { 1.0 - xi[d] }).product())
}

/// Reference gradients: `g[d][a] = ∂N_a/∂ξ_d` (constant on a simplex).
pub fn q1_shape_gradients<const D: usize, const N: usize>(xi: [f64; D]) -> [[f64; N]; D] {
    if is_simplex(D, N) {
        return std::array::from_fn(|d| std::array::from_fn(|a| if a == 0 { -1.0 } else if a == d + 1 { 1.0 } else { 0.0 }));
    }
    std::array::from_fn(|d| {
        std::array::from_fn(|a| {
            (0..D)
                .map(|e| {
                    let on = corner(a, e) == 1.0;
                    match (e == d, on) {
                        (true, true) => 1.0,
                        (true, false) => -1.0,
                        (false, true) => xi[e],
                        (false, false) => 1.0 - xi[e],
                    }
                })
                .product()
        })
    })
}

/// Physical point, det J and physical gradients of a Q1 cell at ξ.
/// `J[i][j] = ∂x_i/∂ξ_j`; gradients are `J⁻ᵀ ∇_ξ N` — the transpose matters
/// as soon as the cell is not a rectangle.
pub fn q1_eval<const D: usize, const N: usize>(p: &[[f64; D]; N], xi: [f64; D]) -> ([f64; D], f64, [[f64; N]; D]) {
    let n: [f64; N] = q1_shape(xi);
    let dn: [[f64; N]; D] = q1_shape_gradients(xi);
    let mut x = [0.0; D];
    let mut j = [[0.0; D]; D];
    for a in 0..N {
        for i in 0..D {
            x[i] += n[a] * p[a][i];
            for k in 0..D {
                j[i][k] += dn[k][a] * p[a][i];
            }
        }
    }
    let (det, inv) = det_inverse(&j);
    // ∇N = J⁻ᵀ ∇_ξ N: g[i][a] = Σ_k inv[k][i] dn[k][a]
    let g = std::array::from_fn(|i| std::array::from_fn(|a| (0..D).map(|k| inv[k][i] * dn[k][a]).sum()));
    (x, det, g)
}

/// The 2D case of [`q1_eval`] with (ξ, η) arguments.
pub fn q1_map(p: &[Point2; 4], xi: f64, eta: f64) -> (Point2, f64, [[f64; 4]; 2]) {
    q1_eval(p, [xi, eta])
}

/// Determinant and inverse of a 2×2 or 3×3 matrix.
fn det_inverse<const D: usize>(j: &[[f64; D]; D]) -> (f64, [[f64; D]; D]) {
    let mut inv = [[0.0; D]; D];
    if D == 2 {
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        inv[0][0] = j[1][1] / det;
        inv[0][1] = -j[0][1] / det;
        inv[1][0] = -j[1][0] / det;
        inv[1][1] = j[0][0] / det;
        return (det, inv);
    }
    let c = |r: usize, s: usize| {
        let (r1, r2, s1, s2) = ((r + 1) % 3, (r + 2) % 3, (s + 1) % 3, (s + 2) % 3);
        j[r1][s1] * j[r2][s2] - j[r1][s2] * j[r2][s1]
    };
    let det = j[0][0] * c(0, 0) + j[0][1] * c(0, 1) + j[0][2] * c(0, 2);
    for r in 0..3 {
        for s in 0..3 {
            inv[s][r] = c(r, s) / det;
        }
    }
    (det, inv)
}

/// Tensor Gauss points (2 per direction) of `[0,1]^D` with their weights.
pub fn gauss_points<const D: usize>() -> impl Iterator<Item = ([f64; D], f64)> {
    (0..1usize << D).map(|k| (std::array::from_fn(|d| GAUSS[(k >> d) & 1]), 1.0 / (1 << D) as f64))
}

/// The degree-2 rule of the unit triangle: its three points at
/// barycentrics (2/3, 1/6, 1/6) and rotations, weight 1/6 each.
const TRIANGLE_RULE: [([f64; 2], f64); 3] = [([1.0 / 6.0, 1.0 / 6.0], 1.0 / 6.0), ([2.0 / 3.0, 1.0 / 6.0], 1.0 / 6.0), ([1.0 / 6.0, 2.0 / 3.0], 1.0 / 6.0)];
/// The degree-2 rule of the unit tetrahedron: four points at barycentrics
/// (a, b, b, b) and permutations, a = (5 + 3√5)/20, b = (5 − √5)/20,
/// weight 1/24 each.
const TET_A: f64 = 0.585_410_196_624_968_5;
const TET_B: f64 = 0.138_196_601_125_010_5;

/// Quadrature of the linear reference cell, exact for the products of two
/// Q1 functions' gradients times a linear f (what Algorithm 1 integrates):
/// [`gauss_points`] on tensor cells; on simplices the degree-2 rules
/// (the gradients are constant there, so the rule only weighs f).
pub fn cell_quadrature<const D: usize, const N: usize>() -> impl Iterator<Item = ([f64; D], f64)> {
    let simplex = is_simplex(D, N);
    let count = if !simplex { 1 << D } else { D + 1 };
    (0..count).map(move |k| {
        if !simplex {
            return (std::array::from_fn(|d| GAUSS[(k >> d) & 1]), 1.0 / (1 << D) as f64);
        }
        if D == 2 {
            let (x, w) = TRIANGLE_RULE[k];
            return (std::array::from_fn(|d| x[d]), w);
        }
        // point k has barycentric a at vertex k (vertex 0 is the origin)
        (std::array::from_fn(|d| if k == d + 1 { TET_A } else { TET_B }), 1.0 / 24.0)
    })
}

/// The assembled reduced system: the symmetric matrix over the free
/// (rotated) unknowns, its right-hand side, and what a multigrid needs to
/// know of it (node blocks, near-null space).
///
/// A node's free unknowns are numbered consecutively, so in the matrix the
/// columns of one neighbour node form one run in every row of a node.
/// The pattern records, per cell and pair of its nodes, where that run
/// starts in the row: assembly adds an element matrix with no search.
pub struct DivCurlSystem<const D: usize = 2, const N: usize = 4> {
    /// The cells with a free unknown (a cell whose nodes are all
    /// prescribed adds nothing to the reduced system: Algorithm 2's band
    /// holds most of a mesh), and their numbers in the mesh.
    cells: Vec<[usize; N]>,
    ids: Vec<usize>,
    /// Blocks of consecutive cells, grouped so that blocks of one colour
    /// share no node.
    colours: Vec<Vec<Range<usize>>>,
    fixed_counts: Vec<usize>,
    /// Free-unknown index of each node's rotated components (NONE if fixed).
    dof: Vec<[u32; D]>,
    /// Per cell, N × N offsets: where node b's run starts in node a's rows.
    offsets: Vec<u32>,
    matrix: Csr,
    node_ptr: Vec<u32>,
    near_null: Vec<f64>,
    /// Right-hand side over the free unknowns.
    pub rhs: Vec<f64>,
    /// Weight of the divergence term.
    pub div_weight: f64,
}

impl<const D: usize, const N: usize> DivCurlSystem<D, N> {
    /// Numbers the free unknowns and builds the pattern for `constraints`
    /// (only their numbers of prescribed components matter here).
    pub fn new(cells: &[[usize; N]], constraints: &[Constraint<D>]) -> Self {
        let nodes = constraints.len();
        let free: Vec<u32> = constraints.iter().map(|c| (D - c.fixed) as u32).collect();
        let mut first = vec![0u32; nodes + 1];
        for i in 0..nodes {
            first[i + 1] = first[i] + free[i];
        }
        let n = first[nodes] as usize;
        let ids: Vec<usize> = (0..cells.len()).filter(|&c| cells[c].iter().any(|&v| free[v] > 0)).collect();
        let cells: Vec<[usize; N]> = ids.iter().map(|&c| cells[c]).collect();
        let cells = &cells[..];
        let dof: Vec<[u32; D]> =
            constraints.iter().zip(&first).map(|(c, &f)| std::array::from_fn(|k| if k < c.fixed { NONE } else { f + (k - c.fixed) as u32 })).collect();
        let neighbours = node_neighbours(cells, &free);
        let (free_ref, neighbours_ref) = (&free, &neighbours);
        // the run of neighbour j in node i's rows starts after the runs of
        // the neighbours numbered below j
        let run_start = move |i: usize, j: usize| -> u32 {
            let nb = &neighbours_ref[i];
            let at = nb.binary_search(&(j as u32)).expect("cell nodes are neighbours");
            nb[..at].iter().map(|&m| free_ref[m as usize]).sum()
        };
        let offsets: Vec<u32> = cells
            .par_iter()
            .flat_map_iter(|cell| {
                (0..N * N).map(move |ab| {
                    let (i, j) = (cell[ab / N], cell[ab % N]);
                    if free_ref[i] == 0 || free_ref[j] == 0 { NONE } else { run_start(i, j) }
                })
            })
            .collect();
        let mut row_ptr = Vec::with_capacity(n + 1);
        let mut col = Vec::new();
        row_ptr.push(0);
        for i in 0..nodes {
            for _ in 0..free[i] {
                for &j in &neighbours[i] {
                    col.extend(first[j as usize]..first[j as usize + 1]);
                }
                row_ptr.push(col.len());
            }
        }
        let node_ptr: Vec<u32> = (0..nodes).filter(|&i| free[i] > 0).map(|i| first[i]).chain([n as u32]).collect();
        let matrix = Csr { nrows: n, ncols: n, val: vec![0.0; col.len()], row_ptr, col };
        DivCurlSystem {
            cells: cells.to_vec(),
            ids,
            colours: colour_blocks(cells, nodes, (cells.len() / 64).clamp(8, CELLS_PER_BLOCK)),
            fixed_counts: constraints.iter().map(|c| c.fixed).collect(),
            dof,
            offsets,
            matrix,
            node_ptr,
            near_null: vec![0.0; D * n],
            rhs: vec![0.0; n],
            div_weight: 1.0,
        }
    }

    /// The assembled matrix (both triangles).
    pub fn matrix(&self) -> &Csr {
        &self.matrix
    }

    /// Node blocks and near-null space (the D translations in the nodes'
    /// frames) of the last assembly, for an algebraic multigrid.
    pub fn structure(&self) -> Structure<'_> {
        Structure { node_ptr: &self.node_ptr, near_null: &self.near_null, count: D }
    }

    /// Number of free unknowns.
    pub fn num_unknowns(&self) -> usize {
        self.matrix.nrows
    }

    /// Fills matrix and right-hand side for nodes at `nodes`, constraints
    /// `constraints` (same kinds as at construction) and the divergence
    /// data `g(x)` at physical points. Parallel over cells of one colour.
    pub fn assemble<G>(&mut self, nodes: &[[f64; D]], constraints: &[Constraint<D>], g: G) -> Result<(), LsfemError>
    where
        G: Fn([f64; D]) -> f64 + Sync,
    {
        if let Some(node) = (0..constraints.len()).find(|&i| constraints[i].fixed != self.fixed_counts[i]) {
            return Err(LsfemError::KindChanged { node });
        }
        self.fill_near_null(constraints);
        self.matrix.val.par_iter_mut().for_each(|v| *v = 0.0);
        self.rhs.par_iter_mut().for_each(|v| *v = 0.0);
        let values = SyncPtr(self.matrix.val.as_mut_ptr());
        let rhs = SyncPtr(self.rhs.as_mut_ptr());
        let (cells, ids, dof, w) = (&self.cells, &self.ids, &self.dof, self.div_weight);
        let (row_ptr, offsets) = (&self.matrix.row_ptr, &self.offsets);
        for group in &self.colours {
            group.par_iter().try_for_each(|block| {
                for c in block.clone() {
                    let cell = &cells[c];
                    let p = cell.map(|n| nodes[n]);
                    let cons = cell.map(|n| constraints[n]);
                    let (k, f) = element(ids[c], &p, &cons, w, &g)?;
                    let at = Scatter { rows: cell.map(|n| dof[n]), row_ptr, offsets: &offsets[c * N * N..(c + 1) * N * N] };
                    // Blocks of one colour share no node, hence no matrix
                    // row and no rhs entry: these writes never race.
                    at.add(&k, &f, &cons, &values, &rhs);
                }
                Ok::<(), LsfemError>(())
            })?;
        }
        Ok(())
    }

    /// The translations in each node's frame: unknown k of a node is u's
    /// component along its frame's k-th direction, so translation e_d has
    /// there the value frame[k][d].
    fn fill_near_null(&mut self, constraints: &[Constraint<D>]) {
        let n = self.matrix.nrows;
        for (c, dofs) in constraints.iter().zip(&self.dof) {
            for k in c.fixed..D {
                let i = dofs[k] as usize;
                for d in 0..D {
                    self.near_null[d * n + i] = c.frame[k][d];
                }
            }
        }
    }

/// Nodal u from the solution `x` of the reduced system: free
    /// components from `x`, prescribed ones from `constraints`, rotated
    /// back to Cartesian components.
    pub fn expand(&self, x: &[f64], constraints: &[Constraint<D>], out: &mut [[f64; D]]) {
        for (node, c) in constraints.iter().enumerate() {
            let mut u = [0.0; D];
            for k in 0..D {
                let w = if k < c.fixed { c.values[k] } else { x[self.dof[node][k] as usize] };
                for i in 0..D {
                    u[i] += w * c.frame[k][i];
                }
            }
            out[node] = u;
        }
    }
}

#[derive(Clone, Copy)]
struct SyncPtr(*mut f64);
// SAFETY: used only for colour-disjoint writes, see `assemble`.
unsafe impl Sync for SyncPtr {}
unsafe impl Send for SyncPtr {}

/// Element matrix (row-major, D·N square) and vector in the nodes' frames.
///
/// Pointwise |curl u|² = |∇u|² − Σ_kl ∂_l u_k ∂_k u_l, so on the Cartesian
/// block of nodes (a, b) the functional w·|div u|² + |curl u|² gives
/// `K_ab[k][l] = w·M_kl + δ_kl·tr M − M_lk` with `M_kl = ∫ ∂_k N_a ∂_l N_b`.
/// Summing the D² products M over the quadrature points costs a quarter
/// of forming the div and curl rows and their outer products; the frames
/// of boundary nodes are applied afterwards, to their rows and columns.
fn element<const D: usize, const N: usize, G: Fn([f64; D]) -> f64>(
    c: usize,
    p: &[[f64; D]; N],
    cons: &[Constraint<D>; N],
    w: f64,
    g: &G,
) -> Result<([f64; MAX_LOCAL * MAX_LOCAL], [f64; MAX_LOCAL]), LsfemError> {
    // m[(k·D + l)·N·N + a·N + b] = Σ_q w_q ∂_k N_a ∂_l N_b
    let mut m = [0.0; MAX_LOCAL * MAX_LOCAL];
    let mut f = [0.0; MAX_LOCAL];
    for (xi, weight) in cell_quadrature::<D, N>() {
        let (x, det, grad) = q1_eval(p, xi);
        if !(det > 0.0) {
            return Err(LsfemError::Inverted { cell: c, det });
        }
        let wq = weight * det;
        let s = wq * w * g(x);
        for a in 0..N {
            for k in 0..D {
                f[D * a + k] += s * grad[k][a];
            }
        }
        for k in 0..D {
            for l in 0..D {
                let block = &mut m[(k * D + l) * N * N..(k * D + l + 1) * N * N];
                for a in 0..N {
                    let ga = wq * grad[k][a];
                    for (b, mb) in block[a * N..(a + 1) * N].iter_mut().enumerate() {
                        *mb += ga * grad[l][b];
                    }
                }
            }
        }
    }
    let nd = D * N;
    let mut k = [0.0; MAX_LOCAL * MAX_LOCAL];
    let at = |kk: usize, l: usize, a: usize, b: usize| m[(kk * D + l) * N * N + a * N + b];
    for a in 0..N {
        for b in 0..N {
            let trace: f64 = (0..D).map(|i| at(i, i, a, b)).sum();
            for kk in 0..D {
                for l in 0..D {
                    let diag = if kk == l { trace } else { 0.0 };
                    k[(D * a + kk) * nd + D * b + l] = w * at(kk, l, a, b) + diag - at(l, kk, a, b);
                }
            }
        }
    }
    rotate_to_frames(&mut k, &mut f, cons);
    Ok((k, f))
}

/// K ← F K Fᵀ and f ← F f, F block-diagonal with the nodes' frames (rows
/// = directions); nodes with the Cartesian frame are skipped.
fn rotate_to_frames<const D: usize, const N: usize>(k: &mut [f64; MAX_LOCAL * MAX_LOCAL], f: &mut [f64; MAX_LOCAL], cons: &[Constraint<D>; N]) {
    let nd = D * N;
    let cartesian = identity::<D>();
    for (a, ca) in cons.iter().enumerate() {
        if ca.frame == cartesian {
            continue;
        }
        let rotate = |v: [f64; D]| -> [f64; D] { std::array::from_fn(|r| (0..D).map(|i| ca.frame[r][i] * v[i]).sum()) };
        let fa = rotate(std::array::from_fn(|i| f[D * a + i]));
        f[D * a..D * a + D].copy_from_slice(&fa);
        for col in 0..nd {
            let ka = rotate(std::array::from_fn(|i| k[(D * a + i) * nd + col]));
            for (r, v) in ka.into_iter().enumerate() {
                k[(D * a + r) * nd + col] = v;
            }
        }
        for row in 0..nd {
            let ka = rotate(std::array::from_fn(|i| k[row * nd + D * a + i]));
            k[row * nd + D * a..row * nd + D * a + D].copy_from_slice(&ka);
        }
    }
}

/// Where one cell's element matrix goes: the free-unknown numbers of its
/// nodes, and the runs of its node pairs in the matrix rows.
struct Scatter<'a, const D: usize, const N: usize> {
    rows: [[u32; D]; N],
    row_ptr: &'a [usize],
    offsets: &'a [u32],
}

impl<const D: usize, const N: usize> Scatter<'_, D, N> {
    /// Adds the element matrix and vector (prescribed columns moved to the
    /// right-hand side).
    fn add(&self, k: &[f64; MAX_LOCAL * MAX_LOCAL], f: &[f64; MAX_LOCAL], cons: &[Constraint<D>; N], values: &SyncPtr, rhs: &SyncPtr) {
        let nd = D * N;
        for a in 0..N {
            for ka in cons[a].fixed..D {
                let i = D * a + ka;
                let gi = self.rows[a][ka] as usize;
                let mut fi = f[i];
                for (b, cb) in cons.iter().enumerate() {
                    for kb in 0..cb.fixed {
                        fi -= k[nd * i + D * b + kb] * cb.values[kb];
                    }
                }
                // SAFETY: colour-disjoint cells, see `assemble`.
                unsafe {
                    *rhs.0.add(gi) += fi;
                    for (b, cb) in cons.iter().enumerate() {
                        if cb.fixed == D {
                            continue;
                        }
                        let run = self.row_ptr[gi] + self.offsets[a * N + b] as usize;
                        for kb in cb.fixed..D {
                            *values.0.add(run + kb - cb.fixed) += k[nd * i + D * b + kb];
                        }
                    }
                }
            }
        }
    }
}

/// The cells at each node, as a CSR pair: node i's cells are
/// `of[ptr[i]..ptr[i + 1]]`, in increasing order.
pub(crate) fn node_cells<const N: usize>(cells: &[[usize; N]], nodes: usize) -> (Vec<usize>, Vec<u32>) {
    let mut ptr = vec![0usize; nodes + 1];
    for cell in cells {
        for &v in cell {
            ptr[v + 1] += 1;
        }
    }
    for i in 0..nodes {
        ptr[i + 1] += ptr[i];
    }
    let mut fill = ptr.clone();
    let mut of = vec![0u32; ptr[nodes]];
    for (c, cell) in cells.iter().enumerate() {
        for &v in cell {
            of[fill[v]] = c as u32;
            fill[v] += 1;
        }
    }
    (ptr, of)
}

/// Each node's neighbours (nodes sharing a cell, itself included) that
/// have free unknowns, sorted; empty for a node without any.
fn node_neighbours<const N: usize>(cells: &[[usize; N]], free: &[u32]) -> Vec<Vec<u32>> {
    let nodes = free.len();
    let (ptr, of) = node_cells(cells, nodes);
    (0..nodes)
        .into_par_iter()
        .map(|i| {
            if free[i] == 0 {
                return Vec::new();
            }
            let mut nb: Vec<u32> =
                of[ptr[i]..ptr[i + 1]].iter().flat_map(|&c| cells[c as usize]).filter(|&j| free[j] > 0).map(|j| j as u32).collect();
            nb.sort_unstable();
            nb.dedup();
            nb
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::QuadMesh;
    use crate::solve::{CholeskySolver, SpdSolver};

    /// The element matrix straight from the definition: at each Gauss
    /// point the div and curl rows in the nodes' frames, K += w_q BᵀB.
    /// The load vector is f += w_q·w·g·(div row) for a constant g.
    fn element_by_rows<const D: usize, const N: usize>(p: &[[f64; D]; N], cons: &[Constraint<D>; N], w: f64, g: f64) -> (Vec<f64>, Vec<f64>) {
        let nd = D * N;
        let mut k = vec![0.0; nd * nd];
        let mut f = vec![0.0; nd];
        for (xi, weight) in gauss_points::<D>() {
            let (_, det, grad) = q1_eval(p, xi);
            let mut rows = vec![vec![0.0; nd]; 4];
            for a in 0..N {
                let g: [f64; 3] = std::array::from_fn(|i| if i < D { grad[i][a] } else { 0.0 });
                let curl = if D == 2 { [[-g[1], g[0], 0.0], [0.0; 3], [0.0; 3]] } else { [[0.0, -g[2], g[1]], [g[2], 0.0, -g[0]], [-g[1], g[0], 0.0]] };
                for (kk, dir) in cons[a].frame.iter().enumerate() {
                    rows[0][D * a + kk] = w.sqrt() * (0..D).map(|i| g[i] * dir[i]).sum::<f64>();
                    for r in 0..3 {
                        rows[r + 1][D * a + kk] = (0..D).map(|i| curl[r][i] * dir[i]).sum();
                    }
                }
            }
            for i in 0..nd {
                f[i] += weight * det * w.sqrt() * g * rows[0][i];
                for j in 0..nd {
                    k[i * nd + j] += weight * det * rows.iter().map(|b| b[i] * b[j]).sum::<f64>();
                }
            }
        }
        (k, f)
    }

    #[test]
    fn element_matrix_matches_the_div_and_curl_rows() {
        // a distorted hex with one slip node, one gliding node and one
        // fixed node; divergence weight ≠ 1 so both terms are checked
        let mut p: [[f64; 3]; 8] = std::array::from_fn(|a| std::array::from_fn(|d| q1_corner(a, d)));
        for (a, q) in p.iter_mut().enumerate() {
            q[0] += 0.1 * (a as f64).sin();
            q[1] += 0.07 * (a as f64 * 1.7).cos();
            q[2] += 0.05 * a as f64 / 8.0;
        }
        let v: [f64; 3] = [0.3, -0.4, 0.866];
        let n = v.map(|x| x / (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt());
        let mut cons = [Constraint::<3>::free(); 8];
        cons[1] = Constraint::<3>::normal(n, 0.2);
        cons[4] = Constraint::<3>::along([0.0, 0.6, 0.8], [0.1, 0.2, 0.3]);
        cons[6] = Constraint::fixed([0.1, 0.0, -0.1]);
        let (k, f) = element(0, &p, &cons, 1.7, &|_| 2.0).unwrap();
        let (k_ref, f_ref) = element_by_rows(&p, &cons, 1.7, 2.0);
        let largest = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let err = (0..24 * 24).fold(0.0f64, |m, i| m.max((k[i] - k_ref[i]).abs()));
        assert!(err < 1e-14 * largest(&k_ref), "K: largest difference {err:e} of {:e}", largest(&k_ref));
        let err = (0..24).fold(0.0f64, |m, i| m.max((f[i] - f_ref[i]).abs()));
        assert!(err < 1e-14 * largest(&f_ref), "f: largest difference {err:e} of {:e}", largest(&f_ref));
    }

    /// Solves the div-curl system for u = ∇ψ, ψ = sin(2x)eʸ: curl u = 0,
    /// div u = −3 sin(2x)eʸ. With the exact normal component on every side,
    /// Q1 LSFEM must converge to u; returns the max nodal error.
    /// Solves an assembled system by Cholesky; the largest nodal error of
    /// the solution against `exact`.
    fn nodal_error<const D: usize, const N: usize>(sys: &DivCurlSystem<D, N>, cons: &[Constraint<D>], nodes: &[[f64; D]], exact: impl Fn([f64; D]) -> [f64; D]) -> f64 {
        let mut solver = CholeskySolver::new();
        solver.analyze(sys.matrix()).unwrap();
        solver.factor(sys.matrix(), sys.structure()).unwrap();
        let mut x = sys.rhs.clone();
        solver.solve_in_place(sys.matrix(), &mut x).unwrap();
        let mut u = vec![[0.0; D]; nodes.len()];
        sys.expand(&x, cons, &mut u);
        u.iter().zip(nodes).map(|(u, p)| (0..D).map(|k| (u[k] - exact(*p)[k]).abs()).fold(0.0, f64::max)).fold(0.0, f64::max)
    }

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
                [] => NodeConstraint::free(),
                [s] => {
                    let nrm = normals[*s];
                    let u = exact(mesh.nodes[i]);
                    NodeConstraint::normal(nrm, u[0] * nrm[0] + u[1] * nrm[1])
                }
                _ => NodeConstraint::fixed(exact(mesh.nodes[i])),
            })
            .collect();
        let mut sys = DivCurlSystem::<2, 4>::new(&mesh.cells, &cons);
        sys.assemble(&mesh.nodes, &cons, |x| -3.0 * (2.0 * x[0]).sin() * x[1].exp()).unwrap();
        nodal_error(&sys, &cons, &mesh.nodes, exact)
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
                [] => NodeConstraint::free(),
                [s] => {
                    let u = exact(mesh.nodes[i]);
                    NodeConstraint::normal(normals[*s], u[0] * normals[*s][0] + u[1] * normals[*s][1])
                }
                _ => NodeConstraint::fixed(exact(mesh.nodes[i])),
            })
            .collect();
        let mut sys = DivCurlSystem::<2, 4>::new(&mesh.cells, &cons);
        sys.assemble(&mesh.nodes, &cons, |_| 2.0).unwrap();
        let error = nodal_error(&sys, &cons, &mesh.nodes, exact);
        assert!(error < 1e-12, "{error:e}");
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

    /// The 3D analogue: u = ∇ψ, ψ = sin(2x) eʸ cos z, div u = −4 sin(2x) eʸ cos z,
    /// on a distorted brick; normal components on faces, u on edges.
    fn solve_3d(n: usize) -> f64 {
        use crate::mesh::HexMesh;
        let mut mesh = HexMesh::structured_box([0.0; 3], [1.0; 3], [n, n, n]);
        for p in &mut mesh.nodes {
            let s = 0.05 * (std::f64::consts::PI * p[0]).sin() * (std::f64::consts::PI * p[1]).sin() * (std::f64::consts::PI * p[2]).sin();
            *p = [p[0] + s, p[1] - s, p[2] + 0.5 * s];
        }
        let exact = |p: [f64; 3]| {
            let (s, c, e) = ((2.0 * p[0]).sin(), (2.0 * p[0]).cos(), p[1].exp());
            [2.0 * c * e * p[2].cos(), s * e * p[2].cos(), -s * e * p[2].sin()]
        };
        let normals = [[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0]];
        let mut parts = vec![Vec::new(); mesh.num_nodes()];
        for f in &mesh.faces {
            for &v in &f.nodes {
                if !parts[v].contains(&f.part) {
                    parts[v].push(f.part);
                }
            }
        }
        let cons: Vec<Constraint<3>> = (0..mesh.num_nodes())
            .map(|i| {
                let u = exact(mesh.nodes[i]);
                match parts[i].as_slice() {
                    [] => Constraint::free(),
                    [f] => {
                        let nv = normals[*f];
                        Constraint::<3>::normal(nv, u[0] * nv[0] + u[1] * nv[1] + u[2] * nv[2])
                    }
                    _ => Constraint::fixed(u),
                }
            })
            .collect();
        let mut sys = DivCurlSystem::<3, 8>::new(&mesh.cells, &cons);
        sys.assemble(&mesh.nodes, &cons, |x| -4.0 * (2.0 * x[0]).sin() * x[1].exp() * x[2].cos()).unwrap();
        nodal_error(&sys, &cons, &mesh.nodes, exact)
    }

    #[test]
    fn converges_in_3d() {
        let (e1, e2, e3) = (solve_3d(4), solve_3d(8), solve_3d(16));
        let (r1, r2) = ((e1 / e2).log2(), (e2 / e3).log2());
        assert!(r1 > 1.6 && r2 > 1.6, "errors {e1:e} {e2:e} {e3:e}, rates {r1} {r2}");
    }

    #[test]
    fn along_constraint_prescribes_the_normal_plane() {
        let tau = [0.6, 0.0, 0.8];
        let v = [1.0, 2.0, 3.0];
        let c = Constraint::<3>::along(tau, v);
        // the prescribed part equals v minus its component along tau
        let mut u = [0.0; 3];
        for k in 0..2 {
            for i in 0..3 {
                u[i] += c.values[k] * c.frame[k][i];
            }
        }
        let vt = v[0] * tau[0] + v[1] * tau[1] + v[2] * tau[2];
        for i in 0..3 {
            assert!((u[i] - (v[i] - vt * tau[i])).abs() < 1e-14);
        }
    }

    #[test]
    fn changed_kind_is_an_error() {
        let mesh = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 2, 2);
        let mut cons = vec![NodeConstraint::fixed([0.0; 2]); 9];
        cons[4] = NodeConstraint::free();
        let mut sys = DivCurlSystem::<2, 4>::new(&mesh.cells, &cons);
        cons[4] = NodeConstraint::normal([1.0, 0.0], 0.0);
        assert!(matches!(sys.assemble(&mesh.nodes, &cons, |_| 0.0), Err(LsfemError::KindChanged { node: 4 })));
    }
}
