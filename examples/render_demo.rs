//! Renders a 20×20 mesh of the unit square bent by a smooth map, coloured
//! by cell values spread over 0.85..1.10, to `render_demo.png`, and a
//! short animation of the bending to `render_demo.gif`.
//!
//! Run with `cargo run --example render_demo [OUT_DIR]`.

use std::path::PathBuf;

use deformesh::mesh::{CurvedMesh, QuadMesh};
use deformesh::render::{render_quads, write_gif, write_png, RenderOptions};

/// Bends the unit square by amount `s` (0 = identity).
fn bend(p: [f64; 2], s: f64) -> [f64; 2] {
    let [x, y] = p;
    let pi = std::f64::consts::PI;
    // The boundary moves too, so the picture shows curved outer edges.
    [
        x + s * 0.10 * (pi * y).sin() * (1.0 - 0.5 * x),
        y + s * (0.12 * (pi * x).sin() * (1.0 - 0.6 * y) + 0.05 * (2.0 * pi * x).sin() * y),
    ]
}

/// Cell area relative to the mean, rescaled linearly onto 0.85..1.10 so the
/// picture spans the range asked for.
fn values(mesh: &QuadMesh) -> Vec<f64> {
    let areas: Vec<f64> = (0..mesh.num_cells()).map(|c| mesh.cell_area(c)).collect();
    let (min, max) = areas
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    areas
        .iter()
        .map(|a| 0.85 + 0.25 * (a - min) / (max - min).max(1e-300))
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    let base = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 20, 20);
    let bent = |s: f64| QuadMesh {
        nodes: base.nodes.iter().map(|&p| bend(p, s)).collect(),
        ..base.clone()
    };

    let mesh = bent(1.0);
    let opts = RenderOptions {
        title: Some("t = 1.00".into()),
        ..RenderOptions::default()
    };
    write_png(
        &out.join("render_demo.png"),
        &render_quads(&CurvedMesh::from_quads(&mesh), &values(&mesh), &opts)?,
    )?;

    // Frames share bounds and range so they line up and colours compare.
    let frame_opts = |t: f64| RenderOptions {
        width: 480,
        bounds: Some(([-0.15, -0.15], [1.15, 1.15])),
        range: Some((0.85, 1.10)),
        title: Some(format!("t = {t:.2}")),
        ..RenderOptions::default()
    };
    let frames = (0..=5)
        .map(|i| {
            let t = i as f64 / 5.0;
            let m = bent(t);
            let v: Vec<f64> = values(&m).iter().map(|v| 1.0 + t * (v - 1.0)).collect();
            render_quads(&CurvedMesh::from_quads(&m), &v, &frame_opts(t))
        })
        .collect::<Result<Vec<_>, _>>()?;
    write_gif(&out.join("render_demo.gif"), &frames, 30)?;
    println!("wrote {}", out.display());
    Ok(())
}
