//! `--record PATH`: a grid trial as a ROS 2 bag ([`madenet_ros2::bag`]), in simulated time
//! (timestep t is second t, published on `/clock`):
//!
//! | topic | type | when |
//! | --- | --- | --- |
//! | `/truth_map` | `nav_msgs/msg/OccupancyGrid` | once, at the start |
//! | `/team_map` | `nav_msgs/msg/OccupancyGrid` | when it changes: the team's merged map 𝓜 (everything any robot observed) |
//! | `/robot<i>/map` | `nav_msgs/msg/OccupancyGrid` | when it changes: robot i's belief with the timestep's own observation |
//! | `/robot<i>/pose` | `geometry_msgs/msg/PoseStamped` | every timestep, the start and the end included |
//! | `/robot<i>/goal_pose` | `geometry_msgs/msg/PoseStamped` | when robot i's goal changes |
//! | `/tf` | `tf2_msgs/msg/TFMessage` | every timestep: `map` → `robot<i>/base_link` |
//! | `/clock` | `rosgraph_msgs/msg/Clock` | every timestep |

#[cfg(feature = "ros2")]
mod imp {
    use anyhow::{Context, Result};
    use madenet_map::{Occupancy, Pos};
    use madenet_ros2::bag::Bag;
    use madenet_ros2::msgs::{
        Clock, Header, TFMessage, Time, Transform, TransformStamped, Vector3,
    };
    use madenet_ros2::{occupancy_grid, pose_stamped, MapFrame, FRAME_ID};
    use madenet_sim::Trial;
    use std::path::Path;

    /// A grid trial being recorded.
    pub struct Recorder {
        bag: Bag,
        frame: MapFrame,
        maps: Vec<Option<Vec<Occupancy>>>,
        team: Option<Vec<Occupancy>>,
        goals: Vec<Option<Pos>>,
    }

    impl Recorder {
        /// Starts the bag at `path` (a new path or an empty folder) with the true map and the
        /// trial's start.
        pub fn start(path: &Path, trial: &Trial) -> Result<Self> {
            let bag = Bag::create(path).context("--record")?;
            let truth = trial.world().truth();
            let frame = MapFrame::of(truth);
            let n = trial.agents().len();
            let mut r = Recorder {
                bag,
                frame,
                maps: vec![None; n],
                team: None,
                goals: vec![None; n],
            };
            let msg = occupancy_grid(&r.frame, truth.cells(), Time::default());
            r.bag.write("/truth_map", &msg, 0).context("--record")?;
            r.step(trial).context("--record")?;
            Ok(r)
        }

        /// Records the trial's current timestep.
        pub fn step(&mut self, trial: &Trial) -> Result<()> {
            let t = trial.world().t() as u64;
            let (ns, stamp) = (
                t * 1_000_000_000,
                Time {
                    sec: t as i32,
                    nanosec: 0,
                },
            );
            let bag = &mut self.bag;
            bag.write("/clock", &Clock { clock: stamp }, ns)?;
            let positions = trial.world().positions();
            let transforms = positions
                .iter()
                .enumerate()
                .map(|(i, &p)| {
                    let (x, y) = self.frame.cell_center(p);
                    let q = pose_stamped(&self.frame, p, stamp).pose.orientation;
                    TransformStamped {
                        header: Header {
                            stamp,
                            frame_id: FRAME_ID.into(),
                        },
                        child_frame_id: format!("robot{i}/base_link"),
                        transform: Transform {
                            translation: Vector3 { x, y, z: 0.0 },
                            rotation: q,
                        },
                    }
                })
                .collect();
            bag.write("/tf", &TFMessage { transforms }, ns)?;
            for (i, a) in trial.agents().iter().enumerate() {
                let [map_t, pose_t, goal_t] = madenet_ros2::topics(i);
                // What the robot knows now: its belief and this timestep's observation, which
                // its agent takes in at the start of the next timestep (or never, at the end).
                let mut belief = a.belief().clone();
                for &(p, occ) in &trial.world().observation(i).seen {
                    belief.observe(p, occ);
                }
                let cells = belief.map();
                if self.maps[i].as_deref() != Some(cells) {
                    bag.write(&map_t, &occupancy_grid(&self.frame, cells, stamp), ns)?;
                    self.maps[i] = Some(cells.to_vec());
                }
                bag.write(&pose_t, &pose_stamped(&self.frame, positions[i], stamp), ns)?;
                if let Some(g) = a.goal().filter(|&g| Some(g) != self.goals[i]) {
                    bag.write(&goal_t, &pose_stamped(&self.frame, g, stamp), ns)?;
                }
                self.goals[i] = a.goal();
            }
            let team = trial.world().team_map();
            if self.team.as_deref() != Some(team) {
                bag.write("/team_map", &occupancy_grid(&self.frame, team, stamp), ns)?;
                self.team = Some(team.to_vec());
            }
            Ok(())
        }

        /// Finishes the bag; the line to print about it.
        pub fn finish(self) -> Result<String> {
            let messages = self.bag.messages();
            let dir = self.bag.finish().context("--record")?;
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
