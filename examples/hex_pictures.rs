//! Writes example pictures of hex meshes to `pictures/` (or the folder
//! given as the first argument): a curved 8×8×8 brick, the same cut open
//! by the plane x = 0.5, a perspective view, and a concave L-shaped block.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use deformesh::mesh::{CurvedMesh, HexMesh};
use deformesh::render::{render_hexes, write_png, Camera, ClipPlane, RenderOptions3};

/// The unit brick with its top bulged up (up to 30 %) and sheared a little,
/// like a mesh after a deformation step.
fn curved_brick(n: usize) -> HexMesh {
    let mut m = HexMesh::structured_box([0.0; 3], [1.0; 3], [n; 3]);
    for p in &mut m.nodes {
        let [x, y, z] = *p;
        let bulge = 1.0 + 0.3 * (PI * x).sin() * (PI * y).sin();
        *p = [x + 0.06 * z * (PI * y).sin(), y, z * bulge];
    }
    m
}

/// A smooth value in 0.85..1.1 over the reference cube, by cell centroid.
fn smooth_values(m: &HexMesh) -> Vec<f64> {
    (0..m.num_cells())
        .map(|c| {
            let p = m.cell_coords(c);
            let mean = |k: usize| p.iter().map(|q| q[k]).sum::<f64>() / 8.0;
            let (x, y, z) = (mean(0), mean(1), mean(2));
            let f = 0.5
                + 0.5 * ((PI * x).cos() * (0.9 * PI * z).cos() + 0.3 * (2.0 * PI * y).sin()) / 1.3;
            0.85 + 0.25 * f.clamp(0.0, 1.0)
        })
        .collect()
}

/// An L-shaped block: a 4×4×4 brick with one 2×2×4 quarter taken out,
/// which painter's-algorithm renderers get wrong.
fn l_block() -> HexMesh {
    let full = HexMesh::structured_box([0.0; 3], [2.0, 2.0, 1.0], [4, 4, 4]);
    let keep: Vec<usize> = (0..full.num_cells())
        .filter(|&c| {
            let p = full.cell_coords(c);
            !(p[0][0] >= 1.0 - 1e-9 && p[0][1] >= 1.0 - 1e-9)
        })
        .collect();
    HexMesh {
        cells: keep.iter().map(|&c| full.cells[c]).collect(),
        faces: Vec::new(),
        ..full
    }
}

fn save(dir: &Path, name: &str, mesh: &HexMesh, values: &[f64], opts: &RenderOptions3) {
    let pixmap = render_hexes(&CurvedMesh::from_hexes(mesh), values, opts).expect("render");
    let path = dir.join(name);
    write_png(&path, &pixmap).expect("write");
    println!("{}", path.display());
}

fn main() {
    let dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| "pictures".into());
    std::fs::create_dir_all(&dir).expect("create folder");
    let mesh = curved_brick(8);
    let values = smooth_values(&mesh);
    let base = RenderOptions3 {
        title: Some("curved brick, 8×8×8".into()),
        ..RenderOptions3::default()
    };
    save(&dir, "hex_brick.png", &mesh, &values, &base);
    let clipped = RenderOptions3 {
        clip: Some(ClipPlane {
            point: [0.5, 0.0, 0.0],
            normal: [1.0, 0.0, 0.0],
        }),
        title: Some("cut at x = 0.5".into()),
        ..base.clone()
    };
    save(&dir, "hex_brick_clipped.png", &mesh, &values, &clipped);
    let perspective = RenderOptions3 {
        camera: Camera {
            azimuth_deg: -30.0,
            elevation_deg: 30.0,
            distance: Some(3.0),
        },
        title: Some("perspective".into()),
        ..base.clone()
    };
    save(
        &dir,
        "hex_brick_perspective.png",
        &mesh,
        &values,
        &perspective,
    );
    let fine = curved_brick(40);
    let fine_values = smooth_values(&fine);
    let fine_opts = RenderOptions3 {
        width: 600,
        title: Some("40×40×40".into()),
        ..base.clone()
    };
    save(&dir, "hex_brick_fine.png", &fine, &fine_values, &fine_opts);
    let l = l_block();
    let lv = smooth_values(&l);
    let l_opts = RenderOptions3 {
        camera: Camera {
            azimuth_deg: 215.0,
            elevation_deg: 35.0,
            distance: None,
        },
        title: Some("L-shaped block".into()),
        ..base
    };
    save(&dir, "hex_l_block.png", &l, &lv, &l_opts);
}
