//! `madenet run --record DIR`: a rosbag2 folder at a new path or an empty folder, the same bytes
//! for the same seed; a taken place, an unwritable one or an unrecorded world is one `error:`
//! line naming the flag, and nothing half-written is left behind. (Readers nobody here wrote —
//! `mcap`, `mcap-ros2-support`, `rosbags` — check the bag's content in the Python tests.)

mod common;

use common::{madenet, madenet_with, madenet_with_extra, signal, spawn_piped};
use madenet_testkit::{assert_clean_error, assert_clean_error_in, assert_ok, entries, Scratch};
use std::path::Path;

fn record(to: &Path) -> std::process::Output {
    madenet_with(
        "run --map paper:2 --policy nf --seed 3 --record {}",
        &[to.to_str().unwrap()],
    )
}

/// The bag at `bag` is finished (its metadata written) and nothing hidden is left in `dir`.
fn assert_bag_finished(dir: &Path, bag: &Path) {
    let metadata = std::fs::read_to_string(bag.join("metadata.yaml")).unwrap();
    assert!(metadata.contains("message_count"), "{metadata}");
    assert!(
        entries(dir).iter().all(|e| !e.starts_with('.')),
        "{:?}",
        entries(dir)
    );
}

#[test]
fn a_run_is_recorded_the_same_for_the_same_seed() {
    let dir = Scratch::new("record-same");
    let out = record(&dir.join("a"));
    assert_ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("ROS 2 bag"));
    // An empty folder is taken as the bag's place.
    std::fs::create_dir(dir.join("b")).unwrap();
    assert!(record(&dir.join("b")).status.success());
    assert_eq!(entries(dir.join("a")), ["a_0.mcap", "metadata.yaml"]);
    assert_eq!(
        std::fs::read(dir.join("a/a_0.mcap")).unwrap(),
        std::fs::read(dir.join("b/b_0.mcap")).unwrap()
    );
    let meta = std::fs::read_to_string(dir.join("a/metadata.yaml")).unwrap();
    for needle in [
        "storage_identifier: mcap",
        "name: \"/truth_map\"",
        "type: \"nav_msgs/msg/OccupancyGrid\"",
        "name: \"/robot2/pose\"",
        "type: \"tf2_msgs/msg/TFMessage\"",
        "type: \"rosgraph_msgs/msg/Clock\"",
        "- path: \"a_0.mcap\"",
        "serialization_format: cdr",
    ] {
        assert!(meta.contains(needle), "{needle}: {meta}");
    }
    assert_eq!(entries(dir.path()), ["a", "b"], "nothing else left behind");
}

/// A `--record` path that is a symbolic link to an empty folder records into that folder; a
/// link to nothing, and a place another run is recording to, are refused at the start, before
/// the trial, and the other run's bag is whole (issue 59: both failed after the whole trial,
/// and the bag was lost).
#[test]
fn a_linked_or_shared_place_is_settled_before_the_trial() {
    let dir = Scratch::new("record-place");
    let real = dir.join("real");
    std::fs::create_dir(&real).unwrap();
    let link = dir.join("link");
    std::os::unix::fs::symlink(&real, &link).unwrap();
    assert_ok(&record(&link));
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(entries(&real), ["metadata.yaml", "real_0.mcap"]);
    let nothing = dir.join("nothing");
    std::os::unix::fs::symlink(dir.join("gone"), &nothing).unwrap();
    assert_clean_error(&record(&nothing), &["--record", "nothing"]);
    // Two runs, one place: the second is refused at once, the first finishes its bag.
    let shared = dir.join("shared");
    let mut first = spawn_piped(
        std::process::Command::new(env!("CARGO_BIN_EXE_madenet")).args([
            "run",
            "--map",
            "paper:2",
            "--policy",
            "nf",
            "--pace-ms",
            "100",
            "--record",
            shared.to_str().unwrap(),
        ]),
    );
    // Its place is taken when its hidden folder appears.
    let t0 = std::time::Instant::now();
    while !entries(dir.path())
        .iter()
        .any(|e| e.starts_with(".shared.partial"))
    {
        assert!(t0.elapsed().as_secs() < 60, "{:?}", entries(dir.path()));
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let second = record(&shared);
    assert!(
        first.try_wait().unwrap().is_none(),
        "the first run is still going"
    );
    assert_clean_error(&second, &["--record", "another madenet run"]);
    assert!(first.wait().unwrap().success());
    assert_bag_finished(dir.path(), &shared);
    assert_eq!(entries(dir.path()), ["link", "nothing", "real", "shared"]);
}

#[test]
fn a_taken_or_unwritable_place_is_refused_and_nothing_is_left_behind() {
    let dir = Scratch::new("record-bad");
    let file = dir.join("file");
    std::fs::write(&file, "mine").unwrap();
    assert_clean_error(&record(&file), &["--record", "already exists"]);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
    let full = dir.join("full");
    std::fs::create_dir(&full).unwrap();
    std::fs::write(full.join("keep.txt"), "mine").unwrap();
    assert_clean_error(&record(&full), &["--record", "already exists"]);
    assert_eq!(entries(&full), ["keep.txt"]);
    // Under a file: no folder can be made there.
    assert_clean_error(&record(&file.join("bag")), &["--record"]);
    assert_eq!(
        entries(dir.path()),
        ["file", "full"],
        "nothing half-written"
    );
}

/// `--foxglove` with an address that is not HOST:PORT or a port already taken, and pacing out
/// of range: one `error:` line naming the flag; a refused live view leaves no bag behind.
#[test]
fn bad_live_view_flags_are_refused() {
    let dir = Scratch::new("record-live");
    let bag = dir.join("bag");
    let run_with = |extra: &[&str]| madenet_with_extra("run --map paper:2 --seed 3", &[], extra);
    assert_clean_error(
        &run_with(&["--foxglove", "localhost"]),
        &["--foxglove", "HOST:PORT"],
    );
    assert_clean_error(
        &run_with(&["--foxglove", "127.0.0.1:99999"]),
        &["--foxglove", "port"],
    );
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap().to_string();
    let out = run_with(&["--foxglove", &addr, "--record", bag.to_str().unwrap()]);
    assert_clean_error(&out, &["--foxglove", &addr]);
    assert_eq!(
        entries(dir.path()),
        Vec::<String>::new(),
        "no bag left behind"
    );
    let out = madenet(&[
        "launch",
        "--map",
        "paper:2",
        "--ros2-robots",
        "--record",
        bag.to_str().unwrap(),
    ]);
    assert_clean_error(&out, &["--record/--foxglove", "--ros2-robots"]);
    // Launch refuses a taken bag place and a taken live-view port before any node starts.
    std::fs::write(&bag, "mine").unwrap();
    let launch = |extra: &[&str]| madenet_with_extra("launch --map paper:2", &[], extra);
    assert_clean_error(
        &launch(&["--record", bag.to_str().unwrap()]),
        &["--record", "already exists"],
    );
    assert_eq!(std::fs::read_to_string(&bag).unwrap(), "mine");
    std::fs::remove_file(&bag).unwrap();
    assert_clean_error(&launch(&["--foxglove", &addr]), &["--foxglove", &addr]);
    assert_clean_error(&run_with(&["--pace-ms", "60001"]), &["--pace-ms"]);
    assert_clean_error(&run_with(&["--realtime", "0"]), &["--realtime"]);
}

/// A run streamed live and recorded writes the bag it writes unstreamed; the continuous world
/// records every topic the grid's bag carries (scans and fine maps beside them), the same bytes
/// for the same seed.
#[test]
fn live_and_continuous_runs_are_recorded() {
    let dir = Scratch::new("record-both");
    let at = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let grid = |extra: &[&str]| {
        let line = "run --map paper:2 --policy spread --seed 3";
        assert_ok(&madenet_with_extra(line, &[], extra));
    };
    grid(&["--record", &at("plain")]);
    grid(&["--record", &at("live"), "--foxglove", "127.0.0.1:0"]);
    assert_eq!(
        std::fs::read(dir.join("plain/plain_0.mcap")).unwrap(),
        std::fs::read(dir.join("live/live_0.mcap")).unwrap()
    );
    let continuous = |name: &str| {
        assert_ok(&madenet_with(
            "run --world continuous --generate 2 --side 10 --seed 4 --policy spread --record {}",
            &[&at(name)],
        ));
    };
    continuous("c1");
    continuous("c2");
    assert_eq!(
        std::fs::read(dir.join("c1/c1_0.mcap")).unwrap(),
        std::fs::read(dir.join("c2/c2_0.mcap")).unwrap()
    );
    let meta = std::fs::read_to_string(dir.join("c1/metadata.yaml")).unwrap();
    // Topic parity: the continuous world's bag carries every topic the grid's does (one
    // recorder reads both worlds), and its own scans and fine maps beside them.
    let topics = |meta: &str| -> std::collections::BTreeSet<String> {
        meta.lines()
            .filter_map(|l| l.trim().strip_prefix("name: \""))
            .filter_map(|l| l.strip_suffix('"'))
            .filter(|t| t.starts_with('/'))
            .map(str::to_string)
            .collect()
    };
    let grid_topics = topics(&std::fs::read_to_string(dir.join("plain/metadata.yaml")).unwrap());
    let continuous_topics = topics(&meta);
    for t in [
        "/team_map",
        "/comms",
        "/robot0/candidates",
        "/metrics/distance",
    ] {
        assert!(grid_topics.contains(t), "{t}: {grid_topics:?}");
    }
    let missing: Vec<_> = grid_topics.difference(&continuous_topics).collect();
    assert!(missing.is_empty(), "the continuous bag lacks {missing:?}");
    for needle in [
        "name: \"/robot0/scan\"",
        "type: \"sensor_msgs/msg/LaserScan\"",
        "name: \"/robot2/map\"",
        "name: \"/metrics/explored\"",
        "name: \"/tf\"",
    ] {
        assert!(meta.contains(needle), "{needle}: {meta}");
    }
}

/// A write that fails part-way — here the file-size limit (`RLIMIT_FSIZE`, its signal
/// ignored), which fails the bag's `write` as a full disk does (`EFBIG` for `ENOSPC`) without
/// needing a full disk — in either world: one `error:` line naming `--record`, the bag's place
/// and the cause, exit 2, and nothing left behind (the hidden partial folder removed).
#[cfg(target_os = "linux")]
#[test]
fn a_write_that_fails_part_way_leaves_nothing_behind() {
    use std::os::unix::process::CommandExt;
    let dir = Scratch::new("record-fsize");
    let worlds: [&[&str]; 2] = [
        &["--map", "paper:3", "--policy", "spread", "--seed", "2"],
        &["--world", "continuous", "--generate", "3", "--side", "12"],
    ];
    for (k, world) in worlds.into_iter().enumerate() {
        let bag = dir.join(format!("bag{k}"));
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_madenet"));
        cmd.arg("run")
            .args(world)
            .args(["--record", bag.to_str().unwrap()]);
        // SAFETY: only async-signal-safe calls (setrlimit, signal) between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                let limit = libc::rlimit {
                    rlim_cur: 16 * 1024,
                    rlim_max: 16 * 1024,
                };
                if libc::setrlimit(libc::RLIMIT_FSIZE, &limit) != 0
                    || libc::signal(libc::SIGXFSZ, libc::SIG_IGN) == libc::SIG_ERR
                {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let out = cmd.output().unwrap();
        assert_clean_error_in(
            &format!("world {k}"),
            &out,
            &["--record", bag.to_str().unwrap(), "File too large"],
        );
        assert_eq!(entries(dir.path()), Vec::<String>::new(), "world {k}");
    }
}

/// `compare --record-trials`: exactly the chosen trials as bags in OUT/bags/, each the bag
/// `run --record` writes for the same trial (byte for byte); a second run keeps them, one with
/// `--fresh` replaces them with its own choice, one without `--record-trials` removes them; bad
/// conditions, a choice of nothing or of an oracle are refused before the study runs (no
/// output folder).
#[test]
fn a_study_records_the_trials_it_is_told_to() {
    let dir = Scratch::new("record-trials");
    let out = dir.join("study");
    let study = |extra: &[&str]| {
        madenet_with_extra(
            "compare --methods nf,spread --oracles none --seeds 2 --out {}",
            &[out.to_str().unwrap()],
            extra,
        )
    };
    let compare = |conditions: &[&str]| study(&[&["--record-trials"][..], conditions].concat());
    for (bad, needle) in [
        (&["team=3"][..], "unknown field `team`"),
        (&["method=nf", "seed=x"][..], "whole number"),
        (
            &["method=made-net"][..],
            "chooses none of the study's 640 trials",
        ),
    ] {
        assert_clean_error_in(
            &format!("{bad:?}"),
            &compare(bad),
            &["--record-trials", needle],
        );
        assert!(!out.exists(), "{bad:?}: refused before the study ran");
    }
    let with_oracle = madenet_with(
        "compare --methods nf --oracles placebo --seeds 1 --out {} --record-trials map=test_2",
        &[out.to_str().unwrap()],
    );
    assert_clean_error(&with_oracle, &["--record-trials", "oracle-placebo"]);
    assert!(!out.exists());

    let chosen = [
        "method=spread",
        "map=test_3|test_5",
        "start=top-right",
        "csp=0.5",
        "seed=2",
    ];
    let first = compare(&chosen);
    assert_ok(&first);
    assert!(String::from_utf8_lossy(&first.stdout).contains("2 trials recorded"));
    let bags = out.join("bags");
    let names = [
        "spread_test_3_top-right_csp0.5_seed2",
        "spread_test_5_top-right_csp0.5_seed2",
    ];
    assert_eq!(entries(&bags), names);
    let alone = dir.join("alone");
    let run = madenet_with(
        "run --map paper:5 --start top-right --policy spread --seed 2 --csp 0.5 --record {}",
        &[alone.to_str().unwrap()],
    );
    assert!(run.status.success());
    let bag = |at: &Path| {
        let name = at.file_name().unwrap().to_string_lossy().into_owned();
        std::fs::read(at.join(format!("{name}_0.mcap"))).unwrap()
    };
    assert_eq!(
        bag(&bags.join(names[1])),
        bag(&alone),
        "the study's trial, recorded"
    );
    let before = bag(&bags.join(names[0]));
    // A killed run's half-written bag (issue 59): the resume removes it.
    let leftover = bags.join(format!(".{}.partial-4000000-0", names[0]));
    std::fs::create_dir(&leftover).unwrap();
    std::fs::write(leftover.join("x_0.mcap"), b"cut").unwrap();
    let again = compare(&chosen);
    assert!(again.status.success());
    assert!(String::from_utf8_lossy(&again.stdout).contains("(0 written now)"));
    assert_eq!(bag(&bags.join(names[0])), before);
    assert_eq!(entries(&bags), names, "the leftover is gone");
    // Afresh: the bags of the new choice replace the folder once they are all written.
    let mut one = chosen.to_vec();
    one[1] = "map=test_3";
    one.push("--fresh");
    let fresh = compare(&one);
    assert!(fresh.status.success());
    assert!(String::from_utf8_lossy(&fresh.stdout).contains("1 trials recorded"));
    assert_eq!(entries(&bags), &names[..1]);
    assert_eq!(bag(&bags.join(names[0])), before);
    assert!(
        entries(&out).iter().all(|e| !e.contains("bags-")),
        "{:?}",
        entries(&out)
    );
    // Afresh without recording: the earlier study's bags go with its rows.
    let bare = study(&["--fresh"]);
    assert!(bare.status.success());
    assert!(!bags.exists());
}

/// Ctrl-C during a paced, recorded and streamed run: the run stops after its timestep, the bag
/// is finished (a bag, not a hidden partial folder), and madenet exits with 130 (SIGTERM: 143)
/// — in both worlds.
#[test]
fn ctrl_c_finishes_the_bag_of_the_run_so_far() {
    use std::io::BufRead;
    let dir = Scratch::new("record-ctrl-c");
    for (k, world) in [
        &["--map", "paper:8"][..],
        &["--world", "continuous", "--generate", "2", "--side", "12"][..],
    ]
    .into_iter()
    .enumerate()
    {
        let bag = dir.join(format!("bag{k}"));
        let mut child = spawn_piped(
            std::process::Command::new(env!("CARGO_BIN_EXE_madenet"))
                .arg("run")
                .args(world)
                .args(["--policy", "spread", "--pace-ms", "50"])
                .args(["--foxglove", "127.0.0.1:0", "--record"])
                .arg(&bag),
        );
        // The live view's address is printed once the signal is watched.
        let mut stderr = std::io::BufReader::new(child.stderr.take().unwrap());
        let mut line = String::new();
        stderr.read_line(&mut line).unwrap();
        assert!(line.contains("ws://"), "world {k}: {line}");
        std::thread::sleep(std::time::Duration::from_millis(500));
        // Ctrl-C in the grid world, SIGTERM in the continuous one.
        let (name, code) = [("-INT", 130), ("-TERM", 143)][k];
        signal(&child, name);
        let out = child.wait_with_output().unwrap();
        let mut rest = String::new();
        std::io::Read::read_to_string(&mut stderr, &mut rest).unwrap();
        assert_eq!(out.status.code(), Some(code), "world {k}: {rest}");
        assert!(rest.contains("interrupted at"), "world {k}: {rest}");
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            stdout.contains("wrote") && stdout.contains("ROS 2 bag"),
            "{stdout}"
        );
        assert_bag_finished(&dir, &bag);
    }
}

/// Ctrl-C during an unpaced run that draws pictures: the GIF and PNG hold the run up to there,
/// and no temporary file is left behind (issue 59: the default signal handler killed the run
/// mid-write).
#[test]
fn ctrl_c_finishes_the_pictures_of_an_unpaced_run() {
    let dir = Scratch::new("render-ctrl-c");
    let child = spawn_piped(
        std::process::Command::new(env!("CARGO_BIN_EXE_madenet"))
            .args([
                "run",
                "--world",
                "continuous",
                "--generate",
                "3",
                "--side",
                "40",
            ])
            .args(["--policy", "spread", "--render"])
            .arg(dir.join("run.gif"))
            .arg("--snapshot")
            .arg(dir.join("end.png")),
    );
    std::thread::sleep(std::time::Duration::from_millis(1500));
    signal(&child, "-INT");
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted at"), "{err}");
    assert_eq!(entries(dir.path()), ["end.png", "run.gif"]);
    let gif = std::fs::read(dir.join("run.gif")).unwrap();
    assert!(
        gif.starts_with(b"GIF89a") && gif.ends_with(&[0x3b]),
        "a whole GIF"
    );
}

/// Ctrl-C to `launch` (its nodes in a process group of their own): the world node ends the run
/// after its timestep and finishes the bag, the robots and the radio stop, `launch` names the
/// bag and exits with 130; nothing hidden is left beside it.
#[test]
fn ctrl_c_to_launch_finishes_the_world_nodes_bag() {
    let dir = Scratch::new("record-launch-ctrl-c");
    let bag = dir.join("bag");
    let child = spawn_piped(
        std::process::Command::new(env!("CARGO_BIN_EXE_madenet"))
            .args(["launch", "--map", "paper:8", "--policy", "spread"])
            .args(["--pace-ms", "100", "--record"])
            .arg(&bag),
    );
    // The world node watches signals before it starts its bag (a hidden folder beside it):
    // once that is there, a second more puts the paced run (≈ 6 s) in its middle.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while !entries(dir.path())
        .iter()
        .any(|e| e.starts_with(".bag.partial"))
    {
        assert!(std::time::Instant::now() < deadline, "no bag started");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(1000));
    signal(&child, "-INT");
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted at step"), "{stderr}");
    assert!(
        stdout.contains("wrote") && stdout.contains("(ROS 2 bag)"),
        "{stdout}"
    );
    // Ended early: before the trial's last timestep (the same trial in one process).
    let at: usize = stderr
        .split("interrupted at step ")
        .nth(1)
        .and_then(|r| r.split(';').next())
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or_else(|| panic!("{stderr}"));
    let whole = std::process::Command::new(env!("CARGO_BIN_EXE_madenet"))
        .args(["run", "--map", "paper:8", "--policy", "spread", "--json"])
        .output()
        .unwrap();
    let whole: serde_json::Value = serde_json::from_slice(&whole.stdout).unwrap();
    let tns = whole["metrics"]["tns"].as_u64().unwrap() as usize;
    assert!(at > 0 && at < tns, "stopped at {at} of {tns}");
    assert_bag_finished(&dir, &bag);
}
