//! `madenet explore`'s flags and what the command does with them (the binary only dispatches).

use crate::node;
use crate::params::ExploreParams;
use std::error::Error;
use std::path::PathBuf;

/// `madenet explore`: one robot's exploration node for a robot that nav2 drives.
#[derive(clap::Args, Debug)]
pub struct ExploreArgs {
    /// explore_lite's parameter file (ROS 2 YAML, as `--params-file` of a ROS node: its `/**`
    /// section and the node's own, `<namespace>/explore_node`, apply). Repeatable: later
    /// files' values win, as in ROS.
    #[arg(long, value_name = "FILE", required = true)]
    pub params_file: Vec<PathBuf>,
    /// The robot's namespace (`/robot0`); the node is `<namespace>/explore_node`, its map,
    /// TF and `navigate_to_pose` are the robot's in that namespace.
    #[arg(long, default_value = "/", value_name = "NS")]
    pub namespace: String,
    /// The zenoh endpoint of the ROS 2 graph: a router or a peer, here or on another machine.
    /// Default: `connect/endpoints` of `ZENOH_CONFIG_OVERRIDE`, as rmw_zenoh reads it, else
    /// rmw_zenoh's router on this machine (tcp/127.0.0.1:7447).
    #[arg(long, value_name = "ENDPOINT")]
    pub ros2: Option<String>,
    /// Remap a topic, service or action name as ROS nodes' `-r from:=to` (`map:=/slam/map`,
    /// `navigate_to_pose:=/robot0/nav/navigate_to_pose`). Repeatable.
    #[arg(short = 'r', long = "remap", value_name = "FROM:=TO", value_parser = remap_arg)]
    pub remap: Vec<(String, String)>,
    /// Check the parameter file, print the parameters that apply, and exit.
    #[arg(long)]
    pub check: bool,
}

/// `-r from:=to`: two ROS names (`__ns`, `__node` and other special rules are not taken: use
/// `--namespace`).
fn remap_arg(s: &str) -> Result<(String, String), String> {
    let Some((from, to)) = s.split_once(":=") else {
        return Err(format!("{s:?} is not a remapping `from:=to`"));
    };
    let name_ok = |n: &str| {
        let body = n
            .strip_prefix('/')
            .unwrap_or(n)
            .strip_prefix("~/")
            .unwrap_or(n);
        !n.is_empty()
            && !n.starts_with("__")
            && !n.contains("//")
            && !n.ends_with('/')
            && body.split('/').all(|seg| {
                !seg.is_empty()
                    && !seg.starts_with(|c: char| c.is_ascii_digit())
                    && seg.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            })
    };
    for (what, n) in [("from", from), ("to", to)] {
        if !name_ok(n) {
            return Err(format!(
                "{s:?}: {what} {n:?} is not a topic, service or action name (special rules such as __ns: use --namespace)"
            ));
        }
    }
    Ok((from.to_string(), to.to_string()))
}

/// Whether `ns` is a ROS namespace: `/`, or `/` and names of letters, digits and `_` (not
/// starting with a digit) separated by `/`.
fn is_namespace(ns: &str) -> bool {
    ns == "/"
        || (ns.starts_with('/')
            && ns[1..].split('/').all(|seg| {
                !seg.is_empty()
                    && !seg.starts_with(|c: char| c.is_ascii_digit())
                    && seg.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            }))
}

/// Runs `madenet explore` until exploration is complete or a signal comes; the lines to print.
pub fn run(a: ExploreArgs) -> Result<Vec<String>, Box<dyn Error + Send + Sync>> {
    if !is_namespace(&a.namespace) {
        return Err(format!(
            "--namespace: {:?} is not a ROS namespace (/robot0)",
            a.namespace
        )
        .into());
    }
    let node_name = match a.namespace.as_str() {
        "/" => "/explore_node".to_string(),
        ns => format!("{ns}/explore_node"),
    };
    let files: Vec<&std::path::Path> = a.params_file.iter().map(|f| f.as_path()).collect();
    let p =
        ExploreParams::from_files(&files, &node_name).map_err(|e| format!("--params-file: {e}"))?;
    if a.check {
        for (from, to) in &a.remap {
            tracing::info!("remapped {from} → {to}");
        }
        let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
        return Ok(vec![format!(
            "{} for {node_name}: {p:?}",
            names.join(" + ")
        )]);
    }
    let connect = match (&a.ros2, madenet_ros2::endpoints_from_env()) {
        (Some(e), _) => vec![e.clone()],
        (None, Some(from_env)) => from_env?,
        (None, None) => madenet_ros2::Ros2Options::default().connect,
    };
    let opts = madenet_ros2::Ros2Options {
        connect,
        ..Default::default()
    };
    let stop = madenet_runtime::signals::Stop::watch(true)?;
    let run = node::run(&opts, &a.namespace, &p, &a.remap, &|| {
        stop.requested().is_some()
    })
    .map_err(|e| match e {
        node::ExploreError::Ros2(e) => format!("--ros2: {e}"),
        e => format!("--params-file: {e}"),
    })?;
    Ok(run.summary())
}
