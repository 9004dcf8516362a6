//! Pictures of a mesh of any order coloured by a per-cell value
//! (typically J/f, the ratio of the cell's Jacobian to its target), as PNG
//! images or animated GIFs.
//!
//! Meshes are [`CurvedMesh`]es of order `p`; a linear mesh is the case
//! `p = 1` ([`CurvedMesh::from_quads`], [`CurvedMesh::from_hexes`]). There
//! is one plan per dimension:
//!
//! - [`render_quads`] fills each cell (quads, triangles, or both in a
//!   mixed mesh) with the colour of its value over the region bounded by
//!   its true edges, and draws thin cell edges and a thicker boundary;
//!   the y axis points up.
//! - [`render_hexes`] draws the shaded boundary surface seen by a
//!   [`Camera`], optionally cut open by a [`ClipPlane`].
//!
//! Both add a vertical colour bar with five labelled ticks on the right and
//! an optional title on top. Text uses a small built-in bitmap font
//! ([`font`]), since tiny-skia has none.
//!
//! Both check what they index or divide by and fail with a [`RenderError`],
//! never panic, if the number of values differs from the number of cells,
//! if a value, node, bound or range is not finite, if the order is
//! unsupported or an element has the wrong number of nodes, if an element
//! refers to a missing node, or if the image size is unusable; in 3D also
//! if the camera or clip plane is degenerate.

/// The [`Style`] of [`RenderOptions`] or [`RenderOptions3`], which share
/// these fields.
macro_rules! style {
    ($opts:expr) => {
        Style {
            width: $opts.width,
            range: $opts.range,
            colour_map: $opts.colour_map,
            label: &$opts.label,
            title: $opts.title.as_deref(),
        }
    };
}

mod colour;
mod encode;
pub mod font;
mod hex;
mod layout;
mod legend;
mod quads;
#[cfg(test)]
mod tests;

use tiny_skia::{Color, Pixmap};

pub use colour::ColourMap;
pub use encode::{gif_bytes, png_bytes, write_gif, write_png};
pub use hex::{render_hexes, Camera, ClipPlane, RenderOptions3};
pub use quads::{render_quads, RenderOptions};

use crate::mesh::element::{check_order, Basis1d, Shape, Spacing, MAX_ORDER};
use crate::mesh::CurvedMesh;
use layout::Layout;

/// Cells smaller than this many pixels across get no edge lines: the lines
/// would cover the colours.
const MIN_CELL_PX_FOR_EDGES: f64 = 3.0;

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

/// The options both plans share: image width, colours and legend.
struct Style<'a> {
    width: u32,
    range: Option<(f64, f64)>,
    colour_map: Option<ColourMap>,
    label: &'a str,
    title: Option<&'a str>,
}

/// What both plans decide before drawing: the colour range and map, the
/// tick labels, and the layout of the picture around the plot.
struct Frame {
    label: String,
    title: Option<String>,
    range: (f64, f64),
    cmap: ColourMap,
    tick_labels: Vec<String>,
    layout: Layout,
}

impl Frame {
    /// The frame of a picture of `values` whose plot area shows the box
    /// `screen` (in world units of the plot's axes).
    fn new(
        values: &[f64],
        style: Style,
        screen: ([f64; 2], [f64; 2]),
    ) -> Result<Frame, RenderError> {
        let range = resolve_range(values, style.range)?;
        let cmap = style.colour_map.unwrap_or_else(|| ColourMap::auto(range));
        let tick_labels = legend::format_ticks(&legend::tick_values(range));
        let layout = Layout::new(
            style.width,
            screen,
            style.title.is_some(),
            style.label,
            &tick_labels,
        )?;
        Ok(Frame {
            label: style.label.to_string(),
            title: style.title.map(str::to_string),
            range,
            cmap,
            tick_labels,
            layout,
        })
    }

    /// The colour of cell value `v`.
    fn colour(&self, v: f64) -> [u8; 3] {
        self.cmap.colour(v, self.range)
    }

    /// A white picture of the layout's size.
    fn canvas(&self) -> Result<Pixmap, RenderError> {
        let (width, height) = (self.layout.width, self.layout.height);
        let mut pixmap =
            Pixmap::new(width, height).ok_or(RenderError::ImageSize { width, height })?;
        pixmap.fill(Color::WHITE);
        Ok(pixmap)
    }

    /// Draws the colour bar and the title around the drawn plot.
    fn decorate(&self, pixmap: &mut Pixmap) {
        let l = &self.layout;
        legend::draw_colour_bar(
            pixmap,
            l,
            self.cmap,
            self.range,
            &self.tick_labels,
            &self.label,
        );
        if let Some(title) = &self.title {
            legend::draw_title(pixmap, l, title);
        }
    }

    /// Line width and opacity of the edges between cells (or faces) whose
    /// world sizes are `sizes`, from the median size in pixels (robust to
    /// a few tiny or huge cells in graded meshes), and that median.
    /// Hairlines that fade on small cells, up to about a pixel on large
    /// ones, so a 200×200 mesh stays readable and coarse meshes look
    /// crisp; none under [`MIN_CELL_PX_FOR_EDGES`].
    fn edge_style(&self, mut sizes: Vec<f64>) -> (f64, Option<(f32, f32)>) {
        if sizes.is_empty() {
            return (0.0, None);
        }
        let mid = sizes.len() / 2;
        let (_, median, _) = sizes.select_nth_unstable_by(mid, f64::total_cmp);
        let px = *median * self.layout.scale();
        if px.is_nan() || px < MIN_CELL_PX_FOR_EDGES {
            return (px, None);
        }
        let width = ((px / 25.0) as f32).clamp(0.4, 1.0) * self.layout.res();
        let alpha = (0.35 + (px as f32 - 3.0) / 30.0).clamp(0.35, 0.8);
        (px, Some((width, alpha)))
    }
}

/// Checks values against cells and the mesh against what drawing indexes
/// (order, node count per cell, node indices, finite nodes), so drawing
/// cannot panic or produce garbage.
fn validate<const D: usize>(mesh: &CurvedMesh<D>, values: &[f64]) -> Result<(), RenderError> {
    if values.len() != mesh.cells.len() {
        return Err(RenderError::LengthMismatch {
            values: values.len(),
            cells: mesh.cells.len(),
        });
    }
    if let Some(index) = values.iter().position(|v| !v.is_finite()) {
        return Err(RenderError::NonFiniteValue { index });
    }
    if check_order(mesh.p).is_err() {
        return Err(RenderError::InvalidCurvedMesh {
            reason: format!("element order {} is not in 1..={MAX_ORDER}", mesh.p),
        });
    }
    if let Some(index) = mesh
        .nodes
        .iter()
        .position(|p| !p.iter().all(|x| x.is_finite()))
    {
        return Err(RenderError::NonFiniteNode { index });
    }
    if mesh.shape.dim() != D {
        return Err(RenderError::InvalidCurvedMesh { reason: format!("cells of shape {:?} in a {D}D mesh", mesh.shape) });
    }
    if let Some(first) = mesh.cells.first().filter(|c| Shape::with_nodes(D, mesh.p, c.len()) != Some(mesh.shape)) {
        let reason = format!("the mesh's cells are labelled {:?}, its first cell has {} nodes", mesh.shape, first.len());
        return Err(RenderError::InvalidCurvedMesh { reason });
    }
    // each plan draws every kind of its dimension, side by side in a
    // mixed mesh
    let per_cell: Vec<usize> = Shape::ALL.iter().filter(|s| s.dim() == D).map(|s| s.num_nodes(mesh.p)).collect();
    check_elements(
        mesh.cells.iter(),
        &per_cell,
        mesh.nodes.len(),
        "cell",
    )
}

/// Every element in `elements` must have one of the node counts `per`,
/// its nodes all below `nodes`. The index reported for a bad node is the
/// element's.
fn check_elements<'a>(
    elements: impl Iterator<Item = &'a [usize]>,
    per: &[usize],
    nodes: usize,
    what: &str,
) -> Result<(), RenderError> {
    for (cell, e) in elements.enumerate() {
        if !per.contains(&e.len()) {
            let expected = per.iter().map(usize::to_string).collect::<Vec<_>>().join(" or ");
            return Err(RenderError::InvalidCurvedMesh {
                reason: format!("{what} {cell} has {} nodes, expected {expected}", e.len()),
            });
        }
        if let Some(&node) = e.iter().find(|&&n| n >= nodes) {
            return Err(RenderError::BadNodeIndex { cell, node, nodes });
        }
    }
    Ok(())
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

/// The bounding box of `points` (infinite and reversed if there are none,
/// which the callers reject).
fn bounding_box<'a, const D: usize>(
    points: impl IntoIterator<Item = &'a [f64; D]>,
) -> ([f64; D], [f64; D]) {
    let mut lo = [f64::INFINITY; D];
    let mut hi = [f64::NEG_INFINITY; D];
    for p in points {
        for k in 0..D {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// Straight pieces that stand for one element edge of order `p`: one for
/// `p = 1`, whose edges are straight (a linear mesh is drawn exactly as
/// its cells), else `per_order · p`.
fn pieces(p: usize, per_order: usize) -> usize {
    if p == 1 {
        1
    } else {
        per_order * p
    }
}

/// Values of the order-`p` Lagrange basis at `t = k / n`, `k = 0..=n`: the
/// weights of the nodes of an edge (or of one axis) at each sample.
fn basis_table(p: usize, spacing: Spacing, n: usize) -> Vec<Vec<f64>> {
    let basis = Basis1d::new(p, spacing).expect("order checked by validate");
    (0..=n).map(|k| basis.eval(k as f64 / n as f64).0).collect()
}

/// The curve through nodes `ids` (in order, `p + 1` of them) sampled at
/// every row of `table`, appended to `out`.
fn sample_curve<const D: usize>(
    table: &[Vec<f64>],
    ids: &[usize],
    nodes: &[[f64; D]],
    out: &mut Vec<[f64; D]>,
) {
    out.extend(table.iter().map(|w| {
        let mut x = [0.0; D];
        for (&wi, &id) in w.iter().zip(ids) {
            for d in 0..D {
                x[d] += wi * nodes[id][d];
            }
        }
        x
    }));
}
