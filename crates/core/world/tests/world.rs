//! The world's per-timestep pipeline: motion (obstacles, conflicts, slip), sensing, explorable
//! cells, contact & communication with dropouts, determinism, and config validation.

use madenet_map::generate::{generate_with_movement, GeneratorConfig};
use madenet_map::{Movement, OccGrid, Occupancy, Pos};
use madenet_world::rng::stream;
use madenet_world::{line_of_sight, step_allowed, Move, ScenarioConfig, ViewPattern, World};
use proptest::prelude::*;
use rand::RngExt;
use std::collections::{BTreeMap, BTreeSet, VecDeque};

const RULES: [Movement; 2] = [Movement::CornerCutting, Movement::NoCornerCutting];
const SQRT2: f64 = std::f64::consts::SQRT_2;

fn grid(rows: &[&str]) -> OccGrid {
    let h = rows.len();
    let w = rows[0].len();
    let cells = rows
        .iter()
        .flat_map(|r| {
            assert_eq!(r.len(), w);
            r.chars().map(|c| {
                if c == '#' {
                    Occupancy::Obstacle
                } else {
                    Occupancy::Free
                }
            })
        })
        .collect();
    OccGrid::from_cells(h, w, cells)
}

fn open(h: usize, w: usize) -> OccGrid {
    OccGrid::new(h, w, Occupancy::Free)
}

/// Deterministic motion and perfect sensing.
fn exact(n: usize) -> ScenarioConfig {
    ScenarioConfig {
        num_robots: n,
        motion_success_prob: 1.0,
        sensor_miss_prob: 0.0,
        ..Default::default()
    }
}

/// A world on `grid` with robots at `starts` (exact motion and sensing, seed 1) after one step
/// of `moves`.
fn after_step(grid: OccGrid, starts: &[Pos], moves: &[Move]) -> World {
    let mut w = World::new(grid, starts, exact(starts.len()), 1).unwrap();
    w.step(moves);
    w
}

fn p(r: i32, c: i32) -> Pos {
    Pos::new(r, c)
}

// ---------------------------------------------------------------------------------------
// Motion
// ---------------------------------------------------------------------------------------

#[test]
fn moving_into_an_obstacle_or_off_the_map_stays() {
    let truth = grid(&["....", ".#..", "...."]);
    let mut w = World::new(truth, &[p(1, 0)], exact(1), 1).unwrap();
    w.step(&[Move::E]);
    assert_eq!(w.positions(), &[p(1, 0)]);
    assert_eq!(w.executed_moves(), &[Move::Stay]);
    w.step(&[Move::W]); // off the map
    assert_eq!(w.positions(), &[p(1, 0)]);
    assert_eq!(w.distances(), &[0.0]);
    assert_eq!(w.t(), 2);
    // A legal move is executed exactly (motion_success_prob = 1).
    w.step(&[Move::N]);
    assert_eq!(w.positions(), &[p(0, 0)]);
    assert_eq!(w.executed_moves(), &[Move::N]);
}

#[test]
fn diagonal_past_a_corner_depends_on_the_movement_rule() {
    // (0,1) is an obstacle: (0,0) -> (1,1) cuts its corner; (1,0) is free.
    let truth = grid(&[".#.", "...", "..."]);
    let cut = ScenarioConfig {
        movement: Movement::CornerCutting,
        ..exact(1)
    };
    let mut w = World::new(truth.clone(), &[p(0, 0)], cut, 1).unwrap();
    w.step(&[Move::SE]);
    assert_eq!(w.positions(), &[p(1, 1)]);
    let strict = ScenarioConfig {
        movement: Movement::NoCornerCutting,
        ..exact(1)
    };
    let mut w = World::new(truth, &[p(0, 0)], strict, 1).unwrap();
    w.step(&[Move::SE]);
    assert_eq!(w.positions(), &[p(0, 0)]);
}

#[test]
fn same_target_lower_index_moves() {
    // Both aim at (2,3); robot 0 comes from the left.
    let w = after_step(open(5, 7), &[p(2, 2), p(2, 4)], &[Move::E, Move::W]);
    assert_eq!(w.positions(), &[p(2, 3), p(2, 4)]);
    assert_eq!(w.executed_moves(), &[Move::E, Move::Stay]);
    assert_eq!(w.distances(), &[1.0, 0.0]);
    // Mirrored: robot 0 comes from the right; it still wins (index, not side).
    let w = after_step(open(5, 7), &[p(2, 4), p(2, 2)], &[Move::W, Move::E]);
    assert_eq!(w.positions(), &[p(2, 3), p(2, 2)]);
    // Three robots on one cell, robot 0 diagonal: 0 wins, 1 and 2 stay.
    let w = after_step(
        open(5, 7),
        &[p(1, 2), p(2, 4), p(3, 3)],
        &[Move::SE, Move::W, Move::N],
    );
    assert_eq!(w.positions(), &[p(2, 3), p(2, 4), p(3, 3)]);
    assert!((w.distances()[0] - SQRT2).abs() < 1e-12);
    // If robot 0 does not compete, robot 1 wins over robot 2.
    let w = after_step(
        open(5, 7),
        &[p(0, 0), p(2, 4), p(3, 3)],
        &[Move::Stay, Move::W, Move::N],
    );
    assert_eq!(w.positions(), &[p(0, 0), p(2, 3), p(3, 3)]);
}

#[test]
fn swap_attempt_both_stay() {
    for (a, b, ma, mb) in [
        (p(2, 2), p(2, 3), Move::E, Move::W),
        (p(2, 2), p(3, 3), Move::SE, Move::NW),
        (p(1, 1), p(2, 1), Move::S, Move::N),
    ] {
        let mut w = World::new(open(5, 5), &[a, b], exact(2), 3).unwrap();
        w.step(&[ma, mb]);
        assert_eq!(w.positions(), &[a, b], "swap {a} <-> {b}");
        assert_eq!(w.executed_moves(), &[Move::Stay, Move::Stay]);
        assert_eq!(w.distances(), &[0.0, 0.0]);
    }
}

#[test]
fn cannot_enter_a_cell_held_at_the_start_of_the_step() {
    // A train: robot 0 follows robot 1, which moves away. Robot 0 still may not enter.
    let w = after_step(open(3, 6), &[p(1, 1), p(1, 2)], &[Move::E, Move::E]);
    assert_eq!(w.positions(), &[p(1, 1), p(1, 3)]);
    // The same with the leader being the lower index.
    let w = after_step(open(3, 6), &[p(1, 2), p(1, 1)], &[Move::E, Move::E]);
    assert_eq!(w.positions(), &[p(1, 3), p(1, 1)]);
    // A rotation of three robots (0 -> 1's cell -> 2's cell -> 0's cell): nobody moves.
    let w = after_step(
        open(4, 4),
        &[p(1, 1), p(1, 2), p(2, 2)],
        &[Move::E, Move::S, Move::NW],
    );
    assert_eq!(w.positions(), &[p(1, 1), p(1, 2), p(2, 2)]);
    // Entering a stationary robot's cell.
    let mut w = after_step(open(3, 6), &[p(1, 1), p(1, 2)], &[Move::E, Move::Stay]);
    assert_eq!(w.positions(), &[p(1, 1), p(1, 2)]);
    // Next step the cell is free: the follower can move in.
    w.step(&[Move::Stay, Move::E]);
    w.step(&[Move::E, Move::Stay]);
    assert_eq!(w.positions(), &[p(1, 2), p(1, 3)]);
}

#[test]
fn distances_are_one_per_straight_and_sqrt2_per_diagonal_step() {
    let mut w = World::new(open(8, 8), &[p(0, 0), p(7, 7)], exact(2), 1).unwrap();
    let plan0 = [Move::E, Move::SE, Move::SE, Move::S, Move::Stay, Move::E];
    let plan1 = [Move::NW, Move::Stay, Move::N, Move::W, Move::W, Move::NW];
    for (a, b) in plan0.iter().zip(&plan1) {
        w.step(&[*a, *b]);
    }
    assert_eq!(w.positions(), &[p(3, 4), p(4, 3)]);
    let d = w.distances();
    assert!((d[0] - (3.0 + 2.0 * SQRT2)).abs() < 1e-12, "{d:?}");
    assert!((d[1] - (3.0 + 2.0 * SQRT2)).abs() < 1e-12, "{d:?}");
    // Metres: cell_size scales the distance.
    let cfg = ScenarioConfig {
        cell_size: 2.5,
        ..exact(1)
    };
    let mut w = World::new(open(4, 4), &[p(0, 0)], cfg, 1).unwrap();
    w.step(&[Move::SE]);
    w.step(&[Move::E]);
    assert!((w.distances()[0] - 2.5 * (1.0 + SQRT2)).abs() < 1e-12);
}

/// Whether `m` from robot i's `at` is legal given the start-of-step positions.
fn legal(truth: &OccGrid, positions: &[Pos], i: usize, m: Move, movement: Movement) -> bool {
    let at = positions[i];
    let to = m.apply(at);
    step_allowed(|q| truth.is_free(q), at, m, movement)
        && (m == Move::Stay
            || !positions
                .iter()
                .enumerate()
                .any(|(j, &pj)| j != i && pj == to))
}

#[test]
fn failed_motion_never_reaches_the_intended_cell_and_stays_legal() {
    for movement in RULES {
        for seed in 0..6u64 {
            let mut gen = GeneratorConfig::for_size(14, 14);
            gen.keep_free = vec![p(0, 0), p(0, 13), p(13, 0)];
            let truth = generate_with_movement(&gen, seed, movement).unwrap();
            let cfg = ScenarioConfig {
                motion_success_prob: 0.0,
                movement,
                ..exact(3)
            };
            let mut w = World::new(truth.clone(), &gen.keep_free, cfg, seed).unwrap();
            let mut intents_rng = stream(seed, "test/intents", 0);
            let mut moved_by_slip = 0;
            for _ in 0..150 {
                let before = w.positions().to_vec();
                let intents: Vec<Move> = (0..3)
                    .map(|_| Move::ALL[intents_rng.random_range(0..9)])
                    .collect();
                w.step(&intents);
                let after = w.positions().to_vec();
                for i in 0..3 {
                    let ex = w.executed_moves()[i];
                    assert_eq!(Some(ex), Move::between(before[i], after[i]));
                    assert!(
                        legal(&truth, &before, i, ex, movement),
                        "illegal executed move {ex:?} of robot {i} at {}",
                        before[i]
                    );
                    if intents[i] == Move::Stay || !legal(&truth, &before, i, intents[i], movement)
                    {
                        // A robot that does not (legally) try to move does not slip by default.
                        assert_eq!(after[i], before[i], "robot {i} intent {:?}", intents[i]);
                    } else {
                        assert_ne!(
                            after[i],
                            intents[i].apply(before[i]),
                            "robot {i} reached its intended cell"
                        );
                        moved_by_slip += (ex != Move::Stay) as usize;
                    }
                }
                let distinct: BTreeSet<Pos> = after.iter().copied().collect();
                assert_eq!(distinct.len(), 3, "two robots share a cell: {after:?}");
            }
            assert!(moved_by_slip > 0);
        }
    }
}

#[test]
fn slip_picks_every_other_legal_move_uniformly() {
    let cfg = ScenarioConfig {
        motion_success_prob: 0.0,
        ..exact(1)
    };
    let mut w = World::new(open(81, 81), &[p(40, 40)], cfg, 5).unwrap();
    let mut counts: BTreeMap<(Move, Move), usize> = BTreeMap::new();
    let mut per_intent: BTreeMap<Move, usize> = BTreeMap::new();
    for _ in 0..1200 {
        // Slipping away from the intent drifts against it: steer back to the middle.
        let at = w.positions()[0];
        let intent = if at.col <= 40 { Move::W } else { Move::E };
        w.step(&[intent]);
        let ex = w.executed_moves()[0];
        assert_ne!(ex, intent);
        // Only count steps far from the border, where all nine moves are legal.
        if at.row >= 2 && at.row <= 78 && at.col >= 2 && at.col <= 78 {
            *counts.entry((intent, ex)).or_default() += 1;
            *per_intent.entry(intent).or_default() += 1;
        }
    }
    for intent in [Move::W, Move::E] {
        let total = per_intent[&intent];
        assert!(total > 400, "{per_intent:?}");
        for m in Move::ALL {
            let c = counts.get(&(intent, m)).copied().unwrap_or(0);
            if m == intent {
                assert_eq!(c, 0);
            } else {
                // Uniform over the 8 other moves (Stay included).
                let expect = total as f64 / 8.0;
                assert!(
                    (c as f64 - expect).abs() < 0.5 * expect,
                    "intent {intent:?}: {m:?} {c} of {total}: {counts:?}"
                );
            }
        }
    }
}

#[test]
fn slip_when_staying_moves_a_staying_robot() {
    let off = ScenarioConfig {
        motion_success_prob: 0.0,
        ..exact(1)
    };
    let mut w = World::new(open(9, 9), &[p(4, 4)], off, 2).unwrap();
    for _ in 0..30 {
        w.step(&[Move::Stay]);
    }
    assert_eq!(w.positions(), &[p(4, 4)]);
    let on = ScenarioConfig {
        motion_success_prob: 0.0,
        slip_when_staying: true,
        ..exact(1)
    };
    let mut w = World::new(open(9, 9), &[p(4, 4)], on, 2).unwrap();
    for _ in 0..30 {
        w.step(&[Move::Stay]);
        assert_ne!(w.executed_moves()[0], Move::Stay);
    }
}

// ---------------------------------------------------------------------------------------
// Sensing and explorable cells
// ---------------------------------------------------------------------------------------

fn visible_from(truth: &OccGrid, view: &ViewPattern, at: Pos) -> BTreeSet<Pos> {
    let mut out = BTreeSet::new();
    view.for_each_visible(
        at,
        |q| truth.in_bounds(q),
        |q| !truth.is_free(q),
        |q| {
            out.insert(q);
        },
    );
    out
}

fn random_world_strategy() -> impl Strategy<Value = (OccGrid, Vec<Pos>, Movement, i32)> {
    (
        5usize..=14,
        5usize..=14,
        0.0f64..0.5,
        1usize..=3,
        any::<bool>(),
        1i32..=4,
    )
        .prop_flat_map(|(h, w, density, n, strict, ds)| {
            (
                prop::collection::vec(0.0f64..1.0, h * w),
                prop::collection::vec(any::<prop::sample::Index>(), n),
            )
                .prop_map(move |(u, picks)| {
                    let cells: Vec<Occupancy> = u
                        .iter()
                        .map(|&x| {
                            if x < density {
                                Occupancy::Obstacle
                            } else {
                                Occupancy::Free
                            }
                        })
                        .collect();
                    let truth = OccGrid::from_cells(h, w, cells);
                    let mut free: Vec<Pos> = (0..h * w)
                        .map(|i| truth.pos(i))
                        .filter(|&q| truth.is_free(q))
                        .collect();
                    let mut starts = Vec::new();
                    for ix in picks {
                        if free.is_empty() {
                            break;
                        }
                        starts.push(free.remove(ix.index(free.len())));
                    }
                    let movement = if strict {
                        Movement::NoCornerCutting
                    } else {
                        Movement::CornerCutting
                    };
                    (truth, starts, movement, ds)
                })
        })
}

/// Explorable cells recomputed independently: BFS with `OccGrid::can_step_with`, then the
/// view from every reachable cell.
fn explorable_reference(truth: &OccGrid, starts: &[Pos], movement: Movement, ds: i32) -> Vec<bool> {
    let mut reach = vec![false; truth.len()];
    let mut queue: VecDeque<Pos> = starts.iter().copied().collect();
    for &s in starts {
        reach[truth.index(s)] = true;
    }
    while let Some(q) = queue.pop_front() {
        for dr in -1..=1 {
            for dc in -1..=1 {
                let r = Pos::new(q.row + dr, q.col + dc);
                if truth.can_step_with(q, r, movement) && !reach[truth.index(r)] {
                    reach[truth.index(r)] = true;
                    queue.push_back(r);
                }
            }
        }
    }
    let view = ViewPattern::new(ds, movement);
    let mut out = reach.clone();
    for (i, _) in reach.iter().enumerate().filter(|(_, &r)| r) {
        {
            for q in visible_from(truth, &view, truth.pos(i)) {
                out[truth.index(q)] = true;
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn initial_team_map_is_exactly_what_the_starts_see((truth, starts, movement, ds) in random_world_strategy()) {
        prop_assume!(!starts.is_empty());
        let n = starts.len();
        let cfg = ScenarioConfig { num_robots: n, sensing_range: ds, movement, ..exact(n) };
        let w = World::new(truth.clone(), &starts, cfg, 11).unwrap();
        let view = ViewPattern::new(ds, movement);
        let mut want = vec![Occupancy::Unknown; truth.len()];
        for (i, &s) in starts.iter().enumerate() {
            let vis = visible_from(&truth, &view, s);
            let obs = w.observation(i);
            prop_assert_eq!(obs.pos, s);
            prop_assert_eq!(obs.t, 0);
            let seen: BTreeSet<Pos> = obs.seen.iter().map(|&(q, _)| q).collect();
            let mut vis_own = vis.clone();
            vis_own.insert(s);
            prop_assert_eq!(&seen, &vis_own, "robot {} at {}", i, s);
            prop_assert_eq!(obs.seen.len(), seen.len(), "duplicate cells in observation");
            for &(q, occ) in &obs.seen {
                prop_assert_eq!(occ, truth.get(q));
            }
            want[truth.index(s)] = Occupancy::Free;
            for q in vis {
                want[truth.index(q)] = truth.get(q);
            }
        }
        prop_assert_eq!(w.team_map(), &want[..]);
        prop_assert_eq!(w.known_count(), want.iter().filter(|o| o.is_known()).count());
    }

    #[test]
    fn explorable_matches_independent_recomputation((truth, starts, movement, ds) in random_world_strategy()) {
        prop_assume!(!starts.is_empty());
        let n = starts.len();
        let cfg = ScenarioConfig { num_robots: n, sensing_range: ds, movement, ..exact(n) };
        let w = World::new(truth.clone(), &starts, cfg, 3).unwrap();
        let want = explorable_reference(&truth, &starts, movement, ds);
        prop_assert_eq!(w.explorable(), &want[..]);
        prop_assert_eq!(w.explorable_count(), want.iter().filter(|&&e| e).count());
        // What the team knows is always explorable.
        for (i, o) in w.team_map().iter().enumerate() {
            if o.is_known() {
                prop_assert!(want[i], "known cell {} is not explorable", truth.pos(i));
            }
        }
        prop_assert!(w.explored_fraction() <= 1.0 + 1e-12);
    }

    #[test]
    fn team_map_accumulates_observations_and_matches_truth(
        (truth, starts, movement, ds) in random_world_strategy(),
        seed in 0u64..1000,
    ) {
        prop_assume!(!starts.is_empty());
        let n = starts.len();
        let cfg = ScenarioConfig { num_robots: n, sensing_range: ds, movement, sensor_miss_prob: 0.3, motion_success_prob: 0.8, ..Default::default() };
        let mut w = World::new(truth.clone(), &starts, cfg, seed).unwrap();
        let mut union: BTreeSet<Pos> = BTreeSet::new();
        let mut rng = stream(seed, "test/intents", 1);
        let view = ViewPattern::new(ds, movement);
        for step in 0..25 {
            for i in 0..n {
                let obs = w.observation(i);
                let vis = visible_from(&truth, &view, obs.pos);
                for &(q, occ) in &obs.seen {
                    prop_assert_eq!(occ, truth.get(q));
                    prop_assert!(q == obs.pos || vis.contains(&q), "robot {} saw {} out of view at step {}", i, q, step);
                    union.insert(q);
                }
            }
            let known: BTreeSet<Pos> = (0..truth.len()).filter(|&k| w.team_map()[k].is_known()).map(|k| truth.pos(k)).collect();
            prop_assert_eq!(&known, &union);
            for k in 0..truth.len() {
                if w.team_map()[k].is_known() {
                    prop_assert_eq!(w.team_map()[k], truth.cells()[k]);
                }
            }
            prop_assert_eq!(w.known_count(), union.len());
            let intents: Vec<Move> = (0..n).map(|_| Move::ALL[rng.random_range(0..9)]).collect();
            w.step(&intents);
        }
    }
}

#[test]
fn always_missing_sensor_knows_only_the_robots_cells() {
    let mut gen = GeneratorConfig::for_size(16, 16);
    gen.keep_free = vec![p(0, 0), p(0, 1), p(1, 0)];
    let truth = generate_with_movement(&gen, 4, Movement::CornerCutting).unwrap();
    let cfg = ScenarioConfig {
        sensor_miss_prob: 1.0,
        ..exact(3)
    };
    let mut w = World::new(truth.clone(), &gen.keep_free, cfg, 9).unwrap();
    let mut visited: BTreeSet<Pos> = gen.keep_free.iter().copied().collect();
    let mut rng = stream(9, "test/intents", 2);
    for step in 0..40 {
        let known: BTreeSet<Pos> = (0..truth.len())
            .filter(|&k| w.team_map()[k].is_known())
            .map(|k| truth.pos(k))
            .collect();
        assert_eq!(known, visited, "step {step}");
        assert_eq!(w.known_count(), visited.len());
        for i in 0..3 {
            let o = w.observation(i);
            assert_eq!(o.seen, vec![(o.pos, Occupancy::Free)]);
        }
        let intents: Vec<Move> = (0..3).map(|_| Move::ALL[rng.random_range(0..9)]).collect();
        w.step(&intents);
        visited.extend(w.positions().iter().copied());
    }
    assert!(visited.len() > 3, "the robots should have moved");
}

#[test]
fn explorable_of_a_walled_pocket() {
    // The right room is sealed: its interior is not explorable, but the wall is (seen from the
    // left room).
    let truth = grid(&[
        "........#....",
        "........#....",
        "........#....",
        "........#....",
        "........#....",
    ]);
    let w = World::new(
        truth.clone(),
        &[p(2, 2)],
        ScenarioConfig {
            sensing_range: 6,
            ..exact(1)
        },
        1,
    )
    .unwrap();
    let want = explorable_reference(&truth, &[p(2, 2)], Movement::CornerCutting, 6);
    assert_eq!(w.explorable(), &want[..]);
    // 5 rows × 9 columns (0..=8, wall included).
    assert_eq!(w.explorable_count(), 45);
    for r in 0..5 {
        assert!(!w.explorable()[truth.index(p(r, 9))]);
    }
    // A diagonal wall seals under NoCornerCutting only.
    let diag = grid(&["..#", ".#.", "#.."]);
    let cut = World::new(
        diag.clone(),
        &[p(0, 0)],
        ScenarioConfig {
            sensing_range: 1,
            ..exact(1)
        },
        1,
    )
    .unwrap();
    assert_eq!(cut.explorable_count(), 9);
    let strict = ScenarioConfig {
        sensing_range: 1,
        movement: Movement::NoCornerCutting,
        ..exact(1)
    };
    let w = World::new(diag, &[p(0, 0)], strict, 1).unwrap();
    // Reachable (0,0),(0,1),(1,0); from them radius 1 sees the three wall cells, and (1,1).
    let explorable: BTreeSet<Pos> = (0..9)
        .filter(|&k| w.explorable()[k])
        .map(|k| Pos::new(k as i32 / 3, k as i32 % 3))
        .collect();
    let want: BTreeSet<Pos> = [p(0, 0), p(0, 1), p(1, 0), p(1, 1), p(0, 2), p(2, 0)]
        .into_iter()
        .collect();
    assert_eq!(explorable, want);
}

// ---------------------------------------------------------------------------------------
// Contact and communication
// ---------------------------------------------------------------------------------------

fn comm_cfg(csp: f64) -> ScenarioConfig {
    ScenarioConfig {
        num_robots: 2,
        comm_success_prob: csp,
        ..exact(2)
    }
}

#[test]
fn full_csp_exchanges_every_step() {
    let mut w = World::new(open(12, 12), &[p(5, 3), p(5, 7)], comm_cfg(1.0), 1).unwrap();
    for t in 0..60 {
        assert_eq!(w.t(), t);
        assert_eq!(w.contacts(), &[(0, 1)]);
        assert_eq!(w.exchanges(), &[(0, 1)], "t = {t}");
        assert_eq!(w.observation(0).exchanged_with, vec![1]);
        assert_eq!(w.observation(1).exchanged_with, vec![0]);
        assert_eq!(w.observation(0).teammates, vec![(1, p(5, 7))]);
        assert_eq!(w.observation(1).teammates, vec![(0, p(5, 3))]);
        assert_eq!(w.dropout_remaining(0, 1), 0);
        w.step(&[Move::Stay, Move::Stay]);
    }
}

#[test]
fn zero_csp_never_exchanges_but_detects() {
    let mut w = World::new(open(12, 12), &[p(5, 3), p(6, 6)], comm_cfg(0.0), 1).unwrap();
    for t in 0..60 {
        assert_eq!(w.contacts(), &[(0, 1)], "t = {t}");
        assert!(w.exchanges().is_empty(), "t = {t}");
        assert_eq!(w.observation(0).teammates, vec![(1, p(6, 6))]);
        assert_eq!(w.observation(1).teammates, vec![(0, p(5, 3))]);
        assert!(w.observation(0).exchanged_with.is_empty());
        w.step(&[Move::Stay, Move::Stay]);
    }
}

#[test]
fn zero_csp_dropout_cycle_is_dropout_steps_long() {
    // Failures at t = 0, 8, 16, ...: each starts a dropout of 7 steps during which no
    // exchange is attempted, then the next attempt fails again.
    let mut w = World::new(open(12, 12), &[p(5, 3), p(5, 5)], comm_cfg(0.0), 1).unwrap();
    let mut remaining = Vec::new();
    for _ in 0..24 {
        remaining.push(w.dropout_remaining(0, 1));
        w.step(&[Move::Stay, Move::Stay]);
    }
    let cycle = [7, 6, 5, 4, 3, 2, 1, 0];
    let want: Vec<u32> = cycle.iter().cycle().take(24).copied().collect();
    assert_eq!(remaining, want);
}

#[test]
fn dropout_after_a_failure_lasts_exactly_dropout_steps() {
    let starts = [p(5, 3), p(5, 6)];
    let mut checked = 0;
    for seed in 0..200u64 {
        let mut w = World::new(open(12, 12), &starts, comm_cfg(0.5), seed).unwrap();
        // Find a step t with a failure: in contact, not exchanged, dropout just set to 7.
        let mut found = None;
        for _ in 0..20 {
            if w.exchanges().is_empty() && w.dropout_remaining(0, 1) == 7 {
                found = Some(w.t());
                break;
            }
            assert_eq!(
                w.exchanges(),
                &[(0, 1)],
                "with no dropout running an exchange either succeeds or fails"
            );
            w.step(&[Move::Stay, Move::Stay]);
        }
        let Some(t) = found else { continue };
        for k in 1..=7u32 {
            w.step(&[Move::Stay, Move::Stay]);
            assert_eq!(w.t(), t + k as usize);
            assert_eq!(w.contacts(), &[(0, 1)], "still in contact");
            assert!(
                w.exchanges().is_empty(),
                "seed {seed}: exchange during dropout at t + {k}"
            );
            assert_eq!(
                w.observation(0).teammates,
                vec![(1, starts[1])],
                "detection works during dropout"
            );
            assert_eq!(w.dropout_remaining(0, 1), 7 - k, "seed {seed}, t + {k}");
            assert_eq!(w.dropout_remaining(1, 0), 7 - k);
        }
        // t + 8: the pair tries again: either it exchanges or a new dropout starts.
        w.step(&[Move::Stay, Move::Stay]);
        let tried = w.exchanges() == [(0, 1)] || w.dropout_remaining(0, 1) == 7;
        assert!(
            tried,
            "seed {seed}: no exchange attempt at t + 8 (remaining {})",
            w.dropout_remaining(0, 1)
        );
        checked += 1;
        if checked >= 10 {
            break;
        }
    }
    assert!(checked >= 10, "too few seeds with a failure");
}

#[test]
fn dropout_counts_down_out_of_contact() {
    let cfg = ScenarioConfig {
        comm_success_prob: 0.0,
        ..comm_cfg(0.0)
    };
    let mut w = World::new(open(12, 12), &[p(5, 2), p(5, 6)], cfg, 1).unwrap();
    assert_eq!(w.dropout_remaining(0, 1), 7);
    w.step(&[Move::Stay, Move::E]); // now 5 apart: out of range
    assert!(w.contacts().is_empty());
    assert_eq!(w.dropout_remaining(0, 1), 6);
    for k in 2..=7 {
        w.step(&[Move::Stay, Move::Stay]);
        assert_eq!(w.dropout_remaining(0, 1), 7 - k);
    }
    assert_eq!(w.dropout_remaining(0, 1), 0);
}

#[test]
fn dropout_steps_config_is_used() {
    let cfg = ScenarioConfig {
        dropout_steps: 3,
        ..comm_cfg(0.0)
    };
    let mut w = World::new(open(12, 12), &[p(5, 3), p(5, 5)], cfg, 1).unwrap();
    let mut remaining = Vec::new();
    for _ in 0..9 {
        remaining.push(w.dropout_remaining(0, 1));
        w.step(&[Move::Stay, Move::Stay]);
    }
    assert_eq!(remaining, vec![3, 2, 1, 0, 3, 2, 1, 0, 3]);
}

#[test]
fn out_of_range_or_without_line_of_sight_never_talks() {
    // Chebyshev 5 > d_s = 4.
    for (a, b) in [(p(5, 1), p(5, 6)), (p(1, 1), p(6, 3)), (p(0, 0), p(5, 5))] {
        let mut w = World::new(open(12, 12), &[a, b], comm_cfg(1.0), 1).unwrap();
        for _ in 0..10 {
            assert!(
                w.contacts().is_empty() && w.exchanges().is_empty(),
                "{a} {b}"
            );
            assert!(w.observation(0).teammates.is_empty() && w.observation(1).teammates.is_empty());
            w.step(&[Move::Stay, Move::Stay]);
        }
    }
    // Chebyshev exactly 4: in contact.
    let w = World::new(open(12, 12), &[p(5, 1), p(9, 5)], comm_cfg(1.0), 1).unwrap();
    assert_eq!(w.exchanges(), &[(0, 1)]);
    // A wall between them.
    let walled = grid(&[
        "......#.....",
        "......#.....",
        "......#.....",
        "......#.....",
        "......#.....",
        "......#.....",
    ]);
    let mut w = World::new(walled.clone(), &[p(2, 4), p(2, 8)], comm_cfg(1.0), 1).unwrap();
    for _ in 0..10 {
        assert!(w.contacts().is_empty() && w.exchanges().is_empty());
        assert!(w.observation(0).teammates.is_empty());
        w.step(&[Move::Stay, Move::Stay]);
    }
    assert!(!line_of_sight(
        |q| !walled.is_free(q),
        p(2, 4),
        p(2, 8),
        Movement::CornerCutting
    ));
}

#[test]
fn diagonal_squeeze_blocks_contact_only_without_corner_cutting() {
    let truth = grid(&["......", "..#...", "...#..", "......", "......"]);
    // The ray (0,4) -> (3,1) is a pure diagonal through (1,3), (2,2); its step (1,3) -> (2,2)
    // squeezes between the obstacles (1,2) and (2,3).
    let (a, b) = (p(0, 4), p(3, 1));
    let cut = World::new(
        truth.clone(),
        &[a, b],
        ScenarioConfig {
            movement: Movement::CornerCutting,
            ..comm_cfg(1.0)
        },
        1,
    )
    .unwrap();
    assert_eq!(cut.contacts(), &[(0, 1)]);
    let strict = World::new(
        truth,
        &[a, b],
        ScenarioConfig {
            movement: Movement::NoCornerCutting,
            ..comm_cfg(1.0)
        },
        1,
    )
    .unwrap();
    assert!(strict.contacts().is_empty());
    assert!(strict.observation(0).teammates.is_empty());
}

// ---------------------------------------------------------------------------------------
// Determinism
// ---------------------------------------------------------------------------------------

#[derive(Debug, PartialEq)]
struct Snapshot {
    positions: Vec<Pos>,
    obs: Vec<madenet_world::Observation>,
    team_map: Vec<Occupancy>,
    exchanges: Vec<(usize, usize)>,
    executed: Vec<Move>,
    distances: Vec<f64>,
    dropout: u32,
}

fn run_world(seed: u64, intents_seed: u64) -> Vec<Snapshot> {
    let mut gen = GeneratorConfig::for_size(20, 20);
    gen.keep_free = vec![p(0, 0), p(1, 0), p(0, 1)];
    let truth = generate_with_movement(&gen, 77, Movement::CornerCutting).unwrap();
    let cfg = ScenarioConfig {
        comm_success_prob: 0.5,
        ..Default::default()
    };
    let mut w = World::new(truth, &gen.keep_free, cfg, seed).unwrap();
    let mut rng = stream(intents_seed, "test/intents", 0);
    let mut out = Vec::new();
    for _ in 0..50 {
        let intents: Vec<Move> = (0..3).map(|_| Move::ALL[rng.random_range(0..9)]).collect();
        w.step(&intents);
        out.push(Snapshot {
            positions: w.positions().to_vec(),
            obs: (0..3).map(|i| w.observation(i).clone()).collect(),
            team_map: w.team_map().to_vec(),
            exchanges: w.exchanges().to_vec(),
            executed: w.executed_moves().to_vec(),
            distances: w.distances().to_vec(),
            dropout: w.dropout_remaining(0, 1)
                + 100 * w.dropout_remaining(0, 2)
                + 10_000 * w.dropout_remaining(1, 2),
        });
    }
    out
}

#[test]
fn same_seed_same_world_different_seed_differs() {
    let a = run_world(5, 1);
    let b = run_world(5, 1);
    assert_eq!(a, b);
    let c = run_world(6, 1);
    assert_ne!(a, c);
    // Positions alone differ too (slip with p = 0.1 over 150 robot-steps).
    assert!(a
        .iter()
        .zip(&c)
        .any(|(x, y)| x.positions != y.positions || x.obs != y.obs));
    // Cloning mid-trial continues identically.
    let mut gen = GeneratorConfig::for_size(20, 20);
    gen.keep_free = vec![p(0, 0), p(1, 0), p(0, 1)];
    let truth = generate_with_movement(&gen, 77, Movement::CornerCutting).unwrap();
    let mut w = World::new(truth, &gen.keep_free, ScenarioConfig::default(), 3).unwrap();
    for _ in 0..5 {
        w.step(&[Move::E, Move::S, Move::SE]);
    }
    let mut w2 = w.clone();
    for _ in 0..20 {
        w.step(&[Move::SE, Move::E, Move::S]);
        w2.step(&[Move::SE, Move::E, Move::S]);
        assert_eq!(w.positions(), w2.positions());
        assert_eq!(w.team_map(), w2.team_map());
    }
}

// ---------------------------------------------------------------------------------------
// ScenarioConfig validation
// ---------------------------------------------------------------------------------------

#[test]
fn every_invalid_field_is_named() {
    type Edit = fn(&mut ScenarioConfig);
    let cases: Vec<(&str, Edit)> = vec![
        ("num_robots", |c| c.num_robots = 0),
        ("sensing_range", |c| c.sensing_range = 0),
        ("sensing_range", |c| c.sensing_range = -3),
        ("sensor_miss_prob", |c| c.sensor_miss_prob = -0.01),
        ("sensor_miss_prob", |c| c.sensor_miss_prob = 1.5),
        ("sensor_miss_prob", |c| c.sensor_miss_prob = f64::NAN),
        ("motion_success_prob", |c| c.motion_success_prob = -1.0),
        ("motion_success_prob", |c| c.motion_success_prob = 1.0001),
        ("motion_success_prob", |c| c.motion_success_prob = f64::NAN),
        ("comm_success_prob", |c| c.comm_success_prob = 2.0),
        ("comm_success_prob", |c| c.comm_success_prob = f64::NAN),
        ("comm_success_prob", |c| {
            c.comm_success_prob = f64::NEG_INFINITY
        }),
        ("step_cap", |c| c.step_cap = 0),
        ("cell_size", |c| c.cell_size = 0.0),
        ("cell_size", |c| c.cell_size = -1.0),
        ("cell_size", |c| c.cell_size = f64::NAN),
        ("cell_size", |c| c.cell_size = f64::INFINITY),
        ("discretize.occupied_prob", |c| {
            c.discretize.occupied_prob = 1.2
        }),
        ("discretize.occupied_prob", |c| {
            c.discretize.occupied_prob = f64::NAN
        }),
        ("discretize.obstacle_fraction", |c| {
            c.discretize.obstacle_fraction = -0.5
        }),
        ("goal_count", |c| c.goal_count = Some(0)),
        ("plan_horizon", |c| c.plan_horizon = 0),
    ];
    for (field, edit) in &cases {
        let mut cfg = ScenarioConfig::default();
        cfg.validate().expect("defaults are valid");
        edit(&mut cfg);
        let e = cfg.validate().expect_err(field).to_string();
        assert!(
            e.contains(&format!("`{field}`")),
            "error for {field} does not name it: {e}"
        );
        // Every other field name is absent (the message names the right field only).
        for (other, _) in &cases {
            if other != field && !field.contains(other) && !other.contains(field) {
                assert!(!e.contains(other), "error for {field} names {other}: {e}");
            }
        }
        // The world refuses it too, with the same field name.
        let err = World::new(open(10, 10), &[p(0, 0), p(0, 1), p(0, 2)], cfg.clone(), 1)
            .expect_err("World::new accepts an invalid config");
        assert!(err.to_string().contains(field), "{err}");
    }
    // Edge values are valid.
    for edit in [
        (|c: &mut ScenarioConfig| c.sensor_miss_prob = 1.0) as Edit,
        |c| c.sensor_miss_prob = 0.0,
        |c| c.comm_success_prob = 0.0,
        |c| c.motion_success_prob = 0.0,
        |c| c.dropout_steps = 0,
        |c| c.step_cap = 1,
        |c| c.goal_count = Some(1),
        |c| c.plan_horizon = 1,
        |c| c.num_robots = 1,
        |c| c.sensing_range = 1,
    ] {
        let mut cfg = ScenarioConfig::default();
        edit(&mut cfg);
        cfg.validate().unwrap();
    }
}

#[test]
fn toml_errors_name_the_field() {
    for (text, field) in [
        ("num_robots = 0", "num_robots"),
        ("sensing_range = 0", "sensing_range"),
        ("sensor_miss_prob = 1.1", "sensor_miss_prob"),
        ("motion_success_prob = -0.2", "motion_success_prob"),
        ("comm_success_prob = 7", "comm_success_prob"),
        ("step_cap = 0", "step_cap"),
        ("cell_size = 0.0", "cell_size"),
        ("goal_count = 0", "goal_count"),
        ("plan_horizon = 0", "plan_horizon"),
        (
            "[discretize]\noccupied_prob = 3.0",
            "discretize.occupied_prob",
        ),
        ("dropout_step = 3", "dropout_step"),
    ] {
        let e = ScenarioConfig::from_toml_str(text)
            .expect_err(text)
            .to_string();
        assert!(
            e.contains(field),
            "TOML {text:?}: error does not name {field}: {e}"
        );
    }
    let cfg =
        ScenarioConfig::from_toml_str("movement = \"no-corner-cutting\"\ncomm_success_prob = 0.5")
            .unwrap();
    assert_eq!(cfg.movement, Movement::NoCornerCutting);
    assert_eq!(cfg.comm_success_prob, 0.5);
    assert_eq!(cfg.num_robots, 3);
}

#[test]
fn toml_type_errors_name_the_field() {
    let mut unnamed = Vec::new();
    for (text, field) in [
        ("movement = \"teleport\"", "movement"),
        ("num_robots = -1", "num_robots"),
        ("step_cap = \"x\"", "step_cap"),
        ("sensor_miss_prob = true", "sensor_miss_prob"),
        ("[discretize]\noccupied_prob = \"high\"", "occupied_prob"),
    ] {
        let e = ScenarioConfig::from_toml_str(text)
            .expect_err(text)
            .to_string();
        if !e.contains(field) {
            unnamed.push(format!("{text:?} -> {e}"));
        }
    }
    assert!(
        unnamed.is_empty(),
        "errors not naming their field:\n{}",
        unnamed.join("\n")
    );
}

#[test]
fn start_errors_are_reported() {
    let truth = grid(&["..#", "...", "..."]);
    let e = World::new(truth.clone(), &[p(0, 0), p(0, 2), p(1, 1)], exact(3), 1)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("not free") && e.contains("robot 1"), "{e}");
    let e = World::new(truth.clone(), &[p(0, 0), p(0, 0), p(1, 1)], exact(3), 1)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("shared"), "{e}");
    let e = World::new(truth.clone(), &[p(0, 0), p(5, 0), p(1, 1)], exact(3), 1)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("outside"), "{e}");
    let e = World::new(truth, &[p(0, 0)], exact(3), 1)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("num_robots"), "{e}");
}
