//! `--record PATH`: a grid trial as a ROS 2 bag ([`madenet_ros2::record`]: its topics, in
//! simulated time), with the CLI's error context and the line it prints.

#[cfg(feature = "ros2")]
mod imp {
    use anyhow::{Context, Result};
    use madenet_sim::Trial;
    use std::path::Path;

    /// A grid trial being recorded.
    pub struct Recorder(madenet_ros2::record::Recorder);

    impl Recorder {
        /// Starts the bag at `path` (a new path or an empty folder) with the true map and the
        /// trial's start.
        pub fn start(path: &Path, trial: &Trial) -> Result<Self> {
            let r = madenet_ros2::record::Recorder::start(path, trial).context("--record")?;
            Ok(Recorder(r))
        }

        /// Records the trial's current timestep.
        pub fn step(&mut self, trial: &Trial) -> Result<()> {
            self.0.step(trial).context("--record")
        }

        /// Finishes the bag; the line to print about it.
        pub fn finish(self) -> Result<String> {
            let (dir, messages) = self.0.finish().context("--record")?;
            let bytes: u64 = std::fs::read_dir(&dir)
                .map(|d| {
                    d.filter_map(|e| e.ok()?.metadata().ok())
                        .map(|m| m.len())
                        .sum()
                })
                .unwrap_or(0);
            Ok(format!(
                "wrote      {} (ROS 2 bag, {messages} messages, {:.1} kB)",
                dir.display(),
                bytes as f64 / 1e3
            ))
        }
    }
}

#[cfg(not(feature = "ros2"))]
mod imp {
    use anyhow::Result;
    use madenet_sim::Trial;
    use std::path::Path;

    /// Without the `ros2` feature there is no bag writer.
    pub struct Recorder;

    impl Recorder {
        pub fn start(_: &Path, _: &Trial) -> Result<Self> {
            anyhow::bail!("--record: this madenet was built without the `ros2` feature")
        }
        pub fn step(&mut self, _: &Trial) -> Result<()> {
            Ok(())
        }
        pub fn finish(self) -> Result<String> {
            Ok(String::new())
        }
    }
}

pub use imp::Recorder;
