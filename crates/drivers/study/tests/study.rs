//! The comparison study end to end through `run_study`: bad input is refused before any trial
//! runs, a small study writes every output with consistent contents, an interrupted study
//! resumes to the same results, a different configuration is not mixed into old results, and
//! the results do not depend on the number of threads.
//!
//! Studies here are small (2 paper maps × 2 corners × 2 CSPs × 2 seeds per method) so the tests
//! stay fast in the dev profile.

use madenet_metrics::COVERAGE_LEVELS;
use madenet_study::{run_study, StudyConfig, TrialOutcome};
use madenet_testkit::{assert_curves_close, read, Scratch};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Columns of `trials.csv` holding wall-clock times: the only non-deterministic ones.
const WALL_CLOCK: [&str; 2] = ["trial_s", "per_decision_s"];
/// Columns of `summary.csv` holding wall-clock times (CT).
const SUMMARY_CT: [&str; 2] = ["trial_s", "per_decision_s"];
const METRICS: [&str; 4] = ["TNS", "TTD", "NOLI", "OFV"];

// ---------------------------------------------------------------------------------------------
// Helpers

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// methods × paper maps 1, 2 × top-left, bottom-right × `csp` × `seeds`.
fn small(methods: &[&str], csp: &[f64], seeds: u64) -> StudyConfig {
    StudyConfig {
        methods: strings(methods),
        maps: strings(&["paper:1", "paper:2"]),
        starts: strings(&["top-left", "bottom-right"]),
        csp: csp.to_vec(),
        seeds,
        oracles: vec![],
        ..StudyConfig::default()
    }
}

type StudyResult = Result<(PathBuf, Vec<TrialOutcome>), madenet_study::StudyError>;

/// Runs the study, recording every progress callback.
fn run(cfg: &StudyConfig, out: &Path, fresh: bool) -> (StudyResult, Vec<(usize, usize)>) {
    let calls = Mutex::new(Vec::new());
    let r = run_study(cfg, out, fresh, &|done, total| {
        calls.lock().unwrap().push((done, total))
    });
    (r, calls.into_inner().unwrap())
}

fn run_ok(
    cfg: &StudyConfig,
    out: &Path,
    fresh: bool,
) -> (PathBuf, Vec<TrialOutcome>, Vec<(usize, usize)>) {
    let (r, calls) = run(cfg, out, fresh);
    let (report, outcomes) = r.unwrap_or_else(|e| panic!("study failed: {e}"));
    (report, outcomes, calls)
}

/// A CSV file: header and records.
#[derive(Debug)]
struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn read(path: &Path) -> Table {
        Table::parse(
            csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
        )
    }
    fn read_str(text: &str) -> Table {
        Table::parse(csv::Reader::from_reader(text.as_bytes()))
    }
    fn parse<R: std::io::Read>(mut rdr: csv::Reader<R>) -> Table {
        let header = rdr.headers().unwrap().iter().map(String::from).collect();
        let rows = rdr
            .records()
            .map(|r| r.unwrap().iter().map(String::from).collect())
            .collect();
        Table { header, rows }
    }
    fn col(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column `{name}` in {:?}", self.header))
    }
    fn get<'a>(&self, row: &'a [String], name: &str) -> &'a str {
        &row[self.col(name)]
    }
    fn num(&self, row: &[String], name: &str) -> f64 {
        let v = self.get(row, name);
        v.parse()
            .unwrap_or_else(|_| panic!("column `{name}`: `{v}` is not a number"))
    }
    /// Header and rows without the named columns.
    fn without(&self, drop: &[&str]) -> (Vec<String>, Vec<Vec<String>>) {
        let keep: Vec<usize> = (0..self.header.len())
            .filter(|&i| !drop.contains(&self.header[i].as_str()))
            .collect();
        assert_eq!(
            keep.len() + drop.len(),
            self.header.len(),
            "every dropped column exists: {drop:?} in {:?}",
            self.header
        );
        let pick = |r: &Vec<String>| keep.iter().map(|&i| r[i].clone()).collect::<Vec<_>>();
        (pick(&self.header), self.rows.iter().map(pick).collect())
    }
}

/// `bad` is refused with a one-line message containing every needle, before any trial runs:
/// no progress, no record files.
fn assert_refused(bad: &StudyConfig, needles: &[&str]) {
    let dir = Scratch::new("study-refused");
    let out = dir.path().join("out");
    let (r, calls) = run(bad, &out, false);
    let msg = match r {
        Ok(_) => panic!("study {bad:?} ran; expected a refusal naming {needles:?}"),
        Err(e) => e.to_string(),
    };
    assert!(!msg.contains('\n'), "one line expected: {msg}");
    for n in needles {
        assert!(msg.contains(n), "`{n}` missing from: {msg}");
    }
    assert!(
        calls.is_empty(),
        "progress reported before refusing: {calls:?}"
    );
    assert!(
        !out.join("trials.csv").exists(),
        "trials.csv written although the study was refused"
    );
    assert!(
        !out.join("curves.jsonl").exists(),
        "curves.jsonl written although the study was refused"
    );
    // With `fresh` too.
    let (r, calls) = run(bad, &out, true);
    assert!(r.is_err() && calls.is_empty() && !out.join("trials.csv").exists());
}

// ---------------------------------------------------------------------------------------------
// 1. Bad input

#[test]
fn unknown_method_is_refused_naming_field_and_method() {
    assert_refused(
        &small(&["nf", "teleport"], &[1.0], 1),
        &["methods", "teleport"],
    );
}

#[test]
fn empty_or_duplicate_methods_are_refused() {
    assert_refused(&small(&[], &[1.0], 1), &["methods"]);
    assert_refused(&small(&["nf", "nf"], &[1.0], 1), &["methods", "nf"]);
}

#[test]
fn missing_map_folder_or_file_is_refused_naming_the_path() {
    let dir = Scratch::new("study-missing-maps");
    let folder = dir.path().join("no_such_maps_folder");
    let file = dir.path().join("no_such_map.yaml");
    for missing in [&folder, &file] {
        let mut cfg = small(&["nf"], &[1.0], 1);
        cfg.maps = vec!["paper:1".into(), missing.display().to_string()];
        assert_refused(&cfg, &[&missing.display().to_string()]);
    }
    // A folder that exists but holds no maps.
    let empty = dir.path().join("empty_maps");
    std::fs::create_dir_all(&empty).unwrap();
    let mut cfg = small(&["nf"], &[1.0], 1);
    cfg.maps = vec![empty.display().to_string()];
    assert_refused(&cfg, &[&empty.display().to_string()]);
}

#[test]
fn bad_map_names_are_refused_naming_maps() {
    let mut cfg = small(&["nf"], &[1.0], 1);
    cfg.maps = vec!["paper:99".into()];
    assert_refused(&cfg, &["maps"]);
    cfg.maps = vec![];
    assert_refused(&cfg, &["maps"]);
    cfg.maps = vec!["paper:1".into(), "paper:1".into()];
    assert_refused(&cfg, &["maps"]);
}

#[test]
fn empty_csp_list_is_refused_naming_csp() {
    assert_refused(&small(&["nf"], &[], 1), &["csp"]);
}

#[test]
fn csp_outside_unit_interval_is_refused_naming_csp_and_value() {
    assert_refused(&small(&["nf"], &[1.0, 1.5], 1), &["csp", "1.5"]);
    assert_refused(&small(&["nf"], &[-0.1, 0.0], 1), &["csp", "-0.1"]);
    assert_refused(&small(&["nf"], &[f64::NAN], 1), &["csp"]);
}

#[test]
fn zero_seeds_is_refused_naming_seeds() {
    assert_refused(&small(&["nf"], &[1.0], 0), &["seeds"]);
}

#[test]
fn bad_starts_are_refused_naming_starts() {
    let mut cfg = small(&["nf"], &[1.0], 1);
    cfg.starts = vec!["top-left".into(), "middle-of-nowhere".into()];
    assert_refused(&cfg, &["starts"]);
    cfg.starts = vec![];
    assert_refused(&cfg, &["starts"]);
}

#[test]
fn malformed_study_toml_names_file_and_line() {
    let dir = Scratch::new("study-toml");
    let cases: [(&str, &str, &[&str]); 4] = [
        // A value of the wrong type on line 3.
        (
            "type.toml",
            "methods = [\"nf\"]\nmaps = [\"paper:1\"]\nseeds = \"two\"\n",
            &["line 3"],
        ),
        // A syntax error on line 2.
        (
            "syntax.toml",
            "methods = [\"nf\"]\ncsp = = [1.0]\nseeds = 1\n",
            &["line 2"],
        ),
        // An unknown field (typo) on line 4.
        (
            "unknown.toml",
            "methods = [\"nf\"]\nmaps = [\"paper:1\"]\nseeds = 1\nmethds = [\"ub\"]\n",
            &["line 4", "methds"],
        ),
        // A negative seed count on line 1.
        ("negative.toml", "seeds = -3\n", &["line 1"]),
    ];
    for (name, text, needles) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let msg = match StudyConfig::from_toml_file(&path) {
            Ok(c) => panic!("{name} parsed: {c:?}"),
            Err(e) => e.to_string(),
        };
        assert!(!msg.contains('\n'), "one line expected: {msg}");
        assert!(
            msg.contains(&path.display().to_string()),
            "file missing from: {msg}"
        );
        for n in needles {
            assert!(msg.contains(n), "{name}: `{n}` missing from: {msg}");
        }
    }
    // A missing study file names the file.
    let missing = dir.path().join("missing.toml");
    let msg = StudyConfig::from_toml_file(&missing)
        .unwrap_err()
        .to_string();
    assert!(msg.contains(&missing.display().to_string()), "{msg}");
}

#[test]
fn study_toml_values_are_validated_after_parsing() {
    // Well-formed TOML with values the study cannot run: parsing succeeds, validation refuses.
    let dir = Scratch::new("study-toml-values");
    let path = dir.path().join("study.toml");
    std::fs::write(
        &path,
        "methods = [\"nf\", \"teleport\"]\nmaps = [\"paper:1\"]\ncsp = [0.5]\nseeds = 1\n",
    )
    .unwrap();
    let cfg = StudyConfig::from_toml_file(&path).unwrap();
    assert_eq!(cfg.methods, strings(&["nf", "teleport"]));
    assert_eq!(cfg.csp, vec![0.5]);
    // Unset fields take the defaults.
    assert_eq!(cfg.starts, StudyConfig::default().starts);
    assert_refused(&cfg, &["methods", "teleport"]);
    std::fs::write(
        &path,
        "methods = [\"nf\"]\nmaps = [\"paper:1\"]\ncsp = [0.5, 1.2]\nseeds = 1\n",
    )
    .unwrap();
    assert_refused(
        &StudyConfig::from_toml_file(&path).unwrap(),
        &["csp", "1.2"],
    );
}

// ---------------------------------------------------------------------------------------------
// 2. Outputs

fn is_png(path: &Path) -> bool {
    std::fs::read(path).is_ok_and(|b| b.len() > 1000 && b.starts_with(b"\x89PNG\r\n\x1a\n"))
}

/// The rows of the calibration table in `report.md`: (method, CSP, metric).
fn calibration_rows(report: &str) -> Vec<(String, String, String)> {
    let start = report
        .find("## Calibration")
        .expect("a Calibration section in report.md");
    let section = &report[start..];
    let end = section[3..]
        .find("\n## ")
        .map(|i| i + 3)
        .unwrap_or(section.len());
    section[..end]
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| method") && !l.starts_with("|---"))
        .map(|l| {
            let cells: Vec<&str> = l.trim_matches('|').split('|').map(str::trim).collect();
            (
                cells[0].to_string(),
                cells[1].to_string(),
                cells[2].to_string(),
            )
        })
        .collect()
}

#[test]
fn small_study_writes_every_output_consistently() {
    let dir = Scratch::new("study-outputs");
    let out = dir.path();
    let methods = ["nf", "ub", "pb"];
    let cfg = small(&methods, &[1.0, 0.0], 2);
    let (report, outcomes, calls) = run_ok(&cfg, out, false);
    let total = 3 * 2 * 2 * 2 * 2;
    assert_eq!(outcomes.len(), total);
    assert_eq!(report, out.join("report.md"));
    // Progress: from 0 to total, one call per trial.
    assert_eq!(calls.first(), Some(&(0, total)));
    assert_eq!(calls.len(), total + 1, "{calls:?}");
    assert!(calls.contains(&(total, total)));
    assert!(calls.iter().all(|&(_, t)| t == total));

    // trials.csv: header with every column (the paper's metrics among them), one row per
    // planned trial, in plan order.
    let trials = Table::read(&out.join("trials.csv"));
    assert_eq!(trials.header, madenet_study::runner::header());
    for c in ["tns", "ttd_m", "noli", "ofv", "explored", "to_100"] {
        trials.col(c);
    }
    assert_eq!(trials.rows.len(), total);
    let mut keys = BTreeSet::new();
    for r in &trials.rows {
        assert_eq!(r.len(), trials.header.len());
        keys.insert((
            trials.get(r, "method").to_string(),
            trials.get(r, "map").to_string(),
            trials.get(r, "start").to_string(),
            trials.get(r, "csp").to_string(),
            trials.get(r, "seed").to_string(),
        ));
        assert!(
            ["true", "false"].contains(&trials.get(r, "completed")),
            "{r:?}"
        );
        let tns = trials.num(r, "tns");
        let cap = cfg.scenario.step_cap as f64;
        assert!(tns >= 1.0 && tns <= cap, "{r:?}");
        let e = trials.num(r, "explored");
        assert!((0.0..=1.0 + 1e-9).contains(&e), "{r:?}");
        // Completed ⇔ everything explored; then the trial ends the step 100 % is first
        // reached, else it runs to the cap and never reaches 100 %.
        let completed = trials.get(r, "completed") == "true";
        assert_eq!(completed, e >= 1.0 - 1e-12, "{r:?}");
        if completed {
            assert_eq!(trials.num(r, "to_100"), tns, "{r:?}");
        } else {
            assert_eq!((tns, trials.get(r, "to_100")), (cap, ""), "{r:?}");
        }
        // Coverage levels: reached in order, and each exactly when the final coverage is at
        // least that level (coverage never falls).
        let mut last = 0.0;
        for level in COVERAGE_LEVELS {
            let v = trials.get(r, &format!("to_{level}"));
            assert_eq!(
                v.is_empty(),
                e < level as f64 / 100.0 - 1e-12,
                "to_{level}: {r:?}"
            );
            if !v.is_empty() {
                let k: f64 = v.parse().unwrap();
                assert!(k >= last && k <= tns, "to_{level}: {r:?}");
                last = k;
            }
        }
        // TTD: positive, and at most every robot moving one diagonal cell every step.
        let ttd = trials.num(r, "ttd_m");
        let most = tns
            * cfg.scenario.num_robots as f64
            * std::f64::consts::SQRT_2
            * cfg.scenario.cell_size;
        assert!(ttd > 0.0 && ttd <= most + 1e-9, "{r:?}");
        assert!(trials.num(r, "ofv") >= 0.0);
        assert!(
            trials.num(r, "noli_authors") <= trials.num(r, "noli"),
            "{r:?}"
        );
        assert!(trials.num(r, "trial_s") >= 0.0 && trials.num(r, "decisions") >= 1.0);
    }
    let expected: BTreeSet<_> = methods
        .iter()
        .flat_map(|m| {
            ["test_1", "test_2"].into_iter().flat_map(move |map| {
                ["top-left", "bottom-right"].into_iter().flat_map(move |s| {
                    ["1", "0"].into_iter().flat_map(move |c| {
                        ["1", "2"].into_iter().map(move |seed| {
                            (
                                m.to_string(),
                                map.to_string(),
                                s.to_string(),
                                c.to_string(),
                                seed.to_string(),
                            )
                        })
                    })
                })
            })
        })
        .collect();
    assert_eq!(
        keys, expected,
        "one row per (method, map, start, csp, seed)"
    );
    // Plan order: methods in config order, first method first.
    assert_eq!(trials.get(&trials.rows[0], "method"), "nf");
    assert_eq!(trials.get(&trials.rows[total - 1], "method"), "pb");
    // Completion agrees with coverage for most trials on these small maps.
    assert!(
        trials
            .rows
            .iter()
            .filter(|r| trials.get(r, "completed") == "true")
            .count()
            > total / 2
    );

    // curves.jsonl: one line per trial, same order, consistent with the row.
    let curves = read(out.join("curves.jsonl"));
    let lines: Vec<&str> = curves.lines().collect();
    assert_eq!(lines.len(), total);
    for (line, r) in lines.iter().zip(&trials.rows) {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        let key = &v["key"];
        assert_eq!(key["method"], trials.get(r, "method"));
        assert_eq!(key["map"], trials.get(r, "map"));
        assert_eq!(key["start"], trials.get(r, "start"));
        assert_eq!(key["csp"], trials.get(r, "csp"));
        assert_eq!(
            key["seed"].as_u64().unwrap().to_string(),
            trials.get(r, "seed")
        );
        let ex: Vec<f64> = v["explored"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let di: Vec<f64> = v["distance"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(ex.len(), di.len());
        assert_eq!(
            ex.len() as f64,
            trials.num(r, "tns") + 1.0,
            "a sample before the first move and after every step"
        );
        assert!(
            di.windows(2).all(|w| w[1] >= w[0]),
            "distance never decreases"
        );
        assert_eq!(di[0], 0.0);
        assert!((ex.last().unwrap() - trials.num(r, "explored")).abs() < 1e-6);
        assert!((di.last().unwrap() - trials.num(r, "ttd_m")).abs() < 1e-6);
        // to_N: first timestep at which coverage reached N %.
        for n in [20u32, 50, 100] {
            let want = ex
                .iter()
                .position(|&e| e >= n as f64 / 100.0 - 1e-12)
                .map(|i| i.to_string())
                .unwrap_or_default();
            assert_eq!(trials.get(r, &format!("to_{n}")), want, "to_{n} of {r:?}");
        }
    }

    // summary.csv: one row per method × CSP, mean ± sd of the rows of trials.csv.
    let summary = Table::read(&out.join("summary.csv"));
    assert_eq!(summary.rows.len(), 3 * 2);
    for s in &summary.rows {
        let (m, c) = (summary.get(s, "method"), summary.get(s, "csp"));
        let sel: Vec<&Vec<String>> = trials
            .rows
            .iter()
            .filter(|r| trials.get(r, "method") == m && trials.get(r, "csp") == c)
            .collect();
        assert_eq!(summary.num(s, "trials"), sel.len() as f64);
        assert_eq!(sel.len(), 8);
        assert_eq!(
            summary.num(s, "completed"),
            sel.iter()
                .filter(|r| trials.get(r, "completed") == "true")
                .count() as f64
        );
        for (col, sum_col) in [
            ("tns", "tns"),
            ("ttd_m", "ttd"),
            ("noli", "noli"),
            ("ofv", "ofv"),
        ] {
            let v: Vec<f64> = sel.iter().map(|r| trials.num(r, col)).collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let sd =
                (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
            assert!(
                (summary.num(s, &format!("{sum_col}_mean")) - mean).abs() < 1e-4,
                "{m} {c} {col} mean"
            );
            assert!(
                (summary.num(s, &format!("{sum_col}_sd")) - sd).abs() < 1e-4,
                "{m} {c} {col} sd"
            );
        }
    }
    let md = read(out.join("summary.md"));
    assert_eq!(
        md.lines()
            .filter(|l| l.starts_with("| ") && l.contains('±'))
            .count(),
        6,
        "{md}"
    );

    // statistics.csv: Friedman per metric per CSP; Wilcoxon per pair per metric per CSP,
    // Bonferroni over the 3 pairs.
    let stats = Table::read(&out.join("statistics.csv"));
    let friedman: Vec<&Vec<String>> = stats
        .rows
        .iter()
        .filter(|r| stats.get(r, "test") == "friedman")
        .collect();
    let wilcoxon: Vec<&Vec<String>> = stats
        .rows
        .iter()
        .filter(|r| stats.get(r, "test") == "wilcoxon")
        .collect();
    assert_eq!(friedman.len(), 4 * 2, "{stats:?}");
    assert_eq!(wilcoxon.len(), 3 * 4 * 2, "{stats:?}");
    assert_eq!(stats.rows.len(), friedman.len() + wilcoxon.len());
    for c in ["1", "0"] {
        for m in METRICS {
            let f: Vec<_> = friedman
                .iter()
                .filter(|r| stats.get(r, "csp") == c && stats.get(r, "metric") == m)
                .collect();
            assert_eq!(f.len(), 1, "Friedman {m} at CSP {c}");
            assert_eq!(
                stats.num(f[0], "n"),
                8.0,
                "blocks: 2 maps × 2 starts × 2 seeds"
            );
            let pairs: BTreeSet<(String, String)> = wilcoxon
                .iter()
                .filter(|r| stats.get(r, "csp") == c && stats.get(r, "metric") == m)
                .map(|r| (stats.get(r, "a").to_string(), stats.get(r, "b").to_string()))
                .collect();
            let want: BTreeSet<(String, String)> = [("nf", "ub"), ("nf", "pb"), ("ub", "pb")]
                .iter()
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .collect();
            assert_eq!(pairs, want, "{m} at CSP {c}");
        }
    }
    for r in &friedman {
        let p = stats.num(r, "p");
        assert!(
            (0.0..=1.0).contains(&p) && stats.num(r, "statistic") >= 0.0,
            "{r:?}"
        );
    }
    for r in &wilcoxon {
        let (p, pc) = (stats.num(r, "p"), stats.num(r, "p_corrected"));
        assert!((0.0..=1.0).contains(&p), "{r:?}");
        assert!(pc >= p && pc <= 1.0, "corrected p ≥ raw p: {r:?}");
        assert!(
            (pc - (3.0 * p).min(1.0)).abs() <= 1e-6 * pc.max(1e-300),
            "Bonferroni over 3 pairs: {r:?}"
        );
        assert!(stats.num(r, "n") <= 8.0);
    }
    let smd = read(out.join("statistics.md"));
    assert!(
        smd.contains("Friedman") && smd.contains("nf vs ub"),
        "{smd}"
    );

    // Figures.
    for f in ["fig4_metrics", "fig5_exploration"] {
        assert!(
            is_png(&out.join(format!("{f}.png"))),
            "{f}.png is not a PNG"
        );
        let svg = read(out.join(format!("{f}.svg")));
        assert!(svg.contains("<svg"), "{f}.svg");
        for m in ["NF", "UB", "PB"] {
            assert!(svg.contains(m), "{f}.svg has no legend entry {m}");
        }
    }

    // report.md ties them together.
    let text = read(&report);
    for needle in [
        "fig4_metrics.png",
        "fig5_exploration.png",
        "## Summary",
        "## Statistics",
        "## Calibration",
        "trials.csv",
    ] {
        assert!(text.contains(needle), "report.md lacks `{needle}`");
    }
    assert!(
        text.contains(&format!("{total} trials")),
        "report states the trial count"
    );
    // Calibration: nf, ub, pb at the two CSPs of this study × steps, distance, local interactions.
    let cal = calibration_rows(&text);
    assert_eq!(cal.len(), 3 * 2 * 3, "{cal:?}");
    for (m, c, _) in &cal {
        assert!(methods.contains(&m.as_str()), "{cal:?}");
        assert!(c == "100 %" || c == "0 %", "{cal:?}");
    }
    // Each row says how many trials each side averaged: ours 2 maps × 2 starts × 2 seeds, the
    // authors' 10 maps × 4 corners.
    assert_eq!(text.matches("| 8 / 40 |").count(), cal.len(), "{text}");
    // The configuration is recorded beside the results.
    assert_eq!(toml_cfg(&out.join("study.toml")), cfg);
}

fn toml_cfg(path: &Path) -> StudyConfig {
    StudyConfig::from_toml_file(path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn calibration_only_for_baselines_on_paper_maps() {
    // `random` has no published counterpart; generated maps are not the paper's.
    let dir = Scratch::new("study-calibration");
    let mut cfg = small(&["random", "nf"], &[1.0], 1);
    cfg.maps = vec!["paper:3".into(), "generate:7".into()];
    let (report, outcomes, _) = run_ok(&cfg, dir.path(), false);
    assert_eq!(outcomes.len(), 2 * 2 * 2);
    let cal = calibration_rows(&read(&report));
    assert_eq!(cal.len(), 3, "nf at CSP 100 % only: {cal:?}");
    assert!(
        cal.iter().all(|(m, c, _)| m == "nf" && c == "100 %"),
        "{cal:?}"
    );

    let mut cfg = small(&["nf"], &[1.0], 1);
    cfg.maps = vec!["generate:7".into()];
    let (report, _, _) = run_ok(&cfg, dir.path(), true);
    let text = read(&report);
    assert!(
        calibration_rows(&text).is_empty(),
        "no calibration rows without paper maps"
    );
    // Fig. 5 still drawn at CSP 1.0; only one method, so no statistics rows.
    let stats = Table::read(&dir.path().join("statistics.csv"));
    assert!(stats.rows.is_empty(), "{stats:?}");
}

// ---------------------------------------------------------------------------------------------
// 3. Resume

/// Trial rows of `trials.csv` without the wall-clock columns.
fn deterministic_trials(out: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    Table::read(&out.join("trials.csv")).without(&WALL_CLOCK)
}

/// `trials.csv` and `curves.jsonl` of the study in `out`, as written.
fn outputs(out: &Path) -> (String, String) {
    (read(out.join("trials.csv")), read(out.join("curves.jsonl")))
}

/// Runs `cfg` uninterrupted into `out`: its [`outputs`].
fn run_full(cfg: &StudyConfig, out: &Path) -> (String, String) {
    run_ok(cfg, out, false);
    outputs(out)
}

/// The study in `out` holds the trials and curves of an uninterrupted run's `trials_full` and
/// `curves_full`, but for the wall-clock columns (and the last bit of a float in the curves).
fn assert_same_results(out: &Path, trials_full: &str, curves_full: &str) {
    assert_eq!(
        deterministic_trials(out),
        Table::read_str(trials_full).without(&WALL_CLOCK)
    );
    assert_curves_close(&read(out.join("curves.jsonl")), curves_full);
}

/// The first `k` lines of `text` (with their newlines).
fn first_lines(text: &str, k: usize) -> String {
    text.split_inclusive('\n').take(k).collect()
}

#[test]
fn interrupted_study_resumes_with_only_complete_consistent_trials() {
    let dir = Scratch::new("study-resume");
    let out = dir.path();
    let cfg = small(&["nf", "ub"], &[1.0, 0.0], 2);
    let total = 2 * 2 * 2 * 2 * 2;
    let (_, first, _) = run_ok(&cfg, out, false);
    assert_eq!(first.len(), total);
    let (trials_full, curves_full) = outputs(out);
    let summary_full = Table::read(&out.join("summary.csv")).without(&SUMMARY_CT);
    let stats_full = read(out.join("statistics.csv"));

    // Interrupt: trials.csv keeps its header, 10 whole rows and half of the 11th; curves.jsonl
    // its first 7 lines. Complete trials: the 7 with both a row and a curve.
    let (k_rows, k_curves) = (10, 7);
    let lines: Vec<&str> = trials_full.split_inclusive('\n').collect();
    let torn = &lines[1 + k_rows][..lines[1 + k_rows].len() / 2];
    assert!(!torn.contains('\n'));
    std::fs::write(
        out.join("trials.csv"),
        format!("{}{torn}", first_lines(&trials_full, 1 + k_rows)),
    )
    .unwrap();
    std::fs::write(
        out.join("curves.jsonl"),
        first_lines(&curves_full, k_curves),
    )
    .unwrap();

    let (_, second, calls) = run_ok(&cfg, out, false);
    assert_eq!(second.len(), total);
    assert_eq!(
        calls.first(),
        Some(&(k_curves, total)),
        "progress starts at the complete, consistent trials: {calls:?}"
    );
    assert_eq!(
        calls.len(),
        1 + total - k_curves,
        "trials actually run: {calls:?}"
    );
    assert_eq!(calls.iter().map(|c| c.0).max(), Some(total));

    // Same results as the uninterrupted run, but for the wall-clock columns …
    assert_same_results(out, &trials_full, &curves_full);
    assert_eq!(
        Table::read(&out.join("summary.csv")).without(&SUMMARY_CT),
        summary_full
    );
    assert_eq!(read(out.join("statistics.csv")), stats_full);
    // … and the trials kept were not run again: their rows are byte-identical, timings included.
    let kept = first_lines(&trials_full, 1 + k_curves);
    assert!(
        read(out.join("trials.csv")).starts_with(&kept),
        "the first {k_curves} rows were kept as recorded"
    );
    assert!(trials_full.ends_with('\n') && read(out.join("trials.csv")).ends_with('\n'));

    // Resuming a finished study runs nothing and changes nothing.
    let before = read(out.join("trials.csv"));
    let (_, _, calls) = run_ok(&cfg, out, false);
    assert_eq!(calls, vec![(total, total)]);
    assert_eq!(read(out.join("trials.csv")), before);
    assert_curves_close(&read(out.join("curves.jsonl")), &curves_full);
}

#[test]
fn resume_drops_a_row_torn_inside_its_last_field() {
    // A row cut just before its end still has every field, but its last field is cut short:
    // without its newline it cannot be trusted and must be run again.
    let dir = Scratch::new("study-resume-last-field");
    let out = dir.path();
    let cfg = small(&["nf"], &[1.0], 2);
    let total = 2 * 2 * 2;
    let (trials_full, curves_full) = run_full(&cfg, out);
    let lines: Vec<&str> = trials_full.split_inclusive('\n').collect();
    // The first row whose last field (to_100) is not empty.
    let i = (1..lines.len())
        .find(|&i| !lines[i].ends_with(",\n"))
        .expect("a trial that reached 100 %");
    let torn = &lines[i][..lines[i].len() - 2]; // drop the newline and the last digit
    std::fs::write(
        out.join("trials.csv"),
        format!("{}{torn}", first_lines(&trials_full, i)),
    )
    .unwrap();
    // Curves of every trial survive, so only the torn row decides whether trial i reruns.
    let (_, _, calls) = run_ok(&cfg, out, false);
    assert_eq!(
        calls.first(),
        Some(&(i - 1, total)),
        "the torn row is run again: {calls:?}"
    );
    assert_same_results(out, &trials_full, &curves_full);
}

#[test]
fn resume_ignores_records_outside_the_plan_and_garbage_lines() {
    let dir = Scratch::new("study-resume-garbage");
    let out = dir.path();
    let cfg = small(&["nf"], &[1.0], 1);
    let total = 2 * 2;
    let (trials_full, curves_full) = run_full(&cfg, out);
    // A line of garbage in each file, and a well-formed record of a trial this study does not plan.
    let lines: Vec<&str> = trials_full.split_inclusive('\n').collect();
    let alien = lines[1].replacen("nf,", "ub,", 1);
    let alien_curve = curves_full
        .lines()
        .next()
        .unwrap()
        .replacen("\"nf\"", "\"ub\"", 1);
    std::fs::write(
        out.join("trials.csv"),
        format!("{}{}not,a,row\n{alien}", lines[0], lines[1]),
    )
    .unwrap();
    std::fs::write(
        out.join("curves.jsonl"),
        format!("{}{{garbage\n{alien_curve}\n", first_lines(&curves_full, 1)),
    )
    .unwrap();
    let (_, outcomes, calls) = run_ok(&cfg, out, false);
    assert_eq!(calls.first(), Some(&(1, total)), "{calls:?}");
    assert_eq!(outcomes.len(), total);
    assert!(outcomes.iter().all(|o| o.row.key.method == "nf"));
    assert_same_results(out, &trials_full, &curves_full);
}

#[test]
fn resumed_curves_are_byte_identical() {
    // Resuming a finished study reads every curve back and writes it again; the bytes must not
    // change (runner.rs: "the same bytes whatever the thread count or interruptions").
    let dir = Scratch::new("study-curves-bytes");
    let out = dir.path();
    let cfg = small(&["nf"], &[1.0], 1);
    run_ok(&cfg, out, false);
    let curves = read(out.join("curves.jsonl"));
    let (_, _, calls) = run_ok(&cfg, out, false);
    assert_eq!(calls, vec![(4, 4)], "nothing ran again");
    let again = read(out.join("curves.jsonl"));
    for (i, (a, b)) in again.lines().zip(curves.lines()).enumerate() {
        assert_eq!(a, b, "curve {i} changed by resuming");
    }
    assert_eq!(again, curves);
    // The in-memory outcomes of a resumed study equal those of a fresh one, curves included.
    let (_, fresh, _) = run_ok(&cfg, out, true);
    let (_, resumed, _) = run_ok(&cfg, out, false);
    for (f, r) in fresh.iter().zip(&resumed) {
        assert_eq!(f.curve, r.curve, "curve of {:?}", f.row.key);
    }
}

// ---------------------------------------------------------------------------------------------
// 4. A different configuration in the same folder

#[test]
fn different_config_in_same_folder_is_refused_unless_fresh() {
    let dir = Scratch::new("study-different");
    let out = dir.path().join("study out");
    let a = StudyConfig {
        maps: vec!["paper:1".into()],
        starts: vec!["top-left".into()],
        ..small(&["nf"], &[1.0], 1)
    };
    run_ok(&a, &out, false);
    let trials_a = read(out.join("trials.csv"));
    let study_a = read(out.join("study.toml"));

    let b = StudyConfig {
        seeds: 2,
        ..a.clone()
    };
    let (r, calls) = run(&b, &out, false);
    let msg = r
        .expect_err("a different config must be refused")
        .to_string();
    assert!(
        msg.contains(&out.display().to_string()),
        "folder missing from: {msg}"
    );
    assert!(msg.contains("fresh"), "the remedy is named: {msg}");
    assert!(calls.is_empty(), "{calls:?}");
    assert_eq!(
        read(out.join("trials.csv")),
        trials_a,
        "old results untouched"
    );
    assert_eq!(
        read(out.join("study.toml")),
        study_a,
        "old configuration untouched"
    );
    // Also a change of the scenario alone.
    let mut c = a.clone();
    c.scenario.step_cap = 200;
    assert!(run(&c, &out, false).0.is_err());

    let (_, outcomes, calls) = run_ok(&b, &out, true);
    assert_eq!(outcomes.len(), 2);
    assert_eq!(calls.first(), Some(&(0, 2)), "fresh: nothing kept");
    assert_eq!(Table::read(&out.join("trials.csv")).rows.len(), 2);
    assert_eq!(toml_cfg(&out.join("study.toml")), b);
    // The first row is the same trial as before (seed 1) with the same results.
    let (_, rows_b) = deterministic_trials(&out);
    assert_eq!(
        rows_b[0],
        Table::read_str(&trials_a).without(&WALL_CLOCK).1[0]
    );
}

// ---------------------------------------------------------------------------------------------
// 5. Determinism across thread counts

#[test]
fn results_do_not_depend_on_thread_count() {
    let dir = Scratch::new("study-threads");
    // One seed keeps it fast: 24 trials, still more than enough to interleave on 2 threads.
    let cfg = small(&["nf", "ub", "pb"], &[1.0, 0.0], 1);
    let outs: Vec<PathBuf> = [1, 2]
        .iter()
        .map(|&n| {
            let out = dir.path().join(format!("threads-{n}"));
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap();
            let (_, outcomes, _) = pool.install(|| run_ok(&cfg, &out, false));
            assert_eq!(outcomes.len(), 24);
            out
        })
        .collect();
    let (one, two) = (&outs[0], &outs[1]);
    assert_eq!(deterministic_trials(one), deterministic_trials(two));
    assert_eq!(
        read(one.join("curves.jsonl")),
        read(two.join("curves.jsonl"))
    );
    assert_eq!(
        Table::read(&one.join("summary.csv")).without(&SUMMARY_CT),
        Table::read(&two.join("summary.csv")).without(&SUMMARY_CT)
    );
    assert_eq!(
        read(one.join("statistics.csv")),
        read(two.join("statistics.csv"))
    );
    assert_eq!(
        read(one.join("statistics.md")),
        read(two.join("statistics.md"))
    );
}

// ---------------------------------------------------------------------------------------------
// 6. Statistics on the real pipeline

#[test]
fn statistics_have_one_friedman_per_metric_and_every_pair() {
    let dir = Scratch::new("study-stats");
    let cfg = small(&["nf", "ub", "pb"], &[0.5], 3);
    let (_, outcomes, _) = run_ok(&cfg, dir.path(), false);
    assert_eq!(outcomes.len(), 3 * 2 * 2 * 3);
    let stats = Table::read(&dir.path().join("statistics.csv"));
    assert_eq!(
        stats.header,
        strings(&[
            "csp",
            "metric",
            "test",
            "a",
            "b",
            "statistic",
            "n",
            "p",
            "p_corrected"
        ])
    );
    let friedman: Vec<_> = stats
        .rows
        .iter()
        .filter(|r| stats.get(r, "test") == "friedman")
        .collect();
    let wilcoxon: Vec<_> = stats
        .rows
        .iter()
        .filter(|r| stats.get(r, "test") == "wilcoxon")
        .collect();
    assert_eq!(friedman.len(), 4, "{stats:?}");
    assert_eq!(wilcoxon.len(), 3 * 4, "{stats:?}");
    assert!(stats.rows.iter().all(|r| stats.get(r, "csp") == "0.5"));
    let metrics: BTreeSet<&str> = friedman.iter().map(|r| stats.get(r, "metric")).collect();
    assert_eq!(metrics, METRICS.into_iter().collect());
    for r in &friedman {
        assert_eq!(
            stats.num(r, "n"),
            12.0,
            "blocks: 2 maps × 2 starts × 3 seeds"
        );
        assert!(
            stats.get(r, "a").is_empty()
                && stats.get(r, "b").is_empty()
                && stats.get(r, "p_corrected").is_empty()
        );
    }
    for r in &wilcoxon {
        let (p, pc) = (stats.num(r, "p"), stats.num(r, "p_corrected"));
        assert!(pc >= p && pc <= 1.0, "{r:?}");
        assert!(stats.num(r, "n") <= 12.0);
    }
    // The statistics are a function of trials.csv: recompute the TNS Friedman statistic by hand.
    let trials = Table::read(&dir.path().join("trials.csv"));
    let f_tns = friedman
        .iter()
        .find(|r| stats.get(r, "metric") == "TNS")
        .unwrap();
    let chi2 = friedman_by_hand(&trials, "tns", &["nf", "ub", "pb"]);
    assert!(
        (stats.num(f_tns, "statistic") - chi2).abs() < 1e-6,
        "Friedman χ² {} vs by hand {chi2}",
        stats.num(f_tns, "statistic")
    );
}

/// Friedman χ² with tie correction (scipy's `friedmanchisquare`), blocks (map, start, seed).
fn friedman_by_hand(t: &Table, col: &str, methods: &[&str]) -> f64 {
    let mut blocks: std::collections::BTreeMap<(String, String, String), Vec<Option<f64>>> =
        Default::default();
    for r in &t.rows {
        let mi = methods
            .iter()
            .position(|m| *m == t.get(r, "method"))
            .unwrap();
        blocks
            .entry((
                t.get(r, "map").into(),
                t.get(r, "start").into(),
                t.get(r, "seed").into(),
            ))
            .or_insert_with(|| vec![None; methods.len()])[mi] = Some(t.num(r, col));
    }
    let k = methods.len() as f64;
    let n = blocks.len() as f64;
    let mut rank_sums = vec![0.0; methods.len()];
    let mut ties = 0.0;
    for v in blocks.values() {
        let v: Vec<f64> = v.iter().map(|x| x.unwrap()).collect();
        for (i, x) in v.iter().enumerate() {
            let less = v.iter().filter(|y| *y < x).count() as f64;
            let equal = v.iter().filter(|y| *y == x).count() as f64;
            rank_sums[i] += less + (equal + 1.0) / 2.0;
        }
        let mut seen = Vec::new();
        for x in &v {
            if !seen.contains(x) {
                seen.push(*x);
                let t = v.iter().filter(|y| *y == x).count() as f64;
                ties += t * t * t - t;
            }
        }
    }
    let ssbn: f64 = rank_sums.iter().map(|r| r * r).sum();
    let chi2 = 12.0 / (n * k * (k + 1.0)) * ssbn - 3.0 * n * (k + 1.0);
    let c = 1.0 - ties / (k * k * k - k) / n;
    if c <= 0.0 {
        0.0
    } else {
        chi2 / c
    }
}

// ---------------------------------------------------------------------------------------------
// Restarted trials (how environments start their next episode)

/// A trial restarted with another seed (reusing the world and every agent's buffers) runs
/// exactly the trial a fresh build with that seed runs, for every shipped policy — the
/// per-step, macro, learned and DME ones, whose navigators, searches and reservation tables
/// are all reused.
#[test]
fn a_restarted_trial_equals_a_fresh_one_for_every_policy() {
    use madenet_map::paper::{paper_map, Corner};
    use madenet_sim::{Trial, TrialResult, TrialSpec};
    let registry = StudyConfig::default().registry().unwrap();
    let spec = |policy: &str, seed: u64| {
        let map = paper_map(4).unwrap();
        let starts = Corner::BottomRight
            .start_cells(map.height(), map.width())
            .to_vec();
        let config = madenet_world::ScenarioConfig {
            comm_success_prob: 0.5,
            ..Default::default()
        };
        TrialSpec {
            map,
            map_name: "test_4".into(),
            starts,
            config,
            policy: policy.into(),
            seed,
        }
    };
    let untimed = |mut r: TrialResult| {
        (r.timing.trial_s, r.timing.per_decision_s) = (0.0, 0.0);
        r
    };
    for policy in [
        "nf",
        "ub",
        "pb",
        "random",
        "spread",
        "made-net",
        "made-net-paper",
        "made-net-dt",
        "dme-drl",
        "belief-plan",
        "convention",
    ] {
        let mut first = Trial::with_registry(spec(policy, 11), &registry)
            .unwrap()
            .record_trajectory(true);
        while first.step() {}
        let restarted = first.restart(12, &registry).unwrap().run();
        let fresh = Trial::with_registry(spec(policy, 12), &registry)
            .unwrap()
            .record_trajectory(true)
            .run();
        assert!(!fresh.trajectory.is_empty());
        assert_eq!(untimed(restarted), untimed(fresh), "{policy}");
    }
}

/// Oracles run beside the methods on the same trials: their rows are what
/// `madenet_baselines::rollout::run_oracle` gives for the same spec, their base rule runs although it
/// is not a method, and they appear in the report's ceiling section only — never in the
/// summary, the statistics or the figures' ranking.
#[test]
fn oracles_run_beside_the_methods_and_are_reported_apart() {
    use madenet_baselines::rollout::{run_oracle, OracleKind};
    let dir = Scratch::new("study-oracles");
    let out = dir.path();
    let cfg = StudyConfig {
        maps: strings(&["paper:1"]),
        oracles: vec![OracleKind::Noiseless, OracleKind::Placebo],
        oracle_futures: 2,
        ..small(&["nf"], &[1.0, 0.0], 1)
    };
    let (report, outcomes, _) = run_ok(&cfg, out, false);
    let per_run = 2 * 2; // starts × CSPs
    let methods: Vec<&str> = outcomes.iter().map(|o| o.row.key.method.as_str()).collect();
    for m in ["nf", "spread", "oracle-noiseless", "oracle-placebo"] {
        assert_eq!(methods.iter().filter(|x| **x == m).count(), per_run, "{m}");
    }
    assert_eq!(outcomes.len(), 4 * per_run);
    // Each oracle row is the oracle's own trial.
    let registry = cfg.registry().unwrap();
    let (maps, starts) = cfg.validate(&registry).unwrap();
    let planned = madenet_study::runner::plan(&cfg, &maps, &starts);
    for p in planned.iter().filter(|p| p.oracle.is_some()) {
        let (kind, futures) = p.oracle.unwrap();
        assert_eq!(p.spec.policy, "spread");
        let direct = run_oracle(p.spec.clone(), &registry, kind, futures).unwrap();
        let row = &outcomes.iter().find(|o| o.row.key == p.key).unwrap().row;
        assert_eq!(row.tns, direct.metrics.tns, "{:?}", p.key);
        assert_eq!(row.noli, direct.metrics.noli, "{:?}", p.key);
    }
    // Only the methods are summarised and tested.
    let summary = read(out.join("summary.csv"));
    let stats = read(out.join("statistics.csv"));
    for text in [&summary, &stats] {
        assert!(
            !text.contains("oracle") && !text.contains("spread"),
            "{text}"
        );
    }
    assert!(summary.contains("\nnf,"));
    let report = read(&report);
    let ceiling = report
        .split("## The ceiling: rollout oracles")
        .nth(1)
        .expect("a ceiling section")
        .split("\n## ")
        .next()
        .unwrap();
    for needle in [
        "| spread (base) |",
        "| oracle-noiseless (oracle) |",
        "| oracle-placebo (oracle) |",
        "| nf |",
        "CSP 0 %",
        "CSP 100 %",
    ] {
        assert!(
            ceiling.contains(needle),
            "`{needle}` missing from: {ceiling}"
        );
    }
    assert!(
        !ceiling.contains("oracle_lookahead"),
        "the default is not announced"
    );

    // Cut and valued by mean discovery: each row is `run_oracle_by` with that lookahead, and
    // the report says how the oracle valued.
    use madenet_baselines::rollout::{run_oracle_by, Lookahead, Value};
    let look = Lookahead {
        horizon: Some(30),
        value: Value::MeanDiscovery,
    };
    let cut_cfg = StudyConfig {
        oracles: vec![OracleKind::Noiseless],
        oracle_lookahead: look,
        ..cfg.clone()
    };
    let cut_dir = Scratch::new("study-oracles-cut");
    let (cut_report, cut_outcomes, _) = run_ok(&cut_cfg, cut_dir.path(), false);
    let planned = madenet_study::runner::plan(&cut_cfg, &maps, &starts);
    assert!(planned.iter().any(|p| p.oracle.is_some()));
    for p in planned.iter().filter(|p| p.oracle.is_some()) {
        let (kind, futures) = p.oracle.unwrap();
        let direct = run_oracle_by(p.spec.clone(), &registry, kind, futures, look).unwrap();
        let row = &cut_outcomes
            .iter()
            .find(|o| o.row.key == p.key)
            .unwrap()
            .row;
        assert_eq!(row.tns, direct.metrics.tns, "{:?}", p.key);
    }
    assert!(read(&cut_report).contains(
        "value a candidate by the mean over cells of the steps until each is known, continuations cut after 30 steps"
    ));
}

#[test]
fn bad_oracle_fields_are_refused() {
    use madenet_baselines::rollout::OracleKind;
    let base = StudyConfig {
        oracles: vec![OracleKind::Noiseless],
        ..small(&["nf"], &[1.0], 1)
    };
    assert_refused(
        &StudyConfig {
            oracles: vec![OracleKind::Noiseless, OracleKind::Noiseless],
            ..base.clone()
        },
        &["oracles", "noiseless", "twice"],
    );
    assert_refused(
        &StudyConfig {
            oracle_base: "nf".into(),
            ..base.clone()
        },
        &["oracle_base", "re-decides every step"],
    );
    assert_refused(
        &StudyConfig {
            oracle_base: "teleport".into(),
            ..base.clone()
        },
        &["oracle_base", "teleport"],
    );
    assert_refused(
        &StudyConfig {
            oracle_lookahead: madenet_baselines::rollout::Lookahead {
                horizon: Some(0),
                ..Default::default()
            },
            ..base.clone()
        },
        &["oracle_lookahead.horizon", "1..=100000"],
    );
    assert_refused(
        &StudyConfig {
            oracle_futures: 0,
            ..base.clone()
        },
        &["oracle_futures", "0"],
    );
}

/// A folder holding another study's table (here `madenet batch`'s, no `study.toml`) is refused
/// and left as it was, unless the study starts afresh.
#[test]
fn a_folder_with_a_foreign_trials_csv_is_refused() {
    let dir = Scratch::new("study-foreign");
    let out = dir.path();
    std::fs::create_dir_all(out).unwrap();
    let foreign = "method,map\nnf,elsewhere\n";
    std::fs::write(out.join("trials.csv"), foreign).unwrap();
    let cfg = small(&["nf"], &[1.0], 1);
    let e = run(&cfg, out, false).0.unwrap_err().to_string();
    assert!(
        e.contains("study.toml") && e.contains(&out.display().to_string()),
        "{e}"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("trials.csv")).unwrap(),
        foreign
    );
    run_ok(&cfg, out, true);
}
