use image::{AnimationDecoder, Rgba};
use madenet_map::{OccGrid, Occupancy, Pos};
use madenet_render::{
    render, robot_color, save_gif, save_png, Frame, GifWriter, Layout, Panel, RenderError,
    RenderOptions, RobotFrame,
};
use madenet_testkit::{entries, Scratch};

/// 20 × 20: a wall in truth, the right half of the team map unknown, three robots.
fn frame20() -> Frame {
    let mut truth = OccGrid::new(20, 20, Occupancy::Free);
    for c in 3..8 {
        truth.set(Pos::new(5, c), Occupancy::Obstacle);
    }
    let mut team = OccGrid::new(20, 20, Occupancy::Unknown);
    for r in 0..20 {
        for c in 0..10 {
            team.set(Pos::new(r, c), truth.get(Pos::new(r, c)));
        }
    }
    let robots = vec![
        RobotFrame {
            pos: Pos::new(2, 2),
            goal: Some(Pos::new(2, 9)),
            path: (3..=9).map(|c| Pos::new(2, c)).collect(),
            candidates: vec![Pos::new(2, 9), Pos::new(8, 9)],
            in_view: vec![Pos::new(1, 1), Pos::new(2, 2)],
        },
        RobotFrame {
            pos: Pos::new(10, 4),
            goal: Some(Pos::new(12, 9)),
            ..Default::default()
        },
        RobotFrame {
            pos: Pos::new(17, 1),
            ..Default::default()
        },
    ];
    Frame {
        step: 42,
        truth,
        team_map: team,
        robots,
        explored: 0.875,
        links: vec![(0, 1)],
    }
}

/// [`frame20`], rendered with the default options, and its layout.
fn rendered20() -> (Frame, image::RgbaImage, Layout) {
    let frame = frame20();
    let opts = RenderOptions::default();
    let img = render(&frame, &opts);
    let layout = Layout::for_frame(&frame, &opts);
    (frame, img, layout)
}

fn px(img: &image::RgbaImage, (x, y): (u32, u32)) -> Rgba<u8> {
    *img.get_pixel(x, y)
}

#[test]
fn dimensions_of_a_20x20_frame() {
    let opts = RenderOptions::default();
    let img = render(&frame20(), &opts);
    // 2 panels of 20 * 16 + 1 px, 8 px margins, 16 px gap; 30 px status bar, 30 px titles.
    assert_eq!(img.dimensions(), (674, 389));
    let layout = Layout::for_frame(&frame20(), &opts);
    assert_eq!((layout.width, layout.height), (674, 389));

    let single = RenderOptions {
        show_truth: false,
        ..opts
    };
    assert_eq!(render(&frame20(), &single).dimensions(), (337, 389));
    // Deterministic: does not depend on the frame's contents.
    let mut other = frame20();
    other.robots.clear();
    other.step = 123_456;
    assert_eq!(render(&other, &opts).dimensions(), (674, 389));
    // Grows linearly with the grid.
    let l = Layout::new(40, 10, &opts);
    assert_eq!(l.panel_size(), (641, 161));
    assert_eq!(l.width, 2 * 8 + 2 * 641 + 16);
}

#[test]
fn robot_centre_has_robot_colour_on_both_panels() {
    let (frame, img, layout) = rendered20();
    for (i, r) in frame.robots.iter().enumerate() {
        for panel in [Panel::Truth, Panel::Team] {
            let c = layout.cell_center(panel, r.pos).unwrap();
            assert_eq!(px(&img, c), robot_color(i), "robot {i} on {panel:?}");
        }
    }
    // Distinct colours, the paper's blue / orange / green first.
    let colours: Vec<_> = (0..24).map(robot_color).collect();
    for i in 0..colours.len() {
        for j in 0..i {
            assert_ne!(colours[i], colours[j], "robots {i} and {j}");
        }
    }
    let [b, o, g] = [colours[0].0, colours[1].0, colours[2].0];
    assert!(b[2] > b[0] && b[2] > b[1], "robot 0 blue");
    assert!(o[0] > o[1] && o[1] > o[2], "robot 1 orange");
    assert!(g[1] > g[0] && g[1] > g[2], "robot 2 green");
}

#[test]
fn unknown_is_gray_in_team_panel_and_known_cells_are_white_or_black() {
    let (_, img, layout) = rendered20();
    let unknown = layout.cell_center(Panel::Team, Pos::new(15, 15)).unwrap();
    let p = px(&img, unknown);
    assert!(
        p[0] == p[1] && p[1] == p[2] && (96..=160).contains(&p[0]),
        "{p:?}"
    );
    let free = layout.cell_center(Panel::Team, Pos::new(15, 5)).unwrap();
    assert_eq!(px(&img, free), Rgba([255, 255, 255, 255]));
    let wall = layout.cell_center(Panel::Team, Pos::new(5, 5)).unwrap();
    assert_eq!(px(&img, wall), Rgba([0, 0, 0, 255]));
    // Truth panel: free cells the team has not seen differ from seen ones.
    let seen = px(
        &img,
        layout.cell_center(Panel::Truth, Pos::new(15, 5)).unwrap(),
    );
    let unseen = px(
        &img,
        layout.cell_center(Panel::Truth, Pos::new(15, 15)).unwrap(),
    );
    assert_eq!(seen, Rgba([255, 255, 255, 255]));
    assert_ne!(unseen, seen);
    // Every pixel is opaque.
    assert!(img.pixels().all(|p| p[3] == 255));
}

#[test]
fn degenerate_frames_do_not_panic() {
    let opts = RenderOptions::default();
    // Empty frame.
    let img = render(&Frame::default(), &opts);
    assert!(img.width() > 0 && img.height() > 0);
    // Zero robots, empty paths, robots / goals / links off the grid, odd sizes.
    let mut f = frame20();
    f.robots.clear();
    f.links = vec![(0, 1), (5, 9)];
    render(&f, &opts);
    let mut f = frame20();
    for r in &mut f.robots {
        r.path.clear();
        r.candidates.clear();
        r.goal = None;
    }
    render(&f, &opts);
    let mut f = frame20();
    f.robots[0].pos = Pos::new(-3, 40);
    f.robots[0].path = vec![Pos::new(-100, -100), Pos::new(1000, 5)];
    f.robots[1].goal = Some(Pos::new(99, -1));
    f.robots[2].in_view = vec![Pos::new(-1, 0), Pos::new(20, 20)];
    f.links = vec![(0, 2), (2, 2), (7, 0)];
    f.explored = f64::NAN;
    f.step = usize::MAX;
    render(&f, &opts);
    for cell_px in [0, 1, 2, 3, 5, 33] {
        for show_truth in [true, false] {
            let o = RenderOptions {
                cell_px,
                show_truth,
            };
            let img = render(&f, &o);
            let l = Layout::for_frame(&f, &o);
            assert_eq!(img.dimensions(), (l.width, l.height));
        }
    }
    let mut f = frame20();
    f.team_map = OccGrid::new(0, 0, Occupancy::Unknown);
    render(&f, &opts);
    // Truth smaller than the team map.
    let mut f = frame20();
    f.truth = OccGrid::new(3, 4, Occupancy::Free);
    render(&f, &opts);
}

#[test]
fn gif_with_three_frames_decodes_back() {
    let dir = Scratch::new("gif3");
    let path = dir.join("episode.gif");
    let opts = RenderOptions::default();
    let mut frames = vec![frame20(), frame20(), frame20()];
    for (k, f) in frames.iter_mut().enumerate() {
        f.step = k;
        f.robots[0].pos = Pos::new(2, 2 + k as i32);
    }
    save_gif(&frames, &opts, 200, &path).unwrap();
    assert_eq!(entries(&dir), ["episode.gif"], "no temp file left behind");

    let file = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
    let decoded = image::codecs::gif::GifDecoder::new(file)
        .unwrap()
        .into_frames()
        .collect_frames()
        .unwrap();
    assert_eq!(decoded.len(), 3);
    let layout = Layout::for_frame(&frames[0], &opts);
    for (k, f) in decoded.iter().enumerate() {
        assert_eq!(f.buffer().dimensions(), (674, 389));
        assert_eq!(f.delay().numer_denom_ms(), (200, 1));
        // Exact colours survive (few colours, no quantization).
        let c = layout
            .cell_center(Panel::Team, frames[k].robots[0].pos)
            .unwrap();
        assert_eq!(px(f.buffer(), c), robot_color(0));
        assert_eq!(
            f.buffer(),
            &render(&frames[k], &opts),
            "frame {k} pixel-exact"
        );
    }
}

#[test]
fn gif_writer_streams_and_checks_sizes() {
    let dir = Scratch::new("stream");
    let path = dir.join("s.gif");
    let opts = RenderOptions {
        cell_px: 8,
        show_truth: false,
    };
    let mut w = GifWriter::new(&path, &opts, 100).unwrap();
    w.push(&frame20()).unwrap();
    w.push(&frame20()).unwrap();
    // A frame of another grid size is refused, naming the file.
    let mut small = frame20();
    small.team_map = OccGrid::new(5, 5, Occupancy::Free);
    let err = w.push(&small).unwrap_err();
    assert!(
        matches!(err, RenderError::FrameSize { index: 2, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("s.gif"), "{err}");
    assert!(!path.exists(), "nothing at the target before finish");
    assert_eq!(w.frames(), 2);
    w.finish().unwrap();
    let file = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
    let n = image::codecs::gif::GifDecoder::new(file)
        .unwrap()
        .into_frames()
        .count();
    assert_eq!(n, 2);
    assert_eq!(entries(&dir), ["s.gif"]);

    // Dropping an unfinished writer leaves nothing behind.
    let other = dir.join("dropped.gif");
    let mut w = GifWriter::new(&other, &opts, 100).unwrap();
    w.push(&frame20()).unwrap();
    drop(w);
    assert_eq!(entries(&dir), ["s.gif"]);

    // No frames is an error, not an empty file.
    let err = GifWriter::new(&other, &opts, 100)
        .unwrap()
        .finish()
        .unwrap_err();
    assert!(matches!(err, RenderError::NoFrames { .. }), "{err}");
    let err = save_gif(&[], &opts, 100, &other).unwrap_err();
    assert!(err.to_string().contains("dropped.gif"), "{err}");
    assert_eq!(entries(&dir), ["s.gif"]);
}

#[test]
fn png_round_trips() {
    let dir = Scratch::new("png");
    let path = dir.join("snap.png");
    let opts = RenderOptions::default();
    save_png(&frame20(), &opts, &path).unwrap();
    // Overwriting works too.
    save_png(&frame20(), &opts, &path).unwrap();
    assert_eq!(entries(&dir), ["snap.png"]);
    let back = image::open(&path).unwrap().to_rgba8();
    assert_eq!(back, render(&frame20(), &opts));
}

#[test]
fn missing_directory_is_an_error_naming_the_path() {
    let dir = Scratch::new("missing");
    let opts = RenderOptions::default();
    let png = dir.join("no/such/dir/snap.png");
    let err = save_png(&frame20(), &opts, &png).unwrap_err();
    assert!(matches!(err, RenderError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains(&*png.to_string_lossy()), "{err}");

    let gif = dir.join("no/such/dir/ep.gif");
    let err = save_gif(&[frame20()], &opts, 100, &gif).unwrap_err();
    assert!(err.to_string().contains(&*gif.to_string_lossy()), "{err}");
    assert!(GifWriter::new(&gif, &opts, 100).is_err());
}
