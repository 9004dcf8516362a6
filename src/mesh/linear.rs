//! Plane meshes of quadrilaterals or triangles (nodes, cells, named
//! boundary edges, the structured box generator), and hexahedral meshes.
//!
//! Cells are stored counter-clockwise (positive orientation), so the
//! linear map from the reference cell has a positive Jacobian on a valid
//! cell. Boundary edges are oriented with the domain on their left.

use std::ops::Range;

/// A point or vector in the plane.
pub type Point2 = [f64; 2];

/// One edge of the boundary, tagged with the boundary part it belongs to.
#[derive(Clone, Debug, PartialEq)]
pub struct BoundaryEdge {
    /// The two end nodes, oriented so the domain lies on the left.
    pub nodes: [usize; 2],
    /// Index into [`QuadMesh::part_names`].
    pub part: usize,
}

/// A linear plane mesh with named boundary parts: bilinear quadrilaterals
/// (`N = 4`, [`QuadMesh`]) or linear triangles (`N = 3`, [`TriMesh`]). The
/// kind is the cell's node count, so every loop over cells is compiled
/// once per kind.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneMesh<const N: usize = 4> {
    /// Node coordinates.
    pub nodes: Vec<Point2>,
    /// Cells as `N` node indices, counter-clockwise.
    pub cells: Vec<[usize; N]>,
    /// Boundary edges with their part.
    pub edges: Vec<BoundaryEdge>,
    /// Names of the boundary parts (physical groups of dimension 1).
    pub part_names: Vec<String>,
}

/// A mesh of bilinear quadrilaterals.
pub type QuadMesh = PlaneMesh<4>;
/// A mesh of linear triangles.
pub type TriMesh = PlaneMesh<3>;

/// The four sides of a structured box, in the order used for part indices
/// of a freshly generated box.
pub const BOX_SIDES: [&str; 4] = ["left", "right", "bottom", "top"];

impl QuadMesh {
    /// A structured `nx × ny` mesh of the box `[lo, hi]`, nodes numbered
    /// x-fastest. Boundary parts are the four sides, named as in
    /// [`BOX_SIDES`]; a corner node belongs to edges of two sides.
    pub fn structured_box(lo: Point2, hi: Point2, nx: usize, ny: usize) -> QuadMesh {
        let id = |i: usize, j: usize| j * (nx + 1) + i;
        let mut nodes = Vec::with_capacity((nx + 1) * (ny + 1));
        for j in 0..=ny {
            for i in 0..=nx {
                // Interpolate from both ends so the far side is exact.
                let sx = i as f64 / nx as f64;
                let sy = j as f64 / ny as f64;
                let x = if i == nx { hi[0] } else { lo[0] + sx * (hi[0] - lo[0]) };
                let y = if j == ny { hi[1] } else { lo[1] + sy * (hi[1] - lo[1]) };
                nodes.push([x, y]);
            }
        }
        let mut cells = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                cells.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let mut edges = Vec::with_capacity(2 * (nx + ny));
        for j in 0..ny {
            // left side runs downward, right side upward (domain on the left)
            edges.push(BoundaryEdge { nodes: [id(0, j + 1), id(0, j)], part: 0 });
            edges.push(BoundaryEdge { nodes: [id(nx, j), id(nx, j + 1)], part: 1 });
        }
        for i in 0..nx {
            edges.push(BoundaryEdge { nodes: [id(i, 0), id(i + 1, 0)], part: 2 });
            edges.push(BoundaryEdge { nodes: [id(i + 1, ny), id(i, ny)], part: 3 });
        }
        QuadMesh {
            nodes,
            cells,
            edges,
            part_names: BOX_SIDES.iter().map(|s| s.to_string()).collect(),
        }
    }
}

impl TriMesh {
    /// [`QuadMesh::structured_box`] with every cell cut into two triangles
    /// along its diagonal from the lower left corner (all cells alike).
    pub fn structured_box(lo: Point2, hi: Point2, nx: usize, ny: usize) -> TriMesh {
        let q = QuadMesh::structured_box(lo, hi, nx, ny);
        let cells = q.cells.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
        TriMesh { nodes: q.nodes, cells, edges: q.edges, part_names: q.part_names }
    }
}

/// The two triangles of a quad `q` (cyclic), cut along the diagonal
/// through its smallest node number, oriented like it: neighbours that
/// share the quad cut it alike, whatever kinds they are (Dompierre,
/// Labbé, Vallet & Camarero, "How to subdivide pyramids, prisms and
/// hexaedra into tetrahedra", 1999).
pub fn cut_quad(q: [usize; 4]) -> [[usize; 3]; 2] {
    let low = (0..4).min_by_key(|&a| q[a]).expect("four corners");
    let r: [usize; 4] = std::array::from_fn(|a| q[(low + a) % 4]);
    [[r[0], r[1], r[2]], [r[0], r[2], r[3]]]
}

impl<const N: usize> PlaneMesh<N> {
    /// Number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Number of cells.
    pub fn num_cells(&self) -> usize {
        self.cells.len()
    }

    /// Coordinates of the corners of cell `c`.
    pub fn cell_coords(&self, c: usize) -> [Point2; N] {
        self.cells[c].map(|n| self.nodes[n])
    }

    /// Area of cell `c` (exact for a bilinear quad or a triangle: the
    /// shoelace formula).
    pub fn cell_area(&self, c: usize) -> f64 {
        polygon_area(&self.cell_coords(c))
    }

    /// Total area.
    pub fn area(&self) -> f64 {
        (0..self.num_cells()).map(|c| self.cell_area(c)).sum()
    }

    /// For every node, the sorted list of boundary parts it touches
    /// (empty for interior nodes).
    pub fn node_parts(&self) -> Vec<Vec<usize>> {
        let mut parts = vec![Vec::new(); self.num_nodes()];
        for e in &self.edges {
            for &n in &e.nodes {
                if !parts[n].contains(&e.part) {
                    parts[n].push(e.part);
                }
            }
        }
        for p in &mut parts {
            p.sort_unstable();
        }
        parts
    }

    /// Turns clockwise cells counter-clockwise, as the method requires;
    /// returns how many were turned.
    ///
    /// Gmsh orders a surface's quads by the surface's normal, so a mesh
    /// (or one surface of it) may be clockwise yet valid. Orientation is
    /// decided per connected set of cells, not per cell: neighbours are
    /// made to agree (a shared edge runs opposite ways in the two cells),
    /// then each set is turned so that its signed area is positive. A cell
    /// folded over its neighbours keeps its order and stays inverted, so
    /// the validity check still refuses it. Where neighbours cannot agree
    /// (not orientable) nothing in that set is turned.
    pub fn orient_counter_clockwise(&mut self) -> usize {
        let flip = self.orientation_flips();
        let mut turned = 0;
        for (cell, f) in self.cells.iter_mut().zip(flip) {
            if f {
                // the same corners the other way round, from the same first
                cell[1..].reverse();
                turned += 1;
            }
        }
        turned
    }

    /// Per cell, whether to reverse it (see
    /// [`QuadMesh::orient_counter_clockwise`]).
    fn orientation_flips(&self) -> Vec<bool> {
        let cells: Vec<&[usize]> = self.cells.iter().map(|c| &c[..]).collect();
        orientation_flips(&cells, &self.nodes)
    }
}

/// Per cell (its corners in cyclic order), whether to reverse it so that
/// neighbours agree and each connected set has a positive signed area
/// (see [`QuadMesh::orient_counter_clockwise`]); cells of any number of
/// corners, so quads and triangles of one mesh agree with each other.
pub(crate) fn orientation_flips(cells: &[&[usize]], nodes: &[Point2]) -> Vec<bool> {
    use std::collections::HashMap;
    let area = |c: usize| {
        let at = |k: usize| nodes[cells[c][k]];
        match cells[c].len() {
            4 => polygon_area(&[at(0), at(1), at(2), at(3)]),
            _ => polygon_area(&[at(0), at(1), at(2)]),
        }
    };
    // undirected edge → (cell, runs from the smaller node)
    let mut by_edge: HashMap<(usize, usize), Vec<(usize, bool)>> = HashMap::new();
    for (c, cell) in cells.iter().enumerate() {
        let n = cell.len();
        for k in 0..n {
            let (a, b) = (cell[k], cell[(k + 1) % n]);
            by_edge.entry((a.min(b), a.max(b))).or_default().push((c, a < b));
        }
    }
    let n = cells.len();
    let mut flip: Vec<Option<bool>> = vec![None; n];
    let mut out = vec![false; n];
    for start in 0..n {
        if flip[start].is_some() {
            continue;
        }
        // a breadth-first walk over the set of `start`
        flip[start] = Some(false);
        let (mut set, mut next, mut consistent) = (vec![start], 0, true);
        while next < set.len() {
            let c = set[next];
            next += 1;
            let fc = flip[c] == Some(true);
            let cell = cells[c];
            let m = cell.len();
            for k in 0..m {
                let (a, b) = (cell[k], cell[(k + 1) % m]);
                for &(d, fwd) in &by_edge[&(a.min(b), a.max(b))] {
                    if d == c {
                        continue;
                    }
                    // same direction in both: one of them must turn
                    let want = fc ^ (fwd == (a < b));
                    match flip[d] {
                        None => {
                            flip[d] = Some(want);
                            set.push(d);
                        }
                        Some(f) if f != want => consistent = false,
                        Some(_) => {}
                    }
                }
            }
        }
        let signed: f64 = set.iter().map(|&c| if flip[c] == Some(true) { -1.0 } else { 1.0 } * area(c)).sum();
        if consistent {
            for &c in &set {
                out[c] = (flip[c] == Some(true)) != (signed < 0.0);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_counts_area_and_orientation() {
        let m = QuadMesh::structured_box([0.0, 0.0], [2.0, 1.0], 4, 3);
        assert_eq!(m.num_nodes(), 20);
        assert_eq!(m.num_cells(), 12);
        assert_eq!(m.edges.len(), 14);
        assert!((m.area() - 2.0).abs() < 1e-14);
        assert!(m.cells.iter().enumerate().all(|(c, _)| m.cell_area(c) > 0.0));
        // every boundary edge has the domain on its left: the outward normal
        // (dy, -dx) points away from the box centre
        for e in &m.edges {
            let (a, b) = (m.nodes[e.nodes[0]], m.nodes[e.nodes[1]]);
            let n = [b[1] - a[1], -(b[0] - a[0])];
            let mid = [(a[0] + b[0]) / 2.0 - 1.0, (a[1] + b[1]) / 2.0 - 0.5];
            assert!(n[0] * mid[0] + n[1] * mid[1] > 0.0);
        }
        let parts = m.node_parts();
        assert_eq!(parts[0], vec![0, 2]);
        assert!(parts[6].is_empty());
    }

    #[test]
    fn clockwise_cells_are_turned_but_folded_ones_are_not() {
        let ccw = QuadMesh::structured_box([0.0, 0.0], [2.0, 1.0], 4, 3);
        let mut m = ccw.clone();
        assert_eq!(m.orient_counter_clockwise(), 0);
        // the whole mesh clockwise: every cell turned, all valid again
        for c in &mut m.cells {
            c.reverse();
        }
        assert!(m.cells.iter().enumerate().all(|(c, _)| m.cell_area(c) < 0.0));
        assert_eq!(m.orient_counter_clockwise(), 12);
        assert!(crate::quality::certify::invalid_cells(&m.cells, &m.nodes).is_empty());
        // one clockwise cell in a counter-clockwise mesh (as from a second
        // Gmsh surface with the other normal): turned
        let mut one = ccw.clone();
        one.cells[5].reverse();
        assert_eq!(one.orient_counter_clockwise(), 1);
        assert!(crate::quality::certify::invalid_cells(&one.cells, &one.nodes).is_empty());
        // a cell folded through its neighbours (its node order agrees with
        // theirs): not turned, still invalid
        let mut folded = ccw.clone();
        let centre = folded.cells[5];
        // mirror the cell's nodes across its centre line x = 0.75 … by
        // moving its right nodes far to the left
        for &n in &[centre[1], centre[2]] {
            folded.nodes[n][0] -= 1.0;
        }
        assert_eq!(folded.orient_counter_clockwise(), 0);
        assert!(crate::quality::certify::invalid_cells(&folded.cells, &folded.nodes).contains(&5));
    }
}

/// Area of a bilinear quad (exact: the shoelace formula on its diagonals).
pub fn quad_area(p: &[Point2; 4]) -> f64 {
    0.5 * ((p[2][0] - p[0][0]) * (p[3][1] - p[1][1]) - (p[3][0] - p[1][0]) * (p[2][1] - p[0][1]))
}

/// Signed area of a cell with straight edges: a triangle, or a bilinear
/// quad (whose area is that of its corner polygon).
pub fn polygon_area<const N: usize>(p: &[Point2; N]) -> f64 {
    if N == 4 {
        // the diagonal form, bit for bit what quads always gave
        return quad_area(&std::array::from_fn(|k| p[k]));
    }
    0.5 * (0..N).map(|k| {
        let (a, b) = (p[k], p[(k + 1) % N]);
        a[0] * b[1] - b[0] * a[1]
    }).sum::<f64>()
}

/// Greedy colouring of blocks of `block` consecutive cells so that no two
/// blocks of one colour share a node: the blocks of one colour can then be
/// scattered into a global matrix in parallel without write conflicts.
/// Returns the blocks (cell ranges) grouped by colour.
///
/// Blocks rather than single cells because of the memory traffic: with one
/// cell per item, a colour is spread over the whole mesh and every colour
/// streams the whole matrix once (8 passes for hexes); a block of
/// consecutive cells (meshes are numbered with locality) keeps the rows it
/// shares in cache, and few colours are needed.
pub fn colour_blocks<const N: usize>(cells: &[[usize; N]], num_nodes: usize, block: usize) -> Vec<Vec<Range<usize>>> {
    let block = block.max(1);
    let ranges: Vec<Range<usize>> = (0..cells.len().div_ceil(block)).map(|b| b * block..((b + 1) * block).min(cells.len())).collect();
    // Colours are handed out 64 at a time, a node's taken ones kept as a
    // bit set; a block that finds all 64 taken (a node in more than 63
    // blocks) waits for the next round, whose colours are all new.
    let mut node_colours = vec![0u64; num_nodes];
    let mut groups: Vec<Vec<Range<usize>>> = Vec::new();
    let mut pending: Vec<usize> = (0..ranges.len()).collect();
    let mut base = 0;
    while !pending.is_empty() {
        node_colours.iter_mut().for_each(|b| *b = 0);
        let mut later = Vec::new();
        for b in pending {
            let nodes = || cells[ranges[b].clone()].iter().flatten();
            let used = nodes().fold(0u64, |acc, &n| acc | node_colours[n]);
            if used == u64::MAX {
                later.push(b);
                continue;
            }
            let colour = (!used).trailing_zeros() as usize;
            nodes().for_each(|&n| node_colours[n] |= 1 << colour);
            if groups.len() <= base + colour {
                groups.resize_with(base + colour + 1, Vec::new);
            }
            groups[base + colour].push(ranges[b].clone());
        }
        pending = later;
        base += 64;
    }
    groups
}

#[cfg(test)]
mod colour_tests {
    use super::*;

    #[test]
    fn colours_share_no_node() {
        let m = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 7, 5);
        let groups = colour_blocks(&m.cells, m.num_nodes(), 1);
        assert!(groups.len() <= 4, "a structured mesh needs 4 colours, got {}", groups.len());
        assert_eq!(groups.iter().flatten().map(|r| r.len()).sum::<usize>(), 35);
        assert_disjoint(&groups, &m.cells, m.num_nodes());
    }

    #[test]
    fn blocks_of_rows_need_two_colours() {
        // blocks of 7 cells are whole rows of the 7 × 5 box: row k shares
        // nodes with rows k ± 1 only, so the rows alternate two colours
        let m = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 7, 5);
        let groups = colour_blocks(&m.cells, m.num_nodes(), 7);
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0], vec![0..7, 14..21, 28..35]);
        assert_disjoint(&groups, &m.cells, m.num_nodes());
    }

    /// No node in two blocks of one colour (cells of one block may share).
    fn assert_disjoint(groups: &[Vec<Range<usize>>], cells: &[[usize; 4]], nodes: usize) {
        for g in groups {
            let mut owner = vec![usize::MAX; nodes];
            for (b, r) in g.iter().enumerate() {
                for &n in cells[r.clone()].iter().flatten() {
                    assert!(owner[n] == usize::MAX || owner[n] == b, "node {n} in two blocks of a colour");
                    owner[n] = b;
                }
            }
        }
    }

    #[test]
    fn a_node_with_seventy_cells_gets_seventy_colours() {
        // a fan of 70 quads around node 0 (used to panic past 64 colours)
        let cells: Vec<[usize; 4]> = (0..70).map(|k| [0, 1 + 2 * k, 2 + 2 * k, 1 + (2 * k + 2) % 140]).collect();
        let groups = colour_blocks(&cells, 141, 1);
        assert_eq!(groups.len(), 70);
        assert!(groups.iter().all(|g| g.len() == 1));
        assert_disjoint(&groups, &cells, 141);
    }
}

/// A point or vector in space.
pub type Point3 = [f64; 3];

/// One face of the boundary of a solid mesh: a quadrilateral (`K = 4`, of
/// a hex mesh) or a triangle (`K = 3`, of a tetrahedral mesh).
#[derive(Clone, Debug, PartialEq)]
pub struct BoundaryFace<const K: usize = 4> {
    /// The nodes, counter-clockwise seen from outside (the right-hand
    /// rule gives the outward normal).
    pub nodes: [usize; K],
    /// Index into [`SolidMesh::part_names`].
    pub part: usize,
}

/// A linear (Q1) hexahedral mesh with named boundary parts.
///
/// Cells list their nodes as Gmsh's HEX_8 and VTK_HEXAHEDRON do: the
/// bottom face (ζ = 0) counter-clockwise seen from above, then the top face
/// in the same order: (0,0,0) (1,0,0) (1,1,0) (0,1,0) (0,0,1) (1,0,1)
/// (1,1,1) (0,1,1) in reference coordinates.
///
/// Tetrahedra (`N = 4`, faces `K = 3`) list their nodes as Gmsh's TET_4
/// and VTK_TETRA do: (0,0,0) (1,0,0) (0,1,0) (0,0,1), positively oriented.
#[derive(Clone, Debug, PartialEq)]
pub struct SolidMesh<const N: usize = 8, const K: usize = 4> {
    /// Node coordinates.
    pub nodes: Vec<Point3>,
    /// Cells as `N` node indices.
    pub cells: Vec<[usize; N]>,
    /// Boundary faces with their part.
    pub faces: Vec<BoundaryFace<K>>,
    /// Names of the boundary parts (physical groups of dimension 2).
    pub part_names: Vec<String>,
}

/// A mesh of trilinear hexahedra.
pub type HexMesh = SolidMesh<8, 4>;
/// A mesh of linear tetrahedra.
pub type TetMesh = SolidMesh<4, 3>;

/// The six faces of a hex in local node numbers (Gmsh/VTK order), each
/// counter-clockwise seen from outside a positively oriented cell:
/// ζ = 0, ζ = 1, η = 0, ξ = 1, η = 1, ξ = 0.
pub const HEX_FACES: [[usize; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
];

/// The six faces of a structured brick, in the order used for part
/// indices of a freshly generated brick.
pub const BOX_FACES: [&str; 6] = ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"];

impl HexMesh {
    /// A structured `n[0] × n[1] × n[2]` mesh of the brick `[lo, hi]`,
    /// nodes numbered x fastest, then y, then z. Boundary parts are the six
    /// faces named as in [`BOX_FACES`].
    pub fn structured_box(lo: Point3, hi: Point3, n: [usize; 3]) -> HexMesh {
        let [nx, ny, nz] = n;
        let id = |i: usize, j: usize, k: usize| (k * (ny + 1) + j) * (nx + 1) + i;
        let coord = |d: usize, i: usize, m: usize| if i == m { hi[d] } else { lo[d] + (hi[d] - lo[d]) * i as f64 / m as f64 };
        let mut nodes = Vec::with_capacity((nx + 1) * (ny + 1) * (nz + 1));
        for k in 0..=nz {
            for j in 0..=ny {
                for i in 0..=nx {
                    nodes.push([coord(0, i, nx), coord(1, j, ny), coord(2, k, nz)]);
                }
            }
        }
        let mut cells = Vec::with_capacity(nx * ny * nz);
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    cells.push([
                        id(i, j, k),
                        id(i + 1, j, k),
                        id(i + 1, j + 1, k),
                        id(i, j + 1, k),
                        id(i, j, k + 1),
                        id(i + 1, j, k + 1),
                        id(i + 1, j + 1, k + 1),
                        id(i, j + 1, k + 1),
                    ]);
                }
            }
        }
        let mut faces = Vec::new();
        // each face listed counter-clockwise seen from outside
        for k in 0..nz {
            for j in 0..ny {
                faces.push(BoundaryFace { nodes: [id(0, j, k), id(0, j, k + 1), id(0, j + 1, k + 1), id(0, j + 1, k)], part: 0 });
                faces.push(BoundaryFace { nodes: [id(nx, j, k), id(nx, j + 1, k), id(nx, j + 1, k + 1), id(nx, j, k + 1)], part: 1 });
            }
        }
        for k in 0..nz {
            for i in 0..nx {
                faces.push(BoundaryFace { nodes: [id(i, 0, k), id(i + 1, 0, k), id(i + 1, 0, k + 1), id(i, 0, k + 1)], part: 2 });
                faces.push(BoundaryFace { nodes: [id(i, ny, k), id(i, ny, k + 1), id(i + 1, ny, k + 1), id(i + 1, ny, k)], part: 3 });
            }
        }
        for j in 0..ny {
            for i in 0..nx {
                faces.push(BoundaryFace { nodes: [id(i, j, 0), id(i, j + 1, 0), id(i + 1, j + 1, 0), id(i + 1, j, 0)], part: 4 });
                faces.push(BoundaryFace { nodes: [id(i, j, nz), id(i + 1, j, nz), id(i + 1, j + 1, nz), id(i, j + 1, nz)], part: 5 });
            }
        }
        HexMesh { nodes, cells, faces, part_names: BOX_FACES.iter().map(|s| s.to_string()).collect() }
    }

}

impl<const N: usize, const K: usize> SolidMesh<N, K> {
    /// Number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Number of cells.
    pub fn num_cells(&self) -> usize {
        self.cells.len()
    }

    /// Coordinates of the nodes of cell `c`.
    pub fn cell_coords(&self, c: usize) -> [Point3; N] {
        self.cells[c].map(|n| self.nodes[n])
    }
}

#[cfg(test)]
mod hex_tests {
    use super::*;
    use crate::numeric::{cross3, dot, sub, triple};

    #[test]
    fn brick_counts_and_outward_faces() {
        let m = HexMesh::structured_box([0.0, 0.0, 0.0], [2.0, 1.0, 1.0], [3, 2, 2]);
        assert_eq!(m.num_nodes(), 4 * 3 * 3);
        assert_eq!(m.num_cells(), 12);
        assert_eq!(m.faces.len(), 2 * (2 * 2 + 3 * 2 + 3 * 2));
        let centre = [1.0, 0.5, 0.5];
        for f in &m.faces {
            let p = f.nodes.map(|n| m.nodes[n]);
            let n = cross3(sub(p[2], p[0]), sub(p[3], p[1]));
            assert!(dot(n, sub(p[0], centre)) > 0.0, "face {f:?} points inward");
        }
        // the first cell is positively oriented: (p1−p0)·((p3−p0)×(p4−p0)) > 0
        let p = m.cell_coords(0);
        assert!(triple(sub(p[1], p[0]), sub(p[3], p[0]), sub(p[4], p[0])) > 0.0);
    }
}
