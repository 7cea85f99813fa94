//! `madenet run`: one trial.

use crate::scenario_args::ScenarioArgs;
use anyhow::{Context, Result};
use clap::Args;
use madenet_render::{Frame, GifWriter, RenderOptions};
use madenet_sim::Trial;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
    /// Include the per-step trajectory in the JSON output.
    #[arg(long, requires = "json")]
    trajectory: bool,
    #[command(flatten)]
    pictures: PictureArgs,
}

/// Pictures of a trial (`run`, `launch` and `world`).
#[derive(Args, Debug, Clone)]
pub struct PictureArgs {
    /// Write an animated GIF of the trial.
    #[arg(long, value_name = "GIF")]
    pub render: Option<PathBuf>,
    /// Write a PNG of the final state.
    #[arg(long, value_name = "PNG")]
    pub snapshot: Option<PathBuf>,
    /// Pixels per cell in pictures.
    #[arg(long, default_value_t = 16)]
    pub cell_px: u32,
    /// GIF frame delay in milliseconds.
    #[arg(long, default_value_t = 150)]
    pub delay_ms: u32,
}

impl PictureArgs {
    /// Whether any picture is asked for.
    pub fn any(&self) -> bool {
        self.render.is_some() || self.snapshot.is_some()
    }

    /// The flags as given, for a child process.
    pub fn to_args(&self) -> Vec<String> {
        let mut v = Vec::new();
        if let Some(p) = &self.render {
            v.extend(["--render".into(), p.display().to_string()]);
        }
        if let Some(p) = &self.snapshot {
            v.extend(["--snapshot".into(), p.display().to_string()]);
        }
        v.extend([
            "--cell-px".into(),
            self.cell_px.to_string(),
            "--delay-ms".into(),
            self.delay_ms.to_string(),
        ]);
        v
    }

    /// Checks the flags against a `width × height` map, before anything runs.
    pub fn check(&self, width: usize, height: usize) -> Result<()> {
        check_extension(self.render.as_deref(), "--render", "gif")?;
        check_extension(self.snapshot.as_deref(), "--snapshot", "png")?;
        if self.any() {
            madenet_render::check_size(width, height, &self.options())
                .map_err(anyhow::Error::msg)
                .context("--cell-px")?;
        }
        Ok(())
    }

    fn options(&self) -> RenderOptions {
        RenderOptions {
            cell_px: self.cell_px,
            ..Default::default()
        }
    }

    /// Starts the pictures: the GIF's first frame is `first`.
    pub fn start(&self, first: &Frame) -> Result<Pictures<'_>> {
        let mut gif = match &self.render {
            Some(p) => Some(GifWriter::new(p, &self.options(), self.delay_ms)?),
            None => None,
        };
        if let Some(g) = gif.as_mut() {
            g.push(first)?;
        }
        Ok(Pictures { args: self, gif })
    }
}

/// Pictures being written: one GIF frame per timestep, the PNG of the last.
pub struct Pictures<'a> {
    args: &'a PictureArgs,
    gif: Option<GifWriter>,
}

impl Pictures<'_> {
    /// Whether frames are wanted for every timestep (a GIF).
    pub fn every_step(&self) -> bool {
        self.gif.is_some()
    }

    /// Adds a timestep's frame to the GIF.
    pub fn push(&mut self, frame: &Frame) -> Result<()> {
        if let Some(g) = self.gif.as_mut() {
            g.push(frame)?;
        }
        Ok(())
    }

    /// Writes the PNG of `last` and finishes the GIF; the lines to print about them.
    pub fn finish(self, last: &Frame) -> Result<Vec<String>> {
        let mut lines = Vec::new();
        if let Some(g) = self.gif {
            let frames = g.frames();
            let bytes = g.finish()?;
            let p = self.args.render.as_ref().expect("a GIF was asked for");
            lines.push(format!(
                "wrote      {} ({frames} frames, {:.1} kB)",
                p.display(),
                bytes as f64 / 1e3
            ));
        }
        if let Some(p) = &self.args.snapshot {
            madenet_render::save_png(last, &self.args.options(), p)?;
            lines.push(format!("wrote      {}", p.display()));
        }
        Ok(lines)
    }
}

/// Refuses an output file whose extension names another picture format than the one written
/// (`x.png` for the GIF, say); a path without an extension (`/dev/stdout`) is taken as is.
pub fn check_extension(path: Option<&std::path::Path>, flag: &str, want: &str) -> Result<()> {
    let Some(ext) = path.and_then(|p| p.extension()) else {
        return Ok(());
    };
    let ext = ext.to_string_lossy().to_ascii_lowercase();
    if ext != want {
        anyhow::bail!(
            "{flag}: writes a {} file, but {} ends in .{ext}: name it *.{want}",
            want.to_uppercase(),
            path.expect("has an extension").display()
        );
    }
    Ok(())
}

pub fn run(a: RunArgs) -> Result<()> {
    let (spec, registry) = a.scenario.spec()?;
    a.pictures.check(spec.map.width(), spec.map.height())?;
    let mut trial = Trial::with_registry(spec, &registry)
        .with_context(|| a.scenario.label())?
        .record_trajectory(a.trajectory);
    let mut pictures = None;
    if a.pictures.any() {
        pictures = Some(a.pictures.start(&madenet_render::trial_frame(&trial))?);
    }
    while trial.step() {
        if let Some(p) = pictures.as_mut().filter(|p| p.every_step()) {
            p.push(&madenet_render::trial_frame(&trial))?;
        }
    }
    let wrote = match pictures {
        Some(p) => p.finish(&madenet_render::trial_frame(&trial))?,
        None => Vec::new(),
    };
    let result = trial.finish();
    if a.json {
        out!("{}", serde_json::to_string_pretty(&result)?)?;
    } else {
        print_summary(&result, &a.scenario.start.name())?;
        for line in wrote {
            out!("{line}")?;
        }
    }
    Ok(())
}

/// The text summary of a trial's result (what `run` prints without `--json`).
pub fn print_summary(result: &madenet_sim::TrialResult, start: &str) -> Result<()> {
    let m = &result.metrics;
    out!(
        "map {}  start {start}  policy {}  csp {}  seed {}",
        result.map,
        result.policy,
        result.comm_success_prob,
        result.seed
    )?;
    out!("completed  {}", m.completed)?;
    out!("TNS        {} steps", m.tns)?;
    out!("TTD        {:.2} m", m.ttd)?;
    out!("NOLI       {}", m.noli)?;
    out!("OFV        {:.3}", m.ofv)?;
    out!("explored   {:.1} %", 100.0 * m.explored)?;
    out!(
        "CT         {:.3} ms per trial, {:.1} µs per decision ({} decisions)",
        1e3 * result.timing.trial_s,
        1e6 * result.timing.per_decision_s,
        result.timing.decisions
    )?;
    Ok(())
}
