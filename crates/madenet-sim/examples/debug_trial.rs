use madenet_map::{io, Pos, Occupancy};
use madenet_sim::{Trial, TrialSpec};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let m: usize = a[1].parse().unwrap();
    let starts: Vec<Pos> = match a[2].as_str() {
        "tl" => vec![Pos::new(0,0),Pos::new(1,0),Pos::new(0,1)],
        "tr" => vec![Pos::new(0,19),Pos::new(1,19),Pos::new(0,18)],
        "bl" => vec![Pos::new(19,0),Pos::new(18,0),Pos::new(19,1)],
        _ => vec![Pos::new(19,19),Pos::new(18,19),Pos::new(19,18)],
    };
    let map = io::load(std::path::Path::new(&format!("maps/paper/test_{m}.yaml")), &Default::default()).unwrap();
    let spec = TrialSpec { map: map.clone(), map_name: "x".into(), starts, config: madenet_world::ScenarioConfig { comm_success_prob: a.get(5).map(|s| s.parse().unwrap()).unwrap_or(1.0), ..Default::default() }, policy: a.get(3).cloned().unwrap_or("nf".into()), seed: 1 };
    let mut t = Trial::new(spec).unwrap();
    let every: usize = a.get(4).map(|s| s.parse().unwrap()).unwrap_or(20);
    while t.step() {
        let w = t.world();
        if w.t() % every == 0 || w.is_done() {
            println!("t={} explored {:.3} pos {:?} goals {:?}", w.t(), w.explored_fraction(), w.positions(), t.agents().iter().map(|a| a.goal()).collect::<Vec<_>>()); for a in t.agents() { println!("  path {:?} term {:?}", a.path().iter().map(|p| (p.row,p.col)).collect::<Vec<_>>(), a.termination()); }
            for r in 0..20 { let mut s = String::new(); for c in 0..20 { let p = Pos::new(r,c); let i = r as usize*20+c as usize;
                let ch = if let Some(k) = w.positions().iter().position(|&q| q==p) { (b'0'+k as u8) as char }
                  else if t.agents().iter().any(|a| a.goal()==Some(p)) { 'G' }
                  else { match (w.team_map()[i], w.explorable()[i]) { (Occupancy::Unknown, true) => '?', (Occupancy::Unknown, false) => ' ', (Occupancy::Free,_) => '.', _ => '#' } };
                s.push(ch);} println!("{s}"); }
        }
    }
}
