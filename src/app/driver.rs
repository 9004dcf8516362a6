//! The whole job of `deformesh run`: a case in, Algorithm 1, quality
//! figures, and the output folder (mesh.msh, mesh.vtu, mesh.png,
//! report.json, frames and an animation).
//!
//! Outputs are produced in memory and written only when the run has
//! succeeded, each file atomically, so a failed run leaves nothing behind.

use crate::app::case::{AnySetup, CaseError, Colour, OutputSpec, Setup};
use crate::refine::Subdividable;
use crate::deform::{BoundaryPart, Cut, Cuttable, DeformError, Deformation, Integrator, Q1Mesh, SolverReport};
use crate::highorder::curve::{certify_mesh, curve_with_progress, CurveError, CurveOptions, Curved, CurvedQuality};
use crate::highorder::Spacing;
use crate::mesh::CurvedMesh;
use crate::io::msh::{hex_msh_string, msh_string, AnyMesh, MshError};
use crate::io::vtu::{hex_vtu_string, vtu_string, VtuError};
use crate::io::folder::{check_output_file, check_run_folder, check_set, write_set, Claim, FolderError};
use crate::mesh::{polygon_area, PlaneMesh, Point2, Point3, SolidMesh};
use crate::quality::{jf_stats, mesh_quality, scaled_jacobian, JfStats, MeshQuality, Range};
use crate::render::{ColourMap, gif_bytes, png_bytes, render_hexes, render_quads, Camera, ClipPlane, RenderError, RenderOptions, RenderOptions3};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Errors of a run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The case is unusable.
    #[error(transparent)]
    Case(#[from] CaseError),
    /// Algorithm 1 failed.
    #[error(transparent)]
    Deform(#[from] DeformError),
    /// The finished mesh has invalid cells (never written as if fine).
    #[error("the deformed mesh has {} invalid cell(s): {:?}", .0.len(), &.0[..(.0.len().min(20))])]
    Invalid(Vec<usize>),
    /// Curved elements whose det J is not certified positive.
    #[error("the curved mesh of order {order} has {} element(s) not certified valid (det J not positive over the whole element): {:?}; certified min det J {min_det:.3e}", cells.len(), &cells[..(cells.len().min(20))])]
    InvalidCurved {
        /// The order.
        order: usize,
        /// The elements.
        cells: Vec<usize>,
        /// The certified lower bound of det J.
        min_det: f64,
    },
    /// Algorithms 2 and 3 failed.
    #[error(transparent)]
    Curve(#[from] CurveError),
    /// Elements of an input file that are, or became, invalid.
    #[error("{what}: {} element(s), by their tags in the file: {:?}", tags.len(), &tags[..tags.len().min(20)])]
    Elements {
        /// What is wrong with them.
        what: String,
        /// Their element tags in the input file.
        tags: Vec<u64>,
    },
    /// No candidate of `curve` was certified valid: the snap left these
    /// elements invalid and no run of Algorithm 2 (on patches around them
    /// or the whole mesh) ended with them valid.
    #[error("no result certified valid for {} element(s), by their tags in the file {:?}: {why}", tags.len(), &tags[..tags.len().min(20)])]
    Unrepaired {
        /// What was tried and how each ended.
        why: String,
        /// Their element tags in the input file.
        tags: Vec<u64>,
    },
    /// The run's stop request ([`stop_on`]) was set (the Python package's Ctrl-C): the run
    /// ended before writing anything.
    #[error("interrupted: nothing was written or changed")]
    Interrupted,
    /// A picture failed.
    #[error("drawing the picture failed")]
    Render(#[from] RenderError),
    /// A writer failed.
    #[error(transparent)]
    Msh(#[from] MshError),
    /// A writer failed.
    #[error(transparent)]
    Vtu(#[from] VtuError),
    /// The MFEM writer refused the mesh.
    #[error(transparent)]
    Mfem(#[from] crate::io::mfem::MfemError),
    /// The ABAQUS writer refused the mesh.
    #[error(transparent)]
    Abaqus(#[from] crate::io::abaqus::AbaqusError),
    /// An input file could not be read.
    #[error("cannot read `{}`: {cause}", path.display())]
    Read {
        /// The path.
        path: PathBuf,
        /// The cause (named so, not `source`, so it is printed once).
        cause: std::io::Error,
    },
    /// The output folder cannot take the files.
    #[error(transparent)]
    Folder(#[from] FolderError),
    /// What the input file holds cannot all be kept in the output.
    #[error("{0}: nothing was written")]
    Layout(#[from] crate::io::layout::LayoutError),
    /// New nodes of a periodic slave put at their masters' images leave a
    /// curved group's shape.
    #[error(
        "periodic links: the new nodes of the slave sides, put at the images of their masters' nodes, lie {distance:.3e} off the shape of group `{group}` \
         (it was {before:.3e}, and {allowed:.1e} more is allowed): the two sides of a link are bound to shapes that are not images of each other. Bind them to shapes that are, or leave both out of the geometry file: nothing was written"
    )]
    PeriodicOffShape {
        /// The group.
        group: String,
        /// Its nodes' largest distance from its shape after the move.
        distance: f64,
        /// Before it.
        before: f64,
        /// How much farther they may be (1e-12 of the mesh's extent).
        allowed: f64,
    },
    /// The CAD model cannot be read, or Gmsh's library is absent.
    #[error(transparent)]
    Cad(#[from] crate::geometry::cad::CadError),
    /// The run needs more memory than the process may have: refused
    /// before anything is computed.
    #[error("this run needs about {} of memory ({what}), more than {} leaves ({} free): nothing was computed or written. {advice}", crate::app::memory::shown(*need), room.what, crate::app::memory::shown(room.bytes))]
    Memory {
        /// The estimate.
        need: u64,
        /// What it was estimated for.
        what: String,
        /// What the process may allocate.
        room: crate::app::memory::Headroom,
        /// What would fit.
        advice: String,
    },
    /// The input holds what `curve` cannot carry to its output (the CLI
    /// names the file).
    #[error("{why}")]
    Unkept {
        /// The input.
        path: PathBuf,
        /// What and what to do.
        why: String,
    },
}

/// The process exit codes, one meaning each (README, `--help`).
pub mod exit {
    /// Success: every output written.
    pub const OK: i32 = 0;
    /// Bad input: a file, field or argument value the message names.
    pub const BAD_INPUT: i32 = 1;
    /// The mesh is, or would become, invalid (the elements are named;
    /// nothing is written).
    pub const INVALID_MESH: i32 = 2;
    /// A linear solve failed (the solver, not the input), or a run of the
    /// method ended without reaching t = 1 (its steps stalled or spent
    /// their budget) and no other candidate was valid; nothing written.
    pub const SOLVER: i32 = 3;
    /// A library the command needs is absent (Gmsh's, for `--cad`):
    /// BSD's EX_UNAVAILABLE.
    pub const UNAVAILABLE: i32 = 69;
    /// The run needs more memory than it may have (the estimate, said
    /// before computing, or an allocation that failed): nothing is written.
    pub const MEMORY: i32 = 4;
    /// An output would replace a file that no run of this tool wrote (or
    /// that changed since): nothing is written; `--force` replaces it.
    /// BSD's EX_CANTCREAT.
    pub const NOT_OURS: i32 = 73;
    /// Writing the outputs failed in the file system (a full disk, a
    /// quota, an I/O error): nothing is written, nothing staged is left.
    /// BSD's EX_IOERR.
    pub const WRITE: i32 = 74;
    /// The command line itself is wrong (unknown option, missing or
    /// unparsable argument): BSD's EX_USAGE.
    pub const USAGE: i32 = 64;
    /// Interrupted by a signal: 128 + its number (130 for Ctrl-C).
    pub const SIGNAL_BASE: i32 = 128;
}

impl RunError {
    /// The process exit code ([`exit`]).
    pub fn exit_code(&self) -> i32 {
        match self {
            RunError::Invalid(_)
            | RunError::InvalidCurved { .. }
            | RunError::Elements { .. }
            | RunError::Deform(DeformError::Tangled { .. })
            | RunError::Deform(DeformError::InvalidStart(_))
            | RunError::Curve(CurveError::InvalidCoarse(_))
            | RunError::Curve(CurveError::Deform(DeformError::Tangled { .. })) => exit::INVALID_MESH,
            RunError::Deform(DeformError::Solve(_) | DeformError::Stalled { .. })
            | RunError::Curve(CurveError::Deform(DeformError::Solve(_) | DeformError::Stalled { .. }) | CurveError::NoCandidate { .. })
            | RunError::Unrepaired { .. } => exit::SOLVER,
            RunError::Cad(crate::geometry::cad::CadError::Absent { .. } | crate::geometry::cad::CadError::Library { .. }) => exit::UNAVAILABLE,
            RunError::Memory { .. } => exit::MEMORY,
            RunError::Interrupted => exit::SIGNAL_BASE + 2,
            RunError::Folder(FolderError::NotWritten { .. }) => exit::NOT_OURS,
            RunError::Folder(FolderError::IsInput { .. }) => exit::USAGE,
            RunError::Folder(f) if f.is_write_failure() => exit::WRITE,
            _ => exit::BAD_INPUT,
        }
    }
}

/// Progress of a run, for a bar or log lines.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// Which algorithm is running: 1 (the deformation) or 2 (the
    /// high-order boundary nodes).
    pub algorithm: u8,
    /// Pseudo-time reached.
    pub t: f64,
    /// Accepted steps.
    pub steps: usize,
    /// Halved steps so far.
    pub halved: usize,
    /// CG iterations of the last solve (0 for a direct solver).
    pub iterations: usize,
}

/// Seconds spent, by phase.
#[derive(Clone, Debug, Serialize)]
pub struct Timings {
    /// Assembly and normalisation, all steps.
    pub assembly_s: f64,
    /// Symbolic analysis (once).
    pub analyze_s: f64,
    /// Numeric factorisation, all steps.
    pub factor_s: f64,
    /// Triangular solves, all steps.
    pub solve_s: f64,
    /// Whole run, outputs included.
    pub total_s: f64,
    /// Peak resident memory of the process when the report was written,
    /// in MiB (Linux's VmHWM; null elsewhere).
    pub peak_memory_mib: Option<f64>,
}

/// `report.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Case name.
    pub case: String,
    /// 2 for quads, 3 for hexes.
    pub dimension: usize,
    /// Cells.
    pub cells: usize,
    /// Nodes.
    pub nodes: usize,
    /// Free unknowns of the LSFEM system.
    pub unknowns: usize,
    /// Integrator.
    pub integrator: Integrator,
    /// Nominal steps asked for.
    pub nominal_steps: usize,
    /// Accepted steps.
    pub steps: usize,
    /// Steps retried with half the step.
    pub halved_steps: usize,
    /// LSFEM solves.
    pub solves: usize,
    /// Validity and shape.
    pub quality: MeshQuality,
    /// What det J and the scaled Jacobian mean.
    pub definitions: Definitions,
    /// Number of invalid cells.
    pub invalid_cells: usize,
    /// J/f over cells.
    pub jf: JfStats,
    /// Max distance of nodes of moving parts to their target shape.
    pub boundary_distance_max: f64,
    /// c(1): f = c g.
    pub normalisation_c: f64,
    /// Solver used.
    pub solver: String,
    /// Iterations and times of Algorithm 1's solves.
    pub solves_detail: SolverReport,
    /// Algorithms 2 and 3, when asked for.
    pub highorder: Option<HighOrderReport>,
    /// Seconds.
    pub time: Timings,
    /// Files written. The report file also records each one's size and
    /// FNV-1a hash (`written`, with the files of other outputs in the
    /// folder still as an earlier run wrote them): a rerun replaces or
    /// removes only those ([`crate::io::folder`]).
    pub outputs: Vec<String>,
}

/// The figures of Algorithms 2 and 3.
#[derive(Clone, Debug, Serialize)]
pub struct HighOrderReport {
    /// Validity and geometry of the curved mesh.
    pub quality: CurvedQuality,
    /// Node spacing in the elements.
    pub spacing: Spacing,
    /// Accepted steps of Algorithm 2.
    pub steps: usize,
    /// Halved steps of Algorithm 2.
    pub halved_steps: usize,
    /// Seconds of Algorithm 1 (without outputs), Algorithm 2, certification.
    pub algorithm1_s: f64,
    /// Algorithm 2's linear solves.
    pub solver: SolverReport,
    /// Seconds of Algorithm 2 (subdivision and flow).
    pub algorithm2_s: f64,
    /// Seconds of the Bézier certification of every element.
    pub certify_s: f64,
    /// What the figures mean.
    pub definitions: &'static str,
}

/// Definitions printed with the figures.
#[derive(Clone, Debug, Serialize)]
pub struct Definitions {
    /// det J.
    pub det_j: &'static str,
    /// Scaled Jacobian.
    pub scaled_jacobian: &'static str,
    /// J/f.
    pub jf: &'static str,
}

/// What `curve` needs of a kind of linear mesh: Algorithms 2 and 3 on it,
/// and the picture of the result.
pub trait Curvable<const D: usize> {
    /// Algorithms 2 and 3 on this mesh, reporting Algorithm 2's progress.
    fn curve(&self, parts: &[BoundaryPart<D>], opts: &CurveOptions, progress: &mut dyn FnMut(Progress)) -> Result<Curved<D>, CurveError>;
    /// A picture of a curved mesh, elements coloured by `values`.
    fn draw_curved(mesh: &CurvedMesh<D>, values: &[f64], look: &Look<D>) -> Result<tiny_skia::Pixmap, RenderError>;
}

/// What a kind of mesh writes and draws: the per-dimension end of a run.
pub trait Outputs<const D: usize, const N: usize>: Q1Mesh<D, N> + Curvable<D> {
    /// What the figures mean.
    const DEFINITIONS: Definitions;
    /// Validity and shape figures.
    fn quality(&self) -> MeshQuality;
    /// Per-cell scaled Jacobians.
    fn scaled_jacobians(&self) -> Vec<f64>;
    /// [`Outputs::quality`] and [`Outputs::scaled_jacobians`] together
    /// (one certification where both come from it).
    fn quality_and_scaled_jacobians(&self) -> (MeshQuality, Vec<f64>) {
        (self.quality(), self.scaled_jacobians())
    }
    /// Per-cell size at positions `nodes`.
    fn cell_sizes(&self, nodes: &[[f64; D]]) -> Vec<f64>;
    /// The MSH 4.1 text.
    fn msh(&self) -> Result<String, MshError>;
    /// The VTU text with cell data.
    fn vtu(&self, cell_data: &[(&str, &[f64])]) -> Result<String, VtuError>;
    /// A picture of the mesh at positions `nodes`, cells coloured by
    /// `values` (one per written cell).
    fn draw(&self, nodes: &[[f64; D]], values: &[f64], look: &Look<D>) -> Result<tiny_skia::Pixmap, RenderError>;
    /// Per written cell, from per-cell ratios of the current size to an
    /// additive measure (J/f, a size ratio) on Algorithm 1's cells at
    /// positions `nodes`: the same cells, but for meshes of several kinds
    /// cut into simplices ([`Cut`]).
    fn written_ratios(&self, _nodes: &[[f64; D]], values: &[f64]) -> Vec<f64> {
        values.to_vec()
    }
    /// Per written cell, from additive per-cell values (sizes) on
    /// Algorithm 1's cells.
    fn written_sums(&self, values: &[f64]) -> Vec<f64> {
        values.to_vec()
    }
}

/// What every picture of one run shares, and its title and width.
pub struct Look<'a, const D: usize> {
    /// The world box around every frame.
    pub bounds: ([f64; D], [f64; D]),
    /// The colour range.
    pub range: (f64, f64),
    /// Title.
    pub title: String,
    /// Width in pixels.
    pub width: u32,
    /// What the colours show, above the colour bar.
    pub label: &'static str,
    /// The colour map (automatic when `None`).
    pub colour_map: Option<ColourMap>,
    /// The case's output options (3D camera and clip).
    pub output: &'a OutputSpec,
}

/// Quads and triangles share the plane's outputs; only the words of the
/// figures differ.
impl<const N: usize> Outputs<2, N> for PlaneMesh<N> {
    const DEFINITIONS: Definitions = if N == 3 {
        Definitions {
            det_j: "determinant of the linear map from the reference triangle (0,0),(1,0),(0,1), constant on a cell (Gmsh's reference triangle is the same)",
            scaled_jacobian: "per cell, Gmsh's minSIGE: (2/sqrt 3) det J times the mean of 1/(|ei||ej|) over the edge pairs, the mean corner sine over sin 60 degrees: 1 for the equilateral triangle",
            jf: "per cell, |K_t| / integral over K_0 of f(phi(xi)) dxi (3-point rule, exact for quadratic f); 1 is perfect",
        }
    } else {
        Definitions {
            det_j: "determinant of the bilinear map from the reference square [0,1]^2, at cell corners (Gmsh's [-1,1]^2 gives 1/4 of it)",
            scaled_jacobian: "per cell, min over corners of det J/(|e1||e2|), the sine of the corner angle",
            jf: "per cell, |K_t| / integral over K_0 of f(phi(xi)) dxi (2x2 Gauss); 1 is perfect",
        }
    };
    fn quality(&self) -> MeshQuality {
        mesh_quality(self)
    }
    fn scaled_jacobians(&self) -> Vec<f64> {
        (0..self.num_cells()).map(|c| scaled_jacobian(&self.cell_coords(c))).collect()
    }
    fn cell_sizes(&self, nodes: &[Point2]) -> Vec<f64> {
        self.cells.iter().map(|c| polygon_area(&c.map(|n| nodes[n]))).collect()
    }
    fn msh(&self) -> Result<String, MshError> {
        Ok(msh_string(self))
    }
    fn vtu(&self, cell_data: &[(&str, &[f64])]) -> Result<String, VtuError> {
        vtu_string(self, cell_data, &[])
    }
    fn draw(&self, nodes: &[Point2], values: &[f64], look: &Look<2>) -> Result<tiny_skia::Pixmap, RenderError> {
        Self::draw_curved(&CurvedMesh { nodes: nodes.to_vec(), ..CurvedMesh::from_quads(self) }, values, look)
    }
}

impl<const N: usize> Curvable<2> for PlaneMesh<N> {
    fn curve(&self, parts: &[BoundaryPart<2>], opts: &CurveOptions, progress: &mut dyn FnMut(Progress)) -> Result<Curved<2>, CurveError> {
        curve_with_progress(self, parts, opts, algorithm2(progress))
    }
    fn draw_curved(mesh: &CurvedMesh<2>, values: &[f64], look: &Look<2>) -> Result<tiny_skia::Pixmap, RenderError> {
        draw_plane(mesh, values, look)
    }
}

/// Quads and triangles together, the linear mesh of order 1 (Algorithm 1
/// moves them as a [`Cut`]).
impl Curvable<2> for CurvedMesh<2> {
    fn curve(&self, parts: &[BoundaryPart<2>], opts: &CurveOptions, progress: &mut dyn FnMut(Progress)) -> Result<Curved<2>, CurveError> {
        crate::highorder::curve::curve_mixed(self, parts, opts, algorithm2(progress))
    }
    fn draw_curved(mesh: &CurvedMesh<2>, values: &[f64], look: &Look<2>) -> Result<tiny_skia::Pixmap, RenderError> {
        draw_plane(mesh, values, look)
    }
}

/// Algorithm 2's progress as the run's.
fn algorithm2(progress: &mut dyn FnMut(Progress)) -> impl FnMut(f64, &crate::deform::RunStats) + '_ {
    |t, s| progress(Progress { algorithm: 2, t, steps: s.steps, halved: s.halved, iterations: s.last_iterations })
}

/// The picture of a plane curved mesh.
fn draw_plane(mesh: &CurvedMesh<2>, values: &[f64], look: &Look<2>) -> Result<tiny_skia::Pixmap, RenderError> {
    let opts = RenderOptions { width: look.width, bounds: Some(look.bounds), range: Some(look.range), title: Some(look.title.clone()), label: look.label.to_string(), colour_map: look.colour_map, ..Default::default() };
    render_quads(mesh, values, &opts)
}

/// Hexes and tetrahedra share the solid outputs; only the words of the
/// figures differ.
impl<const N: usize, const K: usize> Outputs<3, N> for SolidMesh<N, K>
where
    SolidMesh<N, K>: Q1Mesh<3, N> + Subdividable<3, N>,
{
    const DEFINITIONS: Definitions = if N == 4 {
        Definitions {
            det_j: "determinant of the linear map from the reference tetrahedron (0,0,0),(1,0,0),(0,1,0),(0,0,1), constant on a cell (Gmsh's reference is the same)",
            scaled_jacobian: "per cell, Gmsh's minSIGE: sqrt 2 det J times the mean of 1/(|ea||eb||ec|) over the 12 triples of two opposite edges and one other: 1 for the regular tetrahedron",
            jf: "per cell, |K_t| / integral over K_0 of f(phi(xi)) dxi (4-point rule, exact for quadratic f); 1 is perfect",
        }
    } else {
        Definitions {
            det_j: "determinant of the trilinear map from the reference cube [0,1]^3, bounded by its Bezier coefficients (Gmsh's [-1,1]^3 gives 1/8 of it)",
            scaled_jacobian: "per cell, Verdict's hex scaled Jacobian: min over corners (and centre axes) of the triple product of unit edge vectors",
            jf: "per cell, |K_t| / integral over K_0 of f(phi(xi)) dxi (2x2x2 Gauss); 1 is perfect",
        }
    };
    fn quality(&self) -> MeshQuality {
        crate::quality::solid_mesh_quality(self)
    }
    fn scaled_jacobians(&self) -> Vec<f64> {
        (0..self.num_cells()).map(|c| crate::quality::solid_scaled_jacobian(&self.cell_coords(c))).collect()
    }
    fn cell_sizes(&self, nodes: &[Point3]) -> Vec<f64> {
        self.cells.iter().map(|c| crate::quality::cell_size(&c.map(|n| nodes[n]))).collect()
    }
    fn msh(&self) -> Result<String, MshError> {
        Ok(hex_msh_string(self))
    }
    fn vtu(&self, cell_data: &[(&str, &[f64])]) -> Result<String, VtuError> {
        hex_vtu_string(self, cell_data, &[])
    }
    fn draw(&self, nodes: &[Point3], values: &[f64], look: &Look<3>) -> Result<tiny_skia::Pixmap, RenderError> {
        Self::draw_curved(&CurvedMesh { nodes: nodes.to_vec(), ..CurvedMesh::from_hexes(self) }, values, look)
    }
}

impl<const N: usize, const K: usize> Curvable<3> for SolidMesh<N, K>
where
    SolidMesh<N, K>: Q1Mesh<3, N> + Subdividable<3, N>,
{
    fn curve(&self, parts: &[BoundaryPart<3>], opts: &CurveOptions, progress: &mut dyn FnMut(Progress)) -> Result<Curved<3>, CurveError> {
        curve_with_progress(self, parts, opts, algorithm2(progress))
    }
    fn draw_curved(mesh: &CurvedMesh<3>, values: &[f64], look: &Look<3>) -> Result<tiny_skia::Pixmap, RenderError> {
        render_hexes(mesh, values, &options3(look))
    }
}

/// The 3D render options of a look.
fn options3(look: &Look<3>) -> RenderOptions3 {
    let mut opts = RenderOptions3 { width: look.width, bounds: Some(look.bounds), range: Some(look.range), title: Some(look.title.clone()), label: look.label.to_string(), colour_map: look.colour_map, ..Default::default() };
    if let Some(c) = look.output.camera {
        opts.camera = Camera { azimuth_deg: c.azimuth, elevation_deg: c.elevation, distance: c.distance };
    }
    opts.clip = look.output.clip.map(|c| ClipPlane { point: c.point, normal: c.normal });
    opts
}

/// The report of `deformesh run`; its `outputs` list tells a rerun into the
/// same folder which files are an earlier run's.
pub const REPORT: &str = "report.json";

/// Runs a prepared 2D or 3D case; writes into `out_dir` only on success.
pub fn run_any(setup: AnySetup, out_dir: &Path, progress: impl FnMut(Progress)) -> Result<Report, RunError> {
    run_any_with(setup, out_dir, false, progress)
}

/// [`run_any`], with `force` (`--force`): files in `out_dir` of the
/// outputs' names that no run of ours wrote are replaced.
pub fn run_any_with(setup: AnySetup, out_dir: &Path, force: bool, progress: impl FnMut(Progress)) -> Result<Report, RunError> {
    match setup {
        AnySetup::Quad(s) => run_setup_with(s, out_dir, force, progress),
        AnySetup::Tri(s) => run_setup_with(s, out_dir, force, progress),
        AnySetup::Hex(s) => run_setup_with(s, out_dir, force, progress),
        AnySetup::Tet(s) => run_setup_with(s, out_dir, force, progress),
        AnySetup::Cut(s) => run_setup_with(s, out_dir, force, progress),
        AnySetup::CutPlane(s) => run_setup_with(s, out_dir, force, progress),
    }
}

/// The files a run with `output` (and high order or not) may write into
/// its folder, its report last: checked before computing.
fn run_names(output: &OutputSpec, highorder: bool) -> Vec<String> {
    let mut names: Vec<String> = ["mesh.msh", "mesh.vtu", "mesh.png"].map(String::from).to_vec();
    if highorder {
        names.extend(["linear.msh", "linear.vtu", "linear.png"].map(String::from));
    }
    names.extend(output.frames.iter().map(|t| format!("frame_t{t:.2}.png")));
    if output.animation {
        names.push("deformation.gif".into());
    }
    names.push(REPORT.into());
    names
}

/// The claim of `run` on its folder: one output (`mesh.msh`), replacing
/// what an earlier run wrote.
fn run_claim(force: bool) -> Claim {
    Claim { output: "mesh.msh".into(), inputs: Vec::new(), force }
}

/// Runs a prepared case; writes into `out_dir` only on success.
pub fn run_setup<M: Outputs<D, N>, const D: usize, const N: usize>(setup: Setup<M, D>, out_dir: &Path, progress: impl FnMut(Progress)) -> Result<Report, RunError> {
    run_setup_with(setup, out_dir, false, progress)
}

/// [`run_setup`], with `force`: over files no run of ours wrote.
pub fn run_setup_with<M: Outputs<D, N>, const D: usize, const N: usize>(
    setup: Setup<M, D>,
    out_dir: &Path,
    force: bool,
    mut progress: impl FnMut(Progress),
) -> Result<Report, RunError> {
    let clock = Instant::now();
    check_run_folder(out_dir, REPORT, force)?;
    check_set(out_dir, &run_names(&setup.output, setup.highorder.is_some()), REPORT, &run_claim(force))?;
    let Setup { name, mesh, parts, field, options, output, highorder } = setup;
    let nominal_steps = options.steps;
    let integrator = options.integrator;
    let mut def = Deformation::<M, D, N>::new(mesh, parts, field, options)?;
    // frames are drawn at the end, when the box around all of them is known
    let every = (nominal_steps / 40).max(1);
    let start_sizes = mesh_start_sizes(&def);
    let colour = output.colour;
    // per written cell
    let values = |d: &Deformation<M, D, N>| -> Result<Vec<f64>, DeformError> {
        let per_cell = match colour {
            Colour::Jf => d.jf_now()?,
            Colour::Size => d.mesh.cell_sizes(d.mesh.nodes()).iter().zip(&start_sizes).map(|(a, a0)| a / a0).collect(),
        };
        Ok(d.mesh.written_ratios(d.mesh.nodes(), &per_cell))
    };
    let snapshot = |d: &Deformation<M, D, N>| (d.t, d.mesh.nodes().to_vec(), values(d));
    let mut stills = Vec::new();
    let mut anim = if output.animation { vec![snapshot(&def)] } else { Vec::new() };
    def.run(
        &output.frames,
        |d| stills.push(snapshot(d)),
        |d| {
            if output.animation && (d.stats.steps % every == 0 || d.t >= 1.0) {
                anim.push(snapshot(d));
            }
            progress(Progress { algorithm: 1, t: d.t, steps: d.stats.steps, halved: d.stats.halved, iterations: d.stats.last_iterations });
        },
    )?;
    let (quality, scaled) = def.mesh.quality_and_scaled_jacobians();
    if !quality.invalid_cells.is_empty() {
        return Err(RunError::Invalid(quality.invalid_cells));
    }
    let algorithm1_s = clock.elapsed().as_secs_f64();
    let curved = match &highorder {
        Some(opts) => {
            let c = def.mesh.curve(def.parts(), opts, &mut progress)?;
            if !c.quality.invalid_elements.is_empty() {
                return Err(RunError::InvalidCurved { order: opts.order, cells: c.quality.invalid_elements.clone(), min_det: c.quality.min_det_j });
            }
            Some(c)
        }
        None => None,
    };
    let norm = def.normalisation_now()?;
    let ratios = def.jf_now()?;
    let jf = jf_stats(&ratios, &start_sizes);
    let shown = values(&def)?;
    let boundary_distance_max = def.boundary_distances().iter().map(|d| d.1).fold(0.0, f64::max);

    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    // with high order, mesh.* is the curved mesh and linear.* Algorithm 1's
    let linear = if curved.is_some() { "linear" } else { "mesh" };
    files.push((format!("{linear}.msh"), def.mesh.msh()?.into_bytes()));
    let cell_ratios = def.mesh.written_ratios(def.mesh.nodes(), &ratios);
    let vtu = def.mesh.vtu(&[("J/f", &cell_ratios), ("scaled_jacobian", &scaled), ("start_size", &def.mesh.written_sums(&start_sizes))])?;
    files.push((format!("{linear}.vtu"), vtu.into_bytes()));
    if let Some(c) = &curved {
        files.push(("mesh.msh".into(), c.mesh.msh_string()?.into_bytes()));
        let min_det: Vec<f64> = c.certificates.iter().map(|x| x.min_det_lower).collect();
        let sj: Vec<f64> = c.certificates.iter().map(|x| x.min_scaled_jacobian).collect();
        // VTK has no cell for a curved pyramid: the report's `outputs`
        // say what was written
        if crate::io::vtu::vtk_can_hold(&c.mesh) {
            let vtu = c.mesh.vtu_string(&[("J/f", &cell_ratios), ("min_det_j", &min_det), ("min_scaled_jacobian", &sj)])?;
            files.push(("mesh.vtu".into(), vtu.into_bytes()));
        } else {
            tracing::info!("{}", crate::io::vtu::VtuError::NoPyramidCell(c.mesh.p));
        }
    }
    let node_sets = [def.start.as_slice(), def.mesh.nodes()].into_iter().chain(stills.iter().chain(&anim).map(|s| s.1.as_slice()));
    let bounds = frame_bounds(node_sets);
    let range = match colour {
        Colour::Jf => symmetric_range(&ratios),
        Colour::Size => {
            let r = Range::of(stills.iter().chain(&anim).filter_map(|s| s.2.as_ref().ok()).flatten().chain(&shown).copied());
            (r.min, r.max)
        }
    };
    let label = colour.label();
    // sizes read best on a sequential map: the smallest cells darkest
    let colour_map = (colour == Colour::Size).then_some(ColourMap::Sequential);
    let look = |title: String, width: u32| Look { bounds, range, title, width, label, colour_map, output: &output };
    let main_picture = def.mesh.draw(def.mesh.nodes(), &shown, &look(format!("{name}: {label} at t = 1"), output.width))?;
    match &curved {
        Some(c) => {
            files.push(("linear.png".into(), png_bytes(&main_picture)?));
            let picture = M::draw_curved(&c.mesh, &shown, &look(format!("{name}: order {} elements, {label}", c.mesh.p), output.width))?;
            files.push(("mesh.png".into(), png_bytes(&picture)?));
        }
        None => files.push(("mesh.png".into(), png_bytes(&main_picture)?)),
    }
    for (t, nodes, values) in stills {
        let picture = def.mesh.draw(&nodes, &values?, &look(format!("t = {t:.2}"), output.width))?;
        files.push((format!("frame_t{t:.2}.png"), png_bytes(&picture)?));
    }
    if output.animation {
        let frames = anim
            .into_iter()
            .map(|(t, nodes, values)| Ok(def.mesh.draw(&nodes, &values?, &look(format!("t = {t:.2}"), output.width.min(640)))?))
            .collect::<Result<Vec<_>, RunError>>()?;
        files.push(("deformation.gif".into(), gif_bytes(&frames, 8)?));
    }

    let stats = def.stats.clone();
    let mut report = Report {
        case: name,
        dimension: D,
        cells: quality.cells,
        nodes: quality.nodes,
        unknowns: def.num_unknowns(),
        integrator,
        nominal_steps,
        steps: stats.steps,
        halved_steps: stats.halved,
        solves: stats.solves,
        invalid_cells: quality.invalid_cells.len(),
        quality,
        definitions: M::DEFINITIONS,
        jf,
        boundary_distance_max,
        normalisation_c: norm.c,
        solver: def.solver_name().to_string(),
        solves_detail: def.solver_report(),
        highorder: curved.as_ref().map(|c| HighOrderReport {
            quality: c.quality.clone(),
            spacing: c.mesh.spacing,
            steps: c.stats.steps,
            halved_steps: c.stats.halved,
            algorithm1_s,
            solver: c.solver.clone(),
            algorithm2_s: c.seconds.0,
            certify_s: c.seconds.1,
            definitions: "det J of the order-p Lagrange map from the reference [0,1]^d (Gmsh's [-1,1]^d gives 2^-d of it): min_det_j is a certified lower bound from Bezier coefficients with subdivision, min_det_j_attained a value det J takes; scaled Jacobian det J/(product of column norms of J), per element its minimum on a (3p+1)^d grid; boundary distances to the exact shapes of moving (and curved slip) parts, at the nodes and at samples of the curved boundary",
        }),
        time: Timings { assembly_s: stats.assembly.as_secs_f64(), analyze_s: stats.analyze.as_secs_f64(), factor_s: stats.factor.as_secs_f64(), solve_s: stats.solve.as_secs_f64(), total_s: 0.0, peak_memory_mib: None },
        outputs: files.iter().map(|f| f.0.clone()).chain(std::iter::once(REPORT.to_string())).collect(),
    };
    report.time.total_s = clock.elapsed().as_secs_f64();
    report.time.peak_memory_mib = super::bench::peak_memory_mib();
    if stop_requested() {
        return Err(RunError::Interrupted);
    }
    write_set(out_dir, &files, REPORT, serde_json::to_value(&report).expect("report serialises"), &run_claim(force))?;
    Ok(report)
}

/// The starting cell sizes of a run.
fn mesh_start_sizes<M: Outputs<D, N>, const D: usize, const N: usize>(d: &Deformation<M, D, N>) -> Vec<f64> {
    d.mesh.cell_sizes(&d.start)
}

/// A colour range for J/f symmetric about 1, so 1 is white.
fn symmetric_range(values: &[f64]) -> (f64, f64) {
    let r = Range::of(values.iter().copied());
    let d = (1.0 - r.min).max(r.max - 1.0).max(1e-3);
    (1.0 - d, 1.0 + d)
}

/// The box around all node sets, so frames align.
fn frame_bounds<'a, const D: usize>(sets: impl Iterator<Item = &'a [[f64; D]]>) -> ([f64; D], [f64; D]) {
    let mut lo = [f64::INFINITY; D];
    let mut hi = [f64::NEG_INFINITY; D];
    for p in sets.flatten() {
        for k in 0..D {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// Where `curve` puts the curved mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sink {
    /// The job's files (the mesh, its VTU, PNG and report), whole or not
    /// at all.
    Files,
    /// Nowhere: the curved layout is returned in
    /// [`CurveReport::curved`] (the Python package's live Gmsh model).
    Memory,
}

thread_local! {
    /// This thread's stop request ([`stop_on`]), if it has one.
    static STOP: std::cell::RefCell<Option<std::sync::Arc<std::sync::atomic::AtomicBool>>> = const { std::cell::RefCell::new(None) };
}

/// Makes `token` the stop request of the runs on this thread: once it is
/// set they end before they write anything ([`RunError::Interrupted`]).
/// The Python package's Ctrl-C, which must leave files and models as they
/// were; a token per job, so that one caller's Ctrl-C stops its own job
/// only. The command line's Ctrl-C is a signal handler of its own
/// ([`crate::io::folder::install_interrupt_handler`]).
pub fn stop_on(token: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>) {
    STOP.with(|s| *s.borrow_mut() = token);
}

/// Whether this thread's stop request ([`stop_on`]) is set.
pub fn stop_requested() -> bool {
    STOP.with(|s| s.borrow().as_ref().is_some_and(|t| t.load(std::sync::atomic::Ordering::SeqCst)))
}

/// What `deformesh curve` is asked to do.
#[derive(Clone, Debug)]
pub struct CurveJob {
    /// The linear quad or hex mesh (MSH 4.1).
    pub input: PathBuf,
    /// The geometry file binding its groups to shapes (with `cad`, it may
    /// override groups: `slip`, `fixed`, another shape).
    pub geometry: Option<PathBuf>,
    /// The CAD model whose entities the mesh's boundary entities are
    /// bound to by tag.
    pub cad: Option<CadSource>,
    /// The curved mesh to write; the VTU, PNG and report go beside it
    /// under the same stem.
    pub output: PathBuf,
    /// Its format ([`OutputFormat::choose`]).
    pub format: OutputFormat,
    /// Algorithms 2 and 3.
    pub options: CurveOptions,
    /// Picture width in pixels.
    pub width: u32,
    /// `--force`: files of the outputs' names that no run of ours wrote
    /// are replaced (never an input).
    pub force: bool,
}

impl CurveJob {
    /// The folder of the outputs, their stem, the report's name, and the
    /// claim on the folder: the output is the main file's name; the
    /// input mesh, the geometry file and the CAD model are never replaced.
    fn destination(&self) -> (PathBuf, String, String, Claim) {
        let stem = self.output.file_stem().map_or("curved".into(), |s| s.to_string_lossy().into_owned());
        let dir = self.output.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf();
        let name = self.output.file_name().map_or_else(|| format!("{stem}.{}", self.format.extension()), |n| n.to_string_lossy().into_owned());
        let mut inputs = vec![(self.input.clone(), "the input mesh".to_string())];
        inputs.extend(self.geometry.iter().map(|g| (g.clone(), "the geometry file".to_string())));
        inputs.extend(self.cad.iter().map(|c| (c.model.clone(), "the CAD model".to_string())));
        let report = format!("{stem}.report.json");
        (dir, stem, report, Claim { output: name, inputs, force: self.force })
    }

    /// Every file the outputs may be (the VTU is left out for curved
    /// pyramids), the report last.
    fn output_names(&self) -> Vec<String> {
        let (_, stem, report, claim) = self.destination();
        vec![claim.output, format!("{stem}.vtu"), format!("{stem}.png"), report]
    }
}

/// Where `curve --cad` finds its model and Gmsh.
#[derive(Clone, Debug)]
pub struct CadSource {
    /// The STEP, IGES, BREP, XAO or `.geo` file.
    pub model: PathBuf,
    /// Gmsh's library (a file or a folder), before the search of
    /// [`crate::geometry::cad`]'s loader.
    pub library: Option<PathBuf>,
    /// The factor the model's coordinates are multiplied by (a model in
    /// other units than the mesh's; `--cad-scale`), 1 if none.
    pub scale: f64,
}

/// The CAD model of a `curve --cad` run, for its report.
#[derive(Clone, Debug, Serialize)]
pub struct CadReport {
    /// The model file.
    pub model: String,
    /// The Gmsh library that read it.
    pub library: String,
    /// Its version.
    pub gmsh_version: String,
    /// The factor its coordinates were multiplied by (`--cad-scale`).
    pub scale: f64,
    /// Per entity of the mesh, the model's entities it was bound to.
    pub bound: Vec<crate::app::cad::Bound>,
}

/// A `curve` job, the input's layout, and where the result goes.
type JobIn<'a> = (&'a CurveJob, &'a crate::io::layout::Layout, Sink);

/// How `curve` binds a mesh's boundary: a geometry file, a CAD model, or
/// both (the file then overrides groups).
struct Binding<'a> {
    geometry: Option<&'a crate::app::bind::GeometryFile>,
    gfile: &'a str,
    model: Option<&'a std::sync::Arc<crate::geometry::cad::CadModel>>,
}

/// The format of the curved mesh `curve` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OutputFormat {
    /// Gmsh MSH 4.1 ASCII (`.msh`).
    Msh41,
    /// Gmsh MSH 2.2 ASCII (`.msh` with `--format msh22`).
    Msh22,
    /// MFEM mesh v1.0 with high-order nodes (`.mesh`).
    Mfem,
    /// ABAQUS `.inp` as HOHQMesh writes it for Trixi.jl (`.inp`).
    Abaqus,
}

impl OutputFormat {
    /// The names `--format` takes.
    pub const NAMES: &'static str = "msh41, msh22, mfem or abaqus";

    /// The format of `output`: by `--format` if given (it must agree with
    /// the extension), else by the extension: `.msh` MSH 4.1, `.mesh`
    /// MFEM, `.inp` ABAQUS. Anything else is refused, naming the choices.
    pub fn choose(output: &Path, flag: Option<&str>) -> Result<OutputFormat, String> {
        let ext = output.extension().and_then(|e| e.to_str()).unwrap_or("");
        let by_ext = match ext.to_ascii_lowercase().as_str() {
            "msh" => Some(OutputFormat::Msh41),
            "mesh" => Some(OutputFormat::Mfem),
            "inp" => Some(OutputFormat::Abaqus),
            _ => None,
        };
        let by_flag = match flag {
            None => None,
            Some("msh41") => Some(OutputFormat::Msh41),
            Some("msh22") => Some(OutputFormat::Msh22),
            Some("mfem") => Some(OutputFormat::Mfem),
            Some("abaqus") => Some(OutputFormat::Abaqus),
            Some(other) => return Err(format!("--format must be {}, got `{other}`", Self::NAMES)),
        };
        let shown = if ext.is_empty() { "no extension".to_string() } else { format!("the extension `.{ext}`") };
        match (by_flag, by_ext) {
            (Some(f), Some(e)) if f.extension() != e.extension() => Err(format!("--format {} writes `.{}` files, but -o `{}` has {shown}", f.name(), f.extension(), output.display())),
            (Some(f), _) if by_ext.is_none() => Err(format!("-o `{}` has {shown}; --format {} writes `.{}` files: name the output so", output.display(), f.name(), f.extension())),
            (Some(f), _) | (None, Some(f)) => Ok(f),
            (None, None) => Err(format!(
                "-o `{}` has {shown}: the extension chooses the format: `.msh` (Gmsh MSH 4.1; MSH 2.2 with --format msh22), `.mesh` (MFEM), `.inp` (ABAQUS for Trixi.jl)",
                output.display()
            )),
        }
    }

    /// Its `--format` name.
    pub fn name(self) -> &'static str {
        match self {
            OutputFormat::Msh41 => "msh41",
            OutputFormat::Msh22 => "msh22",
            OutputFormat::Mfem => "mfem",
            OutputFormat::Abaqus => "abaqus",
        }
    }

    /// The extension of its files.
    pub fn extension(self) -> &'static str {
        match self {
            OutputFormat::Msh41 | OutputFormat::Msh22 => "msh",
            OutputFormat::Mfem => "mesh",
            OutputFormat::Abaqus => "inp",
        }
    }
}

/// `<stem>.report.json` of `deformesh curve`.
#[derive(Clone, Debug, Serialize)]
pub struct CurveReport {
    /// The input mesh.
    pub input: String,
    /// 2 or 3.
    pub dimension: usize,
    /// Linear input cells (= curved elements).
    pub cells: usize,
    /// Groups the geometry file does not name: their nodes stayed.
    pub unbound_groups: Vec<String>,
    /// The CAD model (`--cad`), if any.
    pub cad: Option<CadReport>,
    /// Clockwise input cells turned counter-clockwise (2D; the written
    /// mesh has them counter-clockwise).
    pub reoriented_cells: usize,
    /// Validity and geometry of the result.
    pub quality: CurvedQuality,
    /// The largest move of a new node of a periodic slave onto the image
    /// of its master (0 without periodic links).
    pub periodic_snap: f64,
    /// Node spacing.
    pub spacing: Spacing,
    /// Accepted and halved steps of Algorithm 2.
    pub steps: usize,
    /// Halved steps.
    pub halved_steps: usize,
    /// Runs of Algorithm 2: more than 1 when its first run, sliding with
    /// the fewest steps, left an element not certified valid: then with
    /// Dirichlet data, then shorter steps (see
    /// [`crate::highorder::curve::AUTO_STEPS`] and `quality.boundary_data`).
    pub algorithm2_runs: usize,
    /// Algorithm 2's linear solves.
    pub solver: SolverReport,
    /// Seconds of Algorithm 2 and of the certification.
    pub algorithm2_s: f64,
    /// Seconds of the certification.
    pub certify_s: f64,
    /// Whole job.
    pub total_s: f64,
    /// Peak resident memory of the process when the report was written,
    /// in MiB (Linux's VmHWM; null elsewhere).
    pub peak_memory_mib: Option<f64>,
    /// Files written. The report file also records each one's size and
    /// FNV-1a hash (`written`, with the files of other outputs in the
    /// folder still as an earlier run wrote them): a rerun replaces or
    /// removes only those ([`crate::io::folder`]).
    pub outputs: Vec<String>,
    /// The curved mesh, with the input's groups, entities and tags, where
    /// the run wrote no files ([`Sink::Memory`]).
    #[serde(skip)]
    pub curved: Option<crate::io::layout::Layout>,
}

/// `deformesh curve`: reads a linear mesh and a geometry file, runs
/// Algorithms 2 and 3, and writes the curved mesh (MSH, VTU, PNG, report)
/// only if every element is certified valid.
pub fn curve_file(job: &CurveJob, progress: impl FnMut(Progress)) -> Result<CurveReport, RunError> {
    check_output_file(&job.output)?;
    let (dir, _, report, claim) = job.destination();
    check_set(&dir, &job.output_names(), &report, &claim)?;
    let bytes = std::fs::read(&job.input).map_err(|cause| RunError::Read { path: job.input.clone(), cause })?;
    let model = match &job.cad {
        Some(c) => {
            std::fs::metadata(&c.model).map_err(|cause| RunError::Read { path: c.model.clone(), cause })?;
            Some(crate::geometry::cad::CadModel::open_scaled(&c.model, c.library.as_deref(), c.scale)?)
        }
        None => None,
    };
    curve_bytes(job, bytes, model.as_ref(), Sink::Files, progress)
}

/// [`curve_file`] on the MSH file `bytes` (read from, or standing for,
/// `job.input`), bound to `model` (the job's `cad` is not read again)
/// and the job's geometry file; with [`Sink::Memory`] nothing is written
/// and the curved mesh is in the report's `curved`.
pub fn curve_bytes(job: &CurveJob, bytes: Vec<u8>, model: Option<&std::sync::Arc<crate::geometry::cad::CadModel>>, sink: Sink, mut progress: impl FnMut(Progress)) -> Result<CurveReport, RunError> {
    let read = crate::io::msh::parse_any(&bytes, true)?;
    drop(bytes);
    unkept(&read.layout).map_err(|why| RunError::Unkept { path: job.input.clone(), why })?;
    check_memory(&read.mesh, job)?;
    let geometry = job.geometry.as_deref().map(crate::app::bind::GeometryFile::read).transpose()?;
    let gfile = job.geometry.as_ref().map_or(String::new(), |g| g.display().to_string());
    if geometry.is_none() && model.is_none() {
        return Err(CaseError { file: job.input.display().to_string(), message: "nothing binds the mesh's boundary: give a geometry file or a CAD model (--cad)".into() }.into());
    }
    let binding = Binding { geometry: geometry.as_ref(), gfile: &gfile, model };
    // either may relax the check that curved groups lie on their shapes
    let mut job = job.clone();
    job.options.shape_tolerance = job.options.shape_tolerance.max(geometry.as_ref().and_then(|g| g.shape_tolerance).unwrap_or(0.0));
    let fine_cells = |d: u32| job.options.order.max(1).pow(d);
    let tags = &read.cell_tags;
    let input = (&job, &read.layout, sink);
    // a mesh of one kind goes to Algorithm 1's kernels compiled for it;
    // several kinds (and prisms, pyramids) through their simplices, where
    // curve_mixed names tangled cells by their coarse cell
    let result = match read.mesh {
        AnyMesh::Solid(mesh) => match (mesh.to_solid::<8, 4>(), mesh.to_solid::<4, 3>()) {
            (Some(hexes), _) => curve_solid(hexes, &binding, input, &mut progress).map_err(|e| by_tag(e, tags, fine_cells(3))),
            (_, Some(tets)) => curve_solid(tets, &binding, input, &mut progress).map_err(|e| by_tag(e, tags, fine_cells(3))),
            _ => curve_mixed_solid(mesh, &binding, input, &mut progress).map_err(|e| by_tag(e, tags, 1)),
        },
        AnyMesh::Plane(mesh) => match (mesh.to_plane::<4>(), mesh.to_plane::<3>()) {
            (Some(quads), _) => curve_plane(quads, &binding, input, &mut progress).map_err(|e| by_tag(e, tags, fine_cells(2))),
            (_, Some(triangles)) => curve_plane(triangles, &binding, input, &mut progress).map_err(|e| by_tag(e, tags, fine_cells(2))),
            _ => curve_plane(mesh, &binding, input, &mut progress).map_err(|e| by_tag(e, tags, 1)),
        },
    };
    result.map_err(|e| in_the_files_tags(with_node_tag(e, &read.node_tags), &job.input))
}

/// A refusal of the mesh's structure by Algorithm 2's subdivision (0-based
/// indices) told again by [`crate::io::msh::check_structure`]: the
/// file's element and node tags and the cause (a hanging node, duplicate
/// nodes, …). The file is read again only then.
fn in_the_files_tags(e: RunError, input: &Path) -> RunError {
    use crate::refine::SubdivideError;
    match e {
        RunError::Curve(CurveError::Subdivide(SubdivideError::NotACellFacet { .. } | SubdivideError::InteriorFacet { .. } | SubdivideError::Uncovered { .. })) => {
            match std::fs::read(input).map(|bytes| crate::io::msh::check_structure(&bytes)) {
                Ok(Err(told)) => told.into(),
                _ => e,
            }
        }
        e => e,
    }
}

/// Refuses a `curve` run whose estimated peak memory
/// ([`crate::app::memory::curve_estimate`]) is more than the process may
/// allocate ([`crate::app::memory::headroom`]), saying what would fit.
fn check_memory(mesh: &AnyMesh, job: &CurveJob) -> Result<(), RunError> {
    use crate::app::memory::{curve_estimate, headroom, reserved_address_space, shown};
    let (dim, vertices) = match mesh {
        AnyMesh::Plane(m) => (2, m.nodes.len() as u64),
        AnyMesh::Solid(m) => (3, m.nodes.len() as u64),
    };
    let whole = job.options.band.is_none();
    let p = job.options.order.max(1) as u64;
    let Some(room) = headroom() else { return Ok(()) };
    // the address space also holds the threads' stacks and arenas
    let reserved = if room.what.contains("RLIMIT_AS") { reserved_address_space() } else { 0 };
    let need = |p: u64, whole: bool| curve_estimate(dim, vertices * p.pow(dim as u32), whole) + reserved;
    if need(p, whole) <= room.bytes {
        return Ok(());
    }
    let mut advice: Vec<String> = Vec::new();
    if whole && need(p, false) <= room.bytes {
        advice.push(format!("Without --band all (Algorithm 2 in a band along the curved walls) it needs about {}", shown(need(p, false))));
    }
    if let Some(q) = (1..p).rev().find(|&q| need(q, whole) <= room.bytes) {
        advice.push(format!("At --order {q} it needs about {}", shown(need(q, whole))));
    }
    if advice.is_empty() {
        advice.push("No lower order fits either: run it where more memory is available, or curve a coarser mesh".into());
    }
    let what = format!("estimated for {} nodes of order {p} in {dim}D{}", vertices * p.pow(dim as u32), if whole { ", --band all" } else { "" });
    Err(RunError::Memory { need: need(p, whole), what, room, advice: advice.join("; ") + "." })
}

/// `curve` on a solid mesh of hexes or tetrahedra.
fn curve_solid<const N: usize, const K: usize>(mesh: SolidMesh<N, K>, binding: &Binding, job: JobIn, progress: &mut impl FnMut(Progress)) -> Result<CurveReport, RunError>
where
    SolidMesh<N, K>: Outputs<3, N> + Subdividable<3, N>,
{
    let (gfile, names) = (binding.gfile, &mesh.part_names);
    if let Some(model) = binding.model {
        let facets: Vec<(Vec<usize>, usize)> = mesh.faces.iter().map(|f| (f.nodes.to_vec(), f.part)).collect();
        let cad = crate::app::cad::bind::<3>(model, (job.1, &mesh.nodes), (&facets, names), binding.geometry.map(|g| (g, gfile)), job.0.options.shape_tolerance)?;
        let mut nodes = mesh.nodes;
        cad.put_on_model(&mut nodes);
        let mesh = SolidMesh::<N, K>::assemble(nodes, mesh.cells, cad.facets, cad.names);
        return curve_mesh(&mesh, &cad.parts, (Vec::new(), &[]), 0, job, (progress, Some((model, cad.bound))));
    }
    let geometry = binding.geometry.expect("a geometry file where there is no model");
    let (parts, unbound) = geometry.parts::<3>(names, gfile)?;
    geometry.check_carried(names, &crate::app::bind::carried(mesh.faces.iter().map(|f| f.part), names.len()), gfile)?;
    let (mesh, shared) = one_group_per_mesh_facet(&mesh, &unbound, gfile)?;
    curve_mesh(&mesh, &parts, (unbound, &shared), 0, job, (progress, None))
}

/// `curve` on a linear solid of prisms, pyramids, hexes and tetrahedra,
/// several kinds or prisms or pyramids alone.
fn curve_mixed_solid(mut mesh: CurvedMesh<3>, binding: &Binding, job: JobIn, progress: &mut impl FnMut(Progress)) -> Result<CurveReport, RunError> {
    let gfile = binding.gfile;
    let facets = mesh.linear_facets();
    if let Some(model) = binding.model {
        let cad = crate::app::cad::bind::<3>(model, (job.1, &mesh.nodes), (&facets, &mesh.part_names), binding.geometry.map(|g| (g, gfile)), job.0.options.shape_tolerance)?;
        cad.put_on_model(&mut mesh.nodes);
        mesh.set_linear_facets(cad.facets);
        mesh.part_names = cad.names;
        return curve_mesh(&mesh, &cad.parts, (Vec::new(), &[]), 0, job, (progress, Some((model, cad.bound))));
    }
    let geometry = binding.geometry.expect("a geometry file where there is no model");
    let names = mesh.part_names.clone();
    let (parts, unbound) = geometry.parts::<3>(&names, gfile)?;
    geometry.check_carried(&names, &crate::app::bind::carried(facets.iter().map(|f| f.1), names.len()), gfile)?;
    let (kept, shared) = one_group_per_facet(facets, &names, &unbound, gfile)?;
    if let Some(kept) = kept {
        mesh.set_linear_facets(kept);
    }
    curve_mesh(&mesh, &parts, (unbound, &shared), 0, job, (progress, None))
}

/// What the figures of a mesh of several kinds mean: Algorithm 1 solves
/// on the simplices cut from its cells ([`Cut`]).
pub trait CutWords {
    /// See [`Outputs::DEFINITIONS`].
    const DEFINITIONS: Definitions;
}

impl CutWords for CurvedMesh<3> {
    const DEFINITIONS: Definitions = Definitions {
        det_j: "determinant of each cell's linear map from its reference element (Gmsh's vertices, mapped to [0,1]-based ones: tetrahedron, prism, pyramid, cube), bounded by its Bezier coefficients as the curved elements are (order 1)",
        scaled_jacobian: "per cell, det J/(product of the column norms of J), its minimum on the order-1 certificate's sampling grid",
        jf: "Algorithm 1 solves on the tetrahedra cut from the cells: the figures are per tetrahedron, |K_t| / integral over K_0 of f(phi(xi)) dxi (4-point rule); the pictures and VTU show each cell's, the volume of its tetrahedra over the sum of their integrals",
    };
}

impl CutWords for CurvedMesh<2> {
    const DEFINITIONS: Definitions = Definitions {
        det_j: "determinant of each cell's linear map from its reference element (triangle (0,0),(1,0),(0,1); square [0,1]^2), bounded by its Bezier coefficients as the curved elements are (order 1)",
        scaled_jacobian: "per cell, det J/(product of the column norms of J), its minimum on the order-1 certificate's sampling grid",
        jf: "Algorithm 1 solves on the triangles cut from the cells: the figures are per triangle, |K_t| / integral over K_0 of f(phi(xi)) dxi (3-point rule); the pictures and VTU show each cell's, the area of its triangles over the sum of their integrals",
    };
}

/// Meshes of several kinds: Algorithm 1 on their simplices, everything
/// written and drawn by their own cells.
impl<const D: usize, const N: usize> Outputs<D, N> for Cut<D, N>
where
    CurvedMesh<D>: Cuttable<D, N> + Curvable<D> + CutWords,
{
    const DEFINITIONS: Definitions = <CurvedMesh<D> as CutWords>::DEFINITIONS;
    fn quality(&self) -> MeshQuality {
        self.quality_and_scaled_jacobians().0
    }
    fn scaled_jacobians(&self) -> Vec<f64> {
        self.quality_and_scaled_jacobians().1
    }
    /// Both from one certification of the cells at order 1.
    fn quality_and_scaled_jacobians(&self) -> (MeshQuality, Vec<f64>) {
        let (certs, q) = certify_mesh(&self.mesh()).expect("order 1 of every kind");
        let sizes = self.written_sums(&self.cell_sizes(self.nodes()));
        let quality = MeshQuality {
            cells: q.elements,
            nodes: q.nodes,
            det_j: Range { min: q.min_det_j, max: q.max_det_j },
            scaled_jacobian: q.scaled_jacobian,
            invalid_cells: q.invalid_elements,
            cell_size: Range::of(sizes.iter().copied()),
        };
        (quality, certs.iter().map(|c| c.min_scaled_jacobian).collect())
    }
    fn cell_sizes(&self, nodes: &[[f64; D]]) -> Vec<f64> {
        Q1Mesh::cells(self).iter().map(|t| crate::quality::cell_size(&t.map(|n| nodes[n]))).collect()
    }
    fn msh(&self) -> Result<String, MshError> {
        self.mesh().msh_string()
    }
    fn vtu(&self, cell_data: &[(&str, &[f64])]) -> Result<String, VtuError> {
        self.mesh().vtu_string(cell_data)
    }
    fn draw(&self, nodes: &[[f64; D]], values: &[f64], look: &Look<D>) -> Result<tiny_skia::Pixmap, RenderError> {
        <CurvedMesh<D> as Curvable<D>>::draw_curved(&self.mesh_at(nodes), values, look)
    }
    fn written_ratios(&self, nodes: &[[f64; D]], values: &[f64]) -> Vec<f64> {
        // a cell's ratio is its simplices' size over the sum of what each
        // one's ratio divides
        let sizes = self.cell_sizes(nodes);
        let under: Vec<f64> = sizes.iter().zip(values).map(|(s, r)| s / r).collect();
        self.written_sums(&sizes).iter().zip(self.written_sums(&under)).map(|(s, u)| s / u).collect()
    }
    fn written_sums(&self, values: &[f64]) -> Vec<f64> {
        self.summed(values)
    }
}

impl<const D: usize, const N: usize> Curvable<D> for Cut<D, N>
where
    CurvedMesh<D>: Cuttable<D, N> + Curvable<D>,
{
    fn curve(&self, parts: &[BoundaryPart<D>], opts: &CurveOptions, progress: &mut dyn FnMut(Progress)) -> Result<Curved<D>, CurveError> {
        self.mesh().curve(parts, opts, progress)
    }
    fn draw_curved(mesh: &CurvedMesh<D>, values: &[f64], look: &Look<D>) -> Result<tiny_skia::Pixmap, RenderError> {
        <CurvedMesh<D> as Curvable<D>>::draw_curved(mesh, values, look)
    }
}

/// Solids of several kinds, or prisms or pyramids, the linear mesh of
/// order 1 (Algorithm 1 moves them as a [`Cut`]).
impl Curvable<3> for CurvedMesh<3> {
    fn curve(&self, parts: &[BoundaryPart<3>], opts: &CurveOptions, progress: &mut dyn FnMut(Progress)) -> Result<Curved<3>, CurveError> {
        crate::highorder::curve::curve_mixed_solid(self, parts, opts, algorithm2(progress))
    }
    fn draw_curved(mesh: &CurvedMesh<3>, values: &[f64], look: &Look<3>) -> Result<tiny_skia::Pixmap, RenderError> {
        render_hexes(mesh, values, &options3(look))
    }
}

/// A linear plane mesh as `curve` takes it: quads, triangles or both.
trait PlaneInput: Curvable<2> {
    /// See [`PlaneMesh::orient_counter_clockwise`].
    fn orient(&mut self) -> usize;
    /// The nodes and the part names.
    fn nodes_and_names(&mut self) -> (&mut [[f64; 2]], &mut Vec<String>);
    /// The boundary edges and their parts.
    fn edges(&self) -> Vec<(Vec<usize>, usize)>;
    /// Replaces the boundary edges (to keep one copy of each, or regroup
    /// them by entity).
    fn set_edges(&mut self, edges: Vec<(Vec<usize>, usize)>);
}

impl<const N: usize> PlaneInput for PlaneMesh<N> {
    fn orient(&mut self) -> usize {
        self.orient_counter_clockwise()
    }
    fn nodes_and_names(&mut self) -> (&mut [[f64; 2]], &mut Vec<String>) {
        (&mut self.nodes, &mut self.part_names)
    }
    fn edges(&self) -> Vec<(Vec<usize>, usize)> {
        self.edges.iter().map(|e| (e.nodes.to_vec(), e.part)).collect()
    }
    fn set_edges(&mut self, edges: Vec<(Vec<usize>, usize)>) {
        self.edges = edges.into_iter().map(|(n, part)| crate::mesh::BoundaryEdge { nodes: [n[0], n[1]], part }).collect();
    }
}

impl PlaneInput for CurvedMesh<2> {
    fn orient(&mut self) -> usize {
        self.orient_counter_clockwise()
    }
    fn nodes_and_names(&mut self) -> (&mut [[f64; 2]], &mut Vec<String>) {
        (&mut self.nodes, &mut self.part_names)
    }
    fn edges(&self) -> Vec<(Vec<usize>, usize)> {
        self.linear_facets()
    }
    fn set_edges(&mut self, edges: Vec<(Vec<usize>, usize)>) {
        self.set_linear_facets(edges);
    }
}

/// `curve` on a plane mesh of quads, triangles or both.
fn curve_plane(mut mesh: impl PlaneInput, binding: &Binding, job: JobIn, progress: &mut impl FnMut(Progress)) -> Result<CurveReport, RunError> {
    // Gmsh may write a surface's cells clockwise (by its normal)
    let turned = mesh.orient();
    let gfile = binding.gfile;
    let edges = mesh.edges();
    let (nodes, names) = mesh.nodes_and_names();
    if let Some(model) = binding.model {
        let cad = crate::app::cad::bind::<2>(model, (job.1, nodes), (&edges, names), binding.geometry.map(|g| (g, gfile)), job.0.options.shape_tolerance)?;
        cad.put_on_model(nodes);
        *names = cad.names;
        mesh.set_edges(cad.facets);
        return curve_mesh(&mesh, &cad.parts, (Vec::new(), &[]), turned, job, (progress, Some((model, cad.bound))));
    }
    let geometry = binding.geometry.expect("a geometry file where there is no model");
    let names = names.to_vec();
    let (parts, unbound) = geometry.parts::<2>(&names, gfile)?;
    geometry.check_carried(&names, &crate::app::bind::carried(edges.iter().map(|e| e.1), names.len()), gfile)?;
    let (kept, shared) = one_group_per_facet(edges, &names, &unbound, gfile)?;
    if let Some(kept) = kept {
        mesh.set_edges(kept);
    }
    curve_mesh(&mesh, &parts, (unbound, &shared), turned, job, (progress, None))
}

/// The curved mesh in the job's format: the layout (every group, entity,
/// tag and periodic pair of the input) for the Gmsh formats; for MFEM and
/// ABAQUS, which know no entities, its cells and boundary elements with
/// the physical tags as attributes and the group names as boundary names
/// ([`crate::io::layout::Layout::as_mesh`]).
fn main_file<const D: usize>(format: OutputFormat, layout: &crate::io::layout::Layout, (mesh, cells, boundary): &(CurvedMesh<D>, Vec<i64>, Vec<i64>)) -> Result<Vec<u8>, RunError> {
    let text = match format {
        OutputFormat::Msh41 => crate::io::msh::layout_text(layout),
        OutputFormat::Msh22 => crate::io::msh::layout_text_22(layout),
        OutputFormat::Mfem => crate::io::mfem::mfem_string(mesh, cells, boundary)?,
        OutputFormat::Abaqus => crate::io::abaqus::abaqus_string(mesh)?,
    };
    Ok(text.into_bytes())
}

/// The curved mesh (its equispaced nodes, as written) with new periodic
/// slave nodes moved to the images of their masters (`layout`'s
/// coordinates): certified again, and its curved groups (the walls of
/// Algorithm 2's parts, slip walls on shapes too) measured before and
/// after the move, whose nodes must not move off their shapes by more
/// than 1e-12 of the mesh's extent. The report's boundary figures stay
/// those of `curve`, which then hold to that.
fn recertify<const D: usize>(c: &mut Curved<D>, layout: &crate::io::layout::Layout, parts: &[BoundaryPart<D>], samples: usize) -> Result<(), RunError> {
    let walls = crate::refine::refine_parts(parts);
    let before = crate::highorder::curve::boundary_errors(&c.mesh, &walls, samples).map_err(CurveError::from)?;
    for (x, y) in c.mesh.nodes.iter_mut().zip(&layout.coords) {
        *x = std::array::from_fn(|d| y[d]);
    }
    let (certificates, q) = crate::highorder::curve::certify_mesh(&c.mesh).map_err(CurveError::from)?;
    c.certificates = certificates;
    c.quality.invalid_elements = q.invalid_elements;
    c.quality.min_det_j = q.min_det_j;
    c.quality.min_det_j_attained = q.min_det_j_attained;
    c.quality.max_det_j = q.max_det_j;
    c.quality.scaled_jacobian = q.scaled_jacobian;
    let after = crate::highorder::curve::boundary_errors(&c.mesh, &walls, samples).map_err(CurveError::from)?;
    let allowed = 1e-12 * layout.extent();
    for (group, e) in &after {
        let was = before.get(group).map_or(0.0, |b| b.nodes);
        if e.nodes > was + allowed {
            return Err(RunError::PeriodicOffShape { group: group.clone(), distance: e.nodes, before: was, allowed });
        }
    }
    Ok(())
}

/// Why the output could not keep all that the input file holds, if so:
/// a partitioned mesh, parametric node coordinates, data sections.
fn unkept(layout: &crate::io::layout::Layout) -> Result<(), String> {
    let partitioned = ["PartitionedEntities", "GhostElements"];
    if let Some(s) = layout.unkept_sections.iter().find(|s| partitioned.contains(&s.as_str())) {
        return Err(format!(
            "partitioned mesh: the file has ${s}; `curve` takes the whole mesh: write it unpartitioned \
             (in Gmsh, save before partitioning, or call `gmsh.model.mesh.unpartition()` before `gmsh.write`)"
        ));
    }
    if let Some(s) = layout.unkept_sections.first() {
        return Err(format!("the file has a ${s} section, which `curve` cannot carry to the curved mesh (it writes the mesh only): save the mesh without it"));
    }
    if layout.parametric {
        return Err("the file gives parametric node coordinates, which `curve` cannot give its new nodes: save it without them (Gmsh: Mesh.SaveParametric = 0)".into());
    }
    Ok(())
}

/// A boundary element of an entity in several physical groups is read
/// once per group, but the flow needs one behaviour per element: a group
/// the geometry file binds governs one it leaves alone, and two bound
/// groups sharing elements are refused, naming both. Returns the mesh with
/// one copy of each element and, per copy left out, the index of the kept
/// one and its group (the output puts the element in that group too).
fn one_group_per_mesh_facet<M: Subdividable<D, N>, const D: usize, const N: usize>(mesh: &M, unbound: &[String], gfile: &str) -> Result<(M, Vec<(usize, usize)>), RunError> {
    let (kept, shared) = one_group_per_facet(mesh.facets(), mesh.names(), unbound, gfile)?;
    match kept {
        None => Ok((mesh.clone(), shared)),
        Some(kept) => Ok((M::assemble(mesh.nodes().to_vec(), mesh.cells().to_vec(), kept, mesh.names().to_vec()), shared)),
    }
}

/// [`one_group_per_mesh_facet`] on the boundary `facets` (nodes, part) of
/// a mesh with parts `names`: the facets kept, if any was left out.
type KeptFacets = (Option<Vec<(Vec<usize>, usize)>>, Vec<(usize, usize)>);
fn one_group_per_facet(facets: Vec<(Vec<usize>, usize)>, names: &[String], unbound: &[String], gfile: &str) -> Result<KeptFacets, RunError> {
    use std::collections::HashMap;
    let bound = |part: usize| !unbound.contains(&names[part]);
    let mut first: HashMap<Vec<usize>, usize> = HashMap::new();
    let mut kept: Vec<(Vec<usize>, usize)> = Vec::new();
    let mut shared: Vec<(usize, usize)> = Vec::new();
    for (nodes, part) in facets {
        let mut key = nodes.clone();
        key.sort_unstable();
        let Some(&k) = first.get(&key).filter(|&&k| kept[k].1 != part) else {
            first.entry(key).or_insert(kept.len());
            kept.push((nodes, part));
            continue;
        };
        let other = kept[k].1;
        if bound(part) && bound(other) {
            return Err(crate::app::case::CaseError {
                file: gfile.to_string(),
                message: format!(
                    "groups `{}` and `{}` share boundary elements (a curve or surface in both groups), and both are bound here: an element can have one behaviour only; bind one of them, or give the shared part a group of its own",
                    names[other], names[part]
                ),
            }
            .into());
        }
        if bound(part) {
            kept[k].1 = part;
            shared.push((k, other));
        } else {
            shared.push((k, part));
        }
    }
    if shared.is_empty() {
        return Ok((None, shared));
    }
    Ok((Some(kept), shared))
}

/// An off-shape node of the input named by its MSH tag.
fn with_node_tag(e: RunError, node_tags: &[u64]) -> RunError {
    match e {
        RunError::Curve(CurveError::OffShape(mut o)) if !o.after => {
            o.tag = node_tags.get(o.node).copied();
            RunError::Curve(CurveError::OffShape(o))
        }
        e => e,
    }
}

/// An error that lists cells, with the cells named by the input file's
/// element tags instead of 0-based indices. Algorithm 2 runs on the cells
/// subdivided `per_cell` times (p^d): its cells are mapped to the element
/// they split.
fn by_tag(e: RunError, tags: &[u64], per_cell: usize) -> RunError {
    let to_tags = |cells: &[usize], per: usize| {
        let mut v: Vec<u64> = cells.iter().filter_map(|&c| tags.get(c / per).copied()).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    match e {
        RunError::Curve(CurveError::InvalidCoarse(cells)) => {
            RunError::Elements { what: "the mesh to be curved already has invalid cells (det J not positive at a corner)".into(), tags: to_tags(&cells, 1) }
        }
        RunError::InvalidCurved { order, cells, min_det } => RunError::Elements {
            what: format!("the curved mesh of order {order} has elements not certified valid (det J not positive over the whole element; certified min det J {min_det:.3e})"),
            tags: to_tags(&cells, 1),
        },
        RunError::Curve(CurveError::NoCandidate { bad, tried, last, whole }) => {
            let why = format!("the snap left them not certified valid; {}", crate::highorder::curve::unrepaired(&tried, &last, whole));
            RunError::Unrepaired { why, tags: to_tags(&bad, 1) }
        }
        RunError::Curve(CurveError::Deform(DeformError::Tangled { t, dt, cells })) => RunError::Elements {
            what: format!("Algorithm 2 (carrying the high-order boundary nodes onto the geometry): the mesh tangles at t = {t:.4} even with step {dt:.3e}"),
            tags: to_tags(&cells, per_cell),
        },
        other => other,
    }
}

fn curve_mesh<M: Curvable<D>, const D: usize>(
    mesh: &M,
    parts: &[BoundaryPart<D>],
    (unbound, shared): (Vec<String>, &[(usize, usize)]),
    reoriented: usize,
    (job, input, sink): JobIn,
    (progress, cad): (&mut dyn FnMut(Progress), Option<(&std::sync::Arc<crate::geometry::cad::CadModel>, Vec<crate::app::cad::Bound>)>),
) -> Result<CurveReport, RunError> {
    let (model, bound) = cad.map_or((None, Vec::new()), |(m, b)| (Some(m), b));
    let clock = Instant::now();
    let mut c = mesh.curve(parts, &job.options, progress)?;
    // a projection Gmsh failed answered with the point itself
    if let Some(e) = model.and_then(|m| m.failure()) {
        return Err(e.into());
    }
    // files store equispaced nodes (the same maps: certificates hold);
    // the node numbering stays
    let spacing = c.mesh.spacing;
    c.mesh = c.mesh.to_equispaced();
    let (layout, snapped) = input.curved(&c.mesh, &c.coarse_nodes)?;
    if snapped > 0.0 {
        recertify(&mut c, &layout, parts, job.options.samples)?;
    }
    // elements of an entity in several groups go into each of them
    for &(k, part) in shared {
        let f = c.mesh.boundary.get(k);
        let (shape, nodes) = (f.shape, f.nodes.to_vec());
        c.mesh.boundary.push(shape, &nodes, part);
    }
    if !c.quality.invalid_elements.is_empty() {
        return Err(RunError::InvalidCurved { order: job.options.order, cells: c.quality.invalid_elements.clone(), min_det: c.quality.min_det_j });
    }
    if stop_requested() {
        return Err(RunError::Interrupted);
    }
    let mut report = CurveReport {
        input: job.input.display().to_string(),
        dimension: D,
        cells: c.mesh.cells.len(),
        unbound_groups: unbound,
        cad: model.map(|m| CadReport { model: m.file.display().to_string(), library: m.library.display().to_string(), gmsh_version: m.version.clone(), scale: m.scale, bound }),
        reoriented_cells: reoriented,
        quality: c.quality.clone(),
        periodic_snap: snapped,
        spacing,
        steps: c.stats.steps,
        halved_steps: c.stats.halved,
        algorithm2_runs: c.attempts,
        solver: c.solver.clone(),
        algorithm2_s: c.seconds.0,
        certify_s: c.seconds.1,
        total_s: 0.0,
        peak_memory_mib: None,
        outputs: Vec::new(),
        curved: None,
    };
    if sink == Sink::Memory {
        report.total_s = clock.elapsed().as_secs_f64();
        report.peak_memory_mib = super::bench::peak_memory_mib();
        report.curved = Some(layout);
        return Ok(report);
    }
    let (dir, stem, report_name, claim) = job.destination();
    let min_det: Vec<f64> = c.certificates.iter().map(|x| x.min_det_lower).collect();
    let sj: Vec<f64> = c.certificates.iter().map(|x| x.min_scaled_jacobian).collect();
    let output = OutputSpec::default();
    let bounds = frame_bounds(std::iter::once(c.mesh.nodes.as_slice()));
    let r = Range::of(sj.iter().copied());
    let look = Look {
        bounds,
        range: (r.min.min(r.max - 1e-3), r.max),
        title: format!("{}: order {} elements", stem, c.mesh.p),
        width: job.width,
        label: "min scaled Jacobian",
        colour_map: Some(ColourMap::Sequential),
        output: &output,
    };
    // the cells in the readers' order, as c.mesh has them
    let view = layout.as_mesh::<D>();
    // the three outputs are independent and each mostly serial: side by side
    // VTK has no cell for a curved pyramid: such a mesh is written
    // without its VTU, as the report's `outputs` say
    let vtk = crate::io::vtu::vtk_can_hold(&c.mesh);
    if !vtk {
        tracing::info!("{}", crate::io::vtu::VtuError::NoPyramidCell(c.mesh.p));
    }
    let ((main, vtu), png) = rayon::join(
        || rayon::join(|| main_file(job.format, &layout, &view), || vtk.then(|| c.mesh.vtu_string_with_attributes(&[("min_det_j", &min_det), ("min_scaled_jacobian", &sj)], &view.1)).transpose()),
        || -> Result<Vec<u8>, RunError> { Ok(png_bytes(&M::draw_curved(&c.mesh, &sj, &look)?)?) },
    );
    let mut files: Vec<(String, Vec<u8>)> = vec![(claim.output.clone(), main?)];
    if let Some(vtu) = vtu? {
        files.push((format!("{stem}.vtu"), vtu.into_bytes()));
    }
    files.push((format!("{stem}.png"), png?));
    report.outputs = files.iter().map(|f| f.0.clone()).chain(std::iter::once(report_name.clone())).collect();
    report.total_s = clock.elapsed().as_secs_f64();
    report.peak_memory_mib = super::bench::peak_memory_mib();
    if stop_requested() {
        return Err(RunError::Interrupted);
    }
    write_set(&dir, &files, &report_name, serde_json::to_value(&report).expect("report serialises"), &claim)?;
    Ok(report)
}
