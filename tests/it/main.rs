//! The integration tests, one test binary: each linked binary costs CI
//! a link of the whole library at the test profile's opt-level 3, so the
//! files are modules of this one crate rather than binaries of their own.
//! `cargo test --test it cli::` runs one file's tests.

#[allow(dead_code)]
mod common;

mod abaqus;
mod adaptation;
mod band;
mod cad;
mod cli;
mod curve_import;
mod deformation;
mod deformation3d;
mod every_kind;
mod highorder;
mod kept;
mod level_sets;
mod mfem;
mod msh22;
mod prisms;
mod real_programs;
mod real_programs_hex;
mod real_programs_highorder;
mod repair;
mod simplex_orders;
mod simplices;
mod solver_failure;
mod trust;
