//! The application layer: what a user of the tool touches. Case files
//! ([`case`]), geometry files that bind a Gmsh mesh's groups to shapes
//! ([`bind`]), the two jobs `run` and `curve` with their reports and output
//! folders ([`driver`]), and the step benchmark ([`bench`](mod@bench)).
//!
//! Everything here sits above the method (`deform`, `refine`,
//! `highorder`) and the core; nothing below imports it.

pub mod bench;
pub mod bind;
pub mod cad;
pub mod case;
pub mod cli;
pub mod driver;
pub mod memory;
