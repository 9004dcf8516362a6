//! Sparse symmetric positive definite solvers behind one trait.
//!
//! The deformation method solves one SPD system per pseudo-time step on a
//! mesh whose connectivity never changes, so a solver analyses the pattern
//! once ([`SpdSolver::analyze`]) and then only refactors numerically
//! ([`SpdSolver::factor`]) into buffers it already owns. A solver knows no
//! mesh: it sees a lower-triangular CSC pattern and values.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

/// Errors of the sparse solvers.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// The pattern is malformed (column pointers, row indices).
    #[error("invalid sparsity pattern: {0}")]
    Pattern(String),
    /// `factor` or `solve` called before `analyze`/`factor`.
    #[error("solver used before {0}")]
    Order(&'static str),
    /// The symbolic analysis failed.
    #[error("symbolic factorisation failed: {0}")]
    Symbolic(String),
    /// The matrix is not numerically positive definite.
    #[error("matrix is not positive definite (a constraint may be missing)")]
    NotPositiveDefinite,
    /// An iterative solver did not reach its tolerance.
    #[error("conjugate gradients did not converge in {0} iterations")]
    NoConvergence(usize),
}

/// The lower triangle (row ≥ column) of a symmetric sparse matrix in
/// compressed-column form, row indices sorted within each column.
#[derive(Clone, Debug, Default)]
pub struct SparsePattern {
    /// Matrix dimension.
    pub n: usize,
    /// Column pointers, `n + 1` entries.
    pub col_ptr: Vec<usize>,
    /// Row index of every stored entry.
    pub row_idx: Vec<usize>,
}

impl SparsePattern {
    /// Builds the lower-triangular pattern from a list of (row, col) pairs
    /// (either triangle; duplicates allowed).
    pub fn from_pairs(n: usize, pairs: impl IntoIterator<Item = (usize, usize)>) -> SparsePattern {
        let mut cols: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (i, j) in pairs {
            let (r, c) = if i >= j { (i, j) } else { (j, i) };
            cols[c].push(r);
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for mut col in cols {
            col.sort_unstable();
            col.dedup();
            row_idx.extend_from_slice(&col);
            col_ptr.push(row_idx.len());
        }
        SparsePattern { n, col_ptr, row_idx }
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Position of entry (row, col), row ≥ col, in the value array.
    pub fn position(&self, row: usize, col: usize) -> Option<usize> {
        let (a, b) = (self.col_ptr[col], self.col_ptr[col + 1]);
        self.row_idx[a..b].binary_search(&row).ok().map(|k| a + k)
    }

    fn faer_ref(&self) -> SymbolicSparseColMatRef<'_, usize> {
        SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx)
    }
}

/// A sparse SPD solver: analyse a pattern once, factor and solve many times.
pub trait SpdSolver: Send {
    /// Analyses the sparsity pattern (symbolic factorisation).
    fn analyze(&mut self, pattern: &SparsePattern) -> Result<(), SolveError>;
    /// Numeric factorisation of the matrix with `values` on the analysed pattern.
    fn factor(&mut self, values: &[f64]) -> Result<(), SolveError>;
    /// Overwrites `rhs` with the solution of `A x = rhs`.
    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolveError>;
    /// A short name for reports.
    fn name(&self) -> &'static str;
}

/// Supernodal/simplicial sparse Cholesky (faer) with an AMD ordering.
///
/// All buffers (factor values, workspace) are allocated by `analyze`, so
/// `factor` and `solve_in_place` allocate nothing.
pub struct CholeskySolver {
    pattern: SparsePattern,
    symbolic: Option<SymbolicCholesky<usize>>,
    l_values: Vec<f64>,
    work: MemBuffer,
    factored: bool,
    par: Par,
}

impl CholeskySolver {
    /// A solver using all of rayon's threads.
    pub fn new() -> CholeskySolver {
        CholeskySolver::with_par(Par::rayon(0))
    }

    /// A solver with an explicit parallelism setting.
    pub fn with_par(par: Par) -> CholeskySolver {
        CholeskySolver {
            pattern: SparsePattern::default(),
            symbolic: None,
            l_values: Vec::new(),
            work: MemBuffer::new(StackReq::empty()),
            factored: false,
            par,
        }
    }
}

impl Default for CholeskySolver {
    fn default() -> Self {
        CholeskySolver::new()
    }
}

impl SpdSolver for CholeskySolver {
    fn analyze(&mut self, pattern: &SparsePattern) -> Result<(), SolveError> {
        check_pattern(pattern)?;
        let symbolic = factorize_symbolic_cholesky(
            pattern.faer_ref(),
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| SolveError::Symbolic(format!("{e:?}")))?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(self.par, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, self.par),
        ]);
        self.l_values = vec![0.0; symbolic.len_val()];
        self.work = MemBuffer::new(req);
        self.symbolic = Some(symbolic);
        self.pattern = pattern.clone();
        self.factored = false;
        Ok(())
    }

    fn factor(&mut self, values: &[f64]) -> Result<(), SolveError> {
        let symbolic = self.symbolic.as_ref().ok_or(SolveError::Order("analyze"))?;
        if values.len() != self.pattern.nnz() {
            return Err(SolveError::Pattern(format!(
                "{} values for {} pattern entries",
                values.len(),
                self.pattern.nnz()
            )));
        }
        self.factored = false;
        let a = SparseColMatRef::new(self.pattern.faer_ref(), values);
        symbolic
            .factorize_numeric_llt(
                &mut self.l_values,
                a,
                Side::Lower,
                LltRegularization::default(),
                self.par,
                MemStack::new(&mut self.work),
                Default::default(),
            )
            .map_err(|_| SolveError::NotPositiveDefinite)?;
        self.factored = true;
        Ok(())
    }

    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolveError> {
        let symbolic = self.symbolic.as_ref().ok_or(SolveError::Order("analyze"))?;
        if !self.factored {
            return Err(SolveError::Order("factor"));
        }
        if rhs.len() != self.pattern.n {
            return Err(SolveError::Pattern(format!("rhs has {} rows, matrix {}", rhs.len(), self.pattern.n)));
        }
        let n = rhs.len();
        let llt = LltRef::new(symbolic, &self.l_values);
        let rhs_mat = MatMut::from_column_major_slice_mut(rhs, n, 1);
        llt.solve_in_place_with_conj(Conj::No, rhs_mat, self.par, MemStack::new(&mut self.work));
        Ok(())
    }

    fn name(&self) -> &'static str {
        "sparse Cholesky (faer, AMD)"
    }
}

/// Preconditioned conjugate gradients (Jacobi), warm-started from the
/// previous solution: memory and work per iteration grow linearly with the
/// unknowns, unlike a sparse factorisation in 3D. Iterates until the
/// residual has fallen by `tolerance` relative to the right-hand side.
pub struct ConjugateGradient {
    pattern: SparsePattern,
    values: Vec<f64>,
    inv_diag: Vec<f64>,
    previous: Vec<f64>,
    // work vectors, allocated once by `analyze`
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
    /// Relative residual to reach.
    pub tolerance: f64,
    /// Iteration cap (a solve that hits it is an error).
    pub max_iterations: usize,
    /// Iterations of the last solve.
    pub last_iterations: usize,
}

impl Default for ConjugateGradient {
    fn default() -> Self {
        ConjugateGradient {
            pattern: SparsePattern::default(),
            values: Vec::new(),
            inv_diag: Vec::new(),
            previous: Vec::new(),
            r: Vec::new(),
            z: Vec::new(),
            p: Vec::new(),
            q: Vec::new(),
            tolerance: 1e-10,
            max_iterations: 20_000,
            last_iterations: 0,
        }
    }
}

impl ConjugateGradient {
    /// y = A x for the symmetric matrix stored as its lower triangle.
    fn apply(pattern: &SparsePattern, values: &[f64], x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..pattern.n {
            let (a, b) = (pattern.col_ptr[j], pattern.col_ptr[j + 1]);
            let xj = x[j];
            let mut yj = 0.0;
            for k in a..b {
                let i = pattern.row_idx[k];
                let v = values[k];
                if i == j {
                    yj += v * xj;
                } else {
                    y[i] += v * xj;
                    yj += v * x[i];
                }
            }
            y[j] += yj;
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl SpdSolver for ConjugateGradient {
    fn analyze(&mut self, pattern: &SparsePattern) -> Result<(), SolveError> {
        check_pattern(pattern)?;
        let n = pattern.n;
        self.pattern = pattern.clone();
        self.values = vec![0.0; pattern.nnz()];
        self.inv_diag = vec![0.0; n];
        self.previous = vec![0.0; n];
        self.r = vec![0.0; n];
        self.z = vec![0.0; n];
        self.p = vec![0.0; n];
        self.q = vec![0.0; n];
        Ok(())
    }

    fn factor(&mut self, values: &[f64]) -> Result<(), SolveError> {
        if self.inv_diag.len() != self.pattern.n {
            return Err(SolveError::Order("analyze"));
        }
        if values.len() != self.pattern.nnz() {
            return Err(SolveError::Pattern(format!("{} values for {} pattern entries", values.len(), self.pattern.nnz())));
        }
        self.values.copy_from_slice(values);
        for j in 0..self.pattern.n {
            let k = self.pattern.position(j, j).ok_or(SolveError::NotPositiveDefinite)?;
            let d = values[k];
            if !(d > 0.0) {
                return Err(SolveError::NotPositiveDefinite);
            }
            self.inv_diag[j] = 1.0 / d;
        }
        Ok(())
    }

    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolveError> {
        let n = self.pattern.n;
        if rhs.len() != n {
            return Err(SolveError::Pattern(format!("rhs has {} rows, matrix {n}", rhs.len())));
        }
        let norm_b = dot(rhs, rhs).sqrt();
        let x = &mut self.previous;
        if norm_b == 0.0 {
            x.iter_mut().for_each(|v| *v = 0.0);
            rhs.iter_mut().for_each(|v| *v = 0.0);
            return Ok(());
        }
        // r = b − A x₀, from the last solution (the velocity changes slowly)
        Self::apply(&self.pattern, &self.values, x, &mut self.q);
        for i in 0..n {
            self.r[i] = rhs[i] - self.q[i];
            self.z[i] = self.inv_diag[i] * self.r[i];
        }
        self.p.copy_from_slice(&self.z);
        let mut rz = dot(&self.r, &self.z);
        let mut it = 0;
        while dot(&self.r, &self.r).sqrt() > self.tolerance * norm_b {
            if it == self.max_iterations {
                return Err(SolveError::NoConvergence(it));
            }
            Self::apply(&self.pattern, &self.values, &self.p, &mut self.q);
            let pq = dot(&self.p, &self.q);
            if !(pq > 0.0) {
                return Err(SolveError::NotPositiveDefinite);
            }
            let alpha = rz / pq;
            for i in 0..n {
                x[i] += alpha * self.p[i];
                self.r[i] -= alpha * self.q[i];
                self.z[i] = self.inv_diag[i] * self.r[i];
            }
            let rz_new = dot(&self.r, &self.z);
            let beta = rz_new / rz;
            rz = rz_new;
            for i in 0..n {
                self.p[i] = self.z[i] + beta * self.p[i];
            }
            it += 1;
        }
        self.last_iterations = it;
        rhs.copy_from_slice(x);
        Ok(())
    }

    fn name(&self) -> &'static str {
        "conjugate gradients (Jacobi, warm start)"
    }
}

/// Rejects patterns faer would panic on, with a message instead.
fn check_pattern(p: &SparsePattern) -> Result<(), SolveError> {
    if p.col_ptr.len() != p.n + 1 || p.col_ptr[0] != 0 || *p.col_ptr.last().unwrap() != p.row_idx.len() {
        return Err(SolveError::Pattern("column pointers do not match the entries".into()));
    }
    for c in 0..p.n {
        let rows = &p.row_idx[p.col_ptr[c]..p.col_ptr[c + 1]];
        if rows.windows(2).any(|w| w[0] >= w[1]) || rows.iter().any(|&r| r < c || r >= p.n) {
            return Err(SolveError::Pattern(format!("column {c} is not sorted lower-triangular")));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1-D Laplacian plus identity: SPD, tridiagonal, known solution.
    #[test]
    fn cholesky_solves_and_refactors() {
        let n = 50;
        let pattern = SparsePattern::from_pairs(n, (0..n).flat_map(|i| [(i, i), (i + 1, i)]).filter(|&(r, _)| r < n));
        let mut solver = CholeskySolver::new();
        solver.analyze(&pattern).unwrap();
        for shift in [1.0, 3.0] {
            let mut vals = vec![0.0; pattern.nnz()];
            for i in 0..n {
                vals[pattern.position(i, i).unwrap()] = 2.0 + shift;
                if i + 1 < n {
                    vals[pattern.position(i + 1, i).unwrap()] = -1.0;
                }
            }
            solver.factor(&vals).unwrap();
            let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).sin()).collect();
            // b = A x
            let mut b: Vec<f64> = (0..n)
                .map(|i| {
                    let mut s = (2.0 + shift) * x[i];
                    if i > 0 { s -= x[i - 1]; }
                    if i + 1 < n { s -= x[i + 1]; }
                    s
                })
                .collect();
            solver.solve_in_place(&mut b).unwrap();
            let err = b.iter().zip(&x).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(err < 1e-12, "error {err}");
        }
    }

    #[test]
    fn conjugate_gradients_agree_with_cholesky() {
        // a 2-D Laplacian plus a small shift on a 30×30 grid
        let m = 30;
        let n = m * m;
        let id = |i: usize, j: usize| j * m + i;
        let mut pairs = Vec::new();
        for j in 0..m {
            for i in 0..m {
                pairs.push((id(i, j), id(i, j)));
                if i + 1 < m {
                    pairs.push((id(i + 1, j), id(i, j)));
                }
                if j + 1 < m {
                    pairs.push((id(i, j + 1), id(i, j)));
                }
            }
        }
        let pattern = SparsePattern::from_pairs(n, pairs);
        let mut vals = vec![0.0; pattern.nnz()];
        for j in 0..n {
            for k in pattern.col_ptr[j]..pattern.col_ptr[j + 1] {
                vals[k] = if pattern.row_idx[k] == j { 4.01 } else { -1.0 };
            }
        }
        let b: Vec<f64> = (0..n).map(|i| ((i * 7) % 13) as f64 - 6.0).collect();
        let mut exact = b.clone();
        let mut chol = CholeskySolver::new();
        chol.analyze(&pattern).unwrap();
        chol.factor(&vals).unwrap();
        chol.solve_in_place(&mut exact).unwrap();
        let mut cg = ConjugateGradient::default();
        cg.analyze(&pattern).unwrap();
        cg.factor(&vals).unwrap();
        let mut x = b.clone();
        cg.solve_in_place(&mut x).unwrap();
        let first = cg.last_iterations;
        let err = x.iter().zip(&exact).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(err < 1e-8, "error {err}");
        // a warm start from the answer needs (almost) no iterations
        let mut again = b.clone();
        cg.solve_in_place(&mut again).unwrap();
        assert!(cg.last_iterations < first / 4, "{} vs {first}", cg.last_iterations);
    }

    #[test]
    fn indefinite_matrix_is_an_error() {
        let pattern = SparsePattern::from_pairs(2, [(0, 0), (1, 1), (1, 0)]);
        let mut s = CholeskySolver::new();
        s.analyze(&pattern).unwrap();
        assert!(matches!(s.factor(&[1.0, 2.0, -1.0]), Err(SolveError::NotPositiveDefinite)));
        assert!(matches!(CholeskySolver::new().factor(&[1.0]), Err(SolveError::Order(_))));
    }
}
