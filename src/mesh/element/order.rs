//! Node orders of Gmsh and VTK Lagrange elements, as permutations from the
//! crate's tensor order (module [`super`] docs) to the format's local node
//! numbers: `perm[tensor index] = local number`.
//!
//! **Gmsh** (MSH element types 1/8/26/27 lines, 3/10/36/37 quads,
//! 5/12/92/93 hexes), reference cell `[-1,1]^d`: corners first, then the
//! interior nodes of each edge in the direction of Gmsh's edge table
//! (first vertex to second), then the interior nodes of each face, ordered
//! like a quad of order `p − 2` whose corners are the face's inner nodes
//! next to the face vertices, in the order of Gmsh's face table; then the
//! interior nodes, ordered recursively like an element of order `p − 2`.
//! Tables from Gmsh's `MQuadrangle.h` / `MHexahedron.h`:
//! quad edges (0,1) (1,2) (2,3) (3,0) — around the loop;
//! hex edges (0,1) (0,3) (0,4) (1,2) (1,5) (2,3) (2,6) (3,7) (4,5) (4,7)
//! (5,6) (6,7) — note (2,3) and (6,7) run *against* the first axis;
//! hex faces (0,3,2,1) (0,1,5,4) (0,4,7,3) (1,2,6,5) (2,3,7,6) (4,5,6,7) —
//! the bottom face (0,3,2,1) starts along the *second* axis.
//! Checked against Gmsh 4.15's own `getElementProperties` node coordinates
//! for every type listed (test `tests/real_programs_highorder.rs`).
//!
//! **VTK** 9 Lagrange cells (`VTK_LAGRANGE_QUADRILATERAL` = 70,
//! `VTK_LAGRANGE_HEXAHEDRON` = 72), reference cell `[0,1]^d`: corners
//! (the linear cell's order), then edges, each by *increasing* parametric
//! coordinate (not around the loop), then faces, then the interior, all
//! face and interior nodes with the lower axis index varying fastest.
//! Hex edges are those of `vtkHigherOrderHexahedron::PointIndexFromIJK`
//! in VTK ≥ 9.0: 0–3 the bottom loop (y=0, x=1, y=1, x=0 sides), 4–7 the
//! top loop, then the vertical edges at (x,y) = (0,0), (1,0), (1,1), (0,1)
//! — VTK 8 had the last two swapped. Faces: x=0, x=1 (nodes y-fastest,
//! then z), y=0, y=1 (x-fastest, then z), z=0, z=1 (x-fastest, then y).

use super::{check_order, HighOrderError};

/// Gmsh's hex edges as pairs of corner numbers (`edges_hexa` in
/// `MHexahedron.h`).
const GMSH_HEX_EDGES: [[usize; 2]; 12] = [
    [0, 1],
    [0, 3],
    [0, 4],
    [1, 2],
    [1, 5],
    [2, 3],
    [2, 6],
    [3, 7],
    [4, 5],
    [4, 7],
    [5, 6],
    [6, 7],
];

/// Gmsh's hex faces as corner loops (`faces_hexa` in `MHexahedron.h`).
const GMSH_HEX_FACES: [[usize; 4]; 6] = [
    [0, 3, 2, 1],
    [0, 1, 5, 4],
    [0, 4, 7, 3],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [4, 5, 6, 7],
];

/// The (unit-cube) corners of the linear hex in Gmsh's and VTK's common
/// order, as 0/1 index triples.
pub const HEX_CORNERS: [[usize; 3]; 8] = [
    [0, 0, 0],
    [1, 0, 0],
    [1, 1, 0],
    [0, 1, 0],
    [0, 0, 1],
    [1, 0, 1],
    [1, 1, 1],
    [0, 1, 1],
];

/// `a + k (b − a) / p` componentwise for index points (exact: `b − a` is a
/// multiple of `p` between corners of the same cell).
fn along<const D: usize>(a: [usize; D], b: [usize; D], k: usize, p: usize) -> [usize; D] {
    std::array::from_fn(|d| {
        let (a, b) = (a[d] as isize, b[d] as isize);
        (a + (b - a) * k as isize / p as isize) as usize
    })
}

/// The index points `(i, j)` of an order-`p` Gmsh quad in Gmsh's node
/// order, `p = 0` meaning the single centre node of a recursion.
fn gmsh_quad_points(p: usize) -> Vec<[usize; 2]> {
    if p == 0 {
        return vec![[0, 0]];
    }
    let c = [[0, 0], [p, 0], [p, p], [0, p]];
    let mut out = c.to_vec();
    for e in 0..4 {
        let (a, b) = (c[e], c[(e + 1) % 4]);
        out.extend((1..p).map(|k| along(a, b, k, p)));
    }
    if p >= 2 {
        out.extend(
            gmsh_quad_points(p - 2)
                .into_iter()
                .map(|[i, j]| [i + 1, j + 1]),
        );
    }
    out
}

/// The index points `(i, j, k)` of an order-`p` Gmsh hex in Gmsh's node
/// order (`p = 0`: the centre node of a recursion).
fn gmsh_hex_points(p: usize) -> Vec<[usize; 3]> {
    if p == 0 {
        return vec![[0, 0, 0]];
    }
    let c: Vec<[usize; 3]> = HEX_CORNERS.iter().map(|v| v.map(|x| x * p)).collect();
    let mut out = c.clone();
    for [a, b] in GMSH_HEX_EDGES {
        out.extend((1..p).map(|k| along(c[a], c[b], k, p)));
    }
    if p >= 2 {
        let face = gmsh_quad_points(p - 2);
        for [a, b, _, d] in GMSH_HEX_FACES {
            // the face's own quad: first axis from vertex a to b, second
            // from a to d, shifted one node inwards on both
            out.extend(face.iter().map(|&[s, t]| {
                let u = along(c[a], c[b], s + 1, p);
                let v = along(c[a], c[d], t + 1, p);
                std::array::from_fn(|x| u[x] + v[x] - c[a][x])
            }));
        }
        out.extend(gmsh_hex_points(p - 2).into_iter().map(|q| q.map(|x| x + 1)));
    }
    out
}

/// `perm[tensor index] = position in list` for a list of index points.
fn permutation<const D: usize>(p: usize, points: &[[usize; D]]) -> Vec<usize> {
    let n = p + 1;
    let mut perm = vec![usize::MAX; n.pow(D as u32)];
    for (local, q) in points.iter().enumerate() {
        let t = q.iter().rev().fold(0, |acc, &x| acc * n + x);
        debug_assert_eq!(perm[t], usize::MAX, "node listed twice");
        perm[t] = local;
    }
    debug_assert!(perm.iter().all(|&l| l != usize::MAX), "node missing");
    perm
}

/// Gmsh's order of an order-`p` line (types 1, 8, 26, 27): the two ends,
/// then the interior from the first end. `perm[i] = local number`.
pub fn gmsh_line_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    Ok((0..=p)
        .map(|i| match i {
            0 => 0,
            i if i == p => 1,
            i => i + 1,
        })
        .collect())
}

/// Gmsh's order of an order-`p` quad (types 3, 10, 36, 37):
/// `perm[i + (p+1) j] = local number` (module docs).
pub fn gmsh_quad_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    Ok(permutation(p, &gmsh_quad_points(p)))
}

/// Gmsh's order of an order-`p` hex (types 5, 12, 92, 93):
/// `perm[i + (p+1) j + (p+1)² k] = local number` (module docs).
pub fn gmsh_hex_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    Ok(permutation(p, &gmsh_hex_points(p)))
}

/// VTK's order of an order-`p` Lagrange quadrilateral (cell type 70):
/// `perm[i + (p+1) j] = local number`. Same formula as
/// `vtkHigherOrderQuadrilateral::PointIndexFromIJK`.
pub fn vtk_quad_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    let n = p + 1;
    let m = p - 1; // interior nodes per edge
    let index = |i: usize, j: usize| -> usize {
        let ib = i == 0 || i == p;
        let jb = j == 0 || j == p;
        match (ib, jb) {
            (true, true) => match (i > 0, j > 0) {
                (false, false) => 0,
                (true, false) => 1,
                (true, true) => 2,
                (false, true) => 3,
            },
            // edges 0 (y=0) and 2 (y=1), along x
            (false, true) => 4 + (i - 1) + if j > 0 { 2 * m } else { 0 },
            // edges 1 (x=1) and 3 (x=0), along y
            (true, false) => 4 + (j - 1) + if i > 0 { m } else { 3 * m },
            (false, false) => 4 + 4 * m + (i - 1) + m * (j - 1),
        }
    };
    Ok((0..n * n).map(|t| index(t % n, t / n)).collect())
}

/// VTK 9's order of an order-`p` Lagrange hexahedron (cell type 72):
/// `perm[i + (p+1) j + (p+1)² k] = local number`. Same formula as
/// `vtkHigherOrderHexahedron::PointIndexFromIJK` (VTK ≥ 9.0 edge numbers).
pub fn vtk_hex_order(p: usize) -> Result<Vec<usize>, HighOrderError> {
    check_order(p)?;
    let n = p + 1;
    let m = p - 1;
    let corner = |i: usize, j: usize| match (i > 0, j > 0) {
        (false, false) => 0,
        (true, false) => 1,
        (true, true) => 2,
        (false, true) => 3,
    };
    let index = |i: usize, j: usize, k: usize| -> usize {
        let (ib, jb, kb) = (i == 0 || i == p, j == 0 || j == p, k == 0 || k == p);
        let top = if k > 0 { 4 * m } else { 0 }; // edges 4-7 follow 0-3
        match (ib, jb, kb) {
            (true, true, true) => corner(i, j) + if k > 0 { 4 } else { 0 },
            (false, true, true) => 8 + (i - 1) + if j > 0 { 2 * m } else { 0 } + top,
            (true, false, true) => 8 + (j - 1) + if i > 0 { m } else { 3 * m } + top,
            (true, true, false) => 8 + 8 * m + (k - 1) + m * corner(i, j),
            (true, false, false) => {
                8 + 12 * m + (j - 1) + m * (k - 1) + if i > 0 { m * m } else { 0 }
            }
            (false, true, false) => {
                8 + 12 * m + 2 * m * m + (i - 1) + m * (k - 1) + if j > 0 { m * m } else { 0 }
            }
            (false, false, true) => {
                8 + 12 * m + 4 * m * m + (i - 1) + m * (j - 1) + if k > 0 { m * m } else { 0 }
            }
            (false, false, false) => 8 + 12 * m + 6 * m * m + (i - 1) + m * ((j - 1) + m * (k - 1)),
        }
    };
    Ok((0..n * n * n)
        .map(|t| index(t % n, t / n % n, t / (n * n)))
        .collect())
}

/// Items in a format's order from items in tensor order:
/// `out[perm[t]] = tensor[t]`.
pub fn to_format<T: Copy>(perm: &[usize], tensor: &[T]) -> Vec<T> {
    assert_eq!(
        perm.len(),
        tensor.len(),
        "permutation and items differ in length"
    );
    let mut out = tensor.to_vec();
    for (t, &l) in perm.iter().enumerate() {
        out[l] = tensor[t];
    }
    out
}

/// Items in tensor order from items in a format's order:
/// `out[t] = format[perm[t]]`.
pub fn from_format<T: Copy>(perm: &[usize], format: &[T]) -> Vec<T> {
    assert_eq!(
        perm.len(),
        format.len(),
        "permutation and items differ in length"
    );
    perm.iter().map(|&l| format[l]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn is_permutation(perm: &[usize]) -> bool {
        let mut seen = vec![false; perm.len()];
        perm.iter()
            .all(|&l| l < seen.len() && !std::mem::replace(&mut seen[l], true))
    }

    #[test]
    fn all_orders_are_permutations_with_corners_first() {
        for p in 1..=4 {
            let n = p + 1;
            for perm in [gmsh_quad_order(p).unwrap(), vtk_quad_order(p).unwrap()] {
                assert!(is_permutation(&perm));
                let corners = [0, p, n * n - 1, n * p];
                assert_eq!(corners.map(|t| perm[t]), [0, 1, 2, 3]);
            }
            for perm in [gmsh_hex_order(p).unwrap(), vtk_hex_order(p).unwrap()] {
                assert!(is_permutation(&perm));
                for (c, [i, j, k]) in HEX_CORNERS.iter().enumerate() {
                    assert_eq!(perm[(i + n * j + n * n * k) * p], c);
                }
            }
            assert!(is_permutation(&gmsh_line_order(p).unwrap()));
        }
        assert!(gmsh_hex_order(5).is_err());
    }

    /// Gmsh's QUA_16 as listed in its manual (nodes 4-11 around the loop,
    /// 12-15 the interior quad) and HEX_27's face and centre nodes.
    #[test]
    fn known_gmsh_tables() {
        // tensor index of Gmsh node k for QUA_16 (4×4 grid, i + 4 j)
        let qua16 = [0, 3, 15, 12, 1, 2, 7, 11, 14, 13, 8, 4, 5, 6, 10, 9];
        assert_eq!(
            to_format(&gmsh_quad_order(3).unwrap(), &(0..16).collect::<Vec<_>>()),
            qua16
        );
        // HEX_27 nodes 8.. (3×3×3 grid, i + 3 j + 9 k): edges then faces then centre
        let hex27_tail = [
            1, 3, 9, 5, 11, 7, 17, 15, 19, 21, 23, 25, 4, 10, 12, 14, 16, 22, 13,
        ];
        let t = to_format(&gmsh_hex_order(2).unwrap(), &(0..27).collect::<Vec<_>>());
        assert_eq!(&t[8..], hex27_tail);
    }

    /// VTK's order for the order-2 hex, as `vtkLagrangeHexahedron`'s
    /// `GetParametricCoords` lists it in VTK 9.7 (×2, as i j k triples).
    #[test]
    fn known_vtk_table() {
        #[rustfmt::skip]
        let vtk27: [[usize; 3]; 27] = [
            [0,0,0],[2,0,0],[2,2,0],[0,2,0],[0,0,2],[2,0,2],[2,2,2],[0,2,2],
            [1,0,0],[2,1,0],[1,2,0],[0,1,0],[1,0,2],[2,1,2],[1,2,2],[0,1,2],
            [0,0,1],[2,0,1],[2,2,1],[0,2,1],
            [0,1,1],[2,1,1],[1,0,1],[1,2,1],[1,1,0],[1,1,2],[1,1,1],
        ];
        let t = to_format(&vtk_hex_order(2).unwrap(), &(0..27).collect::<Vec<_>>());
        let expected: Vec<usize> = vtk27.iter().map(|[i, j, k]| i + 3 * j + 9 * k).collect();
        assert_eq!(t, expected);
        // quad of order 3: edge 2 (y = 1) runs with increasing x
        let q = to_format(&vtk_quad_order(3).unwrap(), &(0..16).collect::<Vec<_>>());
        assert_eq!(q, [0, 3, 15, 12, 1, 2, 7, 11, 13, 14, 4, 8, 5, 6, 9, 10]);
    }

    #[test]
    fn to_and_from_format_are_inverse() {
        let perm = gmsh_hex_order(3).unwrap();
        let items: Vec<usize> = (100..164).collect();
        assert_eq!(from_format(&perm, &to_format(&perm, &items)), items);
    }
}
