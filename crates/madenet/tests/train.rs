//! `madenet train` end to end on a tiny run (plumbing, not learning), `--resume` extending it,
//! `--model` playing the result, and bad input: exit code 2 and one `error:` line naming the
//! file or flag.

mod common;

use common::{madenet, madenet_with};
use madenet_testkit::{assert_ok, error_line, Scratch};
use std::path::{Path, PathBuf};

/// A scratch folder tagged `tag` holding the training config `name` (its text `config`), and
/// the run folder `run` beside it, trained by `madenet train --config <config> --out <run>
/// --method <method> -q` (which must succeed): the folder, the config's path and the run's.
fn tiny_run(tag: &str, name: &str, config: &str, method: &str) -> (Scratch, PathBuf, PathBuf) {
    let dir = Scratch::new(tag);
    let cfg = dir.write(name, config);
    let run = dir.join("run");
    let (c, r) = (cfg.to_str().unwrap(), run.to_str().unwrap());
    assert_ok(&madenet(&[
        "train", "--config", c, "--out", r, "--method", method, "-q",
    ]));
    (dir, cfg, run)
}

/// The lines of `run`'s episodes.csv, its header included.
fn episode_lines(run: &Path) -> usize {
    madenet_testkit::read(run.join("episodes.csv"))
        .lines()
        .count()
}

/// The model in `model` plays a generated map and reports its TNS.
fn assert_model_plays(model: &Path) {
    let o = madenet_with(
        "run --map generate:2 --policy model --model {} --json",
        &[model.to_str().unwrap()],
    );
    assert_ok(&o);
    assert!(String::from_utf8_lossy(&o.stdout).contains("\"tns\""));
}

/// `madenet train --config <config> --out <out>`'s one error line.
fn config_error(config: &Path, out: &Path) -> String {
    error_line(&madenet(&[
        "train",
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]))
}

const TINY: &str = "episodes = 3\nwarmup_episodes = 1\nbatch_size = 2\ntrace_len = 4\nreplay_episodes = 4\nvalidate_every = 3\nvalidation_maps = 1\nvalidation_csp = [0.5]\ncheckpoint_every = 2\nthreads = 1\n[scenario]\nstep_cap = 30\n";

#[test]
fn tiny_run_resume_and_model() {
    let (dir, cfg, run) = tiny_run("train-cli-run", "tiny.toml", TINY, "made-net-dt");
    let (c, r) = (cfg.to_str().unwrap(), run.to_str().unwrap());
    assert_eq!(episode_lines(&run), 1 + 3);
    // A second --out into the same folder is refused; --resume with --episodes extends the run.
    let e = error_line(&madenet(&["train", "--config", c, "--out", r, "-q"]));
    assert!(e.contains("--resume"), "{e}");
    let o = madenet(&["train", "--resume", r, "--episodes", "4", "-q"]);
    assert_ok(&o);
    assert_eq!(episode_lines(&run), 1 + 4);
    assert!(
        !String::from_utf8_lossy(&o.stderr).contains("nothing left"),
        "it trained"
    );
    // Resuming to a length the run is already past trains nothing and says so (and adds no
    // TensorBoard event file: one per call would pile up).
    let events = || {
        std::fs::read_dir(&run)
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .starts_with("events.out.tfevents.")
            })
            .count()
    };
    let before = events();
    assert!(before >= 1);
    let o = madenet(&["train", "--resume", r, "--episodes", "2", "-q"]);
    assert_eq!(
        events(),
        before,
        "a resume that trains nothing adds no event file"
    );
    assert_ok(&o);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("nothing left to train") && e.contains("--episodes 2"),
        "{e}"
    );
    assert_eq!(episode_lines(&run), 1 + 4);
    // A size edited in the run's config.toml after the start is refused by field on resume
    // (not burn's panic on weights that no longer fit); undoing the edit resumes again.
    let cfg_toml = run.join("config.toml");
    let text = std::fs::read_to_string(&cfg_toml).unwrap();
    assert!(text.contains("map_height = 20\n"), "{text}");
    std::fs::write(
        &cfg_toml,
        text.replace("map_height = 20\n", "map_height = 30\n"),
    )
    .unwrap();
    let e = error_line(&madenet(&["train", "--resume", r, "--episodes", "5", "-q"]));
    assert!(
        e.contains("config.toml") && e.contains("`map_height` (20 at the start, 30 now)"),
        "{e}"
    );
    std::fs::write(&cfg_toml, &text).unwrap();
    // The model folder records its weights' digests.
    let best = run.join("best");
    let info = std::fs::read_to_string(best.join("model.toml")).unwrap();
    assert!(info.contains("digests = [\""), "{info}");
    // The trained model plays a generated map.
    assert_model_plays(&best);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_training_input_is_one_line() {
    let dir = Scratch::new("train-cli-bad");
    let cfg = dir.join("bad.toml");
    std::fs::write(&cfg, "gamma = 2.0\n").unwrap();
    let out = dir.join("out");
    let e = config_error(&cfg, &out);
    assert!(e.contains("bad.toml") && e.contains("gamma"), "{e}");
    let e = error_line(&madenet(&[
        "train",
        "--resume",
        dir.join("nothing").to_str().unwrap(),
    ]));
    assert!(e.contains("nothing") && e.contains("config.toml"), "{e}");
    let e = error_line(&madenet(&[
        "train",
        "--out",
        out.to_str().unwrap(),
        "--method",
        "dqn",
    ]));
    assert!(e.contains("dqn"), "{e}");
    // A learned model refuses a team size it was not trained for.
    let four = dir.join("four.toml");
    std::fs::write(&four, "num_robots = 4\n").unwrap();
    let e = error_line(&madenet(&[
        "run",
        "--map",
        "paper:1",
        "--policy",
        "made-net-paper",
        "--start",
        "0,0;0,1;1,0;1,1",
        "--config",
        four.to_str().unwrap(),
    ]));
    assert!(
        e.contains("made-net-paper") && e.contains("3 robots"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

const TINY_DME: &str = "method = \"dme-drl\"\nepisodes = 2\nbatch_size = 4\nreplay_steps = 100\nwarmup_steps = 8\nupdate_every = 4\nhidden = 16\nvalidate_every = 2\nvalidation_maps = 1\nvalidation_csp = [0.5]\ncheckpoint_every = 1\nthreads = 1\n[scenario]\nstep_cap = 25\n";

#[test]
fn dme_drl_tiny_run_resume_model_and_bad_input() {
    // The config's `method` picks the learner; --method dme-drl says the same.
    let (dir, _, run) = tiny_run("train-cli-dme", "tiny-dme.toml", TINY_DME, "dme-drl");
    let r = run.to_str().unwrap();
    let updates = std::fs::read_to_string(run.join("updates.csv")).unwrap();
    assert!(
        updates.starts_with("update,critic_loss,actor_loss"),
        "{updates}"
    );
    let o = madenet(&["train", "--resume", r, "--episodes", "3", "-q"]);
    assert_ok(&o);
    assert_eq!(episode_lines(&run), 1 + 3);
    let o = madenet(&["train", "--resume", r, "--episodes", "3", "-q"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && e.contains("nothing left to train"),
        "{e}"
    );
    let o = madenet(&["plot-training", r]);
    assert_ok(&o);
    assert_model_plays(&run.join("last"));
    // Bad DME-DRL input: the file and field named, exit 2.
    let bad = dir.join("bad-dme.toml");
    std::fs::write(&bad, "method = \"dme-drl\"\ntau = 0.0\n").unwrap();
    let e = config_error(&bad, &dir.join("x"));
    assert!(e.contains("bad-dme.toml") && e.contains("tau"), "{e}");
    std::fs::write(&bad, "method = \"dme-drl\"\ntrace_len = 4\n").unwrap();
    let e = config_error(&bad, &dir.join("x"));
    assert!(e.contains("bad-dme.toml") && e.contains("trace_len"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A run stopped before its first validation has no `best/`: it says so and names the model
/// it does have (`last/`), which plays (the README's next command used to fail on `best/`).
#[test]
fn a_run_without_validation_names_its_model() {
    let dir = Scratch::new("train-no-best");
    let cfg = dir.write(
        "short.toml",
        &TINY.replace("validate_every = 3", "validate_every = 50"),
    );
    let run = dir.join("run");
    let (c, r) = (cfg.to_str().unwrap(), run.to_str().unwrap());
    let o = madenet(&[
        "train",
        "--config",
        c,
        "--out",
        r,
        "--method",
        "made-net-dt",
        "-q",
    ]);
    assert_ok(&o);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!run.join("best").exists());
    assert!(e.contains("no best/ yet") && e.contains("--model"), "{e}");
    assert_model_plays(&run.join("last"));
}
