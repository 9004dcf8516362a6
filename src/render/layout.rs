//! Where everything goes in the picture: the plot area that the world box
//! maps to, the colour bar, its labels and the title.

use super::font::{text_width, ADVANCE, CAP_HEIGHT, GLYPH_HEIGHT};
use super::RenderError;

/// Narrowest image we lay out; below this the colour bar and its labels
/// would not leave room for the mesh.
pub(crate) const MIN_WIDTH: u32 = 200;

/// Pixel positions of all parts of one picture.
#[derive(Clone, Debug)]
pub(crate) struct Layout {
    /// Image size in pixels.
    pub width: u32,
    pub height: u32,
    /// Integer factor applied to the 5×7 font for labels (the title uses
    /// one more).
    pub text_scale: u32,
    /// Plot area (x, y, w, h) in pixels: exactly the world box.
    pub plot: [f64; 4],
    /// Lower-left corner of the world box.
    origin: [f64; 2],
    /// Pixels per world unit (equal on both axes, so shapes are not
    /// distorted).
    px_per_unit: f64,
    /// Colour bar (x, y, w, h) in whole pixels, so each row has one value.
    pub bar: [u32; 4],
    /// Length of the tick marks right of the bar.
    pub tick_len: u32,
    /// Top of the colour-bar label (above the bar).
    pub label_top: i32,
    /// Top of the title.
    pub title_top: i32,
    /// Blank border around everything.
    pub margin: f64,
}

impl Layout {
    /// Lays out a picture `width` pixels wide framing `bounds`, with a
    /// title line if `has_title`, and a colour bar labelled `label` whose
    /// ticks read `tick_labels`.
    pub fn new(
        width: u32,
        bounds: ([f64; 2], [f64; 2]),
        has_title: bool,
        label: &str,
        tick_labels: &[String],
    ) -> Result<Layout, RenderError> {
        if width < MIN_WIDTH {
            return Err(RenderError::ImageSize { width, height: 0 });
        }
        let w = width as f64;
        // Font scale: 1 only for small images; from 360 px on, at least 2,
        // since 7-pixel digits are too small to read comfortably.
        let s = if width < 360 {
            1
        } else {
            ((w / 450.0).round() as u32).max(2)
        };
        let margin = (w / 50.0).round().max(8.0);
        let line = (GLYPH_HEIGHT * s) as f64;

        let title_h = if has_title {
            (GLYPH_HEIGHT * (s + 1)) as f64 + margin
        } else {
            0.0
        };
        let label_h = if label.is_empty() { 0.0 } else { line + margin };
        let top = margin + title_h + label_h;

        // Right panel: gap, bar, ticks, tick labels; wide enough for the
        // bar label too.
        let gap = 1.5 * margin;
        let bar_w = (w / 36.0).round().max(10.0);
        let tick_len = 2 * s + 1;
        let tick_text = tick_labels
            .iter()
            .map(|t| text_width(t, s))
            .max()
            .unwrap_or(0);
        let beside_bar = bar_w + (tick_len + ADVANCE * s + tick_text) as f64;
        let panel = gap + beside_bar.max(text_width(label, s) as f64) + margin;
        let avail_w = w - margin - panel;
        if avail_w < 40.0 {
            return Err(RenderError::ImageSize { width, height: 0 });
        }

        let (lo, hi) = bounds;
        let (dx, dy) = (hi[0] - lo[0], hi[1] - lo[1]);
        // Tall domains would give absurdly tall images: cap the plot at three
        // times the image width and shrink it horizontally instead.
        let k = (avail_w / dx).min(3.0 * w / dy);
        let (pw, ph) = (dx * k, dy * k);
        // The bar needs room for five readable ticks even beside a flat plot.
        let content_h = ph.max(10.0 * line).round();
        let plot = [
            margin + 0.5 * (avail_w - pw),
            top + 0.5 * (content_h - ph),
            pw,
            ph,
        ];

        let height = (top + content_h + margin).ceil();
        if !height.is_finite() || height >= u32::MAX as f64 {
            return Err(RenderError::ImageSize {
                width,
                height: u32::MAX,
            });
        }
        Ok(Layout {
            width,
            height: height as u32,
            text_scale: s,
            plot,
            origin: lo,
            px_per_unit: k,
            bar: [
                (margin + avail_w + gap).round() as u32,
                top as u32,
                bar_w as u32,
                content_h as u32,
            ],
            tick_len,
            label_top: (top - label_h) as i32,
            title_top: margin as i32,
            margin,
        })
    }

    /// The pixel position of world point `p` (y up in the world, down in
    /// the image).
    pub fn to_px(&self, p: [f64; 2]) -> (f32, f32) {
        let x = self.plot[0] + (p[0] - self.origin[0]) * self.px_per_unit;
        let y = self.plot[1] + self.plot[3] - (p[1] - self.origin[1]) * self.px_per_unit;
        (x as f32, y as f32)
    }

    /// Pixels per world unit.
    pub fn scale(&self) -> f64 {
        self.px_per_unit
    }

    /// How much wider lines are than at the reference width of 900 pixels
    /// (at least 0.75, so small pictures keep visible lines).
    pub fn res(&self) -> f32 {
        (self.width as f32 / 900.0).max(0.75)
    }

    /// The pixel rectangle (x, y, w, h) the mesh may be drawn in: the plot
    /// area widened by half a margin, so a boundary or silhouette on the
    /// frame is not cut while a mesh outside a user-given box stays off
    /// the colour bar.
    pub fn plot_region(&self) -> [u32; 4] {
        let pad = 0.5 * self.margin;
        let [x, y, w, h] = self.plot;
        let (width, height) = (self.width as f64, self.height as f64);
        let x0 = (x - pad).floor().clamp(0.0, width) as u32;
        let y0 = (y - pad).floor().clamp(0.0, height) as u32;
        let x1 = (x + w + pad).ceil().clamp(x0 as f64, width) as u32;
        let y1 = (y + h + pad).ceil().clamp(y0 as f64, height) as u32;
        [x0, y0, x1 - x0, y1 - y0]
    }

    /// Pixel row of the bar showing fraction `t` of the range (0 = low end
    /// at the bottom row, 1 = high end at the top row).
    pub fn bar_row(&self, t: f64) -> u32 {
        let [_, y, _, h] = self.bar;
        y + ((1.0 - t) * (h - 1) as f64).round() as u32
    }

    /// Height of capitals of label text in pixels.
    pub fn cap_height(&self) -> u32 {
        CAP_HEIGHT * self.text_scale
    }
}
