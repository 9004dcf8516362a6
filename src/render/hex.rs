//! The 3D plan: the boundary surface of a hex mesh of any order, each face
//! filled with the colour of its cell's value and shaded by a light from
//! the camera's upper left, with its border drawn as the cell edges, a dark
//! silhouette, the colour bar and a title, as in the 2D pictures.
//!
//! Each boundary face is an `m × m` grid of small flat quads on the true
//! face (`m = 1` at `p = 1`, whose faces are bilinear, `m = `
//! [`SUBQUADS_PER_ORDER`]` · p` above), shaded by normals interpolated
//! from the grid points; the edge lines follow the border of the whole
//! face, so the sub-quads do not show.
//!
//! Hidden surfaces are removed with a z-buffer (two triangles per quad,
//! rasterised by our own code), not by sorting faces, because sorting fails
//! on concave meshes. The picture is rasterised at [`SUPERSAMPLE`]× the
//! resolution each way and averaged down, which anti-aliases both the
//! outline and the edge lines. Edge lines are drawn *inside* each face as
//! it is rasterised (a pixel within half a line width of the face's border
//! is darkened), so they take part in the depth test exactly like the
//! faces and hidden edges never show.
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

use super::{basis_table, bounding_box, pieces, validate, ColourMap, Frame, RenderError, Style};
use crate::mesh::element::order::HEX_CORNERS;
use crate::mesh::CurvedMesh;
use raster::{distance_to_segment, edge_blend, Canvas, EdgeStyle};
use surface::{surface_faces, HEX_FACES};
use crate::numeric::{add, cross3 as cross, dot, scale, sub};
use view::{shade_colour, View};

/// Each pixel is rasterised as `SUPERSAMPLE × SUPERSAMPLE` samples: 3 gives
/// smooth outlines and sub-pixel edge lines at a modest memory cost
/// (about 70 bytes per output pixel).
const SUPERSAMPLE: u32 = 3;

/// Width of the silhouette line in output pixels (inside the outline), at
/// a 900-pixel-wide image; it scales with the image like the 2D boundary.
const OUTLINE_PX: f64 = 1.3;

/// Sub-quads per face side and per unit of order (for `p > 1`): a
/// degree-`p` face needs a few flat pieces per polynomial degree to look
/// smooth both in outline and in shading.
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
/// eight corners) lies on the side the normal points to are not drawn.
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

/// Draws the boundary surface of the hex mesh `mesh` (any order; a linear
/// [`HexMesh`] is `CurvedMesh::from_hexes`), of the cells kept by the clip
/// plane if any, as shaded faces coloured by `cell_values` of their cell,
/// with each face's border drawn along its edges (if `opts.draw_edges`),
/// plus silhouette, colour bar and title. A face is on the surface when no
/// other kept cell has a face with the same four corner nodes; the mesh's
/// tagged `boundary` is not used. Without `opts.bounds` the picture frames
/// the sampled surface.
///
/// Fails, never panics, on the inputs listed in [`crate::render`].
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

/// One drawn face: the face sampled on an `(m+1) × (m+1)` grid.
struct Patch {
    /// The cell it belongs to (whose value colours it).
    cell: usize,
    /// World points, index `k + (m+1) l` for face parameters
    /// `(k/m, l/m)`; the grid's border is the face's border.
    points: Vec<[f64; 3]>,
}

/// Everything decided before drawing a hex mesh.
struct HexPlan {
    frame: Frame,
    view: View,
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
        let m = pieces(mesh.p, SUBQUADS_PER_ORDER);
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
/// eight corner nodes, whatever the order, so a curved mesh and its
/// straight-sided version lose the same cells) is not on the positive side
/// of the clip plane; a cell cut by the plane is kept or dropped whole.
fn kept_cells(mesh: &CurvedMesh<3>, clip: Option<&ClipPlane>) -> Vec<bool> {
    let Some(clip) = clip else {
        return vec![true; mesh.cells.len()];
    };
    mesh.cells
        .iter()
        .map(|cell| {
            let corners = corner_nodes(cell, mesh.p);
            let c = corners.iter().fold([0.0; 3], |c, &n| {
                add(c, scale(0.125, mesh.nodes[n]))
            });
            dot(sub(c, clip.point), clip.normal) <= 0.0
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
                        x = add(x, scale(wa * wb * wc, y));
                    }
                }
            }
            points.push(x);
        }
    }
    points
}

/// Rasterises the surface into a supersampled z-buffer over the plot
/// region and copies the averaged result into `pixmap`.
fn draw_patches(pixmap: &mut Pixmap, plan: &HexPlan, values: &[f64], draw_edges: bool) {
    let layout = &plan.frame.layout;
    let region = layout.plot_region();
    let ss = SUPERSAMPLE as f64;
    let mut canvas = Canvas::new(region[2] * SUPERSAMPLE, region[3] * SUPERSAMPLE);
    let edges = if draw_edges { edge_style(plan) } else { None };
    let m = plan.m;
    let at = |k: usize, l: usize| k + (m + 1) * l;
    for patch in &plan.patches {
        // A face with a point behind the eye is skipped rather than
        // clipped: only possible when a given box cuts through the mesh.
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
        let border: Vec<_> = face_border(m).map(|[a, b]| [px[a], px[b]]).collect();
        let base = plan.frame.colour(values[patch.cell]);
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
    let outline = (OUTLINE_PX * layout.res() as f64 * ss).round() as usize;
    canvas.outline(outline.max(1), raster::INK, 0.9);
    canvas.blit(pixmap, region[0], region[1], SUPERSAMPLE);
}

/// Unit normals of the sampled face at its grid points, from central
/// differences (one-sided on the border), all on the same side of the
/// face. Shading with these, interpolated over each sub-quad, makes a
/// curved face look smooth where flat sub-quads would show as facets.
fn grid_normals(points: &[[f64; 3]], m: usize) -> Vec<[f64; 3]> {
    let at = |k: usize, l: usize| points[k + (m + 1) * l];
    let mut normals = Vec::with_capacity(points.len());
    for l in 0..=m {
        for k in 0..=m {
            let du = sub(at((k + 1).min(m), l), at(k.saturating_sub(1), l));
            let dv = sub(at(k, (l + 1).min(m)), at(k, l.saturating_sub(1)));
            normals.push(view::normalise(cross(du, dv)));
        }
    }
    normals
}

/// The light factor at the four corners `ids` of a sub-quad: its corner
/// normals, turned towards the viewer together when the sub-quad faces
/// away (two-sided lighting), so faces of inverted cells and inner faces
/// exposed by clipping are lit like any other.
fn sub_quad_light(
    plan: &HexPlan,
    points: &[[f64; 3]],
    normals: &[[f64; 3]],
    ids: [usize; 4],
) -> [f64; 4] {
    let world = ids.map(|i| points[i]);
    let centre = scale(0.25, add(add(world[0], world[1]), add(world[2], world[3])));
    let away = dot(view::quad_normal(&world), plan.view.to_eye(centre)) < 0.0;
    // Corner normals point to the same side as the sub-quad's own normal
    // (both follow the grid's orientation), so one flip serves all four.
    ids.map(|i| {
        let n = if away {
            scale(-1.0, normals[i])
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

/// The style of the face borders, like the 2D cell edges: from the median
/// face size in pixels (its corners' world size times the scale, which
/// does not vanish for faces seen edge-on, as projected areas would in
/// axis views).
fn edge_style(plan: &HexPlan) -> Option<EdgeStyle> {
    let m = plan.m;
    let corners = [0, m, (m + 1) * (m + 1) - 1, (m + 1) * m];
    let sizes = plan
        .patches
        .iter()
        .map(|f| view::quad_area(&corners.map(|i| f.points[i])).sqrt());
    let (width, alpha) = plan.frame.edge_style(sizes.collect()).1?;
    Some(EdgeStyle {
        half_width: 0.5 * width as f64 * SUPERSAMPLE as f64,
        alpha,
    })
}
