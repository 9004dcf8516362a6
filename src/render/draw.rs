//! Drawing the mesh itself: filled cells, cell edges and the boundary.

use tiny_skia::{
    FillRule, LineCap, Mask, Paint, Path, PathBuilder, Pixmap, Rect, Stroke, Transform,
};

use super::colour::ColourMap;
use super::ink;
use super::layout::Layout;
use crate::mesh::QuadMesh;

/// Cells smaller than this many pixels across get no edge lines: the lines
/// would cover the colours.
const MIN_CELL_PX_FOR_EDGES: f64 = 3.0;

/// A mask that clips drawing to the plot area (widened a little so a
/// boundary lying on the frame is not cut in half), keeping cells outside
/// a user-given frame off the colour bar.
pub(crate) fn plot_clip(layout: &Layout) -> Option<Mask> {
    let pad = 0.5 * layout.margin;
    let [x, y, w, h] = layout.plot;
    let rect = Rect::from_xywh(
        (x - pad) as f32,
        (y - pad) as f32,
        (w + 2.0 * pad) as f32,
        (h + 2.0 * pad) as f32,
    )?;
    let mut mask = Mask::new(layout.width, layout.height)?;
    mask.fill_path(
        &PathBuilder::from_rect(rect),
        FillRule::Winding,
        false,
        Transform::identity(),
    );
    Some(mask)
}

/// Fills every cell with the colour of its value.
pub(crate) fn cells(
    pixmap: &mut Pixmap,
    layout: &Layout,
    mesh: &QuadMesh,
    values: &[f64],
    cmap: ColourMap,
    range: (f64, f64),
    clip: Option<&Mask>,
) {
    // Without anti-aliasing, neighbouring cells tile exactly; with it, the
    // shared edges would show faint background seams. The boundary stroke
    // drawn later smooths the outline.
    let mut paint = Paint {
        anti_alias: false,
        ..Paint::default()
    };
    for (c, &v) in values.iter().enumerate() {
        let Some(path) = polygon(layout, &mesh.cell_coords(c)) else {
            continue;
        };
        let [r, g, b] = cmap.colour(v, range);
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

/// A closed polygon through the pixel positions of `corners`.
fn polygon(layout: &Layout, corners: &[[f64; 2]; 4]) -> Option<Path> {
    let mut pb = PathBuilder::new();
    let (x, y) = layout.to_px(corners[0]);
    pb.move_to(x, y);
    for &p in &corners[1..] {
        let (x, y) = layout.to_px(p);
        pb.line_to(x, y);
    }
    pb.close();
    pb.finish()
}

/// Draws cell edges (if `interior` and the cells are big enough to show
/// them) and the boundary on top.
pub(crate) fn edges(
    pixmap: &mut Pixmap,
    layout: &Layout,
    mesh: &QuadMesh,
    interior: bool,
    clip: Option<&Mask>,
) {
    let (inner, boundary) = split_edges(mesh);
    let res = (layout.width as f32 / 900.0).max(0.75);
    if interior {
        if let Some((width, alpha)) = interior_style(typical_cell_px(layout, mesh), res) {
            stroke_segments(pixmap, layout, mesh, &inner, width, alpha, clip);
        }
    }
    stroke_segments(pixmap, layout, mesh, &boundary, 1.8 * res, 1.0, clip);
}

/// Line width and opacity for interior edges of cells `cell_px` across:
/// hairlines that fade on small cells, up to about a pixel on large ones,
/// so a 200×200 mesh stays readable and coarse meshes look crisp.
pub(crate) fn interior_style(cell_px: f64, res: f32) -> Option<(f32, f32)> {
    if cell_px.is_nan() || cell_px < MIN_CELL_PX_FOR_EDGES {
        return None;
    }
    let width = ((cell_px / 25.0) as f32).clamp(0.4, 1.0) * res;
    let alpha = (0.35 + (cell_px as f32 - 3.0) / 30.0).clamp(0.35, 0.8);
    Some((width, alpha))
}

/// The median cell size in pixels (square root of the area), robust to a
/// few tiny or huge cells in graded meshes.
fn typical_cell_px(layout: &Layout, mesh: &QuadMesh) -> f64 {
    let mut sizes: Vec<f64> = (0..mesh.num_cells())
        .map(|c| mesh.cell_area(c).abs().sqrt())
        .collect();
    if sizes.is_empty() {
        return 0.0;
    }
    let mid = sizes.len() / 2;
    let (_, median, _) = sizes.select_nth_unstable_by(mid, f64::total_cmp);
    *median * layout.scale()
}

/// Unique cell edges, split into interior ones and boundary ones. An edge
/// used by exactly one cell is on the boundary, and so is every tagged
/// boundary edge of the mesh (which may include internal interfaces).
fn split_edges(mesh: &QuadMesh) -> (Vec<[usize; 2]>, Vec<[usize; 2]>) {
    let key = |a: usize, b: usize| if a < b { [a, b] } else { [b, a] };
    let mut all: Vec<[usize; 2]> = mesh
        .cells
        .iter()
        .flat_map(|c| (0..4).map(move |i| key(c[i], c[(i + 1) % 4])))
        .collect();
    all.sort_unstable();
    let mut tagged: Vec<[usize; 2]> = mesh
        .edges
        .iter()
        .map(|e| key(e.nodes[0], e.nodes[1]))
        .collect();
    tagged.sort_unstable();
    tagged.dedup();

    let (mut inner, mut boundary) = (Vec::new(), Vec::new());
    for run in all.chunk_by(|a, b| a == b) {
        let e = run[0];
        if run.len() == 1 || tagged.binary_search(&e).is_ok() {
            boundary.push(e);
        } else {
            inner.push(e);
        }
    }
    // Tagged edges that no cell uses are still worth showing.
    boundary.extend(tagged.into_iter().filter(|e| all.binary_search(e).is_err()));
    (inner, boundary)
}

/// Strokes all `segments` as one path, so overlapping line ends do not
/// darken each other.
fn stroke_segments(
    pixmap: &mut Pixmap,
    layout: &Layout,
    mesh: &QuadMesh,
    segments: &[[usize; 2]],
    width: f32,
    alpha: f32,
    clip: Option<&Mask>,
) {
    let mut pb = PathBuilder::new();
    for &[a, b] in segments {
        let (pa, pb_) = (layout.to_px(mesh.nodes[a]), layout.to_px(mesh.nodes[b]));
        pb.move_to(pa.0, pa.1);
        pb.line_to(pb_.0, pb_.1);
    }
    let Some(path) = pb.finish() else { return };
    let mut paint = Paint::default();
    let mut colour = ink();
    colour.apply_opacity(alpha);
    paint.set_color(colour);
    // Round caps close the small notches where separate segments meet.
    let stroke = Stroke {
        width,
        line_cap: LineCap::Round,
        ..Stroke::default()
    };
    pixmap.stroke_path(&path, &paint, &stroke, Transform::identity(), clip);
}
