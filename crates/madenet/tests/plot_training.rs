//! `madenet plot-training` end to end: a run directory's `episodes.csv` becomes a PNG (at the
//! default path or `--out`); bad input gives exit code 2 and one `error:` line naming the file.

use madenet_testkit::{assert_clean_error, run, Scratch};
use std::path::Path;
use std::process::Output;

fn madenet(args: &[&str]) -> Output {
    run(env!("CARGO_BIN_EXE_madenet"), args)
}

const EPISODES: &str = "episode,env,csp,steps,team_reward,complete,epsilon,updates,wall_s
0,cen,1,300,-95.5,0,1.0,0,1.2
1,cen,1,210,-60.25,1,0.9,12,2.3
2,dec,0.5,180,-41,1,0.8,30,3.1
3,cen,1,150,-30.5,1,0.7,51,4.0
4,dec,0.5,120,-22,1,0.6,70,4.8
";

fn png_size(path: &Path) -> (u32, u32) {
    // PNG IHDR: width and height are the big-endian u32s at bytes 16..24.
    let b = std::fs::read(path).expect("png");
    assert_eq!(&b[1..4], b"PNG");
    (
        u32::from_be_bytes(b[16..20].try_into().unwrap()),
        u32::from_be_bytes(b[20..24].try_into().unwrap()),
    )
}

/// `madenet plot-training <dir> <extra...>`, which must succeed; its stdout, trimmed.
fn plot_ok(dir: &Path, extra: &[&str]) -> String {
    let out = madenet(&[&["plot-training", dir.to_str().unwrap()][..], extra].concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}

/// A fresh run directory `run` under the scratch dir.
fn run_dir(s: &Scratch) -> std::path::PathBuf {
    let dir = s.path().join("run");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Plotting `dir` prints the default figure path, and that figure is two panels (1600 × 564).
fn plots_two_panels_at_the_default_path(dir: &Path, why: &str) {
    let png = dir.join("fig2_training.png");
    assert_eq!(plot_ok(dir, &[]), png.display().to_string());
    assert_eq!(png_size(&png), (1600, 564), "{why}");
}

#[test]
fn plot_training_writes_the_png_and_prints_its_path() {
    let s = Scratch::new("ok");
    let dir = run_dir(&s);
    std::fs::write(dir.join("episodes.csv"), EPISODES).unwrap();

    plots_two_panels_at_the_default_path(&dir, "two panels side by side under the legend");

    // With validation rows, a third panel; --out puts the figure elsewhere.
    std::fs::write(
        dir.join("validation.csv"),
        "episode,updates,mean_steps,mean_team_reward,completed,trials\n2,30,150.5,-40,3,5\n4,70,110,-25.5,5,5\n",
    )
    .unwrap();
    let other = s.path().join("figs").join("training.png");
    plot_ok(&dir, &["--out", other.to_str().unwrap()]);
    assert_eq!(png_size(&other).0, 2400);
}

#[test]
fn plot_training_bad_input_is_one_line_naming_the_file() {
    let s = Scratch::new("bad");
    let dir = s.path().join("no-such-run");
    let out = madenet(&["plot-training", dir.to_str().unwrap()]);
    assert_clean_error(&out, &[&dir.join("episodes.csv").display().to_string()]);

    let dir = s.path();
    std::fs::write(
        dir.join("episodes.csv"),
        "episode,env,csp,steps,team_reward,complete,epsilon,updates,wall_s\n",
    )
    .unwrap();
    let out = madenet(&["plot-training", dir.to_str().unwrap()]);
    assert_clean_error(&out, &["episodes.csv", "no episodes"]);

    std::fs::write(
        dir.join("episodes.csv"),
        EPISODES.replace("2,dec,0.5,180", "2,dec,0.5,many"),
    )
    .unwrap();
    let out = madenet(&["plot-training", dir.to_str().unwrap()]);
    assert_clean_error(&out, &["episodes.csv:4:", "column `steps` = \"many\""]);

    std::fs::write(dir.join("episodes.csv"), EPISODES).unwrap();
    let out = madenet(&["plot-training", dir.to_str().unwrap(), "--out", "fig.jpg"]);
    assert_clean_error(&out, &["fig.jpg", ".png or .svg"]);
    assert!(!dir.join("fig2_training.png").exists());
}

#[test]
fn a_rollout_runs_iterations_become_a_steps_and_a_loss_panel() {
    let s = Scratch::new("rollout");
    let dir = run_dir(&s);
    let mut csv = String::from(
        "iteration,episodes,decisions,rollouts,behaviour_steps,updates,loss,validation_steps,greedy_steps,spread_margin,base_steps,validation_completed,validation_trials,wall_s\n",
    );
    for i in 0..6 {
        csv += &format!(
            "{i},{},20000,100000,120.5,3000,0.{},{},{},0.4,336.9,116,120,{}\n",
            400 * (i + 1),
            107 + i,
            337.0 - i as f64,
            399.9 - 5.0 * i as f64,
            600 * (i + 1)
        );
    }
    std::fs::write(dir.join("iterations.csv"), csv).unwrap();
    plots_two_panels_at_the_default_path(&dir, "steps and loss side by side under the legend");
    // Only the figure asked for is written; a format it cannot write is refused.
    assert!(!dir.join("fig2_training.svg").exists());
    let out = madenet(&["plot-training", dir.to_str().unwrap(), "--out", "fig.jpg"]);
    assert_clean_error(&out, &["fig.jpg", ".png or .svg"]);
}
