//! deformesh: curved, boundary-conforming quadrilateral and hexahedral
//! meshes by the deformation method (a least-squares finite-element
//! div-curl solve per pseudo-time step moves the mesh so that its Jacobian
//! determinant follows a prescribed positive function).
//!
//! The usual path is a case file ([`app::case::Case`]) turned into a setup and
//! run by [`app::driver::run_any`]; the pieces are usable on their own:
//! [`deform::Deformation`] is Algorithm 1 on any [`mesh::QuadMesh`] or
//! [`mesh::HexMesh`].
//!
//! ```
//! use deformesh::app::case::{Case, DEMO_CASE};
//! use deformesh::deform::Deformation;
//!
//! // the seed's quarter disk, coarse: the unit square onto a quarter of
//! // the disk of radius 1.25
//! let mut case = Case::parse(DEMO_CASE, "demo").unwrap();
//! case.mesh.cells = vec![8, 8];
//! case.time.steps = 10;
//! let s = case.setup("demo", std::path::Path::new(".")).unwrap();
//! let mut d = Deformation::new(s.mesh, s.parts, s.field, s.options).unwrap();
//! d.run(&[], |_| {}, |_| {}).unwrap();
//! let worst = d.boundary_distances().iter().map(|x| x.1).fold(0.0, f64::max);
//! assert!(worst < 1e-10); // the moving sides lie on the circle
//! ```

pub mod app;
pub mod deform;
pub mod expr;
pub mod geometry;
pub mod highorder;
pub mod io;
pub mod jacobian;
pub mod lsfem;
pub mod mesh;
pub mod numeric;
pub mod quality;
pub mod refine;
pub mod render;
pub mod solve;
