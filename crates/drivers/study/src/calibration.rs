//! Our classical baselines against the per-run results the paper's authors published for
//! theirs on the same 10 maps and 4 corners (`reference/`, copied from their repository
//! `Federico-PizarroBejarano/Decentralized-Multi-Robot-Exploration`, `decentralized_exploration/results/`).

use crate::runner::TrialOutcome;

/// The authors' per-run CSVs, embedded: (failure probability %, text).
const REFERENCE: [(u32, &str); 4] = [
    (
        0,
        include_str!("../../../../reference/baseline_runs_failure_prob_0.csv"),
    ),
    (
        20,
        include_str!("../../../../reference/baseline_runs_failure_prob_20.csv"),
    ),
    (
        50,
        include_str!("../../../../reference/baseline_runs_failure_prob_50.csv"),
    ),
    (
        100,
        include_str!("../../../../reference/baseline_runs_failure_prob_100.csv"),
    ),
];

/// Their algorithm names for ours.
pub const METHODS: [(&str, &str); 3] = [("nf", "greedy"), ("ub", "utility"), ("pb", "mdp")];

/// A convention in which the authors' simulator differs from ours (docs/guide/configuration.md, "Conventions").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Convention {
    /// Their robots act one after another within a timestep; ours act simultaneously.
    Sequential,
    /// Their robots decide before scanning from the cell they stand on (one step of lag).
    ScanLag,
    /// Their distances and paths count every move as 1, diagonals included; ours are metres.
    KingMetric,
    /// Their failed draw blocks the whole team's exchanges for 7 steps; ours blocks one pair.
    Blackout,
    /// Their runs stop at 100 timesteps.
    Cap100,
    /// Their run ends when their team map has no frontier left; ours when every explorable
    /// cell is known.
    Completion,
    /// Ours plan paths with A* around teammates; theirs take one greedy step at a time.
    Navigation,
    /// Their UB scores cells and repels robots differently from ours (ours: Burgard et al.'s
    /// information gain − β·path cost).
    UbDesign,
    /// Their PB scales rewards and adds repulsion around neighbours; ours solves on the plain
    /// rewards.
    PbDesign,
}

impl Convention {
    /// Short name, listed after each difference above 15 % in the report.
    pub fn name(self) -> &'static str {
        match self {
            Convention::Sequential => "sequential moves",
            Convention::ScanLag => "scan before moving",
            Convention::KingMetric => "move-count distances",
            Convention::Blackout => "global blackout",
            Convention::Cap100 => "100-step cap",
            Convention::Completion => "completion rule",
            Convention::Navigation => "navigation",
            Convention::UbDesign => "UB design",
            Convention::PbDesign => "PB design",
        }
    }
    /// How their simulator and ours differ, in one sentence of the report.
    pub fn explain(self) -> &'static str {
        match self {
            Convention::Sequential => "their robots act one after another inside a timestep, each after the earlier ones have moved, scanned and shared maps; ours act simultaneously, and a robot cannot enter a cell another holds at the start of the step",
            Convention::ScanLag => "their robot chooses its move, scans, then moves, so every decision lacks the view from the cell it stands on (one step of lag); ours sense after moving and decide on what they see where they are",
            Convention::KingMetric => "their nearest frontier and paths come from breadth-first search counting every move as 1, so they take diagonal steps of √2 m where straight ones of 1 m reach as far; ours minimise metres",
            Convention::Blackout => "their failed draw blocks every exchange of the whole team for 7 steps (one draw per step); ours blocks one pair, drawn per pair, so at the same CSP more information flows",
            Convention::Cap100 => "their runs stop at 100 timesteps, so their steps to 100 % are at most 100 and longer runs are cut short (ours are compared capped at 100 too, but their cut runs also travel less)",
            Convention::Completion => "their run ends when their team map has no frontier left; ours when every explorable cell (visible from some reachable cell) is known",
            Convention::Navigation => "our robots plan paths with A* and prioritized space-time A* around teammates they talk to, and treat teammates they see as obstacles; theirs take one greedy step at a time and only avoid occupied cells",
            Convention::UbDesign => "their UB scores cells by a normalized cell reward plus a beta-shaped distance term and repels robots by breadth-first distance from teammates in sight; ours is Burgard et al.'s information gain − β·path cost with targets discounted near the goals teammates announced, as the study specifies",
            Convention::PbDesign => "their PB multiplies the initial values by a reward multiplier, solves each teammate's value function with repulsive rewards around its neighbours; ours solves every teammate's value function on the plain rewards (on these maps one function serves all teammates) and sweeps as they do (at least 21, then until values move by less than 1, at most 50)",
        }
    }
}

/// The conventions that can move a metric for a method at a CSP.
pub fn conventions(method: &str, metric: &str, csp: f64) -> Vec<Convention> {
    let mut v = vec![Convention::Sequential];
    if csp < 1.0 {
        v.push(Convention::Blackout);
    }
    match metric {
        "steps" => v.extend([
            Convention::ScanLag,
            Convention::Cap100,
            Convention::Completion,
        ]),
        "distance" => v.extend([
            Convention::ScanLag,
            Convention::KingMetric,
            Convention::Cap100,
            Convention::Navigation,
        ]),
        _ => v.push(Convention::Navigation),
    }
    match method {
        "ub" => v.push(Convention::UbDesign),
        "pb" => v.push(Convention::PbDesign),
        _ => {}
    }
    v
}

/// One comparison line.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Our method: `nf`, `ub` or `pb` ([`METHODS`]).
    pub method: String,
    /// CSP, 1 − their failure probability.
    pub csp: f64,
    /// `steps` (our TNS capped at 100 against their `to_100`), `distance` (TTD, metres,
    /// against `total_dist`) or `local interactions` (`noli_authors` against `local_int`).
    pub metric: &'static str,
    /// Our mean over the study's trials on the paper's maps.
    pub ours: f64,
    /// The mean of the authors' published runs.
    pub theirs: f64,
    /// Number of our trials averaged in `ours`.
    pub runs: usize,
    /// Number of the authors' published runs averaged in `theirs`.
    pub their_runs: usize,
}

impl Comparison {
    /// (ours − theirs) / theirs.
    pub fn relative(&self) -> f64 {
        (self.ours - self.theirs) / self.theirs
    }
}

fn csp_of_failure(fp: u32) -> f64 {
    1.0 - fp as f64 / 100.0
}

/// Their means per (algorithm, failure probability): (to_100, total_dist, local_int, runs).
fn reference_means(algorithm: &str, fp: u32) -> Option<(f64, f64, f64, usize)> {
    let text = REFERENCE.iter().find(|(f, _)| *f == fp)?.1;
    let mut rdr = csv::Reader::from_reader(text.as_bytes());
    let headers = rdr.headers().ok()?.clone();
    let col = |name: &str| headers.iter().position(|h| h == name);
    let (a, s, d, l) = (
        col("Algorithm")?,
        col("to_100")?,
        col("total_dist")?,
        col("local_int")?,
    );
    let mut acc = (0.0, 0.0, 0.0, 0usize);
    for rec in rdr.records().flatten() {
        if rec.get(a) != Some(algorithm) {
            continue;
        }
        let num = |i: usize| rec.get(i).and_then(|v| v.parse::<f64>().ok());
        if let (Some(x), Some(y), Some(z)) = (num(s), num(d), num(l)) {
            acc = (acc.0 + x, acc.1 + y, acc.2 + z, acc.3 + 1);
        }
    }
    (acc.3 > 0).then(|| {
        (
            acc.0 / acc.3 as f64,
            acc.1 / acc.3 as f64,
            acc.2 / acc.3 as f64,
            acc.3,
        )
    })
}

/// Our NF/UB/PB means against theirs wherever the study has the same method and CSP, on the
/// paper's maps only (`paper_maps`: the names of the embedded paper maps the study used). Our
/// steps are capped at 100 like theirs; our local interactions are counted their way
/// (`noli_authors`).
pub fn compare(outcomes: &[TrialOutcome], paper_maps: &[String]) -> Vec<Comparison> {
    let mut out = Vec::new();
    for (ours, theirs) in METHODS {
        for (fp, _) in REFERENCE {
            let csp = csp_of_failure(fp);
            let sel: Vec<&TrialOutcome> = outcomes
                .iter()
                .filter(|o| o.row.key.method == ours && paper_maps.contains(&o.row.key.map))
                .filter(|o| {
                    o.row
                        .key
                        .csp
                        .parse::<f64>()
                        .is_ok_and(|c| (c - csp).abs() < 1e-9)
                })
                .collect();
            let Some((t_steps, t_dist, t_int, runs)) = reference_means(theirs, fp) else {
                continue;
            };
            if sel.is_empty() {
                continue;
            }
            let n = sel.len() as f64;
            let mean = |f: &dyn Fn(&TrialOutcome) -> f64| sel.iter().map(|o| f(o)).sum::<f64>() / n;
            out.push(Comparison {
                method: ours.into(),
                csp,
                metric: "steps",
                ours: mean(&|o| (o.row.tns as f64).min(100.0)),
                theirs: t_steps,
                runs: sel.len(),
                their_runs: runs,
            });
            out.push(Comparison {
                method: ours.into(),
                csp,
                metric: "distance",
                ours: mean(&|o| o.row.ttd),
                theirs: t_dist,
                runs: sel.len(),
                their_runs: runs,
            });
            out.push(Comparison {
                method: ours.into(),
                csp,
                metric: "local interactions",
                ours: mean(&|o| o.row.noli_authors as f64),
                theirs: t_int,
                runs: sel.len(),
                their_runs: runs,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_means_match_their_summary() {
        // baseline_summary_by_failure_prob.csv: greedy, 0 % → local_int 52.5, total_dist
        // 281.1337804140288, to_100 77.825.
        let (s, d, l, n) = reference_means("greedy", 0).unwrap();
        assert_eq!(n, 40);
        assert!((s - 77.825).abs() < 1e-9);
        assert!((d - 281.1337804140288).abs() < 1e-6);
        assert!((l - 52.5).abs() < 1e-9);
        let (s, _, _, _) = reference_means("mdp", 100).unwrap();
        assert!((s - 100.0).abs() < 1e-9);
    }
}
