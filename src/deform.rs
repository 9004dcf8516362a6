//! Algorithm 1: deformation on a moving domain.
//!
//! Every pseudo-time step solves `div u = −∂_t(1/f)`, `curl u = 0` by
//! LSFEM on the current mesh and moves every node with `dφ/dt = f u`.
//! Boundary parts decide the constraints (DESIGN.md §1):
//! - `slip`: `u·n = 0`, the node glides along its wall and is put back
//!   onto it after the step;
//! - `move` to a target shape: the boundary Γ_t is the blend
//!   `Γ_t(s) = (1−t) P₀(s) + t X(P₀(s))` of the starting chain P₀ and its
//!   image X on the target (radial or closest-point correspondence).
//!   `sliding` imposes only `u·n = v·n/f` and puts the node back onto
//!   Γ_{t+dt}; `dirichlet` imposes `u = v/f`;
//! - `fixed`: `u = 0`.
//!
//! Where chains meet (the corners of a box) a node has two constraints in
//! 2D and so follows a prescribed path.

use crate::geometry::Shape;
use crate::jacobian::{edge_flux_points, lift, normalise, JacobianError, JacobianField, Normalisation};
use crate::lsfem::{DivCurlSystem, LsfemError, NodeConstraint};
use crate::mesh::{Point2, QuadMesh};
use crate::quality::{corner_jacobians, invalid_cells};
use crate::solve::{CholeskySolver, SolveError, SpdSolver};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How a point of the starting boundary finds its place on the target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Correspondence {
    /// Along the ray from a centre through the point.
    Radial {
        /// The centre of the rays.
        centre: Point2,
    },
    /// The closest point of the target.
    Normal,
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
pub enum PartKind {
    /// A wall the nodes glide along: the given shape, or (None) the
    /// starting boundary itself.
    Slip {
        /// The wall, if not the starting boundary.
        wall: Option<Arc<Shape>>,
    },
    /// The part moves onto `target`.
    Move {
        /// The target shape.
        target: Arc<Shape>,
        /// Point correspondence.
        correspondence: Correspondence,
        /// Sliding or Dirichlet.
        mode: MoveMode,
    },
    /// Nodes do not move.
    Fixed,
}

/// A named boundary part; mesh edges refer to parts by index.
#[derive(Clone, Debug)]
pub struct BoundaryPart {
    /// The name (a physical group in the output).
    pub name: String,
    /// Its behaviour.
    pub kind: PartKind,
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
    /// The linear solver failed.
    #[error("the linear solver failed")]
    Solve(#[from] SolveError),
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
    /// The starting mesh is invalid.
    #[error("the starting mesh has {} inverted cell(s), first {:?}", .0.len(), &.0[..(.0.len().min(10))])]
    InvalidStart(Vec<usize>),
}

/// A maximal run of boundary edges of one part between feature nodes,
/// parametrised by normalised arc length s ∈ [0, 1] of its start position.
#[derive(Clone, Debug)]
struct Chain {
    part: usize,
    /// Starting positions of the chain's vertices, in order.
    points: Vec<Point2>,
    /// Cumulative normalised arc length at each vertex.
    s: Vec<f64>,
}

impl Chain {
    /// P₀(s): the starting position at parameter s (piecewise linear).
    /// Outside [0, 1] the end segments are extended: a slip wall goes on
    /// beyond the starting domain, which may grow.
    fn start(&self, s: f64) -> Point2 {
        let k = match self.s.binary_search_by(|v| v.total_cmp(&s)) {
            Ok(k) => return self.points[k],
            Err(k) => k.clamp(1, self.s.len() - 1),
        };
        let (a, b) = (self.points[k - 1], self.points[k]);
        let w = (s - self.s[k - 1]) / (self.s[k] - self.s[k - 1]);
        [a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1])]
    }
}

/// What a node does.
#[derive(Clone, Copy, Debug)]
enum Role {
    Interior,
    /// Inside a chain, at parameter s.
    Chain { chain: usize, s: f64 },
    /// A feature node: follows the path of a moving chain's end, or stays.
    Corner { path: Option<(usize, f64)> },
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
}

impl Default for DeformOptions {
    fn default() -> Self {
        DeformOptions { steps: 40, integrator: Integrator::Euler, div_weight: 1.0, max_halvings: 12 }
    }
}

/// The state of Algorithm 1 on one mesh.
pub struct Deformation {
    /// The mesh at the current pseudo-time.
    pub mesh: QuadMesh,
    /// Node positions at t = 0.
    pub start: Vec<Point2>,
    /// The current pseudo-time.
    pub t: f64,
    /// Counters and timings.
    pub stats: RunStats,
    boundary: Boundary,
    field: JacobianField,
    options: DeformOptions,
    area0: f64,
    system: DivCurlSystem,
    solver: Box<dyn SpdSolver>,
    // buffers reused every step
    constraints: Vec<NodeConstraint>,
    bvel: Vec<Point2>,
    u: Vec<Point2>,
    k1: Vec<Point2>,
    stage: Vec<Point2>,
    next: Vec<Point2>,
    saved_roles: Vec<Role>,
    x: Vec<f64>,
}

impl Deformation {
    /// Prepares Algorithm 1: classifies nodes, checks that every moving
    /// part can reach its target, builds the pattern and analyses it.
    pub fn new(mesh: QuadMesh, parts: Vec<BoundaryPart>, field: JacobianField, options: DeformOptions) -> Result<Deformation, DeformError> {
        Deformation::with_solver(mesh, parts, field, options, Box::new(CholeskySolver::new()))
    }

    /// As [`Deformation::new`] with a given solver.
    pub fn with_solver(
        mesh: QuadMesh,
        parts: Vec<BoundaryPart>,
        field: JacobianField,
        options: DeformOptions,
        mut solver: Box<dyn SpdSolver>,
    ) -> Result<Deformation, DeformError> {
        let bad = invalid_cells(&mesh, &mesh.nodes);
        if !bad.is_empty() {
            return Err(DeformError::InvalidStart(bad));
        }
        let (chains, roles) = classify(&mesh, &parts);
        let boundary = Boundary { parts, chains, initial_roles: roles.clone(), roles, start: mesh.nodes.clone() };
        boundary.check_reachable()?;
        // constraint kinds are fixed for the run: build the pattern once
        let n = mesh.num_nodes();
        let mut constraints = vec![NodeConstraint::free(); n];
        boundary.fill_constraints(0.0, &mesh.nodes, |_| 1.0, &mut constraints);
        let mut system = DivCurlSystem::new(&mesh.cells, &constraints);
        system.div_weight = options.div_weight;
        let t0 = Instant::now();
        solver.analyze(system.pattern())?;
        let stats = RunStats { analyze: t0.elapsed(), ..Default::default() };
        Ok(Deformation {
            start: mesh.nodes.clone(),
            area0: mesh.area(),
            t: 0.0,
            stats,
            x: vec![0.0; system.num_unknowns()],
            system,
            constraints,
            bvel: vec![[0.0; 2]; n],
            u: vec![[0.0; 2]; n],
            k1: vec![[0.0; 2]; n],
            stage: mesh.nodes.clone(),
            next: mesh.nodes.clone(),
            saved_roles: boundary.roles.clone(),
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
        self.mesh.nodes.clone_from(&self.start);
        self.boundary.roles.clone_from(&self.boundary.initial_roles);
        self.t = 0.0;
    }

    /// The boundary parts.
    pub fn parts(&self) -> &[BoundaryPart] {
        &self.boundary.parts
    }

    /// The prescribed Jacobian.
    pub fn field(&self) -> &JacobianField {
        &self.field
    }

    /// Normalisation at the current state (t, current nodes).
    pub fn normalisation_now(&self) -> Result<Normalisation, DeformError> {
        let mut bvel = vec![[0.0; 2]; self.mesh.num_nodes()];
        self.boundary.velocities(&mut bvel);
        let flux = edge_flux_points(&self.mesh, &self.mesh.nodes, &bvel);
        Ok(normalise(&self.mesh.cells, &self.mesh.nodes, &self.field, self.t, self.area0, flux)?)
    }

    /// J/f per cell at the current state (see [`crate::quality::jf_ratios`]).
    pub fn jf_now(&self) -> Result<Vec<f64>, DeformError> {
        let norm = self.normalisation_now()?;
        Ok(crate::quality::jf_ratios(&self.mesh.cells, &self.mesh.nodes, &self.start, &self.field, &norm))
    }

    /// Number of unknowns of the reduced LSFEM system.
    pub fn num_unknowns(&self) -> usize {
        self.system.num_unknowns()
    }

    /// The solver in use.
    pub fn solver_name(&self) -> &'static str {
        self.solver.name()
    }

    /// Runs from the current t to 1 with the nominal step 1/steps, landing
    /// exactly on each of `stops` (sorted pseudo-times); `on_stop` is
    /// called there, `on_step` after every accepted step.
    pub fn run(
        &mut self,
        stops: &[f64],
        mut on_stop: impl FnMut(&Deformation),
        mut on_step: impl FnMut(&Deformation),
    ) -> Result<(), DeformError> {
        let dt = 1.0 / self.options.steps.max(1) as f64;
        let t_start = self.t;
        let mut stops = stops.iter().copied().filter(|&s| s >= t_start).peekable();
        while stops.peek().is_some_and(|&s| s <= self.t + 1e-12) {
            stops.next();
            on_stop(self);
        }
        while self.t < 1.0 - 1e-12 {
            let target = stops.peek().copied().unwrap_or(1.0).min(1.0);
            let h = dt.min(target - self.t);
            self.step(h)?;
            if (self.t - target).abs() < 1e-12 {
                self.t = target;
                if stops.peek().is_some() {
                    stops.next();
                    on_stop(self);
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

    /// One step of size `h` (halved until no cell inverts).
    pub fn step(&mut self, h: f64) -> Result<(), DeformError> {
        let mut h = h;
        for attempt in 0..=self.options.max_halvings {
            match self.try_step(h)? {
                None => {
                    self.stats.steps += 1;
                    return Ok(());
                }
                Some(bad) if attempt == self.options.max_halvings => {
                    return Err(DeformError::Tangled { t: self.t, dt: h, cells: bad });
                }
                Some(_) => {
                    self.stats.halved += 1;
                    h *= 0.5;
                }
            }
        }
        unreachable!("the loop returns on its last attempt")
    }

    /// Tries a step; on success updates the state and returns None, else
    /// leaves the state untouched and returns the cells that would invert.
    fn try_step(&mut self, h: f64) -> Result<Option<Vec<usize>>, DeformError> {
        self.saved_roles.clone_from(&self.boundary.roles);
        let nodes = std::mem::take(&mut self.mesh.nodes);
        let result = self.advance(&nodes, self.t, h);
        self.mesh.nodes = nodes;
        let failure = match result {
            Ok(()) => {
                let bad = invalid_cells(&self.mesh, &self.next);
                if bad.is_empty() {
                    std::mem::swap(&mut self.mesh.nodes, &mut self.next);
                    self.t += h;
                    return Ok(None);
                }
                Ok(Some(bad))
            }
            Err(StepFailure::Inverted(cell)) => Ok(Some(vec![cell])),
            Err(StepFailure::Fatal(e)) => Err(e),
        };
        // the boundary parameters moved with the rejected step: restore them
        std::mem::swap(&mut self.boundary.roles, &mut self.saved_roles);
        failure
    }

    /// Writes into `self.next` the positions after one step of the
    /// integrator from `nodes` at time t.
    fn advance(&mut self, nodes: &[Point2], t: f64, h: f64) -> Result<(), StepFailure> {
        self.node_velocity(nodes, t)?;
        self.k1.copy_from_slice(&self.u);
        for ((o, x), k) in self.next.iter_mut().zip(nodes).zip(&self.k1) {
            *o = [x[0] + h * k[0], x[1] + h * k[1]];
        }
        if self.options.integrator == Integrator::Heun {
            // the stage mesh conforms to Γ_{t+h} too
            self.boundary.put_back(&mut self.next, t + h);
            let mut stage = std::mem::take(&mut self.stage);
            stage.copy_from_slice(&self.next);
            let r = self.node_velocity(&stage, t + h);
            self.stage = stage;
            r?;
            for ((o, x), (a, b)) in self.next.iter_mut().zip(nodes).zip(self.k1.iter().zip(&self.u)) {
                *o = [x[0] + 0.5 * h * (a[0] + b[0]), x[1] + 0.5 * h * (a[1] + b[1])];
            }
        }
        self.boundary.put_back(&mut self.next, t + h);
        Ok(())
    }

    /// Solves the LSFEM system at positions `nodes`, time t, and stores the
    /// node velocity f u in `self.u`.
    fn node_velocity(&mut self, nodes: &[Point2], t: f64) -> Result<(), StepFailure> {
        let t0 = Instant::now();
        self.boundary.velocities(&mut self.bvel);
        let flux = edge_flux_points(&self.mesh, nodes, &self.bvel);
        let norm = normalise(&self.mesh.cells, nodes, &self.field, t, self.area0, flux).map_err(DeformError::from)?;
        let field = &self.field;
        self.boundary.fill_constraints(t, nodes, |i| norm.f(field, lift(nodes[i])), &mut self.constraints);
        self.system
            .assemble(nodes, &self.constraints, |x| norm.div_data(field, lift(x)))
            .map_err(|e| match e {
                LsfemError::Inverted { cell, .. } => StepFailure::Inverted(cell),
                other => StepFailure::Fatal(other.into()),
            })?;
        self.stats.assembly += t0.elapsed();
        let t1 = Instant::now();
        self.solver.factor(&self.system.values).map_err(DeformError::from)?;
        let t2 = Instant::now();
        self.x.copy_from_slice(&self.system.rhs);
        self.solver.solve_in_place(&mut self.x).map_err(DeformError::from)?;
        self.stats.factor += t2 - t1;
        self.stats.solve += t2.elapsed();
        self.stats.solves += 1;
        self.system.expand(&self.x, &self.constraints, &mut self.u);
        for (i, u) in self.u.iter_mut().enumerate() {
            let f = norm.f(field, lift(nodes[i]));
            *u = [f * u[0], f * u[1]];
        }
        Ok(())
    }

    /// For each node on a moving part, its distance to the target shape.
    pub fn boundary_distances(&self) -> Vec<(usize, f64)> {
        self.boundary.distances(&self.mesh.nodes)
    }

    /// Current minimum corner Jacobian determinant (a validity margin).
    pub fn min_corner_jacobian(&self) -> f64 {
        (0..self.mesh.num_cells())
            .flat_map(|c| corner_jacobians(&self.mesh.cell_coords(c)))
            .fold(f64::INFINITY, f64::min)
    }
}

/// The boundary: parts, chains, and every node's role.
#[derive(Clone, Debug)]
struct Boundary {
    parts: Vec<BoundaryPart>,
    chains: Vec<Chain>,
    roles: Vec<Role>,
    /// Roles at t = 0 (for [`Deformation::reset`]).
    initial_roles: Vec<Role>,
    /// Node positions at t = 0.
    start: Vec<Point2>,
}

impl Boundary {
    /// v = X(P₀(s)) − P₀(s) on a moving chain: the (constant) velocity of
    /// the boundary point with parameter s.
    fn chain_velocity(&self, chain: usize, s: f64) -> Option<Point2> {
        let c = &self.chains[chain];
        let p = c.start(s);
        let x = self.image(c.part, p)?;
        Some([x[0] - p[0], x[1] - p[1]])
    }

    /// Γ_t(s) of a moving chain.
    fn chain_point(&self, chain: usize, s: f64, t: f64) -> Point2 {
        let p = self.chains[chain].start(s);
        match self.chain_velocity(chain, s) {
            Some(v) => [p[0] + t * v[0], p[1] + t * v[1]],
            None => p,
        }
    }

    /// The target image X(p) of a starting point on a moving part.
    fn image(&self, part: usize, p: Point2) -> Option<Point2> {
        match &self.parts[part].kind {
            PartKind::Move { target, correspondence, .. } => match correspondence {
                Correspondence::Radial { centre } => target.ray_hit(*centre, [p[0] - centre[0], p[1] - centre[1]]),
                Correspondence::Normal => Some(target.closest_point(p)),
            },
            _ => None,
        }
    }

    /// Every point of a moving chain must have an image on the target,
    /// and the images must run along the target without folding back or
    /// jumping (a closest-point map does both behind a centre of
    /// curvature) — else the boundary itself would tangle.
    fn check_reachable(&self) -> Result<(), DeformError> {
        const PER_EDGE: usize = 8;
        for c in &self.chains {
            let part = &self.parts[c.part];
            let PartKind::Move { correspondence, .. } = part.kind else { continue };
            let fail = |why: String| DeformError::Unreachable { part: part.name.clone(), why };
            let samples: Vec<f64> = c
                .s
                .windows(2)
                .flat_map(|w| (0..PER_EDGE).map(move |j| w[0] + (w[1] - w[0]) * j as f64 / PER_EDGE as f64))
                .chain(std::iter::once(1.0))
                .collect();
            let mut images = Vec::with_capacity(samples.len());
            for &s in &samples {
                let p = c.start(s);
                let Some(x) = self.image(c.part, p) else {
                    return Err(fail(match correspondence {
                        Correspondence::Radial { centre } => format!(
                            "the ray from the centre ({}, {}) through the boundary point ({:.6}, {:.6}) misses the target shape",
                            centre[0], centre[1], p[0], p[1]
                        ),
                        Correspondence::Normal => format!("no closest point on the target for ({:.6}, {:.6})", p[0], p[1]),
                    }));
                };
                images.push(x);
            }
            let steps: Vec<Point2> = images.windows(2).map(|w| [w[1][0] - w[0][0], w[1][1] - w[0][1]]).collect();
            let mut lengths: Vec<f64> = steps.iter().map(|d| d[0].hypot(d[1])).collect();
            for (j, w) in steps.windows(2).enumerate() {
                if w[0][0] * w[1][0] + w[0][1] * w[1][1] < 0.0 {
                    let p = c.start(samples[j + 1]);
                    return Err(fail(format!(
                        "the {} correspondence folds back near the boundary point ({:.6}, {:.6}): its images on the target reverse direction (try correspondence = \"radial\" with a centre)",
                        if matches!(correspondence, Correspondence::Normal) { "closest-point" } else { "radial" },
                        p[0],
                        p[1]
                    )));
                }
            }
            let total: f64 = lengths.iter().sum();
            lengths.sort_by(f64::total_cmp);
            let median = lengths[lengths.len() / 2];
            if let Some(j) = steps.iter().position(|d| d[0].hypot(d[1]) > 50.0 * median.max(1e-3 * total / steps.len() as f64)) {
                let p = c.start(samples[j]);
                return Err(fail(format!(
                    "the correspondence jumps near the boundary point ({:.6}, {:.6}): neighbouring points land far apart on the target (try correspondence = \"radial\" with a centre)",
                    p[0], p[1]
                )));
            }
        }
        Ok(())
    }

    /// The nodal boundary velocity v (constant in t along each path).
    fn velocities(&self, out: &mut [Point2]) {
        for (i, role) in self.roles.iter().enumerate() {
            out[i] = match *role {
                Role::Chain { chain, s } => self.chain_velocity(chain, s).unwrap_or([0.0; 2]),
                Role::Corner { path: Some((chain, s)) } => self.chain_velocity(chain, s).unwrap_or([0.0; 2]),
                _ => [0.0; 2],
            };
        }
    }

    /// Outward unit normal of Γ_t at s on a chain (slip walls: of the wall).
    fn chain_normal(&self, chain: usize, s: f64, t: f64, at: Point2) -> Point2 {
        if let PartKind::Slip { wall: Some(w) } = &self.parts[self.chains[chain].part].kind {
            let n = w.normal(at);
            return self.orient_outward(chain, s, n);
        }
        let hs = 1e-6;
        // a moving chain ends at its corners; a slip wall extends beyond
        let (a, b) = match self.parts[self.chains[chain].part].kind {
            PartKind::Move { .. } => ((s - hs).max(0.0), (s + hs).min(1.0)),
            _ => (s - hs, s + hs),
        };
        let (pa, pb) = (self.chain_point(chain, a, t), self.chain_point(chain, b, t));
        // chains run with the domain on their left: outward is the right
        let tan = [pb[0] - pa[0], pb[1] - pa[1]];
        let len = tan[0].hypot(tan[1]);
        [tan[1] / len, -tan[0] / len]
    }

    /// Flips a shape's normal to point out of the domain (as the chain does).
    fn orient_outward(&self, chain: usize, s: f64, n: Point2) -> Point2 {
        let c = &self.chains[chain];
        let (a, b) = (c.start(s - 1e-6), c.start(s + 1e-6));
        let out = [b[1] - a[1], -(b[0] - a[0])];
        if out[0] * n[0] + out[1] * n[1] < 0.0 {
            [-n[0], -n[1]]
        } else {
            n
        }
    }

    /// The constraint of every node at time t for positions `nodes`, with
    /// prescribed values divided by f (`f(i)` at node i).
    fn fill_constraints(&self, t: f64, nodes: &[Point2], f: impl Fn(usize) -> f64, out: &mut [NodeConstraint]) {
        for i in 0..self.roles.len() {
            let x = nodes[i];
            out[i] = match self.roles[i] {
                Role::Interior => NodeConstraint::free(),
                Role::Corner { path } => {
                    let v = path.and_then(|(c, s)| self.chain_velocity(c, s)).unwrap_or([0.0; 2]);
                    NodeConstraint::fixed([v[0] / f(i), v[1] / f(i)])
                }
                Role::Chain { chain, s } => match &self.parts[self.chains[chain].part].kind {
                    PartKind::Fixed => NodeConstraint::fixed([0.0; 2]),
                    PartKind::Slip { .. } => NodeConstraint::normal(self.chain_normal(chain, s, t, x), 0.0),
                    PartKind::Move { mode: MoveMode::Dirichlet, .. } => {
                        let v = self.chain_velocity(chain, s).unwrap_or([0.0; 2]);
                        NodeConstraint::fixed([v[0] / f(i), v[1] / f(i)])
                    }
                    PartKind::Move { mode: MoveMode::Sliding, .. } => {
                        let v = self.chain_velocity(chain, s).unwrap_or([0.0; 2]);
                        let n = self.chain_normal(chain, s, t, x);
                        NodeConstraint::normal(n, (v[0] * n[0] + v[1] * n[1]) / f(i))
                    }
                },
            };
        }
    }

    /// Puts boundary nodes back exactly onto Γ_t (moving parts), onto their
    /// wall (slip) or their path (Dirichlet nodes and corners).
    fn put_back(&mut self, nodes: &mut [Point2], t: f64) {
        for i in 0..self.roles.len() {
            match self.roles[i] {
                Role::Interior => {}
                Role::Corner { path } => {
                    nodes[i] = match path {
                        Some((c, s)) => self.chain_point(c, s, t),
                        None => self.start[i],
                    };
                }
                Role::Chain { chain, s } => {
                    let (p, s_new) = match &self.parts[self.chains[chain].part].kind {
                        PartKind::Fixed => (self.start[i], s),
                        PartKind::Move { mode: MoveMode::Dirichlet, .. } => (self.chain_point(chain, s, t), s),
                        PartKind::Slip { wall: Some(w) } => (w.closest_point(nodes[i]), s),
                        PartKind::Slip { wall: None } => self.project_on_chain(chain, s, nodes[i], 0.0, None),
                        PartKind::Move { mode: MoveMode::Sliding, .. } => self.project_on_chain(chain, s, nodes[i], t, Some((0.0, 1.0))),
                    };
                    nodes[i] = p;
                    self.roles[i] = Role::Chain { chain, s: s_new };
                }
            }
        }
    }

    /// The point of Γ_t closest to x, by Gauss–Newton on s from `s0`,
    /// with s kept within `bounds` if given.
    fn project_on_chain(&self, chain: usize, s0: f64, x: Point2, t: f64, bounds: Option<(f64, f64)>) -> (Point2, f64) {
        let (lo, hi) = bounds.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
        let mut s = s0;
        let hs = 1e-7;
        for _ in 0..30 {
            let p = self.chain_point(chain, s, t);
            let (a, b) = ((s - hs).max(lo), (s + hs).min(hi));
            let (pa, pb) = (self.chain_point(chain, a, t), self.chain_point(chain, b, t));
            let d = [(pb[0] - pa[0]) / (b - a), (pb[1] - pa[1]) / (b - a)];
            let dd = d[0] * d[0] + d[1] * d[1];
            let step = ((x[0] - p[0]) * d[0] + (x[1] - p[1]) * d[1]) / dd;
            let s_new = (s + step).clamp(lo, hi);
            let done = (s_new - s).abs() < 1e-15;
            s = s_new;
            if done {
                break;
            }
        }
        (self.chain_point(chain, s, t), s)
    }

    /// For each node on a moving part, its distance to the target shape.
    fn distances(&self, nodes: &[Point2]) -> Vec<(usize, f64)> {
        let mut out = Vec::new();
        for (i, role) in self.roles.iter().enumerate() {
            let part = match *role {
                Role::Chain { chain, .. } => self.chains[chain].part,
                Role::Corner { path: Some((chain, _)) } => self.chains[chain].part,
                _ => continue,
            };
            if let PartKind::Move { target, .. } = &self.parts[part].kind {
                out.push((i, target.distance(nodes[i])));
            }
        }
        out
    }

}

/// Why a step attempt failed.
enum StepFailure {
    /// A cell inverted during a stage: retry with a smaller step.
    Inverted(usize),
    /// Anything else: give up.
    Fatal(DeformError),
}

impl From<DeformError> for StepFailure {
    fn from(e: DeformError) -> Self {
        StepFailure::Fatal(e)
    }
}

/// Splits the boundary into chains and gives every node its role.
fn classify(mesh: &QuadMesh, parts: &[BoundaryPart]) -> (Vec<Chain>, Vec<Role>) {
    let n = mesh.num_nodes();
    // per node, outgoing and incoming edge (per part) to walk chains
    let mut next: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n]; // (part, to)
    let mut prev_count = vec![0usize; n];
    for e in &mesh.edges {
        next[e.nodes[0]].push((e.part, e.nodes[1]));
        prev_count[e.nodes[1]] += 1;
    }
    let node_parts = mesh.node_parts();
    let is_feature = |i: usize| -> bool {
        if node_parts[i].len() > 1 || next[i].len() != 1 || prev_count[i] != 1 {
            return true;
        }
        // a sharp turn of the starting boundary (a box corner)
        let incoming = mesh.edges.iter().find(|e| e.nodes[1] == i).map(|e| e.nodes[0]);
        match incoming {
            Some(a) => {
                let (p, q, r) = (mesh.nodes[a], mesh.nodes[i], mesh.nodes[next[i][0].1]);
                let (u, v) = ([q[0] - p[0], q[1] - p[1]], [r[0] - q[0], r[1] - q[1]]);
                let cos = (u[0] * v[0] + u[1] * v[1]) / (u[0].hypot(u[1]) * v[0].hypot(v[1]));
                cos < (30f64).to_radians().cos()
            }
            None => true,
        }
    };
    let feature: Vec<bool> = (0..n).map(|i| !node_parts[i].is_empty() && is_feature(i)).collect();
    let mut roles = vec![Role::Interior; n];
    let mut chains: Vec<Chain> = Vec::new();
    let mut used = vec![false; mesh.edges.len()];
    let edge_from: std::collections::HashMap<(usize, usize), usize> =
        mesh.edges.iter().enumerate().map(|(k, e)| ((e.nodes[0], e.part), k)).collect();
    // walk from every feature node along each outgoing edge; then closed
    // loops without features start at their first node
    let mut starts: Vec<usize> = (0..n).filter(|&i| feature[i]).collect();
    starts.extend(mesh.edges.iter().map(|e| e.nodes[0]));
    let mut loop_feature = feature.clone();
    for start in starts {
        for &(part, _) in next[start].clone().iter() {
            let Some(&k0) = edge_from.get(&(start, part)) else { continue };
            if used[k0] {
                continue;
            }
            loop_feature[start] = true;
            let mut nodes_in = vec![start];
            let mut k = k0;
            loop {
                used[k] = true;
                let to = mesh.edges[k].nodes[1];
                nodes_in.push(to);
                if loop_feature[to] {
                    break;
                }
                match edge_from.get(&(to, part)) {
                    Some(&kn) if !used[kn] => k = kn,
                    _ => break,
                }
            }
            let points: Vec<Point2> = nodes_in.iter().map(|&i| mesh.nodes[i]).collect();
            let mut s = vec![0.0];
            for w in points.windows(2) {
                s.push(s.last().unwrap() + (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]));
            }
            let total = *s.last().unwrap();
            s.iter_mut().for_each(|v| *v /= total);
            let id = chains.len();
            for (j, &node) in nodes_in.iter().enumerate() {
                if j == 0 || j + 1 == nodes_in.len() {
                    // chain ends are corners; prefer the path of a moving chain
                    let moving = matches!(parts[part].kind, PartKind::Move { .. });
                    let here = Some((id, s[j]));
                    roles[node] = match roles[node] {
                        Role::Corner { path: Some(p) } => Role::Corner { path: Some(p) },
                        _ => Role::Corner { path: if moving { here } else { None } },
                    };
                } else {
                    roles[node] = Role::Chain { chain: id, s: s[j] };
                }
            }
            chains.push(Chain { part, points, s });
        }
    }
    (chains, roles)
}
