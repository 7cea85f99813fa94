use madenet_map::{io, Pos};
use madenet_sim::{Trial, TrialSpec};
fn main() {
    let corners = [
        [(0, 0), (1, 0), (0, 1)],
        [(0, 19), (1, 19), (0, 18)],
        [(19, 0), (18, 0), (19, 1)],
        [(19, 19), (18, 19), (19, 18)],
    ];
    let csp: f64 = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(1.0);
    let t0 = std::time::Instant::now();
    let (mut tns, mut ttd, mut noli, mut ofv, mut done, mut n) = (0.0, 0.0, 0.0, 0.0, 0, 0);
    for m in 1..=10 {
        let map = io::load(std::path::Path::new(&format!("maps/paper/test_{m}.yaml")), &Default::default()).unwrap();
        for c in corners {
            let spec = TrialSpec {
                map: map.clone(),
                map_name: format!("test_{m}"),
                starts: c.iter().map(|&(r, c)| Pos::new(r, c)).collect(),
                config: madenet_world::ScenarioConfig { comm_success_prob: csp, ..Default::default() },
                policy: std::env::args().nth(2).unwrap_or("nf".into()),
                seed: 1,
            };
            let r = Trial::new(spec).unwrap().run();
            tns += r.metrics.tns as f64; ttd += r.metrics.ttd; noli += r.metrics.noli as f64; ofv += r.metrics.ofv;
            done += r.metrics.completed as usize; n += 1;
            if !r.metrics.completed { println!("incomplete: map {m} {:?} explored {:.3}", c[0], r.metrics.explored); }
        }
    }
    let n = n as f64;
    println!("40 trials in {:?}: TNS {:.1} TTD {:.1} NOLI {:.1} OFV {:.1} completed {done}", t0.elapsed(), tns / n, ttd / n, noli / n, ofv / n);
}
