//! Smoothed-aggregation algebraic multigrid (Vaněk, Mandel, Brezina 1996)
//! as a preconditioner for conjugate gradients.
//!
//! The LSFEM unknowns are each node's velocity components in a rotated
//! frame of its own (normal/tangent on the boundary, some eliminated). The
//! operator nearly annihilates constant velocities, so the near-null space
//! the aggregation must reproduce is the D translations *expressed in each
//! node's frame*; with plain constants the iteration count grows with the
//! mesh (46–90 against 9–10 measured with pyamg on the 3D bench matrix).
//!
//! Set-up, per level: a node strength graph from the blocks of A,
//! aggregation of nodes (pyamg's "standard" three passes), a tentative
//! prolongator from a QR of the near-null space on each aggregate, one
//! damped-Jacobi smoothing of it, and the Galerkin product Pᵀ A P. The
//! coarse level's nodes are the aggregates, its near-null space the QR's R.
//! The cycle is a V(1,1) with Jacobi-scaled Chebyshev smoothing, which is
//! symmetric (so CG may use it) and made only of mat-vecs (so parallel);
//! the coarsest level is solved by sparse Cholesky.
//!
//! The hierarchy is built once and kept while the mesh moves: each step
//! refreshes only the finest level's diagonal, and the hierarchy is rebuilt
//! when the iteration count grows past what it was after the last build.

use super::cg::{invert_diagonal, Preconditioner};
use super::csr::{axpy, dot};
use super::lines::Lines;
use super::{CholeskySolver, Csr, SolveError, SpdSolver, Structure};
use rayon::prelude::*;

/// Parameters of the hierarchy and cycle.
#[derive(Clone, Debug)]
pub struct AmgOptions {
    /// Strength threshold θ: nodes I, J are coupled when
    /// ‖A_IJ‖ > θ √(‖A_II‖ ‖A_JJ‖) (Frobenius norms of the blocks).
    pub strength: f64,
    /// A level with at most this many unknowns is solved directly.
    pub coarse_size: usize,
    /// Most levels, the direct one included.
    pub max_levels: usize,
    /// Degree of the Chebyshev smoother on the coarse levels (mat-vecs
    /// per smoothing).
    pub degree: usize,
    /// Its degree on the finest level, where a mat-vec costs most: 1
    /// (damped Jacobi) measured faster per solve than 2 or 3 on the
    /// quarter ball and disk (one or two more iterations, 40 % fewer
    /// fine mat-vecs each).
    pub fine_degree: usize,
    /// Rebuild when a solve takes more than `growth` × (the iterations
    /// right after the last build) + 1.
    pub growth: f64,
    /// Line relaxation ([`Lines`]) instead of the point smoother on every
    /// level: an edge joins a line when its coupling is at least this
    /// fraction of the strongest of both its nodes. None: point smoother.
    pub lines: Option<f64>,
}

impl Default for AmgOptions {
    fn default() -> Self {
        AmgOptions { strength: 0.0, coarse_size: 1000, max_levels: 12, degree: 2, fine_degree: 1, growth: 1.3, lines: Some(LINE_RATIO) }
    }
}

/// The default [`AmgOptions::lines`].
pub const LINE_RATIO: f64 = 0.5;

/// Power iterations for λ_max(M⁻¹A) of the line smoother. Its top modes
/// sit in a few thin cells: on the 200² quarter disk (Algorithm 1, 40
/// steps, cells down to scaled Jacobian 0.009) 12 iterations left λ so low
/// that CG broke down on the cycle twice and turned to the factor; with 20
/// it ran through at 10.8 iterations per solve (at most 16).
const LINE_POWER_ITERATIONS: usize = 20;

/// Damping of the prolongator smoother, ω / λ_max(D⁻¹A) (the classical 4/3).
const OMEGA: f64 = 4.0 / 3.0;
/// Chebyshev smoothing interval: [λ/LOWER, UPPER λ] of D⁻¹A.
const UPPER: f64 = 1.1;
const LOWER: f64 = 10.0;

/// One level above the coarsest: its operator (the finest level's is the
/// caller's), smoother data, transfers to the next level, work vectors.
struct Level {
    a: Csr,
    inv_diag: Vec<f64>,
    lines: Option<Lines>,
    lambda: f64,
    p: Csr,
    r: Csr,
    b: Vec<f64>,
    x: Vec<f64>,
    res: Vec<f64>,
    d: Vec<f64>,
    t: Vec<f64>,
}

/// The smoothed-aggregation preconditioner (see the module docs).
pub struct Amg {
    /// Options used at the next build.
    pub options: AmgOptions,
    levels: Vec<Level>,
    coarse: CholeskySolver,
    coarse_a: Csr,
    coarse_rhs: Vec<f64>,
    node_ptr: Vec<u32>,
    near_null: Vec<f64>,
    count: usize,
    baseline: Option<usize>,
    stale: bool,
    // smoothers sized by Gershgorin's bound instead of the power estimate
    safe_bounds: bool,
}

impl Amg {
    /// A preconditioner with the given options.
    pub fn new(options: AmgOptions) -> Amg {
        Amg {
            options,
            levels: Vec::new(),
            coarse: CholeskySolver::new(),
            coarse_a: Csr::default(),
            coarse_rhs: Vec::new(),
            node_ptr: Vec::new(),
            near_null: Vec::new(),
            count: 0,
            baseline: None,
            stale: true,
            safe_bounds: false,
        }
    }

    /// Unknowns per level, finest first (empty before the first build).
    pub fn level_sizes(&self) -> Vec<usize> {
        let mut s: Vec<usize> = self.levels.iter().map(|l| l.p.nrows).collect();
        if !self.levels.is_empty() || self.coarse_a.nrows > 0 {
            s.push(self.coarse_a.nrows);
        }
        s
    }

    /// Operator complexity: stored entries of all levels over the finest's.
    pub fn operator_complexity(&self, a: &Csr) -> f64 {
        let coarse: usize = self.levels.iter().skip(1).map(|l| l.a.nnz()).sum::<usize>() + self.coarse_a.nnz();
        1.0 + coarse as f64 / a.nnz().max(1) as f64
    }

    fn build(&mut self, a0: &Csr) -> Result<(), SolveError> {
        self.levels.clear();
        let mut node_ptr = self.node_ptr.clone();
        let mut near_null = self.near_null.clone();
        let mut a_owned: Option<Csr> = None;
        loop {
            let a = a_owned.as_ref().unwrap_or(a0);
            let n = a.nrows;
            let last = self.levels.len() + 1 >= self.options.max_levels;
            if n <= self.options.coarse_size || last {
                break;
            }
            let mut inv_diag = vec![0.0; n];
            a.diagonal(&mut inv_diag);
            invert_diagonal(&mut inv_diag)?;
            let blocks = block_norms(a, &node_ptr);
            // a rebuild after a failure on a fresh hierarchy goes back to
            // the point smoother, whose Gershgorin bound is safe
            let mut lines = match self.options.lines {
                Some(ratio) if !self.safe_bounds => Some(Lines::new(a, &node_ptr, &blocks, ratio)?).filter(|l| l.count() > 0),
                _ => None,
            };
            let lambda = match &mut lines {
                Some(l) => {
                    let mut t = vec![0.0; n];
                    line_spectral_radius(a, l, &inv_diag, &mut t, LINE_POWER_ITERATIONS) 
                }
                None if self.safe_bounds => gershgorin_bound(a, &inv_diag),
                None => spectral_radius(a, &inv_diag),
            };
            if let Some(l) = &lines {
                tracing::debug!("multigrid level {}: {n} unknowns, {} lines over {} of them (longest {} nodes), λ {lambda:.3}", self.levels.len(), l.count(), l.covered(), l.longest);
            }
            let (aggregate, count) = aggregate_nodes(&strength_graph(&blocks, self.options.strength), node_ptr.len() - 1);
            drop(blocks);
            let (t, coarse_ptr, coarse_null) = tentative(&node_ptr, &aggregate, count, &near_null, self.count, n);
            if t.ncols == 0 || t.ncols as f64 > 0.8 * n as f64 {
                break; // aggregation no longer coarsens: solve here
            }
            let p = smooth_prolongator(a, &t, &inv_diag, OMEGA / lambda);
            drop(t);
            let r = p.transpose();
            let coarse = galerkin(a, &p);
            let level_a = a_owned.take().unwrap_or_default();
            self.levels.push(Level {
                a: level_a,
                inv_diag,
                lines,
                lambda,
                b: vec![0.0; n],
                x: vec![0.0; n],
                res: vec![0.0; n],
                d: vec![0.0; n],
                t: vec![0.0; n],
                p,
                r,
            });
            a_owned = Some(coarse);
            node_ptr = coarse_ptr;
            near_null = coarse_null;
        }
        self.coarse_a = match a_owned {
            Some(c) => c,
            None => a0.clone(), // the whole problem is small: solve it directly
        };
        self.coarse_rhs = vec![0.0; self.coarse_a.nrows];
        self.coarse = CholeskySolver::with_par(faer::Par::Seq);
        self.coarse.analyze(&self.coarse_a)?;
        self.factor_coarse()?;
        self.baseline = None;
        self.stale = false;
        Ok(())
    }

    /// One V-cycle for A z = r from z = 0.
    fn cycle(&mut self, a0: &Csr, r0: &[f64], z0: &mut [f64]) {
        let (degree, fine_degree) = (self.options.degree, self.options.fine_degree);
        let depth = self.levels.len();
        if depth == 0 {
            self.coarse_rhs.copy_from_slice(r0);
            self.solve_coarse();
            z0.copy_from_slice(&self.coarse_rhs);
            return;
        }
        for l in 0..depth {
            let (head, tail) = self.levels.split_at_mut(l + 1);
            let Level { a, inv_diag, lines, lambda, r, b, x, res, d, t, .. } = &mut head[l];
            let (a, b, x): (&Csr, &[f64], &mut [f64]) = if l == 0 { (a0, r0, &mut *z0) } else { (&*a, &*b, &mut x[..]) };
            let deg = if l == 0 { fine_degree } else { degree };
            chebyshev(a, inv_diag, lines.as_mut(), *lambda, deg, b, x, true, res, d, t);
            a.residual(b, x, res);
            let next = if l + 1 < depth { &mut tail[0].b } else { &mut self.coarse_rhs };
            r.apply(res, next);
        }
        self.solve_coarse();
        for l in (0..depth).rev() {
            let (head, tail) = self.levels.split_at_mut(l + 1);
            let Level { a, inv_diag, lines, lambda, p, b, x, res, d, t, .. } = &mut head[l];
            let (a, b, x): (&Csr, &[f64], &mut [f64]) = if l == 0 { (a0, r0, &mut *z0) } else { (&*a, &*b, &mut x[..]) };
            let coarse_x = if l + 1 < depth { &tail[0].x } else { &self.coarse_rhs };
            p.apply(coarse_x, t);
            axpy(1.0, t, x);
            let deg = if l == 0 { fine_degree } else { degree };
            chebyshev(a, inv_diag, lines.as_mut(), *lambda, deg, b, x, false, res, d, t);
        }
    }

    /// Factors the coarsest operator (scalar structure: it is small).
    fn factor_coarse(&mut self) -> Result<(), SolveError> {
        let (ptr, null) = super::scalar_structure(0);
        self.coarse.factor(&self.coarse_a, Structure { node_ptr: &ptr, near_null: &null, count: 0 })
    }

    fn solve_coarse(&mut self) {
        // factored at build time; the only failure is a size mismatch
        self.coarse.solve_in_place(&self.coarse_a, &mut self.coarse_rhs).expect("coarse system sized at build");
    }
}

impl Default for Amg {
    fn default() -> Self {
        Amg::new(AmgOptions::default())
    }
}

impl Preconditioner for Amg {
    fn setup(&mut self, a: &Csr, s: Structure<'_>) -> Result<bool, SolveError> {
        check_structure(a, s)?;
        self.node_ptr.clear();
        self.node_ptr.extend_from_slice(s.node_ptr);
        self.near_null.clear();
        self.near_null.extend_from_slice(s.near_null);
        self.count = s.count;
        if self.stale || self.levels.first().is_some_and(|l| l.inv_diag.len() != a.nrows) {
            self.build(a)?;
            return Ok(true);
        }
        // keep the hierarchy; the finest smoother follows the new diagonal
        if let Some(fine) = self.levels.first_mut() {
            a.diagonal(&mut fine.inv_diag);
            invert_diagonal(&mut fine.inv_diag)?;
            if let Some(lines) = &mut fine.lines {
                lines.factor(a)?;
            }
        } else {
            self.coarse_a.val.copy_from_slice(&a.val);
            self.factor_coarse()?;
        }
        Ok(false)
    }

    fn apply(&mut self, a: &Csr, r: &[f64], z: &mut [f64]) {
        self.cycle(a, r, z);
    }

    fn observe(&mut self, iterations: usize) {
        match self.baseline {
            None => self.baseline = Some(iterations),
            Some(b) if iterations as f64 > self.options.growth * b as f64 + 1.0 => self.stale = true,
            Some(_) => {}
        }
    }

    fn rebuild_if_stale(&mut self, a: &Csr) -> Result<bool, SolveError> {
        if self.baseline.is_none() {
            // built for this very matrix: if its smoothers were sized by the
            // power estimate, that may have been too low; size them safely
            if self.safe_bounds {
                return Ok(false);
            }
            self.safe_bounds = true;
        }
        self.build(a)?;
        Ok(true)
    }

    fn name(&self) -> &'static str {
        "conjugate gradients (smoothed-aggregation AMG, warm start)"
    }
}

fn check_structure(a: &Csr, s: Structure<'_>) -> Result<(), SolveError> {
    let ok_ptr = s.node_ptr.first() == Some(&0)
        && s.node_ptr.last().map(|&e| e as usize) == Some(a.nrows)
        && s.node_ptr.windows(2).all(|w| w[0] < w[1]);
    if !ok_ptr {
        return Err(SolveError::Pattern("node blocks do not partition the unknowns".into()));
    }
    if s.near_null.len() != s.count * a.nrows || s.count == 0 {
        return Err(SolveError::Pattern(format!("{} near-null values for {} vectors of {}", s.near_null.len(), s.count, a.nrows)));
    }
    Ok(())
}

/// λ_max(D⁻¹A) by the Rayleigh quotient of 12 power iterations, from a
/// fixed start (deterministic). The smoothers stay convergent up to
/// 1.2 × this estimate. It can be too low where the top mode sits in a few
/// distorted cells (measured on the p = 3 ball with 7.5k hexes: 200
/// iterations find 1.16 × it; with 49k hexes CG broke down): then the
/// hierarchy is rebuilt with [`gershgorin_bound`].

fn spectral_radius(a: &Csr, inv_diag: &[f64]) -> f64 {
    let n = a.nrows;
    let mut x: Vec<f64> = (0..n).map(|i| 1.0 + ((i * 7919) % 101) as f64 / 101.0).collect();
    let mut y = vec![0.0; n];
    let mut lambda = 0.0;
    for _ in 0..12 {
        // Rayleigh quotient of the pencil (A, D): xᵀAx / xᵀDx
        y.par_iter_mut().zip(x.par_iter().zip(inv_diag)).for_each(|(y, (v, d))| *y = v / d);
        let xdx = dot(&x, &y);
        a.apply(&x, &mut y);
        lambda = dot(&x, &y) / xdx;
        y.par_iter_mut().zip(inv_diag).for_each(|(v, d)| *v *= d);
        let norm = dot(&y, &y).sqrt();
        x.par_iter_mut().zip(&y).for_each(|(v, w)| *v = w / norm);
    }
    lambda
}

/// λ_max(M⁻¹A) for the line smoother M, by the A-Rayleigh quotient of
/// `iterations` power iterations from a fixed start: (Ax)ᵀM⁻¹(Ax) / xᵀAx.
fn line_spectral_radius(a: &Csr, lines: &mut Lines, inv_diag: &[f64], t: &mut [f64], iterations: usize) -> f64 {
    let n = a.nrows;
    let mut x: Vec<f64> = (0..n).map(|i| 1.0 + ((i * 7919) % 101) as f64 / 101.0).collect();
    let mut y = vec![0.0; n];
    let mut lambda = 0.0;
    for _ in 0..iterations {
        a.apply(&x, &mut y);
        lines.apply(&y, inv_diag, t);
        lambda = dot(&y, t) / dot(&x, &y);
        let norm = dot(t, t).sqrt();
        x.par_iter_mut().zip(t.par_iter()).for_each(|(v, w)| *v = w / norm);
    }
    lambda
}

/// An upper bound of λ_max(D⁻¹A): the largest row sum of |a_ij| / a_ii
/// (Gershgorin). Safe, and on distorted meshes about 1.6 × the power
/// estimate (7.5k-hex ball: 4.38 against 2.77; CG took 26 iterations
/// instead of 18).
fn gershgorin_bound(a: &Csr, inv_diag: &[f64]) -> f64 {
    (0..a.nrows).into_par_iter().map(|i| a.row(i).1.iter().map(|x| x.abs()).sum::<f64>() * inv_diag[i]).reduce(|| 0.0, f64::max)
}

/// Strong neighbours of every node (CSR over nodes, self excluded).
fn strength_graph(blocks: &Csr, theta: f64) -> (Vec<usize>, Vec<u32>) {
    let nodes = blocks.nrows;
    let diag: Vec<f64> = (0..nodes).map(|k| blocks.position(k, k).map_or(0.0, |at| blocks.val[at].sqrt())).collect();
    let mut ptr = Vec::with_capacity(nodes + 1);
    let mut adj = Vec::new();
    ptr.push(0);
    for k in 0..nodes {
        let (cols, vals) = blocks.row(k);
        for (&j, &s) in cols.iter().zip(vals) {
            if j as usize != k && s.sqrt() > theta * (diag[k] * diag[j as usize]).sqrt() {
                adj.push(j);
            }
        }
        ptr.push(adj.len());
    }
    (ptr, adj)
}

/// The squared Frobenius norms of the node blocks of A, as a matrix over
/// nodes. (A list per node of every entry of its rows, summed after
/// sorting, took 1.3 kB per unknown: the peak of the set-up.)
fn block_norms(a: &Csr, node_ptr: &[u32]) -> Csr {
    let nodes = node_ptr.len() - 1;
    let mut dof_node = vec![0u32; a.nrows];
    for k in 0..nodes {
        dof_node[node_ptr[k] as usize..node_ptr[k + 1] as usize].fill(k as u32);
    }
    Csr::accumulate_rows(nodes, nodes, |k, acc| {
        for i in node_ptr[k] as usize..node_ptr[k + 1] as usize {
            let (c, v) = a.row(i);
            for (&j, &x) in c.iter().zip(v) {
                acc.add(dof_node[j as usize], x * x);
            }
        }
    })
}

const NONE: u32 = u32::MAX;

/// pyamg's standard aggregation: (1) a node whose strong neighbours are all
/// free starts an aggregate with them; (2) a left-over node joins an
/// aggregate of a neighbour; (3) what remains groups with its free
/// neighbours. Returns each node's aggregate and the count.
fn aggregate_nodes(graph: &(Vec<usize>, Vec<u32>), nodes: usize) -> (Vec<u32>, usize) {
    let (ptr, adj) = graph;
    let neighbours = |k: usize| &adj[ptr[k]..ptr[k + 1]];
    let mut agg = vec![NONE; nodes];
    let mut count = 0u32;
    for k in 0..nodes {
        if agg[k] == NONE && neighbours(k).iter().all(|&j| agg[j as usize] == NONE) {
            agg[k] = count;
            for &j in neighbours(k) {
                agg[j as usize] = count;
            }
            count += 1;
        }
    }
    let first_pass = agg.clone();
    for k in 0..nodes {
        if agg[k] == NONE {
            if let Some(&j) = neighbours(k).iter().find(|&&j| first_pass[j as usize] != NONE) {
                agg[k] = first_pass[j as usize];
            }
        }
    }
    for k in 0..nodes {
        if agg[k] == NONE {
            agg[k] = count;
            for &j in neighbours(k) {
                if agg[j as usize] == NONE {
                    agg[j as usize] = count;
                }
            }
            count += 1;
        }
    }
    (agg, count as usize)
}

/// The tentative prolongator: on each aggregate, an orthonormal basis Q of
/// the near-null vectors restricted to it (modified Gram–Schmidt, columns
/// that are dependent there dropped). Returns T, the coarse node pointer
/// (one node per aggregate, one unknown per kept column) and the coarse
/// near-null space R (B = Q R on every aggregate, so T B_c = B).
fn tentative(node_ptr: &[u32], agg: &[u32], count: usize, null: &[f64], k: usize, n: usize) -> (Csr, Vec<u32>, Vec<f64>) {
    let nodes = node_ptr.len() - 1;
    // the nodes of each aggregate, in node order
    let mut members_ptr = vec![0usize; count + 1];
    for &g in agg {
        members_ptr[g as usize + 1] += 1;
    }
    for g in 0..count {
        members_ptr[g + 1] += members_ptr[g];
    }
    let mut fill = members_ptr.clone();
    let mut members = vec![0u32; nodes];
    for (node, &g) in agg.iter().enumerate() {
        members[fill[g as usize]] = node as u32;
        fill[g as usize] += 1;
    }
    // QR per aggregate, in parallel: (Q row-major over the aggregate's dofs, R k'×k)
    let qr: Vec<(Vec<f64>, Vec<f64>, usize)> = (0..count)
        .into_par_iter()
        .map(|g| {
            let dofs: Vec<usize> = members[members_ptr[g]..members_ptr[g + 1]]
                .iter()
                .flat_map(|&v| node_ptr[v as usize] as usize..node_ptr[v as usize + 1] as usize)
                .collect();
            let m = dofs.len();
            let mut q: Vec<Vec<f64>> = Vec::with_capacity(k);
            let mut r = vec![0.0; k * k];
            for c in 0..k {
                let mut v: Vec<f64> = dofs.iter().map(|&i| null[c * n + i]).collect();
                let norm0 = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                for (row, qq) in q.iter().enumerate() {
                    let s: f64 = qq.iter().zip(&v).map(|(a, b)| a * b).sum();
                    v.iter_mut().zip(qq).for_each(|(x, y)| *x -= s * y);
                    r[row * k + c] = s;
                }
                let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                if norm > 1e-10 * norm0 && norm > 0.0 {
                    r[q.len() * k + c] = norm;
                    v.iter_mut().for_each(|x| *x /= norm);
                    q.push(v);
                }
            }
            let kept = q.len();
            let mut rows = vec![0.0; m * kept];
            for (c, qq) in q.iter().enumerate() {
                for (i, &x) in qq.iter().enumerate() {
                    rows[i * kept + c] = x;
                }
            }
            r.truncate(kept * k);
            (rows, r, kept)
        })
        .collect();
    let mut coarse_ptr = vec![0u32; count + 1];
    for g in 0..count {
        coarse_ptr[g + 1] = coarse_ptr[g] + qr[g].2 as u32;
    }
    let nc = coarse_ptr[count] as usize;
    let mut coarse_null = vec![0.0; k * nc];
    for g in 0..count {
        let (_, r, kept) = &qr[g];
        for row in 0..*kept {
            for c in 0..k {
                coarse_null[c * nc + coarse_ptr[g] as usize + row] = r[row * k + c];
            }
        }
    }
    // T, row by row: dof i of aggregate g at local row `local`
    let mut local_of = vec![0u32; n];
    for g in 0..count {
        let mut local = 0u32;
        for &v in &members[members_ptr[g]..members_ptr[g + 1]] {
            for i in node_ptr[v as usize]..node_ptr[v as usize + 1] {
                local_of[i as usize] = local;
                local += 1;
            }
        }
    }
    let mut t = Csr { nrows: n, ncols: nc, row_ptr: Vec::with_capacity(n + 1), col: Vec::new(), val: Vec::new() };
    t.row_ptr.push(0);
    for v in 0..nodes {
        let g = agg[v] as usize;
        let (rows, _, kept) = &qr[g];
        for i in node_ptr[v] as usize..node_ptr[v + 1] as usize {
            let l = local_of[i] as usize;
            for c in 0..*kept {
                t.col.push(coarse_ptr[g] + c as u32);
                t.val.push(rows[l * kept + c]);
            }
            t.row_ptr.push(t.col.len());
        }
    }
    (t, coarse_ptr, coarse_null)
}

/// Fine rows per block of the Galerkin product: A P is 2.5 times the size
/// of P and was the largest transient of the set-up; in blocks it is never
/// whole.
const GALERKIN_BLOCK_ROWS: usize = 1 << 18;

/// The coarse operator Pᵀ A P, as Σ over blocks b of fine rows of
/// P[b]ᵀ (A[b] P).
fn galerkin(a: &Csr, p: &Csr) -> Csr {
    let mut coarse: Option<Csr> = None;
    for start in (0..a.nrows).step_by(GALERKIN_BLOCK_ROWS) {
        let rows = start..(start + GALERKIN_BLOCK_ROWS).min(a.nrows);
        let ap = a.matmul_rows(rows.clone(), p);
        let part = p.row_block(rows).transpose().matmul(&ap);
        coarse = Some(match coarse {
            Some(c) => c.add(&part),
            None => part,
        });
    }
    coarse.unwrap_or_else(|| Csr { nrows: p.ncols, ncols: p.ncols, row_ptr: vec![0; p.ncols + 1], ..Csr::default() })
}

/// P = (I − s D⁻¹A) T. T's entries lie in the pattern of A T (A has its
/// diagonal), so they are added in place.
fn smooth_prolongator(a: &Csr, t: &Csr, inv_diag: &[f64], s: f64) -> Csr {
    let mut p = a.matmul(t);
    let Csr { row_ptr, col, val, .. } = &mut p;
    let rows: Vec<(&mut [f64], &[u32])> = {
        let mut out = Vec::with_capacity(row_ptr.len() - 1);
        let mut rest_v: &mut [f64] = val;
        let mut rest_c: &[u32] = col;
        for w in row_ptr.windows(2) {
            let len = w[1] - w[0];
            let (v, rv) = std::mem::take(&mut rest_v).split_at_mut(len);
            let (c, rc) = rest_c.split_at(len);
            out.push((v, c));
            rest_v = rv;
            rest_c = rc;
        }
        out
    };
    rows.into_par_iter().enumerate().with_min_len(1024).for_each(|(i, (v, c))| {
        let f = -s * inv_diag[i];
        v.iter_mut().for_each(|x| *x *= f);
        let (tc, tv) = t.row(i);
        for (&j, &x) in tc.iter().zip(tv) {
            let k = c.binary_search(&j).expect("T's pattern lies in A T's");
            v[k] += x;
        }
    });
    p
}

/// `degree` steps of Chebyshev iteration for A x = b, preconditioned by
/// the diagonal, on the interval [λ/LOWER, UPPER λ] of D⁻¹A (Saad,
/// Iterative Methods, Alg. 12.1). `zero`: x is zero on entry.
#[allow(clippy::too_many_arguments)]
fn chebyshev(a: &Csr, inv_diag: &[f64], mut lines: Option<&mut Lines>, lambda: f64, degree: usize, b: &[f64], x: &mut [f64], zero: bool, r: &mut [f64], d: &mut [f64], t: &mut [f64]) {
    let (hi, lo) = (UPPER * lambda, lambda / LOWER);
    let theta = 0.5 * (hi + lo);
    let delta = 0.5 * (hi - lo);
    let sigma = theta / delta;
    let mut rho = 1.0 / sigma;
    if zero {
        r.copy_from_slice(b);
    } else {
        a.residual(b, x, r);
    }
    match lines.as_deref_mut() {
        Some(l) => {
            l.apply(r, inv_diag, t);
            d.par_iter_mut().zip(t.par_iter()).for_each(|(d, t)| *d = t / theta);
        }
        None => d.par_iter_mut().zip(r.par_iter().zip(inv_diag)).for_each(|(d, (r, w))| *d = w * r / theta),
    }
    if zero {
        x.copy_from_slice(d);
    } else {
        axpy(1.0, d, x);
    }
    for _ in 1..degree {
        a.apply(d, t);
        axpy(-1.0, t, r);
        let rho_new = 1.0 / (2.0 * sigma - rho);
        let (c1, c2) = (rho_new * rho, 2.0 * rho_new / delta);
        match lines.as_deref_mut() {
            Some(l) => {
                l.apply(r, inv_diag, t);
                d.par_iter_mut().zip(t.par_iter()).for_each(|(d, t)| *d = c1 * *d + c2 * t);
            }
            None => d.par_iter_mut().zip(r.par_iter().zip(inv_diag)).for_each(|(d, (r, w))| *d = c1 * *d + c2 * w * r),
        }
        axpy(1.0, d, x);
        rho = rho_new;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::scalar_structure;

    /// The 5-point Laplacian on an m×m grid: D⁻¹A has λ_max = 1 + cos(π/(m+1)).
    fn laplacian(m: usize) -> Csr {
        let id = |i: usize, j: usize| j * m + i;
        let pairs = (0..m * m).flat_map(|k| {
            let (i, j) = (k % m, k / m);
            [(i + 1 < m).then(|| (id(i + 1, j), k)), (j + 1 < m).then(|| (id(i, j + 1), k))].into_iter().flatten()
        });
        let mut a = Csr::symmetric_from_pairs(m * m, pairs);
        for i in 0..m * m {
            for k in a.row_ptr[i]..a.row_ptr[i + 1] {
                a.val[k] = if a.col[k] as usize == i { 4.0 } else { -1.0 };
            }
        }
        a
    }

    /// Up to this multiple of the estimate the smoothers converge.
    const UPPER_MARGIN: f64 = 1.2;

    #[test]
    fn power_estimate_is_below_and_gershgorin_above_the_top_eigenvalue() {
        let m = 60;
        let a = laplacian(m);
        let inv_diag = vec![0.25; m * m];
        let exact = 1.0 + (std::f64::consts::PI / (m + 1) as f64).cos();
        let power = spectral_radius(&a, &inv_diag);
        let bound = gershgorin_bound(&a, &inv_diag);
        // 12 iterations from a smooth start reach 0.88 of it here: within
        // the smoothers' margin of 1.2, but not by much
        assert!(power <= exact + 1e-12 && power * UPPER_MARGIN > exact, "power {power}, exact {exact}");
        assert!(bound >= exact && (bound - 2.0).abs() < 1e-15, "bound {bound}");
    }

    #[test]
    fn a_fresh_hierarchy_that_failed_is_rebuilt_once_with_safe_smoothers() {
        let m = 60;
        let a = laplacian(m);
        let (ptr, null) = scalar_structure(m * m);
        let s = Structure { node_ptr: &ptr, near_null: &null, count: 1 };
        let mut amg = Amg::default();
        assert!(amg.setup(&a, s).unwrap());
        let lambda = amg.levels[0].lambda;
        assert!(amg.rebuild_if_stale(&a).unwrap(), "a failure on a fresh power-sized hierarchy rebuilds");
        assert_eq!(amg.levels[0].lambda, 2.0, "now sized by Gershgorin (was {lambda})");
        assert!(!amg.rebuild_if_stale(&a).unwrap(), "and then there is nothing left to try");
    }
}
