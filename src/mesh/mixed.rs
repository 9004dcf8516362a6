//! A plane mesh of quadrilaterals and triangles together: Gmsh's
//! boundary-layer quads with triangles outside. Cells keep the file's
//! order (so the curved cell `c` is the file's element `c`), each with
//! its own kind.

use super::element::Shape;
use super::linear::{cut_quad, orientation_flips, BoundaryEdge, BoundaryFace, HexMesh, Point2, Point3, QuadMesh, TetMesh, TriMesh};

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

    /// A structured `nx × ny` box `[lo, hi]` ([`QuadMesh::structured_box`]'s
    /// nodes and sides) of quads and triangles in a checkerboard: the cell
    /// (i, j) is a quad where i + j is even, else two triangles cut along
    /// its diagonal from the lower left corner. Every kind meets the other
    /// across an edge.
    pub fn structured_box(lo: Point2, hi: Point2, nx: usize, ny: usize) -> MixedPlaneMesh {
        let QuadMesh { nodes, cells: quads, edges, part_names } = QuadMesh::structured_box(lo, hi, nx, ny);
        let mut cells = Vec::with_capacity(2 * quads.len());
        for (c, &q) in quads.iter().enumerate() {
            if (c % nx + c / nx).is_multiple_of(2) {
                cells.push(PlaneCell::Quad(q));
            } else {
                cells.extend(cut_quad(q).map(PlaneCell::Triangle));
            }
        }
        MixedPlaneMesh { nodes, cells, edges, part_names }
    }

    /// The mesh cut into triangles (quads by [`cut_quad`]: any diagonal
    /// will do, as a bilinear quad is valid exactly when all four of its
    /// corner triangles are positive), and the cell each was cut from.
    pub fn triangles(&self) -> (TriMesh, Vec<usize>) {
        let (mut cells, mut owner) = (Vec::with_capacity(2 * self.cells.len()), Vec::with_capacity(2 * self.cells.len()));
        for (c, cell) in self.cells.iter().enumerate() {
            match *cell {
                PlaneCell::Triangle(t) => cells.push(t),
                PlaneCell::Quad(q) => cells.extend(cut_quad(q)),
            }
            owner.resize(cells.len(), c);
        }
        (TriMesh { nodes: self.nodes.clone(), cells, edges: self.edges.clone(), part_names: self.part_names.clone() }, owner)
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

/// The three tetrahedra of a (sub-)prism with corners `v` (Gmsh's order,
/// positively oriented), each quad face cut along the diagonal through its
/// smallest node number, so that neighbours cut a shared face alike
/// (Dompierre, Labbé, Vallet & Camarero, "How to subdivide pyramids,
/// prisms and hexaedra into tetrahedra", 1999). Every tetrahedron is
/// oriented like the prism.
pub fn prism_tets(v: [usize; 6]) -> [[usize; 4]; 3] {
    // turn the prism (rotations of the triangle; top and bottom swapped
    // with a mirror, which keeps the orientation) until its smallest
    // node is vertex 0
    const TURNS: [[usize; 6]; 6] = [[0, 1, 2, 3, 4, 5], [1, 2, 0, 4, 5, 3], [2, 0, 1, 5, 3, 4], [3, 5, 4, 0, 2, 1], [4, 3, 5, 1, 0, 2], [5, 4, 3, 2, 1, 0]];
    let low = (0..6).min_by_key(|&a| v[a]).expect("six corners");
    let r = TURNS[low].map(|a| v[a]);
    if r[1].min(r[5]) < r[2].min(r[4]) {
        [[r[0], r[1], r[2], r[5]], [r[0], r[1], r[5], r[4]], [r[0], r[4], r[5], r[3]]]
    } else {
        [[r[0], r[1], r[2], r[4]], [r[0], r[4], r[2], r[5]], [r[0], r[4], r[5], r[3]]]
    }
}

/// The two tetrahedra of a (sub-)pyramid with corners `v` (base, then
/// apex; positively oriented), its base cut along the diagonal through
/// its smallest node number ([`prism_tets`]'s rule), each oriented like
/// the pyramid.
pub fn pyramid_tets(v: [usize; 5]) -> [[usize; 4]; 2] {
    let [a, b] = cut_quad([v[0], v[1], v[2], v[3]]);
    [[a[0], a[1], a[2], v[4]], [b[0], b[1], b[2], v[4]]]
}

/// The six pyramids of a (sub-)hex with corners `h` (Gmsh's order,
/// positively oriented) and a node `centre` inside: one on each face,
/// apex at the centre, each oriented like the hex.
pub fn hex_pyramids(h: [usize; 8], centre: usize) -> impl Iterator<Item = [usize; 5]> {
    // the faces run counter-clockwise seen from outside: reversed, seen
    // from the centre
    Shape::Hexahedron.faces().iter().map(move |(_, f)| [h[f[0]], h[f[3]], h[f[2]], h[f[1]], centre])
}

/// The twelve tetrahedra of a (sub-)hex with corners `h` (Gmsh's order,
/// positively oriented) and a node `centre` inside: its
/// [`hex_pyramids`], each cut by [`pyramid_tets`].
pub fn hex_tets(h: [usize; 8], centre: usize) -> impl Iterator<Item = [usize; 4]> {
    hex_pyramids(h, centre).flat_map(pyramid_tets)
}

/// The six tetrahedra of a hex `h` (Gmsh's order, positively oriented)
/// along its diagonal from corner 0 to corner 6: one per order in which a
/// path along the edges takes the three axes, each oriented like the hex.
fn kuhn_tets(h: &[usize; 8]) -> [[usize; 4]; 6] {
    // the corner at bits (x, y, z)
    let at = |b: [usize; 3]| h[4 * b[2] + [[0, 3], [1, 2]][b[0]][b[1]]];
    // even orders of the axes first: the odd ones swap the last two corners
    const ORDERS: [[usize; 3]; 6] = [[0, 1, 2], [1, 2, 0], [2, 0, 1], [0, 2, 1], [2, 1, 0], [1, 0, 2]];
    std::array::from_fn(|k| {
        let [a, b, _] = ORDERS[k];
        let mut bits = [0; 3];
        let v0 = at(bits);
        bits[a] = 1;
        let v1 = at(bits);
        bits[b] = 1;
        let (v2, v3) = (at(bits), h[6]);
        if k < 3 {
            [v0, v1, v2, v3]
        } else {
            [v0, v1, v3, v2]
        }
    })
}

/// The mean of the nodes `of`.
fn mean_of(of: &[usize], nodes: &[Point3]) -> Point3 {
    std::array::from_fn(|d| of.iter().map(|&v| nodes[v][d]).sum::<f64>() / of.len() as f64)
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

    /// A structured `n[0] × n[1] × n[2]` brick `[lo, hi]` of `kind`
    /// cells ([`HexMesh::structured_box`]'s nodes and faces, parts named as
    /// in [`super::BOX_FACES`]), or `None` for a kind that is not a solid's:
    /// - hexahedra as they are;
    /// - prisms: each hex cut in two along the diagonal of its bottom
    ///   square from the lower corner, the bottom and top faces into
    ///   triangles alike;
    /// - pyramids: six per hex, one on each face, their apex at a new node
    ///   at the hex's centre;
    /// - tetrahedra: six per hex along its diagonal from the lower to the
    ///   upper corner (Kuhn's cut: every face cut on its diagonal through
    ///   the lower corner, so neighbours agree), boundary squares alike.
    pub fn structured_box(lo: Point3, hi: Point3, n: [usize; 3], kind: Shape) -> Option<MixedSolidMesh> {
        match kind {
            Shape::Hexahedron => Some(Self::hexes_and_prisms(lo, hi, n, |_, _| false)),
            Shape::Prism => Some(Self::hexes_and_prisms(lo, hi, n, |_, _| true)),
            Shape::Pyramid => {
                let HexMesh { mut nodes, cells: hexes, faces, part_names } = HexMesh::structured_box(lo, hi, n);
                let mut cells = Vec::with_capacity(6 * hexes.len());
                for h in &hexes {
                    nodes.push(mean_of(&h[..], &nodes));
                    cells.extend(hex_pyramids(*h, nodes.len() - 1).map(SolidCell::Pyramid));
                }
                Some(MixedSolidMesh { nodes, cells, faces: faces.iter().map(|f| (f.nodes.to_vec(), f.part)).collect(), part_names })
            }
            Shape::Tetrahedron => {
                let HexMesh { nodes, cells: hexes, faces, part_names } = HexMesh::structured_box(lo, hi, n);
                let cells = hexes.iter().flat_map(kuhn_tets).map(SolidCell::Tet).collect();
                // the structured box numbers its nodes lexicographically: a
                // square's smallest node is its lower corner
                let faces = faces.iter().flat_map(|f| cut_quad(f.nodes).map(|t| (t.to_vec(), f.part))).collect();
                Some(MixedSolidMesh { nodes, cells, faces, part_names })
            }
            _ => None,
        }
    }

    /// A structured `n[0] × n[1] × n[2]` brick `[lo, hi]` of hexes and
    /// prisms in columns along z, the column (i, j) of hexes where i + j
    /// is even, else of prisms as in [`MixedSolidMesh::structured_box`]:
    /// each kind meets the other across the quads of its sides.
    pub fn hex_prism_box(lo: Point3, hi: Point3, n: [usize; 3]) -> MixedSolidMesh {
        Self::hexes_and_prisms(lo, hi, n, |i, j| (i + j) % 2 == 1)
    }

    /// [`HexMesh::structured_box`] with the columns (i, j) where `prism`
    /// holds cut into two prisms each (the bottom square along its
    /// diagonal from the lower corner, the column's bottom and top faces
    /// alike).
    fn hexes_and_prisms(lo: Point3, hi: Point3, n: [usize; 3], prism: impl Fn(usize, usize) -> bool) -> MixedSolidMesh {
        let HexMesh { nodes, cells: hexes, faces: quads, part_names } = HexMesh::structured_box(lo, hi, n);
        // the column of a cell or a bottom/top face, by its lower corner
        let column = |lower: usize| (lower % (n[0] + 1), lower / (n[0] + 1) % (n[1] + 1));
        let in_prisms = |lower: usize| {
            let (i, j) = column(lower);
            prism(i, j)
        };
        let cells = hexes
            .iter()
            .flat_map(|h| if in_prisms(h[0]) { [[h[0], h[1], h[2], h[4], h[5], h[6]], [h[0], h[2], h[3], h[4], h[6], h[7]]].map(SolidCell::Prism).to_vec() } else { vec![SolidCell::Hex(*h)] })
            .collect();
        let faces = quads
            .iter()
            .flat_map(|f| {
                let lower = *f.nodes.iter().min().expect("four corners");
                // the zmin and zmax faces of prism columns are triangles
                if f.part >= 4 && in_prisms(lower) {
                    cut_quad(f.nodes).map(|t| (t.to_vec(), f.part)).to_vec()
                } else {
                    vec![(f.nodes.to_vec(), f.part)]
                }
            })
            .collect();
        MixedSolidMesh { nodes, cells, faces, part_names }
    }

    /// The mesh as a [`TetMesh`] if all its cells are tetrahedra and its
    /// boundary faces triangles.
    pub fn to_tet_mesh(&self) -> Option<TetMesh> {
        let cells = self.cells.iter().map(|c| if let SolidCell::Tet(t) = c { Some(*t) } else { None }).collect::<Option<Vec<_>>>()?;
        let faces = self.faces.iter().map(|(f, part)| Some(BoundaryFace { nodes: <[usize; 3]>::try_from(f.as_slice()).ok()?, part: *part })).collect::<Option<Vec<_>>>()?;
        Some(TetMesh { nodes: self.nodes.clone(), cells, faces, part_names: self.part_names.clone() })
    }

    /// The mesh cut into tetrahedra (prisms by [`prism_tets`], pyramids by
    /// [`pyramid_tets`], hexes by [`hex_tets`] about a new node at each
    /// one's centre, after the mesh's nodes), its boundary quads by
    /// [`cut_quad`] as the cells beside them are; and the cell each
    /// tetrahedron was cut from.
    pub fn tetrahedra(&self) -> (TetMesh, Vec<usize>) {
        let mut nodes = self.nodes.clone();
        let (mut cells, mut owner) = (Vec::with_capacity(3 * self.cells.len()), Vec::with_capacity(3 * self.cells.len()));
        for (c, cell) in self.cells.iter().enumerate() {
            match *cell {
                SolidCell::Tet(t) => cells.push(t),
                SolidCell::Prism(v) => cells.extend(prism_tets(v)),
                SolidCell::Pyramid(v) => cells.extend(pyramid_tets(v)),
                SolidCell::Hex(h) => {
                    nodes.push(mean_of(&h[..], &nodes));
                    cells.extend(hex_tets(h, nodes.len() - 1));
                }
            }
            owner.resize(cells.len(), c);
        }
        let faces = self
            .faces
            .iter()
            .flat_map(|(f, part)| match f[..] {
                [a, b, c, d] => cut_quad([a, b, c, d]).map(|t| BoundaryFace { nodes: t, part: *part }).to_vec(),
                _ => vec![BoundaryFace { nodes: [f[0], f[1], f[2]], part: *part }],
            })
            .collect();
        (TetMesh { nodes, cells, faces, part_names: self.part_names.clone() }, owner)
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

    /// The checkerboard box of quads and triangles: positive cells that
    /// fill it, every inner edge held by two cells (so each kind meets the
    /// other), and its triangles the same as its cut's where a triangle
    /// was, quads cut in two there.
    #[test]
    fn the_mixed_plane_box_is_conforming_and_cut_into_its_triangles() {
        use std::collections::HashMap;
        let (lo, hi) = ([-1.0, 0.5], [2.0, 1.5]);
        let m = MixedPlaneMesh::structured_box(lo, hi, 3, 2);
        assert_eq!((m.count(Shape::Quadrilateral), m.count(Shape::Triangle)), (3, 6));
        let mut area = 0.0;
        let mut held: HashMap<[usize; 2], usize> = HashMap::new();
        for c in &m.cells {
            let v = c.nodes();
            let a = match *c {
                PlaneCell::Quad(q) => crate::mesh::linear::polygon_area(&q.map(|n| m.nodes[n])),
                PlaneCell::Triangle(t) => crate::mesh::linear::polygon_area(&t.map(|n| m.nodes[n])),
            };
            assert!(a > 0.0, "{c:?}");
            area += a;
            for k in 0..v.len() {
                let (a, b) = (v[k], v[(k + 1) % v.len()]);
                *held.entry([a.min(b), a.max(b)]).or_default() += 1;
            }
        }
        assert!((area - 3.0).abs() < 1e-14, "{area}");
        assert_eq!(held.values().filter(|&&h| h == 1).count(), m.edges.len());
        assert!(held.values().all(|&h| h <= 2));
        let (tris, owner) = m.triangles();
        assert_eq!((tris.cells.len(), owner.len()), (12, 12));
        for (t, &c) in tris.cells.iter().zip(&owner) {
            assert!(t.iter().all(|n| m.cells[c].nodes().contains(n)), "{t:?} not of {:?}", m.cells[c]);
            assert!(crate::mesh::linear::polygon_area(&t.map(|n| m.nodes[n])) > 0.0);
        }
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

    /// Every kind's brick is made of positive cells that fill it, every
    /// cell face is held twice or is a boundary face of the part it is on.
    #[test]
    fn bricks_of_every_solid_kind_are_conforming_and_fill_the_brick() {
        use std::collections::HashMap;
        let (lo, hi, n) = ([0.0, -1.0, 2.0], [1.0, 1.5, 2.75], [3, 2, 2]);
        let expected = [(Shape::Tetrahedron, 72), (Shape::Pyramid, 72), (Shape::Prism, 24), (Shape::Hexahedron, 12)];
        let of_one_kind = expected.map(|(kind, count)| (format!("{kind:?}"), MixedSolidMesh::structured_box(lo, hi, n, kind).unwrap(), vec![(kind, count)]));
        // columns (i, j) of the 3 × 2 base: (0,0) (2,0) (1,1) hexes, the
        // other three prisms
        let mixed = ("mixed".to_string(), MixedSolidMesh::hex_prism_box(lo, hi, n), vec![(Shape::Hexahedron, 6), (Shape::Prism, 12)]);
        for (kind, m, counts) in of_one_kind.into_iter().chain([mixed]) {
            for &(shape, count) in &counts {
                assert_eq!(m.count(shape), count, "{kind} {shape:?}");
            }
            assert_eq!(m.cells.len(), counts.iter().map(|c| c.1).sum::<usize>(), "{kind}");
            let mut volume = 0.0;
            let mut held: HashMap<Vec<usize>, (usize, Vec<usize>)> = HashMap::new();
            for c in &m.cells {
                // affine cells: det J is the same at every corner
                let j = c.corner_jacobians(&m.nodes);
                assert!(j.iter().all(|&x| x > 0.0 && (x - j[0]).abs() < 1e-12 * j[0]), "{kind:?} {j:?}");
                volume += j[0] * c.shape().volume();
                for f in c.faces() {
                    let mut key = f.clone();
                    key.sort_unstable();
                    held.entry(key).or_insert((0, f)).0 += 1;
                }
            }
            assert!((volume - 1.0 * 2.5 * 0.75).abs() < 1e-12, "{kind:?} {volume}");
            let once: Vec<&Vec<usize>> = held.values().filter(|h| h.0 == 1).map(|h| &h.1).collect();
            assert!(held.values().all(|h| h.0 <= 2));
            assert_eq!(once.len(), m.faces.len(), "{kind:?}");
            for (f, part) in &m.faces {
                let mut key = f.clone();
                key.sort_unstable();
                let (count, cell_face) = &held[&key];
                // the boundary face is the cell's, in the same turn
                let turn = (0..f.len()).find(|&r| (0..f.len()).all(|k| f[(k + r) % f.len()] == cell_face[k]));
                assert!(*count == 1 && turn.is_some(), "{kind:?} {f:?}");
                // on the brick face of its part
                let (axis, side) = (part / 2, part % 2);
                let plane = if side == 0 { lo[axis] } else { hi[axis] };
                assert!(f.iter().all(|&v| m.nodes[v][axis] == plane), "{kind:?} {f:?} {part}");
            }
        }
        assert_eq!(MixedSolidMesh::structured_box(lo, hi, n, Shape::Triangle), None);
        assert!(MixedSolidMesh::structured_box(lo, hi, n, Shape::Tetrahedron).unwrap().to_tet_mesh().is_some());
        assert!(MixedSolidMesh::structured_box(lo, hi, n, Shape::Prism).unwrap().to_tet_mesh().is_none());
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
