//! Algorithm 1: deformation on a moving domain.
//!
//! Every pseudo-time step solves `div u = −∂_t(1/f)`, `curl u = 0` by
//! LSFEM on the current mesh and moves every node with `dφ/dt = f u`.
//! Boundary parts decide the constraints (docs/METHOD.md §3):
//! - `slip`: `u·n = 0`, the node glides along its wall and is put back
//!   onto it after the step;
//! - `move` to a target shape: the boundary Γ_t is the blend
//!   `Γ_t(s) = (1−t) P₀(s) + t X(P₀(s))` of the starting chain P₀ and its
//!   image X on the target (radial or closest-point correspondence).
//!   `sliding` imposes only `u·n = v·n/f` and puts the node back onto
//!   Γ_{t+dt}; `dirichlet` imposes `u = v/f`;
//! - `fixed`: `u = 0`.
//!
//! Where parts meet (the corners of a box in 2D, its corners in 3D) a node
//! has as many constraints as dimensions and follows a prescribed path; on
//! a 3D edge between two faces it glides along the edge's curve.
//!
//! The stepping is written once for both dimensions; what differs — the
//! mesh and its boundary model — comes through [`Q1Mesh`] and
//! [`BoundaryModel`]: `chains` (2D) and `patches` (3D).

mod chains;
mod cut;
mod patches;
pub mod strain;

/// A target or wall shape in D dimensions (see [`crate::geometry::ClosestPoint`]).
pub use crate::geometry::ClosestPoint as BoundaryShape;
use crate::jacobian::{lift, normalise, normalise_with, JacobianError, JacobianField, Normalisation};
use crate::lsfem::{Constraint, DivCurlSystem, LsfemError};
use crate::solve::{Amg, CholeskySolver, ConjugateGradient, FactorLimits, FallbackTally, Fallbacks, FirstSolver, Jacobi, SolveError, SpdSolver};
use std::sync::Arc;
use std::time::{Duration, Instant};

pub use chains::Chains;
pub use cut::{Cut, CutPlane, CutSolid, Cuttable};
pub use patches::Patches;

/// How a point of the starting boundary finds its place on the target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Correspondence<const D: usize = 2> {
    /// Along the ray from a centre through the point.
    Radial {
        /// The centre of the rays.
        centre: [f64; D],
    },
    /// The closest point of the target.
    Normal,
    /// Along a fixed direction: the nearer hit of the line through the
    /// point (a wall of the box parallel to it stays in its plane).
    Along {
        /// The direction.
        direction: [f64; D],
    },
}

/// How a moving boundary imposes its motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MoveMode {
    /// Only `u·n` is imposed; nodes glide and are put back onto Γ_t.
    #[default]
    Sliding,
    /// `u = v/f`: every node follows its prescribed path (the paper).
    Dirichlet,
}

/// What a boundary part does.
#[derive(Clone, Debug)]
pub enum PartKind<const D: usize = 2> {
    /// A wall the nodes glide along: the given shape, or (None) the
    /// starting boundary itself.
    Slip {
        /// The wall, if not the starting boundary.
        wall: Option<Arc<dyn BoundaryShape<D>>>,
    },
    /// The part moves onto `target`.
    Move {
        /// The target shape.
        target: Arc<dyn BoundaryShape<D>>,
        /// Point correspondence.
        correspondence: Correspondence<D>,
        /// Sliding or Dirichlet.
        mode: MoveMode,
    },
    /// Nodes do not move.
    Fixed,
}

/// A named boundary part; boundary edges (faces) refer to parts by index.
#[derive(Clone, Debug)]
pub struct BoundaryPart<const D: usize = 2> {
    /// The name (a physical group in the output).
    pub name: String,
    /// Its behaviour.
    pub kind: PartKind<D>,
    /// Where it meets other parts along curves of their own (a CAD
    /// model's edges, where two of its faces meet): `(other part, the
    /// curves they share)`. Algorithm 2 puts the new nodes of a coarse
    /// edge between the two on the curve nearest the edge, where a node
    /// following one part's shape would leave the other's.
    pub meets: Vec<(usize, Vec<Arc<dyn BoundaryShape<D>>>)>,
}

impl<const D: usize> BoundaryPart<D> {
    /// A part meeting no other along a curve of its own.
    pub fn new(name: impl Into<String>, kind: PartKind<D>) -> Self {
        BoundaryPart { name: name.into(), kind, meets: Vec::new() }
    }
}

/// Where moving parts `a` and `b` meet, a node follows `a`'s image: that
/// is right only if the image lies on `b`'s target too. Refuses the case
/// otherwise (bringing the node onto the intersection of both shapes is
/// not supported), naming both groups. `x` is a starting point there and
/// `h` the local edge length the distance is measured against.
pub(crate) fn check_meeting<const D: usize>(parts: &[BoundaryPart<D>], a: usize, b: usize, x: [f64; D], h: f64) -> Result<(), DeformError> {
    let PartKind::Move { target, .. } = &parts[b].kind else { return Ok(()) };
    // no image: the reachability checks report it
    let Some(y) = parts[a].image(x) else { return Ok(()) };
    let d = target.distance(y);
    // a shared shape (or one that agrees here) gives rounding only
    if d <= 1e-9 * h {
        return Ok(());
    }
    let fmt = |p: [f64; D]| p.iter().map(|c| format!("{c:.6}")).collect::<Vec<_>>().join(", ");
    Err(DeformError::Unreachable {
        part: parts[a].name.clone(),
        why: format!(
            "it meets curved group `{}` along an edge (or at a corner) at ({}), which would follow `{}`'s shape to ({}), {d:.3e} off `{}`'s shape; a node on two different shapes (their intersection) is not supported yet: bind both groups to one shape, or one of them as `fixed` or `slip`",
            parts[b].name,
            fmt(x),
            parts[a].name,
            fmt(y),
            parts[b].name
        ),
    })
}

impl<const D: usize> BoundaryPart<D> {
    /// Whether its target answers from one thread at a time (CAD:
    /// [`crate::geometry::ClosestPoint::serial`]).
    pub(crate) fn serial(&self) -> bool {
        matches!(&self.kind, PartKind::Move { target, .. } if target.serial())
    }

    /// The image X(p) on the target of a starting point p of a moving part.
    pub(crate) fn image(&self, p: [f64; D]) -> Option<[f64; D]> {
        match &self.kind {
            PartKind::Move { target, correspondence, .. } => match correspondence {
                Correspondence::Radial { centre } => target.ray_hit(*centre, std::array::from_fn(|i| p[i] - centre[i])),
                Correspondence::Normal => Some(target.closest_point(p)),
                Correspondence::Along { direction } => {
                    let back = direction.map(|c| -c);
                    let hits = [target.ray_hit(p, *direction), target.ray_hit(p, back)];
                    let dist = |x: &[f64; D]| (0..D).map(|i| (x[i] - p[i]).powi(2)).sum::<f64>();
                    // a point already on the target is its own image
                    if target.distance(p) < 1e-14 {
                        return Some(p);
                    }
                    let hit = hits.into_iter().flatten().min_by(|a, b| dist(a).total_cmp(&dist(b)))?;
                    // coordinates across which the line does not move stay
                    // exact: a node on an axis-aligned wall stays on it
                    Some(std::array::from_fn(|i| if direction[i] == 0.0 { p[i] } else { hit[i] }))
                }
            },
            _ => None,
        }
    }

    /// [`Self::image`] of each of `ps`, in order: the closest points asked
    /// together (a CAD shape answers them in one batch).
    pub(crate) fn images(&self, ps: &[[f64; D]]) -> Vec<Option<[f64; D]>> {
        match &self.kind {
            PartKind::Move { target, correspondence: Correspondence::Normal, .. } => target.closest_points(ps).into_iter().map(Some).collect(),
            _ => ps.iter().map(|&p| self.image(p)).collect(),
        }
    }

    /// The velocity of [`Self::image`] at each of `ps` as the point moves
    /// with velocity `dirs[i]`, where the target knows it
    /// ([`crate::geometry::ClosestPoint::foot_speeds`]: CAD, the normal
    /// correspondence); else None.
    pub(crate) fn image_speeds(&self, ps: &[[f64; D]], dirs: &[[f64; D]]) -> Vec<Option<[f64; D]>> {
        match &self.kind {
            PartKind::Move { target, correspondence: Correspondence::Normal, .. } => target.foot_speeds(ps, dirs),
            _ => vec![None; ps.len()],
        }
    }
}

/// A Q1 mesh as Algorithm 1 needs it: topology, positions, the boundary
/// flux quadrature, validity, and its boundary model.
pub trait Q1Mesh<const D: usize, const N: usize>: Clone + Send + Sync {
    /// The boundary model of this kind of mesh.
    type Boundary: BoundaryModel<D>;
    /// Cells.
    fn cells(&self) -> &[[usize; N]];
    /// Node positions.
    fn nodes(&self) -> &[[f64; D]];
    /// Node positions, to move.
    fn nodes_mut(&mut self) -> &mut Vec<[f64; D]>;
    /// Quadrature of the boundary flux at positions `nodes` for nodal
    /// boundary velocities `v`: pairs (x, v·n dS).
    fn flux_points<'a>(&'a self, nodes: &'a [[f64; D]], v: &'a [[f64; D]]) -> impl Iterator<Item = ([f64; D], f64)> + 'a;
    /// Cells whose Jacobian is not certified positive everywhere at
    /// positions `nodes`.
    fn invalid_cells(&self, nodes: &[[f64; D]]) -> Vec<usize> {
        crate::quality::certify::invalid_cells(self.cells(), nodes)
    }
    /// Area or volume at the current positions.
    fn measure(&self) -> f64;
    /// Splits the boundary into the model's pieces and checks that every
    /// moving part can reach its target.
    fn boundary(&self, parts: Vec<BoundaryPart<D>>) -> Result<Self::Boundary, DeformError>;
}

/// How boundary nodes are constrained and put back onto their shapes.
pub trait BoundaryModel<const D: usize>: Send + Sync {
    /// Per-node state that a rejected step must restore.
    type State: Clone + Send + Sync;
    /// The parts.
    fn parts(&self) -> &[BoundaryPart<D>];
    /// The nodal velocity v of the moving boundary (zero elsewhere).
    fn velocities(&self, out: &mut [[f64; D]]);
    /// Every node's constraint at time t, prescribed values divided by f
    /// (`f(i)` at node i).
    fn fill_constraints(&self, t: f64, nodes: &[[f64; D]], f: impl Fn(usize) -> f64, out: &mut [Constraint<D>]);
    /// Puts boundary nodes exactly back onto Γ_t, their walls or paths.
    fn put_back(&mut self, nodes: &mut [[f64; D]], t: f64);
    /// For each node of a moving part, its distance to the target.
    fn distances(&self, nodes: &[[f64; D]]) -> Vec<(usize, f64)>;
    /// The per-node state.
    fn state(&self) -> &Self::State;
    /// Replaces the per-node state.
    fn state_mut(&mut self) -> &mut Self::State;
    /// Whether node `i` stays where it starts for the whole run. The
    /// cells whose every node stays are left out of the checks made at
    /// every step (a patch repair's run holds all but a few per cent of
    /// the mesh). Default: no node is known to stay.
    fn held(&self, _i: usize) -> bool {
        false
    }
}

/// Explicit time integrators for `dφ/dt = f u`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Integrator {
    /// Forward Euler (the paper).
    #[default]
    Euler,
    /// Heun's method (explicit trapezoid, second order).
    Heun,
}

/// Errors of the deformation.
#[derive(Debug, thiserror::Error)]
pub enum DeformError {
    /// The correspondence cannot reach the target from some boundary point.
    #[error("boundary part `{part}`: {why}")]
    Unreachable {
        /// The part.
        part: String,
        /// Why.
        why: String,
    },
    /// The prescribed Jacobian failed.
    #[error(transparent)]
    Jacobian(#[from] JacobianError),
    /// The linear solver failed, every fallback included (the solver,
    /// not the input).
    #[error("{0}")]
    Solve(SolverFailure),
    /// The assembly failed for a reason other than an inverted cell.
    #[error(transparent)]
    Lsfem(#[from] LsfemError),
    /// The mesh would tangle even with much smaller steps.
    #[error("the mesh tangles at t = {t:.4} even with step {dt:.3e}: {} inverted cell(s), first {:?}", cells.len(), &cells[..cells.len().min(10)])]
    Tangled {
        /// The pseudo-time reached.
        t: f64,
        /// The smallest step tried.
        dt: f64,
        /// The cells that invert.
        cells: Vec<usize>,
    },
    /// g(·, 0) is not 1: the method starts from the undeformed mesh.
    #[error("the prescribed Jacobian must be 1 everywhere at t = 0 (the mesh starts undeformed), but g = {g} at ({:.4}, {:.4}, {:.4}) at t = 0; write f so that it is 1 at t = 0, or give only its final value (without t) and let `path` blend it in", x[0], x[1], x[2])]
    NotOneAtStart {
        /// Where.
        x: [f64; 3],
        /// The value found.
        g: f64,
    },
    /// The steps no longer advance t, or the run spent its budget of
    /// steps ([`DeformOptions::max_steps`]): it is ended, not left to run.
    #[error("the run stalled at t = {t:.4} after {steps} steps: {why}")]
    Stalled {
        /// The pseudo-time reached.
        t: f64,
        /// Accepted steps.
        steps: usize,
        /// Which rule ended it.
        why: String,
    },
    /// The starting mesh is invalid.
    #[error("the starting mesh has {} inverted cell(s), first {:?}", .0.len(), &.0[..(.0.len().min(10))])]
    InvalidStart(Vec<usize>),
}

/// A linear solve that failed every way tried: the last error and, in
/// order, each try and how it ended.
#[derive(Debug)]
pub struct SolverFailure {
    /// The last solver error (the iterations and residual reached, for CG).
    pub error: SolveError,
    /// What was tried, in order, and how each ended.
    pub tried: Vec<String>,
}

impl std::fmt::Display for SolverFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "the linear solver failed (the solver, not the input): {}", self.error)?;
        if !self.tried.is_empty() {
            write!(f, "; tried in turn: {}", self.tried.join("; "))?;
        }
        Ok(())
    }
}

impl std::error::Error for SolverFailure {}

impl From<SolveError> for SolverFailure {
    fn from(e: SolveError) -> Self {
        match e {
            SolveError::Exhausted { last, tried } => SolverFailure { error: *last, tried },
            error => SolverFailure { error, tried: Vec::new() },
        }
    }
}

impl From<SolveError> for DeformError {
    fn from(e: SolveError) -> Self {
        DeformError::Solve(e.into())
    }
}

/// Timings and counters of a run.
#[derive(Clone, Debug, Default)]
pub struct RunStats {
    /// Accepted steps.
    pub steps: usize,
    /// Steps retried with half the step size.
    pub halved: usize,
    /// LSFEM solves (one per Euler step, two per Heun step, plus retries).
    pub solves: usize,
    /// Time in assembly (including normalisation).
    pub assembly: Duration,
    /// Time in numeric factorisation.
    pub factor: Duration,
    /// Time in the triangular solves.
    pub solve: Duration,
    /// Time in the symbolic analysis (once).
    pub analyze: Duration,
    /// Iterations of all solves (0 for a direct solver).
    pub iterations: usize,
    /// Iterations of the last solve.
    pub last_iterations: usize,
    /// Most iterations of one solve.
    pub max_iterations: usize,
    /// Preconditioner hierarchies built (multigrid).
    pub setups: usize,
    /// Time building them (part of `factor`).
    pub setup: Duration,
    /// Steps retaken with half the step because a solve failed every
    /// other way ([`Deformation::step`]).
    pub solver_retakes: usize,
}

/// What the linear solves of a run cost, for `report.json`.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SolverReport {
    /// The solver.
    pub solver: String,
    /// Free unknowns of the system.
    pub unknowns: usize,
    /// Solves.
    pub solves: usize,
    /// Mean CG iterations per solve (0 for Cholesky).
    pub iterations_mean: f64,
    /// Most CG iterations of one solve.
    pub iterations_max: usize,
    /// Preconditioner set-ups: multigrid hierarchies built, or Cholesky
    /// factorisations of the lagged factor (once, then again when the
    /// iterations grew).
    pub hierarchy_builds: usize,
    /// Seconds building them.
    pub setup_s: f64,
    /// Seconds in factorisation or preconditioner refresh, set-up included.
    pub factor_s: f64,
    /// Seconds in the solves.
    pub solve_s: f64,
    /// What solves that did not converge turned to (all 0 when none failed).
    pub fallbacks: FallbackTally,
}

/// Which sparse solver Algorithm 1 uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SolverChoice {
    /// CG on an earlier step's Cholesky factor ([`SolverChoice::CholeskyCg`])
    /// up to [`AUTO_AMG_UNKNOWNS`] unknowns (in its dimension),
    /// multigrid-preconditioned CG above, turning to the factor if the
    /// multigrid does not converge ([`AUTO_FACTOR_LIMIT`]).
    #[default]
    Auto,
    /// Sparse Cholesky (faer): exact, but its fill grows fast in 3D.
    Cholesky,
    /// Jacobi-preconditioned conjugate gradients, warm-started.
    Cg,
    /// Conjugate gradients preconditioned by smoothed-aggregation
    /// multigrid, warm-started: iterations nearly independent of the size.
    Amg,
    /// Conjugate gradients preconditioned by the Cholesky factor of an
    /// earlier step, factored anew when the iterations grow: the exact
    /// solver's robustness (thin layers) at a fraction of its cost per
    /// step when the mesh moves little between steps.
    CholeskyCg,
}

/// Above these many unknowns `auto` chooses multigrid-preconditioned CG
/// over CG on a lagged Cholesky factor, in 2D and in 3D. Measured with
/// `deformesh bench` (see the README): in 3D the multigrid step is 6×
/// faster than Cholesky at 13k unknowns and 60× at 101k; in 2D it is
/// faster from 20k on (3.6× at 80k), but 2D is where boundary-layer meshes
/// are curved, and on cells of aspect ratio 10⁴–10⁵ the multigrid needs
/// 10–100× its usual iterations, while a factor stays exact: the factor
/// keeps the 2D range it handles in a second or two (reused across steps
/// it is cheaper still: 2.8 iterations per step on the cylinder
/// boundary layer at p = 3, one factorisation in ten steps).
pub const AUTO_AMG_UNKNOWNS: [usize; 2] = [200_000, 20_000];

/// Up to these many unknowns `auto`'s multigrid CG turns to CG on a
/// Cholesky factor when it is slow ([`crate::solve::Fallbacks`]); a solve that fails turns
/// to the factor up to [`DeformOptions::factor_limit`] unknowns if it
/// fits.
pub const AUTO_FACTOR_LIMIT: usize = 400_000;

/// `curve`'s `auto`, when it picks the multigrid, solves Algorithm 2 to
/// [`THIN_TOLERANCE`] when a coarse cell is thinner than this: the longest
/// over the shortest distance between two of its corners (the extruded
/// cylinder layers: 6.2e4 at 1e-5, 6.2e2 at 1e-3; the sphere's 1e-4 layer
/// 3.9e3; the ball octant 8.3 keeps the usual tolerance).
pub const THIN_ASPECT: f64 = 100.0;

/// The relative residual Algorithm 2's multigrid CG solves to on cells
/// thinner than [`THIN_ASPECT`] (`highorder::curve`): there the usual
/// tolerance's error changes the step control's path.
pub const THIN_TOLERANCE: f64 = 1e-10;

/// A multigrid solve of more iterations than this makes `auto` turn to
/// the factor ([`crate::solve::Fallbacks`]) from the next step
/// on, and one not converged in twice as many from this solve on: 7–14
/// is usual, 130 to over 1,000 on a 1e-5 hex layer at p = 3.
pub const AUTO_SLOW_MULTIGRID: usize = 100;

impl SolverChoice {
    /// The choice made for a `dim`-D system of `unknowns` when factors
    /// of up to `factor_limit` unknowns are allowed
    /// ([`DeformOptions::factor_limit`]): `Auto` stays `Auto` (the
    /// multigrid, with its fallbacks) when large, or when no factor of this
    /// size is allowed.
    pub fn resolved(self, dim: usize, unknowns: usize, factor_limit: usize) -> SolverChoice {
        match self {
            SolverChoice::Auto if unknowns > AUTO_AMG_UNKNOWNS[usize::from(dim == 3)] || unknowns > factor_limit => SolverChoice::Auto,
            SolverChoice::Auto => SolverChoice::CholeskyCg,
            chosen => chosen,
        }
    }

    /// The solver this choice makes for a `dim`-D system of `unknowns`
    /// with `options`' tolerance, iteration cap and factor limits. Every
    /// iterative choice comes with the fallbacks of [`Fallbacks`]; plain
    /// Cholesky has none (it is exact, and fails only on a matrix that is
    /// not positive definite).
    pub fn make(self, dim: usize, unknowns: usize, options: &DeformOptions) -> Box<dyn SpdSolver> {
        let tolerance = options.tolerance;
        let cap = options.max_iterations;
        let limits = FactorLimits { unknowns: options.factor_limit, bytes: options.factor_bytes };
        match self.resolved(dim, unknowns, options.factor_limit) {
            SolverChoice::Cholesky => Box::new(CholeskySolver::new()),
            SolverChoice::Cg => Box::new(Fallbacks::new(capped(Jacobi::default(), tolerance, cap.unwrap_or(20_000)), FirstSolver::Jacobi, tolerance, cap, limits)),
            SolverChoice::CholeskyCg => Box::new(Fallbacks::factor_first(tolerance, cap, limits)),
            SolverChoice::Amg => Box::new(Fallbacks::new(capped(Amg::default(), tolerance, cap.unwrap_or(1000)), FirstSolver::Multigrid, tolerance, cap, limits)),
            SolverChoice::Auto => Box::new(Fallbacks::auto_multigrid(cap.unwrap_or(2 * AUTO_SLOW_MULTIGRID), tolerance, AUTO_SLOW_MULTIGRID, AUTO_FACTOR_LIMIT, limits)),
        }
    }
}

/// Options of Algorithm 1.
#[derive(Clone, Debug)]
pub struct DeformOptions {
    /// Number of nominal steps from t = 0 to 1.
    pub steps: usize,
    /// The integrator.
    pub integrator: Integrator,
    /// Weight of the div term in the functional.
    pub div_weight: f64,
    /// Give up when the step has been halved this often in a row.
    pub max_halvings: usize,
    /// The sparse solver.
    pub solver: SolverChoice,
    /// Relative residual at which an iterative solver stops.
    pub tolerance: f64,
    /// Step control: a step is cut so that no cell corner's Jacobian
    /// changes by more than this fraction in it ([`strain::max_step`]);
    /// the nominal step 1/`steps` stays the largest. None: fixed steps
    /// (halved only on inversion).
    pub max_strain: Option<f64>,
    /// Most iterations of one CG solve, for every iterative solver (the
    /// first one and CG on a fallback factor). None: each solver's own
    /// (20,000 for Jacobi and lagged-factor CG, 1,000 for `amg`, 200 for
    /// `auto`'s multigrid). A test's knob: with 1 nearly every solve fails.
    pub max_iterations: Option<usize>,
    /// Most unknowns of a system for which a Cholesky factor is built when
    /// a solve fails (0: never; `auto` then never picks a factor either).
    /// Default [`FALLBACK_FACTOR_LIMIT`]; the factor's size from its
    /// symbolic analysis must also stay within `factor_bytes`.
    pub factor_limit: usize,
    /// Most bytes of a fallback factor's values; None:
    /// [`crate::solve::default_factor_bytes`] (a quarter of the memory
    /// available).
    pub factor_bytes: Option<u64>,
    /// Most accepted steps of one run; None: no budget but the stall
    /// rule ([`STALL_WINDOW`]).
    pub max_steps: Option<usize>,
}

/// Every run ends: a run whose last `STALL_WINDOW` accepted steps together
/// advanced t by less than [`STALL_ADVANCE`] ends with
/// [`DeformError::Stalled`]. Why: the step control may accept ever smaller
/// steps where the strain it limits grows without bound (measured on the
/// tet ball in a box at p = 2: t stuck at 0.2102 for hundreds of steps,
/// each reassembling, over 900 s).
pub const STALL_WINDOW: usize = 20;

/// See [`STALL_WINDOW`]: a nominal run takes at most 1/40 of t a step, so
/// 20 steps advancing it by less than 1e-3 in all are 500 times shorter.
pub const STALL_ADVANCE: f64 = 1e-3;

/// With a budget of steps ([`DeformOptions::max_steps`]), a run is also
/// ended at the end of every window of this many accepted steps whose
/// pace, kept for the rest of the budget, would not reach t = 1. Why: a
/// run the step control slows to a crawl takes far longer to meet
/// [`STALL_WINDOW`]'s rule than to show it cannot finish (measured on the
/// 1e-5 extruded layer's patch at p = 2: t = 0.405 after 16 steps, then
/// 44 more steps and 90 s to reach 0.420).
pub const PACE_WINDOW: usize = 10;

/// Up to these many unknowns a solve that failed may turn to a Cholesky
/// factor ([`DeformOptions::factor_limit`]), if its symbolic analysis
/// says it fits ([`DeformOptions::factor_bytes`]). The bound only keeps
/// the symbolic analysis itself (AMD and the column counts, a few seconds
/// and some 100 MB at this size) from being tried where no factor could
/// fit: in 3D the factor of the 101k-unknown quarter ball peaked at 2.2 GB
/// and about 4 GB at 300k unknowns on the thin cylinder layer, growing
/// faster than linearly.
pub const FALLBACK_FACTOR_LIMIT: usize = 2_000_000;

/// CG with `precond`, stopping at `tolerance` within `max_iterations`.
fn capped<P: crate::solve::Preconditioner + 'static>(precond: P, tolerance: f64, max_iterations: usize) -> Box<dyn SpdSolver> {
    let mut cg = ConjugateGradient::new(precond);
    cg.tolerance = tolerance;
    cg.max_iterations = max_iterations;
    Box::new(cg)
}

impl Default for DeformOptions {
    fn default() -> Self {
        DeformOptions {
            steps: 40,
            integrator: Integrator::Euler,
            div_weight: 1.0,
            max_halvings: 12,
            solver: SolverChoice::Auto,
            tolerance: crate::solve::DEFAULT_TOLERANCE,
            max_strain: None,
            max_iterations: None,
            factor_limit: FALLBACK_FACTOR_LIMIT,
            factor_bytes: None,
            max_steps: None,
        }
    }
}

/// The state of Algorithm 1 on one mesh: a [`crate::mesh::QuadMesh`]
/// (D = 2, N = 4) or a [`crate::mesh::HexMesh`] (D = 3, N = 8).
pub struct Deformation<M: Q1Mesh<D, N> = crate::mesh::QuadMesh, const D: usize = 2, const N: usize = 4> {
    /// The mesh at the current pseudo-time.
    pub mesh: M,
    /// Node positions at t = 0.
    pub start: Vec<[f64; D]>,
    /// The current pseudo-time.
    pub t: f64,
    /// Counters and timings.
    pub stats: RunStats,
    boundary: M::Boundary,
    initial_state: <M::Boundary as BoundaryModel<D>>::State,
    field: JacobianField,
    options: DeformOptions,
    volume0: f64,
    system: DivCurlSystem<D, N>,
    solver: Box<dyn SpdSolver>,
    // buffers reused every step
    constraints: Vec<Constraint<D>>,
    bvel: Vec<[f64; D]>,
    u: Vec<[f64; D]>,
    k1: Vec<[f64; D]>,
    // k1 is the velocity at the current nodes and t: a retried step
    // (same nodes, same t) reuses it instead of solving again
    k1_current: bool,
    // with the step control: the largest change of a corner's Jacobian
    // in the step just tried, and the step to try next (∞ at first)
    strain: f64,
    next_step: f64,
    stage: Vec<[f64; D]>,
    next: Vec<[f64; D]>,
    x: Vec<f64>,
    f_nodes: Vec<f64>,
    saved_state: <M::Boundary as BoundaryModel<D>>::State,
    // the last accepted step's start (nodes, boundary state, velocity, t)
    // and size, kept by rotating buffers: a solve that fails at the end of
    // that step retakes it smaller from there
    back: Back<<M::Boundary as BoundaryModel<D>>::State, D>,
    /// The step count and t at the start of the stall rule's window.
    mark: (usize, f64),
    /// The step count and t at the start of the pace rule's window
    /// ([`PACE_WINDOW`]).
    pace_mark: (usize, f64),
    /// The cells some node of which may move, where others never do.
    moving: Option<Moving<N>>,
}

/// The cells of a run some node of which may move ([`BoundaryModel::held`]):
/// the per-step checks (validity, the step control's strain) look at
/// these only. The others keep their start, which was checked valid, and
/// a change of their Jacobians of exactly 1.
struct Moving<const N: usize> {
    /// Their indices in the mesh, ascending.
    ids: Vec<usize>,
    /// Their nodes.
    cells: Vec<[usize; N]>,
    /// [`normalise_with`]'s sums over the other cells, where g does not
    /// change (a uniform field): the normalisation then sums over the
    /// moving cells only.
    still: Option<(f64, f64)>,
}

/// The cells of `cells` at `nodes` with a node not `held`, None if that
/// is all.
fn moving_cells<const D: usize, const N: usize>(cells: &[[usize; N]], nodes: &[[f64; D]], field: &JacobianField, held: impl Fn(usize) -> bool) -> Result<Option<Moving<N>>, DeformError> {
    let moves = |cell: &[usize; N]| !cell.iter().all(|&v| held(v));
    // (every run asks: where every cell moves, as in the paper's cases,
    // nothing is kept)
    if cells.iter().all(moves) {
        return Ok(None);
    }
    let (moving, still): (Vec<usize>, Vec<usize>) = (0..cells.len()).partition(|&c| moves(&cells[c]));
    let picked = |ids: &[usize]| ids.iter().map(|&c| cells[c]).collect::<Vec<_>>();
    let still = if field.is_uniform() { Some(crate::jacobian::cell_sums(&picked(&still), nodes, field, 0.0, (0.0, 0.0))?) } else { None };
    Ok(Some(Moving { cells: picked(&moving), ids: moving, still }))
}

/// Where the last accepted step started, and what solver failures have
/// cut ([`Deformation::step`]).
struct Back<S, const D: usize> {
    nodes: Vec<[f64; D]>,
    state: S,
    k1: Vec<[f64; D]>,
    t: f64,
    h: f64,
    /// Whether the fields above hold a step that may be retaken.
    valid: bool,
    /// The largest step while a solver failure is being stepped around.
    cap: f64,
    /// The pseudo-time of the first solve that failed (the cap holds
    /// until the run has passed it).
    failed_at: f64,
    /// Steps retaken since the run last passed `failed_at`.
    retakes: usize,
    /// After a step retaken smaller was taken: the solver's fallbacks
    /// then; if none was needed since, a smaller step is what solved the
    /// last failure.
    solved: Option<usize>,
}

/// Algorithm 1 on a hexahedral mesh.
pub type Deformation3 = Deformation<crate::mesh::HexMesh, 3, 8>;

impl<M: Q1Mesh<D, N>, const D: usize, const N: usize> Deformation<M, D, N> {
    /// Prepares Algorithm 1: classifies nodes, checks that every moving
    /// part can reach its target, builds the pattern and analyses it.
    pub fn new(mesh: M, parts: Vec<BoundaryPart<D>>, field: JacobianField, options: DeformOptions) -> Result<Self, DeformError> {
        // D unknowns per node bound the system size from above
        let solver = options.solver.make(D, D * mesh.nodes().len(), &options);
        Self::with_solver(mesh, parts, field, options, solver)
    }

    /// As [`Deformation::new`] with a given solver.
    pub fn with_solver(
        mesh: M,
        parts: Vec<BoundaryPart<D>>,
        field: JacobianField,
        options: DeformOptions,
        mut solver: Box<dyn SpdSolver>,
    ) -> Result<Self, DeformError> {
        let bad = mesh.invalid_cells(mesh.nodes());
        if !bad.is_empty() {
            return Err(DeformError::InvalidStart(bad));
        }
        // f = c g with c normalising ∫ 1/f: only g(·, 0) = 1 makes φ₀ the
        // identity, which every step builds on
        for p in mesh.nodes() {
            let x = lift(*p);
            let g = field.g_and_dt(x, 0.0).0;
            if !((g - 1.0).abs() <= 1e-9) {
                return Err(DeformError::NotOneAtStart { x, g });
            }
        }
        let boundary = mesh.boundary(parts)?;
        // constraint kinds are fixed for the run: build the pattern once
        let n = mesh.nodes().len();
        let mut constraints = vec![Constraint::free(); n];
        boundary.fill_constraints(0.0, mesh.nodes(), |_| 1.0, &mut constraints);
        let mut system = DivCurlSystem::new(mesh.cells(), &constraints);
        system.div_weight = options.div_weight;
        let moving = moving_cells(mesh.cells(), mesh.nodes(), &field, |v| boundary.held(v))?;
        let t0 = Instant::now();
        solver.analyze(system.matrix())?;
        let stats = RunStats { analyze: t0.elapsed(), ..Default::default() };
        Ok(Deformation {
            start: mesh.nodes().to_vec(),
            volume0: mesh.measure(),
            t: 0.0,
            stats,
            x: vec![0.0; system.num_unknowns()],
            f_nodes: vec![1.0; n],
            system,
            constraints,
            bvel: vec![[0.0; D]; n],
            u: vec![[0.0; D]; n],
            k1: vec![[0.0; D]; n],
            k1_current: false,
            strain: 0.0,
            next_step: f64::INFINITY,
            stage: mesh.nodes().to_vec(),
            next: mesh.nodes().to_vec(),
            saved_state: boundary.state().clone(),
            initial_state: boundary.state().clone(),
            back: Back { nodes: mesh.nodes().to_vec(), state: boundary.state().clone(), k1: vec![[0.0; D]; n], t: 0.0, h: 0.0, valid: false, cap: f64::INFINITY, failed_at: 0.0, retakes: 0, solved: None },
            mark: (0, 0.0),
            pace_mark: (0, 0.0),
            moving,
            mesh,
            boundary,
            field,
            options,
            solver,
        })
    }

    /// Back to t = 0 (nodes, boundary parameters), keeping the analysed
    /// pattern and the statistics: for repeated measurements.
    pub fn reset(&mut self) {
        self.mesh.nodes_mut().clone_from(&self.start);
        self.boundary.state_mut().clone_from(&self.initial_state);
        self.t = 0.0;
        self.k1_current = false;
        self.next_step = f64::INFINITY;
        self.back.valid = false;
        self.back.cap = f64::INFINITY;
        self.back.retakes = 0;
        self.mark = (self.stats.steps, 0.0);
        self.pace_mark = self.mark;
    }

    /// The boundary parts.
    pub fn parts(&self) -> &[BoundaryPart<D>] {
        self.boundary.parts()
    }

    /// The prescribed Jacobian.
    pub fn field(&self) -> &JacobianField {
        &self.field
    }

    /// Normalisation at the current state (t, current nodes).
    pub fn normalisation_now(&self) -> Result<Normalisation, DeformError> {
        let mut bvel = vec![[0.0; D]; self.start.len()];
        self.boundary.velocities(&mut bvel);
        let flux = self.mesh.flux_points(self.mesh.nodes(), &bvel);
        Ok(normalise(self.mesh.cells(), self.mesh.nodes(), &self.field, self.t, self.volume0, flux)?)
    }

    /// J/f per cell at the current state (see [`crate::quality::jf_ratios`]).
    pub fn jf_now(&self) -> Result<Vec<f64>, DeformError> {
        let norm = self.normalisation_now()?;
        Ok(crate::quality::jf_ratios(self.mesh.cells(), self.mesh.nodes(), &self.start, &self.field, &norm))
    }

    /// Number of unknowns of the reduced LSFEM system.
    pub fn num_unknowns(&self) -> usize {
        self.system.num_unknowns()
    }

    /// The solver in use.
    pub fn solver_name(&self) -> &'static str {
        self.solver.name()
    }

    /// Whether `auto`'s multigrid turned to a Cholesky factor
    /// ([`crate::solve::Fallbacks`]): a later run on this mesh
    /// should start with the factor.
    pub fn solver_fell_back(&self) -> bool {
        self.solver.info().fell_back
    }

    /// What the solves have cost so far.
    pub fn solver_report(&self) -> SolverReport {
        let s = &self.stats;
        SolverReport {
            solver: self.solver.name().to_string(),
            unknowns: self.num_unknowns(),
            solves: s.solves,
            iterations_mean: s.iterations as f64 / s.solves.max(1) as f64,
            iterations_max: s.max_iterations,
            hierarchy_builds: s.setups,
            setup_s: s.setup.as_secs_f64(),
            factor_s: s.factor.as_secs_f64(),
            solve_s: s.solve.as_secs_f64(),
            fallbacks: {
                let mut f = self.solver.fallbacks();
                f.smaller_steps = s.solver_retakes;
                if self.back.solved == Some(fallback_count(&f)) {
                    f.solved_by = Some("a smaller step".into());
                }
                f
            },
        }
    }

    /// Runs from the current t to 1 with the nominal step 1/steps, landing
    /// exactly on each of `stops` (sorted pseudo-times); `on_stop` is
    /// called there, `on_step` after every accepted step.
    pub fn run(
        &mut self,
        stops: &[f64],
        mut on_stop: impl FnMut(&Self),
        mut on_step: impl FnMut(&Self),
    ) -> Result<(), DeformError> {
        let dt = 1.0 / self.options.steps.max(1) as f64;
        let t_start = self.t;
        let mut stops = stops.iter().copied().filter(|&s| s >= t_start && s <= 1.0).peekable();
        while stops.peek().is_some_and(|&s| s <= self.t + 1e-12) {
            stops.next();
            on_stop(self);
        }
        while self.t < 1.0 - 1e-12 {
            let target = stops.peek().copied().unwrap_or(1.0).min(1.0);
            let mut h = dt.min(target - self.t);
            if self.options.max_strain.is_some() {
                h = h.min(self.next_step);
            }
            self.step(h)?;
            self.check_advancing()?;
            if (self.t - target).abs() < 1e-12 {
                self.t = target;
                if stops.peek().is_some() {
                    stops.next();
                    on_stop(self);
                    // a stop was seen: a failed solve is not stepped back across it
                    self.back.valid = false;
                }
            }
            on_step(self);
        }
        self.t = 1.0;
        for _ in stops {
            on_stop(self);
        }
        Ok(())
    }

    /// [`Deformation::run`] to t = 1 without stops, asking `go_on` after
    /// every accepted step whether to continue: Ok(false) if it said no
    /// before t = 1 (the state is then that step's).
    pub fn run_while(&mut self, mut go_on: impl FnMut(&Self) -> bool) -> Result<bool, DeformError> {
        let dt = 1.0 / self.options.steps.max(1) as f64;
        while self.t < 1.0 - 1e-12 {
            let mut h = dt.min(1.0 - self.t);
            if self.options.max_strain.is_some() {
                h = h.min(self.next_step);
            }
            self.step(h)?;
            self.check_advancing()?;
            if self.t < 1.0 - 1e-12 && !go_on(self) {
                return Ok(false);
            }
        }
        self.t = 1.0;
        go_on(self);
        Ok(true)
    }

    /// One step of size at most `h`: cut by the step control
    /// ([`DeformOptions::max_strain`]), then halved until no cell inverts
    /// and, with the step control, until no corner's Jacobian changed by
    /// more than it allows (on the last try only validity counts).
    ///
    /// A solve that fails every way its solver knows ([`Fallbacks`]) is
    /// met with a smaller step, as an inversion is: where the failing
    /// system depends on the step (Heun's second stage) this step is
    /// halved; the system at the step's start does not, so the last
    /// accepted step is retaken from its start with half its size (and
    /// the steps stay at most that until the run has passed the failure),
    /// up to `max_halvings` times. Only then does the run end with
    /// [`DeformError::Solve`].
    pub fn step(&mut self, h: f64) -> Result<(), DeformError> {
        let mut h = h.min(self.back.cap);
        let mut halved_for_solver = 0;
        for attempt in 0..=self.options.max_halvings {
            let control = attempt < self.options.max_halvings;
            match self.try_step(h, control)? {
                Attempt::Taken => {
                    self.stats.steps += 1;
                    if self.t > self.back.failed_at + 1e-12 {
                        // past the failure: the steps may grow again
                        self.back.cap = f64::INFINITY;
                        self.back.retakes = 0;
                    }
                    if halved_for_solver > 0 {
                        self.back.solved = Some(fallback_count(&self.solver.fallbacks()));
                    }
                    return Ok(());
                }
                Attempt::Refused(bad, tried) if attempt == self.options.max_halvings => {
                    return Err(DeformError::Tangled { t: self.t, dt: tried, cells: bad });
                }
                Attempt::Refused(bad, tried) => {
                    self.stats.halved += 1;
                    h = tried * if bad.is_empty() { self.strain_factor().min(0.5) } else { 0.5 };
                }
                Attempt::SolveFailed(e, true, tried) if attempt < self.options.max_halvings => {
                    tracing::info!("a solve at the second stage of a step of {tried:.3e} failed ({e}): half the step");
                    self.stats.halved += 1;
                    self.stats.solver_retakes += 1;
                    halved_for_solver += 1;
                    h = 0.5 * tried;
                }
                Attempt::SolveFailed(e, stage, tried) => {
                    let retake = !stage && self.back.valid && self.back.retakes < self.options.max_halvings;
                    if !retake {
                        let mut failure = SolverFailure::from(e);
                        failure.tried.push(self.no_smaller_step(stage, tried));
                        return Err(DeformError::Solve(failure));
                    }
                    // back to the last step's start, to retake it smaller
                    if self.back.retakes == 0 {
                        self.back.failed_at = self.t;
                    }
                    self.back.retakes += 1;
                    self.back.cap = self.back.cap.min(self.back.h) * 0.5;
                    tracing::info!("the solve at t = {:.4} failed ({e}): the step from t = {:.4} again with {:.3e}", self.t, self.back.t, self.back.cap);
                    self.step_back();
                    self.stats.halved += 1;
                    self.stats.solver_retakes += 1;
                    halved_for_solver += 1;
                    h = self.back.cap;
                }
            }
        }
        unreachable!("the loop returns on its last attempt")
    }

    /// Ends a run short of t = 1 whose steps no longer advance t
    /// ([`STALL_WINDOW`]) or that spent its budget
    /// ([`DeformOptions::max_steps`]).
    fn check_advancing(&mut self) -> Result<(), DeformError> {
        if self.t >= 1.0 - 1e-12 {
            return Ok(());
        }
        let (steps, t) = (self.stats.steps, self.t);
        if let Some(max) = self.options.max_steps {
            if steps >= max {
                return Err(DeformError::Stalled { t, steps, why: format!("its budget of {max} steps is spent") });
            }
            if steps >= self.pace_mark.0 + PACE_WINDOW {
                let advance = t - self.pace_mark.1;
                let reach = t + advance / PACE_WINDOW as f64 * (max - steps) as f64;
                if reach < 1.0 {
                    return Err(DeformError::Stalled { t, steps, why: format!("its last {PACE_WINDOW} steps advanced t by {advance:.2e} in all; at that pace the {} steps left of its budget of {max} would end at t = {reach:.4}", max - steps) });
                }
                self.pace_mark = (steps, t);
            }
        }
        if steps >= self.mark.0 + STALL_WINDOW {
            let advance = t - self.mark.1;
            // (a run of very many nominal steps advances less per window)
            if advance < STALL_ADVANCE.min(STALL_WINDOW as f64 / (2.0 * self.options.steps.max(1) as f64)) {
                return Err(DeformError::Stalled { t, steps, why: format!("its last {STALL_WINDOW} steps advanced t by {advance:.2e} in all (the step control cut them to {:.2e})", self.back.h) });
            }
            self.mark = (steps, t);
        }
        Ok(())
    }

    /// Why no smaller step was tried after a failed solve, for the message.
    fn no_smaller_step(&self, stage: bool, tried: f64) -> String {
        let halvings = self.options.max_halvings;
        if stage {
            format!("a smaller step: halved {halvings} times, down to {tried:.3e}, and still failing")
        } else if self.back.retakes > 0 {
            format!("a smaller step: the steps before t = {:.4} retaken {} times with half the step, down to {:.3e}, and the solve still failing", self.back.failed_at, self.back.retakes, self.back.cap)
        } else if self.t == 0.0 {
            "a smaller step: none to take, as the failing solve is the run's first, at t = 0, which no step size changes".into()
        } else {
            format!("a smaller step: none to take at t = {:.4}, as the failing system is the one at the step's start, which its size does not change, and there is no earlier step to retake (the run started or stopped here)", self.t)
        }
    }

    /// Restores the start of the last accepted step (its nodes, boundary
    /// state and velocity): that step is to be retaken smaller.
    fn step_back(&mut self) {
        std::mem::swap(self.mesh.nodes_mut(), &mut self.back.nodes);
        self.boundary.state_mut().clone_from(&self.back.state);
        self.k1.copy_from_slice(&self.back.k1);
        self.k1_current = true;
        self.t = self.back.t;
        self.next_step = f64::INFINITY;
        // one step back only: the nodes kept are now the failing ones
        self.back.valid = false;
    }

    /// Tries a step of at most `h`; on success updates the state (keeping
    /// the step's start in `back`), else leaves the state untouched and
    /// returns the cells that would invert (none if only the step control
    /// refused it), or the solve that failed, with the step tried.
    fn try_step(&mut self, h: f64, control: bool) -> Result<Attempt, DeformError> {
        self.saved_state.clone_from(self.boundary.state());
        let nodes = std::mem::take(self.mesh.nodes_mut());
        let result = self.advance(&nodes, self.t, h);
        *self.mesh.nodes_mut() = nodes;
        let failure = match result {
            Ok(h) => {
                let bad = self.invalid_cells(&self.next);
                if bad.is_empty() && !(self.too_strained() && control) {
                    std::mem::swap(self.mesh.nodes_mut(), &mut self.next);
                    // keep this step's start by rotating buffers, no copy:
                    // `next` and `saved_state` are overwritten before use
                    std::mem::swap(&mut self.next, &mut self.back.nodes);
                    std::mem::swap(&mut self.saved_state, &mut self.back.state);
                    std::mem::swap(&mut self.k1, &mut self.back.k1);
                    (self.back.t, self.back.h, self.back.valid) = (self.t, h, true);
                    self.t += h;
                    self.next_step = h * self.strain_factor().clamp(1.0, 2.0);
                    self.k1_current = false;
                    return Ok(Attempt::Taken);
                }
                Ok(Attempt::Refused(bad, h))
            }
            Err(StepFailure::Inverted(cell, h)) => Ok(Attempt::Refused(vec![cell], h)),
            Err(StepFailure::Solve(e, stage)) => Ok(Attempt::SolveFailed(e, stage, h)),
            Err(StepFailure::Fatal(e)) => Err(e),
        };
        // the boundary parameters moved with the rejected step: restore them
        std::mem::swap(self.boundary.state_mut(), &mut self.saved_state);
        failure
    }

    /// The cells the per-step checks look at ([`Moving`]).
    fn checked_cells(&self) -> &[[usize; N]] {
        self.moving.as_ref().map_or(self.mesh.cells(), |m| &m.cells)
    }

    /// The cells not certified valid at `nodes`, among those that move.
    fn invalid_cells(&self, nodes: &[[f64; D]]) -> Vec<usize> {
        match &self.moving {
            Some(m) => crate::quality::certify::invalid_cells(&m.cells, nodes).into_iter().map(|k| m.ids[k]).collect(),
            None => self.mesh.invalid_cells(nodes),
        }
    }

    /// With the step control on, whether the step just computed changed
    /// some corner's Jacobian by more than it allows. This sees what the
    /// velocity alone does not: the put-back onto curved walls, which
    /// squeezes thin layers by the square of the step (measured on a 1e-5
    /// layer at p = 3: a ratio of 9.6 in one step, 3.1 in two; 0.90–1.11
    /// on the cylinder and ball meshes of the benchmarks in one step).
    fn too_strained(&mut self) -> bool {
        let Some(c) = self.options.max_strain else { return false };
        let (lo, hi) = strain::corner_ratio_range(self.checked_cells(), self.mesh.nodes(), &self.next);
        self.strain = (1.0 - lo).max(hi - 1.0);
        self.strain > c
    }

    /// By how much to scale the step just tried so that its strain would
    /// meet the step control, with a margin: the change grows like the
    /// square of the step where the put-back dominates, so the square
    /// root of the ratio (bounded to 0.1 … 2).
    fn strain_factor(&self) -> f64 {
        match self.options.max_strain {
            Some(c) if self.strain > 0.0 => (0.9 * (c / self.strain).sqrt()).clamp(0.1, 2.0),
            Some(_) => 2.0,
            None => 1.0,
        }
    }

    /// Writes into `self.next` the positions after one step of the
    /// integrator from `nodes` at time t, of size `h` or less if the strain
    /// limit cuts it; returns the step taken.
    fn advance(&mut self, nodes: &[[f64; D]], t: f64, h: f64) -> Result<f64, StepFailure> {
        if !self.k1_current {
            self.node_velocity(nodes, t).map_err(|e| e.at(h))?;
            self.k1.copy_from_slice(&self.u);
            self.k1_current = true;
        }
        let h = match self.options.max_strain {
            Some(c) => strain::max_step(self.checked_cells(), nodes, &self.k1, c, h),
            None => h,
        };
        for ((o, x), k) in self.next.iter_mut().zip(nodes).zip(&self.k1) {
            *o = std::array::from_fn(|i| x[i] + h * k[i]);
        }
        if self.options.integrator == Integrator::Heun {
            // the stage mesh conforms to Γ_{t+h} too
            self.boundary.put_back(&mut self.next, t + h);
            let mut stage = std::mem::take(&mut self.stage);
            stage.copy_from_slice(&self.next);
            let r = self.node_velocity(&stage, t + h);
            self.stage = stage;
            r.map_err(|e| match e {
                StepFailure::Solve(e, _) => StepFailure::Solve(e, true),
                e => e.at(h),
            })?;
            for ((o, x), (a, b)) in self.next.iter_mut().zip(nodes).zip(self.k1.iter().zip(&self.u)) {
                *o = std::array::from_fn(|i| x[i] + 0.5 * h * (a[i] + b[i]));
            }
        }
        self.boundary.put_back(&mut self.next, t + h);
        Ok(h)
    }

    /// Solves the LSFEM system at positions `nodes`, time t, and stores the
    /// node velocity f u in `self.u`.
    fn node_velocity(&mut self, nodes: &[[f64; D]], t: f64) -> Result<(), StepFailure> {
        let t0 = Instant::now();
        self.boundary.velocities(&mut self.bvel);
        let flux = self.mesh.flux_points(nodes, &self.bvel);
        let norm = match &self.moving {
            Some(Moving { cells, still: Some(still), .. }) => normalise_with(cells, nodes, &self.field, (t, self.volume0), flux, *still),
            _ => normalise(self.mesh.cells(), nodes, &self.field, t, self.volume0, flux),
        }
        .map_err(DeformError::from)?;
        let field = &self.field;
        // f at the nodes, checked: the nodes may have moved where g ≤ 0
        for (f, x) in self.f_nodes.iter_mut().zip(nodes) {
            *f = norm.c * field.g_checked(lift(*x), t).map_err(DeformError::from)?.0;
        }
        let f_nodes = &self.f_nodes;
        self.boundary.fill_constraints(t, nodes, |i| f_nodes[i], &mut self.constraints);
        self.system
            .assemble(nodes, &self.constraints, |x| norm.div_data(field, lift(x)))
            .map_err(|e| match e {
                LsfemError::Inverted { cell, .. } => StepFailure::Inverted(cell, 0.0),
                other => StepFailure::Fatal(other.into()),
            })?;
        self.stats.assembly += t0.elapsed();
        let t1 = Instant::now();
        self.solver.factor(self.system.matrix(), self.system.structure()).map_err(solve_failure)?;
        let t2 = Instant::now();
        self.x.copy_from_slice(&self.system.rhs);
        self.solver.solve_in_place(self.system.matrix(), &mut self.x).map_err(solve_failure)?;
        self.stats.factor += t2 - t1;
        self.stats.solve += t2.elapsed();
        self.stats.solves += 1;
        let info = self.solver.info();
        self.stats.iterations += info.iterations;
        self.stats.last_iterations = info.iterations;
        self.stats.max_iterations = self.stats.max_iterations.max(info.iterations);
        if info.rebuilt {
            self.stats.setups += 1;
            self.stats.setup += info.setup;
        }
        self.system.expand(&self.x, &self.constraints, &mut self.u);
        for (u, f) in self.u.iter_mut().zip(&self.f_nodes) {
            *u = u.map(|c| f * c);
        }
        Ok(())
    }

    /// For each node on a moving part, its distance to the target shape.
    pub fn boundary_distances(&self) -> Vec<(usize, f64)> {
        self.boundary.distances(self.mesh.nodes())
    }
}

/// How often a solver turned to a fallback.
fn fallback_count(f: &FallbackTally) -> usize {
    f.rebuilt + f.factor + f.direct
}

/// A solver error as a step's failure: one a smaller step may avoid, or
/// (a malformed pattern, a solver used out of order) a fatal one.
fn solve_failure(e: SolveError) -> StepFailure {
    match e {
        SolveError::Pattern(_) | SolveError::Order(_) | SolveError::Symbolic(_) => StepFailure::Fatal(e.into()),
        e => StepFailure::Solve(e, false),
    }
}

/// How one try of a step ended.
enum Attempt {
    /// Taken.
    Taken,
    /// Refused with this step: the cells that would invert (none if only
    /// the step control refused it).
    Refused(Vec<usize>, f64),
    /// A solve failed every way its solver knows: the error, whether in
    /// a later stage of the step (whose system depends on the step), and
    /// the step tried.
    SolveFailed(SolveError, bool, f64),
}

/// Why a step attempt failed.
enum StepFailure {
    /// A cell inverted during a stage of a step of this size: retry with
    /// a smaller step.
    Inverted(usize, f64),
    /// A solve failed every way the solver knows (in a later stage:
    /// true).
    Solve(SolveError, bool),
    /// Anything else: give up.
    Fatal(DeformError),
}

impl StepFailure {
    /// The failure of a step of size h (an inversion in a stage records it).
    fn at(self, h: f64) -> Self {
        match self {
            StepFailure::Inverted(cell, _) => StepFailure::Inverted(cell, h),
            fatal => fatal,
        }
    }
}

impl From<DeformError> for StepFailure {
    fn from(e: DeformError) -> Self {
        StepFailure::Fatal(e)
    }
}
