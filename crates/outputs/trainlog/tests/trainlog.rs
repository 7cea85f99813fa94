//! The training-log CSVs (writing, reading, errors naming file, line and
//! column) and the Fig. 2 plot drawn from a run directory.

use std::path::{Path, PathBuf};

use madenet_trainlog::{
    plot_training, read_episodes, read_validation, Env, EpisodeRow, LogRow, LogWriter,
    TrainLogError, ValidationRow,
};

/// A fresh, empty directory for one test.
fn dir(name: &str) -> PathBuf {
    madenet_testkit::fresh_dir(format!(
        "{}/madenet-trainlog-tests/{name}",
        env!("CARGO_TARGET_TMPDIR")
    ))
}

fn episode(episode: u64, env: Env, steps: u32, team_reward: f64) -> EpisodeRow {
    EpisodeRow {
        episode,
        env,
        csp: if env == Env::Cen { 1.0 } else { 0.5 },
        steps,
        team_reward,
        complete: steps < 300,
        epsilon: 0.25,
        updates: episode * 10,
        wall_s: episode as f64 * 0.5,
    }
}

fn validation(episode: u64, mean_steps: f64) -> ValidationRow {
    ValidationRow {
        episode,
        updates: episode * 10,
        mean_steps,
        mean_team_reward: -mean_steps / 4.0,
        completed: 9,
        trials: 10,
    }
}

/// Width and height of a PNG, from its IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(
        &b[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        path.display()
    );
    (
        u32::from_be_bytes(b[16..20].try_into().unwrap()),
        u32::from_be_bytes(b[20..24].try_into().unwrap()),
    )
}

/// Asserts the error's message is one line containing every needle.
fn assert_msg<T: std::fmt::Debug>(r: Result<T, TrainLogError>, needles: &[&str]) -> TrainLogError {
    let e = r.unwrap_err();
    let msg = e.to_string();
    assert_eq!(msg.lines().count(), 1, "{msg:?}");
    for n in needles {
        assert!(msg.contains(n), "{msg:?} lacks {n:?}");
    }
    e
}

const HEADER: &str = "episode,env,csp,steps,team_reward,complete,epsilon,updates,wall_s";

#[test]
fn headers_are_the_documented_ones() {
    use madenet_trainlog::read_rows;
    let d = dir("headers");
    for (path, text) in [
        (
            d.join("e.csv"),
            format!("{}\n{}\n", EpisodeRow::HEADER, EpisodeRow::EXAMPLE),
        ),
        (
            d.join("v.csv"),
            format!("{}\n{}\n", ValidationRow::HEADER, ValidationRow::EXAMPLE),
        ),
    ] {
        std::fs::write(&path, text).unwrap();
    }
    assert_eq!(
        read_rows::<EpisodeRow>(&d.join("e.csv")).unwrap().len(),
        1,
        "EXAMPLE is valid"
    );
    assert_eq!(
        read_rows::<ValidationRow>(&d.join("v.csv")).unwrap().len(),
        1,
        "EXAMPLE is valid"
    );
    assert_eq!(EpisodeRow::HEADER, HEADER);
    assert_eq!(EpisodeRow::FILE_NAME, "episodes.csv");
    assert_eq!(
        ValidationRow::HEADER,
        "episode,updates,mean_steps,mean_team_reward,completed,trials"
    );
    assert_eq!(ValidationRow::FILE_NAME, "validation.csv");
}

#[test]
fn written_rows_read_back_and_the_text_is_plain_csv() {
    let d = dir("roundtrip");
    let path = d.join("run").join("episodes.csv");
    let rows = vec![
        episode(0, Env::Cen, 143, -57.25),
        episode(1, Env::Dec, 300, -80.0),
    ];
    let mut w = LogWriter::open(&path).unwrap();
    assert_eq!(w.path(), path);
    for r in &rows {
        w.append(r).unwrap();
    }
    // Flushed per row: visible before the writer is dropped.
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(
        text,
        format!("{HEADER}\n0,cen,1.0,143,-57.25,1,0.25,0,0.0\n1,dec,0.5,300,-80.0,0,0.25,10,0.5\n")
    );
    assert_eq!(read_episodes(&path).unwrap(), rows);
    drop(w);

    // Reopening appends, without a second header.
    let mut w = LogWriter::open(&path).unwrap();
    w.append(&episode(2, Env::Cen, 99, -20.5)).unwrap();
    let back = read_episodes(&path).unwrap();
    assert_eq!(back.len(), 3);
    assert_eq!(back[2], episode(2, Env::Cen, 99, -20.5));
    assert_eq!(
        std::fs::read_to_string(&path)
            .unwrap()
            .matches("episode,")
            .count(),
        1
    );

    let vpath = d.join("run").join("validation.csv");
    let mut v = LogWriter::open(&vpath).unwrap();
    v.append(&validation(100, 62.5)).unwrap();
    assert_eq!(
        std::fs::read_to_string(&vpath).unwrap(),
        "episode,updates,mean_steps,mean_team_reward,completed,trials\n100,1000,62.5,-15.625,9,10\n"
    );
    assert_eq!(
        read_validation(&vpath).unwrap(),
        vec![validation(100, 62.5)]
    );
}

#[test]
fn a_row_cut_short_is_skipped_by_readers_and_cut_off_by_the_writer() {
    let d = dir("partial");
    let path = d.join("episodes.csv");
    std::fs::write(
        &path,
        format!("{HEADER}\n0,cen,1,143,-57.25,1,0.25,0,0.0\n1,dec,0.5,30"),
    )
    .unwrap();
    assert_eq!(read_episodes(&path).unwrap().len(), 1);
    // The same line complete but bad is an error.
    std::fs::write(
        &path,
        format!("{HEADER}\n0,cen,1,143,-57.25,1,0.25,0,0.0\n1,dec,0.5,30\n"),
    )
    .unwrap();
    assert_msg(
        read_episodes(&path),
        &[&format!("{}:3:", path.display()), "4 fields, expected 9"],
    );

    std::fs::write(
        &path,
        format!("{HEADER}\n0,cen,1,143,-57.25,1,0.25,0,0.0\n1,dec,0.5,30"),
    )
    .unwrap();
    let mut w = LogWriter::open(&path).unwrap();
    w.append(&episode(1, Env::Dec, 30, -3.0)).unwrap();
    assert_eq!(
        std::fs::read_to_string(&path).unwrap(),
        format!("{HEADER}\n0,cen,1,143,-57.25,1,0.25,0,0.0\n1,dec,0.5,30,-3.0,1,0.25,10,0.5\n")
    );

    // Nothing or a header still being written: no rows; the writer starts afresh.
    for text in ["", "episode,env,cs", HEADER, &format!("{HEADER}\n")] {
        std::fs::write(&path, text).unwrap();
        assert_eq!(read_episodes(&path).unwrap(), vec![], "{text:?}");
        LogWriter::<EpisodeRow>::open(&path).unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            format!("{HEADER}\n"),
            "{text:?}"
        );
    }
}

#[test]
fn bad_files_give_one_line_naming_file_line_and_column() {
    let d = dir("bad");
    let path = d.join("episodes.csv");
    let name = path.display().to_string();

    let e = assert_msg(
        read_episodes(d.join("missing.csv")),
        &["cannot read", "missing.csv"],
    );
    assert!(matches!(e, TrainLogError::Io { .. }));

    std::fs::write(
        &path,
        "episode,env,csp,steps,reward,complete,epsilon,updates,wall_s\n",
    )
    .unwrap();
    assert_msg(
        read_episodes(&path),
        &[
            &format!("{name}:1: header is `episode,env,csp,steps,reward"),
            "expected `episode",
        ],
    );
    assert_msg(LogWriter::<EpisodeRow>::open(&path), &[&name, "header is"]);
    std::fs::write(&path, "a,b\n").unwrap();
    assert_msg(
        read_validation(&path),
        &[&name, "expected `episode,updates,mean_steps"],
    );

    let ok = "0,cen,1,143,-57.25,1,0.25,0,0.0";
    let cases = [
        (
            "1,cen,1,-3,-57.25,1,0.25,0,0.0",
            "column `steps` = \"-3\": invalid digit",
        ),
        (
            "1,both,1,3,-57.25,1,0.25,0,0.0",
            "column `env` = \"both\": unknown variant `both`, expected `cen` or `dec`",
        ),
        (
            "1,dec,1,3,-57.25,2,0.25,0,0.0",
            "column `complete` = \"2\": invalid value: integer `2`, expected 0 or 1",
        ),
        (
            "1,dec,1,3,-57.25,true,0.25,0,0.0",
            "column `complete` = \"true\"",
        ),
        (
            "1,dec,1,3,NaN,1,0.25,0,0.0",
            "team_reward is not finite (NaN)",
        ),
        ("1,dec,1.5,3,-1,1,0.25,0,0.0", "csp is 1.5, not in [0, 1]"),
        ("1,dec,1,3,-1,1,0.25,0,-2", "wall_s is negative"),
        ("1,dec,1,3,-1,1,0.25,0,0.0,7", "10 fields, expected 9"),
        ("1,dec,1,3,,1,0.25,0,0.0", "column `team_reward` = \"\""),
    ];
    for (row, needle) in cases {
        std::fs::write(&path, format!("{HEADER}\n{ok}\n{row}\n")).unwrap();
        assert_msg(read_episodes(&path), &[&format!("{name}:3: "), needle]);
    }
    std::fs::write(
        &path,
        b"episode,updates,mean_steps,mean_team_reward,completed,trials\n1,2,3,4,11,10\n1,2,3,4,0,0\n",
    )
    .unwrap();
    assert_msg(
        read_validation(&path),
        &[&format!("{name}:2: completed (11) exceeds trials (10)")],
    );
    std::fs::write(
        &path,
        b"episode,updates,mean_steps,mean_team_reward,completed,trials\n1,2,3,4,0,0\n",
    )
    .unwrap();
    assert_msg(read_validation(&path), &[&format!("{name}:2: trials is 0")]);
    std::fs::write(
        &path,
        [HEADER.as_bytes(), b"\n0,cen,1,143,\xff,1,0.25,0,0.0\n"].concat(),
    )
    .unwrap();
    assert_msg(
        read_episodes(&path),
        &[&format!("{name}:2: not valid UTF-8")],
    );

    // The writer refuses bad rows and leaves the file as it was.
    let w_path = d.join("w.csv");
    let mut w = LogWriter::open(&w_path).unwrap();
    let mut row = episode(0, Env::Cen, 10, f64::INFINITY);
    assert_msg(
        w.append(&row),
        &[
            "w.csv",
            "refusing to append a row: team_reward is not finite (inf)",
        ],
    );
    row.team_reward = 1.0;
    row.epsilon = -0.1;
    assert_msg(w.append(&row), &["epsilon is -0.1"]);
    assert_eq!(
        std::fs::read_to_string(&w_path).unwrap(),
        format!("{HEADER}\n")
    );
}

/// A run directory with a learning-like `cen` then `dec` training and
/// validation every 250 episodes.
fn synthetic_run(d: &Path, episodes: u64) {
    let mut log = LogWriter::open(d.join("episodes.csv")).unwrap();
    let mut val = LogWriter::open(d.join("validation.csv")).unwrap();
    let mut noise = 0x2545_f491_u64;
    let mut normal = move || {
        // Sum of uniforms: roughly normal, deterministic.
        (0..4)
            .map(|_| {
                noise ^= noise << 13;
                noise ^= noise >> 7;
                noise ^= noise << 17;
                (noise >> 11) as f64 / (1u64 << 53) as f64
            })
            .sum::<f64>()
            - 2.0
    };
    for e in 0..episodes {
        let env = if e < episodes / 2 { Env::Cen } else { Env::Dec };
        let t = e as f64;
        let steps = (45.0 + 180.0 * (-t / 900.0).exp() + 40.0 * normal()).clamp(20.0, 300.0);
        let reward = -0.35 * steps + 20.0 * (1.0 - (-t / 600.0).exp()) + 10.0 * normal();
        let mut row = episode(e, env, steps as u32, reward);
        row.epsilon = (1.0 - t / episodes as f64).max(0.05);
        log.append(&row).unwrap();
        if e % 250 == 249 {
            val.append(&validation(e + 1, 40.0 + 150.0 * (-t / 1000.0).exp()))
                .unwrap();
        }
    }
}

#[test]
fn plot_training_draws_two_panels_or_three_with_validation() {
    let d = dir("plot");
    synthetic_run(&d, 3000);
    let png3 = d.join("fig2_with_validation.png");
    assert_eq!(plot_training(&d, &png3).unwrap(), png3);
    assert_eq!(png_size(&png3).0, 2400, "three panels");
    // SVG by extension only; no PNG beside it.
    let svg = d.join("figs").join("fig2.svg");
    plot_training(&d, &svg).unwrap();
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg"));
    for t in [
        "Team reward per episode",
        "Steps per episode",
        "Validation",
        "centralized: EWMA 0.9",
        "decentralized: per episode",
        "validation: mean of 10 trials",
        "Episode",
    ] {
        assert!(text.contains(t), "SVG lacks {t:?}");
    }
    assert!(!d.join("figs").join("fig2.png").exists());

    // Without validation rows: two panels.
    let png = d.join("fig2_training.png");
    std::fs::write(d.join("validation.csv"), "").unwrap();
    plot_training(&d, &png).unwrap();
    assert_eq!(png_size(&png).0, 1600, "two panels");
    std::fs::remove_file(d.join("validation.csv")).unwrap();
    plot_training(&d, &png).unwrap();
    assert_eq!(png_size(&png).0, 1600);
}

#[test]
fn plot_training_copes_with_tiny_resumed_and_one_env_logs() {
    let d = dir("tiny");
    let p = d.join("episodes.csv");
    std::fs::write(&p, format!("{HEADER}\n0,dec,0.5,12,-3.5,1,1.0,0,0.1\n")).unwrap();
    plot_training(&d, &d.join("one.png")).unwrap();
    // Episodes 2 and 3 logged twice (resumed from an older checkpoint), out of order.
    std::fs::write(
        &p,
        format!(
            "{HEADER}\n0,cen,1,50,-9,1,1,0,0.1\n1,cen,1,40,-8,1,1,0,0.2\n2,cen,1,300,-99,0,1,0,0.3\n\
             3,dec,0.5,30,-7,1,1,0,0.4\n2,cen,1,35,-6,1,1,0,0.5\n3,dec,0.5,33,-5,1,1,0,0.6\n"
        ),
    )
    .unwrap();
    let out = d.join("resumed.png");
    plot_training(&d, &out).unwrap();
    assert_eq!(png_size(&out), png_size(&d.join("one.png")));
}

#[test]
fn plot_training_errors_name_the_file() {
    let d = dir("plot-errors");
    let out = d.join("fig.png");
    let e = assert_msg(
        plot_training(&d, &out),
        &["cannot read", &d.join("episodes.csv").display().to_string()],
    );
    assert!(matches!(e, TrainLogError::Io { .. }));
    for text in ["".to_string(), format!("{HEADER}\n")] {
        std::fs::write(d.join("episodes.csv"), text).unwrap();
        let e = assert_msg(
            plot_training(&d, &out),
            &[&d.join("episodes.csv").display().to_string(), "no episodes"],
        );
        assert!(matches!(e, TrainLogError::NoEpisodes { .. }));
    }
    std::fs::write(
        d.join("episodes.csv"),
        format!("{HEADER}\n0,cen,1,50,-9,1,1,0,0.1\n"),
    )
    .unwrap();
    std::fs::write(d.join("validation.csv"), "episode,updates\n").unwrap();
    assert_msg(
        plot_training(&d, &out),
        &["validation.csv:1: header is `episode,updates`"],
    );
    std::fs::remove_file(d.join("validation.csv")).unwrap();
    assert_msg(
        plot_training(&d, &d.join("fig.jpg")),
        &["fig.jpg", "must end in .png or .svg"],
    );
    assert!(!out.exists());
}
