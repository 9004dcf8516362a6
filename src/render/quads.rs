//! The 2D plan: a mesh of quads, triangles or both (mixed) of any order,
//! drawn through each element's own map so that curved edges look curved.
//!
//! Every distinct element edge is sampled once along its Lagrange curve
//! (one straight piece at `p = 1`, [`SAMPLES_PER_ORDER`]` · p` above), and
//! both cells that share it use the same points, so the filled polygons,
//! drawn without anti-aliasing, tile without seams. Lines are drawn on
//! top: faint curves through the elements' internal nodes when elements
//! are large (they show the order-`p` structure), the element edges, the
//! boundary, and dots at the boundary nodes.

use tiny_skia::{
    FillRule, LineCap, LineJoin, Mask, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform,
};

use super::layout::Layout;
use super::{
    basis_table, bounding_box, check_elements, ink, pieces, sample_curve, validate, ColourMap,
    Frame, RenderError, Style,
};
use crate::mesh::element::{Shape, MAX_ORDER};
use crate::mesh::CurvedMesh;

/// Straight pieces per element edge and per unit of order (for `p > 1`):
/// 8 per order keeps the polygon within a small fraction of a pixel of the
/// true curve for elements up to a few hundred pixels across, at little
/// cost.
const SAMPLES_PER_ORDER: usize = 8;

/// Elements at least this many pixels across (median) show their internal
/// node lines and boundary node dots; smaller ones would be cluttered.
const DETAIL_MIN_CELL_PX: f64 = 30.0;

/// What to draw and how, for [`render_quads`].
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Image width in pixels (at least 200). The height follows from the
    /// aspect ratio of the bounds plus room for the title and colour bar.
    pub width: u32,
    /// World box to frame, as (lower-left, upper-right); `None` frames the
    /// mesh's edges. Give all frames of an animation the same box so they
    /// line up.
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
    /// when cells are under about 3 pixels across) and, on large elements
    /// of order above 1, the lines through their internal nodes. The
    /// boundary is always drawn.
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

/// Draws the quad mesh `mesh` (any order; a linear [`QuadMesh`] is
/// `CurvedMesh::from_quads`) with cell `c` filled by the colour of
/// `cell_values[c]` over the region bounded by its four edge curves, plus,
/// as set in `opts`: element edges, faint curves through each element's
/// internal nodes when elements are over about 30 pixels across, the
/// boundary (always, stronger; when elements are that large and `p > 1`,
/// filled dots mark its element corners and rings its high-order nodes),
/// colour bar and title. The boundary is every edge used by one cell plus
/// every tagged boundary element. `opts.bounds == None` frames the
/// bounding box of the sampled edge curves (which may bulge beyond the
/// nodes).
///
/// Fails, never panics, on the inputs listed in [`crate::render`].
///
/// [`QuadMesh`]: crate::mesh::QuadMesh
pub fn render_quads(
    mesh: &CurvedMesh<2>,
    cell_values: &[f64],
    opts: &RenderOptions,
) -> Result<Pixmap, RenderError> {
    let (frame, curves) = plan(mesh, cell_values, opts)?;
    let mut pixmap = frame.canvas()?;
    let clip = plot_clip(&frame.layout);
    fill_cells(&mut pixmap, &frame, &curves, cell_values, clip.as_ref());
    draw_lines(
        &mut pixmap,
        &frame,
        mesh,
        &curves,
        opts.draw_edges,
        clip.as_ref(),
    );
    frame.decorate(&mut pixmap);
    Ok(pixmap)
}

/// Validates, samples the curves and lays out the picture.
pub(super) fn plan(
    mesh: &CurvedMesh<2>,
    values: &[f64],
    opts: &RenderOptions,
) -> Result<(Frame, QuadCurves), RenderError> {
    validate(mesh, values)?;
    let boundary = mesh.boundary.iter().map(|b| b.nodes);
    check_elements(boundary, &[mesh.p + 1], mesh.nodes.len(), "boundary element")?;
    let curves = QuadCurves::new(mesh);
    let (lo, hi) = opts.bounds.unwrap_or_else(|| bounding_box(&curves.points));
    if !(0..2).all(|k| lo[k].is_finite() && hi[k].is_finite() && hi[k] > lo[k]) {
        return Err(RenderError::InvalidBounds { lo, hi });
    }
    Ok((Frame::new(values, style!(opts), (lo, hi))?, curves))
}

/// The sampled curves of a 2D mesh, in world coordinates.
pub(super) struct QuadCurves {
    /// Points sampled per curve.
    stride: usize,
    /// Every distinct element edge (and tagged boundary element), sampled
    /// from the first to the last of its canonical nodes: `stride` points
    /// per edge.
    points: Vec<[f64; 2]>,
    /// The canonical node list of each edge, `p + 1` nodes per edge.
    edge_nodes: Vec<usize>,
    /// Whether each edge is drawn as boundary: used by one cell, or tagged.
    boundary: Vec<bool>,
    /// Each cell's edges (four of a quad, three of a triangle),
    /// counter-clockwise around the reference cell, with whether the edge
    /// is traversed against its samples.
    cell_edges: Vec<smallvec::SmallVec<[(usize, bool); 4]>>,
    /// Curves through each cell's internal nodes: `ξ = t_i` and `η = t_j`
    /// for `0 < i, j < p` (none for `p = 1`), `stride` points each.
    pub(super) grid: Vec<[f64; 2]>,
}

impl QuadCurves {
    /// Samples all edges and internal node lines of `mesh` (validated).
    pub(super) fn new(mesh: &CurvedMesh<2>) -> QuadCurves {
        let p = mesh.p;
        let q = p + 1;
        let n = pieces(p, SAMPLES_PER_ORDER);
        let table = basis_table(p, mesh.spacing, n);
        // each cell is drawn by its own kind: a mixed mesh holds quads
        // and triangles
        let (quad_edges, triangle_edges) = (cell_edges(Shape::Quadrilateral, p), cell_edges(Shape::Triangle, p));
        let mut curves = QuadCurves {
            stride: n + 1,
            points: Vec::new(),
            edge_nodes: Vec::new(),
            boundary: Vec::new(),
            cell_edges: Vec::with_capacity(mesh.cells.len()),
            grid: Vec::new(),
        };
        let mut uses: Vec<u32> = Vec::new();
        // The edges whose canonical list starts at each node, as linked
        // lists (`first` per node, `next` per edge): a node starts few.
        let mut first = vec![usize::MAX; mesh.nodes.len()];
        let mut next: Vec<usize> = Vec::new();
        // Adds (or finds) the edge through `ids`; returns its index and
        // whether `ids` runs against the stored direction: the smaller of
        // the list and its reverse, so either way finds the same edge.
        let mut intern = |curves: &mut QuadCurves, uses: &mut Vec<u32>, ids: &[usize]| {
            let reversed = ids.iter().rev().lt(ids);
            let key = |k: usize| if reversed { ids[q - 1 - k] } else { ids[k] };
            let mut e = first[key(0)];
            while e != usize::MAX && !(0..q).all(|k| curves.edge_nodes[e * q + k] == key(k)) {
                e = next[e];
            }
            if e == usize::MAX {
                e = uses.len();
                next.push(first[key(0)]);
                first[key(0)] = e;
                curves.edge_nodes.extend((0..q).map(key));
                let ids = &curves.edge_nodes[e * q..];
                sample_curve(&table, ids, &mesh.nodes, &mut curves.points);
                curves.boundary.push(false);
                uses.push(0);
            }
            (e, reversed)
        };
        let mut ids = [0; MAX_ORDER + 1];
        for (c, cell) in mesh.cells.iter().enumerate() {
            let simplex = mesh.cell_shape(c).is_simplex();
            let mut edges = smallvec::SmallVec::new();
            for l in if simplex { &triangle_edges } else { &quad_edges } {
                for (id, &a) in ids.iter_mut().zip(l) {
                    *id = cell[a];
                }
                let (e, rev) = intern(&mut curves, &mut uses, &ids[..q]);
                uses[e] += 1;
                edges.push((e, rev));
            }
            curves.cell_edges.push(edges);
            if simplex {
                // a triangle's node lines are not iso-lines of one axis
                continue;
            }
            // The line ξ = t_i passes through node column i exactly, so it
            // is the 1-D interpolant of that column (likewise for rows).
            for i in 1..p {
                let column: Vec<usize> = (0..q).map(|j| cell[i + q * j]).collect();
                let row: Vec<usize> = (0..q).map(|j| cell[j + q * i]).collect();
                sample_curve(&table, &column, &mesh.nodes, &mut curves.grid);
                sample_curve(&table, &row, &mesh.nodes, &mut curves.grid);
            }
        }
        for b in &mesh.boundary {
            let (e, _) = intern(&mut curves, &mut uses, b.nodes);
            curves.boundary[e] = true;
        }
        for (flag, &n) in curves.boundary.iter_mut().zip(&uses) {
            *flag |= n == 1;
        }
        curves
    }

    /// The sampled edges that are (or are not) boundary.
    pub(super) fn edges(&self, boundary: bool) -> impl Iterator<Item = &[[f64; 2]]> {
        let edges = self.points.chunks(self.stride).zip(&self.boundary);
        edges.filter(move |(_, &b)| b == boundary).map(|(e, _)| e)
    }

    /// The closed outline of cell `c` (first point not repeated).
    pub(super) fn outline(&self, c: usize) -> Vec<[f64; 2]> {
        let mut out = Vec::with_capacity(4 * self.stride);
        for &(e, reversed) in &self.cell_edges[c] {
            let pts = &self.points[e * self.stride..(e + 1) * self.stride];
            // Each edge's last point is the next edge's first.
            if reversed {
                out.extend(pts[1..].iter().rev());
            } else {
                out.extend(&pts[..self.stride - 1]);
            }
        }
        out
    }
}

/// Local indices of the edges of an order-`p` element, counter-clockwise
/// around the reference cell: a quad's η = 0, ξ = 1, η = 1, ξ = 0 (tensor
/// order), a triangle's three edges of the element table (lattice order;
/// their nodes sit at the 1-D node set, so each is the 1-D interpolant).
fn cell_edges(shape: Shape, p: usize) -> Vec<Vec<usize>> {
    if shape.is_simplex() {
        return (0..3).map(|e| crate::mesh::element::simplex::edge_nodes(shape, p, e)).collect();
    }
    let q = p + 1;
    vec![
        (0..q).collect(),
        (0..q).map(|j| p + q * j).collect(),
        (0..q).rev().map(|i| i + q * p).collect(),
        (0..q).rev().map(|j| q * j).collect(),
    ]
}

/// A mask that clips drawing to the plot region, keeping cells outside a
/// user-given frame off the colour bar.
fn plot_clip(layout: &Layout) -> Option<Mask> {
    let [x, y, w, h] = layout.plot_region().map(|v| v as f32);
    let rect = Rect::from_xywh(x, y, w, h)?;
    let mut mask = Mask::new(layout.width, layout.height)?;
    let path = PathBuilder::from_rect(rect);
    mask.fill_path(&path, FillRule::Winding, false, Transform::identity());
    Some(mask)
}

/// Fills each cell's outline with the colour of its value.
fn fill_cells(
    pixmap: &mut Pixmap,
    frame: &Frame,
    curves: &QuadCurves,
    values: &[f64],
    clip: Option<&Mask>,
) {
    // Without anti-aliasing, neighbours sharing the exact same edge points
    // tile exactly; with it, shared edges would show faint background
    // seams. The lines drawn later smooth the look.
    let mut paint = Paint {
        anti_alias: false,
        ..Paint::default()
    };
    for (c, &v) in values.iter().enumerate() {
        let mut pb = PathBuilder::new();
        add_polyline(&mut pb, &frame.layout, &curves.outline(c));
        pb.close();
        let Some(path) = pb.finish() else { continue };
        let [r, g, b] = frame.colour(v);
        paint.set_color_rgba8(r, g, b, 255);
        pixmap.fill_path(
            &path,
            &paint,
            FillRule::Winding,
            Transform::identity(),
            clip,
        );
    }
}

/// Signed area of a closed polygon (shoelace formula).
pub(super) fn polygon_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    0.5 * (0..n)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % n]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
}

/// Draws, in this order so stronger lines end up on top: the internal
/// node lines and element edges (if `edges` and the elements are large
/// enough), the boundary, and the boundary node dots.
fn draw_lines(
    pixmap: &mut Pixmap,
    frame: &Frame,
    mesh: &CurvedMesh<2>,
    curves: &QuadCurves,
    edges: bool,
    clip: Option<&Mask>,
) {
    let layout = &frame.layout;
    let res = layout.res();
    let sizes = (0..curves.cell_edges.len())
        .map(|c| polygon_area(&curves.outline(c)).abs().sqrt())
        .collect();
    let (cell_px, style) = frame.edge_style(sizes);
    let detail = cell_px >= DETAIL_MIN_CELL_PX;
    if edges {
        if detail {
            // Fainter and thinner than the element edges, so the elements
            // still read as units and the node lines as their inner grid.
            let lines = curves.grid.chunks(curves.stride);
            stroke_polylines(pixmap, layout, lines, 0.6 * res, 0.28, clip);
        }
        if let Some((width, alpha)) = style {
            stroke_polylines(pixmap, layout, curves.edges(false), width, alpha, clip);
        }
    }
    stroke_polylines(pixmap, layout, curves.edges(true), 1.8 * res, 1.0, clip);
    if detail && mesh.p > 1 {
        draw_boundary_nodes(pixmap, layout, mesh, curves, clip);
    }
}

/// Dots on the nodes of the boundary curves, where the Lagrange curve is
/// pinned: filled for element corners, rings (white inside) for the
/// high-order nodes between them, so the order shows at a glance.
fn draw_boundary_nodes(
    pixmap: &mut Pixmap,
    layout: &Layout,
    mesh: &CurvedMesh<2>,
    curves: &QuadCurves,
    clip: Option<&Mask>,
) {
    let (mut corners, mut inner) = (Vec::new(), Vec::new());
    let q = mesh.p + 1;
    let edges = curves.edge_nodes.chunks(q).zip(&curves.boundary);
    for (ids, _) in edges.filter(|(_, &b)| b) {
        corners.extend([ids[0], ids[q - 1]]);
        inner.extend(&ids[1..q - 1]);
    }
    let res = layout.res();
    let circles = |ids: &mut Vec<usize>| {
        ids.sort_unstable();
        ids.dedup();
        let mut pb = PathBuilder::new();
        for &n in ids.iter() {
            let (x, y) = layout.to_px(mesh.nodes[n]);
            pb.push_circle(x, y, 2.6 * res);
        }
        pb.finish()
    };
    let mut paint = Paint::default();
    let stroke = Stroke {
        width: 1.2 * res,
        ..Stroke::default()
    };
    let fill = FillRule::Winding;
    let id = Transform::identity();
    if let Some(path) = circles(&mut inner) {
        paint.set_color_rgba8(255, 255, 255, 255);
        pixmap.fill_path(&path, &paint, fill, id, clip);
        paint.set_color(ink());
        pixmap.stroke_path(&path, &paint, &stroke, id, clip);
    }
    if let Some(path) = circles(&mut corners) {
        paint.set_color(ink());
        pixmap.fill_path(&path, &paint, fill, id, clip);
    }
}

/// Appends the pixel polyline through world points `pts` as a new subpath.
fn add_polyline(pb: &mut PathBuilder, layout: &Layout, pts: &[[f64; 2]]) {
    for (i, &p) in pts.iter().enumerate() {
        let (x, y) = layout.to_px(p);
        if i == 0 {
            pb.move_to(x, y);
        } else {
            pb.line_to(x, y);
        }
    }
}

/// Strokes all `lines` as one path in ink at opacity `alpha`, so where
/// lines meet they do not darken each other.
fn stroke_polylines<'a>(
    pixmap: &mut Pixmap,
    layout: &Layout,
    lines: impl Iterator<Item = &'a [[f64; 2]]>,
    width: f32,
    alpha: f32,
    clip: Option<&Mask>,
) {
    let mut pb = PathBuilder::new();
    for line in lines.filter(|l| l.len() >= 2) {
        add_polyline(&mut pb, layout, line);
    }
    let Some(path) = pb.finish() else { return };
    let mut paint = Paint::default();
    let mut colour = ink();
    colour.apply_opacity(alpha);
    paint.set_color(colour);
    // Round joins keep the many short pieces of a sampled curve smooth;
    // round caps close the notches where curves meet at corners.
    let stroke = Stroke {
        width,
        line_cap: LineCap::Round,
        line_join: LineJoin::Round,
        ..Stroke::default()
    };
    pixmap.stroke_path(&path, &paint, &stroke, Transform::identity(), clip);
}
