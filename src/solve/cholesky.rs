//! faer's sparse Cholesky behind [`SpdSolver`].

use super::{check_pattern, Csr, SolveError, SpdSolver, Structure};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

/// Supernodal/simplicial sparse Cholesky (faer) with an AMD ordering.
///
/// faer factors the lower triangle in compressed columns; for a symmetric
/// matrix that is the upper triangle of the rows, so `analyze` records
/// where each of those entries sits in the CSR matrix and `factor` copies
/// them. All buffers are allocated by `analyze`: `factor` and
/// `solve_in_place` allocate nothing.
pub struct CholeskySolver {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// CSR position of each lower-triangle entry.
    source: Vec<usize>,
    lower: Vec<f64>,
    symbolic: Option<SymbolicCholesky<usize>>,
    l_values: Vec<f64>,
    work: MemBuffer,
    /// Whether `l_values` and `work` are sized for `symbolic` (done by
    /// the first `factor` after `analyze`; a system of no unknowns has
    /// an empty factor but still needs its aligned scratch).
    sized: bool,
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
            n: 0,
            col_ptr: Vec::new(),
            row_idx: Vec::new(),
            source: Vec::new(),
            lower: Vec::new(),
            symbolic: None,
            l_values: Vec::new(),
            work: MemBuffer::new(StackReq::empty()),
            sized: false,
            factored: false,
            par,
        }
    }

    /// Stored entries of the factor L, from the symbolic analysis (0
    /// before `analyze`): 8 bytes each, what the factor costs in memory.
    pub fn factor_entries(&self) -> usize {
        self.symbolic.as_ref().map_or(0, |s| s.len_val())
    }

    fn lower_ref(&self) -> SymbolicSparseColMatRef<'_, usize> {
        SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx)
    }
}

impl Default for CholeskySolver {
    fn default() -> Self {
        CholeskySolver::new()
    }
}

impl SpdSolver for CholeskySolver {
    fn analyze(&mut self, a: &Csr) -> Result<(), SolveError> {
        check_pattern(a)?;
        self.n = a.nrows;
        self.col_ptr = Vec::with_capacity(a.nrows + 1);
        self.row_idx.clear();
        self.source.clear();
        self.col_ptr.push(0);
        for r in 0..a.nrows {
            for k in a.row_ptr[r]..a.row_ptr[r + 1] {
                if a.col[k] as usize >= r {
                    self.row_idx.push(a.col[k] as usize);
                    self.source.push(k);
                }
            }
            self.col_ptr.push(self.row_idx.len());
        }
        self.lower = vec![0.0; self.source.len()];
        let symbolic = factorize_symbolic_cholesky(self.lower_ref(), Side::Lower, SymmetricOrdering::Amd, CholeskySymbolicParams::default())
            .map_err(|e| SolveError::Symbolic(format!("{e:?}")))?;
        // the factor's values and scratch are allocated by the first
        // `factor`, not here: a caller may look at `factor_entries` first
        // and find that they would not fit (the 1.3M-unknown thin hex
        // layer asked for 27 GB)
        self.l_values = Vec::new();
        self.work = MemBuffer::new(StackReq::EMPTY);
        self.sized = false;
        self.symbolic = Some(symbolic);
        self.factored = false;
        Ok(())
    }

    fn factor(&mut self, a: &Csr, _structure: Structure<'_>) -> Result<(), SolveError> {
        if self.symbolic.is_none() {
            return Err(SolveError::Order("analyze"));
        }
        if a.nrows != self.n || a.val.len() < self.source.last().map_or(0, |&k| k + 1) {
            return Err(SolveError::Pattern(format!("a {}-row matrix for a {}-row analysis", a.nrows, self.n)));
        }
        for (l, &k) in self.lower.iter_mut().zip(&self.source) {
            *l = a.val[k];
        }
        self.factored = false;
        let symbolic = self.symbolic.as_ref().ok_or(SolveError::Order("analyze"))?;
        if !self.sized {
            let req = StackReq::any_of(&[
                symbolic.factorize_numeric_llt_scratch::<f64>(self.par, Default::default()),
                symbolic.solve_in_place_scratch::<f64>(1, self.par),
            ]);
            self.l_values = vec![0.0; symbolic.len_val()];
            self.work = MemBuffer::new(req);
            self.sized = true;
        }
        let pattern = SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx);
        let lower = SparseColMatRef::new(pattern, &self.lower);
        symbolic
            .factorize_numeric_llt(
                &mut self.l_values,
                lower,
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

    fn solve_in_place(&mut self, _a: &Csr, rhs: &mut [f64]) -> Result<(), SolveError> {
        let symbolic = self.symbolic.as_ref().ok_or(SolveError::Order("analyze"))?;
        if !self.factored {
            return Err(SolveError::Order("factor"));
        }
        if rhs.len() != self.n {
            return Err(SolveError::Pattern(format!("rhs has {} rows, matrix {}", rhs.len(), self.n)));
        }
        let n = rhs.len();
        let llt = LltRef::new(symbolic, &self.l_values);
        let rhs_mat = MatMut::from_column_major_slice_mut(rhs, n, 1);
        // serial: faer's parallel triangular solves were slower here (2D
        // 800², one solve: 0.45 s with two threads, 0.40 s with one)
        llt.solve_in_place_with_conj(Conj::No, rhs_mat, Par::Seq, MemStack::new(&mut self.work));
        Ok(())
    }

    fn name(&self) -> &'static str {
        "sparse Cholesky (faer, AMD)"
    }
}

/// A Cholesky factor of an earlier matrix as CG's preconditioner.
///
/// Along the deformation the matrix changes with the mesh, and when
/// curving, only near the boundary: the factor of the first step's matrix
/// stays an excellent preconditioner for several later ones, and a CG
/// iteration with it (two triangular solves and a mat-vec) costs a small
/// part of a numeric factorisation. The factor is renewed when a solve
/// needed more than [`LaggedCholesky::refactor_after`] iterations, or
/// failed.
pub struct LaggedCholesky {
    chol: CholeskySolver,
    /// Iterations above which the next set-up factors the matrix anew.
    pub refactor_after: usize,
    stale: bool,
    fresh: bool,
}

impl Default for LaggedCholesky {
    fn default() -> Self {
        LaggedCholesky { chol: CholeskySolver::new(), refactor_after: 8, stale: true, fresh: false }
    }
}

impl LaggedCholesky {
    /// Analyses `a`'s pattern now (otherwise the first set-up does) and
    /// returns the entries its factor will hold.
    pub(super) fn analyze(&mut self, a: &Csr) -> Result<usize, SolveError> {
        self.chol.analyze(a)?;
        Ok(self.chol.factor_entries())
    }

    /// Overwrites `rhs` with the solution by the factor alone: exact when
    /// the factor is of this very matrix ([`LaggedCholesky::is_fresh`]).
    pub(super) fn direct(&mut self, a: &Csr, rhs: &mut [f64]) -> Result<(), SolveError> {
        self.chol.solve_in_place(a, rhs)
    }

    /// Whether the factor is of the matrix the last set-up saw.
    pub(super) fn is_fresh(&self) -> bool {
        self.fresh
    }

    fn refactor(&mut self, a: &Csr) -> Result<(), SolveError> {
        if self.chol.n != a.nrows || self.chol.symbolic.is_none() {
            self.chol.analyze(a)?;
        }
        self.chol.factor(a, super::Structure { node_ptr: &[], near_null: &[], count: 0 })?;
        self.stale = false;
        self.fresh = true;
        Ok(())
    }
}

impl super::cg::Preconditioner for LaggedCholesky {
    fn setup(&mut self, a: &Csr, _structure: Structure<'_>) -> Result<bool, SolveError> {
        if self.stale || self.chol.n != a.nrows {
            self.refactor(a)?;
            return Ok(true);
        }
        self.fresh = false;
        Ok(false)
    }

    fn apply(&mut self, a: &Csr, r: &[f64], z: &mut [f64]) {
        z.copy_from_slice(r);
        // sized by `setup`; the only failure is a size mismatch
        self.chol.solve_in_place(a, z).expect("factor sized at set-up");
    }

    fn observe(&mut self, iterations: usize) {
        if iterations > self.refactor_after {
            self.stale = true;
        }
    }

    fn rebuild_if_stale(&mut self, a: &Csr) -> Result<bool, SolveError> {
        if self.fresh {
            return Ok(false); // factored for this very matrix
        }
        self.refactor(a)?;
        Ok(true)
    }

    fn name(&self) -> &'static str {
        "conjugate gradients (Cholesky factor of an earlier step, warm start)"
    }
}
