//! Maps as costmap_2d and SLAM nodes publish them: the full `nav_msgs/msg/OccupancyGrid` on
//! `<name>` (reliable, transient local, depth 1: a late joiner gets the current map) and, while
//! the map keeps its geometry, only the rectangle that changed as a
//! `map_msgs/msg/OccupancyGridUpdate` on `<name>_updates` — what RViz's map display and
//! nav2's costmap subscribers read.
//!
//! - [`grid_update`] computes the smallest rectangle holding every changed cell;
//!   [`apply_update`] writes one into a grid (and refuses one that does not fit).
//! - [`MapPublisher`] sends the full grid first, whenever the geometry changes, and again at
//!   most every [`MapPublisher::with_full_every`] calls once updates were sent (so that the
//!   transient-local copy a late joiner gets is never far behind); otherwise only the update,
//!   and nothing when the grid did not change.
//! - [`MapSubscriber`] follows both topics and keeps the current grid.
//!
//! Update rectangles are in the `OccupancyGrid`'s own cell order: `x` is the first column,
//! `y` the first row counted from the origin (row 0 is the row at the origin), data row-major.
//!
//! QoS of `<name>_updates`: reliable, volatile, keep last 10 ([`updates_qos`]). nav2's
//! `Costmap2DPublisher` publishes its updates with the map's own QoS (reliable, transient
//! local, keep last 1); volatile is used here because an update only makes sense on top of
//! the grid it was computed from, and a late joiner's cached update could be older than the
//! full grid it gets at the same time. ROS subscribers asking for either durability receive
//! them (a volatile subscription matches both; rmw_zenoh does not enforce durability).

use crate::msgs::{OccupancyGrid, OccupancyGridUpdate, Time};
use crate::rmw::{Node, Publisher, QosProfile, Subscription};
use crate::{map_qos, Ros2Error};
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// The QoS of a map's `*_updates` topic: reliable, volatile, keep last 10 (see the module doc).
pub fn updates_qos() -> QosProfile {
    QosProfile::default()
}

/// How `new` differs from `old`.
enum Diff {
    /// Size, resolution or origin differ (or a grid's data does not fit its size).
    Geometry,
    /// Same geometry, same cells.
    Same,
    /// Same geometry; the rectangle of changed cells.
    Changed(OccupancyGridUpdate),
}

/// `width × height` when `data` has exactly that many cells.
fn fits(grid: &OccupancyGrid) -> bool {
    grid.info.width as u64 * grid.info.height as u64 == grid.data.len() as u64
}

fn same_geometry(a: &OccupancyGrid, b: &OccupancyGrid) -> bool {
    a.info.width == b.info.width
        && a.info.height == b.info.height
        && a.info.resolution == b.info.resolution
        && a.info.origin == b.info.origin
}

fn diff(old: &OccupancyGrid, new: &OccupancyGrid) -> Diff {
    if !same_geometry(old, new) || !fits(old) || !fits(new) {
        return Diff::Geometry;
    }
    let w = new.info.width as usize;
    // Bounds of the changed cells: columns [x0, x1], rows [y0, y1].
    let mut bounds: Option<(usize, usize, usize, usize)> = None;
    for (row, (a, b)) in old
        .data
        .chunks_exact(w.max(1))
        .zip(new.data.chunks_exact(w.max(1)))
        .enumerate()
    {
        let Some(first) = a.iter().zip(b).position(|(p, q)| p != q) else {
            continue;
        };
        let last = a
            .iter()
            .zip(b)
            .rposition(|(p, q)| p != q)
            .expect("a row with a first change has a last one");
        bounds = Some(match bounds {
            None => (first, last, row, row),
            Some((x0, x1, y0, _)) => (x0.min(first), x1.max(last), y0, row),
        });
    }
    let Some((x0, x1, y0, y1)) = bounds else {
        return Diff::Same;
    };
    // The grid's width and height are u32, so every index fits a u32; x and y are int32 on
    // the wire.
    let (Ok(x), Ok(y)) = (i32::try_from(x0), i32::try_from(y0)) else {
        return Diff::Geometry;
    };
    let data = (y0..=y1)
        .flat_map(|r| new.data[r * w + x0..=r * w + x1].iter().copied())
        .collect();
    Diff::Changed(OccupancyGridUpdate {
        header: new.header.clone(),
        x,
        y,
        width: (x1 - x0 + 1) as u32,
        height: (y1 - y0 + 1) as u32,
        data,
    })
}

/// The update that turns `old` into `new`: the smallest rectangle holding every cell that
/// changed, as costmap_2d and SLAM nodes publish on `*_updates` (`x` the first column, `y`
/// the first row from the origin, data row-major), with `new`'s header. `None` when no cell
/// changed — and also when the two grids' geometry (width, height, resolution or origin)
/// differs, or a grid's data does not fit its size: an update cannot say that, so the caller
/// must publish the full grid then. `map_load_time` is not compared (an update cannot carry
/// it).
pub fn grid_update(old: &OccupancyGrid, new: &OccupancyGrid) -> Option<OccupancyGridUpdate> {
    match diff(old, new) {
        Diff::Changed(u) => Some(u),
        Diff::Same | Diff::Geometry => None,
    }
}

/// Writes `u`'s rectangle into `grid` and takes its header. Refuses, leaving `grid` as it
/// was, a negative `x` or `y`, data that is not `width × height` cells, a rectangle that
/// reaches outside the grid, or a grid whose own data does not fit its size.
pub fn apply_update(grid: &mut OccupancyGrid, u: &OccupancyGridUpdate) -> Result<(), String> {
    if u.x < 0 || u.y < 0 {
        return Err(format!(
            "update at x = {}, y = {}: negative corner",
            u.x, u.y
        ));
    }
    let (x, y) = (u.x as u64, u.y as u64);
    let (w, h) = (u.width as u64, u.height as u64);
    if u.data.len() as u64 != w * h {
        return Err(format!(
            "update of {} × {} cells carries {} values",
            u.width,
            u.height,
            u.data.len()
        ));
    }
    let (gw, gh) = (grid.info.width as u64, grid.info.height as u64);
    if !fits(grid) {
        return Err(format!(
            "grid of {gw} × {gh} cells holds {} values",
            grid.data.len()
        ));
    }
    if x + w > gw || y + h > gh {
        return Err(format!(
            "update of {w} × {h} cells at x = {x}, y = {y} reaches outside the {gw} × {gh} grid"
        ));
    }
    // Every index below is within the grid (checked above), hence fits a usize.
    let (x, y, w, gw) = (x as usize, y as usize, w as usize, gw as usize);
    if w > 0 {
        for (r, row) in u.data.chunks_exact(w).enumerate() {
            let at = (y + r) * gw + x;
            grid.data[at..at + w].copy_from_slice(row);
        }
    }
    grid.header = u.header.clone();
    Ok(())
}

fn time_key(t: Time) -> (i32, u32) {
    (t.sec, t.nanosec)
}

/// Publishes a map as costmap_2d does: the full grid on `<name>` (transient local), the
/// changed rectangle on `<name>_updates` (see the module doc).
pub struct MapPublisher {
    topic: String,
    full: Publisher<OccupancyGrid>,
    updates: Publisher<OccupancyGridUpdate>,
    /// The grid as subscribers have it: the last one sent, full or through updates.
    last: Option<OccupancyGrid>,
    full_every: usize,
    /// Calls since the last full grid.
    since_full: usize,
    /// Whether updates were sent since the last full grid (its cached copy is behind).
    behind: bool,
    full_sent: usize,
    updates_sent: usize,
}

impl MapPublisher {
    /// Publishers on `name` (relative names resolve in `node`'s namespace: `map` in `/robot0`
    /// is `/robot0/map`) with [`map_qos`] and on `<name>_updates` with [`updates_qos`]. Full
    /// grids are re-sent at most every 10 calls ([`MapPublisher::with_full_every`]).
    pub fn new(node: &Node, name: &str) -> Result<Self, Ros2Error> {
        let topic = node.resolve(name);
        Ok(MapPublisher {
            full: node.create_pub(&topic, map_qos())?,
            updates: node.create_pub(&format!("{topic}_updates"), updates_qos())?,
            topic,
            last: None,
            full_every: 10,
            since_full: 0,
            behind: false,
            full_sent: 0,
            updates_sent: 0,
        })
    }

    /// After a full grid, the next `n` calls send updates only; the call after them sends
    /// the full grid again if anything changed since the last one (so that a late joiner's
    /// transient-local copy is at most `n` calls old). `0` or `1`: every change is sent as a
    /// full grid.
    pub fn with_full_every(mut self, n: usize) -> Self {
        self.full_every = n;
        self
    }

    /// The full grid's topic (the updates go on this name with `_updates`).
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// Publishes `grid`: in full on the first call, when its geometry changed, and when
    /// [`MapPublisher::with_full_every`] calls passed since the last full grid and something
    /// changed since; otherwise the changed rectangle as an update, or nothing when no cell
    /// changed (a new stamp alone is not sent). A grid whose data does not fit its size is
    /// refused ([`Ros2Error::BadMessage`]) and not sent.
    pub fn publish(&mut self, grid: &OccupancyGrid) -> Result<(), Ros2Error> {
        if !fits(grid) {
            return Err(Ros2Error::BadMessage {
                topic: self.topic.clone(),
                field: "data",
                why: format!(
                    "{} values for {} × {} cells",
                    grid.data.len(),
                    grid.info.width,
                    grid.info.height
                ),
            });
        }
        let d = match &self.last {
            None => Diff::Geometry,
            Some(last) => diff(last, grid),
        };
        let due = self.since_full >= self.full_every.max(1);
        match d {
            Diff::Geometry => self.send_full(grid)?,
            Diff::Changed(_) if due => self.send_full(grid)?,
            Diff::Same if due && self.behind => self.send_full(grid)?,
            Diff::Changed(u) => {
                self.updates.publish(&u)?;
                self.updates_sent += 1;
                self.behind = true;
                self.since_full += 1;
                self.last = Some(grid.clone());
            }
            Diff::Same => self.since_full += 1,
        }
        Ok(())
    }

    fn send_full(&mut self, grid: &OccupancyGrid) -> Result<(), Ros2Error> {
        self.full.publish(grid)?;
        self.full_sent += 1;
        self.since_full = 0;
        self.behind = false;
        self.last = Some(grid.clone());
        Ok(())
    }

    /// The grid as subscribers have it now (the last one sent, in full or as an update).
    pub fn last(&self) -> Option<&OccupancyGrid> {
        self.last.as_ref()
    }

    /// Full grids sent so far.
    pub fn full_sent(&self) -> usize {
        self.full_sent
    }

    /// Updates sent so far.
    pub fn updates_sent(&self) -> usize {
        self.updates_sent
    }
}

/// Follows a map published as [`MapPublisher`] (or costmap_2d) does: full grids on `<name>`
/// and updates on `<name>_updates`.
///
/// The two topics are two streams; within what arrived at once, full grids and updates are
/// put in order by their header stamps (a full grid first when the stamps are equal), so
/// maps should be stamped with increasing times, as ROS maps are. An update arriving before
/// any full grid, one older than the grid it would change, or one that does not fit the grid
/// is skipped and counted ([`MapSubscriber::refused`]); the next full grid makes up for it.
pub struct MapSubscriber {
    topic: String,
    full: Subscription<OccupancyGrid>,
    updates: Subscription<OccupancyGridUpdate>,
    grid: Option<OccupancyGrid>,
    refused: usize,
    full_received: usize,
    updates_applied: usize,
}

impl MapSubscriber {
    /// Subscriptions to `name` (relative names resolve in `node`'s namespace) with
    /// [`map_qos`], and to `<name>_updates` with [`updates_qos`]. The updates are subscribed
    /// first: by the time the full grid's transient-local history arrives, the publisher's
    /// updates already reach this subscriber.
    pub fn new(node: &Node, name: &str) -> Result<Self, Ros2Error> {
        Self::with_updates(node, name, &format!("{name}_updates"))
    }

    /// [`MapSubscriber::new`] with the updates on `updates` (explore_lite's
    /// `costmap_updates_topic`) instead of `<name>_updates`.
    pub fn with_updates(node: &Node, name: &str, updates: &str) -> Result<Self, Ros2Error> {
        let topic = node.resolve(name);
        let updates = node.create_sub(&node.resolve(updates), updates_qos())?;
        let full = node.create_sub(&topic, map_qos())?;
        Ok(MapSubscriber {
            topic,
            full,
            updates,
            grid: None,
            refused: 0,
            full_received: 0,
            updates_applied: 0,
        })
    }

    /// Takes every full grid and update that arrived, waiting up to `wait` for something new
    /// while none has; returns the current grid (`None` until a full grid was heard).
    pub fn latest(&mut self, wait: Duration) -> Result<Option<&OccupancyGrid>, Ros2Error> {
        let deadline = Instant::now() + wait;
        loop {
            if self.drain()? > 0 && self.grid.is_some() {
                break;
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            std::thread::sleep(left.min(Duration::from_millis(5)));
        }
        Ok(self.grid.as_ref())
    }

    /// Takes what arrived, without waiting: the current grid if something new came since the
    /// last call, else `None`.
    pub fn poll(&mut self) -> Result<Option<&OccupancyGrid>, Ros2Error> {
        Ok(match self.drain()? {
            0 => None,
            _ => self.grid.as_ref(),
        })
    }

    /// Takes what arrived on both topics, in stamp order; returns how many messages.
    fn drain(&mut self) -> Result<usize, Ros2Error> {
        let mut fulls = VecDeque::new();
        while let Some(g) = self.full.recv_timeout(Duration::ZERO)? {
            fulls.push_back(g);
        }
        let mut updates = VecDeque::new();
        while let Some(u) = self.updates.recv_timeout(Duration::ZERO)? {
            updates.push_back(u);
        }
        let n = fulls.len() + updates.len();
        loop {
            let full_first = match (fulls.front(), updates.front()) {
                (None, None) => break,
                (Some(_), None) => true,
                (None, Some(_)) => false,
                (Some(g), Some(u)) => time_key(g.header.stamp) <= time_key(u.header.stamp),
            };
            if full_first {
                let g = fulls.pop_front().expect("checked");
                self.take_full(g);
            } else {
                let u = updates.pop_front().expect("checked");
                self.take_update(&u);
            }
        }
        Ok(n)
    }

    fn take_full(&mut self, g: OccupancyGrid) {
        if !fits(&g) {
            self.refused += 1;
            tracing::warn!(
                "{}: skipped a map of {} × {} cells with {} values",
                self.topic,
                g.info.width,
                g.info.height,
                g.data.len()
            );
            return;
        }
        self.full_received += 1;
        self.grid = Some(g);
    }

    fn take_update(&mut self, u: &OccupancyGridUpdate) {
        let why = match &mut self.grid {
            None => "no full map yet".to_string(),
            Some(g) if time_key(u.header.stamp) < time_key(g.header.stamp) => {
                "older than the map".to_string()
            }
            Some(g) => match apply_update(g, u) {
                Ok(()) => {
                    self.updates_applied += 1;
                    return;
                }
                Err(why) => why,
            },
        };
        self.refused += 1;
        tracing::warn!("{}_updates: skipped an update: {why}", self.topic);
    }

    /// The full grid's topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// Messages skipped so far: updates before any full grid, older than the grid, or not
    /// fitting it, and full grids whose data does not fit their size.
    pub fn refused(&self) -> usize {
        self.refused
    }

    /// Full grids taken so far.
    pub fn full_received(&self) -> usize {
        self.full_received
    }

    /// Updates applied so far.
    pub fn updates_applied(&self) -> usize {
        self.updates_applied
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::{Header, MapMetaData, Point, Pose};

    /// A small deterministic generator (xorshift64*).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
        }
        fn below(&mut self, n: u64) -> u64 {
            self.next() % n
        }
        fn cell(&mut self) -> i8 {
            [-1, 0, 100, 37][self.below(4) as usize]
        }
    }

    fn grid(w: u32, h: u32, rng: &mut Rng) -> OccupancyGrid {
        OccupancyGrid {
            header: Header {
                stamp: Time { sec: 5, nanosec: 0 },
                frame_id: "map".into(),
            },
            info: MapMetaData {
                resolution: 0.05,
                width: w,
                height: h,
                origin: Pose {
                    position: Point {
                        x: -1.0,
                        y: 2.0,
                        z: 0.0,
                    },
                    ..Pose::default()
                },
                ..MapMetaData::default()
            },
            data: (0..w * h).map(|_| rng.cell()).collect(),
        }
    }

    #[test]
    fn applying_the_update_of_two_grids_gives_the_new_one() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        for case in 0..400 {
            let (w, h) = (1 + rng.below(17) as u32, 1 + rng.below(13) as u32);
            let old = grid(w, h, &mut rng);
            let mut new = old.clone();
            new.header.stamp.sec = 6;
            // A few changed cells (some cases none, some many).
            let n = [0, 1, 2, 5, 40][case % 5];
            for _ in 0..n {
                let i = rng.below((w * h) as u64) as usize;
                new.data[i] = rng.cell();
            }
            let changed_cells = old.data.iter().zip(&new.data).filter(|(a, b)| a != b);
            let Some(u) = grid_update(&old, &new) else {
                assert_eq!(changed_cells.count(), 0, "case {case}");
                assert_eq!(old.data, new.data);
                continue;
            };
            assert!(changed_cells.count() > 0);
            // The smallest rectangle: each of its border rows and columns holds a change.
            let (x0, y0) = (u.x as usize, u.y as usize);
            let (x1, y1) = (x0 + u.width as usize - 1, y0 + u.height as usize - 1);
            let at = |i: usize| (i % w as usize, i / w as usize);
            let differs: Vec<(usize, usize)> = (0..old.data.len())
                .filter(|&i| old.data[i] != new.data[i])
                .map(at)
                .collect();
            assert_eq!(differs.iter().map(|p| p.0).min(), Some(x0));
            assert_eq!(differs.iter().map(|p| p.0).max(), Some(x1));
            assert_eq!(differs.iter().map(|p| p.1).min(), Some(y0));
            assert_eq!(differs.iter().map(|p| p.1).max(), Some(y1));
            assert_eq!(u.header, new.header);
            let mut back = old.clone();
            apply_update(&mut back, &u).unwrap();
            assert_eq!(back, new, "case {case}");
        }
    }

    #[test]
    fn rows_count_from_the_origin_and_other_geometry_needs_the_full_grid() {
        let mut rng = Rng(7);
        let old = grid(4, 3, &mut rng);
        let mut new = old.clone();
        // Row 2 (the last in data), column 1.
        new.data[2 * 4 + 1] = if old.data[9] == 100 { 0 } else { 100 };
        let u = grid_update(&old, &new).unwrap();
        assert_eq!((u.x, u.y, u.width, u.height), (1, 2, 1, 1));
        assert_eq!(u.data, vec![new.data[9]]);
        // Unchanged: nothing; a new stamp alone is no change.
        let mut restamped = old.clone();
        restamped.header.stamp.sec += 1;
        assert_eq!(grid_update(&old, &restamped), None);
        // Another size, resolution or origin: None (publish the full grid).
        for change in 0..4 {
            let mut other = new.clone();
            match change {
                0 => {
                    other.info.width = 3;
                    other.info.height = 4;
                }
                1 => other.info.resolution = 0.1,
                2 => other.info.origin.position.x += 0.5,
                _ => other.data.push(0),
            }
            assert_eq!(grid_update(&old, &other), None, "change {change}");
        }
    }

    #[test]
    fn updates_that_do_not_fit_are_refused_and_change_nothing() {
        let mut rng = Rng(11);
        let g = grid(5, 4, &mut rng);
        let ok = OccupancyGridUpdate {
            header: g.header.clone(),
            x: 3,
            y: 2,
            width: 2,
            height: 2,
            data: vec![1, 2, 3, 4],
        };
        let mut applied = g.clone();
        apply_update(&mut applied, &ok).unwrap();
        assert_eq!(applied.data[2 * 5 + 3..2 * 5 + 5], [1, 2]);
        assert_eq!(applied.data[3 * 5 + 3..3 * 5 + 5], [3, 4]);
        let bad = [
            (
                OccupancyGridUpdate {
                    x: -1,
                    ..ok.clone()
                },
                "negative",
            ),
            (
                OccupancyGridUpdate {
                    y: -3,
                    ..ok.clone()
                },
                "negative",
            ),
            (OccupancyGridUpdate { x: 4, ..ok.clone() }, "outside"),
            (OccupancyGridUpdate { y: 3, ..ok.clone() }, "outside"),
            (
                OccupancyGridUpdate {
                    data: vec![1, 2, 3],
                    ..ok.clone()
                },
                "values",
            ),
            // Sizes whose product or sum would overflow 32 bits.
            (
                OccupancyGridUpdate {
                    x: i32::MAX,
                    width: u32::MAX,
                    height: 0,
                    data: vec![],
                    ..ok.clone()
                },
                "outside",
            ),
            (
                OccupancyGridUpdate {
                    width: u32::MAX,
                    height: u32::MAX,
                    ..ok.clone()
                },
                "values",
            ),
        ];
        for (u, why) in bad {
            let mut h = g.clone();
            let e = apply_update(&mut h, &u).unwrap_err();
            assert!(e.contains(why), "{e}");
            assert_eq!(h, g, "a refused update changes nothing");
        }
        // A grid whose own data does not fit its size.
        let mut broken = g.clone();
        broken.data.pop();
        assert!(apply_update(&mut broken, &ok).unwrap_err().contains("grid"));
        // An empty rectangle is a valid no-op on the cells.
        let mut h = g.clone();
        let empty = OccupancyGridUpdate {
            x: 5,
            y: 4,
            width: 0,
            height: 0,
            data: vec![],
            ..ok
        };
        apply_update(&mut h, &empty).unwrap();
        assert_eq!(h.data, g.data);
    }
}
