//! The 3D plan: the boundary surface of a mesh of hexahedra, tetrahedra or
//! prisms of any order, each face filled with the colour of its cell's
//! value and shaded by a light from the camera's upper left, with its
//! border drawn as the cell edges, a dark silhouette, the colour bar and a
//! title, as in the 2D pictures.
//!
//! Each boundary face is sampled on a grid of `m` pieces a side on the
//! true face (`m = 1` at `p = 1`, whose faces are bilinear quads or flat
//! triangles, `m = `[`SUBQUADS_PER_ORDER`]` · p` above): a hex face
//! through the hex map on an `m × m` grid of small quads, a tet face
//! through its own Lagrange triangle (the face's nodes, the triangle space
//! of the mesh's spacing) on a triangle grid of `m²` small triangles, a
//! prism's triangle faces the same way and its quad faces through their
//! own Lagrange quadrilateral on the quad grid. From there on all are the
//! same: pieces shaded by normals interpolated
//! from the grid points, edge lines along the border of the whole face, so
//! the pieces do not show.
//!
//! Hidden surfaces are removed with a z-buffer (each piece drawn as a fan
//! of triangles, rasterised by our own code), not by sorting faces,
//! because sorting fails on concave meshes. The picture is rasterised at
//! [`SUPERSAMPLE`]× the resolution each way and averaged down, which
//! anti-aliases both the outline and the edge lines. Edge lines are drawn
//! *inside* each face as it is rasterised (a pixel within half a line
//! width of the face's border is darkened), so they take part in the depth
//! test exactly like the faces and hidden edges never show.
//!
//! With a [`ClipPlane`], cells whose corner mean lies on the positive side
//! of the plane are dropped and the surface of the kept cells is drawn, so
//! the faces between kept and dropped cells show the inside.

pub(crate) mod raster;
pub(crate) mod surface;
#[cfg(test)]
mod tests;
pub(crate) mod view;

use tiny_skia::Pixmap;
use rayon::prelude::*;

use super::{bounding_box, pieces, validate, ColourMap, Frame, RenderError, Style};
use crate::mesh::CurvedMesh;
use crate::numeric::{add, dot, scale, sub};
use raster::{distance_to_segment, edge_blend, Canvas, EdgeStyle};
use surface::{surface_patches, Corners, Grid, Patch};
use view::{shade_colour, View};

/// Each pixel is rasterised as `SUPERSAMPLE × SUPERSAMPLE` samples: 3 gives
/// smooth outlines and sub-pixel edge lines at a modest memory cost
/// (about 70 bytes per output pixel).
const SUPERSAMPLE: u32 = 3;

/// Width of the silhouette line in output pixels (inside the outline), at
/// a 900-pixel-wide image; it scales with the image like the 2D boundary.
const OUTLINE_PX: f64 = 1.3;

/// Pieces (sub-quads, or sub-triangles of a tet face) per face side and
/// per unit of order (for `p > 1`): a degree-`p` face needs a few flat
/// pieces per polynomial degree to look smooth both in outline and in
/// shading.
const SUBQUADS_PER_ORDER: usize = 3;

/// Where the camera looks from. It always looks at the centre of the
/// framed box, with the z axis pointing up in the picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Rotation about the z axis in degrees: 0 looks along +y (x to the
    /// right), 90 looks along −x (y to the right); positive values swing
    /// the camera towards +x.
    pub azimuth_deg: f64,
    /// Height above the xy plane in degrees, −90..=90: 0 looks
    /// horizontally, 90 straight down (−90 straight up from below).
    pub elevation_deg: f64,
    /// `None` for an orthographic (parallel) view; `Some(d)` for a
    /// perspective view from `d` bounding-sphere radii of the framed box
    /// away from its centre (`d` > 1; about 3 looks natural).
    pub distance: Option<f64>,
}

impl Default for Camera {
    /// A pleasant three-quarter view from the front right and above
    /// (azimuth 35°, elevation 25°), orthographic.
    fn default() -> Self {
        Camera {
            azimuth_deg: 35.0,
            elevation_deg: 25.0,
            distance: None,
        }
    }
}

/// A plane that cuts the mesh open: cells whose centre (the mean of their
/// corners, eight of a hex, four of a tet, six of a prism) lies on the
/// side the normal points to are not drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipPlane {
    /// Any point on the plane.
    pub point: [f64; 3],
    /// The normal, pointing to the side that is removed (need not be of
    /// unit length, but not zero).
    pub normal: [f64; 3],
}

/// What to draw and how, for [`render_hexes`].
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions3 {
    /// Image width in pixels (at least 200). The height follows from the
    /// shape of the projected mesh plus room for the title and colour bar.
    pub width: u32,
    /// The viewpoint.
    pub camera: Camera,
    /// Cuts the mesh open to show the inside; `None` shows all cells.
    pub clip: Option<ClipPlane>,
    /// Colour range (low, high); `None` uses the min and max of all values
    /// (clipped cells included, so a clipped and an unclipped picture use
    /// the same colours). Values outside get the colour of the nearer end.
    pub range: Option<(f64, f64)>,
    /// The colour map; `None` picks one with [`ColourMap::auto`].
    pub colour_map: Option<ColourMap>,
    /// Label drawn above the colour bar, e.g. "J/f".
    pub label: String,
    /// Title drawn at the top, e.g. "t = 0.30".
    pub title: Option<String>,
    /// Whether to draw the cell edges on the surface (they are left out
    /// anyway when faces are under about 3 pixels across). The silhouette
    /// is always drawn.
    pub draw_edges: bool,
    /// World box to frame and look at, as (lower corner, upper corner);
    /// `None` frames the drawn surface (of the cells the clip plane keeps).
    /// Give all frames of an animation, or a clipped and an unclipped
    /// picture meant to be compared, the same box and camera so they line
    /// up.
    pub bounds: Option<([f64; 3], [f64; 3])>,
}

impl Default for RenderOptions3 {
    /// 900 pixels wide, the default [`Camera`], no clipping, automatic
    /// range and colour map, labelled "J/f", no title, edges drawn,
    /// framing the mesh.
    fn default() -> Self {
        RenderOptions3 {
            width: 900,
            camera: Camera::default(),
            clip: None,
            range: None,
            colour_map: None,
            label: "J/f".to_string(),
            title: None,
            draw_edges: true,
            bounds: None,
        }
    }
}

/// Draws the boundary surface of the 3D mesh `mesh` of hexahedra (tensor
/// order), tetrahedra, prisms or pyramids (their lattice orders), alone or
/// mixed, each cell by its own kind, of any order (a
/// linear [`HexMesh`] is `CurvedMesh::from_hexes`), of the cells kept by
/// the clip plane if any, as shaded faces coloured by `cell_values` of
/// their cell, with each face's border drawn along its edges (if
/// `opts.draw_edges`), plus silhouette, colour bar and title. A face is on
/// the surface when no other kept cell has a face with the same corner
/// nodes (four of a quad, three of a triangle); the mesh's tagged
/// `boundary` is not used. Without `opts.bounds` the picture frames the
/// sampled surface.
///
/// Fails, never panics, on the inputs listed in [`crate::render`] (a cell
/// whose node count is no solid kind's is [`RenderError::InvalidCurvedMesh`]).
///
/// [`HexMesh`]: crate::mesh::HexMesh
pub fn render_hexes(
    mesh: &CurvedMesh<3>,
    cell_values: &[f64],
    opts: &RenderOptions3,
) -> Result<Pixmap, RenderError> {
    let plan = HexPlan::new(mesh, cell_values, opts)?;
    let mut pixmap = plan.frame.canvas()?;
    draw_patches(&mut pixmap, &plan, cell_values, opts.draw_edges);
    plan.frame.decorate(&mut pixmap);
    Ok(pixmap)
}

/// Everything decided before drawing a 3D mesh.
struct HexPlan {
    frame: Frame,
    view: View,
    /// Pieces per side of every face's grid.
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
        let m = pieces(mesh.p, SUBQUADS_PER_ORDER);
        let corners = Corners::of(mesh);
        let kept = kept_cells(mesh, &corners, opts.clip.as_ref());
        let patches = surface_patches(mesh, &corners, &kept, m);
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
        let (lo, hi) = opts.bounds.unwrap_or_else(|| bounding_box(&framed));
        // Finite, not reversed, and not a single point (a flat box is
        // fine: it can still be seen from the side).
        let ordered = (0..3).all(|k| lo[k].is_finite() && hi[k].is_finite() && hi[k] >= lo[k]);
        if !(ordered && (0..3).any(|k| hi[k] > lo[k])) {
            return Err(RenderError::InvalidBounds3 { lo, hi });
        }
        let view = View::new(&opts.camera, lo, hi)?;
        let frame = Frame::new(values, style!(opts), screen_bounds(&view, &framed))?;
        Ok(HexPlan {
            frame,
            view,
            m,
            patches,
        })
    }

    /// The image position (pixels, x right, y down) and depth key (smaller
    /// is nearer) of world point `p`, or `None` if it is behind the eye.
    fn to_image(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        let [x, y, depth] = self.view.project(p)?;
        let (px, py) = self.frame.layout.to_px([x, y]);
        Some([px as f64, py as f64, depth])
    }
}

/// A clip plane needs a finite point and a finite, non-zero normal, or
/// the side test would be meaningless.
fn validate_clip(clip: &ClipPlane) -> Result<(), RenderError> {
    let finite = clip.point.iter().chain(&clip.normal).all(|x| x.is_finite());
    if finite && dot(clip.normal, clip.normal) > 0.0 {
        Ok(())
    } else {
        Err(RenderError::InvalidClipPlane {
            point: clip.point,
            normal: clip.normal,
        })
    }
}

/// The eight corners of the box `lo..hi`.
fn box_corners(lo: [f64; 3], hi: [f64; 3]) -> [[f64; 3]; 8] {
    std::array::from_fn(|i| std::array::from_fn(|k| if i >> k & 1 == 0 { lo[k] } else { hi[k] }))
}

/// The box in screen coordinates (world units on the camera's right and
/// up axes) that the plot area shows: the projection of `points` (the
/// given box's corners, or the framed surface, a tighter frame than their
/// bounding box's corners). A side of zero length (a flat mesh seen
/// edge-on) is widened so the layout still has an area to map to.
fn screen_bounds(view: &View, points: &[[f64; 3]]) -> ([f64; 2], [f64; 2]) {
    let mut a = [f64::INFINITY; 2];
    let mut b = [f64::NEG_INFINITY; 2];
    // Every framing point is inside the bounding sphere, so in front of
    // the eye: `project` cannot fail here.
    for [x, y, _] in points.iter().filter_map(|&p| view.project(p)) {
        a = [a[0].min(x), a[1].min(y)];
        b = [b[0].max(x), b[1].max(y)];
    }
    let min_side = 0.02 * view.radius();
    for k in 0..2 {
        let grow = 0.5 * (min_side - (b[k] - a[k])).max(0.0);
        a[k] -= grow;
        b[k] += grow;
    }
    (a, b)
}

/// Which cells are drawn: all, or those whose centre (the mean of the
/// corner nodes, whatever the order, so a curved mesh and its
/// straight-sided version lose the same cells) is not on the positive side
/// of the clip plane; a cell cut by the plane is kept or dropped whole.
fn kept_cells(mesh: &CurvedMesh<3>, corners: &Corners, clip: Option<&ClipPlane>) -> Vec<bool> {
    let Some(clip) = clip else {
        return vec![true; mesh.cells.len()];
    };
    (0..mesh.cells.len())
        .map(|c| {
            // 1/8 and 1/4 are exact, so a hex's mean is the plain sum of
            // eighths
            let w = 1.0 / corners.cell(c).len() as f64;
            let centre = corners
                .cell(c)
                .iter()
                .fold([0.0; 3], |x, &n| add(x, scale(w, mesh.nodes[n])));
            dot(sub(centre, clip.point), clip.normal) <= 0.0
        })
        .collect()
}

/// A face ready to rasterise: its grid points on the canvas (samples, x
/// right, y down, depth key), its border segments there, its colour and
/// its grid's pieces.
struct Projected<'a> {
    patch: &'a Patch,
    /// The corner indices of the pieces of the face's grid, `per_piece` a
    /// piece.
    pieces: &'a [usize],
    per_piece: usize,
    px: Vec<[f64; 3]>,
    /// The smallest and largest y of `px`.
    rows: (f64, f64),
    border: Vec<[[f64; 3]; 2]>,
    base: [u8; 3],
}

/// Rasterises the surface into a supersampled z-buffer over the plot
/// region and copies the averaged result into `pixmap`. Bands of rows are
/// drawn side by side (each sample sees the same triangles in the same
/// order as in one pass: the same picture).
fn draw_patches(pixmap: &mut Pixmap, plan: &HexPlan, values: &[f64], draw_edges: bool) {
    let region = plan.frame.layout.plot_region();
    let ss = SUPERSAMPLE as f64;
    let (width, height) = ((region[2] * SUPERSAMPLE) as usize, (region[3] * SUPERSAMPLE) as usize);
    let edges = if draw_edges { edge_style(plan) } else { None };
    // The same for every face of a grid: computed once per grid.
    let grids = [Grid::Quad(plan.m), Grid::Tri(plan.m)].map(|g| (g, g.pieces(), g.border()));
    let of = |g: Grid| grids.iter().find(|x| x.0 == g).expect("faces are sampled on these grids");
    let faces: Vec<Projected> = plan
        .patches
        .par_iter()
        .filter_map(|patch| {
            // A face with a point behind the eye is skipped rather than
            // clipped: only possible when a given box cuts through the mesh.
            let px = patch
                .points
                .iter()
                .map(|&p| {
                    let [x, y, depth] = plan.to_image(p)?;
                    Some([(x - region[0] as f64) * ss, (y - region[1] as f64) * ss, depth])
                })
                .collect::<Option<Vec<[f64; 3]>>>()?;
            let rows = px.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p[1]), hi.max(p[1])));
            let (grid, pieces, border) = of(patch.grid);
            let border = border.iter().map(|&[a, b]| [px[a], px[b]]).collect();
            Some(Projected { patch, pieces, per_piece: grid.piece_corners(), border, px, rows, base: plan.frame.colour(values[patch.cell]) })
        })
        .collect();
    let bands = (4 * rayon::current_num_threads()).clamp(1, height.max(1));
    let canvases: Vec<Canvas> = (0..bands)
        .into_par_iter()
        .map(|b| {
            let mut canvas = Canvas::rows(width, height * b / bands..height * (b + 1) / bands);
            let mut drawn = Drawn::default();
            for (f, face) in faces.iter().enumerate() {
                if !canvas.meets_rows(face.rows.0, face.rows.1) {
                    continue;
                }
                for ids in face.pieces.chunks_exact(face.per_piece) {
                    draw_piece(&mut canvas, plan, (f, face), ids, edges, &mut drawn);
                }
            }
            canvas.paint_owned(|id, x, y| drawn.paint(id as usize, &faces, edges, x, y));
            canvas
        })
        .collect();
    let mut canvas = Canvas::stack(canvases);
    let outline = (OUTLINE_PX * plan.frame.layout.res() as f64 * ss).round() as usize;
    canvas.outline(outline.max(1), raster::INK, 0.9);
    canvas.blit(pixmap, region[0], region[1], SUPERSAMPLE);
}

/// The triangles a band covered, to paint its samples once they are all
/// drawn: each with its face, corners, light factors and the face border
/// segments near its piece (a range of `segments`).
#[derive(Default)]
struct Drawn {
    triangles: Vec<DrawnTriangle>,
    segments: Vec<[[f64; 3]; 2]>,
}

/// One triangle of [`Drawn`].
struct DrawnTriangle {
    face: usize,
    corners: [[f64; 3]; 3],
    light: [f64; 3],
    near: std::ops::Range<usize>,
}

impl Drawn {
    /// The colour at (x, y) of triangle `id`: its face's colour shaded by
    /// the light interpolated there, with the edge line laid over it.
    fn paint(&self, id: usize, faces: &[Projected], edges: Option<EdgeStyle>, x: f64, y: f64) -> [u8; 3] {
        let DrawnTriangle { face, corners, light, near } = &self.triangles[id];
        let colour = shade_colour(faces[*face].base, interpolate(corners, *light, x, y));
        match edges {
            Some(style) if !near.is_empty() => {
                // the line reaches `reach` from a segment: one whose box is
                // farther cannot darken (x, y), nor be the nearest of
                // those that do
                let reach = style.half_width + 0.5;
                let within = |[a, b]: &&[[f64; 3]; 2]| x >= a[0].min(b[0]) - reach && x <= a[0].max(b[0]) + reach && y >= a[1].min(b[1]) - reach && y <= a[1].max(b[1]) + reach;
                let d = self.segments[near.clone()].iter().filter(within).map(|[a, b]| distance_to_segment(*a, *b, x, y)).fold(f64::INFINITY, f64::min);
                edge_blend(colour, style, d)
            }
            _ => colour,
        }
    }
}

/// Rasterises the piece of `face` (the `f`-th) with grid corners `ids` (3
/// or 4) as the fan of triangles from its first corner, into `drawn` to
/// be shaded and have the face's border darkened where it passes.
fn draw_piece(
    canvas: &mut Canvas,
    plan: &HexPlan,
    (f, face): (usize, &Projected),
    ids: &[usize],
    edges: Option<EdgeStyle>,
    drawn: &mut Drawn,
) {
    let n = ids.len();
    let corners: [[f64; 3]; 4] = std::array::from_fn(|i| face.px[ids[i.min(n - 1)]]);
    let (lo, hi) = corners[..n].iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p[1]), hi.max(p[1])));
    if !canvas.meets_rows(lo, hi) {
        return;
    }
    let light = piece_light(plan, face.patch, ids);
    let start = drawn.segments.len();
    if let Some(style) = edges {
        drawn.segments.extend(nearby_segments(&face.border, &corners[..n], style.half_width + 1.0));
    }
    let near = start..drawn.segments.len();
    for t in 1..n - 1 {
        let tri = [corners[0], corners[t], corners[t + 1]];
        let id = u32::try_from(drawn.triangles.len()).expect("fewer than 2^32 triangles in a band");
        drawn.triangles.push(DrawnTriangle { face: f, corners: tri, light: [light[0], light[t], light[t + 1]], near: near.clone() });
        canvas.cover_triangle(tri, id);
    }
}

/// The light factor at the corners `ids` (3 or 4; unused entries 0) of a
/// piece: its corner normals, turned towards the viewer together when the
/// piece faces away (two-sided lighting), so faces of inverted cells and
/// inner faces exposed by clipping are lit like any other.
fn piece_light(plan: &HexPlan, patch: &Patch, ids: &[usize]) -> [f64; 4] {
    let world: [[f64; 3]; 4] = std::array::from_fn(|i| patch.points[ids[i.min(ids.len() - 1)]]);
    let world = &world[..ids.len()];
    let away = dot(
        view::polygon_normal(world),
        plan.view.to_eye(view::centroid(world)),
    ) < 0.0;
    // Corner normals point to the same side as the piece's own normal
    // (both follow the grid's orientation), so one flip serves all.
    let mut light = [0.0; 4];
    for (l, &i) in light.iter_mut().zip(ids) {
        let n = patch.normals[i];
        *l = plan
            .view
            .light_factor(if away { scale(-1.0, n) } else { n });
    }
    light
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

/// The border segments that come within `reach` samples of the bounding
/// box of `piece`: the only ones that can darken its samples. Taken from
/// the whole border, not just the piece's own sides, because small faces
/// have pieces narrower than the edge line.
fn nearby_segments(border: &[[[f64; 3]; 2]], piece: &[[f64; 3]], reach: f64) -> Vec<[[f64; 3]; 2]> {
    let lo = |k: usize| piece.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min) - reach;
    let hi = |k: usize| piece.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max) + reach;
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

/// The style of the face borders, like the 2D cell edges: from the median
/// face size in pixels (the square root of the area of its corners'
/// polygon in the world, as in 2D, times the scale, which does not vanish
/// for faces seen edge-on, as projected areas would in axis views).
fn edge_style(plan: &HexPlan) -> Option<EdgeStyle> {
    let sizes = plan.patches.iter().map(|f| {
        let polygon: Vec<[f64; 3]> = f.grid.corners().iter().map(|&i| f.points[i]).collect();
        view::polygon_area(&polygon).sqrt()
    });
    let (width, alpha) = plan.frame.edge_style(sizes.collect()).1?;
    Some(EdgeStyle {
        half_width: 0.5 * width as f64 * SUPERSAMPLE as f64,
        alpha,
    })
}
