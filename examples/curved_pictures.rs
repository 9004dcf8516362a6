//! Writes pictures of curved high-order meshes to `pictures/` (or the
//! folder given as the first argument): a quarter annulus of order-3 quads,
//! and a block of order-3 hexes with a curved top, whole and cut open.
//!
//! Cells are coloured by det J at their centre over the mean of that over
//! all cells, a J/f-like value around 1.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use deformesh::highorder::{hex_map, quad_map, Spacing};
use deformesh::mesh::CurvedMesh;
use deformesh::render::{
    render_hexes, render_quads, write_png, ClipPlane, RenderOptions, RenderOptions3,
};

/// The quarter annulus `1 ≤ r ≤ 2`, `0 ≤ θ ≤ π/2`: `n[0]` cells around,
/// `n[1]` across, order `p`, graded (the cell map is not a pure polar
/// map, so straight-sided cells could not follow it).
fn quarter_annulus(p: usize, n: [usize; 2]) -> CurvedMesh<2> {
    CurvedMesh::structured(p, Spacing::GaussLobatto, n, |[u, v]| {
        // Cells graded towards θ = 0 and the inner arc, so their sizes
        // (and colours) differ.
        let (r, t) = (1.0 + v * (0.6 + 0.4 * v), 0.5 * PI * u * (0.55 + 0.45 * u));
        [r * t.cos(), r * t.sin()]
    })
    .expect("order 1..=4")
}

/// The box `[0,2]×[0,1]×[0,1]` with its top lifted by a smooth bump (up
/// to 40 %) and its front side bowed out a little.
fn curved_top_block(p: usize, n: [usize; 3]) -> CurvedMesh<3> {
    CurvedMesh::structured(p, Spacing::GaussLobatto, n, |[x, y, z]| {
        let bump = 1.0 + 0.4 * (PI * x).sin() * (PI * y).sin();
        let bow = 0.15 * (1.0 - y) * (PI * x).sin() * (PI * z).sin();
        [2.0 * x, y - bow, z * bump]
    })
    .expect("order 1..=4")
}

/// det J at each cell's reference centre over the mean of that.
fn relative_det<const D: usize>(
    mesh: &CurvedMesh<D>,
    det: impl Fn(&[[f64; D]]) -> f64,
) -> Vec<f64> {
    let d: Vec<f64> = (0..mesh.cells.len())
        .map(|c| det(&mesh.cell_coords(c)))
        .collect();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    d.iter().map(|v| v / mean).collect()
}

fn det2(m: [[f64; 2]; 2]) -> f64 {
    m[0][0] * m[1][1] - m[0][1] * m[1][0]
}

fn det3(m: [[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

fn save(dir: &Path, name: &str, pixmap: &tiny_skia::Pixmap) {
    let path = dir.join(name);
    write_png(&path, pixmap).expect("write");
    println!("{}", path.display());
}

fn main() {
    let dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| "pictures".into());
    std::fs::create_dir_all(&dir).expect("create folder");

    let annulus = quarter_annulus(3, [5, 3]);
    let values = relative_det(&annulus, |ctrl| {
        det2(
            quad_map(3, annulus.spacing, ctrl, [0.5, 0.5])
                .expect("valid cell")
                .1,
        )
    });
    let opts = RenderOptions {
        title: Some("quarter annulus, p = 3, 5×3 cells".into()),
        ..RenderOptions::default()
    };
    save(
        &dir,
        "curved_annulus.png",
        &render_quads(&annulus, &values, &opts).expect("render"),
    );

    let block = curved_top_block(3, [4, 2, 2]);
    let values = relative_det(&block, |ctrl| {
        det3(
            hex_map(3, block.spacing, ctrl, [0.5; 3])
                .expect("valid cell")
                .1,
        )
    });
    let opts = RenderOptions3 {
        title: Some("curved-top block, p = 3, 4×2×2 cells".into()),
        ..RenderOptions3::default()
    };
    save(
        &dir,
        "curved_block.png",
        &render_hexes(&block, &values, &opts).expect("render"),
    );
    let cut = RenderOptions3 {
        clip: Some(ClipPlane {
            point: [0.0, 0.5, 0.0],
            normal: [0.0, -1.0, 0.0],
        }),
        title: Some("cut open at y = 0.5".into()),
        ..opts
    };
    save(
        &dir,
        "curved_block_cut.png",
        &render_hexes(&block, &values, &cut).expect("render"),
    );
}
