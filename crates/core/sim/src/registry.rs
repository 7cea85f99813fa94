//! Policies by name, so studies and the CLI have no special case per method.

use madenet_agent::{NearestFrontier, Policy, RandomCandidate, Spread};
use madenet_world::ScenarioConfig;
use std::collections::BTreeMap;
use std::sync::Arc;

/// What a policy factory gets to build one robot's policy.
#[derive(Clone, Debug)]
pub struct PolicyContext<'a> {
    /// The trial's seed; a random policy derives its stream from it and `robot`.
    pub seed: u64,
    /// Index i of the robot the policy is for.
    pub robot: usize,
    /// The trial's scenario (d_s, |I|, CSP, …).
    pub config: &'a ScenarioConfig,
    /// Map height in cells (rows); the policy never sees the ground truth itself.
    pub height: usize,
    /// Map width in cells (columns).
    pub width: usize,
}

type Factory = Arc<dyn Fn(&PolicyContext<'_>) -> Box<dyn Policy> + Send + Sync>;
type Check = Arc<dyn Fn(&PolicyContext<'_>) -> Result<(), String> + Send + Sync>;

/// State built at most once, on first use ([`PolicyRegistry::register_lazy`]).
struct Lazy<T, L> {
    cell: std::sync::OnceLock<Result<T, String>>,
    load: L,
}

impl<T, L: Fn() -> Result<T, String>> Lazy<T, L> {
    fn get(&self) -> Result<&T, String> {
        self.cell
            .get_or_init(&self.load)
            .as_ref()
            .map_err(String::clone)
    }
}

/// Named policy factories. [`PolicyRegistry::builtin`] holds the policies of the simulator
/// core; later crates register theirs with [`PolicyRegistry::register`].
#[derive(Clone, Default)]
pub struct PolicyRegistry {
    factories: BTreeMap<String, (String, Factory)>,
    /// Policies that run only on some scenarios (e.g. a learned model's map and team size).
    checks: BTreeMap<String, Check>,
}

impl PolicyRegistry {
    /// `nf` (nearest frontier), `random` (uniform random goal candidate) and `spread` (nearest
    /// candidate away from teammates, [`Spread`]).
    pub fn builtin() -> Self {
        let mut r = PolicyRegistry::default();
        r.register(
            "nf",
            "nearest frontier (Yamauchi 1997), re-decided every timestep",
            |_| Box::new(NearestFrontier),
        );
        r.register(
            "random",
            "uniformly random goal candidate at each macro termination",
            |c| Box::new(RandomCandidate::new(c.seed, c.robot)),
        );
        r.register("spread", "nearest goal candidate, penalised 2·d_s per teammate whose goal or position is within d_s (the simple rule)", |_| {
            Box::new(Spread)
        });
        r
    }

    /// Adds (or replaces, dropping any check) the policy `name`, described by `about`, whose
    /// instances `f` builds, one per robot.
    pub fn register(
        &mut self,
        name: &str,
        about: &str,
        f: impl Fn(&PolicyContext<'_>) -> Box<dyn Policy> + Send + Sync + 'static,
    ) {
        self.factories
            .insert(name.to_string(), (about.to_string(), Arc::new(f)));
        self.checks.remove(name);
    }

    /// Like [`PolicyRegistry::register`], for a policy that runs only where `check` passes
    /// (it says why not otherwise; [`PolicyRegistry::make`] then fails with that reason).
    pub fn register_checked(
        &mut self,
        name: &str,
        about: &str,
        check: impl Fn(&PolicyContext<'_>) -> Result<(), String> + Send + Sync + 'static,
        f: impl Fn(&PolicyContext<'_>) -> Box<dyn Policy> + Send + Sync + 'static,
    ) {
        self.register(name, about, f);
        self.checks.insert(name.to_string(), Arc::new(check));
    }

    /// Like [`PolicyRegistry::register_checked`], for a policy whose shared state `T` (a
    /// network's weights) is built only when a trial first asks for it: `load` runs at most
    /// once, at the first check or make of `name` (a registry whose policy is never used never
    /// loads it), and a load error is what the check says.
    pub fn register_lazy<T: Send + Sync + 'static>(
        &mut self,
        name: &str,
        about: &str,
        load: impl Fn() -> Result<T, String> + Send + Sync + 'static,
        check: impl Fn(&T, &PolicyContext<'_>) -> Result<(), String> + Send + Sync + 'static,
        make: impl Fn(&T, &PolicyContext<'_>) -> Box<dyn Policy> + Send + Sync + 'static,
    ) {
        let lazy = Arc::new(Lazy {
            cell: std::sync::OnceLock::new(),
            load,
        });
        let for_check = Arc::clone(&lazy);
        self.register_checked(
            name,
            about,
            move |ctx| check(for_check.get()?, ctx),
            // `make` checks first, so the state is loaded by the time a policy is built.
            move |ctx| make(lazy.get().expect("loaded by the check"), ctx),
        );
    }

    /// Whether `name` exists and can run in `ctx` (checked before any trial by studies).
    pub fn check(&self, name: &str, ctx: &PolicyContext<'_>) -> Result<(), crate::SimError> {
        if !self.factories.contains_key(name) {
            return Err(crate::SimError::UnknownPolicy {
                name: name.to_string(),
                known: self.names().join(", "),
            });
        }
        match self.checks.get(name) {
            Some(check) => check(ctx).map_err(|reason| crate::SimError::PolicyUnavailable {
                name: name.to_string(),
                reason,
            }),
            None => Ok(()),
        }
    }

    /// Builds robot `ctx.robot`'s policy, or an error listing the known names.
    pub fn make(
        &self,
        name: &str,
        ctx: &PolicyContext<'_>,
    ) -> Result<Box<dyn Policy>, crate::SimError> {
        self.check(name, ctx)?;
        match self.factories.get(name) {
            Some((_, f)) => Ok(f(ctx)),
            None => Err(crate::SimError::UnknownPolicy {
                name: name.to_string(),
                known: self.names().join(", "),
            }),
        }
    }

    /// The registered names, sorted.
    pub fn names(&self) -> Vec<String> {
        self.factories.keys().cloned().collect()
    }

    /// (name, description) pairs.
    pub fn describe(&self) -> Vec<(String, String)> {
        self.factories
            .iter()
            .map(|(k, (a, _))| (k.clone(), a.clone()))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    fn ctx(config: &ScenarioConfig) -> PolicyContext<'_> {
        PolicyContext {
            seed: 1,
            robot: 0,
            config,
            height: 20,
            width: 20,
        }
    }

    /// A lazy policy loads nothing when registered, loads once however often it is checked
    /// and made, and a failed load is its check's error.
    #[test]
    fn lazy_policies_load_once_on_first_use() {
        let loads = Arc::new(AtomicUsize::new(0));
        let mut r = PolicyRegistry::builtin();
        let counter = Arc::clone(&loads);
        r.register_lazy(
            "lazy-nf",
            "nearest frontier, loaded late",
            move || {
                counter.fetch_add(1, Ordering::SeqCst);
                Ok(7usize)
            },
            |&v, _| if v == 7 { Ok(()) } else { Err("wrong".into()) },
            |_, _| Box::new(NearestFrontier),
        );
        r.register_lazy(
            "broken",
            "fails to load",
            || Err::<usize, _>("weights missing".to_string()),
            |_, _| Ok(()),
            |_, _| Box::new(NearestFrontier),
        );
        assert_eq!(
            loads.load(Ordering::SeqCst),
            0,
            "nothing loaded at registration"
        );
        assert!(r.names().iter().any(|n| n == "lazy-nf"));
        let config = ScenarioConfig::default();
        for _ in 0..3 {
            r.check("lazy-nf", &ctx(&config)).unwrap();
            assert_eq!(r.make("lazy-nf", &ctx(&config)).unwrap().name(), "nf");
        }
        assert_eq!(loads.load(Ordering::SeqCst), 1, "loaded once");
        let e = r.make("broken", &ctx(&config)).err().expect("a load error");
        assert!(e.to_string().contains("weights missing"), "{e}");
    }
}
