//! Friedman test for k related samples.

use statrs::distribution::{ChiSquared, ContinuousCDF};

use crate::rank::average_ranks;
use crate::{check_blocks, StatsError};

/// Result of [`friedman`].
#[derive(Clone, Debug, PartialEq)]
pub struct Friedman {
    /// Friedman chi-squared statistic, corrected for ties within blocks
    /// (scipy's `statistic`). `0.0` in the degenerate case where every block is
    /// entirely tied (see [`friedman`]).
    pub statistic: f64,
    /// Degrees of freedom of the chi-squared reference distribution: `groups − 1`.
    pub df: usize,
    /// Upper-tail p-value `P(χ²_df ≥ statistic)` (scipy's `pvalue`).
    pub p_value: f64,
    /// Number of blocks `n` (the common length of the groups).
    pub blocks: usize,
    /// Number of groups `k` (methods).
    pub groups: usize,
}

/// Friedman test that `k ≥ 3` related groups come from the same distribution.
///
/// `groups[g][b]` is the value of group (method) `g` in block `b`; all groups
/// must have the same length `n ≥ 1`. Within each block the `k` values are
/// ranked (average ranks for ties, ties being exact `f64` equality), `R_g` is
/// the rank sum of group `g`, and
///
/// ```text
/// Q = (12 / (n k (k+1)) · Σ_g R_g² − 3 n (k+1)) / C,   C = 1 − Σ(t³ − t) / (n k (k² − 1))
/// ```
///
/// where the tie sum runs over the tie groups of every block. The p-value is
/// the upper tail of χ² with `k − 1` degrees of freedom. This is exactly
/// `scipy.stats.friedmanchisquare(*groups)`, including its requirement of at
/// least three groups (use [`crate::wilcoxon`] for two).
///
/// Degenerate case: if every block is entirely tied (`C = 0`), scipy returns
/// NaN; here the result is `statistic = 0`, `p_value = 1` (no evidence of a
/// difference).
///
/// # Errors
/// [`StatsError::TooFewGroups`] if `k < 3`, [`StatsError::TooFewBlocks`] if
/// `n = 0`, [`StatsError::UnequalLengths`] if the groups differ in length,
/// [`StatsError::NaN`] if any value is NaN. Infinities are allowed (they rank
/// like any other value).
pub fn friedman(groups: &[&[f64]]) -> Result<Friedman, StatsError> {
    let k = groups.len();
    let n = check_blocks(groups, 3, |g| format!("group {g}"))?;

    let mut rank_sums = vec![0.0; k];
    let mut ties = 0.0;
    let mut block = vec![0.0; k];
    for b in 0..n {
        for (slot, values) in block.iter_mut().zip(groups) {
            *slot = values[b];
        }
        let (ranks, tie_sum) = average_ranks(&block);
        for (sum, r) in rank_sums.iter_mut().zip(&ranks) {
            *sum += r;
        }
        ties += tie_sum;
    }

    let (kf, nf) = (k as f64, n as f64);
    let df = k - 1;
    // Same order of operations as scipy, so that results agree to the last bits.
    let c = 1.0 - ties / (kf * (kf * kf - 1.0) * nf);
    if c <= 0.0 {
        return Ok(Friedman {
            statistic: 0.0,
            df,
            p_value: 1.0,
            blocks: n,
            groups: k,
        });
    }
    let ssbn: f64 = rank_sums.iter().map(|r| r * r).sum();
    let statistic = (12.0 / (kf * nf * (kf + 1.0)) * ssbn - 3.0 * nf * (kf + 1.0)) / c;
    let chi2 = ChiSquared::new(df as f64).expect("k - 1 >= 2 degrees of freedom is valid");
    let p_value = chi2.sf(statistic).clamp(0.0, 1.0);
    Ok(Friedman {
        statistic,
        df,
        p_value,
        blocks: n,
        groups: k,
    })
}
