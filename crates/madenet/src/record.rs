//! `--record PATH` and `--foxglove [ADDR]`: a grid trial as ROS 2 messages
//! ([`madenet_ros2::record`]: its topics, in simulated time) into a bag and/or a live Foxglove
//! view, with the CLI's error context and the line it prints.

#[cfg(feature = "ros2")]
mod imp {
    use anyhow::{Context, Result};
    use madenet_sim::Trial;
    use std::path::Path;

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
            let bag = match bag {
                Some(p) => Some(madenet_ros2::bag::Bag::create(p).context("--record")?),
                None => None,
            };
            let live = match live {
                Some(addr) => Some(madenet_ros2::live::Live::start(addr).context("--foxglove")?),
                None => None,
            };
            let mut r = madenet_ros2::record::Recorder::to(bag, trial).context("--record")?;
            if let Some(live) = live {
                // Printed at once (stderr): a viewer connects while the run goes on.
                eprintln!(
                    "foxglove   {} (Foxglove: Open connection → Foxglove WebSocket)",
                    live.url()
                );
                r = r.with_live(live, trial);
            }
            Ok(Some(Recorder(r)))
        }

        /// Records the trial's current timestep.
        pub fn step(&mut self, trial: &Trial) -> Result<()> {
            self.0.step(trial).context("--record")
        }

        /// Finishes the bag, if any; the line to print about it.
        pub fn finish(self) -> Result<Option<String>> {
            let Some((dir, messages)) = self.0.finish().context("--record")? else {
                return Ok(None);
            };
            let bytes: u64 = std::fs::read_dir(&dir)
                .map(|d| {
                    d.filter_map(|e| e.ok()?.metadata().ok())
                        .map(|m| m.len())
                        .sum()
                })
                .unwrap_or(0);
            Ok(Some(format!(
                "wrote      {} (ROS 2 bag, {messages} messages, {:.1} kB)",
                dir.display(),
                bytes as f64 / 1e3
            )))
        }
    }
}

#[cfg(not(feature = "ros2"))]
mod imp {
    use anyhow::Result;
    use madenet_sim::Trial;
    use std::path::Path;

    /// Without the `ros2` feature there is no bag writer and no live view.
    pub struct Recorder;

    impl Recorder {
        pub fn start(bag: Option<&Path>, live: Option<&str>, _: &Trial) -> Result<Option<Self>> {
            match (bag, live) {
                (None, None) => Ok(None),
                (Some(_), _) => {
                    anyhow::bail!("--record: this madenet was built without the `ros2` feature")
                }
                (None, Some(_)) => {
                    anyhow::bail!("--foxglove: this madenet was built without the `ros2` feature")
                }
            }
        }
        pub fn step(&mut self, _: &Trial) -> Result<()> {
            Ok(())
        }
        pub fn finish(self) -> Result<Option<String>> {
            Ok(None)
        }
    }
}

pub use imp::Recorder;
