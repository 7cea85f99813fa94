//! Actions over the rmw_zenoh wire: goals accepted and rejected, feedback, results (also after
//! a long goal), cancel, the transient-local status topic, and a malformed goal refused.

use madenet_ros2::actions::{
    cancel_code, status, ActionClient, ActionEvent, ActionServer, Fibonacci, FibonacciGoal,
    FibonacciSequence, SendGoal, Uuid,
};
use madenet_ros2::services::service_key;
use madenet_ros2::{loopback_router, Ros2Context};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use zenoh::Wait;

const WAIT: Duration = Duration::from_secs(10);

fn two_contexts() -> (zenoh::Session, Ros2Context, Ros2Context) {
    let (router, opts) = loopback_router().unwrap();
    (router, opts.context().unwrap(), opts.context().unwrap())
}

/// A Fibonacci server: rejects orders below 0, sends one feedback per number (every
/// `step`), succeeds at the end; a cancel ends the goal as CANCELED. Runs until `stop`.
fn fibonacci_server(
    ctx: Ros2Context,
    step: Duration,
    stop: Arc<AtomicBool>,
) -> std::thread::JoinHandle<usize> {
    std::thread::spawn(move || {
        let node = ctx.create_node_in("/robot0", "fib").unwrap();
        let mut server = ActionServer::<Fibonacci>::new(&node, "fibonacci").unwrap();
        let mut running: Option<(Uuid, i32, Vec<i32>, Instant)> = None;
        while !stop.load(Ordering::Relaxed) {
            match server.poll(Duration::from_millis(20)).unwrap() {
                Some(ActionEvent::Goal(g)) => {
                    if g.goal().order < 0 {
                        server.reject(g).unwrap();
                    } else {
                        let order = g.goal().order;
                        if let Some((old, _, seq, _)) = running.take() {
                            // Preempted.
                            server
                                .end(old, status::ABORTED, FibonacciSequence { sequence: seq })
                                .unwrap();
                        }
                        let id = server.accept(g).unwrap();
                        running = Some((id, order, vec![0, 1], Instant::now()));
                    }
                }
                Some(ActionEvent::Cancel(id)) => {
                    if let Some((cur, _, seq, _)) = running.take_if(|r| r.0 == id) {
                        server
                            .end(cur, status::CANCELED, FibonacciSequence { sequence: seq })
                            .unwrap();
                    }
                }
                None => {}
            }
            if let Some((id, order, seq, last)) = running.as_mut() {
                if last.elapsed() >= step {
                    *last = Instant::now();
                    if seq.len() as i32 > *order {
                        let done = FibonacciSequence {
                            sequence: std::mem::take(seq),
                        };
                        server.end(*id, status::SUCCEEDED, done).unwrap();
                        running = None;
                    } else {
                        let n = seq[seq.len() - 1] + seq[seq.len() - 2];
                        seq.push(n);
                        server
                            .publish_feedback(
                                *id,
                                FibonacciSequence {
                                    sequence: seq.clone(),
                                },
                            )
                            .unwrap();
                    }
                }
            }
        }
        server.refused()
    })
}

#[test]
fn goals_feedback_results_cancel_and_status() {
    let (_router, s_ctx, c_ctx) = two_contexts();
    let stop = Arc::new(AtomicBool::new(false));
    let server = fibonacci_server(s_ctx, Duration::from_millis(30), stop.clone());
    let node = c_ctx.create_node("caller").unwrap();
    let client = ActionClient::<Fibonacci>::new(&node, "/robot0/fibonacci").unwrap();
    assert!(client.wait_for_server(WAIT).unwrap());

    // Rejected.
    assert!(client
        .send_goal(FibonacciGoal { order: -1 }, WAIT)
        .unwrap()
        .is_none());

    // Succeeds, with feedback on the way.
    let goal = client
        .send_goal(FibonacciGoal { order: 6 }, WAIT)
        .unwrap()
        .expect("accepted");
    let fb = client.feedback(WAIT).unwrap().expect("feedback");
    assert_eq!(fb.goal_id, goal.id);
    assert!(fb.feedback.sequence.len() >= 3);
    let (st, result) = goal.result(WAIT).unwrap().expect("a result");
    assert_eq!(st, status::SUCCEEDED);
    assert_eq!(result.sequence, vec![0, 1, 1, 2, 3, 5, 8]);

    // Canceled.
    let long = client
        .send_goal(FibonacciGoal { order: 1000 }, WAIT)
        .unwrap()
        .unwrap();
    let answer = client.cancel(long.id, WAIT).unwrap();
    assert_eq!(answer.return_code, cancel_code::NONE);
    assert_eq!(answer.goals_canceling.len(), 1);
    assert_eq!(answer.goals_canceling[0].goal_id, long.id);
    let (st, _) = long.result(WAIT).unwrap().unwrap();
    assert_eq!(st, status::CANCELED);
    // Canceling again: the goal has ended. An id nobody sent: unknown.
    assert_eq!(
        client.cancel(long.id, WAIT).unwrap().return_code,
        cancel_code::GOAL_TERMINATED
    );
    assert_eq!(
        client
            .cancel(Uuid { uuid: [7; 16] }, WAIT)
            .unwrap()
            .return_code,
        cancel_code::UNKNOWN_GOAL_ID
    );

    // Preempted by a newer goal.
    let first = client
        .send_goal(FibonacciGoal { order: 1000 }, WAIT)
        .unwrap()
        .unwrap();
    let second = client
        .send_goal(FibonacciGoal { order: 2 }, WAIT)
        .unwrap()
        .unwrap();
    assert_eq!(first.result(WAIT).unwrap().unwrap().0, status::ABORTED);
    assert_eq!(second.result(WAIT).unwrap().unwrap().0, status::SUCCEEDED);

    // A late joiner gets the status array (transient local): every goal so far, ended.
    let late_node = c_ctx.create_node("late").unwrap();
    let late = ActionClient::<Fibonacci>::new(&late_node, "/robot0/fibonacci").unwrap();
    let deadline = Instant::now() + WAIT;
    let mut last = None;
    while Instant::now() < deadline {
        match late.status(Duration::from_millis(200)).unwrap() {
            Some(s) => last = Some(s),
            None if last.is_some() => break,
            None => {}
        }
    }
    let last = last.expect("the status array reaches a late joiner");
    assert_eq!(last.status_list.len(), 4, "{last:?}");
    assert!(last
        .status_list
        .iter()
        .all(|s| status::is_terminal(s.status)));

    stop.store(true, Ordering::Relaxed);
    assert_eq!(server.join().unwrap(), 0);
}

#[test]
fn a_malformed_goal_is_refused_and_the_server_goes_on() {
    let (_router, s_ctx, c_ctx) = two_contexts();
    let stop = Arc::new(AtomicBool::new(false));
    let server = fibonacci_server(s_ctx, Duration::from_millis(5), stop.clone());
    let node = c_ctx.create_node("caller").unwrap();
    let client = ActionClient::<Fibonacci>::new(&node, "/robot0/fibonacci").unwrap();
    assert!(client.wait_for_server(WAIT).unwrap());
    let key = service_key::<SendGoal<Fibonacci>>(0, "/robot0/fibonacci/_action/send_goal");
    let replies = c_ctx
        .session()
        .get(&key)
        .payload(vec![0u8, 1, 0, 0, 1, 2, 3])
        .attachment(madenet_ros2::rmw::attachment(
            1,
            std::time::SystemTime::now(),
            &[1; 16],
        ))
        .timeout(WAIT)
        .wait()
        .unwrap();
    assert!(replies.recv().unwrap().into_result().is_err());
    let goal = client
        .send_goal(FibonacciGoal { order: 3 }, WAIT)
        .unwrap()
        .unwrap();
    assert_eq!(goal.result(WAIT).unwrap().unwrap().0, status::SUCCEEDED);
    stop.store(true, Ordering::Relaxed);
    assert_eq!(server.join().unwrap(), 1);
}

/// The bound: a goal that takes 60 s of wall time still gets its result (the
/// client's `get_result` query must not time out).
#[test]
fn a_result_after_a_minute_still_arrives() {
    let (_router, s_ctx, c_ctx) = two_contexts();
    let stop = Arc::new(AtomicBool::new(false));
    // order 20 at 3 s per number: about 61 s.
    let server = fibonacci_server(s_ctx, Duration::from_millis(3_050), stop.clone());
    let node = c_ctx.create_node("caller").unwrap();
    let client = ActionClient::<Fibonacci>::new(&node, "/robot0/fibonacci").unwrap();
    assert!(client.wait_for_server(WAIT).unwrap());
    let started = Instant::now();
    let goal = client
        .send_goal(FibonacciGoal { order: 20 }, WAIT)
        .unwrap()
        .unwrap();
    let (st, result) = goal
        .result(Duration::from_secs(120))
        .unwrap()
        .expect("a result within 120 s");
    assert_eq!(st, status::SUCCEEDED);
    assert_eq!(result.sequence.len(), 21);
    assert!(
        started.elapsed() >= Duration::from_secs(60),
        "{:?}",
        started.elapsed()
    );
    stop.store(true, Ordering::Relaxed);
    server.join().unwrap();
}
