//! 3D shapes: a [`SurfaceSpec`] as a case or geometry file writes it, and
//! the [`Surface`] it builds.
//!
//! The normal is the unit *outward* one at the closest point: away from
//! the inside of closed surfaces (sphere, ellipsoid, superquadric), away
//! from the axis for the cylinder and surfaces of revolution, and along the
//! spec's `normal` for a plane. A surface of revolution is only its lateral
//! surface (no end caps); its closest points clamp to the `z_range`.

use super::ellipse::Ellipsoid;
use super::flat::Plane;
use super::revolution::Revolution;
use super::round::{Cylinder, Sphere};
use super::superellipse::Superquadric;
use super::{ClosestPoint, GeometryError, Validator};
use crate::numeric::{dot, unit};
use serde::Deserialize;

/// A surface as written in a case file, e.g.
/// `shape = { type = "sphere", centre = [0.0, 0.0, 0.0], radius = 1.25 }`.
///
/// Unknown fields are rejected.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum SurfaceSpec {
    /// The infinite plane through `point` with normal `normal`, which need
    /// not be unit length and points to the plane's positive side.
    Plane {
        /// A point on the plane.
        point: [f64; 3],
        /// A non-zero normal vector, giving the positive side.
        normal: [f64; 3],
    },
    /// A sphere.
    Sphere {
        /// Centre point.
        centre: [f64; 3],
        /// Radius, > 0.
        radius: f64,
    },
    /// The axis-aligned ellipsoid `(x/a)² + (y/b)² + (z/c)² = 1` relative
    /// to `centre`.
    Ellipsoid {
        /// Centre point.
        centre: [f64; 3],
        /// `[a, b, c]`, all > 0.
        semi_axes: [f64; 3],
    },
    /// The axis-aligned superquadric `|x/a|^n + |y/b|^n + |z/c|^n = 1`
    /// relative to `centre`: n = 2 is the ellipsoid, large n approaches a
    /// box, n = 1 is an octahedron and n < 1 has creases and spikes.
    Superquadric {
        /// Centre point.
        centre: [f64; 3],
        /// `[a, b, c]`, all > 0.
        semi_axes: [f64; 3],
        /// `n`, > 0.
        exponent: f64,
    },
    /// The infinite circular cylinder of `radius` about the line through
    /// `point` along `axis`.
    Cylinder {
        /// A point on the axis.
        point: [f64; 3],
        /// A non-zero axis direction (its sign does not matter).
        axis: [f64; 3],
        /// Radius, > 0.
        radius: f64,
    },
    /// The lateral surface `r = R(z)`, `z0 ≤ z ≤ z1`, of revolution about the
    /// vertical line through `axis_point`, where `r` is the distance from
    /// that line; e.g. a horn `radius = "0.3 + 0.5*z^2"`.
    Revolution {
        /// `R(z)` as an expression in `z` (see [`crate::expr`]); must be
        /// positive on `z_range`.
        radius: String,
        /// `[z0, z1]` with `z0 < z1`.
        z_range: [f64; 2],
        /// `[x, y]` of the axis (default `[0, 0]`).
        #[serde(default)]
        axis_point: [f64; 2],
    },
}

impl SurfaceSpec {
    /// The `type` name of this spec, as written in case files.
    pub fn type_name(&self) -> &'static str {
        match self {
            SurfaceSpec::Plane { .. } => "plane",
            SurfaceSpec::Sphere { .. } => "sphere",
            SurfaceSpec::Ellipsoid { .. } => "ellipsoid",
            SurfaceSpec::Superquadric { .. } => "superquadric",
            SurfaceSpec::Cylinder { .. } => "cylinder",
            SurfaceSpec::Revolution { .. } => "revolution",
        }
    }

    /// Validates the parameters and builds the queryable surface.
    pub fn build(&self) -> Result<Surface, GeometryError> {
        let v = Validator(self.type_name());
        let kind = match self {
            SurfaceSpec::Plane { point, normal } => {
                v.finite_point("point", *point)?;
                v.nonzero_vector("normal", *normal)?;
                Kind::Plane(Plane {
                    point: *point,
                    normal: unit(*normal),
                })
            }
            SurfaceSpec::Sphere { centre, radius } => {
                v.finite_point("centre", *centre)?;
                v.positive("radius", *radius)?;
                Kind::Sphere(Sphere { centre: *centre, radius: *radius })
            }
            SurfaceSpec::Ellipsoid { centre, semi_axes } => {
                v.finite_point("centre", *centre)?;
                v.semi_axes(*semi_axes)?;
                Kind::Ellipsoid(Ellipsoid {
                    centre: *centre,
                    semi_axes: *semi_axes,
                })
            }
            SurfaceSpec::Superquadric {
                centre,
                semi_axes,
                exponent,
            } => {
                v.finite_point("centre", *centre)?;
                v.semi_axes(*semi_axes)?;
                v.positive("exponent", *exponent)?;
                Kind::Superquadric(Superquadric::new(*centre, *semi_axes, *exponent))
            }
            SurfaceSpec::Cylinder {
                point,
                axis,
                radius,
            } => {
                v.finite_point("point", *point)?;
                v.nonzero_vector("axis", *axis)?;
                v.positive("radius", *radius)?;
                Kind::Cylinder(Cylinder {
                    point: *point,
                    axis: unit(*axis),
                    radius: *radius,
                })
            }
            SurfaceSpec::Revolution {
                radius,
                z_range,
                axis_point,
            } => Kind::Revolution(Revolution::new(&v, radius, *z_range, *axis_point)?),
        };
        Ok(Surface { kind })
    }
}

/// A validated target surface, ready for geometric queries. Cheap to share
/// between threads (`Send + Sync`); queries do not mutate it.
#[derive(Debug, Clone)]
pub struct Surface {
    kind: Kind,
}

#[derive(Debug, Clone)]
enum Kind {
    Plane(Plane),
    Sphere(Sphere),
    Ellipsoid(Ellipsoid),
    Superquadric(Superquadric),
    Cylinder(Cylinder),
    Revolution(Revolution),
}

impl ClosestPoint<3> for Surface {
    /// The point of the surface closest to `p` (for a surface of
    /// revolution possibly on its end circles). Where several points are
    /// equally close, e.g. `p` at a sphere's centre or on a cylinder's
    /// axis, one of them is returned.
    fn closest_point(&self, p: [f64; 3]) -> [f64; 3] {
        match &self.kind {
            Kind::Plane(s) => s.closest(p),
            Kind::Sphere(s) => s.closest(p),
            Kind::Ellipsoid(s) => s.closest(p),
            Kind::Superquadric(s) => s.closest(p),
            Kind::Cylinder(s) => s.closest(p),
            Kind::Revolution(s) => s.point(s.closest_param(p)),
        }
    }

    /// Unit outward normal of the surface at the point closest to `p` (see
    /// the module docs). On a crease or spike of a superquadric with
    /// exponent ≤ 1 one of the one-sided normals is returned.
    fn normal(&self, p: [f64; 3]) -> [f64; 3] {
        match &self.kind {
            Kind::Plane(s) => s.normal,
            Kind::Sphere(s) => s.normal_at(s.closest(p)),
            Kind::Ellipsoid(s) => s.normal_at(s.closest(p)),
            Kind::Superquadric(s) => s.normal_at(s.closest(p)),
            Kind::Cylinder(s) => s.normal_at(s.closest(p)),
            Kind::Revolution(s) => s.normal_at(s.closest_param(p)),
        }
    }

    /// The first point where the ray `origin + s·dir`, `s > 0`, meets the
    /// surface, or `None` if it misses (or `dir` is zero). A ray starting on
    /// the surface does not report its own origin. Exact for planes,
    /// spheres, ellipsoids, cylinders and superquadrics seen from their
    /// centre; otherwise the first crossing is bracketed by sampling the
    /// ray and refined to full precision with Brent's method.
    fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        if dot(dir, dir) == 0.0 || !dir.iter().chain(&origin).all(|x| x.is_finite()) {
            return None;
        }
        match &self.kind {
            Kind::Plane(s) => s.ray_hit(origin, dir),
            Kind::Sphere(s) => s.ray_hit(origin, dir),
            Kind::Ellipsoid(s) => s.ray_hit(origin, dir),
            Kind::Superquadric(s) => s.ray_hit(origin, dir),
            Kind::Cylinder(s) => s.ray_hit(origin, dir),
            Kind::Revolution(s) => s.ray_hit(origin, dir),
        }
    }
}

impl Surface {
    /// Whether the surface is closed (sphere, ellipsoid, superquadric).
    /// Planes, cylinders and surfaces of revolution are open.
    pub fn is_closed(&self) -> bool {
        matches!(
            self.kind,
            Kind::Sphere(_) | Kind::Ellipsoid(_) | Kind::Superquadric(_)
        )
    }
}

#[cfg(test)]
#[path = "surface_tests.rs"]
mod tests;
