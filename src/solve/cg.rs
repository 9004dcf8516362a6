//! Preconditioned conjugate gradients, warm-started from the previous
//! step's solution, with the preconditioner behind a trait.

use super::csr::{axpy, dot, scale};
use super::{check_pattern, Csr, SolveError, SolveInfo, SpdSolver, Structure};
use rayon::prelude::*;
use std::time::Instant;

/// An SPD approximation of A⁻¹ that CG applies every iteration.
pub trait Preconditioner: Send {
    /// Prepares for the values now in `a`; returns whether this was a full
    /// (re)build rather than a cheap refresh.
    fn setup(&mut self, a: &Csr, structure: Structure<'_>) -> Result<bool, SolveError>;
    /// z ≈ A⁻¹ r.
    fn apply(&mut self, a: &Csr, r: &[f64], z: &mut [f64]);
    /// The iterations the last solve took: a preconditioner that reuses an
    /// older set-up decides from them when to rebuild.
    fn observe(&mut self, _iterations: usize) {}
    /// After a failed solve: rebuilds now if the set-up was older than
    /// the matrix (then the solve is worth retrying); false otherwise.
    fn rebuild_if_stale(&mut self, _a: &Csr) -> Result<bool, SolveError> {
        Ok(false)
    }
    /// A short name for reports.
    fn name(&self) -> &'static str;
}

/// The diagonal of A, inverted.
#[derive(Default)]
pub struct Jacobi {
    inv_diag: Vec<f64>,
}

impl Preconditioner for Jacobi {
    fn setup(&mut self, a: &Csr, _structure: Structure<'_>) -> Result<bool, SolveError> {
        self.inv_diag.resize(a.nrows, 0.0);
        a.diagonal(&mut self.inv_diag);
        invert_diagonal(&mut self.inv_diag)?;
        Ok(true)
    }

    fn apply(&mut self, _a: &Csr, r: &[f64], z: &mut [f64]) {
        scale(&self.inv_diag, r, z);
    }

    fn name(&self) -> &'static str {
        "conjugate gradients (Jacobi, warm start)"
    }
}

/// Inverts a diagonal in place; a non-positive entry means A is not SPD.
pub(super) fn invert_diagonal(d: &mut [f64]) -> Result<(), SolveError> {
    if d.par_iter().any(|&v| !(v > 0.0)) {
        return Err(SolveError::NotPositiveDefinite);
    }
    d.par_iter_mut().for_each(|v| *v = 1.0 / *v);
    Ok(())
}

/// Preconditioned conjugate gradients, warm-started from the previous
/// solution (the velocity changes little from one step to the next).
/// Stops when the residual has fallen to `tolerance` times the
/// right-hand side.
pub struct ConjugateGradient<P: Preconditioner> {
    precond: P,
    previous: Vec<f64>,
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
    /// Relative residual to reach.
    pub tolerance: f64,
    /// Iteration cap (a solve that hits it is an error).
    pub max_iterations: usize,
    info: SolveInfo,
}

/// The relative residual CG stops at. Measured with
/// `examples/tolerance.rs` (multigrid CG, whole runs, largest node
/// distance to a run at 1e-12): 3D quarter ball 24³, 20 steps: 2.7e-10 at
/// 1e-8, 4.7e-8 at 1e-6, 2.8e-7 at 1e-5 (9.3, 6.7, 5.8 iterations);
/// 2D quarter disk 200², 40 steps: 8.2e-10, 2.1e-7, 2.7e-6 (10.4, 7.3,
/// 6.2). At 1e-7 the nodes stay within about 1e-8 of the exact solve's,
/// 10⁴ times below the Euler step's own error, for one iteration less
/// than 1e-8.
pub const DEFAULT_TOLERANCE: f64 = 1e-7;

impl<P: Preconditioner> ConjugateGradient<P> {
    /// CG with the given preconditioner.
    pub fn new(precond: P) -> Self {
        ConjugateGradient {
            precond,
            previous: Vec::new(),
            r: Vec::new(),
            z: Vec::new(),
            p: Vec::new(),
            q: Vec::new(),
            tolerance: DEFAULT_TOLERANCE,
            max_iterations: 20_000,
            info: SolveInfo::default(),
        }
    }

    /// Iterations of the last solve.
    pub fn last_iterations(&self) -> usize {
        self.info.iterations
    }

    /// The preconditioner.
    pub(super) fn precond_mut(&mut self) -> &mut P {
        &mut self.precond
    }

    /// Takes `x` as the solution of the last solve (the next one starts
    /// from it), with no iteration: for a solution found otherwise.
    pub(super) fn accept(&mut self, x: &[f64]) {
        self.previous.copy_from_slice(x);
        self.info.iterations = 0;
    }

    fn iterate(&mut self, a: &Csr, b: &[f64]) -> Result<usize, SolveError> {
        let norm_b = dot(b, b).sqrt();
        let x = &mut self.previous;
        a.residual(b, x, &mut self.r);
        let stop = self.tolerance * norm_b;
        if dot(&self.r, &self.r).sqrt() <= stop {
            return Ok(0);
        }
        self.precond.apply(a, &self.r, &mut self.z);
        self.p.copy_from_slice(&self.z);
        let mut rz = dot(&self.r, &self.z);
        for it in 1..=self.max_iterations {
            a.apply(&self.p, &mut self.q);
            let pq = dot(&self.p, &self.q);
            if !(pq > 0.0) || !(rz > 0.0) {
                return Err(SolveError::NotPositiveDefinite);
            }
            let alpha = rz / pq;
            axpy(alpha, &self.p, x);
            axpy(-alpha, &self.q, &mut self.r);
            if dot(&self.r, &self.r).sqrt() <= stop {
                return Ok(it);
            }
            self.precond.apply(a, &self.r, &mut self.z);
            let rz_new = dot(&self.r, &self.z);
            let beta = rz_new / rz;
            rz = rz_new;
            self.p.par_iter_mut().zip(&self.z).with_min_len(4096).for_each(|(p, z)| *p = z + beta * *p);
        }
        let residual = dot(&self.r, &self.r).sqrt() / norm_b;
        Err(SolveError::NoConvergence { iterations: self.max_iterations, residual, tolerance: self.tolerance })
    }
}

impl<P: Preconditioner> SpdSolver for ConjugateGradient<P> {
    fn analyze(&mut self, a: &Csr) -> Result<(), SolveError> {
        check_pattern(a)?;
        let n = a.nrows;
        for v in [&mut self.previous, &mut self.r, &mut self.z, &mut self.p, &mut self.q] {
            *v = vec![0.0; n];
        }
        Ok(())
    }

    fn factor(&mut self, a: &Csr, structure: Structure<'_>) -> Result<(), SolveError> {
        if self.previous.len() != a.nrows {
            return Err(SolveError::Order("analyze"));
        }
        let t0 = Instant::now();
        let rebuilt = self.precond.setup(a, structure)?;
        self.info.rebuilt = rebuilt;
        self.info.setup = if rebuilt { t0.elapsed() } else { Default::default() };
        Ok(())
    }

    fn solve_in_place(&mut self, a: &Csr, rhs: &mut [f64]) -> Result<(), SolveError> {
        if rhs.len() != self.previous.len() {
            return Err(SolveError::Pattern(format!("rhs has {} rows, matrix {}", rhs.len(), self.previous.len())));
        }
        if dot(rhs, rhs) == 0.0 {
            self.previous.iter_mut().for_each(|v| *v = 0.0);
            self.info.iterations = 0;
            return Ok(());
        }
        self.info.retried = false;
        let iterations = match self.iterate(a, rhs) {
            Ok(k) => k,
            Err(e) => {
                // a preconditioner built for an earlier mesh may no longer
                // fit this one: rebuild it and start again from zero
                if !self.precond.rebuild_if_stale(a)? {
                    return Err(e);
                }
                self.info.rebuilt = true;
                self.info.retried = true;
                self.previous.iter_mut().for_each(|v| *v = 0.0);
                self.iterate(a, rhs)?
            }
        };
        self.info.iterations = iterations;
        self.precond.observe(iterations);
        rhs.copy_from_slice(&self.previous);
        Ok(())
    }

    fn name(&self) -> &'static str {
        self.precond.name()
    }

    fn info(&self) -> SolveInfo {
        self.info
    }
}
