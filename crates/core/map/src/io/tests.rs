//! Tests of map IO across formats, mostly through the public entry points.

use super::pgm::decode_pgm;
use super::raster::classify_pixel;
use super::yaml::{parse_map_yaml, MapMeta};
use super::*;
use crate::Pos;
use madenet_testkit::Scratch;
use proptest::prelude::*;
use std::fs;
use std::path::PathBuf;

fn grid_strategy(max: usize) -> impl Strategy<Value = OccGrid> {
    (1..=max, 1..=max).prop_flat_map(|(h, w)| {
        proptest::collection::vec(
            prop_oneof![
                Just(Occupancy::Free),
                Just(Occupancy::Obstacle),
                Just(Occupancy::Unknown)
            ],
            h * w,
        )
        .prop_map(move |cells| OccGrid::from_cells(h, w, cells))
    })
}

const YAML_OK: &str = "image: m.pgm\nresolution: 1.0\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    fs::write(&p, bytes).expect("write test file");
    p
}

fn assert_names(err: &MapError, needle: &str) {
    let msg = err.to_string();
    assert!(
        msg.contains(needle),
        "error {msg:?} should mention {needle:?}"
    );
}

/// Writes [`YAML_OK`] with `from` replaced by `to` to `dir/name`.
fn write_yaml(dir: &Path, name: &str, from: &str, to: &str) -> PathBuf {
    write(dir, name, YAML_OK.replace(from, to).as_bytes())
}

/// Writes `bytes` to `dir/name` and loads it with the default options: the error, checked to
/// be a format error naming the file.
fn format_error(dir: &Path, name: &str, bytes: &[u8]) -> MapError {
    let e = load(&write(dir, name, bytes), &LoadOptions::default()).unwrap_err();
    assert!(matches!(e, MapError::Format { .. }), "{e}");
    assert_names(&e, name);
    e
}

/// Loads `path` with the default options but `cell_size`.
fn load_with_cells(path: &Path, cell_size: f64) -> Result<OccGrid, MapError> {
    load(
        path,
        &LoadOptions {
            cell_size,
            ..LoadOptions::default()
        },
    )
}

/// A scratch directory holding [`small_pgm`] as `m.pgm`, the image [`YAML_OK`] names.
fn scratch_with_pgm(name: &str) -> Scratch {
    let dir = Scratch::new(name);
    write(&dir, "m.pgm", &small_pgm());
    dir
}

fn small_pgm() -> Vec<u8> {
    b"P5\n3 2\n255\n\x00\xfe\xcd\xfe\xfe\x00".to_vec()
}

#[test]
fn save_thresholds_round_trip_the_three_pixel_values() {
    let meta = MapMeta::bare();
    assert_eq!(classify_pixel(&meta, PIXEL_FREE, 255).1, Occupancy::Free);
    assert_eq!(
        classify_pixel(&meta, PIXEL_OBSTACLE, 255).1,
        Occupancy::Obstacle
    );
    assert_eq!(
        classify_pixel(&meta, PIXEL_UNKNOWN, 255).1,
        Occupancy::Unknown
    );
    // 205 → 50/255 = 0.19608 ≥ 0.196 (not free) but 0.25 would make it free.
    let p_unknown = f64::from(255 - PIXEL_UNKNOWN) / 255.0;
    assert!(p_unknown > SAVE_FREE_THRESH && p_unknown < 0.25);
}

#[test]
fn reads_yaml_with_pgm() {
    let dir = scratch_with_pgm("map-test-yaml-ok");
    let yaml = write_yaml(&dir, "m.yaml", "[0.0, 0.0, 0.0]", "[1.5, -2, 0.0]");
    let g = load(&yaml, &LoadOptions::default()).expect("load");
    assert_eq!((g.height(), g.width()), (2, 3));
    assert_eq!(to_text(&g), "#.?\n..#\n");
    assert_eq!(g.origin, [1.5, -2.0, 0.0]);
    assert_eq!(g.resolution, 1.0);
}

#[test]
fn negate_and_modes() {
    let dir = scratch_with_pgm("map-test-modes");
    let negated = write_yaml(&dir, "n.yaml", "negate: 0", "negate: 1");
    let g = load(&negated, &LoadOptions::default()).expect("negated");
    // 0 → p 0 free; 254 → p 0.996 obstacle; 205 → p 0.80 obstacle.
    assert_eq!(to_text(&g), ".##\n##.\n");
    let scale = write(&dir, "s.yaml", format!("{YAML_OK}mode: scale\n").as_bytes());
    assert_eq!(
        to_text(&load(&scale, &LoadOptions::default()).expect("scale")),
        "#.?\n..#\n"
    );
    // Raw: values 0..=100 are percentages; 205 and 254 are unknown.
    write(&dir, "r.pgm", b"P5\n4 1\n255\n\x00\x32\x64\xfe");
    let raw = write(
        &dir,
        "r.yaml",
        format!("{}mode: raw\n", YAML_OK.replace("m.pgm", "r.pgm")).as_bytes(),
    );
    assert_eq!(
        to_text(&load(&raw, &LoadOptions::default()).expect("raw")),
        ".?#?\n"
    );
    let bad = write(&dir, "b.yaml", format!("{YAML_OK}mode: fancy\n").as_bytes());
    let e = load(&bad, &LoadOptions::default()).unwrap_err();
    assert!(
        matches!(e, MapError::Field { ref field, .. } if field == "mode"),
        "{e}"
    );
}

#[test]
fn ascii_pgm_and_maxval_scaling() {
    let dir = Scratch::new("map-test-p2");
    // maxval 1: 0 → 0 (obstacle), 1 → 255 (free).
    let p = write(&dir, "a.pgm", b"P2\n# comment\n2 2\n1\n0 1\n1 0\n");
    assert_eq!(
        to_text(&load(&p, &LoadOptions::default()).expect("p2")),
        "#.\n.#\n"
    );
}

#[test]
fn bad_inputs_give_the_right_error() {
    let dir = scratch_with_pgm("map-test-bad");
    let opts = LoadOptions::default();

    let missing = dir.join("nope.yaml");
    let e = load(&missing, &opts).unwrap_err();
    assert!(matches!(e, MapError::Io { .. }), "{e}");
    assert_names(&e, "nope.yaml");

    // YAML fields out of range or of the wrong type: (file, text replaced, by, field named).
    #[rustfmt::skip]
    let bad_fields = [
        ("nores.yaml", "resolution: 1.0\n", "", "resolution"),
        ("type.yaml", "resolution: 1.0", "resolution: fine", "resolution"),
        ("negres.yaml", "resolution: 1.0", "resolution: -1", "resolution"),
        ("thresh.yaml", "occupied_thresh: 0.65", "occupied_thresh: 1.5", "occupied_thresh"),
        ("crossed.yaml", "free_thresh: 0.196", "free_thresh: 0.7", "free_thresh"),
        ("origin.yaml", "[0.0, 0.0, 0.0]", "[0.0, 0.0]", "origin"),
        ("negate.yaml", "negate: 0", "negate: 2", "negate"),
    ];
    for (name, from, to, expected) in bad_fields {
        let yaml = YAML_OK.replace(from, to);
        assert_ne!(yaml, YAML_OK, "{name}: nothing replaced");
        let e = load(&write(&dir, name, yaml.as_bytes()), &opts).unwrap_err();
        assert!(
            matches!(e, MapError::Field { ref field, .. } if field == expected),
            "{name}: {e}"
        );
        assert_names(&e, name);
    }

    format_error(&dir, "garbage.yaml", b"image: [unclosed\n  - : :");

    let missing_image = write_yaml(&dir, "noimg.yaml", "m.pgm", "absent.pgm");
    let e = load(&missing_image, &opts).unwrap_err();
    assert!(matches!(e, MapError::Io { .. }), "{e}");
    assert_names(&e, "absent.pgm");

    // Truncated and garbled PGMs, directly and through a YAML.
    let full = small_pgm();
    for (i, bytes) in [
        &full[..full.len() - 2],
        &full[..8],
        &full[..3],
        b"P5\n3 x\n255\n",
        b"P6\n1 1\n255\n\x00",
        b"",
        b"P5\n1 1\n65535\n\x00\x00",
    ]
    .iter()
    .enumerate()
    {
        let name = format!("t{i}.pgm");
        format_error(&dir, &name, bytes);
        let y = write_yaml(&dir, &format!("t{i}.yaml"), "m.pgm", &name);
        let e = load(&y, &opts).unwrap_err();
        assert_names(&e, &name);
    }

    format_error(&dir, "broken.png", b"\x89PNG\r\n\x1a\nnot really");

    let e = format_error(&dir, "ragged.txt", b"...\n..\n...\n");
    assert_names(&e, "line 2");

    let e = format_error(&dir, "char.txt", b"...\n.x.\n");
    assert_names(&e, "line 2, column 2");

    let empty = write(&dir, "empty.txt", b"\n\n");
    assert!(matches!(
        load(&empty, &opts).unwrap_err(),
        MapError::Format { .. }
    ));

    let unsupported = write(&dir, "map.bmp", b"BM");
    let e = load(&unsupported, &opts).unwrap_err();
    assert_names(&e, "map.bmp");
    assert_names(&e, ".yaml");

    let e = load_with_cells(&dir.join("m.pgm"), 0.0).unwrap_err();
    assert!(matches!(e, MapError::Invalid(_)), "{e}");
}

#[test]
fn resolution_must_not_be_coarser_than_the_cell_size() {
    let dir = scratch_with_pgm("map-test-res");
    let yaml = write(&dir, "m.yaml", YAML_OK.as_bytes());
    let e = load_with_cells(&yaml, 0.5).unwrap_err();
    assert!(
        matches!(e, MapError::Field { ref field, .. } if field == "resolution"),
        "{e}"
    );
    let coarse = write_yaml(&dir, "c.yaml", "resolution: 1.0", "resolution: 0.3");
    // 1 m cells of 3.33 pixels of 0.3 m: the 3 × 2 image (0.9 × 0.6 m) is one cell
    // holding all six pixel centres, 2 of them occupied (33 % > 25 %); the cell reaches
    // 0.4 m below the image, so the origin moves down by that.
    let g = load(&coarse, &LoadOptions::default()).expect("resampled by area");
    assert_eq!((g.height(), g.width(), g.resolution), (1, 1, 1.0));
    assert_eq!(g.cells(), [Occupancy::Obstacle]);
    assert!((g.origin[1] + 0.4).abs() < 1e-9, "{:?}", g.origin);
    // Bare images are 1 m/pixel; a 2 m cell merges 2×2 blocks.
    let g = load_with_cells(&dir.join("m.pgm"), 2.0).expect("bare");
    assert_eq!((g.height(), g.width(), g.resolution), (1, 2, 2.0));
}

#[test]
fn discretizes_a_fine_yaml_map() {
    // 8×8 pixels at 0.25 m → 2×2 cells of 1 m (4×4 pixels each).
    // Cell (0,0): exactly 4 occupied pixels of 16 → free.
    // Cell (0,1): 5 occupied pixels → obstacle.
    // Cell (1,0): 16 unknown pixels (205) → unknown counts as not occupied → free.
    // Cell (1,1): 4 occupied + 12 unknown → free; (a 5th occupied pixel would flip it).
    let mut px = [PIXEL_FREE; 64];
    let mut set = |r: usize, c: usize, v: u8| px[r * 8 + c] = v;
    for c in 0..4 {
        set(0, c, PIXEL_OBSTACLE);
    }
    for (r, c) in [(0, 4), (1, 5), (2, 6), (3, 7), (3, 4)] {
        set(r, c, PIXEL_OBSTACLE);
    }
    for r in 4..8 {
        for c in 0..8 {
            set(r, c, PIXEL_UNKNOWN);
        }
    }
    for c in 4..8 {
        set(7, c, PIXEL_OBSTACLE);
    }
    let dir = Scratch::new("map-test-fine");
    let mut pgm = b"P5\n8 8\n255\n".to_vec();
    pgm.extend_from_slice(&px);
    write(&dir, "fine.pgm", &pgm);
    let yaml = write(
        &dir,
        "fine.yaml",
        YAML_OK
            .replace("m.pgm", "fine.pgm")
            .replace("resolution: 1.0", "resolution: 0.25")
            .as_bytes(),
    );
    let g = load(&yaml, &LoadOptions::default()).expect("fine map");
    assert_eq!((g.height(), g.width()), (2, 2));
    assert_eq!(g.resolution, 1.0);
    assert_eq!(g.get(Pos::new(0, 0)), Occupancy::Free);
    assert_eq!(g.get(Pos::new(0, 1)), Occupancy::Obstacle);
    assert_eq!(g.get(Pos::new(1, 0)), Occupancy::Free);
    assert_eq!(g.get(Pos::new(1, 1)), Occupancy::Free);
    // cell_size 0.25 keeps the pixels (and the unknown band).
    let g = load_with_cells(&yaml, 0.25).expect("pixels");
    assert_eq!(
        (g.height(), g.width(), g.count(Occupancy::Unknown)),
        (8, 8, 32 - 4)
    );
}

#[test]
fn partial_bottom_block_moves_the_origin_down() {
    let dir = scratch_with_pgm("map-test-origin"); // m.pgm: 3 wide, 2 high
    let yaml = write_yaml(&dir, "m.yaml", "resolution: 1.0", "resolution: 0.5");
    let g = load(&yaml, &LoadOptions::default()).expect("load");
    // 2 pixel rows fit one 2-pixel cell exactly; 3 columns → 2 cells, no vertical padding.
    assert_eq!((g.height(), g.width(), g.origin), (1, 2, [0.0, 0.0, 0.0]));
    let g = load_with_cells(&yaml, 1.5).expect("load");
    // 2 rows → 1 cell of 3 pixel rows: one padding row of 0.5 m below the image.
    assert_eq!((g.height(), g.width()), (1, 1));
    assert!((g.origin[1] + 0.5).abs() < 1e-12 && g.origin[0].abs() < 1e-12);
}

#[test]
fn text_parsing_details() {
    let p = Path::new("inline.txt");
    let g = parse_text("#.?  \r\n...\r\n\n\n", p).expect("parse");
    assert_eq!((g.height(), g.width()), (2, 3));
    assert_eq!(g.get(Pos::new(0, 2)), Occupancy::Unknown);
    assert_eq!(to_text(&g), "#.?\n...\n");
    let e = parse_text("..\n\n..\n", p).unwrap_err();
    assert_names(&e, "line 2");
}

#[test]
fn png_round_trip_and_save_dispatch() {
    let dir = Scratch::new("map-test-png");
    let g = parse_text("#.?\n..#\n", Path::new("x")).expect("parse");
    for name in ["a.png", "a.pgm", "a.txt", "a.map", "a.yml"] {
        let p = dir.join(name);
        save(&g, &p).expect("save");
        assert_eq!(
            load(&p, &LoadOptions::default()).expect("load"),
            g,
            "{name}"
        );
    }
    assert!(save(&g, &dir.join("a.jpg")).is_err());
    // No temporary files are left behind.
    let leftovers: Vec<_> = fs::read_dir(&dir)
        .expect("read dir")
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().starts_with('.'))
        .collect();
    assert!(leftovers.is_empty());
    // An RGBA PNG: luma for color, transparent pixels unknown.
    let rgba = image::RgbaImage::from_raw(
        3,
        1,
        vec![0, 0, 0, 255, 255, 255, 255, 255, 255, 255, 255, 0],
    )
    .expect("rgba");
    let p = dir.join("rgba.png");
    rgba.save(&p).expect("save rgba");
    assert_eq!(
        to_text(&load(&p, &LoadOptions::default()).expect("rgba")),
        "#.?\n"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn yaml_pgm_round_trip(grid in grid_strategy(12), x in -100.0f64..100.0, y in -100.0f64..100.0, yaw in -3.2f64..3.2) {
        let dir = Scratch::new("map-test-rt");
        let mut grid = grid;
        grid.origin = [x, y, yaw];
        let path = dir.join("map.yaml");
        save_yaml(&grid, &path).expect("save");
        let back = load(&path, &LoadOptions::default()).expect("load");
        prop_assert_eq!(back, grid);
    }

    #[test]
    fn text_round_trip(grid in grid_strategy(30)) {
        let text = to_text(&grid);
        let back = parse_text(&text, Path::new("t.txt")).expect("parse");
        prop_assert_eq!(back, grid);
    }

    #[test]
    fn garbage_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
        let _ = decode_pgm(&bytes, Path::new("g.pgm"));
        let mut p5 = b"P5\n4 4\n255\n".to_vec();
        p5.extend_from_slice(&bytes);
        let _ = decode_pgm(&p5, Path::new("g.pgm"));
        let _ = parse_text(&String::from_utf8_lossy(&bytes), Path::new("g.txt"));
        let _ = parse_map_yaml(&String::from_utf8_lossy(&bytes), Path::new("g.yaml"));
    }
}
