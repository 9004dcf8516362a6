//! The reference shapes of elements, as data (MFEM's `Geometry::Constants`):
//! their dimension, vertices, edges and faces. Everything that depends on
//! the kind of an element asks this table instead of assuming the
//! dimension decides it.
//!
//! Vertices are numbered as Gmsh numbers them (`MTriangle.h`,
//! `MTetrahedron.h`, `MPrism.h`, `MPyramid.h`, `MQuadrangle.h`,
//! `MHexahedron.h`), which is also the order of VTK's linear cells. The
//! edge and face tables are Gmsh's (`edges_tri`, `edges_tetra`,
//! `faces_tetra`, … in those headers), because Gmsh's high-order node
//! numbers follow them; its faces run counter-clockwise seen from outside.
//!
//! Reference cells (ours; Gmsh's differ where noted, always by an affine
//! map):
//! - line, quadrilateral, hexahedron: `[0,1]^d` (Gmsh `[-1,1]^d`,
//!   VTK `[0,1]^d`);
//! - triangle, tetrahedron: the unit simplex (Gmsh's and VTK's own);
//! - prism: the unit triangle × `[0,1]` (Gmsh: × `[-1,1]`; VTK's wedge is
//!   ours);
//! - pyramid: the base `[0,1]²` at z = 0 and the apex at `(½, ½, 1)`, over
//!   the centre of the base. This is Gmsh's pyramid (base `[-1,1]²`, apex
//!   `(0,0,1)`) under `x ↦ (x+1)/2`, `y ↦ (y+1)/2`, z kept: a right
//!   pyramid whose four lateral faces are congruent, so the symmetries of
//!   the square are symmetries of the cell. VTK's linear `vtkPyramid` puts
//!   its parametric apex at `(0,0,1)` instead (MFEM too); its coordinates
//!   `(r,s,t)` are ours by the shear `(r + t/2, s + t/2, t)`.

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
    /// The square `[0,1]²` at height 0 below the apex `(½, ½, 1)`.
    Pyramid,
}

/// A face of a reference cell: its shape and its vertices (numbers of the
/// cell's vertices) in cyclic order, counter-clockwise seen from outside
/// the cell (a 2-D cell's one face is its own loop).
pub type Face = (Shape, &'static [usize]);

const fn tri(vertices: &'static [usize]) -> Face {
    (Shape::Triangle, vertices)
}

const fn quad(vertices: &'static [usize]) -> Face {
    (Shape::Quadrilateral, vertices)
}

const fn seg(vertices: &'static [usize]) -> Face {
    (Shape::Line, vertices)
}

const fn node(vertices: &'static [usize]) -> Face {
    (Shape::Point, vertices)
}

const LINE_VERTICES: [[f64; 3]; 2] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
const TRIANGLE_VERTICES: [[f64; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
const QUAD_VERTICES: [[f64; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
const TET_VERTICES: [[f64; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
const HEX_VERTICES: [[f64; 3]; 8] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [1.0, 1.0, 1.0],
    [0.0, 1.0, 1.0],
];
const PRISM_VERTICES: [[f64; 3]; 6] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
];
const PYRAMID_VERTICES: [[f64; 3]; 5] =
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.5, 0.5, 1.0]];

// Gmsh's edge tables: edges_tri, edges_quad, edges_tetra, edges_hexa,
// edges_prism, edges_pyramid.
const LINE_EDGES: [[usize; 2]; 1] = [[0, 1]];
const TRIANGLE_EDGES: [[usize; 2]; 3] = [[0, 1], [1, 2], [2, 0]];
const QUAD_EDGES: [[usize; 2]; 4] = [[0, 1], [1, 2], [2, 3], [3, 0]];
const TET_EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [2, 0], [3, 0], [3, 2], [3, 1]];
const HEX_EDGES: [[usize; 2]; 12] =
    [[0, 1], [0, 3], [0, 4], [1, 2], [1, 5], [2, 3], [2, 6], [3, 7], [4, 5], [4, 7], [5, 6], [6, 7]];
const PRISM_EDGES: [[usize; 2]; 9] = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 4], [2, 5], [3, 4], [3, 5], [4, 5]];
const PYRAMID_EDGES: [[usize; 2]; 8] = [[0, 1], [0, 3], [0, 4], [1, 2], [1, 4], [2, 3], [2, 4], [3, 4]];

// Gmsh's face tables: faces_tetra, faces_hexa, faces_prism,
// faces_pyramid; a 2-D cell's one face is itself.
const TRIANGLE_FACES: [Face; 1] = [tri(&[0, 1, 2])];
const QUAD_FACES: [Face; 1] = [quad(&[0, 1, 2, 3])];
const TET_FACES: [Face; 4] = [tri(&[0, 2, 1]), tri(&[0, 1, 3]), tri(&[0, 3, 2]), tri(&[3, 1, 2])];
const HEX_FACES: [Face; 6] = [
    quad(&[0, 3, 2, 1]),
    quad(&[0, 1, 5, 4]),
    quad(&[0, 4, 7, 3]),
    quad(&[1, 2, 6, 5]),
    quad(&[2, 3, 7, 6]),
    quad(&[4, 5, 6, 7]),
];
const PRISM_FACES: [Face; 5] =
    [tri(&[0, 2, 1]), tri(&[3, 4, 5]), quad(&[0, 1, 4, 3]), quad(&[0, 3, 5, 2]), quad(&[1, 2, 5, 4])];
const PYRAMID_FACES: [Face; 5] =
    [tri(&[0, 1, 4]), tri(&[3, 0, 4]), tri(&[1, 2, 4]), tri(&[2, 3, 4]), quad(&[0, 3, 2, 1])];

// The facets (faces of dimension d − 1) of 1-D and 2-D cells: the ends of
// a line (its outward "loop" is its vertex); the edges of a polygon, which
// run counter-clockwise, so the outward normal is the tangent turned
// clockwise.
const LINE_FACETS: [Face; 2] = [node(&[0]), node(&[1])];
const TRIANGLE_FACETS: [Face; 3] = [seg(&[0, 1]), seg(&[1, 2]), seg(&[2, 0])];
const QUAD_FACETS: [Face; 4] = [seg(&[0, 1]), seg(&[1, 2]), seg(&[2, 3]), seg(&[3, 0])];

impl Shape {
    /// Every shape, in declaration order.
    pub const ALL: [Shape; 8] = [
        Shape::Point,
        Shape::Line,
        Shape::Triangle,
        Shape::Quadrilateral,
        Shape::Tetrahedron,
        Shape::Hexahedron,
        Shape::Prism,
        Shape::Pyramid,
    ];

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

    /// The reference coordinates of the vertices, in Gmsh's (and VTK's
    /// linear) order; coordinates beyond [`Shape::dim`] are 0.
    pub fn vertices(self) -> &'static [[f64; 3]] {
        match self {
            Shape::Point => &LINE_VERTICES[..1],
            Shape::Line => &LINE_VERTICES,
            Shape::Triangle => &TRIANGLE_VERTICES,
            Shape::Quadrilateral => &QUAD_VERTICES,
            Shape::Tetrahedron => &TET_VERTICES,
            Shape::Hexahedron => &HEX_VERTICES,
            Shape::Prism => &PRISM_VERTICES,
            Shape::Pyramid => &PYRAMID_VERTICES,
        }
    }

    /// The edges as (first, second) vertex numbers, in Gmsh's order and
    /// direction (its high-order edge nodes run from first to second).
    pub fn edges(self) -> &'static [[usize; 2]] {
        match self {
            Shape::Point => &[],
            Shape::Line => &LINE_EDGES,
            Shape::Triangle => &TRIANGLE_EDGES,
            Shape::Quadrilateral => &QUAD_EDGES,
            Shape::Tetrahedron => &TET_EDGES,
            Shape::Hexahedron => &HEX_EDGES,
            Shape::Prism => &PRISM_EDGES,
            Shape::Pyramid => &PYRAMID_EDGES,
        }
    }

    /// The 2-dimensional faces in Gmsh's order, each counter-clockwise
    /// seen from outside; a triangle's or quadrilateral's one face is
    /// itself, points and lines have none.
    pub fn faces(self) -> &'static [Face] {
        match self {
            Shape::Point | Shape::Line => &[],
            Shape::Triangle => &TRIANGLE_FACES,
            Shape::Quadrilateral => &QUAD_FACES,
            Shape::Tetrahedron => &TET_FACES,
            Shape::Hexahedron => &HEX_FACES,
            Shape::Prism => &PRISM_FACES,
            Shape::Pyramid => &PYRAMID_FACES,
        }
    }

    /// The facets (the faces of dimension `dim − 1`, the boundary pieces):
    /// [`Shape::faces`] of a 3-D cell, the edges of a 2-D one (as
    /// [`Shape::Line`] faces, in [`Shape::edges`]'s order and direction,
    /// counter-clockwise), the two ends of a line; a point has none.
    pub fn facets(self) -> &'static [Face] {
        match self {
            Shape::Point => &[],
            Shape::Line => &LINE_FACETS,
            Shape::Triangle => &TRIANGLE_FACETS,
            Shape::Quadrilateral => &QUAD_FACETS,
            Shape::Tetrahedron | Shape::Hexahedron | Shape::Prism | Shape::Pyramid => self.faces(),
        }
    }

    /// The shape of every facet, for the shapes whose facets are all of one
    /// kind (line: point, triangle and quadrilateral: line, tetrahedron:
    /// triangle, hexahedron: quadrilateral).
    ///
    /// # Panics
    /// For a point (no facets) and for prisms and pyramids, whose facets
    /// are triangles and quadrilaterals (ask [`Shape::facets`]).
    pub fn facet_shape(self) -> Shape {
        match self {
            Shape::Line => Shape::Point,
            Shape::Triangle | Shape::Quadrilateral => Shape::Line,
            Shape::Tetrahedron => Shape::Triangle,
            Shape::Hexahedron => Shape::Quadrilateral,
            Shape::Point | Shape::Prism | Shape::Pyramid => {
                panic!("{self:?} has no single facet shape: see Shape::facets")
            }
        }
    }

    /// The number of nodes of the complete Lagrange element of order `p`
    /// (Gmsh's complete, not serendipity, elements): point 1, line `p+1`,
    /// triangle `(p+1)(p+2)/2`, quadrilateral `(p+1)²`, tetrahedron
    /// `(p+1)(p+2)(p+3)/6`, hexahedron `(p+1)³`, prism `(p+1)²(p+2)/2`,
    /// pyramid `(p+1)(p+2)(2p+3)/6` (layers of `1, 4, …, (p+1)²` nodes
    /// from the apex down: PYR_5, 14, 30, 55).
    pub fn num_nodes(self, p: usize) -> usize {
        let n = p + 1;
        match self {
            Shape::Point => 1,
            Shape::Line => n,
            Shape::Triangle => n * (n + 1) / 2,
            Shape::Quadrilateral => n * n,
            Shape::Tetrahedron => n * (n + 1) * (n + 2) / 6,
            Shape::Hexahedron => n * n * n,
            Shape::Prism => n * n * (n + 1) / 2,
            Shape::Pyramid => n * (n + 1) * (2 * n + 1) / 6,
        }
    }

    /// The cell shape of dimension `dim` whose order-`p` element has
    /// `count` nodes, if one has: the counts of the kinds of one dimension
    /// differ at every order (2D: 3, 4; 6, 9; 10, 16; 15, 25 — 3D: tet,
    /// pyramid, prism, hex 4, 5, 6, 8; 10, 14, 18, 27; …), so a mixed mesh
    /// tells each cell's kind by its node count.
    pub fn with_nodes(dim: usize, p: usize, count: usize) -> Option<Shape> {
        let kinds: &[Shape] = match dim {
            1 => &[Shape::Line],
            2 => &[Shape::Triangle, Shape::Quadrilateral],
            3 => &[Shape::Tetrahedron, Shape::Hexahedron, Shape::Prism, Shape::Pyramid],
            _ => &[],
        };
        kinds.iter().copied().find(|s| s.num_nodes(p) == count)
    }

    /// The measure (length, area, volume) of the reference cell; 1 for a
    /// point.
    pub fn volume(self) -> f64 {
        match self {
            Shape::Point | Shape::Line | Shape::Quadrilateral | Shape::Hexahedron => 1.0,
            Shape::Triangle | Shape::Prism => 0.5,
            Shape::Tetrahedron => 1.0 / 6.0,
            Shape::Pyramid => 1.0 / 3.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| a[i] - b[i])
    }

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        (0..3).map(|i| a[i] * b[i]).sum()
    }

    fn centroid(points: impl Iterator<Item = [f64; 3]>) -> [f64; 3] {
        let (mut c, mut n) = ([0.0; 3], 0.0);
        for x in points {
            (0..3).for_each(|i| c[i] += x[i]);
            n += 1.0;
        }
        c.map(|v| v / n)
    }

    /// Newell's normal of a polygon (exact for a planar one, and its
    /// direction follows the loop's orientation).
    fn newell(loop_: &[[f64; 3]]) -> [f64; 3] {
        let mut n = [0.0; 3];
        for (k, a) in loop_.iter().enumerate() {
            let b = loop_[(k + 1) % loop_.len()];
            n[0] += (a[1] - b[1]) * (a[2] + b[2]);
            n[1] += (a[2] - b[2]) * (a[0] + b[0]);
            n[2] += (a[0] - b[0]) * (a[1] + b[1]);
        }
        n
    }

    const SOLIDS: [Shape; 4] = [Shape::Tetrahedron, Shape::Hexahedron, Shape::Prism, Shape::Pyramid];

    fn is_edge(shape: Shape, a: usize, b: usize) -> bool {
        shape.edges().iter().any(|&[x, y]| (x, y) == (a, b) || (x, y) == (b, a))
    }

    #[test]
    fn faces_point_outward_and_are_bounded_by_cell_edges() {
        for shape in SOLIDS {
            let v = shape.vertices();
            let cell = centroid(v.iter().copied());
            for (f, face) in shape.faces().iter().enumerate() {
                assert_eq!(face.1.len(), face.0.vertices().len(), "{shape:?} face {f}");
                let pts: Vec<[f64; 3]> = face.1.iter().map(|&k| v[k]).collect();
                let n = newell(&pts);
                let c = centroid(pts.iter().copied());
                assert!(dot(n, sub(c, cell)) > 0.1, "{shape:?} face {f} {:?} points inward", face.1);
                // planar: every vertex in the plane through the centroid
                assert!(pts.iter().all(|&x| dot(n, sub(x, c)).abs() < 1e-15), "{shape:?} face {f} not planar");
                for k in 0..face.1.len() {
                    let (a, b) = (face.1[k], face.1[(k + 1) % face.1.len()]);
                    assert!(is_edge(shape, a, b), "{shape:?} face {f}: ({a},{b}) is no edge");
                }
            }
            // a closed, consistently oriented surface: every edge in two
            // faces, once in each direction
            for &[a, b] in shape.edges() {
                let runs = |x: usize, y: usize| {
                    shape.faces().iter().filter(|face| {
                        let l = face.1;
                        (0..l.len()).any(|k| l[k] == x && l[(k + 1) % l.len()] == y)
                    }).count()
                };
                assert_eq!((runs(a, b), runs(b, a)), (1, 1), "{shape:?} edge ({a},{b})");
            }
            let (nv, ne, nf) = (v.len() as i64, shape.edges().len() as i64, shape.faces().len() as i64);
            assert_eq!(nv - ne + nf, 2, "{shape:?}: Euler characteristic");
        }
    }

    #[test]
    fn polygon_facets_are_counter_clockwise_and_outward() {
        for shape in [Shape::Triangle, Shape::Quadrilateral] {
            let v = shape.vertices();
            let cell = centroid(v.iter().copied());
            assert_eq!(shape.facets().len(), shape.edges().len());
            for (facet, &[a, b]) in shape.facets().iter().zip(shape.edges()) {
                assert_eq!(*facet, (Shape::Line, &[a, b][..]));
                let t = sub(v[b], v[a]);
                let outward = [t[1], -t[0], 0.0];
                let mid = centroid([v[a], v[b]].into_iter());
                assert!(dot(outward, sub(mid, cell)) > 0.1, "{shape:?} edge ({a},{b})");
            }
            assert_eq!(v.len() as i64 - shape.edges().len() as i64 + shape.faces().len() as i64, 1);
        }
    }

    #[test]
    fn tables_agree_with_each_other() {
        for shape in Shape::ALL {
            let v = shape.vertices();
            assert_eq!(shape.num_nodes(1), v.len(), "{shape:?}");
            // vertices inside the unit cube, zero beyond the dimension
            assert!(v.iter().all(|x| x[shape.dim()..].iter().all(|&c| c == 0.0)));
            assert!(shape.edges().iter().flatten().all(|&k| k < v.len()));
            for facet in shape.facets() {
                assert_eq!(facet.0.dim() + 1, shape.dim(), "{shape:?}");
            }
        }
        // Gmsh's complete element sizes (TRI_15, TET_35, PRI_18/40/75,
        // PYR_14/30/55, HEX_125)
        assert_eq!(Shape::Triangle.num_nodes(4), 15);
        assert_eq!(Shape::Tetrahedron.num_nodes(4), 35);
        assert_eq!([2, 3, 4].map(|p| Shape::Prism.num_nodes(p)), [18, 40, 75]);
        assert_eq!([2, 3, 4].map(|p| Shape::Pyramid.num_nodes(p)), [14, 30, 55]);
        assert_eq!(Shape::Hexahedron.num_nodes(4), 125);
        assert_eq!(Shape::Tetrahedron.facet_shape(), Shape::Triangle);
        assert_eq!(Shape::Quadrilateral.facet_shape(), Shape::Line);
    }

    /// The volume from the faces (divergence theorem: V = Σ_f (c_f · n_f) / 3
    /// with Newell's area vector n_f): checks [`Shape::volume`] and that the
    /// pyramid's apex is where the docs say.
    #[test]
    fn volumes_from_the_boundary() {
        for shape in SOLIDS {
            let v = shape.vertices();
            let vol: f64 = shape.faces().iter().map(|face| {
                let pts: Vec<[f64; 3]> = face.1.iter().map(|&k| v[k]).collect();
                dot(centroid(pts.iter().copied()), newell(&pts)) / 2.0 / 3.0
            }).sum();
            assert!((vol - shape.volume()).abs() < 1e-15, "{shape:?}: {vol}");
        }
        assert_eq!(Shape::Pyramid.vertices()[4], [0.5, 0.5, 1.0]);
    }

    /// Each kind of a dimension is told by its node count at p = 1..=4
    /// (the counts of Gmsh's element types 3/2, 10/9, 36/21, 37/23 and
    /// 5/4/7/6, 12/11/14/13, 92/29/118/90, 93/30/119/91).
    #[test]
    fn node_counts_tell_the_kinds_of_a_dimension_apart() {
        let gmsh = [(2, [(3, 4), (6, 9), (10, 16), (15, 25)].as_slice()), (3, &[(4, 8), (10, 27), (20, 64), (35, 125)])];
        for (dim, counts) in gmsh {
            for (k, &(simplex, tensor)) in counts.iter().enumerate() {
                let p = k + 1;
                assert_eq!(Shape::with_nodes(dim, p, simplex), Some(if dim == 2 { Shape::Triangle } else { Shape::Tetrahedron }));
                assert_eq!(Shape::with_nodes(dim, p, tensor), Some(if dim == 2 { Shape::Quadrilateral } else { Shape::Hexahedron }));
            }
        }
        for (p, prism, pyramid) in [(1, 6, 5), (2, 18, 14), (3, 40, 30), (4, 75, 55)] {
            assert_eq!((Shape::with_nodes(3, p, prism), Shape::with_nodes(3, p, pyramid)), (Some(Shape::Prism), Some(Shape::Pyramid)));
        }
        assert_eq!(Shape::with_nodes(2, 2, 8), None);
    }

    #[test]
    #[should_panic(expected = "no single facet shape")]
    fn prisms_have_two_facet_shapes() {
        Shape::Prism.facet_shape();
    }
}
