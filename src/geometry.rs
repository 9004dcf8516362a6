//! 2D target shapes that boundary parts of a mesh are deformed onto.
//!
//! A [`ShapeSpec`] is what a case file says (deserialised with serde, tagged
//! by `type`); [`ShapeSpec::build`] validates it and precomputes what the
//! queries need, giving a [`Shape`].
//!
//! Conventions shared by every shape:
//! * Every curve has an orientation: lines run `from` → `to`, circles,
//!   arcs, ellipses and superellipses run counter-clockwise, open splines
//!   run from their first to their last point, and closed splines are
//!   reoriented counter-clockwise when built.
//! * [`Shape::normal`] is the unit tangent (along that orientation) rotated
//!   *clockwise* by 90°. For closed curves this is the outward normal; for
//!   a line it points to the right of `from` → `to`. This matches meshes
//!   whose boundary edges run with the domain on their left.
//! * Points returned by [`Shape::closest_point`] and [`Shape::ray_hit`] are
//!   the curve evaluated at some parameter, so they lie on the curve to
//!   machine precision.

use crate::numeric::{add, brent_root, dot, norm, ray_s_min, scale, sub, unit};
use serde::Deserialize;
use std::f64::consts::TAU;



/// Target polyline resolution used to bracket numeric queries: the sampled
/// polyline has chords no longer than its length divided by this.
const SAMPLES_PER_LENGTH: f64 = 512.0;

/// A shape as written in a case file, e.g.
/// `shape = { type = "circle", centre = [0.0, 0.0], radius = 1.25 }`.
///
/// Unknown fields are rejected. Angles are in degrees.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeSpec {
    /// The infinite straight line through `from` and `to` (oriented
    /// `from` → `to`; the normal points to its right).
    Line {
        /// A point on the line.
        from: [f64; 2],
        /// A second, different point on the line.
        to: [f64; 2],
    },
    /// A full circle.
    Circle {
        /// Centre point.
        centre: [f64; 2],
        /// Radius, > 0.
        radius: f64,
    },
    /// A circular arc, running counter-clockwise from `start_angle` to
    /// `end_angle` (degrees). The sweep is `end − start` reduced into
    /// (0°, 360°], so `start = 350, end = 10` is a 20° arc and
    /// `start = 0, end = 360` a full turn.
    Arc {
        /// Centre point.
        centre: [f64; 2],
        /// Radius, > 0.
        radius: f64,
        /// Angle of the first end, degrees from the +x axis.
        start_angle: f64,
        /// Angle of the second end, degrees from the +x axis.
        end_angle: f64,
    },
    /// An ellipse, `semi_axes[0]` along the direction `angle` degrees from
    /// the +x axis and `semi_axes[1]` perpendicular to it.
    Ellipse {
        /// Centre point.
        centre: [f64; 2],
        /// The two semi-axes, both > 0.
        semi_axes: [f64; 2],
        /// Rotation of the first axis, degrees counter-clockwise (default 0).
        #[serde(default)]
        angle: f64,
    },
    /// The superellipse `|x/a|^n + |y/b|^n = 1` (relative to `centre`):
    /// n = 2 is an ellipse, large n approaches a rectangle, n = 1 is a
    /// rhombus and n < 1 has cusps.
    Superellipse {
        /// Centre point.
        centre: [f64; 2],
        /// `[a, b]`, both > 0.
        semi_axes: [f64; 2],
        /// `n`, > 0.
        exponent: f64,
    },
    /// A cubic spline interpolating `points`, parametrised by chord length:
    /// periodic (C2 everywhere, closing back to the first point) when
    /// `closed`, with natural end conditions when open (default).
    Spline {
        /// Interpolated points; at least 3 if closed, 2 if open, no two
        /// consecutive ones equal. A closed spline must not repeat its
        /// first point at the end: it closes by itself.
        points: Vec<[f64; 2]>,
        /// Whether the curve closes back on itself.
        #[serde(default)]
        closed: bool,
    },
}

/// An invalid shape specification: which parameter of which shape, and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{shape}: parameter `{parameter}` {reason}")]
pub struct GeometryError {
    /// The shape type, e.g. `"circle"`.
    pub shape: &'static str,
    /// The offending parameter, e.g. `"radius"` or `"points[3]"`.
    pub parameter: String,
    /// What is wrong with it, e.g. `"must be > 0 (got -1)"`.
    pub reason: String,
}

impl ShapeSpec {
    /// The `type` name of this spec, as written in case files.
    pub fn type_name(&self) -> &'static str {
        match self {
            ShapeSpec::Line { .. } => "line",
            ShapeSpec::Circle { .. } => "circle",
            ShapeSpec::Arc { .. } => "arc",
            ShapeSpec::Ellipse { .. } => "ellipse",
            ShapeSpec::Superellipse { .. } => "superellipse",
            ShapeSpec::Spline { .. } => "spline",
        }
    }

    /// Validates the parameters and builds the queryable shape.
    pub fn build(&self) -> Result<Shape, GeometryError> {
        let v = Validator(self.type_name());
        let kind = match self {
            ShapeSpec::Line { from, to } => {
                v.finite_point("from", *from)?;
                v.finite_point("to", *to)?;
                if from == to {
                    return Err(v.error("to", "must differ from `from`"));
                }
                Kind::Line(Line::new(*from, *to))
            }
            ShapeSpec::Circle { centre, radius } => {
                v.finite_point("centre", *centre)?;
                v.positive("radius", *radius)?;
                Kind::Circle(Circle {
                    centre: *centre,
                    radius: *radius,
                })
            }
            ShapeSpec::Arc {
                centre,
                radius,
                start_angle,
                end_angle,
            } => {
                v.finite_point("centre", *centre)?;
                v.positive("radius", *radius)?;
                v.finite("start_angle", *start_angle)?;
                v.finite("end_angle", *end_angle)?;
                if start_angle == end_angle {
                    return Err(v.error("end_angle", "must differ from `start_angle`"));
                }
                Kind::Arc(Arc::new(
                    Circle {
                        centre: *centre,
                        radius: *radius,
                    },
                    *start_angle,
                    *end_angle,
                ))
            }
            ShapeSpec::Ellipse {
                centre,
                semi_axes,
                angle,
            } => {
                v.finite_point("centre", *centre)?;
                v.positive("semi_axes[0]", semi_axes[0])?;
                v.positive("semi_axes[1]", semi_axes[1])?;
                v.finite("angle", *angle)?;
                Kind::Ellipse(Ellipse::new(*centre, *semi_axes, *angle))
            }
            ShapeSpec::Superellipse {
                centre,
                semi_axes,
                exponent,
            } => {
                v.finite_point("centre", *centre)?;
                v.positive("semi_axes[0]", semi_axes[0])?;
                v.positive("semi_axes[1]", semi_axes[1])?;
                v.positive("exponent", *exponent)?;
                Kind::Superellipse(Superellipse::new(*centre, *semi_axes, *exponent))
            }
            ShapeSpec::Spline { points, closed } => {
                v.spline_points(points, *closed)?;
                Kind::Spline(Spline::new(points, *closed))
            }
        };
        Ok(Shape { kind })
    }
}

/// Builds [`GeometryError`]s for one shape type.
struct Validator(&'static str);

impl Validator {
    fn error(&self, parameter: &str, reason: impl Into<String>) -> GeometryError {
        GeometryError {
            shape: self.0,
            parameter: parameter.to_string(),
            reason: reason.into(),
        }
    }

    fn finite(&self, name: &str, x: f64) -> Result<(), GeometryError> {
        if x.is_finite() {
            Ok(())
        } else {
            Err(self.error(name, format!("must be a finite number (got {x})")))
        }
    }

    fn finite_point(&self, name: &str, p: [f64; 2]) -> Result<(), GeometryError> {
        if p.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(self.error(name, format!("must have finite coordinates (got {p:?})")))
        }
    }

    fn positive(&self, name: &str, x: f64) -> Result<(), GeometryError> {
        self.finite(name, x)?;
        if x > 0.0 {
            Ok(())
        } else {
            Err(self.error(name, format!("must be > 0 (got {x})")))
        }
    }

    fn spline_points(&self, points: &[[f64; 2]], closed: bool) -> Result<(), GeometryError> {
        let needed = if closed { 3 } else { 2 };
        if points.len() < needed {
            let kind = if closed { "a closed" } else { "an open" };
            let reason = format!(
                "needs at least {needed} points for {kind} spline (got {})",
                points.len()
            );
            return Err(self.error("points", reason));
        }
        for (i, p) in points.iter().enumerate() {
            self.finite_point(&format!("points[{i}]"), *p)?;
            if i > 0 && *p == points[i - 1] {
                return Err(self.error(
                    &format!("points[{i}]"),
                    format!("repeats points[{}]", i - 1),
                ));
            }
        }
        let last = points.len() - 1;
        if closed && points[last] == points[0] {
            let reason = "repeats points[0]; a closed spline closes by itself, do not repeat the first point";
            return Err(self.error(&format!("points[{last}]"), reason));
        }
        Ok(())
    }
}

/// A validated target curve, ready for geometric queries. Cheap to share
/// between threads (`Send + Sync`); queries do not mutate it.
#[derive(Debug, Clone)]
pub struct Shape {
    kind: Kind,
}

#[derive(Debug, Clone)]
enum Kind {
    Line(Line),
    Circle(Circle),
    Arc(Arc),
    Ellipse(Ellipse),
    Superellipse(Superellipse),
    Spline(Spline),
}

impl Shape {
    /// The point of the curve closest to `p` (for an arc or open spline,
    /// possibly an end point). Where several points are equally close, e.g.
    /// `p` at a circle's centre, one of them is returned.
    pub fn closest_point(&self, p: [f64; 2]) -> [f64; 2] {
        match &self.kind {
            Kind::Line(s) => s.closest(p),
            Kind::Circle(s) => s.closest(p),
            Kind::Arc(s) => s.closest(p),
            Kind::Ellipse(s) => s.closest(p).0,
            Kind::Superellipse(s) => s.point(closest_param(s, &s.samples, p)),
            Kind::Spline(s) => s.point(closest_param(s, &s.samples, p)),
        }
    }

    /// Euclidean distance from `p` to the curve, `|p − closest_point(p)|`.
    pub fn distance(&self, p: [f64; 2]) -> f64 {
        norm(sub(p, self.closest_point(p)))
    }

    /// Unit normal of the curve at the point closest to `p`: the tangent
    /// rotated clockwise, i.e. outward for closed curves and to the right of
    /// `from` → `to` for a line (see the module docs). At a corner or cusp
    /// (superellipse with n ≤ 1) one of the one-sided normals is returned.
    pub fn normal(&self, p: [f64; 2]) -> [f64; 2] {
        match &self.kind {
            Kind::Line(s) => s.normal,
            Kind::Circle(s) => s.normal_at(s.closest(p)),
            Kind::Arc(s) => s.circle.normal_at(s.closest(p)),
            Kind::Ellipse(s) => s.closest(p).1,
            Kind::Superellipse(s) => param_normal(s, closest_param(s, &s.samples, p)),
            Kind::Spline(s) => param_normal(s, closest_param(s, &s.samples, p)),
        }
    }

    /// The first point where the ray `origin + s·dir`, `s > 0`, meets the
    /// curve, or `None` if it misses (or `dir` is zero). A ray starting on
    /// the curve does not report its own origin. Exact for lines, circles,
    /// arcs, ellipses and superellipses seen from their centre; otherwise
    /// the crossing is bracketed on a fine polyline and refined on the
    /// curve parameter to full precision.
    pub fn ray_hit(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<[f64; 2]> {
        if dot(dir, dir) == 0.0 {
            return None;
        }
        match &self.kind {
            Kind::Line(s) => s.ray_hit(origin, dir),
            Kind::Circle(s) => s.ray_hits(origin, dir).into_iter().flatten().next(),
            Kind::Arc(s) => s.ray_hit(origin, dir),
            Kind::Ellipse(s) => s.ray_hit(origin, dir),
            Kind::Superellipse(s) => s.ray_hit(origin, dir),
            Kind::Spline(s) => {
                let s_min = ray_s_min(origin, dir, s.points[0], s.samples.length);
                ray_param(s, &s.samples, origin, dir, s_min).map(|t| s.point(t))
            }
        }
    }

    /// Whether the curve is closed (circle, ellipse, superellipse, closed
    /// spline; also an arc spanning a full turn). Lines and other arcs and
    /// splines are open.
    pub fn is_closed(&self) -> bool {
        match &self.kind {
            Kind::Line(_) => false,
            Kind::Circle(_) | Kind::Ellipse(_) | Kind::Superellipse(_) => true,
            Kind::Arc(s) => s.sweep >= TAU,
            Kind::Spline(s) => s.closed,
        }
    }
}

// ---------------------------------------------------------------------------
// Small vector helpers.





/// z-component of the 3D cross product.
fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}



/// Rotation by 90° clockwise: turns a tangent into our normal.
fn rot_cw(a: [f64; 2]) -> [f64; 2] {
    [a[1], -a[0]]
}

/// Rotation by 90° counter-clockwise.
fn rot_ccw(a: [f64; 2]) -> [f64; 2] {
    [-a[1], a[0]]
}

/// Rotation by the angle with the given cosine and sine.
fn rotate(a: [f64; 2], cos: f64, sin: f64) -> [f64; 2] {
    [cos * a[0] - sin * a[1], sin * a[0] + cos * a[1]]
}


// ---------------------------------------------------------------------------
// Closed-form shapes.

/// Infinite line through `from` with unit direction `dir`.
#[derive(Debug, Clone)]
struct Line {
    from: [f64; 2],
    dir: [f64; 2],
    normal: [f64; 2],
    length: f64,
}

impl Line {
    fn new(from: [f64; 2], to: [f64; 2]) -> Line {
        let dir = unit(sub(to, from));
        Line {
            from,
            dir,
            normal: rot_cw(dir),
            length: norm(sub(to, from)),
        }
    }

    fn closest(&self, p: [f64; 2]) -> [f64; 2] {
        add(self.from, scale(dot(sub(p, self.from), self.dir), self.dir))
    }

    fn ray_hit(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<[f64; 2]> {
        let denom = cross(dir, self.dir);
        if denom == 0.0 {
            return None; // parallel (or along the line): no single crossing
        }
        let s = cross(sub(self.from, origin), self.dir) / denom;
        let s_min = ray_s_min(origin, dir, self.from, self.length);
        // Project the hit so it lies on the line to machine precision.
        (s > s_min).then(|| self.closest(add(origin, scale(s, dir))))
    }
}

/// Full circle.
#[derive(Debug, Clone)]
struct Circle {
    centre: [f64; 2],
    radius: f64,
}

impl Circle {
    /// Radial projection; the centre itself maps to the point at angle 0.
    fn closest(&self, p: [f64; 2]) -> [f64; 2] {
        let v = sub(p, self.centre);
        let len = norm(v);
        if len == 0.0 {
            return add(self.centre, [self.radius, 0.0]);
        }
        add(self.centre, scale(self.radius / len, v))
    }

    /// Outward normal at a point on the circle.
    fn normal_at(&self, q: [f64; 2]) -> [f64; 2] {
        unit(sub(q, self.centre))
    }

    /// The ray's crossings with the circle in increasing `s` (both `s > 0`
    /// beyond round-off), projected onto the circle.
    fn ray_hits(&self, origin: [f64; 2], dir: [f64; 2]) -> [Option<[f64; 2]>; 2] {
        let s_min = ray_s_min(origin, dir, self.centre, self.radius);
        let Some((s1, s2)) = unit_circle_roots(
            scale(1.0 / self.radius, sub(origin, self.centre)),
            scale(1.0 / self.radius, dir),
        ) else {
            return [None, None];
        };
        let hit = |s: f64| (s > s_min).then(|| self.closest(add(origin, scale(s, dir))));
        [hit(s1), hit(s2)]
    }
}

/// Roots `s1 <= s2` of `|o + s·d| = 1`, computed without cancellation, or
/// `None` if the line misses the unit circle.
fn unit_circle_roots(o: [f64; 2], d: [f64; 2]) -> Option<(f64, f64)> {
    let a = dot(d, d);
    let b = dot(o, d);
    let c = dot(o, o) - 1.0;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    // q has the sign of -b, so q/a and c/q avoid subtracting close numbers.
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return Some((0.0, 0.0)); // o on the circle and d tangent
    }
    let (r1, r2) = (q / a, c / q);
    Some((r1.min(r2), r1.max(r2)))
}

/// Circular arc from angle `start` sweeping counter-clockwise by `sweep`.
#[derive(Debug, Clone)]
struct Arc {
    circle: Circle,
    start: f64,
    sweep: f64,
    ends: [[f64; 2]; 2],
}

impl Arc {
    /// Angle slack when testing whether a ray's circle hit is on the arc,
    /// so that hits exactly at an end are not lost to round-off.
    const ANGLE_TOL: f64 = 1e-14;

    fn new(circle: Circle, start_deg: f64, end_deg: f64) -> Arc {
        let mut sweep = (end_deg - start_deg).rem_euclid(360.0);
        if sweep == 0.0 {
            sweep = 360.0; // the ends differ by whole turns: a full circle
        }
        let start = start_deg.to_radians();
        let sweep = sweep.to_radians();
        let at = |a: f64| {
            add(
                circle.centre,
                [circle.radius * a.cos(), circle.radius * a.sin()],
            )
        };
        let ends = [at(start), at(start + sweep)];
        Arc {
            circle,
            start,
            sweep,
            ends,
        }
    }

    /// Counter-clockwise angle of `v` from the arc's start, in [0, 2π).
    fn relative_angle(&self, v: [f64; 2]) -> f64 {
        (v[1].atan2(v[0]) - self.start).rem_euclid(TAU)
    }

    fn closest(&self, p: [f64; 2]) -> [f64; 2] {
        let v = sub(p, self.circle.centre);
        if v == [0.0, 0.0] {
            return self.ends[0]; // every arc point is equally close
        }
        if self.relative_angle(v) <= self.sweep {
            return self.circle.closest(p);
        }
        // Outside the arc's angular range the distance grows monotonically
        // with the angle away from each end, so the nearer end wins.
        let [a, b] = self.ends;
        if dot(sub(p, a), sub(p, a)) <= dot(sub(p, b), sub(p, b)) {
            a
        } else {
            b
        }
    }

    fn ray_hit(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<[f64; 2]> {
        self.circle
            .ray_hits(origin, dir)
            .into_iter()
            .flatten()
            .find(|q| {
                let u = self.relative_angle(sub(*q, self.circle.centre));
                u <= self.sweep + Self::ANGLE_TOL || u >= TAU - Self::ANGLE_TOL
            })
    }
}

/// Ellipse with semi-axes `a` (along angle `angle`) and `b`.
#[derive(Debug, Clone)]
struct Ellipse {
    centre: [f64; 2],
    a: f64,
    b: f64,
    cos: f64,
    sin: f64,
}

impl Ellipse {
    fn new(centre: [f64; 2], semi_axes: [f64; 2], angle_deg: f64) -> Ellipse {
        let (sin, cos) = angle_deg.to_radians().sin_cos();
        Ellipse {
            centre,
            a: semi_axes[0],
            b: semi_axes[1],
            cos,
            sin,
        }
    }

    fn to_local(&self, p: [f64; 2]) -> [f64; 2] {
        rotate(sub(p, self.centre), self.cos, -self.sin)
    }

    fn to_world(&self, q: [f64; 2]) -> [f64; 2] {
        add(self.centre, rotate(q, self.cos, self.sin))
    }

    /// The local point at the eccentric angle of local `q`: snaps a nearly
    /// on-curve point exactly onto the curve.
    fn snap_local(&self, q: [f64; 2]) -> [f64; 2] {
        let (s, c) = (q[1] / self.b).atan2(q[0] / self.a).sin_cos();
        [self.a * c, self.b * s]
    }

    /// Closest point and outward unit normal there.
    fn closest(&self, p: [f64; 2]) -> ([f64; 2], [f64; 2]) {
        let q = self.to_local(p);
        let x = self.snap_local(closest_on_axis_ellipse(self.a, self.b, q));
        let n = unit([x[0] / (self.a * self.a), x[1] / (self.b * self.b)]);
        (self.to_world(x), rotate(n, self.cos, self.sin))
    }

    fn ray_hit(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<[f64; 2]> {
        // In coordinates scaled by the semi-axes the ellipse is the unit
        // circle and the ray parameter s is unchanged.
        let (o, d) = (self.to_local(origin), rotate(dir, self.cos, -self.sin));
        let stretch = |v: [f64; 2]| [v[0] / self.a, v[1] / self.b];
        let (s1, s2) = unit_circle_roots(stretch(o), stretch(d))?;
        let s_min = ray_s_min(origin, dir, self.centre, self.a.max(self.b));
        let s = [s1, s2].into_iter().find(|s| *s > s_min)?;
        // Project the world-space hit back onto the curve: projecting along
        // the normal moves it less across the ray than snapping the angle in
        // stretched coordinates, which matters for flat ellipses.
        Some(self.closest(add(origin, scale(s, dir))).0)
    }
}

/// Closest point on the axis-aligned ellipse `(x/a)² + (y/b)² = 1` to `q`,
/// by Eberly's robust bisection ("Distance from a point to an ellipse").
fn closest_on_axis_ellipse(a: f64, b: f64, q: [f64; 2]) -> [f64; 2] {
    // Eberly's method wants the first semi-axis to be the larger and the
    // point in the first quadrant; undo both at the end.
    let swap = a < b;
    let (e0, e1, y0, y1) = if swap {
        (b, a, q[1].abs(), q[0].abs())
    } else {
        (a, b, q[0].abs(), q[1].abs())
    };
    let [x0, x1] = eberly_first_quadrant(e0, e1, y0, y1);
    let (x, y) = if swap { (x1, x0) } else { (x0, x1) };
    [x.copysign(q[0]), y.copysign(q[1])]
}

fn eberly_first_quadrant(e0: f64, e1: f64, y0: f64, y1: f64) -> [f64; 2] {
    if y1 > 0.0 {
        if y0 > 0.0 {
            let (z0, z1) = (y0 / e0, y1 / e1);
            let g = z0 * z0 + z1 * z1 - 1.0;
            if g == 0.0 {
                return [y0, y1];
            }
            let r0 = (e0 / e1) * (e0 / e1);
            let s = eberly_root(r0, z0, z1, g);
            return [r0 * y0 / (s + r0), y1 / (s + 1.0)];
        }
        return [0.0, e1];
    }
    // On the major axis: the closest point is either the vertex or, for
    // points inside near the centre, off the axis.
    let (numer, denom) = (e0 * y0, e0 * e0 - e1 * e1);
    if numer < denom {
        let xde = numer / denom;
        return [e0 * xde, e1 * (1.0 - xde * xde).max(0.0).sqrt()];
    }
    [e0, 0.0]
}

/// Bisection for the root of Eberly's monotone function; converges to the
/// last representable bit.
fn eberly_root(r0: f64, z0: f64, z1: f64, g: f64) -> f64 {
    let n0 = r0 * z0;
    let mut lo = z1 - 1.0;
    let mut hi = if g < 0.0 { 0.0 } else { n0.hypot(z1) - 1.0 };
    let mut s = lo;
    for _ in 0..2000 {
        s = 0.5 * (lo + hi);
        if s == lo || s == hi {
            break;
        }
        let (ratio0, ratio1) = (n0 / (s + r0), z1 / (s + 1.0));
        let g = ratio0 * ratio0 + ratio1 * ratio1 - 1.0;
        if g > 0.0 {
            lo = s;
        } else if g < 0.0 {
            hi = s;
        } else {
            break;
        }
    }
    s
}

// ---------------------------------------------------------------------------
// Parametric shapes, queried numerically.

/// A curve with a parameter, for the numeric closest-point and ray queries.
trait Param {
    /// The curve point at parameter `t`.
    fn point(&self, t: f64) -> [f64; 2];
    /// A tangent in the direction of increasing `t` (any positive length).
    fn tangent(&self, t: f64) -> [f64; 2];
}

/// Our normal convention applied to a parametric curve.
fn param_normal<C: Param>(c: &C, t: f64) -> [f64; 2] {
    unit(rot_cw(c.tangent(t)))
}

/// A polyline sampling of a parametric curve, used to bracket queries.
#[derive(Debug, Clone)]
struct Samples {
    t: Vec<f64>,
    p: Vec<[f64; 2]>,
    /// `Some(T)` for a closed curve with period `T` (the last sample then
    /// connects to the first at parameter `t[0] + T`).
    period: Option<f64>,
    /// Longest chord between consecutive samples.
    h_max: f64,
    /// Length of the polyline.
    length: f64,
}

impl Samples {
    /// Samples at `params` (increasing; the end of the domain is included
    /// for an open curve and excluded for a periodic one), then bisects
    /// chords until none is longer than the polyline length over
    /// [`SAMPLES_PER_LENGTH`], so no detail of the curve is skipped.
    fn new<C: Param>(c: &C, params: &[f64], period: Option<f64>) -> Samples {
        let mut ends: Vec<f64> = params.to_vec();
        if let Some(period) = period {
            ends.push(params[0] + period);
        }
        let pts: Vec<[f64; 2]> = ends.iter().map(|&t| c.point(t)).collect();
        let coarse_len: f64 = pts.windows(2).map(|w| norm(sub(w[1], w[0]))).sum();
        let h_target = coarse_len / SAMPLES_PER_LENGTH;
        let mut t = vec![ends[0]];
        let mut p = vec![pts[0]];
        for i in 1..ends.len() {
            refine(
                c,
                (ends[i - 1], pts[i - 1]),
                (ends[i], pts[i]),
                h_target,
                40,
                &mut t,
                &mut p,
            );
        }
        if period.is_some() {
            // The closing sample duplicates the first one.
            t.pop();
            p.pop();
        }
        let mut s = Samples {
            t,
            p,
            period,
            h_max: 0.0,
            length: 0.0,
        };
        for i in 0..s.segments() {
            let h = norm(sub(s.p[(i + 1) % s.p.len()], s.p[i]));
            s.h_max = s.h_max.max(h);
            s.length += h;
        }
        s
    }

    /// Number of polyline segments (wrapping around for a closed curve).
    fn segments(&self) -> usize {
        self.p.len() - usize::from(self.period.is_none())
    }

    /// Parameter range of segment `i`, unwrapped across a periodic seam.
    fn segment(&self, i: usize) -> (f64, f64) {
        match (i + 1 == self.t.len(), self.period) {
            (true, Some(period)) => (self.t[i], self.t[0] + period),
            _ => (self.t[i], self.t[i + 1]),
        }
    }

    /// Parameters of the samples before and after sample `i` (clamped to
    /// `i` itself at the ends of an open curve).
    fn neighbours(&self, i: usize) -> (f64, f64) {
        let n = self.t.len();
        let prev = match (i, self.period) {
            (0, Some(period)) => self.t[n - 1] - period,
            (0, None) => self.t[0],
            _ => self.t[i - 1],
        };
        let next = match (i + 1 < n, self.period) {
            (true, _) => self.t[i + 1],
            (false, Some(period)) => self.t[0] + period,
            (false, None) => self.t[i],
        };
        (prev, next)
    }
}

/// Appends samples strictly after `a` up to and including `b`, bisecting
/// while the chord is longer than `h`.
fn refine<C: Param>(
    c: &C,
    a: (f64, [f64; 2]),
    b: (f64, [f64; 2]),
    h: f64,
    depth: u32,
    t: &mut Vec<f64>,
    p: &mut Vec<[f64; 2]>,
) {
    if depth > 0 && norm(sub(b.1, a.1)) > h {
        let tm = 0.5 * (a.0 + b.0);
        let m = (tm, c.point(tm));
        refine(c, a, m, h, depth - 1, t, p);
        refine(c, m, b, h, depth - 1, t, p);
    } else {
        t.push(b.0);
        p.push(b.1);
    }
}

/// Parameter of the point of `c` closest to `p`.
///
/// Every local minimum of the sampled distance that could hide the global
/// one (within one chord length of the best sample) is refined by finding
/// the sign change of `(c(t) − p)·c'(t)`, the derivative of the squared
/// distance, with Brent's method. Root-finding on the derivative, unlike
/// minimising the distance itself, pins the parameter down to machine
/// precision.
fn closest_param<C: Param>(c: &C, s: &Samples, p: [f64; 2]) -> f64 {
    let d2: Vec<f64> = s.p.iter().map(|q| dot(sub(*q, p), sub(*q, p))).collect();
    let n = d2.len();
    let (best_i, best) =
        d2.iter().enumerate().fold(
            (0, f64::INFINITY),
            |acc, (i, &d)| if d < acc.1 { (i, d) } else { acc },
        );
    let limit = (best.sqrt() + s.h_max).powi(2);
    let mut result = (s.t[best_i], best);
    for i in 0..n {
        let (prev, next) = match s.period {
            Some(_) => ((i + n - 1) % n, (i + 1) % n),
            None => (i.saturating_sub(1), (i + 1).min(n - 1)),
        };
        if d2[i] > limit || d2[i] > d2[prev] || d2[i] > d2[next] {
            continue;
        }
        let (lo, hi) = s.neighbours(i);
        if let Some(t) = refine_minimum(c, p, lo, hi) {
            let q = sub(c.point(t), p);
            if dot(q, q) < result.1 {
                result = (t, dot(q, q));
            }
        }
    }
    result.0
}

/// The best stationary point of the squared distance in `[lo, hi]`, found
/// as a − → + sign change of its derivative. Sub-brackets are tried when
/// the whole bracket shows no such change (several extrema inside).
fn refine_minimum<C: Param>(c: &C, p: [f64; 2], lo: f64, hi: f64) -> Option<f64> {
    let g = |t: f64| dot(sub(c.point(t), p), unit(c.tangent(t)));
    let (glo, ghi) = (g(lo), g(hi));
    if glo < 0.0 && ghi > 0.0 {
        return Some(brent_root(&g, lo, hi, glo, ghi));
    }
    const PIECES: usize = 8;
    let mut best: Option<(f64, f64)> = None;
    let mut a = (lo, glo);
    for k in 1..=PIECES {
        let tb = lo + (hi - lo) * k as f64 / PIECES as f64;
        let b = (tb, g(tb));
        if a.1 < 0.0 && b.1 > 0.0 {
            let t = brent_root(&g, a.0, b.0, a.1, b.1);
            let d = norm(sub(c.point(t), p));
            if best.is_none_or(|(_, bd)| d < bd) {
                best = Some((t, d));
            }
        }
        a = b;
    }
    best.map(|(t, _)| t)
}

/// Parameter of the first crossing (smallest `s > s_min`) of the ray with
/// `c`: sign changes of `cross(dir, c(t) − origin)` along the polyline,
/// each refined with Brent's method.
fn ray_param<C: Param>(
    c: &C,
    s: &Samples,
    origin: [f64; 2],
    dir: [f64; 2],
    s_min: f64,
) -> Option<f64> {
    let side = |q: [f64; 2]| cross(dir, sub(q, origin));
    let along = |q: [f64; 2]| dot(sub(q, origin), dir) / dot(dir, dir);
    let n = s.p.len();
    let mut best: Option<(f64, f64)> = None; // (s, t)
    for i in 0..s.segments() {
        let (pa, pb) = (s.p[i], s.p[(i + 1) % n]);
        let (ha, hb) = (side(pa), side(pb));
        if ha * hb > 0.0 {
            continue;
        }
        // Skip segments entirely behind the origin or beyond a known hit;
        // the margin covers the curve bulging past its chord.
        let (sa, sb) = (along(pa), along(pb));
        let margin = s.h_max / norm(dir);
        if sa.max(sb) < s_min - margin || best.is_some_and(|(bs, _)| sa.min(sb) > bs + margin) {
            continue;
        }
        let (ta, tb) = s.segment(i);
        let t = brent_root(&|t| side(c.point(t)), ta, tb, ha, hb);
        let st = along(c.point(t));
        if st > s_min && best.is_none_or(|(bs, _)| st < bs) {
            best = Some((st, t));
        }
    }
    best.map(|(_, t)| t)
}


/// Superellipse `|x/a|^n + |y/b|^n = 1`, parametrised by the polar angle
/// about its centre (a star-shaped curve, so every angle gives one point;
/// unlike the usual `cos^(2/n)` form this does not crowd points together).
#[derive(Debug, Clone)]
struct Superellipse {
    centre: [f64; 2],
    a: f64,
    b: f64,
    n: f64,
    samples: Samples,
}

impl Superellipse {
    fn new(centre: [f64; 2], semi_axes: [f64; 2], n: f64) -> Superellipse {
        let empty = Samples {
            t: vec![],
            p: vec![],
            period: None,
            h_max: 0.0,
            length: 0.0,
        };
        let mut s = Superellipse {
            centre,
            a: semi_axes[0],
            b: semi_axes[1],
            n,
            samples: empty,
        };
        let params: Vec<f64> = (0..256).map(|k| TAU * k as f64 / 256.0).collect();
        s.samples = Samples::new(&s, &params, Some(TAU));
        s
    }

    /// Outward normal direction (not unit) at local point `(x, y)` on the
    /// curve, from the implicit gradient, rescaled so it stays finite: for
    /// n ≥ 1 the gradient itself; for n < 1 the gradient times
    /// `|x/a|^(1−n) |y/b|^(1−n)`, which removes its poles at the cusps.
    fn normal_dir(&self, x: f64, y: f64) -> [f64; 2] {
        let (u, v) = ((x / self.a).abs(), (y / self.b).abs());
        let (su, sv) = (x.signum() / self.a, y.signum() / self.b);
        if self.n >= 1.0 {
            [su * u.powf(self.n - 1.0), sv * v.powf(self.n - 1.0)]
        } else {
            [su * v.powf(1.0 - self.n), sv * u.powf(1.0 - self.n)]
        }
    }

    fn ray_hit(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<[f64; 2]> {
        let size = self.a.max(self.b);
        if norm(sub(origin, self.centre)) <= 1e-15 * size {
            // From the centre, the ray's angle is the polar parameter.
            return Some(self.point(dir[1].atan2(dir[0])));
        }
        let s_min = ray_s_min(origin, dir, self.centre, size);
        ray_param(self, &self.samples, origin, dir, s_min).map(|t| self.point(t))
    }
}

impl Param for Superellipse {
    fn point(&self, phi: f64) -> [f64; 2] {
        let (s, c) = phi.sin_cos();
        // r = (|c/a|^n + |s/b|^n)^(-1/n), with the larger term factored out
        // so that large n neither overflows nor underflows.
        let (u, v) = ((c / self.a).abs(), (s / self.b).abs());
        let (big, small) = if u >= v { (u, v) } else { (v, u) };
        let r = 1.0 / (big * (1.0 + (small / big).powf(self.n)).powf(1.0 / self.n));
        add(self.centre, [r * c, r * s])
    }

    fn tangent(&self, phi: f64) -> [f64; 2] {
        let q = sub(self.point(phi), self.centre);
        // The polar angle increases counter-clockwise along the curve.
        rot_ccw(unit(self.normal_dir(q[0], q[1])))
    }
}

/// Cubic spline through points, parametrised by cumulative chord length.
#[derive(Debug, Clone)]
struct Spline {
    /// Knots; `knots[k]` is the parameter of `points[k]`.
    knots: Vec<f64>,
    /// Interpolated points; for a closed spline the first is repeated last.
    points: Vec<[f64; 2]>,
    /// Second derivatives at the knots (repeated last too when closed).
    second: Vec<[f64; 2]>,
    closed: bool,
    samples: Samples,
}

impl Spline {
    fn new(points: &[[f64; 2]], closed: bool) -> Spline {
        let mut pts = points.to_vec();
        // Closed curves run counter-clockwise so their normal is outward.
        if closed && signed_area(&pts) < 0.0 {
            pts.reverse();
        }
        if closed {
            pts.push(pts[0]);
        }
        let mut knots = vec![0.0];
        for w in pts.windows(2) {
            knots.push(knots.last().unwrap() + norm(sub(w[1], w[0])));
        }
        let second = spline_second_derivatives(&knots, &pts, closed);
        let empty = Samples {
            t: vec![],
            p: vec![],
            period: None,
            h_max: 0.0,
            length: 0.0,
        };
        let mut s = Spline {
            knots,
            points: pts,
            second,
            closed,
            samples: empty,
        };
        s.samples = s.build_samples();
        s
    }

    /// At least 4 samples per span, refined by chord length.
    fn build_samples(&self) -> Samples {
        let spans = self.knots.len() - 1;
        let mut params = Vec::with_capacity(4 * spans + 1);
        for k in 0..spans {
            let (t0, t1) = (self.knots[k], self.knots[k + 1]);
            params.extend((0..4).map(|j| t0 + (t1 - t0) * j as f64 / 4.0));
        }
        let period = self.closed.then(|| self.period());
        if !self.closed {
            params.push(self.knots[spans]);
        }
        Samples::new(self, &params, period)
    }

    fn period(&self) -> f64 {
        *self.knots.last().unwrap()
    }

    /// Maps `t` into the domain: wraps a closed spline, clamps an open one.
    fn wrap(&self, t: f64) -> f64 {
        let end = self.period();
        if self.closed {
            let w = t.rem_euclid(end);
            if w >= end {
                0.0
            } else {
                w
            }
        } else {
            t.clamp(0.0, end)
        }
    }

    /// Index of the span containing parameter `t` (already in the domain).
    fn span(&self, t: f64) -> usize {
        let k = self.knots.partition_point(|&x| x <= t);
        k.saturating_sub(1).min(self.knots.len() - 2)
    }

    /// Value, first and second derivative of span `k` at `t`.
    fn eval_span(&self, k: usize, t: f64) -> [[f64; 2]; 3] {
        let h = self.knots[k + 1] - self.knots[k];
        let (a, b) = ((self.knots[k + 1] - t) / h, (t - self.knots[k]) / h);
        let (p0, p1, m0, m1) = (
            self.points[k],
            self.points[k + 1],
            self.second[k],
            self.second[k + 1],
        );
        let mut out = [[0.0; 2]; 3];
        for d in 0..2 {
            out[0][d] = a * p0[d]
                + b * p1[d]
                + ((a * a * a - a) * m0[d] + (b * b * b - b) * m1[d]) * h * h / 6.0;
            out[1][d] = (p1[d] - p0[d]) / h - (3.0 * a * a - 1.0) / 6.0 * h * m0[d]
                + (3.0 * b * b - 1.0) / 6.0 * h * m1[d];
            out[2][d] = a * m0[d] + b * m1[d];
        }
        out
    }

    fn eval(&self, t: f64) -> [[f64; 2]; 3] {
        let t = self.wrap(t);
        self.eval_span(self.span(t), t)
    }
}

impl Param for Spline {
    fn point(&self, t: f64) -> [f64; 2] {
        self.eval(t)[0]
    }

    fn tangent(&self, t: f64) -> [f64; 2] {
        let [_, d1, d2] = self.eval(t);
        // A chord-length spline can stop momentarily at a cusp; the second
        // derivative then gives the direction of motion.
        if d1 == [0.0, 0.0] {
            d2
        } else {
            d1
        }
    }
}

/// Shoelace signed area of a closed polygon (positive if counter-clockwise).
fn signed_area(pts: &[[f64; 2]]) -> f64 {
    let n = pts.len();
    0.5 * (0..n).map(|i| cross(pts[i], pts[(i + 1) % n])).sum::<f64>()
}

/// Second derivatives of the interpolating cubic spline at the knots, per
/// coordinate: natural end conditions when open, periodic when closed (the
/// last point then repeats the first, and so does the result).
fn spline_second_derivatives(knots: &[f64], pts: &[[f64; 2]], closed: bool) -> Vec<[f64; 2]> {
    let m = knots.len() - 1; // number of spans
    let h: Vec<f64> = knots.windows(2).map(|w| w[1] - w[0]).collect();
    let mut result = vec![[0.0; 2]; m + 1];
    for d in 0..2 {
        let slope = |k: usize| (pts[k + 1][d] - pts[k][d]) / h[k];
        if closed {
            // Row i ties spans i-1 and i around knot i, indices mod m.
            let prev = |i: usize| (i + m - 1) % m;
            let lower: Vec<f64> = (0..m).map(|i| h[prev(i)]).collect();
            let diag: Vec<f64> = (0..m).map(|i| 2.0 * (h[prev(i)] + h[i])).collect();
            let upper: Vec<f64> = h.clone();
            let rhs: Vec<f64> = (0..m).map(|i| 6.0 * (slope(i) - slope(prev(i)))).collect();
            let x = solve_cyclic(&lower, &diag, &upper, &rhs);
            for i in 0..m {
                result[i][d] = x[i];
            }
            result[m][d] = x[0];
        } else if m >= 2 {
            let inner = 1..m;
            let lower: Vec<f64> = inner.clone().map(|i| h[i - 1]).collect();
            let diag: Vec<f64> = inner.clone().map(|i| 2.0 * (h[i - 1] + h[i])).collect();
            let upper: Vec<f64> = inner.clone().map(|i| h[i]).collect();
            let rhs: Vec<f64> = inner.map(|i| 6.0 * (slope(i) - slope(i - 1))).collect();
            for (k, x) in solve_tridiagonal(&lower, &diag, &upper, &rhs)
                .into_iter()
                .enumerate()
            {
                result[k + 1][d] = x;
            }
        }
    }
    result
}

/// Thomas algorithm for `lower[i]·x[i-1] + diag[i]·x[i] + upper[i]·x[i+1] =
/// rhs[i]` (`lower[0]` and `upper[n-1]` unused). Stable here because the
/// spline systems are strictly diagonally dominant.
fn solve_tridiagonal(lower: &[f64], diag: &[f64], upper: &[f64], rhs: &[f64]) -> Vec<f64> {
    let n = diag.len();
    let mut c = vec![0.0; n];
    let mut x = vec![0.0; n];
    for i in 0..n {
        let (l, cp, xp) = if i == 0 {
            (0.0, 0.0, 0.0)
        } else {
            (lower[i], c[i - 1], x[i - 1])
        };
        let denom = diag[i] - l * cp;
        c[i] = upper[i] / denom;
        x[i] = (rhs[i] - l * xp) / denom;
    }
    for i in (0..n.saturating_sub(1)).rev() {
        x[i] -= c[i] * x[i + 1];
    }
    x
}

/// Cyclic tridiagonal solve (`lower[0]` couples row 0 to `x[n-1]`,
/// `upper[n-1]` couples row n-1 to `x[0]`) by the Sherman–Morrison formula
/// on top of two ordinary tridiagonal solves. Needs n ≥ 3.
fn solve_cyclic(lower: &[f64], diag: &[f64], upper: &[f64], rhs: &[f64]) -> Vec<f64> {
    let n = diag.len();
    let (alpha, beta) = (upper[n - 1], lower[0]);
    let gamma = -diag[0];
    let mut bb = diag.to_vec();
    bb[0] -= gamma;
    bb[n - 1] -= alpha * beta / gamma;
    let mut x = solve_tridiagonal(lower, &bb, upper, rhs);
    let mut u = vec![0.0; n];
    u[0] = gamma;
    u[n - 1] = alpha;
    let z = solve_tridiagonal(lower, &bb, upper, &u);
    let fact = (x[0] + beta * x[n - 1] / gamma) / (1.0 + z[0] + beta * z[n - 1] / gamma);
    for i in 0..n {
        x[i] -= fact * z[i];
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numeric::EPS;
    use proptest::prelude::*;
    use proptest::test_runner::{Config, TestRunner};

    fn build(toml_text: &str) -> Shape {
        spec(toml_text).build().unwrap()
    }

    fn spec(toml_text: &str) -> ShapeSpec {
        #[derive(Deserialize)]
        struct Case {
            shape: ShapeSpec,
        }
        toml::from_str::<Case>(toml_text).unwrap().shape
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

    fn brute_distance(pts: &[[f64; 2]], p: [f64; 2]) -> f64 {
        pts.iter()
            .map(|q| norm(sub(*q, p)))
            .fold(f64::INFINITY, f64::min)
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

    /// A property-test runner with a fixed seed: CI sees the same cases on
    /// every run (a failure is reproducible, never flaky).
    fn runner(cases: u32) -> TestRunner {
        let config = Config { cases, failure_persistence: None, ..Config::default() };
        let rng = proptest::test_runner::TestRng::deterministic_rng(config.rng_algorithm);
        TestRunner::new_with_rng(config, rng)
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

    /// The closest point must beat (or tie) every dense sample, and can be
    /// no closer than the true distance, which the samples over-estimate by
    /// at most one spacing.
    fn check_against_brute(
        name: &str,
        shape: &Shape,
        pts: &[[f64; 2]],
        spacing: f64,
        size: f64,
        p: [f64; 2],
    ) {
        let q = shape.closest_point(p);
        let d = norm(sub(p, q));
        let brute = brute_distance(pts, p);
        assert!(
            d <= brute + 1e-12 * size,
            "{name} {p:?}: {d} vs brute {brute}"
        );
        assert!(d >= brute - spacing, "{name} {p:?}: {d} vs brute {brute}");
        assert_eq!(shape.distance(p), d);
        // First-order optimality to full precision: p − q is normal
        // (except at the end points of open curves).
        let n = shape.normal(p);
        let at_end = !shape.is_closed()
            && (norm(sub(q, pts[0])) < 1e-9 || norm(sub(q, pts[pts.len() - 1])) < 1e-9);
        let at_cusp = name.contains("0.7") && (q[0].abs() < 1e-9 || q[1].abs() < 1e-9);
        assert!(
            at_end || at_cusp || cross(sub(p, q), n).abs() <= 1e-11 * size,
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
            let den = cross(d, e);
            if den == 0.0 {
                continue;
            }
            let s = cross(sub(a, o), e) / den;
            let u = cross(sub(a, o), d) / den;
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
                    cross(d, v).abs()
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
                                    cross(v, unit(d)).abs() <= 1e-12 * size,
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
            assert!(cross(v, d).abs() < 1e-15 && dot(v, d) > 0.0);
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
}
