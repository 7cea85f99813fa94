//! Naming a scenario on a command line or in a config: where the map comes from and where
//! the robots start.

use madenet_map::generate::{
    generate, generate_with_movement, random_starts, GeneratorConfig, WIDE_DENSITY,
};
use madenet_map::io::{load, LoadOptions};
use madenet_map::paper::{paper_map, paper_map_name, Corner, PAPER_MAP_COUNT};
use madenet_map::{MapError, OccGrid, Pos};
use madenet_world::ScenarioConfig;
use std::path::PathBuf;
use std::str::FromStr;

/// Where a map comes from: `paper:N` (the paper's evaluation map N, embedded),
/// `generate:SEED` (the seeded generator at its defaults: 15–40 % obstacles),
/// `generate-wide:SEED` (the generator at [`WIDE_DENSITY`], 15–60 %, the learned policy's
/// training range; the corner start cells kept free), `floorplan:SEED` (rooms and corridors)
/// or a file path.
#[derive(Clone, Debug, PartialEq)]
pub enum MapSource {
    /// `paper:N`: the paper's evaluation map N (Fig. 3), N in 1..=[`PAPER_MAP_COUNT`].
    Paper(usize),
    /// `generate:SEED`: the generator at its default densities, with this seed.
    Generated(u64),
    /// `generate-wide:SEED`: the generator at [`WIDE_DENSITY`], with this seed.
    GeneratedWide(u64),
    /// `floorplan:SEED`: a 20 × 20 floor plan (rooms, doors, corridors, some furniture) of
    /// [`madenet_map::floorplan`], its look drawn from the seed ([`madenet_map::floorplan::varied`]).
    FloorPlan(u64),
    /// A map file (ROS `map_server` YAML, PGM, PNG or a plain-text grid).
    File(PathBuf),
}

impl FromStr for MapSource {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if let Some(n) = s.strip_prefix("paper:") {
            let n: usize = n
                .parse()
                .map_err(|_| format!("`{s}`: expected paper:N with N in 1..={PAPER_MAP_COUNT}"))?;
            if !(1..=PAPER_MAP_COUNT).contains(&n) {
                return Err(format!("`{s}`: the paper has maps 1..={PAPER_MAP_COUNT}"));
            }
            Ok(MapSource::Paper(n))
        } else if let Some(seed) = s.strip_prefix("generate-wide:") {
            seed.parse()
                .map(MapSource::GeneratedWide)
                .map_err(|_| format!("`{s}`: expected generate-wide:SEED with an integer seed"))
        } else if let Some(seed) = s.strip_prefix("floorplan:") {
            seed.parse()
                .map(MapSource::FloorPlan)
                .map_err(|_| format!("`{s}`: expected floorplan:SEED with an integer seed"))
        } else if let Some(seed) = s.strip_prefix("generate:") {
            seed.parse()
                .map(MapSource::Generated)
                .map_err(|_| format!("`{s}`: expected generate:SEED with an integer seed"))
        } else {
            Ok(MapSource::File(PathBuf::from(s)))
        }
    }
}

/// The form [`MapSource::from_str`] reads (`paper:3`, `floorplan:7`, a path).
impl std::fmt::Display for MapSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MapSource::Paper(n) => write!(f, "paper:{n}"),
            MapSource::Generated(seed) => write!(f, "generate:{seed}"),
            MapSource::GeneratedWide(seed) => write!(f, "generate-wide:{seed}"),
            MapSource::FloorPlan(seed) => write!(f, "floorplan:{seed}"),
            MapSource::File(p) => write!(f, "{}", p.display()),
        }
    }
}

impl MapSource {
    /// The true geometry of this map for the continuous world: a map file at its native
    /// resolution (one pixel per obstacle square: thin walls stay thin), a paper map's 1 m
    /// cells, for `generate:SEED` / `generate-wide:SEED` the continuous world's generator of
    /// cluttered `side` × `side` metre worlds (bookshelves, bins, cylinders) with this seed, or
    /// for `floorplan:SEED` a `side` × `side` metre floor plan of 1 m wall squares.
    pub fn scene(&self, side: f64) -> Result<madenet_continuous::Scene, MapError> {
        use madenet_continuous::{scene::generate_cluttered, Scene};
        Ok(match self {
            MapSource::Paper(n) => Scene::from_grid(&paper_map(*n)?, &format!("paper:{n}")),
            MapSource::Generated(seed) | MapSource::GeneratedWide(seed) => {
                generate_cluttered(side, 0.1, *seed)
            }
            MapSource::FloorPlan(seed) => {
                // A floor plan of side × side 1 m cells: walls as cell squares.
                let n = (side.round() as usize).max(8);
                let cfg = madenet_map::floorplan::varied(n, n, *seed);
                // Squares touching at a corner leave no gap: connected without corner cuts.
                let grid = madenet_map::floorplan::floor_plan_with_movement(
                    &cfg,
                    *seed,
                    madenet_map::Movement::NoCornerCutting,
                )?;
                Scene::from_grid(&grid, &format!("floorplan:{seed}"))
            }
            MapSource::File(p) => {
                let resolution = madenet_map::io::native_resolution(p)?;
                let grid = load(
                    p,
                    &LoadOptions {
                        cell_size: resolution,
                        discretize: Default::default(),
                    },
                )?;
                Scene::from_grid(&grid, &p.display().to_string())
            }
        })
    }

    /// For a map file finer than the config's cells: a warning when the discretization erased
    /// most of its obstacles ([`madenet_map::discretize::Erasure::warning`]). Reads the file
    /// again at its native resolution; `None` for built-in maps and maps the rule kept.
    pub fn erasure_warning(&self, cfg: &ScenarioConfig) -> Result<Option<String>, MapError> {
        let MapSource::File(p) = self else {
            return Ok(None);
        };
        let resolution = madenet_map::io::native_resolution(p)?;
        if resolution >= cfg.cell_size {
            return Ok(None);
        }
        let native = LoadOptions {
            cell_size: resolution,
            discretize: cfg.discretize,
        };
        let fine = load(p, &native)?;
        let coarse = self.load(cfg)?;
        let e = madenet_map::discretize::erasure(&fine, &coarse);
        Ok(e.warning(&p.display().to_string(), &cfg.discretize))
    }

    /// Loads or generates the map (discretized to the config's cell size).
    pub fn load(&self, cfg: &ScenarioConfig) -> Result<OccGrid, MapError> {
        let builtin = match self {
            MapSource::Paper(n) => paper_map(*n),
            MapSource::Generated(seed) => generate(&GeneratorConfig::default(), *seed),
            MapSource::GeneratedWide(seed) => {
                let gen = GeneratorConfig {
                    density_min: WIDE_DENSITY.0,
                    density_max: WIDE_DENSITY.1,
                    ..GeneratorConfig::default()
                };
                generate_with_movement(&gen, *seed, cfg.movement)
            }
            MapSource::FloorPlan(seed) => madenet_map::floorplan::floor_plan_with_movement(
                &madenet_map::floorplan::varied(20, 20, *seed),
                *seed,
                cfg.movement,
            ),
            MapSource::File(p) => {
                return load(
                    p,
                    &LoadOptions {
                        cell_size: cfg.cell_size,
                        discretize: cfg.discretize,
                    },
                )
            }
        }?;
        // Built-in maps are grids of 1 m cells, read at the robot cell size like a map file.
        madenet_map::discretize::coarsen(
            &builtin,
            cfg.cell_size,
            &cfg.discretize,
            &self.to_string(),
        )
    }

    /// A short label for outputs.
    pub fn name(&self) -> String {
        match self {
            MapSource::Paper(n) => paper_map_name(*n),
            MapSource::Generated(seed) => format!("generated_{seed}"),
            MapSource::GeneratedWide(seed) => format!("generated_wide_{seed}"),
            MapSource::FloorPlan(seed) => format!("floorplan_{seed}"),
            MapSource::File(p) => p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| p.display().to_string()),
        }
    }
}

/// Where the robots start: one of the paper's corners, explicit cells `r,c;r,c;…`, or `random`
/// (the free cells nearest to a free cell drawn from the map itself, [`random_starts`]: the same
/// map always gives the same cells).
#[derive(Clone, Debug, PartialEq)]
pub enum StartSpec {
    /// The three cells at one of the map's corners (paper Fig. 3), [`Corner::start_cells`].
    Corner(Corner),
    /// Explicit cells, one per robot, written `r,c;r,c;…`.
    Cells(Vec<Pos>),
    /// `random`: cells drawn from the map itself, the same for the same map.
    Random,
}

impl FromStr for StartSpec {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "random" {
            return Ok(StartSpec::Random);
        }
        if s.contains(',') {
            let cells = s
                .split(';')
                .map(|cell| {
                    let mut it = cell.split(',').map(|v| v.trim().parse::<i32>());
                    match (it.next(), it.next(), it.next()) {
                        (Some(Ok(r)), Some(Ok(c)), None) => Ok(Pos::new(r, c)),
                        _ => Err(format!("`{cell}` is not a cell `row,col`")),
                    }
                })
                .collect::<Result<Vec<_>, _>>()?;
            Ok(StartSpec::Cells(cells))
        } else {
            Corner::from_str(s)
                .map(StartSpec::Corner)
                .map_err(|e| e.to_string())
        }
    }
}

impl StartSpec {
    /// The start cells of `team` robots on `map` (corner and explicit starts ignore the team
    /// size: a trial checks it). Empty for `random` when the drawn cell's connected free area
    /// holds fewer than `team` cells (callers say so naming `random`).
    pub fn cells(&self, map: &OccGrid, team: usize, movement: madenet_map::Movement) -> Vec<Pos> {
        match self {
            StartSpec::Corner(c) => c.start_cells(map.height(), map.width()).to_vec(),
            StartSpec::Cells(v) => v.clone(),
            StartSpec::Random => {
                // The map's own cells seed the draw (FNV-1a), so every method meets the same starts.
                let seed = map.cells().iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &c| {
                    (h ^ c as u64).wrapping_mul(0x0100_0000_01b3)
                });
                random_starts(map, team, movement, seed).unwrap_or_default()
            }
        }
    }

    /// [`StartSpec::cells`] in a continuous world of `scene`, read as `scenario`'s cells, for
    /// robots of `robot_radius` metres: a picked start (`random`) is a cell where the footprint
    /// fits ([`madenet_continuous::Scene::start_cells`]), so the world never refuses it.
    pub fn continuous_cells(
        &self,
        scene: &madenet_continuous::Scene,
        scenario: &madenet_world::ScenarioConfig,
        robot_radius: f64,
    ) -> Vec<Pos> {
        let startable = scene.start_cells(scenario.cell_size, &scenario.discretize, robot_radius);
        self.cells(&startable, scenario.num_robots, scenario.movement)
    }

    /// Refuses explicit cells whose count is not the team size (`team` robots); corners and
    /// `random` always fit. The message names the start as written and both counts.
    pub fn check_team(&self, team: usize) -> Result<(), String> {
        match self {
            StartSpec::Cells(cells) if cells.len() != team => Err(format!(
                "`{}` gives {} cells for {} robots (num_robots)",
                self.name(),
                cells.len(),
                team
            )),
            _ => Ok(()),
        }
    }

    /// The start as written on a command line (`top-left`, `0,0;1,2`, `random`).
    pub fn name(&self) -> String {
        match self {
            StartSpec::Corner(c) => c.name().to_string(),
            StartSpec::Cells(v) => v
                .iter()
                .map(|p| format!("{},{}", p.row, p.col))
                .collect::<Vec<_>>()
                .join(";"),
            StartSpec::Random => "random".to_string(),
        }
    }
}

/// Most trials one trial set (a study, `madenet batch`, `madenet oracle`) may plan: every
/// planned and finished trial is held in memory (a few KB each, with its curves).
pub const MAX_TRIALS: u64 = 100_000;
/// Most map cells the plan of one trial set may hold in all (each planned trial carries its
/// map: 2³⁰ cells ≈ 1 GB).
pub const MAX_PLANNED_CELLS: u64 = 1 << 30;

/// Checks the size of a trial set of `runs` × (`cells` per map, one entry per map) × `starts`
/// × `csps` × `seeds` trials against [`MAX_TRIALS`] and [`MAX_PLANNED_CELLS`]; the error says
/// how many trials it would be and the bound.
pub fn check_trial_set_size(
    runs: u64,
    cells: &[u64],
    starts: u64,
    csps: u64,
    seeds: u64,
) -> Result<(), String> {
    let per_map = runs
        .checked_mul(starts)
        .and_then(|v| v.checked_mul(csps))
        .and_then(|v| v.checked_mul(seeds));
    let trials = per_map.and_then(|p| p.checked_mul(cells.len() as u64));
    let planned_cells = per_map.and_then(|p| {
        cells
            .iter()
            .try_fold(0u64, |acc, &c| acc.checked_add(p.checked_mul(c)?))
    });
    let describe = || match trials {
        Some(t) => format!("{t} trials"),
        None => "more than 2^64 trials".to_string(),
    };
    if trials.is_none_or(|t| t > MAX_TRIALS) {
        return Err(format!(
            "{} ({runs} runs × {} maps × {starts} starts × {csps} CSPs × {seeds} seeds): at most {MAX_TRIALS} trials per set; split it into several",
            describe(),
            cells.len()
        ));
    }
    if planned_cells.is_none_or(|c| c > MAX_PLANNED_CELLS) {
        return Err(format!(
            "{} on these maps hold more than {MAX_PLANNED_CELLS} map cells in all; use fewer seeds or smaller maps",
            describe()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]
        /// The program's own start pickers in the continuous world (`--start random`, the
        /// scalability study's start areas) only pick starts the world accepts, over the
        /// accepted team sizes, on cluttered scenes and floor plans (issue 59).
        #[test]
        fn picked_continuous_starts_are_accepted(
            side in 12usize..=40,
            seed in any::<u64>(),
            team in 1usize..=48,
            plan in any::<bool>(),
            anchor in 0usize..3,
        ) {
            use madenet_continuous::{ContinuousConfig, ContinuousWorld, Scene};
            let continuous = ContinuousConfig::default();
            let mut scenario = ScenarioConfig { num_robots: team, ..ScenarioConfig::default() };
            let scene = if plan {
                let cfg = madenet_map::floorplan::FloorPlanConfig::for_size(side, side);
                let grid = madenet_map::floorplan::floor_plan(&cfg, seed).unwrap();
                Scene::from_grid(&grid, "plan")
            } else {
                madenet_continuous::scene::generate_cluttered(side as f64, 0.1, seed)
            };
            let radius = continuous.robot.radius;
            let startable = scene.start_cells(scenario.cell_size, &scenario.discretize, radius);
            let near = [Pos::new(side as i32 - 2, 1), Pos::new(1, side as i32 - 2), Pos::new(side as i32 / 2, side as i32 / 2)][anchor];
            let picks = [
                StartSpec::Random.continuous_cells(&scene, &scenario, radius),
                madenet_map::generate::starts_near(&startable, near, team, scenario.movement).unwrap_or_default(),
            ];
            for starts in picks.into_iter().filter(|s| !s.is_empty()) {
                scenario.num_robots = starts.len();
                let world = ContinuousWorld::new(std::sync::Arc::new(scene.clone()), &starts, scenario.clone(), continuous, 1);
                prop_assert!(world.is_ok(), "{starts:?}: {}", world.err().unwrap());
            }
        }
    }

    #[test]
    fn built_in_maps_are_read_at_the_robot_cell_size() {
        // One meaning of cell_size: built-in maps (1 m cells) are merged like a map file.
        let mut cfg = madenet_world::ScenarioConfig::default();
        let one = MapSource::Paper(3).load(&cfg).unwrap();
        assert_eq!((one.height(), one.width(), one.resolution), (20, 20, 1.0));
        cfg.cell_size = 2.0;
        for source in [MapSource::Paper(3), MapSource::Generated(5)] {
            let two = source.load(&cfg).unwrap();
            assert_eq!((two.height(), two.width(), two.resolution), (10, 10, 2.0));
        }
        // A 2 m cell is an obstacle when more than the discretize fraction of its four 1 m
        // cells are: check against the 1 m map.
        let two = MapSource::Paper(3).load(&cfg).unwrap();
        for r in 0..10 {
            for c in 0..10 {
                let blocked = (0..4)
                    .filter(|k| {
                        one.get(madenet_map::Pos::new(2 * r + k / 2, 2 * c + k % 2))
                            == madenet_map::Occupancy::Obstacle
                    })
                    .count() as f64;
                assert_eq!(
                    two.get(madenet_map::Pos::new(r, c)) == madenet_map::Occupancy::Obstacle,
                    blocked / 4.0 > cfg.discretize.obstacle_fraction,
                    "cell {r},{c}"
                );
            }
        }
        cfg.cell_size = 1.5;
        let e = MapSource::Paper(3).load(&cfg).unwrap_err().to_string();
        assert!(e.contains("paper:3") && e.contains("cell_size"), "{e}");
    }

    #[test]
    fn parse_sources_and_starts() {
        assert_eq!("paper:3".parse::<MapSource>().unwrap(), MapSource::Paper(3));
        assert!("paper:11".parse::<MapSource>().is_err());
        assert_eq!(
            "generate:7".parse::<MapSource>().unwrap(),
            MapSource::Generated(7)
        );
        assert_eq!(
            "maps/x.yaml".parse::<MapSource>().unwrap(),
            MapSource::File("maps/x.yaml".into())
        );
        assert_eq!(
            "top-left".parse::<StartSpec>().unwrap(),
            StartSpec::Corner(Corner::TopLeft)
        );
        assert_eq!(
            "0,0; 1,2".parse::<StartSpec>().unwrap(),
            StartSpec::Cells(vec![Pos::new(0, 0), Pos::new(1, 2)])
        );
        assert!("0,0;x".parse::<StartSpec>().is_err());
        assert!("middle".parse::<StartSpec>().is_err());
        assert_eq!("random".parse::<StartSpec>().unwrap(), StartSpec::Random);
        assert_eq!(
            "generate-wide:9".parse::<MapSource>().unwrap(),
            MapSource::GeneratedWide(9)
        );
        for s in [
            "paper:3",
            "generate:4",
            "generate-wide:5",
            "floorplan:6",
            "maps/x.yaml",
        ] {
            assert_eq!(s.parse::<MapSource>().unwrap().to_string(), s);
        }
        assert!("floorplan:x".parse::<MapSource>().is_err());
        let plan = MapSource::FloorPlan(6)
            .load(&ScenarioConfig::default())
            .unwrap();
        assert_eq!((plan.height(), plan.width()), (20, 20));
        assert!(madenet_map::generate::is_connected(&plan));
        let cfg = ScenarioConfig::default();
        let map = MapSource::GeneratedWide(9).load(&cfg).unwrap();
        let starts = StartSpec::Random.cells(&map, 3, cfg.movement);
        assert_eq!(starts.len(), 3);
        assert!(starts
            .iter()
            .all(|&p| map.get(p) == madenet_map::Occupancy::Free));
        assert_eq!(
            starts,
            StartSpec::Random.cells(&map, 3, cfg.movement),
            "the same map, the same starts"
        );
    }
}
