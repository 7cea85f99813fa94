//! One robot's map: an occupancy-probability grid in log-odds, built from its own scans, and
//! the agent's cells read from it by the paper's rule (Sec. V.B.1: a cell is an obstacle when
//! more than 25 % of its pixels have occupancy probability above 65 %).
//!
//! The agent's belief is write-once but for one upgrade (free → obstacle), so each cell is
//! reported when it first becomes known, and again if it turns into an obstacle: a cell is an
//! obstacle as soon as its occupied pixels exceed the rule's fraction of its observed pixels,
//! or of half its pixels while fewer are observed (a sensor never sees inside an obstacle); it
//! is known free once `known_fraction` of its pixels have been observed without that.

use crate::config::MappingConfig;
use madenet_map::discretize::DiscretizeParams;
use madenet_map::{Occupancy, Pos};

/// A robot's fine map and the coarse cells derived from it.
#[derive(Clone, Debug)]
pub struct RobotMap {
    cfg: MappingConfig,
    /// Log-odds above this are occupied (logit of `occupied_prob`).
    occupied_log_odds: f32,
    obstacle_fraction: f64,
    height: usize,
    width: usize,
    log_odds: Vec<f32>,
    observed: Vec<bool>,
    /// Pixels a beam of the scan being integrated ended on (cleared after each scan).
    hit_now: Vec<bool>,
    coarse_height: usize,
    coarse_width: usize,
    /// Coarse cell of each fine row / column.
    row_cell: Vec<u32>,
    col_cell: Vec<u32>,
    pixels: Vec<u32>,
    observed_in: Vec<u32>,
    occupied_in: Vec<u32>,
    coarse: Vec<Occupancy>,
    /// The radius occupied pixels are inflated by ([`RobotMap::with_inflation`]; 0: none).
    inflation: f64,
    /// Pixel offsets within `inflation` of a pixel's centre (nearest point of the pixel).
    kernel: Vec<(i64, i64)>,
    /// Per pixel, the occupied pixels within `inflation` of its centre.
    inflated: Vec<u32>,
    /// Coarse cells that changed since [`RobotMap::take_changes`] last ran.
    changes: Vec<(Pos, Occupancy)>,
}

impl RobotMap {
    /// An empty map of `height` × `width` pixels of `cfg.resolution` metres, read in cells of
    /// `cell_size` metres by `rule`.
    pub fn new(
        height: usize,
        width: usize,
        cell_size: f64,
        cfg: MappingConfig,
        rule: &DiscretizeParams,
    ) -> Self {
        let madenet_map::discretize::CellTables {
            row_cell,
            col_cell,
            rows: coarse_height,
            cols: coarse_width,
            pixels,
        } = madenet_map::discretize::CellTables::new(height, width, cfg.resolution, cell_size);
        let p = rule.occupied_prob.clamp(1e-6, 1.0 - 1e-6);
        RobotMap {
            cfg,
            occupied_log_odds: (p / (1.0 - p)).ln() as f32,
            obstacle_fraction: rule.obstacle_fraction,
            height,
            width,
            log_odds: vec![0.0; height * width],
            observed: vec![false; height * width],
            hit_now: vec![false; height * width],
            coarse_height,
            coarse_width,
            row_cell,
            col_cell,
            pixels,
            observed_in: vec![0; coarse_height * coarse_width],
            occupied_in: vec![0; coarse_height * coarse_width],
            coarse: vec![Occupancy::Unknown; coarse_height * coarse_width],
            inflation: 0.0,
            kernel: Vec::new(),
            inflated: Vec::new(),
            changes: Vec::new(),
        }
    }

    /// This map with its occupied pixels inflated by `radius` metres (the local planner's
    /// footprint plus margin), kept up to date as pixels turn occupied or free, so that
    /// [`RobotMap::blocked`] answers [`RobotMap::disc_hits_occupied`] at a pixel's centre in
    /// constant time (the costmap inflation of nav2, exact for the disc).
    pub fn with_inflation(mut self, radius: f64) -> Self {
        let res = self.cfg.resolution;
        self.kernel = disc_kernel(radius, res);
        self.inflation = radius;
        self.inflated = vec![0; self.height * self.width];
        for r in 0..self.height {
            for c in 0..self.width {
                if self.occupied(r, c) {
                    self.stamp(r, c, true);
                }
                // The map's edge is a wall (nothing lies beyond it), counted once for good.
                let (x, y) = ((c as f64 + 0.5) * res, (r as f64 + 0.5) * res);
                let (w, h) = (self.width as f64 * res, self.height as f64 * res);
                if x.min(y).min(w - x).min(h - y) < radius {
                    self.inflated[r * self.width + c] += 1;
                }
            }
        }
        self
    }

    /// The radius of [`RobotMap::with_inflation`] (0 when not inflated).
    pub fn inflation(&self) -> f64 {
        self.inflation
    }

    /// Whether a disc of [`RobotMap::inflation`] at pixel (`r`, `c`)'s centre touches an
    /// occupied pixel or the map's edge. Only on an inflated map.
    #[inline]
    pub fn blocked(&self, r: usize, c: usize) -> bool {
        self.inflated[r * self.width + c] > 0
    }

    /// Counts occupied pixel (`r`, `c`) in (`add`) or out of the inflation around it.
    fn stamp(&mut self, r: usize, c: usize, add: bool) {
        for &(dr, dc) in &self.kernel {
            let (nr, nc) = (r as i64 + dr, c as i64 + dc);
            if nr < 0 || nc < 0 || nr as usize >= self.height || nc as usize >= self.width {
                continue;
            }
            let k = &mut self.inflated[nr as usize * self.width + nc as usize];
            if add {
                *k += 1;
            } else {
                *k -= 1;
            }
        }
    }

    /// Pixel rows.
    pub fn height(&self) -> usize {
        self.height
    }
    /// Pixel columns.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Pixel size in metres.
    pub fn resolution(&self) -> f64 {
        self.cfg.resolution
    }
    /// The agent's cells: rows and columns.
    pub fn coarse_size(&self) -> (usize, usize) {
        (self.coarse_height, self.coarse_width)
    }
    /// The agent's cells as this map reads them.
    pub fn coarse(&self) -> &[Occupancy] {
        &self.coarse
    }
    /// Whether pixel (`r`, `c`) is occupied (probability above the rule's threshold).
    #[inline]
    pub fn occupied(&self, r: usize, c: usize) -> bool {
        self.log_odds[r * self.width + c] > self.occupied_log_odds
    }
    /// Whether pixel (`r`, `c`) has been observed.
    #[inline]
    pub fn observed(&self, r: usize, c: usize) -> bool {
        self.observed[r * self.width + c]
    }
    /// Occupancy probability of every pixel (0.5 where unobserved), row-major: the map as
    /// RTAB-Map or gmapping would publish it.
    pub fn probabilities(&self) -> Vec<f64> {
        self.log_odds
            .iter()
            .map(|&l| 1.0 / (1.0 + (-l as f64).exp()))
            .collect()
    }

    /// Pixel (`r`, `c`)'s occupancy in percent, `round(100 p)` of its probability, as ROS maps
    /// carry it. No `exp`: the percent is how many of the 100 log-odds bounds between two
    /// percents the pixel's log-odds reach (computed once).
    pub fn percent(&self, r: usize, c: usize) -> i8 {
        static BOUNDS: std::sync::OnceLock<[f64; 100]> = std::sync::OnceLock::new();
        // Percent k+1 from p = (k + ½)/100 up (round half away from zero), as log-odds.
        let bounds = BOUNDS.get_or_init(|| {
            std::array::from_fn(|k| {
                let p = (k as f64 + 0.5) / 100.0;
                (p / (1.0 - p)).ln()
            })
        });
        let l = self.log_odds[r * self.width + c] as f64;
        bounds.partition_point(|&b| b <= l) as i8
    }

    /// The coarse cells that changed since the last call, in the order they changed.
    pub fn take_changes(&mut self, out: &mut Vec<(Pos, Occupancy)>) {
        out.append(&mut self.changes);
    }

    /// Marks coarse cell `p` an obstacle (the local planner proved it impassable).
    pub fn block(&mut self, p: Pos) {
        let i = p.row as usize * self.coarse_width + p.col as usize;
        if self.coarse[i] != Occupancy::Obstacle {
            self.coarse[i] = Occupancy::Obstacle;
            self.changes.push((p, Occupancy::Obstacle));
        }
    }

    /// Integrates one beam from (`x0`, `y0`) to (`x1`, `y1`) (metres), as a scan of its own:
    /// every pixel it crosses is observed free; the last is observed occupied when `hit`.
    pub fn integrate_beam(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, hit: bool) {
        self.integrate_scan(x0, y0, &[(x1, y1, hit)]);
    }

    /// Integrates one scan from (`x0`, `y0`): beams ending at (`x`, `y`) (metres), returned
    /// from an obstacle there when the flag is set. Each beam is a measurement of its own: every
    /// pixel it crosses is observed free, its last pixel occupied when it returned — but a pixel
    /// some beam of the scan returned from is not freed by the others that cross it: an object
    /// smaller than a few pixels (a cylinder) fills only part of its pixels, and the beams that
    /// graze it would otherwise free the pixels the beams that hit it mark. (OctoMap's one update
    /// per pixel and scan, occupied winning, was measured 25 % faster, but with the default range
    /// noise it thickened every wall by the free pixel before it, and cells along walls turned
    /// into obstacles.)
    pub fn integrate_scan(&mut self, x0: f64, y0: f64, ends: &[(f64, f64, bool)]) {
        let res = self.cfg.resolution;
        let (h, w) = (self.height as i64, self.width as i64);
        let (miss, hit) = (self.cfg.miss_log_odds as f32, self.cfg.hit_log_odds as f32);
        let end_of = move |x1: f64, y1: f64| {
            let (r, c) = (floor(y1 / res), floor(x1 / res));
            (r >= 0 && c >= 0 && r < h && c < w).then_some((r * w + c) as usize)
        };
        for &(x1, y1, returned) in ends {
            if let (true, Some(i)) = (returned, end_of(x1, y1)) {
                self.hit_now[i] = true;
            }
        }
        for &(x1, y1, returned) in ends {
            let end = (floor(y1 / res), floor(x1 / res));
            traverse(x0 / res, y0 / res, x1 / res, y1 / res, |r, c| {
                if r >= 0 && c >= 0 && r < h && c < w {
                    let (r, c) = (r as usize, c as usize);
                    if returned && (r as i64, c as i64) == end {
                        self.update(r, c, hit);
                    } else if !self.hit_now[r * self.width + c] {
                        self.update(r, c, miss);
                    }
                }
            });
        }
        for &(x1, y1, returned) in ends {
            if let (true, Some(i)) = (returned, end_of(x1, y1)) {
                self.hit_now[i] = false;
            }
        }
    }

    #[inline]
    fn update(&mut self, r: usize, c: usize, delta: f32) {
        let i = r * self.width + c;
        let before = self.log_odds[i];
        let after =
            (before + delta).clamp(self.cfg.min_log_odds as f32, self.cfg.max_log_odds as f32);
        // Saturated (most free pixels near a robot): nothing changes. A pixel whose log-odds
        // are not 0 (the prior) has been written, so is observed: the flag is read only at 0.
        if after == before && (before != 0.0 || self.observed[i]) {
            return;
        }
        let was_observed = self.observed[i];
        self.log_odds[i] = after;
        let (was_occ, is_occ) = (
            before > self.occupied_log_odds,
            after > self.occupied_log_odds,
        );
        if was_observed && was_occ == is_occ {
            return;
        }
        self.observed[i] = true;
        let cell = self.row_cell[r] as usize * self.coarse_width + self.col_cell[c] as usize;
        if !was_observed {
            self.observed_in[cell] += 1;
        }
        if is_occ && !was_occ {
            self.occupied_in[cell] += 1;
            self.stamp(r, c, true);
        } else if was_occ && !is_occ {
            self.occupied_in[cell] -= 1;
            self.stamp(r, c, false);
        }
        self.refresh(cell);
    }

    /// Re-reads coarse cell `cell` after one of its pixels changed.
    fn refresh(&mut self, cell: usize) {
        let now = self.coarse[cell];
        if now == Occupancy::Obstacle {
            return;
        }
        // Write-once but for the upgrade to an obstacle (module docs).
        let read = madenet_map::discretize::read_partial_cell(
            self.pixels[cell],
            self.observed_in[cell],
            self.occupied_in[cell],
            self.obstacle_fraction,
            self.cfg.known_fraction,
        );
        let next = madenet_map::discretize::write_once(now, read);
        if next != now {
            self.coarse[cell] = next;
            let p = Pos::new(
                (cell / self.coarse_width) as i32,
                (cell % self.coarse_width) as i32,
            );
            self.changes.push((p, next));
        }
    }

    /// Whether a disc of `radius` metres at (`x`, `y`) overlaps an occupied pixel or the map's
    /// edge (a wall: nothing lies beyond it).
    pub fn disc_hits_occupied(&self, x: f64, y: f64, radius: f64) -> bool {
        let res = self.cfg.resolution;
        let (w, h) = (self.width as f64 * res, self.height as f64 * res);
        if x.min(y).min(w - x).min(h - y) < radius {
            return true;
        }
        let r0 = floor((y - radius) / res).max(0) as usize;
        let c0 = floor((x - radius) / res).max(0) as usize;
        let r1 = (floor((y + radius) / res).max(0) as usize).min(self.height.saturating_sub(1));
        let c1 = (floor((x + radius) / res).max(0) as usize).min(self.width.saturating_sub(1));
        if r0 > r1 || c0 > c1 {
            return false;
        }
        // Most discs lie in cells without a single occupied pixel: the cells' counts answer
        // without a look at the pixels (the local planner asks thousands of times a second).
        let (cr0, cr1) = (self.row_cell[r0] as usize, self.row_cell[r1] as usize);
        let (cc0, cc1) = (self.col_cell[c0] as usize, self.col_cell[c1] as usize);
        if (cr0..=cr1).all(|cr| {
            self.occupied_in[cr * self.coarse_width + cc0..=cr * self.coarse_width + cc1]
                .iter()
                .all(|&k| k == 0)
        }) {
            return false;
        }
        for r in r0..=r1 {
            for c in c0..=c1 {
                if !self.occupied(r, c) {
                    continue;
                }
                // Nearest point of the pixel to the centre.
                let nx = x.clamp(c as f64 * res, (c + 1) as f64 * res);
                let ny = y.clamp(r as f64 * res, (r + 1) as f64 * res);
                if (nx - x).powi(2) + (ny - y).powi(2) < radius * radius {
                    return true;
                }
            }
        }
        false
    }
}

/// Pixel offsets (rows, columns) whose pixel comes within `radius` metres of a pixel centre
/// (pixels of `res` metres): the footprint inflation of [`RobotMap::with_inflation`] and
/// [`crate::Scene::drivable`].
pub(crate) fn disc_kernel(radius: f64, res: f64) -> Vec<(i64, i64)> {
    let reach = (radius / res).ceil() as i64 + 1;
    // The nearest point of a pixel `d` pixels away lies (|d| − ½) pixels from a centre.
    let gap = |d: i64| (d.abs() as f64 - 0.5).max(0.0) * res;
    (-reach..=reach)
        .flat_map(|dr| (-reach..=reach).map(move |dc| (dr, dc)))
        .filter(|&(dr, dc)| gap(dr).powi(2) + gap(dc).powi(2) < radius * radius)
        .collect()
}

/// `x.floor() as i64`, inline: without SSE4.1 (the x86-64 baseline) `f64::floor` is a libm
/// call, 4 % of a continuous trial's time in the map updates' per-beam pixel arithmetic.
#[inline]
pub(crate) fn floor(x: f64) -> i64 {
    let t = x as i64; // Truncates toward 0 (saturating; NaN → 0, as `floor() as i64`).
    t.saturating_sub(((t as f64) > x) as i64)
}

/// The pixels a segment from (`gx0`, `gy0`) to (`gx1`, `gy1`) (in pixels) crosses, in order,
/// both ends included: Amanatides–Woo, by hand (the inner loop of mapping, no allocation).
fn traverse(gx0: f64, gy0: f64, gx1: f64, gy1: f64, mut visit: impl FnMut(i64, i64)) {
    let (mut c, mut r) = (floor(gx0), floor(gy0));
    let (c_end, r_end) = (floor(gx1), floor(gy1));
    // Per axis: the step, the parameter between pixel borders, the parameter of the first one.
    let axis = |g0: f64, d: f64, k: i64| -> (i64, f64, f64) {
        let t_delta = (1.0 / d).abs();
        if d > 0.0 {
            (1, t_delta, (k as f64 + 1.0 - g0) * t_delta)
        } else if d < 0.0 {
            (-1, t_delta, (g0 - k as f64) * t_delta)
        } else {
            (-1, f64::INFINITY, f64::INFINITY)
        }
    };
    let (step_c, t_delta_c, mut t_max_c) = axis(gx0, gx1 - gx0, c);
    let (step_r, t_delta_r, mut t_max_r) = axis(gy0, gy1 - gy0, r);
    // Rounding can step past the end pixel: the walk is bounded by its Manhattan length.
    let limit = (c - c_end).abs() + (r - r_end).abs() + 2;
    for _ in 0..limit {
        visit(r, c);
        if c == c_end && r == r_end {
            return;
        }
        if t_max_c < t_max_r {
            t_max_c += t_delta_c;
            c += step_c;
        } else {
            t_max_r += t_delta_r;
            r += step_r;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percents_are_the_rounded_probabilities() {
        let mut m = RobotMap::new(1, 2001, 1.0, MappingConfig::default(), &Default::default());
        for (k, l) in m.log_odds.iter_mut().enumerate() {
            *l = (k as f32 - 1000.0) / 100.0; // −10 … 10
        }
        for (k, p) in m.probabilities().iter().enumerate() {
            assert_eq!(
                m.percent(0, k),
                (p * 100.0).round() as i8,
                "log-odds {}",
                m.log_odds[k]
            );
        }
        assert_eq!(
            (m.percent(0, 0), m.percent(0, 1000), m.percent(0, 2000)),
            (0, 50, 100)
        );
    }

    fn map() -> RobotMap {
        // 4 m × 4 m at 0.1 m, 1 m cells.
        RobotMap::new(
            40,
            40,
            1.0,
            MappingConfig::default(),
            &DiscretizeParams::default(),
        )
    }

    #[test]
    fn floor_is_f64_floor() {
        for x in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999,
            -2.999,
            1e15 + 0.5,
            -1e15 - 0.5,
            1e300,
            -1e300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -1e-300,
            4503599627370497.0,
        ] {
            assert_eq!(floor(x), x.floor() as i64, "{x}");
        }
    }

    #[test]
    fn a_beam_frees_its_path_and_marks_its_end() {
        let mut m = map();
        for _ in 0..3 {
            m.integrate_beam(0.05, 0.05, 3.55, 0.05, true);
        }
        assert!((0..35).all(|c| m.observed(0, c) && !m.occupied(0, c)));
        assert!(m.occupied(0, 35));
        assert!(!m.observed(0, 36));
        assert!(!m.observed(1, 10));
    }

    #[test]
    fn each_beam_of_a_scan_is_a_measurement_of_its_own_but_a_return_is_not_freed_by_it() {
        let cfg = MappingConfig::default();
        let prob = |l: f64| 1.0 / (1.0 + (-l).exp());
        let close = |a: f64, b: f64| (a - b).abs() < 1e-6;
        // Three beams along row 0: one returns at pixel 35, one passes it to 39.
        let ends = [(3.55, 0.05, true), (3.95, 0.05, false), (2.05, 0.05, false)];
        let mut one = map();
        one.integrate_scan(0.05, 0.05, &ends);
        let p = one.probabilities();
        let three_misses = (3.0 * cfg.miss_log_odds).max(cfg.min_log_odds);
        assert!(close(p[10], prob(three_misses)), "{}", p[10]);
        // The beam that passed pixel 35 does not free what the other returned from.
        assert!(close(p[35], prob(cfg.hit_log_odds)), "{}", p[35]);
        assert!(close(p[38], prob(cfg.miss_log_odds)), "{}", p[38]);
        // As scans of their own, the passing beam does free it; elsewhere the same.
        let mut apart = map();
        for end in ends {
            apart.integrate_beam(0.05, 0.05, end.0, end.1, end.2);
        }
        let q = apart.probabilities();
        assert!(
            close(q[35], prob(cfg.hit_log_odds + cfg.miss_log_odds)),
            "{}",
            q[35]
        );
        assert!((0..40).filter(|&i| i != 35).all(|i| p[i] == q[i]));
        // The marks are cleared after the scan: the next scan frees pixel 35 again.
        one.integrate_scan(0.05, 0.05, &ends[1..2]);
        assert!(close(
            one.probabilities()[35],
            prob(cfg.hit_log_odds + cfg.miss_log_odds)
        ));
    }

    #[test]
    fn cells_become_free_then_obstacle_by_the_rule() {
        let mut m = map();
        // Sweep cell (0, 0) free: 100 pixels, all observed.
        for r in 0..10 {
            m.integrate_beam(
                0.0,
                r as f64 * 0.1 + 0.05,
                0.99,
                r as f64 * 0.1 + 0.05,
                false,
            );
        }
        let mut out = Vec::new();
        m.take_changes(&mut out);
        assert!(out.contains(&(Pos::new(0, 0), Occupancy::Free)), "{out:?}");
        // 26 occupied pixels (> 25 %) in cell (0, 0): an obstacle.
        for k in 0..26 {
            let (r, c) = (k / 10, k % 10);
            let (x, y) = (c as f64 * 0.1 + 0.05, r as f64 * 0.1 + 0.05);
            for _ in 0..2 {
                m.integrate_beam(x, y, x, y, true);
            }
        }
        out.clear();
        m.take_changes(&mut out);
        assert_eq!(out, vec![(Pos::new(0, 0), Occupancy::Obstacle)]);
        assert_eq!(m.coarse()[0], Occupancy::Obstacle);
    }

    #[test]
    fn disc_test_agrees_with_a_look_at_every_pixel() {
        let mut m = map();
        // A few occupied pixels scattered over the cells.
        for (x, y) in [
            (0.35, 0.45),
            (1.95, 2.05),
            (2.05, 2.05),
            (3.55, 0.15),
            (0.95, 3.95),
        ] {
            for _ in 0..2 {
                m.integrate_beam(x, y, x, y, true);
            }
        }
        // The map's edge (4 m square) counts as a wall.
        let brute = |x: f64, y: f64, radius: f64| {
            x.min(y).min(4.0 - x).min(4.0 - y) < radius
                || (0..40).any(|r| {
                    (0..40).any(|c| {
                        let nx = x.clamp(c as f64 * 0.1, (c + 1) as f64 * 0.1);
                        let ny = y.clamp(r as f64 * 0.1, (r + 1) as f64 * 0.1);
                        m.occupied(r, c) && (nx - x).powi(2) + (ny - y).powi(2) < radius * radius
                    })
                })
        };
        let mut hits = 0;
        for i in 0..80 {
            for j in 0..80 {
                let (x, y) = (i as f64 * 0.05 + 0.01, j as f64 * 0.05 + 0.02);
                for radius in [0.1, 0.3, 0.7] {
                    let want = brute(x, y, radius);
                    assert_eq!(
                        m.disc_hits_occupied(x, y, radius),
                        want,
                        "({x}, {y}) r {radius}"
                    );
                    hits += usize::from(want);
                }
            }
        }
        assert!(hits > 100, "{hits}");
    }

    #[test]
    fn the_inflated_map_answers_the_disc_test_at_every_pixel_centre() {
        let radius = 0.227;
        let mut m = map().with_inflation(radius);
        let check = |m: &RobotMap| {
            let mut blocked = 0;
            for r in 0..40 {
                for c in 0..40 {
                    let (x, y) = ((c as f64 + 0.5) * 0.1, (r as f64 + 0.5) * 0.1);
                    assert_eq!(
                        m.blocked(r, c),
                        m.disc_hits_occupied(x, y, radius),
                        "({r}, {c})"
                    );
                    blocked += usize::from(m.blocked(r, c));
                }
            }
            blocked
        };
        // Pixels turn occupied (one by the border), then one turns free again.
        for (x, y) in [(0.35, 0.45), (1.95, 2.05), (2.05, 2.05), (3.95, 0.15)] {
            for _ in 0..2 {
                m.integrate_beam(x, y, x, y, true);
            }
        }
        let before = check(&m);
        assert!(before > 30, "{before}");
        for _ in 0..6 {
            m.integrate_beam(2.05, 2.05, 2.25, 2.05, false);
        }
        assert!(!m.occupied(20, 20));
        let after = check(&m);
        assert!(after < before, "{after} vs {before}");
    }

    #[test]
    fn disc_test_sees_occupied_pixels_only_within_the_radius() {
        let mut m = map();
        for _ in 0..2 {
            m.integrate_beam(2.05, 2.05, 2.05, 2.05, true);
        }
        assert!(m.disc_hits_occupied(2.3, 2.05, 0.3));
        assert!(!m.disc_hits_occupied(2.5, 2.05, 0.3));
    }
}
