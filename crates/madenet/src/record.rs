//! `--record PATH` and `--foxglove [ADDR]`: a grid trial as ROS 2 messages
//! ([`madenet_ros2::record`]: its topics, in simulated time) into a bag and/or a live Foxglove
//! view, with the CLI's error context and the line it prints; `--record-trials` (`compare`,
//! `scale`): chosen trials of a study as bags.

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

    /// Records each of `chosen` (trials of a study, re-run: the same seed gives the same
    /// trial) as a bag in `dir`/[`folder_name`](madenet_study::select::folder_name), in
    /// parallel on the current pool; a bag already there is kept. Returns how many were
    /// written.
    pub fn record_trials(
        chosen: &[&madenet_study::runner::Planned],
        registry: &madenet_sim::PolicyRegistry,
        dir: &Path,
    ) -> Result<usize> {
        use rayon::prelude::*;
        std::fs::create_dir_all(dir)
            .with_context(|| format!("--record-trials: {}", dir.display()))?;
        let written = chosen
            .par_iter()
            .map(|p| -> Result<bool> {
                let at = dir.join(madenet_study::select::folder_name(&p.key));
                if at.join("metadata.yaml").is_file() {
                    return Ok(false);
                }
                let failed = |e: madenet_sim::SimError| anyhow::anyhow!("{}: {e}", p.key);
                let bag = Some(Bag::create(&at).context("--record-trials")?);
                let done = match p.continuous_trial(registry) {
                    Some(trial) => {
                        let mut trial = trial.map_err(failed)?;
                        let mut r = madenet_ros2::record::ContinuousRecorder::to(bag, &trial)
                            .context("--record-trials")?;
                        while trial.step() {
                            r.step(&trial).context("--record-trials")?;
                        }
                        r.finish(&trial)
                    }
                    None => {
                        let mut trial =
                            Trial::with_registry(p.spec.clone(), registry).map_err(failed)?;
                        let mut r = madenet_ros2::record::Recorder::to(bag, &trial)
                            .context("--record-trials")?;
                        while trial.step() {
                            r.step(&trial).context("--record-trials")?;
                        }
                        r.finish()
                    }
                };
                done.context("--record-trials")?;
                Ok(true)
            })
            .collect::<Result<Vec<bool>>>()?;
        Ok(written.into_iter().filter(|&w| w).count())
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

    /// Without the `ros2` feature there is no bag writer.
    pub fn record_trials(
        _: &[&madenet_study::runner::Planned],
        _: &madenet_sim::PolicyRegistry,
        _: &Path,
    ) -> Result<usize> {
        anyhow::bail!("--record-trials: this madenet was built without the `ros2` feature")
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

pub use imp::{record_trials, ContinuousRecorder, Recorder};

/// After a study, while its folder `out` is still locked: records the trials of `planned`
/// that `--record-trials` conditions `items` choose into `out`/bags ([`record_trials`], on
/// `pool`) and prints where. Bags there are kept, as the study keeps its rows; with `fresh`
/// (the study started afresh) the bags are recorded into a hidden folder that replaces
/// `out`/bags only once all are written, so a failed re-recording leaves the old bags.
pub fn record_study_trials(
    items: &[String],
    planned: &[madenet_study::runner::Planned],
    registry: &madenet_sim::PolicyRegistry,
    out: &std::path::Path,
    fresh: bool,
    pool: &rayon::ThreadPool,
) -> anyhow::Result<()> {
    use anyhow::Context;
    let chosen = chosen_trials(items, planned)?;
    let bags = out.join("bags");
    // An interrupted fresh recording's folders (the caller holds `out`'s lock).
    let (new, old) = (out.join(".madenet-bags-new"), out.join(".madenet-bags-old"));
    let clear = |d: &std::path::Path| -> anyhow::Result<()> {
        if d.exists() {
            std::fs::remove_dir_all(d)
                .with_context(|| format!("--record-trials: {}", d.display()))?;
        }
        Ok(())
    };
    // A swap cut between its two renames: the old bags are whole, put them back first.
    if !bags.exists() && old.is_dir() {
        std::fs::rename(&old, &bags)
            .with_context(|| format!("--record-trials: {}", bags.display()))?;
    }
    clear(&new)?;
    clear(&old)?;
    let n = pool.install(|| record_trials(&chosen, registry, if fresh { &new } else { &bags }))?;
    if fresh {
        let swap = || -> std::io::Result<()> {
            if bags.exists() {
                std::fs::rename(&bags, &old)?;
            }
            std::fs::rename(&new, &bags)
        };
        swap().with_context(|| format!("--record-trials: {}", bags.display()))?;
        clear(&old)?;
    }
    out!(
        "{} trials recorded → {} ({n} written now)",
        chosen.len(),
        bags.display()
    )?;
    Ok(())
}

/// After a study run afresh without `--record-trials`, while its folder `out` is still
/// locked: the bags of the earlier study go with its rows.
pub fn discard_bags(out: &std::path::Path) -> anyhow::Result<()> {
    use anyhow::Context;
    for d in ["bags", ".madenet-bags-new", ".madenet-bags-old"] {
        let d = out.join(d);
        if d.exists() {
            std::fs::remove_dir_all(&d).with_context(|| format!("--fresh: {}", d.display()))?;
        }
    }
    Ok(())
}

/// At most this many trials of a study are recorded (a filter choosing more is refused).
const MAX_RECORDED_TRIALS: usize = 1000;

/// The trials of `planned` that `--record-trials` conditions `items` choose: some, at most
/// [`MAX_RECORDED_TRIALS`], none an oracle's; every refusal names the flag. Checked before a
/// study runs.
pub fn chosen_trials<'a>(
    items: &[String],
    planned: &'a [madenet_study::runner::Planned],
) -> anyhow::Result<Vec<&'a madenet_study::runner::Planned>> {
    let filter = madenet_study::select::TrialFilter::parse(items)
        .map_err(|e| anyhow::anyhow!("--record-trials: {e}"))?;
    if !cfg!(feature = "ros2") {
        anyhow::bail!("--record-trials: this madenet was built without the `ros2` feature");
    }
    let chosen: Vec<_> = planned.iter().filter(|p| filter.matches(&p.key)).collect();
    if chosen.is_empty() {
        anyhow::bail!(
            "--record-trials: chooses none of the study's {} trials (fields: method, map, start, csp, seed, as trials.csv writes them)",
            planned.len()
        );
    }
    if chosen.len() > MAX_RECORDED_TRIALS {
        anyhow::bail!(
            "--record-trials: chooses {} trials, more than the {MAX_RECORDED_TRIALS} bags a study records: narrow it (e.g. seed=1)",
            chosen.len()
        );
    }
    if let Some(p) = chosen.iter().find(|p| p.oracle.is_some()) {
        anyhow::bail!(
            "--record-trials: chooses an oracle's trial ({}), which is not recorded: add a method=… condition",
            p.key
        );
    }
    let mut names = std::collections::HashSet::new();
    if let Some(p) = chosen
        .iter()
        .find(|p| !names.insert(madenet_study::select::folder_name(&p.key)))
    {
        anyhow::bail!(
            "--record-trials: two chosen trials share the folder name {} (starts that differ only in punctuation): narrow it",
            madenet_study::select::folder_name(&p.key)
        );
    }
    Ok(chosen)
}
