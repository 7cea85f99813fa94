//! `cargo bench -p madenet-ros2 --bench actions`: how long a `NavigateToPose`-style cancel
//! takes from the client's request to the server's acknowledgement (`cancel_goal`'s reply),
//! over an in-process zenoh router on loopback, with the action server polling as a robot's
//! loop would (`ActionServer::poll` every 10 ms). Prints p50 and p95 of every cancel timed
//! (criterion reports the mean). The anchor is nav2's own expectation of a cancel: well
//! within a control period (50 ms at nav2's default 20 Hz); the contract test
//! (`tests/actions.rs`) asserts a generous 1 s.

use criterion::{criterion_group, criterion_main, Criterion};
use madenet_ros2::actions::{status, ActionClient, ActionEvent, ActionServer, Fibonacci};
use madenet_ros2::actions::{FibonacciGoal, FibonacciSequence};
use madenet_ros2::loopback_router;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const WAIT: Duration = Duration::from_secs(10);

fn bench(c: &mut Criterion) {
    let (_router, opts) = loopback_router().expect("router");
    let server_ctx = opts.context().expect("server session");
    let client_ctx = opts.context().expect("client session");
    let stop = Arc::new(AtomicBool::new(false));
    let halt = stop.clone();
    // A server that accepts every goal, never ends one by itself, and ends each canceled
    // goal as CANCELED.
    let server = std::thread::spawn(move || {
        let node = server_ctx.create_node("bench_server").expect("node");
        let mut server = ActionServer::<Fibonacci>::new(&node, "/fibonacci").expect("server");
        while !halt.load(Ordering::Relaxed) {
            match server.poll(Duration::from_millis(10)).expect("poll") {
                Some(ActionEvent::Goal(g)) => {
                    server.accept(g).expect("accept");
                }
                Some(ActionEvent::Cancel(id)) => {
                    let empty = FibonacciSequence { sequence: vec![] };
                    server.end(id, status::CANCELED, empty).expect("end");
                }
                None => {}
            }
        }
    });
    let node = client_ctx.create_node("bench_client").expect("node");
    let client = ActionClient::<Fibonacci>::new(&node, "/fibonacci").expect("client");
    assert!(client.wait_for_server(WAIT).expect("graph"), "no server");
    let timed = Mutex::new(Vec::new());
    c.bench_function("action_cancel_to_ack", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let goal = client
                    .send_goal(FibonacciGoal { order: 1_000 }, WAIT)
                    .expect("send")
                    .expect("accepted");
                let t = Instant::now();
                let answer = client.cancel(goal.id, WAIT).expect("cancel");
                let took = t.elapsed();
                assert_eq!(answer.goals_canceling.len(), 1);
                total += took;
                timed.lock().expect("samples").push(took);
            }
            total
        })
    });
    let mut all = timed.into_inner().expect("samples");
    all.sort();
    let at = |q: f64| all[((all.len() - 1) as f64 * q).round() as usize];
    eprintln!(
        "cancel → acknowledgement over {} cancels: p50 {:.2} ms, p95 {:.2} ms, max {:.2} ms",
        all.len(),
        at(0.5).as_secs_f64() * 1e3,
        at(0.95).as_secs_f64() * 1e3,
        at(1.0).as_secs_f64() * 1e3
    );
    stop.store(true, Ordering::Relaxed);
    server.join().expect("server thread");
}

criterion_group!(benches, bench);
criterion_main!(benches);
