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
