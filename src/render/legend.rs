//! What surrounds the plot: the colour bar (gradient, ticks, compact tick
//! labels and its label) and the title.

use tiny_skia::{Paint, PathBuilder, Pixmap, Rect, Stroke, Transform};

use super::colour::ColourMap;
use super::font::{draw_text, text_width};
use super::layout::Layout;
use super::{ink, text_colour};

/// Number of ticks on the colour bar, both range ends included.
pub(crate) const NUM_TICKS: usize = 5;

/// Evenly spaced tick values from the low to the high end of `range`.
pub(crate) fn tick_values(range: (f64, f64)) -> [f64; NUM_TICKS] {
    let step = (range.1 - range.0) / (NUM_TICKS - 1) as f64;
    // The last tick is set exactly so the top label shows the range end.
    std::array::from_fn(|i| {
        if i == NUM_TICKS - 1 {
            range.1
        } else {
            range.0 + i as f64 * step
        }
    })
}

/// Formats tick values compactly but exactly enough: the fewest decimals
/// (at most two beyond what the spacing needs) that represent every tick,
/// trailing zeros dropped; scientific notation for very small or large
/// magnitudes (e.g. `1e-3`).
pub(crate) fn format_ticks(ticks: &[f64]) -> Vec<String> {
    let max_abs = ticks.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut step = (ticks[ticks.len() - 1] - ticks[0]).abs() / (ticks.len().max(2) - 1) as f64;
    if step.is_nan() || step <= 0.0 {
        step = if max_abs > 0.0 { max_abs } else { 1.0 };
    }
    let tol = 1e-6 * step;
    if max_abs >= 1e5 || (max_abs < 1e-3 && max_abs > 0.0) {
        format_all(ticks, tol, 0..=3, 3, |v, p| {
            trim_exponent(&format!("{v:.p$e}"))
        })
    } else {
        let d0 = (-step.log10()).ceil().max(0.0) as usize;
        format_all(ticks, tol, d0..=d0 + 2, d0 + 1, |v, d| {
            trim_zeros(&format!("{v:.d$}"))
        })
    }
}

/// Formats all ticks with the first precision in `tries` that reproduces
/// every tick within `tol`, or with `fallback` if none does.
fn format_all(
    ticks: &[f64],
    tol: f64,
    tries: std::ops::RangeInclusive<usize>,
    fallback: usize,
    fmt: impl Fn(f64, usize) -> String,
) -> Vec<String> {
    let exact = |p: usize| {
        ticks
            .iter()
            .all(|&v| fmt(v, p).parse::<f64>().is_ok_and(|r| (r - v).abs() <= tol))
    };
    let p = tries.into_iter().find(|&p| exact(p)).unwrap_or(fallback);
    ticks
        .iter()
        .map(|&v| {
            if v.abs() <= tol {
                "0".to_string()
            } else {
                fmt(v, p)
            }
        })
        .collect()
}

/// "1.2500" → "1.25", "2.000" → "2", "-0.00" → "0".
fn trim_zeros(s: &str) -> String {
    let t = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    };
    if t == "-0" {
        "0".to_string()
    } else {
        t.to_string()
    }
}

/// "1.500e-4" → "1.5e-4".
fn trim_exponent(s: &str) -> String {
    match s.split_once('e') {
        Some((m, e)) => format!("{}e{e}", trim_zeros(m)),
        None => s.to_string(),
    }
}

/// Draws the colour bar with ticks, tick labels and `label` above it.
pub(crate) fn draw_colour_bar(
    pixmap: &mut Pixmap,
    layout: &Layout,
    cmap: ColourMap,
    range: (f64, f64),
    tick_labels: &[String],
    label: &str,
) {
    draw_gradient(pixmap, layout, cmap, range);
    draw_frame(pixmap, layout);
    draw_ticks(pixmap, layout, tick_labels);
    let s = layout.text_scale;
    draw_text(
        pixmap,
        label,
        layout.bar[0] as i32,
        layout.label_top,
        s,
        text_colour(),
    );
}

/// The title, one font step larger than the labels, centred over the plot
/// but kept inside the image.
pub(crate) fn draw_title(pixmap: &mut Pixmap, layout: &Layout, title: &str) {
    let s = layout.text_scale + 1;
    let w = text_width(title, s) as f64;
    let centre = layout.plot[0] + 0.5 * layout.plot[2];
    let max_x = (layout.width as f64 - layout.margin - w).max(0.0);
    let x = (centre - 0.5 * w).clamp(layout.margin.min(max_x), max_x);
    draw_text(pixmap, title, x as i32, layout.title_top, s, text_colour());
}

/// One-pixel rows from the high end (top row) to the low end (bottom row).
fn draw_gradient(pixmap: &mut Pixmap, layout: &Layout, cmap: ColourMap, range: (f64, f64)) {
    let [x, y, w, h] = layout.bar;
    let mut paint = Paint {
        anti_alias: false,
        ..Paint::default()
    };
    for r in 0..h {
        let t = if h > 1 {
            1.0 - r as f64 / (h - 1) as f64
        } else {
            0.5
        };
        let [cr, cg, cb] = cmap.colour(range.0 + t * (range.1 - range.0), range);
        paint.set_color_rgba8(cr, cg, cb, 255);
        if let Some(rect) = Rect::from_xywh(x as f32, (y + r) as f32, w as f32, 1.0) {
            pixmap.fill_rect(rect, &paint, Transform::identity(), None);
        }
    }
}

/// A thin dark frame just outside the bar, so the bar's own end rows keep
/// the exact colours of the range ends.
fn draw_frame(pixmap: &mut Pixmap, layout: &Layout) {
    let [x, y, w, h] = layout.bar.map(|v| v as f32);
    let Some(rect) = Rect::from_xywh(x - 0.5, y - 0.5, w + 1.0, h + 1.0) else {
        return;
    };
    let path = PathBuilder::from_rect(rect);
    let mut paint = Paint::default();
    paint.set_color(ink());
    let stroke = Stroke {
        width: 1.0,
        ..Stroke::default()
    };
    pixmap.stroke_path(&path, &paint, &stroke, Transform::identity(), None);
}

/// Tick marks right of the bar, each with its label centred on it.
fn draw_ticks(pixmap: &mut Pixmap, layout: &Layout, tick_labels: &[String]) {
    let [x, _, w, _] = layout.bar;
    let s = layout.text_scale;
    let mut paint = Paint {
        anti_alias: false,
        ..Paint::default()
    };
    paint.set_color(ink());
    let n = tick_labels.len();
    for (i, text) in tick_labels.iter().enumerate() {
        let t = if n > 1 {
            i as f64 / (n - 1) as f64
        } else {
            0.5
        };
        let row = layout.bar_row(t) as f32;
        // Whole-pixel rectangles keep tick marks crisp at every scale.
        let top = (row + 0.5 - s as f32 / 2.0).round();
        if let Some(rect) =
            Rect::from_xywh((x + w + 1) as f32, top, layout.tick_len as f32, s as f32)
        {
            pixmap.fill_rect(rect, &paint, Transform::identity(), None);
        }
        let text_x = (x + w + 1 + layout.tick_len + s * 2) as i32;
        let text_y = row as i32 - (layout.cap_height() as i32 - 1) / 2;
        draw_text(pixmap, text, text_x, text_y, s, text_colour());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fmt(range: (f64, f64)) -> Vec<String> {
        format_ticks(&tick_values(range))
    }

    #[test]
    fn ticks_are_compact_and_exact() {
        assert_eq!(fmt((0.0, 1.0)), ["0", "0.25", "0.5", "0.75", "1"]);
        assert_eq!(
            fmt((0.85, 1.10)),
            ["0.85", "0.9125", "0.975", "1.0375", "1.1"]
        );
        assert_eq!(fmt((0.8, 1.2)), ["0.8", "0.9", "1", "1.1", "1.2"]);
        assert_eq!(fmt((-2.0, 2.0)), ["-2", "-1", "0", "1", "2"]);
        assert_eq!(fmt((0.0, 400.0)), ["0", "100", "200", "300", "400"]);
    }

    #[test]
    fn tiny_and_huge_values_use_exponents() {
        assert_eq!(
            fmt((0.0, 1e-3 * 0.8)),
            ["0", "2e-4", "4e-4", "6e-4", "8e-4"]
        );
        assert_eq!(fmt((1e5, 5e5)), ["1e5", "2e5", "3e5", "4e5", "5e5"]);
        assert_eq!(format_ticks(&[1e-4, 1.5e-4]), ["1e-4", "1.5e-4"]);
    }

    #[test]
    fn awkward_spacing_still_gives_distinct_labels() {
        let labels = fmt((0.123456, 0.987654));
        for i in 1..labels.len() {
            assert_ne!(labels[i - 1], labels[i]);
        }
        assert!(labels.iter().all(|l| l.len() <= 7), "{labels:?}");
    }
}
