//! VTK XML unstructured grids (`.vtu`, ASCII), for viewing quad and hex
//! meshes and per-cell or per-node fields in ParaView.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use thiserror::Error;

use super::{fmt_f64, write_atomic};
use crate::mesh::{HexMesh, QuadMesh};

/// VTK's cell type number for a linear quadrilateral.
pub const VTK_QUAD: u8 = 9;

/// VTK's cell type number for a linear (8-node) hexahedron.
pub const VTK_HEXAHEDRON: u8 = 12;

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
}

/// The mesh as a VTK XML UnstructuredGrid (version 1.0, ASCII): Float64
/// points with z = 0, Int64 connectivity and offsets, UInt8 cell types
/// ([`VTK_QUAD`]), one Float64 scalar CellData array per `cell_data` entry
/// and one 3-component Float64 PointData array (z = 0) per `point_vectors`
/// entry. Values are printed with round-trip precision.
///
/// Fails without writing anything on NaN or infinite values, on arrays of
/// the wrong length, on dangling node indices and on empty or repeated
/// array names.
pub fn vtu_string(
    mesh: &QuadMesh,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; 2]])],
) -> Result<String, VtuError> {
    let grid = Grid {
        points: &mesh.nodes,
        cells: &mesh.cells,
        cell_type: VTK_QUAD,
    };
    grid.to_vtu(cell_data, point_vectors)
}

/// Writes [`vtu_string`] atomically to `path`.
pub fn write_vtu(
    path: &Path,
    mesh: &QuadMesh,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; 2]])],
) -> Result<(), VtuError> {
    write_text(path, &vtu_string(mesh, cell_data, point_vectors)?)
}

/// The hex mesh as a VTK XML UnstructuredGrid (version 1.0, ASCII), laid
/// out as in [`vtu_string`] but with 3D points, cells of type
/// [`VTK_HEXAHEDRON`] (whose node order is [`HexMesh`]'s) and 3-component
/// point vectors written as given. Rejects the same inputs.
pub fn hex_vtu_string(
    mesh: &HexMesh,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; 3]])],
) -> Result<String, VtuError> {
    let grid = Grid {
        points: &mesh.nodes,
        cells: &mesh.cells,
        cell_type: VTK_HEXAHEDRON,
    };
    grid.to_vtu(cell_data, point_vectors)
}

/// Writes [`hex_vtu_string`] atomically to `path`; nothing is written if
/// the input is rejected.
pub fn write_hex_vtu(
    path: &Path,
    mesh: &HexMesh,
    cell_data: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; 3]])],
) -> Result<(), VtuError> {
    write_text(path, &hex_vtu_string(mesh, cell_data, point_vectors)?)
}

/// Writes `text` atomically, naming `path` in the error.
fn write_text(path: &Path, text: &str) -> Result<(), VtuError> {
    write_atomic(path, text.as_bytes()).map_err(|source| VtuError::Io {
        path: path.to_owned(),
        source,
    })
}

/// An unstructured grid of one cell type: points with `D` coordinates
/// (z = 0 when `D` = 2) and cells of `V` nodes. Quad and hex meshes share
/// all the writing code through it.
struct Grid<'a, const D: usize, const V: usize> {
    points: &'a [[f64; D]],
    cells: &'a [[usize; V]],
    /// VTK cell type of every cell.
    cell_type: u8,
}

impl<const D: usize, const V: usize> Grid<'_, D, V> {
    /// The whole file, after [`Grid::validate`].
    fn to_vtu(
        &self,
        cell_data: &[(&str, &[f64])],
        point_vectors: &[(&str, &[[f64; D]])],
    ) -> Result<String, VtuError> {
        self.validate(cell_data, point_vectors)?;
        let mut out = String::new();
        out.push_str("<?xml version=\"1.0\"?>\n");
        out.push_str(
            "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\">\n",
        );
        out.push_str("<UnstructuredGrid>\n");
        put!(
            out,
            "<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
            self.points.len(),
            self.cells.len()
        );
        push_point_data(&mut out, point_vectors);
        push_cell_data(&mut out, cell_data);
        self.push_points(&mut out);
        self.push_cells(&mut out);
        out.push_str("</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
        Ok(out)
    }

    /// Everything [`vtu_string`] promises to reject.
    fn validate(
        &self,
        cell_data: &[(&str, &[f64])],
        point_vectors: &[(&str, &[[f64; D]])],
    ) -> Result<(), VtuError> {
        check_finite(
            "point coordinates",
            self.points.iter().flatten().copied(),
            D,
        )?;
        let n = self.points.len();
        if let Some(c) = self.cells.iter().position(|c| c.iter().any(|&v| v >= n)) {
            return Err(VtuError::Invalid(format!(
                "cell {c} refers to a node >= {n}"
            )));
        }
        check_names(cell_data.iter().map(|a| a.0))?;
        check_names(point_vectors.iter().map(|a| a.0))?;
        for (name, values) in cell_data {
            let what = format!("cell array {name:?}");
            check_length(&what, self.cells.len(), values.len())?;
            check_finite(&what, values.iter().copied(), 1)?;
        }
        for (name, values) in point_vectors {
            let what = format!("point array {name:?}");
            check_length(&what, n, values.len())?;
            check_finite(&what, values.iter().flatten().copied(), D)?;
        }
        Ok(())
    }

    /// Points, z = 0 in 2D.
    fn push_points(&self, out: &mut String) {
        put!(out, "<Points>\n{}", float_array_tag(None, 3));
        for p in self.points {
            push_vec3(out, p);
        }
        out.push_str("</DataArray>\n</Points>\n");
    }

    /// Connectivity, offsets (end of each cell) and types.
    fn push_cells(&self, out: &mut String) {
        out.push_str(
            "<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n",
        );
        for c in self.cells {
            let _ = write!(out, "{}", c[0]);
            for v in &c[1..] {
                let _ = write!(out, " {v}");
            }
            out.push('\n');
        }
        out.push_str(
            "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n",
        );
        for c in 1..=self.cells.len() {
            put!(out, "{}", V * c);
        }
        out.push_str("</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
        for _ in self.cells {
            put!(out, "{}", self.cell_type);
        }
        out.push_str("</DataArray>\n</Cells>\n");
    }
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

/// CellData: one scalar array per field.
fn push_cell_data(out: &mut String, cell_data: &[(&str, &[f64])]) {
    out.push_str("<CellData>\n");
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

    fn small() -> QuadMesh {
        QuadMesh::structured_box([0.0, 0.0], [1.0, 0.5], 2, 1)
    }

    #[test]
    fn writes_points_cells_and_arrays() {
        let m = small();
        let q = [0.25, -1e-300];
        let d = vec![[0.1, 0.2]; 6];
        let text = vtu_string(&m, &[("quality", &q)], &[("d<x>", &d)]).unwrap();
        assert!(text.contains("version=\"1.0\""));
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
}
