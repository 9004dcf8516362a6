//! Meshes made of what the reader found: the mesh of element blocks of
//! any kinds, linear or of any order, and Algorithm 1's meshes of one
//! kind made from it, from one [`Raw`]. Cells are the elements of the
//! mesh dimension, boundary elements those one below, both ordered by
//! element tag; points, and lines of a 3D mesh, carry nothing kept.
//!
//! Boundary parts are the named physical groups of the boundary dimension
//! in order of physical tag, then `curve<tag>` / `surface<tag>` for
//! entities in none of them; an entity in several groups puts its elements
//! in each.

use std::collections::{HashMap, HashSet};

use super::read::{Accept, Block, Raw};
use super::types::gmsh_perm;
use super::{syntax, MshError, CURVED, LINEAR};
use crate::io::layout::{self, Entity, Layout, Periodic, PhysicalName};
use crate::mesh::element::{from_format, Shape, Spacing};
use crate::mesh::{CurvedMesh, PlaneMesh, SolidMesh};

/// An element: its tag, its block and its nodes (Gmsh's local order).
type Element<'a> = (u64, &'a Block, &'a [usize]);

/// A boundary element in one of its parts: nodes, part, block.
type Facet<'a> = (&'a [usize], usize, &'a Block);

impl Raw {
    /// Everything the file says, as a [`Layout`] (element nodes in
    /// tensor order). Entities named by node or element blocks but not
    /// in `$Entities` (a file without it) are added without groups.
    pub fn layout(&self) -> Layout {
        let mut entities = self.entities.clone();
        let mut known: HashSet<(usize, i64)> = entities.iter().map(|e| (e.dim, e.tag)).collect();
        let used = self.node_entity.iter().copied().chain(self.blocks.iter().map(|b| (b.kind.dim, b.entity)));
        for (dim, tag) in used {
            if known.insert((dim, tag)) {
                entities.push(Entity { dim, tag, bbox: [0.0; 6], physicals: Vec::new(), bounding: Vec::new() });
            }
        }
        let elements = self.blocks.iter().flat_map(|b| {
            let perm = gmsh_perm(b.kind.shape, b.kind.order);
            b.tags.iter().zip(b.nodes.chunks(b.kind.nodes)).map(move |(&tag, nodes)| layout::Element {
                tag,
                entity: b.entity,
                shape: b.kind.shape,
                order: b.kind.order,
                nodes: from_format(&perm, nodes),
            })
        });
        let index = |t: &u64| self.node_index[t];
        let periodic = self.periodic.iter().map(|l| Periodic {
            dim: l.dim,
            slave: l.slave,
            master: l.master,
            affine: l.affine.clone(),
            pairs: l.pairs.iter().map(|(s, m)| (index(s), index(m))).collect(),
        });
        Layout {
            physical_names: self.physical_names.iter().map(|(d, t, n)| PhysicalName { dim: *d as usize, tag: *t, name: n.clone() }).collect(),
            entities,
            coords: self.nodes.clone(),
            node_tags: self.node_tags.clone(),
            node_entity: self.node_entity.clone(),
            elements: elements.collect(),
            periodic: periodic.collect(),
            unkept_sections: self.skipped.clone(),
            parametric: self.parametric,
        }
    }

    /// The linear plane mesh of quads (`N = 4`) or triangles (`N = 3`;
    /// z must be 0) and its cells' element tags.
    pub fn plane_mesh<const N: usize>(&self) -> Result<(PlaneMesh<N>, Vec<u64>), MshError> {
        self.check(LINEAR[0])?;
        self.in_plane()?;
        self.one_shape(2, if N == 3 { Shape::Triangle } else { Shape::Quadrilateral })?;
        let (mesh, tags) = self.linear_mesh(self.plane_nodes())?;
        Ok((mesh.to_plane().expect("cells and edges of one kind, checked"), tags))
    }

    /// The linear plane mesh of quads, triangles or both (z must be 0),
    /// cells in tag order, and its cells' element tags.
    pub fn linear_plane(&self) -> Result<(CurvedMesh<2>, Vec<u64>), MshError> {
        self.check(LINEAR[0])?;
        self.in_plane()?;
        if self.cell_shapes(2).len() > 1 {
            self.plane_kinds()?;
        } else {
            self.one_shape(2, if self.cell_shape(2) == Some(Shape::Triangle) { Shape::Triangle } else { Shape::Quadrilateral })?;
        }
        self.linear_mesh(self.plane_nodes())
    }

    /// The nodes of a plane mesh (z dropped).
    fn plane_nodes(&self) -> Vec<[f64; 2]> {
        self.nodes.iter().map(|p| [p[0], p[1]]).collect()
    }

    /// The linear mesh of dimension `D` on `nodes`, cells in tag order,
    /// and its cells' element tags (the kinds checked by the caller).
    fn linear_mesh<const D: usize>(&self, nodes: Vec<[f64; D]>) -> Result<(CurvedMesh<D>, Vec<u64>), MshError> {
        let cells = self.by_tag(D);
        let (part_names, facets) = self.boundary(D - 1);
        let mesh = CurvedMesh::linear(nodes, cells.iter().map(|c| (c.1.kind.shape, c.2)), facets.iter().map(|&(nodes, part, _)| (nodes, part)), part_names);
        Ok((mesh, cells.iter().map(|c| c.0).collect()))
    }

    /// Fails unless every cell of a plane mesh is a triangle or a quad and
    /// every boundary element a line.
    fn plane_kinds(&self) -> Result<(), MshError> {
        for b in self.blocks.iter().filter(|b| (1..=2).contains(&b.kind.dim)) {
            let (what, expected) = if b.kind.dim == 2 { ("cells", Shape::Quadrilateral) } else { ("boundary elements", Shape::Line) };
            if !matches!((b.kind.dim, b.kind.shape), (2, Shape::Triangle | Shape::Quadrilateral) | (1, Shape::Line)) {
                let why = "a plane mesh holds triangles and quads, bounded by lines";
                return Err(MshError::MixedShapes { at: b.at, what, expected, found: b.kind.shape, why });
            }
        }
        Ok(())
    }

    /// The kinds of cell (dimension `dim`) the blocks hold, in the order of
    /// [`Shape`].
    pub fn cell_shapes(&self, dim: usize) -> Vec<Shape> {
        // an empty block holds no cell of its kind
        let mut out: Vec<Shape> = self.blocks.iter().filter(|b| b.kind.dim == dim && !b.tags.is_empty()).map(|b| b.kind.shape).collect();
        out.sort();
        out.dedup();
        out
    }

    /// The shape of the cells (dimension `dim`): the first cell block's.
    pub fn cell_shape(&self, dim: usize) -> Option<Shape> {
        self.blocks.iter().find(|b| b.kind.dim == dim).map(|b| b.kind.shape)
    }

    /// Fails unless every cell (dimension `dim`) is a `cells` and every
    /// boundary element one of its facets' shape.
    fn one_shape(&self, dim: usize, cells: Shape) -> Result<(), MshError> {
        let facet = cells.facet_shape();
        for b in self.blocks.iter().filter(|b| b.kind.dim + 1 >= dim && b.kind.dim <= dim) {
            let (what, expected) = if b.kind.dim == dim { ("cells", cells) } else { ("boundary elements", facet) };
            if b.kind.shape != expected {
                let why = if b.kind.dim == dim && dim == 2 {
                    "this reads one kind of cell (Algorithm 1's `run` deforms meshes of one kind); `curve` takes quads and triangles together"
                } else if b.kind.dim == dim {
                    "a solid of hexes or of tetrahedra alone holds no other kind of cell (an empty element block of another kind counts: remove it)"
                } else {
                    "the boundary elements must be faces of the cells"
                };
                return Err(MshError::MixedShapes { at: b.at, what, expected, found: b.kind.shape, why });
            }
        }
        Ok(())
    }

    /// The linear hex mesh (`N = 8`, faces `K = 4`) or tetrahedral mesh
    /// (`N = 4`, `K = 3`) and its cells' element tags.
    pub fn solid_mesh<const N: usize, const K: usize>(&self) -> Result<(SolidMesh<N, K>, Vec<u64>), MshError> {
        self.check(LINEAR[1])?;
        self.one_shape(3, if N == 4 { Shape::Tetrahedron } else { Shape::Hexahedron })?;
        let (mesh, tags) = self.linear_mesh(self.nodes.clone())?;
        Ok((mesh.to_solid().expect("cells and faces of one kind, checked"), tags))
    }

    /// Fails unless every cell of a mixed solid is a tetrahedron, prism,
    /// pyramid or hexahedron and every boundary element a triangle or a
    /// quad.
    fn solid_kinds(&self) -> Result<(), MshError> {
        for b in self.blocks.iter().filter(|b| (2..=3).contains(&b.kind.dim)) {
            let (what, expected) = if b.kind.dim == 3 { ("cells", Shape::Prism) } else { ("boundary elements", Shape::Triangle) };
            if !matches!((b.kind.dim, b.kind.shape), (3, Shape::Tetrahedron | Shape::Prism | Shape::Pyramid | Shape::Hexahedron) | (2, Shape::Triangle | Shape::Quadrilateral)) {
                let why = "a mixed solid holds tetrahedra, prisms, pyramids and hexes, bounded by triangles and quads";
                return Err(MshError::MixedShapes { at: b.at, what, expected, found: b.kind.shape, why });
            }
        }
        Ok(())
    }

    /// Whether the solid cells are of more than one kind, or prisms or
    /// pyramids (which only the mixed solid holds).
    pub fn is_mixed_solid(&self) -> bool {
        let shapes = self.cell_shapes(3);
        shapes.len() > 1 || shapes.iter().any(|s| matches!(s, Shape::Prism | Shape::Pyramid))
    }

    /// The linear solid of tetrahedra, prisms, pyramids and hexes
    /// (boundary triangles and quads; hexes or tetrahedra alone bounded by
    /// their faces' kind), cells in tag order, and its cells' element
    /// tags.
    pub fn linear_solid(&self) -> Result<(CurvedMesh<3>, Vec<u64>), MshError> {
        self.check(LINEAR[1])?;
        if self.is_mixed_solid() {
            self.solid_kinds()?;
        } else {
            self.one_shape(3, if self.cell_shape(3) == Some(Shape::Tetrahedron) { Shape::Tetrahedron } else { Shape::Hexahedron })?;
        }
        self.linear_mesh(self.nodes.clone())
    }

    /// The mesh of the first cell's order, nodes in tensor order, and its
    /// cells' element tags; every element must have that order.
    pub fn curved_mesh<const D: usize>(&self) -> Result<(CurvedMesh<D>, Vec<u64>), MshError> {
        self.check(CURVED[D.clamp(2, 3) - 2])?;
        if D == 2 {
            self.in_plane()?;
        }
        let cells = self.by_tag(D);
        let Some(&(_, first, _)) = cells.first() else {
            let at = self.elements_at.expect("read");
            return Err(syntax(at, &format!("at least one {D}D cell"), "none"));
        };
        let p = first.kind.order;
        let shape = first.kind.shape;
        if D == 2 {
            self.plane_kinds()?;
        } else if self.is_mixed_solid() {
            self.solid_kinds()?;
        } else {
            self.one_shape(D, shape)?;
        }
        // each cell and facet by its own block's kind (a plane mesh may mix
        // quads and triangles, a solid prisms and tetrahedra)
        let perms: HashMap<Shape, Vec<usize>> = self.cell_shapes(D).into_iter().chain(self.cell_shapes(D - 1)).map(|s| (s, gmsh_perm(s, p))).collect();
        let (part_names, faces) = self.boundary(D - 1);
        let blocks = cells.iter().map(|c| c.1).chain(faces.iter().map(|f| f.2));
        if let Some(b) = blocks.into_iter().find(|b| b.kind.order != p) {
            return Err(syntax(b.at, &format!("an element of order {p}, as the first cell"), &format!("order {}", b.kind.order)));
        }
        let mesh = CurvedMesh {
            shape,
            p,
            spacing: Spacing::Equispaced,
            nodes: self.nodes.iter().map(|x| std::array::from_fn(|d| x[d])).collect(),
            cells: cells.iter().map(|c| (c.1.kind.shape, from_format(&perms[&c.1.kind.shape], c.2))).collect(),
            boundary: faces.iter().map(|&(nodes, part, b)| (b.kind.shape, from_format(&perms[&b.kind.shape], nodes), part)).collect(),
            part_names,
        };
        Ok((mesh, cells.iter().map(|c| c.0).collect()))
    }

    /// Fails on a block of a type `accept` leaves out: a file read for
    /// any kind of mesh, then made into one kind.
    fn check(&self, accept: Accept) -> Result<(), MshError> {
        match self.blocks.iter().find(|b| accept.kind(b.element_type).is_none()) {
            Some(b) => Err(MshError::UnknownElementType { at: b.at, accepted: accept.phrase, element_type: b.element_type }),
            None => Ok(()),
        }
    }

    /// A 2D mesh keeps x and y only: a node off z = 0 would move.
    fn in_plane(&self) -> Result<(), MshError> {
        match self.off_plane {
            Some((at, tag, z)) => Err(MshError::OffPlane { at, tag, z }),
            None => Ok(()),
        }
    }

    /// The elements of dimension `dim`, by tag (file order among equal
    /// tags).
    fn by_tag(&self, dim: usize) -> Vec<Element<'_>> {
        let blocks = self.blocks.iter().filter(|b| b.kind.dim == dim);
        let mut all: Vec<Element> = blocks.flat_map(|b| b.tags.iter().zip(b.nodes.chunks(b.kind.nodes)).map(move |(&t, n)| (t, b, n))).collect();
        all.sort_by_key(|e| e.0);
        all
    }

    /// Part names and the boundary elements of dimension `dim` with their
    /// part, one copy per part of their entity.
    fn boundary(&self, dim: usize) -> (Vec<String>, Vec<Facet<'_>>) {
        let elements = self.by_tag(dim);
        let (names, parts) = self.resolve_parts(dim, elements.iter().map(|e| e.1.entity));
        let copies = elements.iter().flat_map(|&(_, b, nodes)| parts[&b.entity].iter().map(move |&part| (nodes, part, b)));
        (names, copies.collect())
    }

    /// Part names and the parts of every entity in `entities` (of the
    /// boundary dimension `dim`); see the module docs.
    fn resolve_parts(&self, dim: usize, entities: impl Iterator<Item = i64>) -> (Vec<String>, HashMap<i64, Vec<usize>>) {
        let mut named: Vec<&(i64, i64, String)> = self.physical_names.iter().filter(|p| p.0 == dim as i64).collect();
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
        let prefix = if dim == 1 { "curve" } else { "surface" };
        let mut entity_parts = HashMap::new();
        for entity in entities {
            if entity_parts.contains_key(&entity) {
                continue;
            }
            let physicals = self.entity_physicals.get(&(dim, entity)).map(Vec::as_slice).unwrap_or(&[]);
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
            entity_parts.insert(entity, parts);
        }
        (names, entity_parts)
    }
}
