//! `madenet run`: one trial.

use anyhow::{Context, Result};
use clap::Args;
use madenet_render::{GifWriter, RenderOptions};
use madenet_sim::{MapSource, StartSpec, Trial, TrialSpec};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct RunArgs {
    /// Map: a file (ROS YAML, PGM, PNG, or text grid), `paper:N` (N = 1..10), `generate:SEED` or `generate-wide:SEED` (15–60 % obstacles).
    #[arg(long, default_value = "paper:1", conflicts_with = "generate")]
    map: MapSource,
    /// Use a generated map with this seed (same as `--map generate:SEED`).
    #[arg(long, value_name = "SEED")]
    generate: Option<u64>,
    /// Start: top-left, top-right, bottom-left, bottom-right, `random` (drawn from the map), or cells `r,c;r,c;r,c`.
    #[arg(long, default_value = "top-left")]
    start: StartSpec,
    /// Policy name (see `madenet policies`).
    #[arg(long, default_value = "nf")]
    policy: String,
    /// A trained model directory (`madenet train`'s `best/` or `last/`), usable as `--policy model`.
    #[arg(long, value_name = "DIR")]
    model: Option<std::path::PathBuf>,
    /// Communication success probability (overrides the config).
    #[arg(long)]
    csp: Option<f64>,
    /// Trial seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Scenario config (TOML); defaults are the paper's values.
    #[arg(long)]
    config: Option<PathBuf>,
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
fn check_extension(path: Option<&std::path::Path>, flag: &str, want: &str) -> Result<()> {
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
    let mut cfg = crate::load_config(a.config.as_deref())?;
    if let Some(csp) = a.csp {
        cfg.comm_success_prob = csp;
        cfg.validate().context("--csp")?;
    }
    if a.model.is_some() && a.policy != "model" {
        anyhow::bail!(
            "--model is used only with --policy model (got --policy {})",
            a.policy
        );
    }
    a.start
        .check_team(cfg.num_robots)
        .map_err(anyhow::Error::msg)
        .context("--start")?;
    check_extension(a.render.as_deref(), "--render", "gif")?;
    check_extension(a.snapshot.as_deref(), "--snapshot", "png")?;
    let source = a.generate.map(MapSource::Generated).unwrap_or(a.map);
    let map = source.load(&cfg)?;
    let starts = a.start.cells(&map, cfg.num_robots, cfg.movement);
    if starts.is_empty() {
        anyhow::bail!(
            "--start random: map {} has no {} connected free cells around the cell drawn from it",
            source.name(),
            cfg.num_robots
        );
    }
    let opts = RenderOptions {
        cell_px: a.cell_px,
        ..Default::default()
    };
    if a.render.is_some() || a.snapshot.is_some() {
        madenet_render::check_size(map.width(), map.height(), &opts)
            .map_err(anyhow::Error::msg)
            .context("--cell-px")?;
    }
    let spec = TrialSpec {
        starts,
        map_name: source.name(),
        map,
        config: cfg,
        policy: a.policy.clone(),
        seed: a.seed,
    };
    let mut trial = Trial::with_registry(spec, &crate::registry(a.model.as_deref())?)
        .with_context(|| format!("map {}, start {}", source.name(), a.start.name()))?
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
        let m = &result.metrics;
        out!(
            "map {}  start {}  policy {}  csp {}  seed {}",
            result.map,
            a.start.name(),
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
