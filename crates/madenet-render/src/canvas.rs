//! Hand-written drawing primitives on an RGBA image, clipped to a rectangle: rectangles,
//! filled circles, thick and dashed Bresenham lines, alpha blending and bitmap text.

use crate::font;
use image::{Rgba, RgbaImage};

/// An opaque RGB colour.
pub type Rgb = [u8; 3];

/// `a` moved towards `b` by `t` (0 = `a`, 1 = `b`).
pub fn mix(a: Rgb, b: Rgb, t: f32) -> Rgb {
    let t = t.clamp(0.0, 1.0);
    let f = |x: u8, y: u8| (x as f32 + (y as f32 - x as f32) * t).round() as u8;
    [f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2])]
}

/// A drawing surface: the image plus a clip rectangle `[x0, x1) × [y0, y1)` in pixels.
/// Every primitive silently skips pixels outside the clip, so callers never need to bounds
/// check (robots or paths off the grid just do not show).
pub struct Canvas<'a> {
    img: &'a mut RgbaImage,
    x0: i32,
    y0: i32,
    x1: i32,
    y1: i32,
}

impl<'a> Canvas<'a> {
    /// The whole image.
    pub fn new(img: &'a mut RgbaImage) -> Self {
        let (w, h) = (img.width() as i32, img.height() as i32);
        Canvas {
            img,
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        }
    }

    /// The same image clipped to `[x, x + w) × [y, y + h)` (intersected with the image).
    pub fn clipped(img: &'a mut RgbaImage, x: i32, y: i32, w: i32, h: i32) -> Self {
        let mut c = Canvas::new(img);
        c.x0 = x.max(0);
        c.y0 = y.max(0);
        c.x1 = (x + w).min(c.x1);
        c.y1 = (y + h).min(c.y1);
        c
    }

    #[inline]
    fn inside(&self, x: i32, y: i32) -> bool {
        x >= self.x0 && x < self.x1 && y >= self.y0 && y < self.y1
    }

    #[inline]
    pub fn put(&mut self, x: i32, y: i32, c: Rgb) {
        if self.inside(x, y) {
            self.img
                .put_pixel(x as u32, y as u32, Rgba([c[0], c[1], c[2], 255]));
        }
    }

    /// Moves the pixel at `(x, y)` towards `c` by `alpha`.
    #[inline]
    pub fn blend(&mut self, x: i32, y: i32, c: Rgb, alpha: f32) {
        if self.inside(x, y) {
            let p = self.img.get_pixel_mut(x as u32, y as u32);
            let m = mix([p[0], p[1], p[2]], c, alpha);
            *p = Rgba([m[0], m[1], m[2], 255]);
        }
    }

    /// Filled rectangle with top-left `(x, y)` and size `w × h`.
    pub fn fill_rect(&mut self, x: i32, y: i32, w: i32, h: i32, c: Rgb) {
        for yy in y.max(self.y0)..(y + h).min(self.y1) {
            for xx in x.max(self.x0)..(x + w).min(self.x1) {
                self.put(xx, yy, c);
            }
        }
    }

    /// Rectangle blended towards `c` by `alpha`.
    pub fn blend_rect(&mut self, x: i32, y: i32, w: i32, h: i32, c: Rgb, alpha: f32) {
        for yy in y.max(self.y0)..(y + h).min(self.y1) {
            for xx in x.max(self.x0)..(x + w).min(self.x1) {
                self.blend(xx, yy, c, alpha);
            }
        }
    }

    /// One-pixel rectangle outline, `w × h` outer size.
    pub fn rect_outline(&mut self, x: i32, y: i32, w: i32, h: i32, c: Rgb) {
        if w <= 0 || h <= 0 {
            return;
        }
        self.fill_rect(x, y, w, 1, c);
        self.fill_rect(x, y + h - 1, w, 1, c);
        self.fill_rect(x, y, 1, h, c);
        self.fill_rect(x + w - 1, y, 1, h, c);
    }

    /// Filled disc of radius `r` (pixels whose centre lies within `r` of `(cx, cy)`).
    pub fn fill_circle(&mut self, cx: i32, cy: i32, r: f32, c: Rgb) {
        let ri = r.ceil() as i32;
        let r2 = r * r;
        for dy in -ri..=ri {
            for dx in -ri..=ri {
                if (dx * dx + dy * dy) as f32 <= r2 {
                    self.put(cx + dx, cy + dy, c);
                }
            }
        }
    }

    /// Bresenham line from `a` to `b`, `thick` pixels wide (square brush). With
    /// `dash = Some((on, off))` only the first `on` of every `on + off` steps are drawn.
    pub fn line(
        &mut self,
        a: (i32, i32),
        b: (i32, i32),
        thick: u32,
        c: Rgb,
        dash: Option<(u32, u32)>,
    ) {
        let (mut x, mut y) = a;
        let dx = (b.0 - x).abs();
        let dy = -(b.1 - y).abs();
        let sx = if x < b.0 { 1 } else { -1 };
        let sy = if y < b.1 { 1 } else { -1 };
        let mut err = dx + dy;
        let t = thick.max(1) as i32;
        let lo = -(t - 1) / 2;
        let mut step = 0u32;
        loop {
            let on = match dash {
                Some((on, off)) => step % (on + off).max(1) < on,
                None => true,
            };
            if on {
                for oy in lo..lo + t {
                    for ox in lo..lo + t {
                        self.put(x + ox, y + oy, c);
                    }
                }
            }
            if (x, y) == b {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
            step += 1;
        }
    }

    /// Draws `text` in the bitmap font with its top-left corner at `(x, y)`.
    pub fn text(&mut self, x: i32, y: i32, text: &str, scale: u32, c: Rgb) {
        font::for_each_ink(text, scale, |dx, dy| {
            self.put(x + dx as i32, y + dy as i32, c)
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn px(img: &RgbaImage, x: u32, y: u32) -> Rgb {
        let p = img.get_pixel(x, y);
        [p[0], p[1], p[2]]
    }

    #[test]
    fn clip_keeps_pixels_inside() {
        let mut img = RgbaImage::from_pixel(10, 10, Rgba([0, 0, 0, 255]));
        let mut c = Canvas::clipped(&mut img, 2, 2, 4, 4);
        c.fill_rect(-100, -100, 1000, 1000, [255, 0, 0]);
        c.line((-50, 5), (50, 5), 3, [0, 255, 0], None);
        c.fill_circle(1000, 1000, 5.0, [1, 1, 1]);
        assert_eq!(px(&img, 1, 1), [0, 0, 0]);
        assert_eq!(px(&img, 6, 6), [0, 0, 0]);
        assert_eq!(px(&img, 2, 2), [255, 0, 0]);
        assert_eq!(px(&img, 5, 5), [0, 255, 0]);
    }

    #[test]
    fn line_hits_both_ends_and_dashes_skip() {
        let mut img = RgbaImage::from_pixel(20, 20, Rgba([0, 0, 0, 255]));
        let mut c = Canvas::new(&mut img);
        c.line((1, 2), (17, 9), 1, [9, 9, 9], None);
        c.line((0, 15), (19, 15), 1, [7, 7, 7], Some((2, 2)));
        assert_eq!(px(&img, 1, 2), [9, 9, 9]);
        assert_eq!(px(&img, 17, 9), [9, 9, 9]);
        let dashed: Vec<bool> = (0..8).map(|x| px(&img, x, 15) == [7, 7, 7]).collect();
        assert_eq!(dashed, [true, true, false, false, true, true, false, false]);
    }

    #[test]
    fn circle_and_mix() {
        let mut img = RgbaImage::from_pixel(11, 11, Rgba([0, 0, 0, 255]));
        Canvas::new(&mut img).fill_circle(5, 5, 3.0, [200, 0, 0]);
        assert_eq!(px(&img, 5, 5), [200, 0, 0]);
        assert_eq!(px(&img, 8, 5), [200, 0, 0]);
        assert_eq!(px(&img, 8, 8), [0, 0, 0]);
        assert_eq!(mix([0, 0, 0], [200, 100, 50], 0.5), [100, 50, 25]);
    }
}
