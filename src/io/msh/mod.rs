//! Gmsh MSH 4.1 files of meshes of every kind and any order: one reader for
//! ASCII and binary files (`read`), meshes made of what it read
//! (`build`), and one writer ([`write`]). ASCII MSH 2.2 (and 2.0, 2.1) is
//! read into the same items and written from a layout
//! ([`layout_text_22`], module `v22`); every reader below takes it.
//!
//! Layout written: every boundary part becomes an entity of the boundary
//! dimension (a curve in 2D, a surface in 3D) carrying a physical group of
//! that dimension with the part's name; all nodes and cells live on one
//! entity of the mesh dimension carrying the physical group
//! [`DOMAIN_NAME`]. Element tags run from 1: boundary element `i` gets tag
//! `i + 1`, cell `c` gets tag `boundary.len() + c + 1`. Because the reader
//! orders elements by tag, the boundary order survives even though it is
//! grouped by part in the file. Elements of order `p` keep their nodes in
//! tensor order inside the crate ([`crate::mesh::element`]) and in Gmsh's
//! order in the file.

mod build;
mod read;
mod structure;
mod v22;
mod types;
mod write;

use std::fmt;
use std::path::{Path, PathBuf};

use thiserror::Error;

pub use v22::layout_text_22;
pub use write::{hex_msh_string, layout_text, msh_string, msh_type, write_hex_msh, write_msh};

use crate::mesh::{CurvedMesh, HexMesh, QuadMesh};
use read::Accept;

pub use crate::io::layout::DOMAIN_NAME;

pub use types::{gmsh_perm, shape_of, MSH_TYPES};
/// MSH element types of lines of order 1..=4 (index `p − 1`).
pub const MSH_LINE_TYPES: [i64; 4] = MSH_TYPES[0].1;
/// MSH element types of quads of order 1..=4: QUA_4, QUA_9, QUA_16, QUA_25.
pub const MSH_QUAD_TYPES: [i64; 4] = MSH_TYPES[2].1;
/// MSH element types of hexes of order 1..=4: HEX_8, HEX_27, HEX_64, HEX_125.
pub const MSH_HEX_TYPES: [i64; 4] = MSH_TYPES[4].1;

/// What the linear readers take: quad meshes, then hex meshes.
const LINEAR: [Accept; 2] = [
    Accept { max_dim: 2, max_order: 1, phrase: "only linear meshes: 1 = 2-node line, 2 = 3-node triangle, 3 = 4-node quad, 15 = point" },
    Accept {
        max_dim: 3,
        max_order: 1,
        phrase: "only linear meshes: 1 = 2-node line, 2 = 3-node triangle, 3 = 4-node quad, 4 = 4-node tetrahedron, 5 = 8-node hexahedron, 6 = 6-node prism, 7 = 5-node pyramid, 15 = point",
    },
];

/// What the readers of any order take, in 2D and in 3D.
const CURVED: [Accept; 2] = [
    Accept { max_dim: 2, max_order: 4, phrase: ACCEPTED },
    Accept { max_dim: 3, max_order: 4, phrase: ACCEPTED },
];
const ACCEPTED: &str = "Lagrange triangles 2/9/21/23 or quads 3/10/36/37 with lines 1/8/26/27 (2D), \
                        tetrahedra 4/11/29/30, hexes 5/12/92/93, prisms 6/13/90/91 and pyramids 7/14/118/119, \
                        alone or together, with triangles or quads (3D), points 15";

/// How to turn another MSH flavour into one this reader accepts.
const RESAVE_HINT: &str = "re-save it as ASCII MSH 4.1, e.g. `gmsh IN.msh -save -format msh41 -o OUT.msh`";

/// Where in a file an error is: a 1-based line of text, or a byte offset
/// in the data of a binary file (where lines mean nothing).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pos {
    /// A line of an ASCII file (or of a binary file's text).
    Line(usize),
    /// A byte offset from the start of a binary file.
    Byte(usize),
}

impl fmt::Display for Pos {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            Pos::Line(n) => write!(f, "line {n}"),
            Pos::Byte(n) => write!(f, "byte {n}"),
        }
    }
}

/// Errors of reading or writing MSH files. Parse errors carry where the
/// offending item starts.
#[derive(Debug, Error)]
pub enum MshError {
    /// The file could not be read or written.
    #[error("cannot read or write `{}`", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file ended while more data was expected.
    #[error("{at}: file truncated: expected {expected}")]
    Truncated {
        /// The end of the file.
        at: Pos,
        /// What was expected next.
        expected: String,
    },
    /// An item did not have the expected form.
    #[error("{at}: expected {expected}, found {}", shown(found, "`"))]
    Syntax {
        /// Where the item is.
        at: Pos,
        /// What was expected.
        expected: String,
        /// The item found.
        found: String,
    },
    /// A version other than 4.1 and 2.x (e.g. MSH 3 or 4.0).
    #[error("{at}: MSH version {} is not supported: {RESAVE_HINT}", shown(version, ""))]
    UnsupportedVersion {
        /// Where the version number is.
        at: Pos,
        /// The version found.
        version: String,
    },
    /// A binary MSH 2 file (only ASCII MSH 2 is read).
    #[error(
        "{at}: binary MSH {} is not supported: save the mesh as ASCII MSH 2.2 or as MSH 4.1 (ASCII or binary), \
         e.g. `gmsh IN.msh -save -format msh22 -o OUT.msh` (ASCII unless `-bin`) or `-format msh41`",
        shown(version, "")
    )]
    BinaryV2 {
        /// Where the file type is.
        at: Pos,
        /// The version found.
        version: String,
    },
    /// One element tag on two different elements (MSH 2: copies of one
    /// element, one per physical group, are one element).
    #[error("{at}: element tag {tag} is used by two different elements (the first at {first}): element tags must be unique")]
    DuplicateElement {
        /// Where the second element is.
        at: Pos,
        /// The tag.
        tag: u64,
        /// Where the first is.
        first: Pos,
    },
    /// A section header announced another number of items than it holds.
    #[error("{at}: {what}: the header says {expected}, the blocks hold {found}")]
    CountMismatch {
        /// Where the section header is.
        at: Pos,
        /// What was counted.
        what: &'static str,
        /// Count from the header.
        expected: u64,
        /// Count found.
        found: u64,
    },
    /// An element type the reader cannot store (e.g. a triangle, or a hex
    /// in a quad mesh).
    #[error("{at}: unsupported element type {element_type} ({accepted}){}", recombine_hint(*element_type))]
    UnknownElementType {
        /// Where the element block header is.
        at: Pos,
        /// The element types this reader accepts, as a phrase.
        accepted: &'static str,
        /// The MSH element type number.
        element_type: i64,
    },
    /// A NaN or infinite node coordinate.
    #[error("{at}: node {tag} has a non-finite coordinate `{value}`")]
    NonFinite {
        /// Where the coordinate is.
        at: Pos,
        /// Node tag.
        tag: u64,
        /// The coordinate as written.
        value: String,
    },
    /// An element refers to a node tag that no node block defined.
    #[error("{at}: element {element} refers to unknown node tag {tag}")]
    UnknownNode {
        /// Where the element is.
        at: Pos,
        /// Element tag.
        element: u64,
        /// The undefined node tag.
        tag: u64,
    },
    /// The same node tag defined twice.
    #[error("{at}: node tag {tag} is defined twice")]
    DuplicateNode {
        /// Where the second definition is.
        at: Pos,
        /// The node tag.
        tag: u64,
    },
    /// A node of a 2D mesh off the plane z = 0: dropping z would move it.
    #[error("{at}: node {tag} has z = {z}, but a plane (2D) mesh must lie in the plane z = 0 (move or project the mesh there)")]
    OffPlane {
        /// Where its coordinates are.
        at: Pos,
        /// Node tag.
        tag: u64,
        /// Its z.
        z: f64,
    },
    /// An element block of a kind the mesh cannot hold there: cells of
    /// another kind than a reader of one kind takes, or boundary elements
    /// that are no faces of the cells.
    #[error("{at}: element block of {found:?}s in a mesh whose {what} are {expected:?}s: {why}")]
    MixedShapes {
        /// Where the block header is.
        at: Pos,
        /// "cells" or "boundary elements".
        what: &'static str,
        /// The shape the first cell block set.
        expected: crate::mesh::element::Shape,
        /// The shape of this block.
        found: crate::mesh::element::Shape,
        /// What to do.
        why: &'static str,
    },
    /// One element tag on two elements of an MSH 4.1 file.
    #[error(
        "element tag {tag} is used twice: by the element with nodes {first_nodes} and by the one with nodes {second_nodes}, {}: element tags must be unique (renumber the elements, e.g. gmsh.model.mesh.renumberElements())",
        if first == second { format!("both in the element block at {first}") } else { format!("in the element blocks at {first} and {second}") }
    )]
    DuplicateElementTag {
        /// The tag.
        tag: u64,
        /// The block header of the first element.
        first: Pos,
        /// Its node tags.
        first_nodes: String,
        /// The block header of the second.
        second: Pos,
        /// Its node tags.
        second_nodes: String,
    },
    /// A file without cells of dimension 2 or 3 (a 1D or boundary mesh).
    #[error("{at}: no cells (the file holds {found}): a mesh of the domain is expected, of triangles or quads (2D) or of tetrahedra, hexahedra, prisms or pyramids (3D), not of its boundary only (in Gmsh, mesh the surfaces or volumes: Mesh 2 or 3, `gmsh -2` or `-3`)")]
    NoCells {
        /// The `$Elements` header.
        at: Pos,
        /// What the file holds instead.
        found: String,
    },
    /// Element blocks of different orders in one mesh.
    #[error("{at}: an element block of order {found} in a mesh whose first cell is of order {order}: a mesh has one order (each order from 1 to 4 is read, all of the mesh's cells and boundary elements at that order)")]
    MixedOrders {
        /// The block header.
        at: Pos,
        /// The first cell's order.
        order: usize,
        /// This block's.
        found: usize,
    },
    /// A compressed file (gzip, ...), not an MSH file itself.
    #[error("the file is {0}-compressed, not an MSH file: decompress it first (e.g. `{cmd} FILE`)", cmd = decompressor(.0))]
    Compressed(&'static str),
    /// The cells and boundary elements do not make one mesh (the message
    /// names the file's element and node tags).
    #[error("{0}")]
    Structure(String),
    /// A required section is absent.
    #[error("missing section ${0}")]
    MissingSection(&'static str),
    /// The mesh to write is inconsistent.
    #[error("cannot write mesh: {0}")]
    InvalidMesh(String),
}

/// The command that decompresses a file of `format`.
fn decompressor(format: &str) -> &'static str {
    match format {
        "gzip" => "gunzip",
        "bzip2" => "bunzip2",
        "xz" => "unxz",
        "zstd" => "unzstd",
        _ => "unzip",
    }
}

/// The compression `bytes` start with (gzip, zip, bzip2, xz, zstd), if any.
fn compressed(bytes: &[u8]) -> Option<&'static str> {
    match bytes {
        [0x1f, 0x8b, ..] => Some("gzip"),
        [b'P', b'K', 3, 4, ..] => Some("zip"),
        [b'B', b'Z', b'h', ..] => Some("bzip2"),
        [0xfd, b'7', b'z', b'X', b'Z', 0, ..] => Some("xz"),
        [0x28, 0xb5, 0x2f, 0xfd, ..] => Some("zstd"),
        _ => None,
    }
}

/// A syntax error at `at`.
fn syntax(at: Pos, expected: &str, found: &str) -> MshError {
    MshError::Syntax { at, expected: expected.to_string(), found: found.to_string() }
}

/// A token of the file for a message: quoted, cut to 40 characters, and
/// never raw bytes: a binary or garbage file would otherwise write control
/// characters to the user's terminal.
fn shown(token: &str, quote: &str) -> String {
    if token.chars().any(|c| c.is_control() || c == char::REPLACEMENT_CHARACTER) {
        return "bytes that are not text (is this an MSH file?)".into();
    }
    match token.char_indices().nth(40) {
        Some((cut, _)) => format!("{quote}{}…{quote}", &token[..cut]),
        None => format!("{quote}{token}{quote}"),
    }
}

/// What to do instead of an element type the reader refuses: for
/// serendipity elements, and for elements of order > 1 (`curve` places the
/// high-order nodes itself).
fn recombine_hint(element_type: i64) -> String {
    let high_order = match element_type {
        8 | 26 | 27 => Some(("line", [8, 26, 27].iter().position(|&t| t == element_type).map_or(2, |i| i + 2))),
        10 | 36 | 37 => Some(("quad", [10, 36, 37].iter().position(|&t| t == element_type).map_or(2, |i| i + 2))),
        12 | 92 | 93 => Some(("hexahedron", [12, 92, 93].iter().position(|&t| t == element_type).map_or(2, |i| i + 2))),
        14 | 118 | 119 => Some(("pyramid", [14, 118, 119].iter().position(|&t| t == element_type).map_or(2, |i| i + 2))),
        16 => Some(("serendipity quad", 2)),
        17 => Some(("serendipity hexahedron", 2)),
        _ => None,
    };
    if let Some((shape, p)) = high_order {
        return format!(
            ". Type {element_type} is a {shape} of order {p}: `curve` takes the linear mesh and places the high-order nodes itself \
             (onto the exact shapes, certified). Give it the mesh at order 1: in Gmsh, `gmsh.model.mesh.setOrder(1)` before `gmsh.write` \
             (or `Mesh.ElementOrder = 1;` in the .geo file); `deformesh quality` reads and certifies meshes of order 1 to 4 as they are"
        );
    }
    match element_type {
        20 | 22 | 24 | 25 => ". Serendipity and incomplete triangles are not read: give `curve` the linear mesh (type 2)".into(),
        19 => ". Type 19 is the 13-node (serendipity) pyramid: give `curve` the linear mesh (type 7)".into(),
        18 => ". Type 18 is the 15-node (serendipity) prism: give `curve` the linear mesh (type 6)".into(),
        _ => String::new(),
    }
}

/// True when `bytes` start like a binary MSH 4.1 file.
pub fn is_binary(bytes: &[u8]) -> bool {
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(64)]);
    head.split_whitespace().take(3).eq(["$MeshFormat", "4.1", "1"])
}

/// The bytes of the file at `path`.
fn read_file(path: &Path) -> Result<Vec<u8>, MshError> {
    std::fs::read(path).map_err(|source| MshError::Io { path: path.to_owned(), source })
}

/// Reads an MSH 4.1 file, ASCII or binary (see [`parse_msh`]).
pub fn read_msh(path: &Path) -> Result<QuadMesh, MshError> {
    parse_msh(read_file(path)?)
}

/// Parses an MSH 4.1 file (ASCII text or binary bytes) of 2-node lines
/// (boundary edges), 4-node quads (cells) and points (skipped) into a
/// quad mesh; z must be 0 and is dropped. Nodes keep file order and are
/// renumbered from 0; cells and edges are ordered by element tag and keep
/// the file's node order. Sections other than `$MeshFormat`,
/// `$PhysicalNames`, `$Entities`, `$Nodes` and `$Elements` are skipped.
pub fn parse_msh(bytes: impl AsRef<[u8]>) -> Result<QuadMesh, MshError> {
    Ok(parse_msh_tagged(bytes)?.0)
}

/// [`parse_msh`], with the element tag of every cell in the file (cell
/// `c` is element `tags[c]`): messages name elements as the file does.
pub fn parse_msh_tagged(bytes: impl AsRef<[u8]>) -> Result<(QuadMesh, Vec<u64>), MshError> {
    read::parse(bytes.as_ref(), LINEAR[0])?.plane_mesh()
}

/// Reads an MSH 4.1 hex mesh file, ASCII or binary (see [`parse_hex_msh`]).
pub fn read_hex_msh(path: &Path) -> Result<HexMesh, MshError> {
    parse_hex_msh(read_file(path)?)
}

/// Parses an MSH 4.1 file into a hex mesh: 8-node hexes (cells), 4-node
/// quads (boundary faces); lines and points are skipped. Otherwise as
/// [`parse_msh`].
pub fn parse_hex_msh(bytes: impl AsRef<[u8]>) -> Result<HexMesh, MshError> {
    Ok(parse_hex_msh_tagged(bytes)?.0)
}

/// [`parse_hex_msh`], with the element tag of every cell in the file.
pub fn parse_hex_msh_tagged(bytes: impl AsRef<[u8]>) -> Result<(HexMesh, Vec<u64>), MshError> {
    read::parse(bytes.as_ref(), LINEAR[1])?.solid_mesh()
}

impl<const D: usize> CurvedMesh<D> {
    /// Reads an MSH 4.1 file, ASCII or binary (see [`CurvedMesh::parse_msh`]).
    pub fn read_msh(path: &Path) -> Result<CurvedMesh<D>, MshError> {
        Self::parse_msh(read_file(path)?)
    }

    /// Parses an MSH 4.1 file of Lagrange quads (`D = 2`: types 3, 10, 36,
    /// 37, boundary lines 1, 8, 26, 27) or hexes (`D = 3`: types 5, 12, 92,
    /// 93, boundary quads 3, 10, 36, 37) of one order into a mesh with
    /// [`crate::mesh::element::Spacing::Equispaced`] nodes in tensor order.
    /// Otherwise as [`parse_msh`] and [`parse_hex_msh`].
    pub fn parse_msh(bytes: impl AsRef<[u8]>) -> Result<CurvedMesh<D>, MshError> {
        Ok(Self::parse_msh_tagged(bytes)?.0)
    }

    /// [`CurvedMesh::parse_msh`], with the element tag of every cell.
    pub fn parse_msh_tagged(bytes: impl AsRef<[u8]>) -> Result<(CurvedMesh<D>, Vec<u64>), MshError> {
        read::parse(bytes.as_ref(), CURVED[D.clamp(2, 3) - 2])?.curved_mesh()
    }
}

/// The mesh an MSH file holds, of any kinds and order (p = 1 is the
/// linear mesh), by its dimension.
#[derive(Clone, Debug, PartialEq)]
pub enum AnyMesh {
    /// Quads, triangles or both.
    Plane(CurvedMesh<2>),
    /// Hexes, tetrahedra, prisms and pyramids, of one kind or several.
    Solid(CurvedMesh<3>),
}

/// A mesh read by [`parse_any`], with the file's tags for messages.
#[derive(Clone, Debug, PartialEq)]
pub struct Tagged {
    /// The mesh.
    pub mesh: AnyMesh,
    /// Cell `c` is element `cell_tags[c]` of the file.
    pub cell_tags: Vec<u64>,
    /// Node `i` is node `node_tags[i]` of the file.
    pub node_tags: Vec<u64>,
    /// Everything else the file says (groups, entities, periodicity).
    pub layout: crate::io::layout::Layout,
}

/// Parses an MSH 4.1 file (ASCII or binary) into the mesh it holds: the
/// first element block of the highest dimension (2 at least) sets the
/// dimension and the order. A file without cells, or with cells and
/// boundary elements of several orders, is refused. `linear_only`
/// refuses elements of order > 1.
pub fn parse_any(bytes: &[u8], linear_only: bool) -> Result<Tagged, MshError> {
    read_any(bytes, linear_only, false)
}

/// Checks that the cells and boundary elements of the linear mesh in
/// `bytes` make one conforming mesh whose boundary the boundary elements
/// cover, naming the file's tags and the cause where they do not (a
/// hanging node, nodes given twice at one place, a boundary element inside
/// the mesh or on no cell, boundary edges or faces in no boundary
/// element): `curve` asks it when Algorithm 2's subdivision refuses the
/// mesh, whose message has 0-based indices only.
pub fn check_structure(bytes: &[u8]) -> Result<(), MshError> {
    read_any(bytes, true, true).map(|_| ())
}

fn read_any(bytes: &[u8], linear_only: bool, structure: bool) -> Result<Tagged, MshError> {
    let raw = read::parse(bytes, if linear_only { LINEAR[1] } else { CURVED[1] })?;
    let top = raw.blocks.iter().map(|b| b.kind.dim).max().unwrap_or(0).max(2);
    if !raw.blocks.iter().any(|b| b.kind.dim == top && !b.tags.is_empty()) {
        return Err(MshError::NoCells { at: raw.elements_at.expect("read"), found: raw.element_counts() });
    }
    let order = raw.blocks.iter().find(|b| b.kind.dim == top).map_or(1, |b| b.kind.order);
    // (the linear reader refuses every element of order > 1 as it reads)
    if let Some(b) = raw.blocks.iter().find(|b| b.kind.dim + 1 >= top && !b.tags.is_empty() && b.kind.order != order) {
        return Err(MshError::MixedOrders { at: b.at, order, found: b.kind.order });
    }
    let (mesh, cell_tags) = match (top, order) {
        (3, 1) => raw.linear_solid().map(|(m, t)| (AnyMesh::Solid(m), t))?,
        (3, _) => raw.curved_mesh().map(|(m, t)| (AnyMesh::Solid(m), t))?,
        (_, 1) => raw.linear_plane().map(|(m, t)| (AnyMesh::Plane(m), t))?,
        _ => raw.curved_mesh().map(|(m, t)| (AnyMesh::Plane(m), t))?,
    };
    if structure {
        raw.check_structure(top)?;
    }
    Ok(Tagged { mesh, cell_tags, layout: raw.layout(), node_tags: raw.node_tags })
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests22;
