//! A world node as `madenet world` serves it: the node ([`LockstepWorld`]) driven by the run
//! loop ([`madenet_sim::stepping::run`]) with its sinks — the outputs (bag, live view,
//! pictures) told of every timestep through a [`WorldView`], a progress line per timestep, and
//! a signal ([`OnSignal`]) that ends the run after its timestep — and paced, the robots told
//! meanwhile that the world is there.
//!
//! The simulated world and real robots ([`Ground`]) are served by the same [`serve`]; only the
//! simulated world has a ground truth to show ([`Ground::world`]).

use crate::signals::{OnSignal, Stop};
use crate::transport::Transport;
use crate::wire::Shown;
use crate::world_node::{Ground, LockstepWorld};
use crate::{LockstepResult, RuntimeError, Timeouts};
use madenet_sim::stepping::{Present, Sink, SinkError, WorldView};
use std::ops::ControlFlow;
use std::time::Duration;

/// How a world node is served around its timesteps.
pub struct Serving<'a> {
    /// At least this long per timestep (to watch a run live); zero: as fast as the robots go.
    pub pace: Duration,
    /// A line `progress step=12 explored=0.410` on stderr after every timestep (what a
    /// launcher reads).
    pub progress: bool,
    /// The signal that ends the run after its timestep.
    pub stop: &'a Stop,
}

/// How a served world node's run ended.
#[derive(Debug)]
pub enum Served {
    /// The trial ran to its end.
    Finished(Box<LockstepResult>),
    /// A signal ended it after a timestep: where (`timestep 37`), and which signal.
    Interrupted(String, i32),
}

/// Why serving a world node failed: the node (a robot, the radio, the ground), or an output.
#[derive(Debug)]
pub enum ServeError {
    /// The node failed ([`RuntimeError`]).
    Node(RuntimeError),
    /// An output failed; the robots and the radio were stopped.
    Sink(SinkError),
}

impl std::fmt::Display for ServeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ServeError::Node(e) => e.fmt(f),
            ServeError::Sink(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for ServeError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ServeError::Node(e) => e.source(),
            ServeError::Sink(e) => e.source(),
        }
    }
}

impl From<RuntimeError> for ServeError {
    fn from(e: RuntimeError) -> Self {
        ServeError::Node(e)
    }
}

/// An output of a world node's run: a sink of any timestep's [`WorldView`].
pub type WorldSink = Box<dyn for<'v> Sink<WorldView<'v>>>;

/// What starts a world node's sinks on the first view (a recorder starts on the run's first
/// state), in the order they finish.
pub type StartSinks<'f> = Box<dyn FnOnce(&WorldView<'_>) -> Result<Vec<WorldSink>, SinkError> + 'f>;

/// The node's present as a [`WorldView`], where its ground is the simulated world.
fn view<G: Ground, T: Transport>(w: &LockstepWorld<G, T>) -> Option<WorldView<'_>> {
    Some(WorldView {
        world: w.ground().world()?,
        robots: w.shown().iter().map(Shown::view).collect(),
        exchanges: w.exchanges(),
    })
}

/// The outputs as one sink of the node: started on its first view, told of every later one,
/// finished on the last — unless the node failed (then they are dropped unfinished: a bag
/// being written removes itself).
struct Views<'f> {
    start: Option<StartSinks<'f>>,
    sinks: Vec<WorldSink>,
}

impl<G: Ground, T: Transport> Sink<LockstepWorld<G, T>> for Views<'_> {
    fn begin(&mut self, w: &LockstepWorld<G, T>) -> Result<(), SinkError> {
        let (Some(view), Some(start)) = (view(w), self.start.take()) else {
            return Ok(());
        };
        self.sinks = start(&view)?;
        self.sinks.iter_mut().try_for_each(|s| s.begin(&view))
    }

    fn step(&mut self, w: &LockstepWorld<G, T>) -> Result<ControlFlow<String>, SinkError> {
        let Some(view) = view(w) else {
            return Ok(ControlFlow::Continue(()));
        };
        for s in &mut self.sinks {
            if let ControlFlow::Break(why) = s.step(&view)? {
                return Ok(ControlFlow::Break(why));
            }
        }
        Ok(ControlFlow::Continue(()))
    }

    fn finish(&mut self, w: &LockstepWorld<G, T>) -> Result<Vec<String>, SinkError> {
        let view = view(w).filter(|_| w.failed().is_none());
        let Some(view) = view else {
            return Ok(Vec::new());
        };
        let mut wrote = Vec::new();
        for s in &mut self.sinks {
            wrote.extend(s.finish(&view)?);
        }
        Ok(wrote)
    }
}

/// The line `progress step=12 explored=0.410` on stderr after every timestep.
struct Progress;

impl<G: Ground, T: Transport> Sink<LockstepWorld<G, T>> for Progress {
    fn step(&mut self, w: &LockstepWorld<G, T>) -> Result<ControlFlow<String>, SinkError> {
        let explored = w.ground().explored_fraction();
        {
            use std::io::Write;
            let _ = writeln!(
                std::io::stderr(),
                "progress step={} explored={explored:.3}",
                w.ground().t()
            );
        }
        Ok(ControlFlow::Continue(()))
    }
}

/// Serves `ground` as the world node of a run over `transport` ([`LockstepWorld`]), paced,
/// with progress lines and ended early by a signal as `serving` says. With `sinks`, the robots
/// and the radio report what they show and `sinks` starts the outputs on the first view (only
/// the simulated world is shown: [`Ground::world`]). Returns how the run ended and the
/// outputs' lines about what they wrote.
pub fn serve<G: Ground, T: Transport>(
    ground: G,
    transport: T,
    timeouts: Timeouts,
    scenario: Option<u64>,
    sinks: Option<StartSinks<'_>>,
    serving: &Serving<'_>,
) -> Result<(Served, Vec<String>), ServeError> {
    let show = sinks.is_some();
    let mut node = LockstepWorld::connect(ground, transport, timeouts, scenario, show)?;
    node.set_pace(serving.pace);
    let mut views = Views {
        start: sinks,
        sinks: Vec::new(),
    };
    let mut progress = Progress;
    let mut interrupt = OnSignal::new(serving.stop);
    let ran = {
        let mut all: Vec<&mut dyn Sink<LockstepWorld<G, T>>> = vec![&mut views];
        if serving.progress {
            all.push(&mut progress);
        }
        all.push(&mut interrupt);
        madenet_sim::stepping::run(&mut node, &mut all)
    };
    let end = match ran {
        Ok(end) => end,
        Err(e) => {
            // The robots and the radio are stopped all the same; the output's failure is the
            // error.
            let _ = node.finish();
            return Err(ServeError::Sink(e));
        }
    };
    let result = node.finish()?;
    let served = match (end.stopped, interrupt.signal) {
        (Some((_, at)), Some(signal)) => Served::Interrupted(at, signal),
        _ => Served::Finished(Box::new(result)),
    };
    Ok((served, end.wrote))
}
