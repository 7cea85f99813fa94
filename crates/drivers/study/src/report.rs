//! Writing the study's outputs: summary tables, statistics, figures and `report.md`.

use crate::analysis::{
    csps, mean_curve, select, statistics, summary, Metric, MetricStats, SummaryRow,
};
use crate::calibration::{compare, conventions, Comparison};
use crate::config::{oracle_method, StudyConfig, StudyError};
use crate::runner::{write_atomic, TrialOutcome};
use madenet_plots::{bar_panels, line_panels, BarPanel, BarSeries, LinePanel, LineSeries};
use std::fmt::Write as _;
use std::path::Path;

fn pct(csp: &str) -> String {
    csp.parse::<f64>()
        .map(|c| format!("{:.0} %", 100.0 * c))
        .unwrap_or_else(|_| csp.to_string())
}

fn summary_md(rows: &[SummaryRow]) -> String {
    let mut s = String::from("| method | CSP | trials | completed | TNS | TTD (m) | NOLI | OFV | CT per trial (ms) | CT per decision (µs) |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let _ = write!(
            s,
            "| {} | {} | {} | {} |",
            r.method,
            pct(&r.csp),
            r.trials,
            r.completed
        );
        for (m, sd) in &r.metrics {
            let _ = write!(s, " {m:.1} ± {sd:.1} |");
        }
        let _ = writeln!(
            s,
            " {:.3} | {:.1} |",
            r.trial_s * 1e3,
            r.per_decision_s * 1e6
        );
    }
    s
}

fn summary_csv(rows: &[SummaryRow]) -> String {
    let mut s = String::from("method,csp,trials,completed,tns_mean,tns_sd,ttd_mean,ttd_sd,noli_mean,noli_sd,ofv_mean,ofv_sd,trial_s,per_decision_s\n");
    for r in rows {
        let _ = write!(s, "{},{},{},{}", r.method, r.csp, r.trials, r.completed);
        for (m, sd) in &r.metrics {
            let _ = write!(s, ",{m:.6},{sd:.6}");
        }
        let _ = writeln!(s, ",{:.9},{:.9}", r.trial_s, r.per_decision_s);
    }
    s
}

/// Per CSP, the method with the lowest mean of each metric where lower is better (TNS, TTD,
/// NOLI) and the highest OFV; then each method's change from the highest to the lowest CSP.
fn robustness_md(rows: &[SummaryRow], cs: &[(f64, String)], methods: &[String]) -> String {
    let mut s = String::from("| CSP | fewest steps (TNS) | shortest distance (TTD) | fewest interactions (NOLI) | highest OFV |\n|---|---|---|---|---|\n");
    for (_, c) in cs {
        let at: Vec<&SummaryRow> = rows.iter().filter(|r| &r.csp == c).collect();
        let best = |k: usize, lower: bool| {
            at.iter()
                .min_by(|a, b| {
                    let (x, y) = (a.metrics[k].0, b.metrics[k].0);
                    if lower {
                        x.total_cmp(&y)
                    } else {
                        y.total_cmp(&x)
                    }
                })
                .map_or(String::new(), |r| {
                    format!("{} ({:.1})", r.method, r.metrics[k].0)
                })
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            pct(c),
            best(0, true),
            best(1, true),
            best(2, true),
            best(3, false)
        );
    }
    if let (Some((_, lo)), Some((_, hi))) = (cs.first(), cs.last()) {
        if lo != hi {
            let _ = writeln!(
                s,
                "\nChange from CSP {} to CSP {} (mean; positive = worse for TNS and TTD):\n",
                pct(hi),
                pct(lo)
            );
            s.push_str("| method | TNS | TTD (m) |\n|---|---|---|\n");
            for m in methods {
                let get = |c: &String| rows.iter().find(|r| &r.method == m && &r.csp == c);
                if let (Some(a), Some(b)) = (get(hi), get(lo)) {
                    let d = |k: usize| {
                        let (x, y) = (a.metrics[k].0, b.metrics[k].0);
                        format!(
                            "{:+.1} ({:+.1} %)",
                            y - x,
                            100.0 * (y - x) / x.abs().max(1e-9)
                        )
                    };
                    let _ = writeln!(s, "| {m} | {} | {} |", d(0), d(1));
                }
            }
        }
    }
    s
}

/// The ceiling: mean TNS per CSP of the oracles' base rule, each oracle and each method, each
/// against the base rule and as a share of the noiseless oracle's gain over it.
fn ceiling_md(cfg: &StudyConfig, outcomes: &[TrialOutcome], cs: &[(f64, String)]) -> String {
    let base = &cfg.oracle_base;
    let oracles: Vec<String> = cfg.oracles.iter().map(|&k| oracle_method(k)).collect();
    let mut runs = vec![base.clone()];
    runs.extend(oracles.iter().cloned());
    runs.extend(cfg.methods.iter().filter(|m| *m != base).cloned());
    let rows = summary(outcomes, &runs);
    let tns = |m: &str, c: &str| {
        rows.iter()
            .find(|r| r.method == m && r.csp == c)
            .map(|r| r.metrics[0].0)
    };
    let mut s = format!(
        "Rollout oracles over the base rule `{base}` on the same trials (`madenet oracle`; \
         `madenet_baselines::rollout`): at every decision with two or more goal candidates the oracle \
         scores each candidate by continuing the trial with it under `{base}`, and takes the best. \
         Oracles are never ranked with the methods.\n\n"
    );
    let look = cfg.oracle_lookahead;
    if look != Default::default() {
        let value = match look.value {
            madenet_baselines::rollout::Value::StepsLeft => {
                "the steps left until the map is explored"
            }
            madenet_baselines::rollout::Value::MeanDiscovery => {
                "the mean over cells of the steps until each is known"
            }
        };
        let cut = match look.horizon {
            Some(h) => format!(", continuations cut after {h} steps"),
            None => String::new(),
        };
        let _ = write!(
            s,
            "The scoring oracles (replay, averaged, noiseless, redrawn) value a candidate by {value}{cut} \
             (`oracle_lookahead`).\n\n"
        );
    }
    for kind in &cfg.oracles {
        use madenet_baselines::rollout::OracleKind;
        let f = cfg.oracle_futures;
        let text = match kind {
            OracleKind::Noiseless => "scores in the noiseless future: it knows the map but not the noise to come — what the best choice among these candidates is worth, the ceiling of a policy that learns to choose".to_string(),
            OracleKind::Placebo => format!("keeps `{base}`'s own choice and lives the luckiest of {f} futures of the noise: its gain is luck that no policy can learn"),
            OracleKind::Replay => "scores in the trial's own future: it knows the map and the luck to come (an upper bound that includes luck)".to_string(),
            OracleKind::Averaged => format!("scores over {f} other futures: it knows the map, its scores carry the futures' luck"),
            OracleKind::Redrawn => format!("scores over {f} noiseless futures whose unseen cells the map generator redraws: it knows what the team knows and the kind of map, not this map — what a policy that sees only the team's knowledge could learn to choose"),
            OracleKind::PlanRedrawn => format!("plans the whole team's routes with the known-map reference on {f} maps whose unseen cells the map generator redraws, and takes the candidate nearest the robot's first viewpoint: a team-wide, multi-step teacher that knows what the team knows"),
            OracleKind::PlanOwnMap => format!("plans as plan-redrawn but on the deciding robot's own map (its unseen cells redrawn over {f} maps), every robot at its true cell: what knowing where the teammates are is worth without their maps"),
            OracleKind::PlanTeamMap => format!("plans as plan-redrawn on the team's cells ({f} redrawn maps) but with the teammates where the deciding robot last knew them: what the team's map is worth without their positions"),
            OracleKind::KnownMap => "is the known-map reference (`madenet_baselines::reference`): a team that knows the map — viewpoints that see every cell left after t = 0 (set cover), routes that keep the longest robot's time short (min–max insertion, 2-opt, relocation), walked on true shortest paths in the trial's own world and re-planned as misses and slips demand; it ignores the base rule and the radio (see Headroom)".to_string(),
        };
        let _ = writeln!(s, "- **{}** {text}.", oracle_method(*kind));
    }
    s.push_str("\nMean TNS (change against the base rule; for methods, the share of the noiseless oracle's gain over the base rule they reach):\n\n");
    s.push_str("| run |");
    for (_, c) in cs {
        let _ = write!(s, " CSP {} |", pct(c));
    }
    s.push_str("\n|---|");
    s.push_str(&"---|".repeat(cs.len()));
    s.push('\n');
    let noiseless = oracle_method(madenet_baselines::rollout::OracleKind::Noiseless);
    for m in &runs {
        let role = if m == base {
            " (base)"
        } else if oracles.contains(m) {
            " (oracle)"
        } else {
            ""
        };
        let _ = write!(s, "| {m}{role} |");
        for (_, c) in cs {
            let (Some(v), Some(b)) = (tns(m, c), tns(base, c)) else {
                s.push_str(" — |");
                continue;
            };
            if m == base {
                let _ = write!(s, " {v:.1} |");
                continue;
            }
            let _ = write!(s, " {v:.1} ({:+.1} %", 100.0 * (v / b - 1.0));
            match tns(&noiseless, c) {
                Some(o) if !oracles.contains(m) && b - o > 1e-9 => {
                    let _ = write!(s, "; {:.0} % of the gain", 100.0 * (b - v) / (b - o));
                }
                _ => {}
            }
            s.push_str(") |");
        }
        s.push('\n');
    }
    s
}

/// What the headroom sections of `report.md` and `scale.md` measure against.
pub(crate) const HEADROOM_DEFINITIONS: &str = "How far every run is from what is possible at all. \
    The **lower bound** of a trial: no team explores its map in fewer timesteps — the largest, \
    over the cells left unknown after t = 0, of the fewest moves any robot needs to reach a cell \
    that sees it (slips never shorten a path, misses only add time). The **known-map reference** \
    (`oracle-known-map`, `madenet_baselines::reference`) is a team that knows the map: set-cover \
    viewpoints, min–max routes, re-planned as misses and slips demand, in each trial's own world.";

/// Lower bounds of the trials (see [`madenet_baselines::reference::lower_bound`]), by map, start and
/// seed (a bound does not depend on the CSP).
pub type Bounds = std::collections::BTreeMap<(String, String, u64), u32>;

/// The headroom: every run's mean TNS against the known-map reference and the lower bound,
/// and the share of the base rule's gap to the reference each method closes.
fn headroom_md(
    cfg: &StudyConfig,
    outcomes: &[TrialOutcome],
    bounds: &Bounds,
    cs: &[(f64, String)],
) -> String {
    let base = &cfg.oracle_base;
    let reference = oracle_method(madenet_baselines::rollout::OracleKind::KnownMap);
    let mut runs = vec![base.clone()];
    runs.extend(cfg.methods.iter().filter(|m| *m != base).cloned());
    runs.extend(cfg.oracles.iter().map(|&k| oracle_method(k)));
    let rows = summary(outcomes, &runs);
    let tns = |m: &str, c: &str| {
        rows.iter()
            .find(|r| r.method == m && r.csp == c)
            .map(|r| r.metrics[0].0)
    };
    // The mean bound over the reference's own trials of each CSP.
    let bound = |c: &str| {
        let v: Vec<f64> = outcomes
            .iter()
            .filter(|o| o.row.key.method == reference && o.row.key.csp == c)
            .filter_map(|o| {
                let k = &o.row.key;
                bounds.get(&(k.map.clone(), k.start.clone(), k.seed))
            })
            .map(|&b| b as f64)
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let mut s = format!(
        "{HEADROOM_DEFINITIONS} Each cell: mean TNS (% above the reference; % above the bound); \
         for methods, the share of the base rule's gap to the reference they close.\n\n| run |"
    );
    for (_, c) in cs {
        let _ = write!(s, " CSP {} |", pct(c));
    }
    s.push_str("\n|---|");
    s.push_str(&"---|".repeat(cs.len()));
    s.push_str("\n| lower bound |");
    for (_, c) in cs {
        match bound(c) {
            Some(b) => {
                let _ = write!(s, " {b:.1} |");
            }
            None => s.push_str(" — |"),
        }
    }
    s.push('\n');
    for m in &runs {
        let role = if m == base { " (base)" } else { "" };
        let _ = write!(s, "| {m}{role} |");
        for (_, c) in cs {
            let (Some(v), Some(r)) = (tns(m, c), tns(&reference, c)) else {
                s.push_str(" — |");
                continue;
            };
            let _ = write!(s, " {v:.1} ({:+.1} %", 100.0 * (v / r.max(1.0) - 1.0));
            if let Some(b) = bound(c) {
                let _ = write!(s, "; {:+.1} %", 100.0 * (v / b.max(1.0) - 1.0));
            }
            match tns(base, c) {
                Some(bt)
                    if m != base
                        && *m != reference
                        && bt - r > 1e-9
                        && !m.starts_with("oracle-") =>
                {
                    let _ = write!(s, "; closes {:.0} %", 100.0 * (bt - v) / (bt - r));
                }
                _ => {}
            }
            s.push_str(") |");
        }
        s.push('\n');
    }
    s
}

fn fmt_p(p: f64) -> String {
    if p < 1e-4 {
        format!("{p:.1e}")
    } else {
        format!("{p:.4}")
    }
}

fn statistics_md(stats: &[MetricStats], alpha: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "Friedman test across methods, then two-sided Wilcoxon signed-rank tests between every pair of methods, Bonferroni-corrected over the pairs; blocks are (map, start, seed). Significant: corrected p < {alpha}.\n");
    let _ = writeln!(
        s,
        "| CSP | metric | blocks | Friedman χ² | p |\n|---|---|---|---|---|"
    );
    for st in stats {
        match &st.friedman {
            Ok(f) => {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {:.2} | {} |",
                    pct(&st.csp),
                    st.metric.name(),
                    st.blocks,
                    f.statistic,
                    fmt_p(f.p_value)
                );
            }
            Err(e) => {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | — | {e} |",
                    pct(&st.csp),
                    st.metric.name(),
                    st.blocks
                );
            }
        }
    }
    let _ = writeln!(s, "\n| CSP | metric | pair | W | n | p | corrected p | significant |\n|---|---|---|---|---|---|---|---|");
    for st in stats {
        if let Ok(pairs) = &st.pairs {
            for p in pairs {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} vs {} | {:.1} | {} | {} | {} | {} |",
                    pct(&st.csp),
                    st.metric.name(),
                    p.a,
                    p.b,
                    p.test.statistic,
                    p.test.n,
                    fmt_p(p.test.p_value),
                    fmt_p(p.p_corrected),
                    if p.p_corrected < alpha { "yes" } else { "no" }
                );
            }
        }
    }
    s
}

fn statistics_csv(stats: &[MetricStats]) -> String {
    let mut s = String::from("csp,metric,test,a,b,statistic,n,p,p_corrected\n");
    for st in stats {
        if let Ok(f) = &st.friedman {
            let _ = writeln!(
                s,
                "{},{},friedman,,,{:.9},{},{:.9e},",
                st.csp,
                st.metric.name(),
                f.statistic,
                st.blocks,
                f.p_value
            );
        }
        if let Ok(pairs) = &st.pairs {
            for p in pairs {
                let _ = writeln!(
                    s,
                    "{},{},wilcoxon,{},{},{:.3},{},{:.9e},{:.9e}",
                    st.csp,
                    st.metric.name(),
                    p.a,
                    p.b,
                    p.test.statistic,
                    p.test.n,
                    p.test.p_value,
                    p.p_corrected
                );
            }
        }
    }
    s
}

fn calibration_md(cmp: &[Comparison]) -> String {
    if cmp.is_empty() {
        return "No method of this study has published results of the authors to compare with (NF, UB, PB on the paper's maps).\n".into();
    }
    let mut s = String::from("Our means against the authors' published per-run results for the same maps and starts (`reference/`; failure probability 0/20/50/100 % = CSP 1.0/0.8/0.5/0.0). Their steps are steps to 100 % of the map known, capped at 100 as their runs were; ours are TNS capped at 100. Their local interactions count robot pairs at Chebyshev distance < 4 with line of sight per timestep (their `data_cleaning.py` halves a list of ordered pairs); ours are counted the same way here (`noli_authors`). Differences above 15 % are marked and attributed below.\n\n| method | CSP | metric | ours | theirs | difference | trials (ours / theirs) |\n|---|---|---|---|---|---|---|\n");
    for c in cmp {
        let rel = c.relative();
        let flag = if rel.abs() > 0.15 { " **>15 %**" } else { "" };
        let _ = writeln!(
            s,
            "| {} | {:.0} % | {} | {:.1} | {:.1} | {:+.0} %{flag} | {} / {} |",
            c.method,
            100.0 * c.csp,
            c.metric,
            c.ours,
            c.theirs,
            100.0 * rel,
            c.runs,
            c.their_runs
        );
    }
    let flagged: Vec<&Comparison> = cmp.iter().filter(|c| c.relative().abs() > 0.15).collect();
    if !flagged.is_empty() {
        s.push_str("\nEach difference above 15 % and the convention differences that act on it (described below the list):\n\n");
        for c in &flagged {
            let names: Vec<&str> = conventions(&c.method, c.metric, c.csp)
                .iter()
                .map(|v| v.name())
                .collect();
            let _ = writeln!(
                s,
                "- {} at CSP {:.0} %, {} ({:+.0} %): {}.",
                c.method,
                100.0 * c.csp,
                c.metric,
                100.0 * c.relative(),
                names.join(", ")
            );
        }
        let all: Vec<crate::calibration::Convention> = flagged
            .iter()
            .flat_map(|c| conventions(&c.method, c.metric, c.csp))
            .collect();
        let mut seen = Vec::new();
        s.push('\n');
        for v in all {
            if !seen.contains(&v) {
                seen.push(v);
                let _ = writeln!(s, "- **{}**: {}.", v.name(), v.explain());
            }
        }
    }
    s
}

/// Writes every output of the study into `out`; returns the report's path.
pub fn write_all(
    cfg: &StudyConfig,
    outcomes: &[TrialOutcome],
    paper_maps: &[String],
    bounds: &Bounds,
    out: &Path,
    wall_s: f64,
) -> Result<std::path::PathBuf, StudyError> {
    let alpha = 0.001;
    let rows = summary(outcomes, &cfg.methods);
    write_atomic(&out.join("summary.md"), summary_md(&rows).as_bytes())?;
    write_atomic(&out.join("summary.csv"), summary_csv(&rows).as_bytes())?;
    let stats = statistics(outcomes, &cfg.methods);
    write_atomic(
        &out.join("statistics.md"),
        statistics_md(&stats, alpha).as_bytes(),
    )?;
    write_atomic(
        &out.join("statistics.csv"),
        statistics_csv(&stats).as_bytes(),
    )?;
    let plot_err = |e: madenet_plots::PlotError| StudyError::Other(e.to_string());
    // Fig. 4: grouped bars per metric, methods × CSP, error bars one standard deviation.
    let cs = csps(outcomes);
    let panels: Vec<BarPanel> = Metric::ALL
        .iter()
        .enumerate()
        .map(|(k, m)| BarPanel {
            title: format!("({}) {}", ["a", "b", "c", "d"][k], m.name()),
            y_label: m.label().to_string(),
            categories: cs.iter().map(|(_, c)| format!("CSP {}", pct(c))).collect(),
            series: cfg
                .methods
                .iter()
                .map(|method| {
                    let (means, errors) = cs
                        .iter()
                        .map(|(_, c)| {
                            rows.iter()
                                .find(|r| &r.method == method && &r.csp == c)
                                .map(|r| r.metrics[k])
                                .unwrap_or((0.0, 0.0))
                        })
                        .unzip();
                    BarSeries {
                        name: method.to_uppercase(),
                        means,
                        errors,
                    }
                })
                .collect(),
        })
        .collect();
    bar_panels(&out.join("fig4_metrics"), &panels, 2).map_err(plot_err)?;
    // Fig. 5: mean explored % vs distance at full and no communication.
    let curve_panels: Vec<LinePanel> = cs
        .iter()
        .rev()
        .filter(|(c, _)| *c == 1.0 || *c == 0.0)
        .map(|(_, c)| LinePanel {
            title: format!("CSP {}", pct(c)),
            x_label: "team distance travelled (m)".into(),
            y_label: "explored (%)".into(),
            series: cfg
                .methods
                .iter()
                .map(|m| LineSeries {
                    name: m.to_uppercase(),
                    points: mean_curve(&select(outcomes, m, c), 2.0),
                })
                .collect(),
        })
        .collect();
    let mut fig5 = false;
    if !curve_panels.is_empty() {
        line_panels(
            &out.join("fig5_exploration"),
            &curve_panels,
            curve_panels.len(),
        )
        .map_err(plot_err)?;
        fig5 = true;
    }
    let cmp = compare(outcomes, paper_maps);
    let mut r = String::new();
    let _ = writeln!(r, "# madenet comparison study\n");
    let _ = writeln!(
        r,
        "Methods {}{} on {} maps × {} starts × CSP {{{}}} × {} seeds (seed {}…): {} trials, step cap {}, simulated in {:.1} s on this machine. Configuration: `study.toml`; every trial: `trials.csv` (exploration curves: `curves.jsonl`).\n",
        cfg.methods.join(", "),
        if cfg.oracles.is_empty() {
            String::new()
        } else {
            format!(
                " and the oracles {} over `{}`",
                cfg.oracles.iter().map(|o| o.name()).collect::<Vec<_>>().join(", "),
                cfg.oracle_base
            )
        },
        outcomes.iter().map(|o| &o.row.key.map).collect::<std::collections::BTreeSet<_>>().len(),
        cfg.starts.len(),
        cfg.csp.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(", "),
        cfg.seeds,
        cfg.seed_base,
        outcomes.len(),
        cfg.scenario.step_cap,
        wall_s
    );
    let _ = writeln!(r, "## Summary (mean ± sd)\n\n{}", summary_md(&rows));
    let _ = writeln!(r, "TNS: timesteps to completion (the cap if not completed); TTD: team travel distance; NOLI: robot pairs within d_s in line of sight, over timesteps; OFV: Eq. (1), Σ_p p / D(p); CT: simulation wall time.\n");
    let _ = writeln!(r, "## Figures\n\n![Fig. 4](fig4_metrics.png)\n\n*Fig. 4 — means across trials per method and CSP, error bars one standard deviation (`fig4_metrics.svg`).*\n");
    if fig5 {
        let _ = writeln!(r, "![Fig. 5](fig5_exploration.png)\n\n*Fig. 5 — mean explored % against team distance travelled (`fig5_exploration.svg`).*\n");
    }
    let _ = writeln!(
        r,
        "## Best method per CSP, and robustness to dropouts\n\n{}",
        robustness_md(&rows, &cs, &cfg.methods)
    );
    if !cfg.oracles.is_empty() {
        let _ = writeln!(
            r,
            "## The ceiling: rollout oracles\n\n{}",
            ceiling_md(cfg, outcomes, &cs)
        );
    }
    if cfg
        .oracles
        .contains(&madenet_baselines::rollout::OracleKind::KnownMap)
    {
        let _ = writeln!(
            r,
            "## Headroom: the known-map reference and the lower bound\n\n{}",
            headroom_md(cfg, outcomes, bounds, &cs)
        );
    }
    let _ = writeln!(r, "## Statistics\n\n{}", statistics_md(&stats, alpha));
    let _ = writeln!(
        r,
        "## Calibration against the authors' code\n\n{}",
        calibration_md(&cmp)
    );
    let path = out.join("report.md");
    write_atomic(&path, r.as_bytes())?;
    Ok(path)
}
