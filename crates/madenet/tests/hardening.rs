//! Bad values found by trying the CLI as an adversarial user: each is one `error:` line naming
//! the file or flag and the field, exit code 2, no panic, quickly (no unbounded allocation or
//! hang), and nothing the user pointed at is written. Outputs given as symlinks or devices are
//! written through, never replaced.

use madenet_testkit::{assert_clean_error_in, assert_ok, run_limited, Scratch};
use std::ffi::OsStr;
use std::fmt::Debug;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

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

/// Runs madenet, killing it after 60 s (a hang or a runaway allocation fails the test).
fn madenet<S: AsRef<OsStr> + Debug>(args: &[S]) -> Output {
    run_limited(env!("CARGO_BIN_EXE_madenet"), args, Duration::from_secs(60))
}

const STUDY: &str = "methods = [\"nf\"]\nmaps = [\"paper:1\"]\nstarts = [\"top-left\"]\ncsp = [1.0]\nseeds = 1\noracles = []\n";

#[test]
fn bad_values_are_one_clear_error_and_write_nothing() {
    let dir = Scratch::new("hard-table");
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
    // (case, its command line with `{d}` for the scratch folder and `{model}` for the model
    // folder, what the error names)
    let flags: [(&str, &str, &[&str]); 16] = [
        (
            "batch --seeds 1e12",
            "batch --seeds 1000000000000 --out {d}/keep.csv",
            &["--seeds"],
        ),
        (
            "batch --seed-base max",
            "batch --seed-base 18446744073709551615 --seeds 2 --out {d}/keep.csv",
            &["seed"],
        ),
        (
            "batch --threads 100000",
            "batch --threads 100000 --out {d}/keep.csv",
            &["--threads"],
        ),
        (
            "compare --seeds 1e12",
            "compare --seeds 1000000000000 --out {d}/cmp",
            &["seeds"],
        ),
        (
            "compare --threads 1000",
            "compare --threads 1000 --out {d}/cmp",
            &["--threads"],
        ),
        (
            "run --cell-px 0",
            "run --cell-px 0 --snapshot {d}/keep.png",
            &["--cell-px"],
        ),
        (
            "run --world continuous --cell-px 0 (issue 59)",
            "run --world continuous --cell-px 0 --snapshot {d}/keep.png",
            &["--cell-px"],
        ),
        (
            "run --cell-px 5000",
            "run --cell-px 5000 --render {d}/keep.gif",
            &["--cell-px"],
        ),
        (
            "run --cell-px 100000",
            "run --cell-px 100000 --snapshot {d}/keep.png",
            &["--cell-px"],
        ),
        (
            "run --render x.png",
            "run --render {d}/keep.png",
            &["--render", ".png"],
        ),
        (
            "run --snapshot x.gif",
            "run --snapshot {d}/keep.gif",
            &["--snapshot", ".gif"],
        ),
        (
            "batch --model without --policy model",
            "batch --model {model} --out {d}/keep.csv",
            &["--model", "--policy"],
        ),
        (
            "run --model without --policy model",
            "run --model {model} --snapshot {d}/keep.png",
            &["--model", "--policy"],
        ),
        (
            "run 4 cells for 3 robots",
            "run --start 0,0;0,1;0,2;0,3 --snapshot {d}/keep.png",
            &["--start", "4 cells"],
        ),
        (
            "train --threads 100000",
            "train --threads 100000 --out {d}/run",
            &["--threads"],
        ),
        ("run --csp nan", "run --csp NaN", &["comm_success_prob"]),
    ];
    let model = model.display().to_string();
    for (case, line, needles) in flags {
        // Split before the paths go in: a path may hold a space.
        let args = line
            .split(' ')
            .map(|w| w.replace("{d}", &d).replace("{model}", &model))
            .collect();
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
        assert_clean_error_in(case, &out, &needles);
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
    let dir = Scratch::new("hard-links");
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
    let (gif, png) = (s(&dir.join("trial.gif")), s(&dir.join("final.png")));
    let out = madenet(&[
        "run",
        "--render",
        &gif,
        "--snapshot",
        &png,
        "--cell-px",
        "4",
    ]);
    assert_ok(&out);
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("frames"),
        "the GIF's size is reported"
    );
    // `batch` on paper map 1 at CSP 1, which must succeed, its CSV to `out`.
    let batch = |out: &str| {
        let o = madenet(&["batch", "--maps", "paper:1", "--csp", "1", "--out", out]);
        assert_ok(&o);
        o
    };
    batch(&s(&dir.join("latest.csv")));
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
    batch("/dev/null");
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::metadata("/dev/null")
        .unwrap()
        .file_type()
        .is_char_device());

    // /dev/stdout: the CSV arrives on standard output.
    let out = batch("/dev/stdout");
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
    let dir = Scratch::new("hard-second");
    let s = |p: &Path| p.display().to_string();
    // Unknown fields under [discretize] and in a model's model.toml are refused by name.
    std::fs::write(
        dir.join("scenario.toml"),
        "[discretize]\nobstacle_fractoin = 0.9\n",
    )
    .unwrap();
    let out = madenet(&["run", "--config", &s(&dir.join("scenario.toml"))]);
    assert_clean_error_in(
        "[discretize] typo",
        &out,
        &["scenario.toml", "obstacle_fractoin"],
    );
    let model = model_copy(&dir.join("model"), "made-net-paper", |toml| {
        format!("colour = \"red\"\n{toml}")
    });
    assert_clean_error_in(
        "model.toml typo",
        &run_model(&model),
        &["model.toml", "colour"],
    );
    // `none` is no oracle at all: not beside others.
    let out = madenet(&[
        "compare",
        "--oracles",
        "none,placebo",
        "--out",
        &s(&dir.join("cmp")),
    ]);
    assert_clean_error_in("--oracles none,placebo", &out, &["--oracles", "none"]);
    assert!(!dir.join("cmp").exists());
    // A YAML map whose YAML target is a folder: its image beside it stays untouched.
    std::fs::create_dir_all(dir.join("keep.yaml")).unwrap();
    std::fs::write(dir.join("keep.pgm"), b"precious").unwrap();
    let out = madenet(&["map", "convert", "paper:2", &s(&dir.join("keep.yaml"))]);
    assert_clean_error_in("convert onto a folder", &out, &["keep.yaml"]);
    assert_eq!(std::fs::read(dir.join("keep.pgm")).unwrap(), b"precious");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Unknown cells of a ground truth are obstacles: `explored` never exceeds 100 %.
#[test]
fn unknown_cells_in_a_ground_truth_never_push_explored_past_100() {
    let dir = Scratch::new("hard-unknown");
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
        "run",
        "--map",
        &dir.join("m.txt").display().to_string(),
        "--start",
        "top-left",
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
    let dir = Scratch::new("hard-sizes");
    for (field, bad) in [
        ("goal_count", "0"),
        ("team_size", "100000"),
        ("map_height", "3"),
    ] {
        let model = model_copy(&dir.join(field), "made-net-paper", |toml| {
            let edited = set_field(toml, field, bad);
            assert_ne!(edited, toml, "{field} is in model.toml");
            edited
        });
        let out = run_model(&model);
        assert_clean_error_in(field, &out, &["model.toml", &format!("dep.{field}")]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A copy of shipped model `name` in `dir`, its model.toml passed through `edit`.
fn model_copy(dir: &Path, name: &str, edit: impl Fn(&str) -> String) -> PathBuf {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../models")
        .join(name);
    std::fs::create_dir_all(dir).unwrap();
    for e in std::fs::read_dir(&shipped).unwrap() {
        let p = e.unwrap().path();
        if p.is_file() {
            std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
        }
    }
    let toml = std::fs::read_to_string(dir.join("model.toml")).unwrap();
    std::fs::write(dir.join("model.toml"), edit(&toml)).unwrap();
    dir.to_path_buf()
}

/// `toml` with the value of its line `field = …` replaced by `value`.
fn set_field(toml: &str, field: &str, value: &str) -> String {
    toml.lines()
        .map(|l| {
            if l.starts_with(&format!("{field} =")) {
                format!("{field} = {value}\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect()
}

/// `madenet train --config <cfg> --out <out> <extra>`.
fn train(cfg: &Path, out: &Path, extra: &[&str]) -> Output {
    let (cfg, out) = (cfg.display().to_string(), out.display().to_string());
    madenet(&[&["train", "--config", &cfg, "--out", &out][..], extra].concat())
}

/// `run` on paper map 1 (20 × 20) with 3 robots and the model in `model`.
fn run_model(model: &Path) -> Output {
    let model = model.display().to_string();
    madenet(&["run", "--policy", "model", "--model", &model])
}

/// Weights that disagree with model.toml (sizes), are damaged (digest) or hold NaN are
/// refused by file and field, never burn's panic; a folder without digests still loads.
#[test]
fn a_model_folder_is_checked_against_its_weights() {
    let dir = Scratch::new("hard-weights");
    let set = |field: &'static str, value: &'static str| move |t: &str| set_field(t, field, value);
    // Sizes that are possible but are not the weights' (a 20 × 20, 3-robot model).
    for (field, value) in [("map_height", "30"), ("team_size", "5")] {
        let m = model_copy(&dir.join(field), "made-net-paper", set(field, value));
        let out = run_model(&m);
        assert_clean_error_in(
            field,
            &out,
            &["dep0.bpk", "do not fit", &format!("`dep.{field}` {value}")],
        );
    }
    // 1 000 flipped bytes: the digest refuses them.
    let m = model_copy(&dir.join("flipped"), "made-net-paper", |t| t.to_string());
    let mut w = std::fs::read(m.join("dep0.bpk")).unwrap();
    let n = w.len();
    for i in 0..1000 {
        w[n / 2 + i] ^= 0x5a;
    }
    std::fs::write(m.join("dep0.bpk"), &w).unwrap();
    assert_clean_error_in("flipped", &run_model(&m), &["dep0.bpk", "digest"]);
    // NaN weights under a matching digest: refused by parameter.
    let m = model_copy(&dir.join("nan"), "made-net-paper", |t| t.to_string());
    let mut w = std::fs::read(m.join("dep0.bpk")).unwrap();
    let n = w.len();
    // 4-byte aligned NaNs over a stretch of the tensor data (the file's second half).
    let at = (n / 2) & !3;
    for k in 0..64 {
        w[at + 4 * k..at + 4 * k + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    }
    std::fs::write(m.join("dep0.bpk"), &w).unwrap();
    let digest = madenet_learn::integrity::digest(&w);
    let toml = std::fs::read_to_string(m.join("model.toml")).unwrap();
    let toml: String = toml
        .lines()
        .map(|l| match l.starts_with("digests =") {
            true => format!("digests = [\"{digest}\"]\n"),
            false => format!("{l}\n"),
        })
        .collect();
    std::fs::write(m.join("model.toml"), toml).unwrap();
    assert_clean_error_in("nan", &run_model(&m), &["dep0.bpk", "NaN"]);
    let no_digests = |t: &str| {
        t.lines()
            .filter(|l| !l.starts_with("digests ="))
            .map(|l| format!("{l}\n"))
            .collect::<String>()
    };
    // Without digests, intact weights still play (with a warning that nothing was checked).
    let m = model_copy(&dir.join("old"), "made-net-paper", no_digests);
    let out = run_model(&m);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("no `digests`"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Training configs bound every size they allocate by, and the time budget holds inside an
/// iteration (checked before each episode and update): no allocation abort, no run that
/// outlives `--max-minutes` by more than an episode, an update and a validation.
#[test]
fn training_sizes_are_bounded_and_the_time_budget_holds_inside_iterations() {
    let dir = Scratch::new("hard-train-bounds");
    for (name, text, needles) in [
        (
            "dme.toml",
            "method = \"dme-drl\"\nhidden = 1000000000\n",
            ["`hidden`", "1..=4096"],
        ),
        (
            "grid.toml",
            "map_height = 10000\n",
            ["`map_height`", "1..=200"],
        ),
        (
            // Every field within its bound, the product not: ≈ 1 TiB of minibatch.
            "dme-memory.toml",
            "method = \"dme-drl\"\nmap_height = 200\nmap_width = 200\nhistory = 64\ncritic_history = 1\nbatch_size = 4096\nreplay_steps = 100000\nhidden = 8\n",
            ["needs more memory", "`batch_size` 4096"],
        ),
        (
            "grid-memory.toml",
            "map_height = 200\nmap_width = 200\nbatch_size = 1024\ntrace_len = 1024\nreplay_episodes = 1024\n",
            ["needs more memory", "`trace_len` 1024"],
        ),
        (
            "rollout-memory.toml",
            "method = \"made-net-rollout\"\nmap_height = 200\nmap_width = 200\nbatch_size = 1024\ntrace_len = 1024\nrecurrent = true\n",
            ["needs more memory", "`batch_size` 1024"],
        ),
        (
            "rollout.toml",
            "method = \"made-net-rollout\"\nupdates_per_iteration = 1000000000000\n",
            ["`updates_per_iteration`", "0..=1000000"],
        ),
    ] {
        let cfg = dir.join(name);
        std::fs::write(&cfg, text).unwrap();
        let out = train(&cfg, &dir.join(format!("{name}.out")), &[]);
        assert_clean_error_in(name, &out, &[name, needles[0], needles[1]]);
    }
    // A million updates in one iteration, 3 s of budget: it stops inside the iteration.
    let cfg = dir.join("long.toml");
    std::fs::write(
        &cfg,
        "method = \"made-net-rollout\"\nepisodes = 2\niterations = 1\nrollouts = 1\nupdates_per_iteration = 1000000\nbatch_size = 4\nvalidation_maps = 1\nvalidation_csp = [1.0]\nspread_margins = []\nthreads = 1\n[scenario]\nstep_cap = 30\n",
    )
    .unwrap();
    let t0 = Instant::now();
    let out = train(&cfg, &dir.join("long"), &["--max-minutes", "0.05", "-q"]);
    // The call's first iteration cut: nothing trained, which is an error (resuming with the same
    // budget would cut it again), not a success that loops.
    assert_clean_error_in(
        "time budget",
        &out,
        &["--max-minutes", "ran out inside iteration 1", "raise it"],
    );
    assert!(t0.elapsed() < Duration::from_secs(45), "{:?}", t0.elapsed());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Inputs that are devices or FIFOs are read as capped streams: `/dev/zero` as a config stops at
/// the cap, a FIFO nobody writes reads as empty (a bad map, a bad weight file), never a hang.
#[test]
fn devices_and_fifos_as_inputs_are_bounded() {
    let dir = Scratch::new("hard-streams");
    let out = madenet(&["run", "--config", "/dev/zero"]);
    assert_clean_error_in("config /dev/zero", &out, &["/dev/zero", "16 MiB"]);
    let fifo = |p: &Path| {
        let ok = Command::new("mkfifo").arg(p).status().expect("mkfifo");
        assert!(ok.success(), "mkfifo {p:?}");
    };
    let map = dir.join("fifo.pgm");
    fifo(&map);
    let out = madenet(&["run", "--map", &map.display().to_string()]);
    assert_clean_error_in("map fifo", &out, &["fifo.pgm"]);
    let model = model_copy(&dir.join("model"), "made-net-paper", |t| t.to_string());
    std::fs::remove_file(model.join("dep0.bpk")).unwrap();
    fifo(&model.join("dep0.bpk"));
    assert_clean_error_in("weights fifo", &run_model(&model), &["dep0.bpk"]);
    // A training config from a pipe is read once: its field is what the error names (a
    // second read found the pipe empty).
    let cfg = dir.join("train.toml");
    fifo(&cfg);
    let writer = {
        let cfg = cfg.clone();
        std::thread::spawn(move || {
            std::fs::write(&cfg, "method = \"dme-drl\"\nhidden = 1000000000\n").unwrap()
        })
    };
    let out = train(&cfg, &dir.join("run"), &[]);
    writer.join().unwrap();
    assert_clean_error_in("train config fifo", &out, &["train.toml", "`hidden`"]);
    // A --config that is not there is an error, not the defaults.
    let missing = dir.join("no-such-config.toml");
    let out = train(&missing, &dir.join("run-missing"), &[]);
    assert_clean_error_in("train config missing", &out, &["no-such-config.toml"]);
    assert!(!dir.join("run-missing").exists(), "nothing written");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A map YAML the reader refuses is one line naming the file and the field: no source snippet,
/// no notes, no advice meant for the programmer; deep nesting and alias bombs end quickly.
#[test]
fn yaml_errors_are_one_line_naming_the_field() {
    let dir = Scratch::new("hard-yaml");
    let base = "image: m.pgm\nresolution: 1.0\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
    let mut bomb =
        String::from("a0: &a0 [\"x\",\"x\",\"x\",\"x\",\"x\",\"x\",\"x\",\"x\",\"x\"]\n");
    for i in 1..10 {
        let refs = vec![format!("*a{}", i - 1); 9].join(",");
        bomb.push_str(&format!("a{i}: &a{i} [{refs}]\n"));
    }
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "nan",
            base.replace("resolution: 1.0", "resolution: .nan"),
            "`resolution`",
        ),
        (
            "inf",
            base.replace("occupied_thresh: 0.65", "occupied_thresh: .inf"),
            "`occupied_thresh`",
        ),
        (
            "origin",
            base.replace("[0.0, 0.0, 0.0]", "[0.0, -.inf, 0.0]"),
            "`origin`",
        ),
        (
            "duplicate",
            format!("{base}resolution: 2.0\n"),
            "`resolution`",
        ),
        ("bomb", format!("{bomb}{base}"), "budget"),
        (
            "deep",
            format!("image: {}{}\n", "[".repeat(100_000), "]".repeat(100_000)),
            "`image`",
        ),
    ];
    for (case, text, needle) in cases {
        let yaml = dir.join(format!("{case}.yaml"));
        std::fs::write(&yaml, text).unwrap();
        let out = madenet(&["map", "show", &yaml.display().to_string()]);
        assert_clean_error_in(case, &out, &[&format!("{case}.yaml"), needle]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !err.contains("DuplicateKeyPolicy") && !err.contains("-->"),
            "{case}: {err}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_output_that_cannot_be_written_is_named_and_leaves_nothing_behind() {
    // A file-size limit stands in for a full disk (no small file system is needed): the write
    // fails part-way (EFBIG here, ENOSPC there) exactly where a full disk would fail it.
    use std::os::unix::process::CommandExt;
    let dir = Scratch::new("hard-full");
    let out_csv = dir.join("batch.csv");
    std::fs::write(&out_csv, b"precious").unwrap();
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_madenet"));
    cmd.args([
        "batch",
        "--maps",
        "paper:1,paper:2",
        "--seeds",
        "3",
        "--threads",
        "1",
    ])
    .arg("--out")
    .arg(&out_csv);
    // SAFETY: only async-signal-safe calls between fork and exec; an ignored signal stays
    // ignored across exec, so the write returns an error instead of SIGXFSZ killing madenet.
    unsafe {
        cmd.pre_exec(|| {
            libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
            let limit = libc::rlimit {
                rlim_cur: 2048,
                rlim_max: 2048,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let out = cmd.output().unwrap();
    let shown = out_csv.display().to_string();
    assert_clean_error_in("full", &out, &["--out", &shown, "too large"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !err.contains(".madenet-"),
        "the temporary path leaks: {err}"
    );
    assert_eq!(
        snapshot(&dir),
        vec![(out_csv.clone(), b"precious".to_vec())],
        "the target is kept and no temporary file is left"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A stderr that cannot be written (`2>/dev/full`) is not a panic (exit 101): a run still ends
/// 0 with its result on stdout, and bad input still ends 2 (issue 59).
#[test]
fn a_full_stderr_is_not_a_panic() {
    let full = || {
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    for (args, code) in [
        (&["run", "--map", "paper:1", "--policy", "nf"][..], 0),
        (&["run", "--map", "/nonexistent.txt"][..], 2),
        (&["run", "--map", "paper:1", "--csp", "7"][..], 2),
        (
            &["explore", "--params-file", "/nonexistent.yaml", "--check"][..],
            2,
        ),
    ] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_madenet"))
            .args(args)
            .stderr(full())
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(code), "{args:?}");
        if code == 0 {
            assert!(
                String::from_utf8_lossy(&out.stdout).contains("TNS"),
                "{args:?}"
            );
        }
    }
}

/// A `[continuous]` section in a grid scale study is an error naming it, not ignored (issue 59).
#[test]
fn a_continuous_section_in_a_grid_study_is_refused() {
    let dir = Scratch::new("scale-grid-continuous");
    let cfg = dir.join("grid.toml");
    std::fs::write(&cfg, "sides = [20]\n[continuous]\ncontrol_period = 0.1\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_madenet"))
        .args(["scale", "--config", cfg.to_str().unwrap()])
        .args(["--out", dir.join("out").to_str().unwrap()])
        .output()
        .unwrap();
    assert_clean_error_in(
        "[continuous] in a grid study",
        &out,
        &["continuous", "grid"],
    );
    assert!(!dir.join("out").exists());
}

/// What the study derives from accepted values (the cap of a 500-cell side, the maps of the
/// largest team on the largest side) is checked with the values, before any work, naming
/// them, not a field the user never set mid-study (issue 59).
#[test]
fn a_study_refuses_what_its_own_values_imply_before_it_starts() {
    let dir = Scratch::new("scale-derived");
    for (args, names) in [
        (
            &["--sides", "500"][..],
            &["sides", "steps_per_cell", "500"][..],
        ),
        (
            &["--world", "continuous", "--sides", "300", "--teams", "256"][..],
            &["sides/teams", "GB", "256"][..],
        ),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_madenet"))
            .arg("scale")
            .args(args)
            .args(["--seeds", "1", "--methods", "nf"])
            .args(["--out", dir.join("out").to_str().unwrap()])
            .output()
            .unwrap();
        assert_clean_error_in(&format!("{args:?}"), &out, names);
        assert!(!dir.join("out").exists());
    }
}

/// A cell size the scene cannot be read at (a built-in map's 1 m cells read at 0.5 m) is an
/// error naming `cell_size` in the continuous world as in the grid world, not a panic (issue 59).
#[test]
fn a_cell_size_finer_than_the_scene_is_refused_in_the_continuous_world() {
    let dir = Scratch::new("continuous-cell");
    let cfg = dir.join("half.toml");
    std::fs::write(&cfg, "cell_size = 0.5\n").unwrap();
    for world in ["grid", "continuous"] {
        let out = Command::new(env!("CARGO_BIN_EXE_madenet"))
            .args(["run", "--world", world, "--map", "paper:1"])
            .args(["--config", cfg.to_str().unwrap()])
            .output()
            .unwrap();
        assert_clean_error_in(world, &out, &["cell_size"]);
    }
}

/// A training config with a duplicate key or an integer too large for TOML is one error naming
/// the file, the field and the line, as every other config's reader does (issue 59).
#[test]
fn a_training_config_error_names_the_field_and_line() {
    let dir = Scratch::new("train-config-lines");
    let cases = [
        (
            "dup",
            "method = \"made-net-rollout\"\nseed = 1\nseed = 2\n",
            "line 3",
        ),
        (
            "big",
            "method = \"made-net-rollout\"\nseed = 99999999999999999999\n",
            "line 2",
        ),
    ];
    for (name, text, line) in cases {
        let cfg = dir.join(format!("{name}.toml"));
        std::fs::write(&cfg, text).unwrap();
        let out = train(&cfg, &dir.join(format!("{name}.out")), &[]);
        assert_clean_error_in(name, &out, &[&format!("{name}.toml"), "field `seed`", line]);
        assert!(!dir.join(format!("{name}.out")).exists());
    }
}

/// An output path that is an input's file — directly, through a symbolic link, or as the image
/// a map YAML names — or another output's path is refused with exit 2 before any work, and
/// every file in the folder is left as it was (issue 59). A study's config in its own output
/// folder would be rewritten by the study: refused too.
#[test]
fn an_output_never_replaces_an_input() {
    let dir = Scratch::new("outputs-over-inputs");
    let d = dir.path().display().to_string();
    assert_ok(&madenet(&[
        "map",
        "generate",
        "--height",
        "10",
        "--width",
        "10",
        &format!("{d}/m.txt"),
    ]));
    assert_ok(&madenet(&[
        "map",
        "convert",
        &format!("{d}/m.txt"),
        &format!("{d}/m.png"),
    ]));
    assert_ok(&madenet(&[
        "map",
        "convert",
        &format!("{d}/m.txt"),
        &format!("{d}/thin.yaml"),
    ]));
    #[cfg(unix)]
    std::os::unix::fs::symlink(dir.join("m.png"), dir.join("link.png")).unwrap();
    std::fs::create_dir(dir.join("st")).unwrap();
    std::fs::write(dir.join("st/study.toml"), format!("# mine\n{STUDY}")).unwrap();
    let before = snapshot(dir.path());
    const NOT_AN_INPUT: &str = "an output never replaces an input";
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["--out", "--maps", NOT_AN_INPUT],
            &["oracle", "--maps", "{d}/m.txt", "--out", "{d}/m.txt"],
        ),
        (
            &["--out", "--maps", NOT_AN_INPUT],
            &["batch", "--maps", "{d}/m.txt", "--out", "{d}/./m.txt"],
        ),
        (
            &["--snapshot", "--map", NOT_AN_INPUT],
            &["run", "--map", "{d}/m.png", "--snapshot", "{d}/link.png"],
        ),
        (
            &["--record", "--render"],
            &[
                "run",
                "--map",
                "{d}/m.txt",
                "--render",
                "{d}/a.gif",
                "--record",
                "{d}/a.gif",
            ],
        ),
        (
            &["output", "thin.pgm", NOT_AN_INPUT],
            &["map", "convert", "{d}/thin.yaml", "{d}/thin.pgm"],
        ),
        (
            &["--out", "--config", NOT_AN_INPUT],
            &[
                "compare",
                "--config",
                "{d}/st/study.toml",
                "--out",
                "{d}/st",
            ],
        ),
    ];
    for (needles, args) in cases {
        let args: Vec<String> = args.iter().map(|a| a.replace("{d}", &d)).collect();
        assert_clean_error_in(&args.join(" "), &madenet(&args), needles);
        assert_eq!(snapshot(dir.path()), before, "{args:?}");
    }
    assert_eq!(
        std::fs::read_to_string(dir.join("st/study.toml")).unwrap(),
        format!("# mine\n{STUDY}")
    );
}
