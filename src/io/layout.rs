//! What a mesh file holds besides the cells the method works on: its
//! physical groups, its entities, which entity each node and element is
//! on, the file's node and element tags, elements of lower dimensions
//! (points, curves of a 3D mesh) and periodic node pairs. A reader gives
//! the input's [`Layout`]; [`Layout::curved`] carries it onto the curved
//! mesh (new nodes numbered after the input's, every element and group
//! kept with its tag); the writers of every format write a `Layout`.
//! A mesh made by the crate itself has [`Layout::generated`].
//!
//! Element nodes are in the crate's tensor order ([`crate::mesh::element`])
//! at the element's order; writers turn them into the format's order.

use std::collections::HashMap;

use thiserror::Error;

use crate::mesh::element::{corner_indices, prism, pyramid, simplex};
use crate::mesh::CurvedMesh;

/// Name of the physical group that holds all cells of a mesh the crate
/// made (dimension 2 for quad meshes, 3 for hex meshes).
pub const DOMAIN_NAME: &str = "domain";

/// A named physical group: `$PhysicalNames`.
#[derive(Clone, Debug, PartialEq)]
pub struct PhysicalName {
    /// Its dimension.
    pub dim: usize,
    /// Its tag (the number solvers key boundary conditions on).
    pub tag: i64,
    /// Its name.
    pub name: String,
}

/// A geometric entity: a point, curve, surface or volume of `$Entities`.
#[derive(Clone, Debug, PartialEq)]
pub struct Entity {
    /// 0 to 3.
    pub dim: usize,
    /// Its tag among the entities of its dimension.
    pub tag: i64,
    /// Its point (dimension 0) or bounding box `min max` as the file gave
    /// it; writers put the box of its nodes where it has any.
    pub bbox: [f64; 6],
    /// The physical groups it is in.
    pub physicals: Vec<i64>,
    /// Signed tags of the entities of dimension `dim − 1` bounding it.
    pub bounding: Vec<i64>,
}

/// The kinds of element a layout holds: the element table's shapes.
pub use crate::mesh::element::Shape;

/// The tensor-product shape of dimension `dim` (0..=3): a generated
/// mesh's elements.
/// `attributes` with every one under 1 (entity 0 in no group) made 1, or
/// the largest in use plus one where 1 is taken: the writers' attributes
/// must be positive, and those elements must not join another group.
fn positive(mut attributes: Vec<i64>) -> Vec<i64> {
    if attributes.iter().all(|&a| a > 0) {
        return attributes;
    }
    let free = if attributes.contains(&1) { attributes.iter().max().map_or(1, |m| m.max(&0) + 1) } else { 1 };
    for a in attributes.iter_mut().filter(|a| **a <= 0) {
        *a = free;
    }
    attributes
}

fn tensor_of_dim(dim: usize) -> Shape {
    [Shape::Point, Shape::Line, Shape::Quadrilateral, Shape::Hexahedron][dim.min(3)]
}

/// One element of a file.
#[derive(Clone, Debug, PartialEq)]
pub struct Element {
    /// Its tag in the file.
    pub tag: u64,
    /// The tag of the entity of its dimension it lies on.
    pub entity: i64,
    /// Its shape.
    pub shape: Shape,
    /// Its Lagrange order (1 for points).
    pub order: usize,
    /// Indices into [`Layout::coords`], in the crate's order (tensor
    /// order, or the simplex lattice order).
    pub nodes: Vec<usize>,
}

/// Nodes of one entity paired with those of its master (`$Periodic`).
#[derive(Clone, Debug, PartialEq)]
pub struct Periodic {
    /// The dimension of both entities.
    pub dim: usize,
    /// The entity whose nodes are images.
    pub slave: i64,
    /// The entity they are images of.
    pub master: i64,
    /// The 4×4 affine map from master to slave, by rows (16 values), or
    /// empty where the file gave none.
    pub affine: Vec<f64>,
    /// `(slave node, master node)`, indices into [`Layout::coords`].
    pub pairs: Vec<(usize, usize)>,
}

/// A whole mesh file: groups, entities, nodes, elements, periodicity.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Layout {
    /// The named physical groups.
    pub physical_names: Vec<PhysicalName>,
    /// Every entity, of every dimension.
    pub entities: Vec<Entity>,
    /// Node coordinates (z = 0 in 2D).
    pub coords: Vec<[f64; 3]>,
    /// The file's tag of every node.
    pub node_tags: Vec<u64>,
    /// `(dimension, tag)` of the entity each node is on.
    pub node_entity: Vec<(usize, i64)>,
    /// Every element, of every dimension, in file order.
    pub elements: Vec<Element>,
    /// Periodic links.
    pub periodic: Vec<Periodic>,
    /// Sections of the file that no writer reproduces (`$NodeData`, …),
    /// by name, so that a caller that must lose nothing can refuse them.
    pub unkept_sections: Vec<String>,
    /// Whether some node block gave parametric coordinates (not kept).
    pub parametric: bool,
}

/// Why an input's layout cannot be carried onto its curved mesh.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum LayoutError {
    /// An element of the input has no counterpart in the curved mesh.
    #[error("element {tag} of the input (a {shape:?} on entity {entity}) is not in the curved mesh: {why}")]
    Lost {
        /// Its tag.
        tag: u64,
        /// Its shape.
        shape: Shape,
        /// Its entity.
        entity: i64,
        /// Why.
        why: String,
    },
    /// A node on a periodic entity has no image on its master: the two
    /// sides were not meshed as images of each other.
    #[error(
        "periodic link of entity {slave} (dimension {dim}) to master {master}: the node at {at:?} on the slave (at {place:?} on its straight side) has no node on the master whose place on the straight side the affine map takes to it \
         (nearest {miss:.3e} off): the two sides were not meshed as images of each other. Mesh them so (Gmsh: `setPeriodic` before meshing)"
    )]
    Unpaired {
        /// The dimension.
        dim: usize,
        /// The slave entity.
        slave: i64,
        /// The master entity.
        master: i64,
        /// Where the unpaired node is.
        at: [f64; 3],
        /// Its place on the straight side, which is paired.
        place: [f64; 3],
        /// How far the nearest master's image is from that place.
        miss: f64,
    },
    /// A periodic link without an affine map whose pairs are not a
    /// translation either.
    #[error("periodic link of entity {slave} (dimension {dim}) to master {master} gives no affine map and its node pairs are no translation: new nodes cannot be paired")]
    NoAffine {
        /// The dimension.
        dim: usize,
        /// The slave entity.
        slave: i64,
        /// The master entity.
        master: i64,
    },
}

/// How far, relative to the mesh's extent, a slave node's place on its
/// straight side may be from the image of its master's to be taken as its
/// pair: the places are exact images up to rounding where the two sides
/// were meshed as images; otherwise they are apart by a fraction of a
/// cell.
pub const PAIR_TOLERANCE: f64 = 1e-6;

/// `x` padded to three coordinates.
fn pad<const D: usize>(x: &[f64; D]) -> [f64; 3] {
    std::array::from_fn(|d| if d < D { x[d] } else { 0.0 })
}

impl Layout {
    /// The layout of a mesh the crate made: boundary part `i` is entity
    /// `i + 1` of dimension `D − 1` in physical group `i + 1` named after
    /// the part, all cells and nodes are on entity 1 of dimension `D`, in
    /// the group [`DOMAIN_NAME`] (tag `k + 1`); boundary element `e` has
    /// tag `e + 1`, cell `c` tag `boundary.len() + c + 1`, node `i` tag
    /// `i + 1`. Boundary elements of a part index out of range are left
    /// out.
    pub fn generated<const D: usize>(mesh: &CurvedMesh<D>) -> Layout {
        let k = mesh.part_names.len();
        let mut physical_names: Vec<PhysicalName> =
            mesh.part_names.iter().enumerate().map(|(i, name)| PhysicalName { dim: D - 1, tag: i as i64 + 1, name: name.clone() }).collect();
        physical_names.push(PhysicalName { dim: D, tag: k as i64 + 1, name: DOMAIN_NAME.into() });
        let entity = |dim, tag: i64, physical: i64, bounding| Entity { dim, tag, bbox: [0.0; 6], physicals: vec![physical], bounding };
        let mut entities: Vec<Entity> = (1..=k as i64).map(|t| entity(D - 1, t, t, Vec::new())).collect();
        entities.push(entity(D, 1, k as i64 + 1, (1..=k as i64).collect()));
        let (p, nb) = (mesh.p, mesh.boundary.len());
        let facets = mesh.boundary.iter().enumerate().filter(|(_, b)| b.part < k);
        let mut elements: Vec<Element> = facets
            .map(|(e, b)| Element { tag: e as u64 + 1, entity: b.part as i64 + 1, shape: b.shape, order: p, nodes: b.nodes.to_vec() })
            .collect();
        let cells = mesh.cells.iter().enumerate();
        elements.extend(cells.map(|(c, n)| Element { tag: (nb + c) as u64 + 1, entity: 1, shape: mesh.cell_shape(c), order: p, nodes: n.to_vec() }));
        Layout {
            physical_names,
            entities,
            coords: mesh.nodes.iter().map(pad).collect(),
            node_tags: (1..=mesh.nodes.len() as u64).collect(),
            node_entity: vec![(D, 1); mesh.nodes.len()],
            elements,
            ..Layout::default()
        }
    }

    /// The input's layout carried onto its curved mesh: `mesh` was made
    /// from the input's cells (in order of element tag), `coarse_nodes[i]`
    /// is the curved mesh's node at input node `i` (`usize::MAX` for a
    /// node in no cell). Every group, entity, element and periodic link
    /// of the input is kept with its tags; elements of dimension below the
    /// cells' are raised to the mesh's order with the nodes of the cells'
    /// edges and faces; new nodes are numbered after the input's largest
    /// tag, on the entity of the lowest-dimensional element that holds
    /// them; periodic links gain the pairs of their new nodes.
    /// Returns the layout and the largest move of a new periodic node put
    /// at its master's image (see [`Layout::snap_periodic`]): the caller
    /// moves the mesh's nodes to [`Layout::coords`] and certifies again
    /// if it is not 0.
    pub fn curved<const D: usize>(&self, mesh: &CurvedMesh<D>, coarse_nodes: &[usize]) -> Result<(Layout, f64), LayoutError> {
        let (coords, of_input) = self.merged_nodes(mesh, coarse_nodes);
        let p = mesh.p;
        let wanted = self.elements.iter().filter(|e| (1..D).contains(&e.shape.dim())).map(|e| {
            let mut key: Vec<usize> = e.nodes.iter().map(|&n| of_input[n]).collect();
            key.sort_unstable();
            key
        });
        let lookup = SubElements::new(mesh, &wanted.collect());
        let mut cells_by_tag: Vec<usize> = (0..self.elements.len()).filter(|&e| self.elements[e].shape.dim() == D).collect();
        cells_by_tag.sort_by_key(|&e| self.elements[e].tag);
        let cell_of: HashMap<usize, usize> = cells_by_tag.iter().enumerate().map(|(c, &e)| (e, c)).collect();
        let mut elements = Vec::with_capacity(self.elements.len());
        for (e, el) in self.elements.iter().enumerate() {
            let corners: Vec<usize> = el.nodes.iter().map(|&n| of_input[n]).collect();
            let lost = |why: &str| LayoutError::Lost { tag: el.tag, shape: el.shape, entity: el.entity, why: why.into() };
            let (order, nodes) = match el.shape.dim() {
                0 => (1, corners),
                d if d == D => (p, curved_cell(mesh, cell_of[&e], el.shape).map_err(|why| lost(&why))?),
                _ => (p, lookup.find(&corners).ok_or_else(|| lost("its corners are no edge or face of a cell"))?),
            };
            elements.push(Element { tag: el.tag, entity: el.entity, shape: el.shape, order, nodes });
        }
        let node_tags = self.new_node_tags(&of_input, coords.len());
        let node_entity = self.new_node_entities(&of_input, &elements, coords.len());
        let mut out = Layout { physical_names: self.physical_names.clone(), entities: self.entities.clone(), coords, node_tags, node_entity, elements, ..Layout::default() };
        let mut new_pairs = Vec::new();
        for link in &self.periodic {
            let (carried, map, new) = out.carry_periodic(link, &of_input)?;
            out.periodic.push(carried);
            new_pairs.push((map, new));
        }
        let snapped = out.snap_periodic(&new_pairs);
        Ok((out, snapped))
    }

    /// Puts every new slave node exactly at the affine image of its
    /// master (paired by their places on the straight sides, they are as
    /// far apart as the flow moved the two sides differently: about 1e-9
    /// on symmetric sides, a few hundredths of a cell on sliding sides of
    /// tetrahedra); passes repeat so that a master that is itself a slave of another
    /// link (an edge periodic in two directions) is placed first. Returns
    /// the largest move.
    fn snap_periodic(&mut self, links: &[([f64; 12], Vec<(usize, usize)>)]) -> f64 {
        let mut largest: f64 = 0.0;
        for _ in 0..4 {
            let mut moved = false;
            for (map, pairs) in links {
                for &(s, m) in pairs {
                    let image = apply(map, self.coords[m]);
                    let d = dist(image, self.coords[s]);
                    if d > 0.0 {
                        largest = largest.max(d);
                        moved = true;
                        self.coords[s] = image;
                    }
                }
            }
            if !moved {
                break;
            }
        }
        largest
    }

    /// The layout as a mesh of its cells (dimension `D`, in order of
    /// element tag: the order the readers give) and its elements of
    /// dimension `D − 1`, each once, for the writers of formats without
    /// entities: with the attribute of every cell and boundary element
    /// (the first physical tag of its entity, else the entity's tag: the
    /// numbers solvers key on; an element of entity 0 in no group, as a
    /// mesh from a tool that writes no tags has, gets 1, MFEM's attribute
    /// for an element of no group, or the largest in use plus one where 1
    /// is taken) and, as the boundary parts, the names of those groups
    /// (`surface<tag>` / `curve<tag>` for an entity in none).
    pub fn as_mesh<const D: usize>(&self) -> (CurvedMesh<D>, Vec<i64>, Vec<i64>) {
        let mut cells: Vec<&Element> = self.elements.iter().filter(|e| e.shape.dim() == D).collect();
        cells.sort_by_key(|e| e.tag);
        let facets: Vec<&Element> = self.elements.iter().filter(|e| e.shape.dim() + 1 == D).collect();
        let attribute = |dim: usize, entity: i64| {
            let e = self.entities.iter().find(|x| x.dim == dim && x.tag == entity);
            e.and_then(|x| x.physicals.first().copied()).unwrap_or(entity)
        };
        let mut part_names: Vec<String> = Vec::new();
        let mut part_of: HashMap<i64, usize> = HashMap::new();
        let mut boundary = crate::mesh::Facets::new();
        let mut boundary_attributes = Vec::with_capacity(facets.len());
        for f in &facets {
            let a = attribute(D - 1, f.entity);
            let part = *part_of.entry(a).or_insert_with(|| {
                let named = self.physical_names.iter().find(|g| g.dim == D - 1 && g.tag == a);
                part_names.push(named.map_or_else(|| format!("{}{a}", if D == 2 { "curve" } else { "surface" }), |g| g.name.clone()));
                part_names.len() - 1
            });
            boundary.push(f.shape, &f.nodes, part);
            boundary_attributes.push(a);
        }
        let boundary_attributes = positive(boundary_attributes);
        let mesh = CurvedMesh {
            shape: cells.first().map_or(tensor_of_dim(D), |c| c.shape),
            p: cells.first().map_or(1, |c| c.order),
            spacing: crate::mesh::element::Spacing::Equispaced,
            nodes: self.coords.iter().map(|x| std::array::from_fn(|d| x[d])).collect(),
            // in blocks of their kinds: `shape` is the first's
            cells: cells.iter().map(|c| (c.shape, &c.nodes)).collect(),
            boundary,
            part_names,
        };
        let cell_attributes = positive(cells.iter().map(|c| attribute(D, c.entity)).collect());
        (mesh, cell_attributes, boundary_attributes)
    }

    /// The curved mesh's nodes, then input nodes in no cell; and where
    /// each input node went.
    fn merged_nodes<const D: usize>(&self, mesh: &CurvedMesh<D>, coarse_nodes: &[usize]) -> (Vec<[f64; 3]>, Vec<usize>) {
        let mut coords: Vec<[f64; 3]> = mesh.nodes.iter().map(pad).collect();
        let of_input = (0..self.coords.len())
            .map(|i| match coarse_nodes.get(i).copied().filter(|&n| n < mesh.nodes.len()) {
                Some(n) => n,
                None => {
                    coords.push(self.coords[i]);
                    coords.len() - 1
                }
            })
            .collect();
        (coords, of_input)
    }

    /// Input nodes keep their tags; new ones count on from the largest.
    fn new_node_tags(&self, of_input: &[usize], count: usize) -> Vec<u64> {
        let mut tags = vec![0u64; count];
        for (i, &n) in of_input.iter().enumerate() {
            tags[n] = self.node_tags[i];
        }
        let mut next = self.node_tags.iter().copied().max().unwrap_or(0);
        for t in tags.iter_mut().filter(|t| **t == 0) {
            next += 1;
            *t = next;
        }
        tags
    }

    /// Input nodes keep their entities; a new node goes on the entity of
    /// the lowest-dimensional element holding it.
    fn new_node_entities(&self, of_input: &[usize], elements: &[Element], count: usize) -> Vec<(usize, i64)> {
        let mut entity: Vec<Option<(usize, i64)>> = vec![None; count];
        for (i, &n) in of_input.iter().enumerate() {
            entity[n] = Some(self.node_entity[i]);
        }
        let mut by_dim: Vec<&Element> = elements.iter().collect();
        by_dim.sort_by_key(|e| e.shape.dim());
        for el in by_dim {
            for &n in &el.nodes {
                entity[n].get_or_insert((el.shape.dim(), el.entity));
            }
        }
        on_input_curves(elements, &mut entity, of_input);
        // a node in no element at all (none is made so) stays on the first cell's entity
        let fallback = elements.iter().max_by_key(|e| e.shape.dim()).map_or((0, 0), |e| (e.shape.dim(), e.entity));
        entity.into_iter().map(|e| e.unwrap_or(fallback)).collect()
    }

    /// An input link with its pairs on this (curved) layout's nodes, and
    /// pairs for every other node of the slave's closure: a side is the
    /// nodes the input paired on it and the corners of its elements;
    /// every node of a sub-element (edge, face) whose corners are all on
    /// the slave is paired with the master node whose place on its
    /// straight sub-element the affine map takes to the slave node's
    /// place on its own. Places on the straight sides, not the nodes'
    /// positions, decide: a slip side moves its new nodes as the flow
    /// takes them, which need not be as its master's moved (a tetrahedral
    /// mesh is not symmetric across the period). Returns the link, its
    /// map and the pairs whose slave is a new node (those the caller puts
    /// at the image of their master).
    fn carry_periodic(&self, link: &Periodic, of_input: &[usize]) -> Result<(Periodic, [f64; 12], Vec<(usize, usize)>), LayoutError> {
        use std::collections::HashSet;
        let old: Vec<(usize, usize)> = link.pairs.iter().map(|&(s, m)| (of_input[s], of_input[m])).collect();
        let map = affine_of(link, &old, &self.coords).ok_or(LayoutError::NoAffine { dim: link.dim, slave: link.slave, master: link.master })?;
        let side = |entity: i64, paired: &mut dyn Iterator<Item = usize>| -> HashSet<usize> {
            let on = self.elements.iter().filter(|e| e.shape.dim() == link.dim && e.entity == entity);
            let corners = on.flat_map(|e| corner_indices(e.shape, e.order).into_iter().map(|c| e.nodes[c]));
            paired.chain(corners).collect()
        };
        let slave_side = side(link.slave, &mut old.iter().map(|&(s, _)| s));
        let master_side = side(link.master, &mut old.iter().map(|&(_, m)| m));
        // every node of a side with its place on the straight side (the
        // corners' own positions)
        let closure = |side: &HashSet<usize>| -> Vec<(usize, [f64; 3])> {
            let mut nodes = self.straight_places(link.dim, side);
            nodes.extend(side.iter().map(|&n| (n, self.coords[n])));
            nodes.sort_by_key(|x| x.0);
            nodes.dedup_by_key(|x| x.0);
            nodes
        };
        let paired: HashSet<usize> = old.iter().map(|&(s, _)| s).collect();
        let slaves: Vec<(usize, [f64; 3])> = closure(&slave_side).into_iter().filter(|n| !paired.contains(&n.0)).collect();
        let masters = closure(&master_side);
        let images: Vec<[f64; 3]> = masters.iter().map(|&(_, x)| apply(&map, x)).collect();
        let scale = self.extent().max(f64::MIN_POSITIVE);
        let grid = PointGrid::new(&images, scale * PAIR_TOLERANCE);
        let old_nodes: HashSet<usize> = of_input.iter().copied().collect();
        let (mut pairs, mut movable) = (old, Vec::new());
        for (s, place) in slaves {
            let (k, miss) = grid.nearest(&images, place);
            if miss > PAIR_TOLERANCE * scale {
                return Err(LayoutError::Unpaired { dim: link.dim, slave: link.slave, master: link.master, at: self.coords[s], place, miss });
            }
            pairs.push((s, masters[k].0));
            if !old_nodes.contains(&s) {
                movable.push((s, masters[k].0));
            }
        }
        Ok((Periodic { dim: link.dim, slave: link.slave, master: link.master, affine: link.affine.clone(), pairs }, map, movable))
    }

    /// The nodes of the sub-elements of dimension `dim` (a cell's edges
    /// or faces, or a boundary element itself) whose corners all lie in
    /// `side`, each with its place on the straight sub-element (its
    /// lattice point mapped by the corners).
    fn straight_places(&self, dim: usize, side: &std::collections::HashSet<usize>) -> Vec<(usize, [f64; 3])> {
        let mut out = Vec::new();
        if dim == 0 {
            return out;
        }
        for el in self.elements.iter().filter(|e| e.shape.dim() >= dim) {
            if !corner_indices(el.shape, el.order).iter().any(|&c| side.contains(&el.nodes[c])) {
                continue;
            }
            for (sub_shape, sub) in sub_elements(el.shape, el.order, dim) {
                let corners = corner_indices(sub_shape, el.order);
                if corners.iter().all(|&c| side.contains(&el.nodes[sub[c]])) {
                    let at: Vec<[f64; 3]> = corners.iter().map(|&c| self.coords[el.nodes[sub[c]]]).collect();
                    out.extend(sub.iter().enumerate().map(|(k, &i)| (el.nodes[i], straight_place(sub_shape, el.order, k, &at))));
                }
            }
        }
        out
    }

    /// The diagonal of the nodes' bounding box.
    pub(crate) fn extent(&self) -> f64 {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for x in &self.coords {
            for d in 0..3 {
                lo[d] = lo[d].min(x[d]);
                hi[d] = hi[d].max(x[d]);
            }
        }
        (0..3).map(|d| (hi[d] - lo[d]).max(0.0).powi(2)).sum::<f64>().sqrt()
    }
}

/// Where lattice node `k` of an order-`p` sub-element of `shape` (a
/// line, triangle or quadrilateral, nodes in its own lattice order) lies
/// on the straight sub-element with corners `at` ([`corner_indices`]'
/// order): a corner exactly where it is.
fn straight_place(shape: Shape, p: usize, k: usize, at: &[[f64; 3]]) -> [f64; 3] {
    let p_f = p as f64;
    let mix = |w: &[f64]| std::array::from_fn(|d| w.iter().zip(at).map(|(w, x)| w * x[d]).sum());
    match shape {
        Shape::Line => {
            let t = k as f64 / p_f;
            mix(&[1.0 - t, t])
        }
        Shape::Triangle => {
            let [i, j, _] = simplex::lattice(Shape::Triangle, p)[k];
            let (s, t) = (i as f64 / p_f, j as f64 / p_f);
            mix(&[1.0 - s - t, s, t])
        }
        Shape::Quadrilateral => {
            let (s, t) = ((k % (p + 1)) as f64 / p_f, (k / (p + 1)) as f64 / p_f);
            mix(&[(1.0 - s) * (1.0 - t), s * (1.0 - t), (1.0 - s) * t, s * t])
        }
        _ => at[0],
    }
}

/// The affine map of a link as 12 numbers (3×4, by rows): the file's,
/// checked against the first pair (or its inverse, if the file's maps the
/// other way), else the translation of the pairs, if they all agree.
fn affine_of(link: &Periodic, pairs: &[(usize, usize)], coords: &[[f64; 3]]) -> Option<[f64; 12]> {
    let scale = coords.iter().flat_map(|x| x.iter()).fold(0.0f64, |a, &b| a.max(b.abs())).max(1.0);
    let fits = |m: &[f64; 12]| pairs.iter().all(|&(s, ms)| dist(apply(m, coords[ms]), coords[s]) <= 1e-8 * scale);
    if link.affine.len() == 16 {
        let m: [f64; 12] = std::array::from_fn(|i| link.affine[i]);
        if fits(&m) {
            return Some(m);
        }
    }
    let &(s, m) = pairs.first()?;
    let t: [f64; 3] = std::array::from_fn(|d| coords[s][d] - coords[m][d]);
    let shift = [1.0, 0.0, 0.0, t[0], 0.0, 1.0, 0.0, t[1], 0.0, 0.0, 1.0, t[2]];
    fits(&shift).then_some(shift)
}

/// The distance of two points.
fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    crate::numeric::norm(crate::numeric::sub(a, b))
}

/// `m x` for a 3×4 affine map.
fn apply(m: &[f64; 12], x: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| m[4 * r] * x[0] + m[4 * r + 1] * x[1] + m[4 * r + 2] * x[2] + m[4 * r + 3])
}

/// Puts the new nodes of a solid's mesh edge that runs along a curve of
/// the input on that curve: an edge whose ends the input classifies on
/// curve c (or one on c, one on a point), in faces of two entities (where
/// two surfaces meet). A file that saves no line elements (physical
/// groups on surfaces only) still gets them right: a CAD check of the
/// written file projects them onto the curve they were put on.
fn on_input_curves(elements: &[Element], entity: &mut [Option<(usize, i64)>], of_input: &[usize]) {
    if elements.iter().all(|e| e.shape.dim() < 3) {
        return;
    }
    let mut old = vec![false; entity.len()];
    for &n in of_input {
        old[n] = true;
    }
    let mut edges: HashMap<(usize, usize), (Vec<usize>, Vec<i64>)> = HashMap::new();
    for el in elements.iter().filter(|e| e.shape.dim() == 2) {
        let ends = corner_indices(Shape::Line, el.order);
        for (_, sub) in sub_elements(el.shape, el.order, 1) {
            let (a, b) = (el.nodes[sub[ends[0]]], el.nodes[sub[ends[1]]]);
            let e = edges.entry((a.min(b), a.max(b))).or_insert_with(|| (sub.iter().map(|&i| el.nodes[i]).filter(|&n| !old[n]).collect(), Vec::new()));
            if !e.1.contains(&el.entity) {
                e.1.push(el.entity);
            }
        }
    }
    for ((a, b), (inner, faces)) in edges {
        let curve = match (entity[a], entity[b]) {
            (Some((1, c)), Some((1, d))) if c == d => c,
            (Some((1, c)), Some((0, _))) | (Some((0, _)), Some((1, c))) => c,
            _ => continue,
        };
        if faces.len() >= 2 {
            for n in inner {
                entity[n] = Some((1, curve));
            }
        }
    }
}

/// Every sub-element of dimension `dim` of an element of order `p` (its
/// edges for 1, faces for 2, itself for its own dimension), with its
/// shape, as local indices in the sub-element's own order.
fn sub_elements(shape: Shape, p: usize, dim: usize) -> Vec<(Shape, Vec<usize>)> {
    let d = shape.dim();
    if dim > d {
        return Vec::new();
    }
    if dim == 0 {
        return corner_indices(shape, p).into_iter().map(|c| (Shape::Point, vec![c])).collect();
    }
    if dim == d {
        return vec![(shape, (0..shape.num_nodes(p)).collect())];
    }
    if matches!(shape, Shape::Prism | Shape::Pyramid) {
        return prism_sub_elements(shape, p, dim);
    }
    if shape.is_simplex() {
        return match dim {
            1 => (0..shape.edges().len()).map(|e| (Shape::Line, simplex::edge_nodes(shape, p, e))).collect(),
            _ => (0..shape.faces().len()).map(|f| (Shape::Triangle, simplex::face_nodes(shape, p, f))).collect(),
        };
    }
    let n1 = p + 1;
    let stride = |k: usize| n1.pow(k as u32);
    let mut out = Vec::new();
    // the free axes, in increasing order, and the fixed ones at 0 or p
    for free in (0..1usize << d).filter(|m| m.count_ones() as usize == dim) {
        let axes: Vec<usize> = (0..d).filter(|k| free >> k & 1 == 1).collect();
        let fixed: Vec<usize> = (0..d).filter(|k| free >> k & 1 == 0).collect();
        for side in 0..1usize << fixed.len() {
            let base: usize = fixed.iter().enumerate().map(|(j, &k)| ((side >> j) & 1) * p * stride(k)).sum();
            let nodes = (0..n1.pow(dim as u32))
                .map(|i| base + axes.iter().enumerate().map(|(j, &k)| (i / n1.pow(j as u32) % n1) * stride(k)).sum::<usize>())
                .collect();
            out.push((tensor_of_dim(dim), nodes));
        }
    }
    out
}

/// [`sub_elements`] of an order-`p` prism or pyramid (dimension 1 or 2):
/// each edge from its first vertex, each face on its loop
/// ([`Shape::faces`]) — a triangle in lattice order, a quad in tensor
/// order from its first corner towards its second (the element modules'
/// `edge_nodes` and `face_nodes`).
fn prism_sub_elements(shape: Shape, p: usize, dim: usize) -> Vec<(Shape, Vec<usize>)> {
    type NodesOf = fn(usize, usize) -> Vec<usize>;
    let (edge, face): (NodesOf, NodesOf) = match shape {
        Shape::Pyramid => (pyramid::edge_nodes, pyramid::face_nodes),
        _ => (prism::edge_nodes, prism::face_nodes),
    };
    if dim == 1 {
        return (0..shape.edges().len()).map(|e| (Shape::Line, edge(p, e))).collect();
    }
    shape.faces().iter().enumerate().map(|(f, &(kind, _))| (kind, face(p, f))).collect()
}

/// What [`SubElements::new`] looks up per cell of one kind, computed once
/// per kind rather than per cell.
struct CellKind {
    shape: Shape,
    /// Local indices of the cell's corners.
    corners: Vec<usize>,
    /// Its edges and faces (dimensions `1..D`): their corners' places in
    /// the sub-element, and their nodes as local indices of the cell.
    subs: Vec<(Vec<usize>, Vec<usize>)>,
}

impl CellKind {
    fn new(shape: Shape, p: usize, dim: usize) -> CellKind {
        let subs = (1..dim).flat_map(|d| sub_elements(shape, p, d)).map(|(s, sub)| (corner_indices(s, p), sub)).collect();
        CellKind { shape, corners: corner_indices(shape, p), subs }
    }
}

/// Curved cell `c`, which must be of the input element's `shape`: input
/// cells and curved cells are matched by tag order alone, so a kind that
/// differs means the orders disagree (a triangle would be written with a
/// quad's nodes).
fn curved_cell<const D: usize>(mesh: &CurvedMesh<D>, c: usize, shape: Shape) -> Result<Vec<usize>, String> {
    let cell = mesh.cells.get(c).ok_or("fewer curved cells than input cells")?;
    match mesh.cell_shape(c) {
        s if s == shape => Ok(cell.to_vec()),
        s => Err(format!("its curved cell {c} is a {s:?}")),
    }
}

/// The edges and faces of the curved mesh's cells, by their corner sets.
struct SubElements {
    /// Sorted corners → the sub-element's nodes in its own tensor order.
    by_corners: HashMap<Vec<usize>, Vec<usize>>,
    /// Tensor indices of corners of a sub-element, per dimension.
    p: usize,
}

impl SubElements {
    /// The edges and faces of `mesh` whose sorted corners are in
    /// `wanted` (only those: a mesh of 10⁶ hexes has 1.8·10⁷ of them),
    /// a boundary element's own orientation preferred.
    fn new<const D: usize>(mesh: &CurvedMesh<D>, wanted: &std::collections::HashSet<Vec<usize>>) -> SubElements {
        let mut by_corners = HashMap::new();
        let mut keep = |key: Vec<usize>, nodes: &dyn Fn() -> Vec<usize>, prefer: bool| {
            if wanted.contains(&key) && (prefer || !by_corners.contains_key(&key)) {
                by_corners.insert(key, nodes());
            }
        };
        for b in &mesh.boundary {
            // a 3D boundary of triangles and quads: each by its own kind
            let shape = b.shape;
            let mut key: Vec<usize> = corner_indices(shape, mesh.p).iter().map(|&c| b.nodes[c]).collect();
            key.sort_unstable();
            keep(key, &|| b.nodes.to_vec(), true);
        }
        let kinds: Vec<CellKind> = mesh.shapes().into_iter().map(|s| CellKind::new(s, mesh.p, D)).collect();
        let near: std::collections::HashSet<usize> = wanted.iter().flatten().copied().collect();
        for (c, cell) in mesh.cells.iter().enumerate() {
            // each cell by its own kind: a mixed mesh holds quads and triangles
            let shape = mesh.cell_shape(c);
            let kind = kinds.iter().find(|k| k.shape == shape).expect("shapes() holds every cell's kind");
            if !kind.corners.iter().any(|&k| near.contains(&cell[k])) {
                continue;
            }
            for (corners, sub) in &kind.subs {
                let mut key: Vec<usize> = corners.iter().map(|&c| cell[sub[c]]).collect();
                key.sort_unstable();
                keep(key, &|| sub.iter().map(|&i| cell[i]).collect(), false);
            }
        }
        SubElements { by_corners, p: mesh.p }
    }

    /// The nodes of the edge or face with the given corners (tensor
    /// order of the input element), oriented as the input element: its
    /// first corner first and, for a face, its second corner next.
    fn find(&self, corners: &[usize]) -> Option<Vec<usize>> {
        let mut key = corners.to_vec();
        key.sort_unstable();
        let nodes = self.by_corners.get(&key)?;
        if corners.len() == 3 {
            return Self::oriented_triangle(nodes, corners, self.p);
        }
        let dim = if corners.len() == 2 { 1 } else { 2 };
        let p = self.p;
        let n1 = p + 1;
        // the symmetries of the segment or square, applied to (u, v)
        let maps: Vec<Box<dyn Fn(usize, usize) -> (usize, usize)>> = if dim == 1 {
            vec![Box::new(|u, v| (u, v)), Box::new(move |u, v| (p - u, v))]
        } else {
            vec![
                Box::new(|u, v| (u, v)),
                Box::new(move |u, v| (p - u, v)),
                Box::new(move |u, v| (u, p - v)),
                Box::new(move |u, v| (p - u, p - v)),
                Box::new(|u, v| (v, u)),
                Box::new(move |u, v| (p - v, u)),
                Box::new(move |u, v| (v, p - u)),
                Box::new(move |u, v| (p - v, p - u)),
            ]
        };
        let count = n1.pow(dim as u32);
        let nv = if dim == 1 { 1 } else { n1 };
        let at = |i: usize| (i % n1, i / n1);
        let ends = corner_indices(tensor_of_dim(dim), p);
        maps.iter().find_map(|f| {
            let image = |i: usize| {
                let (u, v) = at(i);
                let (a, b) = f(u, v);
                if nv == 1 { a } else { a + n1 * b }
            };
            let out: Vec<usize> = (0..count).map(|i| nodes[image(i)]).collect();
            ends.iter().zip(corners).all(|(&c, &want)| out[c] == want).then_some(out)
        })
    }

    /// [`SubElements::find`] for a triangle face (lattice order): the one
    /// of its six symmetries (permutations of the barycentric indices)
    /// that puts `corners` at its vertices in order.
    fn oriented_triangle(nodes: &[usize], corners: &[usize], p: usize) -> Option<Vec<usize>> {
        let lattice = simplex::lattice(Shape::Triangle, p);
        let position: HashMap<[usize; 2], usize> = lattice.iter().enumerate().map(|(k, l)| ([l[0], l[1]], k)).collect();
        let ends = corner_indices(Shape::Triangle, p);
        let perms = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
        perms.iter().find_map(|sigma| {
            let out: Vec<usize> = lattice
                .iter()
                .map(|l| {
                    let bary = [p - l[0] - l[1], l[0], l[1]];
                    let b = sigma.map(|k| bary[k]);
                    nodes[position[&[b[1], b[2]]]]
                })
                .collect();
            ends.iter().zip(corners).all(|(&c, &want)| out[c] == want).then_some(out)
        })
    }
}

/// A uniform grid of points for nearest-point queries.
struct PointGrid {
    cell: f64,
    bins: HashMap<[i64; 3], Vec<usize>>,
}

impl PointGrid {
    fn new(points: &[[f64; 3]], cell: f64) -> PointGrid {
        let mut bins: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        for (i, x) in points.iter().enumerate() {
            bins.entry(Self::bin(x, cell)).or_default().push(i);
        }
        PointGrid { cell, bins }
    }

    fn bin(x: &[f64; 3], cell: f64) -> [i64; 3] {
        std::array::from_fn(|d| (x[d] / cell).floor() as i64)
    }

    /// The point nearest `x` among the 27 bins around it, or the
    /// nearest of all (with its distance) if they are empty.
    fn nearest(&self, points: &[[f64; 3]], x: [f64; 3]) -> (usize, f64) {
        let b = Self::bin(&x, self.cell);
        let distance = |i: usize| (i, dist(points[i], x));
        let closer = |a: (usize, f64), b: (usize, f64)| if b.1 < a.1 { b } else { a };
        let near = (0..27)
            .flat_map(|k| {
                let key = [b[0] + k % 3 - 1, b[1] + k / 3 % 3 - 1, b[2] + k / 9 - 1];
                self.bins.get(&key).into_iter().flatten().copied()
            })
            .map(distance)
            .reduce(closer);
        near.or_else(|| (0..points.len()).map(distance).reduce(closer)).unwrap_or((0, f64::INFINITY))
    }
}

#[cfg(test)]
/// Tests, and the mixed test mesh the writers' and the 2D plan's tests
/// share (`pub`: a test module as `scripts/deps.py` recognises one).
pub mod tests {
    use super::*;

    #[test]
    fn elements_of_no_entity_get_a_positive_attribute_of_their_own() {
        // a tagless file: all on entity 0, attribute 1 as MFEM gives
        assert_eq!(positive(vec![0, 0]), vec![1, 1]);
        // 1 taken by a group: the largest plus one, not merged into it
        assert_eq!(positive(vec![1, 0, 3, -2]), vec![1, 4, 3, 4]);
        assert_eq!(positive(vec![2, 0]), vec![2, 1]);
        assert_eq!(positive(vec![5, 7]), vec![5, 7]);
    }
    use crate::mesh::element::Spacing;

    /// A mixed mesh of order `p` (equispaced) on [0, 3] × [0, 1], its
    /// nodes bent by a smooth non-affine map: quads [0, 1] × [0, 1] and
    /// [1, 2] × [0, 1] (cells 0, 1), and the square [2, 3] × [0, 1] cut
    /// along its diagonal (2, 0)–(3, 1) into triangles (cells 2, 3), each
    /// sharing an edge with the next. Node `g` of the lattice of step
    /// `1/p` is numbered as first met; the boundary is one part `"wall"`,
    /// eight lines counter-clockwise.
    pub(crate) fn mixed2(p: usize) -> CurvedMesh<2> {
        let bend = |[x, y]: [f64; 2]| [x + 0.1 * (2.0 * y).sin(), y + 0.05 * x * x];
        let (mut nodes, mut index) = (Vec::new(), HashMap::new());
        let mut at = |g: [usize; 2]| {
            *index.entry(g).or_insert_with(|| {
                nodes.push(bend(g.map(|v| v as f64 / p as f64)));
                nodes.len() - 1
            })
        };
        let q = p + 1;
        let mut cells: Vec<Vec<usize>> = [0, 1].iter().map(|&x0| (0..q * q).map(|a| at([x0 * p + a % q, a / q])).collect()).collect();
        for v in [[[2, 0], [3, 0], [3, 1]], [[2, 0], [3, 1], [2, 1]]] {
            let [a, b, c]: [[usize; 2]; 3] = v;
            let lattice = simplex::lattice(Shape::Triangle, p);
            cells.push(lattice.iter().map(|l| at(std::array::from_fn(|d| a[d] * p + l[0] * b[d] + l[1] * c[d] - (l[0] + l[1]) * a[d]))).collect());
        }
        let around = [[0, 0], [1, 0], [2, 0], [3, 0], [3, 1], [2, 1], [1, 1], [0, 1], [0, 0]];
        let boundary = around
            .windows(2)
            .map(|w| {
                let nodes: Vec<usize> = (0..q).map(|k| at(std::array::from_fn(|d| w[0][d] * p + k * w[1][d] - k * w[0][d]))).collect();
                (Shape::Line, nodes, 0)
            })
            .collect();
        let cells = crate::mesh::Cells::from_cells(2, p, Shape::Quadrilateral, cells);
        CurvedMesh { shape: Shape::Quadrilateral, p, spacing: Spacing::Equispaced, nodes, cells, boundary, part_names: vec!["wall".into()] }
    }

    #[test]
    fn the_mixed_test_mesh_is_valid_and_shares_its_edges() {
        for p in [2, 3] {
            let m = mixed2(p);
            m.validate().unwrap();
            assert_eq!(m.nodes.len(), (3 * p + 1) * (p + 1), "every lattice node once");
            let kinds: Vec<Shape> = (0..4).map(|c| m.cell_shape(c)).collect();
            assert_eq!(kinds, [Shape::Quadrilateral, Shape::Quadrilateral, Shape::Triangle, Shape::Triangle]);
            // the quad's right edge x = 2 is the second triangle's edge (2,1)–(2,0)
            let right: Vec<usize> = (0..=p).map(|j| m.cells[1][p + (p + 1) * j]).collect();
            let mut edge = simplex::edge_nodes(Shape::Triangle, p, 2).iter().map(|&a| m.cells[3][a]).collect::<Vec<_>>();
            edge.reverse();
            assert_eq!(right, edge);
        }
    }

    #[test]
    fn a_generated_layout_gives_each_cell_its_own_shape() {
        for p in [2, 3] {
            let m = mixed2(p);
            let layout = Layout::generated(&m);
            let cells: Vec<&Element> = layout.elements.iter().filter(|e| e.shape.dim() == 2).collect();
            let shapes: Vec<Shape> = cells.iter().map(|e| e.shape).collect();
            assert_eq!(shapes, [Shape::Quadrilateral, Shape::Quadrilateral, Shape::Triangle, Shape::Triangle]);
            assert!(cells.iter().all(|e| e.order == p && e.nodes.len() == e.shape.num_nodes(p)));
            // and back: the mesh view keeps every cell's nodes, so its kind
            let (back, attributes, _) = layout.as_mesh::<2>();
            assert_eq!((back.cells, back.shape, attributes), (m.cells, Shape::Quadrilateral, vec![2; 4]));
        }
    }

    /// The linear mixed input, its layout with a line on the triangles'
    /// diagonal (no boundary element: only the triangle cells have it),
    /// and where each of its nodes is in `curved`.
    fn mixed_input(curved: &CurvedMesh<2>) -> (Layout, Vec<usize>) {
        let coarse = mixed2(1);
        let mut input = Layout::generated(&coarse);
        input.elements.push(Element { tag: 100, entity: 9, shape: Shape::Line, order: 1, nodes: vec![coarse.cells[2][0], coarse.cells[2][2]] });
        let coarse_nodes = coarse.nodes.iter().map(|x| curved.nodes.iter().position(|y| y == x).expect("a corner")).collect();
        (input, coarse_nodes)
    }

    #[test]
    fn a_mixed_input_is_carried_onto_cells_of_its_kinds() {
        for p in [2, 3] {
            let m = mixed2(p);
            let (input, coarse_nodes) = mixed_input(&m);
            let (out, snapped) = input.curved(&m, &coarse_nodes).unwrap();
            assert_eq!(snapped, 0.0);
            let cells: Vec<&Element> = out.elements.iter().filter(|e| e.shape.dim() == 2).collect();
            for (c, e) in cells.iter().enumerate() {
                assert_eq!((e.shape, e.order, &e.nodes), (m.cell_shape(c), p, &m.cells[c].to_vec()), "cell {c}");
            }
            // the diagonal from (2, 0) to (3, 1): the second triangle's
            // edge 0 (its vertices 0 → 1), in that order
            let diagonal = out.elements.iter().find(|e| e.tag == 100).unwrap();
            let want: Vec<usize> = simplex::edge_nodes(Shape::Triangle, p, 0).iter().map(|&a| m.cells[3][a]).collect();
            assert_eq!((diagonal.order, &diagonal.nodes), (p, &want));
        }
    }

    #[test]
    fn an_input_cell_matched_to_a_curved_cell_of_another_kind_is_lost() {
        let mut m = mixed2(2);
        let mut cells = m.cells.to_vecs();
        cells.swap(1, 2);
        m.cells = crate::mesh::Cells::from_cells(2, m.p, m.shape, cells);
        let (input, coarse_nodes) = mixed_input(&mixed2(2));
        let err = input.curved(&m, &coarse_nodes).unwrap_err();
        assert!(matches!(err, LayoutError::Lost { shape: Shape::Quadrilateral, .. }), "{err}");
        assert!(err.to_string().contains("its curved cell 1 is a Triangle"), "{err}");
    }

    /// A sub-element's straight places are its lattice points mapped by
    /// its corners: on the reference corners, the lattice over p; every
    /// corner lands exactly on itself.
    #[test]
    fn straight_places_are_the_lattice_mapped_by_the_corners() {
        for shape in [Shape::Line, Shape::Triangle, Shape::Quadrilateral] {
            for p in 1..=4 {
                let corners = corner_indices(shape, p);
                // the corners in corner_indices' order: a quad's in tensor order
                let at: Vec<[f64; 3]> = match shape {
                    Shape::Quadrilateral => vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]],
                    _ => shape.vertices().to_vec(),
                };
                let lattice: Vec<[usize; 3]> = match shape {
                    Shape::Triangle => simplex::lattice(shape, p),
                    _ => (0..shape.num_nodes(p)).map(|k| [k % (p + 1), k / (p + 1), 0]).collect(),
                };
                for (k, m) in lattice.iter().enumerate() {
                    let x = straight_place(shape, p, k, &at);
                    let want: [f64; 3] = std::array::from_fn(|d| m[d] as f64 / p as f64);
                    assert!((0..3).all(|d| (x[d] - want[d]).abs() < 1e-15), "{shape:?} p = {p}, node {k}: {x:?}, want {want:?}");
                }
                let skew: Vec<[f64; 3]> = at.iter().map(|x| [x[0] + 0.3 * x[1] + 1.7, 2.0 * x[1] - 0.1, x[0] * x[1] + 5.0]).collect();
                for (c, &k) in corners.iter().enumerate() {
                    assert_eq!(straight_place(shape, p, k, &skew), skew[c], "{shape:?} p = {p}, corner {c}");
                }
            }
        }
    }

    #[test]
    fn sub_elements_of_a_hex_are_its_12_edges_and_6_faces() {
        let edges: Vec<Vec<usize>> = sub_elements(Shape::Hexahedron, 2, 1).into_iter().map(|s| s.1).collect();
        let faces: Vec<Vec<usize>> = sub_elements(Shape::Hexahedron, 2, 2).into_iter().map(|s| s.1).collect();
        assert_eq!((edges.len(), faces.len()), (12, 6));
        // the edge along x at y = z = 0 of a p = 2 hex: nodes 0, 1, 2
        assert!(edges.contains(&vec![0, 1, 2]));
        // the edge along z at x = p, y = p: 8, 17, 26
        assert!(edges.contains(&vec![8, 17, 26]));
        // the face z = p: nodes 18..27
        assert!(faces.contains(&(18..27).collect::<Vec<_>>()));
        assert_eq!(corner_indices(Shape::Quadrilateral, 3), vec![0, 3, 12, 15]);
    }

    /// A prism's 9 edges and 5 faces hold the lattice nodes the reference
    /// coordinates put on them, in the order asked (each from its loop's
    /// first corner), and every node on the boundary is on some face.
    #[test]
    fn sub_elements_of_a_prism_are_its_9_edges_and_5_faces() {
        for p in 1..=4 {
            let x = prism::prism_nodes(p, crate::mesh::element::Spacing::Equispaced).unwrap();
            let edges = sub_elements(Shape::Prism, p, 1);
            let faces = sub_elements(Shape::Prism, p, 2);
            assert_eq!((edges.len(), faces.len()), (9, 5));
            let corners = corner_indices(Shape::Prism, p);
            for (k, &c) in corners.iter().enumerate() {
                assert_eq!(x[c], Shape::Prism.vertices()[k]);
            }
            for ((_, e), [a, b]) in edges.iter().zip(Shape::Prism.edges()) {
                let (va, vb) = (Shape::Prism.vertices()[*a], Shape::Prism.vertices()[*b]);
                for (s, &n) in e.iter().enumerate() {
                    let want: [f64; 3] = std::array::from_fn(|d| va[d] + (vb[d] - va[d]) * s as f64 / p as f64);
                    assert!((0..3).all(|d| (x[n][d] - want[d]).abs() < 1e-15), "p = {p}: edge {a}-{b} node {s}");
                }
            }
            let mut on_face = vec![false; x.len()];
            for ((kind, f), (want_kind, l)) in faces.iter().zip(Shape::Prism.faces()) {
                assert_eq!(kind, want_kind);
                assert_eq!(f.len(), kind.num_nodes(p));
                assert_eq!((f[0], f[p]), (corners[l[0]], corners[l[1]]), "p = {p}: face {l:?} starts at its first corner towards its second");
                // every node of the face lies in the face's plane
                let v = |k: usize| Shape::Prism.vertices()[l[k]];
                let normal = crate::numeric::cross3(std::array::from_fn(|d| v(1)[d] - v(0)[d]), std::array::from_fn(|d| v(2)[d] - v(0)[d]));
                for &n in f {
                    assert!(crate::numeric::dot(normal, std::array::from_fn(|d| x[n][d] - v(0)[d])).abs() < 1e-15);
                    on_face[n] = true;
                }
            }
            let inside = x.iter().filter(|y| y[0] > 1e-12 && y[1] > 1e-12 && y[0] + y[1] < 1.0 - 1e-12 && y[2] > 1e-12 && y[2] < 1.0 - 1e-12).count();
            assert_eq!(on_face.iter().filter(|&&b| b).count(), x.len() - inside, "p = {p}");
        }
    }

    #[test]
    fn a_face_is_found_in_the_orientation_asked_for() {
        let mesh = CurvedMesh::<3>::structured(2, crate::mesh::element::Spacing::Equispaced, [1, 1, 1], |x| x).unwrap();
        let cell = &mesh.cells[0];
        // the face x = 0 asked from corner (0,0,0) towards (0,0,1), then (0,1,0)
        let (a, b, c, d) = (cell[0], cell[18], cell[6], cell[24]);
        let sorted = |mut k: Vec<usize>| {
            k.sort_unstable();
            k
        };
        let lookup = SubElements::new(&mesh, &[sorted(vec![a, b, c, d]), sorted(vec![a, cell[26]])].into_iter().collect());
        let face = lookup.find(&[a, b, c, d]).expect("a face of the cell");
        assert_eq!((face[0], face[2], face[6], face[8]), (a, b, c, d));
        // its middle node is the face's centre
        assert_eq!(face[4], cell[12]);
        assert!(lookup.find(&[a, cell[26]]).is_none(), "a diagonal is no edge");
    }
}
