//! A small built-in 5×7 bitmap font (with two descender rows), drawn by
//! filling integer-scaled squares, because tiny-skia has no text support.
//!
//! Each glyph is nine rows of five bits (bit 4 is the leftmost column).
//! Rows 0–6 hold capitals and digits; rows 7–8 hold descenders (g, j, p,
//! q, y, comma). Characters without a glyph are drawn as a hollow box so
//! that missing coverage is visible rather than silently dropped.

use tiny_skia::{Color, Paint, Pixmap, Rect, Transform};

/// Width of a glyph in font pixels.
pub const GLYPH_WIDTH: u32 = 5;
/// Height of capitals and digits in font pixels (the baseline is below it).
pub const CAP_HEIGHT: u32 = 7;
/// Full glyph height including descenders, in font pixels.
pub const GLYPH_HEIGHT: u32 = 9;
/// Horizontal advance per character in font pixels (one column of spacing).
pub const ADVANCE: u32 = 6;

/// A glyph bitmap: nine rows, five bits each, bit 4 leftmost.
pub type Glyph = [u8; 9];

/// Pads a seven-row glyph (no descender) to the full nine rows.
const fn g(r: [u8; 7]) -> Glyph {
    [r[0], r[1], r[2], r[3], r[4], r[5], r[6], 0, 0]
}

/// Shown for characters the font does not cover.
const MISSING: Glyph = g([
    0b11111, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b11111,
]);

/// The bitmap of `c`, or `None` if the font does not cover it.
pub fn glyph(c: char) -> Option<Glyph> {
    digit(c)
        .or_else(|| upper(c))
        .or_else(|| lower(c))
        .or_else(|| punctuation(c))
}

fn digit(c: char) -> Option<Glyph> {
    Some(match c {
        '0' => g([
            0b01110, 0b10001, 0b10011, 0b10101, 0b11001, 0b10001, 0b01110,
        ]),
        '1' => g([
            0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ]),
        '2' => g([
            0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111,
        ]),
        '3' => g([
            0b11111, 0b00010, 0b00100, 0b00010, 0b00001, 0b10001, 0b01110,
        ]),
        '4' => g([
            0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010,
        ]),
        '5' => g([
            0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110,
        ]),
        '6' => g([
            0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110,
        ]),
        '7' => g([
            0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000,
        ]),
        '8' => g([
            0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110,
        ]),
        '9' => g([
            0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100,
        ]),
        _ => return None,
    })
}

fn upper(c: char) -> Option<Glyph> {
    Some(match c {
        'A' => g([
            0b01110, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001,
        ]),
        'B' => g([
            0b11110, 0b10001, 0b10001, 0b11110, 0b10001, 0b10001, 0b11110,
        ]),
        'C' => g([
            0b01110, 0b10001, 0b10000, 0b10000, 0b10000, 0b10001, 0b01110,
        ]),
        'D' => g([
            0b11100, 0b10010, 0b10001, 0b10001, 0b10001, 0b10010, 0b11100,
        ]),
        'E' => g([
            0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b11111,
        ]),
        'F' => g([
            0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b10000,
        ]),
        'G' => g([
            0b01110, 0b10001, 0b10000, 0b10111, 0b10001, 0b10001, 0b01111,
        ]),
        'H' => g([
            0b10001, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001,
        ]),
        'I' => g([
            0b01110, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ]),
        'J' => g([
            0b00111, 0b00010, 0b00010, 0b00010, 0b00010, 0b10010, 0b01100,
        ]),
        'K' => g([
            0b10001, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010, 0b10001,
        ]),
        'L' => g([
            0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b11111,
        ]),
        'M' => g([
            0b10001, 0b11011, 0b10101, 0b10101, 0b10001, 0b10001, 0b10001,
        ]),
        'N' => g([
            0b10001, 0b10001, 0b11001, 0b10101, 0b10011, 0b10001, 0b10001,
        ]),
        'O' => g([
            0b01110, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110,
        ]),
        'P' => g([
            0b11110, 0b10001, 0b10001, 0b11110, 0b10000, 0b10000, 0b10000,
        ]),
        'Q' => g([
            0b01110, 0b10001, 0b10001, 0b10001, 0b10101, 0b10010, 0b01101,
        ]),
        'R' => g([
            0b11110, 0b10001, 0b10001, 0b11110, 0b10100, 0b10010, 0b10001,
        ]),
        'S' => g([
            0b01111, 0b10000, 0b10000, 0b01110, 0b00001, 0b00001, 0b11110,
        ]),
        'T' => g([
            0b11111, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100,
        ]),
        'U' => g([
            0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110,
        ]),
        'V' => g([
            0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100,
        ]),
        'W' => g([
            0b10001, 0b10001, 0b10001, 0b10101, 0b10101, 0b10101, 0b01010,
        ]),
        'X' => g([
            0b10001, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001, 0b10001,
        ]),
        'Y' => g([
            0b10001, 0b10001, 0b10001, 0b01010, 0b00100, 0b00100, 0b00100,
        ]),
        'Z' => g([
            0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b11111,
        ]),
        _ => return None,
    })
}

fn lower(c: char) -> Option<Glyph> {
    Some(match c {
        'a' => g([0, 0, 0b01110, 0b00001, 0b01111, 0b10001, 0b01111]),
        'b' => g([
            0b10000, 0b10000, 0b10110, 0b11001, 0b10001, 0b10001, 0b11110,
        ]),
        'c' => g([0, 0, 0b01110, 0b10000, 0b10000, 0b10001, 0b01110]),
        'd' => g([
            0b00001, 0b00001, 0b01101, 0b10011, 0b10001, 0b10001, 0b01111,
        ]),
        'e' => g([0, 0, 0b01110, 0b10001, 0b11111, 0b10000, 0b01110]),
        'f' => g([
            0b00110, 0b01001, 0b01000, 0b11100, 0b01000, 0b01000, 0b01000,
        ]),
        'g' => [
            0, 0, 0b01111, 0b10001, 0b10001, 0b10001, 0b01111, 0b00001, 0b01110,
        ],
        'h' => g([
            0b10000, 0b10000, 0b10110, 0b11001, 0b10001, 0b10001, 0b10001,
        ]),
        'i' => g([0b00100, 0, 0b01100, 0b00100, 0b00100, 0b00100, 0b01110]),
        'j' => [
            0b00010, 0, 0b00110, 0b00010, 0b00010, 0b00010, 0b00010, 0b10010, 0b01100,
        ],
        'k' => g([
            0b10000, 0b10000, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010,
        ]),
        'l' => g([
            0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ]),
        'm' => g([0, 0, 0b11010, 0b10101, 0b10101, 0b10001, 0b10001]),
        'n' => g([0, 0, 0b10110, 0b11001, 0b10001, 0b10001, 0b10001]),
        'o' => g([0, 0, 0b01110, 0b10001, 0b10001, 0b10001, 0b01110]),
        'p' => [
            0, 0, 0b11110, 0b10001, 0b10001, 0b10001, 0b11110, 0b10000, 0b10000,
        ],
        'q' => [
            0, 0, 0b01111, 0b10001, 0b10001, 0b10001, 0b01111, 0b00001, 0b00001,
        ],
        'r' => g([0, 0, 0b10110, 0b11001, 0b10000, 0b10000, 0b10000]),
        's' => g([0, 0, 0b01111, 0b10000, 0b01110, 0b00001, 0b11110]),
        't' => g([
            0b01000, 0b01000, 0b11100, 0b01000, 0b01000, 0b01001, 0b00110,
        ]),
        'u' => g([0, 0, 0b10001, 0b10001, 0b10001, 0b10011, 0b01101]),
        'v' => g([0, 0, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100]),
        'w' => g([0, 0, 0b10001, 0b10001, 0b10101, 0b10101, 0b01010]),
        'x' => g([0, 0, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001]),
        'y' => [
            0, 0, 0b10001, 0b10001, 0b10001, 0b10001, 0b01111, 0b00001, 0b01110,
        ],
        'z' => g([0, 0, 0b11111, 0b00010, 0b00100, 0b01000, 0b11111]),
        _ => return None,
    })
}

fn punctuation(c: char) -> Option<Glyph> {
    Some(match c {
        ' ' => g([0; 7]),
        '.' => g([0, 0, 0, 0, 0, 0b01100, 0b01100]),
        ',' => [0, 0, 0, 0, 0, 0b01100, 0b01100, 0b00100, 0b01000],
        ':' => g([0, 0b01100, 0b01100, 0, 0b01100, 0b01100, 0]),
        ';' => [
            0, 0b01100, 0b01100, 0, 0b01100, 0b01100, 0b00100, 0b01000, 0,
        ],
        '-' => g([0, 0, 0, 0b11111, 0, 0, 0]),
        '+' => g([0, 0b00100, 0b00100, 0b11111, 0b00100, 0b00100, 0]),
        '=' => g([0, 0, 0b11111, 0, 0b11111, 0, 0]),
        '/' => g([0, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0]),
        '(' => g([
            0b00010, 0b00100, 0b01000, 0b01000, 0b01000, 0b00100, 0b00010,
        ]),
        ')' => g([
            0b01000, 0b00100, 0b00010, 0b00010, 0b00010, 0b00100, 0b01000,
        ]),
        '[' => g([
            0b01110, 0b01000, 0b01000, 0b01000, 0b01000, 0b01000, 0b01110,
        ]),
        ']' => g([
            0b01110, 0b00010, 0b00010, 0b00010, 0b00010, 0b00010, 0b01110,
        ]),
        '<' => g([
            0b00010, 0b00100, 0b01000, 0b10000, 0b01000, 0b00100, 0b00010,
        ]),
        '>' => g([
            0b01000, 0b00100, 0b00010, 0b00001, 0b00010, 0b00100, 0b01000,
        ]),
        '%' => g([
            0b11000, 0b11001, 0b00010, 0b00100, 0b01000, 0b10011, 0b00011,
        ]),
        '!' => g([0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0, 0b00100]),
        '?' => g([0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0, 0b00100]),
        '*' => g([0, 0b00100, 0b10101, 0b01110, 0b10101, 0b00100, 0]),
        '#' => g([
            0b01010, 0b01010, 0b11111, 0b01010, 0b11111, 0b01010, 0b01010,
        ]),
        '|' => g([0b00100; 7]),
        '_' => [0, 0, 0, 0, 0, 0, 0, 0, 0b11111],
        '\'' => g([0b01100, 0b00100, 0b01000, 0, 0, 0, 0]),
        '"' => g([0b01010, 0b01010, 0b01010, 0, 0, 0, 0]),
        '^' => g([0b00100, 0b01010, 0b10001, 0, 0, 0, 0]),
        '~' => g([0, 0, 0b01000, 0b10101, 0b00010, 0, 0]),
        '&' => g([
            0b01100, 0b10010, 0b10100, 0b01000, 0b10101, 0b10010, 0b01101,
        ]),
        '×' => g([0, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001, 0]),
        _ => return None,
    })
}

/// Width in image pixels of `text` drawn at integer `scale`, without the
/// trailing spacing column after the last character.
pub fn text_width(text: &str, scale: u32) -> u32 {
    let n = text.chars().count() as u32;
    if n == 0 {
        0
    } else {
        (n * ADVANCE - (ADVANCE - GLYPH_WIDTH)) * scale
    }
}

/// Draws `text` with its top-left corner (top of the capitals) at `(x, y)`,
/// each font pixel an opaque `scale × scale` square of `colour`.
/// Pixels outside the image are clipped.
pub fn draw_text(pixmap: &mut Pixmap, text: &str, x: i32, y: i32, scale: u32, colour: Color) {
    // Squares on integer pixel positions need no anti-aliasing, and without
    // it the glyphs stay crisp.
    let mut paint = Paint {
        anti_alias: false,
        ..Paint::default()
    };
    paint.set_color(colour);
    for (i, c) in text.chars().enumerate() {
        let left = x + (i as u32 * ADVANCE * scale) as i32;
        draw_glyph(pixmap, glyph(c).unwrap_or(MISSING), left, y, scale, &paint);
    }
}

/// Fills one glyph, merging horizontal runs of set bits into one rectangle
/// each to keep the number of fill calls small.
fn draw_glyph(pixmap: &mut Pixmap, rows: Glyph, x: i32, y: i32, scale: u32, paint: &Paint) {
    let s = scale as f32;
    for (r, &bits) in rows.iter().enumerate() {
        let mut col = 0;
        while col < GLYPH_WIDTH {
            if !is_set(bits, col) {
                col += 1;
                continue;
            }
            let start = col;
            while col < GLYPH_WIDTH && is_set(bits, col) {
                col += 1;
            }
            let left = x as f32 + start as f32 * s;
            let top = y as f32 + r as f32 * s;
            if let Some(rect) = Rect::from_xywh(left, top, (col - start) as f32 * s, s) {
                pixmap.fill_rect(rect, paint, Transform::identity(), None);
            }
        }
    }
}

/// Whether column `col` (0 = leftmost) of a glyph row is set.
fn is_set(bits: u8, col: u32) -> bool {
    bits & (1 << (GLYPH_WIDTH - 1 - col)) != 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_are_distinct() {
        let digits: Vec<Glyph> = ('0'..='9').map(|c| glyph(c).unwrap()).collect();
        for i in 0..digits.len() {
            for j in i + 1..digits.len() {
                assert_ne!(digits[i], digits[j], "digits {i} and {j} share a bitmap");
            }
        }
    }

    #[test]
    fn covers_letters_and_symbols_without_stray_bits() {
        let needed = ('a'..='z').chain('A'..='Z').chain(" .-+=/:(),e%".chars());
        for c in needed {
            let rows = glyph(c).unwrap_or_else(|| panic!("no glyph for {c:?}"));
            assert!(rows.iter().all(|&r| r < 32), "glyph {c:?} wider than 5");
            if c != ' ' {
                assert!(rows.iter().any(|&r| r != 0), "glyph {c:?} is blank");
            }
        }
        // Letters must differ from each other too, or words become ambiguous.
        let letters: Vec<(char, Glyph)> = ('a'..='z')
            .chain('A'..='Z')
            .map(|c| (c, glyph(c).unwrap()))
            .collect();
        for (i, a) in letters.iter().enumerate() {
            for b in &letters[i + 1..] {
                assert_ne!(a.1, b.1, "{} and {} share a bitmap", a.0, b.0);
            }
        }
    }

    #[test]
    fn drawn_text_sets_exactly_the_glyph_pixels() {
        let mut p = Pixmap::new(20, 20).unwrap();
        p.fill(Color::WHITE);
        draw_text(&mut p, "1", 2, 3, 2, Color::BLACK);
        let rows = glyph('1').unwrap();
        for y in 0..20u32 {
            for x in 0..20u32 {
                let (fx, fy) = (x as i32 - 2, y as i32 - 3);
                let inside = (0..10).contains(&fx) && (0..18).contains(&fy);
                let set = inside && is_set(rows[(fy / 2) as usize], (fx / 2) as u32);
                let px = p.pixel(x, y).unwrap();
                assert_eq!(px.red() == 0, set, "pixel ({x},{y})");
            }
        }
        assert_eq!(text_width("1.5", 2), (3 * ADVANCE - 1) * 2);
    }
}
