//! `cargo bench -p madenet-render --bench gif`: writing an animated GIF of an exploration.
//!
//! * `gif/changed_rect/N` — [`GifWriter`] (each frame stores the rectangle that changed) on an
//!   N × N generated map, 60 frames of three robots walking and sensing (16 px cells).
//! * `gif/whole_frames/N` — the same pictures through `image`'s GIF encoder, every frame whole:
//!   how the writer worked before (the anchor).
//!
//! * `gif/render/100` — [`render`] of one frame (the last of the 100 × 100 exploration): the
//!   drawing alone, no encoding.
//!
//! The GIF benches include encoding and writing a temporary file; the pictures are rendered
//! beforehand.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, RgbaImage};
use madenet_map::generate::{generate, GeneratorConfig};
use madenet_map::{OccGrid, Occupancy, Pos};
use madenet_render::{render, Frame, GifWriter, RenderOptions, RobotFrame};

/// Three robots walking diagonally, the team map growing around them.
fn frames(n: usize, steps: usize) -> Vec<Frame> {
    let truth = generate(&GeneratorConfig::for_size(n, n), 7).expect("generate");
    let mut team = OccGrid::new(n, n, Occupancy::Unknown);
    let last = n as i32 - 1;
    let mut pos = [Pos::new(0, 0), Pos::new(0, last), Pos::new(last, 0)];
    let mut out = Vec::new();
    for step in 0..steps {
        let mut robots = Vec::new();
        for (i, p) in pos.iter_mut().enumerate() {
            let mut in_view = Vec::new();
            for r in p.row - 4..=p.row + 4 {
                for c in p.col - 4..=p.col + 4 {
                    let q = Pos::new(r, c);
                    if truth.in_bounds(q) {
                        team.set(q, truth.get(q));
                        in_view.push(q);
                    }
                }
            }
            let goal = Pos::new((p.row + 6).min(last), (p.col + 6).min(last));
            robots.push(RobotFrame {
                pos: *p,
                goal: Some(goal),
                path: vec![goal],
                candidates: vec![goal],
                in_view,
            });
            *p = Pos::new(
                (p.row + 1).min(last),
                (p.col + 1 - 2 * i as i32 % 2).clamp(0, last),
            );
        }
        let frame = Frame {
            step,
            truth: truth.clone(),
            team_map: team.clone(),
            robots,
            explored: 0.0,
            links: vec![(0, 1)],
        };
        out.push(frame);
    }
    out
}

fn pictures(n: usize, steps: usize, opts: &RenderOptions) -> Vec<RgbaImage> {
    frames(n, steps).iter().map(|f| render(f, opts)).collect()
}

fn bench(c: &mut Criterion) {
    let opts = RenderOptions::default();
    let dir = madenet_testkit::Scratch::new("bench-gif");
    let mut g = c.benchmark_group("gif");
    g.sample_size(10);
    let last = frames(100, 60).pop().expect("frames");
    g.bench_function("render/100", |b| b.iter(|| render(&last, &opts)));
    for n in [40, 100] {
        let images = pictures(n, 60, &opts);
        let path = dir.join(format!("{n}.gif"));
        g.bench_with_input(BenchmarkId::new("changed_rect", n), &images, |b, images| {
            b.iter(|| {
                let mut w = GifWriter::new(&path, &opts, 150).expect("writer");
                for img in images {
                    w.push_image(img.clone()).expect("frame");
                }
                w.finish().expect("finish")
            })
        });
        g.bench_with_input(BenchmarkId::new("whole_frames", n), &images, |b, images| {
            b.iter(|| {
                let file = std::io::BufWriter::new(std::fs::File::create(&path).expect("file"));
                let mut enc = GifEncoder::new_with_speed(file, 10);
                enc.set_repeat(Repeat::Infinite).expect("repeat");
                for img in images {
                    enc.encode_frame(image::Frame::from_parts(
                        img.clone(),
                        0,
                        0,
                        Delay::from_numer_denom_ms(150, 1),
                    ))
                    .expect("frame");
                }
            })
        });
        let _ = std::fs::remove_file(&path);
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
