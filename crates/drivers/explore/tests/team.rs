//! A team of exploration nodes, one thread each, and the simulated nav2 team (the continuous
//! world serving `navigate_to_pose`), talking only through a zenoh router: each node shares its
//! map, position and goal over ROS 2 topics, and the team explores a generated floor plan.

mod common;

use madenet_explore::node::{self, ExploreRun};
use madenet_explore::params::ExploreParams;
use madenet_map::paper::Corner;
use madenet_ros2::nav2_sim::Nav2SimRun;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Runs `n` nodes of `policy` on a `size` m floor plan of `seed` until every node is done (or
/// `watchdog` seconds pass).
/// Returns each node's run and the sim's ground truth.
fn explore_team(
    policy: &str,
    n: usize,
    size: usize,
    seed: u64,
    watchdog: u64,
) -> (Vec<ExploreRun>, Nav2SimRun) {
    let (router, opts, sim) = common::plan_sim(size, seed, |_| {
        Corner::TopLeft.start_cells(size, size)[..n].to_vec()
    });
    let stop_all = sim.stop_flag();
    let names: Vec<String> = (0..n).map(|i| format!("/robot{i}")).collect();
    let t0 = Instant::now();
    let nodes: Vec<_> = (0..n)
        .map(|i| {
            let opts = opts.clone();
            let ns = names[i].clone();
            let mates: Vec<String> = names.iter().filter(|m| **m != ns).cloned().collect();
            let yaml = format!(
                "/**:\n  ros__parameters:\n    costmap_topic: map\n    costmap_updates_topic: map_updates\n    planner_frequency: 1.0\n    potential_scale: 3.0\n    use_sim_time: true\n    policy: {policy}\n    teammates: [{}]\n",
                mates.join(", ")
            );
            let p = ExploreParams::from_yaml(&yaml, &format!("{ns}/explore_node")).unwrap();
            let stop_all = stop_all.clone();
            std::thread::spawn(move || {
                let stop = || stop_all.load(Ordering::Relaxed);
                node::run(&opts, &ns, &p, &[], &stop).unwrap()
            })
        })
        .collect();
    let watch = {
        let stop = stop_all.clone();
        std::thread::spawn(move || {
            let t = Instant::now();
            while !stop.load(Ordering::Relaxed) && t.elapsed().as_secs() < watchdog {
                std::thread::sleep(Duration::from_millis(200));
            }
            stop.store(true, Ordering::Relaxed);
        })
    };
    let mut runs = Vec::new();
    for h in nodes {
        runs.push(h.join().unwrap());
    }
    let truth = sim.stop().unwrap();
    watch.join().unwrap();
    drop(router);
    eprintln!(
        "{policy}: {runs:?}; {:.0} s simulated, explored {:.3}, {:.0} s wall",
        truth.time,
        truth.explored,
        t0.elapsed().as_secs_f64()
    );
    (runs, truth)
}

/// explore-lite with teammates: each node plans on its map merged with its teammates' shared
/// maps (the study's method (b)).
#[test]
fn three_explore_lite_nodes_with_merged_maps_explore_a_plan() {
    let (runs, truth) = explore_team("explore-lite", 3, 16, 5, 300);
    assert!(runs.iter().all(|r| r.complete), "{runs:?}");
    // explore_lite's frontiers are the fine map's: "complete" leaves a few of the paper's 1 m
    // cells unread (99.0–100 % in local runs; the explored share is read by the cell rule).
    assert!(truth.explored >= 0.95, "explored {}", truth.explored);
    // Walls: at most one touch. In about 1 of 4 runs on a loaded machine a simulated nav2
    // robot touched a wall once (a defect of the sim's navigator under explore_lite's many
    // preemptions, logged at debug level by the world, open in issue 58's notes).
    // Teammates are not asserted: the simulated robots do not see each other in their maps
    // (issue 57's sim) and explore_lite robots, which do not coordinate, meet in doors (0–2
    // touches a run); the study counts them per method, and the process test of
    // `madenet explore` with spread (crates/madenet/tests/explore.rs) asserts none.
    eprintln!("touches: {:?}", truth.collisions);
    assert!(truth.collisions.obstacle <= 1, "{truth:?}");
}
