//! The GIF writer stores only the changed rectangle of each frame; these tests decode its files
//! and files written the way it used to write them (every frame whole, through `image`'s GIF
//! encoder) with `image`'s GIF decoder, which composites the frames, and compare every frame's
//! pixels and delay.

use image::codecs::gif::{GifDecoder, GifEncoder, Repeat};
use image::{AnimationDecoder, Delay, Rgba, RgbaImage};
use madenet_map::generate::{generate, GeneratorConfig};
use madenet_map::{OccGrid, Occupancy, Pos};
use madenet_render::{render, Frame, GifWriter, RenderOptions, RobotFrame};
use madenet_testkit::Scratch;
use std::path::Path;

/// The writer as it was: every frame whole, through `image`'s encoder at speed 10.
fn write_full_frames(images: &[RgbaImage], delay_ms: u32, path: &Path) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut enc = GifEncoder::new_with_speed(file, 10);
    enc.set_repeat(Repeat::Infinite).unwrap();
    for img in images {
        enc.encode_frame(image::Frame::from_parts(
            img.clone(),
            0,
            0,
            Delay::from_numer_denom_ms(delay_ms, 1),
        ))
        .unwrap();
    }
}

fn write_delta(images: &[RgbaImage], delay_ms: u32, path: &Path) -> u64 {
    let mut w = GifWriter::new(path, &RenderOptions::default(), delay_ms).unwrap();
    for img in images {
        w.push_image(img.clone()).unwrap();
        assert!(w.bytes_written() > 0);
    }
    assert_eq!(w.dimensions(), Some(images[0].dimensions()));
    w.finish().unwrap()
}

/// Every frame as a decoder shows it (composited), with its delay.
fn decode(path: &Path) -> Vec<(RgbaImage, (u32, u32))> {
    let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    GifDecoder::new(file)
        .unwrap()
        .into_frames()
        .collect_frames()
        .unwrap()
        .into_iter()
        .map(|f| (f.delay().numer_denom_ms(), f.into_buffer()))
        .map(|(d, b)| (b, d))
        .collect()
}

/// Writes `images` both ways and checks the decoded animations are identical; returns the
/// file sizes (delta, whole frames).
fn same_animation(name: &str, images: &[RgbaImage], delay_ms: u32) -> (u64, u64) {
    let dir = Scratch::new(&format!("gif-{name}"));
    let (delta, full) = (dir.join("delta.gif"), dir.join("full.gif"));
    let written = write_delta(images, delay_ms, &delta);
    write_full_frames(images, delay_ms, &full);
    let size = std::fs::metadata(&delta).unwrap().len();
    assert_eq!(written, size, "{name}: finish reports the file size");
    let (got, want) = (decode(&delta), decode(&full));
    assert_eq!(got.len(), images.len(), "{name}: frame count");
    assert_eq!(want.len(), images.len(), "{name}: frame count (old)");
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g.1, w.1, "{name}: frame {k} delay");
        // Fully transparent pixels show the frame before (documented on GifWriter); the old
        // writer showed the background there. Every other pixel is as the old file shows it.
        let mut want = w.0.clone();
        if k > 0 {
            for (x, y, p) in want.enumerate_pixels_mut() {
                if images[k].get_pixel(x, y)[3] == 0 {
                    *p = *got[k - 1].0.get_pixel(x, y);
                }
            }
        }
        assert!(g.0 == want, "{name}: frame {k} pixels differ");
    }
    (size, std::fs::metadata(&full).unwrap().len())
}

/// An exploration on a generated map: robots walk, the team map grows around them, links
/// come and go, so every part of the picture changes somewhere.
fn episode(n: usize, steps: usize) -> Vec<Frame> {
    let truth = generate(&GeneratorConfig::for_size(n, n), 7).unwrap();
    let mut team = OccGrid::new(n, n, Occupancy::Unknown);
    let last = n as i32 - 1;
    let mut pos = [Pos::new(0, 0), Pos::new(0, last), Pos::new(last, 0)];
    let mut frames = Vec::new();
    for step in 0..steps {
        let mut robots = Vec::new();
        for (i, p) in pos.iter_mut().enumerate() {
            let mut in_view = Vec::new();
            for r in p.row - 2..=p.row + 2 {
                for c in p.col - 2..=p.col + 2 {
                    let q = Pos::new(r, c);
                    if truth.in_bounds(q) {
                        team.set(q, truth.get(q));
                        in_view.push(q);
                    }
                }
            }
            let goal = Pos::new((p.row + 4).min(last), (p.col + 3 * i as i32).min(last));
            robots.push(RobotFrame {
                pos: *p,
                goal: Some(goal),
                path: vec![Pos::new(p.row + 1, p.col), goal],
                candidates: vec![goal, Pos::new(last / 2, (step % n) as i32)],
                in_view,
            });
            // A diagonal-ish walk, wrapping at the edges.
            *p = Pos::new((p.row + 1) % n as i32, (p.col + 1 + i as i32) % n as i32);
        }
        let explored = team.count(Occupancy::Unknown) as f64 / (n * n) as f64;
        frames.push(Frame {
            step,
            truth: truth.clone(),
            team_map: team.clone(),
            robots,
            explored: 1.0 - explored,
            links: if step % 3 == 0 {
                vec![(0, 1)]
            } else {
                vec![(1, 2)]
            },
        });
    }
    frames
}

#[test]
fn episodes_decode_to_the_same_frames_as_whole_frames() {
    for (cell_px, show_truth) in [(16, true), (5, false), (1, true)] {
        let opts = RenderOptions {
            cell_px,
            show_truth,
        };
        let mut images: Vec<RgbaImage> = episode(24, 30).iter().map(|f| render(f, &opts)).collect();
        // A repeated frame (nothing changes) and a return to an earlier one.
        images.insert(10, images[9].clone());
        images.push(images[3].clone());
        let (delta, full) = same_animation(&format!("episode-{cell_px}"), &images, 150);
        println!("cell_px {cell_px}: {delta} bytes, whole frames {full} bytes");
        assert!(delta < full, "delta {delta} not below {full}");
    }
}

/// A picture of `colours` distinct colours (offset by `shift` so frames differ) in blocks.
fn many_colours(w: u32, h: u32, colours: u32, shift: u32) -> RgbaImage {
    RgbaImage::from_fn(w, h, |x, y| {
        let k = ((y / 3) * (w / 3) + x / 3) % colours + shift;
        Rgba([(k % 256) as u8, (k / 256 % 256) as u8, 77, 255])
    })
}

#[test]
fn palette_overflow_and_quantized_frames_match() {
    let (w, h) = (90, 60);
    let images = vec![
        many_colours(w, h, 200, 0),
        // New colours overflow the 256-entry palette: starts afresh.
        many_colours(w, h, 200, 150),
        many_colours(w, h, 200, 150),
        // More than 256 colours: quantized, stored whole.
        many_colours(w, h, 600, 0),
        many_colours(w, h, 40, 0),
        // Exactly 256 colours: no room for a transparent index.
        many_colours(w, h, 256, 0),
        many_colours(w, h, 256, 1),
        many_colours(w, h, 3, 9),
    ];
    same_animation("colours", &images, 90);
}

#[test]
fn transparent_pixels_in_a_first_or_quantized_frame_match() {
    let (w, h) = (40, 30);
    let mut hole = many_colours(w, h, 20, 0);
    for x in 5..15 {
        hole.put_pixel(x, 7, Rgba([1, 2, 3, 0]));
    }
    let mut translucent = many_colours(w, h, 20, 4);
    translucent.put_pixel(3, 3, Rgba([9, 9, 9, 17]));
    let images = vec![
        hole.clone(),
        many_colours(w, h, 300, 0),
        hole,
        translucent,
        many_colours(w, h, 20, 4),
    ];
    same_animation("alpha", &images, 40);
}

#[test]
fn long_delays_and_single_frames() {
    let img = many_colours(17, 5, 12, 0);
    same_animation("single", std::slice::from_ref(&img), 1_000_000);
    same_animation("short", &[img.clone(), img], 5);
}
