//! Algorithm 1 on solids of every kind: prisms, pyramids, hexes and
//! tetrahedra, alone or mixed. The div–curl system is the tetrahedra's
//! ([`MixedSolidMesh::tetrahedra`]: no new unknowns but a node at each
//! hex's centre), the boundary model the patches of their boundary
//! triangles, and a step is taken only if the cells themselves stay valid
//! (certified as the curved elements are, at order 1): a prism or pyramid
//! can fold while its tetrahedra do not.

use super::{BoundaryPart, DeformError, Patches, Q1Mesh};
use crate::mesh::element::{Shape, Spacing};
use crate::mesh::{CurvedMesh, MixedSolidMesh, Point3, SolidCell, TetMesh};
use crate::quality::certify::Certifiers;
use rayon::prelude::*;
use std::sync::Arc;

/// A linear solid moved through the tetrahedra cut from its cells.
#[derive(Clone)]
pub struct CutSolid {
    /// The cells and boundary faces (their nodes are the first of
    /// `tets`'); `solid.nodes` are the starting positions.
    solid: MixedSolidMesh,
    /// The tetrahedra Algorithm 1 solves on, at the current positions.
    tets: TetMesh,
    /// The cell each tetrahedron was cut from.
    owner: Vec<usize>,
    /// Each cell's vertices in its kind's lattice order, for the
    /// certifiers.
    lattice: Vec<Vec<usize>>,
    certifiers: Arc<Certifiers>,
}

impl CutSolid {
    /// Cuts `solid` into tetrahedra.
    pub fn new(solid: MixedSolidMesh) -> CutSolid {
        let (tets, owner) = solid.tetrahedra();
        let lattice = CurvedMesh::from_mixed_solid(&solid).cells;
        let certifiers = Certifiers::new(&solid.shapes(), 1, Spacing::Equispaced).expect("order 1 of every solid kind");
        CutSolid { solid, tets, owner, lattice, certifiers: Arc::new(certifiers) }
    }

    /// The cells at the current positions.
    pub fn solid(&self) -> MixedSolidMesh {
        self.solid_at(&self.tets.nodes)
    }

    /// The cells at positions `nodes` (of the tetrahedra's nodes: the
    /// hexes' centres, after the cells' nodes, are left out).
    pub fn solid_at(&self, nodes: &[Point3]) -> MixedSolidMesh {
        MixedSolidMesh { nodes: nodes[..self.solid.nodes.len()].to_vec(), cells: self.solid.cells.clone(), faces: self.solid.faces.clone(), part_names: self.solid.part_names.clone() }
    }

    /// The tetrahedra Algorithm 1 solves on, at the current positions.
    pub fn tets(&self) -> &TetMesh {
        &self.tets
    }

    /// The cells.
    pub fn cells_of_kinds(&self) -> &[SolidCell] {
        &self.solid.cells
    }

    /// The cell each tetrahedron was cut from.
    pub fn owner(&self) -> &[usize] {
        &self.owner
    }

    /// The cells not certified valid at positions `nodes`, in order.
    pub fn invalid_solid_cells(&self, nodes: &[Point3]) -> Vec<usize> {
        (0..self.lattice.len())
            .into_par_iter()
            .with_min_len(256)
            .filter(|&c| {
                let ctrl: Vec<Point3> = self.lattice[c].iter().map(|&n| nodes[n]).collect();
                !self.certifiers.of(self.shape(c)).is_valid(&ctrl)
            })
            .collect()
    }

    /// Cell `c`'s kind.
    pub fn shape(&self, c: usize) -> Shape {
        self.solid.cells[c].shape()
    }

    /// Per cell, the sum of its tetrahedra's `values`.
    pub fn summed(&self, values: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.solid.cells.len()];
        for (t, v) in values.iter().enumerate() {
            out[self.owner[t]] += v;
        }
        out
    }
}

impl Q1Mesh<3, 4> for CutSolid {
    type Boundary = Patches;

    fn cells(&self) -> &[[usize; 4]] {
        &self.tets.cells
    }

    fn nodes(&self) -> &[Point3] {
        &self.tets.nodes
    }

    fn nodes_mut(&mut self) -> &mut Vec<Point3> {
        &mut self.tets.nodes
    }

    fn flux_points<'a>(&'a self, nodes: &'a [Point3], v: &'a [Point3]) -> impl Iterator<Item = (Point3, f64)> + 'a {
        self.tets.flux_points(nodes, v)
    }

    /// The tetrahedra that are invalid or cut from a cell that is.
    fn invalid_cells(&self, nodes: &[Point3]) -> Vec<usize> {
        let mut bad = vec![false; self.solid.cells.len()];
        self.invalid_solid_cells(nodes).into_iter().for_each(|c| bad[c] = true);
        let tets = self.tets.invalid_cells(nodes);
        let mut out: Vec<usize> = (0..self.owner.len()).filter(|&t| bad[self.owner[t]]).chain(tets).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    fn measure(&self) -> f64 {
        self.tets.measure()
    }

    fn boundary(&self, parts: Vec<BoundaryPart<3>>) -> Result<Patches, DeformError> {
        self.tets.boundary(parts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
            let at: Vec<Point3> = cut.nodes().iter().map(|x| x.map(|v| v + 0.9 * rand())).collect();
            if !cut.invalid_solid_cells(&at).is_empty() && cut.tets.invalid_cells(&at).is_empty() {
                found = Some(at);
                break;
            }
        }
        let at = found.expect("a twist that folds the prism before its tetrahedra");
        let cells_bad = cut.invalid_solid_cells(&at);
        assert!(!cells_bad.is_empty());
        // folded, not undecided: det J takes a negative value there
        for &c in &cells_bad {
            let ctrl: Vec<Point3> = cut.lattice[c].iter().map(|&n| at[n]).collect();
            let cert = cut.certifiers.of(cut.shape(c)).certify(&ctrl, &Default::default());
            assert!(cert.min_det_upper < 0.0, "{cert:?}");
        }
        let of_bad: Vec<usize> = (0..cut.owner().len()).filter(|&t| cells_bad.contains(&cut.owner()[t])).collect();
        assert_eq!(cut.invalid_cells(&at), of_bad);
    }
}
