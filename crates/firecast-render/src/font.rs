//! Embedded bitmap font for chart text: 5-pixel-wide glyphs with a 7-pixel cap height and a
//! 2-pixel descender, drawn at integer scales with proportional spacing.
//!
//! Covers printable ASCII (0x20–0x7E) plus `°`, `±`, `Δ`, `×`, `µ`, `·`, `≤`, `≥`, the en and
//! em dashes (both a 5-pixel dash) and the minus sign `−` (drawn as the hyphen). Tabs draw
//! as a space; any other character draws as `?`, so callers that need other symbols should
//! spell them out in ASCII (e.g. "deg", "+/-", "d").
//!
//! Each glyph is 9 rows of 5 bits (bit 4 = leftmost column): rows 0–6 hold capitals and
//! ascenders, the baseline is under row 6, and rows 7–8 hold descenders. A glyph advances
//! by its inked width plus one pixel, a space by [`SPACE_WIDTH`] pixels.

use crate::RgbImage;

/// One glyph: 9 rows of 5 bits, bit 4 the leftmost column.
type Glyph = [u8; 9];

/// Rows of a glyph box (cap height 7 + descender 2), before scaling.
pub const GLYPH_ROWS: usize = 9;
/// Rows from the top of a capital to the baseline, before scaling.
pub const CAP_HEIGHT: usize = 7;
/// Advance of a space, before scaling.
pub const SPACE_WIDTH: usize = 3;

/// Printable ASCII 0x20..=0x7E, in code order.
const ASCII: [Glyph; 95] = [
    [0, 0, 0, 0, 0, 0, 0, 0, 0],                                     // space
    [0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0, 0b00100, 0, 0], // '!'
    [0b01010, 0b01010, 0b01010, 0, 0, 0, 0, 0, 0],                   // '"'
    [
        0b01010, 0b01010, 0b11111, 0b01010, 0b11111, 0b01010, 0b01010, 0, 0,
    ], // '#'
    [
        0b00100, 0b01111, 0b10100, 0b01110, 0b00101, 0b11110, 0b00100, 0, 0,
    ], // '$'
    [
        0b11000, 0b11001, 0b00010, 0b00100, 0b01000, 0b10011, 0b00011, 0, 0,
    ], // '%'
    [
        0b01100, 0b10010, 0b10100, 0b01000, 0b10101, 0b10010, 0b01101, 0, 0,
    ], // '&'
    [0b00100, 0b00100, 0b00100, 0, 0, 0, 0, 0, 0],                   // '\''
    [
        0b00100, 0b01000, 0b01000, 0b01000, 0b01000, 0b01000, 0b00100, 0, 0,
    ], // '('
    [
        0b10000, 0b01000, 0b01000, 0b01000, 0b01000, 0b01000, 0b10000, 0, 0,
    ], // ')'
    [0, 0b00100, 0b10101, 0b01110, 0b10101, 0b00100, 0, 0, 0],       // '*'
    [0, 0b00100, 0b00100, 0b11111, 0b00100, 0b00100, 0, 0, 0],       // '+'
    [0, 0, 0, 0, 0, 0b01100, 0b00100, 0b01000, 0],                   // ','
    [0, 0, 0, 0b11110, 0, 0, 0, 0, 0],                               // '-'
    [0, 0, 0, 0, 0, 0b01100, 0b01100, 0, 0],                         // '.'
    [
        0b00001, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b10000, 0, 0,
    ], // '/'
    [
        0b01110, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110, 0, 0,
    ], // '0'
    [
        0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110, 0, 0,
    ], // '1'
    [
        0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111, 0, 0,
    ], // '2'
    [
        0b01110, 0b10001, 0b00001, 0b00110, 0b00001, 0b10001, 0b01110, 0, 0,
    ], // '3'
    [
        0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010, 0, 0,
    ], // '4'
    [
        0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110, 0, 0,
    ], // '5'
    [
        0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110, 0, 0,
    ], // '6'
    [
        0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000, 0, 0,
    ], // '7'
    [
        0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110, 0, 0,
    ], // '8'
    [
        0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100, 0, 0,
    ], // '9'
    [0, 0, 0b01100, 0b01100, 0, 0b01100, 0b01100, 0, 0],             // ':'
    [0, 0, 0b01100, 0b01100, 0, 0b01100, 0b00100, 0b01000, 0],       // ';'
    [
        0b00010, 0b00100, 0b01000, 0b10000, 0b01000, 0b00100, 0b00010, 0, 0,
    ], // '<'
    [0, 0, 0b11111, 0, 0b11111, 0, 0, 0, 0],                         // '='
    [
        0b01000, 0b00100, 0b00010, 0b00001, 0b00010, 0b00100, 0b01000, 0, 0,
    ], // '>'
    [0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0, 0b00100, 0, 0], // '?'
    [
        0b01110, 0b10001, 0b10111, 0b10101, 0b10111, 0b10000, 0b01111, 0, 0,
    ], // '@'
    [
        0b01110, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001, 0, 0,
    ], // 'A'
    [
        0b11110, 0b10001, 0b10001, 0b11110, 0b10001, 0b10001, 0b11110, 0, 0,
    ], // 'B'
    [
        0b01110, 0b10001, 0b10000, 0b10000, 0b10000, 0b10001, 0b01110, 0, 0,
    ], // 'C'
    [
        0b11110, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b11110, 0, 0,
    ], // 'D'
    [
        0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b11111, 0, 0,
    ], // 'E'
    [
        0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b10000, 0, 0,
    ], // 'F'
    [
        0b01110, 0b10001, 0b10000, 0b10111, 0b10001, 0b10001, 0b01111, 0, 0,
    ], // 'G'
    [
        0b10001, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001, 0, 0,
    ], // 'H'
    [
        0b11100, 0b01000, 0b01000, 0b01000, 0b01000, 0b01000, 0b11100, 0, 0,
    ], // 'I'
    [
        0b00111, 0b00010, 0b00010, 0b00010, 0b00010, 0b10010, 0b01100, 0, 0,
    ], // 'J'
    [
        0b10001, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010, 0b10001, 0, 0,
    ], // 'K'
    [
        0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b11111, 0, 0,
    ], // 'L'
    [
        0b10001, 0b11011, 0b10101, 0b10101, 0b10001, 0b10001, 0b10001, 0, 0,
    ], // 'M'
    [
        0b10001, 0b10001, 0b11001, 0b10101, 0b10011, 0b10001, 0b10001, 0, 0,
    ], // 'N'
    [
        0b01110, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110, 0, 0,
    ], // 'O'
    [
        0b11110, 0b10001, 0b10001, 0b11110, 0b10000, 0b10000, 0b10000, 0, 0,
    ], // 'P'
    [
        0b01110, 0b10001, 0b10001, 0b10001, 0b10101, 0b10010, 0b01101, 0, 0,
    ], // 'Q'
    [
        0b11110, 0b10001, 0b10001, 0b11110, 0b10100, 0b10010, 0b10001, 0, 0,
    ], // 'R'
    [
        0b01111, 0b10000, 0b10000, 0b01110, 0b00001, 0b00001, 0b11110, 0, 0,
    ], // 'S'
    [
        0b11111, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0, 0,
    ], // 'T'
    [
        0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110, 0, 0,
    ], // 'U'
    [
        0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100, 0, 0,
    ], // 'V'
    [
        0b10001, 0b10001, 0b10001, 0b10101, 0b10101, 0b10101, 0b01010, 0, 0,
    ], // 'W'
    [
        0b10001, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001, 0b10001, 0, 0,
    ], // 'X'
    [
        0b10001, 0b10001, 0b01010, 0b00100, 0b00100, 0b00100, 0b00100, 0, 0,
    ], // 'Y'
    [
        0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b11111, 0, 0,
    ], // 'Z'
    [
        0b11100, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b11100, 0,
    ], // '['
    [
        0b10000, 0b10000, 0b01000, 0b00100, 0b00010, 0b00001, 0b00001, 0, 0,
    ], // '\\'
    [
        0b11100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b11100, 0,
    ], // ']'
    [0b00100, 0b01010, 0b10001, 0, 0, 0, 0, 0, 0],                   // '^'
    [0, 0, 0, 0, 0, 0, 0, 0b11111, 0],                               // '_'
    [0b01000, 0b00100, 0, 0, 0, 0, 0, 0, 0],                         // '`'
    [0, 0, 0b01110, 0b00001, 0b01111, 0b10001, 0b01111, 0, 0],       // 'a'
    [
        0b10000, 0b10000, 0b11110, 0b10001, 0b10001, 0b10001, 0b11110, 0, 0,
    ], // 'b'
    [0, 0, 0b01110, 0b10000, 0b10000, 0b10001, 0b01110, 0, 0],       // 'c'
    [
        0b00001, 0b00001, 0b01111, 0b10001, 0b10001, 0b10001, 0b01111, 0, 0,
    ], // 'd'
    [0, 0, 0b01110, 0b10001, 0b11111, 0b10000, 0b01110, 0, 0],       // 'e'
    [
        0b00110, 0b01000, 0b11110, 0b01000, 0b01000, 0b01000, 0b01000, 0, 0,
    ], // 'f'
    [
        0, 0, 0b01111, 0b10001, 0b10001, 0b10001, 0b01111, 0b00001, 0b01110,
    ], // 'g'
    [
        0b10000, 0b10000, 0b10110, 0b11001, 0b10001, 0b10001, 0b10001, 0, 0,
    ], // 'h'
    [0b01000, 0, 0b11000, 0b01000, 0b01000, 0b01000, 0b11100, 0, 0], // 'i'
    [
        0b00010, 0, 0b00110, 0b00010, 0b00010, 0b00010, 0b00010, 0b10010, 0b01100,
    ], // 'j'
    [
        0b10000, 0b10000, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010, 0, 0,
    ], // 'k'
    [
        0b11000, 0b01000, 0b01000, 0b01000, 0b01000, 0b01000, 0b11100, 0, 0,
    ], // 'l'
    [0, 0, 0b11010, 0b10101, 0b10101, 0b10101, 0b10101, 0, 0],       // 'm'
    [0, 0, 0b10110, 0b11001, 0b10001, 0b10001, 0b10001, 0, 0],       // 'n'
    [0, 0, 0b01110, 0b10001, 0b10001, 0b10001, 0b01110, 0, 0],       // 'o'
    [
        0, 0, 0b11110, 0b10001, 0b10001, 0b10001, 0b11110, 0b10000, 0b10000,
    ], // 'p'
    [
        0, 0, 0b01111, 0b10001, 0b10001, 0b10001, 0b01111, 0b00001, 0b00001,
    ], // 'q'
    [0, 0, 0b10110, 0b11001, 0b10000, 0b10000, 0b10000, 0, 0],       // 'r'
    [0, 0, 0b01111, 0b10000, 0b01110, 0b00001, 0b11110, 0, 0],       // 's'
    [
        0b01000, 0b01000, 0b11110, 0b01000, 0b01000, 0b01000, 0b00110, 0, 0,
    ], // 't'
    [0, 0, 0b10001, 0b10001, 0b10001, 0b10011, 0b01101, 0, 0],       // 'u'
    [0, 0, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100, 0, 0],       // 'v'
    [0, 0, 0b10001, 0b10001, 0b10101, 0b10101, 0b01010, 0, 0],       // 'w'
    [0, 0, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001, 0, 0],       // 'x'
    [
        0, 0, 0b10001, 0b10001, 0b10001, 0b10001, 0b01111, 0b00001, 0b01110,
    ], // 'y'
    [0, 0, 0b11111, 0b00010, 0b00100, 0b01000, 0b11111, 0, 0],       // 'z'
    [
        0b00100, 0b01000, 0b01000, 0b10000, 0b01000, 0b01000, 0b00100, 0, 0,
    ], // '{'
    [
        0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0,
    ], // '|'
    [
        0b10000, 0b01000, 0b01000, 0b00100, 0b01000, 0b01000, 0b10000, 0, 0,
    ], // '}'
    [0, 0, 0, 0b01000, 0b10101, 0b00010, 0, 0, 0],                   // '~'
];

/// A few non-ASCII symbols common in labels.
const EXTRA: [(char, Glyph); 11] = [
    ('\u{00B0}', [0b01100, 0b10010, 0b10010, 0b01100, 0, 0, 0, 0, 0]), // °
    (
        '\u{00B1}',
        [0b00100, 0b00100, 0b11111, 0b00100, 0b00100, 0, 0b11111, 0, 0],
    ), // ±
    (
        '\u{0394}',
        [
            0b00100, 0b00100, 0b01010, 0b01010, 0b10001, 0b10001, 0b11111, 0, 0,
        ],
    ), // Δ
    (
        '\u{00D7}',
        [0, 0, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001, 0, 0],
    ), // ×
    (
        '\u{00B5}',
        [
            0, 0, 0b10001, 0b10001, 0b10001, 0b10011, 0b11101, 0b10000, 0b10000,
        ],
    ), // µ
    ('\u{00B7}', [0, 0, 0, 0b01100, 0b01100, 0, 0, 0, 0]),             // ·
    (
        '\u{2264}',
        [0b00010, 0b00100, 0b01000, 0b00100, 0b00010, 0, 0b11111, 0, 0],
    ), // ≤
    (
        '\u{2265}',
        [0b01000, 0b00100, 0b00010, 0b00100, 0b01000, 0, 0b11111, 0, 0],
    ), // ≥
    ('\u{2013}', [0, 0, 0, 0b11111, 0, 0, 0, 0, 0]),                   // –
    ('\u{2014}', [0, 0, 0, 0b11111, 0, 0, 0, 0, 0]),                   // —
    ('\u{2212}', [0, 0, 0, 0b11110, 0, 0, 0, 0, 0]),                   // −
];

/// Where text sits relative to its anchor along the reading direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Align {
    /// The anchor is where the text starts.
    #[default]
    Left,
    /// The anchor is the middle of the text.
    Center,
    /// The anchor is where the text ends.
    Right,
}

/// How [`draw_text_styled`] draws text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TextStyle {
    /// Integer pixel scale (0 is treated as 1).
    pub scale: usize,
    /// Ink colour.
    pub color: [u8; 3],
    /// Placement relative to the anchor.
    pub align: Align,
    /// Thicken every stroke by one image pixel (titles).
    pub bold: bool,
    /// Rotate 90° counter-clockwise, reading bottom to top (y-axis titles).
    pub vertical: bool,
}

impl TextStyle {
    /// Left-aligned, regular, horizontal text.
    pub fn new(scale: usize, color: [u8; 3]) -> Self {
        Self {
            scale,
            color,
            align: Align::Left,
            bold: false,
            vertical: false,
        }
    }

    /// The same style with another alignment.
    pub fn align(self, align: Align) -> Self {
        Self { align, ..self }
    }

    /// The same style, bold or not.
    pub fn bold(self, bold: bool) -> Self {
        Self { bold, ..self }
    }

    /// The same style, rotated (reading bottom to top) or not.
    pub fn vertical(self, vertical: bool) -> Self {
        Self { vertical, ..self }
    }
}

/// The rectangle a piece of text occupies, in image pixels: the full line box (cap height
/// plus descender) by the text's advance. It may reach past the image edges, where drawing
/// is clipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TextBox {
    /// Left edge.
    pub x: i64,
    /// Top edge.
    pub y: i64,
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
}

/// The glyph drawn for `c`: printable ASCII, the extra symbols listed in the module docs, a
/// space for a tab, and `?` for anything else.
pub fn glyph(c: char) -> &'static [u8; GLYPH_ROWS] {
    let code = c as u32;
    if (0x20..0x7F).contains(&code) {
        return &ASCII[(code - 0x20) as usize];
    }
    if c == '\t' {
        return &ASCII[0];
    }
    match EXTRA.iter().find(|(e, _)| *e == c) {
        Some((_, g)) => g,
        None => &ASCII[usize::from(b'?' - 0x20)],
    }
}

/// Leftmost and rightmost inked columns (0 = left), or `None` for a blank glyph.
fn ink_columns(g: &Glyph) -> Option<(usize, usize)> {
    let bits = g.iter().fold(0u8, |acc, r| acc | r) & 0x1F;
    if bits == 0 {
        return None;
    }
    // Bit 4 is column 0; the byte's top three bits are always clear.
    let left = bits.leading_zeros() as usize - 3;
    let right = 4 - bits.trailing_zeros() as usize;
    Some((left, right))
}

/// Advance of one character in image pixels: inked width plus one font pixel of spacing
/// (plus one image pixel when bold); a blank glyph advances by [`SPACE_WIDTH`].
fn advance(g: &Glyph, scale: usize, bold: bool) -> usize {
    match ink_columns(g) {
        Some((l, r)) => (r - l + 2) * scale + usize::from(bold),
        None => SPACE_WIDTH * scale,
    }
}

/// Length of `text` along its reading direction, in image pixels, at `scale` (0 = 1),
/// without trailing letter spacing.
pub fn text_width(text: &str, scale: usize) -> usize {
    styled_width(text, scale.max(1), false)
}

fn styled_width(text: &str, scale: usize, bold: bool) -> usize {
    let mut width = 0;
    let mut trailing = 0;
    for c in text.chars() {
        let g = glyph(c);
        width += advance(g, scale, bold);
        // Spacing after the last inked glyph is not part of the text.
        trailing = if ink_columns(g).is_some() { scale } else { 0 };
    }
    width - trailing
}

/// Height of a line box (cap height plus descender) in image pixels at `scale` (0 = 1).
pub fn text_height(scale: usize) -> usize {
    GLYPH_ROWS * scale.max(1)
}

/// Draw `text` left-aligned with its line box's top-left corner at (`x`, `y`).
pub fn draw_text(img: &mut RgbImage, x: i64, y: i64, text: &str, scale: usize, color: [u8; 3]) -> TextBox {
    draw_text_styled(img, x, y, text, &TextStyle::new(scale, color))
}

/// Draw `text` with its line box's top at `y`; `x` is its left edge, centre or right edge
/// as `align` says.
pub fn draw_text_aligned(
    img: &mut RgbImage,
    x: i64,
    y: i64,
    text: &str,
    scale: usize,
    color: [u8; 3],
    align: Align,
) -> TextBox {
    draw_text_styled(img, x, y, text, &TextStyle::new(scale, color).align(align))
}

/// Draw `text` rotated 90° counter-clockwise (reading bottom to top, glyph tops facing
/// left) with its line box's left edge at `x`; `y` is where the text starts (its bottom
/// edge), its centre or where it ends (its top edge) as `align` says.
pub fn draw_text_vertical(
    img: &mut RgbImage,
    x: i64,
    y: i64,
    text: &str,
    scale: usize,
    color: [u8; 3],
    align: Align,
) -> TextBox {
    draw_text_styled(
        img,
        x,
        y,
        text,
        &TextStyle::new(scale, color).align(align).vertical(true),
    )
}

/// Draw `text` in `style` at anchor (`x`, `y`) (see [`draw_text_aligned`] and
/// [`draw_text_vertical`] for what the anchor means) and return the box it occupies.
pub fn draw_text_styled(img: &mut RgbImage, x: i64, y: i64, text: &str, style: &TextStyle) -> TextBox {
    let s = style.scale.max(1);
    let len = styled_width(text, s, style.bold) as i64;
    let line = text_height(s);
    let offset = match style.align {
        Align::Left => 0,
        Align::Center => len / 2,
        Align::Right => len,
    };
    let bx = if style.vertical { x } else { x - offset };
    // Vertical text reads upwards, so starting at `y` means the box ends there.
    let by = if style.vertical {
        match style.align {
            Align::Left => y - len,
            Align::Center => y - (len - len / 2),
            Align::Right => y,
        }
    } else {
        y
    };
    let block = s as i64;
    let stroke = block + i64::from(style.bold);
    let mut pen = 0i64;
    for c in text.chars() {
        let g = glyph(c);
        if let Some((left, right)) = ink_columns(g) {
            for (row, bits) in g.iter().enumerate() {
                for col in left..=right {
                    if bits & (0x10 >> col) == 0 {
                        continue;
                    }
                    let u = pen + (col - left) as i64 * block;
                    let v = row as i64 * block;
                    if style.vertical {
                        fill_block(img, bx + v, by + len - u - stroke, block, stroke, style.color);
                    } else {
                        fill_block(img, bx + u, by + v, stroke, block, style.color);
                    }
                }
            }
        }
        pen += advance(g, s, style.bold) as i64;
    }
    let (width, height) = if style.vertical {
        (line, len as usize)
    } else {
        (len as usize, line)
    };
    TextBox {
        x: bx,
        y: by,
        width,
        height,
    }
}

/// Fill a `w` × `h` block at (`x`, `y`), clipped to the image (coordinates may be negative).
fn fill_block(img: &mut RgbImage, x: i64, y: i64, w: i64, h: i64, color: [u8; 3]) {
    let clip = |v: i64, max: usize| v.clamp(0, max as i64) as usize;
    let (x0, x1) = (clip(x, img.width), clip(x + w, img.width));
    let (y0, y1) = (clip(y, img.height), clip(y + h, img.height));
    img.fill_rect(x0, y0, x1, y1, color);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_printable_ascii_glyph_has_ink_except_space() {
        for code in 0x21u8..0x7F {
            assert!(
                ink_columns(glyph(char::from(code))).is_some(),
                "{}",
                char::from(code)
            );
        }
        assert!(ink_columns(glyph(' ')).is_none());
        assert_eq!(glyph('\u{263A}'), glyph('?'));
    }

    #[test]
    fn widths_are_proportional() {
        assert_eq!(text_width("", 2), 0);
        assert_eq!(text_width("0", 1), 5);
        assert_eq!(text_width("00", 1), 11);
        assert_eq!(text_width("0 0", 1), 5 + 1 + 3 + 5);
        assert_eq!(text_width("i", 3), 9);
        assert!(text_width("l", 1) < text_width("m", 1));
    }
}
