//! Curved (high-order Lagrange) quad and hex meshes: Gmsh MSH 4.1 ASCII
//! writer and reader, and a VTK XML writer with Lagrange cells.
//!
//! Inside the crate every element keeps its nodes in *tensor order*
//! ([`crate::highorder`] docs); the writers permute them into each format's
//! order ([`gmsh_quad_order`], [`gmsh_hex_order`], [`gmsh_line_order`],
//! [`vtk_quad_order`], [`vtk_hex_order`]) and the reader permutes back.
//!
//! Both formats interpolate through *equispaced* nodes. A mesh with
//! [`Spacing::GaussLobatto`] nodes is first resampled
//! ([`CurvedMesh::to_equispaced`]): every node is moved to where the
//! element's own map puts the equispaced node with the same tensor index.
//! The connectivity does not change, and because both node sets are
//! symmetric an edge or face node shared by two cells gets the same point
//! (up to rounding) from either cell.
//!
//! MSH layout (as [`super::msh`] for linear meshes): the physical groups
//! `1..=k` of the boundary dimension named after the parts, one entity per
//! part, then the group [`DOMAIN_NAME`] on the single entity of the mesh
//! dimension, which holds all nodes. Element tags: boundary element `i`
//! gets `i + 1`, cell `c` gets `boundary.len() + c + 1`.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use super::msh::{MshError, DOMAIN_NAME};
use super::vtu::VtuError;
use super::{fmt_f64, write_atomic};
use crate::highorder::basis::{tensor_map, Basis1d};
use crate::highorder::{
    check_order, from_format, gmsh_hex_order, gmsh_line_order, gmsh_quad_order, nodes_1d,
    to_format, vtk_hex_order, vtk_quad_order, Spacing, MAX_ORDER,
};

/// VTK's cell type of a Lagrange quadrilateral.
pub const VTK_LAGRANGE_QUADRILATERAL: u8 = 70;

/// VTK's cell type of a Lagrange hexahedron.
pub const VTK_LAGRANGE_HEXAHEDRON: u8 = 72;

/// MSH element types of lines of order 1..=4 (index `p − 1`).
pub const MSH_LINE_TYPES: [i64; 4] = [1, 8, 26, 27];
/// MSH element types of quads of order 1..=4: QUA_4, QUA_9, QUA_16, QUA_25.
pub const MSH_QUAD_TYPES: [i64; 4] = [3, 10, 36, 37];
/// MSH element types of hexes of order 1..=4: HEX_8, HEX_27, HEX_64, HEX_125.
pub const MSH_HEX_TYPES: [i64; 4] = [5, 12, 92, 93];

/// One boundary element: an order-`p` line (2D meshes) or quad (3D
/// meshes) with its nodes in tensor order, and its part.
#[derive(Clone, Debug, PartialEq)]
pub struct CurvedBoundary {
    /// `p + 1` (line) or `(p+1)²` (quad) node indices in tensor order. The
    /// orientation is kept as given (2D convention: domain on the left).
    pub nodes: Vec<usize>,
    /// Index into [`CurvedMesh::part_names`].
    pub part: usize,
}

/// A mesh of order-`p` Lagrange quads (`D = 2`) or hexes (`D = 3`).
#[derive(Clone, Debug, PartialEq)]
pub struct CurvedMesh<const D: usize> {
    /// Element order, `1..=4`.
    pub p: usize,
    /// Where the element nodes sit in the reference cell.
    pub spacing: Spacing,
    /// Node coordinates.
    pub nodes: Vec<[f64; D]>,
    /// Cells, `(p+1)^D` node indices each, in tensor order.
    pub cells: Vec<Vec<usize>>,
    /// Boundary elements (dimension `D − 1`) with their parts.
    pub boundary: Vec<CurvedBoundary>,
    /// Names of the boundary parts (physical groups of dimension `D − 1`).
    pub part_names: Vec<String>,
}

impl<const D: usize> CurvedMesh<D> {
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
    ) -> Result<CurvedMesh<D>, crate::highorder::HighOrderError> {
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
        let cells = (0..ncells)
            .map(|c| block(cell_index(c).map(|i| i * p), &all_axes))
            .collect();
        let mut boundary = Vec::new();
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
                    boundary.push(CurvedBoundary {
                        nodes,
                        part: 2 * d + side,
                    });
                }
            }
        }
        let names = ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"];
        Ok(CurvedMesh {
            p,
            spacing,
            nodes,
            cells,
            boundary,
            part_names: names[..2 * D].iter().map(|s| s.to_string()).collect(),
        })
    }

    /// Number of nodes of a cell, `(p+1)^D`.
    pub fn nodes_per_cell(&self) -> usize {
        (self.p + 1).pow(D as u32)
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
        let per_cell = self.nodes_per_cell();
        for (c, cell) in self.cells.iter().enumerate() {
            if cell.len() != per_cell {
                return Err(format!(
                    "cell {c} has {} nodes, expected {per_cell}",
                    cell.len()
                ));
            }
            if cell.iter().any(|&v| v >= n) {
                return Err(format!("cell {c} refers to a node >= {n}"));
            }
        }
        let per_face = (self.p + 1).pow(D as u32 - 1);
        for (e, b) in self.boundary.iter().enumerate() {
            if b.nodes.len() != per_face || b.nodes.iter().any(|&v| v >= n) {
                return Err(format!(
                    "boundary element {e} needs {per_face} nodes < {n}, has {:?}",
                    b.nodes
                ));
            }
            if b.part >= self.part_names.len() {
                return Err(format!(
                    "boundary element {e} has part {} of {}",
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
        let basis = Basis1d::new(self.p, self.spacing).expect("order checked by validate");
        let t = nodes_1d(self.p, Spacing::Equispaced).expect("order checked by validate");
        let n = self.p + 1;
        let mut done = vec![false; self.nodes.len()];
        for cell in &self.cells {
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

    /// Gmsh's local order of a cell and of a boundary element.
    fn gmsh_orders(&self) -> (Vec<usize>, Vec<usize>) {
        let p = self.p;
        let ok = "order checked by validate";
        if D == 2 {
            (gmsh_quad_order(p).expect(ok), gmsh_line_order(p).expect(ok))
        } else {
            (gmsh_hex_order(p).expect(ok), gmsh_quad_order(p).expect(ok))
        }
    }

    /// The mesh as MSH 4.1 ASCII text (layout in the module docs), after
    /// resampling to equispaced nodes. Fails as [`CurvedMesh::validate`].
    pub fn msh_string(&self) -> Result<String, MshError> {
        self.validate().map_err(MshError::InvalidMesh)?;
        let mesh = self.to_equispaced();
        Ok(mesh.msh_text())
    }

    /// Writes [`CurvedMesh::msh_string`] atomically to `path`; nothing is
    /// written if the mesh is rejected.
    pub fn write_msh(&self, path: &Path) -> Result<(), MshError> {
        let text = self.msh_string()?;
        write_atomic(path, text.as_bytes()).map_err(|source| MshError::Io {
            path: path.to_owned(),
            source,
        })
    }

    /// The text of an equispaced, valid mesh.
    fn msh_text(&self) -> String {
        let (k, d, p) = (self.part_names.len(), D, self.p);
        let mut out = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
        put!(out, "$PhysicalNames\n{}", k + 1);
        for (i, name) in self.part_names.iter().enumerate() {
            put!(out, "{} {} \"{name}\"", d - 1, i + 1);
        }
        put!(out, "{d} {} \"{DOMAIN_NAME}\"\n$EndPhysicalNames", k + 1);

        // entities: one per part of dimension d-1, one of dimension d
        let mut counts = [0; 4];
        counts[d - 1] = k;
        counts[d] = 1;
        put!(
            out,
            "$Entities\n{} {} {} {}",
            counts[0],
            counts[1],
            counts[2],
            counts[3]
        );
        let mut part_nodes: Vec<Vec<usize>> = vec![Vec::new(); k];
        for b in &self.boundary {
            part_nodes[b.part].extend_from_slice(&b.nodes);
        }
        for (part, nodes) in part_nodes.iter().enumerate() {
            put!(
                out,
                "{} {} 1 {} 0",
                part + 1,
                self.bbox(nodes.iter().copied()),
                part + 1
            );
        }
        let bounding: String = (1..=k).map(|t| format!(" {t}")).collect();
        put!(
            out,
            "1 {} 1 {} {k}{bounding}",
            self.bbox(0..self.nodes.len()),
            k + 1
        );
        out.push_str("$EndEntities\n");

        let n = self.nodes.len();
        let (lo, hi) = if n == 0 { (0, 0) } else { (1, n) };
        put!(out, "$Nodes\n1 {n} {lo} {hi}\n{d} 1 0 {n}");
        for tag in 1..=n {
            put!(out, "{tag}");
        }
        for x in &self.nodes {
            let z = if D == 3 { x[2] } else { 0.0 };
            put!(out, "{} {} {}", fmt_f64(x[0]), fmt_f64(x[1]), fmt_f64(z));
        }
        out.push_str("$EndNodes\n");

        let (cell_perm, face_perm) = self.gmsh_orders();
        let (cell_type, face_type) = if D == 2 {
            (MSH_QUAD_TYPES[p - 1], MSH_LINE_TYPES[p - 1])
        } else {
            (MSH_HEX_TYPES[p - 1], MSH_QUAD_TYPES[p - 1])
        };
        let mut per_part: Vec<Vec<usize>> = vec![Vec::new(); k];
        for (e, b) in self.boundary.iter().enumerate() {
            per_part[b.part].push(e);
        }
        let blocks =
            per_part.iter().filter(|b| !b.is_empty()).count() + usize::from(!self.cells.is_empty());
        let total = self.boundary.len() + self.cells.len();
        let (lo, hi) = if total == 0 { (0, 0) } else { (1, total) };
        put!(out, "$Elements\n{blocks} {total} {lo} {hi}");
        let push = |out: &mut String, tag: usize, nodes: &[usize], perm: &[usize]| {
            let _ = write!(out, "{tag}");
            for v in to_format(perm, nodes) {
                let _ = write!(out, " {}", v + 1);
            }
            out.push('\n');
        };
        for (part, elements) in per_part.iter().enumerate().filter(|(_, b)| !b.is_empty()) {
            put!(out, "{} {} {face_type} {}", d - 1, part + 1, elements.len());
            for &e in elements {
                push(&mut out, e + 1, &self.boundary[e].nodes, &face_perm);
            }
        }
        if !self.cells.is_empty() {
            put!(out, "{d} 1 {cell_type} {}", self.cells.len());
            let first = self.boundary.len() + 1;
            for (c, cell) in self.cells.iter().enumerate() {
                push(&mut out, first + c, cell, &cell_perm);
            }
        }
        out.push_str("$EndElements\n");
        out
    }

    /// `minX minY minZ maxX maxY maxZ` of the given nodes (zeros if none).
    fn bbox(&self, nodes: impl Iterator<Item = usize>) -> String {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for x in nodes.filter_map(|v| self.nodes.get(v)) {
            for d in 0..3 {
                let c = x.get(d).copied().unwrap_or(0.0);
                lo[d] = lo[d].min(c);
                hi[d] = hi[d].max(c);
            }
        }
        if lo[0] > hi[0] {
            return "0 0 0 0 0 0".to_string();
        }
        [lo, hi]
            .iter()
            .flatten()
            .map(|&v| fmt_f64(v))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// The cells as a VTK XML UnstructuredGrid (file version 2.2, ASCII) of
    /// Lagrange cells ([`VTK_LAGRANGE_QUADRILATERAL`] or
    /// [`VTK_LAGRANGE_HEXAHEDRON`], VTK ≥ 9 node order), after resampling to
    /// equispaced nodes: Float64 points (z = 0 in 2D), Int64 connectivity
    /// and offsets, UInt8 types, and one Float64 CellData array per
    /// `cell_data` entry. Boundary elements are not written. VTK infers the
    /// order from the number of points per cell.
    pub fn vtu_string(&self, cell_data: &[(&str, &[f64])]) -> Result<String, VtuError> {
        self.validate().map_err(VtuError::Invalid)?;
        for (i, (name, values)) in cell_data.iter().enumerate() {
            if name.is_empty()
                || name.contains(['"', '<', '>', '&'])
                || cell_data[..i].iter().any(|a| a.0 == *name)
            {
                return Err(VtuError::Invalid(format!(
                    "cell array name {name:?} is empty, repeated or not XML-safe"
                )));
            }
            if values.len() != self.cells.len() {
                return Err(VtuError::Length {
                    what: format!("cell array {name:?}"),
                    expected: self.cells.len(),
                    found: values.len(),
                });
            }
            if let Some(index) = values.iter().position(|v| !v.is_finite()) {
                return Err(VtuError::NonFinite {
                    what: format!("cell array {name:?}"),
                    index,
                    value: values[index],
                });
            }
        }
        let mesh = self.to_equispaced();
        let p = self.p;
        let ok = "order checked by validate";
        let (perm, cell_type) = if D == 2 {
            (vtk_quad_order(p).expect(ok), VTK_LAGRANGE_QUADRILATERAL)
        } else {
            (vtk_hex_order(p).expect(ok), VTK_LAGRANGE_HEXAHEDRON)
        };
        let mut out = String::from("<?xml version=\"1.0\"?>\n");
        // Version 2.2 is how a file says "VTK 9 hex edge order": VTK's XML
        // reader renumbers the edges of Lagrange hexes in older files (it
        // swaps the vertical edges 10 and 11, VTK 8's order), which would
        // silently scramble ours.
        out.push_str("<VTKFile type=\"UnstructuredGrid\" version=\"2.2\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<UnstructuredGrid>\n");
        put!(
            out,
            "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
            mesh.nodes.len(),
            mesh.cells.len()
        );
        if !cell_data.is_empty() {
            out.push_str("<CellData>\n");
            for (name, values) in cell_data {
                put!(
                    out,
                    "<DataArray type=\"Float64\" Name=\"{name}\" format=\"ascii\">"
                );
                for v in values.iter() {
                    put!(out, "{}", fmt_f64(*v));
                }
                out.push_str("</DataArray>\n");
            }
            out.push_str("</CellData>\n");
        }
        out.push_str(
            "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n",
        );
        for x in &mesh.nodes {
            let z = if D == 3 { x[2] } else { 0.0 };
            put!(out, "{} {} {}", fmt_f64(x[0]), fmt_f64(x[1]), fmt_f64(z));
        }
        out.push_str("</DataArray>\n</Points>\n<Cells>\n");
        out.push_str("<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
        for cell in &mesh.cells {
            let line: Vec<String> = to_format(&perm, cell)
                .iter()
                .map(|v| v.to_string())
                .collect();
            put!(out, "{}", line.join(" "));
        }
        out.push_str(
            "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n",
        );
        let per = mesh.nodes_per_cell();
        for c in 1..=mesh.cells.len() {
            put!(out, "{}", c * per);
        }
        out.push_str("</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
        for _ in &mesh.cells {
            put!(out, "{cell_type}");
        }
        out.push_str("</DataArray>\n</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
        Ok(out)
    }

    /// Writes [`CurvedMesh::vtu_string`] atomically to `path`; nothing is
    /// written if the input is rejected.
    pub fn write_vtu(&self, path: &Path, cell_data: &[(&str, &[f64])]) -> Result<(), VtuError> {
        let text = self.vtu_string(cell_data)?;
        write_atomic(path, text.as_bytes()).map_err(|source| VtuError::Io {
            path: path.to_owned(),
            source,
        })
    }

    /// Reads an ASCII MSH 4.1 file (see [`CurvedMesh::parse_msh`]).
    pub fn read_msh(path: &Path) -> Result<CurvedMesh<D>, MshError> {
        Self::parse_msh(&super::msh::read_text(path)?)
    }

    /// Parses ASCII MSH 4.1 text with Lagrange quads (`D = 2`: types 3, 10,
    /// 36, 37, boundary lines 1, 8, 26, 27) or hexes (`D = 3`: types 5, 12,
    /// 92, 93, boundary quads 3, 10, 36, 37) of one order into a mesh with
    /// [`Spacing::Equispaced`] nodes in tensor order. Points (type 15) and,
    /// in 3D, lines are skipped; other types, or a boundary element whose
    /// order differs from the cells', are errors. Nodes keep file order
    /// (renumbered from 0), elements are ordered by tag, and boundary parts
    /// are named as in [`super::msh::parse_msh`]: the named physical groups
    /// of dimension `D − 1` by tag, then `curve<tag>` / `surface<tag>`.
    pub fn parse_msh(text: &str) -> Result<CurvedMesh<D>, MshError> {
        let raw = parse_raw(text, D)?;
        raw.into_mesh()
    }

    /// [`CurvedMesh::parse_msh`], with the element tag of every cell in the
    /// file (cell `c` is element `tags[c]`), for messages.
    pub fn parse_msh_tagged(text: &str) -> Result<(CurvedMesh<D>, Vec<u64>), MshError> {
        let raw = parse_raw(text, D)?;
        let mut tags: Vec<u64> = raw.cells.iter().map(|c| c.0).collect();
        tags.sort_unstable();
        Ok((raw.into_mesh()?, tags))
    }
}

// ---------------------------------------------------------------- reading

/// Tokens with their 1-based lines.
struct Tokens<'a> {
    lines: std::iter::Peekable<std::iter::Enumerate<std::str::Lines<'a>>>,
    current: std::str::SplitWhitespace<'a>,
    line: usize,
    last_line: usize,
}

impl<'a> Tokens<'a> {
    fn new(text: &'a str) -> Self {
        Tokens {
            lines: text.lines().enumerate().peekable(),
            current: "".split_whitespace(),
            line: 0,
            last_line: text.lines().count().max(1),
        }
    }

    /// The next token and its line, or `None` at the end.
    fn next(&mut self) -> Option<(&'a str, usize)> {
        loop {
            if let Some(t) = self.current.next() {
                return Some((t, self.line));
            }
            let (i, l) = self.lines.next()?;
            self.line = i + 1;
            self.current = l.split_whitespace();
        }
    }

    /// The rest of the current line's tokens joined by single spaces (for
    /// quoted names; runs of spaces inside a name collapse to one).
    fn rest_of_line(&mut self) -> String {
        let rest: Vec<&str> = self.current.by_ref().collect();
        rest.join(" ")
    }

    fn token(&mut self, expected: &str) -> Result<(&'a str, usize), MshError> {
        self.next().ok_or_else(|| MshError::Truncated {
            line: self.last_line,
            expected: expected.to_string(),
        })
    }

    fn parse<T: std::str::FromStr>(&mut self, expected: &str) -> Result<(T, usize), MshError> {
        let (t, line) = self.token(expected)?;
        t.parse()
            .map(|v| (v, line))
            .map_err(|_| syntax(line, expected, t))
    }

    fn expect(&mut self, word: &str) -> Result<(), MshError> {
        let (t, line) = self.token(word)?;
        if t == word {
            Ok(())
        } else {
            Err(syntax(line, word, t))
        }
    }
}

fn syntax(line: usize, expected: &str, found: &str) -> MshError {
    MshError::Syntax {
        line,
        expected: expected.to_string(),
        found: found.to_string(),
    }
}

/// What the file says, before orders and parts are resolved.
struct Raw {
    dim: usize,
    physical_names: Vec<(usize, i64, String)>,
    entity_physicals: HashMap<(usize, i64), Vec<i64>>,
    node_index: HashMap<u64, usize>,
    nodes: Vec<[f64; 3]>,
    /// `(tag, order, nodes in Gmsh order)`.
    cells: Vec<(u64, usize, Vec<usize>, usize)>,
    /// `(tag, entity, order, nodes in Gmsh order, line)`.
    boundary: Vec<(u64, i64, usize, Vec<usize>, usize)>,
    /// `(line, tag, z)` of the first node off z = 0 (an error in 2D).
    off_plane: Option<(usize, u64, f64)>,
    has_nodes: bool,
    has_elements: bool,
}

/// `(dimension, order, nodes)` of an MSH element type this reader knows.
fn element_kind(t: i64) -> Option<(usize, usize, usize)> {
    let find = |types: &[i64; 4]| types.iter().position(|&x| x == t).map(|i| i + 1);
    if t == 15 {
        return Some((0, 0, 1));
    }
    if let Some(p) = find(&MSH_LINE_TYPES) {
        return Some((1, p, p + 1));
    }
    if let Some(p) = find(&MSH_QUAD_TYPES) {
        return Some((2, p, (p + 1) * (p + 1)));
    }
    find(&MSH_HEX_TYPES).map(|p| (3, p, (p + 1).pow(3)))
}

fn parse_raw(text: &str, dim: usize) -> Result<Raw, MshError> {
    let mut cur = Tokens::new(text);
    cur.expect("$MeshFormat")?;
    let (version, line) = cur.token("the MSH version number")?;
    if version != "4.1" {
        return Err(MshError::UnsupportedVersion {
            line,
            version: version.to_string(),
        });
    }
    let (file_type, line) = cur.token("the file type")?;
    match file_type {
        "0" => {}
        "1" => return Err(MshError::Binary { line }),
        s => return Err(syntax(line, "file type 0 (ASCII)", s)),
    }
    cur.parse::<u64>("the data size")?;
    cur.expect("$EndMeshFormat")?;
    let mut raw = Raw {
        dim,
        physical_names: Vec::new(),
        entity_physicals: HashMap::new(),
        node_index: HashMap::new(),
        nodes: Vec::new(),
        cells: Vec::new(),
        boundary: Vec::new(),
        off_plane: None,
        has_nodes: false,
        has_elements: false,
    };
    while let Some((token, line)) = cur.next() {
        match token {
            "$PhysicalNames" => {
                let n: u64 = cur.parse("the number of physical names")?.0;
                for _ in 0..n {
                    let d: usize = cur.parse("a physical group dimension")?.0;
                    let tag: i64 = cur.parse("a physical group tag")?.0;
                    let (name_line, line) = (cur.rest_of_line(), cur.line);
                    let name = name_line
                        .strip_prefix('"')
                        .and_then(|s| s.strip_suffix('"'))
                        .ok_or_else(|| syntax(line, "a quoted physical name", &name_line))?;
                    raw.physical_names.push((d, tag, name.to_string()));
                }
                cur.expect("$EndPhysicalNames")?;
            }
            "$Entities" => {
                let mut counts = [0u64; 4];
                for c in &mut counts {
                    *c = cur.parse("an entity count")?.0;
                }
                for (d, &count) in counts.iter().enumerate() {
                    for _ in 0..count {
                        let tag: i64 = cur.parse("an entity tag")?.0;
                        for _ in 0..if d == 0 { 3 } else { 6 } {
                            cur.parse::<f64>("an entity coordinate")?;
                        }
                        let np: u64 = cur.parse("the number of physical tags")?.0;
                        let mut phys = Vec::new();
                        for _ in 0..np {
                            phys.push(cur.parse::<i64>("a physical tag")?.0);
                        }
                        if d > 0 {
                            let nb: u64 = cur.parse("the number of bounding entities")?.0;
                            for _ in 0..nb {
                                cur.parse::<i64>("a bounding entity tag")?;
                            }
                        }
                        raw.entity_physicals.insert((d, tag), phys);
                    }
                }
                cur.expect("$EndEntities")?;
            }
            "$Nodes" => read_nodes(&mut cur, &mut raw)?,
            "$Elements" => read_elements(&mut cur, &mut raw)?,
            s if s.starts_with('$') && !s.starts_with("$End") => {
                let end = format!("$End{}", &s[1..]);
                loop {
                    if cur.token(&end)?.0 == end {
                        break;
                    }
                }
            }
            s => return Err(syntax(line, "a section header like `$Nodes`", s)),
        }
    }
    if !raw.has_nodes {
        return Err(MshError::MissingSection("Nodes"));
    }
    if !raw.has_elements {
        return Err(MshError::MissingSection("Elements"));
    }
    Ok(raw)
}

fn read_nodes(cur: &mut Tokens, raw: &mut Raw) -> Result<(), MshError> {
    let blocks: u64 = cur.parse("the number of node blocks")?.0;
    let (total, header_line) = cur.parse::<u64>("the number of nodes")?;
    cur.parse::<u64>("the minimum node tag")?;
    cur.parse::<u64>("the maximum node tag")?;
    let before = raw.nodes.len();
    for _ in 0..blocks {
        let edim: u64 = cur.parse("a node block dimension")?.0;
        cur.parse::<i64>("a node block entity tag")?;
        let parametric: u64 = cur.parse("the parametric flag")?.0;
        let count: u64 = cur.parse("the number of nodes in the block")?.0;
        let mut tags = Vec::new();
        for _ in 0..count {
            let (tag, line) = cur.parse::<u64>("a node tag")?;
            if raw
                .node_index
                .insert(tag, raw.nodes.len() + tags.len())
                .is_some()
            {
                return Err(MshError::DuplicateNode { line, tag });
            }
            tags.push(tag);
        }
        for tag in tags {
            let mut x = [0.0f64; 3];
            let mut z_line = 0;
            for c in &mut x {
                let (t, line) = cur.token("a node coordinate")?;
                z_line = line;
                *c = t
                    .parse()
                    .map_err(|_| syntax(line, "a node coordinate", t))?;
                if !c.is_finite() {
                    return Err(MshError::NonFinite {
                        line,
                        tag,
                        value: t.to_string(),
                    });
                }
            }
            if parametric == 1 {
                for _ in 0..edim {
                    cur.parse::<f64>("a parametric coordinate")?;
                }
            }
            // a 2D mesh keeps x and y only: a node off z = 0 would move
            // (reported once the elements show the file is a 2D one)
            if raw.dim == 2 && x[2] != 0.0 && raw.off_plane.is_none() {
                raw.off_plane = Some((z_line, tag, x[2]));
            }
            raw.nodes.push(x);
        }
    }
    let found = (raw.nodes.len() - before) as u64;
    if found != total {
        return Err(MshError::CountMismatch {
            line: header_line,
            what: "number of nodes",
            expected: total,
            found,
        });
    }
    raw.has_nodes = true;
    cur.expect("$EndNodes")
}

/// What this reader accepts, for error messages.
const ACCEPTED: &str = "Lagrange quads 3/10/36/37 with lines 1/8/26/27 (2D), \
                        hexes 5/12/92/93 with quads 3/10/36/37 (3D), points 15";

fn read_elements(cur: &mut Tokens, raw: &mut Raw) -> Result<(), MshError> {
    if !raw.has_nodes {
        return Err(syntax(cur.line, "$Nodes before $Elements", "$Elements"));
    }
    let blocks: u64 = cur.parse("the number of element blocks")?.0;
    let (total, header_line) = cur.parse::<u64>("the number of elements")?;
    cur.parse::<u64>("the minimum element tag")?;
    cur.parse::<u64>("the maximum element tag")?;
    let mut found = 0;
    for _ in 0..blocks {
        cur.parse::<u64>("an element block dimension")?;
        let entity: i64 = cur.parse("an element block entity tag")?.0;
        let (t, line) = cur.parse::<i64>("an element type")?;
        // a 2D reader rejects hexes; everything else known is stored or skipped
        let kind = element_kind(t).filter(|&(d, _, _)| d <= raw.dim);
        let Some((edim, order, nn)) = kind else {
            return Err(MshError::UnknownElementType {
                line,
                accepted: ACCEPTED,
                element_type: t,
            });
        };
        let count: u64 = cur.parse("the number of elements in the block")?.0;
        for _ in 0..count {
            let (tag, line) = cur.parse::<u64>("an element tag")?;
            let mut nodes = Vec::with_capacity(nn);
            for _ in 0..nn {
                let node: u64 = cur.parse("a node tag of an element")?.0;
                nodes.push(*raw.node_index.get(&node).ok_or(MshError::UnknownNode {
                    line,
                    element: tag,
                    tag: node,
                })?);
            }
            if edim == raw.dim {
                raw.cells.push((tag, order, nodes, line));
            } else if edim + 1 == raw.dim {
                raw.boundary.push((tag, entity, order, nodes, line));
            } // points, and lines of a 3D mesh, carry nothing we keep
        }
        found += count;
    }
    if found != total {
        return Err(MshError::CountMismatch {
            line: header_line,
            what: "number of elements",
            expected: total,
            found,
        });
    }
    raw.has_elements = true;
    cur.expect("$EndElements")
}

impl Raw {
    fn into_mesh<const D: usize>(mut self) -> Result<CurvedMesh<D>, MshError> {
        if let Some((line, tag, z)) = self.off_plane {
            return Err(MshError::OffPlane { line, tag, z });
        }
        self.cells.sort_by_key(|c| c.0);
        self.boundary.sort_by_key(|b| b.0);
        let Some(&(_, p, _, _)) = self.cells.first() else {
            return Err(MshError::Syntax {
                line: 1,
                expected: format!("at least one {}D cell", D),
                found: "none".into(),
            });
        };
        let mismatch = |line: usize, order: usize| {
            syntax(
                line,
                &format!("an element of order {p}, as the first cell"),
                &format!("order {order}"),
            )
        };
        let (cell_perm, face_perm) = if D == 2 {
            (gmsh_quad_order(p), gmsh_line_order(p))
        } else {
            (gmsh_hex_order(p), gmsh_quad_order(p))
        };
        let (cell_perm, face_perm) = (
            cell_perm.expect("p from the type table"),
            face_perm.expect("p from the type table"),
        );
        let mut cells = Vec::with_capacity(self.cells.len());
        for (_, order, nodes, line) in &self.cells {
            if *order != p {
                return Err(mismatch(*line, *order));
            }
            cells.push(from_format(&cell_perm, nodes));
        }
        // parts: named groups of dimension D-1 by tag, then unnamed entities
        let bdim = D - 1;
        let mut named: Vec<&(usize, i64, String)> =
            self.physical_names.iter().filter(|x| x.0 == bdim).collect();
        named.sort_by_key(|x| x.1);
        let mut part_names: Vec<String> = Vec::new();
        let mut tag_part: HashMap<i64, usize> = HashMap::new();
        for (_, tag, name) in named {
            let part = part_names
                .iter()
                .position(|n| n == name)
                .unwrap_or_else(|| {
                    part_names.push(name.clone());
                    part_names.len() - 1
                });
            tag_part.insert(*tag, part);
        }
        let prefix = if D == 2 { "curve" } else { "surface" };
        // an entity in several named groups belongs to each
        let mut entity_parts: HashMap<i64, Vec<usize>> = HashMap::new();
        let mut boundary = Vec::with_capacity(self.boundary.len());
        for (_, entity, order, nodes, line) in &self.boundary {
            if *order != p {
                return Err(mismatch(*line, *order));
            }
            let parts = entity_parts.entry(*entity).or_insert_with(|| {
                let phys = self.entity_physicals.get(&(bdim, *entity)).map(Vec::as_slice).unwrap_or(&[]);
                let mut parts: Vec<usize> = Vec::new();
                for &part in phys.iter().filter_map(|t| tag_part.get(t)) {
                    if !parts.contains(&part) {
                        parts.push(part);
                    }
                }
                if parts.is_empty() {
                    part_names.push(format!("{prefix}{entity}"));
                    parts.push(part_names.len() - 1);
                }
                parts
            });
            for &part in parts.iter() {
                boundary.push(CurvedBoundary {
                    nodes: from_format(&face_perm, nodes),
                    part,
                });
            }
        }
        Ok(CurvedMesh {
            p,
            spacing: Spacing::Equispaced,
            nodes: self
                .nodes
                .iter()
                .map(|x| std::array::from_fn(|d| x[d]))
                .collect(),
            cells,
            boundary,
            part_names,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::highorder::{certify_hex, certify_quad, hex_map, quad_map};

    fn bend2([x, y]: [f64; 2]) -> [f64; 2] {
        [x + 0.1 * (2.0 * y).sin(), y + 0.15 * x * x]
    }

    fn bend3([x, y, z]: [f64; 3]) -> [f64; 3] {
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
            assert!(certify_quad(3, m.spacing, &m.cell_coords(c)).unwrap().valid);
        }
        // bottom edge of cell 0 runs along +x: its nodes are the cell's
        // first row; left edge runs downwards (domain on the left)
        assert_eq!(
            m.boundary.iter().find(|b| b.part == 2).unwrap().nodes,
            m.cells[0][..4]
        );
        let left = &m.boundary.iter().find(|b| b.part == 0).unwrap().nodes;
        assert_eq!(left[0], m.cells[0][12]);
        assert_eq!(left[3], m.cells[0][0]);
        let h = CurvedMesh::<3>::structured(2, Spacing::GaussLobatto, [2, 1, 1], bend3).unwrap();
        h.validate().unwrap();
        assert_eq!(h.boundary.len(), 2 * (1 + 2 + 2));
        assert!(certify_hex(2, h.spacing, &h.cell_coords(1)).unwrap().valid);
    }

    #[test]
    fn msh_round_trip_keeps_tensor_order_and_parts() {
        for p in 1..=4 {
            let m = CurvedMesh::<2>::structured(p, Spacing::Equispaced, [2, 1], bend2).unwrap();
            let back = CurvedMesh::<2>::parse_msh(&m.msh_string().unwrap()).unwrap();
            assert_eq!(back, m, "p={p}");
            let h = CurvedMesh::<3>::structured(p, Spacing::Equispaced, [1, 2, 1], bend3).unwrap();
            let back = CurvedMesh::<3>::parse_msh(&h.msh_string().unwrap()).unwrap();
            assert_eq!(back, h, "p={p}");
        }
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
        // the file holds the equispaced nodes
        let back = CurvedMesh::<2>::parse_msh(&g.msh_string().unwrap()).unwrap();
        assert_eq!(back.nodes, e.nodes);
    }

    #[test]
    fn bad_meshes_and_files_are_rejected() {
        let mut m = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [1, 1], bend2).unwrap();
        m.cells[0].pop();
        assert!(matches!(m.msh_string(), Err(MshError::InvalidMesh(_))));
        let mut m = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [1, 1], bend2).unwrap();
        m.part_names[1] = "xmin".into();
        assert!(m.vtu_string(&[]).is_err());
        let m = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [1, 1], bend2).unwrap();
        assert!(matches!(
            m.vtu_string(&[("q", &[1.0, 2.0])]),
            Err(VtuError::Length { .. })
        ));
        // a hex file is not a 2D mesh; mixed orders are refused
        let h = CurvedMesh::<3>::structured(2, Spacing::Equispaced, [1, 1, 1], bend3).unwrap();
        assert!(matches!(
            CurvedMesh::<2>::parse_msh(&h.msh_string().unwrap()),
            Err(MshError::UnknownElementType {
                element_type: 12,
                ..
            })
        ));
        let text = m.msh_string().unwrap().replace("\n1 1 8 ", "\n1 1 1 ");
        assert!(CurvedMesh::<2>::parse_msh(&text).is_err());
        let text = m.msh_string().unwrap().replace("4.1 0 8", "2.2 0 8");
        assert!(matches!(
            CurvedMesh::<2>::parse_msh(&text),
            Err(MshError::UnsupportedVersion { .. })
        ));
    }

    #[test]
    fn vtu_lists_cells_in_vtk_order() {
        let m = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [1, 1], bend2).unwrap();
        let text = m.vtu_string(&[("quality", &[0.5])]).unwrap();
        // tensor 0..9 on the 3×3 grid: VTK wants corners 0 2 8 6, edges
        // (y=0) 1, (x=1) 5, (y=1) 7, (x=0) 3, centre 4
        assert!(text.contains("\n0 2 8 6 1 5 7 3 4\n"), "{text}");
        assert!(text.contains("<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n70\n"));
        // VTK reads files older than 2.2 with VTK 8's hex edge order
        assert!(text.contains("version=\"2.2\""));
    }
}
