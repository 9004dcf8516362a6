//! Prescribed Jacobian determinants f(x, t) and their normalisation.
//!
//! The user gives an unnormalised field g(x, t) > 0 with g(·, 0) = 1; the
//! method uses f = c(t) g with `c(t) = (1/|Ω₀|) ∫_{Ω_t} 1/g dx`, so that
//! `∫_{Ω_t} 1/f = |Ω₀|` for every t (DESIGN.md §1). The divergence data of
//! the LSFEM system is then `−∂_t(1/f) = c'/(c² g) + g_t/(c g²)` with c'
//! from the transport theorem, which makes `∫ div u = ∮ u·n` hold.

use crate::expr::Expr;
use crate::lsfem::{gauss_points, q1_eval, GAUSS};
use crate::mesh::{Point2, Point3, QuadMesh};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Errors of the prescribed-Jacobian fields.
#[derive(Debug, thiserror::Error)]
pub enum JacobianError {
    /// g is zero, negative or not finite somewhere the mesh reaches.
    #[error("prescribed Jacobian is not positive: g = {value} at (x, y, z) = ({:.6}, {:.6}, {:.6}), t = {t:.4}", x[0], x[1], x[2])]
    NotPositive {
        /// The point (z = 0 in 2D).
        x: Point3,
        /// The pseudo-time.
        t: f64,
        /// The value found.
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimePath {
    /// g = (1 − t) + t g₁ — the paper's choice.
    #[default]
    Linear,
    /// 1/g = (1 − t) + t/g₁ — linear in cell size, gentler where g₁ is small.
    Inverse,
}

/// A picture as a field of values in [0, 1] over a rectangle of the domain.
#[derive(Clone, Debug)]
pub struct ImageField {
    width: usize,
    height: usize,
    /// Row-major luma in [0, 1], row 0 at the top of the picture.
    luma: Vec<f64>,
    lo: Point2,
    hi: Point2,
    /// g₁ on the darkest pixels (bright pixels get 1).
    pub floor: f64,
    /// Make bright parts small instead of dark ones.
    pub invert: bool,
}

impl ImageField {
    /// Reads a PNG (grey or colour, converted to luma), optionally smoothed
    /// by `smooth` passes of a 3×3 box filter, mapped onto `[lo, hi]`.
    pub fn open(path: &Path, lo: Point2, hi: Point2, floor: f64, invert: bool, smooth: usize) -> Result<ImageField, JacobianError> {
        let err = |reason: String| JacobianError::Image { path: path.to_path_buf(), reason };
        let img = image::ImageReader::open(path)
            .map_err(|e| err(e.to_string()))?
            .with_guessed_format()
            .map_err(|e| err(e.to_string()))?
            .decode()
            .map_err(|e| err(e.to_string()))?
            .to_luma32f();
        if !(floor > 0.0 && floor <= 1.0) {
            return Err(JacobianError::Parameter(format!("image floor must be in (0, 1], got {floor}")));
        }
        if !(hi[0] > lo[0] && hi[1] > lo[1]) {
            return Err(JacobianError::Parameter("image rectangle must have hi > lo in x and y".into()));
        }
        let (width, height) = (img.width() as usize, img.height() as usize);
        let mut luma: Vec<f64> = img.into_raw().into_iter().map(|v| (v as f64).clamp(0.0, 1.0)).collect();
        for _ in 0..smooth {
            luma = box_blur(&luma, width, height);
        }
        Ok(ImageField { width, height, luma, lo, hi, floor, invert })
    }

    /// g₁ at x (its z is ignored): bilinear in the picture, 1 outside its
    /// rectangle.
    pub fn value(&self, x: Point3) -> f64 {
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
        let l = (1.0 - a) * (1.0 - b) * at(i0, j0) + a * (1.0 - b) * at(i1, j0) + (1.0 - a) * b * at(i0, j1) + a * b * at(i1, j1);
        let l = if self.invert { 1.0 - l } else { l };
        self.floor + (1.0 - self.floor) * l
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

/// The unnormalised target g₁ (or a whole g(x, t)).
#[derive(Clone, Debug)]
pub enum Target {
    /// f follows only the change of area: g ≡ 1.
    Uniform,
    /// g₁ as an expression in x, y, z; or g(x, y, z, t) when it uses t.
    /// Its variables are, in order, `x, y, z, t` ([`EXPR_VARS`]).
    Expression(Expr),
    /// g₁ from a picture.
    Image(ImageField),
}

/// The variables of expression fields, in evaluation order.
pub const EXPR_VARS: [&str; 4] = ["x", "y", "z", "t"];

/// A prescribed Jacobian: target plus time path.
#[derive(Clone, Debug)]
pub struct JacobianField {
    /// The target.
    pub target: Target,
    /// The time path (ignored for expressions in t).
    pub path: TimePath,
}

impl JacobianField {
    /// The uniform field.
    pub fn uniform() -> JacobianField {
        JacobianField { target: Target::Uniform, path: TimePath::Linear }
    }

    /// An expression in x, y, z (and optionally t), parsed with [`EXPR_VARS`].
    pub fn expression(expr: Expr) -> JacobianField {
        JacobianField { target: Target::Expression(expr), path: TimePath::Linear }
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

    /// The target g₁(x) at t = 1 (for path-based fields).
    fn g1(&self, x: Point3) -> f64 {
        match &self.target {
            Target::Uniform => 1.0,
            Target::Expression(e) => e.eval(&[x[0], x[1], x[2], 1.0]),
            Target::Image(img) => img.value(x),
        }
    }

    /// g(x, t) and ∂g/∂t.
    pub fn g_and_dt(&self, x: Point3, t: f64) -> (f64, f64) {
        if let Some(e) = self.time_dependent_expr() {
            // central difference: the expression is arbitrary text
            let h = 1e-6;
            let at = |t: f64| e.eval(&[x[0], x[1], x[2], t]);
            let (g, gt) = (at(t), (at(t + h) - at(t - h)) / (2.0 * h));
            return (g, gt);
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
            return Err(JacobianError::NotPositive { x, t, value: g });
        }
        Ok((g, gt))
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

/// A point in 2D or 3D as a point in space (z = 0 in 2D).
pub fn lift<const D: usize>(x: [f64; D]) -> Point3 {
    std::array::from_fn(|i| if i < D { x[i] } else { 0.0 })
}

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
    let (inv_g, dt_term) = cells
        .par_iter()
        .map(|cell| {
            let p = cell.map(|n| nodes[n]);
            let mut acc = (0.0, 0.0);
            for (xi, w) in gauss_points::<D>() {
                let (x, det, _) = q1_eval(&p, xi);
                let (g, gt) = field.g_checked(lift(x), t)?;
                acc.0 += w * det / g;
                acc.1 -= w * det * gt / (g * g);
            }
            Ok(acc)
        })
        .try_reduce(|| (0.0, 0.0), |a, b| Ok((a.0 + b.0, a.1 + b.1)))?;
    let mut flux = 0.0;
    for (x, vn_ds) in boundary {
        flux += vn_ds / field.g_checked(lift(x), t)?.0;
    }
    Ok(Normalisation { t, c: inv_g / volume0, c_dot: (dt_term + flux) / volume0 })
}

/// The boundary-flux quadrature of a quad mesh (two Gauss points per
/// edge): pairs (x, v·n ds) for nodal boundary velocities `velocity`.
pub fn edge_flux_points<'a>(mesh: &'a QuadMesh, nodes: &'a [Point2], velocity: &'a [Point2]) -> impl Iterator<Item = (Point2, f64)> + 'a {
    mesh.edges.iter().flat_map(move |e| {
        let (a, b) = (nodes[e.nodes[0]], nodes[e.nodes[1]]);
        let (va, vb) = (velocity[e.nodes[0]], velocity[e.nodes[1]]);
        // outward normal times length: the domain is on the edge's left
        let nds = [b[1] - a[1], -(b[0] - a[0])];
        GAUSS.map(|s| {
            let x = [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])];
            let v = [va[0] + s * (vb[0] - va[0]), va[1] + s * (vb[1] - va[1])];
            (x, 0.5 * (v[0] * nds[0] + v[1] * nds[1]))
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn non_positive_field_names_the_place() {
        let mesh = QuadMesh::structured_box([0.0, 0.0], [1.0, 1.0], 4, 4);
        let f = JacobianField::expression(expr("x - 0.5"));
        let err = normalise2(&mesh, &f, 1.0, &vec![[0.0; 2]; 25]).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("not positive") && msg.contains("t = 1.0000"), "{msg}");
    }

    #[test]
    fn inverse_path_derivative_matches_difference() {
        let f = JacobianField { target: Target::Expression(expr("0.2 + x")), path: TimePath::Inverse };
        let x = [0.3, 0.1, 0.0];
        for t in [0.1, 0.5, 0.9] {
            let (_, gt) = f.g_and_dt(x, t);
            let fd = (f.g_and_dt(x, t + 1e-6).0 - f.g_and_dt(x, t - 1e-6).0) / 2e-6;
            assert!((gt - fd).abs() < 1e-6);
        }
        assert!((f.g_and_dt(x, 1.0).0 - 0.5).abs() < 1e-15);
    }
}
