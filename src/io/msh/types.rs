//! Gmsh's element types as a table: (shape, order) → MSH type code, and
//! the permutation from the crate's node order to Gmsh's local one. Every
//! reader and writer of the MSH formats asks this table and nothing else.

use crate::mesh::element::{gmsh_hex_order, gmsh_line_order, gmsh_quad_order, prism, pyramid, simplex, Shape};

/// MSH element types per shape, orders 1..=4 (index `p − 1`): Gmsh's
/// complete Lagrange elements (`MSH_PRI_18`, not the 15-node serendipity
/// prism 18; `MSH_PYR_14`, not the 13-node pyramid 19).
pub const MSH_TYPES: [(Shape, [i64; 4]); 7] = [
    (Shape::Line, [1, 8, 26, 27]),
    (Shape::Triangle, [2, 9, 21, 23]),
    (Shape::Quadrilateral, [3, 10, 36, 37]),
    (Shape::Tetrahedron, [4, 11, 29, 30]),
    (Shape::Hexahedron, [5, 12, 92, 93]),
    (Shape::Prism, [6, 13, 90, 91]),
    (Shape::Pyramid, [7, 14, 118, 119]),
];

/// The MSH type of a point.
pub const MSH_POINT: i64 = 15;

/// The MSH element type of `shape` at order `p` (1..=4; a point is 15),
/// `None` for a shape the table has no row for.
pub fn msh_type(shape: Shape, p: usize) -> Option<i64> {
    if shape == Shape::Point {
        return Some(MSH_POINT);
    }
    MSH_TYPES.iter().find(|r| r.0 == shape).and_then(|r| r.1.get(p.wrapping_sub(1)).copied())
}

/// The shape and order of MSH element type `t`, if the table has it.
pub fn shape_of(t: i64) -> Option<(Shape, usize)> {
    if t == MSH_POINT {
        return Some((Shape::Point, 1));
    }
    MSH_TYPES.iter().find_map(|(shape, types)| types.iter().position(|&x| x == t).map(|i| (*shape, i + 1)))
}

/// Gmsh's local order of a `shape` element of order `p`, as a
/// permutation from the crate's order (tensor order, the simplex lattice
/// order, or the prism's of [`prism`] and the pyramid's of [`pyramid`]):
/// `perm[ours] = Gmsh's local number`.
///
/// # Panics
/// For a shape or order outside the table (the readers and writers only
/// hold elements of [`shape_of`]).
pub fn gmsh_perm(shape: Shape, p: usize) -> Vec<usize> {
    let ok = "orders 1..=4 of the type table";
    match shape {
        Shape::Point => vec![0],
        Shape::Line => gmsh_line_order(p).expect(ok),
        Shape::Quadrilateral => gmsh_quad_order(p).expect(ok),
        Shape::Hexahedron => gmsh_hex_order(p).expect(ok),
        Shape::Triangle => simplex::gmsh_triangle_order(p).expect(ok),
        Shape::Tetrahedron => simplex::gmsh_tet_order(p).expect(ok),
        Shape::Prism => prism::gmsh_prism_order(p).expect(ok),
        Shape::Pyramid => pyramid::gmsh_pyramid_order(p).expect(ok),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_row_goes_both_ways() {
        for (shape, types) in MSH_TYPES {
            for (i, &t) in types.iter().enumerate() {
                assert_eq!(shape_of(t), Some((shape, i + 1)));
                assert_eq!(msh_type(shape, i + 1), Some(t));
                // a permutation of the element's nodes
                let mut perm = gmsh_perm(shape, i + 1);
                assert_eq!(perm.len(), shape.num_nodes(i + 1));
                perm.sort_unstable();
                assert!(perm.iter().enumerate().all(|(k, &v)| k == v));
            }
        }
        assert_eq!(shape_of(15), Some((Shape::Point, 1)));
        assert_eq!(shape_of(19), None, "nor has the 13-node pyramid");
        assert_eq!(shape_of(18), None, "nor has the serendipity prism");
        assert_eq!(msh_type(Shape::Pyramid, 3), Some(118));
        assert_eq!(msh_type(Shape::Triangle, 5), None);
    }
}
