//! Naming a scenario on a command line or in a config: where the map comes from and where
//! the robots start.

use madenet_map::generate::{generate, GeneratorConfig};
use madenet_map::io::{load, LoadOptions};
use madenet_map::paper::{paper_map, paper_map_name, Corner, PAPER_MAP_COUNT};
use madenet_map::{MapError, OccGrid, Pos};
use madenet_world::ScenarioConfig;
use std::path::PathBuf;
use std::str::FromStr;

/// Where a map comes from: `paper:N` (the paper's evaluation map N, embedded),
/// `generate:SEED` (the seeded generator at its defaults) or a file path.
#[derive(Clone, Debug, PartialEq)]
pub enum MapSource {
    Paper(usize),
    Generated(u64),
    File(PathBuf),
}

impl FromStr for MapSource {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if let Some(n) = s.strip_prefix("paper:") {
            let n: usize = n.parse().map_err(|_| format!("`{s}`: expected paper:N with N in 1..={PAPER_MAP_COUNT}"))?;
            if !(1..=PAPER_MAP_COUNT).contains(&n) {
                return Err(format!("`{s}`: the paper has maps 1..={PAPER_MAP_COUNT}"));
            }
            Ok(MapSource::Paper(n))
        } else if let Some(seed) = s.strip_prefix("generate:") {
            seed.parse().map(MapSource::Generated).map_err(|_| format!("`{s}`: expected generate:SEED with an integer seed"))
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
            MapSource::File(p) => load(p, &LoadOptions { cell_size: cfg.cell_size, discretize: cfg.discretize }),
        }
    }

    /// A short label for outputs.
    pub fn name(&self) -> String {
        match self {
            MapSource::Paper(n) => paper_map_name(*n),
            MapSource::Generated(seed) => format!("generated_{seed}"),
            MapSource::File(p) => p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string()),
        }
    }
}

/// Where the robots start: one of the paper's corners, or explicit cells `r,c;r,c;…`.
#[derive(Clone, Debug, PartialEq)]
pub enum StartSpec {
    Corner(Corner),
    Cells(Vec<Pos>),
}

impl FromStr for StartSpec {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
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
            Corner::from_str(s).map(StartSpec::Corner).map_err(|e| e.to_string())
        }
    }
}

impl StartSpec {
    /// The start cells on a `height × width` map.
    pub fn cells(&self, height: usize, width: usize) -> Vec<Pos> {
        match self {
            StartSpec::Corner(c) => c.start_cells(height, width).to_vec(),
            StartSpec::Cells(v) => v.clone(),
        }
    }

    pub fn name(&self) -> String {
        match self {
            StartSpec::Corner(c) => c.name().to_string(),
            StartSpec::Cells(v) => v.iter().map(|p| format!("{},{}", p.row, p.col)).collect::<Vec<_>>().join(";"),
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
        assert_eq!("generate:7".parse::<MapSource>().unwrap(), MapSource::Generated(7));
        assert_eq!("maps/x.yaml".parse::<MapSource>().unwrap(), MapSource::File("maps/x.yaml".into()));
        assert_eq!("top-left".parse::<StartSpec>().unwrap(), StartSpec::Corner(Corner::TopLeft));
        assert_eq!(
            "0,0; 1,2".parse::<StartSpec>().unwrap(),
            StartSpec::Cells(vec![Pos::new(0, 0), Pos::new(1, 2)])
        );
        assert!("0,0;x".parse::<StartSpec>().is_err());
        assert!("middle".parse::<StartSpec>().is_err());
    }
}
