//! `madenet`: the command line of the madenet workspace. Thin by design: every command is a
//! few calls into the library crates (`madenet-sim` for trials, `madenet-map` for maps,
//! `madenet-render` for pictures, `madenet-runtime` for trials as processes).

/// `println!` that returns the write error instead of panicking (e.g. on a closed pipe).
macro_rules! out {
    ($($arg:tt)*) => {
        crate::write_out(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// A line to stderr (messages, warnings, errors). Unlike `eprintln!`, a stderr that cannot be
/// written (`2>/dev/full`, a closed pipe) does not panic: the run goes on, and its exit code
/// says how it ended.
macro_rules! say {
    ($($arg:tt)*) => {
        crate::write_err(format_args!("{}\n", format_args!($($arg)*)))
    };
}

mod batch;
mod clashes;
mod compare;
mod map_cmd;
mod nodes;
mod oracle;
mod plot_training;
mod record;
mod run;
mod scale_cmd;
mod scenario_args;
mod train_cmd;

use anyhow::Result;
use clap::{Parser, Subcommand};
use madenet_runtime::signals::Interrupted;

use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "madenet",
    version,
    about = "Decentralized multi-robot exploration with macro actions (MADE-Net) — simulator, baselines and tools"
)]
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
    /// Run the paper's comparison study: trials, summary, statistics, figures, report.
    Compare(compare::CompareArgs),
    /// The scalability study (the paper's Fig. 7): exploration time against team size on maps of several sizes.
    Scale(scale_cmd::ScaleArgs),
    /// Convert, generate and show maps.
    #[command(subcommand)]
    Map(map_cmd::MapCommand),
    /// List the available policies.
    Policies,
    /// Train MADE-Net (paper or rollout-teacher), MADE-Net-DT or DME-DRL (logs, checkpoints, resume).
    Train(train_cmd::TrainArgs),
    /// Draw the training curves (the paper's Fig. 2) of a training run directory.
    PlotTraining(plot_training::PlotTrainingArgs),
    /// The rollout oracle (or its placebo) beside its base rule: the ceiling of candidate choice.
    Oracle(oracle::OracleArgs),
    /// One trial as 3 + robots processes over Zenoh on loopback (world, radio, one agent per robot).
    Launch(nodes::LaunchArgs),
    /// The world node of a run over processes: ground truth, motion, sensing, metrics.
    World(nodes::WorldArgs),
    /// The radio node of a run over processes: the paper's communication model, forwarding robot-to-robot messages.
    Radio(nodes::RadioArgs),
    /// One robot's node of a run over processes: belief, goal candidates, policy, navigator.
    Agent(nodes::AgentArgs),
    /// One robot's exploration node for a robot that nav2 drives (explore_lite's parameter file; its frontier choice; navigate_to_pose).
    Explore(madenet_explore::cli::ExploreArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(), // --help, --version
        Err(e) => {
            // clap's message on one line (its usage hints follow on later lines).
            let text = e.render().to_string();
            let first = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
            let first = first.strip_prefix("error: ").unwrap_or(first);
            say!("error: {first}");
            return ExitCode::from(2);
        }
    };
    // Warnings (an absent robot, a silent teammate, a model folder without digests) go to
    // stderr, one line each: ours at warn, Zenoh's own only when they are errors.
    let _ = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .without_time()
        .with_target(false)
        .with_ansi(false)
        // RUST_LOG, when set, replaces the default levels (`RUST_LOG=madenet_explore=debug`).
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
                tracing_subscriber::EnvFilter::new(
                    "error,madenet_runtime=warn,madenet=warn,madenet_learn=warn,madenet_dme=warn,madenet_explore=info",
                )
            }),
        )
        .try_init();
    let result = match cli.command {
        Command::Run(a) => run::run(a),
        Command::Batch(a) => batch::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Scale(a) => scale_cmd::run(a),
        Command::Map(c) => map_cmd::run(c),
        Command::PlotTraining(a) => plot_training::run(a),
        Command::Train(a) => train_cmd::run(a),
        Command::Oracle(a) => oracle::run(a),
        Command::Launch(a) => nodes::launch(a),
        Command::World(a) => nodes::world(a),
        Command::Radio(a) => nodes::radio(a),
        Command::Agent(a) => nodes::agent(a),
        Command::Explore(a) => madenet_explore::cli::run(a)
            .map_err(anyhow::Error::from_boxed)
            .and_then(|lines| {
                lines
                    .iter()
                    .try_for_each(|l| out!("{l}").map_err(Into::into))
            }),
        Command::Policies => madenet_catalogue::shipped()
            .map_err(Into::into)
            .and_then(|r| {
                r.describe().into_iter().try_for_each(|(name, about)| {
                    out!("{name:<12} {about}").map_err(anyhow::Error::from)
                })
            }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // A closed pipe (`madenet … | head`) is a normal end, not an error.
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) if e.downcast_ref::<Interrupted>().is_some() => {
            say!("{e}");
            ExitCode::from(
                e.downcast_ref::<Interrupted>()
                    .map_or(2, Interrupted::exit_code),
            )
        }
        Err(e) => {
            say!("error: {}", one_line(&e));
            ExitCode::from(2)
        }
    }
}

/// Writes to stdout, reporting failures as errors.
pub fn write_out(args: std::fmt::Arguments<'_>) -> std::io::Result<()> {
    use std::io::Write;
    std::io::stdout().lock().write_fmt(args)
}

/// Writes to stderr; a failure is ignored (see `say!`).
pub fn write_err(args: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let _ = std::io::stderr().lock().write_fmt(args);
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

/// Most worker threads a command starts (more only costs: the work is CPU-bound).
pub const MAX_THREADS: usize = 256;

/// `--threads`: 0 (all cores) up to [`MAX_THREADS`].
pub fn threads_arg(s: &str) -> Result<usize, String> {
    let n: usize = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of threads"))?;
    if n > MAX_THREADS {
        return Err(format!(
            "at most {MAX_THREADS} threads (0 = all cores), got {n}"
        ));
    }
    Ok(n)
}
