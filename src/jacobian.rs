//! Prescribed Jacobian determinants f(x, t) and their normalisation.
//!
//! The user gives an unnormalised field g(x, t) > 0 with g(·, 0) = 1; the
//! method uses f = c(t) g with `c(t) = (1/|Ω₀|) ∫_{Ω_t} 1/g dx`, so that
//! `∫_{Ω_t} 1/f = |Ω₀|` for every t (docs/METHOD.md §1). The divergence data of
//! the LSFEM system is then `−∂_t(1/f) = c'/(c² g) + g_t/(c g²)` with c'
//! from the transport theorem, which makes `∫ div u = ∮ u·n` hold.

use crate::expr::Expr;
use crate::lsfem::{cell_quadrature, q1_eval, GAUSS};
use crate::geometry::{ClosestPoint, LevelSet, Shape, Surface};
use crate::mesh::{PlaneMesh, Point2, Point3};
use crate::numeric::{cross3, dot, scale};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Errors of the prescribed-Jacobian fields.
#[derive(Debug, thiserror::Error)]
pub enum JacobianError {
    /// g is zero, negative or not finite somewhere the mesh reaches.
    #[error("prescribed Jacobian is not positive: the field is {} at (x, y, z) = ({:.6}, {:.6}, {:.6}), t = {t:.4}", signed(*value), x[0], x[1], x[2])]
    NotPositive {
        /// The point (z = 0 in 2D).
        x: Point3,
        /// The pseudo-time.
        t: f64,
        /// The value the user's field has there, before any floor (for a
        /// field without t, its value at t = 1: the target g₁).
        value: f64,
    },
    /// The image could not be read or decoded.
    #[error("cannot read image `{path}`: {reason}")]
    Image {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A parameter is out of range.
    #[error("{0}")]
    Parameter(String),
}

/// How g travels from 1 at t = 0 to the target g₁ at t = 1.
///
/// The default is [`TimePath::Linear`], the paper's path, chosen by
/// measurement. Along it the mesh moves little at first and most near
/// t = 1, when cells have already gathered where f is small, so the band
/// of small f is resolved by many cells while the large motion happens.
/// The inverse path changes 1/f (the cell size) at a constant rate and
/// so moves nodes fastest at the start, on the still uniform mesh, where a
/// narrow band is only two cells wide. On the circle interface of the
/// tests (40² cells, band 0.05, ratio 0.2, 40 Euler steps) J/f spans
/// [0.975, 1.049] on the linear path and [0.900, 1.037] on the inverse one;
/// at 80 steps the L2 errors are 0.95e-2 and 1.38e-2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimePath {
    /// g = (1 − t) + t g₁ — the paper's choice.
    #[default]
    Linear,
    /// 1/g = (1 − t) + t/g₁ — linear in cell size.
    Inverse,
}

/// Which parts of a picture become small cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SmallWhere {
    /// Dark pixels (black gets the smallest cells).
    #[default]
    Dark,
    /// Bright pixels (white gets the smallest cells).
    Bright,
}

/// A picture as a field over a rectangle of the domain.
#[derive(Clone, Debug)]
pub struct ImageField {
    width: usize,
    height: usize,
    /// Row-major luma in [0, 1], row 0 at the top of the picture,
    /// transparent pixels composited onto white.
    luma: Vec<f64>,
    lo: Point2,
    hi: Point2,
    /// g₁ on the pixels that get the smallest cells (the others reach 1).
    pub jacobian_ratio: f64,
    /// Which pixels get small cells.
    pub small: SmallWhere,
}

impl ImageField {
    /// Reads a PNG (grey or colour, converted to luma; transparency over
    /// white), optionally smoothed by `smooth` passes of a 3×3 box filter so
    /// thin dark lines become bands the flow can resolve, mapped onto
    /// `[lo, hi]`. `jacobian_ratio` is g₁ on black (or white) pixels.
    pub fn open(path: &Path, lo: Point2, hi: Point2, jacobian_ratio: f64, small: SmallWhere, smooth: usize) -> Result<ImageField, JacobianError> {
        check_ratio("jacobian ratio of the image", jacobian_ratio)?;
        if !(lo.iter().chain(&hi).all(|v| v.is_finite()) && hi[0] > lo[0] && hi[1] > lo[1]) {
            return Err(JacobianError::Parameter("image rectangle: `upper` must exceed `lower` in x and y (finite numbers)".into()));
        }
        let err = |reason: String| JacobianError::Image { path: path.to_path_buf(), reason };
        let img = image::ImageReader::open(path)
            .map_err(|e| err(e.to_string()))?
            .with_guessed_format()
            .map_err(|e| err(e.to_string()))?
            .decode()
            .map_err(|e| err(e.to_string()))?
            .to_luma_alpha32f();
        let (width, height) = (img.width() as usize, img.height() as usize);
        if width == 0 || height == 0 {
            return Err(err("the picture has no pixels".into()));
        }
        let mut luma: Vec<f64> = img
            .into_raw()
            .chunks_exact(2)
            .map(|la| {
                let (l, a) = ((la[0] as f64).clamp(0.0, 1.0), (la[1] as f64).clamp(0.0, 1.0));
                l * a + (1.0 - a)
            })
            .collect();
        for _ in 0..smooth {
            luma = box_blur(&luma, width, height);
        }
        Ok(ImageField { width, height, luma, lo, hi, jacobian_ratio, small })
    }

    /// Picture brightness in [0, 1] at x (its z is ignored, so in 3D the
    /// picture is extruded along z): bilinear between pixel centres, white
    /// outside the rectangle.
    pub fn luma(&self, x: Point3) -> f64 {
        let u = (x[0] - self.lo[0]) / (self.hi[0] - self.lo[0]);
        let v = (x[1] - self.lo[1]) / (self.hi[1] - self.lo[1]);
        if !(0.0..=1.0).contains(&u) || !(0.0..=1.0).contains(&v) {
            return 1.0;
        }
        // pixel centres at (i + 1/2)/w; picture rows run downward
        let px = (u * self.width as f64 - 0.5).clamp(0.0, (self.width - 1) as f64);
        let py = ((1.0 - v) * self.height as f64 - 0.5).clamp(0.0, (self.height - 1) as f64);
        let (i0, j0) = (px.floor() as usize, py.floor() as usize);
        let (i1, j1) = ((i0 + 1).min(self.width - 1), (j0 + 1).min(self.height - 1));
        let (a, b) = (px - i0 as f64, py - j0 as f64);
        let at = |i: usize, j: usize| self.luma[j * self.width + i];
        (1.0 - a) * (1.0 - b) * at(i0, j0) + a * (1.0 - b) * at(i1, j0) + (1.0 - a) * b * at(i0, j1) + a * b * at(i1, j1)
    }

    /// g₁ at x: the ratio on the small-cell extreme, 1 on the other, linear
    /// in brightness between. Outside the rectangle the picture is white.
    pub fn value(&self, x: Point3) -> f64 {
        let l = self.luma(x);
        let s = match self.small {
            SmallWhere::Dark => l,
            SmallWhere::Bright => 1.0 - l,
        };
        self.jacobian_ratio + (1.0 - self.jacobian_ratio) * s
    }
}

fn box_blur(src: &[f64], w: usize, h: usize) -> Vec<f64> {
    let mut out = vec![0.0; src.len()];
    for j in 0..h {
        for i in 0..w {
            let (mut s, mut n) = (0.0, 0.0);
            for dj in j.saturating_sub(1)..=(j + 1).min(h - 1) {
                for di in i.saturating_sub(1)..=(i + 1).min(w - 1) {
                    s += src[dj * w + di];
                    n += 1.0;
                }
            }
            out[j * w + i] = s / n;
        }
    }
    out
}

fn check_ratio(what: &str, r: f64) -> Result<(), JacobianError> {
    if r > 0.0 && r.is_finite() {
        Ok(())
    } else {
        Err(JacobianError::Parameter(format!("{what} must be a positive number, got {r}")))
    }
}

/// Where an interface lies: a curve (2D), a surface (3D), or the zero set
/// of a level-set function φ(x, y, z).
#[derive(Clone, Debug)]
pub enum Locus {
    /// A curve of the geometry module.
    Curve(Shape),
    /// A surface of the geometry module.
    Surface(Surface),
    /// φ(x, y, z) = 0.
    LevelSet(LevelSet),
}

impl Locus {
    /// Distance from x to the interface (z ignored for curves); for a
    /// level set, its first-order estimate where that exceeds `far` (see
    /// [`LevelSet::band_distance`]).
    pub fn distance(&self, x: Point3, far: f64) -> f64 {
        match self {
            Locus::Curve(s) => s.distance([x[0], x[1]]),
            Locus::Surface(s) => s.distance(x),
            Locus::LevelSet(s) => s.band_distance(x, far),
        }
    }
}

/// Cells crowd along an interface: g₁ = 1 − (1 − r) exp(−(d/w)²), with d
/// the distance to the interface, w the band width and r the Jacobian
/// ratio (smallest to background cell size, in area or volume).
#[derive(Clone, Debug)]
pub struct Interface {
    /// Where the interface lies.
    pub locus: Locus,
    /// Band width w: at distance w the deficit 1 − g₁ has fallen to 1/e.
    pub width: f64,
    /// r = g₁ on the interface: the length ratio to the power of the dimension.
    pub jacobian_ratio: f64,
}

impl Interface {
    /// Checks the parameters.
    pub fn new(locus: Locus, width: f64, jacobian_ratio: f64) -> Result<Interface, JacobianError> {
        if !(width > 0.0 && width.is_finite()) {
            return Err(JacobianError::Parameter(format!("interface width must be a positive number, got {width}")));
        }
        check_ratio("interface jacobian ratio", jacobian_ratio)?;
        Ok(Interface { locus, width, jacobian_ratio })
    }

    /// g₁ at x.
    pub fn value(&self, x: Point3) -> f64 {
        // beyond 8 widths exp(−64) leaves g₁ = 1 to the last bit
        let d = self.locus.distance(x, 8.0 * self.width) / self.width;
        1.0 - (1.0 - self.jacobian_ratio) * (-d * d).exp()
    }
}

/// The unnormalised target g₁ (or a whole g(x, t)).
#[derive(Clone, Debug)]
pub enum Target {
    /// f follows only the change of area: g ≡ 1.
    Uniform,
    /// g₁ as an expression in x, y, z; or g(x, y, z, t) when it uses t
    /// (only as the whole field, not inside a combination).
    /// Its variables are, in order, `x, y, z, t` ([`EXPR_VARS`]).
    Expression(Expr),
    /// g₁ from a picture.
    Image(ImageField),
    /// Small cells along an interface.
    Interface(Interface),
    /// The smallest of several fields: each one's small cells, everywhere.
    Min(Vec<Target>),
    /// The product of several fields: small cells where either asks, and
    /// smaller still where they overlap.
    Product(Vec<Target>),
}

impl Target {
    /// g₁(x).
    pub fn value(&self, x: Point3) -> f64 {
        match self {
            Target::Uniform => 1.0,
            Target::Expression(e) => e.eval(&[x[0], x[1], x[2], 1.0]),
            Target::Image(img) => img.value(x),
            Target::Interface(i) => i.value(x),
            // NaN must survive (f64::min would drop it) so it is reported
            Target::Min(v) => v.iter().map(|t| t.value(x)).fold(f64::INFINITY, |a, b| if a.is_nan() { a } else if b.is_nan() || b < a { b } else { a }),
            Target::Product(v) => v.iter().map(|t| t.value(x)).product(),
        }
    }

    /// True when an expression somewhere inside uses t.
    pub fn uses_time(&self) -> bool {
        match self {
            Target::Expression(e) => e.uses("t"),
            Target::Min(v) | Target::Product(v) => v.iter().any(Target::uses_time),
            _ => false,
        }
    }
}

/// The variables of expression fields, in evaluation order.
pub const EXPR_VARS: [&str; 4] = ["x", "y", "z", "t"];

/// A prescribed Jacobian: target, time path and an optional floor.
#[derive(Clone, Debug)]
pub struct JacobianField {
    /// The target.
    pub target: Target,
    /// The time path (ignored for expressions in t).
    pub path: TimePath,
    /// g₁ is raised to at least this, so f never reaches 0 (none: 0).
    pub floor: f64,
}

impl JacobianField {
    /// The uniform field.
    pub fn uniform() -> JacobianField {
        JacobianField { target: Target::Uniform, path: TimePath::default(), floor: 0.0 }
    }

    /// An expression in x, y, z (and optionally t), parsed with [`EXPR_VARS`].
    pub fn expression(expr: Expr) -> JacobianField {
        JacobianField { target: Target::Expression(expr), path: TimePath::default(), floor: 0.0 }
    }

    /// A target on a time path, without a floor.
    pub fn new(target: Target, path: TimePath) -> JacobianField {
        JacobianField { target, path, floor: 0.0 }
    }

    /// True when g ≡ 1.
    pub fn is_uniform(&self) -> bool {
        matches!(self.target, Target::Uniform)
    }

    fn time_dependent_expr(&self) -> Option<&Expr> {
        match &self.target {
            Target::Expression(e) if e.uses("t") => Some(e),
            _ => None,
        }
    }

    /// The floor applied to a value, keeping NaN a NaN.
    fn floored(&self, g: f64) -> f64 {
        if g < self.floor { self.floor } else { g }
    }

    /// The target g₁(x) at t = 1, floored.
    pub fn g1(&self, x: Point3) -> f64 {
        self.floored(self.target.value(x))
    }

    /// g(x, t) and ∂g/∂t.
    pub fn g_and_dt(&self, x: Point3, t: f64) -> (f64, f64) {
        if let Some(e) = self.time_dependent_expr() {
            // a difference quotient: the expression is arbitrary text. It is
            // only defined on [0, 1] (sqrt(1 − t) is NaN past 1), so at the
            // ends it is one-sided, second order like the central one
            let h = 1e-6;
            let at = |t: f64| e.eval(&[x[0], x[1], x[2], t]);
            let g = at(t);
            if g < self.floor {
                return (self.floor, 0.0);
            }
            let dt = if t + h > 1.0 {
                (3.0 * g - 4.0 * at(t - h) + at(t - 2.0 * h)) / (2.0 * h)
            } else if t - h < 0.0 {
                (-3.0 * g + 4.0 * at(t + h) - at(t + 2.0 * h)) / (2.0 * h)
            } else {
                (at(t + h) - at(t - h)) / (2.0 * h)
            };
            return (g, dt);
        }
        if self.is_uniform() {
            return (1.0, 0.0);
        }
        let g1 = self.g1(x);
        match self.path {
            TimePath::Linear => ((1.0 - t) + t * g1, g1 - 1.0),
            TimePath::Inverse => {
                let inv = (1.0 - t) + t / g1;
                (1.0 / inv, -(1.0 / g1 - 1.0) / (inv * inv))
            }
        }
    }

    /// g(x, t), checked positive and finite.
    pub fn g_checked(&self, x: Point3, t: f64) -> Result<(f64, f64), JacobianError> {
        let (g, gt) = self.g_and_dt(x, t);
        if !(g > 0.0 && g.is_finite() && gt.is_finite()) {
            return Err(JacobianError::NotPositive { x, t, value: self.user_value(x, t) });
        }
        Ok((g, gt))
    }

    /// What the user's field gives at x: the expression in t at t, else
    /// the target g₁. Not g itself: the floor (0 by default) would show a
    /// negative field as 0, and on the path 0·∞ at t = 0 an infinite one
    /// as NaN.
    fn user_value(&self, x: Point3, t: f64) -> f64 {
        match self.time_dependent_expr() {
            Some(e) => e.eval(&[x[0], x[1], x[2], t]),
            None => self.target.value(x),
        }
    }
}

/// f = c g at one pseudo-time, with c' for the divergence data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Normalisation {
    /// The pseudo-time.
    pub t: f64,
    /// c(t).
    pub c: f64,
    /// dc/dt.
    pub c_dot: f64,
}

impl Normalisation {
    /// `−∂_t(1/f)` at x: the right-hand side of `div u`.
    pub fn div_data(&self, field: &JacobianField, x: Point3) -> f64 {
        let (g, gt) = field.g_and_dt(x, self.t);
        self.c_dot / (self.c * self.c * g) + gt / (self.c * g * g)
    }

    /// f(x, t) = c(t) g(x, t).
    pub fn f(&self, field: &JacobianField, x: Point3) -> f64 {
        self.c * field.g_and_dt(x, self.t).0
    }
}

/// A value for a message: infinities signed (`+inf`), as a user thinks of
/// `1/abs(x - 0.5)` at x = 0.5.
fn signed(v: f64) -> String {
    if v == f64::INFINITY { "+inf".into() } else { v.to_string() }
}

/// A point in 2D or 3D as a point in space (z = 0 in 2D).
pub fn lift<const D: usize>(x: [f64; D]) -> Point3 {
    std::array::from_fn(|i| if i < D { x[i] } else { 0.0 })
}

/// Cells per parallel chunk of [`normalise`].
const NORMALISE_CHUNK: usize = 1024;

/// Computes c(t) and c'(t) on the mesh of Ω_t given by `cells` at
/// positions `nodes`: `volume0` = |Ω₀|, `boundary` the quadrature of the
/// boundary flux, pairs (x, v·n dS) with v the velocity of the moving
/// boundary. Fails where g ≤ 0.
pub fn normalise<const D: usize, const N: usize>(
    cells: &[[usize; N]],
    nodes: &[[f64; D]],
    field: &JacobianField,
    t: f64,
    volume0: f64,
    boundary: impl Iterator<Item = ([f64; D], f64)>,
) -> Result<Normalisation, JacobianError> {
    normalise_with(cells, nodes, field, (t, volume0), boundary, (0.0, 0.0))
}

/// [`normalise`] over `cells` with `base` added: the sums over the other
/// cells of Ω_t, where they are known (cells that do not move, where g
/// does not change). `base` (0, 0) is [`normalise`].
pub fn normalise_with<const D: usize, const N: usize>(
    cells: &[[usize; N]],
    nodes: &[[f64; D]],
    field: &JacobianField,
    (t, volume0): (f64, f64),
    boundary: impl Iterator<Item = ([f64; D], f64)>,
    base: (f64, f64),
) -> Result<Normalisation, JacobianError> {
    // fixed chunks summed in order: rayon's own reduction splits where
    // work is stolen, so its sum differed from run to run in the last
    // digits, and a settling flow (water_wave_p3) magnified that to 1e-5
    let (inv_g, dt_term) = cell_sums(cells, nodes, field, t, base)?;
    let mut flux = 0.0;
    for (x, vn_ds) in boundary {
        flux += vn_ds / field.g_checked(lift(x), t)?.0;
    }
    Ok(Normalisation { t, c: inv_g / volume0, c_dot: (dt_term + flux) / volume0 })
}

/// `base` plus the sums of [`normalise`] over `cells`, ∫ 1/g and
/// −∫ ∂g/∂t / g², in chunks of [`NORMALISE_CHUNK`] added in order: the
/// same to the last digit from run to run.
pub fn cell_sums<const D: usize, const N: usize>(cells: &[[usize; N]], nodes: &[[f64; D]], field: &JacobianField, t: f64, base: (f64, f64)) -> Result<(f64, f64), JacobianError> {
    let partial = cells.par_chunks(NORMALISE_CHUNK).map(|chunk| chunk_sums(chunk, nodes, field, t)).collect::<Result<Vec<(f64, f64)>, JacobianError>>()?;
    Ok(partial.iter().fold(base, |a, b| (a.0 + b.0, a.1 + b.1)))
}

/// The sums of [`normalise`] over the cells of one chunk: ∫ 1/g and
/// −∫ ∂g/∂t / g².
fn chunk_sums<const D: usize, const N: usize>(chunk: &[[usize; N]], nodes: &[[f64; D]], field: &JacobianField, t: f64) -> Result<(f64, f64), JacobianError> {
    let mut acc = (0.0, 0.0);
    for cell in chunk {
        let p = cell.map(|n| nodes[n]);
        for (xi, w) in cell_quadrature::<D, N>() {
            let (x, det, _) = q1_eval(&p, xi);
            let (g, gt) = field.g_checked(lift(x), t)?;
            acc.0 += w * det / g;
            acc.1 -= w * det * gt / (g * g);
        }
    }
    Ok(acc)
}

/// The boundary-flux quadrature of a linear mesh: pairs (x, v·n dS) at
/// the quadrature points of every boundary facet `[usize; K]`, for nodal
/// boundary velocities `velocity`. A facet is an edge in 2D (K = 2, the
/// domain on its left; 2 Gauss points), a bilinear face (K = 4; 2 × 2
/// Gauss points) or a triangle (K = 3; the 3-point rule) in 3D, its nodes
/// counter-clockwise seen from outside, so that n points outward. Each
/// rule has K points and is exact for the linear v·n of a flat facet.
pub fn facet_flux_points<'a, const D: usize, const K: usize>(
    facets: impl Iterator<Item = [usize; K]> + 'a,
    nodes: &'a [[f64; D]],
    velocity: &'a [[f64; D]],
) -> impl Iterator<Item = ([f64; D], f64)> + 'a {
    facets.flat_map(move |f| {
        let (p, w) = (f.map(|n| nodes[n]), f.map(|n| velocity[n]));
        (0..K).map(move |k| {
            // quadrature point k and the facet's shape functions there
            let [xi, eta] = if K == 3 { TRIANGLE_POINTS[k] } else { [GAUSS[k & 1], if K == 4 { GAUSS[k >> 1] } else { 0.0 }] };
            let n: [f64; 4] = if K == 3 {
                [1.0 - xi - eta, xi, eta, 0.0]
            } else {
                [(1.0 - xi) * (1.0 - eta), xi * (1.0 - eta), xi * eta, (1.0 - xi) * eta]
            };
            let at = |q: &[[f64; D]; K]| -> [f64; D] { std::array::from_fn(|i| (0..K).map(|a| n[a] * q[a][i]).sum()) };
            (at(&p), dot(at(&w), weighted_normal(&p, xi, eta)))
        })
    })
}

/// The 3-point rule of the unit triangle (weights 1/6 each).
const TRIANGLE_POINTS: [[f64; 2]; 3] = [[1.0 / 6.0, 1.0 / 6.0], [2.0 / 3.0, 1.0 / 6.0], [1.0 / 6.0, 2.0 / 3.0]];

/// n dS at (ξ, η) of a facet times its quadrature weight (1/2 on an edge,
/// 1/4 on a bilinear face, 1/6 on a flat triangle, whose n dS is the same
/// at every point): the tangent turned clockwise, or ∂x/∂ξ × ∂x/∂η.
fn weighted_normal<const D: usize, const K: usize>(p: &[[f64; D]; K], xi: f64, eta: f64) -> [f64; D] {
    let mut n = [0.0; D];
    match (&p[..], &mut n[..]) {
        ([a, b], [n0, n1]) => (*n0, *n1) = (0.5 * (b[1] - a[1]), 0.5 * -(b[0] - a[0])),
        ([p0, p1, p2], [_, _, _]) => {
            let (e1, e2): ([f64; 3], [f64; 3]) = (std::array::from_fn(|i| p1[i] - p0[i]), std::array::from_fn(|i| p2[i] - p0[i]));
            n.copy_from_slice(&scale(1.0 / 6.0, cross3(e1, e2)));
        }
        ([p0, p1, p2, p3], [_, _, _]) => {
            let dxi: [f64; 3] = std::array::from_fn(|i| (1.0 - eta) * (p1[i] - p0[i]) + eta * (p2[i] - p3[i]));
            let deta: [f64; 3] = std::array::from_fn(|i| (1.0 - xi) * (p3[i] - p0[i]) + xi * (p2[i] - p1[i]));
            n.copy_from_slice(&scale(0.25, cross3(dxi, deta)));
        }
        _ => {} // no other facets: the flux through them is not counted
    }
    n
}

/// [`facet_flux_points`] over the boundary edges of a quad mesh.
pub fn edge_flux_points<'a, const N: usize>(mesh: &'a PlaneMesh<N>, nodes: &'a [Point2], velocity: &'a [Point2]) -> impl Iterator<Item = (Point2, f64)> + 'a {
    facet_flux_points(mesh.edges.iter().map(|e| e.nodes), nodes, velocity)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::QuadMesh;

    fn expr(s: &str) -> Expr {
        Expr::parse(s, &EXPR_VARS).unwrap()
    }

    fn normalise2(mesh: &QuadMesh, f: &JacobianField, t: f64, v: &[Point2]) -> Result<Normalisation, JacobianError> {
        normalise(&mesh.cells, &mesh.nodes, f, t, 1.0, edge_flux_points(mesh, &mesh.nodes, v))
    }

    #[test]
    fn uniform_normalisation_is_area_ratio_and_flux() {
        // the unit square stretched to [0,2]×[0,1], right side moving at v = (1, 0)
        let mut mesh = QuadMesh::structured_box([0.0, 0.0], [2.0, 1.0], 4, 3);
        let v: Vec<Point2> = mesh.nodes.iter().map(|p| if p[0] == 2.0 { [1.0, 0.0] } else { [0.0, 0.0] }).collect();
        let n = normalise2(&mesh, &JacobianField::uniform(), 0.5, &v).unwrap();
        assert!((n.c - 2.0).abs() < 1e-14 && (n.c_dot - 1.0).abs() < 1e-14, "{n:?}");
        mesh.nodes[6] = [0.55, 0.3]; // an interior node: the area stays
        assert!((normalise2(&mesh, &JacobianField::uniform(), 0.5, &v).unwrap().c - 2.0).abs() < 1e-14);
    }

    #[test]
    fn expression_normalisation_matches_analytic_integral() {
        // g1 = 1 + x on the fixed unit square: ∫ 1/g at t = 1 is ln 2
        let mesh = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 64, 2);
        let f = JacobianField::expression(expr("1 + x"));
        let v = vec![[0.0; 2]; mesh.num_nodes()];
        let n = normalise2(&mesh, &f, 1.0, &v).unwrap();
        assert!((n.c - 2f64.ln()).abs() < 1e-6, "{}", n.c);
        // c' = −∫ g_t/g² = −∫ x/(1+x)² dx = −(ln 2 − 1/2)
        assert!((n.c_dot + (2f64.ln() - 0.5)).abs() < 1e-6, "{}", n.c_dot);
    }

    #[test]
    fn time_derivative_stays_inside_zero_to_one() {
        // sqrt(1 − t) + 1 is defined on [0, 1] only: a central difference at
        // t = 1 would read t = 1 + 1e-6 and give NaN
        let f = JacobianField::expression(expr("1 + sqrt(1 - t) * (1 - t)"));
        for t in [0.0, 0.5, 1.0] {
            let (g, dt) = f.g_and_dt([0.3, 0.2, 0.0], t);
            let exact = -1.5 * (1.0 - t).sqrt();
            // at t = 1 the derivative's own derivative is infinite: the
            // one-sided quotient is off by 5.9e-4 there (1e-10 elsewhere)
            let bound = if t == 1.0 { 1e-3 } else { 1e-6 };
            assert!(g.is_finite() && (dt - exact).abs() < bound, "t = {t}: g {g}, dg/dt {dt}, exact {exact}");
        }
    }

    #[test]
    fn non_positive_field_names_the_place() {
        let mesh = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 4, 4);
        let f = JacobianField::expression(expr("x - 0.5"));
        let err = normalise2(&mesh, &f, 1.0, &vec![[0.0; 2]; 25]).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("not positive") && msg.contains("t = 1.0000"), "{msg}");
    }

    #[test]
    fn a_bad_field_is_reported_with_the_users_value() {
        // the default floor 0 made g = 0 out of −0.5
        let f = JacobianField::expression(expr("x - 0.5"));
        let msg = f.g_checked([0.0, 0.3, 0.0], 1.0).unwrap_err().to_string();
        assert!(msg.contains("the field is -0.5 at"), "{msg}");
        // the path (1 − t) + t·g₁ made NaN out of +inf at t = 0
        let f = JacobianField::expression(expr("1/abs(x - 0.5)"));
        let msg = f.g_checked([0.5, 0.3, 0.0], 0.0).unwrap_err().to_string();
        assert!(msg.contains("the field is +inf at") && !msg.contains("NaN"), "{msg}");
        // an expression in t: its own value at that t
        let f = JacobianField::expression(expr("1 - 2*t"));
        let msg = f.g_checked([0.0, 0.0, 0.0], 1.0).unwrap_err().to_string();
        assert!(msg.contains("the field is -1 at") && msg.contains("t = 1.0000"), "{msg}");
    }

    #[test]
    fn inverse_path_derivative_matches_difference() {
        let f = JacobianField::new(Target::Expression(expr("0.2 + x")), TimePath::Inverse);
        let x = [0.3, 0.1, 0.0];
        for t in [0.1, 0.5, 0.9] {
            let (_, gt) = f.g_and_dt(x, t);
            let fd = (f.g_and_dt(x, t + 1e-6).0 - f.g_and_dt(x, t - 1e-6).0) / 2e-6;
            assert!((gt - fd).abs() < 1e-6);
        }
        assert!((f.g_and_dt(x, 1.0).0 - 0.5).abs() < 1e-15);
    }

    #[test]
    fn interface_profile_min_product_and_floor() {
        let circle = crate::geometry::ShapeSpec::Circle { centre: [0.0, 0.0], radius: 1.0 }.build().unwrap();
        let band = Interface::new(Locus::Curve(circle), 0.1, 0.2).unwrap();
        assert!((band.value([1.0, 0.0, 0.0]) - 0.2).abs() < 1e-15);
        // at one width the deficit is 1/e of 0.8
        assert!((band.value([1.1, 0.0, 0.0]) - (1.0 - 0.8 / std::f64::consts::E)).abs() < 1e-12);
        assert!((band.value([0.0, 0.0, 0.0]) - 1.0).abs() < 1e-15);
        let half = Target::Expression(expr("0.5"));
        let both = |t: fn(Vec<Target>) -> Target| t(vec![Target::Interface(band.clone()), half.clone()]);
        let x = [1.0, 0.0, 0.0];
        assert!((both(Target::Min).value(x) - 0.2).abs() < 1e-15);
        assert!((both(Target::Product).value(x) - 0.1).abs() < 1e-15);
        assert!((both(Target::Min).value([0.0, 0.0, 0.0]) - 0.5).abs() < 1e-15);
        let mut f = JacobianField::new(both(Target::Product), TimePath::Linear);
        f.floor = 0.15;
        assert_eq!(f.g1(x), 0.15);
        assert_eq!(f.g_and_dt(x, 0.5), (0.575, -0.85));
        // a NaN is not hidden by the floor (or by min): it is reported
        let nan = JacobianField { target: Target::Min(vec![Target::Expression(expr("sqrt(-1)")), half]), path: TimePath::Linear, floor: 0.1 };
        assert!(nan.g_checked(x, 1.0).is_err());
    }

    #[test]
    fn bad_interface_parameters_are_errors() {
        let circle = || Locus::Curve(crate::geometry::ShapeSpec::Circle { centre: [0.0, 0.0], radius: 1.0 }.build().unwrap());
        for (w, r) in [(0.0, 0.5), (-1.0, 0.5), (f64::NAN, 0.5), (0.1, 0.0), (0.1, -2.0), (0.1, f64::INFINITY)] {
            let e = Interface::new(circle(), w, r).unwrap_err().to_string();
            assert!(e.contains("must be a positive number"), "{e}");
        }
    }

    #[test]
    fn image_luma_is_bilinear_and_bright_flag_inverts() {
        // a 2×1 picture: black left pixel, white right pixel
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("two.png");
        image::GrayImage::from_raw(2, 1, vec![0, 255]).unwrap().save(&path).unwrap();
        let dark = ImageField::open(&path, [0.0, 0.0], [2.0, 1.0], 0.25, SmallWhere::Dark, 0).unwrap();
        let bright = ImageField::open(&path, [0.0, 0.0], [2.0, 1.0], 0.25, SmallWhere::Bright, 0).unwrap();
        // pixel centres at x = 0.5 and 1.5; halfway between, luma 1/2
        assert_eq!(dark.value([0.5, 0.5, 0.0]), 0.25);
        assert_eq!(dark.value([1.5, 0.5, 0.0]), 1.0);
        assert!((dark.value([1.0, 0.5, 0.0]) - 0.625).abs() < 1e-7);
        assert_eq!(bright.value([1.5, 0.5, 0.0]), 0.25);
        // outside the rectangle: white
        assert_eq!(dark.value([3.0, 0.5, 0.0]), 1.0);
        assert_eq!(bright.value([3.0, 0.5, 0.0]), 0.25);
        assert!(ImageField::open(&path, [0.0, 0.0], [0.0, 1.0], 0.25, SmallWhere::Dark, 0).is_err());
        assert!(ImageField::open(&path, [0.0, 0.0], [1.0, 1.0], 0.0, SmallWhere::Dark, 0).is_err());
    }
}
