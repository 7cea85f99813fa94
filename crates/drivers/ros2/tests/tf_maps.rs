//! TF trees of a robot team and maps with updates, over the rmw_zenoh wire through a loopback
//! router: publishers in one context, listeners in another (two sessions that reach each other
//! through the router only).

use madenet_ros2::map_updates::{MapPublisher, MapSubscriber};
use madenet_ros2::msgs::{Header, MapMetaData, OccupancyGrid, Time};
use madenet_ros2::tf::{planar, yaw, TfListener, TfNaming, TfPublisher};
use madenet_ros2::{loopback_router, stamp, Ros2Context};
use std::time::{Duration, Instant, SystemTime};

const WAIT: Duration = Duration::from_secs(10);
/// The frame every robot's `odom` hangs from.
const MAP: &str = "map";

fn two_contexts() -> (zenoh::Session, Ros2Context, Ros2Context) {
    let (router, opts) = loopback_router().unwrap();
    (router, opts.context().unwrap(), opts.context().unwrap())
}

/// Robot `i`'s pose: map → odom (x, y, yaw) and odom → base_link (x, y, yaw), apart per robot.
fn poses(i: usize) -> ([f64; 3], [f64; 3]) {
    let i = i as f64;
    ([10.0 * i, -3.0 * i, 0.0], [1.0 + i, 0.5 * i, 0.3 * i])
}

/// Robots 0..3 in namespaces `/robot<i>` send their trees named by `naming`; one listener per
/// robot must find its own robot's `map → base_link`, never another's.
fn robots_keep_their_trees_apart(naming: TfNaming) {
    let (_router, pub_ctx, sub_ctx) = two_contexts();
    let n = 3;
    let nodes: Vec<_> = (0..n)
        .map(|i| {
            pub_ctx
                .create_node_in(&format!("/robot{i}"), "robot_state_publisher")
                .unwrap()
        })
        .collect();
    let pubs: Vec<_> = nodes
        .iter()
        .map(|node| TfPublisher::new(node, naming).unwrap())
        .collect();
    let listen_node = sub_ctx.create_node("tf_listener").unwrap();
    let mut listeners: Vec<_> = (0..n)
        .map(|i| TfListener::new(&listen_node, &format!("/robot{i}"), naming).unwrap())
        .collect();
    // Under a frame prefix the robots share `map` (one tree, robot<i>/odom under it); in
    // namespaced topics each has its own `map`.
    let frame = |i: usize, name: &str| naming.frame(&format!("/robot{i}"), name);
    for (i, p) in pubs.iter().enumerate() {
        let (odom, _) = poses(i);
        let t = planar(
            MAP,
            &frame(i, "odom"),
            Time::default(),
            odom[0],
            odom[1],
            odom[2],
        );
        p.send_static(vec![t]).unwrap();
    }
    let deadline = Instant::now() + WAIT;
    let mut found = vec![false; n];
    while found.iter().any(|f| !f) {
        assert!(
            Instant::now() < deadline,
            "{naming:?}: not every robot's map → base_link within {WAIT:?}: {found:?}"
        );
        // /tf is volatile: send again until the listeners hear it.
        let now = stamp(SystemTime::now());
        for (i, p) in pubs.iter().enumerate() {
            let (_, base) = poses(i);
            let t = planar(
                &frame(i, "odom"),
                &frame(i, "base_link"),
                now,
                base[0],
                base[1],
                base[2],
            );
            p.send(vec![t]).unwrap();
        }
        for (i, l) in listeners.iter_mut().enumerate() {
            l.spin(Duration::from_millis(20)).unwrap();
            let Ok(got) = l.buffer.lookup(
                MAP,
                &frame(i, "base_link"),
                Time::default(),
                Duration::from_millis(100),
            ) else {
                continue;
            };
            // map → base_link = (map → odom) ∘ (odom → base_link).
            let ((odom, base), (x, y)) = (poses(i), (got.translation.x, got.translation.y));
            let (c, s) = (odom[2].cos(), odom[2].sin());
            let want = (
                odom[0] + c * base[0] - s * base[1],
                odom[1] + s * base[0] + c * base[1],
            );
            assert!(
                (x - want.0).abs() < 1e-9 && (y - want.1).abs() < 1e-9,
                "{naming:?}: robot{i}'s listener sees ({x}, {y}), not its robot's {want:?}"
            );
            assert!((yaw(&got.rotation) - odom[2] - base[2]).abs() < 1e-9);
            found[i] = true;
        }
    }
    // Namespaced topics: each listener heard only its own robot (the same frame names, one
    // edge each). Frame prefixes: every listener on /tf heard every robot, under its prefix.
    for (i, l) in listeners.iter().enumerate() {
        for j in 0..n {
            let other = l.buffer.lookup(
                MAP,
                &frame(j, "base_link"),
                Time::default(),
                Duration::from_millis(100),
            );
            match naming {
                TfNaming::NamespacedTopics => {
                    let x = other.unwrap().translation.x;
                    let mine = l
                        .buffer
                        .lookup("map", "base_link", Time::default(), Duration::ZERO)
                        .unwrap();
                    assert_eq!(x, mine.translation.x, "robot{i}'s tree holds one robot");
                }
                TfNaming::FramePrefix => {
                    // Robot j's frames exist once j's /tf reached this listener; when they do,
                    // they are robot j's.
                    if let Ok(t) = other {
                        let (odom, base) = poses(j);
                        let want_x = odom[0] + odom[2].cos() * base[0] - odom[2].sin() * base[1];
                        assert!((t.translation.x - want_x).abs() < 1e-9);
                    }
                }
            }
        }
        assert_eq!(l.buffer.refused(), 0);
    }
    drop(nodes); // the robots' nodes lived until here
}

#[test]
fn namespaced_tf_topics_keep_each_robots_tree_apart() {
    robots_keep_their_trees_apart(TfNaming::NamespacedTopics);
}

#[test]
fn frame_prefixes_on_the_shared_tf_keep_each_robots_frames_apart() {
    robots_keep_their_trees_apart(TfNaming::FramePrefix);
}

/// A 24 × 16 map, stamped `sec`, mostly unknown with a free band.
fn map(sec: i32) -> OccupancyGrid {
    let (w, h) = (24u32, 16u32);
    OccupancyGrid {
        header: Header {
            stamp: Time { sec, nanosec: 0 },
            frame_id: "map".into(),
        },
        info: MapMetaData {
            resolution: 0.1,
            width: w,
            height: h,
            ..MapMetaData::default()
        },
        data: (0..w * h)
            .map(|i| if (i / w) % 5 == 2 { 0 } else { -1 })
            .collect(),
    }
}

/// Polls `sub` until its grid equals `want`.
fn converge(sub: &mut MapSubscriber, want: &OccupancyGrid, what: &str) {
    let deadline = Instant::now() + WAIT;
    loop {
        let got = sub.latest(Duration::from_millis(50)).unwrap();
        if got == Some(want) {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "{what}: the subscriber's map did not become the publisher's within {WAIT:?} \
             (has a map: {}, refused {})",
            got.is_some(),
            sub.refused()
        );
    }
}

#[test]
fn a_late_subscriber_gets_the_full_map_then_follows_the_updates() {
    let (_router, pub_ctx, sub_ctx) = two_contexts();
    let node = pub_ctx.create_node_in("/robot0", "slam").unwrap();
    let mut mp = MapPublisher::new(&node, "map").unwrap();
    assert_eq!(mp.topic(), "/robot0/map");
    let mut g = map(100);
    let mut calls = 0;
    mp.publish(&g).unwrap();
    calls += 1;
    // Only now does the subscriber join: the full map reaches it through transient local.
    let sub_node = sub_ctx.create_node("map_reader").unwrap();
    let mut ms = MapSubscriber::new(&sub_node, "/robot0/map").unwrap();
    converge(&mut ms, &g, "the first map (transient local)");
    assert_eq!(ms.full_received(), 1);
    // Then a robot explores: a few cells at a time, each publish an update.
    for k in 1..=6u32 {
        g.header.stamp.sec += 1;
        for c in 0..3 {
            let i = ((k * 37 + c * 5) % (24 * 16)) as usize;
            g.data[i] = if g.data[i] == 100 { 0 } else { 100 };
        }
        mp.publish(&g).unwrap();
        calls += 1;
        converge(&mut ms, &g, &format!("update {k}"));
    }
    // A grid that did not change sends nothing.
    g.header.stamp.sec += 1;
    mp.publish(&g).unwrap();
    calls += 1;
    assert_eq!((mp.full_sent(), mp.updates_sent()), (1, 6));
    assert!(
        mp.updates_sent() + mp.full_sent() < calls,
        "{} updates and {} full maps for {calls} publish calls",
        mp.updates_sent(),
        mp.full_sent()
    );
    assert!(mp.full_sent() < calls, "updates were used");
    assert_eq!(ms.updates_applied(), 6);
    assert_eq!(ms.full_received(), 1, "one full map, then updates only");
    assert_eq!(ms.refused(), 0);
    let published = mp.last().unwrap().clone();
    assert_eq!(published.data, g.data);
    converge(&mut ms, &published, "the last grid");
    // A second late joiner's transient-local copy is the first map (the updates were
    // volatile); after `full_every` calls the full grid is sent again and it catches up.
    let mut late = MapSubscriber::new(&sub_node, "/robot0/map").unwrap();
    let deadline = Instant::now() + WAIT;
    while mp.full_sent() < 2 {
        assert!(Instant::now() < deadline, "no second full map");
        mp.publish(&g).unwrap();
        calls += 1;
    }
    assert!(
        calls <= 1 + 10 + 1,
        "a full map again after 10 calls, not {calls}"
    );
    converge(&mut late, &g, "the second late joiner");
    converge(
        &mut ms,
        &g,
        "the first subscriber after the second full map",
    );
    // A new geometry (the map grew) goes out in full.
    let mut grown = map(200);
    grown.info.width = 30;
    grown.data = vec![0; 30 * 16];
    mp.publish(&grown).unwrap();
    assert_eq!(mp.full_sent(), 3);
    converge(&mut ms, &grown, "the grown map");
    converge(&mut late, &grown, "the grown map, second subscriber");
    assert_eq!(ms.refused() + late.refused(), 0);
}
