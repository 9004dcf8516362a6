//! Quality figures of quadrilateral meshes: validity, Jacobian
//! determinants, scaled Jacobians and the ratio J/f of achieved to
//! prescribed Jacobian.
//!
//! Definitions (reported with the numbers):
//! - det J is the Jacobian determinant of the bilinear map from the
//!   reference square [0,1]²; it is affine in each reference coordinate,
//!   so its extremes over a cell are at the corners. (Gmsh's reference
//!   square is [−1,1]², so its `minDetJac` is ours divided by 4.)
//! - The scaled Jacobian of a cell is the minimum over its corners of
//!   det J / (|e₁| |e₂|) with e₁, e₂ the two edges at the corner — the
//!   sine of the corner angle (Verdict's definition). 1 for a rectangle.
//! - J/f of a cell is |K_t| / ∫_{K₀} f(φ(ξ), t) dξ: 1 when the cell's
//!   area is what the prescribed Jacobian asks for.

use crate::jacobian::{lift, JacobianField, Normalisation};
use crate::lsfem::{gauss_points, q1_eval};
use crate::hexquality::{det_j_bounds, hex_volume, invalid_hex_cells, scaled_jacobian as hex_scaled_jacobian};
use crate::mesh::{HexMesh, Point2, QuadMesh};
use rayon::prelude::*;
use serde::Serialize;

/// The two edges leaving corner `a` (to the next and the previous corner).
fn corner_edges(p: &[Point2; 4], a: usize) -> (Point2, Point2) {
    let (prev, next) = (p[(a + 3) % 4], p[(a + 1) % 4]);
    ([next[0] - p[a][0], next[1] - p[a][1]], [prev[0] - p[a][0], prev[1] - p[a][1]])
}

/// det J of the bilinear map at the four corners (reference [0,1]²).
pub fn corner_jacobians(p: &[Point2; 4]) -> [f64; 4] {
    std::array::from_fn(|a| {
        let (e1, e2) = corner_edges(p, a);
        e1[0] * e2[1] - e1[1] * e2[0]
    })
}

/// Minimum over the corners of the sine of the corner angle.
pub fn scaled_jacobian(p: &[Point2; 4]) -> f64 {
    let det = corner_jacobians(p);
    (0..4)
        .map(|a| {
            let (e1, e2) = corner_edges(p, a);
            let l = e1[0].hypot(e1[1]) * e2[0].hypot(e2[1]);
            if l > 0.0 { det[a] / l } else { 0.0 }
        })
        .fold(f64::INFINITY, f64::min)
}

/// Cells of `mesh`'s connectivity, at positions `nodes`, whose det J is
/// not certainly positive at some corner (a bilinear cell is valid iff
/// all four are).
pub fn invalid_cells(mesh: &QuadMesh, nodes: &[Point2]) -> Vec<usize> {
    mesh.cells
        .par_iter()
        .enumerate()
        .filter(|(_, c)| !(0..4).all(|a| corner_certainly_positive(&c.map(|n| nodes[n]), a)))
        .map(|(i, _)| i)
        .collect()
}

/// Whether det J at corner `a` is positive beyond the rounding of its
/// computation. Each edge component rounds by at most u (relative), each
/// of the two products and their difference by u: the computed value is
/// within 4u·(|e₁ₓe₂ᵧ| + |e₁ᵧe₂ₓ|) + O(u²) of the exact one, and 5u bounds
/// that. The bound is relative to the products, so it does not depend on
/// where the cell is or on its size.
fn corner_certainly_positive(p: &[Point2; 4], a: usize) -> bool {
    let (e1, e2) = corner_edges(p, a);
    let (x, y) = (e1[0] * e2[1], e1[1] * e2[0]);
    x - y > 5.0 * f64::EPSILON / 2.0 * (x.abs() + y.abs())
}

/// Validity and shape figures of a hex mesh: det J bounds from the
/// Bézier coefficients of each cell (reference [0,1]³; Gmsh's [−1,1]³
/// gives 1/8), Verdict's hex scaled Jacobian, volumes, and the cells that
/// are not certified valid.
pub fn hex_mesh_quality(mesh: &HexMesh) -> MeshQuality {
    let per_cell: Vec<((f64, f64), f64, f64)> = (0..mesh.num_cells())
        .into_par_iter()
        .map(|c| {
            let p = mesh.cell_coords(c);
            (det_j_bounds(&p), hex_scaled_jacobian(&p), hex_volume(&p))
        })
        .collect();
    MeshQuality {
        cells: mesh.num_cells(),
        nodes: mesh.num_nodes(),
        det_j: Range::of(per_cell.iter().flat_map(|c| [c.0 .0, c.0 .1])),
        scaled_jacobian: Range::of(per_cell.iter().map(|c| c.1)),
        invalid_cells: invalid_hex_cells(mesh, &mesh.nodes),
        cell_size: Range::of(per_cell.iter().map(|c| c.2)),
    }
}

/// Extremes over a set of values.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct Range {
    /// Minimum.
    pub min: f64,
    /// Maximum.
    pub max: f64,
}

impl Range {
    /// Min and max of the values (∞, −∞ when empty).
    pub fn of(values: impl IntoIterator<Item = f64>) -> Range {
        values.into_iter().fold(Range { min: f64::INFINITY, max: f64::NEG_INFINITY }, |r, v| Range { min: r.min.min(v), max: r.max.max(v) })
    }
}

/// Validity and shape figures of a quad mesh.
#[derive(Clone, Debug, Serialize)]
pub struct MeshQuality {
    /// Number of cells.
    pub cells: usize,
    /// Number of nodes.
    pub nodes: usize,
    /// det J over all corners, reference square [0,1]².
    pub det_j: Range,
    /// Per-cell minimum scaled Jacobian (corner-angle sine), over cells.
    pub scaled_jacobian: Range,
    /// Cells whose det J is not positive somewhere: 0-based indices (the
    /// `quality` command turns them into the file's element tags).
    pub invalid_cells: Vec<usize>,
    /// Smallest and largest cell size (area in 2D, volume in 3D).
    pub cell_size: Range,
}

/// Computes [`MeshQuality`].
pub fn mesh_quality(mesh: &QuadMesh) -> MeshQuality {
    let per_cell: Vec<([f64; 4], f64, f64)> = (0..mesh.num_cells())
        .into_par_iter()
        .map(|c| {
            let p = mesh.cell_coords(c);
            (corner_jacobians(&p), scaled_jacobian(&p), mesh.cell_area(c))
        })
        .collect();
    MeshQuality {
        cells: mesh.num_cells(),
        nodes: mesh.num_nodes(),
        det_j: Range::of(per_cell.iter().flat_map(|c| c.0)),
        scaled_jacobian: Range::of(per_cell.iter().map(|c| c.1)),
        invalid_cells: invalid_cells(mesh, &mesh.nodes),
        cell_size: Range::of(per_cell.iter().map(|c| c.2)),
    }
}

/// J/f per cell: |K_t| / ∫_{K₀} f(φ(ξ)) dξ, with φ the Q1 map from the
/// starting cell (positions `start`) to the current one (`nodes`), both
/// integrals by tensor Gauss quadrature (exact for |K_t|).
pub fn jf_ratios<const D: usize, const N: usize>(
    cells: &[[usize; N]],
    nodes: &[[f64; D]],
    start: &[[f64; D]],
    field: &JacobianField,
    norm: &Normalisation,
) -> Vec<f64> {
    cells
        .par_iter()
        .map(|cell| {
            let (p0, p) = (cell.map(|n| start[n]), cell.map(|n| nodes[n]));
            let (mut expected, mut size) = (0.0, 0.0);
            for (xi, w) in gauss_points::<D>() {
                let (_, det0, _) = q1_eval(&p0, xi);
                let (x, det, _) = q1_eval(&p, xi);
                expected += w * det0 * norm.f(field, lift(x));
                size += w * det;
            }
            size / expected
        })
        .collect()
}

/// Summary of J/f: extremes and the L2 norm of J/f − 1 weighted by the
/// starting cell areas (relative to |Ω₀|).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct JfStats {
    /// Smallest J/f.
    pub min: f64,
    /// Largest J/f.
    pub max: f64,
    /// sqrt(Σ |K₀| (J/f − 1)² / Σ |K₀|).
    pub l2_error: f64,
    /// Equidistribution: the coefficient of variation (standard deviation
    /// over mean, across cells) of |K_t| / ∫_{K₀} f — each cell's size
    /// measured in the monitor 1/f, relative to its start. 0 is perfect
    /// equidistribution.
    pub equidistribution_cov: f64,
}

/// Computes [`JfStats`] from per-cell ratios and starting areas.
pub fn jf_stats(ratios: &[f64], start_areas: &[f64]) -> JfStats {
    let r = Range::of(ratios.iter().copied());
    let total: f64 = start_areas.iter().sum();
    let l2 = ratios.iter().zip(start_areas).map(|(q, a)| a * (q - 1.0) * (q - 1.0)).sum::<f64>() / total;
    let n = ratios.len().max(1) as f64;
    let mean = ratios.iter().sum::<f64>() / n;
    let var = ratios.iter().map(|q| (q - mean) * (q - mean)).sum::<f64>() / n;
    JfStats { min: r.min, max: r.max, l2_error: l2.sqrt(), equidistribution_cov: var.sqrt() / mean }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_corner_within_rounding_of_zero_is_not_certified() {
        // corner 0 between (1, 1) and (1, 1 + 2⁻⁵²): det J = 2⁻⁵², below
        // the rounding bound of its two products of about 1
        let flat = [[0.0, 0.0], [1.0, 1.0], [0.5, 2.0], [1.0, 1.0 + f64::EPSILON]];
        assert!(corner_jacobians(&flat)[0] > 0.0);
        assert!(!corner_certainly_positive(&flat, 0));
        // a right angle is certain wherever the cell is and whatever its
        // size, and so is a 1 × 1e-6 sliver at 1e6 from the origin
        for (shift, scale) in [(0.0, 1.0), (1e6, 1.0), (0.0, 1e-9), (1e6, 1e-3)] {
            let at = |x: f64, y: f64| [shift + scale * x, shift + scale * y];
            let square = [at(0.0, 0.0), at(1.0, 0.0), at(1.0, 1.0), at(0.0, 1.0)];
            assert!((0..4).all(|a| corner_certainly_positive(&square, a)), "{shift} {scale}");
        }
        let thin = [[1e6, 1e6], [1e6 + 1.0, 1e6], [1e6 + 1.0, 1e6 + 1e-6], [1e6, 1e6 + 1e-6]];
        assert!((0..4).all(|a| corner_certainly_positive(&thin, a)));
    }

    #[test]
    fn rectangle_and_parallelogram_figures() {
        let rect = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]];
        assert_eq!(corner_jacobians(&rect), [2.0; 4]);
        assert!((scaled_jacobian(&rect) - 1.0).abs() < 1e-15);
        // 45° parallelogram: sine of the corner angle is 1/√2
        let par = [[0.0, 0.0], [1.0, 0.0], [2.0, 1.0], [1.0, 1.0]];
        assert!((scaled_jacobian(&par) - 0.5f64.sqrt()).abs() < 1e-15);
        // a dart (non-convex) is invalid at its reflex corner
        let dart = [[0.0, 0.0], [2.0, 0.0], [0.5, 0.5], [0.0, 2.0]];
        assert!(corner_jacobians(&dart)[2] < 0.0);
        let m = QuadMesh { nodes: dart.to_vec(), cells: vec![[0, 1, 2, 3]], edges: vec![], part_names: vec![] };
        assert_eq!(mesh_quality(&m).invalid_cells, vec![0]);
    }

    #[test]
    fn jf_is_one_for_uniform_scaling() {
        let start = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 3, 3);
        let mut m = start.clone();
        m.nodes.iter_mut().for_each(|p| *p = [1.5 * p[0], 1.5 * p[1]]);
        let norm = Normalisation { t: 1.0, c: 2.25, c_dot: 0.0 };
        let r = jf_ratios(&m.cells, &m.nodes, &start.nodes, &JacobianField::uniform(), &norm);
        assert!(r.iter().all(|q| (q - 1.0).abs() < 1e-14));
        let areas: Vec<f64> = (0..9).map(|c| start.cell_area(c)).collect();
        assert!(jf_stats(&r, &areas).l2_error < 1e-14);
        assert!(jf_stats(&r, &areas).equidistribution_cov < 1e-14);
        // ratios 0.5 and 1.5: mean 1, standard deviation 0.5
        let s = jf_stats(&[0.5, 1.5], &[1.0, 1.0]);
        assert!((s.equidistribution_cov - 0.5).abs() < 1e-15 && (s.l2_error - 0.5).abs() < 1e-15);
    }
}

/// The figures of [`MeshQuality`] as lines a person reads.
pub fn format_quality(q: &MeshQuality) -> String {
    format!(
        "cells {}  nodes {}\n\
         det J (reference [0,1]^d): min {:.6e}  max {:.6e}\n\
         scaled Jacobian: min {:.4}  max {:.4}\n\
         cell size: min {:.4e}  max {:.4e}\n\
         invalid cells: {}{}\n",
        q.cells,
        q.nodes,
        q.det_j.min,
        q.det_j.max,
        q.scaled_jacobian.min,
        q.scaled_jacobian.max,
        q.cell_size.min,
        q.cell_size.max,
        q.invalid_cells.len(),
        if q.invalid_cells.is_empty() { String::new() } else { format!(" {:?}", &q.invalid_cells[..q.invalid_cells.len().min(20)]) }
    )
}
