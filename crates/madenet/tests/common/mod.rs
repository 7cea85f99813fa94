//! What the `madenet` binary's integration tests share: running it (with [`madenet_testkit`]'s
//! time limit), a command line written as one string, and signalling a spawned run.
#![allow(dead_code)]

use std::ffi::OsStr;
use std::fmt::Debug;
use std::process::{Child, Command, Output, Stdio};

/// Runs the `madenet` binary with `args` (killed after [`madenet_testkit::RUN_LIMIT`]).
pub fn madenet<S: AsRef<OsStr> + Debug>(args: &[S]) -> Output {
    madenet_testkit::run(env!("CARGO_BIN_EXE_madenet"), args)
}

/// The words of `line`, each `{}` replaced by the next of `fill` (paths: they may hold spaces).
pub fn words<'a>(line: &'a str, fill: &[&'a str]) -> Vec<&'a str> {
    let mut fill = fill.iter();
    let args: Vec<&str> = line
        .split_whitespace()
        .map(|w| match w {
            "{}" => *fill.next().expect("a value for every {}"),
            w => w,
        })
        .collect();
    assert!(fill.next().is_none(), "a {{}} for every value");
    args
}

/// [`madenet`] with the command line [`words`] makes of `line` and `fill`.
pub fn madenet_with(line: &str, fill: &[&str]) -> Output {
    madenet_with_extra(line, fill, &[])
}

/// [`madenet_with`], `extra` after the words of `line`.
pub fn madenet_with_extra(line: &str, fill: &[&str], extra: &[&str]) -> Output {
    madenet(&[words(line, fill), extra.to_vec()].concat())
}

/// Spawns `cmd` with stdout and stderr piped.
pub fn spawn_piped(cmd: &mut Command) -> Child {
    cmd.stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Sends `signal` (as `kill` spells it: `-INT`, `-TERM`) to `child`.
pub fn signal(child: &Child, signal: &str) {
    let kill = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
}
