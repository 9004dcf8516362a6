//! CAD geometry through Gmsh's library (`--cad`): the shapes of a STEP
//! file answer as the exact shapes do, meshes made from a STEP are
//! curved onto it, and wrong pairings are refused.

use crate::common;

use deformesh::geometry::cad::{CadModel, CadShape};
use deformesh::geometry::ClosestPoint;

/// The cylinder r = 0.5 (0 ≤ z ≤ 1) and the sphere r = 0.3 at (2, 0, 0.5)
/// of tests/python/cad_primitives.py, read back from their STEP file.
fn primitives(dir: &std::path::Path) -> std::sync::Arc<CadModel> {
    let step = dir.join("primitives.step");
    common::run_script("cad_primitives.py", &[&step]);
    CadModel::open(&step, Some(&common::gmsh_lib())).unwrap()
}

fn surface_of_type(model: &std::sync::Arc<CadModel>, ty: &str) -> CadShape {
    let tag = model.entities(2).unwrap().into_iter().find(|&t| model.entity_type(2, t).unwrap() == ty).unwrap_or_else(|| panic!("no {ty}"));
    model.shape(2, tag)
}

#[test]
fn step_surfaces_answer_as_the_exact_shapes() {
    let dir = tempfile::tempdir().unwrap();
    let model = primitives(dir.path());
    let cylinder = surface_of_type(&model, "Cylinder");
    let sphere = surface_of_type(&model, "Sphere");
    let mut worst = [0.0f64; 3];
    for k in 0..40 {
        let a = 0.37 * k as f64;
        let (r, z) = (0.3 + 0.02 * k as f64, 0.1 + 0.02 * k as f64);
        let p = [r * a.cos(), r * a.sin(), z];
        let q = ClosestPoint::<3>::closest_point(&cylinder, p);
        let exact = [0.5 * a.cos(), 0.5 * a.sin(), z];
        worst[0] = worst[0].max(deformesh::numeric::dist2(q, exact).sqrt());
        let n = ClosestPoint::<3>::normal(&cylinder, p);
        worst[1] = worst[1].max(1.0 - (n[0] * a.cos() + n[1] * a.sin()).abs());
        let s = [2.0 + r * a.cos(), 0.0 + r * a.sin() * (0.5 * a).cos(), 0.5 + r * a.sin() * (0.5 * a).sin()];
        let d = ClosestPoint::<3>::distance(&sphere, s);
        worst[2] = worst[2].max((d - (r - 0.3).abs()).abs());
    }
    assert!(model.failure().is_none(), "{:?}", model.failure());
    assert!(worst[0] < 1e-12 && worst[1] < 1e-12 && worst[2] < 1e-12, "closest point, normal, sphere distance: {worst:?}");
}
