//! A tiny hand-made bitmap font: 5 × 9 pixel glyphs (7 rows above the baseline, 2 for
//! descenders) drawn as ASCII art, so the pictures need no font files or font libraries.
//!
//! Covered: digits, lowercase letters (uppercase is drawn as lowercase), space and
//! `. , % : - / ( ) = +`. Any other character is drawn as a hollow box, so a missing glyph
//! is visible rather than silently dropped.

/// Glyph width in font pixels.
pub const GLYPH_W: u32 = 5;
/// Glyph height in font pixels, descender rows included.
pub const GLYPH_H: u32 = 9;
/// Horizontal advance per character in font pixels (glyph plus one column of spacing).
pub const ADVANCE: u32 = GLYPH_W + 1;

/// Glyph rows top to bottom; `#` is ink. Rows 0..7 sit on the baseline, rows 7..9 are the
/// descender. Trailing rows left out are blank.
#[rustfmt::skip]
const GLYPHS: &[(char, &[&str])] = &[
    (' ', &[]),
    ('0', &[".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###."]),
    ('1', &["..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###."]),
    ('2', &[".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####"]),
    ('3', &["#####", "...#.", "..#..", "...#.", "....#", "#...#", ".###."]),
    ('4', &["...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#."]),
    ('5', &["#####", "#....", "####.", "....#", "....#", "#...#", ".###."]),
    ('6', &["..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###."]),
    ('7', &["#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#..."]),
    ('8', &[".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###."]),
    ('9', &[".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##.."]),
    ('%', &["##...", "##..#", "...#.", "..#..", ".#...", "#..##", "...##"]),
    ('.', &[".....", ".....", ".....", ".....", ".....", ".##..", ".##.."]),
    (',', &[".....", ".....", ".....", ".....", ".....", ".##..", ".##..", "..#..", ".#..."]),
    (':', &[".....", ".##..", ".##..", ".....", ".##..", ".##..", "....."]),
    ('-', &[".....", ".....", ".....", "#####", ".....", ".....", "....."]),
    ('+', &[".....", "..#..", "..#..", "#####", "..#..", "..#..", "....."]),
    ('=', &[".....", ".....", "#####", ".....", "#####", ".....", "....."]),
    ('/', &[".....", "....#", "...#.", "..#..", ".#...", "#....", "....."]),
    ('(', &["...#.", "..#..", ".#...", ".#...", ".#...", "..#..", "...#."]),
    (')', &[".#...", "..#..", "...#.", "...#.", "...#.", "..#..", ".#..."]),
    ('a', &[".....", ".....", ".###.", "....#", ".####", "#...#", ".####"]),
    ('b', &["#....", "#....", "#.##.", "##..#", "#...#", "#...#", "####."]),
    ('c', &[".....", ".....", ".###.", "#....", "#....", "#...#", ".###."]),
    ('d', &["....#", "....#", ".##.#", "#..##", "#...#", "#...#", ".####"]),
    ('e', &[".....", ".....", ".###.", "#...#", "#####", "#....", ".###."]),
    ('f', &["..##.", ".#..#", ".#...", "###..", ".#...", ".#...", ".#..."]),
    ('g', &[".....", ".....", ".####", "#...#", "#...#", "#...#", ".####", "....#", ".###."]),
    ('h', &["#....", "#....", "#.##.", "##..#", "#...#", "#...#", "#...#"]),
    ('i', &["..#..", ".....", ".##..", "..#..", "..#..", "..#..", ".###."]),
    ('j', &["...#.", ".....", "..##.", "...#.", "...#.", "...#.", "...#.", "#..#.", ".##.."]),
    ('k', &["#....", "#....", "#..#.", "#.#..", "##...", "#.#..", "#..#."]),
    ('l', &[".##..", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."]),
    ('m', &[".....", ".....", "##.#.", "#.#.#", "#.#.#", "#.#.#", "#.#.#"]),
    ('n', &[".....", ".....", "#.##.", "##..#", "#...#", "#...#", "#...#"]),
    ('o', &[".....", ".....", ".###.", "#...#", "#...#", "#...#", ".###."]),
    ('p', &[".....", ".....", "####.", "#...#", "#...#", "#...#", "####.", "#....", "#...."]),
    ('q', &[".....", ".....", ".####", "#...#", "#...#", "#...#", ".####", "....#", "....#"]),
    ('r', &[".....", ".....", "#.##.", "##..#", "#....", "#....", "#...."]),
    ('s', &[".....", ".....", ".####", "#....", ".###.", "....#", "####."]),
    ('t', &[".#...", ".#...", "###..", ".#...", ".#...", ".#..#", "..##."]),
    ('u', &[".....", ".....", "#...#", "#...#", "#...#", "#..##", ".##.#"]),
    ('v', &[".....", ".....", "#...#", "#...#", "#...#", ".#.#.", "..#.."]),
    ('w', &[".....", ".....", "#...#", "#...#", "#.#.#", "#.#.#", ".#.#."]),
    ('x', &[".....", ".....", "#...#", ".#.#.", "..#..", ".#.#.", "#...#"]),
    ('y', &[".....", ".....", "#...#", "#...#", "#...#", "#...#", ".####", "....#", ".###."]),
    ('z', &[".....", ".....", "#####", "...#.", "..#..", ".#...", "#####"]),
];

/// Drawn for characters the font does not have.
const MISSING: &[&str] = &[
    "#####", "#...#", "#...#", "#...#", "#...#", "#...#", "#####",
];

/// The rows of the glyph for `ch` (uppercase maps to lowercase).
pub fn glyph(ch: char) -> &'static [&'static str] {
    let ch = ch.to_ascii_lowercase();
    GLYPHS
        .iter()
        .find(|(c, _)| *c == ch)
        .map_or(MISSING, |(_, rows)| rows)
}

/// Whether the font has a real glyph for `ch`.
pub fn has_glyph(ch: char) -> bool {
    let ch = ch.to_ascii_lowercase();
    GLYPHS.iter().any(|(c, _)| *c == ch)
}

/// Width in pixels of `text` drawn at `scale` (no trailing spacing column).
pub fn text_width(text: &str, scale: u32) -> u32 {
    let n = text.chars().count() as u32;
    (n * ADVANCE).saturating_sub(1) * scale
}

/// Calls `ink(x, y)` for every ink pixel of `text` drawn with its top-left corner at the
/// origin, each font pixel a `scale` × `scale` square.
pub fn for_each_ink(text: &str, scale: u32, mut ink: impl FnMut(u32, u32)) {
    for (i, ch) in text.chars().enumerate() {
        let x0 = i as u32 * ADVANCE * scale;
        for (gy, row) in glyph(ch).iter().enumerate() {
            for (gx, b) in row.bytes().enumerate() {
                if b != b'#' {
                    continue;
                }
                for sy in 0..scale {
                    for sx in 0..scale {
                        ink(x0 + gx as u32 * scale + sx, gy as u32 * scale + sy);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glyphs_are_well_formed() {
        for (ch, rows) in GLYPHS {
            assert!(rows.len() <= GLYPH_H as usize, "{ch:?} too tall");
            for row in rows.iter() {
                assert_eq!(row.len(), GLYPH_W as usize, "{ch:?} row {row:?}");
                assert!(
                    row.bytes().all(|b| b == b'#' || b == b'.'),
                    "{ch:?} row {row:?}"
                );
            }
        }
        let mut seen = std::collections::HashSet::new();
        assert!(
            GLYPHS.iter().all(|(c, _)| seen.insert(*c)),
            "duplicate glyph"
        );
    }

    #[test]
    fn covers_the_status_bar_and_titles() {
        for ch in "step 0123456789 explored 87.5% truth team map".chars() {
            assert!(has_glyph(ch), "{ch:?}");
        }
        assert!(has_glyph('S'));
        assert!(!has_glyph('@'));
    }

    #[test]
    fn width_and_ink() {
        assert_eq!(text_width("", 2), 0);
        assert_eq!(text_width("ab", 1), 11);
        let mut max_x = 0;
        let mut n = 0;
        for_each_ink("1", 2, |x, _| {
            max_x = max_x.max(x);
            n += 1;
        });
        // "1" has 10 ink pixels at scale 1.
        assert_eq!(n, 10 * 4);
        assert!(max_x < text_width("1", 2));
    }
}
