//! Services over the rmw_zenoh wire: calls are matched to replies, malformed requests get an
//! error reply and do not stop the server, servers and clients are in the ROS graph. (The
//! same wire is checked by an outside client in `interop/test_ros2_wire.py`.)

use madenet_ros2::services::{
    read_attachment, service_key, AddTwoInts, AddTwoIntsRequest, AddTwoIntsResponse, ServiceClient,
    ServiceServer,
};
use madenet_ros2::{loopback_router, Ros2Context};
use std::time::Duration;
use zenoh::Wait;

const WAIT: Duration = Duration::from_secs(10);

fn two_contexts() -> (zenoh::Session, Ros2Context, Ros2Context) {
    let (router, opts) = loopback_router().unwrap();
    (router, opts.context().unwrap(), opts.context().unwrap())
}

/// Serves AddTwoInts on `server` until `n` requests were answered.
fn serve(server: ServiceServer<AddTwoInts>, n: usize) -> std::thread::JoinHandle<usize> {
    std::thread::spawn(move || {
        let mut answered = 0;
        while answered < n {
            if let Some(req) = server.recv_timeout(WAIT).unwrap() {
                let AddTwoIntsRequest { a, b } = req.request;
                req.reply(&AddTwoIntsResponse { sum: a + b }).unwrap();
                answered += 1;
            } else {
                break;
            }
        }
        server.refused()
    })
}

/// Waits until `ctx` sees the `/add_two_ints` server in the graph (a foreign client's query
/// sent before would find no queryable).
fn see_server(ctx: &Ros2Context) {
    let node = ctx.create_node("watcher").unwrap();
    let watcher = ServiceClient::<AddTwoInts>::new(&node, "/add_two_ints").unwrap();
    assert!(watcher.wait_for_server(WAIT).unwrap());
}

#[test]
fn calls_are_answered_and_matched_to_their_requests() {
    let (_router, s_ctx, c_ctx) = two_contexts();
    let s_node = s_ctx.create_node("adder").unwrap();
    let c_node = c_ctx.create_node("caller").unwrap();
    let server = ServiceServer::<AddTwoInts>::new(&s_node, "/add_two_ints").unwrap();
    let client = ServiceClient::<AddTwoInts>::new(&c_node, "add_two_ints").unwrap();
    assert!(client.wait_for_server(WAIT).unwrap());
    let done = serve(server, 5);
    // Two calls in flight at once: each reply goes to its own call.
    let first = client.send(&AddTwoIntsRequest { a: 1, b: 2 }).unwrap();
    let second = client.send(&AddTwoIntsRequest { a: 40, b: 2 }).unwrap();
    assert_eq!(second.recv_timeout(WAIT).unwrap().unwrap().sum, 42);
    assert_eq!(first.recv_timeout(WAIT).unwrap().unwrap().sum, 3);
    for k in 0..3 {
        let r = client
            .call(&AddTwoIntsRequest { a: k, b: -2 * k }, WAIT)
            .unwrap();
        assert_eq!(r.sum, -k);
    }
    assert_eq!(done.join().unwrap(), 0);
}

#[test]
fn a_malformed_request_gets_an_error_reply_and_the_server_goes_on() {
    let (_router, s_ctx, c_ctx) = two_contexts();
    let s_node = s_ctx.create_node("adder").unwrap();
    let server = ServiceServer::<AddTwoInts>::new(&s_node, "/add_two_ints").unwrap();
    let done = serve(server, 1);
    let key = service_key::<AddTwoInts>(0, "/add_two_ints");
    see_server(&c_ctx);
    // A foreign client: no attachment, then a good attachment with a truncated payload.
    let garbage = |attach: bool| {
        let mut g = c_ctx
            .session()
            .get(&key)
            .payload(vec![0u8, 1, 0, 0, 7])
            .target(zenoh::query::QueryTarget::AllComplete);
        if attach {
            g = g.attachment(madenet_ros2::rmw::attachment(
                1,
                std::time::SystemTime::now(),
                &[9; 16],
            ));
        }
        let replies = g.timeout(WAIT).wait().unwrap();
        let reply = replies.recv().unwrap();
        let err = reply.into_result().unwrap_err();
        String::from_utf8_lossy(&err.payload().to_bytes()).to_string()
    };
    assert!(
        garbage(false).contains("no attachment"),
        "{}",
        garbage(false)
    );
    assert!(garbage(true).contains("AddTwoInts_Request"));
    // Still serving.
    let c_node = c_ctx.create_node("caller").unwrap();
    let client = ServiceClient::<AddTwoInts>::new(&c_node, "/add_two_ints").unwrap();
    let r = client
        .call(&AddTwoIntsRequest { a: 2, b: 3 }, WAIT)
        .unwrap();
    assert_eq!(r.sum, 5);
    assert_eq!(done.join().unwrap(), 2); // the two malformed requests
}

#[test]
fn replies_echo_the_sequence_number_and_the_clients_gid() {
    let (_router, s_ctx, c_ctx) = two_contexts();
    let s_node = s_ctx.create_node("adder").unwrap();
    let server = ServiceServer::<AddTwoInts>::new(&s_node, "/add_two_ints").unwrap();
    let done = serve(server, 1);
    let key = service_key::<AddTwoInts>(0, "/add_two_ints");
    see_server(&c_ctx);
    let replies = c_ctx
        .session()
        .get(&key)
        .payload(vec![
            0u8, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0,
        ])
        .attachment(madenet_ros2::rmw::attachment(
            77,
            std::time::SystemTime::now(),
            &[5; 16],
        ))
        .target(zenoh::query::QueryTarget::AllComplete)
        .timeout(WAIT)
        .wait()
        .unwrap();
    let sample = replies.recv().unwrap().into_result().unwrap();
    let (sn, ns, gid) = read_attachment(&sample.attachment().unwrap().to_bytes()).unwrap();
    assert_eq!((sn, gid), (77, [5; 16]));
    assert!(ns > 1_600_000_000_000_000_000, "source time {ns} ns");
    // sum = 3, little-endian CDR after the header.
    assert_eq!(
        sample.payload().to_bytes().to_vec(),
        vec![0u8, 1, 0, 0, 3, 0, 0, 0, 0, 0, 0, 0]
    );
    done.join().unwrap();
}

#[test]
fn servers_and_clients_are_in_the_ros_graph_with_their_namespace() {
    let (_router, s_ctx, c_ctx) = two_contexts();
    let s_node = s_ctx.create_node_in("/robot3", "adder").unwrap();
    let c_node = c_ctx.create_node("caller").unwrap();
    let client = ServiceClient::<AddTwoInts>::new(&c_node, "/robot3/add_two_ints").unwrap();
    assert!(!client.wait_for_server(Duration::from_millis(300)).unwrap());
    let server = ServiceServer::<AddTwoInts>::new(&s_node, "add_two_ints").unwrap();
    assert_eq!(server.name(), "/robot3/add_two_ints");
    assert!(client.wait_for_server(WAIT).unwrap());
    let tokens: Vec<String> = c_ctx
        .session()
        .liveliness()
        .get("@ros2_lv/0/**")
        .timeout(WAIT)
        .wait()
        .unwrap()
        .iter()
        .filter_map(|r| r.into_result().ok().map(|s| s.key_expr().to_string()))
        .collect();
    let has = |kind: &str, tail: &str| {
        tokens
            .iter()
            .any(|t| t.contains(&format!("/{kind}/")) && t.contains(tail))
    };
    let typed = "%robot3%add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/RIHS01_e118de6b";
    assert!(
        has("SS", &format!("/%/%robot3/adder/{typed}")),
        "{tokens:#?}"
    );
    assert!(has("SC", &format!("/%/%/caller/{typed}")), "{tokens:#?}");
    assert!(has("NN", "/%/%robot3/adder"), "{tokens:#?}");
}
