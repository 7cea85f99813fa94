//! A run over processes survives faults: a killed agent (its robot stays where it stopped and the
//! others finish the exploration), a killed and restarted agent (it rejoins), a killed and
//! restarted radio, and extra loss and delay at the radio. Every run is bounded in time and its
//! processes are killed when the test ends.

use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const TRIAL: [&str; 8] = [
    "--map",
    "paper:3",
    "--start",
    "top-right",
    "--policy",
    "nf",
    "--seed",
    "3",
];

/// The processes of one run (killed on drop) and what each said on stderr.
struct Run {
    port: String,
    run: String,
    out: tempfile::TempDir,
    children: Vec<(String, Child)>,
    said: Arc<Mutex<Vec<(String, String)>>>,
    /// Every node's `--timeout-s`.
    timeout_s: &'static str,
}

impl Run {
    fn new(name: &str) -> Run {
        Run {
            port: madenet_runtime::zenoh_bus::free_port_block(5)
                .unwrap()
                .to_string(),
            run: format!("{name}-{}", std::process::id()),
            out: tempfile::tempdir().unwrap(),
            children: Vec::new(),
            said: Arc::default(),
            timeout_s: "2",
        }
    }

    /// [`Run::new`] with [`Run::start_all`] called (no extra radio flags).
    fn started(name: &str, pace_ms: &str) -> Run {
        let mut run = Run::new(name);
        run.start_all(pace_ms, &[]);
        run
    }

    /// Starts `madenet <command> <trial> <node flags> <extra>`, its stderr collected as `label`.
    fn start(&mut self, label: &str, command: &str, extra: &[&str]) {
        self.start_on(label, command, &TRIAL, extra)
    }

    /// [`Run::start`] with another trial.
    fn start_on(&mut self, label: &str, command: &str, trial: &[&str], extra: &[&str]) {
        let mut child = Command::new(env!("CARGO_BIN_EXE_madenet"))
            .arg(command)
            .args(trial)
            .args([
                "--run",
                &self.run,
                "--port",
                &self.port,
                "--timeout-s",
                self.timeout_s,
                "--progress",
            ])
            .args(extra)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let stderr = child.stderr.take().unwrap();
        let (said, who) = (self.said.clone(), label.to_string());
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                said.lock().unwrap().push((who.clone(), line));
            }
        });
        self.children.push((label.to_string(), child));
    }

    /// World (taking at least `pace_ms` per timestep), radio and 3 agents.
    fn start_all(&mut self, pace_ms: &str, radio_extra: &[&str]) {
        let out = self.out.path().join("result.json");
        let out = out.to_str().unwrap().to_string();
        self.start(
            "world",
            "world",
            &["--out", &out, "--trajectory", "--pace-ms", pace_ms],
        );
        self.start("radio", "radio", radio_extra);
        for i in 0..3 {
            self.start(&format!("robot {i}"), "agent", &["--robot", &i.to_string()]);
        }
    }

    /// Waits (bounded) until `label` has said a line for which `pred` holds.
    fn wait_for(&self, label: &str, pred: impl Fn(&str) -> bool) -> String {
        let deadline = Instant::now() + Duration::from_secs(60);
        while Instant::now() < deadline {
            if let Some((_, l)) = self
                .said
                .lock()
                .unwrap()
                .iter()
                .find(|(who, l)| who == label && pred(l))
            {
                return l.clone();
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let said = self.said.lock().unwrap();
        let news: Vec<_> = said
            .iter()
            .filter(|(_, l)| !l.starts_with("progress"))
            .collect();
        panic!("{label} never said what was awaited; the nodes' warnings and errors: {news:?}");
    }

    fn lines(&self, label: &str) -> Vec<String> {
        let said = self.said.lock().unwrap();
        said.iter()
            .filter(|(who, _)| who == label)
            .map(|(_, l)| l.clone())
            .collect()
    }

    /// The world's step from its latest progress line.
    fn step(&self) -> usize {
        self.lines("world")
            .iter()
            .rev()
            .find_map(|l| {
                l.strip_prefix("progress step=")?
                    .split(' ')
                    .next()?
                    .parse()
                    .ok()
            })
            .unwrap_or(0)
    }

    /// Waits (bounded) until the world has played 5 timesteps, then kills `label`.
    fn kill_after_step_5(&mut self, label: &str) {
        self.wait_for("world", |l| l.starts_with("progress step=5 "));
        self.kill(label);
    }

    /// Waits (bounded) until `label` reports a timestep after `step`.
    fn wait_past(&self, label: &str, step: usize) {
        self.wait_for(label, |l| {
            l.strip_prefix("progress step=")
                .and_then(|s| s.split(' ').next()?.parse::<usize>().ok())
                .is_some_and(|s| s > step)
        });
    }

    fn kill(&mut self, label: &str) {
        let (_, child) = self
            .children
            .iter_mut()
            .rev()
            .find(|(l, _)| l == label)
            .unwrap();
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
    }

    /// Waits up to `within` for `label`'s process to end; how long it took, or `None`.
    fn exits_within(&mut self, label: &str, within: Duration) -> Option<Duration> {
        let t0 = Instant::now();
        let (_, child) = self.children.iter_mut().find(|(l, _)| l == label).unwrap();
        while t0.elapsed() < within {
            if child.try_wait().unwrap().is_some() {
                return Some(t0.elapsed());
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        None
    }

    /// [`Run::finish`], asserting that the exploration was completed.
    fn finish_completed(&mut self) -> Value {
        let result = self.finish();
        assert_eq!(result["metrics"]["completed"], true, "{result}");
        result
    }

    /// Waits (bounded) for the world to finish; returns its result.
    fn finish(&mut self) -> Value {
        let deadline = Instant::now() + Duration::from_secs(120);
        let (_, world) = self
            .children
            .iter_mut()
            .find(|(l, _)| l == "world")
            .unwrap();
        loop {
            if let Some(status) = world.try_wait().unwrap() {
                assert!(status.success(), "world: {:?}", self.lines("world"));
                break;
            }
            assert!(Instant::now() < deadline, "the world never finished");
            std::thread::sleep(Duration::from_millis(20));
        }
        let json = std::fs::read_to_string(self.out.path().join("result.json")).unwrap();
        serde_json::from_str(&json).unwrap()
    }
}

impl Drop for Run {
    fn drop(&mut self) {
        for (_, c) in &mut self.children {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Robot `i`'s cell at every timestep.
fn cells_of(result: &Value, i: usize) -> Vec<Value> {
    result["positions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p[i].clone())
        .collect()
}

#[test]
fn a_killed_agent_leaves_its_robot_where_it_stopped_and_the_others_finish() {
    let mut run = Run::started("kill", "40");
    run.kill_after_step_5("robot 1");
    let killed_at = run.step();
    run.wait_for("world", |l| l.contains("robot 1 sent no move"));
    let result = run.finish_completed();
    assert!(
        result["runtime"]["absent_robot_steps"].as_u64().unwrap() > 5,
        "{result}"
    );
    let cells = cells_of(&result, 1);
    // From two timesteps after the kill on, robot 1 never moves again.
    let after = &cells[killed_at + 2..];
    assert!(after.iter().all(|c| *c == after[0]), "{after:?}");
    // The others kept exploring to the end.
    let tns = result["metrics"]["tns"].as_u64().unwrap() as usize;
    assert!(tns > killed_at + 5, "tns {tns}, killed at {killed_at}");
    assert_ne!(
        cells_of(&result, 0)[killed_at + 2],
        cells_of(&result, 0)[tns]
    );
}

#[test]
fn a_restarted_agent_rejoins_and_the_trial_completes() {
    // Slow enough that the run outlasts the restarted process's start and connection.
    let mut run = Run::started("restart", "100");
    run.kill_after_step_5("robot 2");
    run.wait_for("world", |l| l.contains("robot 2 sent no move"));
    let gone_at = run.step();
    run.start("robot 2", "agent", &["--robot", "2"]);
    run.wait_for("world", |l| l.contains("robot 2 is back"));
    // It moves again: its progress lines resume.
    run.wait_past("robot 2", gone_at);
    let result = run.finish_completed();
    let cells = cells_of(&result, 2);
    let tns = result["metrics"]["tns"].as_u64().unwrap() as usize;
    assert!(
        cells[gone_at + 1..=tns].windows(2).any(|w| w[0] != w[1]),
        "robot 2 moved after rejoining"
    );
}

#[test]
fn a_restarted_radio_carries_messages_again() {
    let mut run = Run::started("radio", "40");
    run.kill_after_step_5("radio");
    // Robots do without links for a while.
    run.wait_for("robot 0", |l| l.contains("no links from the radio"));
    run.start("radio", "radio", &[]);
    run.finish_completed();
}

#[test]
fn exploration_completes_with_extra_loss_and_delay() {
    for extra in [["--loss", "0.3"], ["--delay", "3"]] {
        let mut run = Run::new("lossy");
        run.start_all("0", &extra);
        let result = run.finish();
        assert_eq!(result["metrics"]["completed"], true, "{extra:?}: {result}");
    }
}

/// A robot started on another map than the world's is refused by name at its hello, before
/// timestep 0 is played (the run would otherwise finish with an agent exploring a map that is
/// not there), and the world ends with one error line.
#[test]
fn a_robot_started_on_another_map_is_refused_by_name() {
    let mut run = Run::new("other-map");
    let out = run.out.path().join("result.json");
    let out = out.to_str().unwrap().to_string();
    run.start("world", "world", &["--out", &out, "--pace-ms", "40"]);
    run.start("radio", "radio", &[]);
    run.start("robot 0", "agent", &["--robot", "0"]);
    run.start("robot 1", "agent", &["--robot", "1"]);
    let mut other = TRIAL;
    other[1] = "paper:4";
    run.start_on("robot 2", "agent", &other, &["--robot", "2"]);
    let line = run.wait_for("world", |l| l.starts_with("error:"));
    assert!(
        line.contains("robot 2")
            && line.contains("another map or scenario")
            && line.contains("at step 0"),
        "{line}"
    );
    // Refused before the first timestep was played: the world reported none.
    let played: Vec<String> = run
        .lines("world")
        .into_iter()
        .filter(|l| l.starts_with("progress step="))
        .collect();
    assert!(played.is_empty(), "{played:?}");
    let (_, world) = run.children.iter_mut().find(|(l, _)| l == "world").unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(s) = world.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < deadline, "the world did not end");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(!status.success(), "{status:?}");
}

#[test]
fn robots_wait_through_a_long_absence_and_notice_a_killed_world_soon() {
    // With --timeout-s 10 the world waits 10 s for an absent robot's move: longer than the
    // others may hear nothing from it (2 × 2 s + 1 s); its `Waiting` keeps them on. Killed
    // while it waits, the world is noticed within those 5 s, not the 21 s of protocol 5.
    let mut run = Run::new("heartbeat");
    run.timeout_s = "10";
    run.start_all("40", &[]);
    run.kill_after_step_5("robot 1");
    run.wait_for("world", |l| l.contains("robot 1 sent no move"));
    // Through that 10 s wait robots 0 and 2 stayed (a robot that gave up would have ended).
    let step = run.step();
    run.wait_past("robot 0", step);
    // Now the world waits 10 s for robot 2's move, and is killed meanwhile.
    run.kill("robot 2");
    std::thread::sleep(Duration::from_secs(1));
    run.kill("world");
    let took = run.exits_within("robot 0", Duration::from_secs(15));
    let took =
        took.unwrap_or_else(|| panic!("robot 0 still waits 15 s after the world was killed"));
    eprintln!("robot 0 noticed the killed world after {took:?}");
    assert!(took < Duration::from_secs(7), "robot 0 took {took:?}");
    assert!(
        run.lines("robot 0")
            .iter()
            .any(|l| l.contains("observation from the world")),
        "{:?}",
        run.lines("robot 0")
    );
}

#[test]
fn a_world_paced_slower_than_the_robots_wait_in_silence_keeps_them() {
    // --pace-ms 3000 with --timeout-s 2: each timestep lasts 3 s, longer than the 2 s a node
    // waits for the world in silence (2 × 0.5 s + 1 s); the world tells them it is there.
    let mut run = Run::started("pace", "3000");
    run.wait_for("world", |l| l.starts_with("progress step=3 "));
    for label in ["robot 0", "robot 1", "robot 2", "radio"] {
        let errors: Vec<String> = run
            .lines(label)
            .into_iter()
            .filter(|l| l.contains("error") || l.contains("nothing arrived"))
            .collect();
        assert!(errors.is_empty(), "{label}: {errors:?}");
        assert!(
            run.exits_within(label, Duration::from_millis(50)).is_none(),
            "{label} ended"
        );
    }
}
