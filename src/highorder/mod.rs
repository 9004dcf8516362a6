//! High-order Lagrange quadrilaterals and hexahedra (Algorithm 3):
//! certified validity of the curved element by Bernstein (Bézier) bounds
//! of det J ([`bezier`]) and the curving pipeline ([`curve`]). The element
//! itself (node sets, bases, Gmsh and VTK node orders, the tensor order
//! of the nodes) is in [`crate::mesh::element`], re-exported here.

pub mod bezier;
pub mod curve;

/// The element itself (node sets, bases, node orders) is core data of the
/// mesh; these re-exports keep Algorithm 3's paths.
pub use crate::mesh::element::{
    basis, check_order, from_format, gmsh_hex_order, gmsh_line_order, gmsh_quad_order, hex_map,
    lagrange_1d, nodes_1d, order, quad_map, to_format, vtk_hex_order, vtk_quad_order, Basis1d,
    HighOrderError, Spacing, MAX_ORDER,
};
pub(crate) use crate::mesh::element::check_nodes;
pub use bezier::{
    certify_hex, certify_hex_with, certify_quad, certify_quad_with, Bezier, Certificate,
    CertifyOptions,
};
