//! A world node as `madenet world` serves it: the lockstep loop of [`run_ground_with`] with the
//! run loop's outputs around it — the sinks of [`madenet_sim::stepping`] (bag, live view,
//! pictures) told of every timestep the node shows, through a [`WorldView`]; pacing that keeps
//! the robots told the world is there; a progress line per timestep; and a signal ([`Stop`])
//! that ends the run after its timestep.
//!
//! The simulated world and real robots ([`Ground`]) are served by the same [`serve`]; only the
//! simulated world has a ground truth to show ([`WorldSinks`]).

use crate::signals::Stop;
use crate::transport::Transport;
use crate::wire::Shown;
use crate::world_node::{run_ground_with, Ground, ShowFn};
use crate::{LockstepResult, RuntimeError, Timeouts};
use madenet_sim::stepping::{Sink, SinkError, WorldView};
use madenet_world::World;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

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

/// Serves `ground` as the world node of a run over `transport` ([`run_ground_with`]: `show`
/// asks the robots what they show), paced, with progress lines and ended early by a signal as
/// `serving` says.
pub fn serve<G: Ground, T: Transport>(
    ground: G,
    transport: T,
    timeouts: Timeouts,
    scenario: Option<u64>,
    show: Option<ShowFn<'_, G>>,
    serving: &Serving<'_>,
) -> Result<Served, RuntimeError> {
    let mut last = Instant::now();
    let mut interrupted = None;
    let r = run_ground_with(ground, transport, timeouts, scenario, show, |w, waiting| {
        if serving.progress {
            let explored = w.explored_fraction();
            eprintln!("progress step={} explored={explored:.3}", w.t());
        }
        // The pace in slices, the robots told the world is still there (a pace may be longer
        // than they wait in silence).
        let until = last + serving.pace;
        loop {
            let left = until.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            std::thread::sleep(left.min(Duration::from_millis(100)));
            waiting();
        }
        last = Instant::now();
        match serving.stop.requested() {
            Some(signal) => {
                interrupted = Some((format!("timestep {}", w.t()), signal));
                ControlFlow::Break(())
            }
            None => ControlFlow::Continue(()),
        }
    })?;
    Ok(match interrupted {
        Some((at, signal)) => Served::Interrupted(at, signal),
        None => Served::Finished(Box::new(r)),
    })
}

/// An output of a world node's run: a sink of any timestep's [`WorldView`].
pub type WorldSink = Box<dyn for<'v> Sink<WorldView<'v>>>;

/// What starts a world node's sinks on the first view (a recorder starts on the run's first
/// state), in the order they finish.
pub type StartSinks<'f> = Box<dyn FnOnce(&WorldView<'_>) -> Result<Vec<WorldSink>, SinkError> + 'f>;

/// The last timestep shown: the world (cloned: the node's world is gone when the run returns),
/// what each robot showed, the exchanges.
type LastShown = (World, Vec<Shown>, Vec<(usize, usize)>);

/// The sinks of a world node's run, fed by its `show` callback ([`WorldSinks::show`]): started
/// on the first timestep shown, told of every later one, finished on the last
/// ([`WorldSinks::finish`]). The first failure stops feeding them; `finish` returns it.
pub struct WorldSinks<'f> {
    start: Option<StartSinks<'f>>,
    sinks: Vec<WorldSink>,
    failed: Option<SinkError>,
    last: Option<LastShown>,
}

impl<'f> WorldSinks<'f> {
    /// Sinks that `start` makes on the first timestep shown.
    pub fn new(start: StartSinks<'f>) -> Self {
        WorldSinks {
            start: Some(start),
            sinks: Vec::new(),
            failed: None,
            last: None,
        }
    }

    /// A timestep shown: the world, what each robot shows, the pairs exchanging.
    pub fn show(&mut self, w: &World, shown: &[Shown], links: &[(usize, usize)]) {
        if self.failed.is_some() {
            return;
        }
        let view = WorldView {
            world: w,
            robots: shown.iter().map(Shown::view).collect(),
            exchanges: links,
        };
        let r = match self.start.take() {
            Some(start) => start(&view).and_then(|sinks| {
                self.sinks = sinks;
                self.sinks.iter_mut().try_for_each(|s| s.begin(&view))
            }),
            // The sinks here never stop a run: a world node's run is ended by its signal.
            None => self
                .sinks
                .iter_mut()
                .try_for_each(|s| s.step(&view).map(drop)),
        };
        self.failed = r.err();
        self.last = Some((w.clone(), shown.to_vec(), links.to_vec()));
    }

    /// The sinks finished on the last timestep shown (in order): their lines about what they
    /// wrote; or the first failure.
    pub fn finish(mut self) -> Result<Vec<String>, SinkError> {
        if let Some(e) = self.failed {
            return Err(e);
        }
        let Some((w, shown, links)) = self.last else {
            return Ok(Vec::new());
        };
        let view = WorldView {
            world: &w,
            robots: shown.iter().map(Shown::view).collect(),
            exchanges: &links,
        };
        let mut wrote = Vec::new();
        for s in &mut self.sinks {
            wrote.extend(s.finish(&view)?);
        }
        Ok(wrote)
    }
}
