//! Bad values found by trying the CLI as an adversarial user: each is one `error:` line naming
//! the file or flag and the field, exit code 2, no panic, quickly (no unbounded allocation or
//! hang), and nothing the user pointed at is written. Outputs given as symlinks or devices are
//! written through, never replaced.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs madenet, killing it after 60 s (a hang or a runaway allocation fails the test).
fn madenet(args: &[String]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_madenet"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run madenet");
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            panic!("madenet {args:?} ran for over 60 s");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("madenet-hard-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn check_error(case: &str, out: &Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{case}: stderr: {err}");
    assert!(!err.contains("panicked"), "{case}: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{case}: one line expected: {err}");
    assert!(lines[0].starts_with("error: "), "{case}: {err}");
    for n in needles {
        assert!(lines[0].contains(n), "{case}: `{n}` missing from: {err}");
    }
}

/// Every file below `dir` with its bytes.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    v.sort();
    v
}

const STUDY: &str = "methods = [\"nf\"]\nmaps = [\"paper:1\"]\nstarts = [\"top-left\"]\ncsp = [1.0]\nseeds = 1\noracles = []\n";

#[test]
fn bad_values_are_one_clear_error_and_write_nothing() {
    let dir = scratch("table");
    let d = dir.display().to_string();
    // A file the user points an output at: it must survive every refused command.
    std::fs::write(dir.join("keep.png"), b"precious").unwrap();
    std::fs::write(dir.join("keep.gif"), b"precious").unwrap();
    std::fs::write(dir.join("keep.csv"), b"precious").unwrap();
    let model = dir.join("model");
    std::fs::create_dir_all(&model).unwrap();

    // (scenario TOML for `run --config`, the field named)
    let scenario = [
        ("sensing_range = 1000\n", "sensing_range"),
        ("sensing_range = 200\n", "sensing_range"),
        ("plan_horizon = 1000000000\n", "plan_horizon"),
        ("step_cap = 10000000000\n", "step_cap"),
    ];
    // (study TOML for `compare --config`, the field named)
    let study = [
        ("csp = [0.5, 0.5]\n", "csp"),
        ("csp = [0.5, 0.50000000000000001]\n", "csp"),
        ("starts = [\"top-left\", \"top-left\"]\n", "starts"),
        ("starts = [\"top-left\", \"tl\"]\n", "starts"),
        ("starts = [\"0,0;0,1;0,2;0,3\"]\n", "starts"),
        ("[baselines.pb]\ndiscount = 5\n", "discount"),
        ("[baselines.pb]\niterations = 0\n", "iterations"),
        ("[baselines.ub]\nbeta = nan\n", "beta"),
        (
            "[baselines.ub]\ncoordination_radius = -3.0\n",
            "coordination_radius",
        ),
        ("seed_base = 18446744073709551615\nseeds = 2\n", "seed_base"),
        ("seeds = 1000000000000\n", "seeds"),
    ];
    let mut cases: Vec<(String, Vec<String>, Vec<String>)> = Vec::new();
    for (i, (text, field)) in scenario.iter().enumerate() {
        let p = dir.join(format!("scenario{i}.toml"));
        std::fs::write(&p, text).unwrap();
        let p = p.display().to_string();
        cases.push((
            format!("scenario {text:?}"),
            vec!["run".into(), "--config".into(), p.clone()],
            vec![format!("scenario{i}.toml"), field.to_string()],
        ));
    }
    for (i, (text, field)) in study.iter().enumerate() {
        let p = dir.join(format!("study{i}.toml"));
        // Later keys of the same name would be duplicates: the case's lines replace the base's.
        let base: String = STUDY
            .lines()
            .filter(|l| {
                !text
                    .lines()
                    .any(|t| t.split('=').next() == l.split('=').next())
            })
            .map(|l| format!("{l}\n"))
            .collect();
        std::fs::write(&p, format!("{base}{text}")).unwrap();
        let p = p.display().to_string();
        cases.push((
            format!("study {text:?}"),
            vec![
                "compare".into(),
                "--config".into(),
                p,
                "--out".into(),
                format!("{d}/study-out{i}"),
            ],
            vec![format!("study{i}.toml"), field.to_string()],
        ));
    }
    let flags: Vec<(&str, Vec<String>, Vec<&str>)> = vec![
        (
            "batch --seeds 1e12",
            vec![
                "batch".into(),
                "--seeds".into(),
                "1000000000000".into(),
                "--out".into(),
                format!("{d}/keep.csv"),
            ],
            vec!["--seeds"],
        ),
        (
            "batch --seed-base max",
            vec![
                "batch".into(),
                "--seed-base".into(),
                "18446744073709551615".into(),
                "--seeds".into(),
                "2".into(),
                "--out".into(),
                format!("{d}/keep.csv"),
            ],
            vec!["seed"],
        ),
        (
            "batch --threads 100000",
            vec![
                "batch".into(),
                "--threads".into(),
                "100000".into(),
                "--out".into(),
                format!("{d}/keep.csv"),
            ],
            vec!["--threads"],
        ),
        (
            "compare --seeds 1e12",
            vec![
                "compare".into(),
                "--seeds".into(),
                "1000000000000".into(),
                "--out".into(),
                format!("{d}/cmp"),
            ],
            vec!["seeds"],
        ),
        (
            "compare --threads 1000",
            vec![
                "compare".into(),
                "--threads".into(),
                "1000".into(),
                "--out".into(),
                format!("{d}/cmp"),
            ],
            vec!["--threads"],
        ),
        (
            "run --cell-px 0",
            vec![
                "run".into(),
                "--cell-px".into(),
                "0".into(),
                "--snapshot".into(),
                format!("{d}/keep.png"),
            ],
            vec!["--cell-px"],
        ),
        (
            "run --cell-px 5000",
            vec![
                "run".into(),
                "--cell-px".into(),
                "5000".into(),
                "--render".into(),
                format!("{d}/keep.gif"),
            ],
            vec!["--cell-px"],
        ),
        (
            "run --cell-px 100000",
            vec![
                "run".into(),
                "--cell-px".into(),
                "100000".into(),
                "--snapshot".into(),
                format!("{d}/keep.png"),
            ],
            vec!["--cell-px"],
        ),
        (
            "run --render x.png",
            vec!["run".into(), "--render".into(), format!("{d}/keep.png")],
            vec!["--render", ".png"],
        ),
        (
            "run --snapshot x.gif",
            vec!["run".into(), "--snapshot".into(), format!("{d}/keep.gif")],
            vec!["--snapshot", ".gif"],
        ),
        (
            "batch --model without --policy model",
            vec![
                "batch".into(),
                "--model".into(),
                model.display().to_string(),
                "--out".into(),
                format!("{d}/keep.csv"),
            ],
            vec!["--model", "--policy"],
        ),
        (
            "run --model without --policy model",
            vec![
                "run".into(),
                "--model".into(),
                model.display().to_string(),
                "--snapshot".into(),
                format!("{d}/keep.png"),
            ],
            vec!["--model", "--policy"],
        ),
        (
            "run 4 cells for 3 robots",
            vec![
                "run".into(),
                "--start".into(),
                "0,0;0,1;0,2;0,3".into(),
                "--snapshot".into(),
                format!("{d}/keep.png"),
            ],
            vec!["--start", "4 cells"],
        ),
        (
            "train --threads 100000",
            vec![
                "train".into(),
                "--threads".into(),
                "100000".into(),
                "--out".into(),
                format!("{d}/run"),
            ],
            vec!["--threads"],
        ),
        (
            "run --csp nan",
            vec!["run".into(), "--csp".into(), "NaN".into()],
            vec!["comm_success_prob"],
        ),
    ];
    for (case, args, needles) in flags {
        cases.push((
            case.to_string(),
            args,
            needles.iter().map(|s| s.to_string()).collect(),
        ));
    }

    let before = snapshot(&dir);
    for (case, args, needles) in &cases {
        let out = madenet(args);
        let needles: Vec<&str> = needles.iter().map(String::as_str).collect();
        check_error(case, &out, &needles);
        assert_eq!(snapshot(&dir), before, "{case}: a file changed");
        for sub in ["cmp", "run"] {
            assert!(!dir.join(sub).exists(), "{case}: wrote {sub}/");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[cfg(unix)]
#[test]
fn outputs_through_symlinks_and_devices() {
    let dir = scratch("links");
    let target_dir = dir.join("results");
    std::fs::create_dir_all(&target_dir).unwrap();
    let s = |p: &Path| p.display().to_string();

    // Symlinks to a picture and a CSV: the targets get the new files, the links stay links.
    for (link, target) in [
        ("trial.gif", "t.gif"),
        ("final.png", "f.png"),
        ("latest.csv", "b.csv"),
    ] {
        std::fs::write(target_dir.join(target), b"old").unwrap();
        std::os::unix::fs::symlink(target_dir.join(target), dir.join(link)).unwrap();
    }
    let out = madenet(&[
        "run".into(),
        "--render".into(),
        s(&dir.join("trial.gif")),
        "--snapshot".into(),
        s(&dir.join("final.png")),
        "--cell-px".into(),
        "4".into(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("frames"),
        "the GIF's size is reported"
    );
    let out = madenet(&[
        "batch".into(),
        "--maps".into(),
        "paper:1".into(),
        "--csp".into(),
        "1".into(),
        "--out".into(),
        s(&dir.join("latest.csv")),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for (link, target, magic) in [
        ("trial.gif", "t.gif", &b"GIF89a"[..]),
        ("final.png", "f.png", &b"\x89PNG"[..]),
        ("latest.csv", "b.csv", &b"method,map,"[..]),
    ] {
        let meta = std::fs::symlink_metadata(dir.join(link)).unwrap();
        assert!(meta.file_type().is_symlink(), "{link} is still a symlink");
        let bytes = std::fs::read(target_dir.join(target)).unwrap();
        assert!(
            bytes.starts_with(magic),
            "{target} was written through {link}"
        );
    }

    // A device: /dev/null stays a device (it used to be replaced by a regular file).
    let out = madenet(&[
        "batch".into(),
        "--maps".into(),
        "paper:1".into(),
        "--csp".into(),
        "1".into(),
        "--out".into(),
        "/dev/null".into(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::metadata("/dev/null")
        .unwrap()
        .file_type()
        .is_char_device());

    // /dev/stdout: the CSV arrives on standard output.
    let out = madenet(&[
        "batch".into(),
        "--maps".into(),
        "paper:1".into(),
        "--csp".into(),
        "1".into(),
        "--out".into(),
        "/dev/stdout".into(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.lines().any(|l| l.starts_with("method,map,")), "{text}");
    assert!(
        text.lines().filter(|l| l.starts_with("nf,test_1,")).count() == 4,
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 27's second pass, the cases that held up badly: each a row that failed before.
#[test]
fn second_pass_unknown_fields_oracles_and_multi_file_writes() {
    let dir = scratch("second");
    let s = |p: &Path| p.display().to_string();
    // Unknown fields under [discretize] and in a model's model.toml are refused by name.
    std::fs::write(
        dir.join("scenario.toml"),
        "[discretize]\nobstacle_fractoin = 0.9\n",
    )
    .unwrap();
    let out = madenet(&[
        "run".into(),
        "--config".into(),
        s(&dir.join("scenario.toml")),
    ]);
    check_error(
        "[discretize] typo",
        &out,
        &["scenario.toml", "obstacle_fractoin"],
    );
    let model = dir.join("model");
    std::fs::create_dir_all(&model).unwrap();
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/made-net");
    for e in std::fs::read_dir(&shipped).unwrap() {
        let p = e.unwrap().path();
        if p.is_file() {
            std::fs::copy(&p, model.join(p.file_name().unwrap())).unwrap();
        }
    }
    let toml = std::fs::read_to_string(model.join("model.toml")).unwrap();
    std::fs::write(
        model.join("model.toml"),
        format!("colour = \"red\"\n{toml}"),
    )
    .unwrap();
    let out = madenet(&[
        "run".into(),
        "--policy".into(),
        "model".into(),
        "--model".into(),
        s(&model),
    ]);
    check_error("model.toml typo", &out, &["model.toml", "colour"]);
    // `none` is no oracle at all: not beside others.
    let out = madenet(&[
        "compare".into(),
        "--oracles".into(),
        "none,placebo".into(),
        "--out".into(),
        s(&dir.join("cmp")),
    ]);
    check_error("--oracles none,placebo", &out, &["--oracles", "none"]);
    assert!(!dir.join("cmp").exists());
    // A YAML map whose YAML target is a folder: its image beside it stays untouched.
    std::fs::create_dir_all(dir.join("keep.yaml")).unwrap();
    std::fs::write(dir.join("keep.pgm"), b"precious").unwrap();
    let out = madenet(&[
        "map".into(),
        "convert".into(),
        "paper:2".into(),
        s(&dir.join("keep.yaml")),
    ]);
    check_error("convert onto a folder", &out, &["keep.yaml"]);
    assert_eq!(std::fs::read(dir.join("keep.pgm")).unwrap(), b"precious");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Unknown cells of a ground truth are obstacles: `explored` never exceeds 100 %.
#[test]
fn unknown_cells_in_a_ground_truth_never_push_explored_past_100() {
    let dir = scratch("unknown");
    let mut text = String::new();
    for r in 0..12 {
        let row: String = (0..12)
            .map(|c| match (r, c) {
                (5, 3..=8) => '?',
                (9, 2) | (2, 9) => '#',
                _ => '.',
            })
            .collect();
        text.push_str(&row);
        text.push('\n');
    }
    std::fs::write(dir.join("m.txt"), text).unwrap();
    let out = madenet(&[
        "run".into(),
        "--map".into(),
        dir.join("m.txt").display().to_string(),
        "--start".into(),
        "top-left".into(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let explored: f64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("explored"))
        .and_then(|v| v.trim().trim_end_matches('%').trim().parse().ok())
        .expect("an explored line");
    assert!(explored <= 100.0 && explored > 99.9, "{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A model.toml whose sizes are impossible is refused by field before any network is built.
#[test]
fn a_model_with_impossible_sizes_names_the_field() {
    let dir = scratch("sizes");
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/made-net");
    for (field, bad) in [
        ("goal_count", "0"),
        ("team_size", "100000"),
        ("map_height", "3"),
    ] {
        let model = dir.join(field);
        std::fs::create_dir_all(&model).unwrap();
        for e in std::fs::read_dir(&shipped).unwrap() {
            let p = e.unwrap().path();
            if p.is_file() {
                std::fs::copy(&p, model.join(p.file_name().unwrap())).unwrap();
            }
        }
        let toml = std::fs::read_to_string(model.join("model.toml")).unwrap();
        let edited: String = toml
            .lines()
            .map(|l| {
                if l.starts_with(&format!("{field} =")) {
                    format!("{field} = {bad}\n")
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        assert_ne!(edited, toml, "{field} is in model.toml");
        std::fs::write(model.join("model.toml"), edited).unwrap();
        let out = madenet(&[
            "run".into(),
            "--policy".into(),
            "model".into(),
            "--model".into(),
            model.display().to_string(),
        ]);
        check_error(field, &out, &["model.toml", &format!("dep.{field}")]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
