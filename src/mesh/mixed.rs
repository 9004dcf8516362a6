//! The linear mesh of several kinds of cells: [`CurvedMesh`] at order 1,
//! as a file gives it (Gmsh's boundary-layer quads with triangles
//! outside; prism layers on walls with tetrahedra outside; hex-dominant
//! meshes with pyramids between hexes and tetrahedra), its cells in the
//! file's order (so the curved cell `c` is the file's element `c`).
//! What Algorithm 1 needs of it is here: its cut into simplices (on which
//! it solves), its orientation, its cells' corner Jacobians; and the
//! structured meshes of every kind the cases and tests use.

use super::element::Shape;
use super::linear::{cut_quad, orientation_flips, BoundaryFace, HexMesh, Point2, Point3, QuadMesh, TetMesh, TriMesh};
use super::CurvedMesh;
use smallvec::SmallVec;

/// A cell's vertices, its kind's count of them.
type Vertices = SmallVec<[usize; 8]>;

impl CurvedMesh<2> {
    /// A structured `nx × ny` box `[lo, hi]` ([`QuadMesh::structured_box`]'s
    /// nodes and sides) of quads and triangles in a checkerboard: the cell
    /// (i, j) is a quad where i + j is even, else two triangles cut along
    /// its diagonal from the lower left corner. Every kind meets the other
    /// across an edge.
    pub fn checkerboard(lo: Point2, hi: Point2, nx: usize, ny: usize) -> CurvedMesh<2> {
        let QuadMesh { nodes, cells: quads, edges, part_names } = QuadMesh::structured_box(lo, hi, nx, ny);
        let mut cells: Vec<(Shape, Vertices)> = Vec::with_capacity(2 * quads.len());
        for (c, q) in quads.iter().enumerate() {
            if (c % nx + c / nx).is_multiple_of(2) {
                cells.push((Shape::Quadrilateral, SmallVec::from_slice(q)));
            } else {
                cells.extend(cut_quad(*q).map(|t| (Shape::Triangle, SmallVec::from_slice(&t))));
            }
        }
        CurvedMesh::linear(nodes, cells, edges.iter().map(|e| (e.nodes, e.part)), part_names)
    }

    /// The linear mesh cut into triangles (quads by [`cut_quad`]: any
    /// diagonal will do, as a bilinear quad is valid exactly when all
    /// four of its corner triangles are positive), and the cell each was
    /// cut from.
    pub fn triangles(&self) -> (TriMesh, Vec<usize>) {
        let (mut cells, mut owner) = (Vec::with_capacity(2 * self.cells.len()), Vec::with_capacity(2 * self.cells.len()));
        for c in 0..self.cells.len() {
            match *self.vertices(c).as_slice() {
                [a, b, d] => cells.push([a, b, d]),
                [a, b, d, e] => cells.extend(cut_quad([a, b, d, e])),
                ref v => unreachable!("a plane cell of {} vertices", v.len()),
            }
            owner.resize(cells.len(), c);
        }
        (TriMesh { nodes: self.nodes.clone(), cells, edges: self.boundary_edges(), part_names: self.part_names.clone() }, owner)
    }

    /// Turns clockwise cells of a linear mesh counter-clockwise, quads
    /// and triangles made to agree across their shared edges (see
    /// [`super::QuadMesh::orient_counter_clockwise`]); returns how many.
    pub fn orient_counter_clockwise(&mut self) -> usize {
        let cells: Vec<Vertices> = (0..self.cells.len()).map(|c| self.vertices(c)).collect();
        let flip = orientation_flips(&cells.iter().map(|v| &v[..]).collect::<Vec<_>>(), &self.nodes);
        let mut turned = 0;
        for (c, (mut v, f)) in cells.into_iter().zip(flip).enumerate() {
            if f {
                // the same corners the other way round, from the same first
                v[1..].reverse();
                self.set_vertices(c, &v);
                turned += 1;
            }
        }
        turned
    }
}

/// The outward faces of a solid cell of `shape` with vertices `v`, each
/// in cyclic order ([`Shape::faces`]).
pub fn cell_faces(shape: Shape, v: &[usize]) -> Vec<Vec<usize>> {
    shape.faces().iter().map(|(_, f)| f.iter().map(|&k| v[k]).collect()).collect()
}

/// det J of the linear map of a solid cell of `shape` with vertices `v`
/// at each vertex (the triple product of the reference axes' images
/// there): only a tetrahedron's det J is constant, and the corners are
/// where a flat or twisted linear cell fails. A pyramid's det J does not
/// depend on the height (see [`crate::mesh::element::pyramid`]): its four
/// base corners tell.
pub fn corner_jacobians(shape: Shape, v: &[usize], at: &[Point3]) -> Vec<f64> {
    let x = |k: usize| at[v[k]];
    let e = |a: usize, b: usize| std::array::from_fn::<f64, 3, _>(|d| x(b)[d] - x(a)[d]);
    match shape {
        Shape::Tetrahedron => vec![triple(e(0, 1), e(0, 2), e(0, 3))],
        Shape::Prism => (0..6)
            .map(|v| {
                // ∂/∂ξ and ∂/∂η along the triangle of v's layer, ∂/∂ζ along
                // the vertical edge through v
                let o = 3 * (v / 3);
                triple(e(o, o + 1), e(o, o + 2), e(v % 3, v % 3 + 3))
            })
            .collect(),
        // the base's edges along x and y at the corner, and the edge up
        // to the apex
        Shape::Pyramid => vec![
            triple(e(0, 1), e(0, 3), e(0, 4)),
            triple(e(0, 1), e(1, 2), e(1, 4)),
            triple(e(3, 2), e(1, 2), e(2, 4)),
            triple(e(3, 2), e(0, 3), e(3, 4)),
        ],
        Shape::Hexahedron => (0..8)
            .map(|v| {
                // v's bits (x, y, z) and the corner across each axis
                let bits = [[0, 0], [1, 0], [1, 1], [0, 1]][v % 4];
                let corner = |x: usize, y: usize, z: usize| 4 * z + [[0, 3], [1, 2]][x][y];
                let (bx, by, bz) = (bits[0], bits[1], v / 4);
                triple(e(corner(0, by, bz), corner(1, by, bz)), e(corner(bx, 0, bz), corner(bx, 1, bz)), e(corner(bx, by, 0), corner(bx, by, 1)))
            })
            .collect(),
        _ => unreachable!("{shape:?} is not a solid"),
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

impl CurvedMesh<3> {
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
    pub fn brick(lo: Point3, hi: Point3, n: [usize; 3], kind: Shape) -> Option<CurvedMesh<3>> {
        match kind {
            Shape::Hexahedron => Some(Self::hexes_and_prisms(lo, hi, n, |_, _| false)),
            Shape::Prism => Some(Self::hexes_and_prisms(lo, hi, n, |_, _| true)),
            Shape::Pyramid => {
                let HexMesh { mut nodes, cells: hexes, faces, part_names } = HexMesh::structured_box(lo, hi, n);
                let mut cells = Vec::with_capacity(6 * hexes.len());
                for h in &hexes {
                    nodes.push(mean_of(&h[..], &nodes));
                    cells.extend(hex_pyramids(*h, nodes.len() - 1));
                }
                let cells = cells.into_iter().map(|v| (Shape::Pyramid, v));
                Some(CurvedMesh::linear(nodes, cells, faces.iter().map(|f| (f.nodes, f.part)), part_names))
            }
            Shape::Tetrahedron => {
                let HexMesh { nodes, cells: hexes, faces, part_names } = HexMesh::structured_box(lo, hi, n);
                let cells = hexes.iter().flat_map(kuhn_tets).map(|t| (Shape::Tetrahedron, t));
                // the structured box numbers its nodes lexicographically: a
                // square's smallest node is its lower corner
                let faces = faces.iter().flat_map(|f| cut_quad(f.nodes).map(|t| (t, f.part)));
                Some(CurvedMesh::linear(nodes, cells, faces, part_names))
            }
            _ => None,
        }
    }

    /// A structured `n[0] × n[1] × n[2]` brick `[lo, hi]` of hexes and
    /// prisms in columns along z, the column (i, j) of hexes where i + j
    /// is even, else of prisms as in [`CurvedMesh::brick`]: each kind
    /// meets the other across the quads of its sides.
    pub fn hex_prism_box(lo: Point3, hi: Point3, n: [usize; 3]) -> CurvedMesh<3> {
        Self::hexes_and_prisms(lo, hi, n, |i, j| (i + j) % 2 == 1)
    }

    /// [`HexMesh::structured_box`] with the columns (i, j) where `prism`
    /// holds cut into two prisms each (the bottom square along its
    /// diagonal from the lower corner, the column's bottom and top faces
    /// alike).
    fn hexes_and_prisms(lo: Point3, hi: Point3, n: [usize; 3], prism: impl Fn(usize, usize) -> bool) -> CurvedMesh<3> {
        let HexMesh { nodes, cells: hexes, faces: quads, part_names } = HexMesh::structured_box(lo, hi, n);
        // the column of a cell or a bottom/top face, by its lower corner
        let column = |lower: usize| (lower % (n[0] + 1), lower / (n[0] + 1) % (n[1] + 1));
        let in_prisms = |lower: usize| {
            let (i, j) = column(lower);
            prism(i, j)
        };
        let cells: Vec<(Shape, Vertices)> = hexes
            .iter()
            .flat_map(|h| {
                if in_prisms(h[0]) {
                    [[h[0], h[1], h[2], h[4], h[5], h[6]], [h[0], h[2], h[3], h[4], h[6], h[7]]].map(|v| (Shape::Prism, SmallVec::from_slice(&v))).to_vec()
                } else {
                    vec![(Shape::Hexahedron, SmallVec::from_slice(h))]
                }
            })
            .collect();
        let faces: Vec<(Vec<usize>, usize)> = quads
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
        CurvedMesh::linear(nodes, cells, faces, part_names)
    }

    /// The linear mesh cut into tetrahedra (prisms by [`prism_tets`],
    /// pyramids by [`pyramid_tets`], hexes by [`hex_tets`] about a new
    /// node at each one's centre, after the mesh's nodes), its boundary
    /// quads by [`cut_quad`] as the cells beside them are; and the cell
    /// each tetrahedron was cut from.
    pub fn tetrahedra(&self) -> (TetMesh, Vec<usize>) {
        let mut nodes = self.nodes.clone();
        let (mut cells, mut owner) = (Vec::with_capacity(3 * self.cells.len()), Vec::with_capacity(3 * self.cells.len()));
        for c in 0..self.cells.len() {
            let v = self.vertices(c);
            match self.cells.shape(c) {
                Shape::Tetrahedron => cells.push([v[0], v[1], v[2], v[3]]),
                Shape::Prism => cells.extend(prism_tets(std::array::from_fn(|k| v[k]))),
                Shape::Pyramid => cells.extend(pyramid_tets(std::array::from_fn(|k| v[k]))),
                Shape::Hexahedron => {
                    nodes.push(mean_of(&v, &nodes));
                    cells.extend(hex_tets(std::array::from_fn(|k| v[k]), nodes.len() - 1));
                }
                other => unreachable!("{other:?} is not a solid cell"),
            }
            owner.resize(cells.len(), c);
        }
        let faces = self
            .linear_facets()
            .into_iter()
            .flat_map(|(f, part)| match f[..] {
                [a, b, c, d] => cut_quad([a, b, c, d]).map(|t| BoundaryFace { nodes: t, part }).to_vec(),
                _ => vec![BoundaryFace { nodes: [f[0], f[1], f[2]], part }],
            })
            .collect();
        (TetMesh { nodes, cells, faces, part_names: self.part_names.clone() }, owner)
    }

    /// The cells of the linear mesh with det J ≤ 0 at a vertex.
    pub fn invalid_cells(&self) -> Vec<usize> {
        (0..self.cells.len()).filter(|&c| corner_jacobians(self.cells.shape(c), &self.vertices(c), &self.nodes).iter().any(|&j| j <= 0.0)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square split into a quad [0, ½] × [0, 1] and two triangles,
    /// some cells given clockwise.
    fn square() -> CurvedMesh<2> {
        let nodes = vec![[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 1.0], [1.0, 1.0]];
        let cells: [(Shape, &[usize]); 3] = [(Shape::Quadrilateral, &[0, 3, 4, 1]), (Shape::Triangle, &[1, 2, 5]), (Shape::Triangle, &[1, 4, 5])];
        CurvedMesh::linear(nodes, cells, Vec::<([usize; 2], usize)>::new(), Vec::new())
    }

    /// The vertices of every cell, in its kind's order.
    fn vertices<const D: usize>(m: &CurvedMesh<D>) -> Vec<Vec<usize>> {
        (0..m.cells.len()).map(|c| m.vertices(c).to_vec()).collect()
    }

    /// Orientation runs across the kinds: the clockwise quad and the
    /// clockwise triangle are turned (by their neighbour's order), the
    /// counter-clockwise triangle stays.
    #[test]
    fn quads_and_triangles_are_oriented_together() {
        let mut m = square();
        assert_eq!(m.orient_counter_clockwise(), 2);
        assert_eq!(vertices(&m), [vec![0, 1, 4, 3], vec![1, 2, 5], vec![1, 5, 4]]);
        // the quad's nodes in tensor order: its corners' lexicographic order
        assert_eq!(m.cells[0], [0, 1, 3, 4]);
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
        let m = CurvedMesh::checkerboard(lo, hi, 3, 2);
        assert_eq!((m.count(Shape::Quadrilateral), m.count(Shape::Triangle)), (3, 6));
        let mut area = 0.0;
        let mut held: HashMap<[usize; 2], usize> = HashMap::new();
        for v in vertices(&m) {
            let a = match v[..] {
                [a, b, c, d] => crate::mesh::linear::polygon_area(&[a, b, c, d].map(|n| m.nodes[n])),
                _ => crate::mesh::linear::polygon_area(&[v[0], v[1], v[2]].map(|n| m.nodes[n])),
            };
            assert!(a > 0.0, "{v:?}");
            area += a;
            for k in 0..v.len() {
                let (a, b) = (v[k], v[(k + 1) % v.len()]);
                *held.entry([a.min(b), a.max(b)]).or_default() += 1;
            }
        }
        assert!((area - 3.0).abs() < 1e-14, "{area}");
        assert_eq!(held.values().filter(|&&h| h == 1).count(), m.boundary.len());
        assert!(held.values().all(|&h| h <= 2));
        let (tris, owner) = m.triangles();
        assert_eq!((tris.cells.len(), owner.len()), (12, 12));
        for (t, &c) in tris.cells.iter().zip(&owner) {
            assert!(t.iter().all(|n| m.cells[c].contains(n)), "{t:?} not of {:?}", &m.cells[c]);
            assert!(crate::mesh::linear::polygon_area(&t.map(|n| m.nodes[n])) > 0.0);
        }
    }

    /// The corner Jacobians of a prism are the reference prism's (1 at
    /// every vertex), scale with the map, and show a folded corner and a
    /// prism given upside down.
    #[test]
    fn prism_corners_show_folds_and_flips() {
        let at: Vec<[f64; 3]> = Shape::Prism.vertices().to_vec();
        let prism = [0, 1, 2, 3, 4, 5];
        assert_eq!(corner_jacobians(Shape::Prism, &prism, &at), vec![1.0; 6]);
        let stretched: Vec<[f64; 3]> = at.iter().map(|x| [2.0 * x[0], x[1], 3.0 * x[2]]).collect();
        assert_eq!(corner_jacobians(Shape::Prism, &prism, &stretched), vec![6.0; 6]);
        // one top corner pushed below the bottom: that corner folds
        let mut folded = at.clone();
        folded[4][2] = -0.5;
        let j = corner_jacobians(Shape::Prism, &prism, &folded);
        assert!(j[1] < 0.0 && j[4] < 0.0 && j[0] > 0.0, "{j:?}");
        assert!(corner_jacobians(Shape::Prism, &[3, 4, 5, 0, 1, 2], &at).iter().all(|&j| j < 0.0));
        let cells: [(Shape, &[usize]); 2] = [(Shape::Prism, &prism), (Shape::Tetrahedron, &[0, 1, 2, 3])];
        let m = CurvedMesh::linear(folded, cells, Vec::<(Vec<usize>, usize)>::new(), Vec::new());
        assert_eq!((m.invalid_cells(), m.count(Shape::Prism)), (vec![0], 1));
    }

    /// Every kind's brick is made of positive cells that fill it, every
    /// cell face is held twice or is a boundary face of the part it is on.
    #[test]
    fn bricks_of_every_solid_kind_are_conforming_and_fill_the_brick() {
        use std::collections::HashMap;
        let (lo, hi, n) = ([0.0, -1.0, 2.0], [1.0, 1.5, 2.75], [3, 2, 2]);
        let expected = [(Shape::Tetrahedron, 72), (Shape::Pyramid, 72), (Shape::Prism, 24), (Shape::Hexahedron, 12)];
        let of_one_kind = expected.map(|(kind, count)| (format!("{kind:?}"), CurvedMesh::brick(lo, hi, n, kind).unwrap(), vec![(kind, count)]));
        // columns (i, j) of the 3 × 2 base: (0,0) (2,0) (1,1) hexes, the
        // other three prisms
        let mixed = ("mixed".to_string(), CurvedMesh::hex_prism_box(lo, hi, n), vec![(Shape::Hexahedron, 6), (Shape::Prism, 12)]);
        for (kind, m, counts) in of_one_kind.into_iter().chain([mixed]) {
            for &(shape, count) in &counts {
                assert_eq!(m.count(shape), count, "{kind} {shape:?}");
            }
            assert_eq!(m.cells.len(), counts.iter().map(|c| c.1).sum::<usize>(), "{kind}");
            let mut volume = 0.0;
            let mut held: HashMap<Vec<usize>, (usize, Vec<usize>)> = HashMap::new();
            for (c, v) in vertices(&m).iter().enumerate() {
                // affine cells: det J is the same at every corner
                let shape = m.cells.shape(c);
                let j = corner_jacobians(shape, v, &m.nodes);
                assert!(j.iter().all(|&x| x > 0.0 && (x - j[0]).abs() < 1e-12 * j[0]), "{kind:?} {j:?}");
                volume += j[0] * shape.volume();
                for f in cell_faces(shape, v) {
                    let mut key = f.clone();
                    key.sort_unstable();
                    held.entry(key).or_insert((0, f)).0 += 1;
                }
            }
            assert!((volume - 1.0 * 2.5 * 0.75).abs() < 1e-12, "{kind:?} {volume}");
            let once: Vec<&Vec<usize>> = held.values().filter(|h| h.0 == 1).map(|h| &h.1).collect();
            assert!(held.values().all(|h| h.0 <= 2));
            assert_eq!(once.len(), m.boundary.len(), "{kind:?}");
            for (f, part) in &m.linear_facets() {
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
        assert_eq!(CurvedMesh::brick(lo, hi, n, Shape::Triangle), None);
        assert!(CurvedMesh::brick(lo, hi, n, Shape::Tetrahedron).unwrap().to_solid::<4, 3>().is_some());
        assert!(CurvedMesh::brick(lo, hi, n, Shape::Prism).unwrap().to_solid::<4, 3>().is_none());
    }

    /// The corner Jacobians of the reference pyramid and hex are 1, scale
    /// with a stretch, and show an apex pushed through the base and a hex
    /// corner folded in.
    #[test]
    fn pyramid_and_hex_corners_show_folds() {
        for shape in [Shape::Pyramid, Shape::Hexahedron] {
            let at: Vec<[f64; 3]> = shape.vertices().to_vec();
            let cell: Vec<usize> = (0..at.len()).collect();
            assert!(corner_jacobians(shape, &cell, &at).iter().all(|&j| (j - 1.0).abs() < 1e-15), "{shape:?}");
            let stretched: Vec<[f64; 3]> = at.iter().map(|x| [2.0 * x[0], x[1], 3.0 * x[2]]).collect();
            assert!(corner_jacobians(shape, &cell, &stretched).iter().all(|&j| (j - 6.0).abs() < 1e-14), "{shape:?}");
        }
        let mut at: Vec<[f64; 3]> = Shape::Pyramid.vertices().to_vec();
        at[4][2] = -0.5;
        assert!(corner_jacobians(Shape::Pyramid, &[0, 1, 2, 3, 4], &at).iter().all(|&j| j < 0.0));
        let mut at: Vec<[f64; 3]> = Shape::Hexahedron.vertices().to_vec();
        at[6] = [0.2, 0.2, 0.2];
        let j = corner_jacobians(Shape::Hexahedron, &[0, 1, 2, 3, 4, 5, 6, 7], &at);
        assert!(j[6] < 0.0 && j[0] > 0.0, "{j:?}");
    }
}
