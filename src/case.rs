//! Case files (TOML): the schema and its translation into a mesh, boundary
//! parts and a prescribed Jacobian.
//!
//! Every table rejects unknown fields, and every error names the file and
//! the field (toml's own errors add the line and column).

use crate::deform::{BoundaryPart, Correspondence, DeformOptions, Integrator, MoveMode, PartKind, BoundaryShape};
use crate::expr::Expr;
use crate::geometry::ShapeSpec;
use crate::jacobian::{lift, ImageField, JacobianField, Target, TimePath, EXPR_VARS};
use crate::mesh::{QuadMesh, BOX_SIDES};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;

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
}

/// A structured box mesh.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// Lower corner.
    pub lower: [f64; 2],
    /// Upper corner.
    pub upper: [f64; 2],
    /// Cells along x and y.
    pub cells: [usize; 2],
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
    /// Box sides: `left`, `right`, `bottom`, `top`.
    pub sides: Vec<String>,
    /// `slip`, `move` or `fixed`.
    pub kind: PartKindSpec,
    /// Target (move) or wall (slip; default: the side itself).
    #[serde(default)]
    pub shape: Option<ShapeSpec>,
    /// `radial` (needs `centre`) or `normal` (default).
    #[serde(default)]
    pub correspondence: Option<CorrespondenceSpec>,
    /// Centre of the radial correspondence.
    #[serde(default)]
    pub centre: Option<[f64; 2]>,
    /// `sliding` (default) or `dirichlet`.
    #[serde(default)]
    pub mode: Option<ModeSpec>,
}

/// The `[jacobian]` table.
#[derive(Clone, Debug, Deserialize, Default)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum JacobianSpec {
    /// f follows only the change of area.
    #[default]
    Uniform,
    /// g₁(x, y) — or g(x, y, t) — as text.
    Expression {
        /// The expression, in x, y and optionally t.
        f: String,
        /// `linear` (default) or `inverse`.
        #[serde(default)]
        path: TimePath,
    },
    /// g₁ from a PNG picture.
    Image {
        /// The PNG, relative to the case file.
        file: PathBuf,
        /// Lower corner of the rectangle the picture covers.
        lower: [f64; 2],
        /// Upper corner.
        upper: [f64; 2],
        /// g₁ on black pixels (white gives 1).
        #[serde(default = "default_floor")]
        floor: f64,
        /// Bright parts small instead of dark ones.
        #[serde(default)]
        invert: bool,
        /// Passes of a 3×3 box filter.
        #[serde(default)]
        smooth: usize,
        /// `linear` (default) or `inverse`.
        #[serde(default)]
        path: TimePath,
    },
}

fn default_floor() -> f64 {
    0.2
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
}

fn default_steps() -> usize {
    40
}

fn one() -> f64 {
    1.0
}

impl Default for TimeSpec {
    fn default() -> Self {
        TimeSpec { steps: default_steps(), integrator: Integrator::Euler, div_weight: 1.0 }
    }
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
}

fn default_width() -> u32 {
    900
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec { frames: Vec::new(), animation: false, width: default_width() }
    }
}

/// A case translated into what the method needs.
pub struct Setup {
    /// Name for titles and the report.
    pub name: String,
    /// The starting mesh, boundary edges tagged with part indices.
    pub mesh: QuadMesh,
    /// The boundary parts.
    pub parts: Vec<BoundaryPart>,
    /// The prescribed Jacobian.
    pub field: JacobianField,
    /// Options of Algorithm 1.
    pub options: DeformOptions,
    /// Output options.
    pub output: OutputSpec,
}

impl Case {
    /// Reads and parses a case file.
    pub fn read(path: &Path) -> Result<Case, CaseError> {
        let text = std::fs::read_to_string(path).map_err(|e| CaseError { file: path.display().to_string(), message: format!("cannot read: {e}") })?;
        Case::parse(&text, &path.display().to_string())
    }

    /// Parses case text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Case, CaseError> {
        toml::from_str(text).map_err(|e| CaseError { file: file.to_string(), message: e.to_string().trim_end().to_string() })
    }

    /// Checks the case and builds mesh, parts and field. Relative paths
    /// (images) are resolved against `base_dir`.
    pub fn setup(&self, file: &str, base_dir: &Path) -> Result<Setup, CaseError> {
        let err = |message: String| CaseError { file: file.to_string(), message };
        let mesh_spec = &self.mesh;
        if mesh_spec.cells[0] == 0 || mesh_spec.cells[1] == 0 {
            return Err(err("field `mesh.cells`: both counts must be at least 1".into()));
        }
        if !(mesh_spec.upper[0] > mesh_spec.lower[0] && mesh_spec.upper[1] > mesh_spec.lower[1]) {
            return Err(err("fields `mesh.lower`/`mesh.upper`: upper must exceed lower in x and y".into()));
        }
        if self.time.steps == 0 {
            return Err(err("field `time.steps`: must be at least 1".into()));
        }
        if !(self.time.div_weight > 0.0 && self.time.div_weight.is_finite()) {
            return Err(err("field `time.div_weight`: must be a positive number".into()));
        }
        if let Some(t) = self.output.frames.iter().find(|t| !(0.0..=1.0).contains(*t)) {
            return Err(err(format!("field `output.frames`: {t} is outside [0, 1]")));
        }
        if self.output.width < 200 {
            return Err(err("field `output.width`: must be at least 200 pixels".into()));
        }
        let mut mesh = QuadMesh::structured_box(mesh_spec.lower, mesh_spec.upper, mesh_spec.cells[0], mesh_spec.cells[1]);
        let (parts, side_part) = self.parts(file)?;
        // re-tag the box's side indices with part indices
        for e in &mut mesh.edges {
            e.part = side_part[e.part];
        }
        mesh.part_names = parts.iter().map(|p| p.name.clone()).collect();
        let field = self.field(file, base_dir)?;
        check_positive(&field, &mesh).map_err(|e| err(format!("field `jacobian`: {e}")))?;
        let mut frames = self.output.frames.clone();
        frames.sort_by(f64::total_cmp);
        frames.dedup();
        Ok(Setup {
            name: self.name.clone().unwrap_or_else(|| Path::new(file).file_stem().map_or("case".into(), |s| s.to_string_lossy().into_owned())),
            mesh,
            parts,
            field,
            options: DeformOptions { steps: self.time.steps, integrator: self.time.integrator, div_weight: self.time.div_weight, ..Default::default() },
            output: OutputSpec { frames, ..self.output.clone() },
        })
    }

    /// Boundary parts, and for each box side the index of its part.
    fn parts(&self, file: &str) -> Result<(Vec<BoundaryPart>, [usize; 4]), CaseError> {
        let err = |message: String| CaseError { file: file.to_string(), message };
        let mut side_part = [usize::MAX; 4];
        let mut parts = Vec::new();
        for (k, spec) in self.boundary.iter().enumerate() {
            let here = format!("boundary[{k}] (`{}`)", spec.name);
            if spec.name.trim().is_empty() {
                return Err(err(format!("field `boundary[{k}].name`: must not be empty")));
            }
            if parts.iter().any(|p: &BoundaryPart| p.name == spec.name) {
                return Err(err(format!("{here}: the name `{}` is used twice", spec.name)));
            }
            if spec.sides.is_empty() {
                return Err(err(format!("{here}: field `sides` is empty")));
            }
            for side in &spec.sides {
                let Some(s) = BOX_SIDES.iter().position(|b| b == side) else {
                    return Err(err(format!("{here}: unknown side `{side}` in `sides` (expected one of left, right, bottom, top)")));
                };
                if side_part[s] != usize::MAX {
                    let other = if side_part[s] == parts.len() { &spec.name } else { &parts[side_part[s]].name };
                    return Err(err(format!("{here}: side `{side}` is named twice (already in `{other}`)")));
                }
                side_part[s] = parts.len();
            }
            let kind = part_kind(spec).map_err(|m| err(format!("{here}: {m}")))?;
            parts.push(BoundaryPart { name: spec.name.clone(), kind });
        }
        // sides nobody named stay slip walls under their own name
        for (s, side) in BOX_SIDES.iter().enumerate() {
            if side_part[s] == usize::MAX {
                if parts.iter().any(|p| p.name == *side) {
                    return Err(err(format!("side `{side}` is in no part, but a part is already named `{side}`")));
                }
                tracing::info!("side `{side}` is in no boundary part: it is a slip wall named `{side}`");
                side_part[s] = parts.len();
                parts.push(BoundaryPart { name: side.to_string(), kind: PartKind::Slip { wall: None } });
            }
        }
        Ok((parts, side_part))
    }

    fn field(&self, file: &str, base_dir: &Path) -> Result<JacobianField, CaseError> {
        let err = |message: String| CaseError { file: file.to_string(), message };
        Ok(match &self.jacobian {
            JacobianSpec::Uniform => JacobianField::uniform(),
            JacobianSpec::Expression { f, path } => {
                let expr = Expr::parse(f, &EXPR_VARS).map_err(|e| err(format!("field `jacobian.f`: {e}")))?;
                JacobianField { target: Target::Expression(expr), path: *path }
            }
            JacobianSpec::Image { file: img, lower, upper, floor, invert, smooth, path } => {
                let full = base_dir.join(img);
                let image = ImageField::open(&full, *lower, *upper, *floor, *invert, *smooth).map_err(|e| err(format!("field `jacobian.file`: {e}")))?;
                JacobianField { target: Target::Image(image), path: *path }
            }
        })
    }
}

/// g must be positive on the starting domain at every pseudo-time; where
/// the domain moves to is checked during the run.
fn check_positive(field: &JacobianField, mesh: &QuadMesh) -> Result<(), crate::jacobian::JacobianError> {
    let centres = (0..mesh.num_cells()).map(|c| {
        let p = mesh.cell_coords(c);
        [0.25 * (p[0][0] + p[1][0] + p[2][0] + p[3][0]), 0.25 * (p[0][1] + p[1][1] + p[2][1] + p[3][1])]
    });
    for x in mesh.nodes.iter().copied().chain(centres) {
        for t in [0.0, 0.25, 0.5, 0.75, 1.0] {
            field.g_checked(lift(x), t)?;
        }
    }
    Ok(())
}

/// Translates one part's spec into its kind, checking the fields that
/// belong together.
fn part_kind(spec: &PartSpec) -> Result<PartKind, String> {
    let shape = match &spec.shape {
        Some(s) => Some(Arc::new(s.build().map_err(|e| format!("field `shape`: {e}"))?) as Arc<dyn BoundaryShape<2>>),
        None => None,
    };
    let move_only = spec.correspondence.is_some() || spec.centre.is_some() || spec.mode.is_some();
    match spec.kind {
        PartKindSpec::Slip | PartKindSpec::Fixed if move_only => {
            Err("fields `correspondence`, `centre` and `mode` belong to kind = \"move\"".into())
        }
        PartKindSpec::Fixed if shape.is_some() => Err("kind = \"fixed\" takes no `shape`".into()),
        PartKindSpec::Fixed => Ok(PartKind::Fixed),
        PartKindSpec::Slip => Ok(PartKind::Slip { wall: shape }),
        PartKindSpec::Move => {
            let target = shape.ok_or("kind = \"move\" needs a `shape` (the target), e.g. shape = { type = \"circle\", centre = [0.0, 0.0], radius = 1.0 }")?;
            let correspondence = match spec.correspondence.unwrap_or(CorrespondenceSpec::Normal) {
                CorrespondenceSpec::Normal if spec.centre.is_some() => return Err("`centre` is only used with correspondence = \"radial\"".into()),
                CorrespondenceSpec::Normal => Correspondence::Normal,
                CorrespondenceSpec::Radial => Correspondence::Radial {
                    centre: spec.centre.ok_or("correspondence = \"radial\" needs a `centre` = [x, y]")?,
                },
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
pub const DEMO_CASE: &str = include_str!("../cases/quarter_disk.toml");
