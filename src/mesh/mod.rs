//! The meshes: the mesh of element blocks of any kinds and order
//! ([`curved`], [`blocks`]; p = 1 is the linear mesh, and [`mixed`] what
//! Algorithm 1 asks of it), Algorithm 1's meshes of one kind
//! (`linear`: quads, triangles, hexes, tetrahedra) and the Lagrange
//! elements of every kind ([`element`]), plus the
//! atomic file write ([`file`](mod@file)) that the readers, writers and renderers
//! share. Everything above the core (io, render, the method) reads its
//! mesh types from here, so no layer needs another one's types.

pub mod blocks;
pub mod curved;
pub mod element;
pub mod file;
mod linear;
pub mod mixed;

pub use blocks::{Block, Cells, Facet, Facets};
pub use curved::CurvedMesh;
pub use linear::*;
pub use mixed::{cell_faces, corner_jacobians};
