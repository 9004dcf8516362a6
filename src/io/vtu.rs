//! VTK XML unstructured grids (`.vtu`, ASCII) of meshes of any order
//! (quads and triangles, also mixed, hexes, tetrahedra, prisms), with per-cell and
//! per-node fields, for ParaView. One writer
//! ([`grid_string`]); linear meshes are its order-1 case.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use thiserror::Error;

use super::fmt_f64;
use crate::mesh::element::{prism, simplex, to_format, vtk_hex_order, vtk_quad_order, Shape, Spacing};
use crate::mesh::file::write_atomic;
use crate::mesh::{CurvedMesh, PlaneMesh, SolidMesh};

/// VTK's cell type number for a linear quadrilateral.
pub const VTK_QUAD: u8 = 9;

/// VTK's cell type number for a linear (8-node) hexahedron.
pub const VTK_HEXAHEDRON: u8 = 12;

/// VTK's cell type of a Lagrange quadrilateral.
pub const VTK_LAGRANGE_QUADRILATERAL: u8 = 70;

/// VTK's cell type of a Lagrange hexahedron.
pub const VTK_LAGRANGE_HEXAHEDRON: u8 = 72;
/// VTK's linear triangle.
pub const VTK_TRIANGLE: u8 = 5;
/// VTK's linear tetrahedron.
pub const VTK_TETRA: u8 = 10;
/// VTK's Lagrange triangle of any order.
pub const VTK_LAGRANGE_TRIANGLE: u8 = 69;
/// VTK's Lagrange tetrahedron of any order.
pub const VTK_LAGRANGE_TETRAHEDRON: u8 = 71;
/// VTK's linear wedge (prism).
pub const VTK_WEDGE: u8 = 13;
/// VTK's Lagrange wedge of any order.
pub const VTK_LAGRANGE_WEDGE: u8 = 73;
/// VTK's linear pyramid, vertices in Gmsh's order.
pub const VTK_PYRAMID: u8 = 14;

/// Errors of writing VTU files.
#[derive(Debug, Error)]
pub enum VtuError {
    /// The file could not be written.
    #[error("cannot write `{}`", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A NaN or infinite value: VTK readers disagree on how to spell them,
    /// and a NaN in a result file hides the bug that produced it.
    #[error("{what} has a non-finite value {value} at index {index}")]
    NonFinite {
        /// The coordinates or the array concerned.
        what: String,
        /// Index of the node, cell or vector.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// An array whose length is not the number of cells or points.
    #[error("{what} has {found} values, expected {expected}")]
    Length {
        /// The array concerned.
        what: String,
        /// Number of cells or points.
        expected: usize,
        /// Length found.
        found: usize,
    },
    /// A mesh or array that cannot be written (dangling index, bad name).
    #[error("cannot write VTU: {0}")]
    Invalid(String),
    /// An element VTK has no cell for.
    #[error("cannot write VTU: VTK has no cell for pyramids of order {0} (VTK 9 names VTK_LAGRANGE_PYRAMID = 74 but has no cell behind it, and its 13- and 19-node pyramids are other spaces); the MSH file holds them")]
    NoPyramidCell(usize),
}

/// Whether VTK has a cell for every element of `mesh`: not for pyramids
/// above order 1.
pub fn vtk_can_hold<const D: usize>(mesh: &CurvedMesh<D>) -> bool {
    mesh.p == 1 || !mesh.shapes().contains(&Shape::Pyramid)
}

/// The quad mesh as a VTK XML UnstructuredGrid ([`grid_string`] of the
/// order-1 mesh): cells of type [`VTK_QUAD`], 2-vectors written with z = 0.
pub fn vtu_string<const N: usize>(
    mesh: &PlaneMesh<N>,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; 2]])],
) -> Result<String, VtuError> {
    grid_string(&CurvedMesh::from_quads(mesh), cell_data, point_vectors)
}

/// Writes [`vtu_string`] atomically to `path`.
pub fn write_vtu<const N: usize>(
    path: &Path,
    mesh: &PlaneMesh<N>,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; 2]])],
) -> Result<(), VtuError> {
    write_text(path, &vtu_string(mesh, cell_data, point_vectors)?)
}

/// The hex mesh as a VTK XML UnstructuredGrid ([`grid_string`] of the
/// order-1 mesh): cells of type [`VTK_HEXAHEDRON`], whose node order is
/// [`HexMesh`]'s.
pub fn hex_vtu_string<const N: usize, const K: usize>(
    mesh: &SolidMesh<N, K>,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; 3]])],
) -> Result<String, VtuError> {
    grid_string(&CurvedMesh::from_hexes(mesh), cell_data, point_vectors)
}

/// Writes [`hex_vtu_string`] atomically to `path`; nothing is written if
/// the input is rejected.
pub fn write_hex_vtu<const N: usize, const K: usize>(
    path: &Path,
    mesh: &SolidMesh<N, K>,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; 3]])],
) -> Result<(), VtuError> {
    write_text(path, &hex_vtu_string(mesh, cell_data, point_vectors)?)
}

impl<const D: usize> CurvedMesh<D> {
    /// [`grid_string`] without point data.
    pub fn vtu_string(&self, cell_data: &[(&str, &[f64])]) -> Result<String, VtuError> {
        grid_string(self, cell_data, &[])
    }

    /// [`CurvedMesh::vtu_string`] plus one integer attribute per cell, the
    /// [`ATTRIBUTE_ARRAY`] MFEM's VTU reader takes its element attributes
    /// from ([`grid_string_with_attributes`]).
    pub fn vtu_string_with_attributes(
        &self,
        cell_data: &[(&str, &[f64])],
        attributes: &[i64],
    ) -> Result<String, VtuError> {
        grid_string_with_attributes(self, cell_data, &[], attributes)
    }

    /// Writes [`CurvedMesh::vtu_string_with_attributes`] atomically to
    /// `path`; nothing is written if the input is rejected.
    pub fn write_vtu_with_attributes(
        &self,
        path: &Path,
        cell_data: &[(&str, &[f64])],
        attributes: &[i64],
    ) -> Result<(), VtuError> {
        write_text(path, &self.vtu_string_with_attributes(cell_data, attributes)?)
    }

    /// Writes [`CurvedMesh::vtu_string`] atomically to `path`; nothing is
    /// written if the input is rejected.
    pub fn write_vtu(&self, path: &Path, cell_data: &[(&str, &[f64])]) -> Result<(), VtuError> {
        write_text(path, &self.vtu_string(cell_data)?)
    }
}

/// Writes `text` atomically, naming `path` in the error.
fn write_text(path: &Path, text: &str) -> Result<(), VtuError> {
    write_atomic(path, text.as_bytes()).map_err(|source| VtuError::Io {
        path: path.to_owned(),
        source,
    })
}

/// The cells of a mesh of any order as a VTK XML UnstructuredGrid (ASCII):
/// Float64 points (z = 0 in 2D), Int64 connectivity and offsets, UInt8
/// types, one per cell by its own kind (a mixed mesh holds quads and
/// triangles; [`VTK_QUAD`], [`VTK_TRIANGLE`], [`VTK_HEXAHEDRON`],
/// [`VTK_TETRA`] and [`VTK_WEDGE`] at order 1, else VTK's Lagrange cells in VTK 9's node
/// order, whose order VTK infers from the number of points), one
/// Float64 CellData array per `cell_data` entry and one 3-component
/// PointData array per `point_vectors` entry. Nodes are resampled to
/// equispaced ones first; boundary elements are not written. Values are
/// printed with round-trip precision.
///
/// Fails without writing anything on NaN or infinite values, arrays of the
/// wrong length, empty or repeated array names, and meshes that fail
/// [`CurvedMesh::validate`].
pub fn grid_string<const D: usize>(
    mesh: &CurvedMesh<D>,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; D]])],
) -> Result<String, VtuError> {
    grid_text(mesh, cell_data, point_vectors, None)
}

/// [`grid_string`] plus an Int32 CellData array [`ATTRIBUTE_ARRAY`] with
/// one attribute per cell, in `1..=i32::MAX` (MFEM's attributes are
/// positive `int`s). MFEM's XML VTK reader takes the first array of the
/// `CellData` element marked `Scalars="attribute"` as the element
/// attributes, so the attributes come first there, before `cell_data`.
/// Fails as [`grid_string`], and on a wrong number of attributes, values
/// outside that range and a `cell_data` array of the same name.
pub fn grid_string_with_attributes<const D: usize>(
    mesh: &CurvedMesh<D>,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; D]])],
    attributes: &[i64],
) -> Result<String, VtuError> {
    grid_text(mesh, cell_data, point_vectors, Some(attributes))
}

/// The name of the attribute array of [`grid_string_with_attributes`].
pub const ATTRIBUTE_ARRAY: &str = "attribute";

/// [`grid_string`], with the attribute array if `attributes` is given.
fn grid_text<const D: usize>(
    mesh: &CurvedMesh<D>,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; D]])],
    attributes: Option<&[i64]>,
) -> Result<String, VtuError> {
    validate(mesh, cell_data, point_vectors)?;
    if let Some(a) = attributes {
        check_attributes(mesh.cells.len(), cell_data, a)?;
    }
    let resampled;
    let mesh = if mesh.spacing == Spacing::Equispaced {
        mesh
    } else {
        resampled = mesh.to_equispaced();
        &resampled
    };
    let mut out = String::from("<?xml version=\"1.0\"?>\n");
    // Version 2.2 is how a file says "VTK 9 hex edge order": VTK's XML
    // reader renumbers the edges of Lagrange hexes in older files (it
    // swaps the vertical edges 10 and 11, VTK 8's order), which would
    // silently scramble ours.
    out.push_str("<VTKFile type=\"UnstructuredGrid\" version=\"2.2\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<UnstructuredGrid>\n");
    put!(out, "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">", mesh.nodes.len(), mesh.cells.len());
    push_point_data(&mut out, point_vectors);
    push_cell_data(&mut out, cell_data, attributes);
    put!(out, "<Points>\n{}", float_array_tag(None, 3));
    for x in &mesh.nodes {
        push_vec3(&mut out, x);
    }
    out.push_str("</DataArray>\n</Points>\n");
    push_cells(&mut out, mesh);
    out.push_str("</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
    Ok(out)
}

/// Everything [`grid_string`] promises to reject.
fn validate<const D: usize>(
    mesh: &CurvedMesh<D>,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; D]])],
) -> Result<(), VtuError> {
    check_finite("point coordinates", mesh.nodes.iter().flatten().copied(), D)?;
    mesh.validate().map_err(VtuError::Invalid)?;
    if !vtk_can_hold(mesh) {
        return Err(VtuError::NoPyramidCell(mesh.p));
    }
    check_names(cell_data.iter().map(|a| a.0))?;
    check_names(point_vectors.iter().map(|a| a.0))?;
    for (name, values) in cell_data {
        let what = format!("cell array {name:?}");
        check_length(&what, mesh.cells.len(), values.len())?;
        check_finite(&what, values.iter().copied(), 1)?;
    }
    for (name, values) in point_vectors {
        let what = format!("point array {name:?}");
        check_length(&what, mesh.nodes.len(), values.len())?;
        check_finite(&what, values.iter().flatten().copied(), D)?;
    }
    Ok(())
}

/// VTK's node order (from the crate's) and cell type of a `shape`
/// element of order `p`: VTK's linear cells at order 1, its Lagrange
/// cells above. The table of this format. A prism keeps its orientation:
/// VTK 9's linear and Lagrange wedges both take the bottom triangle
/// counter-clockwise seen from the top, as Gmsh and we do (module docs of
/// [`prism`]).
fn vtk_type(shape: Shape, p: usize) -> (Vec<usize>, u8) {
    let ok = "order checked by validate";
    match (shape, p) {
        (Shape::Prism, 1) => (prism::vtk_wedge_order(1).expect(ok), VTK_WEDGE),
        (Shape::Prism, _) => (prism::vtk_wedge_order(p).expect(ok), VTK_LAGRANGE_WEDGE),
        // refused above order 1 by validate
        (Shape::Pyramid, _) => (crate::mesh::element::pyramid::gmsh_pyramid_order(1).expect(ok), VTK_PYRAMID),
        (Shape::Triangle, 1) => (vec![0, 1, 2], VTK_TRIANGLE),
        (Shape::Triangle, _) => (simplex::vtk_triangle_order(p).expect(ok), VTK_LAGRANGE_TRIANGLE),
        (Shape::Tetrahedron, 1) => (vec![0, 1, 2, 3], VTK_TETRA),
        (Shape::Tetrahedron, _) => (simplex::vtk_tet_order(p).expect(ok), VTK_LAGRANGE_TETRAHEDRON),
        (Shape::Quadrilateral, 1) => (vtk_quad_order(1).expect(ok), VTK_QUAD),
        (Shape::Quadrilateral, _) => (vtk_quad_order(p).expect(ok), VTK_LAGRANGE_QUADRILATERAL),
        (_, 1) => (vtk_hex_order(1).expect(ok), VTK_HEXAHEDRON),
        _ => (vtk_hex_order(p).expect(ok), VTK_LAGRANGE_HEXAHEDRON),
    }
}

/// Connectivity in VTK's node order, offsets (end of each cell), types,
/// each cell by its own kind: a mixed mesh holds quads and triangles.
fn push_cells<const D: usize>(out: &mut String, mesh: &CurvedMesh<D>) {
    let kinds: Vec<(Shape, (Vec<usize>, u8))> = mesh.shapes().into_iter().map(|s| (s, vtk_type(s, mesh.p))).collect();
    let kind = |c: usize| {
        let shape = mesh.cell_shape(c);
        &kinds.iter().find(|k| k.0 == shape).expect("shapes() holds every cell's kind").1
    };
    out.push_str("<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
    for (c, cell) in mesh.cells.iter().enumerate() {
        for (i, v) in to_format(&kind(c).0, cell).iter().enumerate() {
            let _ = write!(out, "{}{v}", if i == 0 { "" } else { " " });
        }
        out.push('\n');
    }
    out.push_str("</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
    let mut end = 0;
    for cell in &mesh.cells {
        end += cell.len();
        put!(out, "{end}");
    }
    out.push_str("</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
    for c in 0..mesh.cells.len() {
        put!(out, "{}", kind(c).1);
    }
    out.push_str("</DataArray>\n</Cells>\n");
}

/// One line `x y z` of a 2- or 3-vector; missing components are written
/// as 0, since VTK points and vectors always have three.
fn push_vec3<const D: usize>(out: &mut String, v: &[f64; D]) {
    for (i, x) in v.iter().enumerate() {
        let sep = if i == 0 { "" } else { " " };
        let _ = write!(out, "{sep}{}", fmt_f64(*x));
    }
    for _ in D..3 {
        out.push_str(" 0");
    }
    out.push('\n');
}

/// Fails on the first non-finite value; `width` values make one item.
fn check_finite(
    what: &str,
    values: impl Iterator<Item = f64>,
    width: usize,
) -> Result<(), VtuError> {
    match values.enumerate().find(|(_, v)| !v.is_finite()) {
        Some((i, value)) => Err(VtuError::NonFinite {
            what: what.to_string(),
            index: i / width,
            value,
        }),
        None => Ok(()),
    }
}

/// Fails unless `found == expected`.
fn check_length(what: &str, expected: usize, found: usize) -> Result<(), VtuError> {
    if found == expected {
        Ok(())
    } else {
        Err(VtuError::Length {
            what: what.to_string(),
            expected,
            found,
        })
    }
}

/// Array names must be non-empty and distinct: readers look arrays up by
/// name, so a repeated name would hide one of them.
fn check_names<'a>(names: impl Iterator<Item = &'a str>) -> Result<(), VtuError> {
    let mut seen: Vec<&str> = Vec::new();
    for name in names {
        if name.is_empty() || seen.contains(&name) {
            return Err(VtuError::Invalid(format!(
                "array name {name:?} is empty or repeated"
            )));
        }
        seen.push(name);
    }
    Ok(())
}

/// `name` escaped for use inside a double-quoted XML attribute.
fn xml_attr(name: &str) -> String {
    let mut s = String::with_capacity(name.len());
    for ch in name.chars() {
        match ch {
            '&' => s.push_str("&amp;"),
            '<' => s.push_str("&lt;"),
            '>' => s.push_str("&gt;"),
            '"' => s.push_str("&quot;"),
            _ => s.push(ch),
        }
    }
    s
}

/// The opening tag of a Float64 data array.
fn float_array_tag(name: Option<&str>, components: usize) -> String {
    let name = name
        .map(|n| format!(" Name=\"{}\"", xml_attr(n)))
        .unwrap_or_default();
    format!(
        "<DataArray type=\"Float64\"{name} NumberOfComponents=\"{components}\" format=\"ascii\">"
    )
}

/// PointData: one 3-component array per vector field.
fn push_point_data<const D: usize>(out: &mut String, point_vectors: &[(&str, &[[f64; D]])]) {
    out.push_str("<PointData>\n");
    for (name, values) in point_vectors {
        put!(out, "{}", float_array_tag(Some(name), 3));
        for v in *values {
            push_vec3(out, v);
        }
        out.push_str("</DataArray>\n");
    }
    out.push_str("</PointData>\n");
}

/// Fails unless there is one attribute per cell, each in `1..=i32::MAX`,
/// and no `cell_data` array takes the attribute array's name.
fn check_attributes(cells: usize, cell_data: &[(&str, &[f64])], attributes: &[i64]) -> Result<(), VtuError> {
    check_length("cell attributes", cells, attributes.len())?;
    if let Some(i) = attributes.iter().position(|&a| !(1..=i64::from(i32::MAX)).contains(&a)) {
        return Err(VtuError::Invalid(format!(
            "cell {i} has attribute {}; attributes must be in 1..={}",
            attributes[i],
            i32::MAX
        )));
    }
    check_names(cell_data.iter().map(|a| a.0).chain([ATTRIBUTE_ARRAY]))
}

/// CellData: the attributes if given (first, and named as the active
/// scalars, which is where MFEM looks), then one scalar array per field.
fn push_cell_data(out: &mut String, cell_data: &[(&str, &[f64])], attributes: Option<&[i64]>) {
    match attributes {
        None => out.push_str("<CellData>\n"),
        Some(a) => {
            put!(out, "<CellData Scalars=\"{ATTRIBUTE_ARRAY}\">");
            put!(out, "<DataArray type=\"Int32\" Name=\"{ATTRIBUTE_ARRAY}\" format=\"ascii\">");
            for v in a {
                put!(out, "{v}");
            }
            out.push_str("</DataArray>\n");
        }
    }
    for (name, values) in cell_data {
        put!(out, "{}", float_array_tag(Some(name), 1));
        for v in *values {
            put!(out, "{}", fmt_f64(*v));
        }
        out.push_str("</DataArray>\n");
    }
    out.push_str("</CellData>\n");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{HexMesh, QuadMesh};
    use crate::mesh::curved::tests::bend2;
    use crate::mesh::element::Spacing;

    fn small() -> QuadMesh {
        QuadMesh::structured_box([0.0, 0.0], [1.0, 0.5], 2, 1)
    }

    #[test]
    fn writes_points_cells_and_arrays() {
        let m = small();
        let q = [0.25, -1e-300];
        let d = vec![[0.1, 0.2]; 6];
        let text = vtu_string(&m, &[("quality", &q)], &[("d<x>", &d)]).unwrap();
        assert!(text.contains("version=\"2.2\""));
        assert!(text.contains("<Piece NumberOfPoints=\"6\" NumberOfCells=\"2\">"));
        assert!(text.contains(
            "Name=\"quality\" NumberOfComponents=\"1\" format=\"ascii\">\n0.25\n-1e-300\n"
        ));
        assert!(text.contains("Name=\"d&lt;x&gt;\" NumberOfComponents=\"3\""));
        assert!(text.contains("connectivity\" format=\"ascii\">\n0 1 4 3\n1 2 5 4\n"));
        assert!(text.contains("offsets\" format=\"ascii\">\n4\n8\n"));
        assert!(text.contains("types\" format=\"ascii\">\n9\n9\n"));
    }

    #[test]
    fn rejects_nan_everywhere_and_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.vtu");
        let mut m = small();
        m.nodes[4][0] = f64::NAN;
        let err = write_vtu(&path, &m, &[], &[]).unwrap_err();
        assert!(matches!(err, VtuError::NonFinite { index: 4, .. }), "{err}");
        let m = small();
        let err = write_vtu(&path, &m, &[("q", &[1.0, f64::NAN])], &[]).unwrap_err();
        assert!(
            err.to_string().contains("\"q\"") && err.to_string().contains("index 1"),
            "{err}"
        );
        let mut d = vec![[0.0, 0.0]; 6];
        d[5][1] = f64::INFINITY;
        assert!(matches!(
            write_vtu(&path, &m, &[], &[("d", &d)]),
            Err(VtuError::NonFinite { index: 5, .. })
        ));
        assert!(!path.exists());
    }

    #[test]
    fn rejects_bad_lengths_names_and_indices() {
        let m = small();
        assert!(matches!(
            vtu_string(&m, &[("q", &[1.0])], &[]),
            Err(VtuError::Length {
                expected: 2,
                found: 1,
                ..
            })
        ));
        let q = [1.0, 2.0];
        assert!(matches!(
            vtu_string(&m, &[("q", &q), ("q", &q)], &[]),
            Err(VtuError::Invalid(_))
        ));
        let mut bad = small();
        bad.cells[1][2] = 6;
        assert!(matches!(
            vtu_string(&bad, &[], &[]),
            Err(VtuError::Invalid(_))
        ));
    }

    #[test]
    fn write_vtu_writes_the_string() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.vtu");
        let m = small();
        write_vtu(&path, &m, &[], &[]).unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            vtu_string(&m, &[], &[]).unwrap()
        );
    }

    // ------------------------------------------------------------ hex meshes

    fn brick() -> HexMesh {
        HexMesh::structured_box([0.0; 3], [2.0, 1.0, 1.0], [2, 1, 1])
    }

    #[test]
    fn writes_hex_points_cells_and_arrays() {
        let m = brick();
        let v = [0.5, -2e-300];
        let d: Vec<[f64; 3]> = m.nodes.iter().map(|p| [p[0], 0.1, -p[2]]).collect();
        let text = hex_vtu_string(&m, &[("volume", &v)], &[("disp", &d)]).unwrap();
        assert!(text.contains("<Piece NumberOfPoints=\"12\" NumberOfCells=\"2\">"));
        assert!(text.contains(
            "Name=\"disp\" NumberOfComponents=\"3\" format=\"ascii\">\n0 0.1 -0\n1 0.1 -0\n"
        ));
        assert!(text.contains(
            "Name=\"volume\" NumberOfComponents=\"1\" format=\"ascii\">\n0.5\n-2e-300\n"
        ));
        assert!(text.contains("<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n0 0 0\n1 0 0\n2 0 0\n0 1 0\n"));
        assert!(text
            .contains("connectivity\" format=\"ascii\">\n0 1 4 3 6 7 10 9\n1 2 5 4 7 8 11 10\n"));
        assert!(text.contains("offsets\" format=\"ascii\">\n8\n16\n"));
        assert!(text.contains("types\" format=\"ascii\">\n12\n12\n"));
    }

    #[test]
    fn hex_rejects_bad_input_and_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.vtu");
        let mut m = brick();
        m.nodes[7][2] = f64::NAN;
        assert!(matches!(
            write_hex_vtu(&path, &m, &[], &[]),
            Err(VtuError::NonFinite { index: 7, .. })
        ));
        let m = brick();
        let mut d = vec![[0.0; 3]; 12];
        d[11][2] = f64::NEG_INFINITY;
        let err = write_hex_vtu(&path, &m, &[], &[("d", &d)]).unwrap_err();
        assert!(
            matches!(err, VtuError::NonFinite { index: 11, .. }),
            "{err}"
        );
        assert!(matches!(
            write_hex_vtu(&path, &m, &[], &[("d", &d[..5])]),
            Err(VtuError::Length {
                expected: 12,
                found: 5,
                ..
            })
        ));
        assert!(matches!(
            write_hex_vtu(&path, &m, &[("", &[1.0, 2.0])], &[]),
            Err(VtuError::Invalid(_))
        ));
        let mut bad = brick();
        bad.cells[0][6] = 12;
        assert!(matches!(
            write_hex_vtu(&path, &bad, &[], &[]),
            Err(VtuError::Invalid(_))
        ));
        assert!(!path.exists());
        write_hex_vtu(&path, &m, &[], &[]).unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            hex_vtu_string(&m, &[], &[]).unwrap()
        );
    }

    // ------------------------------------------------------------ any order

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

    /// The `<DataArray ... Name="{name}" ...>` values of `text`, as numbers.
    fn array(text: &str, name: &str) -> Vec<Vec<usize>> {
        let start = text.find(&format!("Name=\"{name}\"")).unwrap();
        let body = &text[start..][text[start..].find('\n').unwrap() + 1..];
        let body = &body[..body.find("</DataArray>").unwrap()];
        body.lines().map(|l| l.split(' ').map(|v| v.parse().unwrap()).collect()).collect()
    }

    /// Each cell of a mixed mesh has its own type, node count and VTK
    /// node order: quads 70, triangles 69 (9 and 5 at p = 1).
    #[test]
    fn a_mixed_mesh_gives_each_cell_its_own_type() {
        for p in 1..=3 {
            let m = crate::io::layout::tests::mixed2(p);
            let text = m.vtu_string(&[]).unwrap();
            let types: Vec<usize> = array(&text, "types").concat();
            let (quad, triangle) = if p == 1 { (VTK_QUAD, VTK_TRIANGLE) } else { (VTK_LAGRANGE_QUADRILATERAL, VTK_LAGRANGE_TRIANGLE) };
            assert_eq!(types, [quad, quad, triangle, triangle].map(usize::from), "p = {p}");
            let (nq, nt) = ((p + 1) * (p + 1), (p + 1) * (p + 2) / 2);
            assert_eq!(array(&text, "offsets").concat(), [nq, 2 * nq, 2 * nq + nt, 2 * nq + 2 * nt], "p = {p}");
            let connectivity = array(&text, "connectivity");
            for (c, cell) in m.cells.iter().enumerate() {
                let (perm, _) = vtk_type(m.cell_shape(c), p);
                assert_eq!(connectivity[c], to_format(&perm, cell), "p = {p}, cell {c}");
            }
            // VTK's triangle starts at its three vertices: lattice places 0, p, last
            assert_eq!(connectivity[2][..3], [m.cells[2][0], m.cells[2][p], m.cells[2][nt - 1]], "p = {p}");
        }
    }

    /// A prism mesh: each cell a wedge, 13 at p = 1 and 73 above, its
    /// nodes in VTK's order, the six vertices first in our (and Gmsh's)
    /// vertex order, no mirroring (VTK 9's wedges are oriented like ours;
    /// checked with VTK in `tests/it/real_programs_highorder.rs`).
    #[test]
    fn prisms_are_written_as_vtk_wedges() {
        use crate::mesh::curved::tests::bend3;
        use crate::mesh::element::prism::tests::prism_box;
        for p in 1..=4 {
            let m = prism_box(p, Spacing::Equispaced, [1, 1, 1], bend3);
            let text = m.vtu_string(&[]).unwrap();
            let ty = if p == 1 { VTK_WEDGE } else { VTK_LAGRANGE_WEDGE };
            assert_eq!(array(&text, "types").concat(), [usize::from(ty); 2], "p = {p}");
            let n = Shape::Prism.num_nodes(p);
            assert_eq!(array(&text, "offsets").concat(), [n, 2 * n]);
            let connectivity = array(&text, "connectivity");
            for (c, cell) in m.cells.iter().enumerate() {
                assert_eq!(connectivity[c], to_format(&prism::vtk_wedge_order(p).unwrap(), cell), "p = {p}, cell {c}");
                assert_eq!(connectivity[c][..6], prism::vertex_nodes(p).map(|a| cell[a]), "p = {p}, cell {c}");
            }
        }
    }

    #[test]
    fn attributes_come_first_as_the_active_cell_scalars() {
        let m = CurvedMesh::<2>::structured(2, Spacing::Equispaced, [2, 1], bend2).unwrap();
        let q = [0.5, 0.25];
        let text = m.vtu_string_with_attributes(&[("quality", &q)], &[6, 7]).unwrap();
        assert!(text.contains(
            "<CellData Scalars=\"attribute\">\n<DataArray type=\"Int32\" Name=\"attribute\" format=\"ascii\">\n6\n7\n</DataArray>\n<DataArray type=\"Float64\" Name=\"quality\""
        ), "{text}");
        // without attributes the file is what it was
        assert_eq!(
            m.vtu_string(&[("quality", &q)]).unwrap(),
            text.replace("<CellData Scalars=\"attribute\">\n<DataArray type=\"Int32\" Name=\"attribute\" format=\"ascii\">\n6\n7\n</DataArray>\n", "<CellData>\n")
        );
        assert!(matches!(
            m.vtu_string_with_attributes(&[], &[1]),
            Err(VtuError::Length { expected: 2, found: 1, .. })
        ));
        let err = m.vtu_string_with_attributes(&[], &[1, 0]).unwrap_err();
        assert!(err.to_string().contains("cell 1 has attribute 0"), "{err}");
        assert!(m.vtu_string_with_attributes(&[], &[1, 1 << 31]).is_err());
        assert!(matches!(
            m.vtu_string_with_attributes(&[("attribute", &q)], &[1, 2]),
            Err(VtuError::Invalid(_))
        ));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.vtu");
        assert!(m.write_vtu_with_attributes(&path, &[], &[0, 1]).is_err());
        assert!(!path.exists());
        m.write_vtu_with_attributes(&path, &[], &[3, 4]).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), m.vtu_string_with_attributes(&[], &[3, 4]).unwrap());
    }
}
