//! What the continuous world's robots sense, as ROS 2 messages: a robot's lidar as
//! `sensor_msgs/LaserScan`, its own fine occupancy grid as `nav_msgs/OccupancyGrid`, its pose
//! as `geometry_msgs/PoseStamped` — for the nav2 sim ([`crate::nav2_sim`]) and the recorder.
//!
//! Coordinates: the world's x runs right and y down from the map's top-left corner; ROS's
//! `map` frame has y up from the bottom-left corner, shifted and rotated by the map's origin
//! (the map_server convention, as [`crate::MapFrame`]), so y and headings are mirrored.

use crate::msgs::{LaserScan, OccupancyGrid, PoseStamped, Time};
use crate::{header, MapFrame};
use madenet_continuous::{ContinuousWorld, Pose};

/// The ROS `/robot<i>/scan` topic of robot `i`.
pub fn scan_topic(i: usize) -> String {
    format!("/robot{i}/scan")
}

/// The sensor frame of robot `i`'s scans (`robot<i>/base_link`, REP 105).
pub fn base_frame(i: usize) -> String {
    format!("robot{i}/base_link")
}

/// A world point (x right, y down from the top-left corner, metres) in the `map` frame.
pub(crate) fn map_point(frame: &MapFrame, x: f64, y: f64) -> (f64, f64) {
    frame.point(x, frame.height as f64 * frame.resolution - y)
}

/// A world pose in the `map` frame: position by [`map_point`], heading mirrored (y down → y
/// up) and turned by the origin's yaw.
pub(crate) fn pose_stamped(p: Pose, frame: &MapFrame, t: Time) -> PoseStamped {
    let (x, y) = map_point(frame, p.x, p.y);
    PoseStamped {
        header: header(t),
        pose: frame.pose(x, y, frame.origin[2] - p.theta),
    }
}

/// Robot `i`'s last scan as a `LaserScan` in its own frame: beam k of the world's sensor
/// (clockwise in ROS's y-up frame) is range `N − 1 − k`, so ranges run counter-clockwise.
pub(crate) fn laser_scan(world: &ContinuousWorld, i: usize, t: Time) -> LaserScan {
    let lidar = world.config().lidar;
    let n = lidar.beams;
    let fov = lidar.fov_deg.to_radians();
    let inc = fov / n as f64;
    let range_max = world.sensing_m();
    let theta = world.pose(i).theta;
    // Missed returns (the sensor's dropouts) are invalid readings: NaN (REP 117).
    let mut ranges = vec![f32::NAN; n];
    let res = world.config().mapping.resolution;
    for &(a, d, returned) in world.scan_beams(i) {
        // a = θ − fov/2 + (k + ½)·inc (world frame, y down).
        let k = ((a - theta + fov / 2.0) / inc - 0.5).round() as i64;
        let k = if lidar.fov_deg >= 360.0 {
            k.rem_euclid(n as i64)
        } else {
            k
        };
        if (0..n as i64).contains(&k) {
            ranges[n - 1 - k as usize] = if returned {
                d as f32
            } else if d < range_max {
                // A teammate: the world keeps its beams a pixel short (they do not mark it).
                (d + res).min(range_max) as f32
            } else {
                // Nothing within range: +∞ (REP 117).
                f32::INFINITY
            };
        }
    }
    LaserScan {
        header: crate::msgs::Header {
            stamp: t,
            frame_id: base_frame(i),
        },
        angle_min: (-fov / 2.0 + inc / 2.0) as f32,
        angle_max: (fov / 2.0 - inc / 2.0) as f32,
        angle_increment: inc as f32,
        time_increment: 0.0,
        scan_time: (1.0 / lidar.rate_hz) as f32,
        range_min: 0.0,
        range_max: range_max as f32,
        ranges,
        intensities: Vec::new(),
    }
}

/// Robot `i`'s fine map as an `OccupancyGrid`: occupancy probability in percent, −1 where
/// unobserved; ROS row 0 is the world's bottom pixel row, the origin where its corner lies.
pub(crate) fn fine_grid(
    world: &ContinuousWorld,
    i: usize,
    frame: &MapFrame,
    t: Time,
) -> OccupancyGrid {
    let map = world.map(i);
    let (h, w, res) = (map.height(), map.width(), map.resolution());
    let mut data = Vec::with_capacity(h * w);
    for r in (0..h).rev() {
        for c in 0..w {
            data.push(if map.observed(r, c) {
                map.percent(r, c)
            } else {
                -1
            });
        }
    }
    let mut msg = OccupancyGrid {
        header: header(t),
        data,
        ..Default::default()
    };
    msg.info.map_load_time = t;
    msg.info.resolution = res as f32;
    msg.info.width = w as u32;
    msg.info.height = h as u32;
    let (x0, y0) = map_point(frame, 0.0, h as f64 * res);
    msg.info.origin = frame.pose(x0, y0, frame.origin[2]);
    msg
}

#[cfg(test)]
mod tests {
    use super::*;
    use madenet_continuous::{ContinuousConfig, Scene};
    use madenet_map::{OccGrid, Occupancy, Pos};
    use std::sync::Arc;

    /// A 10 × 10 m room: a wall at x ∈ [7, 8] m (every row) and one at image y ∈ [8, 9] m
    /// (every column), the robot at (2.5, 5.5) m facing +x.
    fn world() -> ContinuousWorld {
        let mut g = OccGrid::new(10, 10, Occupancy::Free);
        for k in 0..10 {
            g.set(Pos::new(k, 7), Occupancy::Obstacle);
            g.set(Pos::new(8, k), Occupancy::Obstacle);
        }
        let mut cfg = ContinuousConfig::default();
        cfg.lidar.miss_prob = 0.0;
        let scenario = madenet_world::ScenarioConfig {
            num_robots: 1,
            ..Default::default()
        };
        let scene = Arc::new(Scene::from_grid(&g, "walls"));
        ContinuousWorld::new(scene, &[Pos::new(5, 2)], scenario, cfg, 1).unwrap()
    }

    #[test]
    fn scans_run_counter_clockwise_in_the_robots_frame() {
        let w = world();
        let scan = laser_scan(&w, 0, Time::default());
        assert_eq!(scan.ranges.len(), 360);
        assert_eq!(scan.header.frame_id, "robot0/base_link");
        let at = |angle: f64| {
            let j = ((angle - scan.angle_min as f64) / scan.angle_increment as f64).round();
            scan.ranges[j as usize] as f64
        };
        // Ahead: the wall at x = 7, 4.5 m away: beyond d_s = 4 m, no return.
        assert!(at(0.0).is_infinite(), "{}", at(0.0));
        // To the right (ROS −y, the image's +y): the wall at image y = 8, 2.5 m away.
        assert!((at(-std::f64::consts::FRAC_PI_2) - 2.5).abs() < 0.05);
        // To the left: free up to the map's edge at image y = 0, 5.5 m: no return.
        assert!(at(std::f64::consts::FRAC_PI_2).is_infinite());
        assert!(scan.angle_min < 0.0 && scan.angle_max > 0.0 && scan.angle_increment > 0.0);
    }

    #[test]
    fn fine_maps_and_poses_are_in_the_map_frame_with_y_up() {
        let w = world();
        let frame = MapFrame::of(w.coarse_truth());
        let grid = fine_grid(&w, 0, &frame, Time::default());
        let (h, width) = (grid.info.height as usize, grid.info.width as usize);
        assert_eq!((h, width), (100, 100));
        assert_eq!(grid.info.origin.position.y, 0.0);
        // The wall at image y ∈ [8, 9] m is at ROS y ∈ [1, 2] m: ROS rows 10–19. Below the
        // robot (ROS x = 2.5 m, column 25) the first occupied pixel going down from the robot
        // (ROS y = 4.5 m, row 45) is in row 19.
        let v = |row: usize| grid.data[row * width + 25];
        let first = (0..45)
            .rev()
            .find(|&r| v(r) > 65)
            .expect("the wall is mapped");
        assert_eq!(first, 19, "{:?}", (10..46).map(v).collect::<Vec<_>>());
        // Seen free once: one miss, probability 0.4.
        assert!((20..40).all(|r| (0..50).contains(&v(r))), "free between");
        assert_eq!(v(5), -1, "behind the wall: unobserved");
        let facing_down = Pose {
            x: 2.5,
            y: 5.5,
            theta: std::f64::consts::FRAC_PI_2,
        };
        let p = pose_stamped(facing_down, &frame, Time::default());
        // Facing the image's +y (down) is facing ROS −y: yaw −90°.
        assert_eq!((p.pose.position.x, p.pose.position.y), (2.5, 4.5));
        let yaw = |q: crate::msgs::Quaternion| 2.0 * q.z.atan2(q.w);
        assert!((yaw(p.pose.orientation) + std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        assert_eq!(frame.cell_at(2.5, 4.5), Some(w.cell_of(0)));
        // A map file's origin (x, y, yaw) moves and turns everything with it: the goal cell a
        // pose names is still the robot's cell.
        let moved = MapFrame {
            origin: [-3.0, 7.0, std::f64::consts::FRAC_PI_2],
            ..frame
        };
        let p = pose_stamped(facing_down, &moved, Time::default());
        let (x, y) = (p.pose.position.x, p.pose.position.y);
        assert!((x - (-3.0 - 4.5)).abs() < 1e-9 && (y - (7.0 + 2.5)).abs() < 1e-9);
        assert_eq!(moved.cell_at(x, y), Some(w.cell_of(0)));
        assert!(yaw(p.pose.orientation).abs() < 1e-9, "−90° + 90°");
        let g = fine_grid(&w, 0, &moved, Time::default());
        let o = g.info.origin;
        assert!((o.position.x + 3.0).abs() < 1e-9 && (o.position.y - 7.0).abs() < 1e-9);
        assert!((yaw(o.orientation) - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
    }
}
