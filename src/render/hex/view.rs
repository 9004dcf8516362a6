//! The camera: projecting world points to the screen, and shading faces.

use super::Camera;
use crate::numeric::{add, cross3 as cross, dot, norm, scale, sub};
use crate::render::RenderError;

/// Share of light that reaches every face whatever its direction. Fairly
/// high, because the colour carries the data: faces turned away from the
/// light (such as the cut face of a clipped mesh in the default view) must
/// keep a readable colour.
pub(crate) const AMBIENT: f64 = 0.5;

/// Direction to the light in camera coordinates (right, up, towards the
/// viewer): from above, slightly left, and mostly from the front. In the
/// default view the three sides of a box then get clearly different
/// shades (about 0.90 top, 0.77 front, 0.63 right) while none goes dark;
/// a light further left would leave right-facing sides nearly black.
const LIGHT: [f64; 3] = [-0.1, 0.55, 1.0];

/// Points nearer the eye than this share of the bounding radius are
/// treated as behind it (they would project to huge or infinite values).
const NEAR: f64 = 1e-3;

/// A camera looking at the centre of a box.
#[derive(Clone, Debug)]
pub(crate) struct View {
    /// Unit vectors of the screen: right, up, and towards the viewer.
    right: [f64; 3],
    up: [f64; 3],
    back: [f64; 3],
    /// Unit vector towards the light.
    light: [f64; 3],
    /// The point looked at (the centre of the framed box).
    centre: [f64; 3],
    /// Radius of the framed box's bounding sphere.
    radius: f64,
    /// Distance from the centre to the eye for a perspective view.
    eye: Option<f64>,
}

impl View {
    /// The view of `camera` looking at the centre of the box `lo..hi`.
    pub fn new(camera: &Camera, lo: [f64; 3], hi: [f64; 3]) -> Result<View, RenderError> {
        let bad = |reason| Err(RenderError::InvalidCamera { reason });
        let (az, el) = (camera.azimuth_deg, camera.elevation_deg);
        if !(az.is_finite() && el.is_finite()) {
            return bad("azimuth and elevation must be finite");
        }
        if el.abs() > 90.0 {
            return bad("elevation must be between -90 and 90 degrees");
        }
        let (az, el) = (az.to_radians(), el.to_radians());
        let back = [az.sin() * el.cos(), -az.cos() * el.cos(), el.sin()];
        // Taken from the azimuth alone, so it stays defined when looking
        // straight down or up (where z × back vanishes).
        let right = [az.cos(), az.sin(), 0.0];
        let up = cross(back, right);
        let centre = scale(0.5, add(lo, hi));
        let radius = 0.5 * norm(sub(hi, lo));
        let eye = match camera.distance {
            None => None,
            Some(d) if d.is_finite() && d > 1.0 => Some(d * radius),
            Some(_) => return bad("perspective distance must be finite and above 1"),
        };
        let l = LIGHT;
        let light = normalise(add(
            add(scale(l[0], right), scale(l[1], up)),
            scale(l[2], back),
        ));
        Ok(View {
            right,
            up,
            back,
            light,
            centre,
            radius,
            eye,
        })
    }

    /// Radius of the framed box's bounding sphere.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Screen position (world units along right and up; for perspective,
    /// as seen on the plane through the centre) and a depth key of `p`,
    /// or `None` if `p` is not in front of the eye. The key is smaller for
    /// nearer points and varies linearly across the screen image of a
    /// triangle, as a z-buffer needs: the depth itself in an orthographic
    /// view, minus its reciprocal in a perspective one.
    pub fn project(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        let q = sub(p, self.centre);
        let (x, y, z) = (dot(q, self.right), dot(q, self.up), dot(q, self.back));
        match self.eye {
            None => Some([x, y, -z]),
            Some(eye) => {
                let dist = eye - z;
                if dist <= NEAR * self.radius {
                    return None;
                }
                let k = eye / dist;
                Some([x * k, y * k, -1.0 / dist])
            }
        }
    }

    /// Unit vector from `p` towards the eye.
    pub(crate) fn to_eye(&self, p: [f64; 3]) -> [f64; 3] {
        match self.eye {
            None => self.back,
            Some(eye) => normalise(sub(add(self.centre, scale(eye, self.back)), p)),
        }
    }

    /// Brightness of a face with unit normal `n` (facing the viewer).
    pub fn light_factor(&self, n: [f64; 3]) -> f64 {
        AMBIENT + (1.0 - AMBIENT) * dot(n, self.light).max(0.0)
    }
}

/// `base` scaled by `factor` (0..=1), rounded (half up, as `round` does
/// for values ≥ 0; the cast saturates below 0 and above 255, as the clamp
/// did). Per sample of a picture: `f64::round` is a call into libm on
/// this target, 5 % of a 3D run.
pub(crate) fn shade_colour(base: [u8; 3], factor: f64) -> [u8; 3] {
    base.map(|c| (c as f64 * factor + 0.5) as u8)
}

/// Twice the vector area of a triangle or of a (possibly non-planar)
/// quad: for a quad the cross product of its diagonals, which is the mean
/// normal of the bilinear patch.
///
/// # Panics
/// For another number of corners (the faces' pieces have 3 or 4).
fn area_vector(p: &[[f64; 3]]) -> [f64; 3] {
    match *p {
        [a, b, c] => cross(sub(b, a), sub(c, a)),
        [a, b, c, d] => cross(sub(c, a), sub(d, b)),
        _ => panic!("a piece has 3 or 4 corners, not {}", p.len()),
    }
}

/// Unit normal of a triangle or quad ([`area_vector`]), following its
/// corner order; zero for one collapsed to a line or point.
pub(crate) fn polygon_normal(p: &[[f64; 3]]) -> [f64; 3] {
    normalise(area_vector(p))
}

/// Area of a triangle, or of a quad's projection on its mean plane.
pub(crate) fn polygon_area(p: &[[f64; 3]]) -> f64 {
    0.5 * norm(area_vector(p))
}

/// The mean of a triangle's or quad's corners (a quad's summed in pairs,
/// as the hex pictures always did).
pub(crate) fn centroid(p: &[[f64; 3]]) -> [f64; 3] {
    match *p {
        [a, b, c, d] => scale(0.25, add(add(a, b), add(c, d))),
        _ => scale(
            1.0 / p.len() as f64,
            p.iter().fold([0.0; 3], |s, &x| add(s, x)),
        ),
    }
}

/// `a` scaled to unit length, or zero if it has none.
pub(crate) fn normalise(a: [f64; 3]) -> [f64; 3] {
    let n = norm(a);
    if n > 0.0 {
        scale(1.0 / n, a)
    } else {
        [0.0; 3]
    }
}
