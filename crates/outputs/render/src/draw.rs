//! What `imageproc` does not draw itself: colour mixing, thick and dashed lines, and text in
//! the plots' bundled font with its antialiasing reduced to a few levels.

use ab_glyph::{FontRef, PxScale};
use image::{GrayImage, Luma, Rgba, RgbaImage};
use imageproc::drawing::{
    draw_filled_rect_mut, draw_text_mut, text_size, BresenhamLineIter, Canvas,
};
use imageproc::rect::Rect;
use std::sync::OnceLock;

/// An opaque RGB colour.
pub type Rgb = [u8; 3];

/// The opaque pixel of `c`.
pub fn rgba([r, g, b]: Rgb) -> Rgba<u8> {
    Rgba([r, g, b, 255])
}

/// `c` with opacity `alpha` (0..=1), for drawing on an `imageproc` `Blend` canvas.
pub fn translucent([r, g, b]: Rgb, alpha: f32) -> Rgba<u8> {
    Rgba([r, g, b, (alpha.clamp(0.0, 1.0) * 255.0).round() as u8])
}

/// `a` moved towards `b` by `t` (0 = `a`, 1 = `b`).
pub fn mix(a: Rgb, b: Rgb, t: f32) -> Rgb {
    let t = t.clamp(0.0, 1.0);
    let f = |x: u8, y: u8| (x as f32 + (y as f32 - x as f32) * t).round() as u8;
    [f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2])]
}

/// A `w` × `h` rectangle at `(x, y)`, `None` when empty (`imageproc` rectangles are not).
pub fn rect(x: i32, y: i32, w: i32, h: i32) -> Option<Rect> {
    (w > 0 && h > 0).then(|| Rect::at(x, y).of_size(w as u32, h as u32))
}

/// Bresenham line from `a` to `b` with a square `thick`-pixel brush; with
/// `dash = Some((on, off))` only the first `on` of every `on + off` steps are drawn.
/// Hand-written because `imageproc` draws only one-pixel solid segments.
pub fn line<C: Canvas<Pixel = Rgba<u8>>>(
    canvas: &mut C,
    (a, b): ((i32, i32), (i32, i32)),
    thick: u32,
    c: Rgb,
    dash: Option<(u32, u32)>,
) {
    let t = thick.max(1) as i32;
    let lo = -(t - 1) / 2;
    let (on, period) = dash.map_or((1, 1), |(on, off)| (on, (on + off).max(1)));
    let points = BresenhamLineIter::new((a.0 as f32, a.1 as f32), (b.0 as f32, b.1 as f32));
    for (step, (x, y)) in points.enumerate() {
        if (step as u32) % period < on {
            draw_filled_rect_mut(
                canvas,
                Rect::at(x + lo, y + lo).of_size(t as u32, t as u32),
                rgba(c),
            );
        }
    }
}

/// The bundled DejaVu Sans of `madenet-plots`, parsed once.
fn font() -> &'static FontRef<'static> {
    static FONT: OnceLock<FontRef<'static>> = OnceLock::new();
    FONT.get_or_init(|| {
        FontRef::try_from_slice(madenet_plots::font_bytes())
            .expect("madenet-plots' bundled font parses")
    })
}

/// Font size in pixels (ascent to descent) at text scale `scale`: capitals `7 * scale`
/// pixels tall, the line `11 * scale`.
fn px(scale: u32) -> PxScale {
    PxScale::from(11.0 * scale as f32)
}

/// Width in pixels of `text` at text scale `scale`.
pub fn text_width(text: &str, scale: u32) -> u32 {
    text_size(px(scale), font(), text).0
}

/// Coverage levels text is drawn with: antialiased, yet adding at most this many colours per
/// text colour and background, so pictures stay within the GIF palette of 256 colours.
const LEVELS: u32 = 8;

/// Draws `text` at text scale `scale` with the top of its line at `(x, y)`.
/// Hand-written compositing because `imageproc` blends every coverage value (up to 255
/// colours per glyph edge), which would overflow the GIF palette.
pub fn text(img: &mut RgbaImage, (x, y): (i32, i32), text: &str, scale: u32, c: Rgb) {
    let (w, h) = text_size(px(scale), font(), text);
    let mut mask = GrayImage::new(w, h);
    draw_text_mut(&mut mask, Luma([255]), 0, 0, px(scale), font(), text);
    for (mx, my, &Luma([m])) in mask.enumerate_pixels() {
        let level = (u32::from(m) * LEVELS + 127) / 255;
        let (px, py) = (x + mx as i32, y + my as i32);
        if level > 0 && px >= 0 && py >= 0 && px < img.width() as i32 && py < img.height() as i32 {
            let p = img.get_pixel_mut(px as u32, py as u32);
            *p = rgba(mix([p[0], p[1], p[2]], c, level as f32 / LEVELS as f32));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(img: &RgbaImage, x: u32, y: u32) -> Rgb {
        let p = img.get_pixel(x, y);
        [p[0], p[1], p[2]]
    }

    #[test]
    fn line_hits_both_ends_and_dashes_skip() {
        let mut img = RgbaImage::from_pixel(20, 20, rgba([0, 0, 0]));
        line(&mut img, ((1, 2), (17, 9)), 1, [9, 9, 9], None);
        line(&mut img, ((0, 15), (19, 15)), 1, [7, 7, 7], Some((2, 2)));
        line(&mut img, ((-50, 5), (50, 5)), 3, [5, 5, 5], None);
        assert_eq!(at(&img, 1, 2), [9, 9, 9]);
        assert_eq!(at(&img, 17, 9), [9, 9, 9]);
        assert_eq!(at(&img, 0, 4), [5, 5, 5]);
        assert_eq!(at(&img, 19, 6), [5, 5, 5]);
        let dashed: Vec<bool> = (0..8).map(|x| at(&img, x, 15) == [7, 7, 7]).collect();
        assert_eq!(dashed, [true, true, false, false, true, true, false, false]);
    }

    #[test]
    fn text_is_measured_drawn_and_few_coloured() {
        assert_eq!(text_width("", 2), 0);
        assert!(text_width("step 42", 2) > text_width("step 42", 1));
        let mut img = RgbaImage::from_pixel(120, 30, rgba([0, 0, 0]));
        text(&mut img, (2, 2), "explored 87.5%", 2, [200, 100, 50]);
        text(&mut img, (-5, 100), "off the picture", 2, [1, 1, 1]);
        let colours: std::collections::HashSet<Rgb> =
            img.pixels().map(|p| [p[0], p[1], p[2]]).collect();
        assert!(colours.contains(&[200, 100, 50]), "full ink");
        assert!(colours.len() <= LEVELS as usize + 1, "{}", colours.len());
        assert_eq!(mix([0, 0, 0], [200, 100, 50], 0.5), [100, 50, 25]);
    }
}
