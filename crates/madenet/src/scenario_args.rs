//! The flags that name one trial (map, start, policy, CSP, seed, config): shared by `run` and by
//! every node of a decentralized run (`world`, `radio`, `agent`, `launch`), so all of them build
//! the same trial from the same words. And the flags trial sets (`batch`, `oracle`) and
//! studies (`compare`, `scale`) share, and the pictures of a trial.

use anyhow::{Context, Result};
use clap::Args;
use madenet_render::{Pictures, RenderOptions};
use madenet_sim::continuous::ContinuousSpec;
use madenet_sim::{MapSource, PolicyRegistry, StartSpec, TrialSpec};
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct ScenarioArgs {
    /// Map: a file (ROS YAML, PGM, PNG, or text grid), `paper:N` (N = 1..10), `generate:SEED`, `generate-wide:SEED` (15–60 % obstacles) or `floorplan:SEED` (rooms and corridors).
    #[arg(long, default_value = "paper:1", conflicts_with = "generate")]
    pub map: MapSource,
    /// Use a generated map with this seed (same as `--map generate:SEED`).
    #[arg(long, value_name = "SEED")]
    pub generate: Option<u64>,
    /// Start: top-left, top-right, bottom-left, bottom-right, `random` (drawn from the map), or cells `r,c;r,c;r,c`.
    #[arg(long, default_value = "top-left")]
    pub start: StartSpec,
    /// Policy name (see `madenet policies`).
    #[arg(long, default_value = "nf")]
    pub policy: String,
    /// A trained model directory (`madenet train`'s `best/` or `last/`), usable as `--policy model`.
    #[arg(long, value_name = "DIR")]
    pub model: Option<PathBuf>,
    /// Communication success probability (overrides the config).
    #[arg(long)]
    pub csp: Option<f64>,
    /// Trial seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Scenario config (TOML); defaults are the paper's values.
    #[arg(long)]
    pub config: Option<PathBuf>,
}

impl ScenarioArgs {
    /// The flags as command-line words (for starting the nodes of a run with the same trial).
    pub fn to_args(&self) -> Vec<String> {
        let mut v = vec![
            "--map".to_string(),
            self.source().to_string(),
            "--start".into(),
            self.start.name(),
            "--policy".into(),
            self.policy.clone(),
            "--seed".into(),
            self.seed.to_string(),
        ];
        if let Some(m) = &self.model {
            v.extend(["--model".into(), m.display().to_string()]);
        }
        if let Some(csp) = self.csp {
            // `--csp=V`, not `--csp V`: a child reads "-0" (from −0.0) as a flag; `+ 0.0`
            // writes −0.0 as 0.
            v.push(format!("--csp={}", csp + 0.0));
        }
        if let Some(c) = &self.config {
            v.extend(["--config".into(), c.display().to_string()]);
        }
        v
    }

    fn source(&self) -> MapSource {
        self.generate
            .map(MapSource::Generated)
            .unwrap_or_else(|| self.map.clone())
    }

    /// The trial these flags name, checked (each problem named by its flag), with the policies
    /// it may use.
    pub fn spec(&self) -> Result<(TrialSpec, PolicyRegistry)> {
        let cfg = self.checked_config()?;
        let source = self.source();
        let map = source.load(&cfg)?;
        let starts = self.starts_on(&map, &cfg)?;
        let registry = madenet_catalogue::with_model(&Default::default(), self.model.as_deref())?;
        let spec = TrialSpec {
            starts,
            map_name: source.name(),
            map,
            config: cfg,
            policy: self.policy.clone(),
            seed: self.seed,
        };
        Ok((spec, registry))
    }

    /// The continuous trial these flags name (`run --world continuous`): the map's true
    /// geometry ([`MapSource::scene`]; generated worlds are `side` metres square), the starts
    /// read on its cells, `continuous` for the world's own parameters.
    pub fn continuous_spec(
        &self,
        side: f64,
        continuous: madenet_continuous::ContinuousConfig,
    ) -> Result<(ContinuousSpec, PolicyRegistry)> {
        let cfg = self.checked_config()?;
        continuous.validate().context("--continuous-config")?;
        if !(side.is_finite() && (4.0..=1000.0).contains(&side)) {
            anyhow::bail!("--side: a generated world is 4 to 1000 m square, got {side}");
        }
        let source = self.source();
        let scene = source.scene(side)?;
        let starts = self
            .start
            .continuous_cells(&scene, &cfg, continuous.robot.radius);
        self.check_drawn(&starts, &cfg)?;
        let registry = madenet_catalogue::with_model(&Default::default(), self.model.as_deref())?;
        let spec = ContinuousSpec {
            scene: std::sync::Arc::new(scene),
            starts,
            config: cfg,
            continuous,
            policy: self.policy.clone(),
            seed: self.seed,
        };
        Ok((spec, registry))
    }

    /// The scenario config (`--config`, `--csp`), checked with `--model` and `--start`.
    fn checked_config(&self) -> Result<madenet_world::ScenarioConfig> {
        let mut cfg =
            madenet_world::ScenarioConfig::from_toml_file_or_default(self.config.as_deref())?;
        if let Some(csp) = self.csp {
            cfg.comm_success_prob = csp;
            cfg.validate().context("--csp")?;
        }
        if self.model.is_some() && self.policy != "model" {
            anyhow::bail!(
                "--model is used only with --policy model (got --policy {})",
                self.policy
            );
        }
        self.start
            .check_team(cfg.num_robots)
            .map_err(anyhow::Error::msg)
            .context("--start")?;
        Ok(cfg)
    }

    /// The start cells of `--start` on `map`.
    fn starts_on(
        &self,
        map: &madenet_map::OccGrid,
        cfg: &madenet_world::ScenarioConfig,
    ) -> Result<Vec<madenet_map::Pos>> {
        let starts = self.start.cells(map, cfg.num_robots, cfg.movement);
        self.check_drawn(&starts, cfg)?;
        Ok(starts)
    }

    /// Refuses an empty draw of `--start random`.
    fn check_drawn(
        &self,
        starts: &[madenet_map::Pos],
        cfg: &madenet_world::ScenarioConfig,
    ) -> Result<()> {
        if starts.is_empty() {
            anyhow::bail!(
                "--start random: map {} has no {} connected free cells around the cell drawn from it",
                self.source().name(),
                cfg.num_robots
            );
        }
        Ok(())
    }

    /// Prints a warning when the map file's discretization into `cfg`'s cells erased most of
    /// its obstacles ([`MapSource::erasure_warning`]).
    pub fn warn_erasure(&self, cfg: &madenet_world::ScenarioConfig) -> Result<()> {
        if let Some(w) = self.source().erasure_warning(cfg)? {
            say!("warning: {w}");
        }
        Ok(())
    }

    /// A label for messages: map and start.
    pub fn label(&self) -> String {
        format!("map {}, start {}", self.source().name(), self.start.name())
    }
}

/// Seeds, config and threads of a trial set (`batch`, `oracle`).
#[derive(Args, Debug)]
pub struct TrialSetArgs {
    /// Seeds per (map, start, CSP): `seed-base`, `seed-base + 1`, …
    #[arg(long, default_value_t = 1)]
    pub seeds: u64,
    #[arg(long, default_value_t = 1)]
    pub seed_base: u64,
    /// Scenario config (TOML).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = crate::threads_arg)]
    pub threads: Option<usize>,
}

/// How a study runs (`compare`, `scale`).
#[derive(Args, Debug)]
pub struct StudyRunArgs {
    /// Discard earlier results in the output folder.
    #[arg(long)]
    pub fresh: bool,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = crate::threads_arg)]
    pub threads: Option<usize>,
    /// Record the trials these conditions choose as ROS 2 bags in OUT/bags/ (after the
    /// study, re-run with their seeds: the same trials): `field=value` over method, map,
    /// start, csp, seed as trials.csv writes them, all met; `a|b` for either (quoted); e.g.
    /// `--record-trials method=spread seed=1`. A bag already there is kept, as the study
    /// keeps its rows (with --fresh: OUT/bags is made anew, replacing the old once every
    /// chosen trial is recorded).
    #[arg(long, num_args = 1.., value_name = "FIELD=VALUE")]
    pub record_trials: Option<Vec<String>>,
}

impl StudyRunArgs {
    /// Runs `study(fresh, progress)` on `--threads` workers with a progress bar; gives its
    /// result and the workers (to record chosen trials on, after).
    pub fn run<T: Send>(
        &self,
        study: impl FnOnce(bool, &(dyn Fn(usize, usize) + Sync)) -> T + Send,
    ) -> Result<(T, rayon::ThreadPool)> {
        let (bar, pool) = madenet_study::progress::trials_bar_and_pool(0, self.threads)?;
        let counted = std::sync::atomic::AtomicBool::new(false);
        let result = pool.install(|| {
            study(self.fresh, &|done, total| {
                bar.set_length(total as u64);
                bar.set_position(done as u64);
                // A resumed study's earlier trials are not this run's rate.
                if !counted.swap(true, std::sync::atomic::Ordering::Relaxed) {
                    bar.reset_eta();
                }
            })
        });
        bar.finish_and_clear();
        Ok((result, pool))
    }

    /// After the study, while its folder `out` is still held: records the trials
    /// `--record-trials` chose among `planned` by `registry`'s policies
    /// ([`crate::record::record_study_trials`]), or with `--fresh` and none chosen, discards
    /// the bags of earlier runs.
    pub fn record(
        &self,
        planned: Option<(&[madenet_study::runner::Planned], &PolicyRegistry)>,
        out: &std::path::Path,
        pool: &rayon::ThreadPool,
    ) -> Result<()> {
        match (&self.record_trials, planned) {
            (Some(items), Some((planned, registry))) => {
                let chosen = madenet_ros2::study_bags::chosen_trials(items, planned)?;
                crate::record::record_study_trials(&chosen, registry, out, self.fresh, pool)
            }
            _ if self.fresh => Ok(madenet_ros2::study_bags::discard_bags(out)?),
            _ => Ok(()),
        }
    }
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
    /// Pixels per cell in pictures (1–256).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=madenet_render::MAX_CELL_PX as i64))]
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
        self.check_names()?;
        if self.any() {
            madenet_render::check_size(width, height, &self.options())
                .map_err(anyhow::Error::msg)
                .context("--cell-px")?;
        }
        Ok(())
    }

    /// Checks the files' extensions (`.gif`, `.png`).
    pub fn check_names(&self) -> Result<()> {
        let named = [
            (&self.render, "--render", "gif"),
            (&self.snapshot, "--snapshot", "png"),
        ];
        for (path, flag, want) in named {
            madenet_files::check_extension(path.as_deref(), flag, want)
                .map_err(anyhow::Error::msg)?;
        }
        Ok(())
    }

    fn options(&self) -> RenderOptions {
        RenderOptions {
            cell_px: self.cell_px,
            ..Default::default()
        }
    }

    /// The pictures asked for as a sink of the run loop (`None`: none), a GIF frame every
    /// `frame_s` simulated seconds.
    pub fn sink(&self, frame_s: f64) -> Result<Option<Pictures>> {
        if !self.any() {
            return Ok(None);
        }
        Ok(Some(Pictures::new(
            self.render.clone(),
            self.snapshot.clone(),
            self.cell_px,
            self.delay_ms,
            frame_s,
        )?))
    }
}
