//! 2D shapes: a [`ShapeSpec`] as a case or geometry file writes it, and the
//! [`Shape`] it builds, a curve of the plane.
//!
//! Every curve has an orientation: lines run `from` → `to`, circles, arcs,
//! ellipses and superellipses run counter-clockwise, open splines run from
//! their first to their last point, and closed splines are reoriented
//! counter-clockwise when built. The normal is the unit tangent (along that
//! orientation) rotated *clockwise* by 90°: outward for closed curves, to
//! the right of `from` → `to` for a line. This matches meshes whose
//! boundary edges run with the domain on their left.

use super::ellipse::Ellipse;
use super::flat::Line;
use super::parametric::{closest_param, param_normal, ray_param, Param};
use super::round::{Arc, Circle};
use super::spline::Spline;
use super::superellipse::Superellipse;
use super::{ray_s_min, ClosestPoint, GeometryError, Validator};
use crate::numeric::dot;
use serde::Deserialize;
use std::f64::consts::TAU;

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
                v.semi_axes(*semi_axes)?;
                v.finite("angle", *angle)?;
                Kind::Ellipse(Ellipse::new(*centre, *semi_axes, *angle))
            }
            ShapeSpec::Superellipse {
                centre,
                semi_axes,
                exponent,
            } => {
                v.finite_point("centre", *centre)?;
                v.semi_axes(*semi_axes)?;
                v.positive("exponent", *exponent)?;
                Kind::Superellipse(Superellipse::new(*centre, *semi_axes, *exponent))
            }
            ShapeSpec::Spline { points, closed } => {
                Spline::check(&v, points, *closed)?;
                Kind::Spline(Spline::new(points, *closed))
            }
        };
        Ok(Shape { kind })
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

impl ClosestPoint<2> for Shape {
    /// The point of the curve closest to `p` (for an arc or open spline,
    /// possibly an end point). Where several points are equally close, e.g.
    /// `p` at a circle's centre, one of them is returned.
    fn closest_point(&self, p: [f64; 2]) -> [f64; 2] {
        match &self.kind {
            Kind::Line(s) => s.closest(p),
            Kind::Circle(s) => s.closest(p),
            Kind::Arc(s) => s.closest(p),
            Kind::Ellipse(s) => s.closest(p).0,
            Kind::Superellipse(s) => s.point(closest_param(s, &s.samples, p)),
            Kind::Spline(s) => s.point(closest_param(s, &s.samples, p)),
        }
    }

    /// Unit normal of the curve at the point closest to `p`: the tangent
    /// rotated clockwise, i.e. outward for closed curves and to the right of
    /// `from` → `to` for a line (see the module docs). At a corner or cusp
    /// (superellipse with n ≤ 1) one of the one-sided normals is returned.
    fn normal(&self, p: [f64; 2]) -> [f64; 2] {
        match &self.kind {
            Kind::Line(s) => s.normal,
            Kind::Circle(s) => s.normal_at(s.closest(p)),
            Kind::Arc(s) => s.circle.normal_at(s.closest(p)),
            Kind::Ellipse(s) => s.closest(p).1,
            Kind::Superellipse(s) => param_normal(s, closest_param(s, &s.samples, p)),
            Kind::Spline(s) => param_normal(s, closest_param(s, &s.samples, p)),
        }
    }

    /// The first crossing of the ray with the curve. Exact for lines,
    /// circles, arcs, ellipses and superellipses seen from their centre;
    /// otherwise the crossing is bracketed on a fine polyline and refined
    /// on the curve parameter to full precision.
    fn ray_hit(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<[f64; 2]> {
        if dot(dir, dir) == 0.0 {
            return None;
        }
        match &self.kind {
            Kind::Line(s) => s.ray_hit(origin, dir),
            Kind::Circle(s) => s.ray_hit(origin, dir),
            Kind::Arc(s) => s.ray_hit(origin, dir),
            Kind::Ellipse(s) => s.ray_hit(origin, dir),
            Kind::Superellipse(s) => s.ray_hit(origin, dir),
            Kind::Spline(s) => {
                let s_min = ray_s_min(origin, dir, s.points[0], s.samples.length);
                ray_param(s, &s.samples, origin, dir, s_min).map(|t| s.point(t))
            }
        }
    }
}

impl Shape {
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

#[cfg(test)]
#[path = "curve_tests.rs"]
mod tests;
