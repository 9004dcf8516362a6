//! Pictures of curved (high-order Lagrange) meshes, drawn through each
//! element's own tensor map so that curved edges and faces look curved.
//!
//! 2D ([`render_curved_quads`]): every distinct element edge is sampled at
//! [`SAMPLES_PER_ORDER`]` · p` intervals along its Lagrange curve, once, and
//! both cells that share it use the same points, so the filled polygons
//! (drawn without anti-aliasing, as in [`render_mesh`](super::render_mesh))
//! tile exactly along curved edges. Lines are drawn on top: faint curves
//! through the element's internal nodes when elements are large (they show
//! the order-`p` structure), the element edges, the boundary, and dots at
//! the boundary nodes.
//!
//! 3D ([`render_curved_hex`]): as [`render_hex`](super::render_hex) (same
//! camera, lighting, z-buffer, silhouette, clip plane and framing rules),
//! except that each boundary face is an `m × m` grid of small flat quads on
//! the true curved face (`m = `[`SUBQUADS_PER_ORDER`]` · p`), each shaded by
//! its own normal, and the edge lines are drawn only along the border of
//! the whole face, so the sub-quads do not show.

use std::collections::HashMap;

use tiny_skia::{FillRule, LineCap, LineJoin, Mask, Paint, PathBuilder, Pixmap, Stroke, Transform};

use super::check_values;
use crate::mesh::element::order::HEX_CORNERS;
use super::colour::ColourMap;
use super::hex::raster::{self, distance_to_segment, edge_blend, Canvas, EdgeStyle};
use super::hex::surface::{surface_faces, HEX_FACES};
use super::hex::view::{self, shade_colour, View};
use super::hex::{
    box_corners, plot_region, resolve_box, screen_bounds, validate_clip, ClipPlane, OUTLINE_PX,
    SUPERSAMPLE,
};
use super::layout::Layout;
use super::{
    canvas, decorate, draw, ink, legend, resolve_range, Legend, Plan, RenderError, RenderOptions,
    RenderOptions3,
};
use crate::mesh::element::{check_order, Basis1d, Spacing, MAX_ORDER};
use crate::mesh::CurvedMesh;

/// Straight pieces per element edge and per unit of order: 8 per order
/// keeps the polygon within a small fraction of a pixel of the true curve
/// for elements up to a few hundred pixels across, at little cost.
const SAMPLES_PER_ORDER: usize = 8;

/// Elements at least this many pixels across (median) show their internal
/// node lines and boundary node dots; smaller ones would be cluttered.
const DETAIL_MIN_CELL_PX: f64 = 30.0;

/// Sub-quads per face side and per unit of order in 3D: a degree-`p`
/// face needs a few flat pieces per polynomial degree to look smooth both
/// in outline and in shading.
const SUBQUADS_PER_ORDER: usize = 3;

/// Draws the curved quad mesh `mesh` with cell `c` filled by the colour of
/// `cell_values[c]` over the region bounded by its four true Lagrange edge
/// curves, plus, as set in `opts`: element edges (as curves), faint curves
/// through each element's internal nodes when elements are over about 30
/// pixels across (with `draw_edges` only), the boundary (always, stronger;
/// when elements are that large and `p > 1`, filled dots mark its element
/// corners and rings its high-order nodes), colour bar and title. The boundary is every edge used by one cell plus every tagged
/// boundary element. `opts.bounds == None` frames the bounding box of the
/// sampled edge curves (which may bulge beyond the nodes).
///
/// Fails (never panics) if the number of values differs from the number of
/// cells, if a value, node, bound or range is not finite, if the order is
/// unsupported or an element has the wrong number of nodes
/// ([`RenderError::InvalidCurvedMesh`]), if an element refers to a missing
/// node, or if the image size is unusable.
pub fn render_curved_quads(
    mesh: &CurvedMesh<2>,
    cell_values: &[f64],
    opts: &RenderOptions,
) -> Result<Pixmap, RenderError> {
    let (plan, curves) = plan_quads(mesh, cell_values, opts)?;
    let layout = &plan.layout;
    let mut pixmap = canvas(layout)?;
    let clip = draw::plot_clip(layout);
    fill_cells(&mut pixmap, &plan, &curves, cell_values, clip.as_ref());
    let cell_px = typical_cell_px(layout, &curves);
    draw_quad_lines(
        &mut pixmap,
        layout,
        mesh,
        &curves,
        cell_px,
        opts.draw_edges,
        clip.as_ref(),
    );
    let legend = Legend {
        cmap: plan.cmap,
        range: plan.range,
        tick_labels: &plan.tick_labels,
        label: &opts.label,
        title: opts.title.as_deref(),
    };
    decorate(&mut pixmap, layout, &legend);
    Ok(pixmap)
}

/// Draws the boundary surface of the curved hex mesh `mesh` (of the cells
/// kept by the clip plane, if any) as curved, shaded faces coloured by
/// `cell_values` of their cell, with each face's border drawn along its
/// curved edges, plus silhouette, colour bar and title, as
/// [`render_hex`](super::render_hex) does for straight hexes with the same
/// `opts`. A face is on the surface when no other kept cell has a face
/// with the same four corner nodes; the mesh's tagged `boundary` is not
/// used. A cell is clipped by the mean of its eight corner nodes, as in
/// `render_hex`. Without `opts.bounds` the picture frames the sampled
/// curved surface.
///
/// Fails (never panics) if the number of values differs from the number of
/// cells, if a value, node, bound, range, camera setting or clip plane is
/// not finite or is degenerate, if the order is unsupported or a cell has
/// the wrong number of nodes ([`RenderError::InvalidCurvedMesh`]), if a
/// cell refers to a missing node, or if the image size is unusable.
pub fn render_curved_hex(
    mesh: &CurvedMesh<3>,
    cell_values: &[f64],
    opts: &RenderOptions3,
) -> Result<Pixmap, RenderError> {
    let plan = HexPlan::new(mesh, cell_values, opts)?;
    let mut pixmap = canvas(&plan.layout)?;
    draw_patches(&mut pixmap, &plan, cell_values, opts.draw_edges);
    let legend = Legend {
        cmap: plan.cmap,
        range: plan.range,
        tick_labels: &plan.tick_labels,
        label: &opts.label,
        title: opts.title.as_deref(),
    };
    decorate(&mut pixmap, &plan.layout, &legend);
    Ok(pixmap)
}

// ---------------------------------------------------------------------------
// Shared: validation and sampling

/// Checks values against cells and the mesh against what drawing indexes,
/// so drawing cannot panic or produce garbage.
fn validate<const D: usize>(mesh: &CurvedMesh<D>, values: &[f64]) -> Result<(), RenderError> {
    check_values(values, mesh.cells.len())?;
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
    let per_cell = (mesh.p + 1).pow(D as u32);
    check_elements(&mesh.cells, per_cell, mesh.nodes.len(), "cell")
}

/// Every element in `elements` must have `per` nodes, all below `nodes`.
/// The index reported for a bad node is the element's.
fn check_elements(
    elements: &[Vec<usize>],
    per: usize,
    nodes: usize,
    what: &str,
) -> Result<(), RenderError> {
    for (cell, e) in elements.iter().enumerate() {
        if e.len() != per {
            return Err(RenderError::InvalidCurvedMesh {
                reason: format!("{what} {cell} has {} nodes, expected {per}", e.len()),
            });
        }
        if let Some(&node) = e.iter().find(|&&n| n >= nodes) {
            return Err(RenderError::BadNodeIndex { cell, node, nodes });
        }
    }
    Ok(())
}

/// Values of the order-`p` Lagrange basis at `t = k / n`, `k = 0..=n`: the
/// weights of the nodes of an edge (or of one axis) at each sample.
fn basis_table(p: usize, spacing: Spacing, n: usize) -> Vec<Vec<f64>> {
    let basis = Basis1d::new(p, spacing).expect("order checked by validate");
    (0..=n).map(|k| basis.eval(k as f64 / n as f64).0).collect()
}

/// The curve through nodes `ids` (in order, `p + 1` of them) sampled at
/// every row of `table`.
fn sample_curve<const D: usize>(
    table: &[Vec<f64>],
    ids: &[usize],
    nodes: &[[f64; D]],
) -> Vec<[f64; D]> {
    table
        .iter()
        .map(|w| {
            let mut x = [0.0; D];
            for (&wi, &id) in w.iter().zip(ids) {
                for d in 0..D {
                    x[d] += wi * nodes[id][d];
                }
            }
            x
        })
        .collect()
}

// ---------------------------------------------------------------------------
// 2D

/// The sampled curves of a 2D curved mesh, in world coordinates.
struct QuadCurves {
    /// Every distinct element edge (and tagged boundary element), sampled
    /// from the first to the last of its canonical nodes.
    edges: Vec<Vec<[f64; 2]>>,
    /// The canonical node list of each edge.
    edge_nodes: Vec<Vec<usize>>,
    /// Whether each edge is drawn as boundary: used by one cell, or tagged.
    boundary: Vec<bool>,
    /// Each cell's four edges, counter-clockwise around the reference
    /// square, with whether the edge is traversed against its samples.
    cell_edges: Vec<[(usize, bool); 4]>,
    /// Curves through each cell's internal nodes: `ξ = t_i` and `η = t_j`
    /// for `0 < i, j < p` (none for `p = 1`).
    grid: Vec<Vec<[f64; 2]>>,
}

impl QuadCurves {
    /// Samples all edges and internal node lines of `mesh` (validated).
    fn new(mesh: &CurvedMesh<2>) -> QuadCurves {
        let p = mesh.p;
        let q = p + 1;
        let table = basis_table(p, mesh.spacing, SAMPLES_PER_ORDER * p);
        let local = quad_edges(p);
        let mut index: HashMap<Vec<usize>, usize> = HashMap::new();
        let mut curves = QuadCurves {
            edges: Vec::new(),
            edge_nodes: Vec::new(),
            boundary: Vec::new(),
            cell_edges: Vec::with_capacity(mesh.cells.len()),
            grid: Vec::new(),
        };
        let mut uses: Vec<u32> = Vec::new();
        // Adds (or finds) the edge through `ids`; returns its index and
        // whether `ids` runs against the stored direction.
        let mut intern = |curves: &mut QuadCurves, uses: &mut Vec<u32>, ids: Vec<usize>| {
            let (key, reversed) = canonical(ids);
            let e = *index.entry(key.clone()).or_insert_with(|| {
                curves.edges.push(sample_curve(&table, &key, &mesh.nodes));
                curves.edge_nodes.push(key);
                curves.boundary.push(false);
                uses.push(0);
                curves.edges.len() - 1
            });
            (e, reversed)
        };
        for cell in &mesh.cells {
            let edges = local.each_ref().map(|l| {
                let (e, rev) = intern(&mut curves, &mut uses, l.iter().map(|&a| cell[a]).collect());
                uses[e] += 1;
                (e, rev)
            });
            curves.cell_edges.push(edges);
            // The line ξ = t_i passes through node column i exactly, so it
            // is the 1-D interpolant of that column (likewise for rows).
            for i in 1..p {
                let column: Vec<usize> = (0..q).map(|j| cell[i + q * j]).collect();
                let row: Vec<usize> = (0..q).map(|j| cell[j + q * i]).collect();
                curves.grid.push(sample_curve(&table, &column, &mesh.nodes));
                curves.grid.push(sample_curve(&table, &row, &mesh.nodes));
            }
        }
        for b in &mesh.boundary {
            let (e, _) = intern(&mut curves, &mut uses, b.nodes.clone());
            curves.boundary[e] = true;
        }
        for (flag, &n) in curves.boundary.iter_mut().zip(&uses) {
            *flag |= n == 1;
        }
        curves
    }

    /// The closed outline of cell `c` (first point not repeated).
    fn outline(&self, c: usize) -> Vec<[f64; 2]> {
        let mut out = Vec::new();
        for &(e, reversed) in &self.cell_edges[c] {
            let pts = &self.edges[e];
            // Each edge's last point is the next edge's first.
            let n = pts.len() - 1;
            if reversed {
                out.extend(pts[1..].iter().rev());
            } else {
                out.extend(&pts[..n]);
            }
        }
        out
    }
}

/// Local tensor indices of the four edges of an order-`p` quad, counter-
/// clockwise around the reference square: η = 0, ξ = 1, η = 1, ξ = 0.
fn quad_edges(p: usize) -> [Vec<usize>; 4] {
    let q = p + 1;
    [
        (0..q).collect(),
        (0..q).map(|j| p + q * j).collect(),
        (0..q).rev().map(|i| i + q * p).collect(),
        (0..q).rev().map(|j| q * j).collect(),
    ]
}

/// The same key for an edge whichever way it is listed: the smaller of
/// the list and its reverse, and whether the reverse was taken.
fn canonical(ids: Vec<usize>) -> (Vec<usize>, bool) {
    let rev: Vec<usize> = ids.iter().rev().copied().collect();
    if rev < ids {
        (rev, true)
    } else {
        (ids, false)
    }
}

/// Validates, samples the curves and lays out the picture.
fn plan_quads(
    mesh: &CurvedMesh<2>,
    values: &[f64],
    opts: &RenderOptions,
) -> Result<(Plan, QuadCurves), RenderError> {
    validate(mesh, values)?;
    check_elements(
        &mesh
            .boundary
            .iter()
            .map(|b| b.nodes.clone())
            .collect::<Vec<_>>(),
        mesh.p + 1,
        mesh.nodes.len(),
        "boundary element",
    )?;
    let range = resolve_range(values, opts.range)?;
    let curves = QuadCurves::new(mesh);
    let (lo, hi) = opts
        .bounds
        .unwrap_or_else(|| bounding_box(curves.edges.iter().flatten()));
    if !(0..2).all(|k| lo[k].is_finite() && hi[k].is_finite() && hi[k] > lo[k]) {
        return Err(RenderError::InvalidBounds { lo, hi });
    }
    let cmap = opts.colour_map.unwrap_or_else(|| ColourMap::auto(range));
    let tick_labels = legend::format_ticks(&legend::tick_values(range));
    let layout = Layout::new(
        opts.width,
        (lo, hi),
        opts.title.is_some(),
        &opts.label,
        &tick_labels,
    )?;
    Ok((
        Plan {
            range,
            cmap,
            tick_labels,
            layout,
        },
        curves,
    ))
}

/// The bounding box of `points` (infinite and reversed if there are none,
/// which the caller rejects).
fn bounding_box<'a>(points: impl Iterator<Item = &'a [f64; 2]>) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// Fills each cell's curved outline with the colour of its value.
fn fill_cells(
    pixmap: &mut Pixmap,
    plan: &Plan,
    curves: &QuadCurves,
    values: &[f64],
    clip: Option<&Mask>,
) {
    // Not anti-aliased, as in `draw::cells`: neighbours share the exact
    // same edge points and tile without seams; the lines smooth the look.
    let mut paint = Paint {
        anti_alias: false,
        ..Paint::default()
    };
    for (c, &v) in values.iter().enumerate() {
        let mut pb = PathBuilder::new();
        add_polyline(&mut pb, &plan.layout, &curves.outline(c));
        pb.close();
        let Some(path) = pb.finish() else { continue };
        let [r, g, b] = plan.cmap.colour(v, plan.range);
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

/// The median element size in pixels (square root of the area enclosed by
/// the sampled outline), robust to a few tiny or huge elements.
fn typical_cell_px(layout: &Layout, curves: &QuadCurves) -> f64 {
    let mut sizes: Vec<f64> = (0..curves.cell_edges.len())
        .map(|c| polygon_area(&curves.outline(c)).abs().sqrt())
        .collect();
    if sizes.is_empty() {
        return 0.0;
    }
    let mid = sizes.len() / 2;
    let (_, median, _) = sizes.select_nth_unstable_by(mid, f64::total_cmp);
    *median * layout.scale()
}

/// Signed area of a closed polygon (shoelace formula).
fn polygon_area(p: &[[f64; 2]]) -> f64 {
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
fn draw_quad_lines(
    pixmap: &mut Pixmap,
    layout: &Layout,
    mesh: &CurvedMesh<2>,
    curves: &QuadCurves,
    cell_px: f64,
    edges: bool,
    clip: Option<&Mask>,
) {
    let res = (layout.width as f32 / 900.0).max(0.75);
    let detail = cell_px >= DETAIL_MIN_CELL_PX;
    if edges {
        if detail {
            // Fainter and thinner than the element edges, so the elements
            // still read as units and the node lines as their inner grid.
            let lines = curves.grid.iter().map(Vec::as_slice);
            stroke_polylines(pixmap, layout, lines, 0.6 * res, 0.28, clip);
        }
        if let Some((width, alpha)) = draw::interior_style(cell_px, res) {
            let inner = curves
                .edges
                .iter()
                .zip(&curves.boundary)
                .filter(|(_, &b)| !b)
                .map(|(e, _)| e.as_slice());
            stroke_polylines(pixmap, layout, inner, width, alpha, clip);
        }
    }
    let outer = curves
        .edges
        .iter()
        .zip(&curves.boundary)
        .filter(|(_, &b)| b)
        .map(|(e, _)| e.as_slice());
    stroke_polylines(pixmap, layout, outer, 1.8 * res, 1.0, clip);
    if detail && mesh.p > 1 {
        draw_boundary_nodes(pixmap, layout, mesh, curves, res, clip);
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
    res: f32,
    clip: Option<&Mask>,
) {
    let mut corners = Vec::new();
    let mut inner = Vec::new();
    for (ids, _) in curves
        .edge_nodes
        .iter()
        .zip(&curves.boundary)
        .filter(|(_, &b)| b)
    {
        let last = ids.len() - 1;
        corners.extend([ids[0], ids[last]]);
        inner.extend(&ids[1..last]);
    }
    for ids in [&mut corners, &mut inner] {
        ids.sort_unstable();
        ids.dedup();
    }
    let circles = |ids: &[usize], r: f32| {
        let mut pb = PathBuilder::new();
        for &n in ids {
            let (x, y) = layout.to_px(mesh.nodes[n]);
            pb.push_circle(x, y, r);
        }
        pb.finish()
    };
    let mut paint = Paint::default();
    let stroke = Stroke {
        width: 1.2 * res,
        ..Stroke::default()
    };
    if let Some(path) = circles(&inner, 2.6 * res) {
        paint.set_color_rgba8(255, 255, 255, 255);
        pixmap.fill_path(
            &path,
            &paint,
            FillRule::Winding,
            Transform::identity(),
            clip,
        );
        paint.set_color(ink());
        pixmap.stroke_path(&path, &paint, &stroke, Transform::identity(), clip);
    }
    if let Some(path) = circles(&corners, 2.6 * res) {
        paint.set_color(ink());
        pixmap.fill_path(
            &path,
            &paint,
            FillRule::Winding,
            Transform::identity(),
            clip,
        );
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

// ---------------------------------------------------------------------------
// 3D


/// One drawn face: the curved face sampled on an `(m+1) × (m+1)` grid.
struct Patch {
    /// The cell it belongs to (whose value colours it).
    cell: usize,
    /// World points, index `k + (m+1) l` for face parameters
    /// `(k/m, l/m)`; the grid's border is the face's border.
    points: Vec<[f64; 3]>,
}

/// Everything decided before drawing a curved hex mesh.
struct HexPlan {
    view: View,
    layout: Layout,
    range: (f64, f64),
    cmap: ColourMap,
    tick_labels: Vec<String>,
    /// Sub-quads per face side.
    m: usize,
    /// The surface of the kept cells.
    patches: Vec<Patch>,
}

impl HexPlan {
    fn new(
        mesh: &CurvedMesh<3>,
        values: &[f64],
        opts: &RenderOptions3,
    ) -> Result<HexPlan, RenderError> {
        validate(mesh, values)?;
        if let Some(clip) = &opts.clip {
            validate_clip(clip)?;
        }
        let range = resolve_range(values, opts.range)?;
        let m = SUBQUADS_PER_ORDER * mesh.p;
        let kept = kept_cells(mesh, opts.clip.as_ref());
        let patches = surface_patches(mesh, &kept, m);
        let framed: Vec<[f64; 3]> = match opts.bounds {
            Some((lo, hi)) => box_corners(lo, hi).to_vec(),
            // The sampled surface, not the nodes: a curved face may bulge
            // beyond its nodes. With nothing kept, frame the whole mesh.
            None if patches.is_empty() => mesh.nodes.clone(),
            None => patches
                .iter()
                .flat_map(|f| f.points.iter().copied())
                .collect(),
        };
        let (lo, hi) = resolve_box(&framed, opts.bounds)?;
        let view = View::new(&opts.camera, lo, hi)?;
        let screen = screen_bounds(&view, &framed);
        let cmap = opts.colour_map.unwrap_or_else(|| ColourMap::auto(range));
        let tick_labels = legend::format_ticks(&legend::tick_values(range));
        let layout = Layout::new(
            opts.width,
            screen,
            opts.title.is_some(),
            &opts.label,
            &tick_labels,
        )?;
        Ok(HexPlan {
            view,
            layout,
            range,
            cmap,
            tick_labels,
            m,
            patches,
        })
    }

    /// The image position of world point `p` (see [`super::hex::to_image`]).
    fn to_image(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        super::hex::to_image(&self.view, &self.layout, p)
    }
}

/// Which cells are drawn: all, or those whose corner-node mean is not on
/// the positive side of the clip plane, the same rule as `render_hex` so
/// a curved mesh and its straight-sided version lose the same cells.
fn kept_cells(mesh: &CurvedMesh<3>, clip: Option<&ClipPlane>) -> Vec<bool> {
    let Some(clip) = clip else {
        return vec![true; mesh.cells.len()];
    };
    let p = mesh.p;
    mesh.cells
        .iter()
        .map(|cell| {
            let c = corner_nodes(cell, p).iter().fold([0.0; 3], |c, &n| {
                view::add(c, view::scale(mesh.nodes[n], 0.125))
            });
            view::dot(view::sub(c, clip.point), clip.normal) <= 0.0
        })
        .collect()
}

/// The eight corner nodes of a tensor-ordered order-`p` hex, in the local
/// numbering of [`HEX_CORNERS`].
fn corner_nodes(cell: &[usize], p: usize) -> [usize; 8] {
    let q = p + 1;
    HEX_CORNERS.map(|[a, b, c]| cell[p * (a + q * b + q * q * c)])
}

/// The sampled boundary faces of the kept cells: faces found by their
/// corner nodes (shared by no other kept cell), in cell order.
fn surface_patches(mesh: &CurvedMesh<3>, kept: &[bool], m: usize) -> Vec<Patch> {
    let corners: Vec<[usize; 8]> = mesh.cells.iter().map(|c| corner_nodes(c, mesh.p)).collect();
    let table = basis_table(mesh.p, mesh.spacing, m);
    surface_faces(&corners, kept)
        .into_iter()
        .filter_map(|face| {
            // Which of the cell's six faces it is: the one whose corners
            // are listed exactly like this.
            let cell = &corners[face.cell];
            let f = HEX_FACES
                .iter()
                .position(|l| l.map(|i| cell[i]) == face.nodes)?;
            let points = sample_face(&mesh.cells[face.cell], &mesh.nodes, mesh.p, f, &table);
            Some(Patch {
                cell: face.cell,
                points,
            })
        })
        .collect()
}

/// Face `f` ([`HEX_FACES`] numbering) of the order-`p` hex with tensor-
/// ordered nodes `cell`, sampled through the hex map on the grid of
/// `table` (rows at `t = k / m`). The face's first corner is the grid's
/// origin, its second lies along the grid's first axis, its fourth along
/// the second.
fn sample_face(
    cell: &[usize],
    nodes: &[[f64; 3]],
    p: usize,
    f: usize,
    table: &[Vec<f64>],
) -> Vec<[f64; 3]> {
    let m = table.len() - 1;
    let q = p + 1;
    let [r0, r1, _, r3] = HEX_FACES[f].map(|i| HEX_CORNERS[i]);
    let axis_u = (0..3)
        .find(|&d| r1[d] != r0[d])
        .expect("face corners differ");
    let axis_v = (0..3)
        .find(|&d| r3[d] != r0[d])
        .expect("face corners differ");
    let fixed = 3 - axis_u - axis_v;
    // The face lies where the basis along the fixed axis is exactly the
    // first or the last function: the face depends on its own nodes only.
    let mut delta = vec![0.0; q];
    delta[r0[fixed] * p] = 1.0;
    // Along a reversed axis, face parameter k/m is reference 1 − k/m.
    let row = |k: usize, reversed: bool| &table[if reversed { m - k } else { k }];
    let mut points = Vec::with_capacity((m + 1) * (m + 1));
    for l in 0..=m {
        for k in 0..=m {
            let mut w: [&[f64]; 3] = [&delta, &delta, &delta];
            w[axis_u] = row(k, r0[axis_u] == 1);
            w[axis_v] = row(l, r0[axis_v] == 1);
            let mut x = [0.0; 3];
            for (c, &wc) in w[2].iter().enumerate().filter(|(_, w)| **w != 0.0) {
                for (b, &wb) in w[1].iter().enumerate().filter(|(_, w)| **w != 0.0) {
                    for (a, &wa) in w[0].iter().enumerate().filter(|(_, w)| **w != 0.0) {
                        let y = nodes[cell[a + q * b + q * q * c]];
                        x = view::add(x, view::scale(y, wa * wb * wc));
                    }
                }
            }
            points.push(x);
        }
    }
    points
}

/// Rasterises the curved surface into a supersampled z-buffer over the
/// plot area and copies the averaged result into `pixmap`.
fn draw_patches(pixmap: &mut Pixmap, plan: &HexPlan, values: &[f64], draw_edges: bool) {
    let region = plot_region(&plan.layout);
    let ss = SUPERSAMPLE as f64;
    let mut canvas = Canvas::new(region[2] * SUPERSAMPLE, region[3] * SUPERSAMPLE);
    let edges = if draw_edges { edge_style(plan) } else { None };
    let m = plan.m;
    let at = |k: usize, l: usize| k + (m + 1) * l;
    for patch in &plan.patches {
        // A face with a point behind the eye is skipped rather than
        // clipped, as in `render_hex`.
        let Some(px) = patch
            .points
            .iter()
            .map(|&p| {
                let [x, y, depth] = plan.to_image(p)?;
                Some([
                    (x - region[0] as f64) * ss,
                    (y - region[1] as f64) * ss,
                    depth,
                ])
            })
            .collect::<Option<Vec<[f64; 3]>>>()
        else {
            continue;
        };
        let normals = grid_normals(&patch.points, m);
        let border = face_border(m)
            .map(|[a, b]| [px[a], px[b]])
            .collect::<Vec<_>>();
        let base = plan.cmap.colour(values[patch.cell], plan.range);
        for l in 0..m {
            for k in 0..m {
                let ids = [at(k, l), at(k + 1, l), at(k + 1, l + 1), at(k, l + 1)];
                let light = sub_quad_light(plan, &patch.points, &normals, ids);
                let quad = ids.map(|i| px[i]);
                let near =
                    edges.map(|style| nearby_segments(&border, &quad, style.half_width + 1.0));
                for t in [[0, 1, 2], [0, 2, 3]] {
                    let tri = t.map(|v| quad[v]);
                    let lit = t.map(|v| light[v]);
                    let paint = |x: f64, y: f64| {
                        let colour = shade_colour(base, interpolate(&tri, lit, x, y));
                        match (edges, &near) {
                            (Some(style), Some(segs)) if !segs.is_empty() => {
                                let d = segs
                                    .iter()
                                    .map(|[a, b]| distance_to_segment(*a, *b, x, y))
                                    .fold(f64::INFINITY, f64::min);
                                edge_blend(colour, style, d)
                            }
                            _ => colour,
                        }
                    };
                    canvas.fill_triangle(tri, &paint);
                }
            }
        }
    }
    let res = (plan.layout.width as f64 / 900.0).max(0.75);
    let outline = (OUTLINE_PX * res * ss).round() as usize;
    canvas.outline(outline.max(1), raster::INK, 0.9);
    canvas.blit(pixmap, region[0], region[1], SUPERSAMPLE);
}

/// Unit normals of the sampled face at its grid points, from central
/// differences (one-sided on the border), all on the same side of the
/// face. Shading with these, interpolated over each sub-quad, makes the
/// face look smooth where flat sub-quads would show as facets.
fn grid_normals(points: &[[f64; 3]], m: usize) -> Vec<[f64; 3]> {
    let at = |k: usize, l: usize| points[k + (m + 1) * l];
    let mut normals = Vec::with_capacity(points.len());
    for l in 0..=m {
        for k in 0..=m {
            let du = view::sub(at((k + 1).min(m), l), at(k.saturating_sub(1), l));
            let dv = view::sub(at(k, (l + 1).min(m)), at(k, l.saturating_sub(1)));
            normals.push(view::normalise(view::cross(du, dv)));
        }
    }
    normals
}

/// The light factor at the four corners `ids` of a sub-quad: its corner
/// normals, turned towards the viewer together when the sub-quad faces
/// away (two-sided, as `render_hex` lights whole faces), so inner faces
/// exposed by clipping are lit like any other.
fn sub_quad_light(
    plan: &HexPlan,
    points: &[[f64; 3]],
    normals: &[[f64; 3]],
    ids: [usize; 4],
) -> [f64; 4] {
    let world = ids.map(|i| points[i]);
    let centre = view::scale(
        view::add(view::add(world[0], world[1]), view::add(world[2], world[3])),
        0.25,
    );
    let away = view::dot(view::quad_normal(&world), plan.view.to_eye(centre)) < 0.0;
    // Corner normals point to the same side as the sub-quad's own normal
    // (both follow the grid's orientation), so one flip serves all four.
    ids.map(|i| {
        let n = if away {
            view::scale(normals[i], -1.0)
        } else {
            normals[i]
        };
        plan.view.light_factor(n)
    })
}

/// The value at (x, y) of the linear function on triangle `tri` (screen
/// positions) taking `values` at its corners; clamped to the corner
/// values' range, since samples at the inclusive edges may lie a hair
/// outside.
fn interpolate(tri: &[[f64; 3]; 3], values: [f64; 3], x: f64, y: f64) -> f64 {
    let orient = |a: [f64; 3], b: [f64; 3]| (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]);
    let area = (tri[1][0] - tri[0][0]) * (tri[2][1] - tri[0][1])
        - (tri[1][1] - tri[0][1]) * (tri[2][0] - tri[0][0]);
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    // The rasteriser skips degenerate triangles; this only guards the
    // division.
    if area.abs() < 1e-12 {
        return lo;
    }
    let w = [
        orient(tri[1], tri[2]) / area,
        orient(tri[2], tri[0]) / area,
        orient(tri[0], tri[1]) / area,
    ];
    (w[0] * values[0] + w[1] * values[1] + w[2] * values[2]).clamp(lo, hi)
}

/// The grid-index pairs of the segments around the border of an
/// `m × m` patch.
fn face_border(m: usize) -> impl Iterator<Item = [usize; 2]> {
    let at = move |k: usize, l: usize| k + (m + 1) * l;
    (0..m).flat_map(move |i| {
        [
            [at(i, 0), at(i + 1, 0)],
            [at(m, i), at(m, i + 1)],
            [at(i, m), at(i + 1, m)],
            [at(0, i), at(0, i + 1)],
        ]
    })
}

/// The border segments that come within `reach` samples of the bounding
/// box of `quad`: the only ones that can darken its samples. Taken from the
/// whole border, not just the quad's own sides, because small faces have
/// sub-quads narrower than the edge line.
fn nearby_segments(
    border: &[[[f64; 3]; 2]],
    quad: &[[f64; 3]; 4],
    reach: f64,
) -> Vec<[[f64; 3]; 2]> {
    let lo = |k: usize| quad.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min) - reach;
    let hi = |k: usize| quad.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max) + reach;
    let (x0, x1, y0, y1) = (lo(0), hi(0), lo(1), hi(1));
    border
        .iter()
        .filter(|[a, b]| {
            a[0].max(b[0]) >= x0
                && a[0].min(b[0]) <= x1
                && a[1].max(b[1]) >= y0
                && a[1].min(b[1]) <= y1
        })
        .copied()
        .collect()
}

/// The style of the face borders, as `render_hex` chooses it: from the
/// median face size in pixels (its corners' world size times the scale,
/// which does not vanish for faces seen edge-on).
fn edge_style(plan: &HexPlan) -> Option<EdgeStyle> {
    if plan.patches.is_empty() {
        return None;
    }
    let m = plan.m;
    let corners = [0, m, (m + 1) * (m + 1) - 1, (m + 1) * m];
    let mut sizes: Vec<f64> = plan
        .patches
        .iter()
        .map(|f| view::quad_area(&corners.map(|i| f.points[i])).sqrt())
        .collect();
    let mid = sizes.len() / 2;
    let (_, median, _) = sizes.select_nth_unstable_by(mid, f64::total_cmp);
    let face_px = *median * plan.layout.scale();
    let res = (plan.layout.width as f32 / 900.0).max(0.75);
    let (width, alpha) = draw::interior_style(face_px, res)?;
    Some(EdgeStyle {
        half_width: 0.5 * width as f64 * SUPERSAMPLE as f64,
        alpha,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::{png_bytes, Camera};
    use std::f64::consts::PI;

    /// Decodes the PNG encoding of `pixmap`, so the tests see exactly
    /// what a file would hold.
    fn decoded(pixmap: &Pixmap) -> image::RgbaImage {
        let png = png_bytes(pixmap).unwrap();
        image::load_from_memory_with_format(&png, image::ImageFormat::Png)
            .unwrap()
            .to_rgba8()
    }

    fn pixel(img: &image::RgbaImage, x: f64, y: f64) -> [u8; 3] {
        let p = img.get_pixel(x as u32, y as u32).0;
        assert_eq!(p[3], 255, "picture should be opaque");
        [p[0], p[1], p[2]]
    }

    fn assert_close(found: [u8; 3], expected: [u8; 3], what: &str) {
        let ok = (0..3).all(|k| found[k].abs_diff(expected[k]) <= 1);
        assert!(ok, "{what}: found {found:?}, expected {expected:?}");
    }

    const WHITE: [u8; 3] = [255, 255, 255];

    fn brightness(c: [u8; 3]) -> u32 {
        c.iter().map(|&x| x as u32).sum()
    }

    /// The darkest pixel within one pixel of (x, y): a thin line through
    /// a point may cover its own pixel only partly.
    fn darkest_near(img: &image::RgbaImage, x: f64, y: f64) -> [u8; 3] {
        let mut best = WHITE;
        for dy in [-1.0, 0.0, 1.0] {
            for dx in [-1.0, 0.0, 1.0] {
                let c = pixel(img, x + dx, y + dy);
                if brightness(c) < brightness(best) {
                    best = c;
                }
            }
        }
        best
    }

    /// Quarter annulus `1 ≤ r ≤ 2`, `0 ≤ θ ≤ π/2`: ξ runs along the angle,
    /// η along the radius.
    fn annulus(p: usize, n: [usize; 2]) -> CurvedMesh<2> {
        CurvedMesh::structured(p, Spacing::GaussLobatto, n, |[u, v]| {
            let (r, t) = (1.0 + v, 0.5 * PI * u);
            [r * t.cos(), r * t.sin()]
        })
        .unwrap()
    }

    /// One cell of the unit square whose top edge bulges up by 0.3 in the
    /// middle (exactly representable at p = 2: y + 1.2 y x (1 − x)).
    fn bulged_square(p: usize) -> CurvedMesh<2> {
        CurvedMesh::structured(p, Spacing::Equispaced, [1, 1], |[x, y]| {
            [x, y + 1.2 * y * x * (1.0 - x)]
        })
        .unwrap()
    }

    fn colour_of(plan: &Plan, v: f64) -> [u8; 3] {
        plan.cmap.colour(v, plan.range)
    }

    #[test]
    fn annulus_renders_with_cell_colours_inside_the_arc() {
        let mesh = annulus(3, [4, 2]);
        let values: Vec<f64> = (0..8).map(|c| 0.9 + 0.03 * c as f64).collect();
        let opts = RenderOptions::default();
        let img = decoded(&render_curved_quads(&mesh, &values, &opts).unwrap());
        let (plan, _) = plan_quads(&mesh, &values, &opts).unwrap();
        assert_eq!(
            (img.width(), img.height()),
            (plan.layout.width, plan.layout.height)
        );
        // Outer cells are 4..8 (η is the second axis). At the middle angle
        // of each, halfway between the chord of its outer edge and the arc:
        // inside the true element, outside the straight-sided one.
        let dt = 0.5 * PI / 4.0;
        let sagitta = 2.0 * (1.0 - (0.5 * dt).cos());
        for i in 0..4 {
            let t = (i as f64 + 0.5) * dt;
            let r = 2.0 - 0.5 * sagitta;
            let at = plan.layout.to_px([r * t.cos(), r * t.sin()]);
            let found = pixel(&img, at.0 as f64, at.1 as f64);
            assert_close(
                found,
                colour_of(&plan, values[4 + i]),
                &format!("bulge of cell {}", 4 + i),
            );
            // Just outside the arc is background.
            let r = 2.0 + 0.02;
            let at = plan.layout.to_px([r * t.cos(), r * t.sin()]);
            assert_eq!(pixel(&img, at.0 as f64, at.1 as f64), WHITE);
        }
        // The inner arc bulges into the hole: between arc and chord there
        // is no cell.
        let t = 0.5 * dt;
        let r = 1.0 - 0.5 * sagitta;
        let at = plan.layout.to_px([r * t.cos(), r * t.sin()]);
        assert_eq!(pixel(&img, at.0 as f64, at.1 as f64), WHITE);
    }

    #[test]
    fn bulge_of_a_curved_edge_has_the_cell_colour() {
        for p in [2, 3] {
            let mesh = bulged_square(p);
            let opts = RenderOptions {
                width: 400,
                ..RenderOptions::default()
            };
            let img = decoded(&render_curved_quads(&mesh, &[1.1], &opts).unwrap());
            let (plan, _) = plan_quads(&mesh, &[1.1], &opts).unwrap();
            // Default bounds follow the curve: the top of the plot is at
            // the top of the bulge (y = 1.3), not at the nodes.
            let (_, top) = plan.layout.to_px([0.5, 1.3]);
            assert!((top as f64 - plan.layout.plot[1]).abs() < 0.5);
            // Above the chord y = 1, below the curve (1.29 at x = 0.42),
            // and off the internal node lines x = ½ (p = 2) and x = ⅓, ⅔.
            let at = plan.layout.to_px([0.42, 1.15]);
            assert_close(
                pixel(&img, at.0 as f64, at.1 as f64),
                colour_of(&plan, 1.1),
                "bulge",
            );
            // Above the curve near the corner (curve at 1.108 there).
            let at = plan.layout.to_px([0.1, 1.25]);
            assert_eq!(pixel(&img, at.0 as f64, at.1 as f64), WHITE, "p = {p}");
        }
    }

    #[test]
    fn boundary_and_internal_node_lines_are_drawn_as_curves() {
        let mesh = bulged_square(2);
        let opts = RenderOptions {
            width: 400,
            ..RenderOptions::default()
        };
        let img = decoded(&render_curved_quads(&mesh, &[1.1], &opts).unwrap());
        let (plan, _) = plan_quads(&mesh, &[1.1], &opts).unwrap();
        let cell = colour_of(&plan, 1.1);
        let darker = |c: [u8; 3]| brightness(c) + 100 < brightness(cell);
        // The boundary follows the curve: dark at (0.3, 1 + 1.2·0.21).
        let at = plan.layout.to_px([0.3, 1.0 + 1.2 * 0.3 * 0.7]);
        assert!(darker(darkest_near(&img, at.0 as f64, at.1 as f64)));
        // The internal line η = ½ is the curve y = ½ + 0.6 x (1 − x): at
        // x = 0.3 it is at 0.626 (faint: darker, but not like an edge),
        // and the straight y = ½ there is plain cell.
        let at = plan.layout.to_px([0.3, 0.626]);
        let on_line = darkest_near(&img, at.0 as f64, at.1 as f64);
        let faint = brightness(on_line) + 15 < brightness(cell)
            && brightness(on_line) + 100 > brightness(cell);
        assert!(faint, "line η = ½ at {on_line:?}, cell {cell:?}");
        let at = plan.layout.to_px([0.3, 0.5]);
        assert_close(pixel(&img, at.0 as f64, at.1 as f64), cell, "off the line");
    }

    #[test]
    fn shared_curved_edges_are_sampled_once() {
        let mesh = annulus(3, [4, 2]);
        let curves = QuadCurves::new(&mesh);
        // 4×2 cells: 4·3 angular edges + 5·2 radial ones.
        assert_eq!(curves.edges.len(), 22);
        assert_eq!(curves.boundary.iter().filter(|&&b| b).count(), 12);
        assert_eq!(curves.grid.len(), 8 * 2 * 2);
        // Outlines are closed curves that follow the arc: the area of
        // the whole annulus is 3π/4 to sampling accuracy.
        let area: f64 = (0..8).map(|c| polygon_area(&curves.outline(c)).abs()).sum();
        // (The chords lose about 1.4e-4 against the true arcs.)
        assert!((area - 0.75 * PI).abs() < 5e-4, "area {area}");
    }

    #[test]
    fn bad_input_is_an_error() {
        let mesh = annulus(2, [2, 2]);
        let opts = RenderOptions::default();
        assert!(matches!(
            render_curved_quads(&mesh, &[1.0; 3], &opts),
            Err(RenderError::LengthMismatch {
                values: 3,
                cells: 4
            })
        ));
        assert!(matches!(
            render_curved_quads(&mesh, &[1.0, f64::NAN, 1.0, 1.0], &opts),
            Err(RenderError::NonFiniteValue { index: 1 })
        ));
        let mut short = mesh.clone();
        short.cells[2].pop();
        assert!(matches!(
            render_curved_quads(&short, &[1.0; 4], &opts),
            Err(RenderError::InvalidCurvedMesh { .. })
        ));
        let mut dangling = mesh.clone();
        dangling.cells[1][0] = 999;
        assert!(matches!(
            render_curved_quads(&dangling, &[1.0; 4], &opts),
            Err(RenderError::BadNodeIndex {
                cell: 1,
                node: 999,
                ..
            })
        ));
        let mut nan = mesh.clone();
        nan.nodes[5][1] = f64::NAN;
        assert!(matches!(
            render_curved_quads(&nan, &[1.0; 4], &opts),
            Err(RenderError::NonFiniteNode { index: 5 })
        ));
        let mut order = mesh;
        order.p = 7;
        assert!(matches!(
            render_curved_quads(&order, &[1.0; 4], &opts),
            Err(RenderError::InvalidCurvedMesh { .. })
        ));
        let block = bulged_block(2, [1, 1, 1]);
        assert!(matches!(
            render_curved_hex(&block, &[], &RenderOptions3::default()),
            Err(RenderError::LengthMismatch {
                values: 0,
                cells: 1
            })
        ));
        assert!(matches!(
            render_curved_hex(&block, &[f64::INFINITY], &RenderOptions3::default()),
            Err(RenderError::NonFiniteValue { index: 0 })
        ));
        let clip = RenderOptions3 {
            clip: Some(ClipPlane {
                point: [0.0; 3],
                normal: [0.0; 3],
            }),
            ..RenderOptions3::default()
        };
        assert!(matches!(
            render_curved_hex(&block, &[1.0], &clip),
            Err(RenderError::InvalidClipPlane { .. })
        ));
    }

    /// The block `[0,1]³` (or `n` cells of it) whose side x = 1 bulges
    /// out by 0.3 at y = ½: x ↦ x (1 + 1.2 y (1 − y)), exact at p = 2.
    fn bulged_block(p: usize, n: [usize; 3]) -> CurvedMesh<3> {
        CurvedMesh::structured(p, Spacing::GaussLobatto, n, |[x, y, z]| {
            [x * (1.0 + 1.2 * y * (1.0 - y)), y, z]
        })
        .unwrap()
    }

    fn from_above() -> RenderOptions3 {
        RenderOptions3 {
            width: 400,
            camera: Camera {
                azimuth_deg: 0.0,
                elevation_deg: 90.0,
                distance: None,
            },
            ..RenderOptions3::default()
        }
    }

    fn pixel_of(img: &image::RgbaImage, plan: &HexPlan, p: [f64; 3]) -> [u8; 3] {
        let [x, y, _] = plan.to_image(p).unwrap();
        pixel(img, x, y)
    }

    #[test]
    fn bulge_of_a_curved_face_has_the_face_colour() {
        for p in [2, 3] {
            let mesh = bulged_block(p, [1, 1, 1]);
            let opts = from_above();
            let img = decoded(&render_curved_hex(&mesh, &[0.9], &opts).unwrap());
            let plan = HexPlan::new(&mesh, &[0.9], &opts).unwrap();
            // The top face seen face-on, lit as a face with normal +z.
            let top = shade_colour(
                plan.cmap.colour(0.9, plan.range),
                plan.view.light_factor([0.0, 0.0, 1.0]),
            );
            assert_close(pixel_of(&img, &plan, [0.5, 0.5, 1.0]), top, "centre");
            // Right of the chord x = 1, left of the curve x = 1.3 at y = ½.
            assert_close(pixel_of(&img, &plan, [1.15, 0.5, 1.0]), top, "bulge");
            // Beyond the curve near a corner (x = 1.108 at y = 0.1).
            assert_eq!(pixel_of(&img, &plan, [1.25, 0.1, 1.0]), WHITE);
            // No line between the sub-quads: on a sub-quad border inside
            // the face, the colour is the plain face colour.
            let m = (SUBQUADS_PER_ORDER * p) as f64;
            assert_close(
                pixel_of(&img, &plan, [1.0 / m, 0.5, 1.0]),
                top,
                "sub-quad border",
            );
        }
    }

    #[test]
    fn face_borders_follow_the_curved_edges() {
        // Two cells along x: the edge between their top faces is the curve
        // x = ½ (1 + 1.2 y (1 − y)), at x = 0.65 for y = ½, where a
        // straight edge would be at x = ½.
        let mesh = bulged_block(2, [2, 1, 1]);
        let values = [0.9, 1.1];
        let opts = from_above();
        let img = decoded(&render_curved_hex(&mesh, &values, &opts).unwrap());
        let plan = HexPlan::new(&mesh, &values, &opts).unwrap();
        assert_eq!(plan.patches.len(), 10, "two cells show ten faces");
        let top = |v: f64| {
            shade_colour(
                plan.cmap.colour(v, plan.range),
                plan.view.light_factor([0.0, 0.0, 1.0]),
            )
        };
        let [x, y, _] = plan.to_image([0.65, 0.5, 1.0]).unwrap();
        let line = darkest_near(&img, x, y);
        for v in values {
            assert!(
                brightness(line) * 10 < brightness(top(v)) * 9,
                "{line:?} vs {:?}",
                top(v)
            );
        }
        assert_close(pixel_of(&img, &plan, [0.5, 0.5, 1.0]), top(0.9), "chord");
    }

    #[test]
    fn clipping_drops_whole_cells_by_their_centre() {
        let mesh = bulged_block(2, [2, 1, 1]);
        let values = [0.9, 1.1];
        let clip = RenderOptions3 {
            clip: Some(ClipPlane {
                point: [0.6, 0.0, 0.0],
                normal: [1.0, 0.0, 0.0],
            }),
            bounds: Some(([0.0; 3], [1.3, 1.0, 1.0])),
            ..from_above()
        };
        let img = decoded(&render_curved_hex(&mesh, &values, &clip).unwrap());
        let plan = HexPlan::new(&mesh, &values, &clip).unwrap();
        // Only cell 0 (centre x = 0.25) is kept; it shows all six faces.
        assert_eq!(plan.patches.len(), 6);
        assert!(plan.patches.iter().all(|f| f.cell == 0));
        let top0 = shade_colour(
            plan.cmap.colour(0.9, plan.range),
            plan.view.light_factor([0.0, 0.0, 1.0]),
        );
        assert_close(pixel_of(&img, &plan, [0.25, 0.5, 1.0]), top0, "kept cell");
        assert_eq!(
            pixel_of(&img, &plan, [0.9, 0.5, 1.0]),
            WHITE,
            "dropped cell"
        );
    }

    #[test]
    fn every_sampled_point_is_finite_and_on_the_face() {
        let mesh = bulged_block(3, [2, 2, 2]);
        let patches = surface_patches(&mesh, &[true; 8], 9);
        assert_eq!(patches.len(), 24);
        for f in &patches {
            assert_eq!(f.points.len(), 100);
            assert!(f.points.iter().flatten().all(|x| x.is_finite()));
            // Every surface point lies on a side of the (bulged) box.
            for &[x, y, z] in &f.points {
                let on = [x.abs(), z.abs(), (z - 1.0).abs(), y.abs(), (y - 1.0).abs()]
                    .into_iter()
                    .fold(f64::INFINITY, f64::min)
                    .min((x - (1.0 + 1.2 * y * (1.0 - y))).abs());
                // p = 3 reproduces the quadratic bulge exactly.
                assert!(on < 1e-12, "{:?} is not on the surface", [x, y, z]);
            }
        }
    }
}
