//! The 2D boundary model: the boundary of a quad mesh split into chains
//! of edges between feature nodes (corners, junctions of parts), each
//! parametrised by arc length of its starting position.

use super::{BoundaryModel, BoundaryPart, Correspondence, DeformError, MoveMode, PartKind, Q1Mesh};
use crate::jacobian::edge_flux_points;
use crate::lsfem::NodeConstraint;
use crate::mesh::{PlaneMesh, Point2};

/// A maximal run of boundary edges of one part between feature nodes,
/// parametrised by normalised arc length s ∈ [0, 1] of its start position.
#[derive(Clone, Debug)]
struct Chain {
    part: usize,
    /// Starting positions of the chain's vertices, in order.
    points: Vec<Point2>,
    /// Cumulative normalised arc length at each vertex.
    s: Vec<f64>,
}

impl Chain {
    /// P₀(s): the starting position at parameter s (piecewise linear).
    /// Outside [0, 1] the end segments are extended: a slip wall goes on
    /// beyond the starting domain, which may grow.
    fn start(&self, s: f64) -> Point2 {
        let k = match self.s.binary_search_by(|v| v.total_cmp(&s)) {
            Ok(k) => return self.points[k],
            Err(k) => k.clamp(1, self.s.len() - 1),
        };
        let (a, b) = (self.points[k - 1], self.points[k]);
        let w = (s - self.s[k - 1]) / (self.s[k] - self.s[k - 1]);
        [a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1])]
    }
}

/// What a node does.
#[derive(Clone, Copy, Debug)]
pub enum Role {
    Interior,
    /// Inside a chain, at parameter s.
    Chain { chain: usize, s: f64 },
    /// A feature node: follows the path of a moving chain's end, or stays.
    Corner { path: Option<(usize, f64)> },
}

/// The 2D boundary: parts, chains, and every node's role.
#[derive(Clone, Debug)]
pub struct Chains {
    parts: Vec<BoundaryPart>,
    chains: Vec<Chain>,
    roles: Vec<Role>,
    /// Node positions at t = 0.
    start: Vec<Point2>,
}

impl Chains {
    /// v = X(P₀(s)) − P₀(s) on a moving chain: the (constant) velocity of
    /// the boundary point with parameter s.
    fn chain_velocity(&self, chain: usize, s: f64) -> Option<Point2> {
        let c = &self.chains[chain];
        let p = c.start(s);
        let x = self.image(c.part, p)?;
        Some([x[0] - p[0], x[1] - p[1]])
    }

    /// Γ_t(s) of a moving chain.
    fn chain_point(&self, chain: usize, s: f64, t: f64) -> Point2 {
        let p = self.chains[chain].start(s);
        match self.chain_velocity(chain, s) {
            Some(v) => [p[0] + t * v[0], p[1] + t * v[1]],
            None => p,
        }
    }

    /// The target image X(p) of a starting point on a moving part.
    fn image(&self, part: usize, p: Point2) -> Option<Point2> {
        self.parts[part].image(p)
    }

    /// Every point of a moving chain must have an image on the target,
    /// and the images must run along the target without folding back or
    /// jumping (a closest-point map does both behind a centre of
    /// curvature) — else the boundary itself would tangle.
    fn check_reachable(&self) -> Result<(), DeformError> {
        const PER_EDGE: usize = 8;
        for c in &self.chains {
            let part = &self.parts[c.part];
            let PartKind::Move { correspondence, .. } = part.kind else { continue };
            let fail = |why: String| DeformError::Unreachable { part: part.name.clone(), why };
            let samples: Vec<f64> = c
                .s
                .windows(2)
                .flat_map(|w| (0..PER_EDGE).map(move |j| w[0] + (w[1] - w[0]) * j as f64 / PER_EDGE as f64))
                .chain(std::iter::once(1.0))
                .collect();
            let mut images = Vec::with_capacity(samples.len());
            for &s in &samples {
                let p = c.start(s);
                let Some(x) = self.image(c.part, p) else {
                    return Err(fail(match correspondence {
                        Correspondence::Radial { centre } => format!(
                            "the ray from the centre ({}, {}) through the boundary point ({:.6}, {:.6}) misses the target shape",
                            centre[0], centre[1], p[0], p[1]
                        ),
                        Correspondence::Normal => format!("no closest point on the target for ({:.6}, {:.6})", p[0], p[1]),
                        Correspondence::Along { direction } => format!(
                            "the line through the boundary point ({:.6}, {:.6}) along ({}, {}) misses the target shape",
                            p[0], p[1], direction[0], direction[1]
                        ),
                    }));
                };
                images.push(x);
            }
            let steps: Vec<Point2> = images.windows(2).map(|w| [w[1][0] - w[0][0], w[1][1] - w[0][1]]).collect();
            let mut lengths: Vec<f64> = steps.iter().map(|d| d[0].hypot(d[1])).collect();
            for (j, w) in steps.windows(2).enumerate() {
                if w[0][0] * w[1][0] + w[0][1] * w[1][1] < 0.0 {
                    let p = c.start(samples[j + 1]);
                    return Err(fail(format!(
                        "the {} correspondence folds back near the boundary point ({:.6}, {:.6}): its images on the target reverse direction (try correspondence = \"radial\" with a centre)",
                        match correspondence {
                            Correspondence::Normal => "closest-point",
                            Correspondence::Radial { .. } => "radial",
                            Correspondence::Along { .. } => "along-a-direction",
                        },
                        p[0],
                        p[1]
                    )));
                }
            }
            let total: f64 = lengths.iter().sum();
            lengths.sort_by(f64::total_cmp);
            let median = lengths[lengths.len() / 2];
            if let Some(j) = steps.iter().position(|d| d[0].hypot(d[1]) > 50.0 * median.max(1e-3 * total / steps.len() as f64)) {
                let p = c.start(samples[j]);
                return Err(fail(format!(
                    "the correspondence jumps near the boundary point ({:.6}, {:.6}): neighbouring points land far apart on the target (try correspondence = \"radial\" with a centre)",
                    p[0], p[1]
                )));
            }
        }
        Ok(())
    }

    /// The nodal boundary velocity v (constant in t along each path).
    fn velocities_impl(&self, out: &mut [Point2]) {
        for (i, role) in self.roles.iter().enumerate() {
            out[i] = match *role {
                Role::Chain { chain, s } => self.chain_velocity(chain, s).unwrap_or([0.0; 2]),
                Role::Corner { path: Some((chain, s)) } => self.chain_velocity(chain, s).unwrap_or([0.0; 2]),
                _ => [0.0; 2],
            };
        }
    }

    /// Outward unit normal of Γ_t at s on a chain (slip walls: of the wall).
    fn chain_normal(&self, chain: usize, s: f64, t: f64, at: Point2) -> Point2 {
        if let PartKind::Slip { wall: Some(w) } = &self.parts[self.chains[chain].part].kind {
            let n = w.normal(at);
            return self.orient_outward(chain, s, n);
        }
        let hs = 1e-6;
        // a moving chain ends at its corners; a slip wall extends beyond
        let (a, b) = match self.parts[self.chains[chain].part].kind {
            PartKind::Move { .. } => ((s - hs).max(0.0), (s + hs).min(1.0)),
            _ => (s - hs, s + hs),
        };
        let (pa, pb) = (self.chain_point(chain, a, t), self.chain_point(chain, b, t));
        // chains run with the domain on their left: outward is the right
        let mut tan = [pb[0] - pa[0], pb[1] - pa[1]];
        if tan[0] == 0.0 && tan[1] == 0.0 {
            // Γ_t collapses here: fall back on the starting chain's direction
            let c = &self.chains[chain];
            let (qa, qb) = (c.start(a), c.start(b));
            tan = [qb[0] - qa[0], qb[1] - qa[1]];
        }
        let len = tan[0].hypot(tan[1]);
        [tan[1] / len, -tan[0] / len]
    }

    /// Flips a shape's normal to point out of the domain (as the chain does).
    fn orient_outward(&self, chain: usize, s: f64, n: Point2) -> Point2 {
        let c = &self.chains[chain];
        let (a, b) = (c.start(s - 1e-6), c.start(s + 1e-6));
        let out = [b[1] - a[1], -(b[0] - a[0])];
        if out[0] * n[0] + out[1] * n[1] < 0.0 {
            [-n[0], -n[1]]
        } else {
            n
        }
    }

    /// The constraint of every node at time t for positions `nodes`, with
    /// prescribed values divided by f (`f(i)` at node i).
    fn fill_constraints_impl(&self, t: f64, nodes: &[Point2], f: impl Fn(usize) -> f64, out: &mut [NodeConstraint]) {
        for i in 0..self.roles.len() {
            let x = nodes[i];
            out[i] = match self.roles[i] {
                Role::Interior => NodeConstraint::free(),
                Role::Corner { path } => {
                    let v = path.and_then(|(c, s)| self.chain_velocity(c, s)).unwrap_or([0.0; 2]);
                    NodeConstraint::fixed([v[0] / f(i), v[1] / f(i)])
                }
                Role::Chain { chain, s } => match &self.parts[self.chains[chain].part].kind {
                    PartKind::Fixed => NodeConstraint::fixed([0.0; 2]),
                    PartKind::Slip { .. } => NodeConstraint::normal(self.chain_normal(chain, s, t, x), 0.0),
                    PartKind::Move { mode: MoveMode::Dirichlet, .. } => {
                        let v = self.chain_velocity(chain, s).unwrap_or([0.0; 2]);
                        NodeConstraint::fixed([v[0] / f(i), v[1] / f(i)])
                    }
                    PartKind::Move { mode: MoveMode::Sliding, .. } => {
                        let v = self.chain_velocity(chain, s).unwrap_or([0.0; 2]);
                        let n = self.chain_normal(chain, s, t, x);
                        NodeConstraint::normal(n, (v[0] * n[0] + v[1] * n[1]) / f(i))
                    }
                },
            };
        }
    }

    /// Puts boundary nodes back exactly onto Γ_t (moving parts), onto their
    /// wall (slip) or their path (Dirichlet nodes and corners).
    fn put_back_impl(&mut self, nodes: &mut [Point2], t: f64) {
        for i in 0..self.roles.len() {
            match self.roles[i] {
                Role::Interior => {}
                Role::Corner { path } => {
                    nodes[i] = match path {
                        Some((c, s)) => self.chain_point(c, s, t),
                        None => self.start[i],
                    };
                }
                Role::Chain { chain, s } => {
                    let (p, s_new) = match &self.parts[self.chains[chain].part].kind {
                        PartKind::Fixed => (self.start[i], s),
                        PartKind::Move { mode: MoveMode::Dirichlet, .. } => (self.chain_point(chain, s, t), s),
                        PartKind::Slip { wall: Some(w) } => (w.closest_point(nodes[i]), s),
                        PartKind::Slip { wall: None } => self.project_on_chain(chain, s, nodes[i], 0.0, None),
                        PartKind::Move { mode: MoveMode::Sliding, .. } => self.project_on_chain(chain, s, nodes[i], t, Some((0.0, 1.0))),
                    };
                    nodes[i] = p;
                    self.roles[i] = Role::Chain { chain, s: s_new };
                }
            }
        }
    }

    /// The point of Γ_t closest to x, by Gauss–Newton on s from `s0`,
    /// with s kept within `bounds` if given.
    fn project_on_chain(&self, chain: usize, s0: f64, x: Point2, t: f64, bounds: Option<(f64, f64)>) -> (Point2, f64) {
        let (lo, hi) = bounds.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
        let mut s = s0;
        let hs = 1e-7;
        for _ in 0..30 {
            let p = self.chain_point(chain, s, t);
            let (a, b) = ((s - hs).max(lo), (s + hs).min(hi));
            let (pa, pb) = (self.chain_point(chain, a, t), self.chain_point(chain, b, t));
            let d = [(pb[0] - pa[0]) / (b - a), (pb[1] - pa[1]) / (b - a)];
            let dd = d[0] * d[0] + d[1] * d[1];
            if !(dd > 0.0) {
                break; // the curve collapses here: keep the last parameter
            }
            let step = ((x[0] - p[0]) * d[0] + (x[1] - p[1]) * d[1]) / dd;
            let s_new = (s + step).clamp(lo, hi);
            let done = (s_new - s).abs() < 1e-15;
            s = s_new;
            if done {
                break;
            }
        }
        (self.chain_point(chain, s, t), s)
    }

    /// For each node on a moving part, its distance to the target shape.
    fn distances_impl(&self, nodes: &[Point2]) -> Vec<(usize, f64)> {
        let mut out = Vec::new();
        for (i, role) in self.roles.iter().enumerate() {
            let part = match *role {
                Role::Chain { chain, .. } => self.chains[chain].part,
                Role::Corner { path: Some((chain, _)) } => self.chains[chain].part,
                _ => continue,
            };
            if let PartKind::Move { target, .. } = &self.parts[part].kind {
                out.push((i, target.distance(nodes[i])));
            }
        }
        out
    }

}

impl Chains {
    /// A corner between two moving chains follows the first one's path:
    /// refuse it unless that ends on the other's target too.
    fn check_meetings(&self) -> Result<(), DeformError> {
        for (i, role) in self.roles.iter().enumerate() {
            let Role::Corner { path: Some((first, _)) } = *role else { continue };
            let a = self.chains[first].part;
            let x = self.start[i];
            for c in self.chains.iter().filter(|c| c.part != a && (c.points[0] == x || c.points[c.points.len() - 1] == x)) {
                let h = c.points.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).fold(f64::INFINITY, f64::min);
                super::check_meeting(&self.parts, a, c.part, x, h)?;
            }
        }
        Ok(())
    }
}

/// Splits the boundary into chains and gives every node its role.
fn classify<const N: usize>(mesh: &PlaneMesh<N>, parts: &[BoundaryPart]) -> (Vec<Chain>, Vec<Role>) {
    let n = mesh.num_nodes();
    // per node, outgoing and incoming edge (per part) to walk chains
    let mut next: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n]; // (part, to)
    let mut prev_count = vec![0usize; n];
    for e in &mesh.edges {
        next[e.nodes[0]].push((e.part, e.nodes[1]));
        prev_count[e.nodes[1]] += 1;
    }
    let node_parts = mesh.node_parts();
    let is_feature = |i: usize| -> bool {
        if node_parts[i].len() > 1 || next[i].len() != 1 || prev_count[i] != 1 {
            return true;
        }
        // a sharp turn of the starting boundary (a box corner)
        let incoming = mesh.edges.iter().find(|e| e.nodes[1] == i).map(|e| e.nodes[0]);
        match incoming {
            Some(a) => {
                let (p, q, r) = (mesh.nodes[a], mesh.nodes[i], mesh.nodes[next[i][0].1]);
                let (u, v) = ([q[0] - p[0], q[1] - p[1]], [r[0] - q[0], r[1] - q[1]]);
                let cos = (u[0] * v[0] + u[1] * v[1]) / (u[0].hypot(u[1]) * v[0].hypot(v[1]));
                cos < (30f64).to_radians().cos()
            }
            None => true,
        }
    };
    let feature: Vec<bool> = (0..n).map(|i| !node_parts[i].is_empty() && is_feature(i)).collect();
    let mut roles = vec![Role::Interior; n];
    let mut chains: Vec<Chain> = Vec::new();
    let mut used = vec![false; mesh.edges.len()];
    let edge_from: std::collections::HashMap<(usize, usize), usize> =
        mesh.edges.iter().enumerate().map(|(k, e)| ((e.nodes[0], e.part), k)).collect();
    // walk from every feature node along each outgoing edge; then closed
    // loops without features start at their first node
    let mut starts: Vec<usize> = (0..n).filter(|&i| feature[i]).collect();
    starts.extend(mesh.edges.iter().map(|e| e.nodes[0]));
    let mut loop_feature = feature.clone();
    for start in starts {
        for &(part, _) in next[start].clone().iter() {
            let Some(&k0) = edge_from.get(&(start, part)) else { continue };
            if used[k0] {
                continue;
            }
            loop_feature[start] = true;
            let mut nodes_in = vec![start];
            let mut k = k0;
            loop {
                used[k] = true;
                let to = mesh.edges[k].nodes[1];
                nodes_in.push(to);
                if loop_feature[to] {
                    break;
                }
                match edge_from.get(&(to, part)) {
                    Some(&kn) if !used[kn] => k = kn,
                    _ => break,
                }
            }
            let points: Vec<Point2> = nodes_in.iter().map(|&i| mesh.nodes[i]).collect();
            let mut s = vec![0.0];
            for w in points.windows(2) {
                s.push(s.last().unwrap() + (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]));
            }
            let total = *s.last().unwrap();
            s.iter_mut().for_each(|v| *v /= total);
            let id = chains.len();
            for (j, &node) in nodes_in.iter().enumerate() {
                if j == 0 || j + 1 == nodes_in.len() {
                    // chain ends are corners; prefer the path of a moving chain
                    let moving = matches!(parts[part].kind, PartKind::Move { .. });
                    let here = Some((id, s[j]));
                    roles[node] = match roles[node] {
                        Role::Corner { path: Some(p) } => Role::Corner { path: Some(p) },
                        _ => Role::Corner { path: if moving { here } else { None } },
                    };
                } else {
                    roles[node] = Role::Chain { chain: id, s: s[j] };
                }
            }
            chains.push(Chain { part, points, s });
        }
    }
    (chains, roles)
}

impl BoundaryModel<2> for Chains {
    type State = Vec<Role>;

    fn parts(&self) -> &[BoundaryPart] {
        &self.parts
    }
    fn velocities(&self, out: &mut [Point2]) {
        self.velocities_impl(out)
    }
    fn fill_constraints(&self, t: f64, nodes: &[Point2], f: impl Fn(usize) -> f64, out: &mut [NodeConstraint]) {
        self.fill_constraints_impl(t, nodes, f, out)
    }
    fn put_back(&mut self, nodes: &mut [Point2], t: f64) {
        self.put_back_impl(nodes, t)
    }
    fn distances(&self, nodes: &[Point2]) -> Vec<(usize, f64)> {
        self.distances_impl(nodes)
    }
    fn state(&self) -> &Vec<Role> {
        &self.roles
    }
    fn state_mut(&mut self) -> &mut Vec<Role> {
        &mut self.roles
    }
}

/// The boundary model works on the edges alone, so quads and triangles
/// share it.
impl<const N: usize> Q1Mesh<2, N> for PlaneMesh<N> {
    type Boundary = Chains;

    fn cells(&self) -> &[[usize; N]] {
        &self.cells
    }
    fn nodes(&self) -> &[Point2] {
        &self.nodes
    }
    fn nodes_mut(&mut self) -> &mut Vec<Point2> {
        &mut self.nodes
    }
    fn flux_points<'a>(&'a self, nodes: &'a [Point2], v: &'a [Point2]) -> impl Iterator<Item = (Point2, f64)> + 'a {
        edge_flux_points(self, nodes, v)
    }
    fn measure(&self) -> f64 {
        self.area()
    }
    fn boundary(&self, parts: Vec<BoundaryPart>) -> Result<Chains, DeformError> {
        let (chains, roles) = classify(self, &parts);
        let b = Chains { parts, chains, roles, start: self.nodes.clone() };
        b.check_reachable()?;
        b.check_meetings()?;
        Ok(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ShapeSpec;
    use std::sync::Arc;

    /// The sides `right` and `top` of the unit square moved onto two
    /// circles: the corner (1, 1) cannot follow both. Refused, naming both
    /// groups; with one circle (bound twice) accepted.
    #[test]
    fn two_moving_parts_meeting_at_a_corner() {
        let mesh = crate::mesh::QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 3, 3);
        let circle = |centre: [f64; 2], radius: f64| -> Arc<dyn super::super::BoundaryShape<2>> { Arc::new(ShapeSpec::Circle { centre, radius }.build().unwrap()) };
        let parts_with = |a: Arc<dyn super::super::BoundaryShape<2>>, b: Arc<dyn super::super::BoundaryShape<2>>| -> Vec<BoundaryPart> {
            crate::mesh::BOX_SIDES
                .iter()
                .map(|&name| {
                    let kind = match name {
                        "right" => PartKind::Move { target: a.clone(), correspondence: Correspondence::Normal, mode: MoveMode::Sliding },
                        "top" => PartKind::Move { target: b.clone(), correspondence: Correspondence::Normal, mode: MoveMode::Sliding },
                        _ => PartKind::Fixed,
                    };
                    BoundaryPart::new(name, kind)
                })
                .collect()
        };
        let e = mesh.boundary(parts_with(circle([0.0, 0.5], 1.2), circle([0.5, 0.0], 1.3))).err().expect("refused").to_string();
        assert!(e.contains("`right`") && e.contains("`top`") && e.contains("not supported"), "{e}");
        let one = circle([0.5, 0.5], 0.8);
        assert!(mesh.boundary(parts_with(one.clone(), one)).is_ok());
    }
}
