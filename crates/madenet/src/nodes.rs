//! `madenet world | radio | agent | launch`: a trial as separate processes over Zenoh
//! (`madenet-runtime`). Each node is started with the same trial flags and builds only its own
//! part (an agent process reads the map flag for the map's size and the start cells only; what
//! it knows of the map comes from its observations and teammates); `launch` starts them all on
//! loopback ports and collects the world's result.

use crate::scenario_args::ScenarioArgs;
use anyhow::{Context, Result};
use clap::Args;
use madenet_runtime::launch::{launch_team, LaunchError};
use madenet_runtime::serve::{self, ServeError, Served, Serving, WorldSink};
use madenet_runtime::signals::{Interrupted, Stop};
use madenet_runtime::wire::Node;
use madenet_runtime::zenoh_bus::loopback_endpoints;
use madenet_runtime::{RadioFaults, Timeouts, WorldOutput, ZenohBus};
use std::path::PathBuf;
use std::time::Duration;

/// Longest wait a node accepts (`--timeout-s`), seconds.
const MAX_TIMEOUT_S: u64 = 3600;

fn timeout_arg(s: &str) -> Result<u64, String> {
    let t: u64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    if !(1..=MAX_TIMEOUT_S).contains(&t) {
        return Err(format!("1 to {MAX_TIMEOUT_S} seconds, got {t}"));
    }
    Ok(t)
}

/// Where a node finds the others: the run's name and ports.
#[derive(Args, Debug, Clone)]
pub struct NodeArgs {
    /// Name of the run: part of every key expression (`madenet/<run>/…`), so runs can share a network.
    #[arg(long, default_value = "madenet")]
    run: String,
    /// First of the run's loopback ports: world on PORT, radio on PORT+1, robot i on PORT+2+i.
    #[arg(long)]
    port: u16,
    /// Longest wait for a message before the node gives up, naming what it waited for. While
    /// the world waits this long for an absent robot it tells the others every quarter of it
    /// (≤ 2 s) that it is still there, so they notice a killed world after twice that plus 1 s
    /// (5 s at the default); before its first message they wait twice this plus 1 s.
    #[arg(long, default_value_t = 30, value_parser = timeout_arg, value_name = "SECONDS")]
    timeout_s: u64,
    /// Print `progress …` lines on stderr (what `launch` shows).
    #[arg(long)]
    progress: bool,
}

impl NodeArgs {
    fn bus(&self, node: Node, robots: usize) -> Result<ZenohBus> {
        let ep = loopback_endpoints(self.port, robots, node).map_err(anyhow::Error::msg)?;
        ZenohBus::open(&self.run, node, &ep)
            .map_err(anyhow::Error::msg)
            .context("--run/--port")
    }
    fn timeouts(&self) -> Timeouts {
        Timeouts::new(Duration::from_secs(self.timeout_s))
    }
}

/// `--loss`: a probability.
fn loss_arg(s: &str) -> Result<f64, String> {
    let p: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a probability"))?;
    if !(0.0..=1.0).contains(&p) {
        return Err(format!("a probability in [0, 1], got {s}"));
    }
    Ok(p)
}

/// `--delay`: timesteps, bounded.
fn delay_arg(s: &str) -> Result<u32, String> {
    let d: u32 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of timesteps"))?;
    if d > madenet_runtime::MAX_DELAY_STEPS {
        return Err(format!(
            "at most {} timesteps, got {d}",
            madenet_runtime::MAX_DELAY_STEPS
        ));
    }
    Ok(d)
}

/// Faults the radio injects beyond the paper's model (for fault tests).
#[derive(Args, Debug, Clone, Copy)]
pub struct FaultArgs {
    /// Extra loss: an exchange the paper's model lets through is lost with this probability.
    #[arg(long, default_value_t = 0.0, value_parser = loss_arg, value_name = "P")]
    loss: f64,
    /// Extra delay: β reach teammates this many timesteps late (no plans over late links).
    #[arg(long, default_value_t = 0, value_parser = delay_arg, value_name = "STEPS")]
    delay: u32,
}

#[derive(Args, Debug)]
pub struct WorldArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    #[command(flatten)]
    node: NodeArgs,
    /// Write the result JSON (as `madenet run --json`) here instead of stdout.
    #[arg(long, value_name = "JSON")]
    out: Option<PathBuf>,
    /// Add every timestep's robot positions to the JSON (`positions`).
    #[arg(long)]
    trajectory: bool,
    #[command(flatten)]
    show: ShowArgs,
}

/// What a world node shows and at what pace, and whether its robots are real (`world`, `launch`).
#[derive(Args, Debug, Clone)]
pub struct ShowArgs {
    /// Take at least this long per timestep, milliseconds (to watch a run live, or real robots'
    /// pace; 0–60000, 0: as fast as the robots answer).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u64).range(0..=60_000), value_name = "MS")]
    pace_ms: u64,
    #[command(flatten)]
    real: RealRobotArgs,
    #[command(flatten)]
    pictures: crate::scenario_args::PictureArgs,
    #[command(flatten)]
    watch: WatchArgs,
}

impl ShowArgs {
    /// Checks the flags against the trial's map before anything runs.
    fn check(&self, map: &madenet_map::OccGrid) -> Result<()> {
        self.pictures.check(map.width(), map.height())?;
        self.real
            .refuse_outputs(self.pictures.any(), self.watch.any())
    }

    /// The flags as given, for the world node `launch` starts.
    fn to_args(&self) -> Vec<String> {
        let mut args = self.real.to_args();
        if self.pictures.any() {
            args.extend(self.pictures.to_args());
        }
        args.extend(self.watch.to_args());
        if self.pace_ms > 0 {
            args.extend(["--pace-ms".into(), self.pace_ms.to_string()]);
        }
        args
    }
}

/// A world node's run as ROS 2 messages (cargo feature `ros2`): a bag, a live view.
#[derive(Args, Debug, Clone, Default)]
pub struct WatchArgs {
    /// Record the run as a ROS 2 bag at this new path (or empty folder), as `run --record`
    /// does, without the robots' own maps (they live in the robots' processes).
    #[arg(long, value_name = "DIR")]
    record: Option<PathBuf>,
    /// Stream the run live to Foxglove at HOST:PORT (default 127.0.0.1:8765), as `run
    /// --foxglove` does; pace it (--pace-ms) to watch.
    #[arg(long, value_name = "HOST:PORT", num_args = 0..=1, default_missing_value = "127.0.0.1:8765")]
    foxglove: Option<String>,
}

impl WatchArgs {
    /// Whether a bag or a live view is asked for.
    fn any(&self) -> bool {
        self.record.is_some() || self.foxglove.is_some()
    }

    /// Refuses, before any node starts, a bag place that is taken and a live-view address that
    /// cannot be bound (the world node would fail only once every node runs).
    fn check(&self) -> Result<()> {
        if let Some(p) = &self.record {
            madenet_ros2::bag::Bag::check_place(p).context("--record")?;
        }
        if let Some(addr) = self.foxglove.as_deref().filter(|a| !a.ends_with(":0")) {
            std::net::TcpListener::bind(addr).with_context(|| format!("--foxglove: {addr}"))?;
        }
        Ok(())
    }

    /// The flags as given, for the world node `launch` starts.
    fn to_args(&self) -> Vec<String> {
        let mut v = Vec::new();
        if let Some(p) = &self.record {
            v.extend(["--record".into(), p.display().to_string()]);
        }
        if let Some(addr) = &self.foxglove {
            v.push(format!("--foxglove={addr}"));
        }
        v
    }
}

/// Real robots in place of the simulated world (cargo feature `ros2`).
#[derive(Args, Debug, Clone)]
pub struct RealRobotArgs {
    /// Real robots instead of the simulation: each robot's /robot<i>/map and /robot<i>/pose are
    /// read through this zenoh endpoint and its moves sent as /robot<i>/goal_pose (the map flag
    /// gives the grid's size, cell size and origin only; bare flag: the rmw_zenoh router).
    #[arg(long, num_args = 0..=1, default_missing_value = "tcp/127.0.0.1:7447", value_name = "ENDPOINT")]
    ros2_robots: Option<String>,
    /// With --ros2-robots: longest wait for the robots to reach a timestep's cells (and for their
    /// first map and pose), seconds.
    #[arg(long, default_value_t = 30, value_parser = timeout_arg, value_name = "SECONDS", requires = "ros2_robots")]
    step_timeout_s: u64,
}

impl RealRobotArgs {
    /// Refuses pictures and a bag or live view with real robots: there is no ground truth to
    /// draw, and the robots' own topics are theirs to record.
    fn refuse_outputs(&self, pictures: bool, watch: bool) -> Result<()> {
        if self.ros2_robots.is_some() && pictures {
            anyhow::bail!("--render/--snapshot: not with --ros2-robots (no ground truth to draw)");
        }
        if self.ros2_robots.is_some() && watch {
            anyhow::bail!(
                "--record/--foxglove: not with --ros2-robots (record the robots' own topics)"
            );
        }
        Ok(())
    }

    fn to_args(&self) -> Vec<String> {
        match &self.ros2_robots {
            Some(e) => vec![
                "--ros2-robots".into(),
                e.clone(),
                "--step-timeout-s".into(),
                self.step_timeout_s.to_string(),
            ],
            None => Vec::new(),
        }
    }
}

#[derive(Args, Debug)]
pub struct RadioArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    #[command(flatten)]
    node: NodeArgs,
    #[command(flatten)]
    faults: FaultArgs,
}

#[derive(Args, Debug)]
pub struct AgentArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    #[command(flatten)]
    node: NodeArgs,
    /// Which robot this process is (0-based).
    #[arg(long)]
    robot: usize,
    #[command(flatten)]
    ros2: Ros2Args,
}

/// ROS 2 topics of the robots (cargo feature `ros2`, on by default).
#[derive(Args, Debug, Clone)]
pub struct Ros2Args {
    /// Publish each robot's /robot<i>/map, /robot<i>/pose and /robot<i>/goal_pose in the rmw_zenoh
    /// format through this zenoh endpoint (bare `--ros2`: the rmw_zenoh router, tcp/127.0.0.1:7447).
    #[arg(long, num_args = 0..=1, default_missing_value = "tcp/127.0.0.1:7447", value_name = "ENDPOINT")]
    ros2: Option<String>,
}

impl Ros2Args {
    fn to_args(&self) -> Vec<String> {
        self.ros2
            .iter()
            .flat_map(|e| ["--ros2".to_string(), e.clone()])
            .collect()
    }
}

/// Robot `i`'s ROS 2 publishers, when `--ros2` asked for them.
struct Ros2Out(Option<madenet_ros2::RobotPublisher>);

impl Ros2Out {
    fn open(a: &Ros2Args, i: usize, map: &madenet_map::OccGrid) -> Result<Self> {
        a.ros2
            .as_ref()
            .map(|endpoint| madenet_ros2::RobotPublisher::connect(endpoint, i, map))
            .transpose()
            .context("--ros2")
            .map(Ros2Out)
    }

    fn publish(&mut self, agent: &madenet_agent::Agent) {
        if let Some(p) = &mut self.0 {
            p.publish(agent.belief().map(), agent.pos(), agent.goal());
        }
    }
}

pub fn world(a: WorldArgs) -> Result<()> {
    let (spec, _) = a.scenario.spec()?;
    a.show.check(&spec.map)?;
    let scenario = Some(scenario_of(&spec));
    if let Some(endpoint) = &a.show.real.ros2_robots {
        let opts = madenet_ros2::Ros2Options {
            connect: vec![endpoint.to_string()],
            ..Default::default()
        };
        let ctx = opts.context().context("--ros2-robots")?;
        let wait = Duration::from_secs(a.show.real.step_timeout_s);
        let frame = madenet_ros2::MapFrame::of(&spec.map);
        let (n, config) = (spec.starts.len(), spec.config.clone());
        let real = madenet_ros2::RealRobots::new(&ctx, n, frame, config, wait, wait)
            .context("--ros2-robots")?;
        let stop = Stop::watch(a.show.pace_ms > 0 || a.node.progress)?;
        let stopped = serve_world(&a, &spec, &stop, |bus, t, serving| {
            serve::serve(real, bus, t, scenario, None, serving)
        })?;
        return Ok(Interrupted::result(stopped)?);
    }
    let mut world = madenet_world::World::new(
        spec.map.clone(),
        &spec.starts,
        spec.config.clone(),
        spec.seed,
    )
    .with_context(|| a.scenario.label())?;
    world.detach_radio();
    // Before the live view prints its address: a Ctrl-C from then on ends the run gracefully
    // (launched, always: `launch` passes its first signal on to this node).
    let stop = Stop::watch(a.show.watch.any() || a.show.pace_ms > 0 || a.node.progress)?;
    // The bag and the live view first (a refused --record leaves no picture behind either);
    // the pictures finish first.
    let sinks: serve::StartSinks<'_> = Box::new(|view| {
        let rec = crate::record::start(
            a.show.watch.record.as_deref(),
            a.show.watch.foxglove.as_deref(),
            view,
        )?;
        let pics = a.show.pictures.sink(1.0)?;
        let mut sinks: Vec<WorldSink> = Vec::new();
        sinks.extend(pics.map(|p| Box::new(p) as WorldSink));
        sinks.extend(rec.map(|r| Box::new(r) as WorldSink));
        Ok(sinks)
    });
    let sinks = (a.show.pictures.any() || a.show.watch.any()).then_some(sinks);
    let stopped = serve_world(&a, &spec, &stop, |bus, t, serving| {
        serve::serve(world, bus, t, scenario, sinks, serving)
    })?;
    Ok(Interrupted::result(stopped)?)
}

/// The digest every node's hello is checked by: map, starts and scenario config.
fn scenario_of(spec: &madenet_sim::TrialSpec) -> u64 {
    madenet_runtime::wire::scenario_digest(&spec.map, &spec.starts, &spec.config)
}

/// Serves a world node (`run` gets the bus, the timeouts and how to serve), prints what its
/// outputs wrote and writes its result; a signal `stop` watches ends the run after its
/// timestep, writes no result and returns where it stopped and the signal.
fn serve_world(
    a: &WorldArgs,
    spec: &madenet_sim::TrialSpec,
    stop: &Stop,
    run: impl FnOnce(&ZenohBus, Timeouts, &Serving) -> Result<(Served, Vec<String>), ServeError>,
) -> Result<Option<(String, i32)>> {
    let bus = a.node.bus(Node::World, spec.starts.len())?;
    let serving = Serving {
        pace: Duration::from_millis(a.show.pace_ms),
        progress: a.node.progress,
        stop,
    };
    let served = run(&bus, a.node.timeouts(), &serving);
    bus.close();
    let (served, wrote) = served.map_err(|e| match e {
        ServeError::Node(e) => anyhow::Error::from(e),
        ServeError::Sink(e) => anyhow::Error::from_boxed(e),
    })?;
    for line in wrote {
        // Launched (`--progress`), launch names the files itself.
        if !a.node.progress {
            say!("{line}");
        }
    }
    let r = match served {
        Served::Finished(r) => *r,
        Served::Interrupted(at, signal) => return Ok(Some((at, signal))),
    };
    let out = WorldOutput::new(spec, &a.scenario.policy, r, a.trajectory);
    let json = serde_json::to_string_pretty(&out)?;
    match &a.out {
        Some(p) => madenet_files::write_atomic(p, format!("{json}\n").as_bytes())
            .with_context(|| format!("--out {}", p.display()))?,
        None => out!("{json}")?,
    }
    Ok(None)
}

pub fn radio(a: RadioArgs) -> Result<()> {
    let (spec, _) = a.scenario.spec()?;
    let n = spec.starts.len();
    let radio = madenet_world::Radio::new(&spec.config, n, spec.seed);
    let bus = a.node.bus(Node::Radio, n)?;
    let faults = RadioFaults {
        loss_prob: a.faults.loss,
        delay_steps: a.faults.delay,
        seed: spec.seed,
    };
    let sent = madenet_runtime::run_radio_with(radio, n, &bus, a.node.timeouts(), faults)?;
    bus.close();
    if a.node.progress {
        say!(
            "progress done: sent {} messages, {} B",
            sent.messages,
            sent.bytes
        );
    }
    Ok(())
}

pub fn agent(a: AgentArgs) -> Result<()> {
    let (spec, registry) = a.scenario.spec()?;
    let n = spec.starts.len();
    if a.robot >= n {
        anyhow::bail!("--robot {}: the team has robots 0 to {}", a.robot, n - 1);
    }
    let agent =
        madenet_sim::build_agent(&spec, &registry, a.robot).with_context(|| a.scenario.label())?;
    let mut ros2 = Ros2Out::open(&a.ros2, a.robot, &spec.map)?;
    let bus = a.node.bus(Node::Robot(a.robot), n)?;
    let progress = a.node.progress;
    let scenario = Some(scenario_of(&spec));
    let timeouts = a.node.timeouts();
    madenet_runtime::run_robot_with(agent, &bus, timeouts, scenario, |step, agent, last| {
        ros2.publish(agent);
        if progress && !last {
            match agent.goal() {
                Some(g) => say!("progress step={step} goal={},{}", g.row, g.col),
                None => say!("progress step={step} goal=none"),
            }
        }
    })?;
    bus.close();
    Ok(())
}

#[derive(Args, Debug)]
pub struct LaunchArgs {
    #[command(flatten)]
    scenario: ScenarioArgs,
    /// First loopback port of the run (world, radio, robots on consecutive ports); 0 picks free ones.
    #[arg(long, default_value_t = 0)]
    port: u16,
    /// Longest wait of any node for any message, seconds.
    #[arg(long, default_value_t = 30, value_parser = timeout_arg, value_name = "SECONDS")]
    timeout_s: u64,
    /// Print the result as JSON (as `madenet run --json`).
    #[arg(long)]
    json: bool,
    /// Add every timestep's robot positions to the JSON (`positions`).
    #[arg(long, requires = "json")]
    trajectory: bool,
    #[command(flatten)]
    faults: FaultArgs,
    #[command(flatten)]
    ros2: Ros2Args,
    #[command(flatten)]
    show: ShowArgs,
}

pub fn launch(a: LaunchArgs) -> Result<()> {
    // Check the trial here once (world and every agent built), so a bad flag is one error
    // rather than five.
    let (spec, registry) = a.scenario.spec()?;
    let n = spec.starts.len();
    a.show.check(&spec.map)?;
    a.show.watch.check()?;
    madenet_sim::build(spec, &registry).with_context(|| a.scenario.label())?;
    if a.port != 0 {
        loopback_endpoints(a.port, n, Node::Robot(n - 1))
            .map_err(anyhow::Error::msg)
            .context("--port")?;
    }
    let dir = tempfile::tempdir().context("a folder for the world's result")?;
    let result_path = dir.path().join("result.json");
    let exe = std::env::current_exe().context("finding the madenet binary")?;
    // Caught from here on, passed on to the world node (which finishes the run); the nodes
    // lead process groups of their own, so a terminal's Ctrl-C does not reach them directly.
    let signals = Stop::catch()?;
    let nodes_on = |port| node_args(&a, n, port, &result_path);
    let (outcome, world_at) = launch_team(&exe, a.port, n as u16 + 2, nodes_on, &signals);
    let port = match outcome {
        Ok(port) => port,
        Err(LaunchError::Interrupted {
            signal,
            world_finished,
            world_error,
        }) => {
            if let Some(line) = world_error {
                say!("world: {line}");
            }
            // The world node ended the run after its timestep and finished everything it
            // writes (it exits with 128 + the signal only then); otherwise nothing asked for
            // is finished.
            if world_finished {
                print_written(&a.show.pictures, &a.show.watch)?;
            }
            return Err(Interrupted {
                at: world_at.unwrap_or_else(|| "the start".into()),
                signal,
                finished: world_finished,
            }
            .into());
        }
        Err(e) => return Err(e.into()),
    };
    let json = std::fs::read_to_string(&result_path).context("the world's result")?;
    if a.json {
        out!("{}", json.trim_end())?;
        return Ok(());
    }
    let out: WorldOutput = serde_json::from_str(&json).context("the world's result")?;
    for line in out.summary(&a.scenario.start.name(), n + 2, port) {
        out!("{line}")?;
    }
    print_written(&a.show.pictures, &a.show.watch)
}

/// The lines naming the pictures and the bag a run wrote.
fn print_written(pictures: &crate::scenario_args::PictureArgs, watch: &WatchArgs) -> Result<()> {
    for p in pictures.render.iter().chain(&pictures.snapshot) {
        out!("wrote      {}", p.display())?;
    }
    if let Some(p) = &watch.record {
        out!("wrote      {} (ROS 2 bag)", p.display())?;
    }
    Ok(())
}

/// Each node's arguments for a launch on the loopback ports from `port` on, the world's
/// result written to `result_path`.
fn node_args(
    a: &LaunchArgs,
    n: usize,
    port: u16,
    result_path: &std::path::Path,
) -> Vec<(Node, Vec<String>)> {
    let run = format!("launch-{}-{port}", std::process::id());
    let common: Vec<String> = a
        .scenario
        .to_args()
        .into_iter()
        .chain([
            "--run".into(),
            run,
            "--port".into(),
            port.to_string(),
            "--timeout-s".into(),
            a.timeout_s.to_string(),
            "--progress".into(),
        ])
        .collect();
    madenet_runtime::nodes_of(n)
        .into_iter()
        .map(|node| {
            let mut args: Vec<String> = Vec::new();
            match node {
                Node::World => {
                    args.push("world".into());
                    args.extend(common.iter().cloned());
                    args.push("--out".into());
                    args.push(result_path.display().to_string());
                    if a.trajectory {
                        args.push("--trajectory".into());
                    }
                    args.extend(a.show.to_args());
                }
                Node::Radio => {
                    args.push("radio".into());
                    args.extend(common.iter().cloned());
                    // As `--csp` (ScenarioArgs::to_args): −0.0 must not reach a child as "-0".
                    args.push(format!("--loss={}", a.faults.loss + 0.0));
                    args.push(format!("--delay={}", a.faults.delay));
                }
                Node::Robot(i) => {
                    args.push("agent".into());
                    args.extend(common.iter().cloned());
                    args.extend(["--robot".to_string(), i.to_string()]);
                    args.extend(a.ros2.to_args());
                }
            }
            (node, args)
        })
        .collect()
}
