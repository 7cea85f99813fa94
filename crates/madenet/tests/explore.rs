//! `madenet explore`: the parameter file as a ROS node reads it (`--check`), one clear error
//! per bad input, and the node exploring a simulated nav2 robot's floor plan as a process
//! (`run --world continuous --nav2` serving it), through a zenoh router alone.

mod common;

use common::{signal, spawn_piped};
use madenet_testkit::{assert_clean_error_in, assert_ok, Scratch};
use std::path::Path;
use std::process::{Child, Command, Stdio};

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
    let unknown_policy = dir.join("policy.yaml");
    std::fs::write(
        &unknown_policy,
        "/**:\n  ros__parameters:\n    policy: no-such-policy\n",
    )
    .unwrap();
    let other = other.to_str().unwrap();
    let typo = typo.to_str().unwrap();
    let unknown_policy = unknown_policy.to_str().unwrap();
    let cases: [(&str, Vec<&str>, &[&str]); 6] = [
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
        (
            "a remapping without :=",
            vec!["--params-file", FIXTURE, "-r", "map", "--check"],
            &["--remap", "from:=to"],
        ),
        (
            "an unknown policy",
            vec!["--params-file", FIXTURE, "--params-file", unknown_policy],
            &[
                "--params-file",
                "policy",
                "no-such-policy",
                "unknown",
                "spread",
            ],
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
    // The rest is drained: a full pipe would block the sim.
    std::thread::spawn(move || std::io::copy(&mut stderr, &mut std::io::sink()));
    let params = dir.join("explore.yaml");
    std::fs::write(
        &params,
        "/**:\n  ros__parameters:\n    costmap_topic: map\n    costmap_updates_topic: map_updates\n    planner_frequency: 1.0\n    potential_scale: 3.0\n    use_sim_time: true\n",
    )
    .unwrap();
    let node_log = dir.join("node.log");
    let node = spawn_logged(
        Command::new(env!("CARGO_BIN_EXE_madenet"))
            .args(["explore", "--params-file", params.to_str().unwrap()])
            .args(["--namespace", "/robot0", "--ros2", &endpoint]),
        &node_log,
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
    let log = read_log(&node_log);
    assert!(
        log.contains("waiting for") || text.contains("succeeded"),
        "{log}"
    );
    let sim_text = String::from_utf8_lossy(&sim_out.stdout);
    let explored = sim_explored(&sim_text);
    eprintln!("{text}{sim_text}");
    assert!(explored >= 95.0, "{sim_text}");
}

/// The sim's summary (`run --nav2` at Ctrl-C): asserts no collision; the explored percentage.
fn sim_explored(sim_text: &str) -> f64 {
    assert!(
        sim_text.contains("collisions 0 with obstacles, 0 between robots"),
        "{sim_text}"
    );
    sim_text
        .split("explored   ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{sim_text}"))
}

/// A free loopback endpoint (bound and released: another program could take it in between).
fn free_endpoint() -> String {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    format!("tcp/127.0.0.1:{port}")
}

/// Spawns `cmd` with stdout piped and stderr written to `log`: a file, not a pipe, which a
/// chatty process fills (64 KB) while the test waits, and then blocks on for ever (the kill
/// test's nodes once did, at 900 s).
fn spawn_logged(cmd: &mut Command, log: &Path) -> Child {
    cmd.stdout(Stdio::piped())
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .unwrap()
}

/// What a process wrote to `log` ([`spawn_logged`]).
fn read_log(log: &Path) -> String {
    String::from_utf8_lossy(&std::fs::read(log).unwrap_or_default()).into_owned()
}

/// Waits for `child` to exit on its own; after `secs` seconds, interrupts it and `all` and
/// fails, with the end of each of `logs`.
fn wait_for(child: &mut Child, secs: u64, what: &str, all: &[&Child], logs: &[&Path]) {
    let started = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed().as_secs() > secs {
            for c in all.iter().copied().chain([&*child]) {
                signal(c, "-INT");
            }
            let tails: Vec<String> = (logs.iter())
                .map(|l| {
                    let text = read_log(l);
                    let lines: Vec<&str> = text.lines().collect();
                    let tail = lines[lines.len().saturating_sub(40)..].join("\n");
                    format!("{}:\n{tail}", l.display())
                })
                .collect();
            panic!(
                "{what} did not finish within {secs} s\n{}",
                tails.join("\n")
            );
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
}

/// The issue's first check: `run --world continuous --nav2 --explore` runs three `madenet
/// explore` processes beside the simulated nav2 team, this run hosting the router; the team
/// explores a generated 20 m floor plan and every node ends on its own, with no collision,
/// and `--record` writes the bag.
#[test]
fn three_explore_processes_and_the_nav2_sim_explore_a_20_m_plan() {
    let dir = Scratch::new("explore-team");
    let bag = dir.join("bag");
    let log = dir.join("run.log");
    let mut run = spawn_logged(
        Command::new(env!("CARGO_BIN_EXE_madenet"))
            .args(["run", "--world", "continuous", "--map", "floorplan:4"])
            .args([
                "--realtime",
                "10",
                "--json",
                "--record",
                bag.to_str().unwrap(),
            ])
            .args(["--nav2", &free_endpoint(), "--explore", "spread"]),
        &log,
    );
    // The wall-clock bound is generous: the run goes at 10 × real time only while the machine
    // keeps up (3.6 × was seen on a loaded one), and the nodes' tail after the map is covered
    // (blacklisted frontiers waiting out 120 s) can take 1 000 s simulated.
    wait_for(&mut run, 900, "the team", &[], &[&log]);
    let out = run.wait_with_output().unwrap();
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stdout)));
    eprintln!("{v:#}");
    assert_eq!(v["robots"], 3);
    assert_eq!(v["nodes_complete"], true, "{v:#}");
    // On failure, what the sim and the nodes said.
    let explored = v["explored"].as_f64().unwrap();
    assert!(explored >= 0.99, "{v:#}\n{}", read_log(&log));
    assert!(v["covered_99_s"].as_f64().is_some(), "{v:#}");
    assert_eq!(v["obstacle_collisions"], 0, "{v:#}");
    assert_eq!(v["robot_collisions"], 0, "{v:#}");
    assert!(bag.join("metadata.yaml").is_file());
}

/// No central node: three `madenet explore` processes and the sim through a router; one node
/// is killed (SIGKILL) mid-run, and the other two still explore the whole plan.
#[test]
fn with_one_explore_process_killed_the_other_two_finish_the_map() {
    let (_router, opts) = madenet_ros2::loopback_router().unwrap();
    let endpoint = opts.connect[0].clone();
    let dir = Scratch::new("explore-kill");
    let sim = spawn_logged(
        Command::new(env!("CARGO_BIN_EXE_madenet"))
            .args(["run", "--world", "continuous", "--map", "floorplan:4"])
            .args(["--realtime", "10", "--nav2", &endpoint]),
        &dir.join("sim.log"),
    );
    let params = dir.join("team.yaml");
    std::fs::write(
        &params,
        madenet_explore::launch::team_params(3, "spread", true),
    )
    .unwrap();
    let logs: Vec<_> = (0..3).map(|i| dir.join(format!("node{i}.log"))).collect();
    let mut nodes: Vec<_> = (0..3)
        .map(|i| {
            spawn_logged(
                Command::new(env!("CARGO_BIN_EXE_madenet"))
                    .args(["explore", "--params-file", params.to_str().unwrap()])
                    .args(["--namespace", &format!("/robot{i}"), "--ros2", &endpoint]),
                &logs[i],
            )
        })
        .collect();
    // Killed at 80 s of simulated time (the team is well under way), read from `/clock`: a
    // wall-clock delay would kill it earlier in simulated time on a loaded machine, where its
    // robot, parked at its last goal, can seal a teammate into a corner.
    let ctx = opts.context().unwrap();
    let watcher = ctx.create_node("kill_timer").unwrap();
    let clock = watcher
        .create_sub::<madenet_ros2::msgs::Clock>("/clock", madenet_ros2::QosProfile::default())
        .unwrap();
    let started = std::time::Instant::now();
    loop {
        let t = clock
            .recv_timeout(std::time::Duration::from_millis(200))
            .unwrap();
        if t.is_some_and(|c| c.clock.sec >= 80) {
            break;
        }
        assert!(
            started.elapsed().as_secs() < 300,
            "no 80 s on /clock in 300 s"
        );
    }
    drop(clock);
    let mut killed = nodes.remove(1);
    killed.kill().unwrap();
    killed.wait().unwrap();
    for (k, node) in nodes.iter_mut().enumerate() {
        let log = &logs[if k == 0 { 0 } else { 2 }];
        wait_for(node, 900, &format!("node {k}"), &[&sim], &[log]);
    }
    signal(&sim, "-INT");
    let sim_out = sim.wait_with_output().unwrap();
    for node in nodes {
        let out = node.wait_with_output().unwrap();
        assert_ok(&out);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains("complete: no frontier left"), "{text}");
    }
    let sim_text = String::from_utf8_lossy(&sim_out.stdout);
    eprintln!("{sim_text}");
    // On failure, what the two nodes said (their goals, give-ups and blacklists).
    let said = format!("{}\n{}", read_log(&logs[0]), read_log(&logs[2]));
    assert!(sim_explored(&sim_text) >= 99.0, "{sim_text}\n{said}");
}

/// A robot for the node made by hand: its map (in `map_frame`) on `/robot0/map` and its pose
/// as TF (`map → base_link`) every 50 ms, and no navigation server; and, on `/robot1`'s
/// `explore/pose`, a teammate flooding messages. Runs until `stop`.
fn fake_robot(
    endpoint: &str,
    map_frame: &str,
    flood: bool,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> std::thread::JoinHandle<()> {
    use madenet_ros2::map_updates::MapPublisher;
    use madenet_ros2::msgs::{Header, OccupancyGrid, PoseStamped, Time};
    use madenet_ros2::tf::{planar, TfNaming, TfPublisher};
    let opts = madenet_ros2::Ros2Options {
        connect: vec![endpoint.to_string()],
        ..Default::default()
    };
    let map_frame = map_frame.to_string();
    std::thread::spawn(move || {
        let ctx = opts.context().unwrap();
        let node = ctx.create_node_in("/robot0", "fake_nav2").unwrap();
        let mut map = MapPublisher::new(&node, "map").unwrap();
        let tf = TfPublisher::new(&node, TfNaming::NamespacedTopics).unwrap();
        let mate = ctx.create_node_in("/robot1", "flood").unwrap();
        let pose = mate
            .create_pub::<PoseStamped>("explore/pose", madenet_ros2::QosProfile::default())
            .unwrap();
        let mut grid = OccupancyGrid {
            header: Header {
                stamp: Time::default(),
                frame_id: map_frame,
            },
            data: vec![-1; 100 * 100],
            ..Default::default()
        };
        (grid.info.width, grid.info.height, grid.info.resolution) = (100, 100, 0.1);
        // A seen 3 m square around the robot at (5, 5): frontiers all round.
        for r in 35..65 {
            for c in 35..65 {
                grid.data[r * 100 + c] = 0;
            }
        }
        let mut k = 0u32;
        while !stop.load(std::sync::atomic::Ordering::Relaxed) {
            k += 1;
            let stamp = Time {
                sec: (k / 20) as i32,
                nanosec: (k % 20) * 50_000_000,
            };
            grid.header.stamp = stamp;
            map.publish(&grid).unwrap();
            tf.send(vec![planar("map", "base_link", stamp, 5.0, 5.0, 0.0)])
                .unwrap();
            if flood {
                for _ in 0..500 {
                    let mut p = PoseStamped::default();
                    p.header.frame_id = "map".into();
                    pose.publish(&p).unwrap();
                }
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
    })
}

/// Bad input while running, each named in the log, never a panic: a map in another frame
/// than TF's; a goal server that never answers; a teammate flooding messages.
#[test]
fn a_node_names_what_is_wrong_with_its_robot() {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    let (_router, opts) = madenet_ros2::loopback_router().unwrap();
    let endpoint = opts.connect[0].clone();
    let dir = Scratch::new("explore-wrong");
    let params = dir.join("p.yaml");
    std::fs::write(
        &params,
        "/**:\n  ros__parameters:\n    costmap_topic: map\n    costmap_updates_topic: map_updates\n    teammates: [/robot1]\n    policy: spread\n",
    )
    .unwrap();
    for (frame, flood, secs, needles) in [
        (
            "world",
            false,
            8,
            &["still no pose", "\"world\"", "/robot0/map"][..],
        ),
        (
            "map",
            true,
            14,
            &["navigate_to_pose did not answer", "/robot1 floods"][..],
        ),
    ] {
        let stop = Arc::new(AtomicBool::new(false));
        let robot = fake_robot(&endpoint, frame, flood, stop.clone());
        let node = spawn_piped(
            Command::new(env!("CARGO_BIN_EXE_madenet"))
                .args(["explore", "--params-file", params.to_str().unwrap()])
                .args(["--namespace", "/robot0", "--ros2", &endpoint]),
        );
        std::thread::sleep(std::time::Duration::from_secs(secs));
        signal(&node, "-INT");
        let out = node.wait_with_output().unwrap();
        stop.store(true, Ordering::Relaxed);
        robot.join().unwrap();
        let log = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{frame}: {log}");
        assert!(!log.contains("panicked"), "{log}");
        for n in needles {
            assert!(log.contains(n), "{frame}: no {n:?} in\n{log}");
        }
    }
}
