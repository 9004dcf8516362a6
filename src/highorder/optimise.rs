//! Quality where peers optimise: once the snap or a repair has left every
//! element certified valid, the inner high-order nodes of the most
//! distorted simplices are moved, one node at a time, by a compass search
//! that raises the least *distortion* of the elements around it.
//!
//! The distortion of a curved element is the least Bernstein coefficient
//! of its det J over the det J of the straight element of its vertices:
//! 1 for a straight element, 0 where the curving flattens it. It is the
//! figure Gmsh gives as `minSJ` (`distoShapeMeasure`), and the one its
//! `HighOrderElastic` raises by moving the inner nodes (measured on the
//! filleted bracket at p = 2: the snap's least 0.705, Elastic's 0.766).
//! A coefficient bounds det J from below, so an element whose distortion
//! is positive is valid; each changed element is certified again at the
//! end all the same.
//!
//! Which nodes move: those of a simplex that lie on no boundary element
//! and are no vertex (the user's linear mesh stays as it was), held by
//! simplices only. Why the worst element first: the least distortion is
//! what a solver's conditioning and the peers' figure see, so the search
//! takes the worst element, moves its free nodes, and ends when the worst
//! cannot be raised (no move of its nodes raises it without lowering a
//! neighbour below it), when every element reaches [`TARGET`], or when
//! its budget of visits or of element figures is spent. No move lowers an element's sampled
//! scaled Jacobian under the mesh's least before the search, so the
//! candidate's least scaled Jacobian stays as it was.

use super::repair::NodeElements;
use crate::mesh::element::{corner_indices, Shape};
use crate::mesh::CurvedMesh;
use crate::quality::certify::{Certificate, Certifiers, CertifyOptions, ElementCertifier};
use crate::quality::simplex::SimplexCertifier;
use rayon::prelude::*;
use serde::Serialize;
use std::cmp::Ordering;
use std::collections::{BTreeMap, BinaryHeap};
use std::time::Instant;

/// Elements at or above this distortion are left as they are (Gmsh's
/// Elastic leaves the bracket's least at 0.766; above 0.9 the snap rule
/// of [`super::curve::SNAP_KEEP`] already calls an element shaped).
pub const TARGET: f64 = 0.9;

/// The compass search's first step, as a share of the node's elements'
/// size (`|det J|^(1/d)` of the straight element).
const FIRST_STEP: f64 = 0.1;

/// The search of one node ends when its step falls under this share of
/// the first (a hundredth of a tenth of the element; at 1e-3 the least
/// distortions measured were within 0.01 and the search took half again
/// as long: 1.5 s against 0.97 s on the torus at p = 3).
const LAST_STEP: f64 = 1e-2;

/// Visits of the worst element at most, per element under [`TARGET`] at
/// the start: the search ends.
const VISITS_PER_ELEMENT: usize = 4;

/// Element figures evaluated at most, per element of the mesh: the
/// search ends. Why: the least distortion rises fast and then slowly
/// (the ball in a box at p = 2: 0.48 → 0.79 in 85k figures, 0.79 → 0.90
/// in 580k more); this bounds the search at about 0.2 s per thousand
/// elements at p = 3 (a figure there is about 10 µs), 0.1 s at p = 2;
/// within [`EVALUATIONS`] (a small mesh's few elements need as many
/// figures as a large mesh's: the dented cube of the test, 162
/// tetrahedra, 13k).
const EVALUATIONS_PER_ELEMENT: usize = 20;

/// The least and the most figures the search may evaluate (0.25 s and
/// 10 s at p = 3).
const EVALUATIONS: [usize; 2] = [25_000, 1_000_000];

/// A fall of the energy around a node smaller than this share is not a
/// gain (round-off of the coefficients).
const RAISE: f64 = 1e-9;

/// The power of [`energy`].
const ENERGY_POWER: i32 = 8;

/// What the search did, for `report.json`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Optimised {
    /// Inner nodes moved.
    pub nodes_moved: usize,
    /// Elements holding a moved node (each certified again).
    pub elements_changed: usize,
    /// The least distortion (Gmsh's `minSJ`) of the simplices, before
    /// and after.
    pub least_distortion_before: f64,
    pub least_distortion: f64,
    /// Elements under [`TARGET`] before the search.
    pub under_target: usize,
    /// Visits of the worst element.
    pub visits: usize,
    /// Element figures evaluated.
    pub evaluations: usize,
    pub seconds: f64,
    /// Why the search ended.
    pub ended: String,
}

/// A trial place of a node: (least, energy) of its elements there, the
/// place, and each element's distortion.
type Trial<const D: usize> = ((f64, f64), [f64; D], Vec<f64>);

/// The search's result: every node's place, the changed elements'
/// certificates, and what it did.
pub struct Moved<const D: usize> {
    pub nodes: Vec<[f64; D]>,
    pub changed: BTreeMap<usize, Certificate>,
    pub report: Optimised,
}

/// A cell in the heap of the worst first.
#[derive(PartialEq)]
struct Worst(f64, usize);

impl Eq for Worst {}

impl PartialOrd for Worst {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Worst {
    fn cmp(&self, other: &Self) -> Ordering {
        // the least distortion first (BinaryHeap pops its greatest)
        other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
    }
}

/// The search's state over one mesh.
struct Search<'a, const D: usize> {
    mesh: &'a CurvedMesh<D>,
    nodes: Vec<[f64; D]>,
    /// The simplex certifier of each cell's kind, None for other kinds.
    of: Vec<Option<&'a SimplexCertifier>>,
    /// det J of each simplex's straight element.
    straight_det: Vec<f64>,
    /// The current distortion of each simplex (+∞ elsewhere).
    dist: Vec<f64>,
    free: Vec<bool>,
    by_node: NodeElements,
    /// No move leaves a sampled scaled Jacobian under this.
    floor: f64,
    evaluations: usize,
}

impl<const D: usize> Search<'_, D> {
    /// The control points of cell `c` with node `v` at `x`.
    fn ctrl(&self, c: usize, v: usize, x: [f64; D]) -> Vec<[f64; D]> {
        self.mesh.cells[c].iter().map(|&n| if n == v { x } else { self.nodes[n] }).collect()
    }

    /// The distortion of each of node `v`'s elements with `v` at `x`,
    /// None where one would not be positive.
    fn star_distortions(&self, v: usize, x: [f64; D]) -> Option<Vec<f64>> {
        let star = self.by_node.of(v);
        let each: Vec<f64> = star.iter().map(|&c| self.of[c].expect("a simplex").least_coefficient(&self.ctrl(c, v, x)) / self.straight_det[c]).collect();
        each.iter().all(|&d| d > 0.0).then_some(each)
    }

    /// Whether every one of node `v`'s elements, with `v` at `x`, keeps a
    /// sampled scaled Jacobian at the floor or above.
    fn shaped(&self, v: usize, x: [f64; D]) -> bool {
        self.by_node.of(v).iter().all(|&c| self.of[c].expect("a simplex").shape_figures(&self.ctrl(c, v, x)).1 >= self.floor)
    }

    /// [`Self::improve`] of each of `nodes`, marking the moved ones and
    /// putting their elements back in the heap: whether one moved.
    fn improve_all(&mut self, nodes: &[usize], moved: &mut [bool], heap: &mut BinaryHeap<Worst>) -> bool {
        let mut any = false;
        for &v in nodes {
            if self.improve(v) {
                any = true;
                moved[v] = true;
                heap.extend(self.by_node.of(v).iter().map(|&e| Worst(self.dist[e], e)));
            }
        }
        any
    }

    /// The compass search of node `v`: whether it moved. Each round tries
    /// a step along each axis both ways and takes the one that raises the
    /// least distortion of the node's elements most, or, where none
    /// raises it, keeps it and lowers their [`energy`] most (keeping their
    /// scaled Jacobians above the floor); the step halves where none
    /// does either.
    fn improve(&mut self, v: usize) -> bool {
        let star = self.by_node.of(v).to_vec();
        let least = |each: &[f64]| each.iter().copied().fold(f64::INFINITY, f64::min);
        let now: Vec<f64> = star.iter().map(|&c| self.dist[c]).collect();
        let size = star.iter().map(|&c| self.straight_det[c].abs().powf(1.0 / D as f64)).fold(f64::INFINITY, f64::min);
        let first = FIRST_STEP * size;
        let (mut h, mut best, mut best_each) = (first, (least(&now), energy(&now)), None);
        let better = |a: (f64, f64), b: (f64, f64)| a.0 > b.0 + RAISE * b.0.abs() || (a.0 >= b.0 && a.1 < b.1 * (1.0 - RAISE));
        while h >= LAST_STEP * first {
            let x = self.nodes[v];
            // (in parallel, the 2d trials took twice as long on 2 cores:
            // a trial is a few figures of about 10 µs)
            let mut tried: Vec<Trial<D>> = (0..2 * D)
                .filter_map(|k| {
                    let mut y = x;
                    y[k / 2] += if k % 2 == 0 { h } else { -h };
                    self.star_distortions(v, y).map(|each| ((least(&each), energy(&each)), y, each))
                })
                .collect();
            self.evaluations += 2 * D * star.len();
            tried.sort_by(|a, b| b.0 .0.total_cmp(&a.0 .0).then(a.0 .1.total_cmp(&b.0 .1)));
            let step = tried.into_iter().filter(|t| better(t.0, best)).find(|t| self.shaped(v, t.1));
            match step {
                Some((f, y, each)) => {
                    self.nodes[v] = y;
                    (best, best_each) = (f, Some(each));
                }
                None => h *= 0.5,
            }
        }
        let Some(each) = best_each else { return false };
        for (&c, d) in star.iter().zip(each) {
            self.dist[c] = d;
        }
        true
    }
}

/// The energy the search lowers around a node where the least distortion
/// cannot rise: `Σ d^−K` over the elements' distortions `d`, in which
/// the least dominates but each counts, so that of two elements tied at
/// the least, raising one alone is a gain, and the other can rise at the
/// next node (the least alone stalls there: measured on a dented cube at
/// p = 2, 0.40 → 0.47, against 0.69 with the energy).
fn energy(each: &[f64]) -> f64 {
    each.iter().map(|d| d.powi(-ENERGY_POWER)).sum()
}

/// The simplex certifier of `shape` in `certifiers`, if it is a simplex.
fn simplex_of(certifiers: &Certifiers, shape: Shape) -> Option<&SimplexCertifier> {
    match certifiers.of(shape) {
        ElementCertifier::Simplex(s) => Some(s),
        _ => None,
    }
}

/// The inner nodes of `mesh` the search may move: no vertex, on no
/// boundary element, held by simplices only.
fn free_nodes<const D: usize>(mesh: &CurvedMesh<D>, simplex: &[bool]) -> Vec<bool> {
    let n = mesh.nodes.len();
    let mut free = vec![true; n];
    for (c, cell) in mesh.cells.iter().enumerate() {
        if !simplex[c] {
            cell.iter().for_each(|&v| free[v] = false);
        }
        for k in corner_indices(mesh.cell_shape(c), mesh.p) {
            free[cell[k]] = false;
        }
    }
    for f in mesh.boundary.iter() {
        f.nodes.iter().for_each(|&v| free[v] = false);
    }
    free
}

/// The mesh with its most distorted simplices' inner nodes moved, the
/// certificates of the elements that changed (every one valid), and what
/// the search did; None where nothing is to gain (no simplex under
/// [`TARGET`] with a free node, order 1) or a changed element is not
/// certified valid. `certificates` are the mesh's, every one valid;
/// `straight` the straight place of every node.
pub fn optimised<const D: usize>(mesh: &CurvedMesh<D>, certificates: &[Certificate], straight: &[[f64; D]]) -> Option<Moved<D>> {
    let clock = Instant::now();
    if mesh.p < 2 || !mesh.shapes().iter().any(|s| s.is_simplex()) {
        return None;
    }
    let certifiers = Certifiers::new(&mesh.shapes(), mesh.p, mesh.spacing).ok()?;
    let cells = mesh.cells.len();
    let of: Vec<Option<&SimplexCertifier>> = (0..cells).map(|c| simplex_of(&certifiers, mesh.cell_shape(c))).collect();
    let simplex: Vec<bool> = of.iter().map(Option::is_some).collect();
    let straight_det: Vec<f64> = (0..cells).into_par_iter().map(|c| of[c].map_or(f64::NAN, |s| s.least_coefficient(&mesh.cells[c].iter().map(|&n| straight[n]).collect::<Vec<_>>()))).collect();
    // a straight element's coefficients are its det J: 1 without asking
    let curved = |c: usize| mesh.cells[c].iter().any(|&n| mesh.nodes[n] != straight[n]);
    let dist: Vec<f64> = (0..cells)
        .into_par_iter()
        .map(|c| match of[c] {
            Some(s) if curved(c) => s.least_coefficient(&mesh.cell_coords(c)) / straight_det[c],
            Some(_) => 1.0,
            None => f64::INFINITY,
        })
        .collect();
    let floor = certificates.iter().map(|c| c.min_scaled_jacobian).fold(f64::INFINITY, f64::min);
    let free = free_nodes(mesh, &simplex);
    let movable = |c: usize| simplex[c] && mesh.cells[c].iter().any(|&v| free[v]);
    let before = dist.iter().copied().fold(f64::INFINITY, f64::min);
    let seeds: Vec<usize> = (0..cells).filter(|&c| dist[c] < TARGET && movable(c)).collect();
    // the least of the elements the search cannot change bounds what it
    // can reach
    let fixed = (0..cells).filter(|&c| !movable(c)).map(|c| dist[c]).fold(f64::INFINITY, f64::min);
    if seeds.is_empty() || fixed <= before {
        return None;
    }
    let mut s = Search { mesh, nodes: mesh.nodes.clone(), of, straight_det, dist, free, by_node: NodeElements::new(mesh), floor, evaluations: 0 };
    let mut heap: BinaryHeap<Worst> = seeds.iter().map(|&c| Worst(s.dist[c], c)).collect();
    let budget = VISITS_PER_ELEMENT * seeds.len();
    let mut moved = vec![false; s.nodes.len()];
    let (mut visits, mut ended) = (0, String::new());
    while let Some(Worst(d, c)) = heap.pop() {
        if d != s.dist[c] {
            continue;
        }
        if d >= TARGET.min(fixed) {
            ended = if d >= TARGET {
                format!("every element it can change at a distortion of {TARGET} or more")
            } else {
                format!("the least distortion at {fixed:.4}, that of an element with no node it may move")
            };
            break;
        }
        if visits == budget || s.evaluations >= (EVALUATIONS_PER_ELEMENT * cells).clamp(EVALUATIONS[0], EVALUATIONS[1]) {
            ended = format!("its budget spent ({visits} visits of the worst element, {} figures evaluated)", s.evaluations);
            break;
        }
        visits += 1;
        // its own nodes, then, where none moves, those of its neighbours
        // (holding its nodes, raising them frees its nodes to move)
        let own: Vec<usize> = mesh.cells[c].iter().copied().filter(|&v| s.free[v]).collect();
        let mut gained = s.improve_all(&own, &mut moved, &mut heap);
        if !gained {
            let mut around: Vec<usize> = own.iter().flat_map(|&v| s.by_node.of(v).to_vec()).flat_map(|e| mesh.cells[e].to_vec()).filter(|&v| s.free[v] && !own.contains(&v)).collect();
            around.sort_unstable();
            around.dedup();
            gained = s.improve_all(&around, &mut moved, &mut heap);
        }
        if !gained {
            ended = format!("no move of the nodes of the worst element (cell {c}, {d:.4}) or of its neighbours raises it or lowers their energy without lowering their least");
            break;
        }
        heap.push(Worst(s.dist[c], c));
    }
    if ended.is_empty() {
        ended = "every element it can change visited".into();
    }
    let after = s.dist.iter().copied().fold(f64::INFINITY, f64::min);
    // moves that only lowered the energy leave the least as it was: the
    // mesh stays as the curving left it
    if after <= before {
        return None;
    }
    let nodes = s.nodes;
    let mut changed: Vec<usize> = (0..nodes.len()).filter(|&v| moved[v]).flat_map(|v| s.by_node.of(v).to_vec()).collect();
    changed.sort_unstable();
    changed.dedup();
    if changed.is_empty() {
        return None;
    }
    let certify = |c: usize| {
        let ctrl: Vec<[f64; D]> = mesh.cells[c].iter().map(|&n| nodes[n]).collect();
        (c, certifiers.of(mesh.cell_shape(c)).certify(&ctrl, &CertifyOptions::element()))
    };
    let certs: BTreeMap<usize, Certificate> = changed.iter().map(|&c| certify(c)).collect();
    if certs.values().any(|c| !c.valid) {
        tracing::warn!("the optimised elements were not all certified valid: the mesh is kept as it was");
        return None;
    }
    let report = Optimised {
        nodes_moved: moved.iter().filter(|&&m| m).count(),
        elements_changed: changed.len(),
        least_distortion_before: before,
        least_distortion: after,
        under_target: seeds.len(),
        visits,
        evaluations: s.evaluations,
        seconds: clock.elapsed().as_secs_f64(),
        ended,
    };
    Some(Moved { nodes, changed: certs, report })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::highorder::curve::{certify_mesh, fine_mesh};
    use crate::highorder::Spacing;
    use crate::mesh::element::simplex::space;
    use crate::numeric::simplex_bezier::multi_indices;
    use crate::refine::subdivide_mixed_solid;

    /// The least of det J over the straight element's det J on a lattice
    /// of `m` points per edge of tetrahedron `c`, J from the monomial
    /// Lagrange basis (not the Bernstein coefficients the search uses).
    fn sampled(mesh: &CurvedMesh<3>, straight: &[[f64; 3]], c: usize, m: usize) -> f64 {
        let sp = space(Shape::Tetrahedron, mesh.p, mesh.spacing).unwrap();
        let n = sp.num_nodes();
        let (mut val, mut grad) = (vec![0.0; n], vec![[0.0; 3]; n]);
        let mut det_at = |x: &[[f64; 3]], xi: [f64; 3]| {
            sp.eval(xi, &mut val, &mut grad);
            let j: [[f64; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|k| mesh.cells[c].iter().zip(&grad).map(|(&v, g)| x[v][r] * g[k]).sum()));
            crate::mesh::element::basis::det(&j)
        };
        let flat = det_at(straight, [0.25; 3]);
        multi_indices(3, m - 1).map(|a| a.map(|i| i as f64 / (m - 1) as f64)).map(|xi| det_at(&mesh.nodes, xi) / flat).fold(f64::INFINITY, f64::min)
    }

    /// Tetrahedra of the unit cube (3 × 3 × 3 cubes) at p = 2 whose wall
    /// z = 0 is dented (its new nodes pushed inwards by up to 0.05, a bump
    /// vanishing at the wall's sides, as a snap onto a dented shape puts
    /// them): the tetrahedra on it flatten. The search raises the
    /// least distortion, by the Bernstein coefficients and by a dense
    /// sampling of det J alike; the coefficient it reports bounds the
    /// sampled figure from below; no vertex and no node of a boundary
    /// element moves; every changed element is certified valid.
    #[test]
    fn the_least_distortion_rises_and_the_walls_and_vertices_stay() {
        let coarse = CurvedMesh::brick([0.0; 3], [1.0; 3], [3, 3, 3], Shape::Tetrahedron).unwrap();
        let (sub, _) = subdivide_mixed_solid(&coarse, 2, Spacing::Equispaced).unwrap();
        let straight = sub.fine.nodes.clone();
        let vertex: Vec<bool> = (0..straight.len()).map(|v| coarse.nodes.contains(&straight[v])).collect();
        let mut nodes = straight.clone();
        for (v, x) in nodes.iter_mut().enumerate() {
            if x[2] == 0.0 && !vertex[v] {
                x[2] += 0.05 * 16.0 * x[0] * (1.0 - x[0]) * x[1] * (1.0 - x[1]);
            }
        }
        let mesh = fine_mesh(&sub, &coarse.part_names, Spacing::Equispaced, nodes);
        let (certs, q) = certify_mesh(&mesh).unwrap();
        assert!(q.invalid_elements.is_empty());
        let Moved { nodes: moved, changed, report } = optimised(&mesh, &certs, &straight).expect("a gain");
        let after = CurvedMesh { nodes: moved.clone(), ..mesh.clone() };
        let dense = |m: &CurvedMesh<3>| (0..m.cells.len()).map(|c| sampled(m, &straight, c, 9)).fold(f64::INFINITY, f64::min);
        let (was, now) = (dense(&mesh), dense(&after));
        // measured: 0.4000 → 0.6900 by the coefficients and sampled alike
        // (the least at a vertex, where the two agree)
        assert!(report.least_distortion_before <= was + 1e-12 && report.least_distortion <= now + 1e-12, "{report:?}: sampled {was} → {now}");
        assert!(report.least_distortion > 0.68 && now > 0.68 && was < 0.41, "{report:?}: sampled {was} → {now}");
        assert!(changed.values().all(|c| c.valid) && changed.len() == report.elements_changed);
        let mut held = vec![false; moved.len()];
        mesh.boundary.iter().for_each(|f| f.nodes.iter().for_each(|&v| held[v] = true));
        for v in 0..moved.len() {
            if vertex[v] || held[v] {
                assert_eq!(moved[v], mesh.nodes[v], "node {v} moved");
            }
        }
        assert!(report.nodes_moved > 0 && (0..moved.len()).filter(|&v| moved[v] != mesh.nodes[v]).count() == report.nodes_moved);
    }
}
