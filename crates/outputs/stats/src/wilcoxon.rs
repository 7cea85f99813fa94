//! Wilcoxon signed-rank test for paired samples.

use statrs::distribution::{ContinuousCDF, Normal};

use crate::rank::average_ranks;
use crate::StatsError;

/// Largest number of non-zero differences for which the exact null
/// distribution is used (scipy's `method="auto"` threshold).
pub const EXACT_MAX_N: usize = 50;

/// How the p-value of a [`Wilcoxon`] test was obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WilcoxonMethod {
    /// Exact null distribution of the signed-rank statistic
    /// (scipy `method="exact"`).
    Exact,
    /// Normal approximation with tie-corrected variance and continuity
    /// correction (scipy `method="asymptotic"`, `correction=True`; called
    /// `"approx"` in scipy < 1.9).
    Normal,
}

/// Result of [`wilcoxon`].
#[derive(Clone, Debug, PartialEq)]
pub struct Wilcoxon {
    /// `min(W+, W−)`, the smaller of the rank sums of the positive and of the
    /// negative differences (scipy's two-sided `statistic`). A multiple of 0.5
    /// when there are ties.
    pub statistic: f64,
    /// Two-sided p-value.
    pub p_value: f64,
    /// Number of non-zero differences actually used (zeros are dropped).
    pub n: usize,
    /// How `p_value` was computed.
    pub method: WilcoxonMethod,
    /// For [`WilcoxonMethod::Normal`] only: the continuity-corrected z-score of
    /// `W+`, `(W+ − μ − 0.5·sign(W+ − μ)) / σ`. It is positive when `x` tends to
    /// exceed `y`. scipy reports `−|z|` as `zstatistic`, which loses the
    /// direction. `None` for [`WilcoxonMethod::Exact`].
    pub z: Option<f64>,
}

/// Paired two-sided Wilcoxon signed-rank test of the differences `x[i] − y[i]`.
///
/// * Zero differences are dropped (scipy's `zero_method="wilcox"`); `n` is the
///   number of non-zero differences left. `|d|` is ranked with average ranks
///   for ties (exact `f64` equality of the computed differences, as in scipy).
/// * If `n ≤ 50`, there are no ties among `|d|` and no zero was dropped, the
///   exact null distribution is used: the number of subsets of `{1, …, n}`
///   with rank sum `w` (counted exactly in `u64`), and
///   `p = min(1, 2·P(W ≤ min(W+, W−)))`. This is scipy's `method="exact"`
///   convention `2·min(P(W ≥ W+), P(W ≤ W+))`, clipped to 1.
/// * Otherwise the normal approximation is used, as scipy's
///   `method="asymptotic", correction=True`: `μ = n(n+1)/4`,
///   `σ² = n(n+1)(2n+1)/24 − Σ(t³ − t)/48` (tie groups `t` of the non-zero
///   `|d|`; dropped zeros do not enter), `z = (W+ − μ − 0.5·sign(W+ − μ)) / σ`
///   and `p = min(1, 2·(1 − Φ(|z|)))`.
///
/// This reproduces `scipy.stats.wilcoxon(x, y)` (`method="auto"`) except for
/// `n ≤ 13` with ties or zeros, where scipy switches to a permutation test and
/// this function uses the normal approximation.
///
/// If every difference is zero (`n = 0`) there is no evidence of a difference:
/// the result is `statistic = 0`, `p_value = 1`, `method = Exact`, `z = None`
/// (scipy returns a NaN p-value).
///
/// The p-value is symmetric: `wilcoxon(x, y)` and `wilcoxon(y, x)` give the
/// same `statistic` and `p_value` (and opposite `z`).
///
/// # Errors
/// [`StatsError::UnequalLengths`] if `x` and `y` differ in length,
/// [`StatsError::TooFewBlocks`] if they are empty, [`StatsError::NaN`] if an
/// input value or a difference (`∞ − ∞`) is NaN.
pub fn wilcoxon(x: &[f64], y: &[f64]) -> Result<Wilcoxon, StatsError> {
    if x.len() != y.len() {
        return Err(StatsError::UnequalLengths {
            what: "y".to_owned(),
            expected: x.len(),
            got: y.len(),
        });
    }
    if x.is_empty() {
        return Err(StatsError::TooFewBlocks { got: 0, min: 1 });
    }
    for (what, values) in [("x", x), ("y", y)] {
        if let Some(position) = values.iter().position(|v| v.is_nan()) {
            return Err(StatsError::NaN {
                what: what.to_owned(),
                position,
            });
        }
    }
    let mut diffs = Vec::with_capacity(x.len());
    for (position, (a, b)) in x.iter().zip(y).enumerate() {
        let d = a - b;
        if d.is_nan() {
            return Err(StatsError::NaN {
                what: "the difference x - y (infinity minus infinity)".to_owned(),
                position,
            });
        }
        if d != 0.0 {
            diffs.push(d);
        }
    }
    let zeros_dropped = diffs.len() < x.len();
    let n = diffs.len();
    if n == 0 {
        return Ok(Wilcoxon {
            statistic: 0.0,
            p_value: 1.0,
            n: 0,
            method: WilcoxonMethod::Exact,
            z: None,
        });
    }

    let abs: Vec<f64> = diffs.iter().map(|d| d.abs()).collect();
    let (ranks, tie_sum) = average_ranks(&abs);
    let (mut w_plus, mut w_minus) = (0.0, 0.0);
    for (d, r) in diffs.iter().zip(&ranks) {
        if *d > 0.0 {
            w_plus += r;
        } else {
            w_minus += r;
        }
    }
    let statistic = f64::min(w_plus, w_minus);

    if n <= EXACT_MAX_N && tie_sum == 0.0 && !zeros_dropped {
        // Without ties the ranks are 1..=n, so the statistic is an integer.
        let p_value = exact_two_sided(n, statistic as usize);
        return Ok(Wilcoxon {
            statistic,
            p_value,
            n,
            method: WilcoxonMethod::Exact,
            z: None,
        });
    }

    let nf = n as f64;
    let mean = nf * (nf + 1.0) * 0.25;
    let sd = ((nf * (nf + 1.0) * (2.0 * nf + 1.0) - tie_sum / 2.0) / 24.0).sqrt();
    let mut z = (w_plus - mean) / sd;
    // Continuity correction towards the mean (scipy: z -= sign(z) * 0.5 / se).
    z -= signum0(z) * 0.5 / sd;
    let p_value = (2.0 * Normal::standard().sf(z.abs())).min(1.0);
    Ok(Wilcoxon {
        statistic,
        p_value,
        n,
        method: WilcoxonMethod::Normal,
        z: Some(z),
    })
}

/// `sign` with `sign(0) = 0`, like `numpy.sign` (unlike `f64::signum`).
fn signum0(v: f64) -> f64 {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// `min(1, 2·P(W ≤ t))` under the null distribution of the signed-rank
/// statistic for `n ≤ 50` untied ranks.
fn exact_two_sided(n: usize, t: usize) -> f64 {
    debug_assert!(n <= EXACT_MAX_N);
    let max_sum = n * (n + 1) / 2;
    let t = t.min(max_sum);
    // counts[s] = number of subsets of {1..m} with sum s, for s ≤ t only: the
    // update for sum s only reads smaller sums, so truncating at t is exact.
    // Counts are at most 2^50, which fits u64 (and f64 exactly).
    let mut counts = vec![0u64; t + 1];
    counts[0] = 1;
    for m in 1..=n {
        for s in (m..=t).rev() {
            counts[s] += counts[s - m];
        }
    }
    let below: u64 = counts.iter().sum();
    // 2·below / 2^n, exact up to one rounding.
    let p = below as f64 * 2f64.powi(1 - n as i32);
    p.min(1.0)
}

#[cfg(test)]
mod tests {
    use super::exact_two_sided;

    /// Brute force over all 2^n sign patterns.
    fn brute(n: usize, t: usize) -> f64 {
        let mut below = 0u64;
        for mask in 0u32..(1 << n) {
            let s: usize = (0..n).filter(|i| mask & (1 << i) != 0).map(|i| i + 1).sum();
            if s <= t {
                below += 1;
            }
        }
        (2.0 * below as f64 / (1u64 << n) as f64).min(1.0)
    }

    #[test]
    fn exact_matches_brute_force() {
        for n in 1..=12 {
            for t in 0..=n * (n + 1) / 4 {
                assert_eq!(exact_two_sided(n, t), brute(n, t), "n={n} t={t}");
            }
        }
    }

    #[test]
    fn exact_extremes() {
        assert_eq!(exact_two_sided(50, 0), 2.0 / 2f64.powi(50));
        // t at (or above) the centre of the distribution: p = 1.
        assert_eq!(exact_two_sided(50, 50 * 51 / 4), 1.0);
        assert_eq!(exact_two_sided(1, 0), 1.0);
    }
}
