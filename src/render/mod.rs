//! Pictures of a mesh coloured by a per-cell value (typically J/f, the
//! ratio of the cell's Jacobian to its target), as PNG images or animated
//! GIFs.
//!
//! A picture shows the cells filled by a [`ColourMap`], thin cell edges, a
//! thicker boundary, a vertical colour bar with five labelled ticks on the
//! right, and an optional title on top. The y axis points up. Text uses a
//! small built-in bitmap font ([`font`]), since tiny-skia has none.
//!
//! Hexahedral meshes are drawn by [`render_hex`]: the shaded boundary
//! surface seen by a [`Camera`], optionally cut open by a [`ClipPlane`],
//! with the same colour bar and title.
//!
//! Curved high-order meshes ([`CurvedMesh`](crate::mesh::CurvedMesh))
//! are drawn by [`render_curved_quads`] and [`render_curved_hex`], which
//! follow the true Lagrange edges and faces of each element.

mod colour;
mod curved;
mod draw;
mod encode;
pub mod font;
mod hex;
mod layout;
mod legend;
#[cfg(test)]
mod tests;

use tiny_skia::{Color, Pixmap};

pub use colour::ColourMap;
pub use curved::{render_curved_hex, render_curved_quads};
pub use encode::{gif_bytes, png_bytes, write_gif, write_png};
pub use hex::{render_hex, Camera, ClipPlane, RenderOptions3};

use crate::mesh::QuadMesh;
use layout::Layout;

/// Colour of lines (edges, ticks, the colour-bar frame): a soft black.
fn ink() -> Color {
    Color::from_rgba8(25, 25, 25, 255)
}

/// Colour of text.
fn text_colour() -> Color {
    Color::from_rgba8(20, 20, 20, 255)
}

/// Errors from rendering or encoding pictures.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The number of values differs from the number of cells.
    #[error("{values} cell values given for {cells} cells")]
    LengthMismatch {
        /// Number of values given.
        values: usize,
        /// Number of cells in the mesh.
        cells: usize,
    },
    /// A cell value is NaN or infinite.
    #[error("cell value {index} is not finite")]
    NonFiniteValue {
        /// Index of the offending cell.
        index: usize,
    },
    /// A node coordinate is NaN or infinite.
    #[error("node {index} has non-finite coordinates")]
    NonFiniteNode {
        /// Index of the offending node.
        index: usize,
    },
    /// A curved mesh that cannot be drawn: an element order outside
    /// `1..=MAX_ORDER`, or a cell or boundary element with the wrong number
    /// of nodes.
    #[error("curved mesh cannot be drawn: {reason}")]
    InvalidCurvedMesh {
        /// What is wrong with it.
        reason: String,
    },
    /// A cell refers to a node that does not exist.
    #[error("cell {cell} refers to node {node}, but the mesh has {nodes} nodes")]
    BadNodeIndex {
        /// Index of the offending cell.
        cell: usize,
        /// The node index it uses.
        node: usize,
        /// Number of nodes in the mesh.
        nodes: usize,
    },
    /// The world box is not finite or has no area (also for a mesh with
    /// no nodes or all nodes on a line, when no box is given).
    #[error("bounds {lo:?}..{hi:?} are not a finite box with positive area")]
    InvalidBounds {
        /// Lower-left corner.
        lo: [f64; 2],
        /// Upper-right corner.
        hi: [f64; 2],
    },
    /// The 3D world box is not finite or is a single point (also for a hex
    /// mesh with no nodes, when no box is given).
    #[error("bounds {lo:?}..{hi:?} are not a finite box of positive size")]
    InvalidBounds3 {
        /// Lower corner.
        lo: [f64; 3],
        /// Upper corner.
        hi: [f64; 3],
    },
    /// The camera cannot give a picture: an angle is not finite, the
    /// elevation is outside ±90°, or the perspective distance is not finite
    /// or puts the eye inside the framed box's bounding sphere (≤ 1).
    #[error("degenerate camera: {reason}")]
    InvalidCamera {
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The clip plane's point or normal is not finite, or the normal is
    /// zero.
    #[error("clip plane through {point:?} with normal {normal:?} is degenerate")]
    InvalidClipPlane {
        /// The point given.
        point: [f64; 3],
        /// The normal given.
        normal: [f64; 3],
    },
    /// The colour range is not finite or is reversed.
    #[error("colour range {low}..{high} is not a finite, increasing range")]
    InvalidRange {
        /// Low end.
        low: f64,
        /// High end.
        high: f64,
    },
    /// The image would be too small to lay out or too large to allocate
    /// (or, for a GIF, larger than 65535 pixels in a direction).
    #[error("cannot make a {width}×{height} image")]
    ImageSize {
        /// Requested width.
        width: u32,
        /// Requested height (0 if not computed yet).
        height: u32,
    },
    /// An animation was given no frames.
    #[error("an animation needs at least one frame")]
    NoFrames,
    /// Animation frames differ in size.
    #[error("frame {index} is {found:?} pixels, but frame 0 is {expected:?}")]
    FrameSize {
        /// Index of the first frame with a different size.
        index: usize,
        /// Size of frame 0 (width, height).
        expected: (u32, u32),
        /// Size of the offending frame.
        found: (u32, u32),
    },
    /// PNG encoding failed.
    #[error("PNG encoding failed: {0}")]
    Png(String),
    /// GIF encoding failed.
    #[error("GIF encoding failed")]
    Gif(#[from] gif::EncodingError),
    /// Writing a file failed.
    #[error("writing the image failed")]
    Io(#[from] std::io::Error),
}

/// What to draw and how.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Image width in pixels (at least 200). The height follows from the
    /// aspect ratio of the bounds plus room for the title and colour bar.
    pub width: u32,
    /// World box to frame, as (lower-left, upper-right); `None` frames the
    /// mesh's bounding box. Give all frames of an animation the same box so
    /// they line up.
    pub bounds: Option<([f64; 2], [f64; 2])>,
    /// Colour range (low, high); `None` uses the min and max of the values.
    /// Values outside are shown in the colour of the nearer end. Give all
    /// frames of an animation the same range so colours compare.
    pub range: Option<(f64, f64)>,
    /// The colour map; `None` picks one with [`ColourMap::auto`].
    pub colour_map: Option<ColourMap>,
    /// Label drawn above the colour bar, e.g. "J/f".
    pub label: String,
    /// Title drawn at the top, e.g. "t = 0.30".
    pub title: Option<String>,
    /// Whether to draw the edges between cells (they are left out anyway
    /// when cells are under about 3 pixels across). The boundary is always
    /// drawn.
    pub draw_edges: bool,
}

impl Default for RenderOptions {
    /// 900 pixels wide, framing the mesh, automatic range and colour map,
    /// labelled "J/f", no title, edges drawn.
    fn default() -> Self {
        RenderOptions {
            width: 900,
            bounds: None,
            range: None,
            colour_map: None,
            label: "J/f".to_string(),
            title: None,
            draw_edges: true,
        }
    }
}

/// Draws `mesh` with cell `c` filled by the colour of `cell_values[c]`,
/// plus edges, boundary, colour bar and title as set in `opts`.
///
/// Fails (never panics) if the number of values differs from the number
/// of cells, if a value, node, bound or range is not finite, if a cell
/// refers to a missing node, or if the image size is unusable.
pub fn render_mesh(
    mesh: &QuadMesh,
    cell_values: &[f64],
    opts: &RenderOptions,
) -> Result<Pixmap, RenderError> {
    let plan = Plan::new(mesh, cell_values, opts)?;
    let layout = &plan.layout;
    let mut pixmap = canvas(layout)?;
    let clip = draw::plot_clip(layout);
    draw::cells(
        &mut pixmap,
        layout,
        mesh,
        cell_values,
        plan.cmap,
        plan.range,
        clip.as_ref(),
    );
    draw::edges(&mut pixmap, layout, mesh, opts.draw_edges, clip.as_ref());
    let legend = Legend { cmap: plan.cmap, range: plan.range, tick_labels: &plan.tick_labels, label: &opts.label, title: opts.title.as_deref() };
    decorate(&mut pixmap, layout, &legend);
    Ok(pixmap)
}

/// A white picture of the layout's size.
fn canvas(layout: &Layout) -> Result<Pixmap, RenderError> {
    let size_error = RenderError::ImageSize { width: layout.width, height: layout.height };
    let mut pixmap = Pixmap::new(layout.width, layout.height).ok_or(size_error)?;
    pixmap.fill(Color::WHITE);
    Ok(pixmap)
}

/// What surrounds a plot: its colour bar and title.
struct Legend<'a> {
    cmap: ColourMap,
    range: (f64, f64),
    tick_labels: &'a [String],
    label: &'a str,
    title: Option<&'a str>,
}

/// Draws the colour bar and the title around a drawn plot (2D and 3D).
fn decorate(pixmap: &mut Pixmap, layout: &Layout, legend: &Legend) {
    legend::draw_colour_bar(pixmap, layout, legend.cmap, legend.range, legend.tick_labels, legend.label);
    if let Some(title) = legend.title {
        draw_title(pixmap, layout, title);
    }
}

/// Everything decided before drawing: validated inputs turned into a
/// colour range, colour map, tick labels and layout.
struct Plan {
    range: (f64, f64),
    cmap: ColourMap,
    tick_labels: Vec<String>,
    layout: Layout,
}

impl Plan {
    fn new(
        mesh: &QuadMesh,
        cell_values: &[f64],
        opts: &RenderOptions,
    ) -> Result<Plan, RenderError> {
        validate(mesh, cell_values)?;
        let range = resolve_range(cell_values, opts.range)?;
        let bounds = resolve_bounds(mesh, opts.bounds)?;
        let cmap = opts.colour_map.unwrap_or_else(|| ColourMap::auto(range));
        let tick_labels = legend::format_ticks(&legend::tick_values(range));
        let layout = Layout::new(
            opts.width,
            bounds,
            opts.title.is_some(),
            &opts.label,
            &tick_labels,
        )?;
        Ok(Plan {
            range,
            cmap,
            tick_labels,
            layout,
        })
    }
}

/// One finite value per cell: what every renderer's colours need.
pub(crate) fn check_values(values: &[f64], cells: usize) -> Result<(), RenderError> {
    if values.len() != cells {
        return Err(RenderError::LengthMismatch { values: values.len(), cells });
    }
    if let Some(index) = values.iter().position(|v| !v.is_finite()) {
        return Err(RenderError::NonFiniteValue { index });
    }
    Ok(())
}

/// Checks that values match cells and everything is finite and in range,
/// so drawing cannot index out of bounds or produce garbage.
fn validate(mesh: &QuadMesh, values: &[f64]) -> Result<(), RenderError> {
    check_values(values, mesh.cells.len())?;
    if let Some(index) = mesh
        .nodes
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(RenderError::NonFiniteNode { index });
    }
    let nodes = mesh.nodes.len();
    let bad_cell = mesh
        .cells
        .iter()
        .enumerate()
        .find_map(|(cell, c)| c.iter().find(|&&n| n >= nodes).map(|&node| (cell, node)));
    let bad_edge = mesh.edges.iter().find_map(|e| {
        e.nodes
            .iter()
            .find(|&&n| n >= nodes)
            .map(|&node| (usize::MAX, node))
    });
    match bad_cell.or(bad_edge) {
        Some((cell, node)) => Err(RenderError::BadNodeIndex { cell, node, nodes }),
        None => Ok(()),
    }
}

/// The colour range: the given one, or the min and max of the values.
/// A zero-width range is widened (by 5 %, or by 0.5 around zero) so the
/// bar still has distinct ticks.
fn resolve_range(values: &[f64], given: Option<(f64, f64)>) -> Result<(f64, f64), RenderError> {
    let (low, high) = given.unwrap_or_else(|| {
        let min = values.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        // No values at all: any range will do; show the ideal J/f band.
        if values.is_empty() {
            (0.5, 1.5)
        } else {
            (min, max)
        }
    });
    if !(low.is_finite() && high.is_finite() && low <= high) {
        return Err(RenderError::InvalidRange { low, high });
    }
    if low < high {
        return Ok((low, high));
    }
    let pad = if low == 0.0 { 0.5 } else { 0.05 * low.abs() };
    Ok((low - pad, high + pad))
}

/// The world box: the given one, or the mesh's bounding box; it must be
/// finite with positive width and height.
fn resolve_bounds(
    mesh: &QuadMesh,
    given: Option<([f64; 2], [f64; 2])>,
) -> Result<([f64; 2], [f64; 2]), RenderError> {
    let (lo, hi) = given.unwrap_or_else(|| {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for p in &mesh.nodes {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    });
    let ok = (0..2).all(|k| lo[k].is_finite() && hi[k].is_finite() && hi[k] > lo[k]);
    if ok {
        Ok((lo, hi))
    } else {
        Err(RenderError::InvalidBounds { lo, hi })
    }
}

/// The title, one font step larger than the labels, centred over the plot
/// but kept inside the image.
fn draw_title(pixmap: &mut Pixmap, layout: &Layout, title: &str) {
    let s = layout.text_scale + 1;
    let w = font::text_width(title, s) as f64;
    let centre = layout.plot[0] + 0.5 * layout.plot[2];
    let max_x = (layout.width as f64 - layout.margin - w).max(0.0);
    let x = (centre - 0.5 * w).clamp(layout.margin.min(max_x), max_x);
    font::draw_text(pixmap, title, x as i32, layout.title_top, s, text_colour());
}
