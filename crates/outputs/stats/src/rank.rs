//! Average ranks with ties, as `scipy.stats.rankdata(method="average")`.

/// Average ranks (1-based) of `values` and the sum of `t³ − t` over the tie
/// groups (`t` = size of a group of equal values).
///
/// Ties are exact `f64` equality (so `-0.0 == 0.0`), as in scipy. The caller
/// guarantees that `values` contains no NaN.
pub(crate) fn average_ranks(values: &[f64]) -> (Vec<f64>, f64) {
    let n = values.len();
    let mut order: Vec<usize> = (0..n).collect();
    // `total_cmp` orders -0.0 before 0.0, but nothing lies between them, so equal
    // values stay adjacent and the `==` grouping below still merges them.
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let mut ranks = vec![0.0; n];
    let mut tie_sum = 0.0;
    let mut start = 0;
    while start < n {
        let mut end = start + 1;
        while end < n && values[order[end]] == values[order[start]] {
            end += 1;
        }
        // Positions start..end (0-based) hold ranks start+1..=end; their mean:
        let rank = (start + 1 + end) as f64 / 2.0;
        for &i in &order[start..end] {
            ranks[i] = rank;
        }
        let t = (end - start) as f64;
        tie_sum += t * t * t - t;
        start = end;
    }
    (ranks, tie_sum)
}

#[cfg(test)]
mod tests {
    use super::average_ranks;

    #[test]
    fn ranks_without_ties() {
        let (r, t) = average_ranks(&[3.0, 1.0, 2.0]);
        assert_eq!(r, vec![3.0, 1.0, 2.0]);
        assert_eq!(t, 0.0);
    }

    #[test]
    fn ranks_with_ties() {
        // scipy.stats.rankdata([2, 1, 2, 2, 5, 1]) == [4, 1.5, 4, 4, 6, 1.5]
        let (r, t) = average_ranks(&[2.0, 1.0, 2.0, 2.0, 5.0, 1.0]);
        assert_eq!(r, vec![4.0, 1.5, 4.0, 4.0, 6.0, 1.5]);
        assert_eq!(t, (27.0 - 3.0) + (8.0 - 2.0));
    }

    #[test]
    fn signed_zeros_tie() {
        let (r, t) = average_ranks(&[0.0, 1.0, -0.0]);
        assert_eq!(r, vec![1.5, 3.0, 1.5]);
        assert_eq!(t, 6.0);
    }

    #[test]
    fn empty() {
        let (r, t) = average_ranks(&[]);
        assert!(r.is_empty());
        assert_eq!(t, 0.0);
    }
}
