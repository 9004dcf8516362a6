//! Which entity of a CAD model each boundary facet of a mesh lies on,
//! found by geometry, not by tag numbers.
//!
//! Why: a mesh made in the session that built its model (OpenCASCADE
//! booleans, then `gmsh.write("m.step")` and `generate`) numbers its
//! entities as that session did, and a later import of the STEP numbers
//! them differently; a mesh from another mesher has no CAD tags at all.
//! The tags are only a first guess.
//!
//! Each entity of the mesh is tried whole first: the model's entity (of
//! the facets' dimension) whose bounding box holds the mesh entity's,
//! every node of it within its tolerance, and the foot of every facet's
//! centroid inside the entity's trimming. That costs two batched Gmsh
//! calls per candidate. A mesh entity that lies on several model
//! entities (a mesher merged faces) is bound facet by facet: the
//! candidates every node of the facet lies on, and among several (a
//! facet whose corners all lie on the curve two faces share) the one
//! whose trimmed face holds the foot of the facet's centroid, nearest.
//!
//! Gmsh's closest point on a face is the untrimmed surface's (a node in a
//! hole of a planar face is at distance 0 from it), hence the test of
//! the feet with `gmshModelIsInside`, which heeds the trimming.

use super::{CadError, CadModel};
use crate::geometry::ClosestPoint;
use std::sync::Arc;

/// The facets of one entity of the mesh, and the model's entity of the
/// same tag, if it has one: the first guess.
#[derive(Clone, Debug)]
pub struct MeshEntity {
    /// Indices of its facets.
    pub facets: Vec<usize>,
    /// The model's entity with its tag.
    pub guess: Option<i32>,
}

/// The model's entity a facet lies on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OnModel {
    /// Its tag.
    pub tag: i32,
    /// The largest distance of the facet's nodes from it.
    pub distance: f64,
}

/// A facet on none of the model's entities: the node of it farthest from
/// any, how far, the model entity nearest to it, and the node's tolerance.
#[derive(Clone, Debug, PartialEq)]
pub struct Off {
    /// The facet.
    pub facet: usize,
    /// Its node farthest from the model.
    pub node: usize,
    /// That node's distance from the nearest entity.
    pub distance: f64,
    /// The nearest entity (none if every query failed).
    pub nearest: Option<i32>,
    /// The node's tolerance.
    pub tolerance: f64,
}

/// Why facets could not be classified.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ClassifyError {
    /// A Gmsh call failed.
    #[error(transparent)]
    Cad(#[from] CadError),
    /// A facet lies on no entity of the model.
    #[error("facet {} lies {:.3e} from the model", .0.facet, .0.distance)]
    Off(Off),
}

/// The boundary of a mesh, lifted to 3D, with per-node tolerances.
#[derive(Clone, Copy)]
pub struct Boundary<'a> {
    /// Node coordinates (z = 0 in 2D).
    pub nodes: &'a [[f64; 3]],
    /// How far each node may lie from its entity.
    pub tolerance: &'a [f64],
    /// The facets, by node index.
    pub facets: &'a [Vec<usize>],
}

/// The model's entities of one dimension and their bounding boxes.
struct Candidates {
    dim: usize,
    tags: Vec<i32>,
    boxes: Vec<[[f64; 3]; 2]>,
}

/// For every facet of `b`, the entity of dimension `dim` of `model` it
/// lies on; `entities` groups the facets by the mesh's entities.
pub fn classify(
    model: &Arc<CadModel>,
    dim: usize,
    b: Boundary,
    entities: &[MeshEntity],
) -> Result<Vec<OnModel>, ClassifyError> {
    let tags = model.entities(dim)?;
    let boxes = tags
        .iter()
        .map(|&t| model.bounding_box(dim as i32, t))
        .collect::<Result<Vec<_>, _>>()?;
    let c = Candidates { dim, tags, boxes };
    let mut out: Vec<Option<OnModel>> = vec![None; b.facets.len()];
    for e in entities {
        match whole(model, &c, b, e)? {
            Some((tag, nodes, d)) => {
                for &f in &e.facets {
                    let distance = b.facets[f]
                        .iter()
                        .map(|n| d[nodes.binary_search(n).expect("a node of the entity")])
                        .fold(0.0, f64::max);
                    out[f] = Some(OnModel { tag, distance });
                }
            }
            None => {
                for (f, on) in by_facet(model, &c, b, e)? {
                    out[f] = Some(on);
                }
            }
        }
    }
    Ok(out
        .into_iter()
        .map(|o| o.expect("every facet is in an entity"))
        .collect())
}

/// Candidate `i`'s box grown by `pad` and by 1e-9 of its size (OCC's
/// boxes are tight to round-off).
fn grown(c: &Candidates, i: usize, pad: f64) -> [[f64; 3]; 2] {
    padded(c.boxes[i], pad + 1e-9 * span(c.boxes[i]))
}

/// The box `bx` grown by `pad` on every side.
fn padded(bx: [[f64; 3]; 2], pad: f64) -> [[f64; 3]; 2] {
    [bx[0].map(|x| x - pad), bx[1].map(|x| x + pad)]
}

/// The bounding box of `points`.
pub fn bounds(points: impl IntoIterator<Item = [f64; 3]>) -> [[f64; 3]; 2] {
    points.into_iter().fold(
        [[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]],
        |[lo, hi], p| {
            [
                std::array::from_fn(|k| lo[k].min(p[k])),
                std::array::from_fn(|k| hi[k].max(p[k])),
            ]
        },
    )
}

fn contains(outer: [[f64; 3]; 2], inner: [[f64; 3]; 2]) -> bool {
    (0..3).all(|k| outer[0][k] <= inner[0][k] && inner[1][k] <= outer[1][k])
}

fn meets(a: [[f64; 3]; 2], b: [[f64; 3]; 2]) -> bool {
    (0..3).all(|k| a[0][k] <= b[1][k] && b[0][k] <= a[1][k])
}

/// The distances of `points` from entity (dim, tag): one batched call, or
/// where Gmsh fails the batch one call a point, a failed point infinitely
/// far (it is on no entity Gmsh can project it onto).
fn distances(
    model: &CadModel,
    dim: usize,
    tag: i32,
    points: &[[f64; 3]],
) -> Result<Vec<f64>, CadError> {
    let dist = |p: &[f64; 3], q: &[f64; 3]| crate::numeric::dist2(*p, *q).sqrt();
    if points.is_empty() {
        return Ok(Vec::new());
    }
    match model.closest_points(dim, tag, points) {
        Ok(f) if f.len() == points.len() => {
            Ok(points.iter().zip(&f).map(|(p, q)| dist(p, q)).collect())
        }
        _ => Ok(points
            .iter()
            .map(|p| {
                model
                    .closest_points(dim, tag, std::slice::from_ref(p))
                    .ok()
                    .and_then(|f| f.first().map(|q| dist(p, q)))
                    .unwrap_or(f64::INFINITY)
            })
            .collect()),
    }
}

/// `d`, the distances of `points` from entity (dim, tag) by Gmsh's
/// closest point (about 1e-9 of the model's size off), made exact where
/// `redo` says (Newton's method on the entity: [`super::CadShape`]).
fn polished(
    model: &Arc<CadModel>,
    (dim, tag): (usize, i32),
    points: &[[f64; 3]],
    d: &mut [f64],
    redo: impl Fn(usize, f64) -> bool,
) {
    let shape = model.shape(dim, tag);
    for (k, (p, d)) in points.iter().zip(d.iter_mut()).enumerate() {
        if d.is_finite() && redo(k, *d) {
            *d = ClosestPoint::<3>::distance(&shape, *p);
        }
    }
}

/// Gmsh's distances a hundred times a node's tolerance or less are
/// checked exactly: its closest point alone may miss a fine mesh's
/// tolerance.
const POLISH: f64 = 100.0;

/// The centroid of facet `f`'s nodes.
fn centroid(b: Boundary, f: usize) -> [f64; 3] {
    let n = &b.facets[f];
    let s = n.iter().fold([0.0; 3], |s, &i| {
        std::array::from_fn(|k| s[k] + b.nodes[i][k])
    });
    s.map(|x| x / n.len() as f64)
}

/// The nodes of `e`, each once, and the largest of their tolerances.
fn nodes_of(b: Boundary, e: &MeshEntity) -> (Vec<usize>, f64) {
    let mut v: Vec<usize> = e
        .facets
        .iter()
        .flat_map(|&f| b.facets[f].iter().copied())
        .collect();
    v.sort_unstable();
    v.dedup();
    let pad = v.iter().map(|&n| b.tolerance[n]).fold(0.0, f64::max);
    (v, pad)
}

/// A model entity's tag, the nodes of a mesh entity it holds (sorted)
/// and their distances from it.
type Held = (i32, Vec<usize>, Vec<f64>);

/// The model's entity that holds all of `e`: every node within its
/// tolerance, every facet's centroid over the trimmed entity. The guess
/// if it does; else the one nearest the centroids. With it, `e`'s nodes
/// (sorted) and their distances from it.
fn whole(
    model: &Arc<CadModel>,
    c: &Candidates,
    b: Boundary,
    e: &MeshEntity,
) -> Result<Option<Held>, CadError> {
    let (nodes, pad) = nodes_of(b, e);
    let bx = bounds(nodes.iter().map(|&n| b.nodes[n]));
    let mut order: Vec<usize> = (0..c.tags.len())
        .filter(|&i| contains(grown(c, i, pad), bx))
        .collect();
    // the guess first: where it holds, nothing else is asked
    order.sort_by_key(|&i| Some(c.tags[i]) != e.guess);
    let mut best: Option<(f64, i32, Vec<f64>)> = None;
    for i in order {
        let tag = c.tags[i];
        let points: Vec<[f64; 3]> = nodes.iter().map(|&n| b.nodes[n]).collect();
        let mut d = distances(model, c.dim, tag, &points)?;
        if !nodes
            .iter()
            .zip(&d)
            .all(|(&n, &d)| d <= POLISH * b.tolerance[n])
        {
            continue;
        }
        // exact for the report, and where Gmsh's figure is not enough
        polished(model, (c.dim, tag), &points, &mut d, |_, _| true);
        if !nodes.iter().zip(&d).all(|(&n, &d)| d <= b.tolerance[n]) {
            continue;
        }
        let mids: Vec<[f64; 3]> = e.facets.iter().map(|&f| centroid(b, f)).collect();
        let feet = model.closest_points(c.dim, tag, &mids)?;
        if model.count_inside(c.dim, tag, &feet)? < mids.len() {
            continue;
        }
        if Some(tag) == e.guess {
            return Ok(Some((tag, nodes, d)));
        }
        let sag = mids
            .iter()
            .zip(&feet)
            .map(|(p, q)| crate::numeric::dist2(*p, *q))
            .fold(0.0, f64::max)
            .sqrt();
        if best.as_ref().is_none_or(|(s, _, _)| sag < *s) {
            best = Some((sag, tag, d));
        }
    }
    Ok(best.map(|(_, tag, d)| (tag, nodes, d)))
}

/// The diagonal of box `bx`.
fn span(bx: [[f64; 3]; 2]) -> f64 {
    crate::numeric::dist2(bx[0], bx[1]).sqrt()
}

/// Each facet of `e` bound on its own (see the module docs); a facet on
/// no candidate is [`ClassifyError::Off`].
fn by_facet(
    model: &Arc<CadModel>,
    c: &Candidates,
    b: Boundary,
    e: &MeshEntity,
) -> Result<Vec<(usize, OnModel)>, ClassifyError> {
    let (nodes, pad) = nodes_of(b, e);
    let local: std::collections::HashMap<usize, usize> =
        nodes.iter().enumerate().map(|(k, &n)| (n, k)).collect();
    let bx = bounds(nodes.iter().map(|&n| b.nodes[n]));
    let near: Vec<usize> = (0..c.tags.len())
        .filter(|&i| meets(grown(c, i, pad), bx))
        .collect();
    // per candidate, the distance of each node in its box (else infinite)
    let mut d = vec![vec![f64::INFINITY; nodes.len()]; near.len()];
    for (j, &i) in near.iter().enumerate() {
        let held = grown(c, i, pad);
        let inside: Vec<usize> = (0..nodes.len())
            .filter(|&k| contains(held, [b.nodes[nodes[k]]; 2]))
            .collect();
        let points: Vec<[f64; 3]> = inside.iter().map(|&k| b.nodes[nodes[k]]).collect();
        let mut got = distances(model, c.dim, c.tags[i], &points)?;
        polished(model, (c.dim, c.tags[i]), &points, &mut got, |j, d| {
            d <= POLISH * b.tolerance[nodes[inside[j]]]
        });
        for (&k, g) in inside.iter().zip(got) {
            d[j][k] = g;
        }
    }
    let mut out = Vec::with_capacity(e.facets.len());
    for &f in &e.facets {
        let ks: Vec<usize> = b.facets[f].iter().map(|n| local[n]).collect();
        let fits: Vec<usize> = (0..near.len())
            .filter(|&j| ks.iter().all(|&k| d[j][k] <= b.tolerance[nodes[k]]))
            .collect();
        let worst = |j: usize| ks.iter().map(|&k| d[j][k]).fold(0.0, f64::max);
        let j = match fits.as_slice() {
            [] => return Err(off(model, c, b, f)?),
            [j] => *j,
            _ => nearest_holding(model, c, (&near, &fits), centroid(b, f))?,
        };
        out.push((
            f,
            OnModel {
                tag: c.tags[near[j]],
                distance: worst(j),
            },
        ));
    }
    Ok(out)
}

/// Of the candidates `fits` (indices into `near`), the one whose trimmed
/// entity holds the foot of `mid`, nearest; the nearest if none does.
fn nearest_holding(
    model: &CadModel,
    c: &Candidates,
    (near, fits): (&[usize], &[usize]),
    mid: [f64; 3],
) -> Result<usize, CadError> {
    let mut best: Option<(bool, f64, usize)> = None;
    for &j in fits {
        let tag = c.tags[near[j]];
        let foot = model.closest_points(c.dim, tag, &[mid])?;
        let Some(&q) = foot.first() else { continue };
        let held = model.count_inside(c.dim, tag, &[q])? == 1;
        let dist = crate::numeric::dist2(mid, q).sqrt();
        // held beats not held; then nearer
        if best.is_none_or(|(h, d, _)| (held, -dist) > (h, -d)) {
            best = Some((held, dist, j));
        }
    }
    Ok(best.map_or(fits[0], |b| b.2))
}

/// The error for facet `f`: its node farthest from every entity, and the
/// entity nearest to that node.
fn off(
    model: &Arc<CadModel>,
    c: &Candidates,
    b: Boundary,
    f: usize,
) -> Result<ClassifyError, CadError> {
    let mut worst: Option<Off> = None;
    for &n in &b.facets[f] {
        let mut nearest: Option<(f64, i32)> = None;
        for &tag in &c.tags {
            let d = distances(model, c.dim, tag, &[b.nodes[n]])?[0];
            if d.is_finite() && nearest.is_none_or(|(m, _)| d < m) {
                nearest = Some((d, tag));
            }
        }
        let distance = nearest.map_or(f64::INFINITY, |m| m.0);
        if distance > b.tolerance[n]
            && worst
                .as_ref()
                .is_none_or(|w| distance / b.tolerance[n] > w.distance / w.tolerance)
        {
            worst = Some(Off {
                facet: f,
                node: n,
                distance,
                nearest: nearest.map(|m| m.1),
                tolerance: b.tolerance[n],
            });
        }
    }
    // every node is near some entity, but no one entity holds them all
    let n = b.facets[f][0];
    Ok(ClassifyError::Off(worst.unwrap_or(Off {
        facet: f,
        node: n,
        distance: 0.0,
        nearest: None,
        tolerance: b.tolerance[n],
    })))
}

/// A uniform scale between the mesh's boundary and the model, read from
/// their bounding boxes: `Some(s)` when the mesh's box is the model's
/// times s (to 2 % of its size) and s is not 1 (to 5 %).
pub fn scale_between(mesh: [[f64; 3]; 2], model: [[f64; 3]; 2]) -> Option<f64> {
    let (a, b) = (span(mesh), span(model));
    if !(a > 0.0 && b > 0.0) {
        return None;
    }
    let s = a / b;
    if (s - 1.0).abs() <= 0.05 {
        return None;
    }
    let agrees = (0..2).all(|e| (0..3).all(|k| (mesh[e][k] - s * model[e][k]).abs() <= 0.02 * a));
    agrees.then_some(s)
}

/// `s` as the unit factor it most likely is (1000 for millimetres
/// against metres, 25.4 for millimetres against inches, …), if it is one
/// to 1 %, with the units: (factor, mesh's unit, model's unit).
pub fn unit_factor(s: f64) -> Option<(f64, &'static str, &'static str)> {
    const UNITS: [(f64, &str, &str); 6] = [
        (1000.0, "millimetres", "metres"),
        (25.4, "millimetres", "inches"),
        (10.0, "millimetres", "centimetres"),
        (100.0, "centimetres", "metres"),
        (304.8, "millimetres", "feet"),
        (12.0, "inches", "feet"),
    ];
    UNITS.iter().find_map(|&(f, a, b)| {
        if (s / f - 1.0).abs() < 0.01 {
            Some((f, a, b))
        } else if (s * f - 1.0).abs() < 0.01 {
            Some((1.0 / f, b, a))
        } else {
            None
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_box_a_thousand_times_another_is_a_unit_mistake() {
        let model = [[0.0, -0.5, 0.0], [2.0, 0.5, 1.0]];
        let mesh = [[0.0, -500.0, 0.0], [2000.0, 500.0, 1000.0]];
        assert_eq!(scale_between(mesh, model), Some(1000.0));
        assert_eq!(unit_factor(1000.0), Some((1000.0, "millimetres", "metres")));
        let back = scale_between(model, mesh).unwrap();
        assert!((back - 1e-3).abs() < 1e-15);
        assert_eq!(
            unit_factor(back).map(|u| (u.1, u.2)),
            Some(("metres", "millimetres"))
        );
        // the same box, or a part of the model, is no scale
        assert_eq!(scale_between(model, model), None);
        assert_eq!(
            scale_between([[0.0, -0.5, 0.0], [1.0, 0.5, 1.0]], model),
            None
        );
        // a box twice as large but moved is no uniform scale
        assert_eq!(
            scale_between([[5.0, -1.0, 0.0], [9.0, 1.0, 2.0]], model),
            None
        );
        assert_eq!(unit_factor(3.0), None);
    }
}
