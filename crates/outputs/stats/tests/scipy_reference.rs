//! Reference values computed once with scipy 1.17.1 (numpy 2.4.6, Python 3.11).
//!
//! Wilcoxon cases were produced with
//! `scipy.stats.wilcoxon(x, y, zero_method="wilcox", correction=True, method=M)`
//! where `M` is `"exact"` for the exact cases and `"asymptotic"` (the name of
//! the old `"approx"` since scipy 1.9) for the normal-approximation cases, as
//! noted per test; scipy's `zstatistic` is `-|z|`.
//! Friedman cases were produced with `scipy.stats.friedmanchisquare(*groups)`.
//! Values were printed with `repr` (17 significant digits) and pasted here.

use madenet_stats::{friedman, wilcoxon, Wilcoxon, WilcoxonMethod};

/// Relative agreement. Statistics, exact p-values and the χ² p-values agree to
/// ~1e-14; normal-approximation p-values to ~5e-11 (statrs' `erfc` versus
/// scipy's `ndtr`).
const REL: f64 = 1e-9;

#[track_caller]
fn assert_close(actual: f64, expected: f64, rel: f64) {
    let tol = rel * expected.abs().max(f64::MIN_POSITIVE);
    assert!(
        (actual - expected).abs() <= tol,
        "actual {actual:e}, expected {expected:e} (relative tolerance {rel:e})"
    );
}

#[track_caller]
fn check_exact(x: &[f64], y: &[f64], n: usize, statistic: f64, p: f64) -> Wilcoxon {
    let r = wilcoxon(x, y).unwrap();
    assert_eq!(r.method, WilcoxonMethod::Exact);
    assert_eq!(r.n, n);
    assert_eq!(r.statistic, statistic);
    assert_eq!(r.z, None);
    assert_close(r.p_value, p, REL);
    r
}

#[track_caller]
fn check_normal(x: &[f64], y: &[f64], n: usize, statistic: f64, p: f64, z_scipy: f64) -> Wilcoxon {
    let r = wilcoxon(x, y).unwrap();
    assert_eq!(r.method, WilcoxonMethod::Normal);
    assert_eq!(r.n, n);
    assert_eq!(r.statistic, statistic);
    assert_close(r.p_value, p, REL);
    let z = r.z.expect("normal approximation reports z");
    assert_close(-z.abs(), z_scipy, REL);
    r
}

fn zeros(n: usize) -> Vec<f64> {
    vec![0.0; n]
}

fn f(v: &[i64]) -> Vec<f64> {
    v.iter().map(|&a| a as f64).collect()
}

// ---------------------------------------------------------------- Wilcoxon, exact
// scipy.stats.wilcoxon(x, y, zero_method="wilcox", correction=True, method="exact")

#[test]
#[allow(clippy::approx_constant)] // 3.14 is a measurement, not π
fn wilcoxon_exact_n9() {
    let x = [1.83, 0.50, 1.62, 2.48, 1.68, 1.88, 1.55, 3.06, 1.30];
    let y = [0.878, 0.647, 0.598, 2.05, 1.06, 1.29, 1.06, 3.14, 1.29];
    check_exact(&x, &y, 9, 5.0, 0.0390625);
}

#[test]
fn wilcoxon_exact_darwin_n15() {
    let d = f(&[6, 8, 14, 16, 23, 24, 28, 29, 41, -48, 49, 56, 60, -67, 75]);
    check_exact(&d, &zeros(15), 15, 24.0, 0.041259765625);
}

#[test]
fn wilcoxon_exact_n20_all_positive() {
    let d: Vec<f64> = (1..=20).map(f64::from).collect();
    check_exact(&d, &zeros(20), 20, 0.0, 1.9073486328125e-06);
}

#[test]
fn wilcoxon_exact_n1() {
    check_exact(&[3.0], &[0.0], 1, 0.0, 1.0);
}

const D50: [i64; 50] = [
    17, 23, -46, 7, 36, 20, 26, -49, 10, 39, 29, -13, 42, 3, -32, 16, -45, -6, -35, 19, 48, 9, 38,
    -22, 12, -41, 25, 15, -44, 28, 18, 47, 2, 31, 21, 50, -5, 34, 24, -8, 37, 27, 11, 40, 1, 30,
    -14, 43, 4, -33,
];

#[test]
fn wilcoxon_exact_n50() {
    check_exact(&f(&D50), &zeros(50), 50, 393.0, 0.017575449774248852);
}

// ------------------------------------------------------- Wilcoxon, normal approx.
// scipy.stats.wilcoxon(x, y, zero_method="wilcox", correction=True, method="asymptotic")

#[test]
fn wilcoxon_normal_n51_no_ties() {
    // n > 50 without ties: D50 followed by 51.
    let mut d = f(&D50);
    d.push(51.0);
    check_normal(
        &d,
        &zeros(51),
        51,
        393.0,
        0.011532045456992391,
        -2.5261493208883516,
    );
}

#[test]
fn wilcoxon_normal_n60_no_ties() {
    let d = [
        7.5, 3.75, 4.25, -14.75, 0.5, 11.0, 11.5, -7.75, -4.0, 4.5, -15.0, 0.75, 11.25, 11.75, 8.0,
        4.75, 1.0, 12.0, 8.25, 5.0, 1.25, -12.25, 8.5, 5.25, 1.5, -12.5, -8.75, 5.5, -1.75, -12.75,
        -9.0, 5.75, 2.0, 13.0, 9.25, 6.0, 2.25, -13.25, 9.5, 6.25, 2.5, -13.5, 9.75, -6.5, 2.75,
        13.75, 10.0, 6.75, 3.0, -14.0, 10.25, 7.0, 3.25, 14.25, 10.5, -7.25, 3.5, 14.5, 0.25,
        10.75,
    ];
    check_normal(
        &d,
        &zeros(60),
        60,
        612.0,
        0.0259549667397667,
        -2.226884907992019,
    );
}

#[test]
fn wilcoxon_normal_n20_ties() {
    let x = f(&[1, 9, 8, 6, 5, 4, 6, 2, 9, 2, 8, 0, 2, 3, 4, 0, 8, 8, 4, 0]);
    let y = f(&[7, 0, 7, 8, 4, 8, 3, 8, 5, 7, 0, 2, 4, 8, 8, 2, 2, 6, 8, 9]);
    check_normal(&x, &y, 20, 80.0, 0.3588216927453268, -0.9176126501018079);
}

#[test]
fn wilcoxon_normal_n12_ties() {
    let x = f(&[5, 7, 9, 3, 8, 6, 10, 4, 9, 8, 7, 12]);
    let y = f(&[3, 4, 6, 4, 5, 5, 6, 2, 7, 5, 4, 8]);
    check_normal(&x, &y, 12, 1.5, 0.003368011144941154, -2.9319867514762112);
}

#[test]
fn wilcoxon_normal_zeros_without_ties() {
    // Three zero differences are dropped; the 7 non-zero |d| are distinct, but
    // dropping zeros rules out the exact distribution. The zeros do not enter
    // the tie correction.
    let x = [1.5, 2.0, 3.25, 4.0, 0.0, -1.0, 7.5, 2.0, 9.0, 3.5];
    let y = [1.5, 0.0, 0.0, 4.0, 1.0, 2.0, 1.0, 2.0, 1.0, 1.0];
    check_normal(&x, &y, 7, 5.0, 0.15078556502797127, -1.4367622330384782);
}

#[test]
fn wilcoxon_normal_centered() {
    // W+ equals its mean: no continuity correction (sign(0) = 0) and p = 1.
    let d = f(&[1, -1, 2, -2, 2, -2, 5, -5]);
    let r = check_normal(&d, &zeros(8), 8, 18.0, 1.0, -0.0);
    assert_eq!(r.z, Some(0.0));
}

#[test]
fn wilcoxon_normal_n80_ties_zeros() {
    let x = f(&[
        10, 12, 3, 5, 3, 1, 10, 20, 11, 5, 5, 0, 7, 20, 6, 14, 1, 0, 10, 0, 17, 1, 2, 20, 17, 20,
        11, 20, 1, 18, 14, 20, 0, 11, 3, 9, 12, 6, 5, 10, 15, 20, 4, 14, 9, 7, 18, 8, 3, 17, 9, 6,
        6, 4, 7, 4, 2, 2, 19, 12, 20, 8, 5, 8, 2, 0, 20, 12, 17, 6, 3, 0, 6, 15, 13, 17, 2, 2, 8,
        3,
    ]);
    let y = f(&[
        5, 1, 10, 2, 13, 8, 16, 5, 11, 7, 10, 7, 4, 15, 8, 10, 12, 6, 0, 10, 16, 14, 7, 16, 17, 4,
        11, 1, 8, 15, 4, 4, 0, 1, 15, 4, 18, 0, 11, 2, 14, 16, 12, 7, 18, 17, 10, 3, 15, 16, 1, 15,
        17, 2, 16, 7, 14, 10, 14, 9, 7, 1, 6, 0, 6, 5, 4, 5, 16, 7, 18, 4, 7, 1, 11, 3, 13, 7, 17,
        9,
    ]);
    check_normal(&x, &y, 76, 1424.5, 0.8439235439573497, -0.196877317921264);
}

#[test]
fn wilcoxon_all_differences_zero() {
    // scipy (method="asymptotic") gives statistic 0.0, p = nan; documented
    // deviation: p = 1, no evidence of a difference.
    let x = [1.0, 2.0, 3.0];
    let r = wilcoxon(&x, &x).unwrap();
    assert_eq!(
        r,
        Wilcoxon {
            statistic: 0.0,
            p_value: 1.0,
            n: 0,
            method: WilcoxonMethod::Exact,
            z: None
        }
    );
}

// ---------------------------------------------------------------------- Friedman
// scipy.stats.friedmanchisquare(*groups)

#[track_caller]
fn check_friedman(groups: &[&[f64]], statistic: f64, p: f64) {
    let r = friedman(groups).unwrap();
    assert_eq!(r.groups, groups.len());
    assert_eq!(r.blocks, groups[0].len());
    assert_eq!(r.df, groups.len() - 1);
    assert_close(r.statistic, statistic, REL);
    assert_close(r.p_value, p, REL);
}

#[test]
fn friedman_k3_n10_no_ties() {
    let g0 = f(&[877, 454, 329, 790, 597, 682, 513, 994, 684, 455]);
    let g1 = f(&[701, 200, 261, 797, 8, 53, 489, 270, 767, 402]);
    let g2 = f(&[214, 256, 194, 803, 110, 425, 776, 858, 851, 348]);
    check_friedman(&[&g0, &g1, &g2], 5.0, 0.0820849986238988);
}

#[test]
fn friedman_k3_n15_ties() {
    let g0 = f(&[1, 1, 3, 1, 2, 2, 2, 1, 3, 0, 1, 2, 3, 0, 2]);
    let g1 = f(&[0, 2, 3, 3, 0, 2, 0, 0, 0, 3, 1, 2, 1, 3, 0]);
    let g2 = f(&[2, 3, 2, 1, 1, 2, 3, 0, 0, 2, 1, 2, 3, 2, 2]);
    check_friedman(&[&g0, &g1, &g2], 0.904761904761894, 0.6361117952585009);
}

#[test]
fn friedman_k5_n12_no_ties() {
    let g0 = f(&[273, 248, 49, 384, 553, 731, 297, 422, 342, 898, 930, 734]);
    let g1 = f(&[137, 344, 1023, 431, 695, 142, 314, 48, 465, 193, 318, 176]);
    let g2 = f(&[691, 130, 995, 478, 147, 554, 640, 366, 278, 179, 707, 618]);
    let g3 = f(&[555, 226, 968, 524, 289, 966, 966, 683, 402, 166, 1096, 750]);
    let g4 = f(&[
        418, 1013, 940, 571, 741, 377, 983, 1001, 525, 1153, 484, 191,
    ]);
    check_friedman(
        &[&g0, &g1, &g2, &g3, &g4],
        7.533333333333331,
        0.11024838447297257,
    );
}

#[test]
fn friedman_k5_n20_ties() {
    let g0 = f(&[3, 1, 0, 2, 2, 1, 4, 2, 1, 4, 0, 2, 3, 0, 1, 1, 4, 4, 4, 0]);
    let g1 = f(&[4, 0, 4, 0, 1, 1, 0, 2, 1, 4, 0, 2, 3, 2, 3, 2, 1, 2, 0, 1]);
    let g2 = f(&[1, 1, 4, 4, 0, 0, 1, 0, 0, 1, 0, 2, 0, 2, 0, 4, 1, 4, 2, 3]);
    let g3 = f(&[0, 0, 3, 3, 2, 4, 0, 2, 1, 4, 0, 0, 2, 1, 4, 4, 0, 0, 0, 3]);
    let g4 = f(&[1, 4, 3, 0, 1, 3, 1, 3, 0, 1, 2, 0, 4, 1, 1, 1, 0, 3, 1, 4]);
    check_friedman(
        &[&g0, &g1, &g2, &g3, &g4],
        0.951289398280784,
        0.9170899493160309,
    );
}

#[test]
fn friedman_k4_n30_strong_effect() {
    // As in the paper: a strong effect, p far below 1e-4.
    let g0 = f(&[
        670, 353, 771, 669, 200, 780, 82, 851, 0, 649, 853, 544, 792, 858, 467, 994, 425, 550, 158,
        259, 380, 165, 906, 56, 830, 164, 426, 785, 622, 50,
    ]);
    let g1 = f(&[
        793, 399, 1004, 976, 912, 451, 668, 737, 1074, 895, 501, 1246, 935, 1180, 340, 388, 1136,
        995, 841, 984, 620, 976, 865, 1267, 389, 828, 1000, 327, 427, 405,
    ]);
    let g2 = f(&[
        607, 755, 1236, 1283, 1314, 1123, 944, 1315, 1457, 1452, 840, 947, 1078, 810, 1214, 1475,
        1155, 749, 1524, 707, 1170, 1095, 823, 1167, 949, 800, 884, 1179, 1233, 1451,
    ]);
    let g3 = f(&[
        1732, 1802, 1468, 1590, 1026, 1795, 1531, 1892, 1531, 1698, 1489, 1339, 1531, 1442, 1778,
        1870, 1866, 1194, 1898, 1432, 1720, 1215, 1092, 1377, 1509, 1773, 1458, 1722, 1038, 1805,
    ]);
    check_friedman(
        &[&g0, &g1, &g2, &g3],
        62.27999999999997,
        1.9142417229428436e-13,
    );
}

#[test]
fn friedman_all_tied() {
    // scipy gives statistic = p = nan (0/0); documented deviation: 0 and 1.
    let g = [1.0, 2.0];
    let r = friedman(&[&g, &g, &g]).unwrap();
    assert_eq!(
        (r.statistic, r.p_value, r.df, r.blocks, r.groups),
        (0.0, 1.0, 2, 2, 3)
    );
}
