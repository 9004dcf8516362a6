//! Lagrange elements of order 1..=4 as data: the reference shapes of every
//! kind ([`shape`]), for quadrilaterals and hexahedra the 1-D node sets,
//! tensor-product bases and maps ([`basis`]) and the node orders of Gmsh
//! and VTK ([`order`]), for triangles and tetrahedra their lattices,
//! spaces and node orders ([`simplex`]). The mesh of any order
//! ([`super::curved`]), its readers and writers and Algorithm 3 all use
//! them, so they sit with the mesh, below all of those.
//!
//! Conventions shared by the whole module:
//! - The reference cell is `[0,1]^d` (Gmsh uses `[-1,1]^d`, VTK `[0,1]^d`).
//! - An element of order `p` has `(p+1)^d` nodes. Inside this crate they are
//!   kept in *tensor order*: node `(i, j)` (quad) or `(i, j, k)` (hex), each
//!   index in `0..=p` along the first, second, third reference axis, sits at
//!   position `i + (p+1) j (+ (p+1)² k)`. Its reference coordinates are
//!   `(t_i, t_j, t_k)` with `t = nodes_1d(p, spacing)`. The corners of a
//!   quad in tensor order are therefore `0, p, (p+1)²-1, (p+1)p` for the
//!   `QuadMesh` corners (0,0), (1,0), (1,1), (0,1).
//! - File formats number the nodes differently; [`order`] gives, per format,
//!   the permutation from tensor index to the format's local node number.

pub mod basis;
pub mod order;
pub mod shape;
pub mod prism;
pub mod pyramid;
pub mod simplex;

pub use shape::{Face, Shape};
pub use simplex::{simplex_nodes, space, SimplexSpace};

pub use basis::{hex_map, lagrange_1d, quad_map, Basis1d};
pub use order::{
    from_format, gmsh_hex_order, gmsh_line_order, gmsh_quad_order, to_format, vtk_hex_order,
    vtk_quad_order,
};

use thiserror::Error;

/// The highest element order supported (Gmsh has fixed element types for
/// quads and hexes of order 1 to 4 in its MSH type table we write).
pub const MAX_ORDER: usize = 4;

/// Where the `p + 1` nodes of an order-`p` element lie on each reference
/// edge `[0,1]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Spacing {
    /// `i / p`: the nodes Gmsh and VTK assume for their Lagrange elements.
    #[default]
    Equispaced,
    /// The Gauss–Lobatto–Legendre points (end points plus the roots of
    /// `P_p'`), mapped to `[0,1]`: better conditioned interpolation. Files
    /// cannot store them; writers resample the map at equispaced points.
    GaussLobatto,
}

/// Errors of the high-order element functions.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum HighOrderError {
    /// An element order outside `1..=MAX_ORDER`.
    #[error("element order {0} is not supported (1..={MAX_ORDER})")]
    UnsupportedOrder(usize),
    /// A control-point array whose length is not `(p+1)^d`.
    #[error("an order-{order} element in {dim}D needs {expected} nodes, got {found}")]
    NodeCount {
        /// Element order.
        order: usize,
        /// Dimension of the element.
        dim: usize,
        /// `(p+1)^dim`.
        expected: usize,
        /// Length given.
        found: usize,
    },
}

/// Fails unless `1 <= p <= MAX_ORDER`.
pub fn check_order(p: usize) -> Result<(), HighOrderError> {
    if (1..=MAX_ORDER).contains(&p) {
        Ok(())
    } else {
        Err(HighOrderError::UnsupportedOrder(p))
    }
}

/// Fails unless `p` is supported and `len == (p+1)^dim`.
pub(crate) fn check_nodes(p: usize, dim: usize, len: usize) -> Result<(), HighOrderError> {
    check_order(p)?;
    let expected = (p + 1).pow(dim as u32);
    if len == expected {
        Ok(())
    } else {
        Err(HighOrderError::NodeCount {
            order: p,
            dim,
            expected,
            found: len,
        })
    }
}

/// Local indices of the corners of an element of order `p`: tensor order
/// of the corners for a tensor element, the vertices in the shape's order
/// for a simplex.
pub fn corner_indices(shape: Shape, p: usize) -> Vec<usize> {
    let d = shape.dim();
    if shape == Shape::Prism {
        return prism::vertex_nodes(p).to_vec();
    }
    if shape == Shape::Pyramid {
        return pyramid::vertex_nodes(p).to_vec();
    }
    if shape.is_simplex() && d >= 2 {
        return simplex::vertex_nodes(shape, p);
    }
    (0..1usize << d).map(|bits| (0..d).map(|k| ((bits >> k) & 1) * p * (p + 1).pow(k as u32)).sum()).collect()
}

/// Where each vertex of `shape` sits in its order-1 node list, in the
/// shape's vertex order ([`Shape::vertices`], Gmsh's): a quad's and a
/// hex's tensor order and a pyramid's lattice order list the corners of
/// a square lexicographically, Gmsh cyclically. Each is its own inverse,
/// so it also takes the vertices to the node list.
pub fn linear_order(shape: Shape) -> &'static [usize] {
    match shape {
        Shape::Quadrilateral => &[0, 1, 3, 2],
        Shape::Hexahedron => &[0, 1, 3, 2, 4, 5, 7, 6],
        Shape::Pyramid => &[0, 1, 3, 2, 4],
        // a simplex's and a prism's vertices are their lattice's first
        _ => &[0, 1, 2, 3, 4, 5][..shape.vertices().len()],
    }
}

/// The `p + 1` node positions in `[0,1]`, increasing, for `p` in
/// `1..=MAX_ORDER`. Both sets contain 0 and 1 and are symmetric about ½
/// (`t[p - i] = 1 - t[i]`, exactly), which the writers rely on when they
/// share an edge node between two cells traversing the edge oppositely.
///
/// Gauss–Lobatto points for `p ≤ 4` in closed form on `[-1,1]`: `±1`, and
/// for p = 2: 0; p = 3: `±1/√5`; p = 4: 0, `±√(3/7)`.
pub fn nodes_1d(p: usize, spacing: Spacing) -> Result<Vec<f64>, HighOrderError> {
    check_order(p)?;
    let t = match spacing {
        // i/p, the value Gmsh and VTK compute for their nodes
        Spacing::Equispaced => (0..=p).map(|i| i as f64 / p as f64).collect(),
        Spacing::GaussLobatto => {
            // The interior roots on [-1,1], increasing; the upper half is
            // mirrored from the lower one.
            let s = match p {
                1 => vec![],
                2 => vec![0.0],
                3 => vec![-(0.2f64).sqrt(), (0.2f64).sqrt()],
                _ => vec![-(3.0f64 / 7.0).sqrt(), 0.0, (3.0f64 / 7.0).sqrt()],
            };
            let mut t = vec![0.0; p + 1];
            t[p] = 1.0;
            for (i, &x) in s.iter().enumerate() {
                if 2 * (i + 1) <= p {
                    t[i + 1] = 0.5 * (1.0 + x);
                }
            }
            for i in 1..p {
                if 2 * i > p {
                    t[i] = 1.0 - t[p - i];
                }
            }
            t
        }
    };
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The order-1 vertex order is the one the kinds' own tables give
    /// (Gmsh's quad and hex orders, the simplex, prism and pyramid
    /// lattices) and its own inverse.
    #[test]
    fn linear_order_is_each_kinds_vertex_table() {
        let identity = |n: usize| (0..n).collect::<Vec<_>>();
        let quad = from_format(&gmsh_quad_order(1).unwrap(), &identity(4));
        let hex = from_format(&gmsh_hex_order(1).unwrap(), &identity(8));
        assert_eq!(linear_order(Shape::Quadrilateral), quad);
        assert_eq!(linear_order(Shape::Hexahedron), hex);
        assert_eq!(linear_order(Shape::Pyramid), pyramid::vertex_nodes(1));
        assert_eq!(linear_order(Shape::Prism), prism::vertex_nodes(1));
        for s in [Shape::Triangle, Shape::Tetrahedron] {
            assert_eq!(linear_order(s), simplex::vertex_nodes(s, 1));
        }
        for s in [Shape::Line, Shape::Triangle, Shape::Quadrilateral, Shape::Tetrahedron, Shape::Prism, Shape::Pyramid, Shape::Hexahedron] {
            let o = linear_order(s);
            assert_eq!(o.len(), s.num_nodes(1), "{s:?}");
            assert!((0..o.len()).all(|k| o[o[k]] == k), "{s:?}");
        }
    }

    #[test]
    fn nodes_are_symmetric_and_include_ends() {
        for p in 1..=MAX_ORDER {
            for s in [Spacing::Equispaced, Spacing::GaussLobatto] {
                let t = nodes_1d(p, s).unwrap();
                assert_eq!(t.len(), p + 1);
                assert_eq!((t[0], t[p]), (0.0, 1.0));
                for i in 0..=p {
                    assert!((t[p - i] - (1.0 - t[i])).abs() < 1e-15, "p={p} {s:?}");
                    if i > 0 {
                        assert!(t[i] > t[i - 1]);
                    }
                }
            }
        }
        let g = nodes_1d(4, Spacing::GaussLobatto).unwrap();
        assert!((g[1] - 0.5 * (1.0 - (3.0f64 / 7.0).sqrt())).abs() < 1e-16);
        assert_eq!(g[2], 0.5);
        // the interior GLL points are the roots of P_p'
        let g3 = nodes_1d(3, Spacing::GaussLobatto).unwrap();
        let x = 2.0 * g3[1] - 1.0; // P_3'(x) = (15x² - 3)/2
        assert!((15.0 * x * x - 3.0).abs() < 1e-14);
    }

    #[test]
    fn orders_outside_range_are_errors() {
        assert_eq!(
            nodes_1d(0, Spacing::Equispaced),
            Err(HighOrderError::UnsupportedOrder(0))
        );
        assert_eq!(
            nodes_1d(5, Spacing::GaussLobatto),
            Err(HighOrderError::UnsupportedOrder(5))
        );
        assert!(check_nodes(2, 2, 8).is_err());
        assert!(check_nodes(2, 3, 27).is_ok());
    }
}
