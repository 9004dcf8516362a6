//! Adaptive prescribed Jacobians: interfaces, pictures and combinations,
//! and the seed's adaptive figures at test resolution.

use deformesh::app::case::{AnySetup, Case, Setup};
use deformesh::deform::{Deformation, Deformation3};
use deformesh::jacobian::{ImageField, SmallWhere};
use deformesh::mesh::{HexMesh, QuadMesh};
use deformesh::quality::{hex_mesh_quality, jf_stats, mesh_quality, JfStats};
use std::path::Path;

fn case_path(file: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("cases").join(file)
}

fn setup2(text: &str, dir: &Path) -> Setup<QuadMesh, 2> {
    Case::parse(text, "test.toml").unwrap().setup("test.toml", dir).unwrap()
}

fn case2(file: &str, edit: impl Fn(&mut Case)) -> Setup<QuadMesh, 2> {
    let path = case_path(file);
    let mut case = Case::read(&path).unwrap();
    edit(&mut case);
    case.setup(file, path.parent().unwrap()).unwrap()
}

fn case3(file: &str, edit: impl Fn(&mut Case)) -> Setup<HexMesh, 3> {
    let path = case_path(file);
    let mut case = Case::read(&path).unwrap();
    edit(&mut case);
    match case.setup_any(file, path.parent().unwrap()).unwrap() {
        AnySetup::Hex(s) => s,
        _ => panic!("{file} is not of hexahedra"),
    }
}

fn run2(s: Setup<QuadMesh, 2>) -> Deformation {
    let mut d = Deformation::new(s.mesh, s.parts, s.field, s.options).unwrap();
    d.run(&[], |_| {}, |_| {}).unwrap();
    assert!(mesh_quality(&d.mesh).invalid_cells.is_empty(), "invalid cells");
    d
}

fn jf2(d: &Deformation) -> JfStats {
    let areas: Vec<f64> = d.mesh.cells.iter().map(|c| deformesh::mesh::quad_area(&c.map(|n| d.start[n]))).collect();
    jf_stats(&d.jf_now().unwrap(), &areas)
}

fn centroid(p: &[[f64; 2]; 4]) -> [f64; 2] {
    [p.iter().map(|q| q[0]).sum::<f64>() / 4.0, p.iter().map(|q| q[1]).sum::<f64>() / 4.0]
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    assert!(n > 0, "mean of nothing");
    s / n as f64
}

const CIRCLE: &str = r#"
[mesh]
lower = [0.0, 0.0]
upper = [1.0, 1.0]
cells = [40, 40]
[jacobian]
type = "interface"
shape = { type = "circle", centre = [0.5, 0.5], radius = 0.3 }
width = 0.05
jacobian_ratio = 0.2
[time]
steps = 40
"#;

/// Mean area of the cells the circle of radius 0.3 crosses, and of the
/// cells more than `far` from it.
fn on_and_far(d: &Deformation, far: f64) -> (f64, f64) {
    let r = |p: [f64; 2]| (p[0] - 0.5).hypot(p[1] - 0.5);
    let on = mean((0..d.mesh.num_cells()).filter_map(|c| {
        let p = d.mesh.cell_coords(c);
        let crosses = p.iter().any(|q| r(*q) < 0.3) && p.iter().any(|q| r(*q) > 0.3);
        crosses.then(|| d.mesh.cell_area(c))
    }));
    let off = mean((0..d.mesh.num_cells()).filter_map(|c| ((r(centroid(&d.mesh.cell_coords(c))) - 0.3).abs() > far).then(|| d.mesh.cell_area(c))));
    (on, off)
}

#[test]
fn circle_interface_crowds_cells_and_keeps_j_near_f() {
    // all four sides are slip walls (no [[boundary]]): the square stays
    let d = run2(setup2(CIRCLE, Path::new(".")));
    let (on, far) = on_and_far(&d, 0.2);
    assert!(far / on >= 4.0, "cells on the circle only {:.2}× smaller than far ones", far / on);
    let jf = jf2(&d);
    assert!(jf.min >= 0.9 && jf.max <= 1.1, "J/f in [{}, {}]", jf.min, jf.max);
    // measured: [0.975, 1.049], areas 4.9× apart
    assert!(jf.min > 0.97 && jf.max < 1.05, "J/f in [{}, {}] (was [0.975, 1.049])", jf.min, jf.max);
    assert!(jf.equidistribution_cov < 0.02, "CoV {}", jf.equidistribution_cov);
    // the square is still the unit square
    assert!((d.mesh.area() - 1.0).abs() < 1e-12);
}

#[test]
fn inverse_time_path_is_less_accurate_here_which_is_why_linear_is_default() {
    let inverse = run2(setup2(&CIRCLE.replace("jacobian_ratio = 0.2", "jacobian_ratio = 0.2\npath = \"inverse\""), Path::new(".")));
    let linear = run2(setup2(&CIRCLE.replace("jacobian_ratio = 0.2", "jacobian_ratio = 0.2\npath = \"linear\""), Path::new(".")));
    let default = run2(setup2(CIRCLE, Path::new(".")));
    let (ji, jl, jd) = (jf2(&inverse), jf2(&linear), jf2(&default));
    assert!((jd.min - jl.min).abs() < 1e-10 && (ji.min - jl.min).abs() > 1e-3, "the default path is the linear one");
    assert!(ji.l2_error > 1.2 * jl.l2_error, "inverse {} vs linear {}", ji.l2_error, jl.l2_error);
    // both reach the target: the same size contrast within 10 %
    let (ci, cl) = (on_and_far(&inverse, 0.2), on_and_far(&linear, 0.2));
    assert!(((ci.1 / ci.0) / (cl.1 / cl.0) - 1.0).abs() < 0.1);
}

#[test]
fn level_set_interface_matches_the_shape_interface() {
    let ls = CIRCLE.replace(
        "shape = { type = \"circle\", centre = [0.5, 0.5], radius = 0.3 }",
        "level_set = \"(x - 0.5)^2 + (y - 0.5)^2 - 0.09\"",
    );
    let (a, b) = (run2(setup2(&ls, Path::new("."))), run2(setup2(CIRCLE, Path::new("."))));
    // the Newton projection finds the same distances: the same mesh
    let worst = a.mesh.nodes.iter().zip(&b.mesh.nodes).map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1])).fold(0.0, f64::max);
    assert!(worst < 1e-8, "level-set and circle meshes differ by {worst:e}");
}

#[test]
fn basketball_80_is_valid_with_the_smallest_cells_on_the_seams() {
    let d = run2(case2("basketball.toml", |_| {}));
    assert_eq!(d.mesh.num_cells(), 6400);
    let jf = jf2(&d);
    // measured [0.958, 1.088]
    assert!(jf.min > 0.94 && jf.max < 1.1, "J/f in [{}, {}]", jf.min, jf.max);
    // seams are where the unsmoothed picture is dark (about 0.1 of white),
    // the ball's body is grey (0.55), the background white
    let png = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/basketball.png");
    let pic = ImageField::open(&png, [0.0, 0.0], [1.0, 1.0], 0.1, SmallWhere::Dark, 0).unwrap();
    let mut cells: Vec<(f64, f64)> = (0..d.mesh.num_cells())
        .map(|c| {
            let x = centroid(&d.mesh.cell_coords(c));
            (d.mesh.cell_area(c), pic.luma([x[0], x[1], 0.0]))
        })
        .collect();
    cells.sort_by(|a, b| a.0.total_cmp(&b.0));
    // the 100 smallest cells all sit on or right beside a seam: darker
    // than the body anywhere near them
    let darkest_near = |x: [f64; 2]| {
        let mut m = 1.0f64;
        for i in -2..=2 {
            for j in -2..=2 {
                m = m.min(pic.luma([x[0] + i as f64 * 0.004, x[1] + j as f64 * 0.004, 0.0]));
            }
        }
        m
    };
    let mut smallest: Vec<usize> = (0..d.mesh.num_cells()).collect();
    smallest.sort_by(|&a, &b| d.mesh.cell_area(a).total_cmp(&d.mesh.cell_area(b)));
    for &c in &smallest[..100] {
        let x = centroid(&d.mesh.cell_coords(c));
        assert!(darkest_near(x) < 0.3, "small cell {c} at {x:?} is not on a seam");
    }
    // and by class: seams < body < background
    let class_mean = |lo: f64, hi: f64| mean(cells.iter().filter(|c| c.1 >= lo && c.1 < hi).map(|c| c.0));
    let (seam, body, background) = (class_mean(0.0, 0.3), class_mean(0.5, 0.6), class_mean(0.95, 1.01));
    assert!(seam < 0.75 * body && body < 0.75 * background, "seam {seam:e}, body {body:e}, background {background:e}");
}

#[test]
fn ellipse_interface_is_valid_on_the_ellipse_with_small_cells_on_the_interface() {
    let d = run2(case2("ellipse_interface.toml", |c| c.mesh.cells = vec![48, 48]));
    for (i, dist) in d.boundary_distances() {
        assert!(dist < 1e-10, "node {i} is {dist:e} off the outer ellipse");
    }
    let jf = jf2(&d);
    let ratios = d.jf_now().unwrap();
    // J/f strays along the outer boundary near the four corners, where two
    // sides of the square land on one smooth curve and the corner cells
    // open to a straight angle; two cells in from the boundary every cell
    // follows f closely
    let inner = |c: usize| (2..46).contains(&(c % 48)) && (2..46).contains(&(c / 48));
    let rest: Vec<f64> = ratios.iter().enumerate().filter(|(c, _)| inner(*c)).map(|(_, r)| *r).collect();
    let rest = jf_stats(&rest, &vec![1.0; rest.len()]);
    assert!(jf.min > 0.6 && jf.max < 1.7, "J/f in [{}, {}]", jf.min, jf.max);
    eprintln!("J/f: all cells {jf:?}, inner cells {rest:?}");
    assert!(rest.min > 0.85 && rest.max < 1.2, "J/f two cells from the boundary in [{}, {}]", rest.min, rest.max);
    // cells crossing the tilted interface ellipse are the small ones
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let level = |p: [f64; 2]| {
        let (x, y) = (p[0] - 0.1, p[1]);
        let (u, v) = (c * x + s * y, -s * x + c * y);
        (u / 0.8).powi(2) + (v / 0.45).powi(2) - 1.0
    };
    let on = mean((0..d.mesh.num_cells()).filter_map(|k| {
        let p = d.mesh.cell_coords(k);
        (p.iter().any(|q| level(*q) < 0.0) && p.iter().any(|q| level(*q) > 0.0)).then(|| d.mesh.cell_area(k))
    }));
    let all = d.mesh.area() / d.mesh.num_cells() as f64;
    assert!(on < 0.5 * all, "interface cells {on:e} vs mean {all:e}");
}

#[test]
fn water_wave_is_valid_on_the_wave_with_both_ellipses_emphasised() {
    let d = run2(case2("water_wave.toml", |c| c.mesh.cells = vec![60, 30]));
    for (i, dist) in d.boundary_distances() {
        assert!(dist < 1e-10, "node {i} is {dist:e} off the wave");
    }
    let jf = jf2(&d);
    assert!(jf.min > 0.85 && jf.max < 1.15, "J/f in [{}, {}]", jf.min, jf.max);
    // each ellipse: cells around it smaller than cells between them
    let small_near = |cx: f64| {
        mean((0..d.mesh.num_cells()).filter_map(|k| {
            let x = centroid(&d.mesh.cell_coords(k));
            ((x[0] - cx).abs() < 0.35 && (x[1] - 0.45).abs() < 0.3).then(|| d.mesh.cell_area(k))
        }))
    };
    let background = mean((0..d.mesh.num_cells()).filter_map(|k| {
        let x = centroid(&d.mesh.cell_coords(k));
        (x[1] < 0.1).then(|| d.mesh.cell_area(k))
    }));
    for cx in [0.6, 1.4] {
        assert!(small_near(cx) < 0.8 * background, "ellipse at x = {cx}: {:e} vs {background:e}", small_near(cx));
    }
}

#[test]
fn cube_on_ball_with_a_ball_interface_is_valid_and_near_f() {
    let s = case3("cube_on_ball.toml", |c| c.mesh.cells = vec![10, 10, 10]);
    let mut d = Deformation3::new(s.mesh, s.parts, s.field, s.options).unwrap();
    d.run(&[], |_| {}, |_| {}).unwrap();
    assert!(hex_mesh_quality(&d.mesh).invalid_cells.is_empty());
    let ratios = d.jf_now().unwrap();
    let jf = jf_stats(&ratios, &vec![1.0; ratios.len()]);
    assert!(jf.min > 0.85 && jf.max < 1.15, "J/f in [{}, {}]", jf.min, jf.max);
    for (i, dist) in d.boundary_distances() {
        assert!(dist < 1e-10, "node {i} is {dist:e} off the ball");
    }
    // cells the interface sphere (centre (0, 0, 1.1), radius 0.45) crosses
    // are smaller than those far below it
    let r = |p: [f64; 3]| p[0].hypot(p[1]).hypot(p[2] - 1.1);
    let vol = |k: usize| deformesh::quality::cell_size(&d.mesh.cell_coords(k));
    let on = mean((0..d.mesh.num_cells()).filter_map(|k| {
        let p = d.mesh.cell_coords(k);
        (p.iter().any(|q| r(*q) < 0.45) && p.iter().any(|q| r(*q) > 0.45)).then(|| vol(k))
    }));
    let far = mean((0..d.mesh.num_cells()).filter_map(|k| d.mesh.cell_coords(k).iter().all(|q| r(*q) > 0.9).then(|| vol(k))));
    assert!(far / on > 2.5, "sphere cells only {:.2}× smaller", far / on);
}
