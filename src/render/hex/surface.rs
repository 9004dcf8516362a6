//! The surface to draw: faces of kept cells that no other kept cell shares,
//! each sampled on a grid of points with their normals.
//!
//! A hex face is sampled through the hex map on a quad grid; a tet, prism
//! or pyramid face through its own Lagrange element (its nodes, and the triangle's or
//! the quadrilateral's basis on the mesh's spacing) on a triangle or quad
//! grid; everything after sampling (lighting, rasterising, edge lines) sees
//! only each face's [`Grid`] and the points, whatever the cell.

use crate::mesh::element::order::HEX_CORNERS;
use crate::mesh::element::{prism, pyramid};
use crate::mesh::element::simplex::{self, lattice, lattice_index};
use crate::mesh::element::{Shape, Spacing};
use crate::mesh::CurvedMesh;
use crate::numeric::{add, cross3 as cross, scale, sub};
use crate::render::basis_table;

use super::view::normalise;

/// The hex faces in local corner numbers. Not [`Shape::faces`] (Gmsh's
/// order and starting corners): the start corner decides how each sub-quad
/// is split into triangles, and the face order which face wins a tie in
/// depth, so this table keeps the hex pictures as they were.
pub(crate) use crate::mesh::HEX_FACES;

/// The points at which a face is sampled, `m` pieces per side, and how
/// they are joined into flat pieces. Points are numbered by their grid
/// position `(k, l)` (face parameters `(k/m, l/m)`), `k` fastest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Grid {
    /// `(m+1)²` points, `k, l ≤ m`, joined into `m²` sub-quads.
    Quad(usize),
    /// The order-`m` triangle lattice, `k + l ≤ m` (in its lattice order),
    /// joined into `m²` sub-triangles.
    Tri(usize),
}

impl Grid {
    /// The grid of a face of shape `face` (triangle or quadrilateral).
    pub fn of(face: Shape, m: usize) -> Grid {
        match face {
            Shape::Triangle => Grid::Tri(m),
            _ => Grid::Quad(m),
        }
    }

    /// Pieces per side.
    pub fn m(self) -> usize {
        match self {
            Grid::Quad(m) | Grid::Tri(m) => m,
        }
    }

    /// The index of grid position `(k, l)`.
    pub fn at(self, k: usize, l: usize) -> usize {
        match self {
            Grid::Quad(m) => k + (m + 1) * l,
            Grid::Tri(m) => lattice_index(Shape::Triangle, m, [k, l, 0]),
        }
    }

    /// The face parameters of the points, in index order.
    fn params(self) -> Vec<[usize; 2]> {
        match self {
            Grid::Quad(m) => (0..=m).flat_map(|l| (0..=m).map(move |k| [k, l])).collect(),
            Grid::Tri(m) => lattice(Shape::Triangle, m)
                .into_iter()
                .map(|[k, l, _]| [k, l])
                .collect(),
        }
    }

    /// Corners per piece: 4 or 3.
    pub fn piece_corners(self) -> usize {
        match self {
            Grid::Quad(_) => 4,
            Grid::Tri(_) => 3,
        }
    }

    /// The pieces' corner indices, [`Grid::piece_corners`] a piece, each
    /// counter-clockwise in the face parameters (so all pieces face the
    /// same side as the face). A piece is drawn as the fan of triangles
    /// from its first corner.
    pub fn pieces(self) -> Vec<usize> {
        let at = |k, l| self.at(k, l);
        match self {
            Grid::Quad(m) => (0..m)
                .flat_map(|l| {
                    (0..m)
                        .flat_map(move |k| [at(k, l), at(k + 1, l), at(k + 1, l + 1), at(k, l + 1)])
                })
                .collect(),
            // Lattice positions of order m are our point indices.
            Grid::Tri(m) => simplex::sub_simplices(Shape::Triangle, m)
                .into_iter()
                .flat_map(|s| [s[0], s[1], s[2]])
                .collect(),
        }
    }

    /// The index pairs of the segments around the border: the face's
    /// edges.
    pub fn border(self) -> Vec<[usize; 2]> {
        let at = |k, l| self.at(k, l);
        let m = self.m();
        (0..m)
            .flat_map(|i| match self {
                Grid::Quad(_) => vec![
                    [at(i, 0), at(i + 1, 0)],
                    [at(m, i), at(m, i + 1)],
                    [at(i, m), at(i + 1, m)],
                    [at(0, i), at(0, i + 1)],
                ],
                Grid::Tri(_) => vec![
                    [at(i, 0), at(i + 1, 0)],
                    [at(m - i, i), at(m - i - 1, i + 1)],
                    [at(0, i), at(0, i + 1)],
                ],
            })
            .collect()
    }

    /// The indices of the face's corners, in order around it.
    pub fn corners(self) -> Vec<usize> {
        let m = self.m();
        match self {
            Grid::Quad(_) => vec![self.at(0, 0), self.at(m, 0), self.at(m, m), self.at(0, m)],
            Grid::Tri(_) => vec![self.at(0, 0), self.at(m, 0), self.at(0, m)],
        }
    }
}

/// The corner nodes of every cell, each cell by its own kind (8 of a hex,
/// 4 of a tet, 6 of a prism, 5 of a pyramid), in the numbering of the
/// shape's vertices (which the face tables use).
pub(crate) struct Corners {
    /// Each cell's kind.
    pub shapes: Vec<Shape>,
    /// Where each cell's corners start in `nodes`, and the end.
    starts: Vec<usize>,
    pub nodes: Vec<usize>,
}

impl Corners {
    /// Cells all of `shape`, their corners in turn in `nodes`.
    #[cfg(test)]
    pub fn uniform(shape: Shape, nodes: Vec<usize>) -> Corners {
        let n = shape.vertices().len();
        let cells = nodes.len() / n;
        Corners { shapes: vec![shape; cells], starts: (0..=cells).map(|c| c * n).collect(), nodes }
    }

    /// The corners of the cells of `mesh`, validated: hexes (tensor
    /// order), tets, prisms and pyramids (lattice orders), mixed or not.
    pub fn of(mesh: &CurvedMesh<3>) -> Corners {
        let p = mesh.p;
        let local = |shape: Shape| -> Vec<usize> {
            match shape {
                Shape::Tetrahedron => simplex::vertex_nodes(shape, p),
                Shape::Prism => prism::vertex_nodes(p).to_vec(),
                Shape::Pyramid => pyramid::vertex_nodes(p).to_vec(),
                _ => {
                    let q = p + 1;
                    HEX_CORNERS.iter().map(|&[a, b, c]| p * (a + q * b + q * q * c)).collect()
                }
            }
        };
        let kinds: Vec<(Shape, Vec<usize>)> = mesh.shapes().into_iter().map(|s| (s, local(s))).collect();
        let (mut shapes, mut starts, mut nodes) = (Vec::with_capacity(mesh.cells.len()), vec![0], Vec::new());
        for (c, cell) in mesh.cells.iter().enumerate() {
            let shape = mesh.cell_shape(c);
            let (_, at) = kinds.iter().find(|k| k.0 == shape).expect("shapes() holds every cell's kind");
            nodes.extend(at.iter().map(|&i| cell[i]));
            shapes.push(shape);
            starts.push(nodes.len());
        }
        Corners { shapes, starts, nodes }
    }

    /// The corners of cell `c`.
    pub fn cell(&self, c: usize) -> &[usize] {
        &self.nodes[self.starts[c]..self.starts[c + 1]]
    }

    /// The kind and corners of each cell in turn.
    fn cells(&self) -> impl Iterator<Item = (Shape, &[usize])> {
        (0..self.shapes.len()).map(|c| (self.shapes[c], self.cell(c)))
    }
}

/// The faces of `shape` as loops of local corner numbers, counter-clockwise
/// seen from outside: [`HEX_FACES`] for hexes, the element table's for
/// tets and prisms (whose loops their `face_nodes` follow).
pub(crate) fn face_loops(shape: Shape) -> Vec<&'static [usize]> {
    match shape {
        Shape::Hexahedron => {
            let table: &'static [[usize; 4]; 6] = &HEX_FACES;
            table.iter().map(|f| f.as_slice()).collect()
        }
        _ => shape.faces().iter().map(|f| f.1).collect(),
    }
}

/// One face of the drawn surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SurfaceFace {
    /// The kept cell the face belongs to (whose value colours it).
    pub cell: usize,
    /// Which of the cell's faces, in the numbering of [`face_loops`].
    pub face: usize,
}

/// The faces (loops of [`face_loops`] of each cell's kind, in local corner
/// numbers) of kept cells (`kept[c]`) not shared with another kept cell:
/// the original boundary of the kept cells plus the faces exposed where a
/// neighbour was dropped. Faces come in cell order, so the picture does
/// not depend on the sorting.
pub(crate) fn surface_faces(corners: &Corners, kept: &[bool]) -> Vec<SurfaceFace> {
    let loops: Vec<(Shape, Vec<&'static [usize]>)> = Shape::ALL.iter().filter(|s| s.dim() == 3).map(|&s| (s, face_loops(s))).collect();
    let loops_of = |shape: Shape| &loops.iter().find(|l| l.0 == shape).expect("a solid kind").1;
    // Every face of a kept cell, keyed by its sorted nodes, then sorted so
    // that the copies of a face are neighbours.
    let mut all: Vec<([usize; 4], usize, usize)> = corners
        .cells()
        .enumerate()
        .filter(|&(c, _)| kept[c])
        .flat_map(|(c, (shape, cell))| {
            loops_of(shape)
                .iter()
                .enumerate()
                .map(move |(f, l)| (key(l.iter().map(|&i| cell[i])), c, f))
        })
        .collect();
    all.sort_unstable();
    let mut faces: Vec<(usize, usize)> = all
        .chunk_by(|a, b| a.0 == b.0)
        .filter(|run| run.iter().all(|r| r.1 == run[0].1))
        .flat_map(|run| run.iter().map(|r| (r.1, r.2)))
        .collect();
    faces.sort_unstable();
    faces
        .into_iter()
        .map(|(cell, face)| SurfaceFace { cell, face })
        .collect()
}

/// The same key for a face whichever corner and direction it starts from:
/// its sorted nodes, a triangle's padded with `usize::MAX` (which no node
/// is, so a triangle never matches a quad).
fn key(nodes: impl Iterator<Item = usize>) -> [usize; 4] {
    let mut k = [usize::MAX; 4];
    k.iter_mut().zip(nodes).for_each(|(slot, n)| *slot = n);
    k.sort_unstable();
    k
}

/// One drawn face: the face sampled on its [`Grid`].
pub(crate) struct Patch {
    /// The cell it belongs to (whose value colours it).
    pub cell: usize,
    /// The grid it is sampled on: a prism has triangle and quad faces.
    pub grid: Grid,
    /// World points, in grid order; the grid's border is the face's
    /// border.
    pub points: Vec<[f64; 3]>,
    /// Unit normals at the points, on the side the pieces face.
    pub normals: Vec<[f64; 3]>,
}

/// The sampled boundary faces of the kept cells of `mesh` (validated:
/// hexes, tets, prisms and pyramids, mixed or not), in cell order, `m`
/// pieces a side.
pub(crate) fn surface_patches(
    mesh: &CurvedMesh<3>,
    corners: &Corners,
    kept: &[bool],
    m: usize,
) -> Vec<Patch> {
    let samplers: Vec<(Shape, Sampler)> = mesh.shapes().into_iter().map(|s| (s, Sampler::new(mesh, s, m))).collect();
    surface_faces(corners, kept)
        .into_iter()
        .map(|face| {
            let shape = corners.shapes[face.cell];
            let sampler = &samplers.iter().find(|k| k.0 == shape).expect("a sampler for every kind").1;
            let (points, normals) = sampler.sample(&mesh.cells[face.cell], &mesh.nodes, face.face);
            Patch {
                cell: face.cell,
                // a hex's faces, numbered by HEX_FACES, are all quads
                grid: Grid::of(shape.faces()[face.face].0, m),
                points,
                normals,
            }
        })
        .collect()
}

/// What sampling the faces of one mesh needs, computed once.
enum Sampler {
    /// Hex faces through the tensor map: the 1-D basis at `t = k / m`.
    Hex { p: usize, table: Vec<Vec<f64>> },
    /// Tet, prism and pyramid faces through their own elements: each face's shape
    /// and nodes (local numbers: a triangle's in lattice order, a quad's in
    /// tensor order, as `face_nodes` of [`simplex`] and [`prism`] give
    /// them), the triangle's basis on the triangle grid and the 1-D basis
    /// at `t = k / m` for the quads.
    Faces {
        faces: Vec<(Shape, Vec<usize>)>,
        triangle: TriangleTable,
        table: Vec<Vec<f64>>,
    },
}

/// The order-`p` triangle basis's values and gradients at every point of
/// the triangle grid `m`, `n` functions a point.
struct TriangleTable {
    n: usize,
    values: Vec<f64>,
    grads: Vec<[f64; 3]>,
}

impl TriangleTable {
    fn new(p: usize, spacing: Spacing, m: usize) -> TriangleTable {
        let space = simplex::space(Shape::Triangle, p, spacing).expect("order checked by validate");
        let n = space.num_nodes();
        let points = Grid::Tri(m).params();
        let (mut values, mut grads) = (
            vec![0.0; n * points.len()],
            vec![[0.0; 3]; n * points.len()],
        );
        for (i, [k, l]) in points.into_iter().enumerate() {
            let xi = [k as f64 / m as f64, l as f64 / m as f64, 0.0];
            space.eval(
                xi,
                &mut values[i * n..(i + 1) * n],
                &mut grads[i * n..(i + 1) * n],
            );
        }
        TriangleTable { n, values, grads }
    }

    /// The points and unit normals of the Lagrange triangle through
    /// `nodes` on the grid.
    fn sample(&self, nodes: &[[f64; 3]]) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let n = self.n;
        let at = |g: usize| {
            (
                &self.values[g * n..(g + 1) * n],
                &self.grads[g * n..(g + 1) * n],
            )
        };
        (0..self.values.len() / n)
            .map(|g| triangle_point(nodes, at(g)))
            .unzip()
    }
}

impl Sampler {
    /// For the cells of `shape` of `mesh`.
    fn new(mesh: &CurvedMesh<3>, shape: Shape, m: usize) -> Sampler {
        let (p, table) = (mesh.p, basis_table(mesh.p, mesh.spacing, m));
        let faces = match shape {
            Shape::Tetrahedron => (0..4)
                .map(|f| {
                    (
                        Shape::Triangle,
                        simplex::face_nodes(Shape::Tetrahedron, p, f),
                    )
                })
                .collect(),
            Shape::Prism => (0..5)
                .map(|f| (Shape::Prism.faces()[f].0, prism::face_nodes(p, f)))
                .collect(),
            Shape::Pyramid => (0..5)
                .map(|f| (Shape::Pyramid.faces()[f].0, pyramid::face_nodes(p, f)))
                .collect(),
            _ => return Sampler::Hex { p, table },
        };
        Sampler::Faces {
            faces,
            triangle: TriangleTable::new(p, mesh.spacing, m),
            table,
        }
    }

    /// Face `f` (numbering of [`face_loops`]) of the cell with nodes
    /// `cell`: its points and unit normals on the grid.
    fn sample(
        &self,
        cell: &[usize],
        nodes: &[[f64; 3]],
        f: usize,
    ) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        match self {
            Sampler::Hex { p, table } => {
                let points = sample_hex_face(cell, nodes, *p, f, table);
                let normals = grid_normals(&points, table.len() - 1);
                (points, normals)
            }
            Sampler::Faces {
                faces,
                triangle,
                table,
            } => {
                let (shape, on) = &faces[f];
                let ids: Vec<[f64; 3]> = on.iter().map(|&a| nodes[cell[a]]).collect();
                if *shape == Shape::Triangle {
                    return triangle.sample(&ids);
                }
                let points = sample_quad(&ids, table);
                let normals = grid_normals(&points, table.len() - 1);
                (points, normals)
            }
        }
    }
}

/// The Lagrange quadrilateral through `nodes` (tensor order) sampled on the
/// grid of `table` (rows at `t = k / m`), first axis fastest.
fn sample_quad(nodes: &[[f64; 3]], table: &[Vec<f64>]) -> Vec<[f64; 3]> {
    let q = table[0].len();
    let mut points = Vec::with_capacity(table.len() * table.len());
    for wl in table {
        for wk in table {
            let mut x = [0.0; 3];
            for (b, &wb) in wl.iter().enumerate().filter(|(_, w)| **w != 0.0) {
                for (a, &wa) in wk.iter().enumerate().filter(|(_, w)| **w != 0.0) {
                    x = add(x, scale(wa * wb, nodes[a + q * b]));
                }
            }
            points.push(x);
        }
    }
    points
}

/// The point of the Lagrange triangle through `nodes` with basis `values`
/// and gradients there, and its unit normal: from the exact tangents, which
/// the triangle grid has no simple neighbours for at its corners.
fn triangle_point(
    nodes: &[[f64; 3]],
    (values, grads): (&[f64], &[[f64; 3]]),
) -> ([f64; 3], [f64; 3]) {
    let (mut x, mut du, mut dv) = ([0.0; 3], [0.0; 3], [0.0; 3]);
    for ((y, &w), g) in nodes.iter().zip(values).zip(grads) {
        x = add(x, scale(w, *y));
        du = add(du, scale(g[0], *y));
        dv = add(dv, scale(g[1], *y));
    }
    (x, normalise(cross(du, dv)))
}

/// Face `f` ([`HEX_FACES`] numbering) of the order-`p` hex with tensor-
/// ordered nodes `cell`, sampled through the hex map on the grid of
/// `table` (rows at `t = k / m`). The face's first corner is the grid's
/// origin, its second lies along the grid's first axis, its fourth along
/// the second.
fn sample_hex_face(
    cell: &[usize],
    nodes: &[[f64; 3]],
    p: usize,
    f: usize,
    table: &[Vec<f64>],
) -> Vec<[f64; 3]> {
    let m = table.len() - 1;
    let q = p + 1;
    let [r0, r1, _, r3] = HEX_FACES[f].map(|i| HEX_CORNERS[i]);
    let axis_u = (0..3)
        .find(|&d| r1[d] != r0[d])
        .expect("face corners differ");
    let axis_v = (0..3)
        .find(|&d| r3[d] != r0[d])
        .expect("face corners differ");
    let fixed = 3 - axis_u - axis_v;
    // The face lies where the basis along the fixed axis is exactly the
    // first or the last function: the face depends on its own nodes only.
    let mut delta = vec![0.0; q];
    delta[r0[fixed] * p] = 1.0;
    // Along a reversed axis, face parameter k/m is reference 1 − k/m.
    let row = |k: usize, reversed: bool| &table[if reversed { m - k } else { k }];
    let mut points = Vec::with_capacity((m + 1) * (m + 1));
    for l in 0..=m {
        for k in 0..=m {
            let mut w: [&[f64]; 3] = [&delta, &delta, &delta];
            w[axis_u] = row(k, r0[axis_u] == 1);
            w[axis_v] = row(l, r0[axis_v] == 1);
            let mut x = [0.0; 3];
            for (c, &wc) in w[2].iter().enumerate().filter(|(_, w)| **w != 0.0) {
                for (b, &wb) in w[1].iter().enumerate().filter(|(_, w)| **w != 0.0) {
                    for (a, &wa) in w[0].iter().enumerate().filter(|(_, w)| **w != 0.0) {
                        let y = nodes[cell[a + q * b + q * q * c]];
                        x = add(x, scale(wa * wb * wc, y));
                    }
                }
            }
            points.push(x);
        }
    }
    points
}

/// Unit normals of a face sampled on the quad grid `m`, at its points,
/// from central differences (one-sided on the border), all on the same
/// side of the face. Shading with these, interpolated over each sub-quad,
/// makes a curved face look smooth where flat sub-quads would show as
/// facets.
fn grid_normals(points: &[[f64; 3]], m: usize) -> Vec<[f64; 3]> {
    let at = |k: usize, l: usize| points[k + (m + 1) * l];
    let mut normals = Vec::with_capacity(points.len());
    for l in 0..=m {
        for k in 0..=m {
            let du = sub(at((k + 1).min(m), l), at(k.saturating_sub(1), l));
            let dv = sub(at(k, (l + 1).min(m)), at(k, l.saturating_sub(1)));
            normals.push(normalise(cross(du, dv)));
        }
    }
    normals
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::HexMesh;
    use crate::numeric::dot;

    fn brick(n: [usize; 3]) -> HexMesh {
        HexMesh::structured_box([0.0; 3], [n[0] as f64, n[1] as f64, n[2] as f64], n)
    }

    fn hex_corners(m: &HexMesh) -> Corners {
        Corners::uniform(Shape::Hexahedron, m.cells.concat())
    }

    /// The nodes of `face` of its cell, in the face's loop order.
    fn nodes_of(corners: &Corners, loops: &[&[usize]], face: SurfaceFace) -> Vec<usize> {
        loops[face.face]
            .iter()
            .map(|&i| corners.cell(face.cell)[i])
            .collect()
    }

    fn hex_faces(m: &HexMesh, kept: &[bool]) -> Vec<Vec<usize>> {
        let (corners, loops) = (hex_corners(m), face_loops(Shape::Hexahedron));
        surface_faces(&corners, kept)
            .into_iter()
            .map(|f| nodes_of(&corners, &loops, f))
            .collect()
    }

    #[test]
    fn boundary_of_a_brick_matches_the_generated_faces() {
        let m = brick([3, 2, 2]);
        let faces = hex_faces(&m, &[true; 12]);
        assert_eq!(faces.len(), m.faces.len());
        let mut got: Vec<_> = faces.iter().map(|f| key(f.iter().copied())).collect();
        let mut want: Vec<_> = m.faces.iter().map(|f| key(f.nodes.into_iter())).collect();
        got.sort_unstable();
        want.sort_unstable();
        assert_eq!(got, want);
    }

    #[test]
    fn faces_keep_the_outward_orientation_of_the_mesh() {
        // The generated boundary faces are counter-clockwise from outside;
        // ours must be too (same cyclic order, not reversed).
        let m = brick([2, 2, 1]);
        let faces = hex_faces(&m, &[true; 4]);
        for f in &m.faces {
            let ours = faces
                .iter()
                .find(|g| key(g.iter().copied()) == key(f.nodes.into_iter()))
                .unwrap();
            let start = ours.iter().position(|&n| n == f.nodes[0]).unwrap();
            let rotated: [usize; 4] = std::array::from_fn(|i| ours[(start + i) % 4]);
            assert_eq!(rotated, f.nodes);
        }
    }

    #[test]
    fn dropping_a_cell_exposes_the_face_it_shared() {
        let m = brick([2, 1, 1]);
        assert_eq!(hex_faces(&m, &[true, true]).len(), 10);
        let corners = hex_corners(&m);
        let loops = face_loops(Shape::Hexahedron);
        let faces = surface_faces(&corners, &[true, false]);
        assert_eq!(faces.len(), 6, "cell 0 alone shows all six faces");
        assert!(faces.iter().all(|f| f.cell == 0));
        let inner = faces
            .iter()
            .filter(|&&f| {
                nodes_of(&corners, &loops, f)
                    .iter()
                    .all(|&n| m.nodes[n][0] == 1.0)
            })
            .count();
        assert_eq!(inner, 1, "the face at x = 1 is exposed");
        assert!(surface_faces(&corners, &[false, false]).is_empty());
    }

    /// The unit cube split into six tets around its diagonal (0,0,0)–(1,1,1),
    /// each positively oriented, on the cube's eight corner nodes.
    fn kuhn_cube() -> (Vec<[f64; 3]>, Corners) {
        let nodes = (0..8)
            .map(|i: usize| [i & 1, i >> 1 & 1, i >> 2 & 1].map(|b| b as f64))
            .collect();
        // Corner i of the cube is (i & 1, i >> 1 & 1, i >> 2 & 1): the path
        // along axes a, b, c; an odd permutation of the axes turns the tet
        // inside out.
        let even = [[1, 2], [2, 4], [4, 1]];
        let tets: Vec<usize> = [[1, 2], [1, 4], [2, 1], [2, 4], [4, 1], [4, 2]]
            .iter()
            .flat_map(|&[a, b]| {
                if even.contains(&[a, b]) {
                    [0, a, a | b, 7]
                } else {
                    [0, a | b, a, 7]
                }
            })
            .collect();
        (
            nodes,
            Corners::uniform(Shape::Tetrahedron, tets),
        )
    }

    #[test]
    fn a_cube_of_tets_shows_twelve_outward_triangles() {
        let (nodes, corners) = kuhn_cube();
        let loops = face_loops(Shape::Tetrahedron);
        let mean = |ids: &[usize]| {
            scale(
                1.0 / ids.len() as f64,
                ids.iter().fold([0.0; 3], |c, &n| add(c, nodes[n])),
            )
        };
        for c in 0..6 {
            let t = corners
                .cell(c)
                .iter()
                .map(|&n| nodes[n])
                .collect::<Vec<_>>();
            let det = dot(sub(t[1], t[0]), cross(sub(t[2], t[0]), sub(t[3], t[0])));
            assert!(det > 0.0, "tet {c} is inverted");
        }
        let faces = surface_faces(&corners, &[true; 6]);
        assert_eq!(faces.len(), 12, "two triangles per side of the cube");
        for f in faces {
            let ids = nodes_of(&corners, &loops, f);
            let x = ids.iter().map(|&n| nodes[n]).collect::<Vec<_>>();
            let normal = cross(sub(x[1], x[0]), sub(x[2], x[0]));
            // On a side of the cube, facing away from its cell.
            assert!((0..3).any(|d| x.iter().all(|y| y[d] == x[0][d])), "{x:?}");
            assert!(dot(normal, sub(mean(&ids), mean(corners.cell(f.cell)))) > 0.0);
        }
        // Dropping tets exposes the faces they shared: a lone tet shows
        // its four.
        let mut kept = [false; 6];
        kept[2] = true;
        assert_eq!(surface_faces(&corners, &kept).len(), 4);
    }

    #[test]
    fn grids_cover_the_face_with_pieces_facing_one_way() {
        for grid in [Grid::Quad(1), Grid::Quad(4), Grid::Tri(1), Grid::Tri(6)] {
            let params = grid.params();
            let m = grid.m() as f64;
            for (i, &[k, l]) in params.iter().enumerate() {
                assert_eq!(grid.at(k, l), i);
            }
            let (n, pieces) = (grid.piece_corners(), grid.pieces());
            let mut area = 0.0;
            for piece in pieces.chunks_exact(n) {
                let x: Vec<[f64; 2]> = piece
                    .iter()
                    .map(|&i| params[i].map(|c| c as f64 / m))
                    .collect();
                let twice: f64 = (0..n)
                    .map(|j| {
                        let (a, b) = (x[j], x[(j + 1) % n]);
                        a[0] * b[1] - a[1] * b[0]
                    })
                    .sum();
                assert!(twice > 0.0, "{grid:?}: {piece:?} is clockwise");
                area += 0.5 * twice;
            }
            let whole = if n == 4 { 1.0 } else { 0.5 };
            assert!((area - whole).abs() < 1e-12, "{grid:?}: {area}");
            // The border runs along the face's edges: every segment has
            // both ends on the same side of the reference face.
            let border = grid.border();
            assert_eq!(border.len(), n * grid.m());
            for [a, b] in border {
                let (a, b) = (params[a], params[b]);
                let on = |s: fn([usize; 2]) -> bool| s(a) && s(b);
                let mm = grid.m();
                let sides = on(|x| x[1] == 0) || on(|x| x[0] == 0);
                let far = if n == 4 {
                    [a, b].iter().all(|x| x[0] == mm) || [a, b].iter().all(|x| x[1] == mm)
                } else {
                    [a, b].iter().all(|x| x[0] + x[1] == mm)
                };
                assert!(sides || far, "{grid:?}: {a:?}–{b:?}");
            }
        }
    }
}
