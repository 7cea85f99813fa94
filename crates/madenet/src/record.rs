//! `--record PATH` and `--foxglove [ADDR]`: a grid trial as ROS 2 messages
//! ([`madenet_ros2::record`]: its topics, in simulated time) into a bag and/or a live Foxglove
//! view, with the CLI's error context and the line it prints.

#[cfg(feature = "ros2")]
mod imp {
    use anyhow::{Context, Result};
    use madenet_ros2::bag::Bag;
    use madenet_ros2::live::Live;
    use madenet_sim::continuous::ContinuousTrial;
    use madenet_sim::Trial;
    use std::path::{Path, PathBuf};

    /// The bag and the live view asked for (the bag's place checked first, so a refused
    /// `--foxglove` leaves no bag behind: an unfinished bag removes itself).
    fn open(bag: Option<&Path>, live: Option<&str>) -> Result<(Option<Bag>, Option<Live>)> {
        let bag = match bag {
            Some(p) => Some(Bag::create(p).context("--record")?),
            None => None,
        };
        let live = match live {
            Some(addr) => {
                let live = Live::start(addr).context("--foxglove")?;
                // Printed at once (stderr): a viewer connects while the run goes on.
                eprintln!(
                    "foxglove   {} (Foxglove: Open connection → Foxglove WebSocket)",
                    live.url()
                );
                Some(live)
            }
            None => None,
        };
        Ok((bag, live))
    }

    /// The line printed about a finished bag.
    fn wrote(done: Option<(PathBuf, u64)>) -> Option<String> {
        let (dir, messages) = done?;
        let bytes: u64 = std::fs::read_dir(&dir)
            .map(|d| {
                d.filter_map(|e| e.ok()?.metadata().ok())
                    .map(|m| m.len())
                    .sum()
            })
            .unwrap_or(0);
        Some(format!(
            "wrote      {} (ROS 2 bag, {messages} messages, {:.1} kB)",
            dir.display(),
            bytes as f64 / 1e3
        ))
    }

    /// A grid trial being recorded or streamed.
    pub struct Recorder(madenet_ros2::record::Recorder);

    impl Recorder {
        /// Starts the bag at `bag` (a new path or an empty folder) and/or the live view at
        /// `live` (HOST:PORT), with the true map and the trial's start; `None` when neither is
        /// asked for.
        pub fn start(
            bag: Option<&Path>,
            live: Option<&str>,
            trial: &Trial,
        ) -> Result<Option<Self>> {
            if bag.is_none() && live.is_none() {
                return Ok(None);
            }
            let r = match open(bag, live)? {
                (bag, Some(live)) => madenet_ros2::record::Recorder::to_live(bag, live, trial),
                (bag, None) => madenet_ros2::record::Recorder::to(bag, trial),
            };
            Ok(Some(Recorder(r.context("--record")?)))
        }

        /// [`Recorder::start`] for a world node (`madenet world`), before its first timestep.
        pub fn start_world(
            bag: Option<&Path>,
            live: Option<&str>,
            world: &madenet_world::World,
        ) -> Result<Option<Self>> {
            if bag.is_none() && live.is_none() {
                return Ok(None);
            }
            use madenet_ros2::record::Recorder as R;
            let r = match open(bag, live)? {
                (bag, Some(live)) => R::for_world_live(bag, live, world),
                (bag, None) => R::for_world(bag, world),
            };
            Ok(Some(Recorder(r.context("--record")?)))
        }

        /// Records the trial's current timestep.
        pub fn step(&mut self, trial: &Trial) -> Result<()> {
            self.0.step(trial).context("--record")
        }

        /// Records a world node's timestep: the world, what the robots show, the exchanges.
        pub fn step_world(
            &mut self,
            world: &madenet_world::World,
            shown: &[madenet_runtime::wire::Shown],
            exchanges: &[(usize, usize)],
        ) -> Result<()> {
            self.0
                .step_world(world, shown, exchanges)
                .context("--record")
        }

        /// Finishes the bag, if any; the line to print about it.
        pub fn finish(self) -> Result<Option<String>> {
            Ok(wrote(self.0.finish().context("--record")?))
        }
    }

    /// A continuous trial being recorded or streamed.
    pub struct ContinuousRecorder(madenet_ros2::record::ContinuousRecorder);

    impl ContinuousRecorder {
        /// [`Recorder::start`] for a continuous trial.
        pub fn start(
            bag: Option<&Path>,
            live: Option<&str>,
            trial: &ContinuousTrial,
        ) -> Result<Option<Self>> {
            if bag.is_none() && live.is_none() {
                return Ok(None);
            }
            use madenet_ros2::record::ContinuousRecorder as R;
            let r = match open(bag, live)? {
                (bag, Some(live)) => R::to_live(bag, live, trial),
                (bag, None) => R::to(bag, trial),
            };
            Ok(Some(ContinuousRecorder(r.context("--record")?)))
        }

        /// Records the control period the trial just finished.
        pub fn step(&mut self, trial: &ContinuousTrial) -> Result<()> {
            self.0.step(trial).context("--record")
        }

        /// Records the trial's final state and finishes the bag, if any; the line to print
        /// about it.
        pub fn finish(self, trial: &ContinuousTrial) -> Result<Option<String>> {
            Ok(wrote(self.0.finish(trial).context("--record")?))
        }
    }
}

#[cfg(not(feature = "ros2"))]
mod imp {
    use anyhow::Result;
    use madenet_sim::continuous::ContinuousTrial;
    use madenet_sim::Trial;
    use std::path::Path;

    /// Refuses what needs the `ros2` feature.
    fn refuse(bag: Option<&Path>, live: Option<&str>) -> Result<()> {
        match (bag, live) {
            (None, None) => Ok(()),
            (Some(_), _) => {
                anyhow::bail!("--record: this madenet was built without the `ros2` feature")
            }
            (None, Some(_)) => {
                anyhow::bail!("--foxglove: this madenet was built without the `ros2` feature")
            }
        }
    }

    /// Without the `ros2` feature there is no bag writer and no live view.
    pub struct Recorder;

    impl Recorder {
        pub fn start(bag: Option<&Path>, live: Option<&str>, _: &Trial) -> Result<Option<Self>> {
            refuse(bag, live).map(|()| None)
        }
        pub fn start_world(
            bag: Option<&Path>,
            live: Option<&str>,
            _: &madenet_world::World,
        ) -> Result<Option<Self>> {
            refuse(bag, live).map(|()| None)
        }
        pub fn step(&mut self, _: &Trial) -> Result<()> {
            Ok(())
        }
        pub fn step_world(
            &mut self,
            _: &madenet_world::World,
            _: &[madenet_runtime::wire::Shown],
            _: &[(usize, usize)],
        ) -> Result<()> {
            Ok(())
        }
        pub fn finish(self) -> Result<Option<String>> {
            Ok(None)
        }
    }

    /// Without the `ros2` feature there is no bag writer and no live view.
    pub struct ContinuousRecorder;

    impl ContinuousRecorder {
        pub fn start(
            bag: Option<&Path>,
            live: Option<&str>,
            _: &ContinuousTrial,
        ) -> Result<Option<Self>> {
            refuse(bag, live).map(|()| None)
        }
        pub fn step(&mut self, _: &ContinuousTrial) -> Result<()> {
            Ok(())
        }
        pub fn finish(self, _: &ContinuousTrial) -> Result<Option<String>> {
            Ok(None)
        }
    }
}

pub use imp::{ContinuousRecorder, Recorder};
