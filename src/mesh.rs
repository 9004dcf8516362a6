//! Quadrilateral meshes: nodes, cells, named boundary edges, and the
//! structured box generator.
//!
//! Cells are stored counter-clockwise (positive orientation), so the
//! bilinear map from the reference square has a positive Jacobian on a
//! valid cell. Boundary edges are oriented with the domain on their left.

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

/// A linear (Q1) quadrilateral mesh with named boundary parts.
#[derive(Clone, Debug, PartialEq)]
pub struct QuadMesh {
    /// Node coordinates.
    pub nodes: Vec<Point2>,
    /// Cells as four node indices, counter-clockwise.
    pub cells: Vec<[usize; 4]>,
    /// Boundary edges with their part.
    pub edges: Vec<BoundaryEdge>,
    /// Names of the boundary parts (physical groups of dimension 1).
    pub part_names: Vec<String>,
}

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

    /// Number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Number of cells.
    pub fn num_cells(&self) -> usize {
        self.cells.len()
    }

    /// Coordinates of the four corners of cell `c`.
    pub fn cell_coords(&self, c: usize) -> [Point2; 4] {
        self.cells[c].map(|n| self.nodes[n])
    }

    /// Area of cell `c`.
    pub fn cell_area(&self, c: usize) -> f64 {
        quad_area(&self.cell_coords(c))
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
}

/// Area of a bilinear quad (exact: the shoelace formula on its diagonals).
pub fn quad_area(p: &[Point2; 4]) -> f64 {
    0.5 * ((p[2][0] - p[0][0]) * (p[3][1] - p[1][1]) - (p[3][0] - p[1][0]) * (p[2][1] - p[0][1]))
}

/// Greedy colouring of the cells so that no two cells of one colour share
/// a node: cells of one colour can then be scattered into a global matrix
/// in parallel without write conflicts. Returns the cells grouped by colour.
pub fn colour_cells(cells: &[[usize; 4]], num_nodes: usize) -> Vec<Vec<usize>> {
    // node_colours[n] is a bit set of the colours already touching node n
    let mut node_colours = vec![0u64; num_nodes];
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (c, cell) in cells.iter().enumerate() {
        let used = cell.iter().fold(0u64, |acc, &n| acc | node_colours[n]);
        let colour = (!used).trailing_zeros() as usize;
        assert!(colour < 64, "more than 64 colours: a node with over 60 cells");
        for &n in cell {
            node_colours[n] |= 1 << colour;
        }
        if groups.len() <= colour {
            groups.resize_with(colour + 1, Vec::new);
        }
        groups[colour].push(c);
    }
    groups
}

#[cfg(test)]
mod colour_tests {
    use super::*;

    #[test]
    fn colours_share_no_node() {
        let m = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 7, 5);
        let groups = colour_cells(&m.cells, m.num_nodes());
        assert!(groups.len() <= 4, "a structured mesh needs 4 colours, got {}", groups.len());
        assert_eq!(groups.iter().map(Vec::len).sum::<usize>(), 35);
        for g in &groups {
            let mut seen = vec![false; m.num_nodes()];
            for &c in g {
                for &n in &m.cells[c] {
                    assert!(!seen[n]);
                    seen[n] = true;
                }
            }
        }
    }
}
