//! `madenet compare` end to end: a small study prints its report's path and writes its
//! outputs; running it again resumes (no trial runs twice); bad input gives exit code 2 and one
//! `error:` line naming the field, before any trial runs.

mod common;

use common::{madenet, madenet_with};
use madenet_testkit::{assert_clean_error, assert_curves_close, assert_ok, Scratch};
use std::path::Path;
use std::process::Command;

const SMALL: &str = r#"methods = ["nf", "ub"]
maps = ["paper:1", "paper:2"]
starts = ["top-left", "bottom-right"]
csp = [1.0, 0.0]
seeds = 2
oracles = []
"#;

fn write(path: &Path, text: &str) -> String {
    std::fs::write(path, text).unwrap();
    path.display().to_string()
}

/// The rows of a CSV file (header first) without the wall-clock columns `trial_s` and
/// `per_decision_s`, which differ between runs.
fn deterministic_rows(path: &Path) -> Vec<Vec<String>> {
    let mut rdr = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| header[i] != "trial_s" && header[i] != "per_decision_s")
        .collect();
    assert_eq!(keep.len(), header.len() - 2, "{header:?}");
    let mut rows = vec![keep.iter().map(|&i| header[i].clone()).collect::<Vec<_>>()];
    for r in rdr.records() {
        let r = r.unwrap();
        rows.push(keep.iter().map(|&i| r[i].to_string()).collect());
    }
    rows
}

/// `madenet compare --config <cfg> --out <out> --threads <threads>`'s arguments.
fn study_args(cfg: &str, out: &Path, threads: &str) -> Vec<String> {
    let out = out.to_str().unwrap();
    let args = [
        "compare",
        "--config",
        cfg,
        "--out",
        out,
        "--threads",
        threads,
    ];
    args.iter().map(|s| s.to_string()).collect()
}

#[test]
fn compare_writes_the_study_and_a_second_run_resumes_without_rerunning() {
    let dir = Scratch::new("ok");
    let cfg = write(&dir.path().join("study.toml"), SMALL);
    let out = dir.path().join("results");
    let args = study_args(&cfg, &out, "2");
    let first = madenet(&args);
    let stdout = String::from_utf8_lossy(&first.stdout);
    assert_ok(&first);
    let report = out.join("report.md");
    assert!(
        stdout.contains(&report.display().to_string()),
        "the report's path is printed: {stdout}"
    );
    assert!(stdout.contains("32 trials"), "{stdout}");
    for f in [
        "trials.csv",
        "curves.jsonl",
        "summary.md",
        "summary.csv",
        "statistics.md",
        "statistics.csv",
        "fig4_metrics.png",
        "fig4_metrics.svg",
        "fig5_exploration.png",
        "fig5_exploration.svg",
        "report.md",
        "study.toml",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let rows = deterministic_rows(&out.join("trials.csv"));
    assert_eq!(rows.len(), 1 + 32);
    let trials_1 = std::fs::read(out.join("trials.csv")).unwrap();
    let curves_1 = std::fs::read_to_string(out.join("curves.jsonl")).unwrap();
    assert_eq!(curves_1.lines().count(), 32);

    // Again, identically: every trial is already recorded, so none runs, and trials.csv is
    // byte-identical, wall-clock columns included (a rerun trial would have new timings).
    let second = madenet(&args);
    assert_ok(&second);
    assert!(String::from_utf8_lossy(&second.stdout).contains(&report.display().to_string()));
    assert_eq!(deterministic_rows(&out.join("trials.csv")), rows);
    assert_eq!(
        std::fs::read(out.join("trials.csv")).unwrap(),
        trials_1,
        "no trial ran again"
    );
    // Same curves; compared as numbers because resuming may change the last digit of a float
    // (madenet-study tests/study.rs `resumed_curves_are_byte_identical`, a known bug).
    assert_curves_close(
        &std::fs::read_to_string(out.join("curves.jsonl")).unwrap(),
        &curves_1,
    );

    // A different study into the same folder is refused, naming the folder …
    let o = out.to_str().unwrap();
    let refused = madenet_with("compare --config {} --out {} --seeds 3", &[&cfg, o]);
    assert_clean_error(&refused, &[o]);
    assert_eq!(std::fs::read(out.join("trials.csv")).unwrap(), trials_1);
    // … unless --fresh.
    let fresh = madenet_with(
        "compare --config {} --out {} --methods nf --seeds 1 --fresh",
        &[&cfg, o],
    );
    assert_ok(&fresh);
    assert_eq!(deterministic_rows(&out.join("trials.csv")).len(), 1 + 8);
}

#[test]
fn bad_study_config_fails_before_any_trial_with_one_line() {
    let dir = Scratch::new("bad");
    let out = dir.path().join("results");
    let o = out.to_str().unwrap();
    let bad = |name: &str, text: &str| write(&dir.path().join(name), text);

    let f = bad("method.toml", &SMALL.replace("\"ub\"", "\"teleport\""));
    assert_clean_error(
        &madenet(&["compare", "--config", &f, "--out", o]),
        &["methods", "teleport"],
    );

    let missing = dir.path().join("no_such_maps");
    let f = bad(
        "maps.toml",
        &SMALL.replace(
            "\"paper:2\"",
            &format!("{:?}", missing.display().to_string()),
        ),
    );
    assert_clean_error(
        &madenet(&["compare", "--config", &f, "--out", o]),
        &[missing.to_str().unwrap()],
    );

    let f = bad("csp.toml", &SMALL.replace("csp = [1.0, 0.0]", "csp = []"));
    assert_clean_error(&madenet(&["compare", "--config", &f, "--out", o]), &["csp"]);

    let f = bad(
        "csp2.toml",
        &SMALL.replace("csp = [1.0, 0.0]", "csp = [1.0, 2.0]"),
    );
    assert_clean_error(
        &madenet(&["compare", "--config", &f, "--out", o]),
        &["csp", "2"],
    );

    let f = bad(
        "oracle.toml",
        &SMALL.replace("oracles = []", "oracles = [\"psychic\"]"),
    );
    assert_clean_error(
        &madenet(&["compare", "--config", &f, "--out", o]),
        &[&f, "psychic", "line 6"],
    );
    let f = bad(
        "oracle_base.toml",
        &SMALL.replace(
            "oracles = []",
            "oracles = [\"placebo\"]\noracle_base = \"nf\"",
        ),
    );
    assert_clean_error(
        &madenet(&["compare", "--config", &f, "--out", o]),
        &["oracle_base", "re-decides every step"],
    );
    let flag = madenet(&["compare", "--oracles", "psychic", "--out", o]);
    assert_eq!(flag.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&flag.stderr).contains(
        "unknown oracle `psychic`; known: replay, averaged, noiseless, placebo, known-map, redrawn, plan-redrawn, plan-own-map, plan-team-map, none"
    ));

    let f = bad("seeds.toml", &SMALL.replace("seeds = 2", "seeds = 0"));
    assert_clean_error(
        &madenet(&["compare", "--config", &f, "--out", o]),
        &["seeds"],
    );

    // Malformed TOML: the file and the line (line 4: `csp = [1.0,, 0.0]`).
    let f = bad(
        "syntax.toml",
        &SMALL.replace("csp = [1.0, 0.0]", "csp = [1.0,, 0.0]"),
    );
    assert_clean_error(
        &madenet(&["compare", "--config", &f, "--out", o]),
        &[&f, "line 4"],
    );

    // A missing config file names the file.
    let f = dir.path().join("absent.toml").display().to_string();
    assert_clean_error(&madenet(&["compare", "--config", &f, "--out", o]), &[&f]);

    // Overrides on the command line are validated the same way.
    let good = bad("good.toml", SMALL);
    assert_clean_error(
        &madenet(&[
            "compare",
            "--config",
            &good,
            "--out",
            o,
            "--methods",
            "nf,teleport",
        ]),
        &["methods", "teleport"],
    );
    assert_clean_error(
        &madenet(&["compare", "--config", &good, "--out", o, "--seeds", "0"]),
        &["seeds"],
    );

    // Nothing ran.
    assert!(
        !out.join("trials.csv").exists(),
        "trials.csv written by a refused study"
    );
    assert!(!out.join("curves.jsonl").exists());
}

#[test]
fn a_study_killed_twice_and_resumed_writes_the_files_of_an_uninterrupted_one() {
    // Enough trials (160) that TTD sums of √2 steps fill every decimal and the statistics
    // notice any rounding of the values read back on resume.
    const STUDY: &str = r#"methods = ["nf", "ub"]
maps = ["paper:1", "paper:2"]
starts = ["top-left", "top-right", "bottom-left", "bottom-right"]
csp = [1.0, 0.0]
seeds = 5
oracles = []
"#;
    let dir = Scratch::new("kill");
    let cfg = dir.path().join("study.toml");
    std::fs::write(&cfg, STUDY).unwrap();
    let cfg = cfg.to_str().unwrap().to_string();
    let (whole, killed) = (dir.path().join("whole"), dir.path().join("killed"));
    let args = |out: &Path, threads: &str| study_args(&cfg, out, threads);
    let ok = |out: std::process::Output| assert_ok(&out);
    ok(Command::new(env!("CARGO_BIN_EXE_madenet"))
        .args(args(&whole, "2"))
        .output()
        .unwrap());

    // Killed (SIGKILL: no clean-up runs) twice, once a tenth and once half of the trials are in.
    let rows =
        |p: &Path| std::fs::read_to_string(p.join("trials.csv")).map_or(0, |t| t.lines().count());
    for at in [17, 80] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_madenet"))
            .args(args(&killed, "1"))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let t0 = std::time::Instant::now();
        while rows(&killed) < at && child.try_wait().unwrap().is_none() {
            assert!(t0.elapsed().as_secs() < 300, "the study did not progress");
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        child.kill().unwrap();
        let status = child.wait().unwrap();
        assert!(
            !status.success(),
            "killed before it finished (at {at} rows)"
        );
    }
    assert!(rows(&killed) < 161, "the study was interrupted");
    ok(Command::new(env!("CARGO_BIN_EXE_madenet"))
        .args(args(&killed, "2"))
        .output()
        .unwrap());

    assert_eq!(
        deterministic_rows(&killed.join("trials.csv")),
        deterministic_rows(&whole.join("trials.csv"))
    );
    for f in ["statistics.csv", "statistics.md", "curves.jsonl"] {
        let (a, b) = (
            std::fs::read_to_string(killed.join(f)).unwrap(),
            std::fs::read_to_string(whole.join(f)).unwrap(),
        );
        assert!(a == b, "{f} differs from the uninterrupted study's");
    }
    assert_eq!(
        deterministic_rows(&killed.join("summary.csv")),
        deterministic_rows(&whole.join("summary.csv"))
    );

    // Re-running on the finished folder runs nothing and changes none of these files.
    let before: Vec<Vec<u8>> = [
        "trials.csv",
        "statistics.csv",
        "summary.csv",
        "curves.jsonl",
    ]
    .iter()
    .map(|f| std::fs::read(whole.join(f)).unwrap())
    .collect();
    ok(Command::new(env!("CARGO_BIN_EXE_madenet"))
        .args(args(&whole, "2"))
        .output()
        .unwrap());
    for (f, b) in [
        "trials.csv",
        "statistics.csv",
        "summary.csv",
        "curves.jsonl",
    ]
    .iter()
    .zip(&before)
    {
        assert!(
            &std::fs::read(whole.join(f)).unwrap() == b,
            "{f} changed by a rerun"
        );
    }
}
