//! Case files (TOML): the schema and its translation into a mesh, boundary
//! parts and a prescribed Jacobian.
//!
//! Every table rejects unknown fields, and every error names the file and
//! the field (toml's own errors add the line and column).

use crate::deform::{BoundaryPart, Correspondence, CutPlane, CutSolid, DeformOptions, Integrator, MoveMode, PartKind, SolverChoice};
use crate::expr::Expr;
use crate::geometry::{shape_from_toml, spec_from_toml, LevelSet, ShapeSpec, SurfaceSpec};
use crate::highorder::curve::CurveOptions;
use crate::highorder::{check_order, Spacing};
use crate::jacobian::{lift, ImageField, JacobianError, Interface, JacobianField, Locus, SmallWhere, Target, TimePath, EXPR_VARS};
use crate::mesh::element::Shape;
use crate::mesh::{CurvedMesh, HexMesh, PlaneMesh, QuadMesh, SolidMesh, TetMesh, TriMesh, BOX_FACES, BOX_SIDES};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A case file that cannot be used.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {message}")]
pub struct CaseError {
    /// The case file (or `<built-in>`).
    pub file: String,
    /// What is wrong, naming the field.
    pub message: String,
}

/// The whole case file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// A name for reports and titles.
    #[serde(default)]
    pub name: Option<String>,
    /// The starting mesh.
    pub mesh: MeshSpec,
    /// Boundary parts.
    #[serde(default)]
    pub boundary: Vec<PartSpec>,
    /// The prescribed Jacobian (default: uniform).
    #[serde(default)]
    pub jacobian: JacobianSpec,
    /// Pseudo-time stepping.
    #[serde(default)]
    pub time: TimeSpec,
    /// What to write.
    #[serde(default)]
    pub output: OutputSpec,
    /// Algorithms 2 and 3: curve the result to order-p elements.
    #[serde(default)]
    pub highorder: Option<HighOrderSpec>,
    /// The text it was parsed from (for line numbers in errors).
    #[serde(skip)]
    pub source: String,
}

/// A structured box mesh: a rectangle (two numbers each) or a brick (three).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// Lower corner.
    pub lower: Vec<f64>,
    /// Upper corner.
    pub upper: Vec<f64>,
    /// Cells along each axis.
    pub cells: Vec<usize>,
    /// What each box cell is made of (quadrilaterals or hexahedra when
    /// not given).
    #[serde(default)]
    pub elements: Option<ElementsSpec>,
}

/// The kinds of elements a case's box is made of.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ElementsSpec {
    /// Quadrilaterals (2D).
    Quadrilateral,
    /// Two triangles per box cell (2D).
    Triangle,
    /// Hexahedra (3D).
    Hexahedron,
    /// Six tetrahedra per box cell, Kuhn's cut (3D).
    Tetrahedron,
    /// Two prisms per box cell, layered along z (3D).
    Prism,
    /// Six pyramids per box cell, their apex at its centre (3D).
    Pyramid,
    /// Kinds side by side, each meeting the other: in 2D quadrilaterals
    /// and triangle pairs in a checkerboard; in 3D columns of hexahedra
    /// and of prisms in a checkerboard (along z).
    Mixed,
}

impl ElementsSpec {
    /// The element kind (`None` for mixed kinds).
    pub fn shape(self) -> Option<Shape> {
        match self {
            ElementsSpec::Quadrilateral => Some(Shape::Quadrilateral),
            ElementsSpec::Triangle => Some(Shape::Triangle),
            ElementsSpec::Hexahedron => Some(Shape::Hexahedron),
            ElementsSpec::Tetrahedron => Some(Shape::Tetrahedron),
            ElementsSpec::Prism => Some(Shape::Prism),
            ElementsSpec::Pyramid => Some(Shape::Pyramid),
            ElementsSpec::Mixed => None,
        }
    }
}

/// Kinds of boundary parts.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PartKindSpec {
    /// Glide along a wall.
    Slip,
    /// Move onto a target shape.
    Move,
    /// Stay.
    Fixed,
}

/// Correspondence rules.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum CorrespondenceSpec {
    /// Along rays from `centre`.
    Radial,
    /// Closest point.
    Normal,
    /// Along `direction`.
    Along,
}

/// Move modes.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ModeSpec {
    /// Only u·n imposed (default).
    Sliding,
    /// u = v/f (the paper).
    Dirichlet,
}

/// One `[[boundary]]` table.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartSpec {
    /// Part name (a physical group in the MSH output).
    pub name: String,
    /// Box sides: `left`, `right`, `bottom`, `top` (2D) or faces `xmin`,
    /// `xmax`, `ymin`, `ymax`, `zmin`, `zmax` (3D).
    pub sides: Vec<String>,
    /// `slip`, `move` or `fixed`.
    pub kind: PartKindSpec,
    /// Target (move) or wall (slip; default: the side itself): a curve
    /// ([`ShapeSpec`]) in 2D, a surface ([`SurfaceSpec`]) in 3D.
    #[serde(default)]
    pub shape: Option<toml::Spanned<toml::Value>>,
    /// `radial` (needs `centre`) or `normal` (default).
    #[serde(default)]
    pub correspondence: Option<CorrespondenceSpec>,
    /// Centre of the radial correspondence.
    #[serde(default)]
    pub centre: Option<Vec<f64>>,
    /// Direction of the `along` correspondence.
    #[serde(default)]
    pub direction: Option<Vec<f64>>,
    /// `sliding` (default) or `dirichlet`.
    #[serde(default)]
    pub mode: Option<ModeSpec>,
}

/// The `[jacobian]` table: one field, its time path and a floor.
#[derive(Clone, Debug, Deserialize, Default)]
pub struct JacobianSpec {
    /// The field (`type = ...` and its parameters).
    #[serde(flatten)]
    pub field: FieldSpec,
    /// `linear` (default: g linear in t, the paper's choice) or `inverse`
    /// (1/g linear in t); see [`TimePath`] for why.
    #[serde(default)]
    pub path: Option<TimePath>,
    /// A lower bound on g₁, so f never reaches 0.
    #[serde(default)]
    pub floor: Option<f64>,
}

/// One prescribed-Jacobian field; combinations nest further fields in `of`.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum FieldSpec {
    /// f follows only the change of area. (A struct variant, so that a
    /// stray field next to it is an error rather than ignored.)
    Uniform {},
    /// g₁(x, y, z) — or g(x, y, z, t) — as text.
    Expression {
        /// The expression, in x, y, z and optionally t.
        f: String,
    },
    /// g₁ from a PNG picture.
    Image {
        /// The PNG, relative to the case file.
        file: PathBuf,
        /// Lower corner of the rectangle the picture covers.
        lower: [f64; 2],
        /// Upper corner.
        upper: [f64; 2],
        /// `dark` (default) or `bright`: the pixels that get small cells.
        #[serde(default)]
        small: SmallWhere,
        /// Cell size on the small-cell extreme relative to the rest, as a
        /// length (converted to a Jacobian ratio by the dimension).
        #[serde(default)]
        size_ratio: Option<f64>,
        /// The same as an area (2D) or volume (3D) ratio.
        #[serde(default)]
        jacobian_ratio: Option<f64>,
        /// Passes of a 3×3 box filter over the picture first.
        #[serde(default)]
        smooth: usize,
    },
    /// Small cells along an interface.
    Interface {
        /// A curve (2D) or surface (3D), as in `[[boundary]]` shapes.
        #[serde(default)]
        shape: Option<toml::Value>,
        /// Or a level set φ(x, y, z) = 0.
        #[serde(default)]
        level_set: Option<String>,
        /// Width of the band of small cells (the 1/e distance).
        width: f64,
        /// Smallest to background cell size, as a length.
        #[serde(default)]
        size_ratio: Option<f64>,
        /// The same as an area (2D) or volume (3D) ratio.
        #[serde(default)]
        jacobian_ratio: Option<f64>,
    },
    /// The smallest of the fields in `of`.
    Min {
        /// The fields.
        of: Vec<FieldSpec>,
    },
    /// The product of the fields in `of`.
    Product {
        /// The fields.
        of: Vec<FieldSpec>,
    },
}

impl Default for FieldSpec {
    fn default() -> Self {
        FieldSpec::Uniform {}
    }
}

/// The Jacobian ratio from exactly one of a length and a Jacobian ratio.
fn jacobian_ratio(size: Option<f64>, jac: Option<f64>, dim: usize, here: &str) -> Result<f64, String> {
    match (size, jac) {
        (Some(s), None) if s > 0.0 && s.is_finite() => Ok(s.powi(dim as i32)),
        (None, Some(j)) if j > 0.0 && j.is_finite() => Ok(j),
        (Some(v), None) | (None, Some(v)) => Err(format!("{here}: the ratio must be a positive number, got {v}")),
        (Some(_), Some(_)) => Err(format!("{here}: give `size_ratio` or `jacobian_ratio`, not both")),
        (None, None) => Err(format!("{here}: needs `size_ratio` (a length ratio) or `jacobian_ratio` (an area/volume ratio)")),
    }
}

impl FieldSpec {
    /// Builds the target; `here` names the field in errors (`jacobian`,
    /// `jacobian.of[1]`, ...).
    fn build(&self, here: &str, dim: usize, base_dir: &Path) -> Result<Target, String> {
        Ok(match self {
            FieldSpec::Uniform {} => Target::Uniform,
            FieldSpec::Expression { f } => Target::Expression(Expr::parse(f, &EXPR_VARS).map_err(|e| format!("field `{here}.f`: {e}"))?),
            FieldSpec::Image { file, lower, upper, small, size_ratio, jacobian_ratio: jr, smooth } => {
                let r = jacobian_ratio(*size_ratio, *jr, dim, &format!("field `{here}`"))?;
                let image = ImageField::open(&base_dir.join(file), *lower, *upper, r, *small, *smooth).map_err(|e| match e {
                    JacobianError::Image { .. } => format!("field `{here}.file`: {e}"),
                    other => format!("field `{here}`: {other}"),
                })?;
                Target::Image(image)
            }
            FieldSpec::Interface { shape, level_set, width, size_ratio, jacobian_ratio: jr } => {
                let r = jacobian_ratio(*size_ratio, *jr, dim, &format!("field `{here}`"))?;
                let locus = match (shape, level_set) {
                    (Some(v), None) if dim == 2 => Locus::Curve(spec_from_toml(v, &format!("{here}.shape"), ShapeSpec::build)?),
                    (Some(v), None) => Locus::Surface(spec_from_toml(v, &format!("{here}.shape"), SurfaceSpec::build)?),
                    (None, Some(text)) => {
                        let phi = Expr::parse(text, &EXPR_VARS).map_err(|e| format!("field `{here}.level_set`: {e}"))?;
                        Locus::LevelSet(LevelSet::new(phi).map_err(|e| format!("field `{here}.level_set`: {e}"))?)
                    }
                    _ => return Err(format!("field `{here}`: an interface needs exactly one of `shape` and `level_set`")),
                };
                Target::Interface(Interface::new(locus, *width, r).map_err(|e| format!("field `{here}`: {e}"))?)
            }
            FieldSpec::Min { of } | FieldSpec::Product { of } => {
                if of.is_empty() {
                    return Err(format!("field `{here}.of`: lists no fields"));
                }
                let parts = of.iter().enumerate().map(|(k, f)| f.build(&format!("{here}.of[{k}]"), dim, base_dir)).collect::<Result<Vec<_>, _>>()?;
                if parts.iter().any(Target::uses_time) {
                    return Err(format!("field `{here}`: t may only appear in an expression that is the whole field, not inside `of`"));
                }
                if matches!(self, FieldSpec::Min { .. }) { Target::Min(parts) } else { Target::Product(parts) }
            }
        })
    }
}

/// The `[time]` table.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeSpec {
    /// Nominal steps from t = 0 to 1.
    #[serde(default = "default_steps")]
    pub steps: usize,
    /// `euler` or `heun`.
    #[serde(default)]
    pub integrator: Integrator,
    /// Weight of the div term of the functional.
    #[serde(default = "one")]
    pub div_weight: f64,
    /// `auto` (default), `cholesky`, `cg` or `amg`.
    #[serde(default)]
    pub solver: SolverChoice,
    /// Relative residual at which CG (`cg`, `amg`) stops.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
}

fn default_tolerance() -> f64 {
    crate::solve::DEFAULT_TOLERANCE
}

fn default_steps() -> usize {
    40
}

fn one() -> f64 {
    1.0
}

impl Default for TimeSpec {
    fn default() -> Self {
        TimeSpec { steps: default_steps(), integrator: Integrator::Euler, div_weight: 1.0, solver: SolverChoice::Auto, tolerance: default_tolerance() }
    }
}

/// The `[highorder]` table.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HighOrderSpec {
    /// Element order p, 1 ..= 4.
    pub order: usize,
    /// `equispaced` (default) or `gauss_lobatto` element nodes.
    #[serde(default)]
    pub spacing: Spacing,
    /// Steps of Algorithm 2 (default: half those of Algorithm 1, at least 4).
    #[serde(default)]
    pub steps: Option<usize>,
    /// Settle the sliding nodes at their intended places after Algorithm 2
    /// (default true; see [`CurveOptions::settle`]).
    #[serde(default = "yes")]
    pub settle: bool,
}

fn yes() -> bool {
    true
}

/// The `[output]` table.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Pseudo-times at which to draw frames (e.g. [0, 0.3, 0.6, 1]).
    #[serde(default)]
    pub frames: Vec<f64>,
    /// Write an animated GIF of the run (frames every few steps).
    #[serde(default)]
    pub animation: bool,
    /// Picture width in pixels.
    #[serde(default = "default_width")]
    pub width: u32,
    /// 3D: where the picture is seen from.
    #[serde(default)]
    pub camera: Option<CameraSpec>,
    /// 3D: cut the picture open with a plane (cells on the side the
    /// normal points to are left out).
    #[serde(default)]
    pub clip: Option<ClipSpec>,
    /// What colours the cells: `jf` (default) or `size`.
    #[serde(default)]
    pub colour: Colour,
}

/// What the pictures colour cells by.
#[derive(Clone, Copy, Debug, Deserialize, Default, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Colour {
    /// J/f, achieved over prescribed Jacobian: 1 is perfect.
    #[default]
    Jf,
    /// Cell size over its starting size: where adaptation put small cells.
    Size,
}

impl Colour {
    /// The label above the colour bar.
    pub fn label(self) -> &'static str {
        match self {
            Colour::Jf => "J/f",
            Colour::Size => "size/start",
        }
    }
}

/// The camera of 3D pictures.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Degrees about the z axis (0 looks along +y).
    pub azimuth: f64,
    /// Degrees above the xy plane.
    pub elevation: f64,
    /// Perspective distance in bounding-sphere radii (orthographic if absent).
    #[serde(default)]
    pub distance: Option<f64>,
}

/// A clip plane for 3D pictures.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipSpec {
    /// A point of the plane.
    pub point: [f64; 3],
    /// Its normal: cells on this side are left out.
    pub normal: [f64; 3],
}

fn default_width() -> u32 {
    900
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec { frames: Vec::new(), animation: false, width: default_width(), camera: None, clip: None, colour: Colour::Jf }
    }
}

/// The largest starting mesh a case may ask for, in nodes.
pub const MAX_NODES: usize = 50_000_000;

/// A case translated into what the method needs, for a mesh `M` in D
/// dimensions.
pub struct Setup<M = QuadMesh, const D: usize = 2> {
    /// Name for titles and the report.
    pub name: String,
    /// The starting mesh, boundary edges (faces) tagged with part indices.
    pub mesh: M,
    /// The boundary parts.
    pub parts: Vec<BoundaryPart<D>>,
    /// The prescribed Jacobian.
    pub field: JacobianField,
    /// Options of Algorithm 1.
    pub options: DeformOptions,
    /// Output options.
    pub output: OutputSpec,
    /// Algorithms 2 and 3, if asked for.
    pub highorder: Option<CurveOptions>,
}

/// A 2D or a 3D setup, by the kind of its elements.
pub enum AnySetup {
    /// Quadrilaterals.
    Quad(Setup<QuadMesh, 2>),
    /// Triangles.
    Tri(Setup<TriMesh, 2>),
    /// Hexahedra.
    Hex(Setup<HexMesh, 3>),
    /// Tetrahedra.
    Tet(Setup<TetMesh, 3>),
    /// Prisms, pyramids or mixed solids, moved through their tetrahedra.
    Cut(Setup<CutSolid, 3>),
    /// Quadrilaterals and triangles, moved through triangles.
    CutPlane(Setup<CutPlane, 2>),
}

impl AnySetup {
    /// The case's name.
    pub fn name(&self) -> &str {
        match self {
            AnySetup::Quad(s) => &s.name,
            AnySetup::Tri(s) => &s.name,
            AnySetup::Hex(s) => &s.name,
            AnySetup::Tet(s) => &s.name,
            AnySetup::Cut(s) => &s.name,
            AnySetup::CutPlane(s) => &s.name,
        }
    }
}

impl Case {
    /// Reads and parses a case file.
    pub fn read(path: &Path) -> Result<Case, CaseError> {
        let text = std::fs::read_to_string(path).map_err(|e| CaseError { file: path.display().to_string(), message: format!("cannot read: {e}") })?;
        Case::parse(&text, &path.display().to_string())
    }

    /// Parses case text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Case, CaseError> {
        let mut case: Case = toml::from_str(text).map_err(|e| CaseError { file: file.to_string(), message: e.to_string().trim_end().to_string() })?;
        case.source = text.to_string();
        Ok(case)
    }

    /// "line N: " for a byte offset of the source, if known.
    fn line_of(&self, offset: usize) -> String {
        if self.source.len() < offset {
            return String::new();
        }
        format!("line {}: ", self.source[..offset].matches('\n').count() + 1)
    }

    /// The number of dimensions (2 or 3), from the mesh table.
    pub fn dimension(&self, file: &str) -> Result<usize, CaseError> {
        let m = &self.mesh;
        let d = m.lower.len();
        if !(d == 2 || d == 3) || m.upper.len() != d || m.cells.len() != d {
            return Err(CaseError {
                file: file.to_string(),
                message: format!(
                    "fields `mesh.lower`, `mesh.upper`, `mesh.cells`: expected two numbers each (2D) or three each (3D), got {}, {}, {}",
                    m.lower.len(),
                    m.upper.len(),
                    m.cells.len()
                ),
            });
        }
        Ok(d)
    }

    /// Checks a 2D case and builds mesh, parts and field. Relative paths
    /// (images) are resolved against `base_dir`.
    pub fn setup(&self, file: &str, base_dir: &Path) -> Result<Setup, CaseError> {
        match self.setup_any(file, base_dir)? {
            AnySetup::Quad(s) => Ok(s),
            _ => Err(CaseError { file: file.to_string(), message: "a 2D case of quadrilaterals was expected".into() }),
        }
    }

    /// Checks a 2D or 3D case and builds mesh, parts and field.
    pub fn setup_any(&self, file: &str, base_dir: &Path) -> Result<AnySetup, CaseError> {
        let err = |message: String| CaseError { file: file.to_string(), message };
        let dim = self.dimension(file)?;
        let m = &self.mesh;
        if m.cells.contains(&0) {
            return Err(err("field `mesh.cells`: every count must be at least 1".into()));
        }
        let nodes = m.cells.iter().try_fold(1usize, |acc, &n| acc.checked_mul(n.checked_add(1)?));
        if nodes.is_none_or(|n| n > MAX_NODES) {
            return Err(err(format!("field `mesh.cells`: {:?} cells is more than this tool handles (at most {MAX_NODES} nodes)", m.cells)));
        }
        if m.lower.iter().chain(&m.upper).any(|v| !v.is_finite()) {
            return Err(err("fields `mesh.lower`/`mesh.upper`: must be finite numbers".into()));
        }
        if (0..dim).any(|k| m.upper[k] <= m.lower[k]) {
            return Err(err("fields `mesh.lower`/`mesh.upper`: upper must exceed lower along every axis".into()));
        }
        if self.time.steps == 0 {
            return Err(err("field `time.steps`: must be at least 1".into()));
        }
        if !(self.time.div_weight > 0.0 && self.time.div_weight.is_finite()) {
            return Err(err("field `time.div_weight`: must be a positive number".into()));
        }
        if !(self.time.tolerance > 0.0 && self.time.tolerance < 1.0) {
            return Err(err(format!("field `time.tolerance`: must lie in (0, 1), got {}", self.time.tolerance)));
        }
        if let Some(t) = self.output.frames.iter().find(|t| !(0.0..=1.0).contains(*t)) {
            return Err(err(format!("field `output.frames`: {t} is outside [0, 1]")));
        }
        if self.output.width < 200 {
            return Err(err("field `output.width`: must be at least 200 pixels".into()));
        }
        if dim == 2 && (self.output.camera.is_some() || self.output.clip.is_some()) {
            return Err(err("fields `output.camera` and `output.clip` are for 3D cases".into()));
        }
        let field = self.field(file, base_dir, dim)?;
        let highorder = match &self.highorder {
            None => None,
            Some(h) => {
                check_order(h.order).map_err(|e| err(format!("field `highorder.order`: {e}")))?;
                if h.steps == Some(0) {
                    return Err(err("field `highorder.steps`: must be at least 1".into()));
                }
                let steps = h.steps.unwrap_or((self.time.steps / 2).max(4));
                let flow = DeformOptions { integrator: self.time.integrator, div_weight: self.time.div_weight, solver: self.time.solver, tolerance: self.time.tolerance, ..Default::default() };
                Some(CurveOptions { order: h.order, spacing: h.spacing, steps: Some(steps), settle: h.settle, flow, ..Default::default() })
            }
        };
        let mut output = self.output.clone();
        output.frames.sort_by(f64::total_cmp);
        output.frames.dedup();
        // frames are files named by t to two decimals: those must differ
        if let Some(w) = output.frames.windows(2).find(|w| format!("{:.2}", w[0]) == format!("{:.2}", w[1])) {
            return Err(err(format!("field `output.frames`: {} and {} would both be written as frame_t{:.2}.png", w[0], w[1], w[0])));
        }
        let name = self.name.clone().unwrap_or_else(|| Path::new(file).file_stem().map_or("case".into(), |s| s.to_string_lossy().into_owned()));
        let options = DeformOptions {
            steps: self.time.steps,
            integrator: self.time.integrator,
            div_weight: self.time.div_weight,
            solver: self.time.solver,
            tolerance: self.time.tolerance,
            ..Default::default()
        };
        let kind = m.elements.unwrap_or(if dim == 2 { ElementsSpec::Quadrilateral } else { ElementsSpec::Hexahedron });
        if let Some(made) = kind.shape().map(|s| s.dim()).filter(|&d| d != dim) {
            let named = format!("{kind:?}").to_lowercase();
            return Err(err(format!("field `mesh.elements`: `{named}` elements make a {made}D mesh, but `mesh.lower` has {dim} numbers")));
        }
        let check = |points: &mut dyn Iterator<Item = [f64; 3]>| check_positive(&field, points).map_err(|e| err(format!("field `jacobian`: {e}")));
        if dim == 2 {
            let (lo, hi) = ([m.lower[0], m.lower[1]], [m.upper[0], m.upper[1]]);
            let (parts, side_part) = self.parts(file, &BOX_SIDES)?;
            let names: Vec<String> = parts.iter().map(|p| p.name.clone()).collect();
            // re-tag the box's side indices with part indices
            let retag = |edges: &mut Vec<crate::mesh::BoundaryEdge>| edges.iter_mut().for_each(|e| e.part = side_part[e.part]);
            if kind == ElementsSpec::Mixed {
                let mut mesh = CurvedMesh::checkerboard(lo, hi, m.cells[0], m.cells[1]);
                mesh.boundary.parts_mut().iter_mut().for_each(|part| *part = side_part[*part]);
                mesh.part_names = names;
                let mesh = CutPlane::new(mesh);
                check(&mut plane_points(mesh.simplices()))?;
                return Ok(AnySetup::CutPlane(Setup { name, mesh, parts, field, options, output, highorder }));
            }
            if kind == ElementsSpec::Triangle {
                let mut mesh = TriMesh::structured_box(lo, hi, m.cells[0], m.cells[1]);
                retag(&mut mesh.edges);
                mesh.part_names = names;
                check(&mut plane_points(&mesh))?;
                return Ok(AnySetup::Tri(Setup { name, mesh, parts, field, options, output, highorder }));
            }
            let mut mesh = QuadMesh::structured_box(lo, hi, m.cells[0], m.cells[1]);
            retag(&mut mesh.edges);
            mesh.part_names = names;
            check(&mut plane_points(&mesh))?;
            return Ok(AnySetup::Quad(Setup { name, mesh, parts, field, options, output, highorder }));
        }
        let (lo, hi, n) = ([m.lower[0], m.lower[1], m.lower[2]], [m.upper[0], m.upper[1], m.upper[2]], [m.cells[0], m.cells[1], m.cells[2]]);
        let (parts, face_part) = self.parts(file, &BOX_FACES)?;
        let names: Vec<String> = parts.iter().map(|p| p.name.clone()).collect();
        if kind == ElementsSpec::Hexahedron {
            let mut mesh = HexMesh::structured_box(lo, hi, n);
            mesh.faces.iter_mut().for_each(|f| f.part = face_part[f.part]);
            mesh.part_names = names;
            check(&mut solid_points(&mesh))?;
            return Ok(AnySetup::Hex(Setup { name, mesh, parts, field, options, output, highorder }));
        }
        let mut solid = match kind.shape() {
            Some(shape) => CurvedMesh::brick(lo, hi, n, shape).expect("a solid kind"),
            None => CurvedMesh::hex_prism_box(lo, hi, n),
        };
        solid.boundary.parts_mut().iter_mut().for_each(|part| *part = face_part[*part]);
        solid.part_names = names;
        if let Some(mesh) = solid.to_solid() {
            check(&mut solid_points(&mesh))?;
            return Ok(AnySetup::Tet(Setup { name, mesh, parts, field, options, output, highorder }));
        }
        let mesh = CutSolid::new(solid);
        check(&mut solid_points(mesh.simplices()))?;
        Ok(AnySetup::Cut(Setup { name, mesh, parts, field, options, output, highorder }))
    }

    /// Boundary parts, and for each box side (face) the index of its part.
    fn parts<const D: usize>(
        &self,
        file: &str,
        sides: &[&str],
    ) -> Result<(Vec<BoundaryPart<D>>, Vec<usize>), CaseError> {
        let err = |message: String| CaseError { file: file.to_string(), message };
        let mut side_part = vec![usize::MAX; sides.len()];
        let mut parts: Vec<BoundaryPart<D>> = Vec::new();
        for (k, spec) in self.boundary.iter().enumerate() {
            let here = format!("boundary[{k}] (`{}`)", spec.name);
            if spec.name.trim().is_empty() {
                return Err(err(format!("field `boundary[{k}].name`: must not be empty")));
            }
            if parts.iter().any(|p| p.name == spec.name) {
                return Err(err(format!("{here}: the name `{}` is used twice", spec.name)));
            }
            if spec.sides.is_empty() {
                return Err(err(format!("{here}: field `sides` is empty")));
            }
            for side in &spec.sides {
                let Some(s) = sides.iter().position(|b| b == side) else {
                    return Err(err(format!("{here}: unknown side `{side}` in `sides` (expected one of {})", sides.join(", "))));
                };
                if side_part[s] != usize::MAX {
                    let other = if side_part[s] == parts.len() { &spec.name } else { &parts[side_part[s]].name };
                    return Err(err(format!("{here}: side `{side}` is named twice (already in `{other}`)")));
                }
                side_part[s] = parts.len();
            }
            let line = spec.shape.as_ref().map_or(String::new(), |v| self.line_of(v.span().start));
            let kind = part_kind(spec).map_err(|m| err(format!("{line}{here}: {m}")))?;
            parts.push(BoundaryPart::new(spec.name.clone(), kind));
        }
        // sides nobody named stay slip walls under their own name
        for (s, side) in sides.iter().enumerate() {
            if side_part[s] == usize::MAX {
                if parts.iter().any(|p| p.name == *side) {
                    return Err(err(format!("side `{side}` is in no part, but a part is already named `{side}`")));
                }
                tracing::info!("side `{side}` is in no boundary part: it is a slip wall named `{side}`");
                side_part[s] = parts.len();
                parts.push(BoundaryPart::new(*side, PartKind::Slip { wall: None }));
            }
        }
        Ok((parts, side_part))
    }

    fn field(&self, file: &str, base_dir: &Path, dim: usize) -> Result<JacobianField, CaseError> {
        let err = |message: String| CaseError { file: file.to_string(), message };
        let target = self.jacobian.field.build("jacobian", dim, base_dir).map_err(err)?;
        let floor = self.jacobian.floor.unwrap_or(0.0);
        if !(floor >= 0.0 && floor.is_finite()) {
            return Err(err(format!("field `jacobian.floor`: must be a number ≥ 0, got {floor}")));
        }
        Ok(JacobianField { target, path: self.jacobian.path.unwrap_or_default(), floor })
    }
}

/// g must be positive on the starting domain at every pseudo-time; where
/// the domain moves to is checked during the run.
fn check_positive<const D: usize>(field: &JacobianField, points: impl Iterator<Item = [f64; D]>) -> Result<(), crate::jacobian::JacobianError> {
    for x in points {
        for t in [0.0, 0.25, 0.5, 0.75, 1.0] {
            field.g_checked(lift(x), t)?;
        }
    }
    Ok(())
}

/// The nodes and cell centres of a plane mesh, lifted to 3D.
fn plane_points<const N: usize>(mesh: &PlaneMesh<N>) -> impl Iterator<Item = [f64; 3]> + '_ {
    let centres = (0..mesh.num_cells()).map(|c| centroid(&mesh.cell_coords(c)));
    mesh.nodes.iter().copied().chain(centres).map(lift)
}

/// The nodes and cell centres of a solid mesh.
fn solid_points<const N: usize, const K: usize>(mesh: &SolidMesh<N, K>) -> impl Iterator<Item = [f64; 3]> + '_ {
    let centres = (0..mesh.num_cells()).map(|c| centroid(&mesh.cell_coords(c)));
    mesh.nodes.iter().copied().chain(centres)
}

fn centroid<const D: usize, const N: usize>(p: &[[f64; D]; N]) -> [f64; D] {
    std::array::from_fn(|i| p.iter().map(|q| q[i]).sum::<f64>() / N as f64)
}

/// Translates one part's spec into its kind, checking the fields that
/// belong together.
fn part_kind<const D: usize>(spec: &PartSpec) -> Result<PartKind<D>, String> {
    let shape = spec.shape.as_ref().map(|v| shape_from_toml::<D>(v.get_ref())).transpose()?;
    let move_only = spec.correspondence.is_some() || spec.centre.is_some() || spec.direction.is_some() || spec.mode.is_some();
    match spec.kind {
        PartKindSpec::Slip | PartKindSpec::Fixed if move_only => {
            Err("fields `correspondence`, `centre`, `direction` and `mode` belong to kind = \"move\"".into())
        }
        PartKindSpec::Fixed if shape.is_some() => Err("kind = \"fixed\" takes no `shape`".into()),
        PartKindSpec::Fixed => Ok(PartKind::Fixed),
        PartKindSpec::Slip => Ok(PartKind::Slip { wall: shape }),
        PartKindSpec::Move => {
            let target = shape.ok_or("kind = \"move\" needs a `shape` (the target), e.g. shape = { type = \"circle\", centre = [0.0, 0.0], radius = 1.0 }")?;
            let which = spec.correspondence.unwrap_or(CorrespondenceSpec::Normal);
            if spec.centre.is_some() && which != CorrespondenceSpec::Radial {
                return Err("`centre` is only used with correspondence = \"radial\"".into());
            }
            if spec.direction.is_some() && which != CorrespondenceSpec::Along {
                return Err("`direction` is only used with correspondence = \"along\"".into());
            }
            let correspondence = match which {
                CorrespondenceSpec::Normal => Correspondence::Normal,
                CorrespondenceSpec::Along => {
                    let d = spec.direction.as_ref().ok_or(format!("correspondence = \"along\" needs a `direction` with {D} numbers"))?;
                    let direction: [f64; D] = d.as_slice().try_into().map_err(|_| format!("field `direction`: expected {D} numbers, got {}", d.len()))?;
                    if direction.iter().all(|&c| c == 0.0) || direction.iter().any(|c| !c.is_finite()) {
                        return Err("field `direction`: must be a finite, non-zero vector".into());
                    }
                    Correspondence::Along { direction }
                }
                CorrespondenceSpec::Radial => {
                    let c = spec.centre.as_ref().ok_or(format!("correspondence = \"radial\" needs a `centre` with {D} numbers"))?;
                    let centre: [f64; D] = c.as_slice().try_into().map_err(|_| format!("field `centre`: expected {D} numbers, got {}", c.len()))?;
                    if centre.iter().any(|v| !v.is_finite()) {
                        return Err("field `centre`: must be finite numbers".into());
                    }
                    Correspondence::Radial { centre }
                }
            };
            let mode = match spec.mode.unwrap_or(ModeSpec::Sliding) {
                ModeSpec::Sliding => MoveMode::Sliding,
                ModeSpec::Dirichlet => MoveMode::Dirichlet,
            };
            Ok(PartKind::Move { target, correspondence, mode })
        }
    }
}

/// The built-in default case: the seed's Figure 2, the unit square onto
/// the quarter disk of radius 1.25 (`deformesh demo`).
pub const DEMO_CASE: &str = include_str!("../../cases/quarter_disk.toml");
