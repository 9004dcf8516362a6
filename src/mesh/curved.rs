//! The mesh of any order: order-`p` Lagrange quads or triangles (`D = 2`),
//! hexes or tetrahedra (`D = 3`), with their nodes in tensor order or the
//! simplex lattice order ([`super::element`]), and
//! boundary elements of dimension `D − 1` in named parts. A linear mesh is
//! the case `p = 1` ([`CurvedMesh::from_quads`], [`CurvedMesh::from_hexes`]),
//! which is how the file writers take meshes of any order.

use super::element::basis::{tensor_map, Basis1d};
use super::element::{check_order, linear_order, nodes_1d, HighOrderError, Spacing, MAX_ORDER};
use smallvec::SmallVec;
use super::element::{prism, pyramid, simplex, Shape};
use super::blocks::{Cells, Facets};
use super::{PlaneMesh, SolidMesh};

/// A mesh of order-`p` Lagrange quads (`D = 2`) or hexes (`D = 3`).
#[derive(Clone, Debug, PartialEq)]
pub struct CurvedMesh<const D: usize> {
    /// The cells' reference shape: quadrilateral or triangle (`D = 2`),
    /// hexahedron or tetrahedron (`D = 3`). Boundary elements have its
    /// facet shape.
    pub shape: Shape,
    /// Element order, `1..=4`.
    pub p: usize,
    /// Where the element nodes sit in the reference cell.
    pub spacing: Spacing,
    /// Node coordinates.
    pub nodes: Vec<[f64; D]>,
    /// Cells as element blocks ([`Cells`]), [`Shape::num_nodes`] node
    /// indices each, in tensor order (quads, hexes) or the lattice order
    /// of their kind ([`super::element::simplex`], [`prism`], [`pyramid`]).
    pub cells: Cells,
    /// Boundary elements (dimension `D − 1`) as element blocks, each
    /// with its part ([`Facets`]): order-`p` lines, triangles or quads,
    /// their nodes in the order of their kind (a quad's tensor order), the
    /// orientation as given (2D: the domain on the left).
    pub boundary: Facets,
    /// Names of the boundary parts (physical groups of dimension `D − 1`).
    pub part_names: Vec<String>,
}

impl<const D: usize> CurvedMesh<D> {
    /// The tensor kind of the dimension, quadrilateral or hexahedron: an
    /// empty mesh's kind, and with its facet kind the fallback where a
    /// node count tells no kind.
    const TENSOR: Shape = if D == 2 { Shape::Quadrilateral } else { Shape::Hexahedron };

    /// A structured mesh of `n[0] × … × n[D−1]` order-`p` cells of the unit
    /// box `[0,1]^D`, its nodes then moved by `map`. Nodes are numbered
    /// first axis fastest on the global grid of `n_d p + 1` nodes per axis,
    /// at `(cell + t_i) / n_d` with `t = nodes_1d(p, spacing)`. Boundary
    /// parts are the box sides `"xmin", "xmax", "ymin", "ymax"(, "zmin",
    /// "zmax")`; in 2D the edges run with the domain on their left, in 3D
    /// the faces list their nodes over the remaining axes in increasing
    /// order (no orientation promised).
    pub fn structured(
        p: usize,
        spacing: Spacing,
        n: [usize; D],
        map: impl Fn([f64; D]) -> [f64; D],
    ) -> Result<CurvedMesh<D>, HighOrderError> {
        let t = nodes_1d(p, spacing)?;
        let dims: [usize; D] = std::array::from_fn(|d| n[d] * p + 1);
        let id = |g: [usize; D]| (0..D).rev().fold(0, |acc, d| acc * dims[d] + g[d]);
        let coord = |g: usize, d: usize| {
            let (c, i) = if g == dims[d] - 1 {
                (n[d] - 1, p)
            } else {
                (g / p, g % p)
            };
            (c as f64 + t[i]) / n[d] as f64
        };
        let total: usize = dims.iter().product();
        let nodes = (0..total)
            .map(|a| {
                let mut rest = a;
                let x: [f64; D] = std::array::from_fn(|d| {
                    let g = rest % dims[d];
                    rest /= dims[d];
                    coord(g, d)
                });
                map(x)
            })
            .collect();
        let q = p + 1;
        // tensor nodes of a block starting at global index `base`, spanning
        // the axes `axes` (in that order), q nodes each
        let block = |base: [usize; D], axes: &[usize]| -> Vec<usize> {
            (0..q.pow(axes.len() as u32))
                .map(|a| {
                    let mut g = base;
                    let mut rest = a;
                    for &d in axes {
                        g[d] += rest % q;
                        rest /= q;
                    }
                    id(g)
                })
                .collect()
        };
        let ncells: usize = n.iter().product();
        let all_axes: Vec<usize> = (0..D).collect();
        let cell_index = |c: usize| -> [usize; D] {
            let mut rest = c;
            std::array::from_fn(|d| {
                let i = rest % n[d];
                rest /= n[d];
                i
            })
        };
        let shape = Self::TENSOR;
        let mut cells = Cells::new();
        for c in 0..ncells {
            cells.push(shape, &block(cell_index(c).map(|i| i * p), &all_axes));
        }
        let mut boundary = Facets::new();
        for d in 0..D {
            let others: Vec<usize> = (0..D).filter(|&e| e != d).collect();
            for side in 0..2 {
                for c in (0..ncells)
                    .map(cell_index)
                    .filter(|ci| ci[d] == side * (n[d] - 1))
                {
                    let mut base = c.map(|i| i * p);
                    base[d] = side * (dims[d] - 1);
                    let mut nodes = block(base, &others);
                    // 2D: bottom (d=1, side 0) and right (d=0, side 1) run
                    // with increasing coordinate, top and left against it
                    if D == 2 && (d == 0) == (side == 0) {
                        nodes.reverse();
                    }
                    boundary.push(shape.facet_shape(), &nodes, 2 * d + side);
                }
            }
        }
        let names = ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"];
        Ok(CurvedMesh {
            shape,
            p,
            spacing,
            nodes,
            cells,
            boundary,
            part_names: names[..2 * D].iter().map(|s| s.to_string()).collect(),
        })
    }

    /// Number of nodes of a cell of the mesh's first kind ([`Self::shape`]):
    /// `(p+1)^D` for quads and hexes.
    pub fn nodes_per_cell(&self) -> usize {
        self.shape.num_nodes(self.p)
    }

    /// Whether the cells are triangles or tetrahedra.
    pub fn is_simplex(&self) -> bool {
        self.shape.is_simplex()
    }

    /// The kind of cell `c`, its block's: a mixed mesh holds triangles and
    /// quads, or tetrahedra, prisms, pyramids and hexes.
    pub fn cell_shape(&self, c: usize) -> Shape {
        self.cells.shape(c)
    }

    /// Boundary elements `facets` (nodes and part) of a mesh of order `p`
    /// as its [`Facets`], each one's kind told by its node count (a 3D
    /// boundary of prisms holds triangles and quads); a count no kind has
    /// is kept for `validate` to refuse.
    pub fn facets_at<C: AsRef<[usize]>>(p: usize, facets: impl IntoIterator<Item = (C, usize)>) -> Facets {
        Facets::from_nodes(D - 1, p, Self::TENSOR.facet_shape(), facets)
    }

    /// The kinds of cell the mesh holds, in the order of [`Shape`].
    pub fn shapes(&self) -> Vec<Shape> {
        let mut out: Vec<Shape> = std::iter::once(self.shape).chain(self.cells.blocks().iter().map(|b| b.shape)).collect();
        out.sort();
        out.dedup();
        out
    }

    /// Whether cells of more than one kind are held (quads with triangles).
    pub fn is_mixed(&self) -> bool {
        self.shapes().len() > 1
    }

    /// The coordinates of cell `c`'s nodes in tensor order.
    pub fn cell_coords(&self, c: usize) -> Vec<[f64; D]> {
        self.cells[c].iter().map(|&v| self.nodes[v]).collect()
    }

    /// Rejects what no file can represent: an order outside `1..=4`,
    /// cells or boundary elements with the wrong number of nodes, dangling
    /// node or part indices, non-finite coordinates and part names that
    /// are empty, repeated or unquotable.
    pub fn validate(&self) -> Result<(), String> {
        if check_order(self.p).is_err() {
            return Err(format!("order {} is not in 1..={MAX_ORDER}", self.p));
        }
        if !(2..=3).contains(&D) {
            return Err(format!("{D}D meshes are not supported"));
        }
        if self.shape.dim() != D || !matches!(self.shape, Shape::Triangle | Shape::Quadrilateral | Shape::Tetrahedron | Shape::Hexahedron | Shape::Prism | Shape::Pyramid) {
            return Err(format!("cells of shape {:?} in a {D}D mesh", self.shape));
        }
        if let Some(first) = self.cells.blocks().first().filter(|b| b.shape != self.shape) {
            return Err(format!("the mesh's kind is {:?}, its first cell's {:?}", self.shape, first.shape));
        }
        let n = self.nodes.len();
        if let Some(i) = self
            .nodes
            .iter()
            .position(|x| !x.iter().all(|v| v.is_finite()))
        {
            return Err(format!(
                "node {i} has a non-finite coordinate {:?}",
                self.nodes[i]
            ));
        }
        // (a block of cells without nodes has nothing to iterate: found
        // here, as the loop below cannot see its cells)
        if self.cells.blocks().iter().any(|b| b.width == 0) {
            return Err("a cell has no nodes".into());
        }
        let per_cell = self.nodes_per_cell();
        for (c, cell) in self.cells.iter().enumerate() {
            // a mixed mesh: quads with triangles; tetrahedra, prisms,
            // pyramids and hexes
            let other = Shape::with_nodes(D, self.p, cell.len());
            if cell.len() != per_cell && other.is_none() {
                return Err(format!(
                    "cell {c} has {} nodes, expected {per_cell}",
                    cell.len()
                ));
            }
            if cell.iter().any(|&v| v >= n) {
                return Err(format!("cell {c} refers to a node >= {n}"));
            }
        }
        // the node counts of the cells' faces (a prism's are triangles and quads)
        let mut counts: Vec<usize> = self.shapes().iter().flat_map(|s| s.facets().iter().map(|f| f.0.num_nodes(self.p))).collect();
        counts.sort_unstable();
        counts.dedup();
        let per_face = counts.iter().map(usize::to_string).collect::<Vec<_>>().join(" or ");
        let word = if D == 2 { "boundary edge" } else { "boundary face" };
        for (e, b) in self.boundary.iter().enumerate() {
            // (the count its own kind has, and a face kind of the cells')
            if b.nodes.len() != b.shape.num_nodes(self.p) || !counts.contains(&b.nodes.len()) || b.nodes.iter().any(|&v| v >= n) {
                return Err(format!(
                    "{word} {e} needs {per_face} nodes < {n}, has {:?}",
                    b.nodes
                ));
            }
            if b.part >= self.part_names.len() {
                return Err(format!(
                    "{word} {e} has part {} of {}",
                    b.part,
                    self.part_names.len()
                ));
            }
        }
        for (i, name) in self.part_names.iter().enumerate() {
            if name.is_empty() || name.contains(['"', '\n', '\r']) {
                return Err(format!(
                    "part name {name:?} is empty or contains a quote or line break"
                ));
            }
            if self.part_names[..i].contains(name) {
                return Err(format!("part name {name:?} appears twice"));
            }
        }
        Ok(())
    }

    /// The same mesh with equispaced element nodes: each node moved to the
    /// image, under the map of the first cell that holds it, of the
    /// equispaced reference node with its tensor index. A no-op (a clone)
    /// for an equispaced mesh. Nodes in no cell stay where they are.
    /// Panics if the mesh fails [`CurvedMesh::validate`].
    pub fn to_equispaced(&self) -> CurvedMesh<D> {
        let mut out = self.clone();
        if self.spacing == Spacing::Equispaced {
            return out;
        }
        // a node shared by a quad and a triangle is the same point of
        // both maps (their edges carry the same 1D nodes): the first wins
        let mut done = vec![false; self.nodes.len()];
        for shape in self.shapes().into_iter().filter(|s| s.is_simplex()) {
            let space = simplex::space(shape, self.p, self.spacing).expect("order checked by validate");
            let equi = simplex::space(shape, self.p, Spacing::Equispaced).expect("order checked by validate");
            let (mut values, mut grads) = (vec![0.0; space.nodes.len()], vec![[0.0; 3]; space.nodes.len()]);
            for cell in self.cells.blocks().iter().filter(|b| b.shape == shape).flat_map(|b| b.cells()) {
                for (a, &v) in cell.iter().enumerate() {
                    if std::mem::replace(&mut done[v], true) {
                        continue;
                    }
                    space.eval(equi.nodes[a], &mut values, &mut grads);
                    out.nodes[v] = std::array::from_fn(|k| cell.iter().zip(&values).map(|(&w, &b)| b * self.nodes[w][k]).sum());
                }
            }
        }
        if self.shapes().contains(&Shape::Prism) {
            let space = prism::space(self.p, self.spacing).expect("order checked by validate");
            let equi = prism::prism_nodes(self.p, Spacing::Equispaced).expect("order checked by validate");
            self.resample(&mut out, &mut done, Shape::Prism, &equi, |x, v, g| space.eval(x, v, g));
        }
        if self.shapes().contains(&Shape::Pyramid) {
            let space = pyramid::space(self.p, self.spacing).expect("order checked by validate");
            let equi = pyramid::pyramid_nodes(self.p, Spacing::Equispaced).expect("order checked by validate");
            self.resample(&mut out, &mut done, Shape::Pyramid, &equi, |x, v, g| space.eval(x, v, g));
        }
        let basis = Basis1d::new(self.p, self.spacing).expect("order checked by validate");
        let t = nodes_1d(self.p, Spacing::Equispaced).expect("order checked by validate");
        let n = self.p + 1;
        let tensor = |s: Shape| matches!(s, Shape::Quadrilateral | Shape::Hexahedron);
        for cell in self.cells.blocks().iter().filter(|b| tensor(b.shape)).flat_map(|b| b.cells()) {
            let ctrl: Vec<[f64; D]> = cell.iter().map(|&v| self.nodes[v]).collect();
            for (a, &v) in cell.iter().enumerate() {
                if std::mem::replace(&mut done[v], true) {
                    continue;
                }
                let mut rest = a;
                let xi: [f64; D] = std::array::from_fn(|_| {
                    let i = rest % n;
                    rest /= n;
                    t[i]
                });
                out.nodes[v] = tensor_map(&basis, &ctrl, xi).0;
            }
        }
        out.spacing = Spacing::Equispaced;
        out
    }

    /// Moves each node of the cells of `shape` not yet `done` in `out` to
    /// the image of its equispaced reference node `equi[a]` under the
    /// cell's map (basis values by `eval`, as the spaces' `eval`).
    fn resample(&self, out: &mut CurvedMesh<D>, done: &mut [bool], shape: Shape, equi: &[[f64; 3]], eval: impl Fn([f64; 3], &mut [f64], &mut [[f64; 3]])) {
        let (mut values, mut grads) = (vec![0.0; equi.len()], vec![[0.0; 3]; equi.len()]);
        for cell in self.cells.blocks().iter().filter(|b| b.shape == shape).flat_map(|b| b.cells()) {
            for (a, &v) in cell.iter().enumerate() {
                if std::mem::replace(&mut done[v], true) {
                    continue;
                }
                eval(equi[a], &mut values, &mut grads);
                out.nodes[v] = std::array::from_fn(|k| cell.iter().zip(&values).map(|(&w, &b)| b * self.nodes[w][k]).sum());
            }
        }
    }
}


impl CurvedMesh<2> {
    /// The linear quad or triangle mesh as the order-1 case (cells and
    /// edges keep their nodes, quads in tensor order; a triangle's three
    /// corners are already its lattice order), for code written for any
    /// order.
    pub fn from_quads<const N: usize>(m: &PlaneMesh<N>) -> Self {
        let shape = if N == 3 { Shape::Triangle } else { Shape::Quadrilateral };
        // an empty mesh keeps its kind
        CurvedMesh { shape, ..CurvedMesh::linear(m.nodes.clone(), m.cells.iter().map(|c| (shape, c)), m.edges.iter().map(|e| (e.nodes, e.part)), m.part_names.clone()) }
    }
}

impl CurvedMesh<2> {
    /// The linear mesh as Algorithm 1's mesh of one kind, `N` vertices
    /// per cell (quads 4, triangles 3; each cell's vertices in its cyclic
    /// order as given: `curve` turns clockwise ones), whose kernels are
    /// compiled for that kind: `None` unless p = 1 and every cell is of
    /// that kind.
    pub fn to_plane<const N: usize>(&self) -> Option<PlaneMesh<N>> {
        let cells = self.vertices_of_one_kind(if N == 3 { Shape::Triangle } else { Shape::Quadrilateral }, 2)?;
        Some(PlaneMesh { nodes: self.nodes.clone(), cells, edges: self.boundary_edges(), part_names: self.part_names.clone() })
    }

    /// The boundary lines of a linear plane mesh, as Algorithm 1's meshes
    /// hold them.
    pub(super) fn boundary_edges(&self) -> Vec<super::BoundaryEdge> {
        self.boundary.iter().map(|b| super::BoundaryEdge { nodes: [b.nodes[0], b.nodes[1]], part: b.part }).collect()
    }
}

impl CurvedMesh<3> {
    /// The linear mesh as Algorithm 1's mesh of one kind (see
    /// [`CurvedMesh::to_plane`]): hexes (`N = 8`, quad faces `K = 4`) or
    /// tetrahedra (`N = 4`, `K = 3`); `None` unless p = 1 and every cell
    /// and face is of those kinds.
    pub fn to_solid<const N: usize, const K: usize>(&self) -> Option<SolidMesh<N, K>> {
        let cells = self.vertices_of_one_kind(if N == 4 { Shape::Tetrahedron } else { Shape::Hexahedron }, K)?;
        let faces = self
            .boundary
            .iter()
            .map(|b| {
                let f = reordered(b.shape, b.nodes);
                super::BoundaryFace { nodes: std::array::from_fn(|k| f[k]), part: b.part }
            })
            .collect();
        Some(SolidMesh { nodes: self.nodes.clone(), cells, faces, part_names: self.part_names.clone() })
    }
}

impl<const D: usize> CurvedMesh<D> {
    /// Every cell's `N` vertices if the mesh is linear, its cells all of
    /// `kind` (of `N` vertices) and its boundary elements all of
    /// `facet_nodes` nodes; else `None`.
    fn vertices_of_one_kind<const N: usize>(&self, kind: Shape, facet_nodes: usize) -> Option<Vec<[usize; N]>> {
        if self.p != 1 || N != kind.num_nodes(1) || self.cells.blocks().iter().any(|b| b.shape != kind) || self.boundary.iter().any(|b| b.nodes.len() != facet_nodes) {
            return None;
        }
        let cells = (0..self.cells.len())
            .map(|c| {
                let v = self.vertices(c);
                std::array::from_fn(|k| v[k])
            })
            .collect();
        Some(cells)
    }
}

impl CurvedMesh<3> {
    /// The linear hex or tetrahedral mesh as the order-1 case (see
    /// [`CurvedMesh::from_quads`]; a tetrahedron's corners are its lattice
    /// order).
    pub fn from_hexes<const N: usize, const K: usize>(m: &SolidMesh<N, K>) -> Self {
        let shape = if N == 4 { Shape::Tetrahedron } else { Shape::Hexahedron };
        // an empty mesh keeps its kind
        CurvedMesh { shape, ..CurvedMesh::linear(m.nodes.clone(), m.cells.iter().map(|c| (shape, c)), m.faces.iter().map(|f| (f.nodes, f.part)), m.part_names.clone()) }
    }
}

/// The linear mesh of cells of any kinds (`p = 1`), as a file gives it:
/// each cell by its vertices in its kind's vertex order
/// ([`Shape::vertices`], Gmsh's), each boundary element by its corners in
/// cyclic order. Its nodes lists are those in [`linear_order`].
impl<const D: usize> CurvedMesh<D> {
    /// The linear mesh of `cells` (kind and vertices) in the order given,
    /// so that cell `c` is the file's element `c`, bounded by `facets`
    /// (corners and part); its `shape` is the first cell's.
    pub fn linear<C: AsRef<[usize]>, F: AsRef<[usize]>>(
        nodes: Vec<[f64; D]>,
        cells: impl IntoIterator<Item = (Shape, C)>,
        facets: impl IntoIterator<Item = (F, usize)>,
        part_names: Vec<String>,
    ) -> Self {
        let cells: Cells = cells.into_iter().map(|(shape, v)| (shape, reordered(shape, v.as_ref()))).collect();
        let shape = cells.blocks().first().map_or(Self::TENSOR, |b| b.shape);
        let mut mesh = CurvedMesh { shape, p: 1, spacing: Spacing::Equispaced, nodes, cells, boundary: Facets::new(), part_names };
        mesh.set_linear_facets(facets);
        mesh
    }

    /// The vertices of cell `c` of a linear mesh, in its kind's vertex
    /// order: [`CurvedMesh::linear`]'s input.
    pub fn vertices(&self, c: usize) -> SmallVec<[usize; 8]> {
        debug_assert_eq!(self.p, 1, "the vertices of a linear mesh's cell");
        reordered(self.cells.shape(c), &self.cells[c])
    }

    /// Gives cell `c` of a linear mesh the vertices `v` (its kind's vertex
    /// order), as [`CurvedMesh::linear`] would.
    pub fn set_vertices(&mut self, c: usize, v: &[usize]) {
        let shape = self.cells.shape(c);
        self.cells[c].copy_from_slice(&reordered(shape, v));
    }

    /// The boundary elements of a linear mesh as corners in cyclic order
    /// and part: [`CurvedMesh::linear`]'s input.
    pub fn linear_facets(&self) -> Vec<(Vec<usize>, usize)> {
        debug_assert_eq!(self.p, 1, "the corners of a linear mesh's boundary");
        self.boundary.iter().map(|b| (reordered(b.shape, b.nodes).to_vec(), b.part)).collect()
    }

    /// Replaces the boundary elements by `facets` (corners in cyclic order
    /// and part) of a linear mesh.
    pub fn set_linear_facets<F: AsRef<[usize]>>(&mut self, facets: impl IntoIterator<Item = (F, usize)>) {
        self.boundary = facets
            .into_iter()
            .map(|(f, part)| {
                let f = f.as_ref();
                let shape = Shape::with_nodes(D - 1, 1, f.len()).unwrap_or(Self::TENSOR.facet_shape());
                (shape, reordered(shape, f), part)
            })
            .collect();
    }

    /// How many cells are of `shape`.
    pub fn count(&self, shape: Shape) -> usize {
        self.cells.blocks().iter().filter(|b| b.shape == shape).map(|b| b.len()).sum()
    }
}

/// The order-1 nodes `v` of a `shape` in the other order: vertex order
/// from node order and back ([`linear_order`] is its own inverse).
fn reordered(shape: Shape, v: &[usize]) -> SmallVec<[usize; 8]> {
    let order = linear_order(shape);
    if order.len() != v.len() {
        // not an order-1 cell of its kind: as it is, for `validate` to name
        return SmallVec::from_slice(v);
    }
    order.iter().map(|&k| v[k]).collect()
}

#[cfg(test)]
/// Tests, and bent test meshes the MSH and VTU tests share (`pub`: a
/// test module as `scripts/deps.py` recognises one).
pub mod tests {
    use super::*;
    use crate::mesh::element::{hex_map, quad_map};
    use crate::quality::certify::certify;

    /// Smooth non-affine maps of the unit square and cube, for test meshes
    /// (also of the file tests).
    pub(crate) fn bend2([x, y]: [f64; 2]) -> [f64; 2] {
        [x + 0.1 * (2.0 * y).sin(), y + 0.15 * x * x]
    }

    /// See [`bend2`].
    pub(crate) fn bend3([x, y, z]: [f64; 3]) -> [f64; 3] {
        [x + 0.1 * (2.0 * y).sin(), y + 0.1 * x * z, z - 0.1 * x * x]
    }

    #[test]
    fn structured_mesh_is_consistent_and_valid() {
        let m = CurvedMesh::<2>::structured(3, Spacing::Equispaced, [2, 3], bend2).unwrap();
        m.validate().unwrap();
        assert_eq!(m.nodes.len(), 7 * 10);
        assert_eq!(m.cells.len(), 6);
        assert_eq!(m.boundary.len(), 2 * (2 + 3));
        for c in 0..m.cells.len() {
            assert!(certify(3, m.spacing, &m.cell_coords(c)).unwrap().valid);
        }
        // bottom edge of cell 0 runs along +x: its nodes are the cell's
        // first row; left edge runs downwards (domain on the left)
        assert_eq!(
            *m.boundary.iter().find(|b| b.part == 2).unwrap().nodes,
            m.cells[0][..4]
        );
        let left = m.boundary.iter().find(|b| b.part == 0).unwrap().nodes;
        assert_eq!(left[0], m.cells[0][12]);
        assert_eq!(left[3], m.cells[0][0]);
        let h = CurvedMesh::<3>::structured(2, Spacing::GaussLobatto, [2, 1, 1], bend3).unwrap();
        h.validate().unwrap();
        assert_eq!(h.boundary.len(), 2 * (1 + 2 + 2));
        assert!(certify(2, h.spacing, &h.cell_coords(1)).unwrap().valid);
    }

    /// Resampling a Gauss–Lobatto mesh keeps the geometry: the equispaced
    /// element maps the same points (same polynomial space).
    #[test]
    fn gauss_lobatto_mesh_is_resampled_onto_the_same_map() {
        let g = CurvedMesh::<2>::structured(4, Spacing::GaussLobatto, [2, 2], bend2).unwrap();
        let e = g.to_equispaced();
        assert_eq!(e.spacing, Spacing::Equispaced);
        let h = CurvedMesh::<3>::structured(3, Spacing::GaussLobatto, [1, 1, 2], bend3).unwrap();
        let he = h.to_equispaced();
        for xi in [[0.1, 0.2], [0.77, 0.5], [0.33, 0.91]] {
            for c in 0..4 {
                let a = quad_map(4, Spacing::GaussLobatto, &g.cell_coords(c), xi)
                    .unwrap()
                    .0;
                let b = quad_map(4, Spacing::Equispaced, &e.cell_coords(c), xi)
                    .unwrap()
                    .0;
                assert!((a[0] - b[0]).abs() < 1e-13 && (a[1] - b[1]).abs() < 1e-13);
            }
            let x3 = [xi[0], xi[1], 0.4];
            let a = hex_map(3, Spacing::GaussLobatto, &h.cell_coords(1), x3)
                .unwrap()
                .0;
            let b = hex_map(3, Spacing::Equispaced, &he.cell_coords(1), x3)
                .unwrap()
                .0;
            assert!((0..3).all(|d| (a[d] - b[d]).abs() < 1e-13));
        }
    }
}
