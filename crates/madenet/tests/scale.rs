//! `madenet scale` end to end: a tiny grid prints its report's path and writes every output, the
//! shipped agnostic model plays every side and team of it, and bad input gives exit code 2 and
//! one `error:` line naming the flag or file and field.

mod common;

use common::{madenet, madenet_with};
use madenet_testkit::{assert_clean_error, assert_ok, Scratch};
use std::path::PathBuf;
use std::process::Output;

/// A scratch folder tagged `tag` and `madenet` run with `line`, its `{}` the folder's `s`, which
/// must succeed: the folder, `s` and the output.
fn scale_ok(tag: &str, line: &str) -> (Scratch, PathBuf, Output) {
    let dir = Scratch::new(tag);
    let out = dir.join("s");
    let r = madenet_with(line, &[out.to_str().unwrap()]);
    assert_ok(&r);
    (dir, out, r)
}

#[test]
fn tiny_grid_with_the_agnostic_model_and_bad_input() {
    let (dir, out, r) = scale_ok(
        "scale-cli",
        "scale --out {} --sides 14,24 --teams 2,4 --seeds 1 --csp 0.5 --methods made-net-any,nf --threads 2",
    );
    let o = out.to_str().unwrap();
    let stdout = String::from_utf8_lossy(&r.stdout);
    // (2 methods + the known-map reference) × 2 sides × 4 maps × 3 starts × 2 teams × 1 seed.
    assert!(
        stdout.starts_with("144 trials → ") && stdout.contains("scale.md"),
        "{stdout}"
    );
    let report = std::fs::read_to_string(out.join("scale.md")).unwrap();
    assert!(
        report.contains("## 24 × 24") && report.contains("| made-net-any |"),
        "{report}"
    );
    let trials = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    assert_eq!(trials.lines().count(), 145);
    assert!(trials
        .lines()
        .any(|l| l.starts_with("made-net-any,side24-map3,middle:4,0.5,")));
    assert!(trials
        .lines()
        .skip(1)
        .all(|l| l.split(',').nth(3) == Some("0.5")));
    assert!(out.join("fig7_scalability.png").exists() && out.join("cells.csv").exists());

    assert_clean_error(
        &madenet(&["scale", "--out", o, "--teams", "0"]),
        &["--teams"],
    );
    assert_clean_error(
        &madenet(&["scale", "--out", o, "--csp", "1.5"]),
        &["--csp", "1.5"],
    );
    assert_clean_error(
        &madenet(&["scale", "--out", o, "--methods", "teleport"]),
        &["--methods", "teleport"],
    );
    let bad = dir.write("bad.toml", "sides = [20]\nseeds = \"three\"\n");
    assert_clean_error(
        &madenet(&["scale", "--config", bad.to_str().unwrap(), "--out", o]),
        &["bad.toml", "seeds", "line 2"],
    );
}

#[test]
fn the_continuous_world_runs_from_the_flag_and_a_bad_world_is_refused() {
    let (_dir, out, r) = scale_ok(
        "scale-cont",
        "scale --world continuous --out {} --sides 12 --teams 2 --seeds 1 --methods spread",
    );
    // 1 method × 1 scene × 3 starts × 1 team × 1 seed.
    assert!(String::from_utf8_lossy(&r.stdout).starts_with("3 trials → "));
    let trials = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    assert!(
        trials.lines().next().unwrap().contains(",et_s,"),
        "{trials}"
    );
    let report = std::fs::read_to_string(out.join("scale.md")).unwrap();
    assert!(report.contains("(continuous world)"), "{report}");
    // No known-map reference in the continuous world, so no headroom figure.
    assert!(out.join("fig7_scalability.png").exists() && !out.join("fig_headroom.png").exists());
    // The grid twin's folder says what it holds (its config is the study's).
    let twin = std::fs::read_to_string(out.join("grid").join("scale.toml")).unwrap();
    assert!(
        twin.starts_with("# The grid twin of ../scale.toml"),
        "{twin}"
    );
    let twin_trials = std::fs::read_to_string(out.join("grid").join("trials.csv")).unwrap();
    assert_eq!(twin_trials.lines().count(), 4, "{twin_trials}");
    let bad = madenet_with("scale --world gazebo --out {}", &[out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--world") && !err.contains("panicked"),
        "{err}"
    );
}

#[test]
fn the_configs_baseline_parameters_are_the_ones_played() {
    // PB with one iteration of its planner and with the paper's 50, on the same trials: the
    // tables differ (before, `madenet scale` played the defaults whatever `[baselines]` said).
    let dir = Scratch::new("scale-pb");
    let trials = |iterations: u32| {
        let cfg = dir.join(format!("pb{iterations}.toml"));
        std::fs::write(
            &cfg,
            format!("methods = [\"pb\"]\nsides = [20]\nteams = [3]\nseeds = 2\n[baselines.pb]\niterations = {iterations}\n"),
        )
        .unwrap();
        let out = dir.join(format!("out{iterations}"));
        let r = madenet_with(
            "scale --config {} --out {} --threads 2",
            &[cfg.to_str().unwrap(), out.to_str().unwrap()],
        );
        assert_ok(&r);
        let text = std::fs::read_to_string(out.join("trials.csv")).unwrap();
        // Everything but the wall-clock columns.
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let keep: Vec<usize> = (0..header.len())
            .filter(|&k| !header[k].ends_with("_s") || header[k] == "et_s")
            .collect();
        text.lines()
            .skip(1)
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                keep.iter().map(|&k| f[k]).collect::<Vec<_>>().join(",")
            })
            .collect::<Vec<_>>()
    };
    let (one, fifty) = (trials(1), trials(50));
    assert_eq!(one.len(), fifty.len());
    assert_ne!(one, fifty, "[baselines.pb] iterations had no effect");
}

/// Off a terminal (stderr to a file or pipe, as `2>log`) a study prints a progress line at
/// least every 10 s — done/total, rate, time so far, ETA — where the bar would be (issue 60:
/// `compare 2>log` was silent for 12 minutes).
#[test]
fn a_study_off_a_terminal_prints_progress_lines() {
    let dir = Scratch::new("scale-progress");
    let out = dir.join("s");
    let start = std::time::Instant::now();
    let r = madenet_with(
        "scale --world continuous --out {} --sides 40 --teams 4,6 --seeds 1 --methods nf,spread",
        &[out.to_str().unwrap()],
    );
    let took = start.elapsed().as_secs();
    assert_ok(&r);
    let err = String::from_utf8_lossy(&r.stderr);
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("progress")).collect();
    assert!(
        took < 10 || lines.len() as u64 >= took / 10,
        "{took} s: {err}"
    );
    assert!(took < 6 || !lines.is_empty(), "{took} s: {err}");
    // The count is the study's own trials, as its last line says (the grid twin's, which
    // take milliseconds, are not in it: a count of both once read 1 800 for a study of 900).
    let said = String::from_utf8_lossy(&r.stdout);
    assert!(said.contains("12 trials →"), "{said}");
    for l in &lines {
        assert!(
            l.contains("/12 trials") && l.contains("trials/s") && l.contains("so far"),
            "{l}"
        );
    }
}
