//! Algorithm 1 on meshes of several kinds of cells: quadrilaterals with
//! triangles in the plane; prisms, pyramids, hexes and tetrahedra, alone
//! or mixed, in space. The div–curl system is the simplices' cut from the
//! cells ([`MixedPlaneMesh::triangles`], [`MixedSolidMesh::tetrahedra`]:
//! no new unknowns but a node at each hex's centre), the boundary model
//! that of their boundary edges or triangles, and a step is taken only if
//! the cells themselves stay valid (certified as the curved elements are,
//! at order 1): a prism or pyramid can fold while its tetrahedra do not.

use super::{BoundaryPart, Q1Mesh};
use crate::mesh::element::Spacing;
use crate::mesh::{Cells, CurvedMesh, MixedPlaneMesh, MixedSolidMesh, TetMesh, TriMesh};
use crate::quality::certify::Certifiers;
use rayon::prelude::*;
use std::sync::Arc;

/// A linear mesh whose cells are of several kinds, as [`Cut`] needs it.
pub trait Cuttable<const D: usize, const N: usize>: Clone + Send + Sync {
    /// The simplices Algorithm 1 solves on.
    type Simplices: Q1Mesh<D, N>;
    /// The mesh cut into simplices (its nodes first, any new ones after)
    /// and the cell each simplex was cut from.
    fn cut(&self) -> (Self::Simplices, Vec<usize>);
    /// The cells as the order-1 case of the curved mesh (each cell's
    /// nodes in its kind's lattice order).
    fn as_curved(&self) -> CurvedMesh<D>;
    /// Its nodes.
    fn node_positions(&self) -> &[[f64; D]];
    /// The same cells on nodes `nodes` (as many as it has).
    fn with_nodes(&self, nodes: Vec<[f64; D]>) -> Self;
}

impl Cuttable<2, 3> for MixedPlaneMesh {
    type Simplices = TriMesh;
    fn cut(&self) -> (TriMesh, Vec<usize>) {
        self.triangles()
    }
    fn as_curved(&self) -> CurvedMesh<2> {
        CurvedMesh::from_mixed(self)
    }
    fn node_positions(&self) -> &[[f64; 2]] {
        &self.nodes
    }
    fn with_nodes(&self, nodes: Vec<[f64; 2]>) -> Self {
        MixedPlaneMesh { nodes, cells: self.cells.clone(), edges: self.edges.clone(), part_names: self.part_names.clone() }
    }
}

impl Cuttable<3, 4> for MixedSolidMesh {
    type Simplices = TetMesh;
    fn cut(&self) -> (TetMesh, Vec<usize>) {
        self.tetrahedra()
    }
    fn as_curved(&self) -> CurvedMesh<3> {
        CurvedMesh::from_mixed_solid(self)
    }
    fn node_positions(&self) -> &[[f64; 3]] {
        &self.nodes
    }
    fn with_nodes(&self, nodes: Vec<[f64; 3]>) -> Self {
        MixedSolidMesh { nodes, cells: self.cells.clone(), faces: self.faces.clone(), part_names: self.part_names.clone() }
    }
}

/// A linear mesh moved through the simplices cut from its cells.
#[derive(Clone)]
pub struct Cut<M: Cuttable<D, N>, const D: usize, const N: usize> {
    /// The cells and boundary facets (their nodes are the first of
    /// `simplices`'); `mesh`'s nodes are the starting positions.
    mesh: M,
    /// The simplices Algorithm 1 solves on, at the current positions.
    simplices: M::Simplices,
    /// The cell each simplex was cut from.
    owner: Vec<usize>,
    /// The cells' vertices in their kinds' lattice order, in blocks of
    /// one kind, for the certifiers.
    lattice: Cells,
    certifiers: Arc<Certifiers>,
}

/// Prisms, pyramids, hexes and tetrahedra moved through tetrahedra.
pub type CutSolid = Cut<MixedSolidMesh, 3, 4>;
/// Quadrilaterals and triangles moved through triangles.
pub type CutPlane = Cut<MixedPlaneMesh, 2, 3>;

impl<M: Cuttable<D, N>, const D: usize, const N: usize> Cut<M, D, N> {
    /// Cuts `mesh` into simplices.
    pub fn new(mesh: M) -> Self {
        let (simplices, owner) = mesh.cut();
        let curved = mesh.as_curved();
        let certifiers = Certifiers::new(&curved.shapes(), 1, Spacing::Equispaced).expect("order 1 of every kind");
        Cut { mesh, simplices, owner, lattice: curved.cells, certifiers: Arc::new(certifiers) }
    }

    /// The cells at the current positions.
    pub fn mesh(&self) -> M {
        self.mesh_at(self.simplices.nodes())
    }

    /// The cells at positions `nodes` (of the simplices' nodes: the
    /// hexes' centres, after the cells' nodes, are left out).
    pub fn mesh_at(&self, nodes: &[[f64; D]]) -> M {
        self.mesh.with_nodes(nodes[..self.mesh.node_positions().len()].to_vec())
    }

    /// The simplices Algorithm 1 solves on, at the current positions.
    pub fn simplices(&self) -> &M::Simplices {
        &self.simplices
    }

    /// The cell each simplex was cut from.
    pub fn owner(&self) -> &[usize] {
        &self.owner
    }

    /// The cells not certified valid at positions `nodes`, in order.
    pub fn invalid_cells_of_kinds(&self, nodes: &[[f64; D]]) -> Vec<usize> {
        (0..self.lattice.len())
            .into_par_iter()
            .with_min_len(256)
            .filter(|&c| {
                let ctrl: Vec<[f64; D]> = self.lattice[c].iter().map(|&n| nodes[n]).collect();
                !self.certifiers.of(self.lattice.shape(c)).is_valid(&ctrl)
            })
            .collect()
    }

    /// Per cell, the sum of its simplices' `values`.
    pub fn summed(&self, values: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.lattice.len()];
        for (t, v) in values.iter().enumerate() {
            out[self.owner[t]] += v;
        }
        out
    }
}

impl<M: Cuttable<D, N>, const D: usize, const N: usize> Q1Mesh<D, N> for Cut<M, D, N> {
    type Boundary = <M::Simplices as Q1Mesh<D, N>>::Boundary;

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
        let mut bad = vec![false; self.lattice.len()];
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
        let mut cut = CutPlane::new(MixedPlaneMesh::structured_box([0.0; 2], [1.0; 2], 1, 1));
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
        let solid = MixedSolidMesh::structured_box([0.0; 3], [1.0; 3], [1, 1, 1], Shape::Prism).unwrap();
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
            let ctrl: Vec<[f64; 3]> = cut.lattice[c].iter().map(|&n| at[n]).collect();
            let cert = cut.certifiers.of(cut.lattice.shape(c)).certify(&ctrl, &Default::default());
            assert!(cert.min_det_upper < 0.0, "{cert:?}");
        }
        let of_bad: Vec<usize> = (0..cut.owner().len()).filter(|&t| cells_bad.contains(&cut.owner()[t])).collect();
        assert_eq!(cut.invalid_cells(&at), of_bad);
    }
}
