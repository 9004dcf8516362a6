//! A small z-buffer rasteriser: triangles painted sample by sample (the
//! painter darkens edge lines), a silhouette pass, and averaging down into
//! a pixmap.

use tiny_skia::{Pixmap, PremultipliedColorU8};

/// Colour of edge and silhouette lines: the soft black of the 2D pictures.
pub(crate) const INK: [u8; 3] = [25, 25, 25];

/// How cell edges are drawn on the faces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct EdgeStyle {
    /// Half the line width in canvas samples: each face darkens this much
    /// along its own border, so a shared edge gets the full width.
    pub half_width: f64,
    /// Opacity of the line.
    pub alpha: f32,
}

/// A white RGB image with a depth per sample (infinite where nothing was
/// drawn), or the band of its rows from `top` on ([`Canvas::rows`]).
pub(crate) struct Canvas {
    width: usize,
    height: usize,
    top: usize,
    rgb: Vec<[u8; 3]>,
    depth: Vec<f32>,
    /// Per sample, the triangle [`Canvas::cover_triangle`] last wrote
    /// ([`NONE`] for none); empty until it is first used.
    owner: Vec<u32>,
}

/// No triangle in [`Canvas`]'s `owner`.
const NONE: u32 = u32::MAX;

impl Canvas {
    /// A blank canvas of `width × height` samples.
    #[cfg(test)]
    pub fn new(width: u32, height: u32) -> Canvas {
        Canvas::rows(width as usize, 0..height as usize)
    }

    /// The rows `rows` of a blank canvas `width` samples wide: triangles
    /// are given in the whole canvas's samples and drawn where they meet
    /// these rows, so bands drawn apart and [`Canvas::stack`]ed are the
    /// canvas drawn whole, sample for sample.
    pub fn rows(width: usize, rows: std::ops::Range<usize>) -> Canvas {
        let n = width * rows.len();
        Canvas { width, height: rows.len(), top: rows.start, rgb: vec![[255; 3]; n], depth: vec![f32::INFINITY; n], owner: Vec::new() }
    }

    /// The bands (in order, from the top) as one canvas.
    pub fn stack(bands: Vec<Canvas>) -> Canvas {
        let width = bands.first().map_or(0, |b| b.width);
        let (mut rgb, mut depth) = (Vec::new(), Vec::new());
        for b in &bands {
            rgb.extend_from_slice(&b.rgb);
            depth.extend_from_slice(&b.depth);
        }
        Canvas { width, height: bands.iter().map(|b| b.height).sum(), top: bands.first().map_or(0, |b| b.top), rgb, depth, owner: Vec::new() }
    }

    /// Whether samples with centres from `lo` to `hi` (y) may be in these
    /// rows.
    pub fn meets_rows(&self, lo: f64, hi: f64) -> bool {
        hi + 0.5 >= self.top as f64 && lo - 0.5 <= (self.top + self.height) as f64
    }

    /// Rasterises one triangle: a sample is inside when its centre is on
    /// the inner side of all three edges (inclusive, so triangles sharing
    /// an edge leave no gap), and is written when its interpolated depth is
    /// nearer than the stored one.
    #[cfg(test)]
    pub(crate) fn fill_triangle(&mut self, t: [[f64; 3]; 3], paint: &impl Fn(f64, f64) -> [u8; 3]) {
        self.rasterise(t, |canvas, i, px, py| canvas.rgb[i] = paint(px, py));
    }

    /// [`Canvas::fill_triangle`] with the painting deferred: the samples
    /// it wins remember `id`, and [`Canvas::paint_owned`] paints each
    /// sample once, for the triangle that won it last — the same picture,
    /// sample for sample, without painting the samples later triangles
    /// cover again.
    pub(crate) fn cover_triangle(&mut self, t: [[f64; 3]; 3], id: u32) {
        if self.owner.is_empty() {
            self.owner = vec![NONE; self.depth.len()];
        }
        self.rasterise(t, |canvas, i, _, _| canvas.owner[i] = id);
    }

    /// Paints every sample a [`Canvas::cover_triangle`] won with
    /// `paint(id, x, y)` at its centre.
    pub(crate) fn paint_owned(&mut self, paint: impl Fn(u32, f64, f64) -> [u8; 3]) {
        for (i, &id) in self.owner.iter().enumerate().filter(|x| *x.1 != NONE) {
            let (x, y) = (i % self.width, i / self.width + self.top);
            self.rgb[i] = paint(id, x as f64 + 0.5, y as f64 + 0.5);
        }
    }

    /// The samples of triangle `t` nearer than what they hold: their depth
    /// stored and `won(self, sample, x, y)` called, in rows from the top.
    fn rasterise(&mut self, t: [[f64; 3]; 3], mut won: impl FnMut(&mut Canvas, usize, f64, f64)) {
        let area = orient(t[0], t[1], t[2][0], t[2][1]);
        // Seen edge-on (or collapsed): nothing to fill, and dividing by the
        // area would give garbage.
        if area.abs() < 1e-9 {
            return;
        }
        let Some((xs, ys)) = self.sample_range(&t) else {
            return;
        };
        for y in ys {
            let py = y as f64 + 0.5;
            for x in xs.clone() {
                let px = x as f64 + 0.5;
                // each weight tested as soon as it is known: most samples
                // of the box around a triangle are outside it
                let w0 = orient(t[1], t[2], px, py) / area;
                if w0 < -1e-9 {
                    continue;
                }
                let w1 = orient(t[2], t[0], px, py) / area;
                if w1 < -1e-9 {
                    continue;
                }
                let w2 = orient(t[0], t[1], px, py) / area;
                if w2 < -1e-9 {
                    continue;
                }
                let w = [w0, w1, w2];
                let depth = (w[0] * t[0][2] + w[1] * t[1][2] + w[2] * t[2][2]) as f32;
                let i = (y - self.top) * self.width + x;
                if depth < self.depth[i] {
                    self.depth[i] = depth;
                    won(self, i, px, py);
                }
            }
        }
    }

    /// The columns and rows of samples whose centres may lie in the
    /// triangle, clamped to the canvas; `None` if it is off the canvas.
    fn sample_range(
        &self,
        t: &[[f64; 3]; 3],
    ) -> Option<(std::ops::Range<usize>, std::ops::Range<usize>)> {
        let span = |k: usize, len: std::ops::Range<usize>| {
            let lo = t.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min);
            let hi = t.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max);
            // Sample i has its centre at i + 0.5.
            let first = (lo - 0.5).ceil().max(len.start as f64);
            let last = (hi - 0.5).floor().min(len.end as f64 - 1.0);
            (first <= last).then(|| first as usize..last as usize + 1)
        };
        Some((span(0, 0..self.width)?, span(1, self.top..self.top + self.height)?))
    }

    /// Darkens covered samples within `radius` samples (horizontally and
    /// vertically) of an uncovered one: the silhouette line, drawn inside
    /// the outline so it never spills onto the background. Samples outside
    /// the canvas count as covered, so a mesh cut off by the frame gets no
    /// line along the cut.
    pub fn outline(&mut self, radius: usize, ink: [u8; 3], alpha: f32) {
        let empty: Vec<bool> = self.depth.iter().map(|d| d.is_infinite()).collect();
        let rows = dilate(&empty, self.width, self.height, radius, 1, self.width);
        let near_empty = dilate_columns(&rows, self.width, self.height, radius);
        for i in 0..self.rgb.len() {
            if near_empty[i] && !empty[i] {
                self.rgb[i] = blend(self.rgb[i], ink, alpha);
            }
        }
    }

    /// Averages each `ss × ss` block of samples into one pixel of `pixmap`
    /// at offset (`x0`, `y0`); blocks with nothing drawn are left alone.
    pub fn blit(&self, pixmap: &mut Pixmap, x0: u32, y0: u32, ss: u32) {
        let ss = ss as usize;
        let (pw, ph) = (pixmap.width() as usize, pixmap.height() as usize);
        let (x0, y0) = (x0 as usize, y0 as usize);
        let pixels = pixmap.pixels_mut();
        for oy in 0..(self.height / ss).min(ph.saturating_sub(y0)) {
            for ox in 0..(self.width / ss).min(pw.saturating_sub(x0)) {
                if let Some([r, g, b]) = self.block_mean(ox * ss, oy * ss, ss) {
                    let c = PremultipliedColorU8::from_rgba(r, g, b, 255);
                    pixels[(y0 + oy) * pw + x0 + ox] = c.expect("opaque colours are valid");
                }
            }
        }
    }

    /// Mean colour of the block with top-left sample (x, y), rounded, or
    /// `None` if no sample in it was drawn.
    fn block_mean(&self, x: usize, y: usize, ss: usize) -> Option<[u8; 3]> {
        let mut sum = [0u32; 3];
        let mut drawn = false;
        for row in y..y + ss {
            for i in row * self.width + x..row * self.width + x + ss {
                drawn |= self.depth[i].is_finite();
                for (s, &c) in sum.iter_mut().zip(&self.rgb[i]) {
                    *s += c as u32;
                }
            }
        }
        let n = (ss * ss) as u32;
        drawn.then(|| sum.map(|s| ((s + n / 2) / n) as u8))
    }
}

/// Twice the signed area of triangle (a, b, p) in the plane: which side of
/// the line a→b the point p is on.
fn orient(a: [f64; 3], b: [f64; 3], px: f64, py: f64) -> f64 {
    (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0])
}

/// Distance in the plane from (x, y) to the segment a–b.
pub(crate) fn distance_to_segment(a: [f64; 3], b: [f64; 3], x: f64, y: f64) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((x - a[0]) * dx + (y - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (ex, ey) = (x - a[0] - t * dx, y - a[1] - t * dy);
    // Not `hypot`: its care for overflow costs much per sample here.
    (ex * ex + ey * ey).sqrt()
}

/// The face colour with the edge line laid over it: full line opacity
/// within the half-width, fading out over one sample so lines at shallow
/// angles do not look stepped.
pub(crate) fn edge_blend(colour: [u8; 3], style: EdgeStyle, distance: f64) -> [u8; 3] {
    let coverage = (style.half_width + 0.5 - distance).clamp(0.0, 1.0) as f32;
    if coverage <= 0.0 {
        return colour;
    }
    blend(colour, INK, style.alpha * coverage)
}

/// `under` with `over` laid on top at opacity `alpha`.
fn blend(under: [u8; 3], over: [u8; 3], alpha: f32) -> [u8; 3] {
    std::array::from_fn(|k| {
        (under[k] as f32 + alpha * (over[k] as f32 - under[k] as f32)).round() as u8
    })
}

/// [`dilate`] along the columns of a `width × height` grid stored row
/// by row, with the same result, but visiting the grid row by row: a
/// count per column of the set flags in the window of rows, moved down
/// one row at a time (the column-wise walk strides a whole row per flag,
/// which cost most of the outline on a large picture).
fn dilate_columns(flags: &[bool], width: usize, height: usize, radius: usize) -> Vec<bool> {
    let mut out = vec![false; flags.len()];
    let mut count = vec![0u32; width];
    let row = |y: usize| &flags[y * width..(y + 1) * width];
    for y in 0..radius.min(height) {
        count.iter_mut().zip(row(y)).for_each(|(c, &f)| *c += f as u32);
    }
    for y in 0..height {
        if y + radius < height {
            count.iter_mut().zip(row(y + radius)).for_each(|(c, &f)| *c += f as u32);
        }
        if y > radius {
            count.iter_mut().zip(row(y - radius - 1)).for_each(|(c, &f)| *c -= f as u32);
        }
        out[y * width..(y + 1) * width].iter_mut().zip(&count).for_each(|(o, &c)| *o = c > 0);
    }
    out
}

/// For a grid of `len` lines of `count` flags each (consecutive flags
/// `step` apart, consecutive lines `stride` apart), whether any flag within
/// `radius` along the line is set. Run once along rows and once along
/// columns this is a square dilation in time independent of the radius.
fn dilate(
    flags: &[bool],
    count: usize,
    lines: usize,
    radius: usize,
    step: usize,
    stride: usize,
) -> Vec<bool> {
    let mut out = vec![false; flags.len()];
    let mut prefix = vec![0u32; count + 1];
    for line in 0..lines {
        let at = |i: usize| line * stride + i * step;
        for i in 0..count {
            prefix[i + 1] = prefix[i] + flags[at(i)] as u32;
        }
        for i in 0..count {
            let (lo, hi) = (i.saturating_sub(radius), (i + radius + 1).min(count));
            out[at(i)] = prefix[hi] > prefix[lo];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quad `q` in a plain colour, as two triangles split along the
    /// 0–2 diagonal, as the surface is drawn.
    fn quad(c: &mut Canvas, q: [[f64; 2]; 4], depth: f64, colour: [u8; 3]) {
        let q = q.map(|[x, y]| [x, y, depth]);
        c.fill_triangle([q[0], q[1], q[2]], &|_, _| colour);
        c.fill_triangle([q[0], q[2], q[3]], &|_, _| colour);
    }

    #[test]
    fn nearer_quad_wins_whatever_the_drawing_order() {
        let square = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let (far, near) = ((5.0, [255, 0, 0]), (1.0, [0, 0, 255]));
        for order in [[far, near], [near, far]] {
            let mut c = Canvas::new(10, 10);
            for (depth, colour) in order {
                quad(&mut c, square, depth, colour);
            }
            assert!(c.rgb.iter().all(|&p| p == [0, 0, 255]));
            assert!(c.depth.iter().all(|&d| d == 1.0));
        }
    }

    #[test]
    fn neighbouring_quads_leave_no_gap_and_either_winding_fills() {
        let mut c = Canvas::new(20, 10);
        let left = [[0.0, 0.0], [7.3, 0.0], [7.3, 10.0], [0.0, 10.0]];
        // Clockwise on screen: must fill as well.
        let right = [[7.3, 0.0], [7.3, 10.0], [20.0, 10.0], [20.0, 0.0]];
        quad(&mut c, left, 0.0, [1, 1, 1]);
        quad(&mut c, right, 0.0, [2, 2, 2]);
        assert!(c.depth.iter().all(|d| d.is_finite()));
    }

    #[test]
    fn edge_lines_fade_over_one_sample_around_the_half_width() {
        let style = EdgeStyle {
            half_width: 1.5,
            alpha: 1.0,
        };
        let grey = [200, 200, 200];
        assert_eq!(edge_blend(grey, style, 1.0), INK);
        assert_eq!(edge_blend(grey, style, 2.0), grey);
        let half = edge_blend(grey, style, 1.5);
        assert!(half[0] > INK[0] && half[0] < grey[0], "{half:?}");
        let (a, b) = ([0.0, 0.0, 0.0], [10.0, 0.0, 0.0]);
        assert_eq!(distance_to_segment(a, b, 5.0, 2.0), 2.0);
        assert_eq!(distance_to_segment(a, b, 13.0, 4.0), 5.0);
    }

    proptest::proptest! {
        /// The row-by-row column dilation is the column-wise walk's.
        #[test]
        fn dilate_columns_is_dilate_along_columns(width in 1usize..12, height in 1usize..12, radius in 0usize..5, seed in 0u64..u64::MAX) {
            let mut s = seed;
            let flags: Vec<bool> = (0..width * height).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); s >> 61 == 0 }).collect();
            proptest::prop_assert_eq!(dilate_columns(&flags, width, height, radius), dilate(&flags, height, width, radius, width, 1));
        }
    }

    #[test]
    fn outline_marks_covered_samples_next_to_empty_ones() {
        let mut c = Canvas::new(10, 10);
        quad(
            &mut c,
            [[2.0, 2.0], [8.0, 2.0], [8.0, 8.0], [2.0, 8.0]],
            0.0,
            [200, 200, 200],
        );
        c.outline(1, INK, 1.0);
        assert_eq!(c.rgb[2 * 10 + 2], INK);
        assert_eq!(c.rgb[5 * 10 + 2], INK);
        assert_eq!(c.rgb[5 * 10 + 5], [200, 200, 200]);
        assert_eq!(c.rgb[0], [255, 255, 255], "background stays white");
    }
}
