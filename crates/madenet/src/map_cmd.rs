//! `madenet map`: convert, generate and show maps.

use anyhow::{Context, Result};
use clap::Subcommand;
use madenet_map::floorplan::{floor_plan, FloorPlanConfig};
use madenet_map::generate::{generate, is_connected, GeneratorConfig};
use madenet_map::io::{save, to_text};
use madenet_map::Occupancy;
use madenet_sim::MapSource;
use std::path::PathBuf;

#[derive(Subcommand, Debug)]
pub enum MapCommand {
    /// Convert a map between formats (by extension: .yaml/.yml, .pgm, .png, .txt/.map).
    Convert {
        /// Input map: a file, `paper:N` or `generate:SEED`.
        input: MapSource,
        output: PathBuf,
        /// Scenario config whose `cell_size` and `discretize` rule apply when reading.
        #[arg(long)]
        config: Option<PathBuf>,
    },
    /// Generate a random map.
    Generate {
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Rows.
        #[arg(long, default_value_t = 20)]
        height: usize,
        /// Columns.
        #[arg(long, default_value_t = 20)]
        width: usize,
        /// Minimum obstacle density.
        #[arg(long, default_value_t = 0.15)]
        density_min: f64,
        /// Maximum obstacle density.
        #[arg(long, default_value_t = 0.40)]
        density_max: f64,
        /// A floor plan (rooms, doors, corridors, some furniture: `madenet_map::floorplan`)
        /// instead of scattered obstacles (the densities do not apply).
        #[arg(long)]
        floorplan: bool,
        /// With `--floorplan`: cells kept free (`r,c;r,c;…`, e.g. robots' start cells; default:
        /// the 12 corner start cells).
        #[arg(long, value_name = "CELLS", requires = "floorplan")]
        keep_free: Option<madenet_sim::StartSpec>,
        /// Output file (format by extension).
        output: PathBuf,
    },
    /// Print a map as text with its statistics.
    Show {
        /// A file, `paper:N` or `generate:SEED`.
        input: MapSource,
        #[arg(long)]
        config: Option<PathBuf>,
    },
}

pub fn run(c: MapCommand) -> Result<()> {
    match c {
        MapCommand::Convert {
            input,
            output,
            config,
        } => {
            let outputs: Vec<_> = (madenet_map::io::files_written(&output).into_iter())
                .map(|f| ("output", f))
                .collect();
            let mut inputs = crate::clashes::map_inputs("input", &input);
            inputs.extend(crate::clashes::given("--config", config.as_ref()));
            crate::clashes::refuse_clashes(&outputs, &inputs)?;
            let cfg = madenet_world::ScenarioConfig::from_toml_file_or_default(config.as_deref())?;
            let grid = input.load(&cfg)?;
            // Read into cells of `cell_size`, thin walls may vanish: say so, as `run` does.
            if let Some(w) = input.erasure_warning(&cfg)? {
                say!("warning: {w}");
            }
            save(&grid, &output)?;
            out!(
                "wrote {} ({}×{})",
                output.display(),
                grid.height(),
                grid.width()
            )?;
        }
        MapCommand::Generate {
            seed,
            height,
            width,
            density_min,
            density_max,
            floorplan,
            keep_free,
            output,
        } => {
            let grid = if floorplan {
                let mut cfg = FloorPlanConfig::for_size(height, width);
                match keep_free {
                    Some(madenet_sim::StartSpec::Cells(cells)) => cfg.keep_free = cells,
                    Some(_) => anyhow::bail!("--keep-free: cells `r,c;r,c;…`"),
                    None => {}
                }
                floor_plan(&cfg, seed).context("map generate --floorplan")?
            } else {
                let cfg = GeneratorConfig {
                    density_min,
                    density_max,
                    ..GeneratorConfig::for_size(height, width)
                };
                generate(&cfg, seed).context("map generate")?
            };
            save(&grid, &output)?;
            out!(
                "wrote {} ({}×{}, obstacle density {:.2})",
                output.display(),
                height,
                width,
                grid.obstacle_density()
            )?;
        }
        MapCommand::Show { input, config } => {
            let cfg = madenet_world::ScenarioConfig::from_toml_file_or_default(config.as_deref())?;
            let grid = input.load(&cfg)?;
            if let Some(w) = input.erasure_warning(&cfg)? {
                say!("warning: {w}");
            }
            crate::write_out(format_args!("{}", to_text(&grid)))?;
            out!(
                "{}: {}×{} cells of {} m, {} free, {} obstacle, {} unknown, density {:.3}, free space connected: {}",
                input.name(),
                grid.height(),
                grid.width(),
                grid.resolution,
                grid.count(Occupancy::Free),
                grid.count(Occupancy::Obstacle),
                grid.count(Occupancy::Unknown),
                grid.obstacle_density(),
                is_connected(&grid)
            )?;
        }
    }
    Ok(())
}
