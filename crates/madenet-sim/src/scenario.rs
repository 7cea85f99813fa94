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
/// training range; the corner start cells kept free) or a file path.
#[derive(Clone, Debug, PartialEq)]
pub enum MapSource {
    Paper(usize),
    Generated(u64),
    GeneratedWide(u64),
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
        } else if let Some(seed) = s.strip_prefix("generate:") {
            seed.parse()
                .map(MapSource::Generated)
                .map_err(|_| format!("`{s}`: expected generate:SEED with an integer seed"))
        } else {
            Ok(MapSource::File(PathBuf::from(s)))
        }
    }
}

impl MapSource {
    /// Loads or generates the map (discretized to the config's cell size).
    pub fn load(&self, cfg: &ScenarioConfig) -> Result<OccGrid, MapError> {
        match self {
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
            MapSource::File(p) => load(
                p,
                &LoadOptions {
                    cell_size: cfg.cell_size,
                    discretize: cfg.discretize,
                },
            ),
        }
    }

    /// A short label for outputs.
    pub fn name(&self) -> String {
        match self {
            MapSource::Paper(n) => paper_map_name(*n),
            MapSource::Generated(seed) => format!("generated_{seed}"),
            MapSource::GeneratedWide(seed) => format!("generated_wide_{seed}"),
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
    Corner(Corner),
    Cells(Vec<Pos>),
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

#[cfg(test)]
mod tests {
    use super::*;

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
