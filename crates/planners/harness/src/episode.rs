//! The one episode runner of every learner: a [`Trial`] played to its end through the
//! simulator's staged timestep (begin → decisions → finish), with a [`Recorder`] that decides
//! for the deciding robots (or lets their own policies decide) and reads each finished
//! timestep. MADE-Net's ε-greedy actor, the rollout teacher's labelling and DME-DRL's replay
//! are three recorders of this one loop.
//!
//! ```
//! use madenet_harness::episode::{self, Recorder};
//! use madenet_sim::{Trial, TrialSpec};
//!
//! /// Counts the timesteps and sums the team reward (Eq. 8) of an episode played by the
//! /// robots' own policies.
//! #[derive(Default)]
//! struct TeamReturn {
//!     steps: usize,
//!     total: f64,
//! }
//! impl Recorder for TeamReturn {
//!     type Error = std::convert::Infallible;
//!     fn stepped(&mut self, trial: &Trial) -> Result<(), Self::Error> {
//!         self.steps += 1;
//!         self.total += trial.rewards().team;
//!         Ok(())
//!     }
//! }
//!
//! let map = madenet_map::paper::paper_map(3).unwrap();
//! let corner = madenet_map::paper::Corner::TopLeft;
//! let spec = TrialSpec {
//!     starts: corner.start_cells(map.height(), map.width()).to_vec(),
//!     map,
//!     map_name: "paper_3".into(),
//!     config: madenet_world::ScenarioConfig::default(),
//!     policy: "spread".into(),
//!     seed: 7,
//! };
//! let mut trial = Trial::new(spec).unwrap();
//! let mut rec = TeamReturn::default();
//! let end = episode::run(&mut trial, &mut rec).unwrap();
//! assert!(end.steps > 0 && rec.total != 0.0);
//! assert_eq!((end.steps, end.complete), (rec.steps, trial.world().is_complete()));
//! ```

use madenet_sim::Trial;

/// What a learner does at the two points of a timestep where it takes part.
pub trait Recorder {
    /// Why the episode stops early.
    type Error;

    /// Between [`Trial::begin_step`] and [`Trial::finish_step`]: the robots in
    /// [`Trial::deciding`] decide now — through [`Trial::decide_jointly`],
    /// [`Trial::decide_with`] or [`Trial::apply_decisions`]. By default each deciding robot's
    /// own policy decides.
    fn decide(&mut self, trial: &mut Trial) -> Result<(), Self::Error> {
        trial.decide_with(&[]);
        Ok(())
    }

    /// After [`Trial::finish_step`]: the timestep's rewards are [`Trial::rewards`], its moves
    /// the world's executed moves.
    fn stepped(&mut self, trial: &Trial) -> Result<(), Self::Error> {
        let _ = trial;
        Ok(())
    }
}

/// How an episode ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EpisodeEnd {
    /// Timesteps played.
    pub steps: usize,
    /// The team explored everything (else the step cap ended the episode).
    pub complete: bool,
}

/// Plays `trial` from its present state to its end with `recorder`.
pub fn run<R: Recorder + ?Sized>(
    trial: &mut Trial,
    recorder: &mut R,
) -> Result<EpisodeEnd, R::Error> {
    while trial.begin_step() {
        recorder.decide(trial)?;
        trial.finish_step();
        recorder.stepped(trial)?;
    }
    Ok(EpisodeEnd {
        steps: trial.world().t(),
        complete: trial.world().is_complete(),
    })
}
