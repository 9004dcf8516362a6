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
mod lines;

pub use amg::{Amg, AmgOptions, LINE_RATIO};
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
    #[error("conjugate gradients did not converge in {} (relative residual {residual:.2e} reached, {tolerance:.0e} wanted)", iterations_text(*.iterations))]
    NoConvergence {
        /// The iterations done (the cap).
        iterations: usize,
        /// The relative residual reached, ‖b − A x‖ / ‖b‖.
        residual: f64,
        /// The relative residual wanted.
        tolerance: f64,
    },
    /// A solve failed every way [`Fallbacks`] knows.
    #[error("{last}; tried in turn: {}", .tried.join("; "))]
    Exhausted {
        /// The last solver's error.
        last: Box<SolveError>,
        /// Each try and how it ended, in order.
        tried: Vec<String>,
    },
}

fn iterations_text(n: usize) -> String {
    if n == 1 {
        "1 iteration".into()
    } else {
        format!("{n} iterations")
    }
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
    /// A solver that can turn to another ([`Fallbacks`]) has.
    pub fell_back: bool,
    /// The last solve failed first and was tried again on a rebuilt
    /// preconditioner ([`Preconditioner::rebuild_if_stale`]).
    pub retried: bool,
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
    /// What failed solves turned to so far ([`Fallbacks`]).
    fn fallbacks(&self) -> FallbackTally {
        FallbackTally::default()
    }
}

/// What the solves of a run turned to when one did not converge
/// ([`Fallbacks`]); in `report.json` under `solver.fallbacks`.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FallbackTally {
    /// Failed solves retried on a rebuilt preconditioner: a multigrid
    /// hierarchy built anew (with safe smoother bounds if it had just been
    /// built), or a lagged Cholesky factor of this very matrix.
    pub rebuilt: usize,
    /// Failed solves handed to a fresh Cholesky factor (CG on it); the
    /// factor then serves the rest of the run.
    pub factor: usize,
    /// Solves done by a fresh factor alone, CG on it not having converged
    /// within its cap.
    pub direct: usize,
    /// Steps retaken with half the step after a solve failed every other
    /// way (the deformation's step control; 0 here).
    pub smaller_steps: usize,
    /// What finally solved the last solve that needed a fallback.
    pub solved_by: Option<String>,
}

/// When a failed solve may turn to a Cholesky factor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FactorLimits {
    /// Most unknowns (0: never).
    pub unknowns: usize,
    /// Most bytes of the factor's values as its symbolic analysis counts
    /// them; None: [`default_factor_bytes`].
    pub bytes: Option<u64>,
}

/// Without an explicit limit, a fallback factor may hold a quarter of the
/// memory available when it is tried (`MemAvailable` of /proc/meminfo),
/// or 4 GB where that is not known. A quarter, because a numeric
/// factorisation needs scratch beyond L and the run keeps its mesh,
/// matrix and multigrid meanwhile (see docs/solvers.md for the measured
/// ratio of peak to L).
pub fn default_factor_bytes() -> u64 {
    let available = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| {
        let line = t.lines().find(|l| l.starts_with("MemAvailable:"))?;
        let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kb * 1024)
    });
    available.map_or(4 << 30, |b| b / 4)
}

/// Which solver a [`Fallbacks`] tries first: only for its name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FirstSolver {
    /// `auto`'s multigrid CG, which also turns to the factor when slow.
    AutoMultigrid,
    /// Multigrid CG chosen by name.
    Multigrid,
    /// Jacobi CG.
    Jacobi,
    /// CG on a lagged Cholesky factor from the start.
    Factor,
}

/// A solver with fallbacks for a solve that does not converge, tried in
/// this order:
///
/// 1. the first solver's own retry on a rebuilt preconditioner (inside
///    [`ConjugateGradient`]: a kept multigrid hierarchy is built anew, one
///    just built is rebuilt with safe smoother bounds; a lagged factor is
///    factored anew for this matrix);
/// 2. CG on a fresh Cholesky factor of this matrix, if the system has at
///    most [`FactorLimits::unknowns`] unknowns and the factor, by its
///    symbolic analysis, at most [`FactorLimits::bytes`]; the factor then
///    serves the rest of the run as a lagged factor;
/// 3. if CG on a fresh factor still does not converge within its cap, the
///    factor's direct solve.
///
/// Only then does the solve fail, with [`SolveError::Exhausted`] naming
/// each try; the deformation may still retake a smaller step
/// ([`crate::deform::Deformation::step`]).
///
/// As `auto`'s solver for large systems ([`FirstSolver::AutoMultigrid`])
/// it also turns to the factor after a solve of more than `slow`
/// iterations, up to `switch_limit` unknowns: the multigrid takes 7–14
/// iterations on the benchmark meshes, but on cells of aspect ratio
/// 10⁴–10⁵ (a 1e-5 boundary layer of hexes at p = 3) it needed 130 to over
/// 1,000 a solve, while a factor stays exact.
pub struct Fallbacks {
    first: Option<Box<dyn SpdSolver>>,
    factor: Option<ConjugateGradient<LaggedCholesky>>,
    kind: FirstSolver,
    tolerance: f64,
    max_iterations: Option<usize>,
    slow: Option<usize>,
    switch_limit: usize,
    limits: FactorLimits,
    switch: bool,
    switched: bool,
    tally: FallbackTally,
}

impl Fallbacks {
    /// `first` (an iterative solver of the given kind) with the fallbacks;
    /// the factor's CG stops at `tolerance` within `max_iterations` (None:
    /// its default).
    pub fn new(first: Box<dyn SpdSolver>, kind: FirstSolver, tolerance: f64, max_iterations: Option<usize>, limits: FactorLimits) -> Self {
        Fallbacks { first: Some(first), factor: None, kind, tolerance, max_iterations, slow: None, switch_limit: 0, limits, switch: false, switched: false, tally: FallbackTally::default() }
    }

    /// CG on a lagged Cholesky factor from the start, with the direct
    /// solve as its fallback.
    pub fn factor_first(tolerance: f64, max_iterations: Option<usize>, limits: FactorLimits) -> Self {
        let mut f = Fallbacks { first: None, factor: None, kind: FirstSolver::Factor, tolerance, max_iterations, slow: None, switch_limit: 0, limits, switch: false, switched: false, tally: FallbackTally::default() };
        f.factor = Some(f.new_factor());
        f
    }

    /// `auto`'s multigrid CG with at most `max_iterations` a solve, that
    /// also turns to the factor from the next step on after a solve of
    /// more than `slow` iterations, up to `switch_limit` unknowns.
    pub fn auto_multigrid(max_iterations: usize, tolerance: f64, slow: usize, switch_limit: usize, limits: FactorLimits) -> Self {
        let mut multigrid = ConjugateGradient::new(Amg::default());
        multigrid.max_iterations = max_iterations;
        multigrid.tolerance = tolerance;
        let mut f = Fallbacks::new(Box::new(multigrid), FirstSolver::AutoMultigrid, tolerance, None, limits);
        f.slow = Some(slow);
        f.switch_limit = switch_limit.min(limits.unknowns);
        f
    }

    fn new_factor(&self) -> ConjugateGradient<LaggedCholesky> {
        let mut f = ConjugateGradient::new(LaggedCholesky::default());
        f.tolerance = self.tolerance;
        if let Some(cap) = self.max_iterations {
            f.max_iterations = cap;
        }
        f
    }

    /// Builds and factors the fallback on `a` if the limits allow it:
    /// Ok(Err(why not)) if they do not or the factorisation fails.
    fn turn_to_factor(&mut self, a: &Csr) -> Result<Result<(), String>, SolveError> {
        let n = a.nrows;
        if n > self.limits.unknowns {
            return Ok(Err(if self.limits.unknowns == 0 {
                "not allowed (factor limit 0 unknowns)".to_string()
            } else {
                format!("not tried: {n} unknowns, above the limit of {}", self.limits.unknowns)
            }));
        }
        let mut f = self.new_factor();
        f.analyze(a)?;
        let entries = f.precond_mut().analyze(a)?;
        let bytes = 8 * entries as u64;
        let limit = self.limits.bytes.unwrap_or_else(default_factor_bytes);
        if bytes > limit {
            return Ok(Err(format!("not tried: by its symbolic analysis it would hold {entries} entries ({:.2} GB), above the {:.2} GB allowed", bytes as f64 / 1e9, limit as f64 / 1e9)));
        }
        // the factor reads no node structure
        match f.factor(a, Structure { node_ptr: &[], near_null: &[], count: 0 }) {
            Ok(()) => {}
            Err(SolveError::NotPositiveDefinite) => return Ok(Err("its factorisation failed: the matrix is not numerically positive definite".into())),
            Err(e) => return Err(e),
        }
        self.factor = Some(f);
        // the first solver's memory (a multigrid hierarchy) is not needed again
        self.first = None;
        self.switched = true;
        Ok(Ok(()))
    }
}

/// Errors after which another solver is worth trying: no convergence, or
/// a breakdown of CG (a preconditioner that lost definiteness).
fn worth_retrying(e: &SolveError) -> bool {
    matches!(e, SolveError::NoConvergence { .. } | SolveError::NotPositiveDefinite)
}

impl SpdSolver for Fallbacks {
    fn analyze(&mut self, a: &Csr) -> Result<(), SolveError> {
        match (&mut self.factor, &mut self.first) {
            (Some(f), _) => f.analyze(a),
            (None, Some(first)) => first.analyze(a),
            (None, None) => Err(SolveError::Order("a solver")),
        }
    }

    fn factor(&mut self, a: &Csr, structure: Structure<'_>) -> Result<(), SolveError> {
        if self.factor.is_none() && self.switch {
            self.switch = false;
            if let Err(why) = self.turn_to_factor(a)? {
                tracing::info!("the multigrid was slow, but a Cholesky factor is {why}: keeping the multigrid");
            }
        }
        match (&mut self.factor, &mut self.first) {
            (Some(f), _) => f.factor(a, structure),
            (None, Some(first)) => first.factor(a, structure),
            (None, None) => Err(SolveError::Order("a solver")),
        }
    }

    fn solve_in_place(&mut self, a: &Csr, rhs: &mut [f64]) -> Result<(), SolveError> {
        let mut tried = Vec::new();
        let mut just_built = false;
        let b = rhs.to_vec();
        if self.factor.is_none() {
            let Some(first) = self.first.as_mut() else { return Err(SolveError::Order("a solver")) };
            let e = match first.solve_in_place(a, rhs) {
                Ok(()) => {
                    let info = first.info();
                    if info.retried {
                        self.tally.rebuilt += 1;
                        self.tally.solved_by = Some("the first solver on a rebuilt preconditioner".into());
                    }
                    if let Some(slow) = self.slow {
                        self.switch = a.nrows <= self.switch_limit && info.iterations > slow;
                    }
                    return Ok(());
                }
                Err(e) if worth_retrying(&e) => e,
                Err(e) => return Err(e),
            };
            let retried = first.info().retried;
            if retried {
                self.tally.rebuilt += 1;
            }
            tried.push(format!("{}{}: {e}", first.name(), if retried { ", then again on a rebuilt preconditioner" } else { "" }));
            tracing::info!("{}: CG on a Cholesky factor of this matrix next", tried[0]);
            match self.turn_to_factor(a)? {
                Ok(()) => {
                    self.tally.factor += 1;
                    just_built = true;
                    rhs.copy_from_slice(&b);
                }
                Err(why) => {
                    tried.push(format!("a Cholesky factor: {why}"));
                    return Err(SolveError::Exhausted { last: Box::new(e), tried });
                }
            }
        }
        let f = self.factor.as_mut().expect("the factor is in use");
        match f.solve_in_place(a, rhs) {
            Ok(()) => {
                if just_built {
                    self.tally.solved_by = Some("conjugate gradients on a fresh Cholesky factor".into());
                } else if f.info().retried {
                    self.tally.rebuilt += 1;
                    self.tally.solved_by = Some("conjugate gradients on the lagged factor, factored anew".into());
                }
                Ok(())
            }
            // after a failed CG the factor is of this very matrix (CG
            // factors it anew if it was older): solve by it alone
            Err(e @ SolveError::NoConvergence { .. }) if f.precond_mut().is_fresh() => {
                if f.info().retried {
                    self.tally.rebuilt += 1;
                }
                tracing::info!("CG on a fresh Cholesky factor: {e}: solving by the factor alone");
                rhs.copy_from_slice(&b);
                f.precond_mut().direct(a, rhs)?;
                f.accept(rhs);
                self.tally.direct += 1;
                self.tally.solved_by = Some("the Cholesky factor's direct solve".into());
                Ok(())
            }
            Err(e) if worth_retrying(&e) => {
                tried.push(format!("{}: {e}", f.name()));
                Err(SolveError::Exhausted { last: Box::new(e), tried })
            }
            Err(e) => Err(e),
        }
    }

    fn name(&self) -> &'static str {
        match (&self.factor, &self.first) {
            (Some(_), _) if self.switched => match self.kind {
                FirstSolver::AutoMultigrid => "conjugate gradients (multigrid, then the Cholesky factor of an earlier step, as multigrid was slow)",
                FirstSolver::Multigrid => "conjugate gradients (multigrid, then the Cholesky factor of an earlier step, as multigrid did not converge)",
                FirstSolver::Jacobi => "conjugate gradients (Jacobi, then the Cholesky factor of an earlier step, as Jacobi did not converge)",
                FirstSolver::Factor => "conjugate gradients (Cholesky factor of an earlier step, warm start)",
            },
            (Some(f), _) => f.name(),
            (None, Some(first)) => first.name(),
            (None, None) => "none",
        }
    }

    fn info(&self) -> SolveInfo {
        match (&self.factor, &self.first) {
            (Some(f), _) => SolveInfo { fell_back: self.switched, ..f.info() },
            (None, Some(first)) => first.info(),
            (None, None) => SolveInfo::default(),
        }
    }

    fn fallbacks(&self) -> FallbackTally {
        self.tally.clone()
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
