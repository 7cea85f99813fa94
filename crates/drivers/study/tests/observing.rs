//! Looking at an observation never changes what happens next: a policy that queries
//! everything its view offers — before and after its decision — and then decides exactly as
//! the shipped policy gives the shipped policy's trajectory, for every registered policy.

use madenet_agent::{AgentView, Decision, DecisionMode, Policy};
use madenet_map::paper::{paper_map, paper_map_name, Corner};
use madenet_map::{generate, Pos};
use madenet_sim::{PolicyRegistry, Trial, TrialSpec};
use madenet_study::StudyConfig;
use madenet_world::ScenarioConfig;

/// Wraps a policy and pokes at the view: every search and query, stopped at odd places.
struct Curious {
    inner: Box<dyn Policy>,
    calls: usize,
}

impl Curious {
    fn poke(&mut self, view: &mut AgentView<'_>) {
        self.calls += 1;
        let _ = view.candidates().cells.len();
        let _ = view.macro_observation();
        let _ = view.map_image();
        let _ = view.nearest_frontier();
        // A search stopped after a few cells, then path costs to cells near and far.
        let k = self.calls % 7;
        let mut n = 0;
        let _ = view.search(|_, _| {
            n += 1;
            n > k
        });
        let (h, w) = (view.belief.height() as i32, view.belief.width() as i32);
        for p in [
            Pos::new(0, 0),
            Pos::new(h - 1, w - 1),
            Pos::new(h / 2, w / 3),
            view.pos,
        ] {
            let _ = view.searched_cost(p);
            let _ = view.path_cost(p);
        }
        let _ = view.search(|i, _| i % 5 == k);
    }
}

impl Policy for Curious {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn mode(&self) -> DecisionMode {
        self.inner.mode()
    }
    fn needs_candidates(&self) -> bool {
        self.inner.needs_candidates()
    }
    fn decide(&mut self, view: &mut AgentView<'_>) -> Decision {
        self.poke(view);
        let d = self.inner.decide(view);
        self.poke(view);
        d
    }
}

fn run(spec: &TrialSpec, registry: &PolicyRegistry) -> String {
    let r = Trial::with_registry(spec.clone(), registry)
        .unwrap()
        .timed(false)
        .record_trajectory(true)
        .run();
    format!(
        "{}\n{}",
        serde_json::to_string(&r.metrics).unwrap(),
        serde_json::to_string(&r.trajectory).unwrap()
    )
}

#[test]
fn querying_the_view_never_changes_the_trajectory() {
    let registry = StudyConfig::default().registry().unwrap();
    let grid = generate::generate(&generate::GeneratorConfig::default(), 5).unwrap();
    let maps = [
        (paper_map(3).unwrap(), paper_map_name(3)),
        (paper_map(7).unwrap(), paper_map_name(7)),
        (grid, "generated_5".to_string()),
    ];
    let mut checked = 0;
    for name in registry.names() {
        // A curious registry: the same policy, wrapped.
        let mut curious = registry.clone();
        let inner = registry.clone();
        let n = name.clone();
        curious.register(&name, "curious", move |ctx| {
            Box::new(Curious {
                inner: inner.make(&n, ctx).unwrap(),
                calls: 0,
            })
        });
        for (map, map_name) in &maps {
            for (corner, csp) in [
                (Corner::TopLeft, 1.0),
                (Corner::BottomRight, 0.0),
                (Corner::TopRight, 0.5),
            ] {
                let starts = corner.start_cells(map.height(), map.width()).to_vec();
                let spec = TrialSpec {
                    map: map.clone(),
                    map_name: map_name.clone(),
                    starts,
                    config: ScenarioConfig {
                        comm_success_prob: csp,
                        ..Default::default()
                    },
                    policy: name.clone(),
                    seed: 3,
                };
                assert_eq!(
                    run(&spec, &registry),
                    run(&spec, &curious),
                    "{name} on {map_name} from {corner}, CSP {csp}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 9 * 7, "{checked} trials checked");
}
