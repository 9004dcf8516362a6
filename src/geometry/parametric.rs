//! Curves of the plane given by a parameter (superellipses, splines),
//! queried numerically: a fine polyline brackets the closest point and the
//! ray crossings, which are then refined on the parameter with Brent's
//! method.

use super::solvers::brent_root;
use crate::numeric::{cross2, dist2, dot, norm, rot_cw, sub, unit};

/// Target polyline resolution used to bracket numeric queries: the sampled
/// polyline has chords no longer than its length divided by this.
const SAMPLES_PER_LENGTH: f64 = 512.0;

/// A curve with a parameter, for the numeric closest-point and ray queries.
pub(super) trait Param {
    /// The curve point at parameter `t`.
    fn point(&self, t: f64) -> [f64; 2];
    /// A tangent in the direction of increasing `t` (any positive length).
    fn tangent(&self, t: f64) -> [f64; 2];
}

/// Our normal convention applied to a parametric curve.
pub(super) fn param_normal<C: Param>(c: &C, t: f64) -> [f64; 2] {
    unit(rot_cw(c.tangent(t)))
}

/// A polyline sampling of a parametric curve, used to bracket queries.
#[derive(Debug, Clone)]
pub(super) struct Samples {
    t: Vec<f64>,
    p: Vec<[f64; 2]>,
    /// `Some(T)` for a closed curve with period `T` (the last sample then
    /// connects to the first at parameter `t[0] + T`).
    period: Option<f64>,
    /// Longest chord between consecutive samples.
    h_max: f64,
    /// Length of the polyline.
    pub(super) length: f64,
}

impl Samples {
    /// No samples: a placeholder while a curve that samples itself is built.
    pub(super) fn empty() -> Samples {
        Samples { t: vec![], p: vec![], period: None, h_max: 0.0, length: 0.0 }
    }

    /// Samples at `params` (increasing; the end of the domain is included
    /// for an open curve and excluded for a periodic one), then bisects
    /// chords until none is longer than the polyline length over
    /// [`SAMPLES_PER_LENGTH`], so no detail of the curve is skipped.
    pub(super) fn new<C: Param>(c: &C, params: &[f64], period: Option<f64>) -> Samples {
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
pub(super) fn closest_param<C: Param>(c: &C, s: &Samples, p: [f64; 2]) -> f64 {
    let d2: Vec<f64> = s.p.iter().map(|q| dist2(*q, p)).collect();
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
/// `c`: sign changes of `cross2(dir, c(t) − origin)` along the polyline,
/// each refined with Brent's method.
pub(super) fn ray_param<C: Param>(
    c: &C,
    s: &Samples,
    origin: [f64; 2],
    dir: [f64; 2],
    s_min: f64,
) -> Option<f64> {
    let side = |q: [f64; 2]| cross2(dir, sub(q, origin));
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
