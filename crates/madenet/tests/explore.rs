//! `madenet explore`: the parameter file as a ROS node reads it (`--check`), one clear error
//! per bad input, and the node exploring a simulated nav2 robot's floor plan as a process
//! (`run --world continuous --nav2` serving it), through a zenoh router alone.

mod common;

use common::{signal, spawn_piped};
use madenet_testkit::{assert_clean_error_in, assert_ok, Scratch};
use std::process::Command;

const FIXTURE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../drivers/explore/tests/fixtures/explore_lite.yaml"
);

fn explore(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_madenet"))
        .arg("explore")
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn check_prints_the_parameters_that_apply_to_the_node() {
    let out = explore(&[
        "--params-file",
        FIXTURE,
        "--namespace",
        "/robot0",
        "--check",
    ]);
    assert_ok(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("/robot0/explore_node"), "{text}");
    assert!(text.contains("planner_frequency: 0.15"), "{text}");
    assert!(text.contains("policy: \"spread\""), "{text}");
}

#[test]
fn bad_input_gets_one_clear_error() {
    let dir = Scratch::new("explore-bad");
    let other = dir.join("slam.yaml");
    std::fs::write(
        &other,
        "slam_toolbox:\n  ros__parameters:\n    resolution: 0.05\n",
    )
    .unwrap();
    let typo = dir.join("typo.yaml");
    std::fs::write(
        &typo,
        "/**:\n  ros__parameters:\n    planner_frequncy: 0.5\n",
    )
    .unwrap();
    let other = other.to_str().unwrap();
    let typo = typo.to_str().unwrap();
    let cases: [(&str, Vec<&str>, &[&str]); 5] = [
        (
            "another node's file",
            vec!["--params-file", other, "--check"],
            &["--params-file", "no section applies", "/explore_node"],
        ),
        (
            "a typo",
            vec!["--params-file", typo, "--check"],
            &["planner_frequncy", "unknown"],
        ),
        (
            "a bad namespace",
            vec!["--params-file", FIXTURE, "--namespace", "robot 0"],
            &["--namespace", "robot 0"],
        ),
        (
            "a missing file",
            vec!["--params-file", "/nonexistent.yaml", "--check"],
            &["--params-file", "/nonexistent.yaml"],
        ),
        // The fixture's /robot0 section asks for spread: not in the node yet.
        (
            "a policy the node does not run",
            vec!["--params-file", FIXTURE, "--namespace", "/robot0"],
            &["policy", "spread", "explore-lite"],
        ),
    ];
    for (case, args, needles) in cases {
        assert_clean_error_in(case, &explore(&args), needles);
    }
}

/// The simulated nav2 robot (`run --world continuous --nav2`) and `madenet explore` as two
/// processes through a zenoh router: the node explores the floor plan and ends on its own
/// ("no frontier left"); Ctrl-C then ends the sim, which counts its goals, with no collision.
#[test]
fn the_node_explores_a_simulated_nav2_robots_floor_plan() {
    use std::io::BufRead;
    let (_router, opts) = madenet_ros2::loopback_router().unwrap();
    let endpoint = opts.connect[0].clone();
    let dir = Scratch::new("explore-sim");
    let config = dir.join("one.toml");
    std::fs::write(&config, "num_robots = 1\n").unwrap();
    // Two rooms joined by a 2 m door.
    let map = dir.join("rooms.txt");
    let rows = [
        "..........",
        "..........",
        "..........",
        "####..####",
        "..........",
        "..........",
    ];
    std::fs::write(&map, rows.join("\n") + "\n").unwrap();
    let mut sim = spawn_piped(
        Command::new(env!("CARGO_BIN_EXE_madenet"))
            .args([
                "run",
                "--world",
                "continuous",
                "--map",
                map.to_str().unwrap(),
            ])
            .args(["--config", config.to_str().unwrap(), "--realtime", "20"])
            .args(["--nav2", &endpoint]),
    );
    let mut stderr = std::io::BufReader::new(sim.stderr.take().unwrap());
    let mut line = String::new();
    stderr.read_line(&mut line).unwrap();
    assert!(line.contains("navigate_to_pose"), "{line}");
    let params = dir.join("explore.yaml");
    std::fs::write(
        &params,
        "/**:\n  ros__parameters:\n    costmap_topic: map\n    costmap_updates_topic: map_updates\n    planner_frequency: 1.0\n    potential_scale: 3.0\n    use_sim_time: true\n",
    )
    .unwrap();
    let node = spawn_piped(
        Command::new(env!("CARGO_BIN_EXE_madenet"))
            .args(["explore", "--params-file", params.to_str().unwrap()])
            .args(["--namespace", "/robot0", "--ros2", &endpoint]),
    );
    // It ends on its own; a watchdog stops it (and fails the test) after 120 s.
    let started = std::time::Instant::now();
    let mut node = node;
    while node.try_wait().unwrap().is_none() {
        if started.elapsed().as_secs() > 120 {
            signal(&node, "-INT");
            signal(&sim, "-INT");
            panic!("the node did not finish within 120 s");
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
    let out = node.wait_with_output().unwrap();
    signal(&sim, "-INT");
    let sim_out = sim.wait_with_output().unwrap();
    assert_ok(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("complete: no frontier left"), "{text}");
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(
        log.contains("waiting for") || text.contains("succeeded"),
        "{log}"
    );
    let sim_text = String::from_utf8_lossy(&sim_out.stdout);
    assert!(
        sim_text.contains("collisions 0 with obstacles, 0 between robots"),
        "{sim_text}"
    );
    let explored: f64 = sim_text
        .split("explored   ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{sim_text}"));
    eprintln!("{text}{sim_text}");
    assert!(explored >= 95.0, "{sim_text}");
}
