//! The exploration node against a simulated nav2 robot (the continuous world serving
//! `navigate_to_pose`), through ROS 2 alone: it explores a generated floor plan.

mod common;

use madenet_explore::node;
use madenet_explore::params::ExploreParams;
use madenet_ros2::msgs::{Bool, Marker, MarkerArray};
use madenet_ros2::QosProfile;
use std::sync::atomic::Ordering;
use std::time::Duration;

#[test]
fn one_node_explores_a_floor_plan_through_its_nav2() {
    let (router, opts, sim) = common::plan_sim(14, 3, |cfg| vec![cfg.keep_free[0]]);
    let stop = sim.stop_flag();
    let params = ExploreParams::from_yaml(
        "/**:\n  ros__parameters:\n    costmap_topic: map\n    costmap_updates_topic: map_updates\n    planner_frequency: 1.0\n    potential_scale: 3.0\n    use_sim_time: true\n    visualize: true\n",
        "/robot0/explore_node",
    )
    .unwrap();
    // A watchdog: 120 s. The node explores the plan well within it, but its last leftovers
    // (frontiers it cannot see, each aborted, blacklisted 120 s simulated, retried, and
    // aborted again) take a tail of simulated time that depends on timing: 810 s here, 2 972 s
    // in one CI run. Completion itself is checked in `crates/madenet/tests/explore.rs`.
    let watchdog = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let t = std::time::Instant::now();
            while !stop.load(Ordering::Relaxed) && t.elapsed().as_secs() < 120 {
                std::thread::sleep(std::time::Duration::from_millis(200));
            }
            stop.store(true, Ordering::Relaxed);
        })
    };
    // A viewer of explore/frontiers and a user pausing and resuming the node.
    let viewer = {
        let opts = opts.clone();
        let stop = stop.clone();
        std::thread::spawn(move || {
            let ctx = opts.context().unwrap();
            let node = ctx.create_node("viewer").unwrap();
            let shown = node
                .create_sub::<MarkerArray>("/robot0/explore/frontiers", QosProfile::default())
                .unwrap();
            let resume = node
                .create_pub::<Bool>("/robot0/explore/resume", QosProfile::default())
                .unwrap();
            let next = |wait: u64| shown.recv_timeout(Duration::from_secs(wait)).unwrap();
            let first = next(60).expect("markers on explore/frontiers");
            let options = &first.markers[1];
            assert_eq!(first.markers[0].action, Marker::DELETEALL);
            assert_eq!(
                (options.ns.as_str(), options.kind),
                ("frontiers", Marker::SPHERE_LIST)
            );
            assert!(!options.points.is_empty(), "{first:?}");
            assert_eq!(options.header.frame_id, "map");
            resume.publish(&Bool { data: false }).unwrap();
            // Paused: it plans no more (a second for a turn in flight), so shows nothing.
            std::thread::sleep(Duration::from_secs(1));
            while shown.recv_timeout(Duration::ZERO).unwrap().is_some() {}
            let during = next(2);
            resume.publish(&Bool { data: true }).unwrap();
            let after = next(30);
            if stop.load(Ordering::Relaxed) {
                return (false, true);
            }
            (during.is_none(), after.is_some())
        })
    };
    let run = node::run(&opts, "/robot0", &params, &[], &|| {
        stop.load(Ordering::Relaxed)
    })
    .unwrap();
    let (quiet_when_paused, shown_after) = viewer.join().unwrap();
    assert!(quiet_when_paused, "markers while paused");
    assert!(shown_after, "no markers after resuming");
    assert!(run.paused <= 1, "{run:?}");
    let truth = sim.stop().unwrap();
    watchdog.join().unwrap();
    drop(router);
    eprintln!(
        "{run:?}; {:.0} s simulated, explored {:.3}",
        truth.time, truth.explored
    );
    // The paper's cell rule reads 98.7–99.4 % of this plan's explorable cells from the robot's
    // 0.1 m map (the last 1–2 of 156 cells: see issue 58's notes).
    assert!(truth.explored >= 0.98, "explored {}", truth.explored);
    assert_eq!(truth.collisions.obstacle + truth.collisions.robot, 0);
    // How many goals end reached rather than preempted by a nearer frontier depends on timing
    // (1 of 45 in one CI run): the node drove the robot by several goals, each accounted for.
    assert!(run.sent >= 3, "{run:?}");
    let ended = run.succeeded + run.aborted + run.given_up + run.preempted + run.paused;
    assert!(ended + 1 >= run.sent && ended <= run.sent, "{run:?}");
}
