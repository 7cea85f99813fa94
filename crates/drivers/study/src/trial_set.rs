//! A trial set named by command-line flags (`madenet batch`, `oracle`): the study config it
//! stands for, planned by the study runner, with a bad field named by the flag that set it
//! ([`StudyError::named_by`], which `compare` and `scale` use for their own flags too); and
//! the lines that sum its outcomes up per CSP ([`means_by_csp`], [`oracle_by_csp`]).

use crate::runner::{self, Planned, TrialOutcome, TrialRow};
use crate::{StudyConfig, StudyError};
use madenet_map::paper::Corner;
use madenet_sim::PolicyRegistry;
use std::path::Path;

impl StudyError {
    /// Names where a bad field came from: the flag that set it (`(field, flag, given)`: the
    /// first given flag of the field), else the `config` file, else nothing more (a default).
    pub fn named_by(self, config: Option<&Path>, flags: &[(&str, &str, bool)]) -> StudyError {
        let StudyError::Field { field, message } = &self else {
            return self;
        };
        let flag = flags
            .iter()
            .find(|(f, _, given)| f == field && *given)
            .map(|(_, flag, _)| *flag);
        match (flag, config) {
            (Some(flag), _) => StudyError::Other(format!("{flag}: {message}")),
            (None, Some(path)) => StudyError::Other(format!("{}: {self}", path.display())),
            (None, None) => self,
        }
    }
}

impl StudyConfig {
    /// The trial set that `maps × starts × csp × seeds` flags describe in `scenario`, with no
    /// methods and no oracles yet: `all` among the starts is the four corners.
    pub fn trial_set(
        maps: &[String],
        starts: &[String],
        csp: &[f64],
        (seeds, seed_base): (u64, u64),
        scenario: madenet_world::ScenarioConfig,
    ) -> StudyConfig {
        let mut corners = Vec::new();
        for s in starts {
            if s == "all" {
                corners.extend(Corner::ALL.iter().map(|c| c.name().to_string()));
            } else {
                corners.push(s.clone());
            }
        }
        StudyConfig {
            methods: Vec::new(),
            maps: maps.to_vec(),
            starts: corners,
            csp: csp.to_vec(),
            seeds,
            seed_base,
            scenario,
            oracles: Vec::new(),
            ..StudyConfig::default()
        }
    }

    /// Checks a [`Self::trial_set`] (a bad field named by its flag, `policy_flag` for the
    /// policy, else by `config`) and plans its trials in the study runner's order: methods,
    /// then oracles; maps, starts, CSPs, seeds.
    pub fn plan_flags(
        &self,
        registry: &PolicyRegistry,
        config: Option<&Path>,
        policy_flag: &str,
    ) -> Result<Vec<Planned>, StudyError> {
        let flags = [
            ("methods", policy_flag, true),
            ("oracle_base", policy_flag, true),
            ("oracle_futures", "--futures", true),
            ("oracle_lookahead.horizon", "--horizon", true),
            ("maps", "--maps", true),
            ("starts", "--starts", true),
            ("csp", "--csp", true),
            ("seeds", "--seeds", true),
            ("seed_base", "--seed-base", true),
        ];
        let (maps, starts) = self
            .validate(registry)
            .map_err(|e| e.named_by(config, &flags))?;
        let planned = runner::plan(self, &maps, &starts);
        runner::check_planned(&planned, registry)?;
        Ok(planned)
    }
}

/// The lines `madenet batch` prints, one per CSP of `csps`: trials completed and the mean TNS,
/// TTD, NOLI and OFV of `outcomes`.
pub fn means_by_csp(outcomes: &[TrialOutcome], csps: &[f64]) -> Vec<String> {
    csps.iter()
        .map(|&csp| {
            let sel: Vec<&TrialRow> = outcomes
                .iter()
                .map(|o| &o.row)
                .filter(|r| r.key.csp == runner::csp_label(csp))
                .collect();
            let n = sel.len().max(1) as f64;
            let mean = |f: &dyn Fn(&TrialRow) -> f64| sel.iter().map(|r| f(r)).sum::<f64>() / n;
            format!(
                "csp {csp:.2}: completed {}/{}  TNS {:.1}  TTD {:.1} m  NOLI {:.1}  OFV {:.2}",
                sel.iter().filter(|r| r.completed).count(),
                sel.len(),
                mean(&|r| r.tns as f64),
                mean(&|r| r.ttd),
                mean(&|r| r.noli as f64),
                mean(&|r| r.ofv),
            )
        })
        .collect()
}

/// The lines `madenet oracle` prints, one per CSP of `csps`: the mean TNS of the `base`
/// rule's trials and of the `oracle`'s on the same trials (paired in order), and on how many
/// the oracle was better and worse.
pub fn oracle_by_csp(base: &[TrialOutcome], oracle: &[TrialOutcome], csps: &[f64]) -> Vec<String> {
    csps.iter()
        .map(|&csp| {
            let sel: Vec<(&TrialRow, &TrialRow)> = base
                .iter()
                .zip(oracle)
                .map(|(b, o)| (&b.row, &o.row))
                .filter(|(b, _)| b.key.csp == runner::csp_label(csp))
                .collect();
            let n = sel.len().max(1) as f64;
            let mean = |f: &dyn Fn(&(&TrialRow, &TrialRow)) -> usize| {
                sel.iter().map(|r| f(r) as f64).sum::<f64>() / n
            };
            let base_tns = mean(&|r| r.0.tns);
            let oracle_tns = mean(&|r| r.1.tns);
            let wins = sel.iter().filter(|r| r.1.tns < r.0.tns).count();
            let losses = sel.iter().filter(|r| r.1.tns > r.0.tns).count();
            format!(
                "csp {csp:.2}: base TNS {base_tns:.1}  oracle TNS {oracle_tns:.1}  ({:+.1} %)  oracle better on {wins}, worse on {losses} of {}",
                100.0 * (oracle_tns / base_tns - 1.0),
                sel.len()
            )
        })
        .collect()
}
