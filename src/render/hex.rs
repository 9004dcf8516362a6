//! Pictures of a hexahedral mesh: its boundary surface, each face filled
//! with the colour of its cell's value and shaded by a light from the
//! camera's upper left, thin cell edges, a dark silhouette, the colour bar
//! and a title, as in the 2D pictures.
//!
//! Hidden surfaces are removed with a z-buffer (two triangles per face,
//! rasterised by our own code), not by sorting faces, because sorting fails
//! on concave meshes. The picture is rasterised at [`SUPERSAMPLE`]× the
//! resolution each way and averaged down, which anti-aliases both the
//! outline and the edge lines. Edge lines are drawn *inside* each face as
//! it is rasterised (a pixel within half a line width of the face's border
//! is darkened), so they take part in the depth test exactly like the
//! faces and hidden edges never show.
//!
//! With a [`ClipPlane`], cells whose centroid lies on the positive side of
//! the plane are dropped and the surface of the kept cells is drawn, so
//! the faces between kept and dropped cells show the inside.

pub(crate) mod raster;
pub(crate) mod surface;
#[cfg(test)]
mod tests;
pub(crate) mod view;

use tiny_skia::Pixmap;

use super::check_values;
use super::colour::ColourMap;
use super::layout::Layout;
use super::{canvas, decorate, draw, legend, resolve_range, Legend, RenderError};
use crate::mesh::HexMesh;
use raster::{Canvas, EdgeStyle};
use view::View;

/// Each pixel is rasterised as `SUPERSAMPLE × SUPERSAMPLE` samples: 3 gives
/// smooth outlines and sub-pixel edge lines at a modest memory cost
/// (about 70 bytes per output pixel).
pub(crate) const SUPERSAMPLE: u32 = 3;

/// Width of the silhouette line in output pixels (inside the outline), at
/// a 900-pixel-wide image; it scales with the image like the 2D boundary.
pub(crate) const OUTLINE_PX: f64 = 1.3;

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

/// A plane that cuts the mesh open: cells whose centroid lies on the side
/// the normal points to are not drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipPlane {
    /// Any point on the plane.
    pub point: [f64; 3],
    /// The normal, pointing to the side that is removed (need not be of
    /// unit length, but not zero).
    pub normal: [f64; 3],
}

/// What to draw and how, for [`render_hex`].
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
    /// `None` frames the drawn cells (those the clip plane keeps). Give all
    /// frames of an animation, or a clipped and an unclipped picture meant
    /// to be compared, the same box and camera so they line up.
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

/// Draws the boundary surface of `mesh` (of the cells kept by the clip
/// plane, if any), each face coloured by `cell_values` of its cell and
/// shaded, with edges, silhouette, colour bar and title as set in `opts`.
///
/// Fails (never panics) if the number of values differs from the number
/// of cells, if a value, node, bound, range, camera setting or clip plane
/// is not finite or is degenerate, if a cell refers to a missing node, or
/// if the image size is unusable. The mesh's tagged `faces` are not used:
/// the surface is found from the cells.
pub fn render_hex(
    mesh: &HexMesh,
    cell_values: &[f64],
    opts: &RenderOptions3,
) -> Result<Pixmap, RenderError> {
    let plan = Plan3::new(mesh, cell_values, opts)?;
    let layout = &plan.layout;
    let mut pixmap = canvas(layout)?;
    draw_surface(&mut pixmap, &plan, mesh, cell_values, opts);
    let legend = Legend { cmap: plan.cmap, range: plan.range, tick_labels: &plan.tick_labels, label: &opts.label, title: opts.title.as_deref() };
    decorate(&mut pixmap, layout, &legend);
    Ok(pixmap)
}

/// Everything decided before drawing: validated inputs turned into a
/// camera, colour range, colour map, tick labels and layout.
struct Plan3 {
    view: View,
    /// Which cells are drawn (see [`kept_cells`]).
    kept: Vec<bool>,
    range: (f64, f64),
    cmap: ColourMap,
    tick_labels: Vec<String>,
    layout: Layout,
}

impl Plan3 {
    fn new(mesh: &HexMesh, values: &[f64], opts: &RenderOptions3) -> Result<Plan3, RenderError> {
        validate(mesh, values)?;
        if let Some(clip) = &opts.clip {
            validate_clip(clip)?;
        }
        let range = resolve_range(values, opts.range)?;
        let kept = kept_cells(mesh, opts.clip.as_ref());
        let framed = match opts.bounds {
            Some((lo, hi)) => box_corners(lo, hi).to_vec(),
            None => framed_nodes(mesh, &kept),
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
        Ok(Plan3 {
            view,
            kept,
            range,
            cmap,
            tick_labels,
            layout,
        })
    }

    /// The image position of world point `p` (see [`to_image`]).
    fn to_image(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        to_image(&self.view, &self.layout, p)
    }
}

/// The image position (pixels, x right, y down) and depth key (smaller is
/// nearer) of world point `p` seen by `view` in `layout`, or `None` if it
/// is behind the eye.
pub(crate) fn to_image(view: &View, layout: &Layout, p: [f64; 3]) -> Option<[f64; 3]> {
    let [x, y, depth] = view.project(p)?;
    let (px, py) = layout.to_px([x, y]);
    Some([px as f64, py as f64, depth])
}

/// Checks that values match cells and everything is finite and in range,
/// so drawing cannot index out of bounds or produce garbage.
fn validate(mesh: &HexMesh, values: &[f64]) -> Result<(), RenderError> {
    check_values(values, mesh.cells.len())?;
    if let Some(index) = mesh
        .nodes
        .iter()
        .position(|p| !p.iter().all(|x| x.is_finite()))
    {
        return Err(RenderError::NonFiniteNode { index });
    }
    let nodes = mesh.nodes.len();
    let bad_cell = mesh
        .cells
        .iter()
        .enumerate()
        .find_map(|(cell, c)| c.iter().find(|&&n| n >= nodes).map(|&node| (cell, node)));
    match bad_cell {
        Some((cell, node)) => Err(RenderError::BadNodeIndex { cell, node, nodes }),
        None => Ok(()),
    }
}

/// A clip plane needs a finite point and a finite, non-zero normal, or
/// the side test would be meaningless.
pub(crate) fn validate_clip(clip: &ClipPlane) -> Result<(), RenderError> {
    let finite = clip.point.iter().chain(&clip.normal).all(|x| x.is_finite());
    if finite && view::dot(clip.normal, clip.normal) > 0.0 {
        Ok(())
    } else {
        Err(RenderError::InvalidClipPlane {
            point: clip.point,
            normal: clip.normal,
        })
    }
}

/// The nodes to frame when no box is given: those of the kept cells, so a
/// clipped mesh fills the picture; all nodes if no cell is kept.
fn framed_nodes(mesh: &HexMesh, kept: &[bool]) -> Vec<[f64; 3]> {
    let mut used = vec![false; mesh.nodes.len()];
    for (cell, _) in mesh.cells.iter().zip(kept).filter(|(_, &k)| k) {
        for &n in cell {
            used[n] = true;
        }
    }
    let nodes = mesh.nodes.iter().zip(&used).filter(|(_, &u)| u);
    let framed: Vec<[f64; 3]> = nodes.map(|(&p, _)| p).collect();
    if framed.is_empty() {
        mesh.nodes.clone()
    } else {
        framed
    }
}

/// The eight corners of the box `lo..hi`.
pub(crate) fn box_corners(lo: [f64; 3], hi: [f64; 3]) -> [[f64; 3]; 8] {
    std::array::from_fn(|i| std::array::from_fn(|k| if i >> k & 1 == 0 { lo[k] } else { hi[k] }))
}

/// The world box: the given one, or the bounding box of `points`; it must
/// be finite, not reversed, and not a single point (a flat box is fine: it
/// can still be seen from the side).
pub(crate) fn resolve_box(
    points: &[[f64; 3]],
    given: Option<([f64; 3], [f64; 3])>,
) -> Result<([f64; 3], [f64; 3]), RenderError> {
    let (lo, hi) = given.unwrap_or_else(|| {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    });
    let ordered = (0..3).all(|k| lo[k].is_finite() && hi[k].is_finite() && hi[k] >= lo[k]);
    if ordered && (0..3).any(|k| hi[k] > lo[k]) {
        Ok((lo, hi))
    } else {
        Err(RenderError::InvalidBounds3 { lo, hi })
    }
}

/// The box in screen coordinates (world units on the camera's right and
/// up axes) that the plot area shows: the projection of `points` (the
/// given box's corners, or the framed nodes, a tighter frame than their
/// bounding box's corners). A side of zero length (a flat mesh seen
/// edge-on) is widened so the layout still has an area to map to.
pub(crate) fn screen_bounds(view: &View, points: &[[f64; 3]]) -> ([f64; 2], [f64; 2]) {
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

/// Rasterises the visible surface into a supersampled z-buffer over the
/// plot area and copies the averaged result into `pixmap`.
fn draw_surface(
    pixmap: &mut Pixmap,
    plan: &Plan3,
    mesh: &HexMesh,
    values: &[f64],
    opts: &RenderOptions3,
) {
    let region = plot_region(&plan.layout);
    let ss = SUPERSAMPLE;
    let mut canvas = Canvas::new(region[2] * ss, region[3] * ss);
    let faces = surface::surface_faces(&mesh.cells, &plan.kept);
    let edges = edge_style(plan, mesh, &faces, opts.draw_edges);
    // Project every node once, straight into supersampled canvas pixels.
    let to_canvas = |p: [f64; 3]| {
        let [x, y, depth] = plan.to_image(p)?;
        let s = ss as f64;
        Some([
            (x - region[0] as f64) * s,
            (y - region[1] as f64) * s,
            depth,
        ])
    };
    let projected: Vec<Option<[f64; 3]>> = mesh.nodes.iter().map(|&p| to_canvas(p)).collect();
    for face in &faces {
        // A face with a node behind the eye is skipped rather than
        // clipped: only possible when a given box cuts through the mesh.
        let Some(corners) = face
            .nodes
            .iter()
            .map(|&n| projected[n])
            .collect::<Option<Vec<_>>>()
        else {
            continue;
        };
        let world = face.nodes.map(|n| mesh.nodes[n]);
        let base = plan.cmap.colour(values[face.cell], plan.range);
        let colour = plan.view.shade(base, &world);
        canvas.fill_quad(
            &[corners[0], corners[1], corners[2], corners[3]],
            colour,
            edges,
        );
    }
    let res = (plan.layout.width as f64 / 900.0).max(0.75);
    let outline = (OUTLINE_PX * res * ss as f64).round() as usize;
    canvas.outline(outline.max(1), raster::INK, 0.9);
    canvas.blit(pixmap, region[0], region[1], ss);
}

/// The pixel rectangle (x, y, w, h) the surface may be drawn in: the plot
/// area widened by half a margin, as for 2D pictures, so the silhouette is
/// not cut while a mesh outside a user-given box stays off the colour bar.
pub(crate) fn plot_region(layout: &Layout) -> [u32; 4] {
    let pad = 0.5 * layout.margin;
    let [x, y, w, h] = layout.plot;
    let x0 = (x - pad).floor().clamp(0.0, layout.width as f64) as u32;
    let y0 = (y - pad).floor().clamp(0.0, layout.height as f64) as u32;
    let x1 = (x + w + pad).ceil().clamp(x0 as f64, layout.width as f64) as u32;
    let y1 = (y + h + pad).ceil().clamp(y0 as f64, layout.height as f64) as u32;
    [x0, y0, x1 - x0, y1 - y0]
}

/// Which cells are drawn: all, or those whose centroid is not on the
/// positive side of the clip plane (the centroid, not the nodes, so a cell
/// cut by the plane is kept or dropped whole).
fn kept_cells(mesh: &HexMesh, clip: Option<&ClipPlane>) -> Vec<bool> {
    let Some(clip) = clip else {
        return vec![true; mesh.cells.len()];
    };
    mesh.cells
        .iter()
        .map(|cell| {
            let mut c = [0.0; 3];
            for &n in cell {
                c = view::add(c, view::scale(mesh.nodes[n], 0.125));
            }
            view::dot(view::sub(c, clip.point), clip.normal) <= 0.0
        })
        .collect()
}

/// The style of the cell edges: like 2D interior edges, chosen from the
/// median face size in pixels (robust to a few tiny or huge faces), and
/// none if edges are off or faces too small to show them.
fn edge_style(
    plan: &Plan3,
    mesh: &HexMesh,
    faces: &[surface::SurfaceFace],
    wanted: bool,
) -> Option<EdgeStyle> {
    if !wanted || faces.is_empty() {
        return None;
    }
    // The world size of the face times the scale at the centre of the
    // view: unlike projected areas, this does not vanish for faces seen
    // edge-on, which would make the median meaningless in axis views.
    let mut sizes: Vec<f64> = faces
        .iter()
        .map(|f| view::quad_area(&f.nodes.map(|n| mesh.nodes[n])).sqrt())
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
