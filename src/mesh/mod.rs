//! The meshes: linear quad and hex meshes (`linear`), the mesh of any
//! order ([`curved`]) and its Lagrange element ([`element`]), plus the
//! atomic file write ([`file`](mod@file)) that the readers, writers and renderers
//! share. Everything above the core (io, render, the method) reads its
//! mesh types from here, so no layer needs another one's types.

pub mod blocks;
pub mod curved;
pub mod element;
pub mod file;
mod linear;
pub mod mixed;

pub use blocks::{Block, Cells};
pub use curved::{CurvedBoundary, CurvedMesh};
pub use linear::*;
pub use mixed::{cell_faces, corner_jacobians};
