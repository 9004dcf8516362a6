//! Algorithm 2: refine, then deform onto the true boundary.
//!
//! Every coarse cell is split at the nodes of an order-p Lagrange element
//! (p^d Q1 sub-cells, nodes shared between neighbours), so each coarse
//! cell's (p+1)^d fine nodes are the nodes of one curved element
//! afterwards. The new boundary nodes lie on the flat coarse boundary;
//! Algorithm 1 on the fine mesh, with a uniform f, carries them onto the
//! true geometry while the interior follows:
//!
//! - old (coarse) nodes are fixed: the boundary ones are on the geometry,
//!   and the interior ones keep the layers (a first layer of 1e-5 moved by
//!   13% at its vertices when they were free);
//! - a new node inside a coarse boundary edge (2D) or face (3D) of a moving
//!   part slides onto `Γ_t(s) = P₀(s) + t (X(P₀(s)) − P₀(s))`, the blend of
//!   the flat coarse facet P₀ and its image X on the target (`u·n = v·n/f`,
//!   put back onto Γ_t after every step), or with Dirichlet data follows
//!   its straight path to X(x₀) (the paper's choice);
//! - in 3D a new node on a coarse edge glides along that edge's blended
//!   curve (its two components across the curve prescribed), except on an
//!   edge inside one flat slip plane (two coplanar facets of one slip
//!   part): there it slides in the plane like a facet node (u·n = 0, put
//!   back onto the plane). Held on its straight edge, such a node 1e-5 from
//!   a curved wall could not follow the wall's new nodes, which move out by
//!   the sagitta, and a thin boundary layer tangled at t ≈ 1e-5 / sagitta;
//! - a curved slip wall is a target like a moving part: the new nodes go
//!   onto it; a flat slip wall keeps its nodes gliding in its plane;
//! - fixed parts stay.

use crate::deform::{BoundaryModel, BoundaryPart, Correspondence, DeformError, MoveMode, PartKind, Q1Mesh};
use crate::lsfem::Constraint;
use crate::mesh::element::{nodes_1d, prism, pyramid, simplex, Shape, Spacing};
use crate::mesh::mixed::{hex_tets, prism_tets, pyramid_tets};
use crate::mesh::{cell_faces, cut_quad, BoundaryEdge, Cells, BoundaryFace, CurvedMesh, HexMesh, PlaneMesh, TetMesh, TriMesh};
use crate::numeric::{dist2, dot, norm, unit};
use crate::geometry::ClosestPoint;
use std::collections::HashMap;
use std::sync::{Arc, OnceLock};
use rayon::prelude::*;

/// A coarse Q1 mesh that can be subdivided: its boundary facets (edges in
/// 2D, faces in 3D) and how a fine mesh of the same kind is put together.
pub trait Subdividable<const D: usize, const N: usize>: Q1Mesh<D, N> {
    /// Boundary facets: `2^(D−1)` nodes each (in the facet's own cyclic
    /// order) and the part index.
    fn facets(&self) -> Vec<(Vec<usize>, usize)>;
    /// Part names.
    fn names(&self) -> &[String];
    /// A mesh of this kind from fine nodes, cells and boundary facets.
    fn assemble(nodes: Vec<[f64; D]>, cells: Vec<[usize; N]>, facets: Vec<(Vec<usize>, usize)>, names: Vec<String>) -> Self;
}

impl<const N: usize> Subdividable<2, N> for PlaneMesh<N> {
    fn facets(&self) -> Vec<(Vec<usize>, usize)> {
        self.edges.iter().map(|e| (e.nodes.to_vec(), e.part)).collect()
    }
    fn names(&self) -> &[String] {
        &self.part_names
    }
    fn assemble(nodes: Vec<[f64; 2]>, cells: Vec<[usize; N]>, facets: Vec<(Vec<usize>, usize)>, names: Vec<String>) -> Self {
        let edges = facets.into_iter().map(|(n, part)| BoundaryEdge { nodes: [n[0], n[1]], part }).collect();
        PlaneMesh { nodes, cells, edges, part_names: names }
    }
}

impl Subdividable<3, 8> for HexMesh {
    fn facets(&self) -> Vec<(Vec<usize>, usize)> {
        self.faces.iter().map(|f| (f.nodes.to_vec(), f.part)).collect()
    }
    fn names(&self) -> &[String] {
        &self.part_names
    }
    fn assemble(nodes: Vec<[f64; 3]>, cells: Vec<[usize; 8]>, facets: Vec<(Vec<usize>, usize)>, names: Vec<String>) -> Self {
        let faces = facets.into_iter().map(|(n, part)| BoundaryFace { nodes: [n[0], n[1], n[2], n[3]], part }).collect();
        HexMesh { nodes, cells, faces, part_names: names }
    }
}

impl Subdividable<3, 4> for TetMesh {
    fn facets(&self) -> Vec<(Vec<usize>, usize)> {
        self.faces.iter().map(|f| (f.nodes.to_vec(), f.part)).collect()
    }
    fn names(&self) -> &[String] {
        &self.part_names
    }
    fn assemble(nodes: Vec<[f64; 3]>, cells: Vec<[usize; 4]>, facets: Vec<(Vec<usize>, usize)>, names: Vec<String>) -> Self {
        let faces = facets.into_iter().map(|(n, part)| BoundaryFace { nodes: [n[0], n[1], n[2]], part }).collect();
        TetMesh { nodes, cells, faces, part_names: names }
    }
}

/// Where a fine boundary node sits on the coarse boundary.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Place {
    /// Not on the boundary.
    Interior,
    /// A coarse node.
    Vertex,
    /// Inside coarse facet `facet`, at its reference coordinates s.
    Facet { facet: usize, s: [f64; 2] },
    /// Inside the coarse edge `edge` (3D), at σ from its first end.
    Edge { edge: usize, sigma: f64 },
}

/// A coarse mesh split at the nodes of order-p elements.
#[derive(Clone, Debug)]
pub struct Subdivision<M, const D: usize> {
    /// The Q1 mesh of the p^d sub-cells of every coarse cell.
    pub fine: M,
    /// The coarse cells' shape.
    pub shape: Shape,
    /// Per coarse cell, its fine nodes in the element's order (tensor
    /// order, first reference axis fastest, or its kind's lattice order),
    /// in blocks of one kind.
    pub elements: Cells,
    /// Per coarse boundary facet, its (p+1)^(D−1) fine nodes in tensor
    /// order of the facet's own frame, and its part.
    pub facets: Vec<(Vec<usize>, usize)>,
    /// The fine index of every coarse node.
    pub coarse_nodes: Vec<usize>,
    /// The order.
    pub p: usize,
    /// Coarse facet corners (start positions), for Γ_t.
    facet_corners: Vec<Vec<[f64; D]>>,
    /// Coarse boundary edges in 3D: end positions and the facets they bound.
    edges: Vec<([[f64; D]; 2], Vec<usize>)>,
    places: Vec<Place>,
    /// Per fine node inside a coarse edge (3D): the facets holding it and
    /// its parameters on each.
    on_facets: HashMap<usize, Vec<(usize, [f64; 2])>>,
}

impl<M, const D: usize> Subdivision<M, D> {
    /// The kind of coarse element `e` (a mixed mesh holds quads and
    /// triangles, or tetrahedra and prisms).
    pub fn element_shape(&self, e: usize) -> Shape {
        self.elements.shape(e)
    }

    /// The kinds of its elements, in the order of [`Shape`].
    pub fn shapes(&self) -> Vec<Shape> {
        let mut out: Vec<Shape> = self.elements.blocks().iter().map(|b| b.shape).collect();
        out.push(self.shape);
        out.sort();
        out.dedup();
        out
    }
}

/// A topological name for a fine node, the same from every coarse cell
/// and facet that contains it.
#[derive(Clone, Copy, Debug, Hash, PartialEq, Eq)]
enum Key {
    Vertex(usize),
    /// Coarse edge (lower id, higher id), k-th of p steps from the lower.
    Edge(usize, usize, usize),
    /// Coarse face in canonical cyclic order, (u, v) in its frame.
    Face([usize; 4], usize, usize),
    /// Triangle face of tetrahedra: its corners by increasing id, and the
    /// node's barycentric indices on them.
    TriFace([usize; 3], [usize; 3]),
    Cell(usize, [usize; 3]),
    /// The centre of sub-hex `s` of coarse hex `c` in a mixed solid: a
    /// node of Algorithm 2's tetrahedra only, no element's.
    Centre(usize, usize),
}

fn edge_key(a: usize, b: usize, k: usize, p: usize) -> Key {
    if a < b { Key::Edge(a, b, k) } else { Key::Edge(b, a, p - k) }
}

/// The key of the node at (u, v) of a face with cyclic corners q, where
/// q0 is at (0, 0), q1 at (p, 0), q2 at (p, p), q3 at (0, p). The frame
/// is made canonical: origin at the smallest id, first axis towards its
/// smaller neighbour.
fn face_key(q: [usize; 4], u: usize, v: usize, p: usize) -> Key {
    let pos = [(0, 0), (p, 0), (p, p), (0, p)];
    let m = (0..4).min_by_key(|&k| q[k]).expect("four corners");
    let (n1, n3) = ((m + 1) % 4, (m + 3) % 4);
    let (a, b) = if q[n1] < q[n3] { (n1, n3) } else { (n3, n1) };
    let dist = |from: (usize, usize), to: (usize, usize)| if from.0 != to.0 { u.abs_diff(from.0) } else { v.abs_diff(from.1) };
    let (o, pa, pb) = (pos[m], pos[a], pos[b]);
    Key::Face([q[m], q[a], q[(m + 2) % 4], q[b]], dist(o, pa), dist(o, pb))
}

/// Local corner number of the reference corner with coordinates `bits`
/// ∈ {0,1}^D (Q1 node order: counter-clockwise, bottom face first).
fn corner_index<const D: usize>(bits: [usize; D]) -> usize {
    const TABLE: [usize; 8] = [0, 1, 3, 2, 4, 5, 7, 6];
    TABLE[(0..D).map(|d| bits[d] << d).sum::<usize>()]
}

/// The key of tensor node `idx` of coarse cell `c` with corners `cell`.
fn cell_key<const D: usize, const N: usize>(c: usize, cell: &[usize; N], idx: [usize; D], p: usize) -> Key {
    let inner: Vec<usize> = (0..D).filter(|&d| idx[d] != 0 && idx[d] != p).collect();
    let corner = |over: &[(usize, usize)]| {
        let mut bits: [usize; D] = idx.map(|i| usize::from(i == p));
        for &(d, b) in over {
            bits[d] = b;
        }
        cell[corner_index(bits)]
    };
    match inner.len() {
        0 => Key::Vertex(corner(&[])),
        1 => edge_key(corner(&[(inner[0], 0)]), corner(&[(inner[0], 1)]), idx[inner[0]], p),
        2 if D == 3 => {
            let (d1, d2) = (inner[0], inner[1]);
            let q = [corner(&[(d1, 0), (d2, 0)]), corner(&[(d1, 1), (d2, 0)]), corner(&[(d1, 1), (d2, 1)]), corner(&[(d1, 0), (d2, 1)])];
            face_key(q, idx[d1], idx[d2], p)
        }
        _ => Key::Cell(c, std::array::from_fn(|d| if d < D { idx[d] } else { 0 })),
    }
}

/// The key of node (u, v) (v = 0 for an edge) of a boundary facet.
fn facet_key(q: &[usize], u: usize, v: usize, p: usize) -> Key {
    if q.len() == 2 {
        return match u {
            0 => Key::Vertex(q[0]),
            u if u == p => Key::Vertex(q[1]),
            u => edge_key(q[0], q[1], u, p),
        };
    }
    let q = [q[0], q[1], q[2], q[3]];
    let (ub, vb) = (u == 0 || u == p, v == 0 || v == p);
    let corner = |u: usize, v: usize| match (u == p, v == p) {
        (false, false) => q[0],
        (true, false) => q[1],
        (true, true) => q[2],
        (false, true) => q[3],
    };
    match (ub, vb) {
        (true, true) => Key::Vertex(corner(u, v)),
        (false, true) => edge_key(corner(0, v), corner(p, v), u, p),
        (true, false) => edge_key(corner(u, 0), corner(u, p), v, p),
        (false, false) => face_key(q, u, v, p),
    }
}

/// All tensor indices of a (p+1)^D grid, first axis fastest.
fn tensor_indices<const D: usize>(p: usize) -> impl Iterator<Item = [usize; D]> {
    let n = p + 1;
    (0..n.pow(D as u32)).map(move |k| std::array::from_fn(|d| (k / n.pow(d as u32)) % n))
}

/// Why a mesh cannot be subdivided.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SubdivideError {
    /// An element order outside 1..=4.
    #[error("subdivision at the nodes of order {0}: the order must be 1..={max}", max = crate::mesh::element::MAX_ORDER)]
    Order(usize),
    /// A boundary element is not an edge (face) of any cell.
    #[error("boundary element {index} (nodes {nodes:?}, group `{part}`) is not an edge or face of any cell")]
    NotACellFacet {
        /// Its index among the boundary elements.
        index: usize,
        /// Its nodes (0-based).
        nodes: Vec<usize>,
        /// Its group.
        part: String,
    },
    /// A boundary element between two cells: an interior curve (surface)
    /// in a boundary group would add a false flux and hold interior nodes.
    #[error("boundary element {index} (nodes {nodes:?}) of group `{part}` lies inside the mesh, between two cells: a boundary group may hold only edges (faces) of exactly one cell; remove the interior curves (surfaces) from the group")]
    InteriorFacet {
        /// Its index among the boundary elements.
        index: usize,
        /// Its nodes (0-based).
        nodes: Vec<usize>,
        /// Its group.
        part: String,
    },
    /// Cell edges (faces) on the boundary that no boundary element covers:
    /// their nodes would move freely.
    #[error("{count} edge(s)/face(s) on the boundary of the mesh are in no boundary group (first with nodes {first:?}): save every boundary element with a physical group (in Gmsh, add the group, or set Mesh.SaveAll = 1)")]
    Uncovered {
        /// How many.
        count: usize,
        /// The nodes (0-based) of the first.
        first: Vec<usize>,
    },
}

/// The outward facets of a cell in cyclic order: its edges counter-
/// clockwise (2D) or its faces counter-clockwise seen from outside (3D).
fn cell_facets<const D: usize, const N: usize>(cell: &[usize; N]) -> Vec<Vec<usize>> {
    if D == 2 {
        (0..N).map(|k| vec![cell[k], cell[(k + 1) % N]]).collect()
    } else if N == 4 {
        Shape::Tetrahedron.faces().iter().map(|(_, f)| f.iter().map(|&k| cell[k]).collect()).collect()
    } else {
        crate::mesh::HEX_FACES.iter().map(|f| f.iter().map(|&k| cell[k]).collect()).collect()
    }
}

/// `q` as a rotation of `f` (same orientation), of its reverse (opposite),
/// or neither.
fn orientation(q: &[usize], f: &[usize]) -> Option<bool> {
    let n = f.len();
    if n == 2 {
        // an edge's rotation is its reverse: only the order tells
        return (q.len() == 2 && (q[0] == f[0] || q[0] == f[1])).then_some(q[0] == f[0]);
    }
    let start = f.iter().position(|&v| v == q[0])?;
    if (0..n).all(|k| q[k] == f[(start + k) % n]) {
        return Some(true);
    }
    if (0..n).all(|k| q[k] == f[(start + n - k) % n]) {
        return Some(false);
    }
    None
}

/// The boundary facets of `coarse`, each oriented like the outward facet
/// of its cell (the flux quadrature relies on it: Gmsh keeps the
/// orientation of the geometry's curves, which may run either way), and
/// checked to cover the whole boundary.
fn oriented_facets<M: Subdividable<D, N>, const D: usize, const N: usize>(coarse: &M) -> Result<Vec<(Vec<usize>, usize)>, SubdivideError> {
    orient_facets(coarse.cells().iter().map(|c| cell_facets::<D, N>(c)), coarse.facets(), coarse.names())
}

/// [`oriented_facets`] from every cell's outward facets (`cell_facets`),
/// the boundary facets and the part names.
fn orient_facets(cell_facets: impl Iterator<Item = Vec<Vec<usize>>>, facets: Vec<(Vec<usize>, usize)>, names: &[String]) -> Result<Vec<(Vec<usize>, usize)>, SubdivideError> {
    let key = |f: &[usize]| {
        let mut k = f.to_vec();
        k.sort_unstable();
        k
    };
    // every cell facet, by its node set: how many cells hold it, and one of
    // them in outward order
    let mut owners: HashMap<Vec<usize>, (usize, Vec<usize>)> = HashMap::new();
    for f in cell_facets.flatten() {
        owners.entry(key(&f)).and_modify(|o| o.0 += 1).or_insert((1, f));
    }
    let mut covered = std::collections::HashSet::new();
    let mut out = Vec::new();
    for (index, (q, part)) in facets.into_iter().enumerate() {
        let k = key(&q);
        let outward = owners.get(&k).and_then(|(n, f)| orientation(&q, f).map(|same| (same, f, *n)));
        let name = |part: usize| names.get(part).cloned().unwrap_or_else(|| format!("#{part}"));
        let Some((same, f, owners)) = outward else {
            return Err(SubdivideError::NotACellFacet { index, nodes: q, part: name(part) });
        };
        if owners != 1 {
            return Err(SubdivideError::InteriorFacet { index, nodes: q, part: name(part) });
        }
        out.push((if same { q } else { f.clone() }, part));
        covered.insert(k);
    }
    let mut open: Vec<&Vec<usize>> = owners.iter().filter(|(k, o)| o.0 == 1 && !covered.contains(*k)).map(|(_, o)| &o.1).collect();
    open.sort();
    if let Some(first) = open.first() {
        return Err(SubdivideError::Uncovered { count: open.len(), first: first.to_vec() });
    }
    Ok(out)
}

/// Splits every cell of `coarse` at the nodes of its order-`p` Lagrange
/// element with nodes at `spacing` (on tensor cells the products of the
/// 1D nodes, on simplices the simplex node set of
/// [`crate::mesh::element::simplex`], whose edges carry the same 1D
/// nodes, so a triangle and a quad next to it share their edge's nodes).
/// Boundary facets are checked against the cells and oriented like them.
pub fn subdivide<M: Subdividable<D, N>, const D: usize, const N: usize>(coarse: &M, p: usize, spacing: Spacing) -> Result<Subdivision<M, D>, SubdivideError> {
    let t = nodes_1d(p, spacing).map_err(|_| SubdivideError::Order(p))?;
    let coarse_facets = oriented_facets(coarse)?;
    let mut ids: HashMap<Key, usize> = HashMap::new();
    let mut nodes: Vec<[f64; D]> = Vec::new();
    let (elements, sub_cells) = if crate::lsfem::is_simplex(D, N) {
        simplex_elements(coarse, p, spacing, &mut ids, &mut nodes)
    } else {
        tensor_elements(coarse, &t, &mut ids, &mut nodes)
    };
    let b = boundary_places(coarse.nodes(), coarse_facets, &ids, nodes.len(), p, &t, spacing);
    let fine = M::assemble(nodes, sub_cells, b.fine_facets, coarse.names().to_vec());
    let shape = linear_shape::<D, N>();
    let elements = Cells::from_cells(D, p, shape, elements);
    let Boundary { places, facets, facet_corners, edges, on_facets, coarse_nodes, .. } = b;
    Ok(Subdivision { fine, shape, elements, facets, coarse_nodes, p, facet_corners, edges, places, on_facets })
}

/// Splits a mixed mesh of quads and triangles as [`subdivide`] does,
/// every element at its own kind's nodes (their edges carry the same 1D
/// nodes, so neighbours of either kind share them). Algorithm 2's mesh is
/// of triangles: each of a quad's p² Q1 sub-cells is cut along its
/// shorter diagonal, so one P1 system serves both kinds (the elements
/// stay order-p quads; only the flow that places their nodes runs on
/// triangles). Returns, per fine cell, the coarse cell it lies in.
pub fn subdivide_mixed(coarse: &CurvedMesh<2>, p: usize, spacing: Spacing) -> Result<(Subdivision<TriMesh, 2>, Vec<usize>), SubdivideError> {
    let t = nodes_1d(p, spacing).map_err(|_| SubdivideError::Order(p))?;
    let facets = coarse.linear_facets();
    let per_cell = (0..coarse.cells.len()).map(|c| {
        let n = coarse.vertices(c);
        (0..n.len()).map(|k| vec![n[k], n[(k + 1) % n.len()]]).collect()
    });
    let coarse_facets = orient_facets(per_cell, facets, &coarse.part_names)?;
    let space = simplex::space(Shape::Triangle, p, spacing).map_err(|_| SubdivideError::Order(p))?;
    let lattice = simplex::lattice(Shape::Triangle, p);
    let subs = simplex::sub_simplices(Shape::Triangle, p);
    let mut ids: HashMap<Key, usize> = HashMap::new();
    let mut nodes: Vec<[f64; 2]> = Vec::new();
    let (mut elements, mut sub_cells, mut owner) = (Cells::new(), Vec::new(), Vec::new());
    for c in 0..coarse.cells.len() {
        let before = sub_cells.len();
        match *coarse.vertices(c).as_slice() {
            [a, b, d, e] => {
                let el = tensor_element::<2, 4>(c, &[a, b, d, e], &coarse.nodes, &t, &mut ids, &mut nodes);
                for sub in tensor_sub_cells::<2, 4>(&el, p) {
                    sub_cells.extend(split_quad(sub, &nodes));
                }
                elements.push(Shape::Quadrilateral, &el);
            }
            [a, b, d] => {
                let el = simplex_element::<2, 3>(c, &[a, b, d], &coarse.nodes, (&lattice, &space.nodes, p), &mut ids, &mut nodes);
                sub_cells.extend(subs.iter().map(|s| std::array::from_fn(|a| el[s[a]])));
                elements.push(Shape::Triangle, &el);
            }
            ref v => unreachable!("a plane cell of {} vertices", v.len()),
        }
        owner.resize(owner.len() + sub_cells.len() - before, c);
    }
    let b = boundary_places(&coarse.nodes, coarse_facets, &ids, nodes.len(), p, &t, spacing);
    let fine = TriMesh::assemble(nodes, sub_cells, b.fine_facets, coarse.part_names.clone());
    let shape = coarse.shape;
    let Boundary { places, facets, facet_corners, edges, on_facets, coarse_nodes, .. } = b;
    Ok((Subdivision { fine, shape, elements, facets, coarse_nodes, p, facet_corners, edges, places, on_facets }, owner))
}

/// Splits a mixed solid of tetrahedra, prisms, pyramids and hexes as
/// [`subdivide`] does, every element at its own kind's nodes (faces carry
/// a triangle's or a quad's nodes, so neighbours of any kinds share them).
/// Algorithm 2's mesh is of tetrahedra, so one P1 system serves every
/// kind and the elements keep theirs: each of a prism's p³ sub-prisms is
/// cut into three ([`prism_tets`]), a pyramid's sub-pyramids into two
/// ([`pyramid_tets`]), and each of a hex's p³ sub-hexes into six pyramids
/// on its faces with their apex at a new centre node, then two each (a
/// hex cut on its face diagonals alone needs such a node for some choices
/// of the diagonals: Dompierre et al. 1999). Every quad is cut along the
/// diagonal through its smallest node number, so neighbours cut a shared
/// quad alike. The centre nodes come after every element's nodes (fine
/// nodes `0..m` are the elements', `m` the largest element node + 1).
/// Returns, per fine cell, the coarse cell it lies in.
pub fn subdivide_mixed_solid(coarse: &CurvedMesh<3>, p: usize, spacing: Spacing) -> Result<(Subdivision<TetMesh, 3>, Vec<usize>), SubdivideError> {
    let t = nodes_1d(p, spacing).map_err(|_| SubdivideError::Order(p))?;
    let per_cell = (0..coarse.cells.len()).map(|c| cell_faces(coarse.cells.shape(c), &coarse.vertices(c)));
    let coarse_facets = orient_facets(per_cell, coarse.linear_facets(), &coarse.part_names)?;
    let tet_space = simplex::space(Shape::Tetrahedron, p, spacing).map_err(|_| SubdivideError::Order(p))?;
    let tet_lattice = simplex::lattice(Shape::Tetrahedron, p);
    let tets = simplex::sub_simplices(Shape::Tetrahedron, p);
    let prism_space = prism::space(p, spacing).map_err(|_| SubdivideError::Order(p))?;
    let prism_lattice = prism::lattice(p);
    let sub_prisms = prism::sub_prisms(p);
    let pyramid_space = pyramid::space(p, spacing).map_err(|_| SubdivideError::Order(p))?;
    let pyramid_lattice = pyramid::lattice(p);
    let (sub_pyramids, pyramid_sub_tets) = pyramid::sub_cells(p);
    let mut sub_hexes: Vec<(usize, [usize; 8])> = Vec::new();
    let mut ids: HashMap<Key, usize> = HashMap::new();
    let mut nodes: Vec<[f64; 3]> = Vec::new();
    let (mut elements, mut sub_cells, mut owner) = (Cells::new(), Vec::new(), Vec::new());
    for c in 0..coarse.cells.len() {
        let before = sub_cells.len();
        let v = coarse.vertices(c);
        match coarse.cells.shape(c) {
            Shape::Tetrahedron => {
                let el = simplex_element::<3, 4>(c, &[v[0], v[1], v[2], v[3]], &coarse.nodes, (&tet_lattice, &tet_space.nodes, p), &mut ids, &mut nodes);
                sub_cells.extend(tets.iter().map(|s| std::array::from_fn(|a| el[s[a]])));
                elements.push(Shape::Tetrahedron, &el);
            }
            Shape::Prism => {
                let el = keyed_element((c, &std::array::from_fn(|k| v[k]), &coarse.nodes), (&prism_lattice, &prism_space.nodes, p), prism_key, prism_point, &mut ids, &mut nodes);
                for s in &sub_prisms {
                    sub_cells.extend(prism_tets(s.map(|a| el[a])));
                }
                elements.push(Shape::Prism, &el);
            }
            Shape::Pyramid => {
                let el = keyed_element((c, &std::array::from_fn(|k| v[k]), &coarse.nodes), (&pyramid_lattice, &pyramid_space.nodes, p), pyramid_key, pyramid_point, &mut ids, &mut nodes);
                for s in &sub_pyramids {
                    sub_cells.extend(pyramid_tets(s.map(|a| el[a])));
                }
                sub_cells.extend(pyramid_sub_tets.iter().map(|s| s.map(|a| el[a])));
                elements.push(Shape::Pyramid, &el);
            }
            Shape::Hexahedron => {
                let el = tensor_element::<3, 8>(c, &std::array::from_fn(|k| v[k]), &coarse.nodes, &t, &mut ids, &mut nodes);
                sub_hexes.extend(tensor_sub_cells::<3, 8>(&el, p).map(|h| (c, h)));
                elements.push(Shape::Hexahedron, &el);
            }
            other => unreachable!("{other:?} is not a solid cell"),
        }
        owner.resize(owner.len() + sub_cells.len() - before, c);
    }
    // the hexes' tetrahedra, about their centres, made last
    for (s, &(c, h)) in sub_hexes.iter().enumerate() {
        let centre = nodes.len();
        nodes.push(std::array::from_fn(|d| h.iter().map(|&n| nodes[n][d]).sum::<f64>() / 8.0));
        ids.insert(Key::Centre(c, s), centre);
        sub_cells.extend(hex_tets(h, centre));
        owner.extend([c; 12]);
    }
    let mut b = boundary_places(&coarse.nodes, coarse_facets, &ids, nodes.len(), p, &t, spacing);
    // the tetrahedra's faces on a quad facet: its sub-quads cut as the
    // sub-prisms beside them are
    let fine_facets = b.fine_facets.drain(..).flat_map(|(f, part)| match f.len() {
        4 => cut_quad([f[0], f[1], f[2], f[3]]).into_iter().map(|t| (t.to_vec(), part)).collect::<Vec<_>>(),
        _ => vec![(f, part)],
    });
    let fine = TetMesh::assemble(nodes, sub_cells, fine_facets.collect(), coarse.part_names.clone());
    let shape = coarse.shape;
    let Boundary { places, facets, facet_corners, edges, on_facets, coarse_nodes, .. } = b;
    Ok((Subdivision { fine, shape, elements, facets, coarse_nodes, p, facet_corners, edges, places, on_facets }, owner))
}

/// The fine nodes of prism or pyramid `c` with corners `cell` (lattice
/// order of [`prism`] or [`pyramid`]), made or found by their `key`s, new
/// ones at `point` of the linear cell; `(lattice, xi, p)` as for
/// [`simplex_element`].
fn keyed_element<const V: usize>(
    (c, cell, at): (usize, &[usize; V], &[[f64; 3]]),
    (lattice, xi, p): (&[[usize; 3]], &[[f64; 3]], usize),
    key: fn(usize, &[usize; V], [usize; 3], usize) -> Key,
    point: fn(&[[f64; 3]; V], [f64; 3]) -> [f64; 3],
    ids: &mut HashMap<Key, usize>,
    nodes: &mut Vec<[f64; 3]>,
) -> Vec<usize> {
    let corners = cell.map(|n| at[n]);
    lattice
        .iter()
        .zip(xi)
        .map(|(idx, xi)| {
            *ids.entry(key(c, cell, *idx, p)).or_insert_with(|| {
                nodes.push(point(&corners, *xi));
                nodes.len() - 1
            })
        })
        .collect()
}

/// The point of the linear pyramid with `corners` at reference `ξ`: the
/// base's bilinear point at the collapsed `(a, b)`, moved towards the
/// apex by `c` ([`pyramid::collapse`]).
fn pyramid_point(corners: &[[f64; 3]; 5], xi: [f64; 3]) -> [f64; 3] {
    let [a, b, c] = pyramid::collapse(xi);
    let w = [(1.0 - a) * (1.0 - b), a * (1.0 - b), a * b, (1.0 - a) * b];
    std::array::from_fn(|d| (1.0 - c) * (0..4).map(|k| w[k] * corners[k][d]).sum::<f64>() + c * corners[4][d])
}

/// The key of lattice node `(i, j, k)` of pyramid `c` with corners
/// `cell`: on the base (k = 0) the quad's, as a hex or prism names it; on
/// a triangle face (its edges and the apex too) the triangle's, as a
/// tetrahedron or prism names it; else inside the cell.
fn pyramid_key(c: usize, cell: &[usize; 5], [i, j, k]: [usize; 3], p: usize) -> Key {
    if k == 0 {
        return facet_key(&cell[..4], i, j, p);
    }
    let n = p - k;
    // each lateral face with the node's barycentric indices on it
    let face = if j == 0 {
        Some(([cell[0], cell[1], cell[4]], [n - i, i, k]))
    } else if j == n {
        Some(([cell[3], cell[2], cell[4]], [n - i, i, k]))
    } else if i == 0 {
        Some(([cell[0], cell[3], cell[4]], [n - j, j, k]))
    } else if i == n {
        Some(([cell[1], cell[2], cell[4]], [n - j, j, k]))
    } else {
        None
    };
    face.and_then(|(corners, bary)| sub_simplex_key(&corners, &bary, p, true)).unwrap_or(Key::Cell(c, [i, j, k]))
}

/// The point of the linear prism with `corners` at reference `ξ`: the
/// triangle's barycentric weights times the two layers'.
fn prism_point(corners: &[[f64; 3]; 6], xi: [f64; 3]) -> [f64; 3] {
    let tri = [1.0 - xi[0] - xi[1], xi[0], xi[1]];
    let w = |a: usize| tri[a % 3] * if a < 3 { 1.0 - xi[2] } else { xi[2] };
    std::array::from_fn(|d| (0..6).map(|a| w(a) * corners[a][d]).sum())
}

/// The key of lattice node `(i, j, k)` of prism `c` with corners `cell`:
/// on the bottom (k = 0) or top (k = p) triangle the triangle's key;
/// between them, on a vertical edge its edge's, on a quad face the quad's
/// (as a hex names it), else inside the cell.
fn prism_key(c: usize, cell: &[usize; 6], [i, j, k]: [usize; 3], p: usize) -> Key {
    let bary = [p - i - j, i, j];
    if k == 0 || k == p {
        let layer = if k == 0 { &cell[..3] } else { &cell[3..] };
        return sub_simplex_key(layer, &bary, p, true).unwrap_or(Key::Cell(c, [i, j, k]));
    }
    let on: Vec<usize> = (0..3).filter(|&a| bary[a] != 0).collect();
    match on[..] {
        [a] => edge_key(cell[a], cell[a + 3], k, p),
        [a, b] => face_key([cell[a], cell[b], cell[b + 3], cell[a + 3]], bary[b], k, p),
        _ => Key::Cell(c, [i, j, k]),
    }
}

/// The two triangles of a convex Q1 sub-cell (corners counter-clockwise),
/// cut along its shorter diagonal: the better angles of the two cuts.
fn split_quad(q: [usize; 4], nodes: &[[f64; 2]]) -> [[usize; 3]; 2] {
    if dist2(nodes[q[0]], nodes[q[2]]) <= dist2(nodes[q[1]], nodes[q[3]]) {
        [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    } else {
        [[q[0], q[1], q[3]], [q[1], q[2], q[3]]]
    }
}

/// Where the boundary's fine nodes sit on the coarse boundary, and the
/// fine boundary facets ([`Subdivision`]'s boundary fields).
struct Boundary<const D: usize> {
    places: Vec<Place>,
    facets: Vec<(Vec<usize>, usize)>,
    fine_facets: Vec<(Vec<usize>, usize)>,
    facet_corners: Vec<Vec<[f64; D]>>,
    edges: Vec<([[f64; D]; 2], Vec<usize>)>,
    on_facets: HashMap<usize, Vec<(usize, [f64; 2])>>,
    coarse_nodes: Vec<usize>,
}

/// The boundary fields of a subdivision whose `count` fine nodes are
/// named by `ids`, from the oriented coarse facets.
fn boundary_places<const D: usize>(
    coarse_nodes_at: &[[f64; D]],
    coarse_facets: Vec<(Vec<usize>, usize)>,
    ids: &HashMap<Key, usize>,
    count: usize,
    p: usize,
    t: &[f64],
    spacing: Spacing,
) -> Boundary<D> {
    let n1 = p + 1;
    let mut places = vec![Place::Interior; count];
    let mut facets = Vec::new();
    let mut fine_facets = Vec::new();
    let mut facet_corners = Vec::new();
    let mut edges: Vec<([[f64; D]; 2], Vec<usize>)> = Vec::new();
    let mut edge_ids: HashMap<(usize, usize), usize> = HashMap::new();
    let mut on_facets: HashMap<usize, Vec<(usize, [f64; 2])>> = HashMap::new();
    for (f, (q, part)) in coarse_facets.into_iter().enumerate() {
        let nodes_here = facet_nodes::<D>(&q, p, &t, spacing);
        let mut grid = Vec::with_capacity(nodes_here.len());
        for &(key, s) in &nodes_here {
            let id = ids[&key];
            grid.push(id);
            places[id] = match key {
                Key::Vertex(_) => Place::Vertex,
                Key::Edge(a, b, k) if D == 3 => {
                    let e = *edge_ids.entry((a, b)).or_insert_with(|| {
                        edges.push(([coarse_nodes_at[a], coarse_nodes_at[b]], Vec::new()));
                        edges.len() - 1
                    });
                    if !edges[e].1.contains(&f) {
                        edges[e].1.push(f);
                    }
                    let on = on_facets.entry(id).or_default();
                    if !on.iter().any(|o| o.0 == f) {
                        on.push((f, s));
                    }
                    Place::Edge { edge: e, sigma: t[k] }
                }
                _ => Place::Facet { facet: f, s },
            };
        }
        // fine facets keep the coarse facet's orientation
        if D == 2 {
            fine_facets.extend(grid.windows(2).map(|w| (vec![w[0], w[1]], part)));
        } else if q.len() == 3 {
            let subs = simplex::sub_simplices(Shape::Triangle, p);
            fine_facets.extend(subs.iter().map(|s| (vec![grid[s[0]], grid[s[1]], grid[s[2]]], part)));
        } else {
            for v in 0..p {
                for u in 0..p {
                    let at = |u: usize, v: usize| grid[v * n1 + u];
                    fine_facets.push((vec![at(u, v), at(u + 1, v), at(u + 1, v + 1), at(u, v + 1)], part));
                }
            }
        }
        facet_corners.push(q.iter().map(|&n| coarse_nodes_at[n]).collect());
        facets.push((grid, part));
    }
    let coarse_nodes: Vec<usize> = (0..coarse_nodes_at.len()).map(|n| ids.get(&Key::Vertex(n)).copied().unwrap_or(usize::MAX)).collect();
    // every coarse node stays, the interior ones too: the elements keep
    // the coarse vertices, so a thin first layer keeps its height there
    for &n in coarse_nodes.iter().filter(|&&n| n != usize::MAX) {
        places[n] = Place::Vertex;
    }
    Boundary { places, facets, fine_facets, facet_corners, edges, on_facets, coarse_nodes }
}

/// The fine nodes of every tensor cell (in tensor order), made or found
/// by their keys, and the p^D Q1 sub-cells.
fn tensor_elements<M: Subdividable<D, N>, const D: usize, const N: usize>(
    coarse: &M,
    t: &[f64],
    ids: &mut HashMap<Key, usize>,
    nodes: &mut Vec<[f64; D]>,
) -> (Vec<Vec<usize>>, Vec<[usize; N]>) {
    let p = t.len() - 1;
    let elements: Vec<Vec<usize>> = coarse.cells().iter().enumerate().map(|(c, cell)| tensor_element(c, cell, coarse.nodes(), t, ids, nodes)).collect();
    let sub_cells = elements.iter().flat_map(|el| tensor_sub_cells::<D, N>(el, p)).collect();
    (elements, sub_cells)
}

/// The fine nodes of tensor cell `c` with corners `cell` (tensor order),
/// made or found by their keys.
fn tensor_element<const D: usize, const N: usize>(c: usize, cell: &[usize; N], at: &[[f64; D]], t: &[f64], ids: &mut HashMap<Key, usize>, nodes: &mut Vec<[f64; D]>) -> Vec<usize> {
    let p = t.len() - 1;
    let corners = cell.map(|n| at[n]);
    tensor_indices::<D>(p)
        .map(|idx| {
            *ids.entry(cell_key::<D, N>(c, cell, idx, p)).or_insert_with(|| {
                let xi: [f64; D] = std::array::from_fn(|d| t[idx[d]]);
                nodes.push(at_reference(&corners, xi));
                nodes.len() - 1
            })
        })
        .collect()
}

/// The p^D Q1 sub-cells of a tensor element `el` (tensor order), corners
/// in Q1 order.
fn tensor_sub_cells<const D: usize, const N: usize>(el: &[usize], p: usize) -> impl Iterator<Item = [usize; N]> + '_ {
    let n1 = p + 1;
    tensor_indices::<D>(p - 1).map(move |idx| {
        let at = |off: [usize; D]| el[(0..D).map(|d| (idx[d] + off[d]) * n1.pow(d as u32)).sum::<usize>()];
        std::array::from_fn(|a| at(std::array::from_fn(|d| usize::from(crate::lsfem::q1_corner(a, d) == 1.0))))
    })
}

/// The shape of a linear cell of `N` nodes in dimension `D`.
pub fn linear_shape<const D: usize, const N: usize>() -> Shape {
    match (D, N) {
        (2, 3) => Shape::Triangle,
        (2, _) => Shape::Quadrilateral,
        (_, 4) => Shape::Tetrahedron,
        _ => Shape::Hexahedron,
    }
}

/// The point of the linear cell with `corners` at reference coordinates ξ.
fn at_reference<const D: usize, const N: usize>(corners: &[[f64; D]; N], xi: [f64; D]) -> [f64; D] {
    let shape = crate::lsfem::q1_shape::<D, N>(xi);
    std::array::from_fn(|k| (0..N).map(|a| shape[a] * corners[a][k]).sum())
}

/// The fine nodes of every triangle or tetrahedron (in the simplex
/// lattice order of [`crate::mesh::element::simplex`]), made or found by
/// their keys, and the p^D sub-simplices of each, oriented like it.
fn simplex_elements<M: Subdividable<D, N>, const D: usize, const N: usize>(
    coarse: &M,
    p: usize,
    spacing: Spacing,
    ids: &mut HashMap<Key, usize>,
    nodes: &mut Vec<[f64; D]>,
) -> (Vec<Vec<usize>>, Vec<[usize; N]>) {
    let shape = linear_shape::<D, N>();
    let space = simplex::space(shape, p, spacing).expect("the order was checked");
    let lattice = simplex::lattice(shape, p);
    let elements: Vec<Vec<usize>> = coarse.cells().iter().enumerate().map(|(c, cell)| simplex_element(c, cell, coarse.nodes(), (&lattice, &space.nodes, p), ids, nodes)).collect();
    let subs = simplex::sub_simplices(shape, p);
    let sub_cells = elements.iter().flat_map(|el| subs.iter().map(move |s| std::array::from_fn(|a| el[s[a]]))).collect();
    (elements, sub_cells)
}

/// The fine nodes of simplex `c` with corners `cell` (lattice order),
/// made or found by their keys; `(lattice, xi, p)` are the space's
/// lattice indices, reference nodes and order.
fn simplex_element<const D: usize, const N: usize>(
    c: usize,
    cell: &[usize; N],
    at: &[[f64; D]],
    (lattice, xi, p): (&[[usize; 3]], &[[f64; 3]], usize),
    ids: &mut HashMap<Key, usize>,
    nodes: &mut Vec<[f64; D]>,
) -> Vec<usize> {
    let corners = cell.map(|n| at[n]);
    lattice
        .iter()
        .zip(xi)
        .map(|(idx, xi)| {
            *ids.entry(simplex_key::<D, N>(c, cell, *idx, p)).or_insert_with(|| {
                nodes.push(at_reference(&corners, std::array::from_fn(|d| xi[d])));
                nodes.len() - 1
            })
        })
        .collect()
}

/// The key of lattice node `idx` (i, j, k) of simplex `c` with corners
/// `cell`: its barycentric indices (p − i − j − k, i, j, k) name the
/// vertex, edge, face or cell it is inside of, by the corners whose index
/// is not 0, so neighbours find the same node.
fn simplex_key<const D: usize, const N: usize>(c: usize, cell: &[usize; N], idx: [usize; 3], p: usize) -> Key {
    let bary: [usize; N] = std::array::from_fn(|a| if a == 0 { p - idx[..D].iter().sum::<usize>() } else { idx[a - 1] });
    sub_simplex_key(&cell[..], &bary, p, D == 3).unwrap_or(Key::Cell(c, idx))
}

/// The key of the node with barycentric indices `bary` on the simplex
/// with corners `corners`, if it lies on one of the parts neighbours
/// share: a vertex, an edge, or (`triangles_shared`: in a tetrahedral
/// mesh) a triangle. None: inside the cell.
fn sub_simplex_key(corners: &[usize], bary: &[usize], p: usize, triangles_shared: bool) -> Option<Key> {
    let on: Vec<usize> = (0..corners.len()).filter(|&a| bary[a] != 0).collect();
    match on.len() {
        1 => Some(Key::Vertex(corners[on[0]])),
        2 => Some(edge_key(corners[on[0]], corners[on[1]], bary[on[1]], p)),
        3 if triangles_shared => {
            let mut by_id: Vec<(usize, usize)> = on.iter().map(|&a| (corners[a], bary[a])).collect();
            by_id.sort_unstable();
            Some(Key::TriFace([by_id[0].0, by_id[1].0, by_id[2].0], [by_id[0].1, by_id[1].1, by_id[2].1]))
        }
        _ => None,
    }
}

/// The fine nodes of boundary facet `q` in the facet's own order (tensor
/// order of an edge or quad, lattice order of a triangle), each by its
/// key and its reference coordinates on the facet (an edge's in `s[0]`).
fn facet_nodes<const D: usize>(q: &[usize], p: usize, t: &[f64], spacing: Spacing) -> Vec<(Key, [f64; 2])> {
    let n1 = p + 1;
    if q.len() == 3 {
        let space = simplex::space(Shape::Triangle, p, spacing).expect("the order was checked");
        let lattice = simplex::lattice(Shape::Triangle, p);
        return lattice.iter().zip(&space.nodes).map(|(l, x)| (sub_simplex_key(q, &[p - l[0] - l[1], l[0], l[1]], p, true).expect("a face node"), [x[0], x[1]])).collect();
    }
    let nv = if D == 2 { 1 } else { n1 };
    (0..nv).flat_map(|v| (0..n1).map(move |u| (u, v))).map(|(u, v)| (facet_key(q, u, v, p), [t[u], if D == 2 { 0.0 } else { t[v] }])).collect()
}

/// How far the settling pass lets nodes move, in multiples of its largest
/// correction (see `RefineBoundary::hold_beyond_band`).
pub const SETTLE_BAND: f64 = 30.0;

/// Algorithm 2 solves only within this many bend lengths (about a facet's
/// size along the wall) of the new nodes of the moving parts
/// ([`Subdivision::band`]); the nodes beyond are held.
/// Why: the motion is the bulge of the curved facets, and it fades away
/// from the wall: by 3–4× per cell on the ball octant at p = 3
/// (`../shared/notes`), by about 1.6× per bend length on the extruded
/// cylinder (2.4e-2 of h on the wall, 1.4e-3 at 4–6 h, 1.6e-4 beyond 8).
/// Measured against the whole-mesh solve, relative change of the certified
/// min det J at 4 / 8 / 12 bend lengths: ball octant p = 3 8e-7 / 4e-11 /
/// 0; extruded 1e-3 layer p = 2 1.5e-4 / 3.3e-7 / 3.7e-8; tet ball in a
/// box p = 3 6e-6 / 2.4e-8 / 1e-11; the 1e-4 sphere layer in the box
/// [-3, 3]³ (`tests/python/sphere_bl.py 1e-4 3 --box 3`), p = 2, 4 steps:
/// 3.7e-5 at 8, 4.2e-7 at 12 (its facets are coarse: 3 × 3 on an octant
/// of the sphere, and the motion reaches further); boundary errors equal
/// throughout. Where the step control chooses another path, the runs
/// differ by more (the 1e-5 extruded layer at p = 3: 2 steps on the whole
/// mesh, 3 in the band, min det J 1.1 % apart).
pub const ALG2_BAND: f64 = 12.0;

/// The nodes within reach of `seeds`: breadth first through the cells,
/// each reached node carrying the seed it was reached from and kept while
/// its straight distance to that seed is within `radius(seed)`.
fn within_reach<const D: usize, const N: usize>(cells: &[[usize; N]], nodes: &[[f64; D]], seeds: &[usize], radius: impl Fn(usize) -> f64) -> Vec<bool> {
    let n = nodes.len();
    let (first, of) = crate::lsfem::node_cells(cells, n);
    let mut seed = vec![usize::MAX; n];
    let mut queue: std::collections::VecDeque<usize> = seeds.iter().copied().collect();
    for &i in seeds {
        seed[i] = i;
    }
    while let Some(i) = queue.pop_front() {
        let (from, reach) = (nodes[seed[i]], radius(seed[i]));
        for &c in &of[first[i]..first[i + 1]] {
            for &v in &cells[c as usize] {
                if seed[v] == usize::MAX && dist2(nodes[v], from).sqrt() <= reach {
                    seed[v] = seed[i];
                    queue.push_back(v);
                }
            }
        }
    }
    seed.into_iter().map(|s| s != usize::MAX).collect()
}

/// 5-point Gauss–Legendre rule on [0, 1]: (point, weight).
const GL5: [(f64, f64); 5] = [
    (0.046_910_077_030_668_0, 0.118_463_442_528_094_5),
    (0.230_765_344_947_158_5, 0.239_314_335_249_683_2),
    (0.5, 0.284_444_444_444_444_4),
    (0.769_234_655_052_841_5, 0.239_314_335_249_683_2),
    (0.953_089_922_969_332_0, 0.118_463_442_528_094_5),
];

/// Where the settling pass puts a new node of a curved facet or edge
/// ([`RefineMesh::settling`]), in the order they are tried.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Settle {
    /// At the place along the image that, with the other new nodes of its
    /// line, brings the edge's polynomial closest to the shape
    /// ([`crate::geometry::fit`]), else as `Arc`.
    Fit,
    /// At the fraction of the image's arc length its place asks for.
    Arc,
    /// At the image X(P₀(s)) of its place on the flat facet (the target of
    /// Dirichlet data): crowded towards the middle of the facet, which
    /// keeps a cell valid at a straight-angle corner where `Arc` does not.
    Image,
    /// Where sliding left it.
    Keep,
}

impl Settle {
    /// The next placement to try when this one left an element invalid.
    pub fn next(self) -> Settle {
        match self {
            Settle::Fit => Settle::Arc,
            Settle::Arc => Settle::Image,
            _ => Settle::Keep,
        }
    }
}

/// Γ_t = p0 + t (X − p0) at each starting point (its image X, else p0
/// itself).
fn moved<const D: usize>(p0: &[[f64; D]], images: Vec<Option<[f64; D]>>, t: f64) -> Vec<[f64; D]> {
    p0.iter()
        .zip(images)
        .map(|(&p0, x)| {
            let x = x.unwrap_or(p0);
            let v: [f64; D] = std::array::from_fn(|i| x[i] - p0[i]);
            std::array::from_fn(|i| p0[i] + t * v[i])
        })
        .collect()
}

/// A starting point and the direction it moves in.
type PointAndDirection<const D: usize> = ([f64; D], [f64; D]);

/// The shape that answers a carrier's images: its own curve (by
/// address), its part's target, or none.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Source {
    Curve(usize),
    Part(usize),
    Nothing,
}

/// Answers each ask (key, points) with one call of `ask(first, points)`
/// per distinct key, on the points of all the asks with that key in
/// their order, `first` the index of the first of them; the answers split
/// back per ask. Keys are taken in order of first appearance, so the
/// calls are the same from run to run.
pub(crate) fn grouped<K: std::hash::Hash + Eq, P: Copy, T>(asks: &[(K, Vec<P>)], ask: impl Fn(usize, &[P]) -> Vec<T>) -> Vec<Vec<T>> {
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut index: HashMap<&K, usize> = HashMap::new();
    for (i, (key, _)) in asks.iter().enumerate() {
        let g = *index.entry(key).or_insert_with(|| {
            groups.push(Vec::new());
            groups.len() - 1
        });
        groups[g].push(i);
    }
    let mut out: Vec<Vec<T>> = (0..asks.len()).map(|_| Vec::new()).collect();
    for g in groups {
        let points: Vec<P> = g.iter().flat_map(|&i| asks[i].1.iter().copied()).collect();
        let mut answers = ask(g[0], &points).into_iter();
        for &i in &g {
            out[i] = answers.by_ref().take(asks[i].1.len()).collect();
        }
    }
    out
}

/// 5-point Gauss–Legendre's places on [a, b].
fn gl5_places(a: f64, b: f64) -> [f64; 5] {
    GL5.map(|(xi, _)| a + xi * (b - a))
}

/// 5-point Gauss–Legendre's sum on [a, b] of the speeds at its places.
fn gl5_piece(a: f64, b: f64, speed: &[f64]) -> f64 {
    GL5.iter().zip(speed).map(|(&(_, w), v)| w * (b - a) * v).sum::<f64>()
}

/// The 4 pieces of [0, x] of the composite rule.
fn quarters(x: f64) -> impl Iterator<Item = (f64, f64)> {
    (0..4).map(move |j| (x * j as f64 / 4.0, x * (j + 1) as f64 / 4.0))
}

/// The arc length of [0, x] from the speeds at its quarters' places.
fn arc_length(x: f64, speed: &[f64]) -> f64 {
    quarters(x).zip(speed.chunks(5)).map(|((a, b), v)| gl5_piece(a, b, v)).sum::<f64>()
}

/// Lines fitted in lockstep on CAD: enough that a round's calls of Gmsh
/// take thousands of points, few enough that a round's points and answers
/// stay a few MB (all 3,045 lines of the 5,082-tet torus at once took
/// 45 MB more at p = 2).
const LOCKSTEP: usize = 256;

/// Newton's steps at most on one node's arc length.
const ARC_STEPS: usize = 30;

/// One node's walk to its place at equal arc length
/// ([`RefineBoundary::arc_places`]): Newton on the arc length, kept
/// inside [0, 1]; the length at x is the start's and the short stretch
/// from s to x (one piece: a quarter of the images a whole new length
/// would take).
struct ArcWalk {
    s: f64,
    goal: f64,
    before: f64,
    x: f64,
    at: f64,
    speed: f64,
    steps: usize,
}

impl ArcWalk {
    /// From the speeds at the quarters' places of [0, 1] (`whole`), and of
    /// [0, s] then at s (`own`).
    fn new(s: f64, whole: &[f64], own: &[f64]) -> Self {
        let before = arc_length(s, &own[..20]);
        ArcWalk { s, goal: s * arc_length(1.0, whole), before, x: s, at: before, speed: own[20], steps: 0 }
    }

    /// A Newton step; the places where the speeds are asked next (the
    /// stretch to x and x), or None when done.
    fn step(&mut self) -> Option<Vec<f64>> {
        if self.steps == ARC_STEPS {
            return None;
        }
        let step = (self.at - self.goal) / self.speed.max(f64::MIN_POSITIVE);
        self.x = (self.x - step).clamp(0.0, 1.0);
        if step.abs() < 1e-14 {
            return None;
        }
        self.steps += 1;
        let mut xs = gl5_places(self.s, self.x).to_vec();
        xs.push(self.x);
        Some(xs)
    }

    /// The speeds at the places [`Self::step`] asked.
    fn answer(&mut self, v: &[f64]) {
        self.at = self.before + gl5_piece(self.s, self.x, &v[..5]);
        self.speed = v[5];
    }
}

/// A line of new nodes on a carrier ([`RefineBoundary::fitted_lines`]):
/// the carrier, the direction along it, and the other coordinate's bits.
type LineKey = (usize, usize, u64);

fn line_key(carrier: usize, s: [f64; 2], d: usize) -> LineKey {
    (carrier, d, if d == 0 { s[1] } else { s[0] }.to_bits())
}

/// A line's new nodes: their reference places, increasing, the carrier
/// parameters they settle at, and their places at equal arc length (the
/// fit's start, kept for a try at equal arc length: on CAD they cost as
/// many projections as the fit).
#[derive(Debug)]
struct Line {
    reference: Vec<f64>,
    places: Vec<f64>,
    arcs: Vec<f64>,
}

impl Line {
    /// The parameter of the node at reference place `r`.
    fn place(&self, r: f64) -> Option<f64> {
        let j = self.reference.iter().position(|&x| x == r)?;
        Some(self.places[j])
    }

    /// The equal arc length parameter of the node at reference place `r`.
    fn arc(&self, r: f64) -> Option<f64> {
        let j = self.reference.iter().position(|&x| x == r)?;
        Some(self.arcs[j])
    }
}

/// The fitted lines of a settling, by line.
type Fits = HashMap<LineKey, Line>;

/// Where the settling pass puts each fine node ([`Settle`]), and the
/// fitted lines, found once for all of the pass's tries (they depend on
/// the lines, not on which of their nodes are fitted).
#[derive(Clone, Debug)]
pub struct SettlePlan {
    /// Per fine node.
    pub places: Vec<Settle>,
    fits: Arc<OnceLock<Fits>>,
}

impl SettlePlan {
    /// Every one of `nodes` fine nodes at its fitted place.
    pub fn new(nodes: usize) -> Self {
        SettlePlan { places: vec![Settle::Fit; nodes], fits: Arc::default() }
    }
}

/// What a fine boundary node does during Algorithm 2.
#[derive(Clone, Copy, Debug)]
pub enum Role2 {
    /// Not on the boundary.
    Interior,
    /// Stays where it is.
    Fixed,
    /// Follows the straight path from its start to its image (Dirichlet).
    Path,
    /// Glides on the blended facet or edge `carrier` at parameter s; the
    /// image is that of `part` (none: the carrier itself, a flat wall).
    Slide {
        /// Index into the carriers.
        carrier: usize,
        /// Parameter on the carrier (one or two coordinates).
        s: [f64; 2],
    },
}

/// A flat coarse facet or edge that carries sliding nodes.
#[derive(Clone, Debug)]
struct Carrier<const D: usize> {
    /// 2 (a segment), 3 (a flat triangle: s are its reference
    /// coordinates) or 4 (a bilinear quad) corner positions.
    corners: Vec<[f64; D]>,
    /// The part whose image X applies, if any (else X = identity).
    part: Option<usize>,
    /// Parameters stay within [0, 1] (moving carriers end at fixed nodes).
    bounded: bool,
    /// An edge's own curve, where two parts meet along one
    /// ([`BoundaryPart::meets`]): X is the closest point on it.
    curve: Option<Arc<dyn ClosestPoint<D>>>,
    /// Its new nodes settle at the images of their flat places, as a
    /// triangle facet's do: so an edge of one (3D) at p ≥ 4, whose nodes
    /// the face's several inside nodes must match. (Fitted along the edge
    /// alone, the quarter nodes of the tet ball's sphere edges at p = 4
    /// sat 4.7e-4 off the images of their flat places while the faces'
    /// inside nodes sat at theirs: the sphere's faces were 2.5e-5 off it,
    /// against 2.2e-7 with every node at its image, Gmsh's `setOrder`
    /// 4.6e-6. At p = 3 the one inside node, the centroid, agrees with
    /// any symmetric fit of the edges, and the fit is better: 1.35e-5
    /// against 5.0e-5.)
    images: bool,
}

impl<const D: usize> Carrier<D> {
    fn dims(&self) -> usize {
        if self.corners.len() == 2 { 1 } else { 2 }
    }

    fn start(&self, s: [f64; 2]) -> [f64; D] {
        let c = &self.corners;
        if c.len() == 2 {
            return std::array::from_fn(|i| (1.0 - s[0]) * c[0][i] + s[0] * c[1][i]);
        }
        if c.len() == 3 {
            return std::array::from_fn(|i| (1.0 - s[0] - s[1]) * c[0][i] + s[0] * c[1][i] + s[1] * c[2][i]);
        }
        let w = [(1.0 - s[0]) * (1.0 - s[1]), s[0] * (1.0 - s[1]), s[0] * s[1], (1.0 - s[0]) * s[1]];
        std::array::from_fn(|i| (0..4).map(|k| w[k] * c[k][i]).sum())
    }

    /// ∂P₀/∂s_k at s.
    fn start_along(&self, s: [f64; 2], k: usize) -> [f64; D] {
        let c = &self.corners;
        if c.len() < 4 {
            return std::array::from_fn(|i| c[k + 1][i] - c[0][i]);
        }
        let w = if k == 0 { [-(1.0 - s[1]), 1.0 - s[1], s[1], -s[1]] } else { [-(1.0 - s[0]), -s[0], s[0], 1.0 - s[0]] };
        std::array::from_fn(|i| (0..4).map(|j| w[j] * c[j][i]).sum())
    }
}

/// The Algorithm 2 boundary: every fine boundary node's role.
pub struct RefineBoundary<const D: usize> {
    parts: Vec<BoundaryPart<D>>,
    carriers: Vec<Carrier<D>>,
    roles: Vec<Role2>,
    start: Vec<[f64; D]>,
    /// Image of each Path node, and the part whose target it is on (none:
    /// a node a patch repair holds at the snap's place, inside the mesh).
    targets: Vec<Option<([f64; D], Option<usize>)>>,
}

/// A fine mesh ready for Algorithm 2: the mesh and where its nodes sit.
#[derive(Clone, Debug)]
pub struct RefineMesh<M, const D: usize> {
    /// The fine Q1 mesh.
    pub mesh: M,
    facet_corners: Vec<Vec<[f64; D]>>,
    facet_parts: Vec<usize>,
    edges: Vec<([[f64; D]; 2], Vec<usize>)>,
    places: Vec<Place>,
    on_facets: HashMap<usize, Vec<(usize, [f64; 2])>>,
    /// Settling: per node, where a new node of a curved carrier goes
    /// (see [`RefineMesh::settling`]).
    settle: Option<SettlePlan>,
    /// Per node, whether it may move ([`Subdivision::band`]); None: all.
    band: Option<Vec<bool>>,
    /// A patch repair's run ([`RefineMesh::with_patch`]).
    patch: Option<Arc<PatchTargets<D>>>,
    /// The order of the elements the fine mesh subdivides.
    p: usize,
}

impl<M, const D: usize> Subdivision<M, D> {
    /// Algorithm 2's band: per fine node, whether it lies within `width`
    /// bend lengths of a new node of a moving part of `parts`, reached
    /// through the cells. A facet's bend length is the length of its side
    /// with the largest sagitta (the distance of the side's midpoint to its
    /// image); an edge's, the largest of its facets'. Why that length: the
    /// motion is the facets' bulge, which fades over the length along which
    /// the facet bends — not over its height (a thin layer has many cells
    /// within one bend length of the wall), nor its straight sides (an
    /// extruded wall's facets are long along the axis and bend across it).
    pub fn band<const N: usize>(&self, parts: &[BoundaryPart<D>], width: f64) -> Vec<bool>
    where
        M: Subdividable<D, N>,
    {
        let bend: Vec<Option<f64>> = (0..self.facet_corners.len()).map(|f| self.bend_length(f, parts)).collect();
        let reach = |facets: &[usize]| facets.iter().filter_map(|&f| bend[f]).reduce(f64::max);
        let reach: Vec<Option<f64>> = self
            .places
            .iter()
            .map(|place| match place {
                Place::Facet { facet, .. } => reach(std::slice::from_ref(facet)),
                Place::Edge { edge, .. } => reach(&self.edges[*edge].1),
                _ => None,
            })
            .collect();
        let seeds: Vec<usize> = (0..reach.len()).filter(|&i| reach[i].is_some()).collect();
        within_reach(self.fine.cells(), self.fine.nodes(), &seeds, |i| width * reach[i].unwrap_or(0.0))
    }

    /// The bend length of coarse facet `f` ([`Subdivision::band`]); None
    /// if its part does not move.
    fn bend_length(&self, f: usize, parts: &[BoundaryPart<D>]) -> Option<f64> {
        let part = &parts[self.facets[f].1];
        if !matches!(part.kind, PartKind::Move { .. }) {
            return None;
        }
        let c = &self.facet_corners[f];
        let sides = if c.len() == 2 { 1 } else { c.len() };
        let side = |k: usize| {
            let (a, b) = (c[k], c[(k + 1) % c.len()]);
            let mid: [f64; D] = std::array::from_fn(|i| 0.5 * (a[i] + b[i]));
            let sagitta = part.image(mid).map_or(0.0, |x| dist2(x, mid).sqrt());
            (sagitta, dist2(a, b).sqrt())
        };
        Some((0..sides).map(side).fold((-1.0, 0.0), |best, s| if s.0 > best.0 { s } else { best }).1)
    }
}

impl<M: Clone, const D: usize> Subdivision<M, D> {
    /// The fine mesh with what Algorithm 2 needs to know about its nodes.
    pub fn refine_mesh(&self) -> RefineMesh<M, D> {
        RefineMesh {
            mesh: self.fine.clone(),
            facet_corners: self.facet_corners.clone(),
            facet_parts: self.facets.iter().map(|f| f.1).collect(),
            edges: self.edges.clone(),
            places: self.places.clone(),
            on_facets: self.on_facets.clone(),
            settle: None,
            band: None,
            patch: None,
            p: self.p,
        }
    }
}

/// The parts of Algorithm 2 from those of Algorithm 1: a curved slip wall
/// becomes a target the new nodes slide onto (closest point).
pub fn refine_parts<const D: usize>(parts: &[BoundaryPart<D>]) -> Vec<BoundaryPart<D>> {
    parts
        .iter()
        .map(|p| match &p.kind {
            PartKind::Slip { wall: Some(w) } => BoundaryPart {
                kind: PartKind::Move { target: w.clone(), correspondence: Correspondence::Normal, mode: MoveMode::Sliding },
                ..p.clone()
            },
            _ => p.clone(),
        })
        .collect()
}

/// Orthonormal completion of the unit vector `n`: a frame with n first.
fn frame_with<const D: usize>(n: [f64; D]) -> [[f64; D]; D] {
    let mut frame = [[0.0; D]; D];
    frame[0] = n;
    let mut k = 1;
    for axis in 0..D {
        if k == D {
            break;
        }
        let mut v: [f64; D] = std::array::from_fn(|i| if i == axis { 1.0 } else { 0.0 });
        for f in &frame[..k] {
            let d: f64 = (0..D).map(|i| v[i] * f[i]).sum();
            v = std::array::from_fn(|i| v[i] - d * f[i]);
        }
        let l = v.iter().map(|c| c * c).sum::<f64>().sqrt();
        if l > 0.3 {
            frame[k] = v.map(|c| c / l);
            k += 1;
        }
    }
    frame
}

impl<const D: usize> RefineBoundary<D> {
    /// Settling (see [`RefineMesh::settling`]): a sliding node of a curved
    /// carrier becomes a path node aimed at the image of its place.
    fn settle_roles(&mut self, plan: &SettlePlan) -> Result<(), DeformError> {
        // the fits only where a node asks for its fitted place (on CAD
        // they cost the most of a snap: 3.8 s of the 5,082-tet torus's
        // 12 s at p = 2, asked again by its try at equal arc length)
        let empty = Fits::default();
        // (a try at equal arc length after the fitted one takes the lines'
        // arc places from it)
        let fits = if plan.places.contains(&Settle::Fit) { plan.fits.get_or_init(|| self.fitted_lines()) } else { plan.fits.get().unwrap_or(&empty) };
        let plan = &plan.places;
        for i in 0..self.roles.len() {
            let Role2::Slide { carrier, s } = self.roles[i] else { continue };
            let car = &self.carriers[carrier];
            let Some(k) = car.part else { continue };
            let place = match plan[i] {
                // a triangle's iso-lines end on its hypotenuse, not at 1:
                // its nodes, and its edges', go to the images of their
                // flat places
                Settle::Fit | Settle::Arc if car.images => s,
                // (every line is fitted: equal arc length is only a guard)
                Settle::Fit => std::array::from_fn(|d| {
                    if d < car.dims() {
                        fits.get(&line_key(carrier, s, d)).and_then(|l| l.place(s[d])).unwrap_or_else(|| self.arc_place(carrier, s, d))
                    } else {
                        s[d]
                    }
                }),
                Settle::Arc => self.arc_parameter(carrier, s, fits),
                Settle::Image => s,
                Settle::Keep => {
                    self.roles[i] = Role2::Fixed;
                    continue;
                }
            };
            let image = self.carrier_image(carrier, car.start(place)).ok_or_else(|| DeformError::Unreachable {
                part: self.parts[k].name.clone(),
                why: format!("the new high-order node {i} at {:?} has no image on the target", self.start[i]),
            })?;
            self.targets[i] = Some((image, Some(k)));
            self.roles[i] = Role2::Path;
        }
        Ok(())
    }

    /// Settling moves nodes by a small correction that fades within a few
    /// multiples of its size from the wall: nodes farther than
    /// [`SETTLE_BAND`] times the largest correction from every moving node
    /// (measured through the cells) are held, so the flow solves only in a
    /// band along the curved walls (measured on the h = 0.05 cylinder layer
    /// at p = 3: the whole-mesh settling doubled Algorithm 2's time).
    fn hold_beyond_band<const N: usize>(&mut self, cells: &[[usize; N]]) {
        let offset = |i: usize| self.targets[i].map_or(0.0, |(to, _)| dist2(to, self.start[i]).sqrt());
        let radius = SETTLE_BAND * (0..self.roles.len()).map(offset).fold(0.0, f64::max);
        let seeds: Vec<usize> = (0..self.roles.len()).filter(|&i| offset(i) > 0.0).collect();
        let band = within_reach(cells, &self.start, &seeds, |_| radius);
        self.hold_outside(&band);
    }

    /// Holds the free nodes outside `band` where they are.
    fn hold_outside(&mut self, band: &[bool]) {
        for (role, &inside) in self.roles.iter_mut().zip(band) {
            if !inside && matches!(role, Role2::Interior | Role2::Slide { .. }) {
                *role = Role2::Fixed;
            }
        }
    }

    /// The parameter on carrier `c` whose image X(P₀) lies at the fraction
    /// `s` of the image's arc length, in each of the carrier's directions
    /// (along the iso-curve through `s`): the node's place "equispaced (or
    /// Gauss–Lobatto) along the facet's image".
    ///
    /// Why not X(P₀(s)) itself: the image of evenly spaced points of a
    /// chord crowds towards the middle of the arc, which costs the
    /// interpolant a constant factor (measured on a circle arc of 0.2 rad:
    /// 3.7e-6 against 4.1e-7 at p = 3, 3.0e-9 against 3.3e-10 at p = 4).
    /// (Taken from `fits` where a fit of the node's line found it.)
    fn arc_parameter(&self, c: usize, s: [f64; 2], fits: &Fits) -> [f64; 2] {
        std::array::from_fn(|k| if k < self.carriers[c].dims() { fits.get(&line_key(c, s, k)).and_then(|l| l.arc(s[k])).unwrap_or_else(|| self.arc_place(c, s, k)) } else { s[k] })
    }

    /// The `k`-th coordinate of [`Self::arc_parameter`].
    fn arc_place(&self, c: usize, s: [f64; 2], k: usize) -> f64 {
        self.arc_places(&[(c, s, k)])[0]
    }

    /// [`Self::arc_place`] of each of `asks` (carrier, parameters,
    /// direction), each walk's arithmetic the same as alone, their speeds
    /// asked together each round ([`Self::speeds`]: on CAD one batch per
    /// shape and round, not per node and Newton step).
    fn arc_places(&self, asks: &[(usize, [f64; 2], usize)]) -> Vec<f64> {
        // the lengths at 1 (once per line: the same speeds for each of
        // its nodes) and at s, and the speed at s, in one batch
        let mut lines: HashMap<LineKey, usize> = HashMap::new();
        let mut first: Vec<(usize, [f64; 2], usize, Vec<f64>)> = Vec::with_capacity(2 * asks.len());
        let whole: Vec<usize> = asks
            .iter()
            .map(|&(c, s, k)| {
                *lines.entry(line_key(c, s, k)).or_insert_with(|| {
                    first.push((c, s, k, quarters(1.0).flat_map(|(a, b)| gl5_places(a, b)).collect()));
                    first.len() - 1
                })
            })
            .collect();
        let own = first.len();
        first.extend(asks.iter().map(|&(c, s, k)| {
            let mut xs: Vec<f64> = quarters(s[k]).flat_map(|(a, b)| gl5_places(a, b)).collect();
            xs.push(s[k]);
            (c, s, k, xs)
        }));
        let v = self.speeds(&first);
        let mut walks: Vec<(usize, ArcWalk)> = (0..asks.len()).map(|i| (i, ArcWalk::new(asks[i].1[asks[i].2], &v[whole[i]], &v[own + i]))).collect();
        let mut out = vec![0.0; asks.len()];
        // each walk takes at most ARC_STEPS rounds
        while !walks.is_empty() {
            let mut asked = Vec::with_capacity(walks.len());
            let mut going = Vec::with_capacity(walks.len());
            for (i, mut walk) in walks {
                match walk.step() {
                    Some(xs) => {
                        let (c, s, k) = asks[i];
                        asked.push((c, s, k, xs));
                        going.push((i, walk));
                    }
                    None => out[i] = walk.x,
                }
            }
            for ((_, walk), v) in going.iter_mut().zip(self.speeds(&asked)) {
                walk.answer(&v);
            }
            walks = going;
        }
        out
    }

    /// The speeds |d/dx Γ_1| at places x along direction k through s, for
    /// each ask (carrier, s, k, places), all asked at once (a CAD shape
    /// answers them in one batch): where the shape knows its foot's
    /// derivative (CAD) from it, one image per place (the stencil's speed
    /// but for its rounding, about 1e-12 of it), else by
    /// [`Self::precise_tangents`], four (on the 5,082-tet torus at p = 2
    /// the fit's projections fell from 900k to 456k, its time from 6.4 s
    /// to 2.0 s with the batches).
    fn speeds(&self, asks: &[(usize, [f64; 2], usize, Vec<f64>)]) -> Vec<Vec<f64>> {
        let at: Vec<Vec<[f64; 2]>> = asks
            .iter()
            .map(|(_, s, k, xs)| {
                xs.iter()
                    .map(|&x| {
                        let mut q = *s;
                        q[*k] = x;
                        q
                    })
                    .collect()
            })
            .collect();
        let exact = self.image_speeds_many(&asks.iter().zip(&at).map(|(&(c, _, k, _), at)| (c, at.clone(), k)).collect::<Vec<_>>());
        asks.iter()
            .zip(at)
            .zip(exact)
            .map(|((&(c, _, k, _), at), exact)| {
                let rest: Vec<[f64; 2]> = at.iter().zip(&exact).filter(|(_, v)| v.is_none()).map(|(&q, _)| q).collect();
                let mut numeric = self.precise_tangents(c, &rest, k).into_iter();
                exact.into_iter().map(|v| norm(v.or_else(|| numeric.next()).unwrap_or([f64::NAN; D]))).collect()
            })
            .collect()
    }

    /// The fitted places ([`Settle::Fit`]) of every line of new nodes of
    /// a curved carrier: per line (carrier, direction, the other
    /// coordinate), each node's reference place and its parameter.
    fn fitted_lines(&self) -> Fits {
        let t0 = std::time::Instant::now();
        let mut lines: HashMap<LineKey, Vec<f64>> = HashMap::new();
        for role in &self.roles {
            let Role2::Slide { carrier, s } = *role else { continue };
            let car = &self.carriers[carrier];
            if car.part.is_none() || car.images {
                continue;
            }
            for d in 0..car.dims() {
                let line = lines.entry(line_key(carrier, s, d)).or_default();
                if !line.contains(&s[d]) {
                    line.push(s[d]);
                }
            }
        }
        let mut lines: Vec<(LineKey, Vec<f64>)> = lines.into_iter().collect();
        // in a fixed order: a CAD shape's answers may depend on the order
        // of its queries by round-off ([`crate::geometry::cad`])
        lines.sort_by_key(|l| l.0);
        for (_, reference) in &mut lines {
            reference.sort_by(f64::total_cmp);
        }
        let count = lines.len();
        // each line's fit is independent of the others and of their
        // order; on CAD ([`ClosestPoint::serial`]) all the lines in
        // lockstep from one thread, each shape asked once per round
        let fits: Fits = if self.serial() { lines.chunks(LOCKSTEP).flat_map(|chunk| self.fit_lines(chunk.to_vec())).collect() } else { lines.into_par_iter().flat_map_iter(|line| self.fit_lines(vec![line])).collect() };
        tracing::info!("settling: {count} lines of new nodes fitted in {:.2} s", t0.elapsed().as_secs_f64());
        fits
    }

    /// Whether a shape of its carriers answers from one thread at a time
    /// ([`ClosestPoint::serial`]).
    fn serial(&self) -> bool {
        self.parts.iter().any(BoundaryPart::serial) || self.carriers.iter().any(|c| c.curve.as_ref().is_some_and(|s| s.serial()))
    }

    /// The lines' fits, from each line's inner nodes' reference places
    /// (increasing): equal arc length where the fit gains nothing.
    fn fit_lines(&self, lines: Vec<(LineKey, Vec<f64>)>) -> Vec<(LineKey, Line)> {
        let base = |&(_, d, other): &LineKey, x: f64| {
            let mut q = [0.0; 2];
            q[d] = x;
            q[1 - d] = f64::from_bits(other);
            q
        };
        let asks: Vec<(usize, [f64; 2], usize)> = lines.iter().flat_map(|(key, reference)| reference.iter().map(move |&r| (key.0, base(key, r), key.1))).collect();
        let mut arcs = self.arc_places(&asks).into_iter();
        let starts: Vec<Vec<f64>> = lines.iter().map(|(_, reference)| arcs.by_ref().take(reference.len()).collect()).collect();
        // the lines with a shape to fit to, and that shape
        let shape = |c: usize| {
            let car = &self.carriers[c];
            car.curve.clone().or_else(|| match &self.parts[car.part?].kind {
                PartKind::Move { target, .. } => Some(target.clone()),
                _ => None,
            })
        };
        let fitted: Vec<(usize, Arc<dyn crate::deform::BoundaryShape<D>>)> = lines.iter().enumerate().filter_map(|(i, (key, _))| Some((i, shape(key.0)?))).collect();
        let problems: Vec<crate::geometry::fit::Line> = fitted
            .iter()
            .map(|&(i, _)| {
                let reference = std::iter::once(0.0).chain(lines[i].1.iter().copied()).chain(std::iter::once(1.0)).collect();
                crate::geometry::fit::Line { reference, start: starts[i].clone() }
            })
            .collect();
        let curve = |asks: &[(usize, Vec<f64>)]| {
            let at: Vec<(usize, Vec<[f64; 2]>)> = asks
                .iter()
                .map(|(j, xs)| {
                    let key = &lines[fitted[*j].0].0;
                    (key.0, xs.iter().map(|&x| base(key, x)).collect())
                })
                .collect();
            self.carrier_points_many(&at)
        };
        let feet = |asks: &[(usize, Vec<[f64; D]>)]| {
            let keyed: Vec<(usize, Vec<[f64; D]>)> = asks.iter().map(|(j, qs)| (Arc::as_ptr(&fitted[*j].1) as *const () as usize, qs.clone())).collect();
            grouped(&keyed, |i, qs| fitted[asks[i].0].1.closest_points(qs))
        };
        let mut places = crate::geometry::fit::fitted_lines(&problems, curve, feet).into_iter();
        let mut places: Vec<Option<Vec<f64>>> = {
            let mut all = vec![None; lines.len()];
            for &(i, _) in &fitted {
                all[i] = places.next().flatten();
            }
            all
        };
        lines
            .into_iter()
            .zip(starts)
            .enumerate()
            .map(|(i, ((key, reference), start))| (key, Line { reference, places: places[i].take().unwrap_or_else(|| start.clone()), arcs: start }))
            .collect()
    }

    /// The image X(p) of carrier `c`'s starting point p: on its curve, or
    /// its part's; None where the part's correspondence finds none.
    fn carrier_image(&self, c: usize, p: [f64; D]) -> Option<[f64; D]> {
        let car = &self.carriers[c];
        match &car.curve {
            Some(curve) => Some(curve.closest_point(p)),
            None => car.part.and_then(|k| self.parts[k].image(p)),
        }
    }

    /// The velocity of Γ_1 = X(P₀(s)) along s_k at each of the parameters
    /// of each ask (carrier, parameters, k), where its shape knows its
    /// foot's derivative ([`crate::geometry::ClosestPoint::foot_speeds`]);
    /// else None. Each shape is asked once for all its asks.
    fn image_speeds_many(&self, asks: &[(usize, Vec<[f64; 2]>, usize)]) -> Vec<Vec<Option<[f64; D]>>> {
        let pairs: Vec<(Source, Vec<PointAndDirection<D>>)> = asks
            .iter()
            .map(|(c, ss, k)| {
                let car = &self.carriers[*c];
                (self.source(*c), ss.iter().map(|&s| (car.start(s), car.start_along(s, *k))).collect())
            })
            .collect();
        grouped(&pairs, |i, pd| {
            let (p0, dirs): (Vec<[f64; D]>, Vec<[f64; D]>) = pd.iter().copied().unzip();
            self.speeds_of(asks[i].0, &p0, &dirs)
        })
    }

    /// The velocities of carrier `c`'s images at starting points `p0` as
    /// they move by `dirs`, where its shape knows them.
    fn speeds_of(&self, c: usize, p0: &[[f64; D]], dirs: &[[f64; D]]) -> Vec<Option<[f64; D]>> {
        let car = &self.carriers[c];
        match (&car.curve, car.part) {
            (Some(curve), _) => curve.foot_speeds(p0, dirs),
            (None, Some(part)) => self.parts[part].image_speeds(p0, dirs),
            (None, None) => vec![None; p0.len()],
        }
    }

    /// Which shape answers carrier `c`'s images: carriers of one source
    /// can be asked together.
    fn source(&self, c: usize) -> Source {
        let car = &self.carriers[c];
        match (&car.curve, car.part) {
            (Some(curve), _) => Source::Curve(Arc::as_ptr(curve) as *const () as usize),
            (None, Some(part)) => Source::Part(part),
            (None, None) => Source::Nothing,
        }
    }

    /// The images X(p0) of carrier `c`'s starting points, where it has.
    fn images_of(&self, c: usize, p0: &[[f64; D]]) -> Vec<Option<[f64; D]>> {
        let car = &self.carriers[c];
        match (&car.curve, car.part) {
            (Some(curve), _) => curve.closest_points(p0).into_iter().map(Some).collect(),
            (None, Some(k)) => self.parts[k].images(p0),
            (None, None) => vec![None; p0.len()],
        }
    }

    /// [`Self::carrier_points`] at t = 1 of each ask (carrier,
    /// parameters), each shape asked once for all its asks.
    fn carrier_points_many(&self, asks: &[(usize, Vec<[f64; 2]>)]) -> Vec<Vec<[f64; D]>> {
        let p0: Vec<(Source, Vec<[f64; D]>)> = asks.iter().map(|(c, ss)| (self.source(*c), ss.iter().map(|&s| self.carriers[*c].start(s)).collect())).collect();
        let images = grouped(&p0, |i, ps| self.images_of(asks[i].0, ps));
        p0.iter().zip(images).map(|((_, p0), images)| moved(p0, images, 1.0)).collect()
    }

    /// Γ_t at each of `ss` on carrier `c` ([`Self::carrier_point`]'s
    /// points), the images asked together.
    fn carrier_points(&self, c: usize, ss: &[[f64; 2]], t: f64) -> Vec<[f64; D]> {
        let p0: Vec<[f64; D]> = ss.iter().map(|&s| self.carriers[c].start(s)).collect();
        moved(&p0, self.images_of(c, &p0), t)
    }

    /// Γ_t(s) of a carrier and its velocity X(P₀(s)) − P₀(s).
    fn carrier_point(&self, c: usize, s: [f64; 2], t: f64) -> ([f64; D], [f64; D]) {
        let p0 = self.carriers[c].start(s);
        let x = self.carrier_image(c, p0).unwrap_or(p0);
        let v = std::array::from_fn(|i| x[i] - p0[i]);
        (std::array::from_fn(|i| p0[i] + t * v[i]), v)
    }

    /// Tangents of Γ_t at s (one or two), by central differences.
    fn tangents(&self, c: usize, s: [f64; 2], t: f64) -> Vec<[f64; D]> {
        (0..self.carriers[c].dims()).map(|k| self.tangent(c, s, t, k)).collect()
    }

    /// d/ds_k of Γ_t at s, by central differences.
    fn tangent(&self, c: usize, s: [f64; 2], t: f64, k: usize) -> [f64; D] {
        let h = 1e-6;
        let (mut a, mut b) = (s, s);
        a[k] -= h;
        b[k] += h;
        let (pa, pb) = (self.carrier_point(c, a, t).0, self.carrier_point(c, b, t).0);
        std::array::from_fn(|i| (pb[i] - pa[i]) / (2.0 * h))
    }

    /// d/ds_k of the image Γ_1 at each of `ss`, by the fourth-order
    /// central difference, the images of every stencil asked at once.
    /// Why not [`Self::tangent`]: its rounding (~1e-10 of the speed) put
    /// the arc places off by enough to floor the p = 4 boundary error at
    /// about 6e-14 on the quarter disk (measured).
    fn precise_tangents(&self, c: usize, ss: &[[f64; 2]], k: usize) -> Vec<[f64; D]> {
        let h = 1e-3;
        let qs: Vec<[f64; 2]> = ss
            .iter()
            .flat_map(|&s| {
                [-2.0 * h, -h, h, 2.0 * h].map(|x| {
                    let mut q = s;
                    q[k] += x;
                    q
                })
            })
            .collect();
        let at = self.carrier_points(c, &qs, 1.0);
        at.chunks(4).map(|w| std::array::from_fn(|i| (w[0][i] - 8.0 * w[1][i] + 8.0 * w[2][i] - w[3][i]) / (12.0 * h))).collect()
    }

    fn constraint(&self, i: usize, t: f64, f: f64) -> Constraint<D> {
        match self.roles[i] {
            Role2::Interior => Constraint::free(),
            Role2::Fixed => Constraint::fixed([0.0; D]),
            Role2::Path => {
                let to = self.targets[i].expect("a path node has a target").0;
                Constraint::fixed(std::array::from_fn(|k| (to[k] - self.start[i][k]) / f))
            }
            Role2::Slide { carrier, s } => {
                let v = self.carrier_point(carrier, s, t).1.map(|c| c / f);
                let tan = self.tangents(carrier, s, t);
                if tan.len() == D - 1 {
                    // a facet: u·n = v·n (the sign of n does not matter)
                    let n = unit(if D == 2 {
                        std::array::from_fn(|k| if k == 0 { tan[0][1] } else { -tan[0][0] })
                    } else {
                        let c = crate::numeric::cross3(std::array::from_fn(|k| tan[0][k]), std::array::from_fn(|k| tan[1][k]));
                        std::array::from_fn(|k| c[k])
                    });
                    Constraint { frame: frame_with(n), fixed: 1, values: std::array::from_fn(|k| if k == 0 { dot(v, n) } else { 0.0 }) }
                } else {
                    // an edge in 3D: the components across the curve follow it
                    let tau = unit(tan[0]);
                    let mut frame = frame_with(tau);
                    frame.rotate_left(1);
                    Constraint { frame, fixed: D - 1, values: std::array::from_fn(|k| if k + 1 < D { dot(v, frame[k]) } else { 0.0 }) }
                }
            }
        }
    }

    /// The point of Γ_t closest to x by Gauss–Newton on s from `s0`.
    fn project(&self, c: usize, s0: [f64; 2], x: [f64; D], t: f64) -> [f64; 2] {
        let car = &self.carriers[c];
        let dims = car.dims();
        let mut s = s0;
        for _ in 0..20 {
            let p = self.carrier_point(c, s, t).0;
            let tan = self.tangents(c, s, t);
            let r: [f64; D] = std::array::from_fn(|i| x[i] - p[i]);
            // normal equations (T^T T) ds = T^T r, one or two unknowns
            let g: Vec<f64> = tan.iter().map(|a| dot(*a, r)).collect();
            let m: Vec<Vec<f64>> = tan.iter().map(|a| tan.iter().map(|b| dot(*a, *b)).collect()).collect();
            let ds = if dims == 1 {
                if !(m[0][0] > 0.0) {
                    break;
                }
                [g[0] / m[0][0], 0.0]
            } else {
                let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
                if !(det.abs() > 0.0) {
                    break;
                }
                [(m[1][1] * g[0] - m[0][1] * g[1]) / det, (m[0][0] * g[1] - m[1][0] * g[0]) / det]
            };
            let mut next = [s[0] + ds[0], s[1] + ds[1]];
            if car.bounded {
                next = next.map(|v| v.clamp(0.0, 1.0));
                if car.corners.len() == 3 && next[0] + next[1] > 1.0 {
                    // back onto the triangle's hypotenuse
                    let over = 0.5 * (next[0] + next[1] - 1.0);
                    next = [next[0] - over, next[1] - over].map(|v| v.clamp(0.0, 1.0));
                }
            }
            let moved = (next[0] - s[0]).abs() + (next[1] - s[1]).abs();
            s = next;
            if moved < 1e-15 {
                break;
            }
        }
        s
    }
}

impl<const D: usize> BoundaryModel<D> for RefineBoundary<D> {
    type State = Vec<Role2>;

    fn parts(&self) -> &[BoundaryPart<D>] {
        &self.parts
    }

    fn velocities(&self, out: &mut [[f64; D]]) {
        for (i, role) in self.roles.iter().enumerate() {
            out[i] = match *role {
                Role2::Path => {
                    let to = self.targets[i].expect("target").0;
                    std::array::from_fn(|k| to[k] - self.start[i][k])
                }
                Role2::Slide { carrier, s } => self.carrier_point(carrier, s, 0.0).1,
                _ => [0.0; D],
            };
        }
    }

    fn fill_constraints(&self, t: f64, _nodes: &[[f64; D]], f: impl Fn(usize) -> f64, out: &mut [Constraint<D>]) {
        for (i, c) in out.iter_mut().enumerate() {
            *c = self.constraint(i, t, f(i));
        }
    }

    fn put_back(&mut self, nodes: &mut [[f64; D]], t: f64) {
        for i in 0..self.roles.len() {
            match self.roles[i] {
                Role2::Interior => {}
                Role2::Fixed => nodes[i] = self.start[i],
                Role2::Path => {
                    let to = self.targets[i].expect("target").0;
                    nodes[i] = std::array::from_fn(|k| self.start[i][k] + t * (to[k] - self.start[i][k]));
                }
                Role2::Slide { carrier, s } => {
                    let s = self.project(carrier, s, nodes[i], t);
                    nodes[i] = self.carrier_point(carrier, s, t).0;
                    self.roles[i] = Role2::Slide { carrier, s };
                }
            }
        }
        // at t = 1 a node of a target lies on it exactly (the blend's end
        // is X(P₀(s)), on the target up to the shape's own projection)
    }

    fn distances(&self, nodes: &[[f64; D]]) -> Vec<(usize, f64)> {
        let mut out = Vec::new();
        for (i, role) in self.roles.iter().enumerate() {
            let part = match *role {
                Role2::Path => self.targets[i].and_then(|x| x.1),
                Role2::Slide { carrier, .. } => self.carriers[carrier].part,
                _ => None,
            };
            if let Some(PartKind::Move { target, .. }) = part.map(|k| &self.parts[k].kind) {
                out.push((i, target.distance(nodes[i])));
            }
        }
        out
    }

    fn state(&self) -> &Vec<Role2> {
        &self.roles
    }

    fn state_mut(&mut self) -> &mut Vec<Role2> {
        &mut self.roles
    }

    // a fixed role is never changed in a run (put_back changes a sliding
    // node's parameter only)
    fn held(&self, i: usize) -> bool {
        matches!(self.roles[i], Role2::Fixed)
    }
}

/// The curve two of the parts `here` (of a coarse edge with midpoint
/// `mid`) meet along ([`BoundaryPart::meets`]), the nearest to `mid` if
/// they share several.
fn meeting_curve<const D: usize>(parts: &[BoundaryPart<D>], here: &[usize], mid: [f64; D]) -> Option<Arc<dyn ClosestPoint<D>>> {
    let shared = here.iter().flat_map(|&a| parts[a].meets.iter().filter(move |(b, _)| *b != a && here.contains(b)).flat_map(|(_, curves)| curves.iter()));
    shared.min_by(|x, y| x.distance(mid).total_cmp(&y.distance(mid))).cloned()
}

/// Unit normal of a bilinear facet with corners `c` at s (zero if degenerate).
fn facet_normal<const D: usize>(c: &[[f64; D]], s: [f64; 2]) -> [f64; 3] {
    if D != 3 || c.len() < 3 {
        return [0.0; 3];
    }
    if c.len() == 3 {
        let n = crate::numeric::cross3(std::array::from_fn(|i| c[1][i] - c[0][i]), std::array::from_fn(|i| c[2][i] - c[0][i]));
        let l = dot(n, n).sqrt();
        return if l > 0.0 { n.map(|x| x / l) } else { [0.0; 3] };
    }
    let du: [f64; 3] = std::array::from_fn(|i| (1.0 - s[1]) * (c[1][i] - c[0][i]) + s[1] * (c[2][i] - c[3][i]));
    let dv: [f64; 3] = std::array::from_fn(|i| (1.0 - s[0]) * (c[3][i] - c[0][i]) + s[0] * (c[2][i] - c[1][i]));
    let n = crate::numeric::cross3(du, dv);
    let l = dot(n, n).sqrt();
    if l > 0.0 { n.map(|x| x / l) } else { [0.0; 3] }
}

/// Largest distance of a facet's corners from the plane through its first
/// corner with normal n, relative to its diameter.
fn off_plane<const D: usize>(c: &[[f64; D]], n: [f64; 3]) -> f64 {
    let diam = (0..c.len()).flat_map(|a| (0..c.len()).map(move |b| (a, b))).map(|(a, b)| (0..D).map(|k| (c[a][k] - c[b][k]).powi(2)).sum::<f64>().sqrt()).fold(0.0, f64::max);
    c.iter().map(|x| (0..D).map(|k| (x[k] - c[0][k]) * n[k.min(2)]).sum::<f64>().abs()).fold(0.0, f64::max) / diam.max(f64::MIN_POSITIVE)
}

/// What a patch repair asks of Algorithm 2 (see
/// [`RefineMesh::with_patch`]): per fine node, whether it is a node of the
/// patch, and where a node of the patch must end (its place in the snap:
/// every node the patch shares with an element outside it, and every new
/// node of a curved facet in it).
#[derive(Clone, Debug)]
pub struct PatchTargets<const D: usize> {
    pub inside: Vec<bool>,
    pub targets: Vec<Option<[f64; D]>>,
}

impl<const D: usize> RefineBoundary<D> {
    /// A patch repair's roles: nodes outside the patch held, a node with a
    /// target on the straight path from its start to it (the paper's
    /// Dirichlet data, onto the snap's place), the rest free.
    fn patch_roles(&mut self, patch: &PatchTargets<D>) {
        for i in 0..self.roles.len() {
            if !patch.inside[i] {
                self.roles[i] = Role2::Fixed;
                continue;
            }
            let Some(to) = patch.targets[i] else { continue };
            if matches!(self.roles[i], Role2::Fixed) && to == self.start[i] {
                continue;
            }
            // the part a curved facet's node is on, for its distance
            let part = match self.roles[i] {
                Role2::Slide { carrier, .. } => self.carriers[carrier].part,
                Role2::Path => self.targets[i].and_then(|x| x.1),
                _ => None,
            };
            self.targets[i] = Some((to, part));
            self.roles[i] = Role2::Path;
        }
    }
}

impl<M, const D: usize> RefineMesh<M, D> {
    /// A patch repair's run of Algorithm 2: from the straight fine mesh,
    /// only the nodes of the patch move; those with a target go straight
    /// to it, the others follow the flow.
    pub fn with_patch(mut self, patch: Arc<PatchTargets<D>>) -> Self {
        self.patch = Some(patch);
        self
    }

    /// Holds the nodes outside `band` ([`Subdivision::band`]) where they
    /// are for the runs of Algorithm 2 on this mesh.
    pub fn with_band(mut self, band: Vec<bool>) -> Self {
        self.band = Some(band);
        self
    }

    /// The settling pass after a sliding run: the mesh starts at `nodes`
    /// (where sliding left it) and every new node of a curved carrier
    /// follows a straight path from there to its place, with Dirichlet
    /// data: by default the point at its fraction (equispaced or
    /// Gauss–Lobatto, as subdivided) of the arc length of the carrier's
    /// image ([`Settle`]); old nodes stay, nodes of flat walls slide in
    /// them, and nodes far from every moved node are held.
    ///
    /// Why: sliding lets the nodes drift along the curve (a p = 3 edge's
    /// nodes at 0.330 and 0.670 instead of 1/3 and 2/3), which costs the
    /// order its accuracy between the nodes. Run as a flow, the correction
    /// carries the cells next to the wall along with it, so a layer thinner
    /// than the drift is moved as a block rather than sheared.
    ///
    /// `plan` says, per fine node, where it goes ([`Settle`]).
    pub fn settling<const N: usize>(mut self, nodes: &[[f64; D]], plan: SettlePlan) -> Self
    where
        M: Q1Mesh<D, N>,
    {
        self.mesh.nodes_mut().copy_from_slice(nodes);
        self.settle = Some(plan);
        self
    }

    /// For fine node `i` inside a coarse edge in 3D: if the edge lies
    /// inside one plane — between two flat, coplanar facets of one flat
    /// slip part — the two facets (carrier indices) and the node's
    /// parameters on each. A crease (two parts, non-coplanar facets) gives
    /// None. (An edge inside one smooth curved part still glides along its
    /// blended curve: letting it slide on the surface tangled the 1e-5
    /// layer of the extruded cylinder at t = 0.15.)
    fn inside_one_plane(&self, i: usize, parts: &[BoundaryPart<D>], carriers: &[Carrier<D>]) -> Option<Vec<(usize, [f64; 2])>> {
        let on = self.on_facets.get(&i)?;
        if D != 3 || on.len() != 2 {
            return None;
        }
        let k = self.facet_parts[on[0].0];
        if self.facet_parts[on[1].0] != k {
            return None;
        }
        if !matches!(parts[k].kind, PartKind::Slip { wall: None }) {
            return None;
        }
        let corners = |f: usize| &carriers[f].corners;
        let n: Vec<[f64; 3]> = on.iter().map(|&(f, s)| facet_normal(corners(f), s)).collect();
        // one plane: the facets are flat and coplanar
        let flat = on.iter().zip(&n).all(|(&(f, _), &nf)| off_plane(corners(f), nf) < 1e-10);
        (flat && 1.0 - dot(n[0], n[1]).abs() < 1e-12).then(|| on.clone())
    }
}

impl<M: Q1Mesh<D, N>, const D: usize, const N: usize> Q1Mesh<D, N> for RefineMesh<M, D> {
    type Boundary = RefineBoundary<D>;

    fn cells(&self) -> &[[usize; N]] {
        self.mesh.cells()
    }
    fn nodes(&self) -> &[[f64; D]] {
        self.mesh.nodes()
    }
    fn nodes_mut(&mut self) -> &mut Vec<[f64; D]> {
        self.mesh.nodes_mut()
    }
    fn flux_points<'a>(&'a self, nodes: &'a [[f64; D]], v: &'a [[f64; D]]) -> impl Iterator<Item = ([f64; D], f64)> + 'a {
        self.mesh.flux_points(nodes, v)
    }
    fn measure(&self) -> f64 {
        self.mesh.measure()
    }

    fn boundary(&self, parts: Vec<BoundaryPart<D>>) -> Result<RefineBoundary<D>, DeformError> {
        let moving = |k: usize| matches!(parts[k].kind, PartKind::Move { .. });
        let dirichlet = |k: usize| matches!(parts[k].kind, PartKind::Move { mode: MoveMode::Dirichlet, .. });
        let fixed = |k: usize| matches!(parts[k].kind, PartKind::Fixed);
        let mut carriers: Vec<Carrier<D>> = Vec::new();
        // one carrier per coarse facet, then one per coarse edge (3D)
        for (corners, &part) in self.facet_corners.iter().zip(&self.facet_parts) {
            carriers.push(Carrier { corners: corners.clone(), part: moving(part).then_some(part), bounded: moving(part), curve: None, images: corners.len() == 3 });
        }
        let edge_base = carriers.len();
        for (ends, facets) in &self.edges {
            let parts_here: Vec<usize> = facets.iter().map(|&f| self.facet_parts[f]).collect();
            let carrier_part = parts_here.iter().copied().find(|&k| moving(k));
            let mid: [f64; D] = std::array::from_fn(|k| 0.5 * (ends[0][k] + ends[1][k]));
            let curve = carrier_part.and_then(|_| meeting_curve(&parts, &parts_here, mid));
            // else the edge's new nodes follow the first moving part only
            if let Some(a) = carrier_part.filter(|_| curve.is_none() && !parts_here.iter().any(|&k| fixed(k))) {
                let h = (0..D).map(|k| (ends[1][k] - ends[0][k]).powi(2)).sum::<f64>().sqrt();
                for &b in parts_here.iter().filter(|&&b| b != a && moving(b)) {
                    for s in [0.25, 0.5, 0.75] {
                        let x = std::array::from_fn(|k| (1.0 - s) * ends[0][k] + s * ends[1][k]);
                        crate::deform::check_meeting(&parts, a, b, x, h)?;
                    }
                }
            }
            // (not where a quad facet of the part meets a triangle of
            // another, as a prism layer's wall meets its flat ends: the
            // quad's inside nodes sit on fitted lines)
            let images = self.p >= 4 && facets.iter().any(|&f| self.facet_corners[f].len() == 3 && Some(self.facet_parts[f]) == carrier_part);
            carriers.push(Carrier { corners: ends.to_vec(), part: carrier_part, bounded: carrier_part.is_some(), curve, images });
        }
        let start = self.mesh.nodes().to_vec();
        let mut roles = vec![Role2::Interior; start.len()];
        let mut targets = vec![None; start.len()];
        for (i, place) in self.places.iter().enumerate() {
            let (carrier, s, parts_here) = match *place {
                Place::Interior => continue,
                Place::Vertex => {
                    roles[i] = Role2::Fixed;
                    continue;
                }
                Place::Facet { facet, s } => (facet, s, vec![self.facet_parts[facet]]),
                Place::Edge { edge, sigma } => (edge_base + edge, [sigma, 0.0], self.edges[edge].1.iter().map(|&f| self.facet_parts[f]).collect()),
            };
            roles[i] = if parts_here.iter().any(|&k| fixed(k)) {
                Role2::Fixed
            } else if let Some(k) = parts_here.iter().copied().find(|&k| dirichlet(k)) {
                let image = parts[k].image(start[i]).ok_or_else(|| DeformError::Unreachable {
                    part: parts[k].name.clone(),
                    why: format!("a new high-order node at {:?} has no image on the target", start[i]),
                })?;
                targets[i] = Some((image, Some(k)));
                Role2::Path
            } else if let Some(on) = self.inside_one_plane(i, &parts, &carriers) {
                // inside one flat slip plane: it slides in the plane like a
                // facet node (the first facet's carrier is unbounded and
                // flat), not along the coarse edge: held on the edge, a node
                // 1e-5 from a curved wall cannot follow the wall's new nodes
                Role2::Slide { carrier: on[0].0, s: on[0].1 }
            } else {
                Role2::Slide { carrier, s }
            };
        }
        let mut b = RefineBoundary { parts, carriers, roles, start, targets };
        if let Some(plan) = &self.settle {
            b.settle_roles(plan)?;
            b.hold_beyond_band(self.mesh.cells());
        } else if let Some(band) = &self.band {
            b.hold_outside(band);
        }
        if let Some(patch) = &self.patch {
            b.patch_roles(patch);
        }
        // every sliding node of a moving carrier needs an image
        for (i, role) in b.roles.iter().enumerate() {
            if let Role2::Slide { carrier, s } = *role {
                let car = &b.carriers[carrier];
                if let Some(k) = car.part {
                    if b.carrier_image(carrier, car.start(s)).is_none() {
                        return Err(DeformError::Unreachable {
                            part: b.parts[k].name.clone(),
                            why: format!("the new high-order node {i} at {:?} has no image on the target", b.start[i]),
                        });
                    }
                }
            }
        }
        Ok(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::QuadMesh;

    /// Asks with one key are answered by one call, in their order, and
    /// the answers go back to their own asks.
    #[test]
    fn grouped_asks_each_key_once_and_splits_the_answers_back() {
        let asks: Vec<(char, Vec<u32>)> = vec![('a', vec![1, 2]), ('b', vec![3]), ('a', vec![4]), ('c', vec![]), ('b', vec![5, 6])];
        let calls = std::cell::RefCell::new(Vec::new());
        let out = grouped(&asks, |first, ps| {
            calls.borrow_mut().push((first, ps.to_vec()));
            ps.iter().map(|p| p * 10).collect()
        });
        assert_eq!(out, vec![vec![10, 20], vec![30], vec![40], vec![], vec![50, 60]]);
        assert_eq!(calls.into_inner(), vec![(0, vec![1, 2, 4]), (1, vec![3, 5, 6]), (3, vec![])]);
    }

    #[test]
    fn quad_subdivision_shares_nodes_and_counts_match() {
        let coarse = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 3, 2);
        for p in 1..=4 {
            let s = subdivide(&coarse, p, Spacing::Equispaced).unwrap();
            // a structured (3p+1)×(2p+1) grid
            assert_eq!(s.fine.nodes.len(), (3 * p + 1) * (2 * p + 1), "p = {p}");
            assert_eq!(s.fine.cells.len(), 6 * p * p);
            assert_eq!(s.fine.edges.len(), 10 * p);
            assert!(crate::quality::certify::invalid_cells(&s.fine.cells, &s.fine.nodes).is_empty());
            assert!((s.fine.area() - 1.0).abs() < 1e-14);
            // each element's nodes sit at its tensor positions
            for (c, el) in s.elements.iter().enumerate() {
                let lo = coarse.nodes[coarse.cells[c][0]];
                for (k, &n) in el.iter().enumerate() {
                    let (i, j) = (k % (p + 1), k / (p + 1));
                    let want = [lo[0] + i as f64 / (3 * p) as f64, lo[1] + j as f64 / (2 * p) as f64];
                    let got = s.fine.nodes[n];
                    assert!((got[0] - want[0]).abs() < 1e-14 && (got[1] - want[1]).abs() < 1e-14);
                }
            }
            assert!(s.coarse_nodes.iter().all(|&n| n != usize::MAX));
        }
    }

    /// The 3 × 2 box with its right column of quads cut into triangles:
    /// quads and triangles share the fine nodes of their common edges (at
    /// the 1D Gauss–Lobatto nodes), every fine triangle is positive and
    /// the fine cells tile the box.
    #[test]
    fn mixed_subdivision_shares_edges_across_kinds() {
        let q = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 3, 2);
        let mut cells = Vec::new();
        for (c, &[a, b, cc, d]) in q.cells.iter().enumerate() {
            if c % 3 == 2 {
                cells.extend([(Shape::Triangle, vec![a, b, cc]), (Shape::Triangle, vec![a, cc, d])]);
            } else {
                cells.push((Shape::Quadrilateral, vec![a, b, cc, d]));
            }
        }
        let coarse = CurvedMesh::linear(q.nodes.clone(), cells, q.edges.iter().map(|e| (e.nodes, e.part)), q.part_names.clone());
        for p in 1..=4 {
            let (s, owner) = subdivide_mixed(&coarse, p, Spacing::GaussLobatto).unwrap();
            // 4 quads of (p+1)² nodes and 4 triangles of (p+1)(p+2)/2, less
            // the shared ones: the 12 vertices, p − 1 on each of the 19
            // edges (17 of the grid, 2 diagonals), and the quads' (p−1)²
            // and triangles' (p−1)(p−2)/2 inner nodes
            let inner = |k: usize| k.saturating_sub(1);
            let want = 12 + 19 * inner(p) + 4 * inner(p) * inner(p) + 4 * inner(p) * inner(p.saturating_sub(1)) / 2;
            assert_eq!(s.fine.nodes.len(), want, "p = {p}");
            let mut sorted = s.fine.nodes.clone();
            sorted.sort_by(|a, b| a.partial_cmp(b).unwrap());
            assert!(sorted.windows(2).all(|w| dist2(w[0], w[1]) > 1e-20), "p = {p}: two fine nodes at one point");
            assert_eq!(s.fine.cells.len(), 4 * 2 * p * p + 4 * p * p);
            assert!(crate::quality::certify::invalid_cells(&s.fine.cells, &s.fine.nodes).is_empty());
            assert!((s.fine.area() - 1.0).abs() < 1e-14);
            assert_eq!(s.fine.edges.len(), 10 * p);
            let kinds: Vec<Shape> = (0..s.elements.len()).map(|e| s.element_shape(e)).collect();
            assert_eq!(kinds, (0..coarse.cells.len()).map(|c| coarse.cells.shape(c)).collect::<Vec<_>>());
            // each fine cell lies in its owner: its centroid inside the
            // coarse cell's bounding box
            for (f, cell) in s.fine.cells.iter().enumerate() {
                let c = cell.map(|n| s.fine.nodes[n]);
                let mid = [(c[0][0] + c[1][0] + c[2][0]) / 3.0, (c[0][1] + c[1][1] + c[2][1]) / 3.0];
                let corners = coarse.cells[owner[f]].iter().map(|&n| coarse.nodes[n]);
                let (lo, hi) = corners.fold(([f64::MAX; 2], [f64::MIN; 2]), |(lo, hi), x| ([lo[0].min(x[0]), lo[1].min(x[1])], [hi[0].max(x[0]), hi[1].max(x[1])]));
                assert!((0..2).all(|d| lo[d] < mid[d] && mid[d] < hi[d]), "fine cell {f} outside coarse cell {}", owner[f]);
            }
        }
    }

    /// The fine tetrahedra of a mixed solid's subdivision `s` of `coarse`
    /// are positive and fill `volume`, no two fine nodes coincide, every
    /// face is held twice (by two tetrahedra, or one and a fine boundary
    /// facet: the cuts of a shared quad agree), and the elements keep
    /// their kinds.
    fn assert_conforming_tets(s: &Subdivision<TetMesh, 3>, coarse: &CurvedMesh<3>, volume: f64, what: &str) {
        let vols: Vec<f64> = s.fine.cells.iter().map(|c| {
            let x = c.map(|n| s.fine.nodes[n]);
            let e = |a: usize| std::array::from_fn::<f64, 3, _>(|d| x[a][d] - x[0][d]);
            crate::numeric::dot(crate::numeric::cross3(e(1), e(2)), e(3)) / 6.0
        }).collect();
        assert!(vols.iter().all(|&v| v > 0.0), "{what}: a negative fine tetrahedron");
        assert!((vols.iter().sum::<f64>() - volume).abs() < 1e-13, "{what}");
        let mut sorted = s.fine.nodes.clone();
        sorted.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert!(sorted.windows(2).all(|w| dist2(w[0], w[1]) > 1e-20), "{what}: two fine nodes at one point");
        let mut held: HashMap<Vec<usize>, usize> = HashMap::new();
        for t in &s.fine.cells {
            for f in [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]] {
                let mut k = f.map(|a| t[a]).to_vec();
                k.sort_unstable();
                *held.entry(k).or_default() += 1;
            }
        }
        for f in &s.fine.faces {
            let mut k = f.nodes.to_vec();
            k.sort_unstable();
            *held.entry(k).or_default() += 1;
        }
        assert!(held.values().all(|&n| n == 2), "{what}: a face held once: the cuts of a shared quad differ");
        let kinds: Vec<Shape> = (0..s.elements.len()).map(|e| s.element_shape(e)).collect();
        assert_eq!(kinds, (0..coarse.cells.len()).map(|c| coarse.cells.shape(c)).collect::<Vec<_>>());
    }

    /// The boundary of `cells` (kind and vertices): the faces held once,
    /// in part 0.
    fn outer_faces(cells: &[(Shape, Vec<usize>)]) -> Vec<(Vec<usize>, usize)> {
        let mut count: HashMap<Vec<usize>, (usize, Vec<usize>)> = HashMap::new();
        for f in cells.iter().flat_map(|(shape, v)| cell_faces(*shape, v)) {
            let mut k = f.clone();
            k.sort_unstable();
            count.entry(k).or_insert((0, f)).0 += 1;
        }
        count.into_values().filter(|c| c.0 == 1).map(|c| (c.1, 0)).collect()
    }

    /// A column of two prisms under six tetrahedra (the top layer's
    /// prisms cut by `prism_tets`), nodes numbered out of order: at every
    /// order the fine tetrahedra are positive, fill the column, and meet
    /// face to face (each face held by two tetrahedra or by one and a fine
    /// boundary facet: the cuts of shared quads agree); the elements keep
    /// their kinds and node counts.
    #[test]
    fn prisms_and_tets_subdivide_into_conforming_tets() {
        let order = [7, 2, 11, 4, 0, 9, 5, 1, 10, 3, 8, 6];
        let mut nodes = vec![[0.0; 3]; 12];
        for level in 0..3 {
            for (k, xy) in [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]].iter().enumerate() {
                nodes[order[4 * level + k]] = [xy[0], xy[1], level as f64];
            }
        }
        let at = |level: usize, k: usize| order[4 * level + k];
        let prism = |l: usize, t: [usize; 3]| [at(l, t[0]), at(l, t[1]), at(l, t[2]), at(l + 1, t[0]), at(l + 1, t[1]), at(l + 1, t[2])];
        let mut cells = vec![(Shape::Prism, prism(0, [0, 1, 2]).to_vec()), (Shape::Prism, prism(0, [0, 2, 3]).to_vec())];
        for t in [[0, 1, 2], [0, 2, 3]] {
            cells.extend(prism_tets(prism(1, t)).map(|t| (Shape::Tetrahedron, t.to_vec())));
        }
        let faces = outer_faces(&cells);
        assert_eq!(faces.iter().filter(|f| f.0.len() == 4).count(), 4, "the prisms' four side quads");
        let coarse = CurvedMesh::linear(nodes, cells, faces, vec!["all".into()]);
        for p in 1..=4 {
            let (s, owner) = subdivide_mixed_solid(&coarse, p, Spacing::GaussLobatto).unwrap();
            assert_eq!(s.fine.cells.len(), 2 * 3 * p * p * p + 6 * p * p * p, "p = {p}");
            assert_eq!(owner.iter().filter(|&&c| c < 2).count(), 6 * p * p * p);
            assert_conforming_tets(&s, &coarse, 2.0, &format!("p = {p}"));
            assert_eq!(s.elements[0].len(), Shape::Prism.num_nodes(p));
        }
    }

    /// Two hexes side by side, a pyramid on the first one's top and a
    /// tetrahedron on each of the pyramid's triangles, nodes numbered out
    /// of order: at every order the fine tetrahedra (the hexes' about
    /// their sub-hexes' centres, the pyramid's cut on their bases) are
    /// positive, fill the cells, and meet face to face; the centres come
    /// after every element node.
    #[test]
    fn hexes_pyramids_and_tets_subdivide_into_conforming_tets() {
        use crate::mesh::corner_jacobians;
        let points = [
            [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0],
            [2.0, 0.0, 0.0], [2.0, 1.0, 0.0], [2.0, 0.0, 1.0], [2.0, 1.0, 1.0], [0.5, 0.5, 1.6],
            [0.5, -0.4, 1.3], [1.4, 0.5, 1.3], [0.5, 1.4, 1.3], [-0.4, 0.5, 1.3],
        ];
        let order = [11, 3, 16, 0, 7, 14, 2, 9, 5, 12, 1, 15, 6, 10, 4, 13, 8];
        let mut nodes = vec![[0.0; 3]; points.len()];
        for (k, x) in points.iter().enumerate() {
            nodes[order[k]] = *x;
        }
        let at = |k: usize| order[k];
        let mut cells = vec![
            (Shape::Hexahedron, [0, 1, 2, 3, 4, 5, 6, 7].map(at).to_vec()),
            (Shape::Hexahedron, [1, 8, 9, 2, 5, 10, 11, 6].map(at).to_vec()),
            (Shape::Pyramid, [4, 5, 6, 7, 12].map(at).to_vec()),
        ];
        // on each triangle (a, b, apex) of the pyramid, outward
        for (a, b, out) in [(4, 5, 13), (5, 6, 14), (6, 7, 15), (7, 4, 16)] {
            cells.push((Shape::Tetrahedron, [a, b, 12, out].map(at).to_vec()));
        }
        let volume: f64 = cells.iter().filter(|c| c.0 == Shape::Tetrahedron).map(|(shape, v)| corner_jacobians(*shape, v, &nodes)[0] / 6.0).sum::<f64>() + 2.0 + 0.6 / 3.0;
        assert!(cells.iter().all(|(shape, v)| corner_jacobians(*shape, v, &nodes).iter().all(|&j| j > 0.0)));
        let faces = outer_faces(&cells);
        let coarse = CurvedMesh::linear(nodes, cells, faces, vec!["all".into()]);
        for p in 1..=4 {
            for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
                let (s, owner) = subdivide_mixed_solid(&coarse, p, spacing).unwrap();
                let p3 = p * p * p;
                assert_eq!(owner.iter().filter(|&&c| c < 2).count(), 2 * 12 * p3, "p = {p}");
                assert_eq!(owner.iter().filter(|&&c| c == 2).count(), (1..=p).map(|q| 2 * q * q + 2 * (q - 1) * (q - 1) + 2 * q * (q - 1)).sum::<usize>());
                let last = s.elements.iter().flatten().max().unwrap() + 1;
                assert_eq!(s.fine.nodes.len(), last + 2 * p3, "p = {p}: the centres come last");
                assert_conforming_tets(&s, &coarse, volume, &format!("p = {p} {spacing:?}"));
            }
        }
    }

    #[test]
    fn hex_subdivision_shares_faces_in_any_orientation() {
        let mut coarse = HexMesh::structured_box([0.0; 3], [1.0; 3], [2, 2, 2]);
        // renumber nodes in reverse so shared faces meet in other frames
        let n = coarse.nodes.len();
        coarse.nodes.reverse();
        coarse.cells.iter_mut().for_each(|c| *c = c.map(|v| n - 1 - v));
        coarse.faces.iter_mut().for_each(|f| f.nodes = f.nodes.map(|v| n - 1 - v));
        for p in 1..=3 {
            let s = subdivide(&coarse, p, Spacing::Equispaced).unwrap();
            assert_eq!(s.fine.nodes.len(), (2 * p + 1).pow(3), "p = {p}");
            assert_eq!(s.fine.faces.len(), 6 * 4 * p * p);
            assert!(crate::quality::certify::invalid_cells(&s.fine.cells, &s.fine.nodes).is_empty());
            // every boundary facet's nodes lie on the box's surface
            for (grid, _) in &s.facets {
                assert_eq!(grid.len(), (p + 1) * (p + 1));
                for &g in grid {
                    let x = s.fine.nodes[g];
                    assert!(x.iter().any(|&c| c.abs() < 1e-14 || (c - 1.0).abs() < 1e-14), "{x:?}");
                }
            }
        }
    }

    #[test]
    fn facets_are_checked_oriented_and_must_cover_the_boundary() {
        let mut coarse = QuadMesh::structured_box([0.0, 0.0], [2.0, 1.0], 2, 1);
        // flip one boundary edge: it is turned back to the cell's orientation
        coarse.edges[0].nodes.reverse();
        let s = subdivide(&coarse, 2, Spacing::Equispaced).unwrap();
        let flux: f64 = crate::jacobian::edge_flux_points(&s.fine, &s.fine.nodes, &vec![[1.0, 0.0]; s.fine.nodes.len()]).map(|x| x.1).sum();
        // a uniform velocity has no net flux through a closed, consistently
        // oriented boundary
        assert!(flux.abs() < 1e-14, "net flux {flux}");
        // a diagonal is no cell edge
        let mut bad = coarse.clone();
        bad.edges[0].nodes = [0, 4];
        assert!(matches!(subdivide(&bad, 2, Spacing::Equispaced), Err(SubdivideError::NotACellFacet { index: 0, .. })));
        // a boundary edge left out: its nodes would move freely
        let mut open = coarse.clone();
        open.edges.remove(3);
        let e = subdivide(&open, 2, Spacing::Equispaced).err().expect("uncovered");
        assert!(matches!(e, SubdivideError::Uncovered { count: 1, .. }), "{e}");
        assert!(matches!(subdivide(&coarse, 0, Spacing::Equispaced), Err(SubdivideError::Order(0))));
        // the edge between the two cells in a group: refused, naming it
        let mut inner = coarse.clone();
        let shared: Vec<usize> = (0..coarse.nodes.len()).filter(|&n| coarse.cells[0].contains(&n) && coarse.cells[1].contains(&n)).collect();
        inner.edges.push(BoundaryEdge { nodes: [shared[0], shared[1]], part: 0 });
        let e = subdivide(&inner, 2, Spacing::Equispaced).err().expect("interior");
        assert!(matches!(e, SubdivideError::InteriorFacet { .. }), "{e}");
        assert!(e.to_string().contains(&format!("group `{}`", coarse.part_names[0])) && e.to_string().contains("inside the mesh"), "{e}");
        // and a hex face between two cells
        let mut hex = HexMesh::structured_box([0.0; 3], [2.0, 1.0, 1.0], [2, 1, 1]);
        let shared: Vec<usize> = (0..hex.nodes.len()).filter(|&n| hex.cells[0].contains(&n) && hex.cells[1].contains(&n)).collect();
        let mut face = hex.faces[0].clone();
        // cyclic order of the shared square x = 1: (y, z) = 00, 10, 11, 01
        let mut sq = shared.clone();
        sq.sort_by(|&a, &b| {
            let ang = |n: usize| (hex.nodes[n][2] - 0.5).atan2(hex.nodes[n][1] - 0.5);
            ang(a).total_cmp(&ang(b))
        });
        face.nodes = [sq[0], sq[1], sq[2], sq[3]];
        hex.faces.push(face);
        let e = subdivide(&hex, 2, Spacing::Equispaced).err().expect("interior face");
        assert!(matches!(e, SubdivideError::InteriorFacet { .. }), "{e}");
    }

    /// Faces xmax and ymax of the unit cube curved to two spheres through
    /// their corners: their shared edge cannot follow both. Refused,
    /// naming both groups; with one sphere (bound twice) accepted.
    #[test]
    fn two_curved_groups_meeting_along_an_edge() {
        use crate::geometry::SurfaceSpec;
        use std::sync::Arc;
        let mesh = HexMesh::structured_box([0.0; 3], [1.0; 3], [2, 2, 2]);
        let sphere = |centre: [f64; 3], radius: f64| -> Arc<dyn crate::deform::BoundaryShape<3>> { Arc::new(SurfaceSpec::Sphere { centre, radius }.build().unwrap()) };
        let parts_with = |a: Arc<dyn crate::deform::BoundaryShape<3>>, b: Arc<dyn crate::deform::BoundaryShape<3>>| -> Vec<BoundaryPart<3>> {
            crate::mesh::BOX_FACES
                .iter()
                .map(|&name| {
                    let kind = match name {
                        "xmax" => PartKind::Move { target: a.clone(), correspondence: Correspondence::Normal, mode: MoveMode::Sliding },
                        "ymax" => PartKind::Move { target: b.clone(), correspondence: Correspondence::Normal, mode: MoveMode::Sliding },
                        _ => PartKind::Slip { wall: None },
                    };
                    BoundaryPart::new(name, kind)
                })
                .collect()
        };
        let s = subdivide(&mesh, 2, Spacing::Equispaced).unwrap();
        let r = 1.5f64.sqrt();
        let two = parts_with(sphere([0.0, 0.5, 0.5], r), sphere([0.5, 0.0, 0.5], r));
        let e = s.refine_mesh().boundary(refine_parts(&two)).err().expect("refused").to_string();
        assert!(e.contains("`xmax`") && e.contains("`ymax`") && e.contains("not supported"), "{e}");
        let one = sphere([0.5; 3], 0.75f64.sqrt());
        assert!(s.refine_mesh().boundary(refine_parts(&parts_with(one.clone(), one))).is_ok());
    }

    #[test]
    fn hex_faces_given_inward_are_turned_outward() {
        let mut coarse = HexMesh::structured_box([0.0; 3], [1.0; 3], [1, 1, 1]);
        for f in coarse.faces.iter_mut() {
            f.nodes.reverse();
        }
        let s = subdivide(&coarse, 2, Spacing::Equispaced).unwrap();
        // every fine face's normal points away from the centre
        for f in &s.fine.faces {
            let p = f.nodes.map(|n| s.fine.nodes[n]);
            let d1: [f64; 3] = std::array::from_fn(|k| p[2][k] - p[0][k]);
            let d2: [f64; 3] = std::array::from_fn(|k| p[3][k] - p[1][k]);
            let n = crate::numeric::cross3(d1, d2);
            let c: [f64; 3] = std::array::from_fn(|k| p.iter().map(|q| q[k]).sum::<f64>() / 4.0 - 0.5);
            assert!(n[0] * c[0] + n[1] * c[1] + n[2] * c[2] > 0.0);
        }
    }
}
