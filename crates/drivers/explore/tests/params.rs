//! explore_lite's parameter file read as a ROS 2 node reads it: which sections apply to which
//! node (rclcpp's rule), every documented parameter, and one clear error per bad input.

use madenet_explore::params::{ExploreParams, ParamsError};
use std::path::Path;

fn fixture() -> &'static Path {
    Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/explore_lite.yaml"
    ))
}

#[test]
fn the_root_node_gets_the_wildcard_then_its_own_section() {
    let p = ExploreParams::from_file(fixture(), "/explore_node").unwrap();
    // explore_node's values win over /**'s.
    assert_eq!(p.robot_base_frame, "base_footprint");
    assert_eq!(p.costmap_topic, "/global_costmap/costmap");
    assert_eq!(p.costmap_updates_topic, "/global_costmap/costmap_updates");
    assert!(!p.visualize && !p.return_to_init);
    assert_eq!(
        [
            p.planner_frequency,
            p.progress_timeout,
            p.potential_scale,
            p.orientation_scale,
            p.gain_scale,
            p.transform_tolerance,
            p.min_frontier_size
        ],
        [0.5, 20.0, 2.0, 0.5, 1.5, 0.5, 0.5]
    );
    // What only /** sets stays.
    assert_eq!(p.policy, "made-net-any");
    assert_eq!(p.teammates, ["/robot1", "/robot2"]);
    // A relative node name is the root namespace's.
    assert_eq!(
        ExploreParams::from_file(fixture(), "explore_node").unwrap(),
        p
    );
}

#[test]
fn a_namespaced_node_gets_the_wildcard_and_its_nested_section_only() {
    let p = ExploreParams::from_file(fixture(), "/robot0/explore_node").unwrap();
    // `explore_node:` is /explore_node: not this node.
    assert_eq!(p.robot_base_frame, "base_link");
    assert_eq!(p.costmap_topic, "map");
    assert_eq!(p.costmap_updates_topic, "map_updates");
    assert!(p.visualize && p.return_to_init);
    assert_eq!(p.planner_frequency, 0.15);
    assert_eq!(p.min_frontier_size, 0.75);
    assert_eq!(p.potential_scale, 3.0);
    // robot0/explore_node's own values win.
    assert_eq!(p.policy, "spread");
    assert_eq!(p.teammates, ["/robot1"]);
    // Another robot: the wildcard alone.
    let q = ExploreParams::from_file(fixture(), "/robot1/explore_node").unwrap();
    assert_eq!(q.policy, "made-net-any");
    assert_eq!(q.teammates, ["/robot1", "/robot2"]);
}

#[test]
fn defaults_are_explore_lites() {
    let p = ExploreParams::from_yaml("/**:\n  ros__parameters: {}\n", "/explore_node").unwrap();
    assert_eq!(p, ExploreParams::default());
    assert_eq!(p.planner_frequency, 1.0);
    assert_eq!(p.potential_scale, 1e-3);
    assert_eq!(p.costmap_topic, "costmap");
    assert_eq!(p.decision_frequency, 2.0);
}

/// Each bad file: its error, with what it must name.
#[test]
fn bad_files_get_one_clear_error_naming_the_parameter() {
    let node = "/robot0/explore_node";
    let cases: [(&str, &[&str]); 11] = [
        (
            "/**:\n  ros__parameters:\n    planner_frequncy: 0.5\n",
            &["planner_frequncy", "unknown", "planner_frequency"],
        ),
        (
            "/**:\n  ros__parameters:\n    planner_frequency: 1\n",
            &["planner_frequency", "expected a double", "write 1.0"],
        ),
        (
            "/**:\n  ros__parameters:\n    visualize: yes please\n",
            &["visualize", "expected a bool"],
        ),
        (
            "/**:\n  ros__parameters:\n    planner_frequency: 0.0\n",
            &["planner_frequency", "(0, 1000]"],
        ),
        (
            "/**:\n  ros__parameters:\n    decision_frequency: -2.0\n",
            &["decision_frequency", "(0, 1000]"],
        ),
        (
            "/**:\n  ros__parameters:\n    progress_timeout: .nan\n",
            &["progress_timeout"],
        ),
        (
            "/**:\n  ros__parameters:\n    teammates: [\"robot1\"]\n",
            &["teammates", "robot1", "namespace"],
        ),
        (
            "slam_toolbox:\n  ros__parameters:\n    resolution: 0.05\n",
            &["no section applies", node, "/slam_toolbox"],
        ),
        (
            "/**:\n  ros__parameters:\n    costmap_topic: [map\n",
            &["parameters:"],
        ),
        ("- just\n- a list\n", &["mapping of node sections"]),
        (
            "/**:\n  ros__parameters: 3\n",
            &["ros__parameters", "not a mapping"],
        ),
    ];
    for (yaml, names) in cases {
        let e = ExploreParams::from_yaml(yaml, node).expect_err(yaml);
        let text = e.to_string();
        for n in names {
            assert!(text.contains(n), "{yaml:?}: {text:?} lacks {n:?}");
        }
        assert_eq!(text.lines().count(), 1, "{text}");
    }
    // A file that is not there, and one that is not a text file.
    let e = ExploreParams::from_file(Path::new("/nonexistent/params.yaml"), node).unwrap_err();
    assert!(matches!(e, ParamsError::Read { .. }), "{e}");
    assert!(e.to_string().contains("/nonexistent/params.yaml"));
    let e = ExploreParams::from_file(Path::new("/dev/zero"), node).unwrap_err();
    assert!(e.to_string().contains("/dev/zero"), "{e}");
}
