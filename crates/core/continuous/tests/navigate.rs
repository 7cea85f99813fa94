//! The navigator (nav2's `NavigateToPose` half) on generated floor plans and small rooms.

use madenet_continuous::{
    ContinuousConfig, ContinuousWorld, NavError, NavParams, NavStatus, Navigator, Scene,
};
use madenet_map::floorplan::{floor_plan, FloorPlanConfig};
use madenet_map::generate::reachable_from_with;
use madenet_map::{Movement, OccGrid, Occupancy, Pos};
use std::sync::Arc;

/// A world of one robot on `grid` (1 m cells), starting in `start`.
fn world_on(grid: &OccGrid, start: Pos, seed: u64) -> ContinuousWorld {
    let scene = Arc::new(Scene::from_grid(grid, "test"));
    let scenario = madenet_world::ScenarioConfig {
        num_robots: 1,
        ..Default::default()
    };
    ContinuousWorld::new(scene, &[start], scenario, ContinuousConfig::default(), seed).unwrap()
}

/// Steps robot 0 with `nav` until it succeeds or fails, or `cap` seconds pass.
fn drive(world: &mut ContinuousWorld, nav: &mut Navigator, cap: f64) -> Option<NavStatus> {
    let t0 = world.time();
    while world.time() - t0 < cap {
        match nav.step(world, 0, &[]) {
            NavStatus::Driving { command, .. } => world.step(&[command]),
            NavStatus::Idle => return Some(NavStatus::Idle),
            done => return Some(done),
        }
    }
    None
}

/// Metres from (`x`, `y`) to the nearest solid cell of `grid` or its edge.
fn clearance(grid: &OccGrid, x: f64, y: f64) -> f64 {
    let (h, w) = (grid.height() as f64, grid.width() as f64);
    let mut d = x.min(y).min(w - x).min(h - y);
    for k in 0..grid.len() {
        if grid.cells()[k] != Occupancy::Free {
            let p = grid.pos(k);
            let (x0, y0) = (p.col as f64, p.row as f64);
            let dx = (x0 - x).max(0.0).max(x - x0 - 1.0);
            let dy = (y0 - y).max(0.0).max(y - y0 - 1.0);
            d = d.min(dx.hypot(dy));
        }
    }
    d
}

/// `n` goals on a 20 m floor plan with 1 m doors, one after the other: every one reached
/// within tolerance, without a collision.
fn goals_on_a_floor_plan(n: usize, seed: u64) {
    let mut cfg = FloorPlanConfig::for_size(20, 20);
    cfg.door_width = 1;
    let grid = floor_plan(&cfg, seed).unwrap();
    let start = cfg.keep_free[0];
    let mut world = world_on(&grid, start, seed);
    // The robot learns the plan as it drives (the planner plans through unknown space, as
    // nav2's with `allow_unknown`): a goal behind a wall not yet seen can take a long detour,
    // hence the generous cap per goal.
    // Goals: non-centre points of the true free cells reachable without corner cutting, with
    // room for the footprint, picked by a fixed stride, at least 4 m apart.
    let reach = reachable_from_with(&grid, start, Movement::NoCornerCutting);
    let offsets = [(0.3, -0.2), (-0.25, 0.15), (0.1, 0.3), (-0.3, -0.1)];
    let candidates: Vec<(f64, f64)> = (0..grid.len())
        .filter(|&k| reach[k] && grid.cells()[k] == Occupancy::Free)
        .map(|k| {
            let p = grid.pos(k);
            let o = offsets[k % offsets.len()];
            (p.col as f64 + 0.5 + o.0, p.row as f64 + 0.5 + o.1)
        })
        .filter(|&(x, y)| clearance(&grid, x, y) > 0.3)
        .collect();
    assert!(candidates.len() > 50, "{}", candidates.len());
    let mut nav = Navigator::new(NavParams::default());
    let mut last = {
        let p = world.pose(0);
        (p.x, p.y)
    };
    let mut k = 7;
    let (mut reached, mut finals, mut longest) = (0, Vec::new(), 0.0f64);
    let t0 = world.time();
    for g in 0..n {
        let goal = loop {
            k = (k + 37) % candidates.len();
            let c = candidates[k];
            if (c.0 - last.0).hypot(c.1 - last.1) > 4.0 {
                break c;
            }
        };
        nav.start(goal, &world, 0)
            .unwrap_or_else(|e| panic!("goal {g} {goal:?}: {e}"));
        let t = world.time();
        let end = drive(&mut world, &mut nav, 300.0);
        let p = world.pose(0);
        let d = (p.x - goal.0).hypot(p.y - goal.1);
        assert_eq!(
            end,
            Some(NavStatus::Succeeded),
            "goal {g} {goal:?}: robot at ({:.2}, {:.2}), {d:.2} m away after {:.0} s",
            p.x,
            p.y,
            world.time() - t
        );
        assert!(d <= 0.25 + 1e-9, "goal {g}: {d}");
        longest = longest.max(world.time() - t);
        finals.push(d);
        reached += 1;
        last = goal;
    }
    let c = world.collisions();
    eprintln!(
        "seed {seed}: {reached}/{n} goals in {:.0} s of sim (longest {longest:.0} s), mean final distance {:.3} m, collisions {c:?}, {} plans",
        world.time() - t0,
        finals.iter().sum::<f64>() / finals.len() as f64,
        nav.replans()
    );
    assert_eq!(c.obstacle + c.robot, 0, "{c:?}");
}

#[test]
fn five_goals_on_a_floor_plan_are_reached_without_collisions() {
    goals_on_a_floor_plan(5, 3);
}

/// Twenty goals on each of two plans (about 4 s in a test build: the crate is built at
/// opt-level 3 there).
#[test]
fn twenty_goals_on_floor_plans_are_reached_without_collisions() {
    for seed in [1, 2] {
        goals_on_a_floor_plan(20, seed);
    }
}

fn room(text: &str) -> OccGrid {
    madenet_map::io::parse_text(text, std::path::Path::new("room.txt")).unwrap()
}

#[test]
fn goals_off_the_map_or_not_finite_are_refused_and_cancel_idles() {
    let grid = room(&"........\n".repeat(8));
    let world = world_on(&grid, Pos::new(1, 1), 1);
    let mut nav = Navigator::new(NavParams::default());
    for goal in [
        (-0.5, 3.0),
        (3.0, 8.0),
        (9.0, 1.0),
        (f64::NAN, 2.0),
        (2.0, f64::INFINITY),
    ] {
        assert_eq!(nav.start(goal, &world, 0), Err(NavError::GoalOutsideMap));
        assert_eq!(nav.step(&world, 0, &[]), NavStatus::Idle);
    }
    assert_eq!(nav.start((6.3, 5.2), &world, 0), Ok(()));
    assert!(matches!(
        nav.step(&world, 0, &[]),
        NavStatus::Driving { .. }
    ));
    nav.cancel();
    assert_eq!(nav.step(&world, 0, &[]), NavStatus::Idle);
}

#[test]
fn a_goal_on_a_seen_wall_is_occupied() {
    // A wall along column 4, rows 0–5; the robot in front of it.
    let text = "....#...\n".repeat(6) + &"........\n".repeat(2);
    let grid = room(&text);
    let mut world = world_on(&grid, Pos::new(2, 2), 1);
    for _ in 0..20 {
        world.step(&[(0.0, 0.0)]);
    }
    let map = world.map(0);
    let res = map.resolution();
    // A pixel of the wall's face the robot has seen occupied.
    let (r, c) = (15..45)
        .flat_map(|r| (35..45).map(move |c| (r, c)))
        .find(|&(r, c)| map.observed(r, c) && map.occupied(r, c))
        .expect("the wall's face is seen");
    let goal = ((c as f64 + 0.5) * res, (r as f64 + 0.5) * res);
    let mut nav = Navigator::new(NavParams::default());
    assert_eq!(nav.start(goal, &world, 0), Err(NavError::GoalOccupied));
}

#[test]
fn a_goal_in_a_closed_room_fails_with_no_valid_path() {
    // A closed 4 × 4 box (2 × 2 inside) in a 12 × 12 room; the robot outside.
    let mut rows = vec!["............".to_string(); 12];
    rows[4] = "....####....".into();
    rows[5] = "....#..#....".into();
    rows[6] = "....#..#....".into();
    rows[7] = "....####....".into();
    let grid = room(&(rows.join("\n") + "\n"));
    let mut world = world_on(&grid, Pos::new(1, 1), 2);
    let mut nav = Navigator::new(NavParams::default());
    let goal = (5.6, 5.7);
    let end = match nav.start(goal, &world, 0) {
        Err(e) => NavStatus::Failed(e),
        Ok(()) => drive(&mut world, &mut nav, 300.0).expect("ends within 300 s"),
    };
    eprintln!("closed room: {end:?} after {:.0} s", world.time());
    assert_eq!(end, NavStatus::Failed(NavError::NoValidPath));
    assert_eq!(world.collisions().obstacle, 0);
}

#[test]
fn a_robot_that_does_not_move_fails_to_make_progress() {
    let grid = room(&"........\n".repeat(8));
    let mut world = world_on(&grid, Pos::new(1, 1), 1);
    let mut nav = Navigator::new(NavParams::default());
    nav.start((6.3, 6.2), &world, 0).unwrap();
    let mut end = None;
    while world.time() < 12.0 {
        match nav.step(&world, 0, &[]) {
            NavStatus::Driving { .. } => world.step(&[(0.0, 0.0)]),
            other => {
                end = Some(other);
                break;
            }
        }
    }
    assert_eq!(end, Some(NavStatus::Failed(NavError::FailedToMakeProgress)));
    assert!(world.time() > 10.0 - 1e-9, "{}", world.time());
}

/// A goal with a heading: in position first, then it turns in place until it faces the
/// heading within nav2's `yaw_goal_tolerance` (0.25 rad), for headings all around.
#[test]
fn a_goal_with_a_heading_is_reached_facing_it() {
    use madenet_continuous::normalize_angle;
    let grid = room(&"........\n".repeat(8));
    let mut world = world_on(&grid, Pos::new(1, 1), 1);
    let mut nav = Navigator::new(NavParams::default());
    let goals = [((5.5, 5.5), 3.0), ((2.5, 5.5), -1.2), ((5.0, 2.0), 0.4)];
    for (goal, yaw) in goals {
        nav.start_pose(goal, Some(yaw), &world, 0).unwrap();
        let end = drive(&mut world, &mut nav, 120.0);
        let p = world.pose(0);
        assert_eq!(end, Some(NavStatus::Succeeded), "{goal:?} {yaw}: {p:?}");
        let off = normalize_angle(p.theta - yaw).abs();
        assert!(
            off <= 0.25 + 1e-9,
            "{goal:?}: heading {} for {yaw}",
            p.theta
        );
        // In position once: it may drift a little while it turns (nav2's stateful checker).
        assert!((p.x - goal.0).hypot(p.y - goal.1) < 0.4, "{goal:?}: {p:?}");
    }
    assert_eq!(
        nav.start_pose((3.0, 3.0), Some(f64::NAN), &world, 0),
        Err(NavError::GoalOutsideMap)
    );
    assert_eq!(world.collisions().obstacle, 0);
}
