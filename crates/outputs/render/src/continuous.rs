//! Pictures of a continuous trial ([`madenet_sim::continuous::ContinuousTrial`]): the true
//! world with the robots (footprints, headings, scans, local paths, target cells), the team's
//! coarse map as the agents read it, and each robot's own fine map.

use crate::draw::{line, mix, rgba, text, Rgb};
use crate::{robot_rgb, save_image_png, RenderError, BACKGROUND, FREE, TITLE_FG, UNKNOWN};
use image::RgbaImage;
use imageproc::drawing::{draw_filled_circle_mut, draw_filled_rect_mut, draw_hollow_rect_mut};
use imageproc::rect::Rect;
use madenet_map::Occupancy;
use madenet_sim::continuous::ContinuousTrial;
use std::path::Path;

const OBSTACLE: Rgb = [40, 40, 40];
const TITLE_H: u32 = 18;
const GAP: u32 = 8;

/// Pixels per metre that keep a panel of `side_m` metres within `max_px` pixels (at least 2).
pub fn px_per_m(side_m: f64, max_px: u32) -> f64 {
    (max_px as f64 / side_m.max(1e-9)).floor().max(2.0)
}

/// The picture: panels "world", "team map" and one "robot i map" per robot, side by side, at
/// `scale` pixels per metre.
pub fn continuous_picture(trial: &ContinuousTrial, scale: f64) -> RgbaImage {
    let w = trial.world();
    let scene = w.scene();
    let (pw, ph) = (
        (scene.width_m() * scale).ceil() as u32,
        (scene.height_m() * scale).ceil() as u32,
    );
    let n = w.robots();
    let panels = 2 + n as u32;
    let width = panels * pw + (panels + 1) * GAP;
    let height = ph + TITLE_H + 2 * GAP;
    let mut img = RgbaImage::from_pixel(width, height, rgba(BACKGROUND));
    let origin = |k: u32| (GAP + k * (pw + GAP), GAP + TITLE_H);
    let to_px = |(ox, oy): (u32, u32), x: f64, y: f64| {
        (
            ox as i32 + (x * scale) as i32,
            oy as i32 + (y * scale) as i32,
        )
    };
    // Panel 0: the true world.
    let o = origin(0);
    fill_raster(
        &mut img,
        o,
        (pw, ph),
        scene.fine.width(),
        scene.fine.height(),
        |r, c| {
            if scene.fine.get(madenet_map::Pos::new(r as i32, c as i32)) == Occupancy::Free {
                FREE
            } else {
                OBSTACLE
            }
        },
    );
    let cell = w.scenario().cell_size;
    // Where each robot has driven, under everything else.
    for i in 0..n {
        let trail = trial.trail(i);
        let colour = mix(robot_rgb(i), FREE, 0.55);
        for seg in trail.windows(2) {
            let (a, b) = (seg[0], seg[1]);
            let a = to_px(o, f64::from(a.0), f64::from(a.1));
            let b = to_px(o, f64::from(b.0), f64::from(b.1));
            line(&mut img, (a, b), 2, colour, None);
        }
    }
    for i in 0..n {
        let colour = robot_rgb(i);
        let p = w.pose(i);
        for &(a, d, hit) in w.scan_beams(i) {
            if hit {
                let (x, y) = to_px(o, p.x + a.cos() * d, p.y + a.sin() * d);
                draw_filled_rect_mut(&mut img, Rect::at(x, y).of_size(2, 2), rgba([220, 40, 40]));
            }
        }
        let mut prev = (p.x, p.y);
        for &pt in trial.planner(i).path() {
            line(
                &mut img,
                (to_px(o, prev.0, prev.1), to_px(o, pt.0, pt.1)),
                1,
                colour,
                None,
            );
            prev = pt;
        }
        if let Some(t) = trial.target(i) {
            outline_cell(&mut img, o, scale, cell, t, colour);
        }
        if let Some(g) = trial.agents()[i].goal() {
            outline_cell(&mut img, o, scale, cell, g, colour);
            let (gx, gy) = to_px(o, (g.col as f64 + 0.5) * cell, (g.row as f64 + 0.5) * cell);
            draw_filled_circle_mut(&mut img, (gx, gy), 3, rgba(colour));
        }
        let (x, y) = to_px(o, p.x, p.y);
        let r = ((w.config().robot.radius * scale).round() as i32).max(2);
        draw_filled_circle_mut(&mut img, (x, y), r, rgba(colour));
        let head = to_px(
            o,
            p.x + p.theta.cos() * w.config().robot.radius * 1.6,
            p.y + p.theta.sin() * w.config().robot.radius * 1.6,
        );
        line(&mut img, ((x, y), head), 2, [0, 0, 0], None);
    }
    panel_title(
        &mut img,
        o,
        &format!(
            "world  t = {:.0} s  explored {:.0} %",
            w.time(),
            100.0 * w.explored_fraction()
        ),
    );
    // Panel 1: the team's coarse map (every robot's own reading, merged).
    let o = origin(1);
    let (ch, cw) = w.map(0).coarse_size();
    let team = w.team_map();
    fill_raster(&mut img, o, (pw, ph), cw, ch, |r, c| {
        match team[r * cw + c] {
            Occupancy::Unknown => UNKNOWN,
            Occupancy::Free => FREE,
            Occupancy::Obstacle => OBSTACLE,
        }
    });
    for i in 0..n {
        let p = w.pose(i);
        let (x, y) = to_px(o, p.x, p.y);
        draw_filled_circle_mut(&mut img, (x, y), 4, rgba(robot_rgb(i)));
    }
    panel_title(&mut img, o, "team map (1 m cells)");
    // Panels 2..: each robot's occupancy probabilities.
    for i in 0..n {
        let o = origin(2 + i as u32);
        let m = w.map(i);
        let probs = m.probabilities();
        fill_raster(&mut img, o, (pw, ph), m.width(), m.height(), |r, c| {
            if !m.observed(r, c) {
                UNKNOWN
            } else {
                let v = (255.0 * (1.0 - probs[r * m.width() + c])).round() as u8;
                [v, v, v]
            }
        });
        let p = w.pose(i);
        let (x, y) = to_px(o, p.x, p.y);
        draw_filled_circle_mut(&mut img, (x, y), 4, rgba(robot_rgb(i)));
        panel_title(&mut img, o, &format!("robot {i} map"));
    }
    img
}

/// Writes [`continuous_picture`] as a PNG (atomically).
pub fn save_continuous_png(
    trial: &ContinuousTrial,
    scale: f64,
    path: &Path,
) -> Result<(), RenderError> {
    save_image_png(&continuous_picture(trial, scale), path)
}

/// Writes a panel's title in the gap above the panel at `o`.
fn panel_title(img: &mut RgbaImage, o: (u32, u32), title: &str) {
    text(img, (o.0 as i32, GAP as i32), title, 1, TITLE_FG);
}

/// Fills a `size` panel at `o` from a `cols` × `rows` raster by nearest neighbour.
fn fill_raster(
    img: &mut RgbaImage,
    o: (u32, u32),
    size: (u32, u32),
    cols: usize,
    rows: usize,
    colour: impl Fn(usize, usize) -> Rgb,
) {
    if cols == 0 || rows == 0 {
        return;
    }
    for py in 0..size.1 {
        let r = ((py as f64 + 0.5) / size.1 as f64 * rows as f64) as usize;
        for px in 0..size.0 {
            let c = ((px as f64 + 0.5) / size.0 as f64 * cols as f64) as usize;
            img.put_pixel(
                o.0 + px,
                o.1 + py,
                rgba(colour(r.min(rows - 1), c.min(cols - 1))),
            );
        }
    }
}

fn outline_cell(
    img: &mut RgbaImage,
    o: (u32, u32),
    scale: f64,
    cell: f64,
    p: madenet_map::Pos,
    colour: Rgb,
) {
    let s = (cell * scale).round() as u32;
    let x = o.0 as i32 + (p.col as f64 * cell * scale).round() as i32;
    let y = o.1 as i32 + (p.row as f64 * cell * scale).round() as i32;
    if s > 0 {
        draw_hollow_rect_mut(img, Rect::at(x, y).of_size(s, s), rgba(colour));
    }
}
