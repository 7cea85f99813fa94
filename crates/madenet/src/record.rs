//! `--record PATH` and `--foxglove [ADDR]`: a run of any world as ROS 2 messages
//! ([`madenet_ros2::record`]: its topics, in simulated time) into a bag and/or a live Foxglove
//! view, as a sink of the run loop, with the CLI's error context and the line it prints;
//! `--record-trials` (`compare`, `scale`): chosen trials of a study as bags
//! ([`madenet_ros2::study_bags`]), and the line it prints.

use anyhow::{Context, Result};
use madenet_ros2::bag::Bag;
use madenet_ros2::live::Live;
use madenet_ros2::record::{Recorder, RecorderSink};
use madenet_ros2::study_bags;
use madenet_sim::stepping::Present;
use std::path::Path;

/// The bag and/or live view asked for, started on `sim`'s present (`None` when neither is):
/// the bag's place checked first, so a refused `--foxglove` leaves no bag behind (an
/// unfinished bag removes itself).
pub fn start<S: Present + ?Sized>(
    bag: Option<&Path>,
    live: Option<&str>,
    sim: &S,
) -> Result<Option<RecorderSink>> {
    if bag.is_none() && live.is_none() {
        return Ok(None);
    }
    let bag = bag
        .map(|p| Bag::create(p).context("--record"))
        .transpose()?;
    let live = match live {
        Some(addr) => {
            let live = Live::start(addr).context("--foxglove")?;
            // Printed at once (stderr): a viewer connects while the run goes on.
            say!(
                "foxglove   {} (Foxglove: Open connection → Foxglove WebSocket)",
                live.url()
            );
            Some(live)
        }
        None => None,
    };
    let r = Recorder::to_live(bag, live, sim).context("--record")?;
    Ok(Some(RecorderSink::new(r)))
}

/// After a study, while its folder `out` is still locked: records the trials `chosen` by
/// `--record-trials` ([`madenet_ros2::study_bags`]) and prints where.
pub fn record_study_trials(
    chosen: &[&madenet_study::runner::Planned],
    registry: &madenet_sim::PolicyRegistry,
    out: &Path,
    fresh: bool,
    pool: &rayon::ThreadPool,
) -> Result<()> {
    let (bags, n) = study_bags::record_study_trials(chosen, registry, out, fresh, pool)?;
    out!(
        "{} trials recorded → {} ({n} written now)",
        chosen.len(),
        bags.display()
    )?;
    Ok(())
}
