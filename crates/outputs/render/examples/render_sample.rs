//! Renders a hand-made 20 × 20 frame (a few obstacles, the right half of the team map still
//! unknown, three robots with paths, goals and candidates) to a PNG, and a short GIF of the
//! robots walking their paths.
//!
//! `cargo run -p madenet-render --example render_sample -- [out.png] [out.gif] [cell_px]`
//! (defaults /tmp/render_sample.png, /tmp/render_sample.gif, 16)

use madenet_map::{OccGrid, Occupancy, Pos};
use madenet_render::{save_gif, save_png, Frame, RenderOptions, RobotFrame};
use std::path::PathBuf;

fn p(row: i32, col: i32) -> Pos {
    Pos::new(row, col)
}

/// Cells of a straight walk from `a` to `b` (exclusive of `a`), rows first.
fn walk(a: Pos, b: Pos) -> Vec<Pos> {
    let mut out = Vec::new();
    let mut cur = a;
    while cur != b {
        if cur.row != b.row {
            cur.row += (b.row - cur.row).signum();
        } else {
            cur.col += (b.col - cur.col).signum();
        }
        out.push(cur);
    }
    out
}

fn view(c: Pos, r: i32, n: i32) -> Vec<Pos> {
    let mut v = Vec::new();
    for row in c.row - r..=c.row + r {
        for col in c.col - r..=c.col + r {
            if (0..n).contains(&row) && (0..n).contains(&col) {
                v.push(p(row, col));
            }
        }
    }
    v
}

fn sample() -> Frame {
    let n = 20;
    let mut truth = OccGrid::new(n as usize, n as usize, Occupancy::Free);
    let obstacles = [
        (3, 3, 2, 4),
        (8, 12, 6, 2),
        (14, 4, 2, 6),
        (4, 15, 3, 3),
        (11, 1, 1, 3),
        (17, 14, 2, 4),
        (0, 9, 3, 1),
    ];
    for (r0, c0, h, w) in obstacles {
        for r in r0..r0 + h {
            for c in c0..c0 + w {
                truth.set(p(r, c), Occupancy::Obstacle);
            }
        }
    }
    // The team has seen the left half plus a ragged band around it.
    let mut team = OccGrid::new(n as usize, n as usize, Occupancy::Unknown);
    for r in 0..n {
        let reach = 10 + (r % 4) - 1;
        for c in 0..reach {
            team.set(p(r, c), truth.get(p(r, c)));
        }
    }
    let starts = [p(2, 1), p(9, 6), p(17, 2)];
    let goals = [p(1, 11), p(12, 10), p(18, 11)];
    let cands = [
        vec![p(1, 11), p(5, 10), p(0, 12)],
        vec![p(12, 10), p(7, 9), p(10, 11)],
        vec![p(18, 11), p(13, 11), p(16, 10)],
    ];
    let robots = (0..3)
        .map(|i| RobotFrame {
            pos: starts[i],
            goal: Some(goals[i]),
            path: walk(starts[i], goals[i]),
            candidates: cands[i].clone(),
            in_view: view(starts[i], 2, n),
        })
        .collect();
    let explored = team.count(Occupancy::Free) as f64 / truth.count(Occupancy::Free) as f64;
    Frame {
        step: 42,
        truth,
        team_map: team,
        robots,
        explored,
        links: vec![(0, 1)],
    }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let png = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "/tmp/render_sample.png".into()),
    );
    let gif = PathBuf::from(
        args.next()
            .unwrap_or_else(|| "/tmp/render_sample.gif".into()),
    );
    let cell_px = args
        .next()
        .map_or(16, |s| s.parse().expect("cell_px must be a number"));
    let opts = RenderOptions {
        cell_px,
        ..RenderOptions::default()
    };
    let frame = sample();
    if let Err(e) = save_png(&frame, &opts, &png) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
    // A short animation: every robot advances one cell of its path per frame.
    let mut frames = Vec::new();
    let mut f = frame.clone();
    for k in 0..8 {
        frames.push(f.clone());
        f.step += 1;
        for r in &mut f.robots {
            if !r.path.is_empty() {
                r.pos = r.path.remove(0);
            }
            r.in_view = view(r.pos, 2, 20);
        }
        f.links = if k < 3 { vec![(0, 1)] } else { vec![] };
    }
    if let Err(e) = save_gif(&frames, &opts, 300, &gif) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
    println!("wrote {} and {}", png.display(), gif.display());
}
