//! Output files, input validation and the EWMA of madenet-plots.

use std::path::{Path, PathBuf};

use madenet_testkit::{entries as files_in, fresh_dir};

use madenet_plots::{
    bar_panels, ewma, line_panels, styled_line_panels, BarPanel, BarSeries, LinePanel, LineSeries,
    LineStyle, PlotError,
};

/// A fresh, empty directory for one test.
fn dir(name: &str) -> PathBuf {
    fresh_dir(format!(
        "{}/madenet-plots-tests/{name}",
        env!("CARGO_TARGET_TMPDIR")
    ))
}

const METHODS: [&str; 5] = ["NF", "UB", "PB", "MADE-Net-DT", "MADE-Net"];

fn bar_panel(title: &str) -> BarPanel {
    BarPanel {
        title: title.into(),
        y_label: format!("{title} value"),
        categories: ["CSP 0 %", "CSP 50 %", "CSP 80 %", "CSP 100 %"]
            .iter()
            .map(|s| s.to_string())
            .collect(),
        series: METHODS
            .iter()
            .enumerate()
            .map(|(i, m)| BarSeries {
                name: m.to_string(),
                means: vec![50.0 + i as f64, 60.0, 70.0, 80.0 - i as f64],
                errors: vec![5.0, 4.0, 3.0, 2.0],
            })
            .collect(),
    }
}

fn line_panel(title: &str) -> LinePanel {
    LinePanel {
        title: title.into(),
        x_label: "Distance travelled (m)".into(),
        y_label: "Explored area (%)".into(),
        series: METHODS
            .iter()
            .enumerate()
            .map(|(i, m)| LineSeries {
                name: m.to_string(),
                points: (0..=40)
                    .map(|k| {
                        let d = k as f64 * 10.0;
                        (d, 100.0 * (1.0 - (-d / (100.0 + 20.0 * i as f64)).exp()))
                    })
                    .collect(),
            })
            .collect(),
    }
}

/// Noisy training-like values that drift upwards (Fig. 2 style).
fn noisy() -> Vec<f64> {
    (0..2000)
        .map(|i| ((i * 7919) % 101) as f64 - 50.0 + i as f64 / 40.0)
        .collect()
}

/// `v` against its index.
fn curve(name: &str, v: &[f64]) -> LineSeries {
    LineSeries {
        name: name.into(),
        points: v.iter().enumerate().map(|(e, &y)| (e as f64, y)).collect(),
    }
}

/// A panel with one series "a" of the given points.
fn one_line(title: &str, points: Vec<(f64, f64)>) -> LinePanel {
    LinePanel {
        title: title.into(),
        x_label: "x".into(),
        y_label: "y".into(),
        series: vec![LineSeries {
            name: "a".into(),
            points,
        }],
    }
}

/// Extreme data is either drawn or rejected as input, never a panic or another error.
fn assert_drawn_or_invalid(r: Result<Vec<PathBuf>, PlotError>) {
    assert!(
        matches!(r, Ok(_) | Err(PlotError::InvalidInput { .. })),
        "{r:?}"
    );
}

/// The PNG at `path`, checked to be 1600 px wide (two 800 px columns) and `heights` high.
fn open_two_column_png(path: &Path, heights: std::ops::RangeInclusive<u32>) -> image::RgbImage {
    let img = image::open(path).unwrap().to_rgb8();
    assert_eq!(img.width(), 1600);
    assert!(heights.contains(&img.height()), "height {}", img.height());
    img
}

/// The SVG at `path`, checked to contain each of `texts`.
fn svg_with(path: &Path, texts: &[&str]) -> String {
    let svg = std::fs::read_to_string(path).unwrap();
    for text in texts {
        assert!(svg.contains(text), "SVG lacks {text:?}");
    }
    svg
}

/// Pixels of exactly this colour in the image.
fn count_colour(img: &image::RgbImage, rgb: [u8; 3]) -> usize {
    img.pixels().filter(|p| p.0 == rgb).count()
}

#[test]
fn bar_panels_write_valid_png_and_svg() {
    let d = dir("bars");
    let panels = [
        bar_panel("TNS"),
        bar_panel("TTD"),
        bar_panel("NOLI"),
        bar_panel("OFV"),
    ];
    let paths = bar_panels(&d.join("fig4"), &panels, 2).unwrap();
    assert_eq!(paths, vec![d.join("fig4.png"), d.join("fig4.svg")]);
    // Only the two outputs: no temporary file is left behind.
    assert_eq!(files_in(&d), vec!["fig4.png", "fig4.svg"]);

    let img = open_two_column_png(&paths[0], 1000..=1120);
    // Series i gets Okabe–Ito colour i: first and fifth series are there.
    assert!(count_colour(&img, [0x00, 0x72, 0xB2]) > 1000);
    assert!(count_colour(&img, [0xCC, 0x79, 0xA7]) > 1000);
    // The legend strip holds text: dark pixels right of the first swatch.
    let dark = (0..img.width())
        .flat_map(|x| (0..50).map(move |y| (x, y)))
        .filter(|&(x, y)| img.get_pixel(x, y).0.iter().all(|&c| c < 80))
        .count();
    assert!(dark > 100, "legend has {dark} dark pixels");

    let svg = svg_with(
        &paths[1],
        &[
            "TNS",
            "TTD",
            "NOLI",
            "OFV",
            "CSP 50 %",
            "MADE-Net-DT",
            "OFV value",
        ],
    );
    assert!(svg.starts_with("<svg"));
    assert!(svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains("font-family=\"sans-serif\""));
}

#[test]
fn line_panels_write_valid_png_and_svg() {
    let d = dir("lines");
    let panels = [line_panel("CSP 100 %"), line_panel("CSP 0 %")];
    let paths = line_panels(&d.join("fig5"), &panels, 2).unwrap();
    assert_eq!(files_in(&d), vec!["fig5.png", "fig5.svg"]);
    let img = open_two_column_png(&paths[0], 500..=620);
    assert!(count_colour(&img, [0xD5, 0x5E, 0x00]) > 500);
    svg_with(
        &paths[1],
        &[
            "CSP 100 %",
            "CSP 0 %",
            "Distance travelled (m)",
            "Explored area (%)",
            "MADE-Net",
        ],
    );
}

#[test]
fn grid_grows_with_rows_and_tolerates_a_partial_last_row() {
    let d = dir("grid");
    let panels = [line_panel("a"), line_panel("b"), line_panel("c")];
    let paths = line_panels(&d.join("three"), &panels, 2).unwrap();
    open_two_column_png(&paths[0], 1000..=u32::MAX);
    // More columns than panels: the figure is as wide as the panels.
    let paths = line_panels(&d.join("one"), &panels[..1], 4).unwrap();
    assert_eq!(image::open(&paths[0]).unwrap().width(), 800);
}

#[test]
fn stem_keeps_dots_and_missing_directories_are_created() {
    let d = dir("stem");
    let stem = d.join("a").join("b").join("fig4.v2");
    let paths = bar_panels(&stem, &[bar_panel("x")], 1).unwrap();
    assert_eq!(paths[0], d.join("a/b/fig4.v2.png"));
    assert_eq!(paths[1], d.join("a/b/fig4.v2.svg"));
    assert!(paths.iter().all(|p| p.is_file()));
}

#[test]
fn overwriting_replaces_the_files() {
    let d = dir("overwrite");
    let stem = d.join("fig");
    bar_panels(&stem, &[bar_panel("first title")], 1).unwrap();
    bar_panels(&stem, &[bar_panel("second title")], 1).unwrap();
    let svg = std::fs::read_to_string(d.join("fig.svg")).unwrap();
    assert!(svg.contains("second title") && !svg.contains("first title"));
    assert_eq!(files_in(&d), vec!["fig.png", "fig.svg"]);
}

#[test]
fn unusual_but_valid_data_is_drawn() {
    let d = dir("unusual");
    // Negative bars, no error bars, zero everywhere, ten series (colours cycle).
    let mut neg = bar_panel("negative");
    for s in &mut neg.series {
        s.means = vec![-10.0, 5.0, -3.0, 0.0];
        s.errors.clear();
    }
    let mut zero = bar_panel("zero");
    for s in &mut zero.series {
        s.means = vec![0.0; 4];
        s.errors = vec![0.0; 4];
    }
    bar_panels(&d.join("neg"), &[neg, zero], 2).unwrap();
    let mut many = bar_panel("many");
    many.series = (0..10)
        .map(|i| BarSeries {
            name: format!("s{i}"),
            means: vec![1.0 + i as f64; 4],
            errors: vec![],
        })
        .collect();
    bar_panels(&d.join("many"), &[many], 1).unwrap();

    // A single point, a constant line, a panel with fewer series, long names.
    let single = LinePanel {
        title: "single point".into(),
        x_label: "x".into(),
        y_label: "y".into(),
        series: vec![LineSeries {
            name: "a very long series name that needs room in the legend".into(),
            points: vec![(3.0, 3.0)],
        }],
    };
    let constant = LinePanel {
        title: "constant".into(),
        x_label: "x".into(),
        y_label: "y".into(),
        series: vec![
            LineSeries {
                name: "a very long series name that needs room in the legend".into(),
                points: vec![(0.0, 0.0), (1.0, 0.0)],
            },
            LineSeries {
                name: "another long series name to force a second legend row".into(),
                points: vec![(0.0, 0.0), (0.0, 0.0)],
            },
        ],
    };
    line_panels(&d.join("degenerate"), &[single, constant], 2).unwrap();

    // Noisy data with its EWMA (Fig. 2 style).
    let noisy = noisy();
    let panel = LinePanel {
        title: "Team reward".into(),
        x_label: "Episode".into(),
        y_label: "Reward".into(),
        series: vec![curve("raw", &noisy), curve("EWMA", &ewma(&noisy, 0.9))],
    };
    line_panels(&d.join("fig2"), &[panel], 1).unwrap();

    // Everything was drawn: every panel title and every legend name is in its SVG, and the
    // PNGs are real images.
    let svg = |stem: &str| std::fs::read_to_string(d.join(format!("{stem}.svg"))).unwrap();
    for (stem, texts) in [
        ("neg", vec!["negative".to_string(), "zero".into()]),
        ("many", (0..10).map(|i| format!(">\ns{i}\n<")).collect()),
        (
            "degenerate",
            vec![
                "single point".into(),
                "constant".into(),
                "another long series name".into(),
            ],
        ),
        ("fig2", vec!["Team reward".into(), ">\nEWMA\n<".into()]),
    ] {
        let text = svg(stem);
        for t in texts {
            assert!(text.contains(&t), "{stem}.svg lacks {t:?}");
        }
        let png = image::open(d.join(format!("{stem}.png"))).unwrap();
        assert!(png.width() >= 400 && png.height() >= 300, "{stem}.png");
    }
}

#[test]
fn styled_line_panels_write_one_file_and_match_series_by_name() {
    let d = dir("styled");
    let noisy = noisy();
    let panel = |title: &str, series: Vec<LineSeries>| LinePanel {
        title: title.into(),
        x_label: "Episode".into(),
        y_label: "y".into(),
        series,
    };
    // Panels with different series; raw values and their EWMA in one colour.
    let panels = [
        panel(
            "Team reward",
            vec![curve("raw", &noisy), curve("EWMA", &ewma(&noisy, 0.9))],
        ),
        panel("Validation", vec![curve("validation", &[30.0, 25.0, 20.0])]),
    ];
    let style = |name: &str, colour: usize, faint: bool| LineStyle {
        name: name.into(),
        colour,
        faint,
    };
    let styles = [
        style("EWMA", 0, false),
        style("raw", 0, true),
        style("validation", 2, false),
    ];
    let png = d.join("fig2.png");
    assert_eq!(styled_line_panels(&png, &panels, 2, &styles).unwrap(), png);
    assert_eq!(files_in(&d), vec!["fig2.png"]);
    let img = open_two_column_png(&png, 0..=u32::MAX);
    assert!(count_colour(&img, [0x00, 0x72, 0xB2]) > 500, "no blue EWMA");
    assert!(
        count_colour(&img, [0x00, 0x9E, 0x73]) > 200,
        "no green validation"
    );
    assert_eq!(
        count_colour(&img, [0xD5, 0x5E, 0x00]),
        0,
        "vermillion unused"
    );

    let svg = d.join("fig2.SVG");
    styled_line_panels(&svg, &panels, 2, &styles).unwrap();
    assert_eq!(files_in(&d), vec!["fig2.SVG", "fig2.png"]);
    let text = svg_with(
        &svg,
        &["Team reward", "Validation", "EWMA", "raw", "validation"],
    );
    assert!(text.starts_with("<svg"));

    let err = |path: &Path, styles: &[LineStyle], needle: &str| {
        assert_invalid_at(styled_line_panels(path, &panels, 2, styles), path, needle);
    };
    err(&d.join("fig2.jpg"), &styles, ".png or .svg");
    err(&d.join("fig2"), &styles, ".png or .svg");
    err(
        &d.join("bad.png"),
        &styles[..2],
        "\"validation\" has no line style",
    );
    err(&d.join("bad.png"), &[], "no line styles");
    let twice = [
        styles[0].clone(),
        styles[1].clone(),
        styles[2].clone(),
        styles[0].clone(),
    ];
    err(&d.join("bad.png"), &twice, "two line styles");
    assert_eq!(files_in(&d), vec!["fig2.SVG", "fig2.png"]);
}

/// Asserts `r` is an input error naming `path`, mentioning `needle`, and that `path` was not
/// written.
fn assert_invalid_at<T: std::fmt::Debug>(r: Result<T, PlotError>, path: &Path, needle: &str) {
    match r {
        Err(e @ PlotError::InvalidInput { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains(&path.display().to_string()), "{msg}");
            assert!(msg.contains(needle), "{msg:?} lacks {needle:?}");
        }
        other => panic!("expected InvalidInput, got {other:?}"),
    }
    assert!(!path.exists());
}

/// Asserts `r` is an input error naming `png` and that nothing was written.
fn assert_invalid(r: Result<Vec<PathBuf>, PlotError>, png: &Path, needle: &str) {
    assert_invalid_at(r, png, needle);
    assert!(!png.with_extension("svg").exists());
}

/// [`bar_panels`] or [`line_panels`].
type Draw<P> = fn(&Path, &[P], usize) -> Result<Vec<PathBuf>, PlotError>;

/// A way to spoil a valid panel, and what the error then says.
type Spoil<P> = (fn(&mut P), &'static str);

/// Checks the input errors common to bars and lines (no panels, no columns, series names
/// out of order across panels), then each `spoils` case on its own, all against the stem
/// `bad` in a fresh directory `name`; nothing may be written.
fn check_bad_input<P>(
    name: &str,
    draw: Draw<P>,
    make: fn(&str) -> P,
    reorder: fn(&mut P),
    spoils: &[Spoil<P>],
) {
    let d = dir(name);
    let stem = d.join("bad");
    let png = d.join("bad.png");
    assert_invalid(draw(&stem, &[], 2), &png, "no panels");
    assert_invalid(draw(&stem, &[make("a")], 0), &png, "cols");
    for (spoil, needle) in spoils {
        let mut p = make("a");
        spoil(&mut p);
        assert_invalid(draw(&stem, &[p], 1), &png, needle);
    }
    // Series order must agree across panels (shared legend).
    let mut b = make("b");
    reorder(&mut b);
    assert_invalid(draw(&stem, &[make("a"), b], 2), &png, "same order");
    assert!(files_in(&d).is_empty());
}

#[test]
fn bad_bar_input_is_an_error() {
    check_bad_input(
        "bad-bars",
        bar_panels,
        bar_panel,
        |b| b.series.swap(0, 1),
        &[
            (|p| p.categories.clear(), "no categories"),
            (|p| p.series.clear(), "no series"),
            (
                |p| {
                    p.series[2].means.pop();
                },
                "3 means for 4 categories",
            ),
            (|p| p.series[1].errors.push(1.0), "5 errors for 4 means"),
            (|p| p.series[0].means[1] = f64::NAN, "non-finite mean"),
            (|p| p.series[0].means[1] = f64::INFINITY, "non-finite mean"),
            (|p| p.series[3].errors[0] = -1.0, "negative or not finite"),
            (
                |p| p.series[3].errors[0] = f64::NAN,
                "negative or not finite",
            ),
        ],
    );
}

#[test]
fn bad_line_input_is_an_error() {
    check_bad_input(
        "bad-lines",
        line_panels,
        line_panel,
        |b| b.series[4].name = "other".into(),
        &[
            (|p| p.series.clear(), "no series"),
            (|p| p.series[4].points.clear(), "no points"),
            (|p| p.series[2].points[7].1 = f64::NAN, "non-finite point"),
            (
                |p| p.series[2].points[0].0 = f64::NEG_INFINITY,
                "non-finite point",
            ),
        ],
    );
}

#[test]
fn unwritable_target_is_an_io_error_naming_the_path() {
    let d = dir("unwritable");
    let file = d.join("not-a-dir");
    std::fs::write(&file, b"x").unwrap();
    let err = bar_panels(&file.join("fig"), &[bar_panel("a")], 1).unwrap_err();
    assert!(matches!(err, PlotError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains("not-a-dir"), "{err}");
}

#[test]
fn ewma_matches_hand_computed_values() {
    assert!(ewma(&[], 0.9).is_empty());
    assert_eq!(ewma(&[4.0], 0.9), vec![4.0]);
    // s0 = 10, s1 = 0.9·10 + 0.1·0 = 9, s2 = 0.9·9 = 8.1, s3 = 0.9·8.1 + 0.1·20 = 9.29
    let s = ewma(&[10.0, 0.0, 0.0, 20.0], 0.9);
    let want = [10.0, 9.0, 8.1, 9.29];
    assert_eq!(s.len(), want.len());
    for (a, b) in s.iter().zip(want) {
        assert!((a - b).abs() < 1e-12, "{s:?}");
    }
    // alpha 0.5: 1, 1.5, 2.25
    assert_eq!(ewma(&[1.0, 2.0, 3.0], 0.5), vec![1.0, 1.5, 2.25]);
    // alpha 0 is the identity, alpha 1 holds the first value.
    assert_eq!(ewma(&[1.0, 5.0, -2.0], 0.0), vec![1.0, 5.0, -2.0]);
    assert_eq!(ewma(&[1.0, 5.0, -2.0], 1.0), vec![1.0, 1.0, 1.0]);
    // A constant stays constant.
    assert!(ewma(&[3.0; 50], 0.9)
        .iter()
        .all(|&v| (v - 3.0).abs() < 1e-12));
}

#[test]
fn extreme_values_do_not_panic() {
    let d = dir("extreme");
    let mut p = bar_panel("huge");
    p.series[0].means = vec![1e308, -1e308, 1e-300, 0.0];
    p.series[0].errors = vec![1e308, 0.0, 0.0, 0.0];
    assert_drawn_or_invalid(bar_panels(&d.join("huge-bars"), &[p], 1));
}

#[test]
fn extreme_lines_do_not_panic() {
    let d = dir("extreme-lines");
    let panel = one_line("huge", vec![(-1e308, -1e308), (1e308, 1e308)]);
    assert_drawn_or_invalid(line_panels(&d.join("huge-lines"), &[panel], 1));
}

#[test]
fn extreme_tiny_do_not_panic() {
    let d = dir("extreme-tiny");
    let tiny = one_line("tiny", vec![(0.0, 1e-300), (1e-300, 2e-300)]);
    assert_drawn_or_invalid(line_panels(&d.join("tiny-lines"), &[tiny], 1));
}

#[test]
fn too_many_panels_is_an_error_not_a_huge_image() {
    let d = dir("too-many");
    let panels: Vec<LinePanel> = (0..200).map(|i| line_panel(&format!("p{i}"))).collect();
    let r = line_panels(&d.join("big"), &panels, 1);
    assert!(matches!(r, Err(PlotError::InvalidInput { .. })), "{r:?}");
}

/// Whole-number x data (e.g. team sizes 2–6) is labelled at whole numbers only; fractional x
/// data keeps fractional ticks where plotters puts them.
#[test]
fn whole_number_x_gets_whole_number_ticks() {
    let d = dir("whole-x");
    let panel = |xs: &[f64]| LinePanel {
        title: "teams".into(),
        x_label: "Robots".into(),
        y_label: "TNS".into(),
        series: vec![LineSeries {
            name: "nf".into(),
            points: xs.iter().map(|&x| (x, 100.0 / x)).collect(),
        }],
    };
    // The x tick labels of the SVG: text elements holding a number.
    let ticks = |stem: &str, xs: &[f64]| -> Vec<String> {
        line_panels(&d.join(stem), &[panel(xs)], 1).unwrap();
        let svg = std::fs::read_to_string(d.join(format!("{stem}.svg"))).unwrap();
        svg.split('>')
            .filter_map(|t| t.split('<').next())
            .map(str::trim)
            .filter(|t| !t.is_empty() && t.parse::<f64>().is_ok())
            .map(String::from)
            .collect()
    };
    let whole = ticks("whole", &[2.0, 3.0, 4.0, 5.0, 6.0]);
    for x in ["2", "3", "4", "5", "6"] {
        assert!(whole.iter().any(|t| t == x), "{x} missing: {whole:?}");
    }
    assert!(!whole.iter().any(|t| t == "2.5" || t == "3.5"), "{whole:?}");
    let halves = ticks("halves", &[2.0, 2.5, 3.0, 3.5, 4.0]);
    assert!(halves.iter().any(|t| t == "2.5"), "{halves:?}");
}
