//! Which cells a robot spares when it writes off what it cannot read, and for how long: the
//! one home of the rule, shared by the in-process continuous trial
//! ([`super::ContinuousTrial`]) and the exploration node (`madenet explore`).
//!
//! A robot that stood in a cell for a scan and still cannot read one of its 8-neighbours
//! writes it off (something thinner than the mapping rule's fraction stands between), or a
//! frontier it cannot resolve would draw it back for ever. Two kinds of cell are spared, for
//! at most the stuck time ([`Spare::renew`]):
//! - a corner (diagonal) neighbour with a side neighbour the robot knows free, can reach and
//!   has not stood in ([`corner_with_open_side`]): from there it may see round the corner
//!   that hid it, and written off it could seal a corridor's far end;
//! - a cell a teammate may hide ([`hidden_by_teammate`]): lidar beams stop at teammates.

use madenet_map::Pos;

/// A cell spared from a robot's write-off: since when it has been spared without a break,
/// when it was spared last, and whether it has started afresh once already.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spare {
    /// Since when (seconds) it has been spared without a break.
    pub first: f64,
    /// When it was spared last.
    pub last: f64,
    /// Whether it started afresh once already.
    pub restarted: bool,
}

impl Spare {
    /// Spared for the first time at `now`.
    pub fn at(now: f64) -> Self {
        Spare {
            first: now,
            last: now,
            restarted: false,
        }
    }

    /// Spares the cell again at `now`; whether it stays spared. Sparing lasts `stuck_time`
    /// from its first time, unless it lapsed: a spare not renewed within `stuck_time` (the
    /// robot went elsewhere) is over, and sparing the cell later starts afresh — once: a
    /// robot that keeps coming back to a cell it cannot read, less often than every
    /// `stuck_time`, would otherwise spare it for ever (an unread cell stays a frontier, so
    /// the idle team's write-off never comes).
    pub fn renew(&mut self, now: f64, stuck_time: f64) -> bool {
        if now - self.last > stuck_time && !self.restarted {
            *self = Spare {
                restarted: true,
                ..Spare::at(now)
            };
        }
        self.last = now;
        now - self.first < stuck_time
    }

    /// Whether its time is up at `now` (it is then written off all the same).
    pub fn expired(&self, now: f64, stuck_time: f64) -> bool {
        now - self.first >= stuck_time
    }
}

/// Whether `q`, an 8-neighbour of `cell`, is a corner (diagonal) neighbour with a side
/// neighbour for which `open_unvisited` holds (known free, reachable, not stood in).
pub fn corner_with_open_side(cell: Pos, q: Pos, open_unvisited: impl Fn(Pos) -> bool) -> bool {
    q.row != cell.row
        && q.col != cell.col
        && [(-1, 0), (1, 0), (0, -1), (0, 1)]
            .iter()
            .any(|&(dr, dc)| open_unvisited(Pos::new(q.row + dr, q.col + dc)))
}

/// Whether a teammate at one of `mates` may hide the point `centre` (a cell's centre) from a
/// robot at `here`: it stands within [`hide_reach`] of the line between them.
pub fn hidden_by_teammate(
    here: (f64, f64),
    centre: (f64, f64),
    mates: &[(f64, f64)],
    reach: f64,
) -> bool {
    mates
        .iter()
        .any(|&m| segment_distance(m, here, centre) < reach)
}

/// How near the line of sight a teammate of footprint `radius` hides a cell of `cell_size`:
/// its radius and half the cell's diagonal.
pub fn hide_reach(radius: f64, cell_size: f64) -> f64 {
    radius + 0.5 * std::f64::consts::SQRT_2 * cell_size
}

/// The distance from `p` to the segment `a`–`b`.
fn segment_distance(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p.0 - a.0 - t * dx).hypot(p.1 - a.1 - t * dy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_corner_is_spared_only_with_an_open_side_and_a_side_cell_never() {
        let cell = Pos::new(5, 5);
        let open = |p: Pos| p == Pos::new(4, 5);
        // (4, 6) is diagonal; its side (4, 5) is open.
        assert!(corner_with_open_side(cell, Pos::new(4, 6), open));
        // (6, 6) is diagonal; none of its sides is open.
        assert!(!corner_with_open_side(cell, Pos::new(6, 6), open));
        // (4, 5)'s neighbours do not matter: a side cell is never a corner.
        assert!(!corner_with_open_side(cell, Pos::new(5, 6), |_| true));
    }

    #[test]
    fn a_teammate_hides_what_lies_behind_it_not_beside_the_line() {
        let reach = hide_reach(0.177, 1.0);
        let (here, behind) = ((0.5, 0.5), (4.5, 0.5));
        assert!(hidden_by_teammate(here, behind, &[(2.5, 0.6)], reach));
        assert!(!hidden_by_teammate(here, behind, &[(2.5, 2.0)], reach));
        // Beyond the cell, not between: not hidden.
        assert!(!hidden_by_teammate(here, behind, &[(7.0, 0.5)], reach));
        assert!(!hidden_by_teammate(here, behind, &[], reach));
    }
}
