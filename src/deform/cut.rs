//! Algorithm 1 on meshes of several kinds of cells: quadrilaterals with
//! triangles in the plane; prisms, pyramids, hexes and tetrahedra, alone
//! or mixed, in space — the linear [`CurvedMesh`] (`p = 1`). The div–curl
//! system is the simplices' cut from the cells ([`CurvedMesh::triangles`],
//! [`CurvedMesh::tetrahedra`]: no new unknowns but a node at each hex's
//! centre), the boundary model that of their boundary edges or
//! triangles, and a step is taken only if the cells themselves stay valid
//! (certified as the curved elements are, at order 1): a prism or pyramid
//! can fold while its tetrahedra do not.

use super::{BoundaryPart, Q1Mesh};
use crate::mesh::element::Spacing;
use crate::mesh::{CurvedMesh, TetMesh, TriMesh};
use crate::quality::certify::Certifiers;
use rayon::prelude::*;
use std::sync::Arc;

/// The simplices a linear mesh of dimension `D` is cut into, `N` nodes
/// each: triangles in the plane, tetrahedra in space.
pub trait Cuttable<const D: usize, const N: usize> {
    /// The simplices Algorithm 1 solves on.
    type Simplices: Q1Mesh<D, N>;
    /// The mesh cut into simplices (its nodes first, any new ones after)
    /// and the cell each simplex was cut from.
    fn cut(&self) -> (Self::Simplices, Vec<usize>);
}

impl Cuttable<2, 3> for CurvedMesh<2> {
    type Simplices = TriMesh;
    fn cut(&self) -> (TriMesh, Vec<usize>) {
        self.triangles()
    }
}

impl Cuttable<3, 4> for CurvedMesh<3> {
    type Simplices = TetMesh;
    fn cut(&self) -> (TetMesh, Vec<usize>) {
        self.tetrahedra()
    }
}

/// A linear mesh moved through the simplices cut from its cells.
#[derive(Clone)]
pub struct Cut<const D: usize, const N: usize>
where
    CurvedMesh<D>: Cuttable<D, N>,
{
    /// The cells (each in its kind's lattice order, in blocks of one kind,
    /// as the certifiers take them) and boundary facets; their nodes are
    /// the first of `simplices`', `mesh`'s the starting positions.
    mesh: CurvedMesh<D>,
    /// The simplices Algorithm 1 solves on, at the current positions.
    simplices: <CurvedMesh<D> as Cuttable<D, N>>::Simplices,
    /// The cell each simplex was cut from.
    owner: Vec<usize>,
    certifiers: Arc<Certifiers>,
}

/// Prisms, pyramids, hexes and tetrahedra moved through tetrahedra.
pub type CutSolid = Cut<3, 4>;
/// Quadrilaterals and triangles moved through triangles.
pub type CutPlane = Cut<2, 3>;

impl<const D: usize, const N: usize> Cut<D, N>
where
    CurvedMesh<D>: Cuttable<D, N>,
{
    /// Cuts the linear `mesh` into simplices.
    pub fn new(mesh: CurvedMesh<D>) -> Self {
        debug_assert_eq!(mesh.p, 1, "Algorithm 1 moves linear meshes");
        let (simplices, owner) = mesh.cut();
        let certifiers = Certifiers::new(&mesh.shapes(), 1, Spacing::Equispaced).expect("order 1 of every kind");
        Cut { mesh, simplices, owner, certifiers: Arc::new(certifiers) }
    }

    /// The cells at the current positions.
    pub fn mesh(&self) -> CurvedMesh<D> {
        self.mesh_at(self.simplices.nodes())
    }

    /// The cells at positions `nodes` (of the simplices' nodes: the
    /// hexes' centres, after the cells' nodes, are left out).
    pub fn mesh_at(&self, nodes: &[[f64; D]]) -> CurvedMesh<D> {
        CurvedMesh { nodes: nodes[..self.mesh.nodes.len()].to_vec(), ..self.mesh.clone() }
    }

    /// The simplices Algorithm 1 solves on, at the current positions.
    pub fn simplices(&self) -> &<CurvedMesh<D> as Cuttable<D, N>>::Simplices {
        &self.simplices
    }

    /// The cell each simplex was cut from.
    pub fn owner(&self) -> &[usize] {
        &self.owner
    }

    /// The cells not certified valid at positions `nodes`, in order.
    pub fn invalid_cells_of_kinds(&self, nodes: &[[f64; D]]) -> Vec<usize> {
        let cells = &self.mesh.cells;
        (0..cells.len())
            .into_par_iter()
            .with_min_len(256)
            .filter(|&c| {
                let ctrl: Vec<[f64; D]> = cells[c].iter().map(|&n| nodes[n]).collect();
                !self.certifiers.of(cells.shape(c)).is_valid(&ctrl)
            })
            .collect()
    }

    /// Per cell, the sum of its simplices' `values`.
    pub fn summed(&self, values: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.mesh.cells.len()];
        for (t, v) in values.iter().enumerate() {
            out[self.owner[t]] += v;
        }
        out
    }
}

impl<const D: usize, const N: usize> Q1Mesh<D, N> for Cut<D, N>
where
    CurvedMesh<D>: Cuttable<D, N>,
{
    type Boundary = <<CurvedMesh<D> as Cuttable<D, N>>::Simplices as Q1Mesh<D, N>>::Boundary;

    fn cells(&self) -> &[[usize; N]] {
        self.simplices.cells()
    }

    fn nodes(&self) -> &[[f64; D]] {
        self.simplices.nodes()
    }

    fn nodes_mut(&mut self) -> &mut Vec<[f64; D]> {
        self.simplices.nodes_mut()
    }

    fn flux_points<'a>(&'a self, nodes: &'a [[f64; D]], v: &'a [[f64; D]]) -> impl Iterator<Item = ([f64; D], f64)> + 'a {
        self.simplices.flux_points(nodes, v)
    }

    /// The simplices that are invalid or cut from a cell that is.
    fn invalid_cells(&self, nodes: &[[f64; D]]) -> Vec<usize> {
        let mut bad = vec![false; self.mesh.cells.len()];
        self.invalid_cells_of_kinds(nodes).into_iter().for_each(|c| bad[c] = true);
        let simplices = self.simplices.invalid_cells(nodes);
        let mut out: Vec<usize> = (0..self.owner.len()).filter(|&t| bad[self.owner[t]]).chain(simplices).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    fn measure(&self) -> f64 {
        self.simplices.measure()
    }

    fn boundary(&self, parts: Vec<BoundaryPart<D>>) -> Result<Self::Boundary, super::DeformError> {
        self.simplices.boundary(parts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::element::Shape;

    /// A quad whose corner on the cut's diagonal is pushed in past the
    /// other diagonal folds, while both its triangles stay positive: the
    /// quad is caught and both its triangles named.
    #[test]
    fn a_folded_quad_is_caught_though_its_triangles_are_positive() {
        let mut cut = CutPlane::new(CurvedMesh::checkerboard([0.0; 2], [1.0; 2], 1, 1));
        assert_eq!(cut.simplices().cells, vec![[0, 1, 3], [0, 3, 2]]);
        assert!(cut.invalid_cells(cut.nodes()).is_empty());
        cut.nodes_mut()[0] = [0.7, 0.7];
        let at = cut.nodes().to_vec();
        assert!(cut.simplices.invalid_cells(&at).is_empty());
        assert_eq!(cut.invalid_cells_of_kinds(&at), vec![0]);
        assert_eq!(cut.invalid_cells(&at), vec![0, 1]);
        assert_eq!(cut.mesh().nodes[0], [0.7, 0.7]);
    }

    /// A prism can fold while the three tetrahedra cut from it stay
    /// positive (its det J at a corner is the volume of a tetrahedron that
    /// is not one of them): such a mesh is caught, and every tetrahedron
    /// cut from a folded cell is named.
    #[test]
    fn a_folded_prism_is_caught_though_its_tetrahedra_are_positive() {
        let solid = CurvedMesh::brick([0.0; 3], [1.0; 3], [1, 1, 1], Shape::Prism).unwrap();
        let cut = CutSolid::new(solid);
        assert_eq!(cut.cells().len(), 6);
        assert!(cut.invalid_cells(cut.nodes()).is_empty());
        // random moves of the nodes (a fixed sequence) until one folds a
        // cell but no tetrahedron
        let mut seed = 12345u64;
        let mut rand = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut found = None;
        for _ in 0..20000 {
            let at: Vec<[f64; 3]> = cut.nodes().iter().map(|x| x.map(|v| v + 0.9 * rand())).collect();
            if !cut.invalid_cells_of_kinds(&at).is_empty() && cut.simplices.invalid_cells(&at).is_empty() {
                found = Some(at);
                break;
            }
        }
        let at = found.expect("a twist that folds the prism before its tetrahedra");
        let cells_bad = cut.invalid_cells_of_kinds(&at);
        assert!(!cells_bad.is_empty());
        // folded, not undecided: det J takes a negative value there
        for &c in &cells_bad {
            let ctrl: Vec<[f64; 3]> = cut.mesh.cells[c].iter().map(|&n| at[n]).collect();
            let cert = cut.certifiers.of(cut.mesh.cells.shape(c)).certify(&ctrl, &Default::default());
            assert!(cert.min_det_upper < 0.0, "{cert:?}");
        }
        let of_bad: Vec<usize> = (0..cut.owner().len()).filter(|&t| cells_bad.contains(&cut.owner()[t])).collect();
        assert_eq!(cut.invalid_cells(&at), of_bad);
    }
}
