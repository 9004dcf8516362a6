//! 3D target surfaces that boundary faces of a hex mesh are deformed onto.
//!
//! A [`SurfaceSpec`] is what a case file says (deserialised with serde,
//! tagged by `type`); [`SurfaceSpec::build`] validates it and precomputes
//! what the queries need, giving a [`Surface`].
//!
//! Conventions shared by every surface:
//! * [`Surface::normal`] is the unit *outward* normal at the closest point:
//!   away from the inside of closed surfaces (sphere, ellipsoid,
//!   superquadric), away from the axis for the cylinder and surfaces of
//!   revolution, and along the spec's `normal` for a plane.
//! * Points returned by [`Surface::closest_point`] and [`Surface::ray_hit`]
//!   are produced by evaluating the surface (a projection in closed form or
//!   a parametrisation), so they lie on it to machine precision even where
//!   the search that located them was numeric.
//! * A surface of revolution is only its lateral surface (no end caps);
//!   its closest points clamp to the `z_range`.

use crate::expr::Expr;
use crate::numeric::{add, brent_root, dot, norm, ray_s_min, scale, sub, unit, EPS};
use serde::Deserialize;
use std::f64::consts::TAU;



/// Intervals of the z sampling of a surface of revolution: the radius
/// expression is checked for positivity at these samples, and they bracket
/// the numeric closest-point and ray searches.
const REVOLUTION_SAMPLES: usize = 4096;

/// Cells per cube face of the direction grid whose surface points seed the
/// superquadric closest-point search (6·(m+1)² seeds).
const SUPERQUADRIC_SEED_CELLS: usize = 12;

/// Samples along the crease curves of a superquadric with exponent ≤ 1.
const CREASE_SAMPLES: usize = 128;

/// Samples along a ray's chord through the superquadric's bounding box when
/// bracketing its first crossing numerically.
const SUPERQUADRIC_RAY_SAMPLES: usize = 512;

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

/// An invalid surface specification: which parameter of which surface, and
/// why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{surface}: parameter `{parameter}` {reason}")]
pub struct SurfaceError {
    /// The surface type, e.g. `"sphere"`.
    pub surface: &'static str,
    /// The offending parameter, e.g. `"radius"` or `"semi_axes[2]"`.
    pub parameter: String,
    /// What is wrong with it, e.g. `"must be > 0 (got -1)"`.
    pub reason: String,
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
    pub fn build(&self) -> Result<Surface, SurfaceError> {
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
                Kind::Sphere(Sphere {
                    centre: *centre,
                    radius: *radius,
                })
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

/// Builds [`SurfaceError`]s for one surface type.
struct Validator(&'static str);

impl Validator {
    fn error(&self, parameter: &str, reason: impl Into<String>) -> SurfaceError {
        SurfaceError {
            surface: self.0,
            parameter: parameter.to_string(),
            reason: reason.into(),
        }
    }

    fn finite(&self, name: &str, x: f64) -> Result<(), SurfaceError> {
        if x.is_finite() {
            Ok(())
        } else {
            Err(self.error(name, format!("must be a finite number (got {x})")))
        }
    }

    fn finite_point<const N: usize>(&self, name: &str, p: [f64; N]) -> Result<(), SurfaceError> {
        if p.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(self.error(name, format!("must have finite coordinates (got {p:?})")))
        }
    }

    fn positive(&self, name: &str, x: f64) -> Result<(), SurfaceError> {
        self.finite(name, x)?;
        if x > 0.0 {
            Ok(())
        } else {
            Err(self.error(name, format!("must be > 0 (got {x})")))
        }
    }

    fn nonzero_vector(&self, name: &str, v: [f64; 3]) -> Result<(), SurfaceError> {
        self.finite_point(name, v)?;
        // `norm` could overflow to infinity for huge finite components, and
        // a normalised direction is what the queries use.
        if v == [0.0; 3] || !norm(v).is_finite() {
            return Err(self.error(name, format!("must be a non-zero vector (got {v:?})")));
        }
        Ok(())
    }

    fn semi_axes(&self, e: [f64; 3]) -> Result<(), SurfaceError> {
        for (k, x) in e.iter().enumerate() {
            self.positive(&format!("semi_axes[{k}]"), *x)?;
        }
        Ok(())
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

impl Surface {
    /// The point of the surface closest to `p` (for a surface of
    /// revolution possibly on its end circles). Where several points are
    /// equally close, e.g. `p` at a sphere's centre or on a cylinder's
    /// axis, one of them is returned.
    pub fn closest_point(&self, p: [f64; 3]) -> [f64; 3] {
        match &self.kind {
            Kind::Plane(s) => s.closest(p),
            Kind::Sphere(s) => s.closest(p),
            Kind::Ellipsoid(s) => s.closest(p),
            Kind::Superquadric(s) => s.closest(p),
            Kind::Cylinder(s) => s.closest(p),
            Kind::Revolution(s) => s.point(s.closest_param(p)),
        }
    }

    /// Euclidean distance from `p` to the surface, `|p − closest_point(p)|`.
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        norm(sub(p, self.closest_point(p)))
    }

    /// Unit outward normal of the surface at the point closest to `p` (see
    /// the module docs). On a crease or spike of a superquadric with
    /// exponent ≤ 1 one of the one-sided normals is returned.
    pub fn normal(&self, p: [f64; 3]) -> [f64; 3] {
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
    pub fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
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

    /// Whether the surface is closed (sphere, ellipsoid, superquadric).
    /// Planes, cylinders and surfaces of revolution are open.
    pub fn is_closed(&self) -> bool {
        matches!(
            self.kind,
            Kind::Sphere(_) | Kind::Ellipsoid(_) | Kind::Superquadric(_)
        )
    }
}

// ---------------------------------------------------------------------------
// Small vector helpers.







fn dist2(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = sub(a, b);
    dot(d, d)
}

/// Two unit vectors completing unit `n` to an orthonormal basis, without a
/// branch on the nearest axis (Duff et al., "Building an orthonormal basis,
/// revisited", 2017).
fn orthonormal_basis(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let s = 1.0f64.copysign(n[2]);
    let a = -1.0 / (s + n[2]);
    let b = n[0] * n[1] * a;
    (
        [1.0 + s * n[0] * n[0] * a, s * b, -s * n[0]],
        [b, s + n[1] * n[1] * a, -n[1]],
    )
}


/// Roots `s1 <= s2` of `|o + s·d| = 1`, computed without cancellation, or
/// `None` if the line misses the unit sphere (or `d` is zero).
fn unit_sphere_roots(o: [f64; 3], d: [f64; 3]) -> Option<(f64, f64)> {
    let a = dot(d, d);
    let b = dot(o, d);
    let c = dot(o, o) - 1.0;
    let disc = b * b - a * c;
    if disc < 0.0 || a == 0.0 {
        return None;
    }
    // q has the sign of -b, so q/a and c/q avoid subtracting close numbers.
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return Some((0.0, 0.0)); // o on the sphere and d tangent
    }
    let (r1, r2) = (q / a, c / q);
    Some((r1.min(r2), r1.max(r2)))
}

// ---------------------------------------------------------------------------
// Closed-form surfaces.

/// Infinite plane through `point` with unit `normal`.
#[derive(Debug, Clone)]
struct Plane {
    point: [f64; 3],
    normal: [f64; 3],
}

impl Plane {
    fn closest(&self, p: [f64; 3]) -> [f64; 3] {
        sub(p, scale(dot(sub(p, self.point), self.normal), self.normal))
    }

    fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        let denom = dot(dir, self.normal);
        if denom == 0.0 {
            return None; // parallel (or within the plane): no single crossing
        }
        let s = dot(sub(self.point, origin), self.normal) / denom;
        let s_min = ray_s_min(origin, dir, self.point, 0.0);
        // Project the hit so it lies on the plane to machine precision.
        (s > s_min).then(|| self.closest(add(origin, scale(s, dir))))
    }
}

/// Sphere.
#[derive(Debug, Clone)]
struct Sphere {
    centre: [f64; 3],
    radius: f64,
}

impl Sphere {
    /// Radial projection; the centre itself maps to the point along +x.
    fn closest(&self, p: [f64; 3]) -> [f64; 3] {
        let v = sub(p, self.centre);
        let len = norm(v);
        if len == 0.0 {
            return add(self.centre, [self.radius, 0.0, 0.0]);
        }
        add(self.centre, scale(self.radius / len, v))
    }

    fn normal_at(&self, q: [f64; 3]) -> [f64; 3] {
        unit(sub(q, self.centre))
    }

    fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        let s_min = ray_s_min(origin, dir, self.centre, self.radius);
        let (s1, s2) = unit_sphere_roots(
            scale(1.0 / self.radius, sub(origin, self.centre)),
            scale(1.0 / self.radius, dir),
        )?;
        let s = [s1, s2].into_iter().find(|s| *s > s_min)?;
        Some(self.closest(add(origin, scale(s, dir))))
    }
}

/// Infinite circular cylinder about the line through `point` along unit
/// `axis`.
#[derive(Debug, Clone)]
struct Cylinder {
    point: [f64; 3],
    axis: [f64; 3],
    radius: f64,
}

impl Cylinder {
    /// Splits `p − point` into its component along the axis and the rest.
    fn split(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let v = sub(p, self.point);
        let t = dot(v, self.axis);
        (t, sub(v, scale(t, self.axis)))
    }

    /// Radial projection away from the axis; points on the axis go in an
    /// arbitrary (but fixed) perpendicular direction.
    fn closest(&self, p: [f64; 3]) -> [f64; 3] {
        let (t, perp) = self.split(p);
        let len = norm(perp);
        let dir = if len == 0.0 {
            orthonormal_basis(self.axis).0
        } else {
            scale(1.0 / len, perp)
        };
        add(
            self.point,
            add(scale(t, self.axis), scale(self.radius, dir)),
        )
    }

    fn normal_at(&self, q: [f64; 3]) -> [f64; 3] {
        unit(self.split(q).1)
    }

    fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        // Only the components across the axis matter; scaled by the radius
        // the cross-section is the unit circle and `s` is unchanged.
        let (_, o) = self.split(origin);
        let d = sub(dir, scale(dot(dir, self.axis), self.axis));
        let k = 1.0 / self.radius;
        let (s1, s2) = unit_sphere_roots(scale(k, o), scale(k, d))?;
        let s_min = ray_s_min(
            origin,
            dir,
            add(
                self.point,
                scale(dot(sub(origin, self.point), self.axis), self.axis),
            ),
            self.radius,
        );
        let s = [s1, s2].into_iter().find(|s| *s > s_min)?;
        Some(self.closest(add(origin, scale(s, dir))))
    }
}

/// Axis-aligned ellipsoid.
#[derive(Debug, Clone)]
struct Ellipsoid {
    centre: [f64; 3],
    semi_axes: [f64; 3],
}

impl Ellipsoid {
    /// Closest point: Eberly's bisection in local coordinates, then a radial
    /// rescale onto `Σ (x/e)² = 1` so the result is on the surface to the
    /// last bit (the rescale moves it by round-off only).
    fn closest(&self, p: [f64; 3]) -> [f64; 3] {
        let e = self.semi_axes;
        let x = closest_on_axis_ellipsoid(e, sub(p, self.centre));
        let level = (0..3).map(|k| (x[k] / e[k]).powi(2)).sum::<f64>().sqrt();
        add(self.centre, scale(1.0 / level, x))
    }

    /// Outward normal at a point on the ellipsoid: the implicit gradient.
    fn normal_at(&self, q: [f64; 3]) -> [f64; 3] {
        let x = sub(q, self.centre);
        let e = self.semi_axes;
        unit([
            x[0] / (e[0] * e[0]),
            x[1] / (e[1] * e[1]),
            x[2] / (e[2] * e[2]),
        ])
    }

    fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        // In coordinates scaled by the semi-axes the ellipsoid is the unit
        // sphere and the ray parameter s is unchanged.
        let e = self.semi_axes;
        let stretch = |v: [f64; 3]| [v[0] / e[0], v[1] / e[1], v[2] / e[2]];
        let (s1, s2) = unit_sphere_roots(stretch(sub(origin, self.centre)), stretch(dir))?;
        let size = e[0].max(e[1]).max(e[2]);
        let s_min = ray_s_min(origin, dir, self.centre, size);
        let s = [s1, s2].into_iter().find(|s| *s > s_min)?;
        // Project the world-space hit back onto the surface along its
        // normal: it moves less across the ray than rescaling in stretched
        // coordinates, which matters for flat ellipsoids.
        Some(self.closest(add(origin, scale(s, dir))))
    }
}

/// Closest point on the axis-aligned ellipsoid `Σ (x_k/e_k)² = 1` to local
/// `q`, by Eberly's robust bisection ("Distance from a point to an
/// ellipse, an ellipsoid, or a hyperellipsoid").
fn closest_on_axis_ellipsoid(e: [f64; 3], q: [f64; 3]) -> [f64; 3] {
    // Eberly's method wants the semi-axes in decreasing order and the point
    // in the first octant; undo both at the end.
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| e[j].total_cmp(&e[i]));
    let es = order.map(|k| e[k]);
    let ys = order.map(|k| q[k].abs());
    let xs = eberly_octant(es, ys);
    let mut x = [0.0; 3];
    for (slot, &k) in order.iter().enumerate() {
        x[k] = xs[slot].copysign(q[k]);
    }
    x
}

/// Eberly's case analysis for `e0 ≥ e1 ≥ e2 > 0` and `y ≥ 0`: the general
/// case is a 1-D root, points on a coordinate plane reduce to an ellipse.
fn eberly_octant(e: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    let [e0, e1, e2] = e;
    let [y0, y1, y2] = y;
    if y2 > 0.0 {
        if y1 > 0.0 {
            if y0 > 0.0 {
                let z = [y0 / e0, y1 / e1, y2 / e2];
                let g = z[0] * z[0] + z[1] * z[1] + z[2] * z[2] - 1.0;
                if g == 0.0 {
                    return y;
                }
                let r = [(e0 / e2).powi(2), (e1 / e2).powi(2)];
                let s = eberly_root3(r, z, g);
                return [
                    r[0] * y0 / (s + r[0]),
                    r[1] * y1 / (s + r[1]),
                    y2 / (s + 1.0),
                ];
            }
            let [x1, x2] = eberly_first_quadrant(e1, e2, y1, y2);
            return [0.0, x1, x2];
        }
        if y0 > 0.0 {
            let [x0, x2] = eberly_first_quadrant(e0, e2, y0, y2);
            return [x0, 0.0, x2];
        }
        return [0.0, 0.0, e2];
    }
    // On the plane of the smallest axis: the closest point is either in
    // that plane or, for points inside near the centre, off it.
    let (d0, d1) = (e0 * e0 - e2 * e2, e1 * e1 - e2 * e2);
    let (n0, n1) = (e0 * y0, e1 * y1);
    if n0 < d0 && n1 < d1 {
        let (xd0, xd1) = (n0 / d0, n1 / d1);
        let disc = 1.0 - xd0 * xd0 - xd1 * xd1;
        if disc > 0.0 {
            return [e0 * xd0, e1 * xd1, e2 * disc.sqrt()];
        }
    }
    let [x0, x1] = eberly_first_quadrant(e0, e1, y0, y1);
    [x0, x1, 0.0]
}

/// Bisection for the root of Eberly's monotone function in 3D; converges to
/// the last representable bit.
fn eberly_root3(r: [f64; 2], z: [f64; 3], g: f64) -> f64 {
    let (n0, n1) = (r[0] * z[0], r[1] * z[1]);
    let mut lo = z[2] - 1.0;
    let mut hi = if g < 0.0 {
        0.0
    } else {
        n0.hypot(n1).hypot(z[2]) - 1.0
    };
    let f = |s: f64| {
        let (a, b, c) = (n0 / (s + r[0]), n1 / (s + r[1]), z[2] / (s + 1.0));
        a * a + b * b + c * c - 1.0
    };
    bisect_decreasing(&f, &mut lo, &mut hi)
}

/// The 2D ellipse case `(x/e0)² + (y/e1)² = 1`, `e0 ≥ e1`, for `y ≥ 0`.
fn eberly_first_quadrant(e0: f64, e1: f64, y0: f64, y1: f64) -> [f64; 2] {
    if y1 > 0.0 {
        if y0 > 0.0 {
            let (z0, z1) = (y0 / e0, y1 / e1);
            let g = z0 * z0 + z1 * z1 - 1.0;
            if g == 0.0 {
                return [y0, y1];
            }
            let r0 = (e0 / e1) * (e0 / e1);
            let n0 = r0 * z0;
            let mut lo = z1 - 1.0;
            let mut hi = if g < 0.0 { 0.0 } else { n0.hypot(z1) - 1.0 };
            let f = |s: f64| {
                let (a, b) = (n0 / (s + r0), z1 / (s + 1.0));
                a * a + b * b - 1.0
            };
            let s = bisect_decreasing(&f, &mut lo, &mut hi);
            return [r0 * y0 / (s + r0), y1 / (s + 1.0)];
        }
        return [0.0, e1];
    }
    // On the major axis: the vertex or, for points near the centre, off
    // the axis.
    let (numer, denom) = (e0 * y0, e0 * e0 - e1 * e1);
    if numer < denom {
        let xde = numer / denom;
        return [e0 * xde, e1 * (1.0 - xde * xde).max(0.0).sqrt()];
    }
    [e0, 0.0]
}

/// Bisection for the root of a decreasing function on `[lo, hi]`, until the
/// midpoint is no longer representable between the ends.
fn bisect_decreasing(f: &dyn Fn(f64) -> f64, lo: &mut f64, hi: &mut f64) -> f64 {
    let mut s = *lo;
    for _ in 0..2000 {
        s = 0.5 * (*lo + *hi);
        if s == *lo || s == *hi {
            break;
        }
        let g = f(s);
        if g > 0.0 {
            *lo = s;
        } else if g < 0.0 {
            *hi = s;
        } else {
            break;
        }
    }
    s
}

// ---------------------------------------------------------------------------
// One-dimensional numerics.


/// Brent's derivative-free minimiser on `[a, b]` (as in Numerical Recipes'
/// `brent`), returning `(x, f(x))`. The tolerance is a few ulps of `x`
/// plus `abs_tol` rather than the textbook √ε: our squared distances vanish
/// at on-surface points, so their minimisers are resolved much better.
fn brent_min(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64, abs_tol: f64) -> (f64, f64) {
    const CGOLD: f64 = 0.381_966_011_250_105_1;
    let mut x = a + CGOLD * (b - a);
    let (mut w, mut v) = (x, x);
    let mut fx = f(x);
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..300 {
        let xm = 0.5 * (a + b);
        let tol1 = 2.0 * EPS * x.abs() + abs_tol;
        let tol2 = 2.0 * tol1;
        if (x - xm).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            // Try a parabola through x, w, v.
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            e = d;
            if p.abs() < (0.5 * q * etemp).abs() && p > q * (a - x) && p < q * (b - x) {
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = tol1.copysign(xm - x);
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= xm { a - x } else { b - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let fu = f(u);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, fv) = (w, fw);
            (w, fw) = (x, fx);
            (x, fx) = (u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv) = (w, fw);
                (w, fw) = (u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (x, fx)
}

/// The first sign change of `f` on `[lo, hi]` sampled at `count` equal
/// steps, refined with Brent's method. A zero sample counts as a crossing
/// unless it is the very first one (the ray's start touching the surface).
/// Where the samples dip towards zero without changing sign, the dip is
/// minimised too: a ray clipping a thin edge or spike of the surface
/// between two samples crosses it twice there.
fn first_crossing(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64, count: usize) -> Option<f64> {
    let at = |k: usize| {
        if k == count {
            hi
        } else {
            lo + (hi - lo) * k as f64 / count as f64
        }
    };
    let mut prev: Option<(f64, f64)> = None;
    let mut a = (lo, f(lo));
    for k in 1..=count {
        let b = (at(k), f(at(k)));
        if b.1 == 0.0 {
            return Some(b.0);
        }
        if !(a.1.is_finite() && b.1.is_finite()) {
            (prev, a) = (None, b);
            continue;
        }
        if let Some(p) = prev {
            if let Some(s) = dip_crossing(f, p, a, b) {
                return Some(s);
            }
        }
        if a.1 != 0.0 && (a.1 > 0.0) != (b.1 > 0.0) {
            return Some(brent_root(f, a.0, b.0, a.1, b.1));
        }
        (prev, a) = (Some(a), b);
    }
    None
}

/// If `a` is a local minimum of `|f|` among three samples `p`, `a`, `b` of
/// one sign, minimises `σf` (σ that sign) on `[p, b]`; when the minimum
/// has the other sign, returns the first root, between `p` and it.
fn dip_crossing(
    f: &dyn Fn(f64) -> f64,
    p: (f64, f64),
    a: (f64, f64),
    b: (f64, f64),
) -> Option<f64> {
    let sigma = a.1.signum();
    let same_sign = a.1 != 0.0 && p.1.signum() == sigma && b.1.signum() == sigma;
    if !same_sign || sigma * p.1 < sigma * a.1 || sigma * b.1 < sigma * a.1 {
        return None;
    }
    let g = |s: f64| sigma * f(s);
    let (sm, gm) = brent_min(&g, p.0, b.0, EPS * (p.0.abs() + b.0.abs()));
    (gm < 0.0).then(|| brent_root(f, p.0, sm, p.1, f(sm)))
}

// ---------------------------------------------------------------------------
// Superquadric.

/// Superquadric `|x/a|^n + |y/b|^n + |z/c|^n = 1` about `centre`.
///
/// It is star-shaped about its centre, and `N(w) = (Σ |w_k/a_k|^n)^(1/n)`
/// is positively homogeneous of degree 1, so `w / N(w)` projects any
/// non-zero local vector radially onto the surface. That projection is the
/// parametrisation every numeric query evaluates, so results are on the
/// surface to machine precision.
#[derive(Debug, Clone)]
struct Superquadric {
    centre: [f64; 3],
    a: [f64; 3],
    n: f64,
    /// Largest semi-axis: the length scale.
    size: f64,
    /// Local surface points on a coarse direction grid, seeding the search.
    seeds: Vec<[f64; 3]>,
}

/// Directions through the grid points of the cube `[-1, 1]³`'s faces,
/// `cells` cells a side (not normalised; edge points repeat).
fn cube_directions(cells: usize) -> Vec<[f64; 3]> {
    let mut dirs = Vec::with_capacity(6 * (cells + 1) * (cells + 1));
    for axis in 0..3 {
        for side in [-1.0, 1.0] {
            for i in 0..=cells {
                for j in 0..=cells {
                    let mut w = [0.0; 3];
                    w[axis] = side;
                    w[(axis + 1) % 3] = -1.0 + 2.0 * i as f64 / cells as f64;
                    w[(axis + 2) % 3] = -1.0 + 2.0 * j as f64 / cells as f64;
                    dirs.push(w);
                }
            }
        }
    }
    dirs
}

/// A step `d` in the local chart of the superquadric's Newton iteration,
/// with the gradient of `½|P − q|²` at the chart's origin.
struct Step {
    d: [f64; 2],
    grad: [f64; 2],
    /// Whether `d` came from the (positive definite) Hessian, not
    /// Gauss-Newton.
    newton: bool,
}

/// One evaluation of the local chart `(α, β) ↦ P(x + α e1 + β e2)` used by
/// the superquadric's Newton iteration.
struct ChartPoint {
    /// Jacobian columns `∂P/∂α`, `∂P/∂β`.
    jac: [[f64; 3]; 2],
    /// Gradient of `½|P − q|²` with respect to `(α, β)`.
    grad: [f64; 2],
}

impl Superquadric {
    fn new(centre: [f64; 3], a: [f64; 3], n: f64) -> Superquadric {
        let mut s = Superquadric {
            centre,
            a,
            n,
            size: a[0].max(a[1]).max(a[2]),
            seeds: vec![],
        };
        s.seeds = cube_directions(SUPERQUADRIC_SEED_CELLS)
            .into_iter()
            .map(|w| s.project(w))
            .collect();
        s
    }

    /// `N(w) = (Σ |w_k/a_k|^n)^(1/n)`, with the largest term factored out
    /// so that large `n` neither overflows nor underflows.
    fn radial_norm(&self, w: [f64; 3]) -> f64 {
        let t = [0, 1, 2].map(|k| (w[k] / self.a[k]).abs());
        let big = t[0].max(t[1]).max(t[2]);
        if big == 0.0 {
            return 0.0;
        }
        let sum: f64 = t.iter().map(|x| (x / big).powf(self.n)).sum();
        big * sum.powf(1.0 / self.n)
    }

    /// Radial projection of a non-zero local vector onto the surface.
    fn project(&self, w: [f64; 3]) -> [f64; 3] {
        scale(1.0 / self.radial_norm(w), w)
    }

    /// `∇N(w)`; infinite on a coordinate plane when `n < 1` (the creases).
    fn grad_norm(&self, w: [f64; 3], nw: f64) -> [f64; 3] {
        [0, 1, 2].map(|k| {
            let t = (w[k] / self.a[k]).abs() / nw;
            w[k].signum() / self.a[k] * t.powf(self.n - 1.0)
        })
    }

    /// Outward normal direction (not unit) at local point `x` on the
    /// surface, from the implicit gradient. For n < 1 the gradient is
    /// multiplied by `Π |x_k/a_k|^(1−n)`, which removes its poles on the
    /// creases and leaves one of the one-sided normals there.
    fn normal_dir(&self, x: [f64; 3]) -> [f64; 3] {
        let t = [0, 1, 2].map(|k| (x[k] / self.a[k]).abs());
        let m = 1.0 - self.n;
        [0, 1, 2].map(|k| {
            let s = x[k].signum() / self.a[k];
            if self.n >= 1.0 {
                s * t[k].powf(self.n - 1.0)
            } else {
                s * t[(k + 1) % 3].powf(m) * t[(k + 2) % 3].powf(m)
            }
        })
    }

    /// Unit outward normal at `q` on the surface. At a spike tip (n < 1),
    /// where every one-sided normal is across the spike, the spike's own
    /// direction is returned instead, the limit of the normals of the
    /// surrounding smooth surface seen from outside it.
    fn normal_at(&self, q: [f64; 3]) -> [f64; 3] {
        let x = sub(q, self.centre);
        let nd = self.normal_dir(x);
        if nd != [0.0; 3] {
            return unit(nd);
        }
        let t = [0, 1, 2].map(|k| (x[k] / self.a[k]).abs());
        let k = (0..3).fold(0, |b, k| if t[k] > t[b] { k } else { b });
        let mut axis = [0.0; 3];
        axis[k] = 1.0f64.copysign(x[k]);
        axis
    }

    fn closest(&self, p: [f64; 3]) -> [f64; 3] {
        add(self.centre, self.closest_local(sub(p, self.centre)))
    }

    /// Closest point to local `q`: the best of Newton refinements on the
    /// smooth part of the surface, seeded by the radial projection of `q`
    /// and by the nearest coarse grid points (so a far point or one near
    /// the centre does not settle for a worse local minimum), and, when
    /// n ≤ 1, the best points on the creases, where the surface is not
    /// smooth and a minimum need not be stationary.
    fn closest_local(&self, q: [f64; 3]) -> [f64; 3] {
        let mut best = ([0.0; 3], f64::INFINITY);
        let mut consider = |x: [f64; 3]| {
            let d = dist2(x, q);
            if d < best.1 {
                best = (x, d);
            }
        };
        if q != [0.0; 3] {
            let radial = self.project(q);
            consider(radial);
            consider(self.refine_patch(q, radial));
        }
        for seed in self.nearest_seeds(q) {
            consider(self.refine_patch(q, seed));
        }
        if self.n <= 1.0 {
            for k in 0..3 {
                consider(self.crease_closest(q, k));
                let mut tip = [0.0; 3];
                tip[k] = self.a[k];
                consider(tip);
                tip[k] = -self.a[k];
                consider(tip);
            }
        }
        best.0
    }

    /// The three seed points nearest to `q`.
    fn nearest_seeds(&self, q: [f64; 3]) -> Vec<[f64; 3]> {
        let mut top = [(f64::INFINITY, [0.0; 3]); 3];
        for s in &self.seeds {
            let d = dist2(*s, q);
            if d < top[2].0 {
                top[2] = (d, *s);
                top.sort_by(|x, y| x.0.total_cmp(&y.0));
            }
        }
        top.iter()
            .filter(|t| t.0.is_finite())
            .map(|t| t.1)
            .collect()
    }

    /// Evaluates the chart about `x` (tangent basis `e`) at `(α, β)`, or
    /// `None` where the parametrisation is not differentiable (a crease).
    fn chart(
        &self,
        q: [f64; 3],
        x: [f64; 3],
        e: [[f64; 3]; 2],
        ab: [f64; 2],
    ) -> Option<ChartPoint> {
        let w = add(x, add(scale(ab[0], e[0]), scale(ab[1], e[1])));
        let nw = self.radial_norm(w);
        let point = scale(1.0 / nw, w);
        let g = self.grad_norm(w, nw);
        // d(w/N) = (dw − P (∇N·dw)) / N
        let jac = e.map(|ek| scale(1.0 / nw, sub(ek, scale(dot(g, ek), point))));
        let r = sub(point, q);
        let grad = [dot(r, jac[0]), dot(r, jac[1])];
        let finite = grad.iter().chain(&point).all(|v| v.is_finite());
        finite.then_some(ChartPoint { jac, grad })
    }

    /// Damped Newton minimisation of `|P − q|²` over the surface from the
    /// on-surface local point `seed`, in a chart re-centred at every step:
    /// `P(x + α e1 + β e2)` with `e1`, `e2` tangent at `x` (never parallel
    /// to the radial direction, the surface being star-shaped). The Hessian
    /// is a central difference of the analytic gradient, accurate enough for
    /// fast convergence while the gradient fixes the stationary point to
    /// machine precision. Where the Hessian is not positive definite the
    /// Gauss-Newton matrix is used instead; steps are capped and halved
    /// until the distance decreases.
    fn refine_patch(&self, q: [f64; 3], seed: [f64; 3]) -> [f64; 3] {
        let h = 1e-6 * self.size;
        let mut x = seed;
        let mut g = dist2(x, q);
        for _ in 0..100 {
            let nd = self.normal_dir(x);
            if !nd.iter().all(|v| v.is_finite()) || nd == [0.0; 3] {
                break;
            }
            let (e1, e2) = orthonormal_basis(unit(nd));
            let e = [e1, e2];
            let Some(step) = self.newton_step(q, x, e, h) else {
                break;
            };
            let Some((next, gn)) = self.line_search(q, x, e, step, g) else {
                break; // no decrease: converged to round-off
            };
            let moved = norm(sub(next, x));
            (x, g) = (next, gn);
            if moved <= 4.0 * EPS * (self.size + g.sqrt()) {
                break;
            }
        }
        x
    }

    /// The Newton (or Gauss-Newton) step in the chart about `x`, capped at
    /// half the surface size, and the gradient it was computed from.
    fn newton_step(&self, q: [f64; 3], x: [f64; 3], e: [[f64; 3]; 2], h: f64) -> Option<Step> {
        let c = self.chart(q, x, e, [0.0, 0.0])?;
        let px = self.chart(q, x, e, [h, 0.0])?;
        let mx = self.chart(q, x, e, [-h, 0.0])?;
        let py = self.chart(q, x, e, [0.0, h])?;
        let my = self.chart(q, x, e, [0.0, -h])?;
        let h11 = (px.grad[0] - mx.grad[0]) / (2.0 * h);
        let h22 = (py.grad[1] - my.grad[1]) / (2.0 * h);
        let h12 = 0.25 * (px.grad[1] - mx.grad[1] + py.grad[0] - my.grad[0]) / h;
        let newton = h11 > 0.0 && h11 * h22 - h12 * h12 > 0.0;
        let [m11, m12, m22] = if newton {
            [h11, h12, h22]
        } else {
            let [j1, j2] = c.jac;
            [dot(j1, j1), dot(j1, j2), dot(j2, j2)]
        };
        let det = m11 * m22 - m12 * m12;
        if det.is_nan() || det <= 0.0 {
            return None;
        }
        let mut d = [
            -(m22 * c.grad[0] - m12 * c.grad[1]) / det,
            -(m11 * c.grad[1] - m12 * c.grad[0]) / det,
        ];
        let len = d[0].hypot(d[1]);
        let cap = 0.5 * self.size;
        if len > cap {
            d = [d[0] * cap / len, d[1] * cap / len];
        }
        Some(Step {
            d,
            grad: c.grad,
            newton,
        })
    }

    /// Backtracking along the step: the first fraction giving sufficient
    /// decrease (Armijo) of the squared distance `g`. The Armijo test keeps
    /// Newton from bouncing across a coordinate plane where the surface's
    /// curvature is unbounded (1 < n < 2), where it would otherwise swap
    /// sides forever. Near the minimum the distance can no longer resolve
    /// the last digits that the gradient still can, so there a small full
    /// Newton step is accepted first if it at least halves the gradient.
    fn line_search(
        &self,
        q: [f64; 3],
        x: [f64; 3],
        e: [[f64; 3]; 2],
        step: Step,
        g: f64,
    ) -> Option<([f64; 3], f64)> {
        let d = step.d;
        let at = |t: f64| self.project(add(x, add(scale(t * d[0], e[0]), scale(t * d[1], e[1]))));
        if step.newton && d[0].hypot(d[1]) <= 1e-4 * self.size {
            let c = self.chart(q, x, e, d)?;
            if c.grad[0].hypot(c.grad[1]) <= 0.5 * step.grad[0].hypot(step.grad[1]) {
                let cand = at(1.0);
                return Some((cand, dist2(cand, q)));
            }
        }
        // Rate of change of g = |P − q|² along d (twice that of ½|P − q|²).
        let slope = 2.0 * (step.grad[0] * d[0] + step.grad[1] * d[1]);
        let mut t = 1.0;
        for _ in 0..50 {
            let cand = at(t);
            let gc = dist2(cand, q);
            if gc <= g + 0.25 * t * slope && gc.is_finite() {
                return Some((cand, gc));
            }
            t *= 0.5;
        }
        None
    }

    /// Closest point to local `q` on the crease curve `x_k = 0` (a
    /// superellipse in the other two coordinates), parametrised by polar
    /// angle: best sample, then Brent's minimiser between its neighbours.
    fn crease_closest(&self, q: [f64; 3], k: usize) -> [f64; 3] {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let point = |phi: f64| {
            let mut w = [0.0; 3];
            (w[j], w[i]) = phi.sin_cos();
            self.project(w)
        };
        let f = |phi: f64| dist2(point(phi), q);
        let step = TAU / CREASE_SAMPLES as f64;
        let best = (0..CREASE_SAMPLES).map(|m| (m, f(m as f64 * step))).fold(
            (0, f64::INFINITY),
            |acc, x| if x.1 < acc.1 { x } else { acc },
        );
        let centre = best.0 as f64 * step;
        let (phi, d) = brent_min(&f, centre - step, centre + step, EPS);
        if d < best.1 {
            point(phi)
        } else {
            point(centre)
        }
    }

    fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        let o = sub(origin, self.centre);
        if norm(o) <= 1e-15 * self.size {
            // From the centre the hit is the radial projection of `dir`.
            return Some(add(self.centre, self.project(dir)));
        }
        // The surface lies in the box |x_k| ≤ a_k: only the ray's chord
        // through it needs searching.
        let (mut lo, mut hi) = (
            ray_s_min(origin, dir, self.centre, self.size),
            f64::INFINITY,
        );
        for k in 0..3 {
            if dir[k] == 0.0 {
                if o[k].abs() > self.a[k] {
                    return None;
                }
                continue;
            }
            let (s1, s2) = ((-self.a[k] - o[k]) / dir[k], (self.a[k] - o[k]) / dir[k]);
            lo = lo.max(s1.min(s2));
            hi = hi.min(s1.max(s2));
        }
        if lo >= hi || lo.is_nan() || hi.is_nan() {
            return None;
        }
        let f = |s: f64| self.radial_norm(add(o, scale(s, dir))) - 1.0;
        let s = first_crossing(&f, lo, hi, SUPERQUADRIC_RAY_SAMPLES)?;
        Some(add(self.centre, self.project(add(o, scale(s, dir)))))
    }
}

// ---------------------------------------------------------------------------
// Surface of revolution.

/// Lateral surface `r = R(z)`, `z0 ≤ z ≤ z1`, about the vertical line through
/// `axis`. Points are `(axis + R(z)(cos θ, sin θ), z)`; every query reduces
/// to the meridian half-plane `(r, z)` of the query point.
#[derive(Debug, Clone)]
struct Revolution {
    radius: Expr,
    axis: [f64; 2],
    z0: f64,
    z1: f64,
    /// `z` at the sample points, `z0` to `z1` inclusive.
    zs: Vec<f64>,
    /// `R` at the sample points.
    rs: Vec<f64>,
    /// Largest sampled radius.
    r_max: f64,
}

/// A point of a surface of revolution: height and the direction of its
/// meridian half-plane.
#[derive(Debug, Clone, Copy)]
struct Meridian {
    z: f64,
    cos: f64,
    sin: f64,
}

impl Revolution {
    fn new(
        v: &Validator,
        text: &str,
        z_range: [f64; 2],
        axis: [f64; 2],
    ) -> Result<Revolution, SurfaceError> {
        v.finite_point("axis_point", axis)?;
        v.finite_point("z_range", z_range)?;
        let [z0, z1] = z_range;
        if z0 >= z1 {
            return Err(v.error(
                "z_range",
                format!("must be increasing, [z0, z1] with z0 < z1 (got {z_range:?})"),
            ));
        }
        let radius = Expr::parse(text, &["z"])
            .map_err(|e| v.error("radius", format!("is not a valid expression in z: {e}")))?;
        let n = REVOLUTION_SAMPLES;
        let zs: Vec<f64> = (0..=n)
            .map(|k| {
                if k == n {
                    z1
                } else {
                    z0 + (z1 - z0) * k as f64 / n as f64
                }
            })
            .collect();
        let mut rs = Vec::with_capacity(zs.len());
        for &z in &zs {
            let r = radius.eval(&[z]);
            if !(r > 0.0 && r.is_finite()) {
                let reason = format!("must be finite and > 0 on z_range (got R = {r} at z = {z})");
                return Err(v.error("radius", reason));
            }
            rs.push(r);
        }
        let r_max = rs.iter().copied().fold(0.0, f64::max);
        Ok(Revolution {
            radius,
            axis,
            z0,
            z1,
            zs,
            rs,
            r_max,
        })
    }

    fn r(&self, z: f64) -> f64 {
        self.radius.eval(&[z])
    }

    /// `R'(z)` by differentiating the quartic through five samples `h`
    /// apart, shifted to stay inside `[z0, z1]` (the expression need not be
    /// valid outside). Accurate to ~1e-12 relative for smooth `R`.
    fn dr(&self, z: f64) -> f64 {
        let h = 1e-3 * (self.z1 - self.z0);
        let zc = z.clamp(self.z0 + 2.0 * h, self.z1 - 2.0 * h);
        let t = (z - zc) / h;
        let nodes = [-2.0, -1.0, 0.0, 1.0, 2.0];
        let mut sum = 0.0;
        for (k, &xk) in nodes.iter().enumerate() {
            // Derivative at t of the Lagrange basis polynomial of node k.
            let mut lk = 0.0;
            for (m, &xm) in nodes.iter().enumerate() {
                if m == k {
                    continue;
                }
                let mut prod = 1.0 / (xk - xm);
                for (l, &xl) in nodes.iter().enumerate() {
                    if l != k && l != m {
                        prod *= (t - xl) / (xk - xl);
                    }
                }
                lk += prod;
            }
            sum += self.r(zc + xk * h) * lk;
        }
        sum / h
    }

    fn size(&self) -> f64 {
        (self.z1 - self.z0).max(self.r_max)
    }

    /// Distance from the axis and meridian direction of `p` (the +x
    /// direction when `p` is on the axis).
    fn polar(&self, p: [f64; 3]) -> (f64, f64, f64) {
        let (x, y) = (p[0] - self.axis[0], p[1] - self.axis[1]);
        let rho = x.hypot(y);
        if rho == 0.0 {
            (0.0, 1.0, 0.0)
        } else {
            (rho, x / rho, y / rho)
        }
    }

    fn point(&self, m: Meridian) -> [f64; 3] {
        let r = self.r(m.z);
        [self.axis[0] + r * m.cos, self.axis[1] + r * m.sin, m.z]
    }

    fn normal_at(&self, m: Meridian) -> [f64; 3] {
        // The meridian (R(z), z) has tangent (R', 1); rotated away from the
        // axis, (1, −R').
        unit([m.cos, m.sin, -self.dr(m.z)])
    }

    /// Closest point in the meridian half-plane of `p`: minimise
    /// `h(z) = (ρ − R(z))² + (z_p − z)²` over `[z0, z1]`. The samples give
    /// the best few local minima (and the range ends as candidates); each
    /// is refined as the sign change of `h'/2 = (R − ρ)R' + (z − z_p)`,
    /// which pins `z` down far better than minimising `h` itself, falling
    /// back to Brent's minimiser where the bracket shows no such change.
    fn closest_param(&self, p: [f64; 3]) -> Meridian {
        let (rho, cos, sin) = self.polar(p);
        let zp = p[2];
        let h = |z: f64| (rho - self.r(z)).powi(2) + (zp - z).powi(2);
        let hs: Vec<f64> = self
            .zs
            .iter()
            .zip(&self.rs)
            .map(|(&z, &r)| (rho - r).powi(2) + (zp - z).powi(2))
            .collect();
        let mut best = if hs[0] <= hs[hs.len() - 1] {
            (self.z0, hs[0])
        } else {
            (self.z1, hs[hs.len() - 1])
        };
        for i in best_local_minima(&hs) {
            let (lo, hi) = (
                self.zs[i.saturating_sub(1)],
                self.zs[(i + 1).min(hs.len() - 1)],
            );
            let z = self.refine_meridian(rho, zp, lo, hi);
            let hz = h(z);
            if hz < best.1 {
                best = (z, hz);
            }
        }
        // A minimum at an end is approached but never evaluated by the
        // refinement, which may then beat the exact end by round-off only:
        // snap to the end, so end-circle points are exactly on it.
        let snap = 8.0 * EPS * (self.z0.abs().max(self.z1.abs()) + self.size());
        let z = if best.0 - self.z0 <= snap {
            self.z0
        } else if self.z1 - best.0 <= snap {
            self.z1
        } else {
            best.0
        };
        Meridian { z, cos, sin }
    }

    fn refine_meridian(&self, rho: f64, zp: f64, lo: f64, hi: f64) -> f64 {
        let g = |z: f64| (self.r(z) - rho) * self.dr(z) + (z - zp);
        let (glo, ghi) = (g(lo), g(hi));
        if glo < 0.0 && ghi > 0.0 {
            return brent_root(&g, lo, hi, glo, ghi);
        }
        // h' = 2g keeps one sign on the bracket: the minimum is at an end
        // (typically the surface's end circle), which a minimiser would
        // only approach to about √ε
        if glo <= 0.0 && ghi <= 0.0 {
            return hi;
        }
        if glo >= 0.0 && ghi >= 0.0 {
            return lo;
        }
        let h = |z: f64| (rho - self.r(z)).powi(2) + (zp - z).powi(2);
        brent_min(&h, lo, hi, EPS * self.size()).0
    }

    fn ray_hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<[f64; 3]> {
        let (lo, hi) = self.ray_window(origin, dir)?;
        let o = [origin[0] - self.axis[0], origin[1] - self.axis[1]];
        let at = |s: f64| {
            let z = (origin[2] + s * dir[2]).clamp(self.z0, self.z1);
            ((o[0] + s * dir[0]).hypot(o[1] + s * dir[1]), z)
        };
        let f = |s: f64| {
            let (rho, z) = at(s);
            rho - self.r(z)
        };
        // Sample finely enough to follow R's z samples and to resolve the
        // cross-section's scale across the axis.
        let span_z = (hi - lo) * dir[2].abs() / (self.z1 - self.z0);
        let span_r = (hi - lo) * dir[0].hypot(dir[1]) / self.r_max;
        let count = (64.0 + REVOLUTION_SAMPLES as f64 * span_z + 256.0 * span_r).min(16384.0);
        let s = first_crossing(&f, lo, hi, count as usize)?;
        let hit = add(origin, scale(s, dir));
        let (_, cos, sin) = self.polar(hit);
        Some(self.point(Meridian {
            z: at(s).1,
            cos,
            sin,
        }))
    }

    /// The range of ray parameters `s > s_min` where the ray is inside the
    /// slab `z0 ≤ z ≤ z1` and close enough to the axis to meet the surface
    /// (within a margin over the largest sampled radius).
    fn ray_window(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<(f64, f64)> {
        let reference = [self.axis[0], self.axis[1], 0.5 * (self.z0 + self.z1)];
        let mut lo = ray_s_min(origin, dir, reference, self.size());
        let mut hi = f64::INFINITY;
        if dir[2] == 0.0 {
            if origin[2] < self.z0 || origin[2] > self.z1 {
                return None;
            }
        } else {
            let (s1, s2) = (
                (self.z0 - origin[2]) / dir[2],
                (self.z1 - origin[2]) / dir[2],
            );
            lo = lo.max(s1.min(s2));
            hi = hi.min(s1.max(s2));
        }
        let bound = 1.05 * self.r_max;
        let o = [origin[0] - self.axis[0], origin[1] - self.axis[1], 0.0];
        let d = [dir[0], dir[1], 0.0];
        if dot(d, d) == 0.0 {
            if norm(o) > bound {
                return None;
            }
        } else {
            let (s1, s2) = unit_sphere_roots(scale(1.0 / bound, o), scale(1.0 / bound, d))?;
            lo = lo.max(s1);
            hi = hi.min(s2);
        }
        (lo < hi && hi.is_finite()).then_some((lo, hi))
    }
}

/// Indices of up to three smallest local minima of `values` (ties with a
/// neighbour count), smallest first.
fn best_local_minima(values: &[f64]) -> Vec<usize> {
    let n = values.len();
    let mut top: Vec<usize> = Vec::with_capacity(4);
    for i in 0..n {
        let left = i == 0 || values[i] <= values[i - 1];
        let right = i + 1 == n || values[i] <= values[i + 1];
        if left && right {
            top.push(i);
            top.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
            top.truncate(3);
        }
    }
    top
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use proptest::test_runner::{Config, TestRunner};

    fn spec(toml_text: &str) -> SurfaceSpec {
        #[derive(Deserialize)]
        struct Case {
            shape: SurfaceSpec,
        }
        toml::from_str::<Case>(toml_text).unwrap().shape
    }

    fn build(toml_text: &str) -> Surface {
        spec(toml_text).build().unwrap()
    }

    /// A property-test runner with a fixed seed: CI sees the same cases on
    /// every run (a failure is reproducible, never flaky).
    fn runner(cases: u32) -> TestRunner {
        let config = Config { cases, failure_persistence: None, ..Config::default() };
        let rng = proptest::test_runner::TestRng::deterministic_rng(config.rng_algorithm);
        TestRunner::new_with_rng(config, rng)
    }

    /// The test surfaces, with a length scale and a reference "centre" each.
    fn surfaces() -> Vec<(&'static str, Surface, f64, [f64; 3])> {
        let specs = [
            (
                "plane",
                r#"shape = { type = "plane", point = [0.1, 0.2, -0.3], normal = [1.0, -2.0, 0.5] }"#,
                1.0,
                [0.1, 0.2, -0.3],
            ),
            (
                "sphere",
                r#"shape = { type = "sphere", centre = [0.3, -0.2, 0.1], radius = 1.25 }"#,
                1.25,
                [0.3, -0.2, 0.1],
            ),
            (
                "ellipsoid",
                r#"shape = { type = "ellipsoid", centre = [0.1, 0.2, 0.3], semi_axes = [2.0, 0.7, 1.2] }"#,
                2.0,
                [0.1, 0.2, 0.3],
            ),
            (
                "flat ellipsoid",
                r#"shape = { type = "ellipsoid", centre = [0.0, 0.0, 0.0], semi_axes = [0.5, 3.0, 0.1] }"#,
                3.0,
                [0.0; 3],
            ),
            (
                "superquadric 4",
                r#"shape = { type = "superquadric", centre = [0.2, 0.0, -0.1], semi_axes = [1.5, 1.0, 0.8], exponent = 4 }"#,
                1.5,
                [0.2, 0.0, -0.1],
            ),
            (
                "superquadric 1.5",
                r#"shape = { type = "superquadric", centre = [0.0, 0.0, 0.0], semi_axes = [1.0, 2.0, 1.0], exponent = 1.5 }"#,
                2.0,
                [0.0; 3],
            ),
            (
                "superquadric 10",
                r#"shape = { type = "superquadric", centre = [0.0, 0.0, 0.0], semi_axes = [2.0, 1.0, 1.0], exponent = 10 }"#,
                2.0,
                [0.0; 3],
            ),
            (
                "superquadric 0.8",
                r#"shape = { type = "superquadric", centre = [0.0, 0.0, 0.0], semi_axes = [1.0, 1.0, 1.0], exponent = 0.8 }"#,
                1.0,
                [0.0; 3],
            ),
            (
                "cylinder",
                r#"shape = { type = "cylinder", point = [0.1, -0.2, 0.0], axis = [1.0, 1.0, 2.0], radius = 0.8 }"#,
                0.8,
                [0.1, -0.2, 0.0],
            ),
            (
                "horn",
                r#"shape = { type = "revolution", radius = "0.3 + 0.5*z^2", z_range = [-1.0, 1.5] }"#,
                1.5,
                [0.0, 0.0, 0.25],
            ),
            (
                "vase",
                r#"shape = { type = "revolution", radius = "1 + 0.3*sin(3*z)", z_range = [0.0, 3.0], axis_point = [0.5, -0.5] }"#,
                3.0,
                [0.5, -0.5, 1.5],
            ),
        ];
        specs
            .into_iter()
            .map(|(name, text, size, c)| (name, build(text), size, c))
            .collect()
    }

    /// A dense grid of surface points (rows of a 2-D parameter grid) from a
    /// parametrisation written independently of the implementation, and
    /// the largest distance between grid neighbours.
    fn dense(s: &Surface, m: usize) -> (Vec<[f64; 3]>, f64) {
        let mut grids: Vec<Vec<Vec<[f64; 3]>>> = vec![];
        let u = |k: usize| k as f64 / m as f64;
        match &s.kind {
            Kind::Plane(p) => {
                let (e1, e2) = orthonormal_basis(p.normal);
                grids.push(
                    (0..=m)
                        .map(|i| {
                            (0..=m)
                                .map(|j| {
                                    add(
                                        p.point,
                                        add(
                                            scale(16.0 * u(i) - 8.0, e1),
                                            scale(16.0 * u(j) - 8.0, e2),
                                        ),
                                    )
                                })
                                .collect()
                        })
                        .collect(),
                );
            }
            Kind::Cylinder(c) => {
                let (e1, e2) = orthonormal_basis(c.axis);
                grids.push(
                    (0..=m)
                        .map(|i| {
                            (0..=m)
                                .map(|j| {
                                    let (sn, cs) = (TAU * u(j)).sin_cos();
                                    let ring =
                                        add(scale(c.radius * cs, e1), scale(c.radius * sn, e2));
                                    add(c.point, add(scale(16.0 * u(i) - 8.0, c.axis), ring))
                                })
                                .collect()
                        })
                        .collect(),
                );
            }
            Kind::Revolution(r) => {
                grids.push(
                    (0..=4 * m)
                        .map(|i| {
                            (0..=m / 2)
                                .map(|j| {
                                    let z = r.z0 + (r.z1 - r.z0) * i as f64 / (4 * m) as f64;
                                    let rad = r.radius.eval(&[z]);
                                    let (sn, cs) = (TAU * 2.0 * j as f64 / m as f64).sin_cos();
                                    [r.axis[0] + rad * cs, r.axis[1] + rad * sn, z]
                                })
                                .collect()
                        })
                        .collect(),
                );
            }
            _ => {
                // Closed surfaces: a cube-sphere of directions mapped by the
                // naive implicit formulas.
                let (centre, a, n) = match &s.kind {
                    Kind::Sphere(x) => (x.centre, [x.radius; 3], 2.0),
                    Kind::Ellipsoid(x) => (x.centre, x.semi_axes, 2.0),
                    Kind::Superquadric(x) => (x.centre, x.a, x.n),
                    _ => unreachable!(),
                };
                for axis in 0..3 {
                    for side in [-1.0, 1.0] {
                        grids.push(
                            (0..=m)
                                .map(|i| {
                                    (0..=m)
                                        .map(|j| {
                                            let mut w = [0.0; 3];
                                            w[axis] = side;
                                            // tan spacing evens out the cube-sphere cells
                                            w[(axis + 1) % 3] = (std::f64::consts::FRAC_PI_4
                                                * (2.0 * u(i) - 1.0))
                                                .tan();
                                            w[(axis + 2) % 3] = (std::f64::consts::FRAC_PI_4
                                                * (2.0 * u(j) - 1.0))
                                                .tan();
                                            let f: f64 =
                                                (0..3).map(|k| (w[k] / a[k]).abs().powf(n)).sum();
                                            add(centre, scale(f.powf(-1.0 / n), w))
                                        })
                                        .collect()
                                })
                                .collect(),
                        );
                    }
                }
            }
        }
        let mut spacing: f64 = 0.0;
        for g in &grids {
            for i in 0..g.len() {
                for j in 0..g[i].len() {
                    if i + 1 < g.len() {
                        spacing = spacing.max(norm(sub(g[i + 1][j], g[i][j])));
                    }
                    if j + 1 < g[i].len() {
                        spacing = spacing.max(norm(sub(g[i][j + 1], g[i][j])));
                    }
                }
            }
        }
        (grids.into_iter().flatten().flatten().collect(), spacing)
    }

    fn brute_distance(pts: &[[f64; 3]], p: [f64; 3]) -> f64 {
        pts.iter()
            .map(|q| dist2(*q, p))
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    }

    /// Signed side of `p` (negative inside / below / nearer the axis), from
    /// the naive formulas, for brute-force ray checks; `None` outside a
    /// surface of revolution's slab.
    fn side(s: &Surface, p: [f64; 3]) -> Option<f64> {
        Some(match &s.kind {
            Kind::Plane(x) => dot(sub(p, x.point), x.normal),
            Kind::Sphere(x) => norm(sub(p, x.centre)) - x.radius,
            Kind::Ellipsoid(x) => {
                let v = sub(p, x.centre);
                (0..3).map(|k| (v[k] / x.semi_axes[k]).powi(2)).sum::<f64>() - 1.0
            }
            Kind::Superquadric(x) => {
                let v = sub(p, x.centre);
                (0..3)
                    .map(|k| (v[k] / x.a[k]).abs().powf(x.n))
                    .sum::<f64>()
                    .powf(1.0 / x.n)
                    - 1.0
            }
            Kind::Cylinder(x) => norm(x.split(p).1) - x.radius,
            Kind::Revolution(x) => {
                if p[2] < x.z0 || p[2] > x.z1 {
                    return None;
                }
                (p[0] - x.axis[0]).hypot(p[1] - x.axis[1]) - x.radius.eval(&[p[2]])
            }
        })
    }

    // ---- specs and validation ------------------------------------------

    #[test]
    fn toml_sphere_deserialises() {
        let s = spec(r#"shape = { type = "sphere", centre = [0.0, 0.0, 0.0], radius = 1.25 }"#);
        assert_eq!(
            s,
            SurfaceSpec::Sphere {
                centre: [0.0; 3],
                radius: 1.25
            }
        );
        // Integers are accepted for floats.
        let s = spec(r#"shape = { type = "sphere", centre = [1, 2, 3], radius = 4 }"#);
        assert_eq!(
            s,
            SurfaceSpec::Sphere {
                centre: [1.0, 2.0, 3.0],
                radius: 4.0
            }
        );
    }

    #[test]
    fn toml_every_type_deserialises() {
        let text = r#"
            [[shape]]
            type = "plane"
            point = [0, 0, 0]
            normal = [0, 0, 2]
            [[shape]]
            type = "ellipsoid"
            centre = [0, 0, 0]
            semi_axes = [2, 1, 0.5]
            [[shape]]
            type = "superquadric"
            centre = [0, 0, 0]
            semi_axes = [2, 1, 1]
            exponent = 4
            [[shape]]
            type = "cylinder"
            point = [0, 0, 0]
            axis = [0, 0, 1]
            radius = 0.5
            [[shape]]
            type = "revolution"
            radius = "0.3 + 0.5*z^2"
            z_range = [0, 1]
            [[shape]]
            type = "revolution"
            radius = "1"
            z_range = [0, 1]
            axis_point = [1, 2]
        "#;
        #[derive(Deserialize)]
        struct Many {
            shape: Vec<SurfaceSpec>,
        }
        let many: Many = toml::from_str(text).unwrap();
        let names: Vec<_> = many.shape.iter().map(|s| s.type_name()).collect();
        assert_eq!(
            names,
            [
                "plane",
                "ellipsoid",
                "superquadric",
                "cylinder",
                "revolution",
                "revolution"
            ]
        );
        assert!(
            matches!(&many.shape[4], SurfaceSpec::Revolution { axis_point, .. } if *axis_point == [0.0, 0.0])
        );
        assert!(
            matches!(&many.shape[5], SurfaceSpec::Revolution { axis_point, .. } if *axis_point == [1.0, 2.0])
        );
        assert!(many.shape.iter().all(|s| s.build().is_ok()));
    }

    #[test]
    fn toml_unknown_field_is_rejected_by_name() {
        #[derive(Debug, Deserialize)]
        #[allow(dead_code)]
        struct Case {
            shape: SurfaceSpec,
        }
        for (text, word) in [
            (
                r#"shape = { type = "sphere", centre = [0, 0, 0], radius = 1, radious = 2 }"#,
                "radious",
            ),
            (
                r#"shape = { type = "plane", point = [0, 0, 0], normal = [0, 0, 1], offset = 2 }"#,
                "offset",
            ),
            (
                r#"shape = { type = "revolution", radius = "1", z_range = [0, 1], axis = [0, 0] }"#,
                "axis",
            ),
            (r#"shape = { type = "torus", centre = [0, 0, 0] }"#, "torus"),
            (
                r#"shape = { type = "sphere", centre = [0, 0, 0] }"#,
                "radius",
            ),
            (
                r#"shape = { type = "sphere", centre = [0, 0], radius = 1 }"#,
                "3",
            ),
        ] {
            let err = toml::from_str::<Case>(text).unwrap_err();
            assert!(err.to_string().contains(word), "{word}: {err}");
        }
    }

    #[test]
    fn invalid_specs_name_the_parameter() {
        let nan = f64::NAN;
        let rev = |radius: &str, z_range: [f64; 2]| SurfaceSpec::Revolution {
            radius: radius.to_string(),
            z_range,
            axis_point: [0.0, 0.0],
        };
        let cases: Vec<(SurfaceSpec, &str, &str)> = vec![
            (
                SurfaceSpec::Plane {
                    point: [0.0; 3],
                    normal: [0.0; 3],
                },
                "normal",
                "non-zero",
            ),
            (
                SurfaceSpec::Plane {
                    point: [nan, 0.0, 0.0],
                    normal: [0.0, 0.0, 1.0],
                },
                "point",
                "finite",
            ),
            (
                SurfaceSpec::Sphere {
                    centre: [0.0; 3],
                    radius: 0.0,
                },
                "radius",
                "> 0",
            ),
            (
                SurfaceSpec::Sphere {
                    centre: [0.0; 3],
                    radius: -1.0,
                },
                "radius",
                "> 0",
            ),
            (
                SurfaceSpec::Sphere {
                    centre: [0.0, f64::INFINITY, 0.0],
                    radius: 1.0,
                },
                "centre",
                "finite",
            ),
            (
                SurfaceSpec::Ellipsoid {
                    centre: [0.0; 3],
                    semi_axes: [1.0, 0.0, 1.0],
                },
                "semi_axes[1]",
                "> 0",
            ),
            (
                SurfaceSpec::Superquadric {
                    centre: [0.0; 3],
                    semi_axes: [1.0, 1.0, -2.0],
                    exponent: 2.0,
                },
                "semi_axes[2]",
                "> 0",
            ),
            (
                SurfaceSpec::Superquadric {
                    centre: [0.0; 3],
                    semi_axes: [1.0; 3],
                    exponent: 0.0,
                },
                "exponent",
                "> 0",
            ),
            (
                SurfaceSpec::Superquadric {
                    centre: [0.0; 3],
                    semi_axes: [1.0; 3],
                    exponent: nan,
                },
                "exponent",
                "finite",
            ),
            (
                SurfaceSpec::Cylinder {
                    point: [0.0; 3],
                    axis: [0.0; 3],
                    radius: 1.0,
                },
                "axis",
                "non-zero",
            ),
            (
                SurfaceSpec::Cylinder {
                    point: [0.0; 3],
                    axis: [0.0, 0.0, 1.0],
                    radius: 0.0,
                },
                "radius",
                "> 0",
            ),
            (rev("0.3 + ", [0.0, 1.0]), "radius", "expression"),
            (rev("x + 1", [0.0, 1.0]), "radius", "expression"),
            (rev("z - 0.5", [0.0, 1.0]), "radius", "z = 0"),
            (rev("1 - z", [0.0, 1.0]), "radius", "z = 1"),
            (rev("sqrt(z - 0.25)", [0.0, 1.0]), "radius", "NaN"),
            (rev("1", [1.0, 1.0]), "z_range", "increasing"),
            (rev("1", [2.0, 1.0]), "z_range", "increasing"),
            (rev("1", [0.0, nan]), "z_range", "finite"),
        ];
        for (s, parameter, reason) in cases {
            let err = s.build().unwrap_err();
            assert_eq!(err.parameter, parameter, "{s:?}: {err}");
            assert_eq!(err.surface, s.type_name());
            assert!(err.reason.contains(reason), "{s:?}: {err}");
            assert!(err.to_string().contains(parameter), "{err}");
        }
    }

    #[test]
    fn surface_is_send_sync_clone_debug() {
        fn check<T: Send + Sync + Clone + std::fmt::Debug>() {}
        check::<Surface>();
        check::<SurfaceSpec>();
    }

    // ---- closest points ------------------------------------------------

    fn check_against_brute(
        name: &str,
        s: &Surface,
        pts: &[[f64; 3]],
        spacing: f64,
        size: f64,
        p: [f64; 3],
    ) {
        let q = s.closest_point(p);
        let d = norm(sub(p, q));
        let brute = brute_distance(pts, p);
        assert!(
            d <= brute + 1e-10 * size,
            "{name} {p:?}: {d} vs brute {brute}"
        );
        assert!(d >= brute - spacing, "{name} {p:?}: {d} vs brute {brute}");
        assert_eq!(s.distance(p), d);
        // On the surface (to round-off).
        let on = side(s, q).unwrap_or(0.0);
        assert!(
            on.abs() <= 1e-13 * size.max(1.0) * 10.0,
            "{name} {p:?}: closest {q:?} off by {on}"
        );
    }

    #[test]
    fn closest_points_match_brute_force() {
        for (name, s, size, c) in surfaces() {
            let (pts, spacing) = dense(&s, 160);
            let far = -3.0 * size..3.0 * size;
            runner(64)
                .run(&(far.clone(), far.clone(), far), |(x, y, z)| {
                    check_against_brute(name, &s, &pts, spacing, size, add(c, [x, y, z]));
                    Ok(())
                })
                .unwrap();
            // Near the surface, where wrong branches are most tempting.
            let near = -0.2 * size..0.2 * size;
            runner(64)
                .run(
                    &(0..pts.len(), near.clone(), near.clone(), near),
                    |(k, x, y, z)| {
                        // The sampled plane and cylinder are finite patches:
                        // stay away from their artificial edges.
                        let infinite = matches!(s.kind, Kind::Plane(_) | Kind::Cylinder(_));
                        if infinite && norm(sub(pts[k], c)) > 5.0 {
                            return Ok(());
                        }
                        check_against_brute(name, &s, &pts, spacing, size, add(pts[k], [x, y, z]));
                        Ok(())
                    },
                )
                .unwrap();
        }
    }

    #[test]
    fn far_point_beyond_the_end_lands_on_the_end_circle() {
        // found by a property test: the minimum over the profile is at the
        // end z = 3, which a 1-D minimiser only approached
        let (_, s, _, _) = surfaces().into_iter().find(|t| t.0 == "vase").unwrap();
        let q = s.closest_point([3.1691866210463657, -5.338795922123056, 6.617925167670109]);
        assert_eq!(q[2], 3.0);
    }

    #[test]
    fn closest_point_is_stationary() {
        // p − q is along the normal at q (first-order optimality), away
        // from superquadric creases and revolution end circles.
        for (name, s, size, c) in surfaces() {
            let box_ = -2.0 * size..2.0 * size;
            runner(100)
                .run(&(box_.clone(), box_.clone(), box_), |(x, y, z)| {
                    let p = add(c, [x, y, z]);
                    let q = s.closest_point(p);
                    let n = s.normal(p);
                    let r = sub(p, q);
                    let tangential = sub(r, scale(dot(r, n), n));
                    let at_end =
                        matches!(&s.kind, Kind::Revolution(v) if q[2] == v.z0 || q[2] == v.z1);
                    // For n < 2 the curvature is unbounded on the coordinate
                    // planes; a closest point within ~(offset)² of one is
                    // located to ~1e-8 there, not to round-off.
                    let singular = matches!(&s.kind, Kind::Superquadric(x) if x.n < 2.0);
                    let at_crease = singular && (0..3).any(|k| (q[k] - c[k]).abs() < 1e-6 * size);
                    prop_assert!(
                        at_end || at_crease || norm(tangential) <= 1e-10 * size,
                        "{name} {p:?}: tangential residual {}",
                        norm(tangential)
                    );
                    Ok(())
                })
                .unwrap();
        }
    }

    #[test]
    fn surface_points_are_fixed_points() {
        for (name, s, size, _) in surfaces() {
            let (pts, _) = dense(&s, 40);
            for q in pts {
                let c = s.closest_point(q);
                assert!(
                    norm(sub(c, q)) <= 1e-13 * size.max(norm(q)),
                    "{name} {q:?} -> {c:?} ({})",
                    norm(sub(c, q))
                );
            }
        }
    }

    #[test]
    fn superquadric_of_exponent_two_is_the_ellipsoid() {
        let e = build(
            r#"shape = { type = "ellipsoid", centre = [0.1, 0.2, 0.3], semi_axes = [2.0, 0.7, 1.2] }"#,
        );
        let sq = build(
            r#"shape = { type = "superquadric", centre = [0.1, 0.2, 0.3], semi_axes = [2.0, 0.7, 1.2], exponent = 2 }"#,
        );
        runner(300)
            .run(&(-4.0..4.0, -4.0..4.0, -4.0..4.0), |(x, y, z)| {
                let p = [x, y, z];
                let (a, b) = (e.closest_point(p), sq.closest_point(p));
                prop_assert!(norm(sub(a, b)) < 1e-9, "{p:?}: {a:?} vs {b:?}");
                prop_assert!((e.distance(p) - sq.distance(p)).abs() < 1e-12);
                prop_assert!(norm(sub(e.normal(p), sq.normal(p))) < 1e-8);
                let d = [y - x, z + 0.5, 1.0];
                let (ha, hb) = (e.ray_hit(p, d), sq.ray_hit(p, d));
                prop_assert_eq!(ha.is_some(), hb.is_some());
                if let (Some(ha), Some(hb)) = (ha, hb) {
                    prop_assert!(norm(sub(ha, hb)) < 1e-9, "{ha:?} vs {hb:?}");
                }
                Ok(())
            })
            .unwrap();
    }

    #[test]
    fn special_points() {
        let sphere = build(r#"shape = { type = "sphere", centre = [1.0, 0.0, 0.0], radius = 2 }"#);
        assert_eq!(sphere.closest_point([1.0, 0.0, 0.0]), [3.0, 0.0, 0.0]);
        assert_eq!(sphere.closest_point([1.0, 0.0, 5.0]), [1.0, 0.0, 2.0]);
        assert_eq!(sphere.normal([1.0, 0.0, 5.0]), [0.0, 0.0, 1.0]);
        assert!(sphere.is_closed());

        let plane = build(
            r#"shape = { type = "plane", point = [0.0, 0.0, 1.0], normal = [0.0, 0.0, -3.0] }"#,
        );
        assert_eq!(plane.closest_point([2.0, 3.0, 7.0]), [2.0, 3.0, 1.0]);
        assert_eq!(plane.normal([2.0, 3.0, 7.0]), [0.0, 0.0, -1.0]);
        assert!(!plane.is_closed());

        let cyl = build(
            r#"shape = { type = "cylinder", point = [0.0, 0.0, 0.0], axis = [0.0, 0.0, -2.0], radius = 1.5 }"#,
        );
        assert_eq!(cyl.closest_point([3.0, 0.0, 7.0]), [1.5, 0.0, 7.0]);
        assert_eq!(cyl.normal([3.0, 0.0, 7.0]), [1.0, 0.0, 0.0]);
        let on_axis = cyl.closest_point([0.0, 0.0, 4.0]);
        assert!((norm([on_axis[0], on_axis[1], 0.0]) - 1.5).abs() < 1e-15 && on_axis[2] == 4.0);
        assert!(!cyl.is_closed());

        let ell = build(
            r#"shape = { type = "ellipsoid", centre = [0.0, 0.0, 0.0], semi_axes = [3.0, 2.0, 1.0] }"#,
        );
        assert_eq!(ell.closest_point([0.0, 0.0, 0.0]), [0.0, 0.0, 1.0]);
        assert_eq!(ell.closest_point([5.0, 0.0, 0.0]), [3.0, 0.0, 0.0]);
        assert_eq!(ell.closest_point([0.0, -5.0, 0.0]), [0.0, -2.0, 0.0]);

        // A horn clamps to its ends: beyond z1 the nearest point is on the
        // top circle, and points on the axis get the +x meridian.
        let horn = build(
            r#"shape = { type = "revolution", radius = "0.3 + 0.5*z^2", z_range = [0.0, 1.0] }"#,
        );
        let top = horn.closest_point([0.8, 0.0, 3.0]);
        assert_eq!(top, [0.8, 0.0, 1.0]);
        let bottom = horn.closest_point([0.0, -0.3, -2.0]);
        assert!(norm(sub(bottom, [0.0, -0.3, 0.0])) < 1e-15, "{bottom:?}");
        let axis = horn.closest_point([0.0, 0.0, 0.0]);
        assert!(norm(sub(axis, [0.3, 0.0, 0.0])) < 1e-12, "{axis:?}");
        assert!(!horn.is_closed());
        // Normal of a horn: outward, tilted down where it widens upward.
        let expect = unit([1.0, 0.0, -0.5]); // R'(0.5) = 0.5
        let p = add([0.425, 0.0, 0.5], scale(0.1, expect));
        let n = horn.normal(p);
        assert!(norm(sub(n, expect)) < 1e-12, "{n:?}");
        assert!(norm(sub(horn.closest_point(p), [0.425, 0.0, 0.5])) < 1e-14);
    }

    #[test]
    fn normals_are_unit_orthogonal_and_outward() {
        for (name, s, size, c) in surfaces() {
            let (pts, _) = dense(&s, 24);
            for q in pts {
                let n = s.normal(q);
                assert!((norm(n) - 1.0).abs() < 1e-14, "{name}: |n| = {}", norm(n));
                if name.contains("0.8") && (0..3).any(|k| (q[k] - c[k]).abs() < 0.05) {
                    continue; // near a crease: no tangent plane to compare with
                }
                // Tangents by finite differences of projections.
                let delta = 1e-7 * size;
                let (t1, t2) = orthonormal_basis(n);
                for t in [t1, t2] {
                    let chord = sub(
                        s.closest_point(add(q, scale(delta, t))),
                        s.closest_point(sub(q, scale(delta, t))),
                    );
                    assert!(
                        dot(unit(chord), n).abs() < 1e-5,
                        "{name} at {q:?}: n {n:?}, chord {chord:?}"
                    );
                }
                // Outward: away from the centre of the convex closed shapes
                // and away from the axis for the open ones.
                let out = match &s.kind {
                    Kind::Plane(p) => dot(n, p.normal) > 0.999_999,
                    Kind::Cylinder(cy) => dot(n, cy.split(q).1) > 0.0,
                    Kind::Revolution(r) => {
                        n[0] * (q[0] - r.axis[0]) + n[1] * (q[1] - r.axis[1]) > 0.0
                    }
                    _ => dot(n, sub(q, c)) > 0.0,
                };
                assert!(out, "{name}: inward normal {n:?} at {q:?}");
            }
        }
    }

    // ---- ray hits ------------------------------------------------------

    /// The first robust sign change of `side` along the ray (both sides
    /// clearly away from zero), by dense sampling up to `s_max`.
    fn brute_ray(s: &Surface, o: [f64; 3], d: [f64; 3], s_max: f64, tol: f64) -> Option<f64> {
        let count = 20_000;
        let mut prev: Option<(f64, f64)> = None;
        for k in 0..=count {
            let t = s_max * k as f64 / count as f64;
            let v = side(s, add(o, scale(t, d)));
            if let (Some((_, a)), Some(b)) = (prev, v) {
                if (a < -tol && b > tol) || (a > tol && b < -tol) {
                    return Some(t);
                }
            }
            prev = v.map(|v| (t, v));
        }
        None
    }

    #[test]
    fn ray_hits_lie_on_surface_and_ray_and_come_first() {
        for (name, s, size, c) in surfaces() {
            let box_ = -2.0 * size..2.0 * size;
            runner(200)
                .run(
                    &(
                        box_.clone(),
                        box_.clone(),
                        box_,
                        -1.0..1.0f64,
                        0.0..TAU,
                        0.1..3.0,
                    ),
                    |(x, y, z, cz, a, len)| {
                        let o = add(c, [x, y, z]);
                        let sz = (1.0 - cz * cz).sqrt();
                        let d = scale(len, [sz * a.cos(), sz * a.sin(), cz]);
                        let s_max = 10.0 * size / len;
                        let hit = s.ray_hit(o, d);
                        if let Some(h) = hit {
                            prop_assert!(
                                s.distance(h) <= 1e-12 * size,
                                "{name}: hit {h:?} off the surface by {}",
                                s.distance(h)
                            );
                            let v = sub(h, o);
                            let t = dot(v, d) / dot(d, d);
                            prop_assert!(t > 0.0);
                            let off = norm(sub(v, scale(t, d)));
                            prop_assert!(
                                off <= 1e-12 * size,
                                "{name}: hit {h:?} off the ray by {off}"
                            );
                            // No robust crossing before it.
                            let before = brute_ray(&s, o, d, t * (1.0 - 1e-6), 1e-9 * size);
                            prop_assert!(
                                before.is_none(),
                                "{name}: crossing at {before:?} before {t}"
                            );
                        } else {
                            let brute = brute_ray(&s, o, d, s_max, 1e-6 * size);
                            prop_assert!(
                                brute.is_none(),
                                "{name}: missed a crossing at {brute:?} from {o:?} along {d:?}"
                            );
                        }
                        Ok(())
                    },
                )
                .unwrap();
        }
    }

    #[test]
    fn rays_from_surface_points_skip_their_origin() {
        for (name, s, size, c) in surfaces() {
            let (pts, _) = dense(&s, 8);
            for o in pts {
                // Through the inside (towards the centre / axis reference).
                let d = sub(c, o);
                if norm(d) < 1e-9 * size {
                    continue;
                }
                if let Some(h) = s.ray_hit(o, d) {
                    assert!(
                        norm(sub(h, o)) > 1e-9 * size,
                        "{name}: hit its own origin {o:?}"
                    );
                }
                if s.is_closed() {
                    assert!(s.ray_hit(o, d).is_some(), "{name}: no far side from {o:?}");
                    assert!(
                        s.ray_hit(o, scale(-1.0, d)).is_none(),
                        "{name}: outward ray hit from {o:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn ray_special_cases() {
        let sphere = build(r#"shape = { type = "sphere", centre = [0.0, 0.0, 0.0], radius = 2 }"#);
        assert_eq!(
            sphere.ray_hit([0.0; 3], [0.0, 0.0, 3.0]),
            Some([0.0, 0.0, 2.0])
        );
        assert_eq!(
            sphere.ray_hit([-5.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
            Some([-2.0, 0.0, 0.0])
        );
        assert_eq!(sphere.ray_hit([5.0, 0.0, 0.0], [1.0, 0.0, 0.0]), None);
        assert_eq!(sphere.ray_hit([0.0; 3], [0.0; 3]), None);
        assert_eq!(
            sphere.ray_hit([2.0, 0.0, 0.0], [-1.0, 0.0, 0.0]),
            Some([-2.0, 0.0, 0.0])
        );

        let plane = build(
            r#"shape = { type = "plane", point = [0.0, 0.0, 1.0], normal = [0.0, 0.0, 1.0] }"#,
        );
        assert_eq!(
            plane.ray_hit([1.0, 2.0, 3.0], [0.0, 0.0, -2.0]),
            Some([1.0, 2.0, 1.0])
        );
        assert_eq!(plane.ray_hit([1.0, 2.0, 3.0], [0.0, 0.0, 2.0]), None);
        assert_eq!(plane.ray_hit([1.0, 2.0, 3.0], [1.0, 0.0, 0.0]), None);
        assert_eq!(plane.ray_hit([1.0, 2.0, 1.0], [0.0, 1.0, -1.0]), None);

        let cyl = build(
            r#"shape = { type = "cylinder", point = [0.0, 0.0, 0.0], axis = [0.0, 0.0, 1.0], radius = 1 }"#,
        );
        assert_eq!(cyl.ray_hit([0.0, 0.0, 5.0], [0.0, 0.0, 1.0]), None);
        assert_eq!(
            cyl.ray_hit([-3.0, 0.0, 5.0], [1.0, 0.0, 0.0]),
            Some([-1.0, 0.0, 5.0])
        );
        assert_eq!(
            cyl.ray_hit([0.0, 0.0, 5.0], [1.0, 0.0, 1.0]),
            Some([1.0, 0.0, 6.0])
        );

        // The horn's lateral surface only: a ray up the axis escapes
        // through the open ends; one across it hits the wall.
        let horn = build(
            r#"shape = { type = "revolution", radius = "0.3 + 0.5*z^2", z_range = [0.0, 1.0] }"#,
        );
        assert_eq!(horn.ray_hit([0.0, 0.0, -1.0], [0.0, 0.0, 1.0]), None);
        let h = horn.ray_hit([-3.0, 0.0, 0.5], [1.0, 0.0, 0.0]).unwrap();
        assert!(norm(sub(h, [-0.425, 0.0, 0.5])) < 1e-14, "{h:?}");
        let h = horn.ray_hit([0.0, 0.0, 0.5], [1.0, 0.0, 0.0]).unwrap();
        assert!(norm(sub(h, [0.425, 0.0, 0.5])) < 1e-14, "{h:?}");
        assert_eq!(horn.ray_hit([0.0, 0.0, 2.0], [1.0, 0.0, 0.0]), None);
    }

    #[test]
    fn superquadric_ray_from_centre_is_exact() {
        let sq = build(
            r#"shape = { type = "superquadric", centre = [0.5, 0.0, -1.0], semi_axes = [2.0, 1.0, 0.5], exponent = 6 }"#,
        );
        for d in [
            [1.0, 0.0, 0.0],
            [0.0, -3.0, 0.0],
            [0.0, 0.0, 0.1],
            [1.0, 1.0, 1.0],
            [-0.3, 0.7, 0.2],
        ] {
            let h = sq.ray_hit([0.5, 0.0, -1.0], d).unwrap();
            let v = sub(h, [0.5, 0.0, -1.0]);
            assert!(norm(sub(unit(v), unit(d))) < 1e-15, "{d:?}: {h:?}");
            assert!(side(&sq, h).unwrap().abs() < 1e-15, "{d:?}: {h:?}");
        }
        assert_eq!(
            sq.ray_hit([0.5, 0.0, -1.0], [1.0, 0.0, 0.0]),
            Some([2.5, 0.0, -1.0])
        );
    }
}
