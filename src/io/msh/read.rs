//! One reader of MSH 4.1, ASCII and binary alike. Both hold the same items
//! in the same order (Gmsh's reference manual, "MSH file format"); a binary
//! file (file type 1, data size 8) stores the numbers of `$Entities`,
//! `$Nodes` and `$Elements` as `int` (4 bytes), `size_t` (8 bytes) and
//! `double` in the writer's byte order, found from the integer 1 after the
//! format line, and everything else as text. So the section readers below
//! ask the [`Reader`] for an `int`, a `size_t` or a `double`, and only the
//! reader knows whether that is a token or bytes.

use std::collections::HashMap;
use std::str::FromStr;

use super::{syntax, types, MshError, Pos};
use crate::mesh::element::Shape;
use crate::io::layout::Entity;

/// What an element type is: its dimension, order and number of nodes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Kind {
    /// Its reference shape.
    pub shape: Shape,
    /// 0 (point) to 3 (hex).
    pub dim: usize,
    /// Lagrange order, 1 for a point.
    pub order: usize,
    /// Nodes per element ([`Shape::num_nodes`]).
    pub nodes: usize,
}

/// The kinds of element a caller can store: anything up to `max_dim` and
/// `max_order`; `phrase` lists them for error messages.
#[derive(Clone, Copy)]
pub(super) struct Accept {
    pub max_dim: usize,
    pub max_order: usize,
    pub phrase: &'static str,
}

impl Accept {
    /// The kind of MSH element type `t` if it is one of the accepted: a
    /// point (15), or a Lagrange element of the type table
    /// ([`types::MSH_TYPES`]).
    pub fn kind(&self, t: i64) -> Option<Kind> {
        let (shape, order) = types::shape_of(t)?;
        let kind = Kind { shape, dim: shape.dim(), order, nodes: shape.num_nodes(order) };
        (kind.dim <= self.max_dim && kind.order <= self.max_order).then_some(kind)
    }
}

/// One element block: its entity and type, where its header is, and its
/// elements' tags and nodes (indices into [`Raw::nodes`], in Gmsh's local
/// order, `kind.nodes` per element).
pub(super) struct Block {
    /// Tag of the entity (of the type's dimension) holding the elements.
    pub entity: i64,
    /// MSH element type.
    pub element_type: i64,
    /// What that type is.
    pub kind: Kind,
    /// Where the block header is.
    pub at: Pos,
    /// Element tags.
    pub tags: Vec<u64>,
    /// Node indices, `kind.nodes` per element.
    pub nodes: Vec<usize>,
}

/// What an MSH file says, before meshes and parts are made of it.
#[derive(Default)]
pub(super) struct Raw {
    /// `(dimension, physical tag, name)` from `$PhysicalNames`.
    pub physical_names: Vec<(i64, i64, String)>,
    /// Physical tags of each `(dimension, tag)` entity.
    pub entity_physicals: HashMap<(usize, i64), Vec<i64>>,
    /// Every entity of `$Entities`, in file order.
    pub entities: Vec<Entity>,
    /// `(dimension, tag)` of the entity of each node's block.
    pub node_entity: Vec<(usize, i64)>,
    /// `$Periodic` links, their pairs as node tags of the file.
    pub periodic: Vec<PeriodicTags>,
    /// Sections skipped, by name (`NodeData`, …).
    pub skipped: Vec<String>,
    /// Whether a node block gave parametric coordinates.
    pub parametric: bool,
    /// The file's node tags, in file order (node `i` is `node_tags[i]`).
    pub node_tags: Vec<u64>,
    /// Node tag → index into `nodes`.
    pub node_index: HashMap<u64, usize>,
    /// Node coordinates, z included.
    pub nodes: Vec<[f64; 3]>,
    /// `(position, tag, z)` of the first node off the plane z = 0.
    pub off_plane: Option<(Pos, u64, f64)>,
    /// Element blocks of accepted types, in file order.
    pub blocks: Vec<Block>,
    /// Whether `$Nodes` was read (`$Elements` needs it first).
    has_nodes: bool,
    /// Where the `$Elements` header is, once read.
    pub elements_at: Option<Pos>,
}

/// A `$Periodic` link as the file gives it.
pub(super) struct PeriodicTags {
    /// Dimension of both entities.
    pub dim: usize,
    /// The slave entity.
    pub slave: i64,
    /// Its master.
    pub master: i64,
    /// The affine map (16 values) or nothing.
    pub affine: Vec<f64>,
    /// `(slave node tag, master node tag)`.
    pub pairs: Vec<(u64, u64)>,
}

/// Reads every section of an MSH 4.1 file; element types other than the
/// `accept`ed ones are an error at their block header.
pub(super) fn parse(bytes: &[u8], accept: Accept) -> Result<Raw, MshError> {
    if let Some(format) = super::compressed(bytes) {
        return Err(MshError::Compressed(format));
    }
    let mut r = Reader::ascii(bytes);
    if r.mesh_format()? == Version::V2 {
        return super::v22::parse(bytes, accept);
    }
    let mut raw = Raw::default();
    while let Some((word, at)) = r.word() {
        match word {
            b"$PhysicalNames" => physical_names(&mut r, &mut raw)?,
            b"$Entities" => entities(r.data(), &mut raw)?,
            b"$Nodes" => nodes(r.data(), &mut raw)?,
            b"$Elements" => elements(r.data(), &mut raw, accept)?,
            b"$Periodic" => periodic(r.data(), &mut raw)?,
            w if w.starts_with(b"$") && !w.starts_with(b"$End") => {
                raw.skipped.push(lossy(&w[1..]));
                r.skip_section(&w[1..])?
            }
            w => return Err(syntax(at, "a section header like `$Nodes`", &lossy(w))),
        }
    }
    if !raw.has_nodes {
        return Err(MshError::MissingSection("Nodes"));
    }
    if raw.elements_at.is_none() {
        return Err(MshError::MissingSection("Elements"));
    }
    Ok(raw)
}

/// `$PhysicalNames`, text in both formats: `count`, then `dim tag "name"`.
pub(super) fn physical_names(r: &mut Reader, raw: &mut Raw) -> Result<(), MshError> {
    let count: u64 = r.text("the number of physical names")?.0;
    for _ in 0..count {
        let dim: i64 = r.text("a physical group dimension")?.0;
        let tag: i64 = r.text("a physical group tag")?.0;
        let name = r.quoted("a quoted physical group name")?;
        raw.physical_names.push((dim, tag, name));
    }
    r.expect("$EndPhysicalNames")
}

/// `$Entities`: counts of points, curves, surfaces, volumes, then each
/// entity: tag, a point (3) or a bounding box (6), its physical tags and,
/// above points, its signed bounding entities.
fn entities(r: &mut Reader, raw: &mut Raw) -> Result<(), MshError> {
    let mut counts = [0u64; 4];
    for (dim, c) in counts.iter_mut().enumerate() {
        *c = r.size(&format!("the number of dimension-{dim} entities"))?.0;
    }
    for (dim, &count) in counts.iter().enumerate() {
        for _ in 0..count {
            let tag = r.int(&format!("a dimension-{dim} entity tag"))?.0;
            let mut bbox = [0.0; 6];
            for c in bbox.iter_mut().take(if dim == 0 { 3 } else { 6 }) {
                *c = r.float("an entity coordinate")?.0;
            }
            if dim == 0 {
                bbox.copy_within(0..3, 3);
            }
            let physicals = tag_list(r, "physical tags")?;
            let bounding = if dim > 0 { tag_list(r, "bounding entity tags")? } else { Vec::new() };
            raw.entity_physicals.insert((dim, tag), physicals.clone());
            raw.entities.push(Entity { dim, tag, bbox, physicals, bounding });
        }
    }
    r.expect("$EndEntities")
}

/// A count followed by that many `int` tags.
fn tag_list(r: &mut Reader, what: &str) -> Result<Vec<i64>, MshError> {
    let count = r.size(&format!("the number of {what}"))?.0;
    let expected = format!("one of {count} {what}");
    // no capacity from the file: a corrupt count must not allocate wildly
    let mut tags = Vec::new();
    for _ in 0..count {
        tags.push(r.int(&expected)?.0);
    }
    Ok(tags)
}

/// `$Nodes`: header `numBlocks numNodes minTag maxTag`, then the blocks;
/// the header's count must be what the blocks hold.
fn nodes(r: &mut Reader, raw: &mut Raw) -> Result<(), MshError> {
    let at = r.at();
    let blocks = r.size("the number of node blocks")?.0;
    let total = r.size("the number of nodes")?.0;
    r.size("the minimum node tag")?;
    r.size("the maximum node tag")?;
    let before = raw.nodes.len();
    for _ in 0..blocks {
        node_block(r, raw)?;
    }
    let found = (raw.nodes.len() - before) as u64;
    if found != total {
        return Err(MshError::CountMismatch { at, what: "number of nodes", expected: total, found });
    }
    raw.has_nodes = true;
    r.expect("$EndNodes")
}

/// One node block: `dim tag parametric count`, the node tags, then per
/// node `x y z` and, if parametric, `dim` more values.
fn node_block(r: &mut Reader, raw: &mut Raw) -> Result<(), MshError> {
    let (dim, at) = r.int("a node block entity dimension")?;
    if !(0..=3).contains(&dim) {
        return Err(syntax(at, "an entity dimension 0..3", &dim.to_string()));
    }
    let entity = r.int("a node block entity tag")?.0;
    let (parametric, at) = r.int("the parametric flag")?;
    if !(0..=1).contains(&parametric) {
        return Err(syntax(at, "parametric flag 0 or 1", &parametric.to_string()));
    }
    let count = r.size("the number of nodes in the block")?.0;
    let first = raw.node_tags.len();
    for _ in 0..count {
        let (tag, at) = r.size("a node tag")?;
        if raw.node_index.insert(tag, raw.node_tags.len()).is_some() {
            return Err(MshError::DuplicateNode { at, tag });
        }
        raw.node_tags.push(tag);
        raw.node_entity.push((dim as usize, entity));
    }
    raw.parametric |= parametric == 1;
    for i in first..raw.node_tags.len() {
        let tag = raw.node_tags[i];
        let mut x = [0.0; 3];
        let mut z_at = at;
        for c in &mut x {
            (*c, z_at) = r.coordinate(tag)?;
        }
        for _ in 0..parametric * dim {
            r.float("a parametric node coordinate")?;
        }
        if x[2] != 0.0 && raw.off_plane.is_none() {
            raw.off_plane = Some((z_at, tag, x[2]));
        }
        raw.nodes.push(x);
    }
    Ok(())
}

/// `$Elements`: header `numBlocks numElements minTag maxTag`, then blocks.
fn elements(r: &mut Reader, raw: &mut Raw, accept: Accept) -> Result<(), MshError> {
    let at = r.at();
    if !raw.has_nodes {
        return Err(syntax(at, "$Nodes before $Elements", "$Elements"));
    }
    let blocks = r.size("the number of element blocks")?.0;
    let total = r.size("the number of elements")?.0;
    r.size("the minimum element tag")?;
    r.size("the maximum element tag")?;
    let mut found = 0;
    for _ in 0..blocks {
        found += element_block(r, raw, accept)?;
    }
    if found != total {
        return Err(MshError::CountMismatch { at, what: "number of elements", expected: total, found });
    }
    raw.unique_element_tags()?;
    raw.elements_at = Some(at);
    r.expect("$EndElements")
}

impl Raw {
    /// Fails on an element tag given to two elements, naming both.
    fn unique_element_tags(&self) -> Result<(), MshError> {
        let mut all: Vec<(u64, usize, usize)> = self.blocks.iter().enumerate().flat_map(|(b, block)| block.tags.iter().enumerate().map(move |(i, &t)| (t, b, i))).collect();
        all.sort_unstable();
        let Some(w) = all.windows(2).find(|w| w[0].0 == w[1].0) else { return Ok(()) };
        let nodes = |&(_, b, i): &(u64, usize, usize)| {
            let block = &self.blocks[b];
            block.nodes[i * block.kind.nodes..(i + 1) * block.kind.nodes].iter().map(|&n| self.node_tags[n].to_string()).collect::<Vec<_>>().join(" ")
        };
        Err(MshError::DuplicateElementTag { tag: w[0].0, first: self.blocks[w[0].1].at, first_nodes: nodes(&w[0]), second: self.blocks[w[1].1].at, second_nodes: nodes(&w[1]) })
    }

    /// What elements the file holds, for a message: "4 lines and 2 points".
    pub(super) fn element_counts(&self) -> String {
        let mut counts: Vec<(Shape, usize)> = Vec::new();
        for b in self.blocks.iter().filter(|b| !b.tags.is_empty()) {
            match counts.iter_mut().find(|c| c.0 == b.kind.shape) {
                Some(c) => c.1 += b.tags.len(),
                None => counts.push((b.kind.shape, b.tags.len())),
            }
        }
        let named: Vec<String> = counts
            .iter()
            .map(|&(shape, n)| {
                let name = format!("{shape:?}").to_lowercase();
                let plural = match name.strip_suffix("on") {
                    Some(stem) if name.ends_with("hedron") => format!("{stem}a"),
                    _ => format!("{name}s"),
                };
                format!("{n} {}", if n == 1 { name } else { plural })
            })
            .collect();
        match named.as_slice() {
            [] => "no elements".into(),
            [one] => one.clone(),
            [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
        }
    }
}

/// `$Periodic`: the number of links, then per link `dim tag masterTag`,
/// the number of affine values (0 or 16) and the values, the number of
/// node pairs and the pairs of node tags.
fn periodic(r: &mut Reader, raw: &mut Raw) -> Result<(), MshError> {
    let links = r.size("the number of periodic links")?.0;
    for _ in 0..links {
        let (dim, at) = r.int("a periodic entity dimension")?;
        if !(0..=3).contains(&dim) {
            return Err(syntax(at, "an entity dimension 0..3", &dim.to_string()));
        }
        let slave = r.int("a periodic entity tag")?.0;
        let master = r.int("a periodic master entity tag")?.0;
        let (count, at) = r.size("the number of affine values")?;
        if count != 0 && count != 16 {
            return Err(syntax(at, "0 or 16 affine values", &count.to_string()));
        }
        let affine = (0..count).map(|_| r.float("an affine value").map(|v| v.0)).collect::<Result<Vec<f64>, _>>()?;
        let pairs_count = r.size("the number of periodic node pairs")?.0;
        let mut pairs = Vec::new();
        for _ in 0..pairs_count {
            let (s, at) = r.size("a periodic node tag")?;
            let m = r.size("a periodic master node tag")?.0;
            for tag in [s, m] {
                if !raw.node_index.contains_key(&tag) {
                    return Err(syntax(at, "the tag of a node of $Nodes (periodic node pair)", &tag.to_string()));
                }
            }
            pairs.push((s, m));
        }
        raw.periodic.push(PeriodicTags { dim: dim as usize, slave, master, affine, pairs });
    }
    r.expect("$EndPeriodic")
}

/// One element block `dim entity type count` and its elements (`tag`, then
/// the node tags); returns the number of elements. The type fixes the
/// number of nodes, so an unknown type cannot even be skipped.
fn element_block(r: &mut Reader, raw: &mut Raw, accept: Accept) -> Result<u64, MshError> {
    r.int("an element block entity dimension")?;
    let entity = r.int("an element block entity tag")?.0;
    let (element_type, at) = r.int("an element type")?;
    let Some(kind) = accept.kind(element_type) else {
        return Err(MshError::UnknownElementType { at, accepted: accept.phrase, element_type });
    };
    let count = r.size("the number of elements in the block")?.0;
    let mut block = Block { entity, element_type, kind, at, tags: Vec::new(), nodes: Vec::new() };
    for _ in 0..count {
        let (tag, at) = r.size("an element tag")?;
        for _ in 0..kind.nodes {
            let node = r.size("a node tag of an element")?.0;
            let index = raw.node_index.get(&node).ok_or(MshError::UnknownNode { at, element: tag, tag: node })?;
            block.nodes.push(*index);
        }
        block.tags.push(tag);
    }
    raw.blocks.push(block);
    Ok(count)
}

/// Bytes for a message (never raw: [`super::shown`] hides non-text).
fn lossy(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The MSH versions read: 4.1 here, 2.x by [`super::v22`].
#[derive(PartialEq)]
enum Version {
    V41,
    V2,
}

/// The file's items in order: text tokens with their lines, or, in the
/// data of a binary file, numbers of fixed size at byte offsets.
pub(super) struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// 1-based line of `pos` (text only).
    line: usize,
    /// `Some(big endian)` once the format line said binary.
    binary: Option<bool>,
}

impl<'a> Reader<'a> {
    /// A reader of a text (ASCII) file from its start.
    pub(super) fn ascii(bytes: &'a [u8]) -> Reader<'a> {
        Reader { bytes, pos: 0, line: 1, binary: None }
    }

    /// The next word, left unread.
    pub(super) fn peek(&mut self) -> Option<&'a [u8]> {
        let (pos, line) = (self.pos, self.line);
        let word = self.word().map(|w| w.0);
        (self.pos, self.line) = (pos, line);
        word
    }

    /// `$MeshFormat`: version 4.1, ASCII (0) or binary (1) with 8-byte
    /// `size_t`, whose byte order the integer 1 that follows tells.
    /// MSH 2.x is left to [`super::v22`] right after the version.
    fn mesh_format(&mut self) -> Result<Version, MshError> {
        self.expect("$MeshFormat")?;
        let (version, at) = self.token("the MSH version number")?;
        if super::v22::is_version(version) {
            return Ok(Version::V2);
        }
        if version != b"4.1" {
            return Err(MshError::UnsupportedVersion { at, version: lossy(version) });
        }
        let (file_type, type_at) = self.token("the file type (0 = ASCII, 1 = binary)")?;
        let (size, at) = self.text::<u64>("the data size")?;
        match file_type {
            b"0" => {}
            b"1" if size == 8 => {
                self.skip_line();
                let (one, at) = self.take::<4>("the integer 1 in binary")?;
                self.binary = Some(match (i32::from_le_bytes(one), i32::from_be_bytes(one)) {
                    (1, _) => false,
                    (_, 1) => true,
                    _ => return Err(syntax(at, "the integer 1 in binary", &format!("{one:?}"))),
                });
            }
            b"1" => return Err(syntax(at, "data size 8 in a binary file", &size.to_string())),
            s => return Err(syntax(type_at, "file type 0 (ASCII) or 1 (binary)", &lossy(s))),
        }
        self.expect("$EndMeshFormat")?;
        Ok(Version::V41)
    }

    /// After a section header of a binary file, its data start on the
    /// next line: moves past the header's line break.
    fn data(&mut self) -> &mut Self {
        if self.binary.is_some() {
            self.skip_line();
        }
        self
    }

    /// Moves past the next line break.
    fn skip_line(&mut self) {
        let rest = &self.bytes[self.pos..];
        self.pos += rest.iter().position(|&b| b == b'\n').map_or(rest.len(), |k| k + 1);
    }

    /// Moves past whitespace, counting line breaks.
    pub(super) fn skip_whitespace(&mut self) {
        while let Some(&b) = self.bytes.get(self.pos).filter(|b| b.is_ascii_whitespace()) {
            self.line += usize::from(b == b'\n');
            self.pos += 1;
        }
    }

    /// Where the next item starts: its line in text, its byte offset in
    /// binary data (where whitespace is data, not a separator).
    pub(super) fn at(&mut self) -> Pos {
        match self.binary {
            Some(_) => Pos::Byte(self.pos),
            None => {
                self.skip_whitespace();
                Pos::Line(self.line)
            }
        }
    }

    /// Where the file ends, for truncation errors: its last line (not the
    /// empty one after a final line break), or its length.
    pub(super) fn end(&self) -> Pos {
        match self.binary {
            Some(_) => Pos::Byte(self.bytes.len()),
            None => {
                let breaks = self.bytes.iter().filter(|&&b| b == b'\n').count();
                let unterminated = !self.bytes.is_empty() && !self.bytes.ends_with(b"\n");
                Pos::Line((breaks + usize::from(unterminated)).max(1))
            }
        }
    }

    /// The next whitespace-separated word and where it starts, if any.
    pub(super) fn word(&mut self) -> Option<(&'a [u8], Pos)> {
        self.skip_whitespace();
        let at = if self.binary.is_some() { Pos::Byte(self.pos) } else { Pos::Line(self.line) };
        let rest = &self.bytes[self.pos..];
        let len = rest.iter().position(|b| b.is_ascii_whitespace()).unwrap_or(rest.len());
        self.pos += len;
        (len > 0).then(|| (&rest[..len], at))
    }

    /// The next word; a truncation error naming `expected` at the end.
    pub(super) fn token(&mut self, expected: &str) -> Result<(&'a [u8], Pos), MshError> {
        self.word().ok_or_else(|| MshError::Truncated { at: self.end(), expected: expected.to_string() })
    }

    /// The next word parsed as `T`.
    pub(super) fn text<T: FromStr>(&mut self, expected: &str) -> Result<(T, Pos), MshError> {
        let (word, at) = self.token(expected)?;
        let value = std::str::from_utf8(word).ok().and_then(|s| s.parse().ok());
        value.map(|v| (v, at)).ok_or_else(|| syntax(at, expected, &lossy(word)))
    }

    /// Requires the next word to be exactly `word`.
    pub(super) fn expect(&mut self, word: &str) -> Result<(), MshError> {
        let (found, at) = self.token(word)?;
        if found == word.as_bytes() {
            Ok(())
        } else {
            Err(syntax(at, word, &lossy(found)))
        }
    }

    /// `N` bytes of binary data.
    fn take<const N: usize>(&mut self, expected: &str) -> Result<([u8; N], Pos), MshError> {
        let at = Pos::Byte(self.pos);
        let bytes = self.bytes.get(self.pos..self.pos + N).ok_or_else(|| MshError::Truncated { at, expected: expected.to_string() })?;
        self.pos += N;
        Ok((bytes.try_into().expect("N bytes"), at))
    }

    /// An `int`: 4 bytes in binary data.
    fn int(&mut self, expected: &str) -> Result<(i64, Pos), MshError> {
        match self.binary {
            Some(big) => self.take(expected).map(|(b, at)| (i64::from(if big { i32::from_be_bytes(b) } else { i32::from_le_bytes(b) }), at)),
            None => self.text(expected),
        }
    }

    /// A `size_t`: 8 bytes in binary data.
    fn size(&mut self, expected: &str) -> Result<(u64, Pos), MshError> {
        match self.binary {
            Some(big) => self.take(expected).map(|(b, at)| (if big { u64::from_be_bytes(b) } else { u64::from_le_bytes(b) }, at)),
            None => self.text(expected),
        }
    }

    /// A `double`: 8 bytes in binary data.
    fn float(&mut self, expected: &str) -> Result<(f64, Pos), MshError> {
        match self.binary {
            Some(big) => self.take(expected).map(|(b, at)| (if big { f64::from_be_bytes(b) } else { f64::from_le_bytes(b) }, at)),
            None => self.text(expected),
        }
    }

    /// A coordinate of node `tag`; NaN and infinities are refused, shown
    /// as the file spells them. The message of a bad token is only made on
    /// error: formatting one per value would dominate large files.
    pub(super) fn coordinate(&mut self, tag: u64) -> Result<(f64, Pos), MshError> {
        let (x, at, word) = match self.binary {
            Some(_) => {
                let (x, at) = self.float("a node coordinate")?;
                (x, at, None)
            }
            None => {
                let (word, at) = self.token("a node coordinate")?;
                let parsed = std::str::from_utf8(word).ok().and_then(|s| s.parse().ok());
                let x = parsed.ok_or_else(|| syntax(at, &format!("a coordinate of node {tag}"), &lossy(word)))?;
                (x, at, Some(word))
            }
        };
        if x.is_finite() {
            return Ok((x, at));
        }
        let value = word.map_or_else(|| x.to_string(), lossy);
        Err(MshError::NonFinite { at, tag, value })
    }

    /// A double-quoted string on one line (it may contain spaces).
    pub(super) fn quoted(&mut self, expected: &str) -> Result<String, MshError> {
        self.skip_whitespace(); // text in binary files too
        let at = self.at();
        let rest = &self.bytes[self.pos..];
        let Some(body) = rest.strip_prefix(b"\"") else {
            return Err(match self.word() {
                Some((found, _)) => syntax(at, expected, &lossy(found)),
                None => MshError::Truncated { at, expected: expected.to_string() },
            });
        };
        let line = &body[..body.iter().position(|&b| b == b'\n').unwrap_or(body.len())];
        let Some(len) = line.iter().position(|&b| b == b'"') else {
            let found = lossy(&rest[..line.len() + 1]);
            return Err(syntax(at, &format!("{expected} (closing quote)"), found.trim_end()));
        };
        self.pos += len + 2;
        Ok(lossy(&body[..len]))
    }

    /// Skips a section this reader does not use up to its `$End<name>`,
    /// by bytes: its data may be binary.
    pub(super) fn skip_section(&mut self, name: &[u8]) -> Result<(), MshError> {
        let end = [b"$End", name].concat();
        let rest = &self.bytes[self.pos..];
        let Some(k) = rest.windows(end.len()).position(|w| w == end) else {
            return Err(MshError::Truncated { at: self.end(), expected: lossy(&end) });
        };
        self.line += rest[..k].iter().filter(|&&b| b == b'\n').count();
        self.pos += k + end.len();
        Ok(())
    }
}
