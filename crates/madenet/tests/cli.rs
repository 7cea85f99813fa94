//! The `madenet` binary end to end: good runs produce their outputs, bad input gives one
//! clear line naming the file and field, exit code 2, and never a panic.

mod common;

use common::{madenet, madenet_with, madenet_with_extra};
use madenet_testkit::{assert_clean_error, assert_ok, Scratch};
use std::process::Output;

#[test]
fn run_prints_metrics_and_writes_pictures() {
    let dir = Scratch::new("cli-run");
    let gif = dir.join("trial.gif");
    let png = dir.join("trial.png");
    let out = madenet_with(
        "run --map paper:3 --start top-right --csp 0.8 --seed 7 --render {} --snapshot {}",
        &[gif.to_str().unwrap(), png.to_str().unwrap()],
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    assert!(text.contains("completed  true"), "{text}");
    assert!(text.contains("TNS"), "{text}");
    assert!(std::fs::metadata(&gif).unwrap().len() > 1000);
    let img = image_size(&png);
    assert!(img.0 > 300 && img.1 > 200, "{img:?}");
}

fn image_size(path: &std::path::Path) -> (u32, u32) {
    // PNG IHDR: width and height are the big-endian u32s at bytes 16..24.
    let b = std::fs::read(path).expect("png");
    assert_eq!(&b[1..4], b"PNG");
    (
        u32::from_be_bytes(b[16..20].try_into().unwrap()),
        u32::from_be_bytes(b[20..24].try_into().unwrap()),
    )
}

#[test]
fn json_output_is_deterministic() {
    let args = [
        "run",
        "--generate",
        "11",
        "--start",
        "bottom-left",
        "--csp",
        "0.5",
        "--seed",
        "3",
        "--json",
        "--trajectory",
    ];
    let a = madenet(&args);
    let b = madenet(&args);
    assert!(a.status.success());
    // Everything but the wall-clock timing block must be byte-identical.
    let strip = |o: &Output| {
        let s = String::from_utf8_lossy(&o.stdout).into_owned();
        s[..s.find("\"timing\"").expect("timing field")].to_string()
    };
    assert_eq!(strip(&a), strip(&b));
    assert!(strip(&a).contains("\"trajectory\": ["));
}

#[test]
fn map_convert_generate_show_round_trip() {
    let dir = Scratch::new("cli-maps");
    let yaml = dir.join("gen.yaml");
    let txt = dir.join("gen.txt");
    assert!(
        madenet(&["map", "generate", "--seed", "5", yaml.to_str().unwrap()])
            .status
            .success()
    );
    assert!(madenet(&[
        "map",
        "convert",
        yaml.to_str().unwrap(),
        txt.to_str().unwrap()
    ])
    .status
    .success());
    let from_yaml = madenet(&["map", "show", yaml.to_str().unwrap()]);
    let from_txt = madenet(&["map", "show", txt.to_str().unwrap()]);
    let grid = |o: &Output| {
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .take(20)
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(grid(&from_yaml), grid(&from_txt));
    assert_eq!(grid(&from_yaml).lines().count(), 20);
}

#[test]
fn map_show_warns_of_passages_through_thin_walls() {
    let dir = Scratch::new("cli-passages");
    // 60 × 60 pixels of 0.1 m (6 × 6 cells of 1 m): a solid block bottom-left (kept: most
    // obstacle pixels stay in obstacle cells) and a one-pixel wall down pixel column 20 from
    // the top to row 40, 10 % of each cell it crosses (erased at the default 25 %).
    let mut px = vec![254u8; 3600];
    for r in 40..60 {
        px[r * 60..r * 60 + 10].fill(0);
    }
    for r in 0..40 {
        px[r * 60 + 20] = 0;
    }
    let mut pgm = b"P5\n60 60\n255\n".to_vec();
    pgm.extend(&px);
    std::fs::write(dir.join("rooms.pgm"), pgm).unwrap();
    let yaml = dir.join("rooms.yaml");
    std::fs::write(
        &yaml,
        "image: rooms.pgm\nresolution: 0.1\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
    )
    .unwrap();
    // `map show` and `map convert` (issue 59: a conversion erased walls without a word).
    let converted = dir.join("rooms.txt");
    for args in [
        vec!["map", "show", yaml.to_str().unwrap()],
        vec![
            "map",
            "convert",
            yaml.to_str().unwrap(),
            converted.to_str().unwrap(),
        ],
    ] {
        let out = madenet(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        assert!(
            err.contains("warning: ")
                && err.contains("rooms.yaml")
                && err.contains("opens passages the map does not have at 3 free cells")
                && err.contains("discretize.obstacle_fraction"),
            "{args:?}: {err}"
        );
    }
    assert!(converted.exists());
    // With the setting the warning names, the wall stays and nothing is said.
    let keep = dir.join("keep.toml");
    std::fs::write(&keep, "[discretize]\nobstacle_fraction = 0.05\n").unwrap();
    let out = madenet(&[
        "map",
        "show",
        yaml.to_str().unwrap(),
        "--config",
        keep.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(!err.contains("warning"), "{err}");
}

#[test]
fn missing_map_file() {
    assert_clean_error(
        &madenet(&["run", "--map", "no/such/map.yaml"]),
        &["no/such/map.yaml"],
    );
}

/// `madenet run <flag> <file>`, the file `name` in a scratch folder tagged `tag` holding `text`,
/// is refused with one error line naming each of `needles`.
fn run_refuses_file(tag: &str, name: &str, text: &str, flag: &str, needles: &[&str]) {
    let dir = Scratch::new(tag);
    let file = dir.write(name, text);
    assert_clean_error(&madenet(&["run", flag, file.to_str().unwrap()]), needles);
}

#[test]
fn malformed_yaml_names_file_and_field() {
    run_refuses_file(
        "cli-bad-yaml",
        "bad.yaml",
        "image: x.pgm\nresolution: fast\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.25\n",
        "--map",
        &["bad.yaml", "resolution"],
    );
}

#[test]
fn truncated_pgm_names_the_image() {
    let dir = Scratch::new("cli-bad-pgm");
    std::fs::write(dir.join("m.pgm"), b"P5\n20 20\n255\n\x00\x00").unwrap();
    std::fs::write(dir.join("m.yaml"), "image: m.pgm\nresolution: 1.0\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.25\n").unwrap();
    assert_clean_error(
        &madenet(&["run", "--map", dir.join("m.yaml").to_str().unwrap()]),
        &["m.pgm"],
    );
}

#[test]
fn start_in_obstacle() {
    // (0, 9) is an obstacle on test_1.
    let map = madenet_map::paper::paper_map(1).unwrap();
    let blocked = (0..20)
        .find(|&c| !map.is_free(madenet_map::Pos::new(0, c)))
        .expect("an obstacle in row 0");
    let start = format!("0,{blocked};1,0;0,1");
    assert_clean_error(
        &madenet(&["run", "--start", &start]),
        &[&format!("(0, {blocked})"), "not free"],
    );
}

#[test]
fn more_robots_than_start_cells() {
    run_refuses_file(
        "cli-robots",
        "four.toml",
        "num_robots = 4\n",
        "--config",
        &["num_robots"],
    );
}

#[test]
fn unknown_policy() {
    assert_clean_error(
        &madenet(&["run", "--policy", "teleport"]),
        &["teleport", "nf"],
    );
}

#[test]
fn bad_config_values() {
    let dir = Scratch::new("cli-cfg");
    let cases = [
        ("comm_success_prob = 1.5\n", "comm_success_prob"),
        ("sensing_rnage = 4\n", "sensing_rnage"),
        ("movement = \"teleport\"\n", "movement"),
        (
            "[discretize]\noccupied_prob = \"high\"\n",
            "discretize.occupied_prob",
        ),
    ];
    for (i, (text, field)) in cases.iter().enumerate() {
        let cfg = dir.join(format!("c{i}.toml"));
        std::fs::write(&cfg, text).unwrap();
        assert_clean_error(
            &madenet(&["run", "--config", cfg.to_str().unwrap()]),
            &[&format!("c{i}.toml"), field],
        );
    }
    assert_clean_error(&madenet(&["run", "--csp=-0.1"]), &["comm_success_prob"]);
}

#[test]
fn oracle_reports_beside_its_base_and_refuses_bad_arguments() {
    // The noiseless oracle on two trials, with `extra` flags.
    let noiseless = |extra: &[&str]| {
        madenet_with_extra(
            "oracle --maps generate-wide:5 --starts top-left,random --kind noiseless --csp 1",
            &[],
            extra,
        )
    };
    let out = noiseless(&[]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    assert!(
        text.contains("2 trials")
            && text.contains("oracle Noiseless over base `spread`")
            && text.contains("base TNS"),
        "{text}"
    );
    assert_clean_error(&madenet(&["oracle", "--seeds", "0"]), &["--seeds"]);
    assert_clean_error(&madenet(&["oracle", "--futures", "0"]), &["--futures"]);
    assert_clean_error(
        &madenet(&["oracle", "--base", "nf", "--maps", "paper:3"]),
        &["--base", "nf"],
    );
    assert_clean_error(&madenet(&["oracle", "--base", "nope"]), &["--base", "nope"]);
    // Continuations cut and valued by mean discovery: the same trials, said in the summary.
    let cut = noiseless(&["--horizon", "30", "--value", "mean-discovery"]);
    let cut_text = String::from_utf8_lossy(&cut.stdout);
    assert!(
        cut.status.success()
            && cut_text.contains("2 trials")
            && cut_text.contains("valued by mean-discovery over 30 steps"),
        "{cut_text}"
    );
    // … and it ran so: the same base trials, other oracle choices (94.5 vs 91.0 steps here).
    let oracle_tns = |t: &str| {
        let line = t
            .lines()
            .find(|l| l.starts_with("csp 1.00"))
            .unwrap()
            .to_string();
        let base = line.split("oracle TNS").next().unwrap().to_string();
        (
            base,
            line.split("oracle TNS")
                .nth(1)
                .unwrap()
                .split_whitespace()
                .next()
                .unwrap()
                .to_string(),
        )
    };
    let (full, cut) = (oracle_tns(&text), oracle_tns(&cut_text));
    assert_eq!(full.0, cut.0, "same base trials");
    assert_ne!(full.1, cut.1, "the lookahead changed the oracle's choices");
    assert_clean_error(
        &madenet(&["oracle", "--kind", "noiseless", "--horizon", "100001"]),
        &["--horizon"],
    );
    assert_clean_error(
        &madenet(&["oracle", "--kind", "placebo", "--value", "mean-discovery"]),
        &["--horizon/--value"],
    );
}

#[test]
fn spread_and_random_starts_run_and_a_random_start_without_room_is_an_error() {
    let out = madenet_with(
        "run --map generate-wide:5 --start random --policy spread --json",
        &[],
    );
    assert_ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("\"policy\": \"spread\""));
    // A map whose free cells are single pockets: no three connected free cells anywhere.
    let dir = Scratch::new("cli-pockets");
    let map = dir.join("pockets.txt");
    std::fs::write(&map, ".#.#.#\n######\n.#.#.#\n######\n.#.#.#\n######\n").unwrap();
    assert_clean_error(
        &madenet(&["run", "--map", map.to_str().unwrap(), "--start", "random"]),
        &["random"],
    );
}

#[test]
fn a_continuous_run_explores_draws_and_refuses_bad_input() {
    let dir = Scratch::new("cli-continuous");
    let png = dir.join("run.png");
    let out = madenet_with(
        "run --world continuous --generate 3 --side 10 --start bottom-left --json --snapshot {}",
        &[png.to_str().unwrap()],
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    let r: serde_json::Value = serde_json::from_str(&text).expect("JSON result");
    assert_eq!(r["complete"], true, "{text}");
    assert_eq!(r["obstacle_collisions"], 0, "{text}");
    assert_eq!(r["robot_collisions"], 0, "{text}");
    assert!(r["exploration_time_s"].as_f64().unwrap() > 5.0, "{text}");
    let img = image::open(&png).expect("a PNG");
    // Five panels (world, team map, three robot maps) side by side.
    assert!(
        img.width() > 4 * img.height(),
        "{}x{}",
        img.width(),
        img.height()
    );

    let bad = |args: &[&str], needles: &[&str]| {
        assert_clean_error(
            &madenet_with_extra("run --world continuous", &[], args),
            needles,
        );
    };
    bad(&["--generate", "1", "--side", "2"], &["--side"]);
    let cfg = dir.join("c.toml");
    // (the world's flags, the continuous config, what the error names)
    let configs: [(&str, &str, &[&str]); 3] = [
        (
            "--generate 1",
            "[robot]\nmax_speed = -1.0\n",
            &["--continuous-config", "robot.max_speed"],
        ),
        ("--generate 1", "[lidar]\nbeam = 3\n", &["c.toml", "beam"]),
        // paper:1's top-left corner cells at 1 m: a robot of radius 0.6 m does not fit.
        (
            "--map paper:1",
            "[robot]\nradius = 0.6\n",
            &["robot.radius"],
        ),
    ];
    for (world, text, needles) in configs {
        std::fs::write(&cfg, text).unwrap();
        let line = format!("{world} --continuous-config {{}}");
        bad(&common::words(&line, &[cfg.to_str().unwrap()]), needles);
    }
    std::fs::remove_dir_all(&dir).ok();
}
