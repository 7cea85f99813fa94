//! Starting a run's nodes as processes and watching them until they end ([`run_nodes`]; with a
//! progress line per node on the terminal, [`run_team`]): the launcher behind `madenet
//! launch`. Each node is a process of the same binary (`madenet world | radio | agent`);
//! what a node says on stderr comes back as events: lines starting `progress ` as progress,
//! any other line as something it said (a warning as it happens, an error before it exits).
//! When one node fails the others are stopped (they would only wait for it to time out), and
//! the error names every failed node with its last error line.
//!
//! Each node leads a process group of its own, so a terminal's Ctrl-C reaches the launcher
//! only; the launcher's `signals` passes the first one on to the world node (which ends the run
//! after its timestep and finishes what it writes, and tells the others to stop) and a second
//! stops every node at once.

use crate::wire::Node;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// What a node did, as [`run_nodes`] reports it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LaunchEvent<'a> {
    /// A progress line (the text after `progress `).
    Progress(Node, &'a str),
    /// Any other line it printed on stderr (warnings; an error line before it fails).
    Said(Node, &'a str),
    /// It exited, successfully or not.
    Finished(Node, bool),
}

/// Why a launch failed.
#[derive(Debug, thiserror::Error)]
pub enum LaunchError {
    /// A node's process could not be started.
    #[error("starting the {node} process: {source}")]
    Spawn {
        /// The node.
        node: Node,
        /// Why.
        source: std::io::Error,
    },
    /// A node could not listen on its port: another program took it (worth another try on
    /// other ports).
    #[error("the run over processes failed: a port of tcp/127.0.0.1:{port}… was taken ({line})")]
    PortsTaken {
        /// The run's first port.
        port: u16,
        /// The node's error line.
        line: String,
    },
    /// A node failed: every failed node with its exit status, and each node's last error line.
    #[error("the run over processes failed: {0}")]
    Failed(String),
    /// The processes could not be waited for.
    #[error("waiting for the node processes: {0}")]
    Wait(std::io::Error),
    /// No block of free loopback ports was found.
    #[error("{0}")]
    NoPorts(String),
    /// The launcher was asked to stop (`signal`: SIGINT, SIGTERM); the nodes have ended.
    #[error("interrupted by signal {signal}")]
    Interrupted {
        /// The first signal.
        signal: i32,
        /// Whether the world node ended the run itself (it exited with 128 + `signal`, having
        /// finished what it writes); not when a second signal, an error or the signal's default
        /// action ended it.
        world_finished: bool,
        /// The world node's last error line, if it printed one.
        world_error: Option<String>,
    },
}

/// After passing a signal on to the world node: how long the others get to stop on their own
/// once it has ended.
const GRACE: Duration = Duration::from_secs(3);

/// The node processes of a launch, each leading a process group of its own; dropping it kills
/// the groups of those still running (a node and anything it started).
struct Children(Vec<(Node, Child)>);

impl Drop for Children {
    fn drop(&mut self) {
        for (_, c) in &mut self.0 {
            if let Ok(None) = c.try_wait() {
                // SAFETY: kill(2) of the process group a child leads (`process_group(0)`); the
                // child is not reaped yet, so its pid (= the group's id) is still its own.
                unsafe { libc::kill(-(c.id() as libc::pid_t), libc::SIGKILL) };
            }
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Lines of each node kept to explain a failure.
const LAST_WORDS: usize = 5;

/// Runs `exe` once per node with its arguments (`nodes`: the run's nodes in order) until all
/// have exited, or one has failed (then the others are stopped). `port` is the run's first
/// loopback port, named when a node finds its port taken. `on_event` hears every line and exit
/// as it happens. `signals` is polled about every 100 ms for a signal the launcher caught (and
/// takes it): the first is sent on to the world node, a second stops every node; either way
/// the launch ends with [`LaunchError::Interrupted`] once the nodes have.
pub fn run_nodes(
    exe: &Path,
    nodes: &[(Node, Vec<String>)],
    port: u16,
    on_event: &mut dyn FnMut(LaunchEvent<'_>),
    signals: &mut dyn FnMut() -> Option<i32>,
) -> Result<(), LaunchError> {
    use std::os::unix::process::CommandExt;
    let mut children = Children(Vec::new());
    let (tx, rx) = std::sync::mpsc::channel::<(usize, String)>();
    for (k, (node, args)) in nodes.iter().enumerate() {
        let mut command = Command::new(exe);
        command.args(args).process_group(0);
        #[cfg(target_os = "linux")]
        // SAFETY: prctl(2) is async-signal-safe, as a pre_exec hook must be. A launcher that
        // dies (SIGKILL, a closed terminal) sends its nodes SIGTERM, so none is left running.
        unsafe {
            command.pre_exec(|| {
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
                Ok(())
            });
        }
        let mut child = command
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|source| LaunchError::Spawn {
                node: *node,
                source,
            })?;
        let stderr = child.stderr.take().expect("piped");
        let tx = tx.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if tx.send((k, line)).is_err() {
                    break;
                }
            }
        });
        children.0.push((*node, child));
    }
    drop(tx);
    // Last words of each node that are not progress (an error explains a failure).
    let mut said: Vec<Vec<String>> = vec![Vec::new(); nodes.len()];
    let mut keep = |k: usize, line: String| {
        said[k].push(line);
        if said[k].len() > LAST_WORDS {
            said[k].remove(0);
        }
    };
    let mut finished = vec![false; nodes.len()];
    // Each node's exit code once it has exited by itself (None: not yet, or by a signal).
    let mut exit_codes: Vec<Option<i32>> = vec![None; nodes.len()];
    let mut failures: Vec<String> = Vec::new();
    let mut running = nodes.len();
    // The first signal, and when the world node ended after it.
    let (mut interrupted, mut world_ended) = (None::<i32>, None::<std::time::Instant>);
    let mut hear = |k: usize, line: String, on_event: &mut dyn FnMut(LaunchEvent<'_>)| {
        let node = nodes[k].0;
        match line.strip_prefix("progress ") {
            Some(p) => on_event(LaunchEvent::Progress(node, p)),
            None => {
                on_event(LaunchEvent::Said(node, &line));
                keep(k, line);
            }
        }
    };
    while running > 0 {
        if let Ok((k, line)) = rx.recv_timeout(Duration::from_millis(100)) {
            hear(k, line, on_event);
        }
        running = 0;
        for (k, (node, child)) in children.0.iter_mut().enumerate() {
            match child.try_wait().map_err(LaunchError::Wait)? {
                None => running += 1,
                Some(status) if !finished[k] => {
                    finished[k] = true;
                    exit_codes[k] = status.code();
                    on_event(LaunchEvent::Finished(*node, status.success()));
                    if !status.success() {
                        failures.push(format!("{node} exited with {status}"));
                    }
                }
                Some(_) => {}
            }
        }
        if let Some(signal) = signals() {
            if interrupted.is_some() {
                break; // a second signal: stop every node now
            }
            interrupted = Some(signal);
            let world = children
                .0
                .iter()
                .enumerate()
                .find(|(_, (n, _))| *n == Node::World);
            match world {
                Some((k, (_, world))) if !finished[k] => {
                    // The world ends the run after its timestep (or dies, if it does not
                    // watch). SAFETY: kill(2) of a child `try_wait` just found running (not
                    // reaped, so the pid is still its own) with a valid signal number.
                    unsafe { libc::kill(world.id() as libc::pid_t, signal) };
                }
                // No world running (it ended, or there is none): nothing to finish, stop now.
                _ => break,
            }
        }
        if interrupted.is_some() {
            // Ended by the user: a node's exit code is not a failure, and once the world has
            // ended the others get `GRACE` to stop on their own.
            let world_done = nodes
                .iter()
                .position(|(n, _)| *n == Node::World)
                .is_none_or(|k| finished[k]);
            if world_done {
                let since = *world_ended.get_or_insert_with(std::time::Instant::now);
                if since.elapsed() > GRACE {
                    break;
                }
            }
            continue;
        }
        if !failures.is_empty() {
            // One node failed: the others would only time out; stop them now.
            break;
        }
    }
    // What the nodes said last: their pipes close as they end (the stopped ones too), so the
    // readers finish; a pipe a node's own child still holds is waited for 2 s at most.
    drop(children);
    let deadline = std::time::Instant::now() + Duration::from_secs(2);
    while let Some(left) = deadline.checked_duration_since(std::time::Instant::now()) {
        match rx.recv_timeout(left) {
            Ok((k, line)) => hear(k, line, on_event),
            Err(_) => break, // every reader done, or the 2 s are up
        }
    }
    if let Some(signal) = interrupted {
        let k = nodes.iter().position(|(n, _)| *n == Node::World);
        return Err(LaunchError::Interrupted {
            signal,
            world_finished: k.is_some_and(|k| exit_codes[k] == Some(128 + signal)),
            world_error: k.and_then(|k| {
                said[k]
                    .iter()
                    .rev()
                    .find(|l| l.starts_with("error"))
                    .cloned()
            }),
        });
    }
    if failures.is_empty() {
        return Ok(());
    }
    let taken = said
        .iter()
        .flatten()
        .find(|l| l.starts_with("error") && l.contains("Address already in use"));
    if let Some(line) = taken {
        return Err(LaunchError::PortsTaken {
            port,
            line: line.clone(),
        });
    }
    let mut msg = failures.join("; ");
    for (k, (node, _)) in nodes.iter().enumerate() {
        if let Some(last) = said[k].iter().rev().find(|l| l.starts_with("error")) {
            msg.push_str(&format!("; {node}: {last}"));
        }
    }
    Err(LaunchError::Failed(msg))
}

/// [`run_nodes`] as `madenet launch` shows it: a progress line per node on the terminal
/// (hidden when stderr is not one), the nodes' warnings printed as they come (their errors end
/// the run and are in its error), the first signal of `signals` passed on as [`run_nodes`]
/// does. Returns the outcome and where the world node last said it was (`step 12`), for an
/// interrupted run's message.
pub fn run_team(
    exe: &Path,
    nodes: &[(Node, Vec<String>)],
    port: u16,
    signals: &crate::signals::Stop,
) -> (Result<(), LaunchError>, Option<String>) {
    let bars = indicatif::MultiProgress::new();
    let style =
        indicatif::ProgressStyle::with_template("{prefix:>8} {msg}").expect("a valid template");
    let bar_of: Vec<indicatif::ProgressBar> = nodes
        .iter()
        .map(|(node, _)| {
            bars.add(
                indicatif::ProgressBar::new_spinner()
                    .with_style(style.clone())
                    .with_prefix(node.to_string())
                    .with_message("starting"),
            )
        })
        .collect();
    let bar = |node: Node| &bar_of[nodes.iter().position(|n| n.0 == node).expect("a node")];
    let mut world_at: Option<String> = None;
    let outcome = run_nodes(
        exe,
        nodes,
        port,
        &mut |event| match event {
            LaunchEvent::Progress(node, p) => {
                if node == Node::World {
                    // `step=12 explored=0.41`: where an interrupted run stopped.
                    world_at = p.split_whitespace().next().map(|s| s.replace('=', " "));
                }
                bar(node).set_message(p.to_string())
            }
            // The world's own "interrupted at …" is said once more by the launcher's caller.
            LaunchEvent::Said(Node::World, line) if line.starts_with("interrupted") => {}
            LaunchEvent::Said(node, line) if !line.starts_with("error") => {
                if bars.is_hidden() {
                    {
                        use std::io::Write;
                        let _ = writeln!(std::io::stderr(), "{node}: {line}");
                    }
                } else {
                    bars.println(format!("{node}: {line}")).ok();
                }
            }
            LaunchEvent::Said(..) => {}
            LaunchEvent::Finished(node, ok) => {
                bar(node).finish_with_message(if ok { "done" } else { "failed" })
            }
        },
        &mut || signals.take(),
    );
    bars.clear().ok();
    (outcome, world_at)
}

/// Launches tried on free ports ([`launch_team`] with port 0) before giving up on ports taken
/// by other programs.
pub const PORT_ATTEMPTS: usize = 3;

/// [`run_team`] on `ports` loopback ports from `port` on, each node's arguments given by
/// `nodes_on(first port)`. With `port` 0 the ports are free ones, found by binding and
/// releasing them: another program may take one before its node binds it, and then the run
/// is tried again on new ones, [`PORT_ATTEMPTS`] times at most (a signal between two
/// attempts ends it as [`LaunchError::Interrupted`]). Returns the outcome (the first port the
/// run used), and where the world node last said it was.
pub fn launch_team(
    exe: &Path,
    port: u16,
    ports: u16,
    nodes_on: impl Fn(u16) -> Vec<(Node, Vec<String>)>,
    signals: &crate::signals::Stop,
) -> (Result<u16, LaunchError>, Option<String>) {
    if port != 0 {
        let (outcome, at) = run_team(exe, &nodes_on(port), port, signals);
        return (outcome.map(|()| port), at);
    }
    let mut attempt = 1;
    loop {
        let port = match crate::zenoh_bus::free_port_block(ports) {
            Ok(p) => p,
            Err(e) => return (Err(LaunchError::NoPorts(e)), None),
        };
        let (outcome, at) = run_team(exe, &nodes_on(port), port, signals);
        match outcome {
            Err(e @ LaunchError::PortsTaken { .. }) if attempt < PORT_ATTEMPTS => {
                tracing::warn!("{e}: trying again on other ports");
                attempt += 1;
                if let Some(signal) = signals.take() {
                    let stopped = LaunchError::Interrupted {
                        signal,
                        world_finished: false,
                        world_error: None,
                    };
                    return (Err(stopped), None);
                }
            }
            outcome => return (outcome.map(|()| port), at),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stand-in binary (the shell) for three nodes: progress and a warning come back as
    /// events; a failing node stops the others and its error line is in the message.
    #[test]
    fn events_and_failures_of_node_processes() {
        let sh = Path::new("/bin/sh");
        let script = |s: &str| vec!["-c".to_string(), s.to_string()];
        let nodes = vec![
            (
                Node::World,
                script("echo 'progress t=1' >&2; echo 'warning: slow' >&2"),
            ),
            (Node::Radio, script("exit 0")),
        ];
        let mut events = Vec::new();
        run_nodes(
            sh,
            &nodes,
            7000,
            &mut |e| events.push(format!("{e:?}")),
            &mut || None,
        )
        .unwrap();
        assert!(events.contains(&format!("{:?}", LaunchEvent::Progress(Node::World, "t=1"))));
        assert!(events.contains(&format!(
            "{:?}",
            LaunchEvent::Said(Node::World, "warning: slow")
        )));
        assert!(events.contains(&format!("{:?}", LaunchEvent::Finished(Node::Radio, true))));

        let t0 = std::time::Instant::now();
        let nodes = vec![
            (Node::World, script("sleep 30")),
            (Node::Robot(0), script("echo 'error: no map' >&2; exit 2")),
        ];
        let e = run_nodes(sh, &nodes, 7000, &mut |_| {}, &mut || None).unwrap_err();
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "the sleeper was stopped"
        );
        let text = e.to_string();
        assert!(text.contains("robot 0 exited with"), "{text}");
        assert!(text.contains("robot 0: error: no map"), "{text}");

        let nodes = vec![(
            Node::Radio,
            script("echo 'error: listen: Address already in use' >&2; exit 2"),
        )];
        let e = run_nodes(sh, &nodes, 7000, &mut |_| {}, &mut || None).unwrap_err();
        assert!(
            matches!(e, LaunchError::PortsTaken { port: 7000, .. }),
            "{e}"
        );
    }

    /// A signal the launcher caught goes to the world node alone (it finishes and says so; the
    /// radio, which would wait for it, is stopped after the grace); a second stops every node.
    #[test]
    fn signals_go_to_the_world_then_stop_everything() {
        let sh = Path::new("/bin/sh");
        let script = |s: &str| vec!["-c".to_string(), s.to_string()];
        let dir = std::env::temp_dir().join(format!("madenet-launch-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let up = dir.join("up");
        let nodes = vec![
            (
                Node::World,
                script(&format!(
                    "trap 'echo finished >&2; exit 143' TERM; touch {}; sleep 30 & wait",
                    up.display()
                )),
            ),
            (Node::Radio, script("trap 'exit 7' TERM; sleep 30 & wait")),
        ];
        let t0 = std::time::Instant::now();
        let mut events = Vec::new();
        let mut sent = false;
        let e = run_nodes(
            sh,
            &nodes,
            7000,
            &mut |e| events.push(format!("{e:?}")),
            &mut || {
                // The signal comes once the world has set its trap (and said so with a file).
                let now = !sent && up.exists();
                sent |= now;
                // SIGTERM: a shell started in the background ignores SIGINT, and cannot trap it.
                now.then_some(libc::SIGTERM)
            },
        )
        .unwrap_err();
        std::fs::remove_dir_all(&dir).ok();
        assert!(
            matches!(
                e,
                LaunchError::Interrupted {
                    signal: 15,
                    world_finished: true,
                    world_error: None
                }
            ),
            "{e:?}"
        );
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "the radio was stopped"
        );
        assert!(events.contains(&format!("{:?}", LaunchEvent::Said(Node::World, "finished"))));
        assert!(events.contains(&format!("{:?}", LaunchEvent::Finished(Node::World, false))));
        // The radio got no signal of its own (it would have exited with 7): it was stopped.
        assert!(
            !events.iter().any(|e| e.contains("Finished(Radio")),
            "{events:?}"
        );

        // A world that does not stop on the first signal is stopped by the second.
        let nodes = vec![(Node::World, script("trap '' INT TERM; sleep 30 & wait"))];
        let t0 = std::time::Instant::now();
        let mut polls = 0;
        let e = run_nodes(sh, &nodes, 7000, &mut |_| {}, &mut || {
            polls += 1;
            (polls == 5 || polls == 15).then_some(libc::SIGTERM)
        })
        .unwrap_err();
        assert!(
            matches!(
                e,
                LaunchError::Interrupted {
                    signal: 15,
                    world_finished: false,
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "stopped by the second"
        );
    }
}
