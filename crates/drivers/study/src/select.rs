//! Choosing trials of a study by their keys (`madenet compare|scale --record-trials`): the
//! conditions `field=value` over a [`TrialKey`]'s fields, every one met, a value being one of
//! `|`-separated alternatives.
//!
//! ```
//! use madenet_study::select::TrialFilter;
//! use madenet_study::TrialKey;
//!
//! let f = TrialFilter::parse(&["method=spread|nf", "csp=1.0", "seed=3"]).unwrap();
//! let key = |method: &str, csp: &str| TrialKey {
//!     method: method.into(),
//!     map: "test_3".into(),
//!     start: "top-left".into(),
//!     csp: csp.into(),
//!     seed: 3,
//! };
//! assert!(f.matches(&key("nf", "1")));
//! assert!(!f.matches(&key("nf", "0.5")));
//! assert!(!f.matches(&key("ub", "1")));
//! assert!(TrialFilter::parse(&["colour=red"]).is_err());
//! ```

use crate::runner::{csp_label, TrialKey};

/// A condition's field of [`TrialKey`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Field {
    Method,
    Map,
    Start,
    Csp,
    Seed,
}

const FIELDS: [(&str, Field); 5] = [
    ("method", Field::Method),
    ("map", Field::Map),
    ("start", Field::Start),
    ("csp", Field::Csp),
    ("seed", Field::Seed),
];

/// Trials chosen by conditions on their keys ([module docs](self)).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TrialFilter {
    /// Each condition: a field and the values it may take (CSPs as [`csp_label`] writes them).
    conditions: Vec<(Field, Vec<String>)>,
}

impl TrialFilter {
    /// Reads conditions `field=value[|value…]` (fields: method, map, start, csp, seed), one an
    /// item or several separated by white space; the error says which condition is wrong.
    pub fn parse<S: AsRef<str>>(items: &[S]) -> Result<Self, String> {
        let mut conditions = Vec::new();
        for cond in items.iter().flat_map(|s| s.as_ref().split_whitespace()) {
            let (name, values) = cond.split_once('=').ok_or_else(|| {
                format!("`{cond}`: expected field=value (fields: method, map, start, csp, seed)")
            })?;
            let field = FIELDS
                .iter()
                .find(|(n, _)| *n == name)
                .map(|&(_, f)| f)
                .ok_or_else(|| {
                    format!(
                        "`{cond}`: unknown field `{name}` (fields: method, map, start, csp, seed)"
                    )
                })?;
            let values = values
                .split('|')
                .map(|v| match field {
                    _ if v.is_empty() => Err(format!("`{cond}`: an empty value")),
                    Field::Csp => v
                        .parse::<f64>()
                        .ok()
                        .filter(|c| (0.0..=1.0).contains(c))
                        .map(csp_label)
                        .ok_or_else(|| format!("`{cond}`: a CSP is a number in [0, 1], got `{v}`")),
                    Field::Seed => v
                        .parse::<u64>()
                        .map(|s| s.to_string())
                        .map_err(|_| format!("`{cond}`: a seed is a whole number, got `{v}`")),
                    _ => Ok(v.to_string()),
                })
                .collect::<Result<Vec<_>, _>>()?;
            conditions.push((field, values));
        }
        if conditions.is_empty() {
            return Err("no condition given (e.g. `method=spread seed=1`)".into());
        }
        Ok(TrialFilter { conditions })
    }

    /// Whether trial `key` meets every condition.
    pub fn matches(&self, key: &TrialKey) -> bool {
        self.conditions.iter().all(|(field, values)| {
            let seed;
            let got: &str = match field {
                Field::Method => &key.method,
                Field::Map => &key.map,
                Field::Start => &key.start,
                Field::Csp => &key.csp,
                Field::Seed => {
                    seed = key.seed.to_string();
                    &seed
                }
            };
            values.iter().any(|v| v == got)
        })
    }
}

/// A folder name for trial `key`'s recording: `method_map_start_csp<C>_seed<S>`, every
/// character other than ASCII letters, digits, `.`, `-` and `_` written as `-`.
pub fn folder_name(key: &TrialKey) -> String {
    format!(
        "{}_{}_{}_csp{}_seed{}",
        key.method, key.map, key.start, key.csp, key.seed
    )
    .chars()
    .map(|c| {
        if c.is_ascii_alphanumeric() || c == '.' || c == '-' || c == '_' {
            c
        } else {
            '-'
        }
    })
    .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key() -> TrialKey {
        TrialKey {
            method: "spread".into(),
            map: "side20-map0".into(),
            start: "3,4;5,6".into(),
            csp: "0.5".into(),
            seed: 12,
        }
    }

    #[test]
    fn conditions_are_all_met_and_values_are_alternatives() {
        let f = TrialFilter::parse(&["method=nf|spread map=side20-map0", "seed=12"]).unwrap();
        assert!(f.matches(&key()));
        let f = TrialFilter::parse(&["start=3,4;5,6", "csp=0.50"]).unwrap();
        assert!(f.matches(&key()));
        for miss in ["seed=1", "csp=1", "map=side20-map1", "method=nf"] {
            assert!(
                !TrialFilter::parse(&[miss]).unwrap().matches(&key()),
                "{miss}"
            );
        }
    }

    #[test]
    fn bad_conditions_say_which_and_why() {
        for (bad, why) in [
            ("seed", "field=value"),
            ("team=4", "unknown field `team`"),
            ("csp=2", "in [0, 1]"),
            ("csp=x", "in [0, 1]"),
            ("seed=-1", "whole number"),
            ("method=", "empty value"),
            ("method=nf|", "empty value"),
        ] {
            let e = TrialFilter::parse(&[bad]).unwrap_err();
            assert!(e.contains(bad) && e.contains(why), "{bad}: {e}");
        }
        assert!(TrialFilter::parse::<&str>(&[])
            .unwrap_err()
            .contains("no condition"));
        assert!(TrialFilter::parse(&["  "]).is_err());
    }

    #[test]
    fn folder_names_keep_only_safe_characters() {
        assert_eq!(
            folder_name(&key()),
            "spread_side20-map0_3-4-5-6_csp0.5_seed12"
        );
    }
}
