//! A team of `madenet explore` processes, one per robot, for `madenet run --world continuous
//! --nav2 --explore`: the simulated nav2 team and its exploration nodes in one command, talking
//! only through ROS 2 (a zenoh router).
//!
//! Each node gets the user's parameter files, then one written here (later files win, as in
//! ROS) that points it at the sim's topics (`map`, `map_updates`), follows `/clock`, names its
//! policy and, in its own section, its teammates. [`TeamNodes`] is a run-loop sink: the run
//! ends when every node has exited; it remembers when (simulated time) each did.

use madenet_ros2::nav2_sim::{namespace, Nav2Team};
use madenet_sim::stepping::{Sink, SinkError};
use std::io::Read;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// The exploration nodes of a team, as child processes.
pub struct TeamNodes {
    nodes: Vec<Node>,
    /// Holds the written parameter file while the nodes run.
    _dir: tempfile::TempDir,
}

struct Node {
    ns: String,
    child: Child,
    /// Exit code (`None`: killed by a signal) and the simulated second it was seen.
    exited: Option<(Option<i32>, f64)>,
}

/// The parameter file the launcher adds for a team of `n`: the sim's topics, `/clock`,
/// `policy`, and each node's teammates (none unless `team`).
pub fn team_params(n: usize, policy: &str, team: bool) -> String {
    let mut y = format!(
        "/**:\n  ros__parameters:\n    costmap_topic: map\n    costmap_updates_topic: map_updates\n    use_sim_time: true\n    policy: {policy}\n"
    );
    for i in 0..n {
        let mates: Vec<String> = match team {
            true => (0..n).filter(|&j| j != i).map(namespace).collect(),
            false => Vec::new(),
        };
        y.push_str(&format!(
            "{}/explore_node:\n  ros__parameters:\n    teammates: [{}]\n",
            namespace(i),
            mates.join(", ")
        ));
    }
    y
}

impl TeamNodes {
    /// Starts `madenet explore` (`exe`) for robots `/robot0` … of a team of `n` on the ROS 2
    /// graph at `endpoint`, with policy `policy` (teammates of each other if `team`) after the
    /// user's `params_files`. Their logs go
    /// to this process's stderr; what each prints at its end is collected.
    pub fn spawn(
        exe: &Path,
        endpoint: &str,
        n: usize,
        policy: &str,
        team: bool,
        params_files: &[PathBuf],
    ) -> std::io::Result<Self> {
        let dir = tempfile::tempdir()?;
        let team_file = dir.path().join("team.yaml");
        std::fs::write(&team_file, team_params(n, policy, team))?;
        let mut nodes = Vec::new();
        for i in 0..n {
            let mut cmd = Command::new(exe);
            cmd.arg("explore");
            for f in params_files.iter().chain([&team_file]) {
                cmd.arg("--params-file").arg(f);
            }
            cmd.args(["--namespace", &namespace(i), "--ros2", endpoint])
                .stdin(Stdio::null())
                .stdout(Stdio::piped());
            let child = match cmd.spawn() {
                Ok(c) => c,
                Err(e) => {
                    let mut started = TeamNodes { nodes, _dir: dir };
                    started.kill();
                    return Err(e);
                }
            };
            nodes.push(Node {
                ns: namespace(i),
                child,
                exited: None,
            });
        }
        Ok(TeamNodes { nodes, _dir: dir })
    }

    /// Notes the nodes that exited by simulated second `now`; whether all have.
    pub fn poll(&mut self, now: f64) -> bool {
        for n in &mut self.nodes {
            if n.exited.is_none() {
                if let Ok(Some(st)) = n.child.try_wait() {
                    n.exited = Some((st.code(), now));
                }
            }
        }
        self.nodes.iter().all(|n| n.exited.is_some())
    }

    /// The simulated second by which every node had exited, if all have.
    pub fn all_exited_at(&self) -> Option<f64> {
        self.nodes
            .iter()
            .map(|n| n.exited.map(|e| e.1))
            .try_fold(0.0f64, |m, t| t.map(|t| m.max(t)))
    }

    /// Stops the nodes still running (SIGKILL).
    pub fn kill(&mut self) {
        for n in &mut self.nodes {
            if n.exited.is_none() {
                let _ = n.child.kill();
                let _ = n.child.wait();
            }
        }
    }

    /// One line per node (how it ended, and what it printed), and whether every node said it
    /// found exploration complete. Call after the nodes exited (or were killed).
    pub fn report(&mut self) -> (Vec<String>, bool) {
        let mut lines = Vec::new();
        let mut all_complete = true;
        for n in &mut self.nodes {
            let mut said = String::new();
            if let Some(out) = n.child.stdout.as_mut() {
                let _ = out.take(64 * 1024).read_to_string(&mut said);
            }
            let how = match n.exited {
                Some((Some(0), t)) => format!("exited at {t:.0} s"),
                Some((Some(c), t)) => format!("failed (exit {c}) at {t:.0} s"),
                Some((None, t)) => format!("killed at {t:.0} s"),
                None => "stopped with the run".into(),
            };
            all_complete &= n.exited.is_some_and(|e| e.0 == Some(0))
                && said.contains("complete: no frontier left");
            let said: Vec<&str> = said.lines().map(str::trim).collect();
            lines.push(format!("{:<10} {how}: {}", n.ns, said.join("; ")));
        }
        (lines, all_complete)
    }
}

impl Drop for TeamNodes {
    fn drop(&mut self) {
        self.kill();
    }
}

impl Sink<Nav2Team> for TeamNodes {
    fn step(&mut self, sim: &Nav2Team) -> Result<ControlFlow<String>, SinkError> {
        Ok(match self.poll(sim.world().time()) {
            true => ControlFlow::Break("every exploration node has exited".into()),
            false => ControlFlow::Continue(()),
        })
    }
}
