//! Tests that render real pictures, decode the encoded bytes and check
//! pixels, so they catch wrong colours, positions, orientation and
//! encodings rather than just "it did not crash".

use std::path::Path;

use image::RgbaImage;

use super::*;

/// Values of the 4×3 test mesh: cell c gets 0.85 + 0.025 c, so cell 6 is
/// exactly 1 and the range 0.85..1.125 contains 1 (diverging map).
fn known_values() -> Vec<f64> {
    (0..12).map(|c| 0.85 + 0.025 * c as f64).collect()
}

fn box_4x3() -> QuadMesh {
    QuadMesh::structured_box([0.0, 0.0], [4.0, 3.0], 4, 3)
}

/// Renders, encodes to PNG and decodes it again, returning the decoded
/// image and the plan used, to locate things.
fn render_decoded(mesh: &QuadMesh, values: &[f64], opts: &RenderOptions) -> (RgbaImage, Plan) {
    let pixmap = render_mesh(mesh, values, opts).unwrap();
    let png = png_bytes(&pixmap).unwrap();
    let img = image::load_from_memory_with_format(&png, image::ImageFormat::Png)
        .unwrap()
        .to_rgba8();
    assert_eq!(
        (img.width(), img.height()),
        (pixmap.width(), pixmap.height())
    );
    (img, Plan::new(mesh, values, opts).unwrap())
}

fn pixel_at(img: &RgbaImage, (x, y): (f32, f32)) -> [u8; 3] {
    let p = img.get_pixel(x as u32, y as u32).0;
    assert_eq!(p[3], 255, "picture should be opaque");
    [p[0], p[1], p[2]]
}

fn assert_close(found: [u8; 3], expected: [u8; 3], what: &str) {
    let ok = (0..3).all(|k| found[k].abs_diff(expected[k]) <= 2);
    assert!(ok, "{what}: found {found:?}, expected {expected:?}");
}

fn centre(mesh: &QuadMesh, c: usize) -> [f64; 2] {
    let p = mesh.cell_coords(c);
    [
        p.iter().map(|q| q[0]).sum::<f64>() / 4.0,
        p.iter().map(|q| q[1]).sum::<f64>() / 4.0,
    ]
}

#[test]
fn cell_centres_have_the_colour_of_their_value() {
    let mesh = box_4x3();
    let values = known_values();
    let (img, plan) = render_decoded(&mesh, &values, &RenderOptions::default());
    assert_eq!(plan.cmap, ColourMap::Diverging { centre: 1.0 });
    assert_eq!(plan.range, (0.85, 0.85 + 0.025 * 11.0));
    for (c, &v) in values.iter().enumerate() {
        let found = pixel_at(&img, plan.layout.to_px(centre(&mesh, c)));
        assert_close(found, plan.cmap.colour(v, plan.range), &format!("cell {c}"));
    }
}

#[test]
fn y_axis_points_up() {
    // Cell 0 is bottom-left in the world, so it must be bottom-left in the
    // picture: probe just inside the plot's lower-left corner, without
    // using the world-to-pixel map under test.
    let mesh = box_4x3();
    let values = known_values();
    let (img, plan) = render_decoded(&mesh, &values, &RenderOptions::default());
    let [x, y, _, h] = plan.layout.plot;
    let lower_left = pixel_at(&img, ((x + 20.0) as f32, (y + h - 20.0) as f32));
    assert_close(
        lower_left,
        plan.cmap.colour(values[0], plan.range),
        "lower-left cell",
    );
    let upper_left = pixel_at(&img, ((x + 20.0) as f32, (y + 20.0) as f32));
    assert_close(
        upper_left,
        plan.cmap.colour(values[8], plan.range),
        "upper-left cell",
    );
}

#[test]
fn value_one_is_near_white_in_the_diverging_map() {
    let mesh = box_4x3();
    let values = known_values();
    assert_eq!(values[6], 1.0);
    let (img, plan) = render_decoded(&mesh, &values, &RenderOptions::default());
    let found = pixel_at(&img, plan.layout.to_px(centre(&mesh, 6)));
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
    let mesh = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 2, 2);
    let opts = RenderOptions {
        bounds: Some(([-1.0, -1.0], [3.0, 2.0])),
        ..RenderOptions::default()
    };
    let (img, plan) = render_decoded(&mesh, &[0.9, 1.0, 1.1, 1.2], &opts);
    for far in [[-0.5, -0.5], [2.5, 1.5], [2.0, 0.5], [0.5, 1.7]] {
        assert_eq!(
            pixel_at(&img, plan.layout.to_px(far)),
            [255; 3],
            "at {far:?}"
        );
    }
    assert_eq!(pixel_at(&img, (1.0, 1.0)), [255; 3], "image corner");
    // and a cell inside is coloured
    assert_ne!(pixel_at(&img, plan.layout.to_px([0.25, 0.25])), [255; 3]);
}

#[test]
fn colour_bar_runs_from_low_at_the_bottom_to_high_at_the_top() {
    for values in [known_values(), (0..12).map(|c| 2.0 + c as f64).collect()] {
        let mesh = box_4x3();
        let (img, plan) = render_decoded(&mesh, &values, &RenderOptions::default());
        let [x, _, w, _] = plan.layout.bar;
        let mid_x = (x + w / 2) as f32;
        let top = pixel_at(&img, (mid_x, plan.layout.bar_row(1.0) as f32));
        let bottom = pixel_at(&img, (mid_x, plan.layout.bar_row(0.0) as f32));
        assert_close(top, plan.cmap.colour(plan.range.1, plan.range), "bar top");
        assert_close(
            bottom,
            plan.cmap.colour(plan.range.0, plan.range),
            "bar bottom",
        );
        assert_ne!(top, bottom);
        // just outside the bar, to its left, is background
        assert_eq!(
            pixel_at(&img, ((x - 4) as f32, plan.layout.bar_row(0.5) as f32)),
            [255; 3]
        );
    }
}

#[test]
fn range_without_one_uses_the_sequential_map() {
    let mesh = box_4x3();
    let values: Vec<f64> = (0..12).map(|c| 2.0 + c as f64).collect();
    let (img, plan) = render_decoded(&mesh, &values, &RenderOptions::default());
    assert_eq!(plan.cmap, ColourMap::Sequential);
    let found = pixel_at(&img, plan.layout.to_px(centre(&mesh, 11)));
    assert_close(
        found,
        ColourMap::Sequential.colour(13.0, (2.0, 13.0)),
        "cell 11",
    );
}

#[test]
fn explicit_range_and_colour_map_are_used() {
    let mesh = box_4x3();
    let values = known_values();
    let opts = RenderOptions {
        range: Some((0.0, 2.0)),
        colour_map: Some(ColourMap::Sequential),
        ..RenderOptions::default()
    };
    let (img, plan) = render_decoded(&mesh, &values, &opts);
    let found = pixel_at(&img, plan.layout.to_px(centre(&mesh, 0)));
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
    let (no_edges, plan) = render_decoded(&mesh, &values, &plain);
    let (with_edges, plan_t) = render_decoded(&mesh, &values, &titled);
    // The vertical line x = 1 between cells 0 and 1, mid-height of row 0.
    let on_edge = |p: &Plan| p.layout.to_px([1.0, 0.5]);
    let dark = |c: [u8; 3]| c.iter().all(|&v| v < 120);
    assert!(!dark(pixel_at(&no_edges, on_edge(&plan))));
    assert!(dark(pixel_at(&with_edges, on_edge(&plan_t))));
    // The title adds height and puts ink in the top band.
    assert!(plan_t.layout.height > plan.layout.height);
    let band = (0..plan_t.layout.plot[1] as u32 / 2)
        .flat_map(|y| (0..with_edges.width()).map(move |x| (x, y)));
    assert!(band
        .into_iter()
        .any(|(x, y)| with_edges.get_pixel(x, y).0[0] < 60));
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let mesh = box_4x3();
    let opts = RenderOptions::default();
    let err = |m: &QuadMesh, v: &[f64], o: &RenderOptions| render_mesh(m, v, o).unwrap_err();
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
    let empty = QuadMesh {
        nodes: vec![],
        cells: vec![],
        edges: vec![],
        part_names: vec![],
    };
    assert!(matches!(
        err(&empty, &[], &opts),
        RenderError::InvalidBounds { .. }
    ));
}

#[test]
fn degenerate_inputs_still_render() {
    // All values equal (a perfect mesh): the range is widened, not an error.
    let mesh = box_4x3();
    let (img, plan) = render_decoded(&mesh, &[1.0; 12], &RenderOptions::default());
    assert!(plan.range.0 < 1.0 && plan.range.1 > 1.0);
    assert!(pixel_at(&img, plan.layout.to_px([0.5, 0.5]))
        .iter()
        .all(|&c| c >= 240));
    // A very tall domain is capped in height; an empty mesh with a frame
    // renders an empty plot.
    let tall = QuadMesh::structured_box([0.0, 0.0], [1.0, 100.0], 1, 10);
    let p = render_mesh(&tall, &[1.0; 10], &RenderOptions::default()).unwrap();
    assert!(p.height() <= 4 * p.width());
    let empty = QuadMesh {
        nodes: vec![],
        cells: vec![],
        edges: vec![],
        part_names: vec![],
    };
    let framed = RenderOptions {
        bounds: Some(([0.0, 0.0], [1.0, 1.0])),
        ..RenderOptions::default()
    };
    assert!(render_mesh(&empty, &[], &framed).is_ok());
}

#[test]
fn edges_fade_out_on_tiny_cells() {
    assert!(draw::interior_style(2.5, 1.0).is_none());
    let (w_small, a_small) = draw::interior_style(4.0, 1.0).unwrap();
    let (w_big, a_big) = draw::interior_style(100.0, 1.0).unwrap();
    assert!(w_small < w_big && a_small < a_big);
    // A 200×200 mesh at the default width still renders, with cell colours
    // visible between the hairlines.
    let mesh = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 200, 200);
    let values: Vec<f64> = (0..mesh.num_cells())
        .map(|c| 0.9 + 0.2 * (c % 200) as f64 / 199.0)
        .collect();
    let (img, plan) = render_decoded(&mesh, &values, &RenderOptions::default());
    let c = 200 * 100 + 150;
    assert_close(
        pixel_at(&img, plan.layout.to_px(centre(&mesh, c))),
        plan.cmap.colour(values[c], plan.range),
        "fine cell",
    );
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
            render_mesh(&mesh, &values, &opts).unwrap()
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
