//! Algorithms 2 and 3 together: a coarse Q1 mesh and its boundary parts
//! in, a certified curved mesh of order-p Lagrange elements out.
//!
//! The coarse mesh is subdivided at the element nodes, Algorithm 2
//! ([`crate::refine`]) carries the new boundary nodes onto the
//! true geometry, and each coarse cell's (p+1)^d fine nodes become one
//! element (Algorithm 3). Every element is then certified by the Bézier
//! bounds of its det J, and the curved boundary is sampled against the
//! exact shapes.

use super::{check_order, Basis1d, HighOrderError, Spacing};
use crate::mesh::element::Shape;
use crate::mesh::Cells;
use crate::quality::certify::{Certificate, Certifiers, CertifyOptions};
use crate::refine::{refine_parts, subdivide, subdivide_mixed, subdivide_mixed_solid, RefineMesh, Settle, SettlePlan, Subdividable, Subdivision, ALG2_BAND};
use crate::deform::{BoundaryPart, DeformError, DeformOptions, Deformation, PartKind, RunStats, SolverChoice, THIN_ASPECT, THIN_TOLERANCE};
use crate::mesh::{CurvedMesh, Facet};
use crate::jacobian::JacobianField;
use super::repair::{Candidate, Repair, MAX_STEPS};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::time::Instant;

/// Options of Algorithms 2 and 3.
#[derive(Clone, Debug)]
pub struct CurveOptions {
    /// Element order p, 1 ..= 4.
    pub order: usize,
    /// Where the element nodes sit.
    pub spacing: Spacing,
    /// Pseudo-time steps of Algorithm 2 (the paper doubles Algorithm 1's
    /// step); None: as few as `step_change` allows.
    pub steps: Option<usize>,
    /// Without `steps`, the step control: the largest relative change of
    /// a fine cell's corner Jacobian in one step ([`CURVE_STEP_CHANGE`]).
    pub step_change: f64,
    /// Options of the flow (integrator, solver); `steps` above wins.
    pub flow: DeformOptions,
    /// Boundary samples per element edge direction for the geometric
    /// error (on top of the nodes).
    pub samples: usize,
    /// New nodes of every curved part follow straight paths to their
    /// images (the paper's Dirichlet data) instead of sliding.
    pub dirichlet: bool,
    /// After sliding, settle: move the new nodes of curved parts to the
    /// images of their places on the flat facets, with the flow carrying
    /// the cells next to them ([`crate::refine::RefineMesh::settling`]),
    /// and keep the result if every element stays certified valid.
    pub settle: bool,
    /// How far a node of a curved part may lie from its shape, relative
    /// to the shortest edge of its boundary elements: checked on the input
    /// (the shape must match the mesh) and on the result (no node pinned
    /// off the shape). See [`DEFAULT_SHAPE_TOLERANCE`].
    pub shape_tolerance: f64,
    /// Algorithm 2 solves only within this many bend lengths (about a
    /// facet's length along the wall) of the new nodes of the curved parts,
    /// the nodes beyond held
    /// ([`Subdivision::band`], [`ALG2_BAND`]); widened where an element not
    /// certified valid has a held node. None: on the whole mesh.
    pub band: Option<f64>,
    /// First try Gmsh's `setOrder` way: the new nodes of the curved
    /// facets put on their shapes, nothing else moved; keep it, without
    /// running Algorithm 2, if every element is certified valid and keeps
    /// [`SNAP_KEEP`] of its straight scaled Jacobian or of the straight
    /// mesh's least ([`SnapFirst`]).
    /// Off by default in the library (the method is Algorithm 2); `curve`'s
    /// `--snap auto`, its default, turns it on.
    pub snap_first: bool,
    /// Then raise the least distortion of the simplices (Gmsh's `minSJ`)
    /// by moving their inner nodes ([`super::optimise`]). Off by default
    /// in the library; `curve`'s `--optimise auto`, its default, turns it
    /// on.
    pub optimise: bool,
}

/// The default of [`CurveOptions::shape_tolerance`]: 1e-3 of the local
/// edge. Gmsh puts the nodes of a meshed curve or surface on it to
/// rounding (measured: wall nodes of `cylinder_bl_coarse.msh` within
/// 5.6e-17 of r = 0.5, 2.1e-16 of their edges of 0.259; sphere nodes of
/// `ball_octant_hex.msh` within 2.2e-16 of r = 1), while a shape visibly
/// off (r = 0.51 on that cylinder: 3.9e-2 of the edge) is far above;
/// 1e-3 leaves room for shapes typed with 4–5 significant digits.
pub const DEFAULT_SHAPE_TOLERANCE: f64 = 1e-3;

/// The step control of Algorithm 2 when no step count is given: no step
/// may change the Jacobian at a corner of a fine Q1 cell by more than this
/// fraction, as predicted from the velocity before the step and as
/// measured after it, put-back onto the walls included
/// ([`crate::deform::strain`], [`DeformOptions::max_strain`]). The motion
/// of Algorithm 2 is local and small: on the benchmark cylinder and ball
/// meshes one step takes the whole way (corner ratios 0.90–1.11), while a
/// 1e-5 boundary layer at p = 3 gets 6 steps.
pub const CURVE_STEP_CHANGE: f64 = 0.25;

/// Without a given step count, the largest steps of the successive runs
/// of Algorithm 2 (as step counts: 1/1, 1/2, 1/4, 1/8): the next run
/// only if the last left an element not certified valid. Eight steps are
/// the most, near the 10 that were the default before the step control.
/// Each step size is run with sliding, then, if that left an element
/// invalid, with the paper's Dirichlet data ([`BoundaryData`]).
pub const AUTO_STEPS: [usize; 4] = [1, 2, 4, 8];

impl Default for CurveOptions {
    fn default() -> Self {
        CurveOptions { order: 3, spacing: Spacing::Equispaced, steps: None, step_change: CURVE_STEP_CHANGE, flow: DeformOptions::default(), samples: 16, dirichlet: false, settle: true, shape_tolerance: DEFAULT_SHAPE_TOLERANCE, band: Some(ALG2_BAND), snap_first: false, optimise: false }
    }
}

/// What the repair tried and how the last run ended
/// ([`CurveError::NoCandidate`]).
pub fn unrepaired(tried: &str, last: &DeformError, whole: bool) -> String {
    if whole {
        format!("{tried}; Algorithm 2 on the whole mesh: {}", with_causes(last))
    } else {
        format!("{tried}; the larger patch stalled as the smaller did, as Algorithm 2 on the whole mesh would: not run")
    }
}

/// An error and its causes, joined by ": " (so that a solver's reason is
/// not lost where the error is shown as text, not as a chain).
fn with_causes(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text = format!("{text}: {c}");
        cause = c.source();
    }
    text
}

/// Errors of curving a mesh.
#[derive(Debug, thiserror::Error)]
pub enum CurveError {
    /// The order or node layout is not supported.
    #[error(transparent)]
    Order(#[from] HighOrderError),
    /// The coarse mesh is invalid: no high-order mesh is made from it.
    #[error("the mesh to be curved already has {} invalid cell(s): {:?}", .0.len(), &.0[..(.0.len().min(20))])]
    InvalidCoarse(Vec<usize>),
    /// The mesh of several kinds to be curved is not linear.
    #[error("the mesh to be curved is of order {0}: curving starts from a linear mesh (order 1)")]
    NotLinear(usize),
    /// The mesh's boundary elements do not fit its cells.
    #[error(transparent)]
    Subdivide(#[from] crate::refine::SubdivideError),
    /// Algorithm 2 failed (a tangle, an unreachable target, ...).
    #[error("Algorithm 2 (carrying the high-order boundary nodes onto the geometry): {}", with_causes(.0))]
    Deform(DeformError),
    /// A node of a curved part is off its shape by more than the
    /// tolerance: the shape does not match the mesh (`after` false), or a
    /// neighbouring group held a node off it (`after` true).
    #[error("{}", off_shape_message(.0))]
    OffShape(Box<OffShape>),
    /// No candidate was certified valid: the snap left elements invalid,
    /// no patch around them mended them, and Algorithm 2 on the whole
    /// mesh ended without a result.
    #[error("no result certified valid: the snap left {} element(s) not certified valid, the first {:?}; {}", bad.len(), &bad[..bad.len().min(10)], unrepaired(tried, last, *whole))]
    NoCandidate {
        /// The elements the snap left not certified valid.
        bad: Vec<usize>,
        /// The patches, and how each ended.
        tried: String,
        /// How the last run ended: the whole mesh's, or the patches'
        /// where a larger patch stalled as the smaller did.
        last: DeformError,
        /// Whether the whole mesh ran (else a larger patch stalled as the
        /// smaller did, and so would the whole mesh).
        whole: bool,
    },
}

// By hand, not `#[from]`: that would also make the DeformError the source,
// and a chain printer (anyhow's `{:#}`) would then print its text twice.
impl From<DeformError> for CurveError {
    fn from(e: DeformError) -> Self {
        CurveError::Deform(e)
    }
}

/// Where a curved part's node is farthest off its shape, relative to the
/// local edge length.
#[derive(Debug, Clone, PartialEq)]
pub struct OffShape {
    /// The group.
    pub group: String,
    /// Distance of the node to the shape.
    pub distance: f64,
    /// Shortest edge of the group's boundary elements at the node.
    pub edge: f64,
    /// The tolerance relative to `edge`.
    pub tolerance: f64,
    /// The node (0-based index of the mesh's nodes; after curving, of the
    /// curved mesh's).
    pub node: usize,
    /// Its MSH node tag, when the caller knows it.
    pub tag: Option<u64>,
    /// Its position.
    pub at: Vec<f64>,
    /// Found on the curved result rather than on the input.
    pub after: bool,
}

fn off_shape_message(o: &OffShape) -> String {
    let node = match (o.tag, o.after) {
        (Some(t), _) => format!("node {t}"),
        (None, true) => "a node".to_string(),
        (None, false) => format!("a node (index {})", o.node),
    };
    let at: Vec<String> = o.at.iter().map(|x| format!("{x}")).collect();
    let what = if o.after {
        "after curving, a node of curved group `{g}` is off its shape (held there by a neighbouring group, e.g. a `fixed` one whose nodes do not lie on this shape)"
    } else {
        "the shape of curved group `{g}` does not match the mesh"
    };
    format!(
        "{}: {node} at ({}) is {:.3e} from the shape, {:.2e} of its shortest adjacent edge {:.3e}; at most {:.1e} is accepted (relax with --shape-tolerance or `shape_tolerance` in the geometry file)",
        what.replace("{g}", &o.group),
        at.join(", "),
        o.distance,
        o.distance / o.edge,
        o.edge,
        o.tolerance
    )
}

/// The node of a moving part farthest off its shape relative to the
/// shortest edge of the part's facets at it, if beyond `tol`. Facets are
/// `(nodes, part)`; `corners` gives a facet's corner nodes in cyclic
/// order, between which the edges are measured.
fn worst_off_shape<const D: usize>(
    nodes: &[[f64; D]],
    facets: &[(Vec<usize>, usize)],
    corners: impl Fn(usize) -> Vec<usize>,
    parts: &[BoundaryPart<D>],
    names: &[String],
    tol: f64,
) -> Option<OffShape> {
    use std::collections::HashMap;
    let len = |a: usize, b: usize| (0..D).map(|k| (nodes[a][k] - nodes[b][k]).powi(2)).sum::<f64>().sqrt();
    // per (part, node): the shortest edge of the part's facets at it
    let mut edge: HashMap<(usize, usize), f64> = HashMap::new();
    for (k, (f, part)) in facets.iter().enumerate() {
        if !matches!(parts.get(*part).map(|p| &p.kind), Some(PartKind::Move { .. })) {
            continue;
        }
        let c = corners(k);
        let shortest = (0..c.len()).map(|i| len(c[i], c[(i + 1) % c.len()])).fold(f64::INFINITY, f64::min);
        for &n in f {
            let e = edge.entry((*part, n)).or_insert(f64::INFINITY);
            *e = e.min(shortest);
        }
    }
    let mut worst: Option<(f64, OffShape)> = None;
    for (&(part, n), &h) in &edge {
        let PartKind::Move { target, .. } = &parts[part].kind else { continue };
        let d = target.distance(nodes[n]);
        // a NaN distance is off the shape too
        let ratio = if d.is_nan() { f64::INFINITY } else { d / h };
        if !(ratio <= tol) && worst.as_ref().is_none_or(|w| ratio > w.0 || (ratio == w.0 && n < w.1.node)) {
            let group = names.get(part).cloned().unwrap_or_else(|| parts[part].name.clone());
            worst = Some((ratio, OffShape { group, distance: d, edge: h, tolerance: tol, node: n, tag: None, at: nodes[n].to_vec(), after: false }));
        }
    }
    worst.map(|w| w.1)
}

/// The figures of a curved mesh.
#[derive(Clone, Debug, Serialize)]
pub struct CurvedQuality {
    /// Element order.
    pub order: usize,
    /// Elements.
    pub elements: usize,
    /// Nodes.
    pub nodes: usize,
    /// Certified lower bound of det J over all elements (reference
    /// `[0,1]^d`; Gmsh's `[−1,1]^d` gives 2^−d of it).
    pub min_det_j: f64,
    /// A value of det J actually attained, at most this much above the bound.
    pub min_det_j_attained: f64,
    /// Upper bound of det J.
    pub max_det_j: f64,
    /// Smallest and largest per-element minimum scaled Jacobian (sampled on
    /// a (3p+1)^d grid).
    pub scaled_jacobian: crate::quality::Range,
    /// Elements whose det J is not certified positive: 0-based indices
    /// (the `quality` command turns them into the file's element tags).
    pub invalid_elements: Vec<usize>,
    /// Largest distance of a boundary node of a curved part to its shape.
    pub boundary_node_distance: f64,
    /// Largest distance of a densely sampled point of the curved boundary
    /// to its shape.
    pub boundary_sample_distance: f64,
    /// Per curved group, the largest relative change of the first-layer
    /// height: the distance from a node of a curved boundary element to the
    /// node across its cell (the opposite face, same face coordinates),
    /// curved against straight, at the coarse vertices and over all nodes.
    pub first_layer_change: BTreeMap<String, FirstLayer>,
    /// Per curved group, the largest distance of its nodes and of its
    /// sampled boundary to its shape.
    pub boundary_error: BTreeMap<String, BoundaryError>,
    /// The settling pass that puts the sliding nodes at their intended
    /// places.
    pub settling: Settling,
    /// The boundary data of the run of Algorithm 2 whose mesh this is.
    pub boundary_data: BoundaryData,
    /// Where Algorithm 2 solved.
    pub band: Band,
    /// The snap tried before Algorithm 2 ([`CurveOptions::snap_first`]).
    pub snap_first: SnapFirst,
    /// The candidates (the snap, its repairs in patches, the whole mesh)
    /// and which was written ([`super::repair`]).
    pub repair: Repair,
}

/// What the snap before Algorithm 2 did ([`CurveOptions::snap_first`]).
#[derive(Clone, Debug, Default, Serialize)]
pub struct SnapFirst {
    /// It was tried.
    pub tried: bool,
    /// Its mesh is the result: Algorithm 2 did not run.
    pub kept: bool,
    /// The kept snap put the new nodes at their fitted places
    /// ([`Settle::Fit`]), not at equal arc length.
    pub fitted: bool,
    /// Why it was not kept: the first elements it left not certified
    /// valid or sheared under [`SNAP_KEEP`] of their straight scaled
    /// Jacobian and of the straight mesh's least.
    pub refused: Option<String>,
}

/// Where Algorithm 2 solved ([`CurveOptions::band`]).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Band {
    /// The band's width in bend lengths in the run kept; None: the whole
    /// mesh.
    pub width: Option<f64>,
    /// Fine nodes free to move in it (every fine node without a band).
    pub nodes: usize,
    /// All fine nodes.
    pub all_nodes: usize,
    /// Times the band was doubled because an element not certified valid
    /// had a node it held.
    pub widened: usize,
}

/// Which boundary data carried the new boundary nodes in the run of
/// Algorithm 2 that was kept ([`AUTO_STEPS`]).
#[derive(Clone, Debug, Default, Serialize)]
pub struct BoundaryData {
    /// The paper's Dirichlet data (straight paths to the images of the
    /// flat places) rather than sliding.
    pub dirichlet: bool,
    /// If Dirichlet data were the fallback: what the sliding run with the
    /// same steps left.
    pub sliding_left: Option<SlidingLeft>,
}

/// What a sliding run left when Dirichlet data took over.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SlidingLeft {
    /// Elements certified inverted (stopped early: those of curved
    /// facets) or not certified valid (at t = 1).
    pub elements: usize,
    /// Where the run stopped: at the first element of a curved facet
    /// certified inverted, where the drift was foreseen, or 1.
    pub t: f64,
    /// The largest relative change of a first row's height (a curved
    /// facet's node to the node one row in) per unit of t when it stopped:
    /// above [`DRIFT_LIMIT`] the run is stopped before t = 1.
    pub first_row_drift: f64,
}

/// A sliding run whose first rows' heights change faster than this, per
/// unit of pseudo-time, is stopped and run with Dirichlet data. Why: the
/// sliding drift (docs/METHOD.md §9) grows about linearly in t, so the
/// first steps foretell it. Measured from the first step on: 1.9 – 5.2
/// in every run sliding left invalid (1e-5 layers at p = 3 in 2D and 3D,
/// p = 4 in 2D; the sphere's 1e-4 layer at p = 3), 0.22 – 0.68 in the
/// runs it left valid (the extruded 1e-5 and 1e-3 layers at p = 2, 1e-3
/// at p = 3; the sphere at p = 2; the 2D 1e-3 layer at p = 3, 4), but 1.16
/// – 1.35 in one it left valid too (the 2D 1e-5 layer with wall size 0.1
/// at p = 3; 2.0 on the sphere's 2 × 2 O-grid at p = 3). So it foretells
/// a drift larger than the first rows themselves, not always an inverted
/// element; 1 means a first row twice its height by t = 1. A stop too
/// many costs nothing but the sliding start: the settling puts the new
/// nodes at the same places after either run (3.81e-7 on that layer both
/// ways); a stop too few costs the whole sliding run. Not applied when
/// the settling is off (`--mode sliding_only` asks for sliding's places).
pub const DRIFT_LIMIT: f64 = 1.0;

/// The elements with a node on a curved facet, watched during a sliding
/// run of Algorithm 2.
struct Watch {
    certifiers: Certifiers,
    /// The watched elements with their kind.
    elements: Vec<(Shape, Vec<usize>)>,
    /// Per node of a curved facet of a watched element, the node one row
    /// in from it and their distance at the start: the first rows'
    /// heights, which sliding's drift changes ([`Watch::drift`]).
    rows: Vec<(usize, usize, f64)>,
}

impl Watch {
    fn new<M: crate::deform::Q1Mesh<D, N>, const D: usize, const N: usize>(sub: &Subdivision<M, D>, parts: &[BoundaryPart<D>], spacing: Spacing) -> Result<Self, HighOrderError> {
        let mut on = vec![false; sub.fine.nodes().len()];
        for (nodes, part) in &sub.facets {
            if matches!(parts[*part].kind, PartKind::Move { .. }) {
                nodes.iter().for_each(|&n| on[n] = true);
            }
        }
        let watched = (0..sub.elements.len()).filter(|&e| sub.elements[e].iter().any(|&n| on[n]));
        let elements: Vec<(Shape, Vec<usize>)> = watched.map(|e| (sub.element_shape(e), sub.elements[e].to_vec())).collect();
        let shapes = sub.shapes();
        let mut rows = Vec::new();
        for &shape in &shapes {
            let of_shape: Vec<Vec<usize>> = elements.iter().filter(|e| e.0 == shape).map(|e| e.1.clone()).collect();
            rows.extend(first_rows::<D>(shape, &of_shape, sub.p, &on, sub.fine.nodes()));
        }
        Ok(Watch { certifiers: Certifiers::new(&shapes, sub.p, spacing)?, elements, rows })
    }

    /// The largest relative change of a first row's height since the start.
    fn drift<const D: usize>(&self, nodes: &[[f64; D]]) -> f64 {
        self.rows.par_iter().map(|&(a, b, h0)| (crate::numeric::dist2(nodes[a], nodes[b]).sqrt() / h0 - 1.0).abs()).reduce(|| 0.0, f64::max)
    }

    /// How many watched elements are certified inverted (det J ≤ 0 at a
    /// point): a cheap search, as validity here needs no tight bound.
    fn inverted<const D: usize>(&self, nodes: &[[f64; D]]) -> usize {
        let quick = CertifyOptions { rel_tol: 0.5, max_splits: 64, samples: 2 };
        self.elements
            .par_iter()
            .filter(|(shape, e)| {
                let ctrl: Vec<[f64; D]> = e.iter().map(|&n| nodes[n]).collect();
                self.certifiers.of(*shape).certify(&ctrl, &quick).min_det_upper <= 0.0
            })
            .count()
    }
}

/// Per node of a face of `elements` (order p, of `shape`) that lies on
/// the boundary (`on`), the node one row in from it and their distance.
fn first_rows<const D: usize>(shape: Shape, elements: &[Vec<usize>], p: usize, on: &[bool], nodes: &[[f64; D]]) -> Vec<(usize, usize, f64)> {
    let mut rows = Vec::new();
    let faces = element_faces::<D>(shape, p, 1);
    for e in elements {
        for face in &faces {
            if face.iter().all(|&(a, _, _)| on[e[a]]) {
                rows.extend(face.iter().map(|&(a, b, _)| (e[a], e[b], crate::numeric::dist2(nodes[e[a]], nodes[e[b]]).sqrt())));
            }
        }
    }
    rows
}

/// The faces (edges in 2D) of an order-p element of `shape`, in local
/// node numbers: per node of the face, the node `depth` rows in from it
/// (`depth` = p: across the element) and whether it is a corner.
fn element_faces<const D: usize>(shape: Shape, p: usize, depth: usize) -> Vec<Vec<(usize, usize, bool)>> {
    if shape == Shape::Prism {
        return prism_faces(p, depth);
    }
    if shape == Shape::Pyramid {
        return pyramid_faces(p, depth);
    }
    if shape.is_simplex() {
        return (0..=D).map(|opp| simplex_face_columns(shape, p, opp, depth)).collect();
    }
    let local: Vec<usize> = (0..(p + 1).pow(D as u32)).collect();
    let mut out = Vec::new();
    for d in 0..D {
        for side in [0, p] {
            out.push(face_columns::<D>(&local, p, d, side, depth).collect());
        }
    }
    out
}

/// [`element_faces`] of an order-p prism (lattice order of
/// [`crate::mesh::element::prism`]): the bottom and top triangles, each
/// node with the node `depth` layers in; the three quads, each node with
/// the node `depth` rows in across the triangle of its layer (as a
/// triangle's edge has it).
fn prism_faces(p: usize, depth: usize) -> Vec<Vec<(usize, usize, bool)>> {
    let nt = (p + 1) * (p + 2) / 2;
    let corner = |t: usize| crate::mesh::element::simplex::vertex_nodes(Shape::Triangle, p).contains(&t);
    let layer = |k: usize, inner: usize| (0..nt).map(|t| (k * nt + t, inner * nt + t, corner(t))).collect();
    let mut out: Vec<Vec<(usize, usize, bool)>> = vec![layer(0, depth.min(p)), layer(p, p - depth.min(p))];
    for opp in 0..3 {
        let columns = simplex_face_columns(Shape::Triangle, p, opp, depth);
        out.push((0..=p).flat_map(|k| columns.iter().map(move |&(t, inner, v)| (k * nt + t, k * nt + inner, v && (k == 0 || k == p)))).collect());
    }
    out
}

/// [`element_faces`] of an order-p pyramid (lattice order of
/// [`crate::mesh::element::pyramid`], faces of [`Shape::faces`]): each
/// node with the node `depth` steps in along the lattice axis that leaves
/// its face (up from the base, across the square layer from a triangle),
/// kept in the lattice (towards the apex the layers narrow); the apex, on
/// all four triangles, with a node of the layer below off the face.
fn pyramid_faces(p: usize, depth: usize) -> Vec<Vec<(usize, usize, bool)>> {
    use crate::mesh::element::pyramid::{face_nodes, lattice, lattice_index, vertex_nodes};
    let lat = lattice(p);
    let vertices = vertex_nodes(p);
    let inward = |face: usize, [i, j, k]: [usize; 3]| -> [usize; 3] {
        let n = p - k;
        if n == 0 && face < 4 {
            // the apex, on every lateral face: a node of the layer below
            // off the face
            let [i, j] = [[0, 1], [1, 0], [0, 0], [0, 0]][face];
            return [i, j, p - 1];
        }
        match face {
            // (0,1,4) at j = 0; (3,0,4) at i = 0; (1,2,4) at i = n; (2,3,4) at j = n
            0 => [i, j + depth.min(n), k],
            1 => [i + depth.min(n), j, k],
            2 => [i - depth.min(i), j, k],
            3 => [i, j - depth.min(j), k],
            _ => {
                let up = depth.min(p);
                [i.min(p - up), j.min(p - up), up]
            }
        }
    };
    (0..Shape::Pyramid.faces().len())
        .map(|f| face_nodes(p, f).into_iter().map(|a| (a, lattice_index(p, inward(f, lat[a])), vertices.contains(&a))).collect())
        .collect()
}

/// The nodes of face `side` (0 or p) across axis `d` of the tensor-ordered
/// order-p element `el`, each with the node `depth` rows in from it and
/// whether it is one of the element's corners.
fn face_columns<const D: usize>(el: &[usize], p: usize, d: usize, side: usize, depth: usize) -> impl Iterator<Item = (usize, usize, bool)> + '_ {
    let n1 = p + 1;
    let index = move |l: usize, a: usize| l / n1.pow(a as u32) % n1;
    let step = depth * n1.pow(d as u32);
    (0..n1.pow(D as u32)).filter(move |&l| index(l, d) == side).map(move |l| {
        let inner = if side == 0 { l + step } else { l - step };
        (el[l], el[inner], (0..D).all(|a| index(l, a) % p == 0))
    })
}

/// The face of a simplex element (lattice order) opposite vertex `opp`:
/// per node of it (barycentric index 0 at `opp`), the node `depth` rows
/// towards `opp` (taken from its largest other barycentric index, so it
/// stays in the element; `depth` = p reaches the vertex `opp` itself) and
/// whether it is a vertex.
fn simplex_face_columns(shape: Shape, p: usize, opp: usize, depth: usize) -> Vec<(usize, usize, bool)> {
    let lattice = crate::mesh::element::simplex::lattice(shape, p);
    let dim = shape.dim();
    let bary = |l: &[usize; 3]| -> [usize; 4] { std::array::from_fn(|a| if a == 0 { p - l[..dim].iter().sum::<usize>() } else if a <= dim { l[a - 1] } else { 0 }) };
    let position: std::collections::HashMap<[usize; 4], usize> = lattice.iter().enumerate().map(|(k, l)| (bary(l), k)).collect();
    let mut out = Vec::new();
    for (k, l) in lattice.iter().enumerate() {
        let b = bary(l);
        if b[opp] != 0 {
            continue;
        }
        let mut inner = b;
        let mut left = depth;
        while left > 0 {
            // one step towards opp from the largest other index
            let from = (0..=dim).filter(|&a| a != opp).max_by_key(|&a| (inner[a], std::cmp::Reverse(a))).expect("a face has vertices");
            if inner[from] == 0 {
                break;
            }
            inner[from] -= 1;
            inner[opp] += 1;
            left -= 1;
        }
        let corner = b.iter().filter(|&&x| x != 0).count() == 1;
        out.push((k, position[&inner], corner));
    }
    out
}

/// What the settling pass did ([`CurveOptions::settle`]).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Settling {
    /// The pass ran and its mesh is the result.
    pub applied: bool,
    /// `snap` (the nodes alone were put at their places) or `flow` (the
    /// correction ran as a flow, moving the cells next to the wall too).
    pub how: Option<&'static str>,
    /// The largest distance a node moved in the pass.
    pub largest_move: f64,
    /// Its accepted steps.
    pub steps: usize,
    /// The new nodes went to their fitted places ([`Settle::Fit`]); else
    /// to equal arc length, where a fitted place cost a cell more than
    /// [`FIT_KEEP`] of its scaled Jacobian.
    pub fitted: bool,
    /// Elements whose new boundary nodes did not go to their places along
    /// the arc, as placing them there left the element not certified
    /// valid: they went to the images of their flat places or, failing
    /// that too, stayed where sliding put them.
    pub demoted_elements: Vec<usize>,
    /// Elements with a node the settling left where Algorithm 2 put it,
    /// as both other places left an element invalid (0-based).
    pub kept_elements: Vec<usize>,
    /// Why the nodes were left where sliding put them, if they were (the
    /// pass was off, tangled, or left elements not certified valid).
    pub kept_sliding: Option<String>,
}

/// Largest relative change of the first-layer height along a curved group.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct FirstLayer {
    /// At the coarse vertices (the old nodes: fixed, so 0 unless a vertex
    /// across the layer moved).
    pub vertices: f64,
    /// At every node of the group's elements, new nodes included (shear
    /// along the wall counts too).
    pub all_nodes: f64,
}

/// A curved mesh with its certificates and figures.
pub struct Curved<const D: usize> {
    /// The mesh of order-p Lagrange elements.
    pub mesh: CurvedMesh<D>,
    /// Per element, its det J certificate: bracketed to 1e-3
    /// ([`CertifyOptions::element`]), to 1e-7 on the elements that may
    /// hold the mesh's least or largest det J.
    pub certificates: Vec<Certificate>,
    /// Summary figures.
    pub quality: CurvedQuality,
    /// Counters and timings of Algorithm 2 (its last run).
    pub stats: RunStats,
    /// Runs of Algorithm 2: more than one when, without a given step
    /// count, an element was not certified valid and the run was redone
    /// with shorter steps ([`AUTO_STEPS`]).
    pub attempts: usize,
    /// Its linear solves (the last run).
    pub solver: crate::deform::SolverReport,
    /// Seconds spent in Algorithm 2, in certification.
    pub seconds: (f64, f64),
    /// The node of `mesh` at each node of the linear mesh (`usize::MAX`
    /// for a node in no cell), so that what a file said of its nodes can
    /// be carried over.
    pub coarse_nodes: Vec<usize>,
}

/// Certifies every element; returns the certificates (each bracketed to
/// 1e-3, the mesh's least and largest det J to 1e-7: [`tighten`]) and the
/// summary without the boundary figures.
pub fn certify_mesh<const D: usize>(mesh: &CurvedMesh<D>) -> Result<(Vec<Certificate>, CurvedQuality), HighOrderError> {
    certify_cells(mesh, None, &BTreeMap::new())
}

/// [`certify_mesh`], where the certificates of `known` are taken as they
/// are (but bracketed again if they may hold an extreme) and an element
/// whose every node is where `straight` has it is certified as the
/// order-1 element of its corners: the same map (the
/// straight nodes are the linear cell's images), whose det J has a far
/// lower degree (a trilinear hex: 27 Bernstein coefficients, against 729
/// at p = 3). Its scaled Jacobian is sampled on the order-p grid, as
/// every other element's. Pyramids are certified at order p: their
/// order-1 map is rational.
pub fn certify_mesh_straight<const D: usize>(mesh: &CurvedMesh<D>, straight: &[[f64; D]], known: &BTreeMap<usize, Certificate>) -> Result<(Vec<Certificate>, CurvedQuality), HighOrderError> {
    certify_cells(mesh, Some(straight), known)
}

/// [`certify_mesh`] and [`certify_mesh_straight`] (no element straight
/// without `straight`).
fn certify_cells<const D: usize>(mesh: &CurvedMesh<D>, straight: Option<&[[f64; D]]>, known: &BTreeMap<usize, Certificate>) -> Result<(Vec<Certificate>, CurvedQuality), HighOrderError> {
    let certifiers = Certifiers::new(&mesh.shapes(), mesh.p, mesh.spacing)?;
    let linear = Linear::new(mesh)?;
    let certify = |c: usize, opts: &CertifyOptions| match straight {
        Some(straight) if mesh.cells[c].iter().all(|&n| mesh.nodes[n] == straight[n]) => linear.certify(&certifiers, mesh, c, opts),
        _ => certify_cell(&certifiers, mesh, c, opts),
    };
    let mut certs: Vec<Certificate> = (0..mesh.cells.len())
        .into_par_iter()
        .map(|c| {
            if let Some(cert) = known.get(&c) {
                return Ok(cert.clone());
            }
            let shape = mesh.cell_shape(c);
            let cell = &mesh.cells[c];
            if cell.len() != shape.num_nodes(mesh.p) {
                return Err(HighOrderError::NodeCount { order: mesh.p, dim: D, expected: shape.num_nodes(mesh.p), found: cell.len() });
            }
            Ok(certify(c, &CertifyOptions::element()))
        })
        .collect::<Result<_, HighOrderError>>()?;
    let again = tighten(&mut certs, |c| certify(c, &CertifyOptions::default()));
    tracing::debug!("certified {} elements ({} known, {again} bracketed again, {} splits)", certs.len(), known.len(), certs.iter().map(|c| c.splits).sum::<usize>());
    let q = summary(mesh, &certs);
    Ok((certs, q))
}

/// Cell `c` of `mesh` certified as the order-p element it is.
fn certify_cell<const D: usize>(certifiers: &Certifiers, mesh: &CurvedMesh<D>, c: usize, opts: &CertifyOptions) -> Certificate {
    certifiers.of(mesh.cell_shape(c)).certify(&mesh.cell_coords(c), opts)
}

/// Brackets the least and largest det J of a mesh whose elements' `certs`
/// are bracketed to [`CertifyOptions::element`] to the default tolerance,
/// `certify` re-certifying an element; how many it did.
fn tighten(certs: &mut [Certificate], certify: impl Fn(usize) -> Certificate + Sync) -> usize {
    let again = crate::quality::certify::extreme_candidates(certs);
    let fine: Vec<Certificate> = again.par_iter().map(|&c| certify(c)).collect();
    for (&c, cert) in again.iter().zip(fine) {
        certs[c] = cert;
    }
    again.len()
}

/// Certifies straight order-p elements as the order-1 elements of their
/// corners ([`certify_mesh_straight`]).
pub(super) struct Linear {
    certifiers: Certifiers,
    /// Per kind, the positions in the order-p element of the order-1
    /// element's nodes in its own order (the tensor order of the corners
    /// on quads and hexes, the vertex order on simplices and prisms);
    /// `None` for pyramids.
    corners: BTreeMap<Shape, Option<Vec<usize>>>,
    /// The order-p elements' sampling grid.
    samples: usize,
}

impl Linear {
    pub(super) fn new<const D: usize>(mesh: &CurvedMesh<D>) -> Result<Self, HighOrderError> {
        let shapes = mesh.shapes();
        let corners = |s: Shape| (s != Shape::Pyramid).then(|| crate::mesh::element::corner_indices(s, mesh.p));
        Ok(Linear { certifiers: Certifiers::new(&shapes, 1, mesh.spacing)?, corners: shapes.iter().map(|&s| (s, corners(s))).collect(), samples: 3 * mesh.p + 1 })
    }

    /// Cell `c`'s certificate as an order-1 element (its other nodes are
    /// taken to be straight), sampled on the order-p grid; a pyramid's by
    /// `order_p`, the order-p certifiers.
    pub(super) fn certify<const D: usize>(&self, order_p: &Certifiers, mesh: &CurvedMesh<D>, c: usize, opts: &CertifyOptions) -> Certificate {
        let shape = mesh.cell_shape(c);
        match &self.corners[&shape] {
            Some(at) => {
                let ctrl: Vec<[f64; D]> = at.iter().map(|&a| mesh.nodes[mesh.cells[c][a]]).collect();
                self.certifiers.of(shape).certify(&ctrl, &CertifyOptions { samples: self.samples, ..*opts })
            }
            None => certify_cell(order_p, mesh, c, opts),
        }
    }
}

/// The summary of a mesh's certificates, without the boundary figures.
fn summary<const D: usize>(mesh: &CurvedMesh<D>, certs: &[Certificate]) -> CurvedQuality {
    let invalid = certs.iter().enumerate().filter(|(_, c)| !c.valid).map(|(i, _)| i).collect();
    CurvedQuality {
        order: mesh.p,
        elements: mesh.cells.len(),
        nodes: mesh.nodes.len(),
        min_det_j: certs.iter().map(|c| c.min_det_lower).fold(f64::INFINITY, f64::min),
        min_det_j_attained: certs.iter().map(|c| c.min_det_upper).fold(f64::INFINITY, f64::min),
        max_det_j: certs.iter().map(|c| c.max_det).fold(f64::NEG_INFINITY, f64::max),
        scaled_jacobian: crate::quality::Range::of(certs.iter().map(|c| c.min_scaled_jacobian)),
        invalid_elements: invalid,
        boundary_node_distance: 0.0,
        boundary_sample_distance: 0.0,
        first_layer_change: Default::default(),
        boundary_error: Default::default(),
        settling: Settling::default(),
        boundary_data: BoundaryData::default(),
        band: Band::default(),
        snap_first: SnapFirst::default(),
        repair: Repair::default(),
    }
}

/// Runs Algorithms 2 and 3 on a valid coarse mesh whose boundary facets
/// carry indices into `parts` (the parts of Algorithm 1).
pub fn curve<M, const D: usize, const N: usize>(coarse: &M, parts: &[BoundaryPart<D>], opts: &CurveOptions) -> Result<Curved<D>, CurveError>
where
    M: Subdividable<D, N>,
    RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
{
    curve_with_progress(coarse, parts, opts, |_, _| {})
}

/// [`curve`], calling `progress(t, stats)` after every accepted
/// step of Algorithm 2.
pub fn curve_with_progress<M, const D: usize, const N: usize>(
    coarse: &M,
    parts: &[BoundaryPart<D>],
    opts: &CurveOptions,
    progress: impl FnMut(f64, &RunStats),
) -> Result<Curved<D>, CurveError>
where
    M: Subdividable<D, N>,
    RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
{
    check_order(opts.order)?;
    let bad = coarse.invalid_cells(coarse.nodes());
    if !bad.is_empty() {
        return Err(CurveError::InvalidCoarse(bad));
    }
    let parts = on_shape_parts(coarse.nodes(), &coarse.facets(), coarse.names(), parts, opts)?;
    let clock = Instant::now();
    let sub = subdivide(coarse, opts.order, opts.spacing)?;
    let aspect = largest_aspect(coarse.nodes(), coarse.cells());
    curve_subdivided(&sub, (coarse.names(), aspect, clock), parts, opts, progress)
}

/// [`curve_with_progress`] on a linear mesh of quads and triangles: the
/// elements keep their kinds, Algorithm 2 runs on the triangles of
/// [`subdivide_mixed`]. Cells that tangle are named by the coarse cell.
pub fn curve_mixed(coarse: &CurvedMesh<2>, parts: &[BoundaryPart<2>], opts: &CurveOptions, progress: impl FnMut(f64, &RunStats)) -> Result<Curved<2>, CurveError> {
    check_order(opts.order)?;
    if coarse.p != 1 {
        return Err(CurveError::NotLinear(coarse.p));
    }
    let bad = crate::quality::certify::invalid_mixed_cells(coarse);
    if !bad.is_empty() {
        return Err(CurveError::InvalidCoarse(bad));
    }
    let parts = on_shape_parts(&coarse.nodes, &coarse.linear_facets(), &coarse.part_names, parts, opts)?;
    let clock = Instant::now();
    let (sub, owner) = subdivide_mixed(coarse, opts.order, opts.spacing)?;
    curve_subdivided(&sub, (&coarse.part_names, largest_aspect(&coarse.nodes, &coarse.cells.iter().collect::<Vec<_>>()), clock), parts, opts, progress).map_err(|e| by_owner(e, &owner))
}

/// [`curve_with_progress`] on a solid of tetrahedra and prisms: the
/// elements keep their kinds, Algorithm 2 runs on the tetrahedra of
/// [`subdivide_mixed_solid`]. Cells that tangle are named by the coarse
/// cell.
pub fn curve_mixed_solid(coarse: &CurvedMesh<3>, parts: &[BoundaryPart<3>], opts: &CurveOptions, progress: impl FnMut(f64, &RunStats)) -> Result<Curved<3>, CurveError> {
    check_order(opts.order)?;
    if coarse.p != 1 {
        return Err(CurveError::NotLinear(coarse.p));
    }
    let bad = coarse.invalid_cells();
    if !bad.is_empty() {
        return Err(CurveError::InvalidCoarse(bad));
    }
    let parts = on_shape_parts(&coarse.nodes, &coarse.linear_facets(), &coarse.part_names, parts, opts)?;
    let clock = Instant::now();
    let (sub, owner) = subdivide_mixed_solid(coarse, opts.order, opts.spacing)?;
    let mut curved = curve_subdivided(&sub, (&coarse.part_names, largest_aspect(&coarse.nodes, &coarse.cells.iter().collect::<Vec<_>>()), clock), parts, opts, progress).map_err(|e| by_owner(e, &owner))?;
    // the hexes' sub-cell centres, after every element node, were
    // Algorithm 2's alone
    let element_nodes = sub.elements.iter().flatten().max().map_or(0, |&n| n + 1);
    curved.mesh.nodes.truncate(element_nodes);
    Ok(curved)
}

/// A tangle of Algorithm 2 named by the coarse cells (`owner` of each
/// fine cell) of a mixed mesh.
fn by_owner(e: CurveError, owner: &[usize]) -> CurveError {
    match e {
        CurveError::Deform(DeformError::Tangled { t, dt, cells }) => {
            let mut cells: Vec<usize> = cells.iter().map(|&c| owner[c]).collect();
            cells.sort_unstable();
            cells.dedup();
            CurveError::Deform(DeformError::Tangled { t, dt, cells })
        }
        e => e,
    }
}

/// The parts of Algorithm 2 for `parts`, once every boundary facet (its
/// corners, in cyclic order) lies on its shape.
fn on_shape_parts<const D: usize>(nodes: &[[f64; D]], facets: &[(Vec<usize>, usize)], names: &[String], parts: &[BoundaryPart<D>], opts: &CurveOptions) -> Result<Vec<BoundaryPart<D>>, CurveError> {
    let parts = refine_parts(parts);
    match worst_off_shape(nodes, facets, |k| facets[k].0.clone(), &parts, names, opts.shape_tolerance) {
        Some(o) => Err(CurveError::OffShape(Box::new(o))),
        None => Ok(parts),
    }
}

/// Algorithms 2 and 3 from the subdivided mesh, with the part names, the
/// largest coarse cell aspect and the clock started before subdividing;
/// with [`CurveOptions::snap_first`], the snap first, Algorithm 2 only
/// where it is not kept.
fn curve_subdivided<M, const D: usize, const N: usize>(
    sub: &Subdivision<M, D>,
    (names, aspect, clock): (&[String], f64, Instant),
    parts2: Vec<BoundaryPart<D>>,
    opts: &CurveOptions,
    progress: impl FnMut(f64, &RunStats),
) -> Result<Curved<D>, CurveError>
where
    M: Subdividable<D, N>,
    RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
{
    let p = opts.order;
    let mut certify_s = 0.0;
    let mut progress = progress;
    let mut snap_first = SnapFirst { tried: opts.snap_first && !opts.dirichlet, ..Default::default() };
    let outcome = if snap_first.tried { Some(snap_straight(sub, names, &parts2, opts, &mut certify_s)?) } else { None };
    let mut repair = Repair::default();
    let mut snap_bad = Vec::new();
    let found = match outcome {
        Some(SnapOutcome::Kept(pass, fitted)) => {
            tracing::info!("the snap kept every element valid and shaped: Algorithm 2 not run");
            (snap_first.kept, snap_first.fitted) = (true, fitted);
            (repair.won, repair.why) = ("snap".into(), "every element certified valid and shaped".into());
            Some(*pass)
        }
        Some(SnapOutcome::Refused(snap)) => {
            tracing::info!("the snap was not kept ({}): repair in patches", snap.why);
            snap_first.refused = Some(snap.why.clone());
            let patched = super::repair::in_patches(sub, &parts2, opts, &snap, &mut certify_s, &mut progress)?;
            repair = patched.report;
            (snap_first.kept, snap_first.fitted) = (repair.won == "snap", snap.fitted);
            if let (None, Some(last)) = (&patched.best, patched.stalled) {
                return Err(CurveError::NoCandidate { bad: snap.bad, tried: super::repair::tried(&repair), last, whole: false });
            }
            snap_bad = snap.bad;
            patched.best
        }
        None => None,
    };
    let (pass, attempts, parts2) = match found {
        Some(pass) => (pass, 0, parts2),
        None => {
            // the whole mesh moves: Algorithm 2 proper
            let t0 = Instant::now();
            let run = deformed(sub, (names, aspect), parts2, opts, &mut progress);
            let seconds = t0.elapsed().as_secs_f64();
            let ended = run.as_ref().err().map(|e| with_causes(e));
            let elements = sub.elements.len();
            let judged = run.as_ref().ok().map(|r| &r.0.quality);
            repair.candidates.push(Candidate {
                name: "whole mesh".into(),
                rings: None,
                elements,
                share: 1.0,
                invalid: judged.map_or(0, |q| q.invalid_elements.len()),
                min_scaled_jacobian: judged.filter(|q| q.invalid_elements.is_empty()).map(|q| q.scaled_jacobian.min),
                seconds,
                ended,
            });
            let (pass, attempts, seconds, parts2) = match run {
                Err(CurveError::Deform(last @ (DeformError::Stalled { .. } | DeformError::Solve(_)))) if snap_first.tried => return Err(CurveError::NoCandidate { bad: snap_bad, tried: super::repair::tried(&repair), last, whole: true }),
                run => run?,
            };
            certify_s += seconds;
            repair.won = "whole mesh".into();
            repair.why = if snap_first.tried { "neither the snap nor a patch left every element certified valid".into() } else { "the snap was not tried".into() };
            (pass, attempts, parts2)
        }
    };
    let pass = if opts.optimise { optimise_pass(pass, sub.fine.nodes(), &mut repair, &mut certify_s)? } else { pass };
    let Pass { mesh, certificates, mut quality, stats, solver, moved_distance } = pass;
    quality.snap_first = snap_first;
    quality.repair = repair;
    let alg2 = clock.elapsed().as_secs_f64() - certify_s;
    let clock = Instant::now();
    let fine_facets: Vec<(Vec<usize>, usize)> = mesh.boundary.iter().map(|b| (b.nodes.to_vec(), b.part)).collect();
    // corners of a boundary element, in cyclic order (by its own kind: a
    // prism's boundary holds triangles and quads)
    let corners = |k: usize| {
        let b = mesh.boundary.get(k);
        corner_positions(b.shape, p).iter().map(|&c| b.nodes[c]).collect()
    };
    if let Some(mut o) = worst_off_shape(&mesh.nodes, &fine_facets, corners, &parts2, &mesh.part_names, opts.shape_tolerance) {
        o.after = true;
        return Err(CurveError::OffShape(Box::new(o)));
    }
    // every node of a curved boundary element, the old (fixed) ones too:
    // they were not moved, so only this shows a vertex off its shape
    quality.boundary_error = boundary_errors(&mesh, &parts2, opts.samples)?;
    quality.boundary_node_distance = quality.boundary_error.values().map(|e| e.nodes).fold(moved_distance, f64::max);
    quality.boundary_sample_distance = quality.boundary_error.values().map(|e| e.samples).fold(0.0, f64::max);
    quality.first_layer_change = first_layer_change(&mesh, sub.fine.nodes(), &parts2);
    let seconds = (alg2, certify_s + clock.elapsed().as_secs_f64());
    Ok(Curved { mesh, certificates, quality, stats, attempts, solver, seconds, coarse_nodes: sub.coarse_nodes.clone() })
}

/// `pass` with its simplices' inner nodes moved to raise their least
/// distortion ([`super::optimise`]), every element certified again where
/// it changed; the search's figures in `repair`.
fn optimise_pass<const D: usize>(pass: Pass<D>, straight: &[[f64; D]], repair: &mut Repair, certify_s: &mut f64) -> Result<Pass<D>, CurveError> {
    let t0 = Instant::now();
    let Some(super::optimise::Moved { nodes, changed, report }) = super::optimise::optimised(&pass.mesh, &pass.certificates, straight) else { return Ok(pass) };
    let mesh = CurvedMesh { nodes, ..pass.mesh };
    let known: BTreeMap<usize, Certificate> = (0..pass.certificates.len()).map(|c| (c, changed.get(&c).copied().unwrap_or(pass.certificates[c]))).collect();
    let (certificates, q) = certify_mesh_straight(&mesh, straight, &known)?;
    let quality = CurvedQuality { min_det_j: q.min_det_j, min_det_j_attained: q.min_det_j_attained, max_det_j: q.max_det_j, scaled_jacobian: q.scaled_jacobian, invalid_elements: q.invalid_elements, ..pass.quality };
    *certify_s += t0.elapsed().as_secs_f64();
    tracing::info!("optimised: {} inner nodes of {} elements moved, the least distortion from {:.4} to {:.4} in {:.2} s, {} visits, {} evaluations ({})", report.nodes_moved, report.elements_changed, report.least_distortion_before, report.least_distortion, report.seconds, report.visits, report.evaluations, report.ended);
    repair.optimised = Some(report);
    Ok(Pass { mesh, certificates, quality, ..pass })
}

/// Algorithm 2 with its fallbacks and the settling pass: the pass kept,
/// the runs of Algorithm 2, the seconds spent certifying, and the parts
/// it ran with.
fn deformed<M, const D: usize, const N: usize>(
    sub: &Subdivision<M, D>,
    (names, aspect): (&[String], f64),
    mut parts2: Vec<BoundaryPart<D>>,
    opts: &CurveOptions,
    mut progress: impl FnMut(f64, &RunStats),
) -> Result<(Pass<D>, usize, f64, Vec<BoundaryPart<D>>), CurveError>
where
    M: Subdividable<D, N>,
    RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
{
    let dirichlet_parts = with_dirichlet_data(&parts2);
    if opts.dirichlet {
        parts2 = dirichlet_parts.clone();
    }
    let band = BandMask::new(sub, &parts2, opts.band);
    let unknowns = D * band.nodes();
    let thin = thin_multigrid::<D>(&opts.flow, aspect, unknowns);
    tracing::debug!("largest cell aspect {aspect:.3e}, {unknowns} unknowns in the band: the multigrid to {THIN_TOLERANCE:e} on thin cells: {thin}");
    let mut opts = opts.clone();
    if thin && N == 1 << D {
        opts.flow.tolerance = opts.flow.tolerance.min(THIN_TOLERANCE);
    } else if thin {
        // the tetrahedra of a prism layer: the line smoother relaxes less
        // across a layer of tetrahedra than of hexes (measured on the
        // extruded 1e-4 prism layer, 10,152 prisms at p = 3: 2.3e-5 after
        // 200 iterations towards 1e-10, then no factor fits in memory);
        // there CG keeps the usual tolerance with `amg`'s cap of 1,000
        // (valid in 321 + 155 iterations, 17 s)
        opts.flow.max_iterations = Some(opts.flow.max_iterations.unwrap_or(THIN_SIMPLEX_ITERATIONS));
    }
    let opts = &opts;
    // `auto` picks multigrid-preconditioned CG for 3D Algorithm 2 above
    // a few thousand nodes, as for Algorithm 1
    let steps: Vec<DeformOptions> = match opts.steps {
        Some(n) => vec![DeformOptions { steps: n.max(1), max_strain: None, max_steps: Some(MAX_STEPS.max(2 * n)), ..opts.flow.clone() }],
        None => AUTO_STEPS.iter().map(|&n| DeformOptions { steps: n, max_strain: Some(opts.step_change), max_steps: Some(MAX_STEPS), ..opts.flow.clone() }).collect(),
    };
    // per step size, sliding first, then the paper's Dirichlet data: a
    // sliding node glides along the curving wall by a straight Euler step
    // and is put back onto it, the cells above it are not, so a first
    // layer thinner than that first-order error is pulled apart (measured
    // on the extruded 1e-5 layer at p = 3: its inner nodes end 1.1e-4,
    // 2.8e-5, 6.9e-6 off the Dirichlet result after 2, 8, 32 steps),
    // while a Dirichlet node's straight path is exact under Euler
    let schedule: Vec<(DeformOptions, bool)> = steps.iter().flat_map(|f| [(f.clone(), false), (f.clone(), true)]).filter(|&(_, d)| d || !opts.dirichlet).collect();
    let mut certify_s = 0.0;
    let mut sliding_left = None;
    let watch = Watch::new(sub, &parts2, opts.spacing)?;
    let mut runner = Runner { sub, names, spacing: opts.spacing, factor: false, band, certify_s: 0.0, drift: 0.0, drift_limit: if opts.settle { DRIFT_LIMIT } else { f64::INFINITY } };
    let mut attempts = 0;
    let slid = loop {
        let (flow, dirichlet) = schedule[attempts].clone();
        attempts += 1;
        // a sliding run with a Dirichlet run after it stops once its first
        // rows drift faster than DRIFT_LIMIT (from the first step on the
        // layers measured), or at the first element of a curved facet
        // certified inverted: the drift that inverts it only grows (that
        // showed at t = 0.87–0.96, too late to save much)
        let watched = (!dirichlet && attempts < schedule.len()).then_some(&watch);
        let parts = if dirichlet { &dirichlet_parts } else { &parts2 };
        let mut pass = match runner.run(parts, &flow, watched, &mut progress)? {
            Ok(pass) => pass,
            Err(left) => {
                tracing::info!("sliding stopped at t = {:.3} ({} elements inverted, first rows' drift {:.2} per unit t): again with Dirichlet data", left.t, left.elements, left.first_row_drift);
                sliding_left = Some(left);
                continue;
            }
        };
        // an element the band held a node of may be invalid for want of
        // room: the same run again in a band twice as wide
        if runner.band.widen_for(&pass.quality.invalid_elements, &sub.elements, &parts2) {
            tracing::info!("{} elements not certified valid with a node held by the band: again in a band of {:?} bend lengths", pass.quality.invalid_elements.len(), runner.band.width);
            attempts -= 1;
            continue;
        }
        // the Q1 cells stay valid with few steps, but the error of a long
        // Euler step can still bend an element of a thin layer invalid
        // (measured: a 1e-5 layer at p = 3 in one step): then again with
        // shorter steps
        if pass.quality.invalid_elements.is_empty() || attempts == schedule.len() {
            pass.quality.boundary_data = BoundaryData { dirichlet, sliding_left: if dirichlet && !opts.dirichlet { sliding_left } else { None } };
            break pass;
        }
        if !dirichlet {
            sliding_left = Some(SlidingLeft { elements: pass.quality.invalid_elements.len(), t: 1.0, first_row_drift: runner.drift });
            tracing::info!("sliding left {} elements not certified valid: again with Dirichlet data", pass.quality.invalid_elements.len());
        }
    };
    // once `auto`'s multigrid has turned to the factor on this mesh, the
    // settling starts with the factor
    let mut opts = opts.clone();
    if runner.factor {
        opts.flow.solver = SolverChoice::CholeskyCg;
    }
    let opts = &opts;
    let why_not = if opts.dirichlet {
        Some("Dirichlet data: the nodes are at their places")
    } else if !opts.settle {
        Some("settling is off")
    } else {
        None
    };
    let pass = match why_not {
        Some(why) => {
            let mut pass = slid;
            pass.quality.settling.kept_sliding = Some(why.into());
            pass
        }
        None => settle(&sub, &parts2, opts, slid, &mut runner.certify_s),
    };
    let mut pass = pass;
    pass.quality.band = runner.band.report();
    certify_s += runner.certify_s;
    Ok((pass, attempts, certify_s, parts2))
}

/// Whether `auto` picks the multigrid for this many unknowns on cells
/// thinner than [`THIN_ASPECT`]: then Algorithm 2 solves hexes to
/// [`THIN_TOLERANCE`] (tetrahedra with a higher cap). Why: on such cells CG's residual of 1e-7 leaves an
/// error in the velocity large enough to change the step control's path
/// (measured on the 1e-4 sphere layer at p = 2: 3 steps instead of 4 with
/// one halved, min det J 14 % lower at the patch corners, where Gmsh's
/// looser minSJ bound then went to −0.062 on 24 elements); at 1e-10 it
/// takes the path of an exact solve (min det J within 2e-6 of a Cholesky
/// factor's). Until stop 32 these runs started on a Cholesky factor
/// instead: 37 s and 2.9 GB on that layer at p = 3, against 5.2 s and
/// 341 MB.
/// The cap on CG iterations per solve of `auto`'s multigrid on thin
/// simplicial cells (see [`deformed`]): `amg`'s own.
const THIN_SIMPLEX_ITERATIONS: usize = 1000;

fn thin_multigrid<const D: usize>(flow: &DeformOptions, aspect: f64, unknowns: usize) -> bool {
    flow.solver.resolved(D, unknowns, flow.factor_limit) == SolverChoice::Auto && aspect > THIN_ASPECT
}

/// The largest ratio, over the cells, of the longest to the shortest
/// distance between two of a cell's corners (1.4 – 1.7 for squares and
/// cubes; the layer's length over its height in a boundary layer).
fn largest_aspect<const D: usize, C: AsRef<[usize]> + Sync>(nodes: &[[f64; D]], cells: &[C]) -> f64 {
    cells
        .par_iter()
        .map(|c| {
            let c = c.as_ref();
            let (mut short, mut long) = (f64::INFINITY, 0.0f64);
            for a in 0..c.len() {
                for b in a + 1..c.len() {
                    let d = crate::numeric::dist2(nodes[c[a]], nodes[c[b]]);
                    (short, long) = (short.min(d), long.max(d));
                }
            }
            (long / short).sqrt()
        })
        .reduce(|| 0.0, f64::max)
}

/// The band Algorithm 2 solves in ([`CurveOptions::band`]), widened on
/// demand.
struct BandMask<'a, M, const D: usize> {
    sub: &'a Subdivision<M, D>,
    /// Width in bend lengths; None: the whole mesh.
    width: Option<f64>,
    /// Per fine node, whether it may move (None: all).
    mask: Option<Vec<bool>>,
    /// All fine nodes.
    all: usize,
    widened: usize,
}

impl<'a, M: Clone, const D: usize> BandMask<'a, M, D> {
    fn new<const N: usize>(sub: &'a Subdivision<M, D>, parts: &[BoundaryPart<D>], width: Option<f64>) -> Self
    where
        M: Subdividable<D, N>,
        RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
    {
        let mut band = BandMask { sub, width, mask: None, all: sub.fine.nodes().len(), widened: 0 };
        band.fill(parts);
        band
    }

    /// The mask for the width; none once it holds no node.
    fn fill<const N: usize>(&mut self, parts: &[BoundaryPart<D>])
    where
        M: Subdividable<D, N>,
        RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
    {
        self.mask = self.width.map(|w| self.sub.band(parts, w)).filter(|m| m.iter().any(|&inside| !inside));
        if self.mask.is_none() {
            self.width = None;
        }
    }

    /// Fine nodes free to move.
    fn nodes(&self) -> usize {
        self.mask.as_ref().map_or(self.all, |m| m.iter().filter(|&&inside| inside).count())
    }

    /// The fine mesh for a run of Algorithm 2 in the band.
    fn mesh(&self) -> RefineMesh<M, D> {
        let mesh = self.sub.refine_mesh();
        match &self.mask {
            Some(m) => mesh.with_band(m.clone()),
            None => mesh,
        }
    }

    /// Doubles the band if one of the `invalid` elements has a node it
    /// held; whether it did.
    fn widen_for<const N: usize>(&mut self, invalid: &[usize], elements: &Cells, parts: &[BoundaryPart<D>]) -> bool
    where
        M: Subdividable<D, N>,
        RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
    {
        let Some(mask) = &self.mask else { return false };
        if !invalid.iter().any(|&e| elements[e].iter().any(|&n| !mask[n])) {
            return false;
        }
        self.width = self.width.map(|w| 2.0 * w);
        self.widened += 1;
        self.fill(parts);
        true
    }

    fn report(&self) -> Band {
        Band { width: self.width, nodes: self.nodes(), all_nodes: self.all, widened: self.widened }
    }
}

/// What every run of Algorithm 2 in one `curve` shares.
struct Runner<'a, M, const D: usize> {
    sub: &'a Subdivision<M, D>,
    names: &'a [String],
    spacing: Spacing,
    /// `auto`'s multigrid has turned to the factor on this mesh: the
    /// later runs start with the factor.
    factor: bool,
    /// Where Algorithm 2 solves.
    band: BandMask<'a, M, D>,
    /// Seconds spent certifying.
    certify_s: f64,
    /// The last watched run's [`SlidingLeft::first_row_drift`].
    drift: f64,
    /// A watched run is stopped once its drift passes this.
    drift_limit: f64,
}

impl<M, const D: usize> Runner<'_, M, D> {
    /// One run of Algorithm 2 from the subdivided mesh, certified; with a
    /// watch, stopped (Err) at the first watched element certified inverted.
    fn run<const N: usize>(
        &mut self,
        parts: &[BoundaryPart<D>],
        flow: &DeformOptions,
        watch: Option<&Watch>,
        progress: &mut impl FnMut(f64, &RunStats),
    ) -> Result<Result<Pass<D>, SlidingLeft>, CurveError>
    where
        M: Subdividable<D, N>,
        RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
    {
        let mut flow = flow.clone();
        // the solver for the band's unknowns, not the whole mesh's
        flow.solver = flow.solver.resolved(D, D * self.band.nodes(), flow.factor_limit);
        if self.factor {
            flow.solver = SolverChoice::CholeskyCg;
        }
        let mut def = Deformation::<RefineMesh<M, D>, D, N>::new(self.band.mesh(), parts.to_vec(), JacobianField::uniform(), flow)?;
        let (mut inverted, mut drift) = (0, 0.0);
        def.run_while(|d| {
            progress(d.t, &d.stats);
            let Some(w) = watch else { return true };
            let nodes = d.mesh.mesh.nodes();
            drift = w.drift(nodes) / d.t;
            tracing::debug!("t = {:.4}: first rows' height change {drift:.3e} per unit t", d.t);
            if drift > self.drift_limit && d.t < 1.0 {
                return false;
            }
            inverted = w.inverted(nodes);
            inverted == 0
        })?;
        self.factor |= def.solver_fell_back();
        self.drift = drift;
        if def.t < 1.0 || inverted > 0 {
            return Ok(Err(SlidingLeft { elements: inverted, t: def.t, first_row_drift: drift }));
        }
        let mesh = fine_mesh(self.sub, self.names, self.spacing, def.mesh.mesh.nodes().to_vec());
        let t0 = Instant::now();
        // the elements beyond the band are held straight
        let (certificates, quality) = certify_mesh_straight(&mesh, self.sub.fine.nodes(), &BTreeMap::new())?;
        self.certify_s += t0.elapsed().as_secs_f64();
        let moved_distance = def.boundary_distances().iter().map(|d| d.1).fold(0.0, f64::max);
        // the solver is dropped here, before settling builds its own
        Ok(Ok(Pass { mesh, certificates, quality, stats: def.stats.clone(), solver: def.solver_report(), moved_distance }))
    }
}

/// The parts with every moving part's new nodes on straight paths to
/// their images (the paper's data) instead of sliding.
fn with_dirichlet_data<const D: usize>(parts: &[BoundaryPart<D>]) -> Vec<BoundaryPart<D>> {
    let mut parts = parts.to_vec();
    for part in parts.iter_mut() {
        if let PartKind::Move { mode, .. } = &mut part.kind {
            *mode = crate::deform::MoveMode::Dirichlet;
        }
    }
    parts
}

/// A curved mesh as a pass of Algorithm 2 left it, certified.
pub(super) struct Pass<const D: usize> {
    pub mesh: CurvedMesh<D>,
    pub certificates: Vec<Certificate>,
    pub quality: CurvedQuality,
    pub stats: RunStats,
    pub solver: crate::deform::SolverReport,
    /// The largest distance of a moved boundary node to its shape.
    pub moved_distance: f64,
}

/// The settling pass ([`CurveOptions::settle`]) on a sliding result: its
/// mesh if no element certified valid before is invalid after, else the
/// sliding result with the reason.
fn settle<M, const D: usize, const N: usize>(sub: &Subdivision<M, D>, parts: &[BoundaryPart<D>], opts: &CurveOptions, slid: Pass<D>, certify_s: &mut f64) -> Pass<D>
where
    M: Subdividable<D, N>,
    RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
{
    let t0 = Instant::now();
    match settled(sub, parts, opts, &slid, certify_s) {
        Ok(mut pass) if newly_invalid(&pass, &slid).is_empty() => {
            pass.quality.boundary_data = slid.quality.boundary_data.clone();
            pass
        }
        other => {
            let why = match other {
                Ok(p) => {
                    let bad = newly_invalid(&p, &slid);
                    format!("{} elements would not be certified valid, the first {:?}", bad.len(), &bad[..bad.len().min(5)])
                }
                Err(e) => with_causes(&e),
            };
            tracing::info!("settling skipped after {:.2} s: {why}", t0.elapsed().as_secs_f64());
            let mut pass = slid;
            pass.quality.settling.kept_sliding = Some(why);
            pass
        }
    }
}

/// The settled mesh. Every new node of a curved facet goes to its fitted
/// place along the arc ([`Settle::Fit`]); where that leaves an element
/// not certified valid, that element's nodes go to their places at equal
/// arc length, then to the images of their flat places, then stay where
/// sliding left them ([`Settle::next`]).
fn settled<M, const D: usize, const N: usize>(sub: &Subdivision<M, D>, parts: &[BoundaryPart<D>], opts: &CurveOptions, slid: &Pass<D>, certify_s: &mut f64) -> Result<Pass<D>, CurveError>
where
    M: Subdividable<D, N>,
    RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
{
    let mut plan = SettlePlan::new(slid.mesh.nodes.len());
    let mut demoted = std::collections::BTreeSet::new();
    loop {
        let mut pass = settle_once(sub, parts, opts, slid, &plan, certify_s)?;
        let bad = newly_invalid(&pass, slid);
        let places = &mut plan.places;
        let mut changed = false;
        for &c in &bad {
            demoted.insert(c);
            for &n in &slid.mesh.cells[c] {
                changed |= places[n] != places[n].next();
                places[n] = places[n].next();
            }
        }
        // where a fitted place shears a cell, every node goes back to equal
        // arc length: a line of nodes part fitted, part not, shears the
        // thin cells along it as well (measured on the sphere's layer)
        if fit_costs_shape(&pass, slid, places) {
            for n in places.iter_mut().filter(|n| **n == Settle::Fit) {
                *n = Settle::Arc;
                changed = true;
            }
        }
        if !changed {
            pass.quality.settling.fitted = places.contains(&Settle::Fit);
            pass.quality.settling.demoted_elements = demoted.into_iter().collect();
            pass.quality.settling.kept_elements = (0..slid.mesh.cells.len()).filter(|&c| slid.mesh.cells[c].iter().any(|&n| places[n] == Settle::Keep)).collect();
            return Ok(pass);
        }
    }
}

/// Whether a cell with a fitted node ([`Settle::Fit`]) has a scaled
/// Jacobian in `pass` under [`FIT_KEEP`] of the sliding result's.
fn fit_costs_shape<const D: usize>(pass: &Pass<D>, slid: &Pass<D>, places: &[Settle]) -> bool {
    (0..slid.mesh.cells.len()).any(|c| {
        let (now, was) = (&pass.certificates[c], &slid.certificates[c]);
        slid.mesh.cells[c].iter().any(|&n| places[n] == Settle::Fit) && was.valid && now.min_scaled_jacobian < FIT_KEEP * was.min_scaled_jacobian
    })
}

/// How much of a cell's scaled Jacobian its fitted nodes must keep. Why:
/// in a thin layer the fitted places' shift along the wall can shear the
/// first cells (measured on the 1e-4 layer around a sphere at p = 3:
/// least scaled Jacobian 0.046 fitted, 0.577 at equal arc length, for a
/// wall error of 4.9e-5 against 1.9e-4).
pub const FIT_KEEP: f64 = 0.8;

/// Elements not certified valid in `pass` that were in `slid` (an
/// element sliding left invalid is not the settling's doing).
fn newly_invalid<const D: usize>(pass: &Pass<D>, slid: &Pass<D>) -> Vec<usize> {
    pass.quality.invalid_elements.iter().copied().filter(|e| slid.quality.invalid_elements.binary_search(e).is_err()).collect()
}

/// One try of the settling pass with a given plan: first the new nodes
/// alone are put at their places (enough when the cells are not much
/// thinner than the correction); if that costs an element validity or
/// quality, the correction is run as a flow that carries the cells next
/// to the wall along.
fn settle_once<M, const D: usize, const N: usize>(
    sub: &Subdivision<M, D>,
    parts: &[BoundaryPart<D>],
    opts: &CurveOptions,
    slid: &Pass<D>,
    plan: &SettlePlan,
    certify_s: &mut f64,
) -> Result<Pass<D>, CurveError>
where
    M: Subdividable<D, N>,
    RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
{
    let (nodes, moved_distance) = snapped_nodes(sub, parts, &slid.mesh.nodes, plan.clone())?;
    let largest_move = largest_distance(&nodes, &slid.mesh.nodes);
    let t0 = Instant::now();
    let snapped = CurvedMesh { nodes, ..slid.mesh.clone() };
    let mut certificates = slid.certificates.clone();
    let touched = moved_cells(&snapped, &slid.mesh.nodes);
    let certifiers = Certifiers::new(&snapped.shapes(), snapped.p, snapped.spacing)?;
    let certify = |c: usize, opts: &CertifyOptions| certify_cell(&certifiers, &snapped, c, opts);
    let fresh: Vec<Certificate> = touched.par_iter().map(|&c| certify(c, &CertifyOptions::element())).collect();
    // a snap that shears a thin cell stays valid but ruins it (measured:
    // a 1e-5 layer at p = 4, min scaled Jacobian 0.72 → 0.001): snapping
    // must keep every element's scaled Jacobian within SNAP_KEEP of before
    let mut kept = true;
    for (&c, cert) in touched.iter().zip(fresh) {
        let was = &certificates[c];
        kept &= !was.valid || (cert.valid && cert.min_scaled_jacobian >= SNAP_KEEP * was.min_scaled_jacobian);
        certificates[c] = cert;
    }
    tighten(&mut certificates, |c| certify(c, &CertifyOptions::default()));
    let mut quality = summary(&snapped, &certificates);
    *certify_s += t0.elapsed().as_secs_f64();
    if kept {
        quality.settling = Settling { applied: true, how: Some("snap"), largest_move, steps: 0, ..Default::default() };
        return Ok(Pass { mesh: snapped, certificates, quality, stats: slid.stats.clone(), solver: slid.solver.clone(), moved_distance });
    }
    // the correction is small: as few steps as the step control allows
    let flow = DeformOptions { steps: 1, max_strain: Some(opts.step_change), max_steps: Some(MAX_STEPS), ..opts.flow.clone() };
    let start = sub.refine_mesh().settling(&slid.mesh.nodes, plan.clone());
    let mut def = Deformation::<RefineMesh<M, D>, D, N>::new(start, parts.to_vec(), JacobianField::uniform(), flow)?;
    def.run(&[], |_| {}, |_| {})?;
    let mesh = CurvedMesh { nodes: def.mesh.mesh.nodes().to_vec(), ..snapped };
    let t0 = Instant::now();
    // the flow moves a band around the settled nodes: the elements it
    // left as sliding put them keep their certificates
    let unchanged = (0..mesh.cells.len()).filter(|&c| mesh.cells[c].iter().all(|&n| mesh.nodes[n] == slid.mesh.nodes[n]));
    let known = unchanged.map(|c| (c, slid.certificates[c].clone())).collect();
    let (certificates, mut quality) = certify_mesh_straight(&mesh, sub.fine.nodes(), &known)?;
    *certify_s += t0.elapsed().as_secs_f64();
    let largest_move = largest_distance(&mesh.nodes, &slid.mesh.nodes);
    quality.settling = Settling { applied: true, how: Some("flow"), largest_move, steps: def.stats.steps, ..Default::default() };
    let moved_distance = def.boundary_distances().iter().map(|d| d.1).fold(0.0, f64::max);
    Ok(Pass { mesh, certificates, quality, stats: slid.stats.clone(), solver: slid.solver.clone(), moved_distance })
}

/// The subdivided mesh as a curved mesh with `nodes`.
pub(super) fn fine_mesh<M, const D: usize>(sub: &Subdivision<M, D>, names: &[String], spacing: Spacing, nodes: Vec<[f64; D]>) -> CurvedMesh<D> {
    CurvedMesh {
        shape: sub.shape,
        p: sub.p,
        spacing,
        nodes,
        cells: sub.elements.clone(),
        boundary: CurvedMesh::<D>::facets_at(sub.p, sub.facets.iter().map(|(nodes, part)| (nodes, *part))),
        part_names: names.to_vec(),
    }
}

/// `nodes` with every new node of a curved facet put on its shape at its
/// place of `plan`, and the largest distance of a moved boundary node to
/// its shape.
fn snapped_nodes<M, const D: usize, const N: usize>(sub: &Subdivision<M, D>, parts: &[BoundaryPart<D>], nodes: &[[f64; D]], plan: SettlePlan) -> Result<(Vec<[f64; D]>, f64), CurveError>
where
    M: Subdividable<D, N>,
    RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
{
    use crate::deform::{BoundaryModel, Q1Mesh};
    let mut boundary = sub.refine_mesh().settling(nodes, plan).boundary(parts.to_vec())?;
    let mut out = nodes.to_vec();
    boundary.put_back(&mut out, 1.0);
    let moved_distance = boundary.distances(&out).iter().map(|d| d.1).fold(0.0, f64::max);
    Ok((out, moved_distance))
}

/// The cells of `mesh` with a node not at its place in `before`, in order.
fn moved_cells<const D: usize>(mesh: &CurvedMesh<D>, before: &[[f64; D]]) -> Vec<usize> {
    (0..mesh.cells.len()).filter(|&c| mesh.cells[c].iter().any(|&n| mesh.nodes[n] != before[n])).collect()
}

/// What the snap before Algorithm 2 gave ([`snap_straight`]).
pub(super) enum SnapOutcome<const D: usize> {
    /// Every element certified valid and shaped: the result, and whether
    /// its places were the fitted ones.
    Kept(Box<Pass<D>>, bool),
    /// Not kept: what it left, for the repair in patches.
    Refused(Snap<D>),
}

/// A snap that was not kept: the try that left the fewest elements
/// invalid (the fitted places on a tie).
pub(super) struct Snap<const D: usize> {
    /// The snapped mesh.
    pub mesh: CurvedMesh<D>,
    /// Its new nodes are at their fitted places (on the second try, all
    /// but those of the elements the first try sheared, which are at
    /// equal arc length: [`snap_straight`]).
    pub fitted: bool,
    /// The largest distance of a moved boundary node to its shape.
    pub moved_distance: f64,
    /// The largest move of a node.
    pub largest_move: f64,
    /// The elements to repair: those not certified valid, or (if none)
    /// those under [`SNAP_KEEP`] of their straight scaled Jacobian and
    /// of the straight mesh's least; ascending.
    pub bad: Vec<usize>,
    /// Whether every element is certified valid (only sheared ones bad).
    pub valid: bool,
    /// The least snapped scaled Jacobian of the elements to repair (−∞
    /// where one is not certified valid).
    pub worst: f64,
    /// Why it was not kept.
    pub why: String,
}

/// Gmsh's `setOrder` way, tried before Algorithm 2
/// ([`CurveOptions::snap_first`]): every new node of a curved facet put on
/// its shape at its fitted place (or, where that is not kept, at equal arc
/// length), every other node left at its straight place. Kept, with
/// whether the places were the fitted ones, if every element is certified
/// valid and each element the snap moved keeps [`SNAP_KEEP`] of its
/// straight scaled Jacobian or of the straight mesh's least; else what it
/// left. The elements the snap moves are
/// checked first (validity by its sign, the scaled Jacobians sampled,
/// straight and snapped); every element is certified once it is kept.
pub(super) fn snap_straight<M, const D: usize, const N: usize>(
    sub: &Subdivision<M, D>,
    names: &[String],
    parts: &[BoundaryPart<D>],
    opts: &CurveOptions,
    certify_s: &mut f64,
) -> Result<SnapOutcome<D>, CurveError>
where
    M: Subdividable<D, N>,
    RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
{
    let straight = fine_mesh(sub, names, opts.spacing, sub.fine.nodes().to_vec());
    let certifiers = Certifiers::new(&straight.shapes(), straight.p, straight.spacing)?;
    let linear = Linear::new(&straight)?;
    let mut refused: Option<Snap<D>> = None;
    // one plan's clones: the try at equal arc length takes the lines' arc
    // places found by the fitted one
    let shared = SettlePlan::new(straight.nodes.len());
    for first in [true, false] {
        // a few elements the fitted places left valid but sheared keep the
        // fit's accuracy elsewhere: only their nodes go to equal arc length
        // (on the OCC torus of 2,271 tetrahedra at p = 2, a sliver at
        // 0.170 straight, 0.001 at its fitted places, where Gmsh's places
        // leave 0.0098), and what is still sheared is the repair's to
        // mend; every node goes to equal arc length where the fit sheared
        // more (a thin layer's first cells: [`FIT_KEEP`]) or inverted one
        // (on the OCC torus of 5,082 tetrahedra at p = 2 the fitted places
        // invert two that Gmsh's setOrder keeps valid) (on CAD each try
        // costs projections)
        let mut plan = shared.clone();
        let mut fitted = first;
        let mut places = "fitted";
        if !first {
            match refused.as_ref() {
                Some(r) if r.valid && r.bad.len() as f64 <= ARC_RETRY * straight.cells.len() as f64 => {
                    for &c in &r.bad {
                        for &n in &straight.cells[c] {
                            plan.places[n] = Settle::Arc;
                        }
                    }
                    (fitted, places) = (true, "fitted places but equal arc length at the sheared elements'");
                }
                _ => {
                    plan.places.fill(Settle::Arc);
                    places = "equal arc length";
                }
            }
        }
        let (mut nodes, moved_distance) = snapped_nodes(sub, parts, &straight.nodes, plan)?;
        let touched = super::blend::blend_into_elements(&straight, &straight.nodes, &mut nodes)?;
        let largest_move = largest_distance(&nodes, &straight.nodes);
        let snapped = CurvedMesh { nodes, ..straight.clone() };
        let t0 = Instant::now();
        // validity first, by the sign alone: bracketing the minimum of an
        // element the snap inverted costs the most splits (measured: 8 s
        // a try on the extruded 1e-3 layer, 1,096 elements moved)
        // (and the certificate from the same det J; on simplices, prisms
        // and pyramids without the bracket of its minimum, which costs
        // more there than a second det J once the snap is kept: measured
        // on the tet ball at p = 3, 0.6 s a refused try)
        let quick = CertifyOptions { max_splits: 0, ..Default::default() };
        let bracket = straight.shapes().iter().all(|s| matches!(s, Shape::Quadrilateral | Shape::Hexahedron));
        let first = if bracket { CertifyOptions::element() } else { quick };
        let mut fresh: Vec<Option<Certificate>> = touched.par_iter().map(|&c| certifiers.of(snapped.cell_shape(c)).certify_if_valid(&snapped.cell_coords(c), &first)).collect();
        // without splits a valid element can come out undecided: the few
        // that did are certified again with them before they count as
        // invalid (on the OCC torus of 5,082 tetrahedra at p = 2, two such
        // sent a snap Gmsh finds valid, minSJ 0.833, to the repair)
        if !bracket {
            let again: Vec<usize> = (0..touched.len()).filter(|&k| fresh[k].is_none()).collect();
            let redone: Vec<Option<Certificate>> = again.par_iter().map(|&k| certifiers.of(snapped.cell_shape(touched[k])).certify_if_valid(&snapped.cell_coords(touched[k]), &CertifyOptions::element())).collect();
            for (k, cert) in again.into_iter().zip(redone) {
                fresh[k] = cert;
            }
        }
        let invalid: Vec<usize> = touched.iter().zip(&fresh).filter(|(_, f)| f.is_none()).map(|(&c, _)| c).collect();
        // the straight elements' certificates are those of their order-1
        // elements, bracketed: without splits a valid trilinear hex can
        // come out not valid, and would escape the rule below
        let sampled = |c: usize| linear.certify(&certifiers, &straight, c, &CertifyOptions::element());
        if let Some(&c) = invalid.first() {
            // the valid elements the snap shears (the rule below) are
            // repaired with the invalid ones, and counted with them when
            // tries are compared: else they stay as the snap left them
            // (the three-element airfoil at p = 2: the fitted places'
            // patch left an element at 0.077 sampled, where equal arc
            // length, with none sheared, gives 0.43 as Gmsh's FastCurving)
            let sheared = sheared_valid(&touched, &fresh, sampled, straight.cells.len());
            if better(&refused, invalid.len() + sheared.len(), false, f64::NEG_INFINITY) {
                let why = format!(
                    "at {places} places, {} of the {} elements it moves are not certified valid, the first element {c}{}",
                    invalid.len(),
                    touched.len(),
                    if sheared.is_empty() { String::new() } else { format!(", and {} valid ones fell under {SNAP_KEEP} of their straight scaled Jacobian and of the straight mesh's least", sheared.len()) }
                );
                let mut bad = invalid;
                bad.extend(sheared);
                bad.sort_unstable();
                refused = Some(Snap { mesh: snapped, fitted, moved_distance, largest_move, bad, valid: false, worst: f64::NEG_INFINITY, why });
            }
            *certify_s += t0.elapsed().as_secs_f64();
            continue;
        }
        let pairs: Vec<(Certificate, Certificate)> = touched.par_iter().zip(fresh).map(|(&c, now)| (sampled(c), now.expect("checked valid"))).collect();
        let sheared = |floor: f64| -> Vec<(usize, f64, f64)> {
            touched
                .iter()
                .zip(&pairs)
                .filter(|(_, (was, now))| !now.valid || (was.valid && now.min_scaled_jacobian < floor.min(SNAP_KEEP * was.min_scaled_jacobian)))
                .map(|(&c, (was, now))| (c, was.min_scaled_jacobian, if now.valid { now.min_scaled_jacobian } else { f64::NEG_INFINITY }))
                .collect()
        };
        let mut lost = sheared(f64::INFINITY);
        // an element the snap shears may still keep 0.9 of the worst the
        // straight mesh already has: then the snap leaves the mesh's least
        // scaled Jacobian within the same 0.9 of where it was, and is kept
        // (the tet ball at p = 3: its worst moved element 0.617 straight,
        // 0.48 snapped, the straight mesh's least 0.30, Algorithm 2's
        // result's 0.29; at size 0.16, 0.367 to 0.289 snapped, 0.2893
        // after Algorithm 2). The unmoved elements' straight certificates
        // are only needed then, and serve the certification of the kept
        // snap.
        let mut straight_known = BTreeMap::new();
        if !lost.is_empty() && lost.iter().all(|l| l.2.is_finite()) {
            let moved: std::collections::BTreeSet<usize> = touched.iter().copied().collect();
            let rest: Vec<usize> = (0..straight.cells.len()).filter(|c| !moved.contains(c)).collect();
            straight_known = rest.par_iter().map(|&c| (c, sampled(c))).collect();
            let least = straight_known.values().chain(pairs.iter().map(|(was, _)| was)).filter(|c| c.valid).map(|c| c.min_scaled_jacobian).fold(f64::INFINITY, f64::min);
            lost = sheared(SNAP_KEEP * least);
        }
        if let Some(&(c, was, now)) = lost.iter().min_by(|a, b| (a.2 / a.1).total_cmp(&(b.2 / b.1))) {
            *certify_s += t0.elapsed().as_secs_f64();
            let valid = lost.iter().all(|l| l.2.is_finite());
            let worst = lost.iter().map(|l| l.2).fold(f64::INFINITY, f64::min);
            if better(&refused, lost.len(), valid, worst) {
                let now = if now.is_finite() { format!("{now:.3}") } else { "not certified valid".into() };
                let why = format!(
                    "at {places} places, {} of the {} elements it moves fell under {} of their straight scaled Jacobian and of the straight mesh's least, or were not certified valid; the worst, element {c}: {was:.3} straight, {now} snapped",
                    lost.len(),
                    touched.len(),
                    SNAP_KEEP
                );
                let mut bad: Vec<usize> = lost.iter().map(|l| l.0).collect();
                bad.sort_unstable();
                refused = Some(Snap { mesh: snapped, fitted, moved_distance, largest_move, bad, valid, worst, why });
            }
            continue;
        }
        let mut known = straight_known;
        if bracket {
            known.extend(touched.iter().zip(pairs).map(|(&c, (_, now))| (c, now)));
        }
        let (certificates, mut quality) = certify_mesh_straight(&snapped, &straight.nodes, &known)?;
        *certify_s += t0.elapsed().as_secs_f64();
        if !quality.invalid_elements.is_empty() {
            let why = format!("{} elements it did not move are not certified valid, the first {}", quality.invalid_elements.len(), quality.invalid_elements[0]);
            let bad = quality.invalid_elements.clone();
            return Ok(SnapOutcome::Refused(Snap { mesh: snapped, fitted, moved_distance, largest_move, bad, valid: false, worst: f64::NEG_INFINITY, why }));
        }
        quality.settling = Settling { largest_move, fitted, ..Default::default() };
        let pass = Pass { mesh: snapped, certificates, quality, stats: RunStats::default(), solver: Default::default(), moved_distance };
        return Ok(SnapOutcome::Kept(Box::new(pass), fitted));
    }
    Ok(SnapOutcome::Refused(refused.expect("a try that was not kept left its snap")))
}

/// The share of the elements above which a snap at the fitted places that
/// was not kept, though valid, is tried again at equal arc length
/// ([`snap_straight`]).
pub const ARC_RETRY: f64 = 0.01;

/// The elements of `touched` certified valid (`fresh`) that fell under
/// [`SNAP_KEEP`] of their straight scaled Jacobian (`straight(c)`'s
/// certificate) and of the straight mesh's least (of its `cells`
/// elements).
fn sheared_valid(touched: &[usize], fresh: &[Option<Certificate>], straight: impl Fn(usize) -> Certificate + Sync, cells: usize) -> Vec<usize> {
    let now: Vec<(usize, Certificate)> = touched.iter().zip(fresh).filter_map(|(&c, f)| Some((c, (*f)?))).collect();
    let was: Vec<Certificate> = now.par_iter().map(|&(c, _)| straight(c)).collect();
    let least = (0..cells).into_par_iter().map(&straight).filter(|c| c.valid).map(|c| c.min_scaled_jacobian).reduce(|| f64::INFINITY, f64::min);
    now.iter().zip(&was).filter(|((_, now), was)| was.valid && now.min_scaled_jacobian < (SNAP_KEEP * least).min(SNAP_KEEP * was.min_scaled_jacobian)).map(|((c, _), _)| *c).collect()
}

/// Whether a refused try that leaves `bad` elements to repair (all valid
/// or not), the worst of them at scaled Jacobian `worst`, is better than
/// the one kept so far: valid first, then fewer, then a higher worst.
fn better<const D: usize>(refused: &Option<Snap<D>>, bad: usize, valid: bool, worst: f64) -> bool {
    refused.as_ref().is_none_or(|r| if r.valid != valid { valid } else if bad != r.bad.len() { bad < r.bad.len() } else { worst > r.worst })
}

/// How much of an element's scaled Jacobian a snap of the settling pass
/// must keep; below it the correction is run as a flow. Also what the
/// snap before Algorithm 2 must keep of the straight element's
/// ([`CurveOptions::snap_first`]).
pub const SNAP_KEEP: f64 = 0.9;

/// The largest distance between corresponding points of `a` and `b`.
fn largest_distance<const D: usize>(a: &[[f64; D]], b: &[[f64; D]]) -> f64 {
    a.iter().zip(b).map(|(x, y)| crate::numeric::dist2(*x, *y).sqrt()).fold(0.0, f64::max)
}

/// Per moving (or curved slip) part, the largest relative change of the
/// first-layer height between the straight positions `straight` and the
/// mesh: see [`CurvedQuality::first_layer_change`].
pub fn first_layer_change<const D: usize>(mesh: &CurvedMesh<D>, straight: &[[f64; D]], parts: &[BoundaryPart<D>]) -> BTreeMap<String, FirstLayer> {
    use std::collections::HashMap;
    let p = mesh.p;
    let corners_key = |mut k: Vec<usize>| {
        k.sort_unstable();
        k
    };
    // the element's faces, each node with the node across the element
    // per kind of cell, its faces
    let across: HashMap<Shape, Vec<Vec<(usize, usize, bool)>>> = mesh.shapes().into_iter().map(|s| (s, element_faces::<D>(s, p, p))).collect();
    let facet_corners = |b: Facet| corner_positions(b.shape, p);
    // every element face by its sorted corner nodes: (element, face)
    let mut faces: HashMap<Vec<usize>, (usize, usize)> = HashMap::new();
    for (e, el) in mesh.cells.iter().enumerate() {
        for (f, face) in across[&mesh.cell_shape(e)].iter().enumerate() {
            let corners: Vec<usize> = face.iter().filter(|c| c.2).map(|c| el[c.0]).collect();
            faces.insert(corners_key(corners), (e, f));
        }
    }
    let dist = |x: &[[f64; D]], a: usize, b: usize| (0..D).map(|k| (x[a][k] - x[b][k]).powi(2)).sum::<f64>().sqrt();
    let mut out = BTreeMap::new();
    for b in &mesh.boundary {
        let Some(PartKind::Move { .. }) = parts.get(b.part).map(|q| &q.kind) else { continue };
        let grid_corners = facet_corners(b).iter().map(|&c| b.nodes[c]).collect();
        let Some(&(e, f)) = faces.get(&corners_key(grid_corners)) else { continue };
        let mut worst = FirstLayer::default();
        // each face node and the node across the cell from it
        let el = &mesh.cells[e];
        for (node, opp, corner) in across[&mesh.cell_shape(e)][f].iter().map(|&(a, b, c)| (el[a], el[b], c)) {
            let (h0, h) = (dist(straight, node, opp), dist(&mesh.nodes, node, opp));
            let change = (h / h0 - 1.0).abs();
            worst.all_nodes = worst.all_nodes.max(change);
            if corner {
                worst.vertices = worst.vertices.max(change);
            }
        }
        let name = mesh.part_names.get(b.part).cloned().unwrap_or_else(|| format!("#{}", b.part));
        let w: &mut FirstLayer = out.entry(name).or_default();
        w.vertices = w.vertices.max(worst.vertices);
        w.all_nodes = w.all_nodes.max(worst.all_nodes);
    }
    out
}

/// Local indices of the corners of an order-p boundary element of
/// `shape` (a line, a quad in tensor order, a triangle in lattice order).
fn corner_positions(shape: Shape, p: usize) -> Vec<usize> {
    let n1 = p + 1;
    match shape {
        Shape::Line => vec![0, p],
        Shape::Triangle => crate::mesh::element::simplex::vertex_nodes(shape, p),
        _ => vec![0, p, n1 * n1 - 1, n1 * p],
    }
}

/// Per curved group, the boundary error: the largest distance of its nodes
/// and of its sampled boundary to its shape.
pub fn boundary_errors<const D: usize>(mesh: &CurvedMesh<D>, parts: &[BoundaryPart<D>], samples: usize) -> Result<BTreeMap<String, BoundaryError>, HighOrderError> {
    // each boundary element's points asked of its shape at once (a CAD
    // shape answers them in one batch)
    let nodes = per_part(mesh, parts, |b, target| {
        let at: Vec<[f64; D]> = b.nodes.iter().map(|&n| mesh.nodes[n]).collect();
        at.iter().zip(target.closest_points(&at)).map(|(&p, q)| crate::numeric::norm(crate::numeric::sub(p, q))).fold(0.0, f64::max)
    });
    let sampled = sampled_per_part(mesh, parts, samples)?;
    Ok(parts
        .iter()
        .enumerate()
        .filter(|(_, part)| matches!(part.kind, PartKind::Move { .. }))
        .map(|(k, part)| (part.name.clone(), BoundaryError { nodes: nodes[k], samples: sampled[k] }))
        .collect())
}

/// The boundary error of one curved group ([`boundary_errors`]).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct BoundaryError {
    /// The largest distance of a node to the shape.
    pub nodes: f64,
    /// The largest distance of a sampled boundary point to the shape.
    pub samples: f64,
}

/// Per part, the largest of `f(boundary element, shape)` over the boundary
/// elements of moving (and curved slip) parts; 0 for other parts.
fn per_part<const D: usize>(mesh: &CurvedMesh<D>, parts: &[BoundaryPart<D>], f: impl Fn(Facet, &std::sync::Arc<dyn crate::deform::BoundaryShape<D>>) -> f64 + Sync) -> Vec<f64> {
    let one = |b: usize| {
        let b = mesh.boundary.get(b);
        match &parts.get(b.part)?.kind {
            PartKind::Move { target, .. } => Some((b.part, f(b, target))),
            _ => None,
        }
    };
    let most = |mut w: Vec<f64>, (k, d): (usize, f64)| {
        w[k] = f64::max(w[k], d);
        w
    };
    // a CAD shape answers from one thread ([`crate::geometry::ClosestPoint::serial`])
    if parts.iter().any(BoundaryPart::serial) {
        return (0..mesh.boundary.len()).filter_map(one).fold(vec![0.0; parts.len()], most);
    }
    (0..mesh.boundary.len())
        .into_par_iter()
        .filter_map(one)
        .fold(|| vec![0.0; parts.len()], most)
        .reduce(|| vec![0.0; parts.len()], |a, b| a.iter().zip(&b).map(|(x, y)| x.max(*y)).collect())
}

/// Per part, the largest distance of the boundary sampled on a grid of
/// `samples` points per direction of each boundary element to the shape.
fn sampled_per_part<const D: usize>(mesh: &CurvedMesh<D>, parts: &[BoundaryPart<D>], samples: usize) -> Result<Vec<f64>, HighOrderError> {
    let m = samples.max(2);
    // per kind of boundary element (a prism's boundary holds two)
    let kinds: Vec<Shape> = mesh.shapes().iter().flat_map(|s| s.facets().iter().map(|f| f.0)).collect();
    let weights: Vec<(Shape, Vec<Vec<f64>>)> = kinds.into_iter().map(|k| Ok((k, facet_sample_weights(k, mesh.p, mesh.spacing, m)?))).collect::<Result<_, HighOrderError>>()?;
    Ok(per_part(mesh, parts, |b, target| {
        let of_kind = &weights.iter().find(|w| w.0 == b.shape).expect("validated facets").1;
        let nodes: Vec<[f64; D]> = b.nodes.iter().map(|&n| mesh.nodes[n]).collect();
        target.largest_sample_distance(&nodes, of_kind)
    }))
}

/// The weights of a boundary element's nodes (its order, `shape`: a line,
/// a quad in tensor order or a triangle in lattice order) at its samples:
/// `m + 1` points per direction, ends included (on a triangle the lattice
/// of `m + 1` points per edge).
fn facet_sample_weights(shape: Shape, p: usize, spacing: Spacing, m: usize) -> Result<Vec<Vec<f64>>, HighOrderError> {
    if shape == Shape::Triangle {
        let space = crate::mesh::element::simplex::space(shape, p, spacing)?;
        let n = space.nodes.len();
        let (mut values, mut grads) = (vec![0.0; n], vec![[0.0; 3]; n]);
        let points = (0..=m).flat_map(|j| (0..=m - j).map(move |i| [i as f64 / m as f64, j as f64 / m as f64, 0.0]));
        return Ok(points
            .map(|xi| {
                space.eval(xi, &mut values, &mut grads);
                values.clone()
            })
            .collect());
    }
    let basis = Basis1d::new(p, spacing)?;
    let at: Vec<Vec<f64>> = (0..=m).map(|k| basis.eval(k as f64 / m as f64).0).collect();
    let n1 = p + 1;
    if shape == Shape::Line {
        return Ok(at);
    }
    Ok((0..=m).flat_map(|kv| (0..=m).map(move |ku| (ku, kv))).map(|(ku, kv)| (0..n1 * n1).map(|idx| at[ku][idx % n1] * at[kv][idx / n1]).collect()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deform::{Correspondence, MoveMode};
    use crate::mesh::QuadMesh;
    use proptest::test_runner::{Config, TestRng, TestRunner};
    use std::sync::Arc;

    /// A sector of the annulus 1 ≤ r ≤ 1.5 (counter-clockwise cells) with
    /// a smooth random bend vanishing on r = 1, moved by `x ↦ s R x + t`;
    /// its bottom side lies on the circle (centre t, radius s).
    fn sector(theta: f64, bend: f64, angle: f64, s: f64, t: [f64; 2]) -> QuadMesh {
        let mut m = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 4, 2);
        let (c, sn) = (angle.cos(), angle.sin());
        for x in &mut m.nodes {
            let [u, v] = *x;
            let r = 1.0 + 0.5 * v + bend * v * (std::f64::consts::PI * u).sin();
            let a = theta * (1.0 - u) + bend * v * u;
            let (px, py) = (r * a.cos(), r * a.sin());
            *x = [s * (c * px - sn * py) + t[0], s * (sn * px + c * py) + t[1]];
        }
        m
    }

    /// Random valid meshes (smooth maps of a box, random rotations, scales
    /// and translations) curved at p = 1..3: the certificate agrees with a
    /// dense sampling of det J (the lower bound is below every sample, the
    /// attained value is not far above the smallest, and valid elements
    /// have no sample ≤ 0).
    /// Over quads and triangles alike: a ½ × 1 quad has corners ½ apart
    /// and 1.118 on its diagonal; the triangle (½,0), (1,0), (½,1) has the
    /// same shortest and longest sides; a unit square's ratio is √2.
    /// Curving starts from a linear mesh: a mesh of several kinds of
    /// order 2 or 3 is refused with its order (its cells' first nodes are
    /// no vertices to cut or check).
    #[test]
    fn meshes_of_several_kinds_are_curved_from_order_one_only() {
        let opts = CurveOptions::default();
        let plane = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [1, 1], |x| x).unwrap();
        assert!(matches!(curve_mixed(&plane, &[], &opts, |_, _| {}), Err(CurveError::NotLinear(2))));
        let solid = CurvedMesh::<3>::structured(3, Spacing::Equispaced, [1, 1, 1], |x| x).unwrap();
        assert!(matches!(curve_mixed_solid(&solid, &[], &opts, |_, _| {}), Err(CurveError::NotLinear(3))));
    }

    #[test]
    fn largest_aspect_takes_cells_of_any_kind() {
        let nodes = [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 1.0]];
        let cells = [vec![0, 1, 4, 3], vec![1, 2, 4]];
        assert!((largest_aspect(&nodes, &cells) - 1.25f64.sqrt() / 0.5).abs() < 1e-15);
        assert!((largest_aspect(&nodes, &[[1, 2, 4]]) - 1.25f64.sqrt() / 0.5).abs() < 1e-15);
        assert!((largest_aspect(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], &[[0, 1, 2, 3]]) - 2f64.sqrt()).abs() < 1e-15);
    }

    /// A straight element certified as its order-1 element has the
    /// order-p certificate: the same verdict, det J's bounds within the
    /// elements' bracket tolerance (1e-3), the mesh's least and largest
    /// det J within the mesh's (1e-7), the same sampled scaled Jacobian. On
    /// distorted boxes of every kind but pyramids, p = 2, 3, both
    /// spacings.
    #[test]
    fn straight_elements_certified_at_order_one_agree_with_order_p() {
        use crate::refine::{subdivide_mixed, subdivide_mixed_solid};
        let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * a.abs().max(b.abs());
        let agree = |(a, qa): &(Vec<Certificate>, CurvedQuality), (b, qb): &(Vec<Certificate>, CurvedQuality), what: &str| {
            assert_eq!(a.len(), b.len());
            for (u, v) in [(qa.min_det_j, qb.min_det_j), (qa.min_det_j_attained, qb.min_det_j_attained), (qa.max_det_j, qb.max_det_j)] {
                assert!(close(u, v, 3e-7), "{what}: {u} against {v}");
            }
            for (c, (x, y)) in a.iter().zip(b).enumerate() {
                assert_eq!(x.valid, y.valid, "{what} element {c}");
                for (u, v) in [(x.min_det_lower, y.min_det_lower), (x.min_det_upper, y.min_det_upper), (x.max_det, y.max_det), (x.max_det_attained, y.max_det_attained)] {
                    assert!(close(u, v, 2.1e-3), "{what} element {c}: {u} against {v}");
                }
                assert!(close(x.min_scaled_jacobian, y.min_scaled_jacobian, 1e-12), "{what} element {c}: {x:?} against {y:?}");
            }
        };
        let bend3 = |[x, y, z]: [f64; 3]| [x + 0.3 * y * z, y + 0.25 * x * z - 0.05 * z, z + 0.3 * x * y];
        let mut solids: Vec<(String, CurvedMesh<3>)> = [Shape::Hexahedron, Shape::Tetrahedron, Shape::Prism]
            .into_iter()
            .map(|k| (format!("{k:?}"), CurvedMesh::brick([0.0; 3], [1.0; 3], [2, 2, 2], k).unwrap()))
            .collect();
        solids.push(("hexes and prisms".into(), CurvedMesh::hex_prism_box([0.0; 3], [1.0; 3], [2, 2, 2])));
        let mut plane = CurvedMesh::checkerboard([0.0; 2], [1.0; 2], 3, 3);
        for x in &mut plane.nodes {
            *x = [x[0] + 0.2 * x[1] * x[1], x[1] + 0.15 * x[0] * x[1]];
        }
        for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
            for p in 2..=3 {
                for (name, coarse) in &mut solids {
                    let mut coarse = coarse.clone();
                    coarse.nodes.iter_mut().for_each(|x| *x = bend3(*x));
                    let (sub, _) = subdivide_mixed_solid(&coarse, p, spacing).unwrap();
                    let mesh = fine_mesh(&sub, &coarse.part_names, spacing, sub.fine.nodes.clone());
                    let a = certify_mesh(&mesh).unwrap();
                    let b = certify_mesh_straight(&mesh, &mesh.nodes, &BTreeMap::new()).unwrap();
                    let spread = a.0.iter().map(|c| c.max_det / c.min_det_upper).fold(0.0, f64::max);
                    // tetrahedra are affine; the others are not
                    assert!(name == "Tetrahedron" || spread > 1.05, "{name}: det J varies by {spread} at most");
                    agree(&a, &b, &format!("{name} p = {p} {spacing:?}"));
                }
                let (sub, _) = subdivide_mixed(&plane, p, spacing).unwrap();
                let mesh = fine_mesh(&sub, &plane.part_names, spacing, sub.fine.nodes.clone());
                let a = certify_mesh(&mesh).unwrap();
                let b = certify_mesh_straight(&mesh, &mesh.nodes, &BTreeMap::new()).unwrap();
                agree(&a, &b, &format!("quads and triangles p = {p} {spacing:?}"));
            }
        }
    }

    /// The elements are bracketed to 1e-3 and the extremes' candidates
    /// again to 1e-7: the mesh's least and largest det J are those of
    /// every element bracketed to 1e-7, on bent hexes and on bent
    /// quads and triangles at p = 3.
    #[test]
    fn the_mesh_extremes_are_bracketed_as_if_every_element_were() {
        use crate::refine::{subdivide_mixed, subdivide_mixed_solid};
        fn check<const D: usize>(mesh: &CurvedMesh<D>, what: &str, loose_differs: bool) {
            let certifiers = Certifiers::new(&mesh.shapes(), mesh.p, mesh.spacing).unwrap();
            let all = |opts: CertifyOptions| -> Vec<Certificate> { (0..mesh.cells.len()).map(|c| certify_cell(&certifiers, mesh, c, &opts)).collect() };
            let (fine, loose) = (all(CertifyOptions::default()), all(CertifyOptions::element()));
            let least = |cs: &[Certificate]| cs.iter().map(|c| c.min_det_lower).fold(f64::INFINITY, f64::min);
            let most = |cs: &[Certificate]| cs.iter().map(|c| c.max_det).fold(f64::NEG_INFINITY, f64::max);
            let (_, q) = certify_mesh(mesh).unwrap();
            let rel = |a: f64, b: f64| (a - b).abs() / a.abs().max(b.abs());
            assert!(rel(q.min_det_j, least(&fine)) < 2e-7 && rel(q.max_det_j, most(&fine)) < 2e-7, "{what}: {q:?} against {} {}", least(&fine), most(&fine));
            // on the hexes the loose brackets alone are not as tight (the
            // quads' and triangles' minima are at corners: exact at once)
            assert_eq!(rel(least(&loose), least(&fine)) > 1e-6, loose_differs, "{what}: {} against {}", least(&loose), least(&fine));
            // (their maxima are inside: the loose brackets differ on both)
            assert!(rel(most(&loose), most(&fine)) > 1e-6, "{what}: max {} against {}", most(&loose), most(&fine));
            let again = crate::quality::certify::extreme_candidates(&loose).len();
            assert!(again > 0 && 4 * again <= mesh.cells.len(), "{what}: {again} of {} bracketed again", mesh.cells.len());
        }
        let bend = |[x, y, z]: [f64; 3]| [x + 0.2 * (y * y - z) * x, y + 0.15 * x * x * z, z + 0.25 * x * y * y];
        let coarse = CurvedMesh::brick([0.0; 3], [1.0; 3], [3, 3, 3], Shape::Hexahedron).unwrap();
        let (sub, _) = subdivide_mixed_solid(&coarse, 3, Spacing::Equispaced).unwrap();
        let nodes = sub.fine.nodes.iter().map(|&x| bend(x)).collect();
        check(&fine_mesh(&sub, &coarse.part_names, Spacing::Equispaced, nodes), "hexes", true);
        let plane = CurvedMesh::checkerboard([0.0; 2], [1.0; 2], 4, 4);
        let (sub, _) = subdivide_mixed(&plane, 3, Spacing::Equispaced).unwrap();
        let nodes = sub.fine.nodes.iter().map(|&[x, y]| [x + 0.05 * (7.0 * y).sin(), y + 0.05 * (6.0 * x).sin()]).collect();
        check(&fine_mesh(&sub, &plane.part_names, Spacing::Equispaced, nodes), "quads and triangles", false);
    }

    #[test]
    fn certificate_agrees_with_dense_sampling() {
        let config = Config { cases: 6, failure_persistence: None, ..Config::default() };
        let mut runner = TestRunner::new_with_rng(config.clone(), TestRng::deterministic_rng(config.rng_algorithm));
        let strategy = (1usize..=3, 0.6f64..1.5, 0.0f64..0.15, 0.0f64..std::f64::consts::TAU, -3.0f64..3.0, -1e3f64..1e3, -1e3f64..1e3);
        runner
            .run(&strategy, |(p, theta, bend, angle, log_s, tx, ty)| {
                let s = 10f64.powf(log_s);
                let m = sector(theta, bend, angle, s, [tx, ty]);
                let circle = crate::geometry::ShapeSpec::Circle { centre: [tx, ty], radius: s }.build().unwrap();
                let parts: Vec<BoundaryPart<2>> = crate::mesh::BOX_SIDES
                    .iter()
                    .map(|&name| {
                        let kind = if name == "bottom" {
                            PartKind::Move { target: Arc::new(circle.clone()), correspondence: Correspondence::Normal, mode: MoveMode::Sliding }
                        } else {
                            PartKind::Fixed
                        };
                        BoundaryPart::new(name, kind)
                    })
                    .collect();
                let opts = CurveOptions { order: p, steps: Some(2), ..Default::default() };
                let c = curve(&m, &parts, &opts).map_err(|e| proptest::test_runner::TestCaseError::fail(e.to_string()))?;
                let n = 41;
                for (e, cert) in c.certificates.iter().enumerate() {
                    // sampled relative to the element's first node: at 1e3 from
                    // the origin, det J from uncentred points carries rounding
                    // of 1e-12 relative, the size of what is checked
                    let coords = c.mesh.cell_coords(e);
                    let o = coords[0];
                    let ctrl: Vec<[f64; 2]> = coords.iter().map(|x| [x[0] - o[0], x[1] - o[1]]).collect();
                    let (mut dense, mut dense_max) = (f64::INFINITY, f64::NEG_INFINITY);
                    for k in 0..n * n {
                        let xi = [(k % n) as f64 / (n - 1) as f64, (k / n) as f64 / (n - 1) as f64];
                        let (_, j) = super::super::quad_map(p, c.mesh.spacing, &ctrl, xi).unwrap();
                        let d = j[0][0] * j[1][1] - j[0][1] * j[1][0];
                        (dense, dense_max) = (dense.min(d), dense_max.max(d));
                    }
                    let range = cert.max_det - cert.min_det_lower;
                    proptest::prop_assert!(cert.min_det_lower <= dense * (1.0 + 1e-12), "p={p} element {e}: {cert:?} dense {dense}");
                    proptest::prop_assert!(cert.min_det_upper <= dense + 1e-2 * range, "p={p} element {e}: {cert:?} dense {dense}");
                    // the max's bracket, from the other side
                    proptest::prop_assert!(dense_max <= cert.max_det * (1.0 + 1e-12) && cert.max_det_attained <= cert.max_det, "p={p} element {e}: {cert:?} dense max {dense_max}");
                    proptest::prop_assert!(cert.max_det_attained >= dense_max - 1e-2 * range, "p={p} element {e}: {cert:?} dense max {dense_max}");
                    proptest::prop_assert!(!cert.valid || dense > 0.0);
                    proptest::prop_assert!(cert.valid, "a valid sector must be certified: p={p} element {e}: {cert:?}");
                }
                Ok(())
            })
            .unwrap();
    }

    /// The faces of a pyramid list each face's nodes once, the inner node
    /// `depth` steps in is in the pyramid and off the face (the apex from
    /// the base at depth p), and the corner flags mark its vertices.
    #[test]
    fn pyramid_faces_step_into_the_pyramid() {
        use crate::mesh::element::pyramid;
        for p in 1..=4 {
            let x = pyramid::pyramid_nodes(p, Spacing::Equispaced).unwrap();
            for depth in [1, p] {
                let faces = element_faces::<3>(Shape::Pyramid, p, depth);
                assert_eq!(faces.len(), 5);
                for (f, face) in faces.iter().enumerate() {
                    let (shape, loop_) = Shape::Pyramid.faces()[f];
                    assert_eq!(face.len(), shape.num_nodes(p));
                    assert_eq!(face.iter().filter(|n| n.2).count(), loop_.len(), "p = {p} face {f}");
                    // the inner node is off the face's plane, on its inner side
                    let v = Shape::Pyramid.vertices();
                    let (a, b, c) = (v[loop_[0]], v[loop_[1]], v[loop_[loop_.len() - 1]]);
                    let normal = crate::numeric::cross3(crate::numeric::sub(b, a), crate::numeric::sub(c, a));
                    for &(on, inner, _) in face {
                        let h = |n: usize| crate::numeric::dot(normal, crate::numeric::sub(x[n], a));
                        assert!(h(on).abs() < 1e-14, "p = {p} face {f}: node {on} off its face");
                        assert!(h(inner) < -1e-14, "p = {p} face {f} depth {depth}: node {inner} not inside");
                    }
                }
                let apex = pyramid::vertex_nodes(p)[4];
                assert_eq!(faces[4].iter().any(|n| n.1 == apex), depth == p, "p = {p} depth {depth}");
            }
        }
    }

    #[test]
    fn a_tangle_in_algorithm_2_is_said_once() {
        let e = CurveError::from(DeformError::Tangled { t: 0.5, dt: 1e-3, cells: vec![3] });
        let chain = format!("{:#}", anyhow::Error::from(e));
        assert_eq!(chain.matches("tangles").count(), 1, "{chain}");
        assert!(chain.starts_with("Algorithm 2 (carrying"), "{chain}");
    }

    #[test]
    fn a_solver_failure_says_why() {
        let e = CurveError::from(DeformError::from(crate::solve::SolveError::NoConvergence { iterations: 1000, residual: 3.5e-4, tolerance: 1e-7 }));
        let chain = format!("{:#}", anyhow::Error::from(e));
        assert!(
            chain.ends_with("the linear solver failed (the solver, not the input): conjugate gradients did not converge in 1000 iterations (relative residual 3.50e-4 reached, 1e-7 wanted)"),
            "{chain}"
        );
        assert_eq!(chain.matches("converge").count(), 1, "{chain}");
    }
}
