//! Sparse symmetric positive definite solvers behind one trait.
//!
//! The deformation method solves one SPD system per pseudo-time step on a
//! mesh whose connectivity never changes, so a solver sees the pattern
//! once ([`SpdSolver::analyze`]), then each step prepares for new values
//! ([`SpdSolver::factor`]: a numeric factorisation, or a preconditioner)
//! and solves. A solver knows no mesh: it sees a symmetric [`Csr`] matrix
//! (both triangles, the one copy the assembly fills), how the unknowns
//! group into nodes, and the near-null space the multigrid coarsens.
//!
//! - [`CholeskySolver`]: faer's sparse Cholesky, exact; fill grows fast in 3D.
//! - [`ConjugateGradient`] with [`Jacobi`]: cheap per iteration, but the
//!   iteration count grows with the mesh.
//! - [`ConjugateGradient`] with [`Amg`]: smoothed-aggregation multigrid,
//!   a count nearly independent of the mesh size.

mod amg;
mod cg;
mod cholesky;
mod csr;

pub use amg::{Amg, AmgOptions};
pub use cg::{ConjugateGradient, Jacobi, Preconditioner, DEFAULT_TOLERANCE};
pub use cholesky::{CholeskySolver, LaggedCholesky};
pub use csr::{axpy, dot, Csr};


use std::time::Duration;

/// Errors of the sparse solvers.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// The pattern is malformed (row pointers, column indices, blocks).
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

/// How the unknowns group into nodes, and the vectors the operator nearly
/// annihilates: what an algebraic multigrid needs beyond the matrix.
#[derive(Clone, Copy, Debug)]
pub struct Structure<'a> {
    /// Unknowns of node k are `node_ptr[k]..node_ptr[k + 1]`: consecutive,
    /// every unknown in exactly one node.
    pub node_ptr: &'a [u32],
    /// `count` vectors of length n, one after the other.
    pub near_null: &'a [f64],
    /// How many near-null vectors.
    pub count: usize,
}

/// What the last `factor` and `solve_in_place` cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveInfo {
    /// Iterations of the last solve (0 for a direct solver).
    pub iterations: usize,
    /// Whether the last `factor` rebuilt a preconditioner hierarchy.
    pub rebuilt: bool,
    /// Time of the last `factor` spent building a hierarchy.
    pub setup: Duration,
    /// A solver that can turn to another ([`MultigridOrFactor`]) has.
    pub fell_back: bool,
}

/// A sparse SPD solver: analyse a pattern once, factor and solve many times.
pub trait SpdSolver: Send {
    /// Analyses the sparsity pattern of `a` (its values are not read).
    fn analyze(&mut self, a: &Csr) -> Result<(), SolveError>;
    /// Prepares to solve with the values now in `a` (same pattern).
    fn factor(&mut self, a: &Csr, structure: Structure<'_>) -> Result<(), SolveError>;
    /// Overwrites `rhs` with the solution of `A x = rhs` (`a` as factored).
    fn solve_in_place(&mut self, a: &Csr, rhs: &mut [f64]) -> Result<(), SolveError>;
    /// A short name for reports.
    fn name(&self) -> &'static str;
    /// Iterations and set-up of the last factor/solve.
    fn info(&self) -> SolveInfo {
        SolveInfo::default()
    }
}

/// Multigrid-preconditioned CG that turns to CG on a lagged Cholesky
/// factor for the rest of the run when the multigrid struggles: a solve
/// that does not converge, or needs more than `slow` iterations (the
/// factor is then built before the next step). What `auto` chooses for
/// large systems. Why: the multigrid takes 7–14 iterations on the
/// benchmark meshes, but on cells of aspect ratio 10⁴–10⁵ (a 1e-5
/// boundary layer of hexes at p = 3) it needed 130 to over 1,000 a solve,
/// while a factor stays exact. The factor is only tried up to
/// `factor_limit` unknowns, as its fill grows fast in 3D (about 4 GB at
/// 300k unknowns on such a layer).
pub struct MultigridOrFactor {
    multigrid: ConjugateGradient<Amg>,
    factor: Option<ConjugateGradient<LaggedCholesky>>,
    tolerance: f64,
    slow: usize,
    factor_limit: usize,
    switch: bool,
}

impl MultigridOrFactor {
    /// Multigrid CG with at most `max_iterations` a solve, relative
    /// residual `tolerance`; the factor after a solve of more than `slow`
    /// iterations or none converged, up to `factor_limit` unknowns.
    pub fn new(max_iterations: usize, tolerance: f64, slow: usize, factor_limit: usize) -> Self {
        let mut multigrid = ConjugateGradient::new(Amg::default());
        multigrid.max_iterations = max_iterations;
        multigrid.tolerance = tolerance;
        MultigridOrFactor { multigrid, factor: None, tolerance, slow, factor_limit, switch: false }
    }

    /// Builds and factors the fallback on `a`.
    fn to_factor(&mut self, a: &Csr) -> Result<(), SolveError> {
        let mut f = ConjugateGradient::new(LaggedCholesky::default());
        f.tolerance = self.tolerance;
        f.analyze(a)?;
        // the factor reads no node structure
        f.factor(a, Structure { node_ptr: &[], near_null: &[], count: 0 })?;
        self.factor = Some(f);
        Ok(())
    }
}

impl SpdSolver for MultigridOrFactor {
    fn analyze(&mut self, a: &Csr) -> Result<(), SolveError> {
        match &mut self.factor {
            Some(f) => f.analyze(a),
            None => self.multigrid.analyze(a),
        }
    }

    fn factor(&mut self, a: &Csr, structure: Structure<'_>) -> Result<(), SolveError> {
        match &mut self.factor {
            Some(f) => f.factor(a, structure),
            None if self.switch => self.to_factor(a),
            None => self.multigrid.factor(a, structure),
        }
    }

    fn solve_in_place(&mut self, a: &Csr, rhs: &mut [f64]) -> Result<(), SolveError> {
        if let Some(f) = &mut self.factor {
            return f.solve_in_place(a, rhs);
        }
        let fits = a.nrows <= self.factor_limit;
        let b = rhs.to_vec();
        match self.multigrid.solve_in_place(a, rhs) {
            Err(SolveError::NoConvergence(n)) if fits => {
                tracing::info!("multigrid CG did not converge in {n} iterations: CG on a Cholesky factor from now on");
                self.to_factor(a)?;
                rhs.copy_from_slice(&b);
                self.factor.as_mut().expect("just built").solve_in_place(a, rhs)
            }
            Ok(()) => {
                self.switch = fits && self.multigrid.info().iterations > self.slow;
                Ok(())
            }
            other => other,
        }
    }

    fn name(&self) -> &'static str {
        match self.factor {
            Some(_) => "conjugate gradients (multigrid, then the Cholesky factor of an earlier step, as multigrid was slow)",
            None => self.multigrid.name(),
        }
    }

    fn info(&self) -> SolveInfo {
        match &self.factor {
            Some(f) => SolveInfo { fell_back: true, ..f.info() },
            None => self.multigrid.info(),
        }
    }
}

/// Rejects square patterns the solvers would panic on, with a message.
fn check_pattern(a: &Csr) -> Result<(), SolveError> {
    if a.nrows != a.ncols {
        return Err(SolveError::Pattern(format!("{} rows but {} columns", a.nrows, a.ncols)));
    }
    if a.row_ptr.len() != a.nrows + 1 || a.row_ptr[0] != 0 || *a.row_ptr.last().unwrap_or(&0) != a.col.len() || a.val.len() != a.col.len() {
        return Err(SolveError::Pattern("row pointers do not match the entries".into()));
    }
    for i in 0..a.nrows {
        let (cols, _) = a.row(i);
        if cols.windows(2).any(|w| w[0] >= w[1]) || cols.iter().any(|&c| c as usize >= a.ncols) || cols.binary_search(&(i as u32)).is_err() {
            return Err(SolveError::Pattern(format!("row {i} is not sorted, out of range or has no diagonal")));
        }
    }
    Ok(())
}

/// Every unknown its own node, constants as the near-null space: the
/// structure of a scalar problem (and of tests).
pub fn scalar_structure(n: usize) -> (Vec<u32>, Vec<f64>) {
    ((0..=n as u32).collect(), vec![1.0; n])
}

#[cfg(test)]
mod tests;
