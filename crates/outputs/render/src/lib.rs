//! Pictures of madenet simulator frames.
//!
//! This crate draws simulator frames as pictures — PNG snapshots and animated GIFs — from
//! plain data ([`Frame`]). The drawing knows nothing of the simulator: whoever runs an episode
//! fills in a [`Frame`] per step (ground truth, the team's merged map, robots with their paths,
//! goals and goal candidates, comm links, explored fraction) — [`trial_frame`] does it for a
//! simulator trial, [`world_frame`] for a world whose agents run elsewhere — and hands it to
//! [`render`], [`save_png`], [`save_gif`] or the streaming [`GifWriter`].
//!
//! The picture has a status bar on top ("step 42  explored 87.5%" plus a progress bar) and
//! two panels side by side (the left one can be switched off with
//! [`RenderOptions::show_truth`]):
//!
//! * **truth** — the ground truth map, free cells white, obstacles near-black; cells the team
//!   has not seen yet are dimmed (blue-gray) so progress is visible;
//! * **team map** — the merged knowledge: unknown mid-gray, free white, obstacles black.
//!
//! Both panels show the robots as filled discs (robot 0 blue, 1 orange, 2 green as in the
//! paper's Fig. 1, then further distinct colours, see [`robot_color`]), each robot's planned
//! path as a line through cell centres, its goal as an X, its goal candidates as small hollow
//! squares in a lighter shade, its field of view as a faint tint, and comm links as thin
//! dashed lines between robots, over light grid lines between cells.
//!
//! Shapes are drawn with `imageproc` and text with `ab_glyph` in the font the figures use
//! (`madenet-plots`' bundled DejaVu Sans), its antialiasing reduced to eight levels so a
//! picture keeps to the 256 colours a GIF frame holds exactly. `image` encodes PNGs and `gif`
//! (the GIF library `image` itself uses) writes animations that store only what changed
//! between frames ([`GifWriter`]). The image size is a
//! deterministic function of the grid size and the options ([`Layout`]). Files are written
//! through `madenet-files` (atomic replace of a regular file, through a symlink to its target,
//! streamed to a device or pipe), and every error names
//! the target file.

#![deny(missing_docs)]

mod animation;
pub mod continuous;
mod draw;
mod of_trial;
pub mod sink;

pub use animation::{save_gif, GifWriter};
pub use of_trial::{trial_frame, world_frame};
pub use sink::{Drawn, Pictures};

use draw::{line, mix, rect, rgba, translucent, Rgb};
use image::{Rgba, RgbaImage};
use imageproc::drawing::{
    draw_filled_circle_mut, draw_filled_rect_mut, draw_hollow_rect_mut, Blend,
};
use imageproc::rect::Rect;
use madenet_files::AtomicFile;
use madenet_map::{OccGrid, Occupancy, Pos};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

/// Everything one picture shows; plain data filled in by the simulator.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Timestep t shown in the status bar (`step 42`).
    pub step: usize,
    /// Ground truth (no Unknown cells).
    pub truth: OccGrid,
    /// The team's merged knowledge, same size as truth (Unknown/Free/Obstacle). The panels
    /// are sized by this grid; `truth` is read cell by cell at the same positions.
    pub team_map: OccGrid,
    /// The robots; robot i (its index here) is drawn in [`robot_color`]`(i)`.
    pub robots: Vec<RobotFrame>,
    /// Explored fraction 0..=1, shown in the status bar.
    pub explored: f64,
    /// Pairs of robot indices currently exchanging information (drawn as thin lines between
    /// them). Pairs naming a robot that does not exist are ignored.
    pub links: Vec<(usize, usize)>,
}

impl Default for Frame {
    /// Step 0, 1 × 1 free grids, no robots.
    fn default() -> Self {
        Frame {
            step: 0,
            truth: OccGrid::new(1, 1, Occupancy::Free),
            team_map: OccGrid::new(1, 1, Occupancy::Free),
            robots: Vec::new(),
            explored: 0.0,
            links: Vec::new(),
        }
    }
}

/// One robot as drawn in a [`Frame`]. Positions outside the grid are simply not drawn.
#[derive(Clone, Debug, Default)]
pub struct RobotFrame {
    /// The robot's cell x_i, drawn as a filled disc.
    pub pos: Pos,
    /// The robot's current exploration goal g_i, drawn as an X; `None` draws no goal.
    pub goal: Option<Pos>,
    /// Planned path from the robot to its goal (cells, first = next cell).
    pub path: Vec<Pos>,
    /// The robot's current goal candidates (the paper's G_i), drawn as small hollow markers.
    pub candidates: Vec<Pos>,
    /// The robot's own sensed cells this step (optional highlight of the field of view).
    pub in_view: Vec<Pos>,
}

/// How to draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderOptions {
    /// Pixels per grid cell (grid lines included); values below 1 count as 1. Default 16.
    pub cell_px: u32,
    /// Draw the ground-truth panel left of the team map. Default true.
    pub show_truth: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            cell_px: 16,
            show_truth: true,
        }
    }
}

/// Which panel of the picture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Panel {
    /// The ground-truth panel (left; absent without [`RenderOptions::show_truth`]).
    Truth,
    /// The team-map panel: the merged knowledge (right, or alone).
    Team,
}

/// Where things go in the picture; a pure function of the grid size and the options.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Picture width in pixels.
    pub width: u32,
    /// Picture height in pixels.
    pub height: u32,
    /// Grid width in cells (columns).
    pub grid_width: usize,
    /// Grid height in cells (rows).
    pub grid_height: usize,
    /// Effective pixels per cell (≥ 1).
    pub cell_px: u32,
    /// Top-left pixel of the truth panel (its outer grid line), if shown.
    pub truth_origin: Option<(u32, u32)>,
    /// Top-left pixel of the team-map panel.
    pub team_origin: (u32, u32),
    /// Font scale of the status bar and titles (1 to 3).
    pub text_scale: u32,
    /// Height of the status bar on top, in pixels.
    pub status_height: u32,
}

const MARGIN: u32 = 8;
const GAP: u32 = 16;
/// The longest status text the layout plans room for.
const STATUS_TEMPLATE: &str = "step 9999  explored 100.0%";

/// The largest `cell_px` a picture may use.
pub const MAX_CELL_PX: u32 = 256;
/// The most pixels one picture may have (64 Mpx: 256 MB as RGBA), so a typo in `cell_px`
/// is an error rather than an allocation of gigabytes.
pub const MAX_PIXELS: u64 = 1 << 26;

/// Checks that pictures of a `grid_width` × `grid_height` grid drawn with `opts` are of a
/// size worth drawing: `cell_px` in 1..=[`MAX_CELL_PX`] and at most [`MAX_PIXELS`] pixels.
/// The message names `cell_px` and the bound.
pub fn check_size(
    grid_width: usize,
    grid_height: usize,
    opts: &RenderOptions,
) -> Result<(), String> {
    if !(1..=MAX_CELL_PX).contains(&opts.cell_px) {
        return Err(format!(
            "cell_px must be in 1..={MAX_CELL_PX}, got {}",
            opts.cell_px
        ));
    }
    // In u64, the way Layout::new computes it, so no size overflows before it is refused.
    let panels = if opts.show_truth { 2 } else { 1 };
    let pw = grid_width as u64 * u64::from(opts.cell_px) + 1;
    let ph = grid_height as u64 * u64::from(opts.cell_px) + 1;
    let pixels = (panels * pw + u64::from(2 * MARGIN + GAP)) * (ph + 100);
    if pixels > MAX_PIXELS {
        return Err(format!(
            "cell_px {} on a {grid_height}×{grid_width} map makes a picture of about {} Mpx, over the {} Mpx limit: use a smaller cell_px",
            opts.cell_px,
            pixels >> 20,
            MAX_PIXELS >> 20
        ));
    }
    Ok(())
}

impl Layout {
    /// Layout for a grid of `grid_width` × `grid_height` cells.
    pub fn new(grid_width: usize, grid_height: usize, opts: &RenderOptions) -> Layout {
        let cell_px = opts.cell_px.max(1);
        let pw = grid_width as u32 * cell_px + 1;
        let ph = grid_height as u32 * cell_px + 1;
        let width = if opts.show_truth {
            2 * MARGIN + 2 * pw + GAP
        } else {
            2 * MARGIN + pw
        };
        // Text grows with the cells (16 px cells: scale 2, at most 3) but shrinks to scale 1
        // when the longest status text would not fit.
        let mut text_scale = (cell_px / 8).clamp(1, 3);
        while text_scale > 1 && width < 2 * MARGIN + draw::text_width(STATUS_TEMPLATE, text_scale) {
            text_scale -= 1;
        }
        let status_height = 15 * text_scale;
        let title_height = 15 * text_scale;
        let top = status_height + title_height;
        let height = top + ph + MARGIN;
        let (truth_origin, team_origin) = if opts.show_truth {
            (Some((MARGIN, top)), (MARGIN + pw + GAP, top))
        } else {
            (None, (MARGIN, top))
        };
        Layout {
            width,
            height,
            grid_width,
            grid_height,
            cell_px,
            truth_origin,
            team_origin,
            text_scale,
            status_height,
        }
    }

    /// Layout for `frame` (sized by its team map).
    pub fn for_frame(frame: &Frame, opts: &RenderOptions) -> Layout {
        Layout::new(frame.team_map.width(), frame.team_map.height(), opts)
    }

    /// Panel size in pixels (both panels are the same size).
    pub fn panel_size(&self) -> (u32, u32) {
        (
            self.grid_width as u32 * self.cell_px + 1,
            self.grid_height as u32 * self.cell_px + 1,
        )
    }

    /// Top-left pixel of `panel`, `None` for a panel not shown.
    pub fn origin(&self, panel: Panel) -> Option<(u32, u32)> {
        match panel {
            Panel::Truth => self.truth_origin,
            Panel::Team => Some(self.team_origin),
        }
    }

    /// Centre pixel of cell `p` in `panel`; `None` if the panel is not shown or `p` is
    /// outside the grid.
    pub fn cell_center(&self, panel: Panel, p: Pos) -> Option<(u32, u32)> {
        let in_grid = p.row >= 0
            && p.col >= 0
            && (p.row as usize) < self.grid_height
            && (p.col as usize) < self.grid_width;
        if !in_grid {
            return None;
        }
        let (ox, oy) = self.origin(panel)?;
        let half = self.cell_px / 2;
        Some((
            ox + p.col as u32 * self.cell_px + half,
            oy + p.row as u32 * self.cell_px + half,
        ))
    }
}

// ---------------------------------------------------------------------------------------
// Colours

pub(crate) const BACKGROUND: Rgb = [246, 246, 244];
const STATUS_BG: Rgb = [36, 40, 48];
const STATUS_FG: Rgb = [238, 238, 238];
const BAR_BORDER: Rgb = [150, 156, 166];
const BAR_FILL: Rgb = [110, 190, 120];
pub(crate) const TITLE_FG: Rgb = [50, 50, 50];
const PANEL_BORDER: Rgb = [90, 90, 90];
const GRID_INK: Rgb = [0, 0, 0];
const GRID_ALPHA: f32 = 0.12;
pub(crate) const FREE: Rgb = [255, 255, 255];
pub(crate) const UNKNOWN: Rgb = [128, 128, 128];
const TEAM_OBSTACLE: Rgb = [0, 0, 0];
const TRUTH_OBSTACLE: Rgb = [40, 40, 40];
const TRUTH_FREE_UNSEEN: Rgb = [192, 201, 216];
const TRUTH_OBSTACLE_UNSEEN: Rgb = [88, 94, 108];
const LINK: Rgb = [60, 60, 60];
const VIEW_ALPHA: f32 = 0.2;

/// Fixed robot colours: the paper's blue, orange, green, then the rest of a
/// colour-blind-friendly qualitative palette (gray left out: it is the unknown colour).
const ROBOT_PALETTE: [Rgb; 9] = [
    [31, 119, 180],  // blue
    [255, 127, 14],  // orange
    [44, 160, 44],   // green
    [214, 39, 40],   // red
    [148, 103, 189], // purple
    [140, 86, 75],   // brown
    [227, 119, 194], // pink
    [188, 189, 34],  // olive
    [23, 190, 207],  // cyan
];

pub(crate) fn robot_rgb(i: usize) -> Rgb {
    if let Some(&c) = ROBOT_PALETTE.get(i) {
        return c;
    }
    // Beyond the palette: hues spread by the golden angle, fairly saturated.
    let h = ((i - ROBOT_PALETTE.len()) as f32 * 137.507_77 + 15.0) % 360.0;
    hsv(h, 0.75, 0.85)
}

fn hsv(h: f32, s: f32, v: f32) -> Rgb {
    let c = v * s;
    let x = c * (1.0 - ((h / 60.0) % 2.0 - 1.0).abs());
    let m = v - c;
    let (r, g, b) = match (h / 60.0) as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let f = |u: f32| ((u + m) * 255.0).round().clamp(0.0, 255.0) as u8;
    [f(r), f(g), f(b)]
}

/// The colour robot `i` is drawn in: 0 blue, 1 orange, 2 green (the paper's Fig. 1), then
/// red, purple, brown, pink, olive, cyan, then golden-angle hues.
pub fn robot_color(i: usize) -> Rgba<u8> {
    let [r, g, b] = robot_rgb(i);
    Rgba([r, g, b, 255])
}

// ---------------------------------------------------------------------------------------
// Rendering

/// Draws `frame` as an opaque RGBA picture of size [`Layout::for_frame`].
pub fn render(frame: &Frame, opts: &RenderOptions) -> RgbaImage {
    let layout = Layout::for_frame(frame, opts);
    // Drawn on directly through `.0`, alpha-blended through the `Blend` wrapper.
    let mut img = Blend(RgbaImage::from_pixel(
        layout.width,
        layout.height,
        rgba(BACKGROUND),
    ));
    draw_status(&mut img.0, &layout, frame);
    let s = layout.text_scale;
    let (pw, _) = layout.panel_size();
    for (panel, title) in [(Panel::Truth, "truth"), (Panel::Team, "team map")] {
        let Some((ox, _)) = layout.origin(panel) else {
            continue;
        };
        let tw = draw::text_width(title, s);
        let tx = ox as i32 + (pw as i32 - tw as i32) / 2;
        let ty = (layout.status_height + 3 * s) as i32;
        draw::text(&mut img.0, (tx.max(0), ty), title, s, TITLE_FG);
        draw_panel(&mut img, &layout, frame, panel);
    }
    img.0
}

fn draw_status(img: &mut RgbaImage, layout: &Layout, frame: &Frame) {
    let s = layout.text_scale;
    let bar = Rect::at(0, 0).of_size(layout.width, layout.status_height);
    draw_filled_rect_mut(img, bar, rgba(STATUS_BG));
    let text = format!(
        "step {}  explored {:.1}%",
        frame.step,
        frame.explored * 100.0
    );
    let cap_top = ((layout.status_height - 7 * s) / 2) as i32;
    // The line's top sits two scale units above the capitals' top.
    draw::text(
        img,
        (MARGIN as i32, cap_top - 2 * s as i32),
        &text,
        s,
        STATUS_FG,
    );

    // Progress bar at the right end, where there is room beside the longest status text.
    let bar_w = 100 * s;
    let text_room = draw::text_width(STATUS_TEMPLATE, s) + 8 * s;
    if layout.width >= 2 * MARGIN + text_room + bar_w {
        let x = (layout.width - MARGIN - bar_w) as i32;
        let h = (7 * s) as i32;
        let fill = if frame.explored.is_finite() {
            frame.explored.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let inner = ((bar_w - 2) as f64 * fill).round() as i32;
        let outline = Rect::at(x, cap_top).of_size(bar_w, h as u32);
        draw_hollow_rect_mut(img, outline, rgba(BAR_BORDER));
        if let Some(r) = rect(x + 1, cap_top + 1, inner, h - 2) {
            draw_filled_rect_mut(img, r, rgba(BAR_FILL));
        }
    }
}

fn cell_color(frame: &Frame, panel: Panel, p: Pos) -> Rgb {
    let team = frame.team_map.get(p);
    match panel {
        Panel::Team => match team {
            Occupancy::Unknown => UNKNOWN,
            Occupancy::Free => FREE,
            Occupancy::Obstacle => TEAM_OBSTACLE,
        },
        Panel::Truth => match (frame.truth.get(p), team.is_known()) {
            (Occupancy::Obstacle, true) => TRUTH_OBSTACLE,
            (Occupancy::Obstacle, false) => TRUTH_OBSTACLE_UNSEEN,
            (_, true) => FREE,
            (_, false) => TRUTH_FREE_UNSEEN,
        },
    }
}

/// Draws `panel`. Everything is drawn around cell centres inside the grid and what belongs to
/// a cell outside it is left out, so nothing reaches beyond the panel.
fn draw_panel(c: &mut Blend<RgbaImage>, layout: &Layout, frame: &Frame, panel: Panel) {
    let Some((ox, oy)) = layout.origin(panel) else {
        return;
    };
    let (pw, ph) = layout.panel_size();
    let (ox, oy) = (ox as i32, oy as i32);
    let cp = layout.cell_px as i32;
    let center = |p: Pos| {
        let (x, y) = layout.cell_center(panel, p)?;
        Some((x as i32, y as i32))
    };

    // Cells (each drawn one pixel larger so the shared grid-line pixels get a colour).
    for row in 0..layout.grid_height as i32 {
        for col in 0..layout.grid_width as i32 {
            let color = rgba(cell_color(frame, panel, Pos::new(row, col)));
            let r = Rect::at(ox + col * cp, oy + row * cp).of_size(cp as u32 + 1, cp as u32 + 1);
            draw_filled_rect_mut(&mut c.0, r, color);
        }
    }
    // Field of view: a faint tint of each robot's colour on its sensed cells' interiors.
    for (i, r) in frame.robots.iter().enumerate() {
        let tint = translucent(robot_rgb(i), VIEW_ALPHA);
        for p in &r.in_view {
            let corner = center(*p).map(|(x, y)| (x - cp / 2, y - cp / 2));
            if let Some(r) = corner.and_then(|(x, y)| rect(x + 1, y + 1, cp - 1, cp - 1)) {
                draw_filled_rect_mut(c, r, tint);
            }
        }
    }
    // Grid lines, darkening whatever is below a little; skipped when cells are tiny.
    if cp >= 4 {
        let ink = translucent(GRID_INK, GRID_ALPHA);
        for col in 1..layout.grid_width as i32 {
            draw_filled_rect_mut(c, Rect::at(ox + col * cp, oy).of_size(1, ph), ink);
        }
        for row in 1..layout.grid_height as i32 {
            draw_filled_rect_mut(c, Rect::at(ox, oy + row * cp).of_size(pw, 1), ink);
        }
    }
    let c = &mut c.0;
    draw_hollow_rect_mut(c, Rect::at(ox, oy).of_size(pw, ph), rgba(PANEL_BORDER));
    let thick = (layout.cell_px / 8).max(1);
    let link_thick = (layout.cell_px / 16).max(1);

    // Comm links under everything robot-specific.
    for &(a, b) in &frame.links {
        let (Some(ra), Some(rb)) = (frame.robots.get(a), frame.robots.get(b)) else {
            continue;
        };
        if let (Some(pa), Some(pb)) = (center(ra.pos), center(rb.pos)) {
            let dash = Some((4 * link_thick, 3 * link_thick));
            line(c, (pa, pb), link_thick, LINK, dash);
        }
    }
    // Paths.
    for (i, r) in frame.robots.iter().enumerate() {
        let mut prev = center(r.pos);
        for &p in &r.path {
            if let (Some(a), Some(b)) = (prev, center(p)) {
                line(c, (a, b), thick, robot_rgb(i), None);
            }
            prev = center(p);
        }
    }
    // Candidates: hollow squares, half a cell wide, in a lighter shade.
    let half = cp / 4;
    for (i, r) in frame.robots.iter().enumerate() {
        let color = rgba(mix(robot_rgb(i), FREE, 0.35));
        for (x, y) in r.candidates.iter().filter_map(|&p| center(p)) {
            let side = 2 * half as u32 + 1;
            draw_hollow_rect_mut(c, Rect::at(x - half, y - half).of_size(side, side), color);
            if cp >= 12 {
                let inner = Rect::at(x - half + 1, y - half + 1).of_size(side - 2, side - 2);
                draw_hollow_rect_mut(c, inner, color);
            }
        }
    }
    // Goals: an X across most of the cell.
    let arm = ((cp as f32) * 0.32).round() as i32;
    for (i, r) in frame.robots.iter().enumerate() {
        if let Some((x, y)) = r.goal.and_then(center) {
            let color = robot_rgb(i);
            line(
                c,
                ((x - arm, y - arm), (x + arm, y + arm)),
                thick,
                color,
                None,
            );
            line(
                c,
                ((x - arm, y + arm), (x + arm, y - arm)),
                thick,
                color,
                None,
            );
        }
    }
    // Robots: discs with a thin darker rim, on top of everything.
    let radius = ((cp as f32 * 0.42).round() as i32).max(1);
    for (i, r) in frame.robots.iter().enumerate() {
        let Some((x, y)) = center(r.pos) else {
            continue;
        };
        let color = robot_rgb(i);
        if radius >= 3 {
            draw_filled_circle_mut(c, (x, y), radius, rgba(mix(color, [0, 0, 0], 0.45)));
            draw_filled_circle_mut(c, (x, y), radius - 1, rgba(color));
        } else {
            draw_filled_circle_mut(c, (x, y), radius, rgba(color));
        }
    }
}

// ---------------------------------------------------------------------------------------
// Files

/// Everything that can go wrong writing a picture; each message starts with the target file.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Creating, writing or renaming the file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The picture file being written.
        path: PathBuf,
        /// The underlying I/O error.
        source: io::Error,
    },
    /// The image encoder refused the picture (e.g. a GIF wider than 65535 pixels).
    #[error("{}: cannot encode picture: {source}", path.display())]
    Encode {
        /// The picture file being written.
        path: PathBuf,
        /// The encoder's error.
        source: image::ImageError,
    },
    /// A GIF frame whose picture size differs from the first frame's.
    #[error(
        "{}: frame {index} is {got_width}x{got_height} px but the animation is \
         {width}x{height} px (all frames need the same grid size and options)",
        path.display()
    )]
    FrameSize {
        /// The GIF being written.
        path: PathBuf,
        /// 0-based index of the offending frame.
        index: usize,
        /// The animation's width in pixels (the first frame's).
        width: u32,
        /// The animation's height in pixels (the first frame's).
        height: u32,
        /// The offending frame's width in pixels.
        got_width: u32,
        /// The offending frame's height in pixels.
        got_height: u32,
    },
    /// A GIF with no frames was requested.
    #[error("{}: no frames to write", path.display())]
    NoFrames {
        /// The GIF that was to be written.
        path: PathBuf,
    },
    /// The picture would be too large, or `cell_px` is out of range ([`check_size`]).
    #[error("{}: {reason}", path.display())]
    TooLarge {
        /// The picture file that was to be written.
        path: PathBuf,
        /// [`check_size`]'s message, naming `cell_px` and the bound.
        reason: String,
    },
    /// The path has no file name to write to.
    #[error("{}: not a file path", path.display())]
    BadPath {
        /// The path given.
        path: PathBuf,
    },
}

fn check_frame_size(frame: &Frame, opts: &RenderOptions, path: &Path) -> Result<(), RenderError> {
    check_size(frame.team_map.width(), frame.team_map.height(), opts).map_err(|reason| {
        RenderError::TooLarge {
            path: path.to_path_buf(),
            reason,
        }
    })
}

/// Starts writing `path` through the workspace's one file writer (atomic replace of regular
/// files, through symlinks, streamed to devices and pipes).
fn create(path: &Path) -> Result<AtomicFile, RenderError> {
    AtomicFile::create(path).map_err(|source| io_err(path, source))
}

fn io_err(path: &Path, source: io::Error) -> RenderError {
    RenderError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Renders `frame` and writes it as a PNG to `path` (atomically).
pub fn save_png(frame: &Frame, opts: &RenderOptions, path: &Path) -> Result<(), RenderError> {
    check_frame_size(frame, opts, path)?;
    save_image_png(&render(frame, opts), path)
}

/// Writes a rendered picture as a PNG to `path` (atomically).
pub fn save_image_png(img: &RgbaImage, path: &Path) -> Result<(), RenderError> {
    let mut w = BufWriter::new(create(path)?);
    img.write_with_encoder(image::codecs::png::PngEncoder::new(&mut w))
        .map_err(|source| RenderError::Encode {
            path: path.to_path_buf(),
            source,
        })?;
    let file = w.into_inner().map_err(|e| io_err(path, e.into_error()))?;
    file.commit().map_err(|e| io_err(path, e))
}
