//! ABAQUS `.inp` in the form HOHQMesh writes for Trixi.jl's `P4estMesh`:
//! the linear mesh (corner nodes, `CPS4` quads or `C3D8` hexes) that
//! p4est and any ABAQUS reader see, followed by HOHQMesh's comment block
//! (`** `) with the high-order side geometry and the boundary names that
//! Trixi.jl reads.
//!
//! The layout, from HOHQMesh `Source/IO/MeshOutputMethods.f90`
//! (`WriteABAQUSMeshFile`) and `Source/3DSource/Mesh3DOutputMethods.f90`
//! (`WriteABAQUSHexMeshFile`), as Trixi.jl's `src/meshes/p4est_mesh.jl`
//! reads it (`P4estMesh{NDIMS}(meshfile)`,
//! `p4est_connectivity_from_hohqmesh_abaqus`, `calc_tree_node_coordinates!`):
//!
//! ```text
//! *Heading
//!  File created by HOHQMesh                 (leading space: Trixi compares the line exactly)
//! *NODE
//! 1, x, y, z                                (corner nodes only, numbered 1..M; z = 0 in 2D)
//! *ELEMENT, type=CPS4, ELSET=Surface1       (3D: *ELEMENT, type=C3D8, ELSET=Volume1)
//! 1, c1, c2, c3, c4                         (3D: 8 corners)
//! ** ***** HOHQMesh boundary information ***** **
//! ** mesh polynomial degree = N
//! per element:
//! **  c1 c2 c3 c4                           (the corners again)
//! **  f1 f2 f3 f4                           (3D: six flags) 1 = side geometry follows
//! **  x y z                                 ((N+1) lines per flagged edge, (N+1)² per face)
//! per element:
//! ** name(-x) name(+x) name(-y) name(+y)    (3D: -x +x -y +y -z +z), "---" = interior
//! ```
//!
//! Conventions (reference cell `[-1,1]^d`, axes ξ, η, ζ):
//! - Corners: the bilinear/trilinear order, counter-clockwise from
//!   (−1,−1): (−,−), (+,−), (+,+), (−,+); in 3D the same at ζ = −1, then
//!   at ζ = +1. Elements must be right-handed; a cell of ours whose map
//!   has det J < 0 (at the centre) is written with its first two reference
//!   axes exchanged.
//! - Sides in HOHQMesh's order: 2D 1 = −y (η = −1, along ξ), 2 = +x
//!   (ξ = +1, along η), 3 = +y (η = +1, along ξ), 4 = −x (ξ = −1, along
//!   η). 3D 1 = −y (η = −1, over (ξ, ζ)), 2 = +y, 3 = −z (ζ = −1, over
//!   (ξ, η)), 4 = +x (ξ = +1, over (η, ζ)), 5 = +z, 6 = −x; a face's
//!   points are listed with its first parameter fastest.
//! - The side points are the Chebyshev–Gauss–Lobatto nodes
//!   `−cos(π j / N)`, `j = 0..N`, which Trixi interpolates with a Lagrange
//!   polynomial of degree `N`. We write `N = p` and evaluate our order-`p`
//!   element map there, so the side geometry is kept exactly.
//! - Names: HOHQMesh's `bndyNameRemap` reorders the sides to p4est's face
//!   order, −x +x −y +y (−z +z).
//!
//! Which sides are flagged: Trixi rebuilds an element from its sides by
//! transfinite interpolation. An element all of whose sides are straight
//! (2D) or bilinear (3D) is written with all flags 0 and Trixi uses its
//! corners. If any side is curved, all its sides are flagged and written:
//! Trixi's fill-in for the unflagged sides of a curved element pairs
//! corners that do not bound the side (2D sides −y and +y, 3D face +x, in
//! `calc_tree_node_coordinates!` / `get_vertices_for_bilinear_interpolant!`),
//! and writing every side leaves nothing to that code.
//!
//! The interior of an element is not part of the format: what Trixi
//! rebuilds is the transfinite interpolant of the sides, which equals our
//! element map only where that map is such an interpolant.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::io::fmt_f64;
use crate::mesh::element::basis::{det, tensor_map, Basis1d};
use crate::mesh::element::Shape;
use crate::mesh::file::write_atomic;
use crate::mesh::CurvedMesh;

/// The name HOHQMesh writes for a side with no boundary.
pub const INTERIOR: &str = "---";

/// Why a mesh cannot be written as HOHQMesh ABAQUS.
#[derive(Debug, Error)]
pub enum AbaqusError {
    /// The mesh fails [`CurvedMesh::validate`].
    #[error("invalid mesh: {0}")]
    InvalidMesh(String),
    /// Cells the HOHQMesh/Trixi form has no place for: it holds quads and
    /// hexes only.
    #[error("the ABAQUS form of HOHQMesh and Trixi.jl holds quads and hexes only, not {0:?}s")]
    Shape(crate::mesh::element::Shape),
    /// A cell whose map is degenerate (or not finite) at its centre: it
    /// has no orientation to write.
    #[error("cell {cell} is degenerate: det J = {det:e} at its centre")]
    DegenerateCell {
        /// The cell.
        cell: usize,
        /// Its det J at the reference centre.
        det: f64,
    },
    /// A cell whose corners are not distinct nodes.
    #[error("cell {cell} uses node {node} as more than one corner")]
    RepeatedCorner {
        /// The cell.
        cell: usize,
        /// The node.
        node: usize,
    },
    /// A boundary element whose corners are those of no cell side.
    #[error("boundary element {boundary} (part {part:?}) lies on no cell side")]
    UnmatchedBoundary {
        /// The boundary element.
        boundary: usize,
        /// Its part name.
        part: String,
    },
    /// A boundary element with the corners of a cell side but other nodes.
    #[error("boundary element {boundary} has the corners of side {side} of cell {cell} but not all its nodes")]
    NonConforming {
        /// The boundary element.
        boundary: usize,
        /// The cell.
        cell: usize,
        /// The side, in HOHQMesh's numbering (1-based).
        side: usize,
    },
    /// Two boundary elements on the same side.
    #[error("boundary elements {first} and {second} lie on the same cell side")]
    DuplicateBoundary {
        /// One boundary element.
        first: usize,
        /// The other.
        second: usize,
    },
    /// A side shared by more than two cells.
    #[error("side {side} of cell {cell} is shared by {count} cells")]
    NonManifold {
        /// One of the cells.
        cell: usize,
        /// Its side, in HOHQMesh's numbering (1-based).
        side: usize,
        /// How many cells have that side.
        count: usize,
    },
    /// A side on the mesh boundary that no boundary element names: Trixi
    /// would need a boundary condition for a side without a name.
    #[error("side {side} of cell {cell} lies on the mesh boundary but no boundary element covers it")]
    UntaggedSide {
        /// The cell.
        cell: usize,
        /// The side, in HOHQMesh's numbering (1-based).
        side: usize,
    },
    /// A part name that is not one whitespace-free word other than `---`
    /// (Trixi splits the name lines at whitespace).
    #[error("part name {0:?} cannot be written: it must be one word without whitespace, not \"---\"")]
    BadPartName(String),
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

/// One side of the reference cell: the axis it is normal to, the end
/// (0 or 1 in our `[0,1]` cell), and the axes it is parametrised by, first
/// parameter first.
struct Side {
    axis: usize,
    end: usize,
    params: &'static [usize],
}

/// HOHQMesh's 2D sides 1..4: −y, +x, +y, −x.
const SIDES_2D: [Side; 4] = [
    Side { axis: 1, end: 0, params: &[0] },
    Side { axis: 0, end: 1, params: &[1] },
    Side { axis: 1, end: 1, params: &[0] },
    Side { axis: 0, end: 0, params: &[1] },
];

/// HOHQMesh's 3D faces 1..6: −y, +y, −z, +x, +z, −x.
const SIDES_3D: [Side; 6] = [
    Side { axis: 1, end: 0, params: &[0, 2] },
    Side { axis: 1, end: 1, params: &[0, 2] },
    Side { axis: 2, end: 0, params: &[0, 1] },
    Side { axis: 0, end: 1, params: &[1, 2] },
    Side { axis: 2, end: 1, params: &[0, 1] },
    Side { axis: 0, end: 0, params: &[1, 2] },
];

/// HOHQMesh's `bndyNameRemap` (0-based): the sides in p4est's order
/// −x +x −y +y (−z +z).
const NAME_ORDER_2D: [usize; 4] = [3, 1, 0, 2];
const NAME_ORDER_3D: [usize; 6] = [5, 3, 0, 1, 2, 4];

fn sides<const D: usize>() -> &'static [Side] {
    if D == 2 {
        &SIDES_2D
    } else {
        &SIDES_3D
    }
}

/// The corner tensor indices in ABAQUS/HOHQMesh order, each index 0 or 1.
fn corner_digits<const D: usize>() -> Vec<[usize; D]> {
    let quad = [[0, 0], [1, 0], [1, 1], [0, 1]];
    let layers = if D == 2 { 1 } else { 2 };
    (0..layers)
        .flat_map(|k| {
            quad.iter().map(move |q| {
                std::array::from_fn(|d| if d < 2 { q[d] } else { k })
            })
        })
        .collect()
}

/// A cell as it is written: its node vector and whether its first two
/// reference axes are exchanged.
struct Cell<'a> {
    nodes: &'a [usize],
    swap: bool,
    n: usize,
}

impl Cell<'_> {
    /// Position in the cell's node vector of the written tensor index.
    fn at<const D: usize>(&self, idx: [usize; D]) -> usize {
        let mut own = idx;
        if self.swap {
            own.swap(0, 1);
        }
        (0..D).rev().fold(0, |acc, d| acc * self.n + own[d])
    }

    /// Our reference point for a written one.
    fn reference<const D: usize>(&self, xi: [f64; D]) -> [f64; D] {
        let mut own = xi;
        if self.swap {
            own.swap(0, 1);
        }
        own
    }

    /// The node of the written tensor index.
    fn node<const D: usize>(&self, idx: [usize; D]) -> usize {
        self.nodes[self.at(idx)]
    }
}

/// The Chebyshev–Gauss–Lobatto nodes `−cos(π j / N)` mapped to `[0,1]`:
/// the lower half computed, the upper half `1 − t`, ½ (N even), 0 and 1
/// exact.
fn cgl_01(n: usize) -> Vec<f64> {
    let mut t = vec![0.5; n + 1];
    for j in 0..=n {
        if 2 * j < n {
            t[j] = 0.5 * (1.0 - (std::f64::consts::PI * j as f64 / n as f64).cos());
            t[n - j] = 1.0 - t[j];
        }
    }
    t
}

/// The sorted node list, used as a key for a side.
fn key(mut nodes: Vec<usize>) -> Vec<usize> {
    nodes.sort_unstable();
    nodes
}

/// The mesh as HOHQMesh-style ABAQUS text for Trixi.jl's `P4estMesh`
/// (layout and conventions in the [module docs](self)). Fails if the mesh
/// fails [`CurvedMesh::validate`], has a degenerate cell, a boundary
/// element on no cell side (or two on one), a mesh-boundary side without a
/// boundary element, part names that are not single words, or
/// triangles or tetrahedra, alone or among quads ([`AbaqusError::Shape`]).
pub fn abaqus_string<const D: usize>(mesh: &CurvedMesh<D>) -> Result<String, AbaqusError> {
    mesh.validate().map_err(AbaqusError::InvalidMesh)?;
    // any cell of another kind, not just the first (a mixed mesh would
    // have its triangles, prisms or pyramids written as quads or hexes)
    if let Some(shape) = mesh.shapes().into_iter().find(|s| !matches!(s, Shape::Quadrilateral | Shape::Hexahedron)) {
        return Err(AbaqusError::Shape(shape));
    }
    for name in &mesh.part_names {
        if name == INTERIOR || name.chars().any(char::is_whitespace) {
            return Err(AbaqusError::BadPartName(name.clone()));
        }
    }
    let p = mesh.p;
    let n = p + 1;
    let basis = Basis1d::new(p, mesh.spacing).map_err(|e| AbaqusError::InvalidMesh(e.to_string()))?;
    let sides = sides::<D>();
    let corners = corner_digits::<D>();

    // orientation of each cell
    let mut cells = Vec::with_capacity(mesh.cells.len());
    for (c, nodes) in mesh.cells.iter().enumerate() {
        let ctrl: Vec<[f64; D]> = nodes.iter().map(|&v| mesh.nodes[v]).collect();
        let (_, jac) = tensor_map(&basis, &ctrl, [0.5; D]);
        let dj = det(&jac);
        if !dj.is_finite() || dj == 0.0 {
            return Err(AbaqusError::DegenerateCell { cell: c, det: dj });
        }
        let cell = Cell { nodes, swap: dj < 0.0, n };
        let mut seen: Vec<usize> = Vec::with_capacity(corners.len());
        for digits in &corners {
            let v = cell.node(digits.map(|b| b * p));
            if seen.contains(&v) {
                return Err(AbaqusError::RepeatedCorner { cell: c, node: v });
            }
            seen.push(v);
        }
        cells.push(cell);
    }

    // the tensor indices of each side's nodes, and of its corners
    let side_nodes = |cell: &Cell, s: &Side, corners_only: bool| -> Vec<usize> {
        let steps: Vec<usize> = if corners_only { vec![0, p] } else { (0..n).collect() };
        let m = steps.len();
        (0..m.pow(s.params.len() as u32))
            .map(|a| {
                let mut idx = [0usize; D];
                idx[s.axis] = s.end * p;
                let mut rest = a;
                for &d in s.params {
                    idx[d] = steps[rest % m];
                    rest /= m;
                }
                cell.node(idx)
            })
            .collect()
    };

    // which cells have each side (by its corner set)
    let mut by_corners: HashMap<Vec<usize>, Vec<(usize, usize)>> = HashMap::new();
    for (c, cell) in cells.iter().enumerate() {
        for (k, s) in sides.iter().enumerate() {
            by_corners.entry(key(side_nodes(cell, s, true))).or_default().push((c, k));
        }
    }
    for list in by_corners.values() {
        if list.len() > 2 {
            let (cell, side) = list[0];
            return Err(AbaqusError::NonManifold { cell, side: side + 1, count: list.len() });
        }
    }

    // the boundary element on each cell side
    let mut names: Vec<Vec<Option<usize>>> = vec![vec![None; sides.len()]; cells.len()];
    for (b, be) in mesh.boundary.iter().enumerate() {
        let q = p + 1;
        let corner_pos: Vec<usize> = if D == 2 { vec![0, p] } else { vec![0, p, q * p, q * q - 1] };
        let ck = key(corner_pos.iter().map(|&i| be.nodes[i]).collect());
        let Some(list) = by_corners.get(&ck) else {
            return Err(AbaqusError::UnmatchedBoundary { boundary: b, part: mesh.part_names[be.part].clone() });
        };
        for &(c, k) in list {
            if key(side_nodes(&cells[c], &sides[k], false)) != key(be.nodes.to_vec()) {
                return Err(AbaqusError::NonConforming { boundary: b, cell: c, side: k + 1 });
            }
            if let Some(first) = names[c][k].replace(b) {
                return Err(AbaqusError::DuplicateBoundary { first, second: b });
            }
        }
    }
    for list in by_corners.values() {
        if let [(c, k)] = list[..] {
            if names[c][k].is_none() {
                return Err(AbaqusError::UntaggedSide { cell: c, side: k + 1 });
            }
        }
    }

    // corner nodes, numbered 1.. in the order of our node indices
    let mut number = vec![0usize; mesh.nodes.len()];
    for cell in &cells {
        for digits in &corners {
            number[cell.node(digits.map(|b| b * p))] = 1;
        }
    }
    let mut out = String::from("*Heading\n File created by HOHQMesh\n*NODE\n");
    let mut next = 0;
    for (v, slot) in number.iter_mut().enumerate() {
        if *slot != 0 {
            next += 1;
            *slot = next;
            let x = mesh.nodes[v];
            let z = if D == 3 { x[2] } else { 0.0 };
            put!(out, "{next}, {}, {}, {}", fmt_f64(x[0]), fmt_f64(x[1]), fmt_f64(z));
        }
    }
    let corner_ids = |cell: &Cell, sep: &str| -> String {
        corners.iter().map(|d| number[cell.node(d.map(|b| b * p))].to_string()).collect::<Vec<_>>().join(sep)
    };
    if D == 2 {
        out.push_str("*ELEMENT, type=CPS4, ELSET=Surface1\n");
    } else {
        out.push_str("*ELEMENT, type=C3D8, ELSET=Volume1\n");
    }
    for (e, cell) in cells.iter().enumerate() {
        put!(out, "{}, {}", e + 1, corner_ids(cell, ", "));
    }

    put!(out, "** ***** HOHQMesh boundary information ***** **");
    put!(out, "** mesh polynomial degree = {p}");
    let t = cgl_01(p);
    for cell in &cells {
        let ctrl: Vec<[f64; D]> = cell.nodes.iter().map(|&v| mesh.nodes[v]).collect();
        let corner_x: Vec<[f64; D]> = corners.iter().map(|d| mesh.nodes[cell.node(d.map(|b| b * p))]).collect();
        let size = bbox_diagonal(&ctrl);
        let samples: Vec<Vec<[f64; D]>> = sides.iter().map(|s| side_samples(&basis, cell, &ctrl, s, &t)).collect();
        let curved = sides
            .iter()
            .zip(&samples)
            .any(|(s, xs)| !is_multilinear::<D>(s, xs, &t, &corner_x, size));
        put!(out, "**  {}", corner_ids(cell, " "));
        let flag = if curved { "1" } else { "0" };
        put!(out, "**  {}", vec![flag; sides.len()].join(" "));
        if curved {
            for xs in &samples {
                for x in xs {
                    let z = if D == 3 { x[2] } else { 0.0 };
                    put!(out, "**  {} {} {}", fmt_f64(x[0]), fmt_f64(x[1]), fmt_f64(z));
                }
            }
        }
    }
    let order: &[usize] = if D == 2 { &NAME_ORDER_2D } else { &NAME_ORDER_3D };
    for row in &names {
        let line: Vec<&str> = order
            .iter()
            .map(|&k| row[k].map_or(INTERIOR, |b| mesh.part_names[mesh.boundary.parts()[b]].as_str()))
            .collect();
        put!(out, "** {} ", line.join(" "));
    }
    Ok(out)
}

/// Writes [`abaqus_string`] atomically to `path`; nothing is written if
/// the mesh is rejected.
pub fn write_abaqus<const D: usize>(path: &Path, mesh: &CurvedMesh<D>) -> Result<(), AbaqusError> {
    let text = abaqus_string(mesh)?;
    write_atomic(path, text.as_bytes()).map_err(|source| AbaqusError::Io { path: path.to_owned(), source })
}

/// The element map on side `s` at the CGL points, first parameter fastest.
fn side_samples<const D: usize>(basis: &Basis1d, cell: &Cell, ctrl: &[[f64; D]], s: &Side, t: &[f64]) -> Vec<[f64; D]> {
    let m = t.len();
    (0..m.pow(s.params.len() as u32))
        .map(|a| {
            let mut xi = [0.0; D];
            xi[s.axis] = s.end as f64;
            let mut rest = a;
            for &d in s.params {
                xi[d] = t[rest % m];
                rest /= m;
            }
            tensor_map(basis, ctrl, cell.reference(xi)).0
        })
        .collect()
}

/// Whether the samples of side `s` are those of the (bi)linear map of its
/// corners, to `1e-12` of the cell size.
fn is_multilinear<const D: usize>(s: &Side, xs: &[[f64; D]], t: &[f64], corner_x: &[[f64; D]], size: f64) -> bool {
    let corners = corner_digits::<D>();
    let m = t.len();
    xs.iter().enumerate().all(|(a, x)| {
        let mut xi = [0.0; D];
        xi[s.axis] = s.end as f64;
        let mut rest = a;
        for &d in s.params {
            xi[d] = t[rest % m];
            rest /= m;
        }
        // the multilinear map of the cell corners, on the side
        let mut lin = [0.0; D];
        for (digits, c) in corners.iter().zip(corner_x) {
            let w: f64 = (0..D).map(|d| if digits[d] == 1 { xi[d] } else { 1.0 - xi[d] }).product();
            for r in 0..D {
                lin[r] += w * c[r];
            }
        }
        (0..D).all(|r| (x[r] - lin[r]).abs() <= 1e-12 * size)
    })
}

/// The diagonal of the points' bounding box.
fn bbox_diagonal<const D: usize>(xs: &[[f64; D]]) -> f64 {
    (0..D)
        .map(|d| {
            let lo = xs.iter().map(|x| x[d]).fold(f64::INFINITY, f64::min);
            let hi = xs.iter().map(|x| x[d]).fold(f64::NEG_INFINITY, f64::max);
            (hi - lo).powi(2)
        })
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::element::Spacing;

    #[test]
    fn cgl_nodes_are_symmetric_with_exact_ends() {
        for n in 1..=4 {
            let t = cgl_01(n);
            assert_eq!((t[0], t[n]), (0.0, 1.0));
            for j in 0..=n {
                if 2 * j < n {
                    assert_eq!(t[n - j], 1.0 - t[j]);
                }
                let want = 0.5 * (1.0 - (std::f64::consts::PI * j as f64 / n as f64).cos());
                assert!((t[j] - want).abs() < 1e-15);
            }
        }
        assert_eq!(cgl_01(2)[1], 0.5);
    }

    #[test]
    fn straight_mesh_has_no_curved_sides_and_bent_one_has_all() {
        let flat = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [2, 1], |[x, y]| [2.0 * x, y + 0.5 * x]).unwrap();
        let s = abaqus_string(&flat).unwrap();
        assert!(s.lines().filter(|l| *l == "**  0 0 0 0").count() == 2, "{s}");
        let bent = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [2, 1], |[x, y]| [x, y + 0.3 * x * x]).unwrap();
        let s = abaqus_string(&bent).unwrap();
        assert!(s.lines().filter(|l| *l == "**  1 1 1 1").count() == 2, "{s}");
    }

    /// Triangles among quads are refused, named: the HOHQMesh form has no
    /// place for them.
    #[test]
    fn a_mixed_mesh_is_refused_naming_its_triangles() {
        let dir = tempfile::tempdir().unwrap();
        for p in [1, 2, 3] {
            let m = crate::io::layout::tests::mixed2(p);
            let err = abaqus_string(&m).unwrap_err();
            assert!(matches!(err, AbaqusError::Shape(crate::mesh::element::Shape::Triangle)), "p = {p}: {err}");
            assert!(err.to_string().contains("not Triangles"), "{err}");
            let path = dir.path().join("mixed.inp");
            assert!(write_abaqus(&path, &m).is_err() && !path.exists());
        }
    }

    #[test]
    fn rejects_untagged_sides_and_bad_names() {
        let mut m = CurvedMesh::<2>::structured(1, Spacing::Equispaced, [2, 1], |x| x).unwrap();
        m.part_names[0] = "has space".into();
        assert!(matches!(abaqus_string(&m), Err(AbaqusError::BadPartName(_))));
        let mut m = CurvedMesh::<2>::structured(1, Spacing::Equispaced, [2, 1], |x| x).unwrap();
        m.boundary = m.boundary.iter().take(m.boundary.len() - 1).map(|f| (f.shape, f.nodes, f.part)).collect();
        assert!(matches!(abaqus_string(&m), Err(AbaqusError::UntaggedSide { .. })));
        let mut m = CurvedMesh::<3>::structured(1, Spacing::Equispaced, [1, 1, 1], |x| x).unwrap();
        let dup = m.boundary.get(0);
        let (shape, nodes, part) = (dup.shape, dup.nodes.to_vec(), dup.part);
        m.boundary.push(shape, &nodes, part);
        assert!(matches!(abaqus_string(&m), Err(AbaqusError::DuplicateBoundary { .. })));
        let mut m = CurvedMesh::<2>::structured(1, Spacing::Equispaced, [1, 1], |x| x).unwrap();
        m.nodes.push([5.0, 5.0]);
        m.boundary.nodes_mut(0)[1] = 4;
        assert!(matches!(abaqus_string(&m), Err(AbaqusError::UnmatchedBoundary { .. })));
        let m = CurvedMesh::<2>::structured(1, Spacing::Equispaced, [1, 1], |[x, _]| [x, 0.0]).unwrap();
        assert!(matches!(abaqus_string(&m), Err(AbaqusError::DegenerateCell { .. })));
    }
}
