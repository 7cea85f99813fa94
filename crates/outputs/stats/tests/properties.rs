//! Property tests of the invariants of the tests.

use madenet_stats::{friedman, pairwise_wilcoxon, wilcoxon, WilcoxonMethod};
use proptest::prelude::*;

/// Small integers (many ties and zero differences) or arbitrary finite floats.
fn value() -> impl Strategy<Value = f64> {
    prop_oneof![(-4i32..=4).prop_map(f64::from), -1e6f64..1e6]
}

/// `(x, y)` of equal length `1..=70` (crosses the exact/normal boundary at 50).
fn paired() -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
    (1usize..=70).prop_flat_map(|n| {
        (
            prop::collection::vec(value(), n),
            prop::collection::vec(value(), n),
        )
    })
}

/// `k` groups (3..=6) of `n` blocks (1..=25).
fn groups() -> impl Strategy<Value = Vec<Vec<f64>>> {
    (3usize..=6, 1usize..=25)
        .prop_flat_map(|(k, n)| prop::collection::vec(prop::collection::vec(value(), n), k))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn wilcoxon_p_in_unit_interval_and_symmetric((x, y) in paired()) {
        let xy = wilcoxon(&x, &y).unwrap();
        let yx = wilcoxon(&y, &x).unwrap();
        prop_assert!((0.0..=1.0).contains(&xy.p_value), "p = {}", xy.p_value);
        prop_assert_eq!(xy.p_value, yx.p_value);
        prop_assert_eq!(xy.statistic, yx.statistic);
        prop_assert_eq!(xy.n, yx.n);
        prop_assert_eq!(xy.method, yx.method);
        prop_assert_eq!(xy.z.is_some(), xy.method == WilcoxonMethod::Normal);
        if let (Some(a), Some(b)) = (xy.z, yx.z) {
            prop_assert_eq!(a, -b);
        }
        let max = (xy.n * (xy.n + 1)) as f64 / 4.0;
        prop_assert!(xy.statistic >= 0.0 && xy.statistic <= max);
    }

    #[test]
    fn friedman_p_in_unit_interval_and_permutation_invariant(
        g in groups(),
        seed in any::<u64>(),
    ) {
        let refs: Vec<&[f64]> = g.iter().map(Vec::as_slice).collect();
        let r = friedman(&refs).unwrap();
        prop_assert!((0.0..=1.0).contains(&r.p_value), "p = {}", r.p_value);
        prop_assert!(r.statistic >= -1e-9, "statistic = {}", r.statistic);

        // A pseudo-random permutation of the groups (Fisher–Yates with an LCG).
        let mut perm = refs.clone();
        let mut s = seed;
        for i in (1..perm.len()).rev() {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            perm.swap(i, (s >> 33) as usize % (i + 1));
        }
        let q = friedman(&perm).unwrap();
        prop_assert!(close(r.statistic, q.statistic), "{} vs {}", r.statistic, q.statistic);
        prop_assert!(close(r.p_value, q.p_value), "{} vs {}", r.p_value, q.p_value);
        prop_assert_eq!((r.df, r.blocks, r.groups), (q.df, q.blocks, q.groups));
    }

    #[test]
    fn pairwise_corrected_p_in_unit_interval(g in groups()) {
        let refs: Vec<&[f64]> = g.iter().map(Vec::as_slice).collect();
        let names: Vec<String> = (0..g.len()).map(|i| format!("m{i}")).collect();
        let res = pairwise_wilcoxon(&names, &refs).unwrap();
        prop_assert_eq!(res.len(), g.len() * (g.len() - 1) / 2);
        for t in &res {
            prop_assert!(t.p_corrected >= t.test.p_value && t.p_corrected <= 1.0);
        }
    }
}
