//! Pictures of any world's run as a [`Sink`] of the run loop ([`madenet_sim::stepping::run`]):
//! an animated GIF (a frame every `frame_s` simulated seconds) and a PNG of the final state.

use crate::continuous::{continuous_picture, px_per_m};
use crate::{render, save_image_png, trial_frame, world_frame, GifWriter};
use crate::{RenderError, RenderOptions};
use image::RgbaImage;
use madenet_sim::continuous::ContinuousTrial;
use madenet_sim::stepping::{Present, Sink, SinkError, WorldView};
use madenet_sim::Trial;
use std::ops::ControlFlow;
use std::path::PathBuf;

/// A world that can be drawn at `cell_px` pixels per cell: the grid's frame, the continuous
/// world's panels.
pub trait Drawn {
    /// The picture of the present.
    fn picture(&self, cell_px: u32) -> RgbaImage;
}

impl Drawn for Trial {
    fn picture(&self, cell_px: u32) -> RgbaImage {
        render(&trial_frame(self), &options(cell_px))
    }
}

impl Drawn for WorldView<'_> {
    fn picture(&self, cell_px: u32) -> RgbaImage {
        let frame = world_frame(
            self.world,
            |i| {
                let r = self.robot(i);
                (r.goal, r.path.to_vec(), r.candidates.to_vec())
            },
            self.exchanges,
        );
        render(&frame, &options(cell_px))
    }
}

impl Drawn for ContinuousTrial {
    /// Panels of at most `25 × cell_px` pixels (100–600) a side.
    fn picture(&self, cell_px: u32) -> RgbaImage {
        let scene = self.world().scene();
        let scale = px_per_m(
            scene.width_m().max(scene.height_m()),
            (cell_px * 25).clamp(100, 600),
        );
        continuous_picture(self, scale)
    }
}

fn options(cell_px: u32) -> RenderOptions {
    RenderOptions {
        cell_px,
        ..Default::default()
    }
}

/// The pictures asked for: a GIF and/or a PNG of the final state.
pub struct Pictures {
    gif: Option<(GifWriter, PathBuf)>,
    snapshot: Option<PathBuf>,
    cell_px: u32,
    frame_s: f64,
    next_frame: f64,
}

impl Pictures {
    /// A GIF at `gif` (`delay_ms` between frames, a frame every `frame_s` simulated seconds:
    /// 1 is every grid timestep) and/or a PNG at `snapshot`, at `cell_px` pixels per cell.
    pub fn new(
        gif: Option<PathBuf>,
        snapshot: Option<PathBuf>,
        cell_px: u32,
        delay_ms: u32,
        frame_s: f64,
    ) -> Result<Self, RenderError> {
        let gif = match gif {
            Some(p) => Some((GifWriter::new(&p, &options(cell_px), delay_ms)?, p)),
            None => None,
        };
        Ok(Pictures {
            gif,
            snapshot,
            cell_px,
            frame_s,
            next_frame: 0.0,
        })
    }

    fn push<S: Drawn + ?Sized>(&mut self, sim: &S) -> Result<(), RenderError> {
        if let Some((g, _)) = self.gif.as_mut() {
            g.push_image(sim.picture(self.cell_px))?;
        }
        Ok(())
    }
}

impl<S: Present + Drawn + ?Sized> Sink<S> for Pictures {
    fn begin(&mut self, sim: &S) -> Result<(), SinkError> {
        self.next_frame = sim.time_s() + self.frame_s;
        Ok(self.push(sim)?)
    }

    fn step(&mut self, sim: &S) -> Result<ControlFlow<String>, SinkError> {
        if self.gif.is_some() && sim.time_s() + 1e-9 >= self.next_frame {
            self.next_frame += self.frame_s;
            self.push(sim)?;
        }
        Ok(ControlFlow::Continue(()))
    }

    fn finish(&mut self, sim: &S) -> Result<Vec<String>, SinkError> {
        let mut lines = Vec::new();
        if let Some((g, p)) = self.gif.take() {
            lines.push(finish_line(g, &p)?);
        }
        if let Some(p) = self.snapshot.take() {
            save_image_png(&sim.picture(self.cell_px), &p)?;
            lines.push(format!("wrote      {}", p.display()));
        }
        Ok(lines)
    }
}

/// Finishes the GIF written to `path`; the line to print about it.
fn finish_line(g: GifWriter, path: &std::path::Path) -> Result<String, RenderError> {
    let frames = g.frames();
    let bytes = g.finish()?;
    Ok(format!(
        "wrote      {} ({frames} frames, {:.1} kB)",
        path.display(),
        bytes as f64 / 1e3
    ))
}
