//! `madenet run`: one trial.

use crate::scenario_args::ScenarioArgs;
use anyhow::{Context, Result};
use clap::Args;
use madenet_render::{GifWriter, RenderOptions};
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
    /// Write an animated GIF of the trial.
    #[arg(long, value_name = "GIF")]
    render: Option<PathBuf>,
    /// Write a PNG of the final state.
    #[arg(long, value_name = "PNG")]
    snapshot: Option<PathBuf>,
    /// Pixels per cell in pictures.
    #[arg(long, default_value_t = 16)]
    cell_px: u32,
    /// GIF frame delay in milliseconds.
    #[arg(long, default_value_t = 150)]
    delay_ms: u32,
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
    check_extension(a.render.as_deref(), "--render", "gif")?;
    check_extension(a.snapshot.as_deref(), "--snapshot", "png")?;
    let (spec, registry) = a.scenario.spec()?;
    let opts = RenderOptions {
        cell_px: a.cell_px,
        ..Default::default()
    };
    if a.render.is_some() || a.snapshot.is_some() {
        madenet_render::check_size(spec.map.width(), spec.map.height(), &opts)
            .map_err(anyhow::Error::msg)
            .context("--cell-px")?;
    }
    let mut trial = Trial::with_registry(spec, &registry)
        .with_context(|| a.scenario.label())?
        .record_trajectory(a.trajectory);

    let mut gif = match &a.render {
        Some(p) => Some(GifWriter::new(p, &opts, a.delay_ms)?),
        None => None,
    };
    if let Some(g) = gif.as_mut() {
        g.push(&madenet_env::frame(&trial))?;
    }
    while trial.step() {
        if let Some(g) = gif.as_mut() {
            g.push(&madenet_env::frame(&trial))?;
        }
    }
    if let Some(p) = &a.snapshot {
        madenet_render::save_png(&madenet_env::frame(&trial), &opts, p)?;
    }
    let mut gif_summary = None;
    if let Some(g) = gif {
        let frames = g.frames();
        gif_summary = Some((frames, g.finish()?));
    }
    let result = trial.finish();
    if a.json {
        out!("{}", serde_json::to_string_pretty(&result)?)?;
    } else {
        print_summary(&result, &a.scenario.start.name())?;
        if let (Some(p), Some((frames, bytes))) = (&a.render, gif_summary) {
            out!(
                "wrote      {} ({frames} frames, {:.1} kB)",
                p.display(),
                bytes as f64 / 1e3
            )?;
        }
        if let Some(p) = &a.snapshot {
            out!("wrote      {}", p.display())?;
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
