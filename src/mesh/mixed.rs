//! A plane mesh of quadrilaterals and triangles together: Gmsh's
//! boundary-layer quads with triangles outside. Cells keep the file's
//! order (so the curved cell `c` is the file's element `c`), each with
//! its own kind.

use super::element::Shape;
use super::linear::{orientation_flips, BoundaryEdge, Point2};

/// One linear cell of a mixed plane mesh, its corners counter-clockwise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaneCell {
    /// A linear triangle.
    Triangle([usize; 3]),
    /// A bilinear quadrilateral.
    Quad([usize; 4]),
}

impl AsRef<[usize]> for PlaneCell {
    fn as_ref(&self) -> &[usize] {
        self.nodes()
    }
}

impl PlaneCell {
    /// The corners in cyclic order.
    pub fn nodes(&self) -> &[usize] {
        match self {
            PlaneCell::Triangle(c) => c,
            PlaneCell::Quad(c) => c,
        }
    }

    /// The reference shape.
    pub fn shape(&self) -> Shape {
        match self {
            PlaneCell::Triangle(_) => Shape::Triangle,
            PlaneCell::Quad(_) => Shape::Quadrilateral,
        }
    }

    /// The same corners the other way round, from the same first.
    fn reverse(&mut self) {
        match self {
            PlaneCell::Triangle(c) => c[1..].reverse(),
            PlaneCell::Quad(c) => c[1..].reverse(),
        }
    }
}

/// A linear plane mesh of quads and triangles with named boundary parts.
#[derive(Clone, Debug, PartialEq)]
pub struct MixedPlaneMesh {
    /// Node coordinates.
    pub nodes: Vec<Point2>,
    /// Cells in the file's order.
    pub cells: Vec<PlaneCell>,
    /// Boundary edges with their part.
    pub edges: Vec<BoundaryEdge>,
    /// Names of the boundary parts.
    pub part_names: Vec<String>,
}

impl MixedPlaneMesh {
    /// How many cells are of `shape`.
    pub fn count(&self, shape: Shape) -> usize {
        self.cells.iter().filter(|c| c.shape() == shape).count()
    }

    /// Turns clockwise cells counter-clockwise, quads and triangles made to
    /// agree across their shared edges (see
    /// [`super::QuadMesh::orient_counter_clockwise`]); returns how many.
    pub fn orient_counter_clockwise(&mut self) -> usize {
        let cells: Vec<&[usize]> = self.cells.iter().map(|c| c.nodes()).collect();
        let flip = orientation_flips(&cells, &self.nodes);
        let mut turned = 0;
        for (cell, f) in self.cells.iter_mut().zip(flip) {
            if f {
                cell.reverse();
                turned += 1;
            }
        }
        turned
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square split into a quad [0, ½] × [0, 1] and two triangles,
    /// some cells given clockwise.
    fn square() -> MixedPlaneMesh {
        let nodes = vec![[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 1.0], [1.0, 1.0]];
        let cells = vec![PlaneCell::Quad([0, 3, 4, 1]), PlaneCell::Triangle([1, 2, 5]), PlaneCell::Triangle([1, 4, 5])];
        MixedPlaneMesh { nodes, cells, edges: Vec::new(), part_names: Vec::new() }
    }

    /// Orientation runs across the kinds: the clockwise quad and the
    /// clockwise triangle are turned (by their neighbour's order), the
    /// counter-clockwise triangle stays.
    #[test]
    fn quads_and_triangles_are_oriented_together() {
        let mut m = square();
        assert_eq!(m.orient_counter_clockwise(), 2);
        assert_eq!(m.cells, vec![PlaneCell::Quad([0, 1, 4, 3]), PlaneCell::Triangle([1, 2, 5]), PlaneCell::Triangle([1, 5, 4])]);
        assert_eq!((m.count(Shape::Quadrilateral), m.count(Shape::Triangle)), (1, 2));
    }
}
