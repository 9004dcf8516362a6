//! MFEM's own mesh format, "MFEM mesh v1.0", for quad and hex meshes of
//! any order, with element and boundary attributes: what MFEM-based
//! solvers read directly (`mfem::Mesh(path)`).
//!
//! Layout: `dimension`, `elements` (`attr geom v0 v1 …`, geometry 3 =
//! square, 5 = cube), `boundary` (geometry 1 = segment in 2D, 3 = square
//! in 3D), `vertices` (the cell corners only, numbered compactly in the
//! order of their node indices). Order 1 writes the vertex coordinates
//! and no curvature; order `p ≥ 2` writes a `nodes` grid function of the
//! H1 space of order `p` with `VDim: D`, `Ordering: 1` (byVDIM).
//!
//! **Basis.** The nodal basis matches the mesh's [`Spacing`], so the node
//! coordinates are written as they are, without resampling:
//! [`Spacing::GaussLobatto`] is MFEM's default H1 basis (`H1_2D_P<p>`,
//! `H1_3D_P<p>`: Gauss–Lobatto points on `[0,1]`, the same points as
//! ours), [`Spacing::Equispaced`] its closed-uniform one (`H1@U_2D_P<p>`,
//! `H1@U_3D_P<p>`: `i/p`).
//!
//! **DOF order** is the one MFEM's reader rebuilds (`Mesh::Loader` →
//! `FinalizeTopology`, then `FiniteElementSpace::Construct`): all vertex
//! dofs, then `p − 1` per edge, then (3D) `(p − 1)²` per face, then
//! `(p − 1)^D` per element. Edges and faces are numbered in order of first
//! appearance, going through the elements in order and through each
//! element's local edges/faces in MFEM's tables (`DSTable` and `STable3D`
//! number on first push). A global edge's dofs run from its lower vertex
//! number to the higher one (an element sees its edge with orientation
//! +1 iff `v[e[0]] < v[e[1]]`). A global face's dofs are those of its
//! first element's local face, which MFEM gives orientation 0: a quad of
//! order `p − 2` with first axis from face vertex 0 to 1 and second from
//! 0 to 3 (`Constants<CUBE>::FaceVert`, `H1_DOF_MAP` in `fe_base.cpp`).
//! Element interiors are in tensor order. Checked against MFEM 4.10
//! (PyMFEM) in `tests/it/mfem.rs`.

use std::collections::HashSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use thiserror::Error;

use super::fmt_f64;
use crate::mesh::element::order::HEX_CORNERS;
use crate::mesh::element::{Shape, Spacing};
use crate::mesh::file::write_atomic;
use crate::mesh::CurvedMesh;

/// MFEM's `Geometry::Type` numbers.
const SEGMENT: u8 = 1;
/// See [`SEGMENT`].
const SQUARE: u8 = 3;
/// See [`SEGMENT`].
const CUBE: u8 = 5;

/// MFEM's quad edges as local vertex pairs (`Constants<SQUARE>::Edges`).
const QUAD_EDGES: [[usize; 2]; 4] = [[0, 1], [1, 2], [2, 3], [3, 0]];

/// MFEM's hex edges (`Constants<CUBE>::Edges`): note (3,2) and (7,6) run
/// along the first axis, unlike Gmsh's.
const HEX_EDGES: [[usize; 2]; 12] = [
    [0, 1],
    [1, 2],
    [3, 2],
    [0, 3],
    [4, 5],
    [5, 6],
    [7, 6],
    [4, 7],
    [0, 4],
    [1, 5],
    [2, 6],
    [3, 7],
];

/// MFEM's hex faces as vertex loops (`Constants<CUBE>::FaceVert`).
const HEX_FACES: [[usize; 4]; 6] = [
    [3, 2, 1, 0],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
    [4, 5, 6, 7],
];

/// Errors of writing MFEM meshes. Nothing is written when one occurs.
#[derive(Debug, Error)]
pub enum MfemError {
    /// The mesh fails [`CurvedMesh::validate`].
    #[error("cannot write an MFEM mesh: {0}")]
    InvalidMesh(String),
    /// Cells this writer has no MFEM node order for yet.
    #[error("the MFEM writer takes quads and hexes for now, not {0:?}s: write the mesh as .msh (MFEM reads Gmsh's MSH 2.2 and 4.1)")]
    Shape(crate::mesh::element::Shape),
    /// An attribute list whose length is not the number of cells or
    /// boundary elements.
    #[error("{found} {what} attributes given, the mesh has {expected} {what}s")]
    AttributeCount {
        /// `"cell"` or `"boundary element"`.
        what: &'static str,
        /// Number of cells or boundary elements.
        expected: usize,
        /// Length given.
        found: usize,
    },
    /// An attribute MFEM cannot hold: attributes are positive C `int`s.
    #[error("{what} {index} has attribute {value}; MFEM attributes must be in 1..={}", i32::MAX)]
    BadAttribute {
        /// `"cell"` or `"boundary element"`.
        what: &'static str,
        /// Index of the cell or boundary element.
        index: usize,
        /// The offending value.
        value: i64,
    },
    /// A cell whose corners are not distinct nodes: MFEM's edge and face
    /// tables assume distinct vertices.
    #[error("cell {cell} has a repeated corner node")]
    RepeatedCorner {
        /// Index of the cell.
        cell: usize,
    },
    /// A boundary element that is no cell's side: MFEM aborts on those.
    #[error("boundary element {index} is not a side of any cell (corner nodes {corners:?})")]
    NotASide {
        /// Index of the boundary element.
        index: usize,
        /// Its corner nodes.
        corners: Vec<usize>,
    },
    /// The file could not be written.
    #[error("cannot write `{}`", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// The mesh as "MFEM mesh v1.0" text (layout, basis and DOF order in the
/// [module docs](self)). `cell_attributes[c]` is the attribute of
/// `mesh.cells[c]`, `boundary_attributes[b]` that of `mesh.boundary[b]`.
///
/// Fails on meshes that fail [`CurvedMesh::validate`], attribute lists of
/// the wrong length or with values outside `1..=i32::MAX`, cells with a
/// repeated corner, boundary elements that are no cell side, and
/// triangles or tetrahedra, alone or among quads ([`MfemError::Shape`]).
pub fn mfem_string<const D: usize>(
    mesh: &CurvedMesh<D>,
    cell_attributes: &[i64],
    boundary_attributes: &[i64],
) -> Result<String, MfemError> {
    mesh.validate().map_err(MfemError::InvalidMesh)?;
    // any cell of another kind, not just the first (a mixed mesh would
    // have its triangles, prisms or pyramids written as quads or hexes)
    if let Some(shape) = mesh.shapes().into_iter().find(|s| !matches!(s, Shape::Quadrilateral | Shape::Hexahedron)) {
        return Err(MfemError::Shape(shape));
    }
    check_attributes("cell", cell_attributes, mesh.cells.len())?;
    check_attributes("boundary element", boundary_attributes, mesh.boundary.len())?;
    let topo = Topology::new(mesh)?;
    topo.check_boundary(mesh)?;
    let mut out = format!("MFEM mesh v1.0\n\ndimension\n{D}\n\n");
    push_elements(&mut out, mesh, &topo, cell_attributes);
    push_boundary(&mut out, mesh, &topo, boundary_attributes);
    if mesh.p == 1 {
        push_vertices(&mut out, mesh, &topo);
    } else {
        push_nodes(&mut out, mesh, &topo);
    }
    Ok(out)
}

/// Writes [`mfem_string`] atomically to `path`; nothing is written if the
/// input is rejected.
pub fn write_mfem<const D: usize>(
    path: &Path,
    mesh: &CurvedMesh<D>,
    cell_attributes: &[i64],
    boundary_attributes: &[i64],
) -> Result<(), MfemError> {
    let text = mfem_string(mesh, cell_attributes, boundary_attributes)?;
    write_atomic(path, text.as_bytes()).map_err(|source| MfemError::Io {
        path: path.to_owned(),
        source,
    })
}

/// Fails unless there is one attribute per item, each in `1..=i32::MAX`.
fn check_attributes(what: &'static str, values: &[i64], expected: usize) -> Result<(), MfemError> {
    if values.len() != expected {
        return Err(MfemError::AttributeCount { what, expected, found: values.len() });
    }
    match values.iter().position(|&a| !(1..=i64::from(i32::MAX)).contains(&a)) {
        Some(index) => Err(MfemError::BadAttribute { what, index, value: values[index] }),
        None => Ok(()),
    }
}

/// Corner `v` of the reference cell of dimension `dim` (MFEM's vertex
/// order, the same as Gmsh's), as a tensor index point of an order-`p`
/// element.
fn corner(dim: usize, v: usize, p: usize) -> [usize; 3] {
    let mut q = [0; 3];
    for d in 0..dim {
        q[d] = HEX_CORNERS[v][d] * p;
    }
    q
}

/// The tensor index of index point `q` (components `0..dim`).
fn tensor(dim: usize, q: [usize; 3], p: usize) -> usize {
    (0..dim).rev().fold(0, |acc, d| acc * (p + 1) + q[d])
}

/// The node indices of an element's corners in MFEM's vertex order.
fn corner_nodes(dim: usize, nodes: &[usize], p: usize) -> Vec<usize> {
    (0..1 << dim).map(|v| nodes[tensor(dim, corner(dim, v, p), p)]).collect()
}

/// The MFEM vertices: the cell corners, numbered by increasing node index.
struct Topology {
    /// MFEM vertex number of each node (`usize::MAX`: not a corner).
    vertex: Vec<usize>,
    /// The node of each MFEM vertex.
    nodes: Vec<usize>,
}

impl Topology {
    /// Numbers the corners; fails on a cell with a repeated corner.
    fn new<const D: usize>(mesh: &CurvedMesh<D>) -> Result<Self, MfemError> {
        let mut is_corner = vec![false; mesh.nodes.len()];
        for (c, cell) in mesh.cells.iter().enumerate() {
            let corners = corner_nodes(D, cell, mesh.p);
            if corners.iter().enumerate().any(|(i, v)| corners[..i].contains(v)) {
                return Err(MfemError::RepeatedCorner { cell: c });
            }
            corners.iter().for_each(|&v| is_corner[v] = true);
        }
        let nodes: Vec<usize> = (0..mesh.nodes.len()).filter(|&v| is_corner[v]).collect();
        let mut vertex = vec![usize::MAX; mesh.nodes.len()];
        nodes.iter().enumerate().for_each(|(i, &v)| vertex[v] = i);
        Ok(Topology { vertex, nodes })
    }

    /// MFEM vertex numbers of a cell's corners.
    fn cell_vertices(&self, cell: &[usize], dim: usize, p: usize) -> Vec<usize> {
        corner_nodes(dim, cell, p).iter().map(|&v| self.vertex[v]).collect()
    }

    /// Fails on a boundary element whose corners are not those of a cell
    /// side (2D: edge, 3D: face), which MFEM's reader would abort on.
    fn check_boundary<const D: usize>(&self, mesh: &CurvedMesh<D>) -> Result<(), MfemError> {
        let sides: Vec<Vec<usize>> = if D == 2 {
            QUAD_EDGES.iter().map(|e| e.to_vec()).collect()
        } else {
            HEX_FACES.iter().map(|f| f.to_vec()).collect()
        };
        let mut known = HashSet::new();
        for cell in &mesh.cells {
            let v = self.cell_vertices(cell, D, mesh.p);
            for side in &sides {
                known.insert(sorted(side.iter().map(|&l| v[l])));
            }
        }
        for (index, b) in mesh.boundary.iter().enumerate() {
            let corners = corner_nodes(D - 1, b.nodes, mesh.p);
            let key = sorted(corners.iter().map(|&v| self.vertex[v]));
            if key.contains(&usize::MAX) || !known.contains(&key) {
                return Err(MfemError::NotASide { index, corners });
            }
        }
        Ok(())
    }
}

/// The items sorted, as a set key.
fn sorted(items: impl Iterator<Item = usize>) -> Vec<usize> {
    let mut v: Vec<usize> = items.collect();
    v.sort_unstable();
    v
}

/// `elements`: `attr geom v0 … v(2^D − 1)`.
fn push_elements<const D: usize>(out: &mut String, mesh: &CurvedMesh<D>, topo: &Topology, attrs: &[i64]) {
    let geom = if D == 2 { SQUARE } else { CUBE };
    let _ = writeln!(out, "elements\n{}", mesh.cells.len());
    for (cell, a) in mesh.cells.iter().zip(attrs) {
        push_element(out, *a, geom, &topo.cell_vertices(cell, D, mesh.p));
    }
    out.push('\n');
}

/// `boundary`: segments (2D) or squares (3D) by their corners; their
/// orientation is MFEM's to fix (`CheckBdrElementOrientation`).
fn push_boundary<const D: usize>(out: &mut String, mesh: &CurvedMesh<D>, topo: &Topology, attrs: &[i64]) {
    let geom = if D == 2 { SEGMENT } else { SQUARE };
    let _ = writeln!(out, "boundary\n{}", mesh.boundary.len());
    for (b, a) in mesh.boundary.iter().zip(attrs) {
        let v: Vec<usize> = corner_nodes(D - 1, b.nodes, mesh.p).iter().map(|&n| topo.vertex[n]).collect();
        push_element(out, *a, geom, &v);
    }
    out.push('\n');
}

/// One line `attr geom v…`.
fn push_element(out: &mut String, attr: i64, geom: u8, vertices: &[usize]) {
    let _ = write!(out, "{attr} {geom}");
    vertices.iter().for_each(|v| {
        let _ = write!(out, " {v}");
    });
    out.push('\n');
}

/// `vertices` with coordinates: the linear mesh.
fn push_vertices<const D: usize>(out: &mut String, mesh: &CurvedMesh<D>, topo: &Topology) {
    let _ = writeln!(out, "vertices\n{}\n{D}", topo.nodes.len());
    for &v in &topo.nodes {
        push_coords(out, &mesh.nodes[v]);
    }
}

/// `vertices` by count only, then the `nodes` grid function.
fn push_nodes<const D: usize>(out: &mut String, mesh: &CurvedMesh<D>, topo: &Topology) {
    let fec = match mesh.spacing {
        Spacing::GaussLobatto => format!("H1_{D}D_P{}", mesh.p),
        Spacing::Equispaced => format!("H1@U_{D}D_P{}", mesh.p),
    };
    let _ = writeln!(out, "vertices\n{}\n\nnodes\nFiniteElementSpace", topo.nodes.len());
    let _ = writeln!(out, "FiniteElementCollection: {fec}\nVDim: {D}\nOrdering: 1\n");
    for v in dof_nodes(mesh, topo) {
        push_coords(out, &mesh.nodes[v]);
    }
}

/// One line of coordinates, with round-trip precision.
fn push_coords<const D: usize>(out: &mut String, x: &[f64; D]) {
    let line: Vec<String> = x.iter().map(|&c| fmt_f64(c)).collect();
    let _ = writeln!(out, "{}", line.join(" "));
}

/// The node of every global DOF, in MFEM's DOF order (module docs).
fn dof_nodes<const D: usize>(mesh: &CurvedMesh<D>, topo: &Topology) -> Vec<usize> {
    let mut dofs = topo.nodes.clone();
    push_edge_dofs(&mut dofs, mesh, topo);
    if D == 3 {
        push_face_dofs(&mut dofs, mesh, topo);
    }
    push_interior_dofs(&mut dofs, mesh);
    dofs
}

/// Each edge's interior nodes on first appearance, from its lower MFEM
/// vertex number to the higher (our 1-D nodes are symmetric, so the k-th
/// node from that end is MFEM's k-th dof in either basis).
fn push_edge_dofs<const D: usize>(dofs: &mut Vec<usize>, mesh: &CurvedMesh<D>, topo: &Topology) {
    let edges: &[[usize; 2]] = if D == 2 { &QUAD_EDGES } else { &HEX_EDGES };
    let p = mesh.p;
    let mut seen = HashSet::new();
    for cell in &mesh.cells {
        let v = topo.cell_vertices(cell, D, p);
        for &[a, b] in edges {
            if !seen.insert((v[a].min(v[b]), v[a].max(v[b]))) {
                continue;
            }
            let (from, to) = if v[a] < v[b] { (a, b) } else { (b, a) };
            let (s, e) = (corner(D, from, p), corner(D, to, p));
            for k in 1..p {
                let q = std::array::from_fn(|d| s[d] + k * e[d] / p - k * s[d] / p);
                dofs.push(cell[tensor(D, q, p)]);
            }
        }
    }
}

/// Each face's interior nodes on first appearance, as its first cell's
/// local face (orientation 0): `(i, j)`, `i` fastest, `i` from face vertex
/// 0 towards 1, `j` from 0 towards 3.
fn push_face_dofs<const D: usize>(dofs: &mut Vec<usize>, mesh: &CurvedMesh<D>, topo: &Topology) {
    let p = mesh.p;
    let mut seen = HashSet::new();
    for cell in &mesh.cells {
        let v = topo.cell_vertices(cell, D, p);
        for f in HEX_FACES {
            if !seen.insert(sorted(f.iter().map(|&l| v[l]))) {
                continue;
            }
            let [o, a, _, b] = f.map(|l| corner(D, l, p));
            for j in 1..p {
                for i in 1..p {
                    // o + i (a − o)/p + j (b − o)/p, each step ±1 on one axis
                    let q = std::array::from_fn(|d| o[d] + i * a[d] / p + j * b[d] / p - (i + j) * o[d] / p);
                    dofs.push(cell[tensor(D, q, p)]);
                }
            }
        }
    }
}

/// Each cell's interior nodes in tensor order, cell by cell.
fn push_interior_dofs<const D: usize>(dofs: &mut Vec<usize>, mesh: &CurvedMesh<D>) {
    let n = mesh.p + 1;
    let interior = |t: usize| (0..D).all(|d| (1..n - 1).contains(&(t / n.pow(d as u32) % n)));
    for cell in &mesh.cells {
        dofs.extend((0..cell.len()).filter(|&t| interior(t)).map(|t| cell[t]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::curved::tests::{bend2, bend3};

    fn quads(p: usize) -> CurvedMesh<2> {
        CurvedMesh::<2>::structured(p, Spacing::Equispaced, [2, 1], bend2).unwrap()
    }

    #[test]
    fn linear_mesh_lists_vertices_with_coordinates() {
        let m = quads(1);
        let text = mfem_string(&m, &[7, 8], &[1, 1, 2, 2, 3, 3]).unwrap();
        assert!(text.starts_with("MFEM mesh v1.0\n\ndimension\n2\n\nelements\n2\n7 3 0 1 4 3\n8 3 1 2 5 4\n"), "{text}");
        assert!(text.contains("boundary\n6\n"));
        assert!(text.contains("vertices\n6\n2\n0 0\n"), "{text}");
        assert!(!text.contains("nodes"));
    }

    #[test]
    fn dofs_are_vertices_edges_interiors_once_each() {
        for p in 2..=4 {
            let m = quads(p);
            let topo = Topology::new(&m).unwrap();
            let dofs = dof_nodes(&m, &topo);
            // every node exactly once: 6 vertices, 7 edges, 2 interiors
            assert_eq!(dofs.len(), m.nodes.len());
            assert_eq!(sorted(dofs.iter().copied()), (0..m.nodes.len()).collect::<Vec<_>>());
            let h = CurvedMesh::<3>::structured(p, Spacing::GaussLobatto, [2, 1, 2], bend3).unwrap();
            let topo = Topology::new(&h).unwrap();
            let dofs = dof_nodes(&h, &topo);
            assert_eq!(sorted(dofs.iter().copied()), (0..h.nodes.len()).collect::<Vec<_>>());
        }
    }

    #[test]
    fn edge_dofs_run_from_the_lower_vertex() {
        // one p = 3 quad (nodes i + 4 j): corners 0 3 15 12 become MFEM
        // vertices 0 1 3 2 (numbered by node index), so edge (2,3) and edge
        // (3,0) run against the element's loop
        let m = CurvedMesh::<2>::structured(3, Spacing::Equispaced, [1, 1], |x| x).unwrap();
        let topo = Topology::new(&m).unwrap();
        let dofs = dof_nodes(&m, &topo);
        // vertices 0 3 12 15, then edges (0,1): 1 2; (1,2): 7 11; (2,3) from
        // MFEM vertex 2 (node 12) to 3 (node 15): 13 14; (3,0): 4 8
        assert_eq!(dofs, [0, 3, 12, 15, 1, 2, 7, 11, 13, 14, 4, 8, 5, 6, 9, 10]);
    }

    #[test]
    fn rejects_bad_attributes_and_meshes() {
        let m = quads(2);
        let b = [1; 6];
        let err = mfem_string(&m, &[1], &b).unwrap_err();
        assert!(matches!(err, MfemError::AttributeCount { expected: 2, found: 1, .. }), "{err}");
        let err = mfem_string(&m, &[1, 0], &b).unwrap_err();
        assert_eq!(err.to_string(), "cell 1 has attribute 0; MFEM attributes must be in 1..=2147483647");
        let err = mfem_string(&m, &[1, 1], &[1, 1, 1, -3, 1, 1]).unwrap_err();
        assert!(matches!(err, MfemError::BadAttribute { index: 3, value: -3, .. }), "{err}");
        assert!(mfem_string(&m, &[1, 1 << 31], &b).is_err());
        let mut bad = m.clone();
        bad.cells[0][2] = bad.cells[0][0];
        assert!(matches!(mfem_string(&bad, &[1, 1], &b), Err(MfemError::RepeatedCorner { cell: 0 })));
        let mut bad = m.clone();
        bad.boundary.nodes_mut(0)[2] = bad.cells[1][8];
        assert!(matches!(mfem_string(&bad, &[1, 1], &b), Err(MfemError::NotASide { index: 0, .. })));
        let mut bad = m;
        bad.p = 5;
        assert!(matches!(mfem_string(&bad, &[1, 1], &b), Err(MfemError::InvalidMesh(_))));
    }

    /// Triangles among quads are refused, named, before anything is
    /// written: the quad node order would scramble them.
    #[test]
    fn a_mixed_mesh_is_refused_naming_its_triangles() {
        let dir = tempfile::tempdir().unwrap();
        for p in [1, 2, 3] {
            let m = crate::io::layout::tests::mixed2(p);
            let err = mfem_string(&m, &[1; 4], &[1; 8]).unwrap_err();
            assert!(matches!(err, MfemError::Shape(crate::mesh::element::Shape::Triangle)), "p = {p}: {err}");
            assert!(err.to_string().contains("not Triangles"), "{err}");
            let path = dir.path().join("mixed.mesh");
            assert!(write_mfem(&path, &m, &[1; 4], &[1; 8]).is_err() && !path.exists());
        }
    }
}
