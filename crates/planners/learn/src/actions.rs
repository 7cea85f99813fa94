//! Action selection over Q values: masked argmax/max (invalid goal candidates are never chosen,
//! in acting and in targets), the CEP's joint action index, and the conditional argmax of
//! Eq. (5)/(6) that keeps robots whose macro action is still running fixed to that action.
//!
//! # Joint action index
//!
//! A joint action `(a_0, …, a_{n−1})` of `n` robots with `|G|` candidates each is the base-`|G|`
//! number with **robot 0 as the least significant digit** ([`madenet_agent::joint_encode`], the
//! one order of the learner, the environments and Python's `CentralizedEnv`):
//! `index = Σ_i a_i · |G|^i`, so with 3 robots and 4 candidates `(1, 2, 3)` ↦ 1 + 8 + 48 = 57
//! and robot 0's action varies fastest along the CEP's F6 outputs.

use burn::tensor::{Bool, Int, Tensor, TensorData};

/// The value masked-out Q entries get in [`masked_max`]: finite so that a target that is later
/// multiplied by a zero "not done" factor stays 0 instead of NaN.
pub const INVALID_Q: f32 = -1.0e9;

fn host_f32(q: Tensor<2>) -> (usize, usize, Vec<f32>) {
    let [b, n] = q.dims();
    let v = q
        .into_data()
        .try_into_vec_as::<f32>()
        .expect("Q values readable as f32");
    (b, n, v)
}

fn host_bool(mask: Tensor<2, Bool>) -> Vec<bool> {
    mask.into_data().iter::<bool>().collect()
}

/// Index of the largest `q[k]` with `valid[k]`, ties to the lowest index; NaN entries are never
/// chosen; `None` if no entry is valid (or all valid ones are NaN).
pub fn masked_argmax_slice(q: &[f32], valid: &[bool]) -> Option<usize> {
    assert_eq!(q.len(), valid.len(), "q and mask lengths differ");
    let mut best: Option<(usize, f32)> = None;
    for (k, (&v, &ok)) in q.iter().zip(valid).enumerate() {
        if ok && !v.is_nan() && best.is_none_or(|(_, b)| v > b) {
            best = Some((k, v));
        }
    }
    best.map(|(k, _)| k)
}

/// Per row of `q` `[batch, outputs]`, the best valid action, or `None` for a row with no valid
/// action.
pub fn try_masked_argmax(q: Tensor<2>, valid: Tensor<2, Bool>) -> Vec<Option<usize>> {
    assert_eq!(q.dims(), valid.dims(), "q and mask shapes differ");
    let (b, n, qv) = host_f32(q);
    let mv = host_bool(valid);
    (0..b)
        .map(|r| masked_argmax_slice(&qv[r * n..(r + 1) * n], &mv[r * n..(r + 1) * n]))
        .collect()
}

/// Per row of `q` `[batch, outputs]`, the index of the largest Q among the valid actions
/// (`valid` `[batch, outputs]`, `true` = may be chosen); ties go to the lowest index.
///
/// # Panics
/// If a row has no valid action: asking for an action then is the caller's bug (use
/// [`try_masked_argmax`] where it can happen).
pub fn masked_argmax(q: Tensor<2>, valid: Tensor<2, Bool>) -> Vec<usize> {
    try_masked_argmax(q, valid)
        .into_iter()
        .enumerate()
        .map(|(r, a)| a.unwrap_or_else(|| panic!("row {r} has no valid action")))
        .collect()
}

/// Per row, the largest Q among the valid actions, `[batch]`, computed on the device (for
/// targets). A row with no valid action gives [`INVALID_Q`].
pub fn masked_max(q: Tensor<2>, valid: Tensor<2, Bool>) -> Tensor<1> {
    let [b, _] = q.dims();
    q.mask_fill(valid.bool_not(), INVALID_Q)
        .max_dim(1)
        .reshape([b])
}

/// `q[r, actions[r]]` for each row, `[batch]`, keeping the autodiff graph (for `Q(δ, m)` in the
/// loss and `Q'(δ', a*)` in the target).
pub fn gather_q(q: Tensor<2>, actions: &[usize]) -> Tensor<1> {
    let [b, n] = q.dims();
    assert_eq!(actions.len(), b, "one action per row");
    assert!(actions.iter().all(|&a| a < n), "action index out of range");
    let idx: Vec<i64> = actions.iter().map(|&a| a as i64).collect();
    let idx = Tensor::<2, Int>::from_data(TensorData::new(idx, [b, 1]), &q.device());
    q.gather(1, idx).reshape([b])
}

/// A `[rows, cols]` boolean mask tensor from row-major host data.
pub fn mask_tensor(
    valid: &[bool],
    rows: usize,
    cols: usize,
    device: &burn::tensor::Device,
) -> Tensor<2, Bool> {
    assert_eq!(valid.len(), rows * cols, "mask length is rows · cols");
    Tensor::from_data(TensorData::new(valid.to_vec(), [rows, cols]), device)
}

/// The joint action index of per-robot actions: [`madenet_agent::joint_encode`], a = Σ k_i·|G|^i
/// (robot 0 the least significant digit; one order for the learner, the environments and Python).
///
/// # Panics
/// If an action is ≥ `goals`.
pub fn joint_index(actions: &[usize], goals: usize) -> usize {
    assert!(
        actions.iter().all(|&a| a < goals),
        "robot action out of range for {goals} candidates"
    );
    madenet_agent::joint_encode(actions, goals)
}

/// The per-robot actions of joint action `index` for `team` robots (inverse of [`joint_index`]).
///
/// # Panics
/// If `index` is out of range.
pub fn joint_actions(index: usize, team: usize, goals: usize) -> Vec<usize> {
    assert!(
        index < crate::joint_action_count(team, goals),
        "joint index {index} out of range"
    );
    madenet_agent::joint_decode(index, team, goals)
}

/// The joint validity mask (length `goals^team`, in joint-index order) from each robot's
/// candidate mask: a joint action is valid iff every robot's action is valid for it.
pub fn joint_valid_mask<M: AsRef<[bool]>>(per_robot: &[M]) -> Vec<bool> {
    let fixed = vec![None; per_robot.len()];
    conditional_joint_mask(per_robot, &fixed)
}

/// The joint mask of the conditional argmax: robot `i` with `fixed[i] = Some(a)` (its macro
/// action is still running) must take `a` — whatever its current candidate mask says, since the
/// action it is executing is not re-chosen — and every other robot must take a valid candidate.
///
/// # Panics
/// If `per_robot` and `fixed` differ in length, the robots' masks differ in length, or a fixed
/// action is out of range.
pub fn conditional_joint_mask<M: AsRef<[bool]>>(
    per_robot: &[M],
    fixed: &[Option<usize>],
) -> Vec<bool> {
    assert_eq!(per_robot.len(), fixed.len(), "one fixed entry per robot");
    let team = per_robot.len();
    let goals = per_robot.first().map_or(0, |m| m.as_ref().len());
    assert!(
        per_robot.iter().all(|m| m.as_ref().len() == goals),
        "every robot has |G| mask entries"
    );
    // Allowed actions per robot.
    let allowed: Vec<Vec<bool>> = per_robot
        .iter()
        .zip(fixed)
        .map(|(m, f)| match f {
            Some(a) => {
                assert!(*a < goals, "fixed action {a} out of range");
                (0..goals).map(|k| k == *a).collect()
            }
            None => m.as_ref().to_vec(),
        })
        .collect();
    let count = crate::joint_action_count(team, goals);
    let mut mask = vec![true; count];
    for (index, ok) in mask.iter_mut().enumerate() {
        // Decode without allocating: robot 0 is the least significant digit.
        let mut rest = index;
        for robot_allowed in &allowed {
            if !robot_allowed[rest % goals] {
                *ok = false;
                break;
            }
            rest /= goals;
        }
    }
    mask
}

/// The conditional argmax over one row of CEP Q values `q` (`goals^team` entries): the best
/// joint action consistent with the robots whose action is `fixed` and valid for the others;
/// `None` if there is none.
pub fn conditional_argmax<M: AsRef<[bool]>>(
    q: &[f32],
    per_robot: &[M],
    fixed: &[Option<usize>],
) -> Option<usize> {
    masked_argmax_slice(q, &conditional_joint_mask(per_robot, fixed))
}

/// [`conditional_argmax`] for a batch: `q` `[batch, goals^team]`, and per row the robots' masks
/// and fixed actions.
///
/// # Panics
/// If a row has no admissible joint action.
pub fn conditional_argmax_batch<M: AsRef<[bool]>>(
    q: Tensor<2>,
    per_robot: &[Vec<M>],
    fixed: &[Vec<Option<usize>>],
) -> Vec<usize> {
    let [b, n] = q.dims();
    assert_eq!(per_robot.len(), b, "one mask set per row");
    assert_eq!(fixed.len(), b, "one fixed set per row");
    let (_, _, qv) = host_f32(q);
    (0..b)
        .map(|r| {
            let mask = conditional_joint_mask(&per_robot[r], &fixed[r]);
            assert_eq!(mask.len(), n, "joint mask length differs from Q outputs");
            masked_argmax_slice(&qv[r * n..(r + 1) * n], &mask)
                .unwrap_or_else(|| panic!("row {r} has no admissible joint action"))
        })
        .collect()
}
