//! Gmsh MSH 4.1 ASCII files, for quad meshes ([`QuadMesh`]) and hex meshes
//! ([`HexMesh`]). Both use one layout, a dimension apart.
//!
//! Writing: every boundary part becomes an entity of the boundary dimension
//! (a curve in 2D, a surface in 3D) carrying a physical group of that
//! dimension with the part's name; all nodes and cells live on one entity of
//! the mesh dimension (a surface of quads in 2D, a volume of hexes in 3D)
//! carrying the physical group `"domain"`. Element tags run from 1: boundary
//! element `i` (edge or face) gets tag `i + 1`, cell `c` gets tag
//! `boundary.len() + c + 1`. Because the reader orders elements by tag, the
//! boundary order survives even though it is grouped by part in the file.
//!
//! Reading: linear meshes only. [`parse_msh`] reads 2-node lines (named by
//! the physical group of their curve) and 4-node quads (the cells) and drops
//! z; [`parse_hex_msh`] reads 4-node quads (boundary faces, named by the
//! physical group of their surface) and 8-node hexes (the cells), skipping
//! lines. Points are skipped by both.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use thiserror::Error;

use super::{fmt_f64, write_atomic};
use crate::mesh::{BoundaryEdge, BoundaryFace, HexMesh, Point3, QuadMesh};

/// Name of the physical group that holds all cells (dimension 2 for quad
/// meshes, 3 for hex meshes).
pub const DOMAIN_NAME: &str = "domain";

/// How to turn another MSH flavour into one this reader accepts.
const RESAVE_HINT: &str =
    "re-save it as ASCII MSH 4.1, e.g. `gmsh IN.msh -save -format msh41 -o OUT.msh`";

/// Errors of reading or writing MSH files. Parse errors carry the 1-based
/// line number where the offending item starts.
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
    #[error("line {line}: file truncated: expected {expected}")]
    Truncated {
        /// Last line of the file.
        line: usize,
        /// What was expected next.
        expected: String,
    },
    /// A token did not have the expected form.
    #[error("line {line}: expected {expected}, found {}", shown(found, "`"))]
    Syntax {
        /// Line of the token.
        line: usize,
        /// What was expected.
        expected: String,
        /// The token found.
        found: String,
    },
    /// A version other than 4.1 (e.g. MSH 2.2).
    #[error("line {line}: MSH version {} is not supported: {RESAVE_HINT}", shown(version, ""))]
    UnsupportedVersion {
        /// Line of the version number.
        line: usize,
        /// The version found.
        version: String,
    },
    /// A binary MSH file.
    #[error("line {line}: binary MSH not supported yet: {RESAVE_HINT}")]
    Binary {
        /// Line of the file-type flag.
        line: usize,
    },
    /// A section header announced another number of items than it holds.
    #[error("line {line}: {what}: the header says {expected}, the blocks hold {found}")]
    CountMismatch {
        /// Line of the section header.
        line: usize,
        /// What was counted.
        what: &'static str,
        /// Count from the header.
        expected: u64,
        /// Count found.
        found: u64,
    },
    /// An element type the reader cannot store (e.g. a triangle, or a hex
    /// in a quad mesh).
    #[error("line {line}: unsupported element type {element_type} ({accepted}){}", recombine_hint(*element_type))]
    UnknownElementType {
        /// Line of the element block header.
        line: usize,
        /// The element types this reader accepts, as a phrase.
        accepted: &'static str,
        /// The MSH element type number.
        element_type: i64,
    },
    /// A NaN or infinite node coordinate.
    #[error("line {line}: node {tag} has a non-finite coordinate `{value}`")]
    NonFinite {
        /// Line of the coordinates.
        line: usize,
        /// Node tag.
        tag: u64,
        /// The coordinate as written.
        value: String,
    },
    /// An element refers to a node tag that no node block defined.
    #[error("line {line}: element {element} refers to unknown node tag {tag}")]
    UnknownNode {
        /// Line of the element.
        line: usize,
        /// Element tag.
        element: u64,
        /// The undefined node tag.
        tag: u64,
    },
    /// The same node tag defined twice.
    #[error("line {line}: node tag {tag} is defined twice")]
    DuplicateNode {
        /// Line of the second definition.
        line: usize,
        /// The node tag.
        tag: u64,
    },
    /// A node of a 2D mesh off the plane z = 0: dropping z would move it.
    #[error("line {line}: node {tag} has z = {z}, but a quad (2D) mesh must lie in the plane z = 0 (move or project the mesh there)")]
    OffPlane {
        /// Line of the coordinates.
        line: usize,
        /// Node tag.
        tag: u64,
        /// Its z.
        z: f64,
    },
    /// A required section is absent.
    #[error("missing section ${0}")]
    MissingSection(&'static str),
    /// The mesh to write is inconsistent.
    #[error("cannot write mesh: {0}")]
    InvalidMesh(String),
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

/// For triangles, tetrahedra, prisms and pyramids: what to do instead.
/// Gmsh makes them by default, so this is the usual first failure.
fn recombine_hint(element_type: i64) -> &'static str {
    match element_type {
        2 | 9 | 20..=25 | 4 | 11 | 29..=33 | 6 | 13 | 18 | 7 | 14 | 19 => {
            ". Triangles, tetrahedra, prisms and pyramids are not supported yet: deformesh takes quad and hex meshes. \
             In Gmsh, recombine: for all quads put `Mesh.RecombineAll = 1;` and `Mesh.SubdivisionAlgorithm = 1;` in the .geo file \
             (or pass `-setnumber Mesh.RecombineAll 1 -setnumber Mesh.SubdivisionAlgorithm 1`), \
             for all hexes `Mesh.SubdivisionAlgorithm = 2;` (or extrude a quad mesh with `Recombine`); see the README"
        }
        _ => "",
    }
}

// ---------------------------------------------------------------- writing

/// The mesh as MSH 4.1 ASCII text (layout in the module docs).
///
/// The mesh is assumed valid; [`write_msh`] checks that first. Coordinates
/// are printed with round-trip precision, so reading gives the same bits.
pub fn msh_string(mesh: &QuadMesh) -> String {
    Layout::quad(mesh).to_msh()
}

/// Checks `mesh` and writes it atomically to `path` as MSH 4.1 ASCII.
pub fn write_msh(path: &Path, mesh: &QuadMesh) -> Result<(), MshError> {
    Layout::quad(mesh).write(path)
}

/// The hex mesh as MSH 4.1 ASCII text: boundary faces as 4-node quads
/// (type 3) on one surface per part, hexes (type 5) and all nodes on one
/// volume carrying the dimension-3 group [`DOMAIN_NAME`] (layout in the
/// module docs).
///
/// The mesh is assumed valid; [`write_hex_msh`] checks that first.
/// Coordinates are printed with round-trip precision.
pub fn hex_msh_string(mesh: &HexMesh) -> String {
    Layout::hex(mesh).to_msh()
}

/// Checks `mesh` and writes it atomically to `path` as MSH 4.1 ASCII
/// ([`hex_msh_string`]). Rejects non-finite coordinates, dangling node or
/// part indices and part names that are empty, repeated or unquotable;
/// nothing is written then.
pub fn write_hex_msh(path: &Path, mesh: &HexMesh) -> Result<(), MshError> {
    Layout::hex(mesh).write(path)
}

/// A quad or hex mesh as the writer sees it: the file layout is the same
/// for both, with every dimension one higher in 3D.
struct Layout<'a> {
    /// Dimension of the cells: 2 (quads) or 3 (hexes).
    dim: usize,
    /// Node coordinates, z = 0 in 2D.
    points: Vec<Point3>,
    /// Boundary elements (edges or faces) as `(part, nodes)`.
    boundary: Vec<(usize, &'a [usize])>,
    /// Cells as node lists.
    cells: Vec<&'a [usize]>,
    /// Names of the boundary parts.
    part_names: &'a [String],
}

impl<'a> Layout<'a> {
    /// The layout of a quad mesh.
    fn quad(mesh: &'a QuadMesh) -> Self {
        Layout {
            dim: 2,
            points: mesh.nodes.iter().map(|p| [p[0], p[1], 0.0]).collect(),
            boundary: mesh.edges.iter().map(|e| (e.part, &e.nodes[..])).collect(),
            cells: mesh.cells.iter().map(|c| &c[..]).collect(),
            part_names: &mesh.part_names,
        }
    }

    /// The layout of a hex mesh.
    fn hex(mesh: &'a HexMesh) -> Self {
        Layout {
            dim: 3,
            points: mesh.nodes.clone(),
            boundary: mesh.faces.iter().map(|f| (f.part, &f.nodes[..])).collect(),
            cells: mesh.cells.iter().map(|c| &c[..]).collect(),
            part_names: &mesh.part_names,
        }
    }

    /// MSH element type of the boundary elements: 2-node line or 4-node quad.
    fn boundary_type(&self) -> u8 {
        if self.dim == 2 {
            1
        } else {
            3
        }
    }

    /// MSH element type of the cells: 4-node quad or 8-node hexahedron.
    fn cell_type(&self) -> u8 {
        if self.dim == 2 {
            3
        } else {
            5
        }
    }

    /// What a boundary element is called in error messages.
    fn boundary_word(&self) -> &'static str {
        if self.dim == 2 {
            "boundary edge"
        } else {
            "boundary face"
        }
    }

    /// The whole file as text.
    fn to_msh(&self) -> String {
        let mut out = String::new();
        out.push_str("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
        self.push_physical_names(&mut out);
        self.push_entities(&mut out);
        self.push_nodes(&mut out);
        self.push_elements(&mut out);
        out
    }

    /// Validates, then writes the text atomically.
    fn write(&self, path: &Path) -> Result<(), MshError> {
        self.validate()?;
        write_atomic(path, self.to_msh().as_bytes()).map_err(|source| MshError::Io {
            path: path.to_owned(),
            source,
        })
    }

    /// Rejects what would make an unreadable or lossy file: non-finite
    /// coordinates, dangling indices, and part names that cannot be quoted
    /// or that repeat (the reader identifies parts by name).
    fn validate(&self) -> Result<(), MshError> {
        let bad = |msg: String| Err(MshError::InvalidMesh(msg));
        let n = self.points.len();
        if let Some(i) = self
            .points
            .iter()
            .position(|p| !p.iter().all(|x| x.is_finite()))
        {
            // Only the mesh's own coordinates: a 2D node shows as [x, y].
            return bad(format!(
                "node {i} has a non-finite coordinate {:?}",
                &self.points[i][..self.dim]
            ));
        }
        if let Some(c) = self.cells.iter().position(|c| c.iter().any(|&v| v >= n)) {
            return bad(format!("cell {c} refers to a node >= {n}"));
        }
        let k = self.part_names.len();
        if let Some(e) = self
            .boundary
            .iter()
            .position(|(part, nodes)| *part >= k || nodes.iter().any(|&v| v >= n))
        {
            return bad(format!(
                "{} {e} refers to a node >= {n} or a part >= {k}",
                self.boundary_word()
            ));
        }
        check_part_names(self.part_names)
    }

    /// Groups 1..k of the boundary dimension named after the parts, then
    /// the "domain" group of the mesh dimension.
    fn push_physical_names(&self, out: &mut String) {
        let (k, d) = (self.part_names.len(), self.dim);
        put!(out, "$PhysicalNames\n{}", k + 1);
        for (i, name) in self.part_names.iter().enumerate() {
            put!(out, "{} {} \"{name}\"", d - 1, i + 1);
        }
        put!(out, "{d} {} \"{DOMAIN_NAME}\"\n$EndPhysicalNames", k + 1);
    }

    /// Entity `i + 1` of the boundary dimension per part (physical tag
    /// `i + 1`, no bounding entities) and one entity of the mesh dimension
    /// bounded by all of them (physical tag `k + 1`).
    fn push_entities(&self, out: &mut String) {
        let k = self.part_names.len();
        let mut counts = [0; 4];
        counts[self.dim - 1] = k;
        counts[self.dim] = 1;
        let [c0, c1, c2, c3] = counts;
        put!(out, "$Entities\n{c0} {c1} {c2} {c3}");
        let mut part_nodes: Vec<Vec<usize>> = vec![Vec::new(); k];
        for &(part, nodes) in &self.boundary {
            part_nodes[part].extend_from_slice(nodes);
        }
        for (part, nodes) in part_nodes.iter().enumerate() {
            let bbox = self.bounding_box(nodes.iter().copied());
            put!(out, "{} {bbox} 1 {} 0", part + 1, part + 1);
        }
        let bounding: String = (1..=k).map(|t| format!(" {t}")).collect();
        let bbox = self.bounding_box(0..self.points.len());
        put!(out, "1 {bbox} 1 {} {k}{bounding}", k + 1);
        out.push_str("$EndEntities\n");
    }

    /// `minX minY minZ maxX maxY maxZ` of the given nodes (zeros if none).
    fn bounding_box(&self, nodes: impl Iterator<Item = usize>) -> String {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in nodes.filter_map(|n| self.points.get(n)) {
            for d in 0..3 {
                lo[d] = lo[d].min(p[d]);
                hi[d] = hi[d].max(p[d]);
            }
        }
        if lo[0] > hi[0] {
            return "0 0 0 0 0 0".to_string();
        }
        let [a, b, c, d, e, f] = [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]].map(fmt_f64);
        format!("{a} {b} {c} {d} {e} {f}")
    }

    /// All nodes in one non-parametric block on the domain entity, tags 1..N.
    fn push_nodes(&self, out: &mut String) {
        let n = self.points.len();
        let (lo, hi) = tag_range(n, 1);
        put!(out, "$Nodes\n1 {n} {lo} {hi}\n{} 1 0 {n}", self.dim);
        for tag in 1..=n {
            put!(out, "{tag}");
        }
        for p in &self.points {
            put!(out, "{} {} {}", fmt_f64(p[0]), fmt_f64(p[1]), fmt_f64(p[2]));
        }
        out.push_str("$EndNodes\n");
    }

    /// One block per non-empty part, then the cell block.
    fn push_elements(&self, out: &mut String) {
        let mut per_part: Vec<Vec<usize>> = vec![Vec::new(); self.part_names.len()];
        for (e, &(part, _)) in self.boundary.iter().enumerate() {
            per_part[part].push(e);
        }
        let blocks =
            per_part.iter().filter(|b| !b.is_empty()).count() + usize::from(!self.cells.is_empty());
        let total = self.boundary.len() + self.cells.len();
        let (lo, hi) = tag_range(total, 1);
        put!(out, "$Elements\n{blocks} {total} {lo} {hi}");
        for (part, elements) in per_part.iter().enumerate().filter(|(_, b)| !b.is_empty()) {
            let header = (self.dim - 1, part + 1, self.boundary_type());
            push_element_block(
                out,
                header,
                elements.iter().map(|&e| (e + 1, self.boundary[e].1)),
            );
        }
        if !self.cells.is_empty() {
            let first = self.boundary.len() + 1;
            let cells = self.cells.iter().enumerate().map(|(c, &v)| (first + c, v));
            push_element_block(out, (self.dim, 1, self.cell_type()), cells);
        }
        out.push_str("$EndElements\n");
    }
}

/// Part names must be quotable on one line and distinct.
fn check_part_names(names: &[String]) -> Result<(), MshError> {
    for (i, name) in names.iter().enumerate() {
        if name.is_empty() || name.contains(['"', '\n', '\r']) {
            return Err(MshError::InvalidMesh(format!(
                "part name {name:?} is empty or contains a quote or line break"
            )));
        }
        if names[..i].contains(name) {
            return Err(MshError::InvalidMesh(format!(
                "part name {name:?} appears twice"
            )));
        }
    }
    Ok(())
}

/// `(min, max)` of `count` consecutive tags starting at `first`; Gmsh
/// writes `0 0` for an empty range.
fn tag_range(count: usize, first: usize) -> (usize, usize) {
    if count == 0 {
        (0, 0)
    } else {
        (first, first + count - 1)
    }
}

/// An element block: header `dim entity type count`, then one line
/// `tag node+1 ...` per element (MSH node tags start at 1).
fn push_element_block<'e>(
    out: &mut String,
    (dim, entity, element_type): (usize, usize, u8),
    elements: impl ExactSizeIterator<Item = (usize, &'e [usize])>,
) {
    put!(out, "{dim} {entity} {element_type} {}", elements.len());
    for (tag, nodes) in elements {
        let _ = write!(out, "{tag}");
        for v in nodes {
            let _ = write!(out, " {}", v + 1);
        }
        out.push('\n');
    }
}

// ---------------------------------------------------------------- reading

/// The dimension and cell element type of an MSH 4.1 ASCII file, by a
/// light scan of its element block headers (None if it does not scan:
/// the reader then gives the precise error).
pub fn cell_type_of(text: &str) -> Option<(usize, i64)> {
    let mut lines = text.lines().skip_while(|l| l.trim() != "$Elements").skip(1);
    let blocks: usize = lines.next()?.split_whitespace().next()?.parse().ok()?;
    let mut best: Option<(usize, i64)> = None;
    for _ in 0..blocks {
        let h: Vec<i64> = lines.next()?.split_whitespace().map(|t| t.parse().ok()).collect::<Option<_>>()?;
        let (dim, ty, count) = (*h.first()? as usize, *h.get(2)?, *h.get(3)? as usize);
        if best.is_none_or(|b| dim > b.0) {
            best = Some((dim, ty));
        }
        for _ in 0..count {
            lines.next()?;
        }
    }
    best
}

/// The node tags of ASCII MSH 4.1 text in file order, i.e. indexed like
/// the nodes of [`parse_msh`] and [`parse_hex_msh`] (None if the `$Nodes`
/// section does not scan: only for messages).
pub fn node_tags(text: &str) -> Option<Vec<u64>> {
    let mut lines = text.lines().skip_while(|l| l.trim() != "$Nodes").skip(1);
    let blocks: usize = lines.next()?.split_whitespace().next()?.parse().ok()?;
    let mut tags = Vec::new();
    for _ in 0..blocks {
        let count: usize = lines.next()?.split_whitespace().nth(3)?.parse().ok()?;
        for _ in 0..count {
            tags.push(lines.next()?.trim().parse().ok()?);
        }
        // the coordinate lines
        for _ in 0..count {
            lines.next()?;
        }
    }
    Some(tags)
}

/// Reads an ASCII MSH 4.1 file (see [`parse_msh`]).
pub fn read_msh(path: &Path) -> Result<QuadMesh, MshError> {
    parse_msh(&read_text(path)?)
}

/// Parses ASCII MSH 4.1 text into a mesh.
///
/// Nodes keep file order and are renumbered from 0 (tags may have gaps);
/// cells and boundary edges are ordered by element tag, quads keep the
/// node order of the file. Boundary parts are the dimension-1 physical
/// names in order of physical tag, followed by `curve<tag>` for lines on
/// curves without a named dimension-1 group. Sections other than
/// `$MeshFormat`, `$PhysicalNames`, `$Entities`, `$Nodes` and `$Elements`
/// are skipped.
pub fn parse_msh(text: &str) -> Result<QuadMesh, MshError> {
    parse_raw(text, QUAD_TYPES)?.into_quad_mesh()
}

/// [`parse_msh`], with the element tag of every cell in the file (cell
/// `c` is element `tags[c]`): messages name elements as the file does.
pub fn parse_msh_tagged(text: &str) -> Result<(QuadMesh, Vec<u64>), MshError> {
    let raw = parse_raw(text, QUAD_TYPES)?;
    let tags = sorted_tags(raw.quads.iter().map(|q| q.0));
    Ok((raw.into_quad_mesh()?, tags))
}

/// [`parse_hex_msh`], with the element tag of every cell in the file.
pub fn parse_hex_msh_tagged(text: &str) -> Result<(HexMesh, Vec<u64>), MshError> {
    let raw = parse_raw(text, HEX_TYPES)?;
    let tags = sorted_tags(raw.hexes.iter().map(|h| h.0));
    Ok((raw.into_hex_mesh()?, tags))
}

/// Tags in the order the readers put cells: by tag.
fn sorted_tags(tags: impl Iterator<Item = u64>) -> Vec<u64> {
    let mut v: Vec<u64> = tags.collect();
    v.sort_unstable();
    v
}

/// Reads an ASCII MSH 4.1 hex mesh file (see [`parse_hex_msh`]).
pub fn read_hex_msh(path: &Path) -> Result<HexMesh, MshError> {
    parse_hex_msh(&read_text(path)?)
}

/// Parses ASCII MSH 4.1 text into a hex mesh.
///
/// Nodes keep file order and are renumbered from 0; cells (8-node hexes)
/// and boundary faces (4-node quads) are ordered by element tag and keep
/// the node order of the file. Boundary parts are the dimension-2 physical
/// names in order of physical tag, followed by `surface<tag>` for quads on
/// surfaces without a named dimension-2 group. Lines and points are
/// skipped; any other element type (e.g. triangles, prisms) is an error.
/// Errors are those of [`parse_msh`].
pub fn parse_hex_msh(text: &str) -> Result<HexMesh, MshError> {
    parse_raw(text, HEX_TYPES)?.into_hex_mesh()
}

/// The file as text, for either parser.
pub(crate) fn read_text(path: &Path) -> Result<String, MshError> {
    let bytes = std::fs::read(path).map_err(|source| MshError::Io {
        path: path.to_owned(),
        source,
    })?;
    msh_text(&bytes)
}

/// The ASCII MSH text of a file's bytes: binary MSH 4.1 is translated
/// ([`super::msh_binary`]), anything else read as text.
pub fn msh_text(bytes: &[u8]) -> Result<String, MshError> {
    if super::msh_binary::is_binary(bytes) {
        return super::msh_binary::binary_to_ascii(bytes);
    }
    // A binary file is not UTF-8; the lossy text still has a readable
    // header, so the reader can say "binary" instead of failing obscurely.
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// The element types one reader stores; others are an error.
struct ElementTypes {
    /// Accepted MSH type numbers.
    types: &'static [i64],
    /// The list for error messages.
    phrase: &'static str,
}

/// What [`parse_msh`] accepts.
const QUAD_TYPES: ElementTypes = ElementTypes {
    types: &[1, 3, 15],
    phrase: "only linear meshes: 1 = 2-node line, 3 = 4-node quad, 15 = point",
};

/// What [`parse_hex_msh`] accepts.
const HEX_TYPES: ElementTypes = ElementTypes {
    types: &[1, 3, 5, 15],
    phrase: "only linear meshes: 1 = 2-node line, 3 = 4-node quad, \
             5 = 8-node hexahedron, 15 = point",
};

/// Reads all sections of `text` into a [`RawMesh`].
fn parse_raw(text: &str, accepted: ElementTypes) -> Result<RawMesh, MshError> {
    let mut cur = Cursor::new(text);
    read_mesh_format(&mut cur)?;
    let mut raw = RawMesh::new(accepted);
    while let Some((token, line)) = cur.next_token() {
        match token {
            "$PhysicalNames" => read_physical_names(&mut cur, &mut raw)?,
            "$Entities" => read_entities(&mut cur, &mut raw)?,
            "$Nodes" => read_nodes(&mut cur, &mut raw)?,
            "$Elements" => read_elements(&mut cur, &mut raw)?,
            s if s.starts_with('$') && !s.starts_with("$End") => skip_section(&mut cur, &s[1..])?,
            s => return Err(syntax(line, "a section header like `$Nodes`", s)),
        }
    }
    raw.check_complete()?;
    Ok(raw)
}

/// What the sections say, before parts are resolved.
struct RawMesh {
    /// Element types to store.
    accepted: ElementTypes,
    /// `(dim, physical tag, name)` from `$PhysicalNames`.
    physical_names: Vec<(i64, i64, String)>,
    /// Physical tags of each `(dimension, tag)` entity.
    entity_physicals: HashMap<(usize, i64), Vec<i64>>,
    /// Node tag → index into `nodes`.
    node_index: HashMap<u64, usize>,
    nodes: Vec<Point3>,
    /// `(element tag, curve tag, nodes)` of 2-node lines.
    lines: Vec<(u64, i64, [usize; 2])>,
    /// `(element tag, surface tag, nodes)` of 4-node quads.
    quads: Vec<(u64, i64, [usize; 4])>,
    /// `(element tag, nodes)` of 8-node hexes.
    hexes: Vec<(u64, [usize; 8])>,
    /// `(line, tag, z)` of the first node off the plane z = 0.
    off_plane: Option<(usize, u64, f64)>,
    has_nodes: bool,
    has_elements: bool,
}

impl RawMesh {
    /// An empty mesh that will store the `accepted` element types.
    fn new(accepted: ElementTypes) -> Self {
        RawMesh {
            accepted,
            physical_names: Vec::new(),
            entity_physicals: HashMap::new(),
            node_index: HashMap::new(),
            nodes: Vec::new(),
            lines: Vec::new(),
            quads: Vec::new(),
            hexes: Vec::new(),
            off_plane: None,
            has_nodes: false,
            has_elements: false,
        }
    }

    /// Fails if `$Nodes` or `$Elements` never came.
    fn check_complete(&self) -> Result<(), MshError> {
        if !self.has_nodes {
            return Err(MshError::MissingSection("Nodes"));
        }
        if !self.has_elements {
            return Err(MshError::MissingSection("Elements"));
        }
        Ok(())
    }

    /// Lines become named boundary edges, quads cells; z must be 0. A
    /// line of a curve in several groups becomes one edge per group.
    fn into_quad_mesh(mut self) -> Result<QuadMesh, MshError> {
        if let Some((line, tag, z)) = self.off_plane {
            return Err(MshError::OffPlane { line, tag, z });
        }
        self.lines.sort_by_key(|l| l.0);
        self.quads.sort_by_key(|q| q.0);
        let curves = self.lines.iter().map(|l| l.1);
        let (part_names, curve_parts) = self.resolve_parts(1, curves, "curve");
        let edges = self
            .lines
            .iter()
            .flat_map(|&(_, curve, nodes)| curve_parts[&curve].iter().map(move |&part| BoundaryEdge { nodes, part }))
            .collect();
        Ok(QuadMesh {
            nodes: self.nodes.iter().map(|p| [p[0], p[1]]).collect(),
            cells: self.quads.into_iter().map(|q| q.2).collect(),
            edges,
            part_names,
        })
    }

    /// Quads become named boundary faces, hexes cells; lines are dropped.
    fn into_hex_mesh(mut self) -> Result<HexMesh, MshError> {
        self.quads.sort_by_key(|q| q.0);
        self.hexes.sort_by_key(|h| h.0);
        let surfaces = self.quads.iter().map(|q| q.1);
        let (part_names, surface_parts) = self.resolve_parts(2, surfaces, "surface");
        let faces = self
            .quads
            .iter()
            .flat_map(|&(_, surface, nodes)| surface_parts[&surface].iter().map(move |&part| BoundaryFace { nodes, part }))
            .collect();
        Ok(HexMesh {
            nodes: self.nodes,
            cells: self.hexes.into_iter().map(|h| h.1).collect(),
            faces,
            part_names,
        })
    }

    /// Part names and the parts of every entity in `entities` (of
    /// dimension `dim`, the boundary dimension): the named physical groups
    /// of that dimension by tag, then `<prefix><tag>` for entities in none
    /// of them. An entity in several named groups belongs to each.
    fn resolve_parts(
        &self,
        dim: usize,
        entities: impl Iterator<Item = i64>,
        prefix: &str,
    ) -> (Vec<String>, HashMap<i64, Vec<usize>>) {
        let mut named: Vec<&(i64, i64, String)> = self
            .physical_names
            .iter()
            .filter(|p| p.0 == dim as i64)
            .collect();
        named.sort_by_key(|p| p.1);
        let mut names: Vec<String> = Vec::new();
        let mut tag_part: HashMap<i64, usize> = HashMap::new();
        for (_, tag, name) in named {
            let part = names.iter().position(|n| n == name).unwrap_or_else(|| {
                names.push(name.clone());
                names.len() - 1
            });
            tag_part.insert(*tag, part);
        }
        let mut entity_part = HashMap::new();
        for entity in entities {
            if entity_part.contains_key(&entity) {
                continue;
            }
            let physicals = self
                .entity_physicals
                .get(&(dim, entity))
                .map(Vec::as_slice)
                .unwrap_or(&[]);
            let mut parts: Vec<usize> = Vec::new();
            for &p in physicals.iter().filter_map(|t| tag_part.get(t)) {
                if !parts.contains(&p) {
                    parts.push(p);
                }
            }
            if parts.is_empty() {
                names.push(format!("{prefix}{entity}"));
                parts.push(names.len() - 1);
            }
            entity_part.insert(entity, parts);
        }
        (names, entity_part)
    }
}

/// `$MeshFormat`: accepts only version 4.1 ASCII.
fn read_mesh_format(cur: &mut Cursor) -> Result<(), MshError> {
    cur.expect("$MeshFormat")?;
    let (version, line) = cur.token("the MSH version number")?;
    if version != "4.1" {
        return Err(MshError::UnsupportedVersion {
            line,
            version: version.to_string(),
        });
    }
    let (file_type, line) = cur.token("the file type (0 = ASCII)")?;
    match file_type {
        "0" => {}
        "1" => return Err(MshError::Binary { line }),
        s => return Err(syntax(line, "file type 0 (ASCII) or 1 (binary)", s)),
    }
    let _data_size: u64 = cur.parse("the data size")?.0;
    cur.expect("$EndMeshFormat")
}

/// `$PhysicalNames`: `count`, then `dim tag "name"` per group.
fn read_physical_names(cur: &mut Cursor, raw: &mut RawMesh) -> Result<(), MshError> {
    let count: u64 = cur.parse("the number of physical names")?.0;
    for _ in 0..count {
        let dim: i64 = cur.parse("a physical group dimension")?.0;
        let tag: i64 = cur.parse("a physical group tag")?.0;
        let name = cur.quoted("a quoted physical group name")?;
        raw.physical_names.push((dim, tag, name));
    }
    cur.expect("$EndPhysicalNames")
}

/// `$Entities`: counts of points, curves, surfaces, volumes, then one line
/// per entity. The physical tags of every entity are kept.
fn read_entities(cur: &mut Cursor, raw: &mut RawMesh) -> Result<(), MshError> {
    let mut counts = [0u64; 4];
    for (dim, c) in counts.iter_mut().enumerate() {
        *c = cur
            .parse(&format!("the number of dimension-{dim} entities"))?
            .0;
    }
    for (dim, &count) in counts.iter().enumerate() {
        for _ in 0..count {
            let (tag, physicals) = read_entity(cur, dim)?;
            raw.entity_physicals.insert((dim, tag), physicals);
        }
    }
    cur.expect("$EndEntities")
}

/// One entity line: a point is `tag x y z`, a higher entity `tag` plus a
/// bounding box; both continue with the physical tags, and higher entities
/// end with their signed bounding entities.
fn read_entity(cur: &mut Cursor, dim: usize) -> Result<(i64, Vec<i64>), MshError> {
    let tag: i64 = cur.parse(&format!("a dimension-{dim} entity tag"))?.0;
    let coords = if dim == 0 { 3 } else { 6 };
    for _ in 0..coords {
        cur.parse::<f64>("an entity coordinate")?;
    }
    let physicals = read_tag_list(cur, "physical tags")?;
    if dim > 0 {
        read_tag_list(cur, "bounding entity tags")?;
    }
    Ok((tag, physicals))
}

/// A count followed by that many integer tags.
fn read_tag_list(cur: &mut Cursor, what: &str) -> Result<Vec<i64>, MshError> {
    let count: u64 = cur.parse(&format!("the number of {what}"))?.0;
    // No capacity from the file: a corrupt count must not allocate wildly.
    let mut tags = Vec::new();
    let expected = format!("one of {count} {what}");
    for _ in 0..count {
        tags.push(cur.parse(&expected)?.0);
    }
    Ok(tags)
}

/// `$Nodes`: header `numBlocks numNodes minTag maxTag`, then blocks.
fn read_nodes(cur: &mut Cursor, raw: &mut RawMesh) -> Result<(), MshError> {
    let header_line = cur.peek_line();
    let blocks: u64 = cur.parse("the number of node blocks")?.0;
    let total: u64 = cur.parse("the number of nodes")?.0;
    cur.parse::<u64>("the minimum node tag")?;
    cur.parse::<u64>("the maximum node tag")?;
    let before = raw.nodes.len();
    for _ in 0..blocks {
        read_node_block(cur, raw)?;
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

/// One node block: `dim tag parametric count`, the tags, then per node
/// `x y z` followed by `dim` parametric values when `parametric` is 1.
fn read_node_block(cur: &mut Cursor, raw: &mut RawMesh) -> Result<(), MshError> {
    let (dim, line) = cur.parse::<u64>("a node block entity dimension")?;
    if dim > 3 {
        return Err(syntax(line, "an entity dimension 0..3", &dim.to_string()));
    }
    cur.parse::<i64>("a node block entity tag")?;
    let (parametric, line) = cur.parse::<u64>("the parametric flag")?;
    if parametric > 1 {
        return Err(syntax(
            line,
            "parametric flag 0 or 1",
            &parametric.to_string(),
        ));
    }
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
    let extra = if parametric == 1 { dim } else { 0 };
    for tag in tags {
        let (x, z_line) = read_node_coords(cur, tag, extra)?;
        if x[2] != 0.0 && raw.off_plane.is_none() {
            raw.off_plane = Some((z_line, tag, x[2]));
        }
        raw.nodes.push(x);
    }
    Ok(())
}

/// `x y z` of node `tag` plus `extra` parametric values; rejects NaN/inf.
/// Expected-item messages in per-value loops are static strings: formatting
/// one per token would dominate the time on large files.
/// Returns the coordinates and the line of z.
fn read_node_coords(cur: &mut Cursor, tag: u64, extra: u64) -> Result<(Point3, usize), MshError> {
    let mut xyz = [0.0f64; 3];
    let mut z_line = 0;
    for x in &mut xyz {
        let (text, line) = cur.token("a node coordinate")?;
        z_line = line;
        *x = text
            .parse()
            .map_err(|_| syntax(line, &format!("a coordinate of node {tag}"), text))?;
        if !x.is_finite() {
            return Err(MshError::NonFinite {
                line,
                tag,
                value: text.to_string(),
            });
        }
    }
    for _ in 0..extra {
        cur.parse::<f64>("a parametric node coordinate")?;
    }
    Ok((xyz, z_line))
}

/// `$Elements`: header `numBlocks numElements minTag maxTag`, then blocks.
fn read_elements(cur: &mut Cursor, raw: &mut RawMesh) -> Result<(), MshError> {
    let header_line = cur.peek_line();
    if !raw.has_nodes {
        return Err(syntax(header_line, "$Nodes before $Elements", "$Elements"));
    }
    let blocks: u64 = cur.parse("the number of element blocks")?.0;
    let total: u64 = cur.parse("the number of elements")?.0;
    cur.parse::<u64>("the minimum element tag")?;
    cur.parse::<u64>("the maximum element tag")?;
    let mut found = 0;
    for _ in 0..blocks {
        found += read_element_block(cur, raw)?;
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

/// One element block `dim entityTag type count` and its elements; returns
/// the number of elements read.
fn read_element_block(cur: &mut Cursor, raw: &mut RawMesh) -> Result<u64, MshError> {
    cur.parse::<u64>("an element block entity dimension")?;
    let entity: i64 = cur.parse("an element block entity tag")?.0;
    let (element_type, line) = cur.parse::<i64>("an element type")?;
    let nodes_per_element = match element_type {
        1 => 2,
        3 => 4,
        5 => 8,
        15 => 1,
        _ => 0,
    };
    if nodes_per_element == 0 || !raw.accepted.types.contains(&element_type) {
        return Err(MshError::UnknownElementType {
            line,
            accepted: raw.accepted.phrase,
            element_type,
        });
    }
    let count: u64 = cur.parse("the number of elements in the block")?.0;
    for _ in 0..count {
        let (tag, line) = cur.parse::<u64>("an element tag")?;
        let mut nodes = [0usize; 8];
        for v in nodes.iter_mut().take(nodes_per_element) {
            let node: u64 = cur.parse("a node tag of an element")?.0;
            *v = *raw.node_index.get(&node).ok_or(MshError::UnknownNode {
                line,
                element: tag,
                tag: node,
            })?;
        }
        let [a, b, c, d, ..] = nodes;
        match element_type {
            1 => raw.lines.push((tag, entity, [a, b])),
            3 => raw.quads.push((tag, entity, [a, b, c, d])),
            5 => raw.hexes.push((tag, nodes)),
            _ => {} // points carry no information the mesh keeps
        }
    }
    Ok(count)
}

/// Skips an unknown section up to its `$End<name>` line.
fn skip_section(cur: &mut Cursor, name: &str) -> Result<(), MshError> {
    let end = format!("$End{name}");
    loop {
        let (token, _) = cur.token(&end)?;
        if token == end {
            return Ok(());
        }
    }
}

/// A syntax error at `line`.
fn syntax(line: usize, expected: &str, found: &str) -> MshError {
    MshError::Syntax {
        line,
        expected: expected.to_string(),
        found: found.to_string(),
    }
}

/// Whitespace-separated tokens of the text, with line numbers.
struct Cursor<'a> {
    text: &'a str,
    pos: usize,
    /// 1-based line of `pos`.
    line: usize,
}

impl<'a> Cursor<'a> {
    fn new(text: &'a str) -> Self {
        Cursor {
            text,
            pos: 0,
            line: 1,
        }
    }

    /// Moves past whitespace, counting line breaks.
    fn skip_whitespace(&mut self) {
        let bytes = self.text.as_bytes();
        while let Some(&b) = bytes.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
    }

    /// Line of the next token (or of the end of the file).
    fn peek_line(&mut self) -> usize {
        self.skip_whitespace();
        self.line
    }

    /// The next token and its line, or `None` at the end.
    fn next_token(&mut self) -> Option<(&'a str, usize)> {
        self.skip_whitespace();
        let rest = &self.text[self.pos..];
        if rest.is_empty() {
            return None;
        }
        let len = rest
            .find(|c: char| c.is_ascii_whitespace())
            .unwrap_or(rest.len());
        self.pos += len;
        Some((&rest[..len], self.line))
    }

    /// The next token; a truncation error naming `expected` at the end.
    fn token(&mut self, expected: &str) -> Result<(&'a str, usize), MshError> {
        // At the end, name the last line of the file rather than the empty
        // "line" after its final line break.
        self.next_token().ok_or_else(|| MshError::Truncated {
            line: self.text.lines().count().max(1),
            expected: expected.to_string(),
        })
    }

    /// The next token parsed as `T`, and its line.
    fn parse<T: FromStr>(&mut self, expected: &str) -> Result<(T, usize), MshError> {
        let (text, line) = self.token(expected)?;
        text.parse()
            .map(|v| (v, line))
            .map_err(|_| syntax(line, expected, text))
    }

    /// Requires the next token to be exactly `word`.
    fn expect(&mut self, word: &str) -> Result<(), MshError> {
        let (text, line) = self.token(word)?;
        if text == word {
            Ok(())
        } else {
            Err(syntax(line, word, text))
        }
    }

    /// A double-quoted string on one line (it may contain spaces).
    fn quoted(&mut self, expected: &str) -> Result<String, MshError> {
        self.skip_whitespace();
        let line = self.line;
        let rest = &self.text[self.pos..];
        let Some(body) = rest.strip_prefix('"') else {
            let found = rest.split_ascii_whitespace().next();
            return Err(match found {
                Some(found) => syntax(line, expected, found),
                None => MshError::Truncated {
                    line,
                    expected: expected.to_string(),
                },
            });
        };
        let line_end = body.find('\n').unwrap_or(body.len());
        let Some(len) = body[..line_end].find('"') else {
            return Err(syntax(
                line,
                &format!("{expected} (closing quote)"),
                rest.lines().next().unwrap_or(""),
            ));
        };
        self.pos += len + 2;
        Ok(body[..len].to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::curved::CurvedMesh;

    /// A 5×4 box with interior and boundary nodes moved by a smooth
    /// non-affine map, and coordinates that stress round-trip printing.
    fn perturbed_box() -> QuadMesh {
        let mut m = QuadMesh::structured_box([0.0, 0.0], [2.0, 1.0], 5, 4);
        for p in &mut m.nodes {
            let [x, y] = *p;
            *p = [
                x + 0.05 * (3.0 * y).sin() * x / 3.0,
                y + 0.04 * (2.0 * x).cos() * y + 1e-17 * x,
            ];
        }
        m.nodes[0] = [-0.0, 5e-324];
        m
    }

    fn written(mesh: &QuadMesh) -> String {
        msh_string(mesh)
    }

    /// The error message for `text`, which must fail to parse.
    fn error_of(text: &str) -> String {
        parse_msh(text)
            .expect_err("bad input must be rejected")
            .to_string()
    }

    #[test]
    fn round_trip_is_identical() {
        let m = perturbed_box();
        let back = parse_msh(&written(&m)).unwrap();
        assert_eq!(back, m);
        for (a, b) in back.nodes.iter().zip(&m.nodes) {
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
        }
    }

    #[test]
    fn file_round_trip_and_layout() {
        let m = perturbed_box();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("box.msh");
        write_msh(&path, &m).unwrap();
        assert_eq!(read_msh(&path).unwrap(), m);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with(
            "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n5\n1 1 \"left\"\n"
        ));
        assert!(text.contains("2 5 \"domain\"\n$EndPhysicalNames\n$Entities\n0 4 1 0\n"));
        // 18 edges and 20 quads: 5 blocks, tags 1..38
        assert!(text.contains("$Elements\n5 38 1 38\n1 1 1 4\n"));
    }

    #[test]
    fn write_rejects_invalid_meshes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.msh");
        let mut m = perturbed_box();
        m.nodes[3][1] = f64::NAN;
        assert!(write_msh(&path, &m)
            .unwrap_err()
            .to_string()
            .contains("node 3"));
        let mut m = perturbed_box();
        m.edges[0].part = 9;
        assert!(matches!(
            write_msh(&path, &m),
            Err(MshError::InvalidMesh(_))
        ));
        let mut m = perturbed_box();
        m.part_names[1] = "left".into();
        assert!(write_msh(&path, &m)
            .unwrap_err()
            .to_string()
            .contains("twice"));
        assert!(!path.exists());
    }

    #[test]
    fn reads_parametric_blocks_gaps_points_and_unnamed_curves() {
        let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
            $PhysicalNames\n1\n1 7 \"wall side\"\n$EndPhysicalNames\n\
            $Entities\n1 2 1 0\n1 0 0 0 0\n\
            3 0 0 0 1 0 0 1 7 2 1 -1\n4 0 0 0 0 1 0 0 0\n\
            1 0 0 0 1 1 0 0 2 3 4\n$EndEntities\n\
            $Nodes\n3 4 2 40\n0 1 0 1\n2\n0 0 0\n\
            1 3 1 1\n10\n1 0 0 0.5\n\
            2 1 1 2\n20\n40\n1 1 0 0.1 0.2\n0 1 0 0.3 0.4\n$EndNodes\n\
            $Elements\n4 5 1 9\n0 1 15 1\n9 2\n1 3 1 1\n5 2 10\n\
            1 4 1 1\n4 40 2\n2 1 3 2\n2 2 10 20 40\n1 40 20 10 2\n$EndElements\n";
        let m = parse_msh(text).unwrap();
        assert_eq!(
            m.nodes,
            vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
        );
        // ordered by element tag, orientation as in the file
        assert_eq!(m.cells, vec![[3, 2, 1, 0], [0, 1, 2, 3]]);
        assert_eq!(
            m.part_names,
            vec!["wall side".to_string(), "curve4".to_string()]
        );
        assert_eq!(
            m.edges,
            vec![
                BoundaryEdge {
                    nodes: [3, 0],
                    part: 1
                },
                BoundaryEdge {
                    nodes: [0, 1],
                    part: 0
                }
            ]
        );
    }

    #[test]
    fn reads_the_real_gmsh_file() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cylinder_bl_coarse.msh");
        let text = std::fs::read_to_string(&path).unwrap();
        let header = |section: &str| -> Vec<usize> {
            let at = text.find(section).unwrap() + section.len();
            text[at..]
                .lines()
                .nth(1)
                .unwrap()
                .split_whitespace()
                .map(|t| t.parse().unwrap())
                .collect()
        };
        let m = read_msh(&path).unwrap();
        assert_eq!(m.num_nodes(), header("$Nodes")[1]);
        assert_eq!(m.num_cells() + m.edges.len(), header("$Elements")[1]);
        assert_eq!(
            m.part_names,
            vec!["wall".to_string(), "farfield".to_string()]
        );
        let count = |p: usize| m.edges.iter().filter(|e| e.part == p).count();
        assert_eq!((count(0), count(1)), (12, 56));
        assert!(
            (0..m.num_cells()).all(|c| m.cell_area(c) > 0.0),
            "Gmsh quads are counter-clockwise"
        );
        // the square [-2,2]² minus the 12-gon inscribed in the r = 0.5 circle
        let expected = 16.0 - 0.5 * 12.0 * 0.25 * (std::f64::consts::PI / 6.0).sin();
        assert!((m.area() - expected).abs() < 1e-12, "area {}", m.area());
    }

    /// A valid 1×1 box file with the first occurrence of `from` replaced
    /// by `to`, and the 1-based line where `to` starts.
    fn corrupted(from: &str, to: &str) -> (String, usize) {
        let text = written(&QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 1, 1));
        let at = text
            .find(from)
            .unwrap_or_else(|| panic!("{from:?} not in {text}"));
        let line = text[..at].matches('\n').count() + 1 + usize::from(from.starts_with('\n'));
        (text.replacen(from, to, 1), line)
    }

    /// Asserts that the corrupted file fails with a message naming the line
    /// and containing every one of `words`.
    fn assert_rejected(from: &str, to: &str, words: &[&str]) {
        let (text, line) = corrupted(from, to);
        let msg = error_of(&text);
        assert!(
            msg.starts_with(&format!("line {line}:")),
            "expected line {line}: {msg}"
        );
        for w in words {
            assert!(msg.contains(w), "{w:?} missing from: {msg}");
        }
    }

    #[test]
    fn rejects_old_and_binary_formats() {
        assert_rejected("4.1 0 8", "2.2 0 8", &["version 2.2", "-format msh41"]);
        assert_rejected("4.1 0 8", "4 0 8", &["version 4 "]);
        assert_rejected(
            "4.1 0 8",
            "4.1 1 8\n\u{1}\0\0\0",
            &["binary MSH not supported yet"],
        );
        assert_eq!(error_of(""), "line 1: file truncated: expected $MeshFormat");
    }

    #[test]
    fn rejects_truncated_files() {
        let text = written(&QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 2, 2));
        let cut = &text[..text.find("$EndNodes").unwrap() - 20];
        let msg = error_of(cut);
        let last_line = cut.lines().count();
        assert!(
            msg.starts_with(&format!("line {last_line}: file truncated"))
                && msg.contains("coordinate"),
            "{msg}"
        );
        // Every prefix fails cleanly, never panics.
        for end in 0..text.len() - 1 {
            assert!(
                parse_msh(&text[..end]).is_err(),
                "prefix of length {end} accepted"
            );
        }
    }

    #[test]
    fn rejects_wrong_counts() {
        // the header claims 5 nodes, the one block holds 4
        assert_rejected(
            "\n1 4 1 4\n",
            "\n1 5 1 4\n",
            &["number of nodes", "says 5", "hold 4"],
        );
        assert_rejected(
            "\n5 5 1 5\n",
            "\n5 6 1 5\n",
            &["number of elements", "says 6", "hold 5"],
        );
        // a block claiming one element too many runs into the section end
        let (text, _) = corrupted("\n2 1 3 1\n", "\n2 1 3 2\n");
        let end_line = text.lines().position(|l| l == "$EndElements").unwrap() + 1;
        let msg = error_of(&text);
        assert!(
            msg.starts_with(&format!(
                "line {end_line}: expected an element tag, found `$EndElements`"
            )),
            "{msg}"
        );
        // a block claiming one node too few no longer adds up to the header
        let (text, block_line) = corrupted("\n2 1 0 4\n", "\n2 1 0 3\n");
        let msg = error_of(&text);
        assert!(
            msg.starts_with(&format!("line {}: number of nodes", block_line - 1)),
            "{msg}"
        );
    }

    #[test]
    fn rejects_unknown_element_types() {
        assert_rejected("\n2 1 3 1\n", "\n2 1 2 1\n", &["element type 2"]);
    }

    #[test]
    fn rejects_non_finite_coordinates() {
        for bad in ["NaN", "inf", "-inf", "infinity"] {
            assert_rejected(
                "\n1 0 0\n",
                &format!("\n1 {bad} 0\n"),
                &["non-finite", "node 2", bad],
            );
        }
    }

    #[test]
    fn rejects_a_2d_node_off_the_plane() {
        // node 2 at (1, 0) given z = 0.25: not dropped silently
        assert_rejected("\n1 0 0\n", "\n1 0 0.25\n", &["node 2", "z = 0.25", "z = 0"]);
        let (text, _) = corrupted("\n1 0 0\n", "\n1 0 0.25\n");
        let e = CurvedMesh::<2>::parse_msh(&text).err().expect("off the plane").to_string();
        assert!(e.contains("node 2 has z = 0.25"), "{e}");
    }

    /// The cylinder's wall curve also in a second group `ring` (listed
    /// first on the entity): its lines belong to both groups.
    #[test]
    fn an_entity_in_two_groups_belongs_to_both() {
        let text = include_str!("../../tests/data/cylinder_bl_coarse.msh")
            .replacen("3\n1 1 \"wall\"", "4\n1 4 \"ring\"\n1 1 \"wall\"", 1)
            .replacen("1e-07 1 1 2 5 -5", "1e-07 2 4 1 2 5 -5", 1);
        let m = parse_msh(&text).unwrap();
        assert_eq!(m.part_names, ["wall", "farfield", "ring"]);
        let count = |part: usize| m.edges.iter().filter(|e| e.part == part).count();
        assert_eq!((count(0), count(2)), (12, 12));
        let wall: Vec<[usize; 2]> = m.edges.iter().filter(|e| e.part == 0).map(|e| e.nodes).collect();
        let ring: Vec<[usize; 2]> = m.edges.iter().filter(|e| e.part == 2).map(|e| e.nodes).collect();
        assert_eq!(wall, ring);
    }

    #[test]
    fn rejects_unknown_node_tags_and_garbage() {
        assert_rejected(
            "\n5 1 2 4 3\n",
            "\n5 1 2 44 3\n",
            &["element 5", "unknown node tag 44"],
        );
        assert_rejected("\n2 1 0 4\n", "\n2 1 x 4\n", &["parametric flag", "`x`"]);
        assert_rejected("\"left\"", "left", &["quoted", "`left`"]);
        assert_rejected("\"left\"", "\"left", &["closing quote"]);
        assert_rejected("$EndNodes", "$EndNode", &["expected $EndNodes"]);
        assert_rejected("$Elements", "Elements", &["section header"]);
    }

    // ------------------------------------------------------------ hex meshes

    /// A 3×2×2 brick moved by a smooth non-affine map, with coordinates
    /// that stress round-trip printing.
    fn perturbed_brick() -> HexMesh {
        let mut m = HexMesh::structured_box([0.0; 3], [1.5, 1.0, 1.0], [3, 2, 2]);
        for p in &mut m.nodes {
            let [x, y, z] = *p;
            *p = [
                x + 0.04 * (2.0 * y).sin() * z,
                y + 0.03 * (3.0 * z).cos() * x + 1e-17 * x,
                z + 0.05 * x * y,
            ];
        }
        m.nodes[0] = [-0.0, 5e-324, 1e300];
        m
    }

    #[test]
    fn hex_round_trip_is_identical() {
        let m = perturbed_brick();
        let back = parse_hex_msh(&hex_msh_string(&m)).unwrap();
        assert_eq!(back, m);
        for (a, b) in back.nodes.iter().zip(&m.nodes) {
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
        }
    }

    #[test]
    fn hex_file_round_trip_and_layout() {
        let m = perturbed_brick();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("brick.msh");
        write_hex_msh(&path, &m).unwrap();
        assert_eq!(read_hex_msh(&path).unwrap(), m);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with(
            "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n7\n2 1 \"xmin\"\n"
        ));
        assert!(text.contains("3 7 \"domain\"\n$EndPhysicalNames\n$Entities\n0 0 6 1\n"));
        // the volume is bounded by the six surfaces
        assert!(text.contains(" 1 7 6 1 2 3 4 5 6\n$EndEntities\n"));
        assert!(text.contains("$Nodes\n1 36 1 36\n3 1 0 36\n1\n"));
        // 2·(2·2 + 3·2 + 3·2) = 32 faces in 6 blocks, 12 hexes: tags 1..44
        assert!(text.contains("$Elements\n7 44 1 44\n2 1 3 4\n1 "));
        assert!(text.contains("\n3 1 5 12\n33 1 2 6 5 13 14 18 17\n"));
        // the 2D reader refuses the hexes, naming what it accepts
        let msg = parse_msh(&text).unwrap_err().to_string();
        assert!(
            msg.contains("element type 5 (only linear meshes: 1 = 2-node line"),
            "{msg}"
        );
    }

    #[test]
    fn hex_write_rejects_invalid_meshes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.msh");
        let mut m = perturbed_brick();
        m.nodes[5][2] = f64::INFINITY;
        let msg = write_hex_msh(&path, &m).unwrap_err().to_string();
        assert!(msg.contains("node 5") && msg.contains("inf"), "{msg}");
        let mut m = perturbed_brick();
        m.faces[3].part = 6;
        let msg = write_hex_msh(&path, &m).unwrap_err().to_string();
        assert!(msg.contains("boundary face 3"), "{msg}");
        let mut m = perturbed_brick();
        m.cells[2][7] = 36;
        let msg = write_hex_msh(&path, &m).unwrap_err().to_string();
        assert!(msg.contains("cell 2 refers to a node >= 36"), "{msg}");
        let mut m = perturbed_brick();
        m.part_names[4] = "xmax".into();
        assert!(write_hex_msh(&path, &m)
            .unwrap_err()
            .to_string()
            .contains("twice"));
        m.part_names[4] = "a\"b".into();
        assert!(matches!(
            write_hex_msh(&path, &m),
            Err(MshError::InvalidMesh(_))
        ));
        assert!(!path.exists());
    }

    #[test]
    fn hex_reader_names_unnamed_surfaces_and_skips_lines() {
        // one hex; a named surface (physical 4 "wall") with one face, an
        // unnamed surface 9 with one face, a line block and a point block
        let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
            $PhysicalNames\n2\n2 4 \"wall\"\n3 1 \"solid\"\n$EndPhysicalNames\n\
            $Entities\n0 1 2 1\n5 0 0 0 1 0 0 0 0\n\
            3 0 0 0 1 1 0 1 4 0\n9 0 0 1 1 1 1 0 0\n\
            1 0 0 0 1 1 1 1 1 2 3 9\n$EndEntities\n\
            $Nodes\n1 8 11 18\n3 1 0 8\n11\n12\n13\n14\n15\n16\n17\n18\n\
            0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n$EndNodes\n\
            $Elements\n5 5 1 20\n0 1 15 1\n20 11\n1 5 1 1\n19 11 12\n\
            3 1 5 1\n3 11 12 13 14 15 16 17 18\n\
            2 9 3 1\n2 15 16 17 18\n2 3 3 1\n7 11 14 13 12\n$EndElements\n";
        let m = parse_hex_msh(text).unwrap();
        assert_eq!(m.cells, vec![[0, 1, 2, 3, 4, 5, 6, 7]]);
        assert_eq!(m.nodes[6], [1.0, 1.0, 1.0]);
        assert_eq!(
            m.part_names,
            vec!["wall".to_string(), "surface9".to_string()]
        );
        // ordered by element tag: 2 (surface 9) before 7 (surface 3)
        assert_eq!(
            m.faces,
            vec![
                BoundaryFace {
                    nodes: [4, 5, 6, 7],
                    part: 1
                },
                BoundaryFace {
                    nodes: [0, 3, 2, 1],
                    part: 0
                }
            ]
        );
    }

    #[test]
    fn hex_reader_errors() {
        let text = hex_msh_string(&HexMesh::structured_box([0.0; 3], [1.0; 3], [1, 1, 1]));
        // triangles cannot be stored
        let bad = text.replacen("\n2 1 3 1\n", "\n2 1 2 1\n", 1);
        let line = bad.lines().position(|l| l == "2 1 2 1").unwrap() + 1;
        let msg = parse_hex_msh(&bad).unwrap_err().to_string();
        let start = format!(
            "line {line}: unsupported element type 2 (only linear meshes: 1 = 2-node \
             line, 3 = 4-node quad, 5 = 8-node hexahedron, 15 = point). Triangles, \
             tetrahedra, prisms and pyramids are not supported yet"
        );
        assert!(msg.starts_with(&start) && msg.contains("Mesh.RecombineAll = 1;"), "{msg}");
        // a hex naming a node that does not exist
        let bad = text.replacen("\n7 1 2 4 3 5 6 8 7\n", "\n7 1 2 4 3 5 6 8 70\n", 1);
        let msg = parse_hex_msh(&bad).unwrap_err().to_string();
        assert!(
            msg.ends_with("element 7 refers to unknown node tag 70"),
            "{msg}"
        );
        // every prefix fails cleanly
        for end in 0..text.len() - 1 {
            assert!(
                parse_hex_msh(&text[..end]).is_err(),
                "prefix {end} accepted"
            );
        }
    }
}
