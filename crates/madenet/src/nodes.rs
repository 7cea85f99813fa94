//! `madenet world | radio | agent | launch`: a trial as separate processes over Zenoh
//! (`madenet-runtime`). Each node is started with the same trial flags and builds only its own
//! part (an agent process reads the map flag for the map's size and the start cells only; what
//! it knows of the map comes from its observations and teammates); `launch` starts them all on
//! loopback ports and collects the world's result.

use crate::scenario_args::ScenarioArgs;
use anyhow::{Context, Result};
use clap::Args;
use madenet_render::Pictures;
use madenet_ros2::record::RecorderSink;
use madenet_runtime::launch::{run_nodes, LaunchError, LaunchEvent};
use madenet_runtime::wire::{Node, Shown};
use madenet_runtime::zenoh_bus::{free_port_block, loopback_endpoints};
use madenet_runtime::{LockstepResult, RadioFaults, Timeouts, WorldOutput, ZenohBus};
use madenet_sim::stepping::{Sink, WorldView};
use std::ops::ControlFlow;
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
    /// Take at least this long per timestep, milliseconds (real robots' pace; 0: as fast as the robots answer).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u64).range(0..=60_000), value_name = "MS")]
    pace_ms: u64,
    #[command(flatten)]
    real: RealRobotArgs,
    #[command(flatten)]
    pictures: crate::run::PictureArgs,
    #[command(flatten)]
    watch: WatchArgs,
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
            let taken = p.exists()
                && !(p.is_dir() && std::fs::read_dir(p).is_ok_and(|mut d| d.next().is_none()));
            if taken {
                anyhow::bail!(
                    "--record: {}: already exists (a file, or a folder that is not empty): choose a new name",
                    p.display()
                );
            }
        }
        if let Some(addr) = self.foxglove.as_deref().filter(|a| !a.ends_with(":0")) {
            std::net::TcpListener::bind(addr)
                .map_err(|e| anyhow::anyhow!("--foxglove: {addr}: {e}"))?;
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

/// A world node's last timestep as shown: the world, what each robot showed, the exchanges.
type LastShown = (madenet_world::World, Vec<Shown>, Vec<(usize, usize)>);

pub fn world(a: WorldArgs) -> Result<()> {
    let (spec, _) = a.scenario.spec()?;
    a.pictures.check(spec.map.width(), spec.map.height())?;
    if let Some(endpoint) = &a.real.ros2_robots {
        if a.pictures.any() {
            anyhow::bail!("--render/--snapshot: not with --ros2-robots (no ground truth to draw)");
        }
        if a.watch.any() {
            anyhow::bail!(
                "--record/--foxglove: not with --ros2-robots (record the robots' own topics)"
            );
        }
        return real_world(&a, &spec, endpoint);
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
    let stop = crate::interrupt::Stop::watch(a.watch.any() || a.pace_ms > 0 || a.node.progress)?;
    // The bag, the live view and the pictures: the run loop's sinks, told of each timestep
    // the world node takes (the first, before the first timestep, starts them). The bag and
    // the live view first: a refused --record leaves no picture behind either.
    let mut sinks: Option<(Option<RecorderSink>, Option<Pictures>)> = None;
    let mut failed: Option<anyhow::Error> = None;
    // The last timestep shown (its world cloned: the node's world is gone when it returns),
    // for the sinks' final state.
    let mut last_view: Option<LastShown> = None;
    let mut draw = |w: &madenet_world::World, shown: &[Shown], links: &[(usize, usize)]| {
        if failed.is_some() {
            return;
        }
        let view = WorldView {
            world: w,
            robots: shown.iter().map(Shown::view).collect(),
            exchanges: links,
        };
        let r = match sinks.as_mut() {
            None => crate::record::start(
                a.watch.record.as_deref(),
                a.watch.foxglove.as_deref(),
                &view,
            )
            .and_then(|rec| {
                let mut pics = a.pictures.sink(1.0)?;
                if let Some(p) = pics.as_mut() {
                    Sink::begin(p, &view).map_err(anyhow::Error::from_boxed)?;
                }
                sinks = Some((rec, pics));
                Ok(())
            }),
            Some((rec, pics)) => {
                // The recorder and the pictures never stop a run: their flow is always Continue.
                let mut step = || -> Result<(), madenet_sim::stepping::SinkError> {
                    if let Some(r) = rec.as_mut() {
                        let _ = Sink::step(r, &view)?;
                    }
                    if let Some(p) = pics.as_mut() {
                        let _ = Sink::step(p, &view)?;
                    }
                    Ok(())
                };
                step().map_err(anyhow::Error::from_boxed)
            }
        };
        failed = r.err();
        last_view = Some((w.clone(), shown.to_vec(), links.to_vec()));
    };
    let show: Option<madenet_runtime::ShowFn<'_, madenet_world::World>> =
        (a.pictures.any() || a.watch.any()).then_some(&mut draw);
    let scenario = Some(scenario_of(&spec));
    let interrupted = serve_world(&a, &spec, &stop, |bus, timeouts, on_step| {
        madenet_runtime::run_ground_with(world, bus, timeouts, scenario, show, |w, waiting| {
            on_step(w, waiting)
        })
    })?;
    if let Some(e) = failed {
        return Err(e);
    }
    let mut wrote = Vec::new();
    if let (Some((rec, pics)), Some((w, shown, links))) = (sinks, last_view) {
        let view = WorldView {
            world: &w,
            robots: shown.iter().map(Shown::view).collect(),
            exchanges: &links,
        };
        if let Some(mut p) = pics {
            wrote.extend(Sink::finish(&mut p, &view).map_err(anyhow::Error::from_boxed)?);
        }
        if let Some(mut r) = rec {
            wrote.extend(Sink::finish(&mut r, &view).map_err(anyhow::Error::from_boxed)?);
        }
    }
    for line in wrote {
        // Launched (`--progress`), launch names the files itself.
        if !a.node.progress {
            eprintln!("{line}");
        }
    }
    crate::interrupt::Interrupted::result(interrupted)
}

/// The digest every node's hello is checked by: map, starts and scenario config.
fn scenario_of(spec: &madenet_sim::TrialSpec) -> u64 {
    madenet_runtime::wire::scenario_digest(&spec.map, &spec.starts, &spec.config)
}

/// The world node on real robots' maps and poses (`--ros2-robots`).
fn real_world(a: &WorldArgs, spec: &madenet_sim::TrialSpec, endpoint: &str) -> Result<()> {
    let opts = madenet_ros2::Ros2Options {
        connect: vec![endpoint.to_string()],
        ..Default::default()
    };
    let ctx = opts.context().context("--ros2-robots")?;
    let wait = Duration::from_secs(a.real.step_timeout_s);
    let real = madenet_ros2::RealRobots::new(
        &ctx,
        spec.starts.len(),
        madenet_ros2::MapFrame::of(&spec.map),
        spec.config.clone(),
        wait,
        wait,
    )
    .context("--ros2-robots")?;
    let scenario = Some(scenario_of(spec));
    let stop = crate::interrupt::Stop::watch(a.pace_ms > 0 || a.node.progress)?;
    let stopped = serve_world(a, spec, &stop, |bus, timeouts, on_step| {
        madenet_runtime::run_ground_with(real, bus, timeouts, scenario, None, |g, waiting| {
            on_step(g, waiting)
        })
    })?;
    crate::interrupt::Interrupted::result(stopped)
}

/// Runs a world node (`run` gets the bus, the timeouts and the progress callback) and writes
/// its result; a signal `stop` watches ends the run after its timestep, writes no result and
/// returns where it stopped and the signal.
fn serve_world(
    a: &WorldArgs,
    spec: &madenet_sim::TrialSpec,
    stop: &crate::interrupt::Stop,
    run: impl FnOnce(
        &ZenohBus,
        Timeouts,
        &mut dyn FnMut(&dyn madenet_runtime::Ground, &mut dyn FnMut()) -> ControlFlow<()>,
    ) -> Result<LockstepResult, madenet_runtime::RuntimeError>,
) -> Result<Option<(String, i32)>> {
    let bus = a.node.bus(Node::World, spec.starts.len())?;
    let progress = a.node.progress;
    let pace = Duration::from_millis(a.pace_ms);
    let mut last = std::time::Instant::now();
    let mut interrupted = None;
    let r = run(&bus, a.node.timeouts(), &mut |w, waiting| {
        if progress {
            let explored = w.explored_fraction();
            eprintln!("progress step={} explored={explored:.3}", w.t());
        }
        // The pace in slices, the robots told the world is still there (a pace may be longer
        // than they wait in silence).
        let until = last + pace;
        loop {
            let left = until.saturating_duration_since(std::time::Instant::now());
            if left.is_zero() {
                break;
            }
            std::thread::sleep(left.min(Duration::from_millis(100)));
            waiting();
        }
        last = std::time::Instant::now();
        match stop.requested() {
            Some(signal) => {
                interrupted = Some((format!("timestep {}", w.t()), signal));
                ControlFlow::Break(())
            }
            None => ControlFlow::Continue(()),
        }
    })?;
    bus.close();
    if interrupted.is_some() {
        return Ok(interrupted);
    }
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
        eprintln!(
            "progress done: sent {} messages, {} B",
            sent.messages, sent.bytes
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
                Some(g) => eprintln!("progress step={step} goal={},{}", g.row, g.col),
                None => eprintln!("progress step={step} goal=none"),
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
    real: RealRobotArgs,
    #[command(flatten)]
    pictures: crate::run::PictureArgs,
    #[command(flatten)]
    watch: WatchArgs,
    /// Take at least this long per timestep, milliseconds (to watch a run live; 0–60000).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u64).range(0..=60_000), value_name = "MS")]
    pace_ms: u64,
}

pub fn launch(a: LaunchArgs) -> Result<()> {
    // Check the trial here once (world and every agent built), so a bad flag is one error
    // rather than five.
    let (spec, registry) = a.scenario.spec()?;
    let n = spec.starts.len();
    a.pictures.check(spec.map.width(), spec.map.height())?;
    if a.real.ros2_robots.is_some() && a.pictures.any() {
        anyhow::bail!("--render/--snapshot: not with --ros2-robots (no ground truth to draw)");
    }
    if a.real.ros2_robots.is_some() && a.watch.any() {
        anyhow::bail!(
            "--record/--foxglove: not with --ros2-robots (record the robots' own topics)"
        );
    }
    a.watch.check()?;
    madenet_sim::build(spec, &registry).with_context(|| a.scenario.label())?;
    // Caught from here on, passed on to the world node (which finishes the run); the nodes
    // lead process groups of their own, so a terminal's Ctrl-C does not reach them directly.
    let signals = crate::interrupt::Stop::catch()?;
    if a.port != 0 {
        loopback_endpoints(a.port, n, Node::Robot(n - 1))
            .map_err(anyhow::Error::msg)
            .context("--port")?;
        return launch_on(&a, n, a.port, &signals);
    }
    // Free ports are found by binding and releasing them; another program may take one before
    // the node binds it. Then the node fails to listen, and the run is tried on new ports.
    let mut attempt = 1;
    loop {
        let port = free_port_block(n as u16 + 2).map_err(anyhow::Error::msg)?;
        match launch_on(&a, n, port, &signals) {
            Err(e)
                if attempt < PORT_ATTEMPTS
                    && matches!(
                        e.downcast_ref::<LaunchError>(),
                        Some(LaunchError::PortsTaken { .. })
                    ) =>
            {
                tracing::warn!("{e}: trying again on other ports");
                attempt += 1;
                if let Some(signal) = signals.take() {
                    // Asked to stop between two attempts: nothing written.
                    return Err(crate::interrupt::Interrupted {
                        at: "the start".into(),
                        signal,
                        finished: false,
                    }
                    .into());
                }
            }
            r => return r,
        }
    }
}

/// Runs of `launch --port 0` tried before giving up on ports taken by other programs.
const PORT_ATTEMPTS: usize = 3;

/// One launch on the loopback ports from `port` on.
fn launch_on(a: &LaunchArgs, n: usize, port: u16, signals: &crate::interrupt::Stop) -> Result<()> {
    let run = format!("launch-{}-{port}", std::process::id());
    let dir = tempfile::tempdir().context("a folder for the world's result")?;
    let result_path = dir.path().join("result.json");
    let exe = std::env::current_exe().context("finding the madenet binary")?;
    let common: Vec<String> = a
        .scenario
        .to_args()
        .into_iter()
        .chain([
            "--run".into(),
            run.clone(),
            "--port".into(),
            port.to_string(),
            "--timeout-s".into(),
            a.timeout_s.to_string(),
            "--progress".into(),
        ])
        .collect();
    let nodes: Vec<(Node, Vec<String>)> = madenet_runtime::nodes_of(n)
        .into_iter()
        .map(|node| {
            let mut args: Vec<String> = Vec::new();
            match node {
                Node::World => {
                    args.push("world".into());
                    args.extend(common.iter().cloned());
                    args.push("--out".into());
                    args.push(result_path.display().to_string());
                    args.extend(a.real.to_args());
                    if a.pictures.any() {
                        args.extend(a.pictures.to_args());
                    }
                    if a.trajectory {
                        args.push("--trajectory".into());
                    }
                    args.extend(a.watch.to_args());
                    if a.pace_ms > 0 {
                        args.extend(["--pace-ms".into(), a.pace_ms.to_string()]);
                    }
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
        .collect();

    // A progress line per node; warnings shown as they come (errors end the run and are in
    // its one-line error).
    let bars = indicatif::MultiProgress::new();
    let style =
        indicatif::ProgressStyle::with_template("{prefix:>8} {msg}").expect("a valid template");
    let bar_of: Vec<indicatif::ProgressBar> = nodes
        .iter()
        .map(|(node, _)| {
            bars.add(
                indicatif::ProgressBar::new_spinner()
                    .with_style(style.clone())
                    .with_prefix(node.to_string())
                    .with_message("starting"),
            )
        })
        .collect();
    let bar = |node: Node| &bar_of[nodes.iter().position(|n| n.0 == node).expect("a node")];
    let mut world_at: Option<String> = None;
    let outcome = run_nodes(
        &exe,
        &nodes,
        port,
        &mut |event| match event {
            LaunchEvent::Progress(node, p) => {
                if node == Node::World {
                    // `step=12 explored=0.41`: where an interrupted run stopped.
                    world_at = p.split_whitespace().next().map(|s| s.replace('=', " "));
                }
                bar(node).set_message(p.to_string())
            }
            // The world's own "interrupted at …" is said once more by launch, below.
            LaunchEvent::Said(Node::World, line) if line.starts_with("interrupted") => {}
            LaunchEvent::Said(node, line) if !line.starts_with("error") => {
                if bars.is_hidden() {
                    eprintln!("{node}: {line}");
                } else {
                    bars.println(format!("{node}: {line}")).ok();
                }
            }
            LaunchEvent::Said(..) => {}
            LaunchEvent::Finished(node, ok) => {
                bar(node).finish_with_message(if ok { "done" } else { "failed" })
            }
        },
        &mut || signals.take(),
    );
    bars.clear().ok();
    if let Err(LaunchError::Interrupted {
        signal,
        world_finished,
        world_error,
    }) = outcome
    {
        if let Some(line) = world_error {
            eprintln!("world: {line}");
        }
        // The world node ended the run after its timestep and finished everything it writes
        // (it exits with 128 + the signal only then); otherwise nothing asked for is finished.
        if world_finished {
            let pictures = a.pictures.render.iter().chain(&a.pictures.snapshot);
            for p in pictures {
                out!("wrote      {}", p.display())?;
            }
            if let Some(p) = &a.watch.record {
                out!("wrote      {} (ROS 2 bag)", p.display())?;
            }
        }
        return Err(crate::interrupt::Interrupted {
            at: world_at.unwrap_or_else(|| "the start".into()),
            signal,
            finished: world_finished,
        }
        .into());
    }
    outcome?;
    let json = std::fs::read_to_string(&result_path).context("the world's result")?;
    if a.json {
        out!("{}", json.trim_end())?;
    } else {
        let out: WorldOutput = serde_json::from_str(&json).context("the world's result")?;
        crate::run::print_summary(&out.result, &a.scenario.start.name())?;
        let rt = out.runtime;
        out!(
            "latency    {:.2} ms mean, {:.2} ms longest from a robot's observation to its move ({} moves)",
            1e3 * rt.latency.mean_s,
            1e3 * rt.latency.max_s,
            rt.latency.acted
        )?;
        if rt.absent_robot_steps > 0 {
            out!("absent     {} robot-timesteps", rt.absent_robot_steps)?;
        }
        out!(
            "nodes      {} processes over Zenoh (tcp/127.0.0.1:{port}…)",
            nodes.len()
        )?;
        for p in a.pictures.render.iter().chain(&a.pictures.snapshot) {
            out!("wrote      {}", p.display())?;
        }
        if let Some(p) = &a.watch.record {
            out!("wrote      {} (ROS 2 bag)", p.display())?;
        }
    }
    Ok(())
}
