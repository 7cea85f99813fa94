//! `madenet launch`: a trial as 5 processes (world, radio, 3 agents) over Zenoh on loopback
//! gives exactly `madenet run`'s result and trajectory.

use serde_json::Value;
use std::process::Command;

fn madenet(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_madenet"))
        .args(args)
        .output()
        .expect("madenet runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The JSON without what depends on the wall clock.
fn without_timing(mut v: Value) -> Value {
    let t = v["timing"].as_object_mut().expect("timing");
    t.remove("trial_s");
    t.remove("per_decision_s");
    v
}

#[test]
fn launch_over_processes_equals_the_in_process_run() {
    for policy in ["nf", "made-net"] {
        for (map, start) in [("paper:3", "top-right"), ("paper:8", "bottom-left")] {
            for csp in ["1", "0.5"] {
                let trial = [
                    "--map", map, "--start", start, "--policy", policy, "--csp", csp, "--seed", "2",
                ];
                let case = format!("{policy} {map} {start} csp {csp}");
                let (ok, launched, err) =
                    madenet(&[&["launch", "--json", "--trajectory"][..], &trial[..]].concat());
                assert!(ok, "{case}: {err}");
                let (ok, ran, err) =
                    madenet(&[&["run", "--json", "--trajectory"][..], &trial[..]].concat());
                assert!(ok, "{case}: {err}");
                let mut launched: Value = serde_json::from_str(&launched).unwrap();
                let mut ran: Value = serde_json::from_str(&ran).unwrap();
                // Positions at every timestep: the start, then after each step.
                let positions = launched
                    .as_object_mut()
                    .unwrap()
                    .remove("positions")
                    .expect("--trajectory adds positions");
                let runtime = launched
                    .as_object_mut()
                    .unwrap()
                    .remove("runtime")
                    .expect("what the processes add");
                assert_eq!(runtime["absent_robot_steps"], 0, "{case}");
                assert!(runtime["latency"]["acted"].as_u64().unwrap() > 0, "{case}");
                let trajectory = std::mem::take(&mut ran["trajectory"]);
                let steps = trajectory.as_array().unwrap();
                let positions = positions.as_array().unwrap();
                assert_eq!(positions.len(), steps.len() + 1, "{case}");
                assert_eq!(positions[0], ran["starts"], "{case}");
                for (k, s) in steps.iter().enumerate() {
                    assert_eq!(positions[k + 1], s["positions"], "{case}: step {}", k + 1);
                }
                ran["trajectory"] = Value::Array(Vec::new());
                assert_eq!(without_timing(launched), without_timing(ran), "{case}");
            }
        }
    }
}

#[test]
fn launch_text_output_and_bad_flags() {
    let (ok, out, err) = madenet(&["launch", "--map", "paper:5", "--policy", "spread"]);
    assert!(ok, "{err}");
    assert!(
        out.contains("TNS") && out.contains("5 processes over Zenoh"),
        "{out}"
    );
    // −0.0 is a number like any other: handed to the children in a form they parse.
    let (ok, _, err) = madenet(&["launch", "--map", "paper:5", "--csp=-0.0", "--loss=-0.0"]);
    assert!(ok, "{err}");
    // A bad trial flag is refused once, by launch itself, before any process starts.
    let (ok, _, err) = madenet(&["launch", "--policy", "nope"]);
    assert!(!ok);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("nope"), "{err}");
    let (ok, _, err) = madenet(&["agent", "--port", "40000", "--robot", "3"]);
    assert!(!ok);
    assert!(err.contains("--robot 3") && err.contains("0 to 2"), "{err}");
    let (ok, _, err) = madenet(&["launch", "--port", "65534"]);
    assert!(!ok);
    assert!(err.contains("--port") && err.contains("65535"), "{err}");
    let (ok, _, err) = madenet(&["world", "--port", "40000", "--run", "a/b"]);
    assert!(!ok);
    assert!(err.contains("run name"), "{err}");
}

#[test]
fn a_node_whose_peers_never_come_gives_up_naming_them() {
    // A radio alone: its robots never appear; it says so within its timeout.
    let port = madenet_runtime::zenoh_bus::free_port_block(5)
        .unwrap()
        .to_string();
    let started = std::time::Instant::now();
    let (ok, _, err) = madenet(&["radio", "--port", &port, "--timeout-s", "1"]);
    assert!(!ok);
    assert!(started.elapsed().as_secs() < 20, "bounded wait");
    assert!(
        err.contains("robot 0") && err.contains("no connection"),
        "{err}"
    );
}

#[test]
fn launch_draws_the_same_pictures_as_run() {
    // The world node draws its side (truth, team map, positions, what each robot sees) and what
    // each agent process reports after its move (goal, path, candidates, exchanges): the GIF and
    // the PNG are byte for byte `run`'s.
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    for policy in ["nf", "made-net"] {
        let trial = [
            "--map",
            "paper:8",
            "--start",
            "bottom-left",
            "--policy",
            policy,
            "--csp",
            "0.5",
            "--seed",
            "3",
            "--cell-px",
            "6",
        ];
        let (gif_l, png_l, gif_r, png_r) =
            (path("l.gif"), path("l.png"), path("r.gif"), path("r.png"));
        let (ok, out, err) = madenet(
            &[
                &["launch", "--render", &gif_l, "--snapshot", &png_l][..],
                &trial[..],
            ]
            .concat(),
        );
        assert!(ok, "{policy}: {err}");
        assert!(out.contains(&format!("wrote      {gif_l}")), "{out}");
        let (ok, _, err) = madenet(
            &[
                &["run", "--render", &gif_r, "--snapshot", &png_r][..],
                &trial[..],
            ]
            .concat(),
        );
        assert!(ok, "{policy}: {err}");
        let gif = std::fs::read(&gif_l).unwrap();
        assert!(gif.len() > 1000, "{policy}: a GIF of {} bytes", gif.len());
        assert!(
            gif == std::fs::read(&gif_r).unwrap(),
            "{policy}: the GIFs differ"
        );
        assert!(
            std::fs::read(&png_l).unwrap() == std::fs::read(&png_r).unwrap(),
            "{policy}: the PNGs differ"
        );
    }
}
