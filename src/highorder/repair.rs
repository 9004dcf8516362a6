//! Repair in patches: where the snap (Gmsh's `setOrder` way: the new
//! boundary nodes put on their shapes, nothing else moved) leaves elements
//! not certified valid or sheared under [`SNAP_KEEP`], Algorithm 2's flow
//! runs on a *patch* of those elements and a few rings of elements around
//! them only. The patch starts straight; every node it shares with an
//! element outside it, and every node of a curved facet in it, goes on a
//! straight path to its place in the snap (the paper's Dirichlet data), so
//! the repaired elements join the snap's without a seam; the nodes inside
//! follow the flow. The patch grows ([`PATCH_RINGS`]) until every element in
//! it is certified valid and keeps [`SNAP_KEEP`] of its straight scaled
//! Jacobian; a patch that would hold more than [`PATCH_SHARE`] of the mesh
//! is the whole mesh's business (Algorithm 2 proper).
//!
//! The snap and each repair are candidates: what is written is certified
//! valid and has the highest least scaled Jacobian, the snap on a tie
//! ([`Repair`] in `report.json` says which won and why). Cost and memory
//! scale with what is wrong: the linear system holds the patch's free
//! nodes only.

use super::curve::{certify_mesh_straight, CurveError, CurveOptions, Linear, Pass, Settling, Snap, AUTO_STEPS, SNAP_KEEP};
use crate::deform::{BoundaryPart, DeformError, DeformOptions, Deformation, RunStats};
use crate::jacobian::JacobianField;
use crate::mesh::CurvedMesh;
use crate::quality::certify::{Certificate, Certifiers, CertifyOptions};
use crate::refine::{PatchTargets, RefineMesh, Subdividable, Subdivision};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

/// The patch sizes tried in turn, in rings of elements (sharing a node)
/// around the elements to repair. Why these: the motion Algorithm 2 makes
/// falls by 3–4× per cell from the wall (`shared/notes`: ball octant at
/// p = 3), so two rings hold most of a snap's correction; a thin layer,
/// whose columns must move together, needs more.
pub const PATCH_RINGS: [usize; 4] = [2, 4, 8, 16];

/// A patch holding more than this share of the elements is not repaired
/// as a patch: the whole mesh is moved (Algorithm 2).
pub const PATCH_SHARE: f64 = 0.5;

/// How much a candidate's least scaled Jacobian must exceed the best
/// so far to replace it: less is within the certificates' sampling.
pub const GAIN: f64 = 0.01;

/// Two stalls at pseudo-times closer than this are the same stall
/// ([`Patched::stalled`]).
pub const STALL_SAME: f64 = 1e-3;

/// Most accepted steps of one run of Algorithm 2 on the whole mesh
/// ([`DeformOptions::max_steps`]): every run ends. The most a run took on
/// the meshes measured is the 1e-5 extruded layer's 6 steps at p = 3.
pub const MAX_STEPS: usize = 200;

/// Most accepted steps of one run of Algorithm 2 on a patch: fewer than
/// on the whole mesh, as a patch that fails has a next candidate (sliding,
/// a larger patch), and with this budget [`crate::deform::PACE_WINDOW`]'s
/// rule ends a crawling run after its first window: one that has not
/// come about half way in 10 steps. The valid patch runs measured (the
/// benchmark's meshes at p = 2 and 3) took at most 6 steps; the 1e-5
/// extruded layer's patch at p = 2 that cannot pass t = 0.42 with its wall
/// nodes held now ends after 10 steps at t = 0.37 (60 steps and 92 s
/// before the pace rule), the tet ball's patches after 10 at
/// t = 0.18 (where they went on to stall at t = 0.2099).
pub const PATCH_MAX_STEPS: usize = 20;

/// The candidates of one `curve` run and which was written.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Repair {
    /// The candidates, in the order they were tried.
    pub candidates: Vec<Candidate>,
    /// The candidate written: `snap`, `patch` or `whole mesh`.
    pub won: String,
    /// Why it won.
    pub why: String,
    /// The search that then raised the least distortion of its simplices,
    /// if it moved a node ([`super::optimise`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub optimised: Option<super::optimise::Optimised>,
}

/// One candidate result.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    /// `snap`, `patch`, `patch (sliding)` or `whole mesh`.
    pub name: String,
    /// The rings of a patch around the elements to repair.
    pub rings: Option<usize>,
    /// The elements it moved (all the snap touched, a patch's, or all).
    pub elements: usize,
    /// Their share of the mesh.
    pub share: f64,
    /// The elements not certified valid among those it moved.
    pub invalid: usize,
    /// The least scaled Jacobian of those it moved, as judged ([`judged`]:
    /// lowered where det J dips between the samples); None where one is
    /// not certified valid.
    pub min_scaled_jacobian: Option<f64>,
    /// Seconds it took, certification included (`time_s` in the report:
    /// a time, which `behaviour.sh` does not compare).
    #[serde(rename = "time_s")]
    pub seconds: f64,
    /// Why it ended without a result, if it did (a run that stalled or
    /// spent its budget of steps, a failed solve).
    pub ended: Option<String>,
}

impl Candidate {
    /// How it ended, for the terminal and messages.
    pub fn outcome(&self) -> String {
        match (&self.ended, self.min_scaled_jacobian) {
            (Some(why), _) => format!("ended: {why}"),
            (None, Some(m)) => format!("valid, least scaled Jacobian {m:.4}"),
            (None, None) => format!("{} element(s) not certified valid", self.invalid),
        }
    }
}

/// Elements by node: for each node, the elements that hold it.
pub(super) struct NodeElements {
    first: Vec<usize>,
    of: Vec<usize>,
}

impl NodeElements {
    pub(super) fn new<const D: usize>(mesh: &CurvedMesh<D>) -> Self {
        let mut first = vec![0usize; mesh.nodes.len() + 1];
        for cell in mesh.cells.iter() {
            for &n in cell {
                first[n + 1] += 1;
            }
        }
        for i in 0..mesh.nodes.len() {
            first[i + 1] += first[i];
        }
        let mut at = first.clone();
        let mut of = vec![0; first[mesh.nodes.len()]];
        for (c, cell) in mesh.cells.iter().enumerate() {
            for &n in cell {
                of[at[n]] = c;
                at[n] += 1;
            }
        }
        NodeElements { first, of }
    }

    pub(super) fn of(&self, n: usize) -> &[usize] {
        &self.of[self.first[n]..self.first[n + 1]]
    }
}

/// The elements within `rings` rings of `seeds`, per element.
fn grow<const D: usize>(mesh: &CurvedMesh<D>, by_node: &NodeElements, seeds: &[usize], rings: usize) -> Vec<bool> {
    let mut inside = vec![false; mesh.cells.len()];
    let mut front: Vec<usize> = seeds.to_vec();
    for &c in seeds {
        inside[c] = true;
    }
    for _ in 0..rings {
        let mut next = Vec::new();
        for &c in &front {
            for &n in &mesh.cells[c] {
                for &e in by_node.of(n) {
                    if !inside[e] {
                        inside[e] = true;
                        next.push(e);
                    }
                }
            }
        }
        if next.is_empty() {
            break;
        }
        front = next;
    }
    inside
}

/// What the run on a patch asks of its nodes: inside the patch or not,
/// and the snap's place for every node it shares with an element outside
/// and, unless they `slide` (Algorithm 2's roles: gliding along the
/// blended facets onto the shapes), every node of a boundary facet in it.
fn targets<const D: usize>(snap: &CurvedMesh<D>, in_patch: &[bool], slide: bool) -> PatchTargets<D> {
    let n = snap.nodes.len();
    let (mut inside, mut outside) = (vec![false; n], vec![false; n]);
    for (c, cell) in snap.cells.iter().enumerate() {
        let side = if in_patch[c] { &mut inside } else { &mut outside };
        for &v in cell {
            side[v] = true;
        }
    }
    let mut on_wall = vec![false; n];
    for f in snap.boundary.iter() {
        for &v in f.nodes {
            on_wall[v] = true;
        }
    }
    let targets = (0..n).map(|v| (inside[v] && (outside[v] || (on_wall[v] && !slide))).then_some(snap.nodes[v])).collect();
    PatchTargets { inside, targets }
}

/// A repaired mesh: the snap with a patch's nodes moved, and the patch's
/// elements' certificates.
struct Repaired<const D: usize> {
    mesh: CurvedMesh<D>,
    /// Per patch element.
    certificates: BTreeMap<usize, Certificate>,
    stats: RunStats,
    solver: crate::deform::SolverReport,
}

/// Runs Algorithm 2 on the patch `in_patch` of `snap`, with as few steps
/// as the step control allows and then more ([`AUTO_STEPS`]) while an
/// element of the patch is not certified valid: the last run's mesh, or
/// why no run ended.
#[allow(clippy::too_many_arguments)]
fn run_patch<M, const D: usize, const N: usize>(
    sub: &Subdivision<M, D>,
    parts: &[BoundaryPart<D>],
    opts: &CurveOptions,
    snap: &CurvedMesh<D>,
    (in_patch, slide): (&[bool], bool),
    certifiers: &Certifiers,
    progress: &mut impl FnMut(f64, &RunStats),
) -> Result<Result<Repaired<D>, DeformError>, CurveError>
where
    M: Subdividable<D, N>,
    RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
{
    let patch = Arc::new(targets(snap, in_patch, slide));
    let free = (0..patch.inside.len()).filter(|&v| patch.inside[v] && patch.targets[v].is_none()).count();
    let elements: Vec<usize> = (0..in_patch.len()).filter(|&c| in_patch[c]).collect();
    let steps: Vec<usize> = match opts.steps {
        Some(n) => vec![n.max(1)],
        None => AUTO_STEPS.to_vec(),
    };
    let mut last = None;
    for steps in steps {
        let max_strain = opts.steps.is_none().then_some(opts.step_change);
        // (steps the user gave are taken whole, as on the whole mesh)
        let budget = opts.steps.map_or(PATCH_MAX_STEPS, |n| PATCH_MAX_STEPS.max(2 * n));
        let mut flow = DeformOptions { steps, max_strain, max_steps: Some(budget), ..opts.flow.clone() };
        flow.solver = flow.solver.resolved(D, D * free, flow.factor_limit);
        let start = sub.refine_mesh().with_patch(patch.clone());
        let mut def = Deformation::<RefineMesh<M, D>, D, N>::new(start, parts.to_vec(), JacobianField::uniform(), flow)?;
        match def.run_while(|d| {
            progress(d.t, &d.stats);
            true
        }) {
            Ok(_) => {}
            // a stalled run stalls again with shorter nominal steps: the
            // step control has already cut them as far as they go
            Err(e @ DeformError::Stalled { .. }) => {
                tracing::info!("a patch of {} elements: {e}", elements.len());
                return Ok(Err(e));
            }
            Err(e @ (DeformError::Tangled { .. } | DeformError::Solve(_))) => {
                tracing::info!("a patch of {} elements, {steps} nominal steps: {e}", elements.len());
                last = Some(Err(e));
                continue;
            }
            Err(e) => return Err(e.into()),
        }
        let flowed = def.mesh.mesh.nodes();
        let mut nodes = snap.nodes.clone();
        for (v, x) in nodes.iter_mut().enumerate() {
            if patch.inside[v] {
                *x = flowed[v];
            }
        }
        let mesh = CurvedMesh { nodes, ..snap.clone() };
        let certificates: BTreeMap<usize, Certificate> = elements.par_iter().map(|&c| (c, certifiers.of(mesh.cell_shape(c)).certify(&mesh.cell_coords(c), &CertifyOptions::element()))).collect();
        let invalid = certificates.values().filter(|c| !c.valid).count();
        let repaired = Repaired { mesh, certificates, stats: def.stats.clone(), solver: def.solver_report() };
        // with every node of the patch's boundary on a fixed path, the end
        // is the same however many steps lead to it: only a sliding run's
        // path (its put-back onto the curved walls) is worth retaking
        if invalid == 0 || !slide {
            return Ok(Ok(repaired));
        }
        tracing::info!("a patch of {} elements, sliding, {steps} nominal steps: {invalid} not certified valid", elements.len());
        last = Some(Ok(repaired));
    }
    Ok(last.expect("at least one run"))
}

/// The patches tried, and how each ended, for a message.
pub fn tried(r: &Repair) -> String {
    let each = r.candidates.iter().filter(|c| c.rings.is_some()).map(|c| {
        let what = match c.rings {
            Some(k) => format!("a {} of {k} rings ({} elements)", c.name, c.elements),
            None => format!("the {}", c.name),
        };
        format!("{what}: {}", c.outcome())
    });
    each.collect::<Vec<_>>().join("; ")
}

/// An element's scaled Jacobian as the candidates are judged: the
/// sampled one, lowered by the share of its sampled least det J that the
/// certified bound falls below it. Why: the samples can miss a dip of
/// det J between them that Gmsh's minSJ, a bound, sees (measured on the
/// OCC torus at p = 2: a sliding patch's element sampled at 0.41, its det
/// J certified down to 8.9e-6, Gmsh's minSJ 0.0065); None if not valid.
pub fn judged(c: &Certificate) -> Option<f64> {
    let dip = if c.min_det_sampled > 0.0 { (c.min_det_lower / c.min_det_sampled).clamp(0.0, 1.0) } else { 0.0 };
    c.valid.then_some(c.min_scaled_jacobian * dip)
}

/// The least [`judged`] scaled Jacobian of `certs`, None if one is not
/// valid.
fn least(certs: impl Iterator<Item = Certificate>) -> Option<f64> {
    certs.map(|c| judged(&c)).try_fold(f64::INFINITY, |m, s| s.map(|s| m.min(s)))
}

/// What the repair in patches gave: the best certified candidate among
/// the snap (where it is valid) and the patches, None where neither is
/// valid; the report of every candidate; and where the runs on two
/// patches, one the other's growth, stalled at the same pseudo-times (a
/// stall is local: a sub-cell degenerating under its prescribed motion,
/// which more room around it does not change), the stall, which Algorithm
/// 2 on the whole mesh would meet too (measured on the tet ball at
/// p = 2: patches of 242 and 1,512 elements and the whole mesh stall at
/// t = 0.2099 alike).
pub(super) struct Patched<const D: usize> {
    pub best: Option<Pass<D>>,
    pub report: Repair,
    pub stalled: Option<DeformError>,
}

/// The snap's elements to repair, repaired in growing patches
/// ([`Patched`]).
pub(super) fn in_patches<M, const D: usize, const N: usize>(
    sub: &Subdivision<M, D>,
    parts: &[BoundaryPart<D>],
    opts: &CurveOptions,
    snap: &Snap<D>,
    certify_s: &mut f64,
    mut progress: impl FnMut(f64, &RunStats),
) -> Result<Patched<D>, CurveError>
where
    M: Subdividable<D, N>,
    RefineMesh<M, D>: crate::deform::Q1Mesh<D, N>,
{
    let mesh = &snap.mesh;
    let straight = sub.fine.nodes();
    let all = mesh.cells.len();
    let by_node = NodeElements::new(mesh);
    let certifiers = Certifiers::new(&mesh.shapes(), mesh.p, mesh.spacing)?;
    let linear = Linear::new(mesh)?;
    let straight_mesh = CurvedMesh { nodes: straight.to_vec(), ..mesh.clone() };
    let mut report = Repair::default();
    // the snap as a candidate: every element certified once it is valid
    let t0 = Instant::now();
    let snap_pass = if snap.valid {
        let (certificates, mut quality) = certify_mesh_straight(mesh, straight, &BTreeMap::new())?;
        let valid = quality.invalid_elements.is_empty();
        quality.settling = Settling { largest_move: snap.largest_move, fitted: snap.fitted, ..Default::default() };
        valid.then(|| Pass { mesh: mesh.clone(), certificates, quality, stats: RunStats::default(), solver: Default::default(), moved_distance: snap.moved_distance })
    } else {
        None
    };
    let seconds = t0.elapsed().as_secs_f64();
    *certify_s += seconds;
    let moved = (0..all).filter(|&c| mesh.cells[c].iter().any(|&n| mesh.nodes[n] != straight[n])).count();
    report.candidates.push(Candidate {
        name: "snap".into(),
        rings: None,
        elements: moved,
        share: moved as f64 / all.max(1) as f64,
        invalid: if snap.valid { 0 } else { snap.bad.len() },
        min_scaled_jacobian: snap_pass.as_ref().and_then(|p| least(p.certificates.iter().copied())),
        seconds,
        ended: None,
    });
    let mut best: Option<(Repaired<D>, usize, f64)> = None;
    // the pseudo-times at which the last patch's runs stalled, if all did
    let mut stalls: Option<Vec<f64>> = None;
    let mut stalled = None;
    'grow: for rings in PATCH_RINGS {
        let in_patch = grow(mesh, &by_node, &snap.bad, rings);
        let elements: Vec<usize> = (0..all).filter(|&c| in_patch[c]).collect();
        let share = elements.len() as f64 / all.max(1) as f64;
        if share > PATCH_SHARE {
            tracing::info!("a patch of {rings} rings would hold {:.0} % of the elements: not a patch", 100.0 * share);
            break;
        }
        // the rule the snap failed: every element of the patch keeps
        // SNAP_KEEP of its straight scaled Jacobian (or of the patch's
        // least straight one)
        let straight_sj: Vec<f64> = elements.par_iter().map(|&c| linear.certify(&certifiers, &straight_mesh, c, &CertifyOptions::element()).min_scaled_jacobian).collect();
        let floor = straight_sj.iter().copied().fold(f64::INFINITY, f64::min);
        // the new boundary nodes at the snap's places first (its boundary
        // accuracy); sliding, as Algorithm 2 proper, where that leaves an
        // element invalid: a node's place on the shape is then free too
        let mut here = Some(Vec::new());
        for slide in [false, true] {
            let t0 = Instant::now();
            let run = run_patch(sub, parts, opts, mesh, (&in_patch, slide), &certifiers, &mut progress)?;
            let name = if slide { "patch (sliding)" } else { "patch" };
            let mut candidate = Candidate { name: name.into(), rings: Some(rings), elements: elements.len(), share, invalid: 0, min_scaled_jacobian: None, seconds: 0.0, ended: None };
            let valid = match run {
                Err(e) => {
                    candidate.ended = Some(e.to_string());
                    match &e {
                        DeformError::Stalled { t, .. } => here.get_or_insert_with(Vec::new).push(*t),
                        _ => here = None,
                    }
                    stalled = Some(e);
                    false
                }
                Ok(r) => {
                    here = None;
                    candidate.invalid = r.certificates.values().filter(|c| !c.valid).count();
                    candidate.min_scaled_jacobian = least(r.certificates.values().copied());
                    let shaped = candidate.invalid == 0 && elements.iter().zip(&straight_sj).all(|(c, &was)| judged(&r.certificates[c]).unwrap_or(f64::NEG_INFINITY) >= SNAP_KEEP * was.min(floor));
                    if let Some(m) = candidate.min_scaled_jacobian.filter(|&m| best.as_ref().is_none_or(|b| m > b.2 * (1.0 + GAIN))) {
                        best = Some((r, rings, m));
                    }
                    candidate.seconds = t0.elapsed().as_secs_f64();
                    if shaped {
                        report.candidates.push(candidate);
                        break 'grow;
                    }
                    candidate.invalid == 0
                }
            };
            candidate.seconds = t0.elapsed().as_secs_f64();
            report.candidates.push(candidate);
            if valid {
                break;
            }
        }
        // a patch grows to be valid, not for shape: a larger one gained
        // nothing measurable on the meshes tried (the OCC ball in a box
        // at p = 3: 2 rings 0.2738, 4 rings 0.2739 at five times the time)
        if elements.len() == all || best.is_some() {
            break;
        }
        let same = |a: &[f64], b: &[f64]| a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < STALL_SAME);
        if let (Some(a), Some(b)) = (&stalls, &here) {
            if same(a, b) {
                tracing::info!("patches of {rings} rings and the one before stalled at the same pseudo-times {b:?}: no larger patch is tried");
                return Ok(Patched { best: None, report: finish(report, snap_pass.is_some()), stalled });
            }
        }
        stalls = here;
    }
    let Some((repaired, rings, _)) = best else {
        let report = finish(report, snap_pass.is_some());
        return Ok(Patched { best: snap_pass, report, stalled: None });
    };
    // the repaired mesh, every element certified: the snap's certificates
    // stand outside the patch where it was certified
    let t0 = Instant::now();
    let mut known = repaired.certificates.clone();
    if let Some(p) = &snap_pass {
        known.extend((0..all).filter(|c| !repaired.certificates.contains_key(c)).map(|c| (c, p.certificates[c])));
    }
    let (certificates, mut quality) = certify_mesh_straight(&repaired.mesh, straight, &known)?;
    *certify_s += t0.elapsed().as_secs_f64();
    let largest_move = repaired.mesh.nodes.iter().zip(straight).map(|(x, y)| crate::numeric::dist2(*x, *y).sqrt()).fold(0.0, f64::max);
    quality.settling = Settling { largest_move, fitted: snap.fitted, steps: repaired.stats.steps, ..Default::default() };
    let patch = Pass { mesh: repaired.mesh, certificates, quality, stats: repaired.stats, solver: repaired.solver, moved_distance: snap.moved_distance };
    let least_patch = least(patch.certificates.iter().copied()).unwrap_or(f64::NEG_INFINITY);
    let least_snap = snap_pass.as_ref().and_then(|s| least(s.certificates.iter().copied()));
    match snap_pass {
        Some(s) if least_snap.is_some_and(|l| l * (1.0 + GAIN) >= least_patch) => {
            report.won = "snap".into();
            report.why = format!("valid, with a least scaled Jacobian (judged) of {:.4}, at least the repaired mesh's {least_patch:.4} within {GAIN}", least_snap.unwrap_or_default());
            Ok(Patched { best: Some(s), report, stalled: None })
        }
        other => {
            report.won = "patch".into();
            report.why = match other {
                Some(_) => format!("a patch of {rings} rings ({} elements) raised the least scaled Jacobian (judged) from the snap's {:.4} to {least_patch:.4}", report.candidates.iter().rev().find(|c| c.rings == Some(rings)).map_or(0, |c| c.elements), least_snap.unwrap_or_default()),
                None => format!("the snap left {} elements not certified valid; a patch of {rings} rings ({} elements) repaired them", snap.bad.len(), report.candidates.iter().rev().find(|c| c.rings == Some(rings)).map_or(0, |c| c.elements)),
            };
            Ok(Patched { best: Some(patch), report, stalled: None })
        }
    }
}

/// The report where no patch was valid: the snap won if it was valid.
fn finish(mut report: Repair, snap_valid: bool) -> Repair {
    if snap_valid {
        report.won = "snap".into();
        report.why = "every element is certified valid, and no patch repaired its sheared elements to a valid result".into();
    } else {
        report.why = "no patch left every element certified valid".into();
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::element::Shape;

    /// A strip of `n` unit quads at order 1, cell c between x = c and c + 1.
    fn strip(n: usize) -> CurvedMesh<2> {
        let nodes: Vec<[f64; 2]> = (0..=n).flat_map(|i| [[i as f64, 0.0], [i as f64, 1.0]]).collect();
        let cells: Vec<Vec<usize>> = (0..n).map(|c| vec![2 * c, 2 * c + 2, 2 * c + 3, 2 * c + 1]).collect();
        CurvedMesh::linear(nodes, cells.into_iter().map(|c| (Shape::Quadrilateral, c)), vec![(vec![4, 6], 0)], vec!["wall".into()])
    }

    #[test]
    fn rings_grow_by_shared_nodes() {
        let mesh = strip(9);
        let by_node = NodeElements::new(&mesh);
        let inside = grow(&mesh, &by_node, &[4], 2);
        let cells: Vec<usize> = (0..9).filter(|&c| inside[c]).collect();
        assert_eq!(cells, vec![2, 3, 4, 5, 6]);
        // a front that reaches the ends stops there
        assert_eq!(grow(&mesh, &by_node, &[0], 20).iter().filter(|&&x| x).count(), 9);
    }

    #[test]
    fn targets_hold_the_seam_and_the_wall() {
        let mesh = strip(4);
        let in_patch = [false, true, true, false];
        let t = targets(&mesh, &in_patch, false);
        // nodes of cells 1 and 2: x = 1, 2, 3 (indices 2..=7)
        let inside: Vec<usize> = (0..mesh.nodes.len()).filter(|&v| t.inside[v]).collect();
        assert_eq!(inside, vec![2, 3, 4, 5, 6, 7]);
        // the seams at x = 1 and x = 3 are held, and the wall facet's node
        // at x = 2 (node 4) inside the patch; node 5 above it is free
        let held: Vec<usize> = (0..mesh.nodes.len()).filter(|&v| t.targets[v].is_some()).collect();
        assert_eq!(held, vec![2, 3, 4, 6, 7]);
        // sliding, the wall's node inside the patch is free to glide
        let t = targets(&mesh, &in_patch, true);
        let held: Vec<usize> = (0..mesh.nodes.len()).filter(|&v| t.targets[v].is_some()).collect();
        assert_eq!(held, vec![2, 3, 6, 7]);
    }

    #[test]
    fn least_is_none_when_one_is_invalid() {
        let cert = |valid: bool, s: f64| Certificate { valid, min_det_lower: s, min_det_upper: s, max_det: 1.0, max_det_attained: 1.0, min_det_sampled: s, min_scaled_jacobian: s, splits: 0 };
        let (good, low, bad) = (cert(true, 0.5), cert(true, 0.25), cert(false, -0.1));
        assert_eq!(least([good, low].into_iter()), Some(0.25));
        assert_eq!(least([good, bad, low].into_iter()), None);
    }
}
