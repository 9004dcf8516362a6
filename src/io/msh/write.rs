//! The one MSH writer: meshes of any order, linear ones as order 1
//! (layout in the [module docs](super)).

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use super::types::gmsh_perm;
use super::MshError;
use crate::io::fmt_f64;
use crate::io::layout::Layout;
use crate::mesh::element::Shape;
use crate::mesh::element::{to_format, Spacing};
use crate::mesh::file::write_atomic;
use crate::mesh::{CurvedMesh, PlaneMesh, SolidMesh};

/// The quad or triangle mesh as MSH 4.1 ASCII text. The mesh is assumed
/// valid; [`write_msh`] checks that first. Coordinates are printed with
/// round-trip precision, so reading gives the same bits.
pub fn msh_string<const N: usize>(mesh: &PlaneMesh<N>) -> String {
    msh_text(&CurvedMesh::from_quads(mesh))
}

/// Checks `mesh` and writes it atomically to `path` as MSH 4.1 ASCII.
pub fn write_msh<const N: usize>(path: &Path, mesh: &PlaneMesh<N>) -> Result<(), MshError> {
    CurvedMesh::from_quads(mesh).write_msh(path)
}

/// The hex mesh as MSH 4.1 ASCII text: boundary faces as 4-node quads
/// (type 3), hexes (type 5). Assumed valid, as [`msh_string`].
pub fn hex_msh_string<const N: usize, const K: usize>(mesh: &SolidMesh<N, K>) -> String {
    msh_text(&CurvedMesh::from_hexes(mesh))
}

/// Checks `mesh` and writes it atomically to `path` as MSH 4.1 ASCII;
/// nothing is written if it fails [`CurvedMesh::validate`].
pub fn write_hex_msh<const N: usize, const K: usize>(path: &Path, mesh: &SolidMesh<N, K>) -> Result<(), MshError> {
    CurvedMesh::from_hexes(mesh).write_msh(path)
}

impl<const D: usize> CurvedMesh<D> {
    /// The mesh as MSH 4.1 ASCII text, after resampling to equispaced
    /// nodes (the only ones the format knows). Fails as
    /// [`CurvedMesh::validate`].
    pub fn msh_string(&self) -> Result<String, MshError> {
        self.validate().map_err(MshError::InvalidMesh)?;
        if self.spacing == Spacing::Equispaced {
            return Ok(msh_text(self));
        }
        Ok(msh_text(&self.to_equispaced()))
    }

    /// Writes [`CurvedMesh::msh_string`] atomically to `path`; nothing is
    /// written if the mesh is rejected.
    pub fn write_msh(&self, path: &Path) -> Result<(), MshError> {
        let text = self.msh_string()?;
        write_atomic(path, text.as_bytes()).map_err(|source| MshError::Io { path: path.to_owned(), source })
    }
}

/// The text of an equispaced mesh the crate made ([`Layout::generated`]).
fn msh_text<const D: usize>(mesh: &CurvedMesh<D>) -> String {
    layout_text(&Layout::generated(mesh))
}

/// A layout as MSH 4.1 ASCII text: its groups, entities (bounding boxes
/// of their nodes where they have any), nodes in one block per entity,
/// elements in one block per entity and type, and periodic links.
pub fn layout_text(layout: &Layout) -> String {
    let mut out = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
    if !layout.physical_names.is_empty() {
        put!(out, "$PhysicalNames\n{}", layout.physical_names.len());
        for g in &layout.physical_names {
            put!(out, "{} {} \"{}\"", g.dim, g.tag, g.name);
        }
        out.push_str("$EndPhysicalNames\n");
    }
    push_entities(&mut out, layout);
    push_nodes(&mut out, layout);
    push_elements(&mut out, layout);
    push_periodic(&mut out, layout);
    out
}

/// Entities by dimension, in layout order within one.
fn push_entities(out: &mut String, layout: &Layout) {
    let boxes = entity_boxes(layout);
    let counts: [usize; 4] = std::array::from_fn(|d| layout.entities.iter().filter(|e| e.dim == d).count());
    let [c0, c1, c2, c3] = counts;
    put!(out, "$Entities\n{c0} {c1} {c2} {c3}");
    for dim in 0..4 {
        for e in layout.entities.iter().filter(|e| e.dim == dim) {
            let b = boxes.get(&(e.dim, e.tag)).copied().unwrap_or(e.bbox).map(fmt_f64);
            let list = |tags: &[i64]| tags.iter().fold(tags.len().to_string(), |s, t| format!("{s} {t}"));
            if dim == 0 {
                put!(out, "{} {} {} {} {}", e.tag, b[0], b[1], b[2], list(&e.physicals));
            } else {
                put!(out, "{} {} {} {} {} {} {} {} {}", e.tag, b[0], b[1], b[2], b[3], b[4], b[5], list(&e.physicals), list(&e.bounding));
            }
        }
    }
    out.push_str("$EndEntities\n");
}

/// `min max` corners of the nodes of each entity's elements (a point
/// entity: its node).
fn entity_boxes(layout: &Layout) -> HashMap<(usize, i64), [f64; 6]> {
    let mut boxes: HashMap<(usize, i64), [f64; 6]> = HashMap::new();
    for el in &layout.elements {
        let b = boxes.entry((el.shape.dim(), el.entity)).or_insert([f64::INFINITY, f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY]);
        for &n in &el.nodes {
            let x = layout.coords[n];
            for d in 0..3 {
                b[d] = b[d].min(x[d]);
                b[d + 3] = b[d + 3].max(x[d]);
            }
        }
    }
    boxes
}

/// `(min, max)` of tags; Gmsh writes `0 0` for none.
fn tag_range(tags: impl Iterator<Item = u64>) -> (u64, u64) {
    tags.fold(None, |r: Option<(u64, u64)>, t| Some(r.map_or((t, t), |(a, b)| (a.min(t), b.max(t))))).unwrap_or((0, 0))
}

/// One non-parametric block per entity (by dimension, then tag).
fn push_nodes(out: &mut String, layout: &Layout) {
    let mut blocks: Vec<((usize, i64), Vec<usize>)> = Vec::new();
    let mut index: HashMap<(usize, i64), usize> = HashMap::new();
    for (n, &entity) in layout.node_entity.iter().enumerate() {
        let k = *index.entry(entity).or_insert_with(|| {
            blocks.push((entity, Vec::new()));
            blocks.len() - 1
        });
        blocks[k].1.push(n);
    }
    blocks.sort_by_key(|b| b.0);
    let (lo, hi) = tag_range(layout.node_tags.iter().copied());
    put!(out, "$Nodes\n{} {} {lo} {hi}", blocks.len(), layout.coords.len());
    for ((dim, tag), nodes) in &blocks {
        put!(out, "{dim} {tag} 0 {}", nodes.len());
        for &n in nodes {
            put!(out, "{}", layout.node_tags[n]);
        }
        for &n in nodes {
            let x = layout.coords[n];
            put!(out, "{} {} {}", fmt_f64(x[0]), fmt_f64(x[1]), fmt_f64(x[2]));
        }
    }
    out.push_str("$EndNodes\n");
}

/// One block per (dimension, entity, type), nodes in Gmsh's order. The
/// shape is in the key: one entity may hold quads and triangles (a mixed
/// mesh), and a block takes its type and node order from its first
/// element.
fn push_elements(out: &mut String, layout: &Layout) {
    let mut order: Vec<usize> = (0..layout.elements.len()).collect();
    let key = |e: usize| {
        let el = &layout.elements[e];
        (el.shape.dim(), el.entity, el.shape, el.order)
    };
    order.sort_by_key(|&e| key(e));
    let blocks = order.chunk_by(|&a, &b| key(a) == key(b)).collect::<Vec<_>>();
    let (lo, hi) = tag_range(layout.elements.iter().map(|e| e.tag));
    put!(out, "$Elements\n{} {} {lo} {hi}", blocks.len(), layout.elements.len());
    for block in blocks {
        let first = &layout.elements[block[0]];
        let perm = gmsh_perm(first.shape, first.order);
        put!(out, "{} {} {} {}", first.shape.dim(), first.entity, msh_type(first.shape, first.order), block.len());
        for &e in block {
            let el = &layout.elements[e];
            let _ = write!(out, "{}", el.tag);
            for v in to_format(&perm, &el.nodes) {
                let _ = write!(out, " {}", layout.node_tags[v]);
            }
            out.push('\n');
        }
    }
    out.push_str("$EndElements\n");
}

/// The MSH element type of a shape of order `p` (1..=4).
///
/// # Panics
/// For a shape outside the type table: layouts hold only elements the
/// readers read or the method made, all in it.
pub fn msh_type(shape: Shape, p: usize) -> i64 {
    super::types::msh_type(shape, p).unwrap_or_else(|| panic!("no MSH type for {shape:?} of order {p}"))
}

/// `$Periodic`, if the layout has links.
fn push_periodic(out: &mut String, layout: &Layout) {
    if layout.periodic.is_empty() {
        return;
    }
    put!(out, "$Periodic\n{}", layout.periodic.len());
    for link in &layout.periodic {
        put!(out, "{} {} {}", link.dim, link.slave, link.master);
        let affine: String = link.affine.iter().map(|&v| format!(" {}", fmt_f64(v))).collect();
        put!(out, "{}{affine}", link.affine.len());
        put!(out, "{}", link.pairs.len());
        for &(s, m) in &link.pairs {
            put!(out, "{} {}", layout.node_tags[s], layout.node_tags[m]);
        }
    }
    out.push_str("$EndPeriodic\n");
}
