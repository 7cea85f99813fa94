//! Writes sample figures with made-up but realistic data to a directory
//! (default `/tmp/plots_sample`):
//!
//! * `fig4` — four metrics × four CSPs × five methods, bars with error bars;
//! * `fig5` — explored area vs distance at CSP 100 % and 0 %;
//! * `fig2` — noisy training curves with their EWMA (α = 0.9).
//!
//! Run: `cargo run -p madenet-plots --example plots_sample [-- OUT_DIR]`

use std::path::PathBuf;

use madenet_plots::{bar_panels, ewma, line_panels, BarPanel, BarSeries, LinePanel, LineSeries};

const METHODS: [&str; 5] = ["NF", "UB", "PB", "MADE-Net-DT", "MADE-Net"];
const CSPS: [u32; 4] = [0, 50, 80, 100];

/// A tiny deterministic generator so the example needs no dependency.
struct Lcg(u64);

impl Lcg {
    /// Uniform in [0, 1).
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Roughly normal (sum of uniforms), mean 0, sd 1.
    fn normal(&mut self) -> f64 {
        (0..12).map(|_| self.next()).sum::<f64>() - 6.0
    }
}

/// One Fig. 4 panel: `best`/`worst` are the metric's values for MADE-Net
/// and NF at CSP 100 %; lower CSP degrades every method but NF.
fn metric_panel(
    title: &str,
    y_label: &str,
    best: f64,
    worst: f64,
    sd_frac: f64,
    rng: &mut Lcg,
) -> BarPanel {
    let categories = CSPS.iter().map(|c| format!("CSP {c} %")).collect();
    let series = METHODS
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let quality = 1.0 - i as f64 / (METHODS.len() - 1) as f64; // NF 1 … MADE-Net 0
            let (means, errors) = CSPS
                .iter()
                .map(|&csp| {
                    let loss = if i == 0 {
                        0.0
                    } else {
                        (1.0 - csp as f64 / 100.0) * 0.35 * (1.0 - 0.5 * (i as f64 / 4.0))
                    };
                    let base = best + (worst - best) * (quality + loss).min(1.1);
                    let m = base * (1.0 + 0.03 * rng.normal());
                    (m, m.abs() * sd_frac * (0.8 + 0.4 * rng.next()))
                })
                .unzip();
            BarSeries {
                name: name.to_string(),
                means,
                errors,
            }
        })
        .collect();
    BarPanel {
        title: title.into(),
        y_label: y_label.into(),
        categories,
        series,
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out: PathBuf = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "/tmp/plots_sample".into())
        .into();
    let mut rng = Lcg(2023);

    // Fig. 4: lower TNS / TTD / NOLI is better, higher OFV is better.
    let fig4 = [
        metric_panel("Total number of steps", "TNS", 48.0, 105.0, 0.12, &mut rng),
        metric_panel(
            "Total travelled distance",
            "TTD (m)",
            160.0,
            380.0,
            0.1,
            &mut rng,
        ),
        metric_panel(
            "Number of local interactions",
            "NOLI",
            8.0,
            55.0,
            0.2,
            &mut rng,
        ),
        metric_panel(
            "Overall field of view",
            "OFV (%)",
            82.0,
            58.0,
            0.05,
            &mut rng,
        ),
    ];
    for p in bar_panels(&out.join("fig4"), &fig4, 2)? {
        println!("{}", p.display());
    }

    // Fig. 5: explored % vs distance; methods saturate at different rates
    // and stop at different distances.
    let fig5: Vec<LinePanel> = [(100, 1.0), (0, 1.35)]
        .iter()
        .map(|&(csp, slow)| LinePanel {
            title: format!("CSP {csp} %"),
            x_label: "Distance travelled (m)".into(),
            y_label: "Explored area (%)".into(),
            series: METHODS
                .iter()
                .enumerate()
                .map(|(i, name)| {
                    let scale = (150.0 - 18.0 * i as f64) * if i == 0 { 1.0 } else { slow };
                    let end = (400.0 - 25.0 * i as f64).min(400.0);
                    let points = (0..=80)
                        .map(|k| {
                            let d = end * k as f64 / 80.0;
                            (d, 98.0 * (1.0 - (-d / scale).exp()))
                        })
                        .collect();
                    LineSeries {
                        name: name.to_string(),
                        points,
                    }
                })
                .collect(),
        })
        .collect();
    for p in line_panels(&out.join("fig5"), &fig5, 2)? {
        println!("{}", p.display());
    }

    // Fig. 2: noisy training curves and their EWMA.
    let episodes = 3000;
    let reward: Vec<f64> = (0..episodes)
        .map(|e| -60.0 + 75.0 * (1.0 - (-(e as f64) / 700.0).exp()) + 12.0 * rng.normal())
        .collect();
    let steps: Vec<f64> = (0..episodes)
        .map(|e| {
            (40.0 + 160.0 * (-(e as f64) / 900.0).exp() + 15.0 * rng.normal()).clamp(20.0, 200.0)
        })
        .collect();
    let curve = |name: &str, v: &[f64]| LineSeries {
        name: name.into(),
        points: v.iter().enumerate().map(|(e, &y)| (e as f64, y)).collect(),
    };
    // One panel per quantity: its per-episode values and their EWMA.
    let panel = |title: &str, y_label: &str, v: &[f64]| LinePanel {
        title: title.into(),
        x_label: "Episode".into(),
        y_label: y_label.into(),
        series: vec![curve("per episode", v), curve("EWMA (0.9)", &ewma(v, 0.9))],
    };
    let fig2 = [
        panel("Team reward", "Team reward", &reward),
        panel("Steps per episode", "Steps", &steps),
    ];
    for p in line_panels(&out.join("fig2"), &fig2, 2)? {
        println!("{}", p.display());
    }
    Ok(())
}
