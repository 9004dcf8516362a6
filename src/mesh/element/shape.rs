//! The reference shapes of elements, as data (MFEM's `Geometry::Constants`):
//! their dimension, vertices, edges and faces. Everything that depends on
//! the kind of an element asks this table instead of assuming the
//! dimension decides it.

/// The kind of an element's reference cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Shape {
    /// A node.
    Point,
    /// `[0,1]`.
    Line,
    /// The unit triangle (0,0), (1,0), (0,1).
    Triangle,
    /// `[0,1]²`.
    Quadrilateral,
    /// The unit tetrahedron (0,0,0), (1,0,0), (0,1,0), (0,0,1).
    Tetrahedron,
    /// `[0,1]³`.
    Hexahedron,
    /// The unit triangle × `[0,1]`.
    Prism,
    /// The square `[0,1]²` at height 0 below an apex at height 1.
    Pyramid,
}

impl Shape {
    /// Dimension of the reference cell.
    pub fn dim(self) -> usize {
        match self {
            Shape::Point => 0,
            Shape::Line => 1,
            Shape::Triangle | Shape::Quadrilateral => 2,
            Shape::Tetrahedron | Shape::Hexahedron | Shape::Prism | Shape::Pyramid => 3,
        }
    }

    /// Whether the cell is a simplex (point, line, triangle, tetrahedron).
    pub fn is_simplex(self) -> bool {
        matches!(self, Shape::Point | Shape::Line | Shape::Triangle | Shape::Tetrahedron)
    }
}
