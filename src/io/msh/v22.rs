//! Gmsh MSH 2.2 ASCII (also 2.0 and 2.1, which Gmsh reads alike): a
//! reader that fills the [`Raw`] the 4.1 reader fills, and a writer of a
//! [`Layout`] ([`layout_text_22`]).
//!
//! MSH 2 has no `$Entities` and no node entities: an element line is
//! `tag type ntags physical elementary [partitions…] nodes…`, so the
//! reader makes the entities of the elementary tags (bounding box of
//! their nodes, no bounding entities), their physical groups from the
//! physical tags of their elements, and puts each node on the entity of
//! the lowest-dimensional element holding it. Gmsh writes an element of
//! an entity in several physical groups once per group, each copy under a
//! new tag (checked with Gmsh 4.15: `Mesh.MshFileVersion = 2.2` numbers
//! every line it writes 1, 2, 3, …, the copies of one element on
//! consecutive lines); other writers repeat the tag. The reader makes one
//! element of such copies: a line repeating the type, elementary tag and
//! nodes of the line before it, or repeating the tag of an earlier
//! element with that element's type, entity and nodes. One tag on two
//! different elements is an error.
//!
//! Physical groups in MSH 2 belong to elements, not entities: where the
//! elements of one elementary tag are in different sets of groups, the
//! first set keeps the tag and each other set gets an entity of its own
//! (tags counted on after the largest of that dimension), so that every
//! element keeps exactly its groups.

use std::collections::HashMap;
use std::fmt::Write as _;

use super::types::gmsh_perm;
use super::read::{physical_names, Accept, Block, PeriodicTags, Raw, Reader};
use super::write::msh_type;
use super::{syntax, MshError, Pos};
use crate::io::fmt_f64;
use crate::io::layout::{Entity, Layout};
use crate::mesh::element::to_format;

/// Whether a `$MeshFormat` version is one of MSH 2 (2, 2.0, 2.1, 2.2).
pub(super) fn is_version(version: &[u8]) -> bool {
    let v = std::str::from_utf8(version).ok().and_then(|s| s.parse::<f64>().ok());
    v.is_some_and(|v| (2.0..3.0).contains(&v))
}

/// One element line as read, before copies are merged into it.
struct Line {
    tag: u64,
    element_type: i64,
    dim: usize,
    elementary: i64,
    at: Pos,
    /// Range of its nodes in `Elements::nodes`.
    nodes: std::ops::Range<usize>,
    /// Its distinct non-zero physical tags, in file order.
    physicals: Vec<i64>,
}

/// Reads an MSH 2 ASCII file (its `$MeshFormat` says version 2.x);
/// element types other than the `accept`ed ones are an error at their
/// line. A binary file is refused.
pub(super) fn parse(bytes: &[u8], accept: Accept) -> Result<Raw, MshError> {
    let mut t = Reader::ascii(bytes);
    t.expect("$MeshFormat")?;
    let (version, _) = t.token("the MSH version number")?;
    let (file_type, at) = t.token("the file type (0 = ASCII)")?;
    match file_type {
        b"0" => {}
        b"1" => return Err(MshError::BinaryV2 { at, version: lossy(version) }),
        s => return Err(syntax(at, "file type 0 (ASCII) or 1 (binary)", &lossy(s))),
    }
    t.text::<u64>("the data size")?;
    t.expect("$EndMeshFormat")?;
    let mut raw = Raw::default();
    let mut has_nodes = false;
    let mut lines: Option<(Vec<Line>, Vec<usize>)> = None;
    while let Some((word, at)) = t.word() {
        match word {
            b"$PhysicalNames" => physical_names(&mut t, &mut raw)?,
            b"$Nodes" => {
                nodes(&mut t, &mut raw)?;
                has_nodes = true;
            }
            b"$Elements" => {
                let at = t.at();
                if !has_nodes {
                    return Err(syntax(at, "$Nodes before $Elements", "$Elements"));
                }
                raw.elements_at = Some(at);
                lines = Some(elements(&mut t, &raw, accept)?);
            }
            b"$Periodic" => periodic(&mut t, &mut raw)?,
            w if w.starts_with(b"$") && !w.starts_with(b"$End") => {
                raw.skipped.push(lossy(&w[1..]));
                t.skip_section(&w[1..])?
            }
            w => return Err(syntax(at, "a section header like `$Nodes`", &lossy(w))),
        }
    }
    if !has_nodes {
        return Err(MshError::MissingSection("Nodes"));
    }
    let Some((lines, nodes)) = lines else {
        return Err(MshError::MissingSection("Elements"));
    };
    assemble(&mut raw, lines, &nodes, accept);
    Ok(raw)
}

/// `$Nodes`: `count`, then `tag x y z` per node.
fn nodes(t: &mut Reader, raw: &mut Raw) -> Result<(), MshError> {
    let count: u64 = t.text("the number of nodes")?.0;
    for _ in 0..count {
        let (tag, at) = t.text::<u64>("a node tag")?;
        if raw.node_index.insert(tag, raw.node_tags.len()).is_some() {
            return Err(MshError::DuplicateNode { at, tag });
        }
        let mut x = [0.0; 3];
        let mut z_at = at;
        for c in &mut x {
            (*c, z_at) = t.coordinate(tag)?;
        }
        if x[2] != 0.0 && raw.off_plane.is_none() {
            raw.off_plane = Some((z_at, tag, x[2]));
        }
        raw.node_tags.push(tag);
        raw.nodes.push(x);
    }
    t.expect("$EndNodes")
}

/// `$Elements`: `count`, then the element lines, copies merged: the
/// distinct elements and their nodes (indices into `raw.nodes`, Gmsh's
/// local order).
fn elements(t: &mut Reader, raw: &Raw, accept: Accept) -> Result<(Vec<Line>, Vec<usize>), MshError> {
    let count: u64 = t.text("the number of elements")?.0;
    let mut lines: Vec<Line> = Vec::new();
    let mut nodes: Vec<usize> = Vec::new();
    // element tag → its line in `lines`
    let mut by_tag: HashMap<u64, usize> = HashMap::new();
    for _ in 0..count {
        let (tag, at) = t.text::<u64>("an element tag")?;
        let (element_type, type_at) = t.text::<i64>("an element type")?;
        let Some(kind) = accept.kind(element_type) else {
            return Err(MshError::UnknownElementType { at: type_at, accepted: accept.phrase, element_type });
        };
        let ntags: u64 = t.text("the number of element tags")?.0;
        let (mut physical, mut elementary) = (0, 0);
        for k in 0..ntags {
            let value: i64 = t.text("an element tag (physical, elementary, partitions)")?.0;
            match k {
                0 => physical = value,
                1 => elementary = value,
                _ => {} // partitions
            }
        }
        let start = nodes.len();
        for _ in 0..kind.nodes {
            let node: u64 = t.text("a node tag of an element")?.0;
            let index = raw.node_index.get(&node).ok_or(MshError::UnknownNode { at, element: tag, tag: node })?;
            nodes.push(*index);
        }
        let same = |l: &Line, nodes: &[usize]| l.element_type == element_type && l.elementary == elementary && nodes[l.nodes.clone()] == nodes[start..];
        // a copy for another group: Gmsh's (the line before, renumbered)
        // or another writer's (the same tag)
        let copy_of = match by_tag.get(&tag) {
            Some(&k) if same(&lines[k], &nodes) => Some(k),
            Some(&k) => return Err(MshError::DuplicateElement { at, tag, first: lines[k].at }),
            None => lines.len().checked_sub(1).filter(|&k| same(&lines[k], &nodes)),
        };
        let k = match copy_of {
            Some(k) => {
                nodes.truncate(start);
                k
            }
            None => {
                lines.push(Line { tag, element_type, dim: kind.dim, elementary, at, nodes: start..nodes.len(), physicals: Vec::new() });
                lines.len() - 1
            }
        };
        by_tag.insert(tag, k);
        if physical != 0 && !lines[k].physicals.contains(&physical) {
            lines[k].physicals.push(physical);
        }
    }
    t.expect("$EndElements")?;
    Ok((lines, nodes))
}

/// `$Periodic`: `count`, then per link `dim slave master`, an optional
/// `Affine` and 16 values, the number of node pairs and the pairs.
fn periodic(t: &mut Reader, raw: &mut Raw) -> Result<(), MshError> {
    let links: u64 = t.text("the number of periodic links")?.0;
    for _ in 0..links {
        let (dim, at) = t.text::<i64>("a periodic entity dimension")?;
        if !(0..=3).contains(&dim) {
            return Err(syntax(at, "an entity dimension 0..3", &dim.to_string()));
        }
        let slave: i64 = t.text("a periodic entity tag")?.0;
        let master: i64 = t.text("a periodic master entity tag")?.0;
        let mut affine = Vec::new();
        if t.peek() == Some(b"Affine".as_slice()) {
            t.word();
            for _ in 0..16 {
                affine.push(t.text::<f64>("an affine value")?.0);
            }
        }
        let count: u64 = t.text("the number of periodic node pairs")?.0;
        let mut pairs = Vec::new();
        for _ in 0..count {
            let (s, at) = t.text::<u64>("a periodic node tag")?;
            let m: u64 = t.text("a periodic master node tag")?.0;
            for tag in [s, m] {
                if !raw.node_index.contains_key(&tag) {
                    return Err(syntax(at, "the tag of a node of $Nodes (periodic node pair)", &tag.to_string()));
                }
            }
            pairs.push((s, m));
        }
        raw.periodic.push(PeriodicTags { dim: dim as usize, slave, master, affine, pairs });
    }
    t.expect("$EndPeriodic")
}

/// The entities, their groups, the element blocks and the nodes'
/// entities of the merged element lines (module docs).
fn assemble(raw: &mut Raw, mut lines: Vec<Line>, nodes: &[usize], accept: Accept) {
    // one entity per (dimension, elementary tag, set of groups)
    let mut largest: HashMap<usize, i64> = HashMap::new();
    for l in &lines {
        let m = largest.entry(l.dim).or_insert(l.elementary);
        *m = (*m).max(l.elementary);
    }
    let mut sets: HashMap<(usize, i64), Vec<(Vec<i64>, i64)>> = HashMap::new();
    for l in &mut lines {
        let options = sets.entry((l.dim, l.elementary)).or_default();
        let tag = match options.iter().find(|(set, _)| *set == l.physicals) {
            Some(&(_, tag)) => tag,
            None => {
                let tag = if options.is_empty() {
                    l.elementary
                } else {
                    let m = largest.get_mut(&l.dim).expect("every dimension seen");
                    *m += 1;
                    *m
                };
                options.push((l.physicals.clone(), tag));
                tag
            }
        };
        l.elementary = tag;
    }
    for (&(dim, _), options) in &sets {
        for (set, tag) in options {
            raw.entity_physicals.insert((dim, *tag), set.clone());
        }
    }
    // blocks of consecutive lines of one dimension, entity and type
    for l in &lines {
        let kind = accept.kind(l.element_type).expect("checked when read");
        let start = match raw.blocks.last() {
            Some(b) if b.kind.dim == l.dim && b.entity == l.elementary && b.element_type == l.element_type => false,
            _ => true,
        };
        if start {
            raw.blocks.push(Block { entity: l.elementary, element_type: l.element_type, kind, at: l.at, tags: Vec::new(), nodes: Vec::new() });
        }
        let b = raw.blocks.last_mut().expect("pushed");
        b.tags.push(l.tag);
        b.nodes.extend_from_slice(&nodes[l.nodes.clone()]);
    }
    // each node on the entity of its lowest-dimensional element (the
    // first in the file among equals); a node in no element on the point
    // entity 0, which Gmsh 4.15 reads (4.1) and keeps the node on
    let mut node_entity: Vec<Option<(usize, i64)>> = vec![None; raw.nodes.len()];
    let mut boxes: HashMap<(usize, i64), [f64; 6]> = HashMap::new();
    for l in &lines {
        let key = (l.dim, l.elementary);
        let b = boxes.entry(key).or_insert([f64::INFINITY, f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY]);
        for &n in &nodes[l.nodes.clone()] {
            if node_entity[n].is_none_or(|(d, _)| d > l.dim) {
                node_entity[n] = Some(key);
            }
            let x = raw.nodes[n];
            for d in 0..3 {
                b[d] = b[d].min(x[d]);
                b[d + 3] = b[d + 3].max(x[d]);
            }
        }
    }
    if let Some(n) = node_entity.iter().position(Option::is_none) {
        let x = raw.nodes[n];
        boxes.entry((0, 0)).or_insert([x[0], x[1], x[2], x[0], x[1], x[2]]);
        raw.entity_physicals.entry((0, 0)).or_default();
    }
    raw.node_entity = node_entity.into_iter().map(|e| e.unwrap_or((0, 0))).collect();
    let mut keys: Vec<(usize, i64)> = boxes.keys().copied().collect();
    keys.sort_unstable();
    raw.entities = keys
        .into_iter()
        .map(|(dim, tag)| Entity { dim, tag, bbox: boxes[&(dim, tag)], physicals: raw.entity_physicals[&(dim, tag)].clone(), bounding: Vec::new() })
        .collect();
}

/// A layout as MSH 2.2 ASCII text: its groups, its nodes (under their
/// tags), its elements in layout order, each with two tags (a physical
/// group of its entity, 0 if it has none, and the entity as elementary
/// tag) and its nodes in Gmsh's order, and its periodic links. An element
/// whose entity is in several groups is written once per group, as Gmsh
/// writes it; then, as Gmsh does, every line is numbered 1, 2, 3, … in
/// file order. Otherwise the elements keep their tags. Entities' bounding
/// boxes and bounding entities and the nodes' entities are lost (MSH 2
/// has no place for them).
pub fn layout_text_22(layout: &Layout) -> String {
    let mut out = String::from("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n");
    if !layout.physical_names.is_empty() {
        put!(out, "$PhysicalNames\n{}", layout.physical_names.len());
        for g in &layout.physical_names {
            put!(out, "{} {} \"{}\"", g.dim, g.tag, g.name);
        }
        out.push_str("$EndPhysicalNames\n");
    }
    put!(out, "$Nodes\n{}", layout.coords.len());
    for (x, tag) in layout.coords.iter().zip(&layout.node_tags) {
        put!(out, "{tag} {} {} {}", fmt_f64(x[0]), fmt_f64(x[1]), fmt_f64(x[2]));
    }
    out.push_str("$EndNodes\n");
    let groups: HashMap<(usize, i64), &[i64]> = layout.entities.iter().map(|e| ((e.dim, e.tag), e.physicals.as_slice())).collect();
    let groups_of = |dim: usize, entity: i64| -> &[i64] {
        match groups.get(&(dim, entity)) {
            Some(g) if !g.is_empty() => g,
            _ => &[0],
        }
    };
    let copies: Vec<&[i64]> = layout.elements.iter().map(|el| groups_of(el.shape.dim(), el.entity)).collect();
    let renumber = copies.iter().any(|g| g.len() > 1);
    put!(out, "$Elements\n{}", copies.iter().map(|g| g.len()).sum::<usize>());
    let mut perms: HashMap<(crate::mesh::element::Shape, usize), Vec<usize>> = HashMap::new();
    let mut line = 0u64;
    for (el, groups) in layout.elements.iter().zip(copies) {
        let perm = perms.entry((el.shape, el.order)).or_insert_with(|| gmsh_perm(el.shape, el.order));
        let nodes: String = to_format(perm, &el.nodes).into_iter().map(|v| format!(" {}", layout.node_tags[v])).collect();
        let ty = msh_type(el.shape, el.order);
        for &g in groups {
            line += 1;
            let tag = if renumber { line } else { el.tag };
            put!(out, "{tag} {ty} 2 {g} {}{nodes}", el.entity);
        }
    }
    out.push_str("$EndElements\n");
    if !layout.periodic.is_empty() {
        put!(out, "$Periodic\n{}", layout.periodic.len());
        for link in &layout.periodic {
            put!(out, "{} {} {}", link.dim, link.slave, link.master);
            if link.affine.len() == 16 {
                let affine: String = link.affine.iter().map(|&v| format!(" {}", fmt_f64(v))).collect();
                put!(out, "Affine{affine}");
            }
            put!(out, "{}", link.pairs.len());
            for &(s, m) in &link.pairs {
                put!(out, "{} {}", layout.node_tags[s], layout.node_tags[m]);
            }
        }
        out.push_str("$EndPeriodic\n");
    }
    out
}

/// Bytes for a message (never raw: [`super::shown`] hides non-text).
fn lossy(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}
