//! Peak memory of one trial: `cargo run --release -p madenet-sim --example footprint -- <side>
//! <team> <steps>` builds the `scaling` bench's trial (generated side × side map, `team` robots
//! around a random cell, `spread`), runs `steps` timesteps and prints the process's peak
//! resident set (VmHWM, Linux) and the time per step. One process per size, so peaks do not mix.

use madenet_sim::Trial;

#[path = "../benches/support/scaling_spec.rs"]
mod scaling_spec;

fn peak_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("usage: footprint <side> <team> <steps>"))
        .collect();
    let [side, team, steps] = args[..] else {
        eprintln!("usage: footprint <side> <team> <steps>");
        std::process::exit(2);
    };
    let before = peak_kib().unwrap_or(0);
    let spec = scaling_spec::spec(side, team);
    let mut trial = Trial::new(spec).expect("trial");
    let t0 = std::time::Instant::now();
    let mut done = 0;
    while done < steps && trial.step() {
        done += 1;
    }
    let per_step = t0.elapsed().as_secs_f64() / done.max(1) as f64;
    let peak = peak_kib().unwrap_or(0);
    println!(
        "side {side} team {team}: {done} steps, {:.3} ms/step, peak RSS {:.1} MiB ({:.1} MiB before the trial), {:.0} B per cell per robot",
        per_step * 1e3,
        peak as f64 / 1024.0,
        before as f64 / 1024.0,
        (peak - before) as f64 * 1024.0 / (side * side * team) as f64
    );
}
