//! The structure of a linear mesh as the file gives it, checked before
//! anything is computed, so that a refusal names the file's own element
//! and node tags and the real cause: a boundary element that is no edge
//! (face) of a cell, one inside the mesh, a hanging node of a mesh that is
//! not conforming, nodes given twice (a mesh cut along them), or edges
//! (faces) on the boundary that no boundary element covers. Algorithm 2's
//! subdivision makes the same checks on 0-based indices; these come first.

use std::collections::HashMap;

use smallvec::SmallVec;

use super::read::{Block, Raw};
use super::MshError;

/// Corners of a facet (node indices).
type Corners = SmallVec<[usize; 4]>;

/// A facet of a cell, by its sorted corners: how many cells hold it, the
/// element tags of the first two, and the first one's corners in cyclic
/// order.
struct Owners {
    count: usize,
    cells: [u64; 2],
    cyclic: Corners,
}

/// A facet on the boundary of the cells that no boundary element covers:
/// its cell's tag, its corners in cyclic order.
struct Open {
    cell: u64,
    corners: Corners,
}

impl Raw {
    /// The corners of an element of `block` with `nodes`: its vertices,
    /// the first nodes in Gmsh's order.
    fn corners_of(block: &Block, nodes: &[usize]) -> Corners {
        nodes[..block.kind.shape.vertices().len()].iter().copied().collect()
    }

    /// Node tags of node indices, for a message.
    fn tags_of(&self, nodes: &[usize]) -> String {
        nodes.iter().map(|&n| self.node_tags[n].to_string()).collect::<Vec<_>>().join(" ")
    }

    /// Checks the structure of a linear mesh of dimension `dim` (its
    /// cells, and its boundary elements one dimension below), naming the
    /// file's tags: see the module docs.
    pub(super) fn check_structure(&self, dim: usize) -> Result<(), MshError> {
        let key = |c: &[usize]| {
            let mut k: Corners = c.iter().copied().collect();
            k.sort_unstable();
            k
        };
        let mut owners: HashMap<Corners, Owners> = HashMap::new();
        for b in self.blocks.iter().filter(|b| b.kind.dim == dim) {
            for (&tag, nodes) in b.tags.iter().zip(b.nodes.chunks(b.kind.nodes)) {
                for (_, facet) in b.kind.shape.facets() {
                    let cyclic: Corners = facet.iter().map(|&v| nodes[v]).collect();
                    owners
                        .entry(key(&cyclic))
                        .and_modify(|o| {
                            if o.count == 1 {
                                o.cells[1] = tag;
                            }
                            o.count += 1;
                        })
                        .or_insert(Owners { count: 1, cells: [tag, 0], cyclic });
                }
            }
        }
        let what = if dim == 2 { "edge" } else { "face" };
        let mut covered: std::collections::HashSet<Corners> = std::collections::HashSet::new();
        let mut facets: Vec<(u64, &Block, &[usize])> = self.blocks.iter().filter(|b| b.kind.dim + 1 == dim).flat_map(|b| b.tags.iter().zip(b.nodes.chunks(b.kind.nodes)).map(move |(&t, n)| (t, b, n))).collect();
        facets.sort_by_key(|f| f.0);
        for (tag, block, nodes) in facets {
            let corners = Self::corners_of(block, nodes);
            let k = key(&corners);
            let shown = self.tags_of(&corners);
            let Some(o) = owners.get(&k) else {
                return Err(MshError::Structure(format!("boundary element {tag} (nodes {shown}) is not an {what} of any cell")));
            };
            if orientation(&corners, &o.cyclic).is_none() {
                return Err(MshError::Structure(format!("boundary element {tag} (nodes {shown}) has the nodes of a {what} of element {} in an order that goes round no {what}", o.cells[0])));
            }
            if o.count != 1 {
                return Err(MshError::Structure(format!(
                    "boundary element {tag} (nodes {shown}) lies inside the mesh, between elements {} and {}: a boundary group may hold only {what}s of exactly one cell; remove the interior {} from the group",
                    o.cells[0],
                    o.cells[1],
                    if dim == 2 { "curves" } else { "surfaces" }
                )));
            }
            covered.insert(k);
        }
        let mut open: Vec<Open> = owners.into_iter().filter(|(k, o)| o.count == 1 && !covered.contains(k)).map(|(_, o)| Open { cell: o.cells[0], corners: o.cyclic }).collect();
        if open.is_empty() {
            return Ok(());
        }
        open.sort_by(|a, b| (a.cell, &a.corners).cmp(&(b.cell, &b.corners)));
        let count = open.len();
        if let Some(message) = self.duplicate_nodes(&open, what) {
            return Err(MshError::Structure(message));
        }
        if let Some(message) = self.hanging_node(&open, dim, what) {
            return Err(MshError::Structure(message));
        }
        let first = &open[0];
        Err(MshError::Structure(format!(
            "{count} {what}(s) on the boundary of the mesh are in no boundary element (the first: the {what} of element {} with nodes {}): save every boundary element with a physical group (in Gmsh, add the group, or set Mesh.SaveAll = 1)",
            first.cell,
            self.tags_of(&first.corners)
        )))
    }

    /// Two different nodes at one place among the open facets' nodes: the
    /// mesh is cut along them.
    fn duplicate_nodes(&self, open: &[Open], what: &str) -> Option<String> {
        let mut nodes: Vec<usize> = open.iter().flat_map(|o| o.corners.iter().copied()).collect();
        nodes.sort_unstable();
        nodes.dedup();
        let extent = self.extent();
        let tol = 1e-10 * extent;
        let at = |n: usize| self.nodes[n];
        nodes.sort_by(|&a, &b| at(a)[0].total_cmp(&at(b)[0]));
        let mut pairs = Vec::new();
        for (i, &a) in nodes.iter().enumerate() {
            for &b in nodes[i + 1..].iter().take_while(|&&b| at(b)[0] - at(a)[0] <= tol) {
                if (0..3).all(|d| (at(a)[d] - at(b)[d]).abs() <= tol) {
                    pairs.push(if self.node_tags[a] < self.node_tags[b] { (a, b) } else { (b, a) });
                }
            }
        }
        pairs.sort_by_key(|&(a, b)| (self.node_tags[a], self.node_tags[b]));
        let &(a, b) = pairs.first()?;
        let more = if pairs.len() > 1 { format!(" ({} pairs in all)", pairs.len()) } else { String::new() };
        let x = at(a);
        Some(format!(
            "nodes {} and {} are at the same place ({}, {}, {}){more}: the mesh is cut along such nodes, so {} {what}(s) inside it have a cell on one side only; merge the duplicate nodes (in Gmsh: Coherence Mesh, or gmsh.model.mesh.removeDuplicateNodes())",
            self.node_tags[a],
            self.node_tags[b],
            x[0],
            x[1],
            x[2],
            open.len()
        ))
    }

    /// A node of one open facet on another open facet (inside it, or on
    /// one of its edges): the mesh is not conforming there.
    fn hanging_node(&self, open: &[Open], dim: usize, what: &str) -> Option<String> {
        let tol = 1e-9 * self.extent();
        // a grid of the open facets' nodes, cells the size of the largest facet
        let size = open.iter().map(|o| self.diameter(&o.corners)).fold(0.0, f64::max).max(tol);
        let cell = |x: [f64; 3]| -> [i64; 3] { std::array::from_fn(|d| (x[d] / size).floor() as i64) };
        let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        let mut nodes: Vec<usize> = open.iter().flat_map(|o| o.corners.iter().copied()).collect();
        nodes.sort_unstable();
        nodes.dedup();
        for &n in &nodes {
            grid.entry(cell(self.nodes[n])).or_default().push(n);
        }
        let mut found: Vec<(u64, usize, &Open)> = Vec::new();
        for o in open {
            let lo = cell(std::array::from_fn(|d| o.corners.iter().map(|&n| self.nodes[n][d]).fold(f64::INFINITY, f64::min)));
            let hi = cell(std::array::from_fn(|d| o.corners.iter().map(|&n| self.nodes[n][d]).fold(f64::NEG_INFINITY, f64::max)));
            for i in lo[0]..=hi[0] {
                for j in lo[1]..=hi[1] {
                    for k in lo[2]..=hi[2] {
                        for &n in grid.get(&[i, j, k]).map_or(&[][..], |v| v.as_slice()) {
                            if !o.corners.contains(&n) && self.on_facet(n, &o.corners, dim, tol) {
                                found.push((self.node_tags[n], n, o));
                            }
                        }
                    }
                }
            }
        }
        found.sort_by_key(|f| (f.2.cell, f.0));
        let &(tag, _, o) = found.first()?;
        let others: Vec<&Open> = open.iter().filter(|x| x.corners.iter().any(|&n| self.node_tags[n] == tag)).collect();
        let mut neighbours: Vec<u64> = others.iter().map(|x| x.cell).filter(|&c| c != o.cell).collect();
        neighbours.sort_unstable();
        neighbours.dedup();
        let by = match neighbours.as_slice() {
            [] => String::new(),
            [one] => format!(", a corner of element {one}"),
            many => format!(", a corner of elements {}", many.iter().map(u64::to_string).collect::<Vec<_>>().join(", ")),
        };
        let more = if found.len() > 1 { format!(" ({} such nodes in all)", found.len()) } else { String::new() };
        Some(format!(
            "node {tag} is a hanging node: it lies on the {what} with nodes {} of element {}{by}, but is no node of element {}{more}: the mesh is not conforming (neighbouring elements must share whole {what}s); make a conforming mesh (in Gmsh, one mesh of the whole domain, with matching transfinite counts on shared curves)",
            self.tags_of(&o.corners),
            o.cell,
            o.cell
        ))
    }

    /// The largest extent of the nodes' bounding box (1 if there are none).
    fn extent(&self) -> f64 {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for x in &self.nodes {
            for d in 0..3 {
                lo[d] = lo[d].min(x[d]);
                hi[d] = hi[d].max(x[d]);
            }
        }
        let e = (0..3).map(|d| hi[d] - lo[d]).fold(0.0, f64::max);
        if e.is_finite() && e > 0.0 { e } else { 1.0 }
    }

    /// The largest distance between two corners.
    fn diameter(&self, corners: &[usize]) -> f64 {
        let mut d: f64 = 0.0;
        for &a in corners {
            for &b in corners {
                d = d.max(dist(self.nodes[a], self.nodes[b]));
            }
        }
        d
    }

    /// Whether node `n` lies on the facet `corners` (an edge in 2D, a
    /// triangle or quad in 3D), within `tol`.
    fn on_facet(&self, n: usize, corners: &[usize], dim: usize, tol: f64) -> bool {
        let x = self.nodes[n];
        let c: Vec<[f64; 3]> = corners.iter().map(|&k| self.nodes[k]).collect();
        if dim == 2 {
            return on_segment(x, c[0], c[1], tol);
        }
        // a triangle, or a quad as its two triangles (either diagonal)
        let triangles: &[[usize; 3]] = if c.len() == 3 { &[[0, 1, 2]] } else { &[[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 3]] };
        triangles.iter().any(|t| in_triangle(x, c[t[0]], c[t[1]], c[t[2]], tol))
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    dot(sub(a, b), sub(a, b)).sqrt()
}

/// `x` on the segment `ab` (its ends excluded), within `tol`.
fn on_segment(x: [f64; 3], a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    if len2 <= tol * tol {
        return false;
    }
    let t = dot(sub(x, a), ab) / len2;
    let foot = [a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]];
    t > 0.0 && t < 1.0 && dist(x, foot) <= tol && dist(x, a) > tol && dist(x, b) > tol
}

/// `x` in the triangle `abc` or on its edges (its corners excluded),
/// within `tol` of its plane.
fn in_triangle(x: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3], tol: f64) -> bool {
    let normal = cross(sub(b, a), sub(c, a));
    let area2 = dot(normal, normal).sqrt();
    if area2 <= tol * tol || [a, b, c].iter().any(|&v| dist(x, v) <= tol) {
        return false;
    }
    if (dot(sub(x, a), normal) / area2).abs() > tol {
        return false;
    }
    // barycentric coordinates by the sub-triangles' signed areas
    let w = |p: [f64; 3], q: [f64; 3]| dot(cross(sub(q, p), sub(x, p)), normal) / (area2 * area2);
    let slack = tol / area2.sqrt();
    w(a, b) >= -slack && w(b, c) >= -slack && w(c, a) >= -slack
}

/// `q` as a rotation of `f` (same orientation), of its reverse (opposite),
/// or neither (an edge's two orders are both rotations).
fn orientation(q: &[usize], f: &[usize]) -> Option<bool> {
    let n = f.len();
    if n != q.len() {
        return None;
    }
    let start = f.iter().position(|&v| v == q[0])?;
    if (0..n).all(|k| q[k] == f[(start + k) % n]) {
        return Some(true);
    }
    if (0..n).all(|k| q[k] == f[(start + n - k) % n]) {
        return Some(false);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::super::check_structure;
    use super::super::MshError;

    /// Tetrahedra on the nodes 1 (0,0,0), 2 (1,0,0), 3 (0,1,0), 4
    /// (0,0,-1), 5 (1/2,0,0), 6 (0,0,1), bounded by `faces` (node tags).
    fn tets(cells: &[[u64; 4]], faces: &[[u64; 3]]) -> String {
        let mut s = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 6 1 6\n3 1 0 6\n1\n2\n3\n4\n5\n6\n0 0 0\n1 0 0\n0 1 0\n0 0 -1\n0.5 0 0\n0 0 1\n$EndNodes\n");
        s += &format!("$Elements\n2 {} 1 {}\n2 1 2 {}\n", cells.len() + faces.len(), 100 + cells.len(), faces.len());
        for (i, f) in faces.iter().enumerate() {
            s += &format!("{} {} {} {}\n", i + 1, f[0], f[1], f[2]);
        }
        s += &format!("3 1 4 {}\n", cells.len());
        for (i, c) in cells.iter().enumerate() {
            s += &format!("{} {} {} {} {}\n", 101 + i, c[0], c[1], c[2], c[3]);
        }
        s + "$EndElements\n"
    }

    #[test]
    fn a_hanging_node_on_a_face_edge_is_named_in_3d() {
        // tet 101 below z = 0; tets 102 and 103 above, their bottoms
        // halving 101's top face at node 5
        let outer = [[1, 2, 4], [1, 3, 4], [2, 3, 4], [1, 5, 6], [1, 3, 6], [5, 2, 6], [2, 3, 6]];
        let e = check_structure(tets(&[[1, 2, 3, 4], [1, 5, 3, 6], [5, 2, 3, 6]], &outer).as_bytes()).unwrap_err();
        assert!(matches!(e, MshError::Structure(_)), "{e}");
        let e = e.to_string();
        assert!(e.contains("node 5 is a hanging node") && e.contains("face with nodes") && e.contains("of element 101, a corner of elements 102, 103"), "{e}");
        // one tet above, sharing 101's whole top face: conforming
        let outer = [[1, 2, 4], [1, 3, 4], [2, 3, 4], [1, 2, 6], [1, 3, 6], [2, 3, 6]];
        check_structure(tets(&[[1, 2, 3, 4], [1, 2, 3, 6]], &outer).as_bytes()).unwrap();
        // a face missing, and a face in the middle
        let e = check_structure(tets(&[[1, 2, 3, 4], [1, 2, 3, 6]], &outer[1..]).as_bytes()).unwrap_err().to_string();
        assert!(e.contains("1 face(s) on the boundary of the mesh are in no boundary element (the first: the face of element 101 with nodes") && e.contains("Mesh.SaveAll"), "{e}");
        let inner = [[1, 2, 4], [1, 3, 4], [2, 3, 4], [1, 2, 6], [1, 3, 6], [2, 3, 6], [3, 2, 1]];
        let e = check_structure(tets(&[[1, 2, 3, 4], [1, 2, 3, 6]], &inner).as_bytes()).unwrap_err().to_string();
        assert!(e.contains("boundary element 7 (nodes 3 2 1) lies inside the mesh, between elements 101 and 102"), "{e}");
    }
}
