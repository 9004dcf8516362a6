//! Target shapes that boundary parts of a mesh are deformed onto: curves of
//! the plane (2D meshes) and surfaces of space (3D meshes).
//!
//! A spec ([`ShapeSpec`] in 2D, [`SurfaceSpec`] in 3D) is what a case or
//! geometry file says (deserialised with serde, tagged by `type`); its
//! `build` validates it and precomputes what the queries need, giving a
//! [`Shape`] or a [`Surface`]. A [`LevelSet`] is the zero set of a function
//! in either dimension. All of them answer the same questions through
//! [`ClosestPoint`].
//!
//! One file per shape family (`flat`: lines and planes; `round`: circles,
//! arcs, spheres, cylinders; `ellipse`: ellipses and ellipsoids;
//! `superellipse`: superellipses and superquadrics; `spline`; `revolution`;
//! `level_set`), `parametric` for the sampled curves, and `solvers` for the
//! one-dimensional root finders and projections they share.
//!
//! Conventions shared by every shape:
//! * Points returned by [`ClosestPoint::closest_point`] and
//!   [`ClosestPoint::ray_hit`] are the shape evaluated at some parameter (or
//!   projected onto it in closed form), so they lie on it to machine
//!   precision even where the search that located them was numeric.
//! * The normal is outward for closed shapes; for open ones see
//!   [`Shape`] and [`Surface`].

pub mod cad;
mod curve;
mod ellipse;
pub mod fit;
mod flat;
mod level_set;
mod parametric;
mod revolution;
mod round;
mod solvers;
mod spline;
mod superellipse;
mod surface;

pub use curve::{Shape, ShapeSpec};
pub use level_set::LevelSet;
pub use surface::{Surface, SurfaceSpec};

use crate::numeric::{mix, norm, sub};
use std::any::Any;
use std::sync::Arc;

#[cfg(test)]
mod test_support {
    use super::ClosestPoint;
    use crate::numeric::{dist2, norm, sub};
    use proptest::test_runner::{Config, TestRng, TestRunner};

    /// The spec in a test's `shape = { ... }` line.
    pub fn spec<S: serde::de::DeserializeOwned>(toml_text: &str) -> S {
        let table: toml::Table = toml::from_str(toml_text).unwrap();
        table["shape"].clone().try_into().unwrap()
    }

    /// A property-test runner with a fixed seed: CI sees the same cases on
    /// every run (a failure is reproducible, never flaky).
    pub fn runner(cases: u32) -> TestRunner {
        let config = Config { cases, failure_persistence: None, ..Config::default() };
        let rng = TestRng::deterministic_rng(config.rng_algorithm);
        TestRunner::new_with_rng(config, rng)
    }

    /// The closest point of `shape` to `p`, checked against dense samples
    /// `pts` of the shape, at most `spacing` apart: it must beat (or tie,
    /// within `tol`) every sample, can be no closer than the true distance,
    /// which the samples over-estimate by at most one spacing, and
    /// `distance` must agree with it.
    pub fn closest_against_brute<const D: usize>(name: &str, shape: &dyn ClosestPoint<D>, pts: &[[f64; D]], spacing: f64, tol: f64, p: [f64; D]) -> [f64; D] {
        let q = shape.closest_point(p);
        let d = norm(sub(p, q));
        let brute = pts.iter().map(|x| dist2(*x, p)).fold(f64::INFINITY, f64::min).sqrt();
        assert!(d <= brute + tol, "{name} {p:?}: {d} vs brute {brute}");
        assert!(d >= brute - spacing, "{name} {p:?}: {d} vs brute {brute}");
        assert_eq!(shape.distance(p), d);
        q
    }
}

/// A shape in `D` dimensions as the mesh needs it: `ClosestPoint<2>` for
/// curves of the plane ([`Shape`], [`LevelSet`]), `ClosestPoint<3>` for
/// surfaces of space ([`Surface`], [`LevelSet`]). One trait instantiated
/// per dimension rather than two traits, because the deformation is
/// written once for both dimensions and holds its targets and walls as
/// `dyn ClosestPoint<D>`.
pub trait ClosestPoint<const D: usize>: Send + Sync + std::fmt::Debug {
    /// The point of the shape closest to `p`. Where several points are
    /// equally close (`p` at a circle's centre, say) one of them.
    fn closest_point(&self, p: [f64; D]) -> [f64; D];

    /// [`Self::closest_point`] of each of `ps`, in order. A shape whose
    /// answers cost a call into another library (CAD) answers them
    /// together; the others one by one.
    fn closest_points(&self, ps: &[[f64; D]]) -> Vec<[f64; D]> {
        ps.iter().map(|&p| self.closest_point(p)).collect()
    }

    /// The velocity of the closest point of each of `ps` as the point
    /// moves with velocity `dirs[i]` (the derivative of the foot map),
    /// where the shape knows it in closed form from its parametrisation
    /// (CAD); None where it does not (the caller differentiates the feet
    /// numerically).
    fn foot_speeds(&self, ps: &[[f64; D]], dirs: &[[f64; D]]) -> Vec<Option<[f64; D]>> {
        let _ = dirs;
        vec![None; ps.len()]
    }

    /// Whether its answers are computed one at a time whatever the thread
    /// (a CAD shape: Gmsh's one session, under a lock): callers then ask
    /// from one thread, since threads queueing on the lock only add the
    /// lock's cost (measured on the 5,082-tet torus: 17 % of a run in the
    /// lock's spinning and the scheduler).
    fn serial(&self) -> bool {
        false
    }

    /// The largest distance to the shape of the points `Σ_j w[j] nodes[j]`,
    /// one per row `w` of `weights`: a boundary element's samples, mixed
    /// from its nodes, which lie on the shape. A CAD shape starts each
    /// sample's foot from the same mix of its nodes' feet.
    fn largest_sample_distance(&self, nodes: &[[f64; D]], weights: &[Vec<f64>]) -> f64 {
        let at: Vec<[f64; D]> = weights.iter().map(|w| mix(w, nodes)).collect();
        at.iter().zip(self.closest_points(&at)).map(|(&p, q)| norm(sub(p, q))).fold(0.0, f64::max)
    }

    /// Euclidean distance from `p` to the shape, `|p − closest_point(p)|`.
    fn distance(&self, p: [f64; D]) -> f64 {
        norm(sub(p, self.closest_point(p)))
    }

    /// Unit normal of the shape at the point closest to `p` (outward for
    /// closed shapes; at a corner, crease or cusp one of the one-sided
    /// normals).
    fn normal(&self, p: [f64; D]) -> [f64; D];

    /// The first point where the ray `origin + s·dir`, `s > 0`, meets the
    /// shape, or `None` if it misses (or `dir` is zero). A ray starting on
    /// the shape does not report its own origin.
    fn ray_hit(&self, origin: [f64; D], dir: [f64; D]) -> Option<[f64; D]>;
}

/// The shape a `shape = { type = ... }` table of a case or geometry file
/// describes: a curve ([`ShapeSpec`]) in 2D, a surface ([`SurfaceSpec`]) in
/// 3D. Errors name the field `shape`.
pub fn shape_from_toml<const D: usize>(v: &toml::Value) -> Result<Arc<dyn ClosestPoint<D>>, String> {
    // D is a const generic, so the spec type is chosen at run time and the
    // built shape handed back through `Any`, which checks that it is D's.
    let built: Box<dyn Any> = match D {
        2 => Box::new(Arc::new(spec_from_toml(v, "shape", ShapeSpec::build)?) as Arc<dyn ClosestPoint<2>>),
        3 => Box::new(Arc::new(spec_from_toml(v, "shape", SurfaceSpec::build)?) as Arc<dyn ClosestPoint<3>>),
        _ => Box::new(()),
    };
    built.downcast::<Arc<dyn ClosestPoint<D>>>().map(|b| *b).map_err(|_| format!("field `shape`: there are no shapes in {D} dimensions"))
}

/// A `shape` table read as a spec and validated by `build` (e.g.
/// [`ShapeSpec::build`]); `field` names the table in errors.
pub fn spec_from_toml<S: serde::de::DeserializeOwned, T>(v: &toml::Value, field: &str, build: fn(&S) -> Result<T, GeometryError>) -> Result<T, String> {
    let spec: S = v.clone().try_into().map_err(|e: toml::de::Error| format!("field `{field}`: {}", e.to_string().trim_end()))?;
    build(&spec).map_err(|e| format!("field `{field}`: {e}"))
}

/// An invalid shape specification: which parameter of which shape, and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{shape}: parameter `{parameter}` {reason}")]
pub struct GeometryError {
    /// The shape type, e.g. `"circle"` or `"sphere"`.
    pub shape: &'static str,
    /// The offending parameter, e.g. `"radius"` or `"points[3]"`.
    pub parameter: String,
    /// What is wrong with it, e.g. `"must be > 0 (got -1)"`.
    pub reason: String,
}

/// Builds [`GeometryError`]s for one shape type: the checks every spec's
/// `build` makes of its parameters, in both dimensions.
struct Validator(&'static str);

impl Validator {
    fn error(&self, parameter: &str, reason: impl Into<String>) -> GeometryError {
        GeometryError { shape: self.0, parameter: parameter.to_string(), reason: reason.into() }
    }

    fn finite(&self, name: &str, x: f64) -> Result<(), GeometryError> {
        if x.is_finite() {
            Ok(())
        } else {
            Err(self.error(name, format!("must be a finite number (got {x})")))
        }
    }

    fn finite_point<const N: usize>(&self, name: &str, p: [f64; N]) -> Result<(), GeometryError> {
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

    fn nonzero_vector(&self, name: &str, v: [f64; 3]) -> Result<(), GeometryError> {
        self.finite_point(name, v)?;
        // `norm` could overflow to infinity for huge finite components, and
        // a normalised direction is what the queries use.
        if v == [0.0; 3] || !norm(v).is_finite() {
            return Err(self.error(name, format!("must be a non-zero vector (got {v:?})")));
        }
        Ok(())
    }

    fn semi_axes<const N: usize>(&self, e: [f64; N]) -> Result<(), GeometryError> {
        for (k, x) in e.iter().enumerate() {
            self.positive(&format!("semi_axes[{k}]"), *x)?;
        }
        Ok(())
    }
}

/// A ray hit closer than this fraction of the problem's length scale is
/// taken to be the ray's own origin lying on the shape, not a hit (`s > 0`).
const RAY_ORIGIN_TOL: f64 = 1e-12;

/// Smallest accepted ray parameter: hits closer than this to the origin
/// are round-off images of an origin lying on the shape. Scaled by the
/// shape size and the origin's distance from it, the two sources of
/// round-off in the intersection arithmetic.
fn ray_s_min<const D: usize>(origin: [f64; D], dir: [f64; D], reference: [f64; D], size: f64) -> f64 {
    RAY_ORIGIN_TOL * (size + norm(sub(origin, reference))) / norm(dir)
}
