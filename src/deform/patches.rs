//! The 3D boundary model: the boundary faces (quads or triangles) of a
//! hex or tetrahedral mesh grouped into planar patches (one per box face
//! and part), the feature edges where two patches meet, and the corners
//! where three or more meet.
//!
//! - A node inside a patch is constrained like a 2D chain node: `u·n = 0`
//!   on a slip wall, `u·n = v·n/f` on a sliding moving patch, `u = v/f`
//!   with Dirichlet data. The moving patch is the blend
//!   `Γ_t(s) = (1−t) P₀(s) + t X(P₀(s))` of its starting plane P₀ and the
//!   image X on the target.
//! - A node on an edge glides along the edge's curve `C_t(σ)`: the image
//!   of the starting edge under a moving neighbour patch's blend (or the
//!   static line between two walls). Its two components across the curve
//!   follow the curve's velocity, the one along it is free. This stays
//!   well posed where the two patches land on one smooth target (the cube
//!   edges of the quarter ball), where two normal constraints would
//!   become parallel.
//! - A corner follows the path `(1−t) x₀ + t X(x₀)` or stays.

use super::{BoundaryModel, BoundaryPart, DeformError, MoveMode, PartKind, Q1Mesh};
use crate::jacobian::facet_flux_points;
use crate::lsfem::Constraint;
use crate::mesh::{Point3, SolidMesh};
use crate::numeric::{cross3 as cross, dot, sub, unit};
use crate::quality::cell_size;
use std::collections::HashMap;

/// A planar patch of boundary faces of one part, with its affine
/// parametrisation P₀(s) = origin + s₀ e₁ + s₁ e₂ (e₁ × e₂ = outward n).
#[derive(Clone, Debug)]
struct Patch {
    part: usize,
    origin: Point3,
    e: [Point3; 2],
    normal: Point3,
    /// The parameter rectangle covered by the patch's starting nodes.
    lo: [f64; 2],
    hi: [f64; 2],
}

impl Patch {
    fn start(&self, s: [f64; 2]) -> Point3 {
        std::array::from_fn(|i| self.origin[i] + s[0] * self.e[0][i] + s[1] * self.e[1][i])
    }

    fn param(&self, x: Point3) -> [f64; 2] {
        let d = sub(x, self.origin);
        [dot(d, self.e[0]), dot(d, self.e[1])]
    }
}

/// A straight starting edge between two patches, parametrised by σ.
#[derive(Clone, Debug)]
struct Edge {
    a: Point3,
    b: Point3,
    patches: [usize; 2],
    /// The moving patch whose blend carries the edge, if any.
    carrier: Option<usize>,
}

impl Edge {
    fn start(&self, sigma: f64) -> Point3 {
        std::array::from_fn(|i| self.a[i] + sigma * (self.b[i] - self.a[i]))
    }
}

/// What a node does.
#[derive(Clone, Copy, Debug)]
pub enum Role3 {
    /// Not on the boundary.
    Interior,
    /// Inside a patch at parameter s.
    Face {
        /// The patch.
        patch: usize,
        /// Its parameter.
        s: [f64; 2],
    },
    /// On an edge at parameter σ.
    Edge {
        /// The edge.
        edge: usize,
        /// Its parameter.
        sigma: f64,
    },
    /// Where three or more patches meet: follows the path of a moving
    /// part (its index) or stays.
    Corner {
        /// The moving part whose path it follows.
        part: Option<usize>,
    },
}

/// The 3D boundary: parts, patches, edges, every node's role.
pub struct Patches {
    parts: Vec<BoundaryPart<3>>,
    patches: Vec<Patch>,
    edges: Vec<Edge>,
    roles: Vec<Role3>,
    start: Vec<Point3>,
}

impl Patches {
    fn kind(&self, patch: usize) -> &PartKind<3> {
        &self.parts[self.patches[patch].part].kind
    }

    fn is_moving(&self, patch: usize) -> bool {
        matches!(self.kind(patch), PartKind::Move { .. })
    }

    /// v = X(p) − p for a starting point p of a moving part (0 otherwise).
    fn velocity_of(&self, part: usize, p: Point3) -> Point3 {
        self.parts[part].image(p).map_or([0.0; 3], |x| sub(x, p))
    }

    /// The velocity of corner node i on the path of `part` (0 if none).
    fn corner_velocity(&self, i: usize, part: Option<usize>) -> Point3 {
        part.map_or([0.0; 3], |p| self.velocity_of(p, self.start[i]))
    }

    /// Γ_t(s) of a patch (its starting plane if it does not move).
    fn patch_point(&self, patch: usize, s: [f64; 2], t: f64) -> Point3 {
        let p = self.patches[patch].start(s);
        let v = self.velocity_of(self.patches[patch].part, p);
        std::array::from_fn(|i| p[i] + t * v[i])
    }

    /// C_t(σ) of an edge.
    fn edge_point(&self, edge: usize, sigma: f64, t: f64) -> Point3 {
        let e = &self.edges[edge];
        let p = e.start(sigma);
        let v = e.carrier.map_or([0.0; 3], |c| self.velocity_of(self.patches[c].part, p));
        std::array::from_fn(|i| p[i] + t * v[i])
    }

    fn edge_velocity(&self, edge: usize, sigma: f64) -> Point3 {
        let e = &self.edges[edge];
        e.carrier.map_or([0.0; 3], |c| self.velocity_of(self.patches[c].part, e.start(sigma)))
    }

    /// Outward unit normal of Γ_t at s (of the wall for a slip patch).
    fn patch_normal(&self, patch: usize, s: [f64; 2], t: f64, at: Point3) -> Point3 {
        let pn = self.patches[patch].normal;
        match self.kind(patch) {
            PartKind::Slip { wall: Some(w) } => {
                let n = w.normal(at);
                if dot(n, pn) < 0.0 { n.map(|c| -c) } else { n }
            }
            PartKind::Move { .. } => {
                let h = 1e-6;
                let d: [Point3; 2] = std::array::from_fn(|k| {
                    let (mut a, mut b) = (s, s);
                    a[k] -= h;
                    b[k] += h;
                    sub(self.patch_point(patch, b, t), self.patch_point(patch, a, t))
                });
                let n = cross(d[0], d[1]);
                // where Γ_t degenerates, the starting plane's normal
                if dot(n, n) > 0.0 { unit(n) } else { pn }
            }
            _ => pn,
        }
    }

    /// Unit tangent of C_t at σ.
    fn edge_tangent(&self, edge: usize, sigma: f64, t: f64) -> Point3 {
        let h = 1e-6;
        unit(sub(self.edge_point(edge, sigma + h, t), self.edge_point(edge, sigma - h, t)))
    }

    /// Closest parameter of Γ_t to x, by Gauss–Newton from s0, kept in
    /// the patch's rectangle when it moves.
    fn project_on_patch(&self, patch: usize, s0: [f64; 2], x: Point3, t: f64) -> [f64; 2] {
        let p = &self.patches[patch];
        let bounded = self.is_moving(patch);
        let mut s = s0;
        for _ in 0..30 {
            let g = self.patch_point(patch, s, t);
            let h = 1e-7;
            let d: [Point3; 2] = std::array::from_fn(|k| {
                let (mut a, mut b) = (s, s);
                a[k] -= h;
                b[k] += h;
                sub(self.patch_point(patch, b, t), self.patch_point(patch, a, t)).map(|c| c / (2.0 * h))
            });
            let r = sub(x, g);
            let (a11, a12, a22) = (dot(d[0], d[0]), dot(d[0], d[1]), dot(d[1], d[1]));
            let (b1, b2) = (dot(d[0], r), dot(d[1], r));
            let det = a11 * a22 - a12 * a12;
            if !(det > 0.0) {
                break; // Γ_t degenerates here: keep the last parameter
            }
            let step = [(a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det];
            let mut next = [s[0] + step[0], s[1] + step[1]];
            if bounded {
                next = std::array::from_fn(|k| next[k].clamp(p.lo[k], p.hi[k]));
            }
            let done = (next[0] - s[0]).abs().max((next[1] - s[1]).abs()) < 1e-15 * (1.0 + s[0].abs() + s[1].abs());
            s = next;
            if done {
                break;
            }
        }
        s
    }

    /// Closest parameter of C_t to x, by Gauss–Newton from σ0.
    fn project_on_edge(&self, edge: usize, sigma0: f64, x: Point3, t: f64) -> f64 {
        let bounded = self.edges[edge].carrier.is_some();
        let mut sigma = sigma0;
        for _ in 0..30 {
            let h = 1e-7;
            let d = sub(self.edge_point(edge, sigma + h, t), self.edge_point(edge, sigma - h, t)).map(|c| c / (2.0 * h));
            let r = sub(x, self.edge_point(edge, sigma, t));
            if !(dot(d, d) > 0.0) {
                break;
            }
            let mut next = sigma + dot(d, r) / dot(d, d);
            if bounded {
                next = next.clamp(0.0, 1.0);
            }
            let done = (next - sigma).abs() < 1e-15;
            sigma = next;
            if done {
                break;
            }
        }
        sigma
    }

    /// Every starting node and face centre of a moving part must have an
    /// image on its target.
    fn check_reachable<const N: usize, const K: usize>(&self, mesh: &SolidMesh<N, K>) -> Result<(), DeformError> {
        for f in &mesh.faces {
            let part = &self.parts[f.part];
            if !matches!(part.kind, PartKind::Move { .. }) {
                continue;
            }
            let pts = f.nodes.map(|n| mesh.nodes[n]);
            let centre: Point3 = std::array::from_fn(|i| pts.iter().map(|p| p[i]).sum::<f64>() / K as f64);
            for p in pts.into_iter().chain(std::iter::once(centre)) {
                if part.image(p).is_none() {
                    return Err(DeformError::Unreachable {
                        part: part.name.clone(),
                        why: format!(
                            "the target cannot be reached from the boundary point ({:.6}, {:.6}, {:.6}) by the chosen correspondence (a ray that misses, or a centre outside the box?)",
                            p[0], p[1], p[2]
                        ),
                    });
                }
            }
        }
        Ok(())
    }

    fn constraint(&self, i: usize, t: f64, x: Point3, f: f64) -> Constraint<3> {
        match self.roles[i] {
            Role3::Interior => Constraint::free(),
            Role3::Corner { part } => {
                let v = self.corner_velocity(i, part);
                Constraint::fixed(v.map(|c| c / f))
            }
            Role3::Face { patch, s } => match self.kind(patch) {
                PartKind::Fixed => Constraint::fixed([0.0; 3]),
                PartKind::Slip { .. } => Constraint::<3>::normal(self.patch_normal(patch, s, t, x), 0.0),
                PartKind::Move { mode: MoveMode::Dirichlet, .. } => {
                    let v = self.velocity_of(self.patches[patch].part, self.patches[patch].start(s));
                    Constraint::fixed(v.map(|c| c / f))
                }
                PartKind::Move { mode: MoveMode::Sliding, .. } => {
                    let v = self.velocity_of(self.patches[patch].part, self.patches[patch].start(s));
                    let n = self.patch_normal(patch, s, t, x);
                    Constraint::<3>::normal(n, dot(v, n) / f)
                }
            },
            Role3::Edge { edge, sigma } => {
                let v = self.edge_velocity(edge, sigma).map(|c| c / f);
                if self.edge_is_fixed(edge) {
                    Constraint::fixed(v)
                } else {
                    Constraint::<3>::along(self.edge_tangent(edge, sigma, t), v)
                }
            }
        }
    }

    /// An edge next to a fixed part, or carried with Dirichlet data,
    /// follows its path instead of gliding.
    fn edge_is_fixed(&self, edge: usize) -> bool {
        self.edges[edge].patches.iter().any(|&p| matches!(self.kind(p), PartKind::Fixed | PartKind::Move { mode: MoveMode::Dirichlet, .. }))
    }
}

impl BoundaryModel<3> for Patches {
    type State = Vec<Role3>;

    fn parts(&self) -> &[BoundaryPart<3>] {
        &self.parts
    }

    fn velocities(&self, out: &mut [Point3]) {
        for (i, role) in self.roles.iter().enumerate() {
            out[i] = match *role {
                Role3::Interior => [0.0; 3],
                Role3::Face { patch, s } => self.velocity_of(self.patches[patch].part, self.patches[patch].start(s)),
                Role3::Edge { edge, sigma } => self.edge_velocity(edge, sigma),
                Role3::Corner { part } => self.corner_velocity(i, part),
            };
        }
    }

    fn fill_constraints(&self, t: f64, nodes: &[Point3], f: impl Fn(usize) -> f64, out: &mut [Constraint<3>]) {
        for i in 0..self.roles.len() {
            out[i] = self.constraint(i, t, nodes[i], f(i));
        }
    }

    fn put_back(&mut self, nodes: &mut [Point3], t: f64) {
        for i in 0..self.roles.len() {
            match self.roles[i] {
                Role3::Interior => {}
                Role3::Corner { part } => {
                    let v = self.corner_velocity(i, part);
                    nodes[i] = std::array::from_fn(|k| self.start[i][k] + t * v[k]);
                }
                Role3::Face { patch, s } => {
                    let (p, s) = match self.kind(patch) {
                        PartKind::Fixed => (self.start[i], s),
                        PartKind::Move { mode: MoveMode::Dirichlet, .. } => (self.patch_point(patch, s, t), s),
                        PartKind::Slip { wall: Some(w) } => (w.closest_point(nodes[i]), s),
                        PartKind::Slip { wall: None } => {
                            let s = self.patches[patch].param(nodes[i]);
                            (self.patches[patch].start(s), s)
                        }
                        PartKind::Move { mode: MoveMode::Sliding, .. } => {
                            let s = self.project_on_patch(patch, s, nodes[i], t);
                            (self.patch_point(patch, s, t), s)
                        }
                    };
                    nodes[i] = p;
                    self.roles[i] = Role3::Face { patch, s };
                }
                Role3::Edge { edge, sigma } if self.edge_is_fixed(edge) => {
                    // on its path from its exact start
                    let v = self.edge_velocity(edge, sigma);
                    nodes[i] = std::array::from_fn(|k| self.start[i][k] + t * v[k]);
                }
                Role3::Edge { edge, sigma } => {
                    let sigma = self.project_on_edge(edge, sigma, nodes[i], t);
                    nodes[i] = self.edge_point(edge, sigma, t);
                    self.roles[i] = Role3::Edge { edge, sigma };
                }
            }
        }
    }

    fn distances(&self, nodes: &[Point3]) -> Vec<(usize, f64)> {
        let mut out = Vec::new();
        for (i, role) in self.roles.iter().enumerate() {
            let part = match *role {
                Role3::Face { patch, .. } => Some(self.patches[patch].part),
                Role3::Edge { edge, .. } => self.edges[edge].carrier.map(|c| self.patches[c].part),
                Role3::Corner { part } => part,
                Role3::Interior => None,
            };
            if let Some(PartKind::Move { target, .. }) = part.map(|p| &self.parts[p].kind) {
                out.push((i, target.distance(nodes[i])));
            }
        }
        out
    }

    fn state(&self) -> &Vec<Role3> {
        &self.roles
    }

    fn state_mut(&mut self) -> &mut Vec<Role3> {
        &mut self.roles
    }
}

/// Hexahedral and tetrahedral meshes alike: Algorithm 1's patches from
/// their boundary quads or triangles (`curve` builds Algorithm 2's
/// boundary model on the refined mesh, [`crate::refine`]).
impl<const N: usize, const K: usize> Q1Mesh<3, N> for SolidMesh<N, K> {
    type Boundary = Patches;

    fn cells(&self) -> &[[usize; N]] {
        &self.cells
    }

    fn nodes(&self) -> &[Point3] {
        &self.nodes
    }

    fn nodes_mut(&mut self) -> &mut Vec<Point3> {
        &mut self.nodes
    }

    fn flux_points<'a>(&'a self, nodes: &'a [Point3], v: &'a [Point3]) -> impl Iterator<Item = (Point3, f64)> + 'a {
        facet_flux_points(self.faces.iter().map(|f| f.nodes), nodes, v)
    }

    fn measure(&self) -> f64 {
        (0..self.num_cells()).map(|c| cell_size(&self.cell_coords(c))).sum()
    }

    fn boundary(&self, parts: Vec<BoundaryPart<3>>) -> Result<Patches, DeformError> {
        let b = classify(self, parts)?;
        b.check_reachable(self)?;
        Ok(b)
    }
}

/// Groups faces into planar patches, finds edges and corners, and gives
/// every node its role.
fn classify<const N: usize, const K: usize>(mesh: &SolidMesh<N, K>, parts: Vec<BoundaryPart<3>>) -> Result<Patches, DeformError> {
    let face_patch = group_faces(mesh);
    let mut patches: Vec<Patch> = Vec::new();
    let npatch = face_patch.iter().copied().max().map_or(0, |m| m + 1);
    for p in 0..npatch {
        let faces: Vec<usize> = (0..mesh.faces.len()).filter(|&f| face_patch[f] == p).collect();
        patches.push(planar_patch(mesh, &faces, &parts)?);
    }
    let node_patches = node_patches(&mesh.faces, &face_patch, mesh.num_nodes());
    let mut edges: Vec<Edge> = Vec::new();
    let mut edge_of: HashMap<[usize; 2], usize> = HashMap::new();
    let mut roles = vec![Role3::Interior; mesh.num_nodes()];
    for i in 0..mesh.num_nodes() {
        let ps = &node_patches[i];
        roles[i] = match ps.len() {
            0 => Role3::Interior,
            1 => Role3::Face { patch: ps[0], s: patches[ps[0]].param(mesh.nodes[i]) },
            2 => {
                let key = [ps[0], ps[1]];
                let id = match edge_of.get(&key) {
                    Some(&id) => id,
                    None => {
                        let e = edge_between(mesh, &node_patches, key, &patches, &parts);
                        check_edge_meeting(&e, &patches, &parts)?;
                        edges.push(e);
                        edge_of.insert(key, edges.len() - 1);
                        edges.len() - 1
                    }
                };
                let e = &edges[id];
                let d = sub(e.b, e.a);
                Role3::Edge { edge: id, sigma: dot(sub(mesh.nodes[i], e.a), d) / dot(d, d) }
            }
            _ => Role3::Corner { part: ps.iter().map(|&p| patches[p].part).find(|&part| matches!(parts[part].kind, PartKind::Move { .. })) },
        };
    }
    Ok(Patches { parts, patches, edges, roles, start: mesh.nodes.clone() })
}

/// An edge carried by one moving patch whose other patch moves too, onto
/// another shape: refuse it unless the carrier's image of the edge lies on
/// that shape as well.
fn check_edge_meeting(e: &Edge, patches: &[Patch], parts: &[BoundaryPart<3>]) -> Result<(), DeformError> {
    let Some(c) = e.carrier else { return Ok(()) };
    let (a, other) = (patches[c].part, e.patches.iter().map(|&p| patches[p].part).find(|&k| k != patches[c].part));
    let Some(b) = other else { return Ok(()) };
    let h = dot(sub(e.b, e.a), sub(e.b, e.a)).sqrt();
    for s in [0.0, 0.5, 1.0] {
        let x = std::array::from_fn(|k| (1.0 - s) * e.a[k] + s * e.b[k]);
        super::check_meeting(parts, a, b, x, h)?;
    }
    Ok(())
}

/// The patches every node touches, sorted.
fn node_patches<const K: usize>(faces: &[crate::mesh::BoundaryFace<K>], face_patch: &[usize], n: usize) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (f, face) in faces.iter().enumerate() {
        for &v in &face.nodes {
            if !out[v].contains(&face_patch[f]) {
                out[v].push(face_patch[f]);
            }
        }
    }
    out.iter_mut().for_each(|p| p.sort_unstable());
    out
}

/// The straight starting edge between two patches: its extent is that of
/// all nodes touching both (the corners at its ends included).
fn edge_between<const N: usize, const K: usize>(mesh: &SolidMesh<N, K>, node_patches: &[Vec<usize>], key: [usize; 2], patches: &[Patch], parts: &[BoundaryPart<3>]) -> Edge {
    let dir = unit(cross(patches[key[0]].normal, patches[key[1]].normal));
    let on: Vec<Point3> = (0..mesh.num_nodes()).filter(|&i| key.iter().all(|k| node_patches[i].contains(k))).map(|i| mesh.nodes[i]).collect();
    let proj = |p: Point3| dot(p, dir);
    let a = on.iter().copied().min_by(|p, q| proj(*p).total_cmp(&proj(*q))).expect("an edge has nodes");
    let b = on.iter().copied().max_by(|p, q| proj(*p).total_cmp(&proj(*q))).expect("an edge has nodes");
    let carrier = key.into_iter().find(|&p| matches!(parts[patches[p].part].kind, PartKind::Move { .. }));
    Edge { a, b, patches: key, carrier }
}

/// Flood-fills faces of one part across edges where the boundary turns
/// by less than 30°: each group is one patch.
fn group_faces<const N: usize, const K: usize>(mesh: &SolidMesh<N, K>) -> Vec<usize> {
    let normal = |f: usize| face_normal(&mesh.faces[f].nodes.map(|n| mesh.nodes[n]));
    let mut by_edge: HashMap<[usize; 2], Vec<usize>> = HashMap::new();
    for (f, face) in mesh.faces.iter().enumerate() {
        for k in 0..K {
            let (a, b) = (face.nodes[k], face.nodes[(k + 1) % K]);
            by_edge.entry([a.min(b), a.max(b)]).or_default().push(f);
        }
    }
    let mut patch = vec![usize::MAX; mesh.faces.len()];
    let mut next = 0;
    for seed in 0..mesh.faces.len() {
        if patch[seed] != usize::MAX {
            continue;
        }
        patch[seed] = next;
        let mut stack = vec![seed];
        while let Some(f) = stack.pop() {
            let face = &mesh.faces[f];
            for k in 0..K {
                let (a, b) = (face.nodes[k], face.nodes[(k + 1) % K]);
                for &g in &by_edge[&[a.min(b), a.max(b)]] {
                    if patch[g] == usize::MAX && mesh.faces[g].part == face.part && dot(normal(f), normal(g)) > 30f64.to_radians().cos() {
                        patch[g] = next;
                        stack.push(g);
                    }
                }
            }
        }
        next += 1;
    }
    patch
}

/// A patch's plane and parameter rectangle; its faces must be planar.
fn planar_patch<const N: usize, const K: usize>(mesh: &SolidMesh<N, K>, faces: &[usize], parts: &[BoundaryPart<3>]) -> Result<Patch, DeformError> {
    let first = mesh.faces[faces[0]].nodes.map(|n| mesh.nodes[n]);
    let normal = face_normal(&first);
    let origin = first[0];
    let e0 = unit(sub(first[1], first[0]));
    let e1 = cross(normal, e0);
    let mut p = Patch { part: mesh.faces[faces[0]].part, origin, e: [e0, e1], normal, lo: [f64::INFINITY; 2], hi: [f64::NEG_INFINITY; 2] };
    let scale = faces.iter().flat_map(|&f| mesh.faces[f].nodes).map(|n| sub(mesh.nodes[n], origin)).map(|d| dot(d, d).sqrt()).fold(0.0, f64::max);
    for &f in faces {
        for n in mesh.faces[f].nodes {
            let x = mesh.nodes[n];
            if dot(sub(x, origin), normal).abs() > 1e-9 * scale.max(1.0) {
                return Err(DeformError::Unreachable {
                    part: parts[p.part].name.clone(),
                    why: format!("its starting faces are not planar near ({:.6}, {:.6}, {:.6}); 3D parts must start on the planar faces of a box", x[0], x[1], x[2]),
                });
            }
            let s = p.param(x);
            for k in 0..2 {
                p.lo[k] = p.lo[k].min(s[k]);
                p.hi[k] = p.hi[k].max(s[k]);
            }
        }
    }
    Ok(p)
}

/// The unit normal of a flat quad (across its diagonals) or triangle, by
/// the right-hand rule of its node order.
fn face_normal(p: &[Point3]) -> Point3 {
    match p.len() {
        3 => unit(cross(sub(p[1], p[0]), sub(p[2], p[0]))),
        _ => unit(cross(sub(p[2], p[0]), sub(p[3], p[1]))),
    }
}
