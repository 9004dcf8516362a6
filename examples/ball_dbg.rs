use deformesh::deform::{BoundaryPart, BoundaryShape, Correspondence, DeformOptions, Deformation3, MoveMode, PartKind};
use deformesh::jacobian::JacobianField;
use deformesh::mesh::HexMesh;
use std::sync::Arc;
#[derive(Debug)]
struct Sphere(f64);
impl BoundaryShape<3> for Sphere {
    fn closest_point(&self, p: [f64; 3]) -> [f64; 3] { let l = (p[0]*p[0]+p[1]*p[1]+p[2]*p[2]).sqrt(); p.map(|c| c * self.0 / l) }
    fn distance(&self, p: [f64; 3]) -> f64 { ((p[0]*p[0]+p[1]*p[1]+p[2]*p[2]).sqrt() - self.0).abs() }
    fn normal(&self, p: [f64; 3]) -> [f64; 3] { let l = (p[0]*p[0]+p[1]*p[1]+p[2]*p[2]).sqrt(); p.map(|c| c / l) }
    fn ray_hit(&self, o: [f64; 3], d: [f64; 3]) -> Option<[f64; 3]> { assert!(o == [0.0;3]); let l = (d[0]*d[0]+d[1]*d[1]+d[2]*d[2]).sqrt(); Some(d.map(|c| c * self.0 / l)) }
}
fn main() {
    let n: usize = std::env::args().nth(1).map_or(12, |s| s.parse().unwrap());
    let mut mesh = HexMesh::structured_box([0.0; 3], [1.0; 3], [n, n, n]);
    // parts: 0 = planes (xmin, ymin, zmin), 1 = sphere (xmax, ymax, zmax)
    for f in &mut mesh.faces { f.part = if f.part % 2 == 0 { 0 } else { 1 }; }
    mesh.part_names = vec!["planes".into(), "sphere".into()];
    let sphere: Arc<dyn BoundaryShape<3>> = Arc::new(Sphere(1.25));
    let parts = vec![
        BoundaryPart { name: "planes".into(), kind: PartKind::Slip { wall: None } },
        BoundaryPart { name: "sphere".into(), kind: PartKind::Move { target: sphere, correspondence: Correspondence::Radial { centre: [0.0; 3] }, mode: MoveMode::Sliding } },
    ];
    let t0 = std::time::Instant::now();
    let mut d = Deformation3::new(mesh, parts, JacobianField::uniform(), DeformOptions { steps: 20, ..Default::default() }).unwrap();
    d.run(&[], |_| {}, |d| eprint!("\rt={:.3} halved {}", d.t, d.stats.halved)).unwrap();
    eprintln!();
    let jf = d.jf_now().unwrap();
    let (mut lo, mut hi, mut blo, mut bhi) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (c, cell) in d.mesh.cells.iter().enumerate() {
        let centre: Vec<f64> = (0..3).map(|k| cell.iter().map(|&v| d.start[v][k]).sum::<f64>() / 8.0).collect();
        let above = centre.iter().filter(|&&x| x > 0.75).count();
        lo = lo.min(jf[c]); hi = hi.max(jf[c]);
        if above <= 1 { blo = blo.min(jf[c]); bhi = bhi.max(jf[c]); }
    }
    let dist = d.boundary_distances().iter().map(|x| x.1).fold(0.0, f64::max);
    let slip_ok = d.mesh.nodes.iter().zip(&d.start).all(|(p, s)| (0..3).all(|k| s[k] != 0.0 || p[k] == 0.0));
    println!("n={n} J/f all [{lo:.3}, {hi:.3}], outside band [{blo:.3}, {bhi:.3}], dist {dist:.2e}, slip exact {slip_ok}, invalid {}, steps {} halved {}, {:.2}s", deformesh::hexquality::invalid_hex_cells(&d.mesh, &d.mesh.nodes).len(), d.stats.steps, d.stats.halved, t0.elapsed().as_secs_f64());
}
