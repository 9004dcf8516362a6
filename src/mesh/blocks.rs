//! The cells of a mesh, and its boundary elements ([`Facets`]), as element
//! blocks: runs of cells of one kind, each
//! block one flat array of node indices (MFEM's and Gmsh's element blocks,
//! VTK's connectivity). A mesh of any mix of kinds is a list of blocks in
//! the file's order, so cell `c` is still the file's element `c`, and a
//! kernel takes a block's cells as fixed-width chunks of one kind — the
//! kind is looked up once per block, not per cell.

use std::ops::{Index, IndexMut};

use super::element::Shape;

/// A run of cells of one kind at one order.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// The cells' kind.
    pub shape: Shape,
    /// Nodes per cell ([`Shape::num_nodes`] at the mesh's order; a count no
    /// kind has is kept as given, for [`super::CurvedMesh::validate`] to
    /// refuse with the cell's number).
    pub width: usize,
    /// `width` node indices per cell, cell after cell.
    pub nodes: Vec<usize>,
}

impl Block {
    /// How many cells the block holds.
    pub fn len(&self) -> usize {
        self.nodes.len() / self.width.max(1)
    }

    /// Whether the block holds no cell.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Its cells' nodes, one slice per cell.
    pub fn cells(&self) -> std::slice::ChunksExact<'_, usize> {
        self.nodes.chunks_exact(self.width.max(1))
    }
}

/// The cells of a mesh: element blocks in order, indexed as one list.
#[derive(Clone, Debug, PartialEq)]
pub struct Cells {
    blocks: Vec<Block>,
    /// The index of each block's first cell, and the total after the last.
    starts: Vec<usize>,
}

impl Cells {
    /// No cells.
    pub fn new() -> Cells {
        Cells { blocks: Vec::new(), starts: vec![0] }
    }

    /// Cells of dimension `dim` at order `p`, each kind told by its node
    /// count ([`Shape::with_nodes`]; a count no kind has gets `fallback`),
    /// consecutive cells of one kind in one block.
    pub fn from_cells<C: AsRef<[usize]>>(dim: usize, p: usize, fallback: Shape, cells: impl IntoIterator<Item = C>) -> Cells {
        cells.into_iter().map(|c| (Shape::with_nodes(dim, p, c.as_ref().len()).unwrap_or(fallback), c)).collect()
    }

    /// Appends a cell of `shape`: to the last block if it is of that kind
    /// and width, else in a new block.
    pub fn push(&mut self, shape: Shape, nodes: &[usize]) {
        match self.blocks.last_mut() {
            Some(b) if b.shape == shape && b.width == nodes.len() => b.nodes.extend_from_slice(nodes),
            _ => {
                self.blocks.push(Block { shape, width: nodes.len(), nodes: nodes.to_vec() });
                let last = *self.starts.last().expect("starts holds the total");
                self.starts.push(last);
            }
        }
        *self.starts.last_mut().expect("starts holds the total") += 1;
    }

    /// The blocks, in order.
    pub fn blocks(&self) -> &[Block] {
        &self.blocks
    }

    /// How many cells there are.
    pub fn len(&self) -> usize {
        *self.starts.last().unwrap_or(&0)
    }

    /// Whether there is no cell.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The block holding cell `c` and `c`'s place in it. A single block
    /// (every mesh of one kind) is found without a search.
    fn locate(&self, c: usize) -> (usize, usize) {
        if self.blocks.len() == 1 {
            return (0, c);
        }
        let b = self.starts.partition_point(|&s| s <= c) - 1;
        (b, c - self.starts[b])
    }

    /// Cell `c`'s nodes, if there is such a cell.
    pub fn get(&self, c: usize) -> Option<&[usize]> {
        (c < self.len()).then(|| &self[c])
    }

    /// The first cell's nodes.
    pub fn first(&self) -> Option<&[usize]> {
        self.get(0)
    }

    /// The kind of cell `c`.
    pub fn shape(&self, c: usize) -> Shape {
        self.blocks[self.locate(c).0].shape
    }

    /// The cells' nodes in order, one slice per cell.
    pub fn iter(&self) -> Iter<'_> {
        // every block's chunks; the sizes are known, so the chain is
        // wrapped to say so
        Exact { inner: self.blocks.iter().flat_map(Block::cells as fn(&Block) -> std::slice::ChunksExact<'_, usize>), left: self.len() }
    }

    /// Each cell's nodes as its own vector, in order (to edit the list
    /// and rebuild it with [`Cells::from_cells`]).
    pub fn to_vecs(&self) -> Vec<Vec<usize>> {
        self.iter().map(<[usize]>::to_vec).collect()
    }
}

/// No cells ([`Cells::new`]: the running total starts at 0).
impl Default for Cells {
    fn default() -> Cells {
        Cells::new()
    }
}

/// No boundary elements.
impl Default for Facets {
    fn default() -> Facets {
        Facets::new()
    }
}

impl Index<usize> for Cells {
    type Output = [usize];
    fn index(&self, c: usize) -> &[usize] {
        let (b, i) = self.locate(c);
        let w = self.blocks[b].width;
        &self.blocks[b].nodes[i * w..(i + 1) * w]
    }
}

impl IndexMut<usize> for Cells {
    fn index_mut(&mut self, c: usize) -> &mut [usize] {
        let (b, i) = self.locate(c);
        let w = self.blocks[b].width;
        &mut self.blocks[b].nodes[i * w..(i + 1) * w]
    }
}

/// Cells each with its kind ([`Cells::push`] one by one), as a reader
/// that knows every element's type gives them.
impl<C: AsRef<[usize]>> FromIterator<(Shape, C)> for Cells {
    fn from_iter<I: IntoIterator<Item = (Shape, C)>>(cells: I) -> Cells {
        let mut out = Cells::new();
        for (shape, c) in cells {
            out.push(shape, c.as_ref());
        }
        out
    }
}

impl<'a> IntoIterator for &'a Cells {
    type Item = &'a [usize];
    type IntoIter = Iter<'a>;
    fn into_iter(self) -> Iter<'a> {
        self.iter()
    }
}

/// The boundary elements of a mesh (dimension `D − 1`): element blocks
/// as the cells are ([`Cells`]), each element with its part.
#[derive(Clone, Debug, PartialEq)]
pub struct Facets {
    elements: Cells,
    parts: Vec<usize>,
}

/// One boundary element of [`Facets`]: its kind, its nodes (in its
/// kind's node order; 2D: the domain on the left) and its part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Facet<'a> {
    /// The element's kind: a line, triangle or quadrilateral.
    pub shape: Shape,
    /// Its nodes.
    pub nodes: &'a [usize],
    /// Index into the mesh's part names.
    pub part: usize,
}

impl Facets {
    /// No boundary elements.
    pub fn new() -> Facets {
        Facets { elements: Cells::new(), parts: Vec::new() }
    }

    /// Boundary elements of dimension `dim` at order `p`, each kind told by
    /// its node count as in [`Cells::from_cells`].
    pub fn from_nodes<C: AsRef<[usize]>>(dim: usize, p: usize, fallback: Shape, facets: impl IntoIterator<Item = (C, usize)>) -> Facets {
        facets.into_iter().map(|(f, part)| (Shape::with_nodes(dim, p, f.as_ref().len()).unwrap_or(fallback), f, part)).collect()
    }

    /// Appends a boundary element of `shape` in `part`.
    pub fn push(&mut self, shape: Shape, nodes: &[usize], part: usize) {
        self.elements.push(shape, nodes);
        self.parts.push(part);
    }

    /// How many boundary elements there are.
    pub fn len(&self) -> usize {
        self.parts.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.parts.is_empty()
    }

    /// Boundary element `b`.
    pub fn get(&self, b: usize) -> Facet<'_> {
        Facet { shape: self.elements.shape(b), nodes: &self.elements[b], part: self.parts[b] }
    }

    /// The nodes of boundary element `b`, to edit in place.
    pub fn nodes_mut(&mut self, b: usize) -> &mut [usize] {
        &mut self.elements[b]
    }

    /// Every element's part, in order.
    pub fn parts(&self) -> &[usize] {
        &self.parts
    }

    /// Every element's part, to change in place.
    pub fn parts_mut(&mut self) -> &mut [usize] {
        &mut self.parts
    }

    /// The elements as blocks of one kind (their parts in [`Facets::parts`],
    /// in the same order).
    pub fn blocks(&self) -> &[Block] {
        self.elements.blocks()
    }

    /// The boundary elements in order.
    pub fn iter(&self) -> FacetIter<'_> {
        let kinded: fn(&Block) -> KindedChunks<'_> = |b| std::iter::repeat(b.shape).zip(b.cells());
        FacetIter { elements: self.elements.blocks().iter().flat_map(kinded), parts: self.parts.iter() }
    }

}

/// Boundary elements each with its kind and part ([`Facets::push`] one by
/// one).
impl<C: AsRef<[usize]>> FromIterator<(Shape, C, usize)> for Facets {
    fn from_iter<I: IntoIterator<Item = (Shape, C, usize)>>(facets: I) -> Facets {
        let mut out = Facets::new();
        for (shape, f, part) in facets {
            out.push(shape, f.as_ref(), part);
        }
        out
    }
}

impl<'a> IntoIterator for &'a Facets {
    type Item = Facet<'a>;
    type IntoIter = FacetIter<'a>;
    fn into_iter(self) -> FacetIter<'a> {
        self.iter()
    }
}

/// The boundary elements in order ([`Facets::iter`]): the blocks' chunks
/// with their kinds, beside the parts.
#[derive(Clone)]
pub struct FacetIter<'a> {
    elements: std::iter::FlatMap<std::slice::Iter<'a, Block>, KindedChunks<'a>, fn(&'a Block) -> KindedChunks<'a>>,
    parts: std::slice::Iter<'a, usize>,
}

/// A block's elements, each with the block's kind.
type KindedChunks<'a> = std::iter::Zip<std::iter::Repeat<Shape>, std::slice::ChunksExact<'a, usize>>;

impl<'a> Iterator for FacetIter<'a> {
    type Item = Facet<'a>;
    fn next(&mut self) -> Option<Facet<'a>> {
        let (shape, nodes) = self.elements.next()?;
        Some(Facet { shape, nodes, part: *self.parts.next()? })
    }
    fn size_hint(&self) -> (usize, Option<usize>) {
        self.parts.size_hint()
    }
}

impl ExactSizeIterator for FacetIter<'_> {}

/// The cells' nodes in order ([`Cells::iter`]): each block's chunks.
pub type Iter<'a> = Exact<std::iter::FlatMap<std::slice::Iter<'a, Block>, std::slice::ChunksExact<'a, usize>, fn(&'a Block) -> std::slice::ChunksExact<'a, usize>>>;

/// An iterator of known length (a chain of the blocks' chunks).
#[derive(Clone)]
pub struct Exact<I> {
    inner: I,
    left: usize,
}

impl<I: Iterator> Iterator for Exact<I> {
    type Item = I::Item;
    fn next(&mut self) -> Option<I::Item> {
        let x = self.inner.next();
        self.left -= x.is_some() as usize;
        x
    }
    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.left, Some(self.left))
    }
}

impl<I: DoubleEndedIterator> DoubleEndedIterator for Exact<I> {
    fn next_back(&mut self) -> Option<I::Item> {
        let x = self.inner.next_back();
        self.left -= x.is_some() as usize;
        x
    }
}

impl<I: Iterator> ExactSizeIterator for Exact<I> {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_of_two_kinds_keep_their_order_in_runs() {
        // quad, quad, triangle, quad at order 1: three blocks
        let cells = Cells::from_cells(2, 1, Shape::Quadrilateral, [vec![0, 1, 2, 3], vec![1, 4, 5, 2], vec![4, 6, 5], vec![6, 7, 8, 5]]);
        assert_eq!(cells.len(), 4);
        assert_eq!(cells.blocks().iter().map(|b| (b.shape, b.len())).collect::<Vec<_>>(), [(Shape::Quadrilateral, 2), (Shape::Triangle, 1), (Shape::Quadrilateral, 1)]);
        assert_eq!(&cells[2], &[4, 6, 5]);
        assert_eq!(&cells[3], &[6, 7, 8, 5]);
        assert_eq!(cells.shape(1), Shape::Quadrilateral);
        assert_eq!(cells.shape(2), Shape::Triangle);
        assert_eq!(cells.iter().len(), 4);
        assert_eq!(cells.iter().rev().next(), Some(&[6, 7, 8, 5][..]));
        assert_eq!(cells.iter().map(<[usize]>::len).collect::<Vec<_>>(), [4, 4, 3, 4]);
    }

    /// A prism's boundary: triangles and quads in runs, each kind told by
    /// its node count at order 2 and kept per block; parts travel with
    /// their elements through iteration and editing, and iteration gives
    /// what indexing does.
    #[test]
    fn facets_of_two_kinds_keep_their_parts_and_order() {
        let (tri, quad) = (Shape::Triangle.num_nodes(2), Shape::Quadrilateral.num_nodes(2));
        let nodes = |first: usize, n: usize| (first..first + n).collect::<Vec<usize>>();
        let list = [(nodes(0, tri), 3), (nodes(10, quad), 0), (nodes(20, quad), 1), (nodes(30, tri), 3)];
        let mut facets = Facets::from_nodes(2, 2, Shape::Quadrilateral, list.iter().map(|(f, part)| (f, *part)));
        assert_eq!(facets.len(), 4);
        assert_eq!(facets.blocks().iter().map(|b| (b.shape, b.len())).collect::<Vec<_>>(), [(Shape::Triangle, 1), (Shape::Quadrilateral, 2), (Shape::Triangle, 1)]);
        let seen: Vec<(Shape, Vec<usize>, usize)> = facets.iter().map(|f| (f.shape, f.nodes.to_vec(), f.part)).collect();
        let kinds = [Shape::Triangle, Shape::Quadrilateral, Shape::Quadrilateral, Shape::Triangle];
        assert_eq!(seen, list.iter().zip(kinds).map(|((f, part), k)| (k, f.clone(), *part)).collect::<Vec<_>>());
        assert_eq!(facets.iter().last().map(|f| f.nodes[0]), Some(30));
        assert_eq!((&facets).into_iter().len(), 4);
        facets.parts_mut()[2] = 7;
        facets.nodes_mut(1)[0] = 99;
        assert_eq!((facets.get(2).part, facets.get(1).nodes[0], facets.parts()), (7, 99, &[3, 0, 7, 3][..]));
        assert!(facets.iter().enumerate().all(|(b, f)| f == facets.get(b)));
        // a facet whose kind and node count disagree is refused
        let mut mesh = crate::mesh::CurvedMesh::brick([0.0; 3], [1.0; 3], [1, 1, 1], Shape::Prism).unwrap();
        assert!(mesh.validate().is_ok());
        mesh.boundary.push(Shape::Quadrilateral, &[0, 1, 2], 0);
        let why = mesh.validate().unwrap_err();
        assert!(why.starts_with(&format!("boundary face {} needs 3 or 4 nodes", mesh.boundary.len() - 1)), "{why}");
        // a count no kind has keeps its width (for `validate` to refuse)
        let odd = Facets::from_nodes(1, 1, Shape::Line, [(vec![0, 1, 2], 0)]);
        assert_eq!((odd.get(0).shape, odd.get(0).nodes.len()), (Shape::Line, 3));
    }

    proptest::proptest! {
        /// Any run of kinds: the blocks index, iterate (both ways) and
        /// tell kinds as the list of vectors they were made from does.
        #[test]
        fn blocks_index_as_the_list_they_were_made_of(kinds in proptest::collection::vec(0usize..4, 0..40), p in 1usize..4) {
            let shapes = [Shape::Tetrahedron, Shape::Prism, Shape::Pyramid, Shape::Hexahedron];
            let mut next = 0;
            let list: Vec<(Shape, Vec<usize>)> = kinds.iter().map(|&k| {
                let n = shapes[k].num_nodes(p);
                next += n;
                (shapes[k], (next - n..next).collect())
            }).collect();
            let cells = Cells::from_cells(3, p, Shape::Hexahedron, list.iter().map(|c| &c.1));
            proptest::prop_assert_eq!(cells.len(), list.len());
            let runs = 1 + kinds.windows(2).filter(|w| w[0] != w[1]).count();
            proptest::prop_assert_eq!(cells.blocks().len(), if kinds.is_empty() { 0 } else { runs });
            for (c, (shape, nodes)) in list.iter().enumerate() {
                proptest::prop_assert_eq!(&cells[c], &nodes[..]);
                proptest::prop_assert_eq!(cells.shape(c), *shape);
            }
            proptest::prop_assert!(cells.iter().eq(list.iter().map(|c| &c.1[..])));
            proptest::prop_assert!(cells.iter().rev().eq(list.iter().rev().map(|c| &c.1[..])));
            proptest::prop_assert_eq!(cells.get(list.len()), None);
        }
    }

    #[test]
    fn a_count_no_kind_has_keeps_its_width() {
        let cells = Cells::from_cells(2, 2, Shape::Quadrilateral, [vec![0; 9], vec![0; 7]]);
        assert_eq!(cells[1].len(), 7);
        assert_eq!(cells.blocks().len(), 2);
        // a cell of no nodes is refused by the mesh's validation
        let mut m = crate::mesh::CurvedMesh::<2>::structured(2, crate::mesh::element::Spacing::Equispaced, [1, 1], |x| x).unwrap();
        m.cells = Cells::from_cells(2, 2, Shape::Quadrilateral, [vec![0; 9], vec![]]);
        assert_eq!(m.validate(), Err("a cell has no nodes".to_string()));
        assert_eq!(m.cells.len(), 2);
    }
}
