//! `madenet`: the command line of the madenet workspace. Thin by design: every command is a
//! few calls into the library crates (`madenet-sim` for trials, `madenet-map` for maps,
//! `madenet-render` for pictures).

mod batch;
mod frames;
mod map_cmd;
mod run;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "madenet", version, about = "Decentralized multi-robot exploration with macro actions (MADE-Net) — simulator, baselines and tools")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run one trial and print its metrics.
    Run(run::RunArgs),
    /// Run many trials (maps × starts × CSPs × seeds) in parallel and write a CSV.
    Batch(batch::BatchArgs),
    /// Convert, generate and show maps.
    #[command(subcommand)]
    Map(map_cmd::MapCommand),
    /// List the available policies.
    Policies,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(a) => run::run(a),
        Command::Batch(a) => batch::run(a),
        Command::Map(c) => map_cmd::run(c),
        Command::Policies => {
            for (name, about) in madenet_sim::PolicyRegistry::builtin().describe() {
                println!("{name:<10} {about}");
            }
            Ok(())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", one_line(&e));
            ExitCode::from(2)
        }
    }
}

/// The error and its causes on one line, skipping causes the message already quotes.
fn one_line(e: &anyhow::Error) -> String {
    let mut msg = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if msg.contains(&text) {
            continue;
        }
        if !msg.is_empty() {
            msg.push_str(": ");
        }
        msg.push_str(&text);
    }
    msg
}

/// Reads the scenario config file if given, else the paper's defaults.
pub fn load_config(path: Option<&std::path::Path>) -> anyhow::Result<madenet_world::ScenarioConfig> {
    Ok(match path {
        Some(p) => madenet_world::ScenarioConfig::from_toml_file(p)?,
        None => madenet_world::ScenarioConfig::default(),
    })
}
