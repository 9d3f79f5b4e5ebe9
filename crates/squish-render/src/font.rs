//! A tiny built-in bitmap font (5 × 7 pixel glyphs plus one row of descender, printable ASCII)
//! and text drawing for labels on pictures and plots.
//!
//! The glyphs are drawn by hand for this crate as pictures below ('#' = ink), parsed at compile
//! time, so there is no font file to ship or load. Text is drawn at an integer `scale`: each font
//! pixel becomes a `scale` × `scale` block, which keeps it crisp in previews. Characters outside
//! printable ASCII are drawn as '?'.

use crate::image::Image;
use crate::shading::Rgb;

/// Width of a glyph in font pixels.
pub const GLYPH_WIDTH: u32 = 5;
/// Height of a glyph cell in font pixels (7 rows above the baseline, 1 of descender).
pub const GLYPH_HEIGHT: u32 = 8;
/// Horizontal distance between consecutive characters, in font pixels.
pub const ADVANCE: u32 = GLYPH_WIDTH + 1;
/// Vertical distance between lines, in font pixels.
pub const LINE_HEIGHT: u32 = GLYPH_HEIGHT + 2;

/// Glyph pictures for ' ' (32) to '~' (126): eight rows of five cells separated by spaces.
const GLYPH_ART: [&str; 95] = [
    "..... ..... ..... ..... ..... ..... ..... .....", // space
    "..#.. ..#.. ..#.. ..#.. ..#.. ..... ..#.. .....", // !
    ".#.#. .#.#. ..... ..... ..... ..... ..... .....", // "
    ".#.#. .#.#. ##### .#.#. ##### .#.#. .#.#. .....", // #
    "..#.. .#### #.#.. .###. ..#.# ####. ..#.. .....", // $
    "##... ##..# ...#. ..#.. .#... #..## ...## .....", // %
    ".##.. #..#. #.#.. .#... #.#.# #..#. .##.# .....", // &
    "..#.. ..#.. ..... ..... ..... ..... ..... .....", // '
    "...#. ..#.. .#... .#... .#... ..#.. ...#. .....", // (
    ".#... ..#.. ...#. ...#. ...#. ..#.. .#... .....", // )
    "..... ..#.. #.#.# .###. #.#.# ..#.. ..... .....", // *
    "..... ..#.. ..#.. ##### ..#.. ..#.. ..... .....", // +
    "..... ..... ..... ..... ..... .##.. ..#.. .#...", // ,
    "..... ..... ..... ##### ..... ..... ..... .....", // -
    "..... ..... ..... ..... ..... .##.. .##.. .....", // .
    "..... ....# ...#. ..#.. .#... #.... ..... .....", // /
    ".###. #...# #..## #.#.# ##..# #...# .###. .....", // 0
    "..#.. .##.. ..#.. ..#.. ..#.. ..#.. .###. .....", // 1
    ".###. #...# ....# ...#. ..#.. .#... ##### .....", // 2
    "##### ...#. ..#.. ...#. ....# #...# .###. .....", // 3
    "...#. ..##. .#.#. #..#. ##### ...#. ...#. .....", // 4
    "##### #.... ####. ....# ....# #...# .###. .....", // 5
    "..##. .#... #.... ####. #...# #...# .###. .....", // 6
    "##### ....# ...#. ..#.. .#... .#... .#... .....", // 7
    ".###. #...# #...# .###. #...# #...# .###. .....", // 8
    ".###. #...# #...# .#### ....# ...#. .##.. .....", // 9
    "..... .##.. .##.. ..... .##.. .##.. ..... .....", // :
    "..... .##.. .##.. ..... .##.. ..#.. .#... .....", // ;
    "...#. ..#.. .#... #.... .#... ..#.. ...#. .....", // <
    "..... ..... ##### ..... ##### ..... ..... .....", // =
    ".#... ..#.. ...#. ....# ...#. ..#.. .#... .....", // >
    ".###. #...# ....# ...#. ..#.. ..... ..#.. .....", // ?
    ".###. #...# ....# .##.# #.#.# #.#.# .###. .....", // @
    ".###. #...# #...# ##### #...# #...# #...# .....", // A
    "####. #...# #...# ####. #...# #...# ####. .....", // B
    ".###. #...# #.... #.... #.... #...# .###. .....", // C
    "###.. #..#. #...# #...# #...# #..#. ###.. .....", // D
    "##### #.... #.... ####. #.... #.... ##### .....", // E
    "##### #.... #.... ####. #.... #.... #.... .....", // F
    ".###. #...# #.... #.### #...# #...# .#### .....", // G
    "#...# #...# #...# ##### #...# #...# #...# .....", // H
    ".###. ..#.. ..#.. ..#.. ..#.. ..#.. .###. .....", // I
    "..### ...#. ...#. ...#. ...#. #..#. .##.. .....", // J
    "#...# #..#. #.#.. ##... #.#.. #..#. #...# .....", // K
    "#.... #.... #.... #.... #.... #.... ##### .....", // L
    "#...# ##.## #.#.# #.#.# #...# #...# #...# .....", // M
    "#...# #...# ##..# #.#.# #..## #...# #...# .....", // N
    ".###. #...# #...# #...# #...# #...# .###. .....", // O
    "####. #...# #...# ####. #.... #.... #.... .....", // P
    ".###. #...# #...# #...# #.#.# #..#. .##.# .....", // Q
    "####. #...# #...# ####. #.#.. #..#. #...# .....", // R
    ".#### #.... #.... .###. ....# ....# ####. .....", // S
    "##### ..#.. ..#.. ..#.. ..#.. ..#.. ..#.. .....", // T
    "#...# #...# #...# #...# #...# #...# .###. .....", // U
    "#...# #...# #...# #...# #...# .#.#. ..#.. .....", // V
    "#...# #...# #...# #.#.# #.#.# #.#.# .#.#. .....", // W
    "#...# #...# .#.#. ..#.. .#.#. #...# #...# .....", // X
    "#...# #...# .#.#. ..#.. ..#.. ..#.. ..#.. .....", // Y
    "##### ....# ...#. ..#.. .#... #.... ##### .....", // Z
    ".###. .#... .#... .#... .#... .#... .###. .....", // [
    "..... #.... .#... ..#.. ...#. ....# ..... .....", // backslash
    ".###. ...#. ...#. ...#. ...#. ...#. .###. .....", // ]
    "..#.. .#.#. #...# ..... ..... ..... ..... .....", // ^
    "..... ..... ..... ..... ..... ..... ..... #####", // _
    ".#... ..#.. ..... ..... ..... ..... ..... .....", // `
    "..... ..... .###. ....# .#### #...# .#### .....", // a
    "#.... #.... #.##. ##..# #...# #...# ####. .....", // b
    "..... ..... .###. #.... #.... #...# .###. .....", // c
    "....# ....# .##.# #..## #...# #...# .#### .....", // d
    "..... ..... .###. #...# ##### #.... .###. .....", // e
    "..##. .#..# .#... ###.. .#... .#... .#... .....", // f
    "..... ..... .#### #...# #...# .#### ....# .###.", // g
    "#.... #.... #.##. ##..# #...# #...# #...# .....", // h
    "..#.. ..... .##.. ..#.. ..#.. ..#.. .###. .....", // i
    "...#. ..... ..##. ...#. ...#. ...#. #..#. .##..", // j
    "#.... #.... #..#. #.#.. ##... #.#.. #..#. .....", // k
    ".##.. ..#.. ..#.. ..#.. ..#.. ..#.. .###. .....", // l
    "..... ..... ##.#. #.#.# #.#.# #.#.# #.#.# .....", // m
    "..... ..... #.##. ##..# #...# #...# #...# .....", // n
    "..... ..... .###. #...# #...# #...# .###. .....", // o
    "..... ..... ####. #...# #...# ####. #.... #....", // p
    "..... ..... .#### #...# #...# .#### ....# ....#", // q
    "..... ..... #.##. ##..# #.... #.... #.... .....", // r
    "..... ..... .###. #.... .###. ....# ####. .....", // s
    ".#... .#... ###.. .#... .#... .#..# ..##. .....", // t
    "..... ..... #...# #...# #...# #..## .##.# .....", // u
    "..... ..... #...# #...# #...# .#.#. ..#.. .....", // v
    "..... ..... #...# #...# #.#.# #.#.# .#.#. .....", // w
    "..... ..... #...# .#.#. ..#.. .#.#. #...# .....", // x
    "..... ..... #...# #...# #...# .#### ....# .###.", // y
    "..... ..... ##### ...#. ..#.. .#... ##### .....", // z
    "...#. ..#.. ..#.. .#... ..#.. ..#.. ...#. .....", // {
    "..#.. ..#.. ..#.. ..#.. ..#.. ..#.. ..#.. .....", // |
    ".#... ..#.. ..#.. ...#. ..#.. ..#.. .#... .....", // }
    "..... ..... .#... #.#.# ...#. ..... ..... .....", // ~
];

/// Parses one glyph picture into eight row masks (bit 4 = leftmost column). A malformed picture
/// fails the build, not a run.
const fn parse_glyph(art: &str) -> [u8; 8] {
    let bytes = art.as_bytes();
    assert!(bytes.len() == 47, "a glyph is 8 rows of 5 cells separated by spaces");
    let mut rows = [0u8; 8];
    let mut r = 0;
    while r < 8 {
        let mut c = 0;
        while c < 5 {
            let cell = bytes[r * 6 + c];
            assert!(cell == b'#' || cell == b'.', "glyph cells are '#' or '.'");
            if cell == b'#' {
                rows[r] |= 1 << (4 - c);
            }
            c += 1;
        }
        if r < 7 {
            assert!(bytes[r * 6 + 5] == b' ', "glyph rows are separated by one space");
        }
        r += 1;
    }
    rows
}

const fn parse_font() -> [[u8; 8]; 95] {
    let mut font = [[0u8; 8]; 95];
    let mut i = 0;
    while i < 95 {
        font[i] = parse_glyph(GLYPH_ART[i]);
        i += 1;
    }
    font
}

static FONT: [[u8; 8]; 95] = parse_font();

/// The row masks of `c`'s glyph ('?' for characters the font does not have).
pub fn glyph(c: char) -> [u8; 8] {
    let code = c as u32;
    let index = if (32..127).contains(&code) { code - 32 } else { u32::from(b'?') - 32 };
    FONT[index as usize]
}

/// Size in pixels (width, height) of `text` drawn at `scale`, counting lines split at '\n'.
/// The width has no trailing inter-character gap.
pub fn text_size(text: &str, scale: u32) -> (u32, u32) {
    let scale = scale.max(1);
    let lines = text.split('\n');
    let mut width = 0u32;
    let mut count = 0u32;
    for line in lines {
        count += 1;
        let n = line.chars().count() as u32;
        if n > 0 {
            width = width.max(n.saturating_mul(ADVANCE).saturating_sub(1).saturating_mul(scale));
        }
    }
    let height = (count.saturating_sub(1) * LINE_HEIGHT + GLYPH_HEIGHT).saturating_mul(scale);
    (width, height)
}

/// Draws `text` with its top-left corner at (x, y), each font pixel a `scale` × `scale` block
/// of the linear colour `color` at opacity `alpha`. '\n' starts a new line.
pub fn draw_text(image: &mut Image, x: i64, y: i64, text: &str, color: Rgb, alpha: f32, scale: u32) {
    let s = i64::from(scale.max(1));
    for (line_index, line) in text.split('\n').enumerate() {
        let top = y + line_index as i64 * i64::from(LINE_HEIGHT) * s;
        for (k, c) in line.chars().enumerate() {
            let left = x + k as i64 * i64::from(ADVANCE) * s;
            let rows = glyph(c);
            for (r, mask) in rows.iter().enumerate() {
                for col in 0..GLYPH_WIDTH {
                    if mask & (1 << (GLYPH_WIDTH - 1 - col)) != 0 {
                        let px = left + i64::from(col) * s;
                        let py = top + r as i64 * s;
                        image.blend_rect(px, py, s as u32, s as u32, color, alpha);
                    }
                }
            }
        }
    }
}

/// Draws `text` rotated a quarter turn counter-clockwise (reading bottom to top, as a y axis
/// label), with the bottom-left corner of the rotated text block at (x, y).
pub fn draw_text_vertical(image: &mut Image, x: i64, y: i64, text: &str, color: Rgb, alpha: f32, scale: u32) {
    let s = i64::from(scale.max(1));
    for (k, c) in text.chars().enumerate() {
        // Glyph column `col` goes up the image; glyph row `r` goes right.
        let base = y - k as i64 * i64::from(ADVANCE) * s;
        let rows = glyph(c);
        for (r, mask) in rows.iter().enumerate() {
            for col in 0..GLYPH_WIDTH {
                if mask & (1 << (GLYPH_WIDTH - 1 - col)) != 0 {
                    let px = x + r as i64 * s;
                    let py = base - (i64::from(col) + 1) * s;
                    image.blend_rect(px, py, s as u32, s as u32, color, alpha);
                }
            }
        }
    }
}

/// Writes a caption in the top-left corner of `image` on a translucent dark band so that it
/// reads on any background, e.g. "frame 12" or "before". The scale grows with the image so the
/// caption stays legible on large pictures.
pub fn label(image: &mut Image, text: &str) {
    let scale = (image.height / 300).clamp(1, 4) + 1;
    let pad = 3 * i64::from(scale);
    let (w, h) = text_size(text, scale);
    image.blend_rect(0, 0, w + 2 * pad as u32, h + 2 * pad as u32, [0.0, 0.0, 0.0], 0.55);
    draw_text(image, pad, pad, text, [1.0, 1.0, 1.0], 1.0, scale);
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn glyphs_are_distinct_and_nonblank() {
        for code in 33u8..127 {
            let g = glyph(char::from(code));
            assert!(g.iter().any(|&r| r != 0), "{}", char::from(code));
            for other in (code + 1)..127 {
                assert_ne!(g, glyph(char::from(other)), "{} vs {}", char::from(code), char::from(other));
            }
        }
        assert_eq!(glyph(' '), [0; 8]);
        assert_eq!(glyph('é'), glyph('?'));
    }

    #[test]
    fn text_size_counts_advances_and_lines() {
        assert_eq!(text_size("", 1), (0, 8));
        assert_eq!(text_size("ab", 1), (11, 8));
        assert_eq!(text_size("ab\nabc", 2), (34, 36));
    }

    #[test]
    fn drawn_text_stays_inside_its_box() {
        let mut image = Image::new(60, 30, [0, 0, 0, 255]);
        draw_text(&mut image, 3, 4, "Hi 12", [1.0; 3], 1.0, 2);
        let (w, h) = text_size("Hi 12", 2);
        let mut inked = 0;
        for y in 0..30 {
            for x in 0..60 {
                if image.pixel(x, y) != Some([0, 0, 0, 255]) {
                    inked += 1;
                    assert!(x >= 3 && x < 3 + w && y >= 4 && y < 4 + h, "{x} {y}");
                }
            }
        }
        assert!(inked > 50);
    }
}
