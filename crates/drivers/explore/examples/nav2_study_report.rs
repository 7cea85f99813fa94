//! The nav2 study's report (issue 58): reads what `scripts/nav2_study.sh OUT` wrote
//! (`OUT/results.jsonl`, the ROS 2 path; `OUT/inprocess.jsonl`, the same trials in-process)
//! and writes `OUT/report.md` (tables, paired tests) and `OUT/exploration-time.{png,svg}`.
//!
//! ```text
//! cargo run --release -p madenet-explore --example nav2_study_report -- OUT
//! ```
//!
//! Exploration time is when the robots' maps together first covered 99 % of the explorable
//! cells (ground truth); a trial that never did counts at the time cap (6 s per m², the
//! script's default; a failure, not a fast trial) and is counted. The
//! best madenet method (the lowest mean over all cells, chosen once) is compared with each
//! explore-lite variant by a paired two-sided Wilcoxon signed-rank test over the seeds both
//! completed as trials.

use madenet_plots::{bar_panels, BarPanel, BarSeries};
use serde_json::Value;
use std::collections::BTreeMap;
use std::fmt::Write;
use std::path::Path;

const METHODS: [&str; 5] = [
    "explore-lite-alone",
    "explore-lite",
    "spread",
    "made-net-any",
    "made-net",
];
const MADENET: [&str; 3] = ["spread", "made-net-any", "made-net"];

/// One trial: (size, team, seed, method) → its record.
type Trials = BTreeMap<(u64, u64, u64, String), Value>;

/// Per map size: per team size, each method's mean and sd of exploration time.
type Bars = BTreeMap<u64, Vec<(u64, Vec<(f64, f64)>)>>;

fn load(path: &Path) -> Trials {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut out = Trials::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let Ok(v) = serde_json::from_str::<Value>(line) else {
            eprintln!("{}: skipped a line that is not JSON", path.display());
            continue;
        };
        let n = |k: &str| v[k].as_u64().unwrap_or(0);
        let key = (
            n("size"),
            n("team"),
            n("seed"),
            v["method"].as_str().unwrap_or("").to_string(),
        );
        out.insert(key, v["result"].clone());
    }
    out
}

/// Simulated seconds per m² after which the study's script ends a trial (its `CAP_PER_CELL`).
const CAP_PER_CELL: f64 = 6.0;

/// The ROS 2 path's exploration time on a `size` m map (99 % covered, else the time cap — a
/// trial whose nodes stopped short of 99 % is a failure, not a fast trial) and whether it
/// reached 99 %.
fn ros2_time(r: &Value, size: u64) -> (f64, bool) {
    let cap = CAP_PER_CELL * (size * size) as f64;
    match r["covered_99_s"].as_f64() {
        Some(t) => (t, true),
        None => (r["simulated_s"].as_f64().unwrap_or(cap).max(cap), false),
    }
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, v.sqrt())
}

fn main() {
    let out = std::env::args()
        .nth(1)
        .expect("usage: nav2_study_report OUT_DIR");
    let out = Path::new(&out);
    let ros2 = load(&out.join("results.jsonl"));
    let inproc = load(&out.join("inprocess.jsonl"));
    let cells: Vec<(u64, u64)> = {
        let mut c: Vec<(u64, u64)> = ros2.keys().map(|k| (k.0, k.1)).collect();
        c.dedup();
        c.sort();
        c.dedup();
        c
    };
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# nav2 study: exploration nodes through ROS 2 on the simulated nav2 team\n\n\
         Exploration time: simulated seconds until the robots' maps together covered 99 % of the \
         explorable cells (ground truth); in brackets, trials that never did (counted at the time cap, \
         6 s per m²: a failure). Mean ± sd over seeds; `stop` is when every node had exited.\n"
    );
    let _ = writeln!(
        md,
        "| size | team | method | trials | 99 % time (s) | stop (s) | distance (m) | collisions | in-process ET (s) |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|");
    let mut panels = Bars::new();
    let mut tests = String::new();
    // The best madenet method, chosen once over every cell (lowest mean exploration time over
    // all its trials), not per cell: picking the luckier one cell by cell would flatter it.
    let best_overall = MADENET
        .iter()
        .filter_map(|m| {
            let t: Vec<f64> = (ros2.iter())
                .filter(|(k, _)| k.3 == *m)
                .map(|(k, v)| ros2_time(v, k.0).0)
                .collect();
            (!t.is_empty()).then(|| (*m, t.iter().sum::<f64>() / t.len() as f64))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(m, _)| m);
    for &(size, team) in &cells {
        let mut bars = Vec::new();
        for m in METHODS {
            let rs: Vec<(u64, &Value)> = ros2
                .iter()
                .filter(|(k, _)| k.0 == size && k.1 == team && k.3 == m)
                .map(|(k, v)| (k.2, v))
                .collect();
            if rs.is_empty() {
                bars.push((f64::NAN, 0.0));
                continue;
            }
            let times: Vec<f64> = rs.iter().map(|(_, r)| ros2_time(r, size).0).collect();
            let never = rs.iter().filter(|(_, r)| !ros2_time(r, size).1).count();
            let stops: Vec<f64> = rs
                .iter()
                .filter_map(|(_, r)| r["nodes_stopped_s"].as_f64())
                .collect();
            let dist: Vec<f64> = rs
                .iter()
                .filter_map(|(_, r)| r["team_distance_m"].as_f64())
                .collect();
            let coll: u64 = rs
                .iter()
                .map(|(_, r)| {
                    r["obstacle_collisions"].as_u64().unwrap_or(0)
                        + r["robot_collisions"].as_u64().unwrap_or(0)
                })
                .sum();
            let ip: Vec<f64> = inproc
                .iter()
                .filter(|(k, _)| k.0 == size && k.1 == team && k.3 == m)
                .filter_map(|(_, v)| v["exploration_time_s"].as_f64())
                .collect();
            let (tm, ts) = mean_sd(&times);
            let fmt = |x: &[f64]| match x.is_empty() {
                true => "–".to_string(),
                false => {
                    let (m, s) = mean_sd(x);
                    format!("{m:.0} ± {s:.0}")
                }
            };
            let _ =
                writeln!(
                md,
                "| {size} m | {team} | {m} | {} | {tm:.0} ± {ts:.0}{} | {} | {} | {coll} | {} |",
                rs.len(),
                if never > 0 { format!(" ({never})") } else { String::new() },
                fmt(&stops),
                fmt(&dist),
                fmt(&ip),
            );
            bars.push((tm, ts));
        }
        panels.entry(size).or_default().push((team, bars));
        // Paired tests: the best madenet method (lower mean) against each explore-lite variant.
        let by = |m: &str| -> BTreeMap<u64, f64> {
            ros2.iter()
                .filter(|(k, _)| k.0 == size && k.1 == team && k.3 == m)
                .map(|(k, v)| (k.2, ros2_time(v, k.0).0))
                .collect()
        };
        let Some(best) = best_overall else { continue };
        let b = by(best);
        for base in ["explore-lite-alone", "explore-lite"] {
            let o = by(base);
            let seeds: Vec<u64> = b.keys().filter(|s| o.contains_key(s)).copied().collect();
            if seeds.len() < 2 {
                continue;
            }
            let x: Vec<f64> = seeds.iter().map(|s| b[s]).collect();
            let y: Vec<f64> = seeds.iter().map(|s| o[s]).collect();
            let (mx, my) = (mean_sd(&x).0, mean_sd(&y).0);
            let p = madenet_stats::wilcoxon(&x, &y)
                .map(|w| format!("{:.4}", w.p_value))
                .unwrap_or_else(|e| e.to_string());
            let _ = writeln!(
                tests,
                "| {size} m | {team} | {best} vs {base} | {} | {mx:.0} vs {my:.0} | {:+.1} % | {p} |",
                seeds.len(),
                100.0 * (my - mx) / my,
            );
        }
    }
    let _ = writeln!(
        md,
        "\n## Paired tests\n\nThe madenet method with the lowest mean over all cells against each \
         explore-lite variant, over the seeds both ran (two-sided Wilcoxon signed-rank); `faster` is how much \
         less time the madenet method took.\n\n| size | team | comparison | pairs | means (s) | faster | p |\n|---|---|---|---|---|---|---|\n{tests}"
    );
    // One panel per map size: groups are team sizes, one bar per method.
    let figure: Vec<BarPanel> = panels
        .iter()
        .map(|(size, groups)| BarPanel {
            title: format!("{size} m floor plans"),
            y_label: "99 % exploration time (s)".into(),
            categories: groups.iter().map(|(t, _)| format!("{t} robots")).collect(),
            series: METHODS
                .iter()
                .enumerate()
                .map(|(k, m)| BarSeries {
                    name: m.to_string(),
                    means: groups
                        .iter()
                        .map(|(_, b)| b[k].0.max(0.0))
                        .map(|v| if v.is_nan() { 0.0 } else { v })
                        .collect(),
                    errors: groups
                        .iter()
                        .map(|(_, b)| if b[k].1.is_nan() { 0.0 } else { b[k].1 })
                        .collect(),
                })
                .collect(),
        })
        .collect();
    if !figure.is_empty() {
        match bar_panels(&out.join("exploration-time"), &figure, figure.len().min(2)) {
            Ok(paths) => {
                for p in paths {
                    eprintln!("wrote {}", p.display());
                }
            }
            Err(e) => eprintln!("figure: {e}"),
        }
    }
    let report = out.join("report.md");
    std::fs::write(&report, md).expect("writing report.md");
    eprintln!("wrote {}", report.display());
}
