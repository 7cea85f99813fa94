//! What a DME-DRL actor sees: its own map as a short history of frames, and a pose vector.
//!
//! * A **frame** is 4 binary channels over the whole `H × W` map (the original feeds the whole
//!   own SLAM map, not a crop): known free, obstacle, the robot's own cell, its teammates' last
//!   known cells (the original draws every robot as a square of its own grey level).
//! * The **history** stacks the last `history` frames as channels, oldest first; at the start
//!   of an episode the first frame is repeated (as the original does).
//! * The **pose vector** has one (row, col) slot per robot, in robot order, normalised by
//!   (H − 1, W − 1): the robot's own position and its teammates' last known positions (from
//!   detection or exchanged messages), −1 for a teammate never heard of or seen.

use madenet_agent::AgentView;
use madenet_map::{Occupancy, Pos};
use std::collections::VecDeque;

/// Channels of one frame.
pub const FRAME_CHANNELS: usize = 4;

/// One frame of robot `view.id`'s map, channel-major `[4][H][W]`, 0/1.
pub fn frame(view: &AgentView<'_>) -> Vec<u8> {
    let b = view.belief;
    let n = b.width() * b.height();
    let mut img = vec![0u8; FRAME_CHANNELS * n];
    for (i, &o) in b.map().iter().enumerate() {
        img[i] = (o == Occupancy::Free) as u8;
        img[n + i] = (o == Occupancy::Obstacle) as u8;
    }
    img[2 * n + b.index(view.pos)] = 1;
    for (j, rec) in view.teammates.iter().enumerate() {
        if let (false, Some(p)) = (j == view.id, rec.last_pos()) {
            img[3 * n + b.index(p)] = 1;
        }
    }
    img
}

/// The pose vector, `2 · team` values.
pub fn pose_vector(view: &AgentView<'_>) -> Vec<f32> {
    let coords = |p: Option<Pos>| view.normalized(p);
    view.teammates
        .iter()
        .enumerate()
        .flat_map(|(j, rec)| {
            coords(if j == view.id {
                Some(view.pos)
            } else {
                rec.last_pos()
            })
        })
        .collect()
}

/// The last `len` frames of one robot.
#[derive(Clone, Debug)]
pub struct History {
    len: usize,
    frames: VecDeque<Vec<u8>>,
}

impl History {
    /// An empty history of `len` frames (at least 1); the first [`push`](Self::push) fills it.
    pub fn new(len: usize) -> Self {
        History {
            len: len.max(1),
            frames: VecDeque::new(),
        }
    }

    /// Adds the newest frame (the first one fills the whole history).
    pub fn push(&mut self, frame: Vec<u8>) {
        if self.frames.is_empty() {
            self.frames.extend(std::iter::repeat_n(frame, self.len));
        } else {
            self.frames.pop_front();
            self.frames.push_back(frame);
        }
    }

    /// The stacked input `[history · 4][H][W]` as `f32`, oldest frame first.
    pub fn stacked(&self) -> Vec<f32> {
        self.frames
            .iter()
            .flat_map(|f| f.iter().map(|&v| f32::from(v)))
            .collect()
    }
}

/// Index of the frame at history slot `k` (0 = oldest) for step `t`: `t − (len − 1 − k)`,
/// clamped at the episode's first step — the replay rebuilds [`History::stacked`] with it.
pub fn history_step(t: usize, len: usize, k: usize) -> usize {
    t.saturating_sub(len - 1 - k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn history_repeats_the_first_frame_then_slides() {
        let mut h = History::new(3);
        h.push(vec![1]);
        assert_eq!(h.stacked(), vec![1.0, 1.0, 1.0]);
        h.push(vec![0]);
        assert_eq!(h.stacked(), vec![1.0, 1.0, 0.0]);
        h.push(vec![1]);
        h.push(vec![0]);
        assert_eq!(h.stacked(), vec![0.0, 1.0, 0.0]);
        // The replay's reconstruction agrees: at step 1 of an episode slots are steps 0, 0, 1.
        assert_eq!(
            (0..3).map(|k| history_step(1, 3, k)).collect::<Vec<_>>(),
            vec![0, 0, 1]
        );
        assert_eq!(
            (0..3).map(|k| history_step(3, 3, k)).collect::<Vec<_>>(),
            vec![1, 2, 3]
        );
    }
}
