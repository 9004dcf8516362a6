use super::*;
use crate::numeric::*;
use proptest::prelude::*;
use super::super::test_support::{closest_against_brute, runner};

fn build(toml_text: &str) -> Shape {
    spec(toml_text).build().unwrap()
}

fn spec(toml_text: &str) -> ShapeSpec {
    super::super::test_support::spec(toml_text)
}

/// Dense points along each test shape, for brute-force comparisons.
fn dense(shape: &Shape, count: usize) -> Vec<[f64; 2]> {
    let u = |k: usize| k as f64 / count as f64;
    match &shape.kind {
        Kind::Line(l) => (0..=count)
            .map(|k| add(l.from, scale(200.0 * u(k) - 100.0, l.dir)))
            .collect(),
        Kind::Circle(c) => (0..count)
            .map(|k| {
                add(
                    c.centre,
                    scale(c.radius, [(TAU * u(k)).cos(), (TAU * u(k)).sin()]),
                )
            })
            .collect(),
        Kind::Arc(a) => (0..=count)
            .map(|k| {
                let t = a.start + a.sweep * u(k);
                add(a.circle.centre, scale(a.circle.radius, [t.cos(), t.sin()]))
            })
            .collect(),
        Kind::Ellipse(e) => (0..count)
            .map(|k| e.to_world([e.a * (TAU * u(k)).cos(), e.b * (TAU * u(k)).sin()]))
            .collect(),
        Kind::Superellipse(s) => (0..count).map(|k| s.point(TAU * u(k))).collect(),
        Kind::Spline(s) => {
            let end = s.period();
            let last = if s.closed { count } else { count + 1 };
            (0..last).map(|k| s.point(end * u(k))).collect()
        }
    }
}

fn max_spacing(pts: &[[f64; 2]]) -> f64 {
    pts.windows(2)
        .map(|w| norm(sub(w[1], w[0])))
        .fold(0.0, f64::max)
}

/// The test shapes, with a length scale each.
fn shapes() -> Vec<(&'static str, Shape, f64)> {
    let specs = [
        (
            "line",
            r#"shape = { type = "line", from = [0.5, -1.0], to = [2.0, 1.0] }"#,
            2.0,
        ),
        (
            "circle",
            r#"shape = { type = "circle", centre = [0.3, -0.2], radius = 1.25 }"#,
            1.25,
        ),
        (
            "arc",
            r#"shape = { type = "arc", centre = [0.0, 0.0], radius = 1.0, start_angle = 300, end_angle = 100 }"#,
            1.0,
        ),
        (
            "ellipse",
            r#"shape = { type = "ellipse", centre = [0.1, 0.2], semi_axes = [2.0, 0.7], angle = 30 }"#,
            2.0,
        ),
        (
            "tall ellipse",
            r#"shape = { type = "ellipse", centre = [0.0, 0.0], semi_axes = [0.5, 1.5] }"#,
            1.5,
        ),
        (
            "superellipse 4",
            r#"shape = { type = "superellipse", centre = [0.2, 0.0], semi_axes = [1.5, 1.0], exponent = 4 }"#,
            1.5,
        ),
        (
            "superellipse 1.5",
            r#"shape = { type = "superellipse", centre = [0.0, 0.0], semi_axes = [1.0, 2.0], exponent = 1.5 }"#,
            2.0,
        ),
        (
            "flat ellipse",
            r#"shape = { type = "ellipse", centre = [0.0, 0.0], semi_axes = [5.0, 0.05], angle = -60 }"#,
            5.0,
        ),
        (
            "superellipse 12",
            r#"shape = { type = "superellipse", centre = [0.0, 0.0], semi_axes = [2.0, 1.0], exponent = 12 }"#,
            2.0,
        ),
        (
            "superellipse 0.7",
            r#"shape = { type = "superellipse", centre = [0.0, 0.0], semi_axes = [1.0, 1.0], exponent = 0.7 }"#,
            1.0,
        ),
        (
            "closed spline",
            r#"shape = { type = "spline", closed = true, points = [[1.0, 0.0], [0.6, 0.9], [-0.4, 0.5], [-1.0, 0.8], [-1.2, -0.3], [0.0, -1.0], [0.8, -0.6]] }"#,
            1.0,
        ),
        (
            "open spline",
            r#"shape = { type = "spline", points = [[0.0, 0.0], [1.0, 0.5], [2.0, -0.3], [2.5, 1.0], [1.5, 1.5]] }"#,
            1.5,
        ),
    ];
    specs
        .into_iter()
        .map(|(name, text, size)| (name, build(text), size))
        .collect()
}


// ---- specs and validation ------------------------------------------

#[test]
fn toml_circle_deserialises() {
    let s = spec(r#"shape = { type = "circle", centre = [0.0, 0.0], radius = 1.25 }"#);
    assert_eq!(
        s,
        ShapeSpec::Circle {
            centre: [0.0, 0.0],
            radius: 1.25
        }
    );
    // Integers are accepted for floats.
    let s = spec(r#"shape = { type = "circle", centre = [1, 2], radius = 3 }"#);
    assert_eq!(
        s,
        ShapeSpec::Circle {
            centre: [1.0, 2.0],
            radius: 3.0
        }
    );
}

#[test]
fn toml_every_type_deserialises() {
    let text = r#"
        [[shape]]
        type = "line"
        from = [0, 0]
        to = [1, 0]
        [[shape]]
        type = "arc"
        centre = [0, 0]
        radius = 1
        start_angle = 0
        end_angle = 90
        [[shape]]
        type = "ellipse"
        centre = [0, 0]
        semi_axes = [2, 1]
        [[shape]]
        type = "superellipse"
        centre = [0, 0]
        semi_axes = [2, 1]
        exponent = 4
        [[shape]]
        type = "spline"
        points = [[0, 0], [1, 1], [2, 0]]
        closed = true
    "#;
    #[derive(Deserialize)]
    struct Many {
        shape: Vec<ShapeSpec>,
    }
    let many: Many = toml::from_str(text).unwrap();
    let names: Vec<_> = many.shape.iter().map(|s| s.type_name()).collect();
    assert_eq!(names, ["line", "arc", "ellipse", "superellipse", "spline"]);
    assert!(matches!(many.shape[2], ShapeSpec::Ellipse { angle, .. } if angle == 0.0));
    assert!(many.shape.iter().all(|s| s.build().is_ok()));
}

#[test]
fn toml_unknown_field_is_rejected_by_name() {
    #[derive(Debug, Deserialize)]
    #[allow(dead_code)]
    struct Case {
        shape: ShapeSpec,
    }
    let err = toml::from_str::<Case>(
        r#"shape = { type = "circle", centre = [0, 0], radius = 1, radious = 2 }"#,
    )
    .unwrap_err();
    assert!(err.to_string().contains("radious"), "{err}");
    let err = toml::from_str::<Case>(
        r#"shape = { type = "ellipse", centre = [0, 0], semi_axes = [1, 1], angel = 2 }"#,
    )
    .unwrap_err();
    assert!(err.to_string().contains("angel"), "{err}");
    let err =
        toml::from_str::<Case>(r#"shape = { type = "hexagon", centre = [0, 0] }"#).unwrap_err();
    assert!(err.to_string().contains("hexagon"), "{err}");
    let err =
        toml::from_str::<Case>(r#"shape = { type = "circle", centre = [0, 0] }"#).unwrap_err();
    assert!(err.to_string().contains("radius"), "{err}");
}

#[test]
fn invalid_specs_name_the_parameter() {
    let nan = f64::NAN;
    let cases: Vec<(ShapeSpec, &str, &str)> = vec![
        (
            ShapeSpec::Line {
                from: [0.0, 0.0],
                to: [0.0, 0.0],
            },
            "to",
            "differ",
        ),
        (
            ShapeSpec::Line {
                from: [nan, 0.0],
                to: [1.0, 0.0],
            },
            "from",
            "finite",
        ),
        (
            ShapeSpec::Circle {
                centre: [0.0, 0.0],
                radius: 0.0,
            },
            "radius",
            "> 0",
        ),
        (
            ShapeSpec::Circle {
                centre: [0.0, f64::INFINITY],
                radius: 1.0,
            },
            "centre",
            "finite",
        ),
        (
            ShapeSpec::Arc {
                centre: [0.0, 0.0],
                radius: -1.0,
                start_angle: 0.0,
                end_angle: 90.0,
            },
            "radius",
            "> 0",
        ),
        (
            ShapeSpec::Arc {
                centre: [0.0, 0.0],
                radius: 1.0,
                start_angle: 10.0,
                end_angle: 10.0,
            },
            "end_angle",
            "differ",
        ),
        (
            ShapeSpec::Arc {
                centre: [0.0, 0.0],
                radius: 1.0,
                start_angle: nan,
                end_angle: 10.0,
            },
            "start_angle",
            "finite",
        ),
        (
            ShapeSpec::Ellipse {
                centre: [0.0, 0.0],
                semi_axes: [1.0, -2.0],
                angle: 0.0,
            },
            "semi_axes[1]",
            "> 0",
        ),
        (
            ShapeSpec::Ellipse {
                centre: [0.0, 0.0],
                semi_axes: [1.0, 2.0],
                angle: nan,
            },
            "angle",
            "finite",
        ),
        (
            ShapeSpec::Superellipse {
                centre: [0.0, 0.0],
                semi_axes: [0.0, 2.0],
                exponent: 2.0,
            },
            "semi_axes[0]",
            "> 0",
        ),
        (
            ShapeSpec::Superellipse {
                centre: [0.0, 0.0],
                semi_axes: [1.0, 2.0],
                exponent: -1.0,
            },
            "exponent",
            "> 0",
        ),
        (
            ShapeSpec::Spline {
                points: vec![[0.0, 0.0], [1.0, 0.0]],
                closed: true,
            },
            "points",
            "at least 3",
        ),
        (
            ShapeSpec::Spline {
                points: vec![[0.0, 0.0]],
                closed: false,
            },
            "points",
            "at least 2",
        ),
        (
            ShapeSpec::Spline {
                points: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]],
                closed: false,
            },
            "points[2]",
            "repeats points[1]",
        ),
        (
            ShapeSpec::Spline {
                points: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 0.0]],
                closed: true,
            },
            "points[3]",
            "repeats points[0]",
        ),
        (
            ShapeSpec::Spline {
                points: vec![[0.0, 0.0], [1.0, nan]],
                closed: false,
            },
            "points[1]",
            "finite",
        ),
    ];
    for (spec, parameter, reason) in cases {
        let err = spec.build().expect_err(&format!("{spec:?}"));
        assert_eq!(err.parameter, parameter, "{err}");
        assert_eq!(err.shape, spec.type_name());
        let msg = err.to_string();
        assert!(
            msg.contains(&format!("`{parameter}`")) && msg.contains(reason),
            "{msg}"
        );
    }
}

#[test]
fn shape_is_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<Shape>();
}

// ---- closest points ------------------------------------------------

/// The closest point against dense samples, and first-order optimal.
fn check_against_brute(name: &str, shape: &Shape, pts: &[[f64; 2]], spacing: f64, size: f64, p: [f64; 2]) {
    let q = closest_against_brute(name, shape, pts, spacing, 1e-12 * size, p);
    // First-order optimality to full precision: p − q is normal
    // (except at the end points of open curves).
    let n = shape.normal(p);
    let at_end = !shape.is_closed()
        && (norm(sub(q, pts[0])) < 1e-9 || norm(sub(q, pts[pts.len() - 1])) < 1e-9);
    let at_cusp = name.contains("0.7") && (q[0].abs() < 1e-9 || q[1].abs() < 1e-9);
    assert!(
        at_end || at_cusp || cross2(sub(p, q), n).abs() <= 1e-11 * size,
        "{name} {p:?}: p-q not normal"
    );
}

#[test]
fn closest_points_match_brute_force() {
    for (name, shape, size) in shapes() {
        let pts = dense(&shape, 100_000);
        let spacing = max_spacing(&pts);
        let far = -3.0 * size..3.0 * size;
        runner(150)
            .run(&(far.clone(), far), |(x, y)| {
                check_against_brute(name, &shape, &pts, spacing, size, [x, y]);
                Ok(())
            })
            .unwrap();
        // Near the curve, where wrong branches are most tempting.
        // (The sampled line is finite; stay away from its artificial ends.)
        let interior = if name == "line" {
            1000..pts.len() - 1000
        } else {
            0..pts.len()
        };
        runner(150)
            .run(
                &(interior.clone(), -0.2 * size..0.2 * size, 0.0..TAU),
                |(k, r, a)| {
                    let p = add(pts[k], [r * a.cos(), r * a.sin()]);
                    check_against_brute(name, &shape, &pts, spacing, size, p);
                    Ok(())
                },
            )
            .unwrap();
    }
}

#[test]
fn curve_points_are_fixed_points() {
    for (name, shape, size) in shapes() {
        for q in dense(&shape, 997) {
            let c = shape.closest_point(q);
            assert!(norm(sub(c, q)) <= 1e-13 * size, "{name} {q:?} -> {c:?}");
        }
    }
}

#[test]
fn closest_points_lie_on_the_curve() {
    let circle = build(r#"shape = { type = "circle", centre = [0.3, -0.2], radius = 1.25 }"#);
    let ellipse =
        build(r#"shape = { type = "ellipse", centre = [0.0, 0.0], semi_axes = [2.0, 0.7] }"#);
    let sup = build(
        r#"shape = { type = "superellipse", centre = [0.0, 0.0], semi_axes = [1.5, 1.0], exponent = 4 }"#,
    );
    runner(300)
        .run(&(-5.0..5.0, -5.0..5.0), |(x, y)| {
            let q = circle.closest_point([x, y]);
            prop_assert!((norm(sub(q, [0.3, -0.2])) - 1.25).abs() <= 4.0 * EPS);
            let q = ellipse.closest_point([x, y]);
            prop_assert!(
                ((q[0] / 2.0).powi(2) + (q[1] / 0.7).powi(2) - 1.0).abs() <= 8.0 * EPS
            );
            let q = sup.closest_point([x, y]);
            prop_assert!(((q[0] / 1.5).powi(4) + q[1].powi(4) - 1.0).abs() <= 16.0 * EPS);
            Ok(())
        })
        .unwrap();
}

#[test]
fn superellipse_of_exponent_two_is_the_ellipse() {
    let sup = build(
        r#"shape = { type = "superellipse", centre = [1.0, 2.0], semi_axes = [3.0, 1.0], exponent = 2 }"#,
    );
    let ell =
        build(r#"shape = { type = "ellipse", centre = [1.0, 2.0], semi_axes = [3.0, 1.0] }"#);
    runner(300)
        .run(&(-4.0..6.0, -2.0..6.0), |(x, y)| {
            let (a, b) = (sup.closest_point([x, y]), ell.closest_point([x, y]));
            // Points near the evolute have two nearly-equal candidates;
            // compare distances there, points elsewhere.
            prop_assert!((norm(sub(a, [x, y])) - norm(sub(b, [x, y]))).abs() <= 1e-12);
            let n = (sup.normal([x, y]), ell.normal([x, y]));
            if norm(sub(a, b)) < 1e-3 {
                prop_assert!(norm(sub(a, b)) <= 1e-12, "{a:?} vs {b:?}");
                prop_assert!(norm(sub(n.0, n.1)) <= 1e-12);
            }
            Ok(())
        })
        .unwrap();
}

#[test]
fn special_points() {
    let circle = build(r#"shape = { type = "circle", centre = [1.0, 1.0], radius = 2 }"#);
    assert_eq!(circle.distance([1.0, 1.0]), 2.0);
    let ellipse =
        build(r#"shape = { type = "ellipse", centre = [0.0, 0.0], semi_axes = [2.0, 1.0] }"#);
    assert!((ellipse.distance([0.0, 0.0]) - 1.0).abs() < 1e-15);
    assert!((ellipse.distance([5.0, 0.0]) - 3.0).abs() < 1e-15);
    assert!((ellipse.distance([0.0, -4.0]) - 3.0).abs() < 1e-15);
    // Inside on the major axis, the closest point is off the axis.
    let q = ellipse.closest_point([0.5, 0.0]);
    assert!(q[1].abs() > 0.5);
    let arc = build(
        r#"shape = { type = "arc", centre = [0.0, 0.0], radius = 1, start_angle = 0, end_angle = 90 }"#,
    );
    assert_eq!(arc.closest_point([0.0, 0.0]), [1.0, 0.0]);
    let q = arc.closest_point([0.1, -1.0]);
    assert!(norm(sub(q, [1.0, 0.0])) < 1e-15, "{q:?}"); // clamps to the nearer end
    let q = arc.closest_point([-1.0, 0.1]);
    assert!(norm(sub(q, [0.0, 1.0])) < 1e-15, "{q:?}");
    assert!(!arc.is_closed());
    let full = build(
        r#"shape = { type = "arc", centre = [0.0, 0.0], radius = 1, start_angle = 0, end_angle = 360 }"#,
    );
    assert!(full.is_closed());
    assert!((full.distance([-3.0, 0.0]) - 2.0).abs() < 1e-15);
}

// ---- normals -------------------------------------------------------

#[test]
fn normals_are_unit_orthogonal_and_outward() {
    for (name, shape, size) in shapes() {
        for q in dense(&shape, 397) {
            let n = shape.normal(q);
            assert!((norm(n) - 1.0).abs() < 1e-14, "{name}: |n| = {}", norm(n));
            // Tangent by finite differences of projections.
            // Small against the smallest radius of curvature (flat ellipse).
            let delta = 1e-9 * size;
            let t = rot_ccw(n);
            let chord = sub(
                shape.closest_point(add(q, scale(delta, t))),
                shape.closest_point(sub(q, scale(delta, t))),
            );
            if norm(chord) < delta {
                continue; // a corner or cusp: no tangent to compare with
            }
            assert!(
                dot(unit(chord), n).abs() < 1e-4,
                "{name} at {q:?}: n {n:?}, chord {chord:?}"
            );
            if shape.is_closed() && !name.contains("0.7") && name != "closed spline" {
                // Convex and centred near the origin: outward is away from it.
                assert!(
                    dot(n, sub(q, centre_of(&shape))) > 0.0,
                    "{name}: inward normal at {q:?}"
                );
            }
        }
    }
}

fn centre_of(shape: &Shape) -> [f64; 2] {
    match &shape.kind {
        Kind::Circle(c) => c.centre,
        Kind::Arc(a) => a.circle.centre,
        Kind::Ellipse(e) => e.centre,
        Kind::Superellipse(s) => s.centre,
        _ => [0.0, 0.0],
    }
}

#[test]
fn line_normal_points_right_of_from_to() {
    let line = build(r#"shape = { type = "line", from = [0.0, 0.0], to = [0.0, 2.0] }"#);
    assert_eq!(line.normal([5.0, 5.0]), [1.0, 0.0]);
    assert_eq!(line.normal([-5.0, 5.0]), [1.0, 0.0]);
    assert_eq!(line.closest_point([3.0, 7.0]), [0.0, 7.0]);
    assert!(!line.is_closed());
}

#[test]
fn closed_spline_normal_is_outward_whatever_the_point_order() {
    let ccw: Vec<[f64; 2]> = (0..12)
        .map(|k| [(TAU * k as f64 / 12.0).cos(), (TAU * k as f64 / 12.0).sin()])
        .collect();
    let cw: Vec<[f64; 2]> = ccw.iter().rev().copied().collect();
    for points in [ccw, cw] {
        let s = ShapeSpec::Spline {
            points,
            closed: true,
        }
        .build()
        .unwrap();
        for p in [[2.0, 0.0], [0.0, 0.3], [-0.5, -0.5]] {
            let q = s.closest_point(p);
            assert!(dot(s.normal(p), q) > 0.99);
        }
    }
}

// ---- ray hits ------------------------------------------------------

/// First crossing of the ray with the dense polyline, by brute force.
fn brute_ray(pts: &[[f64; 2]], closed: bool, o: [f64; 2], d: [f64; 2]) -> Option<f64> {
    let n = pts.len();
    let segs = if closed { n } else { n - 1 };
    let mut best: Option<f64> = None;
    for i in 0..segs {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        let e = sub(b, a);
        let den = cross2(d, e);
        if den == 0.0 {
            continue;
        }
        let s = cross2(sub(a, o), e) / den;
        let u = cross2(sub(a, o), d) / den;
        if (0.0..=1.0).contains(&u) && s > 1e-9 && best.is_none_or(|b| s < b) {
            best = Some(s);
        }
    }
    best
}

fn ray_curve_gap(pts: &[[f64; 2]], o: [f64; 2], d: [f64; 2]) -> f64 {
    let d = unit(d);
    pts.iter()
        .map(|q| {
            let v = sub(*q, o);
            if dot(v, d) < 0.0 {
                norm(v)
            } else {
                cross2(d, v).abs()
            }
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn ray_hits_lie_on_curve_and_ray_and_come_first() {
    for (name, shape, size) in shapes() {
        let pts = dense(&shape, 100_000);
        let spacing = max_spacing(&pts);
        let box_ = -2.0 * size..2.0 * size;
        runner(200)
            .run(
                &(box_.clone(), box_, 0.0..TAU, 0.1..3.0),
                |(x, y, a, len)| {
                    let (o, d) = ([x, y], [len * a.cos(), len * a.sin()]);
                    let hit = shape.ray_hit(o, d);
                    let brute = brute_ray(&pts, shape.is_closed(), o, d);
                    // The sampled line is finite: ignore hits beyond it.
                    let beyond = hit.is_some_and(|h| name == "line" && norm(h) > 90.0);
                    match (hit, brute) {
                        _ if beyond => {}
                        (Some(h), Some(bs)) => {
                            prop_assert!(
                                shape.distance(h) <= 1e-12 * size,
                                "{name}: hit {h:?} off the curve"
                            );
                            let v = sub(h, o);
                            prop_assert!(
                                cross2(v, unit(d)).abs() <= 1e-12 * size,
                                "{name}: hit {h:?} off the ray"
                            );
                            let s = dot(v, d) / dot(d, d);
                            prop_assert!(s > 0.0);
                            prop_assert!(
                                (s - bs).abs() * norm(d) <= 10.0 * spacing,
                                "{name}: s {s} vs brute {bs}"
                            );
                        }
                        (None, None) => {}
                        // Only a grazing ray may be judged differently.
                        _ => prop_assert!(
                            ray_curve_gap(&pts, o, d) < 1e-3 * size,
                            "{name}: {hit:?} vs {brute:?} from {o:?} along {d:?}"
                        ),
                    }
                    Ok(())
                },
            )
            .unwrap();
    }
}

#[test]
fn ray_special_cases() {
    let circle = build(r#"shape = { type = "circle", centre = [0.0, 0.0], radius = 2 }"#);
    assert_eq!(circle.ray_hit([0.0, 0.0], [0.0, 3.0]), Some([0.0, 2.0]));
    assert_eq!(circle.ray_hit([-5.0, 0.0], [1.0, 0.0]), Some([-2.0, 0.0]));
    assert_eq!(circle.ray_hit([5.0, 0.0], [1.0, 0.0]), None);
    assert_eq!(circle.ray_hit([0.0, 0.0], [0.0, 0.0]), None);
    // From a point on the circle: not the origin itself, the far side.
    assert_eq!(circle.ray_hit([2.0, 0.0], [-1.0, 0.0]), Some([-2.0, 0.0]));
    assert_eq!(circle.ray_hit([2.0, 0.0], [1.0, 0.0]), None);

    let line = build(r#"shape = { type = "line", from = [0.0, 1.0], to = [1.0, 1.0] }"#);
    assert_eq!(line.ray_hit([3.0, 0.0], [0.0, 1.0]), Some([3.0, 1.0]));
    assert_eq!(line.ray_hit([3.0, 0.0], [0.0, -1.0]), None);
    assert_eq!(line.ray_hit([3.0, 0.0], [1.0, 0.0]), None);

    // The near crossing is off the arc, so the far one is taken.
    let arc = build(
        r#"shape = { type = "arc", centre = [0.0, 0.0], radius = 1, start_angle = 90, end_angle = 270 }"#,
    );
    let h = arc.ray_hit([3.0, 0.0], [-1.0, 0.0]).unwrap();
    assert!(norm(sub(h, [-1.0, 0.0])) < 1e-15, "{h:?}");
    assert_eq!(arc.ray_hit([0.5, 0.0], [1.0, 0.0]), None);

    let ell = build(
        r#"shape = { type = "ellipse", centre = [1.0, 0.0], semi_axes = [2.0, 1.0], angle = 90 }"#,
    );
    let h = ell.ray_hit([1.0, 0.0], [0.0, 1.0]).unwrap();
    assert!(norm(sub(h, [1.0, 2.0])) < 1e-15, "{h:?}");
}

#[test]
fn superellipse_ray_from_centre_is_exact() {
    let s = build(
        r#"shape = { type = "superellipse", centre = [1.0, -1.0], semi_axes = [2.0, 1.0], exponent = 6 }"#,
    );
    for k in 0..360 {
        let a = (k as f64 + 0.5).to_radians();
        let d = [a.cos(), a.sin()];
        let h = s.ray_hit([1.0, -1.0], d).unwrap();
        let v = sub(h, [1.0, -1.0]);
        assert!(cross2(v, d).abs() < 1e-15 && dot(v, d) > 0.0);
        assert!(((v[0] / 2.0).abs().powi(6) + v[1].abs().powi(6) - 1.0).abs() < 1e-14);
    }
    let h = s.ray_hit([1.0, -1.0], [1.0, 0.0]).unwrap();
    assert!(norm(sub(h, [3.0, -1.0])) < 1e-15);
}

// ---- splines -------------------------------------------------------

fn spline_of(shape: &Shape) -> &Spline {
    match &shape.kind {
        Kind::Spline(s) => s,
        _ => panic!("not a spline"),
    }
}

#[test]
fn spline_interpolates_its_points() {
    for closed in [false, true] {
        let points = vec![[0.0, 0.0], [1.0, 0.5], [2.0, -0.3], [2.5, 1.0], [1.5, 1.5]];
        let shape = ShapeSpec::Spline {
            points: points.clone(),
            closed,
        }
        .build()
        .unwrap();
        let s = spline_of(&shape);
        for (k, p) in s.points.iter().enumerate() {
            assert!(
                norm(sub(s.point(s.knots[k]), *p)) <= 1e-15 * 4.0,
                "closed {closed}, point {k}"
            );
        }
        for p in &points {
            assert!(shape.distance(*p) <= 1e-15 * 4.0);
        }
    }
}

#[test]
fn open_spline_has_natural_ends() {
    let shape = ShapeSpec::Spline {
        points: vec![[0.0, 0.0], [1.0, 1.0], [2.0, 0.0], [3.0, 2.0]],
        closed: false,
    }
    .build()
    .unwrap();
    let s = spline_of(&shape);
    assert_eq!(s.eval(0.0)[2], [0.0, 0.0]);
    assert!(norm(s.eval(s.period())[2]) < 1e-13);
    // Two points make a straight segment.
    let seg = ShapeSpec::Spline {
        points: vec![[0.0, 0.0], [2.0, 2.0]],
        closed: false,
    }
    .build()
    .unwrap();
    assert!(norm(sub(seg.closest_point([2.0, 0.0]), [1.0, 1.0])) < 1e-15);
    assert!(norm(sub(seg.closest_point([5.0, 5.0]), [2.0, 2.0])) < 1e-15);
}

#[test]
fn periodic_spline_is_c2_at_the_seam() {
    let shape = build(
        r#"shape = { type = "spline", closed = true, points = [[1.0, 0.0], [0.6, 0.9], [-0.4, 0.5], [-1.0, 0.8], [-1.2, -0.3], [0.0, -1.0], [0.8, -0.6]] }"#,
    );
    let s = spline_of(&shape);
    let end = s.period();
    let last = s.knots.len() - 2;
    // One-sided limits from the two spans meeting at the seam.
    let left = s.eval_span(last, end);
    let right = s.eval_span(0, 0.0);
    for order in 0..3 {
        assert!(
            norm(sub(left[order], right[order])) < 1e-12,
            "order {order}: {:?} vs {:?}",
            left[order],
            right[order]
        );
    }
    // Finite differences straddling the seam agree with both (to within
    // their O(h) error from the jump in the third derivative).
    let h = 2e-5;
    let (pm, p0, pp) = (s.point(-h), s.point(0.0), s.point(h));
    let d1 = scale(0.5 / h, sub(pp, pm));
    let d2 = scale(1.0 / (h * h), add(sub(pp, scale(2.0, p0)), pm));
    assert!(norm(sub(d1, right[1])) < 1e-6, "{d1:?} vs {:?}", right[1]);
    assert!(norm(sub(d2, right[2])) < 1e-4, "{d2:?} vs {:?}", right[2]);
    // One-sided differences from each side match too.
    let one_sided = |sign: f64| scale(sign / h, sub(s.point(sign * h), p0));
    assert!(norm(sub(one_sided(1.0), one_sided(-1.0))) < 1e-3);
}

#[test]
fn spline_through_circle_points_stays_on_circle() {
    let points: Vec<[f64; 2]> = (0..64)
        .map(|k| [(TAU * k as f64 / 64.0).cos(), (TAU * k as f64 / 64.0).sin()])
        .collect();
    let shape = ShapeSpec::Spline {
        points,
        closed: true,
    }
    .build()
    .unwrap();
    let worst = dense(&shape, 20_000)
        .iter()
        .map(|p| (norm(*p) - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-5, "max deviation {worst}");
    // And queries agree with the circle it approximates.
    let circle = build(r#"shape = { type = "circle", centre = [0.0, 0.0], radius = 1 }"#);
    for p in [[3.0, 1.0], [0.2, -0.1], [-0.7, 0.7]] {
        assert!((shape.distance(p) - circle.distance(p)).abs() < 1e-5);
        let d = norm(sub(shape.normal(p), circle.normal(p)));
        assert!(d < 1e-4, "{d}");
    }
}
