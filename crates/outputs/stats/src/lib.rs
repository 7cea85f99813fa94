//! Statistics of the MADE-Net comparison study (Tan et al., RA-L 2023).
//!
//! The paper compares navigation methods (NF, UB, PB, MADE-Net, …) on paired
//! trials: every method is run on the same *blocks* — one block is one
//! `(map, start, seed)` combination — so the samples are related, not
//! independent. Its analysis is reproduced with:
//!
//! * [`friedman`] — the omnibus test: is there any difference among the `k ≥ 3`
//!   methods for one metric? ("Using the Friedman Test, a statistically
//!   significant difference (p < 0.0001) was found for each metric …")
//!   Matches `scipy.stats.friedmanchisquare(*groups)`.
//! * [`wilcoxon`] — the post-hoc test between two methods: paired, two-sided
//!   Wilcoxon signed-rank test. Matches `scipy.stats.wilcoxon(x, y,
//!   zero_method="wilcox", correction=True)` with `method="exact"` or
//!   `method="asymptotic"` as chosen by the rule documented on [`wilcoxon`].
//! * [`bonferroni`] — the multiple-comparison correction of the post-hoc tests
//!   ("Wilcoxon Signed-rank tests with Bonferroni correction"): a corrected
//!   p-value `min(1, p·m)`, to be compared with the family-wise `α`. Comparing
//!   the raw `p` with `α / m` (the paper's `α_revised`) is equivalent.
//! * [`pairwise_wilcoxon`] — convenience for the study: all `k(k−1)/2`
//!   pairwise Wilcoxon tests among named methods with Bonferroni-corrected
//!   p-values.
//!
//! statrs provides only the distributions (χ², normal); both tests are
//! implemented here by hand.
//!
//! # Conventions (those of scipy)
//!
//! * Data layout: `groups[g][b]` is the value of group (method) `g` in block
//!   `b`; all groups have the same length and index `b` pairs the observations.
//! * Ranks are average ranks for ties (`scipy.stats.rankdata(method="average")`),
//!   and a tie is exact `f64` equality, as in scipy.
//! * Friedman ranks the `k` values within each block and applies the tie
//!   correction; its p-value is the upper tail of χ² with `k − 1` degrees of
//!   freedom.
//! * Wilcoxon drops zero differences (`zero_method="wilcox"`), reports
//!   `min(W+, W−)` as the statistic and a two-sided p-value; exact null
//!   distribution for small samples without ties or zeros, otherwise the
//!   normal approximation with tie-corrected variance and continuity correction.
//! * NaN inputs are errors ([`StatsError::NaN`]), not propagated as scipy does.
//! * Degenerate data where scipy returns NaN give "no evidence of a
//!   difference" instead: all differences zero in [`wilcoxon`], every block
//!   entirely tied in [`friedman`] — statistic `0`, p-value `1`.
//!
//! The implementations are pinned against values computed with scipy 1.17.1
//! (see `tests/scipy_reference.rs`).
//!
//! # Example
//!
//! ```
//! use madenet_stats::{friedman, pairwise_wilcoxon};
//!
//! // Path length of three methods on the same six (map, start, seed) blocks.
//! let a = [10.0, 12.0, 11.0, 13.0, 12.5, 11.5];
//! let b = [9.9, 11.8, 10.7, 12.6, 12.0, 10.9];
//! let c = [14.0, 15.0, 13.5, 16.0, 15.5, 14.5];
//! let omnibus = friedman(&[&a, &b, &c]).unwrap();
//! assert_eq!(omnibus.df, 2);
//! assert!(omnibus.p_value < 0.01);
//!
//! let names = ["A", "B", "C"].map(String::from);
//! let post_hoc = pairwise_wilcoxon(&names, &[&a, &b, &c]).unwrap();
//! assert_eq!(post_hoc.len(), 3);
//! assert_eq!((post_hoc[0].a.as_str(), post_hoc[0].b.as_str()), ("A", "B"));
//! // Six blocks without ties: exact p = 2/2^6, times 3 comparisons.
//! assert_eq!(post_hoc[0].p_corrected, 3.0 * 2.0 / 64.0);
//! ```

#![deny(missing_docs)]

mod friedman;
mod rank;
mod wilcoxon;

pub use friedman::{friedman, Friedman};
pub use wilcoxon::{wilcoxon, Wilcoxon, WilcoxonMethod, EXACT_MAX_N};

/// Errors of the statistical tests: invalid or insufficient input.
#[derive(Debug, thiserror::Error, Clone, PartialEq, Eq)]
pub enum StatsError {
    /// Fewer groups than the test needs (Friedman: 3, pairwise tests: 2).
    #[error("need at least {min} groups (methods), got {got}")]
    TooFewGroups {
        /// Number of groups given.
        got: usize,
        /// Minimum number of groups the test needs.
        min: usize,
    },
    /// Fewer blocks (paired observations) than the test needs.
    #[error("need at least {min} blocks (paired observations), got {got}")]
    TooFewBlocks {
        /// Number of blocks given.
        got: usize,
        /// Minimum number of blocks the test needs.
        min: usize,
    },
    /// A sample's length differs from the others: samples must be paired
    /// block by block.
    #[error("{what} has {got} values but {expected} were expected: samples must be paired block by block")]
    UnequalLengths {
        /// Which sample (e.g. `"group 2"`, `"y"`).
        what: String,
        /// Length of the first sample.
        expected: usize,
        /// Length of this sample.
        got: usize,
    },
    /// A NaN value in the input (or a NaN difference, `∞ − ∞`).
    #[error("NaN in {what} at position {position}")]
    NaN {
        /// Which sample (e.g. `"group 2"`, `"x"`).
        what: String,
        /// Index of the block holding the NaN.
        position: usize,
    },
    /// [`pairwise_wilcoxon`] got a different number of names and groups.
    #[error("{names} names given for {groups} groups")]
    NamesMismatch {
        /// Number of names.
        names: usize,
        /// Number of groups.
        groups: usize,
    },
}

/// Bonferroni-corrected p-value for one of `comparisons` tests: `min(1, p · m)`.
///
/// `comparisons = 0` is treated as 1 (no correction); a NaN `p` stays NaN.
pub fn bonferroni(p: f64, comparisons: usize) -> f64 {
    if p.is_nan() {
        return p;
    }
    (p * comparisons.max(1) as f64).min(1.0)
}

/// One pairwise comparison of [`pairwise_wilcoxon`].
#[derive(Clone, Debug, PartialEq)]
pub struct PairwiseTest {
    /// Name of the first group (the `x` of the test; earlier in input order).
    pub a: String,
    /// Name of the second group (the `y` of the test).
    pub b: String,
    /// The Wilcoxon signed-rank test of `a − b`.
    pub test: Wilcoxon,
    /// `bonferroni(test.p_value, k(k−1)/2)` for `k` groups.
    pub p_corrected: f64,
}

/// All pairwise two-sided Wilcoxon signed-rank tests among named groups, with
/// Bonferroni-corrected p-values over the `k(k−1)/2` comparisons.
///
/// `groups[g][b]` is the value of group `g` (named `names[g]`) in block `b`.
/// The order is stable: pairs `(i, j)` with `i < j` in input order,
/// lexicographically — `(0,1), (0,2), …, (0,k−1), (1,2), …` — and each test is
/// `wilcoxon(groups[i], groups[j])`.
///
/// # Errors
/// [`StatsError::NamesMismatch`] if `names` and `groups` differ in length,
/// [`StatsError::TooFewGroups`] if there are fewer than 2 groups,
/// [`StatsError::UnequalLengths`], [`StatsError::TooFewBlocks`] or
/// [`StatsError::NaN`] (naming the group) for invalid samples.
pub fn pairwise_wilcoxon(
    names: &[String],
    groups: &[&[f64]],
) -> Result<Vec<PairwiseTest>, StatsError> {
    if names.len() != groups.len() {
        return Err(StatsError::NamesMismatch {
            names: names.len(),
            groups: groups.len(),
        });
    }
    let k = groups.len();
    check_blocks(groups, 2, |g| format!("group {:?}", names[g]))?;

    let comparisons = k * (k - 1) / 2;
    let mut out = Vec::with_capacity(comparisons);
    for i in 0..k {
        for j in i + 1..k {
            let test = wilcoxon(groups[i], groups[j]).map_err(|e| match e {
                StatsError::NaN { position, .. } => StatsError::NaN {
                    what: format!(
                        "the difference {:?} - {:?} (infinity minus infinity)",
                        names[i], names[j]
                    ),
                    position,
                },
                other => other,
            })?;
            let p_corrected = bonferroni(test.p_value, comparisons);
            out.push(PairwiseTest {
                a: names[i].clone(),
                b: names[j].clone(),
                test,
                p_corrected,
            });
        }
    }
    Ok(out)
}

/// Checks blocked samples, `groups[g][b]` the value of group `g` in block `b`: at least
/// `min_groups` groups, all of one length, no NaN, at least one block. `label(g)` names group
/// `g` in the errors. Returns the number of blocks.
pub(crate) fn check_blocks(
    groups: &[&[f64]],
    min_groups: usize,
    label: impl Fn(usize) -> String,
) -> Result<usize, StatsError> {
    let k = groups.len();
    if k < min_groups {
        return Err(StatsError::TooFewGroups {
            got: k,
            min: min_groups,
        });
    }
    let n = groups[0].len();
    for (g, values) in groups.iter().enumerate() {
        if values.len() != n {
            return Err(StatsError::UnequalLengths {
                what: label(g),
                expected: n,
                got: values.len(),
            });
        }
        if let Some(position) = values.iter().position(|v| v.is_nan()) {
            return Err(StatsError::NaN {
                what: label(g),
                position,
            });
        }
    }
    if n == 0 {
        return Err(StatsError::TooFewBlocks { got: 0, min: 1 });
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bonferroni_caps_and_scales() {
        assert_eq!(bonferroni(0.01, 6), 0.06);
        assert_eq!(bonferroni(0.3, 6), 1.0);
        assert_eq!(bonferroni(0.02, 0), 0.02);
        assert_eq!(bonferroni(0.0, 6), 0.0);
        assert!(bonferroni(f64::NAN, 6).is_nan());
    }

    #[test]
    fn pairwise_order_and_correction() {
        let names: Vec<String> = ["NF", "UB", "PB", "MADE-Net"].map(String::from).to_vec();
        let g0 = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];
        let g1 = [1.5, 2.5, 2.0, 4.5, 6.0, 5.0, 9.0];
        let g2 = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let g3 = [9.0, 8.0, 7.0, 6.0, 5.5, 4.0, 3.0];
        let groups: [&[f64]; 4] = [&g0, &g1, &g2, &g3];
        let res = pairwise_wilcoxon(&names, &groups).unwrap();
        let pairs: Vec<(&str, &str)> = res.iter().map(|r| (r.a.as_str(), r.b.as_str())).collect();
        assert_eq!(
            pairs,
            [
                ("NF", "UB"),
                ("NF", "PB"),
                ("NF", "MADE-Net"),
                ("UB", "PB"),
                ("UB", "MADE-Net"),
                ("PB", "MADE-Net"),
            ]
        );
        for r in &res {
            let i = names.iter().position(|n| *n == r.a).unwrap();
            let j = names.iter().position(|n| *n == r.b).unwrap();
            assert_eq!(r.test, wilcoxon(groups[i], groups[j]).unwrap());
            assert_eq!(r.p_corrected, bonferroni(r.test.p_value, 6));
        }
    }

    #[test]
    fn pairwise_errors() {
        let names: Vec<String> = ["a", "b"].map(String::from).to_vec();
        let x = [1.0, 2.0];
        let short = [1.0];
        assert_eq!(
            pairwise_wilcoxon(&names[..1], &[&x, &x]),
            Err(StatsError::NamesMismatch {
                names: 1,
                groups: 2
            })
        );
        assert_eq!(
            pairwise_wilcoxon(&names[..1], &[&x]),
            Err(StatsError::TooFewGroups { got: 1, min: 2 })
        );
        assert!(matches!(
            pairwise_wilcoxon(&names, &[&x, &short]),
            Err(StatsError::UnequalLengths {
                expected: 2,
                got: 1,
                ..
            })
        ));
        let nan = [1.0, f64::NAN];
        let err = pairwise_wilcoxon(&names, &[&x, &nan]).unwrap_err();
        assert_eq!(
            err,
            StatsError::NaN {
                what: "group \"b\"".into(),
                position: 1
            }
        );
        let inf = [f64::INFINITY, 1.0];
        let err = pairwise_wilcoxon(&names, &[&inf, &inf]).unwrap_err();
        assert!(err.to_string().contains("\"a\" - \"b\""), "{err}");
        let empty: [f64; 0] = [];
        assert_eq!(
            pairwise_wilcoxon(&names, &[&empty, &empty]),
            Err(StatsError::TooFewBlocks { got: 0, min: 1 })
        );
    }
}
