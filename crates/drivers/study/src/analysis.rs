//! From trial outcomes to the study's tables, statistics, figures and calibration.

use crate::runner::TrialOutcome;
use std::collections::BTreeMap;

/// The four metrics of the paper's Fig. 4.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    /// TNS, total number of steps: timesteps to completion, or the step cap (lower is better).
    Tns,
    /// TTD, total travel distance of the team, metres (lower is better).
    Ttd,
    /// NOLI, number of local interactions: robot pairs within d_s in line of sight, summed
    /// over timesteps (lower is better).
    Noli,
    /// OFV, objective function value of Eq. (1), Σ_p p / D(p) (higher is better).
    Ofv,
}

impl Metric {
    /// Every metric, in the order of Fig. 4's panels and of [`SummaryRow::metrics`].
    pub const ALL: [Metric; 4] = [Metric::Tns, Metric::Ttd, Metric::Noli, Metric::Ofv];
    /// Short name in tables and figures: `TNS`, `TTD`, `NOLI` or `OFV`.
    pub fn name(self) -> &'static str {
        match self {
            Metric::Tns => "TNS",
            Metric::Ttd => "TTD",
            Metric::Noli => "NOLI",
            Metric::Ofv => "OFV",
        }
    }
    /// Spelled-out name (with the unit for TTD): the y-axis label of its Fig. 4 panel.
    pub fn label(self) -> &'static str {
        match self {
            Metric::Tns => "total number of steps",
            Metric::Ttd => "total travel distance (m)",
            Metric::Noli => "number of local interactions",
            Metric::Ofv => "objective function value, Eq. (1)",
        }
    }
    /// The metric's value in trial `o` (counts converted to `f64`).
    pub fn of(self, o: &TrialOutcome) -> f64 {
        match self {
            Metric::Tns => o.row.tns as f64,
            Metric::Ttd => o.row.ttd,
            Metric::Noli => o.row.noli as f64,
            Metric::Ofv => o.row.ofv,
        }
    }
}

/// Mean and sample standard deviation.
pub fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let m = v.iter().sum::<f64>() / n;
    let sd = if v.len() > 1 {
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    (m, sd)
}

/// CSP values present, ascending (as the paper's figures order them), with their labels.
pub fn csps(outcomes: &[TrialOutcome]) -> Vec<(f64, String)> {
    let mut v: Vec<(f64, String)> = Vec::new();
    for o in outcomes {
        let c: f64 = o.row.key.csp.parse().unwrap_or(f64::NAN);
        // Compared by label too, so an unparsable label (NaN ≠ NaN) is listed once.
        if !v
            .iter()
            .any(|(x, label)| *x == c || *label == o.row.key.csp)
        {
            v.push((c, o.row.key.csp.clone()));
        }
    }
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    v
}

/// Outcomes of one method at one CSP, in plan order.
pub fn select<'a>(outcomes: &'a [TrialOutcome], method: &str, csp: &str) -> Vec<&'a TrialOutcome> {
    outcomes
        .iter()
        .filter(|o| o.row.key.method == method && o.row.key.csp == csp)
        .collect()
}

/// One row of the summary table: one method at one CSP.
#[derive(Clone, Debug)]
pub struct SummaryRow {
    /// Method name, as in `trials.csv`.
    pub method: String,
    /// CSP label, as in `trials.csv` (e.g. `0.5`).
    pub csp: String,
    /// Number of trials of this method at this CSP.
    pub trials: usize,
    /// How many of them completed (every explorable cell explored before the step cap).
    pub completed: usize,
    /// (mean, sd) per metric of [`Metric::ALL`].
    pub metrics: Vec<(f64, f64)>,
    /// Mean simulation wall time per trial (CT), seconds.
    pub trial_s: f64,
    /// Mean over trials of each trial's mean wall time per decision (CT), seconds.
    pub per_decision_s: f64,
}

/// One [`SummaryRow`] per method (in the order of `methods`) and CSP present (ascending);
/// a method with no trial at a CSP has no row there.
pub fn summary(outcomes: &[TrialOutcome], methods: &[String]) -> Vec<SummaryRow> {
    let mut rows = Vec::new();
    for m in methods {
        for (_, csp) in csps(outcomes) {
            let sel = select(outcomes, m, &csp);
            if sel.is_empty() {
                continue;
            }
            let metrics = Metric::ALL
                .iter()
                .map(|&k| mean_sd(&sel.iter().map(|o| k.of(o)).collect::<Vec<_>>()))
                .collect();
            rows.push(SummaryRow {
                method: m.clone(),
                csp: csp.clone(),
                trials: sel.len(),
                completed: sel.iter().filter(|o| o.row.completed).count(),
                metrics,
                trial_s: mean_sd(&sel.iter().map(|o| o.row.trial_s).collect::<Vec<_>>()).0,
                per_decision_s: mean_sd(
                    &sel.iter().map(|o| o.row.per_decision_s).collect::<Vec<_>>(),
                )
                .0,
            });
        }
    }
    rows
}

/// Statistics of one metric at one CSP.
#[derive(Clone, Debug)]
pub struct MetricStats {
    /// The metric compared across methods.
    pub metric: Metric,
    /// CSP label, as in `trials.csv`.
    pub csp: String,
    /// Number of (map, start, seed) blocks in which every method has a trial: the only ones
    /// tested.
    pub blocks: usize,
    /// Friedman test across the methods; `Err`: why it could not be computed (e.g. fewer than
    /// 3 methods).
    pub friedman: Result<madenet_stats::Friedman, String>,
    /// Bonferroni-corrected two-sided Wilcoxon signed-rank tests, one per pair of methods;
    /// `Err`: why they could not be computed (e.g. too few blocks).
    pub pairs: Result<Vec<madenet_stats::PairwiseTest>, String>,
}

/// Friedman across methods and pairwise Wilcoxon signed-rank tests (Bonferroni-corrected)
/// per metric per CSP, paired by (map, start, seed).
pub fn statistics(outcomes: &[TrialOutcome], methods: &[String]) -> Vec<MetricStats> {
    let mut out = Vec::new();
    if methods.len() < 2 {
        return out;
    }
    for (_, csp) in csps(outcomes) {
        // Blocks present for every method.
        let mut by_block: BTreeMap<(String, String, u64), Vec<Option<&TrialOutcome>>> =
            BTreeMap::new();
        for (mi, m) in methods.iter().enumerate() {
            for o in select(outcomes, m, &csp) {
                let k = &o.row.key;
                by_block
                    .entry((k.map.clone(), k.start.clone(), k.seed))
                    .or_insert_with(|| vec![None; methods.len()])[mi] = Some(o);
            }
        }
        let blocks: Vec<Vec<&TrialOutcome>> = by_block
            .into_values()
            .filter_map(|v| v.into_iter().collect::<Option<Vec<_>>>())
            .collect();
        for metric in Metric::ALL {
            let groups: Vec<Vec<f64>> = (0..methods.len())
                .map(|g| blocks.iter().map(|b| metric.of(b[g])).collect())
                .collect();
            let refs: Vec<&[f64]> = groups.iter().map(|g| g.as_slice()).collect();
            out.push(MetricStats {
                metric,
                csp: csp.clone(),
                blocks: blocks.len(),
                friedman: madenet_stats::friedman(&refs).map_err(|e| e.to_string()),
                pairs: madenet_stats::pairwise_wilcoxon(methods, &refs).map_err(|e| e.to_string()),
            });
        }
    }
    out
}

/// Mean explored % against team distance for one method at one CSP: the paper's Fig. 5.
/// Each trial's curve is read at distances 0, step, 2·step, … (linear interpolation; after
/// the trial ended, its final coverage), then averaged.
pub fn mean_curve(outcomes: &[&TrialOutcome], step: f64) -> Vec<(f64, f64)> {
    let max_d = outcomes
        .iter()
        .filter_map(|o| o.curve.distance.last().copied())
        .fold(0.0, f64::max);
    let n = (max_d / step).ceil() as usize + 1;
    (0..n)
        .map(|i| {
            let d = i as f64 * step;
            let sum: f64 = outcomes
                .iter()
                .map(|o| explored_at(&o.curve.distance, &o.curve.explored, d))
                .sum();
            (d, 100.0 * sum / outcomes.len().max(1) as f64)
        })
        .collect()
}

fn explored_at(distance: &[f64], explored: &[f64], d: f64) -> f64 {
    match distance.iter().position(|&x| x >= d) {
        None => *explored.last().unwrap_or(&0.0),
        Some(0) => explored[0],
        Some(k) => {
            let (d0, d1) = (distance[k - 1], distance[k]);
            let f = if d1 > d0 { (d - d0) / (d1 - d0) } else { 1.0 };
            explored[k - 1] + f * (explored[k] - explored[k - 1])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_sd_and_interpolation() {
        let (m, sd) = mean_sd(&[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(m, 2.5);
        assert!((sd - 1.2909944487358056).abs() < 1e-12);
        let d = [0.0, 2.0, 4.0];
        let e = [0.1, 0.5, 0.7];
        assert_eq!(explored_at(&d, &e, 0.0), 0.1);
        assert!((explored_at(&d, &e, 1.0) - 0.3).abs() < 1e-12);
        assert!((explored_at(&d, &e, 3.0) - 0.6).abs() < 1e-12);
        assert_eq!(explored_at(&d, &e, 10.0), 0.7);
    }
}
