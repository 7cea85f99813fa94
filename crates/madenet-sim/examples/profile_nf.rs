use madenet_map::paper::{paper_map, Corner};
use madenet_sim::{Trial, TrialSpec};
fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(5);
    let reps: usize = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    for _ in 0..reps {
        let spec = TrialSpec { map: paper_map(n).unwrap(), map_name: "x".into(), starts: Corner::TopLeft.start_cells(20, 20).to_vec(), config: Default::default(), policy: "nf".into(), seed: 1 };
        let mut t = Trial::new(spec).unwrap();
        while t.step() {}
        let st: Vec<_> = t.agents().iter().map(|a| (a.stats().space_time_plans, a.stats().space_time_failures, a.space_time_expanded())).collect();
        let st = format!("{st:?}");
        let r = t.finish();
        println!("tns {} decisions {} {}", r.metrics.tns, r.timing.decisions, st);
    }
}
