//! Tests that render real hex-, tet- and prism-mesh pictures, encode them as PNG,
//! decode them again and check pixels: colours, shading, positions, hidden
//! surfaces, clipping, curved faces and errors.

use std::collections::HashMap;
use std::f64::consts::PI;

use image::RgbaImage;

use super::view::{self, shade_colour};
use super::*;
use crate::mesh::element::Shape;
use crate::mesh::element::prism::tests::prism_box;
use crate::mesh::element::{simplex, Spacing};
use crate::mesh::{Cells, HexMesh};
use crate::numeric::cross3;
use crate::render::tests::{assert_close, brightness, darkest_near, decoded, pixel, WHITE};

const BLUE_VALUE: f64 = 0.9;
const RED_VALUE: f64 = 1.1;

/// The linear mesh `mesh` as the order-1 case.
fn linear(mesh: &HexMesh) -> CurvedMesh<3> {
    CurvedMesh::from_hexes(mesh)
}

fn brick(n: [usize; 3]) -> CurvedMesh<3> {
    linear(&HexMesh::structured_box([0.0; 3], n.map(|k| k as f64), n))
}

/// Looking straight down the z axis (x right, y up in the picture).
fn from_above() -> Camera {
    Camera {
        azimuth_deg: 0.0,
        elevation_deg: 90.0,
        distance: None,
    }
}

fn opts(camera: Camera) -> RenderOptions3 {
    RenderOptions3 {
        width: 400,
        camera,
        ..RenderOptions3::default()
    }
}

/// The plan of `mesh`.
fn plan_of(mesh: &CurvedMesh<3>, values: &[f64], opts: &RenderOptions3) -> HexPlan {
    HexPlan::new(mesh, values, opts).unwrap()
}

/// Renders, encodes to PNG and decodes it again, returning the image and
/// the plan used, to locate things.
fn render_decoded(
    mesh: &CurvedMesh<3>,
    values: &[f64],
    opts: &RenderOptions3,
) -> (RgbaImage, HexPlan) {
    let img = decoded(&render_hexes(mesh, values, opts).unwrap());
    (img, plan_of(mesh, values, opts))
}

/// The pixel showing world point `p`.
fn pixel_of(img: &RgbaImage, plan: &HexPlan, p: [f64; 3]) -> [u8; 3] {
    let [x, y, _] = plan.to_image(p).unwrap();
    pixel(img, x, y)
}

/// The colour a face of value `v` with outward unit normal `n` (facing
/// the viewer) must have: the map's colour times the light factor.
fn expected(plan: &HexPlan, v: f64, n: [f64; 3]) -> [u8; 3] {
    shade_colour(plan.frame.colour(v), plan.view.light_factor(n))
}

fn is_white(c: [u8; 3]) -> bool {
    c == WHITE
}

fn bluish(c: [u8; 3]) -> bool {
    c[2] as i32 > c[0] as i32 + 20
}

fn reddish(c: [u8; 3]) -> bool {
    c[0] as i32 > c[2] as i32 + 20
}

/// Pixel rows and columns of the plot region, where the mesh may be drawn.
fn plot_pixels(plan: &HexPlan) -> impl Iterator<Item = (u32, u32)> {
    let [x0, y0, w, h] = plan.frame.layout.plot_region();
    (y0..y0 + h).flat_map(move |y| (x0..x0 + w).map(move |x| (x, y)))
}

/// Bounding box (x0, y0, x1, y1) of the non-white pixels of the plot
/// region, found from the image alone.
fn drawn_box(img: &RgbaImage, plan: &HexPlan) -> [u32; 4] {
    let mut b = [u32::MAX, u32::MAX, 0, 0];
    for (x, y) in plot_pixels(plan) {
        if !is_white(pixel(img, x as f64, y as f64)) {
            b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        }
    }
    b
}

#[test]
fn cube_from_above_fills_a_square_with_its_top_colour() {
    let mesh = brick([1, 1, 1]);
    let o = RenderOptions3 {
        bounds: Some(([-1.0, -1.0, 0.0], [2.0, 2.0, 1.0])),
        ..opts(from_above())
    };
    let (img, plan) = render_decoded(&mesh, &[1.05], &o);
    let top = expected(&plan, 1.05, [0.0, 0.0, 1.0]);
    assert!(reddish(top), "1.05 is above the centre: {top:?}");

    // The drawn region is a square of the unit cube's size.
    let [x0, y0, x1, y1] = drawn_box(&img, &plan);
    let side = plan.frame.layout.scale();
    assert!(
        ((x1 - x0 + 1) as f64 - side).abs() <= 2.0,
        "width {} vs {side}",
        x1 - x0 + 1
    );
    assert!(
        ((y1 - y0 + 1) as f64 - side).abs() <= 2.0,
        "height {} vs {side}",
        y1 - y0 + 1
    );
    // It is where the cube is: the middle third of the framed 3×3 box.
    let [px, py, pw, _] = plan.frame.layout.plot;
    assert!((x0 as f64 - (px + pw / 3.0)).abs() <= 2.0);
    assert!((y0 as f64 - (py + pw / 3.0)).abs() <= 2.0);

    // Inside (away from the silhouette line) it is the shaded top colour;
    // outside it the plot stays white.
    for (x, y) in plot_pixels(&plan) {
        let c = pixel(&img, x as f64, y as f64);
        let inside = x >= x0 + 3 && x + 3 <= x1 && y >= y0 + 3 && y + 3 <= y1;
        let outside = x + 2 < x0 || x > x1 + 2 || y + 2 < y0 || y > y1 + 2;
        if inside {
            assert_close(c, top, &format!("inside at ({x}, {y})"));
        } else if outside {
            assert!(is_white(c), "outside at ({x}, {y}): {c:?}");
        }
    }
    // The silhouette is drawn dark.
    let mid = (y0 + y1) / 2;
    let edge = pixel(&img, x0 as f64, mid as f64);
    assert!(
        edge.iter().all(|&c| c < top[0].min(top[1]).min(top[2])),
        "outline {edge:?}"
    );
}

#[test]
fn side_by_side_cells_show_their_own_colours_in_the_right_place() {
    let mesh = brick([2, 1, 1]);
    let values = [BLUE_VALUE, RED_VALUE];
    let (img, plan) = render_decoded(&mesh, &values, &opts(from_above()));
    // Found from the image alone: the left half is cell 0 (x < 1), the
    // right half cell 1, so x points right.
    let [x0, y0, x1, y1] = drawn_box(&img, &plan);
    let (w, ymid) = ((x1 - x0) as f64, (y0 + y1) as f64 / 2.0);
    let left = pixel(&img, x0 as f64 + 0.25 * w, ymid);
    let right = pixel(&img, x0 as f64 + 0.75 * w, ymid);
    assert!(
        bluish(left) && reddish(right),
        "left {left:?}, right {right:?}"
    );
    let up = [0.0, 0.0, 1.0];
    assert_close(left, expected(&plan, BLUE_VALUE, up), "cell 0");
    assert_close(right, expected(&plan, RED_VALUE, up), "cell 1");
}

#[test]
fn y_points_up_when_looking_down() {
    let mesh = brick([1, 2, 1]);
    let (img, plan) = render_decoded(&mesh, &[BLUE_VALUE, RED_VALUE], &opts(from_above()));
    let [x0, y0, x1, y1] = drawn_box(&img, &plan);
    let (xmid, h) = ((x0 + x1) as f64 / 2.0, (y1 - y0) as f64);
    assert!(
        bluish(pixel(&img, xmid, y0 as f64 + 0.75 * h)),
        "cell 0 (y < 1) at the bottom"
    );
    assert!(reddish(pixel(&img, xmid, y0 as f64 + 0.25 * h)));
}

#[test]
fn three_quarter_view_shades_top_front_and_side_differently() {
    let mesh = brick([2, 1, 1]);
    let values = [BLUE_VALUE, RED_VALUE];
    let (img, plan) = render_decoded(&mesh, &values, &opts(Camera::default()));
    let faces = [
        ([0.0, 0.0, 1.0], [0.5, 0.5, 1.0], [1.5, 0.5, 1.0]), // top
        ([0.0, -1.0, 0.0], [0.5, 0.0, 0.5], [1.5, 0.0, 0.5]), // front, y = 0
    ];
    for (n, c0, c1) in faces {
        assert_close(
            pixel_of(&img, &plan, c0),
            expected(&plan, BLUE_VALUE, n),
            "cell 0",
        );
        assert_close(
            pixel_of(&img, &plan, c1),
            expected(&plan, RED_VALUE, n),
            "cell 1",
        );
    }
    let side = [1.0, 0.0, 0.0];
    let at = [2.0, 0.5, 0.5];
    assert_close(
        pixel_of(&img, &plan, at),
        expected(&plan, RED_VALUE, side),
        "x = 2 side",
    );
    // The light from the upper left makes the top brightest and the
    // right-facing side darkest, with every face still well lit.
    let f = |n| plan.view.light_factor(n);
    let (top, front, right) = (f([0.0, 0.0, 1.0]), f([0.0, -1.0, 0.0]), f(side));
    assert!(
        top > front + 0.05 && front > right + 0.05,
        "{top} {front} {right}"
    );
    assert!(
        right > 0.5,
        "the darkest side keeps a readable colour: {right}"
    );
}

/// Renders `mesh` (two cells, values blue then red) with the cells and
/// values also listed in reverse order, so a renderer that lets the last
/// drawn face win fails one of the two.
fn both_orders(mesh: &CurvedMesh<3>, o: &RenderOptions3) -> Vec<(RgbaImage, HexPlan)> {
    let mut reversed = mesh.clone();
    reversed.cells = Cells::from_cells(3, mesh.p, mesh.shape, mesh.cells.iter().rev());
    vec![
        render_decoded(mesh, &[BLUE_VALUE, RED_VALUE], o),
        render_decoded(&reversed, &[RED_VALUE, BLUE_VALUE], o),
    ]
}

#[test]
fn a_cell_behind_another_is_hidden() {
    // Cell 0 (blue) is below cell 1 (red).
    let column = brick([1, 1, 2]);
    let below = Camera {
        elevation_deg: -90.0,
        ..from_above()
    };
    for (camera, visible, hidden) in [
        (
            from_above(),
            reddish as fn([u8; 3]) -> bool,
            bluish as fn([u8; 3]) -> bool,
        ),
        (below, bluish, reddish),
    ] {
        for (img, plan) in both_orders(&column, &opts(camera)) {
            let centre = pixel_of(&img, &plan, [0.5, 0.5, 1.0]);
            assert!(visible(centre), "the near cell shows: {centre:?}");
            let leaks = plot_pixels(&plan)
                .filter(|&(x, y)| hidden(pixel(&img, x as f64, y as f64)))
                .count();
            assert_eq!(leaks, 0, "the far cell must not show through");
        }
    }
}

#[test]
fn a_cell_behind_another_is_hidden_from_the_side() {
    // Cell 0 (blue, x < 1) and cell 1 (red, x > 1), seen along ∓x.
    let row = brick([2, 1, 1]);
    for (az, visible, hidden) in [
        (
            90.0,
            reddish as fn([u8; 3]) -> bool,
            bluish as fn([u8; 3]) -> bool,
        ),
        (-90.0, bluish, reddish),
    ] {
        let camera = Camera {
            azimuth_deg: az,
            elevation_deg: 0.0,
            distance: Some(4.0),
        };
        for (img, plan) in both_orders(&row, &opts(camera)) {
            let centre = pixel_of(&img, &plan, [1.0, 0.5, 0.5]);
            assert!(visible(centre), "azimuth {az}: {centre:?}");
            let leaks = plot_pixels(&plan)
                .filter(|&(x, y)| hidden(pixel(&img, x as f64, y as f64)))
                .count();
            assert_eq!(leaks, 0, "azimuth {az}: the far cell shows through");
        }
    }
}

#[test]
fn clip_plane_exposes_the_inner_face() {
    let mesh = brick([2, 1, 1]);
    let values = [BLUE_VALUE, RED_VALUE];
    let from_right = Camera {
        azimuth_deg: 90.0,
        elevation_deg: 0.0,
        distance: None,
    };
    let n = [1.0, 0.0, 0.0];
    let (img, plan) = render_decoded(&mesh, &values, &opts(from_right));
    assert_close(
        pixel_of(&img, &plan, [2.0, 0.5, 0.5]),
        expected(&plan, RED_VALUE, n),
        "unclipped: the end face of cell 1",
    );

    let clipped = RenderOptions3 {
        clip: Some(ClipPlane {
            point: [1.0, 0.3, 0.7],
            normal: [2.0, 0.0, 0.0],
        }),
        ..opts(from_right)
    };
    let (img, plan) = render_decoded(&mesh, &values, &clipped);
    assert!(
        plan.patches.iter().all(|f| f.cell == 0),
        "cell 1 is dropped"
    );
    assert_eq!(
        plan.frame.range,
        (BLUE_VALUE, RED_VALUE),
        "range from all values"
    );
    assert_close(
        pixel_of(&img, &plan, [1.0, 0.5, 0.5]),
        expected(&plan, BLUE_VALUE, n),
        "clipped: the inner face of cell 0",
    );
    let reds = plot_pixels(&plan)
        .filter(|&(x, y)| reddish(pixel(&img, x as f64, y as f64)))
        .count();
    assert_eq!(reds, 0, "the dropped cell is not drawn");
}

#[test]
fn clipping_a_brick_in_a_three_quarter_view_shows_the_cut() {
    // 4×4×4 cells with a value that depends on x only; cutting at x = 2
    // from the default view must show the cut face (x = 2, value of the
    // cells at 1 < x < 2) where the unclipped brick shows nothing.
    let mesh = brick([4, 4, 4]);
    let values: Vec<f64> = (0..64).map(|c| 0.9 + 0.05 * (c % 4) as f64).collect();
    let clip = ClipPlane {
        point: [2.0, 0.0, 0.0],
        normal: [1.0, 0.0, 0.0],
    };
    let o = RenderOptions3 {
        clip: Some(clip),
        ..opts(Camera::default())
    };
    let (img, plan) = render_decoded(&mesh, &values, &o);
    let want = expected(&plan, 0.95, [1.0, 0.0, 0.0]);
    for p in [[2.0, 1.5, 1.5], [2.0, 2.5, 2.5], [2.0, 3.5, 0.5]] {
        assert_close(
            pixel_of(&img, &plan, p),
            want,
            &format!("cut face at {p:?}"),
        );
    }
}

#[test]
fn edges_are_drawn_between_faces_and_can_be_turned_off() {
    let mesh = brick([2, 1, 1]);
    let values = [1.0, 1.0];
    let lum = |c: [u8; 3]| c.iter().map(|&v| v as i32).sum::<i32>();
    for draw_edges in [true, false] {
        let o = RenderOptions3 {
            draw_edges,
            ..opts(from_above())
        };
        let (img, plan) = render_decoded(&mesh, &values, &o);
        let face = lum(pixel_of(&img, &plan, [0.5, 0.5, 1.0]));
        let on_edge = lum(pixel_of(&img, &plan, [1.0, 0.5, 1.0]));
        if draw_edges {
            assert!(on_edge < face - 60, "edge {on_edge} vs face {face}");
        } else {
            assert!((on_edge - face).abs() <= 3, "no edge: {on_edge} vs {face}");
        }
    }
}

#[test]
fn edges_are_left_out_when_faces_are_tiny() {
    let style = |mesh: &CurvedMesh<3>| {
        let values = vec![1.0; mesh.cells.len()];
        let o = opts(Camera::default());
        edge_style(&plan_of(mesh, &values, &o))
    };
    assert!(style(&brick([2, 2, 2])).is_some());
    // A thin plate of 100 × 100 cells: faces of about 2 pixels.
    let fine = linear(&HexMesh::structured_box(
        [0.0; 3],
        [1.0, 1.0, 0.01],
        [100, 100, 1],
    ));
    assert_eq!(style(&fine), None);
}

#[test]
fn perspective_makes_far_edges_shorter() {
    // From the front and above, the silhouette of a cube is bounded by the
    // far top edge above and the near bottom edge below: equally long in a
    // parallel view, the far one shorter in perspective.
    let mesh = brick([1, 1, 1]);
    let widths = |distance| {
        let camera = Camera {
            azimuth_deg: 0.0,
            elevation_deg: 30.0,
            distance,
        };
        let (img, plan) = render_decoded(&mesh, &[1.0], &opts(camera));
        let [_, y0, _, y1] = drawn_box(&img, &plan);
        let row_width = |y: u32| {
            let [x0, _, w, _] = plan.frame.layout.plot_region();
            (x0..x0 + w)
                .filter(|&x| !is_white(pixel(&img, x as f64, y as f64)))
                .count() as f64
        };
        (row_width(y0 + 3), row_width(y1 - 3))
    };
    let (top, bottom) = widths(None);
    assert!((top - bottom).abs() <= 2.0, "parallel: {top} vs {bottom}");
    let (top, bottom) = widths(Some(2.0));
    assert!(top < 0.85 * bottom, "perspective: {top} vs {bottom}");
}

#[test]
fn frames_with_the_same_bounds_line_up() {
    let a = brick([2, 2, 2]);
    let mut b = a.clone();
    for p in &mut b.nodes {
        p[2] *= 1.0 + 0.2 * p[0];
    }
    let bounds = Some(([0.0; 3], [2.0, 2.0, 3.0]));
    let o = RenderOptions3 {
        bounds,
        ..opts(Camera::default())
    };
    let values = vec![1.0; 8];
    let (pa, pb) = (plan_of(&a, &values, &o), plan_of(&b, &values, &o));
    assert_eq!(
        (pa.frame.layout.width, pa.frame.layout.height),
        (pb.frame.layout.width, pb.frame.layout.height)
    );
    let p = [1.0, 0.0, 2.0];
    assert_eq!(pa.to_image(p), pb.to_image(p));
    // Without a box each frames itself, so they differ.
    let o = opts(Camera::default());
    let (pa, pb) = (plan_of(&a, &values, &o), plan_of(&b, &values, &o));
    assert_ne!(pa.to_image(p), pb.to_image(p));
}

#[test]
fn colour_bar_and_title_are_drawn() {
    let mesh = brick([2, 1, 1]);
    let o = RenderOptions3 {
        title: Some("t = 0.5".into()),
        ..opts(Camera::default())
    };
    let (img, plan) = render_decoded(&mesh, &[BLUE_VALUE, RED_VALUE], &o);
    let [bx, by, bw, bh] = plan.frame.layout.bar;
    let x = (bx + bw / 2) as f64;
    assert_close(
        pixel(&img, x, by as f64),
        plan.frame.colour(RED_VALUE),
        "bar top",
    );
    let bottom = (by + bh - 1) as f64;
    assert_close(
        pixel(&img, x, bottom),
        plan.frame.colour(BLUE_VALUE),
        "bar bottom",
    );
    let title_top = plan.frame.layout.title_top as u32;
    let dark = (title_top..title_top + 10)
        .flat_map(|y| (0..img.width()).map(move |x| (x, y)))
        .filter(|&(x, y)| pixel(&img, x as f64, y as f64)[0] < 100)
        .count();
    assert!(dark > 20, "title text expected, found {dark} dark pixels");
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let mesh = brick([1, 1, 1]);
    let ok = RenderOptions3::default();
    let err = |m: &CurvedMesh<3>, v: &[f64], o: &RenderOptions3| render_hexes(m, v, o).unwrap_err();

    assert!(matches!(
        err(&mesh, &[1.0, 2.0], &ok),
        RenderError::LengthMismatch {
            values: 2,
            cells: 1
        }
    ));
    assert!(matches!(
        err(&mesh, &[], &ok),
        RenderError::LengthMismatch { .. }
    ));
    assert!(matches!(
        err(&mesh, &[f64::NAN], &ok),
        RenderError::NonFiniteValue { index: 0 }
    ));
    assert!(matches!(
        err(&mesh, &[f64::INFINITY], &ok),
        RenderError::NonFiniteValue { index: 0 }
    ));

    let mut bad = mesh.clone();
    bad.nodes[5][1] = f64::NAN;
    assert!(matches!(
        err(&bad, &[1.0], &ok),
        RenderError::NonFiniteNode { index: 5 }
    ));
    let mut bad = mesh.clone();
    bad.nodes[2][2] = f64::NEG_INFINITY;
    assert!(matches!(
        err(&bad, &[1.0], &ok),
        RenderError::NonFiniteNode { index: 2 }
    ));
    let mut bad = mesh.clone();
    bad.cells[0][7] = 99;
    assert!(matches!(
        err(&bad, &[1.0], &ok),
        RenderError::BadNodeIndex {
            cell: 0,
            node: 99,
            nodes: 8
        }
    ));

    for camera in [
        Camera {
            elevation_deg: 90.5,
            ..Camera::default()
        },
        Camera {
            elevation_deg: -91.0,
            ..Camera::default()
        },
        Camera {
            elevation_deg: f64::NAN,
            ..Camera::default()
        },
        Camera {
            azimuth_deg: f64::INFINITY,
            ..Camera::default()
        },
        Camera {
            distance: Some(1.0),
            ..Camera::default()
        },
        Camera {
            distance: Some(0.0),
            ..Camera::default()
        },
        Camera {
            distance: Some(-3.0),
            ..Camera::default()
        },
        Camera {
            distance: Some(f64::NAN),
            ..Camera::default()
        },
        Camera {
            distance: Some(f64::INFINITY),
            ..Camera::default()
        },
    ] {
        let o = RenderOptions3 {
            camera,
            ..ok.clone()
        };
        assert!(
            matches!(err(&mesh, &[1.0], &o), RenderError::InvalidCamera { .. }),
            "{camera:?}"
        );
    }

    for clip in [
        ClipPlane {
            point: [0.5; 3],
            normal: [0.0; 3],
        },
        ClipPlane {
            point: [f64::NAN, 0.0, 0.0],
            normal: [1.0, 0.0, 0.0],
        },
        ClipPlane {
            point: [0.5; 3],
            normal: [1.0, f64::INFINITY, 0.0],
        },
    ] {
        let o = RenderOptions3 {
            clip: Some(clip),
            ..ok.clone()
        };
        assert!(matches!(
            err(&mesh, &[1.0], &o),
            RenderError::InvalidClipPlane { .. }
        ));
    }

    for bounds in [
        ([0.0, 0.0, 0.0], [1.0, -1.0, 1.0]),
        ([0.0, 0.0, f64::NAN], [1.0, 1.0, 1.0]),
        ([0.5; 3], [0.5; 3]),
    ] {
        let o = RenderOptions3 {
            bounds: Some(bounds),
            ..ok.clone()
        };
        assert!(matches!(
            err(&mesh, &[1.0], &o),
            RenderError::InvalidBounds3 { .. }
        ));
    }
    let empty = CurvedMesh {
        nodes: vec![],
        cells: Cells::new(),
        boundary: crate::mesh::Facets::new(),
        ..brick([1, 1, 1])
    };
    assert!(matches!(
        err(&empty, &[], &ok),
        RenderError::InvalidBounds3 { .. }
    ));

    let o = RenderOptions3 {
        range: Some((2.0, 1.0)),
        ..ok.clone()
    };
    assert!(matches!(
        err(&mesh, &[1.0], &o),
        RenderError::InvalidRange { .. }
    ));
    let o = RenderOptions3 {
        width: 120,
        ..ok.clone()
    };
    assert!(matches!(
        err(&mesh, &[1.0], &o),
        RenderError::ImageSize { .. }
    ));
}

#[test]
fn edge_cases_still_render() {
    let mesh = brick([2, 1, 1]);
    let values = [BLUE_VALUE, RED_VALUE];
    // A plane that drops every cell leaves an empty plot.
    let o = RenderOptions3 {
        clip: Some(ClipPlane {
            point: [-1.0, 0.0, 0.0],
            normal: [1.0, 0.0, 0.0],
        }),
        ..opts(Camera::default())
    };
    let (img, plan) = render_decoded(&mesh, &values, &o);
    assert!(plot_pixels(&plan).all(|(x, y)| is_white(pixel(&img, x as f64, y as f64))));
    // An empty mesh with a box, a flat cell seen edge-on, a collapsed
    // cell, extreme elevations and a box that cuts through the mesh
    // behind a perspective eye.
    let empty = CurvedMesh {
        nodes: vec![],
        cells: Cells::new(),
        boundary: crate::mesh::Facets::new(),
        ..brick([1, 1, 1])
    };
    let boxed = RenderOptions3 {
        bounds: Some(([0.0; 3], [1.0; 3])),
        ..RenderOptions3::default()
    };
    render_hexes(&empty, &[], &boxed).unwrap();
    let flat = linear(&HexMesh::structured_box(
        [0.0; 3],
        [1.0, 1.0, 0.0],
        [1, 1, 1],
    ));
    let side = Camera {
        azimuth_deg: 0.0,
        elevation_deg: 0.0,
        distance: None,
    };
    render_hexes(&flat, &[1.0], &opts(side)).unwrap();
    let mut collapsed = brick([1, 1, 1]);
    collapsed.nodes = vec![[0.3; 3]; 8];
    collapsed.nodes[0] = [0.0; 3];
    render_hexes(&collapsed, &[1.0], &opts(Camera::default())).unwrap();
    for elevation_deg in [-90.0, 90.0] {
        let camera = Camera {
            elevation_deg,
            distance: Some(1.5),
            ..Camera::default()
        };
        render_hexes(&mesh, &values, &opts(camera)).unwrap();
    }
    let cut = RenderOptions3 {
        camera: Camera {
            distance: Some(1.2),
            ..Camera::default()
        },
        bounds: Some(([0.0; 3], [0.2; 3])),
        ..opts(Camera::default())
    };
    render_hexes(&brick([4, 4, 4]), &vec![1.0; 64], &cut).unwrap();
}

#[test]
fn light_factor_is_ambient_for_faces_turned_from_the_light() {
    let o = opts(from_above());
    let plan = plan_of(&brick([1, 1, 1]), &[1.0], &o);
    // From above, the light comes from above the viewer: a face seen
    // head-on is lit, and its reverse normal only gets the ambient share.
    let lit = plan.view.light_factor([0.0, 0.0, 1.0]);
    assert!(lit > 0.9 && lit <= 1.0, "{lit}");
    assert_eq!(plan.view.light_factor([0.0, 0.0, -1.0]), view::AMBIENT);
}

/// The block `[0,1]³` (or `n` cells of it) whose side x = 1 bulges out by
/// 0.3 at y = ½: x ↦ x (1 + 1.2 y (1 − y)), exact at p = 2.
fn bulged_block(p: usize, n: [usize; 3]) -> CurvedMesh<3> {
    CurvedMesh::structured(p, Spacing::GaussLobatto, n, |[x, y, z]| {
        [x * (1.0 + 1.2 * y * (1.0 - y)), y, z]
    })
    .unwrap()
}

#[test]
fn bulge_of_a_curved_face_has_the_face_colour() {
    for p in [2, 3] {
        let mesh = bulged_block(p, [1, 1, 1]);
        let o = opts(from_above());
        let (img, plan) = render_decoded(&mesh, &[0.9], &o);
        // The top face seen face-on, lit as a face with normal +z.
        let top = expected(&plan, 0.9, [0.0, 0.0, 1.0]);
        assert_close(pixel_of(&img, &plan, [0.5, 0.5, 1.0]), top, "centre");
        // Right of the chord x = 1, left of the curve x = 1.3 at y = ½.
        assert_close(pixel_of(&img, &plan, [1.15, 0.5, 1.0]), top, "bulge");
        // Beyond the curve near a corner (x = 1.108 at y = 0.1).
        assert_eq!(pixel_of(&img, &plan, [1.25, 0.1, 1.0]), WHITE);
        // No line between the sub-quads: on a sub-quad border inside the
        // face, the colour is the plain face colour.
        let m = (SUBQUADS_PER_ORDER * p) as f64;
        assert_close(
            pixel_of(&img, &plan, [1.0 / m, 0.5, 1.0]),
            top,
            "sub-quad border",
        );
    }
}

#[test]
fn face_borders_follow_the_curved_edges() {
    // Two cells along x: the edge between their top faces is the curve
    // x = ½ (1 + 1.2 y (1 − y)), at x = 0.65 for y = ½, where a straight
    // edge would be at x = ½.
    let mesh = bulged_block(2, [2, 1, 1]);
    let values = [0.9, 1.1];
    let o = opts(from_above());
    let (img, plan) = render_decoded(&mesh, &values, &o);
    assert_eq!(plan.patches.len(), 10, "two cells show ten faces");
    let [x, y, _] = plan.to_image([0.65, 0.5, 1.0]).unwrap();
    let line = darkest_near(&img, x, y);
    for v in values {
        let top = expected(&plan, v, [0.0, 0.0, 1.0]);
        assert!(
            brightness(line) * 10 < brightness(top) * 9,
            "{line:?} vs {top:?}"
        );
    }
    let top = expected(&plan, 0.9, [0.0, 0.0, 1.0]);
    assert_close(pixel_of(&img, &plan, [0.5, 0.5, 1.0]), top, "chord");
}

#[test]
fn clipping_drops_whole_curved_cells_by_their_corners() {
    let mesh = bulged_block(2, [2, 1, 1]);
    let values = [0.9, 1.1];
    let clip = RenderOptions3 {
        clip: Some(ClipPlane {
            point: [0.6, 0.0, 0.0],
            normal: [1.0, 0.0, 0.0],
        }),
        bounds: Some(([0.0; 3], [1.3, 1.0, 1.0])),
        ..opts(from_above())
    };
    let (img, plan) = render_decoded(&mesh, &values, &clip);
    // Only cell 0 (corner mean x = 0.25) is kept; it shows all six faces.
    assert_eq!(plan.patches.len(), 6);
    assert!(plan.patches.iter().all(|f| f.cell == 0));
    let top0 = expected(&plan, 0.9, [0.0, 0.0, 1.0]);
    assert_close(pixel_of(&img, &plan, [0.25, 0.5, 1.0]), top0, "kept cell");
    assert_eq!(
        pixel_of(&img, &plan, [0.9, 0.5, 1.0]),
        WHITE,
        "dropped cell"
    );
}

#[test]
fn every_sampled_point_is_finite_and_on_the_face() {
    let mesh = bulged_block(3, [2, 2, 2]);
    let corners = Corners::of(&mesh);
    let patches = surface_patches(&mesh, &corners, &[true; 8], 9);
    assert!(patches.iter().all(|f| f.grid == Grid::Quad(9)));
    assert_eq!(patches.len(), 24);
    for f in &patches {
        assert_eq!(f.points.len(), 100);
        assert!(f.points.iter().flatten().all(|x| x.is_finite()));
        // Every surface point lies on a side of the (bulged) box.
        for &[x, y, z] in &f.points {
            let on = [x.abs(), z.abs(), (z - 1.0).abs(), y.abs(), (y - 1.0).abs()]
                .into_iter()
                .fold(f64::INFINITY, f64::min)
                .min((x - (1.0 + 1.2 * y * (1.0 - y))).abs());
            // p = 3 reproduces the quadratic bulge exactly.
            assert!(on < 1e-12, "{:?} is not on the surface", [x, y, z]);
        }
    }
}

#[test]
fn a_curved_mesh_with_a_bad_cell_is_an_error() {
    let mesh = bulged_block(2, [1, 1, 1]);
    let mut short = mesh.clone();
    let mut cells = short.cells.to_vecs();
    cells[0].pop();
    short.cells = Cells::from_cells(3, short.p, short.shape, cells);
    assert!(matches!(
        render_hexes(&short, &[1.0], &RenderOptions3::default()),
        Err(RenderError::InvalidCurvedMesh { .. })
    ));
    // A quarter cylinder shell is drawn whole at every order.
    for p in 1..=4 {
        let shell = CurvedMesh::structured(p, Spacing::GaussLobatto, [2, 1, 1], |[u, v, w]| {
            let (r, t) = (1.0 + v, 0.5 * PI * u);
            [r * t.cos(), r * t.sin(), w]
        })
        .unwrap();
        render_hexes(&shell, &[1.0, 1.1], &RenderOptions3::default()).unwrap();
    }
}

// Tetrahedra.

/// The box `[0, n]` of unit cubes, each split into six tets around its
/// diagonal from its lowest to its highest corner (so neighbouring cubes
/// split their shared side alike), as an order-`p` tet mesh: each tet's
/// nodes, in the lattice order, at the reference nodes of `spacing` mapped
/// affinely into the tet and then through `map`. Nodes of shared edges and
/// faces are shared (found by their lattice point in the box); every tet
/// is positively oriented before `map`. Cube `c` (x fastest) holds cells
/// `6c..6c + 6`.
fn tet_box(
    p: usize,
    spacing: Spacing,
    n: [usize; 3],
    map: impl Fn([f64; 3]) -> [f64; 3],
) -> CurvedMesh<3> {
    let reference = &simplex::space(Shape::Tetrahedron, p, spacing)
        .unwrap()
        .nodes;
    let lattice = simplex::lattice(Shape::Tetrahedron, p);
    let mut ids: HashMap<[usize; 3], usize> = HashMap::new();
    let (mut nodes, mut cells) = (Vec::new(), Vec::new());
    for cube in 0..n.iter().product() {
        let base = [cube % n[0], cube / n[0] % n[1], cube / (n[0] * n[1])];
        for axes in [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ] {
            // The path from the lowest corner along the three axes.
            let mut v = [base; 4];
            for (s, &a) in axes.iter().enumerate() {
                v[s + 1] = v[s];
                v[s + 1][a] += 1;
            }
            let edge =
                |v: &[[usize; 3]; 4], k: usize| sub(v[k].map(|x| x as f64), v[0].map(|x| x as f64));
            if dot(edge(&v, 1), cross3(edge(&v, 2), edge(&v, 3))) < 0.0 {
                v.swap(1, 2);
            }
            let e = |k: usize| edge(&v, k);
            let cell: Vec<usize> = lattice
                .iter()
                .zip(reference)
                .map(|(&[i, j, k], xi)| {
                    let at: [usize; 3] = std::array::from_fn(|d| {
                        (p - i - j - k) * v[0][d] + i * v[1][d] + j * v[2][d] + k * v[3][d]
                    });
                    *ids.entry(at).or_insert_with(|| {
                        let x = (0..3).fold(v[0].map(|c| c as f64), |x, a| {
                            add(x, scale(xi[a], e(a + 1)))
                        });
                        nodes.push(map(x));
                        nodes.len() - 1
                    })
                })
                .collect();
            cells.push(cell);
        }
    }
    CurvedMesh {
        shape: Shape::Tetrahedron,
        p,
        spacing,
        nodes,
        cells: Cells::from_cells(3, p, Shape::Tetrahedron, cells),
        boundary: crate::mesh::Facets::new(),
        part_names: vec![],
    }
}

/// `v` for each of the six tets of every cube listed, cube by cube.
fn per_cube(cubes: &[f64]) -> Vec<f64> {
    cubes.iter().flat_map(|&v| [v; 6]).collect()
}

/// The number of non-white pixels of the plot region.
fn drawn_area(img: &RgbaImage, plan: &HexPlan) -> usize {
    plot_pixels(plan)
        .filter(|&(x, y)| !is_white(pixel(img, x as f64, y as f64)))
        .count()
}

/// The bulge of [`bulged_block`]: the side x = 1 bulges out by 0.3 at
/// y = ½.
fn bulge([x, y, z]: [f64; 3]) -> [f64; 3] {
    [x * (1.0 + 1.2 * y * (1.0 - y)), y, z]
}

#[test]
fn a_cube_of_tets_covers_what_the_hex_cube_covers() {
    let hex = brick([1, 1, 1]);
    let tets = tet_box(1, Spacing::Equispaced, [1, 1, 1], |x| x);
    for camera in [
        Camera::default(),
        from_above(),
        Camera {
            azimuth_deg: -50.0,
            elevation_deg: -20.0,
            distance: Some(3.0),
        },
    ] {
        let o = opts(camera);
        let (a, plan_a) = render_decoded(&hex, &[1.05], &o);
        let (b, plan_b) = render_decoded(&tets, &[1.05; 6], &o);
        assert_eq!(plan_b.patches.len(), 12, "two triangles a side");
        assert_eq!(
            plan_a.frame.layout.plot_region(),
            plan_b.frame.layout.plot_region()
        );
        let (area_a, area_b) = (drawn_area(&a, &plan_a), drawn_area(&b, &plan_b));
        eprintln!("{camera:?}: hex {area_a} pixels, tets {area_b}");
        assert!(area_a > 10_000, "{area_a}");
        assert!(
            (area_b as f64 / area_a as f64 - 1.0).abs() < 0.02,
            "hex {area_a} vs tets {area_b}"
        );
    }
}

#[test]
fn tet_faces_are_shaded_like_hex_faces_with_their_edges_drawn() {
    let tets = tet_box(1, Spacing::Equispaced, [1, 1, 1], |x| x);
    let (img, plan) = render_decoded(&tets, &[RED_VALUE; 6], &opts(Camera::default()));
    // Off the triangles' edges each side of the cube has the hex colours.
    let sides = [
        ([0.0, 0.0, 1.0], [0.75, 0.25, 1.0]),
        ([0.0, -1.0, 0.0], [0.75, 0.0, 0.25]),
        ([1.0, 0.0, 0.0], [1.0, 0.75, 0.25]),
    ];
    for (n, at) in sides {
        assert_close(
            pixel_of(&img, &plan, at),
            expected(&plan, RED_VALUE, n),
            &format!("{n:?}"),
        );
    }
    // The top is split along its diagonal (0,0,1)–(1,1,1), drawn as an
    // edge; the other diagonal is no edge.
    let top = expected(&plan, RED_VALUE, [0.0, 0.0, 1.0]);
    let [x, y, _] = plan.to_image([0.5, 0.5, 1.0]).unwrap();
    let line = darkest_near(&img, x, y);
    assert!(
        brightness(line) * 10 < brightness(top) * 9,
        "{line:?} vs {top:?}"
    );
    assert_close(
        pixel_of(&img, &plan, [0.8, 0.2, 1.0]),
        top,
        "off the diagonal",
    );
}

#[test]
fn clipping_tets_shows_the_inside() {
    // Two cubes of tets along x, seen from +x: the x = 2 side is red; with
    // the second cube clipped away the side x = 1 between them shows
    // blue.
    let mesh = tet_box(1, Spacing::Equispaced, [2, 1, 1], |x| x);
    let values = per_cube(&[BLUE_VALUE, RED_VALUE]);
    let camera = Camera {
        azimuth_deg: 90.0,
        elevation_deg: 0.0,
        distance: None,
    };
    let bounds = Some(([0.0; 3], [2.0, 1.0, 1.0]));
    let whole = RenderOptions3 {
        bounds,
        ..opts(camera)
    };
    let cut = RenderOptions3 {
        clip: Some(ClipPlane {
            point: [1.0, 0.0, 0.0],
            normal: [1.0, 0.0, 0.0],
        }),
        ..whole.clone()
    };
    let side = [1.0, 0.0, 0.0];
    let (img, plan) = render_decoded(&mesh, &values, &whole);
    assert_eq!(plan.patches.len(), 20);
    assert_close(
        pixel_of(&img, &plan, [2.0, 0.75, 0.25]),
        expected(&plan, RED_VALUE, side),
        "x = 2",
    );
    let (img, plan) = render_decoded(&mesh, &values, &cut);
    assert_eq!(
        plan.patches.len(),
        12,
        "the kept cube shows its twelve triangles"
    );
    assert!(plan.patches.iter().all(|f| f.cell < 6));
    assert_close(
        pixel_of(&img, &plan, [1.0, 0.75, 0.25]),
        expected(&plan, BLUE_VALUE, side),
        "inside at x = 1",
    );
    let reds = plot_pixels(&plan)
        .filter(|&(x, y)| reddish(pixel(&img, x as f64, y as f64)))
        .count();
    assert_eq!(reds, 0, "the dropped cube is gone");
}

#[test]
fn bulged_tets_follow_the_curved_side_at_p3_and_not_at_p1() {
    let bounds = Some(([0.0; 3], [1.3, 1.0, 1.0]));
    let o = RenderOptions3 {
        bounds,
        ..opts(from_above())
    };
    for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
        let (flat, plan1) = render_decoded(&tet_box(1, spacing, [1, 1, 1], bulge), &[0.9; 6], &o);
        let (img, plan) = render_decoded(&tet_box(3, spacing, [1, 1, 1], bulge), &[0.9; 6], &o);
        let top = expected(&plan, 0.9, [0.0, 0.0, 1.0]);
        // Right of the chord x = 1, left of the curve x = 1.3 at y = ½.
        assert_close(
            pixel_of(&img, &plan, [1.15, 0.5, 1.0]),
            top,
            "bulge at p = 3",
        );
        assert_eq!(
            pixel_of(&flat, &plan1, [1.15, 0.5, 1.0]),
            WHITE,
            "no bulge at p = 1"
        );
        // Beyond the curve near a corner (x = 1.108 at y = 0.1).
        assert_eq!(pixel_of(&img, &plan, [1.25, 0.1, 1.0]), WHITE);
        // No line between the sub-triangles inside a face: on the border
        // of the first row of them, the plain face colour.
        assert_close(
            pixel_of(&img, &plan, [0.7, 1.0 / 9.0, 1.0]),
            top,
            "sub-triangle border",
        );
        let (a1, a3) = (drawn_area(&flat, &plan1), drawn_area(&img, &plan));
        // The bulge adds 1.2/6 = 0.2 to the unit square seen from above.
        eprintln!("{spacing:?}: drawn {a1} pixels at p = 1, {a3} at p = 3");
        assert!((a3 as f64 / a1 as f64 - 1.2).abs() < 0.03, "{a1} vs {a3}");
        // The same surface as a curved hex draws the same area.
        let (hex, plan_h) = render_decoded(&bulged_block(2, [1, 1, 1]), &[0.9], &o);
        let ah = drawn_area(&hex, &plan_h);
        assert!(
            (a3 as f64 / ah as f64 - 1.0).abs() < 0.02,
            "tets {a3} vs hex {ah}"
        );
    }
}

#[test]
fn sampled_tet_faces_lie_on_the_surface_with_outward_normals() {
    for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
        let mesh = tet_box(3, spacing, [2, 1, 1], |x| bulge(scale(0.5, x)));
        let corners = Corners::of(&mesh);
        let patches = surface_patches(&mesh, &corners, &[true; 12], 9);
        assert_eq!(patches.len(), 20);
        for f in &patches {
            assert_eq!((f.points.len(), f.normals.len()), (55, 55));
            for &[x, y, z] in &f.points {
                let on = [x.abs(), z.abs(), (z - 0.5).abs(), y.abs(), (y - 0.5).abs()]
                    .into_iter()
                    .fold(f64::INFINITY, f64::min)
                    .min((x - (1.0 + 1.2 * y * (1.0 - y))).abs());
                // p = 3 reproduces the quadratic bulge exactly.
                assert!(on < 1e-12, "{:?} is not on the surface", [x, y, z]);
            }
            // The normals of flat sides are theirs, pointing out.
            let mean = scale(
                1.0 / 55.0,
                f.points.iter().fold([0.0; 3], |s, &x| add(s, x)),
            );
            for (side, normal) in [
                (mean[2] - 0.5, [0.0, 0.0, 1.0]),
                (mean[1], [0.0, -1.0, 0.0]),
            ] {
                if side.abs() < 1e-12 {
                    assert!(
                        f.normals
                            .iter()
                            .all(|&n| sub(n, normal).iter().all(|d| d.abs() < 1e-12)),
                        "{spacing:?}: {:?}",
                        f.normals
                    );
                }
            }
        }
    }
}

#[test]
fn tets_of_every_order_and_spacing_are_drawn() {
    for p in 1..=4 {
        for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
            let mesh = tet_box(p, spacing, [2, 1, 1], crate::mesh::curved::tests::bend3);
            let values: Vec<f64> = (0..12).map(|c| 0.9 + 0.02 * c as f64).collect();
            let (img, plan) = render_decoded(&mesh, &values, &opts(Camera::default()));
            let m = if p == 1 { 1 } else { SUBQUADS_PER_ORDER * p };
            assert!(plan.patches.iter().all(|f| f.grid == Grid::Tri(m)));
            assert_eq!(plan.patches.len(), 20, "p = {p}");
            assert!(plan
                .patches
                .iter()
                .all(|f| f.points.len() == (m + 1) * (m + 2) / 2));
            let area = drawn_area(&img, &plan);
            assert!(area > 10_000, "p = {p} {spacing:?}: {area} pixels drawn");
        }
    }
}

#[test]
fn bad_tet_meshes_are_errors_not_panics() {
    let ok = RenderOptions3::default();
    let mesh = tet_box(3, Spacing::GaussLobatto, [1, 1, 1], |x| x);
    let values = [1.0; 6];
    let mut bad = mesh.clone();
    bad.cells[2][7] = 999;
    let nodes = mesh.nodes.len();
    assert!(matches!(
        render_hexes(&bad, &values, &ok),
        Err(RenderError::BadNodeIndex { cell: 2, node: 999, nodes: n }) if n == nodes
    ));
    let mut short = mesh.clone();
    let mut cells = short.cells.to_vecs();
    cells[4].pop();
    short.cells = Cells::from_cells(3, short.p, short.shape, cells);
    assert!(matches!(
        render_hexes(&short, &values, &ok),
        Err(RenderError::InvalidCurvedMesh { .. })
    ));
    // Tets labelled as hexes, hexes as tets: the label is the first
    // cell's kind.
    let as_hexes = CurvedMesh {
        shape: Shape::Hexahedron,
        ..mesh.clone()
    };
    assert!(matches!(
        render_hexes(&as_hexes, &values, &ok),
        Err(RenderError::InvalidCurvedMesh { .. })
    ));
    let as_tets = CurvedMesh {
        shape: Shape::Tetrahedron,
        ..brick([1, 1, 1])
    };
    assert!(matches!(
        render_hexes(&as_tets, &[1.0], &ok),
        Err(RenderError::InvalidCurvedMesh { .. })
    ));
    let p = 1;
    let pyramid = CurvedMesh {
        shape: Shape::Pyramid,
        cells: Cells::from_cells(3, p, Shape::Pyramid, [(0..Shape::Pyramid.num_nodes(p)).collect::<Vec<_>>()]),
        ..tet_box(p, Spacing::Equispaced, [1, 1, 1], |x| x)
    };
    // pyramids are drawn
    render_hexes(&pyramid, &[1.0], &ok).unwrap();
    // A collapsed tet mesh still renders.
    let mut collapsed = mesh.clone();
    collapsed
        .nodes
        .iter_mut()
        .skip(1)
        .for_each(|x| *x = [0.3; 3]);
    render_hexes(&collapsed, &values, &opts(Camera::default())).unwrap();
}

// Prisms.

/// `v` for each of the two prisms of every cube listed, cube by cube.
fn per_prism_cube(cubes: &[f64]) -> Vec<f64> {
    cubes.iter().flat_map(|&v| [v; 2]).collect()
}

#[test]
fn a_cube_of_prisms_covers_what_the_hex_cube_covers() {
    let hex = brick([1, 1, 1]);
    let prisms = prism_box(1, Spacing::Equispaced, [1, 1, 1], |x| x);
    for camera in [
        Camera::default(),
        from_above(),
        Camera {
            azimuth_deg: -50.0,
            elevation_deg: -20.0,
            distance: Some(3.0),
        },
    ] {
        let o = opts(camera);
        let (a, plan_a) = render_decoded(&hex, &[1.05], &o);
        let (b, plan_b) = render_decoded(&prisms, &[1.05; 2], &o);
        let triangles = plan_b
            .patches
            .iter()
            .filter(|f| f.grid == Grid::Tri(1))
            .count();
        assert_eq!(
            (plan_b.patches.len(), triangles),
            (8, 4),
            "two triangles top and bottom, a quad on each side"
        );
        assert_eq!(
            plan_a.frame.layout.plot_region(),
            plan_b.frame.layout.plot_region()
        );
        let (area_a, area_b) = (drawn_area(&a, &plan_a), drawn_area(&b, &plan_b));
        eprintln!("{camera:?}: hex {area_a} pixels, prisms {area_b}");
        assert!(area_a > 10_000, "{area_a}");
        assert!(
            (area_b as f64 / area_a as f64 - 1.0).abs() < 0.02,
            "hex {area_a} vs prisms {area_b}"
        );
    }
}

#[test]
fn prism_faces_are_shaded_like_hex_faces_with_their_edges_drawn() {
    let prisms = prism_box(1, Spacing::Equispaced, [1, 1, 1], |x| x);
    let (img, plan) = render_decoded(&prisms, &[RED_VALUE; 2], &opts(Camera::default()));
    // Each side of the cube has the hex colours: the top on its two
    // triangles, the front and right sides on their quads.
    let sides = [
        ([0.0, 0.0, 1.0], [0.25, 0.25, 1.0]),
        ([0.0, 0.0, 1.0], [0.75, 0.75, 1.0]),
        ([0.0, -1.0, 0.0], [0.75, 0.0, 0.25]),
        ([1.0, 0.0, 0.0], [1.0, 0.75, 0.25]),
    ];
    for (n, at) in sides {
        assert_close(
            pixel_of(&img, &plan, at),
            expected(&plan, RED_VALUE, n),
            &format!("{n:?} at {at:?}"),
        );
    }
    // The top is split along its diagonal (1,0,1)–(0,1,1), drawn as an
    // edge; the other diagonal is no edge.
    let top = expected(&plan, RED_VALUE, [0.0, 0.0, 1.0]);
    let [x, y, _] = plan.to_image([0.5, 0.5, 1.0]).unwrap();
    let line = darkest_near(&img, x, y);
    assert!(
        brightness(line) * 10 < brightness(top) * 9,
        "{line:?} vs {top:?}"
    );
    assert_close(
        pixel_of(&img, &plan, [0.2, 0.2, 1.0]),
        top,
        "off the diagonal",
    );
}

#[test]
fn clipping_prisms_shows_the_inside() {
    // Two cubes of prisms along x, seen from +x: the x = 2 side is red;
    // with the second cube clipped away the side x = 1 between them shows
    // blue.
    let mesh = prism_box(1, Spacing::Equispaced, [2, 1, 1], |x| x);
    let values = per_prism_cube(&[BLUE_VALUE, RED_VALUE]);
    let camera = Camera {
        azimuth_deg: 90.0,
        elevation_deg: 0.0,
        distance: None,
    };
    let bounds = Some(([0.0; 3], [2.0, 1.0, 1.0]));
    let whole = RenderOptions3 {
        bounds,
        ..opts(camera)
    };
    let cut = RenderOptions3 {
        clip: Some(ClipPlane {
            point: [1.0, 0.0, 0.0],
            normal: [1.0, 0.0, 0.0],
        }),
        ..whole.clone()
    };
    let side = [1.0, 0.0, 0.0];
    let (img, plan) = render_decoded(&mesh, &values, &whole);
    assert_eq!(plan.patches.len(), 14);
    assert_close(
        pixel_of(&img, &plan, [2.0, 0.75, 0.25]),
        expected(&plan, RED_VALUE, side),
        "x = 2",
    );
    let (img, plan) = render_decoded(&mesh, &values, &cut);
    assert_eq!(plan.patches.len(), 8, "the kept cube shows its eight faces");
    assert!(plan.patches.iter().all(|f| f.cell < 2));
    assert_close(
        pixel_of(&img, &plan, [1.0, 0.75, 0.25]),
        expected(&plan, BLUE_VALUE, side),
        "inside at x = 1",
    );
    let reds = plot_pixels(&plan)
        .filter(|&(x, y)| reddish(pixel(&img, x as f64, y as f64)))
        .count();
    assert_eq!(reds, 0, "the dropped cube is gone");
}

#[test]
fn bulged_prisms_follow_the_curved_side_at_p3_and_not_at_p1() {
    let bounds = Some(([0.0; 3], [1.3, 1.0, 1.0]));
    let o = RenderOptions3 {
        bounds,
        ..opts(from_above())
    };
    for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
        // the side x = 1, a quad face, bulges; seen from above its top
        // edge bounds the top triangle
        let (flat, plan1) = render_decoded(&prism_box(1, spacing, [1, 1, 1], bulge), &[0.9; 2], &o);
        let (img, plan) = render_decoded(&prism_box(3, spacing, [1, 1, 1], bulge), &[0.9; 2], &o);
        let top = expected(&plan, 0.9, [0.0, 0.0, 1.0]);
        assert_close(
            pixel_of(&img, &plan, [1.15, 0.5, 1.0]),
            top,
            "bulge at p = 3",
        );
        assert_eq!(
            pixel_of(&flat, &plan1, [1.15, 0.5, 1.0]),
            WHITE,
            "no bulge at p = 1"
        );
        assert_eq!(pixel_of(&img, &plan, [1.25, 0.1, 1.0]), WHITE);
        // No line between the pieces inside a face.
        assert_close(
            pixel_of(&img, &plan, [0.7, 1.0 / 9.0, 1.0]),
            top,
            "piece border",
        );
        let (a1, a3) = (drawn_area(&flat, &plan1), drawn_area(&img, &plan));
        eprintln!("{spacing:?}: drawn {a1} pixels at p = 1, {a3} at p = 3");
        assert!((a3 as f64 / a1 as f64 - 1.2).abs() < 0.03, "{a1} vs {a3}");
        let (hex, plan_h) = render_decoded(&bulged_block(2, [1, 1, 1]), &[0.9], &o);
        let ah = drawn_area(&hex, &plan_h);
        assert!(
            (a3 as f64 / ah as f64 - 1.0).abs() < 0.02,
            "prisms {a3} vs hex {ah}"
        );
    }
}

/// The triangle and quad faces of curved prisms are sampled on the true
/// surface (p = 3 holds the quadratic bulge exactly), on grids of their
/// own kind, with normals pointing out of the mesh.
#[test]
fn sampled_prism_faces_lie_on_the_surface_with_outward_normals() {
    for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
        let mesh = prism_box(3, spacing, [2, 1, 1], |x| bulge(scale(0.5, x)));
        let corners = Corners::of(&mesh);
        let patches = surface_patches(&mesh, &corners, &[true; 4], 9);
        assert_eq!(patches.len(), 14);
        for f in &patches {
            let n = match f.grid {
                Grid::Tri(9) => 55,
                Grid::Quad(9) => 100,
                g => panic!("{g:?}"),
            };
            assert_eq!((f.points.len(), f.normals.len()), (n, n));
            for &[x, y, z] in &f.points {
                let on = [x.abs(), z.abs(), (z - 0.5).abs(), y.abs(), (y - 0.5).abs()]
                    .into_iter()
                    .fold(f64::INFINITY, f64::min)
                    .min((x - (1.0 + 1.2 * y * (1.0 - y))).abs());
                assert!(on < 1e-12, "{:?} is not on the surface", [x, y, z]);
            }
            // The normals of the flat top (triangles) and front (quads)
            // are theirs, pointing out.
            let mean = scale(
                1.0 / n as f64,
                f.points.iter().fold([0.0; 3], |s, &x| add(s, x)),
            );
            for (side, normal, grid) in [
                (mean[2] - 0.5, [0.0, 0.0, 1.0], Grid::Tri(9)),
                (mean[1], [0.0, -1.0, 0.0], Grid::Quad(9)),
            ] {
                if side.abs() < 1e-12 {
                    assert_eq!(f.grid, grid);
                    assert!(
                        f.normals
                            .iter()
                            .all(|&n| sub(n, normal).iter().all(|d| d.abs() < 1e-12)),
                        "{spacing:?}: {:?}",
                        f.normals
                    );
                }
            }
        }
    }
}

#[test]
fn prisms_of_every_order_and_spacing_are_drawn() {
    for p in 1..=4 {
        for spacing in [Spacing::Equispaced, Spacing::GaussLobatto] {
            let mesh = prism_box(p, spacing, [2, 1, 1], crate::mesh::curved::tests::bend3);
            let values: Vec<f64> = (0..4).map(|c| 0.9 + 0.05 * c as f64).collect();
            let (img, plan) = render_decoded(&mesh, &values, &opts(Camera::default()));
            let m = if p == 1 { 1 } else { SUBQUADS_PER_ORDER * p };
            assert_eq!(plan.patches.len(), 14, "p = {p}");
            for f in &plan.patches {
                let n = if f.grid == Grid::Tri(m) {
                    (m + 1) * (m + 2) / 2
                } else {
                    (m + 1) * (m + 1)
                };
                assert!(
                    matches!(f.grid, Grid::Tri(k) | Grid::Quad(k) if k == m) && f.points.len() == n
                );
            }
            let area = drawn_area(&img, &plan);
            assert!(area > 10_000, "p = {p} {spacing:?}: {area} pixels drawn");
        }
    }
}

/// Two hexes, a pyramid on the first one's top and a tetrahedron on each
/// of its triangles (the mixed solid of `refine`'s conformity test), at
/// order `p`: the linear mesh, or the subdivision's elements.
fn hex_pyramid_tets(p: usize) -> CurvedMesh<3> {
    use crate::mesh::cell_faces;
    let nodes = vec![
        [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0],
        [2.0, 0.0, 0.0], [2.0, 1.0, 0.0], [2.0, 0.0, 1.0], [2.0, 1.0, 1.0], [0.5, 0.5, 1.6],
        [0.5, -0.4, 1.3], [1.4, 0.5, 1.3], [0.5, 1.4, 1.3], [-0.4, 0.5, 1.3],
    ];
    let mut cells = vec![(Shape::Hexahedron, vec![0, 1, 2, 3, 4, 5, 6, 7]), (Shape::Hexahedron, vec![1, 8, 9, 2, 5, 10, 11, 6]), (Shape::Pyramid, vec![4, 5, 6, 7, 12])];
    cells.extend([(4, 5, 13), (5, 6, 14), (6, 7, 15), (7, 4, 16)].map(|(a, b, out)| (Shape::Tetrahedron, vec![a, b, 12, out])));
    let mut count: HashMap<Vec<usize>, (usize, Vec<usize>)> = HashMap::new();
    for f in cells.iter().flat_map(|(shape, v)| cell_faces(*shape, v)) {
        let mut k = f.clone();
        k.sort_unstable();
        count.entry(k).or_insert((0, f)).0 += 1;
    }
    let faces: Vec<(Vec<usize>, usize)> = count.into_values().filter(|c| c.0 == 1).map(|c| (c.1, 0)).collect();
    let coarse = CurvedMesh::linear(nodes, cells, faces, vec!["all".into()]);
    if p == 1 {
        return coarse;
    }
    let (s, _) = crate::refine::subdivide_mixed_solid(&coarse, p, Spacing::Equispaced).unwrap();
    CurvedMesh { shape: Shape::Hexahedron, p, spacing: Spacing::Equispaced, nodes: s.fine.nodes.clone(), cells: s.elements.clone(), boundary: crate::mesh::Facets::new(), part_names: vec![] }
}

/// A mesh of hexes, a pyramid and tets is drawn cell by cell: its surface
/// is the 21 outer faces (the faces between kinds found inner), and with
/// the tets clipped away the pyramid shows its four triangles, sampled on
/// triangle grids, while its base stays hidden on the hex.
#[test]
fn hexes_pyramids_and_tets_are_drawn_together() {
    for p in [1, 2] {
        let mesh = hex_pyramid_tets(p);
        assert_eq!(mesh.shapes(), vec![Shape::Tetrahedron, Shape::Hexahedron, Shape::Pyramid]);
        let values: Vec<f64> = (0..mesh.cells.len()).map(|c| c as f64).collect();
        let plan = plan_of(&mesh, &values, &opts(Camera::default()));
        // the hexes' 9 outer faces (of 12: one shared, one under the
        // pyramid), none of the pyramid's, the tets' 3 each
        assert_eq!(plan.patches.len(), 9 + 4 * 3, "p = {p}");
        let kinds = |plan: &HexPlan, c: usize| plan.patches.iter().filter(|f| f.cell == c).count();
        assert_eq!((kinds(&plan, 0), kinds(&plan, 1), kinds(&plan, 2), kinds(&plan, 3)), (4, 5, 0, 3), "p = {p}");
        let clipped = RenderOptions3 { clip: Some(ClipPlane { point: [0.0, 0.0, 1.15], normal: [0.0, 0.0, 1.0] }), ..opts(Camera::default()) };
        let plan = plan_of(&mesh, &values, &clipped);
        let pyramid: Vec<&Patch> = plan.patches.iter().filter(|f| f.cell == 2).collect();
        assert_eq!(pyramid.len(), 4, "p = {p}: the pyramid's triangles");
        assert!(pyramid.iter().all(|f| f.grid.piece_corners() == 3));
        decoded(&render_hexes(&mesh, &values, &clipped).unwrap());
    }
}
