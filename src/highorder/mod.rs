//! High-order Lagrange quadrilaterals and hexahedra (Algorithm 3):
//! the curving pipeline ([`curve`]), whose elements the core certifies
//! ([`crate::quality::certify`]: Bernstein bounds of det J). The element
//! itself (node sets, bases, Gmsh and VTK node orders, the tensor order
//! of the nodes) is in [`crate::mesh::element`], re-exported here.

pub mod blend;
pub mod curve;
pub mod optimise;
pub mod repair;

/// The element itself (node sets, bases, node orders) is core data of the
/// mesh; these re-exports keep Algorithm 3's paths.
pub use crate::mesh::element::{
    basis, check_order, from_format, gmsh_hex_order, gmsh_line_order, gmsh_quad_order, hex_map,
    lagrange_1d, nodes_1d, order, quad_map, to_format, vtk_hex_order, vtk_quad_order, Basis1d,
    HighOrderError, Spacing, MAX_ORDER,
};
