//! What the node tests share: a generated floor plan served as a simulated nav2 team.

use madenet_continuous::{ContinuousConfig, ContinuousWorld, Scene};
use madenet_map::floorplan::{floor_plan, FloorPlanConfig};
use madenet_map::Pos;
use madenet_ros2::nav2_sim::{Nav2SimOptions, Nav2SimThread};
use madenet_ros2::{loopback_router, Ros2Options};
use std::sync::Arc;

/// The floor plan of `size` m (map seed `seed`) with robots at `starts` (given the plan's
/// config, whose `keep_free` cells are free) served as a nav2 team at 20 × real time on a
/// loopback router of its own. The router lives as long as the first value.
pub fn plan_sim(
    size: usize,
    seed: u64,
    starts: impl Fn(&FloorPlanConfig) -> Vec<Pos>,
) -> (Box<dyn std::any::Any>, Ros2Options, Nav2SimThread) {
    let cfg = FloorPlanConfig::for_size(size, size);
    let grid = floor_plan(&cfg, seed).unwrap();
    let starts = starts(&cfg);
    let scene = Arc::new(Scene::from_grid(&grid, "plan"));
    let scenario = madenet_world::ScenarioConfig {
        num_robots: starts.len(),
        ..Default::default()
    };
    let world =
        ContinuousWorld::new(scene, &starts, scenario, ContinuousConfig::default(), seed).unwrap();
    let (router, opts) = loopback_router().unwrap();
    let sim = Nav2SimThread::spawn(
        opts.clone(),
        world,
        Nav2SimOptions {
            realtime: 20.0,
            ..Default::default()
        },
    );
    (Box::new(router), opts, sim)
}
