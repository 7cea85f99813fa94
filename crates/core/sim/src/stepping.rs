//! One stepping contract for every world, and one run loop that reports to sinks.
//!
//! A world's trial — the grid [`crate::Trial`], the continuous
//! [`crate::continuous::ContinuousTrial`], and any later one — implements [`Stepping`]: advance
//! one step, say which robots wait for a decision from outside, take those decisions, say the
//! time, finish with the world's outcome. What outputs read of a run at its present (poses,
//! what each robot shows, maps, the radio, the metrics so far) is [`Present`], which a world
//! node (whose agents live in other processes) implements too.
//!
//! [`run`] drives a [`Stepping`] trial to its end and reports every step to [`Sink`]s, as
//! ripgrep's searcher reports matches to a sink: pictures (`madenet_render`), a bag and a live
//! view (`madenet_ros2`), pacing ([`Pace`]), an interrupt or progress (the command line). A new
//! world is one implementation of [`Stepping`]; a new output is one [`Sink`].
//!
//! ```
//! use madenet_map::paper::{paper_map, Corner};
//! use madenet_sim::stepping::{run, Present, Sink, SinkError};
//! use madenet_sim::{Trial, TrialSpec};
//! use std::ops::ControlFlow;
//!
//! /// Counts the steps and keeps the last explored fraction.
//! #[derive(Default)]
//! struct Count(usize, f64);
//! impl<S: Present> Sink<S> for Count {
//!     fn step(&mut self, sim: &S) -> Result<ControlFlow<String>, SinkError> {
//!         self.0 += 1;
//!         self.1 = sim.explored();
//!         Ok(ControlFlow::Continue(()))
//!     }
//! }
//!
//! let map = paper_map(3).unwrap();
//! let spec = TrialSpec {
//!     starts: Corner::TopLeft.start_cells(map.height(), map.width()).to_vec(),
//!     map,
//!     map_name: "paper_3".into(),
//!     config: Default::default(),
//!     policy: "spread".into(),
//!     seed: 7,
//! };
//! let mut trial = Trial::new(spec.clone()).unwrap();
//! let mut count = Count::default();
//! let end = run(&mut trial, &mut [&mut count]).unwrap();
//! assert!(end.stopped.is_none());
//! let result = madenet_sim::stepping::Stepping::finish(trial);
//! assert_eq!(count.0, result.metrics.tns);
//! // Watching a run does not change it.
//! assert_eq!(Trial::new(spec).unwrap().run().metrics, result.metrics);
//! ```

use madenet_agent::{Agent, Decision};
use madenet_continuous::ContinuousWorld;
/// A robot's pose as [`Present::pose`] gives it (re-exported for worlds that implement
/// [`Present`] without the continuous world's crate).
pub use madenet_continuous::Pose;
use madenet_map::{OccGrid, Occupancy, Pos};
use std::borrow::Cow;
use std::ops::ControlFlow;
use std::time::Duration;

/// What one robot shows of its decisions (goal, route, goal candidates), for outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RobotShown<'a> {
    /// Its goal g_i in force, if any.
    pub goal: Option<Pos>,
    /// Its planned route to the goal (cells).
    pub path: &'a [Pos],
    /// Its goal candidates 𝒢_i at its last decision (Eq. 3).
    pub candidates: &'a [Pos],
    /// The slot of its goal among `candidates`.
    pub chosen: Option<usize>,
    /// What its policy weighed per slot at the decision (learned policies).
    pub scores: Option<&'a [f32]>,
    /// Decisions it has taken so far (changes when it decides).
    pub decisions: u64,
}

impl<'a> RobotShown<'a> {
    /// What `agent` shows.
    pub fn of(agent: &'a Agent) -> Self {
        RobotShown {
            goal: agent.goal(),
            path: agent.path(),
            candidates: &agent.candidates().cells,
            chosen: agent.action(),
            scores: agent.policy_scores(),
            decisions: agent.stats().decisions as u64,
        }
    }
}

/// What outputs read of a run at its present, in every world.
///
/// Positions are metres right of and down from the top-left corner of [`Present::truth`]
/// (image axes; a grid robot stands at its cell's centre, facing +x). Maps are in the agents'
/// cells, row-major.
pub trait Present {
    /// Number of robots.
    fn robots(&self) -> usize;
    /// Simulated seconds since the start (a grid timestep is one second).
    fn time_s(&self) -> f64;
    /// Simulated seconds of one step (a grid timestep: 1; the continuous world: its control
    /// period).
    fn step_s(&self) -> f64;
    /// The true map in the agents' cells.
    fn truth(&self) -> &OccGrid;
    /// Robot `i`'s pose.
    fn pose(&self, i: usize) -> Pose;
    /// Robot `i`'s cell.
    fn cell(&self, i: usize) -> Pos;
    /// What robot `i` shows of its decisions.
    fn robot(&self, i: usize) -> RobotShown<'_>;
    /// Robot `i`'s own map in the agents' cells, if it is known here (`None`: the agent lives
    /// in another process, or the world shows a finer map of its own).
    fn belief(&self, i: usize) -> Option<Cow<'_, [Occupancy]>>;
    /// The team's merged map 𝓜: every cell any robot has read.
    fn team_map(&self) -> Cow<'_, [Occupancy]>;
    /// Pairs `(i, j)`, `i < j`, in contact at the last radio round.
    fn contacts(&self) -> Cow<'_, [(usize, usize)]>;
    /// Of those, the pairs whose exchange succeeded.
    fn exchanges(&self) -> &[(usize, usize)];
    /// The share of the explorable cells the team knows, 0–1.
    fn explored(&self) -> f64;
    /// Metres driven by the team so far (TTD).
    fn distance(&self) -> f64;
    /// The continuous world, where the run is one: its scans, fine maps and scene.
    fn continuous(&self) -> Option<&ContinuousWorld> {
        None
    }
    /// The present in words for messages: `timestep 12` or `12.3 s`.
    fn when(&self) -> String {
        format!("{:.1} s", self.time_s())
    }
}

/// The stepping contract every world implements ([module docs](self)).
pub trait Stepping: Present {
    /// What [`Stepping::finish`] gives: the world's result.
    type Outcome;
    /// Advances one step (a grid timestep, a continuous control period). Returns false once
    /// done. With decisions from outside, a step whose robots wait for them stops at the
    /// decision point ([`Stepping::deciding`]); after [`Stepping::apply_decisions`] the next call
    /// finishes it, and a call while decisions are still awaited does nothing.
    fn step(&mut self) -> bool;
    /// Complete, or at the world's cap.
    fn is_done(&self) -> bool;
    /// Every explorable cell is known.
    fn is_complete(&self) -> bool;
    /// Which robots wait for a decision from outside (one entry per robot).
    fn deciding(&self) -> &[bool];
    /// Gives each waiting robot its decision: `Some(d)` from outside, `None` from its own policy;
    /// robots not waiting are skipped.
    fn apply_decisions(&mut self, decisions: &[Option<Decision>]);
    /// The agents, robot i at index i.
    fn agents(&self) -> &[Agent];
    /// Robot `i`'s agent.
    fn agent_mut(&mut self, i: usize) -> &mut Agent;
    /// The result so far.
    fn finish(self) -> Self::Outcome
    where
        Self: Sized;
}

/// What a sink's failure is (each output has its own error type).
pub type SinkError = Box<dyn std::error::Error + Send + Sync>;

/// An output of a run: told of the present before the first step, after every step and at the
/// end ([`run`]).
pub trait Sink<S: ?Sized> {
    /// Before the first step: the run's start.
    fn begin(&mut self, _sim: &S) -> Result<(), SinkError> {
        Ok(())
    }
    /// After every step. `Break(why)` ends the run early (an interrupt, say: `why` names it).
    fn step(&mut self, sim: &S) -> Result<ControlFlow<String>, SinkError>;
    /// At the end (done or stopped): the final state; the lines to print about what was
    /// written.
    fn finish(&mut self, _sim: &S) -> Result<Vec<String>, SinkError> {
        Ok(Vec::new())
    }
}

/// How a [`run`] ended.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunEnd {
    /// The sinks' lines about what they wrote, in sink order.
    pub wrote: Vec<String>,
    /// Why a sink stopped the run early, and when (`None`: the trial ran to its end).
    pub stopped: Option<(String, String)>,
}

/// One step of a run to its end: robots waiting for a decision from outside take their own
/// policy's, then `sim` steps. False once done.
fn step_on_own<S: Stepping + ?Sized>(sim: &mut S) -> bool {
    if sim.deciding().contains(&true) {
        sim.apply_decisions(&[]);
    }
    sim.step()
}

/// Drives `sim` to its end with no outputs (robots waiting for outside decisions take their
/// own policy's): what [`crate::Trial::run`] and the continuous trial's `run` do.
pub fn run_to_end<S: Stepping + ?Sized>(sim: &mut S) {
    while step_on_own(sim) {}
}

/// Drives `sim` to its end (or until a sink stops it), reporting the start, every step and the
/// end to each of `sinks` in order; robots waiting for outside decisions take their own
/// policy's. The sinks only read: a run with sinks is the run without. On a sink's error the
/// others are not finished (the caller's outputs clean up when dropped).
pub fn run<S: Stepping + ?Sized>(
    sim: &mut S,
    sinks: &mut [&mut dyn Sink<S>],
) -> Result<RunEnd, SinkError> {
    for s in sinks.iter_mut() {
        s.begin(sim)?;
    }
    let mut stopped = None;
    'steps: while step_on_own(sim) {
        for s in sinks.iter_mut() {
            if let ControlFlow::Break(why) = s.step(sim)? {
                stopped = Some((why, sim.when()));
                break 'steps;
            }
        }
    }
    let mut wrote = Vec::new();
    for s in sinks.iter_mut() {
        wrote.extend(s.finish(sim)?);
    }
    Ok(RunEnd { wrote, stopped })
}

/// A sink that waits after every step, to watch a run live.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pace {
    /// This long after every step.
    Wait(Duration),
    /// About `factor` × real time: a step's simulated seconds over `factor`.
    RealTime(f64),
}

impl<S: Present + ?Sized> Sink<S> for Pace {
    fn step(&mut self, sim: &S) -> Result<ControlFlow<String>, SinkError> {
        let wait = match *self {
            Pace::Wait(d) => d,
            Pace::RealTime(f) => Duration::from_secs_f64(sim.step_s() / f),
        };
        std::thread::sleep(wait);
        Ok(ControlFlow::Continue(()))
    }
}

/// The grid's cell `p` as a [`Present`] pose: its centre, facing +x.
pub fn cell_pose(p: Pos, cell_size: f64) -> Pose {
    Pose {
        x: (p.col as f64 + 0.5) * cell_size,
        y: (p.row as f64 + 0.5) * cell_size,
        theta: 0.0,
    }
}

/// A grid world whose agents live elsewhere (the runtime's world node): the world, what each
/// robot shows of its decisions (as it reported them) and the exchanges the radio node let
/// through.
pub struct WorldView<'a> {
    /// The world.
    pub world: &'a madenet_world::World,
    /// What each robot shows, robot i at index i (missing robots show nothing).
    pub robots: Vec<RobotShown<'a>>,
    /// The pairs whose exchange succeeded this timestep.
    pub exchanges: &'a [(usize, usize)],
}

/// The [`Present`] methods a continuous run answers from its world, `self.world` (a
/// [`ContinuousWorld`]), the same way whoever decides its robots' goals (its agents, or
/// nav2 clients in the nav2 sim): robots, time, truth, poses and cells, the team's map,
/// progress, and the world itself; no agent's cell map (each robot's fine map is shown).
/// Exported for `madenet_ros2::nav2_sim`; the paths it names are fully qualified.
#[macro_export]
macro_rules! present_continuous_world {
    () => {
        fn robots(&self) -> usize {
            self.world.robots()
        }
        fn time_s(&self) -> f64 {
            self.world.time()
        }
        fn step_s(&self) -> f64 {
            self.world.config().control_period
        }
        fn truth(&self) -> &madenet_map::OccGrid {
            self.world.coarse_truth()
        }
        fn pose(&self, i: usize) -> $crate::stepping::Pose {
            self.world.pose(i)
        }
        fn cell(&self, i: usize) -> madenet_map::Pos {
            self.world.cell_of(i)
        }
        /// None: the continuous world shows each robot's fine map
        /// ([`Present::continuous`](madenet_sim::stepping::Present::continuous)).
        fn belief(&self, _: usize) -> Option<std::borrow::Cow<'_, [madenet_map::Occupancy]>> {
            None
        }
        fn team_map(&self) -> std::borrow::Cow<'_, [madenet_map::Occupancy]> {
            std::borrow::Cow::Owned(self.world.team_map())
        }
        fn explored(&self) -> f64 {
            self.world.explored_fraction()
        }
        fn distance(&self) -> f64 {
            (0..self.world.robots())
                .map(|i| self.world.distance(i))
                .sum()
        }
        fn continuous(&self) -> Option<&madenet_continuous::ContinuousWorld> {
            Some(&self.world)
        }
    };
}

/// The [`Present`] methods a grid trial answers from its world, `self.world` (a
/// [`madenet_world::World`] or a reference to one), the same way wherever its agents live:
/// time, truth, poses and cells, the team's map, contacts and progress.
macro_rules! present_grid_world {
    () => {
        fn time_s(&self) -> f64 {
            self.world.t() as f64
        }
        fn step_s(&self) -> f64 {
            1.0
        }
        fn truth(&self) -> &madenet_map::OccGrid {
            self.world.truth()
        }
        fn pose(&self, i: usize) -> madenet_continuous::Pose {
            $crate::stepping::cell_pose(self.world.positions()[i], self.world.truth().resolution)
        }
        fn cell(&self, i: usize) -> madenet_map::Pos {
            self.world.positions()[i]
        }
        fn team_map(&self) -> std::borrow::Cow<'_, [madenet_map::Occupancy]> {
            std::borrow::Cow::Borrowed(self.world.team_map())
        }
        fn contacts(&self) -> std::borrow::Cow<'_, [(usize, usize)]> {
            std::borrow::Cow::Borrowed(self.world.contacts())
        }
        fn explored(&self) -> f64 {
            self.world.explored_fraction()
        }
        fn distance(&self) -> f64 {
            self.world.distances().iter().sum()
        }
        fn when(&self) -> String {
            format!("timestep {}", self.world.t())
        }
    };
}
pub(crate) use present_grid_world;

impl Present for WorldView<'_> {
    present_grid_world!();
    fn robots(&self) -> usize {
        self.world.positions().len()
    }
    fn robot(&self, i: usize) -> RobotShown<'_> {
        self.robots.get(i).copied().unwrap_or_default()
    }
    /// None: the robots' beliefs live in their own processes.
    fn belief(&self, _: usize) -> Option<Cow<'_, [Occupancy]>> {
        None
    }
    fn exchanges(&self) -> &[(usize, usize)] {
        self.exchanges
    }
}
