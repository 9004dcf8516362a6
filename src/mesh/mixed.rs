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

/// One linear cell of a mixed solid mesh, vertices in Gmsh's order
/// ([`Shape::vertices`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolidCell {
    /// A linear tetrahedron.
    Tet([usize; 4]),
    /// A linear prism: the bottom triangle, then the top one above it.
    Prism([usize; 6]),
    /// A linear pyramid: the base counter-clockwise seen from the apex,
    /// then the apex.
    Pyramid([usize; 5]),
    /// A trilinear hexahedron: the bottom counter-clockwise seen from the
    /// top, then the top above it.
    Hex([usize; 8]),
}

impl SolidCell {
    /// The cell of `nodes` (4, 5, 6 or 8 of them: a tetrahedron, pyramid,
    /// prism or hexahedron), or `None` for another count.
    pub fn from_nodes(n: &[usize]) -> Option<SolidCell> {
        Some(match n.len() {
            4 => SolidCell::Tet([n[0], n[1], n[2], n[3]]),
            5 => SolidCell::Pyramid([n[0], n[1], n[2], n[3], n[4]]),
            6 => SolidCell::Prism([n[0], n[1], n[2], n[3], n[4], n[5]]),
            8 => SolidCell::Hex(std::array::from_fn(|k| n[k])),
            _ => return None,
        })
    }

    /// The vertices.
    pub fn nodes(&self) -> &[usize] {
        match self {
            SolidCell::Tet(c) => c,
            SolidCell::Prism(c) => c,
            SolidCell::Pyramid(c) => c,
            SolidCell::Hex(c) => c,
        }
    }

    /// The reference shape.
    pub fn shape(&self) -> Shape {
        match self {
            SolidCell::Tet(_) => Shape::Tetrahedron,
            SolidCell::Prism(_) => Shape::Prism,
            SolidCell::Pyramid(_) => Shape::Pyramid,
            SolidCell::Hex(_) => Shape::Hexahedron,
        }
    }

    /// The outward faces, each in cyclic order ([`Shape::faces`]).
    pub fn faces(&self) -> Vec<Vec<usize>> {
        let n = self.nodes();
        self.shape().faces().iter().map(|(_, f)| f.iter().map(|&k| n[k]).collect()).collect()
    }

    /// det J of the linear map at each vertex (the triple product of the
    /// reference axes' images there): only a tetrahedron's det J is
    /// constant, and the corners are where a flat or twisted linear cell
    /// fails. A pyramid's det J does not depend on the height (see
    /// [`crate::mesh::element::pyramid`]): its four base corners tell.
    pub fn corner_jacobians(&self, at: &[[f64; 3]]) -> Vec<f64> {
        let x = |k: usize| at[self.nodes()[k]];
        let e = |a: usize, b: usize| std::array::from_fn::<f64, 3, _>(|d| x(b)[d] - x(a)[d]);
        match self {
            SolidCell::Tet(_) => vec![triple(e(0, 1), e(0, 2), e(0, 3))],
            SolidCell::Prism(_) => (0..6)
                .map(|v| {
                    // ∂/∂ξ and ∂/∂η along the triangle of v's layer, ∂/∂ζ along
                    // the vertical edge through v
                    let o = 3 * (v / 3);
                    triple(e(o, o + 1), e(o, o + 2), e(v % 3, v % 3 + 3))
                })
                .collect(),
            // the base's edges along x and y at the corner, and the edge up
            // to the apex
            SolidCell::Pyramid(_) => vec![
                triple(e(0, 1), e(0, 3), e(0, 4)),
                triple(e(0, 1), e(1, 2), e(1, 4)),
                triple(e(3, 2), e(1, 2), e(2, 4)),
                triple(e(3, 2), e(0, 3), e(3, 4)),
            ],
            SolidCell::Hex(_) => (0..8)
                .map(|v| {
                    // v's bits (x, y, z) and the corner across each axis
                    let bits = [[0, 0], [1, 0], [1, 1], [0, 1]][v % 4];
                    let corner = |x: usize, y: usize, z: usize| 4 * z + [[0, 3], [1, 2]][x][y];
                    let (bx, by, bz) = (bits[0], bits[1], v / 4);
                    triple(e(corner(0, by, bz), corner(1, by, bz)), e(corner(bx, 0, bz), corner(bx, 1, bz)), e(corner(bx, by, 0), corner(bx, by, 1)))
                })
                .collect(),
        }
    }
}

fn triple(u: [f64; 3], v: [f64; 3], w: [f64; 3]) -> f64 {
    u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0])
}

impl AsRef<[usize]> for SolidCell {
    fn as_ref(&self) -> &[usize] {
        self.nodes()
    }
}

/// A linear solid mesh of tetrahedra, prisms, pyramids and hexahedra
/// (prism layers on walls with tetrahedra outside; hex-dominant meshes
/// with pyramids between hexes and tetrahedra) with named boundary parts.
/// Cells keep the file's order.
#[derive(Clone, Debug, PartialEq)]
pub struct MixedSolidMesh {
    /// Node coordinates.
    pub nodes: Vec<super::Point3>,
    /// Cells in the file's order.
    pub cells: Vec<SolidCell>,
    /// Boundary faces (triangles and quads, in cyclic order) with their
    /// part.
    pub faces: Vec<(Vec<usize>, usize)>,
    /// Names of the boundary parts.
    pub part_names: Vec<String>,
}

impl MixedSolidMesh {
    /// How many cells are of `shape`.
    pub fn count(&self, shape: Shape) -> usize {
        self.cells.iter().filter(|c| c.shape() == shape).count()
    }

    /// The kinds of its cells, in the order of [`Shape`].
    pub fn shapes(&self) -> Vec<Shape> {
        let mut out: Vec<Shape> = self.cells.iter().map(SolidCell::shape).collect();
        out.sort();
        out.dedup();
        out
    }

    /// The cells with det J ≤ 0 at a vertex.
    pub fn invalid_cells(&self) -> Vec<usize> {
        (0..self.cells.len()).filter(|&c| self.cells[c].corner_jacobians(&self.nodes).iter().any(|&j| j <= 0.0)).collect()
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

    /// The corner Jacobians of a prism are the reference prism's (1 at
    /// every vertex), scale with the map, and show a folded corner and a
    /// prism given upside down.
    #[test]
    fn prism_corners_show_folds_and_flips() {
        let at: Vec<[f64; 3]> = Shape::Prism.vertices().to_vec();
        let prism = SolidCell::Prism([0, 1, 2, 3, 4, 5]);
        assert_eq!(prism.corner_jacobians(&at), vec![1.0; 6]);
        let stretched: Vec<[f64; 3]> = at.iter().map(|x| [2.0 * x[0], x[1], 3.0 * x[2]]).collect();
        assert_eq!(prism.corner_jacobians(&stretched), vec![6.0; 6]);
        // one top corner pushed below the bottom: that corner folds
        let mut folded = at.clone();
        folded[4][2] = -0.5;
        let j = prism.corner_jacobians(&folded);
        assert!(j[1] < 0.0 && j[4] < 0.0 && j[0] > 0.0, "{j:?}");
        let upside_down = SolidCell::Prism([3, 4, 5, 0, 1, 2]);
        assert!(upside_down.corner_jacobians(&at).iter().all(|&j| j < 0.0));
        let m = MixedSolidMesh { nodes: folded, cells: vec![prism, SolidCell::Tet([0, 1, 2, 3])], faces: Vec::new(), part_names: Vec::new() };
        assert_eq!((m.invalid_cells(), m.count(Shape::Prism)), (vec![0], 1));
    }

    /// The corner Jacobians of the reference pyramid and hex are 1, scale
    /// with a stretch, and show an apex pushed through the base and a hex
    /// corner folded in.
    #[test]
    fn pyramid_and_hex_corners_show_folds() {
        for shape in [Shape::Pyramid, Shape::Hexahedron] {
            let at: Vec<[f64; 3]> = shape.vertices().to_vec();
            let cell = SolidCell::from_nodes(&(0..at.len()).collect::<Vec<_>>()).unwrap();
            assert_eq!(cell.shape(), shape);
            assert!(cell.corner_jacobians(&at).iter().all(|&j| (j - 1.0).abs() < 1e-15), "{shape:?}");
            let stretched: Vec<[f64; 3]> = at.iter().map(|x| [2.0 * x[0], x[1], 3.0 * x[2]]).collect();
            assert!(cell.corner_jacobians(&stretched).iter().all(|&j| (j - 6.0).abs() < 1e-14), "{shape:?}");
        }
        let mut at: Vec<[f64; 3]> = Shape::Pyramid.vertices().to_vec();
        at[4][2] = -0.5;
        assert!(SolidCell::Pyramid([0, 1, 2, 3, 4]).corner_jacobians(&at).iter().all(|&j| j < 0.0));
        let mut at: Vec<[f64; 3]> = Shape::Hexahedron.vertices().to_vec();
        at[6] = [0.2, 0.2, 0.2];
        let j = SolidCell::Hex(std::array::from_fn(|k| k)).corner_jacobians(&at);
        assert!(j[6] < 0.0 && j[0] > 0.0, "{j:?}");
        assert_eq!(SolidCell::from_nodes(&[0, 1, 2]), None);
    }
}
