//! Tests that render real pictures, decode the encoded bytes and check
//! pixels, so they catch wrong colours, positions, orientation and
//! encodings rather than just "it did not crash"; and the helpers the 3D
//! tests share.

use std::f64::consts::PI;
use std::path::Path;

use image::RgbaImage;

use super::quads::{plan, polygon_area, QuadCurves};
use super::*;
use crate::mesh::QuadMesh;

/// Decodes the PNG encoding of `pixmap`, so the tests see exactly what a
/// file would hold.
pub(crate) fn decoded(pixmap: &Pixmap) -> RgbaImage {
    let png = png_bytes(pixmap).unwrap();
    let img = image::load_from_memory_with_format(&png, image::ImageFormat::Png)
        .unwrap()
        .to_rgba8();
    assert_eq!(
        (img.width(), img.height()),
        (pixmap.width(), pixmap.height())
    );
    img
}

pub(crate) fn pixel(img: &RgbaImage, x: f64, y: f64) -> [u8; 3] {
    let p = img.get_pixel(x as u32, y as u32).0;
    assert_eq!(p[3], 255, "picture should be opaque");
    [p[0], p[1], p[2]]
}

pub(crate) fn assert_close(found: [u8; 3], expected: [u8; 3], what: &str) {
    let ok = (0..3).all(|k| found[k].abs_diff(expected[k]) <= 1);
    assert!(ok, "{what}: found {found:?}, expected {expected:?}");
}

pub(crate) const WHITE: [u8; 3] = [255, 255, 255];

pub(crate) fn brightness(c: [u8; 3]) -> u32 {
    c.iter().map(|&x| x as u32).sum()
}

/// The darkest pixel within one pixel of (x, y): a thin line through a
/// point may cover its own pixel only partly.
pub(crate) fn darkest_near(img: &RgbaImage, x: f64, y: f64) -> [u8; 3] {
    let mut best = WHITE;
    for dy in [-1.0, 0.0, 1.0] {
        for dx in [-1.0, 0.0, 1.0] {
            let c = pixel(img, x + dx, y + dy);
            if brightness(c) < brightness(best) {
                best = c;
            }
        }
    }
    best
}

/// Renders, encodes to PNG and decodes it again, returning the decoded
/// image and the frame used, to locate things.
fn render_decoded(
    mesh: &CurvedMesh<2>,
    values: &[f64],
    opts: &RenderOptions,
) -> (RgbaImage, Frame) {
    let img = decoded(&render_quads(mesh, values, opts).unwrap());
    (img, plan(mesh, values, opts).unwrap().0)
}

/// The pixel showing world point `p`.
fn at(img: &RgbaImage, frame: &Frame, p: [f64; 2]) -> [u8; 3] {
    let (x, y) = frame.layout.to_px(p);
    pixel(img, x as f64, y as f64)
}

/// Values of the 4×3 test mesh: cell c gets 0.85 + 0.025 c, so cell 6 is
/// exactly 1 and the range 0.85..1.125 contains 1 (diverging map).
fn known_values() -> Vec<f64> {
    (0..12).map(|c| 0.85 + 0.025 * c as f64).collect()
}

/// The linear mesh of `n[0] × n[1]` cells of the box `0..hi`.
fn linear_box(hi: [f64; 2], n: [usize; 2]) -> CurvedMesh<2> {
    CurvedMesh::from_quads(&QuadMesh::structured_box([0.0, 0.0], hi, n[0], n[1]))
}

fn box_4x3() -> CurvedMesh<2> {
    linear_box([4.0, 3.0], [4, 3])
}

fn centre(mesh: &CurvedMesh<2>, c: usize) -> [f64; 2] {
    let p = mesh.cell_coords(c);
    [
        p.iter().map(|q| q[0]).sum::<f64>() / 4.0,
        p.iter().map(|q| q[1]).sum::<f64>() / 4.0,
    ]
}

fn empty() -> CurvedMesh<2> {
    CurvedMesh {
        nodes: vec![],
        cells: crate::mesh::Cells::new(),
        boundary: crate::mesh::Facets::new(),
        ..box_4x3()
    }
}

#[test]
fn cell_centres_have_the_colour_of_their_value() {
    let mesh = box_4x3();
    let values = known_values();
    let opts = RenderOptions::default();
    let (img, frame) = render_decoded(&mesh, &values, &opts);
    assert_eq!(frame.cmap, ColourMap::Diverging { centre: 1.0 });
    assert_eq!(frame.range, (0.85, 0.85 + 0.025 * 11.0));
    for (c, &v) in values.iter().enumerate() {
        assert_close(
            at(&img, &frame, centre(&mesh, c)),
            frame.colour(v),
            &format!("cell {c}"),
        );
    }
}

#[test]
fn y_axis_points_up() {
    // Cell 0 is bottom-left in the world, so it must be bottom-left in the
    // picture: probe just inside the plot's lower-left corner, without
    // using the world-to-pixel map under test.
    let values = known_values();
    let opts = RenderOptions::default();
    let (img, frame) = render_decoded(&box_4x3(), &values, &opts);
    let [x, y, _, h] = frame.layout.plot;
    let lower_left = pixel(&img, x + 20.0, y + h - 20.0);
    assert_close(lower_left, frame.colour(values[0]), "lower-left cell");
    let upper_left = pixel(&img, x + 20.0, y + 20.0);
    assert_close(upper_left, frame.colour(values[8]), "upper-left cell");
}

#[test]
fn value_one_is_near_white_in_the_diverging_map() {
    let mesh = box_4x3();
    let values = known_values();
    assert_eq!(values[6], 1.0);
    let opts = RenderOptions::default();
    let (img, frame) = render_decoded(&mesh, &values, &opts);
    let found = at(&img, &frame, centre(&mesh, 6));
    assert!(
        found.iter().all(|&c| c >= 240),
        "value 1 drawn as {found:?}"
    );
    // and it is not pure white, so the cell is still distinguishable from
    // the background
    assert!(found.iter().any(|&c| c < 255));
}

#[test]
fn background_outside_the_mesh_is_white() {
    let mesh = linear_box([1.0, 1.0], [2, 2]);
    let opts = RenderOptions {
        bounds: Some(([-1.0, -1.0], [3.0, 2.0])),
        ..RenderOptions::default()
    };
    let (img, frame) = render_decoded(&mesh, &[0.9, 1.0, 1.1, 1.2], &opts);
    for far in [[-0.5, -0.5], [2.5, 1.5], [2.0, 0.5], [0.5, 1.7]] {
        assert_eq!(at(&img, &frame, far), WHITE, "at {far:?}");
    }
    assert_eq!(pixel(&img, 1.0, 1.0), WHITE, "image corner");
    // and a cell inside is coloured
    assert_ne!(at(&img, &frame, [0.25, 0.25]), WHITE);
}

#[test]
fn colour_bar_runs_from_low_at_the_bottom_to_high_at_the_top() {
    for values in [known_values(), (0..12).map(|c| 2.0 + c as f64).collect()] {
        let opts = RenderOptions::default();
        let (img, frame) = render_decoded(&box_4x3(), &values, &opts);
        let [x, _, w, _] = frame.layout.bar;
        let mid_x = (x + w / 2) as f64;
        let top = pixel(&img, mid_x, frame.layout.bar_row(1.0) as f64);
        let bottom = pixel(&img, mid_x, frame.layout.bar_row(0.0) as f64);
        assert_close(top, frame.colour(frame.range.1), "bar top");
        assert_close(bottom, frame.colour(frame.range.0), "bar bottom");
        assert_ne!(top, bottom);
        // just outside the bar, to its left, is background
        assert_eq!(
            pixel(&img, (x - 4) as f64, frame.layout.bar_row(0.5) as f64),
            WHITE
        );
    }
}

#[test]
fn range_without_one_uses_the_sequential_map() {
    let mesh = box_4x3();
    let values: Vec<f64> = (0..12).map(|c| 2.0 + c as f64).collect();
    let opts = RenderOptions::default();
    let (img, frame) = render_decoded(&mesh, &values, &opts);
    assert_eq!(frame.cmap, ColourMap::Sequential);
    let found = at(&img, &frame, centre(&mesh, 11));
    assert_close(
        found,
        ColourMap::Sequential.colour(13.0, (2.0, 13.0)),
        "cell 11",
    );
}

#[test]
fn explicit_range_and_colour_map_are_used() {
    let mesh = box_4x3();
    let opts = RenderOptions {
        range: Some((0.0, 2.0)),
        colour_map: Some(ColourMap::Sequential),
        ..RenderOptions::default()
    };
    let (img, frame) = render_decoded(&mesh, &known_values(), &opts);
    let found = at(&img, &frame, centre(&mesh, 0));
    assert_close(
        found,
        ColourMap::Sequential.colour(0.85, (0.0, 2.0)),
        "cell 0",
    );
}

#[test]
fn edges_and_title_draw_dark_pixels_where_expected() {
    let mesh = box_4x3();
    let values = known_values();
    let plain = RenderOptions {
        draw_edges: false,
        ..RenderOptions::default()
    };
    let titled = RenderOptions {
        title: Some("t = 0.30".into()),
        ..RenderOptions::default()
    };
    let (no_edges, frame) = render_decoded(&mesh, &values, &plain);
    let (with_edges, frame_t) = render_decoded(&mesh, &values, &titled);
    // The vertical line x = 1 between cells 0 and 1, mid-height of row 0.
    let dark = |c: [u8; 3]| c.iter().all(|&v| v < 120);
    assert!(!dark(at(&no_edges, &frame, [1.0, 0.5])));
    assert!(dark(at(&with_edges, &frame_t, [1.0, 0.5])));
    // The title adds height and puts ink in the top band.
    assert!(frame_t.layout.height > frame.layout.height);
    let band = (0..frame_t.layout.plot[1] as u32 / 2)
        .flat_map(|y| (0..with_edges.width()).map(move |x| (x, y)));
    assert!(band
        .into_iter()
        .any(|(x, y)| with_edges.get_pixel(x, y).0[0] < 60));
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let mesh = box_4x3();
    let opts = RenderOptions::default();
    let err = |m: &CurvedMesh<2>, v: &[f64], o: &RenderOptions| render_quads(m, v, o).unwrap_err();
    assert!(matches!(
        err(&mesh, &[1.0; 11], &opts),
        RenderError::LengthMismatch {
            values: 11,
            cells: 12
        }
    ));
    let mut nan = known_values();
    nan[5] = f64::NAN;
    assert!(matches!(
        err(&mesh, &nan, &opts),
        RenderError::NonFiniteValue { index: 5 }
    ));
    nan[5] = f64::INFINITY;
    assert!(matches!(
        err(&mesh, &nan, &opts),
        RenderError::NonFiniteValue { index: 5 }
    ));

    let v = known_values();
    let mut bad = mesh.clone();
    bad.nodes[3][1] = f64::NAN;
    assert!(matches!(
        err(&bad, &v, &opts),
        RenderError::NonFiniteNode { index: 3 }
    ));
    let mut bad = mesh.clone();
    bad.cells[2][1] = 999;
    assert!(matches!(
        err(&bad, &v, &opts),
        RenderError::BadNodeIndex {
            cell: 2,
            node: 999,
            ..
        }
    ));
    // (a quad less one node at p = 1 is a triangle, which is drawn: one
    // more node is no kind)
    let mut bad = mesh.clone();
    let mut cells = bad.cells.to_vecs();
    cells[2].push(0);
    bad.cells = crate::mesh::Cells::from_cells(2, bad.p, bad.shape, cells);
    assert!(matches!(
        err(&bad, &v, &opts),
        RenderError::InvalidCurvedMesh { .. }
    ));
    let mut bad = mesh.clone();
    // a boundary edge with one node too many
    let mut edges: Vec<(Vec<usize>, usize)> = bad.boundary.iter().map(|b| (b.nodes.to_vec(), b.part)).collect();
    edges[1].0.push(0);
    bad.boundary = CurvedMesh::<2>::facets_at(bad.p, edges);
    assert!(matches!(
        err(&bad, &v, &opts),
        RenderError::InvalidCurvedMesh { .. }
    ));
    let mut bad = mesh.clone();
    bad.p = 7;
    assert!(matches!(
        err(&bad, &v, &opts),
        RenderError::InvalidCurvedMesh { .. }
    ));

    let with = |f: &dyn Fn(&mut RenderOptions)| {
        let mut o = RenderOptions::default();
        f(&mut o);
        o
    };
    let inf_bounds = with(&|o| o.bounds = Some(([0.0, 0.0], [f64::INFINITY, 1.0])));
    assert!(matches!(
        err(&mesh, &v, &inf_bounds),
        RenderError::InvalidBounds { .. }
    ));
    let flat_bounds = with(&|o| o.bounds = Some(([0.0, 0.0], [1.0, 0.0])));
    assert!(matches!(
        err(&mesh, &v, &flat_bounds),
        RenderError::InvalidBounds { .. }
    ));
    let nan_range = with(&|o| o.range = Some((f64::NAN, 1.0)));
    assert!(matches!(
        err(&mesh, &v, &nan_range),
        RenderError::InvalidRange { .. }
    ));
    let reversed = with(&|o| o.range = Some((2.0, 1.0)));
    assert!(matches!(
        err(&mesh, &v, &reversed),
        RenderError::InvalidRange { .. }
    ));
    let narrow = with(&|o| o.width = 50);
    assert!(matches!(
        err(&mesh, &v, &narrow),
        RenderError::ImageSize { .. }
    ));
    assert!(matches!(
        err(&empty(), &[], &opts),
        RenderError::InvalidBounds { .. }
    ));
}

#[test]
fn degenerate_inputs_still_render() {
    // All values equal (a perfect mesh): the range is widened, not an error.
    let opts = RenderOptions::default();
    let (img, frame) = render_decoded(&box_4x3(), &[1.0; 12], &opts);
    assert!(frame.range.0 < 1.0 && frame.range.1 > 1.0);
    assert!(at(&img, &frame, [0.5, 0.5]).iter().all(|&c| c >= 240));
    // A very tall domain is capped in height; an empty mesh with a frame
    // renders an empty plot.
    let tall = linear_box([1.0, 100.0], [1, 10]);
    let p = render_quads(&tall, &[1.0; 10], &opts).unwrap();
    assert!(p.height() <= 4 * p.width());
    let framed = RenderOptions {
        bounds: Some(([0.0, 0.0], [1.0, 1.0])),
        ..RenderOptions::default()
    };
    assert!(render_quads(&empty(), &[], &framed).is_ok());
}

#[test]
fn edges_fade_out_on_tiny_cells() {
    let opts = RenderOptions::default();
    let (_, frame) = render_decoded(&box_4x3(), &known_values(), &opts);
    // Sizes in world units for cells of 2.5, 4 and 100 pixels.
    let style = |px: f64| frame.edge_style(vec![px / frame.layout.scale()]).1;
    assert!(style(2.5).is_none());
    let (w_small, a_small) = style(4.0).unwrap();
    let (w_big, a_big) = style(100.0).unwrap();
    assert!(w_small < w_big && a_small < a_big);
    // A 200×200 mesh at the default width still renders, with cell colours
    // visible between the hairlines.
    let mesh = linear_box([1.0, 1.0], [200, 200]);
    let values: Vec<f64> = (0..mesh.cells.len())
        .map(|c| 0.9 + 0.2 * (c % 200) as f64 / 199.0)
        .collect();
    let (img, frame) = render_decoded(&mesh, &values, &opts);
    let c = 200 * 100 + 150;
    assert_close(
        at(&img, &frame, centre(&mesh, c)),
        frame.colour(values[c]),
        "fine cell",
    );
}

/// Quarter annulus `1 ≤ r ≤ 2`, `0 ≤ θ ≤ π/2`: ξ runs along the angle, η
/// along the radius.
fn annulus(p: usize, n: [usize; 2]) -> CurvedMesh<2> {
    CurvedMesh::structured(p, Spacing::GaussLobatto, n, |[u, v]| {
        let (r, t) = (1.0 + v, 0.5 * PI * u);
        [r * t.cos(), r * t.sin()]
    })
    .unwrap()
}

/// One cell of the unit square whose top edge bulges up by 0.3 in the
/// middle (exactly representable at p = 2: y + 1.2 y x (1 − x)).
fn bulged_square(p: usize) -> CurvedMesh<2> {
    CurvedMesh::structured(p, Spacing::Equispaced, [1, 1], |[x, y]| {
        [x, y + 1.2 * y * x * (1.0 - x)]
    })
    .unwrap()
}

#[test]
fn annulus_renders_with_cell_colours_inside_the_arc() {
    let mesh = annulus(3, [4, 2]);
    let values: Vec<f64> = (0..8).map(|c| 0.9 + 0.03 * c as f64).collect();
    let opts = RenderOptions::default();
    let (img, frame) = render_decoded(&mesh, &values, &opts);
    // Outer cells are 4..8 (η is the second axis). At the middle angle of
    // each, halfway between the chord of its outer edge and the arc:
    // inside the true element, outside the straight-sided one.
    let dt = 0.5 * PI / 4.0;
    let sagitta = 2.0 * (1.0 - (0.5 * dt).cos());
    for i in 0..4 {
        let t = (i as f64 + 0.5) * dt;
        let r = 2.0 - 0.5 * sagitta;
        let found = at(&img, &frame, [r * t.cos(), r * t.sin()]);
        assert_close(
            found,
            frame.colour(values[4 + i]),
            &format!("bulge of cell {}", 4 + i),
        );
        // Just outside the arc is background.
        let r = 2.0 + 0.02;
        assert_eq!(at(&img, &frame, [r * t.cos(), r * t.sin()]), WHITE);
    }
    // The inner arc bulges into the hole: between arc and chord there is
    // no cell.
    let (t, r) = (0.5 * dt, 1.0 - 0.5 * sagitta);
    assert_eq!(at(&img, &frame, [r * t.cos(), r * t.sin()]), WHITE);
}

#[test]
fn bulge_of_a_curved_edge_has_the_cell_colour() {
    for p in [2, 3] {
        let mesh = bulged_square(p);
        let opts = RenderOptions {
            width: 400,
            ..RenderOptions::default()
        };
        let (img, frame) = render_decoded(&mesh, &[1.1], &opts);
        // Default bounds follow the curve: the top of the plot is at the
        // top of the bulge (y = 1.3), not at the nodes.
        let (_, top) = frame.layout.to_px([0.5, 1.3]);
        assert!((top as f64 - frame.layout.plot[1]).abs() < 0.5);
        // Above the chord y = 1, below the curve (1.29 at x = 0.42), and
        // off the internal node lines x = ½ (p = 2) and x = ⅓, ⅔.
        assert_close(at(&img, &frame, [0.42, 1.15]), frame.colour(1.1), "bulge");
        // Above the curve near the corner (curve at 1.108 there).
        assert_eq!(at(&img, &frame, [0.1, 1.25]), WHITE, "p = {p}");
    }
}

#[test]
fn boundary_and_internal_node_lines_are_drawn_as_curves() {
    let mesh = bulged_square(2);
    let opts = RenderOptions {
        width: 400,
        ..RenderOptions::default()
    };
    let (img, frame) = render_decoded(&mesh, &[1.1], &opts);
    let cell = frame.colour(1.1);
    let near = |p: [f64; 2]| {
        let (x, y) = frame.layout.to_px(p);
        darkest_near(&img, x as f64, y as f64)
    };
    // The boundary follows the curve: dark at (0.3, 1 + 1.2·0.21).
    assert!(brightness(near([0.3, 1.0 + 1.2 * 0.3 * 0.7])) + 100 < brightness(cell));
    // The internal line η = ½ is the curve y = ½ + 0.6 x (1 − x): at
    // x = 0.3 it is at 0.626 (faint: darker, but not like an edge), and
    // the straight y = ½ there is plain cell.
    let on_line = near([0.3, 0.626]);
    let faint =
        brightness(on_line) + 15 < brightness(cell) && brightness(on_line) + 100 > brightness(cell);
    assert!(faint, "line η = ½ at {on_line:?}, cell {cell:?}");
    assert_close(at(&img, &frame, [0.3, 0.5]), cell, "off the line");
}

#[test]
fn shared_curved_edges_are_sampled_once() {
    let mesh = annulus(3, [4, 2]);
    let curves = QuadCurves::new(&mesh);
    // 4×2 cells: 4·3 angular edges + 5·2 radial ones.
    assert_eq!(curves.edges(false).count() + curves.edges(true).count(), 22);
    assert_eq!(curves.edges(true).count(), 12);
    assert_eq!(curves.grid.len(), 8 * 2 * 2 * (8 * 3 + 1));
    // Outlines are closed curves that follow the arc: the area of the
    // whole annulus is 3π/4 to sampling accuracy (the chords lose about
    // 1.4e-4 against the true arcs).
    let area: f64 = (0..8).map(|c| polygon_area(&curves.outline(c)).abs()).sum();
    assert!((area - 0.75 * PI).abs() < 5e-4, "area {area}");
    // A linear mesh is drawn as its cells: one straight piece per edge.
    let curves = QuadCurves::new(&box_4x3());
    assert_eq!(curves.outline(5).len(), 4);
    assert!(curves.grid.is_empty());
}

/// Quads and triangles in one picture, each cell drawn by its own kind:
/// its outline has its own number of edges, the outlines tile the bent
/// domain, and each cell shows its value's colour inside.
#[test]
fn a_mixed_mesh_draws_each_cell_by_its_kind() {
    // the area of [0, 3] × [0, 1] under the test mesh's bend, whose
    // det J is 1 − 0.02 x cos 2y
    let area = 3.0 - 0.02 * 4.5 * 0.5 * 2f64.sin();
    for p in [1, 2, 3] {
        let mesh = crate::io::layout::tests::mixed2(p);
        let curves = QuadCurves::new(&mesh);
        // 4 + 3 + 2 + 2 distinct edges (x = 1, x = 2 and the diagonal
        // shared), the 8 around on the boundary
        assert_eq!((curves.edges(false).count(), curves.edges(true).count()), (3, 8), "p = {p}");
        let pieces = if p == 1 { 1 } else { 8 * p };
        let sides: Vec<usize> = (0..4).map(|c| curves.outline(c).len() / pieces).collect();
        assert_eq!(sides, [4, 4, 3, 3], "p = {p}");
        let drawn: f64 = (0..4).map(|c| polygon_area(&curves.outline(c))).sum();
        // p = 1 draws the chords of the curved sides
        assert!((drawn - area).abs() < if p == 1 { 0.05 } else { 2e-3 }, "p = {p}: area {drawn}, want {area}");
        let values = [0.9, 1.0, 1.1, 1.2];
        let opts = RenderOptions { width: 600, draw_edges: false, ..RenderOptions::default() };
        let (img, frame) = render_decoded(&mesh, &values, &opts);
        for (c, &v) in values.iter().enumerate() {
            let x = mesh.cell_coords(c);
            let mid = [0, 1].map(|k| x.iter().map(|y| y[k]).sum::<f64>() / x.len() as f64);
            assert_close(at(&img, &frame, mid), frame.colour(v), &format!("p = {p}, cell {c}"));
        }
    }
}

fn frames(sizes: &[u32]) -> Vec<Pixmap> {
    let mesh = box_4x3();
    sizes
        .iter()
        .enumerate()
        .map(|(i, &w)| {
            let values: Vec<f64> = known_values().iter().map(|v| v + 0.01 * i as f64).collect();
            let opts = RenderOptions {
                width: w,
                range: Some((0.8, 1.2)),
                ..RenderOptions::default()
            };
            render_quads(&mesh, &values, &opts).unwrap()
        })
        .collect()
}

#[test]
fn gif_has_all_frames_loops_and_holds_the_last() {
    let pixmaps = frames(&[300, 300, 300]);
    let bytes = gif_bytes(&pixmaps, 20).unwrap();
    let mut opts = gif::DecodeOptions::new();
    opts.set_color_output(gif::ColorOutput::RGBA);
    let mut decoder = opts.read_info(bytes.as_slice()).unwrap();
    assert_eq!(
        (decoder.width() as u32, decoder.height() as u32),
        (pixmaps[0].width(), pixmaps[0].height())
    );
    let mut delays = Vec::new();
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        assert_eq!(
            (frame.width as u32, frame.height as u32),
            (pixmaps[0].width(), pixmaps[0].height())
        );
        // Quantisation keeps the white background white.
        assert_eq!(&frame.buffer[..4], &[255, 255, 255, 255]);
        delays.push(frame.delay);
    }
    assert_eq!(delays, [20, 20, 80]);
    assert_eq!(decoder.repeat(), gif::Repeat::Infinite);
}

#[test]
fn gif_rejects_mixed_sizes_and_no_frames() {
    let pixmaps = frames(&[300, 300, 320]);
    let err = gif_bytes(&pixmaps, 10).unwrap_err();
    assert!(
        matches!(err, RenderError::FrameSize { index: 2, .. }),
        "{err}"
    );
    assert!(matches!(gif_bytes(&[], 10), Err(RenderError::NoFrames)));
}

/// Files in `dir`, to check that no temporary file is left behind.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn files_are_written_whole_and_replace_old_ones() {
    let dir = tempfile::tempdir().unwrap();
    let png_path = dir.path().join("mesh.png");
    std::fs::write(&png_path, b"old contents").unwrap();
    let pixmaps = frames(&[300, 300]);
    write_png(&png_path, &pixmaps[0]).unwrap();
    let img = image::open(&png_path).unwrap();
    assert_eq!(img.width(), 300);
    let gif_path = dir.path().join("anim.gif");
    write_gif(&gif_path, &pixmaps, 10).unwrap();
    assert_eq!(
        std::fs::read(&gif_path).unwrap(),
        gif_bytes(&pixmaps, 10).unwrap()
    );
    assert_eq!(listing(dir.path()), ["anim.gif", "mesh.png"]);
}

#[test]
fn failed_writes_leave_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let pixmaps = frames(&[300]);
    // Renaming a file onto an existing directory fails after the temporary
    // file was written: it must be removed again.
    let blocked = dir.path().join("taken");
    std::fs::create_dir_all(blocked.join("inner")).unwrap();
    assert!(matches!(
        write_png(&blocked, &pixmaps[0]),
        Err(RenderError::Io(_))
    ));
    assert_eq!(listing(dir.path()), ["taken"]);
    // A missing directory is an error too.
    let missing = dir.path().join("no/such/dir/x.png");
    assert!(matches!(
        write_png(&missing, &pixmaps[0]),
        Err(RenderError::Io(_))
    ));
}
