//! The surface to draw: faces of kept cells that no other kept cell shares.

pub(crate) use crate::mesh::HEX_FACES;

/// One quad of the drawn surface.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SurfaceFace {
    /// The four nodes, in the order of the owning cell's face.
    pub nodes: [usize; 4],
    /// The kept cell the face belongs to (whose value colours it).
    pub cell: usize,
}

/// The faces of kept cells (`kept[c]`) not shared with another kept cell:
/// the original boundary of the kept cells plus the faces exposed where a
/// neighbour was dropped. Faces come in cell order, so the picture does not
/// depend on the sorting.
pub(crate) fn surface_faces(cells: &[[usize; 8]], kept: &[bool]) -> Vec<SurfaceFace> {
    // Every face of a kept cell, keyed by its sorted nodes, then sorted so
    // that the copies of a face are neighbours.
    let mut all: Vec<([usize; 4], usize, usize)> = cells
        .iter()
        .enumerate()
        .filter(|&(c, _)| kept[c])
        .flat_map(|(c, cell)| (0..6).map(move |f| (key(HEX_FACES[f].map(|i| cell[i])), c, f)))
        .collect();
    all.sort_unstable();
    let mut faces: Vec<(usize, usize)> = all
        .chunk_by(|a, b| a.0 == b.0)
        .filter(|run| run.iter().all(|r| r.1 == run[0].1))
        .flat_map(|run| run.iter().map(|r| (r.1, r.2)))
        .collect();
    faces.sort_unstable();
    faces
        .into_iter()
        .map(|(cell, f)| SurfaceFace {
            nodes: HEX_FACES[f].map(|i| cells[cell][i]),
            cell,
        })
        .collect()
}

/// The same key for a face whichever corner and direction it starts from.
fn key(mut nodes: [usize; 4]) -> [usize; 4] {
    nodes.sort_unstable();
    nodes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::HexMesh;

    fn brick(n: [usize; 3]) -> HexMesh {
        HexMesh::structured_box([0.0; 3], [n[0] as f64, n[1] as f64, n[2] as f64], n)
    }

    #[test]
    fn boundary_of_a_brick_matches_the_generated_faces() {
        let m = brick([3, 2, 2]);
        let faces = surface_faces(&m.cells, &[true; 12]);
        assert_eq!(faces.len(), m.faces.len());
        let mut got: Vec<_> = faces.iter().map(|f| key(f.nodes)).collect();
        let mut want: Vec<_> = m.faces.iter().map(|f| key(f.nodes)).collect();
        got.sort_unstable();
        want.sort_unstable();
        assert_eq!(got, want);
    }

    #[test]
    fn faces_keep_the_outward_orientation_of_the_mesh() {
        // The generated boundary faces are counter-clockwise from outside;
        // ours must be too (same cyclic order, not reversed).
        let m = brick([2, 2, 1]);
        let faces = surface_faces(&m.cells, &[true; 4]);
        for f in &m.faces {
            let ours = faces.iter().find(|g| key(g.nodes) == key(f.nodes)).unwrap();
            let start = ours.nodes.iter().position(|&n| n == f.nodes[0]).unwrap();
            let rotated: [usize; 4] = std::array::from_fn(|i| ours.nodes[(start + i) % 4]);
            assert_eq!(rotated, f.nodes);
        }
    }

    #[test]
    fn dropping_a_cell_exposes_the_face_it_shared() {
        let m = brick([2, 1, 1]);
        assert_eq!(surface_faces(&m.cells, &[true, true]).len(), 10);
        let faces = surface_faces(&m.cells, &[true, false]);
        assert_eq!(faces.len(), 6, "cell 0 alone shows all six faces");
        assert!(faces.iter().all(|f| f.cell == 0));
        let inner = faces
            .iter()
            .filter(|f| f.nodes.iter().all(|&n| m.nodes[n][0] == 1.0))
            .count();
        assert_eq!(inner, 1, "the face at x = 1 is exposed");
        assert!(surface_faces(&m.cells, &[false, false]).is_empty());
    }
}
