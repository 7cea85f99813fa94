//! `madenet run`: one trial.

use crate::scenario_args::{PictureArgs, ScenarioArgs};
use anyhow::{Context, Result};
use clap::Args;
use madenet_continuous::ContinuousConfig;
use madenet_render::Drawn;
use madenet_runtime::signals::{Interrupted, OnSignal, Stop};
use madenet_sim::continuous::{ContinuousResult, ContinuousTrial};
use madenet_sim::stepping::{Pace, Sink, Stepping};
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
    /// The world: `grid` (the paper's 1 m cells in lockstep timesteps) or `continuous`
    /// (differential-drive robots, a lidar, each robot's own occupancy grid, a local planner,
    /// time in seconds; the map file at its native resolution).
    #[arg(long, default_value = "grid", value_parser = ["grid", "continuous"])]
    world: String,
    /// Side in metres of a generated continuous world (`--world continuous --generate SEED`).
    #[arg(long, default_value_t = 20.0)]
    side: f64,
    /// The continuous world's parameters (TOML: robot, lidar, mapping, planner, …; defaults
    /// documented in `madenet_continuous::ContinuousConfig`).
    #[arg(long, value_name = "TOML")]
    continuous_config: Option<PathBuf>,
    /// Simulated seconds per GIF frame of a continuous run.
    #[arg(long, default_value_t = 1.0)]
    frame_s: f64,
    /// Record the trial as a ROS 2 bag: a rosbag2 folder (metadata.yaml and one MCAP file) at
    /// this new path (or empty folder), in simulated time — maps, poses, goals, plans, /tf,
    /// /clock (the continuous world: scans and fine maps too).
    #[arg(long, value_name = "DIR")]
    record: Option<PathBuf>,
    /// Stream the trial live to Foxglove over its WebSocket protocol (the bag's topics and
    /// encodings) at HOST:PORT (default 127.0.0.1:8765; port 0 picks a free one): open it in
    /// Foxglove with "Open connection" → Foxglove WebSocket. Pace the run to watch it.
    #[arg(long, value_name = "HOST:PORT", num_args = 0..=1, default_missing_value = "127.0.0.1:8765")]
    foxglove: Option<String>,
    /// Wait this many milliseconds after each timestep (a control period in the continuous
    /// world) to watch a run live; 0–60000.
    #[arg(long, value_name = "MS", value_parser = pace_arg, conflicts_with = "realtime")]
    pace_ms: Option<u64>,
    /// Run at about FACTOR × real time (a grid timestep is one simulated second; the
    /// continuous world's control period its own length): 0.02–1000.
    #[arg(long, value_name = "FACTOR", value_parser = realtime_arg)]
    realtime: Option<f64>,
    /// Serve the continuous world's robots as nav2 robots over ROS 2 (rmw_zenoh) through this
    /// zenoh endpoint (bare `--nav2`: the router, tcp/127.0.0.1:7447): each robot in
    /// `/robot<i>` takes goals on `navigate_to_pose` and publishes map, map_updates, scan,
    /// odom, TF (`/robot<i>/tf`) and /clock. No policy runs; it goes at `--realtime` (default
    /// 1; `--pace-ms 0`: as fast as it runs, follow /clock) until Ctrl-C, then prints its goals.
    #[arg(long, value_name = "ENDPOINT", num_args = 0..=1, default_missing_value = "tcp/127.0.0.1:7447")]
    nav2: Option<String>,
    /// With `--nav2`: also run one `madenet explore` process per robot with this policy
    /// (bare `--explore`: explore-lite; or any of `madenet policies`), this run hosting the
    /// zenoh router at the `--nav2` endpoint; the run ends when every node has exited.
    #[arg(long, value_name = "POLICY", num_args = 0..=1, default_missing_value = "explore-lite", requires = "nav2")]
    explore: Option<String>,
    /// With `--explore`: the nodes' parameter files (explore_lite's format), before the one
    /// the run adds (the sim's topics, /clock, the policy, teammates). Repeatable.
    #[arg(long, value_name = "FILE", requires = "explore")]
    params_file: Vec<PathBuf>,
    /// With `--explore`: give the nodes no teammates — each explores on its own map, as
    /// explore_lite's users run it today.
    #[arg(long, requires = "explore")]
    alone: bool,
}

/// `--pace-ms`: 0–60 000 ms.
fn pace_arg(s: &str) -> Result<u64, String> {
    match s.parse::<u64>() {
        Ok(ms) if ms <= 60_000 => Ok(ms),
        _ => Err(format!(
            "`{s}`: must be a whole number of milliseconds in 0..=60000"
        )),
    }
}

/// `--realtime`: a factor in 0.02–1000 (at most 50 s a grid timestep, as `--pace-ms`'s 60 s).
fn realtime_arg(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(f) if (0.02..=1000.0).contains(&f) => Ok(f),
        _ => Err(format!("`{s}`: must be a number in 0.02..=1000")),
    }
}

impl RunArgs {
    /// The pace asked for by `--pace-ms` or `--realtime`, if any.
    fn pace(&self) -> Option<Pace> {
        match (self.pace_ms, self.realtime) {
            (Some(ms), _) => Some(Pace::Wait(std::time::Duration::from_millis(ms))),
            (None, Some(f)) => Some(Pace::RealTime(f)),
            (None, None) => None,
        }
    }
}

pub fn run(a: RunArgs) -> Result<()> {
    fn named(flag: &'static str, p: &Option<PathBuf>) -> Option<(&'static str, PathBuf)> {
        p.clone().map(|p| (flag, p))
    }
    let outputs: Vec<_> = [
        named("--render", &a.pictures.render),
        named("--snapshot", &a.pictures.snapshot),
        named("--record", &a.record),
    ]
    .into_iter()
    .flatten()
    .collect();
    let mut inputs = crate::clashes::map_inputs("--map", &a.scenario.map);
    inputs.extend(named("--config", &a.scenario.config));
    inputs.extend(named("--continuous-config", &a.continuous_config));
    inputs.extend(a.params_file.iter().map(|p| ("--params-file", p.clone())));
    crate::clashes::refuse_clashes(&outputs, &inputs)?;
    if a.nav2.is_some()
        && (a.world != "continuous" || (a.json && a.explore.is_none()) || a.pictures.any())
    {
        anyhow::bail!(
            "--nav2: only with --world continuous, and without --render/--snapshot (--json only with --explore)"
        );
    }
    if a.world == "continuous" {
        return run_continuous(a);
    }
    let (spec, registry) = a.scenario.spec()?;
    a.scenario.warn_erasure(&spec.config)?;
    a.pictures.check(spec.map.width(), spec.map.height())?;
    let trial = Trial::with_registry(spec, &registry)
        .with_context(|| a.scenario.label())?
        .record_trajectory(a.trajectory);
    drive(&a, trial, 1.0, madenet_sim::TrialResult::summary)
}

/// Runs `trial` to its end through the run loop with the sinks asked for — pictures (a GIF
/// frame every `frame_s` simulated seconds), the bag and live view, pacing, Ctrl-C — and
/// prints its outcome (as JSON, or its `summary` and the lines about what was written);
/// interrupted, it prints those lines and ends with [`Interrupted`].
fn drive<S: Stepping + Drawn>(
    a: &RunArgs,
    mut trial: S,
    frame_s: f64,
    summary: impl Fn(&S::Outcome, &str) -> Vec<String>,
) -> Result<()>
where
    S::Outcome: serde::Serialize,
{
    let mut pace = a.pace();
    // Before the live view prints its address: a viewer's Ctrl-C from then on is caught. With
    // pictures too: Ctrl-C finishes them up to there (no temporary file left behind).
    let outputs = a.record.is_some() || a.foxglove.is_some() || a.pictures.any();
    let stop = Stop::watch(outputs || pace.is_some())?;
    // The bag first: a refused --record leaves no picture behind either.
    let mut recorder = crate::record::start(a.record.as_deref(), a.foxglove.as_deref(), &trial)?;
    let mut pictures = a.pictures.sink(frame_s)?;
    let mut interrupt = OnSignal::new(&stop);
    let mut sinks: Vec<&mut dyn Sink<S>> = Vec::new();
    if let Some(p) = pictures.as_mut() {
        sinks.push(p);
    }
    if let Some(r) = recorder.as_mut() {
        sinks.push(r);
    }
    if let Some(p) = pace.as_mut() {
        sinks.push(p);
    }
    sinks.push(&mut interrupt);
    let end =
        madenet_sim::stepping::run(&mut trial, &mut sinks).map_err(anyhow::Error::from_boxed)?;
    if let (Some((_, at)), Some(signal)) = (end.stopped, interrupt.signal) {
        for line in end.wrote {
            out!("{line}")?;
        }
        let finished = true;
        return Err(Interrupted {
            at,
            signal,
            finished,
        }
        .into());
    }
    let result = trial.finish();
    if a.json {
        out!("{}", serde_json::to_string_pretty(&result)?)?;
        return Ok(());
    }
    for line in summary(&result, &a.scenario.start.name())
        .into_iter()
        .chain(end.wrote)
    {
        out!("{line}")?;
    }
    Ok(())
}

/// `run --world continuous`: one trial in the continuous world.
fn run_continuous(a: RunArgs) -> Result<()> {
    if a.trajectory {
        anyhow::bail!("--trajectory: not recorded in the continuous world yet");
    }
    if !(a.frame_s.is_finite() && a.frame_s >= 0.05) {
        anyhow::bail!(
            "--frame-s: at least 0.05 simulated seconds per frame, got {}",
            a.frame_s
        );
    }
    let continuous: ContinuousConfig = match &a.continuous_config {
        Some(p) => madenet_files::read_toml(p)?,
        None => ContinuousConfig::default(),
    };
    a.pictures.check_names()?;
    let (spec, registry) = a.scenario.continuous_spec(a.side, continuous)?;
    a.scenario.warn_erasure(&spec.config)?;
    if let Some(endpoint) = &a.nav2 {
        return serve_nav2(&a, spec.world()?, endpoint);
    }
    let trial = ContinuousTrial::new(spec, &registry).with_context(|| a.scenario.label())?;
    drive(&a, trial, a.frame_s, ContinuousResult::summary)
}

/// `run --world continuous --nav2`: the robots as nav2 robots ([`madenet_ros2::nav2_sim`])
/// through the run loop (bag and live view of the ground truth, pacing), until Ctrl-C.
fn serve_nav2(
    a: &RunArgs,
    world: madenet_continuous::ContinuousWorld,
    endpoint: &str,
) -> Result<()> {
    use madenet_ros2::nav2_sim::{Nav2SimOptions, Nav2Team};
    // With --explore this run is the graph's router (the nodes and the sim connect to it).
    let _router = match &a.explore {
        Some(_) => Some(madenet_ros2::router(endpoint).context("--nav2")?),
        None => None,
    };
    let opts = madenet_ros2::Ros2Options {
        connect: vec![endpoint.to_string()],
        ..Default::default()
    };
    let n = world.robots();
    let mut team = Nav2Team::new(&opts, world, &Nav2SimOptions::default()).context("--nav2")?;
    let stop = Stop::watch(true)?;
    let mut recorder = crate::record::start(a.record.as_deref(), a.foxglove.as_deref(), &team)?;
    let mut pace = a.pace().unwrap_or(Pace::RealTime(1.0));
    let mut interrupt = OnSignal::new(&stop);
    let mut nodes = match &a.explore {
        Some(policy) => {
            let exe = std::env::current_exe().context("finding the madenet binary")?;
            let nodes = madenet_explore::launch::TeamNodes::spawn(
                &exe,
                endpoint,
                n,
                policy,
                !a.alone,
                &a.params_file,
            )
            .context("--explore: starting the exploration nodes")?;
            Some(nodes)
        }
        None => None,
    };
    let mut sinks: Vec<&mut dyn Sink<Nav2Team>> = vec![&mut pace, &mut interrupt];
    if let Some(r) = recorder.as_mut() {
        sinks.insert(0, r);
    }
    if let Some(nodes) = nodes.as_mut() {
        sinks.push(nodes);
    }
    say!(
        "nav2       {n} robots, /robot0 … /robot{}: navigate_to_pose via {endpoint} (Ctrl-C ends){}",
        n - 1,
        match &a.explore {
            Some(p) => format!("; an exploration node each ({p})"),
            None => String::new(),
        }
    );
    let end =
        madenet_sim::stepping::run(&mut team, &mut sinks).map_err(anyhow::Error::from_boxed)?;
    let run = team.finish().context("--nav2")?;
    let (node_lines, complete, stopped_at) = match nodes.as_mut() {
        Some(nodes) => {
            nodes.kill();
            let at = nodes.all_exited_at();
            let (lines, complete) = nodes.report();
            (lines, complete, at)
        }
        None => (Vec::new(), false, None),
    };
    if a.json {
        let json = serde_json::json!({
            "robots": n,
            "policy": a.explore,
            "alone": a.alone,
            "simulated_s": run.time,
            "explored": run.explored,
            "covered_99_s": run.covered_at(0.99),
            "nodes_stopped_s": stopped_at,
            "nodes_complete": complete,
            "team_distance_m": run.distance,
            "obstacle_collisions": run.collisions.obstacle,
            "robot_collisions": run.collisions.robot,
            "nodes": node_lines,
        });
        out!("{}", serde_json::to_string_pretty(&json)?)?;
        return Ok(());
    }
    for line in run.summary().into_iter().chain(node_lines).chain(end.wrote) {
        out!("{line}")?;
    }
    Ok(())
}
