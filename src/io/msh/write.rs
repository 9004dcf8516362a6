//! The one MSH writer: meshes of any order, linear ones as order 1
//! (layout in the [module docs](super)).

use std::fmt::Write as _;
use std::path::Path;

use super::{MshError, DOMAIN_NAME, MSH_HEX_TYPES, MSH_LINE_TYPES, MSH_QUAD_TYPES};
use crate::io::fmt_f64;
use crate::mesh::element::{gmsh_hex_order, gmsh_line_order, gmsh_quad_order, to_format, Spacing};
use crate::mesh::file::write_atomic;
use crate::mesh::{CurvedMesh, HexMesh, QuadMesh};

/// The quad mesh as MSH 4.1 ASCII text. The mesh is assumed valid;
/// [`write_msh`] checks that first. Coordinates are printed with
/// round-trip precision, so reading gives the same bits.
pub fn msh_string(mesh: &QuadMesh) -> String {
    msh_text(&CurvedMesh::from_quads(mesh))
}

/// Checks `mesh` and writes it atomically to `path` as MSH 4.1 ASCII.
pub fn write_msh(path: &Path, mesh: &QuadMesh) -> Result<(), MshError> {
    CurvedMesh::from_quads(mesh).write_msh(path)
}

/// The hex mesh as MSH 4.1 ASCII text: boundary faces as 4-node quads
/// (type 3), hexes (type 5). Assumed valid, as [`msh_string`].
pub fn hex_msh_string(mesh: &HexMesh) -> String {
    msh_text(&CurvedMesh::from_hexes(mesh))
}

/// Checks `mesh` and writes it atomically to `path` as MSH 4.1 ASCII;
/// nothing is written if it fails [`CurvedMesh::validate`].
pub fn write_hex_msh(path: &Path, mesh: &HexMesh) -> Result<(), MshError> {
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

/// The text of an equispaced mesh. Dangling part indices are skipped
/// rather than trusted: the linear writers do not validate first.
fn msh_text<const D: usize>(mesh: &CurvedMesh<D>) -> String {
    let mut out = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
    let mut per_part: Vec<Vec<usize>> = vec![Vec::new(); mesh.part_names.len()];
    for (e, b) in mesh.boundary.iter().enumerate() {
        if let Some(list) = per_part.get_mut(b.part) {
            list.push(e);
        }
    }
    push_physical_names(&mut out, mesh);
    push_entities(&mut out, mesh, &per_part);
    push_nodes(&mut out, mesh);
    push_elements(&mut out, mesh, &per_part);
    out
}

/// Groups 1..k of the boundary dimension named after the parts, then the
/// [`DOMAIN_NAME`] group of the mesh dimension.
fn push_physical_names<const D: usize>(out: &mut String, mesh: &CurvedMesh<D>) {
    let k = mesh.part_names.len();
    put!(out, "$PhysicalNames\n{}", k + 1);
    for (i, name) in mesh.part_names.iter().enumerate() {
        put!(out, "{} {} \"{name}\"", D - 1, i + 1);
    }
    put!(out, "{D} {} \"{DOMAIN_NAME}\"\n$EndPhysicalNames", k + 1);
}

/// Entity `i + 1` of the boundary dimension per part (physical tag
/// `i + 1`, no bounding entities) and one entity of the mesh dimension
/// bounded by all of them (physical tag `k + 1`).
fn push_entities<const D: usize>(out: &mut String, mesh: &CurvedMesh<D>, per_part: &[Vec<usize>]) {
    let k = per_part.len();
    let mut counts = [0; 4];
    counts[D - 1] = k;
    counts[D] = 1;
    let [c0, c1, c2, c3] = counts;
    put!(out, "$Entities\n{c0} {c1} {c2} {c3}");
    for (part, elements) in per_part.iter().enumerate() {
        let nodes = elements.iter().flat_map(|&e| mesh.boundary[e].nodes.iter().copied());
        put!(out, "{} {} 1 {} 0", part + 1, bounding_box(mesh, nodes), part + 1);
    }
    let bounding: String = (1..=k).map(|t| format!(" {t}")).collect();
    put!(out, "1 {} 1 {} {k}{bounding}", bounding_box(mesh, 0..mesh.nodes.len()), k + 1);
    out.push_str("$EndEntities\n");
}

/// `minX minY minZ maxX maxY maxZ` of the given nodes (zeros if none).
fn bounding_box<const D: usize>(mesh: &CurvedMesh<D>, nodes: impl Iterator<Item = usize>) -> String {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for x in nodes.filter_map(|v| mesh.nodes.get(v)) {
        for d in 0..3 {
            let c = x.get(d).copied().unwrap_or(0.0);
            lo[d] = lo[d].min(c);
            hi[d] = hi[d].max(c);
        }
    }
    if lo[0] > hi[0] {
        return "0 0 0 0 0 0".to_string();
    }
    let [a, b, c, d, e, f] = [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]].map(fmt_f64);
    format!("{a} {b} {c} {d} {e} {f}")
}

/// `(min, max)` of `count` tags from 1; Gmsh writes `0 0` for none.
fn tag_range(count: usize) -> (usize, usize) {
    if count == 0 {
        (0, 0)
    } else {
        (1, count)
    }
}

/// All nodes in one non-parametric block on the domain entity, tags 1..N,
/// z = 0 in 2D.
fn push_nodes<const D: usize>(out: &mut String, mesh: &CurvedMesh<D>) {
    let n = mesh.nodes.len();
    let (lo, hi) = tag_range(n);
    put!(out, "$Nodes\n1 {n} {lo} {hi}\n{D} 1 0 {n}");
    for tag in 1..=n {
        put!(out, "{tag}");
    }
    for x in &mesh.nodes {
        let z = if D == 3 { x[2] } else { 0.0 };
        put!(out, "{} {} {}", fmt_f64(x[0]), fmt_f64(x[1]), fmt_f64(z));
    }
    out.push_str("$EndNodes\n");
}

/// One block per non-empty part, then the cell block, nodes in Gmsh's
/// order (MSH node tags start at 1).
fn push_elements<const D: usize>(out: &mut String, mesh: &CurvedMesh<D>, per_part: &[Vec<usize>]) {
    let p = mesh.p;
    let ok = "order checked by validate";
    let (cell_perm, face_perm, cell_type, face_type) = match D {
        2 => (gmsh_quad_order(p).expect(ok), gmsh_line_order(p).expect(ok), MSH_QUAD_TYPES[p - 1], MSH_LINE_TYPES[p - 1]),
        _ => (gmsh_hex_order(p).expect(ok), gmsh_quad_order(p).expect(ok), MSH_HEX_TYPES[p - 1], MSH_QUAD_TYPES[p - 1]),
    };
    let blocks = per_part.iter().filter(|b| !b.is_empty()).count() + usize::from(!mesh.cells.is_empty());
    let total = per_part.iter().map(Vec::len).sum::<usize>() + mesh.cells.len();
    let (lo, hi) = tag_range(mesh.boundary.len() + mesh.cells.len());
    put!(out, "$Elements\n{blocks} {total} {lo} {hi}");
    let push = |out: &mut String, tag: usize, nodes: &[usize], perm: &[usize]| {
        let _ = write!(out, "{tag}");
        for v in to_format(perm, nodes) {
            let _ = write!(out, " {}", v + 1);
        }
        out.push('\n');
    };
    for (part, elements) in per_part.iter().enumerate().filter(|(_, b)| !b.is_empty()) {
        put!(out, "{} {} {face_type} {}", D - 1, part + 1, elements.len());
        for &e in elements {
            push(out, e + 1, &mesh.boundary[e].nodes, &face_perm);
        }
    }
    if !mesh.cells.is_empty() {
        put!(out, "{D} 1 {cell_type} {}", mesh.cells.len());
        let first = mesh.boundary.len() + 1;
        for (c, cell) in mesh.cells.iter().enumerate() {
            push(out, first + c, cell, &cell_perm);
        }
    }
    out.push_str("$EndElements\n");
}
